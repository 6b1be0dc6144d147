"""The problem a sweep continues (:mod:`mshbm.branch`): :class:`_Tracer` gives the continuation
(:func:`mshbm.solvers.arclength.continuation`) the method's residual ``R(x, lam)``, ``dR/dlam`` and the scales
(:func:`unknown_scale`) as functions of the parameter ``lam`` (the forcing frequency or a load factor), and
turns a corrected ``(x, lam)`` into a certified :class:`mshbm.branch_result.BranchPoint`.

Notation: ``n`` DOFs, ``x`` the unknowns of the method, ``omega`` the forcing frequency (rad/s), ``k`` the
period of ``kT``-periodic solutions.
"""
from __future__ import annotations

import time

import numpy as np

from . import stability as _stability
from .branch_result import BranchPoint
from .certificate import certify
from .element_outputs import element_outputs
from .hill import assess_hbm
from .methods.registry import build_problem
from .route.acceptance import ResidualTest
from .route.driver import assemble
from .scaling import displacement_floor

__all__ = ["unknown_scale", "scaled_forcing"]

def unknown_scale(problem, x):
    """Per-unknown scale of ``x`` (physical units of the unknowns: m for displacements and their
    coefficients, m/s for velocities), from the problem and the current solution.

    Shooting and MS-HBM: their ``residual_scale`` rows have the units of the unknowns (``D``, ``V``).
    MS-HBM (Section 3.3): its harmonic-balance rows are forces, their unknowns displacement
    coefficients (scale ``D``).  HBM: every unknown is a displacement coefficient, scale
    ``max(D_0, max |x|)`` (:func:`mshbm.scaling.displacement_floor` of the penalty problem).
    The problem's capabilities say which case applies (``penalty_laws``, ``force_row_unknowns``).
    """
    x = np.asarray(x, dtype=float)
    if problem.penalty_laws:
        if "_sweep_D0" not in problem.__dict__:
            problem._sweep_D0 = displacement_floor(problem.system, problem.omega, penalty=True)
        return np.full(x.size, max(problem._sweep_D0, float(np.max(np.abs(x), initial=0.0))))
    s = np.array(problem.residual_scale(x), dtype=float)
    a = problem.force_row_unknowns
    if a and a < s.size:
        s[:a] = s[a]
    return s


def scaled_forcing(system, load):
    """``system`` with ``f_hat`` times ``load`` (matrices and elements shared)."""
    return system.map_forcing(lambda f: f * float(load))


def _contact_info(system, sol):
    out = []
    lam = np.asarray(sol.lam, dtype=float)
    for j, el in enumerate(system.elements):
        force = lam[:, j] if lam.ndim == 2 and lam.shape[1] > j else np.zeros(1)
        rec = {"kind": el.kind, "dof": int(el.dof)}
        if el.kind == "contact":
            if el.relative_to is not None:  # g_N = gap + sign (q_I - q_J), on the samples
                D = sol.displacement([el.dof, el.relative_to])
                rec["min_gap"] = float(el.gap + np.min(el.sign * (D[:, 0] - D[:, 1])))
            else:
                q_max = sol.info.get("q_max")  # the exact flow's true extrema (samples miss the impact instants)
                q_top = float(q_max[el.dof]) if q_max is not None else float(np.max(sol.displacement([el.dof])[:, 0]))
                rec["min_gap"] = float(el.gap - q_top)
            margins = (sol.info.get("contact_margins") or {}).get(j)
            impacts = margins is not None and int(margins["impacts"]) > 0
            rec["active"] = bool(np.any(force > 0.0)) or rec["min_gap"] <= 0.0 or impacts
        else:
            info = sol.info.get("stability", {})
            stick = info.get("stick_fraction")
            rec["stick_fraction"] = None if stick is None else float(stick)
            rec["active"] = bool(el.acts)
        out.append(rec)
    return out


