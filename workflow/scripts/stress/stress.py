"""Stress suite of mshbm: numerical stability, stiff settings, poor starts, random systems.

Run by the Snakemake rule ``stress`` (workflow/rules/stress.smk) or directly::

    python workflow/scripts/stress/stress.py --config workflow/stress.yaml [--quick] --out results/stress [--jobs 2]

Writes ``<out>/summary.json`` (every row, counts, convergence rates from poor starts) and
``<out>/summary.md`` (Markdown tables for the paper).  Each row is one solve: case, method,
options, outcome, residual, error against the reference, wall time.  Outcomes:

* ``converged`` -- success=True and the amplitudes agree with the reference within the method's
  tolerance (or no reference exists: column ``reference`` says so);
* ``failed-with-diagnosis`` -- success=False with a message, or :class:`mshbm.InputError` naming a key
  (e.g. ``omega`` on an exactly singular ``H_LL``);
* ``failed-certificate`` -- Newton converged but the certificate (:mod:`mshbm.certificate`) refused the
  answer: success=False with a message naming the failed checks (column ``certificate``);
* ``truncation-warned`` -- success=True and certified, the error exceeds the tolerance, but the certificate
  warned that the harmonic truncation error may exceed its bound (named in the message), and the same method with
  more harmonics, started from the answer, agrees with the reference (the error is that truncation);
* ``WRONG`` -- success=True but the error exceeds the tolerance, the residual re-evaluated from the
  unknowns contradicts the claim, NaN/inf or garbage in the solution; or an unexpected exception
  (a crash instead of a diagnosis); or success=False without a message.

References: full shooting with ``reference.steps`` steps at the same omega (from the linear start);
when that fails or disagrees, full shooting started from the solution under test (which then is a
genuine periodic solution of the system, possibly one of several coexisting ones); then shooting at
nearby frequencies; then the same method at a nearby frequency (tolerance + ``nearby_allowance``);
else "no reference".  Systems with more than ``reference.max_dofs`` DOFs use the same method with
``reference.highres_harmonics_factor`` times the harmonics and twice the steps.
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one thread per worker; the workers run side by side

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import multiprocessing  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import yaml  # noqa: E402

import mshbm  # noqa: E402
from mshbm.outfile import jsonable  # noqa: E402
from mshbm_workflow.stress_cases import load_config, load_system, plan, random_system  # noqa: E402
from mshbm_workflow.stress_judge import OUTCOMES, Ctx, run_solve, solve_and_evaluate  # noqa: E402
from mshbm_workflow.stress_report import markdown, start_rates  # noqa: E402


# ----------------------------------------------------------------------------- groups of work
def group_resonance(ctx, sysname, omega, tag, methods):
    system = load_system(ctx.cfg, sysname)
    rows, cache = [], {}
    for method, mo in methods.items():
        mo = dict(mo)
        if method == "shooting" and system.n > mo.pop("max_dofs", 10 ** 9):
            continue
        mo.pop("max_dofs", None)
        row, _ = solve_and_evaluate(ctx, "resonance", sysname, system, omega, method, mo, cache, point=tag)
        rows.append(row)
    return rows


def group_stiff(ctx, kind, spec, value, omega):
    cfg = ctx.cfg
    sysname = spec["system"]
    rows, cache = [], {}
    if kind == "kappa":
        system = load_system(cfg, sysname, kappa=value)
        row, _ = solve_and_evaluate(ctx, "stiff", sysname, system, omega, "hbm", {"harmonics": spec["harmonics"]},
                                    cache, point=f"kappa={value:g}")
        rows.append(row)
    elif kind == "penalty":
        system = load_system(cfg, sysname, penalty=value)
        row, _ = solve_and_evaluate(ctx, "stiff", sysname, system, omega, "hbm", {"harmonics": spec["harmonics"]},
                                    cache, point=f"k_c={value:g}")
        rows.append(row)
    elif kind == "harmonics":
        system = load_system(cfg, sysname)
        method, n_h = value
        opts = {"harmonics": n_h}
        if method != "hbm":
            opts["steps"] = max(spec["steps"], 4 * n_h + 4)
        row, _ = solve_and_evaluate(ctx, "stiff", sysname, system, omega, method, opts, cache, point=f"n_h={n_h}")
        rows.append(row)
    elif kind == "steps":
        system = load_system(cfg, sysname)
        method, steps = value
        opts = {"steps": steps}
        if method != "shooting":
            opts["harmonics"] = spec["harmonics"]
        row, _ = solve_and_evaluate(ctx, "stiff", sysname, system, omega, method, opts, cache, point=f"N=2^{int(round(math.log2(steps)))}")
        rows.append(row)
    return rows


def group_starts(ctx, sysname, omega, method, mopts, starts, random=None):
    """Poor starts with and without continuation; the far guesses are the method's own solutions."""
    if random is not None:
        rng = np.random.default_rng([random["seed"], 1000 + random["index"]])
        system, omega, desc = random_system(rng, random["index"], random["max_dofs"])
        system.name = sysname
    else:
        system = load_system(ctx.cfg, sysname)
    rows, cache = [], {}
    guesses = {}
    for s in starts:
        if s in ("zero", "linear"):
            guesses[s] = s
        else:
            om_g = omega * (0.5 if s == "half" else 2.0)
            g, exc, _ = run_solve(ctx, system, om_g, method, dict(mopts))
            guesses[s] = g if g is not None else "zero"
    for s in starts:
        for cont in (False, True):
            opts = dict(mopts)
            opts["guess"] = guesses[s]
            row, _ = solve_and_evaluate(ctx, "starts", sysname, system, omega, method, opts, cache,
                                        use_continuation=cont, start=s,
                                        guess_converged=bool(getattr(guesses[s], "success", True)))
            rows.append(row)
    return rows


