"""The harmonic truncation estimates of a certificate: ``truncation_solution`` and ``truncation_force``.

Reported for the problems that declare ``harmonic_truncation`` (HBM, DLFT, MS-HBM), not gating: ``n_h``
is the user's choice of discretisation and the answer is the exact solution of the discretised equations;
a value above :data:`TRUNCATION_BOUND` is named in the message as a warning.

``truncation_solution``
    The size of the highest retained harmonic ``n_h`` of ``q_hat`` relative to the largest harmonic.
``truncation_force``
    The displacement (relative to ``D``, RMS over harmonics) that the harmonics of the element forces
    ``lambda(t)`` above ``n_h`` would cause at the element DOF through its diagonal dynamic stiffness
    ``|K_dd - (k omega)^2 M_dd + i k omega C_dd|``.
"""
from __future__ import annotations

import numpy as np

from ..scaling import diagonals
from .kernels import force_tail
from .laws import el_dofs_each
from .record import Check

__all__ = ["TRUNCATION_BOUND", "truncation_checks"]

TRUNCATION_BOUND = 1e-2


def truncation_checks(sol, system, omega, mags, lam, N, D, cert):
    """Append the truncation estimates (module docstring) to ``cert``: ``mags`` the harmonic magnitudes of
    ``q_hat``, shape ``(n_h, n)``; ``lam`` the element forces (N+1, m); ``D`` the displacement scale (m)."""
    els = list(system.elements)
    n_h = int(sol.harmonics)
    top = float(mags.max(initial=0.0))
    eq = float(mags[-1].max()) / top if top > 0 and mags.shape[0] else 0.0
    cert.checks.append(Check("truncation_solution", eq, TRUNCATION_BOUND, bool(eq <= TRUNCATION_BOUND), False,
                             f"|q_hat| at harmonic {n_h} / largest harmonic"))
    if els:
        # displacement that the element-force harmonics above n_h would cause at the element DOF,
        # through the diagonal dynamic stiffness |K_dd - (k omega)^2 M_dd + i k omega C_dd|
        Z = np.fft.rfft(lam[:-1], axis=0) * (2.0 / N)  # (N/2+1, m): complex amplitudes
        Kd, Md, Cd = diagonals(system)
        tail = np.empty(len(els))
        force_tail(Z, Kd, Md, Cd, el_dofs_each(system), omega, n_h, tail)
        ef = 0.0
        for v in tail.tolist():
            ef = max(ef, v / D)
        cert.checks.append(Check("truncation_force", ef, TRUNCATION_BOUND, bool(ef <= TRUNCATION_BOUND), False,
                                 f"displacement of the element-force harmonics above {n_h} "
                                 "(diagonal dynamic stiffness) / D"))
