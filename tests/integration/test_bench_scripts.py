"""Smoke tests of the benchmark scripts (workflow/scripts/bench_*.py) in their --quick form.

They check that the scripts run standalone and write a JSON with the expected keys and finite
numbers plus a PNG.  No timing is asserted: speed is measured by the benchmarks, not by tests.
"""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = ROOT / "workflow" / "scripts"

pytestmark = pytest.mark.slow


def _run(script, out):
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(SCRIPTS / script), "--quick", "--out", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, f"{script} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    assert out.exists() and out.with_suffix(".png").exists()
    return json.loads(out.read_text())


def _finite_positive(x):
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


def _check_machine(data):
    assert isinstance(data.get("summary"), dict)  # read by workflow/scripts/bench_report.py
    m = data["machine"]
    for key in ("date", "cpu_count", "numpy_version", "scipy_version", "numba_version"):
        assert m.get(key) is not None, key


def _check_stats(s):
    assert s["repeats"] == len(s["times_s"]) >= 1
    assert all(_finite_positive(t) for t in s["times_s"])
    assert _finite_positive(s["median_s"]) and s["min_s"] <= s["median_s"]


def test_bench_kernel_quick(tmp_path):
    data = _run("bench_kernel.py", tmp_path / "kernel.json")
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


def test_bench_scaling_quick(tmp_path):
    data = _run("bench_scaling.py", tmp_path / "scaling.json")
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
