# Frequency-response curves (Fig. 9, beyond the paper): one job per branch and method
# (config `branches`), mshbm.sweep over the branch's frequency range, then one summary for the notebook
# and the paper ({{branches.<key>}}).
#
#   <results>/branches/<name>/<method>.json   the branch (scripts/branches/branch.py)
#   <results>/summary/branches.json           all branches and the paper's numbers (scripts/branches/branch_summary.py)

if BRANCHES:

    rule branch:
        input:
            config=f"{R}/config.json",
            script="workflow/scripts/branches/branch.py",
        output:
            f"{R}/branches/{{name}}/{{bmethod}}.json",
        log:
            f"{R}/logs/branches/{{name}}/{{bmethod}}.log",
        benchmark:
            f"{R}/logs/times/branches/{{name}}/{{bmethod}}.tsv",
        wildcard_constraints:
            name="|".join(BRANCHES),
            bmethod=r"[a-z][a-z0-9-]*",  # the curve's label (config branches.<name>.methods)
        params:
            argv=lambda w, input, output: ["--config", input.config, "--branch", w.name, "--method", w.bmethod,
                                           "--out", output[0]],
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

    rule branch_summary:
        input:
            branches=branch_files(),
            script="workflow/scripts/branches/branch_summary.py",
        output:
            f"{R}/summary/branches.json",
        log:
            f"{R}/logs/branch_summary.log",
        benchmark:
            f"{R}/logs/times/branch_summary.tsv",
        params:
            argv=lambda w, input, output: ["--out", output[0], *input.branches],
        threads: 1
        resources:
            mem_mb=500,
            runtime=5,
        message:
            "python {input.script} {params.argv}"
        script:
            "../scripts/cli_job.py"

    EXTRA_SUMMARIES.append(f"{R}/summary/branches.json")
