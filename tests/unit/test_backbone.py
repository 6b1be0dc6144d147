"""Backbones by EPMC (mshbm.backbone): closed forms for a linear chain and a Jenkins oscillator at n_h = 1,
and the peaks of forced responses."""
import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import brentq

import mshbm
from mshbm.backbone import backbone
from workflow_run import load_script

M3 = np.diag([1.0, 2.0, 1.5])
K3 = np.array([[3.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])


@pytest.mark.parametrize("mode", [0, 1, 2])
def test_linear_rayleigh_modal_frequency_and_damping(mode):
    """Rayleigh damping C = alpha M + beta K: EPMC gives the undamped omega_k and zeta_k = alpha/(2 omega_k) +
    beta omega_k / 2 at every amplitude."""
    alpha, beta = 0.02, 0.003
    s = mshbm.System(M3, alpha * M3 + beta * K3, K3, np.zeros(3))
    wk = np.sqrt(sla.eigh(K3, M3, eigvals_only=True)[mode])
    b = backbone(s, 1e-3, 1e-1, mode=mode, harmonics=3, points=5)
    assert b.success, b.message
    assert len(b) >= 5
    assert np.max(np.abs(b.omega / wk - 1)) < 1e-9
    assert np.max(np.abs(b.damping_ratio / (alpha / (2 * wk) + beta * wk / 2) - 1)) < 1e-9
    assert np.allclose(b.modal_amplitude[[0, -1]], [1e-3, 1e-1], rtol=1e-12)
    assert b.to_dict()["stable"] == [None] * len(b)


def test_undamped_linear_mode_is_certified_with_zero_damping():
    s = mshbm.System(M3, np.zeros((3, 3)), K3, np.zeros(3))
    b = backbone(s, 1e-2, 1.0, mode=1, harmonics=2, points=3)
    assert b.success, b.message
    assert np.max(np.abs(b.damping_ratio)) < 1e-14
    assert np.max(np.abs(b.omega / np.sqrt(sla.eigh(K3, M3, eigvals_only=True)[1]) - 1)) < 1e-12


def test_descending_range_through_unit_amplitude():
    """From a = 10 down to a = 0.01 (through a = 1: the parameter ln(a / a_ref) stays negative), the same
    linear mode at every point."""
    alpha, beta = 0.02, 0.003
    s = mshbm.System(M3, alpha * M3 + beta * K3, K3, np.zeros(3))
    w1 = np.sqrt(sla.eigh(K3, M3, eigvals_only=True)[0])
    b = backbone(s, 10.0, 0.01, harmonics=2, points=4)
    assert b.success, b.message
    assert "reached a_end = 0.01 in" in b.message
    assert np.allclose(b.modal_amplitude[[0, -1]], [10.0, 0.01], rtol=1e-12) and np.all(np.diff(b.modal_amplitude) < 0)
    assert np.max(np.abs(b.omega / w1 - 1)) < 1e-9


def _epmc_linear_reference(M, C, K, mode):
    """(omega, xi) with i omega an eigenvalue of lambda^2 M + lambda (C - xi M) + K, for the mode whose
    undamped frequency is the mode-th: the real part of that eigenvalue of the state matrix as a function of
    xi, zero by Brent's method."""
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    w0 = np.sqrt(sla.eigh(K, M, eigvals_only=True)[mode])

    def eig(xi):
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ (C - xi * M)]])
        lam = np.linalg.eigvals(A)
        lam = lam[lam.imag > 0]
        return lam[np.argmin(np.abs(lam.imag - w0))]

    xi = brentq(lambda x: eig(x).real, 0.0, 1.0, xtol=1e-15, rtol=1e-15)
    return eig(xi).imag, xi


