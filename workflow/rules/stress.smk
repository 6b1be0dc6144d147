# Stress suite: numerical stability near resonances, stiff regularisations, many
# harmonics, tiny steps, poor starts (with and without the continuation fallback of
# mshbm.route.continuation) and random chains.  Its own configuration is workflow/stress.yaml,
# validated here against workflow/schemas/stress.schema.yaml (and again by the script, which also runs
# by hand), so it never touches the main config.
#
#   snakemake --cores 2 <results>/stress/summary.md          # full profile (< 5 min on 2 cores)
#   snakemake --cores 2 <results>/stress-quick/summary.md    # quick profile (< 1 min)
#   python workflow/scripts/stress/stress.py --config workflow/stress.yaml [--quick] --out results/stress

with open("workflow/stress.yaml", encoding="utf-8") as _fh:
    STRESS = yaml.safe_load(_fh)
validate(STRESS, "../schemas/stress.schema.yaml")


rule stress:
    input:
        config="workflow/stress.yaml",
        schema="workflow/schemas/stress.schema.yaml",
        script="workflow/scripts/stress/stress.py",
        modules=[f"{WF_LIB}/{name}.py" for name in ("stress_cases", "stress_judge", "stress_report", "wfcore")],
        cases=sorted(str(p) for p in Path("examples").glob("*.yaml")),
    output:
        json=f"{R}/stress/summary.json",
        md=f"{R}/stress/summary.md",
    params:
        argv=lambda w, input, output, threads: ["--config", input.config, "--jobs", threads,
                                                "--out", str(Path(output.json).parent)],
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/stress.log",
    benchmark:
        f"{R}/logs/times/stress.tsv",
    threads: 2
    resources:
        runtime=15,
    message:
        "python {input.script} {params.argv}"
    script:
        "../scripts/cli_job.py"


use rule stress as stress_quick with:
    output:
        json=f"{R}/stress-quick/summary.json",
        md=f"{R}/stress-quick/summary.md",
    params:
        argv=lambda w, input, output, threads: ["--config", input.config, "--quick", "--jobs", threads,
                                                "--out", str(Path(output.json).parent)],
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/stress-quick.log",
    benchmark:
        f"{R}/logs/times/stress-quick.tsv",


# part of `rule all` (common.smk collects EXTRA_TARGETS): the profile the paper embeds (config `stress_profile`);
# the full profile on its own target (rule `stress`)
EXTRA_TARGETS.append(f"{R}/stress-quick/summary.md" if config.get("stress_profile", "full") == "quick"
                     else f"{R}/stress/summary.md")
