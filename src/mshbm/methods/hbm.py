"""Harmonic balance with alternating frequency-time (HBM-AFT), regularised laws.

Unknowns: Fourier coefficients ``q_hat`` (eqs. 1-3).  Residual::

    R = H q_hat - f_ex_hat - FFT(f_nl(IFFT(q_hat), IFFT(Omega q_hat)))

with the block-diagonal dynamic stiffness ``H`` (eqs. 23-24) and ``N_s`` time
samples per period for the AFT.  Because the nonlinear forces act only on the
DOFs ``N``, the linear DOFs ``L`` are eliminated exactly per harmonic
(``condense=True``, default; the solution is that of full HBM, see
:class:`mshbm.condensation.Condensation`).  ``condense=False`` solves the full
(sparse) system instead.  The Jacobian is analytic.

Elements without an explicit ``smoothing`` (friction) or ``penalty_stiffness`` (contact) get them from the
problem's own scales when the problem is built (:mod:`mshbm.methods.hbm_regularisation`; the values used are
``info["regularisation"]`` of the solution), so that the same system in other units gives the same answer.

With penalty contacts only, Newton's failures are taken over by an exact piecewise-linear path follower
(:mod:`mshbm.methods.hbm_path`); the penalty law is evaluated at the AFT samples or integrated on the
linear interpolant of the gap (:mod:`mshbm.methods.hbm_quadrature`).

The penalty law (eq. 45) has no restitution coefficient: its own is that of the Kelvin-Voigt contact
(1 for ``d_c = 0``).  Where it differs from the contact's ``e_N`` the law is a model substitution, which
the certificate's ``model_substitution`` check (:mod:`mshbm.certificate.substitution`) estimates and the
message names.
"""
from __future__ import annotations

import copy
import functools

import numpy as np
import scipy.sparse as sp

from .. import fourier
from . import hbm_kernels
from .base import HarmonicProblem
from .common import guess_parts
from .hbm_path import PiecewiseLinearPaths
from .hbm_regularisation import resolve as resolve_regularisation
from .hbm_quadrature import PENALTY_QUADRATURES, hat_integrals, hat_mass_dft, linear_quadrature_unsupported
from ..elements import Contact, Friction, regularised_forces
from ..errors import InputError
from ..scaling import force_scale

__all__ = ["HBMProblem", "scaled_regularisation", "hat_integrals", "linear_quadrature_unsupported",
           "PENALTY_QUADRATURES"]

#: placeholder Jacobian argument of the compiled kernel when only ``R`` is wanted
_NO_JAC = np.empty((0, 0, 0, 0))


def _fast_laws(elements, nl_cols, pos):
    """Arrays of :func:`hbm_kernels.aft_forces` for the elements, or ``None`` where the kernel does not
    apply (an element relative to a second DOF, with a history, or with a law of its own)."""
    cols = {int(c): i for i, c in enumerate(nl_cols)}
    rows = []
    for el in elements:
        if el.relative_to is not None or el.history or el.normal_contact is not None or el.cone_partner is not None:
            return None
        row = _law_row(el, cols, pos)
        if row is None:
            return None
        rows.append(row)
    if not rows:
        return None
    kind, col, sign, p1, p2, p3 = zip(*rows)
    return (np.array(kind, np.int64), np.array(col, np.int64), np.array(sign, float), np.array(p1, float),
            np.array(p2, float), np.array(p3, float))


def _law_row(el, cols, pos):
    """The kernel's row ``(kind, column, sign, p1, p2, p3)`` of a single-DOF friction or contact element with the
    package's regularised law, else ``None``."""
    law = type(el).regularised_law
    if law is Friction.regularised_law:
        return hbm_kernels.KIND_FRICTION, cols[pos[el.dof]], el.sign, el.bound * 2.0 / np.pi, el.smoothing, 0.0
    if law is Contact.regularised_law:
        return (hbm_kernels.KIND_CONTACT, cols[pos[el.dof]], el.sign, el.gap, el.penalty_stiffness,
                el.penalty_damping)
    return None


