"""Checks of a solve's input that need the method: forcing the method can represent, partitions,
guesses, free-free structures and the float range.

Called by :func:`mshbm.api.build_problem` (and :func:`mshbm.methods.common.guess_parts`); each raises
:class:`mshbm.InputError` naming the key.  Notation as in :mod:`mshbm.system`: ``n`` DOFs,
``n_h`` harmonics, ``N`` time steps (or AFT samples) per period, forcing coefficients
``f_hat`` of shape ``(2 n_f + 1, n)``.

Rules (documented for users in the README section "What mshbm refuses"):

* **Forcing.** A forcing harmonic ``k`` is represented exactly when its DOF is integrated in time
  (shooting; the time-stepped subsystem of MS-HBM) and ``steps > 2k`` (no aliasing: the time
  grid must resolve ``cos(k omega t)`` and ``sin(k omega t)``), or when its DOF is in the harmonic
  part and ``k <= harmonics``.  Anything else is an input error: key ``harmonics`` (HBM, and the
  harmonic part of MS-HBM) or ``steps`` (time-stepped DOFs).
* **Partitions.** Flat list of distinct in-range DOFs holding all element DOFs (``hbm``,
  ``mshbm``); a pair of such lists, disjoint, subsystem 1 holding all element DOFs
  (``mshbm-intermediate``).  Booleans and non-integral numbers are not DOFs.
* **Guesses.** See :func:`check_guess`.
* **Free-free structures.** ``K`` singular (a rigid-body mode) and no contact element: the mean
  position is undetermined (friction forces do not depend on the position), so every method
  would return one arbitrary member of a family, or fail: key ``K``.  With a contact element
  the contact may hold the structure, and the solve is attempted (it fails honestly when the
  contact does not hold it).
* **Float range.** The terms of the dynamic stiffness ``K``, ``k omega C``, ``(k omega)^2 M``
  for ``k <= n_h``, and for time-stepping ``M/h^2``, ``C/h``, must stay below
  :data:`FLOAT_LIMIT`; so must the forcing and the element force bounds.  Beyond, residuals
  overflow and the error would otherwise surface as "singular" matrices or NaN.
"""
from __future__ import annotations

import math
import numbers

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.csgraph  # noqa: F401 -- sp.csgraph
import scipy.sparse.linalg as spla

from .errors import InputError
from .methods.capabilities import capabilities

__all__ = ["check_forcing", "check_partition", "check_guess", "check_free_free", "check_float_range",
           "FLOAT_LIMIT", "GUESS_LIMIT"]

#: largest magnitude of a term of the problem (matrix entries times frequency powers, forces)
FLOAT_LIMIT = 1e250
#: largest magnitude of a guess entry (its square must not overflow)
GUESS_LIMIT = 1e150


# ----------------------------------------------------------------------------- forcing
def forcing_harmonics(f_hat):
    """Highest non-zero forcing harmonic per DOF, shape (n,) (0: constant or no forcing)."""
    f_hat = np.asarray(f_hat)
    n_f = (f_hat.shape[0] - 1) // 2
    top = np.zeros(f_hat.shape[1], dtype=np.int64)
    for k in range(1, n_f + 1):
        nz = np.any(f_hat[2 * k - 1:2 * k + 1] != 0, axis=0)
        top[nz] = k
    return top


def _forcing_top(system):
    """:func:`forcing_harmonics` of ``system.f_hat`` (cached on the system, read-only)."""
    def compute():
        top = forcing_harmonics(system.f_hat)
        top.flags.writeable = False
        return top

    return system.derived("forcing_harmonics", ("f_hat",), compute)


def _forcing_top_max(system):
    """Highest forcing harmonic of any DOF, ``int(max(_forcing_top(system)))`` (0 for no forcing; cached)."""
    return system.derived("forcing_harmonics_max", ("f_hat",), lambda: int(_forcing_top(system).max(initial=0)))


