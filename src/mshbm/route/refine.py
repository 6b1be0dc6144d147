"""A-posteriori error estimates of a solve, and the refinement of its discretisation to a requested accuracy.

Every certified result of :func:`mshbm.solve` carries, besides the certificate of the discretised equations
(:mod:`mshbm.certificate`), estimates of the relative amplitude error
``e = max_i |A_i - A_i^exact| / max_i A_i`` (``A_i = (max - min) / 2`` of DOF ``i``) that each approximation
causes, measured by re-solving the same problem at another discretisation from the converged answer (Newton,
the start ladder with the answer as its only start, within a work budget of Newton residual evaluations:
:data:`RESOLVE_EVALUATIONS`, :data:`RESOLVE_FACTOR`).
With the amplitude change ``d`` between the two answers and an algebraic convergence ``e(n) ~ n^-p``:

``truncation`` (HBM, DLFT, MS-HBM)
    Against the re-solve at ``n_f = 2 n_h`` (3 for ``n_h = 1``: a half-wave symmetric orbit has odd harmonics
    only): ``d / (1 - (n_h / n_f)^p)`` (a coarser partner's change is far larger than the error where the series
    converges fast); when that re-solve fails, against ``n_c = n_h // 2``: ``d / ((n_h / n_c)^p - 1)``.
``time_discretisation`` (shooting and MS-HBM with Moreau-Jean steps)
    Against the re-solve at ``N / 2`` steps per period: ``d / (2^p - 1)``; when it fails, against ``2 N``:
    ``d / (1 - 2^-p)``; at least half the displacement change of one step at the largest velocity jump ``J``
    of an impact, ``h J / (2 max_i A_i)`` (an impact is located to a step, first order, and that error varies
    irregularly with ``N``: on the impact oscillator of ``tests/closed_forms.py`` at omega = 2 the error is
    0.08 %, 0.17 %, 0.04 % at 256, 1024, 4096 steps, and the change against ``N / 2`` at 1024 steps is 0.03 %).
    Zero for the exact event-driven flow (no time steps).
``model_substitution`` (MS-HBM's subsystem impact mass on a consistent mass, where the contact impacts)
    The amplitude change against the re-solve with ``impact_mass="effective"`` and the event-driven flow (the
    exact orbit, the answer and the transient as starts; work budget :data:`IMPACT_MASS_EVALUATIONS`).

``p`` is :data:`RATE` = 1 (first order: Moreau-Jean at impacts and stick-slip, the Fourier series of kinks),
or, in a refinement with two successive changes ``d_1, d_2`` of the same estimate at ratio 2, the observed
rate ``log2(d_1 / d_2)`` within ``[MIN_RATE, MAX_RATE]`` (Richardson).

Irregular convergence.  One change can vanish by coincidence: on Den Hartog's Coulomb oscillator (``zeta = 0,
omega = 0.8, R = 0.2``) Moreau-Jean's error is 2.7e-4 at 2048 and at 4096 steps and the change between them
1.3e-6 (the slip reversals fall at other places of the grid, and the error moves in steps with ``N``); HBM there
is 1.8e-3 off at ``n_h`` = 5 and 10, which agree to 5e-6, while 10 -> 20 changes by 7e-4.  So:

* ``time_discretisation`` takes two changes, ``d_1`` (``N`` against ``N / 2``) and ``d_2`` (``N / 2`` against
  ``N / 4``; on a refinement both are earlier levels, on the first level ``N / 4`` is one more re-solve, made
  only when ``d_1`` alone could pass): ``d_1 / (2^p - 1)`` at their observed rate ``p`` (at most
  :data:`MAX_RATE`; on the first level at most 1); when they do not decrease (``d_1 >= d_2``), one more
  change ``d_0`` (``N`` against ``2 N``, a re-solve made only when ``d_1`` could pass) and the envelope of the
  three at first order, each as a change ``N -> 2 N``, summed from ``N`` on: ``2 max(d_0, d_1 / 2, d_2 / 4)``
  (Moreau-Jean converges at first order; changes that do not fall are the events moving on the grid, where
  the slowest rate, ``d_1 / (2^MIN_RATE - 1)``, over-reads the error by one to two orders); when ``d_1`` fell
  faster than :data:`IRREGULAR_RATE` (8 times: a cancellation, no scheme of order 2 converges so), their
  envelope at first order, ``max(d_1, d_2 / 2)``.  An estimate about to pass gets the change of the answer at
  ``N / 2`` steps when the time grid is shifted by half a step against the forcing added
  (:meth:`_Estimator.grid_shift`; the error of an event depends on its place between two grid points, which a
  halving can leave where it was; the change at ``N / 2`` is about twice the one at ``N``, first order, and one
  alignment's error is up to about twice the spread of two): the halvings measure the part of the error that
  falls with the step, the shift the part that depends on the alignment.
* ``truncation``: Richardson at the slowest of the last :data:`RATE_WINDOW` observed rates of successive
  doublings (one rate alone, or two, can be read fast where the changes oscillate about their decay), and a
  change that fell faster than :data:`MAX_RATE` from the previous level's, or an estimate below
  :data:`TAIL_FACTOR` times the top retained harmonics (:func:`_top_harmonics`), is not trusted when it could
  pass: a second doubling ``2 n_f`` gives ``d_1 + d_2 / (1 - 2^-p)`` (``p`` their observed rate in
  ``[MIN_RATE, MAX_RATE]``).  The coarse fallback takes the slowest of the last :data:`RATE_WINDOW` rates
  observed into ``n_c`` and against it (at most :data:`RATE`), else :data:`MIN_RATE`.

An estimate whose re-solves both fail is ``None`` ("not estimated"), and the combined check ``accuracy``
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
from copy import copy
from dataclasses import replace

import numpy as np

from ..certificate.combined import DEFAULT_ACCURACY, combined_check, estimates, gate
from ..certificate.record import Check
from ..certificate.substitution import IMPACT_MASS_PENDING
from ..certificate.verdict import reword_warnings
from ..errors import InputError
from ..methods.capabilities import capabilities as method_capabilities
from ..options import aft_steps
from ..scaling import displacement_floor
from ..solvers import newton as newton_
from .acceptance import impact_jump
from .options import capabilities, without

__all__ = ["MAX_LEVELS", "RATE", "estimate_and_refine", "amplitude_change"]

MAX_LEVELS = 6  #: most refinements of one solve
#: the assumed (slowest) algebraic convergence rate ``p`` of the estimates
RATE = 1.0
#: the range of an observed rate (two successive amplitude changes at ratio 2); at most the Moreau-Jean scheme's
#: order 2 on smooth parts, so that a pre-asymptotic fast decrease does not shrink the estimate
MIN_RATE, MAX_RATE = 0.25, 2.0
#: a time-step change that falls faster than this rate (8 times per halving) is a cancellation, not the
#: convergence of a scheme of order <= 2 (a rate a little above 2 is the second order of smooth motion, clamped)
IRREGULAR_RATE = 3.0
RATE_WINDOW = 3  #: a truncation rate is the slowest of at most this many rates of successive doublings
MAX_HARMONICS, MAX_STEPS = 2000, 1 << 24
#: a truncation estimate below this fraction of the top retained harmonics is checked by a second doubling
TAIL_FACTOR = 0.1
#: work budget of one re-solve of an estimate in Newton residual evaluations, nested solves included (the same on
#: every machine; :func:`_resolve_box`); the floor is above one Newton solve from the answer (50 iterations of 12)
RESOLVE_EVALUATIONS, RESOLVE_FACTOR, RESOLVE_NEWTON = 1000, 2.0, 60
#: the same for the re-solve with the effective impact mass (``model_substitution``; event-driven flow; starts
#: "exact" within :data:`mshbm.route.starts.EXACT_WORK`, "guess", "transient")
IMPACT_MASS_EVALUATIONS = 2000
_DROP = ("guess", "stability", "progress", "raise_on_failure", "accuracy")


def _resolve_box(sol, floor):
    """The work budget of a re-solve from ``sol`` in evaluations (:func:`mshbm.solvers.newton.work_box`):
    ``max(floor, RESOLVE_FACTOR x W)``, ``W`` the larger of ``sol.nfev`` and the solve's metered work
    (``info["work"]``: an event-driven flow charges its work), and at least :data:`RESOLVE_NEWTON` times the cost
    of the re-solve's first Newton evaluation (its flow, with 2 n_h Fourier sums, costs several times the solve's)."""
    own = max(float(getattr(sol, "nfev", 0) or 0), float(sol.info.get("work", 0.0) or 0.0))
    return newton_.work_box(max(floor, RESOLVE_FACTOR * own), "work budget of the estimate's re-solve", RESOLVE_NEWTON)


def _top_harmonics(sol, floor):
    """``max |q_hat_k|`` over the DOFs given by Fourier series and the two highest retained harmonics
    ``k = n_h - 1, n_h`` (two: an orbit with odd harmonics only has none at even ``n_h``), relative to the largest
    amplitude."""
    qh = np.asarray(sol.q_hat, dtype=float)
    harmonic = np.setdiff1d(np.arange(qh.shape[1]), np.asarray(sol.time_dofs, dtype=int))  # not time-stepped
    if qh.shape[0] < 3 or not harmonic.size:
        return 0.0
    mags = np.hypot(qh[1::2, harmonic], qh[2::2, harmonic])[-2:]
    scale = max(float(np.max(np.abs(sol.amplitude), initial=0.0)), float(floor))
    return float(np.max(mags, initial=0.0)) / scale if scale > 0 else 0.0


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
        self.changes = {}  # all of them with their pair of discretisations, in level order
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

    @staticmethod
    def key(opts):
        """The key of a discretisation in :attr:`solved`: ``(harmonics, steps)`` of its options."""
        return int(opts["harmonics"]), opts.get("steps")

    def resolve(self, sol, **settings):
        """The solve at ``settings`` from ``sol`` (Newton and the problem's own fallbacks, no ladder), or ``None``
        when it fails or the settings are not valid."""
        opts = self.settings(sol, **settings)
        key = self.key(opts)
        # (at the solve's Newton tolerance: on stiff finite-element DOFs a scaled residual of 1e-8 can hide an
        # amplitude change of 0.2 %, so a looser tolerance would let the partner stay where it started)
        if key in self.solved:
            return self.solved[key]
        t = time.perf_counter()
        # the start ladder with the answer as its only start (Newton, its fallbacks, and the acceptance of an
        # impacting orbit periodic to one step's accuracy), within a work budget: no other start, which could find
        # another orbit
        try:
            with _resolve_box(sol, RESOLVE_EVALUATIONS):
                alt = self.route._solve(self.system, self.omega, self.method, dict(opts, guess=sol),
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
                last = self.diffs.get("truncation")
                p = self.rate("truncation", d, (n, nf))
                value = d / (1.0 - (n / nf) ** p)
                note = f"amplitude change {d:.3g} against n_h = {nf}, / (1 - ({n}/{nf})^p), p = {p:.3g}"
                why = self._untrusted(sol, d, last, value)
                if why and value <= self.accuracy and 2 * nf <= MAX_HARMONICS:
                    return self._second_halving(f, nf, d, value, note, why)
                return value, note
        if n >= 2:
            nc = n // 2
            c = self.resolve(sol, harmonics=nc)
            if c is not None:
                d = amplitude_change(sol, c, self.floor)
                # the slowest of the last RATE_WINDOW rates observed into n_c, else MIN_RATE: with the finer re-solve
                # failed nothing shows that the series has reached its asymptotic decay
                seq = [(pair, v) for pair, v in self.changes.get("truncation", []) if pair[1] <= nc]
                prev = seq[-1][1] if seq and seq[-1][0][1] == nc else None
                p, how = MIN_RATE, " (no change into n_c observed: the slowest rate)"
                if prev is not None and prev > 0 and d > 0:
                    q = math.log2(prev / d)
                    if q > MAX_RATE:  # a cancellation: the envelope of the two changes at the slowest rate
                        d, how = max(d, prev / 2.0 ** RATE), f" (irregular: envelope of {prev:.3g})"
                        p = RATE
                    else:
                        ch = [v for _, v in seq[-RATE_WINDOW:]] + [d]
                        q = min(math.log2(a / b) if a > 0 < b else MIN_RATE for a, b in zip(ch, ch[1:]))
                        p, how = max(MIN_RATE, min(RATE, q)), " (the slowest rate observed into n_c, at most 1)"
                return d / ((n / nc) ** p - 1.0), (f"amplitude change {d:.3g} against n_h = {nc}, "
                                                   f"/ (({n}/{nc})^p - 1), p = {p:.3g}{how}")
        return None, f"not estimated: the re-solves at n_h = {nf} and {n // 2} failed ({'; '.join(self.failures[-2:])})"

    def _untrusted(self, sol, d, last, value):
        """Why the change ``d`` of one doubling of ``n_h`` is not trusted (module docstring, "irregular
        convergence"), or ``""``: the change fell faster than :data:`MAX_RATE` from the previous level's ``last``,
        or the estimate ``value`` is below :data:`TAIL_FACTOR` times the top retained harmonics."""
        if last is not None and d > 0 and last > 0 and math.log2(last / d) > MAX_RATE:
            return f"the change fell faster than rate {MAX_RATE:g} from the previous level's {last:.3g}"
        top = _top_harmonics(sol, self.floor)
        if value < TAIL_FACTOR * top:
            return f"the estimate is below {TAIL_FACTOR:g} x the top retained harmonics ({top:.3g})"
        return ""

    def _second_halving(self, f, nf, d1, value, note, why):
        """``truncation`` from two successive changes ``d_1`` (``n_h`` against ``n_f``) and ``d_2`` (``n_f``
        against ``2 n_f``): ``d_1 + d_2 / (1 - 2^-p)``, ``p`` their observed rate within
        ``[MIN_RATE, MAX_RATE]``."""
        ff = self.resolve(f, harmonics=2 * nf)
        if ff is None:
            return None, f"not estimated: {note}, not trusted ({why}), and the re-solve at n_h = {2 * nf} failed"
        d2 = amplitude_change(f, ff, self.floor)
        p = MIN_RATE if d2 <= 0 or d1 <= 0 else min(MAX_RATE, max(MIN_RATE, math.log2(d1 / d2)))
        if d2 <= 0:
            p = MAX_RATE
        out = d1 + d2 / (1.0 - 2.0 ** -p)
        return max(out, value), (f"{note}, not trusted ({why}): second doubling, change {d2:.3g} from n_h = {nf} to "
                                 f"{2 * nf}: d_1 + d_2 / (1 - 2^-p), p = {p:.3g}")

    def rate(self, kind, d, pair=None):
        """The rate ``p`` of the estimate ``kind`` with the amplitude change ``d`` at ratio 2: :data:`RATE`, or
        the rate observed against the previous level's change (Richardson), within ``[MIN_RATE, MAX_RATE]``;
        after three successive doublings, the slowest of the last :data:`RATE_WINDOW` observed rates (module
        docstring, "Irregular convergence")."""
        last = self.diffs.get(kind)
        self.diffs[kind] = d
        seq = self.changes.setdefault(kind, []) if pair is not None else []
        if pair is not None:
            seq.append((pair, d))
        if last is not None and d > 0 and last > 0:
            p = math.log2(last / d)
            # the successive doublings that end in this one (each change's finer level the next one's coarser)
            k = len(seq) - 1
            while k > 0 and seq[k - 1][0][1] == seq[k][0][0] and seq[k - 1][1] > 0 and len(seq) - k < RATE_WINDOW + 1:
                k -= 1
            if len(seq) - k >= 3 and seq[-2][1] == last:
                p = min(math.log2(a[1] / b[1]) for a, b in zip(seq[k:-1], seq[k + 1:]))
            return min(MAX_RATE, max(MIN_RATE, p))
        return RATE

    def time_discretisation(self, sol):
        """``(value, note)`` of ``time_discretisation`` (module docstring)."""
        if self.integrator(sol) == "event":
            return 0.0, "the exact event-driven flow (no time steps)"
        N, n = int(sol.steps), int(sol.harmonics)
        low = 2 * n + 2 if self.caps.harmonic_unknowns else 8
        value = note = c = None
        if N % 2 == 0 and N // 2 >= low:
            c = self.resolve(sol, steps=N // 2)
            if c is not None:
                value, note = self._two_changes(sol, c, N, low)
        if value is None and 2 * N <= MAX_STEPS:
            f = self.resolve(sol, steps=2 * N)
            if f is not None:
                d = amplitude_change(sol, f, self.floor)
                value, note = d / (1.0 - 2.0 ** -RATE), f"amplitude change {d:.3g} against {2 * N} steps, / (1 - 2^-p)"
        if value is None:
            return None, (f"not estimated: the re-solves at {N // 2} and {2 * N} steps failed "
                          f"({'; '.join(self.failures[-2:])})")
        if value <= self.accuracy and c is not None:
            # about to pass: the part of the error that halving the step does not see, measured at N / 2 (half the
            # cost): the change there when the grid is shifted by half a step, halved (first order), doubled (one
            # alignment's error against the spread of two)
            shift = self.grid_shift(c)
            if shift is not None:
                value, note = value + shift, (f"{note}; + {shift:.3g}, the change at {N // 2} steps when the grid is "
                                              f"shifted by half a step (the events' places on the grid)")
        step = self.impact_step(sol)
        if step > value:
            value, note = step, f"{note}; one step at the impacts, h J / (2 max A) = {step:.3g}, is larger (first order)"
        return value, note

    def _two_changes(self, sol, c, N, low):
        """``(value, note)`` of ``time_discretisation`` from the changes ``d_1`` (``N`` against ``N / 2`` steps,
        ``c``) and ``d_2`` (``N / 2`` against ``N / 4``; module docstring, "irregular convergence")."""
        d1 = amplitude_change(sol, c, self.floor)
        first = "time_discretisation" not in self.diffs  # no previous level: never below the one-change estimate
        self.diffs["time_discretisation"] = d1
        head = f"amplitude change d_1 = {d1:.3g} against {N // 2} steps"
        # d_1 alone fails the request at any rate the scheme can have: the next level has this change for free
        if d1 / (2.0 ** MAX_RATE - 1.0) > self.accuracy or N % 4 or N // 4 < low:
            return d1 / (2.0 ** RATE - 1.0), f"{head}, / (2^p - 1), p = {RATE:g}"
        c2 = self.resolve(c, steps=N // 4)
        if c2 is None:
            return d1 / (2.0 ** RATE - 1.0), f"{head}, / (2^p - 1), p = {RATE:g} (no re-solve at {N // 4} steps)"
        d2 = amplitude_change(c, c2, self.floor)
        head += f", d_2 = {d2:.3g} ({N // 2} against {N // 4})"
        if d1 > 0 and d2 > 0 and MIN_RATE <= math.log2(d2 / d1) <= IRREGULAR_RATE:
            p = min(MAX_RATE, math.log2(d2 / d1))
            if first and p > RATE:
                return d1 / (2.0 ** RATE - 1.0), f"{head}, observed rate {p:.3g}, first level: d_1 / (2^p - 1), p = 1"
            return d1 / (2.0 ** p - 1.0), f"{head}, observed rate p = {p:.3g}: d_1 / (2^p - 1)"
        if d1 >= d2:  # not decreasing (yet): the next change, N against 2 N, tells noise from slow convergence
            slow = d1 / (2.0 ** MIN_RATE - 1.0), f"{head}, not decreasing: d_1 / (2^p - 1), p = {MIN_RATE:g}"
            if d1 > self.accuracy or 2 * N > MAX_STEPS:  # (fails the request whatever the next change is)
                return slow
            f = self.resolve(sol, steps=2 * N)
            if f is None:
                return slow[0], f"{slow[1]} (no re-solve at {2 * N} steps)"
            d0 = amplitude_change(sol, f, self.floor)
            head += f", d_0 = {d0:.3g} ({N} against {2 * N})"
            # the changes of a convergent scheme of order 1 (Moreau-Jean) fall as 2^-j; changes that do not are the
            # events' places on the grid moving: the envelope of the three changes at first order, each as the
            # change N -> 2 N (d_0, d_1 / 2, d_2 / 4), summed from N on: 2 max(...)
            env = max(d0, d1 / 2.0, d2 / 4.0)
            return 2.0 * env, f"{head}, irregular (d_1 >= d_2): 2 max(d_0, d_1 / 2, d_2 / 4), first order"
        # faster than the scheme's order: a cancellation, not convergence; the envelope of the two changes at
        # first order
        env = max(d1, d2 / 2.0 ** RATE)
        return env / (2.0 ** RATE - 1.0), (f"{head}, irregular (faster than rate {IRREGULAR_RATE:g}): "
                                           f"max(d_1, d_2 / 2^p) / (2^p - 1), p = {RATE:g}")

    def grid_shift(self, sol):
        """The amplitude change when the time grid is shifted by half a step against the forcing (the forcing
        phase-shifted by ``omega h / 2``, the answer as the start), or ``None`` (no re-solve).  The Moreau-Jean
        error at an impact or a slip reversal depends on where the event falls between two grid points, a
        part that a halving of the step can leave unchanged (module docstring, "irregular convergence")."""
        if getattr(self.system, "base", None) is not None:
            return None
        tau = 0.5 * float(sol.time_step)

        def rotate(F):
            F = np.array(F, dtype=float)
            for k in range(1, (F.shape[0] - 1) // 2 + 1):
                a = k * self.omega * tau
                c, s = F[2 * k - 1].copy(), F[2 * k].copy()
                F[2 * k - 1], F[2 * k] = c * math.cos(a) + s * math.sin(a), s * math.cos(a) - c * math.sin(a)
            return F

        t = time.perf_counter()
        opts = self.settings(sol)
        try:
            with _resolve_box(sol, RESOLVE_EVALUATIONS):
                alt = self.route._solve(self.system.map_forcing(rotate), self.omega, self.method,
                                        dict(opts, guess=sol), ladder_starts=("guess",))
        except InputError:
            alt = None
        self.spent += time.perf_counter() - t
        if alt is None or not alt.success:
            return None
        return amplitude_change(sol, alt, self.floor)

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
        sub = (sol.certificate.info.get("model_substitution") or {}) if sol.certificate is not None else {}
        if sub.get("value_basis") == IMPACT_MASS_PENDING and only in (None, "model_substitution"):
            old = sol.certificate["model_substitution"].note
            out["model_substitution"] = value, note = self.impact_mass(sol, sub["described"])
            if value is not None:  # the message named it "not estimated" (certificate.verdict.apply_certificate)
                sol.message = sol.message.replace(f"; model substitution: {old} (not estimated)",
                                                  f"; model substitution: {note} (estimated relative amplitude "
                                                  f"error {value:.3g})")
        return out

    def impact_mass(self, sol, what):
        """``(value, note)`` of ``model_substitution`` for MS-HBM's subsystem impact law (module docstring)."""
        opts = dict(self.settings(sol), impact_mass="effective", integrator="event")
        opts.pop("accumulation", None)  # (the effective law's own default: the Zeno closure)
        t = time.perf_counter()
        try:
            with _resolve_box(sol, IMPACT_MASS_EVALUATIONS):
                # the exact orbit first: Newton from the subsystem law's orbit (one impact on the reduced cantilever,
                # where the effective mass's bounces accumulate) took ~20 s
                alt = self.route._solve(self.system, self.omega, self.method, dict(opts, guess=sol),
                                   ladder_starts=("exact", "guess", "transient"))
            why = "" if alt.success else alt.message[:200]
        except InputError as exc:
            alt, why = None, str(exc)[:200]
        self.spent += time.perf_counter() - t
        if why:
            return None, (f"{what}: not estimated (the re-solve with impact_mass 'effective' and the event-driven "
                          f"flow failed: {why})")
        d = amplitude_change(sol, alt, self.floor)
        steps = ("; it includes the time steps' error, which time_discretisation also counts"
                 if self.integrator(sol) != "event" else "")
        return d, (f"{what}: amplitude change {d:.3g} against the re-solve with the effective impact mass "
                   f"(impact_mass 'effective', event-driven flow, n_h = {int(sol.harmonics)}{steps})")

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
    est.solved.setdefault(est.key(est.settings(sol)), sol)  # each level is the next level's coarse partner
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
        key = est.key(opts)
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
        est.solved.setdefault(key, new)
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
    sol.wall_time = float(sol.wall_time) + est.spent if len(levels) == 1 else time.perf_counter() - t0
    return sol


def _only_accuracy(sol):
    """The certificate of ``sol`` fails on ``accuracy`` only (a refinement can help)."""
    return sol.certificate.failed == ["accuracy"]


def _fresh(sol):
    """A copy of ``sol`` whose certificate has no estimates yet (a cached re-solve is another level's partner)."""
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
