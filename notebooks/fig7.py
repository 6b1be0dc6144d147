# %% [markdown]
# # Fig. 7 — phase diagram of mass 1, 50-mass impact chain
#
# **Paper (Sec. 4.2, Fig. 7):** *"Phase diagram of the nonlinear subsystem of the 50-mass
# oscillator calculated with 3 and 9 considered harmonics using the HBM (left), MS-HBM (right), as
# reference the full shooting approach is depicted in both diagrams as black curve."*  The text:
# the periodic solution *"shows the existence of an accumulation point, i.e. infinitely many
# impacts occur during a finite time period.  The HBM cannot model this effect but the MS-HBM
# already provides a good approximation with just a few considered harmonics and it exactly
# fulfils the non-penetration condition of the contact."*
#
# **Here:** the solutions are those of the Fig. 8 sweep (same solve jobs, same starts).  An
# impact of the time-stepping methods is a step with a positive contact impulse; consecutive
# impulse steps form one impact cluster.  Whether impacts accumulate is decided by
# `mshbm.accumulation` (runs of impacts whose intervals shrink geometrically, limit by Aitken's
# extrapolation; validated on a bouncing ball with $e_N < 1$ against the closed-form accumulation
# time, `tests/unit/test_accumulation.py`) on the impact times of the exact event-driven solution
# (`mshbm.methods.exact`, started from the reference shooting), or, if that failed, on the impulse steps
# of the reference shooting.  HBM uses the
# penalty spring, so it has contact episodes (intervals with $q_1 > g_{N,0}$) instead of impacts.
# If HBM did not converge from the Fig. 8 starts it is restarted, for this figure only, from the
# converged MS-HBM and full-shooting solutions (config `hbm_fallback`); the legend says so.

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/fig7.json"
npz = {}
out_png = "results/figures/fig7.png"
out_pdf = "results/figures/fig7.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

nc.setup()
cfg = nc.load_json(config)
S = nc.load_json(summary)
num = S["numbers"]
scfg = cfg["systems"][S["system"]]
g0 = scfg["contact"]["gap"]
nhs = S["harmonics"]
ref = nc.load_npz(npz["ref"])

# %% [markdown]
# ## The paper's claims and our numbers

# %%
display(Markdown(nc.claims_table(S)))

# %%
fig, axes = plt.subplots(1, 3, figsize=(10.2, 3.6), gridspec_kw={"width_ratios": [1, 1, 0.9]})
axes, axr = axes[:2], axes[2]
colors = ["#1f77b4", "#2ca02c", "#9467bd", "#8c564b"]
for ax, method in zip(axes, ("hbm", "mshbm")):
    ax.plot(ref["q"][:, 0], ref["u"][:, 0], color="k", lw=1.6, label=f"full shooting, N = {cfg['numerics']['reference_steps']}", zorder=2)
    imp = np.flatnonzero(ref["impulses"][:, 0] > 0)
    ax.plot(ref["q"][imp, 0], ref["u"][imp, 0], "ko", ms=4, mfc="white", zorder=4, label="impulse steps (shooting)")
    notes = []
    for c, nh in zip(colors, nhs):
        key = f"{method}_nh{nh}"
        d = nc.load_npz(npz[key])
        f = S["solves"][key]
        if d is None:
            notes.append(f"$n_H$ = {nh}: no convergence from any start")
            continue
        lab = f"{nc.LABELS[method]}, $n_H$ = {nh}"
        if f.get("display_only"):
            lab += f" (from {f['start_used']})"
        ax.plot(d["q"][:, 0], d["u"][:, 0], color=c, lw=1.1, ls="--" if nh == nhs[0] else "-", label=lab, zorder=3)
    ax.axvline(g0, color="0.4", lw=0.8, ls=":")
    ax.text(g0, 0, r" $g_{N,0}$", fontsize=7, color="0.3", va="bottom")
    for t in notes:
        ax.plot([], [], color="tab:red", marker="x", ls="none", label=t + ", not drawn")
    ax.set_xlabel("$q_1$ (m)")
    ax.set_title({"hbm": "HBM (penalty contact)", "mshbm": "MS-HBM (set-valued contact)"}[method])
    ax.legend(loc="upper left", fontsize=6.5, framealpha=0.9)
