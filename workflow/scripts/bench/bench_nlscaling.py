#!/usr/bin/env python
"""Benchmark: MS-HBM cost against the number of nonlinear DOFs.

Targets: MS-HBM (n_H = 5) on a chain of 10^4 masses with 50 friction elements spread along
it in <= 30 s; a chain of 10^6 masses with one friction element in <= 5 s; the exponent of the cost in
the number of nonlinear DOFs n_N = 1 ... 100, and where the time goes.

Chain (``spread_chain``): masses 1, springs 1, dampers 0.01 (as ``bench_scaling.py``), ``m`` friction
elements (mu 0.8, F_N 5, so mu F_N = 4 N) on the masses ``round((i + 1/2) n / m)``, i = 0 .. m-1 (spread
evenly), each of these masses forced by 5 cos(omega t), omega = pi / 5 (the paper's).  Why this load:
with the force only at the chain's end the wave has decayed (damping) long before it reaches most
elements, which then stick for the whole period; a force of amplitude 5 N on each element's own mass,
above its friction limit mu F_N = 4 N but of the same order, makes every element slip over part of the
period and stick around its velocity reversals.  The JSON records each point's smallest and largest
stick fraction over the elements (measured: between 0.05 and 0.75 for every element at every m of the
sweep on 1000 masses, i.e. stick-slip everywhere, never all stuck or all sliding).

Sweep: n = 1000 masses, m = 1 ... 100 elements (n_N = m nonlinear DOFs), MS-HBM with n_H = 5, 4096
steps, the default start ladder, certificate included; time = wall time of ``mshbm.solve`` (system
built outside), median of the repeats after a warm-up solve.  Exponent: least-squares slope of
log(time) against log(m) over m >= 5.  Where the time goes, per point: the set-up of the problem
(condensation of the linear DOFs, ``mshbm.build_problem``), one residual-and-Jacobian evaluation
(Moreau-Jean with sensitivities; Newton makes about one per iteration plus line-search residuals),
one Newton linear solve (dense LU of the (2 n_H + 3) n_N square Jacobian), the Newton iterations, and
the rest (line search and watchdog steps, start ladder's acceptance, certificate, solution assembly).

Large cases: 10^4 masses with 50 elements (same layout); 10^6 masses with one friction element on mass
1 and the force on the last mass (``bench_scaling.py``'s chain; the wave has decayed at mass 1, which
sticks) and on mass 1 (``-local``: stick-slip).  Each is timed with its system build separately, with
its peak extra memory, its CPU time and the 1-minute load average (the machine is shared: with a load
above the number of cores the wall time overstates the cost).

Profiles: ``quick`` (m <= 10, 10^4/50 only; tests), ``default`` (the sweep and the 10^4/50 chain; part of
``snakemake``), ``full`` (the same with 3 repeats of each sweep point, and the two 10^6-mass chains: each takes
about 10 s to build, 1.5-2 min of CPU and 2 GB of memory to solve, more than the rest of the benchmark, and the
paper quotes none of this benchmark's numbers; ``snakemake --cores 2 benchmarks_full``).

Usage::

    python workflow/scripts/bench/bench_nlscaling.py --out results/benchmarks/nlscaling.json [--profile quick|default|full]
"""
from __future__ import annotations

import gc
import os
import time


import numpy as np  # noqa: E402

from mshbm_workflow import benchlib as bl  # noqa: E402

OMEGA = np.pi / 5
DAMPING = 0.01
N_H = 5
STEPS = 4096
MU, F_N, FORCE = 0.8, 5.0, 5.0
SWEEP_N = 1000
TARGETS = {"10000x50": 30.0, "1000000x1": 5.0, "1000000x1-local": 5.0}


def spread_chain(n, m):
    """Chain of ``n`` masses with ``m`` friction elements spread evenly, each element's mass forced."""
    from mshbm import Friction, chain
    dofs = sorted({int(round((i + 0.5) * n / m)) for i in range(m)})
    return chain([1.0] * n, 1.0, DAMPING, forcing=[{"dof": d, "amplitude": FORCE} for d in dofs],
                 elements=[Friction(d, MU, F_N, 800.0) for d in dofs], name=f"chain{n}-spread{m}")


