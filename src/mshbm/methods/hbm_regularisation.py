"""HBM's regularised laws: their defaults from the problem's own scales, and the estimate of the
regularisation error (the certificate's ``regularisation`` check).

Notation: element direction ``w`` (:mod:`mshbm.elements`), local velocity ``gamma = w^T u``, friction
bound ``mu F_N``, arctan smoothing ``kappa`` (s/m, eq. 42), penalty stiffness ``k_c`` (N/m, eq. 45).

Defaults that do not depend on units
------------------------------------
An element given without ``smoothing`` (friction) or ``penalty_stiffness`` (contact) gets it here, when
HBM builds its problem, from scales of the same system (:func:`resolve`); a value given explicitly stays
as given (absolute, in s/m or N/m).

* Friction: ``kappa = SMOOTHING_FACTOR / V`` with the velocity scale ``V = min(V_lin, omega F / k_w)``:
  ``V_lin = omega sum_k k |w^T q_hat_lin,k|`` the peak slip velocity of the linear response (the structure
  without its elements) at the element, over the forcing's harmonics, and ``omega F / k_w`` that of the
  force scale ``F`` (:func:`mshbm.scaling.force_scale`, the peak forcing) acting quasi-statically on the
  stiffness ``k_w`` along the element (below).  The second caps the first near a resonance of the
  structure without its elements, where ``V_lin`` is unbounded while the friction holds the motion (a
  chain at its undamped resonance whose friction sticks); it is the scale when ``V_lin`` vanishes (a
  static or no forcing).  ``kappa gamma`` is dimensionless and the same in every unit system.
* Contact: ``k_c = PENALTY_FACTOR k_w``, ``k_w = 1 / (w^T (K + omega^2 M)^-1 w)`` the stiffness of the
  structure along the element (its springs and its inertia at ``omega``, every other DOF free; the same
  number in any coordinates of the structure, so a relative contact equals the ground contact in relative
  coordinates).  The penetration ``lambda_N / k_c`` is then the same fraction of the structure's own
  deflection ``lambda_N / k_w`` in every unit system.

Under a change of units (lengths, forces or both: ``M, C, K`` times ``a``, forcing and ``mu F_N`` times
``b``) ``V`` scales like a velocity and ``k_w`` like a stiffness, so ``kappa gamma`` and ``k_c / k_w`` are
unchanged and HBM's answer scales exactly (to rounding).

Error of the regularisation
---------------------------
:func:`regularisation_check` re-solves the problem once with every law ``STIFFENING`` times stiffer
(``kappa``, ``k_c`` and ``d_c`` times 4: :meth:`mshbm.elements.Element.scaled`) by Newton from the
converged answer, and takes the change ``Delta`` of the amplitudes (``max_i |Delta A_i| / max_i A_i``
over the DOFs).  The regularisation error of a law ``p`` times stiffer falls like ``p^-r``; with
``r >= 1/2`` (arctan friction: ``r ~ 0.6`` where stick phases form, ``~ 1`` in pure slip; penalty:
``r = 1``) the error of the answer is at most ``Delta / (1 - 4^-r) <= 2 Delta`` (Richardson), which is
the Richardson estimate.  Where the law is so soft that it hardly acts (an absolute ``kappa`` with a tiny
``mu F_N``: ``kappa gamma << 1`` everywhere) a 4 times stiffer law changes nothing either; the check's value is
therefore at least :func:`law_distance`, the distance of the regularised laws from the set-valued ones along
the solution (close to 1 there, a tenth of the Richardson estimate or less where the law acts).  Both solves
use the same harmonics and samples: the estimate is that of the regularisation at the chosen discretisation;
the truncation error is estimated separately.
"""
from __future__ import annotations

import time

import numpy as np

from ..elements.cone import cone_pairs
from ..scaling import force_scale

__all__ = ["SMOOTHING_FACTOR", "PENALTY_FACTOR", "STIFFENING", "ORDER", "REGULARISATION_BOUND", "resolve",
           "unresolved", "regularised", "law_distance", "regularisation_check"]

