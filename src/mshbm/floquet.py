"""Floquet verdicts: how a solution's stability fields are set from its multipliers (used by
:mod:`mshbm.stability`, which computes them, and by :func:`mshbm.methods.exact.exact_periodic`, whose
Newton already holds the exact monodromy).  No solver imports here, so both can use it."""
from __future__ import annotations

import numpy as np

from .errors import InputError

__all__ = ["check_option", "set_exact", "EXACT", "EXACT_TOL", "STEP_MAP", "STEP_MAP_TOL", "REPORTED", "NEARBY"]

#: a verdict from the exact monodromy needs ``|max|mu| - 1| >`` this
EXACT_TOL = 1e-6
#: a verdict from the Moreau-Jean step map (smooth motion only) needs ``|max|mu| - 1| >`` this
STEP_MAP_TOL = 1e-3

EXACT = "exact-flow-saltation"
STEP_MAP = "moreau-step-map (estimate; verdict for smooth motion only)"


def check_option(value):
    """Validate the ``stability`` option: ``"auto"`` (default, also ``None``), ``True`` or ``False``."""
    if value is None or (isinstance(value, str) and value == "auto"):
        return "auto"
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise InputError("stability", f"must be true, false or 'auto', got {value!r}")


#: ``stability_orbit`` of multipliers of the reported orbit itself (its own monodromy, or Hill's / the step map's
#: linearisation about it)
REPORTED = "reported"
#: ``stability_orbit`` of multipliers of another orbit: the exact periodic orbit of the nonsmooth flow found from
#: the reported one (which is too far from any orbit of the flow to have multipliers of its own)
NEARBY = "nearby exact orbit"


def _set(sol, mult, stable, method, reason="", orbit=None, **details):
    mult = np.asarray(mult if mult is not None else [], dtype=complex).reshape(-1)
    sol.floquet_multipliers = mult
    sol.stable = stable
    sol.stability_method = method
    sol.stability_reason = reason
    sol.stability_orbit = (REPORTED if mult.size else "") if orbit is None else orbit
    details["orbit"] = sol.stability_orbit
    if mult.size:
        details.setdefault("max_modulus", float(np.max(np.abs(mult))))
    sol.info["stability"] = details
    return sol


def _verdict(rho, tol):
    if rho < 1.0 - tol:
        return True, ""
    if rho > 1.0 + tol:
        return False, ""
    return None, f"the largest multiplier modulus {rho:.9f} is within {tol:g} of 1 (marginal)"


def set_exact(sol):
    """Stability fields of a solution of :func:`mshbm.methods.exact.exact_periodic` from its own monodromy."""
    mult = sol.info.get("floquet_multipliers") if sol.success else None
    if mult is None:
        return _set(sol, None, None, "none: the exact solve did not converge", "no converged periodic orbit")
    stable, reason = _verdict(float(np.max(np.abs(mult))), EXACT_TOL)
    return _set(sol, mult, stable, EXACT, reason, tolerance=EXACT_TOL, orbit_distance=0.0)


