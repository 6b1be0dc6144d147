"""The element-law checks of a certificate and the per-element table they read.

``friction_cone`` (gating, friction elements)
    ``max_j max_t |lambda_j| / (mu F_N)_j``; bound ``1 + 1e-9`` (the projected Gauss-Seidel solver resolves
    the cone to ~1e-14; the arctan law of HBM stays strictly inside).  Where ``F_N`` follows a contact, the
    cone is taken per sample.
``non_penetration`` (gating, contacts)
    Largest penetration ``max(0, -min g_N)`` (m).  Bound, time stepping: ``1e-9 D`` with position
    projection (the projection puts a penetrating contact back on ``g_N = 0`` to rounding), otherwise one
    step's travel ``h max |u_dof|`` (the velocity-level law can let a contact run into the obstacle for at
    most one step); penalty contact (HBM): the penetration the penalty law itself needs to carry the contact
    force, ``(max lambda_N + d_c max |u_dof|) / k_c``, plus ``1e-9 D``.  Reported, not gating, where the
    penetration is the law's by construction (``penalty_quadrature="linear"``) or a truncation error of the
    series (contacts on a Lagrangian displacement, DLFT).
``contact_compression`` (gating, contacts, time series)
    ``-min lambda_N / F`` (contact forces push, never pull); bound ``1e-9``.
``spring_law`` (gating, smooth elements: polynomial springs)
    ``max_j max_t |lambda_j - lambda_j(s)| / max(F, max |lambda_j|)``: the reported force is the polynomial of
    the local displacement ``s = w^T q`` -- at the samples ``t_k`` (HBM, DLFT), at Moreau's midpoint
    ``q_k + h/2 u_k`` of each step (time stepping, where the force is the step's impulse over ``h``); bound
    ``1e-9`` (rounding).
``cone_dissipation`` (3-D frictional contact, :mod:`mshbm.elements.cone`)
    Maximal dissipation where a cone pair slips: ``max (mu F_N ||gamma_T|| + lambda_T . gamma_T) /
    (mu F_N ||gamma_T||)`` over the samples with ``||gamma_T|| > 1e-6 V`` (0: the force opposes the slip with
    the full bound).  Time stepping (gating, bound ``1e-8``): the impulse of step ``k`` against the slip velocity
    at its end, ``gamma_T(t_k+1)`` (the law of the local problem); HBM and DLFT (reported): HBM's regularised
    law has the deficit ``1 - (2/pi) arctan(kappa ||gamma_T||)`` by construction, DLFT's law holds on its
    Lagrangian velocity, not on the series.  ``friction_cone`` takes the pair's
    ``||lambda_T||`` per sample.
``hysteresis_periodicity`` (gating, HBM with Jenkins elements: 1-D and the 3-D Jenkins pair)
    The element force of a law with memory is periodic only if the AFT's march over the period ends in the state
    it started from.  One more period of the return mapping (1-D: the interval ``|lambda| <= mu N_0``; a cone
    pair: the disk), started from the reported force at the last sample and driven by the reported series'
    ``s = w^T q`` on the samples, must reproduce every sample: ``max_k |lambda_again(t_k) - lambda(t_k)| / (mu
    N_0)``; bound ``1e-9`` (the 1-D march is periodic after one slip to rounding; the disk's march is iterated to
    ``1e-14 mu N_0``).  Time stepping integrates the sliders as DOFs (their periodicity is ``periodicity``'s);
    DLFT's sliders are Fourier series.
"""
from __future__ import annotations

import numpy as np

from .. import fourier
from .kernels import LAM_ABS, LAM_MAX, LAM_MIN, S_MIN, WU_MAX, element_terms, element_terms_fourier
from .record import Check

__all__ = ["element_tables", "el_dofs_each", "element_series", "element_terms_table", "law_checks", "cone_check",
           "max_abs", "spring_law_check", "hysteresis_check", "hysteresis_closure"]


def max_abs(a):
    """``max |a|`` (0 for an empty array)."""
    return float(np.abs(a).max(initial=0.0))


