"""Damped Newton iteration shared by all methods, and exact piecewise-linear path following.

The residual function returns ``(R, J)``: the residual (shape ``(n_x,)``) and its
Jacobian (dense ``(n_x, n_x)`` or sparse).  Globalisation is an Armijo
backtracking line search on ``||R||_2``; a non-finite residual or Jacobian ends
the iteration with a diagnosis instead of a number.

Convergence is measured in the problem's physical units: ``||R / s(x)||_inf <= tol``
with a per-row scale ``s(x)`` (forces against the problem's force scale, displacements
against the size of the current iterate; see :mod:`mshbm.scaling`).  When ``fun`` is a
bound method of a problem object with ``residual_scale(x)``, that scale is used; the
starting guess never enters it.  The line search uses the same row scaling (at the
current iterate), so the iteration is independent of the units.

When the line search fails and ``fun`` is a bound method of an object that
provides ``newton_fallback`` (e.g. :class:`mshbm.methods.hbm.HBMProblem` with penalty
contacts, whose residual is piecewise linear in ``q_hat``), that method is
called as a second globalisation stage; see :func:`newton`.

:func:`follow_pl_path` traces the solution curve of a piecewise-linear
homotopy ``H(x, lambda) = 0`` exactly, region by region (Eaves' piecewise-linear
continuation): inside a region ``H`` is affine, the curve is a straight segment,
and the curve is followed through turning points (folds) by keeping its
orientation, ``d lambda ~ sign det(dH/dx)``.  A line search on ``||R||`` cannot
pass such folds, which is why Newton stalls on stiff penalty contact.
"""
from __future__ import annotations

import contextlib
import contextvars
import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._lapack import scaled_lu_solve
_dgetrf, _dgecon, _dgetrs = sla.lapack.dgetrf, sla.lapack.dgecon, sla.lapack.dgetrs


def _norm2(v):
    """``||v||_2`` of a 1-D float array (the same sum as ``np.linalg.norm``, without its dispatch)."""
    return math.sqrt(float(v.dot(v)))


__all__ = ["solve_problem", "newton", "NewtonResult", "follow_pl_path", "PathResult", "scaled_norm", "Meter",
           "work_box", "work_spent", "work_left", "charge"]


@dataclass
class NewtonResult:
    """Outcome of :func:`newton`.

    ``nit`` counts Newton iterations plus, when a fallback was used, its
    linear solves (path segments); ``info`` holds the fallback's statistics.
    """

    x: np.ndarray
    success: bool
    message: str
    nit: int
    nfev: int
    residual_norm: float
    history: list = field(default_factory=list)
    info: dict = field(default_factory=dict)


def _solve(J, R, s=None):
    """Newton step ``J^-1 R`` on the row-scaled system ``(J / s) dx = R / s``.

    A (numerically) singular ``J`` -- e.g. friction that sticks all period, whose position
    is then undetermined -- gets the least-squares step of minimal norm; "numerically
    singular" is decided by LAPACK's estimate of the reciprocal condition number of the
    row-scaled matrix (< 1e-15), so the choice does not depend on the units of the rows.
    """
    if s is not None:
        s = np.asarray(s, dtype=float)
        if s.shape != np.shape(R):
            s = np.broadcast_to(s, np.shape(R))
        if type(J) is np.ndarray and J.dtype == np.float64 and J.ndim == 2 and R.dtype == np.float64:
            # the steps below in one compiled call (the same LAPACK routines and numbers)
            dx = np.empty(R.shape[0])
            if scaled_lu_solve(J, R, np.ascontiguousarray(s), 1e-15, dx):
                return dx
        J = (sp.diags(1.0 / s) @ J) if sp.issparse(J) else J / s[:, None]
        R = R / s
    if sp.issparse(J):
        return spla.spsolve(sp.csc_matrix(J), R)
    J = np.asarray(J, dtype=float)
    if np.isfinite(J).all():
        lu, piv, info = _dgetrf(J)
        if info == 0:
            anorm = float(np.abs(J).sum(axis=0).max(initial=0.0))
            rcond, _ = _dgecon(lu, anorm, norm="1")
            if rcond > 1e-15:
                dx, _ = _dgetrs(lu, piv, R)
                return dx
    return np.linalg.lstsq(J, R, rcond=None)[0]


