"""Event location on one sub-step of the event-driven flow.

The events of a mode are linear functions ``c^T z`` of the state that must stay ``> 0`` (rows of the mode's
``C``).  On a sub-step of length ``h`` from ``z`` (end state ``zb``) an event is found from the sign of
``c^T z`` at both ends, from an extremum inside (a sign change of ``c^T A z``), and, right after the mode
was entered (the event function starts at ~0), on the careful grid :data:`_FIRST`; its time is refined by
Brent's method on the Taylor polynomial of the flow to ~1e-15 s.
"""
from __future__ import annotations

import numpy as np
from ..._deferred import brentq

from .modes import EventError, _poly

__all__ = ["locate"]

#: points (fractions of the sub-step) of the careful event search on the first sub-step of a mode,
#: where the event function starts at 0: geometric towards 0, then uniform
_FIRST = np.concatenate([2.0 ** -np.arange(40, 6, -1), np.arange(1, 65) / 64.0])


def locate(flow, md, z, zb, W, h, thr, est, a):
    """The first event of mode ``md`` on the sub-step ``[a, a + h]`` from ``z`` (end state ``zb``).

    ``thr``: per event function the threshold above which it counts as entered (shape (k,)); ``est``: which
    are entered (bool, shape (k,), updated in place); ``W``: the Taylor powers of the flow from ``z``
    (:meth:`~.modes.ModeCatalogue.powers`) or None (formed when needed).  Returns ``(s, i, W)``: the time
    ``s`` into the sub-step of the event and its row ``i`` (``(None, -1)``: none), and ``W``.
    """
    s_ev, i_ev = None, -1
    C_ev, CA_ev = md.C, md.CA
    if C_ev.shape[0]:
        pa, pb = C_ev @ z, C_ev @ zb
        da, db = CA_ev @ z, CA_ev @ zb
        for i in range(C_ev.shape[0]):
            s_i = None
            if not est[i]:
                if W is None:
                    W = flow.powers(md, z)
                coef = C_ev[i] @ W
                ss = _FIRST * h
                ph = _poly(coef, ss)
                above = np.nonzero(ph > thr[i])[0]
                if above.size:
                    est[i] = True
                    p = above[0]
                    below = np.nonzero(ph[p:] <= 0.0)[0]
                    if below.size:
                        q_ = p + below[0]
                        s_i = brentq(lambda s: _poly(coef, s), ss[q_ - 1], ss[q_], xtol=1e-15,
                                     rtol=8.9e-16)
                elif pb[i] < -thr[i]:
                    if md.ev[i][1] != "gap":
                        s_i = 0.0  # the mode cannot be entered: leave it at once
                    elif pb[i] < -1e3 * thr[i]:
                        raise EventError(f"penetration of the contact at t = {a:.9g} without a "
                                         "resolvable impact (start in penetration or unresolved bounce)")
            elif pb[i] <= 0.0:
                if W is None:
                    W = flow.powers(md, z)
                coef = C_ev[i] @ W
                # the end value from the exponential and from the Taylor polynomial may differ in sign by
                # rounding when the event falls on the sub-step's end: the event is then there
                s_i = h if _poly(coef, h) > 0.0 else brentq(lambda s: _poly(coef, s), 0.0, h, xtol=1e-15,
                                                              rtol=8.9e-16)
            elif da[i] < 0.0 < db[i]:
                if W is None:
                    W = flow.powers(md, z)
                dcoef = CA_ev[i] @ W
                s_star = brentq(lambda s: _poly(dcoef, s), 0.0, h, xtol=1e-15, rtol=8.9e-16)
                coef = C_ev[i] @ W
                if _poly(coef, s_star) <= 0.0:
                    s_i = brentq(lambda s: _poly(coef, s), 0.0, s_star, xtol=1e-15, rtol=8.9e-16)
            if s_i is not None and (s_ev is None or s_i < s_ev):
                s_ev, i_ev = s_i, i
    return s_ev, i_ev, W


#: most sub-steps screened at once by :func:`event_free_steps`, and the budget (flops) of the stacked rows built per
#: mode (``2 k D^2`` per sub-step for ``k`` event rows): batching pays where the Python cost of a sub-step exceeds
#: its ``D^2`` product
BATCH_STEPS = 64
BATCH_FLOPS = 4e6
#: an event function (or its derivative) within this many times its threshold of zero ends the screened run (the
#: sub-step is then located one by one, as without batching)
BATCH_MARGIN = 1e4


def event_free_steps(md, z, kmax, tol):
    """How many full sub-steps from ``z`` in mode ``md`` certainly hold no event: at most ``kmax``.

    With every event row of the mode entered (``c^T z > thr``), :func:`locate` finds an event on a full sub-step
    only where an event function ends ``<= 0`` or its derivative changes sign from ``< 0`` to ``> 0`` inside.  Both
    are screened here on ``B`` sub-steps at once from the stacked rows ``[C; C A] E^j`` (``j = 0..B``, kept with the
    mode's shared exponentials): one ``(2 k (B + 1)) x D`` product instead of ``B`` calls of :func:`locate`.  A
    sub-step whose end value or derivative lies within ``tol`` of zero (or of a sign change) ends the run, so rounding
    never hides an event the one-by-one search would find.  ``tol``: :data:`BATCH_MARGIN` times the thresholds of the
    rows ``[C; C A]``, shape ``(2 k,)``.  Returns 0 where batching does not pay (a large system with many rows)."""
    k, D = md.C.shape
    nb = min(BATCH_STEPS, int(BATCH_FLOPS // max(2 * k * D * D, 1)))
    B = min(nb, int(kmax))
    if B < 2:
        return 0
    if k == 0:
        return B
    cache = md.shared.setdefault("G_ev", {})
    key = md.C.tobytes()
    G = cache.get(key)
    if G is None:
        G = np.empty((nb + 1, 2 * k, D))
        G[0] = np.vstack([md.C, md.CA])
        for j in range(1, nb + 1):
            G[j] = G[j - 1] @ md.E
        cache[key] = G
    vals = (G[:B + 1].reshape((B + 1) * 2 * k, D) @ z).reshape(B + 1, 2 * k)
    pb, da, db = vals[1:, :k], vals[:-1, k:], vals[1:, k:]
    flag = np.any(pb <= tol[:k], axis=1) | np.any((da < tol[k:]) & (db > -tol[k:]), axis=1)
    hit = np.flatnonzero(flag)
    return int(hit[0]) if hit.size else B
