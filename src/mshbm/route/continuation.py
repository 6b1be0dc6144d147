"""Globalisation of :func:`mshbm.solve` by restarts and natural-parameter continuation.

Newton's method converges only from a start close enough to the periodic
solution.  When a direct solve fails (a poor start: zero, or a solution at a far
frequency), :func:`solve_with_continuation` tries, in order, until one succeeds:

``"linear"``
    a restart from the linear response (the default start of :func:`mshbm.solve`),
    if the given start was something else;
``"omega"``
    continuation in the forcing frequency from the frequency of the given start
    (when ``guess`` is a :class:`PeriodicSolution` at another ``omega``):
    ``omega(lam) = omega_g (omega / omega_g)^lam``, ``lam`` from 0 to 1;
``"forcing"``
    continuation in the forcing amplitude: ``f_ex -> s f_ex`` with ``s`` from a
    small value to 1.  At small forcing a contact with a positive gap stays open
    (the linear response is the exact solution; the start value of ``s`` is chosen
    just below the first touch) and friction sticks;
``"friction"``
    continuation in the friction bound ``mu F_N -> s mu F_N`` (friction elements
    only), from nearly free sliding (nearly linear) to the requested bound;
``"transient"``
    globalisation by simulation: the whole system is integrated by Moreau-Jean
    from the given start for a growing number of periods (checkpoints
    ``transient_periods``) and Newton restarts from the last simulated period.
    This finds the attracting periodic solutions (damped systems); it is skipped
    for systems too large to integrate in full (``transient_budget``).

Every stage is an ordinary call of :func:`mshbm.solve` with the caller's options
and a start predicted from the previous converged stages (secant predictor,
falling back to the last solution itself).  The step in the continuation
parameter doubles after a success and halves after a failure.  The returned
solution is always the result of a final, ordinary solve of the *original*
system at the *requested* ``omega`` with the caller's options, so ``success``
means exactly what it means for :func:`mshbm.solve`; the path taken is in
``solution.info["continuation"]``.

Positive homogeneity: for a chain with friction (and no constant force) scaling
the forcing by ``s`` is the same as scaling the friction bound by ``1/s`` (the
solution scales by ``s``); for a contact, the same as scaling the gap by ``1/s``.
The two continuations ``"forcing"`` and ``"friction"`` therefore approach the
requested problem from the two sides (much stick / much slip).
"""
from __future__ import annotations

import math
import time

import numpy as np

from .. import fourier
from .. import stability as _stability
from .._blas import blas_threads, check_threads
from ..errors import ConvergenceError, InputError
from ..options import default_harmonics
from ..integrators.moreau_jean import MAX_DENSE_DOFS, MoreauJean
from ..methods.common import guess_parts, linear_response
from ..result import PeriodicSolution
from ..system import System
from .options import capabilities, without

__all__ = ["solve_with_continuation", "scaled_system", "STRATEGIES"]

#: strategies in the default order
STRATEGIES = ("linear", "transient", "omega", "forcing", "friction")


def scaled_system(system, forcing=1.0, friction=1.0):
    """Copy of ``system`` with the forcing scaled by ``forcing`` and every friction bound by ``friction``.

    The matrices are shared (no copy, no re-validation).
    """
    if not isinstance(system, System):
        raise InputError("system", f"must be an mshbm.System, got {type(system).__name__}")
    els = tuple(e.bound_scaled(friction) if friction != 1.0 else e for e in system.elements)
    new = system.map_forcing(lambda f: f * float(forcing)).with_elements(els)
    return new


def _inner(method, options):
    """Options of the solves made here: ``continuation=False`` (Newton from the stage's start, no ladder and
    no continuation of its own), except for penalty laws (HBM), whose ``continuation`` is the problem's own
    regularisation homotopy."""
    opts = dict(options)
    if not capabilities(method).penalty_laws:
        opts["continuation"] = False
    return opts


def _state(sol):
    """Continuation state of a solution: (q_hat, q0, u0)."""
    return (sol.q_hat.copy(),) + sol.initial_state()  # no time grid of all DOFs


def _predict(points, lam):
    """Guess at parameter ``lam`` from the converged points ``[(lam_i, state_i, sol_i)]``."""
    if len(points) < 2:
        return points[-1][2]
    (l0, s0, _), (l1, s1, _) = points[-2], points[-1]
    if l1 == l0:
        return points[-1][2]
    a = (lam - l1) / (l1 - l0)
    q_hat, q0, u0 = (x1 + a * (x1 - x0) for x0, x1 in zip(s0, s1))
    return {"q_hat": q_hat, "q0": q0, "u0": u0}


