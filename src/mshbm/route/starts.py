"""The starting points of the start ladder (:mod:`mshbm.route.ladder`) that need no nested solve.

Each start is an object with a ``name`` and ``run(ladder) -> Attempt or None`` (``None``: it does not
apply to this method or system); it makes its attempts through :meth:`mshbm.route.ladder.Ladder.try_`.

Notation as in the paper: ``M, C, K`` mass, damping and stiffness matrices, ``q, u`` displacements and
velocities, ``omega`` the forcing frequency (period ``T = 2 pi / omega``), ``n_h`` harmonics,
``h = T / N`` the Moreau-Jean step, ``q_hat`` the displacement coefficients, shape ``(2 n_h + 1, n)``.

``"guess"``
    the caller's own guess (only when one is given);
``"linear"``
    the linear response without elements;
``"regularisation"`` (problems with a homotopy: HBM)
    the linear start, continued from softened regularised laws to the requested ones
    (:meth:`PeriodicProblem.homotopy`);
``"shifted"`` (time-stepping problems)
    the linear start with the *Poincare section moved*: the problem is solved for the forcing advanced by
    ``k`` time steps, ``f(t + t0)`` with ``t0 = k h``, and the periodic solution shifted back (only when the
    best failed attempt has events).  The time-domain unknowns ``q(0), u(0)`` of shooting and MS-HBM are
    discontinuous in the impact time when an impact (or a stick-slip switch) lies at the section
    ``t = 0 = T``; Newton then cycles the event across the section and stalls.  ``t0`` is chosen as far as
    possible from the events of the best failed attempt.  The discrete solution is exactly the same (the
    grid is shifted by whole steps);
``"clamped"``
    the linear response with every element DOF held fixed: friction sticking (the DOF at rest at its mean
    linear-response position) and contacts closed (the DOF at the gap); the exact answer when the friction
    sticks for the whole period;
``"zero"``
    all displacements and velocities zero;
``"exact"`` (one element, at most :data:`EXACT_MAX_DOFS` DOFs)
    the exact event-driven periodic orbit (:func:`mshbm.methods.exact.exact_periodic`), itself started
    from the linear response, then from rest, then from the best attempt so far, then from the state a
    Moreau-Jean transient from rest reaches; when none of them gives the orbit, the attempt is recorded
    without a Newton solve of the method.  Where the linear response runs through the stop, that transient
    state is probed first (:meth:`ExactStart._guesses`): its orbit is taken at once when it is attracting and
    the method's solution from it is accepted, and has its ordinary turn, last, otherwise;
``"transient"``
    Moreau-Jean simulation of the whole system (friction and impacts exact, the method's steps per period)
    from the best attempt so far (from rest if that one ran away beyond 1e3 times
    :func:`mshbm.route.acceptance.displacement_scale`), Newton restarted at the checkpoints
    ``transient_periods``; bounded by ``transient_budget`` (``n^2 x steps x periods``, deterministic) and the
    ladder's budget (:meth:`mshbm.route.ladder.Ladder.over`, checked after each period).  Finds attracting orbits;
``"section"`` (time-stepping problems)
    the ``"shifted"`` start's solution with the section *kept* at ``t0`` when the orbit mapped back to
    ``t = 0`` was not accepted (an impact near ``t = 0`` makes the state there ambiguous to one step): the
    same discrete orbit on the same grid, reported in the original time (``info["section"]``).
"""
from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import condensation, fourier
from ..errors import InputError
from ..integrators.event.flow import WORK_PER_EVALUATION
from ..integrators.moreau_jean import MAX_DENSE_DOFS, MoreauJean
from ..methods.common import linear_response
from ..methods.exact import exact_periodic
from ..methods.registry import build_problem
from ..solvers import newton as newton_
from ..solvers.newton import solve_problem
from ..subharmonic import transient_guess
from .acceptance import displacement_scale