def _loaded_laws(elements, nl_cols, pos):
    """Arrays of :func:`hbm_kernels.aft_forces_loaded` (those of :func:`_fast_laws` and ``load``) where a friction
    takes its normal load from a contact element (single-DOF elements, no history, no cone), else ``None``."""
    cols = {int(c): i for i, c in enumerate(nl_cols)}
    rows, load = [], []
    for el in elements:
        law = type(el).regularised_law
        if el.relative_to is not None or el.history or el.cone_partner is not None:
            return None
        if law is Friction.regularised_law and el.normal_contact is not None:
            c = el.normal_contact
            if not (0 <= c < len(elements) and type(elements[c]).regularised_law is Contact.regularised_law):
                return None
            rows.append((hbm_kernels.KIND_LOADED_FRICTION, cols[pos[el.dof]], el.sign, el.mu, el.smoothing,
                         el.normal_force))
            load.append(c)
            continue
        row = None if el.normal_contact is not None else _law_row(el, cols, pos)
        if row is None:
            return None
        rows.append(row)
        load.append(-1)
    if not any(c >= 0 for c in load):
        return None
    kind, col, sign, p1, p2, p3 = zip(*rows)
    return (np.array(kind, np.int64), np.array(col, np.int64), np.array(sign, float), np.array(p1, float),
            np.array(p2, float), np.array(p3, float), np.array(load, np.int64))


def _kernel_laws(linear, elements, nl_cols, pos):
    """``(fast, loaded)``: the arrays of the compiled kernel that applies (:func:`_fast_laws`, else
    :func:`_loaded_laws`), the other ``None``; both ``None`` for a linear problem or where neither applies."""
    if linear:
        return None, None
    fast = _fast_laws(elements, nl_cols, pos)
    return fast, (None if fast is not None else _loaded_laws(elements, nl_cols, pos))


def scaled_regularisation(system, factor):
    """Copy of ``system`` whose HBM laws are ``factor`` times stiffer (``kappa``; ``k_c`` and ``d_c``:
    :meth:`mshbm.elements.Element.scaled`)."""
    return system.with_elements([el.scaled(factor) for el in system.elements])