def test_linear_nonproportional_damping():
    """A damper on the first mass only (non-proportional): EPMC's (omega, D = xi / (2 omega)) are those of the
    pencil with the shifted damping C - xi M having the eigenvalue i omega (reference by the state matrix);
    the complex eigenvalue of the original system agrees only to second order in the damping."""
    C = np.zeros((3, 3))
    C[0, 0] = 0.05
    s = mshbm.System(M3, C, K3, np.zeros(3))
    n = 3
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M3, K3), -np.linalg.solve(M3, C)]])
    for mode in range(3):
        w_ref, xi_ref = _epmc_linear_reference(M3, C, K3, mode)
        b = backbone(s, 1e-2, 1.0, mode=mode, harmonics=2, points=3)
        assert b.success, b.message
        assert np.max(np.abs(b.omega / w_ref - 1)) < 1e-9
        assert np.max(np.abs(b.damping_ratio / (xi_ref / (2 * w_ref)) - 1)) < 1e-9
        lam = np.linalg.eigvals(A)
        lam = lam[np.argmin(np.abs(lam - 1j * w_ref))]
        zeta = -lam.real / abs(lam)
        assert abs(b.damping_ratio[0] / zeta - 1) < 10 * zeta  # second order in the damping


def jenkins_describing_function(A, m, k, c, kt, muN):
    """Single-harmonic (n_h = 1) nonlinear mode of m q'' + c q' + k q + f_J = 0, q = A cos(omega t), with the
    Jenkins element (Masing loop): for A > A_s = muN / kt and cos(theta*) = 1 - 2 A_s / A,
    k_eq = kt / pi (theta* - sin(2 theta*) / 2), the first sine coefficient of f_J is -(4 muN / pi)(1 - A_s / A);
    omega^2 = (k + k_eq) / m and xi m = c + 4 muN (A - A_s) / (pi A^2 omega)."""
    As = muN / kt
    th = np.arccos(np.clip(1 - 2 * As / A, -1, 1))
    keq = np.where(A > As, kt / np.pi * (th - 0.5 * np.sin(2 * th)), kt)
    w = np.sqrt((k + keq) / m)
    xi = (c + np.where(A > As, 4 * muN / np.pi * (A - As) / (A ** 2 * w), 0.0)) / m
    return w, xi / (2 * w)


def test_jenkins_single_harmonic_closed_form():
    """HBM's Jenkins law is the exact (set-valued, return-mapping) elastic-perfectly-plastic law at the AFT
    samples; at n_h = 1 with N_s = 4096 samples its only error against the describing function is the sampled
    quadrature of the loop (O(N_s^-2): 1e-5 at 256, 6e-7 at 1024 in D), below 1e-6 here."""
    m, k, c, kt, muN = 2.0, 1.0, 0.01, 3.0, 0.3
    s = mshbm.System([[m]], [[c]], [[k]], [0.0], elements=[mshbm.Jenkins(0, 1.0, muN, tangential_stiffness=kt)])
    b = backbone(s, 0.1, 2.0, harmonics=1, steps=4096, points=3)
    assert b.success, b.message
    A = b.modal_amplitude / np.sqrt(m)  # phi = 1 / sqrt(m)
    assert A.min() < muN / kt < A.max()  # from stick into macro-slip
    w, D = jenkins_describing_function(A, m, k, c, kt, muN)
    assert np.max(np.abs(b.omega / w - 1)) < 1e-6
    assert np.max(np.abs(b.damping_ratio / D - 1)) < 1e-6
    assert np.allclose(b.amplitude[:, 0], A, rtol=1e-12)  # one harmonic: (max - min)/2 = A


@pytest.mark.parametrize("kw,key", [(dict(amplitude_start=-1.0), "amplitude_start"),
                                    (dict(amplitude_end=1e-3), "amplitude_end"),
                                    (dict(mode=3), "mode"), (dict(method="exact"), "method"),
                                    (dict(harmonics=0), "harmonics"), (dict(dofs=[7]), "dofs"),
                                    (dict(points=1), "points")])
def test_bad_input(kw, key):
    s = mshbm.System(M3, 0.01 * M3, K3, np.zeros(3))
    args = dict(amplitude_start=1e-3, amplitude_end=1e-2)
    args.update(kw)
    if "amplitude_end" in kw and kw["amplitude_end"] == 1e-3:
        args["amplitude_start"] = 1e-3
    with pytest.raises(mshbm.InputError) as e:
        backbone(s, **args)
    assert e.value.key == key


