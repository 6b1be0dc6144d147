#!/usr/bin/env python
"""Benchmark against pyHarm (``pyHarm-os``, Safran) on the penalty-contact chains (GitHub issue 4, target 4).

Target: on the same 5- and 50-mass penalty-contact systems at equal n_H and sampling, our HBM
agrees with pyHarm in the harmonic coefficients to <= 1e-6 (relative) and is >= 5x faster.

pyHarm pins an old jax, so it lives in its own virtual environment: the workflow builds it (rule
``pyharm_env``: ``envs/pyharm`` from ``workflow/envs/pyharm.txt``) and passes ``--pyharm-python``;
``$PYHARM_PYTHON`` overrides both (default without either: ``envs/pyharm/bin/python``).  Run from our environment, this script
re-runs itself with that interpreter (with this repository's ``src`` on ``sys.path``: mshbm
needs only numpy, scipy, numba, pyyaml and threadpoolctl, which that environment has or gets
with ``pip install threadpoolctl``), so that both codes are timed side by side in one process.
If pyHarm cannot be run, the JSON gets ``"status": "unavailable"`` with the error text.

Systems: ``benchlib.impact_chain(n)``: examples/impact5.yaml with n masses (mass 10 then unit masses, unit springs,
dampers 0.3, 5 cos(omega t) on mass n, contact on mass 1 with gap 0.1), penalty law
k_c = 8000, d_c = 0, omega = pi/5, n_H = 5, 512 AFT samples (pyHarm ``nti = 512``); pyHarm input:
one ``substructure`` with our M, C, K (1 DOF per node), a ``CosinusForcing`` and a
``PenaltyUnilateralGap`` connector (contact when q >= g, force k (q - g)), system ``Base``
without adimensionalisation, FRF analysis whose first point (``initialise``) is a Newton solve
(``NewtonRaphson``: no continuation, no line search) at omega.

Measurements (n = 5 and 50):

* ``agreement`` -- pyHarm's residual at our HBM solution, and pyHarm's Newton started from our
  solution perturbed by 1e-4 (relative): the coefficients of the contact DOF and of mass n it
  converges to, compared with ours (max abs difference / max abs coefficient);
* ``from_linear_start`` -- both from the linear response (each code's default start);
* ``from_perturbed_start`` -- both from the same start near the solution (interleaved repeats):
  end-to-end speed-up where both converge;
* ``residual_jacobian_eval`` -- one residual + Jacobian evaluation at the solution (interleaved
  repeats): the cost of a Newton iteration without the linear solve.

Usage::

    python workflow/scripts/bench_pyharm.py --out results/benchmarks/pyharm.json [--quick]
"""
from __future__ import annotations

import logging
import os
import subprocess
import sys
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_SRC = os.path.normpath(os.path.join(HERE, "..", "..", "src"))
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402

import benchlib as bl  # noqa: E402

N_H = 5
NTI = 512
KC = 8000.0
GAP = 0.1
TARGET_AGREE = 1e-6
TARGET_SPEEDUP = 5.0
DEFAULT_PYHARM_PYTHON = os.path.join("envs", "pyharm", "bin", "python")


def _mshbm_parent():
    """Directory holding the ``mshbm`` package this interpreter imports (for the pyHarm child process;
    the workflow may run from a copy without ``src/``)."""
    try:
        import mshbm
    except ImportError:
        return REPO_SRC
    return os.path.dirname(os.path.dirname(os.path.abspath(mshbm.__file__)))


def unavailable(out, what, error, extra=None):
    data = {"benchmark": "pyharm", "status": "unavailable", "what_failed": what, "error": error,
            "machine": bl.machine_info(), "target": {"met": None},
            "summary": {"status": "unavailable", "what_failed": what, "error": error}}
    if extra:
        data.update(extra)
    out = bl.write_json(out, data)
    # the PNG is a declared output too: a figure that says why there is no comparison
    plt = bl.pyplot()
    fig, ax = plt.subplots(figsize=(6, 1.6))
    ax.axis("off")
    ax.text(0.5, 0.5, f"pyHarm comparison unavailable: {what}", ha="center", va="center", fontsize=9, wrap=True)
    fig.savefig(bl.plot_path(out), dpi=100)
    plt.close(fig)
    print(f"pyHarm unavailable: {what}\n{error}")
    return data


