"""Checks of single entries of a case file (:mod:`mshbm.io`): numbers, integers, DOF indices, keys and lists
of mappings; each raises :class:`mshbm.InputError` naming the dotted key."""
from __future__ import annotations

import difflib
import math

import numpy as np

from ..errors import InputError
from .yaml import describe as _describe


def _number(key, value):
    """Finite float; bools, strings and other types are rejected."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(key, f"must be a number, got {_describe(value)}")
    try:
        out = float(value)
    except OverflowError:
        raise InputError(key, "is too large") from None
    if not math.isfinite(out):
        raise InputError(key, f"must be finite, got {out}")
    return out


def _integer(key, value, minimum=None, maximum=None):
    if isinstance(value, float) and math.isfinite(value) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(key, f"must be an integer, got {_describe(value)}")
    value = int(value)
    if minimum is not None and value < minimum:
        raise InputError(key, f"must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise InputError(key, f"must be <= {maximum}, got {value}")
    return value


def _dof(key, value, n):
    d = _integer(key, value)
    if not 0 <= d < n:
        raise InputError(key, f"DOF {d} out of range 0..{n - 1}")
    return d


def _unknown(key, allowed):
    close = difflib.get_close_matches(str(key), list(allowed), n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return f"unknown key (allowed: {', '.join(allowed)}){hint}"


def _keyname(k):
    if not isinstance(k, str):
        k = "null" if k is None else repr(k)
    elif not k.strip() or not k.isprintable():
        k = repr(k)
    return k if len(k) <= 60 else k[:57] + "..."


def _check_keys(prefix, mapping, allowed):
    for k in mapping:
        if k not in allowed:
            raise InputError(f"{prefix}.{_keyname(k)}" if prefix else _keyname(k), _unknown(k, allowed))


def _items(key, value):
    """A mapping or a list of mappings -> list of (item key, mapping)."""
    if isinstance(value, dict):
        return [(key, value)]
    if isinstance(value, list):
        out = []
        for i, item in enumerate(value):
            if not isinstance(item, dict):
                raise InputError(f"{key}[{i}]", f"must be a mapping, got {_describe(item)}")
            out.append((f"{key}[{i}]", item))
        return out
    raise InputError(key, f"must be a mapping or a list of mappings, got {_describe(value)}")
