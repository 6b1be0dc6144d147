"""Compiled Moreau-Jean kernel on raw arrays (and a plain NumPy twin for tests).

One step of the theta-method from ``(q, u)`` at ``t_k`` with step ``h``
(``W = (M + h theta C + h^2 theta^2 K)^-1``)::

    u_free = u + b_k - Aq q - Au u              b_k = h W f_theta,k
                                               Aq = h W K, Au = h W C + h^2 theta W K
    u+     = u_free + WG P                      P: impulses of the m elements
    q+     = q + h ((1 - theta) u + theta u+)

with ``f_theta,k = (1 - theta) f(t_k) + theta f(t_{k+1})``.  Element ``j`` acts on
``dof[j]`` with direction ``sign[j]``; its relative velocity is
``gamma_j = sign[j] u[dof[j]]``.  A *relative* element (``dof2[j] >= 0``) acts between two
DOFs, ``w_j = sign[j] (e_dof[j] - e_dof2[j])`` and ``gamma_j = sign[j] (u[dof[j]] - u[dof2[j]])``;
``dof2[j] = -1`` is the ground (the one-DOF arithmetic is unchanged).  The local problem, with the Delassus matrix
``D = G^T W G``, is:

* cone partners (``tpair``, the two tangential directions of a 3-D contact): the disk
  ``||(P_j, P_k)|| <= bound_j (+ mu_n[j] P_c)``, stick ``gamma_T+ = 0`` inside, else
  ``gamma_T+ = -alpha P_T`` (maximal dissipation);
* friction (kind 0): ``gamma_j+ = 0`` if ``|P_j| < bound_j = h mu F_N`` else
  ``P_j = -bound_j sign(gamma_j+)``; a friction whose normal load comes from a contact
  (``nsrc[j] = c >= 0``, coefficient ``mu_n[j]``) has the bound ``bound_j + mu_n[j] P_c``
  (Coulomb's cone on the impulse level, ``|P_T| <= mu (h N_0 + P_N)``, ``bound_j = h mu N_0`` the
  preload part), updated in every projected Gauss-Seidel sweep;
* contact (kind 1), active when the free end-of-step gap
  ``g_j(q + h((1-theta)u + theta u_free)) <= 0``:
  ``0 <= gamma_j+ + e_j gamma_j- _|_ P_j >= 0`` (Newton's law, ``gamma-`` at
  the start of the step); inactive: ``P_j = 0``;
* smooth (kind 2, a polynomial spring ``lambda_j = sum_p poly[j, p] s^p``, :class:`mshbm.elements.Polynomial`):
  Moreau's midpoint rule evaluates the position-dependent force at ``q_M = q + h/2 u`` (the start of the
  step, whatever ``theta``), known before the step: its impulse ``P_j = h lambda_j(w_j^T q_M)`` is added
  to the free velocity (``u_free += W w_j P_j``), so no iteration is needed, and the element takes no part
  in the local problem (status open).  Its sensitivity ``dP_j = h lambda_j'(s_M) w_j^T (dq + h/2 du)``
  enters ``d u_free`` likewise.

One element is solved in closed form; several by projected Gauss-Seidel on
``D`` (exact to ``tol``), a friction loaded by a contact (that loads no other friction) together
with it as one exactly solved 2x2 block (:func:`_pair_solve`; with scalar updates instead, the
sweeps did not converge in 500 iterations for ``mu = 2`` and ``D_TN / D_TT = 0.67``).  After the step a contact that penetrates is projected
back onto ``g_j = 0`` in the metric of ``M`` (no-op for ``e_N = 1``).

Sensitivities with respect to ``(q0, u0, p)``, where the forcing increment
depends on parameters ``p`` through ``db_k/dp = dB[k]``, are propagated exactly
for the current active set (a stick/closed element has ``dP`` from the linear
equality, a slip/open one ``dP = 0``; a slipping friction with its normal load from a closed contact
``c``: ``dP_j = sign(P_j) mu_n[j] dP_c``, solved together with the equality rows).
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
from numba import njit
from .._deferred import brentq


def _drop_stale_cache():
    """Numba's on-disk cache of this module's kernels is keyed on this file only, but the kernels compile in the
    jitted functions of :mod:`.local_problem`: an edit there alone would keep the old machine code.  A stamp of
    both sources next to the cache drops this module's cache files when either changed."""
    here = Path(__file__).resolve().parent
    cache = here / "__pycache__"
    try:
        sources = (here / "local_problem.py", Path(__file__))
        digest = hashlib.sha256(b"".join(f.read_bytes() for f in sources)).hexdigest()
        stamp = cache / "kernels.sources.sha256"
        if stamp.is_file() and stamp.read_text() == digest:
            return
        cache.mkdir(exist_ok=True)
        for f in cache.glob("kernels.*.nb[ic]"):
            f.unlink(missing_ok=True)
        stamp.write_text(digest)
    except OSError:  # a read-only installation: numba then keeps no cache of its own either
        pass


