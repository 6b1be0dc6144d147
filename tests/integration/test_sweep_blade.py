"""Step control of ``mshbm.sweep`` on the FE blade of the sweep stress suite (workflow/sweeps.yaml, system
``blade-p0``): a 40-element steel cantilever (w_1 = 1049.9 rad/s, 1 % Rayleigh damping) with a tip Jenkins damper
at preload 0, whose element carries no force: the problem is linear in effect, and HBM's curve over +-10 % of w_1
is the closed-form linear response.  The corrector finishes at fixed omega as soon as its residual is small (the
bordered iteration otherwise crept from 1e-7 to 1e-10 through the rounding of dR/domega, 4-7 iterations where
Newton at fixed omega takes one), so the step grows along the curve: 25 points (48 before).
"""
from pathlib import Path

import numpy as np
import pytest
import yaml

import mshbm
from mshbm_workflow import sweep_runner, sweep_systems

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def blade():
    cfg = yaml.safe_load((ROOT / "workflow" / "sweeps.yaml").read_text())
    system, w1, _ = sweep_systems.build(cfg["systems"]["blade-p0"], "blade-p0")
    return system, w1


def test_blade_at_preload_zero_takes_tens_of_points_and_is_the_linear_response(blade):
    system, w1 = blade
    b = mshbm.sweep(system, 0.9 * w1, 1.1 * w1, "hbm", harmonics=5, stability=False, accuracy=False)
    assert b.success, b.message
    assert b.omega[-1] == pytest.approx(1.1 * w1, rel=1e-12)
    assert len(b.points) <= 40, len(b.points)
    om = np.asarray(b.omega)
    assert np.all(np.diff(om) > 0)  # no spurious fold on a linear branch
    assert not [f for f in b.bifurcations if f["type"] == "fold"]
    # the resonance resolved: points within the half-power band (2 zeta w_1 wide) around the peak
    assert np.sum(np.abs(om - w1) < 0.01 * w1) >= 3, om
    worst = max(sweep_runner.deviation(p.amplitude, sweep_runner.linear_reference(system, p.omega))
                for p in b.points)
    assert worst <= 1e-8, worst
