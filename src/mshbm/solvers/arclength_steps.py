"""Step control and the exact roots of natural-parameter steps of pseudo-arclength continuation
(:mod:`mshbm.solvers.arclength`).  Each function takes the run object of
:func:`mshbm.solvers.arclength.continuation` (``trace``: its settings, the branch so far, its evaluations).

* :func:`next_ds` -- the step after an accepted one: the corrector's effort, the tangent's turn, and whether the
  step was smooth (:func:`smooth_step`) and its tangent predicted the point (:func:`prediction_error`);
* :func:`exact_root` -- the exact root of the discretised equations near a point accepted at one time step's
  accuracy.

Notation as in :mod:`mshbm.solvers.arclength`.
"""
from __future__ import annotations

import numpy as np

from .newton import newton

__all__ = ["next_ds", "smooth_step", "prediction_error", "exact_root", "PREDICTED", "EXACT_REACH"]

#: the exact root that replaces a natural-parameter point accepted at step accuracy moves no unknown by more than
#: this (scaled by the solution's size, see :func:`exact_root`): the orbit the stalled iterate approximates
EXACT_REACH = 0.1
#: a smooth step whose predictor missed the corrected point by at most this times ``ds`` may let the step grow
#: (``continuation(predicted=...)``, used by :func:`mshbm.sweep`)
PREDICTED = 0.02
#: a step whose predictor missed the corrected point by at most ``max(ROUGH_PREDICTED ds, PREDICTED_ABS)`` (scaled)
#: is not shortened however slow its corrector, and one that missed by at most ``max(predicted ds, PREDICTED_ABS)``
#: grows (:func:`next_ds`): the tangent predicted the curve, so the corrector's iterations measure the conditioning
#: of the residual (e.g. a stiff regularised friction law, whose Newton needs as many iterations from 1e-4 away as
#: from 1e-2), not the step.  The absolute part: on a residual that is rough on a fine scale (HBM's samples entering
#: and leaving a stiff law's transition) the predictor misses by that roughness whatever the step, and a test
#: relative to ``ds`` alone would hold a short step short for ever
ROUGH_PREDICTED = 0.1
PREDICTED_ABS = 1e-3


def next_ds(trace, p, q, it, kink, smooth):
    """The step after the accepted step ``p -> q`` of ``ds``: grown by ``grow`` after a fast corrector (at most
    ``fast_iter`` iterations) or after a smooth step whose predictor missed ``q`` by at most ``predicted ds``
    (the tangent predicts the curve: the corrector's further iterations only meet ``tol``), shrunk by ``shrink``
    after a slow one (more than ``slow_iter``) -- unless the step was :func:`rough_predicted` and its predictor missed
    ``q`` by at most ``max(ROUGH_PREDICTED ds, PREDICTED_ABS)`` (then it is kept, and grown where it missed by at most
    ``max(predicted ds, PREDICTED_ABS)``, whatever the corrector's effort; with ``predicted`` set).  Growth is bounded by the turn of the tangent
    (``ds max_turn / turn``), and by ``ds_rough`` after a step that is not :func:`smooth_step`."""
    ds = trace.ds
    turn = None
    if trace.max_turn and p.stall is None and q.stall is None and kink is None:
        wq = np.asarray(trace.unknown_scale(q.x, q.lam), dtype=float)
        turn = float(np.arccos(np.clip(trace.scaled_t(q, wq) @ trace.scaled_t(p, wq), -1.0, 1.0)))
    pe = prediction_error(trace, p, q, ds) if trace.predicted is not None else np.inf
    # the tangent predicted the point: the corrector's effort says nothing about the step (see ROUGH_PREDICTED)
    predicted = rough_predicted(trace, p, q, kink) and pe <= max(ROUGH_PREDICTED * ds, PREDICTED_ABS)
    if predicted and pe <= max(trace.predicted * ds, PREDICTED_ABS):
        new = min(ds * trace.grow, trace.ds_max)
    elif it > trace.slow_iter and not predicted:
        new = max(ds * trace.shrink, trace.ds_min)
    elif it <= trace.fast_iter or (smooth and trace.predicted is not None and pe <= trace.predicted * ds):
        new = min(ds * trace.grow, trace.ds_max)
    else:
        new = ds
    if turn is not None and turn > 0.0:
        # the curve, not only the corrector, limits the step: no growth past a turn of max_turn per step
        # (never a shrink: the corrector's effort does)
        new = min(new, max(ds, ds * trace.max_turn / turn))
    if not smooth:
        new = min(new, max(trace.ds_rough, trace.ds_min))
    return new


