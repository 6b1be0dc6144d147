"""Exact references of the accuracy suite (workflow/scripts/stress/accuracy.py): closed forms that no method of
mshbm produced.

Notation: one DOF ``x`` (m), unit mass, ``x'' + 2 zeta x' + x = cos(omega t)`` (forcing amplitude 1, N) unless
stated; ``A = (max - min) / 2`` the amplitude (m).

``impact_11``
    The (1,1) orbit (one impact per period) of the oscillator with a stop ``x <= sigma`` and Newton's restitution
    ``e`` (``x'(t+) = -e x'(t-)``).  Between impacts ``x = x_p + h`` with the forced response
    ``x_p = Re(G e^{i omega t})``, ``G = 1 / (1 - omega^2 + 2 i zeta omega)``, and a free decay ``h`` from
    ``(sigma - x_p(t0), -e v - x_p'(t0))`` (``v > 0`` the approach velocity at the impact time ``t0``).  Returning to
    the stop after one period with the same ``v`` gives, with ``Phi = Phi_h(T)`` the free flow over a period and
    ``P = A_G cos(theta)``, ``P' = -A_G omega sin(theta)`` (``theta = omega t0 + arg G``)::

        p11 a + p12 (-e v - P') = a,     p21 a + p22 (-e v - P') = v - P',     a = sigma - P,

    linear in ``v``; eliminating ``v`` leaves ``alpha cos(theta) + beta sin(theta) = gamma`` (two roots).  For
    ``e = 0`` the first equation alone fixes ``theta`` and the second gives ``v``.  A root is admissible when
    ``v > 0``, the flight stays below the stop, and (``e = 0``) the force pulls the mass off the stop after the
    impact (``cos(omega t0) - sigma < 0``: no sticking phase).  The orbit reported is the admissible one whose
    impact map has the smaller spectral radius (the stable one when one is stable; ``stable`` says whether it is).
``coulomb``
    Den Hartog's oscillator ``x'' + 2 zeta x' + x + R sign(x') = cos(omega t)`` (``R = mu N``) in continuous motion
    (two slip reversals per period, no stop): the half-period symmetric orbit ``x(t + T/2) = -x(t)`` from the
    turning point ``(-X, 0)`` at ``t = 0`` with the forcing phase ``phi`` reaches ``(X, 0)`` at ``T / 2``::

        E (( -X, 0) - p(0)) + p(T/2) = (X, 0),   p(t) = (Re(G e^{i(omega t + phi)}) - R, d/dt),  E = e^{A_h T/2}.

    Two equations in ``(X, phi)``, solved by Newton (scipy ``fsolve``) to a residual below 1e-12; for ``zeta = 0``
    Den Hartog's formula ``X = sqrt(V^2 - (R U)^2)``, ``V = 1 / (1 - omega^2)``,
    ``U = sin(pi / omega) / (omega (1 + cos(pi / omega)))`` is the same number (:func:`den_hartog`).  Admissible
    when ``x' > 0`` on the half period and the force at the turning point exceeds ``R`` (no stop).
``rotating_radius``
    Isotropic 2-DOF oscillator ``m, c, k`` under the rotating force ``F (cos, sin)(omega t)`` with a 3-D friction
    contact at the constant normal load ``N``: the circular orbit's radius ``r`` solves
    ``F^2 = ((k - m omega^2) r)^2 + (c omega r + mu N)^2`` (sliding needs ``F > mu N``).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq, fsolve

__all__ = ["impact_11", "coulomb", "den_hartog", "rotating_radius"]


def _G(omega, zeta):
    return 1.0 / (1.0 - omega ** 2 + 2j * zeta * omega)


def _phi_h(tau, zeta):
    """Flow of ``h'' + 2 zeta h' + h = 0`` over ``tau`` (shape ``tau.shape + (2, 2)``)."""
    wd = math.sqrt(1.0 - zeta ** 2)
    tau = np.asarray(tau, dtype=float)
    E, c, s = np.exp(-zeta * tau), np.cos(wd * tau), np.sin(wd * tau)
    out = np.empty(tau.shape + (2, 2))
    out[..., 0, 0] = E * (c + zeta * s / wd)
    out[..., 0, 1] = E * s / wd
    out[..., 1, 0] = -E * s / wd
    out[..., 1, 1] = E * (c - zeta * s / wd)
    return out


def _forced(t, omega, zeta):
    z = _G(omega, zeta) * np.exp(1j * omega * np.asarray(t, dtype=float))
    return z.real, (1j * omega * z).real, (-omega ** 2 * z).real


def _flight(t, t0, v, omega, zeta, sigma, e):
    P, Pd, _ = _forced(t0, omega, zeta)
    y0 = np.array([sigma - P, -e * v - Pd])
    xp, xpd, _ = _forced(t, omega, zeta)
    y = _phi_h(np.asarray(t, dtype=float) - t0, zeta) @ y0
    return xp + y[..., 0], xpd + y[..., 1]


