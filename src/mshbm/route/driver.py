"""The solve route: builds a method's problem, runs an explicit chain of strategies, assembles and
certifies the :class:`mshbm.PeriodicSolution`.

A :class:`Route` carries what a solve inherits from the solve that made it: the deadline (the
``max_time`` budgets of the enclosing solves, wall time), whether it runs inside a start ladder
(nested solves are then Newton from their one start: :meth:`Route.single`) or inside the ``"frequency"``
start (full ladders without that start and without the event-driven fallback: :meth:`Route.anchor`), and
the sweep component that traces branches (:attr:`Route.sweep`, :mod:`mshbm.branch`).  Nested solves go
through a route derived from the caller's; nothing is kept in global state.

The chain (each step runs only when the previous ones failed and ``continuation`` is not False):

1. **start** -- with no guess, the start ladder (:class:`mshbm.route.ladder.Ladder`: linear,
   regularisation, shifted section, clamped, zero, exact orbit, transient, continuation in forcing and
   friction bound, kept section, frequency; a problem's ``preferred_starts`` right after the guess; the first
   start whose solution the certificate accepts wins);
   with a guess, Newton from it (:func:`mshbm.solvers.newton.solve_problem`, with the problem's exact path
   follower :meth:`PeriodicProblem.path_fallback`), then the ladder with the guess as its first start;
2. **homotopy** -- the problem's softened-law stages (:meth:`PeriodicProblem.homotopy`), each solution
   starting the next;
3. **continuation** -- for problems with ``explicit_continuation`` (the mixed methods), a guess and
   ``continuation=True`` given explicitly: restarts and parameter continuation
   (:func:`mshbm.route.continuation.solve_with_continuation`);
4. **event-driven fallback** -- the last step of the start ladder (:func:`_event_fallback`): when a problem
   that ``supports_event_integrator`` with Moreau-Jean steps (by the default rule: ``integrator`` not given)
   found no certified solution of a system with contact (impact) elements, the same solve with the exact
   event-driven integrator (``integrator="event"``), where that integrator applies to the system,
   bounded by the work budget :data:`EVENT_FALLBACK_EVALUATIONS` and the solve's ``max_time``.  Near a grazing or
   near-grazing impact the Moreau-Jean map moves the impact by whole steps and may have no periodic point
   at all (its residual stalls above the one-step bound from every start), while the exact flow has the
   orbit.  A solution found so says so: ``info["integrator"] == "event"``, ``info["event_fallback"]`` and
   its message name the integrator that produced it, and it is certified like any other.

Then: the solution parts, the certificate (:mod:`mshbm.certificate`: ``success`` only if certified)
and the stability analysis (:mod:`mshbm.stability`).  The route sees the problem only through the
contract of :mod:`mshbm.methods.base`.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, replace

import numpy as np

from .._blas import blas_threads, check_threads
from .. import stability as _stability
from .. import validate
from ..certificate import apply_certificate, certify
from ..certificate.verdict import reword_warnings
from ..condensation import SingularHarmonicError
from ..errors import ConvergenceError, InputError
from ..methods.hbm_regularisation import REGULARISATION_BOUND, regularisation_check, regularised
from ..options import check_accuracy
from ..methods.registry import build_problem
from ..result import PeriodicSolution
from ..solvers import newton as newton_
from ..solvers.newton import solve_problem
from ..subharmonic import PERIOD_K_TOL, check_period, period_options, subharmonic_content, subharmonic_system
from ..subharmonic import transient_guess
from ..system import System, tuned
from .continuation import solve_with_continuation
from .ladder import DEFAULT_STARTS, Ladder, residual_accept
from . import refine as _refine
from .options import capabilities, only, without
from .starts import shift_hat

__all__ = ["Route", "build_problem", "assemble", "EVENT_FALLBACK_EVALUATIONS", "EVENT_FALLBACK_STARTS"]

#: work budget of the event-driven fallback of the start ladder (:func:`_event_fallback`): Newton residual evaluations
#: (:class:`mshbm.solvers.newton.Meter`, nested solves included), the event-driven flow's work counted at
#: :data:`mshbm.integrators.event.flow.WORK_PER_EVALUATION` an evaluation (about a millisecond of one core each),
#: after which its ladder tries no start and no Newton iteration, the same on every machine; the solve's
#: ``max_time`` (wall seconds) bounds it too.  It replaces a wall-time box of 10 s.  Calibration (the fallbacks of
#: tests/unit/test_event_fallback.py, test_ladder_fallbacks.py, test_step_accuracy_size.py): the certified ones used
#: at most 6; the failing ones 1381, 7429 (58 DOFs, 2048 steps) and 10320 in 5.7, 27 and 22 s of CPU, 2-4 ms each
#: (a start may overrun the budget by the Newton iterations it began before): 3000 is some 6-12 s of one core
EVENT_FALLBACK_EVALUATIONS = 3000
#: the starts of that fallback's ladder (:mod:`mshbm.route.ladder`), in this order: the failed Moreau-Jean
#: solution first (its orbit is within one time step of the exact one when only the discrete map lacks a periodic
#: point), the exact orbit and the simulated transient next, then the cheap default starts and the
#: continuations, as far as the work budget reaches
EVENT_FALLBACK_STARTS = ("guess", "exact", "transient", "linear", "clamped", "zero", "forcing", "frequency")


def _starts(problem):
    """:data:`DEFAULT_STARTS` with the problem's ``preferred_starts`` moved right after the guess."""
    first = tuple(problem.preferred_starts or ())
    return ("guess",) + first + tuple(s for s in DEFAULT_STARTS if s != "guess" and s not in first)


