"""The verdict of a certificate: :func:`certify` runs the checks in their fixed order on a solution and
:func:`apply_certificate` gates the solution's ``success`` on them (see :mod:`mshbm.certificate`)."""
from __future__ import annotations

import numpy as np

from ..scaling import displacement_floor, force_scale
from .accuracy import periodicity_check, residual_check, step_accuracy_size_check
from .energy import energy_checks
from .laws import cone_check, element_terms_table, hysteresis_check, law_checks, max_abs, spring_law_check
from .linear import time_discretisation, undamped_resonance
from .record import Certificate, Check
from .substitution import model_substitution_check
from .truncation import truncation_checks

__all__ = ["certify", "apply_certificate", "reword_warnings"]


def certify(problem, sol, tol, step_accuracy=None, step_size_gating=True, substitution="estimate"):
    """Certificate of ``sol`` (a :class:`mshbm.result.PeriodicSolution` of ``problem``).

    Parameters
    ----------
    problem : mshbm.methods.base.PeriodicProblem
        The problem that produced ``sol`` (its residual, scales and declared representation).
    sol : PeriodicSolution
    tol : float
        Newton tolerance of the solve (bound of the ``residual`` check).
    step_accuracy : dict, optional
        Set when the start ladder (:func:`mshbm.route.ladder.residual_accept`) accepted a stalled Newton on
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
    substitution : {"estimate", "name", "skip"}
        ``model_substitution``: a substituted law named and its effect estimated (two exact periodic solves;
        default), only named (solves and :func:`mshbm.sweep`'s points without error estimates, ``accuracy=False``),
        or left out (a sweep's points with error estimates leave it to them, :mod:`mshbm.branch_accuracy`: at the
        estimated points, interpolated between them, as the other estimates: its exact solves cost more than the
        point itself).

    Returns
    -------
    Certificate
    """
    cert = Certificate()
    with np.errstate(all="ignore"):
        try:
            _certify(problem, sol, float(tol), cert, step_accuracy, bool(step_size_gating), substitution)
        except Exception as exc:  # noqa: BLE001 -- a certificate that cannot be computed does not pass
            cert.checks.append(Check("evaluation", None, None, False, True, f"{type(exc).__name__}: {exc}"))
    return cert


def _certify(problem, sol, tol, cert, step_accuracy=None, step_size_gating=True, substitution="estimate"):
    """The checks of :func:`certify`, appended to ``cert`` in their fixed order."""
    system, omega = problem.system, float(sol.omega)
    stepper = None if problem.integrator is None else problem.integrator.stepper  # None: HBM, DLFT, event flow
    T = 2.0 * np.pi / omega
    t = np.asarray(sol.t)
    N = t.size - 1
    h = T / N
    F = force_scale(system, penalty=problem.penalty_contact)
    D0 = displacement_floor(system, omega)
    els = list(system.elements)

    # 1. residual, re-evaluated
    x = np.asarray(sol.x, dtype=float)
    R = problem.residual(x, jac=False)[0]
    step_bound = residual_check(problem, x, R, tol, step_accuracy, cert)

    # sizes of the solution (from the Fourier coefficients and the time series)
    qh = np.asarray(sol.q_hat)
    mags = np.hypot(qh[1::2], qh[2::2])  # (n_h, n): harmonic magnitudes (also the truncation check's)
    amp_h = np.abs(qh[0]) + mags.sum(axis=0) if qh.shape[0] > 1 else np.abs(qh[0])
    D = max(D0, float(amp_h.max(initial=0.0)), max_abs(sol.q_time))
    V = max(omega * D, max_abs(sol.u_time))
    cert.info.update(force_scale=F, displacement_scale=D, velocity_scale=V)

    # 2. periodicity of the time-stepped DOFs, and the size of one step's accuracy against the orbit
    periodicity_check(problem, sol, omega, h, tol, D, V, step_bound, cert)
    if step_bound is not None:
        step_accuracy_size_check(problem, step_accuracy, step_bound, D, step_size_gating, cert)

    # 2b. time discretisation of the time-stepped DOFs' linear dynamics
    if stepper is not None:
        time_discretisation(problem, sol, system, omega, stepper, D, cert)

    # 3. element laws, from one pass over the element DOFs' series on the grid
    lam = np.asarray(sol.lam)
    terms, ue_max = element_terms_table(sol, system, omega, N, lam)
    law_checks(problem, system, terms, lam, F, D, h, stepper, cert)
    spring_law_check(system, sol, lam, F, h, stepper, cert)
    cone_check(problem, sol, system, lam, V, stepper, cert)
    hysteresis_check(problem, sol, system, lam, cert)

    # 4. energy balance
    energy_checks(problem, sol, system, omega, h, N, stepper, els, ue_max, cert, terms, R)

    # 5. undamped resonance
    undamped_resonance(system, omega, h, problem.fourier_all_dofs, els, cert, terms)

    # 6. harmonic truncation (HBM, DLFT, MS-HBM)
    if problem.harmonic_truncation:
        truncation_checks(sol, system, omega, mags, lam, N, D, cert)

    # 7. model substitution (a contact law in place of Newton's law with the user's restitution: DLFT, HBM)
    if substitution != "skip":
        model_substitution_check(problem, sol, cert, estimate=substitution == "estimate")


def apply_certificate(problem, sol, tol, step_accuracy=None, cert=None, substitution="estimate"):
    """Attach ``certify(problem, sol, tol)`` to ``sol.certificate`` and gate ``sol.success`` on it.

    ``success`` stays True only if it was True (Newton converged) and every gating check
    passed; otherwise the message names the failed checks.  Non-gating checks (the truncation
    estimates) above their bound are named in the message of a certified solution as a warning
    (:meth:`Certificate.describe_warnings`; ``success`` stays True).  ``cert``: the certificate
    already computed for the same problem, unknowns and ``step_accuracy`` (the start ladder's
    acceptance test), attached instead of computing it again.  ``substitution``: as for :func:`certify`.
    """
    if cert is None:
        cert = certify(problem, sol, tol, step_accuracy, substitution=substitution)
    sol.certificate = cert
    if sol.success and not cert.passed:
        sol.success = False
        sol.message = f"certificate failed: {cert.describe_failures()} (Newton: {sol.message})"
    elif not cert.passed:
        sol.message = f"{sol.message}; certificate failed: {cert.describe_failures()}"
    if sol.success and cert.warnings:
        sol.message = f"{sol.message}; warning: {cert.describe_warnings()}"
    if "model_substitution" in cert:  # named whenever a law is substituted, whatever its estimated effect
        c = cert["model_substitution"]
        est = "not estimated" if c.value is None else f"estimated relative amplitude error {c.value:.3g}"
        sol.message = f"{sol.message}; model substitution: {c.note} ({est})"
    return cert


def reword_warnings(sol, before):
    """After checks were added to ``sol.certificate``: replace its warnings ``before`` (as
    :meth:`Certificate.describe_warnings` worded them when they went into ``sol.message``) by the current ones,
    named only on a success."""
    if before:
        sol.message = sol.message.replace(f"; warning: {before}", "")
    now = sol.certificate.describe_warnings()
    if sol.success and now:
        sol.message = f"{sol.message}; warning: {now}"
