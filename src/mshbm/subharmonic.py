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

The solve of a ``kT``-periodic solution is :meth:`mshbm.route.driver.Route.solve_period` (public as
:func:`mshbm.period.solve`); this module holds the system, options and measures it uses.
"""
from __future__ import annotations

import numpy as np

from . import fourier
from .errors import InputError
from .integrators.moreau_jean import MAX_DENSE_DOFS, MoreauJean
from .options import default_harmonics, default_steps
from .system import System

__all__ = ["subharmonic_system", "check_period", "period_options", "subharmonic_content", "transient_guess",
           "PERIOD_K_TOL"]


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
    if system.omega_dependent:
        raise InputError("period", "a forcing that depends on omega (support motion) is supported for T-periodic "
                                   "solutions only (period 1)")
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
    n_h = opts.get("harmonics", default_harmonics(method))
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


#: a kT-periodic solution whose harmonics that are not multiples of k are below this (relative) is T-periodic
PERIOD_K_TOL = 1e-6


def subharmonic_content(sol, k):
    """Size of the harmonics of ``omega / k`` that are not multiples of ``k`` in ``sol.q_hat``, relative
    to the largest harmonic (0 for a T-periodic solution)."""
    qh = np.asarray(sol.q_hat, dtype=float)
    n_h = (qh.shape[0] - 1) // 2
    j = np.arange(1, n_h + 1)
    amp = np.hypot(qh[2 * j - 1], qh[2 * j])  # (n_h, n)
    top = float(np.max(amp, initial=0.0))
    if top == 0.0:
        return 0.0
    return float(np.max(amp[j % k != 0], initial=0.0)) / top


def transient_guess(system, omega, options, periods=150, drift_tol=None):
    """Guess ``{q_hat, q0, u0}`` from a Moreau-Jean simulation from rest over ``periods`` periods
    ``2 pi / omega`` of ``system`` (the attracting orbit, if the motion settles); ``None`` if it diverges.
    With ``drift_tol``, the simulation ends early once the structure's state changes by less than ``drift_tol`` of
    its size over a period."""
    if system.n > MAX_DENSE_DOFS:
        return None
    N = int(options.get("steps") or 4096)
    n_h = int(options.get("harmonics") or 5)
    n = system.n
    T = 2 * np.pi / omega
    mj = MoreauJean(system.M, system.C, system.K, system.elements, T / N, float(options.get("theta", 0.5)),
                    bool(options.get("project", True)))
    B = mj.increments(system.forcing(np.linspace(0.0, T, N + 1), omega))
    q, u = np.zeros(system.n), np.zeros(system.n)
    tr = None
    for _ in range(int(periods)):
        tr = mj.run(q, u, B)
        q1, u1 = tr.q[-1].copy(), tr.u[-1].copy()
        if not (np.all(np.isfinite(q1)) and np.all(np.isfinite(u1))):
            return None
        settled = False
        if drift_tol is not None:
            size = max(float(np.max(np.abs(tr.q[:, :n]))), float(np.max(np.abs(tr.u[:, :n]))) / omega, 1e-300)
            drift = max(float(np.max(np.abs(q1[:n] - q[:n]))), float(np.max(np.abs(u1[:n] - u[:n]))) / omega)
            settled = drift <= drift_tol * size
        q, u = q1, u1
        if settled:
            break
    return {"q_hat": fourier.fft(tr.q[:-1], n_h), "q0": q, "u0": u}
