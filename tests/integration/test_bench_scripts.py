"""Smoke tests of the benchmark scripts (workflow/scripts/bench_*.py) in their --quick form.

They check that the scripts run and write a JSON with the expected keys and finite numbers plus a
PNG.  No timing is asserted: speed is measured by the benchmarks, not by tests.  The kernel and
scaling benchmarks are read from the quick workflow's run (fixture ``quick_run``, tests/conftest.py; rule
``bench_standalone`` runs ``bench_<name>.py --profile quick``, the same profile as ``--quick``), once per
session; the others run standalone here.
"""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = ROOT / "workflow" / "scripts" / "bench"

pytestmark = pytest.mark.slow


def _run(script, out):
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(SCRIPTS / script), "--quick", "--out", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, f"{script} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    assert out.exists() and out.with_suffix(".png").exists()
    return json.loads(out.read_text())


def _from_quick_run(quick_run, name):
    """The JSON of the quick workflow's stand-alone benchmark ``name`` (and its PNG must exist)."""
    out = quick_run / "benchmarks" / f"{name}.json"
    assert out.exists() and out.with_suffix(".png").exists()
    return json.loads(out.read_text())


def _finite_positive(x):
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


def _check_machine(data):
    assert isinstance(data.get("summary"), dict)  # read by workflow/scripts/bench/bench_report.py
    m = data["machine"]
    for key in ("date", "cpu_count", "numpy_version", "scipy_version", "numba_version"):
        assert m.get(key) is not None, key


def _check_stats(s):
    assert s["repeats"] == len(s["times_s"]) >= 1
    assert all(_finite_positive(t) for t in s["times_s"])
    assert _finite_positive(s["median_s"]) and s["min_s"] <= s["median_s"]


def test_bench_kernel_quick(quick_run):
    data = _from_quick_run(quick_run, "kernel")
    _check_machine(data)
    assert data["quick"] is True
    meas = data["measurements"]
    for key in ("1dof_friction_plain", "1dof_friction_sens", "1dof_friction_sens_store", "1dof_contact_plain",
                "1dof_contact_sens", "1dof_contact_sens_store", "3dof_friction_plain", "3dof_friction_sens_store",
                "full30_plain", "full50_plain", "numpy_twin_1dof_friction", "compiled_1dof_friction_small"):
        m = meas[key]
        _check_stats(m)
        assert _finite_positive(m["ns_per_step_median"]) and m["steps"] > 0
        assert len(m["ns_per_step_all"]) == m["repeats"]
    assert meas["1dof_friction_sens"]["n_sensitivity_columns"] == 2 + 11  # (q0, u0, 2*5+1 harmonic parameters)
    assert _finite_positive(data["numpy_twin_over_compiled_ratio"])
    assert data["numpy_twin_max_abs_difference_q"] < 1e-9
    assert set(data["target"]) >= {"met_plain", "met_with_sensitivities", "ns_per_step_1dof"}
    # the exact event-driven flow, one period on the converged orbits
    ev = data["event_measurements"]
    assert set(ev) == {f"event_{case}_{kind}" for case, kinds in (("1dof_friction", ("plain", "jac_fourier")),
                                                                   ("1dof_contact", ("plain", "jac_fourier")),
                                                                   ("full3_friction", ("plain", "jac")),
                                                                   ("full5_contact", ("plain", "jac"))) for kind in kinds}
    for key, m in ev.items():
        _check_stats(m)
        assert m["events_per_period"] >= 1, key
        assert m["events_per_second_median"] == pytest.approx(m["events_per_period"] / m["median_s"], rel=1e-12)
    # MS-HBM's subsystem (n_H = 5) and full shooting follow the same orbit: the same events per period
    for label, full in (("friction", "full3_friction"), ("contact", "full5_contact")):
        assert ev[f"event_1dof_{label}_plain"]["events_per_period"] == ev[f"event_{full}_plain"]["events_per_period"]
    assert all(s["success"] for name, s in data["states"].items() if name.endswith("_event"))
    assert set(data["summary"]["events_per_second"]) == set(ev)


def _wp_row(method, error, time_s, harmonics=None, steps=256, success=True):
    return {"method": method, "error": error, "time_s": time_s, "harmonics": harmonics, "steps": steps,
            "success": success, "regularisation_factor": None}


