"""Closed forms for the bifurcation tests: the (1,1) orbit of the damped impact oscillator.

System (one DOF, unit mass, ``mshbm.chain([1], 1, 2 zeta, ...)`` with ``Contact(0, sigma, r)``)::

    x'' + 2 zeta x' + x = cos(omega t),   x <= sigma,   x'(t+) = -r x'(t-) at x = sigma

(Budd & Dux 1994; Bishop 1994; Nordmark 1991).  Derived here from the impact map, nothing copied.

Free flight
-----------
With ``G = 1 / (1 - omega^2 + 2 i zeta omega)`` the forced response is ``x_p(t) = Re(G e^{i omega t})``
(T-periodic, ``T = 2 pi / omega``).  After an impact at ``t0`` with approach velocity ``v > 0`` the
motion is ``x(t) = x_p(t) + h(t - t0)`` where ``h`` solves ``h'' + 2 zeta h' + h = 0`` from
``y0 = (sigma - x_p(t0), -r v - x_p'(t0))``: ``(h, h')(tau) = Phi_h(tau) y0`` with
``omega_d = sqrt(1 - zeta^2)`` and::

    Phi_h(tau) = e^{-zeta tau} [[c + zeta s / omega_d,  s / omega_d],
                                [-s / omega_d,           c - zeta s / omega_d]],  c, s = cos, sin(omega_d tau).

(1,1) orbit: one impact per period
----------------------------------
Next impact at ``t0 + T`` with the same ``v``.  Since ``x_p`` is T-periodic, with ``P = x_p(t0)``,
``P' = x_p'(t0)``, ``a = sigma - P`` and ``Phi = Phi_h(T) = [[p11, p12], [p21, p22]]``::

    p11 a + p12 (-r v - P') = a                  (position returns to sigma)
    p21 a + p22 (-r v - P') = v - P'             (approach velocity returns to v)

The first gives ``v = ((p11 - 1) a - p12 P') / (r p12)``; inserted in the second, with
``P = A cos(theta)``, ``P' = -A omega sin(theta)``, ``A = |G|``, ``theta = omega t0 + arg G``, it is
``alpha cos(theta) + beta sin(theta) = gamma`` (coefficients in :func:`orbit_11`), so
``theta = atan2(beta, alpha) +- arccos(gamma / sqrt(alpha^2 + beta^2))``: two (1,1) orbits (or none
when ``|gamma| > sqrt(alpha^2 + beta^2)``).  An orbit is admissible when ``v > 0`` and
``x < sigma`` between the impacts (checked on a fine grid by :func:`admissible`).

Stability: the impact map
-------------------------
``(t0, v) -> (t1, v1)`` (next impact time, next approach velocity).  With
``x(t; t0, v) = x_p(t) + [Phi_h(t - t0) y0(t0, v)]_1``::

    d(x, x')/dt0 = -A_h Phi_h(tau) y0 + Phi_h(tau) (-x_p'(t0), -x_p''(t0)),   A_h = [[0, 1], [-1, -2 zeta]]
    d(x, x')/dv  = Phi_h(tau) (0, -r)

and the implicit function theorem on ``x(t1) = sigma`` (``x'(t1-) = v1 > 0``)::

    dt1 = -(dx/dt0 dt0 + dx/dv dv) / v1,     dv1 = x''(t1-) dt1 + dx'/dt0 dt0 + dx'/dv dv

with ``x''(t1-) = cos(omega t1) - 2 zeta v1 - sigma``.  The eigenvalues of this 2x2 Jacobian ``J``
are the orbit's Floquet multipliers (the stroboscopic map over one period is conjugate to the impact
map; for one DOF the monodromy of the flow is 2x2, the same two values, no extra multiplier; the exact
solver's extended state ``(q, u, 1, cos, sin)`` adds only the forcing oscillator's trivial ones, which
:mod:`mshbm.methods.exact` drops by taking the ``2n x 2n`` block).  Check (verified in the tests):
``det J = r^2 e^{-2 zeta T}``: the flow contracts areas by ``e^{-2 zeta T}`` (Liouville) and the
impact's saltation matrix ``S = R + (f+ - R f-) c^T / (c^T f-)`` with ``R = diag(1, -r)``,
``c = (1, 0)``, ``f- = (v, a-)``, ``f+ = (-r v, a+)`` is ``[[-r, 0], [(a+ + r a-)/v, -r]]``, of
determinant ``r^2``.

Period doubling: ``det(J + I) = 1 + tr J + det J = 0`` (an eigenvalue ``-1``), solved for ``omega``
along the stable (1,1) branch by :func:`omega_pd`.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

#: parameters of the tests: damping ratio, gap, restitution
ZETA, SIGMA, R = 0.05, 0.1, 0.8


def system(zeta=ZETA, sigma=SIGMA, r=R, **contact):
    """The oscillator as an :class:`mshbm.System`."""
    from mshbm import Contact, chain

    return chain([1.0], 1.0, 2.0 * zeta, forcing=[{"dof": 0, "amplitude": 1.0}],
                 elements=[Contact(0, sigma, r, **contact)], name="impact-oscillator")


def _G(omega, zeta):
    return 1.0 / (1.0 - omega ** 2 + 2j * zeta * omega)


def forced(t, omega, zeta):
    """``x_p, x_p', x_p''`` at ``t``."""
    z = _G(omega, zeta) * np.exp(1j * omega * np.asarray(t, dtype=float))
    return z.real, (1j * omega * z).real, (-omega ** 2 * z).real


