"""Exact event-driven periodic reference solutions (any number of local elements).

The flow between events is exact (closed-form modal flows of the linear structure with
constant or constraint element forces, events located to ~1e-15 s, active sets of simultaneous
events, Newton impacts and saltation matrices): :mod:`mshbm.integrators.event` (the one
event-driven engine; :class:`ExactFlow` is it with the exact Zeno closure of accumulations by
default).  This module finds the periodic solution on that flow.

The periodic solution is found by shooting on this exact map with Newton's
method from a section time chosen far from the events of the guess; the
Jacobian is the exact monodromy matrix (products of the mode flows and
saltation matrices at the events), or central differences.  The matrices are
used dense: the solver is meant for reference solutions of up to a few hundred
DOFs.
"""

from __future__ import annotations

import time

import numpy as np
from .._blas import blas_threads as _blas_threads

from .. import fourier
from .base import central_difference_jacobian
from .common import linear_response
from ..errors import InputError
from ..integrators.event import (CLOSED, MODE_NAMES, MOREAU, STICK, Event, EventError, EventFlow, EventTrajectory,
                                 extrema, mode_tuple)
from ..result import PeriodicSolution

__all__ = ["exact_periodic", "ExactFlow", "ExactTrajectory", "Event", "EventError"]


class ExactFlow(EventFlow):
    """:class:`~mshbm.integrators.event.EventFlow` with the exact Zeno closure of accumulations of impacts
    by default (``accumulation="close"``: the contact closes with ``e = 0`` once the next bounce would rise
    less than ``1e-10`` of the displacement scale); the reference solutions of :func:`exact_periodic` rely
    on it.

    For systems with one acting element: ``element``, ``kind``, ``unilateral``, ``w`` (shape (n,)),
    ``mw = M^-1 w`` and ``sw = w^T M^-1 w``.
    """

    def __init__(self, system, omega, substeps=128, max_events=10000, accumulation="close", moreau_steps=4096):
        super().__init__(system, omega, substeps=substeps, max_events=max_events, accumulation=accumulation,
                         moreau_steps=moreau_steps)

    def _one(self, what):
        if self.m != 1:
            raise AttributeError(f"ExactFlow.{what} is defined for one acting element, the system has {self.m}")
        return 0

    @property
    def element(self):
        return self.elements[self._one("element")] if self.m else None

    @property
    def kind(self):
        return None if self.m == 0 else self.element.kind

    @property
    def unilateral(self):
        return bool(self.m == 1 and self.is_contact[0])

    @property
    def w(self):
        return self.W[:, self._one("w")]

    @property
    def mw(self):
        return self.MW[:, self._one("mw")]

    @property
    def sw(self):
        return float(self.sw_all[self._one("sw")])


class ExactTrajectory(EventTrajectory):
    """:class:`~mshbm.integrators.event.EventTrajectory`; with one element ``evaluate`` gives ``lam`` of shape
    (k,), with several (k, m)."""

    def evaluate(self, t):
        q, u, lam = super().evaluate(t)
        if lam.shape[1] == 1:
            lam = lam[:, 0]
        return q, u, lam