_drop_stale_cache()

from .local_problem import (KIND_CONTACT, KIND_FRICTION, KIND_SMOOTH, STATUS_CLOSED, STATUS_OPEN,  # noqa: E402,F401
                            STATUS_PROJECTED, STATUS_SLIP, STATUS_STICK, _local_solve, _rel, _sens_row, _solve_small)


@njit(cache=True)
def _disk_slip_row(a, j, k, idx, where, n_eq, status, P, r, Del, dof, dof2, sign, nsrc, mu_n, dUf, A, R):
    """Sensitivity row ``a`` of friction ``j`` slipping on the disk it shares with its cone partner ``k``.

    With ``P_T = b d`` (``d`` the unit slip direction, ``gamma_T = -||gamma_T|| d``)::

        dP_T = d db - (b / ||gamma_T||) (I - d d^T) dgamma_T,   dgamma_T = dr_T + D_T. dP,  db = mu_n dP_c

    (``db`` only while the loading contact ``c`` is closed).  Fills ``A[a]``, ``R[a]`` and returns True; False
    (the caller writes the stick row ``dgamma_j = 0``) where ``gamma_T`` vanishes to rounding (slip onset).
    """
    g1 = r[j]
    g2 = r[k]
    for i in range(P.shape[0]):
        g1 += Del[j, i] * P[i]
        g2 += Del[k, i] * P[i]
    gn = np.sqrt(g1 * g1 + g2 * g2)
    b = np.sqrt(P[j] * P[j] + P[k] * P[k])
    if b <= 0.0 or gn <= 1e-13 * (abs(r[j]) + abs(r[k])):
        return False
    inv = b / gn
    dj = P[j] / b
    dk = P[k] / b
    pj = 1.0 - dj * dj  # row j of I - d d^T
    pk = -dj * dk
    for bb in range(n_eq):
        A[a, bb] = inv * (pj * Del[j, idx[bb]] + pk * Del[k, idx[bb]])
    A[a, a] += 1.0
    c = nsrc[j]
    if c >= 0 and (status[c] & 3) == STATUS_CLOSED:
        A[a, where[c]] -= dj * mu_n[j]
    for cc in range(R.shape[1]):
        drj = _rel(dUf[:, cc], dof[j], dof2[j], sign[j])
        drk = _rel(dUf[:, cc], dof[k], dof2[k], sign[k])
        R[a, cc] = -inv * (pj * drj + pk * drk)
    return True


