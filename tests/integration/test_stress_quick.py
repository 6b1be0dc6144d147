"""The quick profile of the stress suite (workflow/scripts/stress/stress.py) and the
continuation fallback it measures (mshbm.route.continuation).

The quick profile must finish in < 90 s, report no WRONG outcome and no NaN in any number.  The profile's
run is the quick workflow's job of rule ``stress_quick`` (fixture ``quick_run``, tests/conftest.py): the same
command line (``stress.py --config workflow/stress.yaml --quick --jobs 2 --out ...``), run once per session
and read here, its wall time from the job's Snakemake benchmark file.
"""
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import mshbm
from paper_systems import OMEGA, friction_chain, impact_chain
from mshbm.api import solve_with_continuation
from mshbm.route.continuation import scaled_system

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "workflow" / "scripts" / "stress" / "stress.py"
CONFIG = ROOT / "workflow" / "stress.yaml"


def _no_nan(text):
    def reject(name):
        raise AssertionError(f"{name} in the JSON summary")

    return json.loads(text, parse_constant=reject)


@pytest.fixture(scope="module")
def quick(quick_run):
    """(summary, Markdown table, wall time in s, log) of the quick profile as the quick workflow ran it."""
    out = quick_run / "stress-quick"
    times = (quick_run / "logs" / "times" / "stress-quick.tsv").read_text().splitlines()
    header, row = times[0].split("\t"), times[-1].split("\t")
    wall = float(row[header.index("s")])  # the job's wall time (Snakemake's benchmark directive)
    summary = _no_nan((out / "summary.json").read_text())
    return summary, (out / "summary.md").read_text(), wall, (quick_run / "logs" / "stress-quick.log").read_text()


@pytest.mark.slow
def test_quick_profile_is_quick(quick):
    summary, _, wall, _ = quick
    assert wall < 90, f"quick stress profile took {wall:.0f} s"


def test_no_wrong_outcome(quick):
    summary, _, _, log = quick
    wrong = [r for r in summary["rows"] if r["outcome"] == "WRONG"]
    assert not wrong, json.dumps(wrong, indent=1)[:4000]
    assert summary["counts"]["WRONG"] == 0
    assert summary["timeouts"] == 0


def test_every_row_is_complete_and_finite(quick):
    summary, md, _, _ = quick
    rows = summary["rows"]
    cats = {r["category"] for r in rows}
    assert cats == {"resonance", "stiff", "starts", "random"}
    for r in rows:
        assert r["outcome"] in ("converged", "failed-with-diagnosis", "failed-certificate", "truncation-warned",
                                "WRONG")
        for key in ("case", "method", "options", "outcome", "message", "reference"):
            assert key in r, (key, r)
        for key in ("omega", "residual", "error", "time_s", "tolerance", "residual_recheck", "error_setvalued"):
            v = r.get(key)
            assert v is None or (isinstance(v, (int, float)) and math.isfinite(v)), (key, r)
        if r["outcome"] == "converged":
            assert r["residual"] is not None and r["time_s"] is not None
            assert r["error"] is not None or r["reference"].startswith("no reference"), r
            if r["error"] is not None:
                assert r["error"] <= r["tolerance"] + 0.05 + 1e-12
        if r["outcome"] == "failed-with-diagnosis":
            assert r["message"].strip(), r
        if r["outcome"] == "failed-certificate":  # names the failed checks
            assert r["certificate"] and all(c in r["message"] for c in r["certificate"]), r
        if r["outcome"] == "converged":
            assert r["certificate"] == [], r
        if r["outcome"] == "truncation-warned":  # outside the tolerance, and the solution's message warned of it
            assert r["error"] > r["tolerance"] and "warning: the harmonic truncation error" in r["message"], r
    assert not re.search(r"\b(nan|inf)\b", md, re.I)  # no NaN in the Markdown table either
    assert "| case | omega |" in md and "## Convergence from poor starts" in md
    assert "## Certificate failures" in md
    assert set(summary["counts"]) == {"converged", "failed-with-diagnosis", "failed-certificate",
                                      "truncation-warned", "WRONG"}


def test_singular_harmonic_is_solved_and_said(quick):
    """omega exactly on omega_r / k (H_LL singular; the full problem is well posed through the friction DOF):
    the resonant DOFs are kept as unknowns instead of condensed, the row converges and its message says so."""
    rows = [r for r in quick[0]["rows"] if "exactly" in str(r.get("point")) and r["method"] != "shooting"]
    assert rows
    for r in rows:
        # converged; at the stress suite's small n_H an HBM row may be outside the default accuracy (truncation
        # 4-9 %), which the accuracy check then names as the only failure
        assert r["outcome"] == "converged" or r["message"].startswith("certificate failed: accuracy ("), r
        assert "H_LL singular at harmonic" in r["message"] and "instead of being condensed" in r["message"], r