#: default ``kappa V`` of the arctan friction law (dimensionless)
SMOOTHING_FACTOR = 3.0e4
#: default ``k_c / k_w`` of the penalty contact
PENALTY_FACTOR = 1.0e4
#: the stiffer law of the error estimate: every regularisation times this
STIFFENING = 4.0
#: the accuracy the estimate is compared with (reported, not gating)
REGULARISATION_BOUND = 1e-2
#: assumed lowest order of the regularisation error in ``kappa`` (``k_c``): estimate ``Delta / (1 - 4^-ORDER)``
ORDER = 0.5


def unresolved(system):
    """True if an element of ``system`` has its regularisation left to the default (``None``)."""
    return any(not el.history and (getattr(el, "smoothing", 0.0) is None
                                   or getattr(el, "penalty_stiffness", 0.0) is None) for el in system.elements)


def regularised(system):
    """True if an element of ``system`` has a regularised law (arctan friction or penalty contact; not the
    elastic Jenkins friction, whose law HBM evaluates without regularisation)."""
    return any(not el.history and (hasattr(el, "smoothing") or hasattr(el, "penalty_stiffness"))
               for el in system.elements)


def _velocity_scales(system, omega):
    """Per element: the peak velocity ``omega sum_k k |w^T q_hat_lin,k|`` (m/s) of the linear response."""
    from .common import linear_response

    nf = max(1, system.n_forcing_harmonics)
    q_hat = linear_response(system, omega, nf)
    k = np.arange(1, nf + 1) * omega
    out = []
    for el in system.elements:
        s = sum(wi * q_hat[:, d] for d, wi in el.direction)
        out.append(float(np.sum(k * np.hypot(s[1::2], s[2::2]))))
    return out


