"""``mshbm.solve``: one driver, a registry of methods, validated options.

Methods (``method=``):

* ``"shooting"`` -- full shooting, Moreau-Jean (:mod:`mshbm.methods.shooting`);
* ``"hbm"`` -- HBM-AFT with regularised laws (:mod:`mshbm.methods.hbm`);
* ``"mshbm"`` -- MS-HBM, Section 3.2 (:mod:`mshbm.methods.mixed`);
* ``"mshbm-intermediate"`` -- MS-HBM, Section 3.3;
* ``"dlft"`` -- dynamic Lagrangian frequency-time method, set-valued laws (:mod:`mshbm.methods.dlft`).
"""
from __future__ import annotations

import math
import sys
import time

import numpy as np
from ._blas import blas_threads, check_threads
from .solvers import starts

from .certificate import apply_certificate, certify
from . import stability as _stability
from .errors import ConvergenceError, InputError
from .condensation import SingularHarmonicError
from .methods.dlft import DLFTProblem
from .methods.hbm import HBMProblem
from .methods.mixed import IntermediateProblem, MixedProblem
from .solvers.newton import newton
from .result import PeriodicSolution
from .methods.shooting import ShootingProblem
from .system import System
from . import validate

__all__ = ["solve", "build_problem", "residual_omega_derivative", "METHODS", "default_steps"]

_COMMON = {"guess", "tol", "max_iter", "line_search", "progress", "raise_on_failure", "continuation", "stability"}
#: options accepted by each method (besides the common ones)
METHODS = {
    "shooting": {"steps", "theta", "jacobian", "harmonics", "project"},
    "hbm": {"harmonics", "steps", "condense", "partition"},
    "mshbm": {"harmonics", "steps", "theta", "jacobian", "partition", "project"},
    "mshbm-intermediate": {"harmonics", "steps", "theta", "jacobian", "partition", "project"},
    "dlft": {"harmonics", "steps", "condense", "partition", "dlft_penalty"},
}
_PROBLEMS = {"shooting": ShootingProblem, "hbm": HBMProblem, "mshbm": MixedProblem,
             "mshbm-intermediate": IntermediateProblem, "dlft": DLFTProblem}


def default_steps(method, n_h):
    """Default time points per period: 4096 for time-stepping, ``max(512, 16 (2 n_h + 1))`` rounded
    up to a power of two for the AFT of HBM and DLFT."""
    if method in ("hbm", "dlft"):
        return 1 << max(9, math.ceil(math.log2(16 * (2 * n_h + 1))))
    return 4096


def _int_option(key, value, minimum):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise InputError(key, f"must be an integer, got {value!r}")
    if value < minimum:
        raise InputError(key, f"must be >= {minimum}, got {value}")
    return int(value)


def _check_options(method, options):
    if method not in METHODS:
        raise InputError("method", f"unknown method {method!r} (choose from {', '.join(METHODS)})")
    allowed = METHODS[method] | _COMMON
    for key in options:
        if key not in allowed:
            raise InputError(key, f"unknown option for method {method!r} (allowed: {', '.join(sorted(allowed))})")
    opts = dict(options)
    n_h = _int_option("harmonics", opts.get("harmonics", 10 if method == "shooting" else 5), 1)
    if n_h > 2000:
        raise InputError("harmonics", f"{n_h} harmonics is beyond what this solver supports (max 2000)")
    opts["harmonics"] = n_h
    steps = opts.get("steps", default_steps(method, n_h))
    min_steps = max(8, 2 * n_h + 2) if method != "shooting" else 8
    steps = _int_option("steps", steps, min_steps)
    if steps > 1 << 24:
        raise InputError("steps", f"{steps} steps per period is beyond what this solver supports (max 2^24)")
    opts["steps"] = steps
    if "theta" in opts:
        th = opts["theta"]
        if isinstance(th, bool) or not isinstance(th, (int, float)) or not 0.5 <= float(th) <= 1.0:
            raise InputError("theta", f"must be a number in [0.5, 1], got {th!r}")
    if opts.get("jacobian", "exact") not in ("exact", "fd"):
        raise InputError("jacobian", f"must be 'exact' or 'fd', got {opts['jacobian']!r}")
    if "tol" in opts:
        tol = opts["tol"]
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (0 < float(tol) < 1):
            raise InputError("tol", f"must be a number in (0, 1), got {tol!r}")
    for key in ("condense", "project", "line_search", "continuation", "raise_on_failure"):
        if key in opts and not isinstance(opts[key], (bool, np.bool_)):
            raise InputError(key, f"must be true or false, got {opts[key]!r}")
    if "progress" in opts and not (isinstance(opts["progress"], (bool, np.bool_)) or opts["progress"] == "always"):
        raise InputError("progress", f"must be true, false or 'always', got {opts['progress']!r}")
    if "max_iter" in opts:
        opts["max_iter"] = _int_option("max_iter", opts["max_iter"], 0)
    if opts.get("dlft_penalty") is not None:
        ep = opts["dlft_penalty"]
        if isinstance(ep, bool) or not isinstance(ep, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(ep)) or not 0.0 < float(ep) <= 1e100:
            raise InputError("dlft_penalty", f"must be a finite number > 0 (N/m), got {ep!r}")
        opts["dlft_penalty"] = float(ep)
    opts["stability"] = _stability.check_option(opts.get("stability"))
    return opts


