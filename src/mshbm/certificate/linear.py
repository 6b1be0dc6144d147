"""Checks of the linear structure's discretisation: ``time_warping`` and ``undamped_resonance``.

``time_warping`` (gating, time stepping)
    First-order estimate of the relative error that the Moreau-Jean scheme's frequency warping of
    the time-stepped DOFs ``T`` causes in the periodic response: on a harmonic ``X e^{i w t}``
    (``w = k omega``) the scheme (with ``theta``-weighted forcing) acts like the dynamic stiffness
    ``K + i w~ C - w~^2 M`` with ``i w~ = (z - 1) / (h (1 - theta + theta z))``, ``z = e^{i w h}``,
    instead of ``K + i w C - w^2 M``; the difference ``dH_k`` on the ``T x T`` block, applied to the
    solution's harmonics, displaces the linear response by ``delta_k = H(k omega)^-1 dH_k X_T,k``.
    Value: ``max_k max |delta_k| / D``; bound :data:`TIME_DISCRETISATION_BOUND`.  Gating only where the
    linear structure describes the solution: its own response to the forcing, ``max |H(k omega)^-1 f_k|``,
    is at most ``10 D`` (not at a resonance of the free structure that the elements suppress).  Tiny on
    lumped chains (``(omega h)^2``), it is large where a stiff, heavily damped DOF is time-stepped next to a
    soft structure (a finite-element node with Rayleigh damping: the warped damping force ``beta K_dd`` is
    amplified by the condensed compliance); there the discrete periodic solution is far from the continuous
    one, and the remedy is more steps (the estimate falls like ``h^2``).  The element laws are left out
    (first-order, linear part only); the bound catches gross under-resolution, not the percent-level step
    error of a deliberately coarse grid: that is the a-posteriori estimate ``time_discretisation`` of
    :mod:`mshbm.route.refine` (step refinement), which :func:`mshbm.solve` adds.
``undamped_resonance`` (gating)
    When no element acts on the solution (no element, friction with ``mu F_N = 0``, contacts that never
    close), the response is that of the linear structure.  If a forced harmonic ``k omega`` lies within the
    discretisation error of an undamped natural frequency ``omega_r`` (``|(k omega / omega_r)^2 - 1| <= eps``
    with ``eps = 10 (k omega h)^2`` for time stepping, ``1e-9`` for HBM and DLFT), no resolved periodic
    solution exists (the discrete answer grows as ``1/eps``, e.g. as ``N^2``).  Value: the smallest relative
    detuning; bound: ``eps``; passes when the value exceeds it.  Not evaluated above :data:`MAX_EIG_DOFS`.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..condensation import solve_dynamic
from ..fourier import to_complex
from .kernels import ACTS
from .record import Check

__all__ = ["TIME_DISCRETISATION_BOUND", "MAX_EIG_DOFS", "time_discretisation", "undamped_resonance"]

#: gating bound of ``time_discretisation``
TIME_DISCRETISATION_BOUND = 0.1
#: largest system for which undamped natural frequencies are computed (dense eigenproblem)
MAX_EIG_DOFS = 2000


def time_discretisation(problem, sol, system, omega, stepper, D, cert):
    """Append ``time_warping`` to ``cert`` (module docstring); nothing without time-stepped DOFs or
    harmonics."""
    T = np.asarray(problem.partition().time, dtype=np.int64)
    qh = np.asarray(sol.q_hat, dtype=float)
    if T.size == 0 or qh.shape[0] < 3:
        return
    X = to_complex(qh)  # (n_h + 1, n): X_k = xc_k - i xs_k
    theta, h = float(stepper.theta), float(stepper.h)
    sub = (lambda A: A.tocsr()[T][:, T].toarray()) if sp.issparse(system.M) else \
        (lambda A: np.asarray(A)[np.ix_(T, T)])
    # the time-stepped subsystem's own M and C: MS-HBM's mass-decoupled system for a consistent mass (its linear
    # solves take and return the user's coordinates), else the system's
    tsys = problem.integrated_system
    MT, CT = sub(tsys.M), sub(tsys.C)
    Fk = to_complex(system.forcing_hat(X.shape[0] - 1, omega))  # (n_h + 1, n) forcing harmonics
    worst, k_worst, linear_max = 0.0, None, 0.0
    for k in range(1, X.shape[0]):
        XT = X[k, T]
        if not np.any(np.abs(XT) > 1e-9 * D):
            continue
        w = k * omega
        z = np.exp(1j * w * h)
        iwt = (z - 1.0) / (h * (1.0 - theta + theta * z))
        r = np.zeros(system.n, dtype=complex)
        r[T] = ((iwt - 1j * w) * CT + (iwt ** 2 + w ** 2) * MT) @ XT  # dH_k X_T (K cancels)
        if not np.any(r):
            continue
        rhs = np.stack([r, Fk[k]], axis=1)  # the warping error and the linear structure's own response
        try:
            # the method's own factorisations (MS-HBM: its condensation; r vanishes off T), else a solve of H_k
            cols = [problem.linear_solve(k, rhs[T, 0], False), problem.linear_solve(k, rhs[T, 1], True)]
            if cols[0] is not None and cols[1] is not None:
                sol_k = np.stack(cols, axis=1)
            else:  # dense, banded LAPACK or sparse LU
                sol_k = solve_dynamic(system.M, system.C, system.K, w, rhs)
        except (RuntimeError, np.linalg.LinAlgError):  # an undamped resonance: undamped_resonance decides
            linear_max = np.inf
            continue
        delta = sol_k[:, 0]
        linear_max = max(linear_max, float(np.max(np.abs(sol_k[:, 1]))))
        e = float(np.max(np.abs(delta))) / D
        if np.isfinite(e) and e > worst:
            worst, k_worst = e, k
    # the estimate propagates through the linear structure; where that structure alone would respond far
    # more than the solution does (the elements dominate: a stuck friction DOF at a resonance of the free
    # structure), it is not a model of the solution's sensitivity and does not gate
    applies = np.isfinite(linear_max) and linear_max <= 10.0 * D
    cert.checks.append(Check("time_warping", worst, TIME_DISCRETISATION_BOUND,
                             bool(worst <= TIME_DISCRETISATION_BOUND) or not applies, applies,
                             "first-order relative error of the response from the frequency warping of the "
                             f"time-stepped DOFs' M and C (largest at harmonic {k_worst}; h^2 convergence: "
                             "more steps reduce it)" + ("" if applies else
                                                        "; not gating: the linear structure alone responds more "
                                                        "than 10 times the solution (the elements dominate)")))


def undamped_resonance(system, omega, h, fourier_all_dofs, els, cert, terms):
    """Append ``undamped_resonance`` to ``cert`` (module docstring) when no element acts on the solution
    (``terms``: :func:`mshbm.certificate.kernels.element_terms`' table); ``fourier_all_dofs``: the
    problem's declaration of that name (no time step bounds ``eps``)."""
    # a bounded (friction) law acts whenever its bound is positive, another one where lambda != 0
    if any(e.acts if e.bounded else bool(terms[j, ACTS]) for j, e in enumerate(els)):
        return
    n = system.n
    if n > MAX_EIG_DOFS:
        cert.checks.append(Check("undamped_resonance", None, None, True, False,
                                 f"not evaluated: {n} DOFs > {MAX_EIG_DOFS}"))
        return
    K, M, C = system.dense("K"), system.dense("M"), system.dense("C")
    w2, Phi = sla.eigh(K, M)
    c_modal = np.sum(Phi * (C @ Phi), axis=0)  # diag(Phi^T C Phi) by one matrix product (einsum's loop: O(n^3) unblocked)
    scaleK = max(float(np.max(np.abs(w2), initial=0.0)), 1e-300)
    fh = system.f_hat_at(omega)
    n_f = (fh.shape[0] - 1) // 2
    worst, worst_bound, where = np.inf, 0.0, ""
    for k in range(1, n_f + 1):
        fk = np.hypot(Phi.T @ fh[2 * k - 1], Phi.T @ fh[2 * k])
        if not np.any(fk):
            continue
        eps = 1e-9 if fourier_all_dofs else max(1e-9, 10.0 * (k * omega * h) ** 2)
        for r in range(n):
            if fk[r] <= 1e-12 * fk.max() or w2[r] <= 1e-14 * scaleK:
                continue
            wr = np.sqrt(w2[r])
            if abs(c_modal[r]) > 1e-12 * (w2[r] + wr):  # damped mode: bounded response
                continue
            det = abs((k * omega) ** 2 / w2[r] - 1.0)
            if det - eps < worst - worst_bound or worst == np.inf:
                worst, worst_bound = det, eps
                where = f"harmonic {k} of the forcing, k*omega = {k * omega:.6g} rad/s, undamped mode at {wr:.6g} rad/s"
    if worst == np.inf:
        return
    ok = worst > worst_bound
    note = where if ok else (where + ": within the discretisation error of an undamped natural frequency and no "
                             "element acts, so no resolved periodic solution exists (add damping or move omega)")
    cert.checks.append(Check("undamped_resonance", worst, worst_bound, bool(ok), True, note))
