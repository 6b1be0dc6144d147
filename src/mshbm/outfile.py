"""Writing the CLI's ``--out`` file safely.

Rules (``mshbm solve CASE --out PATH``):

* The file is written at ``PATH``.  A **symlink** is written through: its target receives the
  output and the link stays a link (a dangling link creates its target, when the target's directory
  exists).
* An existing **regular file** keeps its permission bits (and, where allowed, its owner and group);
  a new file gets ``0666 & ~umask`` like any file the user creates.  A file the user may not write
  is refused, even when its directory is writable.
* The write is atomic (a temporary file in the same directory, renamed over the target) where that
  is safe: for new files and regular files with one link.  A file with **several hard links** is
  rewritten in place, so that every name sees the new content.
* A **FIFO** or a **character device** (``/dev/stdout``, ``/dev/null``, a terminal) is written
  through, never replaced by a regular file; a FIFO without a reader is refused instead of blocking.
  Block devices, sockets and directories are refused.
* The **case file itself** is never overwritten, however it is named (same path, relative path,
  symlink or hard link: compared by device and inode).

Every refusal is an :class:`mshbm.InputError` with key ``--out`` (exit code 2), raised before the
solve when it can be foreseen; the same rules hold for ``mshbm sweep --plot FILE.png`` (key ``--plot``,
``key=`` of :func:`check_out` and :func:`write_text`; ``text`` may then be ``bytes``).

:func:`jsonable` is the one conversion of results to JSON values, used by the CLI and by every
script of the workflow (solves, benchmarks, stress suite).
"""
from __future__ import annotations

import errno
import math
import os
import stat
import tempfile

import numpy as np

from .errors import InputError

__all__ = ["check_out", "write_text", "jsonable"]

KEY = "--out"


def jsonable(obj, allow_nan=False):
    """``obj`` as plain JSON values (for :func:`json.dumps`).

    Mappings become dicts with string keys, lists/tuples/arrays become lists, numpy scalars become
    Python ``bool``/``int``/``float``, a complex number ``z`` becomes ``[z.real, z.imag]``.  A
    non-finite float becomes ``None`` (JSON has no NaN/inf), unless ``allow_nan`` (then it stays, and
    ``json`` writes the non-standard ``NaN``/``Infinity``).  Anything else becomes ``float(obj)`` if it
    converts, else ``str(obj)``.
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v, allow_nan) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v, allow_nan) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist(), allow_nan)
    if obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (complex, np.complexfloating)):
        return [jsonable(float(obj.real), allow_nan), jsonable(float(obj.imag), allow_nan)]
    try:
        x = float(obj)
    except (TypeError, ValueError):
        return str(obj)
    return x if (allow_nan or math.isfinite(x)) else None


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _plan(path, case=None, key=KEY):
    """``(target, kind, st)``: the path to write, ``"new" | "file" | "stream"`` and its stat (or None);
    refusals are :class:`InputError` s naming ``key`` (the option that gave the path)."""
    path = os.fspath(path)
    if not path:
        raise InputError(key, "is empty")
    if "\x00" in path:
        raise InputError(key, "contains a NUL byte")
    try:
        st = os.stat(path)  # follows symlinks in the kernel (also /proc/self/fd/N of pipes)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise InputError(key, f"cannot use {path!r}: {exc.strerror or exc}") from None
    stream = st is not None and (stat.S_ISFIFO(st.st_mode) or stat.S_ISCHR(st.st_mode))
    # a regular file (or a new one) behind symlinks is replaced where it lives, keeping the links
    target = os.path.realpath(path) if not stream and os.path.islink(path) else path
    if case is not None and st is not None:
        try:
            cst = os.stat(case)
        except OSError:
            cst = None
        if cst is not None and (cst.st_dev, cst.st_ino) == (st.st_dev, st.st_ino):
            raise InputError(key, f"{path!r} is the case file itself; refusing to overwrite it")
    if st is None:
        if path.endswith(os.sep):
            raise InputError(key, f"{path!r} names a directory")
        parent = os.path.dirname(os.path.abspath(target))
        if not os.path.isdir(parent):
            raise InputError(key, f"directory {parent!r} does not exist")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise InputError(key, f"directory {parent!r} is not writable")
        return target, "new", None
    mode = st.st_mode
    if stat.S_ISDIR(mode):
        raise InputError(key, f"{path!r} is a directory")
    if stat.S_ISFIFO(mode) or stat.S_ISCHR(mode):
        if not os.access(target, os.W_OK):
            raise InputError(key, f"{path!r} is not writable")
        return target, "stream", st
    if not stat.S_ISREG(mode):
        what = "a block device" if stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode) else "not a file"
        raise InputError(key, f"{path!r} is {what}; refusing to write there")
    if not os.access(target, os.W_OK):
        raise InputError(key, f"{path!r} is not writable (permissions {stat.filemode(mode)})")
    parent = os.path.dirname(os.path.abspath(target))
    if st.st_nlink == 1 and not os.access(parent, os.W_OK | os.X_OK):
        return target, "inplace", st  # cannot create a temporary file next to it: rewrite in place
    return target, ("inplace" if st.st_nlink > 1 else "file"), st


def check_out(path, case=None, key=KEY):
    """Fail early (before solving) when ``path`` cannot or must not be written (errors name ``key``)."""
    _plan(path, case, key)


def _write_stream(target, text, st, key=KEY):
    flags = os.O_WRONLY | (os.O_NONBLOCK if stat.S_ISFIFO(st.st_mode) else 0)
    try:
        fd = os.open(target, flags)
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise InputError(key, f"{target!r} is a FIFO without a reader") from None
        raise
    try:
        if flags & os.O_NONBLOCK:
            os.set_blocking(fd, True)
        with _fdopen(fd, text, closefd=False) as fh:
            fh.write(text)
    finally:
        os.close(fd)


def _write_atomic(target, text, st):
    parent = os.path.dirname(os.path.abspath(target))
    fd, tmp = tempfile.mkstemp(prefix=".mshbm-", suffix=".json", dir=parent)
    try:
        with _fdopen(fd, text) as fh:
            fh.write(text)
            fh.flush()
            if st is None:
                os.fchmod(fh.fileno(), 0o666 & ~_umask())
            else:
                os.fchmod(fh.fileno(), stat.S_IMODE(st.st_mode))
                try:
                    os.fchown(fh.fileno(), st.st_uid, st.st_gid)
                except OSError:
                    pass  # not allowed to give the file away: it stays ours
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _fdopen(fd, data, **kw):
    """``fd`` as a file for ``data``: binary for ``bytes``, else UTF-8 text."""
    if isinstance(data, (bytes, bytearray)):
        return os.fdopen(fd, "wb", **kw)
    return os.fdopen(fd, "w", encoding="utf-8", **kw)


def write_text(path, text, case=None, key=KEY):
    """Write ``text`` (``str``, or ``bytes`` for a figure) to ``path`` by the rules of the module docstring;
    errors name ``key``."""
    target, kind, st = _plan(path, case, key)
    try:
        if kind == "stream":
            _write_stream(target, text, st, key)
        elif kind == "inplace":
            binary = isinstance(text, (bytes, bytearray))
            with open(target, "r+b" if binary else "r+", **({} if binary else {"encoding": "utf-8"})) as fh:
                fh.truncate(0)
                fh.write(text)
        else:
            _write_atomic(target, text, st)
    except OSError as exc:
        raise InputError(key, f"cannot write {os.fspath(path)!r}: {exc.strerror or exc}") from None
