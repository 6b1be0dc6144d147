"""Linear system: every method reproduces (K - w^2 M + i w C)^-1 F."""
import numpy as np
import pytest

import mshbm
from mshbm import chain

OMEGA = 0.9


@pytest.fixture(scope="module")
def linear():
    sys = chain([1.0, 2.0, 1.5], [1.0, 2.0, 0.5], [0.1, 0.05, 0.2],
                forcing=[{"dof": 2, "amplitude": 5.0}, {"dof": 0, "amplitude": 1.0, "sin": 0.5, "harmonic": 2}])
    X = {}
    for k in (1, 2):
        F = np.zeros(3, dtype=complex)
        F[2 if k == 1 else 0] = 5.0 if k == 1 else 1.0 - 0.5j
        H = sys.K - (k * OMEGA) ** 2 * sys.M + 1j * k * OMEGA * sys.C
        X[k] = np.linalg.solve(H, F)
    exact = np.zeros((7, 3))
    for k in (1, 2):
        exact[2 * k - 1], exact[2 * k] = X[k].real, -X[k].imag
    return sys, exact


def test_hbm_exact(linear):
    sys, exact = linear
    for condense in (True, False):
        s = mshbm.solve(sys, OMEGA, "hbm", harmonics=3, condense=condense)
        assert s.success
        assert np.max(np.abs(s.q_hat - exact)) <= 1e-12 * np.max(np.abs(exact))


@pytest.mark.parametrize("method,part", [("mshbm", [0]), ("mshbm-intermediate", ([0], [1]))])
def test_mixed_agrees_with_hbm_1e8(linear, method, part):
    sys, exact = linear
    s = mshbm.solve(sys, OMEGA, method, harmonics=3, steps=2 ** 16, partition=part)  # O(h^2): 5e-9 here
    assert s.success
    rel = np.max(np.abs(s.q_hat - exact)) / np.max(np.abs(exact))
    assert rel <= 1e-8, rel


def test_shooting_second_order(linear):
    """theta = 1/2 is the trapezoidal rule on a linear system: order 2 in h."""
    sys, exact = linear
    errs = []
    for N in (256, 512, 1024):
        s = mshbm.solve(sys, OMEGA, "shooting", steps=N, harmonics=3)
        assert s.success and s.iterations <= 2
        errs.append(np.max(np.abs(s.q_hat - exact)) / np.max(np.abs(exact)))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.05), (errs, orders)
    assert errs[-1] < 5e-5
