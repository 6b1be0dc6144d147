"""The event-driven flow's deterministic work count and its budget (mshbm.integrators.event.flow.WORK_STEP).

The budgets of the stability analysis and of the model-substitution check are counts of the flow's work, not
wall time: the point where a budget ends a run is the same on every machine, whatever its load.
"""
import numpy as np
import pytest

import mshbm
from mshbm import chain, stability
from mshbm.integrators.event import EventError
from mshbm.integrators.event import flow as event_flow
from mshbm.methods.exact import ExactFlow, exact_periodic

from paper_systems import OMEGA


def test_work_of_a_period_without_elements_in_closed_form():
    # no element: no event row; every full sub-step but the last two is screened (``event_free_steps`` keeps two
    # sub-steps before the end for the one-by-one search), and those two are located
    system = chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}], name="linear")
    flow = ExactFlow(system, 0.7)
    flow.batch = True
    flow.simulate(0.0, np.concatenate([np.zeros(4), flow.osc(0.0)]), jac=True)
    D, N = flow.D, flow.substeps
    step = event_flow.WORK_STEP + 2.0 * D * D  # (lazy sensitivities: no column products per sub-step)
    locate = event_flow.WORK_LOCATE + 2.0 * D * D * flow.n_taylor
    assert (D, N) == (7, 128)
    assert flow.work == pytest.approx(N * step + 2 * locate, rel=1e-15)


def test_work_budget_ends_the_run_at_the_same_point(friction3):
    flow = ExactFlow(friction3, OMEGA)
    z0 = np.concatenate([[0.5, 0.0, 1.0, 0.3, -0.2, 0.0], flow.osc(0.0)])
    out = flow.simulate(0.0, z0, jac=True)
    w1 = flow.work
    assert len(out.events) >= 2  # stick-slip: events are charged
    flow.simulate(0.0, z0, jac=True)
    assert flow.work == 2.0 * w1  # the same run, the same work
    stops = []
    for _ in range(2):
        fl = ExactFlow(friction3, OMEGA)
        fl.work_limit = 0.5 * w1
        with pytest.raises(EventError, match="work budget of the event-driven simulation spent") as exc:
            fl.simulate(0.0, z0, jac=True)
        stops.append((fl.work, str(exc.value)))
    assert stops[0] == stops[1] and 0.5 * w1 < stops[0][0] < w1


def test_exact_solve_and_stability_fail_on_the_budget(impact5, monkeypatch):
    sol = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3, stability=False)
    ok = exact_periodic(impact5, OMEGA, guess=sol, samples=256)
    assert ok.success
    low = exact_periodic(impact5, OMEGA, guess=sol, samples=256, work_limit=1e5)
    assert not low.success and "work budget" in low.message
    assert stability.assess(impact5, sol).stability_method == stability.EXACT
    monkeypatch.setattr(stability, "EXACT_WORK_LIMIT", 1e5)
    reasons = {stability.assess(impact5, sol).stability_reason for _ in range(2)}
    (reason,) = reasons  # the same answer twice
    assert sol.stability_method == stability.STEP_MAP and sol.stable is None
    assert "exact flow failed" in reason and "work budget" in reason
