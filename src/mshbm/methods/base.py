"""The problem contract: what every method's problem object provides to the solvers.

A *method* (``"shooting"``, ``"hbm"``, ``"dlft"``, ``"mshbm"``, ``"mshbm-intermediate"``) turns
``M q'' + C q' + K q = f_ex(t) + f_nl`` at angular frequency ``omega`` (period ``T = 2 pi / omega``)
into a square nonlinear system ``R(x) = 0`` in its own unknowns ``x`` (Fourier coefficients ``q_hat``
of ``n_h`` harmonics, states ``q(0), u(0)`` at the Poincaré section, or both).  The solvers
(:mod:`mshbm.solvers`: Newton, continuation; :mod:`mshbm.route`: the start ladder, homotopy, the driver)
see a method only through :class:`PeriodicProblem`; they never probe for attributes.

Contract (every subclass)
-------------------------
``method`` : str
    The registry name.
``system``, ``omega``, ``n_h``
    The :class:`mshbm.System`, the angular frequency (rad/s) and the number of harmonics.
``n_unknowns`` : int
    ``n_x``, the size of ``x``.
``initial_guess(guess) -> x``
    ``guess``: ``None`` or ``"linear"`` (linear response), ``"zero"``, a
    :class:`mshbm.PeriodicSolution` (e.g. at a nearby frequency) or a dict with ``q_hat``, ``q0``,
    ``u0``.  Returns ``x``, shape ``(n_x,)``.
``residual(x, jac=True) -> (R, J)``
    ``R`` shape ``(n_x,)``; ``J = dR/dx`` shape ``(n_x, n_x)`` (dense or sparse), ``None`` when
    ``jac=False``.
``residual_scale(x) -> s``
    Per-row scale (physical units: N, m, m/s) of Newton's test ``||R / s||_inf <= tol``
    (:mod:`mshbm.scaling`); depends on the current unknowns, never on the start.
``omega_derivative(x) -> dR/domega``
    Shape ``(n_x,)``, at fixed unknowns (their meaning does not change with omega: coefficients, or
    states at ``t = 0`` with a fixed number of steps per period).  Default: central differences of
    problems at ``omega (1 +- 1e-6)`` (``nearby(omega)``: rebuilt, or a cheaper copy whose residual differs
    by ``O(d^2)``, e.g. MS-HBM's with its sparse condensation moved by its exact slope); what frequency
    continuation needs besides ``J``.
    Where a difference crosses a change of the orbit's event sequence (``event_signature``), the
    one-sided difference on the side of the same sequence is taken.
``solution_parts(x) -> dict``
    Keys ``t`` (N+1,), ``q_hat`` (2 n_h + 1, n), ``time_dofs`` (n_t,), ``q_time``, ``u_time``
    (N+1, n_t), ``lam`` (N+1, n_el) (element forces, N), ``impulses``, ``harmonics`` and ``info``.
``partition() -> Partition``
    The DOF sets of the method as named index arrays (same names for every method).
``residual_units() -> ndarray``
    Per-row physical unit of ``R``, shape ``(n_x,)``: 0 displacement (m), 1 velocity (m/s), 2 force (N).
``time_step`` : float or None
    The Moreau-Jean step ``h = T / N`` of the time-stepped DOFs (``None``: no time stepping).
``steps`` : int
    Samples per period: Moreau-Jean steps ``N``, or the AFT samples of HBM/DLFT.
``integrator`` : PeriodIntegrator or None
    The integrator of the time-stepped DOFs (:mod:`mshbm.integrators.interface`; ``None``: no time
    integration); its ``stepper`` (the Moreau-Jean stepper, ``None`` for the event-driven flow) serves
    the certificate's energy balance and the step-accuracy bound.

Optional capabilities (declared here with their "not available" default, overridden where a method
has them)
-----------------------------------------------------------------------------------------------------
``homotopy() -> list[PeriodicProblem]``
    Problems with softened laws ending with ``self`` (each solution starts the next); ``[]``: none.
``path_fallback() -> callable or None``
    An exact solution-path follower used when Newton fails,
    ``f(x0, failed, tol=, scale=, max_iter=, callback=) -> NewtonResult or None``; ``None``: none.
``conditioning() -> ndarray or None``
    Reciprocal condition numbers of the condensed per-harmonic blocks, shape ``(n_h + 1,)``.
``linear_solve(k, b_T, forcing) -> ndarray or None``
    The linear structure's harmonic-``k`` response ``x`` (complex, shape ``(n,)``) to ``H_k x = b``, with
    ``b = b_T`` on the time-stepped DOFs (``partition().time``) and the forcing harmonic ``F_k``
    (``forcing=True``) or zero elsewhere, from the method's own factorisations (MS-HBM: its condensation
    of ``L``); ``None``: not available (the caller solves ``H_k`` itself).
``preferred_starts`` : tuple of str (default ``()``)
    Starts of the start ladder (:mod:`mshbm.route.ladder`) tried first, right after the caller's guess (MS-HBM
    with mass-decoupled subsystems and the event flow: the exact orbit and the transient).
``integrated_system`` : System (default ``system``)
    The system whose blocks on ``partition().time`` the time-stepped DOFs are integrated with (MS-HBM with
    ``impact_mass="effective"`` and a consistent mass: the mass-decoupled system, :mod:`mshbm.methods.mass_coupling`).
``notes`` : tuple or list of str (default ``()``)
    Sentences on how the problem was set up differently from what was asked (e.g. DOFs at a resonance
    of the condensed block kept as unknowns, :func:`mshbm.condensation.condense_around_resonances`); the
    driver appends them to the message and puts them in ``info["notes"]``.
``force_rows() -> (G, S) or None``
    For residual rows that are forces driven by the Fourier coefficients ``c`` of the time-stepped DOFs
    (MS-HBM Section 3.3: ``H_21 FFT(q_1) + S q_hat_2 - f``): per such row ``G_i = sum_j |dR_i / dc_j|``
    (N/m), shape ``(n_f,)`` in row order, and the square block ``S = dR_f / dp`` (N/m, ``(n_f, n_f)``) of
    the harmonic unknowns ``p``, whose inverse turns a force residual into the displacement error it
    causes (the start ladder's one-step accuracy test at impacts); ``None``: none.
``cheap_jacobian`` : bool (default False)
    The Jacobian costs little more than ``R`` (HBM, DLFT), or the full step is nearly always taken (MS-HBM
    with the event-driven flow): Newton evaluates the full step with it and keeps it when the step is
    taken; the iterates do not change.

Declared representation (class attributes; the certificate, :mod:`mshbm.certificate`, reads them instead of
the method's name)
-----------------------------------------------------------------------------------------------------------
``fourier_all_dofs`` : bool (default False)
    Every DOF is a truncated Fourier series and the element laws act at the ``steps`` AFT samples (HBM,
    DLFT): the time series are periodic by construction, the energy balance is Parseval's plus the AFT
    quadrature of the element work, and no time step bounds the checks.
``penalty_contact`` : bool (default False)
    Contacts obey the regularised penalty law (``penalty_stiffness``, ``penalty_damping`` of the elements;
    HBM): the force scale includes the penalty, and the penetration the law needs is allowed.
``penalty_quadrature`` : str or None (default None)
    With ``penalty_contact``: ``"samples"`` or ``"linear"`` (:mod:`mshbm.methods.hbm`); ``None`` otherwise.
``lagrangian_contact`` : bool (default False)
    Contacts hold on a Lagrangian displacement at the AFT samples, not on the truncated series (DLFT): the
    penetration of the series is a truncation error, reported but not gated.
``impact_masses()`` : method (default: none)
    The contacts whose impacts act with another mass than the model implies: a list of ``(j, m_model,
    m_used)`` (element index, the effective mass ``1 / (w^T M^-1 w)`` of the whole structure and the mass the
    method's impact law uses, kg); MS-HBM's default subsystem law on a consistent mass.  The certificate names
    them as a model substitution (:mod:`mshbm.certificate.substitution`).
``hysteresis_aft`` : bool (default False)
    Hysteretic (Jenkins) element forces come from a period march of the AFT samples (HBM's history law): the
    certificate checks that march's periodicity (``hysteresis_periodicity``, :mod:`mshbm.certificate.laws`).
``harmonic_truncation`` : bool (default False)
    Unknowns are Fourier coefficients truncated at ``n_h`` (all methods but shooting): the certificate
    reports the truncation estimates.
``time_integrated_subset`` : bool (default False)
    Only a subset of the DOFs is time-stepped, the others are Fourier series entering the discrete work
    sums on the time grid (both MS-HBM variants): the energy balance allows their quadrature error
    ``(n_h omega h)^2``.
``certify_connectivity_work`` : bool (default False)
    The leading residual rows are MS-HBM's connectivity residual ``q_hat_N - FFT(q_N)`` (Section 3.2), whose
    work on the linear subsystem the certificate subtracts from the energy balance and gates as
    ``connectivity_work``.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .. import condensation, fourier
from ..condensation import Condensation

__all__ = ["PeriodicProblem", "HarmonicProblem", "Partition", "forward_difference_jacobian",
           "central_difference_jacobian", "section_limits"]


@dataclass(frozen=True)
class Partition:
    """The DOF sets of a method, as index arrays (0-based DOFs of the full system).

    ``time``: DOFs integrated in time (shooting: all; MS-HBM: ``N`` or subsystem 1; HBM/DLFT: none).
    ``harmonic``: DOFs whose Fourier coefficients are unknowns (HBM/DLFT: the kept DOFs; MS-HBM 3.2:
    ``N``; 3.3: subsystem 2).  ``condensed``: DOFs eliminated exactly per harmonic (``L``; 3.3:
    subsystem 3).  The same DOF may be both ``time`` and ``harmonic`` (MS-HBM 3.2: ``N``).
    """

    time: np.ndarray
    harmonic: np.ndarray
    condensed: np.ndarray

    def as_dict(self):
        """JSON-ready form: lists of DOFs."""
        return {"time": [int(i) for i in self.time], "harmonic": [int(i) for i in self.harmonic],
                "condensed": [int(i) for i in self.condensed]}


def _dofs(a):
    return np.asarray(a, dtype=np.int64).reshape(-1)


def forward_difference_jacobian(f, x, f0, rel_step=1e-7):
    """Forward-difference Jacobian ``df/dx``, shape ``(f0.size, x.size)``: column ``i`` is
    ``(f(x + d e_i) - f0) / d`` with ``d = rel_step max(1, |x_i|)``.  The one finite-difference
    Jacobian of the package (``jacobian="fd"`` of shooting and both MS-HBM variants)."""
    J = np.empty((np.size(f0), x.size))
    for i in range(x.size):
        d = rel_step * max(1.0, abs(x[i]))
        xp = x.copy()
        xp[i] += d
        J[:, i] = (f(xp) - f0) / d
    return J


def central_difference_jacobian(f, x, rel_step=1e-6):
    """Central-difference Jacobian ``df/dx``: column ``i`` is ``(f(x + d e_i) - f(x - d e_i)) / (2 d)``
    with ``d = rel_step max(1, |x_i|)`` (``jacobian="fd"`` of :func:`mshbm.methods.exact.exact_periodic`)."""
    cols = []
    for i in range(x.size):
        d = rel_step * max(1.0, abs(x[i]))
        xp, xm = x.copy(), x.copy()
        xp[i] += d
        xm[i] -= d
        cols.append((f(xp) - f(xm)) / (2 * d))
    return np.column_stack(cols)


class PeriodicProblem:
    """Base class of the methods' problems; the contract is the module docstring of
    :mod:`mshbm.methods.base`.  Subclasses set ``method``, ``system``, ``omega``, ``n_h`` and
    implement the abstract methods below."""

    method = ""
    #: the Jacobian costs little more than the residual: Newton evaluates its full step with the
    #: Jacobian and keeps it when the step is taken (:func:`mshbm.solvers.newton.newton`)
    cheap_jacobian = False
    #: keyword options the problem was built with (set by :func:`mshbm.methods.registry.build_problem`)
    build_options: dict = {}
    #: sentences on how the problem was set up differently from what was asked (e.g. resonant DOFs kept
    #: instead of condensed); the driver puts them in ``info["notes"]`` and the message
    notes: tuple = ()
    #: the integrator of the time-stepped DOFs (:mod:`mshbm.integrators.interface`), None: no time integration
    integrator = None

    # ------------------------------------------------------------------ declared representation (contract)
    fourier_all_dofs = False
    penalty_contact = False
    penalty_quadrature = None
    lagrangian_contact = False
    harmonic_truncation = False
    hysteresis_aft = False
    time_integrated_subset = False
    preferred_starts = ()

    def impact_masses(self):
        """Contacts whose impacts act with another mass than the model's (see the contract above)."""
        return []

    certify_connectivity_work = False
    # ------------------------------------------------------------------ capabilities read by the solve route
    # (mshbm.route, mshbm.branch, mshbm.period): what differs between the methods, declared by each problem
    # class so that the route never tests a method's name
    #: the unknowns are the full state at ``t = 0`` of a time-stepped period (full shooting)
    full_shooting = False
    #: the period can be integrated by the exact event-driven flow instead of Moreau-Jean steps (option
    #: ``integrator``): the start ladder ends with that fallback for systems with contacts
    supports_event_integrator = False
    #: with a guess, ``continuation=True`` given explicitly opts in to restarts and parameter continuation
    #: (:mod:`mshbm.route.continuation`) before the start ladder
    explicit_continuation = False
    #: the elements' laws are regularised penalty laws (HBM): ``continuation=True`` is the problem's own
    #: homotopy of softened laws (kept in continuation stages), the unknowns are displacement coefficients
    #: scaled by the penalty displacement floor, stability is Hill's (without contacts)
    penalty_laws = False
    #: option values :func:`mshbm.solve` takes by default where :func:`mshbm.sweep`'s default differs (HBM: the
    #: sampled penalty law); a branch traced for a solve's start uses them, so that it follows this problem
    solve_defaults: dict = {}

    @staticmethod
    def refine(kind, system, options):
        """The more accurate model for the error estimate ``kind`` (``"regularisation"``,
        ``"model_substitution"``; :mod:`mshbm.route.refine` refines ``n_h`` and the steps itself): ``(system,
        options)`` to solve next, starting from the current answer, or ``None`` when the method cannot make that
        estimate smaller (the default).  ``options``: the solve's options with the current ``harmonics`` and
        ``steps``."""
        return None

    @property
    def force_row_unknowns(self):
        """Number of leading unknowns that are displacement coefficients balanced by force rows (MS-HBM,
        Section 3.3: ``nc n_2``); their branch scale is the displacement one, not ``residual_scale``."""
        return 0

    # ------------------------------------------------------------------ required
    @property
    def n_unknowns(self):
        raise NotImplementedError

    def initial_guess(self, guess=None):
        raise NotImplementedError

    def residual(self, x, jac=True):
        raise NotImplementedError

    def residual_scale(self, x):
        raise NotImplementedError

    def solution_parts(self, x):
        raise NotImplementedError

    def partition(self):
        raise NotImplementedError

    def residual_units(self):
        raise NotImplementedError

    @property
    def steps(self):
        raise NotImplementedError

    @property
    def time_step(self):
        return None


    def omega_derivative(self, x, rel_step=1e-6):
        """``dR/domega`` at fixed ``x``, shape ``(n_x,)``: central differences of the residuals of
        this method's problems rebuilt at ``omega +- rel_step omega`` (error O(rel_step^2)).

        With an event-driven flow (``event_signature`` not ``None``) the residual is smooth only on one
        event sequence: next to a grazing (an impact or a near miss with zero velocity) one of the two
        differences may see another sequence, and its quotient is then O(1 / rel_step) wrong.  The
        derivative is then the one-sided difference on the side of the same sequence (error
        O(rel_step)); when both sides differ, the step is shortened (by 16, at most three times)."""
        x = np.asarray(x, dtype=float)
        s0 = self.event_signature(x)
        d = rel_step * self.omega
        for _ in range(4):
            pp, pm = self.nearby(self.omega + d), self.nearby(self.omega - d)
            Rp = pp.residual(x, jac=False)[0]
            Rm = pm.residual(x, jac=False)[0]
            if s0 is None:
                break
            same_p, same_m = pp.event_signature(x) == s0, pm.event_signature(x) == s0
            if same_p and same_m:
                break
            if same_p or same_m:
                R0 = self.residual(x, jac=False)[0]
                return (Rp - R0) / d if same_p else (R0 - Rm) / d
            d /= 16.0
        return (Rp - Rm) / (2.0 * d)

    def event_signature(self, x):
        """The sequence of events ``((element, kind), ...)`` of the event-driven flow from ``x`` (optional
        capability of problems with an event-driven flow; ``None``: no such flow, or it failed)."""
        return None

    def section_restarts(self, x):
        """Unknowns of the same orbit with its time-stepped state extrapolated to the end of the period from the
        two samples before it and to its start from the two after it (:func:`section_limits`; list of arrays
        shaped like ``x``; optional capability of problems whose unknowns hold the state at ``t = 0``, ``[]``
        otherwise).  Newton starts across a jump of the unknowns
        along a branch: where an event (an impact) crosses the section ``t = 0`` the state there jumps between
        its values after and before the event, and so do the unknowns, while the orbit moves continuously."""
        return []

    def rebuilt(self, omega):
        """The same problem (system, options) at another frequency."""
        return type(self)(self.system, float(omega), **self.build_options)

    def nearby(self, omega):
        """The problem at a frequency ``omega`` a finite-difference step away, for :meth:`omega_derivative`:
        :meth:`rebuilt`, or a cheaper copy whose residual differs from the rebuilt one's by
        ``O((omega - self.omega)^2)`` (which a central difference cancels)."""
        return self.rebuilt(omega)

    # ------------------------------------------------------------------ optional capabilities
    def homotopy(self):
        """Problems with softened laws ending with ``self``; ``[]``: this method has none."""
        return []

    def path_fallback(self):
        """Exact solution-path follower used when Newton fails, or ``None`` (see the contract)."""
        return None

    def conditioning(self):
        """Reciprocal condition numbers of the condensed blocks per harmonic, or ``None``."""
        return None

    @property
    def integrated_system(self):
        """The system the time-stepped DOFs are integrated with (see the contract)."""
        return self.system

    def linear_solve(self, k, b_T, forcing=True):
        """Harmonic-``k`` response of the linear structure from the method's factorisations, or ``None``
        (see the contract)."""
        return None

    def force_rows(self):
        """``(G, S)`` of the force rows driven by the time-stepped DOFs' coefficients, or ``None`` (see the
        contract)."""
        return None


