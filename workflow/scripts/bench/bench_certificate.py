"""Cost of the certificate (mshbm.certificate) relative to the solve, on the paper's example cases.

    python workflow/scripts/bench/bench_certificate.py [--repeats 5] [--out results/bench_certificate.json]
        [examples/friction3.yaml examples/impact5.yaml]

For every case and method: median wall time of ``mshbm.solve`` (which includes the certificate)
and of ``mshbm.certificate.certify`` on the returned solution (re-run on the same problem), and
their ratio.  Numba compilation is excluded by one warm-up solve per case and method.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import mshbm
from mshbm.api import build_problem
from mshbm.certificate import certify

METHODS = ("shooting", "hbm", "mshbm", "mshbm-intermediate")


def measure(case, method, repeats):
    opts = {k: v for k, v in case.solver.items() if k in ("harmonics", "steps")}
    mshbm.solve(case.system, case.omega, method, **opts)  # warm-up
    t_solve, t_cert = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sol = mshbm.solve(case.system, case.omega, method, **opts)
        t_solve.append(time.perf_counter() - t0)
        problem, _ = build_problem(case.system, case.omega, method, **opts)
        t0 = time.perf_counter()
        cert = certify(problem, sol, 1e-10)
        t_cert.append(time.perf_counter() - t0)
    s, c = statistics.median(t_solve), statistics.median(t_cert)
    return {"case": case.name, "method": method, "options": opts, "success": bool(sol.success),
            "certificate_passed": bool(cert.passed), "solve_s": s, "certificate_s": c,
            "certificate_fraction_of_solve": c / s}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", default=["examples/friction3.yaml", "examples/impact5.yaml"])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    rows = []
    for path in args.cases:
        case = mshbm.load_case(path)
        for m in METHODS:
            r = measure(case, m, args.repeats)
            rows.append(r)
            print(f"{r['case']:<10} {m:<20} solve {r['solve_s'] * 1e3:8.1f} ms  certificate "
                  f"{r['certificate_s'] * 1e3:7.2f} ms  ({100 * r['certificate_fraction_of_solve']:5.1f} %)",
                  file=sys.stderr)
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps({"rows": rows}, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
