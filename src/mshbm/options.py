"""The option registry: which solve options exist, which method accepts which, and their checks.

Every option of :func:`mshbm.solve` is validated here, once: :func:`check_options` is called by
:func:`mshbm.methods.registry.build_problem`, and the case-file reader (:mod:`mshbm.io`) takes its key
sets from :data:`METHODS` and :data:`COMMON`.  What differs between methods (their options, default
harmonics and steps) is read from the capability table :mod:`mshbm.methods.capabilities`, never from a
comparison of method names.

Options and their meaning
-------------------------
Common to all methods (:data:`COMMON`): ``guess``, ``tol``, ``max_iter``, ``line_search``,
``progress``, ``raise_on_failure``, ``continuation``, ``stability``, ``max_time``, ``accuracy`` (see
:func:`mshbm.solve`).

``accuracy`` (relative amplitude error, a number in (0, 0.5]; default ``None``): the method refines its
discretisation until the combined error estimate of the result is below it, or fails naming the estimate
(:mod:`mshbm.route.refine`); without it the default accuracy
:data:`mshbm.certificate.combined.DEFAULT_ACCURACY` (1e-2) gates ``success`` and nothing is refined.
``accuracy=False`` makes no estimates: ``success`` then certifies the discretised equations only (the
message says "accuracy not estimated"); for callers that measure the error themselves against exact
references, and for timing a discretisation (the paper's figure solves and work-precision benchmarks).

``max_time`` (s, default ``None``: no limit besides the start ladder's own budget) bounds the wall time of a
solve: no Newton iteration, start of the ladder or event-driven simulation begins after it, and the solve
then fails with a message that says so (the set-up and the last iteration under way are not interrupted).

``continuation`` (default True) switches on the fallbacks of the driver's strategy chain
(:mod:`mshbm.route.driver`) when Newton from the first start fails: with no guess, the start ladder
(:mod:`mshbm.route.starts`) for every method; with a guess, the method's own exact path follower
(HBM/DLFT penalty contact) and regularisation homotopy (HBM); for the mixed methods with a guess,
``continuation=True`` given *explicitly* also opts in to the restarts and continuation fallbacks of
:mod:`mshbm.route.continuation`.  ``continuation=False``: Newton from the one start only.

Per method (:data:`METHODS`): ``harmonics`` (n_h), ``steps`` (time steps or AFT samples per period,
:func:`default_steps`), ``theta`` (Moreau-Jean), ``jacobian`` (``"exact"`` or ``"fd"``), ``project``
(position projection of contacts), ``condense`` (HBM/DLFT: eliminate linear DOFs), ``partition``
(DOFs of the nonlinear/time-stepped subsystem), ``dlft_penalty`` (DLFT's ``eps``, N/m), ``dlft_predictor`` (DLFT's friction predictor,
``"velocity"`` or ``"displacement"``), ``integrator`` (shooting and both MS-HBM variants: ``"moreau"`` or ``"event"``),
``penalty_quadrature`` (HBM: the penalty contact law at the AFT samples, ``"samples"``, or integrated on the
linear interpolant of the gap, ``"linear"``, C^1 in the unknowns; :mod:`mshbm.methods.hbm`; default
``"samples"``, and ``"linear"`` in :func:`mshbm.sweep` with contacts).

Default integrator rule: ``"moreau"`` unless the user asks for ``"event"``.  The exact event-driven
flow (:mod:`mshbm.integrators.event`) removes the time-discretisation error (first order at impacts
and stick-slip for Moreau-Jean) and gives the exact saltation-corrected monodromy, but it supports
friction and contact between a DOF and the ground only (no relative or Jenkins elements), uses dense
matrices (small systems) and its cost grows with the number of events; Moreau-Jean handles every
element, any accumulation, and large subsystems.  Without ``integrator`` given, a solve whose start ladder found
no certified Moreau-Jean solution of a system with contacts ends by trying the event-driven flow
(:meth:`mshbm.route.driver.Route._event_fallback`; the result then says so in its message and
``info["integrator"] == "event"``); ``integrator="moreau"`` given explicitly keeps Moreau-Jean only.
"""
from __future__ import annotations

import math

import numpy as np

from . import stability as _stability
from .errors import InputError
from .methods.capabilities import CAPABILITIES, capabilities

__all__ = ["COMMON", "METHODS", "allowed", "check_options", "check_accuracy", "default_steps", "default_harmonics", "aft_steps"]

#: options of every method (driver and Newton options)
COMMON = frozenset({"guess", "tol", "max_iter", "line_search", "progress", "raise_on_failure", "continuation",
                    "stability", "max_time", "accuracy"})
#: options accepted by each method besides the common ones (from the capability table,
#: :data:`mshbm.methods.capabilities.CAPABILITIES`)
METHODS = {name: c.options for name, c in CAPABILITIES.items()}


def allowed(method):
    """All options ``method`` accepts (its own and the common ones)."""
    return METHODS[method] | COMMON


def aft_steps(n_h):
    """Default AFT samples per period of ``n_h`` harmonics: ``max(512, 16 (2 n_h + 1))`` rounded up to a
    power of two."""
    return 1 << max(9, math.ceil(math.log2(16 * (2 * n_h + 1))))


