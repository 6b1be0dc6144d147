"""The energy checks of a certificate: ``energy_balance``, ``connectivity_work``, ``friction_dissipation``
and ``impact_dissipation``.

``energy_balance`` (gating where it applies)
    Over one period: input work of the forcing ``W_in = int f . u dt`` equals the dissipation of the
    dampers ``D_C = int u^T C u dt`` plus that of the elements ``D_el = -int w lambda u_dof dt`` (friction;
    impacts with ``e_N < 1``; penalty damping).  Value: ``|W_in - D_C - D_el| / E`` with ``E`` the sum of
    the magnitudes of the terms, at least ``F D``.

    Time stepping: the discrete work of the Moreau-Jean scheme (``h f_theta . u_theta``,
    ``h u_theta^T C u_theta``, ``P w . u_theta``, and the work of the position projection of contacts,
    ``delta^T K q_k+1 - delta^T K delta / 2`` for a projection ``delta``), which balances exactly for
    ``theta = 1/2`` (bound :data:`ENERGY_TOL`; for ``theta != 1/2`` the scheme dissipates numerically and
    the check does not gate).  Where only a subset of the DOFs is time-stepped (MS-HBM) the Fourier DOFs
    enter by the same sums, which adds an ``O((n_h omega h)^2)`` quadrature error (bound
    ``ENERGY_TOL + (n_h omega h)^2``).  MS-HBM (Section 3.2) condenses ``L`` under the coupling
    ``H_LN q_hat_N`` of its unknowns ``q_hat_N``, while the solution reports ``FFT(q_N)`` on ``N``; the two
    differ by the connectivity residual ``delta = q_hat_N - FFT(q_N)`` (the first rows of the residual,
    gated by the ``residual`` check).  ``L``'s equations hold exactly for ``q_hat_N``, so its Parseval sums
    evaluated with ``FFT(q_N)`` are short by the work of the coupling force of ``delta``,
    ``W_delta = T/2 sum_k Re(conj(U_L,k)^T H_LN,k Delta_k)`` (``U_L,k = i k omega X_L,k``; ``Delta_k`` the
    complex harmonic of ``delta``), which the balance subtracts
    (``info["energy"]["connectivity_residual_work"]``).  Likewise the periodicity residual
    ``q_N(T) - q_N(0)``: the grid sum ``h sum_k v_L,k^T C_LN v_N,k`` (``v_N = (q_N,k+1 - q_N,k) / h``),
    summed by parts, is the periodic value that ``L``'s Parseval sums see plus the boundary term
    ``(q_N(T) - q_N(0))^T C_NL v_L,N-1``, removed too (``periodicity_residual_work``).  Both are first
    order in the residual, whose size the ``residual`` check gates; with them the balance holds to first
    order at any unknowns.  Not evaluated (does not gate) when the integrated DOFs and their neighbours
    have more than :data:`MAX_GRID_VALUES` values on the grid.

    Fourier series of every DOF (HBM, DLFT): exact quadrature (Parseval for the forcing and dampers, the
    AFT samples for the elements), bound :data:`ENERGY_TOL`.
``connectivity_work`` (gating, MS-HBM of Section 3.2)
    ``|W_delta| / E`` (above): the energy error of the linear subsystem's answer caused by the accepted
    connectivity residual (``L`` responds to ``q_hat_N``, not to the reported ``FFT(q_N)``).  Bound
    :data:`CONNECTIVITY_WORK_BOUND`, the accuracy at which the truncation estimates warn: the step-accuracy
    acceptance of the ``residual`` check bounds ``delta`` by one step's travel of an impact amplified over
    the period, which through a stiff coupling can still be a force error of several per cent of the
    forcing on ``L``.  Evaluated where the problem declares ``certify_connectivity_work``; problems given by
    Fourier series of every DOF report it as 0.
``friction_dissipation`` / ``impact_dissipation`` (gating)
    Friction never delivers energy: ``W_friction <= bound``; impacts with ``e_N = 1`` conserve energy,
    ``e_N < 1`` (and penalty damping) only dissipate: ``W_contact <= bound`` (and ``|W_contact| <= bound``
    for elastic impacts).  Bound ``ENERGY_TOL E``, plus for friction and for HBM the work of one step's
    (one sample's) worth of element force, ``h max|lambda| max|u|`` (Moreau-Jean's friction law acts on
    the end-of-step velocity, and the AFT quadrature of a nonsmooth force is exact only to that).
    Time-stepped contacts get no such allowance: the impact law makes the impulse's work vanish for
    ``e_N = 1`` exactly.
``spring_work`` (polynomial springs)
    A conservative spring does no work over a period: ``|W_springs| / E``.  Its work is part of the balance
    (an element's ``P w . u_theta`` in the scheme's discrete work, the AFT quadrature for HBM and DLFT).
    Fourier series of every DOF: gating with bound :data:`ENERGY_TOL` where the quadrature on the ``N``
    samples is exact (``N > (p + 1) n_h`` for the highest power ``p``: ``lambda(s(t)) gamma(t)`` is a
    trigonometric polynomial of that degree), else reported.  Time stepping: reported, not gating -- the
    force evaluated at ``q + h/2 u`` does the work ``-Delta V`` only to ``O((omega h)^2)``, and the balance
    that gates (``energy_balance``) holds for the scheme's discrete work exactly.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import fourier
from ..methods.common import complement
from .kernels import LAM_ABS, WORK, WORK_ABS, harmonic_power
from .record import Check

__all__ = ["ENERGY_TOL", "CONNECTIVITY_WORK_BOUND", "MAX_GRID_VALUES", "energy_checks", "connectivity_work"]

ENERGY_TOL = 1e-6
#: gating bound of ``connectivity_work``
CONNECTIVITY_WORK_BOUND = 1e-2
#: largest ``N * len(dofs)`` for which the energy balance is evaluated on the grid
MAX_GRID_VALUES = 20_000_000


def energy_checks(problem, sol, system, omega, h, N, stepper, els, ue_max, cert, terms, R=None):
    """Append the energy checks (module docstring) to ``cert`` and their terms to ``cert.info["energy"]``.

    ``h = T / N`` (s); ``stepper`` the problem's Moreau-Jean stepper (``None``: none); ``ue_max`` the largest
    velocity of the element DOFs on the grid (m/s); ``terms`` the per-element table of
    :func:`mshbm.certificate.kernels.element_terms`; ``R`` the residual at the solution (for
    ``connectivity_work``).  ``cert.info`` already holds ``force_scale`` and ``displacement_scale``."""
    is_hbm = problem.fourier_all_dofs
    if is_hbm:
        W_in, E_in, D_C, Wj, Ej, bound_rel, gate, note, step_work = _fourier_work(sol, system, omega, h, ue_max,
                                                                                  terms)
        W_delta = W_per = 0.0  # no residual work (still reported, as zero)
    else:
        parts = _grid_work(problem, sol, system, omega, h, N, stepper, els, ue_max, cert, R)
        if parts is None:
            return
        W_in, E_in, D_C, Wj, Ej, bound_rel, gate, note, step_work, W_delta, W_per = parts
    # energy scale: the magnitudes of the terms, at least F D (the work of the force scale along the
    # displacement scale; without it a balance of terms that all vanish would compare rounding to rounding)
    E = max(abs(E_in) + abs(D_C) + float(np.sum(Ej)), cert.info["force_scale"] * cert.info["displacement_scale"])
    imbalance = W_in - D_C + float(np.sum(Wj)) - (W_delta or 0.0) + W_per
    val = abs(imbalance) / E if E > 0 else 0.0
    cert.info["energy"] = {"input_work": W_in, "damper_dissipation": D_C,
                           "element_dissipation": [-float(w) for w in Wj[:len(els)]], "imbalance": imbalance}
    if W_delta is not None:
        cert.info["energy"]["connectivity_residual_work"] = W_delta
        cert.info["energy"]["periodicity_residual_work"] = W_per
    if len(Wj) > len(els):
        cert.info["energy"]["projection_dissipation"] = -float(Wj[len(els)])
        cert.info["energy"]["stored_energy_change"] = -float(Wj[len(els) + 1])
    cert.checks.append(Check("energy_balance", val, bound_rel, bool(val <= bound_rel) or not gate, gate, note))
    if W_delta is not None:
        cw = abs(W_delta) / E if E > 0 else 0.0
        cert.checks.append(Check("connectivity_work", cw, CONNECTIVITY_WORK_BOUND,
                                 bool(cw <= CONNECTIVITY_WORK_BOUND) or not gate, gate,
                                 "work of the connectivity residual q_hat_N - FFT(q_N) on the linear subsystem / E"))
    bound = ENERGY_TOL * E + step_work
    fr = [j for j, e in enumerate(els) if e.bounded]
    if fr:
        w = max(float(Wj[j]) for j in fr)
        cert.checks.append(Check("friction_dissipation", w, bound, bool(w <= bound),
                                 note="work of the friction forces over a period (must not be positive)"))
    sm = [j for j, e in enumerate(els) if e.smooth]
    if sm:
        w = abs(float(sum(Wj[j] for j in sm)))
        val = w / E if E > 0 else 0.0
        if is_hbm:
            p = max(max(els[j].powers) for j in sm)
            gate_s = N > (p + 1) * int(sol.harmonics)
            note = ("|work of the polynomial springs over a period| / E, AFT quadrature on "
                    f"{N} samples (exact for N > (p + 1) n_h = {(p + 1) * int(sol.harmonics)})")
        else:
            gate_s = False
            note = ("|work of the polynomial springs over a period| / E, the scheme's discrete work (force at "
                    "q + h/2 u: zero to O((omega h)^2); reported, not gating)")
        cert.checks.append(Check("spring_work", val, ENERGY_TOL, bool(val <= ENERGY_TOL) or not gate_s, gate_s, note))
    ct = [j for j, e in enumerate(els) if e.unilateral]
    if ct:
        if not is_hbm and problem.integrator is not None and problem.integrator.stepper is not None:
            # Moreau-Jean: gamma_N+ = -e gamma_N- makes P gamma_N,theta vanish (e = 1) exactly
            bound = ENERGY_TOL * E
        worst, ok = -np.inf, True
        for j in ct:
            e = els[j]
            elastic = e.restitution == 1.0 and (not is_hbm or e.penalty_damping == 0.0)
            w = abs(Wj[j]) if elastic else float(Wj[j])
            if w > worst:
                worst = w
            ok = ok and w <= bound
        cert.checks.append(Check("impact_dissipation", worst, bound, bool(ok),
                                 note="work of the contact forces (0 for elastic impacts, <= 0 otherwise)"))


def _fourier_work(sol, system, omega, h, ue_max, terms):
    """Terms of the balance of a solution given by Fourier series of every DOF: Parseval's sums and the AFT
    quadrature of the element work; returns ``(W_in, E_in, D_C, Wj, Ej, bound_rel, gate, note, step_work)``."""
    T = 2.0 * np.pi / omega
    C = system.C
    qh = np.asarray(sol.q_hat)
    n_h = (qh.shape[0] - 1) // 2
    fh = system.forcing_hat(n_h, omega)
    if sp.issparse(C):
        kw = np.arange(1, n_h + 1)[:, None] * omega
        a, b = qh[1::2], qh[2::2]
        pw = kw * (fh[1::2] * b - fh[2::2] * a)  # (n_h, n): power of the forcing per harmonic and DOF
        W_in = float(0.5 * T * pw.sum())
        E_in = float(0.5 * T * np.abs(pw).sum())
        kab = np.concatenate([kw * a, kw * b])  # (2 n_h, n): velocity coefficients (sin, cos parts)
        D_C = float(0.5 * T * (kab * (C @ kab.T).T).sum())
    else:  # the same sums in one compiled pass
        pwr = np.empty(3)
        harmonic_power(np.ascontiguousarray(qh, dtype=float), fh, np.ascontiguousarray(C, dtype=float), omega,
                       pwr)
        W_in, E_in, D_C = (float(0.5 * T * v) for v in pwr)
    # AFT quadrature of the element work: h sum_k sign lambda u_j, u_j = sign w^T u the element's
    # velocity along +-e_dof (mshbm.certificate.kernels.element_terms)
    Wj = h * terms[:, WORK]
    Ej = h * terms[:, WORK_ABS]
    bound_rel, gate, note = ENERGY_TOL, True, "HBM: Parseval and AFT quadrature"
    step_work = h * float(terms[:, LAM_ABS].max(initial=0.0)) * ue_max
    return W_in, E_in, D_C, Wj, Ej, bound_rel, gate, note, step_work


def _grid_work(problem, sol, system, omega, h, N, stepper, els, ue_max, cert, R):
    """Terms of the balance of a time-stepped solution: the scheme's discrete work on the grid, Parseval's
    sums for the Fourier DOFs not coupled to the time-stepped ones; returns ``(W_in, E_in, D_C, Wj, Ej,
    bound_rel, gate, note, step_work, W_delta, W_per)``, or ``None`` (and a non-gating check) when the
    grid is too large."""
    n = system.n
    T = 2.0 * np.pi / omega
    C = system.C
    # integrated DOFs (and the Fourier DOFs coupled to them by C or K) by the scheme's discrete work on
    # the grid; the block of the other Fourier DOFs by Parseval (exact, and cheap for large L)
    Cr, Kr = sp.csr_matrix(C), sp.csr_matrix(system.K)
    td = np.asarray(sol.time_dofs, dtype=np.int64)
    Ld = complement(n, td)
    cl = np.setdiff1d(Cr[td].nonzero()[1], td) if td.size else np.zeros(0, dtype=np.int64)
    kl = np.setdiff1d(Kr[td].nonzero()[1], td) if td.size else np.zeros(0, dtype=np.int64)
    dofs = np.union1d(np.union1d(td, cl), kl).astype(np.int64)
    if (N + 1) * dofs.size > MAX_GRID_VALUES:
        cert.checks.append(Check("energy_balance", None, None, True, False,
                                 f"not evaluated: {dofs.size} DOFs x {N + 1} time points"))
        return None
    pos = {int(d): i for i, d in enumerate(dofs)}
    ix = lambda ds: np.array([pos[int(d)] for d in ds], dtype=np.int64)
    q = sol.displacement(dofs)
    dq = np.diff(q, axis=0)
    # u_theta of the scheme: the mean of the step's end velocities for integrated DOFs, dq / h for the
    # Fourier DOFs; delta = dq - h u_theta is the position projection of contacts (rounding elsewhere)
    v = dq / h
    itd, icl = ix(td), ix(cl)
    v[:, itd] = 0.5 * (sol.u_time[:-1] + sol.u_time[1:])
    delta = dq - h * v
    f = system.forcing(sol.t, omega, td)
    fm = 0.5 * (f[:-1] + f[1:])
    W_in = h * float(np.sum(fm * v[:, itd]))
    E_in = h * float(np.sum(np.abs(fm * v[:, itd])))
    vt, vc = v[:, itd], v[:, icl]
    D_C = h * float(np.sum(vt * (Cr[td][:, td] @ vt.T).T))
    W_per = 0.0
    if cl.size:
        D_C += 2.0 * h * float(np.sum(vt * (Cr[td][:, cl] @ vc.T).T))
        # half of that cross sum is L's side of the coupling, which L's Parseval sums see through the
        # periodic q_hat_N; summed by parts on the grid it equals the periodic value plus the boundary term
        # (q_N(T) - q_N(0))^T C_NL v_L,N-1 of the periodicity residual, removed here
        W_per = float((q[-1, itd] - q[0, itd]) @ (Cr[td][:, cl] @ vc[-1]))
    if Ld.size:
        # the coefficients of the L DOFs as full-length rows, zero on td: no submatrix of size n_L
        qh = np.asarray(sol.q_hat)
        n_h = (qh.shape[0] - 1) // 2
        fh = system.forcing_hat(n_h, omega)
        k = np.arange(1, n_h + 1)[:, None]
        onL = np.zeros(n)
        onL[Ld] = 1.0
        a, b = qh[1::2] * onL, qh[2::2] * onL
        pw = 0.5 * T * k * omega * (fh[1::2] * b - fh[2::2] * a)
        W_in += float(np.sum(pw))
        E_in += float(np.sum(np.abs(pw)))
        ka, kb = k * omega * a, k * omega * b  # C_LL's quadratic form = C's on rows zero off L
        D_C += float(0.5 * T * (np.sum(ka * (Cr @ ka.T).T) + np.sum(kb * (Cr @ kb.T).T)))
    P = np.asarray(sol.impulses)
    sign = np.array([e.sign for e in els])
    vj = [v[:, pos[int(e.dof)]] if e.relative_to is None else e.sign * e.local(v, pos) for e in els]
    Wj = np.array([float(np.sum(sign[j] * P[:, j] * vj[j])) for j in range(len(els))])
    Ej = np.array([float(np.sum(np.abs(P[:, j] * vj[j]))) for j in range(len(els))])
    # work of the projection: it moves q by delta after the step, changing the potential energy
    W_proj = 0.0
    dl = delta[:, itd]
    steps = np.flatnonzero(np.max(np.abs(dl), axis=1, initial=0.0) > 1e-13 * cert.info["displacement_scale"])
    if steps.size:
        dl = dl[steps]
        Kq = (Kr[td][:, dofs] @ q[steps + 1].T).T
        W_proj = float(np.sum(dl * Kq) - 0.5 * np.sum(dl * (Kr[td][:, td] @ dl.T).T))
    Wj = np.append(Wj, W_proj)
    Ej = np.append(Ej, abs(W_proj))
    # change of the stored energy from t = 0 to T of these DOFs (kinetic + potential; zero for an
    # exactly periodic orbit, one step's worth for an orbit periodic to one step's accuracy): the
    # discrete work identity of the scheme holds for any trajectory, periodic or not
    uq = sol.velocity(dofs)
    Md = sp.csr_matrix(system.M)[dofs][:, dofs]
    Kd = Kr[dofs][:, dofs]
    qa, qb, ua, ub = q[0], q[-1], uq[0], uq[-1]
    dE = 0.5 * float(ub @ (Md @ ub) - ua @ (Md @ ua) + qb @ (Kd @ qb) - qa @ (Kd @ qa))
    Wj = np.append(Wj, -dE)
    Ej = np.append(Ej, abs(dE))
    event = stepper is None  # the exact event-driven flow (shooting with integrator="event")
    theta = 0.5 if event else stepper.theta
    if event:
        bound_rel, note = ENERGY_TOL, ("event-driven flow sampled on the output grid: the sums are a "
                                       "trapezoidal quadrature, O(h) at events (reported, not gating)")
    elif not problem.time_integrated_subset:
        bound_rel, note = ENERGY_TOL, "Moreau-Jean discrete work (exact balance for theta = 1/2)"
    else:
        bound_rel = ENERGY_TOL + (int(sol.harmonics) * omega * h) ** 2
        note = "Moreau-Jean discrete work; Fourier DOFs by the same sums"
    gate = abs(theta - 0.5) < 1e-12 and not event
    if not gate and not event:
        note += f"; theta = {theta:g} dissipates numerically: not gating"
    umax = ue_max
    step_work = float(np.max(np.abs(P), initial=0.0)) * umax if P.size else 0.0
    # the work of MS-HBM's connectivity residual on L (its size is gated by the residual check)
    W_delta = connectivity_work(problem, sol, system, omega, R, Ld)
    return W_in, E_in, D_C, Wj, Ej, bound_rel, gate, note, step_work, W_delta, W_per


def connectivity_work(problem, sol, system, omega, R, Ld):
    """Work ``W_delta`` over one period of the connectivity residual of MS-HBM (Section 3.2) on the linear
    subsystem (module docstring), J; ``None`` unless the problem declares ``certify_connectivity_work``.

    ``R[:a]`` (``a = (2 n_h + 1) n_N``, harmonic-major) is ``delta = q_hat_N - FFT(q_N)``: the ``L`` harmonics
    ``X_L`` were condensed under the coupling ``H_LN q_hat_N``, while the solution reports ``FFT(q_N)`` on
    ``N``, so the Parseval sums of ``L`` miss ``W_delta = T/2 sum_k Re(conj(U_L,k)^T H_LN,k Delta_k)``
    (``U_L,k = i k omega X_L,k``, ``Delta_k`` the complex form of ``delta``)."""
    if not problem.certify_connectivity_work or R is None or not Ld.size:
        return None
    td = np.asarray(sol.time_dofs, dtype=np.int64)
    qh = np.asarray(sol.q_hat)
    nc = qh.shape[0]
    if R.shape[0] < nc * td.size:
        return None
    Dl = fourier.to_complex(np.asarray(R[:nc * td.size], dtype=float).reshape(nc, td.size))
    XL = fourier.to_complex(qh[:, Ld])
    cols = [sp.csr_matrix(A)[Ld][:, td] for A in (system.M, system.C, system.K)]
    W = 0.0
    for k in range(1, Dl.shape[0]):
        if not np.any(Dl[k]):
            continue
        w = k * omega
        v = cols[2] @ Dl[k] - w * w * (cols[0] @ Dl[k]) + 1j * w * (cols[1] @ Dl[k])  # H_LN,k Delta_k
        W += 0.5 * (2.0 * np.pi / omega) * float(np.real(np.vdot(1j * w * XL[k], v)))
    return W
