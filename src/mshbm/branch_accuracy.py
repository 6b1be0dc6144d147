"""The accuracy of a branch's points: the error estimates of :func:`mshbm.solve` on every point of a sweep.

Every point of :func:`mshbm.sweep` (and :func:`mshbm.continue_forcing`, :func:`mshbm.parameter.continue_parameter`)
is certified by the rules of :func:`mshbm.solve`: its certificate of the discretised equations
(:func:`mshbm.certificate.certify`, at the corrector), then the estimates of the relative amplitude error
``e = max_i |A_i - A_i^exact| / max_i A_i`` of every approximation (:mod:`mshbm.certificate.combined`:
``truncation``, ``time_discretisation``, ``regularisation``, ``model_substitution``, ``reduction``) and the
gating check ``accuracy``, their sum against the requested accuracy or, without one,
:data:`mshbm.certificate.combined.DEFAULT_ACCURACY` (1 %).  A point whose sum exceeds it (or whose estimate
could not be made) is *not certified*: the sweep keeps going, the point says so (``certificate["passed"]``
false, ``certificate["failed"] == ["accuracy"]``, ``certificate["accuracy"]``), and so do the branch's
``success`` (false), ``message`` and ``accuracy`` summary.

Cost, and the rule that keeps it affordable.  An estimate is what :mod:`mshbm.route.refine` computes for a solve:
re-solves of the point at ``2 n_h`` (``truncation``) and ``N / 2`` steps (``time_discretisation``), from the
point itself, and for HBM one re-solve with stiffer laws (``regularisation``, :mod:`mshbm.methods.hbm_regularisation`);
``model_substitution`` (two exact event-driven periodic solves, :mod:`mshbm.certificate.substitution`) at the
estimated points too (a sweep's points are certified without it), ``reduction`` (a Craig-Bampton case of the CLI,
:meth:`mshbm.reduction.ReducedModel.error_estimate`) at the estimated points.  These re-solves cost one to a few
corrector solves each, more than the point itself at ``2 n_h``, so they are made at the *estimated points*:

* the first and the last point, every ``estimate_every``-th point (option, default :data:`EVERY`; 1: every
  point), the points at each located fold, grazing or other bifurcation (index and the next one), and the local
  maxima of ``max_i A_i`` (resonance peaks, where the truncation and regularisation errors are largest);
* then, recursively, the middle point between two neighbouring estimated points whose verdicts differ (one
  within the accuracy, the other not, or one not estimated), so that the boundary between certified and
  uncertified points is located to a point.

Every other point gets, per estimate, the **larger** of the values at the two neighbouring estimated points
(a point without a value at either neighbour: not estimated); where those larger values, taken from two
different points, sum above the accuracy although both neighbours are certified, the point is estimated by its
own re-solve (on examples/impact5.yaml, MS-HBM at 2048 steps, omega = 0.660: truncation 5.1e-3 from one neighbour
and time_discretisation 5.4e-3 from the other; its own estimate 7.4e-3, its error 5.8e-3).  This is exact where an estimate is monotone
between its neighbours, and the estimated points include the peaks and the bifurcations where estimates turn;
the note of every interpolated estimate names its two points, and ``certificate["accuracy"]["estimated"]`` is
``"re-solve"`` or ``"interpolated"``.  The default stride is :data:`EVERY`, widened (at most to ``P // 6``)
when the estimates cost more than :data:`BUDGET` times the stride's points' tracing: their cost is the mean over
the anchors of stride ``P // 6`` (estimated first; the first point alone, before a contact closes, costs nothing
and set the stride to 4 on a 2-DOF chain whose impacting points' re-solves cost 500 times more: 379 points,
estimates far beyond the trace's time).  Measured on
the examples (README, "Frequency-response curves"; CPU time): +13 % (friction3, MS-HBM), +30 % (impact5,
Moreau-Jean shooting), about +100 % (a reduced FE beam, with ``reduction``), +160 % (damper2d, HBM, whose many
alternating verdicts are bisected); ``estimate_every=1`` +45 % to +380 %.  Why not a second branch at ``2 n_h``
or ``N / 2`` predicted from the first: its points would sit at other parameter values (the arclength steps
differ), and on impacting and stick-slip orbits the estimates vary irregularly from point to point, so each
estimate must be the same re-solve from the point that :func:`mshbm.solve` makes; the stride only decides
where.  The interpolation follows smooth estimates closely but can miss an isolated larger one between two
estimated points (measured: a truncation estimate of 2.7 % between points estimated below 1 %).

Option ``accuracy`` (API; ``--accuracy`` of ``mshbm sweep``): the same meaning as for :func:`mshbm.solve` -- the
method refines its discretisation until the combined estimate of every point is below it.  A branch is traced
at one discretisation, so the refinement is of the whole branch: while some point fails on ``accuracy`` only,
the sweep is traced again with the discretisation of the largest estimate among the failing points refined
(``harmonics`` doubled for ``truncation``, ``steps`` doubled for ``time_discretisation``), at most
:data:`MAX_LEVELS` levels and within ``max_time``; another largest estimate, or the last level, stops it and the
points that still fail are reported (``Branch.accuracy["levels"]``).  ``accuracy=False`` skips the estimates
(as for :func:`mshbm.solve`: the points are then certified for their discretised equations only, and say so).

Element outputs: every point's solution gets ``elements`` (:func:`mshbm.element_outputs.element_outputs`, a pass
over the grid, a few per cent of a point's cost); the JSON of a point holds their scalar summaries.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from .certificate.combined import DEFAULT_ACCURACY, REMEDY, combined_check, estimates, gate
from .certificate.record import Certificate, Check
from .certificate.substitution import model_substitution_check, substituted_laws
from .errors import InputError
from .interrupt import SweepInterrupted
from .options import check_accuracy
from .methods.hbm_regularisation import REGULARISATION_BOUND, regularisation_check, regularised
from .route.refine import _Estimator
from .route.refine import MAX_HARMONICS, MAX_STEPS
from .solvers.newton import work_box

__all__ = ["EVERY", "MAX_LEVELS", "check_options", "certify_points", "refined_options", "add_reduction",
           "skipped"]

#: default (smallest) stride of the estimated points
EVERY = 4
#: the estimates' share of a sweep's time that sets the default stride (:func:`_stride`)
BUDGET = 0.5
#: most refinement levels of a branch traced to a requested accuracy
MAX_LEVELS = 3
#: the estimates computed at the estimated points and interpolated between them (the re-solves; ``_INTERPOLATED``
#: adds ``model_substitution``: the exact orbits of the system as written and with the substituted law)
_OWN = ("truncation", "time_discretisation", "regularisation", "reduction")
_INTERPOLATED = _OWN + ("model_substitution",)
_RULE = ("estimated by re-solves at the first and last points, every {every}-th point, the bifurcations, the "
         "amplitude peaks and between neighbours whose verdicts differ; elsewhere, per estimate, the larger value "
         "of the two neighbouring estimated points (re-solved where those sum above the accuracy between two "
         "certified points)")


def check_options(accuracy, every):
    """``(accuracy or None or False, estimate_every)`` checked (:class:`InputError` naming the key)."""
    accuracy = check_accuracy(accuracy)
    if every is not None and (isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1):
        raise InputError("estimate_every", f"must be an integer >= 1, got {every!r}")
    return accuracy, None if every is None else int(every)


def _total(values):
    """Sum of ``{name: (value, note)}`` and whether every value is present."""
    vals = [v for v, _ in values.values()]
    if any(v is None for v in vals):
        return None
    return float(sum(vals))


class _Context:
    def __init__(self, route, tracer, method, options, acc, lams):
        self.route, self.tracer, self.method, self.acc = replace(route, estimate=False), tracer, method, acc
        self.options = options  # the problem's options (per base period) plus tol / max_iter / line_search
        self.lams = lams
        self.spent = 0.0

    def estimate(self, bp, lam):
        """``{name: (value, note)}`` of the re-solved estimates of point ``bp`` (module docstring)."""
        t = time.perf_counter()
        problem = self.tracer.problem(lam)
        sol = bp.solution
        est = _Estimator(self.route, problem.system, float(problem.omega), self.method, self.options, t, self.acc)
        values = est.own_estimates(sol)
        if problem.penalty_laws and regularised(problem.system):
            nkw = {k: self.options[k] for k in ("tol", "max_iter", "line_search") if k in self.options}
            nkw.setdefault("tol", self.tracer.tol)
            chk = regularisation_check(problem, sol, nkw, REGULARISATION_BOUND)
            sol.certificate.checks = [c for c in sol.certificate.checks if c.name != "regularisation"]
            values["regularisation"] = (chk.value, chk.note)
        if substituted_laws(problem):  # (the sweep's points leave this check of the certificate to here)
            tmp = Certificate()
            model_substitution_check(problem, sol, tmp)
            chk = next((c for c in tmp.checks if c.name == "model_substitution"), None)
            if chk is not None:
                sol.certificate.info.update(tmp.info)
                values["model_substitution"] = (chk.value, chk.note)
        self.spent += time.perf_counter() - t
        return values


def _verdict(values, cert, acc):
    """Within ``acc`` (True), not (False) or not estimated (None): the sum with the certificate's other
    estimates (``model_substitution``)."""
    total = _total(values)
    if total is None:
        return None
    other = sum(v for k, v in estimates(cert).items() if k not in values)
    return total + other <= acc


def _stride(branch, first_cost, every, trace_cost):
    """The stride of the estimated points: ``every`` when given, else :data:`EVERY` widened so that the
    estimates cost about :data:`BUDGET` times the trace (``first_cost``: the mean cost of the coarse anchors'
    estimates, :func:`certify_points`, against the trace's mean per point, ``trace_cost / P``), at most ``P // 6``
    (at least 6 estimated points).  Both costs are
    counts of Newton residual evaluations (:class:`mshbm.solvers.newton.Meter`), not wall times: the stride is the
    same on every machine, whatever its load.  (An evaluation of the estimates' finer re-solves costs 0.04-10 times
    one of the trace in wall time on the tests' sweeps, whose traces' wall times include the points' certificates
    and stability: unweighted; the stride was 4, :data:`EVERY`, by both rules on all of them.)"""
    if every is not None:
        return int(every)
    P = len(branch.points)
    per_point = float(trace_cost) / max(P, 1)
    need = math.ceil(first_cost / (BUDGET * per_point)) if per_point > 0 else EVERY
    return int(max(EVERY, min(need, P // 6)))


def _coarse_estimates(branch, ctx, every, lams, trace_cost):
    """``(found, stride)``: the estimates of the coarse anchors (:func:`_anchors` at stride ``P // 6``, at least
    :data:`EVERY`; only the first point when ``every`` is given) and the stride that their mean cost in Newton
    residual evaluations sets (:func:`_stride`).  The first point alone (often before the elements act, where the
    estimates cost nothing) set the stride to :data:`EVERY` on branches whose later points cost a hundred times
    more."""
    first = [0] if every is not None else _anchors(branch, max(EVERY, len(branch.points) // 6))
    found = {}
    with work_box() as meter:
        for i in first:
            found[i] = ctx.estimate(branch.points[i], lams[i])
    return found, _stride(branch, meter.used / len(first), every, trace_cost)


def _anchors(branch, every):
    """The first, the last and every ``every``-th point, the bifurcations (index and the next one) and the
    amplitude peaks (``max_i A_i`` largest within ``every`` points on either side)."""
    P = len(branch.points)
    idx = {0, P - 1} | set(range(0, P, every))
    for b in branch.bifurcations:
        i = b.get("index")
        if i is not None:
            idx |= {int(i), int(i) + 1}
    amax = np.array([float(np.max(p.amplitude, initial=0.0)) for p in branch.points])
    for i in range(1, P - 1):
        if amax[i] >= amax[max(0, i - every):i + every + 1].max():
            idx.add(i)
    return sorted(i for i in idx if 0 <= i < P)


def certify_points(branch, route, tracer, method, options, accuracy, every, lams, trace_cost=0):
    """The estimates and the check ``accuracy`` of every point of ``branch`` (module docstring), its element
    outputs, and the branch's ``accuracy`` summary; ``lams`` the continuation parameter of each point (the
    tracer's), ``options`` the problem's options, ``accuracy`` the request (``None``: the default gates),
    ``trace_cost`` the trace's Newton residual evaluations (for the stride, :func:`_stride`)."""
    requested = accuracy is not None
    acc = float(accuracy) if requested else DEFAULT_ACCURACY
    P = len(branch.points)
    ctx = _Context(route, tracer, method, options, acc, lams)
    t0, c0 = time.perf_counter(), time.process_time()
    found, every = _coarse_estimates(branch, ctx, every, lams, trace_cost) if P else ({}, every)
    todo = [i for i in _anchors(branch, every) if i not in found] if P else []
    while todo:
        for i in todo:
            found[i] = ctx.estimate(branch.points[i], lams[i])
        keys = sorted(found)
        todo = []
        for a, b in zip(keys[:-1], keys[1:]):
            if b - a > 1 and _verdict(found[a], branch.points[a].solution.certificate, acc) \
                    != _verdict(found[b], branch.points[b].solution.certificate, acc):
                todo.append((a + b) // 2)
    keys = sorted(found)
    bad, worst = [], (None, -1.0, None)
    for i, bp in enumerate(branch.points):
        sol = bp.solution
        if i in found:
            values, how, src = found[i], "re-solve", [i]
        else:
            a = max(k for k in keys if k < i)
            b = min(k for k in keys if k > i)
            values, how, src = {}, "interpolated", [a, b]
            for name in _INTERPOLATED:
                if name in found[a] or name in found[b]:
                    va, vb = found[a].get(name, (None, ""))[0], found[b].get(name, (None, ""))[0]
                    v = None if va is None or vb is None else max(va, vb)
                    values[name] = (v, f"interpolated: the larger of the estimates at points {a} and {b}"
                                       if v is not None else f"not estimated at point {a} or {b}")
            if _verdict(values, sol.certificate, acc) is False \
                    and _verdict(found[a], branch.points[a].solution.certificate, acc) \
                    and _verdict(found[b], branch.points[b].solution.certificate, acc):
                # the larger values of two certified points, each from another point, sum above the accuracy:
                # the bound is inconclusive, the point's own re-solve decides
                found[i] = ctx.estimate(bp, lams[i])
                values, how, src = found[i], "re-solve", [i]
        cert = sol.certificate
        for name, (value, note) in values.items():
            cert.checks = [c for c in cert.checks if c.name != name] + [
                Check(name, value, acc, bool(value is not None and value <= acc), False, note)]
        chk = combined_check(cert, acc, requested)
        gate(sol, chk)
        est = estimates(cert)
        bp.certificate = dict(bp.certificate, passed=bool(cert.passed), failed=list(cert.failed),
                              accuracy={"accuracy": acc, "requested": requested, "estimate": chk.value,
                                        "passed": bool(chk.passed), "estimates": est, "estimated": how,
                                        "points": src})
        if not chk.passed:
            bad.append(i)
        if chk.value is not None and chk.value > worst[1]:
            worst = (i, float(chk.value), max(est, key=est.get) if est else None)
    spent, cpu = time.perf_counter() - t0, time.process_time() - c0
    branch.accuracy = {"accuracy": acc, "requested": requested, "estimate_every": int(every or EVERY),
                       "rule": _RULE.format(every=every), "estimated_points": sorted(found),
                       "certified_points": P - len(bad), "uncertified_points": bad,
                       "largest": {"index": worst[0], "estimate": worst[1] if worst[0] is not None else None,
                                   "name": worst[2]},
                       "estimate_time_s": spent, "estimate_cpu_s": cpu, "reached_end": bool(branch.success)}
    if bad:
        _fail(branch, bad, worst, acc)
    return branch


def _fail(branch, bad, worst, acc):
    i, v, name = worst
    P = len(branch.points)
    over = [j for j in bad if (branch.points[j].certificate["accuracy"].get("estimate") or 0.0) > acc]
    where = f"omega = {branch.points[i].omega:.6g}" if branch.parameter == "omega" else f"point {i}"
    text = f"{len(bad)} of {P} points not certified: "
    parts = []
    if over:
        parts.append(f"{len(over)} with the combined error estimate above the accuracy {acc:g}"
                     + (f" (largest {v:.3g} at {where}, mostly {name}: {REMEDY[name]} reduce it)" if name else ""))
    if len(over) < len(bad):
        parts.append(f"{len(bad) - len(over)} without an estimate (a re-solve failed; see the points' "
                     "certificates)")
    branch.success = False
    text += "; ".join(parts)
    branch.message = f"{branch.message}; {text}" if branch.message else text


def skipped(branch, why):
    """The branch's ``accuracy`` summary when no estimate is made (``accuracy=False``, an interrupt)."""
    branch.accuracy = {"accuracy": None, "requested": False, "skipped": why,
                       "reached_end": bool(branch.success)}
    for bp in branch.points:
        bp.certificate = dict(bp.certificate, accuracy={"skipped": why})
    return branch


def refined_options(branch, options):
    """The options of the next level of a branch traced to a requested accuracy (module docstring), or
    ``(None, why)``."""
    acc = branch.accuracy
    bad = acc.get("uncertified_points") or []
    if not bad:
        return None, ""
    if any(branch.points[i].certificate.get("failed") != ["accuracy"] for i in bad):
        return None, "a point fails another check"
    worst = {}
    for i in bad:
        for k, v in branch.points[i].certificate["accuracy"]["estimates"].items():
            worst[k] = max(worst.get(k, 0.0), v)
    missing = [k for i in bad for k, c in ((c.name, c) for c in branch.points[i].solution.certificate.checks)
               if k in _OWN and c.value is None]
    kind = missing[0] if missing else (max(worst, key=worst.get) if worst else None)
    sol = branch.points[bad[0]].solution
    k = int(branch.period)
    if kind == "truncation":
        n = max(2 * (int(sol.harmonics) // k), int(sol.harmonics) // k + 2)
        if n * k > MAX_HARMONICS:
            return None, "truncation cannot be refined further"
        out = dict(options, harmonics=n)
        if "steps" in options:
            out["steps"] = max(int(options["steps"]), 2 * n + 2)
        return out, kind
    if kind == "time_discretisation":
        N = 2 * (int(sol.steps) // k)
        if N * k > MAX_STEPS:
            return None, "time_discretisation cannot be refined further"
        return dict(options, steps=N), kind
    return None, f"{kind} is not refined along a branch ({REMEDY.get(kind, '')})"


def add_reduction(branch, reduction):
    """Add the Craig-Bampton ``reduction`` estimate (:meth:`mshbm.reduction.ReducedModel.error_estimate`) to the
    points of ``branch`` (a sweep of the reduced model in omega, period 1) at its estimated points, interpolated
    by the rule of the module docstring, and re-gate ``accuracy``."""
    acc = branch.accuracy
    if not acc or acc.get("skipped") or not branch.points or branch.period != 1:
        return branch
    t0 = time.perf_counter()
    keys = acc["estimated_points"]
    found = {i: reduction.error_estimate(branch.points[i].solution) for i in keys}
    bound, requested = acc["accuracy"], acc["requested"]
    bad, worst = [], (None, -1.0, None)
    for i, bp in enumerate(branch.points):
        if i in found:
            value, note = found[i]
        else:
            a = max(k for k in keys if k < i)
            b = min(k for k in keys if k > i)
            value, note = max(found[a][0], found[b][0]), f"interpolated: the larger of the estimates at points {a} and {b}"
        cert = bp.solution.certificate
        cert.checks = [c for c in cert.checks if c.name != "reduction"] + [
            Check("reduction", value, bound, bool(value <= bound), False, note)]
        chk = combined_check(cert, bound, requested)
        if bp.solution.success or not chk.passed:
            gate(bp.solution, chk)
        est = estimates(cert)
        a = dict(bp.certificate["accuracy"], estimate=chk.value, passed=bool(chk.passed), estimates=est)
        bp.certificate = dict(bp.certificate, passed=bool(cert.passed), failed=list(cert.failed), accuracy=a)
        if not chk.passed:
            bad.append(i)
        if chk.value is not None and chk.value > worst[1]:
            worst = (i, float(chk.value), max(est, key=est.get) if est else None)
    acc.update(certified_points=len(branch.points) - len(bad), uncertified_points=bad,
               largest={"index": worst[0], "estimate": worst[1] if worst[0] is not None else None, "name": worst[2]},
               estimate_time_s=acc["estimate_time_s"] + time.perf_counter() - t0)
    if bad:
        base = branch.message.split("; ")
        branch.message = "; ".join(m for m in base if "points not certified" not in m)
        _fail(branch, bad, worst, bound)
    return branch


def to_accuracy(run, branch, options):
    """Trace the branch again, refined (:func:`refined_options`), while points fail a requested ``accuracy``
    (module docstring); ``run(options) -> Branch`` traces it.  Returns the last branch, with
    ``accuracy["levels"]``.  Interrupted while tracing a refined level, it raises the
    :class:`~mshbm.interrupt.SweepInterrupted` of the last complete level's branch (:func:`_interrupted_refinement`)."""
    if options.get("accuracy") in (None, False) or not branch.accuracy or branch.accuracy.get("skipped"):
        return branch
    t0 = time.perf_counter()
    max_time = options.get("max_time")
    levels = [_level(branch, options, None)]
    stop = ""
    while branch.accuracy.get("uncertified_points"):
        if len(levels) > MAX_LEVELS:
            stop = f"{MAX_LEVELS} refinements made"
            break
        if max_time is not None and time.perf_counter() - t0 + branch.wall_time >= float(max_time):
            stop = "time budget max_time spent"
            break
        nxt, kind = refined_options(branch, options)
        if nxt is None:
            stop = kind
            break
        try:
            new = run(nxt)
        except SweepInterrupted as exc:
            raise _interrupted_refinement(branch, exc, levels, kind) from exc
        new.wall_time += sum(lv["wall_time_s"] for lv in levels)
        options, branch = nxt, new
        levels.append(_level(branch, options, kind))
    branch.accuracy["levels"] = levels
    if stop:
        branch.message += f"; refinement stopped: {stop}"
    return branch


def _reach(branch):
    """How far ``branch`` got from its start in its parameter (0 without points)."""
    values = branch.omega if branch.parameter == "omega" else branch.load
    return abs(float(values[-1]) - float(values[0])) if len(branch.points) else 0.0


def _interrupted_refinement(branch, exc, levels, kind):
    """The :class:`SweepInterrupted` of a sweep interrupted while tracing a refined level: it carries the last
    complete level's ``branch`` (its points certified as far as that level's accuracy allows) unless the refined
    partial one got as far, so that an interrupt keeps the curve already traced."""
    partial = exc.branch
    if partial is not None and _reach(partial) >= _reach(branch):
        return exc
    branch.success = False
    branch.counters = dict(branch.counters or {}, interrupted=True)
    branch.accuracy["levels"] = levels
    branch.message += (f"; interrupted while tracing it again refined ({kind}) after {len(partial.points) if partial else 0} "
                       "points: this is the last complete level")
    return SweepInterrupted(branch, exc.cause)


def _level(branch, options, kind):
    sol = branch.points[0].solution if branch.points else None
    return {"harmonics": None if sol is None else int(sol.harmonics) // int(branch.period),
            "steps": None if sol is None else int(sol.steps) // int(branch.period), "refined": kind,
            "points": len(branch.points), "uncertified": len(branch.accuracy.get("uncertified_points") or []),
            "largest": (branch.accuracy.get("largest") or {}).get("estimate"), "wall_time_s": float(branch.wall_time)}
