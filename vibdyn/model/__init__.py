"""Layer 2, model: a scene compiled once into a System that computes.

system (System: the immutable compiled model and its checked entry points, forwarding to the others),
compile (the build: Pinocchio model, body infos, scales, force groups), configuration (configurations, limits,
checked states), inertia_check (the mass-matrix policy), workspace (per-thread scratch: Pinocchio Data and
force buffers), dynamics and geometry (free functions over (system, workspace) in the manner of
``pin.aba(model, data, ...)``), forces (force-element groups), derivatives (their analytic derivatives), fd
(finite-difference primitives in the tangent space), constraints (compiled loop equations), forcing (what
makes a scene non-autonomous and its common period).
"""
