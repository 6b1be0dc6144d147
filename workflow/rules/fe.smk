# Finite-element example (issue 15): a cantilever Euler-Bernoulli beam built into Matrix Market files
# and a case file with a friction joint and an impact stop (scripts/build_fe_model.py), then solved
# with MS-HBM, HBM and (where feasible) full shooting, timed (scripts/fe_example.py).
#
# On demand only (`snakemake --cores 2 results/fe_beam/solves.json`), not part of `all` and not in the paper:
# on the 10^4-DOF mesh MS-HBM's Moreau-Jean steps are inaccurate for the stiff, Rayleigh-damped node DOF
# (sqrt(K_dd/M_dd)/omega ~ 1e6); the certificate's time_discretisation check rejects those answers
# (README, known limitations).


rule fe_model:
    input:
        script="workflow/scripts/build_fe_model.py",
    output:
        case=f"{R}/fe_beam/beam.yaml",
        M=f"{R}/fe_beam/M.mtx",
        K=f"{R}/fe_beam/K.mtx",
        modes=f"{R}/fe_beam/modes.json",
    params:
        argv=lambda w, output: [os.path.dirname(output.case), "--n-el", "5000", "--case",
                                os.path.basename(output.case)],
    log:
        f"{R}/logs/fe_beam/fe_model.log",
    threads: 1
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
        json=f"{R}/fe_beam/solves.json",
    params:
        argv=lambda w, input, output: [input.case, output.json, "--methods", "mshbm,hbm,shooting",
                                       "--harmonics", "5"],
    log:
        f"{R}/logs/fe_beam/fe_example.log",
    threads: 1
    message:
        "python {input.script} {params.argv}"
    script:
        "../scripts/cli_job.py"
