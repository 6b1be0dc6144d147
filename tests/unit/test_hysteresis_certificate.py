"""The certificate's ``hysteresis_periodicity`` (HBM with Jenkins elements, :mod:`mshbm.certificate.laws`).

* It passes (to rounding) on HBM's periodic march, 1-D and the 3-D Jenkins pair.
* It fails when the AFT's march is not periodic: the Jenkins law marched over one period only, from ``lambda = 0``
  at the last sample (the start's memory survives until the first slip), gives an HBM solution whose residual
  converges but whose force does not close over the period; the solution is then not a success and the message
  names the check.
* :func:`hysteresis_closure` against a hand-made loop: a 1-D loop closes; a loop shifted by ``d`` during a stick
  phase reports ``d / (mu N_0)``.
"""
import numpy as np
import pytest

import mshbm
from mshbm.certificate.laws import hysteresis_closure
from mshbm.elements.friction import Jenkins
from tests.unit.test_cone import W, jenkins_oscillator


def _check(sol):
    return next(c for c in sol.certificate.checks if c.name == "hysteresis_periodicity")


@pytest.mark.parametrize("pair", [True, False])
def test_periodic_march_passes(pair):
    sol = mshbm.solve(jenkins_oscillator(pair=pair), W, "hbm", harmonics=3, steps=256)
    assert sol.success, sol.message
    c = _check(sol)
    assert c.gating and c.passed and c.value <= 1e-13


def test_one_pass_march_fails(monkeypatch):
    def one_pass(self, s, basis=None):  # the law marched once from lambda = 0 at the last sample: not periodic
        s = np.asarray(s, dtype=float)
        V = np.eye(s.size) if basis is None else np.asarray(basis, dtype=float)
        kt, b = self.tangential_stiffness, self.bound
        lam, D = np.zeros(s.size), np.zeros((s.size, V.shape[1]))
        prev_l, prev_D, prev_k = 0.0, np.zeros(V.shape[1]), s.size - 1
        for k in range(s.size):
            l, row = prev_l - kt * (s[k] - s[prev_k]), prev_D - kt * (V[k] - V[prev_k])
            if abs(l) >= b:
                l, row = np.sign(l) * b, np.zeros(V.shape[1])
            lam[k], D[k] = l, row
            prev_l, prev_D, prev_k = l, row, k
        return lam, D

    monkeypatch.setattr(Jenkins, "history_law", one_pass)
    sol = mshbm.solve(jenkins_oscillator("q0", pair=False), W, "hbm", harmonics=3, steps=256, accuracy=False)
    c = _check(sol)
    assert c.gating and not c.passed and c.value > 1e-3
    assert not sol.success and "hysteresis_periodicity" in sol.message


def test_closure_of_hand_made_loops():
    kt, b, N = 2.0, 0.3, 400
    t = np.arange(N) / N
    s = np.cos(2 * np.pi * t)  # amplitude 1 > b / kt: slips twice per period
    lam = np.zeros(N)
    prev = 0.0
    for _ in range(2):
        for k in range(N):
            prev = lam[k] = np.clip(prev - kt * (s[k] - s[k - 1]), -b, b)
    assert hysteresis_closure(kt, b, s, lam) <= 1e-15
    stick = np.flatnonzero(np.abs(lam) < 0.5 * b)[:5]  # a few samples inside a stick phase
    bad = lam.copy()
    bad[stick] += 0.01
    assert hysteresis_closure(kt, b, s, bad) == pytest.approx(0.01 / b, rel=1e-12)
