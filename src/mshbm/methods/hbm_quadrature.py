"""Quadrature of HBM's penalty contact law (the option ``penalty_quadrature``).

``"samples"`` (default): eq. (45) at the ``N_s`` samples (piecewise linear, :mod:`mshbm.methods.hbm_path`).  Its Jacobian
jumps by ``k_c h`` (``h = T / N_s``) whenever a sample enters or leaves the contact, which on a stiff,
short contact is as large as the structure's dynamic stiffness: along a frequency sweep the branch of
the sampled equations is a chain of kinks whose tangents can turn by up to 90 degrees on a contact
closed for a small part of the period, and some kinks are genuine turning points of the sampled
equations.

``"linear"``: the contact force is integrated *exactly* on the piecewise-linear interpolant of the
gap between samples (:func:`hat_integrals`), against the hat functions of the samples, and the result
is mapped back to samples by the consistent (circulant 1-4-1) mass matrix of the hats, which the DFT
diagonalises (``E M^-1 = D^-1 E`` with ``D_k = (2 + cos(2 pi k / N_s)) / 3``).  While every sample of
a contact is closed it is exactly the sampled law; where the gap changes sign inside an interval the
force and its Jacobian are continuous in ``q_hat`` (the residual is C^1), so the branch is smooth and
the continuation's tangents are meaningful.  Ground and relative contacts with ``d_c = 0``.  The exact
piecewise-linear fallback (:mod:`mshbm.methods.hbm_path`) then traces the sampled equations and Newton polishes on these.
"""
from __future__ import annotations

import numpy as np

__all__ = ["PENALTY_QUADRATURES", "hat_integrals", "hat_mass_dft", "linear_quadrature_unsupported"]

#: values of the option ``penalty_quadrature`` (module docstring)
PENALTY_QUADRATURES = ("samples", "linear")


def hat_integrals(a, b):
    """Hat-weighted integrals of the penetration on one sample interval, and their derivatives.

    The gap is linear on the interval, ``g(tau) = a + (b - a) tau`` (``tau`` in ``[0, 1]``, ``a, b`` the
    gaps at its left and right sample, m).  Returns ``(I_L, I_R, dI_L/da, dI_L/db, dI_R/da, dI_R/db)``
    (arrays shaped like ``a``) with ``I_L = int_0^1 max(0, -g) (1 - tau) dtau`` and
    ``I_R = int_0^1 max(0, -g) tau dtau`` (m).  Closed forms: both samples closed,
    ``I_L = -(2a + b)/6``, ``I_R = -(a + 2b)/6``; ``a < 0 < b`` (``d = b - a``),
    ``I_R = -a^3 / (6 d^2)``, ``I_L = a^2 / (2 d) + a^3 / (6 d^2)``; ``a > 0 > b`` by symmetry; both
    open, 0.  The integrals are continuously differentiable in ``(a, b)`` (except at ``a = b = 0``).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    IL, IR = np.zeros_like(a), np.zeros_like(a)
    La, Lb, Ra, Rb = (np.zeros_like(a) for _ in range(4))
    m = (a <= 0.0) & (b <= 0.0)
    IL[m], IR[m] = -(2.0 * a[m] + b[m]) / 6.0, -(a[m] + 2.0 * b[m]) / 6.0
    La[m], Lb[m], Ra[m], Rb[m] = -1.0 / 3.0, -1.0 / 6.0, -1.0 / 6.0, -1.0 / 3.0
    m = (a < 0.0) & (b > 0.0)  # closed at the left end
    if m.any():
        IL[m], IR[m], La[m], Lb[m], Ra[m], Rb[m] = _one_end_closed(a[m], b[m])
    m = (a > 0.0) & (b < 0.0)  # closed at the right end: the mirror image (a <-> b, L <-> R)
    if m.any():
        IR[m], IL[m], Rb[m], Ra[m], Lb[m], La[m] = _one_end_closed(b[m], a[m])
    return IL, IR, La, Lb, Ra, Rb


def linear_quadrature_unsupported(elements):
    """Why ``penalty_quadrature="linear"`` cannot take these elements (one sentence), or ``None``: it needs
    contacts without penalty damping and no friction loaded by a contact."""
    for el in elements:
        if el.unilateral and el.penalty_damping != 0.0:
            return f"'linear' needs contacts without penalty damping (d_c = 0), got d_c = {el.penalty_damping:g}"
        if el.normal_contact is not None:
            return "'linear' does not support friction loaded by a contact (normal_contact)"
        if el.cone_partner is not None:
            return "'linear' does not support the 3-D frictional contact (cone_partner)"
    return None


def hat_mass_dft(k, Ns):
    """``D_k = (2 + cos(2 pi k / N_s)) / 3``: the DFT at frequency index ``k`` (array) of the consistent mass
    matrix of the ``N_s`` periodic hat functions (circulant 1-4-1 / 6, in units of the sample spacing)."""
    return (2.0 + np.cos(2.0 * np.pi * k / Ns)) / 3.0


def _one_end_closed(c, o):
    """:func:`hat_integrals` on intervals closed at one end only (gap ``c < 0`` there, ``o > 0`` at the other):
    ``(I_c, I_o, dI_c/dc, dI_c/do, dI_o/dc, dI_o/do)``, ``I_c`` against the hat of the closed end."""
    d = o - c
    r, r2, r3 = c / d, (c / d) ** 2, (c / d) ** 3
    return (c * r / 2.0 + c * r2 / 6.0, -c * r2 / 6.0,
            r + r2 + r3 / 3.0, -r2 / 2.0 - r3 / 3.0, -r2 / 2.0 - r3 / 3.0, r3 / 3.0)
