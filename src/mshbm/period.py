"""Period-k solutions: ``kT``-periodic responses to a ``T``-periodic forcing (``T = 2 pi / omega``).

A response of period ``kT`` is an ordinary periodic solution of the *same* equations written on the
base frequency ``omega / k``: the forcing ``f_ex(t) = sum_j fc_j cos(j omega t) + fs_j sin(j omega t)``
is, on the base frequency, the forcing with harmonic index ``j k``.  :func:`subharmonic_system`
builds that system (matrices and elements shared, ``f_hat`` re-indexed), and every method follows
without change: HBM and MS-HBM use harmonics of ``omega / k``, shooting integrates over ``kT``,
the certificate checks ``kT``-periodicity, and the Floquet multipliers of :mod:`mshbm.stability` are
those of the ``kT`` orbit (its monodromy over ``kT``).

Resolution: ``harmonics`` and ``steps`` are given per *forcing* period ``T`` as for ``period=1``;
the ``kT`` problem uses ``k n_h`` harmonics of ``omega / k`` and ``k N`` steps, so that the
highest frequency and the time step stay those of the period-1 problem.

The result of :func:`solve` is the :class:`mshbm.result.PeriodicSolution` of the base-frequency
problem: its ``omega`` is ``omega / k`` and its ``period`` is ``kT`` (``q_hat`` holds harmonics of
``omega / k``); ``info["period"] = k`` and ``info["forcing_omega"] = omega``.
"""
from __future__ import annotations

import numpy as np

from .errors import InputError
from .system import System

__all__ = ["subharmonic_system", "check_period", "period_options", "solve"]


def check_period(period):
    """Validate ``period`` (an integer k >= 1)."""
    if isinstance(period, bool) or not isinstance(period, (int, np.integer)):
        if isinstance(period, float) and period.is_integer():
            period = int(period)
        else:
            raise InputError("period", f"must be an integer >= 1, got {period!r}")
    if not 1 <= int(period) <= 64:
        raise InputError("period", f"must be an integer in 1..64, got {period}")
    return int(period)


def subharmonic_system(system, k):
    """``system`` with its forcing written on the base frequency ``omega / k`` (harmonic ``j`` -> ``j k``).

    Parameters
    ----------
    system : System
    k : int
        Period multiple.

    Returns
    -------
    System
        Shares ``M, C, K`` and the elements; ``f_hat`` has ``2 k n_f + 1`` rows.
    """
    k = check_period(k)
    if k == 1:
        return system
    n_f = system.n_forcing_harmonics
    f_hat = np.zeros((2 * k * n_f + 1, system.n))
    f_hat[0] = system.f_hat[0]
    for j in range(1, n_f + 1):
        f_hat[2 * j * k - 1] = system.f_hat[2 * j - 1]
        f_hat[2 * j * k] = system.f_hat[2 * j]
    new = object.__new__(System)
    new.__dict__.update(system.__dict__)
    new.f_hat = f_hat
    new.name = f"{system.name} (period {k})"
    return new


def period_options(method, k, options):
    """Options of the ``kT`` problem: ``harmonics`` and ``steps`` per forcing period times ``k``."""
    opts = dict(options)
    if k == 1:
        return opts
    from .api import default_steps

    n_h = opts.get("harmonics", 10 if method == "shooting" else 5)
    if isinstance(n_h, (int, np.integer)) and not isinstance(n_h, bool):
        opts["harmonics"] = int(n_h) * k
    steps = opts.get("steps")
    if steps is None:
        opts["steps"] = default_steps(method, int(n_h)) * k if isinstance(n_h, (int, np.integer)) else None
        if opts["steps"] is None:
            opts.pop("steps")
    elif isinstance(steps, (int, np.integer)) and not isinstance(steps, bool):
        opts["steps"] = int(steps) * k
    return opts


def solve(system, omega, method="mshbm", period=1, **options):
    """``mshbm.solve`` for a ``period * T``-periodic solution (module docstring).

    With ``period=1`` this is :func:`mshbm.solve`.  Otherwise the problem is solved on the base
    frequency ``omega / period``; the result's ``omega`` is that base frequency and
    ``info["period"]``, ``info["forcing_omega"]`` record the request.
    """
    from .api import solve as _solve

    k = check_period(period)
    if k == 1:
        return _solve(system, omega, method, **options)
    if isinstance(omega, bool) or not isinstance(omega, (int, float, np.integer, np.floating)):
        raise InputError("omega", f"must be a number, got {omega!r}")
    if not isinstance(system, System):
        raise InputError("system", f"must be an mshbm.System, got {type(system).__name__}")
    sol = _solve(subharmonic_system(system, k), float(omega) / k, method, **period_options(method, k, options))
    sol.info["period"] = k
    sol.info["forcing_omega"] = float(omega)
    return sol
