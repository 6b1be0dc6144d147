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

In both variants the time-domain forcing of the integrated subsystem is affine
in the harmonic unknowns, so the exact Jacobian follows from the sensitivities
of the Moreau-Jean steps (``jacobian="exact"``); forward differences are
available (``jacobian="fd"``, the paper's choice).

``integrator="event"`` (both variants): the subsystem is integrated by the exact event-driven flow
(:class:`mshbm.integrators.event.EventFlow`).  Between events it is linear and forced by a
trigonometric polynomial (its external force plus the harmonic coupling force
``V(t)^T c``, ``c = c0 + Tr p``); the coupling coefficients are *forcing states* of the augmented
state (``coupling_harmonics=n_h``), so the mode matrices do not depend on ``p`` and the
sensitivities to ``p`` are columns of the same saltation-corrected monodromy.  The Fourier
coefficients ``FFT(q_1)`` of the residual are the exact ones of the flow (Gauss-Legendre quadrature
on every smooth piece, exact to rounding, with their exact sensitivities), so the only error left is
the harmonic truncation of the coupling.  ``steps`` is then the output grid (and the Moreau-Jean
steps per period of the fallback at accumulations, reported in ``info["event_integrator"]``).
``accumulation="close"`` replaces that fallback by the Zeno closure of the contact (exact up to the
dropped tail, ``< 1e-10`` of the scale): the monodromy stays exact through accumulating impacts, which
is what lets Newton converge on stiff bodies that bounce to rest every period (the finite-element
example's pad, 20 ``omega_1`` on its spring; with the fallback Newton stalls there).

Many nonlinear DOFs: the integrated subsystem couples to the rest only through the harmonic force
coefficients ``c`` (the condensed compliance).  Where its own ``M, C, K`` and elements split it into
independent blocks (elements spread along a structure), each block is integrated alone with
sensitivities only with respect to its states and its own ``(2 n_h + 1) n_b`` coefficients of ``c``;
``d/dp`` follows by the chain rule through ``dc/dp`` (:class:`_TimeDomainPart`).  The cost of a
Jacobian is then linear in the number of blocks instead of cubic in ``n_N``.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import fourier
from .base import Partition, PeriodicProblem, forward_difference_jacobian
from .common import complement, failed_parts, guess_parts
from ..errors import InputError
from ..condensation import Condensation, condense_around_resonances, resonance_note
from ..integrators.moreau_jean import MoreauJean, Trajectory
from ..system import System

__all__ = ["MixedProblem", "IntermediateProblem", "StandardAsIntermediate", "auto_intermediate_partition",
           "intermediate_problem"]


def _sub(A, r, c):
    if sp.issparse(A):
        return A.tocsr()[r][:, c]
    return np.asarray(A)[np.ix_(r, c)]


def _coupling(system, r, c, n_h, omega):
    """Complex per-harmonic blocks ``H_rc,k``, shape (n_h+1, len(r), len(c))."""
    out = np.zeros((n_h + 1, len(r), len(c)), dtype=complex)
    Ms, Cs, Ks = (_sub(getattr(system, a), r, c) for a in "MCK")
    dense = lambda A: A.toarray() if sp.issparse(A) else A
    Ms, Cs, Ks = dense(Ms), dense(Cs), dense(Ks)
    for k in range(n_h + 1):
        out[k] = Ks - (k * omega) ** 2 * Ms + 1j * k * omega * Cs
    return out


def _local_elements(system, dofs):
    pos = {int(d): i for i, d in enumerate(dofs)}
    out = []
    for el in system.elements:
        for d in el.dofs:
            if int(d) not in pos:
                raise InputError("partition", f"{el.kind} element on DOF {d} is not in the nonlinear subsystem")
        out.append(el.renumbered(pos))
    return out


def _blocks(M, C, K, elements):
    """Independent blocks of an integrated subsystem: connected components of the graph of the nonzeros
    of ``M, C, K`` (dense, subsystem numbering) joined by the DOFs of each element.

    Returns a list of ``(dofs, element indices)`` (both sorted int arrays), or ``None`` when the subsystem
    is one block or carries an element whose coupling this function does not know (then it is integrated
    as one block).
    """
    from scipy.sparse.csgraph import connected_components

    from ..elements import Contact, Friction, Jenkins

    n = M.shape[0]
    if n < 2 or any(type(el) not in (Friction, Contact, Jenkins) for el in elements):
        return None
    if any(getattr(el, "normal_contact", None) is not None for el in elements):
        return None  # a friction loaded by a contact couples the two elements' DOFs: one block
    A = (np.abs(M) + np.abs(C) + np.abs(K)) > 0
    rows, cols = np.nonzero(A)
    for el in elements:
        d = [int(x) for x in el.dofs]
        rows = np.concatenate([rows, d[:-1]])
        cols = np.concatenate([cols, d[1:]])
    graph = sp.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n))
    n_comp, label = connected_components(graph, directed=False)
    if n_comp < 2:
        return None
    el_label = np.array([label[int(el.dofs[0])] for el in elements], dtype=np.int64)
    return [(np.flatnonzero(label == b), np.flatnonzero(el_label == b)) for b in range(n_comp)]


