"""Layer 1, description: what a user writes. Plain data, checked on entry, no computing.

scene (Scene, Body), joints (Pivot, Slider, Helical, Ball, ...), elements (Spring, Damper, JointSpring, ...),
inertia (solids' inertia tensors), laws (time and state laws), shapes (viewer geometry), loops (loop closures).
"""
