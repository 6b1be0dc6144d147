"""Branches in any scalar parameter: forcing amplitude, a friction element's preload, any numeric key of a case.

``continue_parameter(family, lam_start, lam_end, omega, method="mshbm", period=1, name="lam", **options)``
    traces the branch of periodic solutions of ``family(lam)`` (a :class:`mshbm.System` for each value
    ``lam`` of the parameter) at the fixed forcing frequency ``omega`` from ``lam_start`` to ``lam_end``:
    the pseudo-arclength continuation of :func:`mshbm.sweep` (:func:`mshbm.solvers.arclength.continuation`,
    every point certified) with ``lam`` in place of ``omega``.
``sweep_case(case, key, start, end, omega=None, method=None, **options)``
    the same for a dotted key of a case file (:mod:`mshbm.io.overrides`: ``friction.0.normal_force``,
    ``forcing.0.amplitude``, ``masses.1``, ``damping.alpha``, ...): ``family(lam)`` is the case re-read with
    that key set to ``lam`` (matrix files read once).  ``omega`` defaults to the case's, the method and its
    options to the case's ``solver:`` section.

The derivative ``dR/dlam`` of the method's residual has no analytic form for a general parameter: it is a
central finite difference of the rebuilt problem's residual, step ``1e-6 max(|lam|, lam_ref)`` with
``lam_ref = max(|lam_start|, |lam_end|)`` (no unit-dependent floor), one-sided where one side leaves the
parameter's admissible range (the rebuild raises :class:`mshbm.InputError`, e.g. a negative preload).  For
a parameter that enters the residual linearly (a forcing amplitude) the difference is exact up to
rounding.  A value outside the admissible range makes the residual NaN there: the corrector's step fails
and is shortened, the branch stays inside the range.

The result is a :class:`ParameterBranch`: a :class:`mshbm.Branch` with ``parameter = name``, ``values``
(the parameter at each point) and, in its JSON, ``parameter_values`` and per point ``value``; folds
carry ``value`` (located by the continuation); period doubling, Neimark-Sacker and grazing are located by
interpolating their test functions in the parameter (:func:`mshbm.bifurcations.detect`, no bisection).

A frequency sweep is :func:`mshbm.sweep` (``key="omega"`` is refused here), a load factor on the whole
forcing :func:`mshbm.continue_forcing`.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from . import bifurcations
from .branch import ROUTE, Branch, _check_number, _guarded
from .branch_tracer import _Tracer
from .errors import InputError
from .interrupt import SweepInterrupted
from .options import COMMON as _COMMON, METHODS
from .subharmonic import subharmonic_system
from .system import System

__all__ = ["ParameterBranch", "continue_parameter", "sweep_case"]


@dataclass
class ParameterBranch(Branch):
    """A :class:`mshbm.Branch` in the parameter ``parameter`` (its name) at a fixed forcing frequency."""

    @property
    def values(self):
        """The parameter at each point, shape ``(n_points,)``."""
        return np.array([p.value for p in self.points], dtype=float)

    def to_dict(self):
        out = super().to_dict()
        out["parameter_values"] = [float(v) for v in self.values]
        for d, p in zip(out["points"], self.points):
            d["value"] = float(p.value)
        return out


class _FamilyTracer(_Tracer):
    """:class:`mshbm.branch_tracer._Tracer` on ``family(lam)`` at the fixed frequency (module docstring)."""

    family = None  # set by _Family.tracer

    def problem(self, lam):
        lam = float(lam)
        if lam in self.cache:
            return self.cache[lam]
        if len(self.cache) > 8:
            self.cache.pop(next(iter(self.cache)))
        try:
            system = self.family.system(lam)
        except InputError:
            p = None  # outside the parameter's admissible range
        else:
            p = self.build_problem(subharmonic_system(system, self.k), self.omega_fixed / self.k, self.method,
                                   **self.options)[0]
        self.cache[lam] = p
        return p

    def residual(self, x, lam):
        p = self.problem(lam)
        if p is None:
            x = np.asarray(x, dtype=float)
            return np.full(x.size, np.nan), np.eye(x.size)
        return p.residual(x, jac=True)

    def _R(self, x, lam):
        p = self.problem(lam)
        return None if p is None else np.asarray(p.residual(x, jac=False)[0], dtype=float)

    def d_lam(self, x, lam):
        d = 1e-6 * max(abs(float(lam)), self.family.lam_ref)
        Rp, Rm = self._R(x, lam + d), self._R(x, lam - d)
        if Rp is not None and Rm is not None:
            return (Rp - Rm) / (2 * d)
        R0 = self._R(x, lam)
        if R0 is not None and Rp is not None:
            return (Rp - R0) / d
        if R0 is not None and Rm is not None:
            return (R0 - Rm) / d
        return np.full(np.asarray(x).size, np.nan)

    def residual_scale(self, x, lam):
        p = self.problem(lam)
        return np.ones(np.asarray(x).size) if p is None else p.residual_scale(x)

    def unknown_scale(self, x, lam):
        return np.ones(np.asarray(x).size) if self.problem(lam) is None else super().unknown_scale(x, lam)

    def segment(self, x, lam):
        return None if self.problem(lam) is None else super().segment(x, lam)

    def stall_accept(self, x, lam):
        return None if self.problem(lam) is None else super().stall_accept(x, lam)

    def point(self, x, lam, iterations, residual, step_accuracy=None):
        pt = super().point(x, lam, iterations, residual, step_accuracy)
        if not isinstance(pt, str):
            pt.value = float(lam)
        return pt


class _Family:
    """``build(lam) -> System`` checked, with the tracer class of :func:`mshbm.branch._run`."""

    def __init__(self, build, lam_ref, n, name):
        self.build, self.lam_ref, self.n, self.name = build, float(lam_ref), n, name

    def system(self, lam):
        s = self.build(float(lam))
        if not isinstance(s, System):
            raise InputError("family", f"must return an mshbm.System, got {type(s).__name__}")
        if self.n is not None and s.n != self.n:
            raise InputError(self.name, f"changes the number of DOFs ({self.n} -> {s.n}): not a parameter")
        return s

    def tracer(self, *args):
        t = _FamilyTracer(*args)
        t.family = self
        return t


def _as_parameter_branch(branch, name, family, omega):
    """``branch`` as a :class:`ParameterBranch`: folds carry ``value``; period doubling, Neimark-Sacker and
    grazing are detected again with the parameter in place of omega (:func:`mshbm.bifurcations.detect` on the
    points' records, each with its own system's gaps), located by interpolation in the parameter."""
    pb = ParameterBranch(**{f.name: getattr(branch, f.name) for f in fields(Branch)})
    pb.parameter = name
    folds = []
    for b in pb.bifurcations:
        if b.get("type") == "fold":
            b["value"] = b.pop("load")
            folds.append(b)
    records = []
    for bp in pb.points:
        r = bifurcations.point_from_solution(family.system(bp.value), bp.solution, x=bp)
        r.omega = float(bp.value)  # detect interpolates in its records' "omega": here the parameter
        records.append(r)
    found = bifurcations.detect(records, rel_tol=1e-4, types=("period-doubling", "neimark-sacker", "grazing")) \
        if records else []
    others = []
    for b in found:
        rec = b.as_dict()
        rec["value"], rec["omega"], rec["located"] = rec.pop("omega"), float(omega), b.located
        rec["bracket"] = [float(v) for v in b.bracket]
        others.append(rec)
    pb.bifurcations = sorted(folds + others, key=lambda b: b.get("index", 0))
    return pb


def continue_parameter(family, lam_start, lam_end, omega, method="mshbm", period=1, name="lam", **options):
    """Branch of periodic solutions of ``family(lam)`` at fixed ``omega`` from ``lam_start`` to ``lam_end``.

    Parameters
    ----------
    family : callable
        ``family(lam) -> System`` for each value of the parameter (same DOFs and elements); raises
        :class:`mshbm.InputError` outside the parameter's admissible range.
    lam_start, lam_end : float
        The parameter range (either order; may include 0, e.g. a preload from 0).
    omega : float
        Forcing frequency (rad/s), fixed.
    method, period, **options
        As for :func:`mshbm.sweep`.
    name : str
        The parameter's name, ``Branch.parameter`` and the label of the output.

    Returns
    -------
    ParameterBranch

    Raises
    ------
    mshbm.interrupt.SweepInterrupted
        On Ctrl-C, with the points so far as its ``branch`` (a :class:`ParameterBranch`).
    """
    if not callable(family):
        raise InputError("family", f"must be a callable lam -> System, got {type(family).__name__}")
    w = _check_number("omega", omega)
    a = _check_number("lam_start", lam_start, positive=False)
    b = _check_number("lam_end", lam_end, positive=False)
    if a == b:
        raise InputError("lam_end", "must differ from lam_start")
    if not isinstance(name, str) or not name or name == "omega":
        raise InputError("name", f"must be a parameter name other than 'omega' (mshbm.sweep), got {name!r}")
    fam = _Family(family, max(abs(a), abs(b)), None, name)
    s0 = fam.system(a)
    fam.n = s0.n
    fam.system(b)  # the end of the range must be admissible too (its error names the key)
    try:
        br = _guarded(ROUTE, s0, a, b, method, period, name, w, options, family=fam)
    except SweepInterrupted as exc:
        raise SweepInterrupted(_as_parameter_branch(exc.branch, name, fam, w), exc.cause) from None
    return _as_parameter_branch(br, name, fam, w)


def sweep_case(case, key, start, end, omega=None, method=None, **options):
    """Branch in the numeric case-file entry ``key`` (a dotted key, :mod:`mshbm.io.overrides`) of
    :class:`mshbm.io.Case` ``case`` from ``start`` to ``end`` at ``omega`` (default: the case's).

    ``method`` defaults to the case's; the case's ``solver:`` options the method accepts are defaults,
    ``options`` override them.  Errors about the key name it (``InputError(key, ...)``)."""
    if not isinstance(key, str) or not key:
        raise InputError("parameter", f"must be a dotted key of the case file, got {key!r}")
    if key == "omega":
        raise InputError("parameter", "omega is swept by mshbm.sweep (mshbm sweep --omega-start/--omega-end)")
    if key.split(".")[0] in ("solver", "name"):
        raise InputError(key, "is not a parameter of the system (solver options and the name are not swept)")
    start = _check_number("start", start, positive=False)
    end = _check_number("end", end, positive=False)
    method = method or case.method
    defaults = {k: v for k, v in case.solver.items() if k != "method" and k in (METHODS.get(method, set()) | _COMMON)}
    omega = case.omega if omega is None else omega
    n = case.model.n  # with reduce: the reduced model (rebuilt for every value of the key)
    mid = start + (end - start) / np.pi  # an irrational point of the range: integer keys fail
    try:
        s = case.with_sets({key: mid}).model
    except InputError as exc:
        if "integer" not in exc.problem and exc.key != key:
            s = None  # the ends' own checks say what is wrong (e.g. a negative preload)
        elif exc.key == key:
            raise
        else:
            raise InputError(key, f"cannot be swept continuously (at {mid:.6g}: {exc.key}: {exc.problem})") from None
    for v in (start, end):  # the ends of the range: the case's own checks
        case.with_sets({key: v})
    if s is None:
        s = case.with_sets({key: mid}).model
    if s.n != n or len(s.elements) != len(case.model.elements):
        raise InputError(key, "changes the structure of the system (DOFs or elements): not a parameter")
    return continue_parameter(lambda lam: case.with_sets({key: lam}).model, start, end, omega, method,
                              name=key, **{**defaults, **options})
