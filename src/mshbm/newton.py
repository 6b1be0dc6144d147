"""Damped Newton iteration shared by all methods.

The residual function returns ``(R, J)``: the residual (shape ``(n_x,)``) and its
Jacobian (dense ``(n_x, n_x)`` or sparse).  Globalisation is an Armijo
backtracking line search on ``||R||_2``; a non-finite residual or Jacobian ends
the iteration with a diagnosis instead of a number.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["newton", "NewtonResult"]


@dataclass
class NewtonResult:
    x: np.ndarray
    success: bool
    message: str
    nit: int
    nfev: int
    residual_norm: float
    history: list = field(default_factory=list)


def _solve(J, R):
    if sp.issparse(J):
        return spla.spsolve(sp.csc_matrix(J), R)
    try:
        return np.linalg.solve(J, R)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(J, R, rcond=None)[0]


def newton(fun, x0, tol=1e-10, max_iter=50, line_search=True, callback=None, scale=None):
    """Solve ``R(x) = 0``.

    Parameters
    ----------
    fun : callable
        ``fun(x, jac=True) -> (R, J)``; with ``jac=False`` it may return ``(R, None)``.
    x0 : ndarray, shape (n_x,)
    tol : float
        Converged when ``||R||_inf <= tol * scale``.
    max_iter : int
    line_search : bool
        Armijo backtracking (halving, down to 1/1024).
    callback : callable, optional
        ``callback(it, x, residual_norm)`` after each iteration (progress display).
    scale : float, optional
        Residual scale; default ``max(1, ||x0||_inf)``.

    Returns
    -------
    NewtonResult
    """
    x = np.array(x0, dtype=float)
    if scale is None:
        scale = max(1.0, float(np.max(np.abs(x), initial=0.0)))
    nfev = 0
    R, J = fun(x)
    nfev += 1
    hist = []
    for it in range(max_iter + 1):
        if not np.all(np.isfinite(R)):
            return NewtonResult(x, False, f"residual is not finite at iteration {it}", it, nfev, np.inf, hist)
        r = float(np.max(np.abs(R), initial=0.0))
        hist.append(r)
        if callback is not None:
            callback(it, x, r)
        if r <= tol * scale:
            return NewtonResult(x, True, f"converged: ||R||_inf = {r:.2e} after {it} iterations", it, nfev, r, hist)
        if it == max_iter:
            break
        Jd = J.data if sp.issparse(J) else J
        if not np.all(np.isfinite(Jd)):
            return NewtonResult(x, False, f"Jacobian is not finite at iteration {it}", it, nfev, r, hist)
        dx = -_solve(J, R)
        if not np.all(np.isfinite(dx)):
            return NewtonResult(x, False, f"Jacobian is singular at iteration {it} (||R||_inf = {r:.2e})",
                                it, nfev, r, hist)
        lam = 1.0
        r2 = float(np.linalg.norm(R))
        best = None
        while True:
            xt = x + lam * dx
            Rt, _ = fun(xt, jac=False)
            nfev += 1
            rt2 = float(np.linalg.norm(Rt)) if np.all(np.isfinite(Rt)) else np.inf
            if best is None or rt2 < best[0]:
                best = (rt2, lam, xt)
            if not line_search or rt2 <= (1.0 - 1e-4 * lam) * r2 or lam < 1.0 / 1024:
                break
            lam *= 0.5
        rt2, lam, xt = best
        if not np.isfinite(rt2):
            return NewtonResult(x, False, f"residual became NaN/inf along the Newton step at iteration {it}",
                                it, nfev, r, hist)
        if line_search and rt2 >= r2 and lam < 1.0 / 512:
            return NewtonResult(x, False, f"line search failed at iteration {it}: ||R||_inf stalls at {r:.2e} "
                                "(no descent; residual may be nonsmooth here or the start is too far)",
                                it, nfev, r, hist)
        x = xt
        R, J = fun(x)
        nfev += 1
    r = float(np.max(np.abs(R), initial=0.0))
    return NewtonResult(x, False, f"no convergence in {max_iter} iterations: ||R||_inf = {r:.2e}",
                        max_iter, nfev, r, hist)
