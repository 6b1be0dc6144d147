"""Exact solution of HBM with penalty contact: piecewise-linear path following.

With penalty contacts only (eq. 45, any ``k_c``, ``d_c``), the AFT residual is
*exactly piecewise linear* in ``q_hat``: it is affine between the hyperplanes
``g_N(t_j) = 0`` of the ``N_s`` samples.  For stiff ``k_c`` the pieces are tiny
and the solution branch has turning points (the grazing bifurcation of the
impact oscillator), so damped Newton stalls at ``||R|| ~ O(1)`` from any start
that is not already in the right region.  :meth:`PiecewiseLinearPaths.newton_fallback`
(called by :func:`mshbm.solvers.newton.newton` when the line search fails) then traces
the solution curve exactly, segment by segment, through the folds
(:func:`mshbm.solvers.newton.follow_pl_path`):

1. a Newton homotopy ``R(q_hat) = (1 - t) R(q_hat_0)``, ``t: 0 -> 1``, from the
   given start (skipped when the start is the linear response);
2. a gap continuation: all gaps offset by ``lambda``, from ``lambda_0`` where
   the linear response just touches down to ``lambda = 0``.

The end point is polished by Newton on the unmodified residual, and success is
declared only by ``||R / s||_inf <= tol`` of the real problem (``s`` from
:meth:`mshbm.methods.hbm.HBMProblem.residual_scale`): no smoothing of the law is involved.

:class:`PiecewiseLinearPaths` holds these paths for :class:`mshbm.methods.hbm.HBMProblem`, whose
attributes (``E``, ``Vs``, ``VsOm``, ``A``, ``r``, ``keep``, ``nl_cols``, ``local_dof``, ``residual``,
``_jacobian``) it reads.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..solvers.newton import NewtonResult, _scale_function, follow_pl_path, newton, scaled_norm

__all__ = ["PiecewiseLinearPaths"]


class PiecewiseLinearPaths:
    """The exact piecewise-linear paths of an HBM problem with penalty contacts (module docstring)."""

    @property
    def piecewise_linear(self):
        """True if every element's regularised law is piecewise linear (penalty contact, eq. 45).

        The AFT residual is then piecewise affine in ``q_hat``: affine on each
        region where the set of closed samples ``{(t_j, contact): g_N(t_j) <= 0}``
        is fixed.  With ``d_c = 0`` it is also continuous, and the path following
        of :meth:`newton_fallback` is exact.  With ``d_c > 0`` eq. (45) jumps by
        ``d_c gamma_N`` where ``g_N`` changes sign, so the residual jumps too and an
        exact zero need not exist (it is found for small ``d_c``, not for large
        ones).  Contacts relative to a second DOF are
        piecewise linear in the same way (on ``w^T q``).
        """
        els = self.system.elements
        return len(els) > 0 and all(el.piecewise_linear for el in els)

    def _contacts(self):
        """``[(i, element)]``: index ``i`` into ``nl_cols`` of each contact's DOF."""
        cols = {int(c): i for i, c in enumerate(self.nl_cols)}
        return [(cols[d if isinstance(d, (int, np.integer)) else d[0]], el)
                for el, d in zip(self.system.elements, self.local_dof) if el.unilateral]

    def _contact_directions(self):
        """``[[(i, w_i), ...]]`` per contact: indices ``i`` into ``nl_cols`` and entries of ``w``."""
        cols = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
        return [[(cols[int(d)], w) for d, w in el.direction] for _, el in self._contacts()]

    def _gaps(self, x, offset=0.0):
        """Sampled gaps ``g_N(t_j) + offset = gap + offset + w^T q(t_j)`` of the contacts, shape (N_s, n_contacts)."""
        q = self.Vs @ x.reshape(2 * self.n_h + 1, self.nR)[:, self.nl_cols]
        col = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
        return np.stack([el.gap + offset + el.local(q, col) for _, el in self._contacts()], axis=1)

    def _pl_jacobian(self, closed):
        """Jacobian of the residual on the region with closed samples ``closed`` (N_s, n_contacts)."""
        nc, nN = 2 * self.n_h + 1, self.nl_cols.size
        Jn = np.zeros((nc, nN, nc, nN))
        for j, ((i, el), wdir) in enumerate(zip(self._contacts(), self._contact_directions())):
            S = np.flatnonzero(closed[:, j])
            if not S.size:
                continue
            # closed: d f / d q = -k_c w w^T, d f / d u = -d_c w w^T
            block = self.E[:, S] @ (el.penalty_stiffness * self.Vs[S] + el.penalty_damping * self.VsOm[S])
            if el.relative_to is None:
                Jn[:, i, :, i] -= block
            else:
                for a, wa in wdir:
                    for b, wb in wdir:
                        Jn[:, a, :, b] -= (wa * wb) * block
        return self._jacobian(Jn)

    def _gap_derivative(self, closed):
        """``dR / d lambda`` when every gap is offset by ``lambda`` (region ``closed``)."""
        h = np.zeros((2 * self.n_h + 1, self.nR))
        for j, ((i, el), wdir) in enumerate(zip(self._contacts(), self._contact_directions())):
            S = np.flatnonzero(closed[:, j])
            if el.relative_to is None:
                h[:, self.nl_cols[i]] -= el.penalty_stiffness * self.E[:, S].sum(axis=1)
            else:  # R = ... - E w lambda, d lambda / d offset = -k_c on the closed samples
                for a, wa in wdir:
                    h[:, self.nl_cols[a]] += wa * el.penalty_stiffness * self.E[:, S].sum(axis=1)
        return h.reshape(-1)

    def _pl_crossing(self, x, dx, closed, offset, doffset):
        """First sample switch along ``x + s dx`` (gap offset ``offset + s doffset``).

        Returns ``(s, closed_after)``; ``s = inf`` if no sample switches.
        """
        g = self._gaps(x, offset)
        dq = self.Vs @ dx.reshape(2 * self.n_h + 1, self.nR)[:, self.nl_cols]
        col = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
        dg = np.stack([doffset - dq[:, i] if el.relative_to is None else doffset + el.local(dq, col)
                       for i, el in self._contacts()], axis=1)
        moving = np.where(closed, dg > 0.0, dg < 0.0)
        if not moving.any():
            return np.inf, closed
        s = np.full(g.shape, np.inf)
        s[moving] = np.maximum(-g[moving] / dg[moving], 0.0)  # clip: a sample rounded onto the wrong side
        smin = float(s.min())
        flip = moving & (s <= smin * (1.0 + 1e-12))  # simultaneous switches (ties)
        return smin, closed ^ flip

    def _linear_solution(self):
        return np.asarray(spla.spsolve(sp.csc_matrix(self.A), self.r) if sp.issparse(self.A)
                          else np.linalg.solve(self.A, self.r), dtype=float)

    def newton_homotopy_path(self, x0, max_segments=None):
        """Trace ``R(q_hat) = (1 - t) R(q_hat_0)`` exactly from ``t = 0`` (at ``x0``) to ``t = 1``.

        Only for :attr:`piecewise_linear` problems.  Returns a
        :class:`mshbm.solvers.newton.PathResult` (``x`` is the solution if ``success``).
        """
        x0 = np.asarray(x0, dtype=float)
        F0, _ = self.residual(x0, jac=False)
        closed0 = self._gaps(x0) <= 0.0
        return follow_pl_path(lambda x, t, c: (self._pl_jacobian(c), F0),
                              lambda x, t, dx, dt, c: self._pl_crossing(x, dx, c, 0.0, 0.0),
                              x0, 0.0, 1.0, closed0, max_segments=max_segments or self._max_segments())

    def gap_continuation_path(self, max_segments=None):
        """Trace the solution branch exactly while all gaps are offset by ``lambda``, down to ``lambda = 0``.

        Starts at the linear response (``lambda_0`` just above its first touch
        down, no sample closed) and follows the branch through its turning
        points.  Only for :attr:`piecewise_linear` problems.  Returns a
        :class:`mshbm.solvers.newton.PathResult`.
        """
        x_lin = self._linear_solution()
        g = self._gaps(x_lin)
        touch = float(-g.min())  # offset at which the first sample touches
        lam0 = touch + max(1e-9, 1e-6 * abs(touch))
        closed0 = np.zeros(g.shape, dtype=bool)
        return follow_pl_path(lambda x, lam, c: (self._pl_jacobian(c), self._gap_derivative(c)),
                              lambda x, lam, dx, dlam, c: self._pl_crossing(x, dx, c, lam, dlam),
                              x_lin, lam0, 0.0, closed0, direction=-1.0,
                              max_segments=max_segments or self._max_segments())

    def _max_segments(self):
        return 10 * self.Ns * len(self.system.elements) + 1000

    def newton_fallback(self, x0, failed=None, tol=1e-10, scale=None, max_iter=50, callback=None):
        """Second globalisation stage for penalty contact, called by :func:`mshbm.solvers.newton.newton`.

        For :attr:`piecewise_linear` problems, tries in turn (1) the exact Newton
        homotopy from ``x0`` (skipped when ``x0`` is the linear response) and
        (2) the exact gap continuation from the linear response
        (:meth:`newton_homotopy_path`, :meth:`gap_continuation_path`).  Each path
        end is polished by damped Newton on the unmodified residual.

        Parameters
        ----------
        x0 : ndarray
            Start of the failed Newton iteration.
        failed : NewtonResult, optional
            The failed result (unused; part of the hook's signature).
        tol, scale, max_iter, callback
            As in :func:`mshbm.solvers.newton.newton`; success means
            ``||R / s||_inf <= tol`` for the real problem (default scale
            :meth:`residual_scale`).

        Returns
        -------
        NewtonResult or None
            ``None`` when not applicable (smooth laws: friction).
        """
        if not self.piecewise_linear:
            return None
        x0 = np.asarray(x0, dtype=float)
        scale = _scale_function(self.residual, self.residual_scale if scale is None else scale)
        key = (x0.tobytes(), float(tol))
        cache = self.__dict__.setdefault("_fallback_cache", {})
        if key in cache:  # same start already tried (e.g. by a continuation driver)
            return replace(cache[key], history=list(cache[key].history), info=dict(cache[key].info))
        try:
            x_lin = self._linear_solution()
        except (np.linalg.LinAlgError, RuntimeError):
            return None
        routes = []
        if not np.allclose(x0, x_lin, rtol=1e-10, atol=1e-12 * max(1e-300, float(np.max(np.abs(x_lin), initial=0)))):
            routes.append(("Newton homotopy", lambda: self.newton_homotopy_path(x0)))
        routes.append(("gap continuation", self.gap_continuation_path))
        segs, nfev, hist, notes = 0, 0, [], []
        out = None
        for name, run in routes:
            path = run()
            segs += path.segments
            note = f"{name}: {path.message}"
            if path.success:
                pol = newton(self.residual, path.x, tol, max_iter, True, callback, scale)
                if not pol.success:  # end point off by rounding across a kink: short exact path from there
                    path2 = self.newton_homotopy_path(pol.x)
                    segs += path2.segments
                    if path2.success:
                        pol = newton(self.residual, path2.x, tol, max_iter, True, callback, scale)
                segs += pol.nit
                nfev += pol.nfev
                hist += pol.history
                if pol.success:
                    nclosed = (self._gaps(pol.x) <= 0.0).sum(axis=0)
                    info = {"fallback": name, "segments": segs, "folds": path.folds,
                            "closed_samples": [int(k) for k in nclosed]}
                    note = ""
                    if 0 < nclosed.min() < 4:  # the sampled solution is then not unique
                        note = (f"; note: a contact is closed at only {int(nclosed.min())} of {self.Ns} AFT "
                                "samples: under-resolved, increase steps")
                    out = NewtonResult(pol.x, True, f"converged: scaled ||R||_inf = {pol.residual_norm:.2e} by exact "
                                       f"piecewise-linear {name} ({path.segments} segments, {path.folds} "
                                       f"folds) and {pol.nit} Newton iterations{note}", segs, nfev,
                                       pol.residual_norm, hist, info)
                    break
                note += f", but Newton polishing failed: {pol.message}"
            notes.append(note)
        if out is None:
            R, _ = self.residual(x0, jac=False)
            out = NewtonResult(x0, False, "exact piecewise-linear path following failed (" + "; ".join(notes) + ")",
                               segs, nfev, scaled_norm(R, scale(x0)), hist,
                               {"fallback": "failed", "segments": segs})
        cache[key] = replace(out, history=list(out.history), info=dict(out.info))
        return out
