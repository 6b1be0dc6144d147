"""The one-step local problem of the Moreau-Jean kernel (:mod:`mshbm.integrators.kernels`): the element
impulses ``P`` of one step from the free velocity, compiled on raw arrays.

With the Delassus matrix ``D = G^T W G`` of the ``m`` elements (``W = (M + h theta C + h^2 theta^2 K)^-1``,
``G`` their directions) and the free velocity ``u_free``, element ``j`` obeys its law on the impulse level
(friction: stick or slip at ``bound_j = h mu F_N``, plus ``mu_n[j] P_c`` when its normal load comes from
contact ``c``; contact: Newton's law ``0 <= gamma_j+ + e_j gamma_j- _|_ P_j >= 0`` while active).  One
element is solved in closed form, several by projected Gauss-Seidel on ``D``, a friction loaded by a contact
together with it as one exactly solved 2x2 block (:func:`_pair_solve`).  Two frictions that are *cone
partners* (``tpair[j] = k``, ``tpair[k] = j``: the tangential directions of a 3-D contact,
:mod:`mshbm.elements.cone`) share the disk ``||(P_j, P_k)|| <= b`` (``b = bound_j + mu_n[j] P_c``) and are one
block of the sweep, solved exactly for the current ``b`` (:func:`_disk_solve`); with the contact that loads
them (and no other friction) the three are one exactly solved block (:func:`_triple_solve`: the normal
impulse by bisection on ``gamma_N``, the disk's tangential impulse for each).  Element kinds and status
codes are the constants of this module.
"""
from __future__ import annotations

import numpy as np
from numba import njit

KIND_FRICTION = 0
KIND_CONTACT = 1
#: a smooth force evaluated explicitly before the step (polynomial spring): no local problem, never active
KIND_SMOOTH = 2

# status codes per element and step
STATUS_OPEN = 0      # contact inactive / impulse zero
STATUS_SLIP = 1      # friction at its bound
STATUS_STICK = 2     # friction stick (gamma+ = 0)
STATUS_CLOSED = 3    # contact active with P > 0 (gamma+ + e gamma- = 0)
STATUS_PROJECTED = 4  # flag added when the position of a contact was projected


@njit(cache=True)
def _rel(x, d, d2, s):
    """``w^T x`` of an element: ``s x[d]`` (ground, ``d2 < 0``) or ``s (x[d] - x[d2])``."""
    if d2 < 0:
        return s * x[d]
    return s * (x[d] - x[d2])


@njit(cache=True)
def _assign(P, i, v, change, scale):
    """``P[i] = v`` in a projected Gauss-Seidel sweep; returns ``(change, scale)`` updated by ``|v - P[i]|`` and
    ``|v|`` (the sweep's convergence test ``change <= tol (1 + scale)``)."""
    d = abs(v - P[i])
    if d > change:
        change = d
    if abs(v) > scale:
        scale = abs(v)
    P[i] = v
    return change, scale