def newton(fun, x0, tol=1e-10, max_iter=50, line_search=True, callback=None, scale=None, fallback=None,
           reuse_jacobian=False):
    """Solve ``R(x) = 0``.

    Parameters
    ----------
    fun : callable
        ``fun(x, jac=True) -> (R, J)``; with ``jac=False`` it may return ``(R, None)``.
    x0 : ndarray, shape (n_x,)
    tol : float
        Converged when ``||R / s||_inf <= tol`` (``s`` from ``scale``).
    max_iter : int
    line_search : bool
        Armijo backtracking (halving, down to 1/1024).
    callback : callable, optional
        ``callback(it, x, residual_norm)`` after each iteration (progress display).
    scale : float, ndarray (n_x,) or callable, optional
        Residual scale ``s``: a number, per-row scales, or ``scale(x) -> (n_x,)``
        evaluated at every iterate.  Default 1 (absolute test); :func:`solve_problem` passes the
        problem's ``residual_scale``.
    fallback : callable, optional
        ``fallback(x0, failed, tol=, scale=, max_iter=, callback=) -> NewtonResult or None``, called
        when Newton fails (e.g. a problem's :meth:`path_fallback`).  Its result is returned if it
        succeeds, with the same convergence test ``||R / s||_inf <= tol`` on the real problem.
    reuse_jacobian : bool
        Evaluate the full Newton step with its Jacobian and keep it if the step is accepted (one
        evaluation per iteration fewer; for problems whose Jacobian costs little more than ``R``).
        The iterates are the same either way.

    Returns
    -------
    NewtonResult
        ``residual_norm`` and ``history`` hold the scaled ``||R / s||_inf`` (dimensionless).
    """
    x0 = np.array(x0, dtype=float)
    scale = _scale_function(fun, scale)
    res = _newton(fun, x0, tol, max_iter, line_search, callback, scale, reuse_jacobian=reuse_jacobian)
    hook = fallback
    if res.success or not hook:
        return res
    alt = hook(x0, res, tol=tol, scale=scale, max_iter=max_iter, callback=callback)
    if alt is None:
        return res
    alt.nit += res.nit
    alt.nfev += res.nfev
    alt.history = res.history + alt.history
    if alt.success:
        alt.message = f"{alt.message} (Newton alone failed: {res.message})"
        return alt
    res.message = f"{res.message}; {alt.message}"
    res.nit, res.nfev, res.info = alt.nit, alt.nfev, alt.info
    return res


def solve_problem(problem, x0, *, fallback=True, **newton_options):
    """Newton on a :class:`mshbm.methods.base.PeriodicProblem`: its residual, its physical-unit
    scale ``residual_scale`` and, if ``fallback``, its exact path follower (``path_fallback()``).
    ``newton_options``: ``tol``, ``max_iter``, ``line_search``, ``callback`` of :func:`newton`."""
    hook = problem.path_fallback() if fallback else None
    newton_options.setdefault("reuse_jacobian", bool(problem.cheap_jacobian))
    return newton(problem.residual, x0, scale=problem.residual_scale, fallback=hook, **newton_options)


def _scale_function(fun, scale):
    """``scale`` normalised to a callable ``x -> per-row scales`` (see :func:`newton`)."""
    if scale is None:
        return lambda x: 1.0
    if callable(scale):
        return scale
    fixed = np.asarray(scale, dtype=float)
    return lambda x: fixed


def scaled_norm(R, s):
    """``||R / s||_inf`` (``inf`` if ``R`` is not finite)."""
    R = np.asarray(R, dtype=float)
    if not np.isfinite(R).all():
        return np.inf
    return float(np.abs(R / s).max(initial=0.0))