class HarmonicProblem(PeriodicProblem):
    """What the harmonic-balance methods (HBM, DLFT) share: unknowns are the Fourier coefficients of
    the kept DOFs ``keep`` (the others, ``elim``, condensed exactly by ``cond``), ``Ns`` AFT samples per
    period, every residual row a force, and an exact path follower ``newton_fallback`` for penalty or
    gap contact."""

    cheap_jacobian = True  # the AFT Jacobian is a few products more than the residual
    fourier_all_dofs = True
    harmonic_truncation = True

    def _setup_harmonic_balance(self, system, omega, harmonics, steps, condense, partition):
        """The linear part both methods share: kept DOFs ``keep`` (the element DOFs or ``partition``; all
        DOFs without ``condense``), the exact condensation ``cond`` of the others (``elim``), the
        block-diagonal ``A = H_RR - T`` per harmonic (dense when condensed, else sparse), the right-hand
        side ``r``, the AFT matrices ``E``, ``Vs`` and ``VsOm = Vs Om`` (velocity samples).  Returns the complex
        condensed blocks ``H_RR,k - T_k``, shape ``(n_h + 1, n_R, n_R)`` (``None`` without ``condense``)."""
        self.system, self.omega = system, float(omega)
        self.n_h, self.Ns = int(harmonics), int(steps)
        n = system.n
        N_dofs = system.nonlinear_dofs if partition is None else np.asarray(partition, dtype=np.int64)
        self.condense = bool(condense)
        self.keep = np.asarray(N_dofs, dtype=np.int64) if self.condense else np.arange(n)
        mask = np.ones(n, dtype=bool)
        mask[self.keep] = False
        self.elim = np.flatnonzero(mask)
        self.resonant_moves = []
        if self.condense and partition is None:
            # a resonance of the linear subsystem (k omega an eigenfrequency of L with N clamped): its DOFs are
            # kept as unknowns instead of condensed (mshbm.condensation.condense_around_resonances)
            self.cond, self.keep, self.elim, self.resonant_moves = condensation.condense_around_resonances(
                system, omega, self.n_h, self.keep, self.elim)
        else:
            self.cond = Condensation(system, omega, self.n_h, self.keep, self.elim)
        if self.resonant_moves:
            self.notes = [condensation.resonance_note(self.resonant_moves, "H_LL", "the harmonic unknowns")]
        nR = self.nR = self.keep.size
        keep = self.keep
        Hs = None
        if self.condense and self.cond.H_RR is not None:  # the kept block of the condensation's stack
            Hs = self.cond.H_RR - self.cond.T
            self.A = self.cond.real_matrix(Hs)
        else:
            sub = lambda A: A.tocsr()[keep][:, keep] if sp.issparse(A) else np.asarray(A)[np.ix_(keep, keep)]
            MRR, CRR, KRR = sub(system.M), sub(system.C), sub(system.K)
            if self.condense:  # dense: n_R is the (small) nonlinear subsystem
                dense = lambda A: A.toarray() if sp.issparse(A) else A
                Hs = condensation.dynamic_stiffness_stack(dense(MRR), dense(CRR), dense(KRR),
                                                          omega * np.arange(self.n_h + 1)) - self.cond.T
                self.A = self.cond.real_matrix(Hs)
            else:
                blocks = []
                for k in range(self.n_h + 1):
                    Hk = sp.csr_matrix(condensation.dynamic_stiffness(MRR, CRR, KRR, k * omega))
                    A, Bm = Hk.real, Hk.imag
                    blocks.append(A if k == 0 else sp.bmat([[A, Bm], [-Bm, A]]))
                self.A = sp.block_diag(blocks, format="csr")
        self.r = fourier.from_complex(self.cond.F[:, keep] - self.cond.g).reshape(-1)
        self.E = fourier.dft_matrix(self.Ns, self.n_h)
        self.Vs = fourier.idft_matrix(self.Ns, self.n_h)
        self.VsOm = fourier.idft_derivative_matrix(self.Ns, self.n_h, self.omega)
        return Hs

    @property
    def n_unknowns(self):
        return (2 * self.n_h + 1) * self.nR

    @functools.cached_property
    def Om(self):
        """Derivative matrix ``Omega`` (``nc x nc``) of :func:`mshbm.fourier.derivative` at ``omega``."""
        return fourier.derivative(np.eye(2 * self.n_h + 1), self.omega)

    @property
    def steps(self):
        return self.Ns

    def partition(self):
        return Partition(time=np.zeros(0, np.int64), harmonic=self.keep.copy(), condensed=self.elim.copy())

    def residual_units(self):
        return np.full(self.n_unknowns, 2, dtype=np.int8)

    def conditioning(self):
        return self.cond.rcond

    def path_fallback(self):
        return self.newton_fallback


def section_limits(run, k):
    """``(q, u)`` of a recorded run (``run.q``, ``run.u``: shape ``(N + 1, n)``) extrapolated linearly to the
    end of the period from its last two samples before it (``k = -1``) or to the start from the two after it
    (``k = 0``): the limits of the state at the section from either side, to ``O(h^2)``, also where an event
    lies between the section and the nearest sample."""
    a, b = (-2, -3) if k == -1 else (1, 2)
    return 2.0 * run.q[a] - run.q[b], 2.0 * run.u[a] - run.u[b]
