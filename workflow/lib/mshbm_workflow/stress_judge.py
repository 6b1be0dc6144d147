"""Stress suite (workflow/scripts/stress/stress.py): running one solve and judging its answer.

:func:`run_solve` runs one solve (exceptions and CPU budgets caught), :func:`evaluate` classifies it
(``converged``, ``failed-with-diagnosis``, ``failed-certificate``, ``truncation-warned``, ``WRONG``) against references
(full shooting, the same method at a higher resolution or a nearby frequency); the residual claimed
by a converged solve is re-evaluated with the public scaling of Newton's test
(:func:`mshbm.scaling.residual_norm`).
"""
from __future__ import annotations

import math
import signal
import time
import warnings

import numpy as np

import mshbm
from mshbm import InputError
from mshbm.scaling import residual_norm
from mshbm.api import solve_with_continuation
from mshbm_workflow.stress_cases import linear_resonances

OUTCOMES = ("converged", "failed-with-diagnosis", "failed-certificate", "truncation-warned", "WRONG")


def amp_error(amp, ref_amp, floor=0.0):
    """``max_i |A_i - A_ref,i| / max(max_i |A_ref,i|, floor)``."""
    amp, ref_amp = np.asarray(amp, float), np.asarray(ref_amp, float)
    scale = max(float(np.max(np.abs(ref_amp))), float(floor))
    if not np.all(np.isfinite(amp)):
        return math.inf
    if scale == 0.0:
        return float(np.max(np.abs(amp)))
    return float(np.max(np.abs(amp - ref_amp)) / scale)


def solution_finite(sol):
    arrays = [sol.q_hat, sol.q_time, sol.u_time, sol.lam, sol.x, np.array([sol.residual])]
    if sol.impulses is not None:
        arrays.append(sol.impulses)
    return all(np.all(np.isfinite(a)) for a in arrays) and np.all(np.isfinite(sol.amplitude))


def recheck_residual(system, omega, method, opts, sol, factor):
    """Re-evaluate the residual at the returned unknowns; ``(ok, value, bound)``.  With the integrator that
    produced the answer: the one asked for, or the exact event-driven flow when the solve says it fell back to it
    (``info["integrator"] == "event"``, :meth:`mshbm.route.driver.Route._event_fallback`)."""
    o = {k: v for k, v in opts.items() if k in ("harmonics", "steps", "theta", "partition", "project", "condense",
                                                "integrator", "accumulation")}
    if sol.info.get("integrator") == "event":
        o["integrator"] = "event"
    try:
        problem, _ = mshbm.build_problem(system, omega, method, **o)
        R = problem.residual(np.asarray(sol.x, float), jac=False)[0]
    except Exception as exc:  # noqa: BLE001
        return False, math.nan, f"re-evaluation failed: {type(exc).__name__}: {exc}"
    # the same row scaling as Newton's convergence test (problem.residual_scale: forces by the force
    # scale of the problem, displacements by the size of the solution; mshbm.scaling)
    step = sol.info.get("step_accuracy")
    if step is not None:
        # accepted as periodic to one time step's accuracy (impacts move by whole steps; mshbm.route.ladder): the
        # residual entries against the jump of the residual when an impact moves by one step
        r = float(np.max(np.abs(R) / np.asarray(step["bound"], dtype=float)))
        bound = 1.0  # the certificate's own bound: re-evaluation must reproduce it, no factor
        return bool(np.isfinite(r) and r <= bound), r, bound
    r = residual_norm(problem, sol.x, R)
    bound = factor * float(opts.get("tol", 1e-10))
    return bool(np.isfinite(r) and r <= bound), r, bound


class Ctx:
    """Shared settings of one run (picklable)."""

    def __init__(self, cfg):
        self.cfg = cfg
        self.tol = cfg["tolerance"]
        self.ref = cfg["reference"]


class ReferenceTimeout(Exception):
    """A reference solve exceeded ``reference.max_cpu_s`` (the reference is then unavailable)."""


def _prof_alarm(signum, frame):
    raise ReferenceTimeout("reference solve exceeded its CPU budget")


