"""Physical scales of a periodic problem: how large a residual may be, in the problem's own units.

Newton's convergence test and the certificate (:mod:`mshbm.certificate`) measure every
residual row against a scale taken from the *problem* and the *current solution*, never
from the starting guess:

* force-like rows (harmonic balance, ``H q_hat - f_hat - f_nl_hat``) against the force
  scale ``F`` of the problem, :func:`force_scale`: the peak forcing on a DOF (for an
  unforced system the element force bounds ``mu F_N`` and the forces ``k gap`` that close
  a contact gap);
* displacement-like rows (periodicity ``q(T) - q(0)``, connectivity ``q_hat - FFT(q)``)
  against the size ``D`` of the solution, floored by ``D_0 = F / k_0`` (the static
  displacement of the force scale, ``k_0`` the largest diagonal entry of
  ``|K| + omega^2 M + omega |C|``);
* velocity-like rows against ``V = D max(1, omega)`` (:func:`velocity_scale`, ``omega`` in
  rad/s): ``omega D`` for fast motion; for ``omega < 1 rad/s`` ``D`` per second, which weighs
  the rows of Newton's line search as the unscaled residual did (the line search on these
  nonsmooth residuals is sensitive to the weights: on the paper's work-precision grid every solve
  converges with ``D max(1, omega)``, not every one with ``max(omega D, max |u|)``).  Only force units are required to drop out; a change of the *time* unit
  changes the weights below 1 rad/s.

Under a change of force unit (``M, C, K, f``, ``mu F_N``, ``k_c``, ``d_c`` all times
``s``) ``F`` scales by ``s`` and ``D_0`` is unchanged, so the scaled residual and thus
Newton's path and result are unit-independent.  Under positive homogeneity (forcing,
``mu F_N`` and gaps times ``s``) every scale is multiplied by ``s``.

Force-like rows are deliberately *not* scaled by the internal forces of the solution
(``|K q|``): near an undamped resonance these are arbitrarily large, and a huge garbage
response (the linear response at resonance, 1e16) would otherwise satisfy
``||R|| <= tol |K q|`` while violating the balance of forces by more than the forcing itself.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["diagonals", "force_scale", "stiffness_scale", "displacement_floor", "velocity_scale", "residual_norm"]


def _diag(A):
    return np.asarray(A.diagonal() if sp.issparse(A) else np.diag(np.asarray(A)), dtype=float)


def diagonals(system):
    """Diagonals ``(K_ii, M_ii, C_ii)`` of the system's matrices, each shape (n,), read-only (cached on
    the system)."""
    def compute():
        out = tuple(_diag(getattr(system, a)).copy() for a in "KMC")
        for d in out:
            d.flags.writeable = False
        return out

    return system.derived("diagonals", ("K", "M", "C"), compute)


def force_scale(system, penalty=False):
    """Force scale ``F`` (N) of ``system`` (see :func:`_force_scale`; cached on the system)."""
    return system.derived(f"force_scale_{bool(penalty)}", ("f_hat", "K", "elements"),
                          lambda: _force_scale(system, penalty))


def _force_scale(system, penalty=False):
    """Force scale ``F`` (N) of ``system``.

    ``F`` is the largest peak forcing of a DOF, ``max_i (|f0_i| + sum_k |f_k,i|)``.  Only
    for an unforced system it is taken from the elements, ``max(mu F_N, K_dd gap[, k_c gap
    if penalty])``, and a tiny positive number if these vanish too (a system at rest).

    Element forces are reactions to the forcing: a friction bound far above the forcing
    (friction that sticks) or a remote contact (``k_c gap = 8e9 N`` for a gap of 1e6 m)
    would otherwise loosen the test arbitrarily.

    Parameters
    ----------
    system : System
    penalty : bool
        Consider ``k_c gap`` of penalty contacts (HBM's regularised law) when unforced.
    """
    f = np.asarray(system.f_hat, dtype=float)
    peak = np.abs(f[0]) + np.hypot(f[1::2], f[2::2]).sum(axis=0) if f.shape[0] > 1 else np.abs(f[0])
    F = float(np.max(peak, initial=0.0))
    if F > 0.0:
        return F
    Kd = np.abs(diagonals(system)[0])
    for el in system.elements:
        F = max(F, el.force_scale(Kd, penalty))
    return F if F > 0.0 else 1e-300


def stiffness_scale(system, omega):
    """``k_0 = max_i (|K_ii| + omega^2 M_ii + omega |C_ii|)`` (N/m), > 0 since ``M`` is definite.

    Remembered per system and ``omega`` (up to :data:`_STIFFNESS_MEMO` frequencies; the same number)."""
    memo = system.derived("stiffness_scale", ("K", "M", "C"), dict)
    w = float(omega)
    k0 = memo.get(w)
    if k0 is None:
        Kd, Md, Cd = diagonals(system)
        k0 = float((np.abs(Kd) + w ** 2 * Md + w * np.abs(Cd)).max())
        if len(memo) >= _STIFFNESS_MEMO:
            memo.clear()
        memo[w] = k0
    return k0


#: frequencies per system whose :func:`stiffness_scale` is remembered (a continuation visits many)
_STIFFNESS_MEMO = 256


def displacement_floor(system, omega, F=None, penalty=False):
    """``D_0 = F / k_0`` (m): the smallest displacement scale of the problem."""
    if F is None:
        F = force_scale(system, penalty)
    return F / stiffness_scale(system, omega)


def velocity_scale(D, omega):
    """Scale ``V = D max(1, omega)`` (m/s) of velocity-like residual rows (see the module docstring)."""
    return D * max(1.0, float(omega))


def residual_norm(problem, x, R=None):
    """The scaled residual ``||R(x) / s(x)||_inf`` of Newton's convergence test (and of the certificate),
    ``s = problem.residual_scale(x)`` (``inf`` when ``R`` is not finite).

    ``problem`` is a method's problem (:func:`mshbm.build_problem`); ``R`` the residual at ``x`` when
    already evaluated.  A solution claimed converged with tolerance ``tol`` has ``residual_norm <= tol``.
    """
    from .solvers.newton import scaled_norm

    x = np.asarray(x, dtype=float)
    if R is None:
        R = problem.residual(x, jac=False)[0]
    return scaled_norm(R, problem.residual_scale(x))
