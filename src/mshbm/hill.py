"""Hill's method: Floquet multipliers of an HBM solution from the harmonic-balance Jacobian.

What it answers
---------------
HBM (:mod:`mshbm.methods.hbm`) solves the system with the *regularised* laws of
:mod:`mshbm.elements` (``arctan`` friction, penalty contact).  Hill's method gives the stability of
that periodic solution **of the regularised system**, not of the set-valued (nonsmooth) one: a
stiff penalty or a steep ``arctan`` has its own fast dynamics, and the multipliers converge to
those of the nonsmooth flow only in the limit (and not uniformly: Newton's impact law has no
penalty counterpart for ``e_N < 1``).  Results are labelled :data:`HILL` so that they are never
mistaken for the exact event-driven multipliers of :mod:`mshbm.stability`.

Linearisation in the frequency domain
-------------------------------------
With ``q*(t)`` the HBM solution of ``M q'' + C q' + K q = f_ex(t) + f_nl(q, q')``, a perturbation
``y = e^{s t} p(t)`` with ``p`` T-periodic (``T = 2 pi / omega``) solves the linearised equation
``M y'' + (C - D_u(t)) y' + (K - D_q(t)) y = 0``, ``D_q = df_nl/dq``, ``D_u = df_nl/du`` along
``q*``, iff (Galerkin on the harmonics ``0..n_h``, the AFT samples of HBM)::

    (s^2 M_h + s C_h + H_h) p_hat = 0,
    M_h = I (x) M,
    C_h = 2 Om (x) M + I (x) C - E diag(D_u) V,
    H_h = Om^2 (x) M + Om (x) C + I (x) K - E diag(D_q) V - E diag(D_u) V Om,

with ``Om`` the derivative matrix of :func:`mshbm.fourier.derivative`, ``E``/``V`` the DFT and
inverse-DFT matrices of the ``N_s`` AFT samples and ``(x)`` the Kronecker product on the
harmonic-major coefficient layout.  ``H_h`` is exactly the Jacobian of the (uncondensed) HBM
residual.  The quadratic eigenvalue problem is linearised (companion form, size
``2 n (2 n_h + 1)``) and solved densely, so the cost grows like ``(n n_h)^3``: the function
refuses more than :data:`MAX_SIZE` coefficients ``n (2 n_h + 1)`` (a 3000-square eigenproblem).

Which eigenvalues
-----------------
The truncated problem has ``2 n (2 n_h + 1)`` eigenvalues; the Floquet exponents are ``2 n`` of them,
each family ``s + i k omega`` (``k`` integer) describing one multiplier ``mu = exp(s T)``.  The copies
far from ``k = 0`` are polluted by the truncation.  Filters (``filter=``):

* ``"symmetric"`` (default; Lazarus & Thomas 2010): the eigenvector of the reliable copy is centred
  on the harmonic 0: its weighted mean harmonic ``sum_k k |P_k|^2 / sum_k |P_k|^2`` (complex
  harmonics ``k = -n_h..n_h``) is the smallest in modulus;
* ``"imag"``: the copy with the smallest ``|Im s|`` (e.g. NLvib).

Eigenvalues whose copies ``s +- i omega`` are not in the spectrum (within ``COPY_TOL omega``) are
spurious (truncation artefacts; e.g. the stiff real eigenvalues of a steep ``arctan`` in stick) and
are ranked after all others.  The distance ``d`` of a chosen exponent's copies to the nearest
eigenvalue estimates its truncation error ``e = |mu| T d``; :func:`assess_hbm` decides "stable" only
when every ``|mu| + e < 1``, "unstable" when some ``|mu| - e > 1`` (margins of :data:`HILL_TOL`).  Without
that check the 2n most "symmetric" eigenvalues of a friction chain with a steep ``arctan`` can all be
spurious real ones (multipliers ~ 0); with it, enough harmonics give multipliers close to those of the
exact nonsmooth flow, and too few give a spectrum that is reported as not converged.

Both are followed by a greedy choice that skips further copies of a family already taken
(``|s - s_j - i k omega| <= FAMILY_TOL omega``, ``k != 0``, or multipliers closer than 4 times the
sum of their error estimates ``|mu| T d``, which also merges the near-double spurious eigenvalues of a
poorly converged spectrum; needed where ``Im s`` of
two copies tie at ``+-omega/2``, i.e. negative real multipliers near a period doubling).  When fewer
than ``2 n`` families remain (a double multiplier, e.g. a linear oscillator forced at twice its
damped frequency), the best-scored skipped eigenvalues fill the set.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from ._deferred import cKDTree

from . import fourier
from .elements import regularised_forces  # the regularised-force Jacobian: imported in this one place only
from .errors import InputError
from .methods.hbm_regularisation import resolve, unresolved
from .options import aft_steps

__all__ = ["hill_matrices", "hill_exponents", "hill_multipliers", "assess_hbm", "HILL", "MAX_SIZE"]

HILL = "hill (HBM, regularised laws: stability of the regularised system)"
#: largest number of coefficients ``n (2 n_h + 1)`` for the dense eigenvalue problem
MAX_SIZE = 1500
#: a verdict needs ``| max|mu| - 1 | >`` this, and more than the estimated multiplier error
HILL_TOL = 1e-6
#: eigenvalues without a copy ``s +- i omega`` within ``COPY_TOL omega`` are chosen last (spurious)
COPY_TOL = 1e-2
#: eigenvalues ``s``, ``s_j`` with ``|s - s_j - i k omega| <= FAMILY_TOL omega`` (``k != 0``) are copies
FAMILY_TOL = 1e-3


def _local(system):
    dofs = system.nonlinear_dofs
    pos = {int(d): i for i, d in enumerate(dofs)}
    return dofs, [pos[el.dof] for el in system.elements]


def hill_matrices(system, omega, q_hat, steps=None):
    """``(M_h, C_h, H_h)`` of the quadratic eigenvalue problem (module docstring).

    Parameters
    ----------
    system : System
    omega : float
    q_hat : ndarray, shape (2 n_h + 1, n)
        Fourier coefficients of the periodic solution (all DOFs).
    steps : int, optional
        AFT samples ``N_s`` (default: :func:`mshbm.options.aft_steps`, those of HBM).

    Returns
    -------
    M_h, C_h, H_h : ndarray, shape (n (2 n_h + 1), n (2 n_h + 1))
    """
    q_hat = np.asarray(q_hat, dtype=float)
    nc, n = q_hat.shape
    n_h = (nc - 1) // 2
    if n != system.n or nc != 2 * n_h + 1:
        raise InputError("q_hat", f"must have shape (2 n_h + 1, {system.n}), got {q_hat.shape}")
    if n * nc > MAX_SIZE:
        raise InputError("harmonics", f"Hill matrix of {n * nc} coefficients exceeds {MAX_SIZE} (dense eigenproblem)")
    if steps is None:
        steps = aft_steps(n_h)
    Ns = int(steps)
    if unresolved(system):  # defaults of the regularised laws: those HBM uses at this frequency
        system = resolve(system, omega)[0]
    M, C, K = system.dense("M"), system.dense("C"), system.dense("K")
    I = np.eye(nc)
    Om = fourier.derivative(I, omega)
    Mh = np.kron(I, M)
    Ch = np.kron(2.0 * Om, M) + np.kron(I, C)
    Hh = np.kron(Om @ Om, M) + np.kron(Om, C) + np.kron(I, K)
    if system.elements:
        E, V = fourier.dft_matrix(Ns, n_h), fourier.idft_matrix(Ns, n_h)
        dofs, ldof = _local(system)
        q = V @ q_hat[:, dofs]
        u = V @ fourier.derivative(q_hat[:, dofs], omega)
        _, _, dfdq, dfdu = regularised_forces(system.elements, ldof, q, u)
        for i, d in enumerate(dofs):
            P = np.zeros((n, n))
            P[d, d] = 1.0
            Dq = (E * dfdq[:, i]) @ V
            Du = (E * dfdu[:, i]) @ V
            Ch -= np.kron(Du, P)
            Hh -= np.kron(Dq + Du @ Om, P)
    return Mh, Ch, Hh


def _centroid(vecs, nc, n):
    """Mean harmonic ``sum k |P_k|^2 / sum |P_k|^2`` of eigenvectors (columns, real-basis coefficients)."""
    X = vecs.reshape(nc, n, -1)
    n_h = (nc - 1) // 2
    w0 = np.sum(np.abs(X[0]) ** 2, axis=0)
    num = np.zeros(X.shape[2])
    den = w0.copy()
    for k in range(1, n_h + 1):
        c, s = X[2 * k - 1], X[2 * k]
        wp = np.sum(np.abs(c - 1j * s) ** 2, axis=0) / 4.0  # |P_k|^2
        wm = np.sum(np.abs(c + 1j * s) ** 2, axis=0) / 4.0  # |P_-k|^2
        num += k * (wp - wm)
        den += wp + wm
    return num / np.maximum(den, 1e-300)


def hill_exponents(system, omega, q_hat, steps=None, filter="symmetric"):
    """The ``2 n`` Floquet exponents ``s`` chosen by ``filter`` (see the module docstring).

    Returns
    -------
    s : complex ndarray, shape (2 n,)
    info : dict
        ``all`` (every eigenvalue), ``score`` (the filter's score of each chosen exponent).
    """
    if filter not in ("symmetric", "imag"):
        raise InputError("filter", f"must be 'symmetric' or 'imag', got {filter!r}")
    Mh, Ch, Hh = hill_matrices(system, omega, q_hat, steps)
    N = Mh.shape[0]
    nc = np.asarray(q_hat).shape[0]
    n = system.n
    # companion form of s^2 M + s C + H: z = (p, s p), A z = s z with M_h^-1 = I (x) M^-1 (M is positive definite)
    Minv = np.kron(np.eye(nc), np.linalg.inv(system.dense("M")))
    A = np.block([[np.zeros((N, N)), np.eye(N)], [-Minv @ Hh, -Minv @ Ch]])
    lam, vec = sla.eig(A)
    ok = np.isfinite(lam)
    lam, vec = lam[ok], vec[:N, ok]
    if filter == "symmetric":
        score = np.abs(_centroid(vec, nc, n))
    else:
        score = np.abs(lam.imag)
    # copy check: a converged exponent s has its copies s +- i omega in the spectrum too
    tree = cKDTree(np.column_stack([lam.real, lam.imag]))
    dp, _ = tree.query(np.column_stack([lam.real, lam.imag + omega]))
    dm, _ = tree.query(np.column_stack([lam.real, lam.imag - omega]))
    dcopy = np.minimum(dp, dm)
    order = np.lexsort((score, dcopy > COPY_TOL * omega))
    T = 2.0 * np.pi / omega
    with np.errstate(over="ignore"):
        mu_all = np.exp(lam * T)
    mu_err = np.abs(mu_all) * T * dcopy  # truncation error estimate of each multiplier
    scale = max(1.0, float(np.max(np.abs(lam.real)))) if lam.size else 1.0
    chosen = []
    for i in order:
        if len(chosen) == 2 * n:
            break
        s = lam[i]
        dup = False
        for j in chosen:
            k = round((s.imag - lam[j].imag) / omega)
            # same family: s = s_j + i k omega, k != 0, within rounding or the copies' own disagreement
            # (which grows with |k|: compared on the multipliers, 4 times their error estimates)
            # (any k: a poorly converged spectrum also has near-double spurious eigenvalues)
            if (k != 0 and abs(s - lam[j] - 1j * k * omega) <= max(1e-8 * scale, FAMILY_TOL * omega)) \
                    or abs(mu_all[i] - mu_all[j]) <= 4.0 * (mu_err[i] + mu_err[j]):
                dup = True
                break
        if not dup:
            chosen.append(i)
    if len(chosen) < 2 * n:  # a multiple multiplier (two families with the same exponent mod i omega)
        rest = [i for i in order if i not in set(chosen)]
        chosen += rest[:2 * n - len(chosen)]
    s = lam[chosen]
    return s, {"all": lam, "score": score[chosen], "copy_distance": dcopy[chosen],
               "multiplier_error": mu_err[chosen]}


def hill_multipliers(system, omega, q_hat, steps=None, filter="symmetric", full_output=False):
    """Floquet multipliers ``exp(s T)`` of the ``2 n`` chosen exponents, sorted by decreasing modulus.

    With ``full_output``: ``(mu, error)`` where ``error[i] = |mu_i| T d_i`` estimates the truncation
    error of ``mu_i`` from the distance ``d_i`` between the exponent's copy ``s_i +- i omega`` and the
    nearest eigenvalue (zero for an exact Hill matrix).
    """
    s, info = hill_exponents(system, omega, q_hat, steps, filter)
    mu = np.exp(s * (2.0 * np.pi / omega))
    order = np.argsort(-np.abs(mu), kind="stable")
    if full_output:
        return mu[order], info["multiplier_error"][order]
    return mu[order]


def assess_hbm(system, sol, filter="symmetric"):
    """Set the stability fields of an HBM solution ``sol`` from Hill's method (in place) and return it.

    ``stability_method`` is :data:`HILL`: the verdict is that of the *regularised* system HBM solved.
    ``stable`` is ``None`` when the solve failed, or a multiplier is within its estimated error (at least
    :data:`HILL_TOL`) of the unit circle; ``info["stability"]["multiplier_error"]`` holds the estimates.
    """
    from .stability import _set, _verdict

    if not sol.success:
        return _set(sol, None, None, "none: the solve did not converge", "no converged periodic solution to analyse")
    try:
        mu, err = hill_multipliers(system, sol.omega, sol.q_hat, sol.steps, filter, full_output=True)
    except (InputError, np.linalg.LinAlgError, ValueError) as exc:
        return _set(sol, None, None, "none: Hill's method failed", f"Hill's method failed: {type(exc).__name__}: {exc}")
    rho = float(np.max(np.abs(mu)))
    a = np.abs(mu)
    if np.all(a + err < 1.0 - HILL_TOL):
        stable, reason = True, ""
    elif np.any(a - err > 1.0 + HILL_TOL):
        stable, reason = False, ""
    elif np.all(err <= HILL_TOL):
        stable, reason = _verdict(rho, HILL_TOL)
    else:
        stable = None
        reason = (f"Hill's method is not converged enough to decide: largest modulus {rho:.6f}, estimated "
                  f"multiplier errors up to {float(np.max(err)):.2g} (copies of the Floquet exponents disagree); "
                  f"increase harmonics")
    return _set(sol, mu, stable, HILL, reason, tolerance=HILL_TOL, filter=filter, multiplier_error=[float(e) for e in err],
                note="multipliers of the regularised system (HBM laws), not of the nonsmooth flow")
