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

__all__ = ["DLFTProblem", "default_penalty", "PREDICTORS"]

#: friction predictors: the Lagrangian on the relative velocity (default) or on the displacement increment
PREDICTORS = ("velocity", "displacement")


def spla_solve(A, b):
    return spla.spsolve(sp.csc_matrix(A), b) if sp.issparse(A) else np.linalg.solve(A, b)


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


class DLFTProblem(HarmonicProblem):
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
        n = system.n
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
            if el.relative_to is not None or el.history:
                what = "relative_to" if el.relative_to is not None else "tangential_stiffness"
                raise InputError(f"{el.kind}.{what}", "DLFT supports ground friction and contact only (relative and "
                                 "elastic (Jenkins) elements: use shooting, mshbm or hbm)")
        dofs = [el.dof for el in system.elements if not el.smooth]
        if len(set(dofs)) != len(dofs):
            d = next(d for d in dofs if dofs.count(d) > 1)
            raise InputError("elements", f"DLFT needs one element per DOF (DOF {d} carries a friction and a "
                                         "contact element: the demanded force cannot be split between them)")
        Hs = self._setup_harmonic_balance(system, omega, harmonics, steps, condense, partition)
        nR, nc = self.nR, 2 * self.n_h + 1
        pos = {int(d): i for i, d in enumerate(self.keep)}
        # the penalty rule: diagonal of the dynamic stiffness condensed onto the element DOFs N
        nl = system.nonlinear_dofs
        if self.condense and np.array_equal(self.keep, nl):
            Hd = Hs
        else:
            c = Condensation(system, omega, self.n_h, nl, np.setdiff1d(np.arange(n), nl))
            sub_nl = lambda A: A.tocsr()[nl][:, nl].toarray() if sp.issparse(A) else np.asarray(A)[np.ix_(nl, nl)]
            Hd = np.array([condensation.dynamic_stiffness(sub_nl(system.M), sub_nl(system.C), sub_nl(system.K),
                                                          k * omega) - c.T[k] for k in range(self.n_h + 1)])
        pn = {int(d): i for i, d in enumerate(nl)}
        diag = {el.dof: Hd[:, pn[el.dof], pn[el.dof]] for el in system.elements}
        Md = np.asarray(system.M.diagonal() if sp.issparse(system.M) else np.diag(system.M), dtype=float)
        if dlft_penalty is None:
            self.eps = np.array([default_penalty(diag[el.dof], Md[el.dof], self.omega) for el in system.elements])
        else:
            self.eps = np.full(len(system.elements), float(dlft_penalty))
        # velocity predictor: eps_v = eps / (n_h omega) (N s/m), the impedance at the resolution of the series
        self.eps_v = self.eps / (self.n_h * self.omega)
        for j, k in cone_pairs(system.elements):  # one penalty per cone: the disk projection stays Euclidean
            self.eps_v[j] = self.eps_v[k] = 0.5 * (self.eps_v[j] + self.eps_v[k])
        self._cone_ny = {}  # cone pairs: ||y_T|| per sample of the last march (the slip Jacobian)
        # d/dt of the series on the samples, Vs Om = -(Om Vs^T)^T (Om is antisymmetric), O(N_s n_h)
        VsOm = -fourier.derivative(self.Vs.T, self.omega).T if any(map(self._velocity, system.elements)) else None
        # per element: rows of its DOF in the unknowns, the columns its demanded force depends on,
        # and Q = d y / d x on those columns (y = lambda_L - eps w q or lambda_L - eps_v w q', affine in x)
        self._el = []
        A = self.A
        for j, el in enumerate(system.elements):
            if el.smooth:
                continue
            i = pos[el.dof]
            rows = np.arange(nc) * nR + i
            Ai = A[rows].toarray() if sp.issparse(A) else A[rows]
            cols = np.flatnonzero(np.any(Ai != 0.0, axis=0) | np.isin(np.arange(A.shape[1]), rows))
            w = el.sign
            Q = w * (self.Vs @ Ai[:, cols])
            sel = np.searchsorted(cols, rows)
            if self._velocity(el):  # y = lambda_L - eps_v w u
                Q[:, sel] -= self.eps_v[j] * w * VsOm
            else:  # y = lambda_L - eps w q (contact: minus eps times the gap)
                Q[:, sel] -= self.eps[j] * w * self.Vs
            self._el.append((el, j, rows, cols, sel, w, Q))
        self._drop_smooth(smooth, pos, nc, nR)

    def _drop_smooth(self, smooth, pos, nc, nR):
        """Take the smooth elements out of the Lagrangian terms: ``self._smooth`` (elements, their
        columns among the kept DOFs), ``self._pos`` (element index -> position in ``self._el``)."""
        self._el = [e for e in self._el if not e[0].smooth]
        self._pos = {e[1]: k for k, e in enumerate(self._el)}
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

    def _smooth_extra(self, blocks, el_row, w):
        """``[(k, Y)]``: the derivative of the demanded force ``lambda_L`` of an element on kept DOF ``el_row``
        through the smooth forces, ``Y = -w Vs d F_s,el_row / d X_k`` (shape ``(N_s, 2 n_h + 1)``)."""
        return [(k, -w * (self.Vs @ B)) for (i, k), B in blocks.items() if i == el_row]

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
        order = sorted(range(len(self._el)), key=lambda k: self._el[k][0].normal_contact is not None)
        for k in order:
            el, j, rows, cols, sel, w, Q = self._el[k]
            lamL = w * (self.Vs @ linear[rows])
            if self._velocity(el):
                if out[k] is not None:
                    continue  # the cone partner of an element done
                y = lamL - self.eps_v[j] * (w * (self.Vs @ (self.Om @ x[rows])))
                b = el.bound_samples(self._element_columns(out)) if el.normal_contact is not None else float(el.bound)
                if el.cone_partner is not None:  # the disk: stick inside, else b y_T / ||y_T||
                    p = el.cone_partner
                    kp = self._pos[p]
                    _, _, rows_p, _, _, w_p, _ = self._el[kp]
                    lamL_p = w_p * (self.Vs @ linear[rows_p])
                    y_p = lamL_p - self.eps_v[p] * (w_p * (self.Vs @ (self.Om @ x[rows_p])))
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
            wq = w * (self.Vs @ x[rows])
            y = lamL - self.eps[j] * wq
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
                lam[:, self._el[k][1]] = o[0]
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
        for (el, j, rows, cols, sel, w, Q), (lam, state, ref, lamL) in zip(self._el, marched):
            R[rows] -= w * (self.E @ lam)
        if not jac:
            return R, None
        blocks = []
        nR, nc = self.nR, 2 * self.n_h + 1
        if smooth is not None:
            for (i, k), B in smooth[1].items():
                blocks.append((np.arange(nc) * nR + i, np.arange(nc) * nR + k, B))
        for (el, j, rows, cols, sel, w, Q), (lam, state, ref, lamL) in zip(self._el, marched):
            act = np.flatnonzero(state)  # only stick/closed samples carry a derivative
            if smooth is not None and act.size:  # lambda_L through the smooth forces on this element's DOF
                for k, Y in self._smooth_extra(smooth[1], int(rows[0]), w):
                    dY = Y[act].copy()
                    if ref is not None:
                        r = ref[act]
                        has = r >= 0
                        dY[has] -= Y[r[has]]
                    blocks.append((rows, np.arange(nc) * nR + k, w * (self.E[:, act] @ dY)))
            dlam = Q[act]
            if ref is not None:  # friction stick: minus the derivative of the memory
                r = ref[act]
                mem = np.zeros((r.size, Q.shape[1]))
                has = r >= 0
                mem[has] = Q[r[has]]
                # no slip in the period: the memory is s0 = lambda_L(0) - y(0) = eps w q(0)
                if (~has).any():
                    d0 = np.zeros(Q.shape[1])
                    d0[sel] = self.eps[j] * w * self.Vs[0]
                    mem[~has] = -d0
                dlam -= mem
            blocks.append((rows, cols, w * (self.E[:, act] @ dlam)))
            direction = np.sign(lam)
            p = el.cone_partner
            if p is not None:  # disk slip: d lambda_T = (b / ||y_T||) (I - d d^T) dy_T + d db, d = lambda_T / b
                sl = np.flatnonzero(state == 0)
                lam_p = marched[self._pos[p]][0]
                bs = np.hypot(lam, lam_p)
                direction = lam / np.where(bs > 0, bs, 1.0)
                if sl.size:
                    _, _, _, cols_p, _, _, Q_p = self._el[self._pos[p]]
                    d_j, d_p = direction[sl], lam_p[sl] / np.where(bs[sl] > 0, bs[sl], 1.0)
                    cfac = bs[sl] / self._cone_ny[j][sl]
                    blocks.append((rows, cols, w * (self.E[:, sl] @ ((cfac * (1.0 - d_j * d_j))[:, None] * Q[sl]))))
                    blocks.append((rows, cols_p, w * (self.E[:, sl] @ ((-cfac * d_j * d_p)[:, None] * Q_p[sl]))))
            c = el.normal_contact
            if c is not None:  # slip on a closed contact: d lambda_T = d mu d lambda_N (d = sign, or on the disk)
                c = self._pos[c]
                _, _, rows_c, cols_c, _, w_c, Q_c = self._el[c]
                sl = np.flatnonzero((state == 0) & (marched[c][1] == 1))
                if sl.size:
                    g = (el.mu * direction[sl])[:, None] * Q_c[sl]
                    blocks.append((rows, cols_c, w * (self.E[:, sl] @ g)))
                    if smooth is not None:
                        for k, Y in self._smooth_extra(smooth[1], int(rows_c[0]), w_c):
                            g = (el.mu * direction[sl])[:, None] * Y[sl]
                            blocks.append((rows, np.arange(nc) * nR + k, w * (self.E[:, sl] @ g)))
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

    # ------------------------------------------------------------------ contacts only: exact path following
    @property
    def piecewise_linear(self):
        """True if every element is a contact: ``lambda = max(0, y)`` with ``y`` affine in ``X``, so the
        residual is continuous and affine on each region of fixed closed samples (as HBM's penalty law)."""
        els = self.system.elements
        return len(els) > 0 and all(el.unilateral for el in els)

    def _y(self, x, offset=0.0):
        """Predictions ``y`` of the contacts with every gap offset by ``offset``, shape (N_s, m)."""
        linear = self.A @ x - self.r
        cols = []
        for el, j, rows, _, _, w, _ in self._el:
            cols.append(w * (self.Vs @ linear[rows]) - self.eps[j] * (w * (self.Vs @ x[rows]) + el.gap + offset))
        return np.stack(cols, axis=1)

    def _pl_residual_jac(self, closed):
        """``(dR/dx, dR/d offset)`` on the region ``closed`` (N_s, m)."""
        if sp.issparse(self.A):
            J = self.A.tolil(copy=True)
        else:
            J = self.A.copy()
        h = np.zeros(self.n_unknowns)
        for k, (el, j, rows, cols, _, w, Q) in enumerate(self._el):
            S = np.flatnonzero(closed[:, k])
            if S.size:
                B = w * (self.E[:, S] @ Q[S])
                if sp.issparse(self.A):
                    J[np.ix_(rows, cols)] = J[np.ix_(rows, cols)].toarray() - B
                else:
                    J[np.ix_(rows, cols)] -= B
                h[rows] += w * self.eps[j] * self.E[:, S].sum(axis=1)  # d lambda / d offset = -eps
        return (J.tocsr() if sp.issparse(self.A) else J), h

    def _pl_crossing(self, x, dx, closed, offset, doffset):
        y = self._y(x, offset)
        dy = self._y(dx, 0.0) - self._y(np.zeros_like(x), 0.0)  # linear part of y along dx
        for k, (_, j, *_rest) in enumerate(self._el):
            dy[:, k] -= self.eps[j] * doffset
        moving = np.where(closed, dy < 0.0, dy > 0.0)
        if not moving.any():
            return np.inf, closed
        sv = np.full(y.shape, np.inf)
        sv[moving] = np.maximum(-y[moving] / dy[moving], 0.0)
        smin = float(sv.min())
        return smin, closed ^ (moving & (sv <= smin * (1.0 + 1e-12)))

    def newton_fallback(self, x0, failed=None, tol=1e-10, scale=None, max_iter=50, callback=None):
        """Contacts only: exact piecewise-linear gap continuation from the linear response.

        All gaps are offset by ``lambda``, from just above the first touch-down of the linear response
        (no sample closed) down to ``lambda = 0``, through the turning points
        (:func:`mshbm.solvers.newton.follow_pl_path`); the end point is polished by Newton on the
        unmodified residual.  Hook of :func:`mshbm.solvers.newton.newton`; ``None`` for friction.
        """
        if not self.piecewise_linear:
            return None
        from ..solvers.newton import NewtonResult, _scale_function, follow_pl_path, newton, scaled_norm

        scale = _scale_function(self.residual, self.residual_scale if scale is None else scale)
        key = float(tol)
        cache = self.__dict__.setdefault("_fallback_cache", {})
        if key in cache:
            return cache[key]
        try:
            x_lin = np.asarray(spla_solve(self.A, self.r), dtype=float)
        except (np.linalg.LinAlgError, RuntimeError):
            return None
        y = self._y(x_lin)
        lam0 = float(np.max(y / self.eps[None, :]))  # offset at which the first sample touches
        lam0 += max(1e-9, 1e-6 * abs(lam0))
        closed0 = np.zeros(y.shape, dtype=bool)
        path = follow_pl_path(lambda x, lam, c: self._pl_residual_jac(c),
                              lambda x, lam, dx, dlam, c: self._pl_crossing(x, dx, c, lam, dlam),
                              x_lin, lam0, 0.0, closed0, direction=-1.0,
                              max_segments=10 * self.Ns * len(self.system.elements) + 1000)
        out = None
        if path.success:
            pol = newton(self.residual, path.x, tol, max_iter, True, callback, scale)
            if pol.success:
                out = NewtonResult(pol.x, True, f"converged: scaled ||R||_inf = {pol.residual_norm:.2e} by exact "
                                   f"piecewise-linear gap continuation ({path.segments} segments, {path.folds} "
                                   f"folds) and {pol.nit} Newton iterations", path.segments + pol.nit,
                                   pol.nfev, pol.residual_norm, pol.history,
                                   {"fallback": "gap continuation", "segments": path.segments, "folds": path.folds})
            note = "" if pol.success else f", but Newton polishing failed: {pol.message}"
        else:
            note = ""
        if out is None:
            R, _ = self.residual(np.asarray(x0, dtype=float), jac=False)
            out = NewtonResult(np.asarray(x0, dtype=float), False, f"exact piecewise-linear gap continuation failed "
                               f"({path.message}{note})", path.segments, 0, scaled_norm(R, scale(x0)), [],
                               {"fallback": "failed", "segments": path.segments})
        cache[key] = out
        return out

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

    def full_coefficients(self, x):
        """``q_hat`` of all DOFs, shape (2 n_h + 1, n)."""
        X = np.asarray(x, dtype=float).reshape(2 * self.n_h + 1, self.nR)
        q_hat = np.zeros((2 * self.n_h + 1, self.system.n))
        q_hat[:, self.keep] = X
        if self.elim.size:
            q_hat[:, self.elim] = fourier.from_complex(self.cond.recover(fourier.to_complex(X)))
        return q_hat

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
        if any(self._velocity(el) for el in self.system.elements):
            info["dlft_velocity_penalty"] = [float(e) if self._velocity(el) else None
                                             for e, el in zip(self.eps_v, self.system.elements)]
        fr = [j for j, el in enumerate(self.system.elements) if el.bounded]
        ct = [j for j, el in enumerate(self.system.elements) if el.unilateral]
        if fr:
            info["stick_samples"] = [int(marched[self._pos[j]][1].sum()) for j in fr]
        if ct:
            info["closed_samples"] = [int(marched[self._pos[j]][1].sum()) for j in ct]
        return dict(t=t, q_hat=q_hat, time_dofs=np.zeros(0, dtype=np.int64),
                    q_time=np.zeros((self.Ns + 1, 0)), u_time=np.zeros((self.Ns + 1, 0)),
                    lam=lam, impulses=None, harmonics=self.n_h, info=info)
