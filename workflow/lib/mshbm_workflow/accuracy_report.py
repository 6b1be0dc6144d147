"""Counts and Markdown tables of the accuracy suite (workflow/scripts/stress/accuracy.py).

Per method variant: cases (system x setting rows), ``within`` (success within the accuracy), ``OUT`` (success
outside it: the defects), ``failed`` (with the diagnoses counted), ``refused`` (input error), ``crash``; the CPU of
the fixed discretisation (``accuracy=False``) and the median ratio of each setting's CPU to it, per row of the same
system and method.
"""
from __future__ import annotations

import statistics
from collections import Counter

__all__ = ["OUTCOMES", "summarise", "markdown"]

OUTCOMES = ("within", "OUT", "failed", "refused", "crash")


def _setting_key(s):
    return "default" if s == "default" else f"{float(s):g}"


def summarise(rows):
    """``{"totals", "per_method", "out_rows"}`` of the rows."""
    per = {}
    for r in rows:
        m = per.setdefault(r["method"], {"cases": 0, **{o: 0 for o in OUTCOMES}, "diagnoses": Counter(),
                                         "cpu_fixed_s": 0.0, "cpu_s": Counter(), "ratios": {}, "systems": set()})
        m["cases"] += 1
        m[r["outcome"]] += 1
        m["systems"].add(r["system"])
        if r["outcome"] in ("failed", "refused", "crash"):
            m["diagnoses"][r.get("diagnosis") or r["outcome"]] += 1
        key = _setting_key(r["setting"])
        m["cpu_s"][key] += r["cpu_s"]
        if r.get("fixed_cpu_s"):
            m["ratios"].setdefault(key, []).append(r["cpu_s"] / r["fixed_cpu_s"])
    fixed_seen = set()
    for r in rows:
        if r.get("fixed_cpu_s") is not None and (r["system"], r["method"]) not in fixed_seen:
            fixed_seen.add((r["system"], r["method"]))
            per[r["method"]]["cpu_fixed_s"] += r["fixed_cpu_s"]
    for m in per.values():
        m["systems"] = len(m["systems"])
        m["diagnoses"] = dict(m["diagnoses"].most_common())
        m["cpu_s"] = dict(m["cpu_s"])
        m["median_cpu_ratio"] = {k: statistics.median(v) for k, v in m.pop("ratios").items()}
    totals = {"cases": len(rows), **{o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES},
              "systems": len({r["system"] for r in rows})}
    out_rows = [{k: r.get(k) for k in ("system", "method", "setting", "accuracy", "error", "estimate", "estimates",
                                       "harmonics", "steps", "integrator", "other_orbit", "reference")}
                for r in rows if r["outcome"] == "OUT"]
    crashes = [{k: r.get(k) for k in ("system", "method", "setting", "message")} for r in rows if r["outcome"] == "crash"]
    return {"totals": totals, "per_method": per, "out_rows": out_rows, "crashes": crashes,
            "units": unit_mismatches(rows)}


def unit_mismatches(rows, rtol=1e-6):
    """Rows of a unit-scaled copy whose outcome differs from the same (method, setting) row of the original system,
    or whose error differs by more than ``rtol`` (relative, at least 1e-12 absolute), or whose combined estimate
    differs by more than 1e-3 relative (at least 1e-8 absolute): a change of units that changed the answer or its
    certificate."""
    base = {(r["system"], r["method"], str(r["setting"])): r for r in rows if not r["scaled"]}
    out, compared = [], 0
    for r in rows:
        if not r["scaled"]:
            continue
        b = base.get((r["system"].split(" [")[0], r["method"], str(r["setting"])))
        if b is None:
            continue
        compared += 1
        e1, e2 = r.get("error"), b.get("error")
        same_err = (e1 is None and e2 is None) or (e1 is not None and e2 is not None
                                                   and abs(e1 - e2) <= max(rtol * abs(e2), 1e-12))
        s1, s2 = r.get("estimate"), b.get("estimate")
        same_est = (s1 is None) == (s2 is None) and (s1 is None or abs(s1 - s2) <= max(1e-3 * abs(s2), 1e-8))
        if r["outcome"] != b["outcome"] or not same_err or not same_est:
            out.append({"system": r["system"], "method": r["method"], "setting": r["setting"],
                        "outcome": r["outcome"], "base_outcome": b["outcome"], "error": e1, "base_error": e2,
                        "estimate": r.get("estimate"), "base_estimate": b.get("estimate")})
    return {"compared": compared, "mismatches": out}


