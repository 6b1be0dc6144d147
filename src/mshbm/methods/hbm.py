"""Harmonic balance with alternating frequency-time (HBM-AFT), regularised laws.

Unknowns: Fourier coefficients ``q_hat`` (eqs. 1-3).  Residual::

    R = H q_hat - f_ex_hat - FFT(f_nl(IFFT(q_hat), IFFT(Omega q_hat)))

with the block-diagonal dynamic stiffness ``H`` (eqs. 23-24) and ``N_s`` time
samples per period for the AFT.  Because the nonlinear forces act only on the
DOFs ``N``, the linear DOFs ``L`` are eliminated exactly per harmonic
(``condense=True``, default; the solution is that of full HBM, see
:class:`mshbm.condensation.Condensation`).  ``condense=False`` solves the full
(sparse) system instead.  The Jacobian is analytic.

Robust solution with penalty contact
------------------------------------
With penalty contacts only (eq. 45, any ``k_c``, ``d_c``), the AFT residual is
*exactly piecewise linear* in ``q_hat``: it is affine between the hyperplanes
``g_N(t_j) = 0`` of the ``N_s`` samples.  For stiff ``k_c`` the pieces are tiny
and the solution branch has turning points (the grazing bifurcation of the
impact oscillator), so damped Newton stalls at ``||R|| ~ O(1)`` from any start
that is not already in the right region.  :meth:`HBMProblem.newton_fallback`
(called by :func:`mshbm.solvers.newton.newton` when the line search fails) then traces
the solution curve exactly, segment by segment, through the folds
(:func:`mshbm.solvers.newton.follow_pl_path`):

1. a Newton homotopy ``R(q_hat) = (1 - t) R(q_hat_0)``, ``t: 0 -> 1``, from the
   given start (skipped when the start is the linear response);
2. a gap continuation: all gaps offset by ``lambda``, from ``lambda_0`` where
   the linear response just touches down to ``lambda = 0``.

The end point is polished by Newton on the unmodified residual, and success is
declared only by ``||R / s||_inf <= tol`` of the real problem (``s`` from
:meth:`HBMProblem.residual_scale`): no smoothing of the law is involved.

Quadrature of the penalty law (``penalty_quadrature``)
-----------------------------------------------------
``"samples"`` (default): eq. (45) at the ``N_s`` samples, as above (piecewise linear).  Its Jacobian
jumps by ``k_c h`` (``h = T / N_s``) whenever a sample enters or leaves the contact, which on a stiff,
short contact is as large as the structure's dynamic stiffness: along a frequency sweep the branch of
the sampled equations is a chain of kinks whose tangents turn by up to 90 degrees (measured on the
5-mass impact chain, ``k_c = 8000``, contact ~1 % of the period, ``n_H = 20``, ``N_s = 8192``), and
some kinks are genuine turning points of the sampled equations (``N_s = 512``, ``n_H = 9``: a fold at
0.531 rad/s that leads back to 0.39 rad/s).

``"linear"``: the contact force is integrated *exactly* on the piecewise-linear interpolant of the
gap between samples (:func:`hat_integrals`), against the hat functions of the samples, and the result
is mapped back to samples by the consistent (circulant 1-4-1) mass matrix of the hats, which the DFT
diagonalises (``E M^-1 = D^-1 E`` with ``D_k = (2 + cos(2 pi k / N_s)) / 3``).  While every sample of
a contact is closed it is exactly the sampled law; where the gap changes sign inside an interval the
force and its Jacobian are continuous in ``q_hat`` (the residual is C^1), so the branch is smooth and
the continuation's tangents are meaningful.  Ground and relative contacts with ``d_c = 0``.  The exact
piecewise-linear fallback above then traces the sampled equations and Newton polishes on these.
"""
from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import fourier
from . import hbm_kernels
from .base import HarmonicProblem
from .common import guess_parts
from ..elements import Contact, Friction, regularised_forces
from ..errors import InputError
from ..scaling import force_scale
from ..solvers.newton import NewtonResult, follow_pl_path, newton

__all__ = ["HBMProblem", "scaled_regularisation", "hat_integrals", "linear_quadrature_unsupported",
           "PENALTY_QUADRATURES"]

#: values of the option ``penalty_quadrature`` (module docstring)
PENALTY_QUADRATURES = ("samples", "linear")


#: placeholder Jacobian argument of the compiled kernel when only ``R`` is wanted
_NO_JAC = np.empty((0, 0, 0, 0))


