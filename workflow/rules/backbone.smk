# Nonlinear modes (Fig. 11, paper Sec. 5.9): the backbone (EPMC, mshbm.backbone) of a cantilever with a
# Jenkins joint by each harmonic-balance method of config `backbone.methods`, with its forced responses at
# the levels of `backbone.peak_amplitudes` and the deviation of their peaks from the backbone
# (scripts/backbone/backbone_curve.py, one job per method); the 50-point backbone of the 100-DOF beam, timed
# (scripts/bench/bench_backbone.py); one summary for the notebook and the paper ({{backbone.<key>}},
# scripts/backbone/backbone_summary.py).  Parameters: config `backbone`.
#
#   <results>/backbone/<method>.json   backbone, forced responses, peaks (rule backbone_curve)
#   <results>/backbone/timing.json     the 100-DOF beam's backbone: points, CPU and wall time (rule backbone_timing)
#   <results>/backbone/impact.json     the conservative impact oscillator's backbone by shooting and MS-HBM (event flow)
#                                      against its closed form T(A) (rule backbone_impact, config backbone.impact)
#   <results>/summary/backbone.json    numbers of Fig. 11 and the paper (rule backbone_summary)

if config.get("backbone"):
    BB = config["backbone"]
    BB_DIR = f"{R}/backbone"

    rule backbone_curve:
        input:
            config=f"{R}/config.json",  # the section `backbone` (read by the script)
            fe="workflow/scripts/fe/build_fe_model.py",  # the beam's matrices
            script="workflow/scripts/backbone/backbone_curve.py",
        output:
            f"{BB_DIR}/{{bmethod}}.json",
        wildcard_constraints:
            bmethod="hbm|dlft|mshbm",
        params:
            argv=lambda w, input, output: ["--config", input.config, "--method", w.bmethod, "--out", output[0]],
            solver=SOLVER_DIGEST,
        log:
            f"{R}/logs/backbone/backbone_{{bmethod}}.log",
        benchmark:
            f"{R}/logs/times/backbone/backbone_{{bmethod}}.tsv",
        priority: 2  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=1000,
            runtime=20,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule backbone_timing:
        input:
            fe="workflow/scripts/fe/build_fe_model.py",
            script="workflow/scripts/bench/bench_backbone.py",
        output:
            f"{BB_DIR}/timing.json",
        params:
            argv=lambda w, output: ["--out", output[0]],
            solver=SOLVER_DIGEST,
        log:
            f"{R}/logs/backbone/timing.log",
        benchmark:
            f"{R}/logs/times/backbone/timing.tsv",
        priority: 2  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=1000,
            runtime=10,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule backbone_impact:
        input:
            config=f"{R}/config.json",  # the section `backbone.impact` (read by the script)
            script="workflow/scripts/backbone/impact_backbone.py",
        output:
            f"{BB_DIR}/impact.json",
        params:
            argv=lambda w, input, output: ["--config", input.config, "--out", output[0]],
            solver=SOLVER_DIGEST,
        log:
            f"{R}/logs/backbone/impact.log",
        benchmark:
            f"{R}/logs/times/backbone/impact.tsv",
        priority: 1  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=500,
            runtime=10,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule backbone_summary:
        input:
            config=f"{R}/config.json",
            curves=expand(f"{BB_DIR}/{{bmethod}}.json", bmethod=BB["methods"]),
            timing=rules.backbone_timing.output[0],
            impact=f"{BB_DIR}/impact.json" if BB.get("impact") else [],
            script="workflow/scripts/backbone/backbone_summary.py",
        output:
            f"{R}/summary/backbone.json",
        params:
            argv=lambda w, input, output: ["--config", input.config, "--timing", input.timing, "--out", output[0],
                                           *(["--impact", input.impact] if BB.get("impact") else []), *input.curves],
        log:
            f"{R}/logs/backbone/summary.log",
        benchmark:
            f"{R}/logs/times/backbone/summary.tsv",
        threads: 1
        resources:
            mem_mb=500,
            runtime=5,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    EXTRA_SUMMARIES.append(f"{R}/summary/backbone.json")
