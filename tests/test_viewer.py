"""The viewer without a browser: imports stay lazy, shapes are checked, animations are the modes they claim
(amplitude, phase, stretching springs), every bundled model and a robot export, pictures are drawn, and the
live server leaves no process behind (normal exit, Ctrl-C, exception)."""

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import vibdyn as vd
from vibdyn.faces import cli
from vibdyn.faces.viewer import content, motion
from vibdyn.faces.viewer.drawing import ROOT

ROOT_DIR = Path(__file__).resolve().parents[1]
MODELS = ROOT_DIR / "models"
TAG = str(os.getpid())
os.environ["VIBDYN_TEST_TAG"] = TAG  # inherited by every server this test process starts
ENV = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}


def test_import_vibdyn_imports_neither_meshcat_nor_matplotlib():
    code = ("import sys, vibdyn, vibdyn.faces.viewer; "
            "assert 'meshcat' not in sys.modules and 'matplotlib' not in sys.modules, "
            "[m for m in sys.modules if m.startswith(('meshcat', 'matplotlib'))]")
    subprocess.run([sys.executable, "-c", code], check=True, env=ENV, timeout=120)


# ---------------------------------------------------------------- shapes

def _body_scene(**shape):
    s = vd.Scene("s")
    s.add_body("b", joint=vd.Pivot((0, 1, 0)), mass=1.0, com=(0, 0, -1), shape=shape or None)
    return s


@pytest.mark.parametrize("shape, message", [
    ({"type": "cone", "radius": 1.0}, "unknown shape type 'cone'"),
    ({"type": "box"}, "needs 'size'"),
    ({"type": "box", "size": [1, 0, 1]}, "box sizes must be positive"),
    ({"type": "sphere", "radius": -1}, "radius: must be positive"),
    ({"type": "cylinder", "radius": 0.1, "length": 1, "axis": [0, 0, 0]}, "axis has zero length"),
    ({"type": "sphere", "radius": 0.1, "colour": "red"}, "unknown key 'colour'"),
    ({"type": "sphere", "radius": 0.1, "color": "#12345"}, "#rrggbb"),
    ({"type": "mesh", "path": "nowhere.stl"}, "not found"),
    ({"type": "mesh", "path": "x.ply"}, "must be one of"),
])
def test_bad_shapes_are_model_errors_naming_the_body(shape, message):
    with pytest.raises(vd.ModelError, match=re.escape(message)) as e:
        _body_scene(**shape)
    assert "body 'b'" in str(e.value)


def test_shapes_round_trip_through_toml_and_are_drawn(tmp_path):
    stl = tmp_path / "part.stl"
    stl.write_bytes(b"solid x\nendsolid x\n")
    (tmp_path / "s.toml").write_text("""
[[body]]
name = "b"
mass = 1.0
com = [0.0, 0.0, -0.5]
joint = { type = "pivot", axis = [0.0, 1.0, 0.0] }
shape = [{ type = "box", size = [0.1, 0.2, 0.3], color = "#ff0000" },
         { type = "capsule", radius = 0.05, length = 0.4, axis = [1.0, 0.0, 0.0], at = [0.0, 0.0, -0.5] },
         { type = "mesh", path = "part.stl", scale = 0.001 }]
""")
    scene = vd.load_scene(tmp_path / "s.toml")
    shapes = scene.bodies["b"].shape
    assert [s.type for s in shapes] == ["box", "capsule", "mesh"]
    assert shapes[0].color == (1.0, 0.0, 0.0) and shapes[2].path == str(stl.resolve())
    scene.save(tmp_path / "again.toml")
    assert vd.load_scene(tmp_path / "again.toml").bodies["b"].shape == shapes
    with pytest.raises(vd.SceneFileError, match="unknown shape type"):
        (tmp_path / "bad.toml").write_text('[[body]]\nname = "b"\nmass = 1.0\nshape = { type = "blob" }\n')
        vd.load_scene(tmp_path / "bad.toml")
    d = content(scene).drawing
    names = [i.name for i in d.items if i.node == "bodies/b"]
    assert names[:4] == ["shape0", "shape1", "shape1.cap0", "shape1.cap1"] and "shape2" in names
    mesh = next(i for i in d.items if i.name == "shape2")
    assert mesh.geometry["format"] == "stl" and isinstance(mesh.geometry["data"], bytes)
    assert np.allclose(np.diag(mesh.matrix)[:3], 0.001)