class _Block:
    """One independent block of the integrated subsystem (see :class:`_TimeDomainPart`): its own
    Moreau-Jean stepper and the increments of the unit harmonic forces on its DOFs."""

    def __init__(self, dofs, el_idx, M, C, K, elements, h, theta, project, V, n1, slider_row):
        self.dofs = dofs  # structure DOFs, subsystem numbering
        pos = {int(d): i for i, d in enumerate(dofs)}
        els = [elements[j].renumbered(pos) for j in el_idx]
        ix = np.ix_(dofs, dofs)
        self.stepper = MoreauJean(M[ix], C[ix], K[ix], els, h, theta, project)
        # integrated states of the block in the subsystem's integrated numbering: its structure DOFs, then
        # the sliders of its Jenkins elements (in element order, as MoreauJean appends them)
        sliders = [slider_row[int(el_idx[j])] for j, _ in self.stepper.sliders]
        self.rows = np.concatenate([dofs, np.asarray(sliders, dtype=np.int64)]).astype(np.int64)
        self.el_idx = el_idx
        nc, nb = V.shape[1], dofs.size
        # coefficient c_(k, i) of the force on subsystem DOF i (harmonic-major): the block's columns
        self.cidx = (np.arange(nc)[:, None] * n1 + dofs[None, :]).reshape(-1)
        # where the block's sensitivities go in the subsystem's (rows; columns [q0 (n_A), u0 (n_A), p])
        nA = n1 + len(slider_row)
        r = self.rows
        self.at_q0, self.at_u0 = np.ix_(r, r), np.ix_(r, nA + r)
        self.at_hat_q0, self.at_hat_u0 = np.ix_(self.cidx, r), np.ix_(self.cidx, nA + r)
        # d f / d c_(k, a) = V_k(t) e_a  ->  increments, shape (N, n_block, nc * nb)
        dF = np.zeros((V.shape[0], nb, nc, nb))
        for a in range(nb):
            dF[:, a, :, a] = V
        self.dB = self.stepper.increments(dF.reshape(V.shape[0], nb, nc * nb))