def _watchdog_step(fun, xt, r2, s):
    """Newton step from the provisional point ``xt``; ``(x, R, J)`` if it ends below ``r2``."""
    Rt, Jt = fun(xt)
    if not np.isfinite(Rt).all():
        return None
    dx = -_solve(Jt, Rt, s)
    if not np.isfinite(dx).all():
        return None
    x2 = xt + dx
    R2, J2 = fun(x2)
    if np.isfinite(R2).all() and _norm2(R2 / s) <= (1.0 - 1e-4) * r2:
        return x2, R2, J2
    return None


#: wall-clock deadline (``time.perf_counter()`` value) of every Newton solve in the current context: an iteration
#: that starts after it ends the solve with a failure that says so (:func:`time_box`)
_DEADLINE = contextvars.ContextVar("mshbm_newton_deadline", default=None)


@contextlib.contextmanager
def time_box(deadline):
    """Within the block, every Newton solve stops at ``deadline`` (a ``time.perf_counter()`` value; ``None``:
    no new limit), failing with the message "time budget spent"; an enclosing earlier deadline stays.

    The deadline is carried by the context (not an argument) because Newton solves run deep inside the
    problems (homotopy stages, path followers, exact orbits); the solve route sets it
    (:class:`mshbm.route.driver.Route`, :class:`mshbm.route.ladder.Ladder`)."""
    outer = _DEADLINE.get()
    new = outer if deadline is None else (float(deadline) if outer is None else min(outer, float(deadline)))
    token = _DEADLINE.set(new)
    try:
        yield
    finally:
        _DEADLINE.reset(token)


def deadline():
    """The Newton deadline of the current context (``None``: none)."""
    return _DEADLINE.get()


class Meter:
    """A deterministic work meter of the Newton solves in a context (:func:`work_box`): ``used`` counts the
    residual evaluations of every Newton solve in the block, nested ones included (continuation stages, anchor
    solves, branch correctors); with a ``limit``, an iteration that starts once ``used >= limit`` (or an enclosing
    meter's) ends its solve with the failure "work budget spent".  The count is the same on every machine, whatever
    its load: the solve route's internal budgets are meters, only the caller's ``max_time`` is wall time."""

    __slots__ = ("limit", "used", "outer", "label", "evaluations")

    def __init__(self, limit=None, outer=None, label="work budget", evaluations=None):
        self.limit = None if limit is None else float(limit)
        self.used = 0
        self.outer = outer
        self.label = label
        #: with a limit: at least this many Newton evaluations of the block's first Newton solve, whatever one costs
        #: (the event-driven flow charges its work per evaluation: :meth:`first_evaluation`)
        self.evaluations = evaluations

    def first_evaluation(self, cost):
        """The first Newton evaluation in the block (or a nested one) cost ``cost`` evaluations of this meter: the
        limit becomes at least :attr:`evaluations` times that, once."""
        m = self
        while m is not None:
            if m.evaluations is not None and m.limit is not None:
                m.limit, m.evaluations = max(m.limit, m.evaluations * float(cost)), None
            m = m.outer

    def spent(self):
        """The label of the innermost meter of this chain whose limit is reached (``None``: none)."""
        m = self
        while m is not None:
            if m.limit is not None and m.used >= m.limit:
                return m.label
            m = m.outer
        return None

    def charge(self, evaluations):
        m = self
        while m is not None:
            m.used += evaluations
            m = m.outer


_METER = contextvars.ContextVar("mshbm_newton_meter", default=None)


@contextlib.contextmanager
def work_box(limit=None, label="work budget", evaluations=None):
    """Within the block, a :class:`Meter` counts the Newton residual evaluations (yielded); with ``limit``, every
    Newton solve stops once the block has used ``limit`` evaluations (enclosing limits stay); with ``evaluations``
    too, the limit is at least that many times the cost of the block's first Newton evaluation."""
    meter = Meter(limit, _METER.get(), label, evaluations)
    token = _METER.set(meter)
    try:
        yield meter
    finally:
        _METER.reset(token)


