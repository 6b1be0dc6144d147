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

Elements between two DOFs: friction and contact *relative* to a second DOF (``relative_to=J``, all
methods): ``dofs = (I, J)``, ``w = sign (e_I - e_J)`` (:attr:`Element.direction`, :meth:`Element.local`);
the laws are the same functions of ``(s, gamma)``.  :func:`regularised_forces` adds the off-diagonal
Jacobian terms of ``w w^T``; the Moreau-Jean kernel takes the second DOF as ``dof2`` (``-1``: the ground);
the exact event-driven flow and hence exact Floquet multipliers handle elements on one DOF only (any number;
InputError; stability falls back to the step map with the reason).

Elements with an internal state (:class:`Jenkins`) and friction whose normal load comes from a contact
(``Friction(..., normal_contact=c)``) are described in :mod:`mshbm.elements.friction`; the 3-D frictional
contact (two frictions linked as ``cone_partner``, circular cone ``||lambda_T|| <= mu F_N``) in
:mod:`mshbm.elements.cone`.

The smooth polynomial spring :class:`Polynomial` (``lambda = -sum_p k_p s^p``, :attr:`Element.smooth`; cubic
springs, Duffing) is described in :mod:`mshbm.elements.polynomial`: exact in HBM and DLFT, explicit at the
midpoint ``q + h/2 u`` in Moreau-Jean, refused by the exact event-driven flow.

Modules: :mod:`~mshbm.elements.base` (the contract), :mod:`~mshbm.elements.friction`,
:mod:`~mshbm.elements.contact`, :mod:`~mshbm.elements.regularised` (the laws assembled on samples).
"""
from .base import Element, _dof, _finite_number, dependent_directions  # noqa: F401 -- the parameter checks, shared with mshbm.system
from .cone import frictional_contact
from .contact import Contact
from .friction import Friction, Jenkins
from .polynomial import Polynomial
from .regularised import regularised_forces

__all__ = ["Element", "Friction", "Contact", "Jenkins", "Polynomial", "frictional_contact", "regularised_forces",
           "ELEMENT_TYPES"]

#: element classes by their ``kind`` (the case-file keys)
ELEMENT_TYPES = {"friction": Friction, "contact": Contact, "polynomial": Polynomial}
