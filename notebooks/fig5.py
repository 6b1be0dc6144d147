# %% [markdown]
# # Fig. 5 — 5-DOF impact oscillator: displacements
#
# **Paper (Sec. 4.2, Fig. 5, Table 2):** the friction element is replaced by a unilateral stop at
# mass 1 (gap $g_{N,0} = 0.1$, Newton's impact law with $e_N = 1$).  Full shooting and MS-HBM use
# the set-valued contact and impact laws (measure differential inclusion, Moreau–Jean); HBM can
# only use a single-valued law and models the contact by a one-sided spring ($k_c = 8000$,
# $d_c = 0$, eq. 45).  The figure shows the displacements of the five masses by the three methods.
# The harmonics used in Fig. 5 are not stated; we use those of Fig. 3 (config `figures.fig5`).
#
# **Here:** every solve starts from the linear response at $\omega$ (no contact) and Newton
# converges from there.  If HBM fails from that start it is restarted from the converged MS-HBM
# solution and then from the full-shooting solution (same $n_H$, config `hbm_fallback`), and the
# start actually used is reported.  A solution that did not converge is never drawn.

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/fig5.json"
npz = {}
out_png = "results/figures/fig5.png"
out_pdf = "results/figures/fig5.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

nc.setup()
cfg = nc.load_json(config)
S = nc.load_json(summary)
num = S["numbers"]
scfg, sol, label = nc.time_figure_solutions(cfg, S, npz)

# %% [markdown]
# ## The paper's claims and our numbers

# %%
display(Markdown(nc.claims_table(S)))

# %%
n = scfg["n"]
fig, axes = plt.subplots(n, 1, figsize=(6.4, 1.45 * n + 0.6), sharex=True)
for m in ("hbm", "mshbm", "shooting"):
    d = sol[m]
    if d is None:
        continue
    lab = label[m] + (" (started from another method's solution)" if m == "hbm" and S["methods"]["hbm"]["display_only"] else "")
    for i in range(n):
        axes[i].plot(d["t"], d["q"][:, i], color=nc.COLORS[m], ls=nc.STYLES[m], lw=1.6 if m == "shooting" else 1.2,
                     label=lab, zorder=2 if m == "shooting" else 3)
axes[0].axhline(scfg["contact"]["gap"], color="0.4", lw=0.8, ls=":", label=r"stop $g_{N,0}$")
for i in range(n):
    axes[i].set_ylabel(f"$q_{i + 1}$ (m)")
if sol["hbm"] is None:
    axes[0].plot([], [], color=nc.COLORS["hbm"], marker="x", ls="none",
                 label=f"HBM ($n_H$ = {S['hbm_harmonics']}, penalty): no convergence from any start, not drawn")
axes[-1].set_xlabel("t (s)")
axes[-1].set_xlim(0, sol["shooting"]["t"][-1])
handles, labels = axes[0].get_legend_handles_labels()
fig.legend(handles, labels, loc="lower center", bbox_to_anchor=(0.5, -0.02), fontsize=7, ncol=2, framealpha=0.95)
fig.tight_layout(rect=(0, 0.05, 1, 1))
axes[0].set_title(f"5-DOF impact oscillator (Table 2), g0 = {scfg['contact']['gap']:g}: "
                  f"{num['reference_impact_clusters']} impact(s) per period;\nthis T-periodic orbit is "
                  f"{nc.stability_short(num, 'reference')}", fontsize=8)
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## Solver facts and branch
#
# The shown full-shooting solution was reached from the linear response at $\omega$ by Newton.
# Its Floquet multipliers come from the exact event-driven flow with the saltation matrices of the
# impacts (`mshbm.stability`); those of the Moreau–Jean step map would be wrong at the impact.
# Where the T-periodic orbit is unstable, the system does not stay on it: a long simulation from
# rest (rule `longrun`, table below; Fig. 6 shows it) settles elsewhere.

# %%
rows = []
for key in ("reference", "shooting", "mshbm", "hbm"):
    m = S["methods"][key]
    err = S["errors"].get(key, {})
    amps = m.get("amplitude") or []
    rows.append((nc.LABELS[key], m["harmonics"] if key in ("mshbm", "hbm") else "-", m["steps"],
                 "yes" if m["success"] else "NO", nc.start_text(m.get("start_used")), m.get("iterations") if m["success"] else "-",
                 ", ".join(f"{a:.4f}" for a in amps) or "-",
                 nc.fmt(err.get("err_max"), "pct") if err else "(reference)",
                 m.get("impulse_steps", m.get("contact_episodes", "-")),
                 nc.fmt(m.get("max_penetration"), "sci") if m["success"] else "-",
                 nc.stability_cell(m)))
display(Markdown(nc.md_table(["method", "n_H", "steps", "converged", "start", "Newton it.", "amplitudes m1..m5 (m)",
                              "max. rel. amplitude error", "impulse steps / contact episodes", "max(q1 - g0) (m)",
                              "stability (max. Floquet modulus)"], rows)))
for key in ("mshbm", "hbm"):
    m = S["methods"][key]
    for a in m["attempts"]:
        print(f"{key} start={a['start']}: {a['message']}")
mods = S["methods"]["reference"].get("floquet_moduli_top")
print("largest Floquet moduli (reference shooting, exact flow):", ", ".join(f"{x:.4f}" for x in mods or []))
print("stability method:", S["methods"]["reference"].get("stability_method"))

# %% [markdown]
# ## What the system does from rest

# %%
display(Markdown(nc.longrun_table(S)))
