"""The live viewer: meshcat's server (a subprocess bound to 127.0.0.1) and a control page served next to it.

The server is started only here and stopped by :meth:`LiveViewer.close` — called on exit, on Ctrl-C and
on an exception by ``with`` blocks and the CLI, at interpreter exit otherwise; on Linux the server also
dies with the process that started it (``PR_SET_PDEATHSIG``), so a killed parent leaves no orphan.
Never ``Visualizer.wait()``: it blocks later commands in meshcat 0.3.2.
"""

import atexit
import http.server
import json
import os
import signal
import subprocess
import sys
import threading
import time
import urllib.parse
import webbrowser
from pathlib import Path

from ...errors import ModelError
from .page import live_page

START_TIMEOUT = 30.0  # s to wait for the server's URLs
REPLY_TIMEOUT_MS = 20000  # a command the server does not acknowledge in this time is an error


def _die_with_parent():  # runs in the child between fork and exec
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the parent's close() and atexit stop it
        pass


def start_server():
    """Start meshcat's server on 127.0.0.1: (process, zmq_url, web_url)."""
    script = Path(__file__).with_name("_server.py")
    env = dict(os.environ)
    kwargs = {"preexec_fn": _die_with_parent} if sys.platform.startswith("linux") else {}
    proc = subprocess.Popen([sys.executable, "-u", str(script)], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, env=env, start_new_session=True, **kwargs)
    urls = {}
    deadline = time.monotonic() + START_TIMEOUT
    try:
        while len(urls) < 2:
            line = proc.stdout.readline().decode("utf-8", "replace").strip()
            if not line and proc.poll() is not None:
                raise ModelError(f"the meshcat server exited with code {proc.returncode} before it started")
            if "=" in line:
                k, v = line.split("=", 1)
                if k in ("zmq_url", "web_url"):
                    urls[k] = v
            if time.monotonic() > deadline:
                raise ModelError("the meshcat server did not start in time")
    except BaseException:
        stop_server(proc)
        raise
    threading.Thread(target=_drain, args=(proc.stdout,), daemon=True).start()
    return proc, urls["zmq_url"], urls["web_url"]


def _drain(stream):
    try:
        for _ in iter(stream.readline, b""):
            pass
    except (OSError, ValueError):
        pass


def stop_server(proc):
    """Stop the server process (terminate, then kill) and reap it."""
    if proc is None or proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(timeout=3)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