def _f(x, fmt="{:.3g}"):
    return "–" if x is None else fmt.format(x)


def markdown(s):
    acc = [f"{float(a):g}" for a in s["accuracies"]]
    t = s["totals"]
    lines = [f"# Accuracy suite ({s['profile']} profile{', PARTIAL: the run stopped early' if s.get('partial') else ''})",
             "",
             f"{t['cases']} cases = (system, method, setting) rows on {t['systems']} systems with exact references "
             f"({', '.join(f'{k} {v}' for k, v in s['systems_by_family'].items())}); settings: default "
             f"(accuracy {s['default_accuracy']:g} gates success) and accuracy = {', '.join(acc)}"
             f"{' (one per system, cycled)' if s.get('rotate_accuracies') else ''}; solve budget "
             f"{s['max_time_s']:g} s wall.  "
             f"within: success and error <= accuracy; **OUT: success and error > accuracy (defects)**; "
             f"CPU: time.process_time() per solve, one core; x: median CPU ratio to the fixed discretisation "
             f"(accuracy=False, no estimates) of the same system and method.  Suite CPU {s['cpu_s']:.0f} s.", "",
             "| method | systems | cases | within | OUT | failed | refused | crash | CPU fixed (s) | "
             "CPU default (s) | x default | " + " | ".join(f"x {a}" for a in acc) + " |",
             "|" + "---|" * (11 + len(acc))]
    for name, m in s["per_method"].items():
        r = m["median_cpu_ratio"]
        lines.append(f"| {name} | {m['systems']} | {m['cases']} | {m['within']} | {m['OUT']} | {m['failed']} | "
                     f"{m['refused']} | {m['crash']} | {m['cpu_fixed_s']:.1f} | {m['cpu_s'].get('default', 0.0):.1f} "
                     f"| {_f(r.get('default'), '{:.1f}')} | "
                     + " | ".join(_f(r.get(a), "{:.1f}") for a in acc) + " |")
    lines.append(f"| **total** | {t['systems']} | {t['cases']} | {t['within']} | {t['OUT']} | {t['failed']} | "
                 f"{t['refused']} | {t['crash']} | | | | " + " | ".join("" for _ in acc) + " |")
    lines += ["", "## Failures by diagnosis", "", "| method | diagnosis | rows |", "|---|---|---|"]
    for name, m in s["per_method"].items():
        for d, n in m["diagnoses"].items():
            lines.append(f"| {name} | {d} | {n} |")
    lines += ["", "## Successes outside the accuracy", ""]
    if not s["out_rows"]:
        lines.append("None.")
    else:
        lines += ["| system | method | setting | error | estimate | n_h | steps | integrator | other orbit |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for r in s["out_rows"]:
            lines.append(f"| {r['system']} | {r['method']} | {r['setting']} | {_f(r['error'])} | "
                         f"{_f(r['estimate'])} | {r['harmonics']} | {r['steps']} | {r['integrator']} | "
                         f"{r['other_orbit']} |")
    if s.get("crashes"):
        lines += ["", "## Crashes", "", "| system | method | setting | message |", "|---|---|---|---|"]
        for r in s["crashes"]:
            lines.append(f"| {r['system']} | {r['method']} | {r['setting']} | {(r['message'] or '').split(' | ')[0][:90]} |")
    u = s.get("units") or {}
    lines += ["", "## Unit-scaled copies against the originals", "",
              f"{u.get('compared', 0)} rows of scaled copies compared with the same method and setting on the original "
              f"system; {len(u.get('mismatches', []))} differ in outcome, error (relative 1e-6) or combined estimate "
              f"(relative 1e-3)."]
    if u.get("mismatches"):
        lines += ["", "| system | method | setting | outcome (original) | error (original) | estimate (original) |",
                  "|---|---|---|---|---|---|"]
        for r in u["mismatches"]:
            lines.append(f"| {r['system']} | {r['method']} | {r['setting']} | {r['outcome']} ({r['base_outcome']}) | "
                         f"{_f(r['error'])} ({_f(r['base_error'])}) | {_f(r['estimate'])} ({_f(r['base_estimate'])}) |")
    if s.get("skipped"):
        lines += ["", f"Systems without an exact reference (not run): {len(s['skipped'])} "
                      f"({'; '.join(sorted({x['reason'][:60] for x in s['skipped']}))})."]
    return "\n".join(lines) + "\n"