class _TimeDomainPart:
    """Moreau-Jean integration of a subsystem driven by a harmonic forcing affine in parameters.

    The force on the subsystem is ``f(t) = f0(t) + V(t)^T c`` with the real coefficient
    vector ``c = c0 + Tr p`` (``c`` flattened harmonic-major, shape ``((2n_h+1) n_1,)``).

    When the subsystem falls apart into independent blocks (:func:`_blocks`: no mass, damping or
    stiffness entry and no element joins them, e.g. friction elements spread along a chain, coupled only
    through the condensed linear part, i.e. through ``c``), each block is integrated on its own, with
    sensitivities with respect to its own states and its own ``(2 n_h + 1) n_b`` coefficients of ``c``
    only; ``d/dp`` follows by the chain rule through ``Tr``.  The cost of the sensitivities is then
    ``sum_b N n_b^2 (2 + 2 n_h + 1) n_b`` instead of ``N n_1^2 (2 n_1 + n_p)``, and nothing of size
    ``N n_1 n_p`` is stored.  Otherwise (one block) the whole subsystem is integrated with sensitivities
    with respect to ``(q0, u0, p)`` directly.
    """

    def __init__(self, system, dofs, omega, n_h, steps, theta, project, c0, Tr):
        self.dofs = np.asarray(dofs, dtype=np.int64)
        self.n1 = self.dofs.size
        self.N = int(steps)
        self.T = 2 * np.pi / omega
        self.h = self.T / self.N
        self.t = np.linspace(0.0, self.T, self.N + 1)
        self.n_h = n_h
        M, C, K = (_sub(getattr(system, a), self.dofs, self.dofs) for a in "MCK")
        els = _local_elements(system, self.dofs)
        self.stepper = MoreauJean(M, C, K, els, self.h, theta, project)
        V = fourier.basis(self.t, omega, n_h)
        nc = 2 * n_h + 1
        self.nc = nc
        self.Tr = np.asarray(Tr, dtype=float)
        n_p = self.Tr.shape[1]
        self.n_p = n_p
        f0 = system.forcing(self.t, omega, self.dofs) + V @ c0.reshape(nc, self.n1)
        dense = lambda A: A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)
        parts = _blocks(dense(M), dense(C), dense(K), els)
        if parts is None:
            self.blocks = None
            self.B0 = self.stepper.increments(f0)
            dF = np.einsum("kj,jlp->klp", V, self.Tr.reshape(nc, self.n1, n_p))
            self.dB = self.stepper.increments(dF)
        else:
            self.f0, self.V = f0, V
            slider_row = {j: z for j, z in self.stepper.sliders}
            self.blocks = [_Block(d, e, dense(M), dense(C), dense(K), els, self.h, theta, project, V, self.n1,
                                  slider_row) for d, e in parts]

        # Fourier projection of sampled signals: a DFT matrix is cheaper than an FFT of all N
        # frequencies when only 2 n_h + 1 coefficients are needed (kept below ~100 MB)
        self.E = fourier.dft_matrix(self.N, n_h) if nc * self.N <= 12_000_000 else None

    def project(self, x):
        """Coefficients (eq. 28) of samples ``x`` of shape (N, ...) -> (2 n_h + 1, ...)."""
        if self.E is None:
            return fourier.fft(x, self.n_h)
        return (self.E @ x.reshape(self.N, -1)).reshape((self.E.shape[0],) + x.shape[1:])

    def run(self, q0, u0, p, sens=True):
        """Trajectory from ``(q0, u0)`` (integrated states, shape ``(n_A,)``) under parameters ``p``.

        With ``sens``: ``Sq, Su`` (shape ``(n_A, 2 n_A + n_p)``, columns ``[q0, u0, p]``) and
        ``q_hat_sensitivity`` (shape ``((2 n_h + 1) n_1, 2 n_A + n_p)``: the Fourier coefficients (eq. 28) of
        ``dq_k/d(q0, u0, p)`` over ``k = 0 .. N-1``, harmonic-major); ``Sq_traj`` is not kept.
        """
        if self.blocks is None:
            B = self.B0 + np.einsum("kip,p->ki", self.dB, p)
            tr = self.stepper.run(q0, u0, B, self.dB, sensitivities=sens, store_q_sensitivities=sens)
            if sens:
                n1 = self.n1
                tr.q_hat_sensitivity = self.project(tr.Sq_traj[:-1, :n1]).reshape(self.nc * n1, -1)
                tr.Sq_traj = None
            return tr
        return self._run_blocks(q0, u0, p, sens)

    def _run_blocks(self, q0, u0, p, sens):
        q0, u0 = self.stepper.with_slider_state(q0, u0)
        nA, n1, nc, N = self.stepper.n, self.n1, self.nc, self.N
        c = (self.Tr @ p).reshape(nc, n1)
        F = self.f0 + self.V @ c
        q = np.empty((N + 1, nA))
        u = np.empty((N + 1, nA))
        m = self.stepper.m
        P = np.zeros((N, m))
        status = np.zeros((N, m), dtype=np.int8)
        n_s = 2 * nA + self.n_p
        Sq = np.zeros((nA, n_s)) if sens else np.zeros((nA, 0))
        Su = np.zeros((nA, n_s)) if sens else np.zeros((nA, 0))
        dqh = np.zeros((nc * n1, n_s)) if sens else None
        pgs = 0
        for b in self.blocks:
            r, nb, nsb = b.rows, b.rows.size, b.dofs.size
            B = b.stepper.increments(F[:, b.dofs])
            tr = b.stepper.run(q0[r], u0[r], B, b.dB, sensitivities=sens, store_q_sensitivities=sens)
            q[:, r], u[:, r] = tr.q, tr.u
            P[:, b.el_idx], status[:, b.el_idx] = tr.P, tr.status
            pgs = max(pgs, int(tr.pgs_iterations))
            if not sens:
                continue
            # kernel columns of the block: [q0_b (nb), u0_b (nb), c_b (nc nsb)]; d/dp = d/dc_b Tr[c_b]
            Trb = self.Tr[b.cidx]
            for S_out, S_b in ((Sq, tr.Sq), (Su, tr.Su)):
                S_out[b.at_q0] = S_b[:, :nb]
                S_out[b.at_u0] = S_b[:, nb:2 * nb]
                S_out[r, 2 * nA:] = S_b[:, 2 * nb:] @ Trb
            D = self.project(tr.Sq_traj[:-1, :nsb]).reshape(nc * nsb, -1)  # rows (k, a) -> row k n1 + dofs[a]
            dqh[b.at_hat_q0] = D[:, :nb]
            dqh[b.at_hat_u0] = D[:, nb:2 * nb]
            dqh[b.cidx, 2 * nA:] = D[:, 2 * nb:] @ Trb
        out = Trajectory(q, u, P, status, Sq, Su, None, pgs)
        out.q_hat_sensitivity = dqh
        return out


