"""Local nonsmooth elements: each element owns its laws.

Notation (Schreyer & Leine 2016, Sec. 4): an element acts on the structure along its direction
``w`` (``+e_dof`` for friction, ``-e_dof`` for contact; ``w = sign * e_dof``) with the force
``w lambda``.  Its local kinematics are the relative displacement and velocity along ``w``::

    s = w^T q,        gamma = w^T u

* :class:`Friction` -- Coulomb dry friction, slip velocity ``gamma_T = u_dof``, set-valued law
  ``-lambda_T in mu F_N Sign(gamma_T)`` (eq. 41), regularised for HBM as
  ``lambda_T = -mu F_N 2/pi arctan(kappa gamma_T)`` (eq. 42).
* :class:`Contact` -- unilateral contact with gap ``g_N = g0 + s = g0 - q_dof >= 0``, relative
  velocity ``gamma_N = -u_dof`` and Newton's impact law with restitution ``e_N`` (eqs. 43-44);
  penalty law for HBM (eq. 45) ``lambda_N = -(k_c g_N + d_c gamma_N)`` while ``g_N <= 0``.

What every element owns (the contract of :class:`Element`; the methods and the integrators
ask the element, they do not test its type):

=========================  ==================================================================
set-valued law             :meth:`Element.project` (prox of an impulse over a step);
                           :meth:`Element.kernel_parameters` (the numbers the compiled
                           Moreau-Jean kernel takes, :mod:`mshbm.integrators.kernels`)
regularised law (HBM)      :meth:`Element.regularised_law`: ``lambda`` and its derivatives;
                           :func:`regularised_forces` assembles them on the AFT samples
homotopy                   :meth:`Element.scaled` (regularisation ``factor`` times stiffer, the
                           set-valued limits kept); :meth:`Element.bound_scaled` (the force
                           bound times ``s``, continuation in the friction bound)
scaling                    :meth:`Element.force_scale`, :meth:`Element.magnitude_terms`
event-driven flow, checks  :attr:`Element.unilateral` (gap ``g_N >= 0``, impacts: ``gap``,
                           ``restitution``), :attr:`Element.bounded` (``|lambda| <= bound``),
                           :attr:`Element.acts`, :attr:`Element.piecewise_linear`
subsystems                 :meth:`Element.renumbered` (the element on renumbered DOFs)
=========================  ==================================================================

Elements of issue 15:

* friction and contact *relative* to a second DOF (``relative_to=J``, all methods): ``dofs = (I, J)``,
  ``w = sign (e_I - e_J)`` (:attr:`Element.direction`, :meth:`Element.local`); the laws are the same
  functions of ``(s, gamma)``.  :func:`regularised_forces` adds the off-diagonal Jacobian terms of
  ``w w^T``; the Moreau-Jean kernel takes the second DOF as ``dof2`` (``-1``: the ground); the exact
  event-driven flow and hence exact Floquet multipliers handle elements on one DOF only (any number;
  InputError; stability falls back to the step map with the reason).
* :class:`Jenkins` friction (tangential stiffness ``k_t`` in series with the slider; all methods but
  the exact flow): a law with an internal state (the slider position ``z``), :attr:`Element.history`.
  HBM evaluates it along the period twice (:meth:`Jenkins.history_law`, derivative with respect to
  the Fourier coefficients).  Time stepping integrates one massless slider DOF per element
  (:func:`mshbm.integrators.moreau_jean._with_sliders`: ``M_zz = 0``, ``K += k_t [w; -e_z][w; -e_z]^T``,
  rigid Coulomb friction on ``z``), stepped with ``theta = 1`` so that its velocity is no state (with
  ``theta = 1/2`` the auxiliary velocity maps to ``-u_z`` every step and a first attempt's shooting
  Jacobian grew to 3e129); shooting and both MS-HBM variants carry ``(z, u_z)`` as unknowns and
  report the structure's DOFs only.  In a motion that never slips ``z`` is free (a family of
  periodic solutions differing in the mean): HBM's march picks ``lambda = 0`` at its last sample, time
  stepping the start ``z = w^T q(0)`` of Newton's first iterate.
* friction whose *normal load* comes from a contact on the same point (``Friction(...,
  normal_contact=c)``; shooting, both MS-HBM variants, HBM, DLFT with the velocity predictor): the
  normal force is
  ``F_N(t) = N_0 + lambda_N(t)`` with the preload ``N_0 = normal_force`` and the force
  ``lambda_N >= 0`` of the contact element ``c`` (an index into the system's element list), so the
  bound ``mu F_N(t)`` varies with the normal motion -- the 2-D frictional contact of a blade damper.
  Time stepping: on the impulse level ``|P_T| <= mu (h N_0 + P_N)`` (Coulomb's cone); in the kernel's
  projected Gauss-Seidel the friction and its contact form one block solved exactly (closed-stick,
  closed-slip in either direction, open; a contact loading several frictions: scalar updates with the
  bound from the current contact impulse); the sensitivities are exact for the active set, a sliding friction
  on a closed contact adding ``dP_T = sign(P_T) mu dP_N`` to the equality rows
  (:mod:`mshbm.integrators.kernels`).  HBM: ``lambda_T = mu (N_0 + max(lambda_N, 0)) (2/pi)
  arctan(kappa gamma_T)`` with the penalty force ``lambda_N`` (eq. 45), with the Jacobian terms in
  the normal DOFs (the coupling terms of :func:`regularised_forces`).  DLFT (velocity predictor): the
  per-sample bound ``mu (N_0 + lambda_N)`` with the contact's DLFT force, and in slip on a closed
  sample ``d lambda_T = sign(lambda_T) mu d lambda_N``.  The certificate checks the cone
  ``|lambda_T| <= mu (N_0 + lambda_N)`` per sample (:meth:`Element.bound_samples`).  Not supported
  (clean :class:`~mshbm.errors.InputError`): the exact/event-driven flow (more than one element;
  :attr:`Element.normal_contact` is the flag to test), DLFT with the displacement predictor, and
  Jenkins friction (``tangential_stiffness``) with a normal contact.  A Moreau-Jean caveat (``e_N = 0``):
  the velocity-level contact law keeps a closed contact closed anywhere within ``O(h^2 F / m)`` of the
  stop, and the normal load then differs by the normal stiffness times that offset (measured
  ``7e-7`` m at 1024 steps per period on ``examples/damper2d.yaml`` without the inclined spring).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np

from .errors import InputError
from .integrators.kernels import KIND_CONTACT, KIND_FRICTION

__all__ = ["Element", "Friction", "Contact", "Jenkins", "regularised_forces", "ELEMENT_TYPES"]


def _finite_number(key, value, *, positive=False, nonnegative=False):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(key, f"must be a number, got {type(value).__name__} {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise InputError(key, f"must be finite, got {value}")
    if positive and value <= 0:
        raise InputError(key, f"must be > 0, got {value:g}")
    if nonnegative and value < 0:
        raise InputError(key, f"must be >= 0, got {value:g}")
    return value


def _dof(key, value):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise InputError(key, f"must be an integer DOF index, got {value!r}")
    return int(value)


class Element:
    """A local nonsmooth element acting on the structure along ``w = sign * e_dof``.

    Subclasses are frozen dataclasses with a field ``dof`` and the parameters of their laws.
    Every element owns:

    * its **set-valued law** (time stepping): :meth:`project` maps an impulse ``p`` over a step
      ``h`` onto the admissible set (friction: ``|p| <= h mu F_N``; contact: ``p >= 0``), and
      :meth:`kernel_parameters` gives the numbers that the compiled Moreau-Jean kernel uses for
      the same law (code, bound ``h mu F_N``, gap, restitution);
    * its **regularised law with Jacobian** (HBM): :meth:`regularised_law` gives ``lambda``,
      ``d lambda / d s`` and ``d lambda / d gamma`` at samples of the local displacement
      ``s = w^T q`` and velocity ``gamma = w^T u``;
    * the **regularisation scaling** used by homotopies: :meth:`scaled` (regularisation times
      ``factor``, set-valued limits unchanged) and :meth:`bound_scaled` (force bound times ``s``);
    * its contributions to the **scales** of a problem: :meth:`force_scale`, :meth:`magnitude_terms`;
    * what the **event-driven flow** and the checks need: :attr:`unilateral` (a gap
      ``g_N = gap + w^T q >= 0`` with impacts, attributes ``gap`` and ``restitution``),
      :attr:`bounded` (a force bound ``|lambda| <= bound``), :attr:`acts`;
    * :meth:`renumbered`: the same element on renumbered DOFs (subsystems).

    Attributes
    ----------
    kind : str
        Name of the element type (case-file key, messages).
    kernel_code : int
        Element code of the compiled kernel (:data:`mshbm.integrators.kernels.KIND_FRICTION`, ...).
    unilateral, bounded : bool
        Class flags, see above.
    piecewise_linear : bool
        The regularised law is piecewise linear in ``(q, u)`` (penalty contact): HBM may then follow
        its solution path exactly (:meth:`mshbm.methods.hbm.HBMProblem.newton_fallback`).
    """

    kind: ClassVar[str] = "element"
    kernel_code: ClassVar[int] = -1
    unilateral: ClassVar[bool] = False
    bounded: ClassVar[bool] = False
    piecewise_linear: ClassVar[bool] = False
    #: the law has an internal state (its force depends on the history of ``s``, not on ``(s, gamma)``):
    #: HBM evaluates :meth:`history_law` instead of :meth:`regularised_law`
    history: ClassVar[bool] = False

    # ------------------------------------------------------------------ geometry
    @property
    def sign(self):
        """Direction ``w = sign * e_dof``."""
        raise NotImplementedError

    #: second DOF of a relative element (``w = sign (e_dof - e_relative_to)``); ``None``: the ground
    relative_to = None

    @property
    def dofs(self):
        """DOFs the element acts on: ``(dof,)`` or ``(dof, relative_to)``."""
        return (self.dof,) if self.relative_to is None else (self.dof, self.relative_to)

    @property
    def relative(self):
        """True if the element acts between two DOFs (on ``q_dof - q_relative_to``)."""
        return self.relative_to is not None

    @property
    def direction(self):
        """``[(dof, w_dof)]``: the nonzero entries of ``w``."""
        if self.relative_to is None:
            return [(self.dof, self.sign)]
        return [(self.dof, self.sign), (self.relative_to, -self.sign)]

    def local(self, X, col=None):
        """``w^T x`` for samples ``X`` whose last axis is indexed by DOF (through ``col``, a mapping
        DOF -> column, if given): ``sign X[..., I]`` or ``sign (X[..., I] - X[..., J])``."""
        c = (lambda d: d) if col is None else (lambda d: col[int(d)])
        if self.relative_to is None:
            return self.sign * X[..., c(self.dof)]
        return self.sign * (X[..., c(self.dof)] - X[..., c(self.relative_to)])

    def renumbered(self, position):
        """The element with its DOFs renumbered by ``position`` (mapping old DOF -> new index)."""
        if self.relative_to is None:
            return replace(self, dof=position[int(self.dof)])
        return replace(self, dof=position[int(self.dof)], relative_to=position[int(self.relative_to)])

    def _check_relative(self):
        if self.relative_to is not None:
            J = _dof(f"{self.kind}.relative_to", self.relative_to)
            if J == self.dof:
                raise InputError(f"{self.kind}.relative_to", f"must differ from dof ({self.dof}): "
                                 "the element acts on q_dof - q_relative_to")
            if J < 0:
                raise InputError(f"{self.kind}.relative_to", f"DOF {J} out of range (negative)")
            object.__setattr__(self, "relative_to", J)

    @property
    def acts(self):
        """False if the element can never exert a force (friction with ``mu F_N = 0``)."""
        return True

    #: index (into the system's element list) of the contact element whose force is this element's
    #: normal load (friction with ``normal_contact``); ``None``: no such coupling
    normal_contact = None

    def kernel_coupling(self):
        """``(c, mu)``: the Moreau-Jean kernel's normal-load coupling (``-1, 0``: none)."""
        return -1, 0.0

    def bound_samples(self, lam):
        """Force bound per sample given the forces ``lam`` (shape (N, m)) of all the system's elements:
        the constant :attr:`bound` (broadcast), or ``mu (N_0 + max(lam[:, c], 0))`` with a normal contact.
        Only for :attr:`bounded` elements."""
        return np.full(np.shape(lam)[0], float(self.bound))

    # ------------------------------------------------------------------ set-valued law
    def project(self, p, h):
        """Impulse ``p`` over a step ``h`` projected onto the admissible set of the set-valued law."""
        raise NotImplementedError

    def kernel_parameters(self, h):
        """``(code, bound, gap, e)``: the element's numbers for the Moreau-Jean kernel with step ``h``."""
        raise NotImplementedError

    # ------------------------------------------------------------------ regularised law
    def regularised_law(self, s, gamma):
        """Regularised law at samples of ``s = w^T q`` and ``gamma = w^T u`` (arrays of one shape).

        Returns ``(lam, dlam_ds, dlam_dgamma)``; a derivative that vanishes identically is ``None``.
        """
        raise NotImplementedError

    def scaled(self, factor):
        """The element with its regularisation ``factor`` times stiffer; the set-valued law is unchanged."""
        return self

    def bound_scaled(self, s):
        """The element with its force bound times ``s`` (itself if it has no bound)."""
        return self

    # ------------------------------------------------------------------ scales
    def force_scale(self, stiffness, penalty=False):
        """Force (N) of the element in an unforced system; ``stiffness`` is ``|K_ii|`` per DOF.

        ``penalty``: count the regularised (penalty) law too.
        """
        return 0.0

    def magnitude_terms(self):
        """``[(key, what, value)]``: magnitudes that must stay inside the float range."""
        return []


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
    smoothing : float
        Regularisation ``kappa`` (s/m) of eq. (42), used by HBM only.
    relative_to : int or None
        Second DOF ``J``: the element then acts on ``q_dof - q_J`` (slip velocity ``u_dof - u_J``,
        ``w = e_dof - e_J``); ``None`` (default): between ``dof`` and the ground.
    normal_contact : int or None
        Index (into the system's element list) of a :class:`Contact` whose force ``lambda_N >= 0`` loads
        this friction: the bound is then ``mu (N_0 + lambda_N(t))``, ``N_0 = normal_force`` (see the
        module docstring).  The contact must act on other DOFs (the normal direction).  ``None``
        (default): the constant normal force ``normal_force``.
    """

    dof: int
    mu: float
    normal_force: float
    smoothing: float = 800.0
    relative_to: int | None = None
    normal_contact: int | None = None
    kind: str = field(default="friction", init=False)

    kernel_code: ClassVar[int] = KIND_FRICTION
    bounded: ClassVar[bool] = True

    def __post_init__(self):
        object.__setattr__(self, "dof", _dof("friction.dof", self.dof))
        object.__setattr__(self, "mu", _finite_number("friction.mu", self.mu, nonnegative=True))
        object.__setattr__(self, "normal_force",
                           _finite_number("friction.normal_force", self.normal_force, nonnegative=True))
        object.__setattr__(self, "smoothing",
                           _finite_number("friction.smoothing", self.smoothing, positive=True))
        self._check_relative()
        if self.normal_contact is not None:
            c = self.normal_contact
            if isinstance(c, bool) or not isinstance(c, (int, np.integer)) or c < 0:
                raise InputError("friction.normal_contact", f"must be the index (>= 0) of a contact element, "
                                 f"got {c!r}")
            object.__setattr__(self, "normal_contact", int(c))

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
        pos = lam_n > 0.0
        FN = self.normal_force + np.where(pos, lam_n, 0.0)
        ku = self.smoothing * gamma
        phi = -(2.0 / np.pi) * np.arctan(ku)
        dphi = -(2.0 / np.pi) * self.smoothing / (1.0 + ku * ku)
        dsN = None if dn_ds is None else self.mu * phi * np.where(pos, dn_ds, 0.0)
        dgN = None if dn_dgamma is None else self.mu * phi * np.where(pos, dn_dgamma, 0.0)
        return self.mu * FN * phi, self.mu * FN * dphi, dsN, dgN

    def project(self, p, h):
        """``-lambda_T in mu F_N Sign(gamma_T)``: the impulse lies in ``[-h mu F_N, h mu F_N]``."""
        b = h * self.bound
        return np.clip(p, -b, b)

    def kernel_parameters(self, h):
        return KIND_FRICTION, h * self.bound, 0.0, 0.0

    def regularised_law(self, s, gamma):
        """Eq. (42): ``lambda_T = -mu F_N (2/pi) arctan(kappa gamma_T)`` (constant ``F_N``; with a normal
        contact: :meth:`coupled_law`)."""
        if self.normal_contact is not None:
            raise TypeError("friction with a normal contact: its law depends on the contact force (coupled_law)")
        a = self.bound * 2.0 / np.pi
        ku = self.smoothing * gamma
        return -a * np.arctan(ku), None, -a * self.smoothing / (1.0 + ku * ku)

    def scaled(self, factor):
        """``kappa`` times ``factor``."""
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
        used by HBM only.
    relative_to : int or None
        Second DOF ``J``: the gap is then ``g_N = gap - (q_dof - q_J)`` (``w = -(e_dof - e_J)``);
        ``None`` (default): a stop fixed to the ground.
    """

    dof: int
    gap: float
    restitution: float = 1.0
    penalty_stiffness: float = 8000.0
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
        g = self.gap + s
        closed = g <= 0.0
        lam = np.where(closed, -(self.penalty_stiffness * g + self.penalty_damping * gamma), 0.0)
        return (lam, np.where(closed, -self.penalty_stiffness, 0.0),
                np.where(closed, -self.penalty_damping, 0.0))

    def scaled(self, factor):
        """``k_c`` and ``d_c`` times ``factor``."""
        return replace(self, penalty_stiffness=self.penalty_stiffness * factor,
                       penalty_damping=self.penalty_damping * factor)

    def force_scale(self, stiffness, penalty=False):
        """``K_dd gap`` (and ``k_c gap`` with ``penalty``)."""
        F = float(stiffness[self.dof]) * self.gap
        if penalty:
            F = max(F, self.penalty_stiffness * self.gap)
        return F

    def magnitude_terms(self):
        return [(f"{self.kind}.penalty_stiffness", "k_c gap", self.penalty_stiffness * max(self.gap, 1.0))]


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
        if self.normal_contact is not None:
            raise InputError("friction.normal_contact", "elastic friction (tangential_stiffness, Jenkins) with a "
                             "normal load from a contact is not supported")

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
        return lam, D

    def magnitude_terms(self):
        return super().magnitude_terms() + [(f"{self.kind}.tangential_stiffness", "k_t", self.tangential_stiffness)]


#: element classes by their ``kind`` (the case-file keys)
ELEMENT_TYPES = {cls.kind: cls for cls in (Friction, Contact)}


def regularised_forces(elements, local_dof, q, u, coupling=False, basis=None):
    """Evaluate the regularised laws (:meth:`Element.regularised_law`) on samples.

    Friction (eq. 42), slip velocity ``gamma_T = w^T u``::

        lambda_T = -mu F_N (2/pi) arctan(kappa gamma_T)

    Penalty contact (eq. 45), ``g_N = g0 + w^T q`` (``g0 - q_d`` on one DOF), ``gamma_N = w^T u``::

        lambda_N = -(k_c g_N + d_c gamma_N)   if g_N <= 0,   0 otherwise

    The force on the DOFs is ``w lambda`` with ``w = +e_d`` (friction) or ``-e_d`` (contact), or
    ``w = sign (e_I - e_J)`` for an element relative to a second DOF ``J``.

    The penalty law is piecewise linear in ``(q, u)``: continuous for ``d_c = 0``, with
    a jump ``d_c gamma_N`` at ``g_N = 0`` for ``d_c > 0``.  On the AFT samples the HBM
    residual inherits this structure, which :meth:`mshbm.methods.hbm.HBMProblem.newton_fallback`
    exploits (exact path following instead of smoothing: the law used at convergence is
    always exactly eq. 45).  At ``g_N = 0`` the sample counts as closed (one-sided Jacobian).

    Parameters
    ----------
    elements : sequence of Element
    local_dof : sequence of int or of tuples of int
        Column of ``q``/``u`` that each element acts on; for a relative element the columns of
        its two DOFs ``(I, J)`` (an int alone: its ``dof``'s column, single-DOF elements).
    q, u : ndarray, shape (N_s, n_N)
        Displacements and velocities of the nonlinear DOFs at the samples.
    coupling : bool
        Also return the off-diagonal Jacobian terms of relative elements.
    basis : ndarray, shape (N_s, n_b), optional
        ``q = basis @ coefficients`` (HBM: the inverse DFT): the derivatives of history elements are
        then taken with respect to the coefficients.

    Returns
    -------
    lam : ndarray, shape (N_s, m)
        Element forces ``lambda_j``.
    f : ndarray, shape (N_s, n_N)
        Generalised forces on the DOFs, ``sum_j w_j lambda_j``.
    dfdq, dfdu : ndarray, shape (N_s, n_N)
        Diagonal derivatives ``d f_i / d q_i`` and ``d f_i / d u_i`` (the diagonal of ``w w^T``
        times the element's derivatives).
    offdiag : list of ``(i, k, dfdq_ik, dfdu_ik)``, only with ``coupling``
        ``d f_i / d q_k`` and ``d f_i / d u_k`` (``i != k``, arrays of shape (N_s,) or None)
        of the relative elements; for elements with a history (:class:`Jenkins`) ``dfdq_ik`` is an
        ``(N_s, N_s)`` matrix ``d f_i(t_a) / d q_k(t_b)`` (``i == k`` included), or with ``basis`` the
        ``(N_s, n_b)`` matrix ``d f_i(t_a) / d c_k`` for the coefficients ``c_k`` of ``q_k``.
    """
    Ns, nN = q.shape
    lam = np.zeros((Ns, len(elements)))
    f = np.zeros((Ns, nN))
    dfdq = np.zeros((Ns, nN))
    dfdu = np.zeros((Ns, nN))
    offdiag = []
    laws = {}  # element index -> (lam, dlam/ds, dlam/dgamma) of the contacts that load a friction
    loads = {el.normal_contact for el in elements if el.normal_contact is not None}
    cols_of = lambda d: (d,) if isinstance(d, (int, np.integer)) else tuple(d)

    def add(i, k, cq, cu):  # d f_i / d (q_k, u_k) of one element: diagonal or coupling term
        if i == k:
            if cq is not None:
                dfdq[:, i] += cq
            if cu is not None:
                dfdu[:, i] += cu
        else:
            offdiag.append((i, k, cq, cu))

    for j, (el, d) in enumerate(zip(elements, local_dof)):
        w = el.sign
        if el.normal_contact is not None:
            continue  # after the contacts (second pass)
        if el.history:  # dense in time: d lambda_k / d s_l, into the coupling terms as (N_s, N_s) matrices
            cols = (d,) if isinstance(d, (int, np.integer)) else tuple(d)
            wc = [(c, wi) for c, (_, wi) in zip(cols, el.direction)]
            s = sum(wi * q[:, c] for c, wi in wc) if len(wc) > 1 else w * q[:, cols[0]]
            lam[:, j], D = el.history_law(s, basis)
            for i, wi in wc:
                f[:, i] += wi * lam[:, j]
                for k, wk in wc:
                    offdiag.append((i, k, D if wi * wk == 1.0 else (wi * wk) * D, None))
            continue
        if el.relative_to is None:
            d = d[0] if isinstance(d, tuple) else d
            lam[:, j], dl_ds, dl_dg = el.regularised_law(w * q[:, d], w * u[:, d])
            if j in loads:
                laws[j] = (lam[:, j], dl_ds, dl_dg)
            f[:, d] += w * lam[:, j]
            if dl_ds is not None:
                dfdq[:, d] += (w * w) * dl_ds
            if dl_dg is not None:
                dfdu[:, d] += (w * w) * dl_dg
            continue
        a, b = d
        lam[:, j], dl_ds, dl_dg = el.regularised_law(w * (q[:, a] - q[:, b]), w * (u[:, a] - u[:, b]))
        if j in loads:
            laws[j] = (lam[:, j], dl_ds, dl_dg)
        f[:, a] += w * lam[:, j]
        f[:, b] -= w * lam[:, j]
        for i, wi in ((a, w), (b, -w)):
            for k, wk in ((a, w), (b, -w)):
                add(i, k, None if dl_ds is None else (wi * wk) * dl_ds, None if dl_dg is None else (wi * wk) * dl_dg)
    # friction loaded by a contact: lambda_T = mu (N_0 + lambda_N) phi(gamma_T); d f / d (q, u) of the
    # tangential DOFs (through gamma_T) and of the contact's DOFs (through lambda_N)
    for j, (el, d) in enumerate(zip(elements, local_dof)):
        if el.normal_contact is None:
            continue
        c = el.normal_contact
        if c not in laws:
            raise InputError("friction.normal_contact", f"element {c} is not a contact element")
        wt = [(col, wi) for col, (_, wi) in zip(cols_of(d), el.direction)]
        wn = [(col, wi) for col, (_, wi) in zip(cols_of(local_dof[c]), elements[c].direction)]
        gam = sum(wi * u[:, col] for col, wi in wt)
        lam[:, j], dl_dgt, dl_dsn, dl_dgn = el.coupled_law(gam, *laws[c])
        for i, wi in wt:
            f[:, i] += wi * lam[:, j]
            for k, wk in wt:
                add(i, k, None, (wi * wk) * dl_dgt)
            for k, wk in wn:
                add(i, k, None if dl_dsn is None else (wi * wk) * dl_dsn,
                    None if dl_dgn is None else (wi * wk) * dl_dgn)
    if coupling:
        return lam, f, dfdq, dfdu, offdiag
    if offdiag:
        raise ValueError("regularised_forces: relative or history elements couple DOFs or samples; "
                         "call with coupling=True")
    return lam, f, dfdq, dfdu
