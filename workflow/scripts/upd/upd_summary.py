"""Summary of the underplatform damper for Fig. 12 and the paper (``{{upd.<key>}}``): the frequency-response curves of
each method (``<method>.json`` of upd_frf.py).

Numbers (flat): the model (``n_dofs``, ``omega_1``, ``omega_2``, ``k_b``, ``k_t``, ``blade_mass``, ``damper_mass``,
``omega_free`` and ``amp_free`` (peak of the system without contact, rad/s and m), ``omega_stuck`` and
``amp_stuck`` (the contacts as springs ``k_t``), ``stuck_shift`` (``omega_stuck / omega_free - 1``); per method
``<m>_refused`` (the InputError of a method that does not take the model, else None), ``<m>_cpu_s`` (the job),
and per preload ``k = 1, 2, ...`` (by increasing ``mu N``): ``mu_N_<k>``, ``<m>_omega_<k>``, ``<m>_ratio_<k>``
(``omega_peak / omega_1``), ``<m>_amp_<k>`` (peak in-plane tip amplitude, m), ``<m>_ampz_<k>`` (out-of-plane tip
amplitude there), ``<m>_est_<k>`` (the method's error estimate at the peak), ``<m>_cert_<k>`` (certified),
``<m>_cpu_<k>``.  The classic trend: ``<m>_drop_then_rise`` (the peak amplitude first falls, then rises with
the preload: it has an interior minimum and is monotone on either side), ``<m>_min_amp_preload`` (the preload of
the lowest peak), ``<m>_attenuation`` (the lowest peak over the free system's); the same numbers tagged ``lo``, ``min``, ``hi``
(the lowest preload, the lowest peak, the highest preload: ``<m>_amp_lo``, ``mu_N_min``, ...) for a text that
holds for any number of preloads, ``<m>_peaks`` (all peaks as text) and ``<m>_cpu_per_curve``.  Between HBM and MS-HBM per
preload: ``diff_amp_<k>`` and ``diff_omega_<k>`` (relative), ``est_<k>`` (the larger of the two estimates) and
``agree_<k>`` (``diff_amp_<k> <=`` the sum of the two estimates); ``max_diff_amp``, ``max_diff_omega``,
``hbm_mshbm_agree`` (at every preload).  The same between DLFT and HBM: ``dlft_diff_amp_<k>``,
``dlft_diff_omega_<k>``, ``dlft_agree_<k>``, ``dlft_max_diff_amp``, ``dlft_max_diff_omega``, ``dlft_hbm_agree``,
``dlft_disagree`` (text: the preloads where the difference exceeds the estimates' sum, with both numbers) and
``dlft_harmonics`` (DLFT's ``n_h``).

Output ``results/summary/upd.json``: ``numbers`` and ``curves`` (per method: the upd_frf.py output).

Usage::

    python workflow/scripts/upd/upd_summary.py --config config.json --out upd.json hbm.json mshbm.json dlft.json
"""
from __future__ import annotations

import argparse
import json


def _load(path):
    with open(path) as fh:
        return json.load(fh)


def drop_then_rise(amps):
    """Whether ``amps`` (by increasing preload) falls to an interior minimum and rises after it, monotonically."""
    if len(amps) < 3:
        return False
    i = min(range(len(amps)), key=amps.__getitem__)
    if i == 0 or i == len(amps) - 1:
        return False
    return all(a > b for a, b in zip(amps[:i], amps[1:i + 1])) and all(a < b for a, b in zip(amps[i:], amps[i + 1:]))


