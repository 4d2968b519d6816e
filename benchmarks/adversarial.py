"""Adversarial run (issue 11): bad inputs, hostile files, numerical extremes and simulation faults, each in
its own process with a time limit. Each case ends "clear" (a vibdyn error, or a result its check accepts),
"silent" (a result that is wrong or not finite, with no error), "raw" (another exception) or "hang".

    python -m benchmarks.adversarial [--timeout 60] [-v]
"""

import argparse
import os
import subprocess
import sys
import textwrap

PRELUDE = ('''
import math, os, sys, tempfile
import numpy as np
import vibdyn as vd
def pendulum(mass=1.0, g=-9.81, I=None):
    s = vd.Scene("p", gravity=(0, 0, g))
    s.add_body("rod", joint=vd.Pivot((1, 0, 0)), mass=mass, com=(0, 0, -0.5),
               inertia=(1e-2 * mass if I is None else I) * np.eye(3))
    return s
def slider(k=10.0, c=0.0):
    s = vd.Scene("m")
    s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_spring("k", ("world", (-1, 0, 0)), ("m", (0, 0, 0)), k)
    if c:
        s.add_joint_damper("m", c)
    return s
def finite(*xs):
    return all(np.all(np.isfinite(np.asarray(x, dtype=complex if np.iscomplexobj(x) else float))) for x in xs)
def tmpfile(text, name="x.toml"):
    d = tempfile.mkdtemp(); p = os.path.join(d, name); open(p, "w").write(text); return p
SCENE = '[scene]\\nname = "x"\\n[[body]]\\nname = "a"\\nmass = {m}\\ncom = [0.0, 0.0, -0.5]\\n'''
'''joint = {{ type = "pivot", axis = [1.0, 0.0, 0.0] }}\\n'
''')

