"""The driver: builds a method's problem, runs an explicit chain of strategies, assembles and
certifies the :class:`mshbm.PeriodicSolution`.

The chain (each step runs only when the previous ones failed and ``continuation`` is not False):

1. **start** -- with no guess, the start ladder (:func:`mshbm.solvers.starts.solve_from_starts`: linear,
   regularisation, shifted section, clamped, zero, exact orbit, transient, continuation in forcing and
   friction bound; the first start whose solution the certificate accepts wins); with a guess, Newton
   from it (:func:`mshbm.solvers.newton.solve_problem`), followed by the problem's exact path follower
   (:meth:`PeriodicProblem.path_fallback`, HBM/DLFT penalty contact);
2. **homotopy** -- the problem's softened-law stages (:meth:`PeriodicProblem.homotopy`, HBM), each
   solution starting the next;
3. **continuation** -- for the mixed methods with a guess and ``continuation=True`` given explicitly:
   restarts and parameter continuation (:func:`mshbm.solvers.continuation.solve_with_continuation`).

Then: the solution parts, the certificate (:mod:`mshbm.certificate`: ``success`` only if certified)
and the stability analysis (:mod:`mshbm.stability`).  The solvers see the problem only through the
contract of :mod:`mshbm.methods.base`.
"""
from __future__ import annotations

import sys
import time

import numpy as np

from .._blas import blas_threads, check_threads
from .. import stability as _stability
from .. import validate
from ..certificate import apply_certificate, certify
from ..condensation import SingularHarmonicError
from ..errors import ConvergenceError
from ..methods.registry import build_problem
from ..result import PeriodicSolution
from . import newton as newton_
from . import starts
from .continuation import solve_with_continuation
from .newton import solve_problem

__all__ = ["solve", "build_problem"]


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


def solve(system, omega, method="mshbm", **options):
    """:func:`mshbm.solve` (its docstring lists the options): the strategy chain of this module, then
    the stability analysis (not part of ``wall_time``).

    ``max_time`` (s): from now on, no Newton iteration (:func:`mshbm.solvers.newton.time_box`), start of the
    ladder or event-driven simulation (:func:`mshbm.solvers.starts.time_limit`) begins after the deadline; a
    solve stopped by it fails with a message naming the budget."""
    mt = options.get("max_time")
    try:
        deadline = time.perf_counter() + float(mt) if mt is not None and float(mt) > 0 else None
    except (TypeError, ValueError):
        deadline = None  # not a number: the option check of build_problem names it
    with newton_.time_box(deadline), starts.time_limit(deadline):
        sol = _solve_chain(system, omega, method, options)
    if deadline is not None and not sol.success and time.perf_counter() > deadline:
        sol.message = f"{sol.message}; time budget max_time = {float(mt):g} s spent"
    return sol


def _solve_chain(system, omega, method, options):
    stab = _stability.check_option(options.pop("stability", "auto"))
    if method in ("mshbm", "mshbm-intermediate") and options.get("continuation") is True \
            and options.get("guess") is not None:  # guess=None: the start ladder (mshbm.solvers.starts) covers it
        with validate.quiet_floats():
            sol = solve_with_continuation(system, omega, method, solve=solve, stability=False, ladder=False,
                                          **{k: v for k, v in options.items() if k != "continuation"})
        if sol.success or starts.active():
            return _stability.assess(system, sol, stab, theta=options.get("theta", 0.5))
        # the restarts and continuations from the guess failed: the start ladder (the guess first), as without
        # the explicit opt-in
        first = sol
        with blas_threads(check_threads(options.get("blas_threads", 1))), validate.quiet_floats():
            sol = _solve(system, omega, method, {k: v for k, v in options.items() if k != "blas_threads"})
        if not sol.success:
            sol.message = f"{sol.message}; before that, restarts and continuation from the guess: {first.message}"
        else:
            sol.wall_time += first.wall_time
        sol.info["continuation"] = first.info.get("continuation")
        return _stability.assess(system, sol, stab, theta=options.get("theta", 0.5))
    with blas_threads(check_threads(options.pop("blas_threads", 1))), validate.quiet_floats():
        if options.get("guess") is not None and options.get("continuation", True) and not starts.active():
            # fast path: Newton from the caller's guess, certified; only when that fails the start ladder (with the
            # guess as its first rung again)
            t0 = time.perf_counter()
            built = {}  # the problem of the guess's Newton, reused by the ladder below
            sol = _solve(system, omega, method, {k: v for k, v in options.items() if k != "raise_on_failure"},
                         ladder=False, built=built)
            if sol.success:
                sol.info["start_used"] = "guess"
                sol.info["starts"] = [{"start": "guess", "accepted": True, "newton_converged": True,
                                       "residual": float(sol.residual), "iterations": int(sol.iterations),
                                       "extra_iterations": 0, "wall_time_s": float(sol.wall_time), "note": "",
                                       "verdict": "", "message": sol.message}]
                return _stability.assess(system, sol, stab, theta=options.get("theta", 0.5))
            sol = _solve(system, omega, method, options, built=built)
            sol.wall_time = time.perf_counter() - t0
        else:
            sol = _solve(system, omega, method, options)
        return _stability.assess(system, sol, stab, theta=options.get("theta", 0.5))


