"""Sweep stress suite of mshbm: frequency-response curves over diverse systems, each method where it applies.

Run by the Snakemake rules ``sweep_stress`` / ``sweep_stress_quick`` (workflow/rules/sweeps.smk) or directly::

    python workflow/scripts/stress/sweeps.py --config workflow/sweeps.yaml [--profile quick] --out results/sweeps
        [--cases NAME,NAME] [--cpu-limit S]

Every case (``<system>/<label>``, workflow/sweeps.yaml) is one :func:`mshbm.sweep` in a child process under a
CPU-time limit, then pointwise :func:`mshbm.solve` checks (:mod:`mshbm_workflow.sweep_runner`); a method that
integrates stiff DOFs in time sweeps the automatic Craig-Bampton reduction (:func:`mshbm_workflow.sweep_systems.
time_reduction`, as ``mshbm sweep`` does for a case file).  Writes
``<out>/summary.json`` (every row, the summary) and ``<out>/summary.md`` (the table and the summary line:
the fraction of sweeps that reached the end of their range, the fraction within the tolerance of their
pointwise solves).  The JSON is rewritten after every case, so an interrupted run keeps its rows.  Exit code
0 when the suite ran (failures of sweeps are its findings, not errors), 2 on a bad configuration.
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # single core

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import multiprocessing  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from pathlib import Path  # noqa: E402

from mshbm.outfile import jsonable  # noqa: E402
from mshbm_workflow import sweep_systems, wfcore  # noqa: E402
from mshbm_workflow.sweep_runner import run_case  # noqa: E402

SCHEMA = Path(__file__).resolve().parents[2] / "schemas" / "sweeps.schema.yaml"


# ----------------------------------------------------------------------------------------- configuration
def load_config(path):
    """Read and validate the suite's configuration; ``ValueError`` names the failing key."""
    cfg = wfcore.load_validated_yaml(path, SCHEMA)
    names = [c["name"] for c in expand(cfg)]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"{path}: cases: duplicate case names {dup}")
    for prof, sel in cfg["profiles"].items():
        if sel != "all":
            unknown = [n for n in sel if n not in names]
            if unknown:
                raise ValueError(f"{path}: profiles.{prof}: unknown cases {unknown}")
    return cfg


def expand(cfg):
    """The cases of the configuration, one dict per sweep: ``name``, ``system``, ``method``, ``label``,
    ``options``, ``omega`` or ``omega_ratio``, ``exact``."""
    out = []
    for entry in cfg["cases"]:
        if entry["system"] not in cfg["systems"]:
            raise ValueError(f"cases: system {entry['system']!r} is not defined under systems")
        for label, opts in entry["methods"].items():
            opts = dict(opts or {})
            method = opts.pop("method", label)
            case = {"name": f"{entry['system']}/{label}", "system": entry["system"], "label": label,
                    "method": method, "options": opts}
            for key in ("omega", "omega_ratio", "exact", "cpu_limit_s", "tolerance"):
                if key in entry:
                    case[key] = entry[key]
            out.append(case)
    return out


def select(cfg, profile, names=None):
    cases = expand(cfg)
    if names:
        wanted = list(names)
        unknown = [n for n in wanted if n not in {c["name"] for c in cases}]
        if unknown:
            raise ValueError(f"--cases: unknown cases {unknown}")
        return [c for c in cases if c["name"] in wanted]
    sel = cfg["profiles"][profile]
    return cases if sel == "all" else [c for c in cases if c["name"] in sel]


# ----------------------------------------------------------------------------------------------- running
def _build(cfg, case):
    """``(system, case, info, reduction)``: the case's system, the case with its range in rad/s, the model's
    description and the automatic reduction its method is swept on (:func:`sweep_systems.time_reduction`)."""
    system, w1, info = sweep_systems.build(cfg["systems"][case["system"]], case["system"])
    case = dict(case)
    if "omega_ratio" in case:
        case["omega"] = [float(r) * w1 for r in case["omega_ratio"]]
    reduction = sweep_systems.time_reduction(system, info, case["method"], case.get("options") or {},
                                             max(case["omega"]))
    if reduction is not None:
        info = dict(info, reduced_dofs=int(reduction.system.n), reduction_modes=reduction.n_modes,
                    reduction="automatic")
    return system, case, info, reduction


