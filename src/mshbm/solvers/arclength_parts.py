"""The pieces of pseudo-arclength continuation (:mod:`mshbm.solvers.arclength`): the points and the result,
the scaled evaluation of the residual, the tangent and its orientation, the location of folds, and the
backtracking of the fixed-parameter Newton.

Notation as in :mod:`mshbm.solvers.arclength`: ``R(x, lam)`` the residual with row scale ``s``, ``J = dR/dx``,
``g = dR/dlam``, unknowns scaled by ``w``, the parameter by ``lam_scale``; ``t = (t_y, t_mu)`` the unit
tangent in scaled variables.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .newton import _METER, charge

__all__ = ["ContinuationPoint", "ContinuationResult", "Failed", "bordered_solve", "Evaluator", "orientation",
           "tangent", "backtrack", "stall_folds", "locate_fold", "free_directions", "FREE_RTOL"]

#: a singular value of the scaled ``J_y`` below ``FREE_RTOL`` times the largest of ``[J_y, g]`` marks a free direction
#: (see :func:`free_directions`)
FREE_RTOL = 1e-10
#: ... when ``[J_y, g]`` is rank deficient too: its smallest singular value below ``FREE_RANGE_RTOL`` times the
#: largest (``g`` in the range of ``J_y`` up to the rounding of ``dR/dlam``, see :func:`free_directions`)
FREE_RANGE_RTOL = 1e-7



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
    #: free directions of the solution set at fixed ``lam`` (:func:`free_directions`, rows in scaled
    #: unknowns, shape ``(k, n_x)``), None if there are none
    free: object = None
    #: a natural-parameter step's stalled iterate where the point is the exact root near it: the next step's start
    track: object = None


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


class Failed(Exception):
    """A step, corrector or Newton solve of the continuation failed (the message says why)."""

    pass


def bordered_solve(A, b, free=None):
    """``A^-1 b`` (least squares if ``A`` is singular); :class:`Failed` if not finite.

    ``free`` (shape ``(k, m)``, ``m <= A.shape[1]``): rows appended to ``A`` with right-hand side 0, so
    that the solution has no component along the free directions (their first ``m`` unknowns): the
    minimum-norm step of a system whose solutions form a family (:func:`free_directions`), solved in
    the least-squares sense (exact when the system is consistent)."""
    if free is not None:
        F = np.zeros((free.shape[0], A.shape[1]))
        F[:, :free.shape[1]] = free
        z = np.linalg.lstsq(np.vstack([A, F]), np.concatenate([b, np.zeros(F.shape[0])]), rcond=None)[0]
        if not np.all(np.isfinite(z)):
            raise Failed("singular bordered system")
        return z
    try:
        z = np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        z = np.linalg.lstsq(A, b, rcond=None)[0]
    if not np.all(np.isfinite(z)):
        raise Failed("singular bordered system")
    return z


class Evaluator:
    """Scaled evaluation of the callables at ``(x, lam)``, counting calls.

    The last ``(R, J)`` is kept with its ``(x, lam)`` (bit for bit): a corrector evaluates the point its line
    search accepted a second time, with the Jacobian the residual callable computed for the trial already
    (it always returns one), so that evaluation is served from the kept one.  It counts and charges the work
    meters as the evaluation it replaces (the route's budgets see the same work)."""

    def __init__(self, residual, d_lam, residual_scale, unknown_scale, lam_scale):
        self.residual, self.d_lam = residual, d_lam
        self.residual_scale, self.unknown_scale = residual_scale, unknown_scale
        self.lam_scale = float(lam_scale)
        self.n_res = self.n_dlam = 0
        self.n_reused = 0  # evaluations served from the kept one
        self._last = None  # ((shape, x bytes, lam), R, J, the work it charged to the meters)

    def _evaluate(self, x, lam):
        """``(R, J)`` of ``residual(x, lam)``, from the kept evaluation where ``(x, lam)`` is its point."""
        x = np.asarray(x, dtype=float)
        key = (x.shape, x.tobytes(), float(lam))
        last = self._last
        if last is not None and last[0] == key:
            self.n_reused += 1
            charge(last[3])
            return np.array(last[1]), (last[2].copy() if last[2] is not None else None)
        meter = _METER.get()
        used0 = meter.used if meter is not None else 0.0
        self._last = None
        R, J = self.residual(x, lam)
        charge(1)  # the work meter of the solve route (mshbm.solvers.newton.work_box), deterministic
        work = meter.used - used0 if meter is not None else 1.0
        self._last = (key, np.array(R), (J.copy() if J is not None else None), work)
        return R, J

    def __call__(self, x, lam, jac=True, dlam=True):
        """``(R, s, r, J, g)``: residual, row scale, scaled residual norm, Jacobian and ``dR/dlam`` (``J, g``
        None without ``jac``; ``g`` None without ``dlam``, see :meth:`g`)."""
        R, J = self._evaluate(x, lam)
        self.n_res += 1
        s = np.asarray(self.residual_scale(x, lam), dtype=float)
        r = float(np.max(np.abs(R) / s)) if R.size else 0.0
        if not jac:
            return R, s, r, None, None
        g = self.g(x, lam) if dlam else None
        # the bordered systems are dense (the harmonic methods' unknowns are few; condense=False gives
        # a sparse J of the same small size)
        J = J.toarray() if sp.issparse(J) else np.asarray(J, dtype=float)
        return R, s, r, J, g

    def g(self, x, lam):
        """``dR/dlam`` at ``(x, lam)``, shape ``(n_x,)``: where it costs residuals of rebuilt problems (central
        differences: two residuals), Newton at fixed ``lam`` asks for it only at the point it returns (for the tangent)."""
        self.n_dlam += 1
        return np.asarray(self.d_lam(x, lam), dtype=float)


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


def free_directions(J, g, s, w, lam_scale, rtol=FREE_RTOL, range_rtol=FREE_RANGE_RTOL):
    """Free directions of the solutions at fixed ``lam``: an orthonormal basis (rows, scaled unknowns
    ``y = x / w``, shape ``(k, n_x)``) of the null space of ``J_y`` (singular values below ``rtol`` times the
    largest of ``[J_y, g]``) when ``[J_y, g]`` is rank deficient too (its smallest singular value below
    ``range_rtol`` times the largest), else ``None``.

    The two bounds differ: a family's null space is exact (a stuck element's periodicity row is identically
    zero: ``1e-17`` of the largest), while ``g`` (``dR/dlam``, e.g. an integrator's derivative in ``omega``)
    lies in the range of ``J_y`` only up to its rounding (``1e-10``-``1e-9`` of the largest singular value on
    a stuck Coulomb contact of MS-HBM).  A fold has ``J_y`` singular only where a point falls on it exactly,
    and ``g`` far outside its range there.

    Then the solutions near ``(x, lam)`` are not a curve but a family of dimension ``k + 1``: e.g. a
    Jenkins slider that sticks the whole period can sit at any offset (with the structure's mean
    displacement following it), and its periodicity row is identically zero.  At a fold ``J_y`` is
    singular but ``[J_y, g]`` is not, and there are no free directions.  The continuation fixes the free
    directions by the minimum-norm rule: tangents and corrections have no component along them
    (:func:`bordered_solve`), i.e. the offset of a stuck element stays where the branch brought it."""
    Jy = (J * w[None, :]) / s[:, None]
    A = np.hstack([Jy, (g * lam_scale / s)[:, None]])
    if A.size == 0 or not np.all(np.isfinite(A)):
        return None
    sa = np.linalg.svd(A, compute_uv=False)
    if sa[0] == 0.0 or sa[-1] > range_rtol * sa[0]:
        return None
    _, sj, Vt = np.linalg.svd(Jy)
    k = int(np.sum(sj <= rtol * sa[0]))
    return Vt[-k:].copy() if k > 0 else None


def tangent(J, g, s, w, lam_scale, previous=None, free=None):
    """Unit tangent ``(t_y, t_mu)`` in scaled variables of ``R(x, lam) = 0`` (see the module docstring),
    oriented along ``previous`` (a scaled tangent) or, without one, towards increasing ``lam``; with
    ``free`` (:func:`free_directions`) the one orthogonal to the free directions (minimum norm)."""
    A = np.hstack([(J * w[None, :]) / s[:, None], (g * lam_scale / s)[:, None]])
    n = A.shape[1]
    if free is not None:
        gauge = np.zeros(n)
        gauge[-1] = 1.0
        if previous is not None and abs(float(previous[-1])) < 0.5:  # near a fold: the previous tangent
            gauge = previous
        z = bordered_solve(np.vstack([A, gauge]), np.eye(n)[-1], free=free)
        z = z / np.linalg.norm(z)
        if previous is not None and float(z @ previous) < 0 or previous is None and z[-1] < 0:
            z = -z
        return z
    if previous is None:  # the row that fixes the gauge: the column of A least in its range (lam, unless at a fold)
        gauge = np.zeros(n)
        gauge[-1] = 1.0
    else:
        gauge = previous
    B = np.vstack([A, gauge])
    try:
        z = np.linalg.solve(B, np.eye(n)[-1])
        if not np.all(np.isfinite(z)):
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        z = np.linalg.svd(A)[2][-1]
    z = z / np.linalg.norm(z)
    if float(z @ gauge) < 0:
        z = -z
    return z


def backtrack(norm, x, dx, r):
    """``x + a dx`` with the largest ``a`` in ``1, 1/2, ..., 1/128`` that lowers ``norm`` below ``r``, and
    True; else ``(x + dx, False)``."""
    a = 1.0
    for _ in range(8):
        xt = x + a * dx
        rt = norm(xt)
        if np.isfinite(rt) and rt < r:
            return xt, True
        a *= 0.5
    return x + dx, False


def stall_folds(points, rtol):
    """Turning points of ``lam`` along the branch with a reversal of more than ``rtol`` (relative) that the next
    point keeps, kept where the extreme point or a neighbour was accepted at step accuracy (tangent folds cover
    the rest)."""
    lam = np.array([p.lam for p in points])
    out, ext, trend = [], 0, 0
    for i in range(1, lam.size):
        thr = rtol * max(abs(lam[ext]), 1e-300)
        if trend == 0:
            if abs(lam[i] - lam[0]) > thr:
                trend, ext = (1 if lam[i] > lam[0] else -1), i
        elif trend * (lam[i] - lam[ext]) >= 0:
            ext = i
        elif trend * (lam[ext] - lam[i]) > thr and (i + 1 == lam.size or trend * (lam[ext] - lam[i + 1]) > thr):
            # a reversal that the next point confirms (a point accepted at step accuracy may lie off the curve
            # by more than rtol, ahead of it: the branch then comes back once and goes on, no fold)
            out.append(ext)
            trend, ext = -trend, i
    folds = []
    for i in out:
        near = points[max(i - 1, 0):i + 2]
        if any(p.stall is not None for p in near):
            folds.append({"lam": float(lam[i]), "x": points[i].x, "index": int(i), "located": "extreme point"})
    return folds


def locate_fold(step, p, w, ds, q, index, rtol, lsc):
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
        from_p = point_tangent_lam(data, x, lam, p, w, lsc)
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


def point_tangent_lam(data, x, lam, p, w, lsc):
    R, s, J, g = data
    t_prev = np.concatenate([p.dx / w, [p.dlam / lsc]])
    t_prev /= np.linalg.norm(t_prev)
    t = tangent(J, g, s, w, lsc, previous=t_prev)
    return float(t[-1] * lsc)
