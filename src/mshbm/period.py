"""Period-k solutions: ``kT``-periodic responses to a ``T``-periodic forcing (``T = 2 pi / omega``).

:func:`solve` is :func:`mshbm.solve` for a ``kT``-periodic solution, solved on the base frequency
``omega / k`` (:mod:`mshbm.subharmonic` describes the ``kT`` problem; the solve is
:meth:`mshbm.route.driver.Route.solve_period` on the package's solve route).

The result of :func:`solve` is the :class:`mshbm.result.PeriodicSolution` of the base-frequency
problem: its ``omega`` is ``omega / k`` and its ``period`` is ``kT`` (``q_hat`` holds harmonics of
``omega / k``); ``info["period"] = k`` and ``info["forcing_omega"] = omega``.
"""
from __future__ import annotations

from .branch import ROUTE
from .subharmonic import (PERIOD_K_TOL, check_period, period_options, subharmonic_content, subharmonic_system,
                          transient_guess)

__all__ = ["subharmonic_system", "check_period", "period_options", "subharmonic_content", "transient_guess",
           "PERIOD_K_TOL", "solve"]


def solve(system, omega, method="mshbm", period=1, transient_periods=150, **options):
    """``mshbm.solve`` for a ``period * T``-periodic solution (:meth:`mshbm.route.driver.Route.solve_period`)."""
    return ROUTE.solve_period(system, omega, method, period=period, transient_periods=transient_periods, **options)