def _roots(alpha, beta, gamma):
    rho = math.hypot(alpha, beta)
    if rho == 0 or abs(gamma) > rho:
        return []
    base, d = math.atan2(beta, alpha), math.acos(gamma / rho)
    return [base + d, base - d]


def _candidates(omega, zeta, sigma, e):
    T = 2.0 * math.pi / omega
    G = _G(omega, zeta)
    A, psi = abs(G), float(np.angle(G))
    (p11, p12), (p21, p22) = _phi_h(T, zeta)
    out = []
    if e > 0:
        # v = v0 + vc cos + vs sin from the first equation; the second is then alpha cos + beta sin = gamma
        v0, vc, vs = (p11 - 1.0) * sigma / (e * p12), -(p11 - 1.0) * A / (e * p12), A * omega / e
        k = 1.0 + p22 * e
        thetas = _roots(-p21 * A - k * vc, -k * vs - (1.0 - p22) * A * omega, -(p21 * sigma - k * v0))
        vel = lambda th: v0 + vc * math.cos(th) + vs * math.sin(th)  # noqa: E731
    else:
        # (p11 - 1) (sigma - A cos) + p12 A omega sin = 0;  v = p21 a + (1 - p22) P'
        thetas = _roots((p11 - 1.0) * A, -p12 * A * omega, (p11 - 1.0) * sigma)
        vel = lambda th: p21 * (sigma - A * math.cos(th)) - (1.0 - p22) * A * omega * math.sin(th)  # noqa: E731
    for th in thetas:
        out.append((((th - psi) / omega) % T, float(vel(th))))
    return out


def _admissible(omega, t0, v, zeta, sigma, e, n=4001, margin=1e-9):
    if v <= 0:
        return False
    if e == 0 and math.cos(omega * t0) - sigma >= 0:  # the mass would stay at the stop
        return False
    T = 2.0 * math.pi / omega
    tt = np.linspace(t0, t0 + T, n)[1:-1]
    x, _ = _flight(tt, t0, v, omega, zeta, sigma, e)
    return bool(np.max(x) < sigma - margin * max(1.0, abs(sigma)))


def _spectral_radius(omega, t0, v, zeta, sigma, e, d=1e-7):
    """Spectral radius of the impact map ``(t0, v) -> (t1, v1)`` (central differences of the exact flight)."""
    T = 2.0 * math.pi / omega

    def step(p):
        t, w = p
        f = lambda s: _flight(s, t, w, omega, zeta, sigma, e)[0] - sigma  # noqa: E731
        lo, hi = t + 0.95 * T, t + 1.05 * T  # the return to the stop, near t + T
        t1 = brentq(f, lo, hi, xtol=1e-15) if f(lo) * f(hi) < 0 else t + T
        return np.array([t1 - T, _flight(t1, t, w, omega, zeta, sigma, e)[1]])

    J = np.empty((2, 2))
    for j in range(2):
        dp = np.zeros(2)
        dp[j] = d * max(1.0, abs((t0, v)[j]))
        J[:, j] = (step(np.array([t0, v]) + dp) - step(np.array([t0, v]) - dp)) / (2 * dp[j])
    return float(np.max(np.abs(np.linalg.eigvals(J))))


def _sticking_11(omega, zeta, sigma, n=20001):
    """``e = 0`` with a sticking phase: the mass rests at the stop until the force ``cos(omega t)`` falls below
    ``sigma`` (at ``t_l = arccos(sigma) / omega``), flies from ``(sigma, 0)`` and returns within a period while the
    force still pushes it onto the stop (``cos(omega t_1) >= sigma``).  ``(amplitude, t_1)`` or ``None``."""
    if not -1.0 < sigma < 1.0:
        return None
    T = 2.0 * math.pi / omega
    tl = math.acos(sigma) / omega
    tt = np.linspace(tl, tl + T, n)
    x, _ = _flight(tt, tl, 0.0, omega, zeta, sigma, 0.0)
    above = np.nonzero(x[1:] >= sigma)[0]
    if len(above) == 0:
        return None
    j = int(above[0]) + 1
    f = lambda s: _flight(s, tl, 0.0, omega, zeta, sigma, 0.0)[0] - sigma  # noqa: E731
    t1 = brentq(f, tt[j - 1], tt[j], xtol=1e-15) if f(tt[j - 1]) < 0 else tt[j]
    if math.cos(omega * t1) < sigma or j < 3:
        return None
    k = int(np.argmin(x[:j]))
    g = lambda s: _flight(s, tl, 0.0, omega, zeta, sigma, 0.0)[1]  # noqa: E731
    lo, hi = tt[max(k - 1, 0)], tt[min(k + 1, j)]
    tm = brentq(g, lo, hi, xtol=1e-15) if g(lo) * g(hi) < 0 else tt[k]
    xmin = float(_flight(tm, tl, 0.0, omega, zeta, sigma, 0.0)[0])
    return 0.5 * (sigma - xmin), float(t1 % T)


