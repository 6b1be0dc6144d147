# Sweep stress suite: frequency-response curves (mshbm.sweep) over diverse systems -- the project's examples,
# 1-DOF stops with closed forms, chains with stuck and relative elements, FE beams and a plate with friction and
# stops on bodies and on Craig-Bampton models, a lap joint -- with each method where it applies.  Per sweep:
# reached the end of its range or not (the sweep's message), points, CPU time, and the largest deviation from
# pointwise certified solves.  Its own configuration is workflow/sweeps.yaml (validated here against
# workflow/schemas/sweeps.schema.yaml, and again by the script, which also runs by hand).
#
#   snakemake --cores 1 <results>/sweeps/summary.md         # full suite (rule sweep_stress; ~40 sweeps, each
#                                                            # limited to cpu_limit_s of CPU time)
#   snakemake --cores 1 <results>/sweeps-quick/summary.md   # quick profile (a few sweeps, < 2 min)
#   python workflow/scripts/stress/sweeps.py --config workflow/sweeps.yaml [--profile quick] --out results/sweeps

with open("workflow/sweeps.yaml", encoding="utf-8") as _fh:
    SWEEP_STRESS = yaml.safe_load(_fh)
validate(SWEEP_STRESS, "../schemas/sweeps.schema.yaml")


rule sweep_stress:
    input:
        config="workflow/sweeps.yaml",
        schema="workflow/schemas/sweeps.schema.yaml",
        script="workflow/scripts/stress/sweeps.py",
        modules=[f"{WF_LIB}/{name}.py" for name in ("sweep_systems", "sweep_runner")],
        fe="workflow/scripts/fe/build_fe_model.py",
        cases=sorted(str(p) for p in Path("examples").glob("*.yaml")),
    output:
        json=f"{R}/sweeps/summary.json",
        md=f"{R}/sweeps/summary.md",
    params:
        argv=lambda w, input, output: ["--config", input.config, "--profile", "full",
                                       "--out", str(Path(output.json).parent)],
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/sweeps.log",
    benchmark:
        f"{R}/logs/times/sweeps.tsv",
    threads: 1  # one sweep at a time: the CPU times it reports are of a single core
    resources:
        runtime=180,
    message:
        "python {input.script} {params.argv}"
    script:
        "../scripts/cli_job.py"


use rule sweep_stress as sweep_stress_quick with:
    output:
        json=f"{R}/sweeps-quick/summary.json",
        md=f"{R}/sweeps-quick/summary.md",
    params:
        argv=lambda w, input, output: ["--config", input.config, "--profile", "quick",
                                       "--out", str(Path(output.json).parent)],
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/sweeps-quick.log",
    benchmark:
        f"{R}/logs/times/sweeps-quick.tsv",
    resources:
        runtime=10,


# part of `rule all` (common.smk collects EXTRA_TARGETS): the profile of config `sweep_stress_profile` (quick by
# default); the full suite on its own target (rule `sweep_stress`)
EXTRA_TARGETS.append(f"{R}/sweeps-quick/summary.md" if config.get("sweep_stress_profile", "quick") == "quick"
                     else f"{R}/sweeps/summary.md")
