"""The solve route's internal budgets are counts of work, not wall time (mshbm.solvers.newton.work_box): the start
ladder, the "frequency" start, the event-driven fallback, the estimates' re-solves and the stride of a sweep's
estimates stop at the same point on every machine, whatever its load; only the caller's max_time is wall time."""
from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest

import mshbm
from mshbm import branch_accuracy, chain
from mshbm.route import driver, ladder
from mshbm.solvers import newton as newton_


def _linear(x, jac=True):
    """R = x^3 - 2 (Newton converges in some 6 iterations from 1)."""
    return x ** 3 - 2.0, (np.diag(3.0 * x ** 2) if jac else None)


def test_meter_counts_the_evaluations_and_stops_newton_at_its_limit():
    with newton_.work_box() as meter:
        free = newton_.newton(_linear, np.ones(2))
    assert free.success and meter.used == free.nfev >= 6
    stops = []
    for _ in range(2):
        with newton_.work_box(4) as outer:
            with newton_.work_box(100) as inner:  # the enclosing, smaller limit stays
                res = newton_.newton(_linear, np.ones(2))
        assert not res.success and res.message.startswith("work budget spent at iteration")
        assert inner.used == outer.used == res.nfev
        stops.append((res.nit, res.nfev, res.x.tobytes()))
    assert stops[0] == stops[1] and 4 <= stops[0][1] < free.nfev
    newton_.charge(5)  # no meter: nothing to charge, no error
    assert newton_.work_spent() is None



def _dear(x, jac=True):
    """:func:`_linear`, each evaluation charging 100 evaluations more (as an event-driven flow charges its work)."""
    newton_.charge(100)
    return _linear(x, jac)


def test_a_budget_of_newton_evaluations_scales_with_the_first_evaluation_s_cost():
    free = newton_.newton(_dear, np.ones(2))
    assert free.success and free.nfev >= 6
    with newton_.work_box(150) as meter:  # 150 evaluations: the first (101) leaves too little for a second
        stopped = newton_.newton(_dear, np.ones(2))
    assert not stopped.success and stopped.nit == 1 and meter.limit == 150
    with newton_.work_box(150, evaluations=20) as meter:  # at least 20 evaluations of 101 each
        res = newton_.newton(_dear, np.ones(2))
    assert res.success and res.x.tobytes() == free.x.tobytes()
    assert meter.limit == 20 * 101 and meter.used == 101 * res.nfev
    with newton_.work_box(150):  # the floor applies to the meter given it, not to an enclosing one
        with newton_.work_box(10_000, evaluations=20) as inner:
            res = newton_.newton(_dear, np.ones(2))
    assert inner.limit == 10_000 and not res.success

def _impact():
    return chain([1.0], 1.0, 0.02, forcing=[{"dof": 0, "amplitude": 1.0}],
                 elements=[mshbm.Contact(0, 0.1, 0.7, 1e4, 0.0)])


def _jumping_clock(monkeypatch, step):
    """time.perf_counter jumps ``step`` seconds forward at every call (a machine loaded beyond any wall-time box)."""
    real, calls = time.perf_counter, [0]

    def clock():
        calls[0] += 1
        return real() + step * calls[0]
    monkeypatch.setattr(time, "perf_counter", clock)


def _ladder_run(s):
    sol = mshbm.solve(s, 1.5, "shooting", steps=512, stability=False, accuracy=False)
    return sol, [(r["start"], r["iterations"], r["residual"]) for r in sol.info["starts"]]


def test_ladder_out_of_budget_skips_the_same_starts_whatever_the_clock(monkeypatch):
    s = _impact()
    monkeypatch.setattr(ladder, "LADDER_EVALUATIONS", 1)
    monkeypatch.setattr(ladder, "LADDER_FACTOR", 1.0)  # the budget: the first attempt's evaluations
    monkeypatch.setattr(driver, "EVENT_FALLBACK_EVALUATIONS", 0)  # the fallback tries no Newton iteration
    a, starts_a = _ladder_run(s)
    assert not a.success and "work budget of the start ladder" in a.message and "starts not tried:" in a.message
    skipped = a.message.split("starts not tried: ")[1].split(";")[0]
    assert skipped.startswith("regularisation, shifted") or skipped.startswith("shifted")
    # a loaded machine: every clock reading 1000 s later than the last (any wall-time box would be spent at once)
    _jumping_clock(monkeypatch, 1000.0)
    b, starts_b = _ladder_run(s)
    assert starts_b == starts_a
    assert b.message.split("starts not tried: ")[1].split(";")[0] == skipped
    assert np.array_equal(a.x, b.x) and a.residual == b.residual


