"""The fallbacks of the continuation (:mod:`mshbm.solvers.arclength`, its ``_Trace``): step control after a failed
step, natural-parameter steps where the arclength corrector cannot go on (at points accepted at one time step's
accuracy, across gaps of the curve, past a false reversal onto the branch already traced, and where the branch
crawls: :meth:`Fallbacks.crawled`), and the end point at ``lam_end``.  A mixin: the methods use the trace's state
(``points``, ``ds``, ``natural``, ``gap_from``, ``counters``, ...) and its Newton (``newton_fixed``)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .arclength_parts import Failed
from .arclength_kinks import fixed_lam_solve
from .arclength_steps import EXACT_REACH, exact_root

__all__ = ["Fallbacks", "CYCLE_RTOL", "RETRACE_BACK", "RETRACE_RTOL", "CRAWL_POINTS", "CRAWL_STEP", "CRAWL_LAM",
           "STUCK_BACK", "WIDE_JUMP", "JUMP_RTOL", "GAP_HALVINGS"]

#: points of a cycle (:meth:`Fallbacks.cross_cycle`) lie within this (relative to ``lam_scale``) of one ``lam``
CYCLE_RTOL = 1e-5
#: a branch that turned back by more than ``RETRACE_BACK`` (relative to ``lam_scale``) from the farthest point reached
#: and lies within ``RETRACE_RTOL`` (scaled distance, the arclength's norm) of the part traced before it is retracing
#: that part (:meth:`Fallbacks.retraced`)
RETRACE_BACK = 0.01
RETRACE_RTOL = 5e-3
#: a crawl (:meth:`Fallbacks.crawled`): the last ``CRAWL_POINTS`` arclength steps were on average shorter than
#: ``CRAWL_STEP * ds0`` (scaled) and advanced less than ``CRAWL_LAM`` of the range ``|lam_end - lam0|`` in ``lam``
CRAWL_POINTS = 15
CRAWL_STEP = 0.125
CRAWL_LAM = 0.01
#: a corrected point that repeats one of the last ``STUCK_BACK`` points is stuck (:meth:`Fallbacks.stuck`)
STUCK_BACK = 5
#: the first of a gap's wider jumps (:meth:`Fallbacks.wide_jump`), in units of the gap's first natural-parameter step
WIDE_JUMP = 2.0
#: a gap's point that lies farther than this (scaled, relative to the last point's size) from the secant of the
#: branch's last two points may lie on another solution (:meth:`Fallbacks.jumped`)
JUMP_RTOL = 0.1
#: a gap's point off the branch is replaced by Newton from the last point at 1/2, 1/4, ... of the step, this many
#: (:meth:`Fallbacks.nearer_on_branch`)
GAP_HALVINGS = 5


class Fallbacks:
    """Step control after failures, natural-parameter steps and the end point of :class:`~mshbm.solvers.arclength._Trace`."""

    #: the farthest point from which a retrace (:meth:`retraced`) was last bridged
    retrace_from = None
    #: the gap under way was started by :meth:`crawled`
    crawl_gap = False

    def finish_at_end(self, p, q):
        """Solve at ``lam_end`` from the interpolation between points ``p`` and ``q`` that bracket it, else from
        ``q`` and from ``p`` themselves (a Newton at fixed ``lam`` on a nonsmooth residual can stall from one
        guess and converge from another); the first failure is raised when all three fail."""
        lam_end = self.lam_end
        a = (lam_end - p.lam) / (q.lam - p.lam)
        free = self.free_units(q, np.asarray(self.unknown_scale(q.x, q.lam), dtype=float))
        first = None
        for xg in (p.x + a * (q.x - p.x), q.x, p.x):
            try:
                x, it, r, data, st = self.newton_fixed(xg, lam_end, free=free)
                break
            except Failed as exc:
                first = first or exc
        else:
            raise first
        w = np.asarray(self.unknown_scale(x, lam_end), dtype=float)
        pt, _, _ = self.make_point(x, lam_end, it, r, data, q.ds, self.scaled_t(q, w), st)
        return pt

    def retraced(self, w):
        """Whether the last point ``q`` retraces the branch: it lies more than ``RETRACE_BACK`` (times ``lam_scale``)
        behind the farthest point reached towards ``lam_end`` (index ``f``) and within ``RETRACE_RTOL`` (scaled,
        the arclength's norm with the scale ``w``) of the branch traced before ``f``, interpolated in ``lam``.
        A genuine fold leads onto another sheet, whose points differ from the first sheet's at the same ``lam`` by
        far more than ``RETRACE_RTOL`` once ``RETRACE_BACK`` behind the fold; on a residual that is a staircase on a fine scale
        (a time-stepping method's discrete map near a plateau of the response) the tangent's ``lam`` component
        changes sign on the jitter and the corrector then follows the curve already traced, backwards, out of the
        range.  Then the points after ``f`` (and the folds and kinks recorded among them) are dropped, and a gap
        is bridged from ``f`` onwards (:meth:`start_gap`: natural-parameter steps, the pointwise solve where they
        fail, then arclength steps again; recorded as a gap, counter ``retraces``).  Returns True when it did so
        (once per farthest point)."""
        points, direction, lsc = self.points, self.direction, self.lsc
        if len(points) < 4 or self.natural is not None:
            return False
        q = points[-1]
        f = max(range(len(points)), key=lambda i: points[i].lam * direction)
        if f >= len(points) - 1 or f == self.retrace_from \
                or (points[f].lam - q.lam) * direction <= RETRACE_BACK * lsc:
            return False
        best = np.inf
        for a, b in zip(points[:f], points[1:f + 1]):
            if (a.lam - q.lam) * (b.lam - q.lam) > 0 or a.lam == b.lam:
                continue  # this segment of the branch before f does not bracket q's lam
            t = (q.lam - a.lam) / (b.lam - a.lam)
            best = min(best, float(np.linalg.norm((a.x + t * (b.x - a.x) - q.x) / w)))
        if best > RETRACE_RTOL:
            return False
        self.retrace_from = f
        self.counters["retraces"] = self.counters.get("retraces", 0) + 1
        del points[f + 1:]
        self.folds = [fo for fo in self.folds if fo["index"] <= f]
        self.kinks = [k for k in self.kinks if k["index"] <= f]
        # a gap from f onwards, the way the branch went before the false turn
        self.gap_onwards(self.ds0 * lsc * 0.5, f"the arclength steps turned back at lam = {points[f].lam:.6g} onto "
                                               f"the branch already traced (within {best:.2g} of it, scaled): no fold "
                                               "there")
        return True

    def crawled(self):
        """Whether the branch crawls: its last ``CRAWL_POINTS`` points (arclength steps, all after the last gap)
        moved on average less than ``CRAWL_STEP * ds0`` per step (scaled distance, the arclength's norm with the
        scale of the last point) and less than ``CRAWL_LAM`` of the range in ``lam``.  A fold is traced with steps
        of the order of ``ds0`` (the step control grows them on a smooth curve); a corrector that converges only
        partly (a stiff penalty law) or a tangent that misses by one time step's accuracy shortens every step
        instead, and the branch would use up ``max_points`` or the time limit in place.  Then a gap is bridged
        (:meth:`start_gap`'s natural-parameter step onwards, the pointwise solve where Newton fails; twice as wide as
        the last gap when the branch crawls again right after a crawl's gap), recorded as a gap (kink ``"crawl":
        True``, counter ``crawls``): the curve in it is not traced."""
        points, n = self.points, CRAWL_POINTS
        gaps = [k["index"] for k in self.kinks if k.get("gap")]
        if self.natural is not None or not self.natural_fallback or len(points) <= n \
                or (gaps and max(gaps) > len(points) - 1 - n):
            return False
        q, span = points[-1], abs(self.lam_end - self.lam0)
        if abs(q.lam - points[-1 - n].lam) >= CRAWL_LAM * span:
            return False
        w = np.asarray(self.unknown_scale(q.x, q.lam), dtype=float)
        path = sum(float(np.linalg.norm(np.append((b.x - a.x) / w, (b.lam - a.lam) / self.lsc)))
                   for a, b in zip(points[-1 - n:-1], points[-n:]))
        if path >= n * CRAWL_STEP * self.ds0:
            return False
        self.crawl_gap_start(f"the arclength steps crawled at lam = {q.lam:.6g} ({n} points within "
                             f"{abs(q.lam - points[-1 - n].lam):.2g} in lam, {path:.2g} scaled): the curve there "
                             "is not traced")
        return True

    def crawl_gap_start(self, why):
        """Start a crawl's gap at the last point (see :meth:`crawled`), onwards towards ``lam_end``."""
        points, n = self.points, CRAWL_POINTS
        self.counters["crawls"] = self.counters.get("crawls", 0) + 1
        step = 0.5 * self.ds0 * self.lsc
        last = [k for k in self.kinks if k.get("crawl")]
        if last and last[-1]["index"] >= len(points) - 1 - n:  # crawling again right after a crawl's gap: wider
            step = max(step, 2.0 * abs(last[-1]["lam_right"] - last[-1]["lam"]))
        self.gap_onwards(step, why)
        self.crawl_gap = True

    def gap_onwards(self, step, why):
        """A gap from the last point onwards, towards ``lam_end`` (its tangent turned that way where it points
        back): natural-parameter steps of ``step`` (:meth:`start_gap`'s mechanism), the reason ``why``."""
        p = self.points[-1]
        if p.dlam * self.direction < 0:
            self.points[-1] = replace(p, dx=-p.dx, dlam=-p.dlam, orientation=-p.orientation)
        self.natural, self.gap_from, self.natural_reason = step, len(self.points), why

    def stuck(self, back):
        """Where the corrected point repeats one of the last ``STUCK_BACK`` points (index ``back``, see
        :meth:`revisited`): the steps have shrunk to nothing there (not a closed loop of the curve, which comes back
        to a point far behind) and would cycle; a crawl's gap onwards instead (:meth:`crawled`; once per point).
        Returns True when it started one."""
        points = self.points
        if back < len(points) - STUCK_BACK or self.natural is not None or not self.natural_fallback \
                or self.gap_from == len(points):
            return False
        self.crawl_gap_start(f"the arclength steps stuck at lam = {points[-1].lam:.6g} (the corrected point "
                             f"repeated point {back}): the curve there is not traced")
        return True

    def revisited(self, q, w, rtol=1e-6):
        """Index of an earlier point (not one of the last two) that ``q`` repeats to ``rtol`` in the scaled
        unknowns and parameter: the continuation has come round to where it was and would trace the same points
        again (a closed loop, or a step sequence that cycles); ``None`` otherwise.  Exact repetition only: the
        two sides of a fold, or a branch passing near an earlier part, are not taken for it."""
        for i, p in enumerate(self.points[:-2]):
            if abs(q.lam - p.lam) <= rtol * self.lsc and float(np.max(np.abs((q.x - p.x) / w), initial=0.0)) <= rtol:
                return i
        return None

    def natural_step(self, p, w):
        """One natural-parameter step from ``p`` (Newton at fixed ``lam``, the step ``natural`` in ``lam``
        adapted); returns True when the branch ends."""
        direction, lam_end, lsc = self.direction, self.lam_end, self.lsc
        natural = self.natural
        sgn = direction if self.gap_from is None or p.dlam == 0 else float(np.sign(p.dlam))  # a gap: onwards
        lam_n = p.lam + sgn * natural
        if (lam_n - lam_end) * direction > 0 and (p.lam - lam_end) * direction < 0:
            lam_n = lam_end
        try:
            start = p.x if p.track is None else p.track
            x, it, r, data, st = self.newton_fixed(start, lam_n, free=self.free_units(p, w))
            track = None
            if st is not None:
                # accepted at step accuracy: the exact root nearby is the point (its amplitude may differ by several
                # per cent); the next step starts from the stalled iterate, whose staircase passes where the exact
                # roots of the discrete map fold
                exact = exact_root(self, start, x, lam_n, EXACT_REACH, self.free_units(p, w))
                if exact is not None:
                    track = x
                    x, it, r, data, st = exact
            q = None
            if st is not None and self.gap_from is not None:
                # a gap's step (a jump of 0.5 ds0 or more) accepted at step accuracy with no exact root near it: the
                # iterate may be no solution at all (beam-friction-stop-cb, Moreau-Jean MS-HBM: 1.41 mm where every
                # solve from it converges to 0.58 mm); the pointwise solve there, when it finds one, is the point
                q, _ = self.pointwise(p, w, lam_n, sgn, natural)
                if q is not None:
                    self.counters["stall_replaced"] = self.counters.get("stall_replaced", 0) + 1
            if q is None:
                q, _, _ = self.make_point(x, lam_n, it, r, data, natural / lsc, self.scaled_t(p, w), st)
                q.track = track
                q.dx, q.dlam = (x - p.x) / (natural / lsc), sgn * lsc  # secant, not the (useless) tangent
                self.judged(q)
        except Failed as exc:
            self.counters["natural_failures"] = self.counters.get("natural_failures", 0) + 1
            q, why = self.pointwise(p, w, lam_n, sgn, natural)
            if q is None and natural * 0.5 < self.ds_min * lsc and sgn != direction and self.gap_from is not None:
                # a gap behind a fold that Newton cannot pass either: the pointwise solve onwards, as a sweep in the
                # parameter alone would jump there (the gap is recorded; the fold in it is not traced)
                lam_n = p.lam + direction * 0.5 * self.ds0 * lsc
                if (lam_n - lam_end) * direction > 0:
                    lam_n = lam_end
                q, why = self.pointwise(p, w, lam_n, direction, natural)
            if q is None and natural * 0.5 < self.ds_min * lsc and self.gap_from is not None:
                q, lam_w, width = self.wide_jump(p, w, exc, why)
                if q is not None:
                    lam_n, natural = lam_w, width
                else:
                    why += f"; no wider jump onwards up to lam = {lam_end:.6g} found a solution either"
            if q is None:
                self.natural = natural * 0.5
                if self.natural < self.ds_min * lsc:
                    self.message = (f"natural-parameter steps below ds_min at lam = {p.lam:.6g} ({exc}{why}) after "
                                    f"the arclength corrector failed ({self.natural_reason})")
                    return True
                return False
        if self.gap_from is not None and not self.crawl_gap and self.off_secant(p, q, w) > JUMP_RTOL:
            nearer = self.nearer_on_branch(p, w, lam_n, sgn)
            if nearer is not None:
                q, natural = nearer
        jump = self.gap_from is not None and self.jumped(p, q, w)
        self.counters["natural_points"] = self.counters.get("natural_points", 0) + 1
        self.add(q, natural / lsc)
        if self.gap_from is not None:  # a gap bridged: back to arclength steps from the new point
            self.kinks.append({"lam": float(p.lam), "lam_right": float(q.lam), "index": len(self.points) - 1,
                               "gap": True, "reason": self.natural_reason, "crawl": self.crawl_gap, "jump": jump})
            self.crawl_gap = False
            self.counters["gaps"] = self.counters.get("gaps", 0) + 1
            self.natural, self.gap_from, self.ds = None, None, self.ds0
            if (q.lam - lam_end) * direction < 0:
                return False
        if q.lam == lam_end:
            self.success, self.message = True, (
                f"reached lam_end = {lam_end:.6g} in {len(self.points)} points "
                f"({self.counters['natural_points']} by natural-parameter steps after the "
                f"arclength corrector failed: {self.natural_reason})")
            return True
        self.natural = min(natural * 1.5, self.ds_max * lsc)
        return False

    def off_secant(self, p, q, w):
        """How far ``q`` lies off the secant of the branch's last two points (``p`` the last), scaled by ``w`` and
        relative to ``p``'s size (0 with fewer than two points)."""
        if len(self.points) < 2:
            return 0.0
        a = self.points[-2]
        slope = (p.x - a.x) / (p.lam - a.lam) if p.lam != a.lam else np.zeros_like(p.x)
        size = max(float(np.linalg.norm(p.x / w)), 1.0)
        return float(np.linalg.norm((q.x - p.x - (q.lam - p.lam) * slope) / w)) / size

    def nearer_on_branch(self, p, w, lam_n, sgn):
        """Where a gap's point at ``lam_n`` lies off the branch (:meth:`off_secant` above :data:`JUMP_RTOL`: Newton from
        ``p`` or the pointwise solve found another solution): Newton at fixed ``lam`` from ``p`` (and from the method's
        restarts, :func:`mshbm.solvers.arclength_kinks.fixed_lam_solve`) at steps of ``1/2, 1/4, ...``
        (:data:`GAP_HALVINGS` of them) of the way to ``lam_n``, the first point it converges to on the branch (within
        :data:`JUMP_RTOL` of the secant) instead; not for a crawl's gap, which is there to leave a branch that the
        steps cannot follow (shortened, chain2-rel-contact by MS-HBM crawled again up to its 400 points).  A branch whose smooth pieces are short (an impacting
        orbit whose bounce sequence gains or loses an impact every fraction of a per cent in ``lam``) is passed by
        Newton from its own points in short steps where a long step leaves it (beam-stop-cb by event shooting with the
        Zeno closure: the step of 9.4 rad/s from 1087.0 rad/s landed on the orbit without impacts, half of it stays on
        the impacting one; tests/integration/test_sweep_impacting_gap.py).  Returns ``(q, step)`` (``step`` in
        ``lam``) or None (counter ``nearer_points``); where it is None the gap's point is kept and said
        (:meth:`jumped`)."""
        width = abs(lam_n - p.lam)
        for k in range(1, GAP_HALVINGS + 1):
            step = width / 2 ** k
            lam_k = p.lam + sgn * step
            try:
                x, it, r, data, _ = fixed_lam_solve(self, p, w, lam_k)
                q, _, _ = self.make_point(x, lam_k, it, r, data, step / self.lsc, self.scaled_t(p, w), None)
                q.dx, q.dlam = (x - p.x) / (step / self.lsc), sgn * self.lsc  # secant, as a natural step's
                if self.off_secant(p, q, w) > JUMP_RTOL:
                    continue
                self.judged(q)
            except Failed:
                continue
            self.counters["nearer_points"] = self.counters.get("nearer_points", 0) + 1
            return q, step
        return None

    def jumped(self, p, q, w):
        """Whether a gap's point ``q`` (a step onwards from the last point ``p``) lies more than :data:`JUMP_RTOL`
        (scaled, relative to ``p``'s size) off the secant of the branch's last two points; then the gap's reason
        says that it may be another solution and the branch beyond the gap's start is not traced (counter
        ``jumps``; the gap is said, not refused: tests/unit/test_continuation_jump.py)."""
        if len(self.points) < 2:
            return False
        off = self.off_secant(p, q, w)
        if off <= JUMP_RTOL:
            return False
        self.natural_reason += (f"; the gap's point at lam = {q.lam:.6g} lies {off:.2g} (scaled) off the branch's "
                                f"secant: it may be another solution, the branch beyond lam = {p.lam:.6g} untraced")
        self.counters["jumps"] = self.counters.get("jumps", 0) + 1
        return True

    def wide_jump(self, p, w, exc, why):
        """Where a gap's natural-parameter steps onwards failed down to ``ds_min`` (no solution of the method near
        ``p`` beyond it: a stretch where Newton from ``p`` and the pointwise solve both fail): wider jumps onwards,
        ``WIDE_JUMP * 2**k`` times the gap's first step up to ``lam_end``, each by Newton from ``p`` and then the
        pointwise solve, as a sweep in the parameter alone would go on past a stretch without solutions.  The first
        point found ends the gap (recorded with its width; the curve in it is not traced, counter ``wide_jumps``).
        Returns ``(q or None, lam_n, natural)``."""
        direction, lam_end, lsc = self.direction, self.lam_end, self.lsc
        base = 0.5 * self.ds0 * lsc
        width = WIDE_JUMP * base
        while True:
            lam_n = p.lam + direction * width
            if (lam_n - lam_end) * direction > 0:
                lam_n, width = lam_end, abs(lam_end - p.lam)
            q = None
            try:
                x, it, r, data, st = self.newton_fixed(p.x, lam_n, free=self.free_units(p, w))
                q, _, _ = self.make_point(x, lam_n, it, r, data, width / lsc, self.scaled_t(p, w), st)
                q.dx, q.dlam = (x - p.x) / (width / lsc), direction * lsc
                self.judged(q)
            except Failed:
                q, _ = self.pointwise(p, w, lam_n, direction, width)
            if q is not None:
                self.counters["wide_jumps"] = self.counters.get("wide_jumps", 0) + 1
                self.natural_reason += (f"; no solution found from lam = {p.lam:.6g} to within {base:.2g} of it "
                                        f"({exc}{why}): jumped {width:.3g} onwards to lam = {lam_n:.6g}")
                return q, lam_n, width
            if lam_n == lam_end:
                return None, lam_n, width
            width *= 2.0

    def pointwise(self, p, w, lam_n, sgn, natural):
        """Where Newton at fixed ``lam_n`` from ``p`` failed in a natural-parameter step: the point from
        ``solve_at(lam_n, p.x)`` (the method's pointwise solve with its own starts, e.g. an exact path follower of a
        piecewise-linear law), kept when its residual is within ``tol`` and ``accept`` takes it (counter
        ``pointwise_points``).  Only onwards towards ``lam_end``: a pointwise solve knows nothing of the branch, and
        behind a fold (the gap's direction of travel back in ``lam``) it would return to the part already traced.
        Returns ``(q or None, why)``, ``why`` a note for the message when it failed."""
        if self.solve_at is None or self.gap_from is None or sgn != self.direction:
            return None, ""
        try:
            x = self.solve_at(lam_n, p.x)
        except (Failed, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            x = str(exc) or type(exc).__name__
        if x is None or isinstance(x, str):
            self.counters["pointwise_failures"] = self.counters.get("pointwise_failures", 0) + 1
            return None, f"; the pointwise solve at {lam_n:.6g} failed too" + (f": {x}" if x else "")
        x = np.asarray(x, dtype=float)
        R, s_, r, J, g = self.ev(x, lam_n)
        if not r <= self.tol:
            return None, f"; the pointwise solve at {lam_n:.6g} left ||R/s|| = {r:.2e}"
        q, _, _ = self.make_point(x, lam_n, 0, r, (R, s_, J, g), natural / self.lsc, self.scaled_t(p, w), None)
        if q.dlam * sgn < 0:
            q.dx, q.dlam, q.orientation = -q.dx, -q.dlam, -q.orientation
        try:
            self.judged(q)
        except Failed as exc:
            return None, f"; the pointwise solve's point at {lam_n:.6g} was rejected: {exc}"
        self.counters["pointwise_points"] = self.counters.get("pointwise_points", 0) + 1
        return q, ""

    def failed_step(self, p, w, exc):
        """Step control after a failed step: halve ``ds``; below ``ds_min`` natural-parameter steps (at a
        point accepted at step accuracy) or one step at fixed ``lam`` across a kink.  Returns True when the
        branch ends."""
        counters = self.counters
        counters["corrector_failures"] += 1
        fails = counters.setdefault("failures", [])
        if len(fails) < 50:  # the first reasons, for diagnosis
            fails.append({"lam": float(p.lam), "ds": float(self.ds), "reason": str(exc)})
        self.ds *= 0.5
        if self.ds >= self.ds_min:
            return False
        if self.natural_fallback and p.stall is not None:
            # at an orbit accepted at step accuracy the residual is a staircase in (x, lam): its
            # Jacobian and dR/dlam do not predict; step in lam at fixed lam instead (no folds)
            self.natural, self.natural_reason = self.ds0 * self.lsc * 0.5, str(exc)
            return False
        if self.kink_crossing and p.stall is None and self.crossed_from != len(self.points):
            self.crossed_from = len(self.points)
            try:
                q = self.cross_kink(p, w)
            except Failed as exc2:
                self.message = (f"step size below ds_min = {self.ds_min:g} at lam = {p.lam:.6g} ({exc}; a step at "
                                f"fixed lam across a kink failed too: {exc2})")
                return self.start_gap(p, self.message)
            counters["kink_crossings"] = counters.get("kink_crossings", 0) + 1
            self.add(q, self.ds0)
            if q.lam == self.lam_end:
                self.success, self.message = True, f"reached lam_end = {self.lam_end:.6g} in {len(self.points)} points"
                return True
            self.ds = self.ds0
            return False
        self.message = f"step size below ds_min = {self.ds_min:g} at lam = {p.lam:.6g} ({exc})"
        return self.start_gap(p, self.message)

    def cross_cycle(self, back, w):
        """Where the continuation came back to its point ``back`` (it would cycle, ``revisited``): once per point,
        the points of the cycle after it are dropped and a step at fixed ``lam`` across a kink
        (:func:`mshbm.solvers.arclength_kinks.cross_kink`) is taken from it, onwards towards ``lam_end`` (a kink of a
        piecewise-linear residual, e.g. Moreau-Jean's stick-slip map, whose pieces the arclength corrector turns
        back on).  Returns True when it added a point."""
        lam_b = self.points[back].lam
        while back > 0 and abs(self.points[back - 1].lam - lam_b) <= CYCLE_RTOL * self.lsc:
            back -= 1  # the cycle's first point: the run of points at that lam
        p = self.points[back]
        if not self.kink_crossing or p.stall is not None or self.crossed_from == back:
            return False
        self.crossed_from = back
        del self.points[back + 1:]
        # the reversals into the cycle are no folds (records between points index - 1 and index)
        self.folds = [f for f in self.folds if f["index"] < back]
        self.kinks = [k for k in self.kinks if k["index"] < back]
        if p.dlam * self.direction < 0:
            p = replace(p, dx=-p.dx, dlam=-p.dlam, orientation=-p.orientation)
        try:
            q = self.cross_kink(p, w)
        except Failed:
            return False
        self.counters["cycle_crossings"] = self.counters.get("cycle_crossings", 0) + 1
        self.add(q, self.ds0)
        self.ds = self.ds0
        return True

    def start_gap(self, p, why):
        """Where the arclength corrector cannot pass an exactly solved point: one natural-parameter step onwards
        (:meth:`natural_step`, Newton at fixed ``lam`` from ``p``), recorded as a gap of the curve (kink
        ``"gap": True``; a fold inside it is not traced), then arclength steps again.  Returns True when the branch
        ends (no fallback, or a gap already started at this point)."""
        if not self.natural_fallback or self.gap_from == len(self.points):
            return True
        self.natural, self.natural_reason, self.gap_from = self.ds0 * self.lsc * 0.5, why, len(self.points)
        return False
