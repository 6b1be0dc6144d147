"""Benchmark: how many 1-DOF impact-oscillator frequencies ``mshbm.solve`` reaches from
its default start, and how many ``mshbm.sweep`` reaches by continuing from a frequency where it converges.

System: ``x'' + x = cos(omega t)``, a stop at gap 0 (``x <= 0``), restitution ``e_N``; omega at 10 values in
[1.2, 3.0], ``e_N`` in {0.5, 0.8, 1.0}; shooting with 2000 steps per period.

For every ``e_N``: ``solve`` at each omega (default options); then, for every omega where ``solve`` failed,
``sweep`` from the nearest omega where ``solve`` converged to that omega (the branch's end point is solved
at the target exactly and certified).  Not wired into Snakemake (stand-alone:
``python workflow/scripts/bench/bench_sweep_reach.py [--out FILE.json]``).
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

import mshbm
from mshbm import Contact, chain

OMEGAS = np.linspace(1.2, 3.0, 10)
RESTITUTIONS = (0.5, 0.8, 1.0)
METHOD, STEPS = "shooting", 2000


def system(e):
    return chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Contact(0, 0.0, e)],
                 name=f"impact-oscillator-e{e}")


def run(omegas=OMEGAS, restitutions=RESTITUTIONS, method=METHOD, steps=STEPS):
    rows, summary = [], {"solve": 0, "sweep": 0, "total": 0}
    for e in restitutions:
        s = system(e)
        ok = {}
        for w in omegas:
            t0 = time.perf_counter()
            sol = mshbm.solve(s, float(w), method, steps=steps, stability=False)
            ok[float(w)] = bool(sol.success)
            rows.append({"e_N": e, "omega": float(w), "route": "solve", "success": bool(sol.success),
                         "wall_time_s": time.perf_counter() - t0, "message": sol.message[:200]})
        conv = [w for w, v in ok.items() if v]
        reached = dict(ok)
        for w, v in ok.items():
            if v or not conv:
                continue
            w0 = min(conv, key=lambda c: abs(c - w))
            t0 = time.perf_counter()
            b = mshbm.sweep(s, w0, w, method, steps=steps, stability=False, max_points=300, max_time=300)
            reached[w] = bool(b.success)
            rows.append({"e_N": e, "omega": w, "route": f"sweep from {w0:.3f}", "success": bool(b.success),
                         "points": len(b), "wall_time_s": time.perf_counter() - t0, "message": b.message[:200]})
        summary["solve"] += sum(ok.values())
        summary["sweep"] += sum(reached.values())
        summary["total"] += len(ok)
        print(f"e_N = {e}: solve {sum(ok.values())}/{len(ok)}, solve or sweep {sum(reached.values())}/{len(ok)}",
              flush=True)
    return {"summary": summary, "rows": rows}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=None, help="write the rows as JSON")
    args = p.parse_args(argv)
    res = run()
    s = res["summary"]
    print(f"solve from its default start: {s['solve']}/{s['total']}; with sweep from a converged frequency: "
          f"{s['sweep']}/{s['total']}")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