def build_problem(system, omega, method="mshbm", **options):
    """Validated problem object of a method (exposes ``residual(x) -> (R, J)`` and the per-row scale
    ``residual_scale(x) -> s`` of Newton's test ``||R / s||_inf <= tol``, :mod:`mshbm.scaling`).

    Returns
    -------
    problem, solver_options : object, dict
        ``solver_options`` are the Newton and driver options not consumed by the problem.
    """
    if not isinstance(system, System):
        raise InputError("system", f"must be an mshbm.System, got {type(system).__name__}")
    if isinstance(omega, bool) or not isinstance(omega, (int, float, np.integer, np.floating)):
        raise InputError("omega", f"must be a number, got {omega!r}")
    if not math.isfinite(float(omega)) or float(omega) <= 0:
        raise InputError("omega", f"must be finite and > 0, got {omega}")
    if not 1e-100 <= float(omega) <= 1e100:
        raise InputError("omega", f"{float(omega):g} rad/s is outside the supported range [1e-100, 1e100] "
                                  "((k omega)^2 and (h theta)^2 would overflow)")
    opts = _check_options(method, options)
    solver_keys = _COMMON
    prob_opts = {k: v for k, v in opts.items() if k not in solver_keys and k in METHODS[method]}
    if method == "hbm":
        prob_opts.pop("theta", None)
    if prob_opts.get("partition") is not None:
        prob_opts["partition"] = validate.check_partition(system, method, prob_opts["partition"])
    validate.check_inputs(system, float(omega), method, opts["harmonics"], opts["steps"], prob_opts.get("partition"))
    problem = _PROBLEMS[method](system, float(omega), **prob_opts)
    return problem, {k: v for k, v in opts.items() if k in solver_keys}


