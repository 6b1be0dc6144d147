"""Why is the impact of Fig. 6 at another time than the paper's t = 0.55 s?  Candidates, tested.

For the impact system of Fig. 6 (config ``figures.fig6.system``) and variants of it, every
candidate gives the impact times (in ``[0, T)``) of

* its T-periodic orbit: full shooting (Moreau-Jean, ``numerics.steps``, from the linear response),
  refined on the exact event-driven flow (:func:`mshbm.methods.exact.exact_periodic`), with its Floquet
  multipliers (:mod:`mshbm.stability`);
* the response reached from rest: the exact flow over ``longrun.periods`` periods, its period
  ``pT`` (end states repeat after ``p`` periods over the last ``longrun.tail`` periods, to 1e-6) and
  the impacts of its last ``p`` periods.

Candidates: the forcing phase (``A cos(omega t + phi)``, phi = pi/2, pi, 3 pi/2: sin vs cos and
the time origin), other chain supports (last mass also held by a spring and damper to a wall;
dampers from every mass to the ground instead of parallel to the springs; the force on mass 1),
other coexisting T-periodic orbits (exact shooting from states of the transient, scaled linear
responses and random states), and the period-2 response.  Writes ``<stem>.json``.  Rule
``impact_time`` (workflow/rules/longrun.smk) or::

    python workflow/scripts/solves/impact_time.py workflow/config.yaml impact5 results/longrun/impact_time_impact5
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import time  # noqa: E402

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402

import mshbm  # noqa: E402
from mshbm import System  # noqa: E402
from mshbm.methods.exact import ExactFlow, exact_periodic  # noqa: E402
from mshbm_workflow.wfcore import build_system, omega as config_omega, write_json, run_case_script  # noqa: E402

#: the paper's impact time of Fig. 6 (Sec. 4.2: "the collision time-instant (t = 0.55)")
PAPER_IMPACT_TIME = 0.55
PERIODIC_TOL = 1e-6


def dense(A):
    return A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)


def variant(base, scfg, kind, phase=0.0):
    """The base chain with another support / damper arrangement / forced mass, forcing phase ``phase``."""
    M, C, K = dense(base.M), dense(base.C), dense(base.K)
    n = base.n
    k, c = float(scfg["stiffness"]), float(scfg["damping"])
    f = np.zeros((3, n))
    amp = float(scfg["forcing_amplitude"])
    dof = 0 if kind == "force_mass1" else n - 1
    f[1, dof], f[2, dof] = amp * np.cos(phase), -amp * np.sin(phase)  # A cos(wt + phi)
    if kind == "fixed_fixed":
        K, C = K.copy(), C.copy()
        K[n - 1, n - 1] += k
        C[n - 1, n - 1] += c
    elif kind == "ground_dampers":
        C = c * np.eye(n)
    return System(M, C, K, f, base.elements, name=f"{base.name}-{kind}")


def impacts_of(ex):
    """Impact times in [0, T) and the velocity of the contact mass before them (gamma = w^T u, w = -e_dof)."""
    return [{"t": float(e.t), "u_before": float(-e.velocity)} for e in ex.info["events"] if e.impulse > 0]


def orbit(system, om, steps, log):
    # Moreau-Jean shooting only starts the exact event-driven orbit below: no error estimate of its own
    # (accuracy=False; a start outside the default accuracy is still a start)
    sh = mshbm.solve(system, om, "shooting", steps=steps, stability=False, accuracy=False)
    if not sh.success:
        return {"success": False, "message": f"shooting: {sh.message}"}
    ex = exact_periodic(system, om, guess=sh)
    if not ex.success:
        return {"success": False, "message": f"exact: {ex.message}"}
    mu = ex.floquet_multipliers
    dom = mu[int(np.argmax(np.abs(mu)))]
    out = {"success": True, "impacts": impacts_of(ex), "amplitude_first": float(ex.info["amplitude_exact"][0]),
           "dominant_multiplier": [float(dom.real), float(dom.imag)], "max_modulus": float(np.abs(dom)),
           "stable": ex.stable, "stability_method": ex.stability_method}
    log(f"    T-periodic orbit: impacts {[round(i['t'], 4) for i in out['impacts']]}, mu = {dom:.4f}, "
        f"stable {ex.stable}")
    return out


def from_rest(system, om, periods, tail, log):
    fl = ExactFlow(system, om)
    n = system.n
    z = fl.state(0.0, np.zeros(n), np.zeros(n))
    t, ends, imps = 0.0, [], []
    for _ in range(periods):
        out = fl.simulate(t, z, duration=fl.T)
        imps.append([{"t": float(np.mod(e.t, fl.T)), "u_before": float(-e.velocity)}
                     for e in out.events if e.impulse > 0])
        z = out.end_state
        t += fl.T
        ends.append(z[:2 * n].copy())
    X = np.array(ends)
    scale = max(float(np.abs(X[-tail:]).max()), 1e-300)
    per = None
    for p in range(1, 9):
        if float(np.abs(X[-tail:] - X[-tail - p:periods - p]).max()) / scale <= PERIODIC_TOL:
            per = p
            break
    last = imps[-(per or 2):]
    log(f"    from rest: period {per} T, impacts of the last periods "
        f"{[[round(i['t'], 4) for i in pi] for pi in last]}")
    return {"response_period": per, "impacts_last": last}


def coexisting(system, om, steps, periods_transient, log, seed=0):
    """Distinct T-periodic orbits reached by exact shooting from many starts."""
    fl = ExactFlow(system, om)
    n = system.n
    gap = system.elements[0].gap
    starts = []
    z = fl.state(0.0, np.zeros(n), np.zeros(n))
    t = 0.0
    marks = {1, 2, 3, 5, 8, 12, 20, 30, 50, 80, periods_transient}
    for k in range(1, periods_transient + 1):
        z = fl.simulate(t, z, duration=fl.T).end_state
        t += fl.T
        if k in marks:
            starts.append((f"transient, period {k}", z[:2 * n].copy()))
    lin = mshbm.solve(system, om, "shooting", steps=steps, stability=False)
    if lin.success:
        for a in (0.3, 0.6, 1.5, 2.0):
            starts.append((f"{a} x the shooting solution", np.concatenate([a * lin.q[0], a * lin.u[0]])))
    rng = np.random.default_rng(seed)
    for i in range(8):
        starts.append((f"random state {i}", rng.normal(scale=4.0, size=2 * n) * np.r_[np.ones(n), 0.6 * np.ones(n)]))
    found, tried = {}, []
    for label, x in starts:
        x = x.copy()
        x[0] = min(x[0], 0.9 * gap)  # start off the stop
        ex = exact_periodic(system, om, guess={"q0": x[:n], "u0": x[n:], "t0": 0.0}, max_iter=40)
        rec = {"start": label, "success": bool(ex.success)}
        if ex.success:
            key = (tuple(round(e.t, 4) for e in ex.info["events"] if e.impulse > 0),
                   round(float(ex.info["amplitude_exact"][0]), 4))
            mu = ex.floquet_multipliers[int(np.argmax(np.abs(ex.floquet_multipliers)))]
            found.setdefault(key, {"impact_times": list(key[0]), "amplitude_first": key[1],
                                   "dominant_multiplier": [float(mu.real), float(mu.imag)], "stable": ex.stable})
            rec["orbit"] = list(found).index(key)
        tried.append(rec)
    log(f"    coexisting T-periodic orbits: {len(found)} distinct from {len(starts)} starts "
        f"({sum(r['success'] for r in tried)} converged)")
    return {"orbits": list(found.values()), "starts": tried}


def nearest(times):
    if not times:
        return None
    d = [abs(t - PAPER_IMPACT_TIME) for t in times]
    i = int(np.argmin(d))
    return {"t": times[i], "distance": d[i]}


def run(config, case, stem, log=print):
    scfg = config["systems"][case]
    base = build_system(scfg, case)
    om = config_omega(config)
    steps = int(config["numerics"]["steps"])
    P, tail = int(config["longrun"]["periods"]), int(config["longrun"]["tail"])
    T = 2 * np.pi / om
    t0 = time.perf_counter()
    cands = []

    def add(key, name, what, system):
        log(f"  {name}: {what}")
        o = orbit(system, om, steps, log)
        r = from_rest(system, om, P, tail, log)
        times = [i["t"] for i in o.get("impacts", [])]
        rest_times = [i["t"] for pi in r["impacts_last"] for i in pi]
        cands.append({"key": key, "name": name, "what": what, "periodic_orbit": o, "from_rest": r,
                      "nearest_periodic": nearest(times), "nearest_from_rest": nearest(rest_times)})

    add("base", "as configured", "the chain of Table 2 as we read Fig. 1, f = A cos ωt", base)
    for key, name, phi, what in (
            ("msin", "forcing −sin ωt", np.pi / 2, "f = A cos(ωt + π/2) = −A sin ωt (time origin shifted by T/4)"),
            ("mcos", "forcing −cos ωt", np.pi, "f = −A cos ωt (time origin shifted by T/2)"),
            ("sin", "forcing sin ωt", 1.5 * np.pi, "f = A sin ωt (time origin shifted by 3T/4)")):
        add(key, name, what, variant(base, scfg, "phase", phi))
    add("fixed_fixed", "fixed–fixed chain", "last mass also held by a spring k and a damper c to a wall",
        variant(base, scfg, "fixed_fixed"))
    add("ground_dampers", "dampers to ground", "dampers c from every mass to the ground instead of parallel to "
        "the springs", variant(base, scfg, "ground_dampers"))
    add("force_mass1", "force on mass 1", "the force acts on mass 1 (the contact mass) instead of the last mass",
        variant(base, scfg, "force_mass1"))
    co = coexisting(base, om, steps, min(120, P), log)
    best = min((c for c in cands for key in ("nearest_periodic", "nearest_from_rest") if c[key]),
               key=lambda c: min(c[k]["distance"] for k in ("nearest_periodic", "nearest_from_rest") if c[k]))
    bkey = min((k for k in ("nearest_periodic", "nearest_from_rest") if best[k]), key=lambda k: best[k]["distance"])
    facts = {
        "case": case, "omega": om, "period_T": T, "paper_impact_time": PAPER_IMPACT_TIME,
        "mshbm_version": mshbm.__version__, "wall_time_s": time.perf_counter() - t0, "periods_from_rest": P,
        "candidates": cands, "coexisting": co,
        "n_coexisting_orbits": len(co["orbits"]), "n_coexisting_starts": len(co["starts"]),
        "closest": {"name": best["name"], "which": "its T-periodic orbit" if bkey == "nearest_periodic" else
                    f"the response from rest (period {best['from_rest']['response_period']}T)",
                    "t": best[bkey]["t"], "distance": best[bkey]["distance"]},
        "numbers": {},
    }
    for c in cands:
        key = c["key"]
        o = c["periodic_orbit"]
        facts["numbers"][f"{key}_impact_time"] = (o.get("impacts") or [{}])[0].get("t")
        facts["numbers"][f"{key}_stable"] = o.get("stable")
        facts["numbers"][f"{key}_rest_period"] = c["from_rest"]["response_period"]
        facts["numbers"][f"{key}_rest_impact_times"] = sorted(i["t"] for pi in c["from_rest"]["impacts_last"]
                                                               for i in pi)
    write_json(f"{stem}.json", facts)
    log(f"closest to t = {PAPER_IMPACT_TIME} s: {facts['closest']} ({facts['wall_time_s']:.1f} s)")
    return facts


if __name__ == "__main__" or "snakemake" in globals():
    run_case_script(run, __doc__, globals())
