"""A branch on which the arclength corrector converges only from very close (an inexact Jacobian, as of a stiff
penalty law's regularisation) is not crawled along to ``max_points``: the crawl is detected
(:meth:`mshbm.solvers.arclength_fallbacks.Fallbacks.crawled`) and bridged onwards by natural-parameter steps with the
pointwise solve, recorded as gaps; a genuine fold is traced and not taken for a crawl."""
import numpy as np

import mshbm.solvers.arclength_fallbacks as fallbacks
from mshbm.solvers.arclength import continuation

B, EPS, W = 9e-4, 1e-3, 0.2  # the curve lam = g(x) = x + B w(x) sin(x / EPS) near x = 1, B / EPS = 0.9: monotone


def _win(s):
    return np.exp(-((s - 1.0) / W) ** 8)


def _g(s):
    return s + B * _win(s) * np.sin(s / EPS)


def _ripple(x, lam):
    # the Jacobian omits the ripple (as a regularised law's Jacobian omits its fine scale): Newton contracts only
    # linearly, by up to B / EPS per iteration, and the corrector meets tol only from a start very near the curve:
    # its steps shrink to ~1e-5, far below ds0 but above ds_min (1e-7 here), and the branch crawls
    return np.array([lam - _g(x[0])]), np.array([[-1.0]])


def _solve_at(lam, x):
    """The root of g(s) = lam (g is increasing) by bisection: the pointwise solve."""
    a, b = lam - 2 * B, lam + 2 * B
    for _ in range(80):
        m = 0.5 * (a + b)
        a, b = (m, b) if _g(m) < lam else (a, m)
    return np.array([0.5 * (a + b)])


def _run(residual, x0, lam0, lam_end, **kw):
    one = lambda x, lam: np.ones(1)  # noqa: E731
    return continuation(residual, lambda x, lam: np.array([1.0]), np.array([x0]), lam0, lam_end, residual_scale=one,
                        unknown_scale=one, lam_scale=1.0, ds0=0.02, ds_max=0.2, max_points=300, predicted=0.02,
                        ds_rough=0.1, ds_min=1e-7, **kw)


def test_a_crawl_is_bridged_by_gaps_to_the_end_of_the_range():
    res = _run(_ripple, 0.0, 0.0, 2.0, solve_at=_solve_at)
    assert res.success, res.message
    lam = np.array([p.lam for p in res.points])
    assert lam[-1] == 2.0 and len(lam) <= 130  # without the crawl test: 300 points (max_points) at lam = 0.892
    crawls = [k for k in res.kinks if k.get("crawl")]
    assert res.counters["crawls"] == len(crawls) >= 1 and "gap" in res.message
    assert all(k["gap"] and "crawled" in k["reason"] for k in crawls)
    assert all(0.8 <= k["lam"] <= 1.2 for k in crawls)  # where the ripple is
    widths = [k["lam_right"] - k["lam"] for k in crawls]
    assert min(widths) >= 0.01 - 1e-12 and max(widths) <= 0.2  # from 0.5 ds0 lam_scale, doubled on a renewed crawl
    for p in res.points:
        assert abs(_ripple(p.x, p.lam)[0][0]) <= 1e-10


def test_without_the_crawl_test_the_branch_stops_at_max_points(monkeypatch):
    monkeypatch.setattr(fallbacks, "CRAWL_POINTS", 10 ** 6)
    res = _run(_ripple, 0.0, 0.0, 2.0, solve_at=_solve_at)
    assert not res.success and "crawls" not in res.counters
    assert len(res.points) == 300 and max(p.lam for p in res.points) < 0.9


def test_a_genuine_fold_is_traced_and_not_taken_for_a_crawl():
    # x^2 + lam - 2 = 0 from (x, lam) = (1, 1) towards lam = 3: a fold at lam = 2, then the sheet x < 0 back
    fold = lambda x, lam: (np.array([x[0] ** 2 + lam - 2.0]), np.array([[2.0 * x[0]]]))  # noqa: E731
    res = _run(fold, 1.0, 1.0, 3.0)
    assert not res.success and "left the parameter range" in res.message
    assert "crawls" not in res.counters and not [k for k in res.kinks if k.get("gap")]
    assert len(res.folds) == 1 and abs(res.folds[0]["lam"] - 2.0) <= 2e-3
