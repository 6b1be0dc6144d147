"""Frequency-response curves: ``mshbm.sweep`` traces a branch of periodic solutions.

``sweep(system, omega_start, omega_end, method="mshbm", period=1, **options) -> Branch``

1. The first point is :func:`mshbm.solve` at ``omega_start`` from its default start (the start
   ladder, :mod:`mshbm.route.ladder`), or from ``guess``.
2. The branch is continued in ``omega`` by pseudo-arclength continuation
   (:func:`mshbm.solvers.arclength.continuation`) on the method's residual ``R(x, omega)``
   (:func:`mshbm.build_problem`) with its Jacobian and ``dR/domega``
   (:meth:`PeriodicProblem.omega_derivative`), in the scaled units of :func:`mshbm.branch_tracer.unknown_scale` and
   ``problem.residual_scale``; it passes folds (turning points).  The continuation runs inside
   :func:`mshbm.condensation.reuse_factors`: a sparse condensation keeps its LU per harmonic and solves
   at nearby frequencies (corrector iterations, ``dR/domega``) by a splitting iteration on it, which makes
   ``R`` smooth in ``omega`` on ill-conditioned meshes (fresh LUs differ by their rounding) and saves most
   factorisations (``Branch.counters["condensation"]``).
3. Every point is certified (:func:`mshbm.certificate.certify` at the corrector's tolerance): a point
   whose certificate fails is rejected and the step is shortened.  Then every point gets the error estimates and the
   gating ``accuracy`` of :func:`mshbm.solve` (:mod:`mshbm.branch_accuracy`): a point beyond it is kept and
   reported not certified.  Its stability is that of
   :func:`mshbm.stability.assess` (exact event-driven multipliers with saltation terms for elements on
   single DOFs, else a verdict only for smooth motion, else ``None``).
4. Folds are located from the sign change of the tangent's ``omega`` component (to ``1e-3``
   relative); other bifurcations come from :func:`mshbm.bifurcations.detect` when that module exists.

``period=k`` traces ``kT``-periodic solutions (:mod:`mshbm.subharmonic`): the problem lives on the base
frequency ``omega / k``; the branch reports the forcing frequency ``omega``.

The sweep is the branch component of the solve route (:class:`mshbm.route.driver.Route`): the start solves
go through the route it is given (:func:`trace`), and :data:`ROUTE`, the route of the public functions,
traces the ``"frequency"`` start's branches with :func:`trace`.

``continue_forcing(system, omega, load_start, load_end, ...)`` continues instead in a load factor
on the forcing (``f_hat`` times ``load``) at fixed ``omega``; :func:`mshbm.parameter.continue_parameter` in
any parameter that rebuilds the system (``family`` of ``_run``).  An interrupt keeps the points so far
(:mod:`mshbm.interrupt`).

The result types are in :mod:`mshbm.branch_result`, the problem the continuation runs on (residual, scales,
certified points as functions of the parameter) in :mod:`mshbm.branch_tracer`; this module puts them together.

Notation: ``n`` DOFs, ``x`` the unknowns of the method, ``omega`` the forcing frequency (rad/s).
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import replace

import numpy as np

from . import bifurcations
from . import stability as _stability
from . import validate
from ._blas import blas_threads, check_threads
from .condensation import reuse_factors
from .errors import InputError
from .interrupt import Collector, SweepInterrupted, interrupted_result
from .methods.hbm import linear_quadrature_unsupported
from .options import METHODS
from .route.driver import Route
from .route.options import capabilities, only, without
from .solvers.arclength import PREDICTED, continuation
from .solvers.newton import work_box
from .branch_grazing import grazing_locator
from .branch_accuracy import certify_points, check_options, skipped, to_accuracy
from .branch_result import Branch, BranchPoint
from .branch_tracer import _Tracer, scaled_forcing, unknown_scale
from .subharmonic import PERIOD_K_TOL, check_period, period_options, subharmonic_content, subharmonic_system
from .system import System

__all__ = ["Branch", "BranchPoint", "sweep", "continue_forcing", "trace", "unknown_scale", "ROUTE"]

#: options of the continuation itself (the others go to the method)
#: the sweep's largest arclength step next to points that are not smooth (stall, kink, change of the smooth piece;
#: :func:`mshbm.solvers.arclength.continuation`'s ``ds_rough``); along smooth stretches steps grow to ``ds_max``
DS_ROUGH = 0.1
_CONT_KEYS = {"ds", "ds_min", "ds_max", "max_points", "predictor", "max_time", "progress", "stability", "grazings"}
#: how a grazing between two points of a frequency sweep is placed: by solves on both sides to 1e-4 of omega
#: (``"bisection"``) or by interpolating the test functions of the two points (``"interpolation"``, no solves)
GRAZINGS = ("bisection", "interpolation")
#: options that are not the problem's (handled by the start solve / the corrector)
_SOLVER_KEYS = {"guess", "tol", "max_iter", "line_search", "raise_on_failure", "continuation", "blas_threads"}


class _Progress:
    def __init__(self, enabled, label):
        self.enabled = enabled is True and sys.stderr.isatty() or enabled == "always"
        self.label = label

    def __call__(self, point, n, ds):
        if self.enabled:
            print(f"\r[sweep {self.label}] points {n:4d}  {point.lam:12.6g}  step {ds:.3g}   ", end="",
                  file=sys.stderr, flush=True)

    def close(self):
        if self.enabled:
            print(file=sys.stderr)


def _check_number(key, value, positive=True):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(key, f"must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or (positive and value <= 0):
        raise InputError(key, f"must be finite{' and > 0' if positive else ''}, got {value}")
    return value


def _split_options(options):
    """``(the continuation's options, the start solve's options, the problem's options)``."""
    rest = without(options, *_CONT_KEYS)
    return only(options, *_CONT_KEYS), rest, without(rest, *_SOLVER_KEYS)


#: the grazing bisection's budget (:func:`mshbm.solvers.newton.work_box`): at most ``LOCATE_SHARE`` of the
#: trace's own work (Newton residual evaluations, the event-driven flow's work charged as evaluations), at least
#: ``LOCATE_FLOOR`` evaluations.  Without it a branch with many impact-count changes (a flexible structure's
#: chattering contact near a near-miss grazing) spent most of its time bisecting them (250 of 346 s, profiled,
#: on a reduced cantilever with a tip stop between 1.0 and 1.03 omega_1); once it is spent, the events are
#: located to their brackets so far and the message says so.
LOCATE_SHARE = 0.5
LOCATE_FLOOR = 200


def _detect_other(branch, system, locate=None):
    """Period doubling, Neimark-Sacker and grazing along the branch (:func:`mshbm.bifurcations.detect`
    on the points' valid multipliers and contact gaps; folds are located by the continuation itself).
    ``locate``: the bisection callback of :func:`mshbm.bifurcations.detect` (records' ``x`` are the
    branch's :class:`BranchPoint` s)."""
    records = [bifurcations.point_from_solution(system, bp.solution, x=bp) for bp in branch.points]
    # rel_tol: only the grazings between impacting orbits are bisected (``locate``); their final interpolation
    # mixes two test functions (impact velocity, near-miss gap) with different slopes, so the bracket
    # itself is the accuracy: 1e-4 of omega, a few more event-driven solves
    found = bifurcations.detect(records, locate=locate, rel_tol=1e-4,
                                types=("period-doubling", "neimark-sacker", "grazing"))
    out = []
    k = int(branch.period)
    for b in found:
        rec = b.as_dict()
        if k > 1:  # the points' solutions live on the base frequency omega / k: report the forcing frequency
            rec["omega"] = k * float(rec["omega"])
            if "bracket" in rec:
                rec["bracket"] = [k * float(v) for v in rec["bracket"]]
        rec["located"] = b.located
        if b.located == "bisection":
            rec["bisections"] = int(b.bisections)
        if branch.parameter != "omega":
            rec["load"] = float(branch.points[b.index].load)
        out.append(rec)
    return out, ""


def _run(route, system, lam_start, lam_end, method, period, parameter, omega_fixed, options, family=None):
    with work_box() as meter:  # the trace's Newton residual evaluations: the unit of the estimates' stride
        return _traced(meter, route, system, lam_start, lam_end, method, period, parameter, omega_fixed, options,
                       family)


def _traced(meter, route, system, lam_start, lam_end, method, period, parameter, omega_fixed, options, family):
    t0 = time.perf_counter()
    if not isinstance(system, System):
        raise InputError("system", f"must be an mshbm.System, got {type(system).__name__}")
    if method not in METHODS:
        raise InputError("method", f"unknown method {method!r} (choose from {', '.join(METHODS)})")
    k = check_period(period)
    accuracy, every = check_options(options.get("accuracy"), options.get("estimate_every"))
    options = {key: v for key, v in options.items() if key not in ("accuracy", "estimate_every")}
    # a branch traced as a start of a solve (the "frequency" start: route.estimate False) needs no estimates
    accuracy, no_estimate = (accuracy, "accuracy=False") if route.estimate else (False, "a start branch of a solve")
    route = replace(route, estimate=False)
    if capabilities(method).penalty_laws and "penalty_quadrature" not in options \
            and any(el.unilateral for el in system.elements) \
            and linear_quadrature_unsupported(system.elements) is None:
        # the sampled penalty law makes the branch a chain of kinks (mshbm.methods.hbm, "Quadrature of the
        # penalty law"); integrated on the gap's linear interpolant the residual is C^1 and the branch smooth
        options = dict(options, penalty_quadrature="linear")
    cont, rest, prob = _split_options(options)
    stab = _stability.check_option(cont.get("stability", "auto"))
    max_points = cont.get("max_points", 400)
    if isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer)) or max_points < 2:
        raise InputError("max_points", f"must be an integer >= 2, got {max_points!r}")
    predictor = cont.get("predictor", "tangent")
    if predictor not in ("tangent", "secant"):
        raise InputError("predictor", f"must be 'tangent' or 'secant', got {predictor!r}")
    ds = _check_number("ds", cont.get("ds", 0.02))
    ds_max = _check_number("ds_max", cont.get("ds_max", 0.5))
    ds_min = _check_number("ds_min", cont.get("ds_min", 1e-5))
    grazings = cont.get("grazings", "bisection")
    if grazings not in GRAZINGS:
        raise InputError("grazings", f"must be one of {', '.join(map(repr, GRAZINGS))}, got {grazings!r}")
    max_time = cont.get("max_time")
    if max_time is not None:
        max_time = _check_number("max_time", max_time)
    tol = float(rest.get("tol", 1e-10))
    label = f"{method}" + (f", period {k}" if k > 1 else "")
    progress = _Progress(cont.get("progress", False), label)

    sys_k = subharmonic_system(system, k)
    prob_k = period_options(method, k, prob)
    # 1. the start point: mshbm.solve from its default start (or the given guess)
    if parameter == "omega":
        sol0 = route.solve_period(system, lam_start, method, period=k, stability=False, **rest)
    elif family is not None:  # any parameter that rebuilds the system (mshbm.parameter)
        sol0 = route.solve_period(family.system(lam_start), omega_fixed, method, period=k, stability=False, **rest)
    else:
        sol0 = route.solve_period(scaled_forcing(system, lam_start), omega_fixed, method, period=k, stability=False,
                                  **rest)
    tracer = (_Tracer if family is None else family.tracer)(sys_k, method, dict(prob_k), parameter, omega_fixed, k,
                                                              tol, stab)
    tracer.substitution_estimate = accuracy is not False  # no error estimates: a substituted law only named
    branch = Branch(success=False, message="", method=method, period=k, parameter=parameter)
    if not sol0.success:
        branch.message = f"no certified solution at the start {parameter} = {lam_start:g}: {sol0.message}"
        branch.wall_time = time.perf_counter() - t0
        return branch
    if k > 1 and subharmonic_content(sol0, k) < PERIOD_K_TOL:
        branch.message = (f"the solution at the start {parameter} = {lam_start:g} is T-periodic, not a "
                          f"{k}T-periodic one (no period-{k} response found there)")
        branch.wall_time = time.perf_counter() - t0
        return branch

    def accept(x, lam, stall):  # iterations and residual are set from the continuation's points below
        pt = tracer.point(x, lam, 0, 0.0, stall)
        return not isinstance(pt, str), pt

    def solve_at(lam, x):  # the pointwise solve (its start ladder) where Newton from the last point fails
        if parameter != "omega" or family is not None:
            return None
        sol = route.solve_period(system, float(lam), method, period=k, stability=False,
                                 **dict(without(rest, "guess"), accuracy=False))
        if not sol.success or sol.x is None:  # why, for the sweep's message
            return (sol.message or "no solution")[:160]
        return np.asarray(sol.x, dtype=float)

    lam_scale = abs(lam_start) if parameter == "omega" else max(abs(lam_start), abs(lam_end))
    # one kept LU per harmonic of the condensed part, reused by the nearby frequencies of a corrector and of
    # dR/domega: faster, and R smooth in omega (mshbm.condensation.FactorReuse)
    seen, reuse = Collector(progress), None  # the accepted points, kept for an interrupt (mshbm.interrupt)
    try:
        with reuse_factors() as reuse:
            res = continuation(
                tracer.residual, tracer.d_lam, np.asarray(sol0.x, dtype=float), float(lam_start), float(lam_end),
                residual_scale=tracer.residual_scale, unknown_scale=tracer.unknown_scale, lam_scale=lam_scale,
                ds0=ds, ds_min=ds_min, ds_max=ds_max, ds_rough=DS_ROUGH, predicted=PREDICTED,
                max_points=int(max_points), tol=tol,
                max_corrector_iter=min(12, int(rest.get("max_iter", 12))),
                predictor=predictor, accept=accept, callback=seen, max_time=max_time,
                stall_accept=tracer.stall_accept, segment=tracer.segment, restarts=tracer.restarts,
                gauge=tracer.gauge, solve_at=solve_at)
    except KeyboardInterrupt as exc:
        interrupted, res = exc, interrupted_result(seen.points)
    else:
        interrupted = None
    finally:
        progress.close()
    branch.points = []
    for p in res.points:
        bp = p.payload
        bp.iterations, bp.residual = int(p.iterations), float(p.residual)
        bp.solution.iterations = int(p.iterations)
        branch.points.append(bp)
    if branch.points:
        branch.points[0].iterations = int(sol0.iterations)
    folds = []
    for f in res.folds:
        rec = {"type": "fold", "index": int(f["index"]), "located": bool(f.get("located", False))}
        if parameter == "omega":
            rec["omega"] = float(f["lam"])
        else:
            rec["omega"], rec["load"] = float(omega_fixed), float(f["lam"])
        if "bracket" in f:
            rec["bracket"] = f["bracket"]
        folds.append(rec)
    # an interrupt after the trace (locating bifurcations, the points' estimates) keeps the traced points
    try:
        locator = grazing_locator(tracer, system, tol) \
            if parameter == "omega" and grazings == "bisection" and not interrupted else None
        with work_box(max(LOCATE_FLOOR, LOCATE_SHARE * meter.used), "bifurcation-location budget") as located:
            others, note = ([], "") if not branch.points else _detect_other(branch, system, locator)
        if locator is not None and located.used >= located.limit:
            note = (f"grazings located to the brackets reached within their budget ({located.limit:.0f} residual "
                    f"evaluations, {LOCATE_SHARE:g} of the trace's)")
    except KeyboardInterrupt as exc:
        interrupted, others, note = exc, [], "interrupted while locating its bifurcations"
    branch.bifurcations = sorted(folds + [dict(b) for b in others], key=lambda b: b.get("index", 0))
    branch.success = bool(res.success)
    branch.message = res.message + (f"; {note}" if note else "")
    if interrupted is None and accuracy is not False:
        est_opts = dict(prob_k, **only(rest, "tol", "max_iter", "line_search"))
        branch.wall_time = time.perf_counter() - t0
        try:  # (the trace's evaluations set the stride of the estimates)
            certify_points(branch, route, tracer, method, est_opts, accuracy, every, [p.lam for p in res.points],
                           trace_cost=meter.used)
        except KeyboardInterrupt as exc:
            interrupted = exc
            branch.message += "; interrupted while estimating the points' accuracy"
    if interrupted is not None or accuracy is False:  # the points' error estimates (mshbm.branch_accuracy)
        skipped(branch, "interrupted" if interrupted is not None else no_estimate)
        if interrupted is not None:
            branch.success = False
    branch.counters = dict(res.counters, start_iterations=int(sol0.iterations), points=len(branch.points),
                           condensation={k: int(v) for k, v in (reuse.counters if reuse is not None else {}).items()})
    branch.wall_time = time.perf_counter() - t0
    if interrupted is not None:
        raise SweepInterrupted(branch, interrupted)
    return branch