def phi_h(tau, zeta):
    """Flow ``Phi_h(tau)`` of ``h'' + 2 zeta h' + h = 0`` (shape (2, 2), or (..., 2, 2))."""
    wd = np.sqrt(1.0 - zeta ** 2)
    tau = np.asarray(tau, dtype=float)
    E, c, s = np.exp(-zeta * tau), np.cos(wd * tau), np.sin(wd * tau)
    out = np.empty(tau.shape + (2, 2))
    out[..., 0, 0] = E * (c + zeta * s / wd)
    out[..., 0, 1] = E * s / wd
    out[..., 1, 0] = -E * s / wd
    out[..., 1, 1] = E * (c - zeta * s / wd)
    return out


def free_flight(t, t0, v, omega, zeta=ZETA, sigma=SIGMA, r=R):
    """``x(t), x'(t)`` after the impact at ``t0`` with approach velocity ``v``."""
    P, Pd, _ = forced(t0, omega, zeta)
    y0 = np.array([sigma - P, -r * v - Pd])
    xp, xpd, _ = forced(t, omega, zeta)
    y = phi_h(np.asarray(t, dtype=float) - t0, zeta) @ y0
    return xp + y[..., 0], xpd + y[..., 1]


def orbit_11(omega, zeta=ZETA, sigma=SIGMA, r=R):
    """Both (1,1) orbits at ``omega``: list of ``(t0, v)`` (impact time in ``[0, T)``, approach velocity).

    Empty when none exists; admissibility is not checked (see :func:`admissible`).
    """
    T = 2.0 * np.pi / omega
    G = _G(omega, zeta)
    A, psi = abs(G), np.angle(G)
    (p11, p12), (p21, p22) = phi_h(T, zeta)
    # v = ((p11 - 1) a - p12 P') / (r p12) with a = sigma - A cos(th), P' = -A omega sin(th):
    #   v = v0 + vc cos(th) + vs sin(th)
    v0 = (p11 - 1.0) * sigma / (r * p12)
    vc = -(p11 - 1.0) * A / (r * p12)
    vs = A * omega / r
    # second equation: p21 a - p22 r v - p22 P' - v + P' = 0
    #   p21 (sigma - A cos) - (1 + p22 r) v + (1 - p22) (-A omega sin) = 0
    k = 1.0 + p22 * r
    const = p21 * sigma - k * v0
    alpha = -p21 * A - k * vc               # coefficient of cos(th)
    beta = -k * vs - (1.0 - p22) * A * omega  # coefficient of sin(th)
    gamma = -const
    rho = np.hypot(alpha, beta)
    if abs(gamma) > rho:
        return []
    base, d = np.arctan2(beta, alpha), np.arccos(gamma / rho)
    out = []
    for th in (base + d, base - d):
        v = v0 + vc * np.cos(th) + vs * np.sin(th)
        t0 = ((th - psi) / omega) % T
        out.append((float(t0), float(v)))
    return out


def admissible(omega, t0, v, zeta=ZETA, sigma=SIGMA, r=R, n=4001, margin=1e-9):
    """True when ``v > 0`` and the free flight stays below ``sigma`` between the impacts."""
    if v <= 0:
        return False
    T = 2.0 * np.pi / omega
    tt = np.linspace(t0, t0 + T, n)[1:-1]
    x, _ = free_flight(tt, t0, v, omega, zeta, sigma, r)
    return bool(np.max(x) < sigma - margin)


