"""Detection of accumulations of impacts (Zeno points) in a sequence of impact times.

An *accumulation point* of impacts is a time ``t_inf`` at which infinitely many
impacts accumulate: the intervals ``tau_k = t_{k+1} - t_k`` between consecutive
impacts shrink so fast that their sum converges.  Near such a point the contact
force pressing the body on the stop is almost constant, ``a = w^T M^-1 w lambda``
per unit impulse, so each flight lasts ``tau_k = 2 v_k / a`` after an impact with
rebound velocity ``v_k``, and Newton's law ``v_{k+1} = e_N v_k`` makes the
intervals a geometric sequence ``tau_{k+1} = e_N tau_k``.  The classical example
is a ball dropped on a table (constant gravity ``g``): released upwards from the
table at ``t_0`` with velocity ``v_0`` it comes to rest at

    t_inf = t_0 + 2 v_0 / (g (1 - e_N)).

With ``e_N = 1`` the intervals do not shrink geometrically: for smooth forcing
the rebound velocity changes by ``O(v_k^2)`` per flight, so ``v_k >~ c / k`` and
the flight times ``tau_k ~ v_k`` have a divergent sum -- no accumulation away
from grazing (Budd & Dux 1994; Brogliato, *Nonsmooth Mechanics*).

The detector (:func:`find_accumulations`) looks for runs of at least
``min_impacts`` consecutive impacts whose interval ratios
``r_k = tau_{k+1} / tau_k`` all lie in ``(0, max_ratio]`` and agree with their
median within ``ratio_spread`` (trailing ratios that do not are dropped: bounces the
data no longer resolve); it extrapolates the geometric tail by Aitken's formula
``t_inf = t_{j+2} - tau_{j+1}^2 / (tau_{j+1} - tau_j)`` (exact for a geometric
sequence), the median over the run.  Inputs:

* :func:`from_events`: the events of :mod:`mshbm.methods.exact` (impacts ``"free->free"``
  and the closing impact ``"free->closed"`` of a resolved accumulation);
* :func:`from_impulses`: Moreau-Jean time-stepping (the first step of every run
  of steps with a nonzero impulse is an impact; a run of more than
  ``contact_steps`` steps is persistent contact, and intervals of fewer than
  ``min_interval_steps`` steps are not resolved by the grid and end a run).

Periodic data (``period`` given) are rotated to start after the largest gap, so
that a sequence crossing ``t = 0`` is seen as one.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["Accumulation", "find_accumulations", "from_events", "from_impulses"]


@dataclass
class Accumulation:
    """One accumulation of impacts.

    Attributes
    ----------
    t_inf : float
        Extrapolated accumulation time (s); for periodic data in ``[0, period)``.
    t_first, t_last : float
        First and last resolved impact of the run (s).
    n_impacts : int
        Resolved impacts in the run.
    ratio : float
        Median ratio ``tau_{k+1} / tau_k`` of consecutive intervals (``~ e_N``).
    """

    t_inf: float
    t_first: float
    t_last: float
    n_impacts: int
    ratio: float

    def as_dict(self):
        return {k: (int(v) if k == "n_impacts" else float(v)) for k, v in asdict(self).items()}


def find_accumulations(times, min_impacts=6, max_ratio=0.95, ratio_spread=0.15, period=None):
    """Accumulations in a sorted sequence of impact times.

    Parameters
    ----------
    times : array_like, shape (k,)
        Impact times (s), ascending (for periodic data: in ``[0, period)``).
    min_impacts : int
        Shortest run of impacts with geometrically shrinking intervals that counts
        (at least 4: three intervals, two ratios).
    max_ratio : float
        Largest interval ratio of a shrinking run (``< 1``).
    ratio_spread : float
        Largest deviation of a ratio from the run's median ratio.
    period : float, optional
        Period of periodic data: the sequence is read cyclically.

    Returns
    -------
    list of Accumulation
    """
    t = np.sort(np.asarray(times, dtype=float).reshape(-1))
    min_impacts = max(4, int(min_impacts))
    if t.size < min_impacts:
        return []
    shift = 0.0
    if period is not None:
        gaps = np.diff(np.concatenate([t, [t[0] + period]]))
        j = int(np.argmax(gaps))
        t = np.concatenate([t[j + 1:], t[:j + 1] + period]) if j + 1 < t.size else t
        shift = float(period)
    tau = np.diff(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = tau[1:] / tau[:-1]
    ok = (tau[1:] > 0) & (tau[:-1] > 0) & (r > 0) & (r <= max_ratio)
    out = []
    k = 0
    while k < r.size:
        if not ok[k]:
            k += 1
            continue
        s = k
        while k < r.size and ok[k]:
            k += 1
        # ratios r[s:e] involve impacts s .. e+1; drop trailing ratios off the run's median (the end of a
        # run that the data no longer resolve, e.g. bounces shorter than a few time steps)
        e = k
        while e - s >= 2 and np.max(np.abs(r[s:e] - np.median(r[s:e]))) > ratio_spread:
            e -= 1
        rr = r[s:e]
        n_imp = e - s + 2
        if n_imp >= min_impacts and np.max(np.abs(rr - np.median(rr))) <= ratio_spread:
            med = float(np.median(rr))
            # Aitken's extrapolation of every three consecutive impacts, t_{j+2} - tau_{j+1}^2 / (tau_{j+1} - tau_j)
            # (exact for a geometric sequence); the median is robust to impact times rounded to a grid
            tj, tj1 = tau[s:e], tau[s + 1:e + 1]
            t_inf = float(np.median(t[s + 2:e + 2] + tj1 ** 2 / (tj - tj1)))
            t_last = float(t[e + 1])
            t_first = float(t[s])
            if period is not None:
                t_inf, t_first, t_last = (x % shift for x in (t_inf, t_first, t_last))
            out.append(Accumulation(t_inf, t_first, t_last, n_imp, med))
    return out


def from_events(events, period=None, **kw):
    """Accumulations in the events of :mod:`mshbm.methods.exact` (``Event`` objects or dicts).

    Impacts are the events out of the open contact with a positive impulse
    (``"free->free"``: a bounce; ``"free->closed"``: the impact that closes a
    resolved accumulation, included as its last impact).
    """
    times = []
    for ev in events:
        kind = ev["kind"] if isinstance(ev, dict) else ev.kind
        imp = ev["impulse"] if isinstance(ev, dict) else ev.impulse
        t = ev["t"] if isinstance(ev, dict) else ev.t
        if kind.startswith("free->") and imp > 0.0:
            times.append(float(t))
    return find_accumulations(times, period=period, **kw)


def from_impulses(t, impulses, contact_steps=2, min_interval_steps=4, period=None, **kw):
    """Accumulations in Moreau-Jean output (impulse of every step).

    Parameters
    ----------
    t : array_like, shape (N+1,) or (N,)
        Step times (s); ``t[k]`` is the start of step ``k``.
    impulses : array_like, shape (N,) or (N, 1)
        Impulse of the contact over each step (``> 0``: contact active).
    contact_steps : int
        A run of more than this many consecutive impulse steps is persistent
        contact (the grid can no longer separate the bounces): it ends a run of
        impacts and counts as its last impact.
    min_interval_steps : int
        Intervals shorter than this many steps are not resolved: they end a run.
    period : float, optional
        Periodic data (the run may cross ``t = 0``).
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    P = np.asarray(impulses, dtype=float).reshape(-1)
    act = P > 0.0
    if not act.any():
        return []
    h = float(t[1] - t[0]) if t.size > 1 else 1.0
    starts = np.nonzero(act & ~np.concatenate([[False], act[:-1]]))[0]
    if period is not None and act[0] and act[-1]:
        starts = starts[starts != 0]  # the run crossing t = 0 starts at its first step before the end
        if not starts.size:
            return []
    lengths = []
    for s in starts:
        e = s
        while act[(e + 1) % act.size] and e + 1 - s < act.size:
            e += 1
        lengths.append(e - s + 1)
    times, runs = [], []
    for s, length in zip(starts, lengths):
        times.append(t[s])
        runs.append(length)
    times = np.asarray(times)
    order = np.argsort(times)
    times, runs = times[order], np.asarray(runs)[order]
    # split the sequence where the grid stops resolving it: after persistent contact, or before an
    # interval of fewer than min_interval_steps steps
    seqs, cur = [], []
    for i, (ti, ln) in enumerate(zip(times, runs)):
        if cur and ti - cur[-1] < min_interval_steps * h * (1 - 1e-9):
            seqs.append(cur)
            cur = []
        cur.append(ti)
        if ln > contact_steps:
            seqs.append(cur)
            cur = []
    if cur:
        seqs.append(cur)
    if period is not None and len(seqs) == 1:
        return find_accumulations(seqs[0], period=period, **kw)
    out = []
    for sq in seqs:
        out += find_accumulations(sq, **kw)
    return out