def element_tables(system):
    """The element bookkeeping of the certificate (cached on the system while its element tuple is the same;
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


def element_series(sol, dofs, N):
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


def element_terms_table(sol, system, omega, N, lam):
    """Per element the extremes of ``w^T q``, ``w^T u``, ``lambda`` on the grid and its work, shape ``(m, 8)``
    (columns :data:`mshbm.certificate.kernels.S_MIN` ...), and the largest velocity of the element DOFs
    (m/s), in one compiled pass; ``lam`` the element forces (N+1, m)."""
    els = list(system.elements)
    el_dofs, _, I, J, sign, _, _ = element_tables(system)
    qh = np.asarray(sol.q_hat)
    # per element: extremes of w^T q, w^T u, lambda on the grid and the element's work (one compiled pass)
    terms = np.zeros((len(els), 8))
    nc = qh.shape[0]
    if els and not np.size(sol.time_dofs) and nc <= 64 and N > 2 * (nc // 2) and lam.shape[0] == N + 1:
        # Fourier series alone (HBM, DLFT): the grid values of the element DOFs are summed in the pass
        ue_max = element_terms_fourier(np.ascontiguousarray(qh[:, el_dofs], dtype=float),
                                       fourier.idft_matrix(N, nc // 2), omega,
                                       np.ascontiguousarray(lam, dtype=float), I, J, sign, N, terms)
    else:
        qe, ue = element_series(sol, el_dofs, N)
        ue_max = max_abs(ue)
        if els:
            element_terms(np.ascontiguousarray(qe), np.ascontiguousarray(ue), np.ascontiguousarray(lam, dtype=float),
                          I, J, sign, N, terms)
    return terms, ue_max


def law_checks(problem, system, terms, lam, F, D, h, stepper, cert):
    """Append ``friction_cone``, ``non_penetration`` and ``contact_compression`` to ``cert`` (module
    docstring) for the elements that have them; ``terms`` from :func:`element_terms_table`, ``F`` the force
    scale (N), ``D`` the displacement scale (m), ``h`` the step (s), ``stepper`` the problem's (or ``None``)."""
    is_hbm = problem.fourier_all_dofs
    fr, ct = element_tables(system)[5:]
    if fr:
        ratios = []
        for j, e in fr:
            if e.cone_partner is not None:  # 3-D contact: ||lambda_T|| of the pair per sample
                b, lt = e.bound_samples(lam), np.hypot(lam[:, j], lam[:, e.cone_partner])
                big = float(np.max(b, initial=0.0))
                r = np.where(b > 1e-12 * big, lt / np.where(b > 0, b, 1.0),
                             np.where(lt <= 1e-12 * big, 0.0, np.inf))
                ratios.append(float(np.max(r, initial=0.0)))
                continue
            if e.normal_contact is None:
                lmax = float(terms[j, LAM_ABS])  # max |lambda_j|
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
            p = max(0.0, float(-(e.gap + terms[j, S_MIN])))
            umax = float(terms[j, WU_MAX])  # max |w^T u|
            if problem.lagrangian_contact:  # the law holds on the Lagrangian displacement; the series may cross
                b = None
            elif problem.penalty_contact:
                b = (max(0.0, float(terms[j, LAM_MAX])) + e.penalty_damping * umax) / e.penalty_stiffness + 1e-9 * D
            elif stepper is not None and stepper.project:
                b = 1e-9 * D
            else:
                b = h * umax + 1e-9 * D
            if b is None:
                pen = max(pen, p)
            elif p - b > pen - bnd or bnd == np.inf:
                pen, bnd = p, b
            comp = max(comp, float(-terms[j, LAM_MIN]) / F)
        if problem.lagrangian_contact:
            cert.checks.append(Check("non_penetration", pen, None, True, False,
                                     "max(0, -min g_N) in m of the truncated Fourier series; DLFT enforces the "
                                     "contact law on its Lagrangian displacement at the AFT samples, so this "
                                     "is a truncation error (reported, not gating)"))
        elif problem.penalty_contact and problem.penalty_quadrature == "linear":
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


def spring_law_check(system, sol, lam, F, h, stepper, cert):
    """Append ``spring_law`` (module docstring) when the system has smooth elements (polynomial springs)."""
    sm = [(j, e) for j, e in enumerate(system.elements) if e.smooth]
    if not sm:
        return
    dofs = np.array(sorted({int(d) for _, e in sm for d in e.dofs}), dtype=np.int64)
    col = {int(d): i for i, d in enumerate(dofs)}
    N = lam.shape[0] - 1
    q, u = element_series(sol, dofs, N)
    where = "at the samples"
    if stepper is not None:  # the step's impulse over h, evaluated at q_M = q_k + h/2 u_k
        q = q[:-1] + 0.5 * h * u[:-1]
        lam = lam[:-1]
        where = "at q_k + h/2 u_k of each step"
    worst = 0.0
    for j, e in sm:
        expect = e.law(e.local(q, col))[0]
        worst = max(worst, max_abs(lam[:, j] - expect) / max(F, max_abs(lam[:, j]), 1e-300))
    cert.checks.append(Check("spring_law", worst, 1e-9, bool(worst <= 1e-9),
                             note="max |lambda - lambda(w^T q)| / max(F, max |lambda|) of the polynomial springs, "
                                  + where))


