"""Robust HBM-AFT with stiff penalty contact (eq. 45) and stiff arctan friction (eq. 42).

With penalty contact the AFT residual is piecewise linear in q_hat; for stiff k_c its
solution branch has turning points, so damped Newton stalls at ||R|| ~ 1-10.  The HBM
solver then follows the branch exactly (mshbm.methods.hbm.HBMProblem.newton_fallback).  These
tests check convergence on the paper's impact chains from the default (linear) start,
that the converged q_hat solves the HBM equations with exactly eq. (45) (independent
implementation below), and the approach to the shooting solution as k_c grows.
"""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mshbm
from tests import discretised
from mshbm import condensation, fourier
from mshbm.api import build_problem
from mshbm.solvers.newton import solve_problem
from paper_systems import OMEGA, friction_chain, impact_chain


def full_hbm_residual(system, omega, q_hat, steps):
    """HBM residual of all DOFs with the penalty law eq. (45), d_c = 0, written independently.

    ``H_k Q_k - F_k + FFT(lambda_N e_dof)_k`` per harmonic, complex form, scaled by ``1``.
    """
    n_h = (q_hat.shape[0] - 1) // 2
    Q = fourier.to_complex(q_hat)
    F = fourier.to_complex(system.forcing_hat(n_h))
    f = np.zeros((steps, system.n))
    q = fourier.ifft(q_hat, steps)
    for el in system.elements:
        g = el.gap - q[:, el.dof]
        lam = np.where(g <= 0.0, -el.penalty_stiffness * g, 0.0)  # eq. (45), d_c = 0
        f[:, el.dof] -= lam  # the contact pushes the DOF back
    Fn = fourier.to_complex(fourier.fft(f, n_h))
    M, C, K = (np.asarray(A.toarray() if hasattr(A, "toarray") else A) for A in (system.M, system.C, system.K))
    R = [condensation.dynamic_stiffness(M, C, K, k * omega) @ Q[k] - F[k] - Fn[k] for k in range(n_h + 1)]
    return np.max(np.abs(np.array(R)))


def penalty_ode_amplitudes(system, omega, y0, tol=1e-9):
    """Amplitudes of the periodic solution of the penalty-model ODE (eq. 45, d_c = 0), by shooting.

    ``M q'' + C q' + K q = f(t) - k_c (q_d - g0)_+ e_d``; Newton on ``y(T) - y(0)`` with the
    variational equations (the vector field is continuous, so no saltation).  Independent of HBM.
    """
    (el,) = system.elements
    n, m, T = system.n, 2 * system.n, 2 * np.pi / omega
    M, C, K = (np.asarray(A.toarray() if hasattr(A, "toarray") else A) for A in (system.M, system.C, system.K))
    Mi = np.linalg.inv(M)
    A0 = np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])
    Ac = A0.copy()
    Ac[n:, el.dof] -= Mi[:, el.dof] * el.penalty_stiffness
    fhat = system.forcing_hat(1)  # mean, cos and sin amplitudes (the chains are forced at omega only)

    def rhs(t, z):
        closed = z[el.dof] > el.gap
        A = Ac if closed else A0
        b = np.zeros(m)
        b[n:] = Mi @ (fhat[0] + fhat[1] * np.cos(omega * t) + fhat[2] * np.sin(omega * t))
        if closed:
            b[n:] += Mi[:, el.dof] * el.penalty_stiffness * el.gap
        S = z[m:].reshape(m, m)
        return np.concatenate([A @ z[:m] + b, (A @ S).ravel()])

    y = np.array(y0, dtype=float)
    for _ in range(20):
        sol = solve_ivp(rhs, (0.0, T), np.concatenate([y, np.eye(m).ravel()]), method="DOP853", rtol=1e-11, atol=1e-12)
        r = sol.y[:m, -1] - y
        if np.abs(r).max() < tol:
            break
        y = y - np.linalg.solve(sol.y[m:, -1].reshape(m, m) - np.eye(m), r)
    assert np.abs(r).max() < tol
    sol = solve_ivp(lambda t, z: rhs(t, np.concatenate([z, np.zeros(m * m)]))[:m], (0.0, T), y, method="DOP853",
                    rtol=1e-11, atol=1e-12, t_eval=np.linspace(0.0, T, 8001))
    return 0.5 * (sol.y[:n].max(axis=1) - sol.y[:n].min(axis=1))


def test_hbm_converges_to_the_penalty_model_as_n_h_grows():
    """HBM error = truncation error of the penalty model, not a solver artefact (5 masses, k_c = 1000)."""
    system = impact_chain(5, kc=1000.0)
    sols = {n_h: discretised.solve(system, OMEGA, "hbm", harmonics=n_h) for n_h in (9, 20, 40)}
    assert all(s.success for s in sols.values())
    s40 = sols[40]
    amp = penalty_ode_amplitudes(system, OMEGA, np.concatenate([s40.q[0], s40.u[0]]))
    errs = [np.max(np.abs(s.amplitude[[0, 4]] / amp[[0, 4]] - 1)) for s in sols.values()]
    # measured: 8.7e-2, 1.2e-2, 4e-4; the penalty model itself is 26 % (mass 1) from rigid impact here
    assert errs[0] > errs[1] > errs[2], errs
    assert errs[2] < 2e-3, errs


