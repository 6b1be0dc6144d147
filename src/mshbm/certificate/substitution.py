"""The ``model_substitution`` check: the amplitude error caused by a contact law a method puts in place of the
one the user wrote (reported, not gating).

Which laws are substituted (read from the problem's declared representation, :mod:`mshbm.methods.base`)
---------------------------------------------------------------------------------------------------------
* ``lagrangian_contact`` (DLFT): the contact force is a Lagrange multiplier on the AFT samples of a truncated
  Fourier series, which has no velocity jumps and no impulses; Newton's impact law with restitution ``e_N`` is
  not represented.  The law DLFT converges to with ``n_h`` is the elastic one, ``e_N = 1`` (its contact force
  does no work over a period): a contact with ``e_N < 1`` is substituted by ``e_N = 1``.
* ``penalty_contact`` (HBM): the penalty law ``lambda_N = -(k_c g_N + d_c gamma_N)`` (eq. 45) in place of
  Newton's law.  Its restitution is that of the Kelvin-Voigt contact of the impulse direction's mass
  ``m = 1 / (w^T M^-1 w)``: ``e_p = exp(-pi z / sqrt(1 - z^2))``, ``z = d_c / (2 sqrt(k_c m))`` (``e_p = 0`` for
  ``z >= 1``; ``e_p = 1`` for ``d_c = 0``).  A contact with ``|e_p - e_N| > RESTITUTION_TOL`` is substituted
  by ``e_p``.  The finite ``k_c`` itself is a regularisation, not measured here.

* ``impact_masses()`` (MS-HBM with its default ``impact_mass="subsystem"`` on a consistent mass): the impact
  acts with the time-integrated subsystem's own mass ``M_NN`` instead of the effective mass ``1 / (w^T M^-1 w)``
  the whole structure implies (:mod:`mshbm.methods.mass_coupling`); named, its effect not estimated here (value
  ``None``) where the contact opens and closes: :func:`mshbm.solve` estimates it (:mod:`mshbm.route.refine`:
  the amplitude change against the re-solve with ``impact_mass="effective"`` and the event-driven flow), and
  without that estimate the combined check ``accuracy`` fails.

Otherwise the time-stepping methods (shooting, MS-HBM: Moreau-Jean or the event-driven flow) represent Newton's
law with ``e_N`` and substitute nothing.

What is measured
----------------
The exact event-driven periodic orbits (:func:`mshbm.methods.exact.exact_periodic`, started from the reported
solution) of the system as written and of the system with the substituted restitutions; the value is
``max_j |A_j(e_N) - A_j(e_sub)| / max_j A_j(e_N)`` over the DOFs ``j`` (``A`` = (max - min) / 2): the relative
amplitude change the substitution causes in the nonsmooth model itself, independent of the method's own
discretisation error (truncation, regularisation), which the other checks estimate.  ``info`` also holds the
distance of the reported amplitudes from the orbit of the system as written (the whole error of the answer).

Without any cost: a substituted contact whose reported force vanishes on every sample (never touched) or is
positive on every sample (persistent contact) has no impact, so its restitution plays no part (value 0).  Not
estimated (value ``None``, the note says why) where the exact flow does not apply (relative elements, friction
loaded by a contact, more than :data:`MAX_DOFS` DOFs: named only) or does not converge from the reported solution
(:data:`NOT_FOUND`: the combined ``accuracy`` check then fails, the error against the model as written unknown).

The bound :data:`MODEL_SUBSTITUTION_BOUND` is the default stated accuracy; the check never gates by itself (the
combined estimate does), and the message of a solution names the substitution whenever one is made.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .record import Check

__all__ = ["MODEL_SUBSTITUTION_BOUND", "RESTITUTION_TOL", "NOT_FOUND", "Substitution", "substituted_laws",
           "model_substitution_check", "describe_substitution"]

#: bound of ``model_substitution`` (relative amplitude error; the default stated accuracy)
MODEL_SUBSTITUTION_BOUND = 1e-2
#: a penalty law whose restitution differs from ``e_N`` by more than this substitutes the law
RESTITUTION_TOL = 1e-3
#: largest system for which the exact orbits are computed (dense matrices, cost ~ n^3)
MAX_DOFS = 200
#: work budget of each exact periodic solve (the event-driven flow's deterministic count, flop equivalents, about a
#: nanosecond each: some 10-100 s of one core), not a wall-time limit: the check's outcome does not depend on the
#: machine's load
WORK_LIMIT = 3e10
#: Newton tolerance of the exact periodic solves for an orbit of unit scale (m, m/s); smaller orbits: relative
EXACT_TOL = 1e-11


@dataclass(frozen=True)
class Substitution:
    """One substituted contact law: element index ``element`` in ``system.elements``, the case-file ``key`` of
    the parameter that is not represented, the model's value ``model`` and the one in its place
    ``represented``, and ``law`` (what the method uses instead, in words)."""

    element: int
    key: str
    model: float
    represented: float
    law: str


def _contact_key(system, j):
    contacts = [i for i, el in enumerate(system.elements) if el.unilateral]
    return "contact.restitution" if len(contacts) == 1 else f"contact[{contacts.index(j)}].restitution"


def _penalty_restitution(system, el):
    """Restitution of the Kelvin-Voigt penalty contact of the impulse direction's mass (module docstring)."""
    if el.penalty_damping == 0.0:
        return 1.0
    from ..methods.mass_coupling import impact_compliance

    m = 1.0 / impact_compliance(system).of(el)
    z = el.penalty_damping / (2.0 * np.sqrt(el.penalty_stiffness * m))
    return 0.0 if z >= 1.0 else float(np.exp(-np.pi * z / np.sqrt(1.0 - z * z)))