def end_chain(n, local=False):
    """``bench_scaling.py``'s chain: friction on mass 1, the force on the last mass (or on mass 1)."""
    from mshbm import Friction, chain
    return chain([1.0] * n, 1.0, DAMPING, forcing=[{"dof": 0 if local else n - 1, "amplitude": FORCE}],
                 elements=[Friction(0, MU, F_N, 800.0)], name=f"chain{n}{'-local' if local else ''}")


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def solve_once(system):
    import mshbm
    gc.collect()
    with bl.PeakRSS() as mem:
        t0, c0 = time.perf_counter(), time.process_time()
        sol = mshbm.solve(system, OMEGA, "mshbm", harmonics=N_H, steps=STEPS, stability=False)
        t, cpu = time.perf_counter() - t0, time.process_time() - c0
    stick = np.asarray(sol.info.get("stick_or_closed_fraction") or [np.nan], dtype=float)
    starts = sol.info.get("starts") or []
    return t, sol, {"success": bool(sol.success), "iterations": int(sol.iterations), "message": sol.message,
                    "start_used": sol.info.get("start_used"), "starts_tried": len(starts),
                    "peak_extra_rss_mb": mem.extra_mb, "cpu_s": cpu,
                    "load_average_1min": os.getloadavg()[0],
                    "stick_fraction_min": float(np.min(stick)), "stick_fraction_max": float(np.max(stick)),
                    # (max - min) / 2 of the time series of the element DOFs (their PeriodicSolution.amplitude;
                    # the amplitude of all n DOFs, from the extrema of every Fourier series, is not needed)
                    "amplitude_element_masses": [float(a) for a in 0.5 * (np.max(sol.q_time, axis=0)
                                                                           - np.min(sol.q_time, axis=0))]}


def breakdown(system, solve_s, iterations):
    """Set-up time and the time of one residual-and-Jacobian evaluation at the linear start (one BLAS
    thread, as inside ``mshbm.solve``)."""
    from mshbm._blas import blas_threads
    with blas_threads(1):
        return _breakdown(system, solve_s, iterations)


def _breakdown(system, solve_s, iterations):
    import mshbm
    t0 = time.perf_counter()
    problem, _ = mshbm.build_problem(system, OMEGA, "mshbm", harmonics=N_H, steps=STEPS)
    setup = time.perf_counter() - t0
    x = problem.initial_guess("linear")
    jac = min(_timed(lambda: problem.residual(x, jac=True)) for _ in range(3))
    res = min(_timed(lambda: problem.residual(x, jac=False)) for _ in range(3))
    from mshbm.solvers.newton import _solve as newton_step
    R, J = problem.residual(x, jac=True)
    s = problem.residual_scale(x)
    lu = min(_timed(lambda: newton_step(J, R, s)) for _ in range(3))  # Newton's dense LU step on J
    newton = iterations * (jac + lu)
    return {"setup_s": setup, "residual_and_jacobian_s": jac, "residual_only_s": res,  # best of 3
            "newton_linear_solve_s": lu, "n_unknowns": int(problem.n_unknowns),
            "newton_estimate_s": newton, "rest_s": max(0.0, solve_s - setup - newton)}


def run_sweep(ms, repeats, log):
    solve_once(spread_chain(50, 2))  # warm-up (numba compilation)
    points = []
    for m in ms:
        system = spread_chain(SWEEP_N, m)
        times, rec = [], None
        for _ in range(repeats):
            t, sol, rec = solve_once(system)
            times.append(t)
            del sol
        point = {"m": m, "n": SWEEP_N, "n_N": len(system.elements), "solve": bl.stats(times), **rec}
        point["breakdown"] = breakdown(system, point["solve"]["median_s"], rec["iterations"])
        points.append(point)
        b = point["breakdown"]
        log(f"  m={m:4d} solve {point['solve']['median_s']:8.3f} s  it {rec['iterations']:3d}  ok {rec['success']}  "
            f"setup {b['setup_s']:.3f} s  R+J {b['residual_and_jacobian_s']:.4f} s  "
            f"LU {b['newton_linear_solve_s']:.4f} s  n_x {b['n_unknowns']}  "
            f"stick {rec['stick_fraction_min']:.2f}..{rec['stick_fraction_max']:.2f}")
    return points


def run_large(cases, log):
    out = {}
    for key, build in cases:
        t0 = time.perf_counter()
        system = build()
        build_s = time.perf_counter() - t0
        t, sol, rec = solve_once(system)
        del sol
        out[key] = {"build_system_s": build_s, "solve_s": t, "target_s": TARGETS.get(key),
                    "met": bool(rec["success"] and t <= TARGETS.get(key, np.inf)), **rec}
        log(f"  {key:18s} build {build_s:6.2f} s  solve {t:7.2f} s (cpu {rec['cpu_s']:.2f} s, load "
            f"{rec['load_average_1min']:.1f})  it {rec['iterations']}  ok {rec['success']}  "
            f"mem +{(rec['peak_extra_rss_mb'] or 0):.0f} MB  start {rec['start_used']}")
        gc.collect()
    return out


