"""Regularised (single-valued) force laws used by HBM-AFT, with derivatives.

Friction (eq. 42), slip velocity ``gamma_T = u_d``::

    lambda_T = -mu F_N (2/pi) arctan(kappa gamma_T)

Penalty contact (eq. 45), ``g_N = g0 - q_d``, ``gamma_N = -u_d``::

    lambda_N = -(k_c g_N + d_c gamma_N)   if g_N <= 0,   0 otherwise

The force on the DOF is ``w lambda`` with ``w = +1`` (friction) or ``-1`` (contact).

The penalty law is piecewise linear in ``(q, u)``: continuous for ``d_c = 0``, with
a jump ``d_c gamma_N`` at ``g_N = 0`` for ``d_c > 0``.  On the AFT samples the HBM
residual inherits this structure, which :meth:`mshbm.methods.hbm.HBMProblem.newton_fallback`
exploits (exact path following instead of smoothing: the law used at convergence is
always exactly eq. 45).  At ``g_N = 0`` the sample counts as closed (one-sided Jacobian).
"""
from __future__ import annotations

import numpy as np

from .system import Contact, Friction

__all__ = ["regularised_forces"]


def regularised_forces(elements, local_dof, q, u):
    """Evaluate the regularised laws on samples.

    Parameters
    ----------
    elements : sequence of Friction or Contact
    local_dof : sequence of int
        Column of ``q``/``u`` that each element acts on.
    q, u : ndarray, shape (N_s, n_N)
        Displacements and velocities of the nonlinear DOFs at the samples.

    Returns
    -------
    lam : ndarray, shape (N_s, m)
        Element forces ``lambda_j``.
    f : ndarray, shape (N_s, n_N)
        Generalised forces on the DOFs, ``sum_j w_j lambda_j``.
    dfdq, dfdu : ndarray, shape (N_s, n_N)
        Diagonal derivatives ``d f_i / d q_i`` and ``d f_i / d u_i``.
    """
    Ns, nN = q.shape
    lam = np.zeros((Ns, len(elements)))
    f = np.zeros((Ns, nN))
    dfdq = np.zeros((Ns, nN))
    dfdu = np.zeros((Ns, nN))
    for j, (el, d) in enumerate(zip(elements, local_dof)):
        if isinstance(el, Friction):
            a = el.bound * 2.0 / np.pi
            ku = el.smoothing * u[:, d]
            lam[:, j] = -a * np.arctan(ku)
            f[:, d] += lam[:, j]
            dfdu[:, d] += -a * el.smoothing / (1.0 + ku * ku)
        elif isinstance(el, Contact):
            g = el.gap - q[:, d]
            closed = g <= 0.0
            lam[:, j] = np.where(closed, -(el.penalty_stiffness * g - el.penalty_damping * u[:, d]), 0.0)
            f[:, d] -= lam[:, j]
            dfdq[:, d] += np.where(closed, -el.penalty_stiffness, 0.0)
            dfdu[:, d] += np.where(closed, -el.penalty_damping, 0.0)
        else:  # pragma: no cover
            raise TypeError(el)
    return lam, f, dfdq, dfdu