def residual_omega_derivative(system, omega, method, x, rel_step=1e-6, **options):
    """``dR/domega`` of a method's residual at fixed unknowns ``x`` (central differences).

    Together with ``problem.residual(x) -> (R, dR/dx)`` this is what frequency
    continuation needs.  The unknowns keep their meaning when omega changes
    (coefficients, or states at t = 0 with a fixed number of steps per period).

    Parameters
    ----------
    system, omega, method, **options
        As for :func:`solve`.
    x : ndarray, shape (n_x,)
        Unknowns of the method.
    rel_step : float
        Difference step relative to omega; the error is O(rel_step^2).

    Returns
    -------
    ndarray, shape (n_x,)
    """
    d = rel_step * float(omega)
    Rp = build_problem(system, omega + d, method, **options)[0].residual(np.asarray(x, float), jac=False)[0]
    Rm = build_problem(system, omega - d, method, **options)[0].residual(np.asarray(x, float), jac=False)[0]
    return (Rp - Rm) / (2.0 * d)


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
    """Periodic solution of ``system`` under forcing of angular frequency ``omega``.

    Parameters
    ----------
    system : System
    omega : float
        Angular frequency (rad/s) of the forcing; period ``T = 2 pi / omega``.
    method : {"shooting", "hbm", "mshbm", "mshbm-intermediate", "dlft"}
    **options
        ``harmonics`` (n_h, default 5; shooting: harmonics of the reported
        ``q_hat``, default 10), ``steps`` (time steps per period; default 4096,
        HBM: AFT samples, see :func:`default_steps`), ``guess`` (``None``:
        a ladder of starts, the first accepted one wins, :mod:`mshbm.solvers.starts`;
        ``"linear"``: linear response; ``"zero"``; a PeriodicSolution, e.g. at a
        nearby frequency; a dict with ``q_hat``, ``q0``, ``u0``), ``tol``
        (Newton tolerance on the scaled residual ``||R / s||_inf``, rows scaled
        by the problem's ``residual_scale``, :mod:`mshbm.scaling`; default 1e-10), ``max_iter`` (default 50), ``line_search`` (default
        True), ``theta`` (Moreau-Jean, default 0.5), ``jacobian`` (``"exact"`` or
        ``"fd"``), ``partition`` (DOFs of N; for ``mshbm-intermediate`` a pair of
        DOF lists for subsystems 1 and 2), ``condense`` (HBM: eliminate linear
        DOFs exactly, default True), ``project`` (position projection of
        contacts, default True), ``dlft_penalty`` (DLFT: the parameter ``eps`` in N/m of every
        element, default from the condensed dynamic stiffness, :mod:`mshbm.methods.dlft`), ``progress`` (print Newton progress to a
        terminal), ``raise_on_failure`` (raise ConvergenceError instead of
        returning ``success=False``), ``blas_threads`` (BLAS threads during
        the solve, default 1: the dense matrices are small, and one thread keeps
        results bit-identical across machines and parallel jobs from
        oversubscribing the cores; ``None`` leaves the setting alone),
        ``continuation`` (``False``: Newton from the one start; mixed methods with
        a guess: ``True`` opts in to restarts and continuation fallbacks,
        :mod:`mshbm.solvers.continuation`; HBM: when Newton fails,
        follow the exact piecewise-linear solution path of penalty contacts
        (:meth:`mshbm.methods.hbm.HBMProblem.newton_fallback`), else
        retry by continuation from softened regularisations; default True),
        ``stability`` (``"auto"``, default: Floquet multipliers and verdict from the exact
        event-driven flow with saltation terms for systems with at most one element and up to
        :data:`mshbm.stability.MAX_EXACT_DOFS` DOFs, else a labelled estimate or none;
        ``True``: also above that size; ``False``: skip.  Not part of ``wall_time``; see
        :mod:`mshbm.stability`).

    Returns
    -------
    PeriodicSolution
        ``success`` is True only when Newton converged and every gating check of the
        certificate (``solution.certificate``, :mod:`mshbm.certificate`) passed.
        With ``floquet_multipliers``, ``stable``, ``stability_method`` and ``stability_reason``.

    Raises
    ------
    InputError
        Invalid system, frequency or option (names the key).
    """
    stab = _stability.check_option(options.pop("stability", "auto"))
    if method in ("mshbm", "mshbm-intermediate") and options.get("continuation") is True \
            and options.get("guess") is not None:  # guess=None: the start ladder (mshbm.solvers.starts) covers it
        from .solvers.continuation import solve_with_continuation

        with validate.quiet_floats():
            sol = solve_with_continuation(system, omega, method, stability=False,
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
                                           solve_options=options)
        else:
            res = newton(problem.residual, x0, fallback=bool(sopts.get("continuation", True)), **nkw)
        fallback = None
        if not res.success and sopts.get("continuation", True) and hasattr(problem, "homotopy") \
                and "starts" not in res.info:
            # fallback: continuation from softened laws to the requested ones
            x, path = x0, problem.homotopy()
            total_it, total_fev = res.nit, res.nfev
            for sub in path:
                r = newton(sub.residual, x, **nkw)
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
        if not np.all(np.isfinite(parts[key])):
            success, message = False, f"non-finite {key} in the solution ({message})"
    message = validate.overflow_message(success, message, res.residual_norm)
    rc = getattr(getattr(problem, "cond", None), "rcond", None)
    if not success and rc is not None and rc.size and float(rc.min()) < 1e-4:
        k = int(np.argmin(rc))
        message += (f"; note: the condensed block is nearly singular at harmonic k={k} (rcond {rc[k]:.1e}): "
                    "k*omega is at a resonance of the linear subsystem, where the periodic solution may be "
                    "non-unique or unbounded (add damping or move omega)")
    sol = _solution(problem, method, omega, sopts, res, parts, success, message, wall)
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


def _solution(problem, method, omega, sopts, res, parts, success, message, wall):
    """The :class:`PeriodicSolution` of a Newton result ``res`` of ``problem`` (not yet certified)."""
    parts = dict(parts)
    n_h = parts.pop("harmonics")
    sol = PeriodicSolution(method=method, omega=float(omega), harmonics=n_h,
                           steps=int(sopts.get("steps", getattr(problem, "N", None) or len(parts["t"]) - 1)),
                           success=success, message=message, iterations=res.nit, nfev=res.nfev,
                           residual=res.residual_norm, wall_time=wall, x=res.x, **parts)
    sol.steps = len(sol.t) - 1
    return sol


def _certified_accept(problem, method, omega, sopts, nkw, system):
    """Acceptance test of the start ladder (:func:`mshbm.solvers.starts.solve_from_starts`): the ladder's own
    start-independent residual test (:func:`mshbm.solvers.starts.residual_accept`: physical units, no run-away
    orbits, one step's accuracy at impacts) *and* the certificate of the solution it would return."""
    first = starts.residual_accept(problem, system, omega, max_iter=nkw["max_iter"])

    def accept(attempt):
        if not first(attempt):
            return False
        sol = _solution(problem, method, omega, sopts, attempt.newton, attempt.parts(), True, "", 0.0)
        cert = certify(problem, sol, nkw["tol"], attempt.step_accuracy)
        if not cert.passed:
            attempt.verdict = f"rejected by the certificate: {cert.describe_failures()}"
        return cert.passed

    return accept
