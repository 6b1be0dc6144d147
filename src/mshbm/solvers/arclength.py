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
  shrinks by ``shrink`` after one of more than ``slow_iter``; a failed (or rejected, see ``accept``)
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
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

#: a step whose tangents at its ends have ``|cos| <`` this is taken as a kink of the branch (see ``continuation``)
KINK_COS = 0.9
#: relative steps in lam tried, in this order, by a step at fixed lam across a kink (``kink_crossing``)
KINK_STEPS = (1e-3, 1e-4, 1e-5)

__all__ = ["ContinuationPoint", "ContinuationResult", "continuation", "tangent"]


@dataclass
class ContinuationPoint:
    """One converged point: unknowns ``x``, parameter ``lam``, unit tangent (physical units ``dx/ds,
    dlam/ds``), corrector iterations, the step ``ds`` that led here, scaled residual, and the payload
    returned by ``accept``."""

    x: np.ndarray
    lam: float
    dx: np.ndarray
    dlam: float
    iterations: int
    ds: float
    residual: float
    payload: object = None
    stall: object = None
    orientation: int = 0  # sign det [J_y, g; t^T] (scaled), 0 if singular or not computed
    segment: object = None  # the smooth piece of the residual (``segment``), None if unknown


@dataclass
class ContinuationResult:
    points: list
    success: bool
    message: str
    folds: list = field(default_factory=list)   # [{"lam", "x", "index"}]: between points index-1 and index
    counters: dict = field(default_factory=dict)
    #: kinks passed (``{"lam", "lam_right", "index", "cos_tangents"}``, ``"fixed_lam": True`` when crossed by a
    #: step at fixed lam): between points index-1 and index
    kinks: list = field(default_factory=list)


class _Failed(Exception):
    pass


def _solve(A, b):
    try:
        z = np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        z = np.linalg.lstsq(A, b, rcond=None)[0]
    if not np.all(np.isfinite(z)):
        raise _Failed("singular bordered system")
    return z


class _Evaluator:
    """Scaled evaluation of the callables at ``(x, lam)``, counting calls."""

    def __init__(self, residual, d_lam, residual_scale, unknown_scale, lam_scale):
        self.residual, self.d_lam = residual, d_lam
        self.residual_scale, self.unknown_scale = residual_scale, unknown_scale
        self.lam_scale = float(lam_scale)
        self.n_res = self.n_dlam = 0

    def __call__(self, x, lam, jac=True):
        R, J = self.residual(x, lam)
        self.n_res += 1
        s = np.asarray(self.residual_scale(x, lam), dtype=float)
        r = float(np.max(np.abs(R) / s)) if R.size else 0.0
        if not jac:
            return R, s, r, None, None
        g = np.asarray(self.d_lam(x, lam), dtype=float)
        self.n_dlam += 1
        # the bordered systems are dense (the harmonic methods' unknowns are few; condense=False gives
        # a sparse J of the same small size)
        J = J.toarray() if sp.issparse(J) else np.asarray(J, dtype=float)
        return R, s, r, J, g


def orientation(J, g, s, w, lam_scale, t):
    """``sign det [J_y, g; t^T]`` (scaled as in :func:`tangent`; positive scales keep the sign): the
    orientation of the tangent ``t`` of the curve ``R(x, lam) = 0``.  Along a branch of regular points
    (folds included) the tangent oriented by ``t . t_prev > 0`` keeps it; it changes sign at a simple branch
    point.  0 when the matrix is singular or not finite."""
    A = np.hstack([(J * w[None, :]) / s[:, None], (g * lam_scale / s)[:, None]])
    try:
        sign, logdet = np.linalg.slogdet(np.vstack([A, t]))
    except np.linalg.LinAlgError:
        return 0
    return int(sign) if np.isfinite(logdet) else 0


