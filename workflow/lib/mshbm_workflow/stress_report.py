"""Stress suite (workflow/scripts/stress/stress.py): the report -- convergence rates from poor starts and
the Markdown tables of ``summary.md``."""
from __future__ import annotations

import math


def start_rates(rows):
    """Convergence rates from poor starts per (method, start, with/without continuation).

    ``rate`` counts every problem; ``rate_solvable`` only the problems (case, omega, method) where at
    least one start (with or without continuation) converged.
    """
    solvable = set()
    for r in rows:
        if r["category"] == "starts" and r["outcome"] == "converged":
            solvable.add((r["case"], r["omega"], r["method"]))
    rates = {}
    for r in rows:
        if r["category"] != "starts" or r["method"] == "(group)":
            continue
        key = (r["method"], r["start"], "with" if "continuation" in r["options"] else "without")
        c = rates.setdefault(key, [0, 0, 0, 0])
        ok = r["outcome"] == "converged"
        c[0] += ok
        c[1] += 1
        if (r["case"], r["omega"], r["method"]) in solvable:
            c[2] += ok
            c[3] += 1
    out = []
    for (m, s, w), (ok, tot, oks, tots) in sorted(rates.items()):
        out.append({"method": m, "start": s, "continuation": w, "converged": ok, "total": tot,
                    "rate": ok / tot if tot else None, "converged_solvable": oks, "solvable": tots,
                    "rate_solvable": oks / tots if tots else None})
    return out


def _fmt(x, spec=".2e"):
    if x is None:
        return "–"
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    return format(x, spec)


def markdown(summary):
    rows = summary["rows"]
    lines = [f"# mshbm stress suite ({summary['profile']})", "",
             f"{len(rows)} solves in {summary['wall_time_s']:.0f} s on {summary['jobs']} worker(s); "
             "outcomes: " + ", ".join(f"{k}: {v}" for k, v in summary["counts"].items()) + ".", "",
             f"Error: max_i |A_i - A_ref,i| / max(max_i |A_ref,i|, {summary['error_floor']:g} max_i |A_lin,i|) (A: half peak-to-peak amplitude over one period; A_lin: linear response without the elements). "
             "Tolerances: " + ", ".join(f"{k} {v:g}" for k, v in summary["tolerance"].items()) + ".", ""]
    cats = [("resonance", "Near-resonant harmonics (c = 0)"), ("stiff", "Stiff regularisations, many harmonics, tiny steps"),
            ("starts", "Poor starts"), ("random", "Random chains")]
    for cat, title in cats:
        sel = [r for r in rows if r["category"] == cat]
        if not sel:
            continue
        lines += [f"## {title}", "",
                  "| case | omega | point | method | options | outcome | residual | error | time (s) | reference / message |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in sel:
            note = r.get("reference") or ""
            if r["outcome"] != "converged":
                note = r.get("message", "")
            note = note.replace("|", "\\|")
            if len(note) > 140:
                note = note[:137] + "..."
            point = r.get("point") or r.get("start") or ""
            if cat == "random":
                point = point.split(": ", 1)[-1]
            lines.append(f"| {r['case']} | {_fmt(r.get('omega'), '.6g')} | {point} | {r['method']} | {r['options']} | "
                         f"{'**WRONG**' if r['outcome'] == 'WRONG' else r['outcome']} | {_fmt(r.get('residual'))} | "
                         f"{_fmt(r.get('error'))} | {_fmt(r.get('time_s'), '.2f')} | {note} |")
        lines.append("")
    cf = [r for r in rows if r["outcome"] == "failed-certificate"]
    lines += ["## Certificate failures", "",
              f"{len(cf)} solve(s) where Newton converged but the certificate (mshbm.certificate) refused the answer"
              + (":" if cf else "."), ""]
    if cf:
        from collections import Counter

        by = Counter((r["method"], ", ".join(r.get("certificate") or [])) for r in cf)
        lines += ["| method | failed checks | solves |", "|---|---|---|"]
        lines += [f"| {m} | {c} | {k} |" for (m, c), k in sorted(by.items())]
        lines.append("")
    if summary["start_rates"]:
        lines += ["## Convergence from poor starts", "",
                  "Solvable: problems (case, omega, method) where at least one start converged.", "",
                  "| method | start | continuation fallback | converged (all) | rate | converged (solvable) | rate |",
                  "|---|---|---|---|---|---|---|"]
        for s in summary["start_rates"]:
            lines.append(f"| {s['method']} | {s['start']} | {s['continuation']} | {s['converged']}/{s['total']} | "
                         f"{_fmt(s['rate'], '.0%')} | {s['converged_solvable']}/{s['solvable']} | "
                         f"{_fmt(s['rate_solvable'], '.0%')} |")
        lines.append("")
    return "\n".join(lines) + "\n"
