# Underplatform damper (Fig. 12, paper Sec. 5.10): two cantilever blades bending in two planes, coupled by a
# damper (a light rigid body) through two 3-D frictional contacts (3-D Jenkins, constant centrifugal normal load),
# under an engine-order force; frequency-response curves at the normal loads of `upd.preloads` by each method of
# `upd.methods` (scripts/upd/upd_frf.py, one job per method; DLFT at `upd.dlft_harmonics`, the contacts' sliders as
# DOFs); one summary for the notebook and the paper ({{upd.<key>}}, scripts/upd/upd_summary.py).
# Parameters: config `upd`.
#
#   <results>/upd/<method>.json     scans and peaks per preload (rule upd_frf)
#   <results>/summary/upd.json      numbers of Fig. 12 and the paper (rule upd_summary)

if config.get("upd"):
    UPD = config["upd"]
    UPD_DIR = f"{R}/upd"

    rule upd_frf:
        input:
            config=f"{R}/config.json",  # the section `upd` (read by the script)
            fe="workflow/scripts/fe/build_fe_model.py",  # the blades' matrices
            script="workflow/scripts/upd/upd_frf.py",
        output:
            f"{UPD_DIR}/{{umethod}}.json",
        wildcard_constraints:
            umethod="hbm|dlft|mshbm",
        params:
            argv=lambda w, input, output: ["--config", input.config, "--method", w.umethod, "--out", output[0]],
            solver=SOLVER_DIGEST,
        log:
            f"{R}/logs/upd/upd_{{umethod}}.log",
        benchmark:
            f"{R}/logs/times/upd/upd_{{umethod}}.tsv",
        priority: 2  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=1000,
            runtime=10,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    rule upd_summary:
        input:
            config=f"{R}/config.json",
            curves=expand(f"{UPD_DIR}/{{umethod}}.json", umethod=UPD["methods"]),
            script="workflow/scripts/upd/upd_summary.py",
        output:
            f"{R}/summary/upd.json",
        params:
            argv=lambda w, input, output: ["--config", input.config, "--out", output[0], *input.curves],
        log:
            f"{R}/logs/upd/summary.log",
        benchmark:
            f"{R}/logs/times/upd/summary.tsv",
        threads: 1
        resources:
            mem_mb=500,
            runtime=5,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    EXTRA_SUMMARIES.append(f"{R}/summary/upd.json")
