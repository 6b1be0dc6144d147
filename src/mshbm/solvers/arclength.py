"""Pseudo-arclength continuation of a residual ``R(x, lam) = 0`` in a scalar parameter ``lam``.

Generic: the driver knows nothing about methods.  It takes callables (like NLvib's one
continuation driver for any residual):

``residual(x, lam) -> (R, J)``
    the residual (shape ``(n_x,)``) and its Jacobian ``dR/dx`` (``(n_x, n_x)``);
``d_lam(x, lam) -> dR/dlam``
    the derivative in the parameter (``(n_x,)``);
``residual_scale(x, lam) -> s``
    per-row scale of ``R``: converged when ``||R / s||_inf <= tol`` (:mod:`mshbm.scaling`);
``unknown_scale(x, lam) -> w``
    per-unknown scale of ``x`` in its physical units (m, m/s), taken from the *current solution*
    and the problem, never from the start.

Scaled variables ``y = x / w``, ``mu = lam / lam_scale`` make the arclength
``ds^2 = ||dx / w||^2 + (dlam / lam_scale)^2`` dimensionless: ``ds = 0.05`` is a step of 5 % of the
solution's size or of ``lam_scale`` (for a frequency sweep ``lam_scale`` is the start frequency).

Algorithm (Keller's pseudo-arclength):

* tangent ``t`` (unit, scaled): the null vector of ``[J_y, g]`` (``J_y = diag(1/s) J diag(w)``,
  ``g = diag(1/s) dR/dlam lam_scale``), oriented so that ``t . t_prev > 0`` -- this carries the
  direction of travel through turning points (folds), where the ``lam`` component of ``t`` changes
  sign;
* predictor: ``(y, mu) + ds t`` (tangent) or along the secant of the last two points;
* corrector: Newton on the bordered system ``[R / s; t . ((y, mu) - predictor)] = 0`` (the
  hyperplane through the predictor orthogonal to ``t``), with backtracking on the scaled residual;
* step control: ``ds`` grows by ``grow`` after a corrector of at most ``fast_iter`` iterations,
  shrinks by ``shrink`` after one of more than ``slow_iter``, and grows at most to ``ds max_turn / theta``
  after a step whose tangent turned by ``theta`` (curvature); a failed (or rejected, see ``accept``)
  corrector halves ``ds`` and retries, down to ``ds_min``;
* kinks (nonsmooth points of the branch, e.g. a grazing impact: the saltation of an impact at velocity
  ``v`` grows like ``1 / v``, so ``dR/dx`` jumps there and the branch has a corner): where a step passes a
  change of the residual's smooth piece (``segment``, e.g. the event sequence) and the tangent
  turns by more than ``acos(KINK_COS)``, the sign of ``t . t_prev`` says nothing about the
  way on, and the new tangent is oriented to keep the curve's orientation ``sign det [J_y, g; t]``
  instead (constant along regular points, folds included; it changes only at branch points, where the
  tangent turns little).  When the corrector cannot turn a corner (``ds < ds_min``: past a corner of
  more than 90 degrees the hyperplane misses the outgoing piece and Newton cycles between the pieces),
  one step at fixed ``lam`` in the direction of travel (relative ``KINK_STEPS``) crosses it where the
  branch passes it monotonically in ``lam``; the result lists the ``kinks``;
* stop: at ``lam_end`` (the last point is solved at ``lam = lam_end`` exactly), after
  ``max_points`` points, when ``ds < ds_min`` (and no step at fixed ``lam`` helps), or when the branch
  turns back beyond the start;
* folds: a sign change of the ``lam`` component of the tangent between two points is located by
  a secant/bisection on the arclength from the earlier point, to ``fold_rtol`` in ``lam``.
"""
from __future__ import annotations

import time

import numpy as np

from .arclength_parts import (ContinuationPoint, ContinuationResult, Evaluator, Failed, backtrack, bordered_solve,
                              free_directions, orientation, stall_folds, tangent)
from .arclength_kinks import KINK_STEPS, cross_kink, family_step, fold_or_corner
from .arclength_fallbacks import Fallbacks
from .arclength_steps import PREDICTED, next_ds, smooth_step
from .newton import newton, work_spent

#: a step whose tangents at its ends have ``|cos| <`` this is taken as a kink of the branch (see ``continuation``)
KINK_COS = 0.9
#: the corrector finishes at fixed lam once its scaled residual is below this (see ``_Trace.corrector``)
POLISH_AT = 1e-6