def charge(evaluations=1):
    """Charge ``evaluations`` residual evaluations to the meters of the current context (path followers'
    correctors, which are not :func:`newton` solves; other work converted to evaluations, e.g. the event-driven
    flow's, :data:`mshbm.integrators.event.flow.WORK_PER_EVALUATION`)."""
    m = _METER.get()
    if m is not None:
        m.charge(evaluations)


def work_left():
    """The evaluations left before the first limit of the current context's meters is reached (``None``: no
    limit)."""
    m, left = _METER.get(), None
    while m is not None:
        if m.limit is not None:
            left = m.limit - m.used if left is None else min(left, m.limit - m.used)
        m = m.outer
    return left


def work_spent():
    """The label of a spent work budget of the current context (``None``: none spent, or no budget)."""
    m = _METER.get()
    return None if m is None else m.spent()


def _newton(fun, x, tol, max_iter, line_search, callback, scale, watchdog=None, reuse_jacobian=False):
    meter = _METER.get()
    charged = [0]  # the evaluations charged to the meter so far (at the iterations' budget checks)
    res = _iterate(fun, x, tol, max_iter, line_search, callback, scale, watchdog, reuse_jacobian, meter, charged)
    if meter is not None:
        meter.charge(res.nfev - charged[0])
    return res


def _iterate(fun, x, tol, max_iter, line_search, callback, scale, watchdog, reuse_jacobian, meter, charged):
    x = np.array(x, dtype=float)
    if watchdog is None:
        watchdog = max_iter
    nfev = 0
    used = None if meter is None else meter.used
    R, J = fun(x)
    nfev += 1
    if meter is not None:
        meter.first_evaluation(meter.used - used + 1)
    hist = []
    for it in range(max_iter + 1):
        if not np.isfinite(R).all():
            return NewtonResult(x, False, f"residual is not finite at iteration {it}", it, nfev, np.inf, hist)
        s = scale(x)
        Rs = R / s
        r = float(np.abs(Rs).max(initial=0.0))  # scaled_norm(R, s): R is finite here
        hist.append(r)
        if callback is not None:
            callback(it, x, r)
        if r <= tol:
            return NewtonResult(x, True, f"converged: scaled ||R||_inf = {r:.2e} after {it} iterations", it, nfev,
                                r, hist)
        if it == max_iter:
            break
        stop = _DEADLINE.get()
        if stop is not None and time.perf_counter() > stop:
            return NewtonResult(x, False, f"time budget spent at iteration {it}: scaled ||R||_inf = {r:.2e}",
                                it, nfev, r, hist)
        if meter is not None:
            meter.charge(nfev - charged[0])
            charged[0] = nfev
            spent = meter.spent()
            if spent is not None:
                return NewtonResult(x, False, f"{spent} spent at iteration {it}: scaled ||R||_inf = {r:.2e}",
                                    it, nfev, r, hist)
        Jd = J.data if sp.issparse(J) else J
        if not np.isfinite(Jd).all():
            return NewtonResult(x, False, f"Jacobian is not finite at iteration {it}", it, nfev, r, hist)
        dx = -_solve(J, R, s)
        if not np.isfinite(dx).all():
            return NewtonResult(x, False, f"Jacobian is singular at iteration {it} (||R||_inf = {r:.2e})",
                                it, nfev, r, hist)
        lam = 1.0
        r2 = _norm2(Rs)
        best = None
        watched = None
        full = None
        while True:
            xt = x + lam * dx
            if lam == 1.0 and reuse_jacobian:  # the full step is usually taken: keep its Jacobian
                Rt, Jt = fun(xt)
                full = (xt, Rt, Jt)
            else:
                Rt, _ = fun(xt, jac=False)
            nfev += 1
            rt2 = _norm2(Rt / s) if np.isfinite(Rt).all() else np.inf
            if best is None or rt2 < best[0]:
                best = (rt2, lam, xt)
            if not line_search or rt2 <= (1.0 - 1e-4 * lam) * r2 or lam < 1.0 / 1024:
                break
            if lam == 1.0 and watchdog > 0 and np.isfinite(rt2):
                # watchdog: a full step that crosses a switch of the active set (an impact moving
                # by one time step) may raise ||R|| although the next Newton step converges.
                # Take it provisionally with one more Newton step; keep both if that ends lower.
                watchdog -= 1
                watched = _watchdog_step(fun, xt, r2, s)
                nfev += 2
                if watched is not None:
                    break
            lam *= 0.5
        if watched is not None:
            x, R, J = watched
            continue
        rt2, lam, xt = best
        if not np.isfinite(rt2):
            return NewtonResult(x, False, f"residual became NaN/inf along the Newton step at iteration {it}",
                                it, nfev, r, hist)
        if line_search and rt2 >= r2 and lam < 1.0 / 512:
            return NewtonResult(x, False, f"line search failed at iteration {it}: scaled ||R||_inf stalls at {r:.2e} "
                                "(no descent; residual may be nonsmooth here or the start is too far)",
                                it, nfev, r, hist)
        if full is not None and full[0] is xt:
            x, R, J = full
            continue
        x = xt
        R, J = fun(x)
        nfev += 1
    r = scaled_norm(R, scale(x))
    return NewtonResult(x, False, f"no convergence in {max_iter} iterations: scaled ||R||_inf = {r:.2e}",
                        max_iter, nfev, r, hist)


