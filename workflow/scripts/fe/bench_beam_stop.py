"""Cold single solves of the stop on the cantilever's tip node, against a converged reference: CPU per point and
agreement, one row per method and frequency.

    python workflow/scripts/fe/bench_beam_stop.py [--out results/bench_beam_stop.json] [--ratios 0.9,0.95,...]
        [--ref-modes 12] [--harmonics 10] [--steps 1024] [--methods mshbm-event,shooting-event,mshbm-moreau]

The model is the sweep suite's ``beam-stop-cb`` (workflow/sweeps.yaml: the 0.1 m steel cantilever of 40 Hermite
elements, a stop with gap 1 mm and ``e = 0.7`` on its tip node, 0.2 N at the tip, 1 % Rayleigh damping, Craig-Bampton
with the tip DOF and 6 fixed-interface modes = 7 DOFs).  At each ``omega = r w_1`` (``w_1`` = 1049.94 rad/s):

* the reference: event-driven shooting with the Zeno closure (``accumulation="close"``: the exact flow and
  monodromy up to the dropped tail of the bounce sequence) on the *same beam reduced with* ``--ref-modes``
  fixed-interface modes (12: the tip amplitude then agrees with the 6-mode model to 1e-4, so the reference checks
  the reduction too);
* each method, cold (no guess, a new problem; one warm-up solve first for Numba), on the 6-mode model, with the
  default certificate (accuracy estimates, stability): its CPU time (``time.process_time``, one BLAS thread; wall
  times are distorted by the machine's load), ``success``, the message, the start used, the tip amplitude
  ``(max - min) / 2`` and its relative difference to the reference, the impacts per period and the impact
  *episodes* per period.

Impacts per period: the event-driven flow's impacts (down to the Zeno closure's resolution); for Moreau-Jean
solutions the runs of consecutive steps with a contact impulse.  On this beam the count is not a converged quantity:
the tip bounces at 100-250 w_1 ever faster into a contact phase (a Zeno sequence), and the count depends on the
closure's resolution and on the modes kept (reference at 0.99 w_1: 3 impacts with 6 modes, 19 with 12, the
amplitudes equal to 7.5e-5).  The rows therefore also give the *episodes*: groups of impacts less than
:data:`EPISODE_GAP` of the period apart (one bounce sequence and its contact phase), which do converge.

Measured (n_H = 10, 1024 steps, CPU of one core on a loaded 2-core machine): event MS-HBM 0.2-1.2 s a point, event
shooting 0.07-2.0 s (1.5-2.0 s at 1.02 w_1 in two runs: its linear, clamped and zero starts stall before the exact
one), Moreau-Jean MS-HBM 0.04-1.2 s, within the 2 s a point asked.  Before the exact start probed
the Moreau-Jean transient state first (the same run, the probe switched off: the state was its last guess, after the
linear response, rest and the best attempt, from which the exact flow's Newton stalls near w_1): event MS-HBM 5.4 s
at 1.01 w_1 and 2.1 s at 0.99, event shooting 2.5 s at 1.02, Moreau-Jean MS-HBM 11.2 / 3.4 / 2.3 s at 1.01 / 0.99 /
1.02 (its effective-mass re-solve ran the exact start's guesses a second time); the answers are the same (amplitudes
equal to 6e-13).  Largest tip amplitude differences to the reference: 2.0e-3, 1.3e-4, 3.5e-3; one impact episode a
period wherever the reference has one; certified 9, 9, 8 of 9 points (Moreau-Jean MS-HBM at 1.02 w_1: its time-step
error estimate's re-solves fail).  With the defaults (n_H = 5, 4096 steps) MS-HBM's truncation estimate leaves
1.0-1.02 w_1 uncertified (its answers 0.9-2.8 % below the reference).

The impacts per period of the reference are a geometric bounce sequence (impulses and intervals falling by about
``e = 0.7`` a bounce) that ends where the Zeno closure's resolution is reached (a bounce height of 1e-10 of the
displacement scale): at 0.99-1.02 w_1 3-24 impacts with 6-16 modes kept (3, 24, 24 with 6; 19, 20, 20 with 12), 9-12
of them above 1 % of the first impulse at 1.01-1.02 w_1, over a bounce sequence of 0.018 T with 6 modes and 0.001 T
with 16, the amplitudes equal to 1e-4.  The count is a property of the closure, not of the orbit.

The JSON holds ``rows`` (one per method and frequency; ``iterations``: the method's Newton iterations, all starts;
``probed``: the answer came from the exact orbit of the probed transient state), ``reference`` (per frequency) and
``summary`` (per method: the largest CPU time and whether it is within :data:`CPU_LIMIT`, the largest amplitude
difference, whether the episodes agree everywhere).
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import yaml

import mshbm
from mshbm._blas import blas_threads
from mshbm.route.starts import PROBE_NOTE

from mshbm_workflow import sweep_systems

#: the repository (for the sweep suite's configuration, workflow/sweeps.yaml, where the beam is defined)
ROOT = Path(__file__).resolve().parents[3]

#: the method rows: label -> (method, options)
METHODS = {
    "mshbm-event": ("mshbm", {"integrator": "event"}),
    "shooting-event": ("shooting", {"integrator": "event"}),
    "mshbm-moreau": ("mshbm", {}),
}
#: impacts closer than this fraction of the period belong to one episode
EPISODE_GAP = 0.05
RATIOS = (0.9, 0.95, 0.98, 0.99, 1.0, 1.01, 1.02, 1.05, 1.1)
#: CPU seconds a point may cost (the measure of the issue on finite-element contact)
CPU_LIMIT = 2.0


def beam(modes=None):
    """``(system, w_1)`` of ``beam-stop-cb``, with ``modes`` fixed-interface modes instead of its 6."""
    spec = copy.deepcopy(yaml.safe_load((ROOT / "workflow" / "sweeps.yaml").read_text())["systems"]["beam-stop-cb"])
    if modes is not None:
        spec["beam"]["reduce"] = {"modes": int(modes)}
    system, w1, _ = sweep_systems.build(spec, "beam-stop-cb")
    return system, w1


def impact_times(sol):
    """Times (in [0, T)) of the impacts of the period: the event list, or the first step of each run of steps with
    a contact impulse (Moreau-Jean)."""
    if "event_list" in sol.info:
        return np.array([e.t for e in sol.info["event_list"] if e.impulse > 0.0])
    P = np.asarray(sol.impulses, dtype=float)
    if P.ndim != 2 or not P.size:
        return np.zeros(0)
    act = P[:, 0] > 1e-12 * max(float(np.max(np.abs(P[:, 0]))), 1e-300)
    starts = np.nonzero(act & ~np.roll(act, 1))[0]
    if act.all():
        starts = np.array([0])
    return starts * float(sol.time_step)


def episodes(times, T):
    """Groups of impacts less than ``EPISODE_GAP T`` apart (circularly)."""
    if not times.size:
        return 0
    t = np.sort(np.asarray(times) % T)
    gaps = np.diff(np.concatenate([t, [t[0] + T]]))
    return max(int(np.sum(gaps > EPISODE_GAP * T)), 1)


def row(sol, T, cpu):
    imp = impact_times(sol)
    last = (sol.info.get("starts") or [{}])[-1]
    return {"success": bool(sol.success), "message": sol.message, "cpu_s": cpu,
            "start": sol.info.get("start_used"), "iterations": int(sol.iterations),
            "probed": str(last.get("note", "")).endswith(PROBE_NOTE), "amplitude": float(sol.amplitude[0]),
            "impacts": int(imp.size), "episodes": episodes(imp, T), "stable": sol.stable}


def run(ratios, ref_modes, harmonics, steps, methods):
    system, w1 = beam()
    ref_system, _ = beam(ref_modes)
    rows, refs = [], []
    with blas_threads(1):
        for label in methods:  # warm-up (Numba compilation), not timed
            method, opts = METHODS[label]
            mshbm.solve(system, 0.9 * w1, method, **dict(opts, steps=steps, **({"harmonics": harmonics}
                                                                                 if method == "mshbm" else {})))
        for r in ratios:
            omega = r * w1
            T = 2.0 * math.pi / omega
            t0 = time.process_time()
            ref = mshbm.solve(ref_system, omega, "shooting", integrator="event", accumulation="close",
                              stability=False, steps=steps)
            refs.append(dict(row(ref, T, time.process_time() - t0), ratio=r, omega=omega, modes=ref_modes))
            print(f"r={r:.3f} reference: {refs[-1]['amplitude']:.7e} m, {refs[-1]['impacts']} impacts, "
                  f"{refs[-1]['episodes']} episodes, {ref.message[:80]}", flush=True)
            for label in methods:
                method, opts = METHODS[label]
                opts = dict(opts, steps=steps, **({"harmonics": harmonics} if method == "mshbm" else {}))
                t0 = time.process_time()
                sol = mshbm.solve(system, omega, method, **opts)
                out = dict(row(sol, T, time.process_time() - t0), ratio=r, omega=omega, method=label)
                out["amplitude_rel_diff"] = out["amplitude"] / refs[-1]["amplitude"] - 1.0
                out["episodes_agree"] = out["episodes"] == refs[-1]["episodes"]
                rows.append(out)
                print(f"   {label:15s} cpu {out['cpu_s']:5.2f} s  success {out['success']!s:5s} amplitude "
                      f"{out['amplitude']:.7e} ({out['amplitude_rel_diff']:+.2e})  impacts {out['impacts']:2d}  "
                      f"episodes {out['episodes']}  start {out['start']}{' (probed)' if out['probed'] else ''}  "
                      f"{out['iterations']} iterations", flush=True)
    summary = {}
    for label in methods:
        mine = [x for x in rows if x["method"] == label]
        summary[label] = {"cpu_max_s": max(x["cpu_s"] for x in mine), "cpu_limit_s": CPU_LIMIT,
                          "within_cpu_limit": all(x["cpu_s"] <= CPU_LIMIT for x in mine),
                          "amplitude_rel_diff_max": max(abs(x["amplitude_rel_diff"]) for x in mine),
                          "episodes_agree": all(x["episodes_agree"] for x in mine),
                          "certified": sum(x["success"] for x in mine), "points": len(mine)}
    return {"w1": w1, "harmonics": harmonics, "steps": steps, "ref_modes": ref_modes, "reference": refs,
            "rows": rows, "summary": summary}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="results/bench_beam_stop.json")
    ap.add_argument("--ratios", default=",".join(f"{r:g}" for r in RATIOS))
    ap.add_argument("--ref-modes", type=int, default=12)
    ap.add_argument("--harmonics", type=int, default=10)
    ap.add_argument("--steps", type=int, default=1024)
    ap.add_argument("--methods", default=",".join(METHODS))
    a = ap.parse_args(argv)
    methods = [m for m in a.methods.split(",") if m]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        ap.error(f"--methods: unknown {unknown[0]!r} (choose from {', '.join(METHODS)})")
    try:
        ratios = [float(r) for r in a.ratios.split(",") if r.strip()]
    except ValueError:
        ap.error(f"--ratios: comma-separated numbers, got {a.ratios!r}")
    if not ratios or any(not (r > 0.0 and math.isfinite(r)) for r in ratios):
        ap.error(f"--ratios: positive numbers, got {a.ratios!r}")
    if a.ref_modes < 1 or a.harmonics < 1 or a.steps < 8:
        ap.error("--ref-modes and --harmonics must be >= 1, --steps >= 8")
    res = run(ratios, a.ref_modes, a.harmonics, a.steps, methods)
    for label, s in res["summary"].items():
        print(f"{label}: largest CPU {s['cpu_max_s']:.2f} s (limit {s['cpu_limit_s']:g} s), largest amplitude "
              f"difference {s['amplitude_rel_diff_max']:.2e}, episodes agree: {s['episodes_agree']}, certified "
              f"{s['certified']}/{s['points']}")
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=1, default=lambda o: None if o is None else str(o)))


if __name__ == "__main__":
    main()