def _child(conn, cfg, case, suite, hard_cpu):
    """Child process: build the system, run the case, send the row."""
    try:
        soft, hard = resource.getrlimit(resource.RLIMIT_CPU)
        used = int(math.ceil(time.process_time()))
        limit = used + int(hard_cpu)
        if hard == resource.RLIM_INFINITY or limit < hard:
            resource.setrlimit(resource.RLIMIT_CPU, (limit, hard))
    except (ValueError, OSError):
        pass
    try:
        system, case, info, reduction = _build(cfg, case)
        row = run_case(case, system, suite, reduction)
        row["model"] = info
    except Exception as exc:
        row = {"name": case["name"], "system": case["system"], "method": case["method"],
               "label": case.get("label"), "stop": "error", "success": False, "reached": False, "points": 0,
               "message": f"{type(exc).__name__}: {exc}", "error": traceback.format_exc(limit=8),
               "checks": [], "max_deviation": None, "within": False, "cpu_s": None}
    conn.send(json.dumps(jsonable(row)))
    conn.close()


def run_isolated(cfg, case, suite):
    """One case in a forked child (module docstring); a child that dies or hangs becomes a row saying so."""
    budget = float(case.get("cpu_limit_s", suite["cpu_limit_s"])) + suite["check_budget_s"] + 2 * suite["check_cpu_s"]
    ctx = multiprocessing.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, cfg, case, suite, budget + 60.0))
    t0 = time.perf_counter()
    proc.start()
    send.close()
    row = None
    if recv.poll(budget * float(suite.get("wall_factor", 8)) + 60.0):
        try:
            row = json.loads(recv.recv())
        except (EOFError, OSError):
            row = None
    if proc.is_alive():
        proc.kill()
    proc.join()
    if row is None:
        row = {"name": case["name"], "system": case["system"], "method": case["method"], "label": case.get("label"),
               "stop": "killed", "success": False, "reached": False, "points": 0,
               "message": f"the child process ended without a result (exit code {proc.exitcode}, "
                          f"{time.perf_counter() - t0:.0f} s wall): a crash or a hang beyond the CPU limit",
               "checks": [], "max_deviation": None, "within": False, "cpu_s": None}
    return row


def warmup(cfg):
    """Solve once with each method and integrator on small systems, so that numba compiles in the parent."""
    import mshbm

    t0 = time.process_time()
    osc = sweep_systems.build(cfg["systems"].get("osc-stop") or {"chain": {
        "masses": [1.0], "stiffness": 1.0, "damping": 0.2, "forcing": [{"dof": 0, "amplitude": 1.0}],
        "elements": [{"type": "contact", "at": 0, "gap": 0.2, "restitution": 0.9}]}}, "warmup")[0]
    fric = mshbm.chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.0}],
                       elements=[mshbm.Jenkins(0, mu=0.5, normal_force=0.5, tangential_stiffness=1.0)])
    coul = mshbm.chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.0}],
                       elements=[mshbm.Friction(0, mu=0.5, normal_force=0.5)])
    runs = [(osc, "shooting", {"integrator": "event", "steps": 256}), (osc, "mshbm", {"integrator": "event"}),
            (osc, "mshbm", {"steps": 256}), (osc, "hbm", {}), (osc, "dlft", {}), (fric, "mshbm", {"steps": 256}),
            (fric, "hbm", {}), (coul, "dlft", {}), (coul, "shooting", {"steps": 256})]
    for system, method, opts in runs:
        try:
            mshbm.solve(system, 1.0, method, stability=False, **opts)
            mshbm.sweep(system, 1.0, 1.02, method, stability=False, max_points=3, **opts)
        except Exception as exc:  # the warm-up only compiles; failures show in the cases
            print(f"warm-up {method} {opts}: {type(exc).__name__}: {exc}", flush=True)
    return time.process_time() - t0


