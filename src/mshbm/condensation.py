"""Dynamic stiffness (eqs. 23-24) and the exact per-harmonic condensation of linear DOFs (eq. 22).

``H_k = K - (k omega)^2 M + i k omega C`` acts on the complex harmonic ``X_k = xc_k - i xs_k``
(conventions of :mod:`mshbm.fourier`); :func:`mshbm.fourier.real_block` gives its real form on
``[xc_k; xs_k]``.  :class:`Condensation` eliminates the DOFs ``E`` (the linear subsystem ``L``)
harmonic by harmonic with one LU factorisation each.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .fourier import real_block, to_complex

__all__ = ["dynamic_stiffness", "dynamic_stiffness_stack", "Condensation", "SingularHarmonicError", "Banded",
           "solve_dynamic"]

#: banded LAPACK (``gbtrf``) instead of SuperLU for sparse ``H`` whose bandwidth ``kl + ku`` is at most this
#: (chains, beams: the band LU is O(n) with no ordering to compute) and whose band storage stays small
MAX_BAND = 16
MAX_BAND_BYTES = 400e6


class SingularHarmonicError(ArithmeticError):
    """A dynamic stiffness block ``H_k`` is singular (a harmonic hits a resonance)."""



def dynamic_stiffness(M, C, K, k_omega):
    """Complex dynamic stiffness ``K - (k omega)^2 M + i k omega C``."""
    if sp.issparse(M) or sp.issparse(C) or sp.issparse(K):
        return (sp.csc_matrix(K, dtype=complex) - k_omega ** 2 * sp.csc_matrix(M)
                + 1j * k_omega * sp.csc_matrix(C)).tocsc()
    return np.asarray(K) - k_omega ** 2 * np.asarray(M) + 1j * k_omega * np.asarray(C)


def dynamic_stiffness_stack(M, C, K, omegas):
    """``H(w) = K - w^2 M + i w C`` for every ``w`` in ``omegas`` at once (dense ``M, C, K``), shape
    ``(len(omegas), n, m)``."""
    w = np.asarray(omegas, dtype=float)[:, None, None]
    return np.asarray(K)[None] - w ** 2 * np.asarray(M)[None] + 1j * w * np.asarray(C)[None]


class Banded:
    """``H(w) = K - w^2 M + i w C`` of sparse ``M, C, K`` in LAPACK band storage, when the bandwidth is small.

    :meth:`build` returns ``None`` for matrices whose ``kl + ku`` exceeds :data:`MAX_BAND` or whose band
    storage exceeds :data:`MAX_BAND_BYTES` (use SuperLU then).  The real band arrays of ``M, C, K``
    (shape ``(2 kl + ku + 1, n)``, the first ``kl`` rows the LU's workspace) are formed once; each ``w``
    then costs ``O(n (kl + ku))`` to assemble and ``O(n kl (kl + ku))`` to factorise (``gbtrf``, partial
    pivoting).
    """

    def __init__(self, kl, ku, bands):
        self.kl, self.ku, self.bands = kl, ku, bands

    @classmethod
    def build(cls, M, C, K):
        ijv = []
        for A in (M, C, K):
            A = sp.csr_matrix(A)
            if not A.has_canonical_format:  # duplicate entries sum
                A = A.copy()
                A.sum_duplicates()
            ijv.append((np.repeat(np.arange(A.shape[0]), np.diff(A.indptr)), A.indices, A.data))
        n = M.shape[0]
        if n == 0 or M.shape[1] != n:
            return None
        kl = max(int(np.max(i - j, initial=0)) for i, j, _ in ijv)
        ku = max(int(np.max(j - i, initial=0)) for i, j, _ in ijv)
        rows = 2 * kl + ku + 1
        if kl + ku > MAX_BAND or 16 * rows * n > MAX_BAND_BYTES:
            return None
        bands = []
        for i, j, v in ijv:
            b = np.zeros((n, rows)).T  # Fortran order, as LAPACK takes it (no transposing copy per factor)
            b[kl + ku + i - j, j] = v
            bands.append(b)
        return cls(kl, ku, bands)

    def factor(self, w):
        """``(lu, piv, rcond)`` of ``H(w)``; ``rcond = min |U_ii| / max |U_ii|`` (0 if exactly singular)."""
        Mb, Cb, Kb = self.bands
        ab = np.empty(Kb.shape[::-1], dtype=complex).T  # K - w^2 M + i w C, Fortran order, no temporaries
        ab.real = Kb - w ** 2 * Mb
        ab.imag = w * Cb
        gbtrf, = sla.get_lapack_funcs(("gbtrf",), (ab,))
        lu, piv, info = gbtrf(ab, self.kl, self.ku, overwrite_ab=True)
        d = np.abs(lu[self.kl + self.ku])
        rcond = float(d.min() / d.max()) if info == 0 and d.max() > 0 else 0.0
        return lu, piv, rcond

    def solve(self, factors, rhs):
        """``H(w)^-1 rhs`` from :meth:`factor`'s output; ``rhs`` shape ``(n,)`` or ``(n, r)``."""
        lu, piv, _ = factors
        rhs = np.asarray(rhs, dtype=complex)
        gbtrs, = sla.get_lapack_funcs(("gbtrs",), (lu,))
        x, info = gbtrs(lu, self.kl, self.ku, np.asfortranarray(rhs.reshape(rhs.shape[0], -1)), piv,
                        overwrite_b=True)
        return x.reshape(rhs.shape)


def solve_dynamic(M, C, K, w, rhs):
    """``H(w)^-1 rhs`` with ``H(w) = K - w^2 M + i w C`` (dense, banded LAPACK or SuperLU).

    Raises ``RuntimeError`` (sparse) or ``numpy.linalg.LinAlgError`` (dense) where ``H`` is singular.
    """
    if not (sp.issparse(M) or sp.issparse(C) or sp.issparse(K)):
        return np.linalg.solve(dynamic_stiffness(M, C, K, w), rhs)
    band = Banded.build(M, C, K)
    if band is None:
        return spla.splu(dynamic_stiffness(M, C, K, w)).solve(np.asarray(rhs, dtype=complex))
    f = band.factor(w)
    if f[2] == 0.0:
        raise RuntimeError("singular matrix")
    return band.solve(f, rhs)


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
        if not (sp.issparse(M) and nE > 400):
            self._dense(M, C, K, F, omega, n_h, rcond_min, name)
            return
        blocks = {}
        for mat, A in (("M", M), ("C", C), ("K", K)):
            blocks[mat] = (_sub(A, self.elim, self.elim), _sub(A, self.elim, self.keep),
                            _sub(A, self.keep, self.elim))
        # banded H_EE (chains, beams): LAPACK band LU, O(n_E) a harmonic; else one sparse LU a harmonic
        band = Banded.build(*(blocks[a][0] for a in "MCK"))
        F_E = F[:, self.elim]
        for k in range(n_h + 1):
            w = k * omega
            H_ER = dynamic_stiffness(blocks["M"][1], blocks["C"][1], blocks["K"][1], w)
            H_RE = dynamic_stiffness(blocks["M"][2], blocks["C"][2], blocks["K"][2], w)
            rhs = np.empty((nE, nR + 1), dtype=complex, order="F")
            rhs[:, 0] = F_E[k]
            rhs[:, 1:] = H_ER.toarray()
            if band is not None:
                factors = band.factor(w)
                self.rcond[k] = factors[2]
                if self.rcond[k] < rcond_min:
                    raise SingularHarmonicError(
                        f"{name} is singular at harmonic k={k} (k*omega={w:.6g}, rcond~{self.rcond[k]:.1e})")
                sol = band.solve(factors, rhs)
            else:
                H_EE = dynamic_stiffness(blocks["M"][0], blocks["C"][0], blocks["K"][0], w)
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
            if not np.all(np.isfinite(sol)) or self.rcond[k] < rcond_min:
                raise SingularHarmonicError(
                    f"{name} is singular at harmonic k={k} (k*omega={w:.6g}, rcond~{self.rcond[k]:.1e})")
            self.z[k] = sol[:, 0]
            self.Z[k] = sol[:, 1:]
            self.T[k] = H_RE @ self.Z[k]
            self.g[k] = H_RE @ self.z[k]

    def _dense(self, M, C, K, F, omega, n_h, rcond_min, name):
        """The dense path (``n_E <= 400`` or dense matrices): the blocks of all harmonics at once,
        one LAPACK LU per harmonic."""
        e, r = self.elim, self.keep
        dense = lambda A: A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)
        if sp.issparse(M):  # small sparse model: only the rows needed
            M, C, K = (A.tocsr() for A in (M, C, K))
            idx = np.concatenate([e, r])
            M, C, K = (dense(A[idx][:, idx]) for A in (M, C, K))
            e, r = np.arange(e.size), np.arange(e.size, idx.size)
        else:
            M, C, K = dense(M), dense(C), dense(K)
        w = omega * np.arange(n_h + 1)

        def H(a, b):  # H_ab,k for all k, shape (n_h + 1, |a|, |b|)
            ab = np.ix_(a, b)
            return dynamic_stiffness_stack(M[ab], C[ab], K[ab], w)

        H_EE, H_ER, H_RE = H(e, e), H(e, r), H(r, e)
        nE, nR = e.size, r.size
        rhs = np.empty((n_h + 1, nE, nR + 1), dtype=complex)
        rhs[:, :, 0] = F[:, self.elim]
        rhs[:, :, 1:] = H_ER
        getrf, getrs = sla.get_lapack_funcs(("getrf", "getrs"), (H_EE[0],))
        sol = np.empty_like(rhs)
        for k in range(n_h + 1):
            # LAPACK directly: the scipy wrappers' checks cost more than the LU of a small H_EE
            lu, piv, info = getrf(H_EE[k])
            d = np.abs(np.diag(lu))
            self.rcond[k] = d.min() / d.max() if info == 0 and d.max() > 0 else 0.0
            if self.rcond[k] < rcond_min:
                raise SingularHarmonicError(
                    f"{name} is singular at harmonic k={k} (k*omega={w[k]:.6g}, rcond~{self.rcond[k]:.1e})")
            sol[k], info = getrs(lu, piv, rhs[k])
        if not np.all(np.isfinite(sol)):
            k = int(np.argmax(~np.isfinite(sol).all(axis=(1, 2))))
            raise SingularHarmonicError(
                f"{name} is singular at harmonic k={k} (k*omega={w[k]:.6g}, rcond~{self.rcond[k]:.1e})")
        self.z = sol[:, :, 0].copy()
        self.Z = sol[:, :, 1:].copy()
        self.T = H_RE @ self.Z
        self.g = np.einsum("kij,kj->ki", H_RE, self.z)

    def solve_full(self, k, H_RR, b_R, forcing=True):
        """Solution of the uncondensed equations ``H_k x = b`` of harmonic ``k`` from the factorisation here.

        ``b`` is ``b_R`` on the kept DOFs and ``F_E`` (``forcing=True``) or zero on the eliminated ones, so
        ``x_R = (H_RR - T_k)^-1 (b_R - g_k)`` and ``x_E = z_k - Z_k x_R`` (``z_k`` dropped without forcing).

        Parameters
        ----------
        k : int
        H_RR : complex ndarray, shape (n_R, n_R)
            ``H_RR,k`` of the kept DOFs.
        b_R : complex ndarray, shape (n_R,) or (n_R, r)
        forcing : bool

        Returns
        -------
        (x_R, x_E) : complex ndarrays, shapes ``(n_R, ...)`` and ``(n_E, ...)``
        """
        b_R = np.asarray(b_R, dtype=complex)
        g = self.g[k] if forcing else np.zeros_like(self.g[k])
        x_R = np.linalg.solve(H_RR - self.T[k], b_R - (g if b_R.ndim == 1 else g[:, None]))
        x_E = -(self.Z[k] @ x_R)
        if forcing:
            x_E += self.z[k] if b_R.ndim == 1 else self.z[k][:, None]
        return x_R, x_E

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
