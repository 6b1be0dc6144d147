"""The certificate's truncation estimates warn in the message of a certified solution.

The 3-DOF friction oscillator (``examples/friction3.yaml``, undamped) one part in 10^6 above omega_1 / 3, with
omega_1 = sqrt((3 - sqrt 5) / 2) the first eigenfrequency of the linear subsystem (masses 1 and 2, the friction
DOF 0 held): the third harmonic of the linear DOFs is nearly resonant, and MS-HBM with n_h = 5 is 3.9 % off full
shooting (the stress suite's former WRONG rows), with n_h = 10 0.1 %.  The n_h = 5 answer is the exact solution of
its discretisation and stays certified, but its message must say that its truncation estimates exceed their bound.
"""
from __future__ import annotations

import math

import numpy as np

import mshbm
from paper_systems import system as paper_system

OMEGA_1 = math.sqrt((3.0 - math.sqrt(5.0)) / 2.0)
OMEGA = OMEGA_1 / 3.0 * (1.0 + 1e-6)


def _amp_error(a, ref):
    return float(np.max(np.abs(a - ref)) / np.max(np.abs(ref)))


def test_truncation_warning_in_the_message():
    system = paper_system("friction3")
    ref = mshbm.solve(system, OMEGA, "shooting", steps=8192, stability=False)
    low = mshbm.solve(system, OMEGA, "mshbm", harmonics=5, steps=2048, stability=False)
    high = mshbm.solve(system, OMEGA, "mshbm", harmonics=10, steps=2048, guess=low, stability=False)
    assert ref.success and low.success and high.success
    # the n_h = 5 answer is off by more than the stress tolerance (3 %), the n_h = 10 one is not: truncation
    assert _amp_error(low.amplitude, ref.amplitude) > 0.03
    assert _amp_error(high.amplitude, ref.amplitude) < 0.01
    warned = low.certificate.warnings
    assert warned and set(warned) <= {"truncation_solution", "truncation_force"}
    assert "warning: the harmonic truncation error may exceed its bound" in low.message
    for name in warned:  # each estimate above its bound is named with its value
        c = low.certificate[name]
        assert c.value > c.bound and f"{name} {c.value:.3g} > {c.bound:.3g}" in low.message
    # no warning where every estimate is within its bound
    assert not high.certificate.warnings and "warning" not in high.message