def sweep(system, omega_start, omega_end, method="mshbm", period=1, **options):
    """Frequency-response curve: the branch of periodic solutions from ``omega_start`` to ``omega_end``.

    Parameters
    ----------
    system : System
    omega_start, omega_end : float
        Forcing frequencies (rad/s) of the start and the end of the branch (either order).
    method : {"shooting", "hbm", "mshbm", "mshbm-intermediate"}
    period : int
        ``k``: trace ``kT``-periodic solutions (:mod:`mshbm.period`); ``harmonics``/``steps`` are per
        forcing period ``T``.
    **options
        The method's options as for :func:`mshbm.solve` (``harmonics``, ``steps``, ``theta``,
        ``partition``...; ``guess`` for the start point; ``tol`` also for the corrector; ``max_iter`` also bounds the corrector's
        iterations, at most 12), and the
        continuation's: ``ds`` (first arclength step, scaled, default 0.02), ``ds_min`` (1e-5),
        ``ds_max`` (0.5 along smooth stretches, 0.1 next to points that are not smooth; growth bounded by a turn of
        the tangent of 0.5 rad per step), ``max_points`` (400), ``predictor`` (``"tangent"`` or ``"secant"``),
        ``max_time`` (s), ``progress`` (show progress on a terminal; ``"always"``: also elsewhere), ``grazings``
        (``"bisection"``: each grazing located by solves on both sides, to 1e-4 of omega; ``"interpolation"``:
        between its two bracketing points, without solves),
        ``stability`` (as for :func:`mshbm.solve`), ``blas_threads`` (default 1, as for :func:`mshbm.solve`),
        ``accuracy`` and ``estimate_every`` (every point's error estimates and the branch's refinement to a
        requested accuracy, :mod:`mshbm.branch_accuracy`; ``accuracy=False``: none).  HBM with penalty contacts (``d_c = 0``, no friction loaded by a contact) defaults to
        ``penalty_quadrature="linear"`` here (:mod:`mshbm.methods.hbm`): with the sampled law the branch
        folds back at kinks of the sampled equations; give ``penalty_quadrature="samples"`` for the branch of
        :func:`mshbm.solve`'s default.

    Returns
    -------
    Branch
        On Ctrl-C :class:`mshbm.interrupt.SweepInterrupted` (a KeyboardInterrupt) carries the points so far.
    """
    w0 = _check_number("omega_start", omega_start)
    w1 = _check_number("omega_end", omega_end)
    if w0 == w1:
        raise InputError("omega_end", "must differ from omega_start")
    return _guarded(ROUTE, system, w0, w1, method, period, "omega", None, options)


