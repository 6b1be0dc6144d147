"""One integrator interface for the time-domain methods (shooting, both MS-HBM variants).

A :class:`PeriodIntegrator` integrates the time-stepped DOFs over one forcing period ``T = 2 pi / omega``
from ``(q0, u0)`` at ``t = 0``, optionally driven by a harmonic coupling force affine in parameters ``p``
(MS-HBM: ``f(t) = f_ex(t) + V(t)^T (c0 + Tr p)``), and returns a :class:`PeriodRun`: the end state, the
Fourier coefficients of ``q`` over the period, the sensitivities of both with respect to ``(q0, u0, p)``,
and, for a recorded run, the samples on the output grid ``t_k = k T / N``, the element forces, the
impulses per interval and the events.  The methods build their residuals and solutions from that
record only; what differs between integrators (a fixed step or none, the cost of the sensitivities,
the reported Fourier coefficients, the solution's info entries) is a property or method of the
integrator.  Implementations: :class:`~mshbm.integrators.moreau_period.MoreauJeanIntegrator` (time
stepping) and :class:`~mshbm.integrators.event.period.EventIntegrator` (the exact event-driven flow);
:func:`mshbm.integrators.registry.make_integrator` maps the ``integrator`` option to them.

Shapes: ``n_A`` integrated states per ``q`` (the time-stepped DOFs ``n_1``, then one slider per Jenkins
element with Moreau-Jean), ``n_p`` parameters, ``n_h`` harmonics, ``N`` output intervals, ``m`` elements.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import fourier

__all__ = ["PeriodRun", "PeriodIntegrator"]


@dataclass
class PeriodRun:
    """One period of the integrated states from ``t = 0``.

    Attributes
    ----------
    end : ndarray, shape (2 n_A,)
        ``(q(T), u(T))``.
    jacobian : ndarray or None
        ``d end / d (q0, u0, p)``, shape ``(2 n_A, 2 n_A + n_p)`` (with ``sensitivities``).
    q_hat : ndarray or None
        Fourier coefficients of ``q`` of the time-stepped DOFs over the period, flattened harmonic-major,
        shape ``((2 n_h + 1) n_1,)`` (integrators built with a ``coupling`` of ``harmonics = n_h``; not
        formed by recorded Moreau-Jean runs, whose solution takes the FFT of the samples).
    q_hat_jacobian : ndarray or None
        ``d q_hat / d (q0, u0, p)``, shape ``((2 n_h + 1) n_1, 2 n_A + n_p)``.
    q, u : ndarray or None
        Samples on the output grid, shape ``(N + 1, n_A)`` (recorded runs).
    forces : ndarray or None
        Element forces ``lambda`` at the samples, shape ``(N + 1, m)`` (N; NaN where not defined).
    impulses : ndarray or None
        Impulse of every element over every output interval, shape ``(N, m)`` (Ns).
    status : ndarray or None
        Element status per step (Moreau-Jean, :mod:`mshbm.integrators.kernels`), shape ``(N, m)``.
    events : list
        Events of the period (:class:`mshbm.integrators.event.Event`; Moreau-Jean: none).
    extrema : tuple or None
        ``(q_max, q_min)`` of the time-stepped DOFs over the period, exact (the event-driven flow).
    error : str
        Why the integrator could not run from this state (``""``: it ran).
    raw : object
        The integrator's own record (:class:`~mshbm.integrators.moreau_jean.Trajectory` or
        :class:`~mshbm.integrators.event.FlowRun`).
    """

    end: np.ndarray | None = None
    jacobian: np.ndarray | None = None
    q_hat: np.ndarray | None = None
    q_hat_jacobian: np.ndarray | None = None
    q: np.ndarray | None = None
    u: np.ndarray | None = None
    forces: np.ndarray | None = None
    impulses: np.ndarray | None = None
    status: np.ndarray | None = None
    events: list = field(default_factory=list)
    extrema: tuple | None = None
    error: str = ""
    raw: object = None

    @property
    def failed(self):
        return bool(self.error)


class PeriodIntegrator:
    """One forcing period of the time-stepped DOFs (module docstring).

    Subclasses set ``name``, ``n`` (integrated states per ``q``), ``n_time`` (time-stepped DOFs of the
    structure), ``steps`` (``N``), ``t`` (output grid, shape ``(N + 1,)``), ``h = T / N`` and implement
    :meth:`run`."""

    #: the ``integrator`` option that selects this class
    name = ""
    #: the run with sensitivities costs little more than the run without (Newton then evaluates its full
    #: step with the Jacobian, :attr:`mshbm.methods.base.PeriodicProblem.cheap_jacobian`)
    cheap_sensitivities = False
    #: the Moreau-Jean stepper of the time-stepped DOFs, or None (no time stepping)
    stepper = None

    @property
    def time_step(self):
        """The fixed step ``h = T / N`` (s), or None (no fixed step)."""
        return None

    def initial_state(self, q0, u0):
        """``(q0, u0)`` of the time-stepped DOFs completed to the integrated states (shape ``(n_A,)`` each)."""
        return np.asarray(q0, dtype=float), np.asarray(u0, dtype=float)

    def run(self, q0, u0, p=None, sensitivities=False, record=False):
        """One period from ``(q0, u0)`` (shape ``(n_A,)``) under parameters ``p`` (shape ``(n_p,)``) ->
        :class:`PeriodRun` (with ``sensitivities``: ``jacobian`` and ``q_hat_jacobian``; with ``record``:
        the samples, forces, impulses, events)."""
        raise NotImplementedError

    def event_signature(self, q0, u0, p=None):
        """``((element, kind), ...)`` of the events of the period, or None (no events, or the run failed)."""
        return None

    def coefficients(self, run, n_h):
        """The Fourier coefficients of ``q`` a solution reports, shape ``(2 n_h + 1, n_time)``: the run's own
        (``run.q_hat``, of the integrator's harmonics) where it has them, else the FFT of its samples."""
        if run.q_hat is not None:
            return run.q_hat.reshape(-1, self.n_time)
        return fourier.fft(run.q[:-1, :self.n_time], n_h)

    def solution_info(self, run, whole_system=False):
        """The integrator's entries of a solution's ``info`` from a recorded run (with sensitivities when
        ``whole_system``).

        ``whole_system``: the integrated states are the whole structure's (shooting), so the eigenvalues of
        ``run.jacobian`` are the period map's multipliers and ``run.extrema`` the structure's."""
        return {}
