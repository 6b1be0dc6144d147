"""Certificate of a periodic solution: checks made after Newton, independently of its bookkeeping.

A result of :func:`mshbm.solve` reports ``success=True`` only when Newton converged *and*
every gating check below passed.  Each check has a ``name``, a ``value``, a ``bound`` (same
units), ``passed`` and ``gating``; the list is ``PeriodicSolution.certificate`` and the
``"certificate"`` entry of ``summary()`` / the CLI JSON.

Notation as in the paper: ``M, C, K``, ``q, u``, ``omega``, ``T = 2 pi / omega``, ``N`` time
points per period (``h = T / N``), ``n_h`` harmonics, element force ``lambda`` along ``w``.
Scales (:mod:`mshbm.scaling`): ``F`` the force scale of the problem, ``D = max(D_0,
max |q|)`` the displacement size of the solution, ``V = max(omega D, max |u|)``.

Checks
------
``residual`` (gating)
    The method's residual re-evaluated at the returned unknowns, row-scaled by the
    problem's ``residual_scale`` (forces by ``F``, displacements by ``D``); bound: the
    Newton tolerance ``tol``.
``periodicity`` (gating)
    ``max(|q(T) - q(0)| / D, |u(T) - u(0)| / V)`` of the time series of the DOFs that are
    integrated in time (DOFs given by Fourier series are periodic by construction).
    Bound: one step's accuracy ``(omega h)^2`` (the relative local error of a step of the
    second-order Moreau-Jean scheme is of this order), at least ``tol``.
``step_accuracy_size`` (gating in :func:`mshbm.solve`; reported on branch points; only for an orbit
    accepted as periodic to one time step's accuracy)
    The displacement change of one step at an impact, ``h J`` (``J`` the largest velocity jump,
    :func:`mshbm.solvers.starts.residual_accept`), relative to the displacement scale ``D`` of the solution.
    Bound ``2e-3``.  A stalled Newton accepted at one step's accuracy is no answer when one step is not small
    against the orbit.  Measured (stress suite, MS-HBM n_h = 5, N = 2048): random21 0.0033 (23 % off the
    8192-step reference), random8 0.048 (99 % off), random19 0.0083 (agreed with its reference; now rejected
    too); impact5 at omega = 1 rad/s 2.3e-4, the 10^4-DOF FE plate (MS-HBM, 4096 steps) 8.3e-4, both kept;
    the Budd-Dux oscillator (1024 steps) 3.3e-3, its answer 0.26 % off the closed form, rejected (the
    event-driven fallback then solves it exactly): the measure does not separate right from wrong sharply.
    Not the amplified bound ``g h J`` of the acceptance: its gain ``g = 1 + ||dR/dx||`` is 7.5e3 on the FE
    plate (``g h J = 6 D`` there, although its answer agrees with HBM to 1.4 %).  Along the Moreau-Jean impact5
    branches of Fig. 9 (omega 0.5 to 0.75) the value is 9.4e-4 to 1.3e-3 (MS-HBM, 4096 steps) and 1.0e-3 to
    2.5e-3 (shooting, 2048 steps: 13 of 24 points above the bound; gated, that sweep stalls at omega = 0.579),
    so on branch points (:func:`mshbm.sweep`) the check is reported, not gating.  Rejected in
    :func:`mshbm.solve`, a system with contacts goes on to the exact event-driven integrator
    (``info["event_fallback"]``).
``friction_cone`` (gating, friction elements)
    ``max_j max_t |lambda_j| / (mu F_N)_j``; bound ``1 + 1e-9`` (the projected Gauss-Seidel
    solver resolves the cone to ~1e-14; the arctan law of HBM stays strictly inside).
``non_penetration`` (gating, contacts)
    Largest penetration ``max(0, -min_t g_N)`` (m).  Bound, time stepping: ``1e-9 D``
    with position projection (the projection puts a penetrating contact back on
    ``g_N = 0`` to rounding), otherwise one step's travel ``h max |u_dof|`` (the
    velocity-level law can let a contact run into the obstacle for at most one step);
    HBM: the penetration the penalty law itself needs to carry the contact force,
    ``(max lambda_N + d_c max |u_dof|) / k_c``, plus ``1e-9 D``.
``contact_compression`` (gating, contacts, time stepping)
    ``-min lambda_N / F`` (contact forces push, never pull); bound ``1e-9``.
``energy_balance`` (gating where it applies)
    Over one period: input work of the forcing ``W_in = int f . u dt`` equals the
    dissipation of the dampers ``D_C = int u^T C u dt`` plus that of the elements
    ``D_el = -int w lambda u_dof dt`` (friction; impacts with ``e_N < 1``; penalty damping).
    Value: ``|W_in - D_C - D_el| / E`` with ``E`` the sum of the magnitudes of the terms,
    at least ``F D``.
    Time stepping: the discrete work of the Moreau-Jean scheme (``h f_theta . u_theta``,
    ``h u_theta^T C u_theta``, ``P w . u_theta``, and the work of the position projection of
    contacts, ``delta^T K q_k+1 - delta^T K delta / 2`` for a projection ``delta``), which
    balances exactly for ``theta = 1/2`` (bound ``1e-6``; for ``theta != 1/2`` the scheme dissipates numerically and the check does not
    gate); for MS-HBM the Fourier DOFs enter by the same sums, which adds an ``O((n_h
    omega h)^2)`` quadrature error (bound ``1e-6 + (n_h omega h)^2``).  MS-HBM (Section 3.2) condenses
    ``L`` under the coupling ``H_LN q_hat_N`` of its unknowns ``q_hat_N``, while the solution reports
    ``FFT(q_N)`` on ``N``; the two differ by the connectivity residual ``delta = q_hat_N - FFT(q_N)``
    (the first rows of the residual, gated by the ``residual`` check).  ``L``'s equations hold exactly
    for ``q_hat_N``, so its Parseval sums evaluated with ``FFT(q_N)`` are short by the work of the
    coupling force of ``delta``, ``W_delta = T/2 sum_k Re(conj(U_L,k)^T H_LN,k Delta_k)``
    (``U_L,k = i k omega X_L,k``; ``Delta_k`` the complex harmonic of ``delta``), which the balance
    subtracts (``info["energy"]["connectivity_residual_work"]``).  Likewise the periodicity residual
    ``q_N(T) - q_N(0)``: the grid sum ``h sum_k v_L,k^T C_LN v_N,k`` (``v_N = (q_N,k+1 - q_N,k) / h``),
    summed by parts, is the periodic value that ``L``'s Parseval sums see plus the boundary term
    ``(q_N(T) - q_N(0))^T C_NL v_L,N-1``, removed too (``periodicity_residual_work``).  Both are first
    order in the residual, whose size the ``residual`` check gates; with them the balance holds to first
    order at any unknowns (a perturbation of ``q_hat_N`` changes it by 0.1 % of ``W_delta``).
    ``W_delta`` is not small: an impacting orbit accepted as periodic to one step's accuracy stalls
    Newton at ``|delta| ~ 2e-8 m`` (relative 7e-6), and through a stiff coupling spring (``k = 3.5e4 N/m``
    on the FE plate with bodies) that is ``W_delta ~ 5e-4 E`` (1024 to 16384 steps, not falling with
    ``h``: a stall level); the rest of the imbalance is then ``2e-6 E`` at ``(n_h omega h)^2 = 6e-5``
    (4096 steps) and ``3e-7 E`` at ``4.7e-6`` (16384 steps), measured on the 10^4-DOF plate.
``connectivity_work`` (gating, MS-HBM of Section 3.2)
    ``|W_delta| / E`` (above): the energy error of the linear subsystem's answer caused by the accepted
    connectivity residual (``L`` responds to ``q_hat_N``, not to the reported ``FFT(q_N)``).  Bound ``1e-2``,
    the accuracy at which the truncation estimates warn: the step-accuracy acceptance of the ``residual``
    check bounds ``delta`` by one step's travel of an impact amplified over the period, which through a
    stiff coupling can still be a force error of 10 % of the forcing on ``L`` (measured: 8192 steps on the
    10^4-DOF plate, ``W_delta = 0.36 E``, the plate's input work 70 % off a 16384-step solution whose
    ``W_delta = 5e-4 E``).  HBM: exact
    quadrature (Parseval for the forcing and dampers, the AFT samples for the elements),
    bound ``1e-6``.  Not evaluated (does not gate) when the integrated DOFs and their
    neighbours have more than ``2e7`` values on the grid.
``friction_dissipation`` / ``impact_dissipation`` (gating)
    Friction never delivers energy: ``W_friction <= bound``; impacts with ``e_N = 1``
    conserve energy, ``e_N < 1`` (and penalty damping) only dissipate:
    ``W_contact <= bound`` (and ``|W_contact| <= bound`` for elastic impacts).  Bound
    ``1e-6 E``, plus for friction and for HBM the work of one step's (one sample's) worth
    of element force, ``h max|lambda| max|u|`` (Moreau-Jean's friction law acts on the
    end-of-step velocity, and the AFT quadrature of a nonsmooth force is exact only to
    that).  Time-stepped contacts get no such allowance: the impact law makes the
    impulse's work vanish for ``e_N = 1`` exactly.
``undamped_resonance`` (gating)
    When no element acts on the solution (no element, friction with ``mu F_N = 0``,
    contacts that never close), the response is that of the linear structure.  If a
    forced harmonic ``k omega`` lies within the discretisation error of an undamped
    natural frequency ``omega_r`` (``|(k omega / omega_r)^2 - 1| <= eps`` with
    ``eps = 10 (k omega h)^2`` for time stepping, ``1e-9`` for HBM), no resolved periodic
    solution exists (the discrete answer grows as ``1/eps``, e.g. as ``N^2``).  Value:
    the smallest relative detuning; bound: ``eps``; passes when the value exceeds it.
``time_discretisation`` (gating, time stepping)
    First-order estimate of the relative error that the Moreau-Jean scheme's frequency warping of
    the time-stepped DOFs ``T`` causes in the periodic response: on a harmonic ``X e^{i w t}``
    (``w = k omega``) the scheme (with ``theta``-weighted forcing) acts like the dynamic stiffness
    ``K + i w~ C - w~^2 M`` with ``i w~ = (z - 1) / (h (1 - theta + theta z))``, ``z = e^{i w h}``,
    instead of ``K + i w C - w^2 M``; the difference ``dH_k`` on the ``T x T`` block, applied to the
    solution's harmonics, displaces the linear response by ``delta_k = H(k omega)^-1 dH_k X_T,k``.
    Value: ``max_k max |delta_k| / D``; bound ``0.1``.  Gating only where the linear structure
    describes the solution: its own response to the forcing, ``max |H(k omega)^-1 f_k|``, is at most
    ``10 D`` (not at a resonance of the free structure that the elements suppress).  Tiny on lumped chains (``(omega h)^2``), it is
    large where a stiff, heavily damped DOF is time-stepped next to a soft structure (a finite-element
    node with Rayleigh damping, ``|K_dd / A| ~ 1e7``: the warped damping force ``beta K_dd`` is amplified
    by the condensed compliance); there the discrete periodic solution is far from the continuous one,
    and the remedy is more steps (the estimate falls like ``h^2``).  The element laws are left out
    (first-order, linear part only); the bound catches gross under-resolution, not the percent-level
    step error of a deliberately coarse grid.
``truncation_solution`` / ``truncation_force`` (HBM and MS-HBM; reported, not gating)
    Estimates of the harmonic truncation error: the size of the highest retained harmonic
    ``n_h`` of ``q_hat`` relative to the largest harmonic, and the displacement (relative
    to ``D``, RMS over harmonics) that the harmonics of the element forces ``lambda(t)``
    above ``n_h`` would cause at the element DOF through its diagonal dynamic stiffness
    ``|K_dd - (k omega)^2 M_dd + i k omega C_dd|``.  Bound ``1e-2``.  They do not
    gate: ``n_h`` is the user's choice of discretisation and the answer is the exact
    solution of the discretised equations; a value above the bound is named in the
    message as a warning.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numba import njit

from . import fourier
from .solvers.newton import scaled_norm
from .scaling import diagonals, displacement_floor, force_scale

__all__ = ["Check", "Certificate", "certify", "apply_certificate"]

#: largest ``N * len(dofs)`` for which the energy balance is evaluated on the grid
MAX_GRID_VALUES = 20_000_000
#: largest system for which undamped natural frequencies are computed (dense eigenproblem)
MAX_EIG_DOFS = 2000
TRUNCATION_BOUND = 1e-2
ENERGY_TOL = 1e-6
#: gating bound of ``connectivity_work`` (see the module docstring)
CONNECTIVITY_WORK_BOUND = 1e-2


@dataclass
class Check:
    """One check: ``passed`` is ``value <= bound`` (``undamped_resonance``: ``value > bound``)."""

    name: str
    value: float | None
    bound: float | None
    passed: bool
    gating: bool = True
    note: str = ""

    def as_dict(self):
        d = asdict(self)
        for k in ("value", "bound"):
            v = d[k]
            d[k] = None if v is None or not np.isfinite(v) else float(v)
        d["passed"], d["gating"] = bool(d["passed"]), bool(d["gating"])
        return d


@dataclass
class Certificate:
    """The checks of one solution (see the module docstring); ``passed``: every gating check passed."""

    checks: list = field(default_factory=list)
    info: dict = field(default_factory=dict)

    @property
    def passed(self):
        return all(c.passed for c in self.checks if c.gating)

    @property
    def failed(self):
        """Names of the gating checks that failed."""
        return [c.name for c in self.checks if c.gating and not c.passed]

    @property
    def warnings(self):
        """Names of the non-gating checks above their bound."""
        return [c.name for c in self.checks if not c.gating and not c.passed and c.value is not None]

    def __getitem__(self, name):
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(name)

    def __contains__(self, name):
        return any(c.name == name for c in self.checks)

    def as_list(self):
        """JSON-ready list of dicts ``{name, value, bound, passed, gating, note}``."""
        return [c.as_dict() for c in self.checks]

    def describe_warnings(self):
        """The non-gating checks above their bound (the harmonic truncation estimates), for the message of a
        certified solution; ``""`` when there are none."""
        above = [c for c in self.checks if not c.gating and not c.passed and c.value is not None and c.bound is not None]
        parts = [f"{c.name} {c.value:.3g} > {c.bound:.3g}" + (f" ({c.note})" if c.note else "")
                 for c in above if c.name != "step_accuracy_size"]
        out = []
        if parts:
            out.append("the harmonic truncation error may exceed its bound: " + ", ".join(parts)
                       + "; more harmonics (option harmonics) reduce it")
        out += [f"one step's accuracy is {c.value:.3g} of the orbit's size (> {c.bound:.3g}); more steps (option "
                "steps) reduce it" for c in above if c.name == "step_accuracy_size"]
        return "; ".join(out)

    def describe_failures(self):
        parts = []
        for c in self.checks:
            if c.gating and not c.passed:
                v = "n/a" if c.value is None else f"{c.value:.3g}"
                b = "n/a" if c.bound is None else f"{c.bound:.3g}"
                rel = "<=" if c.name == "undamped_resonance" else ">"
                parts.append(f"{c.name} ({v} {rel} bound {b}{': ' + c.note if c.note else ''})")
        return ", ".join(parts)


# ----------------------------------------------------------------------------------------------
#: note of the residual and periodicity checks of an orbit accepted as periodic to one step's accuracy
STEP_ACCURACY_NOTE = ("periodic to one time step's accuracy: the Moreau-Jean map moves impacts by whole steps and "
                      "has no exact periodic point here; bound per entry: the jump of the residual when an impact "
                      "moves by one step (mshbm.solvers.starts.residual_accept)")


#: gating bound of ``step_accuracy_size`` (see the module docstring)
STEP_ACCURACY_SIZE_BOUND = 2e-3
STEP_ACCURACY_SIZE_NOTE = ("the displacement change of one step at an impact, h J, relative to the orbit's "
                           "displacement scale D: a stalled Newton accepted as periodic to one step's accuracy "
                           "is no answer when one step is not small against the orbit")


#: columns of :func:`_element_terms`' output
_S_MIN, _WU_MAX, _LAM_MAX, _LAM_MIN, _LAM_ABS, _WORK, _WORK_ABS, _ACTS = range(8)


@njit(cache=True)
def _element_terms(q, u, lam, I, J, sign, N, out):  # pragma: no cover - compiled
    """Per element ``j`` on the grid (``q, u``: (N+1, n_e) of the element DOFs' columns ``I[j]``, ``J[j]``
    (``-1``: single-DOF element); ``lam``: (N+1, m)), in ``out[j]`` (NaN-propagating like NumPy's
    ``min``/``max``): ``min w^T q``, ``max |w^T u|``, ``max lambda``, ``min lambda``, ``max |lambda|``
    (all N+1 points), the work ``sum_k<N sign lambda u_j`` and ``sum_k<N |lambda u_j|`` with ``u_j = sign
    w^T u`` (the velocity along ``+e_dof``), and 1 if some ``lambda != 0``."""
    rows = q.shape[0]
    nan = np.nan
    for j in range(lam.shape[1]):
        a, c, w = I[j], J[j], sign[j]
        smin, umax, lmax, lmin, labs, W, Ea, acts = np.inf, 0.0, -np.inf, np.inf, 0.0, 0.0, 0.0, 0.0
        bad_s, bad_u, bad_l = False, False, False
        for t in range(rows):
            if c >= 0:
                s = w * (q[t, a] - q[t, c])
                wu = w * (u[t, a] - u[t, c])
            else:
                s = w * q[t, a]
                wu = w * u[t, a]
            lt = lam[t, j]
            if s != s:
                bad_s = True
            if wu != wu:
                bad_u = True
            if lt != lt:
                bad_l = True
            smin = min(smin, s)
            umax = max(umax, abs(wu))
            lmax = max(lmax, lt)
            lmin = min(lmin, lt)
            labs = max(labs, abs(lt))
            if abs(lt) > 0.0:
                acts = 1.0
            if t < N:
                uj = w * wu
                W += w * lt * uj
                Ea += abs(lt * uj)
        out[j, 0] = nan if bad_s else smin
        out[j, 1] = nan if bad_u else umax
        out[j, 2] = nan if bad_l else lmax
        out[j, 3] = nan if bad_l else lmin
        out[j, 4] = nan if bad_l else labs
        out[j, 5] = W
        out[j, 6] = Ea
        out[j, 7] = acts


@njit(cache=True)
def _element_terms_fourier(coef, V, omega, lam, I, J, sign, N, out):  # pragma: no cover - compiled
    """:func:`_element_terms` for a solution given by Fourier coefficients alone (HBM, DLFT): the grid
    values ``q = V coef``, ``u = V (Om coef)`` of the element DOFs' columns (``coef`` (2 n_h + 1, n_e),
    ``V`` the inverse DFT (N, 2 n_h + 1)) are summed here instead of stored (``t_N = T`` repeats ``t_0``).
    Returns ``max |u|`` over the element DOFs and the grid."""
    nc, ne = coef.shape
    m = lam.shape[1]
    dcoef = np.zeros((nc, ne))  # Om coef: the velocity's coefficients
    for k in range(1, (nc - 1) // 2 + 1):
        kw = k * omega
        for i in range(ne):
            dcoef[2 * k - 1, i] = kw * coef[2 * k, i]
            dcoef[2 * k, i] = -kw * coef[2 * k - 1, i]
    q = np.empty(ne)
    u = np.empty(ne)
    acc = np.zeros((m, 8))
    for j in range(m):
        acc[j, 0], acc[j, 2], acc[j, 3] = np.inf, -np.inf, np.inf
    bad = np.zeros((m, 3), dtype=np.bool_)
    uall = 0.0
    bad_all = False
    for t in range(N):
        for i in range(ne):
            qs, us = 0.0, 0.0
            for k in range(nc):
                qs += V[t, k] * coef[k, i]
                us += V[t, k] * dcoef[k, i]
            q[i], u[i] = qs, us
            if us != us:
                bad_all = True
            uall = max(uall, abs(us))
        for j in range(m):
            a, c, w = I[j], J[j], sign[j]
            if c >= 0:
                sv = w * (q[a] - q[c])
                wu = w * (u[a] - u[c])
            else:
                sv = w * q[a]
                wu = w * u[a]
            lt = lam[t, j]
            if sv != sv:
                bad[j, 0] = True
            if wu != wu:
                bad[j, 1] = True
            if lt != lt:
                bad[j, 2] = True
            acc[j, 0] = min(acc[j, 0], sv)
            acc[j, 1] = max(acc[j, 1], abs(wu))
            acc[j, 2] = max(acc[j, 2], lt)
            acc[j, 3] = min(acc[j, 3], lt)
            acc[j, 4] = max(acc[j, 4], abs(lt))
            if abs(lt) > 0.0:
                acc[j, 7] = 1.0
            uj = w * wu
            acc[j, 5] += w * lt * uj
            acc[j, 6] += abs(lt * uj)
    for j in range(m):
        lt = lam[N, j]  # lambda at t_N (its own row; equal to t_0 for a periodic series)
        if lt != lt:
            bad[j, 2] = True
        acc[j, 2] = max(acc[j, 2], lt)
        acc[j, 3] = min(acc[j, 3], lt)
        acc[j, 4] = max(acc[j, 4], abs(lt))
        if abs(lt) > 0.0:
            acc[j, 7] = 1.0
        for col in range(8):
            out[j, col] = acc[j, col]
        if bad[j, 0]:
            out[j, 0] = np.nan
        if bad[j, 1]:
            out[j, 1] = np.nan
        if bad[j, 2]:
            out[j, 2] = out[j, 3] = out[j, 4] = np.nan
    return np.nan if bad_all else uall


@njit(cache=True)
def _harmonic_power(qh, fh, C, omega, out):  # pragma: no cover - compiled
    """Parseval sums of a Fourier solution ``qh`` (2 n_h + 1, n) under forcing ``fh`` (same shape) with
    dense damping ``C`` (n, n), per unit ``T / 2``: ``out[0] = sum_k,i k omega (fc_ki xs_ki - fs_ki xc_ki)``
    (input work), ``out[1]`` the same sum of magnitudes, ``out[2] = sum_k (k omega)^2 (xc_k^T C xc_k +
    xs_k^T C xs_k)`` (damper dissipation)."""
    n = qh.shape[1]
    W, Ea, Dc = 0.0, 0.0, 0.0
    for k in range(1, (qh.shape[0] - 1) // 2 + 1):
        kw = k * omega
        a, b = qh[2 * k - 1], qh[2 * k]
        for i in range(n):
            p = kw * (fh[2 * k - 1, i] * b[i] - fh[2 * k, i] * a[i])
            W += p
            Ea += abs(p)
        for i in range(n):
            ca, cb = 0.0, 0.0
            for l in range(n):
                ca += C[i, l] * a[l]
                cb += C[i, l] * b[l]
            Dc += kw * kw * (a[i] * ca + b[i] * cb)
    out[0], out[1], out[2] = W, Ea, Dc


@njit(cache=True)
def _force_tail(Z, Kd, Md, Cd, d, omega, n_h, out):  # pragma: no cover - compiled
    """``out[j] = sqrt(sum_k>n_h (|Z_kj| / |K_dd - (k omega)^2 M_dd + i k omega C_dd|)^2)``, ``d = d[j]``:
    the displacement of the element-force harmonics ``Z`` (N/2+1, m) above ``n_h`` at the element DOF."""
    for j in range(Z.shape[1]):
        dj = d[j]
        acc = 0.0
        for k in range(n_h + 1, Z.shape[0]):
            w = k * omega
            Hd = math.hypot(Kd[dj] - w * w * Md[dj], w * Cd[dj])
            t = abs(Z[k, j]) / max(Hd, 1e-300)
            acc += t * t
        out[j] = math.sqrt(acc)


def _max_abs(a):
    """``max |a|`` (0 for an empty array)."""
    return float(np.abs(a).max(initial=0.0))


def _element_series(sol, dofs, N):
    """``q(t_k)`` and ``u(t_k)`` of ``dofs``, ``k = 0..N``, each (N+1, len(dofs)): as
    ``sol.displacement(dofs)``, ``sol.velocity(dofs)``; for a solution given by its Fourier series
    alone (HBM, DLFT) both from one product with the inverse DFT matrix."""
    if not dofs.size:
        return np.zeros((N + 1, 0)), np.zeros((N + 1, 0))
    qh = np.asarray(sol.q_hat)
    nc, m = qh.shape[0], dofs.size
    if np.size(sol.time_dofs) or not (nc <= 64 and N > 2 * (nc // 2)):
        return sol.displacement(dofs), sol.velocity(dofs)
    coef = np.empty((nc, 2 * m))
    coef[:, :m] = qh[:, dofs]
    coef[:, m:] = fourier.derivative(coef[:, :m], sol.omega)
    out = np.empty((N + 1, 2 * m))
    np.matmul(fourier.idft_matrix(N, nc // 2), coef, out=out[:N])
    out[N] = out[0]  # t_N = T: periodic
    return out[:, :m], out[:, m:]


def certify(problem, sol, tol, step_accuracy=None, step_size_gating=True):
    """Certificate of ``sol`` (a :class:`mshbm.result.PeriodicSolution` of ``problem``).

    Parameters
    ----------
    problem : ShootingProblem, HBMProblem, MixedProblem or IntermediateProblem
        The problem that produced ``sol`` (provides ``residual`` and ``residual_scale``).
    sol : PeriodicSolution
    tol : float
        Newton tolerance of the solve (bound of the ``residual`` check).
    step_accuracy : dict, optional
        Set when the start ladder (:func:`mshbm.solvers.starts.residual_accept`) accepted a stalled Newton on
        an impacting orbit of a time-stepping method as periodic to one time step's accuracy:
        ``{"bound": ndarray (n_x,), "step_change": float}``, per residual entry the change of the periodicity
        residual when an impact moves by one step (``g h J``, ``g h omega J``), and ``h J`` (m).  The ``residual`` and
        ``periodicity`` checks are then judged against that bound (value ``max_i |R_i| / bound_i``,
        bound 1) instead of ``tol`` and ``(omega h)^2``, and say so in their note; and the check
        ``step_accuracy_size`` is added (the one-step displacement bound relative to the orbit's size).
    step_size_gating : bool
        Whether ``step_accuracy_size`` gates (default, :func:`mshbm.solve`) or is only reported
        (:func:`mshbm.sweep`'s points: a branch is followed continuously from certified points, and on the
        Moreau-Jean impact5 branches of Fig. 9 the values are reported in the points' certificates).

    Returns
    -------
    Certificate
    """
    cert = Certificate()
    with np.errstate(all="ignore"):
        try:
            _certify(problem, sol, float(tol), cert, step_accuracy, bool(step_size_gating))
        except Exception as exc:  # noqa: BLE001 -- a certificate that cannot be computed does not pass
            cert.checks.append(Check("evaluation", None, None, False, True, f"{type(exc).__name__}: {exc}"))
    return cert


def _element_tables(system):
    """The element bookkeeping of :func:`_certify` (cached on the system while its element tuple is the same;
    shared: not to be modified): ``el_dofs`` (sorted DOFs carrying elements), ``col`` (DOF -> index in
    ``el_dofs``), ``I``, ``J`` (per element: index of its DOF and of its second DOF, -1 for the ground),
    ``sign`` (per element), ``fr`` and ``ct`` (``[(j, element)]`` of the bounded and the unilateral
    elements)."""
    def compute():
        els = tuple(system.elements)
        el_dofs = np.array(sorted({int(d) for e in els for d in e.dofs}), dtype=np.int64)
        col = {int(d): i for i, d in enumerate(el_dofs)}
        I = np.array([col[int(e.dof)] for e in els], dtype=np.int64)
        J = np.array([-1 if e.relative_to is None else col[int(e.relative_to)] for e in els], dtype=np.int64)
        sign = np.array([float(e.sign) for e in els])
        for a in (el_dofs, I, J, sign):
            a.flags.writeable = False
        fr = tuple((j, e) for j, e in enumerate(els) if e.bounded)
        ct = tuple((j, e) for j, e in enumerate(els) if e.unilateral)
        return el_dofs, col, I, J, sign, fr, ct

    return system.derived("certificate_elements", ("elements",), compute)


def el_dofs_each(system):
    """The DOF of each element, shape ``(m,)``, int64, read-only (cached on the system)."""
    def compute():
        a = np.array([e.dof for e in system.elements], dtype=np.int64)
        a.flags.writeable = False
        return a

    return system.derived("element_dof_each", ("elements",), compute)


def _certify(problem, sol, tol, cert, step_accuracy=None, step_size_gating=True):
    system, omega = problem.system, float(sol.omega)
    is_hbm = problem.method in ("hbm", "dlft")  # Fourier series of all DOFs, AFT samples
    is_dlft = problem.method == "dlft"
    stepper = None if problem.integrator is None else problem.integrator.stepper  # None: HBM, DLFT, event flow
    T = 2.0 * np.pi / omega
    t = np.asarray(sol.t)
    N = t.size - 1
    h = T / N
    F = force_scale(system, penalty=is_hbm and not is_dlft)
    D0 = displacement_floor(system, omega)
    els = list(system.elements)
    el_dofs, col, I, J, sign, fr, ct = _element_tables(system)

    # 1. residual, re-evaluated
    x = np.asarray(sol.x, dtype=float)
    R = problem.residual(x, jac=False)[0]
    step_bound = None if step_accuracy is None else np.asarray(step_accuracy["bound"], dtype=float)
    if step_bound is not None and step_bound.shape == R.shape and not is_hbm:
        r = float(np.max(np.abs(R) / step_bound))
        cert.checks.append(Check("residual", r, 1.0, bool(np.isfinite(r) and r <= 1.0), True,
                                 STEP_ACCURACY_NOTE))
    else:
        step_bound = None
        r = scaled_norm(R, problem.residual_scale(x))
        cert.checks.append(Check("residual", r, tol, bool(np.isfinite(r) and r <= tol)))

    # sizes of the solution (from the Fourier coefficients and the time series)
    qh = np.asarray(sol.q_hat)
    mags = np.hypot(qh[1::2], qh[2::2])  # (n_h, n): harmonic magnitudes (also the truncation check's)
    amp_h = np.abs(qh[0]) + mags.sum(axis=0) if qh.shape[0] > 1 else np.abs(qh[0])
    D = max(D0, float(amp_h.max(initial=0.0)), _max_abs(sol.q_time))
    V = max(omega * D, _max_abs(sol.u_time))
    cert.info.update(force_scale=F, displacement_scale=D, velocity_scale=V)

    # 2. periodicity of the time-stepped DOFs
    if sol.q_time.shape[1]:
        dq = float(np.max(np.abs(sol.q_time[-1] - sol.q_time[0]))) / D
        du = float(np.max(np.abs(sol.u_time[-1] - sol.u_time[0]))) / V
        val = max(dq, du)
        bound = max(tol, (omega * h) ** 2)
        if step_bound is not None:
            # one step's accuracy at an impact: the jumps of q and u when an impact moves by one step
            units = problem.residual_units()  # residual rows: 0 displacement, 1 velocity, 2 force
            bq = float(np.max(step_bound[units == 0], initial=0.0))
            bu = float(np.max(step_bound[units == 1], initial=0.0))
            sq = float(np.max(np.abs(sol.q_time[-1] - sol.q_time[0])))
            su = float(np.max(np.abs(sol.u_time[-1] - sol.u_time[0])))
            val = max(sq / bq if bq > 0 else (0.0 if sq == 0 else np.inf),
                      su / bu if bu > 0 else (0.0 if su == 0 else np.inf))
            cert.checks.append(Check("periodicity", val, 1.0, bool(val <= 1.0), True, STEP_ACCURACY_NOTE))
        else:
            cert.checks.append(Check("periodicity", val, bound, bool(val <= bound)))
    else:
        cert.checks.append(Check("periodicity", 0.0, tol, True, True, "Fourier series: periodic by construction"))

    # 2a. size of the one-step accuracy relative to the orbit (only for an orbit accepted at one step's accuracy)
    if step_bound is not None:
        # the one-step displacement change h J (m); a record without it: the displacement bound g h J >= h J
        # (conservative)
        change = step_accuracy.get("step_change")
        if change is None:
            change = float(np.max(step_bound[problem.residual_units() == 0], initial=0.0))
        val = float(change) / D if D > 0 else np.inf
        cert.checks.append(Check("step_accuracy_size", val, STEP_ACCURACY_SIZE_BOUND,
                                 bool(np.isfinite(val) and val <= STEP_ACCURACY_SIZE_BOUND), step_size_gating,
                                 STEP_ACCURACY_SIZE_NOTE if step_size_gating else
                                 STEP_ACCURACY_SIZE_NOTE + " (reported, not gating, on a branch point)"))

    # 2b. time discretisation of the time-stepped DOFs' linear dynamics
    if stepper is not None:
        _time_discretisation(problem, sol, system, omega, stepper, D, cert)

    # element time series: displacement and velocity of the element DOFs on the grid
    lam = np.asarray(sol.lam)
    # per element: extremes of w^T q, w^T u, lambda on the grid and the element's work (one compiled pass)
    terms = np.zeros((len(els), 8))
    nc = qh.shape[0]
    if els and not np.size(sol.time_dofs) and nc <= 64 and N > 2 * (nc // 2) and lam.shape[0] == N + 1:
        # Fourier series alone (HBM, DLFT): the grid values of the element DOFs are summed in the pass
        qe = ue = None
        ue_max = _element_terms_fourier(np.ascontiguousarray(qh[:, el_dofs], dtype=float),
                                        fourier.idft_matrix(N, nc // 2), omega,
                                        np.ascontiguousarray(lam, dtype=float), I, J, sign, N, terms)
    else:
        qe, ue = _element_series(sol, el_dofs, N)
        ue_max = _max_abs(ue)
        if els:
            _element_terms(np.ascontiguousarray(qe), np.ascontiguousarray(ue), np.ascontiguousarray(lam, dtype=float),
                           I, J, sign, N, terms)

    # 3. element laws
    if fr:
        ratios = []
        for j, e in fr:
            if e.normal_contact is None:
                lmax = float(terms[j, _LAM_ABS])  # max |lambda_j|
                ratios.append(lmax / e.bound if e.bound > 0 else (0.0 if lmax == 0 else np.inf))
                continue
            # normal load from a contact: the cone per sample, |lambda_T| <= mu (N_0 + lambda_N(t))
            b, lt = e.bound_samples(lam), np.abs(lam[:, j])
            big = float(np.max(b, initial=0.0))
            r = np.where(b > 1e-12 * big, lt / np.where(b > 0, b, 1.0), np.where(lt <= 1e-12 * big, 0.0, np.inf))
            ratios.append(float(np.max(r, initial=0.0)))
        val = max(ratios)
        cert.checks.append(Check("friction_cone", val, 1.0 + 1e-9, bool(val <= 1.0 + 1e-9),
                                 note="max |lambda_T| / (mu F_N) (per sample where F_N follows a contact)"))
    if ct:
        pen, bnd, comp = 0.0, np.inf, 0.0
        for j, e in ct:
            # g_N = gap + w^T q (relative contacts: on q_I - q_J): min g_N = gap + min w^T q
            p = max(0.0, float(-(e.gap + terms[j, _S_MIN])))
            umax = float(terms[j, _WU_MAX])  # max |w^T u|
            if is_dlft:  # the law holds on the Lagrangian displacement; the truncated series may cross
                b = None
            elif is_hbm:
                b = (max(0.0, float(terms[j, _LAM_MAX])) + e.penalty_damping * umax) / e.penalty_stiffness + 1e-9 * D
            elif stepper is not None and stepper.project:
                b = 1e-9 * D
            else:
                b = h * umax + 1e-9 * D
            if b is None:
                pen = max(pen, p)
            elif p - b > pen - bnd or bnd == np.inf:
                pen, bnd = p, b
            comp = max(comp, float(-terms[j, _LAM_MIN]) / F)
        if is_dlft:
            cert.checks.append(Check("non_penetration", pen, None, True, False,
                                     "max(0, -min g_N) in m of the truncated Fourier series; DLFT enforces the "
                                     "contact law on its Lagrangian displacement at the AFT samples, so this "
                                     "is a truncation error (reported, not gating)"))
        elif is_hbm and problem.penalty_quadrature == "linear":  # an HBM problem always sets it
            cert.checks.append(Check("non_penetration", pen, None, True, False,
                                     "max(0, -min g_N) in m at the AFT samples; with penalty_quadrature='linear' "
                                     "the penalty force is k_c times the penetration of the gap's linear "
                                     "interpolant, deepest at a sample, so the penetration is the law's by "
                                     "construction (reported, not gating)"))
        else:
            cert.checks.append(Check("non_penetration", pen, bnd, bool(pen <= bnd), note="max(0, -min g_N) in m"))
        if not is_hbm:
            cert.checks.append(Check("contact_compression", comp, 1e-9, bool(comp <= 1e-9),
                                     note="-min lambda_N / F"))

    # 4. energy balance
    _energy(problem, sol, system, omega, h, N, is_hbm, stepper, els, col, ue_max, lam, cert, terms, R)

    # 5. undamped resonance
    _resonance(problem, sol, system, omega, h, is_hbm, els, lam, cert, terms)

    # 6. harmonic truncation (HBM, MS-HBM)
    if problem.method != "shooting":
        n_h = int(sol.harmonics)
        top = float(mags.max(initial=0.0))
        eq = float(mags[-1].max()) / top if top > 0 and mags.shape[0] else 0.0
        cert.checks.append(Check("truncation_solution", eq, TRUNCATION_BOUND, bool(eq <= TRUNCATION_BOUND), False,
                                 f"|q_hat| at harmonic {n_h} / largest harmonic"))
        if els:
            # displacement that the element-force harmonics above n_h would cause at the element DOF,
            # through the diagonal dynamic stiffness |K_dd - (k omega)^2 M_dd + i k omega C_dd|
            Z = np.fft.rfft(lam[:-1], axis=0) * (2.0 / N)  # (N/2+1, m): complex amplitudes
            Kd, Md, Cd = diagonals(system)
            tail = np.empty(len(els))
            _force_tail(Z, Kd, Md, Cd, el_dofs_each(system), omega, n_h, tail)
            ef = 0.0
            for v in tail.tolist():
                ef = max(ef, v / D)
            cert.checks.append(Check("truncation_force", ef, TRUNCATION_BOUND, bool(ef <= TRUNCATION_BOUND), False,
                                     f"displacement of the element-force harmonics above {n_h} "
                                     "(diagonal dynamic stiffness) / D"))


#: gating bound of ``time_discretisation`` (see the module docstring)
TIME_DISCRETISATION_BOUND = 0.1


def _time_discretisation(problem, sol, system, omega, stepper, D, cert):
    T = np.asarray(problem.partition().time, dtype=np.int64)
    qh = np.asarray(sol.q_hat, dtype=float)
    if T.size == 0 or qh.shape[0] < 3:
        return
    from .condensation import solve_dynamic
    from .fourier import to_complex

    X = to_complex(qh)  # (n_h + 1, n): X_k = xc_k - i xs_k
    theta, h = float(stepper.theta), float(stepper.h)
    sub = (lambda A: A.tocsr()[T][:, T].toarray()) if sp.issparse(system.M) else \
        (lambda A: np.asarray(A)[np.ix_(T, T)])
    MT, CT = sub(system.M), sub(system.C)
    Fk = to_complex(system.forcing_hat(X.shape[0] - 1))  # (n_h + 1, n) forcing harmonics
    worst, k_worst, linear_max = 0.0, None, 0.0
    for k in range(1, X.shape[0]):
        XT = X[k, T]
        if not np.any(np.abs(XT) > 1e-9 * D):
            continue
        w = k * omega
        z = np.exp(1j * w * h)
        iwt = (z - 1.0) / (h * (1.0 - theta + theta * z))
        r = np.zeros(system.n, dtype=complex)
        r[T] = ((iwt - 1j * w) * CT + (iwt ** 2 + w ** 2) * MT) @ XT  # dH_k X_T (K cancels)
        if not np.any(r):
            continue
        rhs = np.stack([r, Fk[k]], axis=1)  # the warping error and the linear structure's own response
        try:
            # the method's own factorisations (MS-HBM: its condensation; r vanishes off T), else a solve of H_k
            cols = [problem.linear_solve(k, rhs[T, 0], False), problem.linear_solve(k, rhs[T, 1], True)]
            if cols[0] is not None and cols[1] is not None:
                sol_k = np.stack(cols, axis=1)
            else:  # dense, banded LAPACK or sparse LU
                sol_k = solve_dynamic(system.M, system.C, system.K, w, rhs)
        except (RuntimeError, np.linalg.LinAlgError):  # an undamped resonance: undamped_resonance decides
            linear_max = np.inf
            continue
        delta = sol_k[:, 0]
        linear_max = max(linear_max, float(np.max(np.abs(sol_k[:, 1]))))
        e = float(np.max(np.abs(delta))) / D
        if np.isfinite(e) and e > worst:
            worst, k_worst = e, k
    # the estimate propagates through the linear structure; where that structure alone would respond far
    # more than the solution does (the elements dominate: a stuck friction DOF at a resonance of the free
    # structure), it is not a model of the solution's sensitivity and does not gate
    applies = np.isfinite(linear_max) and linear_max <= 10.0 * D
    cert.checks.append(Check("time_discretisation", worst, TIME_DISCRETISATION_BOUND,
                             bool(worst <= TIME_DISCRETISATION_BOUND) or not applies, applies,
                             "first-order relative error of the response from the frequency warping of the "
                             f"time-stepped DOFs' M and C (largest at harmonic {k_worst}; h^2 convergence: "
                             "more steps reduce it)" + ("" if applies else
                                                        "; not gating: the linear structure alone responds more "
                                                        "than 10 times the solution (the elements dominate)")))


def _connectivity_work(problem, sol, system, omega, R, Ld):
    """Work ``W_delta`` over one period of the connectivity residual of MS-HBM (Section 3.2) on the linear
    subsystem (module docstring, ``energy_balance`` and ``connectivity_work``), J; ``None`` for other methods.

    ``R[:a]`` (``a = (2 n_h + 1) n_N``, harmonic-major) is ``delta = q_hat_N - FFT(q_N)``: the ``L`` harmonics
    ``X_L`` were condensed under the coupling ``H_LN q_hat_N``, while the solution reports ``FFT(q_N)`` on
    ``N``, so the Parseval sums of ``L`` miss ``W_delta = T/2 sum_k Re(conj(U_L,k)^T H_LN,k Delta_k)``
    (``U_L,k = i k omega X_L,k``, ``Delta_k`` the complex form of ``delta``)."""
    if problem.method != "mshbm" or R is None or not Ld.size:
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


def _energy(problem, sol, system, omega, h, N, is_hbm, stepper, els, col, ue_max, lam, cert, terms, R=None):
    n = system.n
    T = 2.0 * np.pi / omega
    C = system.C
    if is_hbm:
        qh = np.asarray(sol.q_hat)
        n_h = (qh.shape[0] - 1) // 2
        fh = system.forcing_hat(n_h)
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
            _harmonic_power(np.ascontiguousarray(qh, dtype=float), fh, np.ascontiguousarray(C, dtype=float), omega,
                            pwr)
            W_in, E_in, D_C = (float(0.5 * T * v) for v in pwr)
        # AFT quadrature of the element work: h sum_k sign lambda u_j, u_j = sign w^T u the element's
        # velocity along +-e_dof (_element_terms)
        Wj = h * terms[:, _WORK]
        Ej = h * terms[:, _WORK_ABS]
        bound_rel, gate, note = ENERGY_TOL, True, "HBM: Parseval and AFT quadrature"
        step_work = h * float(terms[:, _LAM_ABS].max(initial=0.0)) * ue_max
    else:
        # integrated DOFs (and the Fourier DOFs coupled to them by C or K) by the scheme's discrete work on
        # the grid; the block of the other Fourier DOFs by Parseval (exact, and cheap for large L)
        Cr, Kr = sp.csr_matrix(C), sp.csr_matrix(system.K)
        td = np.asarray(sol.time_dofs, dtype=np.int64)
        from .methods.common import complement

        Ld = complement(n, td)
        cl = np.setdiff1d(Cr[td].nonzero()[1], td) if td.size else np.zeros(0, dtype=np.int64)
        kl = np.setdiff1d(Kr[td].nonzero()[1], td) if td.size else np.zeros(0, dtype=np.int64)
        dofs = np.union1d(np.union1d(td, cl), kl).astype(np.int64)
        if (N + 1) * dofs.size > MAX_GRID_VALUES:
            cert.checks.append(Check("energy_balance", None, None, True, False,
                                     f"not evaluated: {dofs.size} DOFs x {N + 1} time points"))
            return
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
            fh = system.forcing_hat(n_h)
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
        elif problem.method == "shooting":
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
        W_delta = _connectivity_work(problem, sol, system, omega, R, Ld)
    # energy scale: the magnitudes of the terms, at least F D (the work of the force scale along the
    # displacement scale; without it a balance of terms that all vanish would compare rounding to rounding)
    E = max(abs(E_in) + abs(D_C) + float(np.sum(Ej)), cert.info["force_scale"] * cert.info["displacement_scale"])
    if is_hbm:
        W_delta = W_per = 0.0
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


def _resonance(problem, sol, system, omega, h, is_hbm, els, lam, cert, terms):
    # a bounded (friction) law acts whenever its bound is positive, another one where lambda != 0
    if any(e.acts if e.bounded else bool(terms[j, _ACTS]) for j, e in enumerate(els)):
        return
    n = system.n
    if n > MAX_EIG_DOFS:
        cert.checks.append(Check("undamped_resonance", None, None, True, False,
                                 f"not evaluated: {n} DOFs > {MAX_EIG_DOFS}"))
        return
    K, M, C = system.dense("K"), system.dense("M"), system.dense("C")
    w2, Phi = sla.eigh(K, M)
    c_modal = np.einsum("ir,ij,jr->r", Phi, C, Phi)
    scaleK = max(float(np.max(np.abs(w2), initial=0.0)), 1e-300)
    fh = system.f_hat
    n_f = (fh.shape[0] - 1) // 2
    worst, worst_bound, where = np.inf, 0.0, ""
    for k in range(1, n_f + 1):
        fk = np.hypot(Phi.T @ fh[2 * k - 1], Phi.T @ fh[2 * k])
        if not np.any(fk):
            continue
        eps = 1e-9 if is_hbm else max(1e-9, 10.0 * (k * omega * h) ** 2)
        for r in range(n):
            if fk[r] <= 1e-12 * fk.max() or w2[r] <= 1e-14 * scaleK:
                continue
            wr = np.sqrt(w2[r])
            if abs(c_modal[r]) > 1e-12 * (w2[r] + wr):  # damped mode: bounded response
                continue
            det = abs((k * omega) ** 2 / w2[r] - 1.0)
            if det - eps < worst - worst_bound or worst == np.inf:
                worst, worst_bound = det, eps
                where = f"harmonic {k} of the forcing, k*omega = {k * omega:.6g} rad/s, undamped mode at {wr:.6g} rad/s"
    if worst == np.inf:
        return
    ok = worst > worst_bound
    note = where if ok else (where + ": within the discretisation error of an undamped natural frequency and no "
                             "element acts, so no resolved periodic solution exists (add damping or move omega)")
    cert.checks.append(Check("undamped_resonance", worst, worst_bound, bool(ok), True, note))


def apply_certificate(problem, sol, tol, step_accuracy=None, cert=None):
    """Attach ``certify(problem, sol, tol)`` to ``sol.certificate`` and gate ``sol.success`` on it.

    ``success`` stays True only if it was True (Newton converged) and every gating check
    passed; otherwise the message names the failed checks.  Non-gating checks (the truncation
    estimates) above their bound are named in the message of a certified solution as a warning
    (:meth:`Certificate.describe_warnings`; ``success`` stays True).  ``cert``: the certificate
    already computed for the same problem, unknowns and ``step_accuracy`` (the start ladder's
    acceptance test), attached instead of computing it again.
    """
    if cert is None:
        cert = certify(problem, sol, tol, step_accuracy)
    sol.certificate = cert
    if sol.success and not cert.passed:
        sol.success = False
        sol.message = f"certificate failed: {cert.describe_failures()} (Newton: {sol.message})"
    elif not cert.passed:
        sol.message = f"{sol.message}; certificate failed: {cert.describe_failures()}"
    if sol.success and cert.warnings:
        sol.message = f"{sol.message}; warning: {cert.describe_warnings()}"
    return cert
