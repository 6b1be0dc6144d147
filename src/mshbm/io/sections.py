"""The sections of a case file (:mod:`mshbm.io`), one checker each: ``masses``/``stiffness``/``damping`` (a chain),
``M``/``C``/``K`` (matrices), ``forcing``, ``base``, ``friction``/``contact``, ``polynomial``/``cubic``, ``solver``
and ``reduce``; :func:`mshbm.io.case.parse_case` puts them together into a System."""
from __future__ import annotations

import numpy as np

from .. import options as options_
from ..elements import Jenkins, Polynomial
from ..errors import InputError
from ..reduction import craig_bampton
from ..support import base_excitation
from ..system import Contact, Friction
from .keys import (BASE_KEYS, CONTACT_KEYS, CUBIC_KEYS, FORCING_KEYS, FRICTION_KEYS, POLYNOMIAL_KEYS, REDUCE_KEYS,
                   SOLVER_KEYS)
from .matrices import read_matrix_file as _read_matrix_file
from .values import _check_keys, _dof, _integer, _items, _number
from .yaml import _REPR, describe as _describe

#: highest forcing harmonic accepted (the solvers support at most 2000 harmonics)
MAX_FORCING_HARMONIC = 2000


def _masses(value):
    if not isinstance(value, list):
        raise InputError("masses", f"must be a list with one mass per DOF, got {_describe(value)}")
    if not value:
        raise InputError("masses", "needs at least one mass")
    return [_number(f"masses[{i}]", v) for i, v in enumerate(value)]


def _per_spring(key, value):
    if isinstance(value, list):
        return [_number(f"{key}[{i}]", v) for i, v in enumerate(value)]
    if isinstance(value, dict) or isinstance(value, str) or value is None:
        raise InputError(key, f"must be a number or a list with one entry per spring, got {_describe(value)}")
    value = _number(key, value)
    if value < 0:
        raise InputError(key, f"must be >= 0, got {value:g}")
    return value


def _matrix(key, value, n=None, base_dir=None, cache=None):
    """A matrix given as a list of rows (dense array) or as a file path (CSR, :mod:`mshbm.io.matrices`);
    ``cache``: a dict of the files already read (by key, path and directory), or None."""
    if isinstance(value, str):
        tag = (key, value, str(base_dir))
        A = cache.get(tag) if cache is not None else None
        if A is None:
            A = _read_matrix_file(key, value, base_dir)
            if cache is not None:
                cache[tag] = A
        if n is not None and A.shape[0] != n:
            raise InputError(key, f"must be {n}x{n} like M, got {A.shape[0]}x{A.shape[1]} from {value!r}")
        return A
    if isinstance(value, (int, float)) and not isinstance(value, bool) and n in (None, 1):
        value = [[value]]
    if not isinstance(value, list) or not value:
        raise InputError(key, f"must be a square matrix given as a list of rows, got {_describe(value)}")
    rows = len(value)
    if n is not None and rows != n:
        raise InputError(key, f"must be {n}x{n} like M, got {rows} row{'s' if rows != 1 else ''}")
    out = np.empty((rows, rows))
    for i, row in enumerate(value):
        if not isinstance(row, list):
            raise InputError(f"{key}[{i}]", f"must be a list (a matrix row), got {_describe(row)}")
        if len(row) != rows:
            raise InputError(key, f"must be square: row {i} has {len(row)} entries, expected {rows}")
        for j, v in enumerate(row):
            out[i, j] = _number(f"{key}[{i}][{j}]", v)
    return out


def _forcing(value, n, section="forcing"):
    """Validated forcing items (dicts with all keys filled); ``section``: the key named in errors."""
    if value is None:
        return []
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list):
        raise InputError(section, f"must be a list of mappings {{dof, amplitude, ...}}, got {_describe(value)}")
    out = []
    for key, item in _items(section, value):
        _check_keys(key, item, FORCING_KEYS)
        if "dof" not in item:
            raise InputError(f"{key}.dof", "missing (required)")
        out.append({
            "dof": _dof(f"{key}.dof", item["dof"], n),
            "amplitude": _number(f"{key}.amplitude", item.get("amplitude", 0.0)),
            "sin": _number(f"{key}.sin", item.get("sin", 0.0)),
            "harmonic": _integer(f"{key}.harmonic", item.get("harmonic", 1), 1, MAX_FORCING_HARMONIC),
            "constant": _number(f"{key}.constant", item.get("constant", 0.0)),
        })
    return out


