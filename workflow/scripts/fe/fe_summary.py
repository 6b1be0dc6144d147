"""Summary of the finite-element example for Fig. 10 and the paper (``{{fe.<key>}}``): the model
(``modes.json`` of build_fe_model.py), the single solves (``solves.json`` of fe_example.py) and the
frequency-response curves (``sweep_<method>.json`` of fe_sweep.py).

Checks of a curve (fe_sweep.py ``--check-points``): ``<method>_check_omega``, ``_check_tip`` (the curve's
last point), ``_check_shooting_tip`` (event-driven full shooting started from it), ``_check_rel_diff_tip``,
``_check_success`` and ``_checks_max_rel_diff_tip`` over every checked point.

With a Craig-Bampton reduction (case key ``reduce:``): ``reduced``, ``reduce_modes``, ``n_reduced_dofs``,
``reduction_build_s``, ``reduction_highest_mode``; per curve ``<method>_reduction_estimate`` (largest error
estimate at its first and last points); per single solve ``solve_<method>_reduction_estimate``; the convergence
in the number of modes ``modes_<m>_tip``, ``modes_<m>_estimate``, ``modes_<m>_tip_rel_diff`` (against the
largest count) and ``modes_<m>_cpu_time``.  CPU times (``time.process_time`` of the job, the machine's load does
not enter): ``<method>_cpu_time``, ``<method>_cpu_per_point``, ``solve_<method>_cpu_time``; the issue's target
of a certified single solve within :data:`SOLVE_TARGET_S` CPU seconds: ``solve_target_s``,
``solve_<method>_within_target`` and ``solve_mshbm_event_within_target``.

Per curve (``<method>_...``): wall time, points, time per point, DOFs of its mesh, MS-HBM's integrator,
corrector iterations and failures, residual evaluations, and the sparse LU factorisations of the
condensation and the solves refined from kept ones (:class:`mshbm.condensation.FactorReuse`; ``None``
when the curve's model is small enough for the dense condensation).

Output ``results/summary/fe.json``: ``numbers`` (flat, for the paper's placeholders), ``model``,
``solves`` and ``branches`` (per method: omega, amplitudes of the named DOFs, stability).

Agreement of two branches: ``<a>_<b>_peak_rel_diff``, the relative difference of their largest tip
amplitudes, and of the frequencies where they occur (``..._peak_omega_rel_diff``); and
``<a>_<b>_max_rel_diff_<dof>`` (both orders), the largest relative difference of ``b``'s amplitude from
``a``'s (interpolated linearly at ``b``'s frequencies) over the frequencies both branches cover, where ``a``'s
frequencies increase along the branch (no folds; else ``None``).  Single solves: ``solve_<m>_hbm_rel_diff_<el>``
and ``solve_<m>_shooting_rel_diff_<el>``, the relative difference of the max |q| at element ``el`` from HBM's and
from full shooting's on the same model.

Usage::

    python workflow/scripts/fe/fe_summary.py --modes modes.json --solves solves.json --out fe.json sweep_*.json
"""
from __future__ import annotations

import argparse
import json
import os
import sys

#: CPU seconds a certified single solve of the 10^4-DOF model should take at most
SOLVE_TARGET_S = 5.0


def _load(path):
    with open(path) as fh:
        return json.load(fh)


def peak(branch, dof="tip"):
    """``(omega, amplitude)`` of the largest amplitude of ``dof`` on the branch (``(None, None)`` if empty)."""
    a = branch["amplitude"].get(dof, [])
    if not a:
        return None, None
    i = max(range(len(a)), key=a.__getitem__)
    return branch["omega"][i], a[i]