def test_box_of_equal_inertia():
    """Without a shape, a body is drawn as the box whose inertia is its own (sides from the moments)."""
    s = vd.Scene("box")
    size = (0.4, 0.2, 0.1)
    s.add_body("b", joint=vd.Slider((1, 0, 0)), mass=3.0, inertia=vd.inertia.box(3.0, size))
    item = next(i for i in content(s).drawing.items if i.name == "mass")
    g = item.geometry
    sides = sorted([g["width"], g["height"], g["depth"]])
    assert np.allclose(sides, sorted(size), rtol=1e-12)


# ---------------------------------------------------------------- motions

def _track(anim, node, name):
    clip = next(a["clip"] for a in anim if a["path"] == f"{ROOT}/{node}")
    tr = next(t for t in clip["tracks"] if t["name"] == name)
    n = 4 if tr["type"] == "quaternion" else 3
    return np.array(tr["times"]), np.array(tr["values"]).reshape(-1, n)


def test_default_amplitude_is_ten_percent_of_the_scene_and_follows_the_mode():
    """Triple pendulum: the largest point displacement of each shown mode is 10 % of the scene's size
    (to second order in the angles), and the masses move as the mode shape says (linearised)."""
    c = content(vd.load_scene(MODELS / "triple_pendulum.toml"))
    system, d = c.system, c.drawing
    assert d.size == pytest.approx(3.0)
    for k, v in enumerate(c.views):
        a = motion.scale(d, c.linear, v)
        frames = motion.mode_frames(system, c.q0, v, a)
        p0 = d.points(c.q0)
        disp = max(np.linalg.norm(d.points(q) - p0, axis=1).max() for q in frames)
        angle = a * np.abs(v.shape).max()
        assert angle <= motion.MAX_ANGLE + 1e-12
        if angle < motion.MAX_ANGLE:  # 10 % of the size, within the chord's second-order error
            assert disp == pytest.approx(0.1 * d.size, rel=angle ** 2)
        # the first frame is q0 ⊕ a·φ: the masses' displacements are J a φ, to second order
        pts = np.array([system.point_position(f"mass{i}", (0, 0, -1), frames[0]) -
                        system.point_position(f"mass{i}", (0, 0, -1), c.q0) for i in (1, 2, 3)])
        J = c.linear.point_jacobian([(f"mass{i}", (0, 0, -1)) for i in (1, 2, 3)])
        assert np.allclose(pts.ravel(), J @ (a * v.shape.real), atol=3 * angle ** 2)
        anim = c.animation(k)
        t, pos = _track(anim, "bodies/mass3", ".position")
        assert t[-1] == pytest.approx(motion.PERIOD) and np.allclose(pos[0], pos[-1])  # one loop
    user = motion.scale(d, c.linear, c.views[0], amplitude=0.05)
    assert user == pytest.approx(motion.scale(d, c.linear, c.views[0]) * 0.05 / 0.3)


