"""The start-independent acceptance test of a Newton solution: its residual in physical units.

A start of the ladder (:mod:`mshbm.route.ladder`), or a stalled corrector of a branch
(:mod:`mshbm.branch`), gives unknowns ``x`` of a method's problem; this module says whether ``x`` is a
solution, before the certificate (:mod:`mshbm.certificate`) judges it.  The test takes plain values
(the problem, ``x``, whether Newton converged and after how many iterations) and returns a
:class:`Verdict`.

Notation as in the paper: ``M, C, K`` mass, damping and stiffness matrices, ``omega`` the forcing
frequency (rad/s), ``h = T / N`` the Moreau-Jean step, ``R(x)`` a method's residual with per-row units
``problem.residual_units()`` (0: displacement, m; 1: velocity, m/s; 2: force, N).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["Verdict", "ResidualTest", "load_scale", "displacement_scale", "impact_jump", "static_deflection"]


def load_scale(system):
    """Force scale (N) of the acceptance test: the largest forcing coefficient and element force bound
    ``mu F_N``.

    Not :func:`mshbm.scaling.force_scale` (the peak forcing on a DOF, which scales Newton's test): the
    acceptance bounds each row by the largest force anywhere in the system, elements' bounds included."""
    s = float(np.max(np.abs(system.f_hat), initial=0.0))
    for el in system.elements:
        if el.bounded:
            s = max(s, el.bound)
    return s if s > 0 else 1.0


def displacement_scale(system, omega):
    """Physical displacement scale (m): :func:`load_scale` over the largest diagonal stiffness
    (``omega^2`` times the largest mass if ``K`` vanishes), at least the largest gap."""
    diag = lambda A: np.abs(A.diagonal() if sp.issparse(A) else np.diag(np.asarray(A)))
    k = float(np.max(diag(system.K), initial=0.0))
    if k <= 0:
        k = float(omega) ** 2 * float(np.max(diag(system.M), initial=0.0))
    D = load_scale(system) / k if k > 0 else 1.0
    gaps = max([el.gap for el in system.elements if el.unilateral], default=0.0)
    return max(D, gaps)


def static_deflection(system):
    """``max |K^-1 f|`` (m) with ``f`` the forcing amplitude per DOF (``sum_k |f_hat_k|``); 0 if ``K`` is
    singular."""
    f = np.sum(np.abs(np.asarray(system.f_hat, dtype=float)), axis=0)
    try:
        if sp.issparse(system.K):
            x = spla.splu(sp.csc_matrix(system.K)).solve(f)
        else:
            x = np.linalg.solve(np.asarray(system.K, dtype=float), f)
    except (RuntimeError, np.linalg.LinAlgError):
        return 0.0
    d = float(np.max(np.abs(x), initial=0.0))
    return d if np.isfinite(d) else 0.0


def impact_jump(system, parts):
    """Largest velocity jump (m/s) at an impact of the solution, ``|P| ((M_TT)^-1)_dd`` over the contact elements
    with ``T = parts["time_dofs"]`` (all DOFs without it): ``|P| / M_dd`` for a diagonal mass, the whole
    structure's ``(M^-1)_dd`` for shooting; 0 without contacts); ``parts`` from ``problem.solution_parts``
    (``system``: the problem's ``integrated_system``)."""
    from ..methods.mass_coupling import impact_compliance

    P = parts.get("impulses")
    if P is None or not P.size:
        return 0.0
    minv = impact_compliance(system, parts.get("time_dofs"))
    J = 0.0
    for j, el in enumerate(system.elements):
        if el.unilateral and j < P.shape[1]:
            J = max(J, float(np.max(np.abs(P[:, j]), initial=0.0)) * minv[int(el.dof)])
    return J


@dataclass
class Verdict:
    """Outcome of :class:`ResidualTest`.

    Attributes
    ----------
    accepted : bool
    verdict : str
        Why, where the test says more than yes or no (a rejection by size, an acceptance to one step's
        accuracy); empty otherwise.
    step_accuracy : dict or None
        Set when a stalled Newton on an impacting orbit is accepted as periodic to one time step's
        accuracy: ``{"ratio": max_i |R_i| / bound_i, "bound": bound (ndarray, shape (n_x,)),
        "step_change": h J (m)}``; the certificate then judges the residual and the periodicity by that
        bound.
    """

    accepted: bool
    verdict: str = ""
    step_accuracy: dict = None


class ResidualTest:
    """The residual of ``problem`` in physical units, start-independent.

    ``test(x, converged, iterations, parts=None) -> Verdict``: the residual is re-evaluated at ``x``.
    Every entry is compared with a scale that depends neither on the start nor on the solution: forces
    (HBM; the harmonic block of ``mshbm-intermediate``) with ``F`` = :func:`load_scale` (forcing and
    ``mu F_N``), displacements with ``D`` = :func:`displacement_scale` (``F`` over the stiffness, or the
    gap), velocities with ``V = omega D``.  (A garbage answer at a resonance, amplitude 1e7 with
    ``||R|| = 500``, is rejected.)

    Accepted when

    * Newton converged and ``|R_i| <= rtol * scale_i`` for every entry; or
    * ``step_accuracy``, the method steps in time (shooting, MS-HBM), the solution has impacts,
      and Newton *stalled* (stopped before ``max_iter``: no descent), with every displacement entry
      ``|R_i| <= g h J`` and every velocity entry ``|R_i| <= g h omega J`` (force entries:
      ``rtol F``, plus ``2 g h J G_i`` where the force rows are driven by the Fourier coefficients of the
      time-stepped DOFs with the gain ``G_i`` of :meth:`PeriodicProblem.force_rows`, MS-HBM 3.3, whose
      displacement error ``S^-1 R_f`` must not exceed ``2 g h J`` either, and only where the step resolves
      the structure, ``omega_max h <= 1``), where ``J`` is the largest velocity jump at an impact
      (:func:`impact_jump`; more than ``20 V`` is an implausible, run-away orbit and rejected), and ``g = 1 +
      ||dR/dx||_2`` bounds the growth of a perturbation over the period (``||Phi||`` for
      shooting, ``dR/dx = Phi - I``).  That is the change of the periodicity residual when the
      impact moves by one time step: the Moreau-Jean map moves impacts by whole steps, so near
      such an orbit the discrete problem often has *no* exact root and Newton stalls at this level from
      any start, also from the exact event-driven orbit.  The time series is then periodic to one step's
      accuracy, and the verdict says so.  (Stick-slip switches are continuous in the velocity and make
      no such jump: friction-only systems need a converged Newton.)

    Rejected in any case: a solution larger than ``max_size * D`` (default 1e4 times the static
    scale).  Near an undamped resonance of the continuous system (no periodic solution) the
    time-stepping map, whose resonance is detuned by ``O((omega h)^2)``, has spurious periodic
    points of amplitude ``~ D / (omega h)^2`` that the residual cannot tell from solutions; the
    rejection is a clean failure, with a verdict saying why.
    """

    def __init__(self, problem, system, omega, rtol=1e-8, step_accuracy=True, max_iter=None, max_size=1e4):
        self.problem, self.system, self.omega = problem, system, float(omega)
        self.rtol, self.step_accuracy, self.max_iter, self.max_size = rtol, step_accuracy, max_iter, max_size
        self.F = load_scale(system)
        self.D = displacement_scale(system, omega)
        self.V = float(omega) * self.D
        self.units = problem.residual_units()
        self.scale = np.where(self.units == 0, self.D, np.where(self.units == 1, self.V, self.F))
        self.h = problem.time_step
        self._static = None
        self._fastest = None

    def static_scale(self):
        """The static deflection under the forcing amplitudes, ``max |K^-1 f|`` (computed once, only when
        a solution exceeds ``max_size D``: on finite-element models the largest diagonal stiffness is a
        local one, and ``F / K_ii`` underestimates the structure's compliance by orders of magnitude)."""
        if self._static is None:
            self._static = static_deflection(self.system)
        return self._static

    def fastest_mode(self):
        """Largest eigenfrequency (rad/s) of the structure ``(K, M)`` (``inf`` above 400 DOFs: not computed)."""
        if self._fastest is None:
            if self.system.n > 400:
                self._fastest = math.inf
            else:
                lam = sla.eigh(self.system.dense("K"), self.system.dense("M"), eigvals_only=True)
                self._fastest = math.sqrt(max(float(lam.max()), 0.0))
        return self._fastest

    def __call__(self, x, converged, iterations, parts=None):
        """The verdict on unknowns ``x`` (shape ``(n_x,)``) where Newton stopped, converged or not, after
        ``iterations``; ``parts``: ``problem.solution_parts(x)`` when already known, or a callable returning it
        (else computed here; either only when needed)."""
        problem, system, omega, rtol = self.problem, self.system, self.omega, self.rtol
        D, F, V, units, h = self.D, self.F, self.V, self.units, self.h
        R, _ = problem.residual(x, jac=False)
        if not np.all(np.isfinite(R)):
            return Verdict(False)
        if parts is None:
            parts = problem.solution_parts(x)
        elif callable(parts):
            parts = parts()
        size = max(float(np.max(np.abs(parts["q_time"]), initial=0.0)),
                   float(np.max(np.sum(np.abs(parts["q_hat"]), axis=0), initial=0.0)))
        max_size = self.max_size
        if not size <= max_size * D and not size <= max_size * self.static_scale():
            return Verdict(False, f"rejected: displacements up to {size:.3g}, more than {max_size:g} times the "
                                  f"static scale {max(D, self.static_scale()):.3g} (a spurious large orbit near an "
                                  "undamped resonance?)")
        if converged and np.all(np.abs(R) <= rtol * self.scale):
            return Verdict(True)
        Ds = self.static_scale()
        if converged and Ds > D and np.all(np.abs(R) <= rtol * np.where(
                units == 0, Ds, np.where(units == 1, float(omega) * Ds, F))):
            return Verdict(True)  # displacement rows in the structure's own scale (finite-element models)
        if not self.step_accuracy or h is None or (self.max_iter is not None and iterations >= self.max_iter):
            return Verdict(False)
        return self._one_step(x, R, parts)

    def _one_step(self, x, R, parts):
        """The one-step acceptance of a stalled Newton on an impacting orbit (class docstring)."""
        problem, system, omega, rtol = self.problem, self.system, self.omega, self.rtol
        F, V, units, h = self.F, self.V, self.units, self.h
        J = impact_jump(problem.integrated_system, parts)
        if not 0.0 < J <= 20.0 * V:  # no impact, or an implausible one (a run-away orbit)
            return Verdict(False)
        _, Jac = problem.residual(x, jac=True)
        Jac = Jac.toarray() if sp.issparse(Jac) else np.asarray(Jac)
        if not np.all(np.isfinite(Jac)):
            return Verdict(False)
        # bounds ||Phi|| = ||(Phi - I) + I|| (shooting); over the displacement and velocity rows only (MS-HBM 3.3: its
        # force rows, in N, would mix a stiffness into this dimensionless gain)
        gain = 1.0 + float(np.linalg.norm(Jac[units != 2], 2))
        bound = np.where(units == 2, rtol * F, gain * h * J * np.where(units == 0, 1.0, float(omega)))
        fr = problem.force_rows()
        if fr is not None and not self.fastest_mode() * h <= 1.0:
            return Verdict(False)  # the step does not resolve the structure: no one-step argument for the force rows
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
                return Verdict(False)
            if not np.all(np.isfinite(err)) or float(np.max(np.abs(err), initial=0.0)) > dq:
                return Verdict(False)
        if not np.all(np.abs(R) <= bound):
            return Verdict(False)
        k = int(np.argmax(np.abs(R) / bound))
        # step_change: the displacement change of one step at the impact, h J (m), without the gain g (the
        # certificate's step_accuracy_size compares it with the orbit's size)
        return Verdict(True, f"periodic to one time step's accuracy, not to Newton's tolerance: worst residual "
                             f"entry {abs(R[k]):.2e} <= {bound[k]:.2e}, the change when an impact (velocity jump "
                             f"{J:.3g}) moves by one step h = {h:.3g} s, amplified by at most {gain:.3g} over "
                             "the period; the Moreau-Jean map moves impacts by "
                             "whole steps and has no exact periodic point here",
                       {"ratio": float(np.max(np.abs(R) / bound)), "bound": bound, "step_change": float(h * J)})