@njit(cache=True)
def _local_solve(uf, u, q_free_gap, kind, dof, dof2, sign, bound, e, nsrc, mu_n, tpair, Del, P, status, tol,
                 max_iter, r, active):
    """Solve the local impulse problem; fills P and status; returns iterations.

    ``r`` and ``active`` are work arrays of length m (right-hand sides
    ``gamma_free + e gamma_minus`` and the active flags).
    """
    m = kind.shape[0]
    for j in range(m):
        gf = _rel(uf, dof[j], dof2[j], sign[j])
        if kind[j] == KIND_FRICTION:
            r[j] = gf
            active[j] = bound[j] > 0.0 or nsrc[j] >= 0
        elif kind[j] == KIND_SMOOTH:  # its impulse is in the free velocity already
            r[j] = 0.0
            active[j] = False
        else:
            r[j] = gf + e[j] * _rel(u, dof[j], dof2[j], sign[j])
            active[j] = q_free_gap[j] <= 0.0
        P[j] = 0.0
    it = 0
    if m == 1:
        it = 1
        if active[0]:
            if kind[0] == KIND_FRICTION:
                p = -r[0] / Del[0, 0]
                if p > bound[0]:
                    p = bound[0]
                elif p < -bound[0]:
                    p = -bound[0]
                P[0] = p
            else:
                p = -r[0] / Del[0, 0]
                P[0] = p if p > 0.0 else 0.0
    else:
        # a contact loading exactly one friction forms a pair solved exactly as a 2x2 block
        # (:func:`_pair_solve`) inside the sweep; pair[j] = c for its friction j, -2 for the contact c
        pair = np.full(m, -1, dtype=np.int64)
        for j in range(m):
            if nsrc[j] >= 0:
                pair[nsrc[j]] = -2 if pair[nsrc[j]] == -1 else -3  # -3: loads several frictions
        for j in range(m):
            if nsrc[j] >= 0 and pair[nsrc[j]] == -2:
                pair[j] = nsrc[j]
            if tpair[j] >= 0:
                pair[j] = -4  # a cone partner: solved with its partner as one disk block
        for c in range(m):
            if pair[c] == -3:
                pair[c] = -1
        # a contact loading exactly the two frictions of one cone: the three solved exactly as one block
        # (:func:`_triple_solve`) at the cone's first friction; the contact is then skipped (pair -2)
        tri = np.zeros(m, dtype=np.bool_)
        for j in range(m):
            k = tpair[j]
            if k > j and nsrc[j] >= 0 and nsrc[k] == nsrc[j]:
                n_load = 0
                for i in range(m):
                    if nsrc[i] == nsrc[j]:
                        n_load += 1
                if n_load == 2:
                    tri[j] = True
                    pair[nsrc[j]] = -2
        for it in range(1, max_iter + 1):
            change = 0.0
            scale = 0.0
            for j in range(m):
                if pair[j] == -2 or (not active[j] and pair[j] < 0):
                    continue  # a paired contact is solved with its friction
                if pair[j] == -4:
                    k = tpair[j]
                    if k < j:
                        continue  # the block is solved at its first element
                    g1 = r[j]
                    g2 = r[k]
                    for i in range(m):
                        if i != j and i != k:
                            g1 += Del[j, i] * P[i]
                            g2 += Del[k, i] * P[i]
                    if tri[j]:
                        c = nsrc[j]
                        gn = r[c]
                        for i in range(m):
                            if i != c and i != j and i != k:
                                gn += Del[c, i] * P[i]
                        g1 -= Del[j, c] * P[c]  # the block's own normal impulse is an unknown of the block
                        g2 -= Del[k, c] * P[c]
                        p1, p2, pn, ok = _triple_solve(g1, g2, gn, Del[j, j], Del[j, k], Del[k, k], Del[j, c],
                                                       Del[k, c], Del[c, j], Del[c, k], Del[c, c], bound[j],
                                                       mu_n[j], active[c])
                        if not ok:  # no consistent case (none found in the measurements): the disk, then N
                            p1, p2, lam = _disk_solve(g1 + Del[j, c] * P[c], g2 + Del[k, c] * P[c], Del[j, j],
                                                      Del[j, k], Del[k, k], bound[j] + mu_n[j] * P[c])
                            pn = 0.0
                            if active[c]:
                                pn = -(gn + Del[c, j] * p1 + Del[c, k] * p2) / Del[c, c]
                                pn = pn if pn > 0.0 else 0.0
                        for i, v in ((j, p1), (k, p2), (c, pn)):
                            change, scale = _assign(P, i, v, change, scale)
                        continue
                    b = bound[j]
                    if nsrc[j] >= 0:
                        b += mu_n[j] * P[nsrc[j]]
                    p1, p2, lam = _disk_solve(g1, g2, Del[j, j], Del[j, k], Del[k, k], b)
                    for i, v in ((j, p1), (k, p2)):
                        change, scale = _assign(P, i, v, change, scale)
                    continue
                if pair[j] >= 0:
                    c = pair[j]
                    rT = r[j]
                    rN = r[c]
                    for i in range(m):
                        if i != j and i != c:
                            rT += Del[j, i] * P[i]
                            rN += Del[c, i] * P[i]
                    pt, pn, ok = _pair_solve(rT, rN, Del[j, j], Del[j, c], Del[c, j], Del[c, c], bound[j],
                                             mu_n[j], active[c])
                    if ok:
                        for i, v in ((j, pt), (c, pn)):
                            change, scale = _assign(P, i, v, change, scale)
                        continue
                    # no consistent case (found none in the measurements): scalar updates of both
                    for i in (j, c):
                        if not active[i]:
                            continue
                        res = r[i]
                        for k in range(m):
                            res += Del[i, k] * P[k]
                        p = P[i] - res / Del[i, i]
                        if i == j:
                            b = bound[j] + mu_n[j] * P[c]
                            p = b if p > b else (-b if p < -b else p)
                        elif p < 0.0:
                            p = 0.0
                        change, scale = _assign(P, i, p, change, scale)
                    continue
                res = r[j]
                for i in range(m):
                    res += Del[j, i] * P[i]
                p = P[j] - res / Del[j, j]
                if kind[j] == KIND_FRICTION:
                    b = bound[j]
                    if nsrc[j] >= 0:
                        b += mu_n[j] * P[nsrc[j]]
                    if p > b:
                        p = b
                    elif p < -b:
                        p = -b
                elif p < 0.0:
                    p = 0.0
                change, scale = _assign(P, j, p, change, scale)
            if change <= tol * (1.0 + scale):
                break
        for j in range(m):  # the cone with the final normal impulse holds exactly
            if kind[j] == KIND_FRICTION and tpair[j] > j:
                k = tpair[j]
                b = bound[j]
                if nsrc[j] >= 0:
                    b += mu_n[j] * P[nsrc[j]]
                nrm = np.sqrt(P[j] * P[j] + P[k] * P[k])
                if nrm > b:
                    f = b / nrm if nrm > 0.0 else 0.0
                    P[j] *= f
                    P[k] *= f
            elif kind[j] == KIND_FRICTION and nsrc[j] >= 0 and tpair[j] < 0:
                b = bound[j] + mu_n[j] * P[nsrc[j]]
                if P[j] > b:
                    P[j] = b
                elif P[j] < -b:
                    P[j] = -b
    for j in range(m):
        if not active[j]:
            status[j] = STATUS_OPEN
        elif kind[j] == KIND_FRICTION:
            b = bound[j]
            if nsrc[j] >= 0:
                b += mu_n[j] * P[nsrc[j]]
            pj = abs(P[j])
            if tpair[j] >= 0:
                pj = np.sqrt(P[j] * P[j] + P[tpair[j]] * P[tpair[j]])
            if b <= 0.0:
                status[j] = STATUS_OPEN  # no normal load: no friction impulse
            else:
                status[j] = STATUS_SLIP if pj >= b * (1.0 - 1e-14) else STATUS_STICK
        else:
            status[j] = STATUS_CLOSED if P[j] > 0.0 else STATUS_OPEN
    return it