def substituted_laws(problem):
    """The contact laws ``problem`` substitutes (module docstring), list of :class:`Substitution`."""
    system = problem.system
    out = []
    masses = {j: (m_model, m_used) for j, m_model, m_used in problem.impact_masses()}
    for j, el in enumerate(system.elements):
        if not el.unilateral:
            continue
        if problem.lagrangian_contact and el.restitution < 1.0:
            out.append(Substitution(j, _contact_key(system, j), el.restitution, 1.0,
                                    "the DLFT contact law (no impulses; elastic, e_N = 1)"))
        elif (j in masses):
            m_model, m_used = masses[j]
            out.append(Substitution(j, "impact_mass", m_model, m_used,
                                    "the impact acts with the time-integrated subsystem's own mass M_NN, not with "
                                    "the structure's effective mass 1/(w^T M^-1 w) (a consistent mass couples the "
                                    "DOFs; impact_mass: effective represents it)"))
        elif problem.penalty_contact:
            e_p = _penalty_restitution(system, el)
            if abs(e_p - el.restitution) > RESTITUTION_TOL:
                out.append(Substitution(j, _contact_key(system, j), el.restitution, e_p,
                                        f"the penalty law (k_c, d_c: restitution {e_p:.3g})"))
    return out


#: ``info["value_basis"]`` of MS-HBM's subsystem impact law before the solve route estimates it (mshbm.route.refine)
IMPACT_MASS_PENDING = "impact mass: not estimated"
#: ``info["value_basis"]`` where the exact flow applies but its periodic orbit was not found (the combined ``accuracy``
#: check fails: the effect of the substitution is not known; "not applicable" systems are only named)
NOT_FOUND = "exact orbit not found"


def describe_substitution(subs):
    """The substitutions in words, e.g. ``"contact.restitution = 0.5 replaced by 1 (the DLFT contact law ...)"``."""
    return "; ".join(f"{s.key if s.key != 'impact_mass' else f'impact mass of element {s.element}'} = "
                     f"{s.model:.4g} replaced by {s.represented:.4g} ({s.law})" for s in subs)


