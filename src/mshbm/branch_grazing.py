"""The grazing locator of frequency sweeps (:func:`mshbm.branch.sweep`): new points on the branch next to a
grazing for the bisection of :func:`mshbm.bifurcations.detect`.

Notation: ``omega`` the frequency of the records (the base frequency ``omega / k`` of kT-periodic orbits), ``x``
the method's unknowns; the ``tracer`` is the sweep's problem cache (:class:`mshbm.branch_tracer._Tracer`).
"""
from __future__ import annotations

from . import bifurcations
from .solvers.newton import newton

__all__ = ["grazing_locator"]


def grazing_locator(tracer, system, tol):
    """Bisection callback of :func:`mshbm.bifurcations.detect` for grazings of the exact event-driven flow
    (records with ``impacts``), on the branch where the grazing happens: a new point on one side's own smooth
    piece (the same impacts and contact state as that end of the bracket), by Newton at fixed omega from the
    secant of the side's two nearest points (then from its end), at 0.9 of the way to the omega where the side's
    test function (near-miss gap, impact velocity or gap, :func:`mshbm.bifurcations.point_from_solution`)
    extrapolates to zero from those points (the middle of the bracket while the side has one point).

    Not the middle frequency of the bracket: at a grazing the branch may turn back in omega (a corner: an
    impacting branch that bends away from the non-impacting one), and then both ends lie on one side of it in
    omega, and a solve at the middle frequency lands on either piece.  The sides take turns; a target whose
    solve fails or lands on the other piece is moved half-way back to the side's end (at most 6 times), then the
    other side is tried; ``None`` (end of the bisection) when both fail.  Other types and other records are
    located by interpolation (``None``)."""
    hist = []  # the points returned for the current event, in order

    def same_piece(p, ref):
        return p.impacts == ref.impacts and bool(p.contact_active) == bool(ref.contact_active)

    def locate(kind, a, b):
        if kind != "grazing" or a.impacts is None or b.impacts is None:
            return None
        if not any(h is a or h is b for h in hist):
            hist.clear()  # a new event
        sides = [[a] + [h for h in hist if same_piece(h, a) and h is not a],
                 [b] + [h for h in hist if same_piece(h, b) and h is not b]]
        for side in sides:  # the side's points, nearest (latest) last; the bracket end is the nearest
            # by identity: the records hold arrays, and == between two of them is ambiguous
            side.sort(key=lambda h: next((i for i, g in enumerate(hist) if g is h), -1))
        first = 0 if len(sides[0]) <= len(sides[1]) else 1
        for k in (first, 1 - first):  # the other side when this one's solves fail
            rec = side_point(sides[k], b if k == 0 else a)
            if rec is not None:
                hist.append(rec)
                return rec
        return None

    def side_point(side, other):
        end, prev = side[-1], (side[-2] if len(side) > 1 else None)
        target = bifurcations.extrapolate_grazing(side, other)
        # 0.9 of the way: a target just past the grazing has no orbit of this piece (its solve fails or lands on
        # the other piece), one just short of it does
        target = 0.5 * (end.omega + other.omega) if target is None else end.omega + 0.9 * (target - end.omega)
        for _ in range(6):
            if not target > 0.0:
                return None
            lam = target * tracer.k  # the records' omega is the base frequency of kT-periodic orbits
            problem = tracer.problem(lam)
            starts = [end.x.x]
            if prev is not None and prev.omega != end.omega:  # the secant of the side's two nearest points
                starts.insert(0, end.x.x + (target - end.omega) / (end.omega - prev.omega) * (end.x.x - prev.x.x))
            for x0 in starts:
                res = newton(problem.residual, x0, tol=tol, max_iter=20, scale=problem.residual_scale)
                if res.success:
                    break
            if res.success:
                pt = tracer.point(res.x, lam, res.nit, res.residual_norm)
                if not isinstance(pt, str):
                    rec = bifurcations.point_from_solution(system, pt.solution, x=pt)
                    if same_piece(rec, end):
                        return rec
            target = 0.5 * (target + end.omega)
        return None

    return locate