@njit(cache=True)
def _moreau_jean_scalar(q0, u0, aq, au, wg, dl, minvg, B, dB, theta, h, kind, sign, bound, gap, e, project,
                        want_sens, store_q_sens):
    """:func:`moreau_jean` for one DOF and one element, in scalar arithmetic (same results)."""
    N = B.shape[0]
    n_p = dB.shape[2]
    n_s = 2 + n_p if want_sens else 0
    qt = np.empty((N + 1, 1))
    ut = np.empty((N + 1, 1))
    Pt = np.zeros((N, 1))
    st = np.zeros((N, 1), dtype=np.int8)
    Sq = np.zeros((1, n_s))
    Su = np.zeros((1, n_s))
    if want_sens:
        Sq[0, 0] = 1.0
        Su[0, 1] = 1.0
    Sqt = np.zeros((N + 1 if store_q_sens else 0, 1, n_s))
    if store_q_sens:
        Sqt[0, 0, :] = Sq[0, :]
    sq = Sq[0].copy()
    su = Su[0].copy()
    duf = np.empty(n_s)
    q = q0[0]
    u = u0[0]
    qt[0, 0] = q
    ut[0, 0] = u
    c1 = h * (1.0 - theta)
    c2 = h * theta
    friction = kind == KIND_FRICTION
    for k in range(N):
        uf = u + B[k, 0] - aq * q - au * u
        # local problem (closed form)
        P = 0.0
        stat = STATUS_OPEN
        if friction:
            if bound > 0.0:
                p = -sign * uf / dl
                if p >= bound:
                    P = bound
                    stat = STATUS_SLIP
                elif p <= -bound:
                    P = -bound
                    stat = STATUS_SLIP
                else:
                    P = p
                    stat = STATUS_STICK
        elif gap + sign * (q + c1 * u + c2 * uf) <= 0.0:
            p = -(sign * uf + e * sign * u) / dl
            if p > 0.0:
                P = p
                stat = STATUS_CLOSED
        un = uf + wg * P
        qn = q + c1 * u + c2 * un
        if want_sens:
            eq = stat == STATUS_STICK or stat == STATUS_CLOSED
            ee = 0.0 if friction else e
            for c in range(n_s):
                d = su[c] - aq * sq[c] - au * su[c]
                if c >= 2:
                    d += dB[k, 0, c - 2]
                duf[c] = d
            for c in range(n_s):
                dun = duf[c]
                if eq:
                    dun += wg * (-sign * (duf[c] + ee * su[c]) / dl)
                sq[c] = sq[c] + c1 * su[c] + c2 * dun
                su[c] = dun
        if project and not friction:
            g = gap + sign * qn
            if g < 0.0:
                w = sign * minvg
                qn += minvg * (-g / w)
                stat += STATUS_PROJECTED
                if want_sens:
                    for c in range(n_s):
                        sq[c] += minvg * (-sign * sq[c] / w)
        q = qn
        u = un
        qt[k + 1, 0] = q
        ut[k + 1, 0] = u
        Pt[k, 0] = P
        st[k, 0] = stat
        if store_q_sens:
            for c in range(n_s):
                Sqt[k + 1, 0, c] = sq[c]
    for c in range(n_s):
        Sq[0, c] = sq[c]
        Su[0, c] = su[c]
    return qt, ut, Pt, st, Sq, Su, Sqt, 1


