"""The result of a sweep (:mod:`mshbm.branch`): :class:`Branch`, the list of its :class:`BranchPoint` s with the
branch's bifurcations, counters and accuracy summary, and its JSON form.

Notation: ``n`` DOFs, ``x`` the unknowns of the method, ``omega`` the forcing frequency (rad/s).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from . import stability as _stability
from .outfile import jsonable

__all__ = ["Branch", "BranchPoint"]

@dataclass
class BranchPoint:
    """One point of a branch.

    ``omega`` is the forcing frequency (rad/s); ``load`` the load factor on the forcing;
    ``amplitude`` ``(max - min) / 2`` per DOF over the response period (``period * T``);
    ``x`` the method's unknowns; ``q_hat`` the displacement coefficients (harmonics of
    ``omega / period``); ``iterations`` corrector (Newton) iterations; ``residual`` the scaled
    residual; ``certificate`` ``{"passed", "failed": [names]}``; ``floquet_multipliers``, ``stable``,
    ``stability_method``; ``contact`` per element ``{kind, dof, min_gap (contacts), active}`` where
    ``active`` means the element acts on the motion (an impact or closed contact, a stick phase);
    ``solution`` the :class:`mshbm.result.PeriodicSolution` (not serialised)."""

    omega: float
    load: float
    amplitude: np.ndarray
    x: np.ndarray
    q_hat: np.ndarray
    iterations: int
    residual: float
    certificate: dict
    floquet_multipliers: np.ndarray
    stable: bool | None
    stability_method: str
    contact: list
    solution: object = None

    def as_dict(self):
        return {"omega": self.omega, "load": self.load, "amplitude": [float(a) for a in self.amplitude],
                "iterations": int(self.iterations), "residual": float(self.residual),
                "certificate": self.certificate, "floquet_multipliers": _stability.multipliers_json(self.floquet_multipliers),
                "stable": self.stable, "stability_method": self.stability_method, "contact": self.contact,
                "elements": [e.summary() for e in (getattr(self.solution, "elements", None) or [])],
                "x": [float(v) for v in self.x]}


@dataclass
class Branch:
    """A branch of periodic solutions (result of :func:`sweep` or :func:`continue_forcing`).

    Attributes
    ----------
    success : bool
        The branch reached the end of the requested range with every point certified, the combined error
        estimate within the accuracy included (:mod:`mshbm.branch_accuracy`).
    message : str
    method : str
    period : int
        ``k`` of ``kT``-periodic solutions.
    parameter : {"omega", "forcing"}
        The continuation parameter.
    points : list of BranchPoint
    bifurcations : list of dict
        ``{"type", "omega", "index", ...}``; ``type`` is ``"fold"`` (located here) or a type from
        :func:`mshbm.bifurcations.detect` (``"period-doubling"``, ``"neimark-sacker"``, ``"grazing"``).
    counters : dict
        Residual evaluations, corrector iterations and failures, rejected points, ...
    wall_time : float
        Seconds, start solve and stability analyses included.
    """

    success: bool
    message: str
    method: str
    period: int = 1
    parameter: str = "omega"
    points: list = field(default_factory=list)
    bifurcations: list = field(default_factory=list)
    counters: dict = field(default_factory=dict)
    wall_time: float = 0.0
    #: where a switched branch starts (:func:`switch_period_doubling`): ``{"type", "omega", "period"}``
    origin: dict = field(default_factory=dict)
    #: the points' accuracy summary (:func:`mshbm.branch_accuracy.certify_points`)
    accuracy: dict = field(default_factory=dict)

    @property
    def omega(self):
        return np.array([p.omega for p in self.points], dtype=float)

    @property
    def load(self):
        return np.array([p.load for p in self.points], dtype=float)

    @property
    def amplitude(self):
        """Shape ``(n_points, n)``."""
        return np.array([p.amplitude for p in self.points], dtype=float)

    @property
    def stable(self):
        return [p.stable for p in self.points]

    @property
    def iterations(self):
        return np.array([p.iterations for p in self.points], dtype=int)

    def __len__(self):
        return len(self.points)

    def to_dict(self):
        return {"success": bool(self.success), "message": self.message, "method": self.method,
                "period": int(self.period), "parameter": self.parameter,
                "omega": [float(w) for w in self.omega], "load": [float(v) for v in self.load],
                "amplitude": [[float(a) for a in p.amplitude] for p in self.points],
                "stable": self.stable,
                "bifurcations": [{k: v for k, v in b.items() if k != "x"} for b in self.bifurcations],
                "iterations": [int(i) for i in self.iterations], "counters": self.counters,
                "wall_time_s": float(self.wall_time), "origin": dict(self.origin), "accuracy": dict(self.accuracy),
                "points": [p.as_dict() for p in self.points],
                # a support motion (mshbm.support): amplitudes of the structure's DOFs, absolute and relative
                **self._base_amplitudes()}

    def _base_amplitudes(self):
        sols = [p.solution for p in self.points]
        if not sols or any(s is None or getattr(s, "base", None) is None for s in sols):
            return {}
        out = [s.base.summary(s) for s in sols]
        return {"base": {**sols[0].base.as_dict(), "amplitude_absolute": [o["amplitude_absolute"] for o in out],
                         "amplitude_relative": [o["amplitude_relative"] for o in out]}}

    def to_json(self, **kwargs):
        """JSON text (non-finite numbers as ``null``)."""
        return json.dumps(jsonable(self.to_dict()), allow_nan=False, **kwargs)
