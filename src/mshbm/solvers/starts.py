"""Start strategy of :func:`mshbm.solve`: several starting points, the first accepted one wins.

Newton's method converges only from a start close enough to a periodic
solution, and the nonsmooth residuals of the time-stepping methods (impacts,
stick-slip) make its basin small and ragged.  The default of
:func:`mshbm.solve` (``guess=None``, ``continuation=True``) is therefore not one
start but a ladder of starts, tried in a documented order until one of them
gives a result that the caller's predicate ``accept(attempt) -> bool`` accepts
(the certificate of the result; :func:`residual_accept` is a start-independent
residual check used until then).

Notation as in the paper: ``M, C, K`` mass, damping and stiffness matrices, ``q, u``
displacements and velocities, ``omega`` the forcing frequency (period ``T = 2 pi / omega``),
``n_h`` harmonics, ``h = T / N`` the Moreau-Jean step, ``x`` a method's unknowns and ``R(x)``
its residual (:func:`mshbm.api.build_problem`).  The starts, in the default order:

``"guess"``
    the caller's own guess (only when one is given to :func:`solve_from_starts`);
``"linear"``
    the linear response without elements (the historical default start);
``"regularisation"`` (HBM only)
    the linear start, continued from softened regularised laws (``kappa``, ``k_c``
    times 1e-3 ... 0.3) to the requested ones (:meth:`mshbm.methods.hbm.HBMProblem.homotopy`);
``"shifted"`` (time-stepping methods)
    the linear start with the *Poincare section moved*: the problem is solved for the
    forcing advanced by ``k`` time steps, ``f(t + t0)`` with ``t0 = k h``, and the periodic
    solution shifted back (only when the best failed attempt has events).  The time-domain unknowns ``q(0), u(0)`` of shooting and MS-HBM are
    discontinuous in the impact time when an impact (or a stick-slip switch) lies at the
    section ``t = 0 = T``; Newton then cycles the event across the section and stalls.
    ``t0`` is chosen as far as possible from the events of the best failed attempt.  The
    discrete solution is exactly the same (the grid is shifted by whole steps);
``"clamped"``
    the linear response with every element DOF held fixed: friction sticking (the
    DOF at rest at its mean linear-response position) and contacts closed (the DOF at
    the gap); the exact answer when the friction sticks for the whole period;
``"zero"``
    all displacements and velocities zero;
``"exact"`` (one element, at most :data:`EXACT_MAX_DOFS` DOFs)
    the exact event-driven periodic orbit (:func:`mshbm.exact_periodic`), itself started
    from the linear response, then from the best attempt so far;
``"transient"``
    Moreau-Jean simulation of the whole system (friction and impacts exact, the
    method's steps per period) from the best attempt so far (from rest if that one ran
    away beyond 1e3 times :func:`displacement_scale`), Newton restarted at the
    checkpoints ``transient_periods``; time-boxed by ``transient_budget``
    (``n^2 x steps x periods``) and ``transient_seconds``.  Finds attracting orbits;
``"forcing"``, ``"friction"``
    natural-parameter continuation in the forcing amplitude / the friction bound
    (:mod:`mshbm.solvers.continuation`), from the side where the linear response is exact;
``"section"`` (time-stepping methods)
    the ``"shifted"`` start's solution with the section *kept* at ``t0`` when the orbit mapped back to
    ``t = 0`` was not accepted (an impact near ``t = 0`` makes the state there ambiguous to one step): the
    same discrete orbit on the same grid, reported in the original time (``info["section"]``);
``"frequency"``
    continuation in the forcing frequency from an anchor ``r omega`` (:data:`FREQUENCY_RATIOS`) where the
    ladder without this start succeeds: the exact event-driven orbit continued (one element; with the
    section moved off its events when one lies at ``t = 0``), else the method's own branch.

Every start ends in an ordinary Newton solve of the *original* problem, so all
accepted results are solutions of the requested discretisation; the starts only
differ in where Newton begins.  The first accepted attempt is returned.  If none
is accepted, the attempt with the smallest residual ``||R||_inf`` (all attempts
solve the same problem, so their residuals are comparable) is returned with
``success=False`` and a message listing the starts tried.

Interface
---------
:func:`solve_from_starts` returns a :class:`mshbm.solvers.newton.NewtonResult` (the type that
:func:`mshbm.solvers.newton.newton` returns), so that :func:`mshbm.api._solve` treats it as
before; ``result.info["starts"]`` holds one record per attempt (start, accepted,
residual, iterations, wall time, message) and ``result.info["start_used"]`` the
accepted start (``None`` on failure).
"""
from __future__ import annotations

import contextlib
import contextvars
import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import condensation, fourier
from ..methods.common import linear_response
from ..errors import InputError
from .continuation import solve_with_continuation
from . import newton as newton_
from .newton import NewtonResult, solve_problem
from ..methods.registry import build_problem

__all__ = ["solve_from_starts", "residual_accept", "Attempt", "DEFAULT_STARTS", "active", "in_frequency_start",
           "deadline", "shifted_system",
           "clamped_response", "force_scale", "displacement_scale",
           "impact_jump"]

#: default order of the starts (those that do not apply to a method or system are skipped)
DEFAULT_STARTS = ("guess", "linear", "regularisation", "shifted", "clamped", "zero", "exact", "transient",
                  "forcing", "friction", "section", "frequency")

#: anchor frequencies ``omega * r`` of the ``"frequency"`` start, in the order tried
FREQUENCY_RATIOS = (0.85, 1.18, 0.7, 1.4)

#: time box of the ``"frequency"`` start (within the ladder's budget): ``max(FREQUENCY_SECONDS,
#: FREQUENCY_FACTOR x the first attempt's wall time)``
FREQUENCY_SECONDS = 5.0
FREQUENCY_FACTOR = 10.0

#: largest system for which the ``"exact"`` start runs the event-driven solver
EXACT_MAX_DOFS = 100
#: share of the ladder's remaining time budget one event-driven solve of the ``"exact"`` start may use
EXACT_SHARE = 0.4

_ACTIVE = contextvars.ContextVar("mshbm_starts_active", default=False)


_FREQUENCY = contextvars.ContextVar("mshbm_starts_frequency", default=False)

#: wall-clock deadline inherited by nested ladders (the ``"frequency"`` start's anchor solves): a nested ladder
#: stops trying starts at the earlier of its own budget's end and this one
_DEADLINE = contextvars.ContextVar("mshbm_starts_deadline", default=None)

#: the continuation driver of the ``"frequency"`` start, ``[mshbm.branch.sweep]``: registered by
#: :mod:`mshbm.branch` on import (which depends on this module, not the other way round)
SWEEP = [None]


def active():
    """True while a start strategy runs (nested :func:`mshbm.solve` calls then use one start only)."""
    return _ACTIVE.get()


