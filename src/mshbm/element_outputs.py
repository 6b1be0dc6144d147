"""Per-element outputs of a periodic solution: what each friction or contact element does over one period.

Notation: ``m`` elements, ``N`` time steps per period (grid ``t_k = k T / N``, ``k = 0..N``), element ``j``
with direction ``w_j`` (:mod:`mshbm.system`), relative displacement ``s_j = w_j^T q`` (friction: the slip
coordinate ``q_dof - q_J``; contact: ``-(q_dof - q_J)``, so that the gap is ``g_N = gap + s_j``), relative
velocity ``w_j^T u`` and force ``lambda_j`` along ``w_j`` (:attr:`mshbm.result.PeriodicSolution.lam`; for
time-stepping methods the impulse of a step divided by ``h``).

Per element (:class:`ElementOutput`):

``force`` (N), shape (N+1,)
    ``lambda_j(t_k)``.
``relative_displacement`` (m), ``relative_velocity`` (m/s), shape (N+1,)
    ``w_j^T q(t_k)`` and ``w_j^T u(t_k)`` from the solution's own representation (Fourier series or the
    time-stepped series).
``relative_amplitude`` (m)
    ``(max - min) / 2`` of ``w_j^T q`` over one period on the grid.
``dissipated_energy`` (J per period)
    ``-int w_j lambda_j . u dt``: the certificate's value (``certificate.info["energy"]["element_dissipation"]``,
    the quadrature that balances the method's energy: AFT samples for harmonic methods, the scheme's discrete
    work with impulses for Moreau-Jean) where the certificate has it, else the rectangle rule on the grid.
    For the exact event-driven flow the impacts are summed exactly from its event list (an impulse ``P > 0``
    under Newton's law leaves ``gamma+ = -e_N gamma-`` and does the work ``P gamma- (1 - e_N) / 2``) and the
    continuous forces by the rectangle rule (``dissipation_source`` says which).  Positive: the element
    removes energy.
``stick_fraction`` (friction)
    Fraction of the samples ``k < N`` whose friction force is more than 1 % inside the cone,
    ``|lambda_j| < 0.99 mu F_N`` (per sample where ``F_N`` follows a contact).  One rule for every method: for
    set-valued laws (Moreau-Jean, the event flow, DLFT) sliding samples sit on the cone to rounding; for the
    regularised law of HBM it counts the samples in the steep zone of the law, ``|u_rel| < tan(0.99 pi / 2) / s``
    with smoothing ``s``, which tends to the stuck samples as ``s`` grows.
``contact_fraction`` (contacts)
    Fraction of the samples ``k < N`` with a compressive force, ``lambda_N > 1e-12 max |lambda_N|``, or an
    impulse in the step (:attr:`~mshbm.result.PeriodicSolution.impulses`): an impact counts its one step.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ElementOutput", "element_outputs", "STICK_MARGIN"]

#: a friction sample counts as stuck when ``|lambda| < (1 - STICK_MARGIN) mu F_N``
STICK_MARGIN = 1e-2


@dataclass
class ElementOutput:
    """What one element does over one period (see the module docstring for every field)."""

    index: int
    kind: str
    dof: int
    relative_to: int | None
    force: np.ndarray
    relative_displacement: np.ndarray
    relative_velocity: np.ndarray
    relative_amplitude: float
    dissipated_energy: float
    dissipation_source: str
    stick_fraction: float | None = None
    contact_fraction: float | None = None

    def summary(self, series=False):
        """JSON-ready dict: scalars, and with ``series=True`` also the three time series (lists)."""
        d = {"index": self.index, "kind": self.kind, "dof": self.dof, "relative_to": self.relative_to,
             "relative_amplitude": self.relative_amplitude, "force_max": float(np.max(self.force)),
             "force_min": float(np.min(self.force)), "dissipated_energy": self.dissipated_energy,
             "dissipation_source": self.dissipation_source}
        if self.stick_fraction is not None:
            d["stick_fraction"] = self.stick_fraction
        if self.contact_fraction is not None:
            d["contact_fraction"] = self.contact_fraction
        if series:
            d["force"] = self.force.tolist()
            d["relative_displacement"] = self.relative_displacement.tolist()
            d["relative_velocity"] = self.relative_velocity.tolist()
        return d


def _fraction(mask):
    return float(np.count_nonzero(mask)) / mask.size if mask.size else 0.0


def element_outputs(sol, system):
    """The :class:`ElementOutput` of every element of ``system`` for the solution ``sol``
    (:class:`mshbm.result.PeriodicSolution` of that system); ``[]`` without elements or without element forces
    on the solution's grid."""
    els = list(system.elements)
    lam = np.asarray(sol.lam, dtype=float)
    t = np.asarray(sol.t)
    N = t.size - 1
    if not els or lam.ndim != 2 or lam.shape != (N + 1, len(els)):
        return []
    dofs = sorted({int(d) for e in els for d in e.dofs})
    col = {d: i for i, d in enumerate(dofs)}
    q = sol.displacement(dofs)
    u = sol.velocity(dofs)
    cert = getattr(sol, "certificate", None)
    energy = {} if cert is None else cert.info.get("energy", {})
    cert_diss = energy.get("element_dissipation")
    h = float(sol.period) / N
    P = getattr(sol, "impulses", None)
    # the exact event-driven flow lists its impacts: an impulse P > 0 of a contact under Newton's law leaves
    # gamma+ = -e_N gamma-, so it does the work P (gamma- + gamma+) / 2 = P gamma- (1 - e_N) / 2 exactly
    events = sol.info.get("event_list") if isinstance(getattr(sol, "info", None), dict) else None
    exact_impacts = events is not None and all(ev.impulse == 0.0 or els[ev.element].unilateral for ev in events)
    impact_loss = np.zeros(len(els))
    if exact_impacts:
        for ev in events:
            if ev.impulse > 0.0:
                e_n = float(els[ev.element].restitution)
                impact_loss[ev.element] -= 0.5 * ev.impulse * ev.velocity * (1.0 - e_n)
    P = None if P is None or np.shape(P) != (N, len(els)) else np.asarray(P, dtype=float)
    out = []
    for j, e in enumerate(els):
        a = col[int(e.dof)]
        s = q[:, a].copy()
        v = u[:, a].copy()
        if e.relative_to is not None:
            b = col[int(e.relative_to)]
            s -= q[:, b]
            v -= u[:, b]
        s *= e.sign
        v *= e.sign
        f = lam[:, j].copy()
        if exact_impacts:
            diss = float(-h * np.dot(f[:N], v[:N])) + impact_loss[j]
            src = "event flow: impacts exact, continuous force on the grid"
        elif cert_diss is not None and len(cert_diss) == len(els):
            diss, src = float(cert_diss[j]), "certificate"
        else:
            diss, src = float(-h * np.dot(f[:N], v[:N])), "grid"
        item = ElementOutput(j, e.kind, int(e.dof), None if e.relative_to is None else int(e.relative_to), f, s, v,
                             float(0.5 * (s.max() - s.min())), diss, src)
        if e.bounded:
            bound = e.bound_samples(lam)[:N] if e.normal_contact is not None else np.full(N, float(e.bound))
            ft = np.abs(f[:N]) if e.cone_partner is None else np.hypot(f[:N], lam[:N, e.cone_partner])  # ||lambda_T||
            item.stick_fraction = _fraction(ft < (1.0 - STICK_MARGIN) * bound)
        if e.unilateral:
            big = float(np.abs(f).max(initial=0.0))
            closed = f[:N] > 1e-12 * big if big > 0 else np.zeros(N, dtype=bool)
            if P is not None:  # impulses of the steps (the event flow reports its impacts only there)
                closed |= P[:, j] > 1e-12 * float(np.abs(P[:, j]).max(initial=0.0))
            item.contact_fraction = _fraction(closed)
        out.append(item)
    return out
