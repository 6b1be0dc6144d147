"""Exact extrema of truncated Fourier series, and the amplitude of a periodic solution.

A DOF represented by Fourier coefficients (rows ``[x0, xc_1, xs_1, ..., xc_nh, xs_nh]``, the
convention of :mod:`mshbm.fourier`) is the trigonometric polynomial::

    p(theta) = x0 + sum_k xc_k cos(k theta) + xs_k sin(k theta),    theta = omega t

Its maximum is found in two stages, vectorised over DOFs:

1. samples on a grid of ``S = max(64, 8 (2 n_h + 1))`` angles; with the bound
   ``|p''| <= B2 = sum_k k^2 sqrt(xc_k^2 + xs_k^2)``, every local maximum lies within
   ``err = B2 (pi / S)^2 / 2`` of its nearest sample, so only samples within ``err`` of the best
   one can be next to the global maximum (usually one or two per DOF);
2. Newton's method on ``p'(theta) = 0`` from each such sample, steps limited to one grid
   spacing; the largest value of ``p`` met is the maximum (to rounding: Newton converges
   quadratically, and the value is evaluated from the coefficients, never interpolated).

The minimum is the maximum of ``-p``.  Cost: ``O(n S n_h)`` for the samples and ``O(n n_h)`` per
Newton step -- independent of the number of time steps of the solution.

The amplitude of a :class:`mshbm.PeriodicSolution` is ``(max - min) / 2`` per DOF over one
period of its exact representation: the Fourier series for harmonic DOFs; the time series
(maximum over its samples) for time-stepped DOFs of shooting and MS-HBM, whose representation
it is; the event-driven extrema for :func:`mshbm.exact_periodic` (``info["amplitude_exact"]``).
"""
from __future__ import annotations

import numpy as np

from . import fourier

__all__ = ["fourier_max", "fourier_extrema", "solution_amplitude"]

_NEWTON_STEPS = 8


def _value_slope_curv(a0, a, b, theta):
    """``p, p', p''`` at ``theta`` (shape (m,)) for coefficients a0 (m,), a, b (n_h, m) per point."""
    n_h = a.shape[0]
    e = np.exp(1j * theta)
    z = np.empty(a.shape, dtype=complex)                       # exp(i k theta), k = 1..n_h
    z[0] = e
    for i in range(1, n_h):
        np.multiply(z[i - 1], e, out=z[i])
    c, s = z.real, z.imag
    k = np.arange(1, n_h + 1, dtype=float)[:, None]
    ac_bs = a * c + b * s
    p = a0 + ac_bs.sum(axis=0)
    dp = ((b * c - a * s) * k).sum(axis=0)
    d2p = -(ac_bs * (k * k)).sum(axis=0)
    return p, dp, d2p


def fourier_max(coef):
    """Maximum over one period of each column of ``coef`` (shape (2 n_h + 1, m)) -> shape (m,)."""
    coef = np.asarray(coef, dtype=float)
    nc, m = coef.shape
    n_h = (nc - 1) // 2
    if n_h == 0 or m == 0:
        return coef[0].copy() if nc else np.zeros(m)
    S = max(64, 8 * nc)
    P = fourier.idft_matrix(S, n_h) @ coef                     # (S, m) samples
    jbest = P.argmax(axis=0)
    cols = np.arange(m)
    best = P[jbest, cols]
    a, b = coef[1::2], coef[2::2]                              # (n_h, m)
    k = np.arange(1, n_h + 1, dtype=float)
    B2 = (k * k) @ np.hypot(a, b)
    dtheta = 2.0 * np.pi / S
    thr = best - 0.5 * B2 * (0.5 * dtheta) ** 2 * (1.0 + 1e-12)
    mask = P >= thr
    # candidates: the best sample of every DOF, and every other sample within the bound
    multi = np.flatnonzero(mask.sum(axis=0) > 1)
    j2, i2 = np.nonzero(mask[:, multi])
    j = np.concatenate([jbest, j2])
    d = np.concatenate([cols, multi[i2]])
    top = P[j, d]
    # start at the vertex of the parabola through the sample and its neighbours
    pm, pp = P[(j - 1) % S, d], P[(j + 1) % S, d]
    curv = pm - 2.0 * top + pp
    with np.errstate(divide="ignore", invalid="ignore"):
        off = np.where(curv < 0, 0.5 * (pm - pp) / curv, 0.0)
    theta = dtheta * (j + np.clip(np.nan_to_num(off), -1.0, 1.0))
    lo, hi = dtheta * (j - 1.0), dtheta * (j + 1.0)
    act = np.arange(j.size)
    a0d, ad, bd = coef[0, d], a[:, d], b[:, d]
    keep = np.ones(j.size, dtype=bool)
    for _ in range(_NEWTON_STEPS):
        if not keep.all():
            a0d, ad, bd = a0d[keep], ad[:, keep], bd[:, keep]
        th = theta[act]
        p, dp, d2p = _value_slope_curv(a0d, ad, bd, th)
        top[act] = np.maximum(top[act], p)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(d2p < 0, -dp / d2p, 0.0)
        step = np.where(np.isfinite(step), step, 0.0)
        theta[act] = np.clip(th + step, lo[act], hi[act])
        keep = np.abs(step) > 1e-8  # the value error at the last point is <= B2 step^2 / 2
        act = act[keep]
        if not act.size:
            break
    if act.size:
        top[act] = np.maximum(top[act], _value_slope_curv(a0d[keep], ad[:, keep], bd[:, keep], theta[act])[0])
    out = best.copy()
    np.maximum.at(out, d, top)
    return out


def fourier_extrema(coef, chunk_values=20_000_000):
    """``(max, min)`` over one period of each column of ``coef`` (2 n_h + 1, m), in DOF chunks."""
    coef = np.asarray(coef, dtype=float)
    nc, m = coef.shape
    hi, lo = np.empty(m), np.empty(m)
    step = max(1, int(chunk_values // max(max(64, 8 * nc), nc)))
    for s in range(0, m, step):
        c = coef[:, s:s + step]
        hi[s:s + step] = fourier_max(c)
        lo[s:s + step] = -fourier_max(-c)
    return hi, lo


def solution_amplitude(sol):
    """``(max - min) / 2`` of every DOF of a :class:`mshbm.PeriodicSolution`, shape (n,)."""
    with np.errstate(all="ignore"):  # non-finite solutions give non-finite amplitudes, silently
        return _amplitude(sol)


def _amplitude(sol):
    n = sol.n
    exact = sol.info.get("amplitude_exact") if isinstance(sol.info, dict) else None
    if exact is not None and np.shape(exact) == (n,):
        return np.asarray(exact, dtype=float).copy()
    amp = np.empty(n)
    timed = np.zeros(n, dtype=bool)
    td = np.asarray(sol.time_dofs, dtype=np.int64).reshape(-1)
    if td.size:
        timed[td] = True
        q = np.asarray(sol.q_time)
        amp[td] = 0.5 * (q.max(axis=0) - q.min(axis=0))
    rest = np.flatnonzero(~timed)
    if rest.size:
        hi, lo = fourier_extrema(sol.q_hat[:, rest])
        amp[rest] = 0.5 * (hi - lo)
    return amp
