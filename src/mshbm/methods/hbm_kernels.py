"""Compiled AFT kernel of HBM: element forces and their Jacobian in one pass (numba, raw arrays).

Notation (:mod:`mshbm.methods.hbm`): ``n_h`` harmonics, ``nc = 2 n_h + 1`` real coefficients per DOF,
``N_s`` AFT samples, ``n_N`` nonlinear DOFs (columns of the kept unknowns the elements act on).
``Vs`` (``N_s x nc``) is the inverse DFT (coefficients -> samples), ``VsOm = Vs Om`` the same for
the velocity, ``E`` (``nc x N_s``) the DFT (samples -> coefficients).

:func:`aft_forces` fuses, for single-DOF elements with the regularised laws of
:meth:`mshbm.elements.Element.regularised_law` (no relative element, no history):

1. samples ``q = Vs Xn``, ``u = VsOm Xn`` of the nonlinear DOFs (only where an element needs them),
2. the laws (``kind`` 0: friction eq. 42, ``lambda = -a arctan(kappa w u)``, ``a = 2 mu F_N / pi``;
   ``kind`` 1: penalty contact eq. 45, ``lambda = -(k_c g + d_c w u)`` while ``g = gap + w q <= 0``),
3. the force coefficients ``Fn = E f`` (``f = sum_j w_j lambda_j`` per DOF),
4. with ``jac``, the diagonal-in-DOF Jacobian blocks ``Jn[:, i, :, i] = E diag(df/dq) Vs +
   E diag(df/du) VsOm``, summed over the samples where the derivative is nonzero only (a contact is
   closed on a small share of the period).

:func:`aft_forces_numpy` is its plain NumPy twin (tested against it in ``tests/unit/test_hbm_kernels.py``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: law codes of :func:`aft_forces`
KIND_FRICTION, KIND_CONTACT, KIND_LOADED_FRICTION = 0, 1, 2


@njit(cache=True)
def aft_forces(Xn, Vs, VsOm, E, kind, col, sign, p1, p2, p3, jac, Fn, Jn, kw):  # pragma: no cover - compiled
    """Fill ``Fn`` (``nc x n_N``) and, with ``jac``, ``Jn`` (``nc x n_N x nc x n_N``, zeroed here).

    Per element ``j``: ``kind[j]`` (0 friction, 1 contact), ``col[j]`` its column in ``Xn``,
    ``sign[j]`` its direction ``w``; friction ``p1 = 2 mu F_N / pi``, ``p2 = kappa``; contact
    ``p1 = gap``, ``p2 = k_c``, ``p3 = d_c``.  ``kw`` (shape ``(n_h,)``, rad/s): the frequencies ``k omega``
    when ``Vs``, ``VsOm``, ``E`` are the uniform-grid matrices of :mod:`mshbm.fourier` (then the Jacobian
    blocks come from the trigonometric sums of :func:`_trig_block`); empty: any matrices, blocks by products.
    """
    Ns, nc = Vs.shape
    nN = Xn.shape[1]
    m = kind.shape[0]
    f = np.zeros((Ns, nN))
    dq = np.zeros((Ns, nN))
    du = np.zeros((Ns, nN))
    ub = np.empty(Ns)
    qb = np.empty(Ns)
    for j in range(m):
        c = col[j]
        w = sign[j]
        # samples u(t_s) (and q(t_s) for contacts), summed over k in order for each s; the loop over s
        # inside keeps the samples' sums independent (no chain of dependent additions)
        ub[:] = 0.0
        for k in range(nc):
            xk = Xn[k, c]
            for s in range(Ns):
                ub[s] += VsOm[s, k] * xk
        if kind[j] != 0:
            qb[:] = 0.0
            for k in range(nc):
                xk = Xn[k, c]
                for s in range(Ns):
                    qb[s] += Vs[s, k] * xk
        for s in range(Ns):
            us = ub[s]
            if kind[j] == 0:
                ku = p2[j] * w * us
                f[s, c] += w * (-p1[j] * math.atan(ku))
                du[s, c] += -p1[j] * p2[j] / (1.0 + ku * ku)
            else:
                g = p1[j] + w * qb[s]
                if g <= 0.0:
                    f[s, c] += w * (-(p2[j] * g + p3[j] * w * us))
                    dq[s, c] += -p2[j]
                    du[s, c] += -p3[j]
    _synthesis(E, f, Fn, nN, nc, Ns)
    if not jac:
        return
    Jn[:] = 0.0
    idx = np.empty(Ns, dtype=np.int64)
    for i in range(nN):
        n_act = 0
        for s in range(Ns):
            if dq[s, i] != 0.0 or du[s, i] != 0.0:
                idx[n_act] = s
                n_act += 1
        if n_act == 0:
            continue
        if kw.shape[0] > 0:  # uniform grid: O(n_act n_h + nc^2) by the product-to-sum identities
            _trig_block(dq[:, i], du[:, i], idx[:n_act], Ns, kw, Jn, i)
        elif 4 * n_act > Ns:  # dense: two matrix products
            Ed = np.empty((nc, Ns))
            Eu = np.empty((nc, Ns))
            for a in range(nc):
                for s in range(Ns):
                    Ed[a, s] = E[a, s] * dq[s, i]
                    Eu[a, s] = E[a, s] * du[s, i]
            B = Ed @ Vs + Eu @ VsOm
            for a in range(nc):
                for b in range(nc):
                    Jn[a, i, b, i] = B[a, b]
        else:
            _accumulate(E, Vs, VsOm, idx, n_act, dq[:, i], du[:, i], Jn, i, i, nc)


@njit(cache=True)
def _accumulate(E, Vs, VsOm, idx, n_act, cq_s, cu_s, Jn, i, k, nc):  # pragma: no cover - compiled
    """``Jn[:, i, :, k] += sum_s E[:, s] (cq_s[s] Vs[s] + cu_s[s] VsOm[s])`` over the active samples ``idx[:n_act]``
    (the sample by sample sum of the kernels' Jacobian, in order)."""
    for t in range(n_act):
        s = idx[t]
        cq = cq_s[s]
        cu = cu_s[s]
        for a in range(nc):
            ea = E[a, s]
            if ea == 0.0:
                continue
            for b in range(nc):
                Jn[a, i, b, k] += ea * (cq * Vs[s, b] + cu * VsOm[s, b])


@njit(cache=True)
def _synthesis(E, f, Fn, nN, nc, Ns):  # pragma: no cover - compiled
    """``Fn = E f`` (shapes ``(nc, Ns) x (Ns, nN)``), summed over the samples in order; samples without force (an
    open contact) add nothing."""
    for i in range(nN):
        for a in range(nc):
            Fn[a, i] = 0.0
        for s in range(Ns):
            fs = f[s, i]
            if fs == 0.0:
                continue
            for a in range(nc):
                Fn[a, i] += E[a, s] * fs


@njit(cache=True)
def _trig_block(dq, du, idx, Ns, kw, Jn, i):  # pragma: no cover - compiled
    """``Jn[:, i, :, i] = E diag(dq) Vs + E diag(du) Vs Om`` on the uniform grid ``theta_s = 2 pi s / N_s``
    (``E``, ``Vs``, ``Om`` of :mod:`mshbm.fourier`: rows/columns ``1, cos k theta, sin k theta``, ``E`` scaled
    ``1/N_s``, ``2/N_s``).  With ``C_d(m) = sum_s d_s cos(m theta_s) / N_s`` and ``S_d(m)`` (sine), ``m <= 2 n_h``,
    summed over the samples ``idx`` where ``d`` is nonzero, ``2 cos a cos b = cos(a-b) + cos(a+b)``,
    ``2 cos a sin b = sin(a+b) - sin(a-b)``, ``2 sin a cos b = sin(a+b) + sin(a-b)``,
    ``2 sin a sin b = cos(a-b) - cos(a+b)`` give every entry; ``X Om`` maps column ``cos k`` to ``-k omega``
    times column ``sin k`` and ``sin k`` to ``k omega`` times ``cos k``."""
    nh = kw.shape[0]
    nc = 2 * nh + 1
    M = 2 * nh + 1
    Cq, Sq, Cu, Su = np.zeros(M), np.zeros(M), np.zeros(M), np.zeros(M)
    two_pi_n = 2.0 * math.pi / Ns
    n_act = idx.shape[0]
    table = n_act * M > Ns  # cos, sin of the grid's Ns phases once, then looked up (the same numbers)
    ct = np.empty(Ns if table else 0)
    st = np.empty(Ns if table else 0)
    if table:
        for r in range(Ns):
            ct[r] = math.cos(two_pi_n * r)
            st[r] = math.sin(two_pi_n * r)
    for t in range(n_act):
        s = idx[t]
        a, b = dq[s], du[s]
        for m in range(M):
            r = (m * s) % Ns
            if table:
                c, sn = ct[r], st[r]
            else:
                ph = two_pi_n * r
                c, sn = math.cos(ph), math.sin(ph)
            Cq[m] += a * c
            Sq[m] += a * sn
            Cu[m] += b * c
            Su[m] += b * sn
    inv = 1.0 / Ns
    for m in range(M):
        Cq[m] *= inv
        Sq[m] *= inv
        Cu[m] *= inv
        Su[m] *= inv
    Bq = np.empty((nc, nc))
    Bu = np.empty((nc, nc))
    for r in range(2):
        C = Cq if r == 0 else Cu
        S = Sq if r == 0 else Su
        B = Bq if r == 0 else Bu
        B[0, 0] = C[0]
        for kb in range(1, nh + 1):
            B[0, 2 * kb - 1] = C[kb]
            B[0, 2 * kb] = S[kb]
        for ka in range(1, nh + 1):
            B[2 * ka - 1, 0] = 2.0 * C[ka]
            B[2 * ka, 0] = 2.0 * S[ka]
            for kb in range(1, nh + 1):
                dm = ka - kb
                cd = C[abs(dm)]
                sd = S[dm] if dm >= 0 else -S[-dm]
                B[2 * ka - 1, 2 * kb - 1] = cd + C[ka + kb]
                B[2 * ka - 1, 2 * kb] = S[ka + kb] - sd
                B[2 * ka, 2 * kb - 1] = S[ka + kb] + sd
                B[2 * ka, 2 * kb] = cd - C[ka + kb]
    for a in range(nc):
        Jn[a, i, 0, i] = Bq[a, 0]
        for k in range(1, nh + 1):
            w = kw[k - 1]
            Jn[a, i, 2 * k - 1, i] = Bq[a, 2 * k - 1] - w * Bu[a, 2 * k]
            Jn[a, i, 2 * k, i] = Bq[a, 2 * k] + w * Bu[a, 2 * k - 1]


@njit(cache=True)
def element_forces(q, u, kind, col, sign, p1, p2, p3, lam):  # pragma: no cover - compiled
    """Element forces ``lam[s, j] = lambda_j(t_s)`` of the laws of :func:`aft_forces` at samples ``q, u``
    (``N_s x n_N``) of the nonlinear DOFs (the formulas of :meth:`mshbm.elements.Element.regularised_law`:
    friction ``-p1 arctan(p2 w u)``, contact ``-(p2 g + p3 w u)`` while ``g = p1 + w q <= 0``)."""
    for j in range(kind.shape[0]):
        c = col[j]
        w = sign[j]
        for s in range(q.shape[0]):
            gamma = w * u[s, c]
            if kind[j] == 0:
                lam[s, j] = -p1[j] * math.atan(p2[j] * gamma)
            else:
                g = p1[j] + w * q[s, c]
                lam[s, j] = -(p2[j] * g + p3[j] * gamma) if g <= 0.0 else 0.0


def aft_forces_numpy(Xn, Vs, VsOm, E, kind, col, sign, p1, p2, p3, jac=True):
    """NumPy twin of :func:`aft_forces`: returns ``(Fn, Jn)`` (``Jn`` None without ``jac``)."""
    Ns, nc = Vs.shape
    nN = Xn.shape[1]
    q, u = Vs @ Xn, VsOm @ Xn
    f, dq, du = np.zeros((Ns, nN)), np.zeros((Ns, nN)), np.zeros((Ns, nN))
    for j in range(kind.size):
        c, w = col[j], sign[j]
        if kind[j] == KIND_FRICTION:
            ku = p2[j] * w * u[:, c]
            f[:, c] += -w * p1[j] * np.arctan(ku)
            du[:, c] += -p1[j] * p2[j] / (1.0 + ku * ku)
        else:
            g = p1[j] + w * q[:, c]
            closed = g <= 0.0
            f[:, c] += np.where(closed, -w * (p2[j] * g + p3[j] * w * u[:, c]), 0.0)
            dq[:, c] += np.where(closed, -p2[j], 0.0)
            du[:, c] += np.where(closed, -p3[j], 0.0)
    Fn = E @ f
    if not jac:
        return Fn, None
    Jn = np.zeros((nc, nN, nc, nN))
    for i in range(nN):
        Jn[:, i, :, i] = (E * dq[:, i]) @ Vs + (E * du[:, i]) @ VsOm
    return Fn, Jn


@njit(cache=True)
def aft_forces_loaded(Xn, Vs, VsOm, E, kind, col, sign, p1, p2, p3, load, jac, Fn, Jn, kw):  # pragma: no cover
    """:func:`aft_forces` with frictions loaded by a contact (``kind`` 2, ``load[j]`` the index of the contact
    among the elements, a ``kind`` 1 row; ``-1`` for the others): ``lambda_T = mu (N_0 + max(lambda_N, 0))
    phi(gamma_T)``, ``phi = -(2/pi) arctan(kappa gamma_T)`` (:meth:`mshbm.elements.Friction.coupled_law`), with
    ``p1 = mu``, ``p2 = kappa``, ``p3 = N_0``.  Its Jacobian couples the friction's DOF to the contact's through
    ``lambda_N``: blocks ``Jn[:, i, :, k] = E diag(dq_ik) Vs + E diag(du_ik) VsOm`` for every pair of DOFs (``i, k``)
    with a nonzero derivative, each as the diagonal blocks of :func:`aft_forces` (``kw``: the same meaning)."""
    Ns, nc = Vs.shape
    nN = Xn.shape[1]
    m = kind.shape[0]
    q = Vs @ Xn
    u = VsOm @ Xn
    f = np.zeros((Ns, nN))
    dq = np.zeros((nN, nN, Ns))
    du = np.zeros((nN, nN, Ns))
    lam = np.zeros((Ns, m))
    dls = np.zeros((Ns, m))
    dlg = np.zeros((Ns, m))
    for rnd in range(2):  # the contacts and the unloaded frictions first, then the frictions they load
        for j in range(m):
            if (kind[j] == 2) != (rnd == 1):
                continue
            c = col[j]
            w = sign[j]
            for s in range(Ns):
                gamma = w * u[s, c]
                if kind[j] == 0:
                    ku = p2[j] * gamma
                    f[s, c] += w * (-p1[j] * math.atan(ku))
                    du[c, c, s] += w * w * (-p1[j] * p2[j] / (1.0 + ku * ku))
                elif kind[j] == 1:
                    g = p1[j] + w * q[s, c]
                    if g <= 0.0:
                        lj = -(p2[j] * g + p3[j] * gamma)
                        lam[s, j] = lj
                        dls[s, j] = -p2[j]
                        dlg[s, j] = -p3[j]
                        f[s, c] += w * lj
                        dq[c, c, s] += w * w * (-p2[j])
                        du[c, c, s] += w * w * (-p3[j])
                else:
                    jc = load[j]
                    cn = col[jc]
                    wn = sign[jc]
                    ln = lam[s, jc]
                    pos = ln > 0.0
                    FN = p3[j] + (ln if pos else 0.0)
                    ku = p2[j] * gamma
                    phi = -(2.0 / math.pi) * math.atan(ku)
                    dphi = -(2.0 / math.pi) * p2[j] / (1.0 + ku * ku)
                    f[s, c] += w * (p1[j] * FN * phi)
                    du[c, c, s] += w * w * (p1[j] * FN * dphi)
                    if pos:
                        dq[c, cn, s] += (w * wn) * (p1[j] * phi * dls[s, jc])
                        du[c, cn, s] += (w * wn) * (p1[j] * phi * dlg[s, jc])
    _synthesis(E, f, Fn, nN, nc, Ns)
    if not jac:
        return
    Jn[:] = 0.0
    idx = np.empty(Ns, dtype=np.int64)
    Jt = np.zeros((nc, 1, nc, 1))
    for i in range(nN):
        for k in range(nN):
            n_act = 0
            for s in range(Ns):
                if dq[i, k, s] != 0.0 or du[i, k, s] != 0.0:
                    idx[n_act] = s
                    n_act += 1
            if n_act == 0:
                continue
            if kw.shape[0] > 0:
                _trig_block(dq[i, k], du[i, k], idx[:n_act], Ns, kw, Jt, 0)
                for a in range(nc):
                    for b in range(nc):
                        Jn[a, i, b, k] = Jt[a, 0, b, 0]
            else:
                _accumulate(E, Vs, VsOm, idx, n_act, dq[i, k], du[i, k], Jn, i, k, nc)
