"""Transitions of the event-driven flow: consistent mode selection, Newton impacts (a small LCP),
accumulation detection and the saltation of the sensitivities at every event.

Impacts: Newton's law for all contacts touching at that instant at once, on the velocity level::

    xi = W^T M^-1 W P + (1 + E) gamma^-  >= 0,   P >= 0,   xi^T P = 0,    u+ = u- + M^-1 W P

(an LCP, :func:`_lcp`, solved by enumeration of the active set).  At a non-impulsive event the new mode is
the first *consistent* combination of the statuses left open (stick ``|lambda| <= mu F_N``, closed
``lambda >= 0``, slip starting in the direction of its acceleration).  The saltation matrix
``S = D_g + (f+ - D_g f-) c^T / (c^T f-)`` updates ``Phi = d z / d z0`` at each event.
"""
from __future__ import annotations

import functools
import itertools

import numpy as np

from ...accumulation import find_accumulations
from .modes import (CLOSED, FREE, MAX_COMBINATIONS, MODE_NAMES, SLIP_M, SLIP_P, STALL_EVENTS, STICK, Event,
                    EventError, _Switch, mode_code)

__all__ = ["Transitions"]


class Transitions:
    """Mode selection, impacts and saltation of an :class:`~mshbm.integrators.event.flow.EventFlow` (mixin)."""

    # ------------------------------------------------------------------ mode selection
    def _project(self, z, st):
        """State on the constraints of ``st`` (stick / closed: ``gamma = 0``; closed: ``g_N = 0``)."""
        n = self.n
        for j, s in enumerate(st):
            if s in (STICK, CLOSED):
                z[n + self.dof[j]] = 0.0
                if s == CLOSED:
                    z[self.dof[j]] = -self.gap[j] / self.sign[j]
        return z

    def select(self, z, base=None, allowed=None):
        """The consistent mode at state ``z`` and the state projected on its constraints.

        ``base``: the current statuses (None: none); ``allowed``: ``{j: statuses}`` imposed by an event.
        Returns ``(st, z)``.
        """
        n, m = self.n, self.m
        allowed = allowed or {}
        if m == 0:
            return (), z
        vt = 1e-9 * self.vscale(z)
        qt = 1e-12 * self.qscale(z)
        g, gam = self.gaps(z), self.gammas(z)
        cands, degenerate = [], []
        for j in range(m):
            if j in allowed:
                c = list(allowed[j])
            elif not self.is_contact[j]:
                if abs(gam[j]) > vt and not (base is not None and base[j] == STICK and abs(gam[j]) <= 1e3 * vt):
                    c = [SLIP_P if gam[j] > 0 else SLIP_M]
                else:
                    c = [STICK, SLIP_P, SLIP_M]
            else:
                if g[j] > qt or gam[j] > vt:
                    c = [FREE]
                elif abs(gam[j]) <= vt or (base is not None and base[j] == CLOSED):
                    c = [CLOSED, FREE]
                else:
                    c = [FREE]  # approaching at g = 0: the impact is found by the gap event
            if base is not None and base[j] in c:  # the current status first
                c.remove(base[j])
                c.insert(0, base[j])
            cands.append(c)
            if len(c) > 1:
                degenerate.append(j)
        total = int(np.prod([len(c) for c in cands]))
        if total == 1:
            st = tuple(c[0] for c in cands)
            return st, self._project(z.copy(), st)
        if total > MAX_COMBINATIONS:
            raise EventError(f"{len(degenerate)} elements change their status at one instant: "
                             f"{total} combinations (more than {MAX_COMBINATIONS})")
        best = None
        for st in itertools.product(*cands):
            md = self.mode(st)
            if md is None:
                continue
            zz = self._project(z.copy(), st)
            viol = self._violation(md, st, zz, degenerate)
            if viol <= 0.0:
                return st, zz
            if best is None or viol < best[0]:
                best = (viol, st, zz)
        if best is None:
            raise EventError("no element-status combination has independent constraints")
        return best[1], best[2]

    def _violation(self, md, st, z, which):
        """Largest scaled violation of the consistency conditions of ``st`` at ``z`` over the elements
        ``which`` (``<= 0``: consistent, with a relative tolerance of 1e-9)."""
        n = self.n
        lam = md.Lam @ z
        acc = (md.A @ z)[n:2 * n]
        ascale = max(np.abs(acc).max(), self.omega * self.vscale(z), 1e-300)
        v = -np.inf
        for j in which:
            s = st[j]
            ga = self.sign[j] * acc[self.dof[j]]
            fs = max(self.bound[j], ascale / self.sw_all[j])
            if s == STICK:
                x = (abs(lam[j]) - self.bound[j]) / fs
            elif s == CLOSED:
                x = -lam[j] / fs
            elif s == SLIP_P or s == FREE:
                x = -ga / ascale
            else:
                x = ga / ascale
            v = max(v, x - 1e-9)
        return v

    # ------------------------------------------------------------------ transitions
    def _transition(self, md, i_ev, z, t, ctx):
        """New mode, post-event state, jump Jacobian (None: identity) and the events of this instant."""
        j, kind, sgn = md.ev[i_ev]
        st = md.st
        n = self.n
        if kind == "gap":
            gam = self.gammas(z)[j]
            if gam >= 0.0:  # grazing without approach: nothing happens
                return st, z, None, [Event(t, f"{MODE_NAMES[st[j]]}->{MODE_NAMES[st[j]]}", 0.0, gam,
                                           self.index[j])]
            return self._impact(st, j, z, t, ctx)
        z = z.copy()
        allowed = {}
        gam0 = self.gammas(z)
        if kind == "slip":
            z[n + self.dof[j]] = 0.0
            allowed[j] = [STICK, SLIP_M if st[j] == SLIP_P else SLIP_P]
        elif kind == "bound":
            allowed[j] = [SLIP_M if sgn > 0 else SLIP_P]
        else:  # lift
            allowed[j] = [FREE]
        new, z = self.select(z, st, allowed)
        evs = [Event(t, f"{MODE_NAMES[st[k]]}->{MODE_NAMES[new[k]]}", 0.0, float(gam0[k]), self.index[k])
               for k in range(self.m) if k == j or new[k] != st[k]]
        return new, z, None, evs

    def _zeno(self, st, j, z, gam):
        """True if the next bounce of contact ``j`` (approach velocity ``gam < 0``) is below resolution."""
        e = self.e[j]
        if e >= 1.0:
            return False
        n = self.n
        if e * abs(gam) <= 1e-10 * self.vscale(z):
            return True
        st_c = tuple(CLOSED if k == j else s for k, s in enumerate(st))
        md = self.mode(st_c)
        if md is None:
            return False
        zz = z.copy()
        zz[n + self.dof[j]] = 0.0
        lam = float(md.Lam[j] @ zz)
        height = (e * gam) ** 2 / (2.0 * self.sw_all[j] * lam) if lam > 0.0 else np.inf
        return height <= 1e-10 * max(abs(self.gap[j]), np.abs(z[:n]).max(), self.qref)

    def _impact(self, st, j, z, t, ctx):
        n, D = self.n, self.D
        z = z.copy()
        z[self.dof[j]] = -self.gap[j] / self.sign[j]
        g, gam = self.gaps(z), self.gammas(z)
        qt = 1e-12 * self.qscale(z)
        touch = [k for k in range(self.m) if self.is_contact[k] and (k == j or st[k] == CLOSED or abs(g[k]) <= qt)]
        e = self.e[touch].copy()
        for a, k in enumerate(touch):
            if gam[k] < 0.0 and 0.0 < e[a] < 1.0:  # (e = 0: plastic, the contact closes at once)
                zeno = self._zeno(st, k, z, gam[k])
                if not zeno and self.accumulation != "close":
                    imp = ctx["impacts"].setdefault(k, [])
                    if len(imp) >= 5:
                        acc = find_accumulations(imp[-11:] + [t], min_impacts=6)
                        zeno = bool(acc) and abs(acc[-1].t_last - t) <= 1e-12 * max(abs(t), self.T)
                if zeno:
                    if self.accumulation == "moreau":
                        raise _Switch(f"accumulation of impacts at contact {self.index[k]} (e_N = {self.e[k]:g}) "
                                      f"at t = {t:.9g}", [k])
                    if self.accumulation == "error":
                        raise EventError(f"accumulation of impacts at contact {self.index[k]} at t = {t:.9g}")
                    e[a] = 0.0
        Wt, MWt = self.W[:, touch], self.MW[:, touch]
        Del = Wt.T @ MWt
        gt = gam[touch]
        P = _lcp(Del, (1.0 + e) * gt)
        S = np.nonzero(P > 0.0)[0]
        u_minus = z[n:2 * n].copy()
        z[n:2 * n] += MWt @ P
        Dg = np.eye(D)
        if S.size:
            Ss = [touch[a] for a in S]
            X = np.linalg.solve(Del[np.ix_(S, S)], (1.0 + e[S])[:, None] * self.W[:, Ss].T)
            Dg[n:2 * n, n:2 * n] -= self.MW[:, Ss] @ X
        for a, k in enumerate(touch):
            if e[a] == 0.0 and P[a] > 0.0:
                z[n + self.dof[k]] = 0.0  # plastic: on the constraint exactly
        gp = self.gammas(z)
        vt = 1e-9 * self.vscale(z)
        allowed = {}
        for a, k in enumerate(touch):
            allowed[k] = [FREE] if gp[k] > vt else [CLOSED, FREE]
        base = tuple(FREE if k in touch else s for k, s in enumerate(st))
        new, z = self.select(z, base, allowed)
        evs = []
        for a, k in enumerate(touch):
            if P[a] > 0.0 or k == j or new[k] != st[k]:
                evs.append(Event(t, f"{MODE_NAMES[st[k]]}->{MODE_NAMES[new[k]]}", float(P[a]), float(gam[k]),
                                 self.index[k]))
                if P[a] > 0.0 and st[k] == FREE:
                    ctx["impacts"].setdefault(k, []).append(t)
        gm = self.sign * u_minus[self.dof]
        for k in range(self.m):
            if k not in touch and new[k] != st[k]:
                evs.append(Event(t, f"{MODE_NAMES[st[k]]}->{MODE_NAMES[new[k]]}", 0.0, float(gm[k]),
                                 self.index[k]))
        return new, z, Dg, evs

    def _event(self, md, i_ev, z, t, ctx, Phi, events, nodes, new=None, zp=None, Dg=None, evs=None):
        """Apply the transition of event ``i_ev`` of mode ``md`` at ``(t, z)``: saltation of ``Phi``, events
        and nodes recorded.  Returns ``(new mode, z+, Phi)``."""
        if new is None:
            new, zp, Dg, evs = self._transition(md, i_ev, z, t, ctx)
        if Phi is not None:
            D = self.D
            nmd = self.mode(new)
            c = md.C[i_ev]
            fm = md.A @ z
            fp = nmd.A @ zp
            den = float(c @ fm)
            if den == 0.0:
                den = 1e-300
            cP = c @ Phi
            if Dg is None:  # S Phi = Phi + (f+ - f-) (c^T Phi) / (c^T f-)
                Phi = Phi + np.outer(fp - fm, cP / den)
            else:  # D_g differs from the identity in the velocity block only (the impact law)
                n = self.n
                Dfm = fm.copy()
                Dfm[n:2 * n] = Dg[n:2 * n, n:2 * n] @ fm[n:2 * n]
                Phi = Phi.copy()
                Phi[n:2 * n] = Dg[n:2 * n, n:2 * n] @ Phi[n:2 * n]
                Phi += np.outer(fp - Dfm, cP / den)
        events += evs
        if nodes is not None:
            nodes.append((t, z.copy(), zp.copy(), mode_code(new)))
        return new, zp, Phi

    def _stalled(self, events, t):
        if len(events) >= STALL_EVENTS and events[-1].t - events[-STALL_EVENTS].t <= 1e-12 * self.T \
                and len({(e.kind, e.element) for e in events[-STALL_EVENTS:]}) == 1:
            return f"{STALL_EVENTS} '{events[-1].kind}' events at t = {t:.12g} without progress in time (chattering)"
        return ""

    def _project_jac(self, Phi, st):
        """Variations on the constraints of ``st`` (rows of ``gamma`` and closed ``g_N`` zeroed)."""
        n = self.n
        for j, s in enumerate(st):
            if s in (STICK, CLOSED):
                Phi[n + self.dof[j]] = 0.0
                if s == CLOSED:
                    Phi[self.dof[j]] = 0.0
        return Phi


