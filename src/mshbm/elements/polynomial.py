"""The smooth polynomial spring :class:`Polynomial` (cubic springs, the Duffing oscillator).

On a DOF (``w = +e_dof``) or between two DOFs (``relative_to=J``, ``w = e_dof - e_J``) with the local
displacement ``s = w^T q`` (m) the element acts on the structure with ``w lambda``::

    lambda(s) = -sum_p k_p s^p,        k_p in N/m^p,  p = 1, 2, 3, ...

(``{3: k3}``: the cubic spring of the Duffing oscillator ``m x'' + c x' + k x + k3 x^3 = F cos(omega t)``).
It is conservative, with the potential ``V(s) = sum_p k_p s^(p+1) / (p+1)`` (J), so it does no work
over a period.  It is an exact law, not an approximation, in every method:

* **HBM-AFT**: :meth:`Polynomial.regularised_law` is the law itself with ``d lambda / d s`` (no
  regularisation: :meth:`scaled` leaves it unchanged and the certificate's ``regularisation`` estimate
  has nothing to estimate for it, 0);
* **DLFT**: the smooth force is evaluated by AFT beside the Lagrangian contact and friction terms
  (:mod:`mshbm.methods.dlft`);
* **Moreau-Jean** (shooting, both MS-HBM variants): the midpoint scheme of the paper evaluates the
  position-dependent force at ``q_M = q_A + h/2 u_A``, which is known before the step; its impulse
  ``P = h lambda(w^T q_M)`` enters the free velocity, so the step stays explicit in the spring (no Newton
  per step) and the nonsmooth impulses are solved with it as before.  The sensitivities carry
  ``dP = h (d lambda / d s) w^T (dq_A + h/2 du_A)`` (:mod:`mshbm.integrators.kernels`); the explicit
  evaluation is second-order accurate for ``theta = 1/2`` and stable while
  ``h^2 max |d lambda / d s| / m << 1`` (the same condition as for a stiff spring evaluated explicitly);
* **the exact event-driven flow** is built on the linear modes between events: it refuses the element
  (:class:`~mshbm.errors.InputError`, integrator ``"moreau"`` instead).

Case file: ``polynomial: [{dof: 0, coefficients: {3: 1.5}, relative_to: J}]`` (powers as keys), or the
shorthand ``cubic: [{dof: 0, stiffness: 1.5}]`` (``k_3``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..errors import InputError
from ..integrators.kernels import KIND_SMOOTH
from .base import Element, _dof, _finite_number

__all__ = ["Polynomial", "MAX_POWER"]

#: highest power ``p`` of a polynomial spring
MAX_POWER = 9


def _coefficients(value, key="polynomial.coefficients"):
    """``((p, k_p), ...)`` sorted by power from a mapping ``{p: k_p}`` or pairs; zero coefficients dropped."""
    if isinstance(value, dict):
        items = list(value.items())
    elif isinstance(value, (list, tuple)) and all(isinstance(v, (list, tuple)) and len(v) == 2 for v in value):
        items = [tuple(v) for v in value]
    else:
        raise InputError(key, f"must be a mapping {{power: coefficient}} (e.g. {{3: 1.5}} for k_3 s^3), "
                              f"got {value!r}")
    out = {}
    for p, k in items:
        if isinstance(p, str) and p.strip().lstrip("+").isdigit():
            p = int(p)
        if isinstance(p, float) and p.is_integer():
            p = int(p)
        if isinstance(p, bool) or not isinstance(p, (int, np.integer)) or not 1 <= int(p) <= MAX_POWER:
            raise InputError(key, f"powers must be integers 1..{MAX_POWER}, got {p!r}")
        p = int(p)
        if p in out:
            raise InputError(key, f"power {p} given twice")
        out[p] = _finite_number(f"{key}.{p}", k)
    pairs = tuple((p, k) for p, k in sorted(out.items()) if k != 0.0)
    if not pairs:
        raise InputError(key, "needs at least one nonzero coefficient")
    return pairs


@dataclass(frozen=True)
class Polynomial(Element):
    """Polynomial spring ``lambda = -sum_p k_p s^p`` along ``w`` (module docstring).

    Parameters
    ----------
    dof : int
        0-based DOF index.
    coefficients : mapping ``{p: k_p}`` or pairs ``((p, k_p), ...)``
        Integer powers ``1 <= p <= 9`` and their coefficients (N/m^p); stored as sorted pairs.
    relative_to : int or None
        Second DOF ``J``: the spring acts on ``s = q_dof - q_J``; ``None`` (default): to the ground.
    """

    dof: int
    coefficients: tuple = ()
    relative_to: int | None = None
    kind: str = field(default="polynomial", init=False)

    kernel_code: ClassVar[int] = KIND_SMOOTH
    #: a smooth, position-dependent, conservative force (no set-valued law, no regularisation)
    smooth: ClassVar[bool] = True

    def __post_init__(self):
        object.__setattr__(self, "dof", _dof("polynomial.dof", self.dof))
        if self.dof < 0:
            raise InputError("polynomial.dof", f"DOF {self.dof} out of range (negative)")
        object.__setattr__(self, "coefficients", _coefficients(self.coefficients))
        self._check_relative()

    @classmethod
    def cubic(cls, dof, stiffness, relative_to=None):
        """The cubic spring ``lambda = -k_3 s^3`` (``stiffness = k_3``, N/m^3)."""
        return cls(dof, {3: _finite_number("cubic.stiffness", stiffness)}, relative_to)

    @property
    def sign(self):
        """Direction ``w = sign * e_dof`` (+1)."""
        return 1.0

    @property
    def powers(self):
        return tuple(p for p, _ in self.coefficients)

    def law(self, s):
        """``(lambda, d lambda / d s)`` at samples ``s`` (any shape, m): N and N/m."""
        s = np.asarray(s, dtype=float)
        lam = np.zeros_like(s)
        dlam = np.zeros_like(s)
        for p, k in self.coefficients:
            lam -= k * s ** p
            dlam -= (k * p) * s ** (p - 1) if p > 1 else k
        return lam, dlam

    def potential(self, s):
        """``V(s) = sum_p k_p s^(p+1) / (p+1)`` (J), ``lambda = -dV/ds``."""
        s = np.asarray(s, dtype=float)
        return sum(k * s ** (p + 1) / (p + 1) for p, k in self.coefficients)

    # ------------------------------------------------------------------ the laws
    def regularised_law(self, s, gamma):
        """The exact law (not regularised): ``(lambda, d lambda / d s, None)``."""
        lam, dlam = self.law(s)
        return lam, dlam, None

    def project(self, p, h):
        raise TypeError("Polynomial: a smooth force, evaluated explicitly at q_M (no set-valued law)")

    def kernel_parameters(self, h):
        """``(KIND_SMOOTH, 0, 0, 0)``: the kernel takes the coefficients from :meth:`kernel_polynomial`."""
        return KIND_SMOOTH, 0.0, 0.0, 0.0

    def kernel_polynomial(self, order):
        """``c`` of shape ``(order + 1,)``, ``lambda = sum_p c_p s^p`` (``c_p = -k_p``)."""
        c = np.zeros(order + 1)
        for p, k in self.coefficients:
            c[p] = -k
        return c

    # ------------------------------------------------------------------ scales
    def force_scale(self, stiffness, penalty=False):
        return 0.0

    def magnitude_terms(self):
        return [(f"{self.kind}.coefficients.{p}", f"k_{p}", abs(k)) for p, k in self.coefficients
                if math.isfinite(k)]