def _forcing_hat(items, n):
    n_f = max([1] + [it["harmonic"] for it in items])
    f_hat = np.zeros((2 * n_f + 1, n))
    for it in items:
        h, d = it["harmonic"], it["dof"]
        f_hat[2 * h - 1, d] += it["amplitude"]
        f_hat[2 * h, d] += it["sin"]
        f_hat[0, d] += it["constant"]
    return f_hat


def _base(value, system, n, name):
    """``base: {dofs, motion, frame}``: the system reduced to the free DOFs (:func:`mshbm.support.base_excitation`;
    ``motion`` items as forcing items, in m, on the base DOFs)."""
    if not isinstance(value, dict):
        raise InputError("base", f"must be a mapping {{dofs, motion, frame}}, got {_describe(value)}")
    _check_keys("base", value, BASE_KEYS)
    for key in ("dofs", "motion"):
        if key not in value:
            raise InputError(f"base.{key}", "missing (required)")
    dofs = value["dofs"] if isinstance(value["dofs"], list) else [value["dofs"]]
    dofs = [_dof(f"base.dofs[{i}]", d, n) for i, d in enumerate(dofs)]
    motion = _forcing(value["motion"], n, "base.motion")
    X = _forcing_hat(motion, n)
    for i, it in enumerate(motion):
        if it["dof"] not in dofs:
            raise InputError(f"base.motion[{i}].dof", f"DOF {it['dof']} is not a base DOF (base.dofs: {dofs})")
    frame = value.get("frame", "auto")
    return base_excitation(system.M, system.C, system.K, dofs, X[:, sorted(set(dofs))], f_hat=system.f_hat,
                           elements=system.elements, frame=frame, name=name)


#: keys a friction entry with ``cone_partner`` may leave out: it takes its partner's (one contact point)
CONE_SHARED = ("mu", "normal_force", "normal_contact", "smoothing", "tangential_stiffness")


def _cone_inherit(items):
    """Friction entries with the keys of :data:`CONE_SHARED` they leave out taken from their cone partner's
    entry (copies; the partner's own values, not inherited ones: one of the two states them)."""
    out = []
    for i, (key, item) in enumerate(items):
        if item.get("cone_partner") is None:
            out.append((key, item))
            continue
        p = _integer(f"{key}.cone_partner", item["cone_partner"], minimum=0)
        if p >= len(items) or p == i:
            raise InputError(f"{key}.cone_partner", f"must be the index of another friction entry "
                             f"(0..{len(items) - 1}, not its own {i}), got {p}")
        other = items[p][1]
        if isinstance(other, dict):
            item = dict(item, **{k: other[k] for k in CONE_SHARED if k not in item and k in other})
        out.append((key, item))
    return out


