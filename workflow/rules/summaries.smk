# Cheap aggregation: errors against the reference, efforts, impacts, claims (scripts/summaries/summarize.py).
# Restyling a figure never reruns a solver; these read JSON only.


rule summary:
    input:
        unpack(lambda w: summary_inputs(w.fig)),
    output:
        f"{R}/summary/{{fig}}.json",
    params:
        figure=lambda w: config["figures"][w.fig],
        clock=config["timing"]["clock"],
        system=lambda w: config["systems"][config["figures"][w.fig]["system"]],
    log:
        f"{R}/logs/summary/{{fig}}.log",
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    script:
        "../scripts/summaries/summarize.py"


rule config_snapshot:
    output:
        f"{R}/config.json",
    params:
        config={k: v for k, v in config.items() if k != "results_dir"},
    log:
        f"{R}/logs/config_snapshot.log",
    priority: 5  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
    threads: 1
    resources:
        mem_mb=200,
        runtime=5,
    script:
        "../scripts/summaries/config_snapshot.py"


# The exact event-driven periodic solution (mshbm.methods.exact) of a figure's system, seeded by the reference
# full shooting: the error reference of Figs. 4 and 8 and the impact sequence of Fig. 7.
rule exact_reference:
    input:
        seed=lambda w: solve_file(w.case, "shooting", reference=True, ext="npz"),
    output:
        f"{R}/solves/{{case}}/exact.json",
    params:
        cfg=lambda w: {"omega_over_pi": config["omega_over_pi"], "systems": {w.case: config["systems"][w.case]},
                       "numerics": {k: NUMERICS[k] for k in ("reference_steps", "theta")}},
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/solves/{{case}}/exact.log",
    benchmark:
        f"{R}/logs/times/solves/{{case}}/exact.tsv",
    priority: 1  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
    threads: 1
    resources:
        mem_mb=2000,
        runtime=30,
    script:
        "../scripts/solves/exact_reference.py"