def check_forcing(system, method, n_h, steps, time_dofs):
    """Raise when a forcing harmonic cannot be represented (see the module docstring).

    Parameters
    ----------
    time_dofs : array of int
        DOFs integrated in time (all DOFs for shooting, none for HBM).
    """
    top_max = _forcing_top_max(system)
    if top_max == 0:
        return
    if len(time_dofs) == 0 and top_max <= n_h:  # HBM, DLFT: every harmonic representable (no array pass)
        return
    top = _forcing_top(system)
    timed = np.zeros(system.n, dtype=bool)
    timed[np.asarray(time_dofs, dtype=np.int64)] = True
    bad = np.flatnonzero(~timed & (top > n_h))
    if bad.size:
        d = int(bad[np.argmax(top[bad])])
        k = int(top[d])
        where = capabilities(method).harmonic_part
        raise InputError("harmonics", f"the forcing has harmonic {k} (on DOF {d}), above harmonics={n_h}: "
                                      f"{where} cannot represent it and would drop it; use harmonics >= {k}")
    bad = np.flatnonzero(timed & (2 * top >= steps))
    if bad.size:
        d = int(bad[np.argmax(top[bad])])
        k = int(top[d])
        raise InputError("steps", f"the forcing has harmonic {k} (on DOF {d}), which {steps} steps per period "
                                  f"cannot resolve (aliasing); use steps > {2 * k}")


# ----------------------------------------------------------------------------- partitions
def _dof_list(key, value, n):
    if isinstance(value, np.ndarray):
        if value.ndim != 1:
            raise InputError(key, f"must be a flat list of DOF indices, got an array of shape {value.shape}")
        value = value.tolist()
    if not isinstance(value, (list, tuple, range)):
        raise InputError(key, f"must be a list of DOF indices, got {type(value).__name__}")
    out = []
    for i, d in enumerate(value):
        if isinstance(d, (list, tuple, np.ndarray)):
            raise InputError(key, f"entry {i} is a list: wrong nesting (expected a flat list of DOF indices)")
        if isinstance(d, (bool, np.bool_)) or not isinstance(d, numbers.Real):
            raise InputError(key, f"entry {i} must be an integer DOF index, got {d!r}")
        if not isinstance(d, numbers.Integral):
            if not (math.isfinite(float(d)) and float(d).is_integer()):
                raise InputError(key, f"entry {i} must be an integer DOF index, got {d!r}")
        d = int(d)
        if not 0 <= d < n:
            raise InputError(key, f"DOF {d} out of range 0..{n - 1}")
        out.append(d)
    seen = set()
    for d in out:
        if d in seen:
            raise InputError(key, f"repeats DOF {d}")
        seen.add(d)
    return np.array(out, dtype=np.int64)


def check_partition(system, method, partition):
    """Validated partition: int array (``hbm``, ``mshbm``) or a pair of int arrays (``mshbm-intermediate``)."""
    n = system.n
    el_dofs = sorted({int(d) for e in system.elements for d in e.dofs})
    if capabilities(method).partition_pair:
        if isinstance(partition, np.ndarray) and partition.dtype != object and partition.ndim == 2 \
                and partition.shape[0] == 2:
            partition = list(partition)
        if not isinstance(partition, (list, tuple)) or len(partition) != 2 \
                or not all(isinstance(p, (list, tuple, np.ndarray, range)) for p in partition):
            raise InputError("partition", "must be a pair [dofs_1, dofs_2] of DOF lists (subsystems 1 and 2; "
                                          "subsystem 3 is the rest)")
        I1 = _dof_list("partition", partition[0], n)
        I2 = _dof_list("partition", partition[1], n)
        both = sorted(set(I1.tolist()) & set(I2.tolist()))
        if both:
            raise InputError("partition", f"subsystems 1 and 2 overlap (DOF {both[0]} is in both)")
        if I1.size == 0:
            raise InputError("partition", "subsystem 1 is empty")
        if I2.size == 0:
            raise InputError("partition", "subsystem 2 is empty: nothing couples subsystem 1 to the rest; "
                                          "use 'mshbm'")
        missing = sorted(set(el_dofs) - set(I1.tolist()))
        if missing:
            raise InputError("partition", f"subsystem 1 must contain the element DOFs {missing}")
        return I1, I2
    if isinstance(partition, (list, tuple)) and partition and all(
            isinstance(p, (list, tuple, np.ndarray)) for p in partition):
        raise InputError("partition", f"a nested list (pair of subsystems) is only for 'mshbm-intermediate'; "
                                      f"{method!r} takes a flat list of DOF indices")
    part = _dof_list("partition", partition, n)
    missing = sorted(set(el_dofs) - set(part.tolist()))
    if missing:
        raise InputError("partition", f"must contain the element DOFs {missing}")
    return part


