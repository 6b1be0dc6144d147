"""Report of the benchmarks: the paper's "Performance" section, its plots and a JSON digest.

Reads the work-precision files (``workprecision_<system>.json``) and the stand-alone
benchmarks (``kernel``, ``scaling``, ``scipy``, ``pyharm``, ``pyharm_sweep``; any may be missing) and writes

* ``workprecision.png`` -- wall time against error, one panel per system, and the speed-up of
  each method over full shooting at equal error;
* ``summary.md`` -- the body of the paper's Performance section (tables; figures as
  ``![caption](benchmarks/<name>.png)`` lines, embedded by build_paper.py);
* ``summary.json`` -- the numbers (targets, ratios) for the paper's checks and the closing note.

Usage: python workflow/scripts/bench/bench_report.py --out-dir results/benchmarks results/benchmarks/*.json
"""
from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
from mshbm_workflow.wfcore import md_table  # noqa: E402

STYLE = {"shooting": ("k", "o", "full shooting"), "mshbm": ("tab:red", "s", "MS-HBM"),
         "mshbm-intermediate": ("tab:orange", "D", "MS-HBM (intermediate)"), "hbm": ("tab:blue", "^", "HBM"),
         "dlft": ("tab:green", "v", "DLFT"),
         # the exact event-driven flow as the integrator (integrator="event")
         "shooting-event": ("k", "*", "full shooting (event)"), "mshbm-event": ("tab:purple", "P", "MS-HBM (event)")}
#: the methods compared with full shooting (Moreau-Jean) at equal error
COMPARED = ("mshbm", "mshbm-intermediate", "hbm", "dlft", "shooting-event", "mshbm-event")
TARGET_SPEEDUP = 20.0


def fmt(x, spec=".2g"):
    return "–" if x is None else format(x, spec)


def point_label(p):
    if p is None:
        return "–"
    if p.get("regularisation_factor") not in (None, 1.0):
        return f"n_H={p['harmonics']}, ×{p['regularisation_factor']:g} reg."
    if p.get("harmonics") is not None:
        return f"n_H={p['harmonics']}, N={p['steps']}"
    return f"N={p['steps']}"


def best_equal_error(d):
    """Largest speed-up of MS-HBM over shooting at an equal error <= the target (from ``targets``)."""
    return (d["targets"].get("mshbm") or {}).get("speedup")


