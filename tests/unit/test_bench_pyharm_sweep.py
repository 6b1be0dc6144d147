"""Pure helpers of the branch benchmark against pyHarm (workflow/scripts/bench/bench_pyharm_sweep.py): the
monotone pieces of a branch, the branch-to-branch amplitude difference (closed-form branches), and the
benchmark's systems read from the workflow config.  pyHarm itself is not needed (its environment is
not part of the test run; the benchmark's JSON is produced by the workflow)."""
from pathlib import Path

import numpy as np
import pytest
from workflow_run import load_script

ROOT = Path(__file__).resolve().parents[2]
bps = load_script("bench/bench_pyharm_sweep.py")


def test_monotone_segments_split_at_folds_and_repeats():
    assert bps.monotone_segments([0.0, 1.0, 2.0, 1.0, 0.0]) == [(0, 2), (2, 4)]   # fold at index 2
    assert bps.monotone_segments([3.0, 2.0, 1.0]) == [(0, 2)]
    assert bps.monotone_segments([0.0, 1.0, 1.0, 2.0]) == [(0, 1), (2, 3)]        # a stalled step
    assert bps.monotone_segments([0.0, 1.0, 0.5, 0.7, 0.6]) == [(0, 1), (1, 2), (2, 3), (3, 4)]
    assert bps.monotone_segments([1.0]) == [] and bps.monotone_segments([]) == []


def test_branch_difference_uniform_offset_is_exact():
    """b linear in omega (exact for linear interpolation), a = 1.02 b on another grid: 0.02 everywhere;
    a's points outside b's range are not compared."""
    wb = np.linspace(0.5, 1.0, 7)
    Ab = np.column_stack([1.0 + 2.0 * wb, 3.0 - wb])
    wa = np.linspace(0.4, 1.1, 15)
    Aa = 1.02 * np.column_stack([1.0 + 2.0 * wa, 3.0 - wa])
    d = bps.branch_difference(wa, Aa, wb, Ab)
    inside = (wa >= 0.5) & (wa <= 1.0)
    assert d["points_compared"] == int(inside.sum()) == 11
    # max_dof |0.02 A| / max_dof |A| = 0.02 exactly
    assert d["max"] == pytest.approx(0.02, rel=1e-12) and d["median"] == pytest.approx(0.02, rel=1e-12)
    assert d["omega_range"] == pytest.approx([wa[inside].min(), wa[inside].max()])


def test_branch_difference_relative_to_the_largest_dof():
    """The difference of a DOF with a small amplitude counts relative to the largest amplitude at that omega."""
    wb, Ab = np.array([0.0, 1.0]), np.array([[1.0, 10.0], [1.0, 10.0]])
    d = bps.branch_difference([0.5], [[1.5, 10.0]], wb, Ab)
    assert d["max"] == pytest.approx(0.05, rel=1e-14) and d["omega_at_max"] == 0.5


def test_branch_difference_through_a_fold_uses_the_nearest_sheet():
    """b turns at omega = 2 (a fold): lower sheet A = omega, upper sheet A = 4 - omega.  Points of a on
    either sheet match exactly; a point 10 % above the upper sheet is 10 % off, not compared with the
    lower sheet."""
    wb = np.array([0.0, 1.0, 2.0, 1.0, 0.0])
    Ab = np.array([[0.0], [1.0], [2.0], [3.0], [4.0]])
    d = bps.branch_difference([0.5, 1.5, 0.5], [[3.5], [2.5], [0.5]], wb, Ab)
    assert d["max"] == pytest.approx(0.0, abs=1e-15) and d["points_compared"] == 3
    d = bps.branch_difference([0.5], [[1.1 * 3.5]], wb, Ab)
    assert d["max"] == pytest.approx(0.1, rel=1e-12)


def test_branch_difference_interpolation_error_is_second_order():
    """a exact on a smooth curve A(omega) = 2 + sin(3 omega), b sampled with spacing h: the difference is
    linear interpolation's error, <= h^2/8 max|A''| / min A, and quarters when h halves."""
    def curve(w):
        return (2.0 + np.sin(3.0 * w))[:, None]

    wa = np.linspace(0.0, 1.0, 401)
    errs = []
    for m in (11, 21, 41):
        wb = np.linspace(0.0, 1.0, m)
        h = wb[1] - wb[0]
        d = bps.branch_difference(wa, curve(wa), wb, curve(wb))
        assert d["points_compared"] == wa.size
        assert d["max"] <= h * h / 8.0 * 9.0 / (2.0 + np.sin(3.0)) * (1 + 1e-9)
        errs.append(d["max"])
    assert 3.5 < errs[0] / errs[1] < 4.5 and 3.5 < errs[1] / errs[2] < 4.5, errs


