"""The accuracy checks of a certificate: ``residual``, ``periodicity`` and ``step_accuracy_size``.

``residual`` (gating)
    The method's residual re-evaluated at the returned unknowns, row-scaled by the problem's
    ``residual_scale`` (forces by ``F``, displacements by ``D``); bound: the Newton tolerance ``tol``.
``periodicity`` (gating)
    ``max(|q(T) - q(0)| / D, |u(T) - u(0)| / V)`` of the time series of the DOFs that are integrated in time
    (DOFs given by Fourier series are periodic by construction).  Bound: one step's accuracy ``(omega h)^2``
    (the relative local error of a step of the second-order Moreau-Jean scheme is of this order), at least
    ``tol``.
``step_accuracy_size`` (gating in :func:`mshbm.solve`; reported on branch points)
    Only for an orbit that the start ladder accepted as periodic to one time step's accuracy
    (:func:`mshbm.route.ladder.residual_accept`: a stalled Newton on an impacting orbit, whose residual and
    periodicity are then judged against the jump of the residual when an impact moves by one step).  The
    displacement change of one step at an impact, ``h J`` (``J`` the largest velocity jump), relative to the
    displacement scale ``D`` of the solution; bound :data:`STEP_ACCURACY_SIZE_BOUND`.  A stalled Newton
    accepted at one step's accuracy is no answer when one step is not small against the orbit.  The measure
    is conservative, not sharp: it also refuses some accurate answers, which :func:`mshbm.solve` then hands
    to the exact event-driven integrator for systems with contacts (``info["event_fallback"]``).  It is not
    the amplified bound ``g h J`` of the acceptance, whose gain ``g = 1 + ||dR/dx||`` can be large on
    finite-element models whose answers are accurate.  On the points of :func:`mshbm.sweep` the check is
    reported, not gating: a branch is followed continuously from certified points.
"""
from __future__ import annotations

import numpy as np

from ..solvers.newton import scaled_norm
from .record import Check

__all__ = ["STEP_ACCURACY_NOTE", "STEP_ACCURACY_SIZE_BOUND", "STEP_ACCURACY_SIZE_NOTE", "residual_check",
           "periodicity_check", "step_accuracy_size_check"]

#: note of the residual and periodicity checks of an orbit accepted as periodic to one step's accuracy
STEP_ACCURACY_NOTE = ("periodic to one time step's accuracy: the Moreau-Jean map moves impacts by whole steps and "
                      "has no exact periodic point here; bound per entry: the jump of the residual when an impact "
                      "moves by one step (mshbm.route.ladder.residual_accept)")


#: gating bound of ``step_accuracy_size``
STEP_ACCURACY_SIZE_BOUND = 2e-3
STEP_ACCURACY_SIZE_NOTE = ("the displacement change of one step at an impact, h J, relative to the orbit's "
                           "displacement scale D: a stalled Newton accepted as periodic to one step's accuracy "
                           "is no answer when one step is not small against the orbit")



def residual_check(problem, x, R, tol, step_accuracy, cert):
    """Append ``residual`` (module docstring) for the residual ``R`` at the unknowns ``x``; returns the
    per-row one-step bound of ``step_accuracy`` (:func:`mshbm.certificate.certify`) when it applies (a
    time series of the right shape), else ``None``."""
    step_bound = None if step_accuracy is None else np.asarray(step_accuracy["bound"], dtype=float)
    if step_bound is not None and step_bound.shape == R.shape and not problem.fourier_all_dofs:
        r = float(np.max(np.abs(R) / step_bound))
        cert.checks.append(Check("residual", r, 1.0, bool(np.isfinite(r) and r <= 1.0), True,
                                 STEP_ACCURACY_NOTE))
    else:
        step_bound = None
        r = scaled_norm(R, problem.residual_scale(x))
        cert.checks.append(Check("residual", r, tol, bool(np.isfinite(r) and r <= tol)))
    return step_bound


def periodicity_check(problem, sol, omega, h, tol, D, V, step_bound, cert):
    """Append ``periodicity`` (module docstring): ``h`` the step (s), ``D``, ``V`` the displacement (m) and
    velocity (m/s) scales, ``step_bound`` from :func:`residual_check`."""
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


def step_accuracy_size_check(problem, step_accuracy, step_bound, D, step_size_gating, cert):
    """Append ``step_accuracy_size`` (module docstring) for an orbit accepted at one step's accuracy
    (``step_bound`` not ``None``)."""
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
