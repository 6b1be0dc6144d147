"""Kept sparse LU factorisations of the condensed dynamic stiffness ``H_EE(k omega)`` across nearby frequencies
(:class:`FactorReuse`, the context :func:`reuse_factors`), used by :class:`mshbm.condensation.Condensation` on its
SuperLU path (``H_k = K - (k omega)^2 M + i k omega C``, :mod:`mshbm.condensation`).
"""
from __future__ import annotations

import contextlib
import contextvars
import math

import numpy as np
import scipy.sparse as sp

__all__ = ["FactorReuse", "reuse_factors"]


class FactorReuse:
    """Sparse LU factorisations of ``H_EE(k omega)`` kept for condensations at nearby frequencies.

    Inside ``with reuse_factors() as reuse:`` every sparse :class:`Condensation` (SuperLU path) first solves
    ``H_EE(w) X = B`` (``w = k omega``; ``B = [F_E, H_ER]``, shape ``(n_E, n_R + 1)``) with the LU of
    ``H_EE(w_ref)`` kept from an earlier condensation of the same system (its matrices, by identity), DOF
    split and harmonic, by the splitting iteration::

        X_0 = H_ref^-1 B,    X_{i+1} = H_ref^-1 (B - dH X_i),    dH = (w_ref^2 - w^2) M_EE + i (w - w_ref) C_EE

    ``dH`` is formed from ``M_EE`` and ``C_EE`` alone, never as the difference of two dynamic stiffnesses, and
    the residual ``B - H X`` is never formed: on a fine mesh ``K_EE`` is so much stiffer than the low modes
    that rounding in ``H X`` is amplified by ``cond(H_EE)`` (a classical refinement step moves ``T`` far
    more than the difference between two LUs with different pivoting).
    The iteration converges when the spectral radius of ``H_ref^-1 dH`` is below 1: for ``|omega -
    omega_ref|`` small against the distance (in the damping's units) from ``k omega`` to the nearest
    eigenfrequency of ``E``, e.g. the ``omega +- 1e-6 omega`` of a finite-difference ``dR/domega``, the
    corrector iterations of a continuation step, and always at ``k = 0``.  A solve is accepted when the
    last correction is at most ``rtol`` of ``X`` column by column (the error left is then about
    ``rtol rho / (1 - rho)``, ``rho <= contraction``), or when the corrections stopped shrinking below
    ``noise`` (the rounding level of ``H_ref^-1 dH X``, which grows with ``|dH|``); otherwise, after ``max_iter`` iterations, a correction that shrank by less than
    ``contraction`` above ``noise``, or as soon as the observed contraction predicts more than ``max_iter``
    iterations to reach ``noise``, the condensation factorises afresh and that factorisation replaces the
    kept one.  A solve accepted after more than ``refactor_after`` iterations drops its kept LU, so the
    next condensation of that harmonic factorises afresh near its own frequency (on a large mesh one LU
    costs as much as many solves).

    Why it matters beyond speed: the condensation of an ill-conditioned ``H_EE`` is accurate only to
    ``~cond(H_EE) eps``, and a fresh LU at each ``omega``
    puts a *different* rounding error there, so ``R(x, omega)`` jumps at that level when ``omega`` moves by
    any amount: a central difference ``dR/domega`` over ``omega (1 +- 1e-6)`` is then noise of order one,
    and a continuation corrector (whose ``omega`` moves every iteration) stalls above its tolerance.  With
    one kept LU the condensation is a smooth (rational) function of ``omega``.

    Counters (``counters``): ``factorisations`` kept, ``refined`` solves accepted, ``refine_iterations``
    (LU solves in them), ``refine_failures``.  The banded and dense paths (``O(n_E)`` or small ``n_E``)
    factorise as before.
    """

    def __init__(self, rtol=1e-13, max_iter=40, contraction=0.7, noise=1e-10, refactor_after=20):
        self.rtol, self.max_iter, self.contraction = float(rtol), int(max_iter), float(contraction)
        self.refactor_after = int(refactor_after)
        self.noise = float(noise)
        self.kept = {}
        self.counters = {"factorisations": 0, "refined": 0, "refine_iterations": 0, "refine_failures": 0}

    def keep(self, key, k, w, solve, rcond):
        """Keep the solver ``solve(B) -> H_EE(w)^-1 B`` of harmonic ``k`` (``w = k omega``) of ``key``."""
        self.kept[(key, int(k))] = (float(w), solve, float(rcond))
        self.counters["factorisations"] += 1

    def refine(self, key, k, w, M, C, B):
        """``(X, rcond_ref)`` with ``H_EE(w) X = B`` by the splitting iteration above (``M, C``: the sparse
        ``M_EE, C_EE``), or ``None`` (no kept LU, or no convergence)."""
        entry = self.kept.get((key, int(k)))
        if entry is None:
            return None
        w_ref, solve, rcond = entry
        B = np.asarray(B, dtype=complex)
        X = solve(B)
        its = 1
        if w != w_ref:
            dH = sp.csr_matrix((w_ref ** 2 - w ** 2) * sp.csr_matrix(M, dtype=complex)
                               + (1j * (w - w_ref)) * sp.csr_matrix(C, dtype=complex))
            last = None
            while True:
                Xn = solve(B - dH @ X)
                its += 1
                corr = np.max(np.abs(Xn - X), axis=0)
                size = np.max(np.abs(Xn), axis=0)
                X = Xn
                c = float(np.max(corr / np.maximum(size, 1e-300)))
                if np.all(corr <= self.rtol * size):
                    break
                stalled = last is not None and c > self.contraction * last
                if stalled and c <= self.noise:
                    break  # the corrections stopped shrinking at rounding level: converged
                # the iterations still needed to reach the rounding level at the observed contraction
                hopeless = last is not None and not stalled and c > self.noise and \
                    its + math.log(self.noise / c) / math.log(c / last) > self.max_iter
                if not np.isfinite(c) or its > self.max_iter or stalled or hopeless:
                    self.counters["refine_iterations"] += its
                    self.counters["refine_failures"] += 1
                    return None
                last = c
        if not np.all(np.isfinite(X)):
            return None
        if its > self.refactor_after:  # slow: the next condensation of this harmonic factorises afresh
            del self.kept[(key, int(k))]
        self.counters["refined"] += 1
        self.counters["refine_iterations"] += its
        return X, rcond


_REUSE = contextvars.ContextVar("mshbm_condensation_reuse", default=None)


@contextlib.contextmanager
def reuse_factors(reuse=None):
    """Context in which sparse condensations reuse kept factorisations (:class:`FactorReuse`); yields it."""
    reuse = FactorReuse() if reuse is None else reuse
    token = _REUSE.set(reuse)
    try:
        yield reuse
    finally:
        _REUSE.reset(token)
