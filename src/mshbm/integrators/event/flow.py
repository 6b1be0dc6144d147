"""The event-driven flow: :class:`EventFlow` (its parameters and the augmented state) and
:meth:`EventFlow.simulate`, which returns a :class:`FlowRun`.

:meth:`EventFlow.simulate` advances sub-step by sub-step of the current mode, locates the first event on
each (:func:`~.location.locate`), applies the transition and the saltation of the sensitivities
(:mod:`.transitions`), samples the state on the requested times, adds the Fourier integrals
(:mod:`.quadrature`) and switches to Moreau-Jean segments at accumulations (:mod:`.fallback`).  The module
docstring of :mod:`mshbm.integrators.event` describes the model and the numerics.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ...errors import InputError
from ...solvers.newton import charge
from ...system import System
from .fallback import MoreauFallback
from .location import BATCH_MARGIN, event_free_steps, locate
from .modes import FREE, MAX_DOFS, MOREAU, SLIP_P, EventError, ModeCatalogue, _Switch, mode_code, mode_tuple
from .quadrature import FourierQuadrature
from .transitions import Transitions

__all__ = ["EventFlow", "FlowRun", "WORK_STEP", "WORK_LOCATE", "WORK_EVENT", "WORK_GEMM", "WORK_PER_EVALUATION"]

#: the deterministic work count of :attr:`EventFlow.work` (flop equivalents): a full sub-step costs ``WORK_STEP`` (the
#: loop's Python overhead) plus ``2 D^2`` for the state and ``2 D^2 / WORK_GEMM`` per sensitivity column it updates
#: (matrix products run ``WORK_GEMM`` times faster per flop than matrix-vector products), a located sub-step
#: ``WORK_LOCATE`` plus a Taylor series ``2 D^2 n_T``, an event ``WORK_EVENT`` plus ``2 D^2 n_T (1 + n_cols /
#: WORK_GEMM)``; one flop equivalent is about a nanosecond of one core (0.2-3 ns measured on the examples' flows)
WORK_STEP = 2e3
WORK_LOCATE = 2e4
WORK_EVENT = 2e5
WORK_GEMM = 8.0
#: the flow's work charged to the solve route's work meters (:func:`mshbm.solvers.newton.work_box`, whose unit is a
#: Newton residual evaluation) as one evaluation: about a millisecond of one core, as a Moreau-Jean or harmonic
#: problem's evaluation of the examples (0.3-1 ms); 1e10 flop equivalents took 3.1-5.8 s of CPU on the exact starts
#: of tests/unit/test_ladder_fallbacks.py.  The event-driven flow then spends the budgets of the start ladder, the
#: "frequency" start and the event-driven fallback by its cost, whatever the size of the system
WORK_PER_EVALUATION = 3e6


def _power_apply(md, P, k):
    """``E^k P`` (``k >= 1``, ``E`` the mode's exponential over one full sub-step): for ``k > 3`` from the binary
    powers ``E^(2^j)``, kept with the mode's shared exponentials (the next run, and the next flow with the same mode
    matrix, reuse them), so a run of ``k`` sub-steps costs about ``log2 k`` products instead of ``k``."""
    if k <= 3:
        for _ in range(k):
            P = md.E @ P
        return P
    pw = md.shared.setdefault("E_pow", [md.E])
    j = 0
    while k:
        if j == len(pw):
            pw.append(pw[-1] @ pw[-1])
        if k & 1:
            P = pw[j] @ P
        k >>= 1
        j += 1
    return P


@dataclass
class FlowRun:
    """One run of :meth:`EventFlow.simulate` from ``t0`` over its duration.

    Attributes
    ----------
    end_state : ndarray, shape (D,)
        The augmented state ``z`` at the end.
    monodromy : ndarray or None
        ``Phi = d z(end) / d z0[cols]``, shape (D, n_cols) (``jac``; columns :meth:`EventFlow.jac_columns`).
    events : list of Event
    samples : ndarray, shape (D, k)
        The state at the requested sample times.
    sample_modes : ndarray of int, shape (k,)
        Mode code of each sample (:data:`~.modes.MOREAU` inside Moreau-Jean segments).
    nodes : list or None
        ``(t, z_left, z_right, mode code)`` of the samples and events (``record``).
    mode_time : dict
        Time spent per mode code (s).
    end_mode : int
        Mode code at the end.
    moreau_segments : list of dict
        The Moreau-Jean segments: ``t_start, t_end, steps, reason`` and the mean element forces ``forces``
        (k, m) of their steps (impulse / h) at the steps' midpoints ``force_times``.
    monodromy_exact : bool
        False after a Moreau-Jean segment (its step Jacobians hold no saltation terms).
    message : str
    q_hat : ndarray or None
        Fourier coefficients of ``q`` over the run, shape (2 n_f + 1, n) (``fourier``).
    q_hat_sensitivity : ndarray or None
        ``d q_hat / d z0[cols]``, shape (2 n_f + 1, n, n_cols) (``fourier`` and ``jac``).
    """

    end_state: np.ndarray
    monodromy: np.ndarray | None
    events: list
    samples: np.ndarray
    sample_modes: np.ndarray
    nodes: list | None
    mode_time: dict
    end_mode: int
    moreau_segments: list
    monodromy_exact: bool
    message: str
    q_hat: np.ndarray | None = None
    q_hat_sensitivity: np.ndarray | None = None

    @property
    def switched(self):
        """A Moreau-Jean segment was used."""
        return bool(self.moreau_segments)


class _Samples:
    """The state at the requested sample times of one run, filled in time order: ``Z`` (D, k) and the mode
    code of each sample ``modes`` (k,)."""

    def __init__(self, times, D):
        self.t = np.asarray(times if times is not None else [], dtype=float)
        self.Z = np.empty((D, self.t.size))
        self.modes = np.empty(self.t.size, dtype=np.int64)
        self.i = 0  # the next sample to fill

    def at_start(self, a, z, code):
        """Samples at or before the start ``a``: the start state ``z``."""
        while self.i < self.t.size and self.t[self.i] <= a:
            self.Z[:, self.i], self.modes[self.i] = z, code
            self.i += 1

    def due(self, t_end):
        """The slice of the unfilled samples at times ``<= t_end``, or None."""
        i0 = self.i
        if not (i0 < self.t.size and self.t[i0] <= t_end):
            return None
        j1 = i0
        while j1 < self.t.size and self.t[j1] <= t_end:
            j1 += 1
        return slice(i0, j1)

    def fill(self, due, Z, code, nodes=None):
        """Fill the samples ``due`` with the states ``Z`` (D, k) of mode ``code`` (and record them as nodes)."""
        self.Z[:, due] = Z
        self.modes[due] = code
        if nodes is not None:
            for jj in range(due.start, due.stop):
                nodes.append((self.t[jj], self.Z[:, jj].copy(), self.Z[:, jj].copy(), code))
        self.i = due.stop

    def interpolate(self, tt, Zs, code=MOREAU):
        """Samples up to ``tt[-1]`` by linear interpolation of the states ``Zs`` (D, len(tt)) at ``tt``
        (Moreau-Jean segments)."""
        i0 = self.i
        i1 = i0
        while i1 < self.t.size and self.t[i1] <= tt[-1]:
            i1 += 1
        if i1 > i0:
            for r in range(self.Z.shape[0]):
                self.Z[r, i0:i1] = np.interp(self.t[i0:i1], tt, Zs[r])
            self.modes[i0:i1] = code
            self.i = i1

    def at_end(self, z, code):
        """The samples left (at the end time, by rounding): the end state ``z``."""
        if self.i < self.t.size:
            self.Z[:, self.i:] = z[:, None]
            self.modes[self.i:] = code


class EventFlow(ModeCatalogue, Transitions, FourierQuadrature, MoreauFallback):
    """Exact event-driven flow of a linear structure with any number of friction and contact elements.

    Parameters
    ----------
    system : System
        ``M, C, K`` are used as dense matrices (intended for up to a few hundred DOFs).  Elements:
        :class:`~mshbm.elements.Friction` and :class:`~mshbm.elements.Contact` between a DOF and the
        ground (elements with ``mu F_N = 0`` are ignored).
    omega : float
        Forcing angular frequency (rad/s), period ``T = 2 pi / omega``.
    substeps : int
        Minimal number of sub-steps per period of the event-search grid (raised per mode so that
        ``||D^-1 A_xx D||_1 h_s <= 1/2``, ``D`` the balancing scaling of :meth:`_scaling`: about
        ``2 T omega_max`` for lightly damped DOFs of highest frequency ``omega_max``).
    max_events : int
        Cap on events per simulated period (then an :class:`EventError`).
    accumulation : {"moreau", "close", "error"}
        What to do at an accumulation of impacts or chattering (module docstring).
    moreau_steps : int
        Moreau-Jean steps per period in the fallback segments.
    coupling_harmonics : int, optional
        ``n_c``: append *forcing states* for an additional force ``f_c(t) = sum_k F_c[k] b_k(t)`` on every
        DOF (``b = [1, cos(omega t), sin(omega t), ..., sin(n_c omega t)]``, coefficients ``F_c`` of
        shape ``(2 n_c + 1, n)`` set by :meth:`set_forcing`): ``y_{k,i}(t) = F_c[k, i] b_k(t)``, shape
        ``(2 n_c + 1) n``, evolving by the exact oscillator.  The mode matrices then do not depend on
        ``F_c``, and the sensitivities to ``F_c`` are columns of the same monodromy
        (``simulate(..., jac_cols="all")``).  Per DOF ``i`` and harmonic ``k`` with ``a = F_c[2k-1, i]``,
        ``b = F_c[2k, i]`` the two states are the force ``Y1 = a cos(k omega t) + b sin(k omega t)`` and
        ``Y2 = -a sin(k omega t) + b cos(k omega t)`` (``Y1' = k omega Y2``, ``Y2' = -k omega Y1``), plus the
        constant ``F_c[0, i]``: at ``t = 0`` the forcing states are ``F_c`` itself, so the columns of
        ``Phi`` for them are ``d / d F_c``.  MS-HBM uses it for the harmonic coupling forces.
    """

    def __init__(self, system, omega, substeps=128, max_events=10000, accumulation="moreau", moreau_steps=4096,
                 coupling_harmonics=None):
        if not isinstance(system, System):
            raise InputError("system", f"must be an mshbm.System, got {type(system).__name__}")
        omega = float(omega)
        if not math.isfinite(omega) or omega <= 0:
            raise InputError("omega", f"must be finite and > 0, got {omega}")
        system = system.at(omega)  # the forcing at omega (a constant forcing: the same system)
        if system.n > MAX_DOFS:
            raise InputError("integrator", f"the event-driven flow uses dense {2 * system.n}-square matrix "
                             f"exponentials; {system.n} DOFs is more than {MAX_DOFS}: use the Moreau-Jean "
                             "integrator, or MS-HBM (its time-domain subsystem is small)")
        if accumulation not in ("moreau", "close", "error"):
            raise InputError("accumulation", f"must be 'moreau', 'close' or 'error', got {accumulation!r}")
        for el in system.elements:
            if getattr(el, "smooth", False):
                raise InputError(f"{el.kind}.dof", f"the event-driven flow is built on the linear modes between "
                                 f"events and cannot integrate the {el.kind} spring on DOF {el.dof}; use "
                                 "integrator 'moreau' (shooting or mshbm), or hbm / dlft")
            if el.history:
                raise InputError("friction.tangential_stiffness", "the event-driven flow does not support "
                                 "elastic friction (Jenkins: a slider state); use method 'hbm'")
            if el.relative_to is not None:
                raise InputError(f"{el.kind}.relative_to", "the event-driven flow supports elements between a "
                                 "DOF and the ground; relative elements are not supported (use shooting, "
                                 "mshbm or hbm with the Moreau-Jean integrator)")
            if getattr(el, "cone_partner", None) is not None:
                raise InputError("friction.cone_partner", f"the event-driven flow does not support the 3-D "
                                 f"frictional contact (friction on DOF {el.dof} with a cone partner: the slip "
                                 "direction rotates); use integrator 'moreau' (shooting or mshbm) or method 'hbm'")
            if getattr(el, "normal_contact", None) is not None:
                raise InputError("friction.normal_contact", "the event-driven flow does not support friction "
                                 "whose normal load comes from a contact; use the Moreau-Jean integrator "
                                 "(shooting or mshbm) or hbm")
            if not (el.bounded or el.unilateral):
                raise InputError("elements", f"the event-driven flow supports friction and contact elements, "
                                             f"got {el.kind}")
        dense = lambda A: A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)
        M, C, K = dense(system.M), dense(system.C), dense(system.K)
        n, nf = system.n, system.n_forcing_harmonics
        self.system, self.omega, self.n, self.nf = system, omega, n, nf
        self.T = 2.0 * np.pi / omega
        self.max_events = int(max_events)
        self.accumulation = accumulation
        self.moreau_steps = int(moreau_steps)
        #: absolute ``time.perf_counter()`` after which :meth:`simulate` raises an EventError (None: no limit); the
        #: result then depends on the machine's load: analyses that must be reproducible use ``work_limit``
        self.deadline = None
        #: work done by :meth:`simulate` since the flow was made (flop equivalents, :data:`WORK_STEP`): deterministic
        self.work = 0.0
        #: a budget of ``work`` (None: none): the run that exceeds it ends with an EventError, on every machine alike
        self.work_limit = None
        #: screen runs of event-free sub-steps at once (:func:`~.location.event_free_steps`; the same flow, the
        #: states differ by rounding): set by the stability analysis, whose flows sample nothing
        self.batch = False
        #: screen runs of event-free sub-steps (as ``batch``) but advance them one sub-step at a time, with the
        #: products and Fourier records of the sub-step-by-sub-step loop: bit-identical to it, without its per-step
        #: event search (False: every sub-step searched, the reference the tests compare with)
        self.screen = True
        nx = 0 if coupling_harmonics is None else int(coupling_harmonics)
        if coupling_harmonics is not None and nx < 0:
            raise InputError("coupling_harmonics", f"must be >= 0, got {coupling_harmonics}")
        self.nx = nx
        self.ncx = (2 * nx + 1) if coupling_harmonics is not None else 0  # forcing components per DOF
        self.iy = 2 * n + 1 + 2 * nf  # first forcing state
        D = self.iy + self.ncx * n
        self.D, self.i1 = D, 2 * n
        self.Fc = np.zeros((self.ncx, n))
        # the forcing states' rotation pairs (relative to iy): Y1 rows _yc, Y2 rows _ys, frequencies _yw
        kk = np.repeat(np.arange(1, nx + 1), n)
        ii = np.tile(np.arange(n), nx)
        self._yc, self._ys = (2 * kk - 1) * n + ii, 2 * kk * n + ii
        self._yw = kk * omega
        self._ck = (self.omega * np.arange(1, nx + 1))
        self.M = M
        self.Minv = sla.cho_solve(sla.cho_factor(M), np.eye(n))
        Rr = np.zeros((n, D))  # r = f_ex - C u - K q as a row block on z
        Rr[:, :n], Rr[:, n:2 * n] = -K, -C
        Rr[:, 2 * n:self.iy] = system.f_hat.T
        for k in ([0] + list(range(1, self.ncx, 2))) if self.ncx else []:  # the constant and the Y1 states
            Rr[np.arange(n), self.iy + k * n + np.arange(n)] = 1.0
        self.Rr = Rr
        base = np.zeros((D, D))
        base[:n, n:2 * n] = np.eye(n)
        for k in range(1, nf + 1):
            ic, is_ = 2 * n + 2 * k - 1, 2 * n + 2 * k
            base[ic, is_], base[is_, ic] = -k * omega, k * omega
        for k in range(1, nx + 1):  # (Y1, Y2)' = k omega (Y2, -Y1)
            ic, is_ = self.iy + (2 * k - 1) * n + np.arange(n), self.iy + 2 * k * n + np.arange(n)
            base[ic, is_], base[is_, ic] = k * omega, -k * omega
        self.base = base
        #: the acting elements (indices into system.elements) and their data
        self.index = [j for j, el in enumerate(system.elements) if el.acts]
        self.elements = [system.elements[j] for j in self.index]
        m = self.m = len(self.elements)
        self.W = np.zeros((n, m))
        for a, el in enumerate(self.elements):
            self.W[el.dof, a] = el.sign
        self.MW = self.Minv @ self.W
        self.sw_all = np.einsum("ij,ij->j", self.W, self.MW) if m else np.zeros(0)  # w_j^T M^-1 w_j
        self.dof = np.array([el.dof for el in self.elements], dtype=np.int64)
        self.sign = np.array([el.sign for el in self.elements])
        self.is_contact = np.array([el.unilateral for el in self.elements], dtype=bool)
        self.bound = np.array([0.0 if el.unilateral else el.bound for el in self.elements])
        self.gap = np.array([el.gap if el.unilateral else 0.0 for el in self.elements])
        self.e = np.array([el.restitution if el.unilateral else 0.0 for el in self.elements])
        kmax, mmax = np.abs(K).max(), np.abs(M).max()
        self._kmax, self._mmax = kmax, mmax
        fmax = np.abs(system.f_hat).max()
        # reference displacement (thresholds when the state itself is ~0)
        self.qref = max(fmax / kmax if kmax > 0 else fmax / (mmax * omega ** 2) if mmax > 0 else 0.0,
                        float(np.abs(self.gap).max()) if m else 0.0, 1e-300)
        self._modes = {}
        self._mj = {}
        self.min_substeps = int(substeps)
        try:
            free = self.mode(tuple(FREE if c else SLIP_P for c in self.is_contact) if m else ())
        except EventError as exc:  # the system itself is out of the flow's reach: bad input, said at once
            raise InputError("integrator", str(exc)) from None
        self.substeps = int(round(self.T / free.h))
        self.h = free.h
        self.n_taylor = free.n_taylor

    # ------------------------------------------------------------------ simulation
    def simulate(self, *args, **kwargs):
        """:meth:`_simulate` (its parameters), its work (:attr:`work`) charged to the solve route's work meters at
        :data:`WORK_PER_EVALUATION` a Newton residual evaluation (:func:`mshbm.solvers.newton.charge`)."""
        w0 = self.work
        try:
            return self._simulate(*args, **kwargs)
        finally:
            charge((self.work - w0) / WORK_PER_EVALUATION)

    def _simulate(self, t0, z0, duration=None, jac=False, sample_times=None, record=False, mode=None,
                  jac_cols="state", fourier=None, jac_init=None):
        """Event-driven flow from ``(t0, z0)`` over ``duration`` (default one period).

        Parameters
        ----------
        t0 : float
        z0 : ndarray, shape (D,)
            Augmented state ``[q, u, oscillator]`` (the oscillator part is reset to ``osc(t0)``).
        jac : bool
            Also return ``Phi = d z(t0 + duration) / d (q0, u0)``, shape (D, 2n).
        sample_times : ndarray, optional
            Sorted absolute times in ``[t0, t0 + duration]`` where the state is recorded.
        record : bool
            Keep the nodes (samples and events) for dense output and extrema.
        mode : int or tuple, optional
            Initial mode (default: the consistent mode at ``z0``).
        jac_cols : {"state", "all"}
            Columns of ``Phi`` (:meth:`jac_columns`): ``d z / d (q0, u0)``, or also ``d z / d y0`` (the
            forcing states of ``coupling_harmonics``).
        fourier : int, optional
            ``n_f``: also return the Fourier coefficients of ``q`` over ``[t0, t0 + duration]``,
            ``q_hat`` shape ``(2 n_f + 1, n)`` (rows ``[a_0, a_1, b_1, ...]`` with ``q ~ a_0 + sum a_k
            cos(k omega t) + b_k sin(k omega t)``, the mean over ``duration`` divided like a period), by
            Gauss-Legendre quadrature on every smooth piece of the exact flow (exact to rounding), and with
            ``jac`` their sensitivities ``dq_hat`` shape ``(2 n_f + 1, n, n_cols)`` (``q`` is continuous at
            events, so the event-time variations add nothing).  Trapezoidal on Moreau-Jean segments.
        jac_init : ndarray, optional
            Shape ``(D, k)``: with ``jac``, ``Phi`` starts from these columns instead of the identity's, so it is
            the derivative along ``k`` directions of the start state (``Phi @ V`` for the full ``Phi``, at the cost
            of ``k`` columns); not with forcing states (``coupling_harmonics``) or ``fourier``.

        Returns
        -------
        FlowRun
        """
        n, D = self.n, self.D
        duration = self.T if duration is None else float(duration)
        T_end = t0 + duration
        z = np.array(z0, dtype=float)
        z[2 * n:] = self.exo(t0)
        cols = self.jac_columns(jac_cols)
        Phi = np.eye(D)[:, cols].copy() if jac else None
        if jac and jac_init is not None:
            if self.ncx or fourier is not None:
                raise ValueError("jac_init needs a flow without forcing states and no Fourier sums")
            Phi = np.array(jac_init, dtype=float).reshape(D, -1)
        four = None
        if fourier is not None:
            nfr = int(fourier)
            # [n_f, q_hat sums, dq_hat sums, full sub-steps whose pieces are summed at the end per mode]
            four = [nfr, np.zeros((2 * nfr + 1, n)), np.zeros((2 * nfr + 1, n, cols.size)) if jac else None, {}]
        samp = _Samples(sample_times, D)
        nodes = [] if record else None
        events = []
        moreau = []
        mode_time = {}
        ctx = {"impacts": {}}
        max_events = self.max_events * max(1, int(math.ceil(duration / self.T - 1e-9)))
        qs = self.qscale(z)
        # per-component scale of the state: the event functions' thresholds are 1e-12 of |C| times it
        state_scale = np.concatenate([np.full(n, qs), np.full(n, max(np.abs(z[n:2 * n]).max(), self.omega * qs)),
                                      np.ones(D - 2 * n)])
        thr_cache = {}

        a = float(t0)
        st = None
        if mode is not None:
            st = mode if isinstance(mode, tuple) else mode_tuple(mode, self.m)
            z = self._project(z, st)
        else:
            st, z = self.select(z)
        if jac:
            Phi = self._project_jac(Phi, st)
        st, z, Phi = self._start_in_penetration(st, z, a, ctx, Phi, events, nodes)
        samp.at_start(a, z, mode_code(st))
        if record:
            nodes.append((a, z.copy(), z.copy(), mode_code(st)))

        def enter(st, z):
            md = self.mode(st)
            thr = thr_cache.get(st)
            if thr is None:
                thr = thr_cache[st] = 1e-12 * (np.abs(md.C) @ state_scale)
            return md, thr, (md.C @ z) > thr

        md, thr, est = enter(st, z)
        # without forcing states and Fourier sums, the sensitivities of a run of full sub-steps in one mode are
        # E^k Phi, formed by squaring when Phi is next needed (log2 k products of D x D matrices instead of k)
        lazy = bool(jac and not self.ncx and four is None)
        pend = 0
        # runs of event-free full sub-steps screened at once (batch; no samples, records or Fourier sums to form)
        batch = bool(self.batch and not record and four is None and (lazy or not jac) and not samp.t.size)
        # screened runs advanced sub-step by sub-step (the same numbers as without screening): no samples or records
        screen = bool(self.screen and not batch and not record and not samp.t.size)
        bthr_cache = {}
        # the work count (deterministic): per full sub-step, located sub-step and event
        d2, ncol = 2.0 * D * D, (Phi.shape[1] if jac else 0)
        w_step = WORK_STEP + d2 * (1.0 + (0 if lazy else ncol / WORK_GEMM))
        w_locate = WORK_LOCATE + d2 * self.n_taylor
        w_event = WORK_EVENT + d2 * self.n_taylor * (1.0 + ncol / WORK_GEMM)
        while a < T_end:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                raise EventError("time limit of the event-driven simulation reached")
            if self.work_limit is not None and self.work > self.work_limit:
                raise EventError(f"work budget of the event-driven simulation spent ({self.work:.3g} of "
                                 f"{self.work_limit:.3g} flop equivalents; at t = {a:.9g}, {len(events)} events)")
            if (batch or screen) and est.all():
                bthr = bthr_cache.get(st)
                if bthr is None:
                    bthr = bthr_cache[st] = BATCH_MARGIN * 1e-12 * (np.abs(np.vstack([md.C, md.CA])) @ state_scale)
                adv = event_free_steps(md, z, int((T_end - a) / md.h) - 2, bthr)
                if adv > 0:
                    self.work += adv * w_step
                    t_mode = mode_time.get(md.code, 0.0)
                    if batch:
                        z = _power_apply(md, z, adv)
                        pend += adv if jac else 0
                        for _ in range(adv):  # the same sums as step by step
                            a += md.h
                            t_mode += md.h
                    else:  # the loop below on event-free full sub-steps, without its event search
                        E, h = md.E, md.h
                        for _ in range(adv):
                            if four is not None:
                                self._fourier_piece(md, z, None, Phi, a, h, four)  # a record (full sub-step)
                            if jac:
                                if lazy:
                                    pend += 1
                                else:  # (pend stays 0 without lazy)
                                    Phi = self.emul(md, Phi, sens=True)
                            z = E @ z
                            a += h
                            t_mode += h
                    mode_time[md.code] = t_mode
                    continue
            rem = T_end - a
            h = md.h if rem > md.h * (1 + 1e-12) else rem
            nt = md.n_taylor
            W = None
            if h == md.h:
                zb = md.E @ z
            else:
                W = self.powers(md, z)
                zb = W @ self.spow(h, nt)
            s_ev, i_ev, W = locate(self, md, z, zb, W, h, thr, est, a)
            self.work += w_step + w_locate
            s_end = h if s_ev is None else s_ev
            due = samp.due(a + s_end)
            if due is not None:  # samples on this piece: from the Taylor series of the flow
                if W is None:
                    W = self.powers(md, z)
                samp.fill(due, W @ self.spow(samp.t[due] - a, nt).T, md.code, nodes)
            mode_time[md.code] = mode_time.get(md.code, 0.0) + s_end
            if four is not None and s_end > 0.0:
                self._fourier_piece(md, z, W, Phi, a, s_end, four)
            if s_ev is None:
                if jac:
                    if lazy and h == md.h:
                        pend += 1  # E^pend applied at once when Phi is next needed (fewer products)
                    else:
                        Phi = _power_apply(md, Phi, pend) if pend else Phi
                        pend = 0
                        Phi = self.emul(md, Phi, sens=True) if h == md.h else self.propagate_matrix(md, Phi, h)
                a += h
                z = zb
                continue
            z = W @ self.spow(s_ev, nt)
            if jac:
                if pend:
                    Phi, pend = _power_apply(md, Phi, pend), 0
                Phi = self.propagate_matrix(md, Phi, s_ev)
            a += s_ev
            z[2 * n:] = self.exo(a)
            self.work += w_event
            try:
                new, zp, Dg, evs = self._transition(md, i_ev, z, a, ctx)
                stall = self._stalled(events + evs, a)
                if stall:
                    if self.accumulation != "moreau":
                        raise EventError(stall)
                    raise _Switch(stall, [])
            except _Switch as sw:
                if record:
                    nodes.append((a, z.copy(), z.copy(), MOREAU))
                start = self._moreau_start(md, i_ev, z, a, Phi) if jac else None
                a, z, Phi, seg = self._moreau(a, z, T_end, Phi, samp.interpolate, nodes, sw.reason, four)
                moreau.append(seg)
                mode_time[MOREAU] = mode_time.get(MOREAU, 0.0) + seg["t_end"] - seg["t_start"]
                ctx["impacts"].clear()
                st, z = self.select(z)
                if jac:
                    Phi = self._project_jac(self._moreau_shift(start, seg, z, st, T_end, Phi), st)
                if record:
                    nodes.append((a, z.copy(), z.copy(), mode_code(st)))
                md, thr, est = enter(st, z)
                continue
            st, z, Phi = self._event(md, i_ev, z, a, ctx, Phi, events, nodes, new, zp, Dg, evs)
            if len(events) > max_events:
                last = events[-min(100, len(events)):]
                raise EventError(f"more than {self.max_events} events in one period (accumulation: the last "
                                 f"{len(last)} events lie in t = [{last[0].t:.9g}, {last[-1].t:.9g}], kinds "
                                 f"{sorted({e.kind for e in last})})")
            z[2 * n:] = self.exo(a)
            md, thr, est = enter(st, z)
        if pend:
            Phi = _power_apply(md, Phi, pend)
        if record:
            nodes.append((T_end, z.copy(), z.copy(), md.code))
        samp.at_end(z, md.code)
        msg = ""
        if moreau:
            msg = (f"switched to Moreau-Jean ({self.moreau_steps} steps per period) in {len(moreau)} segment(s): "
                   + "; ".join(f"{s['reason']}, until t = {s['t_end']:.9g}" for s in moreau))
        res = FlowRun(end_state=z, monodromy=Phi, events=events, samples=samp.Z, sample_modes=samp.modes, nodes=nodes,
                      mode_time=mode_time, end_mode=md.code, moreau_segments=moreau, monodromy_exact=not moreau,
                      message=msg)
        if four is not None:
            self._fourier_flush(four)
            scale = np.full(2 * four[0] + 1, 2.0 / duration)
            scale[0] = 1.0 / duration
            res.q_hat = four[1] * scale[:, None]
            res.q_hat_sensitivity = None if four[2] is None else four[2] * scale[:, None, None]
        return res

    def _start_in_penetration(self, st, z, a, ctx, Phi, events, nodes):
        """A contact that starts in penetration while approaching: the impact now.  Returns ``(st, z, Phi)``."""
        g, gam = self.gaps(z), self.gammas(z)
        pen = [j for j in range(self.m) if self.is_contact[j] and st[j] == FREE and g[j] <= 0.0 and gam[j] < 0.0]
        if not pen:
            return st, z, Phi
        start_mode = self.mode(st)
        i_ev = next(i for i, (j, kd, _) in enumerate(start_mode.ev) if j == pen[0] and kd == "gap")
        try:
            return self._event(start_mode, i_ev, z, a, ctx, Phi, events, nodes)
        except _Switch:  # a negligible first bounce: close the contact (what Moreau-Jean would do too)
            saved, self.accumulation = self.accumulation, "close"
            try:
                return self._event(start_mode, i_ev, z, a, ctx, Phi, events, nodes)
            finally:
                self.accumulation = saved
