"""Post-processing of event-driven runs: dense output, the run record of a solution, exact extrema and
the grazing margins of the contacts."""
from __future__ import annotations

import math

import numpy as np
from ..._deferred import brentq

from .modes import FREE, MOREAU, _poly, mode_tuple

__all__ = ["EventTrajectory", "run_summary", "extrema", "contact_margins"]


class EventTrajectory:
    """Dense output of a recorded simulation (one period): ``evaluate(t)`` gives ``q, u, lambda`` at any
    times (mapped into one period) from the Taylor series of the exact flow about the nearest preceding
    node (linear interpolation inside Moreau-Jean segments)."""

    def __init__(self, flow, nodes, t_start):
        self.flow, self.t_start = flow, float(t_start)
        self.node_t = np.array([nd[0] for nd in nodes])
        self.node_z = np.array([nd[2] for nd in nodes])
        self.node_zl = np.array([nd[1] for nd in nodes])
        self.node_mode = np.array([nd[3] for nd in nodes], dtype=np.int64)

    @property
    def period(self):
        return self.flow.T

    def evaluate(self, t):
        """``(q, u, lam)`` at times ``t`` (array), shapes (k, n), (k, n), (k, m_all).

        At an event time the state after the event is returned.  ``lam`` inside Moreau-Jean segments is NaN.
        """
        fl = self.flow
        t = np.atleast_1d(np.asarray(t, dtype=float))
        tau = self.t_start + np.mod(t - self.t_start, fl.T)
        idx = np.searchsorted(self.node_t, tau, side="right") - 1
        idx = np.clip(idx, 0, self.node_t.size - 1)
        Z = np.empty((t.size, fl.D))
        lam = np.full((t.size, len(fl.system.elements)), np.nan)
        for i in np.unique(idx):
            sel = np.nonzero(idx == i)[0]
            code = int(self.node_mode[i])
            if code == MOREAU:
                i2 = min(i + 1, self.node_t.size - 1)
                dt = self.node_t[i2] - self.node_t[i]
                wgt = (tau[sel] - self.node_t[i]) / dt if dt > 0 else np.zeros(sel.size)
                Z[sel] = (1 - wgt)[:, None] * self.node_z[i] + wgt[:, None] * self.node_zl[i2]
                continue
            md = fl.mode(code)
            W = fl.powers(md, self.node_z[i])
            Z[sel] = (W @ fl.spow(tau[sel] - self.node_t[i], md.n_taylor).T).T
            lam[sel] = fl.full_force(md, Z[sel].T).T
        n = fl.n
        return Z[:, :n], Z[:, n:2 * n], lam


def run_summary(run):
    """The ``info["event_integrator"]`` record of a solution from one :meth:`EventFlow.simulate` run
    (:class:`~.flow.FlowRun`: events, impacts, Moreau-Jean fallback segments, message, whether the monodromy
    is exact)."""
    return {"events": len(run.events),
            "impacts": sum(1 for e in run.events if e.impulse != 0.0),
            "switched_to_moreau": run.switched,
            "moreau_segments": [{k: v for k, v in seg.items() if k not in ("force_times", "forces")}
                                for seg in run.moreau_segments],
            "message": run.message or "exact event-driven flow over the whole period",
            "monodromy_exact": run.monodromy_exact}


def extrema(flow, nodes):
    """True max and min of every ``q_j`` over the nodes' period (zeros of ``u_j`` between nodes).

    Returns ``(q_max, q_min, n_roots)``, shapes (n,), (n,), int.
    """
    n = flow.n
    Zl = np.array([nd[1] for nd in nodes])
    Zr = np.array([nd[2] for nd in nodes])
    qmax = np.maximum(Zl[:, :n].max(axis=0), Zr[:, :n].max(axis=0))
    qmin = np.minimum(Zl[:, :n].min(axis=0), Zr[:, :n].min(axis=0))
    ts = np.array([nd[0] for nd in nodes])
    ua, ub = Zr[:-1, n:2 * n], Zl[1:, n:2 * n]
    cand = np.nonzero(np.any(ua * ub < 0.0, axis=1))[0]
    n_roots = 0
    for i in cand:
        dt = ts[i + 1] - ts[i]
        if dt <= 0.0 or nodes[i][3] == MOREAU:
            continue
        md = flow.mode(nodes[i][3])
        W = flow.powers(md, Zr[i])
        for j in np.nonzero(ua[i] * ub[i] < 0.0)[0]:
            cu = W[n + j]
            f0, f1 = _poly(cu, 0.0), _poly(cu, dt)
            if not f0 * f1 < 0.0:
                continue
            s = brentq(lambda s: _poly(cu, s), 0.0, dt, xtol=1e-15, rtol=8.9e-16)
            qj = float(_poly(W[j], s))
            qmax[j] = max(qmax[j], qj)
            qmin[j] = min(qmin[j], qj)
            n_roots += 1
    return qmax, qmin, n_roots


