"""Harmonic balance with alternating frequency-time (HBM-AFT), regularised laws.

Unknowns: Fourier coefficients ``q_hat`` (eqs. 1-3).  Residual::

    R = H q_hat - f_ex_hat - FFT(f_nl(IFFT(q_hat), IFFT(Omega q_hat)))

with the block-diagonal dynamic stiffness ``H`` (eqs. 23-24) and ``N_s`` time
samples per period for the AFT.  Because the nonlinear forces act only on the
DOFs ``N``, the linear DOFs ``L`` are eliminated exactly per harmonic
(``condense=True``, default; the solution is that of full HBM, see
:class:`mshbm.fourier.Condensation`).  ``condense=False`` solves the full
(sparse) system instead.  The Jacobian is analytic.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from . import fourier
from ._common import guess_parts
from .fourier import Condensation
from .laws import regularised_forces

__all__ = ["HBMProblem"]


class HBMProblem:
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
    """

    method = "hbm"

    def __init__(self, system, omega, harmonics, steps, condense=True, partition=None):
        self._args = (system, omega, harmonics, steps, condense, partition)
        self.system, self.omega = system, float(omega)
        self.n_h, self.Ns = int(harmonics), int(steps)
        n = system.n
        N_dofs = system.nonlinear_dofs if partition is None else np.asarray(partition, dtype=np.int64)
        self.condense = bool(condense)
        if self.condense:
            self.keep = np.asarray(N_dofs, dtype=np.int64)
        else:
            self.keep = np.arange(n)
        self.elim = np.setdiff1d(np.arange(n), self.keep)
        self.cond = Condensation(system, omega, self.n_h, self.keep, self.elim)
        nR = self.keep.size
        pos = {int(d): i for i, d in enumerate(self.keep)}
        self.local_dof = [pos[el.dof] for el in system.elements]
        self.nl_cols = np.array(sorted({pos[el.dof] for el in system.elements}), dtype=np.int64)
        # linear part A = H_RR - T (block diagonal per harmonic)
        F = fourier.to_complex(system.forcing_hat(self.n_h))
        sub = lambda A: A.tocsr()[self.keep][:, self.keep] if sp.issparse(A) else np.asarray(A)[np.ix_(self.keep, self.keep)]
        MRR, CRR, KRR = sub(system.M), sub(system.C), sub(system.K)
        blocks = []
        for k in range(self.n_h + 1):
            Hk = fourier.dynamic_stiffness(MRR, CRR, KRR, k * omega)
            if self.condense:
                Hk = (Hk.toarray() if sp.issparse(Hk) else Hk) - self.cond.T[k]
                blocks.append(sp.csr_matrix(fourier.real_block(Hk, k)))
            else:
                Hk = sp.csr_matrix(Hk)
                A, Bm = Hk.real, Hk.imag
                blocks.append(A if k == 0 else sp.bmat([[A, Bm], [-Bm, A]]))
        self.A = sp.block_diag(blocks, format="csr")
        if self.condense:
            self.A = self.A.toarray()
        self.r = fourier.from_complex(F[:, self.keep] - self.cond.g).reshape(-1)
        self.E = fourier.dft_matrix(self.Ns, self.n_h)
        self.Vs = fourier.idft_matrix(self.Ns, self.n_h)
        self.Om = fourier.derivative(np.eye(2 * self.n_h + 1), self.omega)
        self.VsOm = self.Vs @ self.Om
        self.nR = nR

    @property
    def n_unknowns(self):
        return (2 * self.n_h + 1) * self.nR

    def homotopy(self, factors=(1e-3, 1e-2, 3e-2, 0.1, 0.3)):
        """Problems with softened laws (``kappa`` and ``k_c, d_c`` times each factor), ending with ``self``.

        Used as a fallback when Newton fails from the given start: each
        solution starts the next, stiffer problem.
        """
        from dataclasses import replace

        system, omega, n_h, steps, condense, partition = self._args
        out = []
        for f in factors:
            els = []
            for el in system.elements:
                if el.kind == "friction":
                    els.append(replace(el, smoothing=el.smoothing * f))
                else:
                    els.append(replace(el, penalty_stiffness=el.penalty_stiffness * f,
                                       penalty_damping=el.penalty_damping * f))
            out.append(HBMProblem(system.with_elements(els), omega, n_h, steps, condense, partition))
        return out + [self]

    def initial_guess(self, guess=None):
        q_hat, _, _ = guess_parts(guess, self.system, self.omega, self.n_h)
        return q_hat[:, self.keep].reshape(-1)

    def _time(self, x):
        X = x.reshape(2 * self.n_h + 1, self.nR)
        Xn = X[:, self.nl_cols]
        return self.Vs @ Xn, self.VsOm @ Xn

    def residual(self, x, jac=True):
        """``(R, J)`` with shapes ``(n_x,)`` and ``(n_x, n_x)`` (dense if condensed, else sparse)."""
        nc, nR = 2 * self.n_h + 1, self.nR
        q, u = self._time(x)
        cols = {int(c): i for i, c in enumerate(self.nl_cols)}
        ldof = [cols[d] for d in self.local_dof]
        _, f, dfdq, dfdu = regularised_forces(self.system.elements, ldof, q, u)
        fh = np.zeros((nc, nR))
        fh[:, self.nl_cols] = self.E @ f
        R = self.A @ x - self.r - fh.reshape(-1)
        if not jac:
            return R, None
        nN = self.nl_cols.size
        Jn = np.zeros((nc, nN, nc, nN))
        for i in range(nN):
            Jn[:, i, :, i] = self.E @ (dfdq[:, i:i + 1] * self.Vs + dfdu[:, i:i + 1] * self.VsOm)
        idx = (np.arange(nc)[:, None] * nR + self.nl_cols[None, :]).reshape(-1)
        Jn = Jn.reshape(nc * nN, nc * nN)
        if self.condense:
            J = self.A.copy()
            J[np.ix_(idx, idx)] -= Jn
        else:
            rr, cc = np.meshgrid(idx, idx, indexing="ij")
            J = self.A - sp.csr_matrix((Jn.ravel(), (rr.ravel(), cc.ravel())), shape=self.A.shape)
        return R, J

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
        t = np.linspace(0.0, T, self.Ns + 1)
        q, u = self._time(x)
        cols = {int(c): i for i, c in enumerate(self.nl_cols)}
        lam, _, _, _ = regularised_forces(self.system.elements, [cols[d] for d in self.local_dof], q, u)
        lam = np.vstack([lam, lam[:1]])
        info = {"partition": self.keep.tolist(), "condensed": self.condense,
                "min_rcond_H_LL": float(self.cond.rcond.min())}
        return dict(t=t, q_hat=q_hat, time_dofs=np.zeros(0, dtype=np.int64),
                    q_time=np.zeros((self.Ns + 1, 0)), u_time=np.zeros((self.Ns + 1, 0)),
                    lam=lam, impulses=None, harmonics=self.n_h, info=info)
