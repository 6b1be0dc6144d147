"""Solve the finite-element case (build_fe_model.py) at its forcing frequency with HBM, DLFT, MS-HBM and
(where the dense time stepper allows it) full shooting; time each, record the certificate and the
peak memory, and write a JSON.

Per method: ``success`` (certified), the message, Newton iterations, the scaled residual, the
wall time, the tip and friction-DOF amplitudes (max |q| over the period), the peak of the memory
traced by :mod:`tracemalloc` during the solve (NumPy and Python allocations: a dense ``n x n``
float matrix would show as ``8 n^2`` bytes, 800 MB at ``n = 10^4``) and the process's peak
resident size (``ru_maxrss``, which also counts SuperLU's factors).  Full shooting time-steps all
``n`` DOFs with dense step matrices and is refused above
:data:`mshbm.integrators.moreau_jean.MAX_DENSE_DOFS`; the JSON then records the refusal.

With a Craig-Bampton reduction in the case file (``reduce:``) every method solves the reduced model
(:attr:`mshbm.io.case.Case.model`: the element DOFs, physical nodes, plus a few fixed-interface modes) and
the answer is expanded to the full model's DOFs (:meth:`mshbm.reduction.ReducedModel.expand`), whose
certificate carries the reduction's error estimate (entry ``reduction``, recorded per row as
``reduction_estimate``); a later method starts from the *reduced* solution of an earlier one (``--guess``).
Full shooting then time-steps the reduced model, no smaller case is needed.  ``--accuracy default`` (the
workflow's choice): every solve is certified against the nonsmooth model at the default accuracy
(truncation in harmonics, time steps and the reduction); ``off``: only the discretised equations.
``--mode-convergence 4,16``: the reduction's convergence in the number of modes (:func:`mode_convergence`).
Times: wall (``wall_time_s``) and CPU of the process (``cpu_time_s``, ``time.process_time``: the machine's
load does not enter), both including the expansion and its error estimate.

Without a reduction, a time-stepped node DOF of a fine mesh has a local frequency ``sqrt(K_dd / M_dd)``
far above ``omega`` (2.6e6 omega on examples/fe_plate), and MS-HBM's time discretisation error decays
slowly with the steps (with ``mu = 0``: 0.018 mm at 1024 steps, 0.91 mm at 8192, 2.34 mm at 65536 against
the linear 2.37 mm).

Usage::

    python workflow/scripts/fe/fe_example.py CASE.yaml OUT.json [--methods hbm,mshbm,shooting] [--harmonics 5] \
        [--guess mshbm=hbm] [--shooting-max-dofs 1000] [--shooting-case SMALL.yaml] [--trace-memory] \
        [--accuracy default|off] [--mode-convergence 4,16]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import sys
import time
import tracemalloc

import numpy as np

import mshbm
from mshbm.integrators.moreau_jean import MAX_DENSE_DOFS

METHODS = ("hbm", "dlft", "mshbm", "shooting")
#: labelled variants: label -> (method, options).  ``mshbm-event``: MS-HBM with the exact event-driven flow for
#: the bodies; the pad bounces to rest every period, so accumulating impacts are closed (``accumulation=
#: "close"``: contact kept, the monodromy stays exact) instead of handed to Moreau-Jean steps
VARIANTS = {"mshbm-event": ("mshbm", {"integrator": "event", "accumulation": "close"})}


def _amplitudes(result, dofs):
    """max |q| over the period on the time grid of each named DOF."""
    return {name: float(np.max(np.abs(result.displacement([d])))) for name, d in dofs.items()}


def shooting_period_cost(case, steps):
    """Measured cost of full shooting's time stepping on all ``n`` DOFs: the set-up of the dense
    Moreau-Jean step matrices and one period of the state alone (no sensitivities), in seconds.  A
    Newton iteration of shooting also propagates the ``2 n`` columns of the monodromy through every step
    (``n`` times the work of the state's ``n x n`` products per column)."""
    from mshbm.integrators.moreau_jean import MoreauJean

    s = case.model
    T = 2.0 * np.pi / case.omega
    h = T / steps
    t0 = time.perf_counter()
    mj = MoreauJean(s.M, s.C, s.K, list(s.elements), h)
    t_setup = time.perf_counter() - t0
    t = np.arange(steps + 1) * h
    B = mj.increments(s.forcing(t, case.omega))
    t0 = time.perf_counter()
    mj.run(np.zeros(s.n), np.zeros(s.n), B)
    t_period = time.perf_counter() - t0
    return {"setup_s": t_setup, "period_state_s": t_period, "steps": int(steps), "n_dofs": int(s.n)}


def _solve(case, method, guess, **opts):
    """``(solution on the full model's DOFs, solution of the model solved)``: with a reduction, the reduced
    case solved (``guess``: a reduced solution) and expanded with its error estimate; else the case itself."""
    rm = case.reduction
    if rm is None:
        r = case.solve(method, guess=guess, **opts) if guess is not None else case.solve(method, **opts)
        return r, r
    reduced = dataclasses.replace(case, system=rm.system, reduction=None)
    r = reduced.solve(method, guess=guess, **opts) if guess is not None else reduced.solve(method, **opts)
    return rm.expand(r), r


def solve_one(case, method, harmonics=5, shooting_max_dofs=1000, guess=None, trace_memory=False, solutions=None,
              accuracy=False, **options):
    """One solve with its timing, memory and certificate summary (a JSON-ready dict).

    ``accuracy``: that of :func:`mshbm.solve` (``False``: the discretised equations only; ``None``: the
    default, certified against the nonsmooth model).  Full shooting: refused above :data:`MAX_DENSE_DOFS`
    DOFs of the model it solves; above ``shooting_max_dofs`` only its cost per period is measured
    (:func:`shooting_period_cost`), not a solve."""
    s = case.model
    if method == "shooting" and s.n > MAX_DENSE_DOFS:
        return {"method": method, "skipped": f"full shooting steps all {s.n} DOFs with dense {s.n}x{s.n} step "
                                             f"matrices; refused above {MAX_DENSE_DOFS} DOFs"}
    if method == "shooting" and s.n > shooting_max_dofs:
        cost = shooting_period_cost(case, int(options.get("steps", case.solver.get("steps", 4096))))
        return {"method": method, "skipped": f"{s.n} DOFs > {shooting_max_dofs}: only the time stepping of one "
                                             f"period is measured", "cost": cost}
    base, extra = VARIANTS.get(method, (method, {}))
    opts = dict(options, **extra)
    if accuracy is not None:
        opts.setdefault("accuracy", accuracy)
    if base != "shooting":
        opts.setdefault("harmonics", harmonics)
    if trace_memory:
        tracemalloc.start()
        tracemalloc.reset_peak()
    t0, c0 = time.perf_counter(), time.process_time()
    r, r_model = _solve(case, base, guess, **opts)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = tracemalloc.get_traced_memory()[1] if trace_memory else None
    if trace_memory:
        tracemalloc.stop()
    dofs = {el.kind: el.dof for el in case.system.elements}   # the full model's DOFs
    cert = r.certificate
    failed = [c.name for c in cert.checks if c.gating and not c.passed] if cert is not None else None
    if solutions is not None:
        solutions[method] = r_model
    red = r.info.get("reduction") if isinstance(r.info, dict) else None
    acc = r.info.get("accuracy") if isinstance(r.info, dict) else None
    return {
        "method": method, "harmonics": r.harmonics, "steps": r.steps, "success": bool(r.success),
        "message": r.message, "iterations": int(r.iterations), "residual": float(r.residual),
        "wall_time_s": wall, "cpu_time_s": cpu,
        "reduction_estimate": None if not red else red.get("error_estimate"),
        "accuracy_estimate": acc.get("estimate") if isinstance(acc, dict) else None,
        "traced_peak_mb": None if peak is None else peak / 2**20,
        "start": "guess" if guess is not None else "default",
        "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "failed_checks": failed, "amplitudes": _amplitudes(r, dofs),
    }


def mode_convergence(case, mode_counts, harmonics=5, log=print, **options):
    """The case's reduction with each number of fixed-interface modes in ``mode_counts`` (and the case's own),
    solved by MS-HBM with the exact event-driven flow at the default accuracy: per count the amplitudes of the
    element DOFs (full model's DOFs), the reduction's error estimate, success and CPU time."""
    counts = sorted(set(int(m) for m in mode_counts) | {case.reduction.n_modes})
    rows = []
    for m in counts:
        c = case if m == case.reduction.n_modes else case.with_sets([f"reduce.modes={m}"])
        row = solve_one(c, "mshbm-event", harmonics, accuracy=None, **options)
        rows.append({"modes": m, "n_dofs": c.model.n, "success": row["success"], "cpu_time_s": row["cpu_time_s"],
                     "reduction_estimate": row["reduction_estimate"], "amplitudes": row["amplitudes"],
                     "highest_mode_rad_s": c.reduction.as_dict()["highest_mode_rad_s"]})
        log(f"  modes {m}: {rows[-1]}")
    return rows


def run(case_path, methods=METHODS, harmonics=5, out=None, log=print, guess_from=None, trace_memory=False,
        shooting_max_dofs=1000, shooting_case=None, accuracy=False, mode_counts=(), **options):
    """Solve with each method in turn; ``guess_from={"mshbm": "hbm"}`` starts MS-HBM from the HBM solution
    (a method listed earlier).  ``shooting_case``: full shooting on this (smaller) case instead, when the
    main one is too large for its dense step matrices (its row then names the case and its DOFs)."""
    case = mshbm.load_case(case_path)
    s = case.model
    log(f"{case_path}: {s}" + (f" (reduced from {case.system.n} DOFs)" if case.reduction is not None else "")
        + f", omega = {case.omega:.6g} rad/s")
    rows, sols = [], {}
    for m in methods:
        g = sols.get((guess_from or {}).get(m))
        c = case
        if m == "shooting" and shooting_case is not None and s.n > MAX_DENSE_DOFS:
            c = mshbm.load_case(shooting_case)
        row = solve_one(c, m, harmonics, shooting_max_dofs=shooting_max_dofs, guess=g, trace_memory=trace_memory,
                        solutions=sols, accuracy=accuracy, **options)
        row["n_dofs"] = c.model.n
        row["n_full_dofs"] = c.system.n
        if c is not case:
            row["case"] = str(shooting_case)
            row["refused_on_main"] = (f"full shooting steps all {s.n} DOFs with dense {s.n}x{s.n} step matrices; "
                                      f"refused above {MAX_DENSE_DOFS} DOFs")
        rows.append(row)
        if "skipped" in row:
            log(f"  {m}: skipped ({row['skipped']}) {row.get('cost', '')}")
        else:
            log(f"  {m}: success={row['success']} it={row['iterations']} {row['wall_time_s']:.2f} s "
                f"(CPU {row['cpu_time_s']:.2f} s, reduction estimate {row['reduction_estimate']}) "
                f"(start: {row['start']}), maxrss {row['maxrss_mb']:.0f} MB, "
                f"amplitudes {row['amplitudes']}; {row['message'][:160]}")
    convergence = []
    if case.reduction is not None and mode_counts:
        convergence = mode_convergence(case, mode_counts, harmonics, log=log, **options)
    facts = {"case": str(case_path), "n_dofs": s.n, "mode_convergence": convergence, "n_full_dofs": case.system.n, "omega": case.omega,
             "sparse": s.is_sparse, "accuracy": "default" if accuracy is None else accuracy,
             "reduction": None if case.reduction is None else case.reduction.as_dict(),
             "elements": [{"kind": e.kind, "dof": e.dof} for e in case.system.elements], "solves": rows}
    if out is not None:
        with open(out, "w") as fh:
            json.dump(facts, fh, indent=1)
            fh.write("\n")
    return facts


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("case")
    ap.add_argument("out")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--harmonics", type=int, default=5)
    ap.add_argument("--guess", action="append", default=[], metavar="METHOD=FROM",
                    help="start METHOD from the solution of FROM (listed earlier), e.g. mshbm=hbm")
    ap.add_argument("--shooting-max-dofs", type=int, default=1000,
                    help="above this, full shooting's cost per period is measured instead of a solve")
    ap.add_argument("--shooting-case", default=None,
                    help="a smaller case for full shooting when CASE exceeds the dense time stepper's limit")
    ap.add_argument("--accuracy", choices=("default", "off"), default="off",
                    help="default: certify against the nonsmooth model at the default accuracy; off: the "
                         "discretised equations only")
    ap.add_argument("--mode-convergence", default="", metavar="N1,N2,...",
                    help="with reduce: in the case, also solve MS-HBM (event) with these numbers of modes")
    ap.add_argument("--trace-memory", action="store_true", help="peak traced memory (tracemalloc; slows Python code)")
    args = ap.parse_args(argv)
    guess_from = dict(kv.split("=", 1) for kv in args.guess)
    run(args.case, args.methods.split(","), args.harmonics, args.out, guess_from=guess_from,
        trace_memory=args.trace_memory, shooting_max_dofs=args.shooting_max_dofs, shooting_case=args.shooting_case,
        accuracy=None if args.accuracy == "default" else False,
        mode_counts=[int(m) for m in args.mode_convergence.split(",") if m.strip()])
    return 0


if __name__ == "__main__":
    sys.exit(main())
