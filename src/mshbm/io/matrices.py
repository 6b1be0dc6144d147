"""Matrices of a case file read from files, and Rayleigh damping (:mod:`mshbm.io`).

In a case file, ``M``, ``C`` and ``K`` may each be a path to a matrix file instead of a list of
rows::

    M: beam_M.mtx                    # Matrix Market (scipy.io.mmread), real or integer
    K: beam_K.npz                    # scipy.sparse.save_npz (csr, csc, coo, bsr or dia)
    damping: {alpha: 0.5, beta: 1e-5}   # Rayleigh: C = alpha M + beta K

Paths
    A relative path is resolved against the directory of the case file (against the working
    directory when the case comes from :func:`mshbm.io.parse_case` without ``base_dir``); an
    absolute path is used as it is.  Paths may leave the case directory (``../fe/K.mtx``): a case
    file is trusted as much as the command line that names it; what is bounded is what a file can
    make mshbm do (next paragraph).  Only regular files are read (no devices, FIFOs, directories).

Limits (checked before the values are read)
    A matrix file may be at most :data:`MAX_MATRIX_FILE_BYTES` bytes, declare at most
    :data:`MAX_VALUES` stored entries (the value-count limit of case files, 5 million) and at most
    as many rows.  For ``.mtx`` the header (``scipy.io.mminfo``) gives the size and the entry
    count; for ``.npz`` the zip directory gives each member's uncompressed size (no zip bomb is
    inflated) and the ``shape`` and ``format`` members are read first.  ``.npz`` files are read
    with ``allow_pickle=False``: no code runs.

Checks (after the limits, before any computation)
    The arrays of an ``.npz`` are checked against its format before the sparse matrix is built
    (scipy.sparse does not check index values): integer index arrays of the right dimension;
    ``indptr`` of length (rows or block rows or columns) + 1, starting at 0, non-decreasing and
    ending at the number of stored entries; ``indices``, ``row``, ``col`` (or ``coords``) as long
    as ``data`` and inside the shape; ``bsr`` blocks that tile the shape; ``dia`` offsets inside
    the shape, one per diagonal of ``data`` and not repeated.  Entries of ``.mtx`` files outside
    the declared size are refused by the reader.  Values must be real and finite.  ``M``, ``C``
    and ``K`` must be symmetric (:class:`mshbm.system.System`): their relative asymmetry
    ``max|A - A^T| / max|A|`` may not exceed 1e-12 for ``M`` and 1e-10 for ``C`` and ``K``
    (circulatory and gyroscopic terms are not supported), for matrices from files and inline
    alike.  Every failure is an :class:`~mshbm.errors.InputError` naming the key.

Storage
    Matrices read from files are kept sparse (CSR) when ``n > 200`` -- the rule of
    :func:`mshbm.system.chain` -- and all three of ``M, C, K`` are then sparse; for ``n <= 200``
    they are dense arrays.  A chain written to files therefore gives, bit for bit, the solution of
    the same chain built inline.

Rayleigh damping
    ``damping: {alpha: a, beta: b}`` (each ``>= 0``, default 0) sets ``C = a M + b K``, for
    matrix cases (instead of ``C``) and for chains (instead of the per-spring dampers; the chain's
    ``damping`` may still be a number or a list of dampers, as before).
"""
from __future__ import annotations

import os
import stat
import zipfile
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from .yaml import MAX_VALUES, describe as _describe

__all__ = ["MAX_MATRIX_FILE_BYTES", "MATRIX_EXTENSIONS", "RAYLEIGH_KEYS", "SPARSE_ABOVE",
           "read_matrix_file", "rayleigh", "rayleigh_damping", "matrix_storage"]

#: largest matrix file accepted (bytes): about 64 bytes per entry at the value-count limit
MAX_MATRIX_FILE_BYTES = 320 * 2**20
#: file extensions read as matrices
MATRIX_EXTENSIONS = (".mtx", ".npz")
#: keys of the Rayleigh ``damping`` mapping
RAYLEIGH_KEYS = ("alpha", "beta")
#: matrices from files are stored sparse above this many DOFs (as :func:`mshbm.system.chain`)
SPARSE_ABOVE = 200
_NPZ_FORMATS = ("csr", "csc", "coo", "bsr", "dia")
#: bytes of one stored value in an .npz member (8-byte data or index) plus the .npy header
_NPZ_MEMBER_BYTES = 16 * MAX_VALUES + 4096