# ---------------------------------------------------------------------------------------------- reporting
def summary(rows, tolerance):
    n = len(rows)
    reached = sum(bool(r.get("reached")) for r in rows)
    within = sum(bool(r.get("within")) for r in rows)
    return {"sweeps": n, "reached": reached, "within": within, "tolerance": tolerance,
            "reached_fraction": reached / n if n else None, "within_fraction": within / n if n else None,
            "cpu_s": sum(r.get("cpu_s") or 0.0 for r in rows),
            "checks_cpu_s": sum(r.get("checks_cpu_s") or 0.0 for r in rows)}


def summary_line(s):
    if not s["sweeps"]:
        return "no sweeps"
    return (f"{s['reached']}/{s['sweeps']} sweeps reached the end of their range ({100 * s['reached_fraction']:.0f} %); "
            f"{s['within']}/{s['sweeps']} agree with their pointwise certified solves within "
            f"{100 * s['tolerance']:g} % ({100 * s['within_fraction']:.0f} %); sweeps {s['cpu_s']:.0f} s CPU, "
            f"checks {s['checks_cpu_s']:.0f} s CPU")


def _fmt(v, spec):
    return "–" if v is None else format(v, spec)


def markdown(rows, s, meta):
    lines = [f"# Sweep stress suite ({meta['profile']} profile)", "",
             f"**{summary_line(s)}**", "",
             f"CPU limit per sweep {meta['cpu_limit_s']:g} s; {meta['checks']} pointwise `mshbm.solve` checks per "
             f"sweep (from solve's default start; where that is not certified or lands elsewhere, from the sweep point: "
             f"\"indep. elsewhere\" counts those); deviation = max_i |A_i − A_solve,i| / max_i |A_solve,i| over the "
             f"certified checks (A: amplitude per DOF).  DOFs \"n → m\": swept on the automatic Craig-Bampton "
             f"reduction to m DOFs (stiff time-integrated DOFs), compared on the n DOFs, its estimate in every "
             f"certificate.  Reached: the last point is at omega_end.  Warm-up {meta['warmup_cpu_s']:.0f} s "
             f"CPU (numba compilation, not in the rows).", "",
             "| case | DOFs | range (rad/s) | reached | points | CPU s | max dev. | checks cert. | stop / message |",
             "|---|---:|---|:---:|---:|---:|---:|---:|---|"]
    for r in rows:
        w0, w1 = r.get("omega_start"), r.get("omega_end")
        rng = f"{w0:.4g} → {w1:.4g}" if w0 is not None else "–"
        if r.get("omega_last") is not None and not r.get("reached"):
            rng += f" (last {r['omega_last']:.5g})"
        dev = _fmt(r.get("max_deviation"), ".2e")
        if r.get("exact_deviation") is not None:
            dev += f" (exact {r['exact_deviation']:.1e})"
        msg = str(r.get("message") or "").replace("|", "/").replace("\n", " ")
        if len(msg) > 160:
            msg = msg[:157] + "..."
        checks = f"{r.get('checks_certified', 0)}/{len(r.get('checks') or [])}"
        if r.get("independent_differs"):
            checks += f" ({r['independent_differs']} indep. elsewhere"
            checks += f", {r['coexisting']} coexisting)" if r.get("coexisting") else ")"
        dofs = f"{r.get('dofs', '–')}" + (f" → {r['reduced_dofs']}" if r.get("reduced_dofs") else "")
        lines.append(f"| {r['name']} | {dofs} | {rng} | {'yes' if r.get('reached') else '**no**'} | "
                     f"{r.get('points', 0)} | {_fmt(r.get('cpu_s'), '.1f')} | {dev} | {checks} | "
                     f"{r.get('stop')}: {msg} |")
    lines += ["", "## Checks outside the tolerance or not certified", ""]
    for r in rows:
        tol = r.get("tolerance", meta["tolerance"])
        bad = [c for c in r.get("checks") or [] if c.get("deviation") is None or c["deviation"] > tol]
        for c in bad:
            text = (f"- {r['name']} at omega = {c['omega']:.6g}: deviation {_fmt(c.get('deviation'), '.2e')}"
                    f" (independent {_fmt(c.get('independent_deviation'), '.2e')}, from the sweep point "
                    f"{_fmt(c.get('point_deviation'), '.2e')}); solve: {_short(c.get('message'))}")
            if c.get("coexisting"):
                text += "; coexisting: the solve from the sweep point stays on it, the independent one is another solution"
            if c.get("point_message"):
                text += f"; from the sweep point: {_short(c['point_message'])}"
            lines.append(text)
    return "\n".join(lines) + "\n"