class _Progress:
    def __init__(self, method, enabled):
        self.enabled = enabled and sys.stderr.isatty() or enabled == "always"
        self.method = method

    def __call__(self, it, x, r):
        if self.enabled:
            print(f"\r[{self.method}] Newton iteration {it:3d}  ||R||_inf = {r:.3e}", end="", file=sys.stderr,
                  flush=True)

    def close(self):
        if self.enabled:
            print(file=sys.stderr)


@dataclass(frozen=True)
class Route:
    """How a solve runs, and what its nested solves inherit (module docstring).

    Attributes
    ----------
    deadline : float or None
        ``time.perf_counter()`` after which no start of a ladder, Newton iteration or event-driven
        simulation begins (the earliest of the enclosing solves' ``max_time``); ``None``: none.  The only
        wall-clock budget of the route, the one result that depends on the machine's load: the internal budgets
        are counts of work (:func:`mshbm.solvers.newton.work_box`, the event-driven flow's ``work_limit``).
    single_start : bool
        Inside a start ladder: a solve is Newton from its one start (the guess), no ladder of its own.
    in_frequency : bool
        Inside the ``"frequency"`` start (its anchor solves and branch): the ladders have no
        ``"frequency"`` start and no event-driven fallback.
    estimate : bool
        :meth:`solve` adds the a-posteriori error estimates and the check ``accuracy``, and refines to a
        requested ``accuracy`` (:mod:`mshbm.route.refine`); False for the solves nested in a solve (starts,
        anchors, the estimates' own re-solves).
    sweep : callable or None
        The branch tracer of the ``"frequency"`` start, ``sweep(route, system, omega_start, omega_end,
        method, **options) -> Branch`` (:mod:`mshbm.branch`); ``None``: that start reports it has none.
    law_estimates : bool
        The certificate estimates the effect of regularised and substituted laws (re-solves with stiffer laws,
        the exact orbits with the model's and the represented restitution); False under ``accuracy=False``
        (nothing reads them: a substituted law is then named, not estimated), for this solve and its nested ones.
    """

    deadline: float | None = None
    single_start: bool = False
    in_frequency: bool = False
    sweep: object = None
    estimate: bool = True
    law_estimates: bool = True

    # -- derived routes
    def tightened(self, deadline):
        """This route with the deadline ``deadline`` when it is earlier (``None``: unchanged)."""
        if deadline is None or (self.deadline is not None and self.deadline <= deadline):
            return self
        return replace(self, deadline=deadline)

    def single(self):
        """The route of the solves made by a start of a ladder (continuation stages): one start each."""
        return replace(self, single_start=True, estimate=False)

    def anchor(self, deadline=None):
        """The route of the ``"frequency"`` start's solves: full ladders without that start, within
        ``deadline`` when given (an earlier deadline than this route's)."""
        return replace(self, single_start=False, in_frequency=True, estimate=False,
                       deadline=self.deadline if deadline is None else deadline)

    # -- the solves
    def trace(self, system, omega_start, omega_end, method, **options):
        """The branch from ``omega_start`` to ``omega_end`` by the route's sweep component, on this route."""
        return self.sweep(self, system, omega_start, omega_end, method, **options)

    def solve(self, system, omega, method="mshbm", **options):
        """:func:`mshbm.solve` (its docstring lists the options): the strategy chain of this module, then
        the stability analysis (not part of ``wall_time``).

        ``max_time`` (s): from now on, no Newton iteration (:func:`mshbm.solvers.newton.time_box`), start of
        the ladder or event-driven simulation begins after the deadline; a solve stopped by it fails with a
        message naming the budget."""
        system = tuned(system, omega)  # the forcing at omega (a constant forcing: the same system)
        mt = options.get("max_time")
        try:
            deadline = time.perf_counter() + float(mt) if mt is not None and float(mt) > 0 else None
        except (TypeError, ValueError):
            deadline = None  # not a number: the option check of build_problem names it
        t0 = time.perf_counter()
        accuracy = check_accuracy(options.pop("accuracy", None))
        stab = _stability.check_option(options.pop("stability", "auto"))
        theta = options.get("theta", 0.5)
        route = self.tightened(deadline)
        if accuracy is False and route.law_estimates:
            route = replace(route, law_estimates=False)
        with newton_.time_box(deadline), newton_.work_box() as meter:
            sol = route._chain(system, omega, method, dict(options))
        sol.info["work"] = float(meter.used)  # Newton residual evaluations, the event flow's work included
        with blas_threads(check_threads(options.pop("blas_threads", 1))), validate.quiet_floats():
            if self.estimate and accuracy is not False:  # the error estimates, and the refinement to a request
                with newton_.time_box(deadline):
                    sol = _refine.estimate_and_refine(route, system, omega, method, options, sol, accuracy, t0)
            elif self.estimate:
                sol.info["accuracy"] = {"accuracy": None, "requested": False, "estimate": None, "passed": None,
                                        "estimates": {}, "skipped": "accuracy=False"}
                sol.message = f"{sol.message}; accuracy not estimated (accuracy=False)"
            if deadline is not None and not sol.success and time.perf_counter() > deadline:
                sol.message = f"{sol.message}; time budget max_time = {float(mt):g} s spent"
            return _stability.assess(system, sol, stab, theta=theta)

    def _chain(self, system, omega, method, options):
        """The strategy chain (module docstring) without the stability analysis."""
        if capabilities(method).explicit_continuation and options.get("continuation") is True \
                and options.get("guess") is not None:  # guess=None: the start ladder covers it
            with validate.quiet_floats():
                sol = solve_with_continuation(system, omega, method, solve=replace(self, estimate=False).solve,
                                              stability=False, ladder=False, **without(options, "continuation"))
            if sol.success or self.single_start:
                return sol
            # the restarts and continuations from the guess failed: the start ladder (the guess first), as without
            # the explicit opt-in
            first = sol
            with blas_threads(check_threads(options.get("blas_threads", 1))), validate.quiet_floats():
                sol = self._solve(system, omega, method, without(options, "blas_threads"))
            if not sol.success:
                sol.message = f"{sol.message}; before that, restarts and continuation from the guess: {first.message}"
            else:
                sol.wall_time += first.wall_time
            sol.info["continuation"] = first.info.get("continuation")
            return sol
        with blas_threads(check_threads(options.pop("blas_threads", 1))), validate.quiet_floats():
            if options.get("guess") is not None and options.get("continuation", True) and not self.single_start:
                return self._guess_first(system, omega, method, options)
            return self._solve(system, omega, method, options)

    def solve_period(self, system, omega, method="mshbm", period=1, transient_periods=150, **options):
        """:func:`mshbm.period.solve`: a ``period * T``-periodic solution (:mod:`mshbm.subharmonic`).

        With ``period=1`` this is :meth:`solve`.  Otherwise the problem is solved on the base frequency
        ``omega / period``; the result's ``omega`` is that base frequency and ``info["period"]``,
        ``info["forcing_omega"]`` record the request.

        Without a ``guess``, when the default start ladder finds no solution or a ``T``-periodic one (the
        period-1 orbit is also ``kT``-periodic: :func:`mshbm.subharmonic.subharmonic_content` below
        :data:`mshbm.subharmonic.PERIOD_K_TOL`), Newton is restarted from the state after a Moreau-Jean
        simulation from rest over ``transient_periods`` periods ``kT``
        (:func:`mshbm.subharmonic.transient_guess`), and that result is kept when it is certified and has
        ``kT`` content.  ``info["period_k_content"]`` reports that content.
        """
        k = check_period(period)
        if k == 1:
            return self.solve(system, omega, method, **options)
        if isinstance(omega, bool) or not isinstance(omega, (int, float, np.integer, np.floating)):
            raise InputError("omega", f"must be a number, got {omega!r}")
        if not isinstance(system, System):
            raise InputError("system", f"must be an mshbm.System, got {type(system).__name__}")
        sys_k, w_b, opts = subharmonic_system(system, k), float(omega) / k, period_options(method, k, options)
        sol = self.solve(sys_k, w_b, method, **opts)
        if options.get("guess") is None and (not sol.success or subharmonic_content(sol, k) < PERIOD_K_TOL):
            # the default start found no solution or a T-periodic one: start from an attracting kT orbit instead
            for how, guess in self._kt_starts(sys_k, w_b, method, opts, k, transient_periods):
                alt = self.solve(sys_k, w_b, method, **{**opts, "guess": guess})
                if alt.success and subharmonic_content(alt, k) >= PERIOD_K_TOL:
                    alt.message += f" (start: {how})"
                    sol = alt
                    break
        sol.info["period"] = k
        sol.info["period_k_content"] = subharmonic_content(sol, k)
        sol.info["forcing_omega"] = float(omega)
        return sol

    def _kt_starts(self, sys_k, w_b, method, opts, k, periods):
        """Starts towards an attracting kT orbit: the state after a transient from rest, then (for the other
        methods) the full shooting solution from its default ladder (whose ``"transient"`` start finds
        attracting orbits)."""
        guess = transient_guess(sys_k, w_b, opts, periods=periods)
        if guess is not None:
            yield f"a Moreau-Jean transient of {periods} x {k}T from rest", guess
        if not capabilities(method).full_shooting:
            sh = self.solve(sys_k, w_b, "shooting", stability=False, **only(opts, "steps", "theta", "tol", "max_iter"))
            if sh.success and subharmonic_content(sh, k) >= PERIOD_K_TOL:
                yield "the kT shooting solution of the default start ladder", sh

    def _guess_first(self, system, omega, method, options):
        """Fast path: Newton from the caller's guess, certified; only when that fails the start ladder (with
        the guess as its first start again), on the same problem."""
        t0 = time.perf_counter()
        built = {}  # the problem of the guess's Newton, reused by the ladder below
        sol = self._solve(system, omega, method, without(options, "raise_on_failure"), ladder=False, built=built)
        if sol.success:
            sol.info["start_used"] = "guess"
            sol.info["starts"] = [{"start": "guess", "accepted": True, "newton_converged": True,
                                   "residual": float(sol.residual), "iterations": int(sol.iterations),
                                   "extra_iterations": 0, "wall_time_s": float(sol.wall_time), "note": "",
                                   "verdict": "", "message": sol.message}]
            return sol
        sol = self._solve(system, omega, method, options, built=built)
        sol.wall_time = time.perf_counter() - t0
        return sol

    def _solve(self, system, omega, method, options, ladder=True, built=None, ladder_starts=None):
        """``built``: a dict shared by the fast path's two calls (the guess alone, then the ladder) of the same
        problem; the first stores ``(problem, solver options)`` there and the second reuses them instead of building
        the problem again (MS-HBM: the condensation's sparse factorisations).
        ``ladder_starts``: the starts of the ladder (default :data:`mshbm.route.ladder.DEFAULT_STARTS`).  When the
        ladder ran and found no certified solution, :func:`_event_fallback` (the ladder's last step)."""
        t0 = time.perf_counter()  # wall time includes set-up (condensation, factorisations)
        if built is not None and "problem" in built:
            problem, sopts = built["problem"]
            sopts = dict(sopts)  # the calls differ only in raise_on_failure (kept out of the first)
            if "raise_on_failure" in options:
                sopts["raise_on_failure"] = options["raise_on_failure"]
        else:
            try:
                problem, sopts = build_problem(system, omega, method, **options)
            except SingularHarmonicError as exc:
                raise validate.singular_harmonic_error(exc) from None
            if built is not None:
                built["problem"] = (problem, dict(sopts))
        progress = _Progress(method, sopts.get("progress", False))
        accept = None
        laddered = False
        try:
            x0 = problem.initial_guess(sopts.get("guess"))  # validates a caller's guess (MS-HBM: cached linear start)
            nkw = dict(tol=float(sopts.get("tol", 1e-10)), max_iter=int(sopts.get("max_iter", 50)),
                       line_search=bool(sopts.get("line_search", True)), callback=progress)
            if ladder and sopts.get("continuation", True) and not self.single_start:
                # a ladder of starts, the first accepted one wins (mshbm.route.ladder); a caller's guess is its
                # first start, so a poor guess falls back to the default starts instead of failing
                accept = _certified_accept(problem, method, omega, sopts, nkw, system, self.law_estimates)
                laddered = True
                res = Ladder(problem, method, system, omega, nkw, accept, route=self, options=options,
                             guess=sopts.get("guess")).run(_starts(problem) if ladder_starts is None else ladder_starts)
            else:
                res = solve_problem(problem, x0, fallback=bool(sopts.get("continuation", True)), **nkw)
            section = res.info.get("section")
            if section is not None:
                # the accepted start kept the Poincare section at t_s = k h (an impact near t = 0): its problem is
                # certified as solved, the solution is reported in the original time (_unshift)
                problem = res.info.pop("problem")
            path = problem.homotopy() if not res.success and sopts.get("continuation", True) \
                and "starts" not in res.info else []
            if path:
                res = _homotopy(res, path, x0, nkw)
            # the accepted start's solution parts and certificate, when they are of this problem and x
            cached = getattr(accept, "accepted", None)
            if cached is not None and not (cached["problem"] is problem and np.array_equal(cached["x"], res.x)):
                cached = None
            parts = cached["parts"] if cached is not None else problem.solution_parts(res.x)
        except SingularHarmonicError as exc:
            raise validate.singular_harmonic_error(exc) from None
        finally:
            progress.close()
        wall = time.perf_counter() - t0
        success, message, notes = _outcome(problem, res, parts)
        sol = _solution(problem, method, res, parts, success, message, wall)
        if notes:
            sol.info["notes"] = notes
        sol.info["residual_history"] = res.history
        if "starts" in res.info:
            sol.info["starts"], sol.info["start_used"] = res.info["starts"], res.info["start_used"]
        step_accuracy = res.info.get("step_accuracy")
        if step_accuracy is not None:
            sol.info["step_accuracy"] = {"ratio": step_accuracy["ratio"], "verdict": step_accuracy["verdict"],
                                         "bound": np.asarray(step_accuracy["bound"], dtype=float),
                                         "step_change": step_accuracy.get("step_change")}
        # success only if certified (mshbm.certificate)
        apply_certificate(problem, sol, nkw["tol"], step_accuracy, cert=None if cached is None else cached["cert"],
                          substitution="estimate" if self.law_estimates else "name")
        if sol.success and problem.penalty_laws and regularised(problem.system) and not self.single_start \
                and not self.in_frequency and self.law_estimates:
            # the error of the regularised laws (HBM): one re-solve with stiffer laws (not gating; not for the
            # nested solves of a start ladder, whose answers are starts)
            warned = sol.certificate.describe_warnings()
            check = regularisation_check(problem, sol, nkw, REGULARISATION_BOUND)
            if not check.passed and check.value is not None:  # the message's warnings, now with this estimate
                reword_warnings(sol, warned)
        if section is not None:
            _unshift(sol, section)
        if laddered and not sol.success:
            sol = self._event_fallback(system, omega, method, options, sol, t0)
        if not sol.success and sopts.get("raise_on_failure", False):
            raise ConvergenceError(sol.message)
        return sol

    def _event_fallback(self, system, omega, method, options, failed, t0):
        """The last step of the start ladder: the solve again with the exact event-driven integrator.

        Applies when the problem ``supports_event_integrator`` (integrates the period) with Moreau-Jean steps by the default
        rule (``integrator`` not given; ``integrator="moreau"`` given explicitly keeps Moreau-Jean, and the message
        says the fallback was not tried), the system has a contact element (impacts), the event-driven flow
        can integrate the system (else :class:`InputError` from building its problem: relative or elastic elements,
        too many DOFs or sub-steps; the message of ``failed`` then says why it did not apply), and the solve's
        deadline (``max_time``) leaves time, ``max_iter`` is not 0 (as for the ``"frequency"`` start: no Newton
        iterations asked for), and the failure is not the certificate's ``undamped_resonance`` (a linear
        structure at resonance has no periodic solution with any integrator).  It runs the ladder
        :data:`EVENT_FALLBACK_STARTS` on the event-driven
        problem (the failed Moreau-Jean solution first), within :data:`EVENT_FALLBACK_EVALUATIONS`.

        Parameters
        ----------
        failed : PeriodicSolution
            The certified-failed result of the Moreau-Jean ladder (``success=False``).
        t0 : float
            ``time.perf_counter()`` at the start of the Moreau-Jean solve (``wall_time`` counts both).

        Returns
        -------
        PeriodicSolution
            The event-driven solution when it is certified: ``info["integrator"] = "event"``,
            ``info["event_fallback"]`` (the Moreau-Jean attempt's message, residual and starts) and a message naming
            the integrator; else ``failed``, its message extended by why the fallback did not apply or failed.
        """
        if not capabilities(method).supports_event_integrator or not any(el.unilateral for el in system.elements) \
                or self.in_frequency:
            return failed  # (the anchor solves of the "frequency" start: the outer ladder ends with this fallback)
        if options.get("integrator") is not None:  # asked for explicitly: that integrator only
            if options["integrator"] == "moreau":
                return _declined(failed, {"applied": False, "reason": "integrator='moreau' given explicitly"},
                                 "was not tried (integrator='moreau' given explicitly; leave it out to allow the fallback)")
            return failed
        if int(options.get("max_iter", 50)) < 1:  # no Newton iterations asked for: the starts as given, judged
            return _declined(failed, {"applied": False, "reason": "max_iter = 0"})
        cert = getattr(failed, "certificate", None)
        if cert is not None and "undamped_resonance" in cert.failed:
            # no element acts and a forced harmonic sits on an undamped natural frequency: the linear structure has no
            # periodic solution, whatever the integrator
            return _declined(failed, {"applied": False, "reason": "undamped resonance of the linear structure"})
        now = time.perf_counter()
        outer = [d for d in (newton_.deadline(), self.deadline) if d is not None]
        if outer and min(outer) - now <= 0.0:
            return _declined(failed, {"applied": False, "reason": "time budget spent"},
                             "was not tried (time budget spent)")
        spent = newton_.work_spent()
        if spent is not None:
            return _declined(failed, {"applied": False, "reason": f"{spent} spent"}, f"was not tried ({spent} spent)")
        opts = without(options, "guess", "raise_on_failure", "integrator")
        opts["integrator"] = "event"
        guess = failed if np.all(np.isfinite(failed.x)) and np.all(np.isfinite(failed.q_hat)) else None
        record = {"applied": True, "moreau_message": failed.message, "moreau_residual": float(failed.residual),
                  "moreau_starts": failed.info.get("starts"), "work_budget": EVENT_FALLBACK_EVALUATIONS}
        try:
            with newton_.work_box(EVENT_FALLBACK_EVALUATIONS, "work budget of the event-driven fallback") as meter:
                ev = self._solve(system, omega, method, dict(opts, guess=guess), ladder_starts=EVENT_FALLBACK_STARTS)
        except InputError as exc:  # the event-driven flow does not apply to this system
            return _declined(failed, {"applied": False, "reason": str(exc)}, f"does not apply here ({exc})")
        except (FloatingPointError, np.linalg.LinAlgError, ValueError, OverflowError) as exc:
            return _declined(failed, dict(record, success=False, message=f"{type(exc).__name__}: {exc}"),
                             f"(integrator='event') failed too: {type(exc).__name__}: {exc}")
        record.update(success=bool(ev.success), message=ev.message, wall_time_s=float(ev.wall_time),
                      evaluations=int(meter.used))
        if not ev.success:
            spent = " (its work budget spent)" if meter.spent() is not None else ""
            return _declined(failed, record, f"(integrator='event') failed too{spent}: {ev.message}")
        summary = ev.info.get("event_integrator") or {}
        mixed = summary.get("switched_to_moreau")
        how = ("the exact event-driven integrator (integrator='event'" + (
            ", with Moreau-Jean steps over the accumulation of impacts it reports in info['event_integrator'])"
            if mixed else ")"))
        frm = " from the best Moreau-Jean attempt" if ev.info.get("start_used") == "guess" else ""
        ev.message = (f"{ev.message}; solved with {how}{frm}, after the Moreau-Jean steps (integrator='moreau') found "
                      f"no certified solution (best ||R||_inf = {failed.residual:.2e})")
        ev.info["integrator"] = "event"
        ev.info["event_fallback"] = record
        ev.wall_time = time.perf_counter() - t0
        return ev


