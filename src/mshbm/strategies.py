"""Named solve strategies: where a solve at the forcing frequency ``omega`` starts from.

:func:`mshbm.solve` turns a starting guess into a periodic solution (with its own ladder of starts
when no guess is given, :mod:`mshbm.route.ladder`).  The strategies here choose that guess one
level up, from *other solves*, as the paper does for its sweeps and as the workflow does for every
figure (``workflow/scripts/solves/solve.py``) and the work-precision benchmark
(``workflow/scripts/bench/bench_workprecision.py``):

``"linear"`` (:func:`linear_start`)
    no guess: :func:`mshbm.solve` starts from the linear response at ``omega`` (the elements removed);
``"nearby"`` (:func:`nearby_start`)
    the same method's converged solution at the nearby frequency ``factor * omega`` (itself solved
    from the linear start there) -- the paper's "solution at a nearby frequency" of Figs. 4 and 8;
``"restart"`` (:func:`restart_start`)
    another method's converged solution at ``omega`` (same ``n_h``), e.g. HBM restarted from MS-HBM
    or full shooting when it fails from its own starts.

A strategy returns a :class:`Start`: the guess, whether it exists (a nearby or source solution that
did not converge is no start) and what was solved to get it.  :func:`solve_from` then solves at
``omega`` from it; it may be called repeatedly (timing) with the same start.

Every function takes ``solve=`` (default :func:`mshbm.solve`, same signature): a caller that times or
counts solves passes its own wrapper, so the strategies never change *which* solves are made.
"""
from __future__ import annotations

from dataclasses import dataclass

from .api import solve as _solve

__all__ = ["Start", "linear_start", "nearby_start", "restart_start", "make_start", "solve_from", "NEARBY_FACTOR",
           "STRATEGIES"]

#: default nearby frequency ``factor * omega`` (the workflow's ``starts.nearby_factor``)
NEARBY_FACTOR = 0.98
#: the named strategies
STRATEGIES = ("linear", "nearby", "restart")


@dataclass
class Start:
    """A starting point of a solve at ``omega``.

    Attributes
    ----------
    name : str
        ``"linear"``, ``"nearby"`` or the label of a restart (``"mshbm solution at omega"``).
    guess : PeriodicSolution, dict or None
        Passed as ``guess=`` to :func:`mshbm.solve` (``None``: the linear start).
    ok : bool
        The start exists (``False``: the nearby or source solution did not converge).
    message : str
        Why the start does not exist (empty when ``ok``).
    source : PeriodicSolution or None
        The solve that produced the guess (the nearby-frequency solution), for the records.
    omega : float or None
        Frequency of ``source``.
    factor : float or None
        ``omega_source / omega`` of a nearby start.
    """

    name: str
    guess: object = None
    ok: bool = True
    message: str = ""
    source: object = None
    omega: float | None = None
    factor: float | None = None


def _solver(solve):
    return _solve if solve is None else solve


def linear_start():
    """The linear start: no guess (:func:`mshbm.solve` begins at the linear response at ``omega``)."""
    return Start("linear")


def nearby_start(system, omega, method, factor=NEARBY_FACTOR, *, solve=None, **options):
    """The method's own solution at ``factor * omega``, solved from the linear start there.

    ``options`` are those of the solve at ``omega`` (harmonics, steps, tolerances, ...; not ``guess``).
    The start does not exist (``ok=False``) when that solve did not converge.
    """
    factor = float(factor)
    near = _solver(solve)(system, factor * omega, method, guess=None, **options)
    if not near.success:
        return Start("nearby", None, False, f"no converged solution at {factor} omega to start from: {near.message}",
                     near, factor * omega, factor)
    return Start("nearby", near, True, "", near, factor * omega, factor)


def restart_start(source, label="restart"):
    """Restart from another method's solution at ``omega``: ``source`` is a converged
    :class:`mshbm.PeriodicSolution` or a guess mapping (``q_hat``, ``q0``, ``u0``); ``None`` or a
    solution with ``success=False`` is no start."""
    if source is None or getattr(source, "success", True) is False:
        return Start(label, None, False, f"{label}: the source solution did not converge")
    return Start(label, source)


def make_start(name, system, omega, method, *, factor=NEARBY_FACTOR, solve=None, **options):
    """The start named ``name``: ``"linear"`` (:func:`linear_start`) or ``"nearby"`` (:func:`nearby_start`
    at ``factor * omega``); a restart needs its source solution (:func:`restart_start`)."""
    if name == "linear":
        return linear_start()
    if name == "nearby":
        return nearby_start(system, omega, method, factor, solve=solve, **options)
    raise ValueError(f"unknown start {name!r} (named starts: linear, nearby; restarts: restart_start)")


def solve_from(start, system, omega, method, *, solve=None, **options):
    """Solve at ``omega`` from ``start`` (a :class:`Start` with ``ok``)."""
    if not start.ok:
        raise ValueError(f"start {start.name!r} does not exist: {start.message}")
    return _solver(solve)(system, omega, method, guess=start.guess, **options)
