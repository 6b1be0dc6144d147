"""Regenerate the stored regression references from a finished workflow run -- on purpose only.

    snakemake --cores 2 reproduction --configfile workflow/config-quick.yaml   # writes results/quick/
    python workflow/scripts/paper/update_references.py                  # -> tests/reference/quick.json

    snakemake --cores 2 reproduction                              # full run, results/
    python workflow/scripts/paper/update_references.py results tests/reference/full.json

Every deterministic number of the figure summaries (results/<dir>/summary/*.json, key
``numbers``) is stored with a tolerance that follows from what it is (see TOLERANCES and
tests/reference/README.md).  Wall times, efforts, iteration counts and messages are not stored.
"""
import datetime
import json
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))

#: (pattern on the numbers key, kind, rtol, atol, why); first match wins; unmatched keys are not stored
TOLERANCES = [
    (r"(^|_)(success|accumulation|display_only)$", "exact", 0, 0, "convergence / yes-no facts: exact"),
    (r"(^|_)start$", "exact", 0, 0, "start actually used: exact"),
    (r"(impulse_steps|impact_clusters|contact_episodes|max_cluster)$", "exact", 0, 0,
     "impacts per period are integers: exact"),
    (r"stick_fraction", "number", 0, "1/steps", "stick fraction: one time step of the working grid"),
    (r"(amp_first|amp_last)$", "number", 1e-6, 1e-12,
     "amplitudes of a deterministic solver converged to ||R|| < 1e-10: 1e-6 relative"),
    (r"err_(first|last|max)$|err_(1pct|2pct|min|plateau)$|vs_exact_maxdiff$", "number", 1e-3, 1e-6,
     "relative amplitude errors e = A/A_ref - 1: 1e-6 absolute (= 1e-6 relative in A) or 0.1 % of e"),
    (r"floquet$", "number", 1e-6, 1e-9, "largest Floquet multiplier modulus: 1e-6 relative"),
    (r"max_penetration$", "number", 1e-6, 1e-9, "largest q1 - g0 on the grid: 1e-6 relative"),
    (r"(^|_)nh_(1pct|2pct)$|^(hbm|mshbm|mshbmfd)_(converged|failed)$|^both_converged$|^mshbm_better_count$",
     "exact", 0, 0, "counts and thresholds in n_H: exact"),
    (r"friction_bound$", "number", 1e-12, 0, "mu F_N from the configuration"),
    (r"(^|_)stable$", "exact", 0, 0, "stability verdicts of the exact flow (true / false / null): exact"),
    (r"^longrun_period$|^it_.*rest_period$|^it_coexisting$", "exact", 0, 0,
     "period of the response from rest, number of coexisting orbits found: exact"),
    (r"^it_.*impact_time$", "number", 0, 1e-6, "impact times of exact periodic orbits (s): 1e-6 s"),
    (r"^longrun_(amp_max|amp_min)$", "number", 1e-6, 1e-9, "amplitudes of the settled response from rest"),
]


def classify(key):
    for pattern, kind, rtol, atol, why in TOLERANCES:
        if re.search(pattern, key):
            return kind, rtol, atol, why
    return None


def git_commit():
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None


def collect(results_dir):
    with open(os.path.join(results_dir, "config.json")) as fh:
        cfg = json.load(fh)
    steps = int(cfg["numerics"]["steps"])
    values = []
    sdir = os.path.join(results_dir, "summary")
    for fn in sorted(os.listdir(sdir)):
        if not fn.endswith(".json"):
            continue
        with open(os.path.join(sdir, fn)) as fh:
            numbers = json.load(fh)["numbers"]
        fig = fn[:-5]
        for key in sorted(numbers):
            c = classify(key)
            if c is None:
                continue
            kind, rtol, atol, _ = c
            value = numbers[key]
            if kind == "number" and not isinstance(value, (int, float)) and value is not None:
                continue
            if atol == "1/steps":
                atol = 1.0 / steps
            values.append({"figure": fig, "key": key, "value": value, "kind": kind, "rtol": rtol, "atol": atol})
    return cfg, values


def main(argv):
    results_dir = argv[0] if argv else os.path.join(ROOT, "results", "quick")
    out = argv[1] if len(argv) > 1 else os.path.join(ROOT, "tests", "reference", "quick.json")
    cfg, values = collect(results_dir)
    data = {
        "about": "Regression references of the workflow summaries; regenerate only on purpose with "
                 "workflow/scripts/paper/update_references.py (see tests/reference/README.md).",
        "results_dir": os.path.relpath(results_dir, ROOT),
        "generated": datetime.date.today().isoformat(),
        "commit": git_commit(),
        "config_numerics": cfg["numerics"],
        "tolerance_rules": [{"pattern": p, "kind": k, "rtol": r, "atol": a, "why": w} for p, k, r, a, w in TOLERANCES],
        "values": values,
    }
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as fh:
        json.dump(data, fh, indent=1)
        fh.write("\n")
    print(f"wrote {len(values)} reference values to {os.path.relpath(out, ROOT)}")


if __name__ == "__main__":
    main(sys.argv[1:])