def default_steps(method, n_h):
    """Default time points per period: :func:`aft_steps` for the methods whose ``steps`` are AFT samples
    (HBM, DLFT), else 4096 time steps."""
    caps = CAPABILITIES.get(method)
    if caps is not None and caps.aft_samples:
        return aft_steps(n_h)
    return 4096


def default_harmonics(method):
    """``n_h`` of ``method`` when ``harmonics`` is not given."""
    return capabilities(method).default_harmonics


def _int_option(key, value, minimum):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise InputError(key, f"must be an integer, got {value!r}")
    if value < minimum:
        raise InputError(key, f"must be >= {minimum}, got {value}")
    return int(value)


def check_accuracy(value):
    """The validated ``accuracy`` option: ``None``, ``False`` (no estimates) or a float in (0, 0.5]."""
    if value is None or value is False:
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(float(value)) or not 0.0 < float(value) <= 0.5:
        raise InputError("accuracy", f"must be a relative amplitude error in (0, 0.5], got {value!r}")
    return float(value)


def check_options(method, options):
    caps = capabilities(method)
    allowed = caps.options | COMMON
    for key in options:
        if key not in allowed:
            raise InputError(key, f"unknown option for method {method!r} (allowed: {', '.join(sorted(allowed))})")
    opts = dict(options)
    n_h = _int_option("harmonics", opts.get("harmonics", caps.default_harmonics), 1)
    if n_h > 2000:
        raise InputError("harmonics", f"{n_h} harmonics is beyond what this solver supports (max 2000)")
    opts["harmonics"] = n_h
    steps = opts.get("steps", default_steps(method, n_h))
    min_steps = max(8, 2 * n_h + 2) if caps.harmonic_unknowns else 8
    steps = _int_option("steps", steps, min_steps)
    if steps > 1 << 24:
        raise InputError("steps", f"{steps} steps per period is beyond what this solver supports (max 2^24)")
    opts["steps"] = steps
    if "theta" in opts:
        th = opts["theta"]
        if isinstance(th, bool) or not isinstance(th, (int, float)) or not 0.5 <= float(th) <= 1.0:
            raise InputError("theta", f"must be a number in [0.5, 1], got {th!r}")
    if opts.get("jacobian", "exact") not in ("exact", "fd"):
        raise InputError("jacobian", f"must be 'exact' or 'fd', got {opts['jacobian']!r}")
    if opts.get("integrator", "moreau") not in ("moreau", "event"):
        raise InputError("integrator", f"must be 'moreau' or 'event', got {opts['integrator']!r}")
    if opts.get("accumulation", "moreau") not in ("moreau", "close"):
        raise InputError("accumulation", f"must be 'moreau' or 'close', got {opts['accumulation']!r}")
    if opts.get("accumulation", "moreau") == "close" and opts.get("integrator", "moreau") != "event":
        raise InputError("accumulation", "'close' (the Zeno closure of accumulating impacts) applies to "
                                         "integrator='event' only")
    if opts.get("impact_mass", "subsystem") not in ("subsystem", "effective"):
        raise InputError("impact_mass", f"must be 'subsystem' or 'effective', got {opts['impact_mass']!r}")
    if "tol" in opts:
        tol = opts["tol"]
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (0 < float(tol) < 1):
            raise InputError("tol", f"must be a number in (0, 1), got {tol!r}")
    for key in ("condense", "project", "line_search", "continuation", "raise_on_failure"):
        if key in opts and not isinstance(opts[key], (bool, np.bool_)):
            raise InputError(key, f"must be true or false, got {opts[key]!r}")
    if "progress" in opts and not (isinstance(opts["progress"], (bool, np.bool_)) or opts["progress"] == "always"):
        raise InputError("progress", f"must be true, false or 'always', got {opts['progress']!r}")
    if "max_iter" in opts:
        opts["max_iter"] = _int_option("max_iter", opts["max_iter"], 0)
    if opts.get("max_time") is not None:
        mt = opts["max_time"]
        if isinstance(mt, bool) or not isinstance(mt, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(mt)) or float(mt) <= 0.0:
            raise InputError("max_time", f"must be a finite number of seconds > 0, got {mt!r}")
        opts["max_time"] = float(mt)
    if opts.get("penalty_quadrature", "samples") not in ("samples", "linear"):
        raise InputError("penalty_quadrature", f"must be 'samples' or 'linear', got {opts['penalty_quadrature']!r}")
    if opts.get("dlft_penalty") is not None:
        ep = opts["dlft_penalty"]
        if isinstance(ep, bool) or not isinstance(ep, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(ep)) or not 0.0 < float(ep) <= 1e100:
            raise InputError("dlft_penalty", f"must be a finite number > 0 (N/m), got {ep!r}")
        opts["dlft_penalty"] = float(ep)
    if "dlft_predictor" in opts and opts["dlft_predictor"] not in ("velocity", "displacement"):
        raise InputError("dlft_predictor", f"must be 'velocity' or 'displacement', got {opts['dlft_predictor']!r}")
    opts["stability"] = _stability.check_option(opts.get("stability"))
    opts["accuracy"] = check_accuracy(opts.get("accuracy"))
    return opts


