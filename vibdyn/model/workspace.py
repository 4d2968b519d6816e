"""Workspaces: the mutable scratch a System computes in, one per caller or thread, never shared behind a
caller's back (the System itself is immutable after ``build()``, like Pinocchio's Model against its Data).
No computation reads what another left in a workspace: each reads only what its own pass wrote, before any
user callable runs (tests/test_thin_system.py), so a force law may ask its System for a pose or a reaction.
"""

import os
import threading

import numpy as np
import pinocchio as pin

from ..errors import ModelError


class Workspace:
    """Pinocchio Data of one model and the external-force buffer handed to ABA/RNEA (one ``pin.Force`` per
    joint), with live numpy views, one per joint, of the Data's joint poses (``rotations``, ``translations``)
    and velocities (``linear``, ``angular``, local axes), which every forward kinematics updates in place,
    and of the forces (``forces``: writing one writes its ``pin.Force``), and the finite-difference stencils
    made for it (``stencils``). Results of
    :mod:`vibdyn.model.dynamics` may share memory with it: copy what you keep."""

    __slots__ = ("data", "fext", "rotations", "translations", "linear", "angular", "forces", "stencils")

    def __init__(self, model: pin.Model):
        self.data = data = create_data(model)
        self.fext = pin.StdVec_Force()
        for _ in range(model.njoints):
            self.fext.append(pin.Force.Zero())
        joints = range(model.njoints)
        self.rotations = [data.oMi[j].rotation for j in joints]
        self.translations = [data.oMi[j].translation for j in joints]
        self.linear = [data.v[j].linear for j in joints]
        self.angular = [data.v[j].angular for j in joints]
        self.forces = [self.fext[j].vector for j in joints]
        self.stencils: dict = {}  # finite-difference stencils by steps (vibdyn.model.fd.stencil)
        check_views(model, self)


def check_views(model, ws):
    """The views must be live (Pinocchio 4.1's bindings return references into its Data and Force objects):
    a binding that hands out copies would leave them stale and every point force silently wrong, so that is
    refused here, once per workspace."""
    if model.njoints < 2:
        return
    q = pin.integrate(model, pin.neutral(model), np.full(model.nv, 0.3))
    pin.forwardKinematics(model, ws.data, q, np.full(model.nv, 0.7))
    live = all(np.array_equal(ws.rotations[j], ws.data.oMi[j].rotation)
               and np.array_equal(ws.translations[j], ws.data.oMi[j].translation)
               and np.array_equal(ws.linear[j], ws.data.v[j].linear) for j in range(1, model.njoints))
    ws.forces[1][:] = 1.0
    live = live and np.array_equal(ws.fext[1].linear, np.ones(3))
    ws.forces[1][:] = 0.0
    if not live:
        raise ModelError(f"Pinocchio {pin.__version__} returns copies of its Data's poses and velocities, not "
                         "references: vibdyn needs a Pinocchio whose bindings return references (4.1 does)")


class PerThread(threading.local):
    """One lazily created Workspace per thread (``threading.local``): what a System's methods use."""

    workspace = None


def create_data(model):
    """Pinocchio's Data, refused with a clear error where it cannot fit: Pinocchio 4.1 allocates and fills
    four nv×nv×nv tensors in every Data (32·nv³ bytes; upstream issue stack-of-tasks/pinocchio#2949)."""
    need = 2 * 32.0 * model.nv**3  # createData's peak: the tensors are built, then copied into Data
    free = available_memory()
    message = (f"scene '{model.name}' has nv = {model.nv} coordinates: Pinocchio {pin.__version__} allocates "
               f"{need / 2e9:.3g} GB of second-order-derivative tensors in every Data (32·nv³ bytes, "
               f"stack-of-tasks/pinocchio#2949) and peaks at twice that while building it, more than this "
               f"machine or container has free ({free / 1e9:.3g} GB)")
    if need > 0.8 * free:
        raise ModelError(message)
    try:
        return model.createData()
    except MemoryError:
        raise ModelError(message) from None


def available_memory():
    """Bytes this process can still allocate: the host's available pages, and the cgroup's limit minus its
    usage where there is one (a container sees the host's free memory, not its own limit)."""
    try:
        free = float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        free = float("inf")
    for limit_file, usage_file in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                                   ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                                    "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        try:
            with open(limit_file) as f:
                limit = f.read().strip()
            with open(usage_file) as f:
                usage = float(f.read().strip())
        except (OSError, ValueError):
            continue
        if limit.isdigit() and float(limit) < 2**60:
            free = min(free, float(limit) - usage)
        break
    return max(free, 0.0)
