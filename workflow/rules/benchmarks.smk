# Performance benchmarks (issue 4): work-precision against the exact reference, kernel speed,
# scaling to 1e5 DOFs, the SciPy baseline and pyHarm.  Target `benchmarks` runs them all;
# `benchmarks.in_all: true` in the config makes them part of `rule all`.
BENCH = config.get("benchmarks")

if BENCH:
    _BQ = ["--quick"] if BENCH.get("quick") else []

    rule bench_workprecision:
        input:
            config=f"{R}/config.json",
        output:
            f"{R}/benchmarks/workprecision_{{system}}.json",
        log:
            f"{R}/logs/benchmarks/workprecision_{{system}}.log",
        threads: 1
        resources:
            mem_mb=2000,
        shell:
            "python workflow/scripts/bench_workprecision.py --config {input.config} --system {wildcards.system} "
            "--out {output} > {log} 2>&1"

    rule bench_standalone:
        output:
            json=f"{R}/benchmarks/{{bench}}.json",
            png=f"{R}/benchmarks/{{bench}}.png",
        log:
            f"{R}/logs/benchmarks/{{bench}}.log",
        wildcard_constraints:
            bench="kernel|scaling|scipy|pyharm",
        params:
            quick=" ".join(_BQ),
        threads: 1
        resources:
            mem_mb=6000,
        shell:
            "python workflow/scripts/bench_{wildcards.bench}.py --out {output.json} {params.quick} > {log} 2>&1"

    rule bench_report:
        input:
            wp=expand(f"{R}/benchmarks/workprecision_{{system}}.json", system=BENCH["systems"]),
            other=expand(f"{R}/benchmarks/{{bench}}.json", bench=BENCH["standalone"]),
        output:
            png=f"{R}/benchmarks/workprecision.png",
            md=f"{R}/benchmarks/summary.md",
            json=f"{R}/benchmarks/summary.json",
        log:
            f"{R}/logs/benchmarks/report.log",
        shell:
            "python workflow/scripts/bench_report.py --out-dir {R}/benchmarks {input.wp} {input.other} > {log} 2>&1"

    rule benchmarks:
        input:
            rules.bench_report.output,

    if BENCH.get("in_all", False):
        EXTRA_TARGETS.extend([f"{R}/benchmarks/summary.md", f"{R}/benchmarks/workprecision.png"])
