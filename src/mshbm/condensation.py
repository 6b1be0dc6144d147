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

from ._lapack import lu_solve_batch
from .factor_reuse import _REUSE, FactorReuse, reuse_factors
from .fourier import real_block, to_complex

__all__ = ["dynamic_stiffness", "dynamic_stiffness_stack", "permuted_blocks", "Condensation", "SingularHarmonicError", "Banded",
           "solve_dynamic", "FactorReuse", "reuse_factors"]

#: banded LAPACK (``gbtrf``) instead of SuperLU for sparse ``H`` whose bandwidth ``kl + ku`` is at most this
#: (chains, beams: the band LU is O(n) with no ordering to compute) and whose band storage stays small
MAX_BAND = 16
MAX_BAND_BYTES = 400e6


class SingularHarmonicError(ArithmeticError):
    """A dynamic stiffness block ``H_k`` is singular (a harmonic hits a resonance); ``k`` is the harmonic
    (``None`` where unknown)."""

    def __init__(self, message, k=None):
        super().__init__(message)
        self.k = None if k is None else int(k)



def dynamic_stiffness(M, C, K, k_omega):
    """Complex dynamic stiffness ``K - (k omega)^2 M + i k omega C``."""
    if sp.issparse(M) or sp.issparse(C) or sp.issparse(K):
        return (sp.csc_matrix(K, dtype=complex) - k_omega ** 2 * sp.csc_matrix(M)
                + 1j * k_omega * sp.csc_matrix(C)).tocsc()
    return np.asarray(K) - k_omega ** 2 * np.asarray(M) + 1j * k_omega * np.asarray(C)


def dynamic_stiffness_stack(M, C, K, omegas):
    """``H(w) = K - w^2 M + i w C`` for every ``w`` in ``omegas`` at once (dense ``M, C, K``), shape
    ``(len(omegas), n, m)``: real part ``K - w^2 M``, imaginary part ``w C``."""
    w = np.asarray(omegas, dtype=float)[:, None, None]
    K, M, C = np.asarray(K), np.asarray(M), np.asarray(C)
    H = np.empty((w.shape[0],) + K.shape, dtype=complex)  # M, C, K of one shape
    np.subtract(K, w * w * M, out=H.real)  # w ** 2 is w * w
    np.multiply(w, C, out=H.imag)
    return H