def _elements(kind, value, n, contacts=()):
    """Elements of one section; ``contacts``: the parsed ``contact`` entries (for ``normal_contact``, which
    becomes an index into the system's element list: the friction entries come first)."""
    if value is None:
        return []
    cls, spec = (Friction, FRICTION_KEYS) if kind == "friction" else (Contact, CONTACT_KEYS)
    out, seen = [], {}
    items = _items(kind, value)
    if kind == "friction":
        items = _cone_inherit(items)
    for key, item in items:
        _check_keys(key, item, tuple(spec))
        vals = {}
        for name, default in spec.items():
            if name not in item:
                if default is ... and not (name == "normal_force" and item.get("normal_contact") is not None):
                    raise InputError(f"{key}.{name}", "missing (required)")
                vals[name] = 0.0 if default is ... else default  # normal_force: no preload
            elif name in ("dof", "relative_to"):
                vals[name] = _dof(f"{key}.{name}", item[name], n)
            elif name == "normal_contact":
                i = _integer(f"{key}.{name}", item[name], minimum=0)
                if i >= len(contacts):
                    raise InputError(f"{key}.{name}", f"no contact entry {i} (the case has {len(contacts)} "
                                     "contact entries, indexed from 0)")
                if contacts[i].dof == vals["dof"]:
                    raise InputError(f"{key}.{name}", f"contact {i} acts on the friction's own DOF {vals['dof']}: "
                                     "the normal direction must be another DOF")
                vals[name] = len(items) + i
            elif name == "cone_partner":  # checked by _cone_inherit: the friction entries come first
                vals[name] = _integer(f"{key}.{name}", item[name], minimum=0)
            else:
                vals[name] = _number(f"{key}.{name}", item[name])
        if vals.get("relative_to") is not None and vals["relative_to"] == vals["dof"]:
            raise InputError(f"{key}.relative_to", f"must differ from dof ({vals['dof']}): the element acts on "
                                                   "q_dof - q_relative_to")
        where = vals["dof"] if vals.get("relative_to") is None else (vals["dof"], vals["relative_to"])
        if where in seen:
            what = f"DOF {where}" if vals.get("relative_to") is None else f"DOFs {where[0]}-{where[1]}"
            raise InputError(f"{key}.dof", f"{what} already has a {kind} element ({seen[where]})")
        seen[where] = key
        make = cls
        if kind == "friction":
            if vals.get("tangential_stiffness") is None:
                vals.pop("tangential_stiffness", None)
            else:
                make = Jenkins
        try:
            out.append(make(**vals))
        except InputError as exc:  # Friction/Contact name keys "friction.mu": add the list index
            if key != kind and exc.key.startswith(kind + "."):
                raise InputError(key + exc.key[len(kind):], exc.problem) from None
            raise
    return out


def _springs(data, n):
    """The polynomial springs of the sections ``polynomial`` (``coefficients: {p: k_p}``) and ``cubic``
    (``stiffness: k_3``), in that order (after the friction and contact elements)."""
    out, seen = [], {}
    for kind, spec in (("polynomial", POLYNOMIAL_KEYS), ("cubic", CUBIC_KEYS)):
        value = data.get(kind)
        if value is None:
            continue
        for key, item in _items(kind, value):
            _check_keys(key, item, tuple(spec))
            for name, default in spec.items():
                if default is ... and name not in item:
                    raise InputError(f"{key}.{name}", "missing (required)")
            dof = _dof(f"{key}.dof", item["dof"], n)
            rel = None if item.get("relative_to") is None else _dof(f"{key}.relative_to", item["relative_to"], n)
            if rel is not None and rel == dof:
                raise InputError(f"{key}.relative_to", f"must differ from dof ({dof}): the spring acts on "
                                                       "q_dof - q_relative_to")
            where = dof if rel is None else (dof, rel)
            if where in seen:
                what = f"DOF {where}" if rel is None else f"DOFs {where[0]}-{where[1]}"
                raise InputError(f"{key}.dof", f"{what} already has a polynomial spring ({seen[where]}): give all "
                                 "its powers in one 'polynomial' entry")
            seen[where] = key
            try:
                if kind == "cubic":
                    out.append(Polynomial(dof, {3: _number(f"{key}.stiffness", item["stiffness"])}, rel))
                else:
                    out.append(Polynomial(dof, item["coefficients"], rel))
            except InputError as exc:  # Polynomial names keys "polynomial.coefficients": add the list index
                if exc.key.startswith("polynomial."):
                    raise InputError(key + exc.key[len("polynomial"):], exc.problem) from None
                raise
    return out


