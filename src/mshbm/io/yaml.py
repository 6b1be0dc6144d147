"""Safe YAML reading of case files (the rules are in :mod:`mshbm.io`, whose docstring states them)."""
from __future__ import annotations

import os
import re
import reprlib

import yaml

from ..errors import InputError

__all__ = ["MAX_FILE_BYTES", "MAX_DEPTH", "MAX_VALUES", "read_text", "load_yaml", "describe"]

#: largest case file accepted (bytes)
MAX_FILE_BYTES = 10 * 1024 * 1024
#: deepest nesting of YAML collections accepted
MAX_DEPTH = 32
#: most values (after alias expansion) accepted
MAX_VALUES = 5_000_000


# ----------------------------------------------------------------------------- YAML reading
_BaseLoader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_MERGE_TAG = "tag:yaml.org,2002:merge"


class _Loader(_BaseLoader):
    """Safe loader that rejects duplicate keys and reads ``1e3`` / ``1.0e3`` as floats
    (PyYAML follows YAML 1.1, where an exponent needs a dot and a sign)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = set()
            for key_node, _ in node.value:
                if isinstance(key_node, yaml.ScalarNode) and key_node.tag != _MERGE_TAG:
                    ident = (key_node.tag, key_node.value)
                    if ident in seen:
                        raise yaml.constructor.ConstructorError(
                            "while constructing a mapping", node.start_mark,
                            f"found duplicate key {_REPR.repr(key_node.value)}", key_node.start_mark)
                    seen.add(ident)
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    # YAML 1.2 floats that YAML 1.1 reads as strings: 1e3, 1.0e3, +.5 (checked after the int resolver)
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)?$"),
    list("-+0123456789."))


_AMBIGUOUS_TAG = "tag:mshbm,2026:yaml11-number"
_AMBIGUOUS = re.compile(r"""^(?:[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?   # sexagesimal 1:30, 1:30.5
                          |[-+]?0[0-9_]+                                   # leading zero: YAML 1.1 octal
                          |[-+]?0o[0-7_]+)$""", re.X)                      # YAML 1.2 octal


class _YAML11Number(str):
    """A plain scalar that YAML 1.1 and 1.2 (and readers) disagree on: ``1:30`` (sexagesimal, 90 in
    YAML 1.1), ``010`` (octal 8 in YAML 1.1, 10 in YAML 1.2 and to most readers), ``0o10`` (octal 8
    in YAML 1.2, a string in 1.1).  Kept as its text, so that a numeric key rejects it by name."""

    def describe(self):
        text = str(self)
        if ":" in text:
            return (f"{text!r}, a YAML 1.1 sexagesimal (base-60) number ({text} would be read as "
                    f"{_sexagesimal(text):g}); write the decimal value")
        if "0o" in text:
            return (f"{text!r}, a YAML 1.2 octal number (a string in YAML 1.1); write the decimal value "
                    f"({int(text.replace('_', ''), 8)})")
        return (f"{text!r}, a number with a leading zero that YAML 1.1 reads as octal and YAML 1.2 "
                "as decimal; write it without the leading zero (or in decimal)")


def _sexagesimal(text):
    sign = -1.0 if text.startswith("-") else 1.0
    value = 0.0
    for part in text.lstrip("+-").replace("_", "").split(":"):
        value = 60.0 * value + float(part)
    return sign * value


_Loader.yaml_implicit_resolvers = {k: list(v) for k, v in _Loader.yaml_implicit_resolvers.items()}
for _first in "-+0123456789":
    _Loader.yaml_implicit_resolvers.setdefault(_first, []).insert(0, (_AMBIGUOUS_TAG, _AMBIGUOUS))
_Loader.add_constructor(_AMBIGUOUS_TAG, lambda loader, node: _YAML11Number(loader.construct_scalar(node)))


def _yaml_problem(exc):
    """One-line description of a YAML error, with the line number when known."""
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    problem = getattr(exc, "problem", None) or getattr(exc, "reason", None) or str(exc)
    context = getattr(exc, "context", None)
    text = f"{context}: {problem}" if context and getattr(exc, "problem", None) else str(problem)
    text = " ".join(str(text).split())
    if mark is not None:
        return f"invalid YAML at line {mark.line + 1}, column {mark.column + 1}: {text}"
    return f"invalid YAML: {text}"


def read_text(path):
    try:
        fspath = os.fspath(path)
    except TypeError:
        raise InputError("path", f"must be a file path, got {type(path).__name__}") from None
    key = str(fspath) or "path"
    try:
        with open(fspath, "rb") as fh:
            try:
                size = os.fstat(fh.fileno()).st_size
            except OSError:
                size = 0
            if size > MAX_FILE_BYTES:
                raise InputError(key, f"file is {size / 2**20:.1f} MB; case files are limited to "
                                      f"{MAX_FILE_BYTES // 2**20} MB")
            raw = fh.read(MAX_FILE_BYTES + 1)  # bounded even for endless special files
    except InputError:
        raise
    except (OSError, ValueError) as exc:  # ValueError: NUL byte in the path
        raise InputError(key.replace("\x00", "\\0"),
                         f"cannot read the file: {getattr(exc, 'strerror', None) or exc}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise InputError(key, f"file is larger than {MAX_FILE_BYTES // 2**20} MB (the limit for case files)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise InputError("yaml", f"not UTF-8 text (invalid byte at line {line})") from None


def load_yaml(text):
    """Parse ``text`` with bounded nesting (the C parser would crash on deep nesting)."""
    try:
        depth = 0
        for event in yaml.parse(text, Loader=_Loader):
            if isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
                depth += 1
                if depth > MAX_DEPTH:
                    line = event.start_mark.line + 1 if event.start_mark is not None else "?"
                    raise InputError("yaml", f"nesting deeper than {MAX_DEPTH} levels at line {line}")
            elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
                depth -= 1
        data = yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        raise InputError("yaml", _yaml_problem(exc)) from None
    except RecursionError:
        raise InputError("yaml", "nesting too deep") from None
    _check_expanded_size(data)
    return data


def _check_expanded_size(data):
    """Bound the size and depth of the loaded data counting aliases as copies (billion laughs),
    and reject recursive aliases.  Shared (aliased) nodes are measured once."""
    sizes, depths, active = {}, {}, set()
    stack = [(data, False)]
    while stack:
        obj, done = stack.pop()
        if not isinstance(obj, (dict, list)):
            continue
        oid = id(obj)
        children = [x for kv in obj.items() for x in kv] if isinstance(obj, dict) else obj
        if done:
            active.discard(oid)
            sizes[oid] = 1 + sum(sizes.get(id(c), 1) for c in children)
            depths[oid] = 1 + max((depths.get(id(c), 0) for c in children), default=0)
            if sizes[oid] > MAX_VALUES:
                raise InputError("yaml", f"more than {MAX_VALUES:,} values after expanding aliases")
            if depths[oid] > MAX_DEPTH:
                raise InputError("yaml", f"nesting deeper than {MAX_DEPTH} levels after expanding aliases")
            continue
        if oid in sizes:
            continue
        if oid in active:
            raise InputError("yaml", "an alias refers to a collection containing it (recursive data)")
        active.add(oid)
        stack.append((obj, True))
        stack.extend((c, False) for c in children if isinstance(c, (dict, list)) and id(c) not in sizes)


# ----------------------------------------------------------------------------- value checks
_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxstring, _REPR.maxother = 2, 4, 3, 40, 40


def describe(value):
    if isinstance(value, _YAML11Number):
        return value.describe()
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return f"string {_REPR.repr(value)}"
        return f"string {_REPR.repr(value)} (remove the quotes)"
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"boolean {str(value).lower()} (YAML reads true/false/yes/no/on/off as booleans)"
    return f"{type(value).__name__} {_REPR.repr(value)}"


