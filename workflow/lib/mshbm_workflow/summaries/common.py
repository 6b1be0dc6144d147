"""What every figure summary uses: the paper's claims (``CLAIMS``, one verdict each), the facts of one
solve, its stability, the long run from rest, amplitude errors against a reference, the system's
parameters for the text.  Amplitudes are ``(max - min) / 2`` over one period (m); errors relative.
"""
from mshbm_workflow.wfcore import rel_err

CLAIMS = {
    "fig3": [
        ("stick_slip", "Mass 1 shows a pronounced stick-slip behaviour."),
        ("mshbm_better", "MS-HBM with n_H = 3 approximates full shooting much better than HBM with n_H = 20 "
                         "(kappa = 800)."),
    ],
    "fig4": [
        ("mshbm_more_accurate", "MS-HBM is more accurate than HBM for every n_H."),
        ("plateau", "The MS-HBM error reaches a plateau (limited resolution of the FFT and the time "
                    "integration)."),
        ("effort", "The effort for a moderate accuracy is reduced drastically by MS-HBM."),
    ],
    "fig5": [
        ("agreement", "MS-HBM and full shooting agree; HBM (penalty contact) approximates the displacements."),
    ],
    "fig6": [
        ("jump", "MS-HBM and full shooting show a true velocity jump at the impact (paper: t = 0.55 s); HBM "
                 "only a rough approximation."),
    ],
    "fig7": [
        ("accumulation", "The periodic solution has an accumulation point of impacts (infinitely many impacts "
                         "in finite time)."),
        ("mshbm_good", "MS-HBM approximates it well with a few harmonics and fulfils non-penetration exactly; "
                       "HBM cannot model the effect."),
    ],
    "fig8": [
        ("two_percent", "MS-HBM: less than 2 % amplitude deviation at one fifth of the effort of full shooting."),
        ("mshbm_more_accurate", "MS-HBM is more accurate than HBM (as for Fig. 4)."),
    ],
}


#: "reduced drastically" (Fig. 4 claim): at least a factor 5 less effort, as the "one fifth" of Fig. 8
DRASTIC = 0.2


def pct(x, digits=2):
    if x is None:
        return "n/a"
    if x == 0:
        return "0 %"
    return f"{100 * x:.{digits}g} %"


def facts_subset(r):
    keys = ["method", "harmonics", "steps", "success", "timed_success", "start_used", "display_only", "message",
            "iterations", "residual", "amplitude_first", "amplitude_last", "amplitude", "floquet_max_modulus",
            "floquet_moduli_top", "stable", "stick_or_closed_fraction", "impulse_steps", "impact_clusters",
            "impact_cluster_sizes", "impacts", "contact_episodes", "contact_episode_times", "max_penetration",
            "wall_time_median", "wall_times", "wall_time_median_by_start", "cpu_time_median", "cpu_times",
            "cpu_time_median_by_start", "max_friction_force",
            "friction_bound", "period", "nfev", "work", "work_by_start", "machine", "accumulations",
            "floquet_multipliers", "floquet_dominant", "stability_method", "stability_reason", "stability_details",
            "step_map_max_modulus"]
    out = {k: r.get(k) for k in keys if k in r}
    out["attempts"] = [{k: a.get(k) for k in ("start", "success", "message", "iterations", "wall_time_median",
                                                "display_only", "nearby")} for a in r.get("attempts", [])]
    return out


def mu_text(dom):
    """The dominant Floquet multiplier as text: ``-1.1085`` or ``0.9566 ± 0.3196i``."""
    if not dom:
        return "none"
    re_, im = dom
    text = f"{re_:.4f}" if abs(im) < 1e-9 else f"{re_:.4f} ± {abs(im):.4f}i"
    return text.replace("-", "\u2212")


def stability_numbers(prefix, r):
    """Stability of one solve result for the text: verdict, method, dominant multiplier (mshbm.stability)."""
    st = r.get("stable") if r.get("success") else None
    method = r.get("stability_method") or "none: not assessed"
    dom = r.get("floquet_dominant")
    kind = ""
    if dom and st is False:
        kind = ("period-doubling (flip)" if abs(dom[1]) < 1e-9 and dom[0] < 0 else
                "fold" if abs(dom[1]) < 1e-9 else "Neimark\u2013Sacker (torus)")
    if st is True:
        verdict = "stable"
    elif st is False:
        verdict = f"unstable: {kind} instability, dominant Floquet multiplier {mu_text(dom)}"
    else:
        verdict = "undecided (" + (r.get("stability_reason") or method) + ")"
    return {f"{prefix}_stable": st, f"{prefix}_stability": verdict, f"{prefix}_stability_word":
            {True: "stable", False: "unstable", None: "undecided"}[st],
            f"{prefix}_stability_method": method, f"{prefix}_floquet": r.get("floquet_max_modulus"),
            f"{prefix}_mu": mu_text(dom), f"{prefix}_instability_kind": kind or "none",
            f"{prefix}_step_map_floquet": r.get("step_map_max_modulus")}


