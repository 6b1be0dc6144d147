"""DLFT against HBM (regularised laws) and MS-HBM on the paper's chains: error and wall time.

Stand-alone (not a Snakemake rule)::

    PYTHONPATH=src python workflow/scripts/bench/bench_dlft.py [--harmonics 5 10 25] [--repeat 3]

For each case (``examples/friction3.yaml``, ``examples/impact5.yaml``) the exact event-driven
periodic orbit (:func:`mshbm.exact_periodic`) is the reference; every method is solved with its
default start strategy and default steps at each ``n_h``.  Printed per row: success, the
largest relative amplitude error over the DOFs ``max_i |a_i - a_i,exact| / a_i,exact`` (``a``
half the peak-to-peak displacement), the Newton iterations and the best wall time of
``--repeat`` solves (``PeriodicSolution.wall_time``: set-up, Newton and output; stability off).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import mshbm
from mshbm.methods.exact import exact_periodic

ROOT = Path(__file__).resolve().parents[3]
METHODS = ("dlft", "hbm", "mshbm")


def reference(case):
    ms = mshbm.solve(case.system, case.omega, "mshbm", harmonics=5, stability=False)
    ex = exact_periodic(case.system, case.omega, guess=ms)
    if not ex.success:
        raise RuntimeError(f"exact reference of {case.name} failed: {ex.message}")
    return np.asarray(ex.info["amplitude_exact"], dtype=float)


def run(harmonics, repeat, cases):
    rows = []
    for name in cases:
        case = mshbm.load_case(ROOT / "examples" / f"{name}.yaml")
        A = reference(case)
        for n_h in harmonics:
            for method in METHODS:
                best, sol = np.inf, None
                for _ in range(repeat):
                    s = mshbm.solve(case.system, case.omega, method, harmonics=n_h, stability=False)
                    if s.wall_time < best:
                        best, sol = s.wall_time, s
                err = float(np.max(np.abs(sol.amplitude - A) / A))
                rows.append((name, n_h, method, sol.success, err, sol.iterations, best, sol.steps))
                print(f"{name:10s} {n_h:4d} {method:6s} {str(sol.success):5s} {err:10.3e} {sol.iterations:5d} "
                      f"{best:9.3f} {sol.steps:6d}", flush=True)
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--harmonics", type=int, nargs="+", default=[5, 10, 25])
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--cases", nargs="+", default=["friction3", "impact5"])
    args = p.parse_args(argv)
    print(f"{'case':10s} {'n_h':>4s} {'method':6s} {'ok':5s} {'amp. err':>10s} {'iter':>5s} {'wall [s]':>9s} "
          f"{'steps':>6s}")
    run(args.harmonics, args.repeat, args.cases)
    return 0


if __name__ == "__main__":
    sys.exit(main())
