"""The regularised laws of a set of elements assembled on samples (HBM's AFT, Hill's method):
:func:`regularised_forces`."""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from .cone import cone_history_law, cone_law

__all__ = ["regularised_forces"]


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
        if (el.normal_contact is not None or el.cone_partner is not None) and not el.history:
            continue  # after the contacts (second pass)
        if el.history and el.cone_partner is not None:  # 3-D Jenkins: the pair's return mapping on the disk
            p = el.cone_partner
            if p < j:
                continue  # done with its partner
            wcs = [[(c, wi) for c, (_, wi) in zip(cols_of(local_dof[i]), elements[i].direction)] for i in (j, p)]
            ss = [sum(wi * q[:, c] for c, wi in wc) for wc in wcs]
            lam2, D = cone_history_law(el, ss[0], ss[1], basis)
            for a, (ja, wa) in enumerate(((j, wcs[0]), (p, wcs[1]))):
                lam[:, ja] = lam2[:, a]
                for i, wi in wa:
                    f[:, i] += wi * lam2[:, a]
                    for bb, wb in enumerate(wcs):
                        for kk, wk in wb:
                            offdiag.append((i, kk, (wi * wk) * D[:, a, bb], None))
            continue
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
    # (3-D frictional contact: lambda_T = -mu F_N (2/pi) arctan(kappa ||gamma_T||) gamma_T / ||gamma_T||, its
    # partner's slip entering through ||gamma_T||, mshbm.elements.cone.cone_law)
    for j, (el, d) in enumerate(zip(elements, local_dof)):
        if (el.normal_contact is None and el.cone_partner is None) or el.history:
            continue
        c = el.normal_contact
        if c is not None and c not in laws:
            raise InputError("friction.normal_contact", f"element {c} is not a contact element")
        wt = [(col, wi) for col, (_, wi) in zip(cols_of(d), el.direction)]
        wn = [] if c is None else [(col, wi) for col, (_, wi) in zip(cols_of(local_dof[c]), elements[c].direction)]
        gam = sum(wi * u[:, col] for col, wi in wt)
        if el.cone_partner is None:
            lam[:, j], dl_dgt, dl_dsn, dl_dgn = el.coupled_law(gam, *laws[c])
        else:
            p = el.cone_partner
            if not 0 <= p < len(elements) or elements[p].cone_partner != j:
                raise InputError("friction.cone_partner", f"element {p} is not the cone partner of friction {j}")
            wp = [(col, wi) for col, (_, wi) in zip(cols_of(local_dof[p]), elements[p].direction)]
            gp = sum(wi * u[:, col] for col, wi in wp)
            lam[:, j], dl_dgt, dl_dgp, dl_dsn, dl_dgn = cone_law(el, gam, gp, *(laws[c] if c is not None else ()))
            for i, wi in wt:
                for k, wk in wp:
                    add(i, k, None, (wi * wk) * dl_dgp)
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