def test_start_rates_reported(quick):
    rates = quick[0]["start_rates"]
    assert rates and all(0 <= s["converged"] <= s["total"] for s in rates)
    with_c = {(s["method"], s["start"]): s["converged"] for s in rates if s["continuation"] == "with"}
    without = {(s["method"], s["start"]): s["converged"] for s in rates if s["continuation"] == "without"}
    assert all(with_c[k] >= without[k] for k in without)  # the fallback never makes things worse


def test_invalid_config_is_rejected(tmp_path):
    cfg = yaml.safe_load(CONFIG.read_text())
    cfg["tolerance"]["mshbm"] = "1e-2"  # a string (YAML 1.1 reads 1e-2 without a dot as text)
    bad = tmp_path / "stress.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    proc = subprocess.run([sys.executable, str(SCRIPT), "--config", str(bad), "--quick", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "tolerance.mshbm" in proc.stderr and "Traceback" not in proc.stderr


# ----------------------------------------------------------------------------- continuation
KW = dict(harmonics=5, steps=1024)


def test_continuation_rescues_zero_start():
    system = friction_chain(3)
    direct = mshbm.solve(system, OMEGA, "mshbm", guess="zero", **KW)
    sol = solve_with_continuation(system, OMEGA, "mshbm", guess="zero", strategies=("forcing",), **KW)
    assert sol.success, sol.message
    c = sol.info["continuation"]
    assert c["used"] == ("forcing" if not direct.success else None)
    ref = mshbm.solve(system, OMEGA, "mshbm", **KW)
    assert np.allclose(sol.amplitude, ref.amplitude, rtol=1e-6)


@pytest.mark.parametrize("strategy", ["transient", "omega"])
def test_continuation_from_far_frequency(strategy):
    """impact5 at omega = 0.3 from its solution at 0.6: direct Newton fails, the fallback succeeds."""
    system = impact_chain(5)
    kw = dict(KW, accuracy=False)  # the continuation of the discretised equations (n_H = 5, 1024 steps)
    far = mshbm.solve(system, 0.6, "mshbm", **kw)
    assert far.success
    direct = mshbm.solve(system, 0.3, "mshbm", guess=far, **kw)
    sol = solve_with_continuation(system, 0.3, "mshbm", guess=far, strategies=(strategy,), **kw)
    assert sol.success, sol.message
    if not direct.success:
        assert sol.info["continuation"]["used"] == strategy
        assert sol.info["continuation"]["stages"] >= 1
    # the answer is a solution of the original problem: same as shooting started from it
    ref = mshbm.solve(system, 0.3, "shooting", steps=4096, guess=sol)
    assert ref.success
    assert np.max(np.abs(sol.amplitude - ref.amplitude)) < 0.03 * np.max(ref.amplitude)


@pytest.mark.slow
def test_continuation_never_claims_success_it_did_not_get():
    system = impact_chain(5)
    sol = solve_with_continuation(system, 1.0, "mshbm", guess="zero", strategies=("linear", "forcing"),
                                  max_stages=6, **KW)
    if not sol.success:
        assert "continuation fallbacks failed" in sol.message
        assert sol.info["continuation"]["used"] is None
    with pytest.raises(mshbm.ConvergenceError):
        solve_with_continuation(system, 1.0, "mshbm", guess="zero", strategies=(), max_iter=1,
                                raise_on_failure=True, **KW)


def test_continuation_input_errors():
    system = friction_chain(3)
    with pytest.raises(mshbm.InputError) as info:
        solve_with_continuation(system, OMEGA, "mshbm", strategies=("nope",))
    assert info.value.key == "strategies"
    w1 = (3 - 5 ** 0.5) / 2  # first eigenvalue of K_LL (masses 2, 3 of the chain)
    with pytest.raises(mshbm.InputError) as info:
        # an explicit partition: its singular H_LL stays an error (the default one keeps the resonant DOFs)
        solve_with_continuation(system, w1 ** 0.5, "mshbm", partition=[0], **KW)
    assert info.value.key == "omega"
    with pytest.raises(mshbm.InputError) as info:
        solve_with_continuation(system, OMEGA, "mshbm", blas_threads="many")
    assert info.value.key == "blas_threads"


def test_scaled_system_shares_matrices_and_scales():
    system = friction_chain(3)
    s = scaled_system(system, forcing=0.5, friction=0.25)
    assert s.M is system.M and s.K is system.K
    assert np.array_equal(s.f_hat, 0.5 * system.f_hat)
    assert s.elements[0].normal_force == 0.25 * system.elements[0].normal_force
    assert system.elements[0].normal_force == 5.0 or system.elements[0].normal_force == 9.81  # unchanged
    # positive homogeneity of friction: (s f, s mu F_N) -> s x solution
    a = mshbm.solve(system, OMEGA, "shooting", steps=1024)
    b = mshbm.solve(scaled_system(system, forcing=2.0, friction=2.0), OMEGA, "shooting", steps=1024)
    assert np.allclose(b.amplitude, 2.0 * a.amplitude, rtol=1e-8)
