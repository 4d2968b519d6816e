"""Moving supports (base excitation): forces, energy and linear input against closed forms.

Tolerances: direct evaluations (CRBA, RNEA, ABA, kinematics, energies, parsed numbers) carry no error
estimate; their error is round-off, a few ε × the size of the terms (× κ(M) where M is solved). Fixed
1e-15..1e-12 relative (≈ 4.5–4500 ε) bound it on these small, well-conditioned models; 1e-10 where M is
solved or another engine's arithmetic is compared. Results that carry an estimate are checked against it.
"""

import numpy as np
import pytest

import vibdyn as vd


def base_excited(m=2.0, k=800.0, c=6.0, Y=0.01, w=15.0):
    """A mass on a vertical slider tied by a spring and a damper to a support moving as Y sin(ωt)."""
    s = vd.Scene("base")
    s.add_support("ground", vd.laws.HarmonicMotion((0, 0, Y), w))
    s.add_body("mass", joint=vd.Slider((0, 0, 1), at=(0, 0, 1.0)), mass=m)
    s.add_spring("k", ("ground", (0, 0, 0)), "mass", stiffness=k)
    s.add_damper("c", ("ground", (0, 0, 0)), "mass", damping=c)
    return s.build()


def test_base_excitation_force_is_k_y_plus_c_ydot():
    m, k, c, Y, w = 2.0, 800.0, 6.0, 0.01, 15.0
    system = base_excited(m, k, c, Y, w)
    assert system.depends_on_time
    for t, x, xd in [(0.0, 0.0, 0.0), (0.1, 0.003, -0.2), (0.37, -0.004, 0.5)]:
        y, yd = Y * np.sin(w * t), Y * w * np.cos(w * t)
        a = system.accelerations([x], [xd], t)
        assert a[0] == pytest.approx((-k * (x - y) - c * (xd - yd)) / m, rel=1e-12, abs=1e-12)
        e = system.energy([x], [xd], t)
        assert e.elastic == pytest.approx(0.5 * k * (x - y) ** 2, rel=1e-12, abs=1e-15)


def test_support_input_of_the_linear_model():
    system = base_excited()
    By, Bv = system.linearize().support_input("ground")
    np.testing.assert_allclose(By, [[0, 0, 800.0]], atol=1e-6)
    np.testing.assert_allclose(Bv, [[0, 0, 6.0]], atol=1e-8)
    with pytest.raises(vd.ModelError, match="unknown support 'nope'"):
        system.linearize().support_input("nope")


def test_road_profile_frequency():
    motion = vd.laws.road(0.02, wavelength=5.0, speed=20.0)
    assert motion.omega == pytest.approx(2 * np.pi * 20.0 / 5.0)
    np.testing.assert_allclose(motion.position(0.0125), [0, 0, 0.02 * np.sin(motion.omega * 0.0125)])


def test_support_errors_name_the_support():
    s = vd.Scene("bad")
    with pytest.raises(vd.ModelError, match="support 'g'"):
        s.add_support("g", motion=(0, 0, 1))
    s.add_support("g", vd.laws.Motion(lambda t: np.array([0, 0, np.nan]), lambda t: np.zeros(3)))
    s.add_body("b", joint=vd.Slider((0, 0, 1), at=(0, 0, 1.0)), mass=1.0)
    s.add_spring("k", ("g", (0, 0, 0)), "b", stiffness=1.0, free_length=1.0)
    with pytest.raises(vd.ModelError, match="support 'g': motion is not finite"):
        s.build().accelerations([0.0], [0.0], 0.0)


def test_support_in_a_scene_file_round_trips(tmp_path):
    path = tmp_path / "base.toml"
    path.write_text('[[support]]\nname = "ground"\n'
                    'motion = { law = "harmonic_motion", amplitude = [0.0, 0.0, 0.01], omega = 15.0 }\n'
                    '[[body]]\nname = "mass"\nmass = 2.0\n'
                    'joint = { type = "slider", axis = [0, 0, 1], at = [0, 0, 1] }\n'
                    '[[spring]]\nname = "k"\na = ["ground", [0, 0, 0]]\nb = "mass"\nstiffness = 800.0\n')
    scene = vd.load_scene(path)
    scene.save(tmp_path / "again.toml")
    a = vd.load_scene(tmp_path / "again.toml").build()
    t = 0.3
    assert a.accelerations([0.0], [0.0], t)[0] == pytest.approx(800.0 * 0.01 * np.sin(15.0 * t) / 2.0, rel=1e-12)
    path.write_text(path.read_text().replace('"harmonic_motion"', '"wobble"'))
    with pytest.raises(vd.SceneFileError, match=r"base.toml.*support\[0\]"):
        vd.load_scene(path)
