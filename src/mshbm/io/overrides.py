"""Dotted-key overrides of a case file: ``mshbm solve CASE --set friction.0.normal_force=2.5``.

A dotted key names one entry of the parsed case file (:mod:`mshbm.io`): its components are mapping keys
and 0-based list indices, e.g. ``omega``, ``solver.harmonics``, ``friction.0.normal_force``,
``forcing.1.amplitude``, ``masses.2``, ``damping.alpha``, ``K.0.1``.  A section given as a single mapping
(``friction: {dof: 0, ...}``) is its own entry ``0``: ``friction.0.mu`` and ``friction.mu`` both name it.

Rules:

* every mapping key must be one the schema allows at that place (``TOP_KEYS``, ``SOLVER_KEYS``, the
  element keys, ``alpha``/``beta`` of Rayleigh damping); an entry may be added where the schema allows
  it (``solver.harmonics`` without a ``solver:`` section, ``friction.0.smoothing`` left at its default);
* a list index must exist (``friction.3`` of a case with two friction entries is an error);
* a value is read as YAML (the case file's own reader: ``2.5``, ``1e3``, ``hbm``, ``true``,
  ``[1, 2]``), then the whole case is checked as usual.

Every violation is an :class:`mshbm.InputError` naming the dotted key (CLI exit code 2).  The case
file on disk is never changed: overrides act on a copy of the parsed data (copied along the key's
path only).
"""
from __future__ import annotations

import difflib

from ..errors import InputError
from .keys import (BASE_KEYS, CONTACT_KEYS, CUBIC_KEYS, FORCING_KEYS, FRICTION_KEYS, POLYNOMIAL_KEYS, REDUCE_KEYS,
                   SOLVER_KEYS, TOP_KEYS)
from .matrices import RAYLEIGH_KEYS
from .yaml import describe as _describe, load_yaml as _load_yaml

__all__ = ["parse_assignment", "apply_sets", "SECTION_KEYS", "add_set_option", "case_sets"]


def _schema():
    return {(): tuple(TOP_KEYS), ("solver",): tuple(SOLVER_KEYS), ("friction",): tuple(FRICTION_KEYS),
            ("contact",): tuple(CONTACT_KEYS), ("forcing",): tuple(FORCING_KEYS), ("damping",): tuple(RAYLEIGH_KEYS),
            ("reduce",): tuple(REDUCE_KEYS), ("polynomial",): tuple(POLYNOMIAL_KEYS), ("cubic",): tuple(CUBIC_KEYS),
            ("base",): tuple(BASE_KEYS), ("base", "motion"): tuple(FORCING_KEYS)}


#: the sections whose entries are mappings, given as one mapping or a list of them
SECTION_KEYS = ("friction", "contact", "forcing", "polynomial", "cubic")
#: the mappings an override may create when the case file lacks them
_CREATABLE = ("solver", "damping", "reduce")


def parse_assignment(text, option="--set"):
    """``"key=value"`` -> ``(key, value)``, the value read as YAML (``option`` names the CLI option in errors)."""
    if not isinstance(text, str) or "=" not in text:
        raise InputError(option, f"expects KEY=VALUE (e.g. friction.0.normal_force=2.5), got {text!r}")
    key, _, raw = text.partition("=")
    key = key.strip()
    if not key:
        raise InputError(option, f"expects KEY=VALUE with a non-empty key, got {text!r}")
    try:
        value = _load_yaml(raw)
    except InputError as exc:
        raise InputError(key, f"value {raw!r} is not valid YAML ({exc.problem})") from None
    return key, value


def _index(key, part, length, what):
    if not part.isdigit():
        raise InputError(key, f"{what} is a list: {part!r} must be an index 0..{length - 1}")
    j = int(part)
    if j >= length:
        raise InputError(key, f"no entry {j} ({what} has {length} entr{'y' if length == 1 else 'ies'}, "
                              "indexed from 0)")
    return j