def plot(data, png):
    plt = bl.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    pts = data["sweep"]
    m = np.array([p["m"] for p in pts], float)
    ax = axes[0]
    ax.loglog(m, [p["solve"]["median_s"] for p in pts], "o-", label="mshbm.solve (median)")
    ax.loglog(m, [p["breakdown"]["setup_s"] for p in pts], "s--", ms=3, label="set-up (condensation)")
    ax.loglog(m, [p["breakdown"]["residual_and_jacobian_s"] for p in pts], "^--", ms=3,
              label="one residual + Jacobian")
    e = data["exponent_m_ge_5"]
    ax.set_xlabel("friction elements m (= nonlinear DOFs n_N)")
    ax.set_ylabel("wall time (s)")
    ax.set_title(f"MS-HBM, chain of {SWEEP_N} masses, n_H = {N_H}, {STEPS} steps\n"
                 f"exponent (m >= 5): {e if e is None else round(e, 2)}", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1]
    large = data["large"]
    keys = list(large)
    ax.bar(range(len(keys)), [large[k]["solve_s"] for k in keys], color="C0")
    for i, k in enumerate(keys):
        if large[k].get("target_s"):
            ax.plot([i - 0.4, i + 0.4], [large[k]["target_s"]] * 2, "r--", lw=1)
    ax.set_xticks(range(len(keys)), keys, fontsize=8)
    ax.set_ylabel("wall time of mshbm.solve (s)")
    ax.set_title("large chains (red: the targets)", fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = bl.parser(__doc__.splitlines()[1], "results/benchmarks/nlscaling.json")
    ap.add_argument("--elements", help="comma-separated numbers of elements of the sweep (overrides the profile's)")
    ap.add_argument("--no-large", action="store_true", help="skip the large chains")
    args = ap.parse_args(argv)
    t_begin = time.perf_counter()

    def log(msg):
        print(msg, flush=True)

    profile = bl.profile(args)
    if profile == "quick":
        ms, repeats = [1, 2, 5, 10], 1
        large = [("10000x50", lambda: spread_chain(10_000, 50))]
    else:
        ms = [1, 2, 3, 5, 7, 10, 15, 20, 30, 50, 70, 100]
        repeats = 3 if profile == "full" else 1
        large = [("10000x50", lambda: spread_chain(10_000, 50))]
        if profile == "full":  # each 10^6-mass chain: ~10 s to build, 1.5-2 min of CPU and 2 GB to solve
            large += [("1000000x1", lambda: end_chain(1_000_000)),
                      ("1000000x1-local", lambda: end_chain(1_000_000, local=True))]
    if args.elements:
        ms = [int(v) for v in args.elements.split(",")]
    if args.no_large:
        large = []
    sweep = run_sweep(ms, repeats, log)
    big = run_large(large, log)
    fit = [(p["m"], p["solve"]["median_s"]) for p in sweep if p["m"] >= 5]
    exponent = bl.fit_exponent([a for a, _ in fit], [b for _, b in fit]) if len(fit) >= 2 else None
    fit_j = [(p["m"], p["breakdown"]["residual_and_jacobian_s"]) for p in sweep if p["m"] >= 5]
    exponent_j = bl.fit_exponent([a for a, _ in fit_j], [b for _, b in fit_j]) if len(fit_j) >= 2 else None
    data = {
        "benchmark": "nlscaling", "quick": profile == "quick", "profile": profile, "machine": bl.machine_info(),
        "method": "wall time of mshbm.solve (method mshbm, n_H 5, 4096 steps, default start ladder, certificate, "
                  "stability off) after a warm-up solve; system build timed separately",
        "system": {"sweep": f"{SWEEP_N} masses 1, springs 1, dampers {DAMPING}; m friction elements (mu {MU}, "
                            f"F_N {F_N}) on masses round((i + 1/2) n / m), each forced by {FORCE} cos(omega t)",
                   "large": "10000x50: the same layout; 1000000x1: friction on mass 1, force on the last mass "
                            "(-local: on mass 1)",
                   "omega": OMEGA, "harmonics": N_H, "steps": STEPS},
        "sweep": sweep, "large": big,
        "exponent_m_ge_5": exponent, "jacobian_exponent_m_ge_5": exponent_j,
        "total_wall_s": time.perf_counter() - t_begin,
    }
    data["summary"] = {
        "exponent_m_ge_5": exponent, "jacobian_exponent_m_ge_5": exponent_j,
        "time_table_s": {str(p["m"]): p["solve"]["median_s"] for p in sweep},
        "all_success": all(p["success"] for p in sweep) and all(v["success"] for v in big.values()),
        "stick_slip_everywhere": all(0.0 < p["stick_fraction_min"] and p["stick_fraction_max"] < 1.0
                                     for p in sweep),
        "large": {k: {"solve_s": v["solve_s"], "target_s": v["target_s"], "met": v["met"]} for k, v in big.items()},
    }
    out = bl.write_json(args.out, data)
    plot(data, bl.plot_path(out))
    log(f"exponent (m >= 5): {exponent}; one residual + Jacobian: {exponent_j}")
    log(f"wrote {out} and {bl.plot_path(out)} in {time.perf_counter() - t_begin:.1f} s")
    return data


if __name__ == "__main__":
    main()
