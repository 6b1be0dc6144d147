"""``PeriodicSolution.initial_state``: the state at ``t_0`` without the time grid of all DOFs."""
import copy

import numpy as np

import mshbm
from tests import discretised
from paper_systems import OMEGA, impact_chain


def test_initial_state_is_row_zero_of_the_time_series():
    system = impact_chain(5, e=0.8)
    for method, kw in (("mshbm", dict(harmonics=5, steps=512)), ("hbm", dict(harmonics=7))):
        sol = discretised.solve(system, OMEGA, method, **kw)
        assert sol.success, (method, sol.message)
        fresh = copy.copy(sol)
        for key in ("q", "u"):  # cached full series (the stability analysis may have made them)
            fresh.__dict__.pop(key, None)
        q0, u0 = fresh.initial_state()
        assert "q" not in fresh.__dict__ and "u" not in fresh.__dict__  # the full series was not assembled
        scale_q, scale_u = float(np.max(np.abs(sol.q))), float(np.max(np.abs(sol.u)))
        np.testing.assert_allclose(q0, sol.q[0], rtol=0, atol=1e-14 * scale_q)
        np.testing.assert_allclose(u0, sol.u[0], rtol=0, atol=1e-14 * scale_u)
        if method == "mshbm":  # time-stepped DOFs: their own series, exactly
            td = np.asarray(sol.time_dofs)
            assert np.array_equal(q0[td], sol.q_time[0]) and np.array_equal(u0[td], sol.u_time[0])


def test_fast_path_builds_the_problem_once(monkeypatch):
    """A caller's guess that Newton alone does not take to a certified answer: the start ladder that follows
    reuses the problem of the first attempt (MS-HBM: no second condensation), and its answer is a solution of
    the problem built afresh."""
    from mshbm.route import driver

    system = impact_chain(5, e=0.8)
    calls = []
    real = driver.build_problem
    monkeypatch.setattr(driver, "build_problem", lambda *a, **k: calls.append(1) or real(*a, **k))
    opts = dict(harmonics=5, steps=512, max_iter=2)
    sol = discretised.solve(system, OMEGA, "mshbm", guess="zero", **opts)
    assert len(calls) == 1
    assert sol.info["starts"][0]["start"] == "guess"  # the ladder ran after the fast path
    assert sol.success, sol.message
    assert sol.certificate["residual"].passed