def _fast_laws(elements, nl_cols, pos):
    """Arrays of :func:`hbm_kernels.aft_forces` for the elements, or ``None`` where the kernel does not
    apply (an element relative to a second DOF, with a history, or with a law of its own)."""
    cols = {int(c): i for i, c in enumerate(nl_cols)}
    rows = []
    for el in elements:
        law = type(el).regularised_law
        if el.relative_to is not None or el.history or el.normal_contact is not None:
            return None
        if law is Friction.regularised_law:
            rows.append((hbm_kernels.KIND_FRICTION, cols[pos[el.dof]], el.sign, el.bound * 2.0 / np.pi,
                         el.smoothing, 0.0))
        elif law is Contact.regularised_law:
            rows.append((hbm_kernels.KIND_CONTACT, cols[pos[el.dof]], el.sign, el.gap, el.penalty_stiffness,
                         el.penalty_damping))
        else:
            return None
    if not rows:
        return None
    kind, col, sign, p1, p2, p3 = zip(*rows)
    return (np.array(kind, np.int64), np.array(col, np.int64), np.array(sign, float), np.array(p1, float),
            np.array(p2, float), np.array(p3, float))


def hat_integrals(a, b):
    """Hat-weighted integrals of the penetration on one sample interval, and their derivatives.

    The gap is linear on the interval, ``g(tau) = a + (b - a) tau`` (``tau`` in ``[0, 1]``, ``a, b`` the
    gaps at its left and right sample, m).  Returns ``(I_L, I_R, dI_L/da, dI_L/db, dI_R/da, dI_R/db)``
    (arrays shaped like ``a``) with ``I_L = int_0^1 max(0, -g) (1 - tau) dtau`` and
    ``I_R = int_0^1 max(0, -g) tau dtau`` (m).  Closed forms: both samples closed,
    ``I_L = -(2a + b)/6``, ``I_R = -(a + 2b)/6``; ``a < 0 < b`` (``d = b - a``),
    ``I_R = -a^3 / (6 d^2)``, ``I_L = a^2 / (2 d) + a^3 / (6 d^2)``; ``a > 0 > b`` by symmetry; both
    open, 0.  The integrals are continuously differentiable in ``(a, b)`` (except at ``a = b = 0``).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    IL, IR = np.zeros_like(a), np.zeros_like(a)
    La, Lb, Ra, Rb = (np.zeros_like(a) for _ in range(4))
    m = (a <= 0.0) & (b <= 0.0)
    IL[m], IR[m] = -(2.0 * a[m] + b[m]) / 6.0, -(a[m] + 2.0 * b[m]) / 6.0
    La[m], Lb[m], Ra[m], Rb[m] = -1.0 / 3.0, -1.0 / 6.0, -1.0 / 6.0, -1.0 / 3.0
    m = (a < 0.0) & (b > 0.0)  # closed at the left end
    if m.any():
        IL[m], IR[m], La[m], Lb[m], Ra[m], Rb[m] = _one_end_closed(a[m], b[m])
    m = (a > 0.0) & (b < 0.0)  # closed at the right end: the mirror image (a <-> b, L <-> R)
    if m.any():
        IR[m], IL[m], Rb[m], Ra[m], Lb[m], La[m] = _one_end_closed(b[m], a[m])
    return IL, IR, La, Lb, Ra, Rb


def linear_quadrature_unsupported(elements):
    """Why ``penalty_quadrature="linear"`` cannot take these elements (one sentence), or ``None``: it needs
    contacts without penalty damping and no friction loaded by a contact."""
    for el in elements:
        if el.unilateral and el.penalty_damping != 0.0:
            return f"'linear' needs contacts without penalty damping (d_c = 0), got d_c = {el.penalty_damping:g}"
        if el.normal_contact is not None:
            return "'linear' does not support friction loaded by a contact (normal_contact)"
    return None


def hat_mass_dft(k, Ns):
    """``D_k = (2 + cos(2 pi k / N_s)) / 3``: the DFT at frequency index ``k`` (array) of the consistent mass
    matrix of the ``N_s`` periodic hat functions (circulant 1-4-1 / 6, in units of the sample spacing)."""
    return (2.0 + np.cos(2.0 * np.pi * k / Ns)) / 3.0


def _one_end_closed(c, o):
    """:func:`hat_integrals` on intervals closed at one end only (gap ``c < 0`` there, ``o > 0`` at the other):
    ``(I_c, I_o, dI_c/dc, dI_c/do, dI_o/dc, dI_o/do)``, ``I_c`` against the hat of the closed end."""
    d = o - c
    r, r2, r3 = c / d, (c / d) ** 2, (c / d) ** 3
    return (c * r / 2.0 + c * r2 / 6.0, -c * r2 / 6.0,
            r + r2 + r3 / 3.0, -r2 / 2.0 - r3 / 3.0, -r2 / 2.0 - r3 / 3.0, r3 / 3.0)


def scaled_regularisation(system, factor):
    """Copy of ``system`` whose HBM laws are ``factor`` times stiffer (``kappa``; ``k_c`` and ``d_c``:
    :meth:`mshbm.elements.Element.scaled`)."""
    return system.with_elements([el.scaled(factor) for el in system.elements])


class HBMProblem(HarmonicProblem):
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
    penalty_laws, solve_defaults = True, {"penalty_quadrature": "samples"}  # solve-route capabilities

    def __init__(self, system, omega, harmonics, steps, condense=True, partition=None, penalty_quadrature="samples"):
        if penalty_quadrature not in PENALTY_QUADRATURES:
            raise InputError("penalty_quadrature", f"must be one of {', '.join(PENALTY_QUADRATURES)}, "
                                                   f"got {penalty_quadrature!r}")
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
        self._fast = None if self._linear else _fast_laws(system.elements, self.nl_cols, pos)

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
        system, omega, n_h, steps, condense, partition, quad = self._args
        return [HBMProblem(scaled_regularisation(system, f), omega, n_h, steps, condense, partition, quad)
                for f in factors] + [self]

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
        if self._fast is not None:  # one compiled pass (mshbm.methods.hbm_kernels)
            nN = self.nl_cols.size
            every = nN == nR  # every kept DOF carries an element (the default condensation): no gather
            X = x.reshape(nc, nR)
            Xn = np.ascontiguousarray(X if every else X[:, self.nl_cols])
            Fn = np.empty((nc, nN))
            Jn = np.empty((nc, nN, nc, nN)) if jac else _NO_JAC
            hbm_kernels.aft_forces(Xn, self.Vs, self.VsOm, self.E, *self._fast, jac, Fn, Jn)
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

    # ------------------------------------------------------------------------------------------
    # exact piecewise-linear solution (penalty contact only)

    @property
    def piecewise_linear(self):
        """True if every element's regularised law is piecewise linear (penalty contact, eq. 45).

        The AFT residual is then piecewise affine in ``q_hat``: affine on each
        region where the set of closed samples ``{(t_j, contact): g_N(t_j) <= 0}``
        is fixed.  With ``d_c = 0`` it is also continuous, and the path following
        of :meth:`newton_fallback` is exact.  With ``d_c > 0`` eq. (45) jumps by
        ``d_c gamma_N`` where ``g_N`` changes sign, so the residual jumps too and an
        exact zero need not exist (measured: found for ``d_c <= 5``, not for
        ``d_c = 50`` on the 5-mass chain, ``k_c = 8000``).  Contacts relative to a second DOF are
        piecewise linear in the same way (on ``w^T q``).
        """
        els = self.system.elements
        return len(els) > 0 and all(el.piecewise_linear for el in els)

    def _contacts(self):
        """``[(i, element)]``: index ``i`` into ``nl_cols`` of each contact's DOF."""
        cols = {int(c): i for i, c in enumerate(self.nl_cols)}
        return [(cols[d if isinstance(d, (int, np.integer)) else d[0]], el)
                for el, d in zip(self.system.elements, self.local_dof) if el.unilateral]

    def _contact_directions(self):
        """``[[(i, w_i), ...]]`` per contact: indices ``i`` into ``nl_cols`` and entries of ``w``."""
        cols = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
        return [[(cols[int(d)], w) for d, w in el.direction] for _, el in self._contacts()]

    def _gaps(self, x, offset=0.0):
        """Sampled gaps ``g_N(t_j) + offset = gap + offset + w^T q(t_j)`` of the contacts, shape (N_s, n_contacts)."""
        q = self.Vs @ x.reshape(2 * self.n_h + 1, self.nR)[:, self.nl_cols]
        col = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
        return np.stack([el.gap + offset + el.local(q, col) for _, el in self._contacts()], axis=1)

    def _pl_jacobian(self, closed):
        """Jacobian of the residual on the region with closed samples ``closed`` (N_s, n_contacts)."""
        nc, nN = 2 * self.n_h + 1, self.nl_cols.size
        Jn = np.zeros((nc, nN, nc, nN))
        for j, ((i, el), wdir) in enumerate(zip(self._contacts(), self._contact_directions())):
            S = np.flatnonzero(closed[:, j])
            if not S.size:
                continue
            # closed: d f / d q = -k_c w w^T, d f / d u = -d_c w w^T
            block = self.E[:, S] @ (el.penalty_stiffness * self.Vs[S] + el.penalty_damping * self.VsOm[S])
            if el.relative_to is None:
                Jn[:, i, :, i] -= block
            else:
                for a, wa in wdir:
                    for b, wb in wdir:
                        Jn[:, a, :, b] -= (wa * wb) * block
        return self._jacobian(Jn)

    def _gap_derivative(self, closed):
        """``dR / d lambda`` when every gap is offset by ``lambda`` (region ``closed``)."""
        h = np.zeros((2 * self.n_h + 1, self.nR))
        for j, ((i, el), wdir) in enumerate(zip(self._contacts(), self._contact_directions())):
            S = np.flatnonzero(closed[:, j])
            if el.relative_to is None:
                h[:, self.nl_cols[i]] -= el.penalty_stiffness * self.E[:, S].sum(axis=1)
            else:  # R = ... - E w lambda, d lambda / d offset = -k_c on the closed samples
                for a, wa in wdir:
                    h[:, self.nl_cols[a]] += wa * el.penalty_stiffness * self.E[:, S].sum(axis=1)
        return h.reshape(-1)

    def _pl_crossing(self, x, dx, closed, offset, doffset):
        """First sample switch along ``x + s dx`` (gap offset ``offset + s doffset``).

        Returns ``(s, closed_after)``; ``s = inf`` if no sample switches.
        """
        g = self._gaps(x, offset)
        dq = self.Vs @ dx.reshape(2 * self.n_h + 1, self.nR)[:, self.nl_cols]
        col = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
        dg = np.stack([doffset - dq[:, i] if el.relative_to is None else doffset + el.local(dq, col)
                       for i, el in self._contacts()], axis=1)
        moving = np.where(closed, dg > 0.0, dg < 0.0)
        if not moving.any():
            return np.inf, closed
        s = np.full(g.shape, np.inf)
        s[moving] = np.maximum(-g[moving] / dg[moving], 0.0)  # clip: a sample rounded onto the wrong side
        smin = float(s.min())
        flip = moving & (s <= smin * (1.0 + 1e-12))  # simultaneous switches (ties)
        return smin, closed ^ flip

    def _linear_solution(self):
        return np.asarray(spla.spsolve(sp.csc_matrix(self.A), self.r) if sp.issparse(self.A)
                          else np.linalg.solve(self.A, self.r), dtype=float)

    def newton_homotopy_path(self, x0, max_segments=None):
        """Trace ``R(q_hat) = (1 - t) R(q_hat_0)`` exactly from ``t = 0`` (at ``x0``) to ``t = 1``.

        Only for :attr:`piecewise_linear` problems.  Returns a
        :class:`mshbm.solvers.newton.PathResult` (``x`` is the solution if ``success``).
        """
        x0 = np.asarray(x0, dtype=float)
        F0, _ = self.residual(x0, jac=False)
        closed0 = self._gaps(x0) <= 0.0
        return follow_pl_path(lambda x, t, c: (self._pl_jacobian(c), F0),
                              lambda x, t, dx, dt, c: self._pl_crossing(x, dx, c, 0.0, 0.0),
                              x0, 0.0, 1.0, closed0, max_segments=max_segments or self._max_segments())

    def gap_continuation_path(self, max_segments=None):
        """Trace the solution branch exactly while all gaps are offset by ``lambda``, down to ``lambda = 0``.

        Starts at the linear response (``lambda_0`` just above its first touch
        down, no sample closed) and follows the branch through its turning
        points.  Only for :attr:`piecewise_linear` problems.  Returns a
        :class:`mshbm.solvers.newton.PathResult`.
        """
        x_lin = self._linear_solution()
        g = self._gaps(x_lin)
        touch = float(-g.min())  # offset at which the first sample touches
        lam0 = touch + max(1e-9, 1e-6 * abs(touch))
        closed0 = np.zeros(g.shape, dtype=bool)
        return follow_pl_path(lambda x, lam, c: (self._pl_jacobian(c), self._gap_derivative(c)),
                              lambda x, lam, dx, dlam, c: self._pl_crossing(x, dx, c, lam, dlam),
                              x_lin, lam0, 0.0, closed0, direction=-1.0,
                              max_segments=max_segments or self._max_segments())

    def _max_segments(self):
        return 10 * self.Ns * len(self.system.elements) + 1000

    def newton_fallback(self, x0, failed=None, tol=1e-10, scale=None, max_iter=50, callback=None):
        """Second globalisation stage for penalty contact, called by :func:`mshbm.solvers.newton.newton`.

        For :attr:`piecewise_linear` problems, tries in turn (1) the exact Newton
        homotopy from ``x0`` (skipped when ``x0`` is the linear response) and
        (2) the exact gap continuation from the linear response
        (:meth:`newton_homotopy_path`, :meth:`gap_continuation_path`).  Each path
        end is polished by damped Newton on the unmodified residual.

        Parameters
        ----------
        x0 : ndarray
            Start of the failed Newton iteration.
        failed : NewtonResult, optional
            The failed result (unused; part of the hook's signature).
        tol, scale, max_iter, callback
            As in :func:`mshbm.solvers.newton.newton`; success means
            ``||R / s||_inf <= tol`` for the real problem (default scale
            :meth:`residual_scale`).

        Returns
        -------
        NewtonResult or None
            ``None`` when not applicable (smooth laws: friction).
        """
        if not self.piecewise_linear:
            return None
        from ..solvers.newton import _scale_function, scaled_norm

        x0 = np.asarray(x0, dtype=float)
        scale = _scale_function(self.residual, self.residual_scale if scale is None else scale)
        key = (x0.tobytes(), float(tol))
        cache = self.__dict__.setdefault("_fallback_cache", {})
        if key in cache:  # same start already tried (e.g. by a continuation driver)
            return replace(cache[key], history=list(cache[key].history), info=dict(cache[key].info))
        try:
            x_lin = self._linear_solution()
        except (np.linalg.LinAlgError, RuntimeError):
            return None
        routes = []
        if not np.allclose(x0, x_lin, rtol=1e-10, atol=1e-12 * max(1e-300, float(np.max(np.abs(x_lin), initial=0)))):
            routes.append(("Newton homotopy", lambda: self.newton_homotopy_path(x0)))
        routes.append(("gap continuation", self.gap_continuation_path))
        segs, nfev, hist, notes = 0, 0, [], []
        out = None
        for name, run in routes:
            path = run()
            segs += path.segments
            note = f"{name}: {path.message}"
            if path.success:
                pol = newton(self.residual, path.x, tol, max_iter, True, callback, scale)
                if not pol.success:  # end point off by rounding across a kink: short exact path from there
                    path2 = self.newton_homotopy_path(pol.x)
                    segs += path2.segments
                    if path2.success:
                        pol = newton(self.residual, path2.x, tol, max_iter, True, callback, scale)
                segs += pol.nit
                nfev += pol.nfev
                hist += pol.history
                if pol.success:
                    nclosed = (self._gaps(pol.x) <= 0.0).sum(axis=0)
                    info = {"fallback": name, "segments": segs, "folds": path.folds,
                            "closed_samples": [int(k) for k in nclosed]}
                    note = ""
                    if 0 < nclosed.min() < 4:  # measured: the HBM solution is then not unique (sample-level)
                        note = (f"; note: a contact is closed at only {int(nclosed.min())} of {self.Ns} AFT "
                                "samples: under-resolved, increase steps")
                    out = NewtonResult(pol.x, True, f"converged: scaled ||R||_inf = {pol.residual_norm:.2e} by exact "
                                       f"piecewise-linear {name} ({path.segments} segments, {path.folds} "
                                       f"folds) and {pol.nit} Newton iterations{note}", segs, nfev,
                                       pol.residual_norm, hist, info)
                    break
                note += f", but Newton polishing failed: {pol.message}"
            notes.append(note)
        if out is None:
            R, _ = self.residual(x0, jac=False)
            out = NewtonResult(x0, False, "exact piecewise-linear path following failed (" + "; ".join(notes) + ")",
                               segs, nfev, scaled_norm(R, scale(x0)), hist,
                               {"fallback": "failed", "segments": segs})
        cache[key] = replace(out, history=list(out.history), info=dict(out.info))
        return out

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
        contacts = self._contacts()
        if contacts:
            # AFT resolution of each contact: samples with g_N <= 0 (a few only: increase ``steps``);
            # g_N = gap + w^T q on the samples q above (as :meth:`_gaps`)
            col = {int(self.keep[c]): i for i, c in enumerate(self.nl_cols)}
            info["closed_samples"] = [int(np.count_nonzero(el.gap + el.local(q, col) <= 0.0)) for _, el in contacts]
        return dict(t=t, q_hat=q_hat, time_dofs=np.zeros(0, dtype=np.int64),
                    q_time=np.zeros((self.Ns + 1, 0)), u_time=np.zeros((self.Ns + 1, 0)),
                    lam=lam, impulses=None, harmonics=self.n_h, info=info)
