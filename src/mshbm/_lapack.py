"""LAPACK's complex LU (``zgetrf``) and solve (``zgetrs``) called from compiled code, for the
per-harmonic blocks of :class:`mshbm.condensation.Condensation`.

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

__all__ = ["lu_solve_batch"]

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
