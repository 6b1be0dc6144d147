"""A-posteriori error estimates of a solve, and the refinement of its discretisation to a requested accuracy.

Every certified result of :func:`mshbm.solve` carries, besides the certificate of the discretised equations
(:mod:`mshbm.certificate`), estimates of the relative amplitude error
``e = max_i |A_i - A_i^exact| / max_i A_i`` (``A_i = (max - min) / 2`` of DOF ``i``) that each approximation
causes, measured by re-solving the same problem at another discretisation from the converged answer (Newton,
the start ladder with the answer as its only start, time-boxed: :data:`RESOLVE_SECONDS`, :data:`RESOLVE_FACTOR`).
With the amplitude change ``d`` between the two answers and an algebraic convergence ``e(n) ~ n^-p``:

``truncation`` (HBM, DLFT, MS-HBM)
    Against the re-solve at ``n_f = 2 n_h`` (3 for ``n_h = 1``: a half-wave symmetric orbit has odd harmonics
    only, and ``n_h = 2`` would change nothing): ``d / (1 - (n_h / n_f)^p)``.  (A coarser partner ``n_h / 2`` would be cheaper,
    but where the series converges fast its change is far larger than the error at ``n_h``: on the paper's
    friction oscillator ``n_h = 2`` is 7 % off, ``n_h = 5`` 5e-5.)  When that re-solve fails, against
    ``n_c = n_h // 2``: ``d / ((n_h / n_c)^p - 1)``.
``time_discretisation`` (shooting and MS-HBM with Moreau-Jean steps)
    Against the re-solve at ``N / 2`` steps per period: ``d / (2^p - 1)``; when it fails, against ``2 N``:
    ``d / (1 - 2^-p)``; at least half the displacement change of one step at the largest velocity jump ``J``
    of an impact, ``h J / (2 max_i A_i)`` (an impact is located to a step, first order, and that error varies
    irregularly with ``N``: on the impact oscillator of ``tests/closed_forms.py`` at omega = 2 the error is
    0.08 %, 0.17 %, 0.04 % at 256, 1024, 4096 steps, and the change against ``N / 2`` at 1024 steps is 0.03 %).
    Zero for the exact event-driven flow (no time steps).

``p`` is :data:`RATE` = 1 (first order: Moreau-Jean at impacts and stick-slip, the Fourier series of kinks),
or, in a refinement with two successive changes ``d_1, d_2`` of the same estimate at ratio 2, the observed
rate ``log2(d_1 / d_2)`` within ``[MIN_RATE, MAX_RATE]`` (Richardson).  An estimate whose re-solves both fail
is ``None`` ("not estimated"), and the combined check ``accuracy``
(:func:`mshbm.certificate.combined.combined_check`: the sum of ``truncation``, ``time_discretisation`` and the
``regularisation`` and ``model_substitution`` estimates of the certificate) then fails.

Refinement (option ``accuracy``): while the combined estimate exceeds the request, the discretisation of the
largest estimate is refined -- ``n_h`` doubled (``truncation``: the estimate's re-solve at ``n_f`` is that
level), the steps doubled (``time_discretisation``: the previous level is the new level's coarse partner), or
what the problem class's hook ``refine(kind, system, options)`` returns for the other kinds (``(system,
options)`` of a more accurate model, or ``None``: :meth:`mshbm.methods.base.PeriodicProblem.refine`) -- each
level solved from the previous answer; the estimates not refined are carried over.  It stops when the request
is met, when the discretisation cannot be refined (``n_h`` 2000, ``2^24`` steps, :data:`MAX_LEVELS` levels),
when a refined solve fails, or when the solve's ``max_time`` is spent; the result then fails naming the
estimate.  Without ``accuracy`` nothing is refined and :data:`mshbm.certificate.combined.DEFAULT_ACCURACY`
gates ``success``.

``info["accuracy"]``: the accuracy (requested or default), the combined estimate, the estimates, the levels
(``harmonics``, ``steps``, what was refined, the estimate) and the wall time spent on the estimates' and the
refinement's solves (included in ``wall_time``).
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from ..certificate.combined import DEFAULT_ACCURACY, combined_check, estimates, gate
from ..certificate.record import Check
from ..certificate.verdict import reword_warnings
from ..errors import InputError
from ..methods.capabilities import capabilities as method_capabilities
from ..options import aft_steps
from ..scaling import displacement_floor
from ..solvers import newton as newton_
from .acceptance import impact_jump
from .options import capabilities, without

__all__ = ["MAX_LEVELS", "RATE", "estimate_and_refine", "amplitude_change"]

#: most refinements of one solve
MAX_LEVELS = 6
#: the assumed (slowest) algebraic convergence rate ``p`` of the estimates
RATE = 1.0
#: the range of an observed rate (two successive amplitude changes at ratio 2); at most the Moreau-Jean scheme's
#: order 2 on smooth parts, so that a pre-asymptotic fast decrease does not shrink the estimate
MIN_RATE, MAX_RATE = 0.25, 2.0
MAX_HARMONICS, MAX_STEPS = 2000, 1 << 24
#: time box (s) of one re-solve of an estimate: this many seconds, or this factor times the solve's wall time
RESOLVE_SECONDS, RESOLVE_FACTOR = 5.0, 2.0
_DROP = ("guess", "stability", "progress", "raise_on_failure", "accuracy")


def amplitude_change(sol, ref, floor=0.0):
    """``max_i |A_i - A_ref,i| / max(max_i A_i, floor)`` of two solutions of the same system (``inf`` when
    an amplitude is not finite)."""
    a, b = np.asarray(sol.amplitude, dtype=float), np.asarray(ref.amplitude, dtype=float)
    if a.shape != b.shape or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return math.inf
    scale = max(float(np.max(np.abs(a), initial=0.0)), float(floor))
    d = float(np.max(np.abs(a - b), initial=0.0))
    return d / scale if scale > 0 else (0.0 if d == 0 else math.inf)


class _Estimator:
    """The estimates of one solve (module docstring); ``route`` solves without estimates of their own."""

    def __init__(self, route, system, omega, method, options, t0, accuracy):
        self.accuracy = float(accuracy)
        self.route, self.system, self.omega, self.method = route, system, float(omega), method
        self.options = without(options, *_DROP)
        self.caps = method_capabilities(method)
        self.truncates = bool(capabilities(method).harmonic_truncation)
        self.user_steps = "steps" in options
        self.floor = 1e-3 * displacement_floor(system, self.omega)
        self.t0 = t0
        self.diffs = {}  # the last amplitude change between refinement levels, per estimate
        self.solved = {}  # (harmonics, steps) -> the certified re-solve, or None (failed)
        self.failures = []  # messages of the failed re-solves
        self.spent = 0.0

    # -- settings of a solution
    def integrator(self, sol):
        return sol.info.get("integrator") or self.options.get("integrator")

    def time_stepped(self, sol):
        return sol.time_step is not None and sol.q_time.shape[1] > 0

    def settings(self, sol, harmonics=None, steps=None):
        """Options of ``sol``'s discretisation with ``harmonics`` / ``steps`` changed."""
        n = int(sol.harmonics) if harmonics is None else int(harmonics)
        out = dict(self.options, harmonics=n)
        if self.caps.aft_samples:  # HBM, DLFT: AFT samples follow n_h unless given
            if self.user_steps:
                out["steps"] = max(int(self.options["steps"]), 2 * n + 2) if steps is None else int(steps)
            else:
                out.pop("steps", None)
        else:
            out["steps"] = int(sol.steps) if steps is None else int(steps)
        integ = self.integrator(sol)
        if "integrator" in self.caps.options:  # the answer's integrator, and no fallback to the other one
            out["integrator"] = integ or "moreau"
        return out

    def resolve(self, sol, **settings):
        """The solve at ``settings`` from ``sol`` (Newton and the problem's own fallbacks, no ladder), or ``None``
        when it fails or the settings are not valid."""
        opts = self.settings(sol, **settings)
        # (at the solve's Newton tolerance: on stiff finite-element DOFs a scaled residual of 1e-8 can hide an
        # amplitude change of 0.2 %, so a looser tolerance would let the partner stay where it started)
        key = (int(opts["harmonics"]), opts.get("steps"))
        if key in self.solved:
            return self.solved[key]
        t = time.perf_counter()
        # the start ladder with the answer as its only start (Newton, its fallbacks, and the acceptance of an
        # impacting orbit periodic to one step's accuracy), time-boxed: no other start, which could find another
        # orbit
        route = self.route.tightened(t + max(RESOLVE_SECONDS, RESOLVE_FACTOR * float(sol.wall_time)))
        try:
            with newton_.time_box(route.deadline):
                alt = route._solve(self.system, self.omega, self.method, dict(opts, guess=sol),
                                   ladder_starts=("guess",))
        except InputError:
            alt = None
        self.spent += time.perf_counter() - t
        self.solved[key] = alt if alt is not None and alt.success else None
        if self.solved[key] is None:
            self.failures.append(f"{_describe(opts)}: " + ("invalid settings" if alt is None else alt.message[:200]))
        return self.solved[key]

    # -- the estimates
    def truncation(self, sol):
        """``(value, note)`` of ``truncation`` (module docstring)."""
        n = int(sol.harmonics)
        nf = max(2 * n, n + 2)  # (n + 2 > 2 for n = 1: a half-wave symmetric orbit has odd harmonics only)
        if nf <= MAX_HARMONICS:
            f = self.resolve(sol, harmonics=nf)
            if f is not None:
                d = amplitude_change(sol, f, self.floor)
                p = self.rate("truncation", d)
                return d / (1.0 - (n / nf) ** p), (f"amplitude change {d:.3g} against n_h = {nf}, "
                                                   f"/ (1 - ({n}/{nf})^p), p = {p:.3g}")
        if n >= 2:
            nc = n // 2
            c = self.resolve(sol, harmonics=nc)
            if c is not None:
                d = amplitude_change(sol, c, self.floor)
                return d / ((n / nc) ** RATE - 1.0), (f"amplitude change {d:.3g} against n_h = {nc}, "
                                                      f"/ (({n}/{nc})^p - 1), p = {RATE:g}")
        return None, f"not estimated: the re-solves at n_h = {nf} and {n // 2} failed ({'; '.join(self.failures[-2:])})"

    def rate(self, kind, d):
        """The rate ``p`` of the estimate ``kind`` with the amplitude change ``d`` at ratio 2: :data:`RATE`, or
        the rate observed against the previous level's change (Richardson), within ``[MIN_RATE, MAX_RATE]``."""
        last = self.diffs.get(kind)
        self.diffs[kind] = d
        if last is not None and d > 0 and last > 0:
            return min(MAX_RATE, max(MIN_RATE, math.log2(last / d)))
        return RATE

    def time_discretisation(self, sol):
        """``(value, note)`` of ``time_discretisation`` (module docstring)."""
        if self.integrator(sol) == "event":
            return 0.0, "the exact event-driven flow (no time steps)"
        N, n = int(sol.steps), int(sol.harmonics)
        low = 2 * n + 2 if self.caps.harmonic_unknowns else 8
        value = note = None
        if N % 2 == 0 and N // 2 >= low:
            c = self.resolve(sol, steps=N // 2)
            if c is not None:
                d = amplitude_change(sol, c, self.floor)
                p = self.rate("time_discretisation", d)
                value, note = d / (2.0 ** p - 1.0), (f"amplitude change {d:.3g} against {N // 2} steps, / (2^p - 1), "
                                                     f"p = {p:.3g}")
        if value is None and 2 * N <= MAX_STEPS:
            f = self.resolve(sol, steps=2 * N)
            if f is not None:
                d = amplitude_change(sol, f, self.floor)
                value, note = d / (1.0 - 2.0 ** -RATE), f"amplitude change {d:.3g} against {2 * N} steps, / (1 - 2^-p)"
        if value is None:
            return None, (f"not estimated: the re-solves at {N // 2} and {2 * N} steps failed "
                          f"({'; '.join(self.failures[-2:])})")
        step = self.impact_step(sol)
        if step > value:
            value, note = step, f"{note}; one step at the impacts, h J / (2 max A) = {step:.3g}, is larger (first order)"
        return value, note

    def impact_step(self, sol):
        """``h J / (2 max_i A_i)``: the displacement change of one step at the largest velocity jump ``J`` of an
        impact, relative to the largest amplitude, halved (an amplitude is half the range of the displacement).
        The error of an impact located to a step is of this size and varies irregularly with ``N`` (a
        refinement difference can nearly cancel); 0 without impacts."""
        if sol.impulses is None or sol.time_step is None:
            return 0.0
        J = impact_jump(self.system, {"impulses": np.asarray(sol.impulses), "time_dofs": sol.time_dofs})
        scale = max(float(np.max(np.abs(sol.amplitude), initial=0.0)), self.floor)
        return 0.5 * float(sol.time_step) * J / scale if scale > 0 else 0.0

    def attach(self, sol, values, accuracy, requested):
        """Put the estimates ``values`` (``{name: (value, note)}``) and the check ``accuracy`` into ``sol``'s
        certificate and gate ``sol.success`` on it."""
        cert = sol.certificate
        warned = cert.describe_warnings()  # the warnings of the certificate alone, re-worded with the estimates
        for name, (value, note) in values.items():
            ok = value is not None and value <= accuracy
            chk = Check(name, value, float(accuracy), bool(ok), False, note)
            cert.checks = [c for c in cert.checks if c.name != name] + [chk]
        chk = combined_check(cert, accuracy, requested)
        gate(sol, chk)
        reword_warnings(sol, warned)
        return chk

    def own_estimates(self, sol, only=None):
        """The estimates this module computes for ``sol`` (``{name: (value, note)}``); ``only``: that one."""
        out = {}
        if self.truncates and only in (None, "truncation"):
            out["truncation"] = self.truncation(sol)
        if self.time_stepped(sol) and only in (None, "time_discretisation"):
            out["time_discretisation"] = self.time_discretisation(sol)
        return out

    def refined(self, kind, sol):
        """``(system, options)`` of the next level for the estimate ``kind``, or ``None``."""
        if kind == "truncation":
            n = max(2 * int(sol.harmonics), int(sol.harmonics) + 2)  # the estimate's partner (truncation())
            if n > MAX_HARMONICS:
                return None
            opts = self.settings(sol, harmonics=n)
            if "steps" in opts and self.caps.harmonic_unknowns:
                opts["steps"] = max(opts["steps"], 2 * n + 2 if not self.caps.aft_samples else aft_steps(n))
            return self.system, opts
        if kind == "time_discretisation":
            N = 2 * int(sol.steps)
            return None if N > MAX_STEPS else (self.system, self.settings(sol, steps=N))
        hook = getattr(capabilities(self.method), "refine", None)
        if hook is None:
            return None
        return hook(kind, self.system, self.settings(sol))


def estimate_and_refine(route, system, omega, method, options, sol, accuracy=None, t0=None):
    """The estimates of ``sol`` and, with ``accuracy`` given, the refinement loop (module docstring).

    Parameters
    ----------
    route : mshbm.route.driver.Route
        The route of the solve (its re-solves run on ``replace(route, estimate=False)``).
    system, omega, method, options
        The solve's arguments (``options`` as given, without ``stability``).
    sol : PeriodicSolution
        The solve's certified (or failed) result at the user's discretisation.
    accuracy : float or None
        The requested relative amplitude accuracy; ``None``: :data:`DEFAULT_ACCURACY` gates, no refinement.

    Returns
    -------
    PeriodicSolution
        ``sol`` or the last refined solution, with the estimates and the check ``accuracy`` in its certificate
        and ``info["accuracy"]``.
    """
    t0 = time.perf_counter() if t0 is None else t0
    requested = accuracy is not None
    acc = float(accuracy) if requested else DEFAULT_ACCURACY
    est = _Estimator(replace(route, estimate=False), system, omega, method, options, t0, acc)
    if not sol.success or sol.certificate is None:  # no answer to estimate the error of
        sol.info["accuracy"] = {"accuracy": acc, "requested": requested, "estimate": None, "passed": False,
                                "estimates": {}, "levels": [], "estimate_time_s": 0.0,
                                "note": "not estimated: the solve failed"}
        return sol
    values = est.own_estimates(sol)
    chk = est.attach(sol, values, acc, requested)
    levels = [_level(sol, chk, None)]
    stop = ""
    while requested and not chk.passed and _only_accuracy(sol):
        if len(levels) > MAX_LEVELS:
            stop = f"{MAX_LEVELS} refinements made"
            break
        if route.deadline is not None and time.perf_counter() >= route.deadline:
            stop = "time budget max_time spent"
            break
        current = estimates(sol.certificate)
        missing = [k for k, (v, _) in values.items() if v is None]
        kind = missing[0] if missing else max(current, key=current.get)
        nxt = est.refined(kind, sol)
        if nxt is None:
            stop = f"{kind} cannot be refined further by this method"
            break
        sys_n, opts = nxt
        key = (int(opts["harmonics"]), opts.get("steps"))
        start = est.solved.get(key) if sys_n is system else None  # the estimate's own re-solve at these settings
        t = time.perf_counter()
        new = replace(route, estimate=False).solve(sys_n, omega, method, guess=start or sol, stability=False, **opts)
        est.spent += time.perf_counter() - t
        if not new.success:
            stop = f"the refined solve ({_describe(opts)}) failed: {new.message}"
            break
        if sys_n is not system:
            est.system, est.solved, system = sys_n, {}, sys_n
        new = _fresh(new)
        values = {k: (v, note if "carried over" in note else f"{note} (carried over from the previous level)")
                  for k, (v, note) in values.items() if k != kind}
        own = est.own_estimates(new, only=kind)
        values.update(own)
        sol = new
        chk = est.attach(sol, values, acc, requested)
        levels.append(_level(sol, chk, kind))
    if stop:
        sol.message += f"; refinement stopped: {stop}"
    sol.info["accuracy"] = {"accuracy": acc, "requested": requested, "estimate": chk.value, "passed": chk.passed,
                            "estimates": {k: v for k, v in estimates(sol.certificate).items()},
                            "levels": levels, "estimate_time_s": est.spent}
    sol.wall_time = float(sol.wall_time) + (est.spent if len(levels) == 1 else 0.0)
    if len(levels) > 1:
        sol.wall_time = time.perf_counter() - t0
    return sol


def _only_accuracy(sol):
    """The certificate of ``sol`` fails on ``accuracy`` only (a refinement can help)."""
    return sol.certificate.failed == ["accuracy"]


def _fresh(sol):
    """A copy of ``sol`` whose certificate has no estimates yet (a cached re-solve is also another level's
    partner)."""
    from copy import copy

    out = copy(sol)
    out.info = dict(sol.info)
    cert = copy(sol.certificate)
    cert.checks = list(sol.certificate.checks)
    cert.info = dict(sol.certificate.info)
    out.certificate = cert
    return out


def _level(sol, chk, kind):
    return {"harmonics": int(sol.harmonics), "steps": int(sol.steps), "refined": kind,
            "estimate": chk.value, "passed": bool(chk.passed)}


def _describe(opts):
    return ", ".join(f"{k}={opts[k]}" for k in ("harmonics", "steps") if k in opts)