def test_generous_budget_reaches_the_same_answer_on_a_loaded_clock(monkeypatch):
    """The default budgets, with the clock jumping 1000 s at every reading: the ladder (and the event-driven
    fallback, which solves this impact) end as on an idle machine."""
    s = _impact()
    ref, starts_ref = _ladder_run(s)
    _jumping_clock(monkeypatch, 1000.0)
    sol, starts = _ladder_run(s)
    assert ref.success and sol.success
    assert starts == starts_ref and np.array_equal(sol.x, ref.x)
    assert sol.info.get("integrator") == ref.info.get("integrator")


def test_event_fallback_budget_is_a_count(monkeypatch):
    s = _impact()
    monkeypatch.setattr(driver, "EVENT_FALLBACK_EVALUATIONS", 1)
    monkeypatch.setattr(ladder, "LADDER_EVALUATIONS", 1)
    monkeypatch.setattr(ladder, "LADDER_FACTOR", 1.0)
    out = []
    for step in (0.0, 1000.0):
        if step:
            _jumping_clock(monkeypatch, step)
        sol = mshbm.solve(s, 1.5, "shooting", steps=512, stability=False, accuracy=False)
        rec = sol.info.get("event_fallback") or {}
        out.append((sol.success, rec.get("applied"), rec.get("evaluations"), sol.residual))
    assert out[0] == out[1]
    assert out[0][1] is True and out[0][2] is not None and out[0][2] >= 1


def test_stride_from_evaluations_not_wall_time():
    # 60 points traced with 600 evaluations (10 a point); the first point's estimates 40 evaluations: the
    # estimates cost BUDGET = 0.5 times the trace at a stride ceil(40 / (0.5 * 10)) = 8, within [EVERY, P // 6]
    for wall in (1e-3, 1e3):  # the trace's wall time does not enter
        br = SimpleNamespace(points=[None] * 60, wall_time=wall)
        assert branch_accuracy._stride(br, 40, None, 600) == 8
        assert branch_accuracy._stride(br, 1, None, 600) == branch_accuracy.EVERY
        assert branch_accuracy._stride(br, 10 ** 6, None, 600) == 60 // 6
        assert branch_accuracy._stride(br, 40, 3, 600) == 3  # given: as given


def test_frequency_start_budget_counts_its_branch_correctors():
    """The branch traced by the "frequency" start stops at the start's work budget (arclength correctors are
    metered), not at a wall-time limit."""
    from mshbm.solvers.arclength_parts import Evaluator

    ev = Evaluator(lambda x, lam: (x - lam, np.eye(x.size)), lambda x, lam: -np.ones(x.size),
                   lambda x, lam: np.ones(x.size), lambda x, lam: np.ones(x.size), 1.0)
    with newton_.work_box(3) as meter:
        for _ in range(3):
            ev(np.zeros(2), 1.0, jac=False)
        assert meter.used == 3 and newton_.work_spent() == "work budget"


def test_event_flow_charges_its_work_to_the_meter():
    from mshbm.integrators.event import flow as event_flow
    from mshbm.methods.exact import ExactFlow

    system = chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}], name="linear")
    flow = ExactFlow(system, 0.7)
    with newton_.work_box() as meter:
        flow.simulate(0.0, np.concatenate([np.zeros(4), flow.osc(0.0)]), jac=True)
    assert flow.work > 0
    assert meter.used == pytest.approx(flow.work / event_flow.WORK_PER_EVALUATION, rel=1e-15)


def test_stride_from_the_coarse_anchors_not_the_first_point():
    # 120 points traced with 1200 evaluations (10 a point); the estimates cost 1 evaluation up to point 59 (the
    # contact open) and 200 from point 60 on.  The coarse anchors (stride 120 // 6 = 20: points 0, 20, ..., 100,
    # 119, and the amplitude peak 90) cost (1 * 3 + 200 * 5) / 8 = 125.4 on average: stride ceil(125.4 / 5) = 26 ->
    # capped at 120 // 6 = 20.  By the first point alone (1 evaluation) it was EVERY = 4: 30 estimates at 200.
    from mshbm.solvers.newton import charge

    amp = [2.0 if i == 90 else 1.0 + 1e-3 * i for i in range(120)]  # rising, one peak at point 90
    br = SimpleNamespace(points=[SimpleNamespace(amplitude=np.array([a])) for a in amp], bifurcations=[])
    seen = []

    class Ctx:
        def estimate(self, bp, lam):
            seen.append(lam)
            charge(1 if lam < 60 else 200)
            return {}

    found, every = branch_accuracy._coarse_estimates(br, Ctx(), None, list(range(120)), 1200)
    assert sorted(found) == seen == [0, 20, 40, 60, 80, 90, 100, 119]
    assert every == 20
    # a given stride: only the first point first, the stride as given
    seen.clear()
    found, every = branch_accuracy._coarse_estimates(br, Ctx(), 3, list(range(120)), 1200)
    assert sorted(found) == seen == [0] and every == 3
