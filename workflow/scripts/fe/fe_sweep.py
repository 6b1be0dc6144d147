"""Frequency-response curve of the finite-element example (build_fe_model.py) with one method:
``mshbm.sweep`` from ``r0 w_1`` to ``r1 w_1`` (``w_1`` the first bending frequency of the model in
``modes.json``, next to the case file), timed, written as JSON.

The JSON holds what the figure and the paper need, not the branch's unknowns: ``method``, ``success``,
``message``, ``points``, ``omega`` (rad/s), ``amplitude`` (per named DOF, ``(max - min) / 2`` of each point,
m): ``tip`` (the node of the stop, the contact DOF), ``friction_node`` (the node of the friction joint) and,
with bodies (the older model), ``shoe`` and ``pad``; ``stable`` / ``stability_method`` per point,
``bifurcations``, ``counters``, ``wall_time_s`` and ``cpu_time_s`` (the whole sweep: start solve, continuation,
certificates, stability).

With a Craig-Bampton reduction in the case file (``reduce:``, build_fe_model.py ``--reduce``) the sweep
runs on the reduced model (:attr:`mshbm.io.case.Case.model`, boundary DOFs plus modal coordinates); the
named DOFs are element DOFs, hence boundary DOFs, and are read there
(:meth:`mshbm.reduction.ReducedModel.reduced_dof`).  ``reduction`` records the reduction
(:meth:`~mshbm.reduction.ReducedModel.as_dict`) and its error estimate at the sweep's first and last points.

Usage::

    python workflow/scripts/fe/fe_sweep.py CASE.yaml OUT.json --method mshbm --omega-ratio 0.9 1.1 \
        [--harmonics 5] [--steps 4096] [--max-points 60] [--ds-max 0.5] [--stability off|auto|on] \
        [--integrator moreau|event] [--accumulation moreau|close] [--penalty-quadrature samples|linear] \
        [--check-points K]

MS-HBM's curve uses the exact event-driven flow (``--integrator event --accumulation close``, config
``fe_example.sweep_options``): with Moreau-Jean steps its residual is a staircase in ``omega`` where the
stop impacts (impacts move by whole steps), points are accepted only at step accuracy, their tangents do not
predict, and the branch zigzags (measured on the 162-DOF plate with bodies: 75 points, never reaching the
end of the range).  ``failures`` lists the first reasons the corrector failed.

``--check-points K``: the last ``K`` points solved again by event-driven full shooting from the branch's
solution (``checks``; :func:`check_against_shooting`), an independent check of where the curve ends.

Stability (``--stability``, :func:`mshbm.stability.assess`): on the reduced model (10 DOFs) the exact
event-driven monodromy applies; on the full model with bodies it was a Moreau step-map estimate (~20 s per
point at 162 DOFs) and skipped above 400 DOFs (``stable = None``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

import mshbm
from mshbm.errors import InputError

METHODS = ("mshbm", "hbm", "dlft", "shooting")


def named_dofs(modes, reduction=None):
    """``{name: DOF}`` of the structure's tip, the friction node and (with bodies) the shoe and the pad; with
    ``reduction`` (a :class:`mshbm.reduction.ReducedModel`) the DOFs of the reduced model."""
    out = {}
    body = modes.get("bodies")
    if body:
        out["friction_node"], out["tip"] = (int(d) for d in body["nodes_dofs"])
        out["shoe"], out["pad"] = (int(d) for d in body["dofs"])
    else:
        out["friction_node"], out["tip"] = int(modes["friction"]["dof"]), int(modes["contact"]["dof"])
    if reduction is not None:
        out = {k: reduction.reduced_dof(d) for k, d in out.items()}
    return out


def _reduction_facts(rm, b):
    """The reduction and its error estimate (:meth:`~mshbm.reduction.ReducedModel.error_estimate`) at the
    branch's first and last points (relative error of the linear dynamics the elements see)."""
    out = rm.as_dict()
    pts = [p.solution for p in (b.points[:1] + b.points[-1:]) if p.solution is not None] if len(b) else []
    est = []
    for p in pts:
        try:
            est.append(float(rm.error_estimate(p)[0]))
        except Exception as exc:  # an estimate that cannot be formed is reported, not fatal for the curve
            est.append(None)
            out["error_estimate_failure"] = f"{type(exc).__name__}: {exc}"
    out["error_estimate_ends"] = est
    return out


def check_against_shooting(s, b, k, dofs, log=print):
    """The last ``k`` points of the branch ``b`` solved again by full shooting with the exact event-driven flow,
    started from the branch's solution: per point ``omega``, the branch's and shooting's amplitudes of the named
    DOFs (``(max - min) / 2``), shooting's success and CPU time.  An independent check of the branch's end against
    the nonsmooth model (only on small models: full shooting steps all DOFs)."""
    out = []
    for p in b.points[-k:] if k > 0 and len(b) else []:
        c0 = time.process_time()
        r = mshbm.solve(s, p.omega, "shooting", guess=p.solution, integrator="event", accumulation="close")
        cpu = time.process_time() - c0
        amp = lambda sol, d: float(np.ptp(sol.displacement([d])) / 2.0)
        row = {"omega": float(p.omega), "success": bool(r.success), "cpu_time_s": cpu,
               "branch": {n: amp(p.solution, d) for n, d in dofs.items()},
               "shooting": {n: amp(r, d) for n, d in dofs.items()}}
        out.append(row)
        log(f"check at {p.omega:.6g} rad/s: {row}")
    return out


