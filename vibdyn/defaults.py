"""Shared numerical defaults: tolerances and steps used by several layers, defined once."""

import numpy as np

#: machine epsilon of float64
EPS = float(np.finfo(float).eps)
#: default finite-difference step in the tangent space (relative to each coordinate's scale)
FD_STEP = 1e-5
#: default Newton tolerance of equilibrium searches (residual relative to the force scale)
EQUILIBRIUM_TOL = 1e-10
#: default iteration cap of equilibrium searches
MAX_ITER = 100
#: default relative tolerance of adaptive time integration
RTOL = 1e-8

#: relative tolerance of rank decisions: singular values below RANK_RTOL × the largest are zero. Far above
#: the round-off of a Jacobian (~1e-15 relative) and below any physical near-singularity an analysis uses.
RANK_RTOL = 1e-9
#: assembly tolerance: dimensionless residual (positions / length scale, angles in rad)
ASSEMBLY_TOL = 1e-12
#: rpm per rad/s (30/π): speeds shown in rpm
RPM = 30.0 / np.pi