def _solve(system, omega, method, options, ladder=True, built=None):
    """``built``: a dict shared by the fast path's two calls (the guess alone, then the ladder) of the same
    problem; the first stores ``(problem, solver options)`` there and the second reuses them instead of building
    the problem again (MS-HBM: the condensation's sparse factorisations, ~0.6 s on a 10^4-DOF plate)."""
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
    try:
        x0 = problem.initial_guess(sopts.get("guess"))  # validates a caller's guess (MS-HBM: cached linear start)
        nkw = dict(tol=float(sopts.get("tol", 1e-10)), max_iter=int(sopts.get("max_iter", 50)),
                   line_search=bool(sopts.get("line_search", True)), callback=progress)
        if ladder and sopts.get("continuation", True) and not starts.active():
            # a ladder of starts, the first accepted one wins (mshbm.solvers.starts); a caller's guess is its
            # first rung, so a poor guess falls back to the default starts instead of failing
            accept = _certified_accept(problem, method, omega, sopts, nkw, system)
            res = starts.solve_from_starts(problem, method, system, omega, nkw, accept,
                                           guess=sopts.get("guess"), solve_options=options, solve=solve)
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
            # fallback: continuation from softened laws to the requested ones
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
    sol = _solution(problem, method, res, parts, success, message, wall)
    if notes:
        sol.info["notes"] = notes
    sol.info["residual_history"] = res.history
    if "starts" in res.info:
        sol.info["starts"], sol.info["start_used"] = res.info["starts"], res.info["start_used"]
    step_accuracy = res.info.get("step_accuracy")
    if step_accuracy is not None:
        sol.info["step_accuracy"] = {"ratio": step_accuracy["ratio"], "verdict": step_accuracy["verdict"],
                                     "bound": np.asarray(step_accuracy["bound"], dtype=float)}
    # success only if certified (mshbm.certificate)
    apply_certificate(problem, sol, nkw["tol"], step_accuracy, cert=None if cached is None else cached["cert"])
    if section is not None:
        _unshift(sol, section)
    if not sol.success and sopts.get("raise_on_failure", False):
        raise ConvergenceError(sol.message)
    return sol


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
    sol.q_hat = starts._shift_hat(np.asarray(sol.q_hat), sol.omega, -ts)
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
                            conditioning=problem.conditioning(), time_step=problem.time_step, **parts)


def _solution(problem, method, res, parts, success, message, wall):
    """:func:`assemble` for a Newton result ``res``."""
    return assemble(problem, method, res.x, parts, success=success, message=message, iterations=res.nit,
                    nfev=res.nfev, residual=res.residual_norm, wall_time=wall)


def _certified_accept(problem, method, omega, sopts, nkw, system):
    """Acceptance test of the start ladder (:func:`mshbm.solvers.starts.solve_from_starts`): the ladder's own
    start-independent residual test (:func:`mshbm.solvers.starts.residual_accept`: physical units, no run-away
    orbits, one step's accuracy at impacts) *and* the certificate of the solution it would return."""
    firsts = {}

    def accept(attempt):
        prob = attempt.problem  # the requested problem, or the same with its section moved (Attempt.section)
        if id(prob) not in firsts:
            firsts[id(prob)] = (prob, starts.residual_accept(prob, prob.system, omega, max_iter=nkw["max_iter"]))
        if not firsts[id(prob)][1](attempt):
            return False
        sol = _solution(prob, method, attempt.newton, attempt.parts(), True, "", 0.0)
        cert = certify(prob, sol, nkw["tol"], attempt.step_accuracy)
        if not cert.passed:
            attempt.verdict = f"rejected by the certificate: {cert.describe_failures()}"
        else:  # the driver reuses parts and certificate of the accepted x (same problem, same x)
            accept.accepted = dict(problem=prob, x=np.array(attempt.x, copy=True), parts=attempt.parts(), cert=cert)
        return cert.passed

    accept.accepted = None
    return accept