def max_rel_diff(a, b, dof):
    """Largest ``|A_b / A_a - 1|`` over ``b``'s points inside ``a``'s frequency range, ``A_a``
    interpolated linearly; ``None`` when ``a``'s frequencies do not increase along the branch or no
    point of ``b`` lies in its range."""
    wa, wb = a["omega"], b["omega"]
    if len(wa) < 2 or any(w2 <= w1 for w1, w2 in zip(wa, wa[1:])):
        return None
    import numpy as np

    wb_arr = np.asarray(wb, dtype=float)
    inside = (wb_arr >= wa[0]) & (wb_arr <= wa[-1])
    if not inside.any():
        return None
    Aa = np.interp(wb_arr[inside], wa, a["amplitude"][dof])
    return float(np.max(np.abs(np.asarray(b["amplitude"][dof], dtype=float)[inside] / Aa - 1.0)))


def summarize(modes, solves, sweeps, solve_modes=None):
    """``modes``: the model of the sweeps; ``solve_modes``: the (finer) model of the single solves."""
    m = modes
    p = m["params"]
    body = m.get("bodies")
    nums = {
        "model": p["model"], "n_el": m["n_el"], "ny": p.get("ny") if p["model"] == "plate" else None,
        "n_dofs": m["n_dofs"], "n_structure_dofs": m.get("n_structure_dofs", m["n_dofs"]),
        "omega_1": m.get("omega_model", m["omega_fe"])[0], "omega_1_structure": m["omega_fe"][0],
        "omega_2": m.get("omega_model", m["omega_fe"])[1],
        "omega_exact_1": m["omega_exact"][0], "zeta": p["zeta"],
        "length": p["length"], "width": p["width"], "thickness": p["height"],
        "mu_FN": m["friction"]["mu"] * m["friction"]["normal_force"], "force": p["force"],
        "gap": m["contact"]["gap"], "restitution": m["contact"]["restitution"],
        "x_friction": p["x_friction"], "x_force": p["x_force"], "penalty_ratio": p["penalty_ratio"],
        "bodies": bool(body),
    }
    if body:
        nums.update(body_mass=body["mass"], body_stiffness=body["stiffness"], body_freq_ratio=p["body_freq_ratio"],
                    body_mass_ratio=p["body_mass_ratio"])
    tds = m.get("time_domain_subsystem", {})
    if "node_dofs" in tds:
        nums["node_local_ratio"] = max(tds["node_dofs"]["omega_local_over_omega"])
        nums["node_event_substeps"] = tds["node_dofs"]["event_substeps_per_period"]
    if "bodies" in tds:
        nums["body_local_ratio"] = max(tds["bodies"]["omega_local_over_omega"])
        nums["body_event_substeps"] = tds["bodies"]["event_substeps_per_period"]
    if solve_modes is not None:
        sm = solve_modes
        nums.update(solve_n_dofs=sm["n_dofs"], solve_n_el=sm["n_el"], solve_ny=sm["params"].get("ny"),
                    solve_omega_1=sm.get("omega_model", sm["omega_fe"])[0], solve_omega=sm["omega"])
        tds2 = sm.get("time_domain_subsystem", {})
        if "node_dofs" in tds2:
            nums["solve_node_local_ratio"] = max(tds2["node_dofs"]["omega_local_over_omega"])
            nums["solve_node_event_substeps"] = tds2["node_dofs"]["event_substeps_per_period"]
    red = solves.get("reduction")
    nums["reduced"] = red is not None
    if red is not None:
        nums.update(reduce_modes=red["modes"], n_reduced_dofs=red["n_reduced"], reduction_build_s=red["build_time_s"],
                    reduction_highest_mode=red["highest_mode_rad_s"])
    conv = solves.get("mode_convergence") or []
    if conv:
        top = max(conv, key=lambda r: r["modes"])
        for r in conv:
            m_ = r["modes"]
            nums[f"modes_{m_}_tip"] = r["amplitudes"].get("contact")
            nums[f"modes_{m_}_estimate"] = r["reduction_estimate"]
            nums[f"modes_{m_}_success"] = r["success"]
            nums[f"modes_{m_}_cpu_time"] = r["cpu_time_s"]
            if r is not top and top["amplitudes"].get("contact"):
                nums[f"modes_{m_}_tip_rel_diff"] = abs(r["amplitudes"]["contact"] / top["amplitudes"]["contact"] - 1.0)
        nums["modes_checked"] = ", ".join(str(r["modes"]) for r in conv)
    nums["solve_target_s"] = SOLVE_TARGET_S
    for row in solves["solves"]:
        k = row["method"].replace("-", "_")  # a labelled variant (mshbm-event) as a placeholder name
        nums[f"solve_{k}_n_dofs"] = row.get("n_dofs")
        if "skipped" in row:
            nums[f"solve_{k}_skipped"] = True
            cost = row.get("cost")
            if cost:
                nums[f"solve_{k}_setup_s"] = cost["setup_s"]
                nums[f"solve_{k}_period_s"] = cost["period_state_s"]
                nums[f"solve_{k}_steps"] = cost["steps"]
            continue
        nums[f"solve_{k}_skipped"] = False
        nums[f"solve_{k}_time"] = row["wall_time_s"]
        cpu = row.get("cpu_time_s")
        nums[f"solve_{k}_cpu_time"] = cpu
        nums[f"solve_{k}_reduction_estimate"] = row.get("reduction_estimate")
        nums[f"solve_{k}_accuracy_estimate"] = row.get("accuracy_estimate")
        nums[f"solve_{k}_within_target"] = bool(row["success"] and cpu is not None and cpu <= SOLVE_TARGET_S)
        nums[f"solve_{k}_success"] = row["success"]
        nums[f"solve_{k}_iterations"] = row["iterations"]
        nums[f"solve_{k}_start"] = row.get("start", "default")
        nums[f"solve_{k}_failed_checks"] = ", ".join(row.get("failed_checks") or [])
        for name, a in row["amplitudes"].items():
            nums[f"solve_{k}_amp_{name}"] = a
    # the rows of the main case (not full shooting on a smaller case, which names its "case")
    a = {r["method"].replace("-", "_"): r["amplitudes"] for r in solves["solves"] if "skipped" not in r and "case" not in r}
    for ref in ("hbm", "shooting"):  # against HBM, and against full shooting (no truncation in harmonics)
        for k in a:
            if k != ref and ref in a:
                for name in a[ref]:
                    nums[f"solve_{k}_{ref}_rel_diff_{name}"] = abs(a[k][name] / a[ref][name] - 1.0)
    branches = {}
    for b in sweeps:
        k = b["method"]
        branches[k] = {key: b[key] for key in ("omega", "amplitude", "stable", "stability_method", "certified",
                                               "bifurcations", "success", "message", "points", "wall_time_s",
                                               "options", "dofs", "n_dofs", "counters")}
        branches[k]["cpu_time_s"] = b.get("cpu_time_s")
        w, a = peak(b)
        cnt = b.get("counters", {})
        cond = cnt.get("condensation", {})
        nums.update({f"{k}_n_dofs": b["n_dofs"], f"{k}_integrator": b["options"].get("integrator", "moreau") if k in ("mshbm", "shooting") else None,
                     f"{k}_corrector_failures": cnt.get("corrector_failures"),
                     f"{k}_corrector_iterations": cnt.get("corrector_iterations"),
                     f"{k}_residual_evaluations": cnt.get("residual_evaluations"),
                     f"{k}_factorisations": cond.get("factorisations"),
                     f"{k}_refined": cond.get("refined"),
                     f"{k}_time_per_point": b["wall_time_s"] / max(b["points"], 1)})
        cpu = b.get("cpu_time_s")
        red_b = b.get("reduction") or {}
        ends = [e for e in red_b.get("error_estimate_ends", []) if e is not None]
        nums.update({f"{k}_cpu_time": cpu, f"{k}_cpu_per_point": None if cpu is None else cpu / max(b["points"], 1),
                     f"{k}_reduction_estimate": max(ends) if ends else None,
                     f"{k}_stability_method": next((m_ for m_ in b["stability_method"]  # "none: <reason>": no analysis
                                                                   if m_ and not m_.startswith("none")), None)})
        checks = b.get("checks") or []
        if checks:  # the curve's last point against event-driven full shooting started from it
            c_ = checks[-1]
            nums.update({f"{k}_check_omega": c_["omega"], f"{k}_check_success": c_["success"],
                         f"{k}_check_tip": c_["branch"].get("tip"), f"{k}_check_shooting_tip": c_["shooting"].get("tip"),
                         f"{k}_check_rel_diff_tip": abs(c_["shooting"]["tip"] / c_["branch"]["tip"] - 1.0),
                         f"{k}_checks_max_rel_diff_tip": max(abs(c["shooting"]["tip"] / c["branch"]["tip"] - 1.0)
                                                             for c in checks)})
        nums.update({f"{k}_time": b["wall_time_s"], f"{k}_points": b["points"], f"{k}_success": b["success"],
                     f"{k}_peak_omega": w, f"{k}_peak_tip": a,
                     f"{k}_unstable": sum(v is False for v in b["stable"]),
                     f"{k}_no_stability": sum(v is None for v in b["stable"]),
                     f"{k}_folds": sum(1 for f in b["bifurcations"] if f.get("type") == "fold"),
                     f"{k}_omega_min": min(b["omega"]) if b["omega"] else None,
                     f"{k}_omega_max": max(b["omega"]) if b["omega"] else None,
                     f"{k}_message": b["message"],
                     # the end of the range reached (success also needs every point certified within the accuracy)
                     f"{k}_reached_end": b["message"].startswith("reached lam_end"),
                     f"{k}_estimated": b["options"].get("accuracy", True) is not False,
                     f"{k}_uncertified": sum(not c for c in b["certified"])})
        nums["omega_start"], nums["omega_end"] = (r * b["omega_1"] for r in b["omega_ratio"])
        nums["harmonics"] = b["options"].get("harmonics", nums.get("harmonics"))
        if "steps" in b["options"] and k == "mshbm":
            nums["steps"] = b["options"]["steps"]
    names = [b["method"] for b in sweeps]
    for i, x in enumerate(names):
        for y in names[i + 1:]:
            (wx, ax), (wy, ay) = peak(branches[x]), peak(branches[y])
            if ax and ay:
                nums[f"{x}_{y}_peak_rel_diff"] = abs(ax / ay - 1.0)
                nums[f"{x}_{y}_peak_omega_rel_diff"] = abs(wx / wy - 1.0)
            for dof in branches[x]["amplitude"]:  # both orders: the reference must be the one without folds
                nums[f"{x}_{y}_max_rel_diff_{dof}"] = max_rel_diff(branches[x], branches[y], dof)
                nums[f"{y}_{x}_max_rel_diff_{dof}"] = max_rel_diff(branches[y], branches[x], dof)
            nums[f"{x}_{y}_common_omega_max"] = nums[f"{y}_{x}_common_omega_max"] = \
                min(max(branches[x]["omega"] or [0]), max(branches[y]["omega"] or [0]))
    return {"numbers": nums, "model": {k: m[k] for k in m if k != "params"}, "params": p,
            "solves": solves["solves"], "branches": branches}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--modes", required=True)
    ap.add_argument("--solves", required=True)
    ap.add_argument("--solve-modes", default=None, help="modes.json of the single solves' model")
    ap.add_argument("--out", required=True)
    ap.add_argument("sweeps", nargs="+")
    a = ap.parse_args(argv)
    out = summarize(_load(a.modes), _load(a.solves), [_load(f) for f in a.sweeps],
                    _load(a.solve_modes) if a.solve_modes else None)
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    with open(a.out, "w") as fh:
        json.dump(out, fh, indent=1, allow_nan=False)
        fh.write("\n")
    print(json.dumps(out["numbers"], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