def summarize(cfg, curves):
    u = cfg["upd"]
    ref = curves[0]
    mdl = ref["model"]
    n = {"methods": ", ".join(c["method"] for c in curves), "n_preloads": len(u["preloads"]),
         "preloads": ", ".join(f"{p:g}" for p in u["preloads"]), "harmonics": u["harmonics"], "steps": u["steps"],
         "scan_points": u["scan_points"], "interblade_phase": u["interblade_phase"], "force": u["force"],
         "force_angle": u["force_angle"], "zeta": u["zeta"], "contact_stiffness": u["contact_stiffness"],
         "damper_mass_ratio": u["damper_mass"], "n_el": u["n_el"]}
    n.update({k: mdl[k] for k in ("n_dofs", "omega_1", "omega_2", "k_b", "k_t", "blade_mass", "damper_mass")})
    n.update(omega_free=ref["free"]["omega"], amp_free=ref["free"]["amplitude"], omega_stuck=ref["stuck"]["omega"],
             amp_stuck=ref["stuck"]["amplitude"], stuck_shift=ref["stuck"]["omega"] / ref["free"]["omega"] - 1.0)
    by = {}
    for c in curves:
        m = c["method"]
        n[f"{m}_refused"] = c["refused"]
        n[f"{m}_cpu_s"] = c["cpu_time_s"]
        if c["refused"]:
            continue
        pre = sorted(c["preloads"], key=lambda p: p["mu_N"])
        by[m] = pre
        amps = []
        for k, p in enumerate(pre, 1):
            pk = p["peak"] or {}
            n[f"mu_N_{k}"] = p["mu_N"]
            n.update({f"{m}_omega_{k}": pk.get("omega"), f"{m}_ratio_{k}": pk.get("omega_ratio"),
                      f"{m}_amp_{k}": pk.get("amplitude"), f"{m}_ampz_{k}": pk.get("amplitude_z"),
                      f"{m}_est_{k}": pk.get("accuracy_estimate"), f"{m}_cert_{k}": pk.get("certified"),
                      f"{m}_cpu_{k}": p["cpu_time_s"], f"{m}_failed_{k}": p["scan"]["success"].count(False)})
            amps.append(pk.get("amplitude") or 0.0)
        n[f"{m}_drop_then_rise"] = drop_then_rise(amps)
        i = min(range(len(amps)), key=amps.__getitem__)
        n[f"{m}_min_amp_preload"] = pre[i]["mu_N"]
        n[f"{m}_attenuation"] = amps[i] / ref["free"]["amplitude"]
        for tag, j in (("lo", 0), ("min", i), ("hi", len(pre) - 1)):  # any number of preloads: for the text
            pk = pre[j]["peak"] or {}
            n.update({f"mu_N_{tag}": pre[j]["mu_N"], f"{m}_amp_{tag}": pk.get("amplitude"),
                      f"{m}_ratio_{tag}": pk.get("omega_ratio"), f"{m}_omega_{tag}": pk.get("omega"),
                      f"{m}_est_{tag}": pk.get("accuracy_estimate"), f"{m}_ampz_{tag}": pk.get("amplitude_z")})
        n[f"{m}_peaks"] = "; ".join(
            f"μN = {p['mu_N']:g} N: {1e6 * p['peak']['amplitude']:.4g} µm at ω = {p['peak']['omega_ratio']:.4f} ω₁"
            if p["peak"] else f"μN = {p['mu_N']:g} N: no peak" for p in pre)
        n[f"{m}_cpu_per_curve"] = c["cpu_time_s"] / max(1, len(pre))
        n[f"{m}_all_certified"] = all((p["peak"] or {}).get("certified") for p in pre)
    if "hbm" in by and "mshbm" in by:
        da, dw, ok = [], [], []
        for k, (a, b) in enumerate(zip(by["hbm"], by["mshbm"]), 1):
            pa, pb = a["peak"], b["peak"]
            d_amp = abs(pb["amplitude"] / pa["amplitude"] - 1.0)
            d_om = abs(pb["omega"] / pa["omega"] - 1.0)
            ea, eb = pa["accuracy_estimate"] or 0.0, pb["accuracy_estimate"] or 0.0
            n.update({f"diff_amp_{k}": d_amp, f"diff_omega_{k}": d_om, f"est_{k}": max(ea, eb),
                      f"agree_{k}": bool(d_amp <= ea + eb)})
            da.append(d_amp)
            dw.append(d_om)
            ok.append(d_amp <= ea + eb)
        n.update(max_diff_amp=max(da), max_diff_omega=max(dw), hbm_mshbm_agree=bool(all(ok)))
    if "hbm" in by and "dlft" in by:
        da, dw, ok, bad = [], [], [], []
        for k, (a, b) in enumerate(zip(by["hbm"], by["dlft"]), 1):
            pa, pb = a["peak"], b["peak"]
            d_amp = abs(pb["amplitude"] / pa["amplitude"] - 1.0)
            d_om = abs(pb["omega"] / pa["omega"] - 1.0)
            ea, eb = pa["accuracy_estimate"] or 0.0, pb["accuracy_estimate"] or 0.0
            n.update({f"dlft_diff_amp_{k}": d_amp, f"dlft_diff_omega_{k}": d_om, f"dlft_agree_{k}": bool(d_amp <= ea + eb)})
            da.append(d_amp)
            dw.append(d_om)
            ok.append(d_amp <= ea + eb)
            if d_amp > ea + eb:
                bad.append(f"μN = {a['mu_N']:g} N: {d_amp:.2g} against {ea + eb:.2g}")
        n.update(dlft_max_diff_amp=max(da), dlft_max_diff_omega=max(dw), dlft_hbm_agree=bool(all(ok)),
                 dlft_disagree="; ".join(bad) or "none",
                 dlft_harmonics=by["dlft"][0].get("harmonics", u["harmonics"]))
    return {"numbers": n, "curves": {c["method"]: c for c in curves}}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("curves", nargs="+")
    args = p.parse_args(argv)
    out = summarize(_load(args.config), [_load(c) for c in args.curves])
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps(out["numbers"], indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