@functools.lru_cache(maxsize=None)
def _active_sets(k):
    """The candidate active sets of :func:`_lcp` for ``k`` unknowns, smallest first: ``(S, rest)`` index arrays
    (read-only), ``rest`` the complement of ``S``."""
    idx = np.arange(k)
    out = []
    for mask in sorted(range(1, 2 ** k), key=lambda s: bin(s).count("1")):
        sel = np.array([(mask >> i) & 1 == 1 for i in range(k)])
        S, rest = idx[sel], idx[~sel]
        S.setflags(write=False)
        rest.setflags(write=False)
        out.append((S, rest))
    return tuple(out)


def _lcp(A, b):
    """Solution ``x`` of ``0 <= x _|_ A x + b >= 0`` for a small symmetric positive definite ``A``
    (enumeration of the active set, smallest sets first)."""
    k = b.size
    if np.all(b >= 0.0):
        return np.zeros(k)
    tol = 1e-12 * max(np.abs(b).max(), 1e-300)
    neg = -tol * 1e-3 / max(np.abs(np.diag(A)).max(), 1e-300)
    for S, rest in _active_sets(k):
        xs = np.linalg.solve(A[np.ix_(S, S)], -b[S])
        if np.any(xs < neg):
            continue
        x = np.zeros(k)
        x[S] = np.maximum(xs, 0.0)
        w = A @ x + b
        if np.all(w[rest] >= -tol):
            return x
    # projected Gauss-Seidel (A positive definite: converges)
    x = np.zeros(k)
    for _ in range(10000):
        x_old = x.copy()
        for i in range(k):
            x[i] = max(0.0, x[i] - (A[i] @ x + b[i]) / A[i, i])
        if np.abs(x - x_old).max() <= 1e-15 * max(np.abs(x).max(), 1e-300):
            break
    return x
