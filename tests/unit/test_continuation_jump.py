"""A gap's natural-parameter step that lands off the branch (:meth:`mshbm.solvers.arclength_fallbacks.Fallbacks.
jumped`): on the reduced cantilever with a tip stop (workflow/sweeps.yaml, beam-stop-cb, event shooting) the
impacting branch crawls at 1071.3 rad/s, and the crawl's gap, one step of 0.5 ds0 (9.4 rad/s) by Newton from the
last point, landed on the coexisting orbit without impacts (tip amplitude 7.3e-4 where the impacting branch goes on
at 1.05e-3, solved by Newton from its own points up to 1100 rad/s); the step is now quartered until the point lies on
the branch's secant (2.4 rad/s there), at most JUMP_RETRIES times, and a jump that is taken is said."""
from types import SimpleNamespace

import numpy as np

from mshbm.solvers.arclength_fallbacks import JUMP_RETRIES, JUMP_RTOL, Fallbacks


def _trace(points):
    t = Fallbacks()
    t.points, t.gap_from, t.counters, t.natural_reason = points, len(points), {}, "a crawl"
    return t


def _pt(x, lam):
    return SimpleNamespace(x=np.asarray(x, dtype=float), lam=float(lam))


def test_a_point_on_the_secant_is_taken():
    t = _trace([_pt([1.0, 2.0], 1.0), _pt([1.1, 2.2], 1.1)])
    q = _pt([1.3, 2.6 * (1 + 0.5 * JUMP_RTOL / 2)], 1.3)  # within JUMP_RTOL of the secant's prediction (1.3, 2.6)
    assert not t.jumped(t.points[-1], q, np.ones(2), 0.2)
    assert "jump_retries" not in t.counters


def test_a_jump_is_refused_jump_retries_times_then_taken_and_said():
    t = _trace([_pt([1.0, 2.0], 1.0), _pt([1.1, 2.2], 1.1)])
    q = _pt([0.7, 1.4], 1.3)  # the other branch: 0.55 x the prediction (scaled, relative to |p|)
    w = np.ones(2)
    refused = [t.jumped(t.points[-1], q, w, 0.2) for _ in range(JUMP_RETRIES + 1)]
    assert refused == [True] * JUMP_RETRIES + [False]
    assert t.counters["jump_retries"] == JUMP_RETRIES and t.counters["jumps"] == 1
    assert "may be another solution" in t.natural_reason
    t.gap_from += 1  # a new gap starts with its own retries
    assert t.jumped(t.points[-1], q, w, 0.2)


def test_outside_a_gap_nothing_is_judged():
    t = _trace([_pt([1.0], 1.0), _pt([1.1], 1.1)])
    t.gap_from = None
    assert not t.jumped(t.points[-1], _pt([5.0], 1.3), np.ones(1), 0.2)
