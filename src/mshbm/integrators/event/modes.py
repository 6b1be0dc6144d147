"""Mode catalogue of the event-driven flow: element statuses, the events they produce, and per mode the
linear vector field ``z' = A_mode z`` with its exact exponential over a sub-step.

A *mode* is one status per acting element (:data:`FREE`, :data:`SLIP_P`, :data:`SLIP_M`, :data:`STICK`,
:data:`CLOSED`; code ``sum_j st_j 5^j``).  With the constrained elements ``a`` and the slip forces
``f_s`` the reactions solve ``(W_a^T M^-1 W_a) lambda_a = -W_a^T M^-1 (f_ex - C u - K q + f_s)``, so every
mode is an autonomous linear system on the augmented state ``z = [q, u, oscillator, forcing states]``
(shape ``(D,)``).  :class:`ModeCatalogue` builds the modes when first met, their balanced sub-step and
Taylor length, and the structured products with the forcing states (:mod:`.structured`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ...errors import InputError
from .structured import _amul_sens, _emul_sens, _powers_state

__all__ = ["FREE", "SLIP_P", "SLIP_M", "STICK", "CLOSED", "MODE_NAMES", "MOREAU", "STALL_EVENTS", "RELEASE_STEPS",
           "MAX_COMBINATIONS", "MAX_DOFS", "MAX_SUBSTEPS", "EventError", "Event", "mode_code", "mode_tuple",
           "ModeCatalogue"]

FREE, SLIP_P, SLIP_M, STICK, CLOSED = 0, 1, 2, 3, 4
MODE_NAMES = {FREE: "free", SLIP_P: "slip+", SLIP_M: "slip-", STICK: "stick", CLOSED: "closed"}
#: mode code of the nodes and samples inside a Moreau-Jean segment
MOREAU = -1
#: this many identical transitions at one instant: no progress (chattering)
STALL_EVENTS = 50
#: a Moreau-Jean segment ends after this many steps without impulse at the contacts / status change
RELEASE_STEPS = 8
#: largest number of element-status combinations enumerated at one event
MAX_COMBINATIONS = 6561
#: largest (sub)system the dense event-driven flow accepts (matrix exponentials of size ~2n)
MAX_DOFS = 1000
#: most sub-steps per period of the event-search grid (``2 T ||D^-1 A_xx D||_1``, balanced, per mode: ~2 T
#: omega_max for light damping): stiffer subsystems (finite-element node DOFs, heavily damped by
#: stiffness-proportional damping) are refused with an error instead of running for hours
MAX_SUBSTEPS = 2 ** 16
#: the exponentials of a mode over its sub-step (and its Fourier weights) depend only on its matrix ``A``,
#: ``omega`` and the sub-step count: kept for that many modes (of at most ``SHARED_MAX_D`` states) across
#: flows, so that repeated solves of one problem (Newton restarts, benchmarks, continuation at one
#: frequency) compute them once; keyed by the exact bytes of ``A``
SHARED_MAX, SHARED_MAX_D = 32, 400
#: a state's Taylor powers (:meth:`ModeCatalogue.powers`) by the compiled loop up to this size of ``z`` (a few
#: microseconds instead of ``n_taylor`` NumPy products of some microseconds each); BLAS's products beyond
POWERS_LOOP_MAX_D = 48
_NO_INT, _NO_FLOAT = np.zeros(0, np.int64), np.zeros(0)
_SHARED = {}


class EventError(RuntimeError):
    """The event-driven simulation cannot continue (accumulation, too many events, time limit)."""


class _Switch(Exception):
    """Internal: switch to Moreau-Jean (accumulation or chattering)."""

    def __init__(self, reason, elements):
        super().__init__(reason)
        self.reason, self.elements = reason, elements


def mode_code(st):
    """Integer code of a mode (tuple of element statuses): ``sum_j st_j 5^j`` (one element: its status)."""
    return int(sum(s * 5 ** j for j, s in enumerate(st)))


def mode_tuple(code, m):
    """Inverse of :func:`mode_code` for ``m`` elements."""
    return tuple((int(code) // 5 ** j) % 5 for j in range(m))


def _poly(coef, s):
    """``sum_j coef[j] s^j`` (Horner)."""
    if isinstance(s, float) and getattr(coef, "ndim", 1) == 1:
        # one time (root finding calls this most): the same operations on floats, without numpy's 0-d arrays
        out = 0.0 + float(coef[-1])
        for c in coef[-2::-1].tolist():
            out = out * s + c
        return out
    out = np.zeros_like(np.asarray(s, dtype=float)) + coef[-1]
    for c in coef[-2::-1]:
        out = out * s + c
    return out


@dataclass
class Event:
    """One event.

    Attributes
    ----------
    t : float
        Time (s).
    kind : str
        ``"<old status>-><new status>"`` of the element, e.g. ``"slip+->stick"``; an impact on an open
        contact is ``"free->free"`` (bounce) or ``"free->closed"``.
    impulse : float
        Impact impulse ``P_N >= 0`` along ``w`` (Ns), else 0.
    velocity : float
        Relative velocity ``gamma = w^T u`` of the element before the event (m/s).
    element : int
        Index of the element in ``system.elements``.
    """

    t: float
    kind: str
    impulse: float = 0.0
    velocity: float = 0.0
    element: int = 0


class _Mode:
    __slots__ = ("st", "A", "Lam", "C", "CA", "ev", "h", "E", "n_taylor", "code", "shared", "Ey", "scale", "norm_xx")


class ModeCatalogue:
    """The modes of an :class:`~mshbm.integrators.event.flow.EventFlow` and the linear algebra on them (mixin:
    the flow sets ``n``, ``D``, ``m``, ``Rr``, ``base``, ``W``, ``MW``, ``Minv``, ``dof``, ``sign``, ``bound``,
    ``gap``, ``is_contact``, ``T``, ``omega``, ``min_substeps`` and the forcing-state layout)."""

    # ------------------------------------------------------------------ modes
    def mode(self, st):
        """The data of mode ``st`` (tuple of statuses, or its integer code); None if its constraints are
        dependent (singular ``W_a^T M^-1 W_a``)."""
        if not isinstance(st, tuple):
            st = mode_tuple(st, self.m)
        md = self._modes.get(st, 0)
        if md != 0:
            return md
        md = self._build(st)
        self._modes[st] = md
        return md

    def _build(self, st):
        n, D, i1 = self.n, self.D, self.i1
        R = self.Rr.copy()
        Lam = np.zeros((self.m, D))
        act = []
        for j, s in enumerate(st):
            if s in (SLIP_P, SLIP_M):
                lam0 = -self.bound[j] if s == SLIP_P else self.bound[j]
                R[:, i1] += self.W[:, j] * lam0
                Lam[j, i1] = lam0
            elif s in (STICK, CLOSED):
                act.append(j)
        A = self.base.copy()
        if act:
            Wa, MWa = self.W[:, act], self.MW[:, act]
            Del = Wa.T @ MWa
            if np.linalg.cond(Del) > 1e10:
                return None
            La = -np.linalg.solve(Del, MWa.T @ R)
            Lam[act] = La
            A[n:2 * n] = self.Minv @ R + MWa @ La
            A[n + self.dof[act]] = 0.0  # gamma' = 0 exactly on the constraints
        else:
            A[n:2 * n] = self.Minv @ R
        rows, ev = [], []
        for j, s in enumerate(st):
            d, sg = self.dof[j], self.sign[j]
            c = np.zeros(D)
            if s == SLIP_P or s == SLIP_M:
                c[n + d] = sg if s == SLIP_P else -sg
                rows.append(c)
                ev.append((j, "slip", 0))
            elif s == STICK:
                b = self.bound[j]
                rows.append(b * np.eye(D)[i1] - Lam[j])
                ev.append((j, "bound", 1))
                rows.append(b * np.eye(D)[i1] + Lam[j])
                ev.append((j, "bound", -1))
            elif s == FREE:
                c[i1], c[d] = self.gap[j], sg
                rows.append(c)
                ev.append((j, "gap", 0))
            else:  # CLOSED
                rows.append(Lam[j].copy())
                ev.append((j, "lift", 0))
        md = _Mode()
        md.st, md.A, md.Lam, md.code = st, A, Lam, mode_code(st)
        md.C = np.array(rows) if rows else np.zeros((0, D))
        md.CA = md.C @ A
        md.ev = ev
        # sub-step and Taylor length from the norms of the diagonally scaled (balanced) matrix
        # A_s = D^-1 A D, z = D z_s (_scaling; the docstring of _scaling says why the event search and the
        # series are as rigorous in z_s as the unscaled rule was in z)
        d = self._scaling(A)
        As = A * (d[None, :] / d[:, None])
        norm_xx = np.abs(As[:2 * n, :2 * n]).sum(axis=0).max()
        ns_f = max(float(self.min_substeps), math.ceil(2.0 * self.T * norm_xx))
        if ns_f > MAX_SUBSTEPS:  # a stiff subsystem: fail at once rather than step for hours
            raise EventError(f"the event-driven flow would need {ns_f:.3g} sub-steps per period (balanced "
                             f"||D^-1 A_xx D||_1 = {norm_xx:.3g} 1/s: stiff or heavily damped DOFs) > {MAX_SUBSTEPS}; "
                             "keep the stiff DOFs out of the time-integrated subsystem (the nodes of a fine mesh: "
                             "reduce the model onto its element DOFs, mshbm.reduction.method_reduction, which a case "
                             "file without reduce: does by itself), or use integrator='moreau'")
        ns = int(ns_f)
        md.h = self.T / ns
        md.scale, md.norm_xx = d, norm_xx
        key = (self.omega, ns, n, A.shape[0], A.tobytes())
        shared = _SHARED.get(key)
        if shared is None:
            shared = {"E": self._expm(md, md.h), "Eg": None, "G0": {}}
            if A.shape[0] <= SHARED_MAX_D:
                if len(_SHARED) >= SHARED_MAX:
                    _SHARED.pop(next(iter(_SHARED)))
                _SHARED[key] = shared
        md.E, md.shared = shared["E"], shared
        md.Ey = (np.cos(self._yw * md.h), np.sin(self._yw * md.h))  # rotation of the forcing states over h_s
        rho = np.abs(As).sum(axis=0).max() * md.h
        k, term = 1, rho
        while (term > 1e-18 or k < 8) and k < 400:
            k += 1
            term *= rho / k
        if not term <= 1e-18:
            raise EventError(f"the event-driven flow cannot integrate this system: ||D^-1 A D|| h = {rho:.3g} "
                             "(forcing far larger than M, K times the displacement scale)")
        md.n_taylor = k + 1
        return md

    def _scaling(self, A):
        """Diagonal scaling ``d`` (shape (D,), powers of 2) of the state, ``z = D z_s`` with ``D = diag(d)``,
        that makes ``A_s = D^-1 A D`` small in the 1-norm; the sub-step (``||A_s,xx||_1 h_s <= 1/2``) and the
        Taylor length (``||A_s||_1 h_s``) are taken from ``A_s``.

        Why.  ``||A_xx||_1`` of ``[[0, I], [-M^-1 K, -M^-1 C]]`` adds displacements (m) and velocities (m/s):
        a DOF with ``K/M = w^2`` contributes ``w^2``, so a body at ``20 omega_1`` asked for ``~(20 omega_1)^2 T``
        sub-steps per period although it moves through ~20 cycles.  Scaling ``q`` by ``~w`` (velocity units)
        gives ``||A_s,xx||_1 ~ w + ||M^-1 C||``: the sub-step then resolves the fastest motion (every
        eigenvalue satisfies ``|lambda| <= ||A_s||``, any induced norm of a similar matrix bounds it),
        ``~2 omega_max T`` sub-steps per period.  The ``(q, u)`` block is balanced by LAPACK's ``gebal``
        (``scipy.linalg.matrix_balance``, no permutation; kept only if it lowers the norm); the exosystem
        states (oscillator, forcing states: their rows are the exact rotations ``k omega``) get one common
        factor ``2^-j <= 1`` so that their columns in ``A_s`` (``M^-1 f``, accelerations) are not larger
        than ``||A_s,xx||_1``; the rotation entries are unchanged.

        Rigour.  Nothing the flow computes changes form: an event function is ``c^T z = (D c)^T z_s``, the
        state and its Taylor powers ``A^j z / j! = D A_s^j z_s / j!`` are the same numbers (formed in ``z``;
        ``d`` are powers of 2, and the rounding of ``A w`` is bounded row by row by ``|A| |w|``, the same in
        either coordinates).  The bounds the grid search relies on hold in ``z_s`` with ``||A_s||`` exactly
        as they held in ``z`` with ``||A||``: ``|d^k/ds^k c^T z(s)| <= ||D c||_inf ||A_s||_1^k ||z_s(s)||_1``
        and ``||z_s(s)||_1 <= e^{||A_s|| s} ||z_s(0)||_1``, so over a sub-step the event function and its
        derivative vary with the same Taylor ratios ``(||A_s,xx|| h_s)^k / k! <= 2^-k / k!`` as before (the
        sign-change test of ``c^T z`` at the grid points, the extremum test of ``c^T A z`` and Brent's
        method on the Taylor polynomial are unchanged); the series is truncated when its tail
        ``(||A_s|| h_s)^k / k! <= 1e-18`` relative to ``||z_s||_1``, the same criterion in the scaled norm.
        The exponentials are formed as ``D expm(A_s s) D^-1`` (:meth:`_expm`), better conditioned than
        ``expm(A s)`` of the unbalanced matrix."""
        n, D = self.n, self.D
        d = np.ones(D)
        Axx = A[:2 * n, :2 * n]
        nrm0 = np.abs(Axx).sum(axis=0).max()
        if nrm0 > 0.0:
            _, (sc, _) = sla.matrix_balance(Axx, permute=False, separate=True)
            sc = np.exp2(np.round(np.log2(sc)))  # powers of 2 (gebal's are; made sure)
            sc = sc / sc[n:].max()  # a common factor changes nothing: the largest velocity factor is 1
            Bs = Axx * (sc[None, :] / sc[:, None])
            if np.all(np.isfinite(Bs)) and np.abs(Bs).sum(axis=0).max() < nrm0:
                d[:2 * n] = sc
        nrm = np.abs(A[:2 * n, :2 * n] * (d[None, :2 * n] / d[:2 * n, None])).sum(axis=0).max()
        col = (np.abs(A[:2 * n, 2 * n:]) / d[:2 * n, None]).sum(axis=0).max() if D > 2 * n else 0.0
        if col > nrm > 0.0:
            d[2 * n:] = 2.0 ** math.floor(math.log2(nrm / col))
        return d

    def _expm(self, md, s):
        """``exp(A s)`` of mode ``md`` as ``D expm(A_s s) D^-1`` (:meth:`_scaling`), shape (D, D)."""
        d = md.scale
        return d[:, None] * sla.expm(md.A * (s * d[None, :] / d[:, None])) / d[None, :]

    def _expm_rows(self, md, ss):
        """The ``q`` rows of ``exp(A s)`` at the times ``ss`` within a sub-step (``0 <= s <= h_s``), shape
        ``(len(ss), n, D)``: ``D (sum_j (A_s s)^j / j!)[:n] D^-1`` with the ``n_taylor`` terms of the mode (the
        series of :meth:`propagate_matrix`, exact to rounding on a sub-step: ``||A_s||_1 h_s`` sets its length),
        one product of an ``n x D`` block per term instead of one :func:`scipy.linalg.expm` per time."""
        n, d = self.n, md.scale
        As = md.A * (d[None, :] / d[:, None])
        P = np.zeros((n, As.shape[0]))
        P[:, :n] = np.eye(n)
        terms = [P]
        for j in range(1, md.n_taylor):
            P = (P @ As) / j
            terms.append(P)
        Eg = np.tensordot(self.spow(np.asarray(ss, dtype=float), md.n_taylor), np.array(terms), axes=(1, 0))
        return Eg * (d[:n, None] / d[None, :])

    # ------------------------------------------------------------------ pieces
    def osc(self, t):
        """Oscillator part ``[1, cos(k omega t), sin(k omega t)]`` of ``z`` at time ``t``."""
        out = np.empty(1 + 2 * self.nf)
        out[0] = 1.0
        for k in range(1, self.nf + 1):
            out[2 * k - 1], out[2 * k] = math.cos(k * self.omega * t), math.sin(k * self.omega * t)
        return out

    def state(self, t, q, u):
        """Augmented state ``z`` at time ``t``, shape (D,)."""
        return np.concatenate([q, u, self.exo(t)])

    def basis_c(self, t):
        """``b(t) = [1, cos(omega t), sin(omega t), ...]`` of the coupling forcing, shape (2 n_c + 1,) or (k, 2 n_c + 1)."""
        t = np.asarray(t, dtype=float)
        out = np.empty(t.shape + (self.ncx,))
        if self.ncx:
            out[..., 0] = 1.0
            for k in range(1, self.nx + 1):
                out[..., 2 * k - 1], out[..., 2 * k] = np.cos(k * self.omega * t), np.sin(k * self.omega * t)
        return out

    def exo(self, t):
        """The exosystem part of ``z`` at time ``t``: the oscillator and the forcing states, shape (D - 2n,)."""
        if not self.ncx:
            return self.osc(t)
        Y = np.empty_like(self.Fc)
        Y[0] = self.Fc[0]
        if self.nx:
            c, s_ = np.cos(self._ck * t)[:, None], np.sin(self._ck * t)[:, None]
            a, b = self.Fc[1::2], self.Fc[2::2]
            Y[1::2], Y[2::2] = a * c + b * s_, -a * s_ + b * c
        return np.concatenate([self.osc(t), Y.reshape(-1)])

    def set_forcing(self, Fc):
        """Coefficients ``F_c`` (shape ``(2 n_c + 1, n)``) of the coupling force (``coupling_harmonics``)."""
        Fc = np.asarray(Fc, dtype=float)
        if Fc.shape != (self.ncx, self.n):
            raise InputError("coupling forcing", f"must have shape {(self.ncx, self.n)}, got {Fc.shape}")
        self.Fc = Fc.copy()
        fmax = max(np.abs(self.system.f_hat).max(), np.abs(Fc).max())
        kmax, mmax = self._kmax, self._mmax
        self.qref = max(fmax / kmax if kmax > 0 else fmax / (mmax * self.omega ** 2) if mmax > 0 else 0.0,
                        float(np.abs(self.gap).max()) if self.m else 0.0, 1e-300)

    def forcing_at(self, t):
        """External plus coupling force at times ``t``, shape (k, n)."""
        f = self.system.forcing(t, self.omega)
        if self.ncx:
            f = f + self.basis_c(t) @ self.Fc
        return f

    def jac_columns(self, which="state"):
        """Indices of ``z`` whose sensitivities ``Phi`` holds: ``"state"`` ``(q, u)``; ``"all"`` also the
        forcing states (``(q, u, y)``, ``y`` component-major: index ``k n + i``; from ``t0 = 0``:
        ``d / d F_c[k, i]``)."""
        cols = np.arange(2 * self.n)
        if which == "all" and self.ncx:
            cols = np.concatenate([cols, self.iy + np.arange(self.ncx * self.n)])
        return cols

    def powers(self, mode, z):
        """``W`` with ``W[:, j] = A^j z / j!`` so that ``z(s) = W @ s^j``.  For a state ``z`` (shape (D,)) with
        forcing states, their rows of ``A`` (rotations) are applied from their structure."""
        md = self.mode(mode) if not isinstance(mode, _Mode) else mode
        if self.ncx and z.ndim == 1:
            return _powers_state(md.A, np.ascontiguousarray(z, dtype=float), md.n_taylor, self.iy, self.n,
                                 self._yc, self._ys, self._yw)
        if z.ndim == 1 and z.shape[0] <= POWERS_LOOP_MAX_D:  # no forcing states: every row from the full A
            return _powers_state(md.A, np.ascontiguousarray(z, dtype=float), md.n_taylor, z.shape[0], self.n,
                                 _NO_INT, _NO_INT, _NO_FLOAT)
        W = np.empty((z.shape[0], md.n_taylor) + z.shape[1:])
        W[:, 0] = z
        for j in range(1, md.n_taylor):
            W[:, j] = (md.A @ W[:, j - 1]) / j
        return W

    @staticmethod
    def spow(s, n_taylor):
        s = np.asarray(s, dtype=float)
        return s[..., None] ** np.arange(n_taylor) if s.ndim else s ** np.arange(n_taylor)

    def propagate_matrix(self, md, P, s):
        """``exp(A s) P`` for ``0 <= s <= h_s`` (Taylor), ``P`` the sensitivities of :meth:`simulate`."""
        acc, term = P.copy(), P
        # without forcing states (whose columns can be far smaller than the others) the series stops early
        tiny = 1e-18 * float(np.max(np.abs(P), initial=0.0)) if not self.ncx else -1.0
        for j in range(1, md.n_taylor):
            term = self.amul(md, term, sens=True) * (s / j)
            acc += term
            # the terms fall off like (||A|| s)^j / j! once j > ||A|| s (<= 1/2 in the balanced norm): stop when
            # one is below rounding of the columns' size (short partial steps need few terms)
            if j >= 4 and float(np.max(np.abs(term), initial=0.0)) <= tiny:
                break
        return acc

    def amul(self, md, P, sens=False):
        """``A P`` for a matrix ``P`` of ``D`` rows; the rows of the forcing states (block rotations) are
        formed from their structure (with ``coupling_harmonics`` they are most of ``A``).  ``sens``: ``P`` has
        the structure of the sensitivities of :meth:`simulate` (:meth:`emul`), which ``A P`` keeps; only its
        nonzero entries are formed."""
        if not self.ncx:
            return md.A @ P
        if sens:
            return _amul_sens(md.A, P, self.iy, self.n, self._yc, self._ys, self._yw)
        dx = self.iy
        out = np.empty_like(P)
        out[:dx] = md.A[:dx] @ P
        Py = P[dx:]
        oy = out[dx:]
        oy[:self.n] = 0.0
        oy[self._yc] = self._yw[:, None] * Py[self._ys]
        oy[self._ys] = -self._yw[:, None] * Py[self._yc]
        return out

    def emul(self, md, P, sens=False):
        """``exp(A h_s) P`` over a full sub-step of mode ``md`` (structured in the forcing states).

        ``sens``: ``P`` is the sensitivity matrix ``Phi`` of :meth:`simulate` (columns :meth:`jac_columns`),
        updated in place: its oscillator rows are zero and its forcing-state rows are zero but in the 2 x 2
        rotation blocks of the pairs (and the diagonal of the constants) when it has the forcing-state
        columns (:meth:`_phi_rotation_entries`), so only those entries enter and are rotated: the cost is linear, not
        quadratic, in the number of forcing states."""
        if not self.ncx:
            return md.E @ P
        dx = self.iy
        if sens:  # in place: simulate's Phi is private to the run
            c, s_ = md.Ey
            _emul_sens(md.E, P, self.iy, self.n, self._yc, self._ys, c, s_)
            return P
        out = np.empty_like(P)
        out[:dx] = md.E[:dx] @ P
        Py = P[dx:]
        oy = out[dx:]
        c, s_ = np.cos(self._yw * md.h)[:, None], np.sin(self._yw * md.h)[:, None]
        oy[:self.n] = Py[:self.n]
        oy[self._yc] = c * Py[self._yc] + s_ * Py[self._ys]
        oy[self._ys] = -s_ * Py[self._yc] + c * Py[self._ys]
        return out

    def force(self, mode, z):
        """Element forces ``lambda`` (acting elements) in ``mode`` at state(s) ``z``: shape (m,) or (m, k)."""
        md = self.mode(mode) if not isinstance(mode, _Mode) else mode
        return md.Lam @ z

    def full_force(self, mode, z):
        """Forces of all ``system.elements`` (0 for the ones that never act), shape (m_all,) or (m_all, k)."""
        lam = self.force(mode, z)
        out = np.zeros((len(self.system.elements),) + lam.shape[1:])
        out[self.index] = lam
        return out

    def vscale(self, z):
        """Velocity scale ``max(||u||_inf, omega ||q||_inf)`` of a state."""
        n = self.n
        return max(np.abs(z[n:2 * n]).max(), self.omega * np.abs(z[:n]).max(), 1e-300)

    def qscale(self, z):
        return max(np.abs(z[:self.n]).max(), self.qref)

    def gaps(self, z):
        """``g_N = gap + w^T q`` of every acting element (friction: 0), shape (m,)."""
        return np.where(self.is_contact, self.gap + self.sign * z[self.dof], 0.0)

    def gammas(self, z):
        """``gamma = w^T u``, shape (m,)."""
        return self.sign * z[self.n + self.dof]