def group_random(ctx, index, seed, max_dofs, methods):
    rng = np.random.default_rng([seed, index])
    system, omega, desc = random_system(rng, index, max_dofs)
    rows, cache = [], {}
    for method, mo in methods.items():
        mo = dict(mo)
        if system.n > mo.pop("max_dofs", 10 ** 9):
            continue
        row, _ = solve_and_evaluate(ctx, "random", system.name, system, omega, method, mo, cache, point=desc)
        rows.append(row)
    return rows


def _alarm(signum, frame):
    raise TimeoutError("group timed out")


def run_group(args):
    """Worker entry: ``(ctx, name, kwargs) -> rows`` with a wall-clock limit."""
    ctx, fname, kwargs, label = args
    fn = globals()[fname]
    t0 = time.perf_counter()
    # the solves of the group get wall-time budgets (run_solve: max_time) that end group_reserve_s before the alarm
    ctx.group_deadline = t0 + float(ctx.cfg["group_timeout_s"]) - float(ctx.cfg.get("group_reserve_s", 0.0))
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(int(math.ceil(ctx.cfg["group_timeout_s"])))
    try:
        rows = fn(ctx, **kwargs)
    except TimeoutError:
        rows = [{"category": label[0], "case": label[1], "omega": label[2], "method": "(group)", "options": "",
                 "outcome": "failed-with-diagnosis", "residual": None, "error": None, "reference": "",
                 "message": f"stress harness: group exceeded {ctx.cfg['group_timeout_s']} s", "timeout": True}]
    except Exception as exc:  # noqa: BLE001 -- a crash of the harness or the library: a WRONG row
        rows = [{"category": label[0], "case": label[1], "omega": label[2], "method": "(group)", "options": "",
                 "outcome": "WRONG", "residual": None, "error": None, "reference": "",
                 "message": f"crash: {type(exc).__name__}: {exc} | " + " ".join(traceback.format_exc().split()[-40:])}]
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    for r in rows:
        r.setdefault("time_s", None)
    return label, rows, time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--config", default="workflow/stress.yaml")
    ap.add_argument("--out", default="results/stress")
    ap.add_argument("--quick", action="store_true", help="the quick profile (a few points per category)")
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--only", default=None, help="run only this category (resonance, stiff, starts, random)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    try:
        cfg = load_config(args.config)
    except (OSError, ValueError, yaml.YAMLError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    profile = "quick" if args.quick else "full"
    groups = plan(cfg, profile)
    if args.only:
        groups = [g for g in groups if g[2][0] == args.only]
    ctx = Ctx(cfg)
    work = [(ctx, f, kw, label) for f, kw, label in groups]
    # the expensive groups first (better packing on few workers)
    order = sorted(range(len(work)), key=lambda i: -_cost_hint(work[i]))
    results = [None] * len(work)
    jobs = max(1, int(args.jobs))
    print(f"stress ({profile}): {len(work)} groups on {jobs} worker(s)", file=sys.stderr, flush=True)
    if jobs == 1:
        for i in order:
            results[i] = run_group(work[i])
            _progress(results[i])
    else:
        ctx_mp = multiprocessing.get_context("fork")
        with ctx_mp.Pool(jobs, maxtasksperchild=20) as pool:
            for i, res in zip(order, pool.imap(run_group, [work[i] for i in order])):
                results[i] = res
                _progress(res)
    rows = [r for _, rs, _ in results for r in rs]
    counts = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES}
    summary = {"profile": profile, "config": str(args.config), "jobs": jobs, "tolerance": cfg["tolerance"],
               "error_floor": cfg["error_floor"], "few_harmonics": cfg.get("few_harmonics"),
               "counts": counts, "rows": rows, "start_rates": start_rates(rows),
               "timeouts": sum(bool(r.get("timeout")) for r in rows),
               "wall_time_s": time.perf_counter() - t0,
               "group_times_s": [{"label": list(lbl), "time_s": t} for lbl, _, t in results],
               "mshbm_version": mshbm.__version__}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = jsonable(summary)
    (out / "summary.json").write_text(json.dumps(summary, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    (out / "summary.md").write_text(markdown(summary), encoding="utf-8")
    print(f"stress ({profile}): {len(rows)} rows, {counts}, {summary['wall_time_s']:.1f} s -> {out}/summary.{{json,md}}",
          file=sys.stderr)
    return 0


def _cost_hint(item):
    _, fname, kw, _ = item
    if fname == "group_stiff" and kw["kind"] == "steps":
        return kw["value"][1] / 1000.0
    if fname == "group_starts":
        return 50.0
    if fname == "group_random":
        return 20.0
    return 1.0


def _progress(res):
    label, rows, t = res
    bad = [r for r in rows if r["outcome"] == "WRONG"]
    print(f"  {label[0]:<9} {label[1]:<10} {'' if label[2] is None else f'{label[2]:.6g}':<10} {t:6.1f} s"
          f"{'  WRONG: ' + '; '.join(r['method'] + ' ' + r['message'][:100] for r in bad) if bad else ''}",
          file=sys.stderr, flush=True)


if __name__ == "__main__":
    sys.exit(main())
