"""The event-driven fallback of the start ladder (:meth:`mshbm.route.driver.Route._event_fallback`).

The system is the stress suite's ``start-random10`` (seed 7, a 7-mass chain with a stop of restitution 0.9 on
DOF 1, forced at 0.6206 rad/s): its exact orbit has a near-grazing impact, and the Moreau-Jean map with 2048
steps has no periodic point there (Newton stalls at ``||R||_inf ~ 2e-3`` from every start of the ladder, 13 times
the one-step bound).  The exact event-driven flow has the orbit.  Parameters as drawn by
``mshbm_workflow.stress_cases.random_system`` (spring ``i`` joins mass ``i-1`` to mass ``i``).
"""
from __future__ import annotations

import numpy as np
import pytest

import mshbm
from mshbm import Contact, Friction, chain

MASSES = [41.91283647057952, 47.9921196694801, 1.0211736888852874, 0.05662274384421569, 5.783964292781453,
          0.6441894707174173, 0.060639394637366235]
STIFFNESS = [5.675857480717194, 0.10673802088205067, 17.599895399988604, 0.7910906913947554, 5.483843253164717,
             0.15314112843939479, 0.460508361021533]
DAMPING = [0.08131923679569703, 0.2931792462328052, 0.5876313754895935, 0.02933652823968178, 0.07723925855994332,
           0.04353643431865034, 0.023163080307609274]
OMEGA = 0.620604554281628
OPTS = dict(harmonics=5, steps=2048, stability=False)


def _system(elements):
    return chain(MASSES, STIFFNESS, DAMPING, forcing=[{"dof": 2, "amplitude": 5.454481722347405}],
                 elements=elements, name="start-random10")


@pytest.fixture(scope="module")
def grazing():
    return _system([Contact(1, 0.010223060602203507, 0.9, 3608.4060904752746, 0.0)])


@pytest.fixture(scope="module")
def fallback(grazing):
    return mshbm.solve(grazing, OMEGA, "mshbm", **OPTS)


def test_moreau_jean_has_no_periodic_point_and_the_fallback_is_certified(grazing, fallback):
    sol = fallback
    rec = sol.info["event_fallback"]
    # the Moreau-Jean ladder failed: its best residual is far above Newton's tolerance
    assert rec["applied"] and rec["moreau_residual"] > 1e-4
    assert rec["moreau_starts"] and not any(r["accepted"] for r in rec["moreau_starts"])
    # the event-driven answer: certified, and it says which integrator produced it
    assert sol.success and sol.certificate.passed and sol.residual <= 1e-10
    assert sol.info["integrator"] == "event" and sol.time_step is None  # no Moreau-Jean step: the exact flow
    assert "event_integrator" in sol.info  # the flow's own record (events, impacts, Moreau-Jean segments)
    assert "integrator='event'" in sol.message and "Moreau-Jean" in sol.message
    # the same answer as asking for the event-driven integrator directly (same discretisation, n_h = 5)
    direct = mshbm.solve(grazing, OMEGA, "mshbm", integrator="event", **OPTS)
    assert direct.success and "event_fallback" not in direct.info
    scale = float(np.max(np.abs(direct.q_hat)))
    assert float(np.max(np.abs(sol.q_hat - direct.q_hat))) <= 1e-8 * scale
    # an impacting orbit: the contact closes and the stop is never penetrated
    assert sol.info["event_integrator"]["impacts"] >= 1
    assert sol.certificate["non_penetration"].passed


def test_explicit_moreau_keeps_moreau_jean(grazing):
    sol = mshbm.solve(grazing, OMEGA, "mshbm-intermediate", integrator="moreau", **OPTS)
    assert not sol.success
    assert sol.info["event_fallback"] == {"applied": False, "reason": "integrator='moreau' given explicitly"}
    assert "integrator" not in sol.info and "not tried (integrator='moreau' given explicitly" in sol.message


def test_fallback_respects_max_time(grazing):
    # a budget the Moreau-Jean ladder spends on its own: the fallback is not started after it
    sol = mshbm.solve(grazing, OMEGA, "shooting", steps=2048, stability=False, max_time=0.5)
    assert not sol.success and sol.wall_time < 0.5 + 2.0  # the last iteration under way may finish
    assert sol.info["event_fallback"]["applied"] is False
    assert "time budget" in sol.message


@pytest.mark.slow
def test_no_fallback_without_impacts():
    # the same chain with a friction element at the same DOF, no Newton iteration allowed, so that every start
    # of the ladder fails: a system without contacts never switches integrator
    system = _system([Friction(1, 0.3, 2.0)])
    sol = mshbm.solve(system, OMEGA, "mshbm", max_iter=0, **OPTS)
    assert not sol.success
    assert "event_fallback" not in sol.info and "integrator" not in sol.info
    assert "event-driven" not in sol.message
    # with the stop instead, a failed Moreau-Jean ladder does try it (the condition is the contact, not the failure;
    # one Newton iteration per start: with max_iter = 0 the fallback is not run, as the "frequency" start is not)
    graz = _system([Contact(1, 0.010223060602203507, 0.9, 3608.4060904752746, 0.0)])
    sol2 = mshbm.solve(graz, OMEGA, "mshbm", max_iter=1, max_time=20.0, **OPTS)
    assert sol2.info["event_fallback"]["applied"] is True
    sol3 = mshbm.solve(graz, OMEGA, "mshbm", max_iter=0, **OPTS)
    assert not sol3.success and sol3.info["event_fallback"] == {"applied": False, "reason": "max_iter = 0"}
    # and a converged friction solve is plain Moreau-Jean
    ok = mshbm.solve(system, OMEGA, "mshbm", **OPTS)
    assert ok.success and "event_fallback" not in ok.info and ok.time_step is not None


def test_no_fallback_at_an_undamped_resonance():
    # a stop 1e6 m away never closes, and the undamped 2-mass chain is forced at its first eigenfrequency: no
    # periodic solution with any integrator (the certificate's undamped_resonance), so the fallback is not run
    system = chain([1.0, 1.0], 1.0, 0.0, forcing=[{"dof": 1, "amplitude": 1.0}], elements=[Contact(0, 1e6)])
    w = np.sqrt((3 - np.sqrt(5)) / 2)
    sol = mshbm.solve(system, w, "shooting", steps=1024, stability=False)
    assert not sol.success and "undamped_resonance" in sol.certificate.failed
    assert sol.info["event_fallback"] == {"applied": False, "reason": "undamped resonance of the linear structure"}
    assert "integrator" not in sol.info
