"""Case-file schema: checks every entry of a parsed case file and builds the System (:mod:`mshbm.io`); the
entries are checked by :mod:`mshbm.io.values`, the sections by :mod:`mshbm.io.sections`."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from .. import api
from .. import options as options_
from ..errors import InputError
from ..reduction import method_reduction
from ..system import System, chain
from .overrides import apply_sets as _apply_sets
from .keys import (BASE_KEYS, CHAIN_KEYS, CONTACT_KEYS, CUBIC_KEYS, FORCING_KEYS, FRICTION_KEYS,  # noqa: F401
                   MATRIX_KEYS, POLYNOMIAL_KEYS, REDUCE_KEYS, SOLVER_KEYS, TOP_KEYS)
from .matrices import matrix_storage as _matrix_storage, rayleigh as _rayleigh, \
    rayleigh_damping as _rayleigh_damping
from .sections import (CONE_SHARED, MAX_FORCING_HARMONIC, _base, _elements, _forcing, _forcing_hat,  # noqa: F401
                       _masses, _matrix, _per_spring, _reduce, _solver, _springs)
from .values import _check_keys, _number
from .yaml import MAX_FILE_BYTES, describe as _describe, load_yaml as _load_yaml, read_text as _read_text

__all__ = ["Case", "load_case", "parse_case", "MAX_FILE_BYTES", "SOLVER_KEYS", "TOP_KEYS"]



@dataclass
class Case:
    """A system, a forcing frequency and default solver options, read from a case file.

    Attributes
    ----------
    system : System
    omega : float
        Angular frequency of the forcing (rad/s).
    solver : dict
        Default options from the ``solver:`` section (may hold ``method``).
    name : str
    source : str or None
        File the case was read from.
    reduction : mshbm.reduction.ReducedModel or None
        The Craig-Bampton reduction of ``reduce:`` (``system`` stays the full model).
    auto_reduce : bool
        Without ``reduce:`` (or with ``reduce: auto``), a method that integrates stiff DOFs in time (the nodes
        of a fine mesh) solves an automatic reduction (:func:`mshbm.reduction.auto_reduction`, :meth:`solve`);
        ``reduce: none`` solves the model as written.
    """

    system: System
    omega: float
    solver: dict = field(default_factory=dict)
    name: str = "case"
    source: str | None = None
    reduction: object = None
    auto_reduce: bool = True
    #: the parsed case file and the directory of its matrix files (for :meth:`with_sets`)
    data: dict | None = field(default=None, repr=False)
    base_dir: object = field(default=None, repr=False)
    _matrices: dict = field(default_factory=dict, repr=False)

    @property
    def model(self):
        """The system the methods solve: the reduced one with ``reduce:`` (:attr:`reduction`), else
        :attr:`system`."""
        return self.system if self.reduction is None else self.reduction.system

    @property
    def method(self):
        """Default method: ``solver.method`` or ``"mshbm"``."""
        return self.solver.get("method", "mshbm")

    def solve(self, method=None, **options):
        """``mshbm.solve(system, omega, method, **{solver defaults, then options})``.

        ``method`` defaults to :attr:`method`.  When another method is asked for,
        defaults of the ``solver:`` section that it does not accept are dropped;
        ``options`` always pass through.  Errors in values coming from the
        ``solver:`` section are reported as ``solver.<key>``.
        """
        method = method or self.method
        defaults = {k: v for k, v in self.solver.items() if k != "method"}
        if method in options_.METHODS:
            allowed = options_.allowed(method)
            defaults = {k: v for k, v in defaults.items() if k in allowed}
        opts = {**defaults, **options}
        from_file = set(defaults) - set(options)
        try:
            red = self.reduction if self.reduction is not None else self.automatic_reduction(method, opts)
            if red is not None:
                sol = red.solve(self.omega, method, **opts)
                if red.auto:
                    sol.message = f"{sol.message}; {describe_auto(red)}"
                return sol
            return api.solve(self.system, self.omega, method, **opts)
        except InputError as exc:
            if exc.key in from_file:
                raise InputError(f"solver.{exc.key}", exc.problem) from None
            raise

    def automatic_reduction(self, method, options, omega=None):
        """The automatic reduction for ``method`` with ``options`` at ``omega`` (default: the case's; a sweep's
        highest) (:func:`mshbm.reduction.auto_reduction`: the method integrates stiff DOFs in time), built once
        per DOF set, ``n_h`` and ``omega``; ``None`` when it does not apply (``reduce:`` given or ``none``, a
        ``partition`` given, an unknown method, no stiff DOF)."""
        if self.reduction is not None or not self.auto_reduce or method not in options_.METHODS:
            return None
        omega = float(self.omega if omega is None else omega)
        key = ("auto_reduction", method, options.get("harmonics"), "partition" in options, omega)
        if key not in self._matrices:
            self._matrices[key] = method_reduction(self.system, omega, method, options)
        return self._matrices[key]

    def with_sets(self, sets):
        """This case with the dotted-key assignments ``sets`` applied (:func:`mshbm.io.overrides.apply_sets`:
        ``{"friction.0.normal_force": 2.5}``, ``["solver.harmonics=9"]``); matrix files are read once."""
        if self.data is None:
            raise InputError("case", "was not read from a case file (no data to override)")
        data = _apply_sets(self.data, sets)
        case = parse_case(data, name=self.name, source=self.source, base_dir=self.base_dir,
                          matrix_cache=self._matrices)
        case.name = self.name
        return case

    def __repr__(self):
        return f"Case({self.name!r}, {self.system!r}, omega={self.omega:g}, solver={self.solver!r})"


def parse_case(data, name=None, source=None, base_dir=None, matrix_cache=None):
    """Build a :class:`Case` from an already parsed mapping (the content of a case file).

    ``base_dir``: directory against which relative matrix file paths (``M: K.mtx``) are resolved;
    default: the working directory (:func:`load_case` passes the case file's directory).
    ``matrix_cache``: a dict kept between calls, so that matrix files are read once (default: none).
    """
    matrix_cache = {} if matrix_cache is None else matrix_cache
    if not isinstance(data, dict):
        got = "an empty document" if data is None else f"a {type(data).__name__}"
        raise InputError("yaml", f"the top level must be a mapping of keys ({', '.join(TOP_KEYS)}), got {got}")
    _check_keys("", data, TOP_KEYS)
    rayleigh = isinstance(data.get("damping"), dict)  # damping: {alpha, beta} -> C = alpha M + beta K
    chain_keys = [k for k in CHAIN_KEYS if k in data and not (k == "damping" and rayleigh)]
    matrix_keys = [k for k in MATRIX_KEYS if k in data]
    if chain_keys and matrix_keys:
        raise InputError(matrix_keys[0], f"cannot be combined with {'/'.join(chain_keys)}: describe the "
                                         "structure either as a chain (masses, stiffness, damping) or by "
                                         "matrices (M, C, K)")
    if "name" in data:
        if not isinstance(data["name"], str):
            raise InputError("name", f"must be a string, got {_describe(data['name'])}")
        name = data["name"]
    if "omega" not in data:
        raise InputError("omega", "missing (required): the angular frequency of the forcing in rad/s")
    omega = _number("omega", data["omega"])
    if omega <= 0:
        raise InputError("omega", f"must be > 0, got {omega:g}")
    name = name if name is not None else "case"

    if matrix_keys:
        if "M" not in data:
            raise InputError("M", "missing (required with C/K)")
        if "K" not in data:
            raise InputError("K", "missing (required with M)")
        M = _matrix("M", data["M"], base_dir=base_dir, cache=matrix_cache)
        n = M.shape[0]
        K = _matrix("K", data["K"], n, base_dir, matrix_cache)
        if rayleigh and "C" in data:
            raise InputError("damping", "cannot be combined with C: give either C or Rayleigh damping "
                                        "{alpha, beta} (C = alpha M + beta K)")
        C = _matrix("C", data["C"], n, base_dir, matrix_cache) if "C" in data else None
        mats = _matrix_storage({k: A for k, A in (("M", M), ("C", C), ("K", K)) if A is not None})
        M, K = mats["M"], mats["K"]
        if rayleigh:
            C = _rayleigh_damping(M, K, *_rayleigh(data["damping"], _number))
        elif C is None:
            C = sp.csr_matrix((n, n)) if sp.issparse(M) else np.zeros((n, n))
        else:
            C = mats["C"]
        forcing = _forcing(data.get("forcing"), n)
        contacts = _elements("contact", data.get("contact"), n)
        elements = _elements("friction", data.get("friction"), n, contacts) + contacts + _springs(data, n)
        system = System(M, C, K, _forcing_hat(forcing, n), elements, name=name)
    else:
        if "masses" not in data:
            raise InputError("masses", "missing (required): give masses and stiffness for a chain, "
                                       "or M and K matrices")
        if "stiffness" not in data:
            raise InputError("stiffness", "missing (required with masses)")
        masses = _masses(data["masses"])
        n = len(masses)
        stiffness = _per_spring("stiffness", data["stiffness"])
        alpha_beta = _rayleigh(data["damping"], _number) if rayleigh else None
        damping = 0.0 if rayleigh else _per_spring("damping", data.get("damping", 0.0))
        forcing = _forcing(data.get("forcing"), n)
        contacts = _elements("contact", data.get("contact"), n)
        elements = _elements("friction", data.get("friction"), n, contacts) + contacts + _springs(data, n)
        system = chain(masses, stiffness, damping, forcing=forcing, elements=elements, name=name)
        if rayleigh:
            system = System(system.M, _rayleigh_damping(system.M, system.K, *alpha_beta), system.K,
                            system.f_hat, system.elements, name=name)
    if "base" in data:
        system = _base(data["base"], system, n, name)
        if isinstance(data.get("solver"), dict) and "partition" in data["solver"]:
            raise InputError("solver.partition", "cannot be combined with base (the solved DOFs are the free ones, "
                                                 "renumbered): leave the partition to its default")
        n = system.n
    solver = _solver(data.get("solver"), n)
    raw = data.get("reduce", "auto")
    auto = raw == "auto"
    reduction = None if auto or raw is False or raw == "none" else _reduce(raw, system, n)
    return Case(system=system, omega=omega, solver=solver, name=name, source=source, data=data, base_dir=base_dir,
                _matrices=matrix_cache, reduction=reduction, auto_reduce=auto)


def describe_auto(red):
    """The message note of an automatic reduction ``red`` (:func:`mshbm.reduction.auto_reduction`)."""
    d = red.as_dict()
    return (f"solved on an automatic Craig-Bampton reduction onto the {len(d['boundary'])} element DOFs and "
            f"{d['modes']} fixed-interface modes (up to {d['highest_mode_rad_s']:.4g} rad/s): the time-integrated "
            f"DOFs are stiff (local frequency up to {red.auto['stiffness_ratio']:.3g} omega; reduce: none solves "
            f"the model as written), its error estimate 'reduction' in the certificate")


def _apply_overrides(data, overrides):
    if not overrides:
        return data
    if not isinstance(data, dict):
        return data  # parse_case reports it
    data = dict(data)
    for k, v in overrides.items():
        if k in TOP_KEYS:
            if v is None:
                data.pop(k, None)
            elif k == "solver" and isinstance(v, dict) and isinstance(data.get("solver"), dict):
                data["solver"] = {**data["solver"], **v}
            else:
                data[k] = v
        elif k in SOLVER_KEYS:
            solver = data.get("solver") or {}
            if isinstance(solver, dict):
                solver = dict(solver)
                if v is None:
                    solver.pop(k, None)
                else:
                    solver[k] = v
                data["solver"] = solver
        else:
            raise InputError(k, f"unknown override (allowed: the top-level keys {', '.join(TOP_KEYS)} "
                                f"or the solver options {', '.join(SOLVER_KEYS)})")
    return data


def load_case(path, sets=None, **overrides):
    """Read a YAML case file (see the module docstring for its keys).

    Parameters
    ----------
    path : str or path-like
    sets : mapping or list, optional
        Dotted-key assignments applied after ``overrides`` (:mod:`mshbm.io.overrides`:
        ``{"friction.0.normal_force": 2.5}`` or ``["solver.harmonics=9"]``, values read as YAML);
        an unknown key is an :class:`InputError` naming it.
    **overrides
        Replace top-level keys (``omega=0.5``, ``friction={...}``; ``None`` removes
        a key) or set solver options (``harmonics=3``, ``method="hbm"``) before
        validation.

    Returns
    -------
    Case

    Raises
    ------
    InputError
        Unreadable file (key: the path), invalid YAML (key ``"yaml"``) or an invalid
        entry (its dotted key, e.g. ``friction.mu``).
    """
    text = _read_text(path)
    data = _load_yaml(text)
    data = _apply_overrides(data, overrides)
    data = _apply_sets(data, sets)
    return parse_case(data, name=Path(os.fspath(path)).stem, source=str(os.fspath(path)),
                      base_dir=Path(os.fspath(path)).parent)