def contact_margins(flow, run):
    """How far each contact of a simulated interval is from a grazing, from one :meth:`EventFlow.simulate`
    run (:class:`~.flow.FlowRun`, ``record=True``).

    A grazing is a contact touched with zero relative velocity: an impact whose velocity tends to 0, or a
    near miss (a local minimum of the gap in free flight) whose gap tends to 0.  Where either vanishes
    along a branch the number of impacts per period changes and the orbit's sensitivities jump (the
    saltation matrix of an impact at velocity ``v`` grows like ``1 / v``).

    Returns
    -------
    dict
        Keyed by the element's index in ``system.elements`` (contacts only): ``{"impacts": int``, the
        impacts of that contact in the interval; ``"v_min"``: the smallest ``|gamma_N^-|`` of those impacts
        (m/s; ``inf`` without impacts); ``"miss"``: the smallest gap ``g_N = gap + w^T q >= 0`` at a local
        minimum of ``g_N`` in free flight, located exactly on the flow between nodes (m; ``inf`` without
        one); ``"t_miss"``: its time (s)``}``.
    """
    n, nodes = flow.n, run.nodes
    res = {}
    if not nodes:
        return res
    ts = np.array([nd[0] for nd in nodes])
    Zl = np.array([nd[1] for nd in nodes])
    Zr = np.array([nd[2] for nd in nodes])
    codes = np.array([nd[3] for nd in nodes], dtype=np.int64)
    for a in range(flow.m):
        if not flow.is_contact[a]:
            continue
        j, d, sg, g0 = flow.index[a], int(flow.dof[a]), float(flow.sign[a]), float(flow.gap[a])
        imps = [e for e in run.events if e.element == j and e.impulse != 0.0]
        rec = {"impacts": len(imps), "v_min": min((abs(float(e.velocity)) for e in imps), default=math.inf),
               "miss": math.inf, "t_miss": math.nan}
        # g_N' = sg u_d goes from - to + inside a smooth piece [node i, node i+1] with the contact free
        ga, gb = sg * Zr[:-1, n + d], sg * Zl[1:, n + d]
        free = np.array([c != MOREAU and mode_tuple(c, flow.m)[a] == FREE for c in codes[:-1]], dtype=bool)
        for i in np.nonzero(free & (ga < 0.0) & (gb > 0.0))[0]:
            dt = ts[i + 1] - ts[i]
            if dt <= 0.0:
                continue
            W = flow.powers(flow.mode(int(codes[i])), Zr[i])
            cu = W[n + d]
            if not _poly(cu, 0.0) * _poly(cu, dt) < 0.0:
                continue
            s = brentq(lambda s: _poly(cu, s), 0.0, dt, xtol=1e-15, rtol=8.9e-16)
            g = g0 + sg * float(_poly(W[d], s))
            if g < rec["miss"]:
                rec["miss"], rec["t_miss"] = g, float(ts[i] + s)
        # a minimum exactly at the ends of the interval (periodic orbit: g_N' < 0 at its end, > 0 at its start)
        if codes[0] != MOREAU and mode_tuple(int(codes[0]), flow.m)[a] == FREE \
                and sg * Zr[0, n + d] >= 0.0 and sg * Zl[-1, n + d] <= 0.0:
            g = g0 + sg * float(Zr[0, d])
            if g < rec["miss"]:
                rec["miss"], rec["t_miss"] = g, float(ts[0])
        res[j] = rec
    return res