def run_solve(ctx, system, omega, method, opts, *, use_continuation=False, cpu_budget=None):
    """One solve; returns ``(solution or None, exception or None, wall time)``.

    ``cpu_budget`` (s of CPU time, for reference solves only) stops the solve with
    :class:`ReferenceTimeout` (returned as the exception).
    """
    t0 = time.perf_counter()
    old = None
    # a wall-time budget of the solve (mshbm's max_time): a slow solve ends with a diagnosed failure instead of
    # the group's timeout; at most solve_max_time_s (a reference solve: its CPU budget, as wall time), and what is
    # left of the group's time minus a reserve
    budget = [float(cpu_budget) if cpu_budget else float(ctx.cfg.get("solve_max_time_s", 0.0)) or math.inf]
    end = getattr(ctx, "group_deadline", None)
    if end is not None:
        budget.append(max(1.0, end - t0))
    if math.isfinite(min(budget)):
        opts = dict(opts, max_time=min(budget))
    if cpu_budget:
        old = signal.signal(signal.SIGPROF, _prof_alarm)
        signal.setitimer(signal.ITIMER_PROF, float(cpu_budget))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if use_continuation:
                sol = solve_with_continuation(system, omega, method, stability=False, **opts)
            else:
                sol = mshbm.solve(system, omega, method, stability=False, **opts)  # convergence only
        return sol, None, time.perf_counter() - t0
    except TimeoutError:
        raise
    except Exception as exc:  # noqa: BLE001 -- classified below
        return None, exc, time.perf_counter() - t0
    finally:
        if cpu_budget:
            signal.setitimer(signal.ITIMER_PROF, 0.0)
            signal.signal(signal.SIGPROF, old)


def reference_shooting(ctx, system, omega, guess=None, nearby=True):
    """Shooting reference ``(solution, note, is_nearby)`` or ``(None, why, False)``."""
    if system.n > ctx.ref["max_dofs"]:
        return None, f"no shooting reference (n={system.n} > {ctx.ref['max_dofs']})", False
    steps = int(ctx.ref["steps"])
    trials = [(omega, "same omega", False)]
    if nearby:
        trials += [(omega * (1 + d), f"omega*(1{d:+g})", True) for d in ctx.ref["nearby"]]
    for om, note, near in trials:
        opts = {"steps": steps}
        if guess is not None:
            opts["guess"] = guess
        sol, exc, _ = run_solve(ctx, system, om, "shooting", opts, cpu_budget=ctx.ref.get("max_cpu_s"))
        if isinstance(exc, ReferenceTimeout):
            return None, f"shooting reference exceeded {ctx.ref.get('max_cpu_s')} s CPU", False
        if sol is not None and sol.success and solution_finite(sol):
            start = "from this solution" if guess is not None else "from the linear start"
            return sol, f"shooting N={steps} {start} at {note}", near
        if sol is not None and "time budget max_time" in sol.message:  # its wall-time budget (run_solve): no retries
            return None, f"shooting reference exceeded its time budget ({ctx.ref.get('max_cpu_s')} s)", False
    return None, "shooting reference did not converge", False


def row_tolerance(ctx, method, opts):
    """The method's tolerance; ``few_harmonics.tolerance`` for ``n_h <= few_harmonics.max_harmonics``."""
    tol = float(ctx.tol[method])
    few = ctx.cfg.get("few_harmonics")
    if few and method != "shooting" and int(opts.get("harmonics", 5)) <= int(few["max_harmonics"]):
        tol = max(tol, float(few["tolerance"]))
    return tol


def resonance_distance(system, omega, n_h):
    """``min_{k <= n_h, r} |k omega / omega_r - 1|`` over the eigenfrequencies of ``(K_LL, M_LL)``."""
    try:
        wr = linear_resonances(system)
    except Exception:  # noqa: BLE001
        return 0.0
    wr = wr[wr > 0]
    if wr.size == 0:
        return math.inf
    k = np.arange(1, n_h + 1)[:, None]
    return float(np.min(np.abs(k * omega / wr[None, :] - 1.0)))


