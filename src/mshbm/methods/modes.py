"""Nonlinear modes by shooting with the exact event-driven flow: conservative nonsmooth modes and the
extended periodic motion concept (EPMC) in the time domain.

The mode ``k`` at modal amplitude ``a`` is the periodic motion of the autonomous system::

    M q'' + (C - xi M) q' + K q = sum_j w_j lambda_j          (no forcing)

with the set-valued element laws of :mod:`mshbm.integrators.event` (friction on the ground, unilateral
contacts with Newton's impact law), integrated exactly by :class:`~mshbm.integrators.event.EventFlow`.
For a conservative system (``C = 0``, elastic impacts ``e_N = 1``, no acting friction) the mode is a
family of periodic orbits of the free system and ``xi = 0``: the artificial damping is the unfolding
parameter that makes the periodicity equations of an autonomous conservative system regular (one
periodicity equation is dependent on the others by the energy integral; ``xi`` restores the missing
unknown, and the solution has ``xi = 0``).  With dissipation ``xi`` balances it, as in
:mod:`mshbm.methods.epmc` (``D = xi / (2 omega)``).

Unknowns ``y = [q0, u0, omega, xi]`` (``2n + 2``: the state at ``t = 0`` in m and m/s, the angular
frequency in rad/s, ``xi`` in 1/s); the period is ``T = 2 pi / omega``.  Parameter ``lam = ln(a / a_ref)``.
Residual (``2n + 2`` rows)::

    R_per   = (q(T) - q0, u(T) - u0)                                  (m, m/s)
    R_amp   = v^T b_1 - a,    R_phase = v^T a_1                      (kg^1/2 m)

with ``q ~ a_0 + sum_k a_k cos(k omega t) + b_k sin(k omega t)`` the exact Fourier coefficients of the
flow over the period (Gauss-Legendre on its smooth pieces) and ``v = M phi`` as in
:mod:`mshbm.methods.epmc`, so ``a`` is the same mass-normalised first-harmonic modal amplitude as EPMC's
with harmonic balance; only the time origin differs: the modal coordinate's first harmonic is
``a sin(omega t)``, so ``t = 0`` lies at its zero crossing, away from the turning points where impacts and
stick-slip transitions happen (a start on an event would make the period map non-smooth there).

Jacobian: ``d/d(q0, u0)`` from the flow's saltation-corrected monodromy and the sensitivities of its
Fourier coefficients (exact); ``d/domega`` and ``d/dxi`` by central differences of flows rebuilt at
``omega (1 +- 1e-6)`` and ``xi +- 1e-6 omega`` (they steer Newton only: the solution is the root of ``R``).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..integrators.event import EventError, EventFlow, EventTrajectory, contact_margins, extrema
from ..solvers.arclength_parts import Failed
from ..solvers.arclength import continuation
from ..solvers.newton import newton
from .epmc import linear_modes, shifted_system
from .modes_common import ENERGY_TOL, ModalParameter, fd_omega_xi, xi_guess

__all__ = ["ShootingModeProblem", "xi_guess", "harmonic_mode_past", "shift_to_sine_phase"]

#: Gauss-Legendre nodes per smooth piece of the power integrals of the energy balance
_GAUSS = np.polynomial.legendre.leggauss(8)


def _dense(A):
    return A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)


def harmonic_mode_past(system, mode, a_c, a_t, n_h=15):
    """The EPMC mode by DLFT (``n_h`` harmonics, set-valued laws: smooth enough to pass a grazing corner)
    traced from ``0.9 a_c`` to ``a_t``: ``(EPMCProblem, x)`` at ``a_t`` (cosine phase), or None."""
    from ..options import aft_steps
    from .epmc import EPMCProblem

    ep = EPMCProblem(system, mode, n_h, aft_steps(n_h), "dlft")
    ep.a_ref = np.e * a_t
    l0, l1 = float(np.log(0.9 * a_c / ep.a_ref)), float(np.log(a_t / ep.a_ref))
    ds = abs(l1 - l0) / 10
    res = continuation(ep.residual, ep.d_lam, ep.start(0.9 * a_c), l0, l1, residual_scale=ep.residual_scale,
                       unknown_scale=ep.unknown_scale, lam_scale=1.0, ds0=ds, ds_min=1e-6 * ds, ds_max=ds,
                       max_points=200, tol=1e-8, natural_fallback=False, kink_crossing=False,
                       lam_limits=(l0 - 1.0, l1 + 1.0))
    return (ep, res.points[-1].x) if res.success else None


def shift_to_sine_phase(q_hat, omega):
    """Fourier coefficients ``(2 n_h + 1, n)`` of ``q(t + 3 T / 4)`` (EPMC's cosine phase to the sine phase of
    the shooting modes), and ``q, u`` at that time (the new ``t = 0``), shapes ``(n,)``."""
    from .. import fourier

    n_h = (q_hat.shape[0] - 1) // 2
    out = q_hat.copy()
    for k in range(1, n_h + 1):
        th = 1.5 * np.pi * k
        a, b = q_hat[2 * k - 1], q_hat[2 * k]
        out[2 * k - 1], out[2 * k] = a * np.cos(th) + b * np.sin(th), b * np.cos(th) - a * np.sin(th)
    V = fourier.basis(np.zeros(1), omega, n_h)
    return out, (V @ out).reshape(-1), (V @ fourier.derivative(out, omega)).reshape(-1)


class ShootingModeProblem(ModalParameter):
    """The shooting-EPMC residual of mode ``mode`` for :func:`mshbm.solvers.arclength.continuation`
    (the interface of :class:`mshbm.methods.epmc.EPMCProblem`).

    Parameters
    ----------
    system : System
        Elements: friction and contacts between a DOF and the ground (the event-driven flow's scope).
    mode : int
        0-based mode of the undamped linear system ``(K, M)``.
    harmonics : int
        ``n_h`` of the reported harmonic content (the residual needs the first harmonic only).
    steps : int
        Output samples per period of a converged point (its extrema, energy and power integrals are exact
        on the flow; the samples only split it into pieces) and Moreau-Jean steps per period of the
        flow's fallback at accumulations of impacts (a point that needs the fallback is not certified).
    integrator : {"event"}
        The exact event-driven flow (Moreau-Jean shooting is not offered for modes).
    """

    method = "shooting"
    integrator = "event"
    event_flow = True
    point_keys = ("periodicity_q", "periodicity_u", "energy", "energy_drift", "impacts", "events",
                  "moreau_segments", "max_multiplier", "energy_mismatch", "q0", "u0")

    def __init__(self, system, mode, harmonics, steps, integrator="event"):
        if integrator != "event":
            raise InputError("integrator", "backbone by shooting uses the exact event-driven flow "
                             f"(integrator 'event'), got {integrator!r}")
        if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or not 0 <= mode < system.n:
            raise InputError("mode", f"must be an integer in 0..{system.n - 1}, got {mode!r}")
        if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) or harmonics < 1:
            raise InputError("harmonics", f"must be an integer >= 1, got {harmonics!r}")
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 8:
            raise InputError("steps", f"must be an integer >= 8, got {steps!r}")
        self.system, self.mode, self.n_h, self.Ns = system, int(mode), int(harmonics), int(steps)
        omegas, Phi = linear_modes(system, self.mode + 1)
        self.omega0, self.phi = float(omegas[-1]), Phi[:, -1]
        self.M, self.C = _dense(system.M), _dense(system.C)
        self.K = _dense(system.K)
        self.v = self.M @ self.phi
        self.ref_dof = int(np.argmax(np.abs(self.phi)))
        n = self.n = system.n
        self.n_x = 2 * n
        self.n_unknowns = 2 * n + 2
        self.xi0 = float(self.phi @ self.C @ self.phi)
        self._cache = {}
        self.a_ref = 1.0
        try:
            self.flow(self.omega0, self.xi0)  # the flow's own input checks (element kinds, size), at once
        except InputError as exc:
            if exc.key != "integrator":
                raise
            raise InputError("method", f"backbone by shooting: {exc.problem.split(': use')[0]}; use method 'hbm' "
                             "or 'dlft'") from None
        acting = [el for el in system.elements if el.acts]
        #: no dissipation: no damping matrix, elastic impacts only, no acting friction
        self.conservative = (not np.any(self.C) and all(el.unilateral and el.restitution == 1.0 for el in acting))

    # ------------------------------------------------------------------ certificate (ModalParameter)
    def certify(self, pt, tol):
        """Residuals within ``10 tol``, no Moreau-Jean segments, the energy balance within :data:`ENERGY_TOL`
        (or the mismatch over the reactive power within ``10 tol``: where nothing dissipates Newton leaves
        ``xi`` at its tolerance); a conservative orbit also conserves its energy (``energy_drift``, ``|D|``
        within ``10 tol``) and gets ``stable`` from its multipliers."""
        ok = (super().certify(pt, tol) and not pt["moreau_segments"]
              and (pt["energy_balance"] <= ENERGY_TOL or pt["energy_mismatch"] <= 10 * tol))
        if self.conservative:
            ok = ok and pt["energy_drift"] <= 10 * tol and abs(pt["damping_ratio"]) <= 10 * tol
            pt["stable"] = bool(pt["max_multiplier"] <= 1 + 1e-6)
        return ok

    def stability_note(self):
        if self.conservative:
            return "Floquet multipliers of the conservative orbit (all on the unit circle: neutrally stable)"
        return super().stability_note()

    # ------------------------------------------------------------------ flows
    def flow(self, omega, xi):
        """The event-driven flow of the shifted autonomous system at ``(omega, xi)`` (cached)."""
        key = (float(omega), float(xi))
        fl = self._cache.get(key)
        if fl is None:
            if len(self._cache) > 16:
                self._cache.clear()
            fl = EventFlow(shifted_system(self.system, xi), omega, moreau_steps=self.Ns, accumulation="moreau")
            self._cache[key] = fl
        return fl

    def run(self, y, omega=None, xi=None, jac=False, fourier=1, record=False):
        """One period of the flow from ``y``'s state (:class:`~mshbm.integrators.event.FlowRun`); raises
        :class:`~mshbm.solvers.arclength_parts.Failed` where the flow fails."""
        n = self.n
        omega = float(y[-2]) if omega is None else omega
        xi = float(y[-1]) if xi is None else xi
        if not (np.isfinite(omega) and omega > 0 and np.isfinite(xi)):
            raise Failed(f"omega = {omega:.6g}, xi = {xi:.6g} out of range")
        fl = self.flow(omega, xi)
        times = np.linspace(0.0, fl.T, self.Ns + 1) if record else None
        try:
            return fl.simulate(0.0, fl.state(0.0, y[:n], y[n:2 * n]), jac=jac, fourier=fourier,
                               sample_times=times, record=record)
        except (EventError, ValueError) as exc:
            raise Failed(f"event-driven flow at omega = {omega:.6g}, xi = {xi:.6g}: {exc}") from None

    def start(self, a):
        """A solution at modal amplitude ``a`` (unknowns ``y``), by Newton from the linear mode
        ``q = a phi sin(omega_0 t)`` (``xi`` from :meth:`_xi_guess`), else from the harmonic-balance mode
        (EPMC with DLFT, then with HBM-AFT, ``n_h = 9``) at ``a``, shifted to this phase, else (contacts
        only) by tracing the mode from below the first stop (:meth:`_contact_free_amplitude`); the last guess
        if none converges (the continuation's first corrector then says why)."""
        lin = np.r_[np.zeros(self.n), a * self.omega0 * self.phi, self.omega0, self._xi_guess(a)]
        if not any(el.acts for el in self.system.elements):
            return lin
        guesses = [lambda: lin, lambda: self._hbm_guess(a, "dlft"), lambda: self._hbm_guess(a, "hbm")]
        y = lin
        for guess in guesses:
            try:
                y = guess()
                res = self._newton_at(y, a)
            except (Failed, InputError, np.linalg.LinAlgError):
                continue
            if res.success:
                return res.x
        a_free = self._contact_free_amplitude()
        if a_free is not None and a > a_free:
            # impacts from the start: trace this mode from half the amplitude at which the linear mode
            # touches the first stop (a linear orbit, exact) up to a
            lam0, lam1 = float(np.log(0.5 * a_free / self.a_ref)), float(np.log(a / self.a_ref))
            y0 = np.r_[np.zeros(self.n), 0.5 * a_free * self.omega0 * self.phi, self.omega0, self.xi0]
            ds = 0.25 * abs(lam1 - lam0) + 1e-3
            res = continuation(self.residual, self.d_lam, y0, lam0, lam1, residual_scale=self.residual_scale,
                               unknown_scale=self.unknown_scale, lam_scale=1.0, ds0=ds, ds_min=1e-6 * ds,
                               ds_max=ds, max_points=100, tol=1e-8, natural_fallback=False, kink_crossing=True,
                               segment=self.segment, lam_limits=(min(lam0, lam1) - 1.0, max(lam0, lam1) + 1.0))
            if res.success:
                return res.points[-1].x
        return y

    def restart_past_corner(self, lam_c, lam_end, tol=1e-8):
        """An orbit beyond a corner of the branch at ``lam_c`` where the trace in ``a`` stopped, or None.

        At a grazing impact the backbone has a corner where ``a`` reverses (a stop hardens the mode: omega
        grows with the impacts while ``a`` first falls back, then folds and grows again), which no step in
        ``a`` crosses.  The harmonic-balance mode (EPMC with DLFT, ``n_h = 15``, set-valued contact: smooth
        enough to pass the corner) is traced from ``0.9 a_c`` to ``a_t = 1.05 a_c`` (towards ``lam_end``),
        which it reaches beyond the fold; its orbit there, shifted to this phase, starts Newton on the
        shooting residual at ``a_t``.  Returns ``(y, lam_t)``."""
        if lam_end <= lam_c:
            return None
        a_c = self.a_ref * np.exp(lam_c)
        a_t = min(1.05 * a_c, self.a_ref * np.exp(lam_end))
        try:
            hb = harmonic_mode_past(self.system, self.mode, a_c, a_t)
            if hb is None:
                return None
            out = self._newton_at(self._from_hbm(*hb), a_t, tol)
        except (Failed, InputError, np.linalg.LinAlgError):
            return None
        return (out.x, float(np.log(a_t / self.a_ref))) if out.success else None

    def _contact_free_amplitude(self):
        """The modal amplitude at which the linear mode first touches a stop (kg^1/2 m), or None (no contact
        moves in the mode, or friction acts: then the small-amplitude mode is not the linear one)."""
        out = None
        for el in self.system.elements:
            if not el.acts:
                continue
            if not el.unilateral:
                return None
            wphi = abs(float(self.phi[el.dof] - (self.phi[el.relative_to] if el.relative_to is not None else 0.0)))
            if wphi > 0 and el.gap > 0:
                out = min(out, el.gap / wphi) if out is not None else el.gap / wphi
        return out

    def _xi_guess(self, a):
        return xi_guess(self.system, self.phi, self.omega0, self.xi0, a)

    def _newton_at(self, y, a, tol=1e-10):
        lam = float(np.log(a / self.a_ref))
        fun = lambda x, jac=True: self.residual(x, lam, jac)
        return newton(fun, y, tol=tol, max_iter=15, scale=lambda x: self.residual_scale(x, lam))

    def _hbm_guess(self, a, method):
        """``y`` from the EPMC mode by harmonic balance (``method``: "dlft" or "hbm") at ``a``."""
        from ..options import aft_steps
        from .epmc import EPMCProblem

        n_h = 9
        ep = EPMCProblem(self.system, self.mode, n_h, aft_steps(n_h), method)
        ep.a_ref = a
        fun = lambda x, jac=True: ep.residual(x, 0.0, jac)
        y0 = ep.start(a)
        y0[-1] = self._xi_guess(a)
        res = newton(fun, y0, tol=1e-9, max_iter=50, scale=lambda x: ep.residual_scale(x, 0.0))
        if not res.success:
            raise Failed(f"harmonic-balance start at a = {a:.6g}: {res.message}")
        return self._from_hbm(ep, res.x)

    def _from_hbm(self, ep, x):
        """Shooting unknowns from EPMC's ``x`` (:class:`~mshbm.methods.epmc.EPMCProblem`, cosine phase):
        ``z(t)`` of its Fourier series at ``t = 3 T / 4``."""
        omega, xi = float(x[-2]), float(x[-1])
        _, q, u = shift_to_sine_phase(ep.hbm(omega, xi).full_coefficients(x[:ep.n_x]), omega)
        return np.r_[q, u, omega, xi]

    def _amp_rows(self, q_hat, a):
        return np.array([self.v @ q_hat[2] - a, self.v @ q_hat[1]])

    # ------------------------------------------------------------------ residual
    def residual(self, y, lam, jac=True):
        """``(R, J)``: shapes ``(2n + 2,)`` and ``(2n + 2, 2n + 2)``."""
        n2 = self.n_x
        a = float(self.a_ref * np.exp(lam))
        fr = self.run(y, jac=jac)
        R = np.r_[fr.end_state[:n2] - y[:n2], self._amp_rows(fr.q_hat, a)]
        if not jac:
            return R, None
        J = np.zeros((n2 + 2, n2 + 2))
        J[:n2, :n2] = fr.monodromy[:n2] - np.eye(n2)
        dq = fr.q_hat_sensitivity  # (3, n, 2n)
        J[n2, :n2] = self.v @ dq[2]
        J[n2 + 1, :n2] = self.v @ dq[1]

        def rows(om, xx):
            r = self.run(y, om, xx)
            return np.r_[r.end_state[:n2], self._amp_rows(r.q_hat, 0.0)]

        J[:, n2:] = fd_omega_xi(rows, float(y[-2]), float(y[-1]))
        return R, J

    def _disp_scale(self, y, a):
        n = self.n
        w = abs(float(y[-2]))
        return max(float(np.max(np.abs(y[:n]))), float(np.max(np.abs(y[n:2 * n]))) / w,
                   a * float(np.max(np.abs(self.phi))))

    def residual_scale(self, y, lam):
        """Per-row scale: the displacement scale ``D`` (m) on the ``q`` rows, ``omega D`` (m/s) on the ``u``
        rows, ``a`` (kg^1/2 m) on the amplitude rows; ``D`` the largest of ``|q0|``, ``|u0| / omega`` and
        ``a max |phi|``."""
        a = float(self.a_ref * np.exp(lam))
        D = self._disp_scale(y, a)
        s = np.empty(self.n_unknowns)
        s[:self.n], s[self.n:self.n_x], s[self.n_x:] = D, D * abs(float(y[-2])), a
        return s

    def unknown_scale(self, y, lam):
        """Per-unknown scale: ``D`` (m), ``omega D`` (m/s), ``omega`` for ``omega`` and ``xi``."""
        s = self.residual_scale(y, lam)
        s[-2:] = abs(float(y[-2]))
        return s

    def segment(self, y, lam):
        """The event sequence of the period from ``y`` (a smooth piece of the branch), or None."""
        try:
            fr = self.run(y)
        except Failed:
            return None
        return tuple((int(e.element), e.kind) for e in fr.events)

    # ------------------------------------------------------------------ a converged point
    def point(self, y, lam, dofs):
        """The physical quantities of a converged point (fields of :mod:`mshbm.backbone`)."""
        n, n2 = self.n, self.n_x
        omega, xi = float(y[-2]), float(y[-1])
        a = float(self.a_ref * np.exp(lam))
        fr = self.run(y, jac=True, fourier=self.n_h, record=True)
        fl = self.flow(omega, xi)
        R = np.r_[fr.end_state[:n2] - y[:n2], self._amp_rows(fr.q_hat, a)]
        scale = self.residual_scale(y, lam)
        qmax, qmin, _ = extrema(fl, fr.nodes)
        dofs = list(dofs)
        Q = fr.q_hat[1::2] - 1j * fr.q_hat[2::2]
        r = self.ref_dof
        energy = self._energy(fl, fr, xi)
        margins = contact_margins(fl, fr)
        mult = np.linalg.eigvals(fr.monodromy[:n2])
        return dict(modal_amplitude=a, omega=omega, xi=xi, damping_ratio=xi / (2 * omega),
                    amplitude=0.5 * (qmax - qmin)[dofs], harmonics=np.abs(Q[:, r]).tolist(),
                    residual_N=None, residual=float(np.max(np.abs(R[:n2] / scale[:n2]))),
                    periodicity_q=float(np.max(np.abs(R[:n]))), periodicity_u=float(np.max(np.abs(R[n:n2]))),
                    amplitude_residual=float(np.max(np.abs(R[n2:]))) / a,
                    truncation=float(np.abs(Q[-1, r]) / max(np.abs(Q[0, r]), 1e-300)),
                    impacts=int(sum(1 for e in fr.events if e.impulse != 0.0)), events=len(fr.events),
                    impact_velocity_min=min([m["v_min"] for m in margins.values()] + [float("inf")]),
                    moreau_segments=len(fr.moreau_segments), max_multiplier=self._max_multiplier(mult),
                    q0=y[:n].tolist(), u0=y[n:n2].tolist(), q_hat=fr.q_hat, **energy)

    def _max_multiplier(self, mult):
        """Largest modulus of the Floquet multipliers (shape ``(2n,)``); for a conservative system without the
        trivial pair at 1 (the time shift along the orbit and the energy: a Jordan block, whose computed
        eigenvalues scatter like the square root of the rounding), the two nearest 1; 1.0 when none is left."""
        if self.conservative:
            mult = mult[np.argsort(np.abs(mult - 1.0))[2:]]
        return float(np.max(np.abs(mult))) if mult.size else 1.0

    def _energy(self, fl, fr, xi):
        """Energy of the orbit: ``energy`` (the mechanical energy ``H = u^T M u / 2 + q^T K q / 2`` at
        ``t = 0``, J), ``energy_drift`` (``max |H(t) - H(0)| / H(0)`` over the orbit's nodes, both sides of
        every event), and the mean powers over the period, each integral by Gauss-Legendre on the smooth
        pieces of the flow (exact to rounding), ``xi <u, M u> = <u, C u> - <lambda, gamma> + (impact
        losses) / T``: ``energy_balance`` its mismatch over the largest of them (floor ``1e-12 omega
        <u, M u>``, as :mod:`mshbm.methods.epmc`) and ``energy_mismatch`` over the reactive power
        ``omega <u, M u>`` (where nothing dissipates, Newton leaves ``xi`` at its tolerance, not at 0: the
        relative balance is then rounding over rounding, the mismatch is what a tolerance can bound)."""
        n = self.n
        nodes = fr.nodes
        H = lambda z: 0.5 * (z[n:2 * n] @ self.M @ z[n:2 * n] + z[:n] @ self.K @ z[:n])
        H0 = H(nodes[0][2])
        drift = max(max(abs(H(nd[1]) - H0), abs(H(nd[2]) - H0)) for nd in nodes) / max(H0, 1e-300)
        T = fl.T
        ts = np.array([nd[0] for nd in nodes])
        x, wg = _GAUSS
        tt, ww = [], []
        for t0, t1 in zip(ts[:-1], ts[1:]):
            if t1 > t0:
                tt.append(t0 + 0.5 * (t1 - t0) * (x + 1))
                ww.append(0.5 * (t1 - t0) * wg)
        tt, ww = np.concatenate(tt), np.concatenate(ww)
        _, u, lam = EventTrajectory(fl, nodes, 0.0).evaluate(tt)
        uMu = float(ww @ np.einsum("ki,ij,kj->k", u, self.M, u)) / T
        P_C = float(ww @ np.einsum("ki,ij,kj->k", u, self.C, u)) / T
        gam = fl.sign * u[:, fl.dof] if fl.m else np.zeros((tt.size, 0))
        P_el = -float(ww @ np.sum(np.nan_to_num(lam[:, fl.index]) * gam, axis=1)) / T if fl.m else 0.0
        KE = lambda z: 0.5 * z[n:2 * n] @ self.M @ z[n:2 * n]
        P_imp = -sum(KE(nd[2]) - KE(nd[1]) for nd in nodes) / T
        P_xi = xi * uMu
        omega = 2 * np.pi / T
        P_ref = max(abs(P_xi), abs(P_C), abs(P_el), abs(P_imp), 1e-12 * omega * uMu, 1e-300)
        return dict(energy=float(H0), energy_drift=float(drift),
                    energy_balance=abs(P_xi - P_C - P_el - P_imp) / P_ref,
                    energy_mismatch=abs(P_xi - P_C - P_el - P_imp) / max(omega * uMu, 1e-300),
                    power_dissipated=dict(damping=P_C, elements=P_el, impacts=P_imp))
