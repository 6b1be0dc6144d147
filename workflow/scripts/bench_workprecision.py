"""Work-precision benchmark of one system against the exact (event-driven) periodic solution.

For every method and discretisation (n_h, steps, regularisation) the solve at omega is
started, as in the paper, from that method's own converged solution at a nearby
frequency; the timed quantity is the median wall time of repeated solves from that start
(after one untimed warm-up, so numba compilation is excluded).  The error is the relative
amplitude error of masses 1 and n against ``mshbm.exact.exact_periodic``.

Usage::

    python workflow/scripts/bench_workprecision.py --config workflow/config.yaml \
        --system impact50 --out results/benchmarks/workprecision_impact50.json
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
import wfcore  # noqa: E402

import mshbm  # noqa: E402
from mshbm.exact import exact_periodic  # noqa: E402
from mshbm.hbm import scaled_regularisation  # noqa: E402


def timed_solve(system, omega, nearby, method, repeats, **opts):
    """Start from the method's own solution at ``nearby``; median wall time of ``repeats`` solves."""
    start = mshbm.solve(system, nearby, method, **opts)
    guess = start if start.success else None
    sol = mshbm.solve(system, omega, method, guess=guess, **opts)  # warm-up (compilation, caches)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sol = mshbm.solve(system, omega, method, guess=guess, **opts)
        times.append(time.perf_counter() - t0)
    return sol, times, start.success


def points(bcfg):
    """The (method, options) grid of the benchmark config."""
    for steps in bcfg["shooting_steps"]:
        yield "shooting", {"steps": steps}
    for method in ("mshbm", "mshbm-intermediate"):
        for n_h in bcfg["mixed_harmonics"]:
            for steps in bcfg["mixed_steps"]:
                if steps > 2 * n_h + 1:
                    yield method, {"harmonics": n_h, "steps": steps}
    for n_h in bcfg["hbm_harmonics"]:
        for factor in bcfg["hbm_regularisation_factors"]:
            yield "hbm", {"harmonics": n_h, "regularisation_factor": factor}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--system", required=True)
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    config = yaml.safe_load(Path(args.config).read_text())
    bcfg = config["benchmarks"]
    system = wfcore.build_system(config["systems"][args.system], args.system)
    omega = wfcore.omega(config)
    nearby = omega * float(bcfg["nearby_factor"])
    n = system.n

    t0 = time.perf_counter()
    seed = mshbm.solve(system, omega, "shooting", steps=int(bcfg["reference_seed_steps"]))
    ref = exact_periodic(system, omega, guess=seed)
    ref_time = time.perf_counter() - t0
    if not ref.success:
        raise SystemExit(f"exact reference failed for {args.system}: {ref.message}")
    amp_ref = np.asarray(ref.info["amplitude_exact"])
    idx = [0, n - 1]
    rows = []
    for method, opts in points(bcfg):
        opts = dict(opts)
        factor = opts.pop("regularisation_factor", 1.0)
        sys_m = scaled_regularisation(system, factor) if method == "hbm" else system
        sol, times, nearby_ok = timed_solve(sys_m, omega, nearby, method, int(bcfg["repeats"]), **opts)
        amp = sol.amplitude
        err = [abs(amp[i] / amp_ref[i] - 1.0) if amp_ref[i] > 1e-9 * amp_ref.max() else abs(amp[i])
               for i in idx]
        rows.append({
            "method": method, "harmonics": opts.get("harmonics"), "steps": sol.steps,
            "regularisation_factor": factor if method == "hbm" else None,
            "success": bool(sol.success), "message": sol.message, "iterations": sol.iterations,
            "nearby_start_converged": bool(nearby_ok),
            "error_mass1": float(err[0]), "error_massn": float(err[1]), "error": float(max(err)),
            "time_s": float(np.median(times)), "times_s": [float(t) for t in times],
        })
        print(f"{args.system} {method:19s} {opts} f={factor:g}: ok={sol.success} err={max(err):.2e} "
              f"t={np.median(times):.4f}s", flush=True)

    summary = targets(rows, float(bcfg["target_error"]))
    out = {
        "system": args.system, "n": n, "omega": omega, "nearby_omega": nearby,
        "reference": {"method": "exact", "amplitude": [float(a) for a in amp_ref[idx]],
                      "residual": float(ref.residual), "time_s": ref_time,
                      "n_events": len(ref.info.get("events", [])),
                      "max_floquet_modulus": float(np.max(np.abs(ref.info["floquet_multipliers"])))
                      if "floquet_multipliers" in ref.info else None},
        "machine": {"cpus": __import__("os").cpu_count(), "python": platform.python_version(),
                    "numpy": np.__version__, "mshbm": mshbm.__version__},
        "rows": rows, "targets": summary,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1))


def targets(rows, target_error):
    """Speed-up of MS-HBM over full shooting at the same error, for errors <= ``target_error``.

    For every converged MS-HBM point with error e <= target, the shooting time is the
    cheapest converged shooting point with error <= e (the cheapest overall if none is
    that accurate is *not* used: then the speed-up is reported as ``None``).
    """
    shoot = [r for r in rows if r["method"] == "shooting" and r["success"]]
    res = {"target_error": target_error}
    for method in ("mshbm", "mshbm-intermediate", "hbm"):
        best = None
        for r in rows:
            if r["method"] != method or not r["success"] or r["error"] > target_error:
                continue
            cand = [s["time_s"] for s in shoot if s["error"] <= r["error"]]
            if not cand:
                continue
            speedup = min(cand) / r["time_s"]
            if best is None or speedup > best["speedup"]:
                best = {"speedup": speedup, "error": r["error"], "time_s": r["time_s"],
                        "harmonics": r["harmonics"], "steps": r["steps"], "shooting_time_s": min(cand)}
        res[method] = best
    return res


if __name__ == "__main__":
    main()