def _chain_jenkins(F):
    """Three unit masses in a wall-spring chain (k = 1, dashpots c = 0.002 parallel to the springs), a Jenkins
    joint (k_t = 0.5, mu N = 0.1) from mass 0 to the ground, forcing F cos(omega t) on mass 2."""
    return mshbm.chain([1.0, 1.0, 1.0], 1.0, 0.002, forcing=[{"dof": 2, "amplitude": F}] if F else (),
                       elements=[mshbm.Jenkins(0, 1.0, 0.1, tangential_stiffness=0.5)])


@pytest.mark.slow
def test_backbone_passes_through_forced_peaks():
    """Light damping: the peak of the forced response (pointwise mshbm.solve, HBM, n_h = 3) at five forcing
    levels from micro- to macro-slip lies on the backbone within 0.5 % in frequency, at the peak's modal
    amplitude a = |phi^T M Q_1| (the backbone's omega interpolated by a cubic spline in ln a).  The amplitude
    peak and the phase resonance differ by O(D^2) (D <= 3.4 % here: <= 0.12 %)."""
    from scipy.interpolate import CubicSpline
    from scipy.optimize import minimize_scalar

    from mshbm.methods.epmc import linear_modes

    s0 = _chain_jenkins(0.0)
    b = backbone(s0, 1e-2, 10.0, harmonics=3, points=40)
    assert b.success, b.message
    assert 0.03 < b.damping_ratio.max() < 0.035  # friction damping well above the dashpots' 0.05 %
    omega_bb = CubicSpline(np.log(b.modal_amplitude), b.omega)
    v = s0.M @ linear_modes(s0, 1)[1][:, 0]
    errors, amplitudes = [], []
    for F in (2e-4, 1e-3, 3e-3, 1e-2, 3e-2):
        s = _chain_jenkins(F)
        # descend in omega from above the backbone along the resonant branch (softening), warm starts
        w, guess, best = 1.02 * b.omega.max(), None, (-1.0, None, None)
        while w > 0.97 * b.omega.min():
            sol = mshbm.solve(s, w, method="hbm", harmonics=3, guess=guess, stability=False, accuracy=False)
            assert sol.success, sol.message
            if sol.amplitude[2] > best[0]:
                best = (sol.amplitude[2], w, sol)
            elif sol.amplitude[2] < 0.7 * best[0]:
                break
            guess, w = sol, 0.998 * w
        _, w0, sol0 = best
        sols = {}

        def minus_amplitude(w):
            sols[w] = mshbm.solve(s, w, method="hbm", harmonics=3, guess=sol0, stability=False, accuracy=False)
            return -sols[w].amplitude[2]

        wp = minimize_scalar(minus_amplitude, bracket=(1.002 * w0, w0, 0.998 * w0), tol=1e-9).x
        a = abs(v @ (sols[wp].q_hat[1] - 1j * sols[wp].q_hat[2]))
        assert b.modal_amplitude.min() < a < b.modal_amplitude.max()
        amplitudes.append(a)
        errors.append(wp / omega_bb(np.log(a)) - 1)
    assert np.all(np.diff(amplitudes) > 0)
    assert np.max(np.abs(errors)) < 5e-3, errors


def test_dlft_coulomb_single_harmonic():
    """Rigid Coulomb friction on a 1-DOF oscillator by DLFT (set-valued law) at n_h = 1: the friction force's
    first harmonic is -(4 mu N / pi) in phase with the velocity (no cosine part), so omega = sqrt(k / m) and
    xi m = c + 4 mu N / (pi A omega) (the describing function; also the free decay's energy loss 4 mu N A per
    cycle).  omega is exact; D deviates by DLFT's Lagrangian correction near the velocity reversals, which
    decays with the amplitude (1.2e-3 at A = 10 mu N / k, 4e-6 at A = 100 mu N / k): below 1e-5 from
    A = 100 mu N / k."""
    m, k, c, muN = 1.0, 1.0, 0.01, 0.01
    s = mshbm.System([[m]], [[c]], [[k]], [0.0], elements=[mshbm.Friction(0, 1.0, muN)])
    b = backbone(s, 1.0, 10.0, harmonics=1, steps=1024, points=3, method="dlft")
    assert b.success, b.message
    A = b.modal_amplitude
    assert np.max(np.abs(b.omega - 1.0)) < 1e-12
    D = (c + 4 * muN / (np.pi * A)) / (2 * m)
    assert np.max(np.abs(b.damping_ratio / D - 1)) < 1e-5


