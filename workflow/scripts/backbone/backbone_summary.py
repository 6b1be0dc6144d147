"""Summary of the nonlinear modes for Fig. 11 and the paper (``{{backbone.<key>}}``): the backbone and forced
responses of each method (``<method>.json`` of backbone_curve.py) and the timed backbone of the 100-DOF beam
(``timing.json`` of bench_backbone.py).

Numbers (flat): the model (``omega_free``, ``omega_stuck``, ``a_stick``, ``shoe_mass``, ``shoe_mass_ratio``), per
method ``<m>_success``, ``<m>_points``, ``<m>_omega_min``/``_max``, ``<m>_D_max`` (largest damping ratio),
``<m>_D_at_a_min`` (at the smallest amplitude: HBM the stuck joint, DLFT the onset of slip), ``<m>_backbone_cpu_s``, ``<m>_cpu_s`` (the job: backbone and forced
responses), ``<m>_levels`` (peaks measured inside the backbone's range), ``<m>_max_deviation`` (largest
``|omega_peak / omega_bb(a_peak) - 1|``), ``<m>_worst_level`` (1-based, levels by increasing force) and
``<m>_worst_a`` (its peak's modal amplitude), ``<m>_forces`` (the levels, N); ``max_deviation`` over the methods and
``dlft_eps_peak_spread``: how far (relative) DLFT's peak of its worst level moves when its ``eps`` is fixed at
``dlft_eps_factors`` times the default (backbone_curve.py); ``deviation_ok`` against ``deviation_goal`` (and at least five peaks per method); ``D_max_squared``, the
order of the gap between the amplitude peak and the phase resonance.  Between HBM and DLFT: ``hbm_dlft_max_rel_diff_omega`` and
``hbm_dlft_max_rel_diff_D``, the largest relative differences of DLFT's omega and D from HBM's (interpolated in
the log of the tip amplitude) over the tip amplitudes both cover (``hbm_mshbm_...`` the same for MS-HBM), and ``hbm_dlft_max_abs_diff_D`` (the largest
difference in D itself) with ``hbm_dlft_max_abs_diff_D_tip`` (the tip amplitude where it occurs, m).  Timing: ``timing_points``,
``timing_cpu_s`` (process CPU time of the backbone call), ``timing_wall_s``, ``timing_success``, ``timing_ok``
(CPU time within ``time_goal``).  ``mshbm_available``: whether MS-HBM has a backbone in this run.

The impact oscillator (``--impact``, Fig. 11c): :func:`impact_numbers`.

Output ``results/summary/backbone.json``: ``numbers``, ``curves`` (per method: backbone, levels), ``timing`` and
``impact`` (or None).

Usage::

    python workflow/scripts/backbone/backbone_summary.py --config config.json --timing timing.json --out backbone.json hbm.json ...
"""
from __future__ import annotations

import argparse
import json

import numpy as np


def _load(path):
    with open(path) as fh:
        return json.load(fh)


def compare(a, b):
    """``b`` against ``a`` at equal tip amplitude (linear interpolation of ``a`` in the log of the tip amplitude, at
    ``b``'s points within ``a``'s range): the largest relative difference of omega and of the damping ratio, the
    largest difference of the damping ratio and the tip amplitude (m) where it occurs; Nones without overlap."""
    xa, xb = np.log(a["amplitude_tip"]), np.log(b["amplitude_tip"])
    oa = np.argsort(xa)
    inside = (xb >= xa.min()) & (xb <= xa.max())
    if inside.sum() < 2:
        return None, None, None, None
    wa = np.interp(xb[inside], xa[oa], np.asarray(a["omega"])[oa])
    Da = np.interp(xb[inside], xa[oa], np.asarray(a["damping_ratio"])[oa])
    wb, Db = np.asarray(b["omega"])[inside], np.asarray(b["damping_ratio"])[inside]
    i = int(np.argmax(np.abs(Db - Da)))
    return (float(np.max(np.abs(wb / wa - 1.0))), float(np.max(np.abs(Db / Da - 1.0))), float(abs(Db[i] - Da[i])),
            float(np.exp(xb[inside][i])))


def impact_numbers(impact):
    """``impact_<m>_points``, ``impact_<m>_period_error`` (largest ``|T / T(A) - 1|`` against the closed form),
    ``impact_<m>_D_max`` (largest ``|D|``), ``impact_<m>_cpu_s``, ``impact_<m>_success`` per method, and
    ``impact_omega_ratio_max`` (the largest ``omega / omega_0`` reached) of impact_backbone.py's output."""
    n = {}
    for m, r in impact["methods"].items():
        n.update({f"impact_{m}_points": r["points"], f"impact_{m}_period_error": r["max_period_error"],
                  f"impact_{m}_D_max": r["max_abs_D"], f"impact_{m}_cpu_s": r["cpu_time_s"],
                  f"impact_{m}_success": r["success"]})
    w0 = impact["model"]["omega0"]
    n["impact_omega_ratio_max"] = max(max(r["omega"]) for r in impact["methods"].values()) / w0
    n["impact_gap"], n["impact_m"], n["impact_k"] = (impact["model"][k] for k in ("gap", "m", "k"))
    n["impact_period_error"] = max(r["max_period_error"] for r in impact["methods"].values())
    return n