def in_frequency_start():
    """True within the nested solves of the ``"frequency"`` start (its anchor solves and branch)."""
    return _FREQUENCY.get()


def deadline():
    """The wall-clock deadline (``time.perf_counter()``) ladders inherit in this context (:func:`time_limit`);
    ``None``: none."""
    return _DEADLINE.get()


@contextlib.contextmanager
def _nested(deadline=None):
    """Nested solves of the ``"frequency"`` start: full ladders (not :func:`active`) without their own
    ``"frequency"`` start, bounded by ``deadline`` when one is given (:data:`_DEADLINE`)."""
    tokens = [(_ACTIVE, _ACTIVE.set(False)), (_FREQUENCY, _FREQUENCY.set(True))]
    if deadline is not None:
        tokens.append((_DEADLINE, _DEADLINE.set(deadline)))
    try:
        yield
    finally:
        for var, tok in reversed(tokens):
            var.reset(tok)


def time_limit(deadline):
    """Within the block, ladders try no further start after ``deadline`` (a ``time.perf_counter()`` value;
    ``None``: no new limit; an enclosing earlier one stays): :func:`mshbm.solvers.driver.solve`'s ``max_time``."""
    return newton_.tighter_deadline(_DEADLINE, deadline)


@contextlib.contextmanager
def _activated():
    token = _ACTIVE.set(True)
    try:
        yield
    finally:
        _ACTIVE.reset(token)


@dataclass
class Attempt:
    """One start and the Newton solve of the original problem from it (the argument of ``accept``).

    Attributes
    ----------
    start : str
        Name of the start (see the module docstring).
    x0 : ndarray, shape (n_x,)
        Unknowns Newton started from (after any continuation or simulation).
    newton : NewtonResult
        Newton's outcome on the original problem; ``newton.x`` are the final unknowns.
    problem : object
        The method's problem (``residual(x) -> (R, J)``, ``solution_parts(x)``).
    note : str
        What the start did (e.g. "180 periods simulated").
    """

    start: str
    x0: np.ndarray
    newton: NewtonResult
    problem: object
    note: str = ""
    wall_time: float = 0.0
    accepted: bool = False
    extra_iterations: int = 0
    verdict: str = ""
    #: set by :func:`residual_accept` when it accepts a stalled Newton on an impacting orbit as periodic to
    #: one time step's accuracy: ``{"ratio": max_i |R_i| / bound_i, "bound": bound (ndarray), "verdict": str}``;
    #: the certificate then judges the residual and the periodicity by that bound
    step_accuracy: dict = None
    #: ``(k, t_s)`` when ``problem`` is the requested one with its Poincare section moved to ``t_s = k h``
    #: (:func:`section_problem`): ``x`` is then the state at ``t_s``; ``None`` for the section ``t = 0``
    section: tuple = None
    _parts: dict = field(default=None, repr=False)

    @property
    def x(self):
        return self.newton.x

    def parts(self):
        """``problem.solution_parts(x)`` (cached): time series, ``q_hat``, element forces."""
        if self._parts is None:
            self._parts = self.problem.solution_parts(self.newton.x)
        return self._parts

    def record(self):
        return {"start": self.start, "accepted": bool(self.accepted), "newton_converged": bool(self.newton.success),
                "residual": float(self.newton.residual_norm), "iterations": int(self.newton.nit),
                "extra_iterations": int(self.extra_iterations), "wall_time_s": float(self.wall_time),
                "note": self.note, "verdict": self.verdict, "message": self.newton.message}


# ----------------------------------------------------------------------------------------------
# a start-independent acceptance test (until the certificate of the result replaces it)


def force_scale(system):
    """Physical force scale (N): the largest forcing coefficient and element force bound ``mu F_N``."""
    s = float(np.max(np.abs(system.f_hat), initial=0.0))
    for el in system.elements:
        if el.bounded:
            s = max(s, el.bound)
    return s if s > 0 else 1.0


def displacement_scale(system, omega):
    """Physical displacement scale (m): :func:`force_scale` over the largest diagonal stiffness
    (``omega^2`` times the largest mass if ``K`` vanishes), at least the largest gap."""
    diag = lambda A: np.abs(A.diagonal() if sp.issparse(A) else np.diag(np.asarray(A)))
    k = float(np.max(diag(system.K), initial=0.0))
    if k <= 0:
        k = float(omega) ** 2 * float(np.max(diag(system.M), initial=0.0))
    D = force_scale(system) / k if k > 0 else 1.0
    gaps = max([el.gap for el in system.elements if el.unilateral], default=0.0)
    return max(D, gaps)


def _static_deflection(system):
    """``max |K^-1 f|`` with ``f`` the forcing amplitude per DOF (``sum_k |f_hat_k|``); 0 if ``K`` is singular."""
    f = np.sum(np.abs(np.asarray(system.f_hat, dtype=float)), axis=0)
    try:
        if sp.issparse(system.K):
            import scipy.sparse.linalg as spla
            x = spla.splu(sp.csc_matrix(system.K)).solve(f)
        else:
            x = np.linalg.solve(np.asarray(system.K, dtype=float), f)
    except (RuntimeError, np.linalg.LinAlgError):
        return 0.0
    d = float(np.max(np.abs(x), initial=0.0))
    return d if np.isfinite(d) else 0.0


def impact_jump(system, parts):
    """Largest velocity jump at an impact of the solution, ``|P| / M_dd`` over the contact elements
    (0 without contacts); ``parts`` from ``problem.solution_parts``."""
    P = parts.get("impulses")
    if P is None or not P.size:
        return 0.0
    M = system.M
    mdiag = M.diagonal() if sp.issparse(M) else np.diag(np.asarray(M))
    J = 0.0
    for j, el in enumerate(system.elements):
        if el.unilateral and j < P.shape[1]:
            J = max(J, float(np.max(np.abs(P[:, j]), initial=0.0)) / float(mdiag[el.dof]))
    return J


