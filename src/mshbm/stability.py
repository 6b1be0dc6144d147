"""Stability (Floquet multipliers) of a periodic solution, valid for the nonsmooth flow.

Notation: ``n`` DOFs, state ``(q, u)`` of shape ``(2n,)``, period ``T = 2 pi / omega``.
The Floquet multipliers ``mu`` are the eigenvalues of the monodromy matrix
``Phi = d(q, u)(t_s + T) / d(q, u)(t_s)`` of the periodic orbit; the orbit is
asymptotically stable when every ``|mu| < 1`` and unstable when one ``|mu| > 1``.

Every result of :func:`mshbm.solve` carries

* ``floquet_multipliers`` -- complex ndarray, shape ``(2n,)`` (empty when none were computed);
* ``stable`` -- ``True``, ``False``, or ``None`` where the multipliers at hand cannot decide;
* ``stability_method`` -- how they were obtained (:data:`EXACT`, :data:`STEP_MAP`, or
  ``"none: <reason>"``);
* ``stability_reason`` -- why ``stable`` is ``None`` (empty otherwise);
* ``info["stability"]`` -- details (largest modulus, tolerance, distance between the exact
  orbit and the solution, wall time).

How (:func:`assess`):

1. **Friction and contact elements on single DOFs (any number), n <= MAX_EXACT_DOFS** (or
   ``stability=True``): the exact event-driven flow (:mod:`mshbm.integrators.event`, several
   elements with simultaneous events) is shot to periodicity, started from the
   converged solution of whichever method (a few Newton iterations), and the multipliers
   are those of its exact monodromy matrix: the products of the closed-form mode flows and
   the saltation matrices ``S = R + (f+ - R f-) c^T / (c^T f-)`` at every impact
   (``R`` the Jacobian of Newton's impact law), slip-stick, stick-slip and slip-reversal
   event.  Verdict when ``| max|mu| - 1 | > EXACT_TOL``.  The exact orbit must lie within
   ``MAX_ORBIT_DISTANCE`` (relative) of the solution, else the verdict is ``None``: the exact
   flow found another orbit.  The multipliers are those of the nonsmooth system (Newton's
   impact law, set-valued friction), also for HBM solutions of its regularised laws.
2. **Otherwise** (relative elements, exact flow failed, or too large): the Moreau-Jean step
   map of the whole system over one period from the solution's state at ``t = 0``
   (``steps`` steps).  Its step Jacobians hold no saltation terms, so it is an *estimate*,
   labelled :data:`STEP_MAP`, and it decides only when the motion is smooth over the period
   (no impulse of a contact, no stick, no reversal of a slip velocity) and
   ``| max|mu| - 1 | > STEP_MAP_TOL``; else ``stable`` is ``None``.  Never a verdict from the
   step map at impacts, where its multipliers are wrong (on the 5-DOF impact chain of the
   paper even the sign and the side of the unit circle of the largest one).
3. Above ``MAX_EXACT_DOFS`` by default, or with ``stability=False``, or for a solve that did
   not converge: nothing is computed, ``stable = None``.

``MAX_EXACT_DOFS = 200``: the exact flow works with dense ``(2n+1+2n_f)``-square matrices
(matrix exponentials, monodromy products), so its cost grows like ``n^3`` (a few seconds at
``n = 200`` on one thread).  ``stability=True lifts the limit (up to the event flow's own
:data:`mshbm.integrators.event.MAX_DOFS` = 1000; above it the step map's estimate with the reason).
"""
from __future__ import annotations

import time

import numpy as np

from .errors import InputError
from .floquet import EXACT, EXACT_TOL, STEP_MAP, STEP_MAP_TOL, _set, _verdict, check_option, set_exact  # noqa: F401
from .result import describe_stability as describe, multipliers_json

__all__ = ["assess", "check_option", "describe", "multipliers_json", "set_exact", "MAX_EXACT_DOFS", "EXACT", "STEP_MAP"]