@njit(cache=True)
def moreau_jean(q0, u0, Aq, Au, WG, Del, MinvG, B, dB, theta, h,
                kind, dof, dof2, sign, bound, gap, e, nsrc, mu_n, tpair, project,
                want_sens, store_q_sens, tol, max_iter, n_slider, poly):
    """Integrate ``N = B.shape[0]`` Moreau-Jean steps.

    Parameters
    ----------
    q0, u0 : (n,) initial displacement and velocity.
    Aq, Au : (n, n) step matrices ``hWK`` and ``hWC + h^2 theta WK``.
    WG : (n, m) ``W G``;  Del : (m, m) ``G^T W G``;  MinvG : (n, m) ``M^-1 G``.
    B : (N, n) forcing increments ``b_k``;  dB : (N, n, n_p) their parameter derivatives.
    theta, h : scheme parameter and step (s).
    kind, dof, dof2, sign, bound, gap, e : (m,) element data; ``bound = h mu F_N``; ``dof2 = -1``
        for an element on one DOF, else the second DOF of a relative element.
    nsrc, mu_n : (m,) normal-load coupling of friction elements: ``nsrc[j]`` the index of the contact
        whose impulse loads friction ``j`` (bound ``bound[j] + mu_n[j] P[nsrc[j]]``), ``-1``: none.
    tpair : (m,) cone partner of friction ``j`` (the other tangential direction of a 3-D contact: the two
        impulses share the disk ``||(P_j, P_tpair[j])|| <= bound``), ``-1``: none.
    project : bool, project penetrating contacts back to ``g = 0``.
    want_sens : bool, propagate sensitivities w.r.t. ``(q0, u0, p)``.
    store_q_sens : bool, also store ``dq_k/d(q0,u0,p)`` at every step.

    Returns
    -------
    q, u : (N+1, n) trajectory;  P : (N, m) impulses;  status : (N, m) int8;
    Sq, Su : (n, n_s) end sensitivities, ``n_s = 2n + n_p`` (empty if not wanted);
    Sq_traj : (N+1, n, n_s) if ``store_q_sens`` else empty;  max_iter_used : int.

    ``poly``: (m, n_c) coefficients of the smooth elements (kind 2), ``lambda_j = sum_p poly[j, p] s^p``
    (rows of the other elements unused).

    ``n_slider``: the last ``n_slider`` DOFs are massless sliders of Jenkins elements
    (:func:`mshbm.integrators.moreau_jean._with_sliders`), stepped with ``theta = 1``
    (``q+ = q + h u+``) so that their velocity is no state; ``Aq, Au, WG`` must be built alike.
    """
    N = B.shape[0]
    n = q0.shape[0]
    m = kind.shape[0]
    if n == 1 and m == 1 and n_slider == 0 and kind[0] != KIND_SMOOTH:
        return _moreau_jean_scalar(q0, u0, Aq[0, 0], Au[0, 0], WG[0, 0], Del[0, 0], MinvG[0, 0], B, dB, theta, h,
                                   kind[0], sign[0], bound[0], gap[0], e[0], project, want_sens, store_q_sens)
    n_p = dB.shape[2]
    n_s = 2 * n + n_p if want_sens else 0
    qt = np.empty((N + 1, n))
    ut = np.empty((N + 1, n))
    Pt = np.zeros((N, m))
    st = np.zeros((N, m), dtype=np.int8)
    Sq = np.zeros((n, n_s))
    Su = np.zeros((n, n_s))
    if want_sens:
        for i in range(n):
            Sq[i, i] = 1.0
            Su[i, n + i] = 1.0
    Sqt = np.zeros((N + 1 if store_q_sens else 0, n, n_s))
    if store_q_sens:
        Sqt[0] = Sq
    q = q0.copy()
    u = u0.copy()
    qt[0] = q
    ut[0] = u
    uf = np.empty(n)
    un = np.empty(n)
    qn = np.empty(n)
    P = np.zeros(m)
    status = np.zeros(m, dtype=np.int8)
    fgap = np.empty(m)
    rwork = np.empty(m)
    awork = np.empty(m, dtype=np.bool_)
    dUf = np.empty((n, n_s))
    dUn = np.empty((n, n_s))
    dQn = np.empty((n, n_s))
    dP = np.zeros((m, n_s))
    used = 0
    n_smooth = 0
    for j in range(m):
        if kind[j] == KIND_SMOOTH:
            n_smooth += 1
    Ps = np.zeros(m)  # explicit impulses of the smooth elements
    dls = np.zeros(m)  # their d lambda / d s at q_M
    c1v = np.empty(n)
    c2v = np.empty(n)
    for i in range(n):
        if i < n - n_slider:
            c1v[i] = h * (1.0 - theta)
            c2v[i] = h * theta
        else:
            c1v[i] = 0.0
            c2v[i] = h
    for k in range(N):
        # free velocity
        for i in range(n):
            s = u[i] + B[k, i]
            for j in range(n):
                s -= Aq[i, j] * q[j] + Au[i, j] * u[j]
            uf[i] = s
        # smooth elements: impulse h lambda(w^T q_M), q_M = q + h/2 u, into the free velocity
        if n_smooth > 0:
            for j in range(m):
                if kind[j] == KIND_SMOOTH:
                    d = dof[j]
                    d2 = dof2[j]
                    sm = sign[j] * (q[d] + 0.5 * h * u[d])
                    if d2 >= 0:
                        sm -= sign[j] * (q[d2] + 0.5 * h * u[d2])
                    lam = 0.0
                    dlam = 0.0
                    for p in range(poly.shape[1] - 1, 0, -1):  # Horner
                        dlam = dlam * sm + p * poly[j, p]
                        lam = lam * sm + poly[j, p]
                    lam = lam * sm + poly[j, 0]
                    Ps[j] = h * lam
                    dls[j] = dlam
                    for i in range(n):
                        uf[i] += WG[i, j] * Ps[j]
        # predicted free end-of-step gap of contacts
        for j in range(m):
            if kind[j] == KIND_CONTACT:
                d = dof[j]
                d2 = dof2[j]
                if d2 < 0:
                    fgap[j] = gap[j] + sign[j] * (q[d] + c1v[d] * u[d] + c2v[d] * uf[d])
                else:
                    fgap[j] = gap[j] + sign[j] * ((q[d] + c1v[d] * u[d] + c2v[d] * uf[d])
                                                  - (q[d2] + c1v[d2] * u[d2] + c2v[d2] * uf[d2]))
            else:
                fgap[j] = 0.0
        if m > 0:
            it = _local_solve(uf, u, fgap, kind, dof, dof2, sign, bound, e, nsrc, mu_n, tpair, Del, P, status, tol,
                              max_iter, rwork, awork)
            if it > used:
                used = it
        for i in range(n):
            s = uf[i]
            for j in range(m):
                s += WG[i, j] * P[j]
            un[i] = s
            qn[i] = q[i] + c1v[i] * u[i] + c2v[i] * s
        if want_sens:
            if n * n * n_s > 4096:
                dUf[:, :] = Su - np.dot(Aq, Sq) - np.dot(Au, Su)
                for i in range(n):
                    for c in range(n_p):
                        dUf[i, 2 * n + c] += dB[k, i, c]
            else:
                for i in range(n):
                    for c in range(n_s):
                        s = Su[i, c]
                        for j in range(n):
                            s -= Aq[i, j] * Sq[j, c] + Au[i, j] * Su[j, c]
                        if c >= 2 * n:
                            s += dB[k, i, c - 2 * n]
                        dUf[i, c] = s
            if n_smooth > 0:  # dP_j = h lambda'(s_M) w^T (dq + h/2 du)
                for j in range(m):
                    if kind[j] == KIND_SMOOTH:
                        d = dof[j]
                        d2 = dof2[j]
                        for c in range(n_s):
                            ds = sign[j] * (Sq[d, c] + 0.5 * h * Su[d, c])
                            if d2 >= 0:
                                ds -= sign[j] * (Sq[d2, c] + 0.5 * h * Su[d2, c])
                            dps = h * dls[j] * ds
                            if dps != 0.0:
                                for i in range(n):
                                    dUf[i, c] += WG[i, j] * dps
            # impulse sensitivities for equality-active elements and for slipping friction whose
            # bound follows a closed contact (dP_T = sign(P_T) mu dP_N)
            n_eq = 0
            for j in range(m):
                if _sens_row(j, status, nsrc, tpair):
                    n_eq += 1
            for j in range(m):
                for c in range(n_s):
                    dP[j, c] = 0.0
            if n_eq > 0:
                idx = np.empty(n_eq, dtype=np.int64)
                where = np.full(m, -1, dtype=np.int64)
                t = 0
                for j in range(m):
                    if _sens_row(j, status, nsrc, tpair):
                        idx[t] = j
                        where[j] = t
                        t += 1
                A = np.empty((n_eq, n_eq))
                R = np.empty((n_eq, n_s))
                for a in range(n_eq):
                    ja = idx[a]
                    if (status[ja] & 3) == STATUS_SLIP and tpair[ja] >= 0 and _disk_slip_row(
                            a, ja, tpair[ja], idx, where, n_eq, status, P, rwork, Del, dof, dof2, sign, nsrc, mu_n,
                            dUf, A, R):
                        continue
                    if status[ja] == STATUS_SLIP and tpair[ja] < 0:  # coupled slip: dP_T - sign(P_T) mu dP_N = 0
                        for b in range(n_eq):
                            A[a, b] = 0.0
                        A[a, a] = 1.0
                        A[a, where[nsrc[ja]]] = mu_n[ja] if P[ja] < 0.0 else -mu_n[ja]
                        for c in range(n_s):
                            R[a, c] = 0.0
                        continue
                    for b in range(n_eq):
                        A[a, b] = Del[ja, idx[b]]
                    d = dof[ja]
                    d2 = dof2[ja]
                    ee = e[ja] if kind[ja] == KIND_CONTACT else 0.0
                    for c in range(n_s):
                        if d2 < 0:
                            R[a, c] = -sign[ja] * (dUf[d, c] + ee * Su[d, c])
                        else:
                            R[a, c] = -sign[ja] * ((dUf[d, c] - dUf[d2, c]) + ee * (Su[d, c] - Su[d2, c]))
                X = _solve_small(A, R)
                for a in range(n_eq):
                    for c in range(n_s):
                        dP[idx[a], c] = X[a, c]
            for i in range(n):
                for c in range(n_s):
                    s = dUf[i, c]
                    for j in range(m):
                        s += WG[i, j] * dP[j, c]
                    dUn[i, c] = s
                    dQn[i, c] = Sq[i, c] + c1v[i] * Su[i, c] + c2v[i] * s
        # position projection of penetrating contacts (metric M)
        if project:
            for j in range(m):
                if kind[j] == KIND_CONTACT:
                    d = dof[j]
                    d2 = dof2[j]
                    g = gap[j] + _rel(qn, d, d2, sign[j])
                    if g < 0.0:
                        w = _rel(MinvG[:, j], d, d2, sign[j])
                        delta = -g / w
                        for i in range(n):
                            qn[i] += MinvG[i, j] * delta
                        status[j] += STATUS_PROJECTED
                        if want_sens:
                            for c in range(n_s):
                                dd = -_rel(dQn[:, c], d, d2, sign[j]) / w
                                for i in range(n):
                                    dQn[i, c] += MinvG[i, j] * dd
        for i in range(n):
            q[i] = qn[i]
            u[i] = un[i]
            qt[k + 1, i] = qn[i]
            ut[k + 1, i] = un[i]
        for j in range(m):
            Pt[k, j] = Ps[j] if kind[j] == KIND_SMOOTH else P[j]
            st[k, j] = status[j]
        if want_sens:
            for i in range(n):
                for c in range(n_s):
                    Sq[i, c] = dQn[i, c]
                    Su[i, c] = dUn[i, c]
            if store_q_sens:
                Sqt[k + 1] = Sq
    return qt, ut, Pt, st, Sq, Su, Sqt, used


