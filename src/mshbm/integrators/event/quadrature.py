"""Exact Fourier coefficients of the event-driven flow (MS-HBM's ``FFT(q_1)``).

The Fourier integrals ``int q(t) b_k(t) dt`` over the simulated interval are taken by Gauss-Legendre
quadrature on every smooth piece of the flow (exact to rounding), with their sensitivities (``q`` is
continuous at events, so the event-time variations add nothing).  A full sub-step of a mode uses a fixed
weight matrix ``G0`` (the nodes' ``exp(A s_g)`` against the basis), rotated to the sub-step's start time;
the full sub-steps of a run are summed once at its end (:meth:`FourierQuadrature._fourier_flush`).
"""
from __future__ import annotations

import numpy as np

from .structured import _rotation_entries

__all__ = ["FourierQuadrature"]

#: Gauss-Legendre nodes and weights on [-1, 1] of the Fourier quadrature on smooth pieces of the flow
_GL_X, _GL_W = np.polynomial.legendre.leggauss(12)


class FourierQuadrature:
    """Fourier quadrature of an :class:`~mshbm.integrators.event.flow.EventFlow` (mixin)."""

    def _fourier_basis(self, t, nfr):
        """``[1, cos(k omega t), sin(k omega t)]`` at times ``t``, shape (k_t, 2 n_f + 1)."""
        t = np.asarray(t, dtype=float)
        out = np.empty(t.shape + (2 * nfr + 1,))
        out[..., 0] = 1.0
        if nfr:
            wt = np.multiply.outer(t, self.omega * np.arange(1, nfr + 1))
            out[..., 1::2], out[..., 2::2] = np.cos(wt), np.sin(wt)
        return out

    def _fourier_full(self, md, nfr):
        """Fourier weights of a full sub-step of mode ``md`` starting at ``t = 0``:
        ``G0[k] = sum_g w_g b_k(s_g) exp(A s_g)[:n]`` (Gauss-Legendre nodes ``s_g`` and weights ``w_g`` on
        ``[0, h_s]``), shape (2 n_f + 1, n, D), once per mode and ``n_f``.  From a start ``a`` the weights
        are the rows of ``G0`` rotated by ``k omega a`` (:meth:`_fourier_flush`)."""
        sh = md.shared
        G0 = sh["G0"].get(nfr)
        if G0 is None:
            h, n = md.h, self.n
            ss = 0.5 * h * (_GL_X + 1.0)
            if sh["Eg"] is None:  # the q rows of exp(A s_g) at the nodes of a full sub-step
                sh["Eg"] = self._expm_rows(md, ss)  # (g, n, D)
            B0 = self._fourier_basis(ss, nfr) * (0.5 * h * _GL_W)[:, None]  # (g, nc)
            G0 = sh["G0"][nfr] = np.einsum("gk,gnd->knd", B0, sh["Eg"])
        return G0

    def _phi_rotation_entries(self, Phi):
        """The nonzero entries of the forcing-state block of ``Phi``: the diagonal of the constants ``d`` (n,)
        and per pair ``(Y1, Y2)`` the block ``[[c1, s1], [m1, c2]]`` (rows Y1, Y2; columns d/dY1_0, d/dY2_0),
        concatenated ``[d, c1, m1, s1, c2]``, shape (n + 4 n_c n,).

        Structure of the sensitivities ``Phi`` of :meth:`simulate`: the rows of the oscillator are zero, and
        with the forcing-state columns (``jac_cols="all"``) the forcing-state block is the rotation of those
        states: zero in the ``(q0, u0)`` columns, per DOF ``i`` and harmonic ``k`` nonzero only in the 2 x 2
        block of the pair ``(Y1, Y2)`` (and 1 x 1 for the constant), whatever the events (the saltation and
        the impact law change the ``(q, u)`` rows only, the vector fields of all modes agree in the
        forcing-state rows; Moreau-Jean segments leave the block unchanged).  Products with ``Phi`` then
        cost linear, not quadratic, in the number of forcing states."""
        return _rotation_entries(Phi, self.iy, self.n, self._yc, self._ys)

    def _fourier_flush(self, four):
        """Add the full sub-steps recorded by :meth:`_fourier_piece` (``four[3]``: per mode the start times
        ``a_j``, states ``z_j``, the rows ``Phi_j[:2n]`` and :meth:`_phi_rotation_entries`), all at once:

        ``sum_j Rot(a_j) G0 z_j`` and ``sum_j Rot(a_j) G0 Phi_j`` with ``Rot(a)`` the rotation of the
        harmonic rows through ``k omega a`` (``b_k(a + s)`` from ``b_k(s)``).  The ``(q, u)`` rows of ``Phi_j`` enter by one
        matrix product over all ``j``; the forcing-state rows (rotation blocks) by the sums
        ``sum_j [1, cos, sin](k omega a_j) [d, c1, m1, s1, c2]_j`` (one product of a (1 + 2 n_f, J) by a
        (J, n + 4 n_c n) matrix), so the cost is linear, not cubic, in the harmonics per sub-step."""
        nfr, n, iy, D = four[0], self.n, self.iy, self.D
        nc, K = 2 * nfr + 1, nfr
        recs, four[3] = four[3], {}
        for code, (al, zl, pl, yl) in recs.items():
            if not al:
                continue
            G0 = self._fourier_full(self.mode(code), nfr)  # (nc, n, D)
            A = np.asarray(al)
            J = A.size
            wa = self.omega * A[:, None] * np.arange(1, K + 1)  # (J, K)
            Cj, Sj = np.cos(wa), np.sin(wa)
            # states: Y[h, i, j] = (G0 z_j)[h, i], then the rotated sum over j
            Y = (G0.reshape(nc * n, D) @ np.array(zl).T).reshape(nc, n, J)
            four[1] += self._rot_sum(Y, Cj, Sj)
            if four[2] is None or not pl:
                continue
            # (q, u) rows of Phi (its oscillator rows are zero): L_j = Rot(a_j) G0[..., :2n], one product
            # over (j, rows)
            n2 = 2 * n
            Gx = G0[:, :, :n2]
            L = np.empty((J, nc, n, n2))
            L[:, 0] = Gx[0]
            if K:
                cc, ss_ = Cj[:, :, None, None], Sj[:, :, None, None]
                L[:, 1::2] = cc * Gx[1::2] - ss_ * Gx[2::2]
                L[:, 2::2] = ss_ * Gx[1::2] + cc * Gx[2::2]
            P = np.array(pl)  # (J, 2n, cols)
            four[2] += (L.transpose(1, 2, 0, 3).reshape(nc * n, J * n2) @ P.reshape(J * n2, -1)).reshape(
                nc, n, -1)
            if not yl:
                continue
            # forcing-state rows: X_j = G0_y Py_j has in column (const i') g0 d_j, in (Y1 of pair p)
            # gc c1_j + gs m1_j and in (Y2 of p) gc s1_j + gs c2_j
            V = np.array(yl)  # (J, n + 4 Pn)
            U = np.hstack([np.ones((J, 1)), Cj, Sj])  # (J, 1 + 2K)
            SU = U.T @ V  # (1 + 2K, n + 4 Pn)
            Pn = self._yc.size
            sl = lambda q: SU[:, n + q * Pn:n + (q + 1) * Pn]
            d_, c1, m1, s1, c2 = SU[:, :n], sl(0), sl(1), sl(2), sl(3)
            Gy = G0[:, :, iy:]
            g0, gc, gs = Gy[:, :, :n], Gy[:, :, self._yc], Gy[:, :, self._ys]
            out = four[2][:, :, 2 * n:]
            out[:, :, :n] += self._rot_comb(g0, d_, None, None, K)
            out[:, :, self._yc] += self._rot_comb(gc, c1, gs, m1, K)
            out[:, :, self._ys] += self._rot_comb(gc, s1, gs, c2, K)

    @staticmethod
    def _rot_sum(Y, Cj, Sj):
        """``sum_j Rot(a_j) Y[..., j]`` for ``Y`` of shape (2 K + 1, r, J) and ``cos, sin(k omega a_j)`` of
        shape (J, K); shape (2 K + 1, r)."""
        out = np.empty(Y.shape[:2])
        out[0] = Y[0].sum(axis=-1)
        if Cj.shape[1]:
            Yc, Ys = Y[1::2], Y[2::2]
            ein = lambda X, W: np.einsum("krj,jk->kr", X, W)
            out[1::2] = ein(Yc, Cj) - ein(Ys, Sj)
            out[2::2] = ein(Yc, Sj) + ein(Ys, Cj)
        return out

    @staticmethod
    def _rot_comb(ga, sa, gb, sb, K):
        """``sum_j Rot(a_j) (ga alpha_j + gb beta_j)`` (column-wise products) from the sums
        ``sa = sum_j [1, cos, sin](k omega a_j) alpha_j`` (shape (1 + 2K, q)), likewise ``sb``; ``ga, gb`` of
        shape (2 K + 1, n, q); ``gb`` may be None."""
        def part(g, S):
            o = np.empty_like(g)
            S1, SC, SS = S[0], S[1:K + 1, None, :], S[K + 1:, None, :]
            o[0] = g[0] * S1
            if K:
                gcr, gsr = g[1::2], g[2::2]
                o[1::2] = gcr * SC - gsr * SS
                o[2::2] = gcr * SS + gsr * SC
            return o
        out = part(ga, sa)
        if gb is not None:
            out += part(gb, sb)
        return out

    def _fourier_piece(self, md, z, W, Phi, a, s, four):
        """Add ``int_a^{a+s} q(t) b(t) dt`` (and of ``Phi_q``) by Gauss-Legendre quadrature on the flow from
        the state ``z`` at ``a`` (``W``: its Taylor powers, or None).  A full sub-step is recorded in
        ``four[3]`` and summed by :meth:`_fourier_flush` (the weights :meth:`_fourier_full` of its mode,
        rotated to ``a``)."""
        n, nfr = self.n, four[0]
        if s == md.h:
            # summed at the end (_fourier_flush): keep what the piece needs
            rec = four[3].setdefault(md.code, ([], [], [], []))
            rec[0].append(a)
            rec[1].append(z.copy())
            if four[2] is not None and Phi is not None:
                rec[2].append(Phi[:2 * n].copy())  # the oscillator rows are zero (_phi_rotation_entries)
                if Phi.shape[1] > 2 * n and self.ncx:
                    rec[3].append(self._phi_rotation_entries(Phi))
            return
        ss = 0.5 * s * (_GL_X + 1.0)
        wts = 0.5 * s * _GL_W
        B = self._fourier_basis(a + ss, nfr) * wts[:, None]  # (g, nc)
        if W is None:
            W = self.powers(md, z)
        P = self.spow(ss, md.n_taylor)  # (g, n_taylor)
        Q = P @ W[:n].T
        four[1] += B.T @ Q
        if four[2] is not None and Phi is not None:
            acc = [Phi[:n]]
            term = Phi
            for j in range(1, md.n_taylor):
                term = self.amul(md, term, sens=True) / j
                acc.append(term[:n])
            WP = np.array(acc)  # (n_taylor, n, cols)
            PhiQ = np.tensordot(P, WP, axes=(1, 0))  # (g, n, cols)
            four[2] += np.tensordot(B, PhiQ, axes=(0, 0))