# name -> code; the code raises (a vibdyn error is "clear") or sets ok (True: right, False: silently wrong)
CASES = {
    # ------------------------------------------------------------ silently wrong before
    "tiny mass 1e-18": "a = pendulum(1e-18).build().accelerations([0.3], [0])\n"
                       "ok = abs(a[0] + 5.575102360284117) < 1e-6",
    "tiny mass 1e-16": "a = pendulum(1e-16).build().accelerations([0.3], [0])\n"
                       "ok = abs(a[0] + 5.575102360284117) < 1e-6",
    "tiny mass 1e-15": "a = pendulum(1e-15).build().accelerations([0.3], [0])\n"
                       "ok = abs(a[0] + 5.575102360284117) < 1e-6",
    "tiny mass modes": "m = pendulum(1e-17).build().linearize().modes()\n"
                       "ok = abs(m.omega[0] - math.sqrt(9.81 * 0.5 / 0.26)) < 1e-6",
    "stiffness ratio 1e12 fd": textwrap.dedent('''
        s = vd.Scene("two"); s.add_body("a", joint=vd.Slider((1,0,0)), mass=1.0); '''
        '''s.add_body("b", joint=vd.Slider((1,0,0)), mass=1.0)
        s.add_spring("k1", ("world",(-1,0,0)), ("a",(0,0,0)), 1.0); '''
        '''s.add_spring("k2", ("a",(0,0,0)), ("b",(1,0,0)), 1e12)
        m = s.build().linearize(method="fd").modes()
        ok = (not m.rigid[0]) and abs(m.omega[0] - 0.70710678) <= max(m.omega_error[0], 1e-9) * 0.7072 * 2'''),
    "stiffness ratio 1e14 fd": textwrap.dedent('''
        s = vd.Scene("two"); s.add_body("a", joint=vd.Slider((1,0,0)), mass=1.0); '''
        '''s.add_body("b", joint=vd.Slider((1,0,0)), mass=1.0)
        s.add_spring("k1", ("world",(-1,0,0)), ("a",(0,0,0)), 1.0); '''
        '''s.add_spring("k2", ("a",(0,0,0)), ("b",(1,0,0)), 1e14)
        m = s.build().linearize(method="fd").modes()
        # rigid is honest only if the result's zero threshold (ω below it counts as 0) covers the true 0.707
        ok = (m.rigid[0] and m.zero_threshold >= 0.7072) or '''
        '''abs(m.omega[0] - 0.70710678) <= 2 * m.omega_error[0] * 0.7072'''),
    "singular M carriage linearize": textwrap.dedent('''
        s = vd.Scene("c", gravity=(0,0,-9.81)); s.add_body("carriage", joint=vd.Pivot((0,0,1)), mass=0.0)
        s.add_body("bob", parent="carriage", joint=vd.Pivot((1,0,0)), mass=1.0, com=(0,1,0)); sy = s.build()
        sy.linearize(sy.configuration([0, np.pi/2])).modes(); ok = False'''),
    "singular M carriage radau": textwrap.dedent('''
        s = vd.Scene("c", gravity=(0,0,-9.81)); s.add_body("carriage", joint=vd.Pivot((0,0,1)), mass=0.0)
        s.add_body("bob", parent="carriage", joint=vd.Pivot((1,0,0)), mass=1.0, com=(0,1,0)); sy = s.build()
        sy.simulate(1.0, q0=sy.configuration([0, np.pi/2]), method="radau"); ok = False'''),
    "singular M carriage dop853": textwrap.dedent('''
        s = vd.Scene("c", gravity=(0,0,-9.81)); s.add_body("carriage", joint=vd.Pivot((0,0,1)), mass=0.0)
        s.add_body("bob", parent="carriage", joint=vd.Pivot((1,0,0)), mass=1.0, com=(0,1,0)); sy = s.build()
        sy.simulate(1.0, q0=sy.configuration([0, np.pi/2])); ok = False'''),
    "gravity 1e300": "m = pendulum(g=-1e300).build().linearize().modes()\n"
                     "ok = (not m.rigid[0]) and abs(m.omega[0] / math.sqrt(1e300*0.5/0.26) - 1) < 1e-6",
    "gravity 1e170 two dof": textwrap.dedent('''
        s = vd.Scene("f", gravity=(0,0,2.6e170)); s.add_body("cart", joint=vd.Slider((1,0,0)), mass=1.0)
        s.add_body("rod", parent="cart", joint=vd.Pivot((0,1,0)), mass=1.0, com=(0,0,-0.5), inertia=np.eye(3))
        m = s.build().linearize().modes(); ok = finite(m.omega, m.omega_error)'''),
    "genforces spring 1e300": "sy = slider(1e10).build()\nQ = sy.generalized_forces([1e300], [0])\nok = finite(Q)",
    "energy v 1e200": "e = slider().build().energy([0], [1e200])\nok = finite(e.total)",
    "trajectory spin 1e160": textwrap.dedent('''
        s = vd.Scene("s"); s.add_body("r", joint=vd.Pivot((0,0,1)), mass=1.0, inertia=np.eye(3))
        tr = s.build().simulate(1e-3, v0=[1e160]); ok = finite(tr.kinetic)'''),
    "mac nan": "x = vd.mac(np.array([[np.nan], [1.0]]))\nok = finite(x)",
    "modes tol nan": "m = slider().build().linearize().modes(tol=float('nan'))\nok = False",
    "equilibrium tol nan": "eq = pendulum().build().equilibrium(vd.Scene and pendulum().build().configuration([0.5]), "
                           "tol=float('nan'))\nok = False",
    "q numeric strings": "pendulum().build().accelerations(['0.3'], [0]); ok = False",
    "q complex": "pendulum().build().accelerations([0.3 + 1j], [0]); ok = False",
    "box negative size": "vd.inertia.box(1.0, (-1, 1, 1)); ok = False",
    "rayleigh negative zeta": "vd.rayleigh((-0.1, 0.02), (1.0, 10.0)); ok = False",
    "spring same point": "s = slider(); s.add_spring('k2', ('m', (0,0,0)), ('m', (0,0,0)), 1.0); s.build(); ok = False",
    "mjcf include": textwrap.dedent('''
        d = tempfile.mkdtemp(); open(os.path.join(d, "arm.xml"), "w").write('<mujoco><worldbody><body name="b">'''
        '''<joint name="j" type="hinge"/><geom size="0.1" mass="1"/></body></worldbody></mujoco>')
        p = os.path.join(d, "m.xml"); open(p, "w").write('<mujoco model="m"><include file="arm.xml"/><worldbody>'''
        '''<body name="a"><joint name="i" type="hinge"/><geom size="0.1" mass="1"/></body></worldbody></mujoco>')
        s = vd.load_mjcf(p); ok = len(s.bodies) == 2'''),
    "dop853 local estimate labelled": "tr = slider(c=1.0).build().simulate(1.0, v0=[1.0])\n"
                                      "ok = tr.error_scope != 'local'",
    # ------------------------------------------------------------ raw exceptions and hangs before
    "dop853 nan first step": "slider(c=1e200).build().simulate(1.0, v0=[1e150]); ok = False",
    "dop853 v0 1e300": "slider(c=1.0).build().simulate(1.0, v0=[1e300]); ok = False",
    "radau v0 1e300": "slider(c=1.0).build().simulate(1.0, v0=[1e300], method='radau'); ok = False",
    "radau nan first step": "slider(c=1e200).build().simulate(1.0, v0=[1e150], method='radau'); ok = False",
    "radau blow-up 300 s": textwrap.dedent('''
        s = slider(); s.add_joint_force("m", lambda t, q, v: 0.5 * v + 1e3 * q**3)
        s.build().simulate(300.0, v0=[1.0], method="radau"); ok = False'''),
    **{f"callable raises {m}": textwrap.dedent(f'''
        def law(t, q, v):
            if t > 0.5: raise RuntimeError("boom")
            return 0.0
        s = slider(); s.add_joint_force("m", law)
        s.build().simulate(1.0, method="{m}", dt=0.01); ok = False''')
       for m in ("dop853", "radau", "rk4", "symplectic")},
    "callable wrong signature": "s = slider(); s.add_joint_force('m', lambda t: 0.0); s.build().simulate(1.0); "
                                "ok = False",
    "body force wrong signature": "s = slider(); s.add_force('f', 'm', force=lambda t, q: (0,0,0)); ok = False",
    "callable python-float overflow": textwrap.dedent('''
        s = slider(); s.add_joint_force("m", lambda t, q, v: 1e3 * q**3)
        s.build().simulate(100.0, q0=[1e100], method="rk4", dt=0.01); ok = False'''),
    "rk4 1e11 steps": "slider().build().simulate(1e6, method='rk4', dt=1e-5); ok = False",
    "symplectic dt 1e-300": "slider().build().simulate(1.0, method='symplectic', dt=1e-300); ok = False",
    "linearize step str": "slider().build().linearize(step='a'); ok = False",
    "equilibrium max_iter str": "slider().build().equilibrium(max_iter='a'); ok = False",
    "steady_motion speed str": "pendulum().build().steady_motion({'rod': 'fast'}); ok = False",
    "accelerations t str": "slider().build().accelerations([0], [0], t='abc'); ok = False",
    "t None time-dependent": textwrap.dedent('''
        s = slider(); s.add_joint_force("m", lambda t, q, v: math.sin(t))
        s.build().accelerations([0], [0], t=None); ok = False'''),
    "scene file huge integer": "vd.load_scene(tmpfile(SCENE.format(m='1' + '0' * 400))); ok = False",
    "scene file nested 1000": "vd.load_scene(tmpfile(SCENE.format(m='1.0') + 'x = ' + '[' * 1000 + ']' * 1000)); "
                              "ok = False",
    "references nested 5000": textwrap.dedent('''
        s = pendulum(); x = []
        for _ in range(5000): x = [x]
        s.references = {"x": x}; s.build(); ok = False'''),
    "load_scene None": "vd.load_scene(None); ok = False",
    "load_scene 0": "vd.load_scene(0); ok = False",
    "load_scene /dev/zero": "vd.load_scene('/dev/zero'); ok = False",
    "load_scene fifo": "d = tempfile.mkdtemp(); p = os.path.join(d, 'f.toml'); os.mkfifo(p); vd.load_scene(p); "
                       "ok = False",
    "load_scene directory": "vd.load_scene(tempfile.mkdtemp()); ok = False",
    "20k bodies linear": textwrap.dedent('''
        import time; s = vd.Scene("n"); t0 = time.time()
        for i in range(20000): s.add_body(f"b{i}", parent="world" if i == 0 else f"j{i-1}", '''
        '''joint=vd.Pivot((0,0,1), name=f"j{i}"), mass=1.0)
        ok = time.time() - t0 < 20'''),
    "cli out missing dir": textwrap.dedent('''
        import subprocess
        r = subprocess.run([sys.executable, "-c", "import sys; from vibdyn.faces.cli import main; sys.exit(main())", '''
        '''"simulate", "chain5_fixed_fixed", "--t-end", "0.01", "--no-progress", "--out", "/nonexistent/dir/x.npz"], '''
        '''capture_output=True, text=True)
        ok = r.returncode == 2 and "Traceback" not in r.stderr'''),
    # ------------------------------------------------------------ more bad numbers
    **{f"mass {v}": f"pendulum({v}, I=0.01).build(); ok = False"
       for v in ("-1.0", "float('nan')", "float('inf')", "'1'", "None", "10**400")},
    **{f"stiffness {v}": f"slider({v}).build(); ok = False" for v in ("-1.0", "float('nan')", "'10'", "10**400")},
    **{f"dt {v}": f"slider().build().simulate(1.0, method='rk4', dt={v}); ok = False"
       for v in ("0.0", "-1.0", "float('nan')", "'a'")},
    **{f"t_end {v}": f"slider().build().simulate({v}); ok = False" for v in ("0.0", "-1.0", "float('inf')", "None")},
    **{f"rtol {v}": f"slider().build().simulate(1.0, rtol={v}); ok = False"
       for v in ("0.0", "1e-300", "float('nan')", "2.0")},
    "v0 wrong length": "slider().build().simulate(1.0, v0=[1, 2]); ok = False",
    "q wrong length": "slider().build().accelerations([1, 2], [0]); ok = False",
    "v nan": "slider().build().accelerations([0], [float('nan')]); ok = False",
    "gravity nan": "vd.Scene('g', gravity=(0, 0, float('nan'))); ok = False",
    "axis zero": "vd.Scene('x').add_body('a', joint=vd.Pivot((0, 0, 0)), mass=1.0); ok = False",
    "inertia not symmetric": "vd.Scene('x').add_body('a', joint=vd.Pivot((1,0,0)), mass=1.0, "
                             "inertia=[[1,0.5,0],[0,1,0],[0,0,1]]); ok = False",
    "frf nan omega": "slider(c=0.1).build().linearize().receptance([float('nan')]); ok = False",
    "modes big spring": "m = slider(1e300).build().linearize().modes()\n"
                        "ok = finite(m.omega) and abs(m.omega[0] - 1e150) < 1e140",
    "equilibrium start nan": "pendulum().build().equilibrium([float('nan')]); ok = False",
}