#: largest system for which the exact flow is used by default (see the module docstring)
MAX_EXACT_DOFS = 200
#: wall-time limit (s) of the exact flow's periodic solve in the stability analysis, well above what the exact
#: flow needs up to MAX_EXACT_DOFS; a flow that has not converged by then (an event sequence that makes no progress,
#: e.g. a slip velocity that stays at its switching threshold) is reported as "exact flow failed", never a hang
EXACT_TIME_LIMIT = 20.0
#: most Moreau-Jean steps per period of the step-map estimate (its cost is O(steps n^2))
STEP_MAP_MAX_STEPS = 16384
#: the exact periodic orbit must be this close (relative, amplitudes and section state) to the solution
MAX_ORBIT_DISTANCE = 0.25

def assess(system, sol, stability="auto", steps=None, theta=0.5):
    """Set the stability fields of ``sol`` (in place) and return it.

    Parameters
    ----------
    system : System
        The system ``sol`` solves.
    sol : PeriodicSolution
        A solution of any method.
    stability : {"auto", True, False}
        ``"auto"``: the exact flow up to :data:`MAX_EXACT_DOFS` DOFs; ``True``: at any size;
        ``False``: nothing computed.
    steps : int, optional
        Moreau-Jean steps per period of the step-map estimate (default: those of ``sol``,
        at least 1024, at most :data:`STEP_MAP_MAX_STEPS`).
    theta : float
        Moreau-Jean parameter of the step-map estimate.

    Returns
    -------
    PeriodicSolution
    """
    stability = check_option(stability)
    t0 = time.perf_counter()
    n = system.n
    if stability is False:
        return _set(sol, None, None, "none: not computed (stability=False)",
                    "stability analysis switched off (stability=False)")
    if not sol.success:
        return _set(sol, None, None, "none: the solve did not converge",
                    "no converged periodic solution to analyse")
    if n > MAX_EXACT_DOFS and stability is not True:  # "auto"
        why = (f"n = {n} DOFs > {MAX_EXACT_DOFS}: the exact flow needs dense matrices of the whole system "
               f"(cost ~ n^3, 9.5 s at 400 DOFs), skipped by default; pass stability=True to compute it")
        return _set(sol, None, None, "none: system too large for the default analysis", why)
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # failures end in a reason
            return _assess(system, sol, stability, steps, theta, t0)
    except Exception as exc:  # noqa: BLE001 -- the analysis must never turn a converged solve into a crash
        return _set(sol, None, None, "none: the stability analysis failed",
                    f"the stability analysis failed: {type(exc).__name__}: {exc}")


def _assess(system, sol, stability, steps, theta, t0):
    reason_exact = ""
    if any(el.history for el in system.elements):
        return _set(sol, None, None, "none: not supported for elastic friction",
                    "elastic friction (Jenkins) has a slider state that neither the exact flow nor the "
                    "Moreau-Jean step map carries: no multipliers")
    if any(el.relative_to is not None for el in system.elements):
        reason_exact = "an element relative to a second DOF (the exact flow handles elements on one DOF); "
    else:
        res = _exact(system, sol)
        if res.get("ok"):
            mult = res.pop("mult")
            rho = float(np.max(np.abs(mult)))
            stable, reason = _verdict(rho, EXACT_TOL)
            if res["orbit_distance"] > MAX_ORBIT_DISTANCE:
                stable = None
                reason = (f"the exact periodic orbit reached from this solution differs from it by "
                          f"{res['orbit_distance']:.2g} (relative, amplitudes or state at t = "
                          f"{res['section_time']:.4g} s): the solution approximates it poorly or approximates "
                          f"another orbit, so its multipliers are no verdict for this solution")
            res.pop("ok")
            return _set(sol, mult, stable, EXACT, reason, tolerance=EXACT_TOL, time_s=time.perf_counter() - t0,
                        **res)
        reason_exact = f"exact flow failed ({res['message']}); "
    return _step_map(system, sol, steps, theta, reason_exact, t0)


