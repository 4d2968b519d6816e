"""Layer 4, time: nonlinear time simulation (simulate, Trajectory) and its integrators."""