def permuted_blocks(system, idx):
    """Dense ``M, C, K`` of ``system`` restricted to the rows and columns ``idx`` (in that order), each
    ``(len(idx), len(idx))``, read-only; cached on the system (:meth:`mshbm.System.derived`)."""
    idx = np.asarray(idx, dtype=np.int64)

    def compute():
        out = []
        for A in (system.M, system.C, system.K):
            B = A.tocsr()[idx][:, idx].toarray() if sp.issparse(A) else np.asarray(A, dtype=float)[np.ix_(idx, idx)]
            B.flags.writeable = False
            out.append(B)
        return tuple(out)

    return system.derived(("permuted_blocks", idx.tobytes()), ("M", "C", "K"), compute)


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
    F : complex ndarray, shape (n_h+1, n)
        Complex forcing harmonics of all DOFs.
    H_RR : complex ndarray, shape (n_h+1, n_R, n_R), or None
        The kept block of the dynamic stiffness (dense path only; ``None`` otherwise).
    rcond : ndarray, shape (n_h+1,)
        Reciprocal condition estimate of each ``H_EE,k`` (1 for an empty E).
    name : str
        Name of ``H_EE`` in error messages (``"H_LL"``, ``"H_33"``).
    """

    def __init__(self, system, omega, n_h, keep, eliminate, rcond_min=1e-13, name="H_LL"):
        self.keep = np.asarray(keep, dtype=np.int64)
        self.elim = np.asarray(eliminate, dtype=np.int64)
        nR, nE = self.keep.size, self.elim.size
        F = self.F = to_complex(system.forcing_hat(n_h, omega))
        self.H_RR = None
        self.rcond = np.ones(n_h + 1)
        M, C, K = system.M, system.C, system.K
        if nE > 0 and not (sp.issparse(M) and nE > 400):
            self._dense(system, F, omega, n_h, rcond_min, name)  # sets z, Z, T, g
            return
        self.z = np.zeros((n_h + 1, nE), dtype=complex)
        self.Z = np.zeros((n_h + 1, nE, nR), dtype=complex)
        self.T = np.zeros((n_h + 1, nR, nR), dtype=complex)
        self.g = np.zeros((n_h + 1, nR), dtype=complex)
        if nE == 0:
            return
        blocks = {}
        for mat, A in (("M", M), ("C", C), ("K", K)):
            blocks[mat] = (_sub(A, self.elim, self.elim), _sub(A, self.elim, self.keep),
                            _sub(A, self.keep, self.elim))
        self._sparse = (float(omega), blocks)  # for omega_slope
        # banded H_EE (chains, beams): LAPACK band LU, O(n_E) a harmonic; else one sparse LU a harmonic
        band = Banded.build(*(blocks[a][0] for a in "MCK"))
        reuse = _REUSE.get()
        # kept factorisations are per system (its matrices, by identity), DOF split and harmonic
        key = (id(M), id(C), id(K), self.keep.tobytes(), self.elim.tobytes())
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
                        f"{name} is singular at harmonic k={k} (k*omega={w:.6g}, rcond~{self.rcond[k]:.1e})", k=k)
                sol = band.solve(factors, rhs)
                solve_k = None  # a band LU is O(n_E): nothing to gain from reuse
            else:
                refined = None if reuse is None else reuse.refine(key, k, w, blocks["M"][0], blocks["C"][0], rhs)
                if refined is not None:
                    sol, self.rcond[k] = refined
                    solve_k = None
                else:
                    H_EE = dynamic_stiffness(blocks["M"][0], blocks["C"][0], blocks["K"][0], w)  # only to factorise
                    try:
                        # H is complex symmetric: symmetric mode keeps the fill-reducing ordering
                        # (default pivoting destroys it on 2-D meshes, and the factorisation becomes far slower)
                        lu = spla.splu(sp.csc_matrix(H_EE), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                                       options=dict(SymmetricMode=True))
                    except RuntimeError:
                        raise SingularHarmonicError(
                            f"{name} is singular at harmonic k={k} (k*omega={w:.6g})", k=k) from None
                    d = np.abs(lu.U.diagonal())
                    self.rcond[k] = d.min() / d.max() if d.max() > 0 else 0.0
                    sol = lu.solve(rhs)
                    solve_k = lu.solve
            if not np.all(np.isfinite(sol)) or self.rcond[k] < rcond_min:
                raise SingularHarmonicError(
                    f"{name} is singular at harmonic k={k} (k*omega={w:.6g}, rcond~{self.rcond[k]:.1e})", k=k)
            if reuse is not None and solve_k is not None:
                reuse.keep(key, k, w, solve_k, self.rcond[k])
            self.z[k] = sol[:, 0]
            self.Z[k] = sol[:, 1:]
            self.T[k] = H_RE @ self.Z[k]
            self.g[k] = H_RE @ self.z[k]

    def omega_slope(self):
        """``(dT/domega, dg/domega)`` (shapes of ``T`` and ``g``) of the sparse path, from ``Z`` and ``z`` alone;
        ``None`` on the dense path or where ``M, C, K`` are not symmetric.

        With ``H' = dH/dw = -2 w M + i C`` at ``w = k omega`` and ``d(H_EE^-1) = -H_EE^-1 H_EE' H_EE^-1``::

            dT_k/domega = k (H_RE' Z_k + Z_k^T H_ER' - Z_k^T H_EE' Z_k),
            dg_k/domega = k (H_RE' z_k - Z_k^T H_EE' z_k)

        (``F`` does not depend on omega), where ``H_RE H_EE^-1 = Z^T`` because symmetric ``M, C, K`` make
        ``H_EE`` complex symmetric and ``H_RE = H_ER^T``: no solve with ``H_EE``, only sparse products.
        The finite difference of two condensations at ``omega +- d`` costs two condensations and carries
        their rounding divided by ``d``."""
        if getattr(self, "_sparse", None) is None:
            return None
        omega, blocks = self._sparse
        if "_slope" not in self.__dict__:
            same = lambda A, B: sp.csr_matrix(A - B).count_nonzero() == 0
            sym = all(same(blocks[a][0], blocks[a][0].T) and same(blocks[a][1], blocks[a][2].T) for a in "MCK")
            if not sym:
                self._slope = None
                return None
            (M_EE, M_ER, M_RE), (C_EE, C_ER, C_RE) = blocks["M"], blocks["C"]
            dT, dg = np.zeros_like(self.T), np.zeros_like(self.g)
            for k in range(1, self.T.shape[0]):  # k = 0: H does not depend on omega
                w = k * omega
                d = lambda Mb, Cb: sp.csr_matrix(-2.0 * w * Mb, dtype=complex) + 1j * sp.csr_matrix(Cb, dtype=complex)
                Z, z = self.Z[k], self.z[k]
                dEE_Z = d(M_EE, C_EE) @ np.column_stack([Z, z])
                dRE = d(M_RE, C_RE)
                dT[k] = k * (dRE @ Z + (d(M_ER, C_ER).T @ Z).T - Z.T @ dEE_Z[:, :-1])
                dg[k] = k * (dRE @ z - Z.T @ dEE_Z[:, -1])
            self._slope = (dT, dg)
        return self._slope

    def shifted(self, d_omega):
        """A copy of the sparse path's condensation at ``omega + d_omega`` to first order in ``d_omega``
        (:meth:`omega_slope`; error ``O(d_omega^2)``): ``T`` and ``g`` only, for residuals at ``omega +- d``
        of a finite-difference ``dR/domega`` (``z``, ``Z`` are not shifted and are left out); ``None`` where
        :meth:`omega_slope` is ``None``."""
        slope = self.omega_slope()
        if slope is None:
            return None
        out = object.__new__(type(self))
        out.keep, out.elim, out.F, out.H_RR, out.rcond = self.keep, self.elim, self.F, self.H_RR, self.rcond
        out.z = out.Z = None
        out.T = self.T + d_omega * slope[0]
        out.g = self.g + d_omega * slope[1]
        out._sparse = None
        return out

    def _dense(self, system, F, omega, n_h, rcond_min, name):
        """The dense path (``n_E <= 400`` or dense matrices): the blocks of all harmonics at once,
        one LAPACK LU per harmonic.

        Sets ``H_RR`` (complex, ``(n_h + 1, n_R, n_R)``) too: the kept block of the same dynamic
        stiffness, which the harmonic-balance methods need next to ``T``."""
        e, r = self.elim, self.keep
        nE, nR = e.size, r.size
        idx = np.concatenate([e, r])  # [E, R]: every block below is a slice of one (n_h + 1, n', n') stack
        M, C, K = permuted_blocks(system, idx)
        w = omega * np.arange(n_h + 1)
        H = dynamic_stiffness_stack(M, C, K, w)
        H_EE, H_RE = H[:, :nE, :nE], H[:, nE:, :nE]
        self.H_RR = H[:, nE:, nE:]
        rhs = np.empty((n_h + 1, nE, nR + 1), dtype=complex)
        rhs[:, :, 0] = F[:, e]
        rhs[:, :, 1:] = H[:, :nE, nE:]
        # LAPACK's zgetrf/zgetrs for all harmonics in one compiled call (mshbm._lapack: the same routines
        # as scipy.linalg.lapack, without the wrappers' per-call cost), with the pivot ratios
        sol = np.empty_like(rhs)
        lu_solve_batch(np.ascontiguousarray(H_EE), rhs, sol, self.rcond)  # an exactly zero pivot: rcond 0
        bad = np.flatnonzero(self.rcond < rcond_min)
        if bad.size:
            k = int(bad[0])
            raise SingularHarmonicError(
                f"{name} is singular at harmonic k={k} (k*omega={w[k]:.6g}, rcond~{self.rcond[k]:.1e})", k=k)
        if not np.isfinite(sol).all():
            k = int(np.argmax(~np.isfinite(sol).all(axis=(1, 2))))
            raise SingularHarmonicError(
                f"{name} is singular at harmonic k={k} (k*omega={w[k]:.6g}, rcond~{self.rcond[k]:.1e})", k=k)
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
        if n_h:
            # harmonic k >= 1: [[A, B], [-B, A]] with Zs[k] = A + iB (fourier.real_block), all k at once
            A, B = Zs[1:].real, Zs[1:].imag
            blk = np.empty((n_h, 2, a, 2, b))
            blk[:, 0, :, 0], blk[:, 0, :, 1], blk[:, 1, :, 0], blk[:, 1, :, 1] = A, B, -B, A
            kk = np.arange(n_h)
            out[a:, b:].reshape(n_h, 2 * a, n_h, 2 * b)[kk, :, kk, :] = blk.reshape(n_h, 2 * a, 2 * b)
        return out


#: largest ``n_E`` whose resonant null space :func:`condense_around_resonances` computes (a dense SVD)
MAX_RESONANT_DENSE = 2000


def resonant_modes(system, omega, k, keep, elim, null_tol=1e-8):
    """The null space of ``H_EE(k omega)`` at a resonance of the eliminated DOFs and what it means for
    the uncondensed problem.

    Right null vectors ``v`` (``H_EE v = 0``) and left ones ``w`` (``w^H H_EE = 0``) from one dense SVD
    (singular values ``<= null_tol * sigma_max``, at least the smallest).  A ``v`` with ``H_RE v = 0``
    is a null vector of the whole ``H_k`` that vanishes on the kept DOFs (which carry every element);
    a ``w`` with ``w^H H_ER = 0`` likewise.  Then the ``k``-th harmonic of the equations of motion
    projected on ``w`` reads ``0 = w^H F_k`` for *every* periodic motion (the elements' forces act on
    kept rows only): with ``w^H F_k != 0`` no periodic solution exists (an undamped mode forced at its
    eigenfrequency, the response grows without bound), with ``H_RE v = 0`` and ``w^H F_k = 0`` the mode
    ``v`` can be added with any amplitude (not unique).

    Parameters
    ----------
    system : System
    omega : float
        Fundamental angular frequency (rad/s).
    k : int
        Harmonic at which ``H_EE`` is singular.
    keep, elim : arrays of int
        DOFs ``R`` kept and ``E`` eliminated.

    Returns
    -------
    dict with ``support`` (sorted int array: the DOFs of ``E`` where a null vector is nonzero),
    ``no_solution`` and ``not_unique`` (``None`` or a sentence saying why).
    """
    keep = np.asarray(keep, dtype=np.int64)
    elim = np.asarray(elim, dtype=np.int64)
    dense = lambda A: A.toarray() if sp.issparse(A) else np.asarray(A)
    w = k * float(omega)
    blk = lambda r, c: dense(dynamic_stiffness(*(_sub(getattr(system, a), r, c) for a in "MCK"), w))
    H_EE, H_RE, H_ER = blk(elim, elim), blk(keep, elim), blk(elim, keep)
    if not (np.isfinite(H_EE).all() and np.isfinite(H_RE).all() and np.isfinite(H_ER).all()):
        raise FloatingPointError("non-finite dynamic stiffness")
    U, s, Vh = np.linalg.svd(H_EE)
    scale = max(float(s[0]), float(np.abs(H_RE).max(initial=0.0)), float(np.abs(H_ER).max(initial=0.0)))
    null = np.flatnonzero(s <= null_tol * s[0]) if s[0] > 0 else np.arange(s.size)
    if null.size == 0:
        null = np.array([s.size - 1])
    V = Vh[null].conj().T  # (n_E, r), orthonormal columns
    W = U[:, null]  # left null vectors
    mag = np.abs(V).max(axis=1)
    support = np.sort(elim[mag > 1e-6 * mag.max()])
    coupled_v = np.abs(H_RE @ V).max(axis=0) > null_tol * scale if keep.size else np.zeros(null.size, bool)
    coupled_w = np.abs(W.conj().T @ H_ER).max(axis=1) > null_tol * scale if keep.size else np.zeros(null.size, bool)
    F = to_complex(system.forcing_hat(max(k, 0), omega))[k]
    F_E = F[elim]
    F_scale = float(np.abs(F).max(initial=0.0))
    out = {"support": support, "no_solution": None, "not_unique": None}
    dofs = lambda x: sorted(int(d) for d in elim[np.abs(x) > 1e-6 * np.abs(x).max()])
    for j in np.flatnonzero(~coupled_w):
        drive = abs(complex(W[:, j].conj() @ F_E))
        if drive > null_tol * max(F_scale, 1e-300) and F_scale > 0:
            out["no_solution"] = (
                f"no periodic solution exists: harmonic k={k} of the forcing (k*omega={w:.6g} rad/s) drives an "
                f"undamped mode of DOFs {dofs(W[:, j])} at its eigenfrequency, and neither an element nor the "
                f"rest of the structure acts on that mode (the response grows without bound); move omega or "
                f"add damping")
            return out
    for j in np.flatnonzero(~coupled_v):
        out["not_unique"] = (
            f"the periodic solution is not unique: an undamped mode of DOFs {dofs(V[:, j])} has the "
            f"eigenfrequency k*omega={w:.6g} rad/s (k={k}), is not forced there and is touched by no element, "
            f"so it adds to any periodic solution with any amplitude; move omega or add damping")
    return out


def condense_around_resonances(system, omega, n_h, keep, elim, name="H_LL", max_rounds=8):
    """:class:`Condensation` of ``elim``, keeping the DOFs of a resonance of ``H_EE`` instead of failing.

    Where ``H_EE(k omega)`` is singular at a harmonic ``k >= 1`` (``k omega`` an eigenfrequency of the
    undamped eliminated subsystem with the kept DOFs clamped), the DOFs carrying its null space
    (:func:`resonant_modes`) are moved from ``elim`` to ``keep`` and the condensation is repeated; the full
    problem is the same, only fewer DOFs are condensed.  Where the resonant mode is not coupled to the kept
    DOFs, the problem itself has no (unique) periodic solution: ``InputError("omega")`` says so.  A singular
    ``K_EE`` (``k = 0``, a free-free part) and ``n_E >`` :data:`MAX_RESONANT_DENSE` raise the
    :class:`SingularHarmonicError` as before.

    Returns
    -------
    cond : Condensation
    keep, elim : sorted int arrays
        The DOFs kept and eliminated in the end.
    moved : list of dict
        One record ``{"k", "k_omega", "dofs"}`` per move (empty when ``H_EE`` was regular).
    """
    from .errors import InputError

    keep = np.asarray(keep, dtype=np.int64)
    elim = np.asarray(elim, dtype=np.int64)
    moved = []
    for _ in range(max_rounds):
        try:
            return Condensation(system, omega, n_h, keep, elim, name=name), keep, elim, moved
        except SingularHarmonicError as exc:
            if not exc.k or elim.size > MAX_RESONANT_DENSE:
                raise
            try:
                modes = resonant_modes(system, omega, exc.k, keep, elim)
            except (np.linalg.LinAlgError, ValueError, FloatingPointError):  # non-finite blocks (overflow)
                raise exc from None
            for why in ("no_solution", "not_unique"):
                if modes[why]:
                    raise InputError("omega", f"{exc}: {modes[why]}") from None
            S = modes["support"]
            moved.append({"k": exc.k, "k_omega": exc.k * float(omega), "dofs": [int(d) for d in S]})
            keep = np.union1d(keep, S)
            elim = np.setdiff1d(elim, S)
    return Condensation(system, omega, n_h, keep, elim, name=name), keep, elim, moved


def resonance_note(moved, name, where):
    """One sentence for ``info`` and the message on the DOFs :func:`condense_around_resonances` moved."""
    parts = [f"DOFs {m['dofs']} ({name} singular at harmonic k={m['k']}, k*omega={m['k_omega']:.6g})"
             for m in moved]
    return f"{'; '.join(parts)} moved to {where} instead of being condensed (resonance of the condensed part)"
