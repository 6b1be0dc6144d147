"""Pieces shared by the nonlinear-mode residuals (:mod:`mshbm.methods.epmc`, :mod:`mshbm.methods.modes`,
:mod:`mshbm.methods.modes_mixed`, :mod:`mshbm.methods.modes_moreau`).

Each residual has unknowns ``y = [x, omega, xi]`` (``x`` the method's own ``n_x`` unknowns, ``omega`` in rad/s,
``xi`` the artificial negative damping in 1/s) and the parameter ``lam = ln(a / a_ref)`` (``a`` the
mass-normalised first-harmonic modal amplitude, kg^1/2 m), which enters only the amplitude row ``n_x``
(``R_amp = ... - a``).  The columns ``dR/domega`` and ``dR/dxi`` are central differences of the residual's
rows rebuilt at ``omega (1 +- FD_OMEGA)`` and ``xi +- FD_XI omega`` at fixed ``x``: they steer Newton and
the continuation's tangent only (the solution is the root of ``R``).
"""
from __future__ import annotations

import numpy as np

__all__ = ["ENERGY_TOL", "FD_OMEGA", "FD_XI", "MOREAU_STEPS", "SHOOTING_STEPS", "fd_omega_xi", "ModalParameter",
           "xi_guess"]

#: relative central-difference steps of ``dR/domega`` and ``dR/dxi`` (the latter relative to omega)
FD_OMEGA, FD_XI = 1e-6, 1e-6


def fd_omega_xi(rows, omega, xi):
    """``[dR/domega, dR/dxi]``, shape ``(len(rows(omega, xi)), 2)``, by central differences of ``rows(omega,
    xi)`` (the residual rows at fixed ``x``, without the amplitude ``a``: it does not depend on omega or xi)."""
    cols = []
    for om, xx, d in ((omega * (1 + FD_OMEGA), xi, omega * FD_OMEGA), (omega, xi + FD_XI * omega, FD_XI * omega)):
        cols.append((np.asarray(rows(om, xx)) - np.asarray(rows(2 * omega - om, 2 * xi - xx))) / (2 * d))
    return np.stack(cols, axis=1)


#: gate of the energy balance (relative): the harmonic balance satisfies it to the residual's accuracy
ENERGY_TOL = 1e-6
#: output samples per period of a point by shooting (the flow is exact: they only split it into pieces)
SHOOTING_STEPS = 256
#: Moreau-Jean steps per period of a backbone by Moreau-Jean (order 1 at stick-slip and impacts)
MOREAU_STEPS = 1024


class ModalParameter:
    """Base of the mode residuals: what :func:`mshbm.backbone.backbone` asks of one.

    A subclass sets ``n_x``, ``n_unknowns``, ``ref_dof``, ``omega0``, ``a_ref`` (by the caller) and implements
    ``residual(y, lam, jac)``, ``residual_scale``, ``unknown_scale``, ``start(a)`` and ``point(y, lam, dofs)``
    (a dict of the fields of :mod:`mshbm.backbone`).  It declares (class attributes, or set in ``__init__``):

    ``integrator``
        ``None`` (harmonic balance), ``"event"`` (the exact event-driven flow) or ``"moreau"``.
    ``event_flow``
        ``True`` where the branch has corners at changes of the event sequence: the residual then offers
        ``segment(y, lam)`` (the sequence of a point) and ``restart_past_corner(lam_c, lam_end, tol)``.
    ``point_keys``
        The per-point fields besides the common ones (:data:`mshbm.backbone.Backbone.to_dict`).
    ``conservative``
        No dissipation (``C = 0``, elastic impacts, no acting friction).

    and decides :meth:`certify` (a converged point's certificate), :meth:`stability_note` and
    :meth:`failure_hint`, so that the driver never asks which method it runs.
    """

    integrator = None
    event_flow = False
    point_keys = ()
    conservative = False

    @staticmethod
    def default_steps(harmonics):
        """Samples (or steps) per period when the caller gives none."""
        raise NotImplementedError

    def certify(self, pt, tol):
        """Whether the converged point ``pt`` (its fields) is certified at corrector tolerance ``tol``; may add
        fields (e.g. ``stable``).  Base rule: ``residual`` and ``amplitude_residual`` within ``10 tol``."""
        return pt["residual"] <= 10 * tol and pt["amplitude_residual"] <= 10 * tol

    def stability_note(self):
        """What ``stable`` of the points means."""
        return "not defined for the EPMC's artificial autonomous motion"

    def failure_hint(self, points_found, steps_given):
        """A hint appended to the message of a backbone that did not succeed (``""``: none)."""
        return ""

    def d_lam(self, y, lam):
        """``dR / dlam``: ``-a`` on the amplitude row ``n_x``, shape ``(n_unknowns,)``."""
        g = np.zeros(self.n_unknowns)
        g[self.n_x] = -self.a_ref * np.exp(lam)
        return g


def xi_guess(system, phi, omega0, xi0, a):
    """``xi`` (1/s) of the linear mode ``phi`` (``xi0``) plus the describing function of the friction elements
    on it: a bound ``mu F_N`` slipping with amplitude ``s = |w^T phi| a`` dissipates as a dashpot
    ``4 mu F_N / (pi omega_0 s)``."""
    xi = xi0
    for el in system.elements:
        if el.acts and el.bounded:
            wphi = abs(float(phi[el.dof] - (phi[el.relative_to] if el.relative_to is not None else 0.0)))
            if wphi > 0:
                xi += 4 * float(el.force_scale(0.0)) * wphi / (np.pi * omega0 * a)
    return xi
