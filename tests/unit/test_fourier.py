"""Fourier conventions (eqs. 1-5) and dynamic stiffness (eq. 24)."""
import numpy as np
import pytest

from mshbm import condensation, fourier


def test_round_trip_band_limited():
    rng = np.random.default_rng(1)
    n_h, N = 7, 64
    x_hat = rng.standard_normal((2 * n_h + 1, 3))
    x = fourier.ifft(x_hat, N)
    assert np.allclose(fourier.fft(x, n_h), x_hat, atol=1e-13)
    assert np.allclose(fourier.ifft(fourier.fft(x, n_h), N), x, atol=1e-13)


def test_ifft_matches_basis_and_derivative():
    rng = np.random.default_rng(2)
    n_h, N, omega = 4, 32, 0.7
    x_hat = rng.standard_normal((2 * n_h + 1, 2))
    t = np.arange(N) * 2 * np.pi / omega / N
    V = fourier.basis(t, omega, n_h)
    assert np.allclose(fourier.ifft(x_hat, N), V @ x_hat, atol=1e-13)
    # derivative by finite differences of the exact series
    d = 1e-6
    fd = (fourier.basis(t + d, omega, n_h) - fourier.basis(t - d, omega, n_h)) / (2 * d) @ x_hat
    assert np.allclose(V @ fourier.derivative(x_hat, omega), fd, atol=1e-8)
    assert np.allclose(fourier.dft_matrix(N, n_h) @ fourier.ifft(x_hat, N), x_hat, atol=1e-13)


def test_complex_form_and_dynamic_stiffness_eq24():
    rng = np.random.default_rng(3)
    n, n_h, omega = 3, 3, 1.3
    A = rng.standard_normal((n, n))
    M, C, K = A @ A.T + n * np.eye(n), np.diag(rng.random(n)), A + A.T + 5 * np.eye(n)
    x_hat = rng.standard_normal((2 * n_h + 1, n))
    Z = fourier.to_complex(x_hat)
    assert np.allclose(fourier.from_complex(Z), x_hat)
    for k in range(n_h + 1):
        kw = k * omega
        Hk = condensation.dynamic_stiffness(M, C, K, kw)
        # eq. (24), real block acting on (xc, xs)
        H24 = np.block([[K - M * kw ** 2, C * kw], [-C * kw, K - M * kw ** 2]])
        if k == 0:
            assert np.allclose(fourier.real_block(Hk, 0), K)
        else:
            assert np.allclose(fourier.real_block(Hk, k), H24)
            # and it is the harmonic balance of M x'' + C x' + K x
            xk = np.zeros_like(x_hat)
            xk[2 * k - 1:2 * k + 1] = x_hat[2 * k - 1:2 * k + 1]
            lhs = (fourier.derivative(fourier.derivative(xk, omega), omega) @ M.T
                   + fourier.derivative(xk, omega) @ C.T + xk @ K.T)
            assert np.allclose(lhs[2 * k - 1:2 * k + 1].reshape(-1), H24 @ xk[2 * k - 1:2 * k + 1].reshape(-1))


def test_fft_rejects_too_few_samples():
    with pytest.raises(ValueError):
        fourier.fft(np.zeros((8, 1)), 4)
