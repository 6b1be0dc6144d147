"""DLFT's element terms: relative elements, the demanded forces, the penalty rule and Jenkins sliders.

Notation as in :mod:`mshbm.methods.dlft`: the kept DOFs' Fourier coefficients ``X`` (``n_R`` DOFs, ``nc = 2 n_h
+ 1`` coefficients each, unknown ``i * ... + k`` ordered harmonic-major: row of DOF ``p`` in harmonic ``c`` is
``c n_R + p``), the linear residual ``A X - r`` and the set-valued elements ``j`` with directions ``w_j`` (a
column of ``W``, shape ``(n_R, m)``): ``w_j = sign e_I`` (ground) or ``sign (e_I - e_J)`` (between two DOFs,
``relative_to``).

The demanded forces
-------------------
Any weights ``C`` with ``C^T W = I`` give the same converged solution (at a solution ``C^T (A X - r) = C^T W P
lambda = P lambda``); they differ in how Newton gets there.  Ground elements use the least-squares weights
below; as soon as an element acts between two DOFs, the compliance weights ``C = A^-1 W (W^T A^-1 W)^-1`` per
harmonic (:func:`compliance_demand`), for which ``lambda_L = (W^T A^-1 W)^-1 (s - s_lin)`` depends on the
elements' displacements ``s = W^T X`` only (``s_lin`` those of the linear response), so the prediction's
derivative ``Q`` touches the elements' own columns, not the rows of ``A`` of both DOFs (the least-squares demand
``((A X - r)_I - (A X - r)_J) / 2``).  Measured on a partner held by a spring ``k_c``: both weightings converge
for ``k_c`` up to ``1e12`` times the structure's stiffness (above it Newton's matrix is numerically singular
for any method and its least-squares step stalls).  A harmonic whose ``A`` or ``W^T A^-1 W`` is singular (free
bodies at ``k = 0``) keeps the least-squares weights.

The harmonic balance is ``A X - r = W DFT[lambda]``.  The forces the linear part demands of the elements are
the least-squares solution of ``W lambda_L = A X - r``, per coefficient::

    lambda_L = G^-1 W^T (A X - r),   G = W^T W,

i.e. the demand of element ``j`` is ``c_j^T (A X - r)`` with ``c_j = W G^-1 e_j`` (:func:`demand_weights`).  At a
solution ``A X - r = W P lambda`` (``P`` the truncation of the sampled force to the series) so ``lambda_L =
P lambda`` for every element: the Lagrangian variables are those of the grounded method
(:mod:`mshbm.methods.dlft`).  Ground elements on distinct DOFs have ``G = I`` and ``c_j = w_j``: exactly the
grounded DLFT.  One element between two DOFs alone: ``c_j = w_j / 2``.  The directions must be linearly
independent (``G`` regular): two elements along one direction (a friction and a contact on one DOF) split no
demanded force and are refused.

The penalty rule for an element between two DOFs
-------------------------------------------------
``eps = max_k |k_r(k omega)|`` with the stiffness of the relative coordinate ``s = w^T q`` when the pair is
loaded by ``+-f`` and the rest of the nonlinear DOFs by nothing, ``k_r = 1 / (w^T B^-1 w)`` (``B``: the 2x2 block
of the condensed dynamic stiffness at ``I, J``; ``k_r = det B / (B_II + B_JJ + 2 B_IJ)``).  With the partner
``J`` clamped (``B_JJ -> inf``) it tends to ``B_II``, the ground rule; its mass fallback uses the reduced mass.

Jenkins elements (tangential stiffness) as sliders
--------------------------------------------------
A Jenkins element (:class:`mshbm.elements.Jenkins`, 1-D or the 3-D Jenkins cone pair) is a spring ``k_t`` from
``s = w^T q`` to a massless slider DOF ``z`` carrying rigid Coulomb friction on the ground (the disk for a cone
pair), as in Moreau-Jean (:func:`mshbm.integrators.moreau_jean._with_sliders`): ``K += k_t v v^T``, ``v = [w;
-e_z]``, ``M_zz = C_zz = 0``.  DLFT balances the harmonics of ``z`` too (condensed onto them like any element
DOF) and predicts and corrects the slider's friction force; the element's force on the structure is the
slider's friction force, ``lambda = -k_t (s - z)`` (:func:`with_sliders`).  HBM instead marches the return
mapping on the samples of ``s`` (:meth:`mshbm.elements.Jenkins.history_law`): the two methods differ by the
truncation of ``z`` and DLFT's Lagrangian remainder, and agree as ``n_h`` grows.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..elements.base import dependent_directions
from ..errors import InputError

__all__ = ["Term", "with_sliders", "relative_stiffness", "demand_weights", "element_terms"]


@dataclass
class Term:
    """One set-valued element in DLFT.  ``rows``/``w``: per DOF of the element (one or two), its rows in the
    unknowns (shape (nc,)) and its entry of ``w``; ``drows``/``dc``: the rows and weights of its demanded force
    (``lambda_L = sum dc_i (A X - r)[drows_i]`` per coefficient); ``cols``: the unknowns the prediction ``y``
    depends on; ``sel``: per own DOF, the positions of its rows in ``cols``; ``Q = d y / d x[cols]`` on the
    samples, shape (N_s, cols.size)."""

    el: object
    j: int
    rows: tuple
    w: tuple
    drows: tuple
    dc: tuple
    cols: np.ndarray
    sel: tuple
    Q: np.ndarray
    #: with elements between two DOFs: the demand as a matrix on the unknowns, ``lambda_L = Vs D (A X - r)``,
    #: shape (nc, n_x) (``drows``, ``dc`` then unused)
    D: object = None


def with_sliders(structure):
    """``(system, sliders)``: ``structure`` with one massless slider DOF per Jenkins element appended (module
    docstring), its Jenkins elements replaced by rigid frictions on the sliders (same indices, cone partners
    kept); ``sliders`` the list of ``(element index, slider DOF)``.  Without Jenkins elements: ``(structure,
    [])``.  The returned system is a copy whose matrices are not checked by :class:`mshbm.system.System` (its
    mass matrix is singular on the sliders); its forcing is the structure's at its frequency, zero on the
    sliders."""
    from ..elements import Friction

    jen = [j for j, el in enumerate(structure.elements) if getattr(el, "history", False)]
    if not jen:
        return structure, []
    n = structure.n
    na = n + len(jen)
    sparse = structure.is_sparse
    pad = (lambda A: sp.block_diag([sp.csr_matrix(A), sp.csr_matrix((na - n, na - n))], format="lil")) if sparse \
        else (lambda A: np.pad(np.asarray(A, dtype=float), ((0, na - n), (0, na - n))))
    Ma, Ca, Ka = pad(structure.M), pad(structure.C), pad(structure.K)
    els, sliders = list(structure.elements), []
    for i, j in enumerate(jen):
        el = els[j]
        z = n + i
        v = [(int(d), float(w)) for d, w in el.direction] + [(z, -1.0)]
        for a, wa in v:
            for b, wb in v:
                Ka[a, b] += el.tangential_stiffness * wa * wb
        els[j] = Friction(z, el.mu, el.normal_force, el.smoothing, cone_partner=el.cone_partner,
                          normal_contact=el.normal_contact)
        sliders.append((j, z))
    if sparse:
        Ma, Ca, Ka = Ma.tocsr(), Ca.tocsr(), Ka.tocsr()
    system = structure.with_elements(els)
    f = np.pad(np.asarray(structure.f_hat, dtype=float), ((0, 0), (0, na - n)))
    system.__dict__.update(M=Ma, C=Ca, K=Ka, f_hat=f, forcing_parts=(), forcing_omega=structure.forcing_omega,
                           name=f"{structure.name} (Jenkins sliders)")
    system.__dict__.pop("_derived", None)
    return system, sliders


def relative_stiffness(Hd, Md, pn, el):
    """``(A_dd, m_dd)`` for :func:`mshbm.methods.dlft.default_penalty`: the diagonal entry of the condensed
    dynamic stiffness ``Hd`` (shape (n_h + 1, n_N, n_N); ``pn``: DOF -> index) and the mass ``Md`` at a ground
    element's DOF, or for an element between two DOFs the relative stiffness ``det B / (w^T adj(B) w)`` and the
    reduced mass (module docstring; a harmonic whose relative compliance vanishes is skipped)."""
    if el.relative_to is None:
        return Hd[:, pn[el.dof], pn[el.dof]], Md[el.dof]
    i, k = pn[int(el.dof)], pn[int(el.relative_to)]
    bii, bkk, bik = Hd[:, i, i], Hd[:, k, k], 0.5 * (Hd[:, i, k] + Hd[:, k, i])
    den = bii + bkk + 2.0 * bik  # w^T adj(B) w, w = +-(1, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        kr = np.where(den != 0.0, (bii * bkk - bik * bik) / np.where(den != 0.0, den, 1.0), 0.0)
    mi, mk = float(Md[el.dof]), float(Md[el.relative_to])
    return kr, (mi * mk / (mi + mk) if mi + mk > 0.0 else 0.0)


def demand_weights(elements, pos):
    """``C = W G^-1``, shape (n_R, m): column ``j`` weighs the linear residual's kept DOFs into element ``j``'s
    demanded force (module docstring); ``pos``: DOF -> kept index.  ``G = I`` (ground elements on distinct DOFs)
    gives ``C = W`` exactly.  Raises :class:`~mshbm.errors.InputError` (``elements``) if the directions are
    linearly dependent."""
    m = len(elements)
    W = np.zeros((len(pos), m))
    for j, el in enumerate(elements):
        for d, w in el.direction:
            W[pos[int(d)], j] = w
    G = W.T @ W
    if np.array_equal(G, np.eye(m)):
        return W
    if np.linalg.matrix_rank(G) < m:
        what = dependent_directions(elements) or "two elements act along one direction"
        raise InputError("elements", f"DLFT needs linearly independent element directions ({what}: the demanded "
                                     "force cannot be split between them)")
    return W @ np.linalg.inv(G)


def compliance_demand(problem, elements, pos):
    """``D``, shape (nc m, n_x): row ``c m + j`` gives element ``j``'s demand in coefficient ``c`` from the linear
    residual, ``D = C^T`` with the compliance weights per harmonic (module docstring).  ``problem``: its ``A``
    (real, harmonic-major unknowns ``c n_R + p``), ``n_h``, ``nR``."""
    A, nR, n_h = problem.A, problem.nR, problem.n_h
    m = len(elements)
    nc = 2 * n_h + 1
    W = np.zeros((nR, m))
    for j, el in enumerate(elements):
        for d, w in el.direction:
            W[pos[int(d)], j] = w
    D = np.zeros((nc * m, nc * nR))
    for k in range(n_h + 1):
        coeffs = [0] if k == 0 else [2 * k - 1, 2 * k]
        idx = np.concatenate([c * nR + np.arange(nR) for c in coeffs])
        Ak = A[idx][:, idx]
        Ak = Ak.toarray() if sp.issparse(Ak) else np.asarray(Ak)
        Wk = np.kron(np.eye(len(coeffs)), W)
        Ck = None
        try:
            if np.linalg.cond(Ak) < 1e13:
                AiW = np.linalg.solve(Ak, Wk)
                Sk = Wk.T @ AiW
                if np.linalg.cond(Sk) < 1e13:
                    Ck = np.linalg.solve(Sk.T, AiW.T).T  # A^-1 W S^-1
        except np.linalg.LinAlgError:
            Ck = None
        if Ck is None:  # singular harmonic: least squares
            Ck = Wk @ np.linalg.inv(Wk.T @ Wk)
        rows = np.concatenate([c * m + np.arange(m) for c in coeffs])
        D[np.ix_(rows, idx)] = Ck.T
    return D


def element_terms(problem, system, pos, VsOm):
    """The :class:`Term` of every set-valued element of ``system`` (index ``j`` into its elements), for the DLFT
    ``problem`` (its ``A``, ``Vs``, ``eps``, ``eps_v``, ``n_h``, ``nR``, ``_velocity``)."""
    A, Vs = problem.A, problem.Vs
    nR, nc = problem.nR, 2 * problem.n_h + 1
    idx = [j for j, el in enumerate(system.elements) if not el.smooth]
    els = [system.elements[j] for j in idx]
    Cw = demand_weights(els, pos)
    Dall = compliance_demand(problem, els, pos) if any(el.relative for el in els) else None
    harm = np.arange(nc) * nR
    out = []
    for col, j in enumerate(idx):
        el = system.elements[j]
        own = [(harm + pos[int(d)], float(w)) for d, w in el.direction]
        dem = [(harm + p, float(Cw[p, col])) for p in np.flatnonzero(Cw[:, col])]
        touched = np.zeros(A.shape[1], dtype=bool)
        for r, _ in own:
            touched[r] = True
        if Dall is None:
            Ad = [A[r].toarray() if sp.issparse(A) else A[r] for r, _ in dem]
            for Ai in Ad:
                touched |= np.any(Ai != 0.0, axis=0)
            cols = np.flatnonzero(touched)
            Q = None
            for Ai, (_, c) in zip(Ad, dem):
                Qi = c * (Vs @ Ai[:, cols])
                Q = Qi if Q is None else Q + Qi
            D = None
        else:  # D A = (W^T A^-1 W)^-1 W^T on the harmonics with compliance weights: the elements' columns only
            D = Dall[np.arange(nc) * len(idx) + col]
            DA = np.asarray((A.T @ D.T).T) if sp.issparse(A) else D @ A
            big = np.abs(DA) > 1e-13 * np.abs(DA).max()
            touched |= np.any(big, axis=0)
            cols = np.flatnonzero(touched)
            Q = Vs @ DA[:, cols]
        sel = tuple(np.searchsorted(cols, r) for r, _ in own)
        for s_i, (_, w) in zip(sel, own):
            if problem._velocity(el):  # y = lambda_L - eps_v w^T u
                Q[:, s_i] -= problem.eps_v[j] * w * VsOm
            else:  # y = lambda_L - eps w^T q (contact: minus eps times the gap)
                Q[:, s_i] -= problem.eps[j] * w * Vs
        out.append(Term(el, j, tuple(r for r, _ in own), tuple(w for _, w in own), tuple(r for r, _ in dem),
                        tuple(c for _, c in dem), cols, sel, Q, D))
    return out


def slider_guess(q_hat, structure, sliders, guess, n_h):
    """``q_hat`` (shape (2 n_h + 1, n)) with the sliders' coefficients appended: ``z = s + lambda / k_t`` from the
    element forces of a solution given as ``guess`` (its ``lam`` on a uniform grid), else ``z = s`` (the springs
    unloaded, the linear guess of the structure)."""
    from .. import fourier

    out = np.zeros((q_hat.shape[0], structure.n + len(sliders)))
    out[:, :structure.n] = q_hat
    lam = getattr(guess, "lam", None)
    t = getattr(guess, "t", None)
    E = None
    if lam is not None and t is not None and np.ndim(lam) == 2 and np.shape(lam)[1] == len(structure.elements):
        lam = np.asarray(lam, dtype=float)
        dt = np.diff(np.asarray(t, dtype=float))
        if lam.shape[0] > 2 * n_h + 2 and dt.size and np.allclose(dt, dt[0], rtol=1e-9) and np.all(np.isfinite(lam)):
            E = fourier.dft_matrix(lam.shape[0] - 1, n_h)
    for j, z in sliders:
        el = structure.elements[j]
        out[:, z] = el.local(q_hat)
        if E is not None:
            out[:, z] += E @ lam[:-1, j] / el.tangential_stiffness
    return out
