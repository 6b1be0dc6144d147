"""The element contract: :class:`Element`, what every local nonsmooth element owns, and the checks of
element parameters (numbers, DOF indices) that the element classes share."""
from __future__ import annotations

import math
from dataclasses import replace
from typing import ClassVar

import numpy as np

from ..errors import InputError

__all__ = ["Element", "dependent_directions"]


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
    #: a smooth position-dependent force (:class:`mshbm.elements.Polynomial`): no set-valued law, exact in HBM,
    #: explicit at ``q_M = q + h/2 u`` in Moreau-Jean (kernel kind ``KIND_SMOOTH``)
    smooth: ClassVar[bool] = False

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

    #: index (into the system's element list) of the friction on the second tangential direction of a 3-D
    #: frictional contact (circular cone, :mod:`mshbm.elements.cone`); ``None``: none
    cone_partner = None

    def kernel_partner(self):
        """Index of the Moreau-Jean kernel's disk partner (``-1``: none)."""
        return -1

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


def dependent_directions(elements):
    """Why the directions ``w_j`` of the set-valued elements (friction and contact; smooth springs are not
    constraints) are linearly dependent, or ``None`` if they are independent.  Dependent directions (a friction
    and a contact element on one DOF) leave the elements' forces along them undetermined while both are active:
    the one-step impulse problem and the event flow's contact forces have no unique solution."""
    els = [el for el in elements if not getattr(el, "smooth", False)]
    if len(els) < 2:
        return None
    dofs = sorted({int(d) for el in els for d, _ in el.direction})
    pos = {d: i for i, d in enumerate(dofs)}
    W = np.zeros((len(dofs), len(els)))
    for j, el in enumerate(els):
        for d, w in el.direction:
            W[pos[int(d)], j] = w
    if np.linalg.matrix_rank(W) == len(els):
        return None
    ground = [int(el.dof) for el in els if el.relative_to is None]
    d = next((d for d in ground if ground.count(d) > 1), None)
    if d is not None:
        kinds = " and ".join(el.kind for el in els if el.relative_to is None and int(el.dof) == d)
        return f"DOF {d} carries {kinds} elements"
    return "two elements act along one direction"
