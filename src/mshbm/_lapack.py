"""LAPACK's LU (``zgetrf``/``dgetrf``), condition estimate (``dgecon``) and solve (``zgetrs``/``dgetrs``)
called from compiled code: the per-harmonic blocks of :class:`mshbm.condensation.Condensation` and the
dense Newton step of :func:`mshbm.solvers.newton._solve`.

The routines are SciPy's own (``scipy.linalg.cython_lapack``, the library behind
``scipy.linalg.lapack.zgetrf``), so the numbers are bit-identical to calling them through SciPy's
wrappers; what is saved is the wrappers' per-call cost (argument checks and copies, ~2 µs a call),
which exceeded the LU of a small block.  The symbols are registered with LLVM under fixed names,
so the kernel is cached on disk like the other numba kernels.
"""
from __future__ import annotations

import llvmlite.binding as llvm
import numpy as np
from numba import njit, types
from numba.extending import get_cython_function_address

__all__ = ["lu_solve_batch", "scaled_lu_solve"]

llvm.add_symbol("mshbm_zgetrf", get_cython_function_address("scipy.linalg.cython_lapack", "zgetrf"))
llvm.add_symbol("mshbm_zgetrs", get_cython_function_address("scipy.linalg.cython_lapack", "zgetrs"))
_vp = types.voidptr
#: zgetrf(m, n, a, lda, ipiv, info), zgetrs(trans, n, nrhs, a, lda, ipiv, b, ldb, info): Fortran, int32
_zgetrf = types.ExternalFunction("mshbm_zgetrf", types.void(_vp, _vp, _vp, _vp, _vp, _vp))
_zgetrs = types.ExternalFunction("mshbm_zgetrs", types.void(_vp, _vp, _vp, _vp, _vp, _vp, _vp, _vp, _vp))


@njit(cache=True)
def lu_solve_batch(H, rhs, sol, rcond):  # pragma: no cover - compiled
    """For every ``k``: LU of ``H[k]`` (``n x n``, complex) with partial pivoting (``zgetrf``), then
    ``sol[k] = H[k]^-1 rhs[k]`` (``zgetrs``, ``rhs[k]`` of shape ``n x m``); ``rcond[k]`` gets the pivot
    ratio ``min |U_ii| / max |U_ii|`` (0 if ``max |U_ii|`` is 0 or NaN; an exactly zero pivot means a
    singular ``H[k]``, whose ``sol[k]`` is then not finite)."""
    nk, n, _ = H.shape
    m = rhs.shape[2]
    dims = np.empty(3, np.int32)  # n, m, info
    dims[0], dims[1] = n, m
    ipiv = np.empty(n, np.int32)
    trans = np.empty(1, np.uint8)
    trans[0] = 78  # "N"
    a = np.empty((n, n), np.complex128)  # a[c, r] = H[k, r, c]: column-major for LAPACK
    b = np.empty((m, n), np.complex128)
    pn, pm, pinfo = dims[0:1].ctypes, dims[1:2].ctypes, dims[2:3].ctypes
    for k in range(nk):
        for r in range(n):
            for c in range(n):
                a[c, r] = H[k, r, c]
            for c in range(m):
                b[c, r] = rhs[k, r, c]
        _zgetrf(pn, pn, a.ctypes, pn, ipiv.ctypes, pinfo)
        dmin, dmax, nan = np.inf, 0.0, False
        for j in range(n):
            d = abs(a[j, j])
            if d != d:
                nan = True
            dmin = min(dmin, d)
            dmax = max(dmax, d)
        rcond[k] = dmin / dmax if dmax > 0.0 and not nan else 0.0
        _zgetrs(trans.ctypes, pn, pm, a.ctypes, pn, ipiv.ctypes, b.ctypes, pn, pinfo)
        for r in range(n):
            for c in range(m):
                sol[k, r, c] = b[c, r]


llvm.add_symbol("mshbm_dgetrf", get_cython_function_address("scipy.linalg.cython_lapack", "dgetrf"))
llvm.add_symbol("mshbm_dgecon", get_cython_function_address("scipy.linalg.cython_lapack", "dgecon"))
llvm.add_symbol("mshbm_dgetrs", get_cython_function_address("scipy.linalg.cython_lapack", "dgetrs"))
#: dgetrf(m, n, a, lda, ipiv, info); dgecon(norm, n, a, lda, anorm, rcond, work, iwork, info);
#: dgetrs(trans, n, nrhs, a, lda, ipiv, b, ldb, info)
_dgetrf = types.ExternalFunction("mshbm_dgetrf", types.void(_vp, _vp, _vp, _vp, _vp, _vp))
_dgecon = types.ExternalFunction("mshbm_dgecon", types.void(_vp, _vp, _vp, _vp, _vp, _vp, _vp, _vp, _vp))
_dgetrs = types.ExternalFunction("mshbm_dgetrs", types.void(_vp, _vp, _vp, _vp, _vp, _vp, _vp, _vp, _vp))


@njit(cache=True)
def scaled_lu_solve(J, R, s, rcond_min, dx):  # pragma: no cover - compiled
    """Newton step of the row-scaled system: ``dx = (J / s)^-1 (R / s)`` (``J`` (n, n) real, ``R``, ``s``
    (n,)) by ``dgetrf``/``dgetrs``, if ``J / s`` is finite, its LU has no zero pivot and ``dgecon``'s
    1-norm reciprocal condition estimate exceeds ``rcond_min``; returns 1 then, else 0 (``dx`` unset).

    The numbers are those of ``scipy.linalg.lapack.dgetrf/dgecon/dgetrs`` on ``J / s[:, None]`` and
    ``R / s`` with ``anorm = max_j sum_i |J_ij / s_i|`` (column sums accumulated row by row, as NumPy's
    ``abs(J).sum(axis=0)``)."""
    n = J.shape[0]
    ints = np.empty(3, np.int32)  # n, nrhs, info
    ints[0], ints[1] = n, 1
    pn, p1, pinfo = ints[0:1].ctypes, ints[1:2].ctypes, ints[2:3].ctypes
    a = np.empty((n, n))  # a[c, r] = J[r, c] / s[r]: column-major
    colsum = np.zeros(n)
    for r in range(n):
        for c in range(n):
            v = J[r, c] / s[r]
            if not np.isfinite(v):
                return 0
            a[c, r] = v
            colsum[c] += abs(v)
    anorm = np.zeros(2)  # anorm, rcond
    for c in range(n):
        anorm[0] = max(anorm[0], colsum[c])
    ipiv = np.empty(n, np.int32)
    _dgetrf(pn, pn, a.ctypes, pn, ipiv.ctypes, pinfo)
    if ints[2] != 0:
        return 0
    chars = np.empty(2, np.uint8)
    chars[0], chars[1] = 49, 78  # "1", "N"
    work = np.empty(4 * n)
    iwork = np.empty(n, np.int32)
    _dgecon(chars[0:1].ctypes, pn, a.ctypes, pn, anorm[0:1].ctypes, anorm[1:2].ctypes, work.ctypes, iwork.ctypes,
            pinfo)
    if not anorm[1] > rcond_min:
        return 0
    for r in range(n):
        dx[r] = R[r] / s[r]
    _dgetrs(chars[1:2].ctypes, pn, p1, a.ctypes, pn, ipiv.ctypes, dx.ctypes, pn, pinfo)
    return 1
