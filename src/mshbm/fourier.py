"""Fourier conventions of the paper (eqs. 1-5): transforms and DFT matrices only
(the dynamic stiffness and the condensation are in :mod:`mshbm.condensation`).

A T-periodic signal ``x(t)`` in ``R^n`` truncated to ``n_h`` harmonics is

    x(t) = x0 + sum_{k=1}^{n_h} xc_k cos(k omega t) + xs_k sin(k omega t) = V(t)^T x_hat

with ``omega = 2 pi / T``.  Coefficient arrays ``x_hat`` have shape
``(2 n_h + 1, n)`` with rows ``[x0, xc_1, xs_1, ..., xc_nh, xs_nh]``; flattened in
C order they are the paper's stacked vector.  ``x0`` is the mean (the factor
1/2 of ``J`` in eq. 1).

Internally harmonic ``k`` is also used in complex form ``X_k = xc_k - i xs_k``
(``X_0 = x0``), for which ``x(t) = Re sum_k X_k exp(i k omega t)`` and the
dynamic stiffness (24) becomes ``H_k = K - (k omega)^2 M + i k omega C``.

Samples are always taken on the uniform grid ``t_j = j T / N``, ``j = 0..N-1``.
"""
from __future__ import annotations

import functools

import numpy as np

__all__ = [
    "n_coeffs", "basis", "fft", "ifft", "derivative", "to_complex", "from_complex",
    "dft_matrix", "idft_matrix", "idft_derivative_matrix", "real_block",
]


def n_coeffs(n_h):
    """Number of real coefficients per DOF, ``2 n_h + 1``."""
    return 2 * n_h + 1


def basis(t, omega, n_h):
    """Scalar basis ``V(t)`` of eq. (2), shape ``(len(t), 2 n_h + 1)``."""
    t = np.asarray(t, dtype=float).reshape(-1)
    V = np.empty((t.size, n_coeffs(n_h)))
    V[:, 0] = 1.0
    for k in range(1, n_h + 1):
        V[:, 2 * k - 1] = np.cos(k * omega * t)
        V[:, 2 * k] = np.sin(k * omega * t)
    return V


def fft(x, n_h):
    """Fourier coefficients (eq. 1) of samples on the uniform grid.

    Parameters
    ----------
    x : ndarray, shape (N, ...)
        Samples ``x(t_j)``, ``t_j = j T / N``; the period's end point is excluded.
    n_h : int
        Harmonics to keep; needs ``N > 2 n_h``.

    Returns
    -------
    ndarray, shape (2 n_h + 1, ...)
    """
    x = np.asarray(x, dtype=float)
    N = x.shape[0]
    if N <= 2 * n_h:
        raise ValueError(f"{N} samples cannot resolve {n_h} harmonics (need > {2 * n_h})")
    X = np.fft.rfft(x, axis=0)
    out = np.empty((n_coeffs(n_h),) + x.shape[1:])
    out[0] = X[0].real / N
    out[1::2] = 2.0 * X[1:n_h + 1].real / N
    out[2::2] = -2.0 * X[1:n_h + 1].imag / N
    return out


