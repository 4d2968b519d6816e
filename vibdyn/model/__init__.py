"""Layer 2, model: a scene compiled once into a System that computes.

system (System: the immutable compiled model and its checked entry points), workspace (per-thread scratch:
Pinocchio Data and force buffers), dynamics (free functions over (system, workspace) in the manner of
``pin.aba(model, data, ...)``), forces (force-element groups), derivatives (their analytic derivatives), fd
(finite-difference primitives in the tangent space), constraints (compiled loop equations), forcing (what
makes a scene non-autonomous and its common period).
"""
