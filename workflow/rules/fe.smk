# Finite-element example (Fig. 10, paper Sec. 5.8): a cantilever structure built into Matrix
# Market files and a case file with a friction joint and an impact stop (scripts/fe/build_fe_model.py), its
# frequency-response curve with each method of config `fe_example.methods` (scripts/fe/fe_sweep.py, one job
# per method), single solves at the case's frequency (scripts/fe/fe_example.py: full shooting where the dense
# time stepper allows it, else its refusal) and one summary for the notebook and the paper
# ({{fe.<key>}}, scripts/fe/fe_summary.py).  Parameters: config `fe_example`.
#
#   <results>/fe/<mesh>/{M,K}.mtx, fe.yaml, modes.json   the model on mesh `sweep`, `solve` or `shooting` (rule fe_model)
#   <results>/fe/sweep/sweep_<method>.json              the frequency-response curve (rule fe_sweep)
#   <results>/fe/solve/solves.json                      single solves, timed (rule fe_example)
#   <results>/summary/fe.json                           numbers of Fig. 10 and the paper (rule fe_summary)
#
# Meshes of the same structure (config `fe_example.meshes`): the curves on `sweep`, the single solves on `solve`
# (both 10^4 DOFs, the target size), and, optional, full shooting's single solve on `shooting` (a coarse mesh,
# needed only without a reduction: full shooting's dense step matrices refuse 10^4 DOFs; default the sweep's).
#
# The elements act on node DOFs of the plate, and the case file reduces the model onto them (Craig-Bampton,
# config `fe_example.reduce_modes`; mshbm.reduction): every method solves the 2 element DOFs plus a few
# fixed-interface modes, and the single solves report on the full model's DOFs with the reduction's error
# estimate in their certificate.  `bodies: true` rebuilds the older model, the elements on two lumped bodies
# tied to the nodes by springs (build_fe_model.py).