def _homotopy(res, path, x0, nkw):
    """The fallback of a failed Newton: continuation from the problem's softened laws (``path``, ending with
    the requested problem) from ``x0``, each stage's solution starting the next; the Newton result of the
    last stage on success, else ``res`` with a message saying so (iterations of every stage counted)."""
    x = x0
    total_it, total_fev = res.nit, res.nfev
    for sub in path:
        r = solve_problem(sub, x, **nkw)
        total_it, total_fev = total_it + r.nit, total_fev + r.nfev
        if not r.success:
            break
        x = r.x
    fallback = f"regularisation continuation over {len(path)} stages"
    if r.success:
        res = r
        res.message = f"{r.message} (after {fallback})"
    else:
        res.message = f"{res.message}; {fallback} failed too: {r.message}"
    res.nit, res.nfev = total_it, total_fev
    return res


def _outcome(problem, res, parts):
    """``(success, message, notes)`` of the Newton result ``res`` with its solution ``parts``: not a success
    when a part is not finite or the method could not form the solution; the message notes an overflow, a
    nearly singular condensed block (a resonance of the linear subsystem) and the problem's ``notes``."""
    success, message = res.success, res.message
    for key in ("q_time", "u_time", "q_hat", "lam"):
        if parts[key].size and not np.isfinite(parts[key]).all():  # (HBM: empty q_time, u_time)
            success, message = False, f"non-finite {key} in the solution ({message})"
    failure = (parts.get("info") or {}).get("failure")
    if failure:  # the method could not form the solution at its converged unknowns
        success, message = False, f"{failure} ({message})"
    message = validate.overflow_message(success, message, res.residual_norm)
    rc = problem.conditioning()
    # a block far worse conditioned than the static one (k = 0, no resonance there): finite-element blocks
    # have tiny pivot ratios at every harmonic, which is no resonance
    if not success and rc is not None and rc.size > 1 and float(rc[1:].min()) < 1e-4 * float(rc[0]):
        k = 1 + int(np.argmin(rc[1:]))
        message += (f"; note: the condensed block is nearly singular at harmonic k={k} (rcond {rc[k]:.1e}): "
                    "k*omega is at a resonance of the linear subsystem, where the periodic solution may be "
                    "non-unique or unbounded (add damping or move omega)")
    notes = list(problem.notes)
    if notes:
        message = f"{message}; note: {'; '.join(notes)}"
    return success, message, notes