def residual_accept(problem, system, omega, rtol=1e-8, step_accuracy=True, max_iter=None, max_size=1e4):
    """Predicate ``accept(attempt) -> bool`` on the residual in physical units (start-independent).

    The residual is re-evaluated at the final unknowns.  Every entry is compared with a scale that
    depends neither on the start nor on the solution: forces (HBM; the harmonic block of
    ``mshbm-intermediate``) with ``F`` = :func:`force_scale` (forcing and ``mu F_N``), displacements
    with ``D`` = :func:`displacement_scale` (``F`` over the stiffness, or the gap), velocities with
    ``V = omega D``.  (A garbage answer at a resonance, amplitude 1e7 with ``||R|| = 500``, is
    rejected.)

    Accepted when

    * Newton converged and ``|R_i| <= rtol * scale_i`` for every entry; or
    * ``step_accuracy``, the method steps in time (shooting, MS-HBM), the solution has impacts,
      and Newton *stalled* (stopped before ``max_iter``: no descent), with every displacement entry
      ``|R_i| <= g h J`` and every velocity entry ``|R_i| <= g h omega J`` (force entries:
      ``rtol F``, plus ``2 g h J G_i`` where the force rows are driven by the Fourier coefficients of the
      time-stepped DOFs with the gain ``G_i`` of :meth:`PeriodicProblem.force_rows`, MS-HBM 3.3, whose
      displacement error ``S^-1 R_f`` must not exceed ``2 g h J`` either, and only where the step resolves
      the structure, ``omega_max h <= 1``), where ``J`` is the largest velocity jump at an impact (:func:`impact_jump`;
      more than ``20 V`` is an implausible, run-away orbit and rejected), and ``g = 1 +
      ||dR/dx||_2`` bounds the growth of a perturbation over the period (``||Phi||`` for
      shooting, ``dR/dx = Phi - I``).  That is the change of the periodicity residual when the
      impact moves by one time step: the Moreau-Jean map moves impacts by whole steps, so near
      such an orbit the discrete problem often has *no* exact root and Newton stalls at this level from any start, also from
      the exact event-driven orbit.  The time series is then periodic to one step's accuracy, and
      ``attempt.verdict`` says so.  (Stick-slip switches are continuous in the velocity and make
      no such jump: friction-only systems need a converged Newton.)

    Rejected in any case: a solution larger than ``max_size * D`` (default 1e4 times the static
    scale).  Near an undamped resonance of the continuous system (no periodic solution) the
    time-stepping map, whose resonance is detuned by ``O((omega h)^2)``, has spurious periodic
    points of amplitude ``~ D / (omega h)^2`` that the residual cannot tell from solutions
    (e.g. 1e6 for the 3-mass chain at its first eigenfrequency with ``mu F_N = 4``, 1024 steps);
    the rejection is a clean failure, with ``attempt.verdict`` saying why.
    """
    F = force_scale(system)
    D = displacement_scale(system, omega)
    V = float(omega) * D
    units = problem.residual_units()
    scale = np.where(units == 0, D, np.where(units == 1, V, F))
    h = problem.time_step
    static = []

    def static_scale():
        """The static deflection under the forcing amplitudes, ``max |K^-1 f|`` (computed once, only when
        a solution exceeds ``max_size D``: on finite-element models the largest diagonal stiffness is a
        local one, and ``F / K_ii`` underestimates the structure's compliance by orders of magnitude)."""
        if not static:
            static.append(_static_deflection(system))
        return static[0]

    fastest = []

    def fastest_mode():
        """Largest eigenfrequency (rad/s) of the structure ``(K, M)`` (``inf`` above 400 DOFs: not computed)."""
        if not fastest:
            if system.n > 400:
                fastest.append(math.inf)
            else:
                import scipy.linalg as sla

                lam = sla.eigh(system.dense("K"), system.dense("M"), eigvals_only=True)
                fastest.append(math.sqrt(max(float(lam.max()), 0.0)))
        return fastest[0]

    def accept(attempt):
        R, _ = problem.residual(attempt.x, jac=False)
        if not np.all(np.isfinite(R)):
            return False
        parts = attempt.parts()
        size = max(float(np.max(np.abs(parts["q_time"]), initial=0.0)),
                   float(np.max(np.sum(np.abs(parts["q_hat"]), axis=0), initial=0.0)))
        if not size <= max_size * D and not size <= max_size * static_scale():
            attempt.verdict = (f"rejected: displacements up to {size:.3g}, more than {max_size:g} times the static "
                               f"scale {max(D, static_scale()):.3g} (a spurious large orbit near an undamped "
                               "resonance?)")
            return False
        if attempt.newton.success and np.all(np.abs(R) <= rtol * scale):
            return True
        Ds = static_scale()
        if attempt.newton.success and Ds > D and np.all(np.abs(R) <= rtol * np.where(
                units == 0, Ds, np.where(units == 1, float(omega) * Ds, F))):
            return True  # displacement rows in the structure's own scale (finite-element models)
        if not step_accuracy or h is None or (max_iter is not None and attempt.newton.nit >= max_iter):
            return False
        J = impact_jump(system, attempt.parts())
        if not 0.0 < J <= 20.0 * V:  # no impact, or an implausible one (a run-away orbit)
            return False
        _, Jac = problem.residual(attempt.x, jac=True)
        Jac = Jac.toarray() if sp.issparse(Jac) else np.asarray(Jac)
        if not np.all(np.isfinite(Jac)):
            return False
        # bounds ||Phi|| = ||(Phi - I) + I|| (shooting); over the displacement and velocity rows only (MS-HBM 3.3: its
        # force rows, in N, would mix a stiffness into this dimensionless gain)
        gain = 1.0 + float(np.linalg.norm(Jac[units != 2], 2))
        bound = np.where(units == 2, rtol * F, gain * h * J * np.where(units == 0, 1.0, float(omega)))
        fr = problem.force_rows()
        if fr is not None and not fastest_mode() * h <= 1.0:
            return False  # the step does not resolve the structure: no one-step argument for the force rows
        if fr is not None:
            # force rows driven by the coefficients of the time-stepped DOFs (MS-HBM 3.3: H_21 FFT(q_1)): the one-step
            # change of q_1(t) (gain h J) changes each coefficient by at most twice that, the row by G_i times it.
            # And the displacement error the force residual causes, S^-1 R_f, must stay within that one-step change
            # (an undamped or resonant harmonic block turns a small force residual into a large error: rejected)
            G, S = fr
            rows = np.flatnonzero(units == 2)
            dq = 2.0 * gain * h * J
            bound[rows] = rtol * F + dq * np.asarray(G, dtype=float)
            try:
                err = np.linalg.solve(np.asarray(S, dtype=float), R[rows])
            except np.linalg.LinAlgError:
                return False
            if not np.all(np.isfinite(err)) or float(np.max(np.abs(err), initial=0.0)) > dq:
                return False
        if np.all(np.abs(R) <= bound):
            k = int(np.argmax(np.abs(R) / bound))
            # step_change: the displacement change of one step at the impact, h J (m), without the gain g (the
            # certificate's step_accuracy_size compares it with the orbit's size)
            attempt.step_accuracy = {"ratio": float(np.max(np.abs(R) / bound)), "bound": bound,
                                     "step_change": float(h * J)}
            attempt.verdict = (f"periodic to one time step's accuracy, not to Newton's tolerance: worst residual "
                               f"entry {abs(R[k]):.2e} <= {bound[k]:.2e}, the change when an impact (velocity jump "
                               f"{J:.3g}) moves by one step h = {h:.3g} s, amplified by at most {gain:.3g} over "
                               "the period; the Moreau-Jean map moves impacts by "
                               "whole steps and has no exact periodic point here")
            return True
        return False

    return accept


