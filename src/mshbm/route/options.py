"""Option subsets along the solve route, and the capabilities of a method by name.

The options of :func:`mshbm.solve` go to three places: the problem (built by
:func:`mshbm.methods.registry.build_problem`), Newton (``tol``, ``max_iter``, ``line_search``) and the route
(``guess``, ``continuation``, ``raise_on_failure``, ``blas_threads``, ``max_time``, ``stability``,
``progress``).  Nested solves pass them on with a few keys removed or kept: :func:`without` and
:func:`only` are the one way this is written.
"""
from __future__ import annotations

from ..methods.base import PeriodicProblem
from ..methods.registry import PROBLEMS

__all__ = ["without", "only", "capabilities", "NEWTON_KEYS", "DRIVER_KEYS"]

#: Newton's options
NEWTON_KEYS = ("tol", "max_iter", "line_search")
#: options of the driver itself, not of the method (dropped for the related problems a ladder builds)
DRIVER_KEYS = ("guess", "progress", "raise_on_failure", "continuation", "blas_threads")


def without(options, *keys):
    """``options`` (a mapping) without ``keys``, as a new dict."""
    return {k: v for k, v in options.items() if k not in keys}


def only(options, *keys):
    """The entries of ``options`` among ``keys`` (in the order of ``keys``), as a new dict."""
    return {k: options[k] for k in keys if k in options}


def capabilities(method):
    """The problem class of ``method`` (:data:`mshbm.methods.registry.PROBLEMS`), whose class attributes
    declare what the route needs to know before a problem is built (:class:`PeriodicProblem`'s
    capabilities); the base class for an unknown name (the option check names it later)."""
    return PROBLEMS.get(method, PeriodicProblem)