# ----------------------------------------------------------------------------------------------
# exact piecewise-linear path following


@dataclass
class PathResult:
    """Outcome of :func:`follow_pl_path`.

    Attributes
    ----------
    x : ndarray
        Point reached (on the curve at ``lam_end`` if ``success``).
    lam : float
        Homotopy parameter reached.
    state : object
        Region (as defined by the caller) of the last segment.
    success : bool
        ``lam_end`` was reached.
    message : str
    segments : int
        Straight segments traversed (one factorisation each).
    folds : int
        Turning points passed (sign changes of ``det dH/dx``, i.e. of ``d lambda``).
    """

    x: np.ndarray
    lam: float
    state: object
    success: bool
    message: str
    segments: int
    folds: int


def _perm_parity(p):
    """Sign of the permutation ``i -> p[i]``."""
    p = np.asarray(p)
    seen = np.zeros(p.size, dtype=bool)
    sign = 1.0
    for i in range(p.size):
        if seen[i]:
            continue
        j, length = i, 0
        while not seen[j]:
            seen[j] = True
            j = p[j]
            length += 1
        if length % 2 == 0:
            sign = -sign
    return sign


def _factor(J):
    """``(solve, sign det J)`` of a dense or sparse square matrix; ``(None, 0)`` if singular."""
    if sp.issparse(J):
        try:
            lu = spla.splu(sp.csc_matrix(J))
        except RuntimeError:
            return None, 0.0
        d = lu.U.diagonal()
        if not np.all(np.isfinite(d)) or np.any(d == 0):
            return None, 0.0
        sign = float(np.prod(np.sign(d))) * _perm_parity(lu.perm_r) * _perm_parity(lu.perm_c)
        return lu.solve, sign
    J = np.asarray(J)
    if not np.all(np.isfinite(J)):
        return None, 0.0
    lu, piv = sla.lu_factor(J, check_finite=False)
    d = np.diag(lu)
    if np.any(d == 0) or np.min(np.abs(d)) <= 1e-14 * np.max(np.abs(d)):
        return None, 0.0
    sign = float(np.prod(np.sign(d))) * (-1.0) ** int(np.count_nonzero(piv != np.arange(piv.size)))
    return (lambda b: sla.lu_solve((lu, piv), b, check_finite=False)), sign


