# Accuracy suite: certified answers against exact references (closed-form impact, Coulomb and rotating-force
# orbits, the event-driven flow on random chains, unit-scaled copies), at the default accuracy and on request.
# Its own configuration is workflow/accuracy.yaml, validated here against workflow/schemas/accuracy.schema.yaml
# (and again by the script, which also runs by hand).  Not part of `all`: the full profile is ~15 min CPU.
#
#   snakemake --cores 1 <results>/accuracy/summary.md         # full profile (rule accuracy)
#   snakemake --cores 1 <results>/accuracy-quick/summary.md   # quick profile (< 60 s CPU)
#   python workflow/scripts/stress/accuracy.py --config workflow/accuracy.yaml [--quick] --out results/accuracy

with open("workflow/accuracy.yaml", encoding="utf-8") as _fh:
    ACCURACY = yaml.safe_load(_fh)
validate(ACCURACY, "../schemas/accuracy.schema.yaml")


rule accuracy:
    input:
        config="workflow/accuracy.yaml",
        schema="workflow/schemas/accuracy.schema.yaml",
        script="workflow/scripts/stress/accuracy.py",
        modules=[f"{WF_LIB}/{name}.py" for name in ("accuracy_cases", "accuracy_refs", "accuracy_report", "wfcore")],
    output:
        json=f"{R}/accuracy/summary.json",
        md=f"{R}/accuracy/summary.md",
    params:
        argv=lambda w, input, output: ["--config", input.config, "--out", str(Path(output.json).parent)],
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/accuracy.log",
    benchmark:
        f"{R}/logs/times/accuracy.tsv",
    priority: 2  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
    threads: 1
    resources:
        runtime=40,
    message:
        "python {input.script} {params.argv}"
    script:
        "../scripts/cli_job.py"


use rule accuracy as accuracy_quick with:
    output:
        json=f"{R}/accuracy-quick/summary.json",
        md=f"{R}/accuracy-quick/summary.md",
    params:
        argv=lambda w, input, output: ["--config", input.config, "--quick", "--out", str(Path(output.json).parent)],
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/accuracy-quick.log",
    benchmark:
        f"{R}/logs/times/accuracy-quick.tsv",
    resources:
        runtime=5,
