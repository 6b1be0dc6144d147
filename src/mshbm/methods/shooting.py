"""Full shooting with Moreau-Jean time-stepping of the set-valued laws.

Unknowns ``x = (q(0), u(0))`` (shape ``(2n,)``); residual (periodicity)::

    R(x) = (q(T) - q(0), u(T) - u(0))

with ``q(T), u(T)`` from ``N`` Moreau-Jean steps of ``h = T/N`` of the whole
system (with Jenkins elements, :class:`mshbm.elements.Jenkins`, ``q`` and ``u`` also hold one
massless slider DOF per element, :func:`mshbm.integrators.moreau_jean._with_sliders`: the slider
positions are periodic too; the reported solution has the structure's DOFs only).  The Jacobian is ``Phi - I`` with the monodromy matrix ``Phi``: the exact
product of the step Jacobians for the active sets met along the trajectory
(formed from matrix powers of runs of equal active sets,
:meth:`MoreauJean.monodromy`), or forward finite differences (``jacobian="fd"``).

``integrator="event"``: the period is integrated by the exact event-driven flow
(:class:`mshbm.integrators.event.EventFlow`: closed-form flows between events, events to ~1e-15 s,
Newton impacts) and ``Phi`` is its saltation-corrected monodromy, exact.  The only errors left are
Newton's tolerance and rounding; ``steps`` is then the number of output samples (and the Moreau-Jean
steps per period of the fallback at accumulations of impacts or chattering, which the solution's
``info["event_integrator"]`` reports).  Supported: friction and contact between a DOF and the ground
(InputError otherwise).  The default is ``"moreau"`` (see :mod:`mshbm.options`).
"""
from __future__ import annotations

import numpy as np

from .. import fourier
from .base import Partition, PeriodicProblem, forward_difference_jacobian
from .common import failed_parts, guess_parts
from ..integrators import kernels
from ..integrators.moreau_jean import MoreauJean

__all__ = ["ShootingProblem"]


