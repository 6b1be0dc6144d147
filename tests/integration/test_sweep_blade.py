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


def test_blade_at_preload_zero_with_ms_hbm_is_swept_on_the_automatic_reduction(blade):
    """MS-HBM integrates the tip DOF in time; on the 40-element mesh its local frequency sqrt(K_dd / M_dd) is
    2350 omega, so the suite sweeps the automatic Craig-Bampton reduction (tip DOF + 8 fixed-interface modes), as
    ``mshbm sweep`` does for a case file.  On the mesh as written the same sweep had 34 of 44 points not certified
    (time_discretisation up to 12 %) and deviated from the closed form by 8.6e-2; on the reduction every point and
    every check is certified with the reduction's estimate, and the points, expanded to the 80 DOFs, are the
    closed-form linear response to 2.3e-4 (Moreau-Jean at 1024 steps; the points' own combined estimates are
    0.8-4.8e-4)."""
    system, w1 = blade
    info = {"auto_reduce": True}
    opts = {"harmonics": 5, "steps": 1024}
    red = sweep_systems.time_reduction(system, info, "mshbm", opts, 1.1 * w1)
    assert red is not None and red.system.n == 9 and red.boundary.tolist() == [78]
    assert sweep_systems.time_reduction(system, info, "hbm", opts, 1.1 * w1) is None  # HBM integrates nothing
    assert sweep_systems.time_reduction(system, {"auto_reduce": False}, "mshbm", opts, 1.1 * w1) is None
    case = {"name": "blade-p0/mshbm", "system": "blade-p0", "method": "mshbm", "label": "mshbm", "options": opts,
            "omega": [0.9 * w1, 1.1 * w1], "exact": "linear"}
    suite = {"cpu_limit_s": 60.0, "checks": 10, "check_cpu_s": 20.0, "check_budget_s": 60.0, "tolerance": 0.005}
    row = sweep_runner.run_case(case, system, suite, red)
    assert row["stop"] == "end" and row["reached"] and row["success"], row["message"]
    assert row["points"] <= 40, row["points"]
    assert row["dofs"] == 80 and row["reduced_dofs"] == 9
    assert row["exact_deviation"] < 1e-3, row["exact_deviation"]
    assert row["checks_certified"] == 10 and row["within"] and row["max_deviation"] < 1e-6
    # the reduction's estimate is part of every check's certificate, as for mshbm solve
    sol, _ = sweep_runner._solve(system, w1, "mshbm", dict(opts, stability=False), None, 20.0, red)
    assert sol.success and sol.q_hat.shape[1] == 80
    assert sol.certificate["reduction"].passed and 0.0 < sol.certificate["reduction"].value < 1e-3
