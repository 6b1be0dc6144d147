"""The former one-element event-driven engine, now the general one (:mod:`mshbm.integrators.event`).

:class:`ExactFlow` is :class:`mshbm.integrators.event.EventFlow` with ``accumulation="close"`` by
default: an accumulation of impacts (``e_N < 1``) is closed exactly (the contact closes with ``e = 0``
once the next bounce would rise less than ``1e-10`` of the displacement scale), as this engine always
did; the reference solutions of :func:`mshbm.exact_periodic` rely on it.  There is one event-driven
engine; this module keeps the names its users import.
"""
from __future__ import annotations

from .event import (CLOSED, FREE, MODE_NAMES, SLIP_M, SLIP_P, STALL_EVENTS, STICK, Event, EventError, EventFlow,
                    EventTrajectory, extrema)

__all__ = ["ExactFlow", "ExactTrajectory", "Event", "EventError", "STALL_EVENTS", "MODE_NAMES",
           "FREE", "SLIP_P", "SLIP_M", "STICK", "CLOSED"]

_extrema = extrema


class ExactTrajectory(EventTrajectory):
    """:class:`~mshbm.integrators.event.EventTrajectory`; with one element ``evaluate`` gives ``lam`` of shape
    (k,) (its former shape), with several (k, m)."""

    def evaluate(self, t):
        q, u, lam = super().evaluate(t)
        if lam.shape[1] == 1:
            lam = lam[:, 0]
        return q, u, lam


class ExactFlow(EventFlow):
    """:class:`~mshbm.integrators.event.EventFlow` with the exact Zeno closure (``accumulation="close"``).

    The former one-element attributes remain for systems with one acting element: ``element``, ``kind``,
    ``unilateral``, ``w`` (shape (n,)), ``mw = M^-1 w`` and ``sw = w^T M^-1 w``.  (``dof`` is now the array
    of the element DOFs, shape (m,).)
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