def test_springs_stretch_with_the_motion():
    """rao_three_mass_series: each spring node's z scale is the distance between its anchors, frame by
    frame, and its z axis points from end a to end b."""
    c = content(vd.load_scene(MODELS / "rao_three_mass_series.toml"))
    from vibdyn.description.elements import Spring

    springs = c.system.scene.elements_of(Spring)
    assert springs
    v = c.views[-1]
    frames = motion.mode_frames(c.system, c.q0, v, motion.scale(c.drawing, c.linear, v))
    anim = c.animation(len(c.views) - 1)
    for e in springs:
        _, scale = _track(anim, f"links/{e.name}", ".scale")
        _, pos = _track(anim, f"links/{e.name}", ".position")
        ends = [[np.asarray(p) if b not in c.system.scene.bodies else c.system.point_position(b, p, q)
                 for b, p in (e.a, e.b)] for q in frames]
        L = np.array([np.linalg.norm(b - a) for a, b in ends])
        assert np.allclose(scale[:, 2], L, rtol=1e-5, atol=1e-6)
        assert np.allclose(pos, [a for a, _ in ends], atol=1e-6)
        assert np.ptp(L) > 0  # they do stretch in this mode


def test_damped_gyroscopic_and_unstable_modes_are_labelled():
    rotor = content(vd.load_scene(MODELS / "rotor_slider.toml"))
    kinds = [v.behaviour for v in rotor.views]
    assert "rigid" in kinds
    assert all(np.isfinite(v.zeta) for v in rotor.views)
    assert any("ζ" in m["label"] for m in rotor.motions())
    # a rigid mode drifts one way over the loop (a sawtooth), an oscillating one comes back
    rigid = rotor.views[kinds.index("rigid")]
    z = motion._phases(rigid)
    assert z[0].real == -1 and z[-1].real == 1 and np.all(np.diff(z.real) > 0)
    bar = content(vd.load_scene(MODELS / "inverted_bar_unstable.toml"))
    assert any(v.behaviour == "unstable" for v in bar.views)
    assert any(m["unstable"] and "UNSTABLE" in m["label"] for m in bar.motions())
    # a complex shape animates its phase: mode frames at θ and θ + π are mirror images
    damped = content(vd.load_scene(MODELS / "receptance_damped.toml"))
    v = next(v for v in damped.views if v.behaviour == "oscillating")
    assert np.iscomplexobj(v.shape) and np.any(v.shape.imag != 0)
    fr = motion.mode_frames(damped.system, damped.q0, v, 1e-3)
    half = len(fr) // 2
    dq = damped.system.difference(damped.q0, fr[0]) + damped.system.difference(damped.q0, fr[half])
    assert np.abs(dq).max() <= 1e-12


# ---------------------------------------------------------------- pages and pictures

