"""Helpers shared by the method modules (initial guesses, padding, the linear response)."""
from __future__ import annotations

import numpy as np

from .. import condensation, fourier
from ..errors import InputError
from ..validate import check_guess, check_guess_values

__all__ = ["linear_response", "pad_hat", "guess_parts", "complement", "failed_parts"]


def failed_parts(t, N, hat_shape, time_dofs, n_el, harmonics, why):
    """``solution_parts`` of a method that cannot form its solution at the given unknowns (e.g. the
    event-driven flow fails from them): ``t`` as given, every series NaN (``q_hat`` of shape ``hat_shape``,
    ``q_time``/``u_time`` (N + 1, len(time_dofs)), ``lam`` (N + 1, n_el), ``impulses`` (N, n_el)), which the
    driver reports as a failure, and ``info["failure"] = why``."""
    nt = len(time_dofs)
    return dict(t=t, q_hat=np.full(hat_shape, np.nan), time_dofs=time_dofs, q_time=np.full((N + 1, nt), np.nan),
                u_time=np.full((N + 1, nt), np.nan), lam=np.full((N + 1, n_el), np.nan),
                impulses=np.full((N, n_el), np.nan), harmonics=harmonics, info={"failure": why})


def complement(n, idx):
    """Sorted indices of ``range(n)`` not in ``idx`` (as ``np.setdiff1d(np.arange(n), idx)``, in O(n))."""
    keep = np.ones(n, dtype=bool)
    keep[np.asarray(idx, dtype=np.int64)] = False
    return np.flatnonzero(keep)


def pad_hat(x_hat, n_h):
    """Truncate or zero-pad coefficients (2 n_h' + 1, ...) to ``n_h`` harmonics."""
    x_hat = np.asarray(x_hat, dtype=float)
    out = np.zeros((2 * n_h + 1,) + x_hat.shape[1:])
    m = min(out.shape[0], x_hat.shape[0])
    out[:m] = x_hat[:m]
    return out


def linear_response(system, omega, n_h):
    """Steady state of the linear structure without elements, ``q_hat`` shape (2 n_h + 1, n).

    Harmonics whose dynamic stiffness is singular (undamped resonance) are set to zero.
    """
    F = fourier.to_complex(system.forcing_hat(n_h, omega))
    Z = np.zeros_like(F)
    for k in range(n_h + 1):
        if not np.any(F[k]):
            continue
        try:  # dense, banded LAPACK or sparse LU (mshbm.condensation.solve_dynamic)
            x = condensation.solve_dynamic(system.M, system.C, system.K, k * omega, F[k])
        except (np.linalg.LinAlgError, RuntimeError):
            continue
        if np.all(np.isfinite(x)):
            Z[k] = x
    return fourier.from_complex(Z)


def guess_parts(guess, system, omega, n_h, states=True):
    """Normalise a user guess to ``(q_hat (2n_h+1, n), q0 (n,), u0 (n,))``.

    ``guess`` may be ``None``/``"linear"`` (linear response), ``"zero"``, a
    :class:`PeriodicSolution` (e.g. at a nearby frequency) or a dict with keys
    ``q_hat`` and optionally ``q0``, ``u0``.  ``states=False`` (the harmonic-balance methods, which
    use ``q_hat`` only): ``q0`` and ``u0`` are not derived from ``q_hat`` where the guess does not
    give them (``None`` then); given ones are validated as always.
    """
    from ..result import PeriodicSolution

    n = system.n
    checked = False  # q_hat already validated (the loop below then checks only q0, u0)
    if guess is None or (isinstance(guess, str) and guess == "linear"):
        q_hat = linear_response(system, omega, n_h)
        q0, u0 = None, None
    elif isinstance(guess, str) and guess == "zero":
        return np.zeros((2 * n_h + 1, n)), np.zeros(n), np.zeros(n)
    elif isinstance(guess, PeriodicSolution):
        if guess.n != n:
            raise InputError("guess", f"solution has {guess.n} DOFs, system has {n}")
        check_guess_values("guess", guess.q_hat)
        q_hat = pad_hat(guess.q_hat, n_h)  # truncated or zero-padded: the check above covers it
        checked = True
        q0, u0 = guess.initial_state()
    elif isinstance(guess, dict):
        guess = check_guess(guess, n)
        q_hat, q0, u0 = pad_hat(guess["q_hat"], n_h), guess["q0"], guess["u0"]
        checked = True
    else:
        raise InputError("guess", "must be None, 'linear', 'zero', a PeriodicSolution or a dict, got "
                                  f"{guess!r:.40}")
    if not states:  # q_hat validated above (dict, PeriodicSolution) or computed here; a dict's q0, u0 too
        if isinstance(guess, PeriodicSolution):
            check_guess_values("guess.q0", q0)
            check_guess_values("guess.u0", u0)
        return q_hat, q0, u0
    if q0 is None:
        q0 = q_hat[0] + q_hat[1::2].sum(axis=0)  # V(0)^T q_hat
    if u0 is None:  # fourier.derivative(q_hat, omega)[1::2].sum(axis=0): the cosine rows k omega xs_k
        k = (np.arange(1, (q_hat.shape[0] - 1) // 2 + 1) * omega)[:, None]
        u0 = (k * q_hat[2::2]).sum(axis=0)
    if guess is not None and not isinstance(guess, str):
        for key, a in (("guess.q_hat", q_hat), ("guess.q0", q0), ("guess.u0", u0))[int(checked):]:
            check_guess_values(key, a)
    return q_hat, q0, u0
