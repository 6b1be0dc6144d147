"""Friction elements: :class:`Friction` (Coulomb) and :class:`Jenkins` (a spring in series with a slider).

:class:`Friction` -- Coulomb dry friction, slip velocity ``gamma_T = w^T u``, set-valued law
``-lambda_T in mu F_N Sign(gamma_T)`` (eq. 41), regularised for HBM as
``lambda_T = -mu F_N 2/pi arctan(kappa gamma_T)`` (eq. 42).

:class:`Jenkins` friction (tangential stiffness ``k_t`` in series with the slider; all methods but the
exact flow): a law with an internal state (the slider position ``z``), :attr:`Element.history`.  HBM
evaluates it along the period twice (:meth:`Jenkins.history_law`, derivative with respect to the Fourier
coefficients).  DLFT appends the same slider DOFs to the harmonic balance (:mod:`mshbm.methods.dlft_terms`).
Time stepping integrates one massless slider DOF per element
(:func:`mshbm.integrators.moreau_jean._with_sliders`: ``M_zz = 0``, ``K += k_t [w; -e_z][w; -e_z]^T``,
rigid Coulomb friction on ``z``), stepped with ``theta = 1`` so that its velocity is no state (with
``theta = 1/2`` the auxiliary velocity maps to ``-u_z`` every step and the shooting Jacobian grows without
bound); shooting and both MS-HBM variants carry ``(z, u_z)`` as unknowns and report the structure's DOFs
only.  In a motion that never slips ``z`` is free (a family of periodic solutions differing in the mean):
HBM's march picks ``lambda = 0`` at its last sample, time stepping the start ``z = w^T q(0)`` of Newton's
first iterate.

Friction whose *normal load* comes from a contact on the same point (``Friction(..., normal_contact=c)``;
shooting, both MS-HBM variants, HBM, DLFT with the velocity predictor): the normal force is
``F_N(t) = N_0 + lambda_N(t)`` with the preload ``N_0 = normal_force`` and the force ``lambda_N >= 0`` of
the contact element ``c`` (an index into the system's element list), so the bound ``mu F_N(t)`` varies with
the normal motion -- the 2-D frictional contact of a blade damper.  Time stepping: on the impulse level
``|P_T| <= mu (h N_0 + P_N)`` (Coulomb's cone); in the kernel's projected Gauss-Seidel the friction and its
contact form one block solved exactly (closed-stick, closed-slip in either direction, open; a contact
loading several frictions: scalar updates with the bound from the current contact impulse); the
sensitivities are exact for the active set, a sliding friction on a closed contact adding
``dP_T = sign(P_T) mu dP_N`` to the equality rows (:mod:`mshbm.integrators.kernels`).  HBM:
``lambda_T = mu (N_0 + max(lambda_N, 0)) (2/pi) arctan(kappa gamma_T)`` with the penalty force
``lambda_N`` (eq. 45), with the Jacobian terms in the normal DOFs (the coupling terms of
:func:`mshbm.elements.regularised_forces`).  DLFT (velocity predictor): the per-sample bound
``mu (N_0 + lambda_N)`` with the contact's DLFT force, and in slip on a closed sample
``d lambda_T = sign(lambda_T) mu d lambda_N``.  The certificate checks the cone
``|lambda_T| <= mu (N_0 + lambda_N)`` per sample (:meth:`Element.bound_samples`).  Not supported (clean
:class:`~mshbm.errors.InputError`): the exact/event-driven flow (more than one element;
:attr:`Element.normal_contact` is the flag to test), DLFT with the displacement predictor, and HBM with Jenkins
friction (``tangential_stiffness``) with a normal contact (time stepping and DLFT load the slider's bound).  A Moreau-Jean caveat (``e_N = 0``): the
velocity-level contact law keeps a closed contact closed anywhere within ``O(h^2 F / m)`` of the stop, and
the normal load then differs by the normal stiffness times that offset.

Two frictions on the two tangential directions of one contact point that name each other as
``cone_partner`` form a 3-D frictional contact with the circular cone ``||lambda_T|| <= mu F_N``
(:mod:`mshbm.elements.cone`; with ``tangential_stiffness`` a 3-D Jenkins element).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np

from ..errors import InputError
from ..integrators.kernels import KIND_FRICTION
from .base import Element, _dof, _finite_number

__all__ = ["Friction", "Jenkins"]


@dataclass(frozen=True)
class Friction(Element):
    """Coulomb friction on one DOF.

    Parameters
    ----------
    dof : int
        0-based DOF index.
    mu : float
        Friction coefficient, ``>= 0``.
    normal_force : float
        Normal force ``F_N`` (N), ``>= 0``.  The friction bound is ``mu*F_N``.  With
        ``normal_contact``: the preload ``N_0`` added to the contact force.
    smoothing : float or None
        Regularisation ``kappa`` (s/m) of eq. (42), used by HBM only.  ``None`` (default): HBM derives it
        from the problem's velocity scale, ``kappa = SMOOTHING_FACTOR / V`` with ``V`` the peak slip velocity
        of the linear response at the element (:mod:`mshbm.methods.hbm_regularisation`), the same physics in
        every unit system; a number is used as given.
    relative_to : int or None
        Second DOF ``J``: the element then acts on ``q_dof - q_J`` (slip velocity ``u_dof - u_J``,
        ``w = e_dof - e_J``); ``None`` (default): between ``dof`` and the ground.
    normal_contact : int or None
        Index (into the system's element list) of a :class:`Contact` whose force ``lambda_N >= 0`` loads
        this friction: the bound is then ``mu (N_0 + lambda_N(t))``, ``N_0 = normal_force`` (see the
        module docstring).  The contact must act on other DOFs (the normal direction).  ``None``
        (default): the constant normal force ``normal_force``.
    cone_partner : int or None
        Index (into the system's element list) of the friction on the second tangential direction of the
        same contact point: the two form one 3-D frictional contact with the circular cone
        ``||(lambda_T1, lambda_T2)|| <= mu F_N`` (the slip direction rotates; :mod:`mshbm.elements.cone`).
        Both must name each other and have the same ``mu``, ``normal_force``, ``normal_contact`` and
        ``smoothing``.  ``None`` (default): 1-D friction.
    """

    dof: int
    mu: float
    normal_force: float
    smoothing: float | None = None
    relative_to: int | None = None
    normal_contact: int | None = None
    cone_partner: int | None = None
    kind: str = field(default="friction", init=False)

    kernel_code: ClassVar[int] = KIND_FRICTION
    bounded: ClassVar[bool] = True

    def __post_init__(self):
        object.__setattr__(self, "dof", _dof("friction.dof", self.dof))
        object.__setattr__(self, "mu", _finite_number("friction.mu", self.mu, nonnegative=True))
        object.__setattr__(self, "normal_force",
                           _finite_number("friction.normal_force", self.normal_force, nonnegative=True))
        if self.smoothing is not None:
            object.__setattr__(self, "smoothing",
                               _finite_number("friction.smoothing", self.smoothing, positive=True))
        self._check_relative()
        if self.normal_contact is not None:
            c = self.normal_contact
            if isinstance(c, bool) or not isinstance(c, (int, np.integer)) or c < 0:
                raise InputError("friction.normal_contact", f"must be the index (>= 0) of a contact element, "
                                 f"got {c!r}")
            object.__setattr__(self, "normal_contact", int(c))
        if self.cone_partner is not None:
            c = self.cone_partner
            if isinstance(c, bool) or not isinstance(c, (int, np.integer)) or c < 0:
                raise InputError("friction.cone_partner", f"must be the index (>= 0) of the friction element on "
                                 f"the second tangential direction, got {c!r}")
            object.__setattr__(self, "cone_partner", int(c))

    @property
    def sign(self):
        """Direction ``w = sign * e_dof``."""
        return 1.0

    @property
    def bound(self):
        """Maximal friction force ``mu * F_N`` (with ``normal_contact``: its constant part ``mu N_0``)."""
        return self.mu * self.normal_force

    @property
    def acts(self):
        if self.normal_contact is not None:
            return self.mu > 0.0
        return self.bound > 0.0

    def kernel_coupling(self):
        """``(c, mu)`` with a normal contact ``c``, else ``(-1, 0)``."""
        return (-1, 0.0) if self.normal_contact is None else (self.normal_contact, self.mu)

    def bound_samples(self, lam):
        """``mu (N_0 + max(lambda_N, 0))`` per sample (``lam``: forces of all elements, shape (N, m))."""
        if self.normal_contact is None:
            return np.full(np.shape(lam)[0], float(self.bound))
        lN = np.maximum(np.asarray(lam)[:, self.normal_contact], 0.0)
        return self.mu * (self.normal_force + lN)

    def coupled_law(self, gamma, lam_n, dn_ds, dn_dgamma):
        """Regularised law of a friction with a normal contact (HBM)::

            lambda_T = -mu (N_0 + max(lambda_N, 0)) (2/pi) arctan(kappa gamma_T)

        Parameters: slip velocity samples ``gamma``; the contact's force ``lam_n`` and its derivatives
        ``dn_ds``, ``dn_dgamma`` (arrays or ``None``) with respect to its own ``s_N``, ``gamma_N``.
        Returns ``(lam, dlam_dgamma_T, dlam_ds_N, dlam_dgamma_N)`` (``None`` for a vanishing term).
        """
        self._resolved()
        pos = lam_n > 0.0
        FN = self.normal_force + np.where(pos, lam_n, 0.0)
        ku = self.smoothing * gamma
        phi = -(2.0 / np.pi) * np.arctan(ku)
        dphi = -(2.0 / np.pi) * self.smoothing / (1.0 + ku * ku)
        dsN = None if dn_ds is None else self.mu * phi * np.where(pos, dn_ds, 0.0)
        dgN = None if dn_dgamma is None else self.mu * phi * np.where(pos, dn_dgamma, 0.0)
        return self.mu * FN * phi, self.mu * FN * dphi, dsN, dgN

    def kernel_partner(self):
        """Index of the cone partner (the second tangential direction of a 3-D contact), ``-1``: none."""
        return -1 if self.cone_partner is None else self.cone_partner

    def project(self, p, h):
        """``-lambda_T in mu F_N Sign(gamma_T)``: the impulse lies in ``[-h mu F_N, h mu F_N]``."""
        b = h * self.bound
        return np.clip(p, -b, b)

    def kernel_parameters(self, h):
        return KIND_FRICTION, h * self.bound, 0.0, 0.0

    def regularised_law(self, s, gamma):
        """Eq. (42): ``lambda_T = -mu F_N (2/pi) arctan(kappa gamma_T)`` (constant ``F_N``; with a normal
        contact: :meth:`coupled_law`)."""
        if self.normal_contact is not None or self.cone_partner is not None:
            raise TypeError("friction with a normal contact or a cone partner: its law depends on the contact force "
                            "or the partner's slip (coupled_law, mshbm.elements.cone.cone_law)")
        self._resolved()
        a = self.bound * 2.0 / np.pi
        ku = self.smoothing * gamma
        return -a * np.arctan(ku), None, -a * self.smoothing / (1.0 + ku * ku)

    def _resolved(self):
        if self.smoothing is None:
            raise TypeError("friction.smoothing is None (the default): HBM fills it in from the problem's scales "
                            "(mshbm.methods.hbm_regularisation.resolve) before the law is evaluated")

    def scaled(self, factor):
        """``kappa`` times ``factor`` (``None``, the default left to HBM: unchanged)."""
        if self.smoothing is None:
            return self
        return replace(self, smoothing=self.smoothing * factor)

    def bound_scaled(self, s):
        """``F_N`` times ``s`` (with ``normal_contact``: ``mu`` times ``s``, which scales the whole bound)."""
        if self.normal_contact is not None:
            return replace(self, mu=self.mu * s)
        return replace(self, normal_force=self.normal_force * s)

    def force_scale(self, stiffness, penalty=False):
        return float(self.bound)

    def magnitude_terms(self):
        return [(f"{self.kind}.normal_force", "mu F_N", self.mu * self.normal_force)]


@dataclass(frozen=True)
class Jenkins(Friction):
    """Elastic Coulomb friction (Jenkins element): a spring ``k_t`` in series with a Coulomb slider.

    With the slider position ``z`` (internal state), the force on the structure is ``w lambda`` with::

        lambda = -k_t (s - z),   |lambda| <= mu F_N,   z moves only while |lambda| = mu F_N

    (``s = w^T q``).  While the slider sticks the element is a linear spring ``k_t`` (the structure
    behaves like ``K + k_t w w^T``); as ``k_t -> inf`` it tends to rigid Coulomb friction.  Under
    ``s = a cos(omega t)`` with ``a > mu F_N / k_t`` the hysteresis loop encloses the energy
    ``4 mu F_N (a - mu F_N / k_t)`` per cycle (Masing/Iwan).

    Methods: HBM evaluates the law along the period's samples, marching the period twice from
    ``lambda = 0`` at the last sample (:meth:`history_law`, the usual AFT treatment of hysteresis,
    with its exact Jacobian); the law is not regularised.  Time stepping (shooting, MS-HBM) integrates
    ``z`` as a massless slider DOF (see the module docstring); the exact flow does not support it (a
    clean :class:`~mshbm.errors.InputError`).  In the case file: a ``friction`` entry with
    ``tangential_stiffness``.
    """

    tangential_stiffness: float = 1.0

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "tangential_stiffness",
                           _finite_number("friction.tangential_stiffness", self.tangential_stiffness, positive=True))

    history: ClassVar[bool] = True

    def kernel_parameters(self, h):
        """Not a kernel element itself: :class:`mshbm.integrators.moreau_jean.MoreauJean` integrates it as
        a massless slider DOF carrying rigid friction (its :meth:`project` is Coulomb's on that DOF)."""
        raise TypeError("Jenkins: MoreauJean integrates it as a slider DOF with Coulomb friction")

    def regularised_law(self, s, gamma):
        raise TypeError("Jenkins has a history-dependent law: use history_law")

    def scaled(self, factor):
        """Not regularised: unchanged."""
        return self

    def history_law(self, s, basis=None):
        """``lambda`` at the periodic samples ``s`` (shape (N_s,)) and its derivative ``D``.

        Return mapping over two periods: ``lambda_k = clip(lambda_{k-1} - k_t (s_k - s_{k-1}), +-mu F_N)``
        from ``lambda = 0`` at the last sample (``s_{-1} = s_{N_s-1}``); the second period is returned.
        ``D`` follows the same recursion (zero rows while the slider slides): ``d lambda / d s``, shape
        (N_s, N_s), or with ``basis`` (shape (N_s, n_b), ``s = basis @ c``) ``d lambda / d c``, shape
        (N_s, n_b) -- for HBM the Fourier coefficients, ``O(N_s n_b)`` memory instead of ``O(N_s^2)``.

        A stuck orbit (the loop's range ``max lambda - min lambda`` below ``2 mu F_N``: a slider that moves in
        a periodic state moves both ways, so it reaches both bounds) has no unique slider position: every
        offset that keeps ``|lambda| <= mu F_N`` is periodic, and the march's own choice follows the phase
        of ``s`` at the last sample, so it jumps with omega (a kink in the harmonic-0 force, which sweeps took
        for folds).  The rule: the loop is centred, ``lambda <- lambda - (max + min) / 2``, the middle of the
        admissible offsets, which the slipping loop of a symmetric response continues at slip onset.
        """
        s = np.asarray(s, dtype=float)
        Ns = s.size
        V = np.eye(Ns) if basis is None else np.asarray(basis, dtype=float)
        kt, b = self.tangential_stiffness, self.bound
        lam = np.zeros(Ns)
        D = np.zeros((Ns, V.shape[1]))
        zero = np.zeros(V.shape[1])
        prev_l, prev_D, prev_k = 0.0, zero, Ns - 1
        for _ in range(2):
            for k in range(Ns):
                l = prev_l - kt * (s[k] - s[prev_k])
                row = prev_D - kt * (V[k] - V[prev_k])
                if l >= b:
                    l, row = b, zero
                elif l <= -b:
                    l, row = -b, zero
                lam[k], D[k] = l, row
                prev_l, prev_D, prev_k = l, row, k
        i, j = int(np.argmax(lam)), int(np.argmin(lam))
        if lam[i] - lam[j] < 2 * b * (1 - 1e-9):  # stuck: centre the loop (docstring)
            lam, D = lam - 0.5 * (lam[i] + lam[j]), D - 0.5 * (D[i] + D[j])
        return lam, D

    def magnitude_terms(self):
        return super().magnitude_terms() + [(f"{self.kind}.tangential_stiffness", "k_t", self.tangential_stiffness)]
