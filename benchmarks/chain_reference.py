"""The pendulum chains' natural frequencies in 40-digit arithmetic, the linearisation benchmarks' reference.

The exact M and K of :func:`benchmarks.linearization.exact_chain` (its float inputs taken exactly) are
formed in mpmath, M = LLᵀ, and the eigenvalues of L⁻¹ K L⁻ᵀ solved there: in double precision that solve's
own round-off grows with the chain (2.6e-9 at n = 100), as large as the errors it should measure. Writes
``benchmarks/data/chain_omega.json`` (ω in rad/s, 25 significant digits); needs mpmath, which vibdyn does not
(``pip install mpmath``; n = 300 takes some minutes)::

    python -m benchmarks.chain_reference 10 30 100 300
"""

import json
import sys

from .linearization import REFERENCE, exact_chain

DIGITS = 40


def omega(n):
    """The n natural frequencies of the chain (mpmath numbers, rad/s, ascending)."""
    import mpmath as mp

    mp.mp.dps = DIGITS
    M, K = exact_chain(n, number=mp.mpf)
    L = mp.cholesky(mp.matrix(M.tolist()))
    Linv = mp.inverse(L)
    return [mp.sqrt(e) for e in sorted(mp.eigsy(Linv * mp.matrix(K.tolist()) * Linv.T, eigvals_only=True))]


def main(argv):
    import mpmath as mp

    stored = json.loads(REFERENCE.read_text()) if REFERENCE.exists() else {"omega": {}}
    for n in [int(a) for a in argv] or [10, 30, 100]:
        stored["omega"][str(n)] = [mp.nstr(w, 25) for w in omega(n)]
        print(f"n = {n}: ω from {stored['omega'][str(n)][0]} to {stored['omega'][str(n)][-1]} rad/s")
    stored["digits"] = DIGITS
    stored["how"] = "python -m benchmarks.chain_reference (mpmath, 40 digits): Cholesky of M, eigsy of L⁻¹KL⁻ᵀ"
    REFERENCE.parent.mkdir(exist_ok=True)
    REFERENCE.write_text(json.dumps(stored, indent=1, sort_keys=True, ensure_ascii=False) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
