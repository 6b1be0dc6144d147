# Stress suite (GitHub issue 5): numerical stability near resonances, stiff regularisations, many
# harmonics, tiny steps, poor starts (with and without the continuation fallback of
# mshbm.solvers.continuation) and random chains.  Its own configuration is workflow/stress.yaml (validated
# inside the script against workflow/schemas/stress.schema.yaml), so it never touches the main config.
#
#   snakemake --cores 2 <results>/stress/summary.md          # full profile (< 5 min on 2 cores)
#   snakemake --cores 2 <results>/stress-quick/summary.md    # quick profile (< 1 min)
#   python workflow/scripts/stress.py --config workflow/stress.yaml [--quick] --out results/stress
import sys as _stress_sys
from pathlib import Path as _StressPath

_STRESS_R = config.get("results_dir", "results").rstrip("/")
#: the library the results depend on (paths relative to the working directory, the repository)
_STRESS_SRC = [str(p) for p in sorted(_StressPath("src", "mshbm").rglob("*.py"))]


rule stress:
    input:
        config="workflow/stress.yaml",
        schema="workflow/schemas/stress.schema.yaml",
        script="workflow/scripts/stress.py",
        modules=["workflow/scripts/stress_cases.py", "workflow/scripts/stress_judge.py",
                 "workflow/scripts/stress_report.py", "workflow/scripts/wfcore.py"],
        cases=sorted(str(p) for p in _StressPath("examples").glob("*.yaml")),
        src=_STRESS_SRC,
    output:
        json=f"{_STRESS_R}/stress/summary.json",
        md=f"{_STRESS_R}/stress/summary.md",
    params:
        python=_stress_sys.executable,
        outdir=lambda w, output: str(_StressPath(output.json).parent),
        profile="",
    log:
        f"{_STRESS_R}/logs/stress.log",
    threads: 2
    resources:
        runtime=15,
    shell:
        "{params.python} {input.script} --config {input.config} {params.profile} --jobs {threads} "
        "--out {params.outdir} > {log} 2>&1"


use rule stress as stress_quick with:
    output:
        json=f"{_STRESS_R}/stress-quick/summary.json",
        md=f"{_STRESS_R}/stress-quick/summary.md",
    params:
        python=_stress_sys.executable,
        outdir=lambda w, output: str(_StressPath(output.json).parent),
        profile="--quick",
    log:
        f"{_STRESS_R}/logs/stress-quick.log",


# part of `rule all` of the main Snakefile (workflow/rules/00_common.smk collects EXTRA_TARGETS)
if "EXTRA_TARGETS" in globals():
    EXTRA_TARGETS.append(f"{_STRESS_R}/stress/summary.md")