axes[0].set_ylabel(r"$u_1$ (m/s)")
axes[1].sharey(axes[0])
# right: what the chain does from rest next to the T-periodic orbit (rule longrun)
lr = nc.load_npz(npz["longrun"]) if "longrun" in npz else None
if lr is not None:
    LR = S["longrun"]
    axr.plot(np.arange(1, len(lr["amp"]) + 1), lr["amp"], color="tab:orange", lw=0.7, label="from rest (exact flow)")
    axr.axhline(num["reference_amp_first"], color="k", ls="--", lw=0.9, label="T-periodic orbit")
    axr.set_xlabel("period"); axr.set_ylabel("amplitude of mass 1 (m)")
    axr.set_title(f"from rest: period-{LR['response_period']} response" if LR["response_period"]
                  else f"from rest: not periodic in {LR['periods']} periods", fontsize=8)
    axr.legend(fontsize=6.5, loc="lower right", framealpha=0.9)
else:
    axr.set_visible(False)
fig.suptitle(f"mass 1 of the {scfg['n']}-mass impact chain: {num['reference_impulse_steps']} impulse step(s) per period, "
             f"{'accumulation' if num['accumulation'] else 'no accumulation'} of impacts (full shooting);\n"
             f"this T-periodic orbit is {nc.stability_short(num, 'reference')}", fontsize=8)
fig.tight_layout()
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## Impacts per period, non-penetration, branch
#
# `max(q1 - g0)` is the largest value of $q_1 - g_{N,0}$ on the time grid: negative or zero means
# no penetration.  The shooting reference was reached from its own solution at the nearby
# frequency (Newton).  Stability: Floquet multipliers of the exact event-driven flow with the
# saltation matrices of the impacts (`mshbm.stability`), for the reference and for every MS-HBM and
# HBM solution (started from each).

# %%
rows = [("full shooting (reference)", "-", "yes", num["reference_start"], num["reference_impulse_steps"],
         num["reference_impact_clusters"], "-", nc.fmt(S["reference"].get("max_penetration"), "sci"),
         nc.stability_cell(S["reference"]))]
for method in ("hbm", "mshbm"):
    for nh in nhs:
        f = S["solves"][f"{method}_nh{nh}"]
        rows.append((nc.LABELS[method], nh, "yes" if f["success"] else "NO", f.get("start_used") or "-",
                     f.get("impulse_steps", "-") if f["success"] else "-",
                     f.get("impact_clusters", "-") if f["success"] else "-",
                     f.get("contact_episodes", "-") if f["success"] else "-",
                     nc.fmt(f.get("max_penetration"), "sci") if f["success"] else "-", nc.stability_cell(f)))
display(Markdown(nc.md_table(["method", "n_H", "converged", "start", "impulse steps/period", "impact clusters",
                              "HBM contact episodes", "max(q1 - g0) (m)", "stability (max. Floquet modulus)"], rows)))
print("impact cluster sizes (reference):", S["reference"].get("impact_cluster_sizes"))
print("largest Floquet moduli (reference):", ", ".join(f"{x:.4f}" for x in S["reference"].get("floquet_moduli_top") or []))

# %% [markdown]
# ## Accumulation of impacts
#
# The detector's verdict on the exact solution and on the reference full shooting, and the
# impacts of the exact solution (time, approach velocity, impulse).

# %%
ex = S.get("exact") or {}
print("accumulation:", num["accumulation"], "(from", num.get("accumulation_source"), ")",
      "| on the reference shooting:", num.get("accumulation_shooting"))
if ex.get("success"):
    display(Markdown(nc.md_table(["t (s)", "approach velocity (m/s)", "impulse (N s)"],
                                 [(f"{i['t']:.6f}", f"{i['velocity']:.6f}", f"{i['impulse']:.6f}")
                                  for i in ex.get("impacts", [])])))
    print("accumulations found on the exact solution:", ex.get("accumulations"))
else:
    print("exact solution:", ex.get("message"))

# %% [markdown]
# ## What the chain does next to its T-periodic orbit: a long simulation from rest
#
# The exact event-driven flow from rest (rule `longrun`), with Moreau–Jean as a cross-check; the
# right panel of the figure shows the amplitude of mass 1 in every period of it.

# %%
display(Markdown(nc.longrun_table(S)))
