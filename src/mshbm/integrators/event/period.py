"""One forcing period by the exact event-driven flow (:class:`EventIntegrator`, ``integrator="event"``).

The flow (:class:`~mshbm.integrators.event.flow.EventFlow`) has no step: ``steps`` is the output grid
(and the Moreau-Jean steps per period of its fallback at accumulations).  The sensitivities are the
saltation-corrected monodromy, exact.  With the harmonic coupling force of MS-HBM
(``coupling=(c0, Tr)``) the coupling coefficients ``c = c0 + Tr p`` are *forcing states* of the flow
(``coupling_harmonics = n_h``): the sensitivities to ``p`` are columns of the same monodromy times ``Tr``,
and the Fourier coefficients of ``q`` are the exact ones of the flow (Gauss-Legendre quadrature on its
smooth pieces).  The element forces of a recorded run are those of the mode at each sample (the mean
step force inside Moreau-Jean segments), the impulses per output interval the force times ``h`` plus
the impacts in it.  A run that fails (:class:`~mshbm.integrators.event.EventError`, or event bracketing
lost to rounding) is a :class:`~mshbm.integrators.interface.PeriodRun` with its ``error``.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ...system import System
from ..interface import PeriodIntegrator, PeriodRun
from ..subsystem import local_elements, submatrix
from .flow import EventFlow
from .modes import MOREAU, EventError
from .trajectory import contact_margins, extrema, run_summary

__all__ = ["EventIntegrator"]


class EventIntegrator(PeriodIntegrator):
    """The event-driven flow over one period (module docstring); parameters as
    :class:`~mshbm.integrators.moreau_period.MoreauJeanIntegrator`, and

    accumulation : {"moreau", "close"}
        At an accumulation of impacts: Moreau-Jean segments (default) or the Zeno closure of the contact
        (:mod:`mshbm.integrators.event`).
    """

    name = "event"
    #: a residual with its Jacobian costs one flow with sensitivities, and the runs are cached: a
    #: residual-only request at the same state is answered from the run with sensitivities
    cheap_sensitivities = True

    def __init__(self, system, omega, steps, dofs=None, coupling=None, harmonics=0, theta=None, project=None,
                 accumulation="moreau"):
        self.omega, self.steps = float(omega), int(steps)
        system = system.at(omega)  # the forcing at omega (a constant forcing: the same system)
        T = 2 * np.pi / self.omega
        self.h = T / self.steps
        self.t = np.linspace(0.0, T, self.steps + 1)
        dense = lambda A: A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)
        if dofs is not None:  # the subsystem of the time-stepped DOFs, its elements renumbered
            M, C, K = (dense(submatrix(getattr(system, a), dofs, dofs)) for a in "MCK")
            system = System(M, C, K, system.f_hat[:, dofs], local_elements(system, dofs), name=f"{system.name}-sub")
        self.n_elements = len(system.elements)
        self.coupled = coupling is not None
        self.n_h = int(harmonics)
        self.flow = EventFlow(system, self.omega, accumulation=accumulation, moreau_steps=self.steps,
                              coupling_harmonics=self.n_h if self.coupled else None)
        self.n = self.n_time = system.n
        if self.coupled:
            c0, Tr = coupling
            self.c0 = np.asarray(c0, dtype=float).reshape(-1)
            self.Tr = dense(Tr)
        self._cache = []

    def flow_run(self, q0, u0, p=None, sensitivities=False, record=False):
        """The flow's own record (:class:`~mshbm.integrators.event.FlowRun`) of the period from ``(q0, u0)``
        under ``p``; raises :class:`EventError` or ``ValueError`` where the flow fails."""
        fl = self.flow
        kw = {}
        if self.coupled:
            fl.set_forcing((self.c0 + self.Tr @ p).reshape(2 * self.n_h + 1, self.n))
            kw = dict(jac_cols="all", fourier=self.n_h)
        return fl.simulate(0.0, fl.state(0.0, q0, u0), jac=sensitivities, sample_times=self.t if record else None,
                           record=record, **kw)

    def run(self, q0, u0, p=None, sensitivities=False, record=False):
        # the last few runs: a run with sensitivities also answers a request without them at the same state
        # (the flow, its events and Fourier coefficients do not depend on them: the same numbers)
        key = np.concatenate([q0, u0] + ([p] if self.coupled else [])).tobytes()
        for k, s, r, out in self._cache:
            if k == key and r == record and (s == sensitivities or (s and not sensitivities)):
                return out
        try:
            fr = self.flow_run(q0, u0, p, sensitivities, record)
        except (EventError, ValueError) as exc:  # ValueError: event bracketing lost to rounding
            out = PeriodRun(error=f"{type(exc).__name__}: {exc}")
        else:
            out = self._period_run(fr, sensitivities, record)
        self._cache = ([(key, sensitivities, record, out)] + self._cache)[:3]
        return out

    def _period_run(self, fr, sensitivities, record):
        n = self.n
        out = PeriodRun(end=fr.end_state[:2 * n], events=fr.events, raw=fr)
        if self.coupled:
            out.q_hat = fr.q_hat.reshape(-1)
        if sensitivities:  # columns [q0, u0, forcing states = d/dc]; dc/dp = Tr
            Pz = fr.monodromy[:2 * n]
            if self.coupled:
                dq = fr.q_hat_sensitivity.reshape(-1, Pz.shape[1])
                out.jacobian = np.hstack([Pz[:, :2 * n], Pz[:, 2 * n:] @ self.Tr])
                out.q_hat_jacobian = np.hstack([dq[:, :2 * n], dq[:, 2 * n:] @ self.Tr])
            else:
                out.jacobian = Pz
        if record:
            Z = fr.samples
            out.q, out.u = Z[:n].T.copy(), Z[n:2 * n].T.copy()
            out.forces, out.impulses = self._forces(fr)
            out.extrema = extrema(self.flow, fr.nodes)[:2]  # zeros of u between the nodes
        return out

    def _forces(self, fr):
        """Element forces at the samples (N + 1, m) and impulses per output interval (N, m)."""
        fl, N, h = self.flow, self.steps, self.h
        lam = np.full((N + 1, self.n_elements), np.nan)
        modes = fr.sample_modes
        for code in np.unique(modes):
            sel = modes == code
            lam[sel] = (fl.moreau_force(fr.moreau_segments, self.t[sel]) if code == MOREAU
                        else fl.full_force(int(code), fr.samples[:, sel]).T)
        P = np.nan_to_num(lam[:-1]) * h
        for ev in fr.events:
            if ev.impulse != 0.0:
                P[min(int(ev.t / h), N - 1), ev.element] += ev.impulse
        return lam, P

    def event_signature(self, q0, u0, p=None):
        out = self.run(q0, u0, p)
        return None if out.failed else tuple((int(e.element), e.kind) for e in out.events)

    def solution_info(self, run, whole_system=False):
        fr = run.raw
        info = {"event_integrator": run_summary(fr)}
        if whole_system:
            info["event_multipliers"] = np.linalg.eigvals(run.jacobian)
        info["event_list"] = fr.events
        info["contact_margins"] = contact_margins(self.flow, fr)
        if whole_system:
            qmax, qmin = run.extrema
            info.update(amplitude_exact=0.5 * (qmax - qmin), q_max=qmax, q_min=qmin)
        return info