def model_substitution_check(problem, sol, cert, estimate=True):
    """Append ``model_substitution`` (module docstring) when ``problem`` substitutes a law; details in
    ``cert.info["model_substitution"]``.  ``estimate=False`` (the points of a sweep without error estimates,
    ``accuracy=False``): the substitution is named, its effect (two exact periodic solves) not estimated."""
    subs = substituted_laws(problem)
    if not subs:
        return
    system = problem.system
    what = describe_substitution(subs)
    info = {"substitutions": [s.__dict__.copy() for s in subs], "described": what}
    cert.info["model_substitution"] = info
    lam = np.asarray(sol.lam)[:-1]
    # an impact: a contact that opens and closes on the grid, or an impulse (time-stepping methods: the event
    # flow's impacts carry no force on the grid)
    imp = None if getattr(sol, "impulses", None) is None else np.asarray(sol.impulses)
    involved = [s for s in subs if 0 < int(np.count_nonzero(lam[:, s.element] > 0.0)) < lam.shape[0]
                or (imp is not None and imp.ndim == 2 and bool(np.any(imp[:, s.element] > 0.0)))]
    if not involved:
        note = (f"{what}: the contact never opens or never closes on the reported orbit (no impact), so the "
                f"restitution plays no part")
        cert.checks.append(Check("model_substitution", 0.0, MODEL_SUBSTITUTION_BOUND, True, False, note))
        info["value_basis"] = "no impact"
        return
    if any(s.key == "impact_mass" for s in involved):
        # estimated by the solve route (mshbm.route.refine: the re-solve with the effective impact mass); until
        # then (certify alone, a sweep's points) not estimated
        note = (f"{what}: its effect on the amplitudes was not estimated (compare the exact event-driven orbit: "
                f"method 'shooting' with integrator 'event')")
        cert.checks.append(Check("model_substitution", None, MODEL_SUBSTITUTION_BOUND, False, False, note))
        info["value_basis"] = IMPACT_MASS_PENDING
        return
    if not estimate:
        note = f"{what}: its effect on the amplitudes was not estimated (no error estimates requested)"
        cert.checks.append(Check("model_substitution", None, MODEL_SUBSTITUTION_BOUND, False, False, note))
        info["value_basis"] = "not requested"
        return
    value, why = _exact_change(system, sol, involved, info)
    if value is None:
        note = f"{what}: its effect on the amplitudes was not estimated ({why})"
        if info.get("value_basis") is None:  # the exact flow applies but found no orbit: the accuracy is not known
            info["value_basis"] = NOT_FOUND
        cert.checks.append(Check("model_substitution", None, MODEL_SUBSTITUTION_BOUND, False, False, note))
        return
    note = (f"{what}: relative amplitude change of the exact event-driven orbit when e_N is replaced so (max over "
            f"the DOFs, relative to the largest amplitude); the reported amplitudes are "
            f"{info['answer_distance']:.3g} from the exact orbit of the system as written")
    cert.checks.append(Check("model_substitution", value, MODEL_SUBSTITUTION_BOUND,
                             bool(value <= MODEL_SUBSTITUTION_BOUND), False, note))


def _exact_change(system, sol, subs, info):
    """``(value, reason)``: the relative amplitude change between the exact orbits (module docstring)."""
    from ..errors import InputError
    from ..integrators.event import EventError
    from ..methods.exact import exact_periodic

    if system.n > MAX_DOFS:
        info["value_basis"] = "not applicable"
        return None, f"{system.n} DOFs > {MAX_DOFS}: the exact flow's dense matrices are too costly"
    els = list(system.elements)
    for s in subs:
        els[s.element] = replace(els[s.element], restitution=s.represented)
    substituted = system.with_elements(els)
    # Newton's tolerance on the state (q, u) relative to the orbit's scale, never looser than the absolute default:
    # with amplitudes of 1e-11 m an absolute 1e-11 accepts the start (the reported solution) for both systems,
    # and the change would read 0
    amp = np.asarray(sol.amplitude, dtype=float)
    S = float(np.max(np.abs(amp), initial=0.0)) * max(1.0, float(sol.omega))
    tol = EXACT_TOL * min(1.0, S) if np.isfinite(S) and S > 0 else EXACT_TOL
    amps = []
    for sysx, name in ((system, "as written"), (substituted, "with the substituted restitution")):
        try:
            ex = exact_periodic(sysx, sol.omega, guess=sol, samples=1024, blas_threads=None, work_limit=WORK_LIMIT,
                                tol=max(tol, 1e-300))
        except InputError as exc:  # the exact flow does not apply (relative elements, friction loaded by a contact)
            info["value_basis"] = "not applicable"
            return None, f"the exact flow of the system {name} failed: {type(exc).__name__}: {exc}"
        except (EventError, ValueError, np.linalg.LinAlgError) as exc:
            return None, f"the exact flow of the system {name} failed: {type(exc).__name__}: {exc}"
        if not ex.success:
            return None, f"the exact periodic orbit of the system {name} was not found: {ex.message}"
        amps.append(np.asarray(ex.info["amplitude_exact"], dtype=float))
    a_model, a_sub = amps
    scale = max(float(np.max(a_model)), 1e-300)
    value = float(np.max(np.abs(a_model - a_sub))) / scale
    info.update(value_basis="exact orbits", amplitude_model=[float(a) for a in a_model],
                amplitude_substituted=[float(a) for a in a_sub],
                answer_distance=float(np.max(np.abs(np.asarray(sol.amplitude, dtype=float) - a_model))) / scale)
    return value, ""