def _first_touch_scale(system, omega, n_h=10, samples=256):
    """Largest forcing scale at which the linear response keeps every contact open (inf if always)."""
    contacts = [e for e in system.elements if e.unilateral]
    if not contacts:
        return math.inf
    q_hat = linear_response(system, omega, n_h)
    q = fourier.ifft(q_hat, samples)
    best = math.inf
    for e in contacts:
        # g = gap - q_d(t) > 0 for s * q_d(t) < gap  (the forcing is affine: q = s * q_lin)
        qmax = float(np.max(-e.local(q)))  # g = gap + w^T q
        if qmax > 0:
            best = min(best, e.gap / qmax)
    return best


class _Path:
    """Adaptive natural-parameter continuation ``lam: lam0 -> 1`` of ``solve(problem(lam))``."""

    def __init__(self, make, method, options, first_guess, lam0, max_stages, min_step, stage_max_iter, solve):
        self.make, self.method, self.options, self.solve = make, method, options, solve
        self.first_guess, self.lam0 = first_guess, float(lam0)
        self.max_stages, self.min_step, self.stage_max_iter = max_stages, min_step, stage_max_iter
        self.log = []

    def _solve(self, lam, guess, final):
        system, omega = self.make(lam)
        opts = _inner(self.method, self.options)
        if not final and self.stage_max_iter is not None:
            opts["max_iter"] = min(int(opts.get("max_iter", 50)), self.stage_max_iter)
        opts["raise_on_failure"] = False
        t0 = time.perf_counter()
        try:
            sol = self.solve(system, omega, self.method, guess=guess, **opts)
        except InputError as exc:  # e.g. an intermediate omega on a resonance of H_LL
            self.log.append({"lam": float(lam), "omega": float(omega), "success": False,
                             "message": str(exc), "iterations": 0,
                             "wall_time_s": time.perf_counter() - t0})
            return None
        self.log.append({"lam": float(lam), "omega": float(omega), "success": bool(sol.success),
                         "message": sol.message, "iterations": int(sol.iterations),
                         "wall_time_s": float(sol.wall_time)})
        return sol

    def run(self):
        """Returns ``(solution or None, message, reached)``; ``reached``: a solve at ``lam = 1`` converged."""
        sol = self._solve(self.lam0, self.first_guess, self.lam0 >= 1.0)
        if sol is None or not sol.success:
            return sol, f"the first stage (lambda={self.lam0:.3g}) did not converge", False
        if self.lam0 >= 1.0:
            return sol, "reached lambda=1", True
        points = [(self.lam0, _state(sol), sol)]
        lam, step = self.lam0, (1.0 - self.lam0) / 4
        while True:
            if len(self.log) >= self.max_stages:
                return sol, f"stopped after {len(self.log)} stages at lambda={lam:.4g}", False
            nxt = min(1.0, lam + step)
            final = nxt >= 1.0
            new = self._solve(nxt, _predict(points, nxt), final)
            if (new is None or not new.success) and len(points) >= 2:
                new = self._solve(nxt, points[-1][2], final)  # plain previous solution
            if new is not None and new.success:
                if final:
                    return new, "reached lambda=1", True
                lam, sol = nxt, new
                points = (points + [(lam, _state(new), new)])[-2:]
                step *= 2.0
                continue
            step *= 0.5
            if step < self.min_step:
                return (new if final and new is not None else sol), \
                    f"step fell below {self.min_step:g} at lambda={lam:.4g}", False


