"""CPU cost of the stability analysis against the solve it belongs to, side by side in one run.

    python workflow/scripts/bench/bench_stability.py [--repeats 5] [--harmonics 5] [--out results/bench_stability.json]
        [--set key=value ...] [examples/impact5.yaml examples/impact50.yaml examples/friction3.yaml]

For every case (its ``solver:`` defaults, its reduced model with ``reduce:``) and ``repeats`` frequencies
``omega (1 + 0.01 k)``, ``k = -repeats//2 ..`` (a new problem each time: nothing cached from the previous point):
the CPU time (``time.process_time``, one BLAS thread; wall times are distorted by load) of
``mshbm.solve(..., stability=False)`` and, on the solution it returned, of :func:`mshbm.stability.assess` (what
``stability="auto"`` adds to a solve).  One warm-up solve and analysis per case first (Numba compilation).
Prints per case the medians and the ratio analysis / solve (the goal: below 25 %), the orbit the multipliers belong
to, the verdict and the events of the period.  ``--set key=value`` passes solver options (e.g. ``integrator=event``).
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import yaml

import mshbm
from mshbm import stability
from mshbm._blas import blas_threads

DEFAULT_CASES = ("examples/impact5.yaml", "examples/impact50.yaml", "examples/friction3.yaml")


def measure(case, repeats, harmonics=None, extra=None):
    """Medians of the solve's and the analysis's CPU time over ``repeats`` frequencies of ``case``."""
    opts = {k: v for k, v in case.solver.items() if k != "method"}
    opts.update(extra or {})
    if harmonics is not None:
        opts["harmonics"] = int(harmonics)
    system, method = case.model, case.method
    rows = []
    with blas_threads(1):
        warm = mshbm.solve(system, case.omega * 1.05, method, stability=False, **opts)
        stability.assess(system, warm)
        for k in range(repeats):
            omega = case.omega * (1.0 + 0.01 * (k - repeats // 2))
            t0 = time.process_time()
            sol = mshbm.solve(system, omega, method, stability=False, **opts)
            t1 = time.process_time()
            stability.assess(system, sol)
            t2 = time.process_time()
            info = sol.info.get("stability", {})
            rows.append({"omega": omega, "success": bool(sol.success), "solve_s": t1 - t0, "stability_s": t2 - t1,
                         "stability_method": sol.stability_method, "orbit": sol.stability_orbit,
                         "stable": sol.stable, "n_events": info.get("n_events"),
                         "max_modulus": float(np.max(np.abs(sol.floquet_multipliers)))
                         if sol.floquet_multipliers.size else None,
                         "multiplier_error": info.get("multiplier_error")})
    s = statistics.median(r["solve_s"] for r in rows)
    a = statistics.median(r["stability_s"] for r in rows)
    return {"case": case.name, "method": method, "n": system.n, "options": opts,
            "clock": "cpu (process_time, 1 BLAS thread), medians", "solve_s": s, "stability_s": a,
            "stability_fraction_of_solve": a / s, "points": rows}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("cases", nargs="*", default=list(DEFAULT_CASES))
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--harmonics", type=int, default=None, help="n_h (default: the case's)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a solver option (YAML value)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    extra = {}
    for item in args.set:
        key, _, value = item.partition("=")
        extra[key] = yaml.safe_load(value)
    results = []
    for path in args.cases:
        r = measure(mshbm.load_case(path), max(1, args.repeats), args.harmonics, extra)
        results.append(r)
        p = r["points"][len(r["points"]) // 2]
        print(f"{r['case']:<10} n = {r['n']:<4} {r['method']:<8} solve {r['solve_s'] * 1e3:8.1f} ms  stability "
              f"{r['stability_s'] * 1e3:7.2f} ms  ({100 * r['stability_fraction_of_solve']:5.1f} % of the solve)  "
              f"[{p['orbit'] or p['stability_method']}, stable={p['stable']}, {p['n_events']} events]",
              file=sys.stderr, flush=True)
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps({"rows": results}, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