def run(case_path, out, method, omega_ratio, harmonics=5, steps=None, max_points=60, ds_max=None, stability=False,
        log=print, integrator=None, accumulation=None, penalty_quadrature=None, check_points=0, estimates=True,
        grazings=None):
    if method not in METHODS:
        raise InputError("method", f"{method!r} is not one of {', '.join(METHODS)}")
    r0, r1 = (float(r) for r in omega_ratio)
    case = mshbm.load_case(case_path)
    s = case.model                          # the reduced model with reduce:, else the case's system
    rm = case.reduction
    modes = json.loads((Path(case_path).parent / "modes.json").read_text())
    w1 = float(modes.get("omega_model", modes["omega_fe"])[0])
    opts = {"max_points": int(max_points), "stability": stability}
    if not estimates:  # no per-point error estimates (mshbm.sweep's accuracy=False): the discretised equations only
        opts["accuracy"] = False
    if ds_max is not None:
        opts["ds_max"] = float(ds_max)
    if grazings is not None:  # mshbm.sweep's default: located by bisection
        opts["grazings"] = str(grazings)
    if method != "shooting":
        opts["harmonics"] = int(harmonics)
    if method in ("mshbm", "shooting") and steps is not None:
        opts["steps"] = int(steps)
    if method in ("mshbm", "shooting") and integrator is not None:
        opts["integrator"] = str(integrator)
        if accumulation is not None:
            opts["accumulation"] = str(accumulation)
    if method == "hbm" and penalty_quadrature is not None:
        opts["penalty_quadrature"] = str(penalty_quadrature)
    dofs = named_dofs(modes, rm)
    log(f"{case_path}: {s}; sweep {method} over [{r0:g}, {r1:g}] w_1 = [{r0 * w1:.6g}, {r1 * w1:.6g}] rad/s, {opts}")
    t0, c0 = time.perf_counter(), time.process_time()
    b = mshbm.sweep(s, r0 * w1, r1 * w1, method, progress="always", **opts)  # every accepted point to the log
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    A = b.amplitude if len(b) else np.zeros((0, s.n))
    res = {
        "method": method, "success": bool(b.success), "message": b.message, "points": len(b),
        "wall_time_s": wall, "cpu_time_s": cpu, "n_dofs": s.n,
        "n_full_dofs": case.system.n, "reduction": None if rm is None else _reduction_facts(rm, b), "omega_1": w1, "omega_ratio": [r0, r1], "options": opts,
        "dofs": dofs, "omega": [float(w) for w in b.omega],
        "amplitude": {k: [float(a) for a in A[:, d]] for k, d in dofs.items()},
        "stable": b.stable, "stability_method": [p.stability_method for p in b.points],
        "certified": [bool(p.certificate.get("passed")) for p in b.points],
        "iterations": [int(i) for i in b.iterations],
        "bifurcations": [{k: v for k, v in bf.items() if k != "x"} for bf in b.bifurcations],
        "counters": {k: v for k, v in b.counters.items() if k != "failures"},
        "failures": b.counters.get("failures", []),
    }
    if check_points:
        res["checks"] = check_against_shooting(s, b, int(check_points), dofs, log)
    from mshbm.outfile import jsonable

    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(out, "w") as fh:
        json.dump(jsonable(res), fh, indent=1, allow_nan=False)
        fh.write("\n")
    log(f"{method}: {b.message} ({len(b)} points, {wall:.2f} s, CPU {cpu:.2f} s)")
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("case")
    ap.add_argument("out")
    ap.add_argument("--method", required=True, choices=METHODS)
    ap.add_argument("--omega-ratio", type=float, nargs=2, required=True, metavar=("R0", "R1"))
    ap.add_argument("--harmonics", type=int, default=5)
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument("--max-points", type=int, default=60)
    ap.add_argument("--ds-max", type=float, default=None, help="largest arclength step (scaled; mshbm.sweep)")
    ap.add_argument("--integrator", choices=("moreau", "event"), default=None,
                    help="MS-HBM / shooting time integration (default: the method's, Moreau-Jean)")
    ap.add_argument("--accumulation", choices=("moreau", "close"), default=None,
                    help="with --integrator event: accumulating impacts by Moreau-Jean steps or closed (Zeno)")
    ap.add_argument("--penalty-quadrature", choices=("samples", "linear"), default=None,
                    help="HBM: the penalty contact law at the AFT samples or integrated on the gap's linear "
                         "interpolant (default: mshbm.sweep's, linear with contacts)")
    ap.add_argument("--check-points", type=int, default=0,
                    help="solve the last K points again by event-driven full shooting (an independent check)")
    ap.add_argument("--stability", choices=("off", "auto", "on"), default="off",
                    help="stability of every point (mshbm.stability; off by default: ~20 s per point at 162 DOFs)")
    ap.add_argument("--estimates", choices=("on", "off"), default="on",
                    help="the points' error estimates (mshbm.sweep's default; off: accuracy=False, the discretised "
                         "equations only)")
    ap.add_argument("--grazings", choices=("bisection", "interpolation"), default=None,
                    help="grazings of the curve located by solves on both sides (mshbm.sweep's default, bisection) or "
                         "interpolated between their two points (no solves)")
    a = ap.parse_args(argv)
    st = {"off": False, "auto": "auto", "on": True}[a.stability]
    run(a.case, a.out, a.method, a.omega_ratio, a.harmonics, a.steps, a.max_points, a.ds_max, st,
        integrator=a.integrator, accumulation=a.accumulation, penalty_quadrature=a.penalty_quadrature,
        check_points=a.check_points, estimates=a.estimates == "on", grazings=a.grazings)
    return 0


if __name__ == "__main__":
    sys.exit(main())