def _times(lo, hi):
    words = {0: "never", 1: "once", 2: "twice"}
    if lo == hi:
        return words.get(lo, f"{lo} times")
    return "at most once" if (lo, hi) == (0, 1) else f"{lo} to {hi} times"


def longrun_numbers(lr):
    """What the system does from rest (scripts/solves/longrun.py), for the text."""
    if not lr:
        return {}
    num = {"longrun_periods": lr["periods"], "longrun_period": lr["response_period"],
           "longrun_settled": bool(lr["settled"]),
           "longrun_mj_steps": lr["moreau_jean"]["steps"], "longrun_wall": lr["wall_time_s"],
           "longrun_impacts_per_period": ", ".join(map(str, lr["impacts_per_period_last"])),
           "longrun_tail_impacts_min": lr["impacts_per_period_tail"][0],
           "longrun_tail_impacts_max": lr["impacts_per_period_tail"][1],
           "longrun_tail_impacts_text": _times(*lr["impacts_per_period_tail"])}
    if lr["settled"]:
        num.update(longrun_amp_max=lr["amplitude_first_max"], longrun_amp_min=lr["amplitude_first_min"],
                   longrun_mj_amp_max=lr["moreau_jean"]["amplitude_first_max"],
                   longrun_mj_amp_min=lr["moreau_jean"]["amplitude_first_min"],
                   longrun_impact_times=", ".join(f"{i['t_mod_T']:.3f}" for imps in
                                                  lr["impacts_last"][-lr["response_period"]:] for i in imps))
        orb = lr.get("response_orbit") or {}
        num.update(longrun_orbit_success=bool(orb.get("success")), longrun_orbit_floquet=orb.get("max_modulus"),
                   longrun_orbit_stable=orb.get("stable"), longrun_orbit_amp=orb.get("amplitude_first"),
                   longrun_orbit_mu=mu_text(orb.get("dominant_multiplier")))
    else:
        lo, hi = lr["amplitude_first_tail_range"]
        num.update(longrun_tail=lr["tail"], longrun_tail_amp_min=lo, longrun_tail_amp_max=hi,
                   longrun_mj_last=", ".join(f"{a:.4f}" for a in lr["moreau_jean"]["amplitude_first_last"]),
                   longrun_exact_last=", ".join(f"{a:.4f}" for a in lr["amplitude_first_last"]))
    return num


def impact_time_numbers(it):
    """Candidates for the paper's impact time of Fig. 6 (scripts/solves/impact_time.py), for the text."""
    if not it:
        return {}
    num = {f"it_{k}": v for k, v in it["numbers"].items() if not isinstance(v, list)}
    num.update({f"it_{k}": ", ".join(f"{t:.3f}" for t in v) for k, v in it["numbers"].items() if isinstance(v, list)})
    c = it["closest"]
    num.update(it_paper_time=it["paper_impact_time"], it_closest_name=c["name"], it_closest_which=c["which"],
               it_closest_t=c["t"], it_closest_distance=c["distance"], it_coexisting=it["n_coexisting_orbits"],
               it_coexisting_starts=it["n_coexisting_starts"], it_periods=it["periods_from_rest"])
    return num


def amp_errors(r, ref):
    """Relative amplitude errors of masses 1 and n (and of every mass when stored)."""
    if not r.get("success"):
        return {"err_first": None, "err_last": None, "err_all": None, "err_max": None}
    e1 = rel_err(r["amplitude_first"], ref["amplitude_first"])
    en = rel_err(r["amplitude_last"], ref["amplitude_last"])
    eall = None
    if r.get("amplitude") and ref.get("amplitude"):
        eall = [rel_err(a, b) for a, b in zip(r["amplitude"], ref["amplitude"])]
    return {"err_first": e1, "err_last": en, "err_all": eall,
            "err_max": max(eall) if eall else max(e1, en)}


def _claim(fig, key, ours, verdict):
    text = dict(CLAIMS[fig])[key]
    return {"key": key, "paper": text, "ours": ours, "verdict": verdict}


def system_numbers(scfg):
    """Parameters of the figure's system, for the text (the system differs between configurations)."""
    out = {k: scfg[k] for k in ("n", "mass_first", "mass_other", "stiffness", "damping", "forcing_amplitude")}
    for law in ("friction", "contact"):
        out.update(scfg.get(law, {}))
    out["title"] = scfg["title"]
    return out