@pytest.mark.parametrize("method", ["hbm", "dlft"])
def test_contact_backbone_linear_below_gap_then_hardening(method):
    """A stop at gap g = 1 on a 1-DOF oscillator (omega_0 = 1, D_0 = c / 2): below the gap the backbone is the
    linear mode to 1e-9 (HBM: penalty contact, integrated on the gap's interpolant; DLFT: set-valued); once it
    impacts it hardens and the relative share of the dashpot's dissipation drops."""
    s = mshbm.System([[1.0]], [[0.01]], [[1.0]], [0.0], elements=[mshbm.Contact(0, 1.0, 1.0, penalty_stiffness=1e4)])
    b = backbone(s, 0.1, 3.0, harmonics=10, points=15, method=method)
    assert b.success, b.message
    amp = b.amplitude[:, 0]
    below = amp < 1.0 - 1e-9
    assert below.sum() >= 5
    assert np.max(np.abs(b.omega[below] - 1.0)) < 1e-9 and np.max(np.abs(b.damping_ratio[below] / 0.005 - 1)) < 1e-9
    assert b.omega[-1] > 1.4 and b.damping_ratio[-1] < 0.004


@pytest.mark.slow
def test_fe_beam_joint_limits():
    """The 100-DOF FE cantilever with a Jenkins joint at mid-span (workflow/scripts/bench/bench_backbone.py):
    at small amplitude the joint sticks and the backbone is the linear EPMC mode of (M, C, K + k_t e e^T) (the
    Rayleigh C is not proportional to it: reference by the state matrix, to 1e-9); at large amplitude the joint
    slides with a bounded force and omega tends to the free beam's first bending frequency."""
    from mshbm.methods.epmc import stuck_stiffness

    bench = load_script("bench/bench_backbone.py")
    s = bench.beam()
    b = backbone(s, 1e-6, 1e-1, harmonics=5, points=15)
    assert b.success, b.message
    M, C, K0 = s.M.toarray(), s.C.toarray(), stuck_stiffness(s)
    # reference: (omega, xi) with H = K0 - omega^2 M + i omega (C - xi M) singular, as the zero of the complex
    # f = 1 / (v^T H^-1 v) (v = M phi_0), by fsolve on two real unknowns from the undamped mode (the state matrix
    # M^-1 K of the fine mesh is too ill-conditioned for 1e-9)
    from scipy.optimize import fsolve

    lam0, Phi = sla.eigh(K0, M, subset_by_index=[0, 0])
    v = M @ Phi[:, 0]

    def f(p):
        w, xi = p
        z = 1.0 / (v @ np.linalg.solve(K0 - w * w * M + 1j * w * (C - xi * M), v))
        return [z.real, z.imag]

    w_ref, xi_ref = fsolve(f, [np.sqrt(lam0[0]), Phi[:, 0] @ C @ Phi[:, 0]], xtol=1e-14)
    assert abs(b.omega[0] / w_ref - 1) < 1e-9 and abs(b.damping_ratio[0] / (xi_ref / (2 * w_ref)) - 1) < 1e-9
    w_free = np.sqrt(sla.eigh(s.K.toarray(), M, eigvals_only=True, subset_by_index=[0, 0])[0])
    assert abs(b.omega[-1] / w_free - 1) < 1e-3 < abs(b.omega[0] / w_free - 1)
    assert b.damping_ratio.max() > 10 * b.damping_ratio[0]
