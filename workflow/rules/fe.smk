# Finite-element example (issue 15, Fig. 10, paper Sec. 5.8): a cantilever structure built into Matrix
# Market files and a case file with a friction joint and an impact stop (scripts/build_fe_model.py), its
# frequency-response curve with each method of config `fe_example.methods` (scripts/fe_sweep.py, one job
# per method), single solves at the case's frequency (scripts/fe_example.py: full shooting where the dense
# time stepper allows it, else its refusal) and one summary for the notebook and the paper
# ({{fe.<key>}}, scripts/fe_summary.py).  Parameters: config `fe_example`.
#
#   <results>/fe/{M,K}.mtx, fe.yaml, modes.json   the model (rule fe_model)
#   <results>/fe/sweep_<method>.json              the frequency-response curve (rule fe_sweep)
#   <results>/fe/solves.json                      single solves, timed (rule fe_example)
#   <results>/summary/fe.json                     numbers of Fig. 10 and the paper (rule fe_summary)
#
# The elements act on two lumped bodies tied to the structure by springs (`bodies: true`; the shoe of the
# friction joint and the pad of the stop): MS-HBM integrates the element DOFs in time with their own
# M_NN, C_NN, K_NN, and a node DOF of the 10^4-DOF mesh is far too stiff for that (build_fe_model.py,
# "Why"; README, known limitations).

if config.get("fe_example"):
    FE = config["fe_example"]
    FE_DIR = f"{R}/fe"

    def fe_model_argv(output):
        argv = [os.path.dirname(output.case), "--model", FE["model"], "--n-el", str(FE["n_el"]),
                "--ny", str(FE.get("ny", 1)), "--case", os.path.basename(output.case)]
        if FE["bodies"]:
            argv.append("--bodies")
        for key in ("body_freq_ratio", "body_mass_ratio", "width", "gap_ratio", "friction_ratio", "zeta"):
            if key in FE:
                argv += ["--set", f"{key}={FE[key]}"]
        argv += ["--set", f"steps={FE['steps']}", "--set", f"harmonics={FE['harmonics']}"]
        return argv

    rule fe_model:
        input:
            script="workflow/scripts/build_fe_model.py",
        output:
            case=f"{FE_DIR}/fe.yaml",
            M=f"{FE_DIR}/M.mtx",
            K=f"{FE_DIR}/K.mtx",
            modes=f"{FE_DIR}/modes.json",
        params:
            argv=lambda w, output: fe_model_argv(output),
        log:
            f"{R}/logs/fe/fe_model.log",
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
            case=rules.fe_model.output.case,
            M=rules.fe_model.output.M,
            K=rules.fe_model.output.K,
            modes=rules.fe_model.output.modes,
            script="workflow/scripts/fe_sweep.py",
        output:
            f"{FE_DIR}/sweep_{{fmethod}}.json",
        wildcard_constraints:
            fmethod=r"mshbm|hbm|dlft|shooting",
        params:
            argv=lambda w, input, output: [input.case, output[0], "--method", w.fmethod,
                                           "--omega-ratio", *[str(r) for r in FE["omega_ratio"]],
                                           "--harmonics", str(FE["harmonics"]), "--steps", str(FE["steps"]),
                                           "--max-points", str(FE["max_points"])],
            solver=SOLVER_DIGEST,
        log:
            f"{R}/logs/fe/fe_sweep_{{fmethod}}.log",
        threads: 1
        resources:
            mem_mb=2000,
            runtime=30,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule fe_example:
        input:
            case=rules.fe_model.output.case,
            M=rules.fe_model.output.M,
            K=rules.fe_model.output.K,
            script="workflow/scripts/fe_example.py",
        output:
            json=f"{FE_DIR}/solves.json",
        params:
            argv=lambda w, input, output: [input.case, output.json, "--methods", ",".join(FE["solve_methods"]),
                                           "--harmonics", str(FE["harmonics"])],
            solver=SOLVER_DIGEST,
        log:
            f"{R}/logs/fe/fe_example.log",
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
            modes=rules.fe_model.output.modes,
            solves=rules.fe_example.output.json,
            sweeps=expand(f"{FE_DIR}/sweep_{{fmethod}}.json", fmethod=FE["methods"]),
            script="workflow/scripts/fe_summary.py",
        output:
            f"{R}/summary/fe.json",
        params:
            argv=lambda w, input, output: ["--modes", input.modes, "--solves", input.solves, "--out", output[0],
                                           *input.sweeps],
        log:
            f"{R}/logs/fe/fe_summary.log",
        threads: 1
        resources:
            mem_mb=500,
            runtime=5,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    EXTRA_SUMMARIES.append(f"{R}/summary/fe.json")