def test_branch_difference_without_overlap_and_bad_shapes():
    d = bps.branch_difference([2.0, 3.0], [[1.0], [1.0]], [0.0, 1.0], [[1.0], [1.0]])
    assert d["points_compared"] == 0 and d["max"] is None
    with pytest.raises(ValueError, match="DOF counts"):
        bps.branch_difference([0.5], [[1.0, 2.0]], [0.0, 1.0], [[1.0], [1.0]])


def test_compare_evaluates_at_the_sparser_branch():
    dense = {"name": "dense", "omega": list(np.linspace(0.0, 1.0, 11)), "amplitude": [[1.0]] * 11}
    sparse = {"name": "sparse", "omega": [0.25, 0.75], "amplitude": [[1.1], [1.1]]}
    for a, b in ((dense, sparse), (sparse, dense)):
        d = bps.compare(a, b)
        assert d["evaluated_at"] == "sparse" and d["points_compared"] == 2
        assert d["max"] == pytest.approx(0.1, rel=1e-12)
    assert bps.compare({"name": "empty", "omega": [], "amplitude": []}, dense)["max"] is None


def test_pyharm_timeout_string():
    assert bps._timeout_str(60) == "00:00:01:00"
    assert bps._timeout_str(90061) == "01:01:01:01"


def test_pyharm_budget_is_ten_times_the_twin_within_bounds():
    assert bps.pyharm_budget("default", 1.52) == pytest.approx(15.2)  # ten times our same-law branch
    assert bps.pyharm_budget("default", 0.4) == 10.0                 # at least PYHARM_BUDGET_MIN
    assert bps.pyharm_budget("default", 7.0) == 20.0                 # at most PYHARM_BUDGET
    assert bps.pyharm_budget("default", None) == 20.0                # no twin time: the cap
    assert bps.pyharm_budget("quick", 3.79) == 20.0
    assert bps.pyharm_budget("full", 3.79) == 300.0                  # full: fixed


def test_reach_fraction_is_where_the_branch_first_nears_its_end():
    # 10 points; the largest omega 1.0 first approached (to 1e-4) at index 3: 3 / 10 of the points passed before
    w = [0.5, 0.8, 0.99, 0.99995, 1.0, 0.99999, 1.0, 1.0, 0.99996, 1.0]
    assert bps.reach_fraction(w) == pytest.approx(0.3)
    assert bps.reach_fraction([0.5, 0.6, 0.7]) == pytest.approx(2 / 3)
    assert bps.reach_fraction([]) is None


def test_specs_follow_the_workflow_branches():
    """Our runs of the default profile are the workflow's Fig. 9 branches (config `branches`): the same
    omega ranges, the same method options and max_points, and, as those curves, no per-point error estimates
    where the branch has none (`accuracy: false`, every run of the system: pyHarm's twins too); every same-law
    pair names existing runs."""
    from mshbm.io.yaml import load_yaml, read_text

    cfg = {b["name"]: b for b in load_yaml(read_text(ROOT / "workflow" / "config.yaml"))["branches"]}
    specs = {s["name"]: s for s in bps.specs("default")}
    for name in ("friction3", "impact5"):
        s, b = specs[name], cfg[name]
        assert s["omega"] == [float(w) for w in b["omega"]]
        ours = {r["name"]: r for r in s["ours"]}
        assert len(ours) == len(s["ours"]), name  # no curve replaces another of the same name
        twins = {a for a, _ in s["pairs"]}
        for label, opts in b["methods"].items():
            if label in twins:  # pyHarm's twin keeps the benchmark's settings (the same equations as pyHarm)
                continue
            expect = dict({k: v for k, v in opts.items() if k != "method"},
                          **({"max_points": b["max_points"]} if "max_points" in b else {}),
                          **({"accuracy": False} if b.get("accuracy") is False else {}))
            assert ours[label]["options"] == expect, (name, label)
            assert ours[label]["method"] == opts.get("method", label)
        if name == "impact5":  # pyHarm's twin on the impact chain: its n_H and the penalty law at the samples
            assert ours["hbm"]["options"]["harmonics"] == bps.N_H_IMPACT
            assert ours["hbm"]["options"]["penalty_quadrature"] == "samples"
        assert b.get("accuracy") is False   # the main run's curves make no estimates, so neither do ours here
        assert all(r["options"].get("accuracy") is False for r in s["ours"]), name
        names = set(ours) | {r["name"] for r in s["pyharm"]}
        assert all(a in names and p in names for a, p in s["pairs"])
    quick = {s["name"]: s for s in bps.specs("quick")}
    assert quick["friction3"]["omega"][1] < specs["friction3"]["omega"][1]
