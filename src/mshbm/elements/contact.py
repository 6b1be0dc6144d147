"""The unilateral contact element :class:`Contact`: gap ``g_N = g0 + w^T q = g0 - q_dof >= 0``, relative
velocity ``gamma_N = -u_dof`` and Newton's impact law with restitution ``e_N`` (eqs. 43-44); penalty law
for HBM (eq. 45) ``lambda_N = -(k_c g_N + d_c gamma_N)`` while ``g_N <= 0``."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np

from ..errors import InputError
from ..integrators.kernels import KIND_CONTACT
from .base import Element, _dof, _finite_number

__all__ = ["Contact"]


@dataclass(frozen=True)
class Contact(Element):
    """Unilateral contact ``g_N = gap - q_dof >= 0`` with Newton impact law.

    Parameters
    ----------
    dof : int
        0-based DOF index.
    gap : float
        Initial gap ``g_N,0 >= 0`` (m).
    restitution : float
        Newton restitution coefficient ``e_N`` in ``[0, 1]``.
    penalty_stiffness, penalty_damping : float
        ``k_c > 0`` (N/m) and ``d_c >= 0`` (Ns/m) of the penalty law eq. (45),
        used by HBM only.  ``penalty_stiffness=None`` (default): HBM derives it from the structure's
        stiffness along the element, ``k_c = PENALTY_FACTOR k_w`` (:mod:`mshbm.methods.hbm_regularisation`),
        the same physics in every unit system; a number is used as given.
    relative_to : int or None
        Second DOF ``J``: the gap is then ``g_N = gap - (q_dof - q_J)`` (``w = -(e_dof - e_J)``);
        ``None`` (default): a stop fixed to the ground.
    """

    dof: int
    gap: float
    restitution: float = 1.0
    penalty_stiffness: float | None = None
    penalty_damping: float = 0.0
    relative_to: int | None = None
    kind: str = field(default="contact", init=False)

    kernel_code: ClassVar[int] = KIND_CONTACT
    unilateral: ClassVar[bool] = True
    piecewise_linear: ClassVar[bool] = True

    def __post_init__(self):
        object.__setattr__(self, "dof", _dof("contact.dof", self.dof))
        object.__setattr__(self, "gap", _finite_number("contact.gap", self.gap, nonnegative=True))
        e = _finite_number("contact.restitution", self.restitution)
        if not 0.0 <= e <= 1.0:
            raise InputError("contact.restitution", f"must lie in [0, 1], got {e:g}")
        object.__setattr__(self, "restitution", e)
        if self.penalty_stiffness is not None:
            object.__setattr__(self, "penalty_stiffness",
                               _finite_number("contact.penalty_stiffness", self.penalty_stiffness, positive=True))
        object.__setattr__(self, "penalty_damping",
                           _finite_number("contact.penalty_damping", self.penalty_damping, nonnegative=True))
        self._check_relative()

    @property
    def sign(self):
        """Direction ``w = sign * e_dof`` (``g_N = gap + sign*q_dof``)."""
        return -1.0

    def project(self, p, h):
        """``0 <= g_N _|_ lambda_N >= 0`` on the impulse level: ``P_N >= 0``."""
        return np.maximum(p, 0.0)

    def kernel_parameters(self, h):
        return KIND_CONTACT, 0.0, self.gap, self.restitution

    def regularised_law(self, s, gamma):
        """Eq. (45): ``lambda_N = -(k_c g_N + d_c gamma_N)`` while ``g_N = gap + s <= 0``, else 0.

        At ``g_N = 0`` the sample counts as closed (one-sided derivatives).
        """
        if self.penalty_stiffness is None:
            raise TypeError("contact.penalty_stiffness is None (the default): HBM fills it in from the structure's "
                            "stiffness (mshbm.methods.hbm_regularisation.resolve) before the law is evaluated")
        g = self.gap + s
        closed = g <= 0.0
        lam = np.where(closed, -(self.penalty_stiffness * g + self.penalty_damping * gamma), 0.0)
        return (lam, np.where(closed, -self.penalty_stiffness, 0.0),
                np.where(closed, -self.penalty_damping, 0.0))

    def scaled(self, factor):
        """``k_c`` and ``d_c`` times ``factor`` (``k_c = None``, the default left to HBM: ``d_c`` only)."""
        if self.penalty_stiffness is None:
            return replace(self, penalty_damping=self.penalty_damping * factor)
        return replace(self, penalty_stiffness=self.penalty_stiffness * factor,
                       penalty_damping=self.penalty_damping * factor)

    def force_scale(self, stiffness, penalty=False):
        """``K_dd gap`` (and ``k_c gap`` with ``penalty``)."""
        F = float(stiffness[self.dof]) * self.gap
        if penalty and self.penalty_stiffness is not None:
            F = max(F, self.penalty_stiffness * self.gap)
        return F

    def magnitude_terms(self):
        if self.penalty_stiffness is None:
            return []
        return [(f"{self.kind}.penalty_stiffness", "k_c gap", self.penalty_stiffness * max(self.gap, 1.0))]
