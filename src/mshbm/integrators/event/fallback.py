"""Moreau-Jean fallback of the event-driven flow at accumulations of impacts and chattering.

The flow switches to the Moreau-Jean step map (:class:`mshbm.integrators.moreau_jean.MoreauJean`,
``moreau_steps`` steps per period) for the rest of a contact phase, until no element has an impulse or a
status change over :data:`~.modes.RELEASE_STEPS` steps; the step Jacobians of those segments hold no
saltation terms.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..moreau_jean import MoreauJean
from .modes import MOREAU, RELEASE_STEPS, EventError

__all__ = ["MoreauFallback", "STEPPERS"]

#: Moreau-Jean steppers kept per flow (one per step size; the oldest other than the full step is dropped first)
STEPPERS = 16


class MoreauFallback:
    """Moreau-Jean segments of an :class:`~mshbm.integrators.event.flow.EventFlow` (mixin)."""

    # ------------------------------------------------------------------ Moreau-Jean fallback
    def _stepper(self, h):
        key = float(h)
        if key not in self._mj:
            if len(self._mj) >= STEPPERS:  # the last chunk's steps vary with the state (and the start-time replays)
                h0 = self.T / self.moreau_steps
                del self._mj[next(k for k in self._mj if k != h0)]
            s = self.system
            self._mj[key] = MoreauJean(s.M, s.C, s.K, self.elements, h, 0.5, True)
        return self._mj[key]

    def _moreau(self, a, z, T_end, Phi, sample, nodes, reason, fourier=None):
        """Moreau-Jean steps from ``(a, z)`` until the phase ends (or ``T_end``).  Returns ``(a, z, Phi,
        segment)``."""
        n = self.n
        h0 = self.T / self.moreau_steps
        q, u = z[:n].copy(), z[n:2 * n].copy()
        t_start, steps, quiet = a, 0, 0
        forces = []
        chunk = 4 * RELEASE_STEPS
        last = None
        while a < T_end * (1 - 1e-15) and quiet < RELEASE_STEPS:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                raise EventError("time limit of the event-driven simulation reached")
            if self.work_limit is not None and self.work > self.work_limit:
                raise EventError(f"work budget of the event-driven simulation spent ({self.work:.3g} of "
                                 f"{self.work_limit:.3g} flop equivalents, in a Moreau-Jean segment at t = {a:.9g})")
            rem = T_end - a
            k = chunk
            h = h0
            if rem < chunk * h0 * (1 + 1e-12):
                k = max(1, int(math.ceil(rem / h0 - 1e-9)))
                h = rem / k
            mj = self._stepper(h)
            tt = a + h * np.arange(k + 1)
            tr = mj.run(q, u, mj.increments(self.forcing_at(tt)))
            # (work: a step's Python-free kernel ~ its (2n)^2 products, the monodromy's 2n columns when carried)
            self.work += k * 8.0 * n * n * (1 + (2 * n if Phi is not None else 0))
            if Phi is not None:  # d(q, u) through the segment; the forcing states' influence is neglected
                J = mj.monodromy(tr.status)
                Phi = np.vstack([J @ Phi[:2 * n], Phi[2 * n:]])
            Zs = np.vstack([tr.q.T, tr.u.T, np.array([self.exo(x) for x in tt]).T])
            if fourier is not None:  # trapezoidal quadrature of the Fourier integrals on the steps
                Bq = self._fourier_basis(tt, fourier[0])[:, :, None] * tr.q[:, None, :n]
                fourier[1] += 0.5 * h * (Bq[:-1] + Bq[1:]).sum(axis=0)
            sample(tt, Zs)
            if nodes is not None:
                for i in range(1, k + 1):
                    nodes.append((tt[i], Zs[:, i].copy(), Zs[:, i].copy(), MOREAU))
            # quiet steps: no contact impulse and no status change
            for i in range(k):
                row = tuple(int(s) & 3 for s in tr.status[i])
                imp = bool(np.any(tr.P[i][self.is_contact] != 0.0)) if self.m else False
                quiet = 0 if (imp or (last is not None and row != last)) else quiet + 1
                last = row
            forces.append((tt[:-1] + 0.5 * h, tr.P / h))
            q, u = tr.q[-1].copy(), tr.u[-1].copy()
            a = float(tt[-1])
            steps += k
        z = np.concatenate([q, u, self.exo(a)])
        tm = np.concatenate([f[0] for f in forces])
        lm = np.vstack([f[1] for f in forces])
        return a, z, Phi, {"t_start": t_start, "t_end": a, "steps": steps, "reason": reason,
                           "force_times": tm, "forces": lm}

    def _moreau_start(self, md, i_ev, z, a, Phi):
        """What :meth:`_moreau_shift` needs of the event at ``(a, z)`` (pre-event state, mode ``md``, event ``i_ev``)
        where a Moreau-Jean segment starts: the row ``d a / d x = -c^T Phi / (c^T f-)`` of the event time's
        variation (as in the saltation matrix), the state, the time and ``f-``; None where ``c^T f- = 0``."""
        c = md.C[i_ev]
        fm = md.A @ z
        den = float(c @ fm)
        if den == 0.0 or not np.isfinite(den):
            return None
        return -(c @ Phi) / den, z.copy(), float(a), fm

    def _moreau_shift(self, start, seg, z_new, st, T_end, Phi):
        """``Phi`` after a Moreau-Jean segment with the variation of the segment's start time: the segment starts at
        an event whose time ``a`` moves with the unknowns (``start``: :meth:`_moreau_start`), and its steps move
        with it, so its end state moves by ``m = d z_e / d a`` (at fixed number of steps; the step map is applied at
        the shifted forcing times) and, where the segment ends by release (not at ``T_end``), its end time by
        ``d a``, which the flow after it turns into ``-f+ d a`` (``f+`` the vector field of the mode ``st`` entered
        at ``z_new``).  ``Phi`` (shape ``(D, k)``) gets ``(m - f+) (d a / d x)`` on its ``(q, u)`` rows.  The product
        of the step Jacobians alone (``_moreau``) misses this term, like a saltation matrix: Newton with it converges
        only linearly (ratio 0.3 on the stopped cantilever's impacting orbits near its chattering contact phase).
        ``m`` is a central difference of two replays of the segment (start shifted by ``+-1e-4`` of a step along
        ``f-``); where a replay takes another number of steps ``Phi`` is returned unchanged."""
        if start is None or Phi is None or seg["steps"] == 0:
            return Phi
        ax, z0, a0, fm = start
        n2 = 2 * self.n
        delta = 1e-4 * self.T / self.moreau_steps
        ends = []
        for d in (delta, -delta):
            _, ze, _, sg = self._moreau(a0 + d, z0 + d * fm, T_end, None, lambda *args: None, None, seg["reason"])
            if sg["steps"] != seg["steps"]:
                return Phi
            ends.append(ze[:n2])
        m = (ends[0] - ends[1]) / (2.0 * delta)
        if seg["t_end"] < T_end * (1 - 1e-15):  # ended by release: its end time moves with its start
            m = m - (self.mode(st).A @ z_new)[:n2]
        Phi = Phi.copy()
        Phi[:n2] += np.outer(m, ax)
        return Phi

    def moreau_force(self, segments, t):
        """Element forces (all ``system.elements``) at times ``t`` inside Moreau-Jean segments: the impulse of
        the step containing ``t`` divided by the step, shape (k, m_all) (NaN outside the segments)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.full((t.size, len(self.system.elements)), np.nan)
        for seg in segments:
            tm, lm = seg["force_times"], seg["forces"]
            if tm.size == 0:
                continue
            sel = (t >= seg["t_start"]) & (t <= seg["t_end"])
            if np.any(sel):
                i = np.clip(np.searchsorted(tm, t[sel]), 0, tm.size - 1)
                i = np.where((i > 0) & (np.abs(tm[np.maximum(i - 1, 0)] - t[sel]) < np.abs(tm[i] - t[sel])), i - 1, i)
                out[np.ix_(np.nonzero(sel)[0], self.index)] = lm[i]
        return out
