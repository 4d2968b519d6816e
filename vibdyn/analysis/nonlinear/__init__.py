"""Nonlinear vibrations: periodic orbits and their Floquet multipliers (:mod:`.periodic`, shooting on the
configuration Lie group in :mod:`.shooting`), backbones of nonlinear normal modes and forced-response curves by
harmonic balance."""