def summarize(cfg, curves, timing, impact=None):
    bb = cfg["backbone"]
    n = {"deviation_goal": bb["deviation_goal"], "time_goal": bb["time_goal"], "n_levels": len(bb["peak_amplitudes"]),
         "methods": ", ".join(c["method"] for c in curves), "mshbm_available": any(c["method"] == "mshbm" for c in curves)}
    ref = curves[0]["model"]
    n.update(n_el=ref["n_el"], n_dofs=ref["n_dofs"], omega_free=ref["omega_free"], omega_stuck=ref["omega_stuck"],
             a_stick=ref["a_stick"], k_t=ref["k_t"], mu_N=ref["mu_N"], zeta=ref["zeta"], harmonics=ref["harmonics"],
             softening=1.0 - ref["omega_free"] / ref["omega_stuck"], beam_mass=ref["beam_mass"])
    devs = []
    for c in curves:
        m, b = c["method"], c["backbone"]
        if c["model"].get("shoe_mass") is not None:
            n["shoe_mass"] = c["model"]["shoe_mass"]
            n["shoe_mass_ratio"] = c["model"]["shoe_mass"] / c["model"]["beam_mass"]
            n["body_freq_ratio"] = c["model"]["body_freq_ratio"]
        a = np.asarray(b["modal_amplitude"])
        lo = int(np.argmin(a))
        n.update({f"{m}_success": b["success"], f"{m}_message": b["message"], f"{m}_points": len(b["omega"]),
                  f"{m}_omega_min": min(b["omega"]) if b["omega"] else None,
                  f"{m}_omega_max": max(b["omega"]) if b["omega"] else None,
                  f"{m}_D_max": max(b["damping_ratio"]) if b["omega"] else None,
                  f"{m}_D_at_a_min": b["damping_ratio"][lo] if b["omega"] else None,
                  f"{m}_a_min": float(a.min()) if a.size else None, f"{m}_a_max": float(a.max()) if a.size else None,
                  f"{m}_backbone_cpu_s": b["cpu_time_s"], f"{m}_cpu_s": c["cpu_time_s"],
                  f"{m}_levels": c["levels_measured"], f"{m}_max_deviation": c["max_abs_deviation"],
                  f"{m}_forces": ", ".join(f"{lv['force']:.3g}" for lv in c["levels"]),
                  f"{m}_peaks_failed": sum(1 for lv in c["levels"] if not (lv["peak"] and lv["peak"]["success"]))})
        if c["max_abs_deviation"] is not None:
            devs.append(c["max_abs_deviation"])
            worst = max((lv for lv in c["levels"] if lv["peak"] and lv["peak"]["deviation"] is not None),
                        key=lambda lv: abs(lv["peak"]["deviation"]))
            n[f"{m}_worst_a"] = worst["peak"]["modal_amplitude"]
            n[f"{m}_worst_level"] = c["levels"].index(worst) + 1
    n["max_deviation"] = max(devs) if devs else None
    for c in curves:
        if c.get("penalty_sensitivity"):
            n[f"{c['method']}_eps_peak_spread"] = c["penalty_sensitivity"]["spread"]
            n[f"{c['method']}_eps_factors"] = " and ".join(f"{f:g}" for f in c["penalty_sensitivity"]["factors"])
    D_max = [n[f"{c['method']}_D_max"] for c in curves if n[f"{c['method']}_D_max"] is not None]
    n["D_max_squared"] = max(D_max) ** 2 if D_max else None
    n["min_levels"] = min(c["levels_measured"] for c in curves)
    n["deviation_ok"] = bool(devs and len(devs) == len(curves) and n["max_deviation"] <= bb["deviation_goal"]
                             and n["min_levels"] >= 5)
    by = {c["method"]: c["backbone"] for c in curves}
    if "hbm" in by and "dlft" in by:
        (n["hbm_dlft_max_rel_diff_omega"], n["hbm_dlft_max_rel_diff_D"], n["hbm_dlft_max_abs_diff_D"],
         n["hbm_dlft_max_abs_diff_D_tip"]) = compare(by["hbm"], by["dlft"])
    if "hbm" in by and "mshbm" in by:
        (n["hbm_mshbm_max_rel_diff_omega"], n["hbm_mshbm_max_rel_diff_D"], n["hbm_mshbm_max_abs_diff_D"],
         _) = compare(by["hbm"], by["mshbm"])
    n.update(timing_points=timing["points"], timing_cpu_s=timing["cpu_time_s"], timing_wall_s=timing["wall_time_s"],
             timing_success=timing["success"], timing_n_dofs=timing["n_dofs"], timing_harmonics=timing["harmonics"],
             timing_ok=bool(timing["success"] and timing["cpu_time_s"] <= bb["time_goal"]))
    if impact is not None:
        n.update(impact_numbers(impact))
    return {"numbers": n, "curves": {c["method"]: c for c in curves}, "timing": timing, "impact": impact}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", required=True)
    p.add_argument("--timing", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--impact", default=None, help="impact.json of impact_backbone.py (Fig. 11c)")
    p.add_argument("curves", nargs="+")
    args = p.parse_args(argv)
    out = summarize(_load(args.config), [_load(c) for c in args.curves], _load(args.timing),
                    _load(args.impact) if args.impact else None)
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps(out["numbers"], indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
