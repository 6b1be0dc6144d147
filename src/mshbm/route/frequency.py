"""The starts of the start ladder (:mod:`mshbm.route.ladder`) that solve other problems first.

``"forcing"``, ``"friction"`` (:class:`ContinuationStart`)
    natural-parameter continuation in the forcing amplitude / the friction bound
    (:func:`mshbm.route.continuation.solve_with_continuation`), from the side where the linear response is
    exact; its stages are single-start solves of the ladder's route (:meth:`Route.single`);
``"frequency"`` (:class:`FrequencyStart`)
    continuation in the forcing frequency from an anchor ``r omega`` (:data:`FREQUENCY_RATIOS`) where the
    ladder without this start succeeds (a solve of :meth:`Route.anchor`, whose ladders have no
    ``"frequency"`` start): the exact event-driven orbit continued (one element; with the section moved off
    its events when one lies at ``t = 0``), else the method's own branch traced by the route's sweep
    component (:attr:`Route.sweep`).

Notation: ``omega`` the forcing frequency (rad/s), ``omega_a = r omega`` the anchor.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import InputError
from ..solvers import newton as newton_
from .continuation import solve_with_continuation
from .options import NEWTON_KEYS, only, without
from .starts import EXACT_MAX_DOFS, exact_section, metered_exact

__all__ = ["ContinuationStart", "FrequencyStart", "FREQUENCY_RATIOS", "FREQUENCY_EVALUATIONS", "FREQUENCY_FACTOR"]

#: anchor frequencies ``omega * r`` of the ``"frequency"`` start, in the order tried
FREQUENCY_RATIOS = (0.85, 1.18, 0.7, 1.4)

#: work budget of the ``"frequency"`` start (within the ladder's): ``max(FREQUENCY_EVALUATIONS, FREQUENCY_FACTOR x
#: the first attempt's evaluations)`` Newton residual evaluations (:class:`mshbm.solvers.newton.Meter`: the anchors'
#: solves and the branches' correctors included), the same on every machine; it replaces a wall-time box
#: ``max(5 s, 10 x the first attempt's wall time)`` with the same factor.  Calibration (the frequency starts of
#: tests/unit/test_event_fallback.py, test_ladder_fallbacks.py, test_time_budget.py): their evaluations took
#: 0.3-3 ms of CPU each (0.3-3 s for the floor); on a 480-DOF plate with time-stepped node DOFs (certificates of
#: rejected branch points, unmetered, ~13 ms an evaluation) a floor of 10000 ran the start for 131 s where the box
#: had stopped it at 5 s, so the floor is 1000 (13 s there); none of those starts
#: succeeded, and one given no budget at all (a one-mass impact at omega = 1.5, 118 branch points) ended as rejected
FREQUENCY_EVALUATIONS = 1000
FREQUENCY_FACTOR = 10.0

#: exceptions of a nested solve that end one anchor's try, not the start
_SOLVE_ERRORS = (InputError, FloatingPointError, np.linalg.LinAlgError, ValueError)


def _over(ladder, why):
    """The start's (or an enclosing) work budget is spent or the caller's deadline has passed (appended to
    ``why``)."""
    spent = newton_.work_spent()
    if spent is None and ladder.deadline is not None and time.perf_counter() > ladder.deadline:
        spent = "time budget (max_time)"
    if spent is not None:
        why.append(f"{spent} spent")
    return spent is not None


def _nested_options(ladder):
    """The ladder's method options with its Newton options (``tol``, ``max_iter``, ``line_search``)."""
    return {**ladder.options, **only(ladder.nkw, *NEWTON_KEYS)}


class ContinuationStart:
    """Continuation in the forcing amplitude (``"forcing"``) or the friction bound (``"friction"``)."""

    def __init__(self, strategy):
        self.name = strategy

    def run(self, ladder):
        if self.name == "friction" and not any(e.bounded for e in ladder.system.elements):
            return None
        t0 = time.perf_counter()
        opts = _nested_options(ladder)
        try:
            sol = solve_with_continuation(ladder.system, ladder.omega, ladder.method, guess="zero",
                                          solve=ladder.route.single().solve, ladder=False, strategies=(self.name,),
                                          **opts)
        except InputError as exc:
            return ladder.try_(self.name, ladder.problem.initial_guess("linear"), f"skipped: {exc}", 0, t0)
        info = sol.info.get("continuation", {})
        att = info.get("attempts") or [{}]
        note = f"{len(att[-1].get('stages', []))} stages: {att[-1].get('result', '')}"
        x = np.asarray(sol.x, dtype=float)
        if x.shape != (ladder.problem.n_unknowns,) or not np.all(np.isfinite(x)):
            x = ladder.problem.initial_guess("linear")
        return ladder.try_(self.name, x, note, int(info.get("total_iterations", 0)), t0)