def _exact(system, sol):
    from .integrators.event import EventError
    from .methods.exact import exact_periodic

    try:
        ex = exact_periodic(system, sol.omega, guess=sol, samples=1024, blas_threads=None,
                            time_limit=EXACT_TIME_LIMIT)
    except (EventError, ValueError, np.linalg.LinAlgError, InputError) as exc:
        return {"ok": False, "message": f"{type(exc).__name__}: {exc}"}
    if not ex.success or "floquet_multipliers" not in ex.info:
        return {"ok": False, "message": ex.message}
    if not np.all(np.isfinite(ex.info["floquet_multipliers"])):
        return {"ok": False, "message": "non-finite monodromy matrix"}
    # distance of the exact orbit from the solution: amplitudes, and the state at the section time
    a_ex = np.asarray(ex.info["amplitude_exact"], dtype=float)
    a_sol = np.asarray(sol.amplitude, dtype=float)
    ascale = max(float(np.max(np.abs(a_ex))), 1e-300)
    d_amp = float(np.max(np.abs(a_ex - a_sol))) / ascale
    t_s = float(ex.info["section_time"])
    k = int(round(t_s / sol.period * (sol.t.size - 1))) % (sol.t.size - 1)
    x_ex = ex.info["state_at_section"]
    q_ex, u_ex = x_ex[:system.n], x_ex[system.n:]
    qscale = max(float(np.max(np.abs(ex.q))), 1e-300)
    uscale = max(float(np.max(np.abs(ex.u))), 1e-300)
    d_state = max(float(np.max(np.abs(sol.q[k] - q_ex))) / qscale, float(np.max(np.abs(sol.u[k] - u_ex))) / uscale)
    return {"ok": True, "mult": np.asarray(ex.info["floquet_multipliers"], dtype=complex),
            "orbit_distance": max(d_amp, d_state), "orbit_amplitude_distance": d_amp,
            "exact_amplitude": [float(a) for a in a_ex], "section_time": t_s,
            "exact_iterations": int(ex.iterations), "exact_message": ex.message,
            "n_events": int(ex.info.get("n_events", 0)), "n_impacts": int(ex.info.get("n_impacts", 0)),
            "stick_fraction": float(ex.info.get("stick_fraction", 0.0))}


def _step_map(system, sol, steps, theta, prefix, t0):
    from .integrators import kernels
    from .methods.shooting import ShootingProblem

    N = int(steps) if steps is not None else min(max(int(sol.steps), 1024), STEP_MAP_MAX_STEPS)
    try:
        prob = ShootingProblem(system, sol.omega, N, theta=theta)
        x = np.concatenate([sol.q[0], sol.u[0]])
        tr = prob.simulate(x)
        Phi = prob.stepper.monodromy(tr.status, tr.P)
        if not np.all(np.isfinite(Phi)):
            raise np.linalg.LinAlgError("non-finite monodromy matrix")
        mult = np.linalg.eigvals(Phi)
    except (InputError, np.linalg.LinAlgError, MemoryError) as exc:
        return _set(sol, None, None, f"none: {prefix}step map failed",
                    f"{prefix}Moreau-Jean step map failed: {type(exc).__name__}: {exc}")
    kind = prob.stepper.kind
    impacts = bool(np.any((kind == kernels.KIND_CONTACT) & np.any(tr.P > 0, axis=0)))
    acting = np.array([el.acts for el in system.elements])
    stick = bool(np.any(((tr.status & 3) == kernels.STATUS_STICK) & (kind == kernels.KIND_FRICTION) & acting))
    reversal = False
    for j, el in enumerate(system.elements):
        if el.bounded and el.acts:  # mu F_N = 0: the element never acts
            v = el.local(tr.u)
            reversal |= bool(np.any(v > 0)) and bool(np.any(v < 0))
    rho = float(np.max(np.abs(mult)))
    details = dict(steps=N, impacts=impacts, stick=stick, slip_reversal=reversal, tolerance=STEP_MAP_TOL,
                   time_s=time.perf_counter() - t0)
    if impacts or stick or reversal:
        what = ", ".join(w for w, f in (("impacts", impacts), ("stick phases", stick),
                                        ("slip reversals", reversal)) if f)
        return _set(sol, mult, None, STEP_MAP,
                    f"{prefix}the Moreau-Jean step map has no saltation terms and the motion has {what}: "
                    f"its multipliers (largest modulus {rho:.4f}) are an estimate, not a verdict", **details)
    stable, reason = _verdict(rho, STEP_MAP_TOL)
    return _set(sol, mult, stable, STEP_MAP, (prefix + reason) if reason else "", **details)


