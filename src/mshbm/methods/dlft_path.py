"""DLFT with contacts only: the exact piecewise-linear path from the linear response (a mixin of
:class:`mshbm.methods.dlft.DLFTProblem`).

With contacts only, ``lambda = max(0, y)`` with ``y`` affine in ``X``: the DLFT residual is continuous and
affine on each region of fixed closed samples (as HBM's penalty law), and damped Newton stalls on it from the
linear start.  :meth:`ContactPath.newton_fallback` follows the solution branch exactly from the linear
response, all gaps offset by ``lambda`` from the first touch-down to ``lambda = 0``
(:func:`mshbm.solvers.newton.follow_pl_path`), and polishes by Newton.  Notation as in
:mod:`mshbm.methods.dlft` (``self._el``: the element terms, ``_demand``, ``_wq``).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["ContactPath"]


def spla_solve(A, b):
    return spla.spsolve(sp.csc_matrix(A), b) if sp.issparse(A) else np.linalg.solve(A, b)


class ContactPath:
    """Exact gap continuation for DLFT problems whose elements are all contacts."""

    @property
    def piecewise_linear(self):
        """True if every element is a contact: ``lambda = max(0, y)`` with ``y`` affine in ``X``, so the
        residual is continuous and affine on each region of fixed closed samples (as HBM's penalty law)."""
        els = self.system.elements
        return len(els) > 0 and all(el.unilateral for el in els)

    def _y(self, x, offset=0.0):
        """Predictions ``y`` of the contacts with every gap offset by ``offset``, shape (N_s, m)."""
        linear = self.A @ x - self.r
        cols = []
        for t in self._el:
            cols.append(self._demand(t, linear) - self.eps[t.j] * (self._wq(t, x) + t.el.gap + offset))
        return np.stack(cols, axis=1)

    def _pl_residual_jac(self, closed):
        """``(dR/dx, dR/d offset)`` on the region ``closed`` (N_s, m)."""
        if sp.issparse(self.A):
            J = self.A.tolil(copy=True)
        else:
            J = self.A.copy()
        h = np.zeros(self.n_unknowns)
        for k, t in enumerate(self._el):
            S = np.flatnonzero(closed[:, k])
            if S.size:
                B0 = self.E[:, S] @ t.Q[S]
                for rows, w in zip(t.rows, t.w):
                    B = w * B0
                    if sp.issparse(self.A):
                        J[np.ix_(rows, t.cols)] = J[np.ix_(rows, t.cols)].toarray() - B
                    else:
                        J[np.ix_(rows, t.cols)] -= B
                    h[rows] += w * self.eps[t.j] * self.E[:, S].sum(axis=1)  # d lambda / d offset = -eps
        return (J.tocsr() if sp.issparse(self.A) else J), h

    def _pl_crossing(self, x, dx, closed, offset, doffset):
        y = self._y(x, offset)
        dy = self._y(dx, 0.0) - self._y(np.zeros_like(x), 0.0)  # linear part of y along dx
        for k, t in enumerate(self._el):
            dy[:, k] -= self.eps[t.j] * doffset
        moving = np.where(closed, dy < 0.0, dy > 0.0)
        if not moving.any():
            return np.inf, closed
        sv = np.full(y.shape, np.inf)
        sv[moving] = np.maximum(-y[moving] / dy[moving], 0.0)
        smin = float(sv.min())
        return smin, closed ^ (moving & (sv <= smin * (1.0 + 1e-12)))

    def newton_fallback(self, x0, failed=None, tol=1e-10, scale=None, max_iter=50, callback=None):
        """Contacts only: exact piecewise-linear gap continuation from the linear response.

        All gaps are offset by ``lambda``, from just above the first touch-down of the linear response
        (no sample closed) down to ``lambda = 0``, through the turning points
        (:func:`mshbm.solvers.newton.follow_pl_path`); the end point is polished by Newton on the
        unmodified residual.  Hook of :func:`mshbm.solvers.newton.newton`; ``None`` for friction.
        """
        if not self.piecewise_linear:
            return None
        from ..solvers.newton import NewtonResult, _scale_function, follow_pl_path, newton, scaled_norm

        scale = _scale_function(self.residual, self.residual_scale if scale is None else scale)
        key = float(tol)
        cache = self.__dict__.setdefault("_fallback_cache", {})
        if key in cache:
            return cache[key]
        try:
            x_lin = np.asarray(spla_solve(self.A, self.r), dtype=float)
        except (np.linalg.LinAlgError, RuntimeError):
            return None
        y = self._y(x_lin)
        lam0 = float(np.max(y / self.eps[None, :]))  # offset at which the first sample touches
        lam0 += max(1e-9, 1e-6 * abs(lam0))
        closed0 = np.zeros(y.shape, dtype=bool)
        path = follow_pl_path(lambda x, lam, c: self._pl_residual_jac(c),
                              lambda x, lam, dx, dlam, c: self._pl_crossing(x, dx, c, lam, dlam),
                              x_lin, lam0, 0.0, closed0, direction=-1.0,
                              max_segments=10 * self.Ns * len(self.system.elements) + 1000)
        out = None
        if path.success:
            pol = newton(self.residual, path.x, tol, max_iter, True, callback, scale)
            if pol.success:
                out = NewtonResult(pol.x, True, f"converged: scaled ||R||_inf = {pol.residual_norm:.2e} by exact "
                                   f"piecewise-linear gap continuation ({path.segments} segments, {path.folds} "
                                   f"folds) and {pol.nit} Newton iterations", path.segments + pol.nit,
                                   pol.nfev, pol.residual_norm, pol.history,
                                   {"fallback": "gap continuation", "segments": path.segments, "folds": path.folds})
            note = "" if pol.success else f", but Newton polishing failed: {pol.message}"
        else:
            note = ""
        if out is None:
            R, _ = self.residual(np.asarray(x0, dtype=float), jac=False)
            out = NewtonResult(np.asarray(x0, dtype=float), False, f"exact piecewise-linear gap continuation failed "
                               f"({path.message}{note})", path.segments, 0, scaled_norm(R, scale(x0)), [],
                               {"fallback": "failed", "segments": path.segments})
        cache[key] = out
        return out