def trace(route, system, omega_start, omega_end, method="mshbm", period=1, **options):
    """:func:`sweep` whose start solves go through ``route`` (:class:`mshbm.route.driver.Route`): the sweep
    component of the solve route."""
    w0 = _check_number("omega_start", omega_start)
    w1 = _check_number("omega_end", omega_end)
    if w0 == w1:
        raise InputError("omega_end", "must differ from omega_start")
    return _guarded(route, system, w0, w1, method, period, "omega", None, options)


#: the solve route of the public functions (:func:`mshbm.solve`, :func:`sweep`, :func:`mshbm.period.solve`):
#: no deadline of its own, and :func:`trace` as the sweep of its ``"frequency"`` start
ROUTE = Route(sweep=trace)


def _guarded(route, system, a, b, method, period, parameter, omega, options, family=None):
    """``_run`` with one BLAS thread (option ``blas_threads``, as :func:`mshbm.solve`) and quiet floats."""
    options = dict(options)
    with blas_threads(check_threads(options.pop("blas_threads", 1))), validate.quiet_floats():
        branch = _run(route, system, a, b, method, period, parameter, omega, options, family)
        return to_accuracy(lambda o: _run(route, system, a, b, method, period, parameter, omega, o, family), branch,
                           options)


def continue_forcing(system, omega, load_start, load_end=1.0, method="mshbm", period=1, **options):
    """Branch in the load factor ``load`` on the forcing (``f_hat`` times ``load``) at fixed ``omega``.

    Parameters and result as for :func:`sweep`; ``Branch.load`` holds the load factors and
    fold records carry ``load``.  ``load_start`` and ``load_end`` must be > 0.
    """
    w = _check_number("omega", omega)
    a = _check_number("load_start", load_start)
    b = _check_number("load_end", load_end)
    if a == b:
        raise InputError("load_end", "must differ from load_start")
    return _guarded(ROUTE, system, a, b, method, period, "forcing", w, options)
