# Performance benchmarks: work-precision against the exact reference, kernel speed,
# scaling to 1e5 DOFs, the SciPy baseline and pyHarm (single solves: `pyharm`; branch tracing with
# pyHarm's own continuation: `pyharm_sweep`); nlscaling: MS-HBM against the number of friction
# elements and the 10^4/50, 10^6/1 chains.  Parameters: `benchmarks` of the config.
#
#   <results>/benchmarks/       profile `benchmarks.profile` (default): part of `snakemake`, since
#                               the paper's Performance section embeds its summary
#   <results>/benchmarks-full/  the long sweeps (grids of `benchmarks.full`, scripts' full
#                               profile): `snakemake --cores 2 benchmarks_full` (long; see README)
#
# Every benchmark is one single-threaded process; ratios are measured side by side inside it.
# The scripts have a command line (run them by hand too); under Snakemake scripts/cli_job.py calls
# their main(params.argv).  (BENCH, bench_args and bench_profile are defined in common.smk)

if BENCH:
    _BDIRS = "benchmarks|benchmarks-full"
    _unknown = [s for s in BENCH["systems"] if s not in config["systems"]]
    if _unknown:
        raise ValueError(f"invalid configuration: benchmarks.systems: unknown system(s) {_unknown}")

    rule bench_workprecision:
        input:
            config=f"{R}/config.json",
            script="workflow/scripts/bench/bench_workprecision.py",
        output:
            f"{R}/{{bdir}}/workprecision_{{system}}.json",
        log:
            f"{R}/logs/{{bdir}}/workprecision_{{system}}.log",
        benchmark:
            f"{R}/logs/times/{{bdir}}/workprecision_{{system}}.tsv",
        wildcard_constraints:
            bdir=_BDIRS,
        params:
            argv=lambda w, input, output: ["--config", input.config, "--system", w.system,
                                           "--profile", "full" if w.bdir == "benchmarks-full" else "default",
                                           "--out", output[0]],
            solver=SOLVER_DIGEST,
        priority: 1  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=2000,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule pyharm_env:
        # pyHarm (`pyHarm-os`, pinned with its dependencies) in its own venv, built once and reused;
        # skipped when $PYHARM_PYTHON names an interpreter with pyHarm.  Needs the package registry.
        input:
            requirements="workflow/envs/pyharm.txt",
        output:
            f"{PYHARM_ENV}/installed.txt",
        log:
            f"{R}/logs/pyharm_env.log",
        benchmark:
            f"{R}/logs/times/pyharm_env.tsv",
        params:
            python=BENCH_PY,
            venv=lambda w, output: os.path.dirname(output[0]),
        threads: 1
        resources:
            mem_mb=2000,
            runtime=30,
        shell:
            "({params.python} -m venv --clear {params.venv} "
            "&& {params.venv}/bin/python -m pip install --disable-pip-version-check -r {input.requirements} "
            "&& {params.venv}/bin/python -c 'import pyHarm, threadpoolctl, numba, yaml' "
            "&& {params.venv}/bin/python -m pip freeze > {output}) > {log} 2>&1"

    rule bench_standalone:
        input:
            unpack(bench_inputs),
            script="workflow/scripts/bench/bench_{bench}.py",
            lib=f"{WF_LIB}/benchlib.py",
        output:
            json=f"{R}/{{bdir}}/{{bench}}.json",
            png=f"{R}/{{bdir}}/{{bench}}.png",
        log:
            f"{R}/logs/{{bdir}}/{{bench}}.log",
        benchmark:
            f"{R}/logs/times/{{bdir}}/{{bench}}.tsv",
        wildcard_constraints:
            bench="kernel|scaling|scipy|pyharm|pyharm_sweep|nlscaling",
            bdir=_BDIRS,
        params:
            argv=lambda w, output: ["--profile", bench_profile(w), "--out", output.json] + bench_args(w),
            solver=SOLVER_DIGEST,
        priority: 2  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=6000,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule bench_report:
        input:
            script="workflow/scripts/bench/bench_report.py",
            wp=lambda w: expand(f"{R}/{w.bdir}/workprecision_{{system}}.json", system=BENCH["systems"]),
            other=lambda w: expand(f"{R}/{w.bdir}/{{bench}}.json", bench=BENCH["standalone"]),
        output:
            png=f"{R}/{{bdir}}/workprecision.png",
            md=f"{R}/{{bdir}}/summary.md",
            json=f"{R}/{{bdir}}/summary.json",
        log:
            f"{R}/logs/{{bdir}}/report.log",
        benchmark:
            f"{R}/logs/times/{{bdir}}/report.tsv",
        wildcard_constraints:
            bdir=_BDIRS,
        params:
            argv=lambda w, input, output: ["--out-dir", str(Path(output.md).parent), *input.wp, *input.other],
        threads: 1
        resources:
            mem_mb=1000,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule benchmarks:
        input:
            f"{R}/benchmarks/summary.md",

    rule benchmarks_full:
        input:
            f"{R}/benchmarks-full/summary.md",
