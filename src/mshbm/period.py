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
    from .options import default_steps

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


def transient_guess(system, omega, options, periods=150):
    """Guess ``{q_hat, q0, u0}`` from a Moreau-Jean simulation from rest over ``periods`` periods
    ``2 pi / omega`` of ``system`` (the attracting orbit, if the motion settles); ``None`` if it diverges."""
    from . import fourier
    from .integrators.moreau_jean import MAX_DENSE_DOFS, MoreauJean

    if system.n > MAX_DENSE_DOFS:
        return None
    N = int(options.get("steps") or 4096)
    n_h = int(options.get("harmonics") or 5)
    T = 2 * np.pi / omega
    mj = MoreauJean(system.M, system.C, system.K, system.elements, T / N, float(options.get("theta", 0.5)),
                    bool(options.get("project", True)))
    B = mj.increments(system.forcing(np.linspace(0.0, T, N + 1), omega))
    q, u = np.zeros(system.n), np.zeros(system.n)
    tr = None
    for _ in range(int(periods)):
        tr = mj.run(q, u, B)
        q, u = tr.q[-1].copy(), tr.u[-1].copy()
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(u))):
            return None
    return {"q_hat": fourier.fft(tr.q[:-1], n_h), "q0": q, "u0": u}


def _kt_starts(sys_k, w_b, method, opts, k, periods):
    """Starts towards an attracting kT orbit: the state after a transient from rest, then (for the other
    methods) the shooting solution from the default ladder of shooting (whose ``"transient"`` start
    finds attracting orbits)."""
    from .solvers.driver import solve as _solve

    guess = transient_guess(sys_k, w_b, opts, periods=periods)
    if guess is not None:
        yield f"a Moreau-Jean transient of {periods} x {k}T from rest", guess
    if method != "shooting":
        sh_opts = {key: opts[key] for key in ("steps", "theta", "tol", "max_iter") if key in opts}
        sh = _solve(sys_k, w_b, "shooting", stability=False, **sh_opts)
        if sh.success and subharmonic_content(sh, k) >= PERIOD_K_TOL:
            yield "the kT shooting solution of the default start ladder", sh


def solve(system, omega, method="mshbm", period=1, transient_periods=150, **options):
    """``mshbm.solve`` for a ``period * T``-periodic solution (module docstring).

    With ``period=1`` this is :func:`mshbm.solve`.  Otherwise the problem is solved on the base
    frequency ``omega / period``; the result's ``omega`` is that base frequency and
    ``info["period"]``, ``info["forcing_omega"]`` record the request.

    Without a ``guess``, when the default start ladder finds no solution or a ``T``-periodic one (the
    period-1 orbit is also ``kT``-periodic: :func:`subharmonic_content` below :data:`PERIOD_K_TOL`),
    Newton is restarted from the state after a Moreau-Jean simulation from rest over
    ``transient_periods`` periods ``kT`` (:func:`transient_guess`), and that result is kept when it is
    certified and has ``kT`` content.  ``info["period_k_content"]`` reports that content.
    """
    from .solvers.driver import solve as _solve

    k = check_period(period)
    if k == 1:
        return _solve(system, omega, method, **options)
    if isinstance(omega, bool) or not isinstance(omega, (int, float, np.integer, np.floating)):
        raise InputError("omega", f"must be a number, got {omega!r}")
    if not isinstance(system, System):
        raise InputError("system", f"must be an mshbm.System, got {type(system).__name__}")
    sys_k, w_b, opts = subharmonic_system(system, k), float(omega) / k, period_options(method, k, options)
    sol = _solve(sys_k, w_b, method, **opts)
    if options.get("guess") is None and (not sol.success or subharmonic_content(sol, k) < PERIOD_K_TOL):
        # the default start found no solution or a T-periodic one: start from an attracting kT orbit instead
        for how, guess in _kt_starts(sys_k, w_b, method, opts, k, transient_periods):
            alt = _solve(sys_k, w_b, method, **{**opts, "guess": guess})
            if alt.success and subharmonic_content(alt, k) >= PERIOD_K_TOL:
                alt.message += f" (start: {how})"
                sol = alt
                break
    sol.info["period"] = k
    sol.info["period_k_content"] = subharmonic_content(sol, k)
    sol.info["forcing_omega"] = float(omega)
    return sol
