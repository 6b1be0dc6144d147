"""Compiled products with the structured sensitivities of the event-driven flow.

The rows of the forcing states of ``A`` (and of ``exp(A h_s)``) are 2 x 2 rotations per harmonic and DOF;
the sensitivity matrix ``Phi`` of :meth:`~mshbm.integrators.event.flow.EventFlow.simulate` has, in its
forcing-state block, nonzero entries only in those 2 x 2 blocks (and the diagonal of the constants).  These
kernels form ``A P``, ``exp(A h_s) P`` and the Taylor powers ``A^j z / j!`` from that structure, so their cost
is linear, not quadratic, in the number of forcing states.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _top_rows(E, P, iy, n, yc, ys, X):
    """``X[:iy] += E[:iy] P`` for the sensitivities ``P`` of :meth:`EventFlow.simulate` (shape (D, cols)): from
    the rows ``:iy`` of ``P`` and the nonzero entries of its forcing-state block (the constants' diagonal, the
    2 x 2 block of each pair ``(Y1, Y2) = (yc[p], ys[p])``, relative to ``iy``); the rest of that block is zero."""
    cols = P.shape[1]
    n2 = 2 * n
    for r in range(iy):
        for k in range(iy):
            e = E[r, k]
            if e != 0.0:
                for j in range(cols):
                    X[r, j] += e * P[k, j]
    if cols > n2:
        for i in range(n):
            d = P[iy + i, n2 + i]
            for r in range(iy):
                X[r, n2 + i] += E[r, iy + i] * d
        for p in range(yc.size):
            a, b = yc[p], ys[p]
            c1, s1 = P[iy + a, n2 + a], P[iy + a, n2 + b]
            m1, c2 = P[iy + b, n2 + a], P[iy + b, n2 + b]
            for r in range(iy):
                ec, es = E[r, iy + a], E[r, iy + b]
                X[r, n2 + a] += ec * c1 + es * m1
                X[r, n2 + b] += ec * s1 + es * c2


@njit(cache=True)
def _emul_sens(E, P, iy, n, yc, ys, c, s):
    """In place ``P <- exp(A h_s) P`` for the sensitivities ``P`` of :meth:`EventFlow.simulate` (shape (D, cols)):
    rows ``:iy`` by :func:`_top_rows`; the 2 x 2 block of each forcing-state pair rotates through
    ``(c[p], s[p])`` (:meth:`EventFlow.emul`)."""
    cols = P.shape[1]
    n2 = 2 * n
    X = np.zeros((iy, cols))
    _top_rows(E, P, iy, n, yc, ys, X)
    if cols > n2:
        for p in range(yc.size):
            a, b = yc[p], ys[p]
            c1, s1 = P[iy + a, n2 + a], P[iy + a, n2 + b]
            m1, c2 = P[iy + b, n2 + a], P[iy + b, n2 + b]
            P[iy + a, n2 + a] = c[p] * c1 + s[p] * m1
            P[iy + a, n2 + b] = c[p] * s1 + s[p] * c2
            P[iy + b, n2 + a] = -s[p] * c1 + c[p] * m1
            P[iy + b, n2 + b] = -s[p] * s1 + c[p] * c2
    for r in range(iy):
        for j in range(cols):
            P[r, j] = X[r, j]


@njit(cache=True)
def _amul_sens(A, P, iy, n, yc, ys, yw):
    """``A P`` for the sensitivities ``P`` of :meth:`EventFlow.simulate`: rows ``:iy`` by :func:`_top_rows`; the
    forcing-state rows of ``A`` are the rotations ``(Y1, Y2)' = yw[p] (Y2, -Y1)`` (constants: 0)."""
    cols = P.shape[1]
    n2 = 2 * n
    out = np.zeros_like(P)
    _top_rows(A, P, iy, n, yc, ys, out)
    if cols > n2:
        for p in range(yc.size):
            a, b = yc[p], ys[p]
            c1, s1 = P[iy + a, n2 + a], P[iy + a, n2 + b]
            m1, c2 = P[iy + b, n2 + a], P[iy + b, n2 + b]
            w = yw[p]
            out[iy + a, n2 + a] = w * m1
            out[iy + a, n2 + b] = w * c2
            out[iy + b, n2 + a] = -w * c1
            out[iy + b, n2 + b] = -w * s1
    return out


@njit(cache=True)
def _powers_state(A, z, nt, iy, n, yc, ys, yw):
    """``W[:, j] = A^j z / j!`` (:meth:`EventFlow.powers`) for a state ``z`` (D,): rows ``:iy`` from the full
    rows of ``A``, the forcing states from their rotation ``(Y1, Y2)' = yw[p] (Y2, -Y1)`` (constants: 0)."""
    D = z.size
    W = np.zeros((D, nt))
    W[:, 0] = z
    for j in range(1, nt):
        for r in range(iy):
            acc = 0.0
            for k in range(D):
                acc += A[r, k] * W[k, j - 1]
            W[r, j] = acc / j
        for p in range(yc.size):
            a, b = iy + yc[p], iy + ys[p]
            W[a, j] = yw[p] * W[b, j - 1] / j
            W[b, j] = -yw[p] * W[a, j - 1] / j
    return W


@njit(cache=True)
def _rotation_entries(P, iy, n, yc, ys):
    """``[d, c1, m1, s1, c2]`` of the forcing-state block of ``P`` (:meth:`EventFlow._phi_rotation_entries`)."""
    n2, q = 2 * n, yc.size
    out = np.empty(n + 4 * q)
    for i in range(n):
        out[i] = P[iy + i, n2 + i]
    for p in range(q):
        a, b = yc[p], ys[p]
        out[n + p] = P[iy + a, n2 + a]
        out[n + q + p] = P[iy + b, n2 + a]
        out[n + 2 * q + p] = P[iy + a, n2 + b]
        out[n + 3 * q + p] = P[iy + b, n2 + b]
    return out
