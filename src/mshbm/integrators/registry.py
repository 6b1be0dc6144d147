"""The integrators of the ``integrator`` option (:mod:`mshbm.options`): name -> class of
:class:`~mshbm.integrators.interface.PeriodIntegrator`."""
from __future__ import annotations

from ..elements.base import dependent_directions
from ..errors import InputError
from .event.period import EventIntegrator
from .moreau_period import MoreauJeanIntegrator

__all__ = ["INTEGRATORS", "make_integrator"]

#: the integrators by the name of the ``integrator`` option
INTEGRATORS = {cls.name: cls for cls in (MoreauJeanIntegrator, EventIntegrator)}


def make_integrator(name, system, omega, steps, **options):
    """The integrator ``name`` (:data:`INTEGRATORS`) of ``system`` at ``omega`` (rad/s) with ``steps`` output
    intervals per period; ``options`` as the class takes them (``dofs``, ``coupling``, ``harmonics``,
    ``theta``, ``project``, ``accumulation``).  Linearly dependent element directions (a friction and a contact
    element on one DOF, :func:`mshbm.elements.base.dependent_directions`) are an input error naming ``elements``:
    neither integrator has unique impulses or forces for them (Moreau-Jean's step Jacobian is singular)."""
    cls = INTEGRATORS.get(name)
    if cls is None:
        raise InputError("integrator", f"must be one of {sorted(INTEGRATORS)}, got {name!r}")
    what = dependent_directions(system.elements)
    if what is not None:
        raise InputError("elements", f"time integration needs linearly independent element directions ({what}: "
                                     "their forces along it are not unique while both act; model the stop or the "
                                     "friction on its own DOF, e.g. a stiff spring to a light body, or use 'hbm')")
    return cls(system, omega, steps, **options)
