"""The compiled passes of the certificate over the time grid and the harmonics (numba, cached on disk).

Each kernel reduces the solution's series to the few numbers the checks need, without storing the grid
values: per element the extremes of its gap, velocity and force and its work (:func:`element_terms`,
:func:`element_terms_fourier`), the Parseval sums of input work and damper dissipation
(:func:`harmonic_power`), and the displacement of the element-force harmonics above ``n_h``
(:func:`force_tail`).  Notation as in :mod:`mshbm.certificate`.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["S_MIN", "WU_MAX", "LAM_MAX", "LAM_MIN", "LAM_ABS", "WORK", "WORK_ABS", "ACTS", "element_terms",
           "element_terms_fourier", "harmonic_power", "force_tail"]

#: columns of :func:`element_terms`' output
S_MIN, WU_MAX, LAM_MAX, LAM_MIN, LAM_ABS, WORK, WORK_ABS, ACTS = range(8)


@njit(cache=True)
def element_terms(q, u, lam, I, J, sign, N, out):  # pragma: no cover - compiled
    """Per element ``j`` on the grid (``q, u``: (N+1, n_e) of the element DOFs' columns ``I[j]``, ``J[j]``
    (``-1``: single-DOF element); ``lam``: (N+1, m)), in ``out[j]`` (NaN-propagating like NumPy's
    ``min``/``max``): ``min w^T q``, ``max |w^T u|``, ``max lambda``, ``min lambda``, ``max |lambda|``
    (all N+1 points), the work ``sum_k<N sign lambda u_j`` and ``sum_k<N |lambda u_j|`` with ``u_j = sign
    w^T u`` (the velocity along ``+e_dof``), and 1 if some ``lambda != 0``."""
    rows = q.shape[0]
    nan = np.nan
    for j in range(lam.shape[1]):
        a, c, w = I[j], J[j], sign[j]
        smin, umax, lmax, lmin, labs, W, Ea, acts = np.inf, 0.0, -np.inf, np.inf, 0.0, 0.0, 0.0, 0.0
        bad_s, bad_u, bad_l = False, False, False
        for t in range(rows):
            if c >= 0:
                s = w * (q[t, a] - q[t, c])
                wu = w * (u[t, a] - u[t, c])
            else:
                s = w * q[t, a]
                wu = w * u[t, a]
            lt = lam[t, j]
            if s != s:
                bad_s = True
            if wu != wu:
                bad_u = True
            if lt != lt:
                bad_l = True
            smin = min(smin, s)
            umax = max(umax, abs(wu))
            lmax = max(lmax, lt)
            lmin = min(lmin, lt)
            labs = max(labs, abs(lt))
            if abs(lt) > 0.0:
                acts = 1.0
            if t < N:
                uj = w * wu
                W += w * lt * uj
                Ea += abs(lt * uj)
        out[j, 0] = nan if bad_s else smin
        out[j, 1] = nan if bad_u else umax
        out[j, 2] = nan if bad_l else lmax
        out[j, 3] = nan if bad_l else lmin
        out[j, 4] = nan if bad_l else labs
        out[j, 5] = W
        out[j, 6] = Ea
        out[j, 7] = acts


@njit(cache=True)
def element_terms_fourier(coef, V, omega, lam, I, J, sign, N, out):  # pragma: no cover - compiled
    """:func:`element_terms` for a solution given by Fourier coefficients alone (HBM, DLFT): the grid
    values ``q = V coef``, ``u = V (Om coef)`` of the element DOFs' columns (``coef`` (2 n_h + 1, n_e),
    ``V`` the inverse DFT (N, 2 n_h + 1)) are summed here instead of stored (``t_N = T`` repeats ``t_0``).
    Returns ``max |u|`` over the element DOFs and the grid."""
    nc, ne = coef.shape
    m = lam.shape[1]
    dcoef = np.zeros((nc, ne))  # Om coef: the velocity's coefficients
    for k in range(1, (nc - 1) // 2 + 1):
        kw = k * omega
        for i in range(ne):
            dcoef[2 * k - 1, i] = kw * coef[2 * k, i]
            dcoef[2 * k, i] = -kw * coef[2 * k - 1, i]
    q = np.empty(ne)
    u = np.empty(ne)
    acc = np.zeros((m, 8))
    for j in range(m):
        acc[j, 0], acc[j, 2], acc[j, 3] = np.inf, -np.inf, np.inf
    bad = np.zeros((m, 3), dtype=np.bool_)
    uall = 0.0
    bad_all = False
    for t in range(N):
        for i in range(ne):
            qs, us = 0.0, 0.0
            for k in range(nc):
                qs += V[t, k] * coef[k, i]
                us += V[t, k] * dcoef[k, i]
            q[i], u[i] = qs, us
            if us != us:
                bad_all = True
            uall = max(uall, abs(us))
        for j in range(m):
            a, c, w = I[j], J[j], sign[j]
            if c >= 0:
                sv = w * (q[a] - q[c])
                wu = w * (u[a] - u[c])
            else:
                sv = w * q[a]
                wu = w * u[a]
            lt = lam[t, j]
            if sv != sv:
                bad[j, 0] = True
            if wu != wu:
                bad[j, 1] = True
            if lt != lt:
                bad[j, 2] = True
            acc[j, 0] = min(acc[j, 0], sv)
            acc[j, 1] = max(acc[j, 1], abs(wu))
            acc[j, 2] = max(acc[j, 2], lt)
            acc[j, 3] = min(acc[j, 3], lt)
            acc[j, 4] = max(acc[j, 4], abs(lt))
            if abs(lt) > 0.0:
                acc[j, 7] = 1.0
            uj = w * wu
            acc[j, 5] += w * lt * uj
            acc[j, 6] += abs(lt * uj)
    for j in range(m):
        lt = lam[N, j]  # lambda at t_N (its own row; equal to t_0 for a periodic series)
        if lt != lt:
            bad[j, 2] = True
        acc[j, 2] = max(acc[j, 2], lt)
        acc[j, 3] = min(acc[j, 3], lt)
        acc[j, 4] = max(acc[j, 4], abs(lt))
        if abs(lt) > 0.0:
            acc[j, 7] = 1.0
        for col in range(8):
            out[j, col] = acc[j, col]
        if bad[j, 0]:
            out[j, 0] = np.nan
        if bad[j, 1]:
            out[j, 1] = np.nan
        if bad[j, 2]:
            out[j, 2] = out[j, 3] = out[j, 4] = np.nan
    return np.nan if bad_all else uall


@njit(cache=True)
def harmonic_power(qh, fh, C, omega, out):  # pragma: no cover - compiled
    """Parseval sums of a Fourier solution ``qh`` (2 n_h + 1, n) under forcing ``fh`` (same shape) with
    dense damping ``C`` (n, n), per unit ``T / 2``: ``out[0] = sum_k,i k omega (fc_ki xs_ki - fs_ki xc_ki)``
    (input work), ``out[1]`` the same sum of magnitudes, ``out[2] = sum_k (k omega)^2 (xc_k^T C xc_k +
    xs_k^T C xs_k)`` (damper dissipation)."""
    n = qh.shape[1]
    W, Ea, Dc = 0.0, 0.0, 0.0
    for k in range(1, (qh.shape[0] - 1) // 2 + 1):
        kw = k * omega
        a, b = qh[2 * k - 1], qh[2 * k]
        for i in range(n):
            p = kw * (fh[2 * k - 1, i] * b[i] - fh[2 * k, i] * a[i])
            W += p
            Ea += abs(p)
        for i in range(n):
            ca, cb = 0.0, 0.0
            for l in range(n):
                ca += C[i, l] * a[l]
                cb += C[i, l] * b[l]
            Dc += kw * kw * (a[i] * ca + b[i] * cb)
    out[0], out[1], out[2] = W, Ea, Dc


@njit(cache=True)
def force_tail(Z, Kd, Md, Cd, d, omega, n_h, out):  # pragma: no cover - compiled
    """``out[j] = sqrt(sum_k>n_h (|Z_kj| / |K_dd - (k omega)^2 M_dd + i k omega C_dd|)^2)``, ``d = d[j]``:
    the displacement of the element-force harmonics ``Z`` (N/2+1, m) above ``n_h`` at the element DOF."""
    for j in range(Z.shape[1]):
        dj = d[j]
        acc = 0.0
        for k in range(n_h + 1, Z.shape[0]):
            w = k * omega
            Hd = math.hypot(Kd[dj] - w * w * Md[dj], w * Cd[dj])
            t = abs(Z[k, j]) / max(Hd, 1e-300)
            acc += t * t
        out[j] = math.sqrt(acc)

