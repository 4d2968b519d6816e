"""Adversarial run (issue 11): each case in its own process with a timeout, classified as
clear (a vibdyn error), right (finite result, checked where a closed form exists), silent (a wrong or
non-finite result without an error) or raw/hang (another exception, or the timeout).

    python tests/adversarial/run.py      # prints one line per case and the counts
"""

import subprocess
import sys

PRE = """
import numpy as np, vibdyn as vd
def pend(g=-9.81, m=1.0, I=None):
    s = vd.Scene("p", gravity=(0, 0, g))
    s.add_body("rod", joint=vd.Pivot((0, 1, 0)), mass=m, com=(0, 0, -0.5),
               inertia=vd.inertia.rod(m, 1.0) if I is None else I * np.eye(3))
    return s
def cart(c=1.0):
    s = vd.Scene("c"); s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=1.0); s.add_joint_spring("m", 1.0)
    s.add_joint_damper("m", c); return s
def check(ok):
    if not ok: raise SystemExit(3)
"""

CASES = {
    "tiny mass": "m,l,I=1e-18,0.5,1e-20; a=pend(m=m,I=I).build().accelerations([0.3],[0])[0]; "
                 "check(abs(a+m*9.81*l*np.sin(0.3)/(I+m*l*l))<1e-9*abs(a))",
    "stiff 1e12 fd": "s=vd.Scene('s'); s.add_body('a',joint=vd.Slider((1,0,0)),mass=1.0); "
                     "s.add_body('b',joint=vd.Slider((1,0,0)),mass=1.0); s.add_spring('k1',('world',(-1,0,0)),('a',(0,0,0)),1.0); "
                     "s.add_spring('k2',('a',(0,0,0)),('b',(1,0,0)),1e12); m=s.build().linearize().modes(); "
                     "check(abs(m.omega[0]-0.5**0.5)<1e-3 and not m.rigid.any())",
    "singular M": "s=vd.Scene('c',gravity=(0,0,-9.81)); s.add_body('c',joint=vd.Pivot((0,0,1)),mass=0.0); "
                  "s.add_body('b',parent='c',joint=vd.Pivot((1,0,0)),mass=1.0,com=(0,-1,0)); y=s.build(); "
                  "y.linearize(y.integrate(y.neutral(),[0,np.pi/2]))",
    "gravity 1e300": "m=pend(g=-1e300).build().linearize().modes(); check(not m.rigid[0] and np.isfinite(m.omega[0]))",
    "spring 1e300": "s=vd.Scene('s'); s.add_body('a',joint=vd.Slider((1,0,0)),mass=1.0); "
                    "s.add_spring('k',('a',(0,0,0)),('world',(1,0,0)),1e10); print(s.build().generalized_forces([1e300],[0]))",
    "energy v 1e200": "print(pend().build().energy([0],[1e200]))",
    "spin 1e160": "s=vd.Scene('r'); s.add_body('r',joint=vd.Pivot((0,0,1)),mass=1.0,inertia=np.eye(3)); "
                  "t=s.build().simulate(1e-170,v0=[1e160],method='rk4',dt=1e-171); check(np.isfinite(t.energy).all())",
    "mac nan": "print(vd.mac(np.array([[np.nan],[1.0]])))",
    "modes tol nan": "print(pend().build().linearize().modes(tolerance=float('nan')))",
    "eq tol nan": "print(pend().build().equilibrium([1.0],tol=float('nan')))",
    "q strings": "print(pend().build().accelerations(['0.3'],[0]))",
    "q complex": "print(pend().build().accelerations([0.3+1j],[0]))",
    "box negative": "print(vd.inertia.box(1.0,(-1,1,1)))",
    "rayleigh negative": "print(vd.rayleigh((-0.01,0.02),(1,10)))",
    "spring same point": "s=vd.Scene('s'); s.add_body('a',joint=vd.Slider((1,0,0)),mass=1.0); "
                         "s.add_spring('k',('a',(0,0,0)),('a',(0,0,0)),1.0); s.build()",
    "dop853 v0 1e300": "cart().build().simulate(1.0,v0=[1e300])",
    "radau v0 1e300": "cart().build().simulate(1.0,v0=[1e300],method='radau')",
    "callable raises dop853": "s=cart(); s.add_joint_force('m',lambda t,q,v: 1/0 if t>0.5 else 0.0); s.build().simulate(1.0)",
    "callable raises rk4": "s=cart(); s.add_joint_force('m',lambda t,q,v: 1/0 if t>0.5 else 0.0); s.build().simulate(1.0,method='rk4',dt=1e-3)",
    "wrong signature": "s=cart(); s.add_joint_force('m',lambda t,q: 0.0)",
    "cubic overflow": "s=cart(); s.add_joint_force('m',lambda t,q,v: 1e3*q**3); s.build().simulate(10.0,q0=[1e100],method='rk4',dt=1e-2)",
    "radau blow-up": "s=cart(); s.add_joint_force('m',lambda t,q,v: 5.0*v); s.build().simulate(300.0,q0=[0.1],method='radau')",
    "rk4 1e11 steps": "cart().build().simulate(1e6,method='rk4',dt=1e-5)",
    "rk4 dt 1e-300": "cart().build().simulate(1.0,method='symplectic',dt=1e-300)",
    "linearize step a": "pend().build().linearize(step='a')",
    "equilibrium max_iter a": "pend().build().equilibrium(max_iter='a')",
    "steady fast": "pend().build().steady_motion({'rod':'fast'})",
    "accelerations t abc": "pend().build().accelerations([0],[0],t='abc')",
    "t None time-dependent": "s=cart(); s.add_joint_force('m',lambda t,q,v: np.sin(t)); s.build().accelerations([0],[0],t=None)",
    "file huge int": "open('/tmp/_adv.toml','w').write('[[body]]\\nname=\"a\"\\nmass=1'+'0'*400+'\\n'); vd.load_scene('/tmp/_adv.toml')",
    "file nested": "open('/tmp/_adv2.toml','w').write('x='+'['*1000+']'*1000+'\\n'); vd.load_scene('/tmp/_adv2.toml')",
    "load None": "vd.load_scene(None)",
    "load 0": "vd.load_scene(0)",
    "load /dev/zero": "vd.load_scene('/dev/zero')",
    "load fifo": "import os; p='/tmp/_adv_fifo'; os.path.exists(p) or os.mkfifo(p); vd.load_scene(p)",
    "cli out missing dir": "import sys; cart().save('/tmp/_adv3.toml'); from vibdyn.cli import main; "
                           "sys.exit(0 if main(['simulate','/tmp/_adv3.toml','--t-end','0.1','--out','/nonexistent/d/x.npz'])==2 else 3)",
}


def classify(code):
    try:
        r = subprocess.run([sys.executable, "-c", PRE + "\ntry:\n    " + code.replace("\n", "\n    ")
                            + "\nexcept vd.VibdynError as e:\n    print('CLEAR', e); raise SystemExit(2)\n"],
                           capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        return "raw/hang"
    return {0: "right", 2: "clear", 3: "silent"}.get(r.returncode, "raw/hang")


if __name__ == "__main__":
    counts = {"clear": 0, "right": 0, "silent": 0, "raw/hang": 0}
    for name, code in CASES.items():
        c = classify(code)
        counts[c] += 1
        print(f"{c:9} {name}")
    print(f"tried {len(CASES)}: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
