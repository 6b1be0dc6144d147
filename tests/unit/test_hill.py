"""Hill's method (mshbm.hill) against exact multipliers.

* linear damped 2-DOF chain: the Floquet multipliers are ``exp(lambda T)`` of the eigenvalues
  ``lambda`` of ``[[0, I], [-M^-1 K, -M^-1 C]]``; the truncated Hill matrix is exact for linear systems;
* regularised (``arctan``) friction, 1 and 2 DOFs: the monodromy of the regularised ODE integrated
  with scipy's DOP853 at ``rtol = 1e-13`` (periodic orbit by Newton on the variational equations);
* the Hill matrix ``H_h`` is the Jacobian of the uncondensed HBM residual.
"""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import linear_sum_assignment

import mshbm
from tests import discretised
from mshbm import Friction, chain, hill
from mshbm.errors import InputError
from mshbm.methods.hbm import HBMProblem


def _match(a, b):
    """Largest distance between two multiplier sets after optimal pairing."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    D = np.abs(a[:, None] - b[None, :])
    r, c = linear_sum_assignment(D)
    return float(D[r, c].max())


def _linear_multipliers(system, omega):
    M, C, K = system.dense("M"), system.dense("C"), system.dense("K")
    n = system.n
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    return np.exp(np.linalg.eigvals(A) * 2 * np.pi / omega)


@pytest.mark.parametrize("filt", ["symmetric", "imag"])
@pytest.mark.parametrize("omega", [0.4, 1.3, 2.9])
def test_linear_damped_exact(omega, filt):
    s = chain([1.0, 2.0], [1.0, 3.0], [0.05, 0.1], forcing=[{"dof": 1, "amplitude": 1.0}])
    sol = discretised.solve(s, omega, "hbm", harmonics=5, stability=False)
    mu = hill.hill_multipliers(s, omega, sol.q_hat, sol.steps, filter=filt)
    ref = _linear_multipliers(s, omega)
    assert mu.shape == (4,)
    assert _match(mu, ref) < 1e-10
    assert np.abs(mu[0]) == pytest.approx(np.max(np.abs(ref)), rel=1e-12)  # sorted by modulus


def _regularised_monodromy(system, omega, x0):
    """Periodic orbit and monodromy of ``M q'' + C q' + K q = f(t) + f_reg(q, u)`` (friction only)."""
    M, C, K = system.dense("M"), system.dense("C"), system.dense("K")
    n, T = system.n, 2 * np.pi / omega
    Minv = np.linalg.inv(M)

    def rhs(t, y):
        q, u, Phi = y[:n], y[n:2 * n], y[2 * n:].reshape(2 * n, 2 * n)
        f = system.forcing(t, omega)[0] - C @ u - K @ q
        D = -C.copy()
        for el in system.elements:
            a = el.bound * 2 / np.pi
            ku = el.smoothing * u[el.dof]
            f[el.dof] -= a * np.arctan(ku)
            D[el.dof, el.dof] -= a * el.smoothing / (1 + ku * ku)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, Minv @ D]])
        return np.concatenate([u, Minv @ f, (A @ Phi).ravel()])

    def flow(x):
        r = solve_ivp(rhs, (0.0, T), np.concatenate([x, np.eye(2 * n).ravel()]), method="DOP853",
                      rtol=1e-13, atol=1e-14)
        return r.y[:2 * n, -1], r.y[2 * n:, -1].reshape(2 * n, 2 * n)

    x = np.asarray(x0, dtype=float)
    for _ in range(8):
        xe, Phi = flow(x)
        R = xe - x
        if np.max(np.abs(R)) < 1e-12:
            break
        x = x - np.linalg.solve(Phi - np.eye(2 * n), R)
    assert np.max(np.abs(R)) < 1e-12
    return np.linalg.eigvals(Phi)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["1dof", "2dof"])
def test_regularised_friction_against_ode_monodromy(case):
    omega = 0.9
    if case == "1dof":
        s = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Friction(0, 1.0, 0.3, 2.0)])
    else:
        s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.0}],
                  elements=[Friction(0, 1.0, 0.4, 2.0)])
    sol = discretised.solve(s, omega, "hbm", harmonics=25, stability=False)
    assert sol.success
    ref = _regularised_monodromy(s, omega, np.concatenate([sol.q[0], sol.u[0]]))
    for filt in ("symmetric", "imag"):
        mu = hill.hill_multipliers(s, omega, sol.q_hat, sol.steps, filter=filt)
        assert _match(mu, ref) < 1e-6
        big = ref[np.argmax(np.abs(ref))]
        assert abs(np.abs(mu[0]) - abs(big)) < 1e-6
    out = hill.assess_hbm(s, sol)
    assert out.stability_method == hill.HILL and out.stable is True
    assert "regularised" in out.info["stability"]["note"]


