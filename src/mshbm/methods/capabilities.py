"""What each method accepts and needs before its problem exists: the per-method capability table.

Option checks (:mod:`mshbm.options`) and input checks (:mod:`mshbm.validate`) run before a problem object
is built, so they cannot ask the problem (:mod:`mshbm.methods.base`).  They ask this table instead,
through :func:`capabilities`, and never compare method names.  The table imports nothing of the methods'
modules, so that the checks it serves can be imported by them.

Registering a method: one :class:`MethodCapabilities` in :data:`CAPABILITIES` and its problem class in
:data:`mshbm.methods.registry.PROBLEMS`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["MethodCapabilities", "CAPABILITIES", "capabilities"]

_TIME_DOFS = ("all", "none", "partition")


@dataclass(frozen=True)
class MethodCapabilities:
    """The declarations of one method that the option and input checks read.

    Attributes
    ----------
    name : str
        The registry name (``method`` of :func:`mshbm.solve`).
    options : frozenset of str
        Options the method accepts besides the common ones (:data:`mshbm.options.COMMON`).
    default_harmonics : int
        ``n_h`` when ``harmonics`` is not given.
    harmonic_unknowns : bool
        Fourier coefficients of ``n_h`` harmonics are unknowns of the method (not only a post-processing of
        time series): ``steps`` must then sample them without aliasing, ``steps >= 2 n_h + 2``.
    aft_samples : bool
        Every DOF is a Fourier series and ``steps`` counts the AFT samples of the element laws, not time
        steps: the default ``steps`` follows ``n_h`` (:func:`mshbm.options.default_steps`) and the float-range
        check has no step-size terms.
    partition_pair : bool
        ``partition`` is a pair ``[dofs_1, dofs_2]`` of subsystems (else a flat list of DOFs).
    time_dofs : {"all", "none", "partition"}
        The DOFs integrated in time: every DOF, none, or the (first) subsystem of the partition (default:
        the element DOFs).
    harmonic_part : str
        How messages name the part of the method that represents DOFs by truncated Fourier series.
    """

    name: str
    options: frozenset
    default_harmonics: int
    harmonic_unknowns: bool
    aft_samples: bool
    partition_pair: bool
    time_dofs: str
    harmonic_part: str

    def __post_init__(self):
        if self.time_dofs not in _TIME_DOFS:
            raise ValueError(f"time_dofs must be one of {_TIME_DOFS}, got {self.time_dofs!r}")

    def timed_dofs(self, system, partition=None):
        """The DOFs integrated in time, int array, for a validated ``partition`` (``None``: the default)."""
        if self.time_dofs == "all":
            return np.arange(system.n)
        if self.time_dofs == "none":
            return np.zeros(0, dtype=np.int64)
        if partition is None:
            return system.nonlinear_dofs
        return partition[0] if self.partition_pair else partition


_TIME_STEPPING = frozenset({"harmonics", "steps", "theta", "jacobian", "partition", "project", "integrator",
                            "accumulation"})

#: the capability table, in the order in which messages list the methods
CAPABILITIES = {c.name: c for c in (
    MethodCapabilities("shooting", frozenset({"steps", "theta", "jacobian", "harmonics", "project", "integrator",
                                              "accumulation"}),
                       default_harmonics=10, harmonic_unknowns=False, aft_samples=False, partition_pair=False,
                       time_dofs="all", harmonic_part="the harmonic part of shooting"),
    MethodCapabilities("hbm", frozenset({"harmonics", "steps", "condense", "partition", "penalty_quadrature"}),
                       default_harmonics=5, harmonic_unknowns=True, aft_samples=True, partition_pair=False,
                       time_dofs="none", harmonic_part="HBM"),
    MethodCapabilities("mshbm", _TIME_STEPPING | {"impact_mass"},
                       default_harmonics=5, harmonic_unknowns=True, aft_samples=False, partition_pair=False,
                       time_dofs="partition", harmonic_part="the harmonic part of mshbm"),
    MethodCapabilities("mshbm-intermediate", _TIME_STEPPING,
                       default_harmonics=5, harmonic_unknowns=True, aft_samples=False, partition_pair=True,
                       time_dofs="partition", harmonic_part="the harmonic part of mshbm-intermediate"),
    MethodCapabilities("dlft", frozenset({"harmonics", "steps", "condense", "partition", "dlft_penalty",
                                          "dlft_predictor"}),
                       default_harmonics=5, harmonic_unknowns=True, aft_samples=True, partition_pair=False,
                       time_dofs="none", harmonic_part="DLFT"),
)}


def capabilities(method):
    """The :class:`MethodCapabilities` of ``method``; ``InputError`` (key ``method``) for an unknown name."""
    try:
        return CAPABILITIES[method]
    except KeyError:
        raise InputError("method", f"unknown method {method!r} (choose from {', '.join(CAPABILITIES)})") from None