__all__ = ["shifted_system", "shift_hat", "clamped_response", "hat_guess", "event_steps", "section_shift",
           "section_problem", "exact_section", "metered_exact", "linear_penetrates", "forced_at_fundamental",
           "EXACT_MAX_DOFS", "EXACT_WORK", "PROBE_NOTE"]

#: largest system for which the ``"exact"`` start runs the event-driven solver
EXACT_MAX_DOFS = 100
#: work budget of one event-driven periodic solve of the ``"exact"`` start (the flow's deterministic count
#: :attr:`mshbm.integrators.event.flow.EventFlow.work`, flop equivalents, 0.2-3 ns of one core each): it replaces 40 %
#: of the ladder's remaining wall time (12 s and more on an idle machine).  Calibration (the 75 exact starts of
#: tests/unit/test_ladder_fallbacks.py, test_event_fallback.py, test_time_budget.py): the converged ones used at most
#: 1.1e8; 1e10 took 3.1-5.8 s of CPU on the failing ones
EXACT_WORK = 1e10


#: the exact start's guess "the transient state, its orbit known from the probe" (:meth:`ExactStart._guesses`)
_PROBED = object()
#: the end of the note of an exact start's attempt from the probed transient state
PROBE_NOTE = "; from the Moreau-Jean transient state, probed first"


def metered_exact(system, omega, **kwargs):
    """:func:`mshbm.methods.exact.exact_periodic` within the work budgets of the solve route: a flow work budget of
    :data:`EXACT_WORK`, or less when the meters of the context have fewer evaluations left (at
    :data:`mshbm.integrators.event.flow.WORK_PER_EVALUATION`; the flow charges its work to them).  Deterministic:
    the same on every machine."""
    left = newton_.work_left()
    limit = EXACT_WORK if left is None else min(EXACT_WORK, max(left, 0.0) * WORK_PER_EVALUATION)
    return exact_periodic(system, omega, work_limit=limit, **kwargs)


