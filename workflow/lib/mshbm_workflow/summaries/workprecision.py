"""Summary of a work-precision diagram (Figs. 4, 8): for every method and n_H the amplitude errors of
masses 1 and n against the error reference and the effort (median time relative to full shooting from the
same start), the finite-difference variants, and the paper's claims on accuracy and effort."""
from mshbm_workflow.summaries.common import CLAIMS, DRASTIC, amp_errors, facts_subset, pct, stability_numbers
from mshbm_workflow.wfcore import rel_err


def sweep_row(method, nh, r, ref, sh, clock="wall"):
    """One point of a work-precision diagram; effort = median time / full shooting's from the same start."""
    ok = bool(r.get("timed_success"))
    start = r.get("start_used") if ok else None
    err = amp_errors(r, ref) if ok else {"err_first": None, "err_last": None, "err_max": None}
    t_med = r.get(f"{clock}_time_median") if ok else None
    # the effort reference is full shooting from the same start; if full shooting did not converge
    # from that start, from the other one (recorded in effort_ref_start)
    ref_start = start
    if start and not (sh.get(f"{clock}_time_median_by_start") or {}).get(start):
        ref_start = sh.get("start_used")
    t_ref = (sh.get(f"{clock}_time_median_by_start") or {}).get(ref_start) if ref_start else None
    alt = "cpu" if clock == "wall" else "wall"
    a_med = r.get(f"{alt}_time_median") if ok else None
    a_ref = (sh.get(f"{alt}_time_median_by_start") or {}).get(ref_start) if ref_start else None
    return {
        "method": method, "harmonics": nh, "success": ok, "start": start,
        "message": r.get("message"), "iterations": r.get("iterations") if ok else None,
        # machine-independent effort: residual evaluations, Moreau-Jean steps (x integrated DOFs)
        "nfev": r.get("nfev") if ok else None,
        "integration_steps": (r.get("work") or {}).get("steps") if ok else None,
        "dof_steps": (r.get("work") or {}).get("dof_steps") if ok else None,
        "load_1min": _load(r) if ok else None,
        "shooting_dof_steps": ((sh.get("work_by_start") or {}).get(ref_start) or {}).get("dof_steps")
        if (ok and ref_start) else None,
        "shooting_nfev": ((sh.get("work_by_start") or {}).get(ref_start) or {}).get("nfev")
        if (ok and ref_start) else None,
        "err_first": err["err_first"], "err_last": err["err_last"],
        "time_median": t_med, "shooting_time_median": t_ref,
        "effort": (t_med / t_ref) if (t_med is not None and t_ref) else None,
        "effort_ref_start": ref_start,
        f"effort_{alt}": (a_med / a_ref) if (a_med is not None and a_ref) else None,
        "clock": clock,
        "failed_wall_time": None if ok else _failed_wall(r),
        "amplitude_first": r.get("amplitude_first") if ok else None,
        "amplitude_last": r.get("amplitude_last") if ok else None,
        "display_start": r.get("start_used"), "display_success": bool(r.get("success")),
        "nearby_message": next((a["nearby"]["message"] for a in r.get("attempts", []) if a.get("nearby")), None),
        "nearby_success": next((a["nearby"]["success"] for a in r.get("attempts", []) if a.get("nearby")), None),
        "nearby_residual": next((a["nearby"]["residual"] for a in r.get("attempts", []) if a.get("nearby")), None),
        "impulse_steps": r.get("impulse_steps"), "impact_clusters": r.get("impact_clusters"),
        "contact_episodes": r.get("contact_episodes"), "max_penetration": r.get("max_penetration"),
        "stick_fraction": r.get("stick_or_closed_fraction"),
    }


def _load(r):
    """1-minute load average of the machine when the solve was timed (largest of before/after)."""
    m = r.get("machine") or {}
    loads = [x["loadavg"][0] for x in (m.get("before"), m.get("after")) if x and x.get("loadavg")]
    return max(loads) if loads else None


def error_reference(res):
    """The error reference of a work-precision figure: the exact event-driven solution if it converged
    (``res["exact"]``), else the reference full shooting; and a label saying which."""
    ex = res.get("exact")
    if ex and ex.get("success"):
        return ex, "exact"
    return res["ref"], "shooting"


def sweep_methods(res, nhs):
    """The harmonic methods of a work-precision sweep present in ``res``: HBM and MS-HBM, and DLFT
    when the workflow solved it (``SWEEP_METHODS`` of workflow/rules/common.smk)."""
    return [m for m in ("hbm", "mshbm", "dlft") if m in ("hbm", "mshbm") or f"{m}_nh{nhs[0]}" in res]