def _short(text, limit=160):
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def resolve_path(key, value, base_dir=None):
    """Absolute :class:`~pathlib.Path` of a matrix file named in the case (see the module docstring)."""
    if not isinstance(value, str) or not value.strip():
        raise InputError(key, f"must be a matrix file path or a list of rows, got {_describe(value)}")
    if "\x00" in value:
        raise InputError(key, "the file path contains a NUL character")
    path = Path(value).expanduser()
    if not path.is_absolute():
        path = Path(base_dir if base_dir is not None else os.getcwd()) / path
    return path


def read_matrix_file(key, value, base_dir=None):
    """Read the matrix file ``value`` (a path; relative to ``base_dir``) as a CSR matrix of floats.

    Raises
    ------
    InputError
        With ``key`` (``"M"``, ``"C"`` or ``"K"``): unsupported extension, missing or unreadable
        file, a file over the limits, malformed content (arrays inconsistent with their format or
        shape), a matrix that is not square, not real or not finite.
    """
    path = resolve_path(key, value, base_dir)
    ext = path.suffix.lower()
    if ext not in MATRIX_EXTENSIONS:
        raise InputError(key, f"unsupported matrix file {value!r} ({f'extension {ext!r}' if ext else 'no extension'}); "
                              "use a Matrix Market .mtx or a scipy.sparse .npz file, or a list of rows")
    try:
        st = path.stat()
    except OSError as exc:
        raise InputError(key, f"cannot read the matrix file {str(path)!r}: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(key, f"{str(path)!r} is not a regular file")
    if st.st_size > MAX_MATRIX_FILE_BYTES:
        raise InputError(key, f"matrix file {str(path)!r} is {st.st_size / 2**20:.1f} MB; matrix files "
                              f"are limited to {MAX_MATRIX_FILE_BYTES / 2**20:.0f} MB")
    A = _read_mtx(key, path) if ext == ".mtx" else _read_npz(key, path)
    if A.dtype.kind not in "biuf":
        raise InputError(key, f"matrix file {str(path)!r} holds {A.dtype} values; real numbers are needed")
    A = sp.csr_matrix(A, dtype=float)
    if A.shape[0] != A.shape[1]:
        raise InputError(key, f"must be a square matrix, got {A.shape[0]}x{A.shape[1]} from {str(path)!r}")
    if not np.all(np.isfinite(A.data)):
        raise InputError(key, f"matrix file {str(path)!r} contains NaN or inf values")
    A.sum_duplicates()
    A.sort_indices()
    return A


def _check_size(key, path, rows, cols, entries):
    if rows < 1 or cols < 1:
        raise InputError(key, f"matrix file {str(path)!r} declares an empty {rows}x{cols} matrix")
    if rows != cols:
        raise InputError(key, f"must be a square matrix, got {rows}x{cols} from {str(path)!r}")
    if rows > MAX_VALUES or entries > MAX_VALUES:
        raise InputError(key, f"matrix file {str(path)!r} declares {rows}x{cols} with {entries:,} entries; "
                              f"at most {MAX_VALUES:,} rows and stored entries are accepted")


def _read_mtx(key, path):
    import scipy.io as sio
    try:
        rows, cols, entries, fmt, field, symmetry = sio.mminfo(str(path))
    except Exception as exc:  # noqa: BLE001 - any parse failure of a foreign file is bad input
        raise InputError(key, f"not a Matrix Market file {str(path)!r}: {_short(exc)}") from None
    if fmt == "array":
        entries = rows * cols
    _check_size(key, path, int(rows), int(cols), int(entries))
    if field not in ("real", "integer", "double"):
        raise InputError(key, f"Matrix Market file {str(path)!r} has field {field!r}; "
                              "real or integer values are needed")
    try:
        A = sio.mmread(str(path))
    except Exception as exc:  # noqa: BLE001
        raise InputError(key, f"malformed Matrix Market file {str(path)!r}: {_short(exc)}") from None
    if A.shape != (rows, cols):
        raise InputError(key, f"malformed Matrix Market file {str(path)!r}: header says {rows}x{cols}, "
                              f"read {A.shape[0]}x{A.shape[1]}")
    return A


def _read_npz(key, path):
    what = f"{str(path)!r} is not a scipy.sparse .npz file (write it with scipy.sparse.save_npz)"
    try:
        with zipfile.ZipFile(path) as zf:
            sizes = {info.filename: info.file_size for info in zf.infolist()}
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
        raise InputError(key, f"{what}: {_short(exc)}") from None
    big = [name for name, size in sizes.items() if size > _NPZ_MEMBER_BYTES]
    if big:
        raise InputError(key, f"matrix file {str(path)!r}: member {big[0]!r} unpacks to "
                              f"{sizes[big[0]] / 2**20:.0f} MB, more than {MAX_VALUES:,} values")
    if "format.npy" not in sizes or "shape.npy" not in sizes:
        raise InputError(key, f"{what}: no 'format' and 'shape' entries")
    try:
        with np.load(path, allow_pickle=False) as npz:
            fmt = npz["format"]
            shape = npz["shape"]
            fmt = fmt.item() if fmt.ndim == 0 else None
            fmt = fmt.decode("ascii", "replace") if isinstance(fmt, bytes) else fmt
            if not isinstance(fmt, str) or fmt not in _NPZ_FORMATS:
                raise InputError(key, f"{what}: unknown sparse format {_short(repr(fmt), 40)}")
            if shape.shape != (2,) or shape.dtype.kind not in "iu":
                raise InputError(key, f"{what}: 'shape' must be two integers")
            rows, cols = (int(s) for s in shape)
            nnz = sizes.get("data.npy", 0) // 8
            _check_size(key, path, rows, cols, nnz)
            names = _npz_members(fmt, sizes)
            missing = [name for name in names if f"{name}.npy" not in sizes]
            if missing:
                raise InputError(key, f"{what}: no {missing[0]!r} entry (a {fmt} matrix has "
                                      f"{', '.join(names)})")
            arrays = {name: npz[name] for name in names}
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise InputError(key, f"{what}: {_short(exc)}") from None
    data = arrays["data"]
    if data.dtype.kind not in "biuf":
        raise InputError(key, f"matrix file {str(path)!r} holds {data.dtype} values; real numbers are needed")
    _check_npz_arrays(key, path, fmt, rows, cols, arrays)
    try:
        A = _npz_matrix(fmt, (rows, cols), arrays)
    except Exception as exc:  # noqa: BLE001
        raise InputError(key, f"{what}: {_short(exc)}") from None
    if A.nnz > MAX_VALUES:
        raise InputError(key, f"matrix file {str(path)!r} holds {A.nnz:,} entries; at most {MAX_VALUES:,}")
    return A


def _npz_members(fmt, sizes):
    """Names of the arrays of a ``fmt`` matrix in an .npz (as :func:`scipy.sparse.save_npz` writes them)."""
    if fmt in ("csr", "csc", "bsr"):
        return ("data", "indices", "indptr")
    if fmt == "dia":
        return ("data", "offsets")
    return ("data", "coords") if "coords.npy" in sizes and "row.npy" not in sizes else ("data", "row", "col")


def _check_npz_arrays(key, path, fmt, rows, cols, arrays):
    """Check the raw arrays of a ``rows x cols`` sparse matrix in format ``fmt`` (see the module
    docstring); scipy.sparse does not check index values when it builds a matrix from arrays."""

    def bad(problem):
        return InputError(key, f"malformed {fmt} matrix in {str(path)!r}: {problem}")

    def index_array(name, ndim=1):
        a = arrays[name]
        if a.dtype.kind not in "iu":
            raise bad(f"{name!r} must hold integers, got {a.dtype}")
        if a.ndim != ndim:
            raise bad(f"{name!r} must be a {ndim}-D array, got shape {a.shape}")
        return a

    def in_range(name, a, lo, hi):
        """Every entry of ``a`` in ``lo..hi``."""
        if a.size and (int(a.min()) < lo or int(a.max()) > hi):
            i = int(np.flatnonzero((a < lo) | (a > hi))[0])
            where = f"{name}[{i}]" if a.ndim == 1 else f"{name}{list(np.unravel_index(i, a.shape))}"
            raise bad(f"{where} = {int(a.flat[i])} is outside {lo}..{hi}")

    def same_length(name, a, other, n):
        if a.shape[-1] != n:
            raise bad(f"{name!r} has {a.shape[-1]} entries, {other!r} has {n}")

    data = arrays["data"]
    if fmt in ("csr", "csc", "bsr"):
        if fmt == "bsr":
            if data.ndim != 3:
                raise bad(f"'data' must be a 3-D array of blocks, got shape {data.shape}")
            R, C = data.shape[1:]
            if R < 1 or C < 1 or rows % R or cols % C:
                raise bad(f"blocks of {R}x{C} do not tile the {rows}x{cols} matrix")
            major, minor = rows // R, cols // C
        else:
            if data.ndim != 1:
                raise bad(f"'data' must be a 1-D array, got shape {data.shape}")
            major, minor = (rows, cols) if fmt == "csr" else (cols, rows)
        stored = data.shape[0]
        indptr, indices = index_array("indptr"), index_array("indices")
        if indptr.size != major + 1:
            raise bad(f"'indptr' has {indptr.size} entries, a {rows}x{cols} {fmt} matrix needs {major + 1}")
        same_length("indices", indices, "data", stored)
        ptr = indptr.astype(np.int64)
        if ptr[0] != 0:
            raise bad(f"indptr[0] = {ptr[0]}, must be 0")
        if ptr[-1] != stored:
            raise bad(f"indptr[-1] = {ptr[-1]} differs from the {stored} stored "
                      f"{'blocks' if fmt == 'bsr' else 'entries'} of 'data'")
        drops = np.flatnonzero(np.diff(ptr) < 0)
        if drops.size:  # with indptr[0] = 0 and indptr[-1] = stored, every entry is then in 0..stored
            i = int(drops[0])
            raise bad(f"indptr is not non-decreasing (indptr[{i}] = {ptr[i]} > indptr[{i + 1}] = {ptr[i + 1]})")
        in_range("indices", indices, 0, minor - 1)
    elif fmt == "coo":
        if data.ndim != 1:
            raise bad(f"'data' must be a 1-D array, got shape {data.shape}")
        if "coords" in arrays:
            coords = index_array("coords", ndim=2)
            if coords.shape[0] != 2:
                raise bad(f"'coords' must have 2 rows (row and column indices), got shape {coords.shape}")
            row, col = coords
        else:
            row, col = index_array("row"), index_array("col")
        same_length("row", row, "data", data.size)
        same_length("col", col, "data", data.size)
        in_range("row", row, 0, rows - 1)
        in_range("col", col, 0, cols - 1)
    else:  # dia
        offsets = index_array("offsets")
        if data.ndim != 2:
            raise bad(f"'data' must be a 2-D array (one row per diagonal), got shape {data.shape}")
        if offsets.size != data.shape[0]:
            raise bad(f"'offsets' has {offsets.size} entries, 'data' has {data.shape[0]} diagonals")
        in_range("offsets", offsets, -(rows - 1), cols - 1)
        if np.unique(offsets).size != offsets.size:
            raise bad("'offsets' repeats a diagonal")


def _npz_matrix(fmt, shape, arrays):
    """The sparse matrix of checked arrays (:func:`_check_npz_arrays`)."""
    cls = getattr(sp, f"{fmt}_matrix")
    if fmt in ("csr", "csc", "bsr"):
        return cls((arrays["data"], arrays["indices"], arrays["indptr"]), shape=shape)
    if fmt == "dia":
        return cls((arrays["data"], arrays["offsets"]), shape=shape)
    row, col = arrays["coords"] if "coords" in arrays else (arrays["row"], arrays["col"])
    return cls((arrays["data"], (row, col)), shape=shape)


def matrix_storage(mats):
    """Apply the storage rule to ``{name: matrix}`` (see the module docstring): all CSR when ``n > 200``
    and at least one came from a file (is sparse), otherwise dense arrays for the file matrices."""
    n = next(iter(mats.values())).shape[0]
    if not any(sp.issparse(A) for A in mats.values()):
        return mats
    if n > SPARSE_ABOVE:
        return {k: (A if sp.issparse(A) else sp.csr_matrix(A, dtype=float)) for k, A in mats.items()}
    return {k: (A.toarray() if sp.issparse(A) else A) for k, A in mats.items()}


def rayleigh(value, number):
    """``(alpha, beta)`` of ``damping: {alpha, beta}``; ``number(key, value)`` checks one number."""
    if not isinstance(value, dict):
        raise InputError("damping", f"must be a mapping {{alpha, beta}}, got {_describe(value)}")
    for k in value:
        if k not in RAYLEIGH_KEYS:
            name = k if isinstance(k, str) else repr(k)
            raise InputError(f"damping.{name}", "unknown key (allowed: alpha, beta; Rayleigh damping "
                                                "C = alpha M + beta K)")
    out = []
    for k in RAYLEIGH_KEYS:
        v = number(f"damping.{k}", value.get(k, 0.0))
        if v < 0:
            raise InputError(f"damping.{k}", f"must be >= 0, got {v:g}")
        out.append(v)
    return tuple(out)


def rayleigh_damping(M, K, alpha, beta):
    """``C = alpha M + beta K`` (sparse CSR when ``M`` or ``K`` is sparse)."""
    if sp.issparse(M) or sp.issparse(K):
        return sp.csr_matrix(alpha * sp.csr_matrix(M, dtype=float) + beta * sp.csr_matrix(K, dtype=float))
    return alpha * np.asarray(M, dtype=float) + beta * np.asarray(K, dtype=float)