class _Tracer:
    """The method's problem as a function of the parameter (cached), and the point bookkeeping."""

    def __init__(self, system, method, options, parameter, omega_fixed=None, k=1, tol=1e-10, stability="auto"):
        self.build_problem = build_problem
        self.system, self.method, self.options, self.parameter = system, method, options, parameter
        self.omega_fixed, self.k, self.tol, self.stability = omega_fixed, k, tol, stability
        self.cache = {}
        self.stability_seed = None  # the last point assessed: starts the next one's exact orbit (stability.assess)
        self.substitution_estimate = True  # False: a substituted law is named, not estimated (accuracy=False)

    def problem(self, lam):
        lam = float(lam)
        p = self.cache.get(lam)
        if p is None:
            if len(self.cache) > 8:
                self.cache.pop(next(iter(self.cache)))
            if self.parameter == "omega":
                p = self.build_problem(self.system, lam / self.k, self.method, **self.options)[0]
            else:
                p = self.build_problem(scaled_forcing(self.system, lam), self.omega_fixed / self.k, self.method,
                                       **self.options)[0]
            self.cache[lam] = p
        return p

    def residual(self, x, lam):
        return self.problem(lam).residual(x, jac=True)

    def d_lam(self, x, lam):
        p = self.problem(lam)
        if self.parameter == "omega":  # d/domega = (1/k) d/d(omega / k)
            return np.asarray(p.omega_derivative(x), dtype=float) / self.k  # the problem contract's dR/domega
        d = 1e-6 * max(abs(lam), 1e-3)
        Rp = self.problem(lam + d).residual(x, jac=False)[0]
        Rm = self.problem(lam - d).residual(x, jac=False)[0]
        return (Rp - Rm) / (2 * d)

    def residual_scale(self, x, lam):
        return self.problem(lam).residual_scale(x)

    def unknown_scale(self, x, lam):
        return unknown_scale(self.problem(lam), x)

    def segment(self, x, lam):
        """The smooth piece of the residual at ``(x, lam)``: the event sequence of an event-driven flow
        (:meth:`PeriodicProblem.event_signature`), else ``None``."""
        return self.problem(lam).event_signature(np.asarray(x, dtype=float))

    def gauge(self, x, lam, F):
        """The member of a family of solutions at ``lam`` (free directions ``F``: a friction element stuck the whole
        period) that the method's rule picks (``family_gauge``: centred stick forces), or None."""
        rule = getattr(self.problem(lam), "family_gauge", None)
        return None if rule is None else rule(np.asarray(x, dtype=float), F)

    def restarts(self, x, lam):
        """Newton starts across a jump of the unknowns where an event crosses the section ``t = 0``
        (:meth:`PeriodicProblem.section_restarts`)."""
        return self.problem(lam).section_restarts(np.asarray(x, dtype=float))

    def stall_accept(self, x, lam):
        """A stalled corrector on an impacting orbit of a time-stepping method is accepted when periodic to
        one time step's accuracy (:class:`mshbm.route.acceptance.ResidualTest`, as :func:`mshbm.solve`'s
        start ladder does); returns the ``step_accuracy`` record for the certificate, else ``None``."""
        problem = self.problem(lam)
        if problem.penalty_laws:
            return None
        try:
            v = ResidualTest(problem, problem.system, problem.omega)(np.asarray(x, dtype=float), converged=False,
                                                                     iterations=0)
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            return None
        return v.step_accuracy if v.accepted and v.step_accuracy is not None else None

    def point(self, x, lam, iterations, residual, step_accuracy=None):
        """Certified :class:`BranchPoint` at ``(x, lam)``, or the reason (str) if the certificate fails."""
        t0 = time.perf_counter()
        problem = self.problem(lam)
        x = np.asarray(x, dtype=float)
        omega_b = problem.omega
        sol = assemble(problem, self.method, x, problem.solution_parts(x), success=True,
                       message="continuation corrector converged", iterations=int(iterations), nfev=0,
                       residual=float(residual), wall_time=0.0)
        # step_accuracy_size reported, not gating: along a branch of Moreau-Jean orbits h J / D exceeds its bound at
        # many one-step points that are the branch's, and gated the sweep would stall there
        # model_substitution (two exact periodic solves) is one of the point's error estimates (mshbm.branch_accuracy);
        # without estimates (accuracy=False) a substituted law is named, not estimated
        cert = certify(problem, sol, self.tol, step_accuracy, step_size_gating=False,
                       substitution="skip" if self.substitution_estimate else "name")
        sol.certificate = cert
        if not cert.passed:
            return f"certificate failed: {cert.describe_failures()}"
        system = problem.system
        if problem.penalty_laws and self.stability is not False \
                and not any(el.unilateral for el in system.elements):
            # Hill's method: stability of the regularised system HBM solves.  Not with penalty contacts: there its
            # truncated spectrum can give spurious multipliers outside the unit circle (a false Neimark-Sacker pair)
            assess_hbm(system, sol)
        else:
            _stability.assess(system, sol, self.stability, theta=self.options.get("theta", 0.5),
                              seed=self.stability_seed)
            self.stability_seed = sol
        sol.wall_time = time.perf_counter() - t0
        sol.elements = element_outputs(sol, system)
        omega = float(omega_b) * self.k
        sol.info["period"], sol.info["forcing_omega"] = self.k, omega
        if step_accuracy is not None:
            sol.info["step_accuracy"] = {"ratio": float(step_accuracy["ratio"]),
                                         "bound": np.asarray(step_accuracy["bound"], dtype=float)}
        return BranchPoint(omega=omega, load=float(lam) if self.parameter == "forcing" else 1.0,
                           amplitude=np.asarray(sol.amplitude, dtype=float), x=np.asarray(x, dtype=float),
                           q_hat=np.asarray(sol.q_hat, dtype=float), iterations=int(iterations),
                           residual=float(residual),
                           certificate={"passed": True, "failed": [],
                                        "checks": len([c for c in cert.checks if c.gating]),
                                        "step_accuracy": None if step_accuracy is None
                                        else float(step_accuracy["ratio"]),
                                        "step_accuracy_size": cert["step_accuracy_size"].value
                                        if "step_accuracy_size" in cert else None},
                           floquet_multipliers=np.asarray(sol.floquet_multipliers, dtype=complex),
                           stable=sol.stable, stability_method=sol.stability_method,
                           contact=_contact_info(system, sol), solution=sol)