@njit(cache=True)
def _disk_solve(g1, g2, a11, a12, a22, b):
    """Exact solution of two frictions sharing the disk ``||P|| <= b`` with the other impulses fixed:
    ``gamma = g + A P`` (``A = [[a11, a12], [a12, a22]]``, the symmetric positive definite Delassus block),
    ``P`` minimises ``P^T A P / 2 + g^T P`` on the disk (Coulomb's law with maximal dissipation,
    ``gamma = -lam P``, ``lam >= 0``).

    Stick when ``-A^-1 g`` lies in the disk (``lam = 0``); else ``P = -(A + lam I)^-1 g`` with
    ``||P|| = b``, ``lam`` from Newton's iteration on the convex decreasing ``1/b - 1/||P(lam)||`` from
    ``lam = 0`` (monotone, exact in one step for ``A = a I``), in the eigenbasis of ``A``.
    Returns ``(P_1, P_2, lam)``; ``b <= 0``: ``(0, 0, 0)``.
    """
    if b <= 0.0:
        return 0.0, 0.0, 0.0
    det = a11 * a22 - a12 * a12
    p1 = -(a22 * g1 - a12 * g2) / det
    p2 = -(a11 * g2 - a12 * g1) / det
    if p1 * p1 + p2 * p2 <= b * b:
        return p1, p2, 0.0
    half = 0.5 * (a11 + a22)
    rad = np.sqrt(0.25 * (a11 - a22) ** 2 + a12 * a12)
    l1 = half + rad
    l2 = half - rad
    th = 0.5 * np.arctan2(2.0 * a12, a11 - a22)
    c = np.cos(th)
    s = np.sin(th)
    h1 = c * g1 + s * g2  # g in the eigenbasis (v1 = (c, s) for l1, v2 = (-s, c) for l2)
    h2 = -s * g1 + c * g2
    lam = 0.0
    for _ in range(100):
        e1 = h1 / (l1 + lam)
        e2 = h2 / (l2 + lam)
        nrm = np.sqrt(e1 * e1 + e2 * e2)
        dn = -(e1 * e1 / (l1 + lam) + e2 * e2 / (l2 + lam)) / nrm  # d||P|| / d lam
        step = -(1.0 / b - 1.0 / nrm) * nrm * nrm / dn
        lam += step
        if abs(step) <= 1e-15 * (lam + l1):
            break
    e1 = h1 / (l1 + lam)
    e2 = h2 / (l2 + lam)
    p1 = -(c * e1 - s * e2)
    p2 = -(s * e1 + c * e2)
    f = b / np.sqrt(p1 * p1 + p2 * p2)  # on the circle to rounding
    return p1 * f, p2 * f, lam


