"""Nonlinear modes by MS-HBM (Section 3.2) with the exact event-driven flow of the nonlinear subsystem.

The mode is the EPMC motion of :mod:`mshbm.methods.modes` (``M q'' + (C - xi M) q' + K q = f_nl``, no
forcing), solved by :class:`mshbm.methods.mixed.MixedProblem` (``integrator="event"``) of the shifted system:
the nonlinear DOFs ``N`` (the element DOFs) are integrated exactly under the harmonic coupling force of
the linear DOFs ``L``, which are condensed per harmonic.  Unknowns ``y = [x, omega, xi]`` with ``x =
(q_hat_N, q_N(0), u_N(0))`` the MS-HBM unknowns (eq. 26; ``n_h`` harmonics); parameter ``lam = ln(a /
a_ref)``.  Residual: the MS-HBM residual (eq. 27: connectivity ``q_hat_N - FFT(q_N)``, periodicity of
``N``) and the two amplitude rows of :mod:`mshbm.methods.modes` on the complex first harmonic of all
DOFs, ``v^T Q_1 = w^T Q_N,1`` with ``w = v_N - Z_1^T v_L`` (``Q_L = -Z Q_N`` without forcing, the
condensation of :class:`mshbm.condensation.Condensation`): ``v^T Q_1 = -i a`` (the modal coordinate's
first harmonic ``a sin(omega t)``, as by shooting).  ``d/dx`` exact (the flow's monodromy and Fourier
sensitivities); ``d/domega``, ``d/dxi`` central differences of rebuilt problems.

The only error against the nonsmooth model is the harmonic truncation of the coupling (``N``'s motion
is exact for the coupling force it gets); a grazing corner is passed as by shooting
(:meth:`MixedModeProblem.restart_past_corner`); no energy balance is formed (the powers of ``N`` and of the
truncated ``L`` are not comparable to the certificate's 1e-6): a point is certified by its residuals.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..extrema import fourier_extrema
from ..solvers.arclength_parts import Failed
from ..solvers.newton import newton
from .epmc import linear_modes, shifted_system
from .mixed import MixedProblem
from .modes_common import ModalParameter, fd_omega_xi
from .modes_moreau import half_steps_error, moreau_certify, moreau_impact_hint, refuse_conservative_impacts
from .modes import ShootingModeProblem, harmonic_mode_past, shift_to_sine_phase, xi_guess

__all__ = ["MixedModeProblem"]



class MixedModeProblem(ModalParameter):
    """The MS-HBM EPMC residual of mode ``mode`` (interface of :class:`mshbm.methods.epmc.EPMCProblem`).

    Parameters
    ----------
    system : System
        Elements: friction and contacts between a DOF and the ground (the event-driven flow's scope).
    mode : int
    harmonics : int
        ``n_h`` of the coupling.
    steps : int
        Output samples per period of the flow (and its Moreau-Jean fallback's steps); with
        ``integrator="moreau"`` the Moreau-Jean steps per period (even).
    integrator : {"event", "moreau"}
        The exact event-driven flow (default) or Moreau-Jean time stepping of ``N`` (every element the stepper
        takes, Jenkins elements as sliders; a point then carries the half-steps error estimate of
        :mod:`mshbm.methods.modes_moreau`; a conservative system with impacts is refused there).
    """

    method = "mshbm"

    def __init__(self, system, mode, harmonics, steps, integrator="event"):
        if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or not 0 <= mode < system.n:
            raise InputError("mode", f"must be an integer in 0..{system.n - 1}, got {mode!r}")
        if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) or harmonics < 1:
            raise InputError("harmonics", f"must be an integer >= 1, got {harmonics!r}")
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps <= 2 * harmonics:
            raise InputError("steps", f"must be an integer > 2 harmonics = {2 * harmonics}, got {steps!r}")
        if integrator not in ("event", "moreau"):
            raise InputError("integrator", f"must be 'event' or 'moreau', got {integrator!r}")
        if integrator == "moreau" and steps % 2:
            raise InputError("steps", f"must be even with integrator 'moreau', got {steps!r}")
        self.system, self.mode, self.n_h, self.Ns = system, int(mode), int(harmonics), int(steps)
        self.integrator = integrator
        self.event_flow = integrator == "event"
        self.point_keys = (("omega_error", "D_error") if integrator == "moreau" else ()) + (
            "impacts", "events", "moreau_segments")
        self.Nd = np.asarray(system.nonlinear_dofs, dtype=np.int64)
        if self.Nd.size == 0:
            raise InputError("method", "MS-HBM needs a friction or contact element (its time-domain subsystem)")
        omegas, Phi = linear_modes(system, self.mode + 1)
        self.omega0, self.phi = float(omegas[-1]), Phi[:, -1]
        self.v = np.asarray(system.M @ self.phi).reshape(-1)
        self.ref_dof = int(np.argmax(np.abs(self.phi)))
        self.nN, self.nc = self.Nd.size, 2 * self.n_h + 1
        C = system.C.toarray() if hasattr(system.C, "toarray") else np.asarray(system.C)
        self.xi0 = float(self.phi @ (C @ self.phi))
        acting = [el for el in system.elements if el.acts]
        self.conservative = (not np.any(C) and all(el.unilateral and el.restitution == 1.0 for el in acting))
        if integrator == "moreau":
            refuse_conservative_impacts(system, self.conservative, "mshbm")
        self._cache = {}
        self._half = None
        self.a_ref = 1.0
        # input checks of MS-HBM and the integrator, at once; n_A the integrated states of N (Moreau-Jean: one
        # slider per Jenkins element more)
        self.nA = self.problem(self.omega0, self.xi0).nA
        self.n_x = self.nc * self.nN + 2 * self.nA
        self.n_unknowns = self.n_x + 2

    # ------------------------------------------------------------------ certificate (ModalParameter)
    def certify(self, pt, tol):
        """Residuals within ``10 tol``; Moreau-Jean: its half-steps estimate within its tolerances; the event
        flow: no Moreau-Jean segments and, for a conservative system, ``|D|`` within ``10 tol`` (no energy
        balance)."""
        if self.integrator == "moreau":
            return super().certify(pt, tol) and moreau_certify(pt)
        return (super().certify(pt, tol) and not pt["moreau_segments"]
                and (not self.conservative or abs(pt["damping_ratio"]) <= 10 * tol))

    def failure_hint(self, points_found, steps_given):
        return moreau_impact_hint(self.system) if self.integrator == "moreau" else ""

    # ------------------------------------------------------------------ problems
    def problem(self, omega, xi):
        """The MS-HBM problem of the shifted autonomous system at ``(omega, xi)`` (cached), with ``_w``."""
        key = (float(omega), float(xi))
        p = self._cache.get(key)
        if p is None:
            if not (np.isfinite(omega) and omega > 0 and np.isfinite(xi)):
                raise Failed(f"omega = {omega:.6g}, xi = {xi:.6g} out of range")
            if len(self._cache) > 16:
                self._cache.clear()
            try:
                p = MixedProblem(shifted_system(self.system, xi), omega, self.n_h, self.Ns, partition=self.Nd,
                                 integrator=self.integrator)
            except np.linalg.LinAlgError as exc:
                raise Failed(f"condensation at omega = {omega:.6g}: {exc}") from None
            p._w = self.v[p.cond.keep] - p.recovery_matrix(1).T @ self.v[p.cond.elim]
            self._cache[key] = p
        return p

    def _amp_rows(self, p, x, a):
        P = x[:self.nc * self.nN].reshape(self.nc, self.nN)
        c = p._w @ (P[1] - 1j * P[2])
        return np.array([-c.imag - a, c.real])

    def residual(self, y, lam, jac=True):
        """``(R, J)``: shapes ``(n_x + 2,)`` and ``(n_x + 2, n_x + 2)``."""
        n, x = self.n_x, y[:self.n_x]
        omega, xi = float(y[-2]), float(y[-1])
        a = float(self.a_ref * np.exp(lam))
        p = self.problem(omega, xi)
        Rx, Jx = p.residual(x, jac)
        if not np.all(np.isfinite(Rx)):
            raise Failed(f"the event-driven flow failed at omega = {omega:.6g}, xi = {xi:.6g}")
        R = np.r_[Rx, self._amp_rows(p, x, a)]
        if not jac:
            return R, None
        J = np.zeros((n + 2, n + 2))
        J[:n, :n] = Jx
        w, nN = p._w, self.nN
        J[n, nN:2 * nN], J[n, 2 * nN:3 * nN] = -w.imag, w.real
        J[n + 1, nN:2 * nN], J[n + 1, 2 * nN:3 * nN] = w.real, w.imag

        def rows(om, xx):
            pp = self.problem(om, xx)
            return np.r_[pp.residual(x, False)[0], self._amp_rows(pp, x, 0.0)]

        J[:, n:] = fd_omega_xi(rows, omega, xi)
        return R, J

    def residual_scale(self, y, lam):
        """MS-HBM's row scales (m, m/s) and ``a`` on the amplitude rows."""
        a = float(self.a_ref * np.exp(lam))
        s = np.full(self.n_unknowns, a)
        s[:self.n_x] = self.problem(float(y[-2]), float(y[-1])).residual_scale(y[:self.n_x])
        return s

    def unknown_scale(self, y, lam):
        a = float(self.a_ref * np.exp(lam))
        w = abs(float(y[-2]))
        nu = self.n_x - self.nA  # the velocities u_N(0) are the last n_A of x
        D = max(float(np.max(np.abs(y[:nu]))), float(np.max(np.abs(y[nu:self.n_x]))) / w,
                a * float(np.max(np.abs(self.phi))))
        s = np.full(self.n_unknowns, D)
        s[nu:self.n_x] = D * w
        s[-2:] = w
        return s

    def segment(self, y, lam):
        try:
            return self.problem(float(y[-2]), float(y[-1])).event_signature(y[:self.n_x])
        except Failed:
            return None

    # ------------------------------------------------------------------ start
    def start(self, a):
        """Newton from the linear mode (``q_N = a phi_N sin(omega_0 t)``), else from the mode by shooting of the
        whole system at ``a`` (:meth:`ShootingModeProblem.start`, where the event flow takes the system)."""
        X = np.zeros((self.nc, self.nN))
        X[2] = a * self.phi[self.Nd]
        for xi in ((self.xi0,) if self.integrator == "moreau" else ()) + \
                (xi_guess(self.system, self.phi, self.omega0, self.xi0, a),):
            lin = np.r_[X.reshape(-1), self._state(np.zeros(self.nN), a * self.omega0 * self.phi[self.Nd]),
                        self.omega0, xi]
            res = self._newton_at(lin, a)
            if res is not None and res.success:
                return res.x
        try:
            sh = ShootingModeProblem(self.system, self.mode, self.n_h, max(self.Ns, 64))
            sh.a_ref = self.a_ref
            ys = sh.start(a)
            fr = sh.run(ys, fourier=self.n_h)
        except (Failed, InputError):
            return lin
        n = self.system.n
        y = np.r_[fr.q_hat[:, self.Nd].reshape(-1), self._state(ys[self.Nd], ys[n + self.Nd]), ys[-2], ys[-1]]
        res = self._newton_at(y, a)
        return res.x if res is not None and res.success else y

    def restart_past_corner(self, lam_c, lam_end, tol=1e-8):
        """An orbit beyond a grazing corner at ``lam_c`` (:meth:`ShootingModeProblem.restart_past_corner`): from
        the DLFT mode at ``a_t = 1.05 a_c``, shifted to the sine phase, by Newton; ``(y, lam_t)`` or None."""
        if lam_end <= lam_c:
            return None
        a_c = self.a_ref * np.exp(lam_c)
        a_t = min(1.05 * a_c, self.a_ref * np.exp(lam_end))
        try:
            hb = harmonic_mode_past(self.system, self.mode, a_c, a_t, n_h=max(self.n_h, 15))
            if hb is None:
                return None
            ep, x = hb
            omega, xi = float(x[-2]), float(x[-1])
            qh, q, u = shift_to_sine_phase(ep.hbm(omega, xi).full_coefficients(x[:ep.n_x]), omega)
            P = np.zeros((self.nc, self.nN))
            m = min(self.nc, qh.shape[0])
            P[:m] = qh[:m, self.Nd]
            res = self._newton_at(np.r_[P.reshape(-1), self._state(q[self.Nd], u[self.Nd]), omega, xi], a_t, tol)
        except (Failed, InputError, np.linalg.LinAlgError):
            return None
        return (res.x, float(np.log(a_t / self.a_ref))) if res is not None and res.success else None

    def _state(self, q, u):
        """``(q_N, u_N)`` completed to the integrated states (Moreau-Jean's sliders), flattened."""
        return np.concatenate(self.problem(self.omega0, self.xi0).integrator.initial_state(q, u))

    def _newton_at(self, y, a, tol=1e-10):
        lam = float(np.log(a / self.a_ref))
        try:
            return newton(lambda x, jac=True: self.residual(x, lam, jac), y, tol=tol, max_iter=15,
                          scale=lambda x: self.residual_scale(x, lam))
        except (Failed, np.linalg.LinAlgError):
            return None

    # ------------------------------------------------------------------ a converged point
    def point(self, y, lam, dofs):
        x, omega, xi = y[:self.n_x], float(y[-2]), float(y[-1])
        a = float(self.a_ref * np.exp(lam))
        p = self.problem(omega, xi)
        R = p.residual(x, False)[0]
        parts = p.solution_parts(x)
        q_hat, info = parts["q_hat"], parts["info"]
        amp = info.get("amplitude_exact")
        if amp is None:
            hi, lo = fourier_extrema(q_hat)
            amp = 0.5 * (hi - lo)
        Q = q_hat[1::2] - 1j * q_hat[2::2]
        r = self.ref_dof
        ev = info.get("event_integrator", {})
        extra = {}
        if self.integrator == "moreau":
            if self._half is None:
                self._half = MixedModeProblem(self.system, self.mode, self.n_h, self.Ns // 2 + (self.Ns // 2) % 2,
                                              integrator="moreau")
            self._half.a_ref = self.a_ref
            extra["omega_error"], extra["D_error"] = half_steps_error(self._half, y, lam, omega, xi / (2 * omega))
        return dict(**extra, modal_amplitude=a, omega=omega, xi=xi, damping_ratio=xi / (2 * omega),
                    amplitude=np.asarray(amp)[list(dofs)], harmonics=np.abs(Q[:, r]).tolist(), residual_N=None,
                    residual=float(np.max(np.abs(R / p.residual_scale(x)))),
                    amplitude_residual=float(np.max(np.abs(self._amp_rows(p, x, a)))) / a,
                    energy_balance=None, truncation=float(np.abs(Q[-1, r]) / max(np.abs(Q[0, r]), 1e-300)),
                    impacts=int(ev.get("impacts", 0)), events=int(ev.get("events", 0)),
                    moreau_segments=len(ev.get("moreau_segments", [])), q_hat=q_hat)
