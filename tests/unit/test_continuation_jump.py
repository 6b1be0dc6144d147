"""A gap's point that lands off the branch (:meth:`mshbm.solvers.arclength_fallbacks.Fallbacks.jumped`): on the
reduced cantilever with a tip stop (workflow/sweeps.yaml, beam-stop-cb, event shooting) the impacting branch crawls
at 1071.3 rad/s, and the crawl's gap, one step of 0.5 ds0 (9.4 rad/s) by Newton from the last point, lands on the
coexisting orbit without impacts (tip amplitude 7.3e-4 where the impacting branch goes on at 1.05e-3, solved by
Newton from its own points up to 1100 rad/s).  The gap's reason then says so instead of only "a fold there is not
traced".  (That crawl came from the event flow's sensitivities through its Moreau-Jean segments, now exact:
tests/unit/test_moreau_segment_jacobian.py.)  Such a point is first replaced by Newton from the last point at a
fraction of the step where that stays on the branch (:meth:`Fallbacks.nearer_on_branch`,
tests/integration/test_sweep_impacting_gap.py); where it does not, the jump is said, not refused."""
from types import SimpleNamespace

import numpy as np

from mshbm.solvers.arclength_fallbacks import JUMP_RTOL, Fallbacks


def _trace(points):
    t = Fallbacks()
    t.points, t.gap_from, t.counters, t.natural_reason = points, len(points), {}, "a crawl"
    return t


def _pt(x, lam):
    return SimpleNamespace(x=np.asarray(x, dtype=float), lam=float(lam))


def test_a_point_on_the_secant_is_not_a_jump():
    t = _trace([_pt([1.0, 2.0], 1.0), _pt([1.1, 2.2], 1.1)])
    q = _pt([1.3, 2.6 * (1 + 0.5 * JUMP_RTOL / 2)], 1.3)  # within JUMP_RTOL of the secant's prediction (1.3, 2.6)
    assert not t.jumped(t.points[-1], q, np.ones(2))
    assert "jumps" not in t.counters and t.natural_reason == "a crawl"


def test_a_point_off_the_secant_is_said():
    t = _trace([_pt([1.0, 2.0], 1.0), _pt([1.1, 2.2], 1.1)])
    q = _pt([0.7, 1.4], 1.3)  # the other branch: 0.55 x the prediction (scaled, relative to |p|)
    assert t.jumped(t.points[-1], q, np.ones(2))
    assert t.counters["jumps"] == 1
    assert "may be another solution" in t.natural_reason and "beyond lam = 1.1" in t.natural_reason


def test_the_offset_is_relative_to_the_size_of_the_last_point():
    t = _trace([_pt([1.0, 2.0], 1.0), _pt([1.1, 2.2], 1.1)])
    q = _pt([1.3, 2.6 + 0.5], 1.3)  # 0.5 off: a jump at size 2.5, not at size 250
    assert t.jumped(t.points[-1], q, np.ones(2))
    t = _trace([_pt([100.0, 200.0], 1.0), _pt([110.0, 220.0], 1.1)])
    assert not t.jumped(t.points[-1], _pt([130.0, 260.5], 1.3), np.array([1.0, 1.0]))