# ----------------------------------------------------------------------------------------------
# starting points


def shifted_system(system, t0, omega):
    """Copy of ``system`` with the forcing advanced by ``t0``: ``f_s(t) = f(t + t0)`` (matrices shared)."""
    fh = np.array(system.f_hat, dtype=float)
    out = fh.copy()
    for k in range(1, (fh.shape[0] - 1) // 2 + 1):
        phi = k * omega * t0
        a, b = fh[2 * k - 1], fh[2 * k]
        out[2 * k - 1] = a * math.cos(phi) + b * math.sin(phi)
        out[2 * k] = b * math.cos(phi) - a * math.sin(phi)
    new = system.with_elements(system.elements)
    new.f_hat = out
    return new


def _shift_hat(q_hat, omega, t0):
    """Coefficients of ``q(t + t0)`` from those of ``q(t)``, shape (2 n_h + 1, n)."""
    out = np.array(q_hat, dtype=float)
    for k in range(1, (q_hat.shape[0] - 1) // 2 + 1):
        phi = k * omega * t0
        a, b = q_hat[2 * k - 1], q_hat[2 * k]
        out[2 * k - 1] = a * math.cos(phi) + b * math.sin(phi)
        out[2 * k] = b * math.cos(phi) - a * math.sin(phi)
    return out


def clamped_response(system, omega, n_h):
    """Linear response with the element DOFs held fixed, ``q_hat`` shape (2 n_h + 1, n).

    Friction DOFs stick at their mean linear-response position, contact DOFs are closed at the gap
    (``q_dof = gap``); elements relative to a second DOF fix nothing.  The other DOFs respond to the forcing through the dynamic stiffness of the
    clamped structure, harmonic by harmonic (singular harmonics are set to zero).
    """
    n = system.n
    fixed = {}
    lin = linear_response(system, omega, n_h)
    for el in system.elements:
        if el.relative_to is not None:
            continue  # a relative element fixes no DOF to the ground: its DOFs respond freely
        fixed[int(el.dof)] = el.gap if el.unilateral else float(lin[0, el.dof])
    Nd = np.array(sorted(fixed), dtype=np.int64)
    Ld = np.setdiff1d(np.arange(n), Nd)
    q_hat = np.zeros((2 * n_h + 1, n))
    q_hat[0, Nd] = [fixed[int(d)] for d in Nd]
    if not Ld.size:
        return q_hat
    F = fourier.to_complex(system.forcing_hat(n_h))
    Z = np.zeros_like(F)
    for k in range(n_h + 1):
        rhs = F[k][Ld].astype(complex)
        H = condensation.dynamic_stiffness(system.M, system.C, system.K, k * omega)
        if sp.issparse(H):  # large models stay sparse (a dense H_LL of 10^4 DOFs would be 1.5 GiB)
            H = H.tocsr()
            if k == 0:
                rhs = rhs - H[Ld][:, Nd] @ q_hat[0, Nd]
            if not np.any(rhs):
                continue
            try:
                x = spla.splu(H[Ld][:, Ld].tocsc()).solve(rhs)
            except RuntimeError:  # exactly singular
                continue
        else:
            H = np.asarray(H)
            if k == 0:
                rhs = rhs - H[np.ix_(Ld, Nd)] @ q_hat[0, Nd]
            if not np.any(rhs):
                continue
            try:
                x = np.linalg.solve(H[np.ix_(Ld, Ld)], rhs)
            except np.linalg.LinAlgError:
                continue
        if np.all(np.isfinite(x)):
            Z[k][Ld] = x
    q_hat[:, Ld] = fourier.from_complex(Z)[:, Ld]
    return q_hat


def _hat_guess(q_hat, omega):
    """Guess dict ``{q_hat, q0, u0}`` consistent with the coefficients."""
    q0 = q_hat[0] + q_hat[1::2].sum(axis=0)
    u0 = fourier.derivative(q_hat, omega)[1::2].sum(axis=0)
    return {"q_hat": q_hat, "q0": q0, "u0": u0}


def _event_steps(parts, system):
    """Steps (indices of the time grid) at which an element switches: impacts, contact closing or
    opening, stick-slip transitions."""
    P = parts.get("impulses")
    if P is None or not P.size:
        return np.zeros(0, dtype=np.int64)
    N = P.shape[0]
    h = float(parts["t"][1] - parts["t"][0])
    ev = []
    for j, el in enumerate(system.elements):
        if el.unilateral:
            act = P[:, j] > 1e-12 * float(np.max(np.abs(P[:, j]), initial=0.0))  # not rounding-level impulses
        else:
            act = np.abs(P[:, j]) < (1.0 - 1e-9) * h * el.bound_samples(P / h)  # sticking
        change = np.nonzero(act != np.roll(act, 1))[0]
        ev.extend(change.tolist())
        if el.unilateral:
            ev.extend(np.nonzero(act)[0].tolist())
    return np.unique(np.asarray(ev, dtype=np.int64) % max(N, 1))


def _section_shift(parts, system, N):
    """Step ``k`` farthest (circularly) from every event of ``parts``; ``N // 2`` without events."""
    ev = _event_steps(parts, system) if parts is not None else np.zeros(0, dtype=np.int64)
    if ev.size == 0:
        return N // 2
    grid = np.arange(N)
    d = np.abs(grid[:, None] - ev[None, :])
    d = np.minimum(d, N - d).min(axis=1)
    d[0] = -1  # the present section
    return int(np.argmax(d))


# ----------------------------------------------------------------------------------------------
# the strategy


class _Runner:
    def __init__(self, problem, method, system, omega, newton_options, accept, solve_options, fallback,
                 transient_periods, transient_budget, transient_seconds, solve):
        self.problem, self.method, self.system, self.omega = problem, method, system, float(omega)
        self.solve = solve
        self.nkw = dict(newton_options)
        self.accept = accept
        self.options = {k: v for k, v in dict(solve_options or {}).items()
                        if k not in ("guess", "progress", "raise_on_failure", "continuation", "blas_threads")}
        self.fallback = fallback
        self.transient_periods = tuple(sorted(int(p) for p in transient_periods))
        self.transient_budget = float(transient_budget)
        self.transient_seconds = float(transient_seconds)
        self.attempts = []
        self.n_h = int(problem.n_h)
        self.deadline = None  # wall-clock end of the ladder's time budget (set once the first attempt is made)

    # -- helpers
    def _newton(self, x0, problem=None):
        return solve_problem(self.problem if problem is None else problem, x0, fallback=self.fallback, **self.nkw)

    def _try(self, start, x0, note="", extra_iterations=0, t0=None, problem=None, section=None, result=None):
        """Newton from ``x0`` (or the given Newton ``result``) on ``problem`` (default: the requested one; a
        section-shifted one with ``section = (k, t_s)``), judged by ``accept`` and recorded."""
        t0 = time.perf_counter() if t0 is None else t0
        problem = self.problem if problem is None else problem
        res = self._newton(x0, problem) if result is None else result
        att = Attempt(start, np.array(x0, dtype=float), res, problem, note, extra_iterations=extra_iterations,
                      section=section)
        try:
            att.accepted = bool(self.accept(att))
        except (FloatingPointError, np.linalg.LinAlgError, ValueError, OverflowError) as exc:
            att.accepted = False
            att.note = f"{note}; accept() raised {type(exc).__name__}: {exc}".lstrip("; ")
        att.wall_time = time.perf_counter() - t0
        self.attempts.append(att)
        return att

    def _keep_one(self, n0):
        """One record per start: of the attempts made since ``n0``, the accepted one, else the one with the
        smallest residual (the others' notes are appended to its note)."""
        mine = self.attempts[n0:]
        if len(mine) <= 1:
            return mine[0] if mine else None
        won = next((a for a in mine if a.accepted), None)
        if won is None:
            fin = [a for a in mine if np.isfinite(a.newton.residual_norm)]
            won = min(fin, key=lambda a: a.newton.residual_norm) if fin else mine[-1]
            others = "; ".join(f"also tried: {a.note}" for a in mine if a is not won and a.note)
            won.note = f"{won.note}; {others}" if others else won.note
        won.extra_iterations += sum(a.newton.nit + a.extra_iterations for a in mine if a is not won)
        del self.attempts[n0:]
        self.attempts.append(won)
        return won

    def _best(self):
        ok = [a for a in self.attempts if np.isfinite(a.newton.residual_norm)]
        return min(ok, key=lambda a: a.newton.residual_norm) if ok else None

    def _x_from_hat(self, q_hat):
        return self.problem.initial_guess(_hat_guess(q_hat, self.omega))

    # -- the starts; each returns an Attempt, or None if it does not apply
    def start_guess(self, guess):
        if guess is None:
            return None
        return self._try("guess", self.problem.initial_guess(guess))

    def start_linear(self):
        return self._try("linear", self.problem.initial_guess("linear"))

    def start_zero(self):
        return self._try("zero", self.problem.initial_guess("zero"))

    def start_clamped(self):
        if not self.system.elements:
            return None
        return self._try("clamped", self._x_from_hat(clamped_response(self.system, self.omega, self.n_h)))

    def start_regularisation(self):
        t0 = time.perf_counter()
        path = self.problem.homotopy()[:-1]  # softened laws (HBM); [] for the other methods
        if not path:
            return None
        x = self.problem.initial_guess("linear")
        it = 0
        for i, sub in enumerate(path):
            r = solve_problem(sub, x, **self.nkw)
            it += r.nit
            if not r.success:
                return self._try("regularisation", x, f"stage {i + 1}/{len(path)} failed: {r.message}", it, t0)
            x = r.x
        return self._try("regularisation", x, f"{len(path)} softened stages", it, t0)

    def start_shifted(self):
        if self.problem.time_step is None:
            return None
        t0 = time.perf_counter()
        N = int(self.problem.steps)
        best = self._best()
        parts = None
        if best is not None:
            try:
                parts = best.parts()
            except (FloatingPointError, np.linalg.LinAlgError, ValueError):
                parts = None
        if parts is None or _event_steps(parts, self.system).size == 0:
            return None  # no event near which the section could lie
        k = _section_shift(parts, self.system, N)
        try:
            probS, ts = self._section_problem(k)
        except InputError as exc:
            return self._try("shifted", self.problem.initial_guess("linear"), f"skipped: {exc}", 0, t0)
        rS = solve_problem(probS, probS.initial_guess("linear"), **self.nkw)
        note = f"section at t0 = {k}/{N} T: {rS.message}"
        if not np.all(np.isfinite(rS.x)):
            return self._try("shifted", self.problem.initial_guess("linear"), note, rS.nit, t0)
        pS = probS.solution_parts(rS.x)
        # q(t) = q_s(t - t0): q(0) = q_s(T - t0), the state at step N - k of the shifted period
        q_hat = _shift_hat(pS["q_hat"], self.omega, -ts)
        g = _hat_guess(q_hat, self.omega)
        td = np.asarray(pS["time_dofs"], dtype=np.int64)
        g["q0"][td] = pS["q_time"][N - k]
        g["u0"][td] = pS["u_time"][N - k]
        if not all(np.all(np.isfinite(v)) for v in g.values()):
            return self._try("shifted", self.problem.initial_guess("linear"), note, rS.nit, t0)
        att = self._try("shifted", self.problem.initial_guess(g), note, rS.nit, t0)
        if not att.accepted:
            # the orbit back at the section t = 0 is not accepted (an impact near t = 0 makes the state there
            # ambiguous to one step): the start "section" keeps the section at t0, if no other start succeeds
            self._section_candidate = (probS, rS, k, ts, note)
        return att

    def start_section(self):
        """The ``"shifted"`` start's solution with the section kept at ``t0`` (the same discrete orbit on the
        same grid, reported in the original time by the driver), when the orbit mapped back to ``t = 0`` was
        not accepted."""
        cand = getattr(self, "_section_candidate", None)
        if cand is None:
            return None
        probS, rS, k, ts, note = cand
        return self._try("section", probS.initial_guess("linear"), f"{note}; section kept at t0", 0,
                         problem=probS, section=(k, ts), result=rS)

    def _section_problem(self, k):
        """The requested problem with its Poincare section at ``t_s = k h`` (forcing advanced by ``t_s``:
        :func:`shifted_system`), and ``t_s``."""
        ts = k * (2 * math.pi / self.omega) / int(self.problem.steps)
        probS, _ = build_problem(shifted_system(self.system, ts, self.omega), self.omega, self.method, **self.options)
        return probS, ts

    def start_exact(self):
        if len(self.system.elements) != 1 or self.system.n > EXACT_MAX_DOFS:
            return None
        from ..methods.exact import exact_periodic

        t0 = time.perf_counter()
        N = int(self.problem.steps) if self.problem.time_step is not None else 2048
        guesses = ["linear"]
        best = self._best()
        if best is not None:
            try:
                p = best.parts()
                q0 = p["q_hat"][0] + p["q_hat"][1::2].sum(axis=0)
                u0 = fourier.derivative(p["q_hat"], self.omega)[1::2].sum(axis=0)
                td = np.asarray(p["time_dofs"], dtype=np.int64)
                q0[td], u0[td] = p["q_time"][0], p["u_time"][0]
                if np.all(np.isfinite(q0)) and np.all(np.isfinite(u0)):
                    guesses.append({"q0": q0, "u0": u0})
            except (FloatingPointError, np.linalg.LinAlgError, ValueError):
                pass
        why = []
        for g in guesses:
            # the event-driven simulation stops at the ladder's (or the solve's) deadline: at a low frequency
            # with stiff modes the flow has many steps a period and a Newton solve of it can take minutes
            stop = [d for d in (self.deadline, newton_.deadline()) if d is not None]
            left = None if not stop else min(stop) - time.perf_counter()
            if left is not None and left <= 0.0:
                why.append("time budget spent")
                break
            if left is not None:
                left = max(min(left, 1.0), EXACT_SHARE * left)  # the later starts keep a share of the budget
            try:
                ex = exact_periodic(self.system, self.omega, guess=g, samples=max(N, 64),
                                    harmonics=max(self.n_h, 1), blas_threads=None, time_limit=left)
            except (InputError, FloatingPointError, np.linalg.LinAlgError, ValueError) as exc:
                why.append(f"{type(exc).__name__}: {exc}")
                continue
            if ex.success and np.all(np.isfinite(ex.q_hat)):
                gg = {"q_hat": ex.q_hat, "q0": ex.q[0].copy(), "u0": ex.u[0].copy()}
                att = self._try("exact", self.problem.initial_guess(gg), f"exact orbit: {ex.message}", 0, t0)
                if att.accepted or self.problem.time_step is None or ex.q.shape[0] != N + 1:
                    return att
                return self._exact_section(ex, N, att, t0)
            why.append(ex.message)
        return self._try("exact", self.problem.initial_guess("linear"),
                         "exact_periodic failed: " + "; ".join(w[:120] for w in why), 0, t0)

    def _exact_section(self, ex, N, att, t0, start="exact"):
        """The exact orbit ``ex`` (on the grid ``t_k = k T / N`` of the method) as the start of the problem with
        its section at the step farthest from the orbit's events, when one lies within two steps of ``t = 0``
        (an impact at the section: the state there is ambiguous to one step, and Newton cycles the impact
        across the section)."""
        T = 2 * math.pi / self.omega
        ev = np.array([e.t for e in ex.info.get("events", [])], dtype=float)
        if not ev.size:
            return att
        d = np.minimum(ev % T, T - ev % T)
        if float(d.min()) > 2.0 * T / N:
            return att
        steps = np.unique(np.round(ev / (T / N)).astype(np.int64) % N)
        grid = np.arange(N)
        dist = np.abs(grid[:, None] - steps[None, :])
        dist = np.minimum(dist, N - dist).min(axis=1)
        k = int(np.argmax(dist))
        try:
            probS, ts = self._section_problem(k)
        except InputError:
            return att
        # q_s(t) = q(t + t_s): coefficients advanced by t_s, the state at grid point k
        gS = {"q_hat": _shift_hat(ex.q_hat, self.omega, ts), "q0": ex.q[k].copy(), "u0": ex.u[k].copy()}
        return self._try(start, probS.initial_guess(gS), f"{att.note}; section at t0 = {k}/{N} T, away from the "
                         "orbit's events", 0, t0, problem=probS, section=(k, ts))

    def start_transient(self):
        from ..integrators.moreau_jean import MAX_DENSE_DOFS, MoreauJean

        n = self.system.n
        steps = int(self.problem.steps) if self.problem.time_step is not None else 1024
        total = max(self.transient_periods)
        if n > MAX_DENSE_DOFS or float(n) * n * steps * total > self.transient_budget:
            return None
        t0 = time.perf_counter()
        best = self._best()
        try:
            g = best.parts() if best is not None else None
        except (FloatingPointError, np.linalg.LinAlgError, ValueError):
            g = None
        # from the best attempt so far, unless it is not finite or has run away (then from rest)
        D = displacement_scale(self.system, self.omega)
        if g is not None and not (all(np.all(np.isfinite(g[k])) for k in ("q_hat", "q_time", "u_time"))
                                  and np.max(np.abs(g["q_time"]), initial=0.0) <= 1e3 * D):
            g = None
        q_hat0 = g["q_hat"] if g is not None else np.zeros((2 * self.n_h + 1, self.system.n))
        start = _hat_guess(q_hat0, self.omega)
        if g is not None:
            td = np.asarray(g["time_dofs"], dtype=np.int64)
            if np.all(np.isfinite(g["q_time"])) and np.all(np.isfinite(g["u_time"])):
                start["q0"][td] = g["q_time"][0]
                start["u0"][td] = g["u_time"][0]
        q, u = start["q0"].copy(), start["u0"].copy()
        T = 2 * math.pi / self.omega
        theta = float(self.options.get("theta", 0.5)) if self.method != "hbm" else 0.5
        try:
            stepper = MoreauJean(self.system.M, self.system.C, self.system.K, self.system.elements, T / steps,
                                 theta, bool(self.options.get("project", True)))
        except InputError:  # an element time stepping does not support (elastic friction): no transient start
            return None
        t = np.linspace(0.0, T, steps + 1)
        B = stepper.increments(self.system.forcing(t, self.omega))
        done, att, it = 0, None, 0
        for cp in self.transient_periods:
            tr = None
            while done < cp:
                tr = stepper.run(q, u, B)
                q, u = tr.q[-1].copy(), tr.u[-1].copy()
                done += 1
                if not (np.all(np.isfinite(q)) and np.all(np.isfinite(u))):
                    return self._try("transient", self.problem.initial_guess("linear"),
                                     f"the simulation diverged after {done} periods", 0, t0)
                if self._transient_over(t0):
                    break
            if tr is None:
                break
            # the structure's DOFs (the stepper also integrates the sliders of Jenkins elements)
            gg = {"q_hat": fourier.fft(tr.q[:-1, :n], self.n_h), "q0": q[:n].copy(), "u0": u[:n].copy()}
            drift = float(np.max(np.abs(np.concatenate([tr.q[-1] - tr.q[0], tr.u[-1] - tr.u[0]]))))
            att = self._try("transient", self.problem.initial_guess(gg),
                            f"{done} periods simulated (period drift {drift:.1e})", it, t0)
            if att.accepted:
                return att
            self.attempts.pop()  # keep one record per start: the last checkpoint
            it += att.newton.nit
            if self._transient_over(t0):
                break
        if att is not None:
            self.attempts.append(att)
            att.note += f"; time box {self.transient_seconds:g} s" if time.perf_counter() - t0 > \
                self.transient_seconds else ""
        return att

    def _transient_over(self, t0):
        """The ``"transient"`` start's simulation stops: its time box ``transient_seconds`` is spent, or the
        ladder's deadline has passed (its Newton solves would stop at once)."""
        now = time.perf_counter()
        return now - t0 > self.transient_seconds or (self.deadline is not None and now > self.deadline)

    def _continuation(self, strategy):
        if self.solve is None:
            return None  # no full solver given (solve_from_starts(..., solve=)): no continuation start
        if strategy == "friction" and not any(e.bounded for e in self.system.elements):
            return None
        t0 = time.perf_counter()
        opts = dict(self.options)
        for key in ("tol", "max_iter", "line_search"):
            if key in self.nkw:
                opts[key] = self.nkw[key]
        try:
            sol = solve_with_continuation(self.system, self.omega, self.method, guess="zero", solve=self.solve, ladder=False,
                                          strategies=(strategy,), **opts)
        except InputError as exc:
            return self._try(strategy, self.problem.initial_guess("linear"), f"skipped: {exc}", 0, t0)
        info = sol.info.get("continuation", {})
        att = info.get("attempts") or [{}]
        note = f"{len(att[-1].get('stages', []))} stages: {att[-1].get('result', '')}"
        x = np.asarray(sol.x, dtype=float)
        if x.shape != (self.problem.n_unknowns,) or not np.all(np.isfinite(x)):
            x = self.problem.initial_guess("linear")
        return self._try(strategy, x, note, int(info.get("total_iterations", 0)), t0)

    def start_frequency(self):
        """Continuation in the forcing frequency from an anchor ``omega_a = r omega`` (``r`` in
        :data:`FREQUENCY_RATIOS`) where the whole ladder (without this start) gives a certified solution: the
        exact event-driven orbit continued to ``omega`` (one element; then as the ``"exact"`` start), else the
        method's own branch (:func:`mshbm.sweep`) from the anchor to ``omega``."""
        if self.solve is None or _FREQUENCY.get() or int(self.nkw.get("max_iter", 50)) < 1:
            return None  # (max_iter = 0: no Newton iterations asked for, and a branch needs corrector iterations)
        sweep = SWEEP[0]

        t0 = time.perf_counter()
        opts = dict(self.options)
        for key in ("tol", "max_iter", "line_search"):
            if key in self.nkw:
                opts[key] = self.nkw[key]
        if self.method == "hbm":  # the branch of this problem's equations (sweep's own default is the linear quadrature)
            opts.setdefault("penalty_quadrature", "samples")
        why = []
        box = t0 + max(FREQUENCY_SECONDS, FREQUENCY_FACTOR * (self.attempts[0].wall_time if self.attempts else 0.0))
        outer = self.deadline
        self.deadline = box if outer is None else min(box, outer)
        try:
            return self._frequency(opts, why, t0, sweep)
        finally:
            self.deadline = outer

    def _frequency(self, opts, why, t0, sweep):
        for r in FREQUENCY_RATIOS:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                why.append("time budget spent")
                break
            wa = self.omega * r
            try:
                with _nested(self.deadline):
                    sol_a = self.solve(self.system, wa, self.method, stability=False, **opts)
            except (InputError, FloatingPointError, np.linalg.LinAlgError, ValueError) as exc:
                why.append(f"omega_a = {wa:.4g}: {type(exc).__name__}: {exc}"[:160])
                continue
            if not sol_a.success:
                why.append(f"no certified solution at omega_a = {wa:.4g}")
                continue
            att = self._exact_continuation(sol_a, wa, t0)
            if att is not None and att.accepted:
                return att
            if sweep is None:
                why.append("no continuation driver registered (mshbm.branch not imported)")
                continue
            left = None if self.deadline is None else max(1.0, self.deadline - time.perf_counter())
            try:
                with _nested():
                    br = sweep(self.system, wa, self.omega, self.method, guess=sol_a, stability=False,
                               max_time=left, **{k: v for k, v in opts.items() if k not in ("guess", "stability", "max_time")})
            except (InputError, FloatingPointError, np.linalg.LinAlgError, ValueError) as exc:
                why.append(f"branch from {wa:.4g}: {type(exc).__name__}: {exc}"[:160])
                continue
            end = br.points[-1] if br.points else None
            if end is None or not math.isclose(end.omega, self.omega, rel_tol=1e-9):
                why.append(f"branch from {wa:.4g} stopped at omega = {end.omega if end else wa:.4g}: "
                           f"{br.message}"[:200])
                continue
            att = self._try("frequency", self.problem.initial_guess(end.solution),
                            f"branch from omega_a = {wa:.4g} ({len(br.points)} points)", 0, t0)
            if att.accepted:
                return att
            why.append(f"branch from {wa:.4g} reached omega, Newton there: {att.verdict or att.newton.message}"[:200])
        return self._try("frequency", self.problem.initial_guess("linear"), "; ".join(why) or "no anchor", 0, t0)

    def _exact_continuation(self, sol_a, wa, t0):
        """Natural-parameter continuation of the exact orbit (:func:`mshbm.exact_periodic`) from the anchor
        solution ``sol_a`` at ``wa`` to ``omega`` (steps doubled after a success, halved after a failure, down
        to 1/64 of the distance); the orbit at ``omega`` then starts Newton as in the ``"exact"`` start.
        ``None`` where the exact solver does not apply or the continuation fails."""
        if len(self.system.elements) != 1 or self.system.n > EXACT_MAX_DOFS or self.problem.time_step is None:
            return None
        from ..methods.exact import exact_periodic

        N = int(self.problem.steps)
        kw = dict(samples=max(N, 64), harmonics=max(self.n_h, 1), blas_threads=None)
        try:
            ex = exact_periodic(self.system, wa, guess=sol_a, **kw)
        except (InputError, FloatingPointError, np.linalg.LinAlgError, ValueError):
            return None
        if not ex.success:
            return None
        lam, step, dist = wa, (self.omega - wa) / 4.0, self.omega - wa
        while lam != self.omega:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                return None
            nxt = self.omega if abs(self.omega - lam) <= abs(step) * 1.0000001 else lam + step
            try:
                e2 = exact_periodic(self.system, nxt, guess=ex, **kw)
            except (InputError, FloatingPointError, np.linalg.LinAlgError, ValueError):
                e2 = None
            if e2 is not None and e2.success:
                ex, lam, step = e2, nxt, 2.0 * step if abs(2.0 * step) <= abs(dist) / 2 else step
            else:
                step /= 2.0
                if abs(step) < abs(dist) / 64.0:
                    return None
        gg = {"q_hat": ex.q_hat, "q0": ex.q[0].copy(), "u0": ex.u[0].copy()}
        att = self._try("frequency", self.problem.initial_guess(gg),
                        f"exact orbit continued from omega_a = {wa:.4g}", 0, t0)
        if att.accepted or ex.q.shape[0] != N + 1:
            return att
        return self._exact_section(ex, N, att, t0, start="frequency")

    def start_forcing(self):
        return self._continuation("forcing")

    def start_friction(self):
        return self._continuation("friction")


#: time budget of the start ladder: no further start is tried once the ladder has run for
#: ``max(LADDER_SECONDS, LADDER_FACTOR x the first attempt's wall time)``; the failure names the skipped starts
LADDER_SECONDS = 30.0
LADDER_FACTOR = 30.0


def solve_from_starts(problem, method, system, omega, newton_options, accept, *, guess=None, starts=DEFAULT_STARTS,
                      solve_options=None, fallback=True, transient_periods=(10, 40, 160), transient_budget=2e9,
                      transient_seconds=20.0, solve=None):
    """Try the starts in order until ``accept`` accepts a Newton solution of ``problem``.

    Parameters
    ----------
    problem : object
        The method's problem (:func:`mshbm.api.build_problem`): ``residual(x) -> (R, J)``,
        ``initial_guess(guess)``, ``solution_parts(x)``, ``n_unknowns``.
    method : str
        Name of the method (``"shooting"``, ``"hbm"``, ``"mshbm"``, ``"mshbm-intermediate"``).
    system : System
    omega : float
        Forcing frequency (rad/s).
    newton_options : dict
        Keyword arguments of :func:`mshbm.solvers.newton.newton` (``tol``, ``max_iter``, ``line_search``,
        ``callback``); used for every Newton solve.
    accept : callable
        ``accept(attempt: Attempt) -> bool``; the first attempt it accepts is returned
        (e.g. :func:`residual_accept`, or the certificate of the result).
    guess : optional
        A user guess (as for :func:`mshbm.solve`), tried first as start ``"guess"``.
    starts : sequence of str
        Starts in the order tried (default :data:`DEFAULT_STARTS`); inapplicable ones are skipped.
    solve_options : dict
        The method's options as given to :func:`mshbm.solve` (``harmonics``, ``steps``, ``theta``,
        ``partition``...): needed to build the shifted problem, the simulation, the continuations.
    fallback : bool
        Allow Newton the problem's exact path follower (:meth:`PeriodicProblem.path_fallback`, HBM/DLFT).
    solve : callable, optional
        The full solver (:func:`mshbm.solvers.driver.solve`) for the continuation starts ``"forcing"``
        and ``"friction"``, whose stages are complete solves; ``None`` skips them.
    transient_periods : sequence of int
        Checkpoints (periods simulated so far) of the ``"transient"`` start.
    transient_budget : float
        Largest ``n^2 x steps x periods`` the ``"transient"`` start simulates (skipped above).
    transient_seconds : float
        Wall-time box of the simulation of the ``"transient"`` start.

    Returns
    -------
    NewtonResult
        ``success`` = some attempt was accepted.  ``x``, ``residual_norm``, ``history`` are those of
        the accepted attempt (on failure: of the attempt with the smallest ``||R||_inf``); ``nit``
        and ``nfev`` count every attempt (continuation stages and simulation checkpoints
        included in ``nit``); ``message`` names the start used, or lists every start tried and
        the best residual; ``info["starts"]`` one record per attempt, ``info["start_used"]``.
    """
    unknown = [s for s in starts if s not in DEFAULT_STARTS]
    if unknown:
        raise InputError("starts", f"unknown start {unknown[0]!r} (choose from {', '.join(DEFAULT_STARTS)})")
    run = _Runner(problem, method, system, omega, newton_options, accept, solve_options, fallback,
                  transient_periods, transient_budget, transient_seconds, solve)
    won, skipped, t_start = None, [], time.perf_counter()
    inherited = _DEADLINE.get()
    by_caller = False  # the caller's deadline (max_time, an enclosing time box) stopped the ladder, not its own budget
    with _activated():
        for name in starts:
            own = run.attempts and time.perf_counter() - t_start > max(LADDER_SECONDS,
                                                                       LADDER_FACTOR * run.attempts[0].wall_time)
            outer = run.attempts and inherited is not None and time.perf_counter() > inherited
            if own or outer:
                by_caller = by_caller or (outer and not own and not skipped)
                skipped.append(name)  # the ladder's time budget is spent: report, do not try further starts
                continue
            if run.attempts and run.deadline is None:
                run.deadline = t_start + max(LADDER_SECONDS, LADDER_FACTOR * run.attempts[0].wall_time)
                if inherited is not None:
                    run.deadline = min(run.deadline, inherited)
            n0 = len(run.attempts)
            # every Newton solve of this start ends at the ladder's deadline (newton.time_box), so one start cannot
            # run on far beyond the budget
            with newton_.time_box(run.deadline):
                if name == "guess":
                    att = run.start_guess(guess)
                else:
                    att = getattr(run, f"start_{name}")()
            if att is not None:
                att = run._keep_one(n0)
            if att is not None and att.accepted:
                won = att
                break
    records = [a.record() for a in run.attempts]
    nit = sum(a.newton.nit + a.extra_iterations for a in run.attempts)
    nfev = sum(a.newton.nfev for a in run.attempts)
    if won is not None:
        res = won.newton
        res.success = True
        if won.step_accuracy is not None:
            res.info["step_accuracy"] = dict(won.step_accuracy, verdict=won.verdict)
        more = f" (start '{won.start}'" + (f" after {len(records) - 1} rejected starts: "
                                             + ", ".join(r["start"] for r in records[:-1]) if len(records) > 1
                                             else "") + ")"
        res.message = (f"{won.verdict} (Newton: {res.message}){more}" if won.verdict else f"{res.message}{more}")
    else:
        best = run._best() or (run.attempts[-1] if run.attempts else None)
        if best is None:  # pragma: no cover - "linear" always applies
            raise InputError("starts", "no start applies")
        res = best.newton
        res.success = False
        tried = "; ".join(f"{a.start}: " + (a.verdict if a.verdict else ("rejected (" + a.newton.message + ")"
                                                                      if a.newton.success else a.newton.message))
                          for a in run.attempts)
        res.message = (f"no start led to an accepted solution; best ||R||_inf = {best.newton.residual_norm:.2e} "
                       f"from start '{best.start}'; starts tried: {tried}")
    res.nit, res.nfev = nit, nfev
    res.info = dict(res.info or {})
    if skipped and won is None:
        budget = ("the caller's time budget (max_time or an enclosing time box)" if by_caller else
                  f"time budget of the start ladder (max({LADDER_SECONDS:g} s, {LADDER_FACTOR:g} x the first attempt))")
        res.message += f"; {budget} spent, starts not tried: {', '.join(skipped)}"
    res.info["starts"] = records
    res.info["start_used"] = None if won is None else won.start
    chosen = won if won is not None else (run._best() or run.attempts[-1])
    if chosen.section is not None:
        # x is the state at the moved section t_s of chosen.problem (see Attempt.section)
        res.info["problem"], res.info["section"] = chosen.problem, chosen.section
    return res
