"""The a-posteriori truncation estimate bounds the harmonic truncation error and gates ``success``.

The 3-DOF friction oscillator (``examples/friction3.yaml``, undamped) one part in 10^6 above omega_1 / 3, with
omega_1 = sqrt((3 - sqrt 5) / 2) the first eigenfrequency of the linear subsystem (masses 1 and 2, the friction
DOF 0 held): the third harmonic of the linear DOFs is nearly resonant, and MS-HBM with n_h = 5 is 3.9 % off full
shooting (the stress suite's former WRONG rows), with n_h = 10 0.12 %.  The certificate's heuristic truncation
checks read 0.01-0.1 on both; the estimate ``truncation`` (the amplitude change against the re-solve at 2 n_h,
times 2: :mod:`mshbm.route.refine`) reads 7.9 % and 0.23 %, so the n_h = 5 answer is no success at the default
accuracy 1e-2 and its message names the estimate, the n_h = 10 one is; ``accuracy=1e-2`` from n_h = 5 refines
to n_h = 10.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import mshbm
from mshbm.certificate import DEFAULT_ACCURACY
from paper_systems import system as paper_system

OMEGA_1 = math.sqrt((3.0 - math.sqrt(5.0)) / 2.0)
OMEGA = OMEGA_1 / 3.0 * (1.0 + 1e-6)


def _amp_error(a, ref):
    return float(np.max(np.abs(a - ref)) / np.max(np.abs(ref)))


@pytest.fixture(scope="module")
def solves():
    system = paper_system("friction3")
    ref = mshbm.solve(system, OMEGA, "shooting", steps=8192, stability=False)
    low = mshbm.solve(system, OMEGA, "mshbm", harmonics=5, steps=2048, stability=False)
    high = mshbm.solve(system, OMEGA, "mshbm", harmonics=10, steps=2048, guess=low, stability=False)
    return system, ref, low, high


def test_truncation_estimate_bounds_the_error_and_gates(solves):
    _, ref, low, high = solves
    assert ref.success, ref.message
    err_low, err_high = _amp_error(low.amplitude, ref.amplitude), _amp_error(high.amplitude, ref.amplitude)
    # the n_h = 5 answer is off by more than the stress tolerance (3 %), the n_h = 10 one is not: truncation
    assert err_low > 0.03 and err_high < 2e-3
    for sol, err in ((low, err_low), (high, err_high)):
        est = sol.certificate["truncation"].value
        assert err <= est <= 3.0 * err  # an upper estimate, not a loose one
        acc = sol.certificate["accuracy"]
        assert acc.gating and acc.bound == DEFAULT_ACCURACY
        assert acc.value == pytest.approx(est + sol.certificate["time_discretisation"].value, rel=1e-12)
        assert sol.info["accuracy"]["estimate"] == acc.value
    # n_h = 5: every check of the discretised equations passes, the accuracy does not, and the message says why
    assert not low.success and low.certificate.failed == ["accuracy"]
    assert low.message.startswith("certificate failed: accuracy") and "largest: truncation" in low.message
    assert "option harmonics" in low.message
    assert high.success and "warning" not in high.message


def test_requested_accuracy_refines_the_harmonics(solves):
    system, ref, _, high = solves
    sol = mshbm.solve(system, OMEGA, "mshbm", harmonics=5, steps=2048, stability=False, accuracy=1e-2)
    assert sol.success and sol.harmonics == 10, sol.message
    assert _amp_error(sol.amplitude, ref.amplitude) < 1e-2
    info = sol.info["accuracy"]
    assert info["requested"] and info["accuracy"] == 1e-2 and info["passed"]
    assert [(lv["harmonics"], lv["refined"], lv["passed"]) for lv in info["levels"]] == \
        [(5, None, False), (10, "truncation", True)]
    assert info["estimate"] < 1e-2 and sol.certificate["accuracy"].bound == 1e-2
    # the same answer as the n_h = 10 solve
    assert _amp_error(sol.amplitude, high.amplitude) < 1e-9


def test_unreachable_accuracy_fails_naming_the_estimate(solves):
    system, _, _, _ = solves
    sol = mshbm.solve(system, OMEGA, "mshbm", harmonics=5, steps=2048, stability=False, accuracy=1e-12,
                      max_time=20)
    assert not sol.success and sol.certificate.failed == ["accuracy"]
    assert "certificate failed: accuracy" in sol.message and "refinement stopped" in sol.message
    assert len(sol.info["accuracy"]["levels"]) >= 2


@pytest.mark.parametrize("bad", [0.0, -1e-3, 0.7, float("nan"), "1e-2", True])
def test_bad_accuracy_is_an_input_error(bad):
    with pytest.raises(mshbm.InputError, match="accuracy"):
        mshbm.solve(paper_system("friction3"), 1.0, "mshbm", accuracy=bad)