def follow_pl_path(linearise, crossing, x0, lam0, lam_end, state0, direction=None,
                   max_segments=100000, max_norm=1e12):
    """Follow the solution curve of a piecewise-linear homotopy ``H(x, lambda) = 0`` exactly.

    ``H`` is continuous and affine in ``(x, lambda)`` on each region of a
    partition (regions are identified by a caller-defined ``state``).  From a
    point ``(x0, lam0)`` on the curve, each segment moves along the tangent
    ``(dx, dlam)`` with ``dH/dx dx + dH/dlam dlam = 0`` up to the next region
    boundary.  The direction keeps the curve's orientation,
    ``dlam = direction * sign det(dH/dx) / sign det(dH/dx)_0``, so turning points
    (where ``det dH/dx`` changes sign) are passed instead of stalling there
    (pseudo-arclength continuation without step size: the steps are exact).

    Parameters
    ----------
    linearise : callable
        ``linearise(x, lam, state) -> (J, h)``: ``J = dH/dx`` (dense or sparse)
        and ``h = dH/dlambda`` (shape ``(n_x,)``) of region ``state``.
    crossing : callable
        ``crossing(x, lam, dx, dlam, state) -> (s, new_state)``: the smallest
        ``s > 0`` at which ``(x, lam) + s (dx, dlam)`` leaves region ``state``
        and the region entered there (``s = inf`` if none).
    x0 : ndarray, shape (n_x,)
    lam0, lam_end : float
        Start and target of ``lambda``; the path ends when ``lambda`` reaches ``lam_end``.
    state0 : object
        Region at the start, entered in the direction of travel.
    direction : float, optional
        Initial sign of ``dlam`` (default ``sign(lam_end - lam0)``).
    max_segments : int
    max_norm : float
        Failure when ``||x||_inf`` exceeds this (the curve runs off to infinity).

    Returns
    -------
    PathResult
    """
    x = np.array(x0, dtype=float)
    lam = float(lam0)
    state = state0
    if direction is None:
        direction = 1.0 if lam_end >= lam0 else -1.0
    sign0, prev, folds, stuck = None, None, 0, 0
    for seg in range(1, max_segments + 1):
        J, h = linearise(x, lam, state)
        solve, sdet = _factor(J)
        if solve is None:
            return PathResult(x, lam, state, False, f"singular dH/dx on segment {seg} (lambda = {lam:.6g}); "
                              "the path is not regular here", seg, folds)
        if sign0 is None:
            sign0 = sdet
        dlam = direction * sdet * sign0
        if prev is not None and dlam != prev:
            folds += 1
        prev = dlam
        dx = -dlam * solve(np.asarray(h, dtype=float))
        if not np.all(np.isfinite(dx)):
            return PathResult(x, lam, state, False, f"non-finite tangent on segment {seg}", seg, folds)
        s, new_state = crossing(x, lam, dx, dlam, state)
        s_end = (lam_end - lam) / dlam
        if 0.0 <= s_end <= s:
            return PathResult(x + s_end * dx, float(lam_end), state, True,
                              f"reached lambda = {lam_end:.6g} after {seg} segments, {folds} folds", seg, folds)
        if not np.isfinite(s):
            return PathResult(x, lam, state, False, f"the path leaves to infinity after {seg} segments "
                              f"(lambda = {lam:.6g}, {folds} folds)", seg, folds)
        x = x + s * dx
        lam = lam + s * dlam
        state = new_state
        stuck = stuck + 1 if s <= 0.0 else 0
        if stuck > 1000:
            return PathResult(x, lam, state, False, f"the path is degenerate at lambda = {lam:.6g} (1000 "
                              "zero-length segments)", seg, folds)
        if not np.all(np.isfinite(x)) or np.max(np.abs(x)) > max_norm:
            return PathResult(x, lam, state, False, f"the path diverges (||x|| > {max_norm:.0e}) after {seg} "
                              "segments", seg, folds)
    return PathResult(x, lam, state, False, f"no end of the path after {max_segments} segments "
                      f"(lambda = {lam:.6g}, {folds} folds)", max_segments, folds)
