"""Steps at fixed parameter of pseudo-arclength continuation (:mod:`mshbm.solvers.arclength`): across a kink
of the branch that the arclength corrector cannot turn (:func:`cross_kink`), and onwards at the edge of a
family of solutions (:func:`family_step`).  Each takes the run object of :func:`mshbm.solvers.arclength.continuation`
(``trace``: its settings, the branch so far, its Newton solves) and returns the new point.  A turn in ``lam``
between two points is recorded as a fold or, where the smooth piece changed with it, as a corner
(:func:`fold_or_corner`).

Notation as in :mod:`mshbm.solvers.arclength`.
"""
from __future__ import annotations

import numpy as np

from .arclength_parts import Failed, locate_fold

__all__ = ["cross_kink", "family_step", "fold_or_corner", "fixed_lam_solve", "KINK_STEPS"]

#: relative steps in lam tried, in this order, by a step at fixed lam across a kink (:func:`cross_kink`)
KINK_STEPS = (1e-3, 1e-4, 1e-5)


def cross_kink(trace, p, w):
    """A step at fixed ``lam`` from ``p`` in its direction of travel, across a kink of the branch that the
    arclength corrector cannot turn: past a kink whose two pieces meet at more than 90 degrees the
    hyperplane orthogonal to the incoming tangent misses the outgoing piece, and Newton on the
    bordered system cycles between the two pieces.  Where the branch passes the kink monotonically in
    ``lam`` a hyperplane ``lam = const`` meets it: Newton at fixed ``lam`` from ``p.x`` (relative
    steps ``KINK_STEPS``, at most ``2 max_corrector_iter`` iterations, a jump guard of ``max_jump ds0``).
    The new point keeps the orientation of the curve (sign det [A; t]).

    Where Newton from ``p.x`` fails or lands beyond the jump guard, the starts of ``restarts(x, lam)`` are
    tried (e.g. the state of the orbit just before and after the section ``t = 0`` of a shooting method: an
    event crossing the section makes the unknowns jump while the orbit moves on continuously); the jump guard
    then measures from the start used, the new point is oriented onwards in ``lam``, and the kink is marked
    ``"restart": True``."""
    lsc, lam_end, direction = trace.lsc, trace.lam_end, trace.direction
    if p.dlam == 0.0:
        raise Failed("no direction of travel in lam")
    sgn = 1.0 if p.dlam > 0 else -1.0
    last = "no step tried"
    for rel in KINK_STEPS:
        lam_n = p.lam + sgn * rel * lsc
        if (lam_n - lam_end) * direction > 0 and (p.lam - lam_end) * direction < 0:
            lam_n = lam_end
        try:
            x, it, r, data, x0 = fixed_lam_solve(trace, p, w, lam_n)
        except Failed as exc:
            last = str(exc)
            continue
        q, tq, wq = trace.make_point(x, lam_n, it, r, data, rel, trace.scaled_t(p, w), None)
        restart = x0 is not p.x
        if restart:  # the unknowns jumped: orientation by the direction of travel in lam
            flip = q.dlam * sgn < 0
        elif p.orientation and q.orientation:
            flip = q.orientation != p.orientation
        else:
            flip = q.dlam * sgn < 0
        if flip:
            q.dx, q.dlam, q.orientation = -q.dx, -q.dlam, -q.orientation
        try:
            trace.judged(q)
        except Failed as exc:
            last = str(exc)
            continue
        kink = {"lam": float(p.lam), "lam_right": float(lam_n), "index": len(trace.points),
                "cos_tangents": float(trace.scaled_t(q, wq) @ trace.scaled_t(p, wq)), "fixed_lam": True}
        if restart:
            kink["restart"] = True
            trace.counters["restarts"] = trace.counters.get("restarts", 0) + 1
        trace.kinks.append(kink)
        return q
    raise Failed(last)


