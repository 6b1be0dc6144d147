# Section 3.3 of the paper (MS-HBM with an intermediate subsystem) on a chain where its condition (31)
# holds: several friction masses coupled to the rest through one mass.  Parameters: config
# `intermediate_demo`; one single-threaded job (it times both variants side by side).
#
#   <results>/summary/intermediate.json   rows and the numbers of the paper ({{intermediate.<key>}})
#   <results>/tables/intermediate.md      the table of the paper ({{include:intermediate}})

if config.get("intermediate_demo"):

    rule intermediate_demo:
        input:
            config=f"{R}/config.json",
            script="workflow/scripts/solves/intermediate_demo.py",
        output:
            json=f"{R}/summary/intermediate.json",
            md=f"{R}/tables/intermediate.md",
        log:
            f"{R}/logs/intermediate_demo.log",
        benchmark:
            f"{R}/logs/times/intermediate_demo.tsv",
        params:
            argv=lambda w, input, output: ["--config", input.config, "--out", output.json, "--table", output.md],
            solver=SOLVER_DIGEST,
        priority: 1  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
        threads: 1
        resources:
            mem_mb=2000,
            runtime=30,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    EXTRA_SUMMARIES.append(f"{R}/summary/intermediate.json")
    EXTRA_SUMMARIES.append(f"{R}/tables/intermediate.md")
