"""Mixed shooting-harmonic balance (MS-HBM), Sections 3.2 and 3.3 of the paper.

Section 3.2 (``method="mshbm"``): subsystems ``N`` (nonlinear, time domain) and
``L`` (linear, harmonic).  Unknowns ``x = (q_hat_N, q_N(0), u_N(0))`` (eq. 26).
The linear subsystem follows from eq. (22),
``q_hat_L = H_LL^-1 (f_hat_ex,L - H_LN q_hat_N)``, condensed per harmonic.
``q_N(t)`` is integrated by Moreau-Jean under eq. (25) with the sign of the
forcing as in eq. (6)::

    M_NN q_N'' + C_NN q_N' + K_NN q_N = f_ex,N(t) - V(t)^T H_NL q_hat_L + f_nl,N

(the paper's eq. 25 prints ``- f_ex,N``; eq. 6 requires ``+``).  Residual (27)::

    R = (q_hat_N - FFT(q_N(t)), q_N(T) - q_N(0), u_N(T) - u_N(0))

Section 3.3 (``method="mshbm-intermediate"``): subsystems 1 (nonlinear, time
domain), 2 (intermediate, harmonic unknowns) and 3 (condensed, eq. 35); needs
``M_13 = C_13 = K_13 = 0``.  Unknowns ``x = (q_hat_2, q_1(0), u_1(0))`` (eq. 38),
residual (39)::

    R = (H_21 FFT(q_1) + (H_22 - H_23 H_33^-1 H_32) q_hat_2 - f_hat_2 + H_23 H_33^-1 f_hat_3,
         q_1(T) - q_1(0), u_1(T) - u_1(0))

with ``q_1(t)`` integrated under eq. (37).

In both variants the time-domain forcing of the integrated subsystem is affine in the harmonic
unknowns, ``f(t) = f_ex(t) + V(t)^T c`` with ``c = c0 + Tr p``: one period of the integrator
(:mod:`mshbm.integrators.interface`, ``integrator="moreau"`` or ``"event"``) gives ``q_1(T), u_1(T)``,
``FFT(q_1)`` and, for the exact Jacobian (``jacobian="exact"``), their sensitivities with respect to
``(q_1(0), u_1(0), p)``; forward differences are available (``jacobian="fd"``, the paper's choice).
Moreau-Jean: forward sensitivities of the steps, blockwise where the subsystem falls apart into
independent blocks (:class:`mshbm.integrators.subsystem.SubsystemStepper`).  The event-driven flow: the
coupling coefficients are forcing states of the flow, the sensitivities to ``p`` columns of its
saltation-corrected monodromy and ``FFT(q_1)`` the exact Fourier coefficients of the flow, so the only
error left is the harmonic truncation of the coupling (:mod:`mshbm.integrators.event.period`).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import fourier
from .base import Partition, PeriodicProblem, forward_difference_jacobian, section_limits
from .common import complement, failed_parts, guess_parts
from ..errors import InputError
from ..extrema import fourier_extrema
from ..scaling import displacement_floor, force_scale, velocity_scale
from ..condensation import Condensation, condense_around_resonances, resonance_note
from .mass_coupling import impact_compliance, mass_decoupling
from ..integrators.registry import make_integrator
from ..integrators.subsystem import submatrix
from .stuck_gauge import centred_member

__all__ = ["MixedProblem", "IntermediateProblem", "StandardAsIntermediate", "auto_intermediate_partition",
           "intermediate_problem"]


def _coupling(system, r, c, n_h, omega):
    """Complex per-harmonic blocks ``H_rc,k``, shape (n_h+1, len(r), len(c))."""
    out = np.zeros((n_h + 1, len(r), len(c)), dtype=complex)
    Ms, Cs, Ks = (submatrix(getattr(system, a), r, c) for a in "MCK")
    dense = lambda A: A.toarray() if sp.issparse(A) else A
    Ms, Cs, Ks = dense(Ms), dense(Cs), dense(Ks)
    for k in range(n_h + 1):
        out[k] = Ks - (k * omega) ** 2 * Ms + 1j * k * omega * Cs
    return out


class _MixedBase(PeriodicProblem):
    """What both MS-HBM variants share: unknowns ``x = (p, q_1(0), u_1(0))`` with the harmonic
    unknowns ``p`` (coefficients of the DOFs ``_harm``) and the states of the time-stepped DOFs
    ``_time``; residual ``(balance(FFT(q_1), p), q_1(T) - q_1(0), u_1(T) - u_1(0))``.  Subclasses set
    ``_time``, ``_harm``, ``_cond_dofs``, ``cond``, ``nc``, the balance hooks and (:meth:`_setup_integrator`)
    the ``integrator`` of the time-stepped DOFs."""

    # -- declared representation (mshbm.methods.base contract), read by the certificate
    harmonic_truncation = True
    time_integrated_subset = True
    # --
    supports_event_integrator = True  # solve-route capabilities (mshbm.methods.base)
    explicit_continuation = True

    @property
    def n_unknowns(self):
        return self.nc * self._harm.size + 2 * self.nA

    @property
    def steps(self):
        return self.integrator.steps

    @property
    def time_step(self):
        return self.integrator.time_step

    @property
    def cheap_jacobian(self):
        """The integrator's run with sensitivities costs little more than without (the event-driven flow)
        and the Jacobian is exact: Newton evaluates the full step with its Jacobian
        (:func:`mshbm.solvers.newton.newton`; the iterates do not change)."""
        return self.integrator.cheap_sensitivities and self.jacobian == "exact"

    def _setup_integrator(self, integrator, system, dofs, c0, Tr, steps, theta, project, accumulation="moreau"):
        """The integrator of the time-domain subsystem ``dofs`` driven by the coupling force
        ``c = c0 + Tr p`` (:mod:`mshbm.integrators.interface`)."""
        self.integrator = make_integrator(integrator, system, self.omega, steps, dofs=dofs, coupling=(c0, Tr),
                                          harmonics=self.n_h, theta=theta, project=project,
                                          accumulation=accumulation)
        self.nA = self.integrator.n  # integrated: the time-stepped DOFs, then one slider per Jenkins element

    def event_signature(self, x):
        """``((element, kind), ...)`` of the events of the period from ``x`` (event-driven flow), else ``None``."""
        p, q0, u0 = self._split(np.asarray(x, dtype=float))
        return self.integrator.event_signature(q0, u0, p)

    def partition(self):
        return Partition(time=self._time.copy(), harmonic=self._harm.copy(), condensed=self._cond_dofs.copy())

    def conditioning(self):
        return self.cond.rcond

    def residual_units(self):
        a, nt = self.nc * self._harm.size, self.nA
        units = np.zeros(self.n_unknowns, dtype=np.int8)
        units[:a] = 2 if self._force_rows else 0
        units[a + nt:] = 1
        return units

    def initial_guess(self, guess=None):
        linear = guess is None or (isinstance(guess, str) and guess == "linear")
        if linear and self.__dict__.get("_linear_guess") is not None:
            # the linear response of the whole structure (a sparse solve per harmonic): once per problem,
            # however many starts of the ladder begin from it
            return self._linear_guess.copy()
        parts = self._linear_parts() if linear else None
        if parts is None:
            q_hat, q0, u0 = guess_parts(guess, self.system, self.omega, self.n_h)
            parts = q_hat[:, self._harm], q0[self._time], u0[self._time]
        q0, u0 = self.integrator.initial_state(parts[1], parts[2])
        x = np.concatenate([parts[0].reshape(-1), q0, u0])
        if linear:
            self._linear_guess = x.copy()
        return x

    def _linear_parts(self):
        """``(q_hat[:, harm], q0[time], u0[time])`` of the linear response, or ``None``: the guess module's
        :func:`mshbm.methods.common.linear_response` of the whole structure then."""
        return None

    def residual_scale(self, x):
        """Per-row scale of the residual at unknowns ``x``, shape ``(n_x,)``: m (3.2) or N (3.3) for
        the harmonic-balance rows, m for the ``q`` rows, m/s for the ``u`` rows."""
        return _mixed_scale(self, x, self.nc * self._harm.size, self.nA, force_rows=self._force_rows)

    def _split(self, x):
        a, nt = self.nc * self._harm.size, self.nA
        return x[:a], x[a:a + nt], x[a + nt:]

    def section_restarts(self, x):
        """``x`` with the time-stepped state extrapolated to ``T`` from before and to ``0`` from after
        (:meth:`PeriodicProblem.section_restarts`)."""
        p, q0, u0 = self._split(np.asarray(x, dtype=float))
        run = self.integrator.run(q0, u0, p, record=True)
        if run.failed:
            return []
        out = [np.concatenate((p,) + section_limits(run, k)) for k in (-1, 0)]
        return [z for z in out if z.size == p.size + q0.size + u0.size]

    def residual(self, x, jac=True):
        """``(R, J)``, shapes ``(n_x,)`` and ``(n_x, n_x)``."""
        x = np.asarray(x, dtype=float)
        p, q0, u0 = self._split(x)
        run = self.integrator.run(q0, u0, p, sensitivities=jac and self.jacobian == "exact")
        if run.failed:
            return np.full(x.size, np.nan), (np.full((x.size, x.size), np.nan) if jac else None)
        nt, a = self.nA, self.nc * self._harm.size
        R = np.concatenate([self._balance(run.q_hat, p), run.end[:nt] - q0, run.end[nt:] - u0])
        if not jac:
            return R, None
        if self.jacobian == "fd":
            return R, forward_difference_jacobian(lambda xp: self.residual(xp, False)[0], x, R)
        # integrator columns: [q0 (nA), u0 (nA), p (a)] -> reorder to x = [p, q0, u0]
        perm = np.concatenate([np.arange(2 * nt, 2 * nt + a), np.arange(2 * nt)])
        J = np.zeros((x.size, x.size))
        J[:a] = self._balance_dq(run.q_hat_jacobian[:, perm])
        J[:a, :a] += self._balance_dp()
        J[a:] = run.jacobian[:, perm]
        J[a:, a:] -= np.eye(2 * nt)
        return R, J

    def family_gauge(self, x, F):
        """The member of the family of solutions through ``x`` (free directions ``F``) whose friction elements that
        stick the whole period have centred forces (:func:`mshbm.methods.stuck_gauge.centred_member`), or None."""
        def forces(xx):
            p, q0, u0 = self._split(np.asarray(xx, dtype=float))
            run = self.integrator.run(q0, u0, p, record=True)
            if run.failed or run.forces is None or run.status is None:
                return None
            return run.forces[:-1], run.status

        return centred_member(forces, x, F)

    def solution_parts(self, x):
        x = np.asarray(x, dtype=float)
        p, q0, u0 = self._split(x)
        ig, n1 = self.integrator, self._time.size
        run = ig.run(q0, u0, p, record=True)
        if run.failed:  # no flow to report: non-finite parts, which the driver reports as a failure, with why
            return failed_parts(ig.t, ig.steps, (self.nc, self.system.n), self._time, len(self.system.elements),
                                self.n_h, f"the event-driven flow failed at the solution: {run.error}")
        X = p.reshape(self.nc, self._harm.size)
        q_hat = np.zeros((self.nc, self.system.n))
        q_hat[:, self._time] = ig.coefficients(run, self.n_h)
        if not self._harmonic_dofs_are_time_dofs:
            q_hat[:, self._harm] = X
        if self._cond_dofs.size:
            q_hat[:, self._cond_dofs] = fourier.from_complex(self.cond.recover(fourier.to_complex(X)))
        if getattr(self, "decoupling", None) is not None:  # y -> q (MixedProblem with a consistent mass)
            q_hat = self.decoupling.to_original(q_hat)
        info = self._info(p, q_hat)
        if run.extrema is not None:  # the time DOFs' true extrema from the integrator
            hi, lo = fourier_extrema(q_hat)
            hi[self._time], lo[self._time] = run.extrema
            info["amplitude_exact"] = 0.5 * (hi - lo)
        info.update(ig.solution_info(run))
        return dict(t=ig.t, q_hat=q_hat, time_dofs=self._time, q_time=run.q[:, :n1], u_time=run.u[:, :n1],
                    lam=run.forces, impulses=run.impulses, harmonics=self.n_h, info=info)


class MixedProblem(_MixedBase):
    """MS-HBM with a linear and a nonlinear subsystem (Section 3.2).

    Parameters
    ----------
    system : System
    omega : float
    harmonics : int
        ``n_h``.
    steps : int
        Moreau-Jean steps per period (``> 2 n_h``).
    theta : float
    jacobian : {"exact", "fd"}
    partition : array of int, optional
        DOFs of ``N`` (default: the DOFs carrying elements).
    project : bool
    integrator : {"moreau", "event"}
        Moreau-Jean time stepping (default) or the exact event-driven flow (module docstring).
    accumulation : {"moreau", "close"}, optional
        With ``integrator="event"``: at an accumulation of impacts switch to Moreau-Jean for that contact
        phase (also handles chattering), or close the contact once the bounces are below ``1e-10`` of the
        scale (the Zeno closure: the flow and its monodromy stay exact up to the dropped tail; chattering is
        then an error) (:mod:`mshbm.integrators.event`).  Default ``"close"`` where the subsystems are
        mass-decoupled (``impact_mass="effective"`` on a consistent mass), else ``"moreau"``: the decoupled
        ``N`` carries the light effective mass, so an impact on a node starts a fast local bounce that
        accumulates into a contact phase every period (the cantilever's tip: ~20 bounces within 1 % of the
        period, at ~100 omega), and the Moreau-Jean segment's step Jacobians neglect the forcing states, whose
        columns are the sensitivities to the harmonic unknowns ``p``: Newton's Jacobian is then wrong (measured
        ``d u_N(T) / d p``: 205 against 0.015 by differences) and Newton stalls.
    impact_mass : {"subsystem", "effective"}, optional
        With a consistent mass (``M_LN != 0``) and a contact: the impacts on ``N`` act with ``M_NN`` (the
        paper's subsystems) or with the effective mass ``1 / (M^-1)_NN`` of the whole structure, the
        subsystems then solved in mass-decoupled coordinates (:mod:`mshbm.methods.mass_coupling`).  Only
        ``"effective"`` converges to the model's orbit as ``n_h`` grows.  Default: ``"effective"`` with the
        event flow, else ``"subsystem"`` (with Moreau-Jean steps the light node found no certified orbit on the
        reduced FE plate), whose effect the solve route estimates (:mod:`mshbm.route.refine`).  The event
        ladder then starts with the exact orbit and the transient (``preferred_starts``; reduced cantilever
        cold: 19.6 s CPU from the linear start, 5.3 s so).

    Residual scale
    --------------
    :meth:`residual_scale` gives Newton's per-row scale: all rows are displacement-like
    (``q_hat_N - FFT(q_N)``, ``q_N(T) - q_N(0)``) except ``u_N(T) - u_N(0)``; they are
    measured against the size ``D = max(D_0, ||q_hat_N||_inf, ||q_N(0)||_inf,
    ||u_N(0)||_inf / omega)`` of the current unknowns (floor ``D_0`` of
    :mod:`mshbm.scaling`) and ``D max(1, omega)`` (:func:`mshbm.scaling.velocity_scale`).
    The guess never enters.
    """

    method = "mshbm"

    # -- declared representation (mshbm.methods.base contract), read by the certificate
    certify_connectivity_work = True
    # --

    def __init__(self, system, omega, harmonics, steps, theta=0.5, jacobian="exact", partition=None,
                 project=True, integrator="moreau", accumulation=None, condensation=None,
                 impact_mass=None):
        system = system.at(omega)  # the forcing at omega (a constant forcing: the same system)
        self.system, self.omega, self.n_h = system, float(omega), int(harmonics)
        self.jacobian = jacobian
        n = system.n
        if impact_mass is None:
            impact_mass = "effective" if integrator == "event" else "subsystem"
        decouple = mass_decoupling if impact_mass == "effective" else (lambda *a: None)
        self.impact_mass = impact_mass
        self.Nd = system.nonlinear_dofs if partition is None else np.asarray(partition, dtype=np.int64)
        if self.Nd.size == 0:
            key = "partition" if partition is not None else "method"
            raise InputError(key, "the nonlinear subsystem is empty: the system has no friction or contact "
                             "element (use 'hbm', or give partition=[dofs] to integrate some DOFs in time)")
        self.Ld = complement(n, self.Nd)
        # impact_mass="effective" with a consistent mass (M_LN != 0): N and L are solved in the mass-decoupled
        # coordinates q = T y, so that impacts on N act with the effective mass (W^T M^-1 W)^-1 of the whole
        # structure (mshbm.methods.mass_coupling)
        if condensation is not None:  # given (nearby, built on the decoupled system of its split): its split
            self.cond, self.Nd, self.Ld = condensation, condensation.keep, condensation.elim
            self.decoupling = decouple(system, self.Nd, self.Ld)
        elif partition is None:
            # a resonance of L (k omega an eigenfrequency of L with N clamped): its DOFs are integrated with N
            # instead of condensed (mshbm.condensation.condense_around_resonances); H_LL is the same in both
            # coordinates, so the moves are too
            self.decoupling = decouple(system, self.Nd, self.Ld)
            ysys = system if self.decoupling is None else self.decoupling.system
            self.cond, Nd, Ld, moved = condense_around_resonances(ysys, omega, self.n_h, self.Nd, self.Ld)
            if moved:
                self.notes = [resonance_note(moved, "H_LL", "the time-integrated subsystem N")]
                self.Nd, self.Ld = Nd, Ld
                self.decoupling = decouple(system, self.Nd, self.Ld)
                if self.decoupling is not None:
                    self.cond = Condensation(self.decoupling.system, omega, self.n_h, self.Nd, self.Ld)
        else:
            self.decoupling = decouple(system, self.Nd, self.Ld)
            ysys = system if self.decoupling is None else self.decoupling.system
            self.cond = Condensation(ysys, omega, self.n_h, self.Nd, self.Ld)
        ysys = self.integrated_system
        # coupling force coefficients on N:  c = -H_NL q_hat_L = -g + T q_hat_N
        c0 = fourier.from_complex(-self.cond.g).reshape(-1)
        Tr = self.cond.real_matrix(self.cond.T)
        if accumulation is None:
            accumulation = "close" if (self.decoupling is not None and integrator == "event") else "moreau"
        if self.decoupling is not None and integrator == "event":
            self.preferred_starts = ("exact", "transient")
        self._setup_integrator(integrator, ysys, self.Nd, c0, Tr, steps, theta, project, accumulation)
        self.nN = self.Nd.size
        self.nc = 2 * self.n_h + 1
        self._time, self._harm, self._cond_dofs = self.Nd, self.Nd, self.Ld

    def nearby(self, omega):
        """The problem at ``omega`` a finite-difference step away with the condensation of ``L`` moved to
        ``omega`` to first order (:meth:`mshbm.condensation.Condensation.shifted`, the exact slope of ``T`` and
        ``g``): on a large sparse ``L`` a condensation costs several LU solves per harmonic and the integrator
        of ``N`` almost nothing, and the difference to :meth:`rebuilt` is ``O((omega - self.omega)^2)``.
        :meth:`rebuilt` where the condensation has no slope (the dense path, which is cheap)."""
        cond = None if self.system.omega_dependent else self.cond.shifted(float(omega) - self.omega)
        if cond is None:  # (the shift moves T and g, not a forcing that depends on omega)
            return self.rebuilt(omega)
        p = type(self)(self.system, float(omega), **{**self.build_options, "condensation": cond})
        p.notes = self.notes
        return p

    def impact_masses(self):
        """With ``impact_mass="subsystem"``: the contacts on ``N`` whose impact mass ``1 / (w_N^T M_NN^-1 w_N)``
        differs (relatively, by more than 1e-9) from the structure's ``1 / (w^T M^-1 w)`` (a consistent mass,
        ``M_LN != 0``): ``[(j, m_model, m_used)]``."""
        if getattr(self, "impact_mass", "subsystem") != "subsystem" or self.Ld.size == 0:
            return []
        contacts = [(j, el) for j, el in enumerate(self.system.elements) if el.unilateral]
        if not contacts:
            return []
        M_LN = submatrix(self.system.M, self.Ld, self.Nd)
        if not (M_LN.nnz if sp.issparse(M_LN) else np.count_nonzero(M_LN)):
            return []
        used, model = impact_compliance(self.system, self.Nd), impact_compliance(self.system)
        out = []
        for j, el in contacts:
            c_used = used.of(el)
            if c_used is None:  # a DOF of the contact is not integrated in time
                continue
            m_used, m_model = 1.0 / c_used, 1.0 / model.of(el)
            if abs(m_used - m_model) > 1e-9 * abs(m_model):
                out.append((j, m_model, m_used))
        return out

    @property
    def integrated_system(self):
        """The system the subsystems are solved in: the mass-decoupled one (:attr:`decoupling`) or ``system``."""
        return self.system if self.decoupling is None else self.decoupling.system

    def recovery_matrix(self, k):
        """``Z_k`` of ``X_L = z_k - Z_k X_N`` in the user's coordinates, complex, shape ``(n_L, n_N)``."""
        Z = self.cond.Z[int(k)] if self.Ld.size else np.zeros((0, self.nN), complex)
        return Z if self.decoupling is None else Z + self.decoupling.A

    # the mixed residual (27): harmonic-balance rows of N are the connectivity q_hat_N - FFT(q_N)
    _force_rows = False
    _harmonic_dofs_are_time_dofs = True

    def _balance(self, qh, p):
        return p - qh

    def _balance_dq(self, dqh):
        return -dqh

    def _balance_dp(self):
        return np.eye(self.nc * self.nN)

    def _linear_parts(self):
        """The linear response (no elements) on ``N`` from the condensation: per harmonic
        ``X_N = (H_NN - T_k)^-1 (F_N - g_k)`` (:meth:`mshbm.condensation.Condensation.solve_full`), equal to
        the ``N`` rows of the whole structure's steady state without a solve of size ``n``; a singular
        harmonic is set to zero as in :func:`mshbm.methods.common.linear_response`."""
        H_NN = _coupling(self.integrated_system, self.Nd, self.Nd, self.n_h, self.omega)
        F = fourier.to_complex(self.integrated_system.forcing_hat(self.n_h, self.omega))[:, self.Nd]
        X = np.zeros((self.n_h + 1, self.nN), dtype=complex)
        for k in range(self.n_h + 1):
            if not (np.any(F[k]) or np.any(self.cond.g[k])):
                continue
            try:
                x, _ = self.cond.solve_full(k, H_NN[k], F[k]) if self.cond.elim.size else \
                    (np.linalg.solve(H_NN[k], F[k]), None)
            except np.linalg.LinAlgError:
                continue
            if np.all(np.isfinite(x)):
                X[k] = x
        q_hat = fourier.from_complex(X)
        q0 = q_hat[0] + q_hat[1::2].sum(axis=0)  # V(0)^T q_hat, as mshbm.methods.common.guess_parts
        u0 = fourier.derivative(q_hat, self.omega)[1::2].sum(axis=0)
        return q_hat, q0, u0

    def linear_solve(self, k, b_T, forcing=True):
        """``H_k x = b`` (``b = b_T`` on ``N``, ``F_k`` or zero on ``L``) from the condensation of ``L``:
        ``x_N = (H_NN - T_k)^-1 (b_N - g_k)``, ``x_L = z_k - Z_k x_N`` (no solve of size ``n``); complex,
        shape ``(n,)``.  Raises ``numpy.linalg.LinAlgError`` where ``H_NN - T_k`` is singular."""
        if not 0 <= int(k) <= self.n_h:
            return None
        if "_H_NN" not in self.__dict__:
            self._H_NN = _coupling(self.integrated_system, self.Nd, self.Nd, self.n_h, self.omega)
        x = np.empty(self.system.n, dtype=complex)
        if self.decoupling is not None and forcing:  # (T^T b)_N with b_L = F_L
            b_T = self.decoupling.forcing_on_keep(np.asarray(b_T), self.cond.F[int(k), self.Ld])
        x[self.Nd], x[self.Ld] = self.cond.solve_full(int(k), self._H_NN[int(k)], b_T, forcing)
        return x if self.decoupling is None else self.decoupling.to_original(x)

    def _info(self, p, q_hat):
        return {"connectivity_defect": float(np.max(np.abs(p - q_hat[:, self.Nd].reshape(-1)), initial=0.0))}