# ----------------------------------------------------------------------------- guesses
def _guess_array(key, value, shape_text, ok):
    if isinstance(value, (str, bytes)):
        raise InputError(key, f"must be a numeric array {shape_text}, got a string")
    try:
        arr = np.asarray(value)
    except Exception as exc:  # noqa: BLE001 -- ragged lists and other oddities
        raise InputError(key, f"must be a numeric array {shape_text} ({exc})") from None
    if arr.dtype == object:
        try:
            arr = arr.astype(float)
        except (TypeError, ValueError):
            raise InputError(key, f"must be a numeric array {shape_text} (ragged or non-numeric)") from None
    if arr.dtype.kind in "c":
        raise InputError(key, "must be real (got complex numbers; give real coefficients "
                              "[x0, xc_1, xs_1, ...])")
    if arr.dtype.kind not in "iuf":
        raise InputError(key, f"must be a numeric array {shape_text}, got dtype {arr.dtype}")
    arr = arr.astype(float)
    if not ok(arr.shape):
        raise InputError(key, f"must have shape {shape_text}, got {arr.shape}")
    check_guess_values(key, arr)
    return arr


def check_guess_values(key, arr):
    """NaN/inf and absurd sizes (``> GUESS_LIMIT``) are input errors."""
    arr = np.asarray(arr, dtype=float)
    if not np.isfinite(arr).all():
        raise InputError(key, "contains NaN or inf")
    big = float(np.abs(arr).max(initial=0.0))
    if big > GUESS_LIMIT:
        raise InputError(key, f"has entries of size {big:.3g}, beyond {GUESS_LIMIT:.0e} (their squares "
                              "overflow): give a guess of the size of the expected response")


def check_guess(guess, n):
    """Validated dict guess: ``{"q_hat": (2 m + 1, n), "q0": (n,), "u0": (n,)}`` (q0, u0 optional).

    Unknown keys, strings, complex or ragged arrays, wrong shapes, NaN/inf and entries beyond
    :data:`GUESS_LIMIT` raise :class:`InputError` with key ``guess.<name>``.
    """
    allowed = ("q_hat", "q0", "u0")
    for k in guess:
        if k not in allowed:
            raise InputError(f"guess.{k}", f"unknown key (a dict guess has {', '.join(allowed)})")
    if "q_hat" not in guess or guess["q_hat"] is None:
        raise InputError("guess", "a dict guess needs 'q_hat'")
    out = {"q_hat": _guess_array("guess.q_hat", guess["q_hat"], f"(2*n_h+1, {n})",
                                 lambda s: len(s) == 2 and s[1] == n and s[0] % 2 == 1)}
    for k in ("q0", "u0"):
        v = guess.get(k)
        out[k] = None if v is None else _guess_array(f"guess.{k}", v, f"({n},)", lambda s: s == (n,))
    return out


# ----------------------------------------------------------------------------- free-free, float range
def _max_abs(A):
    if sp.issparse(A):
        return float(abs(A).max()) if A.nnz else 0.0
    return float(np.max(np.abs(A), initial=0.0))


def _irreducibly_dominant(K):
    """Sufficient test of regularity in O(nnz): every connected block of ``K`` is weakly diagonally
    dominant with one strictly dominant row (Taussky) -- true for grounded chains and meshes."""
    A = sp.csr_matrix(K)
    diag = A.diagonal()
    off = np.asarray(abs(A).sum(axis=1)).ravel() - np.abs(diag)
    if np.any(diag < off * (1.0 + 1e-12)) and np.any(diag < off - 1e-12 * np.abs(diag)):
        return False
    strict = diag > off * (1.0 + 1e-9) + 1e-300
    ncomp, labels = sp.csgraph.connected_components(A, directed=False)
    return bool(np.all(np.bincount(labels, weights=strict.astype(float), minlength=ncomp) > 0))


