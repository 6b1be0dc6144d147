# One job per periodic solve, keyed by system (case), method, n_H and steps.
# Output: <results>/solves/<case>/<method>_nh<n_H>_N<steps>.json (+ .npz), see scripts/solves/solve.py.


wildcard_constraints:
    case=r"[a-z][a-z0-9]*",
    method=r"shooting|hbm|dlft|mshbm|mshbm-intermediate|shooting-fd|mshbm-fd|mshbm-intermediate-fd",
    nh=r"\d+",
    steps=r"\d+",
    fig=r"fig\d+",


rule solve:
    input:
        unpack(solve_inputs),
    output:
        json=f"{R}/solves/{{case}}/{{method}}_nh{{nh}}_N{{steps}}.json",
        npz=f"{R}/solves/{{case}}/{{method}}_nh{{nh}}_N{{steps}}.npz",
    params:
        cfg=solve_params,
        reference=_is_reference,
        solver=SOLVER_DIGEST,
    log:
        f"{R}/logs/solves/{{case}}/{{method}}_nh{{nh}}_N{{steps}}.log",
    threads: 1
    resources:
        mem_mb=2000,
        runtime=30,
    script:
        "../scripts/solves/solve.py"
