"""What the system does next to an unstable periodic orbit: a long simulation from rest.

The exact event-driven flow (:class:`mshbm.methods.exact.ExactFlow`: closed-form flow of the linear
structure between events, impacts located to machine precision, Newton's impact law) runs from
``q = u = 0`` at ``t = 0`` for ``longrun.periods`` periods.  Per period ``[kT, (k+1)T)`` it records
max, min and amplitude ``(max - min)/2`` of mass 1 (true extrema: the velocity zeros between
``longrun.samples`` sample points per period), its impacts (time mod T, velocity before and after)
and the state at the period's end.  The response has period ``pT`` when the end states of the last
``longrun.tail`` periods repeat after ``p`` periods to ``1e-6`` (relative); the smallest such ``p``
up to 8 is reported, else ``null`` (not periodic within the run: quasi-periodic or chaotic, or not
settled yet).  A ``pT``-periodic response is then refined by exact shooting on the ``pT`` map (the
forcing written in harmonics of ``omega/p``) and its Floquet multipliers are reported.  As a cross-check, Moreau-Jean time-stepping (``numerics.steps`` steps per period,
theta of the config) is run from rest over the same periods and its per-period amplitudes of the last
periods are reported.

Writes ``<stem>.json`` (facts) and ``<stem>.npz`` (``t``, ``q1``, ``u1`` over the last ``2p`` periods,
or 2 if not periodic; ``amp`` per period).  Rule ``longrun`` (workflow/rules/longrun.smk) or::

    python workflow/scripts/solves/longrun.py workflow/config.yaml impact5 results/longrun/impact5
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import time  # noqa: E402

import numpy as np  # noqa: E402

import mshbm  # noqa: E402
from mshbm import System  # noqa: E402
from mshbm.methods.exact import ExactFlow, exact_periodic  # noqa: E402
from mshbm.integrators.event import extrema  # noqa: E402
from mshbm.integrators.moreau_jean import MoreauJean  # noqa: E402
from mshbm_workflow.wfcore import build_system, omega as config_omega, write_json, run_case_script  # noqa: E402

MAX_PERIOD = 8
PERIODIC_TOL = 1e-6


def detect_period(ends, tail):
    """Smallest ``p <= MAX_PERIOD`` with ``x_k = x_{k-p}`` over the last ``tail`` end states, and the
    mismatch for every ``p`` (relative to the largest state entry)."""
    X = np.asarray(ends)
    scale = max(float(np.max(np.abs(X[-tail:]))), 1e-300)
    mism = {}
    for p in range(1, MAX_PERIOD + 1):
        if X.shape[0] < tail + p:
            break
        mism[p] = float(np.max(np.abs(X[-tail:] - X[-tail - p:X.shape[0] - p]))) / scale
    per = next((p for p, d in mism.items() if d <= PERIODIC_TOL), None)
    return per, mism


def subharmonic_system(system, p):
    """The same system with its forcing written in harmonics of ``omega / p`` (period ``pT``)."""
    f = np.asarray(system.f_hat)
    nf = (f.shape[0] - 1) // 2
    g = np.zeros((2 * p * nf + 1, system.n))
    g[0] = f[0]
    for k in range(1, nf + 1):
        g[2 * p * k - 1], g[2 * p * k] = f[2 * k - 1], f[2 * k]
    return System(system.M, system.C, system.K, g, system.elements, name=f"{system.name}-period{p}")


def response_orbit(system, om, p, t_end, x_end, log):
    """The pT-periodic orbit of the settled response: exact shooting on the pT map from the last state,
    its Floquet multipliers (mshbm.stability) and true amplitude of mass 1 over pT."""
    sub = subharmonic_system(system, p)
    n = system.n
    t0 = float(np.mod(t_end, p * 2 * np.pi / om))
    ex = exact_periodic(sub, om / p, guess={"q0": x_end[:n], "u0": x_end[n:], "t0": t0})
    if not ex.success:
        log(f"  the {p}T-periodic orbit did not converge: {ex.message}")
        return {"success": False, "message": ex.message}
    mu = ex.floquet_multipliers
    dom = mu[int(np.argmax(np.abs(mu)))]
    out = {"success": True, "period": p, "multipliers": mshbm.stability.multipliers_json(mu),
           "dominant_multiplier": [float(dom.real), float(dom.imag)], "max_modulus": float(np.abs(dom)),
           "stable": ex.stable, "stability_method": ex.stability_method,
           "amplitude_first": float(ex.info["amplitude_exact"][0]),
           "distance_from_simulation": float(np.max(np.abs(ex.info["state_at_section"] - x_end))) /
           max(float(np.max(np.abs(x_end))), 1e-300),
           "impacts": [{"t": float(e.t), "u_before": float(-e.velocity)} for e in ex.info["events"] if e.impulse > 0]}
    log(f"  {p}T-periodic orbit: max |mu| = {out['max_modulus']:.6f} (stable {ex.stable}), amplitude of mass 1 "
        f"over {p}T {out['amplitude_first']:.6f}, impacts at {[round(i['t'], 4) for i in out['impacts']]}")
    return out


def run(config, case, stem, log=print):
    lcfg = config["longrun"]
    P, S, tail = int(lcfg["periods"]), int(lcfg["samples"]), int(lcfg["tail"])
    system = build_system(config["systems"][case], case)
    om = config_omega(config)
    n = system.n
    el = system.elements[0]
    flow = ExactFlow(system, om)
    T = flow.T
    log(f"{case} ({system!r}) omega={om:.6g}: exact flow from rest, {P} periods, {S} samples per period")
    t0w = time.perf_counter()
    z = flow.state(0.0, np.zeros(n), np.zeros(n))
    t = 0.0
    amp, qmax1, qmin1, ends, impacts, traces = [], [], [], [], [], []
    keep = 2 * MAX_PERIOD
    for k in range(P):
        ts = t + T * np.arange(S) / S
        out = flow.simulate(t, z, duration=T, sample_times=ts, record=True)
        qmax, qmin, _ = extrema(flow, out.nodes)
        qmax1.append(float(qmax[0]))
        qmin1.append(float(qmin[0]))
        amp.append(0.5 * float(qmax[0] - qmin[0]))
        imps = []
        for e in out.events:
            if e.impulse > 0.0:
                u_before = float(el.sign * e.velocity)  # gamma = w^T u, w = sign e_dof
                imps.append({"t_mod_T": float(np.mod(e.t, T)), "u_before": u_before,
                             "u_after": u_before + float(e.impulse * flow.mw[el.dof])})
        impacts.append(imps)
        z = out.end_state
        t += T
        ends.append(z[:2 * n].copy())
        if k >= P - keep:
            traces.append((ts, out.samples[0].copy(), out.samples[n].copy()))
        if (k + 1) % max(1, P // 10) == 0:
            log(f"  period {k + 1}: amplitude of mass 1 {amp[-1]:.6f}, {len(imps)} impact(s)")
    wall = time.perf_counter() - t0w
    per, mism = detect_period(ends, tail)
    show = per if per is not None else 2
    last = list(range(P - 2 * show, P))
    tr = traces[-2 * show:]
    data = {"valid": np.array(True), "t": np.concatenate([x[0] for x in tr]), "q1": np.concatenate([x[1] for x in tr]),
            "u1": np.concatenate([x[2] for x in tr]), "amp": np.array(amp), "qmax1": np.array(qmax1),
            "qmin1": np.array(qmin1), "period_index": np.array(last)}
    # Moreau-Jean cross-check from rest
    steps = int(config["numerics"]["steps"])
    mj = MoreauJean(system.M, system.C, system.K, system.elements, T / steps, float(config["numerics"]["theta"]))
    B = mj.increments(system.forcing(np.linspace(0.0, T, steps + 1), om))
    q, u = np.zeros(n), np.zeros(n)
    mj_amp, mj_imp = [], []
    t1 = time.perf_counter()
    for k in range(P):
        r = mj.run(q, u, B)
        q, u = r.q[-1].copy(), r.u[-1].copy()
        if k >= P - 2 * show:
            mj_amp.append(0.5 * float(r.q[:, 0].max() - r.q[:, 0].min()))
            mj_imp.append([float(i * T / steps) for i in np.flatnonzero(r.P[:, 0] > 0)])
    mj_wall = time.perf_counter() - t1
    settled_amps = [amp[k] for k in last]
    facts = {
        "case": case, "n": n, "omega": om, "period_T": T, "mshbm_version": mshbm.__version__,
        "method": "exact event-driven flow (closed-form flow between events, Newton's impact law) from rest",
        "periods": P, "samples_per_period": S, "tail": tail, "wall_time_s": wall,
        "response_period": per,
        "periodicity_mismatch": {str(p): d for p, d in mism.items()},
        "settled": per is not None,
        "last_periods": last,
        "amplitude_first_last": settled_amps,
        "amplitude_first_distinct": sorted({round(a, 9) for a in settled_amps[:show]}, reverse=True),
        "qmax_first_last": [qmax1[k] for k in last], "qmin_first_last": [qmin1[k] for k in last],
        "impacts_last": [impacts[k] for k in last],
        "impacts_per_period_last": [len(impacts[k]) for k in last],
        "impacts_per_period_tail": [min(len(i) for i in impacts[-tail:]), max(len(i) for i in impacts[-tail:])],
        "amplitude_first_all": amp,
        "moreau_jean": {"steps": steps, "theta": float(config["numerics"]["theta"]),
                        "amplitude_first_last": mj_amp, "impact_times_last": mj_imp, "wall_time_s": mj_wall},
    }
    if per is not None:
        facts["amplitude_first_max"] = max(settled_amps)
        facts["amplitude_first_min"] = min(settled_amps)
        facts["moreau_jean"]["amplitude_first_max"] = max(mj_amp)
        facts["moreau_jean"]["amplitude_first_min"] = min(mj_amp)
    else:
        tail_amp = amp[-tail:]
        facts["amplitude_first_tail_range"] = [min(tail_amp), max(tail_amp)]
    if per is not None:
        facts["response_orbit"] = response_orbit(system, om, per, t, ends[-1], log)
    write_json(f"{stem}.json", facts)
    np.savez_compressed(f"{stem}.npz", **data)
    log(f"done in {wall:.1f} s (Moreau-Jean {mj_wall:.1f} s): response period {per} T, "
        f"last amplitudes of mass 1 {np.round(settled_amps, 4).tolist()}, Moreau-Jean {np.round(mj_amp, 4).tolist()}")
    return facts


if __name__ == "__main__" or "snakemake" in globals():
    run_case_script(run, __doc__, globals())
