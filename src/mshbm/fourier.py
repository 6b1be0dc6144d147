"""Fourier conventions of the paper (eqs. 1-5) and the dynamic stiffness (eqs. 23-24).

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
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = [
    "n_coeffs", "basis", "fft", "ifft", "derivative", "to_complex", "from_complex",
    "dft_matrix", "idft_matrix", "real_block", "dynamic_stiffness", "Condensation",
    "SingularHarmonicError",
]


class SingularHarmonicError(ArithmeticError):
    """A dynamic stiffness block ``H_k`` is singular (a harmonic hits a resonance)."""


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
    Z[1:] = x_hat[1::2] - 1j * x_hat[2::2]
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

    Read-only; small matrices are cached (every HBM problem of a sweep uses the same).
    """
    if N * (2 * n_h + 1) <= _CACHE_MAX:
        return _dft_cached(int(N), int(n_h))
    return _dft(N, n_h)


def idft_matrix(N, n_h):
    """Matrix ``V`` with ``ifft(x_hat, N) = V @ x_hat`` (read-only, cached like :func:`dft_matrix`)."""
    if N * (2 * n_h + 1) <= _CACHE_MAX:
        return _idft_cached(int(N), int(n_h))
    return _idft(N, n_h)


_CACHE_MAX = 1 << 20  # entries (8 MiB) per cached matrix


def _dft(N, n_h):
    t = 2.0 * np.pi * np.arange(N) / N
    E = basis(t, 1.0, n_h).T * (2.0 / N)
    E[0] *= 0.5
    E.flags.writeable = False
    return E


def _idft(N, n_h):
    V = basis(2.0 * np.pi * np.arange(N) / N, 1.0, n_h)
    V.flags.writeable = False
    return V


_dft_cached = functools.lru_cache(maxsize=32)(_dft)
_idft_cached = functools.lru_cache(maxsize=32)(_idft)


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


def dynamic_stiffness(M, C, K, k_omega):
    """Complex dynamic stiffness ``K - (k omega)^2 M + i k omega C``."""
    if sp.issparse(M) or sp.issparse(C) or sp.issparse(K):
        return (sp.csc_matrix(K, dtype=complex) - k_omega ** 2 * sp.csc_matrix(M)
                + 1j * k_omega * sp.csc_matrix(C)).tocsc()
    return np.asarray(K) - k_omega ** 2 * np.asarray(M) + 1j * k_omega * np.asarray(C)


def _sub(A, rows, cols):
    if sp.issparse(A):
        return A.tocsr()[rows][:, cols]
    return np.asarray(A)[np.ix_(rows, cols)]