@pytest.mark.parametrize("model", sorted(p.stem for p in MODELS.glob("*.toml")) + ["robot:ur5"])
def test_view_html_every_model(model, tmp_path, capsys):
    out = tmp_path / "page.html"
    spec = model if model.startswith("robot:") else str(MODELS / f"{model}.toml")
    assert cli.main(["view", spec, "--html", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    text = out.read_text(encoding="utf-8")
    scene = json.loads(re.search(r'id="vd-scene">(.*?)</script>', text, re.S).group(1).replace("<\\/", "</"))
    anims = json.loads(re.search(r'id="vd-animations">(.*?)</script>', text, re.S).group(1).replace("<\\/", "</"))
    assert any(c["type"] == "set_object" for c in scene)
    assert len(anims) == text.count('class="vd-row')
    assert "MeshCat.Viewer" in text
    if model == "robot:ur5":
        assert sum(c["type"] == "set_object" and c["object"]["geometries"][0]["type"] == "_meshfile_geometry"
                   for c in scene) == 7  # the URDF's visual meshes


def test_trajectory_replay_page(tmp_path, capsys):
    traj = tmp_path / "traj.npz"
    assert cli.main(["simulate", str(MODELS / "double_pendulum.toml"), "--t-end", "1.0", "--samples", "51",
                     "--offset", "0.3", "0", "--out", str(traj), "--no-progress"]) == 0
    out = tmp_path / "replay.html"
    assert cli.main(["view", str(MODELS / "double_pendulum.toml"), "--trajectory", str(traj), "--speed", "0.5",
                     "--html", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    anims = json.loads(re.search(r'id="vd-animations">(.*?)</script>', text, re.S).group(1).replace("<\\/", "</"))
    assert len(anims) == 1
    times = np.array(anims[0][0]["clip"]["tracks"][0]["times"])
    assert times[-1] == pytest.approx(2.0)  # 1 s at half speed
    capsys.readouterr()
    assert cli.main(["view", str(MODELS / "triple_pendulum.toml"), "--trajectory", str(traj), "--html",
                     str(out)]) == 2
    assert "coordinates" in capsys.readouterr().err


def test_modes_png_and_plot(tmp_path, capsys):
    png = tmp_path / "modes.png"
    assert cli.main(["modes", str(MODELS / "triple_pendulum.toml"), "--png", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    m = vd.load_scene(MODELS / "trailer.toml").build().operating_point().linearize().modes()
    fig = m.plot(tmp_path / "trailer.png")
    titles = [a.get_title() for a in fig.axes if a.get_title()]
    assert len(titles) == m.n and all("Hz" in t and "rad/s" in t for t in titles)
    with pytest.raises(vd.ModelError, match="indices"):
        m.plot(which=[5])


def test_bad_requests_are_model_errors(tmp_path, capsys):
    with pytest.raises(vd.ModelError, match="amplitude"):
        vd.export_html(vd.load_scene(MODELS / "trailer.toml"), tmp_path / "x.html", amplitude=-1.0)
    with pytest.raises(vd.ModelError, match="Modes, Trajectory, System, Scene, PeriodicOrbit"):
        vd.export_html(42, tmp_path / "x.html")
    assert cli.main(["view", str(MODELS / "trailer.toml"), "--html", str(tmp_path / "no" / "x.html")]) == 2
    assert "cannot write" in capsys.readouterr().err
    # --mode with --html: the page starts there (it was accepted and ignored, 99 of 2 modes too)
    assert cli.main(["view", "double_pendulum", "--html", str(tmp_path / "m.html"), "--mode", "99"]) == 2
    assert "mode 99: choose a motion from 1 to 2" in capsys.readouterr().err
    for bad in (0, 2.0, True, "1"):
        with pytest.raises(vd.ModelError, match="choose a motion from 1 to 2"):
            vd.export_html(vd.load_scene("double_pendulum"), tmp_path / "m.html", mode=bad)
    vd.export_html(vd.load_scene("double_pendulum"), tmp_path / "m.html", mode=2)
    assert '"current":1' in (tmp_path / "m.html").read_text()


# ---------------------------------------------------------------- live server hygiene

def _servers():
    """PIDs of running meshcat servers started by the viewer (its _server.py script)."""
    out = set()
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                cmd = (d / "cmdline").read_bytes()
                state = (d / "stat").read_text().rsplit(")", 1)[1].split()[0]
            except OSError:
                continue
            if b"vibdyn/faces/viewer/_server.py" in cmd and state != "Z" and _ours(d):
                out.add(int(d.name))
    return out


def _ours(proc_dir):
    """Started by this test process (the CLI children carry its tag in their environment): tests running in
    parallel (pytest -n) must not count each other's servers."""
    try:
        return f"VIBDYN_TEST_TAG={TAG}".encode() in (proc_dir / "environ").read_bytes()
    except OSError:
        return False


def _gone(before, timeout=10.0):
    deadline = time.monotonic() + timeout
    while _servers() - before and time.monotonic() < deadline:
        time.sleep(0.1)
    return not (_servers() - before)


pytestmark_linux = pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs /proc")


def _interruptible():
    """Ctrl-C reaches the child as a user's would: a suite run from a background shell inherits SIGINT
    ignored, and Python then installs no KeyboardInterrupt handler."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start_cli(*args):
    p = subprocess.Popen([sys.executable, "-m", "vibdyn.faces.cli", "view", str(MODELS / "triple_pendulum.toml"),
                          "--no-browser", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=ENV,
                         text=True, preexec_fn=_interruptible)
    line = p.stdout.readline()
    return p, line


@pytestmark_linux
def test_live_cli_stops_its_server_on_ctrl_c_and_at_the_end():
    before = _servers()
    p, line = _start_cli()
    try:
        assert line.startswith("viewer: http://127.0.0.1:"), line + p.stderr.read()
        assert len(_servers() - before) == 1
        p.send_signal(signal.SIGINT)
        assert p.wait(timeout=30) == 0
    finally:
        p.kill()
    assert _gone(before)
    p, line = _start_cli("--duration", "0.5")
    assert line.startswith("viewer: ") and p.wait(timeout=60) == 0
    assert _gone(before)
    p, line = _start_cli("--mode", "99")  # fails after the server started
    assert p.wait(timeout=60) == 2 and "no motion 99" in p.stderr.read()
    assert _gone(before)


@pytestmark_linux
def test_live_viewer_closes_on_exception_and_dies_with_its_parent():
    before = _servers()
    with pytest.raises(ZeroDivisionError):
        with vd.view(vd.load_scene(MODELS / "trailer.toml")) as v:
            assert v.running and v.url.startswith("http://127.0.0.1:")
            assert "<iframe" in v._repr_html_()
            1 / 0
    assert not v.running and _gone(before)
    # a parent killed outright (SIGKILL: no cleanup runs) takes the server with it
    code = ("import vibdyn as vd, time; v = vd.view(vd.load_scene(%r)); print(v.process.pid, flush=True); "
            "time.sleep(60)" % str(MODELS / "trailer.toml"))
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, env=ENV, text=True)
    try:
        pid = int(p.stdout.readline())
        assert pid in _servers()
        p.kill()
        p.wait()
    finally:
        p.kill()
    assert _gone(before)


@pytestmark_linux
def test_live_trajectory_replay_shows_its_time():
    system = vd.load_scene(MODELS / "double_pendulum.toml").build()
    traj = system.simulate(1.0, q0=system.integrate(system.neutral(), np.array([0.3, 0.0])),
                           t_eval=np.linspace(0, 1, 51))
    before = _servers()
    with vd.view(traj, speed=2.0) as v:
        assert v.content.n == 1 and v.state()["current"] == 0
        time.sleep(0.2)
        t = v.state()["t"]
        assert 0.0 <= t <= 1.0
        paused = v.toggle()
        assert not paused["playing"] and paused["t"] == 0.0
        with pytest.raises(vd.ModelError, match="no motion 2"):
            v.show(1)
    assert _gone(before)


def test_live_viewer_refuses_a_bad_amplitude_and_keeps_a_valid_state():
    """A NaN or negative amplitude sent to the live viewer is refused (a 400 on the page) and not kept: the
    next request still works and the state is valid JSON."""
    import json
    import urllib.error
    import urllib.request

    m = vd.load_scene(MODELS / "double_pendulum.toml").build().operating_point().linearize().modes()
    before = _servers()
    with vd.view(m) as v:
        for bad in ("nan", "-1", "big"):
            with pytest.raises(urllib.error.HTTPError) as e:
                urllib.request.urlopen(f"{v.url.rstrip('/')}/show?n=0&amplitude={bad}", timeout=10)
            assert e.value.code == 400
        state = json.loads(urllib.request.urlopen(f"{v.url.rstrip('/')}/state", timeout=10).read(),
                           parse_constant=lambda c: pytest.fail(f"invalid JSON constant {c}"))
        assert state["amplitude"] is None
        assert v.show(1, 0.05)["current"] == 1
    assert _gone(before)


def test_a_mesh_deleted_after_its_body_was_described_is_named(tmp_path):
    mesh = tmp_path / "part.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    s = vd.Scene("meshed")
    s.add_body("part", joint=vd.Pivot((0, 0, 1)), mass=1.0, com=(0.1, 0, 0),
               shape=[{"type": "mesh", "path": str(mesh)}])
    system = s.build()
    mesh.unlink()
    with pytest.raises(vd.ModelError, match=r"part shape .*mesh file .*part.obj: cannot read it"):
        vd.export_html(system, tmp_path / "m.html")
