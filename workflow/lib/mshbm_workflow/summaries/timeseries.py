"""Summary of a time-series figure (Figs. 3, 5, 6): HBM and MS-HBM at one n_H each against full shooting
(reference steps), stick fractions or impacts, the long run from rest and the impact time (Fig. 6)."""
import math

from mshbm_workflow.summaries.common import (_claim, amp_errors, facts_subset, impact_time_numbers, longrun_numbers,
                                             pct, stability_numbers)


def summarize_timefigure(fig, fcfg, res):
    ref, sh = res["ref"], res["shooting"]
    hb, ms = res[f"hbm_nh{fcfg['hbm_harmonics']}"], res[f"mshbm_nh{fcfg['mshbm_harmonics']}"]
    methods = {"reference": ref, "shooting": sh, "mshbm": ms, "hbm": hb}
    out = {"figure": fig, "system": fcfg["system"], "hbm_harmonics": fcfg["hbm_harmonics"],
           "mshbm_harmonics": fcfg["mshbm_harmonics"],
           "methods": {k: facts_subset(v) for k, v in methods.items()},
           "errors": {k: amp_errors(v, ref) for k, v in methods.items() if k != "reference"}}
    num = {}
    for k, v in methods.items():
        num[f"{k}_success"] = bool(v["success"])
        num[f"{k}_start"] = v.get("start_used") or "none"
        num[f"{k}_iterations"] = v.get("iterations")
        num[f"{k}_amp_first"] = v.get("amplitude_first")
        num[f"{k}_amp_last"] = v.get("amplitude_last")
        num[f"{k}_message"] = v.get("message")
        if k != "reference":
            num[f"{k}_err_max"] = out["errors"][k]["err_max"]
            num[f"{k}_err_first"] = out["errors"][k]["err_first"]
            num[f"{k}_err_last"] = out["errors"][k]["err_last"]
    for k in ("reference", "shooting", "mshbm", "hbm"):
        num.update(stability_numbers(k, methods[k]))
    num.update(longrun_numbers(res.get("longrun")))
    num.update(impact_time_numbers(res.get("impact_time")))
    claims = []
    if fig == "fig3":
        num["stick_fraction_shooting"] = sh.get("stick_or_closed_fraction")
        num["stick_fraction_reference"] = ref.get("stick_or_closed_fraction")
        num["stick_fraction_mshbm"] = ms.get("stick_or_closed_fraction")
        num["friction_bound"] = ref.get("friction_bound")
        sf = ref.get("stick_or_closed_fraction") or 0.0
        claims.append(_claim(fig, "stick_slip", f"mass 1 sticks {pct(sf)} of the period (reference shooting), "
                             f"{pct(num['stick_fraction_mshbm'])} (MS-HBM)",
                             "agrees" if 0.1 < sf < 0.9 else "disagrees"))
        e_ms, e_hb = num["mshbm_err_max"], num["hbm_err_max"]
        if hb["success"]:
            ours = (f"largest amplitude error of the 3 masses: MS-HBM {pct(e_ms)}, HBM {pct(e_hb)}"
                    + (" (HBM started from another method's solution)" if hb.get("display_only") else ""))
            verdict = "agrees" if e_ms < e_hb else "disagrees"
        else:
            ours = f"MS-HBM {pct(e_ms)}; HBM did not converge ({hb['message']})"
            verdict = "not testable"
        claims.append(_claim(fig, "mshbm_better", ours, verdict))
    else:
        for k in ("reference", "shooting", "mshbm", "hbm"):
            v = methods[k]
            num[f"{k}_impulse_steps"] = v.get("impulse_steps")
            num[f"{k}_impact_clusters"] = v.get("impact_clusters")
            num[f"{k}_contact_episodes"] = v.get("contact_episodes")
            num[f"{k}_max_penetration"] = v.get("max_penetration")
            imp = v.get("impacts") or []
            if imp:
                num[f"{k}_impact_time"] = imp[0]["t"]
                num[f"{k}_u_before"] = imp[0]["u_before"]
                num[f"{k}_u_after"] = imp[0]["u_after"]
            ep = v.get("contact_episode_times") or []
            if ep:
                num[f"{k}_contact_time"] = ep[0]
        if fig == "fig5":
            if hb["success"]:
                ours = (f"largest amplitude error of the 5 masses: MS-HBM {pct(num['mshbm_err_max'])}, "
                        f"HBM {pct(num['hbm_err_max'])}")
                verdict = "agrees" if num["mshbm_err_max"] < num["hbm_err_max"] else "disagrees"
            else:
                ours = (f"MS-HBM within {pct(num['mshbm_err_max'])} of shooting; HBM with the penalty contact did "
                        f"not converge from any start ({hb['message']})")
                verdict = "partly (HBM not converged)"
            claims.append(_claim(fig, "agreement", ours, verdict))
        else:
            t_sh = num.get("reference_impact_time")
            ours = (f"impact at t = {t_sh:.3f} s; jump of u_1 from {num.get('reference_u_before', math.nan):.3f} to "
                    f"{num.get('reference_u_after', math.nan):.3f} m/s (reference shooting), "
                    f"MS-HBM {num.get('mshbm_u_before', math.nan):.3f} to {num.get('mshbm_u_after', math.nan):.3f}"
                    if t_sh is not None else "no impact found")
            if not hb["success"]:
                ours += "; HBM did not converge"
            if num.get("it_closest_name"):
                ours += (f"; no candidate puts a periodic impact at 0.55 s: closest {num['it_closest_name']}, "
                         f"{num['it_closest_which']}, t = {num['it_closest_t']:.3f} s")
            claims.append(_claim(fig, "jump", ours, "agrees (jump), time differs" if t_sh is not None
                                 and abs(t_sh - 0.55) > 0.05 else "agrees"))
    out["numbers"] = num
    out["claims"] = claims
    return out
