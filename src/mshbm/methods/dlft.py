"""Dynamic Lagrangian frequency-time method (DLFT), set-valued laws without regularisation.

Nacivet, Pierre, Thouverez, Jezequel (2003), J. Sound Vib. 265, 201-219 (the paper's ref. [10]).

Unknowns and condensation
-------------------------
As in :mod:`mshbm.methods.hbm`: the Fourier coefficients ``X`` (eqs. 1-3) of the DOFs ``R``
kept (default: the element DOFs ``N``); the linear DOFs ``L`` are eliminated exactly per
harmonic (:class:`mshbm.condensation.Condensation`, ``condense=True``), or all DOFs are kept
(``condense=False``).  The harmonic balance of the kept DOFs is::

    R(X) = A X - r - F_nl(X) = 0,     A = H_RR - H_RL H_LL^-1 H_LR (per harmonic),

``r`` the (condensed) forcing and ``F_nl`` the Fourier coefficients of the element forces
``w_j lambda_j(t)`` (``w = +e_dof`` friction, ``-e_dof`` contact, :mod:`mshbm.system`).

The DLFT element force (prediction, correction)
-----------------------------------------------
The force the linear part demands of element ``j`` is ``lambda_L(t) = w^T IDFT[A X - r]``
(the contact force the harmonic balance needs).  DLFT adds a Lagrangian penalty-like term and
corrects the prediction in the time domain, on the ``N_s`` AFT samples:

* **Unilateral contact** (``g_N = gap - q_dof``): prediction
  ``lambda_pred(t_n) = lambda_L(t_n) - eps g_N(t_n)``; correction
  ``lambda_N = max(0, lambda_pred)`` (closed: ``lambda_N = lambda_pred``, open: 0).
* **Coulomb friction, velocity predictor** (``dlft_predictor="velocity"``, the default; slip
  velocity ``u = w q'`` of the series): prediction ``lambda_pred(t_n) = lambda_L(t_n) - eps_v u(t_n)``
  with ``eps_v = eps / (n_h omega)`` (N s/m); correction ``|lambda_pred| <= mu F_N``: stick,
  ``lambda = lambda_pred``; otherwise slip, ``lambda = mu F_N sign(lambda_pred)``.  No memory, no
  march: every sample is corrected on its own.  A friction whose normal load comes from a contact
  (``normal_contact``, :class:`mshbm.elements.Friction`) has the per-sample bound
  ``mu (N_0 + lambda_N(t_n))`` with the contact's corrected force (the contacts are corrected first);
  while it slips on a closed sample, ``d lambda = sign(lambda) mu d lambda_N`` (velocity predictor only).
  A 3-D frictional contact (cone partners ``j, k``, :mod:`mshbm.elements.cone`; velocity predictor only) is
  predicted as a pair, ``y_T = (y_j, y_k)`` with one ``eps_v`` (the mean of the two), and projected onto the
  disk: stick ``lambda_T = y_T`` while ``||y_T|| <= mu F_N``, else ``lambda_T = mu F_N y_T / ||y_T||``, with
  ``d lambda_T = (mu F_N / ||y_T||) (I - d d^T) dy_T + d mu d lambda_N`` (``d = lambda_T / (mu F_N)``).
* **Coulomb friction, displacement predictor** (``dlft_predictor="displacement"``; slip
  displacement ``xi = w q``): the incremental stick prediction ``lambda_pred(t_n) = lambda(t_{n-1})
  + lambda_L(t_n) - lambda_L(t_{n-1}) - eps (xi(t_n) - xi(t_{n-1}))``, written with the Lagrangian
  slip displacement ``xi_r`` (the memory of the law) as ``lambda_L(t_n) - eps (xi(t_n) -
  xi_r(t_{n-1}))``; correction as above, and in slip ``xi_r`` such that ``lambda = lambda_L - eps
  (xi - xi_r)``.  The march runs twice over the period (the first pass builds the memory, started
  from ``xi_r = xi(0)``; the second is used), so the state at ``t = 0`` is the one left by the last
  slip of the period (:mod:`mshbm.methods.dlft_kernels`).

Then ``F_nl = DFT[w lambda]`` and, since ``DFT[IDFT[A X - r]] = A X - r``, the residual is
``R = w DFT[lambda_L - lambda]``.

Elements between two DOFs (``relative_to``; friction, contact, the 3-D cone pair): ``w = sign (e_I - e_J)``, the
demanded force weighs the linear residual of both DOFs (compliance weights per harmonic, so that ``lambda_L``
depends on the elements' relative displacements only) and the penalty rule takes the stiffness of the relative
coordinate; Jenkins elements (``tangential_stiffness``, 1-D and the 3-D Jenkins pair) are massless slider DOFs
appended to the structure, tied to it by the spring ``k_t`` and carrying rigid (ground) friction, whose
harmonics are balanced with the rest (:mod:`mshbm.methods.dlft_terms`; the solution reports the structure's DOFs,
``info["dlft_jenkins_sliders"]`` their number).  With only ground elements everything below is unchanged.

What a converged DLFT solution is, and why it depends on ``eps``
----------------------------------------------------------------
``R = 0`` says ``lambda_L = P[lambda]``: the harmonic balance holds with the time-domain force
``lambda`` (``P = IDFT DFT`` keeps the harmonics ``0..n_h`` of a sampled signal).  The law holds
*exactly* on every sample, not on the series but on a Lagrangian variable:
``xi_r = xi - (lambda_L - lambda) / eps`` (contact: ``g_r = g_N - (lambda_L - lambda) / eps``),
``u_r = u - (lambda_L - lambda) / eps_v``.  Closed contact is ``g_r = 0``, open ``lambda = 0``
and ``g_r >= 0``; friction stick is ``xi_r`` constant (``u_r = 0``), slip ``lambda = -mu F_N
sign(Delta xi_r)`` (``-mu F_N sign(u_r)``).  At a solution ``lambda_L - lambda = -(I - P)
lambda``, so::

    xi_r = xi + (I - P)[lambda] / eps,       u_r = u + (I - P)[lambda] / eps_v:

only the retained harmonics of the correction vanish.  In the time domain it is the Gibbs-like
remainder of ``lambda`` near each jump or kink of the force (slip reversal, stick onset, impact),
of the size of the jump over ``~ T / n_h``; this is why the converged solution depends on
``eps``, whatever the number of samples.  It cannot be tuned away: the series itself differs from
the exact orbit by ``-sum_{k > n_h} G_k lambda_k`` with the compliance ``G_k ~ -1 / (k omega)^2
M_dd`` of the unresolved, mass-like harmonics, which a positive ``1 / eps`` does not represent.
``eps`` is a tolerance: a true stick needs ``(I - P) lambda / eps`` to absorb the wiggles of the
truncated series (``eps`` not too large), and at a slip reversal the same compliance turns the
force over a finite time (``eps`` not too small).  As ``eps -> inf`` both predictors tend to the
sign law on the series itself, which cannot hold a stick.

The two friction predictors differ in *where* that transition sits.  Velocity: at a slip
reversal ``u ~ a t`` and ``lambda = lambda_L - eps_v u`` crosses the cone in ``|t| < b / (eps_v a)``
centred on the zero of ``u``: the force reverses on time, and the orbit hardly notices.
Displacement: the stick starts at the reversal and lasts until ``eps (xi - xi_r) ~ eps a t^2 / 2`` has
turned the force across the cone: the force reverses late by ``~ (b / (eps a))^(1/2)``, a lag of the
force that costs amplitude.  Its memory adds a second defect: after a stick onset the ringing series
slips once more, which moves ``xi_r`` and shifts the force of the whole stick phase; a larger ``eps``
shortens the lag and amplifies this.  Too coarse a grid adds a lag of up to a sample (with
``N_s = 2 n_h + 2`` there is no unresolved harmonic on the grid, hence no ``eps`` dependence, but that
lag); at the default samples (below) the grid's share is negligible.

Jacobian (analytic, exact on each region of fixed sample states): with ``y_n`` the part of the
prediction affine in ``X`` (contact and displacement friction ``y_n = lambda_L(t_n) - eps w
q(t_n)``; velocity friction ``y_n = lambda_L(t_n) - eps_v w q'(t_n)``), closed contact and
velocity stick ``d lambda_n = d y_n``; displacement stick ``d lambda_n = d y_n - d y_m`` with
``m`` the last slip sample (the memory); open and slip 0 (the bound is constant; only its sign
switches).

The DLFT parameter ``eps``
--------------------------
``eps`` (N/m) scales the Lagrangian prediction; the velocity predictor uses ``eps_v = eps /
(n_h omega)`` (N s/m).  Default, per element: ``eps = max_k |A_dd(k omega)|``, ``k = 0..n_h``,
the largest diagonal entry of the condensed dynamic stiffness at its DOF over the harmonics --
the stiffness at the resolution of the series (``~ (n_h omega)^2 M_dd``, so ``eps_v ~ n_h omega
M_dd``, the impedance there), which scales the tolerance with the wiggles of the truncated series
(:func:`default_penalty`).  If the rule gives 0, ``(n_h omega)^2 M_dd``.  Option ``dlft_penalty``: one ``eps`` (N/m, > 0) for all elements.

The velocity predictor depends less on ``eps`` than the displacement predictor, whose error is
erratic in both ``eps`` and ``n_h``; against Den Hartog's closed form and the exact orbit of the friction
chain the velocity predictor is the more accurate at every ``n_h`` tested, its error falling like
``1 / n_h`` (the workflow's DLFT benchmark, ``workflow/scripts/bench/bench_dlft.py``, and
``tests/unit/test_dlft.py`` measure both).

What DLFT represents for a gap (restitution)
-------------------------------------------
DLFT is a harmonic balance method: the displacement is a truncated Fourier series, so the
periodic solution has no velocity jumps and no impulses.  An impact of the exact flow appears
as a contact force spread over tens of AFT samples (closed samples per period:
``info["closed_samples"]``), acting on a smooth series that runs into the obstacle around them
by about the amplitude error (the gap is enforced on the Lagrangian displacement at the
samples, not on the truncated series).  The law has no restitution coefficient: ``e_N`` is not
used, and a contact with ``e_N < 1`` is a model substitution (by the elastic law DLFT converges to):
the certificate's ``model_substitution`` check (:mod:`mshbm.certificate.substitution`) estimates its
effect on the amplitudes from the exact orbits with both restitutions, and the message names it
(on ``x'' + 0.2 x' + x = cos 1.2 t`` with a stop at 0.2: 0.342 for ``e_N = 0``, 0.206 for ``e_N = 0.5``).  Against the exact ``e_N = 1`` orbit the DLFT contact force does almost no work over a period
(a nearly elastic, persistent soft contact over tens of samples); the amplitude lies *below* the exact
one, by an error that falls with ``n_h`` much as that of HBM with the penalty law, and the series
penetrates the obstacle by a part of the gap that falls likewise.

Newton on contacts: the DLFT contact residual is continuous and piecewise linear in ``X`` (affine
on each region of fixed closed samples), like HBM's penalty law, and damped Newton stalls on it
from the linear start.  :meth:`DLFTProblem.newton_fallback` then follows the solution branch
exactly from the linear response, all gaps offset by ``lambda`` from the first touch-down to
``lambda = 0`` (:func:`mshbm.solvers.newton.follow_pl_path`), and polishes by Newton.

The certificate gates the friction cone and the energy balance, and reports the penetration of
the truncated series without gating it.

Smooth forces (polynomial springs, :class:`mshbm.elements.Polynomial`, on a DOF or between two
DOFs) are no Lagrangian terms: their force is evaluated by AFT, ``F_s = DFT[f_s(IDFT X)]`` with
its exact Jacobian, and counted in the force the linear part demands of the set-valued elements,
``lambda_L = w^T IDFT[A X - r - F_s]``, so ``R = A X - r - F_s - F_nl``.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import condensation, fourier
from ..condensation import Condensation
from ..elements.cone import cone_pairs
from ..errors import InputError
from .base import HarmonicProblem
from .common import guess_parts
from .dlft_kernels import friction_march
from .dlft_path import ContactPath
from .dlft_terms import element_terms, relative_stiffness, slider_guess, with_sliders

__all__ = ["DLFTProblem", "default_penalty", "PREDICTORS"]

#: friction predictors: the Lagrangian on the relative velocity (default) or on the displacement increment
PREDICTORS = ("velocity", "displacement")


def default_penalty(A_dd, m_dd, omega):
    """Default DLFT parameter ``eps`` (N/m) of one element (see the module docstring).

    ``A_dd``: the diagonal entry of the condensed dynamic stiffness at the element DOF for the
    harmonics ``k = 0..n_h`` (complex, shape (n_h + 1,)).  ``eps = max_k |A_dd(k omega)|``; if that
    vanishes, ``(n_h omega)^2 M_dd``.
    """
    A_dd = np.abs(np.asarray(A_dd))
    eps = float(np.max(A_dd))
    if not np.isfinite(eps) or eps <= 0.0:
        eps = (max(1, A_dd.size - 1) * omega) ** 2 * m_dd
    return eps


class DLFTProblem(ContactPath, HarmonicProblem):
    """DLFT periodic problem (see the module docstring).

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
    dlft_penalty : float, optional
        ``eps`` (N/m) for every element; default: per element from the dynamic stiffness.
    dlft_predictor : {"velocity", "displacement"}
        Friction predictor: the Lagrangian on the slip velocity (default, ``eps_v = eps / (n_h
        omega)``) or on the slip-displacement increment (the marched memory).  Contacts always use
        the gap.
    """

    method = "dlft"
    lagrangian_contact = True  # declared representation (mshbm.methods.base)

    def __init__(self, system, omega, harmonics, steps, condense=True, partition=None, dlft_penalty=None,
                 dlft_predictor="velocity"):
        if dlft_predictor not in PREDICTORS:
            raise InputError("dlft_predictor", f"must be one of {', '.join(map(repr, PREDICTORS))}, got "
                                               f"{dlft_predictor!r}")
        self.predictor = dlft_predictor
        system = system.at(omega)  # the forcing at omega (a constant forcing: the same system)
        smooth = [j for j, el in enumerate(system.elements) if el.smooth]
        for el in system.elements:
            if el.smooth:
                continue
            if el.cone_partner is not None and dlft_predictor != "velocity":
                raise InputError("friction.cone_partner", "DLFT supports the 3-D frictional contact (cone partners) "
                                 "with dlft_predictor 'velocity' only")
            if el.normal_contact is not None and dlft_predictor != "velocity":
                raise InputError("friction.normal_contact", "DLFT supports friction with a normal load from a "
                                 "contact with dlft_predictor 'velocity' only")
        structure = system
        system, self._sliders = with_sliders(structure)
        if self._sliders and partition is not None:  # the sliders carry the friction: always kept
            partition = np.union1d(np.asarray(partition, dtype=np.int64), [z for _, z in self._sliders])
        Hs = self._setup_harmonic_balance(system, omega, harmonics, steps, condense, partition)
        nR, nc = self.nR, 2 * self.n_h + 1
        pos = {int(d): i for i, d in enumerate(self.keep)}
        # the penalty rule: diagonal of the dynamic stiffness condensed onto the element DOFs N
        nl, n = system.nonlinear_dofs, system.n
        if self.condense and np.array_equal(self.keep, nl):
            Hd = Hs
        else:
            c = Condensation(system, omega, self.n_h, nl, np.setdiff1d(np.arange(n), nl))
            sub_nl = lambda A: A.tocsr()[nl][:, nl].toarray() if sp.issparse(A) else np.asarray(A)[np.ix_(nl, nl)]
            Mn, Cn, Kn = sub_nl(system.M), sub_nl(system.C), sub_nl(system.K)
            Hd = np.array([condensation.dynamic_stiffness(Mn, Cn, Kn, k * omega) - c.T[k] for k in range(self.n_h + 1)])
        pn = {int(d): i for i, d in enumerate(nl)}
        Md = np.asarray(system.M.diagonal() if sp.issparse(system.M) else np.diag(system.M), dtype=float)
        if dlft_penalty is None:
            self.eps = np.array([default_penalty(*relative_stiffness(Hd, Md, pn, el), self.omega)
                                 for el in system.elements])
        else:
            self.eps = np.full(len(system.elements), float(dlft_penalty))
        # velocity predictor: eps_v = eps / (n_h omega) (N s/m), the impedance at the resolution of the series
        self.eps_v = self.eps / (self.n_h * self.omega)
        for j, k in cone_pairs(system.elements):  # one penalty per cone: the disk projection stays Euclidean
            self.eps_v[j] = self.eps_v[k] = 0.5 * (self.eps_v[j] + self.eps_v[k])
        self._cone_ny = {}  # cone pairs: ||y_T|| per sample of the last march (the slip Jacobian)
        # d/dt of the series on the samples, Vs Om = -(Om Vs^T)^T (Om is antisymmetric), O(N_s n_h)
        VsOm = -fourier.derivative(self.Vs.T, self.omega).T if any(map(self._velocity, system.elements)) else None
        self._el = element_terms(self, system, pos, VsOm)
        self._drop_smooth(smooth, pos, nc, nR)
        self._sys, self.system = system, structure  # harmonic balance of the system with sliders; the structure

    def _drop_smooth(self, smooth, pos, nc, nR):
        """Take the smooth elements out of the Lagrangian terms: ``self._smooth`` (elements, their
        columns among the kept DOFs), ``self._pos`` (element index -> position in ``self._el``)."""
        self._pos = {t.j: k for k, t in enumerate(self._el)}
        els = [self.system.elements[j] for j in smooth]
        self._smooth = None
        if els:
            used = sorted({pos[int(d)] for el in els for d in el.dofs})
            col = {c: i for i, c in enumerate(used)}
            local = [tuple(col[pos[int(d)]] for d in el.dofs) if el.relative else col[pos[int(el.dof)]]
                     for el in els]
            self._smooth = (smooth, els, np.array(used, dtype=np.int64), local)

    def _smooth_forces(self, x, jac=True):
        """``(F_s, blocks, lam)``: the smooth forces' coefficients on the unknowns (shape ``(n_x,)``), their
        Jacobian as ``{(i, k): (2 n_h + 1)^2 block}`` for the kept DOFs ``i, k`` (``d F_s,i / d X_k``), and
        the element forces on the samples ``(N_s, m_s)``; ``None`` without smooth elements."""
        if self._smooth is None:
            return None
        from ..elements import regularised_forces

        _, els, used, local = self._smooth
        nc, nR = 2 * self.n_h + 1, self.nR
        X = np.asarray(x, dtype=float).reshape(nc, nR)[:, used]
        q = self.Vs @ X
        lam, f, dfdq, _, off = regularised_forces(els, local, q, np.zeros_like(q), coupling=True)
        F = np.zeros((nc, nR))
        F[:, used] = self.E @ f
        blocks = {}
        if jac:
            terms = [(i, i, dfdq[:, i]) for i in range(used.size)] + [(i, k, d) for i, k, d, _ in off if d is not None]
            for i, k, d in terms:
                key = (int(used[i]), int(used[k]))
                B = self.E @ (d[:, None] * self.Vs)
                blocks[key] = blocks[key] + B if key in blocks else B
        return F.reshape(-1), blocks, lam

    def _smooth_extra(self, blocks, t):
        """``[(k, Y)]``: the derivative of the demanded force ``lambda_L`` of element term ``t`` through the smooth
        forces, ``Y = -sum_i c_i Vs d F_s,i / d X_k`` over its demand rows ``i`` (shape ``(N_s, 2 n_h + 1)``;
        a kept DOF ``k`` may appear more than once: the blocks add)."""
        nR, nc = self.nR, 2 * self.n_h + 1
        if t.D is not None:
            return [(k, -(self.Vs @ (t.D[:, np.arange(nc) * nR + i] @ B))) for (i, k), B in blocks.items()]
        first = {int(r[0]): c for r, c in zip(t.drows, t.dc)}
        return [(k, -first[i] * (self.Vs @ B)) for (i, k), B in blocks.items() if i in first]

    def _demand(self, t, v):
        """``lambda_L`` on the samples: the demand of term ``t`` from the linear residual ``v``, shape (N_s,)."""
        if t.D is not None:
            return self.Vs @ (t.D @ v)
        out = None
        for r, c in zip(t.drows, t.dc):
            y = c * (self.Vs @ v[r])
            out = y if out is None else out + y
        return out

    def _wq(self, t, x, derivative=False):
        """``w^T q`` (or ``w^T q'``) of term ``t`` on the samples, shape (N_s,)."""
        out = None
        for r, w in zip(t.rows, t.w):
            y = w * (self.Vs @ (self.Om @ x[r] if derivative else x[r]))
            out = y if out is None else out + y
        return out

    def _velocity(self, el):
        """True if element ``el`` uses the velocity predictor (friction with ``dlft_predictor="velocity"``)."""
        return el.bounded and not el.unilateral and self.predictor == "velocity"

    # ------------------------------------------------------------------ the problem interface
    def residual_scale(self, x=None):
        """Per-row scale of the residual, shape ``(n_x,)``: the force scale ``F`` (N) on every row."""
        from ..scaling import force_scale

        if "_F" not in self.__dict__:
            self._F = force_scale(self.system)
        return np.full(self.n_unknowns, self._F)

    def initial_guess(self, guess=None):
        q_hat, _, _ = guess_parts(guess, self.system, self.omega, self.n_h, states=False)
        if self._sliders:  # the sliders z = s + lambda / k_t from a solution's forces, else z = s (springs unloaded)
            q_hat = slider_guess(q_hat, self.system, self._sliders, guess, self.n_h)
        return q_hat[:, self.keep].reshape(-1)

    def _march(self, x, linear=None):
        """Per element: ``(lam (N_s,), state (N_s,), ref (N_s,))`` on the AFT samples.

        ``state``: 1 where the element carries its constraint force (friction stick, contact
        closed), 0 where it does not (slip, open).  ``ref`` (friction): the memory sample.
        """
        if linear is None:
            linear = self.A @ x - self.r
        out = [None] * len(self._el)
        # friction loaded by a contact last: its bound mu (N_0 + lambda_N) needs the contact's force
        order = sorted(range(len(self._el)), key=lambda k: self._el[k].el.normal_contact is not None)
        for k in order:
            t = self._el[k]
            el, j = t.el, t.j
            lamL = self._demand(t, linear)
            if self._velocity(el):
                if out[k] is not None:
                    continue  # the cone partner of an element done
                y = lamL - self.eps_v[j] * self._wq(t, x, derivative=True)
                b = el.bound_samples(self._element_columns(out)) if el.normal_contact is not None else float(el.bound)
                if el.cone_partner is not None:  # the disk: stick inside, else b y_T / ||y_T||
                    p = el.cone_partner
                    kp = self._pos[p]
                    lamL_p = self._demand(self._el[kp], linear)
                    y_p = lamL_p - self.eps_v[p] * self._wq(self._el[kp], x, derivative=True)
                    ny = np.hypot(y, y_p)
                    stick = ny <= b
                    f = np.where(stick, 1.0, b / np.where(stick, 1.0, ny))
                    self._cone_ny[j] = self._cone_ny[p] = ny
                    out[k] = (y * f, stick.astype(np.int8), None, lamL)
                    out[kp] = (y_p * f, stick.astype(np.int8), None, lamL_p)
                    continue
                stick = np.abs(y) <= b
                out[k] = (np.clip(y, -b, b), stick.astype(np.int8), None, lamL)
                continue
            y = lamL - self.eps[j] * self._wq(t, x)
            if el.unilateral:
                y = y - self.eps[j] * el.gap
                closed = y > 0.0
                out[k] = (np.where(closed, y, 0.0), closed.astype(np.int8), None, lamL)
            else:
                lam = np.empty(self.Ns)
                slip = np.empty(self.Ns, dtype=np.int8)
                ref = np.empty(self.Ns, dtype=np.int64)
                friction_march(y, float(el.bound), float(lamL[0] - y[0]), lam, slip, ref)
                out[k] = (lam, (1 - slip).astype(np.int8), ref, lamL)
        return out

    def _element_columns(self, out):
        """The forces of ``out`` (per position in ``self._el``) as columns of the system's elements, (N_s, m)."""
        lam = np.zeros((self.Ns, len(self.system.elements)))
        for k, o in enumerate(out):
            if o is not None:
                lam[:, self._el[k].j] = o[0]
        return lam

    def residual(self, x, jac=True):
        """``(R, J)`` with shapes ``(n_x,)`` and ``(n_x, n_x)`` (dense if condensed, else sparse)."""
        x = np.asarray(x, dtype=float)
        linear = self.A @ x - self.r
        smooth = self._smooth_forces(x, jac)
        if smooth is not None:
            linear = linear - smooth[0]
        R = linear.copy()
        marched = self._march(x, linear)
        for t, (lam, state, ref, lamL) in zip(self._el, marched):
            f = self.E @ lam
            for rows, w in zip(t.rows, t.w):
                R[rows] -= w * f
        if not jac:
            return R, None
        blocks = []
        nR, nc = self.nR, 2 * self.n_h + 1
        if smooth is not None:
            for (i, k), B in smooth[1].items():
                blocks.append((np.arange(nc) * nR + i, np.arange(nc) * nR + k, B))

        def add(t, cols, B):  # d (w lambda) / d x[cols] on the element's own rows, from d lambda's coefficients B
            for rows, w in zip(t.rows, t.w):
                blocks.append((rows, cols, w * B))

        for t, (lam, state, ref, lamL) in zip(self._el, marched):
            el, j, cols, Q = t.el, t.j, t.cols, t.Q
            act = np.flatnonzero(state)  # only stick/closed samples carry a derivative
            if smooth is not None and act.size:  # lambda_L through the smooth forces on this element's DOFs
                for k, Y in self._smooth_extra(smooth[1], t):
                    dY = Y[act].copy()
                    if ref is not None:
                        r = ref[act]
                        has = r >= 0
                        dY[has] -= Y[r[has]]
                    add(t, np.arange(nc) * nR + k, self.E[:, act] @ dY)
            dlam = Q[act]
            if ref is not None:  # friction stick: minus the derivative of the memory
                r = ref[act]
                mem = np.zeros((r.size, Q.shape[1]))
                has = r >= 0
                mem[has] = Q[r[has]]
                # no slip in the period: the memory is s0 = lambda_L(0) - y(0) = eps w^T q(0)
                if (~has).any():
                    d0 = np.zeros(Q.shape[1])
                    for s_i, w in zip(t.sel, t.w):
                        d0[s_i] = self.eps[j] * w * self.Vs[0]
                    mem[~has] = -d0
                dlam -= mem
            add(t, cols, self.E[:, act] @ dlam)
            direction = np.sign(lam)
            p = el.cone_partner
            if p is not None:  # disk slip: d lambda_T = (b / ||y_T||) (I - d d^T) dy_T + d db, d = lambda_T / b
                sl = np.flatnonzero(state == 0)
                lam_p = marched[self._pos[p]][0]
                bs = np.hypot(lam, lam_p)
                direction = lam / np.where(bs > 0, bs, 1.0)
                if sl.size:
                    tp = self._el[self._pos[p]]
                    d_j, d_p = direction[sl], lam_p[sl] / np.where(bs[sl] > 0, bs[sl], 1.0)
                    cfac = bs[sl] / self._cone_ny[j][sl]
                    add(t, cols, self.E[:, sl] @ ((cfac * (1.0 - d_j * d_j))[:, None] * Q[sl]))
                    add(t, tp.cols, self.E[:, sl] @ ((-cfac * d_j * d_p)[:, None] * tp.Q[sl]))
            c = el.normal_contact
            if c is not None:  # slip on a closed contact: d lambda_T = d mu d lambda_N (d = sign, or on the disk)
                c = self._pos[c]
                tc = self._el[c]
                sl = np.flatnonzero((state == 0) & (marched[c][1] == 1))
                if sl.size:
                    g = (el.mu * direction[sl])[:, None] * tc.Q[sl]
                    add(t, tc.cols, self.E[:, sl] @ g)
                    if smooth is not None:
                        for k, Y in self._smooth_extra(smooth[1], tc):
                            g = (el.mu * direction[sl])[:, None] * Y[sl]
                            add(t, np.arange(nc) * nR + k, self.E[:, sl] @ g)
        if sp.issparse(self.A):
            rr = [np.repeat(rows, cols.size) for rows, cols, _ in blocks]
            cc = [np.tile(cols, rows.size) for rows, cols, _ in blocks]
            vv = [B.ravel() for _, _, B in blocks]
            J = self.A - sp.csr_matrix((np.concatenate(vv), (np.concatenate(rr), np.concatenate(cc))),
                                       shape=self.A.shape)
        else:
            J = self.A.copy()
            for rows, cols, B in blocks:
                J[np.ix_(rows, cols)] -= B
        return R, J

    def partition(self):
        """The kept and condensed DOFs of the structure (with Jenkins sliders: the sliders are the kept unknowns
        and the structure's DOFs all condensed)."""
        from .base import Partition

        n = self.system.n
        return Partition(time=np.zeros(0, np.int64), harmonic=self.keep[self.keep < n].copy(),
                         condensed=self.elim[self.elim < n].copy())

    def element_states(self, x):
        """Per element, on the AFT samples ``t_n = n T / N_s``: ``(lambda, constrained)``.

        ``constrained`` is True on friction-stick / contact-closed samples.
        """
        x = np.asarray(x, dtype=float)
        linear = self.A @ x - self.r
        smooth = self._smooth_forces(x, jac=False)
        if smooth is not None:
            linear = linear - smooth[0]
        return [(lam, state.astype(bool)) for lam, state, _, _ in self._march(x, linear)]

    def full_coefficients(self, x, sliders=False):
        """``q_hat`` of all DOFs of the structure, shape (2 n_h + 1, n) (``sliders``: and the Jenkins sliders)."""
        X = np.asarray(x, dtype=float).reshape(2 * self.n_h + 1, self.nR)
        q_hat = np.zeros((2 * self.n_h + 1, self._sys.n))
        q_hat[:, self.keep] = X
        if self.elim.size:
            q_hat[:, self.elim] = fourier.from_complex(self.cond.recover(fourier.to_complex(X)))
        return q_hat if sliders else q_hat[:, :self.system.n]

    def solution_parts(self, x):
        x = np.asarray(x, dtype=float)
        q_hat = self.full_coefficients(x)
        T = 2 * np.pi / self.omega
        t = np.linspace(0.0, T, self.Ns + 1)
        linear = self.A @ x - self.r
        smooth = self._smooth_forces(x, jac=False)
        if smooth is not None:
            linear = linear - smooth[0]
        marched = self._march(x, linear)
        m = len(self.system.elements)
        lam = np.zeros((self.Ns + 1, m))
        lam[:-1] = self._element_columns(marched)
        if smooth is not None:
            lam[:-1, self._smooth[0]] = smooth[2]
        lam[-1] = lam[0]
        info = {"condensed": self.condense,  # partition, conditioning: typed fields of the solution
                "dlft_penalty": [None if el.smooth else float(e) for e, el in zip(self.eps, self.system.elements)],
                "dlft_predictor": self.predictor}
        if any(self._velocity(el) for el in self._sys.elements):
            info["dlft_velocity_penalty"] = [float(e) if self._velocity(el) else None
                                             for e, el in zip(self.eps_v, self._sys.elements)]
        if self._sliders:
            info["dlft_jenkins_sliders"] = len(self._sliders)
        fr = [j for j, el in enumerate(self.system.elements) if el.bounded]
        ct = [j for j, el in enumerate(self.system.elements) if el.unilateral]
        if fr:
            info["stick_samples"] = [int(marched[self._pos[j]][1].sum()) for j in fr]
        if ct:
            info["closed_samples"] = [int(marched[self._pos[j]][1].sum()) for j in ct]
        return dict(t=t, q_hat=q_hat, time_dofs=np.zeros(0, dtype=np.int64),
                    q_time=np.zeros((self.Ns + 1, 0)), u_time=np.zeros((self.Ns + 1, 0)),
                    lam=lam, impulses=None, harmonics=self.n_h, info=info)
