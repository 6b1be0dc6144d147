"""Nonlinear modes by the extended periodic motion concept (EPMC, Krack 2015) with HBM-AFT or DLFT.

The nonlinear mode ``k`` at modal amplitude ``a`` is the periodic motion of the autonomous system::

    M q'' + (C - xi M) q' + K q = f_nl(q, q')

(no forcing) whose artificial negative damping ``xi`` (1/s) balances the dissipation of ``C`` and of
the elements.  Unknowns: the Fourier coefficients ``q_hat`` (``n_h`` harmonics, conventions of
:mod:`mshbm.fourier`) of the kept DOFs ``R`` (the element DOFs and the reference DOF; the others are
condensed exactly per harmonic as in :class:`mshbm.methods.hbm.HBMProblem`), the angular frequency
``omega`` (rad/s) and ``xi``; the parameter is ``lam = ln(a / a_ref)`` (``a_ref`` above the range, so that
``lam < 0`` throughout: the continuation keeps a positive parameter positive).  The residual (``n_x + 2`` rows)::

    R_hb    = the HBM (or DLFT) residual of (M, C - xi M, K, f_nl) at omega, no forcing  (N)
    R_amp   = Re(v^T Q_1) - a,   R_phase = Im(v^T Q_1)                              (kg^1/2 m)

with ``Q_1 = qc_1 - i qs_1`` the complex first harmonic of *all* DOFs (the condensed ones recovered,
``Q_E = -Z_1 Q_R``) and ``v = M phi``, ``phi`` the mass-normalised (``phi^T M phi = 1``) undamped mode
``k`` of ``(K_0, M)``; ``K_0 = K + sum k_t w w^T`` over the Jenkins elements (the joints stuck, the
linearisation at small amplitude), sign such that its largest entry is positive.  So ``a`` is the
mass-normalised modal coordinate of the first harmonic (kg^1/2 m) and the phase makes it real (a
cosine).  The modal damping ratio is ``D = xi / (2 omega)``.

What EPMC returns for a linear system: ``omega`` and ``xi`` such that ``i omega`` is an eigenvalue of the
pencil ``lambda^2 M + lambda (C - xi M) + K``.  With proportional (e.g. Rayleigh) damping that is the
undamped natural frequency ``omega_k`` and ``xi = phi_k^T C phi_k``, so ``D`` is the modal damping
ratio ``zeta_k`` exactly.  With non-proportional damping it differs from the complex eigenvalue
``lambda_k = -zeta omega_n + i omega_d`` at second order in the damping.

The Jacobian in ``q_hat`` is the HBM one (analytic); ``dR/domega`` and ``dR/dxi`` are central differences
of problems rebuilt at ``omega (1 +- 1e-6)`` and ``xi +- 1e-6 omega`` (they steer Newton and the
continuation's tangent only; the solution is the root of ``R``); they difference the linear part ``A x`` of the
HBM residual only, and the element forces too where a law depends on the velocity (friction, penalty damping).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..condensation import SingularHarmonicError
from ..errors import InputError
from ..solvers.arclength_parts import Failed
from ..elements import Jenkins
from ..system import System
from .dlft import DLFTProblem
from .hbm import HBMProblem
from .modes_common import ENERGY_TOL, ModalParameter, fd_omega_xi, xi_guess
from ..solvers.newton import newton

#: the harmonic-balance problems EPMC builds on (same constructor: system, omega, n_h, steps, condense, partition)
PROBLEMS = {"hbm": HBMProblem, "dlft": DLFTProblem}

__all__ = ["EPMCProblem", "linear_modes", "shifted_system"]

def _dense(A):
    return A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)


def stuck_stiffness(system):
    """``K_0 = K + sum_j k_t,j w_j w_j^T`` over the Jenkins elements (dense, ``(n, n)``, N/m)."""
    K0 = _dense(system.K).copy()
    for el in system.elements:
        if isinstance(el, Jenkins):
            w = np.zeros(system.n)
            for d, s in zip(el.dofs, (el.sign, -el.sign)):
                w[d] += s
            K0 += el.tangential_stiffness * np.outer(w, w)
    return K0


def linear_modes(system, count):
    """The ``count`` lowest undamped modes of ``(K_0, M)`` (:func:`stuck_stiffness`): ``(omega_0, Phi)``,
    shapes ``(count,)`` (rad/s) and ``(n, count)`` (mass-normalised, largest entry positive)."""
    n = system.n
    lam, Phi = sla.eigh(stuck_stiffness(system), _dense(system.M), subset_by_index=[0, min(count, n) - 1])
    if np.any(lam <= 0):
        raise InputError("mode", "the linear system (joints stuck) has a rigid-body or unstable mode "
                                 f"(eigenvalue {lam.min():.3g}): no vibration mode to follow")
    idx = np.argmax(np.abs(Phi), axis=0)
    Phi = Phi * np.sign(Phi[idx, np.arange(Phi.shape[1])])
    return np.sqrt(lam), Phi


def shifted_system(system, xi):
    """``system`` with damping ``C - xi M`` and no forcing (a shallow copy: ``M, K`` and the elements
    shared)."""
    new = object.__new__(System)
    new.__dict__.update(system.__dict__)
    new.__dict__.pop("_derived", None)
    if sp.issparse(system.C) or sp.issparse(system.M):
        C = sp.csr_matrix(system.C) - xi * sp.csr_matrix(system.M)
    else:
        C = np.asarray(system.C) - xi * np.asarray(system.M)
        C.flags.writeable = False
    f = np.zeros((1, system.n))
    f.flags.writeable = False
    new.C, new.f_hat = C, f
    new.forcing_parts, new.forcing_omega, new.base = (), None, None  # unforced
    return new


class EPMCProblem(ModalParameter):
    """The EPMC residual of mode ``mode`` (0-based) for :func:`mshbm.solvers.arclength.continuation`.

    Parameters
    ----------
    system : System
    mode : int
        Mode number ``k`` (0: the lowest) of ``(K_0, M)`` (module docstring).
    harmonics, steps : int
        ``n_h`` and the AFT samples per period ``N_s`` (``> 2 n_h``).
    method : {"hbm", "dlft"}
        The harmonic balance of the residual's first rows (:data:`PROBLEMS`).

    Unknowns ``y = [x, omega, xi]`` with ``x`` the HBM coefficients of the kept DOFs (``n_x``), parameter
    ``lam = ln(a / a_ref)`` (module docstring).
    """

    def __init__(self, system, mode, harmonics, steps, method="hbm"):
        if method not in PROBLEMS:
            raise InputError("method", f"backbone supports {', '.join(PROBLEMS)}, got {method!r}")
        self.method, self._cls = method, PROBLEMS[method]
        if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or not 0 <= mode < system.n:
            raise InputError("mode", f"must be an integer in 0..{system.n - 1}, got {mode!r}")
        if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) or harmonics < 1:
            raise InputError("harmonics", f"must be an integer >= 1, got {harmonics!r}")
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps <= 2 * harmonics:
            raise InputError("steps", f"must be an integer > 2 harmonics = {2 * harmonics}, got {steps!r}")
        for el in system.elements:
            if el.normal_contact is not None:
                raise InputError(f"{el.kind}.normal_contact", "backbone: friction loaded by a contact is not "
                                 "supported")
            if el.cone_partner is not None:
                raise InputError(f"{el.kind}.cone_partner", "backbone: the 3-D frictional contact is not supported")
            if method == "dlft" and (el.history or el.relative_to is not None):
                what = "tangential_stiffness" if el.history else "relative_to"
                raise InputError(f"{el.kind}.{what}", "backbone with DLFT: ground friction and contacts only "
                                 "(relative and elastic (Jenkins) elements: use method 'hbm')")
        if method == "dlft" and not system.elements:
            raise InputError("method", "DLFT needs a friction or contact element (its Lagrange multipliers); the "
                             "system is linear: use 'hbm' (exact for it) or 'shooting'")
        self.system, self.mode, self.n_h, self.Ns = system, int(mode), int(harmonics), int(steps)
        omegas, Phi = linear_modes(system, self.mode + 1)
        self.omega0, self.phi = float(omegas[-1]), Phi[:, -1]
        self.v = np.asarray(system.M @ self.phi).reshape(-1)
        self.ref_dof = int(np.argmax(np.abs(self.phi)))
        self.keep = np.array(sorted(set(int(d) for d in system.nonlinear_dofs) | {self.ref_dof}), dtype=np.int64)
        self.nR = self.keep.size
        self.n_x = (2 * self.n_h + 1) * self.nR
        self.n_unknowns = self.n_x + 2
        self.xi0 = float(self.phi @ (system.C @ self.phi))
        self._cache = {}
        #: reference amplitude (kg^1/2 m) of the parameter ``lam = ln(a / a_ref)`` (set by the caller)
        self.a_ref = 1.0
        # HBM with contacts: the penalty force integrated on the gap's linear interpolant (a C^1 residual, as in
        # sweep; sampled, the backbone is a chain of kinks where samples enter or leave the contact)
        contacts = method == "hbm" and any(el.unilateral for el in system.elements)
        self._options = {"penalty_quadrature": "linear"} if contacts else {}
        # laws whose force depends on the velocity samples (hence on omega at fixed coefficients): not Jenkins,
        # not a contact without penalty damping
        # (DLFT: its element forces depend on the linear part, so always)
        self._velocity_laws = method == "dlft" or any(not (el.history or (el.unilateral and not getattr(el, "penalty_damping", 1.0)))
                                  for el in system.elements)
        # force scale: the largest modal inertia (or linear stiffness) force per unit modal amplitude, N/(kg^1/2 m)
        self._force_per_a = float(np.max(np.abs(self.v))) * self.omega0 ** 2
        self._bound = max([float(el.force_scale(0.0)) for el in system.elements if el.bounded] + [0.0])

    # ------------------------------------------------------------------ certificate (ModalParameter)
    def certify(self, pt, tol):
        """Residuals within ``10 tol`` and the energy balance within :data:`ENERGY_TOL`."""
        return super().certify(pt, tol) and pt["energy_balance"] <= ENERGY_TOL

    def failure_hint(self, points_found, steps_given):
        """HBM without points and with default samples on a steep regularisation: ask for more samples."""
        if points_found or steps_given or self.method != "hbm":
            return ""
        kappas = [el.smoothing for el in self.system.elements if getattr(el, "smoothing", None) is not None]
        if not kappas:
            return ""
        # a steep regularisation (the case's smoothing kappa) that the default AFT samples do not resolve: the
        # residual is then non-smooth at the samples' resolution and Newton stalls (friction3.yaml: converges
        # with 8192)
        return (f"; the regularised friction (smoothing {max(kappas):g}) may need more AFT samples than the "
                f"default {self.Ns}: try steps (--steps) 8192")

    # ------------------------------------------------------------------ pieces
    def hbm(self, omega, xi):
        """The HBM problem of the shifted system at ``(omega, xi)`` (cached)."""
        key = (float(omega), float(xi))
        p = self._cache.get(key)
        if p is None:
            if len(self._cache) > 16:
                self._cache.clear()
            try:
                p = self._cls(shifted_system(self.system, xi), omega, self.n_h, self.Ns, condense=True,
                              partition=self.keep, **self._options)
            except SingularHarmonicError as exc:  # a harmonic of omega at an undamped resonance of the condensed DOFs
                raise Failed(f"condensation at omega = {omega:.6g}, xi = {xi:.6g}: {exc}") from None
            Z1 = p.cond.Z[1] if p.elim.size else np.zeros((0, self.nR), complex)
            p._epmc_w = self.v[p.keep] - Z1.T @ self.v[p.elim]  # v^T Q_1 = w^T Q_R
            self._cache[key] = p
        return p

    def start(self, a):
        """Unknowns of the linear mode at modal amplitude ``a``: ``q = a phi cos(omega_0 t)``, ``xi`` of the
        linear mode, corrected by Newton at ``a``; else the same with ``xi`` from the friction's describing
        function (:func:`mshbm.methods.modes_common.xi_guess`: a slipping Coulomb contact on the ground, whose
        damping dominates at small amplitude); the uncorrected linear mode if neither converges (the
        continuation's first corrector then says why)."""
        X = np.zeros((2 * self.n_h + 1, self.nR))
        X[1] = a * self.phi[self.keep]
        lin = np.r_[X.reshape(-1), self.omega0, self.xi0]
        if not any(el.acts for el in self.system.elements):
            return lin
        lam = float(np.log(a / self.a_ref))
        for xi in (self.xi0, xi_guess(self.system, self.phi, self.omega0, self.xi0, a)):
            try:
                res = newton(lambda x, jac=True: self.residual(x, lam, jac), np.r_[lin[:-1], xi], tol=1e-10,
                             max_iter=30, scale=lambda x: self.residual_scale(x, lam))
            except (Failed, np.linalg.LinAlgError):
                continue
            if res.success:
                return res.x
        return lin

    def _amp_rows(self, p, x, a):
        X = x.reshape(2 * self.n_h + 1, self.nR)
        c = p._epmc_w @ (X[1] - 1j * X[2])
        return np.array([c.real - a, c.imag])

    def _rows(self, y, lam, jac):
        x, omega, xi = y[:self.n_x], float(y[-2]), float(y[-1])
        p = self.hbm(omega, xi)
        R, J = p.residual(x, jac=jac)
        return np.r_[R, self._amp_rows(p, x, self.a_ref * np.exp(lam))], J, p

    def residual(self, y, lam, jac=True):
        """``(R, J)``: shapes ``(n_x + 2,)`` and ``(n_x + 2, n_x + 2)`` (dense)."""
        R, Jx, p = self._rows(y, lam, jac)
        if not jac:
            return R, None
        n = self.n_x
        J = np.zeros((n + 2, n + 2))
        J[:n, :n] = Jx.toarray() if sp.issparse(Jx) else Jx
        w = p._epmc_w
        nR = self.nR
        J[n, nR:2 * nR], J[n, 2 * nR:3 * nR] = w.real, w.imag  # d Re(w^T (c - i s)) / d (c, s)
        J[n + 1, nR:2 * nR], J[n + 1, 2 * nR:3 * nR] = w.imag, -w.real
        omega, xi = float(y[-2]), float(y[-1])
        x = y[:n]
        full = self._velocity_laws  # the element forces depend on omega (velocity laws; DLFT: on xi too)

        def rows(om, xx):
            p = self.hbm(om, xx)
            # the linear part A x (HBM's forces do not depend on xi; on omega only through velocity laws)
            lin = p.residual(x, jac=False)[0] if full and (xx == xi or self.method == "dlft") else p.A @ x
            return np.r_[lin, self._amp_rows(p, x, 0.0)]

        J[:, n:] = fd_omega_xi(rows, omega, xi)
        return R, J

    def force_scale(self, a):
        """Force scale (N) of the HBM rows at modal amplitude ``a``: the largest modal inertia force
        ``omega_0^2 max |M phi| a``, at least the largest friction bound."""
        return max(self._force_per_a * a, self._bound)

    def residual_scale(self, y, lam):
        """Per-row scale: the force scale (N) on the HBM rows, ``a`` (kg^1/2 m) on the two amplitude rows."""
        a = float(self.a_ref * np.exp(lam))
        s = np.full(self.n_unknowns, self.force_scale(a))
        s[self.n_x:] = a
        return s

    def unknown_scale(self, y, lam):
        """Per-unknown scale: the largest coefficient (m), ``omega`` (rad/s) for ``omega`` and ``xi``."""
        x = y[:self.n_x]
        a = float(self.a_ref * np.exp(lam))
        sx = max(float(np.max(np.abs(x))) if x.size else 0.0, a * float(np.max(np.abs(self.phi))))
        w = np.full(self.n_unknowns, sx)
        w[-2:] = abs(float(y[-2]))
        return w

    # ------------------------------------------------------------------ a converged point
    def point(self, y, lam, dofs):
        """The physical quantities of a converged point (:class:`mshbm.backbone.BackbonePoint` fields)."""
        from ..extrema import fourier_extrema
        from .. import fourier

        x, omega, xi = y[:self.n_x], float(y[-2]), float(y[-1])
        p = self.hbm(omega, xi)
        R = p.residual(x, jac=False)[0]
        a = float(self.a_ref * np.exp(lam))
        q_hat = p.full_coefficients(x)
        hi, lo = fourier_extrema(q_hat[:, dofs])
        Fs = self.force_scale(a)
        # energy balance (mean power, W): xi <q', M q'> = <q', C q'> - <gamma, lambda> (Parseval; AFT samples)
        U = fourier.derivative(q_hat, omega)
        Mx, Cx = self.system.M, self.system.C
        P_M = 0.5 * sum(float(U[i] @ (Mx @ U[i])) for i in range(1, U.shape[0]))
        P_C = 0.5 * sum(float(U[i] @ (Cx @ U[i])) for i in range(1, U.shape[0]))
        parts = p.solution_parts(x)
        u_s = fourier.ifft(U, self.Ns)
        P_nl = -sum(float(np.mean(el.local(u_s) * parts["lam"][:-1, j])) for j, el in enumerate(self.system.elements))
        # dissipated powers; floor: 1e-12 of the reactive power omega <q', M q'> (a conservative mode dissipates 0)
        P_ref = max(abs(xi) * P_M, abs(P_C), abs(P_nl), 1e-12 * omega * P_M, 1e-300)
        Q = q_hat[1::2] - 1j * q_hat[2::2]  # complex harmonics 1..n_h, (n_h, n)
        r = self.ref_dof
        return dict(modal_amplitude=a, omega=omega, xi=xi, damping_ratio=xi / (2 * omega),
                    amplitude=0.5 * (hi - lo), harmonics=np.abs(Q[:, r]).tolist(),
                    residual_N=float(np.max(np.abs(R))), residual=float(np.max(np.abs(R))) / Fs,
                    amplitude_residual=float(np.max(np.abs(self._amp_rows(p, x, a)))) / a,
                    energy_balance=abs(xi * P_M - P_C - P_nl) / P_ref,
                    truncation=float(np.abs(Q[-1, r]) / max(np.abs(Q[0, r]), 1e-300)), q_hat=q_hat)