def linear_scale(system, omega):
    """Largest amplitude of the linear response (elements removed); 0 if it cannot be computed."""
    from mshbm import fourier
    from mshbm.methods.common import linear_response

    try:
        q = fourier.ifft(linear_response(system, omega, 5), 64)
        a = float(np.max(0.5 * (q.max(axis=0) - q.min(axis=0))))
    except Exception:  # noqa: BLE001
        return 0.0
    return a if math.isfinite(a) else 0.0


def evaluate(ctx, row, system, omega, method, opts, sol, exc, ref_cache):
    """Fill outcome/error/residual/reference/message of ``row``.

    Errors are relative to the largest reference amplitude, floored at ``error_floor`` x the largest
    amplitude of the linear response (so that a solution at rest, e.g. permanent stick, is not
    compared relatively to round-off).  References, tried in order until one agrees within the
    tolerance:

    1. full shooting (``reference.steps``) from the linear start at the same omega;
    2. full shooting started from the solution under test (it then is a genuine periodic solution,
       possibly one of several coexisting ones);
    3. HBM only (it solves the regularised model, not the set-valued one): HBM itself with
       ``reference.highres_harmonics_factor`` times the harmonics, started from the solution (the converged answer of its own model);
    4. only if none of 1-3 exists: the same method with that many more harmonics and 2x steps (systems too large
       for shooting), then shooting or the same method at nearby frequencies (tolerance +
       ``nearby_allowance``; skipped within 20x the offset of a resonance of H_LL).

    A solution that disagrees with every reference that exists is WRONG; with none it is "converged
    (no reference)".  ``error_setvalued`` is the error against reference 1 whenever it exists.
    """
    tol = row_tolerance(ctx, method, opts)
    if "floor" not in ref_cache:
        ref_cache["floor"] = float(ctx.cfg.get("error_floor", 1e-3)) * linear_scale(system, omega)
    floor = ref_cache["floor"]
    row["tolerance"] = tol
    row["error"] = None
    row["reference"] = ""
    if exc is not None:
        if isinstance(exc, InputError):
            row.update(outcome="failed-with-diagnosis", message=f"InputError {exc.key}: {exc.problem}", residual=None)
        else:
            row.update(outcome="WRONG", message=f"crash: {type(exc).__name__}: {exc}", residual=None)
        return row
    row["residual"] = float(sol.residual) if math.isfinite(sol.residual) else None
    row["iterations"] = int(sol.iterations)
    row["message"] = " ".join(str(sol.message).split())
    if "continuation" in sol.info:
        row["continuation"] = sol.info["continuation"]["used"]
    cert = getattr(sol, "certificate", None)
    row["certificate"] = None if cert is None else cert.failed
    row["step_accuracy"] = "step_accuracy" in sol.info
    if not sol.success:
        row["outcome"] = "failed-with-diagnosis" if row["message"] else "WRONG"
        if row["message"].startswith("certificate failed"):  # Newton converged, the certificate refused
            row["outcome"] = "failed-certificate"
        if not row["message"]:
            row["message"] = "success=False without a message"
        return row
    if cert is None or not cert.passed:
        row.update(outcome="WRONG", message="success=True without a passed certificate: " + row["message"])
        return row
    if not solution_finite(sol):
        row.update(outcome="WRONG", message="success=True with NaN/inf in the solution: " + row["message"])
        return row
    ok, r, bound = recheck_residual(system, omega, method, opts, sol, ctx.cfg["residual_check_factor"])
    row["residual_recheck"] = r if math.isfinite(r) else None
    if not ok:
        row.update(outcome="WRONG", message=f"success=True but the residual re-evaluates to {r:.3g} > {bound}")
        return row
    amp = sol.amplitude
    tried = []  # (error, allowance, note)

    def agrees(ref_sol, note, allowance=0.0):
        err = amp_error(amp, ref_sol.amplitude, floor)
        tried.append((err, allowance, note, ref_sol))
        if err <= tol + allowance:
            row.update(outcome="converged", error=err, reference=note)
            _garbage(ctx, row, amp, ref_sol.amplitude)
            return True
        return False

    small = system.n <= ctx.ref["max_dofs"]
    # 1. the primary reference (shared by the rows of a group)
    if "primary" not in ref_cache:
        ref_cache["primary"] = reference_shooting(ctx, system, omega, nearby=False)
    ref, note, _ = ref_cache["primary"]
    if ref is not None:
        row["error_setvalued"] = amp_error(amp, ref.amplitude, floor)
        if agrees(ref, note):
            return row
    # 2. shooting from this solution
    if small:
        ref2, note2, _ = reference_shooting(ctx, system, omega, guess=sol, nearby=False)
        if ref2 is not None:
            extra = "" if ref is None else f" (coexisting solution: {row['error_setvalued']:.2g} from the linear-start reference)"
            if agrees(ref2, note2 + extra):
                return row
    # 3. HBM: its own model at a higher resolution
    if method == "hbm":
        ref3, note3 = same_method_highres(ctx, system, omega, method, opts, sol)
        if ref3 is not None:
            extra = "" if ref is None else f"; {row['error_setvalued']:.2g} from set-valued shooting"
            if agrees(ref3, note3 + " (regularised model)" + extra):
                return row
    # 4. weaker references, only when nothing above exists
    if not tried:
        n_h_ref = max(int(opts.get("harmonics", 5)), 10)
        dist = resonance_distance(system, omega, n_h_ref)
        near_ok = dist > 20.0 * max([abs(d) for d in ctx.ref["nearby"]] + [0.0])
        why = "no converged reference"
        if not small and method != "hbm":
            ref4, note4 = same_method_highres(ctx, system, omega, method, opts, sol)
            if ref4 is not None and agrees(ref4, note4):
                return row
            why = note4 if ref4 is None else why
        if not tried and near_ok:
            if small:
                if "nearby" not in ref_cache:
                    ref_cache["nearby"] = reference_shooting(ctx, system, omega, nearby=True)
                refn, noten, _ = ref_cache["nearby"]
                if refn is not None and agrees(refn, noten, float(ctx.cfg["nearby_allowance"])):
                    return row
            if not tried:
                refn, noten = same_method_nearby(ctx, system, omega, method, opts, sol)
                if refn is not None and agrees(refn, noten, float(ctx.cfg["nearby_allowance"])):
                    return row
        elif not tried:
            why += f"; nearby frequencies are no reference within {dist:.1g} of a resonance of H_LL"
        if not tried:
            row.update(outcome="converged", reference=f"no reference ({why})")
            return _garbage(ctx, row, amp, None, system=system, omega=omega)
    err, allowance, note, ref_sol = min(tried, key=lambda t: t[0] - t[1])
    if _truncation_warned(ctx, row, system, omega, method, opts, sol, cert, err, tol + allowance, note, ref_sol,
                          floor):
        return row
    row.update(outcome="WRONG", error=err, reference=note,
               message=f"success=True but error {err:.3g} > tolerance {tol + allowance:g}; " + row["message"])
    return row


