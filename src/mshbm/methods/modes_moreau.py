"""Nonlinear modes by shooting with Moreau-Jean time stepping (``backbone(method="shooting",
integrator="moreau")``).

The mode is the EPMC motion of :mod:`mshbm.methods.modes` (``M q'' + (C - xi M) q' + K q = f_nl``, no
forcing), its period map by ``N`` Moreau-Jean steps of ``h = T / N``
(:class:`mshbm.integrators.moreau_period.MoreauJeanIntegrator` of the whole system: every element the
time stepper takes, Jenkins elements as massless sliders).  Unknowns ``y = [q0, u0, omega, xi]``
(``2 n_A + 2``; ``n_A`` the structure's DOFs and one slider per Jenkins element), parameter
``lam = ln(a / a_ref)``; residual: the periodicity of all integrated states and the two amplitude rows of
:mod:`mshbm.methods.modes` on the first harmonic of the samples (``v^T b_1 = a``, ``v^T a_1 = 0``: the
modal coordinate's first harmonic is ``a sin(omega t)``).  ``d/d(q0, u0)`` exact (the forward sensitivities
of the step map and of the samples' Fourier coefficients); ``d/domega``, ``d/dxi`` by central differences
(:mod:`mshbm.methods.modes_common`).

Error against the nonsmooth model.  Moreau-Jean is of order 1 where stick-slip transitions or impacts
happen, so a point carries the estimate ``omega_error = |omega_N - omega_N/2| / omega_N`` and ``D_error =
|D_N - D_N/2|`` from the same mode at half the steps (Newton from the point; for order 1 the difference is
the error of the ``N``-step answer), and is certified only when ``omega_error <= MOREAU_OMEGA_TOL`` and
``D_error <= MOREAU_D_TOL``.

Refused (``InputError`` on ``integrator``): a conservative system with impacts (``C = 0``, elastic
contacts).  Its mode is a family of orbits of the free system with ``xi = 0``, which the discrete scheme
does not have: Moreau-Jean's impact law at velocity level with the active set from the predicted gap does not
conserve the energy at an impact (the impact lands on the step grid), so ``xi`` would absorb an ``O(h)``
spurious power and the "conservative" mode would be damped; and the period map jumps where an impact moves to
the next step, so Newton has no smooth root to converge to.  Use the event-driven flow
(``integrator="event"``), which is exact there.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..extrema import fourier_extrema
from ..integrators.moreau_period import MoreauJeanIntegrator
from ..solvers.arclength_parts import Failed
from ..solvers.newton import newton
from .epmc import linear_modes, shifted_system
from .modes import shift_to_sine_phase
from .modes_common import ModalParameter, fd_omega_xi, xi_guess

__all__ = ["MoreauModeProblem", "MOREAU_OMEGA_TOL", "MOREAU_D_TOL", "refuse_conservative_impacts",
           "half_steps_error"]

#: certificate of a Moreau-Jean point: the estimated error of omega (relative) and of D (absolute)
MOREAU_OMEGA_TOL, MOREAU_D_TOL = 1e-3, 1e-3


def refuse_conservative_impacts(system, conservative, method):
    """InputError on ``integrator`` for a conservative system with impacts (module docstring)."""
    if conservative and any(el.acts and el.unilateral for el in system.elements):
        raise InputError("integrator", f"backbone by {method} with 'moreau': the conservative mode (C = 0, "
                         "elastic impacts) is an orbit family of the free system with xi = 0, which Moreau-Jean "
                         "does not have (its impact law on the step grid does not conserve energy and its period "
                         "map jumps where an impact moves to the next step); use integrator 'event' (exact)")


def moreau_certify(pt):
    """The half-steps estimate of a Moreau-Jean point within ``MOREAU_OMEGA_TOL`` and ``MOREAU_D_TOL``."""
    return pt["omega_error"] <= MOREAU_OMEGA_TOL and pt["D_error"] <= MOREAU_D_TOL


def moreau_impact_hint(system):
    """The hint of a Moreau-Jean backbone that failed on a system with contacts (``""`` without contacts)."""
    if any(el.acts and el.unilateral for el in system.elements):
        return ("; Moreau-Jean's period map jumps where an impact moves to the next step (no smooth root past the "
                "onset of impacts): integrator 'event' is exact there")
    return ""


def half_steps_error(prob_half, y, lam, omega, D):
    """``(omega_error, D_error)`` of a point ``y`` at ``lam`` (module docstring) from the same mode of
    ``prob_half`` (half the steps), by Newton from ``y``; ``(inf, inf)`` where it does not converge."""
    try:
        res = newton(lambda x, jac=True: prob_half.residual(x, lam, jac), y, tol=1e-10, max_iter=15,
                     scale=lambda x: prob_half.residual_scale(x, lam))
    except (Failed, np.linalg.LinAlgError, ValueError):
        return float("inf"), float("inf")
    if not res.success:
        return float("inf"), float("inf")
    w2, xi2 = float(res.x[-2]), float(res.x[-1])
    return abs(w2 - omega) / omega, abs(xi2 / (2 * w2) - D)


class MoreauModeProblem(ModalParameter):
    """The shooting-EPMC residual of mode ``mode`` by Moreau-Jean (interface of
    :class:`mshbm.methods.epmc.EPMCProblem`).

    Parameters
    ----------
    system : System
    mode : int
        0-based mode of ``(K_0, M)`` (:func:`mshbm.methods.epmc.linear_modes`: the Jenkins joints stuck).
    harmonics : int
        ``n_h`` of the reported harmonic content (the residual needs the first harmonic only).
    steps : int
        Moreau-Jean steps per period ``N`` (even, ``>= 16``).
    theta : float
        Moreau-Jean parameter (default 1/2).
    """

    method = "shooting"
    integrator = "moreau"
    point_keys = ("omega_error", "D_error", "contact_steps")

    def __init__(self, system, mode, harmonics, steps, theta=0.5):
        if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or not 0 <= mode < system.n:
            raise InputError("mode", f"must be an integer in 0..{system.n - 1}, got {mode!r}")
        if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) or harmonics < 1:
            raise InputError("harmonics", f"must be an integer >= 1, got {harmonics!r}")
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 16 or steps % 2 \
                or steps <= 2 * harmonics:
            raise InputError("steps", f"must be an even integer >= 16 and > 2 harmonics, got {steps!r}")
        self.system, self.mode, self.n_h, self.Ns, self.theta = system, int(mode), int(harmonics), int(steps), theta
        omegas, Phi = linear_modes(system, self.mode + 1)
        self.omega0, self.phi = float(omegas[-1]), Phi[:, -1]
        self.v = np.asarray(system.M @ self.phi).reshape(-1)
        self.ref_dof = int(np.argmax(np.abs(self.phi)))
        C = system.C.toarray() if hasattr(system.C, "toarray") else np.asarray(system.C)
        self.xi0 = float(self.phi @ (C @ self.phi))
        acting = [el for el in system.elements if el.acts]
        self.conservative = (not np.any(C) and all(el.unilateral and el.restitution == 1.0 for el in acting))
        refuse_conservative_impacts(system, self.conservative, "shooting")
        self.n = system.n
        self.nc = 2 * self.n_h + 1
        self._cache = {}
        self.a_ref = 1.0
        self.nA = self.stepper(self.omega0, self.xi0).n
        self.n_x = 2 * self.nA
        self.n_unknowns = self.n_x + 2
        self._half = None

    def certify(self, pt, tol):
        """Residuals within ``10 tol`` and the half-steps estimate within its tolerances."""
        return super().certify(pt, tol) and moreau_certify(pt)

    def failure_hint(self, points_found, steps_given):
        return moreau_impact_hint(self.system)

    def stepper(self, omega, xi):
        """Moreau-Jean over one period of the shifted autonomous system at ``(omega, xi)`` (cached)."""
        key = (float(omega), float(xi))
        ig = self._cache.get(key)
        if ig is None:
            if not (np.isfinite(omega) and omega > 0 and np.isfinite(xi)):
                raise Failed(f"omega = {omega:.6g}, xi = {xi:.6g} out of range")
            if len(self._cache) > 16:
                self._cache.clear()
            n = self.n
            ig = MoreauJeanIntegrator(shifted_system(self.system, xi), omega, self.Ns, dofs=np.arange(n),
                                      coupling=(np.zeros(self.nc * n), np.zeros((self.nc * n, 0))),
                                      harmonics=self.n_h, theta=self.theta)
            self._cache[key] = ig
        return ig

    def _run(self, y, omega, xi, jac=False):
        nA = self.nA
        run = self.stepper(omega, xi).run(y[:nA], y[nA:2 * nA], np.zeros(0), sensitivities=jac)
        if run.failed or not np.all(np.isfinite(run.end)):
            raise Failed(f"Moreau-Jean at omega = {omega:.6g}, xi = {xi:.6g}: {run.error or 'not finite'}")
        return run

    def _amp_rows(self, q_hat, a):
        Q = q_hat.reshape(self.nc, self.n)
        return np.array([self.v @ Q[2] - a, self.v @ Q[1]])

    def residual(self, y, lam, jac=True):
        """``(R, J)``: shapes ``(2 n_A + 2,)`` and ``(2 n_A + 2, 2 n_A + 2)``."""
        n2 = self.n_x
        omega, xi = float(y[-2]), float(y[-1])
        a = float(self.a_ref * np.exp(lam))
        run = self._run(y, omega, xi, jac)
        R = np.r_[run.end - y[:n2], self._amp_rows(run.q_hat, a)]
        if not jac:
            return R, None
        J = np.zeros((n2 + 2, n2 + 2))
        J[:n2, :n2] = run.jacobian[:, :n2] - np.eye(n2)
        dQ = run.q_hat_jacobian[:, :n2].reshape(self.nc, self.n, n2)
        J[n2], J[n2 + 1] = np.r_[self.v @ dQ[2], 0.0, 0.0], np.r_[self.v @ dQ[1], 0.0, 0.0]

        def rows(om, xx):
            r = self._run(y, om, xx)
            return np.r_[r.end, self._amp_rows(r.q_hat, 0.0)]

        J[:, n2:] = fd_omega_xi(rows, omega, xi)
        return R, J

    def _disp_scale(self, y, a):
        nA, w = self.nA, abs(float(y[-2]))
        return max(float(np.max(np.abs(y[:nA]))), float(np.max(np.abs(y[nA:2 * nA]))) / w,
                   a * float(np.max(np.abs(self.phi))))

    def residual_scale(self, y, lam):
        """``D`` (m) on the ``q`` rows, ``omega D`` (m/s) on the ``u`` rows, ``a`` on the amplitude rows;
        ``D`` the largest of ``|q0|``, ``|u0| / omega`` and ``a max |phi|``."""
        a = float(self.a_ref * np.exp(lam))
        D = self._disp_scale(y, a)
        s = np.empty(self.n_unknowns)
        s[:self.nA], s[self.nA:self.n_x], s[self.n_x:] = D, D * abs(float(y[-2])), a
        return s

    def unknown_scale(self, y, lam):
        s = self.residual_scale(y, lam)
        s[-2:] = abs(float(y[-2]))
        return s

    # ------------------------------------------------------------------ start
    def start(self, a):
        """Newton from the linear mode ``q = a phi sin(omega_0 t)`` (``xi`` of the linear mode, then with the
        friction's describing function), else from the mode by the event-driven flow
        (:class:`mshbm.methods.modes.ShootingModeProblem`, where it takes the system), else from the EPMC mode by DLFT (``n_h = 9``) shifted to this phase; the
        last guess if none converges (the continuation's first corrector then says why)."""
        ig = self.stepper(self.omega0, self.xi0)
        q0, u0 = ig.initial_state(np.zeros(self.n), a * self.omega0 * self.phi)
        for xi in (self.xi0, xi_guess(self.system, self.phi, self.omega0, self.xi0, a)):
            y = np.r_[q0, u0, self.omega0, xi]
            res = self._newton_at(y, a)
            if res is not None and res.success:
                return res.x
        for guess in (self._event_guess, self._dlft_guess):
            try:
                g = guess(a)
            except (Failed, InputError, np.linalg.LinAlgError):
                continue
            q0, u0 = ig.initial_state(g[:self.n], g[self.n:2 * self.n])
            y = np.r_[q0, u0, g[-2], g[-1]]
            res = self._newton_at(y, a)
            if res is not None and res.success:
                return res.x
        return y

    def _event_guess(self, a):
        from .modes import ShootingModeProblem

        sh = ShootingModeProblem(self.system, self.mode, self.n_h, 64)
        sh.a_ref = self.a_ref
        return sh.start(a)

    def _dlft_guess(self, a):
        from ..options import aft_steps
        from .epmc import EPMCProblem

        ep = EPMCProblem(self.system, self.mode, 9, aft_steps(9), "dlft")
        ep.a_ref = a
        hb = ep.start(a)  # corrected by Newton where it converges
        omega, xi = float(hb[-2]), float(hb[-1])
        _, q, u = shift_to_sine_phase(ep.hbm(omega, xi).full_coefficients(hb[:ep.n_x]), omega)
        return np.r_[q, u, omega, xi]

    def _newton_at(self, y, a, tol=1e-10):
        lam = float(np.log(a / self.a_ref))
        try:
            return newton(lambda x, jac=True: self.residual(x, lam, jac), y, tol=tol, max_iter=20,
                          scale=lambda x: self.residual_scale(x, lam))
        except (Failed, np.linalg.LinAlgError):
            return None

    # ------------------------------------------------------------------ a converged point
    def half(self):
        """The same mode with ``N / 2`` steps (the error estimate)."""
        if self._half is None:
            self._half = MoreauModeProblem(self.system, self.mode, self.n_h, self.Ns // 2 + (self.Ns // 2) % 2,
                                           self.theta)
        self._half.a_ref = self.a_ref
        return self._half

    def point(self, y, lam, dofs):
        """The physical quantities of a converged point (fields of :mod:`mshbm.backbone`)."""
        nA, n2 = self.nA, self.n_x
        omega, xi = float(y[-2]), float(y[-1])
        a = float(self.a_ref * np.exp(lam))
        run = self._run(y, omega, xi)
        ig = self.stepper(omega, xi)
        rec = ig.run(y[:nA], y[nA:n2], np.zeros(0), record=True)
        R = np.r_[run.end - y[:n2], self._amp_rows(run.q_hat, a)]
        scale = self.residual_scale(y, lam)
        q = rec.q[:, :self.n]
        dofs = list(dofs)
        q_hat = ig.coefficients(rec, self.n_h)
        Q = q_hat[1::2] - 1j * q_hat[2::2]
        r = self.ref_dof
        D = xi / (2 * omega)
        w_err, D_err = half_steps_error(self.half(), y, lam, omega, D)
        contact = np.array([el.unilateral for el in self.system.elements], dtype=bool)
        contact_steps = int(np.sum(np.any(rec.impulses[:, contact] > 0, axis=1))) if contact.any() else 0
        return dict(modal_amplitude=a, omega=omega, xi=xi, damping_ratio=D,
                    amplitude=(0.5 * (q.max(axis=0) - q.min(axis=0)))[dofs], harmonics=np.abs(Q[:, r]).tolist(),
                    residual_N=None, residual=float(np.max(np.abs(R[:n2] / scale[:n2]))),
                    amplitude_residual=float(np.max(np.abs(R[n2:]))) / a, energy_balance=None,
                    truncation=float(np.abs(Q[-1, r]) / max(np.abs(Q[0, r]), 1e-300)),
                    omega_error=w_err, D_error=D_err, contact_steps=contact_steps,
                    q_hat=q_hat)