# ----------------------------------------------------------------------------- pyHarm side
def pyharm_model(system, omega, max_iter=300):
    """pyHarm ``Maestro`` of ``system`` (a chain with one Contact on DOF 0 and a cosine force)."""
    import pyHarm
    n = system.n
    M, C, K = (system.dense(a) for a in "MCK")
    el = system.elements[0]
    f_dof = int(np.flatnonzero(system.f_hat[1])[0])
    inp = {
        "system": {"type": "Base", "nh": N_H, "nti": NTI, "adim": {"status": False, "lc": 1.0, "wc": 1.0}},
        "substructures": {"chain": {"type": "substructure", "ndofs": 1,
                                    "matrix": {"M": M, "C": C, "K": K, "G": 0.0 * M}}},
        "connectors": {
            "force": {"type": "CosinusForcing", "amp": float(system.f_hat[1, f_dof]),
                      "connect": {"chain": [f_dof]}, "dirs": [0]},
            "contact": {"type": "PenaltyUnilateralGap", "k": float(el.penalty_stiffness), "g": float(el.gap),
                        "connect": {"chain": [int(el.dof)]}, "dirs": [0]},
        },
        "analysis": {"frf": {"study": "frf", "puls_inf": omega, "puls_sup": 1.01 * omega,
                             "solver": "NewtonRaphson", "solver_options": {"max_iter": int(max_iter)},
                             "verbose": False}},
    }
    maestro = pyHarm.Maestro(inp)
    return maestro, maestro.nls["frf"]


def pyharm_solve(ana, n, start):
    """Newton solve of pyHarm's FRF first point from ``start`` (q_hat (2n_h+1, n) or None: linear)."""
    ana.SolList = []
    t0 = time.perf_counter()
    ana.initialise(None if start is None else np.asarray(start, float).reshape(-1).copy())
    t = time.perf_counter() - t0
    s = ana.SolList[-1]
    q_hat = np.asarray(s.x[:-1]).reshape(2 * N_H + 1, n)
    return t, {"success": bool(s.flag_accepted), "iterations": int(s.iter_numb),
               "residual_norm": float(np.linalg.norm(s.R_solver))}, q_hat