def _truncation_warned(ctx, row, system, omega, method, opts, sol, cert, err, tol, note, ref_sol, floor):
    """``truncation-warned``: a certified answer outside the tolerance whose error is the harmonic truncation that
    its own certificate warned of (a truncation estimate above its bound, named in the message), and shown to be:
    the same method with ``highres_harmonics_factor`` times the harmonics and twice the steps, started from this
    answer, agrees with the same reference within the tolerance.  Not counted as converged, and not WRONG: the
    answer did not claim to be accurate to the tolerance.  Only where that refinement is a new solve (not when
    the reference is that same refinement, systems too large for shooting).  Sets the row and returns True."""
    trunc = [c for c in cert.warnings if c.startswith("truncation")]  # (not the regularisation estimate)
    if method == "shooting" or not trunc or note.startswith("same method,"):
        return False
    hi, note_hi = same_method_highres(ctx, system, omega, method, opts, sol)
    if hi is None:
        return False
    err_hi = amp_error(hi.amplitude, ref_sol.amplitude, floor)
    if not err_hi <= tol:
        return False
    warned = ", ".join(f"{c} {cert[c].value:.3g}" for c in trunc)
    row.update(outcome="truncation-warned", error=err, reference=note,
               message=f"success=True with error {err:.3g} > tolerance {tol:g}, a harmonic truncation error: the "
                       f"certificate warned ({warned} > {cert[trunc[0]].bound:g}), and the {note_hi} has "
                       f"error {err_hi:.2g}; " + row["message"])
    return True


