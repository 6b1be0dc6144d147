# What the impact chains do next to their (unstable) T-periodic orbits: the exact event-driven flow
# from rest over config `longrun.periods` periods, with a Moreau-Jean cross-check (scripts/solves/longrun.py),
# and the candidates for the impact time of Fig. 6 (scripts/solves/impact_time.py).


rule longrun:
    output:
        json=f"{R}/longrun/{{case}}.json",
        npz=f"{R}/longrun/{{case}}.npz",
    params:
        cfg=lambda w: {"omega_over_pi": config["omega_over_pi"], "systems": {w.case: config["systems"][w.case]},
                       "numerics": {k: NUMERICS[k] for k in ("steps", "theta")}, "longrun": config["longrun"]},
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/longrun/{{case}}.log",
    benchmark:
        f"{R}/logs/times/longrun/{{case}}.tsv",
    priority: 1  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
    threads: 1
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/solves/longrun.py"


rule impact_time:
    output:
        json=f"{R}/longrun/impact_time_{{case}}.json",
    params:
        cfg=lambda w: {"omega_over_pi": config["omega_over_pi"], "systems": {w.case: config["systems"][w.case]},
                       "numerics": {k: NUMERICS[k] for k in ("steps", "theta")}, "longrun": config["longrun"]},
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/longrun/impact_time_{{case}}.log",
    benchmark:
        f"{R}/logs/times/longrun/impact_time_{{case}}.tsv",
    priority: 2  # long jobs first: a shorter tail on few cores (common.smk, "Priorities")
    threads: 1
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/solves/impact_time.py"
