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
* ``stability_reason`` -- why ``stable`` is ``None``, and whether the multipliers belong to another orbit;
* ``stability_orbit`` -- which orbit they belong to: :data:`REPORTED` (the returned solution) or
  :data:`NEARBY` (the exact periodic orbit found from it), ``""`` when there are none;
* ``info["stability"]`` -- details (largest modulus, estimated multiplier error, distance between the
  reported orbit and the exact periodic orbit, wall time).

How (:func:`assess`):

1. **Friction and contact elements on single DOFs (any number), n <= MAX_EXACT_DOFS** (or
   ``stability=True``): the reported orbit's own monodromy.  One period of the exact event-driven flow
   (:mod:`mshbm.integrators.event`, several elements with simultaneous events) from the solution's state at
   a section time far from its events, with the sensitivities: the products of the closed-form mode flows
   and the saltation matrices ``S = R + (f+ - R f-) c^T / (c^T f-)`` at every impact (``R`` the Jacobian of
   Newton's impact law), slip-stick, stick-slip and slip-reversal event.  No Newton solve: one flow (two
   when the orbit is not exact), a fraction of the solve's cost.  These are the multipliers of the nonsmooth
   system (Newton's impact law, set-valued friction) along the reported orbit, whatever method produced it.
   The Newton step ``(I - Phi)^-1 (x(t_s + T) - x)`` of the exact shooting from that state measures the
   distance of the reported orbit from the exact periodic orbit (``orbit_distance``, relative).  Up to
   :data:`OWN_MAX_DISTANCE` the multipliers are the reported orbit's (``stability_orbit = "reported"``); their
   error estimate ``multiplier_error`` is twice the change of the largest modulus when the monodromy is taken
   one Newton step away (on the exact orbit to second order), at least ``EXACT_TOL``, and the verdict needs
   ``| max|mu| - 1 |`` above it.  Farther away (an HBM or DLFT orbit with large truncation, regularisation or
   model-substitution error) the reported orbit is no orbit of the nonsmooth flow and has no multipliers of
   its own: the exact flow is shot to periodicity from it (a few Newton iterations) and the multipliers are
   that *other* orbit's, ``stability_orbit = "nearby exact orbit"``, said in ``stability_reason``; a verdict
   only when that orbit lies within ``MAX_ORBIT_DISTANCE`` (relative) of the solution.  Along a branch
   (``seed``: the previous point's result) that exact orbit is continued: its Newton starts from the
   previous point's exact orbit (same phase of the section state), a few iterations, where the reported
   orbit's state (MS-HBM's truncated harmonics on a Craig-Bampton plate that impacts: 6-50 % off the
   flow's orbit) needs many more and fails near grazings and folds.  The continued orbit is taken when it
   lies within ``MAX_ORBIT_DISTANCE`` of the reported one or within twice the previous point's distance;
   else (a jump), and when its Newton fails after a frequency step above ``SEED_CLOSE``, the start from
   the reported orbit; the verdict's checks are the same.
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

Hill's method (:mod:`mshbm.hill`) is not used here: it gives the multipliers of HBM's regularised laws, not
of the nonsmooth flow (it serves :func:`mshbm.sweep`'s HBM branches with friction only, labelled so).

``MAX_EXACT_DOFS = 200``: the exact flow works with dense ``(2n+1+2n_f)``-square matrices
(matrix exponentials, monodromy products), so its cost grows like ``n^3`` (a few seconds at
``n = 200`` on one thread).  ``stability=True lifts the limit (up to the event flow's own
:data:`mshbm.integrators.event.MAX_DOFS` = 1000; above it the step map's estimate with the reason).
"""
from __future__ import annotations

import time

import numpy as np

from .errors import InputError
from .floquet import (EXACT, EXACT_TOL, NEARBY, REPORTED, STEP_MAP, STEP_MAP_TOL, _set, _verdict,  # noqa: F401
                      check_option, set_exact)
from .result import describe_stability as describe, multipliers_json

__all__ = ["assess", "check_option", "describe", "multipliers_json", "set_exact", "MAX_EXACT_DOFS", "EXACT", "STEP_MAP",
           "REPORTED", "NEARBY"]

#: largest system for which the exact flow is used by default (see the module docstring)
MAX_EXACT_DOFS = 200
#: work budget (the event-driven flow's deterministic count, flop equivalents, :data:`mshbm.integrators.event.flow.
#: WORK_STEP`; 0.3-3 ns each on the examples' flows) of the reported orbit's monodromy flows and, separately, of the
#: exact flow's periodic solve in the stability analysis: some 10-100 s of one core, 40 times and more what the
#: exact solve needs on the examples up to 150 DOFs (1e7-5e8); a flow that exceeds it (an event sequence that makes
#: no progress, e.g. a slip velocity that stays at its switching threshold) is reported as "exact flow failed",
#: never a hang, and at the same point on every machine whatever its load (not a wall-time limit)
EXACT_WORK_LIMIT = 3e10
#: most Moreau-Jean steps per period of the step-map estimate (its cost is O(steps n^2))
STEP_MAP_MAX_STEPS = 16384
#: the exact periodic orbit must be this close (relative, amplitudes and section state) to the solution
MAX_ORBIT_DISTANCE = 0.25
#: the reported orbit has multipliers of its own when one Newton step of the exact shooting from its state moves
#: it by at most this (relative to its displacement and velocity sizes); farther, the exact orbit is solved for
OWN_MAX_DISTANCE = 0.05
#: below this distance the reported orbit is the exact one (to rounding): no second monodromy for the error estimate
OWN_EXACT_DISTANCE = 1e-9
#: a seed (:func:`assess`) within this relative frequency step is close: when the exact orbit continued from it
#: fails, the start from the reported orbit is not tried
SEED_CLOSE = 0.01

def assess(system, sol, stability="auto", steps=None, theta=0.5, seed=None):
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
    seed : PeriodicSolution, optional
        A nearby solution already assessed (the previous point of a branch): when its multipliers are a
        nearby exact orbit's, that orbit's section state (``info["stability"]["exact_state"]``) starts the
        exact orbit's Newton here (see the module docstring); ignored otherwise.

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
    cert = getattr(sol, "certificate", None)
    if not (sol.success or (cert is not None and cert.failed == ["accuracy"])):
        # (a certified solution of the discretised equations outside the requested accuracy is analysed: it is
        # a periodic orbit, whose distance from the nonsmooth flow's the analysis measures itself)
        return _set(sol, None, None, "none: the solve did not converge",
                    "no converged periodic solution to analyse")
    if n > MAX_EXACT_DOFS and stability is not True:  # "auto"
        why = (f"n = {n} DOFs > {MAX_EXACT_DOFS}: the exact flow needs dense matrices of the whole system "
               f"(cost ~ n^3, 9.5 s at 400 DOFs), skipped by default; pass stability=True to compute it")
        return _set(sol, None, None, "none: system too large for the default analysis", why)
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # failures end in a reason
            return _assess(system, sol, stability, steps, theta, t0, seed)
    except Exception as exc:  # noqa: BLE001 -- the analysis must never turn a converged solve into a crash
        return _set(sol, None, None, "none: the stability analysis failed",
                    f"the stability analysis failed: {type(exc).__name__}: {exc}")


def _assess(system, sol, stability, steps, theta, t0, seed=None):
    reason_exact = ""
    if any(el.history for el in system.elements):
        return _set(sol, None, None, "none: not supported for elastic friction",
                    "elastic friction (Jenkins) has a slider state that neither the exact flow nor the "
                    "Moreau-Jean step map carries: no multipliers")
    if any(el.relative_to is not None for el in system.elements):
        reason_exact = "an element relative to a second DOF (the exact flow handles elements on one DOF); "
        return _step_map(system, sol, steps, theta, reason_exact, t0)
    if any(getattr(el, "smooth", False) for el in system.elements):
        reason_exact = "a polynomial spring (the exact flow is linear between events); "
        return _step_map(system, sol, steps, theta, reason_exact, t0)
    own = _own(system, sol)
    if own.get("ok") and own["orbit_distance"] <= OWN_MAX_DISTANCE:
        own.pop("ok")
        mult = own.pop("mult")
        rho = float(np.max(np.abs(mult)))
        margin = EXACT_TOL
        step, flow, Phi = own.pop("step"), own.pop("flow"), own.pop("Phi")
        if own["orbit_distance"] > OWN_EXACT_DISTANCE:
            # error of the reported orbit's multipliers: against those one Newton step of the exact shooting away
            # (on the exact periodic orbit to second order in the distance); twice that difference is the margin
            rho1, why = _newton_step_max_modulus(system, sol, flow, step, Phi, mult)
            if rho1 is None:
                margin = np.inf
                own["newton_step_message"] = why
            else:
                margin = max(EXACT_TOL, 2.0 * abs(rho - rho1))
                own["newton_step_max_modulus"] = rho1
        stable, reason = _verdict(rho, margin)
        if stable is None:
            reason = (f"the largest multiplier modulus {rho:.9f} of the reported orbit is within its estimated error "
                      f"{margin:.2g} of 1 (the reported orbit lies {own['orbit_distance']:.2g} (relative) from the "
                      f"exact periodic orbit of the nonsmooth flow)")
        return _set(sol, mult, stable, EXACT, reason, orbit=REPORTED, tolerance=EXACT_TOL, multiplier_error=margin,
                    time_s=time.perf_counter() - t0, **own)
    if own.get("ok"):
        why_other = (f"the reported orbit is {own['orbit_distance']:.2g} (relative; one Newton step of the exact "
                     f"shooting from its state at t = {own['section_time']:.4g} s) from the nearest periodic orbit of "
                     f"the nonsmooth flow, more than {OWN_MAX_DISTANCE:g}: it has no multipliers of its own")
    else:
        why_other = f"the reported orbit's own monodromy failed ({own['message']})"
    res = _exact(system, sol, seed)
    if res.get("ok"):
        mult = res.pop("mult")
        res.pop("ok")
        rho = float(np.max(np.abs(mult)))
        stable, reason = _verdict(rho, EXACT_TOL)
        other = (f"multipliers of the exact periodic orbit found from the reported one (a different orbit, "
                 f"{res['orbit_distance']:.2g} away): {why_other}")
        if res["orbit_distance"] > MAX_ORBIT_DISTANCE:
            stable = None
            reason = (f"{other}; the exact periodic orbit reached from this solution differs from it by "
                      f"{res['orbit_distance']:.2g} (relative, amplitudes or state at t = "
                      f"{res['section_time']:.4g} s): the solution approximates it poorly or approximates "
                      f"another orbit, so its multipliers are no verdict for this solution")
        else:
            reason = other + (f"; {reason}" if reason else "")
        return _set(sol, mult, stable, EXACT, reason, orbit=NEARBY, tolerance=EXACT_TOL,
                    own_orbit_distance=own.get("orbit_distance"), time_s=time.perf_counter() - t0, **res)
    reason_exact = f"{why_other}; exact flow failed ({res['message']}); "
    return _step_map(system, sol, steps, theta, reason_exact, t0)


def _own(system, sol, start=None, flow=None):
    """The reported orbit's own monodromy: one period of the exact event-driven flow (closed-form mode flows and
    saltation matrices, :mod:`mshbm.integrators.event`) from the solution's state at a section time far from
    its events, with the sensitivities.  ``start``: ``(t_s, x, scale)`` to start from instead (a Newton step),
    ``flow`` the flow of the first call.

    Returns a dict: ``ok``; ``mult`` (eigenvalues of the ``2n``-square monodromy ``Phi``), ``orbit_distance``
    (the Newton step ``(I - Phi)^-1 (x(t_s + T) - x)`` of the exact shooting from the state, relative to the
    displacement and velocity sizes of the solution: the distance of the reported state from the exact periodic
    orbit to first order), ``defect`` (``x(t_s + T) - x``, same scaling), ``step`` (the start of that Newton
    step's call), event counts, or ``message`` when the flow failed."""
    from .integrators.event import EventError
    from .methods.exact import ExactFlow, _section_index, _stick_fraction

    n = system.n
    try:
        if flow is None:
            flow = ExactFlow(system, sol.omega)
            flow.batch = True  # nothing sampled: runs of event-free sub-steps screened at once
        flow.work_limit = flow.work + EXACT_WORK_LIMIT
        if start is None:
            t_s, x, scale = _section_state(flow, sol, _section_index)
        else:
            t_s, x, scale = start
        out = flow.simulate(t_s, np.concatenate([x, flow.osc(t_s)]), jac=True)
    except (EventError, ValueError, np.linalg.LinAlgError, InputError) as exc:
        return {"ok": False, "message": f"{type(exc).__name__}: {exc}"}
    if out.moreau_segments:
        return {"ok": False, "message": "the flow switched to Moreau-Jean (accumulation): no exact monodromy"}
    Phi = out.monodromy[:2 * n]
    if not np.all(np.isfinite(Phi)):
        return {"ok": False, "message": "non-finite monodromy matrix"}
    R = out.end_state[:2 * n] - x
    try:
        dx = np.linalg.solve(np.eye(2 * n) - Phi, R)
    except np.linalg.LinAlgError:  # a multiplier 1: the minimum-norm step
        dx = np.linalg.lstsq(np.eye(2 * n) - Phi, R, rcond=1e-13)[0]
    evs = out.events
    dist = float(np.max(np.abs(dx) / scale))
    return {"ok": True, "Phi": Phi, "mult": np.linalg.eigvals(Phi) if dist <= OWN_MAX_DISTANCE else None,
            "orbit_distance": dist,
            "defect": float(np.max(np.abs(R) / scale)), "section_time": float(t_s), "step": (t_s, x + dx, scale),
            "flow": flow, "n_events": len(evs), "n_impacts": sum(1 for e in evs if e.impulse != 0.0),
            "stick_fraction": _stick_fraction(flow, out.mode_time, None) / flow.T}


def _newton_step_max_modulus(system, sol, flow, step, Phi0, mult, max_candidates=4):
    """Largest multiplier modulus one Newton step away (at ``step``), to first order in the change ``dPhi`` of the
    monodromy: ``mu + l^H dPhi r / (l^H r)`` for the ``max_candidates`` eigenvalues ``mu`` of largest modulus (one of
    each conjugate pair), ``r``, ``l`` their right and left eigenvectors of ``Phi0`` by inverse iteration, and
    ``dPhi r`` from one flow that carries only the directions ``Re r, Im r`` (not the ``2n`` columns of ``Phi``; no
    second eigenvalue problem).  The full monodromy and its eigenvalues instead where that is not safe: an
    ill-conditioned eigenvalue (a multiple multiplier), or an estimated change larger than the modulus gap to the
    first eigenvalue left out.  Returns ``(rho1, "")`` or ``(None, reason)``."""
    import scipy.linalg as sla

    from .integrators.event import EventError

    n, D = system.n, flow.D
    rep = np.flatnonzero(mult.imag >= 0.0)  # one of each conjugate pair (equal moduli, conjugate changes)
    rep = rep[np.argsort(-np.abs(mult[rep]), kind="stable")]
    cand, left = rep[:max_candidates], rep[max_candidates:]
    gap = float(np.abs(mult[cand[-1]]) - np.abs(mult[left[0]])) if left.size else np.inf
    b = np.random.default_rng(0).standard_normal(2 * n) + 0j
    vecs = []
    for i in cand:
        mu = mult[i]
        try:
            lu = sla.lu_factor(Phi0 - (mu + 1e-10 * max(1.0, abs(mu))) * np.eye(2 * n), check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            return _full_step_max_modulus(system, sol, flow, step)
        # (no finiteness checks: Phi0 is finite; a non-finite vector from an exactly singular factor ends below in
        # the ill-conditioned case)
        r, lv = sla.lu_solve(lu, b, check_finite=False), sla.lu_solve(lu, b, trans=2, check_finite=False)
        r = sla.lu_solve(lu, r / np.linalg.norm(r), check_finite=False)
        lv = sla.lu_solve(lu, lv / np.linalg.norm(lv), trans=2, check_finite=False)
        r, lv = r / np.linalg.norm(r), lv / np.linalg.norm(lv)
        c = np.vdot(lv, r)
        if not abs(c) >= 1e-8:  # ill-conditioned eigenvalue: no first-order formula
            return _full_step_max_modulus(system, sol, flow, step)
        vecs.append((mu, r, lv, c))
    V = np.zeros((D, 2 * len(vecs)))
    for k, (_, r, _, _) in enumerate(vecs):
        V[:2 * n, 2 * k], V[:2 * n, 2 * k + 1] = r.real, r.imag
    t_s, x, _ = step
    try:
        out = flow.simulate(t_s, np.concatenate([x, flow.osc(t_s)]), jac=True, jac_init=V)
    except (EventError, ValueError, np.linalg.LinAlgError, InputError) as exc:
        return None, f"the flow one Newton step away failed: {type(exc).__name__}: {exc}"
    if out.moreau_segments or not np.all(np.isfinite(out.monodromy)):
        return None, "no exact monodromy one Newton step away"
    PV = out.monodromy[:2 * n]
    moduli, change = [], 0.0
    for k, (mu, r, lv, c) in enumerate(vecs):
        d = np.vdot(lv, PV[:, 2 * k] + 1j * PV[:, 2 * k + 1] - mu * r) / c
        moduli.append(abs(mu + d))
        change = max(change, abs(d))
    if change >= 0.5 * gap:  # the largest modulus may move to an eigenvalue left out
        return _full_step_max_modulus(system, sol, flow, step)
    return float(max(moduli)), ""


def _full_step_max_modulus(system, sol, flow, step):
    nxt = _own(system, sol, start=step, flow=flow)
    if not nxt.get("ok"):
        return None, nxt["message"]
    mult = nxt["mult"] if nxt["mult"] is not None else np.linalg.eigvals(nxt["Phi"])
    return float(np.max(np.abs(mult))), ""


def _section_state(flow, sol, section_index):
    """``(t_s, x, scale)``: a section time of the solution's grid far from its events (the element DOFs' series
    only), the state ``x = (q, u)(t_s)`` of all DOFs, shape ``(2n,)``, and per entry the solution's displacement or
    velocity size (bounds from the harmonic magnitudes; the time series' maxima for time-stepped DOFs), without
    assembling the whole grid of every DOF."""
    n = sol.n
    dofs = np.unique(flow.dof) if flow.m else np.zeros(0, dtype=np.int64)
    k = section_index(_FlowView(flow, dofs), sol.displacement(dofs)[:-1], sol.velocity(dofs)[:-1]) \
        if dofs.size else 0
    t_s = float(sol.t[k])
    qh = np.asarray(sol.q_hat, dtype=float)
    n_h = (qh.shape[0] - 1) // 2
    kw = np.arange(1, n_h + 1)[:, None] * sol.omega
    c, s_ = np.cos(kw * t_s), np.sin(kw * t_s)
    q = qh[0] + np.sum(qh[1::2] * c + qh[2::2] * s_, axis=0)
    u = np.sum(kw * (qh[2::2] * c - qh[1::2] * s_), axis=0)
    mag = np.hypot(qh[1::2], qh[2::2])
    qmax = np.abs(qh[0]) + mag.sum(axis=0)
    umax = (kw * mag).sum(axis=0)
    td = np.asarray(sol.time_dofs, dtype=np.int64)
    if td.size:
        q[td], u[td] = sol.q_time[k], sol.u_time[k]
        qmax[td] = np.max(np.abs(sol.q_time), axis=0)
        umax[td] = np.max(np.abs(sol.u_time), axis=0)
    scale = np.concatenate([np.full(n, max(float(qmax.max(initial=0.0)), 1e-300)),
                            np.full(n, max(float(umax.max(initial=0.0)), 1e-300))])
    return t_s, np.concatenate([q, u]), scale


class _FlowView:
    """The flow's element table seen on the columns ``dofs`` (for :func:`mshbm.methods.exact._section_index`
    on the element DOFs' series only)."""

    def __init__(self, flow, dofs):
        pos = {int(d): i for i, d in enumerate(dofs)}
        self.m, self.is_contact, self.sign, self.gap = flow.m, flow.is_contact, flow.sign, flow.gap
        self.dof = np.array([pos[int(d)] for d in flow.dof], dtype=np.int64)


def _seed_guess(seed, omega, n):
    """The exact-orbit start from ``seed`` (a solution assessed before, see :func:`assess`): its nearby exact
    orbit's section state at the same phase, ``{"q0", "u0", "t0"}``, or ``None``."""
    det = getattr(seed, "info", {}).get("stability") or {}
    x = det.get("exact_state")
    if x is None or len(x) != 2 * n or not np.isfinite(getattr(seed, "omega", np.nan)):
        return None
    x = np.asarray(x, dtype=float)
    return {"q0": x[:n], "u0": x[n:], "t0": float(det["section_time"]) * float(seed.omega) / float(omega)}


def _exact(system, sol, seed=None):
    from .integrators.event import EventError
    from .methods.exact import exact_periodic

    guess = _seed_guess(seed, sol.omega, system.n) if seed is not None else None
    starts = ([("seed", guess)] if guess is not None else []) + [("reported", sol)]
    for k, (start, g) in enumerate(starts):
        try:
            ex = exact_periodic(system, sol.omega, guess=g, samples=1024, blas_threads=None,
                                work_limit=EXACT_WORK_LIMIT)
        except (EventError, ValueError, np.linalg.LinAlgError, InputError) as exc:
            res = {"ok": False, "message": f"{type(exc).__name__}: {exc}"}
        else:
            res = _exact_facts(system, sol, ex)
        if res.get("ok") and (start != "seed" or res["orbit_distance"] <= _seed_reach(seed)):
            # from the seed: the orbit continued from the previous point's if it is near the reported orbit, or no
            # farther from it than twice the previous point's (the distance grows along the branch); a jump away is
            # left to the start from the reported orbit
            res["exact_start"] = start
            return res
        if start == "seed" and not res.get("ok") and abs(sol.omega / seed.omega - 1.0) <= SEED_CLOSE:
            # the continued orbit's Newton failed one small step from an exact orbit: the start from the reported
            # orbit, farther away, has not converged there either (the FE plate's MS-HBM curve near its fold: 70
            # flows until the time limit, 4 s of CPU per point, all failed) and is not tried
            res["message"] = f"continued from the exact orbit at {seed.omega:.6g} rad/s: {res['message']}"
            return res
    return res


def _seed_reach(seed):
    """Largest accepted distance of an exact orbit continued from ``seed`` (see :func:`_exact`)."""
    d = (getattr(seed, "info", {}).get("stability") or {}).get("orbit_distance")
    return max(MAX_ORBIT_DISTANCE, 2.0 * float(d)) if d is not None and np.isfinite(d) else MAX_ORBIT_DISTANCE


def _exact_facts(system, sol, ex):
    """The dict of :func:`_exact` for the exact periodic solution ``ex``."""
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
            "exact_state": [float(v) for v in x_ex],
            "exact_iterations": int(ex.iterations), "exact_message": ex.message,
            "exact_start_residual": float((ex.info.get("residual_history") or [np.nan])[0]),
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
        if prob.stepper.smooth or np.any(prob.stepper.tpair >= 0):
            # state-dependent step Jacobians (polynomial springs; a 3-D contact, whose slip direction rotates):
            # the kernel's forward sensitivities
            Phi = prob._run(x, sensitivities=True).jacobian
        else:
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