def same_method_nearby(ctx, system, omega, method, opts, sol):
    for d in ctx.ref["nearby"]:
        o = dict(opts)
        o["guess"] = sol
        r, exc, _ = run_solve(ctx, system, omega * (1 + d), method, o, cpu_budget=ctx.ref.get("max_cpu_s"))
        if r is not None and r.success and solution_finite(r):
            return r, f"same method at omega*(1{d:+g}), started from this solution"
    return None, "no converged reference at nearby frequencies"


def same_method_highres(ctx, system, omega, method, opts, sol):
    o = dict(opts)
    n_h = int(o.get("harmonics", 5))
    factor = int(ctx.ref.get("highres_harmonics_factor", 3))
    o["harmonics"] = factor * n_h
    o["steps"] = 2 * int(o.get("steps", mshbm.api.default_steps(method, n_h)))
    if method == "hbm":
        o["steps"] = max(o["steps"], mshbm.api.default_steps("hbm", factor * n_h))
    o["guess"] = sol
    r, exc, _ = run_solve(ctx, system, omega, method, o, cpu_budget=ctx.ref.get("max_cpu_s"))
    if isinstance(exc, ReferenceTimeout):
        return None, f"the higher-resolution solve exceeded {ctx.ref.get('max_cpu_s')} s CPU"
    if r is not None and r.success and solution_finite(r):
        return r, f"same method, {factor}x harmonics and 2x steps (n_h={o['harmonics']}, N={o['steps']})"
    return None, "the higher-resolution solve did not converge"


def _garbage(ctx, row, amp, ref_amp, system=None, omega=None):
    if ref_amp is None:
        from mshbm.methods.common import linear_response

        try:
            qh = linear_response(system, omega, 5)
            scale = float(np.max(np.abs(qh))) * 10 + 1.0
        except Exception:  # noqa: BLE001
            scale = 1.0
    else:
        scale = float(np.max(np.abs(ref_amp))) + 1e-300
    if float(np.max(np.abs(amp))) > ctx.cfg["garbage_factor"] * scale:
        row.update(outcome="WRONG", message=f"garbage: amplitude {np.max(np.abs(amp)):.3g} vs scale {scale:.3g}")
    return row


def opt_text(method, opts):
    parts = []
    for k in ("harmonics", "steps", "guess"):
        if k in opts:
            v = opts[k]
            if k == "guess" and not isinstance(v, str):
                v = f"solution at omega={v.omega:.4g}" if hasattr(v, "omega") else "dict"
            parts.append(f"{ {'harmonics': 'n_h', 'steps': 'N', 'guess': 'guess'}[k] }={v}")
    return ", ".join(parts)


def new_row(category, case, omega, method, opts, **extra):
    row = {"category": category, "case": case, "omega": float(omega), "method": method,
           "options": opt_text(method, opts)}
    row.update(extra)
    return row


def solve_and_evaluate(ctx, category, case, system, omega, method, opts, ref_cache, use_continuation=False,
                       **extra):
    sol, exc, wall = run_solve(ctx, system, omega, method, opts, use_continuation=use_continuation)
    row = new_row(category, case, omega, method, opts, **extra)
    if use_continuation:
        row["options"] += (", " if row["options"] else "") + "continuation"
    row["time_s"] = wall
    evaluate(ctx, row, system, omega, method, {k: v for k, v in opts.items()}, sol, exc, ref_cache)
    return row, sol
