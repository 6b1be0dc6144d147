"""Exact amplitudes: the amplitude of a DOF given by Fourier coefficients is
(max - min)/2 of the Fourier series, not of a sample grid.  References: closed-form extrema of
linear responses, and the roots of the derivative polynomial (an independent method)."""
import numpy as np
import pytest

import mshbm
from mshbm import System, chain
from mshbm.result import PeriodicSolution


def roots_extrema(coef):
    """max, min of p(theta) = c0 + sum ck cos k theta + sk sin k theta from the roots of p'
    (z^n p'(theta) is a polynomial of degree 2n in z = exp(i theta))."""
    coef = np.asarray(coef, float)
    n = (coef.size - 1) // 2
    c = np.zeros(2 * n + 1, complex)                     # c[k + n]: coefficient of z^k in p
    c[n] = coef[0]
    for k in range(1, n + 1):
        c[n + k] = 0.5 * (coef[2 * k - 1] - 1j * coef[2 * k])
        c[n - k] = np.conj(c[n + k])
    d = np.array([1j * (j - n) * c[j] for j in range(2 * n + 1)])   # z^n p'(theta), ascending powers
    r = np.roots(d[::-1])
    theta = np.angle(r[np.abs(np.abs(r) - 1.0) < 1e-6])
    k = np.arange(1, n + 1)
    val = coef[0] + np.cos(np.outer(theta, k)) @ coef[1::2] + np.sin(np.outer(theta, k)) @ coef[2::2]
    return val.max(), val.min()


def solution(q_hat, time_dofs=(), q_time=None, steps=16):
    q_hat = np.asarray(q_hat, float)
    td = np.asarray(time_dofs, dtype=np.int64)
    t = np.linspace(0.0, 2 * np.pi, steps + 1)
    qt = np.zeros((steps + 1, td.size)) if q_time is None else q_time
    return PeriodicSolution(method="hbm", omega=1.0, harmonics=(q_hat.shape[0] - 1) // 2, steps=steps,
                            success=True, message="", iterations=0, nfev=0, residual=0.0, wall_time=0.0, t=t,
                            q_hat=q_hat, time_dofs=td, q_time=qt, u_time=qt, lam=np.zeros((steps + 1, 0)),
                            impulses=None, x=np.zeros(1))


# ----------------------------------------------------------------------------- closed form, HBM
@pytest.mark.parametrize("f1, f2, omega", [
    (1.0, 0.3, 0.37),      # interior extremum at cos(theta) = -A1 / (4 A2)
    (1.0, 0.05, 0.45),     # extrema at theta = 0, pi only
    (0.2, 1.0, 0.61),      # dominated by the second harmonic
    (1.0, -0.7, 0.29),
    (1.0, 0.25, 0.71),     # beyond the resonance of harmonic 2 (A2 < 0)
])
def test_hbm_amplitude_of_two_harmonic_linear_response_is_exact(f1, f2, omega):
    """Undamped 1-DOF oscillator (m = k = 1) forced by f1 cos(theta) + f2 cos(2 theta): the response
    A1 cos(theta) + A2 cos(2 theta), A_k = f_k / (1 - (k omega)^2), has the stationary points
    theta = 0, pi and cos(theta) = -A1/(4 A2)."""
    s = chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": f1}, {"dof": 0, "amplitude": f2, "harmonic": 2}])
    sol = mshbm.solve(s, omega, "hbm", harmonics=2)
    A1, A2 = f1 / (1 - omega ** 2), f2 / (1 - (2 * omega) ** 2)
    vals = [A1 + A2, -A1 + A2]
    x = -A1 / (4 * A2)
    if abs(x) <= 1:
        vals.append(A1 * x + A2 * (2 * x * x - 1))
    exact = 0.5 * (max(vals) - min(vals))
    assert sol.success
    assert sol.amplitude[0] == pytest.approx(exact, rel=1e-13, abs=1e-15)


