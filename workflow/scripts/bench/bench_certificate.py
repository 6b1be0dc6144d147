"""Cost of the certificate (mshbm.certificate) relative to the solve, on the paper's example cases.

    python workflow/scripts/bench/bench_certificate.py [--repeats 5] [--out results/bench_certificate.json]
        [examples/friction3.yaml examples/impact5.yaml]
    python workflow/scripts/bench/bench_certificate.py --stability [--harmonics 3] [examples/impact50.yaml]

For every case and method: median wall time of ``mshbm.solve`` (which includes the certificate)
and of ``mshbm.certificate.certify`` on the returned solution (re-run on the same problem), and
their ratio.  Numba compilation is excluded by one warm-up solve per case and method.

``--stability``: the same for the stability analysis (:func:`mshbm.stability.assess`, the reported orbit's own
monodromy), in CPU time (``time.process_time``, one BLAS thread: wall times are distorted by load), at
``repeats`` frequencies ``omega (1 + 0.01 k)``, ``k = -repeats//2 ..`` (a solve at a new frequency, not a
repeat of a cached one), next to the exact re-solve of the periodic orbit it replaced
(``stability._exact``).  Methods: ``mshbm`` only unless ``--methods`` is given.
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


def measure_stability(case, method, repeats, harmonics=None):
    import numpy as np

    from mshbm import stability
    from mshbm._blas import blas_threads

    opts = {k: v for k, v in case.solver.items() if k in ("harmonics", "steps")}
    if harmonics is not None:
        opts["harmonics"] = int(harmonics)
    mshbm.solve(case.system, case.omega * 1.05, method, **opts)  # warm-up (compilation)
    t_solve, t_stab, t_old, rows = [], [], [], []
    with blas_threads(1):
        for k in range(repeats):
            omega = case.omega * (1.0 + 0.01 * (k - repeats // 2))
            t0 = time.process_time()
            sol = mshbm.solve(case.system, omega, method, stability=False, **opts)
            t_solve.append(time.process_time() - t0)
            t0 = time.process_time()
            stability.assess(case.system, sol)
            t_stab.append(time.process_time() - t0)
            t0 = time.process_time()
            stability._exact(case.system, sol)
            t_old.append(time.process_time() - t0)
            rows.append({"omega": omega, "stable": sol.stable, "orbit": sol.stability_orbit,
                         "max_modulus": float(np.max(np.abs(sol.floquet_multipliers)))
                         if sol.floquet_multipliers.size else None,
                         "multiplier_error": sol.info["stability"].get("multiplier_error")})
    s, a, o = statistics.median(t_solve), statistics.median(t_stab), statistics.median(t_old)
    return {"case": case.name, "method": method, "options": opts, "clock": "cpu (process_time, 1 BLAS thread)",
            "solve_s": s, "stability_s": a, "exact_resolve_s": o, "stability_fraction_of_solve": a / s,
            "exact_resolve_fraction_of_solve": o / s, "points": rows}


def main_stability(args):
    rows = []
    for path in args.cases or ["examples/impact50.yaml"]:
        case = mshbm.load_case(path)
        for m in args.methods or ["mshbm"]:
            r = measure_stability(case, m, args.repeats, args.harmonics)
            rows.append(r)
            print(f"{r['case']:<10} {m:<20} solve {r['solve_s'] * 1e3:8.1f} ms  stability {r['stability_s'] * 1e3:7.2f} "
                  f"ms ({100 * r['stability_fraction_of_solve']:5.1f} %)  exact re-solve {r['exact_resolve_s'] * 1e3:7.2f} "
                  f"ms ({100 * r['exact_resolve_fraction_of_solve']:5.1f} %)  [CPU, medians]", file=sys.stderr)
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps({"rows": rows}, indent=1) + "\n", encoding="utf-8")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", default=None)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=None)
    ap.add_argument("--stability", action="store_true", help="measure the stability analysis instead")
    ap.add_argument("--harmonics", type=int, default=None, help="n_h of the --stability solves")
    ap.add_argument("--methods", nargs="*", default=None, help="methods of the --stability solves")
    args = ap.parse_args(argv)
    if args.stability:
        return main_stability(args)
    args.cases = args.cases or ["examples/friction3.yaml", "examples/impact5.yaml"]
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