def k_is_singular(K, rcond_min=1e-13):
    """True when ``K`` is numerically singular (LU pivot ratio below ``rcond_min``).

    The LU is skipped when the O(nnz) test :func:`_irreducibly_dominant` proves ``K`` regular.
    """
    if _irreducibly_dominant(K):
        return False
    if sp.issparse(K):
        try:
            lu = spla.splu(sp.csc_matrix(K), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                           options=dict(SymmetricMode=True))
        except RuntimeError:
            return True
        d = np.abs(lu.U.diagonal())
    else:
        K = np.asarray(K, dtype=float)
        getrf, = sla.get_lapack_funcs(("getrf",), (K,))
        lu, _, info = getrf(K)
        if info > 0:
            return True
        d = np.abs(np.diag(lu))
    return not (d.max() > 0 and d.min() / d.max() >= rcond_min)


def check_free_free(system):
    """Raise ``InputError("K")`` for a free-free structure not held by a contact element."""
    if any(e.unilateral for e in system.elements):
        return
    if not system.derived("k_is_singular", ("K",), lambda: k_is_singular(system.K)):
        return
    held = "friction does not hold a position" if system.elements else "no element holds it"
    raise InputError("K", f"is singular: the structure is free-free (a rigid-body mode without a spring to "
                          f"ground; {held}), so its mean position, and for an undamped rigid mode its drift, "
                          "are undetermined; add a grounding spring")


def check_float_range(system, omega, n_h, steps, method):
    """Raise when a term of the problem leaves the float range (see the module docstring)."""
    mM, mC, mK, mf, el_terms = system.derived(
        "magnitudes", ("M", "C", "K", "f_hat", "elements"),
        lambda: tuple(_max_abs(getattr(system, a)) for a in ("M", "C", "K", "f_hat"))
        + (tuple(t for e in system.elements for t in e.magnitude_terms()),))
    w = n_h * omega
    terms = [("K", "max |K|", mK), ("omega", f"({n_h} omega)^2 max |M|", w * w * mM),
             ("omega", f"{n_h} omega max |C|", w * mC)]
    if not capabilities(method).aft_samples:  # steps are time steps
        h = 2 * math.pi / omega / steps
        terms += [("steps", "max |M| / h^2 (h = T/steps)", mM / (h * h)), ("steps", "max |C| / h", mC / h)]
    terms += [("forcing", "max |f|", mf)]
    terms += el_terms
    for key, what, val in terms:
        if not math.isfinite(val) or val > FLOAT_LIMIT:
            raise InputError(key, f"{what} = {val:.3g} leaves the float range (limit {FLOAT_LIMIT:.0e}): the "
                                  "computation would overflow; rescale the units (e.g. time, length)")


def check_inputs(system, omega, method, n_h, steps, partition=None):
    """All checks of :func:`mshbm.api.build_problem` that need the method, in the order of their keys:
    float range, free-free structure, forcing representation (``partition`` already validated)."""
    check_float_range(system, omega, n_h, steps, method)
    check_free_free(system)
    time_dofs = capabilities(method).timed_dofs(system, partition)
    check_forcing(system, method, n_h, steps, time_dofs)


# ----------------------------------------------------------------------------- messages
class quiet_floats:
    """Context manager: no floating-point RuntimeWarnings reach the user during a solve.

    Overflow and invalid operations show up as non-finite numbers, which the solvers check and
    report in the result's message (:func:`overflow_message`).
    """

    def __enter__(self):
        import warnings

        self._err = np.errstate(all="ignore")  # a context variable in numpy 2: cheaper than seterr twice
        self._err.__enter__()
        self._cw = warnings.catch_warnings()
        self._cw.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)
        return self

    def __exit__(self, *exc):
        self._cw.__exit__(*exc)
        self._err.__exit__(*exc)
        return False


_NONFINITE = ("not finite", "NaN/inf", "non-finite")


def overflow_message(success, message, residual):
    """Name the cause when a solve failed on non-finite numbers: the float range was left."""
    if success:
        return message
    if any(s in message for s in _NONFINITE) or not math.isfinite(float(residual)):
        if not message.startswith("overflow"):
            return ("overflow: the computation left the float range (residual, Jacobian or solution not "
                    f"finite); rescale the units or give a smaller guess ({message})")
    return message


def singular_harmonic_error(exc):
    """InputError for a singular dynamic-stiffness block: ``K`` at harmonic 0 (free-free part), else omega."""
    text = str(exc)
    if "harmonic k=0 " in text:
        return InputError("K", f"{text}: a part of the structure is free-free (singular K, no grounding "
                               "spring); add a spring to ground or choose a partition that contains it")
    return InputError("omega", f"{text}; move omega away from this resonance or add damping")