def _mixed_scale(problem, x, a, n1, force_rows):
    """Row scales ``(coefficient rows (a), q rows (n1), u rows (n1))`` of the mixed residuals."""
    if "_FD0" not in problem.__dict__:
        F = force_scale(problem.system)
        problem._FD0 = (F, displacement_floor(problem.system, problem.omega, F))
    F, D0 = problem._FD0
    w = problem.omega
    p, q0, u0 = np.abs(x[:a]), np.abs(x[a:a + n1]), np.abs(x[a + n1:])
    umax = float(np.max(u0, initial=0.0))
    D = max(D0, float(np.max(p, initial=0.0)), float(np.max(q0, initial=0.0)), umax / w)
    return np.concatenate([np.full(a, F if force_rows else D), np.full(n1, D), np.full(n1, velocity_scale(D, w))])


def auto_intermediate_partition(system):
    """Default subsystems of Section 3.3: 1 = element DOFs, 2 = DOFs coupled to 1, 3 = the rest."""
    I1 = system.nonlinear_dofs
    coupled = set()
    for A in (system.M, system.C, system.K):
        rows = A.tocsr()[I1] if sp.issparse(A) else sp.csr_matrix(np.asarray(A)[I1])
        coupled.update(int(c) for c in sp.find(rows)[1])
    I2 = np.array(sorted(coupled - set(int(i) for i in I1)), dtype=np.int64)
    return I1, I2