def _stiffness_scales(system, omega, elements):
    """Per element of ``elements`` (indices): ``k_w = 1 / (w^T (K + omega^2 M)^-1 w)`` (N/m), the stiffness of
    the structure (springs and inertia at ``omega``, all other DOFs free) along ``w``; the same in any
    coordinates of the structure.  Where it is not positive and finite (an indefinite ``K``): the diagonal
    form ``|w^T K w| + omega^2 w^T M w``."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    n = system.n
    W = np.zeros((n, len(elements)))
    for c, j in enumerate(elements):
        for d, wi in system.elements[j].direction:
            W[d, c] += wi
    K, M = system.K, system.M
    try:
        if sp.issparse(K) or sp.issparse(M):
            A = (sp.csc_matrix(K) + omega ** 2 * sp.csc_matrix(M)).tocsc()
            X = spla.splu(A).solve(W)
        else:
            X = np.linalg.solve(np.asarray(K) + omega ** 2 * np.asarray(M), W)
        flex = np.einsum("ij,ij->j", W, X)
    except (np.linalg.LinAlgError, RuntimeError, ValueError):
        flex = np.full(len(elements), np.nan)
    out = []
    for c in range(len(elements)):
        if np.isfinite(flex[c]) and flex[c] > 0.0:
            out.append(1.0 / float(flex[c]))
            continue
        w = W[:, c]
        quad = lambda B: float(w @ (B @ w))
        out.append(abs(quad(K)) + omega ** 2 * quad(M))
    return out


def _compute(system, omega):
    """``(elements, record)`` with the defaults filled in (module docstring)."""
    V = None
    smooth = [j for j, el in enumerate(system.elements) if getattr(el, "smoothing", 0.0) is None and not el.history]
    need = [j for j, el in enumerate(system.elements) if getattr(el, "penalty_stiffness", 0.0) is None]
    kws = dict(zip(need + smooth, _stiffness_scales(system, omega, need + smooth))) if need or smooth else {}
    els, record = [], []
    for j, el in enumerate(system.elements):
        entry = {"element": j, "kind": el.kind}
        if j in smooth:
            if V is None:
                V = _velocity_scales(system, omega)
            v_lin = V[j]
            v_f = omega * force_scale(system) / kws[j]
            v = min(v_lin, v_f) if np.isfinite(v_lin) and v_lin > 0.0 else v_f
            kappa = SMOOTHING_FACTOR / v
            el = _replace(el, smoothing=kappa)
            entry.update(smoothing=kappa, velocity_scale=v, linear_velocity=v_lin, force_velocity=v_f,
                         rule=f"smoothing = {SMOOTHING_FACTOR:g} / V, V = min(peak slip velocity of the linear "
                         "response, omega F / k_w)", default=True)
        elif getattr(el, "smoothing", None) is not None and not el.history:
            entry.update(smoothing=float(el.smoothing), default=False)
        if getattr(el, "penalty_stiffness", 0.0) is None:
            if kws is None:
                kws = dict(zip(need, _stiffness_scales(system, omega, need)))
            kw = kws[j]
            kc = PENALTY_FACTOR * kw
            el = _replace(el, penalty_stiffness=kc)
            entry.update(penalty_stiffness=kc, stiffness_scale=kw, rule=f"penalty_stiffness = {PENALTY_FACTOR:g} k_w, "
                         "k_w = 1 / (w^T (K + omega^2 M)^-1 w)", default=True)
        elif getattr(el, "penalty_stiffness", None) is not None:
            entry.update(penalty_stiffness=float(el.penalty_stiffness), default=False)
        els.append(el)
        record.append(entry)
    for j, k in cone_pairs(system.elements):  # one contact point: one kappa, from the larger velocity scale
        if j in smooth and k in smooth:
            kappa = min(els[j].smoothing, els[k].smoothing)
            for i in (j, k):
                els[i] = _replace(els[i], smoothing=kappa)
                record[i].update(smoothing=kappa, rule=record[i]["rule"] + "; cone partners: the smaller kappa")
    return els, record


def _replace(el, **kw):
    from dataclasses import replace

    return replace(el, **kw)


def resolve(system, omega):
    """``(system, record)``: ``system`` with every default regularisation filled in (module docstring), the
    same object when there is none to fill; ``record`` per element the values used (``default``: from the
    rule, with its scale; else as given).  Cached per system and frequency."""
    memo = system.derived("hbm_regularisation", ("M", "C", "K", "f_hat", "elements"), dict)
    w = float(omega)
    hit = memo.get(w)
    if hit is None:
        if not unresolved(system):
            hit = (system, _compute(system, w)[1])
        else:
            els, record = _compute(system, w)
            hit = (system.with_elements(els), record)
        if len(memo) >= 64:
            memo.clear()
        memo[w] = hit
    return hit


# ------------------------------------------------------------------------------------------------ the estimate
REGULARISATION_NOTE = ("estimated relative amplitude error of the regularised laws: 2 x the change of the amplitudes "
                       "(max |dA| / max A over the DOFs) when every law is {f:g} x stiffer (smoothing kappa, penalty "
                       "k_c, d_c), re-solved from this answer at the same harmonics and samples; Richardson with an "
                       "error order >= 1/2 in the regularisation")


def law_distance(system, sol):
    """Distance of the regularised laws from the set-valued ones along the solution ``sol`` (dimensionless):
    the largest of, per friction element, the deficit ``(W_0 - W) / max(W_0, W_in)`` of the work
    ``W = -int lambda gamma dt`` it dissipates against ``W_0 = int mu F_N |gamma| dt`` of Coulomb's law on the same
    motion, relative to the energy the orbit dissipates (``W_in``, the forcing's work per period, at least ``W_0``)
    and weighted by ``min(1, max|gamma| / max|u|)`` (the element's slip speed against the orbit's velocities: a
    sticking element's creep), and per contact
    the penetration ``max(-g_N)`` relative to the largest amplitude.  Small against the amplitude change where the
    law acts as the set-valued one (about a tenth of it on Den Hartog's oscillator); close to 1 where the
    regularisation is so soft that the law hardly acts at all (a tiny ``mu F_N`` with an absolute ``kappa``),
    where a stiffer law changes nothing either and the Richardson estimate says nothing."""
    t, lam = np.asarray(sol.t), np.asarray(sol.lam)
    dt = np.diff(t)
    top = float(np.max(sol.amplitude, initial=0.0))
    cert = getattr(sol, "certificate", None)
    energy = {} if cert is None else cert.info.get("energy", {})
    W_in = abs(float(energy.get("input_work", 0.0) or 0.0))
    V = float(np.max(np.abs(np.asarray(sol.u)), initial=0.0))  # the orbit's velocity scale
    out = 0.0
    for j, el in enumerate(system.elements):
        if el.history:
            continue
        if el.bounded:
            gam = el.local(np.asarray(sol.u))[:-1]
            W0 = float(np.sum(el.bound_samples(lam)[:-1] * np.abs(gam) * dt))
            if el.cone_partner is not None:  # the pair's work against mu F_N ||gamma_T||, at its first element
                p = el.cone_partner
                if p < j:
                    continue
                gp = system.elements[p].local(np.asarray(sol.u))[:-1]
                W0 = float(np.sum(el.bound_samples(lam)[:-1] * np.hypot(gam, gp) * dt))
                Wl = float(-np.sum((lam[:-1, j] * gam + lam[:-1, p] * gp) * dt))
                weight = min(1.0, float(np.max(np.hypot(gam, gp), initial=0.0)) / V) if V > 0 else 1.0
                if W0 > 0.0:
                    out = max(out, weight * (W0 - Wl) / max(W0, W_in))
                continue
            if W0 > 0.0:
                # the work deficit relative to the energy the orbit dissipates per period (at least W_0): an
                # element that creeps where Coulomb's would stick has a deficit near W_0 but W_0 is then a
                # vanishing part of the energy budget, and the amplitude hardly depends on it
                # and weighted by the element's slip speed against the orbit's: a creep far below the orbit's
                # velocities (an element that sticks) moves the amplitude by as little
                weight = min(1.0, float(np.max(np.abs(gam), initial=0.0)) / V) if V > 0 else 1.0
                out = max(out, weight * (W0 - float(-np.sum(lam[:-1, j] * gam * dt))) / max(W0, W_in))
        elif el.unilateral and top > 0.0:
            out = max(out, max(0.0, -float(np.min(el.gap + el.local(np.asarray(sol.q))))) / top)
    return out


def regularisation_check(problem, sol, nkw, bound):
    """The certificate entry ``regularisation`` of an HBM solution (module docstring), appended to
    ``sol.certificate`` (reported, not gating).

    ``problem``: the HBM problem ``sol`` solves; ``nkw``: Newton's options of the solve (``tol``,
    ``max_iter``, ``line_search``); ``bound``: the stated accuracy the value is compared with.
    Returns the :class:`mshbm.certificate.Check`."""
    from ..certificate import Check
    from ..extrema import fourier_extrema
    from ..solvers.newton import solve_problem

    t0 = time.process_time()
    f = STIFFENING
    note = REGULARISATION_NOTE.format(f=f)
    opts = {k: nkw[k] for k in ("tol", "max_iter", "line_search") if k in nkw}
    x = np.asarray(sol.x, dtype=float)
    res = None
    for path in ((f,), (2.0, f), (1.4, 2.0, 2.8, f)):  # directly, else in stages of the stiffening
        xs = x
        for g in path:
            stiff = problem.stiffened(g)
            res = solve_problem(stiff, xs, **opts)
            if not res.success:
                break
            xs = res.x
        if res is not None and res.success:
            break
    if res is None or not res.success:
        check = Check("regularisation", None, bound, False, False,
                      note + f"; the stiffer law could not be solved from this answer ({res.message if res else ''})")
    else:
        hi, lo = fourier_extrema(stiff.full_coefficients(res.x))  # HBM: every DOF a series
        A, A4 = np.asarray(sol.amplitude, dtype=float), 0.5 * (hi - lo)
        top = float(np.max(A, initial=0.0))
        delta = float(np.max(np.abs(A4 - A), initial=0.0)) / top if top > 0 else 0.0
        richardson, distance = delta / (1.0 - f ** -ORDER), law_distance(problem.system, sol)
        value = max(richardson, distance)
        check = Check("regularisation", value, bound, bool(value <= bound), False,
                      note + f" ({richardson:.3g}), and at least the distance of the laws from the set-valued ones "
                      f"along the solution ({distance:.3g}: the friction work's deficit against mu F_N |gamma|, the "
                      "penetration / max A)")
    sol.certificate.checks.append(check)
    sol.info["regularisation_check_cpu_s"] = time.process_time() - t0
    return check