def tangent(J, g, s, w, lam_scale, previous=None):
    """Unit tangent ``(t_y, t_mu)`` in scaled variables of ``R(x, lam) = 0`` (see the module docstring),
    oriented along ``previous`` (a scaled tangent) or, without one, towards increasing ``lam``."""
    A = np.hstack([(J * w[None, :]) / s[:, None], (g * lam_scale / s)[:, None]])
    n = A.shape[1]
    if previous is None:
        # the row that fixes the gauge: the column of A least in its range (lam, unless at a fold)
        row = np.zeros(n)
        row[-1] = 1.0
        B = np.vstack([A, row])
        try:
            z = np.linalg.solve(B, np.eye(n)[-1])
            if not np.all(np.isfinite(z)):
                raise np.linalg.LinAlgError
        except np.linalg.LinAlgError:
            z = np.linalg.svd(A)[2][-1]
    else:
        B = np.vstack([A, previous])
        try:
            z = np.linalg.solve(B, np.eye(n)[-1])
            if not np.all(np.isfinite(z)):
                raise np.linalg.LinAlgError
        except np.linalg.LinAlgError:
            z = np.linalg.svd(A)[2][-1]
    z = z / np.linalg.norm(z)
    ref = previous if previous is not None else np.eye(n)[-1]
    if float(z @ ref) < 0:
        z = -z
    return z