@njit(cache=True)
def _triple_solve(g1, g2, gn, a11, a12, a22, a1n, a2n, an1, an2, ann, bT, mu, closable):
    """Exact solution of a cone (frictions 1, 2 on the disk ``||P_T|| <= bT + mu P_N``) and the contact ``N``
    that loads it, the other impulses fixed: ``gamma_T = g_T + A_TT P_T + a_TN P_N``, ``gamma_N = gn + a_NT . P_T
    + ann P_N`` (``gamma_N`` including ``e gamma_N-``).

    For a normal impulse ``P_N >= 0`` the tangential one is the disk's, ``P_T(P_N)`` (:func:`_disk_solve` with
    ``g_T + a_TN P_N`` and the bound ``bT + mu P_N``), continuous in ``P_N``; so is ``h(P_N) = gamma_N``.  Open
    if ``h(0) >= 0``; else ``P_N`` is a root of ``h``, bracketed by doubling and found by bisection (a root
    exists where ``ann > mu ||a_NT||``: ``h -> +inf``).  ``closable``: the contact is active in this step.
    Returns ``(P_1, P_2, P_N, ok)``; ``ok`` False: no bracket found (``h`` stays negative).
    """
    q1, q2, lam = _disk_solve(g1, g2, a11, a12, a22, bT)
    if not closable:
        return q1, q2, 0.0, True
    h0 = gn + an1 * q1 + an2 * q2
    if h0 >= -1e-14 * (abs(gn) + abs(an1 * q1) + abs(an2 * q2)):
        return q1, q2, 0.0, True
    lo = 0.0
    hi = -h0 / ann
    found = False
    for _ in range(200):
        p1, p2, lam = _disk_solve(g1 + a1n * hi, g2 + a2n * hi, a11, a12, a22, bT + mu * hi)
        if gn + an1 * p1 + an2 * p2 + ann * hi >= 0.0:
            found = True
            break
        lo = hi
        hi *= 2.0
    if not found:
        return 0.0, 0.0, 0.0, False
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        p1, p2, lam = _disk_solve(g1 + a1n * mid, g2 + a2n * mid, a11, a12, a22, bT + mu * mid)
        if gn + an1 * p1 + an2 * p2 + ann * mid >= 0.0:
            hi = mid
        else:
            lo = mid
    p1, p2, lam = _disk_solve(g1 + a1n * hi, g2 + a2n * hi, a11, a12, a22, bT + mu * hi)
    return p1, p2, hi, True