def _assign(node, parts, i, value, key, schema):
    """A copy of ``node`` with ``parts[i:]`` set to ``value`` (``parts[:i]`` lead to ``node``)."""
    where = ".".join(parts[:i + 1])  # the component in trouble (errors name the whole key, ``key``)
    here = ".".join(parts[:i]) or "the case"
    part = parts[i]
    last = i == len(parts) - 1
    norm = tuple(p for p in parts[:i] if not p.isdigit())
    if isinstance(node, list):
        j = _index(key, part, len(node), here)
        out = list(node)
        out[j] = value if last else _assign(node[j], parts, i + 1, value, key, schema)
        return out
    if isinstance(node, dict):
        if len(norm) == 1 and norm[0] in SECTION_KEYS and len(parts[:i]) == 1 and part.isdigit():
            _index(key, part, 1, here)  # a section given as one mapping is its own entry 0
            if last:
                raise InputError(key, f"names a whole {norm[0]} entry; give one of its keys "
                                        f"({', '.join(schema[norm])})")
            return _assign(node, parts, i + 1, value, key, schema)
        if norm == ("polynomial", "coefficients"):  # a mapping power -> k_p: its keys are the powers
            if not (part.isdigit() and last):
                raise InputError(key, f"a polynomial coefficient is set by its power, e.g. "
                                      f"{'.'.join(parts[:i])}.3=0.5 (k_3), got {where!r}")
            out = {k: v for k, v in node.items() if str(k) != part}
            out[int(part)] = value
            return out
        allowed = schema.get(norm)
        if allowed is None or part not in allowed:
            close = difflib.get_close_matches(part, list(allowed or ()), n=1)
            hint = (f" (allowed: {', '.join(allowed)})" if allowed else "") + \
                (f"; did you mean {close[0]!r}?" if close else "")
            raise InputError(key, f"unknown key {where!r}{hint}")
        out = dict(node)
        if last:
            out[part] = value
        elif part in node:
            out[part] = _assign(node[part], parts, i + 1, value, key, schema)
        elif not norm and part in _CREATABLE:
            out[part] = _assign({}, parts, i + 1, value, key, schema)
        elif not norm and part in SECTION_KEYS:
            raise InputError(key, f"the case has no {part} entries")
        else:
            raise InputError(key, f"{where!r} is not in the case file (only its entries and their keys can be set)")
        return out
    raise InputError(key, f"{here} is {_describe(node)}: it has no entries")


def apply_sets(data, sets):
    """``data`` (a parsed case file) with the dotted-key assignments ``sets`` applied.

    Parameters
    ----------
    data : dict
        The parsed case file (not modified).
    sets : mapping or iterable
        ``{dotted key: value}``, or ``(key, value)`` pairs, or ``"key=value"`` strings (values read as
        YAML, :func:`parse_assignment`).

    Returns
    -------
    dict
    """
    if not sets:
        return data
    if not isinstance(data, dict):
        return data  # parse_case reports it
    items = sets.items() if isinstance(sets, dict) else sets
    schema = _schema()
    for item in items:
        key, value = parse_assignment(item) if isinstance(item, str) else item
        if not isinstance(key, str) or not key or any(not p.strip() for p in key.split(".")):
            raise InputError(str(key), "is not a dotted key (components separated by '.', e.g. solver.harmonics)")
        parts = [p.strip() for p in key.split(".")]
        data = _assign(data, parts, 0, value, key, schema)
    return data


def add_set_option(parser):
    """``--set KEY=VALUE`` (repeatable) of every subcommand that reads a case file."""
    parser.add_argument("--set", action="append", default=None, metavar="KEY=VALUE", dest="set",
                        help="set a dotted key of the case file, e.g. friction.0.normal_force=2.5 or "
                        "solver.harmonics=9 (value read as YAML; repeatable)")


def case_sets(args):
    """The ``--set`` assignments of ``args`` (and ``--omega`` of ``solve``) for :func:`mshbm.io.load_case`."""
    sets = list(args.set or [])
    if getattr(args, "command", None) == "solve" and args.omega is not None:
        sets.append(("omega", args.omega))
    return sets
