"""3-D frictional contact: two :class:`~mshbm.elements.Friction` elements linked as *cone partners*.

A contact point with two tangential DOFs ``t1, t2`` and one normal DOF ``n`` (each relative to a second
DOF, or to the ground) is modelled by the existing elements, linked by indices into the system's element
list:

* ``Friction(t1, mu, N_0, cone_partner=j2, normal_contact=c)`` and ``Friction(t2, mu, N_0, cone_partner=j1,
  normal_contact=c)``: the tangential force ``lambda_T = (lambda_T1, lambda_T2)`` obeys Coulomb's law with
  the **circular cone** ``||lambda_T|| <= mu F_N`` and maximal dissipation,
  ``-lambda_T in mu F_N d||gamma_T||`` (``gamma_T = (gamma_T1, gamma_T2)``, the slip direction rotates);
* ``Contact(n, gap, e_N)`` (optional, index ``c``): the unilateral normal contact with Newton's restitution
  whose force loads the friction, ``F_N = N_0 + lambda_N``; without it the normal load is the constant
  ``N_0 = normal_force``.

:func:`frictional_contact` builds the two or three elements with the indices filled in.

**3-D Jenkins** (``tangential_stiffness=k_t`` on both, :class:`~mshbm.elements.Jenkins`; constant normal load,
preload ``N_0``): a tangential spring ``k_t`` in each direction in series with one slider on the disk.
Moreau-Jean integrates the two massless slider DOFs with rigid friction that are cone partners
(:func:`mshbm.integrators.moreau_jean._with_sliders`); HBM marches the return mapping on the disk
(:func:`cone_history_law`, exact derivative).  **Jenkins partners loaded by a (rigid) normal contact**
(``normal_contact`` with ``tangential_stiffness``; preload ``N_0``, varying ``N = N_0 + lambda_N``): time stepping
and DLFT give the sliders the contact-loaded disk (the kernel's cone block with the contact; DLFT's per-sample
bound); HBM refuses (:class:`~mshbm.errors.InputError` naming ``friction.normal_contact``, CLI exit 2): its
return mapping would need the per-sample bound ``mu (N_0 + lambda_N(t_k))``, its derivative with respect to the
normal DOFs' coefficients and the periodic start's fixed point with a moving bound.  **A normal contact
stiffness** (a compliant normal contact) is not implemented in any method: there is no key for it
(``Contact.penalty_stiffness`` is HBM's regularisation, not a physical stiffness; time stepping and DLFT keep
the rigid contact).  It would be a massless normal slider DOF ``z_N`` tied to the normal DOF by ``k_N`` and
carrying the rigid contact, whose impulse loads the sliders' disk; the slider DOFs are stepped with ``theta =
1``, and a contact on a massless DOF has no impact law (``e_N`` is meaningless there): the Moreau-Jean step
would have to treat it as a quasi-static complementarity, which the kernel does not do.

Methods:

* **Moreau-Jean** (shooting, both MS-HBM variants): the local problem projects the tangential impulse onto
  the disk ``||P_T|| <= mu (h N_0 + P_N)`` -- the pair is one block of the projected Gauss-Seidel sweep,
  solved exactly for the current bound (:func:`mshbm.integrators.local_problem._disk_solve`, the
  trust-region subproblem of the 2x2 Delassus block); the sensitivities are exact for the active set,
  with the rotation of the slip direction in slip (:mod:`mshbm.integrators.kernels`).
* **HBM**: the regularised cone law (:func:`cone_law`)::

      lambda_T = -mu F_N (2/pi) arctan(kappa ||gamma_T||) gamma_T / ||gamma_T||

  smooth at ``gamma_T = 0`` (``arctan(x)/x`` is even and analytic) and, with the slip in one direction,
  *exactly* the 1-D law of eq. (42); ``kappa`` is the friction's ``smoothing`` (default from the unit-free
  rule of :mod:`mshbm.methods.hbm_regularisation`, one value per pair from the pair's larger velocity
  scale).  With a normal contact ``F_N = N_0 + max(lambda_N, 0)`` with the penalty force (eq. 45).
* **DLFT** (velocity predictor): the pair's prediction ``y_T`` projected onto the disk, one penalty per pair
  (:mod:`mshbm.methods.dlft`), on ground or between two node triples; the 3-D Jenkins pair as two massless slider
  DOFs carrying the rigid pair (:mod:`mshbm.methods.dlft_terms`).
* The **exact event-driven flow**, DLFT's displacement predictor, the backbone (EPMC) and
  ``penalty_quadrature="linear"``: not supported, a clear :class:`~mshbm.errors.InputError` naming
  ``friction.cone_partner`` (time stepping: the Moreau-Jean integrator).  Hill's method (HBM stability)
  reports that it cannot take the pair's coupling terms; the step map's multipliers come from the kernel's
  sensitivities.
* **Certificate**: ``friction_cone`` checks ``||lambda_T|| <= mu F_N`` per sample; ``cone_dissipation``
  checks maximal dissipation, ``lambda_T . gamma_T = -||lambda_T|| ||gamma_T||`` wherever the pair slips.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import InputError

__all__ = ["frictional_contact", "cone_law", "cone_history_law", "cone_pairs", "check_cone_pairs"]


def frictional_contact(t1, t2, mu, normal_force=0.0, *, normal=None, gap=0.0, restitution=0.0, first=0,
                       relative_to=None, smoothing=None, penalty_stiffness=None, penalty_damping=0.0,
                       tangential_stiffness=None):
    """The elements of one 3-D frictional contact, to be placed at ``elements[first:first + 2 or 3]``.

    Parameters
    ----------
    t1, t2 : int
        Tangential DOFs.
    mu : float
        Friction coefficient.
    normal_force : float
        ``N_0`` (N): the constant normal load, or with ``normal`` the preload added to the contact force.
    normal : int or None
        Normal DOF of a unilateral contact (gap ``g_N = gap - q_n``, restitution ``e_N``) whose force loads
        the friction; ``None``: the constant normal load ``normal_force``.
    first : int
        Index of the first returned element in the system's element list.
    relative_to : None or tuple of (int or None)
        Second DOFs ``(J1, J2, Jn)`` of a contact between two nodes (``None`` entries: the ground).
    smoothing, penalty_stiffness, penalty_damping : as for :class:`Friction` and :class:`Contact` (HBM only).
    tangential_stiffness : float or None
        ``k_t`` (N/m): the 3-D Jenkins element (a tangential spring in both directions in series with the
        slider on the disk, :func:`cone_history_law`); constant normal load only.

    Returns
    -------
    list of Element: ``[Friction(t1), Friction(t2)]`` and, with ``normal``, ``Contact(normal)``.
    """
    from functools import partial

    from .contact import Contact
    from .friction import Friction, Jenkins

    J = (None, None, None) if relative_to is None else tuple(relative_to)
    if len(J) != 3:
        raise InputError("frictional_contact.relative_to", f"must be three DOFs (J1, J2, Jn) or None, got {J!r}")
    c = None if normal is None else first + 2
    if tangential_stiffness is not None:
        Friction = partial(Jenkins, tangential_stiffness=tangential_stiffness)  # noqa: N806
    out = [Friction(t1, mu, normal_force, smoothing=smoothing, relative_to=J[0], normal_contact=c,
                    cone_partner=first + 1),
           Friction(t2, mu, normal_force, smoothing=smoothing, relative_to=J[1], normal_contact=c,
                    cone_partner=first)]
    if normal is not None:
        out.append(Contact(normal, gap, restitution, penalty_stiffness=penalty_stiffness,
                           penalty_damping=penalty_damping, relative_to=J[2]))
    return out


def cone_pairs(elements):
    """``[(j, k)]`` with ``j < k``: the cone partners among ``elements``."""
    return [(j, int(el.cone_partner)) for j, el in enumerate(elements)
            if el.cone_partner is not None and j < el.cone_partner]


def check_cone_pairs(elements):
    """Clear errors for inconsistent cone partners (:class:`~mshbm.errors.InputError` naming
    ``friction.cone_partner``)."""
    m = len(elements)
    for j, el in enumerate(elements):
        k = el.cone_partner
        if k is None:
            continue
        key = "friction.cone_partner"
        if not 0 <= k < m or k == j:
            raise InputError(key, f"friction {j}: no other element {k} (the system has {m})")
        other = elements[k]
        if not other.bounded or other.cone_partner != j:
            raise InputError(key, f"friction {j} names element {k} as its cone partner, which must be a friction "
                             f"naming {j} back (got a {other.kind} with cone_partner {other.cone_partner})")
        if int(other.dof) == int(el.dof) and other.relative_to == el.relative_to:
            raise InputError(key, f"frictions {j} and {k} act on the same DOF {el.dof}: the two tangential "
                             "directions must be different DOFs")
        if el.history != other.history:
            raise InputError(key, f"cone partners {j} and {k}: both elastic (tangential_stiffness) or both rigid")
        for name in ("mu", "normal_force", "normal_contact", "smoothing", "tangential_stiffness"):
            if getattr(el, name, None) != getattr(other, name, None):
                raise InputError(key, f"cone partners {j} and {k} must have the same {name} (one contact point), "
                                 f"got {getattr(el, name)!r} and {getattr(other, name)!r}")


def _atan_ratio(x):
    """``A(x) = arctan(x)/x`` and ``B(x) = (x/(1+x^2) - arctan(x))/x^3`` (``A'(x) = x B(x)``), with their
    series at small ``x`` (``A -> 1``, ``B -> -2/3``)."""
    x = np.asarray(x, dtype=float)
    small = x < 1e-3
    xs = np.where(small, 1.0, x)
    at = np.arctan(xs)
    x2 = x * x
    A = np.where(small, 1.0 - x2 / 3.0 + x2 * x2 / 5.0, at / xs)
    B = np.where(small, -2.0 / 3.0 + 0.8 * x2 - 6.0 / 7.0 * x2 * x2, (xs / (1.0 + xs * xs) - at) / xs ** 3)
    return A, B


def cone_law(el, g1, g2, lam_n=None, dn_ds=None, dn_dgamma=None):
    """Regularised cone law of friction ``el`` (direction 1) given its slip ``g1`` and its partner's ``g2``::

        lambda_1 = -mu F_N (2/pi) arctan(kappa r) g1 / r,    r = ||(g1, g2)||

    ``F_N = N_0`` or, with the contact force samples ``lam_n`` (and its derivatives ``dn_ds``,
    ``dn_dgamma`` with respect to the contact's own ``s_N``, ``gamma_N``), ``N_0 + max(lambda_N, 0)``.

    Returns ``(lam, dlam_dg1, dlam_dg2, dlam_ds_N, dlam_dgamma_N)`` (``None`` for a vanishing term).
    """
    if el.smoothing is None:
        raise TypeError("friction.smoothing is None (the default): HBM fills it in from the problem's scales "
                        "(mshbm.methods.hbm_regularisation.resolve) before the law is evaluated")
    kappa = float(el.smoothing)
    g1, g2 = np.asarray(g1, dtype=float), np.asarray(g2, dtype=float)
    x = kappa * np.hypot(g1, g2)
    A, B = _atan_ratio(x)
    c = (2.0 / np.pi) * kappa
    phi = -c * A * g1  # lambda_1 / (mu F_N)
    d11 = -c * (A + kappa * kappa * B * g1 * g1)
    d12 = -c * kappa * kappa * B * g1 * g2
    if lam_n is None:
        b = el.mu * el.normal_force
        return b * phi, b * d11, b * d12, None, None
    pos = lam_n > 0.0
    FN = el.normal_force + np.where(pos, lam_n, 0.0)
    dsN = None if dn_ds is None else el.mu * phi * np.where(pos, dn_ds, 0.0)
    dgN = None if dn_dgamma is None else el.mu * phi * np.where(pos, dn_dgamma, 0.0)
    b = el.mu * FN
    return b * phi, b * d11, b * d12, dsN, dgN


#: most periods marched to the periodic state of the 3-D Jenkins law (:func:`cone_history_law`)
MAX_PASSES = 10000


@njit(cache=True)
def _periodic_start(ds, kt, b, max_passes):
    """The periodic state at the last sample of the disk's return mapping driven by the increments ``ds``
    (N_s, 2): the fixed point ``lambda* = Phi(lambda*)`` of the period map ``Phi``, from zero until one period
    returns to its start to ``1e-14 b`` (at most ``max_passes`` periods).  Each period is marched with its
    derivative ``J = d Phi / d lambda`` (the product of the slip projections ``(b / ||t||) (I - d d^T)``); the
    next start is Newton's ``lambda + (I - J)^-1 (Phi(lambda) - lambda)`` (the plain march ``Phi(lambda)``
    converges only geometrically, for slow rates over thousands of periods) as long as Newton at least halves
    the return ``||Phi(lambda) - lambda||`` per period, the march after that."""
    x, y = 0.0, 0.0
    newton, r_prev = True, np.inf
    for _ in range(max_passes):
        px, py = x, y
        j00, j01, j10, j11 = 1.0, 0.0, 0.0, 1.0
        for k in range(ds.shape[0]):
            tx, ty = px - kt * ds[k, 0], py - kt * ds[k, 1]
            nt = math.hypot(tx, ty)
            if nt > b:
                d0, d1 = tx / nt, ty / nt
                c = b / nt
                p00, p01, p11 = c * (1.0 - d0 * d0), -c * d0 * d1, c * (1.0 - d1 * d1)
                j00, j01, j10, j11 = (p00 * j00 + p01 * j10, p00 * j01 + p01 * j11,
                                      p01 * j00 + p11 * j10, p01 * j01 + p11 * j11)
                tx, ty = b * tx / nt, b * ty / nt
            px, py = tx, ty
        rx, ry = px - x, py - y
        r = math.hypot(rx, ry)
        if r <= 1e-14 * b:
            return np.array([px, py])
        if newton and r > 0.5 * r_prev:
            newton = False
        r_prev = r
        a00, a01, a10, a11 = 1.0 - j00, -j01, -j10, 1.0 - j11
        det = a00 * a11 - a01 * a10
        if newton and abs(det) > 1e-12:
            x, y = x + (a11 * rx - a01 * ry) / det, y + (a00 * ry - a10 * rx) / det
        else:
            x, y = px, py
    return np.array([x, y])


@njit(cache=True)
def _march(ds, V, kt, b, start):
    """One period of the disk's return mapping from ``start`` (the state at the last sample) with both
    sensitivities: ``lam`` (N_s, 2), ``Dc`` (N_s, 2, 2, n_b) ``d lambda_k / d c`` with the start held, ``J``
    (N_s, 2, 2) ``d lambda_k / d lambda_start``, and whether the pair slipped (:func:`cone_history_law`).  In slip
    ``d lambda = P d t`` with ``P = (b / ||t||) (I - d d^T)``."""
    Ns, nb = ds.shape[0], V.shape[1]
    lam = np.zeros((Ns, 2))
    Dc = np.zeros((Ns, 2, 2, nb))
    J = np.zeros((Ns, 2, 2))
    l0, l1 = start[0], start[1]
    j00, j01, j10, j11 = 1.0, 0.0, 0.0, 1.0
    prev_k = Ns - 1
    slipped = False
    for k in range(Ns):
        t0, t1 = l0 - kt * ds[k, 0], l1 - kt * ds[k, 1]
        Dt = Dc[k]
        if k > 0:
            Dt[:, :, :] = Dc[k - 1]
        for n in range(nb):
            dV = kt * (V[k, n] - V[prev_k, n])
            Dt[0, 0, n] -= dV
            Dt[1, 1, n] -= dV
        nt = math.hypot(t0, t1)
        if nt > b:
            slipped = True
            d0, d1 = t0 / nt, t1 / nt
            c = b / nt
            p00, p01, p10, p11 = c * (1.0 - d0 * d0), c * (0.0 - d0 * d1), c * (0.0 - d1 * d0), c * (1.0 - d1 * d1)
            t0, t1 = b * d0, b * d1
            for bb in range(2):
                for n in range(nb):
                    x0, x1 = Dt[0, bb, n], Dt[1, bb, n]
                    Dt[0, bb, n] = p00 * x0 + p01 * x1
                    Dt[1, bb, n] = p10 * x0 + p11 * x1
            j00, j01, j10, j11 = (p00 * j00 + p01 * j10, p00 * j01 + p01 * j11,
                                  p10 * j00 + p11 * j10, p10 * j01 + p11 * j11)
        lam[k, 0], lam[k, 1] = t0, t1
        J[k, 0, 0], J[k, 0, 1], J[k, 1, 0], J[k, 1, 1] = j00, j01, j10, j11
        l0, l1, prev_k = t0, t1, k
    return lam, Dc, J, slipped


def cone_history_law(el, s1, s2, basis=None):
    """3-D Jenkins law of cone partners (``el`` the first; both with ``k_t = tangential_stiffness`` and the bound
    ``b = mu N_0``) at the periodic samples of their ``s = w^T q``, ``s1`` and ``s2`` (shape (N_s,) each).

    The return mapping on the disk, from ``lambda = 0`` at the last sample::

        t_k = lambda_{k-1} - k_t (s_k - s_{k-1}),   lambda_k = t_k if ||t_k|| <= b else b t_k / ||t_k||

    marched period after period until the state at the last sample repeats (to ``1e-14 b``; at most
    :data:`MAX_PASSES` periods): the periodic hysteresis.  Unlike the 1-D law, two periods do not suffice in 2-D:
    a slip phase removes only the component of the state along the slip direction and shrinks the other one, so
    the memory of the start fades geometrically (with an elliptic relative motion in partial slip, tens to
    thousands of periods; Newton on the period map, :func:`_periodic_start`, takes a few).  A stuck orbit (the loop, centred on the middle of its bounding box, lies strictly inside the disk;
    a slipping periodic orbit cannot: its slip directions, the loop's points on the circle, surround the origin)
    has no unique slider position; it is centred on that middle, as the 1-D law (:meth:`Jenkins.history_law`)
    does with the middle of its range, which it is when the motion keeps one direction.

    Returns ``lam`` (N_s, 2) and ``D`` (N_s, 2, 2, n_b): ``d lambda_a(t_k) / d c_b`` of the periodic law for the
    coefficients ``s_b = basis @ c_b`` (``basis=None``: the samples themselves, ``n_b = N_s``); in slip
    ``d lambda = (b / ||t||) (I - d d^T) d t``.  The derivative of the periodic start ``lambda*`` (a fixed
    point of the period map ``Phi``) is ``(I - d Phi / d lambda)^-1 d Phi / d c``, from one period marched with
    both sensitivities.
    """
    s = np.stack([np.asarray(s1, dtype=float), np.asarray(s2, dtype=float)], axis=1)
    Ns = s.shape[0]
    V = np.eye(Ns) if basis is None else np.asarray(basis, dtype=float)
    nb = V.shape[1]
    kt, b = float(el.tangential_stiffness), float(el.bound)
    ds = np.diff(s, axis=0, prepend=s[-1:])  # s_k - s_{k-1}, periodic
    start = _periodic_start(np.ascontiguousarray(ds), kt, b, MAX_PASSES)
    lam, Dc, J, slipped = _march(ds, np.ascontiguousarray(V), kt, b, start)
    i, j = np.argmax(lam, axis=0), np.argmin(lam, axis=0)
    mid = 0.5 * (lam[i, [0, 1]] + lam[j, [0, 1]])
    if np.hypot(*(lam - mid).T).max() < b * (1 - 1e-9):  # stuck: the start is a convention, centred (docstring)
        dmid = 0.5 * (Dc[i, [0, 1]] + Dc[j, [0, 1]])  # (2, 2, n_b): row a from the samples of component a
        return lam - mid, Dc - dmid
    if not slipped:
        return lam, Dc
    dstart = np.linalg.solve(np.eye(2) - J[-1], Dc[-1].reshape(2, -1)).reshape(2, 2, nb)
    return lam, Dc + np.einsum("kac,cbn->kabn", J, dstart)