def _transient(solve, system, omega, method, guess, options, periods, budget):
    """Simulate the full system from ``guess`` and restart Newton at each checkpoint of ``periods``.

    Returns ``(solution or None, message, log)``.
    """
    log = []
    n = system.n
    cap = capabilities(method)
    n_h = int(options.get("harmonics", default_harmonics(method)))
    steps = int(options.get("steps", 2048)) if not cap.penalty_laws else 2048  # (HBM's steps are AFT samples)
    steps = max(steps, 2 * n_h + 2)
    total = max(periods)
    if n > MAX_DENSE_DOFS or float(n) * n * steps * total > budget:
        return None, f"skipped: {n} DOFs x {steps} steps x {total} periods exceeds the simulation budget", log
    try:
        _, q, u = guess_parts(guess, system, omega, n_h)
    except InputError as exc:
        return None, f"skipped: {exc}", log
    T = 2 * np.pi / omega
    stepper = MoreauJean(system.M, system.C, system.K, system.elements, T / steps,
                         float(options.get("theta", 0.5)), bool(options.get("project", True)))
    t = np.linspace(0.0, T, steps + 1)
    B = stepper.increments(system.forcing(t, omega))
    done, sol = 0, None
    opts = _inner(method, without(options, "guess"))
    for checkpoint in sorted(periods):
        tr = None
        while done < checkpoint:
            tr = stepper.run(q, u, B)
            q, u = tr.q[-1].copy(), tr.u[-1].copy()
            done += 1
            if not (np.all(np.isfinite(q)) and np.all(np.isfinite(u))):
                return None, f"the simulation diverged after {done} periods", log
        drift = float(np.max(np.abs(np.concatenate([tr.q[-1] - tr.q[0], tr.u[-1] - tr.u[0]]))))
        g = {"q_hat": fourier.fft(tr.q[:-1], n_h), "q0": q, "u0": u}
        t0 = time.perf_counter()
        sol = solve(system, omega, method, guess=g, **opts)
        log.append({"lam": 1.0, "periods": done, "period_drift": drift, "omega": float(omega),
                    "success": bool(sol.success), "message": sol.message, "iterations": int(sol.iterations),
                    "wall_time_s": time.perf_counter() - t0})
        if sol.success:
            return sol, f"converged after {done} simulated periods", log
    return sol, f"no convergence after {done} simulated periods", log


def solve_with_continuation(system, omega, method="mshbm", guess=None, *, solve, strategies=STRATEGIES,
                            forcing_start=0.05, friction_start=0.02, max_stages=30, min_step=1e-3,
                            stage_max_iter=20, transient_periods=(10, 40, 160), transient_budget=2e9,
                            ladder=True, **options):
    """:func:`mshbm.solve` with restarts and parameter continuation when the direct solve fails.

    Parameters
    ----------
    solve : callable
        The full solver, ``solve(system, omega, method, **options) -> PeriodicSolution``
        (:meth:`mshbm.route.driver.Route.solve` of the caller's route): every stage is a complete solve.
    system : System
    omega : float
        Requested forcing frequency (rad/s).
    method : str
        Any method of :func:`mshbm.solve` (meant for ``"mshbm"`` and ``"mshbm-intermediate"``).
    guess :
        Start of the direct solve, as for :func:`mshbm.solve`.  A
        :class:`PeriodicSolution` at another frequency enables the ``"omega"`` strategy.
    strategies : sequence of str
        Fallbacks tried in order after the direct solve fails (see the module docstring).
    forcing_start, friction_start : float
        First scale of the forcing / friction continuation (the forcing one starts lower,
        just below the first touch, for contacts).
    max_stages : int
        Most intermediate solves per strategy.
    min_step : float
        Smallest step of the continuation parameter before the strategy gives up.
    stage_max_iter : int
        Newton iterations allowed for an intermediate stage (the final stage uses the
        caller's ``max_iter``).
    transient_periods : sequence of int
        Checkpoints (periods simulated so far) of the ``"transient"`` strategy.
    transient_budget : float
        Largest ``n^2 x steps x periods`` simulated by the ``"transient"`` strategy.
    ladder : bool
        When every strategy fails: a last full solve with the start ladder (:mod:`mshbm.route.ladder`, the
        guess its first start), as :func:`mshbm.solve` does by default, so that opting in to continuation
        never ends worse than not doing so (the ladder's starts and the driver, which runs the ladder itself,
        pass ``False``; :func:`mshbm.api.solve_with_continuation` passes ``True``).
    **options
        Options of :func:`mshbm.solve` (``harmonics``, ``steps``, ``tol``, ``blas_threads``...);
        ``blas_threads`` (default 1) also applies to the transient simulation.

    Returns
    -------
    PeriodicSolution
        ``info["continuation"]`` holds ``used`` (strategy that succeeded, or None),
        ``direct`` (message of the direct solve), ``attempts`` (per strategy: its
        stages with parameter, omega, success, iterations, message), ``stages``,
        ``total_iterations`` and ``wall_time_s`` (everything, including the direct solve).

    Raises
    ------
    InputError
        As :func:`mshbm.solve` (invalid input, or ``omega`` on a resonance of ``H_LL``).
    """
    unknown = [s for s in strategies if s not in STRATEGIES]
    if unknown:
        raise InputError("strategies", f"unknown strategy {unknown[0]!r} (choose from {', '.join(STRATEGIES)})")
    # the same BLAS pinning as solve() (bit-identical results whatever the thread settings), also
    # around the transient simulation that runs outside solve()
    stab = _stability.check_option(options.pop("stability", "auto"))
    options["stability"] = False  # intermediate solves: no Floquet analysis; the final solution gets it below
    with blas_threads(check_threads(options.get("blas_threads", 1))):
        sol = _solve_with_continuation(solve, system, omega, method, guess, strategies, forcing_start,
                                       friction_start, max_stages, min_step, stage_max_iter, transient_periods,
                                       transient_budget, options, ladder)
        return _stability.assess(system, sol, stab, theta=options.get("theta", 0.5))


