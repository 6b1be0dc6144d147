"""Wall-time budget of a solve (``max_time``: a solve fails with a message instead of
running on): Newton's time box, the option check, and a solve stopped by its budget."""
from __future__ import annotations

import time

import numpy as np
import pytest

import mshbm
from mshbm import Friction, chain
from mshbm.solvers import newton as newton_


def _slow_linear(x, jac=True):
    """R = x - 1 (converges in one step), 50 ms an evaluation."""
    time.sleep(0.05)
    return x - 1.0, (np.eye(x.size) if jac else None)


def test_newton_stops_at_the_deadline():
    with newton_.time_box(time.perf_counter() - 1.0):  # already past
        res = newton_.newton(_slow_linear, np.zeros(3))
    assert not res.success and res.message.startswith("time budget spent at iteration 0")
    assert res.nfev == 1
    res = newton_.newton(_slow_linear, np.zeros(3))  # outside the box: converges
    assert res.success and res.nit == 1


def test_time_box_keeps_the_earlier_deadline():
    t = time.perf_counter()
    with newton_.time_box(t + 100.0):
        with newton_.time_box(t + 1000.0):
            assert newton_.deadline() == pytest.approx(t + 100.0)
        with newton_.time_box(None):
            assert newton_.deadline() == pytest.approx(t + 100.0)
    assert newton_.deadline() is None


def _impact():
    return chain([1.0], 1.0, 0.02, forcing=[{"dof": 0, "amplitude": 1.0}],
                 elements=[mshbm.Contact(0, 0.1, 0.7, 1e4, 0.0)])


def test_solve_stopped_by_max_time_says_so():
    """A budget shorter than the set-up: the first Newton iteration does not begin, the solve fails at
    once with a message naming the budget (instead of the full ladder, which takes far longer)."""
    s = _impact()
    t0 = time.perf_counter()
    sol = mshbm.solve(s, 1.5, "shooting", steps=512, max_time=1e-9, stability=False)
    wall = time.perf_counter() - t0
    assert not sol.success
    assert "time budget" in sol.message and "max_time = 1e-09 s spent" in sol.message
    assert sol.iterations == 0
    ref = mshbm.solve(s, 1.5, "shooting", steps=512, stability=False)
    assert wall < max(5.0, 0.5 * ref.wall_time + 1.0)


def test_generous_budget_changes_nothing():
    s = chain([1.0, 1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 2, "amplitude": 5.0}],
              elements=[Friction(0, 0.8, 5.0)])
    a = mshbm.solve(s, 0.7, "mshbm", harmonics=3, steps=512, max_time=600.0)
    b = mshbm.solve(s, 0.7, "mshbm", harmonics=3, steps=512)
    assert a.success and b.success
    assert np.array_equal(a.x, b.x)


@pytest.mark.parametrize("bad", [0, -1.0, float("inf"), "10", True])
def test_max_time_is_checked(bad):
    s = _impact()
    with pytest.raises(mshbm.InputError) as exc:
        mshbm.solve(s, 1.5, "shooting", steps=256, max_time=bad)
    assert exc.value.key == "max_time"


def test_stress_harness_gives_each_solve_a_budget():
    """mshbm_workflow.stress_judge.run_solve passes max_time = min(solve_max_time_s, time left in the group): a
    solve beyond its budget fails at once with the budget in its message instead of timing out the group."""
    from mshbm_workflow import stress_judge

    ctx = stress_judge.Ctx({"tolerance": {}, "reference": {}, "solve_max_time_s": 1e-6})
    ctx.group_deadline = time.perf_counter() + 1000.0
    sol, exc, wall = stress_judge.run_solve(ctx, _impact(), 1.5, "shooting", {"steps": 512})
    assert exc is None and not sol.success
    assert "max_time = 1e-06 s spent" in sol.message
    # no per-solve limit: the group's remaining time (here 1000 s) is the budget, and the solve converges
    ctx = stress_judge.Ctx({"tolerance": {}, "reference": {}})
    ctx.group_deadline = time.perf_counter() + 1000.0
    sol, exc, wall = stress_judge.run_solve(ctx, _impact(), 1.5, "shooting", {"steps": 512})
    assert exc is None and sol.success