def _disk_numpy(P, j, k, r, Del, b):
    """The impulses of cone partners ``j, k`` with the others fixed: the minimiser of the Delassus block's
    quadratic form on the disk ``||P|| <= b``, ``P = -(A + lam I)^-1 g``, ``lam`` by bisection."""
    jk = [j, k]
    others = [i for i in range(P.size) if i not in jk]
    return _disk_qp(r[jk] + Del[np.ix_(jk, others)] @ P[others], Del[np.ix_(jk, jk)], b)


def _disk_qp(g, A, b):
    """``argmin P^T A P / 2 + g^T P`` on the disk ``||P|| <= b`` (Brent's method on the multiplier)."""
    if b <= 0.0:
        return np.zeros(2)
    p = np.linalg.solve(A, -g)
    if np.linalg.norm(p) <= b:
        return p
    # ||(A + lam I)^-1 g|| = b: decreasing in lam, and <= b at ||g|| / b (Brent's method, to rounding)
    lam = brentq(lambda s: np.linalg.norm(np.linalg.solve(A + s * np.eye(2), g)) - b, 0.0, np.linalg.norm(g) / b,
                 xtol=1e-300, rtol=8.9e-16)
    p = -np.linalg.solve(A + lam * np.eye(2), g)
    return p * (b / np.linalg.norm(p))


