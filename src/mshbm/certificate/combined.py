"""The combined error estimate of a certificate and the accuracy that gates ``success``.

Every approximation between the user's nonsmooth system and the equations a method solves has its own check,
whose ``value`` is an estimate of the relative amplitude error it causes,
``max_i |A_i - A_i^exact| / max_i A_i^exact`` with ``A_i = (max - min) / 2`` of DOF ``i`` over one period:

* ``truncation`` -- the harmonic truncation at ``n_h`` (HBM, DLFT, MS-HBM);
* ``time_discretisation`` -- the Moreau-Jean steps (shooting, MS-HBM);
* ``regularisation`` -- the regularised laws of HBM (smoothing, penalty);
* ``model_substitution`` -- a law a method replaces by another one (DLFT's contact law for impacts with
  restitution);
* ``reduction`` -- a Craig-Bampton reduction of the model (:meth:`mshbm.reduction.ReducedModel.expand`, which
  re-gates ``accuracy`` with it).

The check ``accuracy`` (gating) is their sum (:data:`ESTIMATES` that are present), against the requested
``accuracy`` of :func:`mshbm.solve` or, without one, :data:`DEFAULT_ACCURACY`; its note names each estimate and
the largest one, so that a failure says which approximation could not be made accurate enough.  The solve
route (:mod:`mshbm.route.refine`) computes ``truncation`` and ``time_discretisation`` by re-solving on a
coarser discretisation and appends the ``accuracy`` check; :func:`mshbm.certify` alone does not.
"""
from __future__ import annotations

from .record import Check
from .substitution import IMPACT_MASS_PENDING, NOT_FOUND

__all__ = ["DEFAULT_ACCURACY", "ESTIMATES", "combined_check", "gate"]

#: accuracy (relative amplitude error) that gates ``success`` when :func:`mshbm.solve` is given no ``accuracy``
DEFAULT_ACCURACY = 1e-2
#: the checks whose values are estimates of the relative amplitude error, summed by :func:`combined_check`
ESTIMATES = ("truncation", "time_discretisation", "regularisation", "model_substitution", "reduction")
#: how each estimate is reduced (named in the message of a failed ``accuracy``)
REMEDY = {"truncation": "more harmonics (option harmonics)",
          "time_discretisation": "more time steps (option steps)",
          "regularisation": "a stiffer regularised law (smoothing, penalty_stiffness)",
          "model_substitution": "a method that represents the law (MS-HBM on a consistent mass: integrator "
                                "'event', whose impact_mass default is 'effective')",
          "reduction": "more modes (reduce.modes)"}


def estimates(cert):
    """``{name: value}`` of the estimates (:data:`ESTIMATES`) present in ``cert`` with a finite value."""
    out = {}
    for name in ESTIMATES:
        if name in cert and cert[name].value is not None:
            out[name] = float(cert[name].value)
    return out


def combined_check(cert, accuracy, requested):
    """Append (or replace) the gating check ``accuracy`` of ``cert``: the sum of its estimates against
    ``accuracy``; ``requested``: the bound is the caller's ``accuracy`` (else :data:`DEFAULT_ACCURACY`).
    Returns the check."""
    est = estimates(cert)
    total = float(sum(est.values()))
    parts = " + ".join(f"{k} {v:.2g}" for k, v in est.items()) or "no estimate"
    note = (f"combined estimate of the relative amplitude error: {parts}; "
            + ("requested accuracy" if requested else "default accuracy (option accuracy)"))
    if est and total > accuracy:
        worst = max(est, key=est.get)
        note += f"; largest: {worst} ({REMEDY[worst]} reduce it)"
    missing = [k for k in ("truncation", "time_discretisation") if k in cert and cert[k].value is None]
    # MS-HBM's subsystem impact law (the solve route estimates its effect, mshbm.route.refine) and a substituted law
    # whose exact orbit was not found: without that estimate a success could lie outside the accuracy
    basis = (cert.info.get("model_substitution") or {}).get("value_basis")
    if "model_substitution" in cert and cert["model_substitution"].value is None and basis in (IMPACT_MASS_PENDING,
                                                                                                 NOT_FOUND):
        missing.append("model_substitution")
    ok = total <= accuracy and not missing
    if missing:
        note += f"; not estimated: {', '.join(missing)}"
    chk = Check("accuracy", total, float(accuracy), bool(ok), True, note)
    cert.checks = [c for c in cert.checks if c.name != "accuracy"] + [chk]
    return chk


def gate(sol, check):
    """Gate ``sol.success`` on ``check`` (the ``accuracy`` check appended after the certificate was applied): a
    certified solution whose check failed is not a success, and its message names the check and its note."""
    if check.passed:
        return sol
    # the sum may be within the bound while an estimate is missing: then say so, not a false "value > bound"
    why = (f"{check.value:.3g} > bound {check.bound:.3g}" if check.value > check.bound
           else f"{check.value:.3g} <= bound {check.bound:.3g} without the missing estimates")
    if sol.success:
        sol.success = False
        sol.message = f"certificate failed: {check.name} ({why}: {check.note}) ({sol.message})"
    else:
        sol.message = f"{sol.message}; accuracy not established: {why} ({check.note})"
    return sol
