"""``vibdyn simulate``: run a simulation from the command line, print its summary, write its trajectory."""

import sys
from pathlib import Path

import numpy as np

from .._format import number, table
from ..errors import ModelError
from ..simulation.simulate import SimulationError, simulate


def command(system, args, out=None):
    """``vibdyn simulate``: run, print a summary, write ``--out`` (.npz or .csv) — the partial trajectory
    too if the run fails (the error is then raised for the command's exit status)."""
    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    if args.out is not None and Path(args.out).suffix.lower() not in (".npz", ".csv"):
        raise ModelError(f"--out {args.out}: the file must end in .npz or .csv")
    if args.out is not None and not Path(args.out).parent.is_dir():  # found before the run, not after it
        raise ModelError(f"--out {args.out}: no such directory '{Path(args.out).parent}'")
    if args.samples is not None and args.samples < 2:
        raise ModelError(f"--samples must be at least 2 (the start and the end), got {args.samples}")
    origin = system.start_configuration()[0] if system.constraints is not None else system.neutral()
    q0 = None if args.offset is None else system.integrate(origin, system.check_velocity(args.offset, "--offset"))
    v0 = None if args.v0 is None else system.check_velocity(args.v0, "--v0")
    t_eval = None if args.samples is None else np.linspace(0.0, args.t_end, args.samples) if args.t_end > 0 else None
    try:
        traj = simulate(system, args.t_end, q0, v0, args.method, args.rtol, args.atol, args.dt, t_eval,
                        error_method=args.error, progress=False if args.no_progress else None)
        failure = None
    except SimulationError as e:
        traj, failure = e.trajectory, e
    p(f"scene      {system.name} (nq = {system.nq}, nv = {system.nv})")
    p(f"run        {traj.summary()}")
    if len(traj):
        dq = system.difference(system.neutral(), traj.q[-1])
        qe, ve = traj.q_error[-1], traj.v_error[-1]  # values below the run's error estimate print as 0
        rows = [[c, number(x, u, qe), number(y, f"{u}/s", ve)]
                for c, u, x, y in zip(system.coordinates, system.units, dq, traj.v[-1])]
        p(f"final      t = {number(traj.t[-1], 's')} (offsets from neutral; error ≈ {qe:.1e} in q, {ve:.1e} in v)")
        for line in table(["coordinate", "offset", "velocity"], rows, ["<", ">", ">"]):
            p("  " + line)
        de = abs(traj.drift)  # the energy balance: the run's error estimate on energies
        p(f"energy     {number(traj.energy[0], 'J', de)} → {number(traj.energy[-1], 'J', de)}, work of "
          f"non-conservative forces {number(traj.work[-1], 'J', de)}, balance {traj.drift:.2e} J")
    if args.out is not None:
        try:
            path = traj.to_npz(args.out) if Path(args.out).suffix.lower() == ".npz" else traj.to_csv(args.out)
        except OSError as e:
            raise ModelError(f"--out {args.out}: cannot write: {e.strerror or e}") from None
        p(f"written    {path} ({len(traj)} rows)")
    if failure is not None:
        raise failure
    return traj

