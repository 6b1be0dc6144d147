"""A branch with a stretch of the parameter where the method has no solution (HBM on a lifting damper finds none
over a few per cent of omega, then again): the gap's natural-parameter steps fail down to ``ds_min`` there, and
wider jumps onwards (:meth:`mshbm.solvers.arclength_fallbacks.Fallbacks.wide_jump`) find the branch beyond the
stretch; the gap is recorded with its width, and no point lies inside the stretch."""
import numpy as np

from mshbm.solvers.arclength import continuation

HOLE = (1.0, 1.3)  # no root for lam in this open interval; x = lam^2 / 2 elsewhere


def _in_hole(lam):
    return HOLE[0] < lam < HOLE[1]


def _residual(x, lam):
    if _in_hole(lam):  # no root: 1 + (x - c)^2 > 0, and Newton from anywhere fails
        d = x[0] - 0.5 * lam ** 2
        return np.array([1.0 + d * d]), np.array([[2.0 * d + 1e-3]])
    return np.array([x[0] - 0.5 * lam ** 2]), np.array([[1.0]])


def _d_lam(x, lam):
    return np.array([0.0 if _in_hole(lam) else -lam])


def _solve_at(lam, x):
    return None if _in_hole(lam) else np.array([0.5 * lam ** 2])


def _run(lam0, lam_end, **kw):
    one = lambda x, lam: np.ones(1)  # noqa: E731
    return continuation(_residual, _d_lam, np.array([0.5 * lam0 ** 2]), lam0, lam_end, residual_scale=one,
                        unknown_scale=one, lam_scale=1.0, ds0=0.02, ds_max=0.2, max_points=300, predicted=0.02,
                        ds_rough=0.1, ds_min=1e-5, **kw)


def test_a_stretch_without_solutions_is_jumped_and_recorded_as_a_gap():
    res = _run(0.5, 2.0, solve_at=_solve_at)
    assert res.success, res.message
    lam = np.array([p.lam for p in res.points])
    assert lam[-1] == 2.0 and not any(_in_hole(v) for v in lam)
    for p in res.points:  # every point is a root
        assert abs(p.x[0] - 0.5 * p.lam ** 2) <= 1e-10
    gaps = [k for k in res.kinks if k.get("gap")]
    assert len(gaps) == 1 and res.counters["wide_jumps"] == 1
    g = gaps[0]
    # the gap starts within ds_min-ish of the hole's left edge and ends past its right edge, at a width of
    # WIDE_JUMP * 2^k times the first natural step 0.5 ds0 = 0.01: 0.02, 0.04, 0.08, 0.16, 0.32 -> 0.32
    assert HOLE[0] - 0.02 <= g["lam"] <= HOLE[0] and HOLE[1] <= g["lam_right"] <= HOLE[1] + 0.04
    assert abs((g["lam_right"] - g["lam"]) - 0.32) <= 1e-12
    assert "jumped" in g["reason"] and "gap" in res.message


def test_without_a_pointwise_solve_the_jump_by_newton_from_the_last_point_still_crosses():
    res = _run(0.5, 2.0)  # no solve_at: Newton at fixed lam from the last point beyond the hole converges
    assert res.success, res.message
    assert res.points[-1].lam == 2.0 and res.counters["wide_jumps"] == 1


def test_no_solution_up_to_the_end_stops_and_says_so():
    res = _run(0.5, 1.2, solve_at=_solve_at)  # the hole reaches past lam_end: nothing to jump to
    assert not res.success
    assert "no wider jump onwards up to lam = 1.2" in res.message
    assert max(p.lam for p in res.points) <= HOLE[0]
