"""The registry of nonlinear-mode residuals: ``(method, integrator)`` -> the residual of
:mod:`mshbm.methods.modes_common`'s contract, and :func:`mode_problem`, the one place where a backbone's
residual is built.

Methods: ``"hbm"`` and ``"dlft"`` (EPMC by harmonic balance, :mod:`mshbm.methods.epmc`; no integrator),
``"shooting"`` (the exact event-driven flow, :mod:`mshbm.methods.modes`, or Moreau-Jean,
:mod:`mshbm.methods.modes_moreau`) and ``"mshbm"`` (MS-HBM with either, :mod:`mshbm.methods.modes_mixed`).
Default samples or steps per period (``n_h`` the harmonics): AFT samples :func:`mshbm.options.aft_steps` for
harmonic balance, :data:`~mshbm.methods.modes_common.SHOOTING_STEPS` output samples for the flow (MS-HBM:
at least ``4 n_h``), :data:`~mshbm.methods.modes_common.MOREAU_STEPS` Moreau-Jean steps.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..options import aft_steps
from .epmc import EPMCProblem
from .modes import ShootingModeProblem
from .modes_common import MOREAU_STEPS, SHOOTING_STEPS
from .modes_mixed import MixedModeProblem
from .modes_moreau import MoreauModeProblem

__all__ = ["MODE_METHODS", "mode_problem"]


def _integer(n_h):
    return isinstance(n_h, (int, np.integer)) and not isinstance(n_h, bool)


#: (method, integrator) -> (builder(system, mode, harmonics, steps), default steps(harmonics))
_MODES = {
    ("hbm", None): (lambda s, k, n_h, N: EPMCProblem(s, k, n_h, N, "hbm"),
                    lambda n_h: aft_steps(n_h) if _integer(n_h) else 0),
    ("dlft", None): (lambda s, k, n_h, N: EPMCProblem(s, k, n_h, N, "dlft"),
                     lambda n_h: aft_steps(n_h) if _integer(n_h) else 0),
    ("shooting", "event"): (ShootingModeProblem, lambda n_h: SHOOTING_STEPS),
    ("shooting", "moreau"): (MoreauModeProblem, lambda n_h: MOREAU_STEPS),
    ("mshbm", "event"): (MixedModeProblem, lambda n_h: max(SHOOTING_STEPS, 4 * n_h) if _integer(n_h) else 0),
    ("mshbm", "moreau"): (lambda s, k, n_h, N: MixedModeProblem(s, k, n_h, N, integrator="moreau"),
                          lambda n_h: MOREAU_STEPS),
}
#: the methods a backbone takes, in the order of the error messages
MODE_METHODS = ("hbm", "dlft", "shooting", "mshbm")
#: the methods that integrate in time (take ``integrator``; default: the exact event-driven flow)
_TIME_METHODS = tuple(m for m in MODE_METHODS if (m, "event") in _MODES)


def mode_problem(system, mode, method, harmonics, steps=None, integrator=None):
    """The mode residual of ``method`` and ``integrator`` (module docstring).

    Returns
    -------
    problem, steps : ModalParameter, int
        The residual and its samples (or steps) per period (``steps``, or the method's default).
    """
    if method not in MODE_METHODS:
        raise InputError("method", f"backbone supports {', '.join(MODE_METHODS)}, got {method!r}")
    if integrator is not None and integrator not in ("event", "moreau"):
        raise InputError("integrator", f"must be 'event' or 'moreau', got {integrator!r}")
    if integrator is not None and method not in _TIME_METHODS:
        raise InputError("integrator", f"only with method {' or '.join(repr(m) for m in _TIME_METHODS)} (got "
                         f"method {method!r}, which is harmonic balance)")
    key = (method, (integrator or "event") if method in _TIME_METHODS else None)
    build, default = _MODES[key]
    steps = default(harmonics) if steps is None else steps
    return build(system, mode, harmonics, steps), steps
