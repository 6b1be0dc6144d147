"""The ``step_accuracy_size`` check of the certificate: an orbit accepted as periodic to one time
step's accuracy (a stalled Newton on an impacting orbit of Moreau-Jean shooting / MS-HBM,
:func:`mshbm.route.ladder.residual_accept`) is certified by :func:`mshbm.solve` only if the displacement
change of one step at the impact, ``h J``, is at most 2e-3 of the orbit's displacement scale ``D``.

* impact5 at omega = 1 rad/s (``tests/unit/test_ladder_fallbacks.py``): 2.3e-4, still accepted;
* the stress suite's random21 (4 masses, a stop of restitution 0 on DOF 3; MS-HBM n_h = 5, N = 2048): the
  step-accuracy acceptance of the 'linear' start had 3.3e-3 and was 23 % off the reference; now the
  certificate rejects it and the ladder goes on to a converged root of the same discretisation;
* random8 (58 masses, MS-HBM): 0.048, the accepted orbit 99 % off; now a diagnosed failure that names
  the check (the event-driven fallback applies and finds no certified orbit within its time box).
"""
from __future__ import annotations

import numpy as np
import pytest

import mshbm
from mshbm.certificate import STEP_ACCURACY_SIZE_BOUND, certify
from paper_systems import impact_chain

OPTS = dict(harmonics=5, steps=2048, stability=False)


def _random(index):
    from mshbm_workflow.stress_cases import random_system

    system, omega, _ = random_system(np.random.default_rng([20160501, index]), index, 200)
    return system, omega


@pytest.fixture(scope="module")
def impact5_at_1():
    system = impact_chain(5)
    sol = mshbm.solve(system, 1.0, "mshbm", **OPTS)
    return system, sol


def test_small_one_step_bound_still_accepted(impact5_at_1):
    system, sol = impact5_at_1
    assert sol.success, sol.message
    assert sol.message.startswith("periodic to one time step's accuracy")
    c = sol.certificate["step_accuracy_size"]
    assert c.gating and c.passed and c.bound == STEP_ACCURACY_SIZE_BOUND == 2e-3
    # the value is h J (one step times the largest velocity jump at an impact) over the certificate's D
    from mshbm.route.acceptance import impact_jump

    prob, _ = mshbm.build_problem(system, 1.0, "mshbm", harmonics=5, steps=2048)
    J = impact_jump(system, prob.solution_parts(np.asarray(sol.x)))
    h = 2.0 * np.pi / 2048
    assert sol.info["step_accuracy"]["step_change"] == pytest.approx(h * J, rel=1e-12)
    assert c.value == pytest.approx(h * J / sol.certificate.info["displacement_scale"], rel=1e-12)
    assert 5e-5 < c.value < 1e-3  # measured 2.3e-4
    # below the amplified displacement bound g h J of the acceptance (g >= 1)
    units = prob.residual_units()
    bq = float(np.max(np.asarray(sol.info["step_accuracy"]["bound"])[units == 0]))
    assert h * J <= bq


def test_check_gates_only_in_solve_and_scales_with_the_bound(impact5_at_1):
    system, sol = impact5_at_1
    prob, _ = mshbm.build_problem(system, 1.0, "mshbm", harmonics=5, steps=2048)
    rec = sol.info["step_accuracy"]
    bound, change = np.asarray(rec["bound"]), rec["step_change"]
    base = certify(prob, sol, 1e-10, {"bound": bound, "step_change": change})
    assert base.passed, base.describe_failures()
    # a 20x larger one-step change (and bound): residual and periodicity still within it, the size check not
    big = certify(prob, sol, 1e-10, {"bound": 20.0 * bound, "step_change": 20.0 * change})
    assert big["step_accuracy_size"].value == pytest.approx(20.0 * base["step_accuracy_size"].value, rel=1e-12)
    assert big["residual"].passed and big["periodicity"].passed
    assert big.failed == ["step_accuracy_size"]
    assert "step_accuracy_size" in big.describe_failures()
    # on a branch point (mshbm.sweep) the check is reported, not gating
    branch = certify(prob, sol, 1e-10, {"bound": 20.0 * bound, "step_change": 20.0 * change},
                     step_size_gating=False)
    assert branch.passed and not branch["step_accuracy_size"].gating
    assert branch.warnings == ["step_accuracy_size"]
    assert "one step's accuracy" in branch.describe_warnings() and "harmonic" not in branch.describe_warnings()
    # no step-accuracy acceptance: no such check
    assert "step_accuracy_size" not in certify(prob, sol, 1e-10)


@pytest.mark.slow
def test_random21_large_one_step_bound_not_certified():
    system, omega = _random(21)
    sol = mshbm.solve(system, omega, "mshbm", **OPTS)
    starts = {r["start"]: r for r in sol.info["starts"]}
    # the attempt accepted before (start 'linear', h J = 3.3e-3 D) is now rejected by the named check
    lin = starts["linear"]
    assert not lin["accepted"] and "step_accuracy_size" in lin["verdict"]
    assert "step_accuracy_size (0.00328 > bound 0.002" in lin["verdict"]
    # the ladder goes on to a Newton-converged root of the same discretisation (not a one-step acceptance),
    # whose every check of the discretised equations passes; it is no success: its harmonic truncation error
    # exceeds the default accuracy (n_h = 5 is 22 % off full shooting here), and the message says so
    assert "step_accuracy" not in sol.info and sol.residual <= 1e-10, sol.message
    assert "step_accuracy_size" not in sol.certificate
    assert not sol.success and sol.certificate.failed == ["accuracy"], sol.message
    trunc = sol.certificate["truncation"].value  # None: not estimated (the re-solves from it fail)
    assert (trunc is None or trunc > 1e-2) and "truncation" in sol.message
    # ... which is the exact event-driven flow's MS-HBM answer (same n_h, N; measured 9e-4)
    ev = mshbm.solve(system, omega, "mshbm", integrator="event", **OPTS)
    assert ev.certificate.failed == ["accuracy"] and "event_integrator" in ev.info and ev.time_step is None, \
        ev.message
    assert "time_discretisation" not in ev.certificate  # no time steps, no such estimate
    err = float(np.max(np.abs(sol.amplitude - ev.amplitude)) / np.max(np.abs(ev.amplitude)))
    assert err < 1e-2


@pytest.mark.slow
def test_random8_large_one_step_bound_fails_naming_the_check():
    system, omega = _random(8)
    sol = mshbm.solve(system, omega, "mshbm", max_time=90, **OPTS)
    # before: accepted at one step's accuracy with h J = 0.048 D (99 % off); now no Moreau-Jean attempt is
    # certified, each one-step acceptance rejected by the size check, and the event fallback finds none either
    assert not sol.success
    rec = sol.info["event_fallback"]
    assert rec["applied"] and not any(r["accepted"] for r in rec["moreau_starts"])
    sized = [r for r in rec["moreau_starts"] if "step_accuracy_size" in r["verdict"]]
    assert sized and "step_accuracy_size" in rec["moreau_message"]
    assert "step_accuracy_size" in sol.message