def rel_diff(a, b):
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def run_case(n, quick, log):
    import mshbm
    from mshbm.api import build_problem
    omega = bl.OMEGA
    system = bl.impact_chain(n, gap=GAP, kc=KC)
    maestro, ana = pyharm_model(system, omega, max_iter=20 if quick else 300)
    hbm_opts = dict(harmonics=N_H, steps=NTI, stability=False)  # Floquet analysis not timed
    res = {"n": n, "dofs_compared": {"contact": 0, "mass_n": n - 1}}
    # warm-up of both (numba/jax compilation)
    ours = mshbm.solve(system, omega, "hbm", **hbm_opts)
    pyharm_solve(ana, n, ours.q_hat)
    q_ref = ours.q_hat
    cols = [0, n - 1]
    res["ours_from_linear"] = {"success": ours.success, "iterations": ours.iterations, "message": ours.message}

    # --- agreement
    x_ref = np.concatenate([q_ref.reshape(-1), [omega]])
    R_py = np.asarray(maestro.system.Residual(x_ref))
    rng = np.random.default_rng(0)
    start_near = q_ref * (1.0 + 1e-4 * rng.standard_normal(q_ref.shape))
    t_py, info_py, q_py = pyharm_solve(ana, n, start_near)
    res["agreement"] = {
        "pyharm_residual_at_our_solution_max_abs": float(np.max(np.abs(R_py))),
        "pyharm_from_perturbed_start": info_py,
        "relative_difference_contact_dof": rel_diff(q_py[:, 0], q_ref[:, 0]),
        "relative_difference_mass_n": rel_diff(q_py[:, n - 1], q_ref[:, n - 1]),
        "relative_difference_all": rel_diff(q_py, q_ref),
        "ours_q_hat_contact_and_mass_n": q_ref[:, cols].tolist(),
        "pyharm_q_hat_contact_and_mass_n": q_py[:, cols].tolist(),
    }
    log(f"  n={n}: pyHarm residual at our solution {res['agreement']['pyharm_residual_at_our_solution_max_abs']:.2e}; "
        f"rel. diff contact {res['agreement']['relative_difference_contact_dof']:.2e}, "
        f"mass n {res['agreement']['relative_difference_mass_n']:.2e}")

    # --- from the linear response (each code's default start), one run each
    t0 = time.perf_counter()
    s_lin = mshbm.solve(system, omega, "hbm", **hbm_opts)
    t_ours_lin = time.perf_counter() - t0
    t_py_lin, info_py_lin, q_py_lin = pyharm_solve(ana, n, None)
    res["from_linear_start"] = {
        "ours": {"time_s": t_ours_lin, "success": s_lin.success, "iterations": s_lin.iterations,
                 "message": s_lin.message},
        "pyharm": dict(info_py_lin, time_s=t_py_lin, max_iter=20 if quick else 300,
                       relative_difference_to_ours=rel_diff(q_py_lin, q_ref)),
    }
    log(f"  n={n}: from linear start: ours {t_ours_lin:.3f} s ok={s_lin.success}; pyHarm {t_py_lin:.3f} s "
        f"ok={info_py_lin['success']} it={info_py_lin['iterations']}")

    # --- same start near the solution, interleaved.  End to end: from the system matrices to
    # the solution (our solve() builds the condensed problem; pyHarm builds its Maestro model).
    # Newton only: both problems built beforehand, only the Newton solve from the start is timed.
    from mshbm.solvers.newton import solve_problem
    repeats = 2 if quick else 7
    outs = {}
    prob, _ = build_problem(system, omega, "hbm", **hbm_opts)
    x_near = prob.initial_guess({"q_hat": start_near})

    def ours_fn():
        outs["ours"] = mshbm.solve(system, omega, "hbm", guess={"q_hat": start_near}, **hbm_opts)

    def py_fn():
        _, ana_new = pyharm_model(system, omega, max_iter=20 if quick else 300)
        outs["pyharm"] = pyharm_solve(ana_new, n, start_near)

    def ours_newton_fn():
        outs["ours_newton"] = solve_problem(prob, x_near, tol=1e-10, max_iter=50)

    def py_newton_fn():
        outs["pyharm_newton"] = pyharm_solve(ana, n, start_near)

    times = bl.interleaved({"ours": ours_fn, "pyharm": py_fn, "ours_newton": ours_newton_fn,
                            "pyharm_newton": py_newton_fn}, repeats, warmup=1)
    so = outs["ours"]
    _, pinfo, pq = outs["pyharm"]
    st = {k: bl.stats(v) for k, v in times.items()}
    res["from_perturbed_start"] = {
        "start": "our HBM solution times (1 + 1e-4 N(0,1)) per coefficient",
        "ours": dict(st["ours"], success=so.success, iterations=so.iterations,
                     what="mshbm.solve(system, omega, 'hbm', guess=...): set-up (condensation) + Newton"),
        "pyharm": dict(st["pyharm"], **pinfo, what="pyHarm.Maestro(input) + first FRF point (NewtonRaphson)"),
        "ours_newton_only": dict(st["ours_newton"], success=bool(outs["ours_newton"].success),
                                 iterations=int(outs["ours_newton"].nit),
                                 what="mshbm.solvers.newton.solve_problem(problem, x0) on a prebuilt HBMProblem"),
        "pyharm_newton_only": dict(st["pyharm_newton"], what="FRF first point (analysis.initialise) on a "
                                                              "prebuilt Maestro"),
        "both_converged": bool(so.success and pinfo["success"]),
        "speedup": st["pyharm"]["median_s"] / st["ours"]["median_s"],
        "speedup_newton_only": st["pyharm_newton"]["median_s"] / st["ours_newton"]["median_s"],
        "relative_difference_solutions": rel_diff(pq, so.q_hat),
    }
    fps = res["from_perturbed_start"]
    log(f"  n={n}: from the same near start, end to end: ours {st['ours']['median_s'] * 1e3:.2f} ms, pyHarm "
        f"{st['pyharm']['median_s'] * 1e3:.2f} ms -> {fps['speedup']:.1f}x; Newton only: ours "
        f"{st['ours_newton']['median_s'] * 1e3:.2f} ms, pyHarm {st['pyharm_newton']['median_s'] * 1e3:.2f} ms "
        f"-> {fps['speedup_newton_only']:.1f}x")

    # --- one residual + Jacobian evaluation at the solution
    x_ours = prob.initial_guess({"q_hat": q_ref})
    times = bl.interleaved({"ours": lambda: prob.residual(x_ours),
                            "pyharm": lambda: (maestro.system.Residual(x_ref), maestro.system.Jacobian(x_ref))},
                           3 if quick else 11, warmup=1)
    st_o, st_p = bl.stats(times["ours"]), bl.stats(times["pyharm"])
    res["residual_jacobian_eval"] = {"ours": st_o, "pyharm": st_p, "speedup": st_p["median_s"] / st_o["median_s"],
                                     "note": "ours: HBMProblem.residual (condensed unknowns, R and J); pyHarm: "
                                             "system.Residual + system.Jacobian (all unknowns)"}
    log(f"  n={n}: R+J evaluation: ours {st_o['median_s'] * 1e3:.2f} ms, pyHarm {st_p['median_s'] * 1e3:.2f} ms "
        f"-> {res['residual_jacobian_eval']['speedup']:.1f}x")
    return res


