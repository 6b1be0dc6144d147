"""The centring rule for stuck friction elements of the time-stepped methods (shooting, MS-HBM).

While a friction element (Coulomb, or the slider of a Jenkins element) sticks the whole period, the periodic
solutions at fixed ``omega`` form a family: its offset (a Jenkins slider's position ``z``, or the relative
position of two bodies held by a Coulomb contact) can sit anywhere the stick force stays within its bound
``|lambda(t)| <= mu F_N``.  The family is affine (the stuck system is linear), and along it the element's force
moves by a constant.  HBM's history law takes the middle of the admissible offsets (a centred stuck loop,
:meth:`mshbm.elements.Jenkins.history_law`); :func:`centred_member` picks the same member for the time-stepped
methods: every element stuck at all samples has

    max_t lambda_j(t) + min_t lambda_j(t) = 0,

i.e. its force centred in ``[-mu F_N, mu F_N]``.  Where the loop starts to slip the admissible range shrinks
to that one point, so the centred branch goes on continuously into slip (a held offset meets the range's edge on
one side first, and the branch turns back there).

Used by :func:`mshbm.sweep` (the continuation's ``gauge``, :mod:`mshbm.solvers.arclength`) through the
problems' ``family_gauge(x, F)``.  Notation: ``x`` the method's unknowns, ``F`` the free directions (rows, shape
``(k, n_x)``, physical units), ``lambda`` the element forces at the ``N`` samples of the period, shape ``(N, m)``.
"""
from __future__ import annotations

import numpy as np

from ..integrators.local_problem import STATUS_STICK

__all__ = ["centred_member", "GAUGE_STEP"]

#: probe step along each free direction (a row of ``F`` times this: the continuation's rows are unit steps in its
#: scaled unknowns, so the probe moves the solution by 1e-6 of its size)
GAUGE_STEP = 1e-6


def stuck_columns(status):
    """Elements (columns of ``status``, shape ``(N, m)``) that stick at every sample."""
    if status is None or status.size == 0:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(np.all((np.asarray(status) & 3) == STATUS_STICK, axis=0))


def centred_member(forces, x, F, max_iter=8):
    """The member ``x + F^T alpha`` of the family through ``x`` whose stuck friction elements have centred forces
    (module docstring), or ``None`` when no element sticks the whole period or the rule does not fix ``alpha``.

    ``forces(x) -> (lambda, status)`` or ``None``: the element forces and states at the samples of the period from
    ``x`` (a recorded run of the method's integrator).  ``lambda`` is affine in ``alpha`` while the elements stick:
    its derivative along each direction is one probe run; the max and min samples are then found by a few
    Newton steps on the piecewise-linear ``max + min`` (least squares for more directions than stuck elements).
    """
    x = np.asarray(x, dtype=float)
    F = np.atleast_2d(np.asarray(F, dtype=float))
    base = forces(x)
    if base is None:
        return None
    lam0, status = base
    cols = stuck_columns(status)
    if cols.size == 0 or F.shape[0] == 0:
        return None
    L0 = np.asarray(lam0, dtype=float)[:, cols]
    dL = np.empty(L0.shape + (F.shape[0],))
    for i, f in enumerate(F):
        probe = forces(x + GAUGE_STEP * f)
        if probe is None or not np.array_equal(stuck_columns(probe[1])[np.isin(stuck_columns(probe[1]), cols)], cols):
            return None
        dL[:, :, i] = (np.asarray(probe[0], dtype=float)[:, cols] - L0) / GAUGE_STEP
    scale = float(np.max(np.abs(L0))) if L0.size else 0.0
    if not np.isfinite(scale) or scale == 0.0:
        return None
    alpha = np.zeros(F.shape[0])
    idx = np.arange(cols.size)
    for _ in range(max_iter):
        L = L0 + dL @ alpha
        kmax, kmin = np.argmax(L, axis=0), np.argmin(L, axis=0)
        c = L[kmax, idx] + L[kmin, idx]
        if float(np.max(np.abs(c))) <= 1e-12 * scale:
            break
        A = dL[kmax, idx, :] + dL[kmin, idx, :]
        step = np.linalg.lstsq(A, -c, rcond=None)[0]
        if not np.all(np.isfinite(step)):
            return None
        alpha = alpha + step
    else:
        return None
    return x + F.T @ alpha