def cone_check(problem, sol, system, lam, V, stepper, cert):
    """Append ``cone_dissipation`` (module docstring) for the cone pairs of ``system``; ``lam`` the element forces
    (N+1, m), ``V`` the velocity scale (m/s), ``stepper`` the Moreau-Jean stepper (``None``: HBM)."""
    pairs = [(j, int(e.cone_partner)) for j, e in enumerate(system.elements)
             if e.cone_partner is not None and j < e.cone_partner and not e.history]  # Jenkins: the slider slips
    if not pairs:
        return
    N = lam.shape[0] - 1
    dofs = np.array(sorted({int(d) for j, k in pairs for i in (j, k) for d in system.elements[i].dofs}))
    _, u = element_series(sol, dofs, N)
    col = {int(d): i for i, d in enumerate(dofs)}
    val = 0.0
    for j, k in pairs:
        g = np.stack([system.elements[i].local(u, col) for i in (j, k)], axis=1)  # (N+1, 2)
        g = g[1:] if stepper is not None else g[:-1]  # the step's end velocity (time stepping) / the sample's
        L = lam[:-1][:, [j, k]]
        b = system.elements[j].bound_samples(lam)[:-1]
        gn = np.linalg.norm(g, axis=1)
        slip = (gn > 1e-6 * V) & (b > 0)
        if slip.any():
            dev = (b[slip] * gn[slip] + np.einsum("ij,ij->i", L[slip], g[slip])) / (b[slip] * gn[slip])
            val = max(val, float(dev.max()))
    if stepper is not None:
        cert.checks.append(Check("cone_dissipation", val, 1e-8, bool(val <= 1e-8),
                                 note="max (mu F_N ||gamma_T|| + lambda_T . gamma_T) / (mu F_N ||gamma_T||) where a "
                                 "3-D contact slips (maximal dissipation; impulse against the end-of-step slip)"))
    else:
        cert.checks.append(Check("cone_dissipation", val, None, True, False,
                                 note="max (mu F_N ||gamma_T|| + lambda_T . gamma_T) / (mu F_N ||gamma_T||) where a "
                                 "3-D contact slips; HBM: the regularised cone law's deficit 1 - (2/pi) arctan(kappa "
                                 "||gamma_T||) by construction; DLFT: the law holds on the Lagrangian velocity, not "
                                 "the series (reported, not gating)"))


def hysteresis_closure(kt, b, s, lam):
    """``max_k |lambda_again_k - lambda_k| / b``: one more period of the return mapping (spring ``kt``, bound ``b``)
    from ``lam[-1]``, driven by ``s`` (both shape (N,) for a 1-D Jenkins element, (N, 2) for a cone pair: the
    disk), against ``lam`` (module docstring, ``hysteresis_periodicity``)."""
    s, lam = np.asarray(s, dtype=float), np.asarray(lam, dtype=float)
    pair = s.ndim == 2
    prev = lam[-1].copy()
    worst = 0.0
    for k in range(s.shape[0]):
        t = prev - kt * (s[k] - s[k - 1])
        if pair:
            nt = float(np.hypot(t[0], t[1]))
            prev = t if nt <= b else (b / nt) * t
        else:
            prev = min(max(t, -b), b)
        worst = max(worst, float(np.max(np.abs(prev - lam[k]))))
    return worst / b if b > 0 else 0.0


def hysteresis_check(problem, sol, system, lam, cert):
    """Append ``hysteresis_periodicity`` (module docstring) for HBM solutions with Jenkins elements; ``lam`` the
    element forces on the samples (N+1, m)."""
    if not problem.hysteresis_aft:  # declared representation (mshbm.methods.base)
        return
    hist = [(j, e) for j, e in enumerate(system.elements) if e.history and (e.cone_partner is None
                                                                             or j < e.cone_partner)]
    if not hist:
        return
    N = lam.shape[0] - 1
    dofs = np.array(sorted({int(d) for j, e in hist for i in ([j] if e.cone_partner is None else [j, e.cone_partner])
                            for d in system.elements[i].dofs}), dtype=np.int64)
    q, _ = element_series(sol, dofs, N)
    col = {int(d): i for i, d in enumerate(dofs)}
    worst = 0.0
    for j, e in hist:
        idx = [j] if e.cone_partner is None else [j, int(e.cone_partner)]
        sk = np.stack([system.elements[i].local(q, col)[:-1] for i in idx], axis=1)
        L = lam[:-1][:, idx]
        if len(idx) == 1:
            sk, L = sk[:, 0], L[:, 0]
        worst = max(worst, hysteresis_closure(float(e.tangential_stiffness), float(e.bound), sk, L))
    cert.checks.append(Check("hysteresis_periodicity", worst, 1e-9, bool(worst <= 1e-9),
                             note="max |lambda_again - lambda| / (mu N_0): one more period of the Jenkins return "
                                  "mapping from the force at the last sample reproduces every sample"))