__all__ = ["ContinuationPoint", "ContinuationResult", "continuation", "tangent", "orientation"]


def continuation(residual, d_lam, x0, lam0, lam_end, *, residual_scale, unknown_scale, lam_scale=None,
                 ds0=0.02, ds_min=1e-5, ds_max=0.2, max_points=200, tol=1e-10, max_corrector_iter=12,
                 fast_iter=3, slow_iter=7, grow=1.6, shrink=0.5, predictor="tangent", accept=None,
                 callback=None, fold_rtol=1e-3, max_time=None, lam_limits=None, stall_accept=None, max_jump=3.0,
                 stall_fold_rtol=5e-3, natural_fallback=True, kink_crossing=True, segment=None, max_turn=0.5,
                 restarts=None, ds_rough=None, predicted=None, gauge=None, early_polish=True, solve_at=None):
    """Trace the branch of ``R(x, lam) = 0`` from the converged point ``(x0, lam0)`` towards ``lam_end``.

    Parameters
    ----------
    residual, d_lam, residual_scale, unknown_scale : callable
        See the module docstring.
    x0 : ndarray
        A solution at ``lam0`` (``||R / s||_inf <= tol``, else the first corrector makes it one).
    lam0, lam_end : float
        Start and end of the parameter range; the branch is followed in the direction of
        ``lam_end`` and stops when it reaches it.
    lam_scale : float
        Scale of ``lam`` in the arclength (default ``|lam0|``, or 1).
    ds0, ds_min, ds_max : float
        Initial, smallest and largest arclength step (scaled, see the module docstring).
    ds_rough : float, optional
        Largest step after a step that was not smooth (default ``ds_max``): a point accepted at step accuracy
        (``stall_accept``), a kink, a change of the smooth piece (``segment``) or of the free directions, or
        a corrector slower than ``slow_iter``, or a failed step.  Steps grow beyond it, up to ``ds_max``, only
        along a smooth stretch, where the tangent's turn (``max_turn``) measures the curve: a branch that is
        linear in effect is traced in tens of points, while corners and staircases keep the cautious step.
    gauge : callable, optional
        ``gauge(x, lam, F) -> x or None``: where the solutions at fixed ``lam`` form a family (free directions
        ``F``, rows: directions in the physical unknowns, each a unit step in the scaled ones, of
        :func:`mshbm.solvers.arclength_parts.free_directions`), the member
        of the family a rule picks (e.g. every stuck friction element's force centred in its admissible range);
        each such point is replaced by it when its residual stays within ``tol`` (counter ``gauged``).  Without
        it the family is held by minimum-norm steps (the offset where the branch brought it).
    predicted : float, optional
        After a smooth step (as for ``ds_rough``) whose tangent predictor missed the corrected point by at most
        ``predicted * ds`` (scaled), the step grows as after a fast corrector, whatever the corrector's iteration
        count (its further iterations only meet ``tol``; e.g. :data:`PREDICTED`).  Default: off.
    max_points : int
        Most points on the branch (the start included).
    tol : float
        Corrector tolerance on ``||R / s||_inf``.
    max_corrector_iter, fast_iter, slow_iter, grow, shrink
        Step control (module docstring).
    predictor : {"tangent", "secant"}
    accept : callable, optional
        ``accept(x, lam, stall) -> (ok, payload)`` after each converged corrector (e.g. a certificate;
        ``stall`` is what ``stall_accept`` returned, else ``None``); a rejected point counts as a
        failed corrector.  The payload is stored on the point.
    max_turn : float
        Largest turn (radians) of the scaled tangent per step: after a step whose tangent turned by ``theta``
        the step grows at most to ``ds max_turn / theta`` (the curve's curvature, not only the corrector's
        effort, bounds the growth; it never shrinks the step, which the corrector's effort does; 0 disables).
    max_jump : float
        A corrected point farther than ``max_jump * max(ds, ds0)`` (scaled) from the last point is rejected
        (a jump to another branch) and the step is shortened.  (Not ``ds`` alone: near points accepted at
        step accuracy, Newton moves by about one time step's worth whatever ``ds`` is.)
    stall_fold_rtol : float
        Folds next to points accepted by ``stall_accept`` (their tangents come from a map that moves
        events by whole steps and jitter) are taken from the sequence of ``lam`` along the branch
        instead: a turning point whose reversal exceeds ``stall_fold_rtol`` (relative), located at the
        extreme point (``"located": "extreme point"``).
    segment : callable, optional
        ``segment(x, lam) -> hashable or None``: which smooth piece of a piecewise-smooth residual the point
        lies on (e.g. the event sequence of an event-driven flow).  Where it differs between two points the
        step passed a kink, and the tangent there keeps the curve's orientation (module docstring); without
        it (or where it returns ``None``) every step is taken as smooth.
    early_polish : bool
        Finish the corrector by Newton at fixed ``lam`` as soon as the bordered iteration's residual is below
        ``POLISH_AT`` (default), or only where that iteration stalls (the backbone's residual: polished early, the
        impact oscillator's corner at a grazing is met again from the other side and the trace stops).
    kink_crossing : bool
        When the step falls below ``ds_min`` at a point solved exactly (not by ``stall_accept``), try one
        step at fixed ``lam`` across a kink (module docstring) before stopping, once per point.
    solve_at : callable, optional
        ``solve_at(lam, x) -> x or None``: a pointwise solve at ``lam`` by other means than Newton from a nearby point
        (e.g. the method's own start ladder and exact path followers; ``x`` the last point, a hint).  Where a
        natural-parameter step across a gap fails (Newton at fixed ``lam`` from the last point does not converge:
        a residual that is nonsmooth on a scale below the step, e.g. a stiff penalty law), its point at that ``lam``
        is taken from it (counter ``pointwise_points``; the gap is recorded as any other) before the step is halved.
    restarts : callable, optional
        ``restarts(x, lam) -> list of x``: other Newton starts for the step at fixed ``lam`` across a kink
        (:func:`mshbm.solvers.arclength_kinks.cross_kink`) where the unknowns jump along the branch (a shooting
        method's state at ``t = 0`` when an event crosses that section).
    natural_fallback : bool
        When the step falls below ``ds_min`` at a point accepted by ``stall_accept``, continue by
        natural-parameter steps (Newton at fixed ``lam`` from the last point, ``lam`` step adapted,
        points accepted at step accuracy too) to ``lam_end``; this passes no fold, and the message says
        so.  The residual of a time-stepping method at impacts is a staircase in ``(x, lam)`` (the map
        moves impacts by whole steps), so its Jacobian and ``dR/dlam`` may not predict at all.
    stall_accept : callable, optional
        ``stall_accept(x, lam) -> info or None``: when the corrector *stalls* (no descent of the scaled
        residual, or ``max_corrector_iter`` reached) above ``tol``, the iterate is accepted when this
        returns a truthy ``info`` (e.g. an orbit periodic to one time step's accuracy of a
        time-stepping method, whose discrete map moves impacts by whole steps and has no exact
        root; :class:`mshbm.route.acceptance.ResidualTest`).
    callback : callable, optional
        ``callback(point, n_points, ds)`` after each accepted point (progress display).
    fold_rtol : float
        Relative accuracy in ``lam`` of the located folds.
    max_time : float, optional
        Wall-time limit (s).
    lam_limits : (float, float), optional
        The branch stops when ``lam`` leaves this interval (default: the range widened by half its
        length on both sides, for a positive range at most down to half its lower end).

    Returns
    -------
    ContinuationResult
        Its ``counters`` include ``free_points`` (points solved, kept or not, where the solutions at fixed
        ``lam`` form a family: :func:`mshbm.solvers.arclength_parts.free_directions`), ``free_dimension``
        (the family's largest number of free directions, held fixed by minimum-norm steps) and
        ``family_steps`` (corners at the family's edge crossed at fixed ``lam``).
    """
    ev = Evaluator(residual, d_lam, residual_scale, unknown_scale,
                    lam_scale if lam_scale is not None else (abs(lam0) if lam0 != 0 else 1.0))
    trace = _Trace(ev, unknown_scale, lam0, lam_end, lam_limits, dict(
        ds0=ds0, ds_min=ds_min, ds_max=ds_max, max_points=max_points, tol=tol,
        max_corrector_iter=max_corrector_iter, fast_iter=fast_iter, slow_iter=slow_iter, grow=grow, shrink=shrink,
        predictor=predictor, accept=accept, callback=callback, fold_rtol=fold_rtol, max_time=max_time,
        stall_accept=stall_accept, max_jump=max_jump, stall_fold_rtol=stall_fold_rtol,
        natural_fallback=natural_fallback, kink_crossing=kink_crossing, segment=segment, max_turn=max_turn,
        restarts=restarts, ds_rough=ds_max if ds_rough is None else min(ds_rough, ds_max), predicted=predicted,
        gauge=gauge, early_polish=early_polish, solve_at=solve_at))
    return trace.run(x0)


