"""One periodic solve of the workflow: a system of the config, one method, n_H and steps.

Writes ``<stem>.json`` (facts: success, message, iterations, residual, every start tried,
wall times, amplitudes, Floquet multipliers and stability verdict (mshbm.stability, computed
once, untimed, on the displayed solution), stick fraction, impacts) and ``<stem>.npz``
(time series of the solution shown in the figures).  Run by the Snakemake rule ``solve``
(workflow/rules/solves.smk) or stand-alone::

    python workflow/scripts/solves/solve.py workflow/config.yaml impact5 mshbm 3 4096 results/solves/impact5/mshbm_nh3_N4096

Start protocol (config ``systems.<case>.starts``, tried in order until one converges): the named
strategies of :mod:`mshbm.strategies`,

* ``linear``: Newton at omega from the linear response at omega;
* ``nearby``: Newton at omega from the method's own converged solution at
  ``nearby_factor * omega`` (which itself starts from the linear response there);
* HBM that fails from every start: restarted from another method's solution (``hbm_fallback``).

This script loads the system (its case file), solves, times and writes; it decides nothing about
how a solve starts beyond the order of the configured starts.

Wall time (``time.perf_counter``) and the process CPU time (``time.process_time``; robust when
other processes load the machine) of every timed call are recorded.

For ``timed`` systems each start gets ``timing.warmup`` untimed solves and then
``timing.repeats`` timed ones (the whole :func:`mshbm.solve` call is timed).  Full shooting
at the working step count is the effort reference and is timed from every start.  HBM
solutions that fail from every start may be restarted from the converged solutions of
``hbm_fallback`` methods (inputs ``fallback``), for display only (never timed).
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one thread per job: timings are per core, jobs run side by side

import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import mshbm  # noqa: E402
from mshbm import strategies  # noqa: E402
from mshbm.accumulation import from_impulses  # noqa: E402
from mshbm.integrators.moreau_jean import WORK  # noqa: E402
from mshbm_workflow.wfcore import build_system, get_key, omega as config_omega, runs, split_method, write_json  # noqa: E402

#: DOFs whose full time series are stored when the system is at most this large
STORE_ALL_DOFS = 10


def solve_options(method, n_h, steps, numerics):
    """``(method, options)`` of every solve of this job; a ``-fd`` suffix selects FD Jacobians."""
    base, jac = split_method(method)
    # stability=False: the Floquet analysis (mshbm.stability) is not part of the timed solve; it runs
    # once on the displayed solution (see `run`)
    kw = dict(harmonics=int(n_h), steps=int(steps), tol=float(numerics["tol"]),
              max_iter=int(numerics["max_iter"]), stability=False, accuracy=numerics.get("accuracy", False))
    if base not in ("hbm", "dlft"):
        kw.update(theta=float(numerics["theta"]), jacobian=jac or numerics["jacobian"])
    return base, kw


def timed_solve(system, omega, method, **options):
    """:func:`mshbm.solve`, timed as a whole (set-up included): ``info["call_wall_time"]``,
    ``info["cpu_time"]`` and the machine-independent effort ``info["work"]`` of the call."""
    w0 = dict(WORK)
    c0, t0 = time.process_time(), time.perf_counter()
    sol = mshbm.solve(system, omega, method, **options)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    sol.info["call_wall_time"] = wall
    sol.info["cpu_time"] = cpu
    # machine-independent effort of the whole call (the time-domain output included)
    sol.info["work"] = {k: int(WORK[k] - w0[k]) for k in WORK}
    return sol


def brief(sol, wall):
    return {"success": bool(sol.success), "message": sol.message, "iterations": int(sol.iterations),
            "nfev": int(sol.nfev), "residual": float(sol.residual), "wall_time": wall,
            "work": dict(sol.info.get("work") or {})}


def machine_state():
    """CPUs and load averages (1, 5, 15 min) of the machine, recorded with every timing."""
    try:
        load = [float(x) for x in os.getloadavg()]
    except OSError:
        load = None
    return {"cpus": os.cpu_count(), "loadavg": load}


def guess_from_npz(path):
    with np.load(path) as z:
        if not bool(z["valid"]):
            return None
        return {"q_hat": z["q_hat"].copy(), "q0": z["q0"].copy(), "u0": z["u0"].copy()}


def describe(sol, system):
    """Scalar facts of a converged solution (JSON)."""
    n = system.n
    amp = sol.amplitude
    out = {"amplitude_first": float(amp[0]), "amplitude_last": float(amp[n - 1]),
           "amplitude": [float(a) for a in amp] if n <= STORE_ALL_DOFS else None,
           "period": float(sol.period)}
    info = sol.info or {}
    # stability of the nonsmooth flow (mshbm.stability): multipliers as [re, im] pairs, verdict or null
    out.update(mshbm.stability.describe(sol))
    mult = np.asarray(sol.floquet_multipliers)
    if mult.size:
        out["floquet_moduli_top"] = [float(m) for m in np.sort(np.abs(mult))[::-1][:6]]
        dom = mult[int(np.argmax(np.abs(mult)))]
        out["floquet_dominant"] = [float(dom.real), float(dom.imag)]
    if "step_map_multipliers" in info:  # shooting: the discrete map's own multipliers (no saltation terms)
        out["step_map_max_modulus"] = float(np.max(np.abs(info["step_map_multipliers"])))
    out["stability_details"] = {k: v for k, v in (info.get("stability") or {}).items()
                                if isinstance(v, (int, float, str, bool)) or v is None}
    if "stick_or_closed_fraction" in info:
        out["stick_or_closed_fraction"] = float(info["stick_or_closed_fraction"][0])
    el = system.elements[0]
    q1 = sol.displacement([0])[:, 0]
    u1 = sol.velocity([0])[:, 0]
    t = sol.t
    if el.kind == "contact":
        gap = float(el.gap)
        out["max_penetration"] = float(np.max(q1 - gap))
        if sol.impulses is not None:
            imp = sol.impulses[:, 0] > 0
            clusters = runs(imp)
            out["impulse_steps"] = int(np.count_nonzero(imp))
            out["impact_clusters"] = len(clusters)
            out["impact_cluster_sizes"] = [c[1] for c in clusters]
            jumps = []
            for s, length in clusters[:50]:
                e = (s + length) % (t.size - 1)
                jumps.append({"t": float(t[s]), "steps": int(length), "u_before": float(u1[s]),
                              "u_after": float(u1[e])})
            out["impacts"] = jumps
            out["accumulations"] = [a.as_dict() for a in from_impulses(t[:-1], sol.impulses[:, 0],
                                                                        period=float(sol.period))]
        else:
            pen = runs(q1[:-1] > gap)
            out["contact_episodes"] = len(pen)
            out["contact_episode_times"] = [float(t[s]) for s, _ in pen[:50]]
    else:
        bound = float(el.mu * el.normal_force)
        out["friction_bound"] = bound
        out["max_friction_force"] = float(np.max(np.abs(sol.lam[:, 0])))
        if sol.impulses is not None:
            out["stick_fraction"] = out.get("stick_or_closed_fraction")
            stick = np.abs(u1[:-1]) < 1e-9 * max(1.0, float(np.max(np.abs(u1))))
            out["stick_phases"] = len(runs(stick))
    return out


def arrays(sol, system):
    n = system.n
    dofs = np.arange(n) if n <= STORE_ALL_DOFS else np.array([0, n - 1])
    return {"valid": np.array(True), "t": sol.t, "dofs": dofs, "q": sol.displacement(dofs),
            "u": sol.velocity(dofs), "lam": sol.lam,
            "impulses": sol.impulses if sol.impulses is not None else np.zeros((0, len(system.elements))),
            "q_hat": sol.q_hat, "q0": sol.q[0], "u0": sol.u[0], "omega": np.array(sol.omega)}


def run(config, case, method, n_h, steps, stem, fallback=(), reference=False, log=print, solver_digest=None):
    scfg = config["systems"][case]
    numerics = config["numerics"]
    system = build_system(scfg, case)
    om = config_omega(config)
    timed = bool(scfg["timed"]) and not reference
    warmup = int(config["timing"]["warmup"]) if timed else 0
    repeats = int(config["timing"]["repeats"]) if timed else 1
    # full shooting at the working steps is the effort reference: time it from every start
    all_starts = timed and split_method(method)[0] == "shooting"
    starts = list(scfg["starts"])
    log(f"{case} ({system!r}) method={method} n_h={n_h} steps={steps} omega={om:.6g} "
        f"starts={starts} timed={timed} warmup={warmup} repeats={repeats}")

    base, kw = solve_options(method, n_h, steps, numerics)
    attempts, chosen = [], None
    for name in starts:
        rec = {"start": name, "timed": timed}
        near_kw = {"factor": float(config["starts"]["nearby_factor"])} if name == "nearby" else {}
        start = strategies.make_start(name, system, om, base, solve=timed_solve, **near_kw, **kw)
        if start.source is not None:  # the nearby-frequency solution it starts from
            near, wall = start.source, start.source.info["call_wall_time"]
            rec["nearby"] = dict(brief(near, wall), omega=start.omega, factor=start.factor,
                                 amplitude_first=float(near.amplitude[0]) if near.success else None,
                                 amplitude_last=float(near.amplitude[-1]) if near.success else None)
            log(f"  [{name}] solution at {start.factor} omega: {near.message} ({wall:.3f} s)")
        if not start.ok:
            rec.update(success=False, message=start.message, wall_times=[], wall_time_median=None)
            attempts.append(rec)
            continue
        times, cpus, sol = [], [], None
        rec["machine_before"] = machine_state()
        for i in range(warmup + repeats):
            s = strategies.solve_from(start, system, om, base, solve=timed_solve, **kw)
            wall = s.info["call_wall_time"]
            log(f"  [{name}] solve {i + 1}/{warmup + repeats}: {s.message} ({wall:.4f} s)")
            if i == 0:
                sol = s
                rec.update(brief(s, wall))
                rec["first_wall_time"] = wall
                if not s.success:
                    break
            elif not np.array_equal(s.x, sol.x):
                raise RuntimeError("repeated solve gave a different solution: the solver is not deterministic")
            if i >= warmup:
                times.append(wall)
                cpus.append(s.info["cpu_time"])
        rec["machine_after"] = machine_state()
        rec["wall_times"] = times if sol.success else []
        rec["wall_time_median"] = statistics.median(times) if (times and sol.success) else None
        rec["cpu_times"] = cpus if sol.success else []
        rec["cpu_time_median"] = statistics.median(cpus) if (cpus and sol.success) else None
        attempts.append(rec)
        if sol.success and chosen is None:
            chosen = (name, sol)
            if not all_starts:
                break

    display = chosen
    display_only = False
    if chosen is None and method == "hbm":
        for path in fallback:
            src = os.path.basename(path).split("_nh")[0]
            start = strategies.restart_start(guess_from_npz(path), f"{src} solution at omega")
            rec = {"start": start.name, "timed": False, "display_only": True, "source": str(path)}
            if not start.ok:
                rec.update(success=False, message=f"{src} did not converge either")
                attempts.append(rec)
                continue
            s = strategies.solve_from(start, system, om, base, solve=timed_solve, **kw)
            wall = s.info["call_wall_time"]
            rec.update(brief(s, wall))
            attempts.append(rec)
            log(f"  [fallback from {src}] {s.message} ({wall:.3f} s)")
            if s.success:
                display, display_only = (rec["start"], s), True
                break

    facts = {
        "case": case, "method": method, "harmonics": int(n_h), "steps": int(steps), "omega": om,
        "n": system.n, "element": system.elements[0].kind, "reference": bool(reference), "timed": timed,
        "mshbm_version": mshbm.__version__, "solver_digest": solver_digest,
        "success": display is not None,
        "timed_success": chosen is not None,
        "start_used": display[0] if display else None,
        "display_only": display_only,
        "attempts": attempts,
    }
    last = attempts[-1] if attempts else {}
    main = next((a for a in attempts if a.get("success") and a["start"] == (display[0] if display else None)), last)
    for key in ("message", "iterations", "residual", "nfev"):
        facts[key] = main.get(key)
    # machine-independent effort of the solve at omega from the start used (Newton iterations above,
    # residual evaluations `nfev`, Moreau-Jean integrations and steps) and the machine when it was timed
    facts["work"] = main.get("work") or {}
    facts["work_by_start"] = {a["start"]: dict(a.get("work") or {}, nfev=a.get("nfev"), iterations=a.get("iterations"))
                              for a in attempts if not a.get("display_only") and a.get("success")}
    facts["machine"] = {"before": main.get("machine_before"), "after": main.get("machine_after")}
    if display is None:
        facts["message"] = "; ".join(f"[{a['start']}] {a.get('message')}" for a in attempts)
    chosen_rec = next((a for a in attempts if chosen and a["start"] == chosen[0]), None)
    facts["wall_times"] = chosen_rec["wall_times"] if chosen_rec else []
    facts["wall_time_median"] = chosen_rec["wall_time_median"] if chosen_rec else None
    facts["wall_time_median_by_start"] = {a["start"]: a.get("wall_time_median") for a in attempts
                                          if not a.get("display_only")}
    facts["cpu_times"] = chosen_rec["cpu_times"] if chosen_rec else []
    facts["cpu_time_median"] = chosen_rec["cpu_time_median"] if chosen_rec else None
    facts["cpu_time_median_by_start"] = {a["start"]: a.get("cpu_time_median") for a in attempts
                                         if not a.get("display_only")}
    data = {"valid": np.array(False)}
    if display is not None:
        mshbm.stability.assess(system, display[1], "auto", theta=float(numerics.get("theta", 0.5)))
        log(f"  stability: stable={display[1].stable} ({display[1].stability_method}) "
            f"{display[1].stability_reason}")
        facts.update(describe(display[1], system))
        data = arrays(display[1], system)
    write_json(f"{stem}.json", facts)
    np.savez_compressed(f"{stem}.npz", **data)
    log(f"done: success={facts['success']} start={facts['start_used']} message={facts['message']}")
    return facts


def _snakemake_main(smk):
    with open(smk.log[0], "w") as logf:
        def log(msg):
            print(msg, file=logf, flush=True)
        w = smk.wildcards
        stem = smk.output.json[: -len(".json")]
        run(smk.params.cfg, w.case, w.method, int(w.nh), int(w.steps), stem,
            fallback=list(smk.input.fallback) if hasattr(smk.input, "fallback") else [],
            reference=bool(smk.params.reference), log=log, solver_digest=smk.params.solver)


if __name__ == "__main__" and "snakemake" not in globals():
    import yaml

    if len(sys.argv) < 7:
        sys.exit(__doc__)
    cfg_path, case, method, nh, steps, stem = sys.argv[1:7]
    with open(cfg_path) as fh:
        cfg = yaml.safe_load(fh)
    ref = int(steps) == int(get_key(cfg, "numerics.reference_steps")) and split_method(method)[0] == "shooting"
    run(cfg, case, method, int(nh), int(steps), stem, fallback=sys.argv[7:], reference=ref)
elif "snakemake" in globals():
    _snakemake_main(snakemake)  # noqa: F821