def fixed_lam_solve(trace, p, w, lam_n):
    """Newton at fixed ``lam_n`` from ``p.x``, then from the starts of ``trace.restarts`` (module docstring):
    the first solution within the jump guard ``max_jump ds0`` (scaled) of its start; returns ``(x, iterations,
    residual, data, start)``."""
    why, starts = "no start", [p.x]
    k = 0
    while k < len(starts):
        x0 = starts[k]
        try:
            x, it, r, data, _ = trace.newton_fixed(x0, lam_n, allow_stall=False, max_iter=2 * trace.max_corrector_iter,
                                                   free=trace.free_units(p, w) if k == 0 else None)
            dist = float(np.linalg.norm(np.concatenate([(x - x0) / w, [(lam_n - p.lam) / trace.lsc]])))
            if dist <= trace.max_jump * trace.ds0:
                return x, it, r, data, x0
            why = f"the solution at lam = {lam_n:.6g} is {dist:.3g} away (another branch?)"
        except Failed as exc:
            why = str(exc)
        if k == 0 and trace.restarts is not None:
            starts += list(trace.restarts(p.x, p.lam))
        k += 1
    raise Failed(why if len(starts) == 1 else f"{why} (also from {len(starts) - 1} restarts)")


def family_step(trace, p, w):
    """A step at fixed ``lam`` onwards (by the ``lam`` part of ``min(ds, ds0)`` along the tangent, at least
    ``KINK_STEPS[0]``, in the direction of travel) where the branch would turn back next to a family of solutions (a stuck element: its offset is free inside an interval that
    shrinks as the amplitude grows).  The arclength corrector follows the family's edge, and where the
    interval closes its tangent turns into the other edge, back in ``lam``: a corner of the solution set,
    not a fold.  Newton at fixed ``lam`` from ``p`` (no free directions held) continues on the branch
    beyond (slip); the point is oriented onwards and the corner recorded as a kink (``"family": True``)."""
    sgn = 1.0 if p.dlam > 0 else -1.0 if p.dlam < 0 else trace.direction
    lam_n = p.lam + sgn * max(min(trace.ds, trace.ds0) * abs(trace.scaled_t(p, w)[-1]), KINK_STEPS[0]) * trace.lsc
    if (lam_n - trace.lam_end) * trace.direction > 0 and (p.lam - trace.lam_end) * trace.direction < 0:
        lam_n = trace.lam_end
    x, it, r, data, st = trace.newton_fixed(p.x, lam_n, allow_stall=False, max_iter=2 * trace.max_corrector_iter)
    q, _, _ = trace.make_point(x, lam_n, it, r, data, trace.ds, trace.scaled_t(p, w), st)
    if q.dlam * sgn < 0:
        q.dx, q.dlam, q.orientation = -q.dx, -q.dlam, -q.orientation
    trace.judged(q)
    trace.kinks.append({"lam": float(p.lam), "lam_right": float(lam_n), "index": len(trace.points),
                       "fixed_lam": True, "family": True})
    trace.counters["family_steps"] = trace.counters.get("family_steps", 0) + 1
    return q


def fold_or_corner(trace, step_p, w, q):
    """A fold between the last point ``p`` of ``trace`` and ``q`` (the ``lam`` component of the tangent changed
    sign), located by :func:`mshbm.solvers.arclength_parts.locate_fold` and appended to ``trace.folds``; a turn
    that comes with a change of the smooth piece is a corner instead (appended to ``trace.kinks``)."""
    p, ds, fold_rtol = step_p, trace.ds, trace.fold_rtol
    if p.dlam * q.dlam < 0 and p.segment is not None and q.segment is not None and p.segment != q.segment:
        # the turn in lam comes with a change of the smooth piece: a corner (e.g. a grazing, where an impacting
        # branch bends away from the non-impacting one), not a fold (whose tangent turns smoothly)
        trace.kinks.append({"lam": float(p.lam), "lam_right": float(q.lam), "index": len(trace.points),
                            "reversal": True})
        return
    if p.dlam * q.dlam < 0 and p.stall is None and q.stall is None:
        try:
            trace.folds.append(locate_fold(trace.step, p, w, ds, q, len(trace.points), fold_rtol, trace.lsc))
        except Failed as exc:
            trace.folds.append({"lam": float(0.5 * (p.lam + q.lam)) if abs(q.lam - p.lam) <= fold_rtol * abs(q.lam)
                                else max(p.lam, q.lam) if p.dlam > 0 else min(p.lam, q.lam),
                                "x": q.x, "index": len(trace.points), "located": False, "note": str(exc)})