def continuation(residual, d_lam, x0, lam0, lam_end, *, residual_scale, unknown_scale, lam_scale=None,
                 ds0=0.02, ds_min=1e-5, ds_max=0.2, max_points=200, tol=1e-10, max_corrector_iter=12,
                 fast_iter=3, slow_iter=7, grow=1.6, shrink=0.5, predictor="tangent", accept=None,
                 callback=None, fold_rtol=1e-3, max_time=None, lam_limits=None, stall_accept=None, max_jump=3.0,
                 stall_fold_rtol=5e-3, natural_fallback=True, kink_crossing=True, segment=None):
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
    kink_crossing : bool
        When the step falls below ``ds_min`` at a point solved exactly (not by ``stall_accept``), try one
        step at fixed ``lam`` across a kink (module docstring) before stopping, once per point.
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
    """
    ev = _Evaluator(residual, d_lam, residual_scale, unknown_scale,
                    lam_scale if lam_scale is not None else (abs(lam0) if lam0 != 0 else 1.0))
    lsc = ev.lam_scale
    direction = 1.0 if lam_end >= lam0 else -1.0
    span = abs(lam_end - lam0)
    lo, hi = lam_limits if lam_limits is not None else (min(lam0, lam_end) - 0.5 * span,
                                                         max(lam0, lam_end) + 0.5 * span)
    if lam_limits is None and min(lam0, lam_end) > 0:  # a positive parameter: at most down to half the range's start
        lo = max(lo, 0.5 * min(lam0, lam_end))
    t_start = time.perf_counter()
    counters = {"corrector_failures": 0, "rejected": 0, "corrector_iterations": 0}

    def stalled(x, lam):
        return stall_accept(x, lam) if stall_accept is not None else None

    def newton_fixed(x, lam, allow_stall=True, max_iter=None):
        """Newton at fixed ``lam`` (the start and the end point); returns (x, it, r, data, stall)."""
        best = None
        max_iter = max_corrector_iter if max_iter is None else max_iter
        for it in range(max_iter + 1):
            R, s, r, J, g = ev(x, lam)
            if best is None or r < best[2]:
                best = (x, it, r, (R, s, J, g))
            if r <= tol:
                return x, it, r, (R, s, J, g), None
            if it == max_iter:
                break
            dx = _solve(J / s[:, None], -R / s)
            xn, ok = _backtrack(lambda xx: ev(xx, lam, jac=False)[2], x, dx, r)
            if not ok:
                break
            x = xn
        info = stalled(best[0], lam) if allow_stall else None
        if info:
            return best + (info,)
        raise _Failed(f"Newton at fixed parameter {lam:.6g} did not converge (||R/s|| = {r:.2e})")

    def _backtrack(norm, x, dx, r):
        a = 1.0
        for _ in range(8):
            xt = x + a * dx
            rt = norm(xt)
            if np.isfinite(rt) and rt < r:
                return xt, True
            a *= 0.5
        return x + dx, False

    def corrector(xp, lp, t, w, ds):
        """Bordered Newton from the predictor ``(xp, lp)`` on the hyperplane orthogonal to ``t``."""
        x, lam = xp.copy(), lp
        ty, tm = t[:-1], t[-1]
        best = None
        for it in range(max_corrector_iter + 1):
            if lam0 > 0 >= lam:  # a positive parameter (frequency, load factor) stays positive
                raise _Failed("the corrector left the positive parameter range")
            if abs(lam - lp) > max_jump * max(ds, ds0) * lsc:
                raise _Failed(f"the corrector moved the parameter to {lam:.6g}, more than {max_jump:g} x max(ds, ds0) "
                              "from the predictor (a jump, or a useless dR/dlam)")
            R, s, r, J, g = ev(x, lam)
            c = float(ty @ ((x - xp) / w) + tm * (lam - lp) / lsc)
            if np.isfinite(r) and abs(c) <= 1e-8 and (best is None or r < best[3]):
                best = (x, lam, it, r, (R, s, J, g))
            if r <= tol and abs(c) <= 1e-8:
                return x, lam, it, r, (R, s, J, g), None
            if it == max_corrector_iter or not np.isfinite(r):
                break
            A = np.zeros((x.size + 1, x.size + 1))
            A[:-1, :-1] = (J * w[None, :]) / s[:, None]
            A[:-1, -1] = g * lsc / s
            A[-1, :-1], A[-1, -1] = ty, tm
            z = _solve(A, -np.concatenate([R / s, [c]]))
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
                xf, itf, rf, dataf, _ = newton_fixed(best[0], best[1], allow_stall=False)
                if float(np.linalg.norm((xf - best[0]) / w)) <= 0.5 * max(ds, ds0):  # the same root, not another
                    return xf, best[1], best[2] + itf, rf, dataf, None
            except _Failed:
                pass
            info = stalled(best[0], best[1])
            if info:
                return best + (info,)
        raise _Failed(f"corrector did not converge in {max_corrector_iter} iterations (||R/s|| = {r:.2e})")

    def make_point(x, lam, it, r, data, ds, prev_t, stall=None):
        R, s, J, g = data
        w = np.asarray(unknown_scale(x, lam), dtype=float)
        t = tangent(J, g, s, w, lsc, previous=prev_t)
        seg = segment(x, lam) if segment is not None and stall is None else None
        return ContinuationPoint(x=x, lam=float(lam), dx=t[:-1] * w, dlam=float(t[-1] * lsc), iterations=it,
                                 ds=ds, residual=r, stall=stall, segment=seg,
                                 orientation=orientation(J, g, s, w, lsc, t) if seg is not None else 0), t, w

    def scaled_t(p, w):
        t = np.concatenate([p.dx / w, [p.dlam / lsc]])
        return t / np.linalg.norm(t)

    def step(p, w, ds, prev=None):
        """Predict from point ``p`` by ``ds`` and correct; returns (x, lam, it, r, data, stall)."""
        t = scaled_t(p, w)
        if predictor == "secant" and prev is not None:
            d = np.concatenate([(p.x - prev.x) / w, [(p.lam - prev.lam) / lsc]])
            nd = np.linalg.norm(d)
            if nd > 0 and float(d @ t) > 0:
                t = d / nd
        xp, lp = p.x + ds * t[:-1] * w, p.lam + ds * t[-1] * lsc
        return corrector(xp, lp, t, w, ds), t

    # ---- the start point
    try:
        x, it, r, data, st = newton_fixed(np.asarray(x0, dtype=float), float(lam0))
    except _Failed as exc:
        return ContinuationResult([], False, f"start point: {exc}", [], counters)
    p0, t0, _ = make_point(x, lam0, it, r, data, 0.0, None, st)
    if t0[-1] * direction < 0:  # orient towards lam_end
        p0.dx, p0.dlam, p0.orientation = -p0.dx, -p0.dlam, -p0.orientation
    if accept is not None:
        ok, p0.payload = accept(p0.x, p0.lam, p0.stall)
        if not ok:
            return ContinuationResult([p0], False, "the start point was rejected", [], counters)
    points, folds, kinks = [p0], [], []
    if callback is not None:
        callback(p0, 1, ds0)
    ds, message, success = ds0, "", False
    natural, natural_reason = None, ""
    crossed_from = -1  # the point from which a step at fixed lam across a kink was last tried

    def cross_kink(p, w):
        """A step at fixed ``lam`` from ``p`` in its direction of travel, across a kink of the branch that the
        arclength corrector cannot turn: past a kink whose two pieces meet at more than 90 degrees the
        hyperplane orthogonal to the incoming tangent misses the outgoing piece, and Newton on the
        bordered system cycles between the two pieces.  Where the branch passes the kink monotonically in
        ``lam`` a hyperplane ``lam = const`` meets it: Newton at fixed ``lam`` from ``p.x`` (relative
        steps ``KINK_STEPS``, at most ``2 max_corrector_iter`` iterations, a jump guard of ``max_jump ds0``).
        The new point keeps the orientation of the curve (sign det [A; t])."""
        if p.dlam == 0.0:
            raise _Failed("no direction of travel in lam")
        sgn = 1.0 if p.dlam > 0 else -1.0
        last = "no step tried"
        for rel in KINK_STEPS:
            lam_n = p.lam + sgn * rel * lsc
            if (lam_n - lam_end) * direction > 0 and (p.lam - lam_end) * direction < 0:
                lam_n = lam_end
            try:
                x, it, r, data, _ = newton_fixed(p.x, lam_n, allow_stall=False, max_iter=2 * max_corrector_iter)
            except _Failed as exc:
                last = str(exc)
                continue
            dist = float(np.linalg.norm(np.concatenate([(x - p.x) / w, [(lam_n - p.lam) / lsc]])))
            if dist > max_jump * ds0:
                last = f"the solution at lam = {lam_n:.6g} is {dist:.3g} away (another branch?)"
                continue
            q, tq, wq = make_point(x, lam_n, it, r, data, rel, scaled_t(p, w), None)
            if p.orientation and q.orientation:
                flip = q.orientation != p.orientation
            else:
                flip = q.dlam * sgn < 0
            if flip:
                q.dx, q.dlam, q.orientation = -q.dx, -q.dlam, -q.orientation
            if accept is not None:
                ok, q.payload = accept(q.x, q.lam, q.stall)
                if not ok:
                    last = "point rejected" + (f": {q.payload}" if isinstance(q.payload, str) else "")
                    continue
            kinks.append({"lam": float(p.lam), "lam_right": float(lam_n), "index": len(points),
                          "cos_tangents": float(scaled_t(q, wq) @ scaled_t(p, wq)), "fixed_lam": True})
            return q
        raise _Failed(last)

    def finish_at_end(p, q):
        """Solve at ``lam_end`` from the interpolation between points ``p`` and ``q`` that bracket it."""
        a = (lam_end - p.lam) / (q.lam - p.lam)
        xg = p.x + a * (q.x - p.x)
        x, it, r, data, st = newton_fixed(xg, lam_end)
        w = np.asarray(unknown_scale(x, lam_end), dtype=float)
        pt, _, _ = make_point(x, lam_end, it, r, data, q.ds, scaled_t(q, w), st)
        return pt

    while True:
        if len(points) >= max_points:
            message = f"stopped after {max_points} points (max_points) at lam = {points[-1].lam:.6g}"
            break
        if max_time is not None and time.perf_counter() - t_start > max_time:
            message = f"stopped by the time limit ({max_time:g} s) at lam = {points[-1].lam:.6g}"
            break
        p = points[-1]
        w = np.asarray(unknown_scale(p.x, p.lam), dtype=float)
        if natural is not None:  # natural-parameter steps (see the fallback below)
            try:
                lam_n = p.lam + direction * natural
                if (lam_n - lam_end) * direction > 0:
                    lam_n = lam_end
                x, it, r, data, st = newton_fixed(p.x, lam_n)
                q, _, _ = make_point(x, lam_n, it, r, data, natural / lsc, scaled_t(p, w), st)
                q.dx, q.dlam = (x - p.x) / (natural / lsc), direction * lsc  # secant, not the (useless) tangent
                if accept is not None:
                    ok, q.payload = accept(q.x, q.lam, q.stall)
                    if not ok:
                        raise _Failed("point rejected" + (f": {q.payload}" if isinstance(q.payload, str) else ""))
            except _Failed as exc:
                counters["natural_failures"] = counters.get("natural_failures", 0) + 1
                natural *= 0.5
                if natural < ds_min * lsc:
                    message = (f"natural-parameter steps below ds_min at lam = {p.lam:.6g} ({exc}) after the "
                               f"arclength corrector failed ({natural_reason})")
                    break
                continue
            points.append(q)
            counters["natural_points"] = counters.get("natural_points", 0) + 1
            if callback is not None:
                callback(q, len(points), natural / lsc)
            if q.lam == lam_end:
                success, message = True, (f"reached lam_end = {lam_end:.6g} in {len(points)} points (the last "
                                          f"{counters['natural_points']} by natural-parameter steps after the "
                                          f"arclength corrector failed: {natural_reason})")
                break
            natural = min(natural * 1.5, ds_max * lsc)
            continue
        try:
            (x, lam, it, r, data, st), t_used = step(p, w, ds, points[-2] if len(points) > 1 else None)
            counters["corrector_iterations"] += it
            q, tq, wq = make_point(x, lam, it, r, data, ds, scaled_t(p, np.asarray(unknown_scale(x, lam), float)), st)
            tp = scaled_t(p, wq)
            c_t = float(tq @ tp)
            if p.segment is not None and q.segment is not None and p.segment != q.segment and c_t < KINK_COS \
                    and p.orientation and q.orientation and q.orientation != p.orientation:
                # the step passed a change of the residual's smooth piece and the tangent turned by more than
                # acos(KINK_COS): a kink of the branch (a nonsmooth point, e.g. a grazing impact, whose saltation
                # makes dR/dx jump), where the sign of t_p says nothing about the way on.  The orientation of the curve, sign det [A; t], is
                # kept instead (constant along a branch of regular points, folds included)
                q.dx, q.dlam, q.orientation = -q.dx, -q.dlam, -q.orientation
                kink = {"lam": float(p.lam), "lam_right": float(lam), "index": len(points), "cos_tangents": -c_t}
            else:
                kink = None
            moved = np.concatenate([(x - p.x) / w, [(lam - p.lam) / lsc]])  # the step in scaled units
            dist = float(np.linalg.norm(moved))
            if p.segment is not None and st is None and float(scaled_t(p, w) @ moved) < 0.1 * ds:
                # a corrector polished at fixed lam (see ``corrector``) can return to p itself (at a corner
                # the hyperplane misses the outgoing piece): no progress along the branch (checked on
                # piecewise-smooth residuals, ``segment``)
                raise _Failed("the corrected point did not advance along the branch")
            if dist > max_jump * max(ds, ds0):
                raise _Failed(f"the corrector moved {dist:.3g} away, more than {max_jump:g} x max(ds, ds0) "
                              "(a jump to another branch?)")
            if len(points) == 1 and (lam - p.lam) * direction < 0:
                # the start tangent points towards lam_end: a first step away from it means the tangent
                # was useless (e.g. dR/dlam of an orbit accepted at step accuracy), never a fold
                raise _Failed("the first step moved away from lam_end")
            if accept is not None:
                ok, q.payload = accept(q.x, q.lam, q.stall)
                if not ok:
                    counters["rejected"] += 1
                    raise _Failed("point rejected" + (f": {q.payload}" if isinstance(q.payload, str) else ""))
        except _Failed as exc:
            counters["corrector_failures"] += 1
            fails = counters.setdefault("failures", [])
            if len(fails) < 50:  # the first reasons, for diagnosis
                fails.append({"lam": float(p.lam), "ds": float(ds), "reason": str(exc)})
            ds *= 0.5
            if ds < ds_min:
                if natural_fallback and p.stall is not None:
                    # at an orbit accepted at step accuracy the residual is a staircase in (x, lam): its
                    # Jacobian and dR/dlam do not predict; step in lam at fixed lam instead (no folds)
                    natural, natural_reason = ds0 * lsc * 0.5, str(exc)
                    continue
                if kink_crossing and p.stall is None and crossed_from != len(points):
                    crossed_from = len(points)
                    try:
                        q = cross_kink(p, w)
                    except _Failed as exc2:
                        message = (f"step size below ds_min = {ds_min:g} at lam = {p.lam:.6g} ({exc}; a step at "
                                   f"fixed lam across a kink failed too: {exc2})")
                        break
                    counters["kink_crossings"] = counters.get("kink_crossings", 0) + 1
                    points.append(q)
                    if callback is not None:
                        callback(q, len(points), ds0)
                    if q.lam == lam_end:
                        success, message = True, f"reached lam_end = {lam_end:.6g} in {len(points)} points"
                        break
                    ds = ds0
                    continue
                message = f"step size below ds_min = {ds_min:g} at lam = {p.lam:.6g} ({exc})"
                break
            continue
        if kink is not None:
            kinks.append(kink)
            counters["kinks"] = counters.get("kinks", 0) + 1
        # fold: the lam component of the tangent changed sign between p and q
        if p.dlam * q.dlam < 0 and p.stall is None and q.stall is None:
            try:
                folds.append(_locate_fold(step, p, w, ds, q, len(points), fold_rtol, lsc))
            except _Failed as exc:
                folds.append({"lam": float(0.5 * (p.lam + q.lam)) if abs(q.lam - p.lam) <= fold_rtol * abs(q.lam)
                              else max(p.lam, q.lam) if p.dlam > 0 else min(p.lam, q.lam),
                              "x": q.x, "index": len(points), "located": False, "note": str(exc)})
        # the end of the range
        if (q.lam - lam_end) * direction >= 0 and (p.lam - lam_end) * direction < 0:
            try:
                q = finish_at_end(p, q)
                if accept is not None:
                    ok, q.payload = accept(q.x, q.lam, q.stall)
                    if not ok:
                        raise _Failed("end point rejected")
            except _Failed as exc:
                message = f"reached lam_end but the end point failed: {exc}"
                break
            points.append(q)
            if callback is not None:
                callback(q, len(points), ds)
            success, message = True, f"reached lam_end = {lam_end:.6g} in {len(points)} points"
            break
        points.append(q)
        if callback is not None:
            callback(q, len(points), ds)
        if not lo <= q.lam <= hi:
            message = f"the branch left the parameter range [{lo:.6g}, {hi:.6g}] at lam = {q.lam:.6g}"
            break
        ds = min(ds * grow, ds_max) if it <= fast_iter else (max(ds * shrink, ds_min) if it > slow_iter else ds)
    folds += _stall_folds(points, stall_fold_rtol)
    folds.sort(key=lambda f: f["index"])
    counters.update(residual_evaluations=ev.n_res, parameter_derivatives=ev.n_dlam,
                    wall_time=time.perf_counter() - t_start)
    return ContinuationResult(points, success, message, folds, counters, kinks)


def _stall_folds(points, rtol):
    """Turning points of ``lam`` along the branch with a reversal of more than ``rtol`` (relative), kept
    where the extreme point or a neighbour was accepted at step accuracy (tangent folds cover the rest)."""
    lam = np.array([p.lam for p in points])
    out, ext, trend = [], 0, 0
    for i in range(1, lam.size):
        thr = rtol * max(abs(lam[ext]), 1e-300)
        if trend == 0:
            if abs(lam[i] - lam[0]) > thr:
                trend, ext = (1 if lam[i] > lam[0] else -1), i
        elif trend * (lam[i] - lam[ext]) >= 0:
            ext = i
        elif trend * (lam[ext] - lam[i]) > thr:
            out.append(ext)
            trend, ext = -trend, i
    folds = []
    for i in out:
        near = points[max(i - 1, 0):i + 2]
        if any(p.stall is not None for p in near):
            folds.append({"lam": float(lam[i]), "x": points[i].x, "index": int(i), "located": "extreme point"})
    return folds


def _locate_fold(step, p, w, ds, q, index, rtol, lsc):
    """Arclength ``sigma`` in ``(0, ds)`` from ``p`` where the ``lam`` component of the tangent vanishes:
    secant steps safeguarded by bisection on ``f(sigma) = dlam/ds``."""
    a, fa, la = 0.0, p.dlam, p.lam
    b, fb, lb = ds, q.dlam, q.lam
    best = q
    for _ in range(40):
        if abs(lb - la) <= rtol * max(abs(la), abs(lb), 1e-300) and abs(b - a) < 1e-3 * ds or abs(b - a) < 1e-9:
            break
        sig = b - fb * (b - a) / (fb - fa) if fb != fa else 0.5 * (a + b)
        if not (a + 0.05 * (b - a) < sig < b - 0.05 * (b - a)):
            sig = 0.5 * (a + b)
        (x, lam, it, r, data, _), _ = step(p, w, sig)
        from_p = _point_tangent_lam(data, x, lam, p, w, lsc)
        if from_p * fa > 0:
            a, fa, la = sig, from_p, lam
        else:
            b, fb, lb = sig, from_p, lam
        best = (x, lam)
        if abs(from_p) < 1e-12:
            break
    x, lam = best if isinstance(best, tuple) else (best.x, best.lam)
    # the fold lies between la and lb; report the extreme (the turning point) of the bracket
    lam_f = max(la, lb) if p.dlam > 0 else min(la, lb)
    return {"lam": float(lam_f), "x": x, "index": index, "located": True,
            "bracket": [float(min(la, lb)), float(max(la, lb))]}


def _point_tangent_lam(data, x, lam, p, w, lsc):
    R, s, J, g = data
    t_prev = np.concatenate([p.dx / w, [p.dlam / lsc]])
    t_prev /= np.linalg.norm(t_prev)
    t = tangent(J, g, s, w, lsc, previous=t_prev)
    return float(t[-1] * lsc)
