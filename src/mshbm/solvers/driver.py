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
    the stability analysis (not part of ``wall_time``)."""
    stab = _stability.check_option(options.pop("stability", "auto"))
    if method in ("mshbm", "mshbm-intermediate") and options.get("continuation") is True \
            and options.get("guess") is not None:  # guess=None: the start ladder (mshbm.solvers.starts) covers it
        with validate.quiet_floats():
            sol = solve_with_continuation(system, omega, method, solve=solve, stability=False,
                                          **{k: v for k, v in options.items() if k != "continuation"})
            return _stability.assess(system, sol, stab, theta=options.get("theta", 0.5))
    with blas_threads(check_threads(options.pop("blas_threads", 1))), validate.quiet_floats():
        sol = _solve(system, omega, method, options)
        return _stability.assess(system, sol, stab, theta=options.get("theta", 0.5))


def _solve(system, omega, method, options):
    t0 = time.perf_counter()  # wall time includes set-up (condensation, factorisations)
    try:
        problem, sopts = build_problem(system, omega, method, **options)
    except SingularHarmonicError as exc:
        raise validate.singular_harmonic_error(exc) from None
    progress = _Progress(method, sopts.get("progress", False))
    try:
        x0 = problem.initial_guess(sopts.get("guess"))
        nkw = dict(tol=float(sopts.get("tol", 1e-10)), max_iter=int(sopts.get("max_iter", 50)),
                   line_search=bool(sopts.get("line_search", True)), callback=progress)
        if sopts.get("guess") is None and sopts.get("continuation", True) and not starts.active():
            # default start: a ladder of starts, the first accepted one wins (mshbm.solvers.starts)
            res = starts.solve_from_starts(problem, method, system, omega, nkw,
                                           _certified_accept(problem, method, omega, sopts, nkw, system),
                                           solve_options=options, solve=solve)
        else:
            res = solve_problem(problem, x0, fallback=bool(sopts.get("continuation", True)), **nkw)
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
        parts = problem.solution_parts(res.x)
    except SingularHarmonicError as exc:
        raise validate.singular_harmonic_error(exc) from None
    finally:
        progress.close()
    wall = time.perf_counter() - t0
    success, message = res.success, res.message
    for key in ("q_time", "u_time", "q_hat", "lam"):
        if not np.isfinite(parts[key]).all():
            success, message = False, f"non-finite {key} in the solution ({message})"
    message = validate.overflow_message(success, message, res.residual_norm)
    rc = problem.conditioning()
    # a block far worse conditioned than the static one (k = 0, no resonance there): finite-element blocks
    # have tiny pivot ratios at every harmonic, which is no resonance
    if not success and rc is not None and rc.size > 1 and float(rc[1:].min()) < 1e-4 * float(rc[0]):
        k = 1 + int(np.argmin(rc[1:]))
        message += (f"; note: the condensed block is nearly singular at harmonic k={k} (rcond {rc[k]:.1e}): "
                    "k*omega is at a resonance of the linear subsystem, where the periodic solution may be "
                    "non-unique or unbounded (add damping or move omega)")
    sol = _solution(problem, method, res, parts, success, message, wall)
    sol.info["residual_history"] = res.history
    if "starts" in res.info:
        sol.info["starts"], sol.info["start_used"] = res.info["starts"], res.info["start_used"]
    step_accuracy = res.info.get("step_accuracy")
    if step_accuracy is not None:
        sol.info["step_accuracy"] = {"ratio": step_accuracy["ratio"], "verdict": step_accuracy["verdict"],
                                     "bound": np.asarray(step_accuracy["bound"], dtype=float)}
    # success only if certified (mshbm.certificate)
    apply_certificate(problem, sol, nkw["tol"], step_accuracy)
    if not sol.success and sopts.get("raise_on_failure", False):
        raise ConvergenceError(sol.message)
    return sol


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
    first = starts.residual_accept(problem, system, omega, max_iter=nkw["max_iter"])

    def accept(attempt):
        if not first(attempt):
            return False
        sol = _solution(problem, method, attempt.newton, attempt.parts(), True, "", 0.0)
        cert = certify(problem, sol, nkw["tol"], attempt.step_accuracy)
        if not cert.passed:
            attempt.verdict = f"rejected by the certificate: {cert.describe_failures()}"
        return cert.passed

    return accept