def _solve_with_continuation(solve, system, omega, method, guess, strategies, forcing_start, friction_start,
                             max_stages, min_step, stage_max_iter, transient_periods, transient_budget, options,
                             ladder=False):
    raise_on_failure = bool(options.pop("raise_on_failure", False))
    t0 = time.perf_counter()
    sol = solve(system, omega, method, guess=guess, **_inner(method, options))  # InputError propagates
    info = {"used": None, "direct": sol.message, "attempts": [], "stages": 0}
    total_it = int(sol.iterations)
    direct = sol
    if not sol.success:
        omega = float(omega)
        for strategy in strategies:
            if strategy == "transient":
                final, why, log = _transient(solve, system, omega, method, guess, options, transient_periods,
                                             transient_budget)
                info["attempts"].append({"strategy": strategy, "result": why, "stages": log})
                info["stages"] += len(log)
                total_it += sum(s["iterations"] for s in log)
                if final is not None and final.success:
                    sol, info["used"] = final, strategy
                    break
                continue
            path = _make_path(solve, strategy, system, omega, method, guess, options, forcing_start,
                              friction_start, max_stages, min_step, stage_max_iter)
            if path is None:
                continue
            final, why, reached = path.run()
            info["attempts"].append({"strategy": strategy, "result": why, "stages": path.log})
            info["stages"] += len(path.log)
            total_it += sum(s["iterations"] for s in path.log)
            if reached and final is not None and final.success:
                sol = final
                info["used"] = strategy
                break
        if info["used"] is None:
            tried = ", ".join(f"{a['strategy']} ({a['result']})" for a in info["attempts"]) or "none applicable"
            sol = direct
            sol.message = f"{direct.message}; continuation fallbacks failed: {tried}"
            if ladder and not capabilities(method).penalty_laws and options.get("continuation", True) is not False:
                # the start ladder (the guess first), as mshbm.solve without the opt-in; options without an explicit
                # continuation=True, so the driver does not come back here
                last = solve(system, omega, method, guess=guess, **without(options, "continuation"))
                total_it += int(last.iterations)
                if last.success:
                    info["used"] = "start ladder"
                    last.message = f"{last.message} (by the start ladder after the continuation fallbacks failed: {tried})"
                    sol = last
                else:
                    sol.message = f"{sol.message}; start ladder failed too: {last.message}"
        else:
            sol.message = f"{sol.message} (after {info['used']} continuation, {info['stages']} stages)"
    info["total_iterations"] = total_it
    info["wall_time_s"] = time.perf_counter() - t0
    sol.info["continuation"] = info
    if raise_on_failure and not sol.success:
        raise ConvergenceError(sol.message)
    return sol


def _make_path(solve, strategy, system, omega, method, guess, options, forcing_start, friction_start, max_stages,
               min_step, stage_max_iter):
    args = (method, options)
    kw = dict(max_stages=max_stages, min_step=min_step, stage_max_iter=stage_max_iter, solve=solve)
    if strategy == "linear":
        if guess is None or (isinstance(guess, str) and guess == "linear"):
            return None
        return _Path(lambda lam: (system, omega), *args, first_guess="linear", lam0=1.0, **kw)
    if strategy == "omega":
        if not isinstance(guess, PeriodicSolution) or not guess.success or guess.omega == omega:
            return None
        w0 = float(guess.omega)
        return _Path(lambda lam: (system, w0 * (omega / w0) ** lam), *args, first_guess=guess, lam0=0.0, **kw)
    if strategy == "forcing":
        s0 = float(forcing_start)
        touch = _first_touch_scale(system, omega)
        if math.isfinite(touch):
            s0 = min(0.9 * touch, 0.5) if touch > 0 else s0
        s0 = max(s0, 1e-6)
        return _Path(lambda lam: (scaled_system(system, forcing=lam), omega), *args, first_guess="linear",
                     lam0=s0, **kw)
    if strategy == "friction":
        if not any(e.bounded for e in system.elements):
            return None
        return _Path(lambda lam: (scaled_system(system, friction=lam), omega), *args, first_guess="linear",
                     lam0=float(friction_start), **kw)
    raise AssertionError(strategy)  # pragma: no cover