def _declined(failed, record, note=None):
    """``failed`` with ``info["event_fallback"] = record`` and, with ``note``, its message extended by "the
    exact event-driven integrator <note>" (:func:`_event_fallback`)."""
    failed.info["event_fallback"] = record
    if note:
        failed.message += f"; the exact event-driven integrator {note}"
    return failed


def _unshift(sol, section):
    """Report a solution computed with the Poincare section at ``t_s = k h`` in the original time, in place.

    The problem with the moved section integrates ``q_s(t) = q(t + t_s)`` on the same grid, so the orbit is the
    same discrete trajectory: the time series are rotated by ``k`` steps (``q(t_j) = q_s(t_{j-k})``, indices
    modulo ``N``; the end-of-period mismatch of a orbit periodic to one step's accuracy then sits at ``t_s``,
    where the certificate measured it) and the coefficients are delayed by ``t_s``.  ``x`` stays the state at
    ``t_s``; ``info["section"]`` records ``k`` and ``t_s``.
    """
    k, ts = int(section[0]), float(section[1])
    N = sol.t.size - 1
    idx = np.r_[np.arange(N - k, N), np.arange(0, N - k + 1)]
    sol.q_hat = shift_hat(np.asarray(sol.q_hat), sol.omega, -ts)
    sol.q_time, sol.u_time = sol.q_time[idx], sol.u_time[idx]
    if sol.lam is not None and sol.lam.shape[0] == N + 1:
        sol.lam = sol.lam[idx]
    if sol.impulses is not None and sol.impulses.shape[0] == N:
        sol.impulses = sol.impulses[(np.arange(N) - k) % N]
    sol.info["section"] = {"steps": k, "time": ts,
                           "note": f"solved with the Poincare section at t_s = {k}/{N} T (an impact near t = 0 makes "
                                   "the state there ambiguous to one step); x is the state at t_s, the time series "
                                   "and q_hat are in the original time"}