class ShootingProblem(PeriodicProblem):
    """Periodicity problem of the full system.

    Parameters
    ----------
    system : System
    omega : float
        Forcing angular frequency (rad/s).
    steps : int
        Time steps per period ``N``.
    theta : float
        Moreau-Jean parameter.
    jacobian : {"exact", "fd"}
    harmonics : int
        ``n_h`` of the reported Fourier coefficients ``q_hat``.
    project : bool
        Position projection of penetrating contacts.
    integrator : {"moreau", "event"}
        Moreau-Jean time stepping (default) or the exact event-driven flow (module docstring).
    accumulation : {"moreau", "close"}
        With ``integrator="event"``: Moreau-Jean segments at accumulations of impacts (default) or the
        Zeno closure of the contact (:class:`mshbm.methods.mixed.MixedProblem`).

    Residual scale
    --------------
    :meth:`residual_scale` gives Newton's per-row scale: the periodicity rows
    ``q(T) - q(0)`` are measured against the displacement size ``D`` of the current
    unknowns, ``max(D_0, ||q0||_inf, ||u0||_inf / omega)`` with the floor
    ``D_0 = F / k_0`` of :mod:`mshbm.scaling`; the rows ``u(T) - u(0)`` against
    ``D max(1, omega)`` (:func:`mshbm.scaling.velocity_scale`).  The guess never enters.
    """

    method = "shooting"

    def __init__(self, system, omega, steps, theta=0.5, jacobian="exact", harmonics=10, project=True,
                 integrator="moreau", accumulation="moreau"):
        self.system, self.omega, self.N = system, float(omega), int(steps)
        self.T = 2 * np.pi / self.omega
        self.h = self.T / self.N
        self.jacobian, self.n_h = jacobian, int(harmonics)
        self.integrator = integrator
        self.t = np.linspace(0.0, self.T, self.N + 1)
        self.ns = system.n
        if integrator == "event":
            from ..integrators.event import EventFlow

            self.flow = EventFlow(system, self.omega, accumulation=accumulation, moreau_steps=self.N)
            self.stepper = None
            self.n = system.n
            self._cache = None
            return
        self.stepper = MoreauJean(system.M, system.C, system.K, system.elements, self.h, theta, project)
        self.B = self.stepper.increments(system.forcing(self.t, self.omega))
        self.n = self.stepper.n  # integrated DOFs (the structure's, then the Jenkins sliders')

    @property
    def n_unknowns(self):
        return 2 * self.n

    @property
    def steps(self):
        return self.N

    @property
    def time_step(self):
        return None if self.integrator == "event" else self.h

    def time_stepper(self):
        return self.stepper

    def _event_run(self, x, jac=False, record=False):
        """Event-driven flow over one period from ``x = (q0, u0)`` at ``t = 0`` (samples on ``self.t``)."""
        key = (x.tobytes(), jac, record)
        c = self._cache
        if c is not None and (c[0] == key or (not jac and c[0] == (key[0], True, record))):
            return self._cache[1]  # a run with sensitivities also answers one without (the same flow)
        fl = self.flow
        out = fl.simulate(0.0, fl.state(0.0, x[:self.n], x[self.n:]), jac=jac,
                          sample_times=self.t if record else None, record=False)
        self._cache = (key, out)
        return out

    def partition(self):
        return Partition(time=np.arange(self.ns), harmonic=np.zeros(0, np.int64), condensed=np.zeros(0, np.int64))

    def residual_units(self):
        return np.repeat(np.array([0, 1], dtype=np.int8), self.n)

    def residual_scale(self, x):
        """Per-row scale of the residual at unknowns ``x``, shape ``(2n,)`` (m, then m/s)."""
        from ..scaling import displacement_floor, velocity_scale

        if "_D0" not in self.__dict__:
            self._D0 = displacement_floor(self.system, self.omega)
        n, w = self.n, self.omega
        q0, u0 = np.abs(x[:n]), np.abs(x[n:])
        D = max(self._D0, float(np.max(q0, initial=0.0)), float(np.max(u0, initial=0.0)) / w)
        V = velocity_scale(D, w)
        return np.concatenate([np.full(n, D), np.full(n, V)])

    def initial_guess(self, guess=None):
        _, q0, u0 = guess_parts(guess, self.system, self.omega, self.n_h)
        if self.stepper is None:
            return np.concatenate([q0, u0])
        return np.concatenate(self.stepper.with_slider_state(q0, u0))

    def simulate(self, x, sensitivities=False):
        """Trajectory over one period from ``x = (q0, u0)``."""
        n = self.n
        return self.stepper.run(x[:n], x[n:], self.B, sensitivities=sensitivities)

    def residual(self, x, jac=True):
        """``(R, J)`` with ``R`` shape (2n,) and ``J`` shape (2n, 2n) (``None`` if not ``jac``)."""
        n = self.n
        if self.integrator == "event":
            return self._event_residual(np.asarray(x, dtype=float), jac)
        tr = self.simulate(x)
        R = np.concatenate([tr.q[-1] - x[:n], tr.u[-1] - x[n:]])
        if not jac:
            return R, None
        if self.jacobian == "exact":
            Phi = self.stepper.monodromy(tr.status, tr.P)
        else:
            xe = np.concatenate([tr.q[-1], tr.u[-1]])

            def end_state(xp):
                tp = self.simulate(xp)
                return np.concatenate([tp.q[-1], tp.u[-1]])

            Phi = forward_difference_jacobian(end_state, x, xe)
        return R, Phi - np.eye(2 * n)

    def _event_residual(self, x, jac):
        from ..integrators.event import EventError

        n = self.n
        try:
            out = self._event_run(x, jac=jac and self.jacobian == "exact")
        except (EventError, ValueError) as exc:  # ValueError: event bracketing lost to rounding
            self.last_error = f"{type(exc).__name__}: {exc}"
            return np.full(2 * n, np.nan), (np.full((2 * n, 2 * n), np.nan) if jac else None)
        R = out.end_state[:2 * n] - x
        if not jac:
            return R, None
        if self.jacobian == "exact":
            Phi = out.monodromy[:2 * n]
        else:
            def end_state(xp):
                try:
                    return self._event_run(xp).end_state[:2 * n]
                except (EventError, ValueError):
                    return np.full(2 * n, np.nan)

            Phi = forward_difference_jacobian(end_state, x, out.end_state[:2 * n])
        return R, Phi - np.eye(2 * n)

    def event_signature(self, x):
        """``((element, kind), ...)`` of the events of the period from ``x`` (event integrator), else ``None``."""
        from ..integrators.event import EventError

        if self.integrator != "event":
            return None
        try:
            out = self._event_run(np.asarray(x, dtype=float))
        except (EventError, ValueError):
            return None
        return tuple((int(e.element), e.kind) for e in out.events)

    def monodromy(self, x):
        """Monodromy matrix ``d(q(T), u(T))/d(q0, u0)``, shape (2n, 2n)."""
        if self.integrator == "event":
            return self._event_run(np.asarray(x, dtype=float), jac=True).monodromy[:2 * self.n]
        tr = self.simulate(x)
        return self.stepper.monodromy(tr.status, tr.P)

    def _event_solution_parts(self, x):
        from ..integrators.event import MOREAU, EventError, contact_margins, extrema, run_summary

        fl, n, N = self.flow, self.n, self.N
        try:
            out = fl.simulate(0.0, fl.state(0.0, x[:n], x[n:]), jac=True, sample_times=self.t, record=True)
        except (EventError, ValueError) as exc:  # as in _event_residual: no flow from this state
            # non-finite parts, which the driver reports as a failure, with why (as MS-HBM does)
            n_h = min(self.n_h, (N - 1) // 2)
            return failed_parts(self.t, N, (2 * n_h + 1, n), np.arange(n), len(self.system.elements), n_h,
                                f"the event-driven flow failed at the solution: {type(exc).__name__}: {exc}")
        qmax, qmin, _ = extrema(fl, out.nodes)  # true extrema from the flow (zeros of u between nodes)
        Z = out.samples
        q, u = Z[:n].T.copy(), Z[n:2 * n].T.copy()
        m_all = len(self.system.elements)
        lam = np.full((N + 1, m_all), np.nan)
        modes = out.sample_modes
        for code in np.unique(modes):
            sel = modes == code
            if code == MOREAU:  # inside a Moreau-Jean segment: impulse / h of the step
                lam[sel] = fl.moreau_force(out.moreau_segments, self.t[sel])
                continue
            lam[sel] = fl.full_force(int(code), Z[:, sel]).T
        # impulse of every sampling interval: the element force times h plus the impacts in it
        P = np.nan_to_num(lam[:-1]) * self.h
        for ev in out.events:
            if ev.impulse != 0.0:
                k = min(int(ev.t / self.h), N - 1)
                P[k, ev.element] += ev.impulse
        n_h = min(self.n_h, (N - 1) // 2)
        Phi = out.monodromy[:2 * n]
        mult = np.linalg.eigvals(Phi)
        info = {"event_integrator": run_summary(out),
                "event_multipliers": mult, "event_list": out.events,
                "contact_margins": contact_margins(fl, out),
                "amplitude_exact": 0.5 * (qmax - qmin), "q_max": qmax, "q_min": qmin}
        return dict(t=self.t, q_hat=fourier.fft(q[:-1], n_h), time_dofs=np.arange(n), q_time=q, u_time=u,
                    lam=lam, impulses=P, harmonics=n_h, info=info)

    def solution_parts(self, x):
        """Time-domain data for :class:`PeriodicSolution`."""
        if self.integrator == "event":
            return self._event_solution_parts(np.asarray(x, dtype=float))
        tr = self.simulate(x)
        n_h = min(self.n_h, (self.N - 1) // 2)
        ns = self.ns
        q_hat = fourier.fft(tr.q[:-1, :ns], n_h)
        lam = np.vstack([tr.P, tr.P[:1]]) / self.h
        mult = np.linalg.eigvals(self.monodromy(x))
        impacts = bool(np.any((self.stepper.kind == kernels.KIND_CONTACT) & np.any(tr.P > 0, axis=0)))
        info = {# eigenvalues of the discrete map's monodromy: its step Jacobians hold no saltation terms,
                # so at impacts they are not the flow's multipliers.  The solution's floquet_multipliers /
                # stable (mshbm.stability) are the valid ones.
                "step_map_multipliers": mult, "step_map_impacts": impacts,
                "stick_or_closed_fraction":
                    [float(np.mean((tr.status[:, j] & 3) >= 2)) for j in range(tr.status.shape[1])]}
        return dict(t=self.t, q_hat=q_hat, time_dofs=np.arange(ns), q_time=tr.q[:, :ns], u_time=tr.u[:, :ns],
                    lam=lam, impulses=tr.P, harmonics=n_h, info=info)
