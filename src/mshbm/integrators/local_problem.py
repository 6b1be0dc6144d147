"""The one-step local problem of the Moreau-Jean kernel (:mod:`mshbm.integrators.kernels`): the element
impulses ``P`` of one step from the free velocity, compiled on raw arrays.

With the Delassus matrix ``D = G^T W G`` of the ``m`` elements (``W = (M + h theta C + h^2 theta^2 K)^-1``,
``G`` their directions) and the free velocity ``u_free``, element ``j`` obeys its law on the impulse level
(friction: stick or slip at ``bound_j = h mu F_N``, plus ``mu_n[j] P_c`` when its normal load comes from
contact ``c``; contact: Newton's law ``0 <= gamma_j+ + e_j gamma_j- _|_ P_j >= 0`` while active).  One
element is solved in closed form, several by projected Gauss-Seidel on ``D``, a friction loaded by a contact
together with it as one exactly solved 2x2 block (:func:`_pair_solve`).  Element kinds and status codes are
the constants of this module.
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
def _local_solve(uf, u, q_free_gap, kind, dof, dof2, sign, bound, e, nsrc, mu_n, Del, P, status, tol, max_iter,
                 r, active):
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
        for c in range(m):
            if pair[c] == -3:
                pair[c] = -1
        for it in range(1, max_iter + 1):
            change = 0.0
            scale = 0.0
            for j in range(m):
                if pair[j] == -2 or (not active[j] and pair[j] < 0):
                    continue  # a paired contact is solved with its friction
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
                            d = abs(v - P[i])
                            if d > change:
                                change = d
                            if abs(v) > scale:
                                scale = abs(v)
                            P[i] = v
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
                        d = abs(p - P[i])
                        if d > change:
                            change = d
                        if abs(p) > scale:
                            scale = abs(p)
                        P[i] = p
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
                d = abs(p - P[j])
                if d > change:
                    change = d
                if abs(p) > scale:
                    scale = abs(p)
                P[j] = p
            if change <= tol * (1.0 + scale):
                break
        for j in range(m):  # the cone with the final normal impulse holds exactly
            if kind[j] == KIND_FRICTION and nsrc[j] >= 0:
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
            if b <= 0.0:
                status[j] = STATUS_OPEN  # no normal load: no friction impulse
            else:
                status[j] = STATUS_SLIP if abs(P[j]) >= b * (1.0 - 1e-14) else STATUS_STICK
        else:
            status[j] = STATUS_CLOSED if P[j] > 0.0 else STATUS_OPEN
    return it


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
def _sens_row(j, status, nsrc):
    """Element ``j`` has an impulse sensitivity row: stick, closed, or slip with the bound of a closed contact."""
    st = status[j] & 3
    if st == STATUS_STICK or st == STATUS_CLOSED:
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
