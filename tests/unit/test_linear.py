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


def test_residual_omega_derivative_matches_dynamic_stiffness(linear):
    """For a linear system the HBM residual is H(omega) q_hat - f_hat: dR/domega = dH/domega q_hat."""
    sys, exact = linear
    prob, _ = mshbm.build_problem(sys, OMEGA, "hbm", harmonics=3, condense=False)
    x = np.random.default_rng(0).standard_normal(prob.n_unknowns)
    dR = mshbm.residual_omega_derivative(sys, OMEGA, "hbm", x, harmonics=3, condense=False)
    X = x.reshape(7, 3)
    expect = np.zeros_like(X)
    for k in range(1, 4):
        a, b = X[2 * k - 1], X[2 * k]
        dK = -2 * k * k * OMEGA * sys.M  # d/domega of K - (k omega)^2 M
        dC = k * sys.C                   # d/domega of k omega C
        expect[2 * k - 1] = dK @ a + dC @ b
        expect[2 * k] = -dC @ a + dK @ b
    assert np.allclose(dR, expect.reshape(-1), rtol=0, atol=1e-7)


def test_residual_omega_derivative_time_domain_methods(linear):
    """Consistency of the difference quotient for shooting and MS-HBM (two step sizes agree)."""
    sys, _ = linear
    for method, kw in (("shooting", {"steps": 512}), ("mshbm", {"steps": 512, "partition": [0], "harmonics": 3})):
        prob, _ = mshbm.build_problem(sys, OMEGA, method, **kw)
        x = prob.initial_guess()
        a = mshbm.residual_omega_derivative(sys, OMEGA, method, x, rel_step=1e-4, **kw)
        b = mshbm.residual_omega_derivative(sys, OMEGA, method, x, rel_step=1e-5, **kw)
        assert np.abs(a).max() > 0.1
        assert np.max(np.abs(a - b)) <= 1e-5 * np.max(np.abs(a))  # O(d^2) truncation


def test_sparse_condensation_matches_dense():
    """The sparse (symmetric-mode LU) path of the condensation gives the dense result."""
    from mshbm import Friction
    kw = dict(forcing=[{"dof": 599, "amplitude": 5.0}], elements=[Friction(0, 0.8, 5.0)])
    s = chain([1.0] * 600, 1.0, 0.05, sparse=True, **kw)
    d = chain([1.0] * 600, 1.0, 0.05, sparse=False, **kw)
    a = mshbm.solve(s, 0.9, "mshbm", harmonics=3, steps=1024)
    b = mshbm.solve(d, 0.9, "mshbm", harmonics=3, steps=1024)
    assert a.success and b.success
    assert np.max(np.abs(a.q_hat - b.q_hat)) <= 1e-12 * np.max(np.abs(b.q_hat))


def test_forcing_of_selected_dofs_is_the_same_columns():
    """System.forcing(t, omega, dofs) evaluates only those columns, bit for bit (MS-HBM uses it)."""
    system = chain([1.0, 2.0, 1.0, 3.0], stiffness=1.0, damping=0.1,
                   forcing=[{"dof": 1, "amplitude": 2.0, "harmonic": 1}, {"dof": 3, "amplitude": 0.5, "harmonic": 2}])
    t = np.linspace(0.0, 10.0, 257)
    full = system.forcing(t, 0.7)
    for dofs in ([0], [1, 3], [3, 1, 2]):
        assert np.array_equal(system.forcing(t, 0.7, dofs), full[:, dofs])
