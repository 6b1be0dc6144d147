"""One forcing period by Moreau-Jean time stepping (:class:`MoreauJeanIntegrator`, ``integrator="moreau"``).

``N`` steps of ``h = T / N`` of the theta-method (:class:`mshbm.integrators.moreau_jean.MoreauJean`).
The whole system (shooting): the sensitivities are the monodromy matrix of the step map, the product of
the step Jacobians for the active sets met along the trajectory (:meth:`MoreauJean.monodromy`).  A
subsystem driven by the harmonic coupling force (MS-HBM, ``coupling=(c0, Tr)``): forward sensitivities
with respect to ``(q0, u0, p)`` and the Fourier coefficients of ``q`` with theirs
(:class:`mshbm.integrators.subsystem.SubsystemStepper`).  The output grid is the step grid: the element
forces are the impulses of the steps divided by ``h``.
"""
from __future__ import annotations

import numpy as np

from . import kernels
from .interface import PeriodIntegrator, PeriodRun
from .moreau_jean import MoreauJean
from .subsystem import SubsystemStepper

__all__ = ["MoreauJeanIntegrator"]


class MoreauJeanIntegrator(PeriodIntegrator):
    """Moreau-Jean integration over one period (module docstring).

    Parameters
    ----------
    system : System
    omega : float
        Forcing angular frequency (rad/s).
    steps : int
        Steps per period ``N``.
    dofs : array of int, optional
        The time-stepped DOFs (default: all, the whole system).
    coupling : (ndarray, ndarray), optional
        ``(c0, Tr)``: the coupling force coefficients ``c = c0 + Tr p`` on ``dofs`` (shapes
        ``((2 n_h + 1) n_1,)`` and ``((2 n_h + 1) n_1, n_p)``), with ``harmonics = n_h``.
    harmonics : int
        ``n_h`` of the coupling force and of ``PeriodRun.q_hat``.
    theta : float
        Moreau-Jean parameter.
    project : bool
        Position projection of penetrating contacts.
    accumulation : str
        Not used (the event-driven flow's option).
    """

    name = "moreau"

    def __init__(self, system, omega, steps, dofs=None, coupling=None, harmonics=0, theta=0.5, project=True,
                 accumulation=None):
        self.omega, self.steps = float(omega), int(steps)
        T = 2 * np.pi / self.omega
        self.h = T / self.steps
        self.t = np.linspace(0.0, T, self.steps + 1)
        if coupling is None:  # the whole system
            self.part = None
            self.stepper = MoreauJean(system.M, system.C, system.K, system.elements, self.h, theta, project)
            self.B = self.stepper.increments(system.forcing(self.t, self.omega))
            self.n_time = system.n
        else:
            c0, Tr = coupling
            self.part = SubsystemStepper(system, dofs, self.omega, int(harmonics), self.steps, theta, project,
                                         c0, Tr)
            self.stepper = self.part.stepper
            self.n_time = self.part.n1
        self.n = self.stepper.n  # the time-stepped DOFs, then one slider per Jenkins element

    @property
    def time_step(self):
        return self.h

    def initial_state(self, q0, u0):
        return self.stepper.with_slider_state(q0, u0)

    def trajectory(self, q0, u0):
        """The Moreau-Jean trajectory of the whole system from ``(q0, u0)`` (:class:`~.moreau_jean.Trajectory`)."""
        return self.stepper.run(q0, u0, self.B, sensitivities=False)

    def run(self, q0, u0, p=None, sensitivities=False, record=False):
        if self.part is None:
            if sensitivities and (self.stepper.smooth or np.any(self.stepper.tpair >= 0)):
                # state-dependent step Jacobians (polynomial springs; a 3-D frictional contact, whose step
                # Jacobian in slip depends on the slip direction): the kernel's forward sensitivities, not the
                # active-set monodromy
                tr = self.stepper.run(q0, u0, self.B, sensitivities=True)
                n = self.stepper.n
                jac = np.vstack([tr.Sq[:, :2 * n], tr.Su[:, :2 * n]])
            else:
                tr = self.trajectory(q0, u0)
                jac = self.stepper.monodromy(tr.status, tr.P) if sensitivities else None
            out = PeriodRun(end=np.concatenate([tr.q[-1], tr.u[-1]]), jacobian=jac, raw=tr)
        else:
            tr = self.part.run(q0, u0, p, sensitivities)
            out = PeriodRun(end=np.concatenate([tr.q[-1], tr.u[-1]]), raw=tr)
            if not record:
                out.q_hat = self.part.project(tr.q[:-1, :self.n_time]).reshape(-1)
            if sensitivities:
                out.jacobian = np.vstack([tr.Sq, tr.Su])
                out.q_hat_jacobian = tr.q_hat_sensitivity
        if record:
            out.q, out.u, out.status = tr.q, tr.u, tr.status
            out.forces = np.vstack([tr.P, tr.P[:1]]) / self.h
            out.impulses = tr.P
        return out

    def solution_info(self, run, whole_system=False):
        tr = run.raw
        info = {}
        if whole_system:
            # eigenvalues of the discrete map's monodromy: its step Jacobians hold no saltation terms, so at
            # impacts they are not the flow's multipliers (the solution's floquet_multipliers, mshbm.stability,
            # are the valid ones)
            info["step_map_multipliers"] = np.linalg.eigvals(run.jacobian)
            info["step_map_impacts"] = bool(np.any((self.stepper.kind == kernels.KIND_CONTACT)
                                                   & np.any(tr.P > 0, axis=0)))
        info["stick_or_closed_fraction"] = [float(np.mean((tr.status[:, j] & 3) >= 2))
                                            for j in range(tr.status.shape[1])]
        return info