def run_here(args):
    t_begin = time.perf_counter()
    try:
        import pyHarm
    except Exception as exc:  # pragma: no cover - depends on the environment
        return unavailable(args.out, "import pyHarm", f"{type(exc).__name__}: {exc}")
    try:
        import mshbm  # noqa: F401
    except Exception as exc:
        return unavailable(args.out, "import mshbm in the pyHarm environment (needs numpy, scipy, numba, pyyaml, "
                                     "threadpoolctl)", f"{type(exc).__name__}: {exc}")
    logging.disable(logging.CRITICAL)  # pyHarm logs every solve
    import warnings
    warnings.filterwarnings("ignore")
    cases = {}
    for n in ((5,) if args.quick else (5, 50)):
        try:
            cases[str(n)] = run_case(n, args.quick, lambda m: print(m, flush=True))
        except Exception:
            cases[str(n)] = {"status": "failed", "error": traceback.format_exc()}
    ok = [c for c in cases.values() if "agreement" in c]
    agree = [max(c["agreement"]["relative_difference_contact_dof"], c["agreement"]["relative_difference_mass_n"])
             for c in ok]
    speed = [c["from_perturbed_start"]["speedup"] for c in ok if c["from_perturbed_start"]["both_converged"]]
    speed_newton = [c["from_perturbed_start"]["speedup_newton_only"] for c in ok
                    if c["from_perturbed_start"]["both_converged"]]
    lin_fail = {k: not c["from_linear_start"]["pyharm"]["success"] for k, c in cases.items() if "agreement" in c}
    data = {
        "benchmark": "pyharm", "status": "ok" if ok else "failed", "quick": bool(args.quick),
        "machine": bl.machine_info(), "pyharm_version": getattr(pyHarm, "__version__", None),
        "python_executable": sys.executable,
        "settings": {"harmonics": N_H, "aft_samples": NTI, "penalty_stiffness": KC, "penalty_damping": 0.0,
                     "gap": GAP, "omega": bl.OMEGA, "pyharm_solver": "NewtonRaphson (no continuation)",
                     "ours": "mshbm.solve(system, omega, 'hbm', harmonics=5, steps=512)"},
        "cases": cases,
        "target": {
            "statement": "our HBM agrees with pyHarm in the harmonic coefficients to <= 1e-6 relative and is >= 5x "
                         "faster (same systems, n_H, sampling)",
            "max_relative_difference": max(agree) if agree else None,
            "agreement_met": bool(agree and max(agree) <= TARGET_AGREE),
            "speedups_same_start": speed,
            "speedups_newton_only": speed_newton,
            "speedup_met": bool(speed and min(speed) >= TARGET_SPEEDUP),
            "speedup_newton_only_met": bool(speed_newton and min(speed_newton) >= TARGET_SPEEDUP),
            "pyharm_failed_from_linear_start": lin_fail,
        },
        "total_wall_s": time.perf_counter() - t_begin,
    }
    data["summary"] = dict(data["target"], status=data["status"])
    out = bl.write_json(args.out, data)
    plot(data, bl.plot_path(out))
    print(f"wrote {out} and {bl.plot_path(out)} in {data['total_wall_s']:.1f} s")
    return data