class _Trace(Fallbacks):
    """One run of :func:`continuation`: its settings (the keyword arguments of :func:`continuation`, as
    attributes), the branch so far (``points``, ``folds``, ``kinks``, ``counters``) and the step state
    (``ds``; ``natural``, the step in ``lam`` once natural-parameter steps have taken over)."""

    def __init__(self, ev, unknown_scale, lam0, lam_end, lam_limits, settings):
        self.__dict__.update(settings)
        self.ev, self.unknown_scale, self.lam0, self.lam_end = ev, unknown_scale, lam0, lam_end
        self.lsc = ev.lam_scale
        self.direction = 1.0 if lam_end >= lam0 else -1.0
        span = abs(lam_end - lam0)
        lo, hi = lam_limits if lam_limits is not None else (min(lam0, lam_end) - 0.5 * span,
                                                             max(lam0, lam_end) + 0.5 * span)
        if lam_limits is None and min(lam0, lam_end) > 0:  # a positive parameter: at most down to half the range's start
            lo = max(lo, 0.5 * min(lam0, lam_end))
        self.lo, self.hi = lo, hi
        self.t_start = time.perf_counter()
        self.counters = {"corrector_failures": 0, "rejected": 0, "corrector_iterations": 0}
        self.points, self.folds, self.kinks = [], [], []
        self.ds, self.message, self.success = self.ds0, "", False
        self.natural, self.natural_reason, self.gap_from = None, "", None
        self.crossed_from = -1  # the point from which a step at fixed lam across a kink was last tried

    # ------------------------------------------------------------------ the corrector
    def stalled(self, x, lam):
        return self.stall_accept(x, lam) if self.stall_accept is not None else None

    def newton_fixed(self, x, lam, allow_stall=True, max_iter=None, free=None):
        """Newton at fixed ``lam`` (the start and the end point); returns (x, it, r, data, stall).  ``free``:
        the free directions of the point ``x`` comes from, in physical units (rows ``F / w``), held fixed."""
        ev, tol = self.ev, self.tol
        best = None
        max_iter = self.max_corrector_iter if max_iter is None else max_iter
        for it in range(max_iter + 1):
            R, s, r, J, _ = ev(x, lam, dlam=False)  # dR/dlam only at the point returned (fixed lam)
            if best is None or r < best[2]:
                best = (x, it, r, (R, s, J, None))
            if r <= tol:
                return x, it, r, (R, s, J, ev.g(x, lam)), None
            if it == max_iter:
                break
            dx = bordered_solve(J / s[:, None], -R / s, free=free)
            xn, ok = backtrack(lambda xx: ev(xx, lam, jac=False)[2], x, dx, r)
            if not ok:
                break
            x = xn
        info = self.stalled(best[0], lam) if allow_stall else None
        if info:
            R, s, J, _ = best[3]
            return best[:3] + ((R, s, J, ev.g(best[0], lam)), info)
        raise Failed(f"Newton at fixed parameter {lam:.6g} did not converge (||R/s|| = {r:.2e})")

    def corrector(self, xp, lp, t, w, ds, free=None):
        """Bordered Newton from the predictor ``(xp, lp)`` on the hyperplane orthogonal to ``t``; ``free``: the
        free directions (scaled) of the point the step comes from, held fixed (minimum-norm corrections)."""
        ev, tol, lsc, lam0, ds0 = self.ev, self.tol, self.lsc, self.lam0, self.ds0
        max_corrector_iter, max_jump = self.max_corrector_iter, self.max_jump
        x, lam = xp.copy(), lp
        ty, tm = t[:-1], t[-1]
        best, polished = None, False
        for it in range(max_corrector_iter + 1):
            if lam0 > 0 >= lam:  # a positive parameter (frequency, load factor) stays positive
                raise Failed("the corrector left the positive parameter range")
            if abs(lam - lp) > max_jump * max(ds, ds0) * lsc:
                raise Failed(f"the corrector moved the parameter to {lam:.6g}, more than {max_jump:g} x max(ds, ds0) "
                              "from the predictor (a jump, or a useless dR/dlam)")
            r_prev = r if it > 0 else np.inf
            R, s, r, J, g = ev(x, lam)
            c = float(ty @ ((x - xp) / w) + tm * (lam - lp) / lsc)
            if np.isfinite(r) and abs(c) <= 1e-8 and (best is None or r < best[3]):
                best = (x, lam, it, r, (R, s, J, g))
            if r <= tol and abs(c) <= 1e-8:
                return x, lam, it, r, (R, s, J, g), None
            if it > 0 and r <= POLISH_AT and ((self.early_polish and not polished) or r > 0.9 * r_prev):
                # the parameter has converged to within the step's accuracy: finish by Newton on x alone at this
                # lam, first as soon as the residual is below POLISH_AT, again where the bordered iteration no
                # longer lowers it (by 10 % at least).  dR/dlam (central differences of rebuilt problems) carries
                # its rounding, e.g. a condensation's LU, and the bordered iteration creeps or stalls at that
                # noise (a linear problem: 5-7 iterations from 1e-7 to 1e-10 where Newton at fixed lam takes one);
                # at fixed lam it plays no role, and the step control then sees the corrector's real effort
                polished = True
                try:
                    xf, itf, rf, dataf, _ = self.newton_fixed(x, lam, allow_stall=False, max_iter=4,
                                                              free=None if free is None else free / w[None, :])
                    if float(np.linalg.norm((xf - x) / w)) <= 0.1 * max(ds, ds0):
                        self.counters["polish_iterations"] = self.counters.get("polish_iterations", 0) + itf
                        return xf, lam, it + itf, rf, dataf, None
                except Failed:
                    pass
            if it == max_corrector_iter or not np.isfinite(r):
                break
            A = np.zeros((x.size + 1, x.size + 1))
            A[:-1, :-1] = (J * w[None, :]) / s[:, None]
            A[:-1, -1] = g * lsc / s
            A[-1, :-1], A[-1, -1] = ty, tm
            z = bordered_solve(A, -np.concatenate([R / s, [c]]), free=free)
            dx, dl = z[:-1] * w, z[-1] * lsc
            a, accepted = 1.0, False
            for _ in range(8):  # backtracking on the scaled residual
                xt, lt = x + a * dx, lam + a * dl
                if lt > 0 or lam0 <= 0:
                    rt = ev(xt, lt, jac=False)[2]
                    if np.isfinite(rt) and rt < max(r, tol):
                        accepted = True
                        break
                a *= 0.5
            if not accepted:
                break  # stalled: no descent along the Newton direction
            x, lam = xt, lt
        if best is not None:
            # the bordered iteration stalled: polish at the parameter reached (a natural-parameter Newton
            # on x alone often finds the root that the joint line search misses), else accept the stall
            try:
                xf, itf, rf, dataf, _ = self.newton_fixed(best[0], best[1], allow_stall=False,
                                                          free=None if free is None else free / w[None, :])
                if float(np.linalg.norm((xf - best[0]) / w)) <= 0.5 * max(ds, ds0):  # the same root, not another
                    return xf, best[1], best[2] + itf, rf, dataf, None
            except Failed:
                pass
            info = self.stalled(best[0], best[1])
            if info:
                return best + (info,)
        raise Failed(f"corrector did not converge in {max_corrector_iter} iterations (||R/s|| = {r:.2e})")

    # ------------------------------------------------------------------ points and the predictor
    def make_point(self, x, lam, it, r, data, ds, prev_t, stall=None):
        R, s, J, g = data
        lsc, segment = self.lsc, self.segment
        w = np.asarray(self.unknown_scale(x, lam), dtype=float)
        free = free_directions(J, g, s, w, lsc)
        if free is not None and self.gauge is not None and stall is None:
            x, r, (R, s, J, g), w, free = self.gauged(x, lam, r, (R, s, J, g), w, free)
        t = tangent(J, g, s, w, lsc, previous=prev_t, free=free)
        seg = segment(x, lam) if segment is not None and stall is None else None
        if free is not None:
            self.counters["free_points"] = self.counters.get("free_points", 0) + 1
            self.counters["free_dimension"] = max(self.counters.get("free_dimension", 0), int(free.shape[0]))
        return ContinuationPoint(x=x, lam=float(lam), dx=t[:-1] * w, dlam=float(t[-1] * lsc), iterations=it,
                                 ds=ds, residual=r, stall=stall, segment=seg, free=free,
                                 orientation=orientation(J, g, s, w, lsc, t) if seg is not None and free is None
                                 else 0), t, w

    def gauged(self, x, lam, r, data, w, free):
        """The member of the family through ``x`` that ``gauge`` picks, with its residual, data, scale and free
        directions; ``x`` itself when the gauge declines or its point is not a solution (``tol``)."""
        try:
            xg = self.gauge(x, lam, free * w[None, :])  # the directions in physical units
        except (ValueError, FloatingPointError, np.linalg.LinAlgError):
            xg = None
        if xg is None:
            return x, r, data, w, free
        R, s, rg, J, g = self.ev(np.asarray(xg, dtype=float), lam)
        if not rg <= max(self.tol, r):
            self.counters["gauge_rejected"] = self.counters.get("gauge_rejected", 0) + 1
            return x, r, data, w, free
        self.counters["gauged"] = self.counters.get("gauged", 0) + 1
        wg = np.asarray(self.unknown_scale(xg, lam), dtype=float)
        fg = free_directions(J, g, s, wg, self.lsc)
        return xg, rg, (R, s, J, g), wg, free if fg is None else fg

    @staticmethod
    def free_units(p, w):
        """The free directions of point ``p`` as rows on the physical unknowns (``F / w``), or None."""
        return None if p.free is None else p.free / w[None, :]

    def scaled_t(self, p, w):
        t = np.concatenate([p.dx / w, [p.dlam / self.lsc]])
        return t / np.linalg.norm(t)

    def step(self, p, w, ds, prev=None):
        """Predict from point ``p`` by ``ds`` and correct; returns (x, lam, it, r, data, stall)."""
        lsc = self.lsc
        t = self.scaled_t(p, w)
        if self.predictor == "secant" and prev is not None:
            d = np.concatenate([(p.x - prev.x) / w, [(p.lam - prev.lam) / lsc]])
            nd = np.linalg.norm(d)
            if nd > 0 and float(d @ t) > 0:
                t = d / nd
        xp, lp = p.x + ds * t[:-1] * w, p.lam + ds * t[-1] * lsc
        if p.free is None:
            out = self.corrector(xp, lp, t, w, ds)
        else:
            try:
                out = self.corrector(xp, lp, t, w, ds, free=p.free)
            except Failed:
                # the step left the family (a stuck element starts to slip: its offset is no longer free)
                out = self.corrector(xp, lp, t, w, ds)
        if out[-1] is not None and p.stall is None:
            # accepted at step accuracy only (the iterate may lie off the curve by that much, ahead of it or behind):
            # Newton with an Armijo line search at that lam from the last point often reaches the root the
            # corrector missed (the exact solution's start of mshbm.solve)
            lam = out[1]
            def fun(xx, jac=True):
                R, J = self.ev.residual(xx, lam)
                return (R, J) if jac else (R, None)

            res = newton(fun, p.x, tol=self.tol, max_iter=2 * self.max_corrector_iter,
                         scale=lambda xx: self.ev.residual_scale(xx, lam))
            if res.success and float(np.linalg.norm((res.x - out[0]) / w)) <= self.max_jump * max(ds, self.ds0):
                R, s_, r, J, g = self.ev(res.x, lam)
                self.counters["stall_solved"] = self.counters.get("stall_solved", 0) + 1
                self.counters["stall_solve_iterations"] = self.counters.get("stall_solve_iterations", 0) + res.nit
                # the step control sees the corrector's own count, as for an accepted stall
                return (res.x, lam, out[2], r, (R, s_, J, g), None), t
        return out, t

    def judged(self, q, what="point rejected", detail=True):
        """``q`` with the payload of ``accept`` (none without it); :class:`Failed` when it rejects ``q`` (its
        message ``what``, with ``detail`` followed by the payload when that is a reason)."""
        if self.accept is not None:
            ok, q.payload = self.accept(q.x, q.lam, q.stall)
            if not ok:
                raise Failed(what + (f": {q.payload}" if detail and isinstance(q.payload, str) else ""))
        return q

    def add(self, q, ds):
        self.failures_at_point = self.counters["corrector_failures"]  # see smooth_step
        self.points.append(q)
        if self.callback is not None:
            self.callback(q, len(self.points), ds)

    # ------------------------------------------------------------------ kinks and the end of the range
    def cross_kink(self, p, w):
        return cross_kink(self, p, w)

    def near_family(self, back=4):
        """A point among the last ``back`` has free directions (:func:`free_directions`)."""
        return any(p.free is not None for p in self.points[-back:])

    def family_step(self, p, w):
        return family_step(self, p, w)

    # ------------------------------------------------------------------ the steps
    def arclength_step(self, p, w):
        """One predictor-corrector step of length ``ds`` from ``p``, with the kink test and the guards
        against no progress and jumps; returns ``(q, it, kink)`` or raises :class:`Failed`."""
        points, lsc, ds, direction = self.points, self.lsc, self.ds, self.direction
        (x, lam, it, r, data, st), t_used = self.step(p, w, ds, points[-2] if len(points) > 1 else None)
        self.counters["corrector_iterations"] += it
        q, tq, wq = self.make_point(x, lam, it, r, data, ds,
                                    self.scaled_t(p, np.asarray(self.unknown_scale(x, lam), float)), st)
        tp = self.scaled_t(p, wq)
        c_t = float(tq @ tp)
        if q.segment is not None and p.segment != q.segment and (lam - p.lam) * p.dlam < 0 \
                and q.segment == self.previous_segment():
            # back, against the direction of travel, onto the smooth piece the branch came from: past a grazing
            # the new piece can be steep (an impact velocity grows like the square root of the distance to it),
            # and the hyperplane of a long step meets the old piece behind the kink; a shorter step stays on.
            # (A corner that turns back onto another piece, e.g. an impacting branch ending at a grazing with
            # the non-impacting one, is not this: the piece before the current one differs.)
            raise Failed("the step went back across a kink onto the piece the branch came from")
        if p.segment is not None and q.segment is not None and p.segment != q.segment and c_t < KINK_COS \
                and p.orientation and q.orientation and q.orientation != p.orientation:
            # the step passed a change of the residual's smooth piece and the tangent turned by more than
            # acos(KINK_COS): a kink of the branch (a nonsmooth point, e.g. a grazing impact, whose saltation
            # makes dR/dx jump), where the sign of t_p says nothing about the way on.  The orientation of the
            # curve, sign det [A; t], is kept instead (constant along a branch of regular points, folds included)
            q.dx, q.dlam, q.orientation = -q.dx, -q.dlam, -q.orientation
            kink = {"lam": float(p.lam), "lam_right": float(lam), "index": len(points), "cos_tangents": -c_t}
        else:
            kink = None
        moved = np.concatenate([(x - p.x) / w, [(lam - p.lam) / lsc]])  # the step in scaled units
        if p.free is not None:  # a move within the family of a stuck element is no jump
            moved[:-1] -= p.free.T @ (p.free @ moved[:-1])
        dist = float(np.linalg.norm(moved))
        if p.segment is not None and st is None and float(self.scaled_t(p, w) @ moved) < 0.1 * ds:
            # a corrector polished at fixed lam (see ``corrector``) can return to p itself (at a corner
            # the hyperplane misses the outgoing piece): no progress along the branch (checked on
            # piecewise-smooth residuals, ``segment``)
            raise Failed("the corrected point did not advance along the branch")
        if dist > self.max_jump * max(ds, self.ds0):
            raise Failed(f"the corrector moved {dist:.3g} away, more than {self.max_jump:g} x max(ds, ds0) "
                          "(a jump to another branch?)")
        if len(points) == 1 and (lam - p.lam) * direction < 0:
            # the start tangent points towards lam_end: a first step away from it means the tangent
            # was useless (e.g. dR/dlam of an orbit accepted at step accuracy), never a fold
            raise Failed("the first step moved away from lam_end")
        if self.accept is not None:
            ok, q.payload = self.accept(q.x, q.lam, q.stall)
            if not ok:
                self.counters["rejected"] += 1
                raise Failed("point rejected" + (f": {q.payload}" if isinstance(q.payload, str) else ""))
        return q, it, kink

    def previous_segment(self):
        """The smooth piece (``segment``) of the branch before the run of points on the last point's piece
        (``None`` when there is none or it is not known)."""
        last = self.points[-1].segment
        for o in reversed(self.points[:-1]):
            if o.segment != last:
                return o.segment
        return None

    def fold(self, step_p, w, q):
        return fold_or_corner(self, step_p, w, q)

    # ------------------------------------------------------------------ the branch
    def start(self, x0):
        """The start point (Newton at ``lam0``), oriented towards ``lam_end``; a failure as a result."""
        lam0 = self.lam0
        try:
            x, it, r, data, st = self.newton_fixed(np.asarray(x0, dtype=float), float(lam0))
        except Failed as exc:
            return ContinuationResult([], False, f"start point: {exc}", [], self.counters)
        p0, t0, _ = self.make_point(x, lam0, it, r, data, 0.0, None, st)
        if t0[-1] * self.direction < 0:  # orient towards lam_end
            p0.dx, p0.dlam, p0.orientation = -p0.dx, -p0.dlam, -p0.orientation
        if self.accept is not None:
            ok, p0.payload = self.accept(p0.x, p0.lam, p0.stall)
            if not ok:
                return ContinuationResult([p0], False, "the start point was rejected", [], self.counters)
        self.add(p0, self.ds0)
        return None

    def run(self, x0):
        failed = self.start(x0)
        if failed is not None:
            return failed
        points, lam_end, direction = self.points, self.lam_end, self.direction
        while True:
            if len(points) >= self.max_points:
                self.message = f"stopped after {self.max_points} points (max_points) at lam = {points[-1].lam:.6g}"
                break
            if self.max_time is not None and time.perf_counter() - self.t_start > self.max_time:
                self.message = f"stopped by the time limit ({self.max_time:g} s) at lam = {points[-1].lam:.6g}"
                break
            spent = work_spent()
            if spent is not None:  # a work budget of the solve route (mshbm.solvers.newton.work_box)
                self.message = f"stopped by the {spent} at lam = {points[-1].lam:.6g}"
                break
            p = points[-1]
            w = np.asarray(self.unknown_scale(p.x, p.lam), dtype=float)
            if self.natural is not None:  # natural-parameter steps (see failed_step)
                if self.natural_step(p, w):
                    break
                continue
            try:
                q, it, kink = self.arclength_step(p, w)
                if p.dlam * q.dlam <= 0 and self.near_family():
                    q, it, kink = self.family_step(p, w), 0, None
            except Failed as exc:
                if self.failed_step(p, w, exc):
                    break
                continue
            if kink is not None:
                self.kinks.append(kink)
                self.counters["kinks"] = self.counters.get("kinks", 0) + 1
            back = self.revisited(q, w)
            lam_back = None if back is None else points[back].lam  # (cross_cycle may drop the cycle's points)
            if back is not None and self.cross_cycle(back, w):  # a kink the corrector turns back on: crossed at fixed lam
                if points[-1].lam == lam_end:
                    self.success, self.message = True, f"reached lam_end = {lam_end:.6g} in {len(points)} points"
                    break
                continue
            if back is not None and self.stuck(back):  # a repeat of one of the last points: a gap onwards
                continue
            if back is not None:  # the curve closed on itself: it would be traced again and again
                self.message = (f"the continuation came back to its point {back} (lam = {lam_back:.6g}) and "
                                "would trace the same points again (a closed loop of the curve, or a cycle of steps "
                                "at a corner): stopped before lam_end")
                self.counters["revisits"] = self.counters.get("revisits", 0) + 1
                break
            self.fold(p, w, q)
            smooth = smooth_step(self, p, q, it, kink)
            self.clean_step = self.counters["corrector_failures"] == self.failures_at_point  # no failed step since p
            # the end of the range
            if (q.lam - lam_end) * direction >= 0 and (p.lam - lam_end) * direction < 0:
                try:
                    q = self.judged(self.finish_at_end(p, q), "end point rejected", detail=False)
                except Failed as exc:
                    # a long step past lam_end interpolates badly: step again from p, shorter (the step then lands
                    # nearer lam_end, or before it)
                    self.counters["end_retries"] = self.counters.get("end_retries", 0) + 1
                    self.ds *= 0.5
                    if self.ds < self.ds_min:
                        self.message = f"reached lam_end but the end point failed: {exc}"
                        break
                    continue
                self.add(q, self.ds)
                self.success, self.message = True, f"reached lam_end = {lam_end:.6g} in {len(points)} points"
                break
            self.add(q, self.ds)
            if self.retraced(w) or self.crawled():  # a false fold, or no progress (see Fallbacks): a gap onwards
                continue
            if not self.lo <= q.lam <= self.hi:
                self.message = f"the branch left the parameter range [{self.lo:.6g}, {self.hi:.6g}] at lam = {q.lam:.6g}"
                break
            self.ds = next_ds(self, p, q, it, kink, smooth)
        gaps = [k for k in self.kinks if k.get("gap")]
        if gaps and self.success:
            where = ", ".join(f"{k['lam']:.6g}" + " (a crawl)" * bool(k.get("crawl"))
                              + " (landed off the branch: maybe another solution)" * bool(k.get("jump")) for k in gaps)
            self.message += (f" ({len(gaps)} gap(s) bridged by a natural-parameter step where the arclength corrector "
                             f"could not pass, from lam = {where}: a fold there is not traced)")
        folds = self.folds + stall_folds(points, self.stall_fold_rtol)
        folds.sort(key=lambda f: f["index"])
        self.counters.update(residual_evaluations=self.ev.n_res, parameter_derivatives=self.ev.n_dlam,
                             wall_time=time.perf_counter() - self.t_start)
        return ContinuationResult(points, self.success, self.message, folds, self.counters, self.kinks)