def stable_orbit(omega, zeta=ZETA, sigma=SIGMA, r=R):
    """The admissible (1,1) orbit with the smaller largest multiplier modulus: ``(t0, v)`` or ``None``."""
    cands = [(t0, v) for t0, v in orbit_11(omega, zeta, sigma, r) if admissible(omega, t0, v, zeta, sigma, r)]
    if not cands:
        return None
    return min(cands, key=lambda p: np.max(np.abs(multipliers(omega, *p, zeta, sigma, r))))


def impact_map_jacobian(omega, t0, v, zeta=ZETA, sigma=SIGMA, r=R):
    """``d(t1, v1) / d(t0, v)`` of the impact map at a (1,1) orbit (see the module docstring)."""
    T = 2.0 * np.pi / omega
    P, Pd, Pdd = forced(t0, omega, zeta)
    y0 = np.array([sigma - P, -r * v - Pd])
    Ph = phi_h(T, zeta)
    Ah = np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]])
    d_t0 = -Ah @ Ph @ y0 + Ph @ np.array([-Pd, -Pdd])
    d_v = Ph @ np.array([0.0, -r])
    t1 = t0 + T
    x1, v1 = free_flight(t1, t0, v, omega, zeta, sigma, r)
    acc = np.cos(omega * t1) - 2.0 * zeta * v1 - x1
    dt1 = -np.array([d_t0[0], d_v[0]]) / v1
    dv1 = acc * dt1 + np.array([d_t0[1], d_v[1]])
    return np.array([dt1, dv1])


def multipliers(omega, t0, v, zeta=ZETA, sigma=SIGMA, r=R):
    """Eigenvalues of :func:`impact_map_jacobian` (sorted by real part)."""
    return np.sort_complex(np.linalg.eigvals(impact_map_jacobian(omega, t0, v, zeta, sigma, r)))


def amplitude(omega, t0, v, zeta=ZETA, sigma=SIGMA, r=R, n=20001):
    """``(max - min) / 2`` of ``x`` over the period (max = ``sigma`` at the impact; min on a fine grid,
    polished by the zero of ``x'``)."""
    T = 2.0 * np.pi / omega
    tt = np.linspace(t0, t0 + T, n)
    x, xd = free_flight(tt, t0, v, omega, zeta, sigma, r)
    k = int(np.argmin(x))
    lo, hi = tt[max(k - 1, 0)], tt[min(k + 1, n - 1)]
    f = lambda s: free_flight(s, t0, v, omega, zeta, sigma, r)[1]
    tm = brentq(f, lo, hi, xtol=1e-15) if f(lo) * f(hi) < 0 else tt[k]
    xmin = float(free_flight(tm, t0, v, omega, zeta, sigma, r)[0])
    return 0.5 * (max(sigma, float(np.max(x))) - xmin)


def pd_test_function(omega, zeta=ZETA, sigma=SIGMA, r=R):
    """``det(J + I)`` on the stable-side (1,1) orbit: zero at period doubling (an eigenvalue -1)."""
    p = stable_orbit(omega, zeta, sigma, r)
    if p is None:
        return np.nan
    J = impact_map_jacobian(omega, *p, zeta, sigma, r)
    return float(np.linalg.det(J + np.eye(2)))


def omega_pd(lo=2.4, hi=2.5, zeta=ZETA, sigma=SIGMA, r=R):
    """Period-doubling frequency of the (1,1) orbit in ``[lo, hi]``: the root of :func:`pd_test_function`.

    For the test parameters (``zeta = 0.05, sigma = 0.1, r = 0.8``): ``omega_PD = 2.4567153560435933``
    (multipliers there ``-1`` and ``-0.495572``; impact phase ``t0 = 1.214223``, approach velocity
    ``v = 0.358195``, amplitude 0.317083).  Below it the multipliers form a complex pair of modulus
    ``r e^{-zeta T}`` (0.70 at 0.99 omega_PD) that meets on the negative real axis at omega ~ 2.44;
    above it one real multiplier is below -1 (-1.573 at 1.01 omega_PD).  Undamped with
    ``sigma = 0, r = 0.8`` the same formulas give the Budd & Dux values of tests/unit/test_stability.py.
    """
    return brentq(lambda w: pd_test_function(w, zeta, sigma, r), lo, hi, xtol=1e-13)


def omega_grazing(lo=2.5, hi=4.0, zeta=ZETA, sigma=SIGMA):
    """Grazing frequency above resonance: the linear response's amplitude ``|G|`` equals ``sigma``
    (``3.315795717103483`` for the test parameters); the (1,1) orbit's impact velocity vanishes there."""
    return brentq(lambda w: abs(_G(w, zeta)) - sigma, lo, hi, xtol=1e-14)
