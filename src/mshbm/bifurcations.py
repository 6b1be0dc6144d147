"""Bifurcations along a branch of periodic solutions: detection and location.

:func:`detect` takes the points of a branch (in the order of the continuation) and returns the
bifurcations between consecutive points, each a :class:`Bifurcation` with ``type``, ``omega`` and
``index`` (the event lies between points ``index`` and the next point with data).

Types and test functions
------------------------
Multipliers count as *real* when ``|Im mu| <= REAL_TOL max(1, |mu|)``; the crossing is classified
by which multipliers leave (or enter) the unit circle between two points:

``"fold"`` (turning point)
    ``tau_F = tangent_omega``, the omega-component of the arclength tangent: it changes sign.
    (A multiplier passes +1 there; that crossing alone is not reported, it is a fold or a branch
    point.)
``"period-doubling"`` (flip)
    a real multiplier passes -1: the number of real multipliers with ``mu < -1`` changes.
    ``tau_PD = prod_j (mu_j + 1) = det(Phi + I)`` (real): it changes sign exactly when a real
    multiplier passes -1 and is smooth in omega also where two multipliers meet on the negative
    real axis just before the crossing (a complex pair contributes ``|mu + 1|^2 > 0``), unlike
    ``|mu| - 1`` of the multiplier nearest -1.  On the impact oscillator's closed-form branch
    it locates the period doubling an order of magnitude more precisely than ``|mu| - 1``.
``"neimark-sacker"`` (secondary Hopf)
    a complex pair passes the unit circle: the number of non-real multipliers with ``|mu| > 1``
    changes.  ``tau_NS = max{|mu| : Im mu != 0} - 1``.
``"grazing"``
    ``contact_active`` (any contact element closed or touching during the period) changes: the
    branch's first or last contact; or, between impacting orbits of the exact flow, ``impacts`` (the
    number of impacts per period) changes: an impact appears or disappears with zero velocity (a near
    miss touches the stop, or an impact's velocity vanishes).  The branch goes on with the other
    impact sequence, with a kink in ``(x, omega)``: on the side with the extra impact the saltation
    matrix of that impact grows like ``1 / v``, so multipliers there run off to infinity; a
    period-doubling or Neimark-Sacker count change across it is attributed to the grazing.  Its test
    function is ``-v_min / (omega D)`` (the smallest impact velocity, as a displacement, ``impact_margin``)
    on the side with more impacts and ``miss / D`` (the smallest gap at a near miss, ``miss_margin``) on
    the other; both vanish at the grazing and vary linearly in omega near it.  For the first or last
    contact ``tau_G = gap``, when the points give it: a signed number that
    is positive without contact (e.g. the smallest gap over the period), negative with contact
    (e.g. minus the impact velocity or the penetration) and zero at grazing; else the midpoint.
    Where the contact state changes, the multipliers of a nonsmooth flow jump (the saltation
    matrix of a grazing impact diverges): a change of the multiplier counts in the same interval is
    attributed to the grazing and not reported as a period doubling or Neimark-Sacker bifurcation.

Location
--------
1. Interpolation of the test function between the bracketing points: linear in omega for
   ``tau_PD``, ``tau_NS``, ``tau_G``.  For a fold, omega is extremal, so ``omega`` is modelled as
   quadratic in a local parameter ``theta`` in [0, 1] with ``d omega / d theta`` proportional to the
   linearly interpolated ``tangent_omega``; the fold is the extremum of that quadratic.
2. With a ``locate`` callback, bisection: ``locate(type, left, right)`` must return a new
   :class:`BranchPoint` on the branch strictly between the two bracketing records (``left`` and
   ``right`` are :class:`BranchPoint` s; at the first call ``points[i]`` and ``points[j]``, whose
   ``x`` the callback may use, e.g. a corrector from their mean), or ``None`` to stop.  The half
   bracket in which the test function changes sign is kept until the bracket spans at most
   ``rel_tol`` (default 1e-3, well below the required 1 %) of omega, then step 1 is applied to the
   final bracket.  A grazing is different: the branch may turn back in omega there (a corner, e.g. an
   impacting branch that bends away from the non-impacting one), so that both bracketing points lie on one
   side of it in omega and no bracket in omega closes on it.  Its test function is extrapolated on each side
   separately (linearly in omega, from that side's two nearest points), and the bisection ends when the side
   nearest to its own estimate is within ``rel_tol`` of it and the other side's estimate agrees; the
   callback then places new points on either side's own piece (:func:`mshbm.branch.sweep`'s locator).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, Callable, Optional, Sequence

import numpy as np
import scipy.sparse as sp

from .errors import InputError

__all__ = ["BranchPoint", "Bifurcation", "detect", "point_from_solution", "TYPES", "REAL_TOL"]

TYPES = ("fold", "period-doubling", "neimark-sacker", "grazing")
#: a multiplier is real when ``|Im mu| <= REAL_TOL max(1, |mu|)``
REAL_TOL = 1e-6
#: most bisection steps per event
MAX_BISECTIONS = 40


@dataclass
class BranchPoint:
    """One point of a branch as :func:`detect` sees it.

    Attributes
    ----------
    omega : float
    x : any
        The solution (unknowns, PeriodicSolution, ...) for a ``locate`` callback; unused here.
    multipliers : complex ndarray or None
        Floquet multipliers, ``None`` where no reliable estimate exists.
    tangent_omega : float or None
        omega-component of the arclength tangent (in the continuation's direction).
    contact_active : bool or None
        Any contact element closed or touching during the period.
    gap : float or None
        Signed grazing test function (see the module docstring).
    impacts : int or None
        Impacts per period of all contacts (exact event-driven solutions only).
    impact_margin : float or None
        ``-v_min / (omega D)``: minus the smallest impact velocity as a displacement, relative (``None``
        without impacts).
    miss_margin : float or None
        The smallest gap at a near miss (a local minimum of the gap in free flight), relative (``None``
        without one).
    """

    omega: float
    x: Any = None
    multipliers: Optional[np.ndarray] = None
    tangent_omega: Optional[float] = None
    contact_active: Optional[bool] = None
    gap: Optional[float] = None
    impacts: Optional[int] = None
    impact_margin: Optional[float] = None
    miss_margin: Optional[float] = None

    def __post_init__(self):
        self.omega = float(self.omega)
        if self.multipliers is not None:
            self.multipliers = np.asarray(self.multipliers, dtype=complex).reshape(-1)


@dataclass
class Bifurcation:
    """A bifurcation located between points ``index`` and ``index_right`` of the branch."""

    type: str
    omega: float
    index: int
    index_right: int
    located: str  # "interpolation" or "bisection"
    bracket: tuple = field(default=(np.nan, np.nan))  # omega of the final bracketing points
    bisections: int = 0

    def as_dict(self):
        """``{"type", "omega", "index"}`` (JSON-ready)."""
        return {"type": self.type, "omega": float(self.omega), "index": int(self.index)}


_KEYS = {f.name for f in fields(BranchPoint)}


def _point(p, k):
    if isinstance(p, BranchPoint):
        return p
    if isinstance(p, dict):
        if "omega" not in p:
            raise InputError(f"points[{k}].omega", "missing")
        return BranchPoint(**{key: v for key, v in p.items() if key in _KEYS})
    raise InputError(f"points[{k}]", f"must be a BranchPoint or a dict, got {type(p).__name__}")


# --------------------------------------------------------------------------------------- test functions
def _is_real(mu):
    return np.abs(mu.imag) <= REAL_TOL * np.maximum(1.0, np.abs(mu))


def _n_flip(mu):
    r = _is_real(mu)
    return int(np.sum(r & (mu.real < -1.0)))


def _n_ns(mu):
    return int(np.sum(~_is_real(mu) & (np.abs(mu) > 1.0)))


def _tau(kind, p):
    """Test function of ``kind`` at a point (``None`` where the point has no data)."""
    if kind == "fold":
        return None if p.tangent_omega is None else float(p.tangent_omega)
    if kind == "grazing":
        return None if p.gap is None else float(p.gap)
    mu = p.multipliers
    if mu is None or mu.size == 0:
        return None
    if kind == "period-doubling":
        return float(np.real(np.prod(mu + 1.0)))
    sel = ~_is_real(mu)
    if not sel.any():
        return -1.0  # no candidate: far from the crossing
    return float(np.max(np.abs(mu[sel]))) - 1.0


def _has_data(kind, p):
    if kind == "fold":
        return p.tangent_omega is not None and np.isfinite(p.tangent_omega)
    if kind == "grazing":
        return p.contact_active is not None
    return p.multipliers is not None and p.multipliers.size > 0 and bool(np.all(np.isfinite(p.multipliers)))


def _impacts_change(a, b):
    return a.impacts is not None and b.impacts is not None and int(a.impacts) != int(b.impacts)


def _crosses(kind, a, b):
    """True when the event ``kind`` lies between the points ``a`` and ``b`` (both with data)."""
    if kind == "fold":
        return np.sign(a.tangent_omega) * np.sign(b.tangent_omega) < 0
    if kind == "grazing":
        return bool(a.contact_active) != bool(b.contact_active) or _impacts_change(a, b)
    if a.contact_active is not None and b.contact_active is not None and a.contact_active != b.contact_active:
        return False  # the multipliers jump at a grazing (the saltation diverges): reported as the grazing
    if _impacts_change(a, b):
        return False  # the same between impacting orbits: an impact appears or vanishes with zero velocity
    if kind == "period-doubling":
        return _n_flip(a.multipliers) != _n_flip(b.multipliers)
    return _n_ns(a.multipliers) != _n_ns(b.multipliers)


def _interpolate(kind, a, b):
    """omega of the event between ``a`` and ``b`` from the test function (module docstring)."""
    wa, wb = a.omega, b.omega
    if kind == "fold":
        ta, tb = float(a.tangent_omega), float(b.tangent_omega)
        th = ta / (ta - tb)  # zero of the linear tangent in theta
        ssum = 0.5 * (ta + tb)
        if abs(ssum) <= 1e-12 * max(abs(ta), abs(tb)):
            return max(wa, wb) if ta > 0 else min(wa, wb)
        c = (wb - wa) / ssum
        return wa + c * (ta * th + 0.5 * (tb - ta) * th * th)
    if kind == "grazing" and bool(a.contact_active) == bool(b.contact_active) and _impacts_change(a, b):
        # between impacting orbits: the impact velocity on the side with the extra impact, the near miss
        # on the other
        fa = a.impact_margin if a.impacts > b.impacts else a.miss_margin
        fb = b.impact_margin if b.impacts > a.impacts else b.miss_margin
    else:
        fa, fb = _tau(kind, a), _tau(kind, b)
    if fa is None or fb is None or fa == fb or np.sign(fa) * np.sign(fb) > 0:
        return 0.5 * (wa + wb)
    return wa + (wb - wa) * fa / (fa - fb)


def _side(kind, a, m):
    """True when the event lies between ``a`` and the new point ``m`` (else between ``m`` and the right)."""
    return _crosses(kind, a, m)


def detect(points: Sequence, locate: Optional[Callable] = None, rel_tol: float = 1e-3,
           types: Sequence[str] = TYPES) -> list:
    """Bifurcations along a branch.

    Parameters
    ----------
    points : sequence of BranchPoint or dict
        The branch in continuation order; dicts with keys ``omega`` and optionally ``x``,
        ``multipliers``, ``tangent_omega``, ``contact_active``, ``gap`` (unknown keys ignored).
    locate : callable, optional
        ``locate(type, left, right) -> BranchPoint | dict | None``: a point on the branch between two
        bracketing records, for bisection (module docstring).
    rel_tol : float
        Bisection ends when the bracket spans at most ``rel_tol * |omega|``.
    types : sequence of str
        Which of :data:`TYPES` to look for.

    Returns
    -------
    list of Bifurcation
        Sorted by ``index`` (then by type order).  Points without the data a test needs (e.g.
        ``multipliers=None``) are skipped: the event is then bracketed by the nearest points with data.
    """
    pts = [_point(p, k) for k, p in enumerate(points)]
    for t in types:
        if t not in TYPES:
            raise InputError("types", f"unknown bifurcation type {t!r} (choose from {', '.join(TYPES)})")
    if not (isinstance(rel_tol, (int, float)) and 0 < rel_tol < 1):
        raise InputError("rel_tol", f"must be a number in (0, 1), got {rel_tol!r}")
    out = []
    for kind in types:
        last = None
        for k, p in enumerate(pts):
            if not _has_data(kind, p):
                continue
            if last is not None and _crosses(kind, pts[last], p):
                out.append(_locate(kind, last, k, pts[last], p, locate, rel_tol))
            last = k
    out.sort(key=lambda b: (b.index, TYPES.index(b.type)))
    return out


def _side_value(kind, p, other):
    """The grazing test function on ``p``'s side of a bracket ``(p, other)`` (module docstring), or ``None``."""
    if bool(p.contact_active) == bool(other.contact_active) and _impacts_change(p, other):
        v = p.impact_margin if p.impacts > other.impacts else p.miss_margin
    else:
        v = _tau(kind, p)
    return None if v is None or not np.isfinite(v) else float(v)


def extrapolate_grazing(side, other):
    """omega where the grazing test function of the points ``side`` (one side of a grazing, nearest last; the
    other side's end ``other``) vanishes, extrapolated linearly in omega from the two nearest; ``None``
    without two usable points, or where it lands farther than half the frequency from the nearest (a test
    function nearly flat on the side: beam-stop-cb by event shooting extrapolated to omega = -1.4e5 from points
    near 1080 rad/s, and its sweep ended in an error after the trace; at a corner the grazing lies outside the
    bracket, but some bracket widths away)."""
    vals = [(p.omega, _side_value("grazing", p, other)) for p in side[-2:]]
    if len(vals) < 2 or any(v is None for _, v in vals) or vals[0][0] == vals[1][0] or vals[0][1] == vals[1][1]:
        return None
    (w0, f0), (w1, f1) = vals
    w = w1 - f1 * (w1 - w0) / (f1 - f0)
    return w if math.isfinite(w) and abs(w - w1) <= 0.5 * abs(w1) else None


def _estimate(kind, sides, a, b, tol):
    """``(omega, done)``: omega of the event in the bracket ``(a, b)`` and whether the bracket locates it to
    ``tol``.  For a grazing, the extrapolation of the side whose nearest point is nearest to its own
    extrapolation (``sides``: the bracket ends so far, per side; the branch may turn back in omega at a
    grazing, a corner: the event then lies outside ``[omega_a, omega_b]``, and one side's smooth piece may be
    harder to approach than the other's); done when that point is within ``tol`` of it and the other side's
    extrapolation, where it exists, agrees to ``tol`` (a short bracket is not enough: at a corner both ends may
    be near each other and far from it).  Else :func:`_interpolate`, done when the bracket spans
    at most ``tol``."""
    span = abs(b.omega - a.omega) <= tol
    if kind == "grazing":
        est = [(abs(e - side[-1].omega), e) for side, other in ((sides[0], b), (sides[1], a))
               for e in (extrapolate_grazing(side, other),) if e is not None]
        if est:
            near, w = min(est)
            return float(w), near <= tol and max(abs(e - w) for _, e in est) <= tol
    return _interpolate(kind, a, b), span


def _locate(kind, i, j, a, b, locate, rel_tol):
    located, nb = "interpolation", 0
    sides = ([a], [b])
    if locate is not None:
        while nb < MAX_BISECTIONS:
            w, done = _estimate(kind, sides, a, b, rel_tol * max(abs(a.omega), abs(b.omega)))
            if done:
                break
            m = locate(kind, a, b)
            if m is None:
                break
            m = _point(m, f"locate:{nb}")
            nb += 1
            if not _has_data(kind, m):
                break
            if _side(kind, a, m):
                b = m
                sides[1].append(m)
            elif _crosses(kind, m, b):
                a = m
                sides[0].append(m)
            else:  # the new point sees no crossing on either side: keep the old bracket, stop
                break
            located = "bisection"
    w = _estimate(kind, sides, a, b, 0.0)[0] if located == "bisection" else _interpolate(kind, a, b)
    return Bifurcation(kind, float(w), i, j, located, (a.omega, b.omega), nb)


#: a contact counts as touching when its smallest gap over the period is at most this (relative to
#: the gap and the displacement amplitude of its DOF)
CONTACT_TOL = 1e-8


def point_from_solution(system, sol, tangent_omega=None, x=None):
    """:class:`BranchPoint` of a :class:`mshbm.PeriodicSolution` of ``system``.

    * ``multipliers``: the solution's Floquet multipliers when they are valid for the flow that is
      reported: the exact flow with saltation (:data:`mshbm.stability.EXACT`, also when marginal),
      Hill's method (:data:`mshbm.hill.HILL`, the regularised system) or a step-map estimate that
      gave a verdict (smooth motion); ``None`` otherwise (never Moreau-Jean multipliers at impacts);
    * ``contact_active`` and ``gap``: for systems with contacts, the smallest gap
      ``min_t (g0 - q_dof(t))`` over the period and elements (``info["q_max"]`` of exact solutions,
      else the samples); active when it is at most :data:`CONTACT_TOL` (relative); ``None`` without
      contacts.  With contact, exact solutions (``info["events"]``) give ``gap = -v / omega`` (same
      scale) with ``v`` the largest impact velocity, which also vanishes at grazing, so that the
      grazing is interpolated between a positive and a negative value.  For a failed solve everything is ``None``.
    * ``impacts``, ``impact_margin``, ``miss_margin``: from the exact event-driven flow's
      ``info["contact_margins"]`` (:func:`mshbm.integrators.event.contact_margins`: impacts per period,
      smallest impact velocity and smallest near-miss gap of each contact), relative to the same scale;
      ``None`` for other solutions (a Moreau-Jean map resolves neither quantity).
    """
    from . import stability
    from .hill import HILL
    from .methods.mass_coupling import impact_compliance

    if not sol.success:
        return BranchPoint(sol.omega, x=sol if x is None else x, tangent_omega=tangent_omega)
    mult = np.asarray(getattr(sol, "floquet_multipliers", []), dtype=complex)
    meth = getattr(sol, "stability_method", "")
    valid = meth in (stability.EXACT, HILL) or (meth == stability.STEP_MAP and sol.stable is not None)
    mu = mult if (valid and mult.size) else None
    gaps = []
    q_max = sol.info.get("q_max") if isinstance(sol.info, dict) else None
    time_dofs = set(int(i) for i in np.asarray(sol.time_dofs).reshape(-1))
    impulses = sol.impulses if isinstance(sol.impulses, np.ndarray) and sol.impulses.ndim == 2 else None
    # ((M_TT)^-1)_dd: 1 / the mass an impact on DOF d acts with where the DOFs T are integrated in time
    minv = impact_compliance(system, sol.time_dofs) if time_dofs else {}
    for j, el in enumerate(system.elements):
        if not el.unilateral:
            continue
        d = el.dof
        amp = float(np.max(np.abs(sol.displacement([d]))))
        scale = max(abs(el.gap), amp, 1e-300)
        if impulses is not None and d in time_dofs and q_max is None:
            # time-stepped DOF: an impact is an impulse (the sampled gap may stay just above 0 between
            # samples); as for the exact flow, minus the impact velocity as a displacement, -> 0 at grazing
            P = float(np.max(impulses[:, j], initial=0.0))
            if P > 0.0:
                v = P * minv[d] / (1.0 + el.restitution)
                gaps.append(-v / sol.omega / scale)
                continue
        qd = float(np.asarray(q_max)[d]) if q_max is not None else float(np.max(sol.displacement([d])))
        gaps.append((el.gap - qd) / scale)
    margins = sol.info.get("contact_margins") if isinstance(sol.info, dict) else None
    n_imp = imp_m = miss_m = None
    if margins:
        n_imp, imp, miss = 0, [], []
        for j, rec in margins.items():
            el = system.elements[int(j)]
            scale = max(abs(el.gap), float(np.max(np.abs(sol.displacement([el.dof])))), 1e-300)
            n_imp += int(rec["impacts"])
            if rec["impacts"] and np.isfinite(rec["v_min"]):
                imp.append(-float(rec["v_min"]) / sol.omega / scale)
            if np.isfinite(rec["miss"]):
                miss.append(float(rec["miss"]) / scale)
        imp_m = max(imp) if imp else None  # the impact nearest to grazing: the smallest velocity
        miss_m = min(miss) if miss else None
    if gaps:
        g = min(gaps)
        active = g <= CONTACT_TOL
        evs = sol.info.get("events") if isinstance(sol.info, dict) else None
        if active and evs:  # exact flow: minus the largest impact velocity (-> 0 at grazing), as a displacement
            v = max((abs(float(e.velocity)) for e in evs if getattr(e, "impulse", 0.0) != 0.0), default=0.0)
            if v > 0.0:
                el = next(e for e in system.elements if e.kind == "contact")
                amp = float(np.max(np.abs(sol.displacement([el.dof]))))
                g = -v / sol.omega / max(abs(el.gap), amp, 1e-300)
        return BranchPoint(sol.omega, x=sol if x is None else x, multipliers=mu, tangent_omega=tangent_omega,
                           contact_active=active, gap=g, impacts=n_imp, impact_margin=imp_m, miss_margin=miss_m)
    return BranchPoint(sol.omega, x=sol if x is None else x, multipliers=mu, tangent_omega=tangent_omega)
