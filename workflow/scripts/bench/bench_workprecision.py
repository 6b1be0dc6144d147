"""Work-precision benchmark of one system against the exact (event-driven) periodic solution.

For every method and discretisation (n_h, steps, regularisation) the solve at omega is
started, as in the paper, from that method's own converged solution at a nearby
frequency; the timed quantity is the median wall time of repeated solves from that start
(one untimed warm-up solve per method excludes numba compilation).  The error is the
relative amplitude error of masses 1 and n against ``mshbm.methods.exact.exact_periodic``, whose
own convergence is checked by independent re-solves (``reference_convergence``).  The grids
are ``benchmarks`` of the config (``--profile full``: with the overrides of ``benchmarks.full``).

Event-driven variants: ``shooting-event`` (full shooting with ``integrator="event"``: one
point, exact up to Newton's tolerance; ``event_shooting``) and ``mshbm-event`` (MS-HBM with
``integrator="event"`` over ``event_mixed_harmonics``: its only error is the harmonic truncation);
``event_steps`` is only their output grid.  The event-driven goal is recorded in ``targets.event_goal``:
the time of the cheapest MS-HBM (event) point with error <= ``event_goal.mshbm_event_error`` (1e-6)
against the time of the cheapest Moreau-Jean full-shooting point with error <= ``event_goal.
shooting_error`` (1e-3), both from this run; ``ratio`` = shooting time / MS-HBM (event) time.

Usage::

    python workflow/scripts/bench/bench_workprecision.py --config workflow/config.yaml \
        --system impact50 --out results/benchmarks/workprecision_impact50.json
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np
import yaml

from mshbm_workflow import wfcore  # noqa: E402

import mshbm  # noqa: E402
from mshbm.methods.exact import exact_periodic  # noqa: E402
from mshbm.methods.hbm import scaled_regularisation  # noqa: E402
from mshbm import strategies  # noqa: E402


def timed_solve(system, omega, factor, method, repeats, warmup=True, **opts):
    """Start from the method's own solution at ``factor * omega`` (the nearby strategy of
    :mod:`mshbm.strategies`; the linear start when that one did not converge); wall times of
    ``repeats`` solves at ``omega`` from that start.

    ``warmup``: one untimed solve first (numba compilation; needed once per method and process).
    """
    opts.setdefault("stability", False)  # the Floquet analysis is not part of the timed solve
    opts.setdefault("accuracy", False)  # nor error estimates: the error is measured against the reference
    start = strategies.nearby_start(system, omega, method, factor, **opts)
    if not start.ok:
        start = strategies.linear_start()
    if warmup:
        strategies.solve_from(start, system, omega, method, **opts)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sol = strategies.solve_from(start, system, omega, method, **opts)
        times.append(time.perf_counter() - t0)
    return sol, times, start.name == "nearby"


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
    for n_h in bcfg.get("dlft_harmonics", []):  # set-valued laws, AFT samples as HBM
        yield "dlft", {"harmonics": n_h}
    ev_steps = int(bcfg.get("event_steps", 256))  # the output grid of the event-driven flow
    if bcfg.get("event_shooting", False):
        yield "shooting-event", {"steps": ev_steps, "integrator": "event"}
    for n_h in bcfg.get("event_mixed_harmonics", []):
        yield "mshbm-event", {"harmonics": n_h, "steps": ev_steps, "integrator": "event"}


#: the benchmark's method labels -> the method of ``mshbm.solve`` (the integrator is in the options)
SOLVE_METHOD = {"shooting-event": "shooting", "mshbm-event": "mshbm"}
#: every label, in report order
METHODS = ("shooting", "mshbm", "mshbm-intermediate", "hbm", "dlft", "shooting-event", "mshbm-event")


def hbm_samples(bcfg, config, n_h):
    """AFT samples of HBM: ``benchmarks.hbm_samples`` if given, else the reproduction's rule."""
    rule = bcfg.get("hbm_samples", config["numerics"]["hbm_samples"])
    return wfcore.hbm_samples({"numerics": {"hbm_samples": rule}}, n_h)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--system", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--profile", choices=("default", "full"), default="default",
                    help="full: the grids of `benchmarks.full` (overrides) instead of the default ones")
    args = ap.parse_args(argv)
    text = Path(args.config).read_text()
    # JSON (the workflow's config snapshot) with the JSON parser: YAML 1.1 reads 1e-05 as a string
    config = json.loads(text) if args.config.endswith(".json") else yaml.safe_load(text)
    bcfg = dict(config["benchmarks"])
    if args.profile == "full":
        bcfg.update(bcfg.get("full") or {})
    system = wfcore.build_system(config["systems"][args.system], args.system)
    omega = wfcore.omega(config)
    factor_nearby = float(bcfg["nearby_factor"])
    nearby = omega * factor_nearby
    n = system.n

    load_start = list(os.getloadavg())
    t0 = time.perf_counter()
    seed = mshbm.solve(system, omega, "shooting", steps=int(bcfg["reference_seed_steps"]))
    ref = exact_periodic(system, omega, guess=seed)
    ref_time = time.perf_counter() - t0
    if not ref.success:
        raise SystemExit(f"exact reference failed for {args.system}: {ref.message}")
    amp_ref = np.asarray(ref.info["amplitude_exact"])
    idx = [0, n - 1]
    ref_check = reference_convergence(system, omega, amp_ref, idx, seed)
    print(f"{args.system} exact reference: amplitudes {amp_ref[idx]}, {len(ref.info.get('events', []))} events, "
          f"{ref_time:.2f} s; variants differ by <= {ref_check['max_relative_difference']:.1e}", flush=True)
    rows, warmed = [], set()
    for method, opts in points(bcfg):
        opts = dict(opts)
        factor = opts.pop("regularisation_factor", 1.0)
        if method in ("hbm", "dlft"):
            opts["steps"] = hbm_samples(bcfg, config, opts["harmonics"])
        sys_m = scaled_regularisation(system, factor) if method == "hbm" else system
        sol, times, nearby_ok = timed_solve(sys_m, omega, factor_nearby, SOLVE_METHOD.get(method, method),
                                            int(bcfg["repeats"]), warmup=method not in warmed, **opts)
        warmed.add(method)
        amp = sol.amplitude
        err = [abs(amp[i] / amp_ref[i] - 1.0) if amp_ref[i] > 1e-9 * amp_ref.max() else abs(amp[i])
               for i in idx]
        rows.append({
            "method": method, "integrator": opts.get("integrator", "moreau"),
            "harmonics": opts.get("harmonics"), "steps": sol.steps,
            "regularisation_factor": factor if method == "hbm" else None,
            "success": bool(sol.success), "message": sol.message, "iterations": sol.iterations,
            "nfev": int(sol.nfev), "loadavg_1min": os.getloadavg()[0],
            "nearby_start_converged": bool(nearby_ok),
            "error_mass1": float(err[0]), "error_massn": float(err[1]), "error": float(max(err)),
            "time_s": float(np.median(times)), "times_s": [float(t) for t in times],
        })
        print(f"{args.system} {method:19s} {opts} f={factor:g}: ok={sol.success} err={max(err):.2e} "
              f"t={np.median(times):.4f}s", flush=True)

    summary = targets(rows, float(bcfg["target_error"]))
    summary["equal_error"] = equal_error_ratios(rows, [float(e) for e in bcfg.get("error_levels", [0.02, 1e-2, 1e-3])])
    summary["shooting_order"] = observed_order(rows)
    summary["event_goal"] = event_goal(rows, bcfg.get("event_goal") or {})
    out = {
        "system": args.system, "profile": args.profile, "n": n, "omega": omega, "nearby_omega": nearby,
        "reference": {"method": "exact", "amplitude": [float(a) for a in amp_ref[idx]],
                      "residual": float(ref.residual), "time_s": ref_time,
                      "n_events": len(ref.info.get("events", [])),
                      "convergence": ref_check,
                      "max_floquet_modulus": float(np.max(np.abs(ref.info["floquet_multipliers"])))
                      if "floquet_multipliers" in ref.info else None},
        # the load average (1, 5, 15 min) at the start and end of the benchmark: timings on a loaded
        # machine measure the scheduler as well
        "machine": {"cpus": os.cpu_count(), "loadavg_start": load_start, "loadavg_end": list(os.getloadavg()),
                    "python": platform.python_version(),
                    "numpy": np.__version__, "mshbm": mshbm.__version__},
        "rows": rows, "targets": summary,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1))


