"""The method registry: name -> problem class, and :func:`build_problem`, the one place where a
problem is constructed from validated options (:mod:`mshbm.options`).

Registering a method: its problem class (a :class:`mshbm.methods.base.PeriodicProblem`) in
:data:`PROBLEMS`, its options and the other declarations that the checks read before the problem exists in
:data:`mshbm.methods.capabilities.CAPABILITIES` (re-exported here with :func:`capabilities`).
"""
from __future__ import annotations

import math

import numpy as np

from .. import options as options_
from .. import validate
from ..errors import InputError
from ..system import System
from .capabilities import CAPABILITIES, capabilities
from .dlft import DLFTProblem
from .hbm import HBMProblem
from .mixed import IntermediateProblem, MixedProblem, intermediate_problem
from .shooting import ShootingProblem

__all__ = ["PROBLEMS", "CAPABILITIES", "build_problem", "capabilities"]

#: problem class of each method
PROBLEMS = {"shooting": ShootingProblem, "hbm": HBMProblem, "mshbm": MixedProblem,
            "mshbm-intermediate": IntermediateProblem, "dlft": DLFTProblem}
#: what builds each method's problem: its class, but for mshbm-intermediate the function that returns the
#: standard MS-HBM when the default subsystem 2 is empty (:func:`mshbm.methods.mixed.intermediate_problem`)
_BUILDERS = {**PROBLEMS, "mshbm-intermediate": intermediate_problem}


def build_problem(system, omega, method="mshbm", **options):
    """Validated problem object of a method (exposes ``residual(x) -> (R, J)`` and the per-row scale
    ``residual_scale(x) -> s`` of Newton's test ``||R / s||_inf <= tol``, :mod:`mshbm.scaling`).

    Returns
    -------
    problem, solver_options : object, dict
        ``solver_options`` are the Newton and driver options not consumed by the problem.
    """
    if not isinstance(system, System):
        raise InputError("system", f"must be an mshbm.System, got {type(system).__name__}")
    if isinstance(omega, bool) or not isinstance(omega, (int, float, np.integer, np.floating)):
        raise InputError("omega", f"must be a number, got {omega!r}")
    if not math.isfinite(float(omega)) or float(omega) <= 0:
        raise InputError("omega", f"must be finite and > 0, got {omega}")
    if not 1e-100 <= float(omega) <= 1e100:
        raise InputError("omega", f"{float(omega):g} rad/s is outside the supported range [1e-100, 1e100] "
                                  "((k omega)^2 and (h theta)^2 would overflow)")
    system = system.at(float(omega))  # the forcing at omega (a constant forcing: the same system)
    opts = options_.check_options(method, options)
    solver_keys = options_.COMMON
    prob_opts = {k: v for k, v in opts.items() if k not in solver_keys and k in options_.METHODS[method]}
    if prob_opts.get("partition") is not None:
        prob_opts["partition"] = validate.check_partition(system, method, prob_opts["partition"])
    validate.check_inputs(system, float(omega), method, opts["harmonics"], opts["steps"], prob_opts.get("partition"))
    problem = _BUILDERS[method](system, float(omega), **prob_opts)
    problem.build_options = dict(prob_opts)
    return problem, {k: v for k, v in opts.items() if k in solver_keys}
