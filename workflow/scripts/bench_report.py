"""Summary of the benchmarks: work-precision plot (all systems) and a Markdown/JSON digest for the paper.

Usage: python workflow/scripts/bench_report.py --out-dir results/benchmarks results/benchmarks/*.json
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

STYLE = {"shooting": ("k", "o"), "mshbm": ("tab:red", "s"), "mshbm-intermediate": ("tab:orange", "D"),
         "hbm": ("tab:blue", "^")}


def fmt(x, spec=".2g"):
    return "–" if x is None else format(x, spec)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("files", nargs="+")
    args = ap.parse_args(argv)
    out = Path(args.out_dir)
    wp = [json.loads(Path(f).read_text()) for f in args.files if Path(f).name.startswith("workprecision_")]
    other = {Path(f).stem: json.loads(Path(f).read_text()) for f in args.files
             if not Path(f).name.startswith("workprecision_")}

    fig, axes = plt.subplots(1, len(wp), figsize=(4.2 * len(wp), 4.0), squeeze=False)
    for ax, d in zip(axes[0], wp):
        for method, (c, mk) in STYLE.items():
            rows = [r for r in d["rows"] if r["method"] == method]
            ok = [r for r in rows if r["success"]]
            bad = [r for r in rows if not r["success"]]
            ax.loglog([r["time_s"] for r in ok], [max(r["error"], 1e-12) for r in ok], mk, color=c,
                      ms=4, alpha=0.8, label=method)
            if bad:
                ax.loglog([r["time_s"] for r in bad], [max(r["error"], 1e-12) for r in bad], mk, color=c,
                          mfc="none", ms=5, alpha=0.6)
        ax.axhline(d["targets"]["target_error"], color="0.5", ls=":", lw=1)
        ax.set_title(f"{d['system']} (n = {d['n']})")
        ax.set_xlabel("wall time (s), median")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("max rel. amplitude error, masses 1 and n\n(vs exact event-driven solution)")
    axes[0][0].legend(fontsize=8, loc="lower left")
    fig.suptitle("Work-precision against the exact reference (hollow: not converged); dotted: 2 % target")
    fig.tight_layout()
    fig.savefig(out / "workprecision.png", dpi=130)

    lines = ["| system | n | exact reference: amplitude mass 1 / mass n | max Floquet modulus | "
             "MS-HBM best speed-up over shooting at equal error ≤ 2 % | at error | MS-HBM time (s) | shooting time (s) |",
             "|---|---|---|---|---|---|---|---|"]
    digest = {"workprecision": {}}
    for d in wp:
        t = d["targets"]["mshbm"] or {}
        ref = d["reference"]
        lines.append(f"| {d['system']} | {d['n']} | {ref['amplitude'][0]:.6f} / {ref['amplitude'][1]:.6f} | "
                     f"{fmt(ref.get('max_floquet_modulus'), '.4f')} | {fmt(t.get('speedup'), '.1f')}× | "
                     f"{fmt(t.get('error'))} | {fmt(t.get('time_s'), '.3g')} | {fmt(t.get('shooting_time_s'), '.3g')} |")
        digest["workprecision"][d["system"]] = d["targets"]
    digest.update({k: v.get("summary", {k2: v[k2] for k2 in v if k2 in ("status", "targets")})
                   for k, v in other.items()})
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    (out / "summary.json").write_text(json.dumps(digest, indent=1))


if __name__ == "__main__":
    main()
