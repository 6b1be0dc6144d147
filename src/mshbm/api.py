"""``mshbm.solve``: one driver, a registry of methods, validated options.

Methods (``method=``):

* ``"shooting"`` -- full shooting, Moreau-Jean (:mod:`mshbm.methods.shooting`);
* ``"hbm"`` -- HBM-AFT with regularised laws (:mod:`mshbm.methods.hbm`);
* ``"mshbm"`` -- MS-HBM, Section 3.2 (:mod:`mshbm.methods.mixed`);
* ``"mshbm-intermediate"`` -- MS-HBM, Section 3.3;
* ``"dlft"`` -- dynamic Lagrangian frequency-time method, set-valued laws (:mod:`mshbm.methods.dlft`).
"""
from __future__ import annotations

import numpy as np

from . import period as _period
from .branch import ROUTE
from .element_outputs import element_outputs
from .methods.registry import build_problem
from .options import METHODS, default_steps
from .route import continuation as _continuation

__all__ = ["solve", "build_problem", "residual_omega_derivative", "solve_with_continuation", "METHODS",
           "default_steps"]


def solve(system, omega, method="mshbm", **options):
    """Periodic solution of ``system`` under forcing of angular frequency ``omega``.

    Parameters
    ----------
    system : System
    omega : float
        Angular frequency (rad/s) of the forcing; period ``T = 2 pi / omega``.
    method : {"shooting", "hbm", "mshbm", "mshbm-intermediate", "dlft"}
    **options
        ``harmonics`` (n_h, default 5; shooting: harmonics of the reported
        ``q_hat``, default 10), ``steps`` (time steps per period; default 4096,
        HBM: AFT samples, see :func:`default_steps`), ``guess`` (``None``:
        a ladder of starts, the first accepted one wins, :mod:`mshbm.route.ladder`, ending with
        continuation in the forcing frequency from an anchor frequency where the ladder succeeds;
        ``"linear"``: linear response; ``"zero"``; a PeriodicSolution, e.g. at a
        nearby frequency; a dict with ``q_hat``, ``q0``, ``u0``; a given guess is the ladder's first
        start, the default starts follow if its solution is not certified), ``tol``
        (Newton tolerance on the scaled residual ``||R / s||_inf``, rows scaled
        by the problem's ``residual_scale``, :mod:`mshbm.scaling`; default 1e-10), ``max_iter`` (default 50), ``line_search`` (default
        True), ``theta`` (Moreau-Jean, default 0.5), ``jacobian`` (``"exact"`` or
        ``"fd"``), ``partition`` (DOFs of N; for ``mshbm-intermediate`` a pair of
        DOF lists for subsystems 1 and 2), ``condense`` (HBM: eliminate linear
        DOFs exactly, default True), ``project`` (position projection of
        contacts, default True), ``dlft_penalty`` (DLFT: the parameter ``eps`` in N/m of every
        element, default from the condensed dynamic stiffness, :mod:`mshbm.methods.dlft`), ``dlft_predictor``
        (DLFT friction: ``"velocity"``, the default, or ``"displacement"``), ``progress`` (print Newton progress to a
        terminal), ``max_time`` (s: wall-time budget of the solve; no Newton iteration or start begins after
        it, the solve then fails with "time budget spent"; default ``None``; the one budget that depends on the
        machine's load: the solve's internal budgets are counts of work, the same on every machine), ``raise_on_failure`` (raise ConvergenceError instead of
        returning ``success=False``), ``blas_threads`` (BLAS threads during
        the solve, default 1: the dense matrices are small, and one thread keeps
        results bit-identical across machines and parallel jobs from
        oversubscribing the cores; ``None`` leaves the setting alone),
        ``continuation`` (``False``: Newton from the one start (the guess), no ladder; mixed methods with
        a guess: ``True`` opts in to restarts and continuation fallbacks,
        :mod:`mshbm.route.continuation`; HBM: when Newton fails,
        follow the exact piecewise-linear solution path of penalty contacts
        (:meth:`mshbm.methods.hbm.HBMProblem.newton_fallback`), else
        retry by continuation from softened regularisations; default True),
        ``stability`` (``"auto"``, default: Floquet multipliers and verdict from the exact
        event-driven flow with saltation terms for systems with friction and contact elements on
        single DOFs (any number) and up to
        :data:`mshbm.stability.MAX_EXACT_DOFS` DOFs, else a labelled estimate or none;
        ``True``: also above that size; ``False``: skip.  Not part of ``wall_time``; see
        :mod:`mshbm.stability`), ``period`` (``k``, default 1: a ``kT``-periodic solution, solved on
        the base frequency ``omega / k`` with ``harmonics`` and ``steps`` per forcing period; the
        result's ``omega`` is ``omega / k``, see :mod:`mshbm.period`), ``accuracy`` (relative amplitude
        error in (0, 0.5]: the method refines ``harmonics`` and ``steps`` until the combined error estimate
        is below it, or fails naming the estimate; default ``None``: nothing is refined and the default
        accuracy 1e-2 gates ``success``; :mod:`mshbm.route.refine`).

    Returns
    -------
    PeriodicSolution
        ``success`` is True only when Newton converged and every gating check of the
        certificate (``solution.certificate``, :mod:`mshbm.certificate`) passed, including ``accuracy``:
        the combined error estimate within the requested or default accuracy (``info["accuracy"]``).
        With ``floquet_multipliers``, ``stable``, ``stability_method`` and ``stability_reason``,
        and per element its force, relative motion, dissipated energy and stick or contact
        fraction over the period (``elements``, :mod:`mshbm.element_outputs`).

    Raises
    ------
    InputError
        Invalid system, frequency or option (names the key).
    """
    period = options.pop("period", 1)
    if not (isinstance(period, (int, np.integer)) and not isinstance(period, bool) and int(period) == 1):
        # kT-periodic solutions (subharmonic base frequency omega / k)
        sol = _period.solve(system, omega, method, period=period, **options)
    else:
        sol = ROUTE.solve(system, omega, method, **options)
    sol.elements = element_outputs(sol, system)
    return sol


def residual_omega_derivative(system, omega, method, x, rel_step=1e-6, **options):
    """``dR/domega`` of a method's residual at fixed unknowns ``x`` (central differences).

    Together with ``problem.residual(x) -> (R, dR/dx)`` this is what frequency
    continuation needs.  The unknowns keep their meaning when omega changes
    (coefficients, or states at t = 0 with a fixed number of steps per period).

    Parameters
    ----------
    system, omega, method, **options
        As for :func:`solve`.
    x : ndarray, shape (n_x,)
        Unknowns of the method.
    rel_step : float
        Difference step relative to omega; the error is O(rel_step^2).

    Returns
    -------
    ndarray, shape (n_x,)
    """
    problem, _ = build_problem(system, omega, method, **options)
    return problem.omega_derivative(np.asarray(x, float), rel_step)


def solve_with_continuation(system, omega, method="mshbm", guess=None, **options):
    """:func:`solve` with restarts and parameter continuation when the direct solve fails
    (:func:`mshbm.route.continuation.solve_with_continuation` on the package's solve route)."""
    options.setdefault("ladder", True)  # when the fallbacks fail, the start ladder as in solve()
    return _continuation.solve_with_continuation(system, omega, method, guess, solve=ROUTE.solve, **options)
