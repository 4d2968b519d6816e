"""Time integrators behind :func:`vibdyn.simulate.simulate`: the chart ODE (:mod:`.chart`), explicit
Runge–Kutta (:mod:`.explicit`), scipy's implicit solvers (:mod:`.implicit`) and the variational integrator
(:mod:`.variational`)."""
