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

__all__ = ["FD_OMEGA", "FD_XI", "fd_omega_xi", "ModalParameter", "xi_guess"]

#: relative central-difference steps of ``dR/domega`` and ``dR/dxi`` (the latter relative to omega)
FD_OMEGA, FD_XI = 1e-6, 1e-6


def fd_omega_xi(rows, omega, xi):
    """``[dR/domega, dR/dxi]``, shape ``(len(rows(omega, xi)), 2)``, by central differences of ``rows(omega,
    xi)`` (the residual rows at fixed ``x``, without the amplitude ``a``: it does not depend on omega or xi)."""
    cols = []
    for om, xx, d in ((omega * (1 + FD_OMEGA), xi, omega * FD_OMEGA), (omega, xi + FD_XI * omega, FD_XI * omega)):
        cols.append((np.asarray(rows(om, xx)) - np.asarray(rows(2 * omega - om, 2 * xi - xx))) / (2 * d))
    return np.stack(cols, axis=1)


class ModalParameter:
    """``d_lam`` of a mode residual (``n_x``, ``n_unknowns``, ``a_ref`` set by the class)."""

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
