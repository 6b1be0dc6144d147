"""Imposed harmonic motion of chosen DOFs: base excitation (a support, a shaker table).

Notation: the structure ``M q'' + C q' + K q = f_ex(t) + f_nl`` of ``n`` DOFs is split into the base
DOFs ``b`` (``n_b`` of them), whose motion is imposed,

    x_b(t) = X0 + sum_k Xc_k cos(k omega t) + Xs_k sin(k omega t)    (``X_hat``, shape (2 n_x + 1, n_b), m)

and the free DOFs ``f`` (``n_f = n - n_b``).  The base rows of the equations give the reactions and
are dropped; the free DOFs are solved in the coordinates ``z = q_f - R x_b`` (``R``, shape (n_f, n_b)):

    M_ff z'' + C_ff z' + K_ff z = f_f - M_e x_b'' - C_e x_b' - K_e x_b,
    M_e = M_ff R + M_fb,  C_e = C_ff R + C_fb,  K_e = K_ff R + K_fb,

so harmonic ``k`` of the force is ``f_k - (K_e - (k omega)^2 M_e) X_k - k omega C_e J X_k``
(``J X_k = (Xs_k, -Xc_k)`` the coefficients of ``x_b' / (k omega)``).  It depends on ``omega``: the
reduced :class:`~mshbm.system.System` carries it as ``F0 + omega F1 + omega^2 F2``
(:meth:`mshbm.system.System.with_omega_forcing`), which every method, the certificate (residual, energy
balance: the base's work is the work of this force on ``z``) and the frequency continuation (``dR/domega``)
evaluate at their frequency.

Frames (``frame``):

* ``"absolute"``: ``R = 0``, ``z = q_f``.  Elements act between free DOFs or between a free DOF and the
  fixed ground.
* ``"relative"``: ``R = -K_ff^-1 K_fb``, the quasi-static motion the base imposes on the free DOFs (for a
  structure held only by the base: its rigid-body motion with it, ``R = 1`` for one base DOF); ``z`` is
  the motion relative to it.  Elements act between a free DOF and a base DOF (a stop on the shaker table:
  the gap moves with the table), or between free DOFs, as long as the base motion does not enter their
  relative displacement (``R_i = e_b``, resp. ``R_i = R_j``, to 1e-9); ground elements are refused when
  ``R_i != 0``.
* ``"auto"`` (default): ``"relative"`` when an element involves a base DOF, else ``"absolute"``.

An element on a base DOF must name the free DOF as ``dof`` and the base DOF as ``relative_to`` (it acts on
``q_dof - x_b``); one between two base DOFs is refused.

Results: a solution's ``q_hat`` holds the coefficients of ``z``; :meth:`BaseMotion.absolute_hat` gives all
``n`` DOFs in absolute coordinates (the base rows are ``X_hat``) and :meth:`BaseMotion.relative_hat` the
motion relative to the base's quasi-static motion, ``q_f - R_qs x_b`` (``R_qs = -K_ff^-1 K_fb``; one
rigidly carried base DOF: ``q_f - x_b``), zero on the base rows.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import InputError
from .system import System

__all__ = ["BaseMotion", "base_excitation", "FRAMES"]

FRAMES = ("auto", "absolute", "relative")
#: largest ``|R_i - R_j|`` (relative to ``max(1, max|R|)``) for which an element's relative displacement is
#: taken to be free of the base motion
ELEMENT_RTOL = 1e-9


@dataclass(frozen=True)
class BaseMotion:
    """The imposed motion and the map between the solved coordinates ``z`` and the DOFs of the structure.

    ``dofs`` (n_b,), ``free`` (n_f,): base and free DOFs of the structure (0-based, ``n`` DOFs in all);
    ``X_hat`` (2 n_x + 1, n_b): the base motion's coefficients (m); ``R`` (n_f, n_b): ``z = q_f - R x_b``;
    ``R_qs`` (n_f, n_b): the quasi-static influence ``-K_ff^-1 K_fb`` of the relative coordinates;
    ``frame``: ``"absolute"`` or ``"relative"``."""

    dofs: np.ndarray
    free: np.ndarray
    X_hat: np.ndarray
    R: np.ndarray
    R_qs: np.ndarray
    frame: str
    n: int

    def base_hat(self, n_h):
        """``X_hat`` truncated or zero-padded to ``n_h`` harmonics, shape (2 n_h + 1, n_b)."""
        out = np.zeros((2 * n_h + 1, self.dofs.size))
        m = min(out.shape[0], self.X_hat.shape[0])
        out[:m] = self.X_hat[:m]
        return out

    def motion(self, t, omega):
        """``x_b(t)``, shape (len(t), n_b) (m)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        X = self.X_hat
        x = np.tile(X[0], (t.size, 1))
        for k in range(1, (X.shape[0] - 1) // 2 + 1):
            x += np.cos(k * omega * t)[:, None] * X[2 * k - 1] + np.sin(k * omega * t)[:, None] * X[2 * k]
        return x

    def absolute_hat(self, z_hat):
        """Coefficients of every DOF in absolute coordinates, shape (2 n_h + 1, n), from those of ``z``
        (2 n_h + 1, n_f): ``q_f = z + R x_b``, ``q_b = x_b`` (the base's harmonics above ``n_h`` dropped)."""
        z_hat = np.asarray(z_hat, dtype=float)
        X = self.base_hat((z_hat.shape[0] - 1) // 2)
        out = np.zeros((z_hat.shape[0], self.n))
        out[:, self.free] = z_hat + X @ self.R.T
        out[:, self.dofs] = X
        return out

    def relative_hat(self, z_hat):
        """Coefficients of the motion relative to the base, ``q_f - R_qs x_b`` on the free DOFs and 0 on the
        base DOFs, shape (2 n_h + 1, n)."""
        z_hat = np.asarray(z_hat, dtype=float)
        X = self.base_hat((z_hat.shape[0] - 1) // 2)
        out = np.zeros((z_hat.shape[0], self.n))
        out[:, self.free] = z_hat + X @ (self.R - self.R_qs).T
        return out

    def absolute_time(self, t, omega, z):
        """Displacements of every DOF in absolute coordinates at times ``t`` (shape (len(t), n)) from ``z``
        sampled there (shape (len(t), n_f))."""
        x = self.motion(t, omega)
        out = np.zeros((x.shape[0], self.n))
        out[:, self.free] = np.asarray(z, dtype=float) + x @ self.R.T
        out[:, self.dofs] = x
        return out

    def relative_time(self, t, omega, z):
        """Displacements relative to the base (``q_f - R_qs x_b``; 0 on the base DOFs) at times ``t``, shape
        (len(t), n)."""
        x = self.motion(t, omega)
        out = np.zeros((x.shape[0], self.n))
        out[:, self.free] = np.asarray(z, dtype=float) + x @ (self.R - self.R_qs).T
        return out

    def summary(self, sol):
        """JSON-ready outputs of a solution ``sol`` on the reduced system: the description, both coefficient
        sets and the amplitudes ``(max - min) / 2`` per DOF on the solution's time grid."""
        z = sol.displacement()
        qa, qr = self.absolute_time(sol.t, sol.omega, z), self.relative_time(sol.t, sol.omega, z)
        amp = lambda q: [float(a) for a in 0.5 * (q.max(axis=0) - q.min(axis=0))]
        return {**self.as_dict(), "q_hat_absolute": self.absolute_hat(sol.q_hat).tolist(),
                "q_hat_relative": self.relative_hat(sol.q_hat).tolist(),
                "amplitude_absolute": amp(qa), "amplitude_relative": amp(qr)}

    def as_dict(self):
        """JSON-ready description."""
        return {"dofs": [int(d) for d in self.dofs], "free": [int(d) for d in self.free], "frame": self.frame,
                "X_hat": self.X_hat.tolist()}


def _dense(A):
    return A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)


def _block(A, rows, cols):
    if sp.issparse(A):
        return sp.csr_matrix(A)[rows][:, cols]
    return np.asarray(A, dtype=float)[np.ix_(rows, cols)]


def _influence(K_ff, K_fb):
    """``-K_ff^-1 K_fb``, shape (n_f, n_b); InputError when ``K_ff`` is singular."""
    rhs = _dense(K_fb)
    try:
        if sp.issparse(K_ff):
            X = spla.splu(sp.csc_matrix(K_ff)).solve(rhs)
        else:
            X = np.linalg.solve(np.asarray(K_ff, dtype=float), rhs)
    except (RuntimeError, np.linalg.LinAlgError):
        raise InputError("base.dofs", "K of the free DOFs is singular: with the base DOFs held the structure "
                                      "has a rigid-body mode (add a spring to the base or the ground)") from None
    if not np.all(np.isfinite(X)):
        raise InputError("base.dofs", "K of the free DOFs is singular (non-finite influence of the base)")
    return -X


def _check_dofs(dofs, n):
    try:
        arr = [int(d) for d in np.atleast_1d(dofs)]
    except (TypeError, ValueError):
        raise InputError("base.dofs", f"must be a list of DOFs, got {dofs!r:.40}") from None
    if not arr:
        raise InputError("base.dofs", "needs at least one DOF")
    for i, (d, raw) in enumerate(zip(arr, np.atleast_1d(dofs))):
        if isinstance(raw, (bool, np.bool_)) or float(raw) != d or not 0 <= d < n:
            raise InputError(f"base.dofs[{i}]", f"must be a DOF in 0..{n - 1}, got {raw!r}")
    if len(set(arr)) != len(arr):
        raise InputError("base.dofs", f"repeats a DOF: {arr}")
    if len(arr) >= n:
        raise InputError("base.dofs", f"leaves no free DOF (the structure has {n})")
    return np.array(arr, dtype=np.int64)


def _map_elements(elements, dofs, free, R_full, frame):
    """The elements renumbered to the free DOFs (module docstring: what is supported)."""
    base = set(int(d) for d in dofs)
    pos = {int(d): i for i, d in enumerate(free)}
    scale = max(1.0, float(np.abs(R_full).max(initial=0.0)))
    out, seen = [], {}
    for el in elements:
        key = f"{el.kind}[{seen.get(el.kind, 0)}]"  # the index among the elements of its kind (case-file entries)
        seen[el.kind] = seen.get(el.kind, 0) + 1
        if int(el.dof) in base:
            other = "" if el.relative_to is None else f" relative_to {el.relative_to}"
            raise InputError(f"{key}.dof", f"DOF {el.dof} is a base DOF (its motion is imposed): an element on it "
                             "names the free DOF as dof and the base DOF as relative_to" + other)
        i = int(el.dof)
        infl = R_full[i] if el.relative_to is None else R_full[i] - R_full[int(el.relative_to)]
        if np.abs(infl).max(initial=0.0) > ELEMENT_RTOL * scale:
            where = "the fixed ground" if el.relative_to is None else f"DOF {el.relative_to}"
            raise InputError(f"{key}.relative_to" if el.relative_to is not None else f"{key}.dof",
                             f"the element between DOF {i} and {where} would see the base motion in the "
                             f"{frame} frame (influence {np.abs(infl).max():.3g}): supported are elements between "
                             "free DOFs or to the ground (absolute frame), and between a free DOF and a base DOF "
                             "on which it rides rigidly (relative frame)")
        if el.relative_to is not None and int(el.relative_to) in base:
            out.append(replace(el, dof=pos[i], relative_to=None))
        else:
            out.append(el.renumbered(pos))
    return out


def base_excitation(M, C, K, base_dofs, X_hat, f_hat=None, elements=(), frame="auto", name="system"):
    """The reduced :class:`~mshbm.system.System` on the free DOFs of a structure whose DOFs ``base_dofs``
    move as ``x_b(t)`` (module docstring).

    Parameters
    ----------
    M, C, K : array_like or sparse, shape (n, n)
        The whole structure, base DOFs included (kg, Ns/m, N/m).
    base_dofs : sequence of int
        The DOFs whose motion is imposed.
    X_hat : array_like, shape (2 n_x + 1, n_b) or (2 n_x + 1,) for one base DOF
        Coefficients ``[X0, Xc_1, Xs_1, ...]`` of the base motion (m), columns in the order of ``base_dofs``
        (``system.base`` keeps them in increasing DOF order).
    f_hat : array_like, shape (2 n_f + 1, n), optional
        Further forcing on the free DOFs (N); zero on the base DOFs.
    elements : sequence of Element
        Elements in the numbering of the whole structure (see the module docstring).
    frame : ``"auto"``, ``"absolute"`` or ``"relative"``

    Returns
    -------
    System
        On the free DOFs (numbered in increasing order of ``free``), forcing depending on ``omega``,
        ``system.base`` the :class:`BaseMotion`.
    """
    full = System(M, C, K, np.zeros((1, np.shape(M)[0])) if f_hat is None else f_hat, name=name)
    n = full.n
    given = _check_dofs(base_dofs, n)
    dofs = np.sort(given)
    keep = np.ones(n, dtype=bool)
    keep[dofs] = False
    free = np.flatnonzero(keep)
    X = np.array(X_hat, dtype=float) if not isinstance(X_hat, np.ndarray) else X_hat.astype(float)
    if X.ndim == 1 and dofs.size == 1:
        X = X.reshape(-1, 1)
    if X.ndim != 2 or X.shape[1] != dofs.size or X.shape[0] % 2 != 1:
        raise InputError("base.amplitude", f"X_hat must have shape (2*n_x+1, {dofs.size}), got {X.shape}")
    if not np.all(np.isfinite(X)):
        raise InputError("base.amplitude", "contains NaN or inf")
    X = X[:, np.argsort(given)]  # columns in the order of the sorted base DOFs
    fh = full.f_hat
    if np.any(fh[:, dofs] != 0):
        raise InputError("forcing", "a force on a base DOF has no effect (its motion is imposed): remove it")
    if frame not in FRAMES:
        raise InputError("base.frame", f"must be one of {', '.join(FRAMES)}, got {frame!r}")
    base = set(int(d) for d in dofs)
    if frame == "auto":
        frame = "relative" if any(int(d) in base for el in elements for d in el.dofs) else "absolute"
    K_ff, K_fb = _block(full.K, free, free), _block(full.K, free, dofs)
    R_qs = _influence(K_ff, K_fb)
    R = R_qs if frame == "relative" else np.zeros_like(R_qs)
    R_full = np.zeros((n, dofs.size))
    R_full[free] = R
    R_full[dofs] = np.eye(dofs.size)
    els = _map_elements(tuple(elements), dofs, free, R_full, frame)
    eff = {}
    for a in "MCK":
        A = getattr(full, a)
        eff[a] = _dense(_block(A, free, free) @ R) + _dense(_block(A, free, dofs))
    n_x = max((X.shape[0] - 1) // 2, (fh.shape[0] - 1) // 2)
    Xp = np.zeros((2 * n_x + 1, dofs.size))
    Xp[:X.shape[0]] = X
    F0 = np.zeros((2 * n_x + 1, free.size))
    F0[:fh.shape[0]] = fh[:, free]
    F0 -= Xp @ eff["K"].T
    F1, F2 = np.zeros_like(F0), np.zeros_like(F0)
    for k in range(1, n_x + 1):
        xc, xs = Xp[2 * k - 1], Xp[2 * k]
        F1[2 * k - 1] = -k * (eff["C"] @ xs)  # x_b' has cosine coefficient k omega xs, sine -k omega xc
        F1[2 * k] = k * (eff["C"] @ xc)
        F2[2 * k - 1] = k * k * (eff["M"] @ xc)  # x_b'' = -(k omega)^2 x_b
        F2[2 * k] = k * k * (eff["M"] @ xs)
    sub = System(_block(full.M, free, free), _block(full.C, free, free), K_ff, np.zeros((1, free.size)), els,
                 name=name)
    out = sub.with_omega_forcing(F0, F1, F2)
    for A in (R, R_qs, Xp):
        A.flags.writeable = False
    out.base = BaseMotion(dofs=dofs, free=free, X_hat=Xp, R=R, R_qs=R_qs, frame=frame, n=n)
    return out
