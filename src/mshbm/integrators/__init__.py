"""Time integrators of the nonsmooth flow.

:mod:`.interface`: one forcing period of the time-stepped DOFs -> :class:`~.interface.PeriodRun`, the one
interface of shooting and MS-HBM; :mod:`.registry` maps the ``integrator`` option to its implementations,
:mod:`.moreau_period` (Moreau-Jean time stepping: the compiled kernels :mod:`.kernels`, their typed layer
:mod:`.moreau_jean`, MS-HBM's coupled subsystem :mod:`.subsystem`) and :mod:`.event.period` (the exact
event-driven flow, :mod:`.event`).
"""
