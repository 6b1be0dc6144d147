"""The sweep stress suite (workflow/scripts/stress/sweeps.py, workflow/sweeps.yaml) on two of its cases, through
the script's own path: configuration and schema, a forked child per sweep under its CPU limit, the pointwise
solve checks, the JSON and Markdown report.

Both cases have closed forms: ``chain2-open/hbm`` never reaches its stop (the linear response of the 2-DOF
chain), ``chain3-jenkins-stuck/mshbm`` never slips (the chain with the Jenkins spring ``k_t`` added).
"""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from mshbm_workflow import sweep_runner, sweep_systems
from workflow_run import load_script

ROOT = Path(__file__).resolve().parents[2]
sweeps = load_script("stress/sweeps.py")  # the script's main(argv), as workflow/scripts/cli_job.py runs it

CONFIG = ROOT / "workflow" / "sweeps.yaml"
CASES = ["chain2-open/hbm", "chain3-jenkins-stuck/mshbm"]
#: error of each case's method against the closed form: HBM of a linear response is exact (Newton's tolerance);
#: MS-HBM integrates the element DOF by Moreau-Jean steps, 1024 per period: O((omega h)^2) = (2 pi / 1024)^2 = 3.8e-5
EXACT_TOL = {"chain2-open/hbm": 1e-8, "chain3-jenkins-stuck/mshbm": 1e-4}


def _strict_json(text):
    def reject(name):
        raise AssertionError(f"{name} in the JSON summary")

    return json.loads(text, parse_constant=reject)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweeps")
    code = sweeps.main(["--config", str(CONFIG), "--cases", ",".join(CASES), "--no-warmup", "--out", str(out)])
    assert code == 0
    return _strict_json((out / "summary.json").read_text()), (out / "summary.md").read_text()


def test_two_cases_reach_the_end_and_agree_with_closed_forms(report):
    data, _ = report
    rows = {r["name"]: r for r in data["rows"]}
    assert sorted(rows) == sorted(CASES)
    for name, r in rows.items():
        assert r["stop"] == "end" and r["reached"] and r["success"], (name, r["message"])
        assert r["omega_last"] == pytest.approx(r["omega_end"], rel=1e-9)
        assert r["points"] >= 10 and len(r["curve"]["omega"]) == len(r["curve"]["amplitude_max"]) == r["points"]
        assert r["curve"]["omega"][0] == r["omega_start"] and r["curve"]["omega"][-1] == r["omega_last"]
        assert 0.0 < r["cpu_s"] < r["cpu_limit_s"]
        # every point against the closed form (the contact is never reached / the Jenkins element never slips)
        assert r["exact_deviation"] < EXACT_TOL[name], (name, r["exact_deviation"])
        # ten certified pointwise solves, spread over the range, agreeing with the sweep
        assert len(r["checks"]) == 10 and r["checks_certified"] == 10
        assert r["max_deviation"] < 1e-6 and r["within"]
        w = sorted(c["omega"] for c in r["checks"])
        lo, hi = sorted((r["omega_start"], r["omega_end"]))
        assert w[0] == pytest.approx(lo, rel=1e-9) and w[-1] == pytest.approx(hi, rel=1e-9)
        assert np.all(np.diff(w) > 0.05 * (hi - lo))
    s = data["summary"]
    assert (s["sweeps"], s["reached"], s["within"]) == (2, 2, 2)
    assert data["summary_line"].startswith("2/2 sweeps reached the end of their range (100 %); 2/2 agree")


def test_markdown_table_lists_every_case(report):
    data, md = report
    assert data["summary_line"] in md
    for name in CASES:
        line = next(line for line in md.splitlines() if line.startswith(f"| {name} |"))
        assert "| yes |" in line and "10/10" in line


