"""``vibdyn view SCENE [--mode N] [--amplitude A] [--trajectory traj.npz] [--speed S] [--html out.html]
[--no-browser] [--duration S]``."""

import signal
import sys
import time


def command(scene, args, out=None):
    """Write the offline page (``--html``), or run the live viewer until Ctrl-C, SIGTERM or ``--duration``."""
    from . import content, export_html

    out = out or sys.stdout
    system = scene.build()
    if args.html:
        start = time.perf_counter()
        path = export_html(system, args.html, amplitude=args.amplitude, trajectory=args.trajectory,
                           speed=args.speed, mode=args.mode)
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB, {time.perf_counter() - start:.2f} s); "
              "open it in any browser (no network needed)", file=out)
        return
    from .live import LiveViewer, open_in_browser

    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        # Ctrl-C anywhere from the start (even just after the URL is printed, as a script may do) stops the
        # viewer cleanly: the with-block's exit stops the server, then "stopped" and exit status 0
        with LiveViewer(content(system, args.trajectory, args.speed), amplitude=args.amplitude,
                        mode=args.mode) as viewer:
            print(f"viewer: {viewer.url}  (meshcat: {viewer.meshcat_url}); Ctrl-C stops it", file=out, flush=True)
            if not args.no_browser and not open_in_browser(viewer.url):
                print("no graphical browser here: open the URL above in one", file=out, flush=True)
            deadline = None if args.duration is None else time.monotonic() + args.duration
            while viewer.running and (deadline is None or time.monotonic() < deadline):
                time.sleep(0.1)
    except KeyboardInterrupt:
        print("stopped", file=out)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _interrupt(signum, frame):
    raise KeyboardInterrupt