def ifft(x_hat, N):
    """Samples ``V(t_j)^T x_hat`` on ``N`` uniform points (eq. 3), shape ``(N, ...)``."""
    x_hat = np.asarray(x_hat, dtype=float)
    n_h = (x_hat.shape[0] - 1) // 2
    if N <= 2 * n_h:
        raise ValueError(f"{N} samples cannot represent {n_h} harmonics (need > {2 * n_h})")
    X = np.zeros((N // 2 + 1,) + x_hat.shape[1:], dtype=complex)
    X[0] = x_hat[0] * N
    X[1:n_h + 1] = 0.5 * N * (x_hat[1::2] - 1j * x_hat[2::2])
    return np.fft.irfft(X, n=N, axis=0)


def derivative(x_hat, omega):
    """Coefficients of the time derivative, ``Omega x_hat`` (eqs. 4-5)."""
    x_hat = np.asarray(x_hat, dtype=float)
    n_h = (x_hat.shape[0] - 1) // 2
    k = (np.arange(1, n_h + 1) * omega).reshape((-1,) + (1,) * (x_hat.ndim - 1))
    out = np.zeros_like(x_hat)
    out[1::2] = k * x_hat[2::2]
    out[2::2] = -k * x_hat[1::2]
    return out


def to_complex(x_hat):
    """``(2 n_h + 1, ...)`` real coefficients to ``(n_h + 1, ...)`` complex ``X_k``."""
    x_hat = np.asarray(x_hat, dtype=float)
    Z = np.empty(((x_hat.shape[0] + 1) // 2,) + x_hat.shape[1:], dtype=complex)
    Z[0] = x_hat[0]
    Z[1:].real = x_hat[1::2]  # = x_hat[1::2] - 1j x_hat[2::2] for finite values, without temporaries
    Z[1:].imag = -x_hat[2::2]
    return Z


def from_complex(Z):
    """Inverse of :func:`to_complex`."""
    Z = np.asarray(Z)
    out = np.empty((2 * Z.shape[0] - 1,) + Z.shape[1:])
    out[0] = Z[0].real
    out[1::2] = Z[1:].real
    out[2::2] = -Z[1:].imag
    return out


def dft_matrix(N, n_h):
    """Matrix ``E`` with ``fft(x, n_h) = E @ x`` for samples ``x`` of shape (N,).

    Read-only; small matrices are cached (every HBM problem of a sweep uses the same), and the last large one
    (the refinement's re-solves build several problems of one size).
    """
    if N * (2 * n_h + 1) <= _CACHE_MAX:
        return _dft_cached(int(N), int(n_h))
    return _dft_large(int(N), int(n_h))


def idft_matrix(N, n_h):
    """Matrix ``V`` with ``ifft(x_hat, N) = V @ x_hat`` (read-only, cached like :func:`dft_matrix`)."""
    if N * (2 * n_h + 1) <= _CACHE_MAX:
        return _idft_cached(int(N), int(n_h))
    return _idft_large(int(N), int(n_h))


def idft_derivative_matrix(N, n_h, omega):
    """``Vs Om``: samples of the time derivative, ``ifft(derivative(x_hat, omega), N) = (Vs Om) @ x_hat``,
    shape ``(N, 2 n_h + 1)``.  Each column of ``Om`` has one entry ``+-k omega``, so the product is the
    column-swapped ``Vs`` (cached like :func:`idft_matrix`) times those entries: the same numbers."""
    return _swapped(N, n_h) * (_signed_k(int(n_h)) * float(omega))  # the entries +-(k omega) of Om


@functools.lru_cache(maxsize=32)
def _signed_k(n_h):
    """``[0, -1, 1, -2, 2, ..., -n_h, n_h]`` (read-only): the entries of ``Om`` per column, per unit omega."""
    s = np.zeros(2 * n_h + 1)
    s[2::2] = np.arange(1, n_h + 1)
    s[1::2] = -s[2::2]
    s.flags.writeable = False
    return s


def _swapped_columns(N, n_h):
    V = idft_matrix(N, n_h)
    P = np.zeros(V.shape)
    P[:, 2::2] = V[:, 1::2]
    P[:, 1::2] = V[:, 2::2]
    P.flags.writeable = False
    return P


def _swapped(N, n_h):
    if N * (2 * n_h + 1) <= _CACHE_MAX:
        return _swapped_cached(int(N), int(n_h))
    return _swapped_large(int(N), int(n_h))


_CACHE_MAX = 1 << 20  # entries (8 MiB) per cached matrix


def _dft(N, n_h):
    E = idft_matrix(N, n_h).T * (2.0 / N)  # V(t_j)^T: the basis on the same grid
    E[0] *= 0.5
    E.flags.writeable = False
    return E


def _idft(N, n_h):
    V = basis(2.0 * np.pi * np.arange(N) / N, 1.0, n_h)
    V.flags.writeable = False
    return V


_dft_cached = functools.lru_cache(maxsize=32)(_dft)
_idft_cached = functools.lru_cache(maxsize=32)(_idft)
_swapped_cached = functools.lru_cache(maxsize=32)(_swapped_columns)
# above _CACHE_MAX the last matrix of each kind only (the problem built last holds it anyway)
_dft_large = functools.lru_cache(maxsize=1)(_dft)
_idft_large = functools.lru_cache(maxsize=1)(_idft)
_swapped_large = functools.lru_cache(maxsize=1)(_swapped_columns)


def real_block(Zk, k):
    """Real matrix of the complex linear map ``X -> Zk X`` on harmonic ``k``.

    For ``k = 0`` this is ``Re Zk``; for ``k >= 1`` it acts on ``(xc_k, xs_k)``
    stacked as ``[xc; xs]`` and equals ``[[A, B], [-B, A]]`` with ``Zk = A + iB``.
    """
    A, B = Zk.real, Zk.imag
    if k == 0:
        return A.copy()
    a, b = A.shape
    out = np.empty((2 * a, 2 * b))
    out[:a, :b] = A
    out[:a, b:] = B
    out[a:, :b] = -B
    out[a:, b:] = A
    return out
