"""Section 3.3 of the paper (MS-HBM with an intermediate subsystem) on a system where it applies.

The paper introduces the variant for systems whose nonlinear subsystem 1 couples to the large
linear remainder 3 only through a small intermediate subsystem 2 (``M_13 = C_13 = K_13 = 0``) with

    dim(q_3) >> dim(q_1) > dim(q_2)                                          (31)

e.g. "a chain of n masses, where the first n_1 masses are subjected to friction and the mass
n_1 + 1 acts as intermediate subsystem".  This script builds exactly that chain (config
``intermediate_demo``) for each ``friction_masses`` value n_1 and solves it with

* ``mshbm`` (Section 3.2): unknowns q_hat of the n_1 friction masses and their initial state,
  ``n_1 (2 n_H + 1) + 2 n_1``;
* ``mshbm-intermediate`` (Section 3.3): unknowns q_hat of the one intermediate mass and the
  initial state of the friction masses, ``(2 n_H + 1) + 2 n_1``;

for every n_H and step count of the grid, from the linear response at omega, timed as the median of
``repeats`` solves after one untimed warm-up solve (CPU time of this single-threaded process, robust
to other processes on a shared machine; the wall times are recorded too).  Both integrate the same n_1 masses with the same
Moreau-Jean steps; they differ in the harmonic unknowns and hence in the sensitivity columns of the
exact Jacobian and the size of the Newton system.  The error is the largest relative amplitude error of
the friction masses and of the last mass against full shooting with ``reference_steps`` steps (the
exact event-driven solver handles one element only); that reference's own error is estimated from a
second full shooting with half the steps (order 2: error ~ |A_N - A_N/2| / 3).

Writes ``--out`` (JSON: rows, numbers for the paper under ``numbers``) and ``--table`` (Markdown).

    python workflow/scripts/solves/intermediate_demo.py --config results/config.json \
        --out results/summary/intermediate.json --table results/tables/intermediate.md
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

from mshbm_workflow import wfcore  # noqa: E402

import mshbm  # noqa: E402
from mshbm import Friction, chain  # noqa: E402
from mshbm.integrators.moreau_jean import WORK  # noqa: E402

METHODS = ("mshbm", "mshbm-intermediate")


def build(dcfg, n1):
    """The chain of ``dcfg`` with dry friction on its first ``n1`` masses (forcing on the last)."""
    n = int(dcfg["n"])
    f = dcfg["friction"]
    els = [Friction(dof=i, mu=float(f["mu"]), normal_force=float(f["normal_force"]), smoothing=800.0)
           for i in range(n1)]
    return chain([float(dcfg["mass"])] * n, float(dcfg["stiffness"]), float(dcfg["damping"]),
                 forcing=[{"dof": n - 1, "amplitude": float(dcfg["forcing_amplitude"])}], elements=els,
                 name=f"chain{n}_friction{n1}")


def measure(system, omega, method, n_h, steps, repeats, tol, max_iter):
    """Warm-up solve, then ``repeats`` timed solves from the linear response; counts of the last one."""
    # Newton from the linear response for both variants (not the start ladder, whose attempts would make
    # the counts depend on which starts each variant needs); the timed solves skip the stability analysis
    # (and no error estimates: their re-solves would be counted; the errors are measured against the reference)
    kw = dict(harmonics=n_h, steps=steps, tol=tol, max_iter=max_iter, guess="linear", stability=False, accuracy=False)
    mshbm.solve(system, omega, method, **kw)
    times, cpus, sol, work = [], [], None, None
    for _ in range(repeats):
        w0 = dict(WORK)
        c0, t0 = time.process_time(), time.perf_counter()
        sol = mshbm.solve(system, omega, method, **kw)
        times.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
        work = {k: int(WORK[k] - w0[k]) for k in WORK}
    return sol, times, cpus, work


def errors(sol, ref, dofs):
    a, b = sol.amplitude[dofs], ref.amplitude[dofs]
    return float(np.max(np.abs(a / b - 1.0)))


def run(config, log=print):
    dcfg = config["intermediate_demo"]
    num_cfg = config["numerics"]
    omega = wfcore.omega(config)
    tol, max_iter = float(num_cfg["tol"]), int(num_cfg["max_iter"])
    repeats = int(dcfg["repeats"])
    rows, cases = [], {}
    load0 = os.getloadavg()
    for n1 in dcfg["friction_masses"]:
        system = build(dcfg, int(n1))
        n = system.n
        dofs = list(range(int(n1))) + [n - 1]
        t0 = time.perf_counter()
        ref = mshbm.solve(system, omega, "shooting", steps=int(dcfg["reference_steps"]), tol=tol, max_iter=max_iter)
        half = mshbm.solve(system, omega, "shooting", steps=int(dcfg["reference_steps"]) // 2, guess=ref, tol=tol,
                           max_iter=max_iter)
        ref_time = time.perf_counter() - t0
        if not ref.success:
            raise SystemExit(f"reference full shooting failed for n_1 = {n1}: {ref.message}")
        ref_err = errors(half, ref, dofs) / 3.0 if half.success else None
        stick = ref.info.get("stick_or_closed_fraction")
        log(f"n_1 = {n1}: reference {ref.message} ({ref_time:.1f} s), estimated error {ref_err}, stick {stick}")
        cases[str(n1)] = {"n": n, "n1": int(n1), "reference_message": ref.message,
                          "reference_error_estimate": ref_err,
                          "stick_fraction": [float(x) for x in stick] if stick else None,
                          "amplitude_reference": [float(ref.amplitude[d]) for d in dofs]}
        for n_h in dcfg["harmonics"]:
            for steps in dcfg["steps"]:
                sols = {}
                for method in METHODS:
                    sol, times, cpus, work = measure(system, omega, method, int(n_h), int(steps), repeats, tol,
                                                     max_iter)
                    sols[method] = sol
                    part = sol.partition.as_dict() if sol.partition is not None else {}
                    row = {"friction_masses": int(n1), "method": method, "harmonics": int(n_h), "steps": int(steps),
                           "success": bool(sol.success), "message": sol.message,
                           "unknowns": int(sol.x.size), "iterations": int(sol.iterations), "nfev": int(sol.nfev),
                           # the compared time: CPU time of this single-threaded process (on a shared
                           # machine the wall time of millisecond solves measures the scheduler)
                           "time_s": float(statistics.median(cpus)), "cpu_times_s": [float(t) for t in cpus],
                           "wall_time_s": float(statistics.median(times)), "wall_times_s": [float(t) for t in times],
                           "work": work, "partition": part,
                           "error": errors(sol, ref, dofs) if sol.success else None}
                    rows.append(row)
                    log(f"  n_1={n1} {method:19s} n_H={n_h:3d} N={steps:6d}: ok={sol.success} it={sol.iterations} "
                        f"x={sol.x.size} t={row['time_s']:.4f}s err={row['error']}")
                a, b = sols["mshbm"], sols["mshbm-intermediate"]
                if a.success and b.success:
                    rows[-1]["difference_to_mshbm"] = float(np.max(np.abs(b.amplitude / a.amplitude - 1.0)))
    load1 = os.getloadavg()
    return rows, cases, {"cpus": os.cpu_count(), "loadavg_start": list(load0), "loadavg_end": list(load1),
                         "python": platform.python_version(), "mshbm": mshbm.__version__}


def pairs(rows):
    """(mshbm row, intermediate row) of every grid point where both converged."""
    by = {(r["friction_masses"], r["method"], r["harmonics"], r["steps"]): r for r in rows}
    out = []
    for (n1, m, nh, N), r in by.items():
        if m != "mshbm":
            continue
        s = by.get((n1, "mshbm-intermediate", nh, N))
        if s and r["success"] and s["success"]:
            out.append((r, s))
    return out


def numbers(rows, cases, dcfg, machine):
    num = {"n": int(dcfg["n"]), "friction_masses": ", ".join(str(x) for x in dcfg["friction_masses"]),
           "nh_max": max(dcfg["harmonics"]), "nh_min": min(dcfg["harmonics"]),
           "steps_list": ", ".join(str(x) for x in dcfg["steps"]), "reference_steps": int(dcfg["reference_steps"]),
           "converged": sum(r["success"] for r in rows), "solves": len(rows),
           "loadavg_begin": machine["loadavg_start"][0], "loadavg_end": machine["loadavg_end"][0],
           "cpus": machine["cpus"]}
    pp = pairs(rows)
    num["max_difference"] = max((s.get("difference_to_mshbm", 0.0) for _, s in pp), default=None)
    num["same_iterations"] = all(r["iterations"] == s["iterations"] and r["nfev"] == s["nfev"] for r, s in pp)
    for n1 in dcfg["friction_masses"]:
        sub = [(r, s) for r, s in pp if r["friction_masses"] == n1]
        tag = f"n1_{n1}"
        c = cases[str(n1)]
        num[f"reference_error_{tag}"] = c["reference_error_estimate"]
        num[f"stick_max_{tag}"] = max(c["stick_fraction"]) if c["stick_fraction"] else None
        if not sub:
            continue
        sp = [(r["time_s"] / s["time_s"], r, s) for r, s in sub]
        best = max(sp, key=lambda x: x[0])
        worst = min(sp, key=lambda x: x[0])
        top = [x for x in sp if x[1]["harmonics"] == max(dcfg["harmonics"])]
        low = [x for x in sp if x[1]["harmonics"] == min(dcfg["harmonics"])]
        num.update({f"speedup_max_{tag}": best[0], f"speedup_max_nh_{tag}": best[1]["harmonics"],
                    f"speedup_max_steps_{tag}": best[1]["steps"],
                    f"speedup_min_{tag}": worst[0], f"speedup_min_nh_{tag}": worst[1]["harmonics"],
                    f"speedup_min_steps_{tag}": worst[1]["steps"],
                    f"speedup_nhmax_{tag}": max(x[0] for x in top) if top else None,
                    f"speedup_nhmin_{tag}": min(x[0] for x in low) if low else None,
                    f"unknowns_mshbm_nhmax_{tag}": top[0][1]["unknowns"] if top else None,
                    f"unknowns_inter_nhmax_{tag}": top[0][2]["unknowns"] if top else None,
                    f"sens_ratio_nhmax_{tag}": (top[0][1]["work"]["sensitivity_steps"]
                                                / top[0][2]["work"]["sensitivity_steps"])
                    if top and top[0][2]["work"]["sensitivity_steps"] else None,
                    f"err_min_{tag}": min(r["error"] for r, _ in sub),
                    f"err_max_{tag}": max(r["error"] for r, _ in sub)})
    # the same numbers under fixed names for the text: `one` = the smallest n_1 (1: the paper's chain, where
    # (31) fails), `big` = the largest n_1 of the configuration
    for alias, n1 in (("one", min(dcfg["friction_masses"])), ("big", max(dcfg["friction_masses"]))):
        num[f"n1_{alias}"] = int(n1)
        for key in list(num):
            if key.endswith(f"_n1_{n1}"):
                num[key[: -len(f"_n1_{n1}")] + f"_{alias}"] = num[key]
    return num


def table(rows):
    by = {(r["friction_masses"], r["method"], r["harmonics"], r["steps"]): r for r in rows}
    lines = []
    for (n1, m, nh, N), r in sorted(by.items()):
        if m != "mshbm":
            continue
        s = by.get((n1, "mshbm-intermediate", nh, N), {})
        def cell(x, key, f):
            return f(x[key]) if x and x.get("success") and x.get(key) is not None else "–"
        ratio = (f"{r['time_s'] / s['time_s']:.2f}" if r.get("success") and s.get("success") else "–")
        lines.append((n1, nh, N,
                      f"{cell(r, 'unknowns', str)} / {cell(s, 'unknowns', str)}",
                      f"{cell(r, 'iterations', str)} / {cell(s, 'iterations', str)}",
                      f"{cell(r, 'nfev', str)} / {cell(s, 'nfev', str)}",
                      f"{r['work']['sensitivity_steps'] / 1e6:.3g} / {s['work']['sensitivity_steps'] / 1e6:.3g}"
                      if r.get("success") and s.get("success") else "–",
                      cell(r, "error", lambda v: f"{v:.2e}"),
                      f"{cell(r, 'time_s', lambda v: f'{1e3 * v:.3g}')} / {cell(s, 'time_s', lambda v: f'{1e3 * v:.3g}')}",
                      ratio))
    return wfcore.md_table(["friction masses $n_1$", "$n_H$", "steps $N$", "unknowns (3.2 / 3.3)", "Newton it.",
                            "residual eval.", "sensitivity steps, 10⁶", "error (both)", "CPU time, ms (3.2 / 3.3)",
                            "speed-up of 3.3"], lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--table", required=True)
    args = ap.parse_args(argv)
    text = Path(args.config).read_text()
    if args.config.endswith(".json"):
        config = json.loads(text)
    else:
        import yaml
        config = yaml.safe_load(text)
    rows, cases, machine = run(config)
    dcfg = config["intermediate_demo"]
    out = {"figure": "intermediate", "config": dcfg, "machine": machine, "cases": cases, "rows": rows,
           "numbers": numbers(rows, cases, dcfg, machine), "claims": []}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1))
    Path(args.table).parent.mkdir(parents=True, exist_ok=True)
    Path(args.table).write_text(table(rows) + "\n")


if __name__ == "__main__":
    main()