def _solver(value, n):
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise InputError("solver", f"must be a mapping of solver options, got {_describe(value)}")
    _check_keys("solver", value, SOLVER_KEYS)
    out = {}
    for k, v in value.items():
        key = f"solver.{k}"
        if k == "method":
            if not isinstance(v, str) or v not in options_.METHODS:
                raise InputError(key, f"unknown method {_REPR.repr(v)} (choose from {', '.join(options_.METHODS)})")
        elif k == "harmonics":
            v = _integer(key, v, 1, 2000)
        elif k == "steps":
            v = _integer(key, v, 8, 1 << 24)
        elif k == "max_iter":
            v = _integer(key, v, 0)
        elif k == "theta":
            v = _number(key, v)
            if not 0.5 <= v <= 1.0:
                raise InputError(key, f"must be a number in [0.5, 1], got {v:g}")
        elif k == "tol":
            v = _number(key, v)
            if not 0.0 < v < 1.0:
                raise InputError(key, f"must be a number in (0, 1), got {v:g}")
        elif k == "jacobian":
            if v not in ("exact", "fd"):
                raise InputError(key, f"must be 'exact' or 'fd', got {_describe(v)}")
        elif k == "integrator":
            if v not in ("moreau", "event"):
                raise InputError(key, f"must be 'moreau' or 'event', got {_describe(v)}")
        elif k in ("condense", "project", "line_search", "continuation"):
            if not isinstance(v, bool):
                raise InputError(key, f"must be true or false, got {_describe(v)}")
        elif k == "partition":
            v = _partition(key, v, n)
        elif k == "dlft_penalty":
            v = _number(key, v)
            if not v > 0.0:
                raise InputError(key, f"must be a number > 0 (N/m), got {v:g}")
        elif k == "dlft_predictor":
            if v not in ("velocity", "displacement"):
                raise InputError(key, f"must be 'velocity' or 'displacement', got {_describe(v)}")
        elif k == "accuracy":  # relative amplitude error (mshbm.route.refine), or false: no estimates
            try:
                v = False if v is False else options_.check_accuracy(_number(key, v))
            except InputError as exc:
                raise InputError(key, exc.problem) from None
        elif k == "stability":  # true, false or "auto" (mshbm.stability)
            if not (isinstance(v, bool) or v == "auto"):
                raise InputError(key, f"must be true, false or 'auto', got {_describe(v)}")
        out[k] = v
    method = out.get("method")
    if method is not None:
        allowed = options_.allowed(method)
        for k in out:
            if k != "method" and k not in allowed:
                raise InputError(f"solver.{k}", f"is not an option of method {method!r} "
                                                f"(its options: {', '.join(sorted(allowed & set(SOLVER_KEYS)))})")
    return out


def _partition(key, value, n):
    if not isinstance(value, list):
        raise InputError(key, f"must be a list of DOF indices, got {_describe(value)}")
    if value and all(isinstance(v, list) for v in value):  # (N1, N2) of mshbm-intermediate
        return [[_dof(f"{key}[{i}][{j}]", d, n) for j, d in enumerate(part)] for i, part in enumerate(value)]
    return [_dof(f"{key}[{i}]", d, n) for i, d in enumerate(value)]



def _reduce(value, system, n):
    if not isinstance(value, dict):
        raise InputError("reduce", f"must be a mapping {{method: craig_bampton, modes: n, keep: [dofs]}}, auto "
                                   "(the default: a reduction where a time-integrating method meets stiff DOFs) or "
                                   f"none, got {_describe(value)}")
    _check_keys("reduce", value, REDUCE_KEYS)
    if value.get("method", "craig_bampton") != "craig_bampton":
        raise InputError("reduce.method", f"must be 'craig_bampton', got {_describe(value.get('method'))}")
    if "modes" not in value:
        raise InputError("reduce.modes", "missing (required): the number of fixed-interface modes to keep")
    modes = _integer("reduce.modes", value["modes"], 0)
    keep = value.get("keep", [])
    if not isinstance(keep, list):
        raise InputError("reduce.keep", f"must be a list of DOF indices, got {_describe(keep)}")
    keep = [_dof(f"reduce.keep[{i}]", d, n) for i, d in enumerate(keep)]
    return craig_bampton(system, modes, keep)