def run_case(name, code, timeout):
    child = PRELUDE + textwrap.dedent(f'''
ok = None
try:
{textwrap.indent(code, "    ")}
except vd.VibdynError as e:
    print("CLEAR", type(e).__name__, str(e).splitlines()[0][:150] if str(e) else ""); sys.exit(0)
except BaseException as e:
    print("RAW", type(e).__name__, str(e).splitlines()[0][:150] if str(e) else ""); sys.exit(0)
print("CLEAR right" if ok else "SILENT", "" if ok else "(no error; wrong or not finite)")
''')
    try:
        r = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, timeout=timeout,
                           env={"OPENBLAS_NUM_THREADS": "1", "PATH": "/usr/bin:/bin", "PYTHONWARNINGS": "ignore",
                                **{k: v for k, v in os.environ.items() if k == "PYTHONPATH"}})
    except subprocess.TimeoutExpired:
        return "hang", f"no answer in {timeout} s"
    line = (r.stdout.strip().splitlines() or [""])[-1]
    if line.startswith("CLEAR"):
        return "clear", line[6:]
    if line.startswith("SILENT"):
        return "silent", line[7:]
    if line.startswith("RAW"):
        return "raw", line[4:]
    return "raw", f"exit {r.returncode}: {(r.stderr.strip().splitlines() or [''])[-1][:150]}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args(argv)
    counts = {"clear": 0, "silent": 0, "raw": 0, "hang": 0}
    for name, code in CASES.items():
        kind, detail = run_case(name, code, args.timeout)
        counts[kind] += 1
        if args.verbose or kind != "clear":
            print(f"{kind:6s} {name}: {detail}", flush=True)
    print(f"tried {len(CASES)} / clear {counts['clear']} / silent {counts['silent']} / raw-hang "
          f"{counts['raw'] + counts['hang']} (raw {counts['raw']}, hang {counts['hang']})")
    return 0 if counts["silent"] + counts["raw"] + counts["hang"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