class HBMProblem(PiecewiseLinearPaths, HarmonicProblem):
    """HBM-AFT periodic problem.

    Parameters
    ----------
    system : System
    omega : float
    harmonics : int
        ``n_h``.
    steps : int
        AFT samples per period ``N_s`` (``> 2 n_h``).
    condense : bool
        Eliminate the linear DOFs exactly (default) or keep all DOFs.
    partition : array of int, optional
        DOFs kept with the nonlinear elements (default: the element DOFs).

    Residual scale
    --------------
    :meth:`residual_scale` gives Newton's per-row scale: every row is a balance of
    forces (condensed or not), measured against the force scale ``F`` of the problem
    (:func:`mshbm.scaling.force_scale` with ``k_c gap``), independent of the solution
    and of the guess.
    """

    method = "hbm"
    penalty_contact = True  # declared representation (mshbm.methods.base); penalty_quadrature: set per problem
    hysteresis_aft = True  # Jenkins forces by the period march of the samples (declared representation)
    penalty_laws, solve_defaults = True, {"penalty_quadrature": "samples"}  # solve-route capabilities

    def __init__(self, system, omega, harmonics, steps, condense=True, partition=None, penalty_quadrature="samples"):
        if penalty_quadrature not in PENALTY_QUADRATURES:
            raise InputError("penalty_quadrature", f"must be one of {', '.join(PENALTY_QUADRATURES)}, "
                                                   f"got {penalty_quadrature!r}")
        system = system.at(omega)  # the forcing at omega (a constant forcing: the same system)
        for el in system.elements:  # the return mapping marches with a constant bound
            if el.history and el.normal_contact is not None:
                raise InputError("friction.normal_contact", "HBM: elastic friction (tangential_stiffness, Jenkins) "
                                 "with a normal load from a contact is not supported (its return mapping has a "
                                 "constant bound); use shooting, mshbm or dlft")
        # the regularisations left to their defaults, from the problem's scales (mshbm.methods.hbm_regularisation)
        self.given_system = system
        system, self.regularisation = resolve_regularisation(system, float(omega))
        self._args = (system, omega, harmonics, steps, condense, partition, penalty_quadrature)
        self._setup_harmonic_balance(system, omega, harmonics, steps, condense, partition)
        pos = {int(d): i for i, d in enumerate(self.keep)}
        self.local_dof = [pos[el.dof] if el.relative_to is None else tuple(pos[d] for d in el.dofs)
                          for el in system.elements]
        self.nl_cols = np.array(sorted({pos[d] for el in system.elements for d in el.dofs}), dtype=np.int64)
        self.penalty_quadrature = penalty_quadrature
        # contacts integrated on the linear interpolant of the gap (module docstring), else all laws sampled
        self._linear = penalty_quadrature == "linear" and any(el.unilateral for el in system.elements)
        why = linear_quadrature_unsupported(system.elements) if self._linear else None
        if why:
            raise InputError("penalty_quadrature", why)
        self._fast, self._loaded = _kernel_laws(self._linear, system.elements, self.nl_cols, pos)
        self._kw = np.arange(1, self.n_h + 1) * float(self.omega)  # the harmonics' frequencies k omega (rad/s)

    def residual_scale(self, x=None):
        """Per-row scale of the residual, shape ``(n_x,)``: the force scale ``F`` (N) on every row."""
        s = self.__dict__.get("_scale")
        if s is None:  # independent of x: one read-only array for all iterates
            self._F = force_scale(self.system, penalty=True)
            s = self._scale = np.full(self.n_unknowns, self._F)
            s.flags.writeable = False
        return s

    def homotopy(self, factors=(1e-3, 1e-2, 3e-2, 0.1, 0.3)):
        """Problems with softened laws (``kappa`` and ``k_c, d_c`` times each factor), ending with ``self``.

        Used as a fallback when Newton fails from the given start: each
        solution starts the next, stiffer problem.
        """
        return [self.stiffened(f) for f in factors] + [self]

    def stiffened(self, factor):
        """The same problem with every regularisation ``factor`` times stiffer (``factor < 1``: softer; the
        homotopy, the regularisation estimate).  Shares the linear part (condensation, ``A``, the AFT
        matrices), which does not depend on the laws' parameters."""
        new = copy.copy(self)
        system = scaled_regularisation(self.system, factor)
        new.system, new._args = system, (system,) + self._args[1:]
        for k in ("_scale", "_F"):  # the force scale may include k_c gap (unforced systems)
            new.__dict__.pop(k, None)
        pos = {int(d): i for i, d in enumerate(self.keep)}
        new._fast, new._loaded = _kernel_laws(self._linear, system.elements, self.nl_cols, pos)
        return new

    def rebuilt(self, omega):
        """The same problem at another frequency, its default regularisations derived there again (so that
        ``dR/domega`` is that of the problems a frequency sweep builds)."""
        return type(self)(self.given_system, float(omega), **self.build_options)

    def initial_guess(self, guess=None):
        q_hat, _, _ = guess_parts(guess, self.system, self.omega, self.n_h, states=False)
        return q_hat[:, self.keep].reshape(-1)

    def _time(self, x):
        X = x.reshape(2 * self.n_h + 1, self.nR)
        Xn = X[:, self.nl_cols]
        return self.Vs @ Xn, self.VsOm @ Xn

    def residual(self, x, jac=True):
        """``(R, J)`` with shapes ``(n_x,)`` and ``(n_x, n_x)`` (dense if condensed, else sparse)."""
        nc, nR = 2 * self.n_h + 1, self.nR
        if self._fast is not None or self._loaded is not None:  # one compiled pass (mshbm.methods.hbm_kernels)
            nN = self.nl_cols.size
            every = nN == nR  # every kept DOF carries an element (the default condensation): no gather
            X = x.reshape(nc, nR)
            Xn = np.ascontiguousarray(X if every else X[:, self.nl_cols])
            Fn = np.empty((nc, nN))
            Jn = np.empty((nc, nN, nc, nN)) if jac else _NO_JAC
            if self._fast is not None:
                hbm_kernels.aft_forces(Xn, self.Vs, self.VsOm, self.E, *self._fast, jac, Fn, Jn, self._kw)
            else:  # frictions loaded by contacts
                hbm_kernels.aft_forces_loaded(Xn, self.Vs, self.VsOm, self.E, *self._loaded, jac, Fn, Jn, self._kw)
            R = self.A @ x - self.r
            if every:
                R -= Fn.reshape(-1)
            else:
                R.reshape(nc, nR)[:, self.nl_cols] -= Fn
            if not jac:
                return R, None
            if every and self.condense:  # A - Jn
                return R, self.A - Jn.reshape(nc * nN, nc * nN)
            return R, self._jacobian(Jn)
        q, u = self._time(x)
        nN = self.nl_cols.size
        R = self.A @ x - self.r
        Jn = np.zeros((nc, nN, nc, nN)) if jac else None
        sampled = self._sampled_elements
        if self._linear:
            Fc = self._linear_contact_terms(q, Jn)
            R.reshape(nc, nR)[:, self.nl_cols] -= Fc
            if not sampled:
                return (R, self._jacobian(Jn)) if jac else (R, None)
        els = [self.system.elements[j] for j in sampled]
        _, f, dfdq, dfdu, offdiag = regularised_forces(els, [self._ldof[j] for j in sampled], q, u, coupling=True,
                                                       basis=self.Vs)
        R.reshape(nc, nR)[:, self.nl_cols] -= self.E @ f
        if not jac:
            return R, None
        for i in range(nN):
            # d f / d q (penalty contact) and d f / d u (friction, contact damping): skip zero terms
            if dfdq[:, i].any():
                Jn[:, i, :, i] += (self.E * dfdq[:, i]) @ self.Vs
            if dfdu[:, i].any():
                Jn[:, i, :, i] += (self.E * dfdu[:, i]) @ self.VsOm
        for i, k, cq, cu in offdiag:  # relative elements: d f_i / d (q_k, u_k), i != k
            if cq is not None and cq.ndim == 2:  # history (Jenkins): d f_i(t_a) / d q_hat_k (through Vs)
                Jn[:, i, :, k] += self.E @ cq
            elif cq is not None and cq.any():
                Jn[:, i, :, k] += (self.E * cq) @ self.Vs
            if cu is not None and cu.any():
                Jn[:, i, :, k] += (self.E * cu) @ self.VsOm
        return R, self._jacobian(Jn)

    @functools.cached_property
    def _sampled_elements(self):
        """Indices of the elements whose law is evaluated at the samples (all but the contacts with
        ``penalty_quadrature="linear"``)."""
        return [j for j, el in enumerate(self.system.elements) if not (self._linear and el.unilateral)]

    @functools.cached_property
    def _hat_mass(self):
        """``D_k = (2 + cos(2 pi k / N_s)) / 3`` per coefficient row (``[0, c_1, s_1, ...]``): the DFT of the
        hats' consistent mass matrix (circulant 1-4-1 / 6)."""
        return hat_mass_dft(np.r_[0, np.repeat(np.arange(1, self.n_h + 1), 2)], self.Ns)

    def _linear_contact_forces(self, q):
        """Per contact: ``(b, db)`` with ``b`` (N_s,) the hat-weighted contact force ``k_c int max(0, -g) hat_s dt
        / h`` (N) on the linear interpolant of the sampled gaps and ``db`` its three diagonals
        ``d b_s / d g_{s-1}, d g_s, d g_{s+1}`` (N/m), shape (3, N_s)."""
        col = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
        out = []
        for _, el in self._contacts():
            g = el.gap + el.local(q, col)
            IL, IR, La, Lb, Ra, Rb = hat_integrals(g, np.roll(g, -1))  # interval s: [t_s, t_{s+1}]
            kc = el.penalty_stiffness
            b = kc * (np.roll(IR, 1) + IL)
            db = kc * np.stack([np.roll(Ra, 1), np.roll(Rb, 1) + La, Lb])
            out.append((b, db))
        return out

    def _linear_contact_terms(self, q, Jn=None):
        """Force coefficients ``(nc, n_N)`` of the contacts with the linear quadrature (module docstring), and
        with ``Jn`` (``nc x n_N x nc x n_N``) their Jacobian added into it (``d F / d Xn``)."""
        nc, nN = 2 * self.n_h + 1, self.nl_cols.size
        Et = self.E / self._hat_mass[:, None]
        F = np.zeros((nc, nN))
        for (b, db), wdir in zip(self._linear_contact_forces(q), self._contact_directions()):
            eb = Et @ b
            for a, wa in wdir:
                F[:, a] += wa * eb
            if Jn is None:
                continue
            act = np.flatnonzero(np.any(db != 0.0, axis=0))
            if not act.size:
                continue
            Vs = self.Vs
            B = (db[0, act, None] * Vs[(act - 1) % self.Ns] + db[1, act, None] * Vs[act]
                 + db[2, act, None] * Vs[(act + 1) % self.Ns])
            block = Et[:, act] @ B  # d (Et b) / d (coefficients of g)
            for a, wa in wdir:
                for c, wc in wdir:
                    Jn[:, a, :, c] += (wa * wc) * block
        return F

    @functools.cached_property
    def _ldof(self):
        """Column of the nonlinear-DOF samples each element acts on."""
        cols = {int(c): i for i, c in enumerate(self.nl_cols)}
        return [cols[d] if isinstance(d, (int, np.integer)) else tuple(cols[c] for c in d)
                for d in self.local_dof]

    @functools.cached_property
    def _nl_idx(self):
        """Rows/columns of the nonlinear DOFs' coefficients in the unknowns (harmonic-major)."""
        nc = 2 * self.n_h + 1
        return (np.arange(nc)[:, None] * self.nR + self.nl_cols[None, :]).reshape(-1)

    def _jacobian(self, Jn):
        """``A - P^T Jn P`` with ``Jn`` (nc, n_N, nc, n_N) acting on the nonlinear columns."""
        nc, nN = 2 * self.n_h + 1, self.nl_cols.size
        idx = self._nl_idx
        Jn = Jn.reshape(nc * nN, nc * nN)
        if self.condense:
            J = self.A.copy()
            if nN == self.nR:
                J -= Jn
            else:
                J[np.ix_(idx, idx)] -= Jn
        else:
            rr, cc = np.meshgrid(idx, idx, indexing="ij")
            J = self.A - sp.csr_matrix((Jn.ravel(), (rr.ravel(), cc.ravel())), shape=self.A.shape)
        return J

    def _element_forces(self, q, u):
        """Element forces ``lambda_j`` (N_s, m) at the samples ``q, u`` (N_s, n_N) of the nonlinear DOFs:
        the regularised laws (:func:`mshbm.elements.regularised_forces`; for the laws of the compiled
        kernel, :func:`_fast_laws`, the same formulas compiled: :func:`hbm_kernels.element_forces`)."""
        if self._linear:  # sampled laws, and for contacts the samples whose DFT the residual uses: M^-1 b
            lam = np.zeros((q.shape[0], len(self.system.elements)))
            sampled = self._sampled_elements
            if sampled:
                lam[:, sampled] = regularised_forces([self.system.elements[j] for j in sampled],
                                                     [self._ldof[j] for j in sampled], q, u, coupling=True)[0]
            Ns = q.shape[0]
            mh = hat_mass_dft(np.arange(Ns // 2 + 1), Ns)
            idx = [j for j, el in enumerate(self.system.elements) if el.unilateral]
            for j, (b, _) in zip(idx, self._linear_contact_forces(q)):
                lam[:, j] = np.fft.irfft(np.fft.rfft(b) / mh, Ns)
            return lam
        if self._fast is None:
            return regularised_forces(self.system.elements, self._ldof, q, u, coupling=True)[0]
        lam = np.empty((q.shape[0], self._fast[0].size))
        hbm_kernels.element_forces(q, u, *self._fast, lam)
        return lam

    def full_coefficients(self, x):
        """``q_hat`` of all DOFs, shape (2 n_h + 1, n)."""
        X = x.reshape(2 * self.n_h + 1, self.nR)
        q_hat = np.zeros((2 * self.n_h + 1, self.system.n))
        q_hat[:, self.keep] = X
        if self.elim.size:
            q_hat[:, self.elim] = fourier.from_complex(self.cond.recover(fourier.to_complex(X)))
        return q_hat

    def solution_parts(self, x):
        q_hat = self.full_coefficients(x)
        T = 2 * np.pi / self.omega
        t = np.arange(self.Ns + 1) * (T / self.Ns)  # np.linspace(0, T, Ns + 1), the same numbers
        t[-1] = T
        q, u = self._time(x)
        lam = np.empty((self.Ns + 1, len(self.system.elements)))
        lam[:-1] = self._element_forces(q, u)
        lam[-1] = lam[0]
        info = {"condensed": self.condense}  # partition, conditioning: typed fields of the solution
        info["regularisation"] = [dict(r) for r in self.regularisation]
        contacts = self._contacts()
        if contacts:
            # AFT resolution of each contact: samples with g_N <= 0 (a few only: increase ``steps``);
            # g_N = gap + w^T q on the samples q above (as :meth:`_gaps`)
            col = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
            info["closed_samples"] = [int(np.count_nonzero(el.gap + el.local(q, col) <= 0.0)) for _, el in contacts]
        return dict(t=t, q_hat=q_hat, time_dofs=np.zeros(0, dtype=np.int64),
                    q_time=np.zeros((self.Ns + 1, 0)), u_time=np.zeros((self.Ns + 1, 0)),
                    lam=lam, impulses=None, harmonics=self.n_h, info=info)
