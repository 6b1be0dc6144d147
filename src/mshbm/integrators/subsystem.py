"""Moreau-Jean integration of a subsystem driven by a harmonic force affine in parameters (MS-HBM's
time-domain part).

The force on the integrated DOFs is ``f(t) = f0(t) + V(t)^T c`` with the real coefficients
``c = c0 + Tr p`` of the harmonic coupling force (``V`` the Fourier basis, ``c`` flattened
harmonic-major).  :class:`SubsystemStepper` integrates one period with the sensitivities with respect
to ``(q0, u0, p)`` and the Fourier coefficients of ``q`` with theirs.  Where the subsystem falls apart
into independent blocks (:func:`_blocks`), each block is integrated alone and ``d/dp`` follows by the
chain rule through ``Tr``: the cost of a Jacobian is linear in the number of blocks instead of cubic in
the subsystem size.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .. import fourier
from ..elements import Contact, Friction, Jenkins, Polynomial
from ..errors import InputError
from .moreau_jean import MoreauJean, Trajectory

__all__ = ["SubsystemStepper", "submatrix", "local_elements"]


def submatrix(A, r, c):
    """Block ``A[r][:, c]`` of a dense or sparse matrix (sparse stays CSR)."""
    if sp.issparse(A):
        return A.tocsr()[r][:, c]
    return np.asarray(A)[np.ix_(r, c)]



def local_elements(system, dofs):
    """The elements of ``system`` renumbered to the subsystem ``dofs`` (an InputError if one lies outside)."""
    pos = {int(d): i for i, d in enumerate(dofs)}
    out = []
    for el in system.elements:
        for d in el.dofs:
            if int(d) not in pos:
                raise InputError("partition", f"{el.kind} element on DOF {d} is not in the nonlinear subsystem")
        out.append(el.renumbered(pos))
    return out


def _blocks(M, C, K, elements):
    """Independent blocks of an integrated subsystem: connected components of the graph of the nonzeros
    of ``M, C, K`` (dense, subsystem numbering) joined by the DOFs of each element.

    Returns a list of ``(dofs, element indices)`` (both sorted int arrays), or ``None`` when the subsystem
    is one block or carries an element whose coupling this function does not know (then it is integrated
    as one block).
    """
    n = M.shape[0]
    if n < 2 or any(type(el) not in (Friction, Contact, Jenkins, Polynomial) for el in elements):
        return None
    if any(el.normal_contact is not None or el.cone_partner is not None for el in elements):
        return None  # a friction loaded by a contact or a cone pair couples the elements' DOFs: one block
    A = (np.abs(M) + np.abs(C) + np.abs(K)) > 0
    rows, cols = np.nonzero(A)
    for el in elements:
        d = [int(x) for x in el.dofs]
        rows = np.concatenate([rows, d[:-1]])
        cols = np.concatenate([cols, d[1:]])
    graph = sp.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n))
    n_comp, label = connected_components(graph, directed=False)
    if n_comp < 2:
        return None
    el_label = np.array([label[int(el.dofs[0])] for el in elements], dtype=np.int64)
    return [(np.flatnonzero(label == b), np.flatnonzero(el_label == b)) for b in range(n_comp)]


class _Block:
    """One independent block of the integrated subsystem (see :class:`SubsystemStepper`): its own
    Moreau-Jean stepper and the increments of the unit harmonic forces on its DOFs."""

    def __init__(self, dofs, el_idx, M, C, K, elements, h, theta, project, V, n1, slider_row):
        self.dofs = dofs  # structure DOFs, subsystem numbering
        pos = {int(d): i for i, d in enumerate(dofs)}
        els = [elements[j].renumbered(pos) for j in el_idx]
        ix = np.ix_(dofs, dofs)
        self.stepper = MoreauJean(M[ix], C[ix], K[ix], els, h, theta, project)
        # integrated states of the block in the subsystem's integrated numbering: its structure DOFs, then
        # the sliders of its Jenkins elements (in element order, as MoreauJean appends them)
        sliders = [slider_row[int(el_idx[j])] for j, _ in self.stepper.sliders]
        self.rows = np.concatenate([dofs, np.asarray(sliders, dtype=np.int64)]).astype(np.int64)
        self.el_idx = el_idx
        nc, nb = V.shape[1], dofs.size
        # coefficient c_(k, i) of the force on subsystem DOF i (harmonic-major): the block's columns
        self.cidx = (np.arange(nc)[:, None] * n1 + dofs[None, :]).reshape(-1)
        # where the block's sensitivities go in the subsystem's (rows; columns [q0 (n_A), u0 (n_A), p])
        nA = n1 + len(slider_row)
        r = self.rows
        self.at_q0, self.at_u0 = np.ix_(r, r), np.ix_(r, nA + r)
        self.at_hat_q0, self.at_hat_u0 = np.ix_(self.cidx, r), np.ix_(self.cidx, nA + r)
        # d f / d c_(k, a) = V_k(t) e_a  ->  increments, shape (N, n_block, nc * nb)
        dF = np.zeros((V.shape[0], nb, nc, nb))
        for a in range(nb):
            dF[:, a, :, a] = V
        self.dB = self.stepper.increments(dF.reshape(V.shape[0], nb, nc * nb))


class SubsystemStepper:
    """Moreau-Jean integration of a subsystem driven by a harmonic forcing affine in parameters.

    The force on the subsystem is ``f(t) = f0(t) + V(t)^T c`` with the real coefficient
    vector ``c = c0 + Tr p`` (``c`` flattened harmonic-major, shape ``((2n_h+1) n_1,)``).

    When the subsystem falls apart into independent blocks (:func:`_blocks`: no mass, damping or
    stiffness entry and no element joins them, e.g. friction elements spread along a chain, coupled only
    through the condensed linear part, i.e. through ``c``), each block is integrated on its own, with
    sensitivities with respect to its own states and its own ``(2 n_h + 1) n_b`` coefficients of ``c``
    only; ``d/dp`` follows by the chain rule through ``Tr``.  The cost of the sensitivities is then
    ``sum_b N n_b^2 (2 + 2 n_h + 1) n_b`` instead of ``N n_1^2 (2 n_1 + n_p)``, and nothing of size
    ``N n_1 n_p`` is stored.  Otherwise (one block) the whole subsystem is integrated with sensitivities
    with respect to ``(q0, u0, p)`` directly.
    """

    def __init__(self, system, dofs, omega, n_h, steps, theta, project, c0, Tr):
        self.dofs = np.asarray(dofs, dtype=np.int64)
        self.n1 = self.dofs.size
        self.N = int(steps)
        self.T = 2 * np.pi / omega
        self.h = self.T / self.N
        self.t = np.linspace(0.0, self.T, self.N + 1)
        self.n_h = n_h
        M, C, K = (submatrix(getattr(system, a), self.dofs, self.dofs) for a in "MCK")
        els = local_elements(system, self.dofs)
        self.stepper = MoreauJean(M, C, K, els, self.h, theta, project)
        V = fourier.basis(self.t, omega, n_h)
        nc = 2 * n_h + 1
        self.nc = nc
        self.Tr = np.asarray(Tr, dtype=float)
        n_p = self.Tr.shape[1]
        self.n_p = n_p
        f0 = system.forcing(self.t, omega, self.dofs) + V @ c0.reshape(nc, self.n1)
        dense = lambda A: A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)
        parts = _blocks(dense(M), dense(C), dense(K), els)
        if parts is None:
            self.blocks = None
            self.B0 = self.stepper.increments(f0)
            dF = np.einsum("kj,jlp->klp", V, self.Tr.reshape(nc, self.n1, n_p))
            self.dB = self.stepper.increments(dF)
        else:
            self.f0, self.V = f0, V
            slider_row = {j: z for j, z in self.stepper.sliders}
            self.blocks = [_Block(d, e, dense(M), dense(C), dense(K), els, self.h, theta, project, V, self.n1,
                                  slider_row) for d, e in parts]

        # Fourier projection of sampled signals: a DFT matrix is cheaper than an FFT of all N
        # frequencies when only 2 n_h + 1 coefficients are needed (kept below ~100 MB)
        self.E = fourier.dft_matrix(self.N, n_h) if nc * self.N <= 12_000_000 else None

    def project(self, x):
        """Coefficients (eq. 28) of samples ``x`` of shape (N, ...) -> (2 n_h + 1, ...)."""
        if self.E is None:
            return fourier.fft(x, self.n_h)
        return (self.E @ x.reshape(self.N, -1)).reshape((self.E.shape[0],) + x.shape[1:])

    def run(self, q0, u0, p, sens=True):
        """Trajectory from ``(q0, u0)`` (integrated states, shape ``(n_A,)``) under parameters ``p``.

        With ``sens``: ``Sq, Su`` (shape ``(n_A, 2 n_A + n_p)``, columns ``[q0, u0, p]``) and
        ``q_hat_sensitivity`` (shape ``((2 n_h + 1) n_1, 2 n_A + n_p)``: the Fourier coefficients (eq. 28) of
        ``dq_k/d(q0, u0, p)`` over ``k = 0 .. N-1``, harmonic-major); ``Sq_traj`` is not kept.
        """
        if self.blocks is None:
            B = self.B0 + np.einsum("kip,p->ki", self.dB, p)
            tr = self.stepper.run(q0, u0, B, self.dB, sensitivities=sens, store_q_sensitivities=sens)
            if sens:
                n1 = self.n1
                tr.q_hat_sensitivity = self.project(tr.Sq_traj[:-1, :n1]).reshape(self.nc * n1, -1)
                tr.Sq_traj = None
            return tr
        return self._run_blocks(q0, u0, p, sens)

    def _run_blocks(self, q0, u0, p, sens):
        q0, u0 = self.stepper.with_slider_state(q0, u0)
        nA, n1, nc, N = self.stepper.n, self.n1, self.nc, self.N
        c = (self.Tr @ p).reshape(nc, n1)
        F = self.f0 + self.V @ c
        q = np.empty((N + 1, nA))
        u = np.empty((N + 1, nA))
        m = self.stepper.m
        P = np.zeros((N, m))
        status = np.zeros((N, m), dtype=np.int8)
        n_s = 2 * nA + self.n_p
        Sq = np.zeros((nA, n_s)) if sens else np.zeros((nA, 0))
        Su = np.zeros((nA, n_s)) if sens else np.zeros((nA, 0))
        dqh = np.zeros((nc * n1, n_s)) if sens else None
        pgs = 0
        for b in self.blocks:
            r, nb, nsb = b.rows, b.rows.size, b.dofs.size
            B = b.stepper.increments(F[:, b.dofs])
            tr = b.stepper.run(q0[r], u0[r], B, b.dB, sensitivities=sens, store_q_sensitivities=sens)
            q[:, r], u[:, r] = tr.q, tr.u
            P[:, b.el_idx], status[:, b.el_idx] = tr.P, tr.status
            pgs = max(pgs, int(tr.pgs_iterations))
            if not sens:
                continue
            # kernel columns of the block: [q0_b (nb), u0_b (nb), c_b (nc nsb)]; d/dp = d/dc_b Tr[c_b]
            Trb = self.Tr[b.cidx]
            for S_out, S_b in ((Sq, tr.Sq), (Su, tr.Su)):
                S_out[b.at_q0] = S_b[:, :nb]
                S_out[b.at_u0] = S_b[:, nb:2 * nb]
                S_out[r, 2 * nA:] = S_b[:, 2 * nb:] @ Trb
            D = self.project(tr.Sq_traj[:-1, :nsb]).reshape(nc * nsb, -1)  # rows (k, a) -> row k n1 + dofs[a]
            dqh[b.at_hat_q0] = D[:, :nb]
            dqh[b.at_hat_u0] = D[:, nb:2 * nb]
            dqh[b.cidx, 2 * nA:] = D[:, 2 * nb:] @ Trb
        out = Trajectory(q, u, P, status, Sq, Su, None, pgs)
        out.q_hat_sensitivity = dqh
        return out
