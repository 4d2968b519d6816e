"""Layer 2, solvers: the one kit of iterative methods the analyses share — Newton on a manifold
(:mod:`.newton`), pseudo-arclength continuation with folds (:mod:`.continuation`), mode tracking by MAC
(:mod:`.tracking`), a bracketed root with its error (:mod:`.roots`), difference quotients (:mod:`.differences`,
the package's one kit of them). Numpy and scipy only: no scene, no system."""