@pytest.fixture(scope="module")
def impact50_ref():
    return discretised.solve(impact_chain(50), OMEGA, "shooting", steps=4096)


@pytest.mark.parametrize("n_h", [3, 9, 20])
@pytest.mark.parametrize("kc", [100.0, 1000.0, 8000.0])
@pytest.mark.parametrize("n", [5, 50])
def test_impact_hbm_converges_from_default_start(n, kc, n_h):
    system = impact_chain(n, kc=kc)
    s = discretised.solve(system, OMEGA, "hbm", harmonics=n_h)
    assert s.success, s.message
    scale = max(1.0, np.abs(s.x).max())
    assert s.residual <= 1e-10 * scale
    # the full (uncondensed) HBM equations with exactly eq. (45) hold at the converged q_hat
    assert full_hbm_residual(system, OMEGA, s.q_hat, s.steps) < 1e-8 * max(1.0, np.abs(s.q_hat).max())
    assert min(s.info["closed_samples"]) >= 2  # the contact is active and sampled


def test_hbm_approaches_shooting_as_kc_grows(impact50_ref):
    ref = impact50_ref
    assert ref.success
    errs = []
    for kc in (10.0, 100.0, 1000.0, 8000.0):
        s = discretised.solve(impact_chain(50, kc=kc), OMEGA, "hbm", harmonics=20)
        assert s.success, s.message
        errs.append(abs(s.amplitude[0] / ref.amplitude[0] - 1))
    # measured: 0.61, 0.41, 0.16, 0.077 (mass 1; n_H = 20)
    assert all(a > b for a, b in zip(errs, errs[1:])), errs
    assert errs[-1] < 0.1, errs


def test_newton_alone_stalls_and_the_fallback_is_exact():
    system = impact_chain(5, kc=8000.0)
    prob, _ = build_problem(system, OMEGA, "hbm", harmonics=9)
    x0 = prob.initial_guess(None)
    plain = solve_problem(prob, x0, fallback=False)
    assert not plain.success and plain.residual_norm > 1.0  # the reported failure
    res = solve_problem(prob, x0)
    assert res.success, res.message
    assert res.info["fallback"] == "gap continuation"
    # the branch has turning points (why a line search on ||R|| cannot get there)
    path = prob.gap_continuation_path()
    assert path.success and path.folds > 0
    assert np.allclose(path.x, res.x, rtol=0, atol=1e-8 * np.abs(res.x).max())


def test_guess_homotopy_and_gap_continuation_agree():
    system = impact_chain(5, kc=8000.0)
    a = discretised.solve(system, OMEGA, "hbm", harmonics=20)
    ref = discretised.solve(system, OMEGA, "shooting", steps=2048)
    b = discretised.solve(system, OMEGA, "hbm", harmonics=20, guess=ref)
    assert a.success and b.success, (a.message, b.message)
    assert np.allclose(a.q_hat, b.q_hat, rtol=0, atol=1e-8 * np.abs(a.q_hat).max())


def test_uncondensed_hbm_uses_the_same_fallback():
    system = impact_chain(5, kc=8000.0)
    a = discretised.solve(system, OMEGA, "hbm", harmonics=9)
    b = discretised.solve(system, OMEGA, "hbm", harmonics=9, condense=False)
    assert a.success and b.success, (a.message, b.message)
    assert np.allclose(a.q_hat, b.q_hat, rtol=0, atol=1e-8 * np.abs(a.q_hat).max())


def test_success_only_with_a_small_residual():
    # d_c > 0 makes eq. (45) jump at g_N = 0: no exact zero may exist (measured: none found at d_c = 50)
    system = mshbm.chain([10.0] + [1.0] * 4, 1.0, 0.3, forcing=[{"dof": 4, "amplitude": 5.0}],
                         elements=[mshbm.Contact(0, 0.1, 1.0, 8000.0, 50.0)])
    s = discretised.solve(system, OMEGA, "hbm", harmonics=3)
    scale = max(1.0, np.abs(s.x).max())
    if s.success:
        assert s.residual <= 1e-10 * scale
    else:
        assert s.residual > 1e-10 * scale


@pytest.fixture(scope="module")
def friction3_ref():
    return discretised.solve(friction_chain(3), OMEGA, "shooting", steps=8192)


@pytest.mark.parametrize("kappa", [1e3, 1e4, 1e5])
def test_stiff_friction_hbm_converges(friction3_ref, kappa):
    system = friction_chain(3, kappa)
    for n_h in (3, 9, 20):
        s = discretised.solve(system, OMEGA, "hbm", harmonics=n_h)
        assert s.success, s.message
        assert s.residual <= 1e-10 * max(1.0, np.abs(s.x).max())
    err = np.max(np.abs(s.amplitude[[0, 2]] / friction3_ref.amplitude[[0, 2]] - 1))
    assert err < 0.01, err  # n_H = 20 (measured 0.3 %, 0.2 %, 0.15 %)