def reference_convergence(system, omega, amp_ref, idx, seed):
    """Evidence that the exact reference is converged: independent re-solves agree with it.

    Variants: a 100x tighter Newton tolerance, a 4x finer event-search grid and a different
    seed (shooting with 16x fewer steps than ``seed``, the reference's own start).  Returns
    their relative amplitude differences (masses 1 and n) to the reference; their maximum is
    what the reference is good to.
    """
    seed_steps = max(256, int(seed.steps) // 16)
    coarse = mshbm.solve(system, omega, "shooting", steps=seed_steps)
    variants = {
        "tol_1e-13": dict(guess=seed, tol=1e-13),
        "substeps_512": dict(guess=seed, substeps=512),
        f"seed_shooting_{seed_steps}_steps": dict(guess=coarse),
    }
    out = {}
    for name, kw in variants.items():
        v = exact_periodic(system, omega, **kw)
        if not v.success:
            out[name] = {"success": False, "message": v.message}
            continue
        a = np.asarray(v.info["amplitude_exact"])
        out[name] = {"success": True, "residual": float(v.residual),
                     "relative_difference": float(max(abs(a[i] / amp_ref[i] - 1.0) for i in idx))}
    diffs = [v["relative_difference"] for v in out.values() if v.get("success")]
    return {"variants": out, "max_relative_difference": float(max(diffs)) if diffs else None,
            "all_converged": all(v.get("success") for v in out.values())}


def observed_order(rows):
    """Least-squares order p of full shooting's error ~ steps^-p (converged points, error > 1e-12)."""
    pts = [(r["steps"], r["error"]) for r in rows if r["method"] == "shooting" and r["success"] and r["error"] > 1e-12]
    if len(pts) < 3:
        return None
    s, e = np.log(np.array(pts, dtype=float)).T
    return float(-np.polyfit(s, e, 1)[0])


def cheapest(rows, method, level):
    """Cheapest converged point of ``method`` with error <= ``level`` (None if there is none)."""
    ok = [r for r in rows if r["method"] == method and r["success"] and r["error"] <= level]
    return min(ok, key=lambda r: r["time_s"]) if ok else None


def equal_error_ratios(rows, levels):
    """Time of full shooting over the time of each method to reach the same error level.

    For each level ``e``: the cheapest converged point of each method with error <= e,
    and ``speedup[method] = time(shooting) / time(method)`` (``None`` if either never
    reaches ``e`` in the sweep).
    """
    out = []
    for level in levels:
        entry = {"error_level": float(level)}
        shoot = cheapest(rows, "shooting", level)
        for method in METHODS:
            best = cheapest(rows, method, level)
            entry[method] = None if best is None else {
                "time_s": best["time_s"], "error": best["error"], "harmonics": best["harmonics"],
                "steps": best["steps"], "regularisation_factor": best["regularisation_factor"],
                "speedup_over_shooting": (shoot["time_s"] / best["time_s"]) if shoot else None}
        out.append(entry)
    return out


def event_goal(rows, gcfg):
    """The event-driven goal: MS-HBM (event) at ``mshbm_event_error`` faster than Moreau-Jean full shooting at
    ``shooting_error`` (cheapest converged point of each reaching its level, same run).

    ``ratio`` = time(shooting) / time(MS-HBM event); ``met`` = ratio > 1; None where a method does not
    reach its level in the sweep (then ``met`` is False and ``why`` says which).
    """
    lv_ev = float(gcfg.get("mshbm_event_error", 1e-6))
    lv_sh = float(gcfg.get("shooting_error", 1e-3))
    ev, sh = cheapest(rows, "mshbm-event", lv_ev), cheapest(rows, "shooting", lv_sh)
    pick = lambda r: None if r is None else {k: r[k] for k in ("time_s", "error", "harmonics", "steps")}
    out = {"mshbm_event_error": lv_ev, "shooting_error": lv_sh, "mshbm_event": pick(ev), "shooting": pick(sh),
           "ratio": (sh["time_s"] / ev["time_s"]) if ev and sh else None}
    out["met"] = bool(out["ratio"] is not None and out["ratio"] > 1.0)
    if not any(r["method"] == "mshbm-event" for r in rows):
        out["why"] = "MS-HBM (event) not in this sweep"
    elif ev is None:
        out["why"] = f"no MS-HBM (event) point reached {lv_ev:g}"
    elif sh is None:
        out["why"] = f"no full-shooting point reached {lv_sh:g}"
    return out


def targets(rows, target_error):
    """Speed-up of MS-HBM over full shooting at the same error, for errors <= ``target_error``.

    For every converged MS-HBM point with error e <= target, the shooting time is the
    cheapest converged shooting point with error <= e (the cheapest overall if none is
    that accurate is *not* used: then the speed-up is reported as ``None``).
    """
    shoot = [r for r in rows if r["method"] == "shooting" and r["success"]]
    res = {"target_error": target_error}
    for method in METHODS[1:]:
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