def _short(text, n=200):
    text = str(text or "").replace("\n", " ")
    return text if len(text) <= n else text[:n - 3] + "..."


def write(out, rows, meta):
    s = summary(rows, meta["tolerance"])
    out.mkdir(parents=True, exist_ok=True)
    data = {"meta": meta, "summary": s, "summary_line": summary_line(s), "rows": rows}
    (out / "summary.json").write_text(json.dumps(jsonable(data), indent=1, allow_nan=False) + "\n", encoding="utf-8")
    (out / "summary.md").write_text(markdown(rows, s, meta), encoding="utf-8")
    return s


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", default="workflow/sweeps.yaml")
    p.add_argument("--profile", default="full", choices=["quick", "full"])
    p.add_argument("--cases", default=None, help="comma-separated case names (instead of the profile's)")
    p.add_argument("--cpu-limit", type=float, default=None, help="CPU-time limit of each sweep (s), overrides "
                                                                 "cpu_limit_s")
    p.add_argument("--no-warmup", action="store_true", help="skip the warm-up solves (config warmup)")
    p.add_argument("--render", default=None, metavar="SUMMARY_JSON",
                   help="only rewrite the Markdown of an earlier run's summary.json into --out")
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    if args.render:
        data = json.loads(Path(args.render).read_text(encoding="utf-8"))
        write(Path(args.out), data["rows"], data["meta"])
        return 0
    try:
        cfg = load_config(args.config)
        cases = select(cfg, args.profile, args.cases.split(",") if args.cases else None)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.cpu_limit is not None and not args.cpu_limit > 0:
        print("error: --cpu-limit must be > 0", file=sys.stderr)
        return 2
    suite = {k: cfg[k] for k in ("cpu_limit_s", "checks", "check_cpu_s", "check_budget_s", "tolerance",
                                  "wall_factor")}
    if args.cpu_limit is not None:
        suite["cpu_limit_s"] = float(args.cpu_limit)
        cases = [{k: v for k, v in c.items() if k != "cpu_limit_s"} for c in cases]
    meta = {"profile": args.profile if not args.cases else "selected cases", "config": str(args.config),
            "cases": [c["name"] for c in cases], **suite, "warmup_cpu_s": 0.0}
    out = Path(args.out)
    if cfg.get("warmup", True) and not args.no_warmup:
        meta["warmup_cpu_s"] = warmup(cfg)
        print(f"warm-up: {meta['warmup_cpu_s']:.1f} s CPU", flush=True)
    rows = []
    t0 = time.perf_counter()
    for i, case in enumerate(cases):
        row = run_isolated(cfg, case, suite)
        rows.append(row)
        write(out, rows, meta)
        print(f"[{i + 1}/{len(cases)}] {case['name']}: reached={row.get('reached')} points={row.get('points')} "
              f"cpu={_fmt(row.get('cpu_s'), '.1f')} s max_dev={_fmt(row.get('max_deviation'), '.2e')} "
              f"stop={row.get('stop')}: {str(row.get('message'))[:200]}", flush=True)
    meta["wall_s"] = time.perf_counter() - t0
    s = write(out, rows, meta)
    print(summary_line(s), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
