"""The integrators of the ``integrator`` option (:mod:`mshbm.options`): name -> class of
:class:`~mshbm.integrators.interface.PeriodIntegrator`."""
from __future__ import annotations

from ..errors import InputError
from .event.period import EventIntegrator
from .moreau_period import MoreauJeanIntegrator

__all__ = ["INTEGRATORS", "make_integrator"]

#: the integrators by the name of the ``integrator`` option
INTEGRATORS = {cls.name: cls for cls in (MoreauJeanIntegrator, EventIntegrator)}


def make_integrator(name, system, omega, steps, **options):
    """The integrator ``name`` (:data:`INTEGRATORS`) of ``system`` at ``omega`` (rad/s) with ``steps`` output
    intervals per period; ``options`` as the class takes them (``dofs``, ``coupling``, ``harmonics``,
    ``theta``, ``project``, ``accumulation``)."""
    cls = INTEGRATORS.get(name)
    if cls is None:
        raise InputError("integrator", f"must be one of {sorted(INTEGRATORS)}, got {name!r}")
    return cls(system, omega, steps, **options)