def test_cpu_limit_stops_a_sweep_and_keeps_its_points(tmp_path):
    """A limit far below the sweep's CPU time: the row says so, with the points traced until then."""
    code = sweeps.main(["--config", str(CONFIG), "--cases", "chain2-open/hbm", "--no-warmup", "--cpu-limit", "0.02",
                        "--out", str(tmp_path)])
    assert code == 0
    (r,) = _strict_json((tmp_path / "summary.json").read_text())["rows"]
    assert r["stop"] == "cpu-limit" and r["reached"] is False
    # 'within' judges the points traced (their pointwise checks), whether or not the sweep reached its end: how
    # many points 0.02 s of CPU buys depends on the machine's load, so it is checked for consistency, not a value
    devs = [c["deviation"] for c in r["checks"] if c["deviation"] is not None]
    assert r["within"] is bool(r["checks"] and len(devs) == len(r["checks"]) and max(devs) <= r["tolerance"])
    assert "CPU limit of 0.02 s reached" in r["message"]
    # the limit's timer (ITIMER_PROF, armed before the sweep's set-up) and the row's process_time (around the
    # sweep call) start at different instants: the row can read a little below the limit (0.183 s of 0.2 measured)
    assert 0.01 <= r["cpu_s"] < 5.0
    if r["points"]:
        assert r["omega_last"] < r["omega_start"]  # swept down, stopped before omega_end = 0.3
        assert r["omega_last"] > r["omega_end"]


def test_linear_reference_is_the_dense_solve():
    """The closed form the suite compares with: ``|(K - w^2 M + i w C)^{-1} f|`` (stuck: K + k_t e_0 e_0^T)."""
    cfg = sweeps.load_config(CONFIG)
    system, w1, _ = sweep_systems.build(cfg["systems"]["chain3-jenkins-stuck"], "s")
    assert w1 == pytest.approx(2 * math.sin(math.pi / 14), rel=1e-12)  # chain of 3 unit masses and springs
    w = 0.9
    K = np.array([[2.0 + 1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])  # k_t = 1 on DOF 0
    C = 0.05 * np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    q = np.linalg.solve(K - w ** 2 * np.eye(3) + 1j * w * C, [0.0, 0.0, 1.0])
    np.testing.assert_allclose(sweep_runner.linear_reference(system, w, stuck=True), np.abs(q), rtol=1e-12)


def test_bad_configuration_is_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(CONFIG.read_text().replace("checks: 10", "checks: 0"))
    assert sweeps.main(["--config", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "checks" in capsys.readouterr().err


class _Cert:
    def __init__(self, failed):
        self.failed = failed


class _Sol:
    def __init__(self, amplitude, success, failed=()):
        self.amplitude, self.success, self.message = np.asarray(amplitude, float), success, "stub"
        self.certificate = _Cert(list(failed))


class _Point:
    def __init__(self, omega, amplitude):
        self.omega, self.amplitude, self.solution = omega, np.asarray(amplitude, float), object()


class _Branch:
    def __init__(self, points):
        self.points = points
        self.omega = np.array([p.omega for p in points])


@pytest.mark.parametrize("point_certified", [True, False])
def test_a_coexisting_solution_is_reported_as_such_not_as_a_deviation(monkeypatch, point_certified):
    # at the sweep point (amplitude 1), the default start's certified solve lands on another solution (amplitude 4:
    # deviation |1 - 4| / 4 = 0.75); the solve from the sweep point stays on it (1 + 1e-9), certified or failing only on accuracy
    point = _Point(2.0, [1.0])

    def solve(system, omega, method, guess=None, **opts):
        if guess is None:
            return _Sol([4.0], True)
        return _Sol([1.0 + 1e-9], point_certified, () if point_certified else ("accuracy",))

    monkeypatch.setattr(sweep_runner.mshbm, "solve", solve)
    case = {"method": "hbm", "options": {}}
    (rec,) = sweep_runner.run_checks(None, case, _Branch([point]), 1, 10.0, 60.0, 0.005)
    assert rec["coexisting"] and rec["start"] == "sweep point"
    assert rec["independent_deviation"] == pytest.approx(0.75)
    assert rec["point_deviation"] == pytest.approx(1e-9)
    assert rec["success"] is point_certified
    # certified: the deviation is the point's own solve's; not certified: none (the check is not certified), never
    # the distance 0.75 to the other solution
    assert rec["deviation"] == (pytest.approx(1e-9) if point_certified else None)


def test_a_solve_from_the_sweep_point_that_leaves_it_is_no_coexistence(monkeypatch):
    point = _Point(2.0, [1.0])

    def solve(system, omega, method, guess=None, **opts):
        return _Sol([4.0], True) if guess is None else _Sol([2.0], False, ("accuracy",))

    monkeypatch.setattr(sweep_runner.mshbm, "solve", solve)
    (rec,) = sweep_runner.run_checks(None, {"method": "hbm", "options": {}}, _Branch([point]), 1, 10.0, 60.0, 0.005)
    assert not rec.get("coexisting") and rec["start"] == "default" and rec["deviation"] == pytest.approx(0.75)
