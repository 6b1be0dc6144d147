"""The start ladder of :func:`mshbm.solve`: several starting points, the first accepted one wins.

Newton's method converges only from a start close enough to a periodic solution, and the nonsmooth
residuals of the time-stepping methods (impacts, stick-slip) make its basin small and ragged.  The
default of :func:`mshbm.solve` (``guess=None``, ``continuation=True``) is therefore not one start but a
ladder of starts, tried in a documented order until one of them gives a result that the caller's
predicate ``accept(attempt) -> bool`` accepts (the certificate of the result;
:func:`residual_accept` is the start-independent residual check of :mod:`mshbm.route.acceptance`).

Notation as in the paper: ``omega`` the forcing frequency (period ``T = 2 pi / omega``), ``n_h``
harmonics, ``h = T / N`` the Moreau-Jean step, ``x`` a method's unknowns and ``R(x)`` its residual.

The starts are objects registered in :data:`STARTS` (name -> start; :mod:`mshbm.route.starts` and
:mod:`mshbm.route.frequency` describe each), tried in the order :data:`DEFAULT_STARTS`:

``"guess"``, ``"linear"``, ``"regularisation"`` (HBM), ``"shifted"`` (time-stepping methods),
``"clamped"``, ``"zero"``, ``"exact"`` (one element), ``"transient"``, ``"forcing"``, ``"friction"``,
``"section"`` (time-stepping methods), ``"frequency"``.

Every start ends in an ordinary Newton solve of the *original* problem (or of the same problem with its
Poincare section moved, ``"section"``), so all accepted results are solutions of the requested
discretisation; the starts only differ in where Newton begins.  The first accepted attempt is returned.
If none is accepted, the attempt with the smallest residual ``||R||_inf`` is returned with
``success=False`` and a message listing the starts tried.

The ladder owns its work budget, a count of Newton residual evaluations (:class:`mshbm.solvers.newton.Meter`, nested
solves included), not wall time: no further start is tried, and no Newton iteration of a start begins, once the
ladder has used ``max(LADDER_EVALUATIONS, LADDER_FACTOR x the first attempt's evaluations)``; the point where it
stops is the same on every machine, whatever its load.  Only the deadline of the route that runs it
(:class:`mshbm.route.driver.Route`, the caller's ``max_time`` in wall seconds) depends on the load.

:meth:`Ladder.run` returns a :class:`mshbm.solvers.newton.NewtonResult`;
``result.info["starts"]`` holds one record per attempt (start, accepted, residual, iterations, wall
time, message) and ``result.info["start_used"]`` the accepted start (``None`` on failure).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..solvers import newton as newton_
from ..solvers.newton import NewtonResult, solve_problem
from .acceptance import ResidualTest
from .frequency import ContinuationStart, FrequencyStart
from .options import DRIVER_KEYS, without
from .starts import (ClampedStart, ExactStart, GuessStart, LinearStart, RegularisationStart, SectionStart,
                     ShiftedStart, TransientStart, ZeroStart, hat_guess)

__all__ = ["Attempt", "Ladder", "residual_accept", "solve_from_starts", "STARTS", "DEFAULT_STARTS",
           "LADDER_EVALUATIONS", "LADDER_FACTOR"]

#: the registered starts, by name
STARTS = {s.name: s for s in (GuessStart(), LinearStart(), RegularisationStart(), ShiftedStart(), ClampedStart(),
                              ZeroStart(), ExactStart(), TransientStart(), ContinuationStart("forcing"),
                              ContinuationStart("friction"), SectionStart(), FrequencyStart())}

#: default order of the starts (those that do not apply to a method or system are skipped)
DEFAULT_STARTS = ("guess", "linear", "regularisation", "shifted", "clamped", "zero", "exact", "transient",
                  "forcing", "friction", "section", "frequency")

#: work budget of the start ladder (Newton residual evaluations, :class:`mshbm.solvers.newton.Meter`): no further
#: start is tried once the ladder has used ``max(LADDER_EVALUATIONS, LADDER_FACTOR x the first attempt's
#: evaluations)``; the failure names the skipped starts.  It replaces a wall-time box ``max(30 s, 30 x the first
#: attempt's wall time)``, with the same factor.  Calibration (tests/unit/test_ladder_fallbacks.py,
#: test_event_fallback.py, test_time_budget.py, the sweeps of tests/integration/test_sweep_accuracy.py): a first
#: attempt's evaluation took 0.07-70 ms of wall time (median 1.5 ms, loaded machine), so the floor is some 20 s of
#: evaluations at the median (30 s at 1 ms); the largest whole ladder measured used 17848 evaluations, none reached
#: the floor
LADDER_EVALUATIONS = 30000
LADDER_FACTOR = 30.0


@dataclass
class Attempt:
    """One start and the Newton solve of the original problem from it (the argument of ``accept``).

    Attributes
    ----------
    start : str
        Name of the start.
    x0 : ndarray, shape (n_x,)
        Unknowns Newton started from (after any continuation or simulation).
    newton : NewtonResult
        Newton's outcome on the original problem; ``newton.x`` are the final unknowns.
    problem : object
        The method's problem (``residual(x) -> (R, J)``, ``solution_parts(x)``).
    note : str
        What the start did (e.g. "180 periods simulated").
    """

    start: str
    x0: np.ndarray
    newton: NewtonResult
    problem: object
    note: str = ""
    wall_time: float = 0.0
    accepted: bool = False
    extra_iterations: int = 0
    verdict: str = ""
    #: set by :func:`residual_accept` when it accepts a stalled Newton on an impacting orbit as periodic to
    #: one time step's accuracy (:class:`mshbm.route.acceptance.Verdict`); the certificate then judges the
    #: residual and the periodicity by that bound
    step_accuracy: dict = None
    #: ``(k, t_s)`` when ``problem`` is the requested one with its Poincare section moved to ``t_s = k h``:
    #: ``x`` is then the state at ``t_s``; ``None`` for the section ``t = 0``
    section: tuple = None
    _parts: dict = field(default=None, repr=False)

    @property
    def x(self):
        return self.newton.x

    def parts(self):
        """``problem.solution_parts(x)`` (cached): time series, ``q_hat``, element forces."""
        if self._parts is None:
            self._parts = self.problem.solution_parts(self.newton.x)
        return self._parts

    def record(self):
        return {"start": self.start, "accepted": bool(self.accepted), "newton_converged": bool(self.newton.success),
                "residual": float(self.newton.residual_norm), "iterations": int(self.newton.nit),
                "extra_iterations": int(self.extra_iterations), "wall_time_s": float(self.wall_time),
                "note": self.note, "verdict": self.verdict, "message": self.newton.message}


def residual_accept(problem, system, omega, rtol=1e-8, step_accuracy=True, max_iter=None, max_size=1e4):
    """Predicate ``accept(attempt) -> bool``: :class:`mshbm.route.acceptance.ResidualTest` on the attempt's
    final unknowns; its verdict and ``step_accuracy`` are written to the attempt."""
    test = ResidualTest(problem, system, omega, rtol=rtol, step_accuracy=step_accuracy, max_iter=max_iter,
                        max_size=max_size)

    def accept(attempt):
        v = test(attempt.x, attempt.newton.success, attempt.newton.nit, parts=attempt.parts)
        if v.verdict:
            attempt.verdict = v.verdict
        if v.step_accuracy is not None:
            attempt.step_accuracy = v.step_accuracy
        return v.accepted

    return accept


class Ladder:
    """One run of the start ladder on ``problem``: the attempts so far, the time budget, the route of its
    nested solves.

    Parameters
    ----------
    problem : PeriodicProblem
        The method's problem (:func:`mshbm.methods.registry.build_problem`).
    method : str
        Name of the method (to build the related problems of the starts).
    system : System
    omega : float
        Forcing frequency (rad/s).
    newton_options : dict
        Keyword arguments of :func:`mshbm.solvers.newton.newton` (``tol``, ``max_iter``, ``line_search``,
        ``callback``); used for every Newton solve.
    accept : callable
        ``accept(attempt: Attempt) -> bool``; the first attempt it accepts is returned.
    route : mshbm.route.driver.Route
        The route of the solve that runs the ladder: its deadline (``max_time``) bounds the ladder, its nested solves
        (continuations, anchors, branches) go through it.
    options : dict
        The method's options as given to :func:`mshbm.solve` (``harmonics``, ``steps``, ``theta``,
        ``partition``...; the driver's own options are dropped here): to build the shifted problem, the
        simulation, the continuations.
    guess : optional
        A user guess (as for :func:`mshbm.solve`), tried first as start ``"guess"``.
    fallback : bool
        Allow Newton the problem's exact path follower (:meth:`PeriodicProblem.path_fallback`, HBM/DLFT).
    transient_periods : sequence of int
        Checkpoints (periods simulated so far) of the ``"transient"`` start.
    transient_budget : float
        Largest ``n^2 x steps x periods`` the ``"transient"`` start simulates (skipped above): a deterministic
        bound of its cost.
    """

    def __init__(self, problem, method, system, omega, newton_options, accept, *, route, options=None, guess=None,
                 fallback=True, transient_periods=(10, 40, 160), transient_budget=2e9):
        self.problem, self.method, self.system, self.omega = problem, method, system, float(omega)
        self.route = route
        self.nkw = dict(newton_options)
        self.accept = accept
        self.options = without(options or {}, *DRIVER_KEYS)
        self.guess = guess
        self.fallback = fallback
        self.transient_periods = tuple(sorted(int(p) for p in transient_periods))
        self.transient_budget = float(transient_budget)
        self.attempts = []
        self.n_h = int(problem.n_h)
        self.deadline = route.deadline  # the caller's wall-clock deadline (max_time; None: none)
        #: the ladder's work meter (:class:`mshbm.solvers.newton.Meter`, set by :meth:`run`): Newton residual
        #: evaluations so far; its limit is set once the first attempt is made
        self.meter = None
        #: the first attempt's Newton residual evaluations (the unit of the ladder's and the starts' budgets)
        self.first_cost = None
        self.section_candidate = None  # the "shifted" start's solution for the "section" start

    # -- the attempts
    def newton(self, x0, problem=None):
        return solve_problem(self.problem if problem is None else problem, x0, fallback=self.fallback, **self.nkw)

    def try_(self, start, x0, note="", extra_iterations=0, t0=None, problem=None, section=None, result=None):
        """Newton from ``x0`` (or the given Newton ``result``) on ``problem`` (default: the requested one; a
        section-shifted one with ``section = (k, t_s)``), judged by ``accept`` and recorded."""
        t0 = time.perf_counter() if t0 is None else t0
        problem = self.problem if problem is None else problem
        res = self.newton(x0, problem) if result is None else result
        att = Attempt(start, np.array(x0, dtype=float), res, problem, note, extra_iterations=extra_iterations,
                      section=section)
        try:
            att.accepted = bool(self.accept(att))
        except (FloatingPointError, np.linalg.LinAlgError, ValueError, OverflowError) as exc:
            att.accepted = False
            att.note = f"{note}; accept() raised {type(exc).__name__}: {exc}".lstrip("; ")
        att.wall_time = time.perf_counter() - t0
        self.attempts.append(att)
        return att

    def keep_one(self, n0):
        """One record per start: of the attempts made since ``n0``, the accepted one, else the one with the
        smallest residual (the others' notes are appended to its note)."""
        mine = self.attempts[n0:]
        if len(mine) <= 1:
            return mine[0] if mine else None
        won = next((a for a in mine if a.accepted), None)
        if won is None:
            fin = [a for a in mine if np.isfinite(a.newton.residual_norm)]
            won = min(fin, key=lambda a: a.newton.residual_norm) if fin else mine[-1]
            others = "; ".join(f"also tried: {a.note}" for a in mine if a is not won and a.note)
            won.note = f"{won.note}; {others}" if others else won.note
        won.extra_iterations += sum(a.newton.nit + a.extra_iterations for a in mine if a is not won)
        del self.attempts[n0:]
        self.attempts.append(won)
        return won

    def best(self):
        """The attempt with the smallest finite ``||R||_inf`` so far, or ``None``."""
        ok = [a for a in self.attempts if np.isfinite(a.newton.residual_norm)]
        return min(ok, key=lambda a: a.newton.residual_norm) if ok else None

    def x_from_hat(self, q_hat):
        """The problem's unknowns from displacement coefficients ``q_hat``, shape (2 n_h + 1, n)."""
        return self.problem.initial_guess(hat_guess(q_hat, self.omega))

    # -- the ladder
    def budget(self):
        """The ladder's own work budget, ``max(LADDER_EVALUATIONS, LADDER_FACTOR x the first attempt's
        evaluations)`` (Newton residual evaluations)."""
        return max(LADDER_EVALUATIONS, LADDER_FACTOR * self.first_cost)

    def over(self):
        """The ladder's starts should stop: its work budget (or an enclosing one) is spent, or the caller's
        deadline has passed."""
        return (self.meter is not None and self.meter.spent() is not None) or (
            self.deadline is not None and time.perf_counter() > self.deadline)

    def run(self, starts=DEFAULT_STARTS):
        """Try ``starts`` (names of :data:`STARTS`) in order until ``accept`` accepts a Newton solution.

        Returns
        -------
        NewtonResult
            ``success`` = some attempt was accepted.  ``x``, ``residual_norm``, ``history`` are those of
            the accepted attempt (on failure: of the attempt with the smallest ``||R||_inf``); ``nit``
            and ``nfev`` count every attempt (continuation stages and simulation checkpoints
            included in ``nit``); ``message`` names the start used, or lists every start tried and
            the best residual; ``info["starts"]`` one record per attempt, ``info["start_used"]``;
            ``info["problem"]`` and ``info["section"]`` when the chosen attempt kept a moved section.
        """
        unknown = [s for s in starts if s not in STARTS]
        if unknown:
            raise InputError("starts", f"unknown start {unknown[0]!r} (choose from {', '.join(DEFAULT_STARTS)})")
        won, skipped = None, []
        by_caller = None  # what stopped the ladder when not its own budget: the caller's deadline or enclosing budget
        with newton_.work_box(None, "work budget of the start ladder") as meter:
            self.meter = meter
            for name in starts:
                if self.attempts:
                    own = meter.limit is not None and meter.used >= meter.limit
                    outer = meter.outer.spent() if meter.outer is not None else None
                    if self.deadline is not None and time.perf_counter() > self.deadline:
                        outer = "the caller's time budget (max_time)"
                    if own or outer:
                        if not skipped and not own:
                            by_caller = outer
                        skipped.append(name)  # the ladder's budget is spent: report, do not try further starts
                        continue
                n0 = len(self.attempts)
                # every Newton solve of this start stops once the ladder's budget is spent (the meter) or at the
                # caller's deadline (newton.time_box), so one start cannot run on far beyond the budget
                with newton_.time_box(self.deadline):
                    att = STARTS[name].run(self)
                if self.attempts and self.first_cost is None:
                    self.first_cost = meter.used
                    meter.limit = self.budget()
                if att is not None:
                    att = self.keep_one(n0)
                if att is not None and att.accepted:
                    won = att
                    break
        return self._result(won, skipped, by_caller)

    def _result(self, won, skipped, by_caller):
        records = [a.record() for a in self.attempts]
        nit = sum(a.newton.nit + a.extra_iterations for a in self.attempts)
        nfev = sum(a.newton.nfev for a in self.attempts)
        if won is not None:
            res = won.newton
            res.success = True
            if won.step_accuracy is not None:
                res.info["step_accuracy"] = dict(won.step_accuracy, verdict=won.verdict)
            more = f" (start '{won.start}'" + (f" after {len(records) - 1} rejected starts: "
                                                 + ", ".join(r["start"] for r in records[:-1]) if len(records) > 1
                                                 else "") + ")"
            res.message = (f"{won.verdict} (Newton: {res.message}){more}" if won.verdict else f"{res.message}{more}")
        else:
            best = self.best() or (self.attempts[-1] if self.attempts else None)
            if best is None:  # pragma: no cover - "linear" always applies
                raise InputError("starts", "no start applies")
            res = best.newton
            res.success = False
            tried = "; ".join(f"{a.start}: " + (a.verdict if a.verdict else ("rejected (" + a.newton.message + ")"
                                                                          if a.newton.success else a.newton.message))
                              for a in self.attempts)
            res.message = (f"no start led to an accepted solution; best ||R||_inf = {best.newton.residual_norm:.2e} "
                           f"from start '{best.start}'; starts tried: {tried}")
        res.nit, res.nfev = nit, nfev
        res.info = dict(res.info or {})
        if skipped and won is None:
            budget = (by_caller if by_caller else
                      f"work budget of the start ladder ({self.meter.limit:.0f} Newton residual evaluations, max("
                      f"{LADDER_EVALUATIONS}, {LADDER_FACTOR:g} x the first attempt's {self.first_cost:.0f}))")
            res.message += f"; {budget} spent, starts not tried: {', '.join(skipped)}"
        res.info["starts"] = records
        res.info["start_used"] = None if won is None else won.start
        chosen = won if won is not None else (self.best() or self.attempts[-1])
        if chosen.section is not None:
            # x is the state at the moved section t_s of chosen.problem (see Attempt.section)
            res.info["problem"], res.info["section"] = chosen.problem, chosen.section
        return res


def solve_from_starts(problem, method, system, omega, newton_options, accept, *, route, guess=None,
                      starts=DEFAULT_STARTS, solve_options=None, fallback=True, transient_periods=(10, 40, 160),
                      transient_budget=2e9):
    """:meth:`Ladder.run` of a new :class:`Ladder` (parameters as there; ``solve_options`` its ``options``)."""
    ladder = Ladder(problem, method, system, omega, newton_options, accept, route=route, options=solve_options,
                    guess=guess, fallback=fallback, transient_periods=transient_periods,
                    transient_budget=transient_budget)
    return ladder.run(starts)