class LiveViewer:
    """A running viewer: ``url`` (the control page: modes, amplitude, pause, meshcat's view),
    ``meshcat_url`` (meshcat's own page), ``show(k)``, ``close()``. A context manager; in Jupyter it
    displays itself inline."""

    def __init__(self, content, amplitude=None, mode=1, open_browser=False):
        import umsgpack
        import zmq

        self.content = content
        self.amplitude = amplitude
        self.current = 0
        self.playing = True
        self._started = time.monotonic()
        self._lock = threading.Lock()
        self._umsgpack = umsgpack
        self._http = None
        self._socket = None
        self.process, self.zmq_url, self.meshcat_url = start_server()
        try:
            self._context = zmq.Context.instance()
            self._socket = self._context.socket(zmq.REQ)
            self._socket.setsockopt(zmq.RCVTIMEO, REPLY_TIMEOUT_MS)
            self._socket.setsockopt(zmq.SNDTIMEO, REPLY_TIMEOUT_MS)
            self._socket.setsockopt(zmq.LINGER, 0)
            self._socket.connect(self.zmq_url)
            for cmd in content.scene_commands():
                self._send(cmd)
            self.show(int(mode) - 1)
            self._http = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _handler(self))
            self._http.daemon_threads = True
            threading.Thread(target=self._http.serve_forever, daemon=True).start()
            self.url = f"http://127.0.0.1:{self._http.server_address[1]}/"
        except BaseException:
            self.close()
            raise
        atexit.register(self.close)
        if open_browser:
            open_in_browser(self.url)

    # ------------------------------------------------------------ commands
    def _send(self, cmd):
        import zmq

        data = self._umsgpack.packb(_ext(cmd, self._umsgpack))
        with self._lock:
            try:
                self._socket.send_multipart([cmd["type"].encode(), cmd.get("path", "").encode(), data])
                self._socket.recv()
            except zmq.ZMQError as e:
                raise ModelError(f"the meshcat server does not answer ({e})") from None

    def show(self, k, amplitude=None):
        """Animate motion k (0-based: a mode, or the trajectory first when there is one)."""
        if not 0 <= k < self.content.n:
            raise ModelError(f"no motion {k + 1}: choose 1 to {self.content.n}")
        amplitude = self.amplitude if amplitude is None else amplitude
        anim = self.content.animation(k, amplitude)  # a bad amplitude is refused here: the state keeps its own
        self.amplitude = amplitude
        self._send({"type": "set_animation", "path": "", "animations": anim,
                    "options": {"play": True, "repetitions": 1_000_000_000}})
        self.current, self.playing, self._started = k, True, time.monotonic()
        return self.state()

    def toggle(self):
        """Pause (on the motion's first frame) or play again."""
        anim = self.content.animation(self.current, self.amplitude)
        self.playing, self._started = not self.playing, time.monotonic()
        self._send({"type": "set_animation", "path": "", "animations": anim,
                    "options": {"play": self.playing, "repetitions": 1_000_000_000}})
        if not self.playing:  # a stopped animation leaves the nodes where they were: put them on frame 0
            for clip in anim:
                for track in clip["clip"]["tracks"]:
                    n = 4 if track["type"] == "quaternion" else 3
                    self._send({"type": "set_property", "path": clip["path"], "property": track["name"][1:],
                                "value": track["values"][:n]})
        return self.state()

    def state(self):
        """What the page shows: current motion, playing, amplitude, and ``t`` (s) of a replayed trajectory."""
        out = {"current": self.current, "playing": self.playing, "amplitude": self.amplitude,
               "motions": self.content.n}
        traj = self.content.trajectory
        if traj is not None and self.current == 0:
            shown = (traj[0][-1] - traj[0][0]) / self.content.speed
            elapsed = (time.monotonic() - self._started) % shown if self.playing and shown > 0 else 0.0
            out["t"] = float(traj[0][0] + elapsed * self.content.speed)
        return out

    def page(self):
        c = self.content
        return live_page(c.title, c.subtitle, c.motions(self.amplitude), self.meshcat_url, self.current)

    # ------------------------------------------------------------ life
    def close(self):
        """Stop the control page and meshcat's server (idempotent)."""
        if self._http is not None:
            self._http.shutdown()
            self._http.server_close()
            self._http = None
        if self._socket is not None:
            self._socket.close(linger=0)
            self._socket = None
        stop_server(getattr(self, "process", None))
        atexit.unregister(self.close)

    @property
    def running(self):
        return self.process is not None and self.process.poll() is None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _repr_html_(self):
        return (f'<div style="height: 520px; width: 100%; resize: both; overflow: hidden">'
                f'<iframe src="{self.url}" style="width: 100%; height: 100%; border: none"></iframe></div>')

    def __repr__(self):
        return f"LiveViewer({self.url!r}, meshcat {self.meshcat_url!r}, {'running' if self.running else 'closed'})"


def open_in_browser(url):
    """Open url in the user's graphical browser; False when there is none (then print the URL instead).
    Without a display, Python's webbrowser would fall back on a text browser taking over the terminal."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    try:
        return bool(webbrowser.open(url, new=2))
    except webbrowser.Error:
        return False


def _ext(obj, umsgpack):
    """Binary mesh data as meshcat's Uint8Array extension (msgpack ext 0x12)."""
    if isinstance(obj, (bytes, bytearray)):
        return umsgpack.Ext(0x12, bytes(obj))
    if isinstance(obj, dict):
        return {k: _ext(v, umsgpack) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_ext(v, umsgpack) for v in obj]
    return obj


def _handler(viewer):
    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):  # noqa: N802 (http.server's name)
            url = urllib.parse.urlparse(self.path)
            args = dict(urllib.parse.parse_qsl(url.query))
            try:
                if url.path == "/":
                    return self._reply(viewer.page().encode(), "text/html; charset=utf-8")
                if url.path == "/show":
                    amp = args.get("amplitude")
                    state = viewer.show(int(args.get("n", 0)), float(amp) if amp else None)
                elif url.path == "/toggle":
                    state = viewer.toggle()
                elif url.path == "/state":
                    state = viewer.state()
                else:
                    return self.send_error(404)
            except (ModelError, ValueError) as e:
                return self._reply(json.dumps({"error": str(e)}).encode(), "application/json", 400)
            self._reply(json.dumps(state).encode(), "application/json")

        def _reply(self, body, kind, code=200):
            self.send_response(code)
            self.send_header("Content-Type", kind)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):  # quiet
            pass

    return Handler
