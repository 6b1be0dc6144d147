"""Accuracy suite of mshbm: certified answers against exact references, at the default accuracy and on request.

Run by the Snakemake rules ``accuracy`` / ``accuracy_quick`` (workflow/rules/accuracy.smk) or directly::

    python workflow/scripts/stress/accuracy.py --config workflow/accuracy.yaml [--quick] --out results/accuracy

Systems and references: :mod:`mshbm_workflow.accuracy_cases` (closed-form impact, Coulomb and rotating-force
orbits, event-driven flow on random chains, unit-scaled copies).  Every method variant of the configuration that
applies is solved with ``stability=False`` at its default discretisation, once per *setting*: ``default`` (no
``accuracy`` option: the default accuracy :data:`mshbm.certificate.combined.DEFAULT_ACCURACY` gates success) and
``accuracy = a`` for each ``a`` of ``accuracies`` (the method refines its discretisation), and once with
``accuracy=False`` (the fixed discretisation, no estimates: the CPU baseline of the refinement's cost).  A *case*
is one (system, method variant, setting) row.

Error ``err = max_i |A_i - A_ref,i| / max_i A_ref,i`` (the estimates' measure, :mod:`mshbm.route.refine`).
Outcomes of a row:

* ``within`` -- success and ``err <= a`` (``a`` the requested accuracy, or the default);
* ``OUT`` -- success and ``err > a``: a defect (an estimate under-read); the row records the estimates and
  whether the answer is another exact orbit (the event-driven flow started from it stays there);
* ``failed`` -- no success; the diagnosis is the failed certificate checks, the largest or missing estimate, or
  the message (no solution, time budget);
* ``refused`` -- :class:`mshbm.InputError` (the method cannot take the system; the key is recorded);
* ``crash`` -- any other exception (a defect).

CPU times are ``time.process_time()`` of each solve in this process (after a warm-up solve of every variant, so
that JIT compilation is not counted).
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import yaml  # noqa: E402

import mshbm  # noqa: E402
from mshbm.certificate.combined import DEFAULT_ACCURACY  # noqa: E402
from mshbm.outfile import jsonable  # noqa: E402
from mshbm_workflow.accuracy_cases import (build_system, load_config, methods_for, plan_systems,  # noqa: E402
                                           reference)
from mshbm_workflow.accuracy_report import markdown, summarise  # noqa: E402


def _err(amp, ref):
    amp = np.asarray(amp, dtype=float)
    if amp.shape != ref.shape or not np.all(np.isfinite(amp)):
        return math.inf
    return float(np.max(np.abs(amp - ref)) / np.max(np.abs(ref)))


def _diagnosis(sol):
    """What made a solve fail: the failed checks and the largest / missing estimate."""
    acc = sol.info.get("accuracy") or {}
    est = {k: v for k, v in (acc.get("estimates") or {}).items()}
    failed = list(getattr(sol.certificate, "failed", []) or []) if sol.certificate is not None else []
    missing = [k for k, v in est.items() if v is None]
    largest = max(((v, k) for k, v in est.items() if v is not None), default=(None, None))[1]
    msg = str(sol.message or "")
    if "time budget" in msg:
        kind = "time budget"
    elif failed == ["accuracy"]:
        kind = "accuracy: " + (("not estimated: " + ", ".join(missing)) if missing else f"largest {largest}")
    elif failed:
        kind = "certificate: " + ", ".join(failed)
    else:
        kind = "no solution"
    return kind, failed, largest, missing


def solve_row(system, omega, variant, vopts, setting, cfg):
    opts = {k: v for k, v in vopts.items() if k != "method"}
    opts.update(stability=False, max_time=float(cfg.get("solve_max_time_s", cfg["max_time_s"])))
    if setting == "fixed":
        opts["accuracy"] = False
    elif setting != "default":
        opts["accuracy"] = float(setting)
    t = time.process_time()
    try:
        sol = mshbm.solve(system, omega, vopts["method"], **opts)
        exc = None
    except mshbm.InputError as e:
        sol, exc = None, ("refused", f"{e.key}: {e}")
    except Exception as e:  # noqa: BLE001 -- a crash is a row (a defect), not the end of the suite
        sol, exc = None, ("crash", f"{type(e).__name__}: {e} | " + " ".join(traceback.format_exc().split()[-30:]))
    cpu = time.process_time() - t
    return sol, exc, cpu


def run_system(case, cfg, variants, settings, log):
    system = build_system(case)
    omega = float(case["params"]["omega"])
    ref, source = reference(case, cfg)
    rows = []
    if ref is None:
        return [], {"id": case["id"], "family": case["family"], "reason": source}
    for name in methods_for(case, variants):
        vopts = variants[name]
        fixed_cpu = None
        for setting in settings:
            sol, exc, cpu = solve_row(system, omega, name, vopts, setting, cfg)
            if setting == "fixed":
                fixed_cpu = cpu
                continue
            target = DEFAULT_ACCURACY if setting == "default" else float(setting)
            row = {"system": case["id"], "family": case["family"], "scaled": case.get("scale") is not None,
                   "method": name, "setting": setting, "accuracy": target, "cpu_s": cpu, "fixed_cpu_s": fixed_cpu,
                   "reference": source, "ref_amplitude": float(np.max(ref))}
            if exc is not None:
                row.update(outcome=exc[0], message=exc[1][:400], diagnosis=exc[0])
            else:
                err = _err(sol.amplitude, ref)
                acc = sol.info.get("accuracy") or {}
                row.update(error=err, success=bool(sol.success), estimate=acc.get("estimate"),
                           estimates=acc.get("estimates"), harmonics=int(sol.harmonics),
                           steps=None if sol.steps is None else int(sol.steps),
                           integrator=sol.info.get("integrator"), event_fallback=bool(sol.info.get("event_fallback")),
                           levels=len(acc.get("levels") or []), message=str(sol.message)[:400])
                if sol.success:
                    row["outcome"] = "within" if err <= target else "OUT"
                    if row["outcome"] == "OUT":
                        row["other_orbit"] = _other_orbit(system, omega, sol, case, cfg, ref, target)
                else:
                    kind, failed, largest, missing = _diagnosis(sol)
                    row.update(outcome="failed", diagnosis=kind, failed_checks=failed, largest_estimate=largest,
                               missing_estimates=missing)
            rows.append(row)
            print(f"    {name:<20} {setting:<8} {row['outcome']:<8} err={row.get('error', float('nan')):.2e} "
                  f"est={row.get('estimate')} cpu={cpu:.2f}s {row.get('diagnosis', '')}", file=log, flush=True)
    return rows, None


def _other_orbit(system, omega, sol, case, cfg, ref, target):
    """True when the exact event-driven flow started from the answer converges to an orbit within ``target`` of
    the answer and outside ``target`` of the reference: the answer is another periodic orbit of the system;
    ``None`` when the flow does not apply (3-D friction) or fails."""
    if case["family"] == "rotating":
        return None
    try:
        ev = mshbm.solve(system, omega, "shooting", integrator="event", guess=sol, stability=False,
                         max_time=float(cfg["max_time_s"]))
    except Exception:  # noqa: BLE001
        return None
    if not ev.success:
        return None
    amp = np.asarray(ev.amplitude, dtype=float)
    return bool(_err(sol.amplitude, amp) <= target < _err(amp, ref))


def warm_up(variants, cfg):
    """One untimed solve of every variant (JIT compilation), on the first impact oscillator."""
    case = {"id": "warm-up", "family": "impact", "scale": None,
            "params": {"zeta": 0.1, "omega": 1.2, "sigma": 0.2, "e": 0.5}}
    system = build_system(case)
    for name, v in variants.items():
        solve_row(system, 1.2, name, v, "default", cfg)
    case = {"id": "warm-up", "family": "rotating", "scale": None,
            "params": {"c": 0.05, "omega": 0.8, "mu": 0.3, "N": 1.0}}
    system = build_system(case)
    for name, v in variants.items():
        if v.get("integrator") != "event":
            solve_row(system, 0.8, name, v, "default", cfg)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--config", default="workflow/accuracy.yaml")
    ap.add_argument("--out", default="results/accuracy")
    ap.add_argument("--quick", action="store_true", help="the quick profile (a few cases, < 60 s CPU)")
    ap.add_argument("--limit", type=int, default=None, help="only the first LIMIT systems (trials)")
    args = ap.parse_args(argv)
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        cfg = load_config(args.config)
    except (OSError, ValueError, yaml.YAMLError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    profile = "quick" if args.quick else "full"
    prof = cfg["profiles"][profile]
    variants = {n: cfg["methods"][n] for n in prof["methods"]}
    accs = [float(a) for a in prof.get("accuracies", cfg["accuracies"])]
    head = ["fixed", "default"] if prof.get("timing", True) else ["default"]
    if prof.get("max_time_s"):  # the profile's solve budget (the references keep max_time_s)
        cfg = dict(cfg, solve_max_time_s=prof["max_time_s"])
    systems = plan_systems(prof)
    if args.limit:
        systems = systems[:args.limit]
    print(f"accuracy ({profile}): {len(systems)} systems, {len(variants)} method variants", file=sys.stderr,
          flush=True)
    warm_up(variants, cfg)
    warm_cpu = time.process_time() - c0
    rows, skipped = [], []
    for i, case in enumerate(systems):
        c1 = time.process_time()
        print(f"  [{i + 1}/{len(systems)}] {case['id']}", file=sys.stderr, flush=True)
        # rotate: one requested accuracy per system, cycled over the systems (the suite's CPU budget)
        settings = head + ([accs[i % len(accs)]] if prof.get("rotate_accuracies") else accs)
        r, skip = run_system(case, cfg, variants, settings, sys.stderr)
        rows += r
        if skip:
            skipped.append(skip)
        print(f"  [{i + 1}/{len(systems)}] {case['id']}: {time.process_time() - c1:.1f} s CPU", file=sys.stderr,
              flush=True)
        _write(args, cfg, profile, prof, variants, accs, systems[:i + 1], skipped, rows, c0, t0, warm_cpu,
               partial=i + 1 < len(systems))
    summary = _write(args, cfg, profile, prof, variants, accs, systems, skipped, rows, c0, t0, warm_cpu, partial=False)
    print(f"accuracy ({profile}): {len(rows)} cases on {summary['systems']} systems, "
          f"{summary['totals']}, {summary['cpu_s']:.1f} s CPU -> {args.out}/summary.{{json,md}}", file=sys.stderr)
    return 0


def _write(args, cfg, profile, prof, variants, accs, systems, skipped, rows, c0, t0, warm_cpu, partial):
    """Write summary.json and summary.md (after every system: a time-limited run leaves its rows)."""
    summary = summarise(rows)
    summary.update(profile=profile, partial=partial, rotate_accuracies=bool(prof.get("rotate_accuracies")), config=str(args.config), accuracies=accs,
                   max_time_s=float(cfg.get("solve_max_time_s", cfg["max_time_s"])),
                   default_accuracy=DEFAULT_ACCURACY, methods=variants,
                   systems=len(systems) - len(skipped), skipped=skipped,
                   systems_by_family={f: len({r["system"] for r in rows if r["family"] == f})
                                      for f in sorted({r["family"] for r in rows})},
                   cpu_s=time.process_time() - c0, warm_up_cpu_s=warm_cpu, wall_time_s=time.perf_counter() - t0,
                   mshbm_version=mshbm.__version__, rows=rows)
    t = summary["totals"]
    # the numbers the paper quotes ({{accuracy.<key>}}, workflow/scripts/paper/build_paper.py)
    summary["numbers"] = {"profile": profile, "partial": partial, "cases": t["cases"], "systems": t["systems"],
                          "within": t["within"], "out": t["OUT"], "failed": t["failed"], "refused": t["refused"],
                          "crash": t["crash"], "methods": len(summary["per_method"]), "cpu_s": summary["cpu_s"],
                          "scaled_systems": len({r["system"] for r in rows if r["scaled"]}),
                          "accuracies": ", ".join(f"{a:g}" for a in accs)}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = jsonable(summary)
    (out / "summary.json").write_text(json.dumps(summary, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    (out / "summary.md").write_text(markdown(summary), encoding="utf-8")
    return summary


if __name__ == "__main__":
    sys.exit(main())