def summarize_sweep(fig, fcfg, res, clock="wall"):
    sh = res["shooting"]
    ref, ref_kind = error_reference(res)
    shref = res["ref"]
    nhs = list(fcfg["harmonics"])
    sh_times = sh.get(f"{clock}_time_median_by_start") or {}
    methods = sweep_methods(res, nhs)
    rows = [sweep_row(method, nh, res[f"{method}_nh{nh}"], ref, sh, clock)
            for method in methods for nh in nhs]
    fd_rows = []
    if "shooting-fd" in res:
        fd_rows = [sweep_row("mshbm-fd", nh, res[f"mshbm-fd_nh{nh}"], ref, res["shooting-fd"], clock)
                   for nh in fcfg.get("fd_harmonics", [])]
    floor = amp_errors(sh, ref)
    shref_err = amp_errors(shref, ref) if ref_kind == "exact" else {"err_first": None, "err_last": None}
    out = {"figure": fig, "system": fcfg["system"], "harmonics": nhs, "rows": rows, "fd_rows": fd_rows, "clock": clock,
           "error_reference": ref_kind,
           "reference": facts_subset(shref), "shooting": facts_subset(sh),
           "exact": {k: v for k, v in (res.get("exact") or {}).items() if k != "impacts"},
           "shooting_error": {"err_first": floor["err_first"], "err_last": floor["err_last"]},
           "reference_shooting_error": shref_err}
    loads = [r["load_1min"] for r in rows + fd_rows if r["load_1min"] is not None] + \
        [x for x in (_load(sh), _load(res.get("shooting-fd") or {})) if x is not None]
    cpus = ((sh.get("machine") or {}).get("before") or {}).get("cpus")
    num = {"reference_amp_first": shref.get("amplitude_first"), "reference_amp_last": shref.get("amplitude_last"),
           "reference_start": shref.get("start_used"), "shooting_start": sh.get("start_used"),
           "reference_iterations": shref.get("iterations"), "shooting_iterations": sh.get("iterations"),
           "shooting_err_first": floor["err_first"], "shooting_err_last": floor["err_last"],
           # which solution the errors are measured against; the reference shooting's own error against it
           "error_reference": ref_kind, "exact_success": bool((res.get("exact") or {}).get("success")),
           "exact_amp_first": ref.get("amplitude_first") if ref_kind == "exact" else None,
           "exact_amp_last": ref.get("amplitude_last") if ref_kind == "exact" else None,
           "refshooting_err_first": shref_err["err_first"], "refshooting_err_last": shref_err["err_last"],
           "refshooting_err_max": (max(shref_err["err_first"], shref_err["err_last"])
                                   if shref_err["err_first"] is not None else None),
           # machine-independent effort of full shooting (the effort reference) and the load when timed
           "shooting_nfev": sh.get("nfev"), "shooting_integration_steps": (sh.get("work") or {}).get("steps"),
           "shooting_dof_steps": (sh.get("work") or {}).get("dof_steps"),
           "timing_load_max": max(loads) if loads else None, "timing_load_min": min(loads) if loads else None,
           "timing_cpus": cpus,
           "shooting_time": sh.get(f"{clock}_time_median"), "shooting_time_linear": sh_times.get("linear"),
           "shooting_time_nearby": sh_times.get("nearby"),
           "reference_stick_fraction": shref.get("stick_or_closed_fraction"),
           "reference_impulse_steps": shref.get("impulse_steps"),
           "reference_impact_clusters": shref.get("impact_clusters")}
    num.update(stability_numbers("reference", shref))
    num.update(stability_numbers("shooting", sh))
    for nh in nhs:
        num.update(stability_numbers(f"mshbm_nh{nh}", res[f"mshbm_nh{nh}"]))
    for method in methods:  # verdicts of the converged solutions of the sweep
        verdicts = [res[f"{method}_nh{nh}"].get("stable") for nh in nhs if res[f"{method}_nh{nh}"].get("success")]
        num[f"{method}_stable_count"] = sum(v is True for v in verdicts)
        num[f"{method}_unstable_count"] = sum(v is False for v in verdicts)
        num[f"{method}_undecided_count"] = sum(v is None for v in verdicts)
    if "check" in res:
        chk = res["check"]
        out["check"] = facts_subset(chk)
        num.update(check_success=bool(chk["success"]), check_amp_first=chk.get("amplitude_first"),
                   check_amp_last=chk.get("amplitude_last"),
                   check_stick_fraction=chk.get("stick_or_closed_fraction"),
                   check_floquet=chk.get("floquet_max_modulus"), check_stable=chk.get("stable"))
    for row in rows:
        p = f"{row['method']}_nh{row['harmonics']}"
        for k in ("success", "start", "err_first", "err_last", "effort", "time_median", "iterations", "nfev",
                  "integration_steps", "dof_steps"):
            num[f"{p}_{k}"] = row[k]
        num[f"{p}_err_max"] = (max(row["err_first"], row["err_last"]) if row["success"] else None)
    if fd_rows:
        shfd = res["shooting-fd"]
        out["shooting_fd"] = facts_subset(shfd)
        num.update(shootingfd_success=bool(shfd.get("timed_success")), shootingfd_time=shfd.get(f"{clock}_time_median"),
                   shootingfd_start=shfd.get("start_used"), shootingfd_iterations=shfd.get("iterations"),
                   shootingfd_err_first=rel_err(shfd.get("amplitude_first"), ref.get("amplitude_first")),
                   shootingfd_nfev=shfd.get("nfev"), shootingfd_integration_steps=(shfd.get("work") or {}).get("steps"),
                   shootingfd_dof_steps=(shfd.get("work") or {}).get("dof_steps"),
                   shootingfd_over_exact=(shfd.get(f"{clock}_time_median") / sh.get(f"{clock}_time_median")
                                          if shfd.get(f"{clock}_time_median") and sh.get(f"{clock}_time_median")
                                          and shfd.get("start_used") == sh.get("start_used") else None))
        for row in fd_rows:
            p = f"mshbmfd_nh{row['harmonics']}"
            for k in ("success", "start", "err_first", "err_last", "effort", "time_median", "iterations"):
                num[f"{p}_{k}"] = row[k]
        eff = [r["effort"] for r in fd_rows if r["effort"] is not None]
        num["mshbmfd_effort_min"] = min(eff) if eff else None
        num["mshbmfd_effort_max"] = max(eff) if eff else None
        num["mshbmfd_converged"] = sum(r["success"] for r in fd_rows)
        num["mshbmfd_failed"] = sum(not r["success"] for r in fd_rows)
        # same solution as with the exact Jacobian? (largest relative amplitude difference)
        exact = {r["harmonics"]: r for r in rows if r["method"] == "mshbm"}
        diffs = [abs(r["amplitude_first"] / exact[r["harmonics"]]["amplitude_first"] - 1)
                 for r in fd_rows if r["success"] and exact.get(r["harmonics"], {}).get("success")]
        num["mshbmfd_vs_exact_maxdiff"] = max(diffs) if diffs else None
    for method in methods:
        mrows = [r for r in rows if r["method"] == method]
        num[f"{method}_converged"] = sum(r["success"] for r in mrows)
        num[f"{method}_failed"] = sum(not r["success"] for r in mrows)
        num[f"{method}_failed_nh"] = ", ".join(str(r["harmonics"]) for r in mrows if not r["success"]) or "none"
        ok = [r for r in mrows if r["success"]]
        emax = lambda r: max(r["err_first"], r["err_last"])
        num[f"{method}_nhmin_err_max"] = emax(mrows[0]) if mrows[0]["success"] else None
        num[f"{method}_nhmax_err_max"] = emax(mrows[-1]) if mrows[-1]["success"] else None
        best = min(ok, key=emax) if ok else None
        num[f"{method}_best_err_max"] = emax(best) if best else None
        num[f"{method}_best_nh"] = best["harmonics"] if best else None
        num[f"{method}_best_effort"] = best["effort"] if best else None
        num[f"{method}_nhmax_effort"] = mrows[-1]["effort"] if mrows[-1]["success"] else None
        num[f"{method}_nhmax_iterations"] = mrows[-1]["iterations"] if mrows[-1]["success"] else None
        num[f"{method}_nearby"] = sum(r["start"] == "nearby" for r in mrows)
        nres = [r["nearby_residual"] for r in mrows if r["nearby_success"] is False and r["nearby_residual"] is not None]
        num[f"{method}_nearby_failed"] = len(nres)
        num[f"{method}_nearby_fail_residual_min"] = min(nres) if nres else None
        num[f"{method}_nearby_fail_residual_max"] = max(nres) if nres else None
        num[f"{method}_linear"] = sum(r["start"] == "linear" for r in mrows)
    if "dlft" in methods:  # DLFT against HBM and MS-HBM at equal n_H, where both converged
        emax = lambda r: max(r["err_first"], r["err_last"])
        by = {(r["method"], r["harmonics"]): r for r in rows}
        for other in ("hbm", "mshbm"):
            both = [nh for nh in nhs if by[("dlft", nh)]["success"] and by[(other, nh)]["success"]]
            num[f"dlft_vs_{other}_both"] = len(both)
            num[f"dlft_better_than_{other}"] = sum(emax(by[("dlft", nh)]) < emax(by[(other, nh)]) for nh in both)
        ok = [nh for nh in nhs if by[("dlft", nh)]["success"] and by[("mshbm", nh)]["success"]]
        ratios = [emax(by[("dlft", nh)]) / max(emax(by[("mshbm", nh)]), 1e-300) for nh in ok]
        num["dlft_over_mshbm_error_min"] = min(ratios) if ratios else None
        num["dlft_over_mshbm_error_max"] = max(ratios) if ratios else None
    num["n_harmonics"] = len(nhs)
    out["numbers"] = num
    out["claims"] = sweep_claims(fig, rows, num, nhs, fd_rows)
    return out