# ---------------------------------------------------------------------------------------------- geometry
def shifted_system(system, t0, omega):
    """Copy of ``system`` with the forcing advanced by ``t0``: ``f_s(t) = f(t + t0)`` (matrices shared)."""
    def shift(f_hat):
        fh = np.array(f_hat, dtype=float)
        out = fh.copy()
        for k in range(1, (fh.shape[0] - 1) // 2 + 1):
            phi = k * omega * t0
            a, b = fh[2 * k - 1], fh[2 * k]
            out[2 * k - 1] = a * math.cos(phi) + b * math.sin(phi)
            out[2 * k] = b * math.cos(phi) - a * math.sin(phi)
        return out

    return system.map_forcing(shift)


def shift_hat(q_hat, omega, t0):
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
    (``q_dof = gap``); elements relative to a second DOF fix nothing.  The other DOFs respond to the forcing
    through the dynamic stiffness of the clamped structure, harmonic by harmonic (singular harmonics are set
    to zero).
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
    F = fourier.to_complex(system.forcing_hat(n_h, omega))
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


def linear_penetrates(system, omega, n_h):
    """True if the linear response (no elements, ``n_h`` harmonics) closes the gap of a contact element somewhere in
    the period (sampled at ``8 n_h + 8`` points): the linear start is then no answer."""
    els = [el for el in system.elements if el.unilateral]
    if not els:
        return False
    n_h = max(int(n_h), 1)
    q_hat = linear_response(system, omega, n_h)
    tau = 2.0 * np.pi * np.arange(8 * n_h + 8) / (8 * n_h + 8)
    k = np.arange(1, n_h + 1)
    q = q_hat[0] + np.cos(np.outer(tau, k)) @ q_hat[1::2] + np.sin(np.outer(tau, k)) @ q_hat[2::2]
    return any(float(np.min(el.gap + el.local(q))) < 0.0 for el in els)


def forced_at_fundamental(system, omega):
    """True if the forcing has the harmonic ``omega`` itself (``T`` is its own period; not so for the ``kT`` problems
    of :mod:`mshbm.period`, whose orbits come in ``k`` copies shifted by the forcing period)."""
    F = np.asarray(system.forcing_hat(max(system.n_forcing_harmonics, 1), omega), dtype=float)
    return bool(np.any(F[1:3] != 0.0))


def hat_guess(q_hat, omega):
    """Guess dict ``{q_hat, q0, u0}`` consistent with the coefficients."""
    q0 = q_hat[0] + q_hat[1::2].sum(axis=0)
    u0 = fourier.derivative(q_hat, omega)[1::2].sum(axis=0)
    return {"q_hat": q_hat, "q0": q0, "u0": u0}


def event_steps(parts, system):
    """Steps (indices of the time grid) at which an element switches: impacts, contact closing or
    opening, stick-slip transitions."""
    P = parts.get("impulses")
    if P is None or not P.size:
        return np.zeros(0, dtype=np.int64)
    N = P.shape[0]
    h = float(parts["t"][1] - parts["t"][0])
    ev = []
    for j, el in enumerate(system.elements):
        if not (el.unilateral or el.bounded):
            continue  # a smooth force (polynomial spring) never switches
        if el.unilateral:
            act = P[:, j] > 1e-12 * float(np.max(np.abs(P[:, j]), initial=0.0))  # not rounding-level impulses
        else:
            PT = np.abs(P[:, j]) if el.cone_partner is None else np.hypot(P[:, j], P[:, el.cone_partner])
            act = PT < (1.0 - 1e-9) * h * el.bound_samples(P / h)  # sticking (3-D contact: ||P_T||)
        change = np.nonzero(act != np.roll(act, 1))[0]
        ev.extend(change.tolist())
        if el.unilateral:
            ev.extend(np.nonzero(act)[0].tolist())
    return np.unique(np.asarray(ev, dtype=np.int64) % max(N, 1))


def section_shift(parts, system, N):
    """Step ``k`` farthest (circularly) from every event of ``parts``; ``N // 2`` without events."""
    ev = event_steps(parts, system) if parts is not None else np.zeros(0, dtype=np.int64)
    if ev.size == 0:
        return N // 2
    grid = np.arange(N)
    d = np.abs(grid[:, None] - ev[None, :])
    d = np.minimum(d, N - d).min(axis=1)
    d[0] = -1  # the present section
    return int(np.argmax(d))


def section_problem(ladder, k):
    """The ladder's problem with its Poincare section at ``t_s = k h`` (forcing advanced by ``t_s``:
    :func:`shifted_system`), and ``t_s``."""
    ts = k * (2 * math.pi / ladder.omega) / int(ladder.problem.steps)
    probS, _ = build_problem(shifted_system(ladder.system, ts, ladder.omega), ladder.omega, ladder.method,
                             **ladder.options)
    return probS, ts


def exact_section(ladder, ex, N, att, t0, start="exact"):
    """The exact orbit ``ex`` (on the grid ``t_k = k T / N`` of the method) as the start of the problem with
    its section at the step farthest from the orbit's events, when one lies within two steps of ``t = 0``
    (an impact at the section: the state there is ambiguous to one step, and Newton cycles the impact
    across the section)."""
    T = 2 * math.pi / ladder.omega
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
        probS, ts = section_problem(ladder, k)
    except InputError:
        return att
    # q_s(t) = q(t + t_s): coefficients advanced by t_s, the state at grid point k
    gS = {"q_hat": shift_hat(ex.q_hat, ladder.omega, ts), "q0": ex.q[k].copy(), "u0": ex.u[k].copy()}
    return ladder.try_(start, probS.initial_guess(gS), f"{att.note}; section at t0 = {k}/{N} T, away from the "
                       "orbit's events", 0, t0, problem=probS, section=(k, ts))


# ---------------------------------------------------------------------------------------------- the starts
class GuessStart:
    name = "guess"

    def run(self, ladder):
        if ladder.guess is None:
            return None
        return ladder.try_("guess", ladder.problem.initial_guess(ladder.guess))


class LinearStart:
    name = "linear"

    def run(self, ladder):
        return ladder.try_("linear", ladder.problem.initial_guess("linear"))


class ZeroStart:
    name = "zero"

    def run(self, ladder):
        return ladder.try_("zero", ladder.problem.initial_guess("zero"))


class ClampedStart:
    name = "clamped"

    def run(self, ladder):
        if not ladder.system.elements:
            return None
        return ladder.try_("clamped", ladder.x_from_hat(clamped_response(ladder.system, ladder.omega, ladder.n_h)))


class RegularisationStart:
    name = "regularisation"

    def run(self, ladder):
        t0 = time.perf_counter()
        path = ladder.problem.homotopy()[:-1]  # softened laws (HBM); [] for the other methods
        if not path:
            return None
        x = ladder.problem.initial_guess("linear")
        it = 0
        for i, sub in enumerate(path):
            r = solve_problem(sub, x, **ladder.nkw)
            it += r.nit
            if not r.success:
                return ladder.try_("regularisation", x, f"stage {i + 1}/{len(path)} failed: {r.message}", it, t0)
            x = r.x
        return ladder.try_("regularisation", x, f"{len(path)} softened stages", it, t0)


class ShiftedStart:
    name = "shifted"

    def run(self, ladder):
        if ladder.problem.time_step is None:
            return None
        t0 = time.perf_counter()
        N = int(ladder.problem.steps)
        best = ladder.best()
        parts = None
        if best is not None:
            try:
                parts = best.parts()
            except (FloatingPointError, np.linalg.LinAlgError, ValueError):
                parts = None
        if parts is None or event_steps(parts, ladder.system).size == 0:
            return None  # no event near which the section could lie
        k = section_shift(parts, ladder.system, N)
        try:
            probS, ts = section_problem(ladder, k)
        except InputError as exc:
            return ladder.try_("shifted", ladder.problem.initial_guess("linear"), f"skipped: {exc}", 0, t0)
        rS = solve_problem(probS, probS.initial_guess("linear"), **ladder.nkw)
        note = f"section at t0 = {k}/{N} T: {rS.message}"
        if not np.all(np.isfinite(rS.x)):
            return ladder.try_("shifted", ladder.problem.initial_guess("linear"), note, rS.nit, t0)
        pS = probS.solution_parts(rS.x)
        # q(t) = q_s(t - t0): q(0) = q_s(T - t0), the state at step N - k of the shifted period
        q_hat = shift_hat(pS["q_hat"], ladder.omega, -ts)
        g = hat_guess(q_hat, ladder.omega)
        td = np.asarray(pS["time_dofs"], dtype=np.int64)
        g["q0"][td] = pS["q_time"][N - k]
        g["u0"][td] = pS["u_time"][N - k]
        if not all(np.all(np.isfinite(v)) for v in g.values()):
            return ladder.try_("shifted", ladder.problem.initial_guess("linear"), note, rS.nit, t0)
        att = ladder.try_("shifted", ladder.problem.initial_guess(g), note, rS.nit, t0)
        if not att.accepted:
            # the orbit back at the section t = 0 is not accepted (an impact near t = 0 makes the state there
            # ambiguous to one step): the start "section" keeps the section at t0, if no other start succeeds
            ladder.section_candidate = (probS, rS, k, ts, note)
        return att


class SectionStart:
    """The ``"shifted"`` start's solution with the section kept at ``t0`` (the same discrete orbit on the
    same grid, reported in the original time by the driver), when the orbit mapped back to ``t = 0`` was
    not accepted."""

    name = "section"

    def run(self, ladder):
        cand = ladder.section_candidate
        if cand is None:
            return None
        probS, rS, k, ts, note = cand
        return ladder.try_("section", probS.initial_guess("linear"), f"{note}; section kept at t0", 0,
                           problem=probS, section=(k, ts), result=rS)


class ExactStart:
    name = "exact"

    def run(self, ladder):
        system, problem, omega = ladder.system, ladder.problem, ladder.omega
        if len(system.elements) != 1 or system.n > EXACT_MAX_DOFS:
            return None
        t0 = time.perf_counter()
        N = int(problem.steps) if problem.time_step is not None else 2048
        why = []
        probe = {}  # the transient state's probe (_guesses): "state", "orbit" and the "attempts" set aside
        for g in self._guesses(ladder, probe):
            if g is _PROBED:  # the transient state's turn, its orbit known from the probe
                if "attempts" in probe:  # (attracting, not accepted): the attempts set aside, now
                    ladder.attempts.extend(probe["attempts"])
                    return ladder.attempts[-1]
                ex = probe["orbit"]
            else:
                # the event-driven solve stops when its work budget EXACT_WORK is spent (stiff modes at a low
                # frequency: many flow steps a period), or at the caller's deadline (max_time)
                spent = newton_.work_spent()
                stop = [d for d in (ladder.deadline, newton_.deadline()) if d is not None]
                left = None if not stop else min(stop) - time.perf_counter()
                if spent is not None or (left is not None and left <= 0.0):
                    why.append(f"{spent or 'time budget'} spent")
                    break
                try:
                    ex = metered_exact(system, omega, guess=g, samples=max(N, 64), harmonics=max(ladder.n_h, 1),
                                       blas_threads=None, time_limit=left)
                except (InputError, FloatingPointError, np.linalg.LinAlgError, ValueError) as exc:
                    why.append(f"{type(exc).__name__}: {exc}")
                    continue
                if g is probe.get("state") and "orbit" not in probe:
                    probe["orbit"] = ex
                    if ex.success and ex.stable is True and np.all(np.isfinite(ex.q_hat)):
                        n0 = len(ladder.attempts)
                        att = self._from_orbit(ladder, ex, N, t0, PROBE_NOTE)
                        if att.accepted:
                            return att
                        # not accepted: as if not probed (its attempts wait for the transient state's own turn)
                        probe["attempts"] = ladder.attempts[n0:]
                        del ladder.attempts[n0:]
                    continue  # (named in the record at the transient state's own turn)
            if ex.success and np.all(np.isfinite(ex.q_hat)):
                return self._from_orbit(ladder, ex, N, t0)
            why.append(ex.message)
        # no Newton solve of the method from the linear response here: that is the start "linear" (tried before
        # this one); the record names why the exact orbit was not found
        x0 = problem.initial_guess("linear")
        failed = newton_.NewtonResult(x=np.array(x0, dtype=float), success=False, nit=0, nfev=0,
                                      residual_norm=float("inf"), message="the exact orbit was not found")
        return ladder.try_("exact", x0, "exact_periodic failed: " + "; ".join(w[:120] for w in why), 0, t0,
                           result=failed)

    @staticmethod
    def _from_orbit(ladder, ex, N, t0, how=""):
        """The method's Newton from the exact orbit ``ex`` (and from it with the section moved away from its events,
        :func:`exact_section`, when that is not accepted); ``how`` ends the attempt's note."""
        problem = ladder.problem
        gg = {"q_hat": ex.q_hat, "q0": ex.q[0].copy(), "u0": ex.u[0].copy()}
        att = ladder.try_("exact", problem.initial_guess(gg), f"exact orbit: {ex.message}{how}", 0, t0)
        if att.accepted or problem.time_step is None or ex.q.shape[0] != N + 1:
            return att
        return exact_section(ladder, ex, N, att, t0)

    @staticmethod
    def _guesses(ladder, probe):
        """The linear start, the state of rest (on the reduced cantilever's tip stop at 0.99 w_1 the exact flow's
        Newton converged from rest and stalled from the linear response), the state at ``t = 0`` of the best
        attempt so far (when finite), then the state a Moreau-Jean transient from rest reaches
        (:meth:`_transient_state`; near that beam's resonance, 1.01-1.02 w_1, the exact flow's Newton stalls from
        the linear response and from rest, 30 and 16 iterations, 2-5 s of CPU, and converges in 3 iterations from
        the transient state).

        Where the linear response runs through the stop (:func:`linear_penetrates`: the linear start is then no
        answer) and ``T`` is the forcing's own period (:func:`forced_at_fundamental`), the transient state is
        *probed* first: :meth:`run` takes its exact orbit at once when the orbit is attracting (the exact monodromy's
        multipliers inside the unit circle: the orbit the simulation settled on, not one it passed near) and the
        method's solution from it is accepted.  Otherwise the order above holds as without the probe: the probe's
        attempts are set aside, so that the best attempt so far is the same, and are recorded at the transient
        state's own turn, last, with no second solve (``probe``: ``"state"``, ``"orbit"``, ``"attempts"``).  Not for
        the ``kT`` problems of :mod:`mshbm.period`: their orbit comes in ``k`` copies shifted by the forcing period and
        the transient picks one by chance (the impact chain's period-2 MS-HBM solve at pi / 5 then ended on the
        T-periodic orbit)."""
        n = ladder.system.n
        # (a generator: the simulation runs only when its turn comes)
        if linear_penetrates(ladder.system, ladder.omega, ladder.n_h) and forced_at_fundamental(ladder.system,
                                                                                              ladder.omega):
            probe["state"] = ExactStart._transient_state(ladder)
            if probe["state"] is not None:
                yield probe["state"]
        yield "linear"
        yield {"q0": np.zeros(n), "u0": np.zeros(n)}
        best = ladder.best()
        if best is not None:
            try:
                p = best.parts()
                q0 = p["q_hat"][0] + p["q_hat"][1::2].sum(axis=0)
                u0 = fourier.derivative(p["q_hat"], ladder.omega)[1::2].sum(axis=0)
                td = np.asarray(p["time_dofs"], dtype=np.int64)
                q0[td], u0[td] = p["q_time"][0], p["u_time"][0]
                if np.all(np.isfinite(q0)) and np.all(np.isfinite(u0)):
                    yield {"q0": q0, "u0": u0}
            except (FloatingPointError, np.linalg.LinAlgError, ValueError):
                pass
        if "state" in probe:  # probed first: its orbit (a failed probe solve is named in the record already)
            if "orbit" in probe:
                yield _PROBED
            return
        simulated = ExactStart._transient_state(ladder)
        if simulated is not None:
            yield simulated

    @staticmethod
    def _transient_state(ladder, drift_tol=1e-3):
        """``{"q0", "u0"}`` at ``t = 0`` after a Moreau-Jean simulation of the whole system from rest
        (:func:`mshbm.subharmonic.transient_guess`; the method's steps per period, 1024 for HBM), ended when the
        state changes by less than ``drift_tol`` of its size over a period or after ``max(transient_periods)``
        periods; ``None`` when the simulation would exceed the ladder's ``transient_budget`` (``n^2 x steps x
        periods``), fails or diverges."""
        n = ladder.system.n
        steps = int(ladder.problem.steps) if ladder.problem.time_step is not None else 1024
        periods = max(ladder.transient_periods)
        if n > MAX_DENSE_DOFS or float(n) * n * steps * periods > ladder.transient_budget:
            return None
        opts = {"steps": steps, "theta": ladder.options.get("theta", 0.5), "project": ladder.options.get("project", True)}
        try:
            guess = transient_guess(ladder.system, ladder.omega, opts, periods, drift_tol=drift_tol)
        except InputError:
            return None
        return None if guess is None else {"q0": guess["q0"][:n].copy(), "u0": guess["u0"][:n].copy()}


class TransientStart:
    name = "transient"

    def run(self, ladder):
        system, problem, omega = ladder.system, ladder.problem, ladder.omega
        n = system.n
        steps = int(problem.steps) if problem.time_step is not None else 1024
        total = max(ladder.transient_periods)
        if n > MAX_DENSE_DOFS or float(n) * n * steps * total > ladder.transient_budget:
            return None
        t0 = time.perf_counter()
        q, u = self._initial_state(ladder)
        T = 2 * math.pi / omega
        theta = float(ladder.options.get("theta", 0.5))  # (validated options: only the time-stepping methods have one)
        try:
            stepper = MoreauJean(system.M, system.C, system.K, system.elements, T / steps,
                                 theta, bool(ladder.options.get("project", True)))
        except InputError:  # an element time stepping does not support (elastic friction): no transient start
            return None
        t = np.linspace(0.0, T, steps + 1)
        B = stepper.increments(system.forcing(t, omega))
        done, att, it = 0, None, 0
        for cp in ladder.transient_periods:
            tr = None
            while done < cp:
                tr = stepper.run(q, u, B)
                q, u = tr.q[-1].copy(), tr.u[-1].copy()
                done += 1
                if not (np.all(np.isfinite(q)) and np.all(np.isfinite(u))):
                    return ladder.try_("transient", problem.initial_guess("linear"),
                                       f"the simulation diverged after {done} periods", 0, t0)
                if self._over(ladder, t0):
                    break
            if tr is None:
                break
            # the structure's DOFs (the stepper also integrates the sliders of Jenkins elements)
            gg = {"q_hat": fourier.fft(tr.q[:-1, :n], ladder.n_h), "q0": q[:n].copy(), "u0": u[:n].copy()}
            drift = float(np.max(np.abs(np.concatenate([tr.q[-1] - tr.q[0], tr.u[-1] - tr.u[0]]))))
            att = ladder.try_("transient", problem.initial_guess(gg),
                              f"{done} periods simulated (period drift {drift:.1e})", it, t0)
            if att.accepted:
                return att
            ladder.attempts.pop()  # keep one record per start: the last checkpoint
            it += att.newton.nit
            if self._over(ladder, t0):
                break
        if att is not None:
            ladder.attempts.append(att)
            att.note += f"; stopped after {done} periods (budget spent)" if done < total else ""
        return att

    @staticmethod
    def _initial_state(ladder):
        """``(q, u)`` at ``t = 0`` of the best attempt so far, unless it is not finite or has run away (then
        from rest)."""
        best = ladder.best()
        try:
            g = best.parts() if best is not None else None
        except (FloatingPointError, np.linalg.LinAlgError, ValueError):
            g = None
        D = displacement_scale(ladder.system, ladder.omega)
        if g is not None and not (all(np.all(np.isfinite(g[k])) for k in ("q_hat", "q_time", "u_time"))
                                  and np.max(np.abs(g["q_time"]), initial=0.0) <= 1e3 * D):
            g = None
        q_hat0 = g["q_hat"] if g is not None else np.zeros((2 * ladder.n_h + 1, ladder.system.n))
        start = hat_guess(q_hat0, ladder.omega)
        if g is not None:
            td = np.asarray(g["time_dofs"], dtype=np.int64)
            if np.all(np.isfinite(g["q_time"])) and np.all(np.isfinite(g["u_time"])):
                start["q0"][td] = g["q_time"][0]
                start["u0"][td] = g["u_time"][0]
        return start["q0"].copy(), start["u0"].copy()

    @staticmethod
    def _over(ladder, t0):
        """The simulation stops: the ladder's budget is spent or the caller's deadline has passed (its Newton
        solves would stop at once)."""
        return ladder.over()