if config.get("fe_example"):
    FE = config["fe_example"]
    FE_DIR = f"{R}/fe"

    rule fe_model:
        input:
            # the config snapshot: its mesh sizes enter only through the callable params below, and Snakemake
            # records no callable params, so without this input a changed mesh did not rebuild the model
            config=f"{R}/config.json",
            script="workflow/scripts/fe/build_fe_model.py",
        output:
            case=f"{FE_DIR}/{{mesh}}/fe.yaml",
            M=f"{FE_DIR}/{{mesh}}/M.mtx",
            K=f"{FE_DIR}/{{mesh}}/K.mtx",
            modes=f"{FE_DIR}/{{mesh}}/modes.json",
        wildcard_constraints:
            mesh="sweep|solve|shooting",
        params:
            argv=lambda w, output: fe_model_argv(w, output),
        log:
            f"{R}/logs/fe/fe_model_{{mesh}}.log",
        benchmark:
            f"{R}/logs/times/fe/fe_model_{{mesh}}.tsv",
        priority: 4  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=1000,
            runtime=5,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule fe_sweep:
        input:
            config=f"{R}/config.json",  # FE options enter through callable params, which Snakemake does not record
            case=f"{FE_DIR}/sweep/fe.yaml",
            M=f"{FE_DIR}/sweep/M.mtx",
            K=f"{FE_DIR}/sweep/K.mtx",
            modes=f"{FE_DIR}/sweep/modes.json",
            script="workflow/scripts/fe/fe_sweep.py",
        output:
            f"{FE_DIR}/sweep/sweep_{{fmethod}}.json",
        wildcard_constraints:
            fmethod=r"mshbm|hbm|dlft|shooting",
        params:
            argv=lambda w, input, output: [input.case, output[0], "--method", w.fmethod,
                                           "--omega-ratio", *[str(r) for r in FE["omega_ratio"]],
                                           "--harmonics", str(FE["harmonics"]), "--steps", str(FE["steps"]),
                                           "--max-points", str(FE["max_points"]), "--ds-max", str(FE["ds_max"]),
                                           *[a for k, v in FE.get("sweep_options", {}).get(w.fmethod, {}).items()
                                             for a in (f"--{k.replace('_', '-')}", str(v))]],
            solver=SOLVER_DIGEST,
        log:
            f"{R}/logs/fe/fe_sweep_{{fmethod}}.log",
        benchmark:
            f"{R}/logs/times/fe/fe_sweep_{{fmethod}}.tsv",
        priority: 3  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=3000,
            runtime=30,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule fe_example:
        input:
            config=f"{R}/config.json",  # as fe_sweep
            case=f"{FE_DIR}/solve/fe.yaml",
            M=f"{FE_DIR}/solve/M.mtx",
            K=f"{FE_DIR}/solve/K.mtx",
            shooting_case=f"{FE_DIR}/{'shooting' if 'shooting' in FE['meshes'] else 'sweep'}/fe.yaml",
            script="workflow/scripts/fe/fe_example.py",
        output:
            json=f"{FE_DIR}/solve/solves.json",
        params:
            argv=lambda w, input, output: [input.case, output.json, "--methods", ",".join(FE["solve_methods"]),
                                           "--harmonics", str(FE["harmonics"]), "--guess", "mshbm=hbm", "--guess", "mshbm-event=hbm",
                                           "--shooting-case", input.shooting_case,
                                           "--shooting-max-dofs", str(FE["shooting_max_dofs"]),
                                           "--accuracy", "default",
                                           *(["--mode-convergence", ",".join(str(m) for m in FE["mode_convergence"])]
                                             if FE.get("mode_convergence") else [])],
            solver=SOLVER_DIGEST,
        log:
            f"{R}/logs/fe/fe_example.log",
        benchmark:
            f"{R}/logs/times/fe/fe_example.tsv",
        priority: 3  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=2000,
            runtime=30,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule fe_summary:
        input:
            modes=f"{FE_DIR}/sweep/modes.json",
            solve_modes=f"{FE_DIR}/solve/modes.json",
            solves=rules.fe_example.output.json,
            sweeps=expand(f"{FE_DIR}/sweep/sweep_{{fmethod}}.json", fmethod=FE["methods"]),
            script="workflow/scripts/fe/fe_summary.py",
        output:
            f"{R}/summary/fe.json",
        params:
            argv=lambda w, input, output: ["--modes", input.modes, "--solve-modes", input.solve_modes,
                                           "--solves", input.solves, "--out", output[0], *input.sweeps],
        log:
            f"{R}/logs/fe/fe_summary.log",
        benchmark:
            f"{R}/logs/times/fe/fe_summary.tsv",
        threads: 1
        resources:
            mem_mb=500,
            runtime=5,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    EXTRA_SUMMARIES.append(f"{R}/summary/fe.json")

    # every curve, with those of config fe_example.long_methods (too long for the main run, if any):
    # `snakemake --cores 1 fe_curves`
    rule fe_curves:
        input:
            expand(f"{FE_DIR}/sweep/sweep_{{fmethod}}.json", fmethod=FE.get("long_methods", []) + FE["methods"]),


# Cold single solves of a stop on a finite-element node (the sweep suite's beam-stop-cb: the 0.1 m steel cantilever
# of 40 elements, its stop on the tip node, reduced by Craig-Bampton) at nine frequencies across w_1 +- 10 %: CPU per
# point and agreement with event shooting on the beam reduced with 12 modes, per method (scripts/fe/bench_beam_stop.py;
# about 20 s of CPU).  Part of `rule all`; `snakemake --cores 1 <results>/fe/beam_stop/bench.json` alone.
rule bench_beam_stop:
    input:
        script="workflow/scripts/fe/bench_beam_stop.py",
        sweeps="workflow/sweeps.yaml",
        systems=f"{WF_LIB}/sweep_systems.py",
    output:
        json=f"{R}/fe/beam_stop/bench.json",
    params:
        argv=lambda w, output: ["--out", output.json],
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/fe/bench_beam_stop.log",
    benchmark:
        f"{R}/logs/times/fe/bench_beam_stop.tsv",
    priority: 2  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    message:
        "python {input.script} {params.argv}"
    script:
        "../scripts/cli_job.py"


EXTRA_TARGETS.append(f"{R}/fe/beam_stop/bench.json")
