"""Layer 3, analyses: functions and small classes that take a System and return frozen results.

equilibrium, linearize (LinearModel), modal (Modes), response (FRF, harmonic, base, transient, ...),
statespace, identify, constrained (equilibria and linear models of closed loops), campbell_diagram.
"""