@njit(cache=True)
def _pair_solve(rT, rN, Dtt, Dtn, Dnt, Dnn, bT, mu, closable):
    """Exact solution of one friction ``T`` whose bound ``bT + mu P_N`` follows one contact ``N``.

    With the other elements' impulses fixed, ``gamma_T = rT + Dtt P_T + Dtn P_N`` and ``gamma_N = rN + Dnt P_T
    + Dnn P_N`` (``gamma_N`` including ``e gamma_N-``).  The cases are tried in turn: contact closed and
    friction sticking (``gamma_T = gamma_N = 0``), closed and slipping (``P_T = s (bT + mu P_N)``,
    ``s gamma_T <= 0``, ``gamma_N = 0``), open (``P_N = 0``, ``gamma_N >= 0``, friction with the bound
    ``bT``); ``closable``: the contact is active in this step (else open).  Returns ``(P_T, P_N, ok)``.
    """
    pt0 = -rT / Dtt
    if pt0 > bT:
        pt0 = bT
    elif pt0 < -bT:
        pt0 = -bT
    if not closable:
        return pt0, 0.0, True
    tolr = 1e-12 * (abs(rT) + abs(rN))
    det = Dtt * Dnn - Dtn * Dnt
    if det != 0.0:
        pt = (-rT * Dnn + rN * Dtn) / det
        pn = (-rN * Dtt + rT * Dnt) / det
        if pn >= 0.0:
            b = bT + mu * pn
            if abs(pt) <= b * (1.0 + 1e-12):
                if pt > b:
                    pt = b
                elif pt < -b:
                    pt = -b
                return pt, pn, True
    for s in (1.0, -1.0):
        den = Dnn + s * mu * Dnt
        if den > 0.0:
            pn = -(rN + Dnt * s * bT) / den
            if pn >= 0.0:
                pt = s * (bT + mu * pn)
                gT = rT + Dtt * pt + Dtn * pn
                if s * gT <= tolr + 1e-12 * (abs(Dtt * pt) + abs(Dtn * pn)):
                    return pt, pn, True
    gN = rN + Dnt * pt0
    if gN >= -(tolr + 1e-12 * abs(Dnt * pt0)):
        return pt0, 0.0, True
    return 0.0, 0.0, False


@njit(cache=True)
def _sens_row(j, status, nsrc, tpair):
    """Element ``j`` has an impulse sensitivity row: stick, closed, slip on a disk (cone partners: the slip
    direction rotates), or slip with the bound of a closed contact."""
    st = status[j] & 3
    if st == STATUS_STICK or st == STATUS_CLOSED:
        return True
    if st == STATUS_SLIP and tpair[j] >= 0:
        return True
    return st == STATUS_SLIP and nsrc[j] >= 0 and (status[nsrc[j]] & 3) == STATUS_CLOSED


@njit(cache=True)
def _solve_small(A, B):
    """Solve A X = B for a small dense A by Gaussian elimination with pivoting."""
    n = A.shape[0]
    A = A.copy()
    X = B.copy()
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if p != c:
            for k in range(n):
                A[c, k], A[p, k] = A[p, k], A[c, k]
            for k in range(X.shape[1]):
                X[c, k], X[p, k] = X[p, k], X[c, k]
        for r in range(c + 1, n):
            f = A[r, c] / A[c, c]
            if f != 0.0:
                for k in range(c, n):
                    A[r, k] -= f * A[c, k]
                for k in range(X.shape[1]):
                    X[r, k] -= f * X[c, k]
    for c in range(n - 1, -1, -1):
        for k in range(X.shape[1]):
            s = X[c, k]
            for j in range(c + 1, n):
                s -= A[c, j] * X[j, k]
            X[c, k] = s / A[c, c]
    return X