def impact_11(omega, zeta, sigma, e):
    """The (1,1) impact orbit (module docstring): ``{"amplitude", "t0", "v", "spectral_radius", "stable"}``, or
    ``None`` when no admissible (1,1) orbit exists.  ``e = 0``: the orbit with a sticking phase
    (:func:`_sticking_11`, ``"sticking": True``; superstable: the exit from the stop does not depend on the
    impact) when it exists, else the one without."""
    if e == 0:
        st = _sticking_11(omega, zeta, sigma)
        if st is not None:
            return {"amplitude": st[0], "t0": st[1], "v": None, "spectral_radius": 0.0, "stable": True,
                    "sticking": True}
    cands = [(t0, v) for t0, v in _candidates(omega, zeta, sigma, e)
             if _admissible(omega, t0, v, zeta, sigma, e)]
    if not cands:
        return None
    rad = [0.0 if e == 0 else _spectral_radius(omega, t0, v, zeta, sigma, e) for t0, v in cands]
    i = int(np.argmin(rad))
    t0, v = cands[i]
    T = 2.0 * math.pi / omega
    tt = np.linspace(t0, t0 + T, 20001)
    x, _ = _flight(tt, t0, v, omega, zeta, sigma, e)
    k = int(np.argmin(x))
    lo, hi = tt[max(k - 1, 0)], tt[min(k + 1, len(tt) - 1)]
    f = lambda s: _flight(s, t0, v, omega, zeta, sigma, e)[1]  # noqa: E731
    tm = brentq(f, lo, hi, xtol=1e-15) if f(lo) * f(hi) < 0 else tt[k]
    xmin = float(_flight(tm, t0, v, omega, zeta, sigma, e)[0])
    # e = 0: the impact map is one-dimensional (v is a function of t0 alone); its stability is not computed here
    return {"amplitude": 0.5 * (sigma - xmin), "t0": float(t0), "v": float(v), "spectral_radius": rad[i],
            "stable": None if e == 0 else bool(rad[i] < 1.0)}


def den_hartog(omega, R):
    """Den Hartog's amplitude of the undamped Coulomb oscillator in continuous motion (module docstring)."""
    V = 1.0 / (1.0 - omega ** 2)
    U = math.sin(math.pi / omega) / (omega * (1.0 + math.cos(math.pi / omega)))
    return math.sqrt(V ** 2 - (R * U) ** 2)


def coulomb(omega, zeta, R):
    """The continuous-motion orbit of the Coulomb oscillator (module docstring): ``{"amplitude", "phase",
    "residual"}`` or ``None`` when it is not admissible (a stop, or no solution)."""
    Ah = np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]])
    half = math.pi / omega
    E = expm(Ah * half)
    H = _G(omega, zeta)

    def part(t, phi):
        z = H * np.exp(1j * (omega * t + phi))
        return np.array([z.real - R, (1j * omega * z).real])

    def res(p):
        X, phi = p
        return E @ (np.array([-X, 0.0]) - part(0.0, phi)) + part(half, phi) - np.array([X, 0.0])

    best = None
    for phi0 in np.linspace(-math.pi, math.pi, 9)[:-1]:
        sol, info, ier, _ = fsolve(res, [abs(H), phi0], xtol=1e-14, full_output=True)
        r = float(np.max(np.abs(res(sol))))
        if ier == 1 and r < 1e-12 and sol[0] > 0 and (best is None or r < best[1]):
            best = (sol, r)
    if best is None:
        return None
    (X, phi), r = best
    # admissibility: x' > 0 on (0, T/2) and the turning point is no stop (|cos(phi) + X| > R)
    tt = np.linspace(0.0, half, 2001)[1:-1]
    flow = _phi_h(tt, zeta) if zeta < 1.0 else np.array([expm(Ah * t) for t in tt])  # e^{A_h t}, closed form
    xd = (flow @ (np.array([-X, 0.0]) - part(0.0, phi)))[:, 1] + part(tt, phi)[1]
    if np.min(xd) <= 0 or math.cos(phi) + X <= R:
        return None
    return {"amplitude": float(X), "phase": float(phi), "residual": r}


def rotating_radius(omega, m, c, k, mu, N, F):
    """Radius (m) of the circular orbit under the rotating force (module docstring); ``None`` when ``F <= mu N``."""
    if F <= mu * N:
        return None
    a, b = (k - m * omega ** 2) ** 2 + (c * omega) ** 2, 2.0 * c * omega * mu * N
    return float((-b + math.sqrt(b * b - 4.0 * a * ((mu * N) ** 2 - F ** 2))) / (2.0 * a))