class Condensation:
    """Exact elimination of the DOFs ``E`` from the harmonic equations.

    Per harmonic ``k`` the linear equations ``H_EE,k X_E + H_ER,k X_R = F_E,k``
    are solved for ``X_E = z_k - Z_k X_R`` with ``z_k = H_EE^-1 F_E`` and
    ``Z_k = H_EE^-1 H_ER`` (eq. 22).  One (sparse) LU factorisation per harmonic
    is made once and reused; the cost grows linearly with ``len(E)`` for banded
    matrices.

    Parameters
    ----------
    system : System
    omega : float
        Fundamental angular frequency (rad/s).
    n_h : int
        Number of harmonics.
    keep : array of int
        DOFs ``R`` kept (e.g. the nonlinear subsystem ``N``).
    eliminate : array of int
        DOFs ``E`` eliminated (e.g. the linear subsystem ``L``).

    Attributes
    ----------
    z : complex ndarray, shape (n_h+1, n_E)
    Z : complex ndarray, shape (n_h+1, n_E, n_R)
    T : complex ndarray, shape (n_h+1, n_R, n_R)
        ``H_RE H_EE^-1 H_ER``.
    g : complex ndarray, shape (n_h+1, n_R)
        ``H_RE H_EE^-1 F_E``.
    rcond : ndarray, shape (n_h+1,)
        Reciprocal condition estimate of each ``H_EE,k`` (1 for an empty E).
    name : str
        Name of ``H_EE`` in error messages (``"H_LL"``, ``"H_33"``).
    """

    def __init__(self, system, omega, n_h, keep, eliminate, rcond_min=1e-13, name="H_LL"):
        self.keep = np.asarray(keep, dtype=np.int64)
        self.elim = np.asarray(eliminate, dtype=np.int64)
        nR, nE = self.keep.size, self.elim.size
        F = to_complex(system.forcing_hat(n_h))
        self.z = np.zeros((n_h + 1, nE), dtype=complex)
        self.Z = np.zeros((n_h + 1, nE, nR), dtype=complex)
        self.T = np.zeros((n_h + 1, nR, nR), dtype=complex)
        self.g = np.zeros((n_h + 1, nR), dtype=complex)
        self.rcond = np.ones(n_h + 1)
        if nE == 0:
            return
        M, C, K = system.M, system.C, system.K
        blocks = {}
        for mat, A in (("M", M), ("C", C), ("K", K)):
            blocks[mat] = (_sub(A, self.elim, self.elim), _sub(A, self.elim, self.keep),
                            _sub(A, self.keep, self.elim))
        sparse = sp.issparse(blocks["M"][0]) and nE > 400
        for k in range(n_h + 1):
            w = k * omega
            H_EE = dynamic_stiffness(blocks["M"][0], blocks["C"][0], blocks["K"][0], w)
            H_ER = dynamic_stiffness(blocks["M"][1], blocks["C"][1], blocks["K"][1], w)
            H_RE = dynamic_stiffness(blocks["M"][2], blocks["C"][2], blocks["K"][2], w)
            rhs = np.empty((nE, nR + 1), dtype=complex)
            rhs[:, 0] = F[k, self.elim]
            rhs[:, 1:] = H_ER.toarray() if sp.issparse(H_ER) else H_ER
            if sparse:
                try:
                    # H is complex symmetric: symmetric mode keeps the fill-reducing ordering
                    # (default pivoting destroys it on 2-D meshes: 30 s instead of 0.03 s a harmonic)
                    lu = spla.splu(sp.csc_matrix(H_EE), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                                   options=dict(SymmetricMode=True))
                except RuntimeError:
                    raise SingularHarmonicError(
                        f"{name} is singular at harmonic k={k} (k*omega={w:.6g})") from None
                d = np.abs(lu.U.diagonal())
                self.rcond[k] = d.min() / d.max() if d.max() > 0 else 0.0
                sol = lu.solve(rhs)
            else:
                H = H_EE.toarray() if sp.issparse(H_EE) else H_EE
                # LAPACK directly: the scipy wrappers' checks cost more than the LU of a small H_EE
                getrf, getrs = sla.get_lapack_funcs(("getrf", "getrs"), (H,))
                lu, piv, info = getrf(H)
                d = np.abs(np.diag(lu))
                self.rcond[k] = d.min() / d.max() if info == 0 and d.max() > 0 else 0.0
                if self.rcond[k] < rcond_min:
                    raise SingularHarmonicError(
                        f"{name} is singular at harmonic k={k} (k*omega={w:.6g}, rcond~{self.rcond[k]:.1e})")
                sol, info = getrs(lu, piv, rhs)
            if not np.all(np.isfinite(sol)) or self.rcond[k] < rcond_min:
                raise SingularHarmonicError(
                    f"{name} is singular at harmonic k={k} (k*omega={w:.6g}, rcond~{self.rcond[k]:.1e})")
            self.z[k] = sol[:, 0]
            self.Z[k] = sol[:, 1:]
            HRE = H_RE.toarray() if sp.issparse(H_RE) else H_RE
            self.T[k] = HRE @ self.Z[k]
            self.g[k] = HRE @ self.z[k]

    def recover(self, XR):
        """``X_E`` (complex, shape (n_h+1, n_E)) from ``X_R`` (complex, (n_h+1, n_R))."""
        return self.z - np.einsum("kij,kj->ki", self.Z, XR)

    def real_matrix(self, Zs):
        """Block-diagonal real matrix of per-harmonic complex maps ``Zs[k]``.

        Rows and columns follow the flattened real coefficient layout
        ``[x0, xc_1, xs_1, ...]`` (harmonic-major, DOF-minor).
        """
        n_h = Zs.shape[0] - 1
        a, b = Zs.shape[1], Zs.shape[2]
        out = np.zeros(((2 * n_h + 1) * a, (2 * n_h + 1) * b))
        out[:a, :b] = Zs[0].real
        for k in range(1, n_h + 1):
            r, c = (2 * k - 1) * a, (2 * k - 1) * b
            out[r:r + 2 * a, c:c + 2 * b] = real_block(Zs[k], k)
        return out