class _MixedBase(PeriodicProblem):
    """What both MS-HBM variants share: unknowns ``x = (p, q_1(0), u_1(0))`` with the harmonic
    unknowns ``p`` (coefficients of the DOFs ``_harm``) and the states of the time-stepped DOFs
    ``_time``; residual ``(balance(FFT(q_1), p), q_1(T) - q_1(0), u_1(T) - u_1(0))``.  Subclasses set
    ``_time``, ``_harm``, ``_cond_dofs``, ``td``, ``cond``, ``nc`` and the balance hooks."""

    @property
    def n_unknowns(self):
        return self.nc * self._harm.size + 2 * self.nA

    @property
    def steps(self):
        return self.td.N

    @property
    def time_step(self):
        return None if self.integrator == "event" else self.td.h

    @property
    def cheap_jacobian(self):
        """Event-driven flow with the exact Jacobian: Newton evaluates the full step with its Jacobian
        (:func:`mshbm.solvers.newton.newton`; the iterates do not change).  Its full steps are nearly always
        taken, and when one is not, the watchdog evaluates the same point with its Jacobian anyway (found in
        the run cache), so this saves the separate residual-only flow of every iteration."""
        return self.integrator == "event" and self.jacobian == "exact"

    def time_stepper(self):
        return None if self.integrator == "event" else self.td.stepper

    def _setup_integrator(self, integrator, system, dofs, c0, Tr, accumulation="moreau"):
        """``integrator="event"``: the event-driven flow of the time-domain subsystem with the coupling force
        as forcing states (module docstring); ``accumulation`` its treatment of accumulating impacts."""
        self.integrator = integrator
        if integrator != "event":
            return
        from ..integrators.event import EventFlow

        dense = lambda A: A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)
        M, C, K = (dense(_sub(getattr(system, a), dofs, dofs)) for a in "MCK")
        sub = System(M, C, K, system.f_hat[:, dofs], _local_elements(system, dofs), name=f"{system.name}-sub")
        self.flow = EventFlow(sub, self.omega, accumulation=accumulation, moreau_steps=self.td.N,
                              coupling_harmonics=self.n_h)
        self._c0 = np.asarray(c0, dtype=float).reshape(-1)
        self._Tr = dense(Tr)
        self._ev_cache = None

    def _event_run(self, x, sens, record=False):
        from ..integrators.event import EventError

        # the last few runs: a run with sensitivities also answers a residual-only request at the same
        # x (the flow, its events and Fourier coefficients do not depend on them: the same numbers)
        xb = np.asarray(x).tobytes()
        cache = self._ev_cache if self._ev_cache is not None else []
        for kx, ks, kr, kout in cache:
            if kx == xb and kr == record and (ks == sens or (ks and not sens)):
                return kout
        p, q0, u0 = self._split(x)
        n1 = self._time.size
        fl = self.flow
        fl.set_forcing((self._c0 + self._Tr @ p).reshape(self.nc, n1))
        try:
            out = fl.simulate(0.0, fl.state(0.0, q0, u0), jac=sens, jac_cols="all", fourier=self.n_h,
                              sample_times=self.td.t if record else None, record=record)
        except (EventError, ValueError) as exc:  # ValueError: event bracketing lost to rounding
            self.last_error = f"{type(exc).__name__}: {exc}"
            out = None
        self._ev_cache = ([(xb, sens, record, out)] + cache)[:3]
        return out

    def event_signature(self, x):
        """``((element, kind), ...)`` of the events of the period from ``x`` (event integrator), else ``None``."""
        if getattr(self, "integrator", "moreau") != "event":
            return None
        out = self._event_run(np.asarray(x, dtype=float), False)
        return None if out is None else tuple((int(e.element), e.kind) for e in out.events)

    def _event_residual(self, x, jac):
        n1, a = self._time.size, self.nc * self._harm.size
        p, q0, u0 = self._split(x)
        out = self._event_run(x, jac and self.jacobian == "exact")
        if out is None:
            return np.full(x.size, np.nan), (np.full((x.size, x.size), np.nan) if jac else None)
        R = np.concatenate([self._balance(out.q_hat.reshape(-1), p), out.end_state[:n1] - q0,
                            out.end_state[n1:2 * n1] - u0])
        if not jac:
            return R, None
        if self.jacobian == "fd":
            return R, forward_difference_jacobian(lambda xp: self._event_residual(xp, False)[0], x, R)
        # Phi columns: [q0, u0, forcing states = d/dc]; x = [p, q0, u0], dc/dp = Tr
        dq = out.q_hat_sensitivity.reshape(self.nc * n1, -1)
        Dq = np.hstack([dq[:, 2 * n1:] @ self._Tr, dq[:, :2 * n1]])
        Pz = out.monodromy[:2 * n1]
        Dz = np.hstack([Pz[:, 2 * n1:] @ self._Tr, Pz[:, :2 * n1]])
        J = np.zeros((x.size, x.size))
        J[:a] = self._balance_dq(Dq)
        J[:a, :a] += self._balance_dp()
        J[a:] = Dz
        J[a:, a:] -= np.eye(2 * n1)
        return R, J

    def _event_solution_parts(self, x):
        from ..extrema import fourier_extrema
        from ..integrators.event import MOREAU, contact_margins, extrema, run_summary

        p, q0, u0 = self._split(x)
        out = self._event_run(x, False, record=True)
        if out is None:  # no flow to report: non-finite parts, which the driver reports as a failure, with why
            return failed_parts(self.td.t, self.td.N, (self.nc, self.system.n), self._time,
                                len(self.system.elements), self.n_h, "the event-driven flow failed at the "
                                f"solution: {getattr(self, 'last_error', 'unknown error')}")
        fl, n1, N = self.flow, self._time.size, self.td.N
        Z = out.samples
        q_t, u_t = Z[:n1].T.copy(), Z[n1:2 * n1].T.copy()
        X = p.reshape(self.nc, self._harm.size)
        q_hat = np.zeros((self.nc, self.system.n))
        q_hat[:, self._time] = out.q_hat
        if not self._harmonic_dofs_are_time_dofs:
            q_hat[:, self._harm] = X
        if self._cond_dofs.size:
            q_hat[:, self._cond_dofs] = fourier.from_complex(self.cond.recover(fourier.to_complex(X)))
        lam = np.full((N + 1, len(self.system.elements)), np.nan)
        modes = out.sample_modes
        for code in np.unique(modes):
            sel = modes == code
            lam[sel] = (fl.moreau_force(out.moreau_segments, self.td.t[sel]) if code == MOREAU
                        else fl.full_force(int(code), Z[:, sel]).T)
        P = np.nan_to_num(lam[:-1]) * self.td.h
        for ev in out.events:
            if ev.impulse != 0.0:
                P[min(int(ev.t / self.td.h), N - 1), ev.element] += ev.impulse
        hi, lo = fourier_extrema(q_hat)
        qmax, qmin, _ = extrema(fl, out.nodes)  # time DOFs: the true extrema of the flow
        hi[self._time], lo[self._time] = qmax, qmin
        info = {**self._info(p, q_hat),
                "amplitude_exact": 0.5 * (hi - lo),
                "event_integrator": run_summary(out),
                "event_list": out.events, "contact_margins": contact_margins(fl, out)}
        return dict(t=self.td.t, q_hat=q_hat, time_dofs=self._time, q_time=q_t, u_time=u_t,
                    lam=lam, impulses=P, harmonics=self.n_h, info=info)

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
        q0, u0 = self.td.stepper.with_slider_state(parts[1], parts[2])
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

    def _eval(self, x, sens):
        p, q0, u0 = self._split(x)
        tr = self.td.run(q0, u0, p, sens)
        qh = self.td.project(tr.q[:-1, :self._time.size]).reshape(-1)
        R = np.concatenate([self._balance(qh, p), tr.q[-1] - q0, tr.u[-1] - u0])
        return R, tr

    def residual(self, x, jac=True):
        """``(R, J)``, shapes ``(n_x,)`` and ``(n_x, n_x)``."""
        if self.integrator == "event":
            return self._event_residual(np.asarray(x, dtype=float), jac)
        if not jac:
            return self._eval(x, False)[0], None
        if self.jacobian == "fd":
            R, _ = self._eval(x, False)
            return R, forward_difference_jacobian(lambda xp: self._eval(xp, False)[0], x, R)
        R, tr = self._eval(x, True)
        nt, a = self.nA, self.nc * self._harm.size
        # kernel columns: [q0 (nA), u0 (nA), p (a)] -> reorder to x = [p, q0, u0]; nA: the time-stepped
        # DOFs, then one slider per Jenkins element (mshbm.integrators.moreau_jean)
        perm = np.concatenate([np.arange(2 * nt, 2 * nt + a), np.arange(2 * nt)])
        n1 = self._time.size
        dqh = tr.q_hat_sensitivity[:, perm]
        J = np.zeros((x.size, x.size))
        J[:a] = self._balance_dq(dqh)
        J[:a, :a] += self._balance_dp()
        J[a:a + nt] = tr.Sq[:, perm]
        J[a + nt:] = tr.Su[:, perm]
        J[a:a + nt, a:a + nt] -= np.eye(nt)
        J[a + nt:, a + nt:] -= np.eye(nt)
        return R, J

    def solution_parts(self, x):
        if self.integrator == "event":
            return self._event_solution_parts(np.asarray(x, dtype=float))
        p, q0, u0 = self._split(x)
        tr = self.td.run(q0, u0, p, sens=False)
        X = p.reshape(self.nc, self._harm.size)
        q_hat = np.zeros((self.nc, self.system.n))
        n1 = self._time.size
        q_hat[:, self._time] = fourier.fft(tr.q[:-1, :n1], self.n_h)
        if not self._harmonic_dofs_are_time_dofs:
            q_hat[:, self._harm] = X
        if self._cond_dofs.size:
            q_hat[:, self._cond_dofs] = fourier.from_complex(self.cond.recover(fourier.to_complex(X)))
        lam = np.vstack([tr.P, tr.P[:1]]) / self.td.h
        info = {**self._info(p, q_hat),
                "stick_or_closed_fraction": [float(np.mean((tr.status[:, j] & 3) >= 2))
                                             for j in range(tr.status.shape[1])]}
        return dict(t=self.td.t, q_hat=q_hat, time_dofs=self._time, q_time=tr.q[:, :n1], u_time=tr.u[:, :n1],
                    lam=lam, impulses=tr.P, harmonics=self.n_h, info=info)


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
    accumulation : {"moreau", "close"}
        With ``integrator="event"``: at an accumulation of impacts switch to Moreau-Jean for that contact
        phase (default; also handles chattering), or close the contact once the bounces are below
        ``1e-10`` of the scale (the Zeno closure: the flow and its monodromy stay exact up to the dropped
        tail; chattering is then an error) (:mod:`mshbm.integrators.event`).

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

    def __init__(self, system, omega, harmonics, steps, theta=0.5, jacobian="exact", partition=None,
                 project=True, integrator="moreau", accumulation="moreau"):
        self.system, self.omega, self.n_h = system, float(omega), int(harmonics)
        self.jacobian = jacobian
        n = system.n
        self.Nd = system.nonlinear_dofs if partition is None else np.asarray(partition, dtype=np.int64)
        if self.Nd.size == 0:
            key = "partition" if partition is not None else "method"
            raise InputError(key, "the nonlinear subsystem is empty: the system has no friction or contact "
                             "element (use 'hbm', or give partition=[dofs] to integrate some DOFs in time)")
        self.Ld = complement(n, self.Nd)
        if partition is None:
            # a resonance of L (k omega an eigenfrequency of L with N clamped): its DOFs are integrated with N
            # instead of condensed (mshbm.condensation.condense_around_resonances)
            self.cond, self.Nd, self.Ld, moved = condense_around_resonances(system, omega, self.n_h, self.Nd, self.Ld)
            if moved:
                self.notes = [resonance_note(moved, "H_LL", "the time-integrated subsystem N")]
        else:
            self.cond = Condensation(system, omega, self.n_h, self.Nd, self.Ld)
        # coupling force coefficients on N:  c = -H_NL q_hat_L = -g + T q_hat_N
        c0 = fourier.from_complex(-self.cond.g).reshape(-1)
        Tr = self.cond.real_matrix(self.cond.T)
        self.td = _TimeDomainPart(system, self.Nd, omega, self.n_h, steps, theta, project, c0, Tr)
        self.nN = self.Nd.size
        self.nc = 2 * self.n_h + 1
        self._time, self._harm, self._cond_dofs = self.Nd, self.Nd, self.Ld
        self.nA = self.td.stepper.n  # integrated: N, then one slider per Jenkins element
        self._setup_integrator(integrator, system, self.Nd, c0, Tr, accumulation)

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
        H_NN = _coupling(self.system, self.Nd, self.Nd, self.n_h, self.omega)
        F = fourier.to_complex(self.system.forcing_hat(self.n_h))[:, self.Nd]
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
            self._H_NN = _coupling(self.system, self.Nd, self.Nd, self.n_h, self.omega)
        x = np.empty(self.system.n, dtype=complex)
        x[self.Nd], x[self.Ld] = self.cond.solve_full(int(k), self._H_NN[int(k)], b_T, forcing)
        return x

    def _info(self, p, q_hat):
        return {"connectivity_defect": float(np.max(np.abs(p - q_hat[:, self.Nd].reshape(-1)), initial=0.0))}


def _mixed_scale(problem, x, a, n1, force_rows):
    """Row scales ``(coefficient rows (a), q rows (n1), u rows (n1))`` of the mixed residuals."""
    from ..scaling import displacement_floor, force_scale, velocity_scale

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

    def __init__(self, system, omega, harmonics, steps, theta=0.5, jacobian="exact", partition=None,
                 project=True, integrator="moreau", accumulation="moreau"):
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
            blk = _sub(getattr(system, a), I1, I3)
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
        self.td = _TimeDomainPart(system, I1, omega, self.n_h, steps, theta, project, np.zeros(nc * I1.size), Tr)
        self.H21r = self.cond.real_matrix(H21)
        self.Sr = self.cond.real_matrix(H22 - self.cond.T)
        F = fourier.to_complex(system.forcing_hat(self.n_h))
        self.rhs = fourier.from_complex(F[:, I2] - self.cond.g).reshape(-1)
        self.nc, self.n1, self.n2 = nc, I1.size, I2.size
        self._time, self._harm, self._cond_dofs = I1, I2, I3
        self.nA = self.td.stepper.n  # integrated: subsystem 1, then one slider per Jenkins element
        self._setup_integrator(integrator, system, I1, np.zeros(nc * I1.size), Tr, accumulation)

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