def plot(data, png):
    plt = bl.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    cases = {k: c for k, c in data["cases"].items() if "agreement" in c}
    ax = axes[0]
    labels, ours, py = [], [], []
    for k, c in cases.items():
        fps = c["from_perturbed_start"]
        labels += [f"n={k}\nend to end", f"n={k}\nNewton", f"n={k}\nR+J eval"]
        ours += [fps["ours"]["median_s"], fps["ours_newton_only"]["median_s"],
                 c["residual_jacobian_eval"]["ours"]["median_s"]]
        py += [fps["pyharm"]["median_s"], fps["pyharm_newton_only"]["median_s"],
               c["residual_jacobian_eval"]["pyharm"]["median_s"]]
    x = np.arange(len(labels))
    ax.bar(x - 0.2, ours, 0.4, label="mshbm HBM")
    ax.bar(x + 0.2, py, 0.4, label="pyHarm")
    ax.set_xticks(x)
    ax.set_xticklabels(labels, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("seconds (median)")
    ax.set_title("Same start: end to end (model + solve), Newton only; one residual+Jacobian", fontsize=9)
    ax.legend(fontsize=8)
    ax = axes[1]
    for k, c in cases.items():
        a = np.array(c["agreement"]["ours_q_hat_contact_and_mass_n"])
        b = np.array(c["agreement"]["pyharm_q_hat_contact_and_mass_n"])
        ax.semilogy(np.abs(a - b).ravel() / np.abs(a).max() + 1e-18, "o", label=f"n={k}")
    ax.axhline(TARGET_AGREE, color="r", ls="--", lw=0.8, label="1e-6")
    ax.set_xlabel("coefficient index (contact DOF, then mass n)")
    ax.set_ylabel("|ours - pyHarm| / max|ours|")
    ax.set_title(f"Harmonic coefficients, n_H={N_H}, {NTI} AFT samples, k_c={KC:g}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = bl.parser(__doc__.splitlines()[1], "results/benchmarks/pyharm.json")
    ap.add_argument("--pyharm-python", default=None,
                    help=f"interpreter with pyHarm ($PYHARM_PYTHON overrides; default {DEFAULT_PYHARM_PYTHON})")
    args = ap.parse_args(argv)
    bl.profile(args)  # no separate full sweep: default and full are the same
    args.out = os.path.abspath(args.out)
    try:
        import pyHarm  # noqa: F401
        return run_here(args)
    except ImportError as exc:
        first_error = f"{type(exc).__name__}: {exc}"
    py = os.environ.get("PYHARM_PYTHON") or args.pyharm_python or DEFAULT_PYHARM_PYTHON
    if os.environ.get("_BENCH_PYHARM_CHILD"):
        return unavailable(args.out, f"import pyHarm with {sys.executable}", first_error)
    if not os.path.exists(py):
        return unavailable(args.out, "find a Python with pyHarm", f"{first_error} (in {sys.executable}); "
                           f"{py} does not exist (create it: snakemake --cores 1 {os.path.join('envs', 'pyharm', 'installed.txt')}, "
                           f"or set $PYHARM_PYTHON)")
    env = dict(os.environ, _BENCH_PYHARM_CHILD="1",
               PYTHONPATH=os.pathsep.join([REPO_SRC, _mshbm_parent(), HERE]
                                          + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    cmd = [py, os.path.abspath(__file__), "--out", args.out] + (["--quick"] if args.quick else [])
    print(f"re-running with the pyHarm environment: {' '.join(cmd)}", flush=True)
    proc = subprocess.run(cmd, env=env)
    if proc.returncode != 0 and not os.path.exists(args.out):
        return unavailable(args.out, f"run with {py}", f"exit code {proc.returncode}")
    return None


if __name__ == "__main__":
    main()
