"""vibdyn beside ROSS (issue 43, item 5): a rigid rotor on two cross-coupled bearings — damped frequencies, log
decrements and unbalance-response peaks — agreeing to the limit set by ROSS's shaft flexibility. Runs only where
``ross-rotordynamics`` is installed (no vibdyn dependency).

ROSS's own error (its shaft is Timoshenko elements made stiff by multiplying the moduli by 1e5) is estimated from
ROSS itself: the change of each number between the moduli × 1e4 and × 1e5, which scales as 1/E (the flexibility
left at × 1e5 is a tenth of it, measured 4e-7 relative on the frequencies)."""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

pytest.importorskip("ross")

from benchmarks import bench_ross as B  # noqa: E402


@pytest.fixture(scope="module")
def rotors():
    warnings.filterwarnings("ignore")
    out = {}
    for factor in (1e4, 1e5):
        B.STIFFER = factor
        out[factor] = B.ross_rotor()
    B.STIFFER = 1e5
    return B.vibdyn_rotor(), out


@pytest.mark.parametrize("speed", [0.0, 300.0, 600.0])
def test_frequencies_and_log_decrements_agree_with_ross(rotors, speed):
    system, ross = rotors
    w, d, err = B.vibdyn_modes(system, speed)
    w4, d4 = B.ross_modes(ross[1e4], speed)
    w5, d5 = B.ross_modes(ross[1e5], speed)
    ross_error_w, ross_error_d = np.abs(w4 - w5) / 9, np.abs(d4 - d5) / 9  # (the 1/E series: the rest of it)
    assert np.all(np.abs(w - w5) <= 10 * (ross_error_w + err) + 1e-9 * w)
    assert np.all(np.abs(d - d5) <= 10 * ross_error_d + 1e-9)
    assert np.all(np.abs(w - w5) / w < 1e-5)  # the figure


def test_unbalance_response_peaks_agree_with_ross(rotors):
    system, ross = rotors
    grid = np.linspace(150.0, 450.0, 31)
    mine, response = B.vibdyn_peaks(system, grid)
    p4, _ = B.ross_peaks(ross[1e4], grid)
    p5, _ = B.ross_peaks(ross[1e5], grid)
    peaks = response.peaks(0) + response.peaks(1)
    assert len(mine) == len(p5) == len(p4) == len(peaks) == 2
    for (s, a, s_err, a_err), (s4, a4), (s5, a5), peak in zip(mine, p4, p5, peaks):
        # (ROSS's amplitude is 0-peak, as vibdyn's .amplitude)
        tol_a = 10 * (abs(a4 - a5) / 9 + a_err)
        assert abs(a - a5) <= tol_a + 1e-12 * a
        # a peak is flat: an amplitude known to δA places it to about the half-width √(2 δA / A) (A ≈ A_c (1 −
        # ((Ω − N_c)/Δ)²/2) near it, Δ the half-power half-width)
        half_width = (peak.half_power[1] - peak.half_power[0]) / 2
        assert abs(s - s5) <= half_width * np.sqrt(2 * tol_a / a) + 10 * s_err
        assert abs(s - s5) / s < 1e-5  # the figure