def test_workprecision_event_goal_and_grid():
    """The event-driven points of the work-precision grid, and the event-driven goal check: the cheapest
    MS-HBM (event) point at 1e-6 against the cheapest Moreau-Jean shooting point at 1e-3."""
    from mshbm_workflow import script_module

    bw = script_module("bench", "bench_workprecision")

    grid = {"shooting_steps": [128], "mixed_harmonics": [3], "mixed_steps": [512], "hbm_harmonics": [3],
            "hbm_regularisation_factors": [1.0], "event_shooting": True, "event_mixed_harmonics": [9, 27],
            "event_steps": 128}
    pts = [(m, o) for m, o in bw.points(grid) if o.get("integrator") == "event"]
    assert pts == [("shooting-event", {"steps": 128, "integrator": "event"}),
                   ("mshbm-event", {"harmonics": 9, "steps": 128, "integrator": "event"}),
                   ("mshbm-event", {"harmonics": 27, "steps": 128, "integrator": "event"})]
    assert all(bw.SOLVE_METHOD[m] in ("shooting", "mshbm") for m, _ in pts)
    assert not [1 for _, o in bw.points(dict(grid, event_shooting=False, event_mixed_harmonics=[]))
                if o.get("integrator") == "event"]

    rows = [_wp_row("shooting", 3e-3, 0.05, steps=512), _wp_row("shooting", 8e-4, 0.25, steps=2048),
            _wp_row("shooting", 6e-4, 0.54, steps=4096), _wp_row("shooting", 1e-4, 0.01, steps=64, success=False),
            _wp_row("mshbm-event", 6e-6, 0.17, 27), _wp_row("mshbm-event", 9e-7, 0.43, 61),
            _wp_row("mshbm-event", 2e-7, 0.65, 81), _wp_row("mshbm-event", 1e-9, 0.02, 99, success=False)]
    g = bw.event_goal(rows, {"mshbm_event_error": 1e-6, "shooting_error": 1e-3})
    assert g["mshbm_event"]["harmonics"] == 61 and g["shooting"]["steps"] == 2048  # not converged: ignored
    assert g["ratio"] == pytest.approx(0.25 / 0.43, rel=1e-14) and g["met"] is False and "why" not in g
    g = bw.event_goal(rows, {"mshbm_event_error": 1e-5, "shooting_error": 1e-3})
    assert g["mshbm_event"]["harmonics"] == 27 and g["met"] is True
    g = bw.event_goal(rows, {"mshbm_event_error": 1e-8, "shooting_error": 1e-3})
    assert g["ratio"] is None and g["met"] is False and "1e-08" in g["why"]
    g = bw.event_goal([r for r in rows if r["method"] == "shooting"], {})
    assert g["ratio"] is None and g["why"] == "MS-HBM (event) not in this sweep"
    eq = bw.equal_error_ratios(rows, [1e-3])[0]
    assert eq["mshbm-event"]["speedup_over_shooting"] == pytest.approx(0.25 / 0.17, rel=1e-14)


def test_bench_scaling_quick(quick_run):
    data = _from_quick_run(quick_run, "scaling")
    _check_machine(data)
    assert "damping_note" in data["system"] and data["system"]["harmonics"] == 5
    chain = data["chain"]
    assert set(chain) >= {"mshbm", "mshbm-intermediate", "hbm", "hbm-full", "shooting"}
    ns = [p["n"] for p in chain["mshbm"]["points"]]
    assert ns == [10, 100, 1000, 10_000]
    for m, res in chain.items():
        for p in res["points"]:
            _check_stats(p["solve"])
            _check_stats(p["amplitude_eval"])
            assert p["success"], (m, p["n"], p["message"])
            assert math.isfinite(p["amplitude_last"])
        if res["stopped"] is not None:
            assert isinstance(res["stopped"], str)
    exponent = data["mshbm_exponent_n_ge_1000"]
    assert isinstance(exponent, float) and math.isfinite(exponent)
    fe = data["fe_membrane"]
    pts = fe["mshbm"]["points"]
    assert pts and all(p["success"] and _finite_positive(p["solve_s"]) for p in pts)
    assert "target" in data and "exponent_le_1" in data["target"]


def test_bench_nlscaling_quick(tmp_path):
    data = _run("bench_nlscaling.py", tmp_path / "nlscaling.json")
    _check_machine(data)
    pts = data["sweep"]
    assert [p["m"] for p in pts] == [1, 2, 5, 10] and [p["n_N"] for p in pts] == [1, 2, 5, 10]
    for p in pts:
        _check_stats(p["solve"])
        assert p["success"], (p["m"], p["message"])
        assert 0.0 < p["stick_fraction_min"] <= p["stick_fraction_max"] < 1.0  # stick-slip at every element
        assert _finite_positive(p["breakdown"]["residual_and_jacobian_s"])
        assert p["breakdown"]["n_unknowns"] == 13 * p["m"]  # (2 n_h + 1 + 2) n_N with n_h = 5
    assert math.isfinite(data["exponent_m_ge_5"])
    big = data["large"]["10000x50"]
    assert big["success"] and _finite_positive(big["solve_s"]) and big["target_s"] == 30.0


@pytest.mark.parametrize("bench", ["pyharm", "pyharm_sweep"])
def test_bench_pyharm_reports_unavailable_with_both_outputs(tmp_path, bench):
    """Without a pyHarm environment the benchmarks against pyHarm still write their JSON (status and
    reason) and PNG, the outputs the workflow declares, instead of failing the workflow."""
    out = tmp_path / f"{bench}.json"
    env = dict(os.environ, MPLBACKEND="Agg", PYHARM_PYTHON=str(tmp_path / "no-such-python"))
    proc = subprocess.run([sys.executable, str(SCRIPTS / f"bench_{bench}.py"), "--quick", "--out", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    data = json.loads(out.read_text())
    assert data["status"] == "unavailable" and "no-such-python" in data["error"]
    assert out.with_suffix(".png").stat().st_size > 500