def _triple_numpy(P, j, k, c, r, Del, bT, mu, closable):
    """Cone partners ``j, k`` and the contact ``c`` that loads them, the others fixed: for ``P_N >= 0`` the
    disk's ``P_T``; ``P_N = 0`` if then ``gamma_N >= 0``, else the root of ``gamma_N(P_N)`` (Brent's method)."""
    jk = [j, k]
    others = [i for i in range(P.size) if i not in (j, k, c)]
    gT = r[jk] + Del[np.ix_(jk, others)] @ P[others]
    gN = r[c] + Del[c, others] @ P[others]
    A, aTN, aNT = Del[np.ix_(jk, jk)], Del[jk, c], Del[c, jk]
    disk = lambda pn: _disk_qp(gT + aTN * pn, A, bT + mu * pn)
    gamma_n = lambda pn: gN + aNT @ disk(pn) + Del[c, c] * pn
    if not closable or gamma_n(0.0) >= 0.0:
        return np.append(disk(0.0), 0.0)
    hi = 1.0
    for _ in range(2000):
        if gamma_n(hi) >= 0.0:
            break
        hi *= 2.0
    pn = brentq(gamma_n, 0.0, hi, xtol=1e-300, rtol=8.9e-16)
    return np.append(disk(pn), pn)