def test_hill_matrix_is_the_hbm_jacobian():
    s = chain([1.0, 1.0, 1.0], 1.0, 0.0, forcing=[{"dof": 2, "amplitude": 5.0}],
              elements=[Friction(0, 0.8, 5.0, 800.0)])
    omega = np.pi / 5
    sol = discretised.solve(s, omega, "hbm", harmonics=4, stability=False)
    assert sol.success
    prob = HBMProblem(s, omega, 4, sol.steps, condense=False)
    _, J = prob.residual(sol.q_hat.reshape(-1))
    _, _, H = hill.hill_matrices(s, omega, sol.q_hat, sol.steps)
    J = J.toarray()
    assert np.max(np.abs(J - H)) <= 1e-12 * np.max(np.abs(J))


def test_bad_input():
    s = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0}])
    with pytest.raises(InputError, match="filter"):
        hill.hill_exponents(s, 1.0, np.zeros((3, 1)), filter="nearest")
    with pytest.raises(InputError, match="q_hat"):
        hill.hill_matrices(s, 1.0, np.zeros((3, 2)))


def test_double_negative_multiplier():
    """1-DOF linear oscillator forced at twice its damped frequency: mu = -exp(-zeta T), double."""
    zeta = 0.02
    wd = np.sqrt(1 - zeta ** 2)
    s = chain([1.0], 1.0, 2 * zeta, forcing=[{"dof": 0, "amplitude": 1.0}])
    omega = 2 * wd
    sol = discretised.solve(s, omega, "hbm", harmonics=3, stability=False)
    for filt in ("symmetric", "imag"):
        mu = hill.hill_multipliers(s, omega, sol.q_hat, sol.steps, filter=filt)
        assert _match(mu, [-np.exp(-zeta * np.pi / wd)] * 2) < 1e-9


@pytest.mark.slow
def test_stiff_regularisation_no_spurious_multipliers(friction3):
    """The paper's 3-DOF friction chain (kappa = 800, stick-slip): the stiff 'stick' damping puts spurious
    real eigenvalues into the truncated Hill spectrum (real eigenvectors: centroid 0); they once gave six
    multipliers ~ 0.  With the copy check the largest pair is that of the lightly damped modes, close to
    the exact nonsmooth flow's (0.9666), and a verdict needs a margin above the estimated error."""
    omega = np.pi / 5
    exact = discretised.solve(friction3, omega, "hbm", harmonics=5)
    assert exact.stability_method == mshbm.stability.EXACT
    rho_exact = float(np.max(np.abs(exact.floquet_multipliers)))
    sol = discretised.solve(friction3, omega, "hbm", harmonics=40, stability=False)
    mu, err = hill.hill_multipliers(friction3, omega, sol.q_hat, sol.steps, full_output=True)
    assert abs(np.abs(mu[0]) - rho_exact) < 1e-2  # measured 0.9630 against 0.9666
    out = hill.assess_hbm(friction3, sol)
    assert out.stable is True and np.all(np.abs(mu) + err < 1)
    np.testing.assert_allclose(out.info["stability"]["multiplier_error"], err)


def test_no_verdict_within_the_error_estimate(monkeypatch):
    s = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Friction(0, 1.0, 0.3, 2.0)])
    sol = discretised.solve(s, 0.9, "hbm", harmonics=10, stability=False)
    mu, err = hill.hill_multipliers(s, 0.9, sol.q_hat, sol.steps, full_output=True)
    rho = np.abs(mu[0])  # 0.58: stable with a margin far above the error estimate
    assert hill.assess_hbm(s, sol).stable is True and err.max() < 1e-3
    monkeypatch.setattr(hill, "hill_multipliers", lambda *a, **k: (mu / rho * 0.999, np.full(mu.size, 0.01)))
    out = hill.assess_hbm(s, sol)
    assert out.stable is None and "not converged" in out.stability_reason