def rough_predicted(trace, p, q, kink):
    """The step ``p -> q`` may grow by its prediction alone (:func:`next_ds`): both points solved exactly, no kink,
    no change of the free directions, a residual without smooth pieces (``segment`` None: a piecewise-smooth one
    keeps its cautious step, see :func:`smooth_step`), no failed step since ``p`` (``trace.clean_step``, set before
    ``q`` is added)."""
    same_free = (p.free is None) == (q.free is None) and (p.free is None or p.free.shape == q.free.shape)
    return (p.stall is None and q.stall is None and kink is None and p.segment is None and q.segment is None
            and same_free and trace.clean_step)


def prediction_error(trace, p, q, ds):
    """Scaled distance of ``q`` from the tangent predictor ``p + ds t_p``."""
    w = np.asarray(trace.unknown_scale(p.x, p.lam), dtype=float)
    moved = np.concatenate([(q.x - p.x) / w, [(q.lam - p.lam) / trace.lsc]])
    return float(np.linalg.norm(moved - ds * trace.scaled_t(p, w)))


def smooth_step(trace, p, q, it, kink):
    """The step from ``p`` to ``q`` (``it`` corrector iterations, ``kink``) was smooth: both points solved
    exactly, no kink, a residual without smooth pieces (``segment`` None), the same free directions, a corrector
    of at most ``slow_iter`` iterations, and no failed step since the last point; only then may ``ds`` exceed
    ``ds_rough``."""
    same_free = (p.free is None) == (q.free is None) and (p.free is None or p.free.shape == q.free.shape)
    # a piecewise-smooth residual (``segment`` known: an event-driven flow) keeps the cautious step throughout:
    # its pieces end at grazings and folds of impacting orbits that a long step would pass unseen
    return (p.stall is None and q.stall is None and kink is None and p.segment is None and q.segment is None
            and same_free
            and it <= trace.slow_iter and trace.counters["corrector_failures"] == trace.failures_at_point)


def exact_root(trace, x0, x_stall, lam, reach, free=None):
    """Where Newton at fixed ``lam`` from ``x0`` stalled at ``x_stall`` (an orbit accepted at one time step's
    accuracy: the discrete map moves impacts by whole steps), the exact root of the discretised equations near
    it: Newton with an Armijo line search (the exact solution's start of :func:`mshbm.solve`) from ``x_stall``
    and from ``x0``; kept when it converged and no unknown moved by more than ``reach`` (scaled, max norm) from
    ``x_stall``.  Returns the tuple of ``_Trace.newton_fixed`` (``stall`` None) or None.  A point accepted at step accuracy may lie off the exact
    root by several per cent of the amplitude (a natural-parameter step's points on the impact5 chain at
    2048 steps: 1.4-5.7 %); the certified pointwise solve finds the root."""
    if reach is None or free is not None:
        return None
    w = np.asarray(trace.unknown_scale(x_stall, lam), dtype=float)

    def fun(xx, jac=True):
        R, J = trace.ev.residual(xx, lam)
        return (R, J) if jac else (R, None)

    for start in (x_stall, x0):
        res = newton(fun, start, tol=trace.tol, max_iter=50, scale=lambda xx: trace.ev.residual_scale(xx, lam))
        if res.success and float(np.max(np.abs(res.x - x_stall) / w)) <= reach:
            R, s, r, J, g = trace.ev(res.x, lam)
            if r <= trace.tol:
                trace.counters["stall_solved"] = trace.counters.get("stall_solved", 0) + 1
                return res.x, res.nit, r, (R, s, J, g), None
    return None
