"""Continuation through a family of solutions (a free direction, as the offset of a stuck Jenkins slider):
the free direction is found, held fixed by minimum-norm steps, and reported."""
import numpy as np

from mshbm.solvers.arclength import continuation
from mshbm.solvers.arclength_parts import free_directions, tangent


def _family(x, lam):
    """R = (x0 (1 + x0^2) - lam, 0): every x1 solves the second row (a zero row and column, like the
    periodicity row of a slider that sticks all period); x0 is the curve's own unknown."""
    R = np.array([x[0] * (1 + x[0] ** 2) - lam, 0.0])
    J = np.array([[1 + 3 * x[0] ** 2, 0.0], [0.0, 0.0]])
    return R, J


def test_free_direction_found_and_tangent_orthogonal_to_it():
    R, J = _family(np.array([0.5, 0.3]), 0.625)
    g, s, w = np.array([-1.0, 0.0]), np.ones(2), np.ones(2)
    F = free_directions(J, g, s, w, 1.0)
    assert F is not None and F.shape == (1, 2)
    assert abs(abs(F[0, 1]) - 1.0) < 1e-12 and abs(F[0, 0]) < 1e-12
    t = tangent(J, g, s, w, 1.0, free=F)
    assert abs(t[1]) < 1e-12 and t[2] > 0  # no component along the family, oriented to increasing lam
    assert abs(t[0] / t[2] - 1 / 1.75) < 1e-12  # dx0/dlam = 1 / (1 + 3 x0^2)
    # at a fold J is singular but [J, g] is not: no free direction
    assert free_directions(np.array([[0.0, 1.0], [0.0, 1.0]]), np.array([1.0, 0.0]), s, w, 1.0) is None


def test_continuation_holds_the_offset_and_reports_the_family():
    res = continuation(_family, lambda x, lam: np.array([-1.0, 0.0]), np.array([0.0, 0.3]), 0.0, 2.0,
                       residual_scale=lambda x, lam: np.ones(2), unknown_scale=lambda x, lam: np.ones(2),
                       lam_scale=1.0, ds0=0.05, ds_max=0.2, max_points=200)
    assert res.success, res.message
    x = np.array([p.x for p in res.points])
    lam = np.array([p.lam for p in res.points])
    np.testing.assert_allclose(x[:, 1], 0.3, atol=1e-14)  # the free unknown stays where it started
    np.testing.assert_allclose(x[:, 0] * (1 + x[:, 0] ** 2), lam, atol=1e-10)
    assert lam[-1] == 2.0 and np.all(np.diff(lam) > 0) and not res.folds
    assert res.counters["free_points"] >= len(res.points) and res.counters["free_dimension"] == 1


def test_gauge_picks_the_member_of_the_family():
    """A ``gauge`` (e.g. the centred stick force of a stuck element) moves every point of the family along its free
    direction to the member the rule picks, here x1 = x0 / 2; a gauge whose point is not a solution is refused."""
    def gauge(x, lam, F):
        assert F.shape == (1, 2) and abs(abs(F[0, 1]) - 1.0) < 1e-12  # the free direction, physical units
        return x + F[0] * (0.5 * x[0] - x[1]) / F[0, 1]

    res = continuation(_family, lambda x, lam: np.array([-1.0, 0.0]), np.array([0.0, 0.3]), 0.0, 2.0,
                       residual_scale=lambda x, lam: np.ones(2), unknown_scale=lambda x, lam: np.ones(2),
                       lam_scale=1.0, ds0=0.05, ds_max=0.2, max_points=200, gauge=gauge)
    assert res.success, res.message
    x = np.array([p.x for p in res.points])
    lam = np.array([p.lam for p in res.points])
    np.testing.assert_allclose(x[:, 1], 0.5 * x[:, 0], atol=1e-14)
    np.testing.assert_allclose(x[:, 0] * (1 + x[:, 0] ** 2), lam, atol=1e-10)
    assert res.counters["gauged"] >= len(res.points) and not res.folds  # (and trial points: the end)
    off = continuation(_family, lambda x, lam: np.array([-1.0, 0.0]), np.array([0.0, 0.3]), 0.0, 2.0,
                       residual_scale=lambda x, lam: np.ones(2), unknown_scale=lambda x, lam: np.ones(2),
                       lam_scale=1.0, ds0=0.05, ds_max=0.2, max_points=200, gauge=lambda x, lam, F: x + [0.1, 0.0])
    assert off.success and off.counters["gauge_rejected"] >= len(off.points) and "gauged" not in off.counters
    np.testing.assert_allclose([p.x[1] for p in off.points], 0.3, atol=1e-14)


def test_revisit_is_an_exact_repetition_of_an_earlier_point():
    """The guard against a continuation that cycles (seen on a reduced FE blade with a stop: the same 20 points
    traced again and again until max_points): a point that repeats an earlier one to 1e-6 in the scaled
    variables is named; a nearby but distinct point (the other side of a fold) and the last two points are not."""
    from types import SimpleNamespace

    from mshbm.solvers.arclength import _Trace

    pts = [SimpleNamespace(x=np.array([np.cos(a), np.sin(a)]), lam=float(a)) for a in np.linspace(0.0, 1.0, 11)]
    tr = SimpleNamespace(points=pts, lsc=1.0)
    w = np.ones(2)
    again = SimpleNamespace(x=pts[3].x * (1 + 1e-9), lam=pts[3].lam)
    assert _Trace.revisited(tr, again, w) == 3
    near = SimpleNamespace(x=pts[3].x + 1e-4, lam=pts[3].lam)
    assert _Trace.revisited(tr, near, w) is None
    last = SimpleNamespace(x=pts[-1].x.copy(), lam=pts[-1].lam)
    assert _Trace.revisited(tr, last, w) is None


def test_free_direction_with_the_parameter_derivative_rounded():
    """An exact null direction of J (a zero row and column) with dR/dlam outside J's range only by rounding
    (1e-9 of the largest singular value: an integrator's derivative in omega) is a family; an O(1) component
    outside the range (a fold's neighbour) is not."""
    J = np.array([[2.0, 0.0], [0.0, 0.0]])
    s, w = np.ones(2), np.ones(2)
    F = free_directions(J, np.array([-1.0, 2e-9]), s, w, 1.0)
    assert F is not None and F.shape == (1, 2) and abs(abs(F[0, 1]) - 1.0) < 1e-12
    assert free_directions(J, np.array([-1.0, 1e-3]), s, w, 1.0) is None
    # a nearly singular J (a regular point near an edge of the family: 1e-5) has no free direction
    assert free_directions(np.array([[2.0, 0.0], [0.0, 1e-5]]), np.array([-1.0, 0.0]), s, w, 1.0) is None