def _failed_wall(r):
    walls = [a.get("wall_time") for a in r.get("attempts", []) if not a.get("display_only")]
    walls = [w for w in walls if w is not None]
    return max(walls) if walls else None


def sweep_claims(fig, rows, num, nhs, fd_rows=()):
    by = {(r["method"], r["harmonics"]): r for r in rows}
    both = [nh for nh in nhs if by[("hbm", nh)]["success"] and by[("mshbm", nh)]["success"]]
    better = [nh for nh in both if max(by[("mshbm", nh)]["err_first"], by[("mshbm", nh)]["err_last"])
              < max(by[("hbm", nh)]["err_first"], by[("hbm", nh)]["err_last"])]
    worse = [nh for nh in both if nh not in better]
    num["both_converged"] = len(both)
    num["mshbm_better_count"] = len(better)
    num["mshbm_worse_nh"] = ", ".join(map(str, worse)) or "none"
    ms_fail = [nh for nh in nhs if not by[("mshbm", nh)]["success"]]
    ours = (f"MS-HBM more accurate (larger of the two mass errors) at {len(better)} of the {len(both)} n_H where both "
            f"converged" + (f"; not at n_H = {', '.join(map(str, worse))}" if worse else "")
            + (f"; HBM failed at n_H = {num['hbm_failed_nh']}" if num["hbm_failed"] else "")
            + (f"; MS-HBM failed at n_H = {', '.join(map(str, ms_fail))}" if ms_fail else ""))
    if not both:
        verdict = "not testable"
    elif not worse:
        verdict = "agrees"
    else:
        verdict = "partly"
    claims = [{"key": "mshbm_more_accurate", "paper": dict(CLAIMS[fig])["mshbm_more_accurate"], "ours": ours,
               "verdict": verdict}]
    ms_rows = [by[("mshbm", nh)] for nh in nhs if by[("mshbm", nh)]["success"]]
    # smallest n_H at which MS-HBM is within 2 % (and 1 %) on both masses, and its effort
    for lim, tag in ((0.02, "2pct"), (0.01, "1pct")):
        hit = next((r for r in ms_rows if max(r["err_first"], r["err_last"]) < lim), None)
        num[f"mshbm_nh_{tag}"] = hit["harmonics"] if hit else None
        num[f"mshbm_effort_{tag}"] = hit["effort"] if hit else None
        num[f"mshbm_err_{tag}"] = max(hit["err_first"], hit["err_last"]) if hit else None
        num[f"mshbm_saving_{tag}"] = 1.0 / hit["effort"] if hit and hit["effort"] else None
        num[f"mshbm_start_{tag}"] = hit["start"] if hit else None
        # the same comparison in machine-independent counts: residual evaluations and Moreau-Jean steps
        # times integrated DOFs of MS-HBM over those of full shooting from the same start
        num[f"mshbm_nfev_{tag}"] = hit["nfev"] if hit else None
        num[f"mshbm_iterations_{tag}"] = hit["iterations"] if hit else None
        num[f"mshbm_dofsteps_{tag}"] = hit["dof_steps"] if hit else None
        sh_ds = (hit or {}).get("shooting_dof_steps")
        num[f"shooting_dofsteps_{tag}"] = sh_ds
        num[f"mshbm_dofstep_ratio_{tag}"] = (hit["dof_steps"] / sh_ds if hit and hit["dof_steps"] and sh_ds
                                              else None)
        hb_rows = [by[("hbm", nh)] for nh in nhs if by[("hbm", nh)]["success"]]
        hhit = next((r for r in hb_rows if max(r["err_first"], r["err_last"]) < lim), None)
        num[f"hbm_nh_{tag}"] = hhit["harmonics"] if hhit else None
        num[f"hbm_effort_{tag}"] = hhit["effort"] if hhit else None
    efforts = [r["effort"] for r in ms_rows if r["effort"] is not None]
    num["mshbm_effort_min"] = min(efforts) if efforts else None
    num["mshbm_effort_max"] = max(efforts) if efforts else None
    errs = [max(r["err_first"], r["err_last"]) for r in ms_rows]
    num["mshbm_err_min"] = min(errs) if errs else None
    tail = [max(r["err_first"], r["err_last"]) for r in ms_rows if r["harmonics"] >= nhs[len(nhs) // 2]]
    num["mshbm_err_plateau"] = (sorted(tail)[len(tail) // 2] if tail else None)
    if fig == "fig4":
        floor = max(num["shooting_err_first"] or 0, num["shooting_err_last"] or 0)
        claims.append({"key": "plateau", "paper": dict(CLAIMS[fig])["plateau"],
                       "ours": f"MS-HBM error over the upper half of the n_H range: median {pct(num['mshbm_err_plateau'])} "
                               f"against the {num['error_reference']} reference; full shooting with the working step "
                               f"count is off it by {pct(floor)}"
                               + (f", the reference full shooting ({'finer'} steps) by {pct(num['refshooting_err_max'])}"
                                  if num.get("refshooting_err_max") is not None else ""),
                       "verdict": "agrees" if tail and num["mshbm_err_plateau"] < 10 * max(floor, 1e-6) else "partly"})
        # "drastically": at least a factor DRASTIC less effort than full shooting, at 1 % accuracy
        e1 = num["mshbm_effort_1pct"]
        ours = ((f"MS-HBM is within 1 % from n_H = {num['mshbm_nh_1pct']} at an effort of {e1:.2g} x full shooting"
                 if e1 is not None else "MS-HBM never within 1 %")
                + (f"; over all n_H {num['mshbm_effort_min']:.2g}-{num['mshbm_effort_max']:.2g} x" if efforts else "")
                + " (exact Jacobians)")
        verdict = ("agrees" if e1 is not None and e1 <= DRASTIC else "disagrees" if e1 is not None
                   else "not testable")
        fd_ok_rows = [r for r in fd_rows if r["success"] and r["effort"] is not None]
        hit = next((r for r in fd_ok_rows if max(r["err_first"], r["err_last"]) < 0.01), None)
        num["mshbmfd_effort_1pct"] = hit["effort"] if hit else None
        num["mshbmfd_nh_1pct"] = hit["harmonics"] if hit else None
        num["mshbmfd_saving_1pct"] = 1.0 / hit["effort"] if hit and hit["effort"] else None
        num["mshbm_saving_1pct"] = 1.0 / e1 if e1 else None
        if fd_ok_rows:
            fd_eff = [r["effort"] for r in fd_ok_rows]
            ours += (f"; with the paper's finite-difference Jacobian for both methods: "
                     + (f"{hit['effort']:.2g} x at n_H = {hit['harmonics']}, " if hit else "")
                     + f"{min(fd_eff):.2g}-{max(fd_eff):.2g} x over all n_H")
            if verdict == "disagrees" and hit and hit["effort"] <= DRASTIC:
                verdict = "agrees only with FD Jacobians"
        claims.append({"key": "effort", "paper": dict(CLAIMS[fig])["effort"], "ours": ours, "verdict": verdict})
    else:
        e2, nh2 = num["mshbm_effort_2pct"], num["mshbm_nh_2pct"]
        claims.insert(0, {"key": "two_percent", "paper": dict(CLAIMS[fig])["two_percent"],
                          "ours": (f"MS-HBM within {pct(num['mshbm_err_2pct'])} from n_H = {nh2} at "
                                   f"{e2:.2f} x the effort of full shooting (start: {num['mshbm_start_2pct']})"
                                   if e2 is not None else "MS-HBM never within 2 %"),
                          "verdict": ("agrees" if e2 is not None and e2 <= DRASTIC * 1.25 else
                                      "partly" if e2 is not None and e2 < 1 else "disagrees")})
    return claims