class IntermediateProblem(_MixedBase):
    """MS-HBM with an intermediate subsystem (Section 3.3).

    Parameters
    ----------
    system : System
    omega : float
    harmonics, steps, theta, jacobian, project, integrator, accumulation :
        As for :class:`MixedProblem`.
    partition : (array of int, array of int), optional
        DOFs of subsystems 1 and 2 (subsystem 3 is the rest); default
        :func:`auto_intermediate_partition`.

    Residual scale
    --------------
    :meth:`residual_scale` gives Newton's per-row scale: the harmonic balance rows of
    subsystem 2 are forces, measured against the force scale ``F`` of the problem
    (:func:`mshbm.scaling.force_scale`); the periodicity rows against the size ``D``
    of the current unknowns (``q_hat_2``, ``q_1(0)``, ``u_1(0) / omega``, floored by
    ``D_0``) and ``D max(1, omega)``.  The guess never enters.
    """

    method = "mshbm-intermediate"
    force_row_unknowns = property(lambda self: self.nc * self.n2)  # solve-route capability (mshbm.methods.base)

    def __init__(self, system, omega, harmonics, steps, theta=0.5, jacobian="exact", partition=None,
                 project=True, integrator="moreau", accumulation="moreau", condensation=None):
        system = system.at(omega)  # the forcing at omega (a constant forcing: the same system)
        self.system, self.omega, self.n_h = system, float(omega), int(harmonics)
        self.jacobian = jacobian
        n = system.n
        if partition is None:
            I1, I2 = auto_intermediate_partition(system)
        else:
            try:
                I1, I2 = (np.asarray(p, dtype=np.int64).reshape(-1) for p in partition)
            except (TypeError, ValueError):
                raise InputError("partition", "must be a pair (dofs_1, dofs_2)") from None
        if I1.size == 0:
            key = "partition" if partition is not None else "method"
            raise InputError(key, "subsystem 1 is empty: the system has no friction or contact element "
                             "(use 'hbm', or give partition=(dofs_1, dofs_2))")
        if I2.size == 0:
            raise InputError("partition", "subsystem 2 is empty: nothing couples subsystem 1 to the rest; "
                             "use 'mshbm'")
        if np.intersect1d(I1, I2).size or I1.min() < 0 or I2.min() < 0 or max(I1.max(), I2.max()) >= n:
            raise InputError("partition", "subsystems 1 and 2 must be disjoint DOF sets within range")
        I3 = np.setdiff1d(np.arange(n), np.concatenate([I1, I2]))
        for a in "MCK":
            blk = submatrix(getattr(system, a), I1, I3)
            nz = blk.nnz if sp.issparse(blk) else np.count_nonzero(blk)
            if I3.size and nz:
                raise InputError("partition", f"{a}_13 must vanish for Section 3.3 (subsystem 1 couples to 3)")
        if partition is None:
            # a resonance of subsystem 3 (k omega an eigenfrequency of H_33): its DOFs become harmonic unknowns of
            # subsystem 2 instead of being condensed (mshbm.condensation.condense_around_resonances); subsystem 3
            # only shrinks, so M_13 = C_13 = K_13 = 0 still holds
            self.cond, I2, I3, moved = condense_around_resonances(system, omega, self.n_h, I2, I3, name="H_33")
            if moved:
                self.notes = [resonance_note(moved, "H_33", "subsystem 2 (harmonic unknowns)")]
        else:
            self.cond = Condensation(system, omega, self.n_h, I2, I3, name="H_33")
        self.I1, self.I2, self.I3 = I1, I2, I3
        nc = 2 * self.n_h + 1
        H12 = _coupling(system, I1, I2, self.n_h, omega)
        H21 = _coupling(system, I2, I1, self.n_h, omega)
        H22 = _coupling(system, I2, I2, self.n_h, omega)
        # force on subsystem 1: f_ex,1 - V^T H_12 q_hat_2   -> c = -H12r p
        Tr = -self.cond.real_matrix(H12)
        self._setup_integrator(integrator, system, I1, np.zeros(nc * I1.size), Tr, steps, theta, project,
                               accumulation)
        self.H21r = self.cond.real_matrix(H21)
        self.Sr = self.cond.real_matrix(H22 - self.cond.T)
        F = fourier.to_complex(system.forcing_hat(self.n_h, self.omega))
        self.rhs = fourier.from_complex(F[:, I2] - self.cond.g).reshape(-1)
        self.nc, self.n1, self.n2 = nc, I1.size, I2.size
        self._time, self._harm, self._cond_dofs = I1, I2, I3

    # residual (39): harmonic-balance rows of subsystem 2 are forces
    _force_rows = True
    _harmonic_dofs_are_time_dofs = False

    def _balance(self, qh, p):
        return self.H21r @ qh + self.Sr @ p - self.rhs

    def _balance_dq(self, dqh):
        return self.H21r @ dqh

    def _balance_dp(self):
        return self.Sr

    def force_rows(self):
        """``(G, S)``: ``G_i = sum_j |H_21,ij|`` per harmonic-balance row (eq. 39: the rows depend on ``FFT(q_1)``
        through ``H_21``), shape ``((2 n_h + 1) n_2,)``, and ``S = H_22 - H_23 H_33^-1 H_32`` (real block form),
        shape ``((2 n_h + 1) n_2, (2 n_h + 1) n_2)``, both N/m."""
        return np.abs(self.H21r).sum(axis=1), self.Sr

    def _info(self, p, q_hat):
        return {}


