"""Full shooting: the periodicity of the whole system integrated over one period.

Unknowns ``x = (q(0), u(0))`` (shape ``(2n,)``); residual (periodicity)::

    R(x) = (q(T) - q(0), u(T) - u(0))

with ``q(T), u(T)`` from one period of the integrator (:mod:`mshbm.integrators.interface`):
``integrator="moreau"`` (default, :mod:`mshbm.options`), ``N`` Moreau-Jean steps of ``h = T/N`` of the
whole system (with Jenkins elements, :class:`mshbm.elements.Jenkins`, ``q`` and ``u`` also hold one
massless slider DOF per element, :func:`mshbm.integrators.moreau_jean._with_sliders`: the slider
positions are periodic too; the reported solution has the structure's DOFs only), whose Jacobian is
``Phi - I`` with the step map's monodromy ``Phi`` (products of the step Jacobians for the active sets
met along the trajectory, :meth:`MoreauJean.monodromy`); or ``integrator="event"``, the exact
event-driven flow (:class:`mshbm.integrators.event.EventFlow`: closed-form flows between events, events
to ~1e-15 s, Newton impacts) with its saltation-corrected monodromy, exact: the only errors left are
Newton's tolerance and rounding, and ``steps`` is the number of output samples (and the Moreau-Jean
steps per period of the fallback at accumulations of impacts or chattering, which the solution's
``info["event_integrator"]`` reports; supported: friction and contact between a DOF and the ground).
``jacobian="fd"``: forward differences of the end state instead of ``Phi``.
"""
from __future__ import annotations

import numpy as np

from .base import Partition, PeriodicProblem, forward_difference_jacobian, section_limits
from .common import failed_parts, guess_parts
from ..integrators.registry import make_integrator
from ..scaling import displacement_floor, velocity_scale
from .stuck_gauge import centred_member

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
    full_shooting, supports_event_integrator = True, True  # solve-route capabilities

    def __init__(self, system, omega, steps, theta=0.5, jacobian="exact", harmonics=10, project=True,
                 integrator="moreau", accumulation="moreau"):
        system = system.at(omega)  # the forcing at omega (a constant forcing: the same system)
        self.system, self.omega, self.N = system, float(omega), int(steps)
        self.jacobian, self.n_h = jacobian, int(harmonics)
        self.integrator = make_integrator(integrator, system, self.omega, self.N, theta=theta, project=project,
                                          accumulation=accumulation)
        self.t = self.integrator.t
        self.ns = system.n
        self.n = self.integrator.n  # integrated states (the structure's, then the Jenkins sliders')

    @property
    def n_unknowns(self):
        return 2 * self.n

    @property
    def steps(self):
        return self.N

    @property
    def time_step(self):
        return self.integrator.time_step

    @property
    def stepper(self):
        """The Moreau-Jean stepper of the whole system (None with the event-driven flow)."""
        return self.integrator.stepper

    @property
    def B(self):
        """The Moreau-Jean forcing increments of one period (:meth:`MoreauJean.increments`)."""
        return self.integrator.B

    def simulate(self, x):
        """The Moreau-Jean trajectory over one period from ``x = (q0, u0)`` (:class:`Trajectory`)."""
        return self.integrator.trajectory(x[:self.n], x[self.n:])

    def _run(self, x, sensitivities=False, record=False):
        x = np.asarray(x, dtype=float)
        return self.integrator.run(x[:self.n], x[self.n:], sensitivities=sensitivities, record=record)

    def partition(self):
        return Partition(time=np.arange(self.ns), harmonic=np.zeros(0, np.int64), condensed=np.zeros(0, np.int64))

    def residual_units(self):
        return np.repeat(np.array([0, 1], dtype=np.int8), self.n)

    def residual_scale(self, x):
        """Per-row scale of the residual at unknowns ``x``, shape ``(2n,)`` (m, then m/s)."""
        if "_D0" not in self.__dict__:
            self._D0 = displacement_floor(self.system, self.omega)
        n, w = self.n, self.omega
        q0, u0 = np.abs(x[:n]), np.abs(x[n:])
        D = max(self._D0, float(np.max(q0, initial=0.0)), float(np.max(u0, initial=0.0)) / w)
        V = velocity_scale(D, w)
        return np.concatenate([np.full(n, D), np.full(n, V)])

    def initial_guess(self, guess=None):
        _, q0, u0 = guess_parts(guess, self.system, self.omega, self.n_h)
        return np.concatenate(self.integrator.initial_state(q0, u0))

    def residual(self, x, jac=True):
        """``(R, J)`` with ``R`` shape (2n,) and ``J`` shape (2n, 2n) (``None`` if not ``jac``)."""
        n = self.n
        x = np.asarray(x, dtype=float)
        run = self._run(x, sensitivities=jac and self.jacobian == "exact")
        if run.failed:
            return np.full(2 * n, np.nan), (np.full((2 * n, 2 * n), np.nan) if jac else None)
        R = run.end - x
        if not jac:
            return R, None
        if self.jacobian == "exact":
            Phi = run.jacobian
        else:
            def end_state(xp):
                r = self._run(xp)
                return np.full(2 * n, np.nan) if r.failed else r.end

            Phi = forward_difference_jacobian(end_state, x, run.end)
        return R, Phi - np.eye(2 * n)

    def event_signature(self, x):
        """``((element, kind), ...)`` of the events of the period from ``x`` (event-driven flow), else ``None``."""
        x = np.asarray(x, dtype=float)
        return self.integrator.event_signature(x[:self.n], x[self.n:])

    def section_restarts(self, x):
        """``x`` with the state extrapolated to ``T`` from before and to ``0`` from after
        (:meth:`PeriodicProblem.section_restarts`)."""
        run = self._run(x, record=True)
        if run.failed:
            return []
        out = [np.concatenate(section_limits(run, k)) for k in (-1, 0)]
        return [z for z in out if z.shape == np.shape(x)]

    def family_gauge(self, x, F):
        """The member of the family of solutions through ``x`` (free directions ``F``) whose friction elements that
        stick the whole period have centred forces (:func:`mshbm.methods.stuck_gauge.centred_member`), or None."""
        def forces(xx):
            run = self._run(xx, record=True)
            if run.failed or run.forces is None or run.status is None:
                return None
            return run.forces[:-1], run.status

        return centred_member(forces, x, F)

    def monodromy(self, x):
        """Monodromy matrix ``d(q(T), u(T))/d(q0, u0)``, shape (2n, 2n)."""
        return self._run(x, sensitivities=True).jacobian

    def solution_parts(self, x):
        """Time-domain data for :class:`PeriodicSolution`."""
        N, ns = self.N, self.ns
        n_h = min(self.n_h, (N - 1) // 2)
        run = self._run(x, sensitivities=True, record=True)
        if run.failed:  # non-finite parts, which the driver reports as a failure, with why (as MS-HBM does)
            return failed_parts(self.t, N, (2 * n_h + 1, ns), np.arange(ns), len(self.system.elements), n_h,
                                f"the event-driven flow failed at the solution: {run.error}")
        info = self.integrator.solution_info(run, whole_system=True)
        return dict(t=self.t, q_hat=self.integrator.coefficients(run, n_h), time_dofs=np.arange(ns),
                    q_time=run.q[:, :ns], u_time=run.u[:, :ns], lam=run.forces, impulses=run.impulses,
                    harmonics=n_h, info=info)
