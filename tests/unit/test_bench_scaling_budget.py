"""Which sizes the scaling benchmark (workflow/scripts/bench/bench_scaling.py) runs: a method with a largest n
runs every size up to it and none above whatever its timings, the others stop where the predicted CPU time
exceeds the limit, and every size not run is recorded with its reason (the report prints "not run").  The
solves are replaced by a cost model, so the decisions are checked without timing anything."""
from pathlib import Path

import pytest
from workflow_run import load_script

ROOT = Path(__file__).resolve().parents[2]


def _load(name):
    return load_script(f"bench/{name}.py")


bs = _load("bench_scaling")


def test_predict_uses_the_exponent_floor():
    pts = [(10, 0.026), (100, 0.79)]                         # measured slope 1.48
    assert bs._predict(pts, 1000) == pytest.approx(0.79 * 10 ** 1.4826, rel=1e-3)
    assert bs._predict(pts, 1000, floor=3.0) == pytest.approx(790.0)   # n^3: dense step matrices
    assert bs._predict([(100, 2.0)], 1000) == pytest.approx(2.0 * 10 ** 1.5)
    assert bs._predict([(100, 2.0)], 1000, floor=3.0) == pytest.approx(2000.0)
    assert bs._predict([], 1000) == 0.0


def _fake(cost):
    """``one_solve`` whose CPU and wall time are ``cost(method, n)`` (n read from the system's name)."""
    class Sys:
        def __init__(self, n, local):
            self.n, self.local = n, local

    def chain_system(n, local=False):
        return Sys(n, local)

    def one_solve(system, method, opts):
        t = cost(method, opts, system.n)
        return {"solve_s": t, "solve_cpu_s": t, "internal_wall_time_s": t, "amplitude_s": 0.0,
                "peak_extra_rss_mb": 0.0, "success": True, "iterations": 3, "message": "ok",
                "amplitude_mass1": 1.0, "amplitude_last": 1.0, "stick_fraction": None}, None
    return chain_system, one_solve


@pytest.mark.parametrize("overhead", [0.001, 0.05])
def test_capped_series_do_not_depend_on_timings(monkeypatch, overhead):
    """Shooting costs overhead + 0.8 s (n/100)^3: with the cap 100 it runs n = 10 and 100 whether n = 10 took
    2 ms or 50 ms (the prediction from n = 10 with exponent 3, 50 s, would drop n = 100), never n = 1000; the
    uncapped series with the same cost stops where the prediction exceeds the limit."""
    def cost(method, opts, n):
        if method == "shooting":
            return overhead + 0.8 * (n / 100) ** 3
        return 1e-3 * n / 10
    chain_system, one_solve = _fake(cost)
    monkeypatch.setattr(bs, "chain_system", chain_system)
    monkeypatch.setattr(bs, "one_solve", one_solve)
    ns = [10, 100, 1000, 10_000]
    res = bs.run_chain(ns, lambda n: 1, 30.0, lambda msg: None, local_max_n=1000, max_n={"shooting": 100})
    sh = res["shooting"]
    assert [p["n"] for p in sh["points"]] == [10, 100]
    assert [s["n"] for s in sh["skipped"]] == [1000, 10_000]
    assert "above 100" in sh["skipped"][0]["reason"]
    assert sh["skipped"][0]["predicted_s"] == pytest.approx((overhead + 0.8) * 1000)   # n^3 from n = 100
    assert [p["n"] for p in res["mshbm"]["points"]] == ns and res["mshbm"]["skipped"] == []
    assert [s["n"] for s in res["mshbm-local"]["skipped"]] == [10_000]
    # uncapped: the same cubic cost, dropped by the prediction (floor 3 for shooting's cost model)
    res = bs.run_chain(ns, lambda n: 1, 30.0, lambda msg: None, max_n={})
    sh = res["shooting"]
    ran = [p["n"] for p in sh["points"]]
    assert ran == ([10, 100] if (overhead + 0.0008) * 1000 <= 30.0 else [10])
    assert [s["n"] for s in sh["skipped"]] == [n for n in ns if n not in ran]
    assert "predicted" in sh["skipped"][0]["reason"]


def test_report_prints_not_run_with_the_reason():
    br = _load("bench_report")
    summary = {"time_table_s": {"mshbm": {"10": 0.01, "100": 0.02}, "shooting": {"10": 0.03}},
               "skipped_table": {"mshbm": {}, "shooting": {"100": "above 10, this profile's largest n"}},
               "mshbm_exponent_n_ge_1000": None}
    text = "\n".join(br.section_scaling({"summary": summary}, "sub"))
    assert "| shooting | 0.03 | not run |" in text
    assert "shooting at n = 100: above 10, this profile's largest n" in text