def assemble(problem, method, x, parts, *, success, message, iterations, nfev, residual, wall_time):
    """The :class:`PeriodicSolution` at unknowns ``x`` of ``problem`` (``parts``: its
    ``solution_parts(x)``), not yet certified; the one place a solution is built from a problem
    (the driver here, the continuation's points in :mod:`mshbm.branch`)."""
    parts = dict(parts)
    n_h = parts.pop("harmonics")
    return PeriodicSolution(method=method, omega=float(problem.omega), harmonics=n_h, steps=len(parts["t"]) - 1,
                            success=success, message=message, iterations=iterations, nfev=nfev, residual=residual,
                            wall_time=wall_time, x=x, partition=problem.partition(),
                            conditioning=problem.conditioning(), time_step=problem.time_step,
                            base=problem.system.base, **parts)


def _solution(problem, method, res, parts, success, message, wall):
    """:func:`assemble` for a Newton result ``res``."""
    return assemble(problem, method, res.x, parts, success=success, message=message, iterations=res.nit,
                    nfev=res.nfev, residual=res.residual_norm, wall_time=wall)


def _certified_accept(problem, method, omega, sopts, nkw, system, law_estimates=True):
    """Acceptance test of the start ladder (:class:`mshbm.route.ladder.Ladder`): the ladder's own
    start-independent residual test (:func:`mshbm.route.ladder.residual_accept`: physical units, no run-away
    orbits, one step's accuracy at impacts) *and* the certificate of the solution it would return."""
    firsts = {}

    def accept(attempt):
        prob = attempt.problem  # the requested problem, or the same with its section moved (Attempt.section)
        if id(prob) not in firsts:
            firsts[id(prob)] = (prob, residual_accept(prob, prob.system, omega, max_iter=nkw["max_iter"]))
        if not firsts[id(prob)][1](attempt):
            return False
        sol = _solution(prob, method, attempt.newton, attempt.parts(), True, "", 0.0)
        cert = certify(prob, sol, nkw["tol"], attempt.step_accuracy,
                       substitution="estimate" if law_estimates else "name")
        if not cert.passed:
            attempt.verdict = f"rejected by the certificate: {cert.describe_failures()}"
        else:  # the driver reuses parts and certificate of the accepted x (same problem, same x)
            accept.accepted = dict(problem=prob, x=np.array(attempt.x, copy=True), parts=attempt.parts(), cert=cert)
        return cert.passed

    accept.accepted = None
    return accept