def moreau_jean_numpy(q0, u0, Aq, Au, WG, Del, MinvG, B, theta, h,
                      kind, dof, sign, bound, gap, e, project=True, dof2=None, n_slider=0, nsrc=None, mu_n=None,
                      tpair=None, poly=None):
    """Plain NumPy version of :func:`moreau_jean` (no sensitivities), for testing.

    One element per step is solved in closed form; several by PGS as in the kernel.
    ``dof2``: second DOF of relative elements (-1: ground; default: all on one DOF).
    ``nsrc, mu_n``: normal-load coupling of friction elements (default: none).
    ``tpair``: cone partners (default: none); a pair's impulse is the minimiser of the Delassus block's
    quadratic form on the disk, found here by Brent's method on the multiplier (the kernel: Newton's iteration);
    with the contact that loads them, the normal impulse by Brent's method on ``gamma_N`` (the kernel: bisection).
    ``poly``: (m, n_c) coefficients of the smooth elements (kind 2), explicit at ``q + h/2 u``.
    Returns ``q, u, P`` with the shapes of the kernel's outputs.
    """
    N, n, m = B.shape[0], q0.size, kind.size
    dof2 = -np.ones(m, dtype=np.int64) if dof2 is None else np.asarray(dof2)
    nsrc = -np.ones(m, dtype=np.int64) if nsrc is None else np.asarray(nsrc)
    mu_n = np.zeros(m) if mu_n is None else np.asarray(mu_n, dtype=float)
    tpair = -np.ones(m, dtype=np.int64) if tpair is None else np.asarray(tpair)
    th = np.full(n, float(theta))
    th[n - n_slider:] = 1.0  # massless slider DOFs: theta = 1
    W = np.zeros((n, m))  # columns w_j
    for j in range(m):
        W[dof[j], j] = sign[j]
        if dof2[j] >= 0:
            W[dof2[j], j] = -sign[j]
    q, u = q0.astype(float).copy(), u0.astype(float).copy()
    qt, ut, Pt = [q.copy()], [u.copy()], np.zeros((N, m))
    smooth = np.flatnonzero(np.asarray(kind) == KIND_SMOOTH)
    for k in range(N):
        uf = u + B[k] - Aq @ q - Au @ u
        Ps = np.zeros(m)
        for j in smooth:  # polynomial spring at q_M = q + h/2 u, explicit
            Ps[j] = h * np.polynomial.polynomial.polyval(W[:, j] @ (q + 0.5 * h * u), poly[j])
        uf = uf + WG @ Ps
        P = np.zeros(m)
        qfree = q + h * (1 - th) * u + h * th * uf
        active = np.array([(bound[j] > 0 or nsrc[j] >= 0) if kind[j] == KIND_FRICTION
                           else (kind[j] != KIND_SMOOTH and gap[j] + W[:, j] @ qfree <= 0)
                           for j in range(m)], dtype=bool)
        r = np.array([W[:, j] @ uf + (e[j] * (W[:, j] @ u) if kind[j] == KIND_CONTACT else 0.0)
                      for j in range(m)])
        # a contact loading exactly the two frictions of one cone: solved with them as one block
        tri = {j: nsrc[j] for j in range(m) if tpair[j] > j and nsrc[j] >= 0 and nsrc[tpair[j]] == nsrc[j]
               and np.count_nonzero(nsrc == nsrc[j]) == 2}
        for _ in range(1 if m == 1 else 1000):
            Pold = P.copy()
            for j in np.flatnonzero(active):
                if j in tri.values():
                    continue
                if j in tri:
                    c = tri[j]
                    P[[j, tpair[j], c]] = _triple_numpy(P, j, tpair[j], c, r, Del, bound[j], mu_n[j], active[c])
                    continue
                if tpair[j] >= 0:
                    if tpair[j] > j:
                        P[[j, tpair[j]]] = _disk_numpy(P, j, tpair[j], r, Del, bound[j] + (
                            mu_n[j] * P[nsrc[j]] if nsrc[j] >= 0 else 0.0))
                    continue
                p = P[j] - (r[j] + Del[j] @ P) / Del[j, j]
                if kind[j] == KIND_FRICTION:
                    b = bound[j] + (mu_n[j] * P[nsrc[j]] if nsrc[j] >= 0 else 0.0)
                    P[j] = np.clip(p, -b, b)
                else:
                    P[j] = max(p, 0.0)
            if np.max(np.abs(P - Pold), initial=0.0) <= 1e-14 * (1 + np.max(np.abs(P), initial=0.0)):
                break
        u_new = uf + WG @ P
        q_new = q + h * ((1 - th) * u + th * u_new)
        if project:
            for j in range(m):
                if kind[j] == KIND_CONTACT:
                    g = gap[j] + W[:, j] @ q_new
                    if g < 0:
                        q_new += MinvG[:, j] * (-g / (W[:, j] @ MinvG[:, j]))
        q, u = q_new, u_new
        qt.append(q.copy())
        ut.append(u.copy())
        Pt[k] = P + Ps
    return np.array(qt), np.array(ut), Pt