class FrequencyStart:
    """Continuation in the forcing frequency from an anchor ``omega_a = r omega`` (``r`` in
    :data:`FREQUENCY_RATIOS`) where the whole ladder (without this start) gives a certified solution: the
    exact event-driven orbit continued to ``omega`` (one element; then as the ``"exact"`` start), else the
    method's own branch (the route's sweep) from the anchor to ``omega``."""

    name = "frequency"

    def run(self, ladder):
        if ladder.route.in_frequency or int(ladder.nkw.get("max_iter", 50)) < 1:
            return None  # (max_iter = 0: no Newton iterations asked for, and a branch needs corrector iterations)
        t0 = time.perf_counter()
        opts = _nested_options(ladder)
        for key, value in ladder.problem.solve_defaults.items():
            # the branch of this problem's equations (the sweep's own defaults may differ)
            opts.setdefault(key, value)
        why = []
        limit = max(FREQUENCY_EVALUATIONS, FREQUENCY_FACTOR * (ladder.first_cost or 0))
        with newton_.work_box(limit, "work budget of the 'frequency' start"):
            return self._anchors(ladder, opts, why, t0)

    def _anchors(self, ladder, opts, why, t0):
        system, omega, method = ladder.system, ladder.omega, ladder.method
        for r in FREQUENCY_RATIOS:
            if _over(ladder, why):
                break
            wa = omega * r
            try:
                sol_a = ladder.route.anchor().solve(system, wa, method, stability=False, **opts)
            except _SOLVE_ERRORS as exc:
                why.append(f"omega_a = {wa:.4g}: {type(exc).__name__}: {exc}"[:160])
                continue
            if not sol_a.success:
                why.append(f"no certified solution at omega_a = {wa:.4g}")
                continue
            att = self._exact_continuation(ladder, sol_a, wa, t0)
            if att is not None and att.accepted:
                return att
            if ladder.route.sweep is None:
                why.append("no continuation driver in the solve route")
                continue
            # the branch's correctors are metered (the start's work budget); the caller's max_time stays wall time
            left = None if ladder.deadline is None else max(1.0, ladder.deadline - time.perf_counter())
            try:
                br = ladder.route.anchor().trace(system, wa, omega, method, guess=sol_a, stability=False, max_time=left,
                                                 **without(opts, "guess", "stability", "max_time"))
            except _SOLVE_ERRORS as exc:
                why.append(f"branch from {wa:.4g}: {type(exc).__name__}: {exc}"[:160])
                continue
            end = br.points[-1] if br.points else None
            if end is None or not math.isclose(end.omega, omega, rel_tol=1e-9):
                why.append(f"branch from {wa:.4g} stopped at omega = {end.omega if end else wa:.4g}: "
                           f"{br.message}"[:200])
                continue
            att = ladder.try_("frequency", ladder.problem.initial_guess(end.solution),
                              f"branch from omega_a = {wa:.4g} ({len(br.points)} points)", 0, t0)
            if att.accepted:
                return att
            why.append(f"branch from {wa:.4g} reached omega, Newton there: {att.verdict or att.newton.message}"[:200])
        return ladder.try_("frequency", ladder.problem.initial_guess("linear"), "; ".join(why) or "no anchor", 0, t0)

    @staticmethod
    def _exact_continuation(ladder, sol_a, wa, t0):
        """Natural-parameter continuation of the exact orbit (:func:`mshbm.methods.exact.exact_periodic`) from
        the anchor solution ``sol_a`` at ``wa`` to ``omega`` (steps doubled after a success, halved after a
        failure, down to 1/64 of the distance); the orbit at ``omega`` then starts Newton as in the ``"exact"``
        start.  ``None`` where the exact solver does not apply or the continuation fails."""
        system, problem, omega = ladder.system, ladder.problem, ladder.omega
        if len(system.elements) != 1 or system.n > EXACT_MAX_DOFS or problem.time_step is None:
            return None
        N = int(problem.steps)
        kw = dict(samples=max(N, 64), harmonics=max(ladder.n_h, 1), blas_threads=None)
        try:
            ex = metered_exact(system, wa, guess=sol_a, **kw)
        except _SOLVE_ERRORS:
            return None
        if not ex.success:
            return None
        lam, step, dist = wa, (omega - wa) / 4.0, omega - wa
        while lam != omega:
            if _over(ladder, []):
                return None
            nxt = omega if abs(omega - lam) <= abs(step) * 1.0000001 else lam + step
            try:
                e2 = metered_exact(system, nxt, guess=ex, **kw)
            except _SOLVE_ERRORS:
                e2 = None
            if e2 is not None and e2.success:
                ex, lam, step = e2, nxt, 2.0 * step if abs(2.0 * step) <= abs(dist) / 2 else step
            else:
                step /= 2.0
                if abs(step) < abs(dist) / 64.0:
                    return None
        gg = {"q_hat": ex.q_hat, "q0": ex.q[0].copy(), "u0": ex.u[0].copy()}
        att = ladder.try_("frequency", problem.initial_guess(gg), f"exact orbit continued from omega_a = {wa:.4g}", 0,
                          t0)
        if att.accepted or ex.q.shape[0] != N + 1:
            return att
        return exact_section(ladder, ex, N, att, t0, start="frequency")