def test_hbm_amplitudes_of_damped_three_harmonic_response():
    """A damped 3-DOF structure with forcing at harmonics 1, 2 (sine) and 3 plus a constant: every
    DOF's amplitude agrees with the roots of the derivative of its exact series (base: ~1e-6 off)."""
    M = np.diag([1.0, 2.0, 1.5])
    K = np.array([[3.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    C = 0.05 * K + 0.01 * M
    f_hat = np.zeros((7, 3))
    f_hat[0, 0], f_hat[1, 2], f_hat[4, 1], f_hat[5, 0], f_hat[6, 2] = 0.2, 1.0, 0.7, 0.4, -0.3
    s = System(M, C, K, f_hat)
    omega = 0.53
    sol = mshbm.solve(s, omega, "hbm", harmonics=3)
    ref = np.zeros_like(f_hat)
    ref[0] = np.linalg.solve(K, f_hat[0])
    for k in (1, 2, 3):
        Q = np.linalg.solve(K - (k * omega) ** 2 * M + 1j * k * omega * C, f_hat[2 * k - 1] - 1j * f_hat[2 * k])
        ref[2 * k - 1], ref[2 * k] = Q.real, -Q.imag
    for d in range(3):
        hi, lo = roots_extrema(ref[:, d])
        assert sol.amplitude[d] == pytest.approx(0.5 * (hi - lo), rel=1e-11)


# ----------------------------------------------------------------------------- the extremum finder
@pytest.mark.parametrize("seed, n_h", [(0, 1), (1, 2), (2, 3), (3, 5), (4, 8), (5, 12), (6, 20), (7, 40)])
def test_amplitude_of_random_series_matches_derivative_roots(seed, n_h):
    rng = np.random.default_rng(seed)
    q_hat = rng.standard_normal((2 * n_h + 1, 4)) / np.repeat(np.arange(1, n_h + 2), 2)[:2 * n_h + 1, None]
    amp = solution(q_hat).amplitude
    for d in range(4):
        hi, lo = roots_extrema(q_hat[:, d])
        assert amp[d] == pytest.approx(0.5 * (hi - lo), rel=1e-12)


@pytest.mark.parametrize("phase", [0.0, 0.0123, 1.0, 2.5])
def test_amplitude_of_a_narrow_peak(phase):
    """Dirichlet kernel sum_{k<=30} cos(k (theta - phase)): one peak of height 30 (width ~ 2 pi / 61)
    and minimum from the derivative roots, wherever the peak falls between samples."""
    n_h = 30
    q_hat = np.zeros((2 * n_h + 1, 1))
    k = np.arange(1, n_h + 1)
    q_hat[1::2, 0], q_hat[2::2, 0] = np.cos(k * phase), np.sin(k * phase)
    hi, lo = roots_extrema(q_hat[:, 0])
    assert hi == pytest.approx(30.0, rel=1e-12)
    assert solution(q_hat).amplitude[0] == pytest.approx(0.5 * (hi - lo), rel=1e-12)


def test_amplitude_of_two_nearly_equal_peaks():
    """Two maxima (theta = 0 and pi) that differ by 2e-9: the larger one is found."""
    q_hat = np.zeros((7, 1))
    q_hat[3, 0], q_hat[5, 0] = 1.0, 1e-9      # cos 2 theta + 1e-9 cos 3 theta: maxima 1 +- 1e-9
    hi, lo = roots_extrema(q_hat[:, 0])
    assert solution(q_hat).amplitude[0] == pytest.approx(0.5 * (hi - lo), rel=1e-15)


def test_constant_and_zero_series():
    q_hat = np.zeros((5, 2))
    q_hat[0] = [3.0, -1.0]
    np.testing.assert_array_equal(solution(q_hat).amplitude, [0.0, 0.0])


def test_time_stepped_dofs_use_their_time_series():
    """Time-stepped DOFs of shooting/MS-HBM are represented by the time series: their amplitude is
    (max - min)/2 of it; the Fourier DOFs beside them are exact."""
    q_hat = np.zeros((3, 2))
    q_hat[1] = [5.0, 2.0]
    qt = np.linspace(-1.0, 3.0, 17)[:, None]
    np.testing.assert_allclose(solution(q_hat, time_dofs=[0], q_time=qt).amplitude, [2.0, 2.0], rtol=1e-15)


def test_exact_solution_uses_event_driven_extrema():
    sol = solution(np.zeros((3, 2)))
    sol.info["amplitude_exact"] = np.array([0.25, 0.5])
    np.testing.assert_array_equal(sol.amplitude, [0.25, 0.5])