class StandardAsIntermediate(MixedProblem):
    """``method="mshbm-intermediate"`` where the default subsystem 2 is empty: no DOF outside subsystem 1
    couples to it (``M_1j = C_1j = K_1j = 0`` for every ``j`` not in 1), so eq. (39) has no harmonic unknowns
    and subsystem 3 is all of the linear DOFs.  Subsystem 1 is then driven by its own forcing alone, and the
    equations of Section 3.3 are those of Section 3.2 with ``N`` = subsystem 1, ``L`` = subsystem 3: this
    problem is :class:`MixedProblem` (unknowns ``(q_hat_N, q_N(0), u_N(0))``, residual (27)), reported under
    the requested method with a note in ``info["notes"]`` and the message."""

    method = "mshbm-intermediate"
    force_row_unknowns = property(lambda self: self.nc * self.n2)  # solve-route capability (mshbm.methods.base)

    # -- declared representation (mshbm.methods.base contract), read by the certificate: reported as the
    # intermediate variant, its certificate has no connectivity_work check
    certify_connectivity_work = False
    # --

    def __init__(self, system, omega, harmonics, steps, theta=0.5, jacobian="exact", project=True,
                 integrator="moreau"):
        super().__init__(system, omega, harmonics, steps, theta=theta, jacobian=jacobian, partition=None,
                         project=project, integrator=integrator)
        self.n2 = self.nN  # harmonic unknowns (of N here), as IntermediateProblem.n2
        self.notes = ["subsystem 2 is empty (nothing couples subsystem 1 to the rest): the intermediate variant "
                      "(Section 3.3) is the standard MS-HBM (Section 3.2) here and was solved as such"] \
            + list(self.notes)


def intermediate_problem(system, omega, harmonics, steps, theta=0.5, jacobian="exact", partition=None,
                         project=True, integrator="moreau"):
    """The problem of ``method="mshbm-intermediate"``: :class:`IntermediateProblem`, or
    :class:`StandardAsIntermediate` when the default partition (:func:`auto_intermediate_partition`) has
    an empty subsystem 2 (an explicit ``partition`` with an empty subsystem 2 stays an ``InputError``)."""
    if partition is None:
        I1, I2 = auto_intermediate_partition(system)
        if I1.size and I2.size == 0:
            return StandardAsIntermediate(system, omega, harmonics, steps, theta=theta, jacobian=jacobian,
                                          project=project, integrator=integrator)
    return IntermediateProblem(system, omega, harmonics, steps, theta=theta, jacobian=jacobian, partition=partition,
                               project=project, integrator=integrator)
