"""Mechanical systems with local nonsmooth elements.

Notation (Schreyer & Leine 2016, eq. 6)::

    M q'' + C q' + K q = f_ex(t) + f_nl(q, q')

``q`` (displacements, shape ``(n,)``) and ``u = q'`` (velocities).  ``M, C, K``
are ``(n, n)`` arrays, dense (``numpy.ndarray``) or ``scipy.sparse``.  The
periodic forcing ``f_ex(t)`` with angular frequency ``omega`` is given by its
Fourier coefficients in the paper's real convention (eqs. 1-3)::

    f_ex(t) = f0 + sum_k fc_k cos(k omega t) + fs_k sin(k omega t)

stored as ``f_hat`` of shape ``(2 n_f + 1, n)``, rows ``[f0, fc_1, fs_1, ...]``.

A forcing may depend on ``omega`` (imposed support motion, :mod:`mshbm.support`): its coefficients are
then ``f_hat(omega) = F0 + omega F1 + omega^2 F2`` (``forcing_parts = (F0, F1, F2)``).  Such a system is
*tuned* to one frequency by :meth:`System.at`, which sets ``f_hat = f_hat(omega)``; every problem is built
on the system tuned to its frequency, so code reading ``f_hat`` sees the forcing at that frequency.  The
untuned system's ``f_hat`` is NaN (undefined), and :meth:`System.forcing` and :meth:`System.forcing_hat`
with an explicit ``omega`` evaluate ``f_hat(omega)`` on any copy.

Local nonlinear elements (:mod:`mshbm.elements`: :class:`~mshbm.elements.Friction`,
:class:`~mshbm.elements.Contact`, re-exported here) act on single DOFs; every element has a
direction ``w`` (``+e_dof`` for friction, ``-e_dof`` for contact) and its force on the DOFs is
``w * lambda``.  The elements own their laws (set-valued and regularised).

The DOFs carrying elements form the nonlinear subsystem ``N``; the others the
linear subsystem ``L`` (eq. 7).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .elements import Contact, Element, Friction, _dof, _finite_number
from .elements.cone import check_cone_pairs
from .errors import InputError

__all__ = ["Friction", "Contact", "System", "chain"]


def _as_matrix(key, A, n=None):
    if sp.issparse(A):
        A = sp.csr_matrix(A, dtype=float)
        data = A.data
    else:
        try:
            A = np.array(A, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(key, f"must be a numeric matrix ({exc})") from None
        if A.ndim == 0 and n is None:
            A = A.reshape(1, 1)
        data = A
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise InputError(key, f"must be a square matrix, got shape {A.shape}")
    if n is not None and A.shape[0] != n:
        raise InputError(key, f"must be {n}x{n} like M, got {A.shape[0]}x{A.shape[1]}")
    if not np.all(np.isfinite(data)):
        raise InputError(key, "contains NaN or inf")
    return A


#: largest relative asymmetry ``max|A - A^T| / max|A|`` accepted for ``M`` and for ``C``, ``K``
SYMMETRY_RTOL = {"M": 1e-12, "C": 1e-10, "K": 1e-10}


def asymmetry(A):
    """Relative asymmetry ``max|A - A^T| / max|A|`` (entrywise maxima) of a square matrix; 0 for ``A = 0``."""
    if sp.issparse(A):
        d = abs(A - A.T)
        num = d.max() if d.nnz else 0.0
        scale = abs(A).max() if A.nnz else 0.0
    else:
        num = np.abs(A - A.T).max() if A.size else 0.0
        scale = np.abs(A).max() if A.size else 0.0
    return float(num) / float(scale) if scale > 0 else 0.0


def _check_symmetric(key, A):
    """:class:`InputError` naming ``key`` when ``A`` is not symmetric (see :data:`SYMMETRY_RTOL`)."""
    r = asymmetry(A)
    if r > SYMMETRY_RTOL[key]:
        raise InputError(key, f"must be symmetric: relative asymmetry max|{key} - {key}^T| / max|{key}| = "
                              f"{r:.3g} exceeds {SYMMETRY_RTOL[key]:g}"
                              + ("" if key == "M" else " (circulatory or gyroscopic terms are not supported)"))


def _check_positive_definite(M):
    if sp.issparse(M):
        off = M - sp.diags(M.diagonal())
        diag = M.diagonal()
        if np.any(diag <= 0):
            raise InputError("M", "must be positive definite (non-positive diagonal entry)")
        if off.nnz == 0 or np.all(diag > np.asarray(abs(off).sum(axis=1)).ravel()):
            return  # diagonal or strictly diagonally dominant with positive diagonal
        if M.shape[0] <= 3000:
            M = M.toarray()
        else:
            # Sylvester's law of inertia: a symmetric M is positive definite iff every pivot of its
            # symmetric (diagonal-pivoting) LU factorisation is > 0.  Sparse LU costs O(nnz) for a
            # banded FE mass matrix; the Lanczos smallest eigenvalue (eigsh "SA") took over a minute
            # at n = 10^4 for a consistent beam mass matrix.
            from scipy.sparse.linalg import eigsh, splu
            try:
                lu = splu(sp.csc_matrix(M), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                          options={"SymmetricMode": True})
            except RuntimeError:  # exactly singular
                raise InputError("M", "must be positive definite (singular)") from None
            if np.array_equal(lu.perm_r, lu.perm_c):  # no off-diagonal pivot: the pivots are U's diagonal
                piv = lu.U.diagonal()
                if np.all(piv > 0):
                    return
                raise InputError("M", "must be positive definite (a non-positive pivot in its "
                                      "symmetric factorisation)")
            lam = eigsh(M, k=1, which="SA", return_eigenvectors=False, tol=1e-8)[0]
            if lam <= 0:
                raise InputError("M", f"must be positive definite (smallest eigenvalue {lam:.3g})")
            return
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise InputError("M", "must be positive definite") from None


class System:
    """Linear structure ``M q'' + C q' + K q = f_ex(t)`` plus local elements.

    Parameters
    ----------
    M, C, K : array_like or sparse matrix, shape (n, n)
        Mass (kg), damping (Ns/m) and stiffness (N/m) matrices, symmetric (relative asymmetry
        :func:`asymmetry` at most :data:`SYMMETRY_RTOL`: 1e-12 for ``M``, 1e-10 for ``C`` and ``K``;
        skew-symmetric, i.e. gyroscopic or circulatory, terms are refused).  ``M`` must be
        positive definite.
    f_hat : array_like, shape (2*n_f + 1, n) or (n,)
        Fourier coefficients of the forcing (N) in the order
        ``[f0, fc_1, fs_1, ..., fc_nf, fs_nf]``; a 1-D array is a constant force.
    elements : sequence of mshbm.elements.Element
        Local nonlinear elements (Friction, Contact).
    name : str
        Label used in outputs.

    Notes
    -----
    The system keeps its own copies of dense ``M, C, K`` and of ``f_hat``, read-only: quantities
    derived from them (diagonals, scales, validation verdicts, dense blocks) are cached per system
    (:meth:`derived`) and stay valid.  To change a matrix, build a new System (or assign a new array
    to the attribute: the cache checks the objects' identity).
    """

    #: class defaults of the omega-dependent forcing (:meth:`with_omega_forcing`), for copies made by
    #: ``object.__new__`` and for systems pickled before these attributes existed
    forcing_parts = ()
    forcing_omega = None
    base = None

    def __init__(self, M, C, K, f_hat, elements=(), name="system"):
        self.M = _as_matrix("M", M)
        n = self.M.shape[0]
        if n < 1:
            raise InputError("M", "must have at least one DOF")
        self.C = _as_matrix("C", C, n)
        self.K = _as_matrix("K", K, n)
        _check_symmetric("M", self.M)
        _check_positive_definite(self.M)
        _check_symmetric("C", self.C)
        _check_symmetric("K", self.K)
        f_hat = np.array(f_hat, dtype=float) if not isinstance(f_hat, np.ndarray) else f_hat.astype(float)
        if f_hat.ndim == 1:
            f_hat = f_hat.reshape(1, -1)
        if f_hat.ndim != 2 or f_hat.shape[1] != n or f_hat.shape[0] % 2 != 1:
            raise InputError("forcing", f"f_hat must have shape (2*n_f+1, {n}), got {f_hat.shape}")
        if not np.all(np.isfinite(f_hat)):
            raise InputError("forcing", "contains NaN or inf")
        self.f_hat = f_hat
        for A in (self.M, self.C, self.K, self.f_hat):  # own copies: read-only, so derived values stay valid
            if isinstance(A, np.ndarray):
                A.flags.writeable = False
        self.elements = tuple(elements)
        seen = set()
        for i, el in enumerate(self.elements):
            if not isinstance(el, Element):
                raise InputError(f"elements[{i}]", f"must be an element (Friction, Contact), got {type(el).__name__}")
            if not 0 <= el.dof < n:
                raise InputError(f"{el.kind}.dof", f"DOF {el.dof} out of range 0..{n - 1}")
            if el.relative_to is not None and not 0 <= el.relative_to < n:
                raise InputError(f"{el.kind}.relative_to", f"DOF {el.relative_to} out of range 0..{n - 1}")
            key = (el.kind, tuple(el.dofs))
            if key in seen:
                where = f"DOF {el.dof}" if el.relative_to is None else f"DOFs {el.dof}-{el.relative_to}"
                raise InputError(f"{el.kind}.dof", f"two {el.kind} elements on {where}")
            seen.add(key)
        for i, el in enumerate(self.elements):
            c = el.normal_contact
            if c is None:
                continue
            if not 0 <= c < len(self.elements) or not self.elements[c].unilateral:
                what = f"element {c} is a {self.elements[c].kind}" if 0 <= c < len(self.elements) else \
                    f"no element {c} (the system has {len(self.elements)})"
                raise InputError(f"{el.kind}.normal_contact", f"must be the index of a contact element: {what}")
            if int(self.elements[c].dof) == int(el.dof):
                raise InputError(f"{el.kind}.normal_contact", f"contact {c} acts on the friction's own DOF "
                                 f"{el.dof}: the normal direction must be another DOF")
        check_cone_pairs(self.elements)
        self.name = str(name)
        # instance attributes set by with_omega_forcing / at / mshbm.support.base_excitation (class defaults
        # above): ``forcing_parts`` (F0, F1, F2) of an omega-dependent forcing (``()``: none), ``forcing_omega``
        # the frequency (rad/s) at which ``f_hat`` was evaluated (``None``: untuned or constant), ``base`` the
        # support motion (:class:`mshbm.support.BaseMotion`) the system was reduced from (``None``: none)

    # ------------------------------------------------------------------ omega-dependent forcing
    @property
    def omega_dependent(self):
        """True if the forcing depends on ``omega`` (``forcing_parts`` set)."""
        return bool(self.forcing_parts)

    def with_omega_forcing(self, F0, F1, F2):
        """Copy (matrices shared) whose forcing is ``F0 + omega F1 + omega^2 F2``, each shape
        ``(2 n_f + 1, n)`` (N, N s, N s^2); untuned (``f_hat`` NaN until :meth:`at`)."""
        parts = []
        for key, F in (("F0", F0), ("F1", F1), ("F2", F2)):
            F = np.array(F, dtype=float)
            if F.ndim != 2 or F.shape[1] != self.n or F.shape[0] % 2 != 1:
                raise InputError("forcing", f"{key} must have shape (2*n_f+1, {self.n}), got {F.shape}")
            if not np.all(np.isfinite(F)):
                raise InputError("forcing", f"{key} contains NaN or inf")
            parts.append(F)
        if len({F.shape for F in parts}) != 1:
            raise InputError("forcing", f"F0, F1, F2 must have one shape, got {[F.shape for F in parts]}")
        for F in parts:
            F.flags.writeable = False
        new = self.with_elements(self.elements)
        new.forcing_parts = tuple(parts)
        nan = np.full(parts[0].shape, np.nan)
        nan.flags.writeable = False
        new.f_hat, new.forcing_omega = nan, None
        return new

    def f_hat_at(self, omega):
        """Forcing coefficients at ``omega``, shape ``(2 n_f + 1, n)``: ``f_hat`` itself for a forcing that
        does not depend on omega (the same object)."""
        if not self.forcing_parts:
            return self.f_hat
        if self.forcing_omega is not None and float(omega) == self.forcing_omega:
            return self.f_hat
        F0, F1, F2 = self.forcing_parts
        w = float(omega)
        return F0 + w * F1 + (w * w) * F2

    def f_hat_omega_derivative(self, omega):
        """``d f_hat / d omega`` at ``omega``, shape ``(2 n_f + 1, n)`` (zero for a constant forcing)."""
        if not self.forcing_parts:
            return np.zeros_like(self.f_hat)
        _, F1, F2 = self.forcing_parts
        return F1 + (2.0 * float(omega)) * F2

    def at(self, omega):
        """The system with ``f_hat`` evaluated at ``omega`` (itself when the forcing does not depend on
        omega or it is tuned to ``omega`` already; else a copy sharing the matrices)."""
        if not self.forcing_parts or (self.forcing_omega is not None and float(omega) == self.forcing_omega):
            return self
        new = self.with_elements(self.elements)
        f = self.f_hat_at(omega)
        f.flags.writeable = False
        new.f_hat, new.forcing_omega = f, float(omega)
        return new

    def map_forcing(self, fn):
        """Copy (matrices shared) with every forcing array ``F`` replaced by ``fn(F)`` (``f_hat``, and the
        parts of an omega-dependent forcing): scaling, phase shifts, projections."""
        new = self.with_elements(self.elements)
        new.f_hat = fn(self.f_hat)
        if self.forcing_parts:
            new.forcing_parts = tuple(fn(F) for F in self.forcing_parts)
        return new

    # ------------------------------------------------------------------ basics
    @property
    def n(self):
        """Number of DOFs."""
        return self.M.shape[0]

    @property
    def is_sparse(self):
        return sp.issparse(self.M) or sp.issparse(self.C) or sp.issparse(self.K)

    @property
    def n_forcing_harmonics(self):
        """Highest harmonic ``n_f`` present in the forcing."""
        return (self.f_hat.shape[0] - 1) // 2

    @property
    def nonlinear_dofs(self):
        """Sorted DOFs carrying nonlinear elements (the default subsystem N)."""
        return np.array(sorted({d for el in self.elements for d in el.dofs}), dtype=np.int64)

    def derived(self, name, deps, compute):
        """``compute()``, cached on this system while the attributes ``deps`` (names, e.g. ``("K",)``)
        are the same objects and immutable: read-only arrays (``M, C, K, f_hat`` of a System are made
        read-only at construction) and the element tuple.  A dependency that is sparse or writeable
        (e.g. ``f_hat`` replaced by a writeable array on a copy) is not cached: ``compute()`` runs every
        time.  The value is shared between calls: callers must not modify it."""
        cache = self.__dict__.get("_derived")
        if cache is None or cache[None] != id(self):  # none yet, or the dict of the system copied from
            cache = self.__dict__["_derived"] = {None: id(self)}  # (entries are checked by their deps anyway)
        hit = cache.get(name)
        if hit is not None:
            for d, o in zip(deps, hit[0]):
                if getattr(self, d) is not o or not _immutable(o):
                    break
            else:
                return hit[1]
        objs = tuple(getattr(self, d) for d in deps)
        for o in objs:
            if not _immutable(o):
                return compute()
        value = compute()
        cache[name] = (objs, value)
        return value

    def dense(self, name):
        A = getattr(self, name)
        return A.toarray() if sp.issparse(A) else np.asarray(A)

    def forcing(self, t, omega, dofs=None):
        """External force ``f_ex(t)``, shape ``(len(t), n)`` (``(len(t), len(dofs))`` for given ``dofs``).

        Only the requested DOFs are evaluated: MS-HBM needs the force on its few time-stepped
        DOFs, and all ``n`` columns would be ``N n`` numbers (3 GB at ``n = 1e5``, 4096 steps).
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        fh = self.f_hat_at(omega)
        fh = fh if dofs is None else fh[:, np.asarray(dofs, dtype=np.int64)]
        f = np.tile(fh[0], (t.size, 1))
        for k in range(1, self.n_forcing_harmonics + 1):
            f += np.cos(k * omega * t)[:, None] * fh[2 * k - 1]
            f += np.sin(k * omega * t)[:, None] * fh[2 * k]
        return f

    def forcing_hat(self, n_h, omega=None):
        """Forcing coefficients truncated or zero-padded to ``n_h`` harmonics, shape (2 n_h + 1, n), at
        ``omega`` (rad/s; needed only by an omega-dependent forcing, else ``f_hat`` of a tuned system)."""
        if omega is None:
            if self.forcing_parts and self.forcing_omega is None:
                raise ValueError("forcing_hat: the forcing depends on omega; pass omega or tune the system "
                                 "(System.at)")
            fh = self.f_hat
        else:
            fh = self.f_hat_at(omega)
        out = np.zeros((2 * n_h + 1, self.n))
        m = min(out.shape[0], fh.shape[0])
        out[:m] = fh[:m]
        return out

    def with_elements(self, elements):
        """Copy of the system with other elements (matrices are shared)."""
        new = object.__new__(System)
        new.__dict__.update(self.__dict__)
        new.elements = tuple(elements)
        return new

    def __repr__(self):
        els = ", ".join(f"{e.kind}@{e.dof}" + ("" if e.relative_to is None else f"-{e.relative_to}")
                        for e in self.elements) or "linear"
        return f"System({self.name!r}, n={self.n}, {els}, sparse={self.is_sparse})"


def tuned(system, omega):
    """``system.at(omega)`` for a :class:`System` with an omega-dependent forcing and a finite ``omega > 0``;
    anything else unchanged (the input checks downstream name a bad system or frequency)."""
    if not isinstance(system, System) or not system.forcing_parts or isinstance(omega, bool):
        return system
    try:
        w = float(omega)
    except (TypeError, ValueError):
        return system
    return system.at(w) if np.isfinite(w) and w > 0 else system


def _immutable(obj):
    if isinstance(obj, np.ndarray):
        return not obj.flags.writeable
    return isinstance(obj, tuple)


def _per_spring(key, value, n, *, positive):
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = list(value)
        if len(arr) != n:
            raise InputError(key, f"needs {n} entries (one per spring), got {len(arr)}")
    else:
        arr = [value] * n
    return np.array([_finite_number(f"{key}[{i}]", v, positive=positive, nonnegative=True)
                     for i, v in enumerate(arr)])


def chain(masses, stiffness, damping=0.0, forcing=(), elements=(), sparse=None, name="chain"):
    """Wall-spring-mass chain (Fig. 1 extended to ``n`` masses).

    Spring ``i`` (and the damper parallel to it) joins mass ``i-1`` to mass
    ``i``; spring 0 joins mass 0 to the wall; the last mass has a free end.

    Parameters
    ----------
    masses : sequence of float, length n
        Masses (kg), each ``> 0``.
    stiffness, damping : float or sequence of float (length n)
        Spring stiffnesses (N/m, ``>= 0``) and damper coefficients (Ns/m, ``>= 0``).
    forcing : sequence of dict
        Items ``{"dof": i, "amplitude": a, "sin": b, "harmonic": k, "constant": c}``:
        ``a cos(k omega t) + b sin(k omega t) + c`` on DOF ``i`` (``k`` defaults to 1).
    elements : sequence of Friction or Contact
    sparse : bool or None
        Store ``M, C, K`` as CSR matrices; default: when ``n > 200``.

    Returns
    -------
    System
    """
    if isinstance(masses, (int, float)) or not hasattr(masses, "__len__"):
        raise InputError("masses", "must be a list with one mass per DOF")
    n = len(masses)
    if n < 1:
        raise InputError("masses", "needs at least one mass")
    m = np.array([_finite_number(f"masses[{i}]", v, positive=True) for i, v in enumerate(masses)])
    k = _per_spring("stiffness", stiffness, n, positive=False)
    c = _per_spring("damping", damping, n, positive=False)

    def tridiag(s):
        main = s.copy()
        main[:-1] += s[1:]
        off = -s[1:]
        return sp.diags([off, main, off], [-1, 0, 1], shape=(n, n), format="csr")

    M = sp.diags(m, 0, format="csr")
    with np.errstate(over="ignore"):  # sums beyond the float range become inf: System names the matrix
        K, C = tridiag(k), tridiag(c)
    if sparse is None:
        sparse = n > 200
    if not sparse:
        M, C, K = M.toarray(), C.toarray(), K.toarray()

    n_f = 1
    items = list(forcing)
    for j, item in enumerate(items):
        if not isinstance(item, dict):
            raise InputError(f"forcing[{j}]", "must be a mapping with keys dof, amplitude")
        h = item.get("harmonic", 1)
        if isinstance(h, bool) or not isinstance(h, (int, np.integer)) or not 1 <= h <= 2000:
            raise InputError(f"forcing[{j}].harmonic", f"must be an integer in 1..2000, got {h!r}")
        n_f = max(n_f, int(h))
    f_hat = np.zeros((2 * n_f + 1, n))
    allowed = {"dof", "amplitude", "sin", "harmonic", "constant"}
    for j, item in enumerate(items):
        unknown = set(item) - allowed
        if unknown:
            raise InputError(f"forcing[{j}].{sorted(unknown)[0]}", f"unknown key (allowed: {', '.join(sorted(allowed))})")
        if "dof" not in item:
            raise InputError(f"forcing[{j}].dof", "missing")
        d = _dof(f"forcing[{j}].dof", item["dof"])
        if not 0 <= d < n:
            raise InputError(f"forcing[{j}].dof", f"DOF {d} out of range 0..{n - 1}")
        h = int(item.get("harmonic", 1))
        f_hat[2 * h - 1, d] += _finite_number(f"forcing[{j}].amplitude", item.get("amplitude", 0.0))
        f_hat[2 * h, d] += _finite_number(f"forcing[{j}].sin", item.get("sin", 0.0))
        f_hat[0, d] += _finite_number(f"forcing[{j}].constant", item.get("constant", 0.0))
    return System(M, C, K, f_hat, elements, name=name)