def plot_workprecision(wp, path):
    fig, axes = plt.subplots(2, len(wp), figsize=(4.0 * len(wp), 7.4), squeeze=False)
    for j, d in enumerate(wp):
        ax = axes[0][j]
        for method, (c, mk, label) in STYLE.items():
            rows = [r for r in d["rows"] if r["method"] == method]
            ok = [r for r in rows if r["success"]]
            bad = [r for r in rows if not r["success"]]
            ax.loglog([r["time_s"] for r in ok], [max(r["error"], 1e-12) for r in ok], mk, color=c, ms=7 if mk == "*" else 4,
                      alpha=0.8, label=label)
            if bad:
                ax.loglog([r["time_s"] for r in bad], [max(r["error"], 1e-12) for r in bad], mk, color=c,
                          mfc="none", ms=5, alpha=0.6)
            if method in ("shooting", "mshbm-event") and ok:  # the convergence lines (steps; n_H)
                ok = sorted(ok, key=lambda r: r["steps"] if method == "shooting" else r["harmonics"])
                ax.loglog([r["time_s"] for r in ok], [max(r["error"], 1e-12) for r in ok], "-", color=c, lw=0.7)
        ax.axhline(d["targets"]["target_error"], color="0.5", ls=":", lw=1)
        ax.set_title(f"{d['system']} (n = {d['n']})", fontsize=10)
        ax.set_xlabel("wall time (s), median")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # minor labels overlap on short ranges
        ax.grid(True, which="both", alpha=0.3)
        ax = axes[1][j]
        levels = [e["error_level"] for e in d["targets"]["equal_error"]]
        for method in COMPARED:
            c, mk, label = STYLE[method]
            sp = [(lv, (e.get(method) or {}).get("speedup_over_shooting"))
                  for lv, e in zip(levels, d["targets"]["equal_error"])]
            sp = [(lv, s) for lv, s in sp if s is not None]
            if sp:
                ax.loglog(*zip(*sp), mk + "-", color=c, ms=4, label=label)
        ax.axhline(TARGET_SPEEDUP, color="0.5", ls="--", lw=0.8)
        ax.axhline(1.0, color="0.5", ls=":", lw=0.8)
        ax.invert_xaxis()
        ax.set_xlabel("error level e (reached by both)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("max rel. amplitude error, masses 1 and n\n(vs exact event-driven solution)")
    axes[0][0].legend(fontsize=7, loc="lower left")
    axes[1][0].set_ylabel("speed-up over full shooting\nat equal error (dashed: 20x)")
    axes[1][0].legend(fontsize=7, loc="upper left")
    fig.suptitle("Work-precision against the exact reference (hollow: not converged; dotted: 2 % error)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def section_workprecision(wp, sub):
    lines = ["### Work–precision against the exact reference", ""]
    rows = []
    for d in wp:
        ref = d["reference"]
        conv = ref.get("convergence") or {}
        rows.append((d["system"], d["n"], f"{ref['amplitude'][0]:.8f} / {ref['amplitude'][1]:.8f}",
                     ref["n_events"], fmt(conv.get("max_relative_difference"), ".1e"),
                     fmt(d["targets"].get("shooting_order"), ".2f"), fmt(ref.get("max_floquet_modulus"), ".3f"),
                     f"{ref['time_s']:.2f}"))
    lines += [
        "The reference of every system is the exact periodic solution of the event-driven flow "
        "(`mshbm.methods.exact.exact_periodic`: exact modal flows between stick/slip or impact events, Newton "
        "with the saltation-corrected monodromy matrix). Its convergence is shown by re-solving it with "
        "a 100× tighter tolerance, a 4× finer event-search grid and a 16× coarser seed: the largest "
        "relative amplitude difference of the variants is listed. The observed order of full shooting "
        "(Moreau–Jean, θ = 1/2) against it is the slope of its error over the step count.", "",
        md_table(["system", "n", "exact amplitude, mass 1 / mass n", "events per period",
                  "variants differ by", "observed order of shooting", "max Floquet modulus",
                  "reference time (s)"], rows), ""]
    lines += ["![Work–precision of the four methods on the four benchmark systems, each solve started from "
              "the method's own solution at 0.98 ω (top), and the speed-up of each method over full shooting "
              "at equal error, cheapest converged point of each reaching the error level (bottom).]"
              f"({sub}/workprecision.png)", ""]
    rows = []
    for d in wp:
        for e in d["targets"]["equal_error"]:
            sh = e.get("shooting")
            cells = [d["system"], f"{e['error_level']:g}",
                     "–" if sh is None else f"{sh['time_s'] * 1e3:.3g} ms ({point_label(sh)})"]
            for m in COMPARED:
                p = e.get(m)
                cells.append("–" if p is None else
                             f"{p['time_s'] * 1e3:.3g} ms ({point_label(p)}): **{fmt(p['speedup_over_shooting'], '.3g')}×**"
                             if p["speedup_over_shooting"] is not None else f"{p['time_s'] * 1e3:.3g} ms")
            rows.append(cells)
    lines += ["**Equal-error comparison.** For each error level, the cheapest converged point of each method "
              "that reaches it, and its speed-up over the cheapest full-shooting point that reaches it "
              "(median wall time of repeated solves, one process, numba compilation excluded).", "",
              md_table(["system", "error level", "full shooting", "MS-HBM", "MS-HBM (intermediate)", "HBM", "DLFT",
                        "full shooting (event)", "MS-HBM (event)"], rows),
              ""]
    lines += section_event_goal(wp)
    return lines


def section_event_goal(wp):
    """The event-driven goal per system: MS-HBM (event) at 1e-6 against Moreau-Jean full shooting at 1e-3."""
    goals = [(d["system"], d["targets"].get("event_goal")) for d in wp]
    goals = [(name, g) for name, g in goals if g and g.get("why") != "MS-HBM (event) not in this sweep"]
    if not goals:
        return []
    rows = []
    for name, g in goals:
        ev, sh = g.get("mshbm_event"), g.get("shooting")
        rows.append((name,
                     "–" if ev is None else f"{ev['time_s'] * 1e3:.3g} ms (n_H={ev['harmonics']}, error {ev['error']:.1e})",
                     "–" if sh is None else f"{sh['time_s'] * 1e3:.3g} ms (N={sh['steps']}, error {sh['error']:.1e})",
                     fmt(g.get("ratio"), ".3g"), "yes" if g.get("met") else f"no{'' if 'why' not in g else ': ' + g['why']}"))
    g0 = goals[0][1]
    return [f"**Event-driven integrator.** Time of MS-HBM with the exact event-driven flow to reach "
            f"{g0['mshbm_event_error']:g} relative error against the time of Moreau–Jean full shooting to reach "
            f"{g0['shooting_error']:g}, cheapest converged point of each, same run; ratio = shooting / MS-HBM (event).",
            "", md_table(["system", f"MS-HBM (event) at {g0['mshbm_event_error']:g}",
                          f"full shooting (Moreau–Jean) at {g0['shooting_error']:g}", "ratio", "goal met"], rows), ""]


def section_kernel(k):
    if not k or "measurements" not in k:
        return []
    rows = [(name, f"{m['steps']:,}".replace(",", " "), m["n_dof"], m["n_sensitivity_columns"],
             f"{m['ns_per_step_median']:.3g}", f"{1e3 / m['ns_per_step_median']:.3g}", m["what"])
            for name, m in k["measurements"].items()]
    s = k.get("summary", {})
    return ["### Time-stepping kernel", "",
            "Compiled Moreau–Jean kernel (numba), ns per step (median of interleaved repeats) for the 1-DOF "
            "nonlinear subsystems of MS-HBM (the forcing increments include the condensed harmonic coupling "
            "forces), for the general path and for whole chains (full shooting's cost per step). "
            "Sensitivity columns: derivatives propagated with the state (q0, u0 and the 2 n_H + 1 = 11 coupling "
            "coefficients) for the exact Jacobian. Runs of 2<sup>20</sup> steps stream their output arrays "
            "through memory; MS-HBM uses at most 2<sup>16</sup> steps per period. "
            f"Compiled over its plain NumPy twin: {fmt(s.get('numpy_twin_over_compiled'), '.0f')}×.", "",
            md_table(["case", "steps", "DOFs", "sensitivity columns", "ns / step", "10⁶ steps / s", "what"], rows),
            ""] + section_event_kernel(k)


def section_event_kernel(k):
    """Events per second of the event-driven flow, next to the steps per second above."""
    ev = k.get("event_measurements")
    if not ev:
        return []
    rows = [(name, m["system"], m["n_dof"], m["events_per_period"], f"{m['us_per_period_median'] / 1e3:.3g}",
             fmt(m.get("events_per_second_median"), ".3g"), m["what"]) for name, m in ev.items()]
    return ["Event-driven flow (`mshbm.integrators.event`): one period on the converged orbit "
            "(n_H = 5 for the MS-HBM subsystems), median wall time; its cost is per period (the event search "
            "on the sub-step grid) more than per event, so events per second is the period's events over its "
            "time.", "",
            md_table(["case", "system", "DOFs", "events / period", "ms / period", "events / s", "what"], rows), ""]


def section_scaling(sc, sub):
    if not sc or "summary" not in sc:
        return []
    s = sc["summary"]
    tt = s.get("time_table_s", {})
    sk = s.get("skipped_table", {})
    ns = sorted({int(n) for m in tt.values() for n in m} | {int(n) for m in sk.values() for n in m})
    rows = [[m] + [fmt(tt[m].get(str(n)), ".3g") if str(n) not in sk.get(m, {}) else "not run"
                   for n in ns] for m in tt]
    notes = []
    for m, cells in sk.items():
        if cells:
            first = min(cells, key=int)
            sizes = ", ".join(f"{int(n):,}".replace(",", " ") for n in sorted(cells, key=int))
            notes.append(f"{m} at n = {sizes}: {cells[first]}")
    if s.get("time_at_1e5_s") is not None:
        big = (f"n = 10⁵ solved in {fmt(s.get('time_at_1e5_s'), '.3g')} s (target ≤ 30 s; amplitudes of all DOFs "
               f"from the solution in a further {fmt(s.get('amplitude_eval_at_1e5_s'), '.3g')} s)")
    else:
        big = f"this profile stops at n = {max(ns):,}".replace(",", " ") if ns else "no solve finished"
    lines = ["### Scaling to 10⁵ degrees of freedom", "",
             f"Chain of n masses (light damping 0.01), friction on mass 1, MS-HBM with n_H = 5: fitted cost exponent "
             f"{fmt(s.get('mshbm_exponent_n_ge_1000'), '.2f')} for n ≥ 1000; {big}. Each method runs up to this "
             "profile's largest n for it, if it has one, and is otherwise dropped where the CPU time predicted for the "
             "next n, or that of one solve, exceeds the benchmark's limit (or its memory the memory limit); the "
             "sizes it did not run say so.", "",
             md_table(["method \\ n"] + [f"{n:,}".replace(",", " ") for n in ns], rows), "",
             *([f"Not run: {'; '.join(notes)}.", ""] if notes else []),
             "![Wall time of one solve (set-up included) against the number of masses; the FE membrane "
             f"(general sparse M, C, K) takes the same path.]({sub}/scaling.png)", ""]
    return lines


def section_peers(py, sp):
    lines = ["### Against pyHarm and a SciPy baseline" if py else "### Against a SciPy baseline", ""]
    if py and py.get("status") == "ok":
        rows = []
        for n, c in py["cases"].items():
            if "agreement" not in c:
                rows.append((n, "failed", "", "", "", ""))
                continue
            f = c["from_perturbed_start"]
            a = c["agreement"]
            rows.append((n, f"{max(a['relative_difference_contact_dof'], a['relative_difference_mass_n']):.1e}",
                         f"{f['ours']['median_s'] * 1e3:.3g} / {f['pyharm']['median_s'] * 1e3:.3g} ms: "
                         f"**{f['speedup']:.1f}×**",
                         f"{f['ours_newton_only']['median_s'] * 1e3:.3g} / {f['pyharm_newton_only']['median_s'] * 1e3:.3g}"
                         f" ms: **{f['speedup_newton_only']:.1f}×**",
                         f"{c['residual_jacobian_eval']['speedup']:.1f}×",
                         "fails" if not c["from_linear_start"]["pyharm"]["success"] else "converges"))
        st = py["settings"]
        lines += [f"pyHarm {py.get('pyharm_version') or ''} (its own environment) and our HBM on the same "
                  f"penalty-contact chains (n_H = {st['harmonics']}, {st['aft_samples']} AFT samples, "
                  f"k_c = {st['penalty_stiffness']:g}), both from the same start near the solution; end to end "
                  "= from the system matrices to the solution (our `solve` with its condensation, pyHarm's model "
                  "construction and first FRF point); Newton only = both problems built beforehand; medians over "
                  "alternating blocks of consecutive calls of each code, one BLAS thread (`timing` in pyharm.json).",
                  "",
                  md_table(["masses", "coefficients differ by (rel.)", "end to end, ours / pyHarm",
                            "Newton only, ours / pyHarm", "one residual + Jacobian", "pyHarm's Newton from the linear start"],
                           rows), ""]
    elif py:  # the reason for a reader; the error text with its machine paths stays in pyharm.json
        lines += [f"The pyHarm comparison could not be run here (step that failed: {unavailable_reason(py)}); "
                  "the error is recorded in `benchmarks/pyharm.json`.", ""]
    if sp and "summary" in sp:
        rows = [(name, v.get("n_baseline_points_compared"), fmt(v.get("median_speedup_converged_baselines"), ".0f"),
                 fmt(v.get("min_speedup_converged_baselines"), ".0f"))
                for name, v in sp["summary"].get("per_system", {}).items()]
        lines += ["SciPy baseline: shooting with `solve_ivp` (LSODA, Radau, RK45 at several tolerances) on the "
                  "regularised law and `optimize.root`, against our Moreau shooting and MS-HBM from the same "
                  "(linear) start; speed-up of each baseline point = its time over the cheapest of ours that is at "
                  "least as accurate (errors against the exact solution).", "",
                  md_table(["system", "baseline points", "median speed-up", "smallest speed-up"], rows), ""]
    return lines


def unavailable_reason(py):
    """What failed in the pyHarm benchmark, without paths (``what_failed`` of pyharm.json)."""
    what = py.get("what_failed") or py.get("status") or "unknown"
    return re.sub(r"\s+(?:with|in)\s+\S*/\S*", "", what)


def numbers(wp, other, digest):
    """Flat numbers for the paper's placeholders ``{{benchmarks.<key>}}`` (None: not measured here)."""
    num = {"mshbm_20x_met": digest["mshbm_20x_met"]}
    by = {d["system"]: d for d in wp}
    for name in sorted(set(by) | {"friction3", "friction30", "impact5", "impact50"}):
        d = by.get(name)
        lvl = {e["error_level"]: e for e in d["targets"]["equal_error"]} if d else {}
        at2 = (lvl.get(0.02, {}).get("mshbm") or {}) if d else {}
        num[f"speedup_best_{name}"] = best_equal_error(d) if d else None
        num[f"error_at_best_{name}"] = (d["targets"].get("mshbm") or {}).get("error") if d else None
        num[f"speedup_2pct_{name}"] = at2.get("speedup_over_shooting")
        for tag, level in (("lvl2", 1e-2), ("lvl3", 1e-3), ("lvl4", 1e-4), ("lvl5", 1e-5)):
            p = (lvl.get(level, {}).get("mshbm") or {}) if d else {}
            num[f"speedup_{tag}_{name}"] = p.get("speedup_over_shooting")
        ms = [r for r in d["rows"] if r["method"] == "mshbm"] if d else []
        num[f"mshbm_nearby_failed_{name}"] = (sum(not r["nearby_start_converged"] for r in ms) / len(ms)) if ms else None
        fine = [r["iterations"] for r in ms if r["steps"] >= 4096 and r["success"]]
        num[f"mshbm_iter_min_fine_{name}"] = min(fine) if fine else None  # Newton iterations, >= 4096 steps
        num[f"mshbm_iter_max_fine_{name}"] = max(fine) if fine else None
        num[f"shooting_order_{name}"] = d["targets"].get("shooting_order") if d else None
        hb = [r["error"] for r in d["rows"] if r["method"] == "hbm" and r["success"]] if d else []
        num[f"hbm_best_error_{name}"] = min(hb) if hb else None
        dl = [r for r in d["rows"] if r["method"] == "dlft" and r["success"]] if d else []
        best_dl = min(dl, key=lambda r: r["error"]) if dl else None
        num[f"dlft_best_error_{name}"] = best_dl["error"] if best_dl else None
        num[f"dlft_best_nh_{name}"] = best_dl["harmonics"] if best_dl else None
        num[f"dlft_best_time_{name}"] = best_dl["time_s"] if best_dl else None
        ms_ok = [r for r in ms if r["success"]]
        if best_dl and ms_ok:  # the cheapest MS-HBM point at least as accurate as DLFT's best
            hit = [r for r in ms_ok if r["error"] <= best_dl["error"]]
            num[f"mshbm_time_at_dlft_best_{name}"] = min(r["time_s"] for r in hit) if hit else None
        else:
            num[f"mshbm_time_at_dlft_best_{name}"] = None
        conv = (d["reference"].get("convergence") or {}) if d else {}
        num[f"reference_variants_{name}"] = conv.get("max_relative_difference")
        num[f"reference_events_{name}"] = d["reference"].get("n_events") if d else None
        # the event-driven variants and the goal (MS-HBM (event) at 1e-6 vs shooting at 1e-3)
        g = (d["targets"].get("event_goal") or {}) if d else {}
        num[f"event_goal_ratio_{name}"] = g.get("ratio")
        num[f"event_goal_met_{name}"] = g.get("met")
        num[f"event_goal_mshbm_time_{name}"] = (g.get("mshbm_event") or {}).get("time_s")
        num[f"event_goal_mshbm_nh_{name}"] = (g.get("mshbm_event") or {}).get("harmonics")
        num[f"event_goal_mshbm_error_{name}"] = (g.get("mshbm_event") or {}).get("error")
        num[f"event_goal_shooting_time_{name}"] = (g.get("shooting") or {}).get("time_s")
        num[f"event_goal_shooting_steps_{name}"] = (g.get("shooting") or {}).get("steps")
        num[f"event_goal_shooting_error_{name}"] = (g.get("shooting") or {}).get("error")
        se = [r for r in d["rows"] if r["method"] == "shooting-event" and r["success"]] if d else []
        num[f"shooting_event_error_{name}"] = min(r["error"] for r in se) if se else None
        num[f"shooting_event_time_{name}"] = min(r["time_s"] for r in se) if se else None
        me = [r for r in d["rows"] if r["method"] == "mshbm-event" and r["success"]] if d else []
        best_me = min(me, key=lambda r: r["error"]) if me else None
        num[f"mshbm_event_best_error_{name}"] = best_me["error"] if best_me else None
        num[f"mshbm_event_best_nh_{name}"] = best_me["harmonics"] if best_me else None
        num[f"mshbm_event_best_time_{name}"] = best_me["time_s"] if best_me else None
        sh = [r for r in d["rows"] if r["method"] == "shooting" and r["success"]] if d else []
        best_sh = min(sh, key=lambda r: r["error"]) if sh else None
        num[f"shooting_best_error_{name}"] = best_sh["error"] if best_sh else None
        num[f"shooting_best_time_{name}"] = best_sh["time_s"] if best_sh else None
        num[f"shooting_best_steps_{name}"] = best_sh["steps"] if best_sh else None
    diffs = [v for k, v in num.items() if k.startswith("reference_variants_") and v is not None]
    num["reference_variants_max"] = max(diffs) if diffs else None
    k = (other.get("kernel") or {}).get("summary", {})
    ns = k.get("ns_per_step_1dof", {})
    num.update(kernel_friction_plain_ns=ns.get("1dof_friction_plain"), kernel_contact_plain_ns=ns.get("1dof_contact_plain"),
               kernel_friction_sens_store_ns=ns.get("1dof_friction_sens_store"),
               kernel_contact_sens_store_ns=ns.get("1dof_contact_sens_store"),
               kernel_numpy_ratio=k.get("numpy_twin_over_compiled"))
    meas = (other.get("kernel") or {}).get("measurements", {})
    at16 = [m["ns_per_step_median"] for name, m in meas.items()
            if name.startswith("1dof_friction_sens_store") and m["steps"] == 1 << 16]
    num["kernel_friction_sens_store_2p16_ns"] = at16[0] if at16 else None
    big = [m["steps"] for name, m in meas.items() if name == "1dof_friction_sens_store"]
    num["kernel_long_run_steps"] = big[0] if big else None
    ev = (other.get("kernel") or {}).get("event_measurements", {})  # the event-driven flow: events per second
    for key in ("event_1dof_friction_plain", "event_1dof_contact_plain", "event_1dof_friction_jac_fourier",
                "event_1dof_contact_jac_fourier", "event_full3_friction_jac", "event_full5_contact_jac"):
        m = ev.get(key) or {}
        num[f"kernel_{key}_events_per_s"] = m.get("events_per_second_median")
        num[f"kernel_{key}_ms_per_period"] = (m["us_per_period_median"] / 1e3) if m else None
        num[f"kernel_{key}_events_per_period"] = m.get("events_per_period")
        # the same time in compiled Moreau-Jean steps of the 1-DOF subsystem (the plain kernel for the plain
        # flow, the kernel storing its sensitivities for the flow with Jacobian)
        kind = "sens_store" if "jac" in key else "plain"
        mj = num[f"kernel_{'contact' if 'contact' in key else 'friction'}_{kind}_ns"]
        num[f"kernel_{key}_mj_steps"] = (int(round(m["us_per_period_median"] * 1e3 / mj)) if m and mj else None)
    sc = (other.get("scaling") or {}).get("summary", {})
    num.update(scaling_time_1e5_s=sc.get("time_at_1e5_s"), scaling_exponent=sc.get("mshbm_exponent_n_ge_1000"),
               scaling_amplitude_1e5_s=sc.get("amplitude_eval_at_1e5_s"))
    py = other.get("pyharm") or {}
    ok = py.get("status") == "ok"
    ps = py.get("summary", {}) if ok else {}
    num.update(pyharm_available=ok,
               pyharm_agreement=ps.get("max_relative_difference"),
               pyharm_speedup_min=min(ps["speedups_same_start"]) if ps.get("speedups_same_start") else None,
               pyharm_speedup_max=max(ps["speedups_same_start"]) if ps.get("speedups_same_start") else None,
               pyharm_newton_speedup_min=min(ps["speedups_newton_only"]) if ps.get("speedups_newton_only") else None)
    sw = other.get("pyharm_sweep") or {}  # branch tracing against pyHarm's continuation
    num["pyharm_sweep_available"] = sw.get("status") in ("ok", "partial")
    budget = (sw.get("settings") or {}).get("pyharm_cpu_budget_s")  # a number in older files: one fixed budget
    budget = budget if isinstance(budget, dict) else {"max": budget, "factor_of_twin": None, "min": None}
    num.update(sweep_pyharm_budget_factor=budget.get("factor_of_twin"), sweep_pyharm_budget_min_s=budget.get("min"),
               sweep_pyharm_budget_max_s=budget.get("max"))
    spent = [r.get("reach_fraction") for s in ((sw.get("summary") or {}).get("per_system") or {}).values()
             for r in (s.get("branches") or {}).values() if str(r.get("stop", "")).startswith("CPU-time budget")]
    # the largest fraction of its points a budget-limited pyHarm run had passed when it first came within 1e-4
    # of the omega where it ended (0: no run spent its budget; None: not recorded)
    num["sweep_pyharm_budget_reach_fraction"] = (max(spent) if spent and None not in spent else
                                                 (0.0 if not spent else None))
    for system, s in ((sw.get("summary") or {}).get("per_system") or {}).items():
        for name, r in (s.get("branches") or {}).items():
            key = f"sweep_{system}_{re.sub(r'[^A-Za-z0-9]+', '_', name)}"  # e.g. sweep_impact5_pyharm_penalty_ours
            num.update({f"{key}_time_s": r.get("wall_time_s"), f"{key}_cpu_s": r.get("cpu_time_s"),
                        f"{key}_points": r.get("points"),
                        f"{key}_omega_reached": r.get("omega_reached"), f"{key}_budget_s": r.get("cpu_budget_s")})
    sp = (other.get("scipy") or {}).get("summary", {})
    num.update(scipy_median_speedup=sp.get("median_speedup"), scipy_min_speedup=sp.get("min_speedup"))
    return num


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("files", nargs="+")
    args = ap.parse_args(argv)
    out = Path(args.out_dir)
    wp = [json.loads(Path(f).read_text()) for f in args.files if Path(f).name.startswith("workprecision_")]
    other = {Path(f).stem: json.loads(Path(f).read_text()) for f in args.files
             if not Path(f).name.startswith("workprecision_")}
    plot_workprecision(wp, out / "workprecision.png")

    sub = out.name  # figure paths relative to the results directory (build_paper.py embeds them)
    lines = section_workprecision(wp, sub)
    lines += section_kernel(other.get("kernel"))
    lines += section_scaling(other.get("scaling"), sub)
    lines += section_peers(other.get("pyharm"), other.get("scipy"))
    (out / "summary.md").write_text("\n".join(lines) + "\n")

    digest = {"workprecision": {d["system"]: {"best_mshbm_speedup_equal_error": best_equal_error(d),
                                              "targets": d["targets"],
                                              "reference_convergence": d["reference"].get("convergence")}
                                for d in wp}}
    big = [d for d in wp if d["n"] >= 30]
    digest["mshbm_20x_met"] = bool(big) and all((best_equal_error(d) or 0) >= TARGET_SPEEDUP for d in big)
    for k, v in other.items():
        digest[k] = v.get("summary", {"status": v.get("status")})
    digest["numbers"] = numbers(wp, other, digest)
    (out / "summary.json").write_text(json.dumps(digest, indent=1))


if __name__ == "__main__":
    main()
