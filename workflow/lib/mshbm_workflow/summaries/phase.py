"""Summary of the phase diagram of the impact chain (Fig. 7): MS-HBM at the figure's n_H against the
reference, the impacts per period, the long run from rest."""
from mshbm_workflow.summaries.common import CLAIMS, facts_subset, longrun_numbers, pct, stability_numbers
from mshbm_workflow.wfcore import rel_err


def summarize_fig7(fcfg, res):
    ref = res["ref"]
    out = {"figure": "fig7", "system": fcfg["system"], "harmonics": list(fcfg["harmonics"]),
           "reference": facts_subset(ref), "solves": {}}
    num = {"reference_impulse_steps": ref.get("impulse_steps"),
           "reference_impact_clusters": ref.get("impact_clusters"),
           "reference_max_cluster": max(ref.get("impact_cluster_sizes") or [0]),
           "reference_start": ref.get("start_used"), "reference_amp_first": ref.get("amplitude_first")}
    num.update(stability_numbers("reference", ref))
    num.update(longrun_numbers(res.get("longrun")))
    for method in ("hbm", "mshbm"):
        for nh in fcfg["harmonics"]:
            r = res[f"{method}_nh{nh}"]
            out["solves"][f"{method}_nh{nh}"] = facts_subset(r)
            p = f"{method}_nh{nh}"
            num[f"{p}_success"] = bool(r["success"])
            num[f"{p}_start"] = r.get("start_used") or "none"
            num[f"{p}_display_only"] = bool(r.get("display_only"))
            num[f"{p}_impulse_steps"] = r.get("impulse_steps")
            num[f"{p}_impact_clusters"] = r.get("impact_clusters")
            num[f"{p}_contact_episodes"] = r.get("contact_episodes")
            num[f"{p}_max_penetration"] = r.get("max_penetration")
            num[f"{p}_err_first"] = rel_err(r.get("amplitude_first"), ref["amplitude_first"]) if r["success"] else None
            num.update(stability_numbers(p, r))
    # accumulation of impacts: mshbm.accumulation on the exact event-driven solution (impact times to machine
    # precision) where it converged, else on the impulse steps of the reference full shooting
    ex = res.get("exact") or {}
    acc_mj = ref.get("accumulations") or []
    acc_ex = ex.get("accumulations") or [] if ex.get("success") else None
    accumulation = bool(acc_ex) if acc_ex is not None else bool(acc_mj)
    num["accumulation"] = accumulation
    num["accumulation_source"] = "exact" if acc_ex is not None else "shooting"
    num["accumulation_shooting"] = bool(acc_mj)
    num["exact_success"] = bool(ex.get("success"))
    num["exact_impacts"] = ex.get("n_impacts")
    num["exact_floquet"] = ex.get("floquet_max_modulus")
    imp = ex.get("impacts") or []
    num["exact_impact_speed_min"] = min(abs(i["velocity"]) for i in imp) if imp else None
    out["exact"] = {k: v for k, v in ex.items()}
    src = (f"exact event-driven solution: {ex.get('n_impacts')} impact(s) per period"
           if acc_ex is not None else f"reference shooting: {num['reference_impulse_steps']} impulse step(s) per "
                                      f"period in {num['reference_impact_clusters']} impact(s)")
    claims = [{"key": "accumulation", "paper": dict(CLAIMS["fig7"])["accumulation"],
               "ours": (src + "; " + ("an accumulation of impacts" if accumulation else "no accumulation of impacts")
                        + " (detector: geometric runs of impact intervals, mshbm.accumulation)"),
               "verdict": "agrees" if accumulation else "disagrees"}]
    ms_ok = [nh for nh in fcfg["harmonics"] if num[f"mshbm_nh{nh}_success"]]
    pen = [num[f"mshbm_nh{nh}_max_penetration"] for nh in ms_ok]
    hb_pen = [num[f"hbm_nh{nh}_max_penetration"] for nh in fcfg["harmonics"] if num[f"hbm_nh{nh}_success"]]
    claims.append({"key": "mshbm_good", "paper": dict(CLAIMS["fig7"])["mshbm_good"],
                   "ours": (f"MS-HBM converged for n_H = {', '.join(map(str, ms_ok)) or 'none'}; mass-1 amplitude error "
                            + ", ".join(f"{pct(num[f'mshbm_nh{nh}_err_first'])} (n_H = {nh})" for nh in ms_ok)
                            + (f"; largest q_1 - g_0 = {max(pen):.1e} m (no penetration)" if pen else "")
                            + (f"; HBM penetrates up to {max(hb_pen):.2e} m" if hb_pen else "; HBM did not converge")),
                   "verdict": "agrees" if ms_ok and max(pen) <= 1e-9 else "partly"})
    out["numbers"] = num
    out["claims"] = claims
    return out
