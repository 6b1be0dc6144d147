"""Time-marching correction of the DLFT friction law on raw arrays (numba), and its NumPy twin.

Used by the displacement predictor (``dlft_predictor="displacement"``); the default velocity
predictor corrects every sample on its own and needs no march.

Notation of :mod:`mshbm.methods.dlft`: on the AFT samples ``t_n = n T / N_s`` of one friction
element, ``y_n = lambda_L,n - eps w q_n`` is the *free* part of the Lagrangian prediction
(``lambda_L`` the force the linear part demands, ``eps`` the DLFT parameter, ``w q`` the slip
displacement) and ``s = eps xi_r`` the memory (the Lagrangian slip displacement ``xi_r`` times
``eps``).  Per sample::

    lambda_pred = y_n + s
    stick:  |lambda_pred| <= b   ->  lambda_n = lambda_pred,           s unchanged
    slip:   otherwise            ->  lambda_n = b sign(lambda_pred),   s = lambda_n - y_n

with the sliding bound ``b = mu F_N``.  The march runs over two periods: the first one only
builds the memory (the initial ``s`` is ``s0``), the second one is recorded.  ``ref[n]`` is
the sample of the last slip that fixed ``s`` at sample ``n`` (``-1``: ``s`` is still ``s0``,
i.e. no slip anywhere in the period), so that in stick ``d lambda_n = d y_n - d y_ref[n]``
(``d y_n + d s0`` when ``ref[n] = -1``) and in slip ``d lambda_n = 0``.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["friction_march", "friction_march_numpy"]


@njit(cache=True)
def friction_march(y, bound, s0, lam, slip, ref):
    """Fill ``lam`` (N_s,), ``slip`` (N_s, int8: 0 stick, 1 slip) and ``ref`` (N_s, int64) in place."""
    Ns = y.shape[0]
    s = s0
    last = -1
    for p in range(2):
        for n in range(Ns):
            pred = y[n] + s
            if pred > bound or pred < -bound:
                val = bound if pred > 0.0 else -bound
                s = val - y[n]
                last = n
                if p == 1:
                    lam[n] = val
                    slip[n] = 1
                    ref[n] = n
            elif p == 1:
                lam[n] = pred
                slip[n] = 0
                ref[n] = last


def friction_march_numpy(y, bound, s0):
    """Plain Python twin of :func:`friction_march`; returns ``(lam, slip, ref)``."""
    y = np.asarray(y, dtype=float)
    Ns = y.size
    lam, slip, ref = np.zeros(Ns), np.zeros(Ns, dtype=np.int8), np.full(Ns, -1, dtype=np.int64)
    s, last = float(s0), -1
    for p in range(2):
        for n in range(Ns):
            pred = y[n] + s
            if abs(pred) > bound:
                val = float(np.copysign(bound, pred))
                s, last = val - y[n], n
                if p:
                    lam[n], slip[n], ref[n] = val, 1, n
            elif p:
                lam[n], slip[n], ref[n] = pred, 0, last
    return lam, slip, ref