def _section_index(flow, q, u):
    """Grid index in the middle of the longest event-free stretch of a sampled guess.

    Every element is classified per sample (friction: slip direction or stick, ``|gamma| <= 1e-6
    max|u|``; contact: clearly open, ``g_N > 1e-3 max g_N``, or not); the longest run of one
    combined class is taken, preferring runs with all contacts open.
    """
    N = q.shape[0]
    if flow.m == 0 or N < 2:
        return 0
    tol = 1e-6 * max(np.abs(u).max(), 1e-300)
    cls = np.zeros(N, dtype=np.int64)
    open_all = np.ones(N, dtype=bool)
    for j in range(flow.m):
        d, sg = flow.dof[j], flow.sign[j]
        if flow.is_contact[j]:
            g = flow.gap[j] + sg * q[:, d]
            c = (g > 1e-3 * max(g.max(), 1e-300)).astype(np.int64)
            open_all &= c == 1
        else:
            v = sg * u[:, d]
            c = np.where(v > tol, 1, np.where(v < -tol, -1, 0)) + 1
        cls = 3 * cls + c
    starts = np.nonzero(cls != np.roll(cls, 1))[0]
    if starts.size == 0:
        if flow.is_contact.any():
            j = int(np.nonzero(flow.is_contact)[0][0])
            return int(np.argmax(flow.gap[j] + flow.sign[j] * q[:, flow.dof[j]]))
        return 0
    lengths = (np.roll(starts, -1) - starts) % N
    lengths[lengths == 0] = N
    if flow.is_contact.any():
        op = open_all[starts]
        if np.any(op):
            lengths = np.where(op, lengths, -1)
    i = int(np.argmax(lengths))
    return int((starts[i] + lengths[i] // 2) % N)


def _start(flow, guess, omega):
    """Shooting start time and state ``(t_s, q_s, u_s)`` from a guess, far from events."""
    system, n = flow.system, flow.n
    if isinstance(guess, PeriodicSolution):
        if guess.n != n:
            raise InputError("guess", f"solution has {guess.n} DOFs, system has {n}")
        q, u = guess.q[:-1], guess.u[:-1]
        t = guess.t[:-1] * (guess.omega / omega)  # same phase if the guess is at another frequency
        k = _section_index(flow, q, u)
        return float(t[k]), q[k].astype(float).copy(), u[k].astype(float).copy()
    if isinstance(guess, dict) and "q0" in guess and "u0" in guess:
        q0 = np.asarray(guess["q0"], dtype=float).reshape(-1)
        u0 = np.asarray(guess["u0"], dtype=float).reshape(-1)
        if q0.size != n or u0.size != n:
            raise InputError("guess", f"q0 and u0 need {n} entries")
        return float(guess.get("t0", 0.0)), q0, u0
    if guess is None or (isinstance(guess, str) and guess == "linear"):
        q_hat = linear_response(system, omega, max(1, system.n_forcing_harmonics))
    elif isinstance(guess, str) and guess == "zero":
        return 0.0, np.zeros(n), np.zeros(n)
    elif isinstance(guess, dict) and "q_hat" in guess:
        q_hat = np.asarray(guess["q_hat"], dtype=float)
        if q_hat.ndim != 2 or q_hat.shape[1] != n or q_hat.shape[0] % 2 != 1:
            raise InputError("guess.q_hat", f"must have shape (2*n_h+1, {n}), got {q_hat.shape}")
    else:
        raise InputError("guess", "must be None, 'linear', 'zero', a PeriodicSolution or a dict "
                                  "with q0, u0 (and optionally t0) or q_hat")
    q0 = q_hat[0] + q_hat[1::2].sum(axis=0)
    u0 = fourier.derivative(q_hat, omega)[1::2].sum(axis=0)
    return 0.0, q0, u0


def exact_periodic(system, omega, guess=None, samples=4096, tol=1e-11, max_iter=30, harmonics=25,
                   jacobian="saltation", substeps=128, max_events=10000, blas_threads=1, time_limit=None,
                   accumulation="close", work_limit=None):
    """Exact periodic solution of a linear structure with local elements (any number).

    Shooting on the exact event-driven flow (see the module docstring): the
    unknowns are ``x = (q(t_s), u(t_s))`` at a section time ``t_s`` chosen far
    from events of the guess, the residual is ``R(x) = x(t_s + T) - x`` and
    Newton's method (minimum-norm steps, backtracking) uses the exact monodromy
    matrix ``Phi`` (flows of the modes times saltation matrices) in
    ``J = Phi - I``.

    Parameters
    ----------
    system : System
        ``M q'' + C q' + K q = f_ex(t) + sum_j w_j lambda_j`` with Friction and Contact elements
        between a DOF and the ground (any number).
    omega : float
        Forcing angular frequency (rad/s), period ``T = 2 pi / omega``.
    guess : PeriodicSolution, dict, str or None
        Start.  A PeriodicSolution (e.g. ``mshbm.solve(system, omega,
        "shooting", steps=4096)``) gives the section time ``t_s`` (friction:
        largest slip speed; contact: largest gap) and the state there; a dict
        ``{"q0", "u0"[, "t0"]}`` a state at ``t0`` (default 0); ``None`` or
        ``"linear"`` the response of the structure without the element.
    samples : int
        ``N``: the output grid ``t_k = k T / N``, ``k = 0..N``.
    tol : float
        Convergence when ``||R||_inf <= tol`` (absolute).
    max_iter : int
        Newton iterations.
    harmonics : int
        ``n_h`` of ``q_hat`` (FFT of the samples).
    jacobian : {"saltation", "fd"}
        Exact monodromy matrix or central differences (``4 n`` extra flows).
    substeps : int
        Minimal sub-steps per period of the event search grid.
    max_events : int
        Events per period before the flow is declared an accumulation.
    time_limit : float, optional
        Seconds of wall time; a simulation still running then ends with an EventError, and the
        solve fails with that message (``None``, the default: no limit).  The answer then depends on the
        machine's load; ``work_limit`` is the reproducible budget.
    work_limit : float, optional
        Budget of the event-driven flow's deterministic work count over the whole solve (flop equivalents,
        :data:`mshbm.integrators.event.flow.WORK_STEP`; about a nanosecond each): the simulation that exceeds it
        ends with an EventError and the solve fails with that message, on every machine alike (``None``: none).
    accumulation : {"close", "moreau", "error"}
        At an accumulation of impacts: close the contact exactly (default), switch to Moreau-Jean for
        that phase (then ``info["moreau"]`` lists the segments and the monodromy is no longer exact),
        or fail (:class:`mshbm.integrators.event.EventFlow`).
    blas_threads : int or None
        OpenBLAS threads during the solve (restored afterwards); ``None``
        leaves them alone.  The matrices are small, so 1 is fastest.

    Returns
    -------
    PeriodicSolution
        ``method="exact"``; ``q_time, u_time`` (all DOFs) and ``lam`` (element
        force ``lambda`` on the grid: friction force on the DOF, contact
        normal force in persistent contact, 0 otherwise; impacts are in
        ``info["events"]``); ``info`` holds ``amplitude_exact`` (``(max-min)/2``
        of every ``q_j`` from the true extrema), ``q_max``, ``q_min``,
        ``events`` (list of :class:`Event`, times in ``[0, T)``),
        ``n_impacts``, ``impulses`` (times and impulses of the impacts),
        ``stick_fraction`` (time fraction with an element in stick or closed contact),
        ``element_stick_fraction`` (per element), ``moreau`` (Moreau-Jean segments, if any),
        ``residual_history``, ``floquet_multipliers``, ``section_time`` and
        ``trajectory`` (:class:`ExactTrajectory` for dense output).  The stability fields
        (``floquet_multipliers``, ``stable``, ``stability_method``) come from the exact
        monodromy (:func:`mshbm.stability.set_exact`).

    Raises
    ------
    InputError
        Unsupported elements (relative, Jenkins), invalid ``omega``, ``samples`` or guess.
    """
    t_wall = time.perf_counter()
    with _blas_threads(blas_threads):
        sol = _exact_periodic(system, omega, guess, samples, tol, max_iter, harmonics, jacobian, substeps,
                              max_events, None if time_limit is None else t_wall + float(time_limit),
                              accumulation, work_limit)
    sol.wall_time = time.perf_counter() - t_wall
    from ..floquet import set_exact

    return set_exact(sol)


def _exact_periodic(system, omega, guess, samples, tol, max_iter, harmonics, jacobian, substeps, max_events,
                    deadline=None, accumulation="close", work_limit=None):
    t_wall = time.perf_counter()
    if isinstance(omega, bool) or not isinstance(omega, (int, float, np.integer, np.floating)):
        raise InputError("omega", f"must be a number, got {omega!r}")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 8:
        raise InputError("samples", f"must be an integer >= 8, got {samples!r}")
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 0 < float(tol) < 1:
        raise InputError("tol", f"must be a number in (0, 1), got {tol!r}")
    if jacobian not in ("saltation", "fd"):
        raise InputError("jacobian", f"must be 'saltation' or 'fd', got {jacobian!r}")
    flow = ExactFlow(system, omega, substeps=substeps, max_events=max_events, accumulation=accumulation)
    flow.deadline = deadline
    flow.work_limit = None if work_limit is None else float(work_limit)
    n, D, T = flow.n, flow.D, flow.T
    omega = flow.omega
    t_s, q_s, u_s = _start(flow, guess, omega)
    z_osc = flow.osc(t_s)
    err = {}

    def residual(x, jac=True):
        z0 = np.concatenate([x, z_osc])
        try:
            out = flow.simulate(t_s, z0, jac=(jac and jacobian == "saltation"))
        except (EventError, ValueError) as exc:  # ValueError: event bracketing lost to rounding
            err["msg"] = f"{type(exc).__name__}: {exc}"
            return np.full(2 * n, np.nan), None
        R = out.end_state[:2 * n] - x
        if not jac:
            return R, None
        if jacobian == "saltation":
            return R, out.monodromy[:2 * n] - np.eye(2 * n)
        return R, central_difference_jacobian(lambda xp: residual(xp, False)[0], x)

    x = np.concatenate([q_s, u_s])
    hist, nfev, success, message = [], 0, False, ""
    R, J = residual(x)
    nfev += 1
    it = 0
    for it in range(max_iter + 1):
        if not np.all(np.isfinite(R)):
            message = f"event-driven flow failed at iteration {it}: {err.get('msg', 'non-finite residual')}"
            break
        r = float(np.max(np.abs(R)))
        hist.append(r)
        if r <= tol:
            success, message = True, f"converged: ||R||_inf = {r:.2e} after {it} iterations"
            break
        if it == max_iter:
            message = f"no convergence in {max_iter} iterations: ||R||_inf = {r:.2e}"
            break
        if J is None or not np.all(np.isfinite(J)):
            message = f"Jacobian is not finite at iteration {it}"
            break
        dx = np.linalg.lstsq(J, -R, rcond=1e-13)[0]
        r2, lam, best = float(np.linalg.norm(R)), 1.0, None
        while True:
            Rt, _ = residual(x + lam * dx, False)
            nfev += 1
            rt2 = float(np.linalg.norm(Rt)) if np.all(np.isfinite(Rt)) else np.inf
            if best is None or rt2 < best[0]:
                best = (rt2, lam)
            if rt2 <= (1.0 - 1e-4 * lam) * r2 or lam < 1.0 / 1024:
                break
            lam *= 0.5
        if not np.isfinite(best[0]) or (best[0] >= r2 and r > 1e3 * tol):
            message = (f"line search failed at iteration {it}: ||R||_inf stalls at {r:.2e}"
                       + (f" ({err['msg']})" if "msg" in err else ""))
            break
        if best[0] >= r2:  # rounding level: accept the full step once more
            best = (best[0], 1.0)
        x = x + best[1] * dx
        R, J = residual(x)
        nfev += 1

    # ---- output on the uniform grid from the section state
    N = int(samples)
    t = np.linspace(0.0, T, N + 1)
    tau = t[:-1].copy()
    tau[tau < t_s] += T
    order = np.argsort(tau, kind="stable")
    info = {"residual_history": hist, "section_time": t_s, "substeps": flow.substeps,
            "taylor_terms": flow.n_taylor}
    q_time = np.full((N + 1, n), np.nan)
    u_time = np.full((N + 1, n), np.nan)
    m_el = len(system.elements)
    lam_t = np.full((N + 1, m_el), np.nan)
    try:
        out = flow.simulate(t_s, np.concatenate([x, z_osc]), jac=True, sample_times=tau[order], record=True)
    except (EventError, ValueError) as exc:
        out = None
        success, message = False, f"{message}; final flow failed: {exc}"
    if out is not None:
        Zs = np.empty((D, N))
        Zs[:, order] = out.samples
        modes = np.empty(N, dtype=np.int64)
        modes[order] = out.sample_modes
        q_time[:N], u_time[:N] = Zs[:n].T, Zs[n:2 * n].T
        q_time[N], u_time[N] = q_time[0], u_time[0]
        if m_el:
            for md in np.unique(modes):
                if md == MOREAU:
                    continue
                sel = modes == md
                lam_t[:N][sel] = flow.full_force(int(md), Zs[:, sel]).T
            lam_t[N] = lam_t[0]
        qmax, qmin, n_roots = extrema(flow, out.nodes)
        evs = [Event(float(np.mod(e.t, T)), e.kind, e.impulse, e.velocity, e.element) for e in out.events]
        evs.sort(key=lambda e: e.t)
        Phi = out.monodromy[:2 * n]
        mult = np.linalg.eigvals(Phi)
        x_end = out.end_state[:2 * n]
        info.update(
            amplitude_exact=0.5 * (qmax - qmin), q_max=qmax, q_min=qmin, velocity_zeros=n_roots,
            events=evs, n_events=len(evs),
            n_impacts=sum(1 for e in evs if e.impulse != 0.0),
            impulses=np.array([[e.t, e.impulse] for e in evs if e.impulse != 0.0]).reshape(-1, 2),
            stick_fraction=_stick_fraction(flow, out.mode_time, None) / T,
            element_stick_fraction=[_stick_fraction(flow, out.mode_time, j) / T for j in range(flow.m)],
            mode_fractions={_mode_name(flow, m): v / T for m, v in out.mode_time.items()},
            moreau=out.moreau_segments, jacobian_exact=out.monodromy_exact,
            floquet_multipliers=mult, max_floquet_modulus=float(np.max(np.abs(mult))),
            monodromy=Phi, state_at_section=x.copy(),
            periodicity_error=float(np.max(np.abs(x_end - x))),
            trajectory=ExactTrajectory(flow, out.nodes, t_s))
    if out is not None and out.moreau_segments:
        message = f"{message}; {out.message}"
    n_h = min(int(harmonics), (N - 1) // 2)
    q_hat = fourier.fft(q_time[:N], n_h) if out is not None else np.full((2 * n_h + 1, n), np.nan)
    residual_norm = hist[-1] if hist else np.inf
    return PeriodicSolution(method="exact", omega=omega, harmonics=n_h, steps=N, success=bool(success),
                            message=message, iterations=max(0, len(hist) - 1), nfev=nfev,
                            residual=residual_norm, wall_time=time.perf_counter() - t_wall, t=t,
                            q_hat=q_hat, time_dofs=np.arange(n), q_time=q_time, u_time=u_time, lam=lam_t,
                            impulses=None, x=np.concatenate([q_time[0], u_time[0]]), info=info)


def _mode_name(flow, code):
    """``"slip+"`` (one element) or ``"(stick,free)"`` (several); ``"moreau-jean"`` for the fallback."""
    if code == MOREAU:
        return "moreau-jean"
    st = mode_tuple(code, flow.m)
    names = [MODE_NAMES[s] for s in st]
    return names[0] if len(names) == 1 else "(" + ",".join(names) + ")"


def _stick_fraction(flow, mode_time, j):
    """Time (s) with element ``j`` (None: any element) in stick or closed contact."""
    tot = 0.0
    for code, dt in mode_time.items():
        if code == MOREAU:
            continue
        st = mode_tuple(code, flow.m)
        sel = st if j is None else (st[j],)
        if any(s in (STICK, CLOSED) for s in sel):
            tot += dt
    return float(tot)
