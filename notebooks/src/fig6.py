# %% [markdown]
# # Fig. 6 — 5-DOF impact oscillator: velocity of mass 1
#
# **Paper (Sec. 4.2, Fig. 6):** *"the HBM has difficulties to approximate the jump in the velocity
# of the first mass at the collision time-instant ($t = 0.55$), although the contact stiffness
# $k_c$ is chosen relatively high.  The mixed and full shooting method show a true velocity jump
# whereas the HBM only gives a rough approximation of this phenomenon."*
#
# **Here:** velocities of mass 1 from the same solves as Fig. 5.  MS-HBM and full shooting
# integrate mass 1 by Moreau–Jean time-stepping, so their velocity jumps within one step at the
# impact; the HBM velocity is the derivative of a truncated Fourier series.  The time of the
# impact depends on the time origin of the forcing ($f = 5\cos\omega t$ here) and on the branch
# of periodic solutions; we report ours.

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/fig6.json"
npz = {}
out_png = "results/figures/fig6.png"
out_pdf = "results/figures/fig6.pdf"

# %%
import os, sys
sys.path.insert(0, "notebooks") if os.path.isdir("notebooks") else None
import nbcommon as nc
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
fig, (ax, axz) = plt.subplots(1, 2, figsize=(7.6, 3.0), gridspec_kw={"width_ratios": [2.2, 1]})
for m in ("hbm", "mshbm", "shooting"):
    d = sol[m]
    if d is None:
        continue
    lab = label[m] + (" (from another method's solution)" if m == "hbm" and S["methods"]["hbm"]["display_only"] else "")
    for a in (ax, axz):
        a.plot(d["t"], d["u"][:, 0], color=nc.COLORS[m], ls=nc.STYLES[m], lw=1.6 if m == "shooting" else 1.2,
               label=lab, marker="." if a is axz and m != "hbm" else None, ms=2.5, zorder=2 if m == "shooting" else 3)
t_imp = num.get("reference_impact_time")
if t_imp is not None:
    ax.axvline(t_imp, color="0.5", lw=0.7, ls=":")
    T = sol["shooting"]["t"][-1]
    axz.set_xlim(t_imp - 0.01 * T, t_imp + 0.01 * T)
    axz.set_title(f"zoom at the impact, t = {t_imp:.3f} s")
if sol["hbm"] is None:
    ax.plot([], [], color=nc.COLORS["hbm"], marker="x", ls="none",
            label=f"HBM ($n_H$ = {S['hbm_harmonics']}): no convergence, not drawn")
ax.set_xlabel("t (s)"); axz.set_xlabel("t (s)")
ax.set_ylabel(r"$u_1 = \dot q_1$ (m/s)")
ax.set_xlim(0, sol["shooting"]["t"][-1])
ax.legend(loc="upper left", fontsize=7, framealpha=0.9)
ax.set_title("velocity of mass 1, 5-DOF impact oscillator")
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## Impacts (velocity jumps) per solution
#
# For the time-stepping methods an impact is a step with a positive contact impulse; with
# $e_N = 1$ the post-impact velocity is the negative of the pre-impact one (to the order of the
# scheme).  For HBM the contact is a penalty spring and the table lists the contact episodes
# (intervals with $q_1 > g_{N,0}$).

# %%
rows = []
for key in ("reference", "shooting", "mshbm", "hbm"):
    m = S["methods"][key]
    if not m["success"]:
        rows.append((nc.LABELS[key], "no convergence", "-", "-", "-"))
        continue
    imps = m.get("impacts")
    if imps:
        for k, imp in enumerate(imps):
            rows.append((nc.LABELS[key] if k == 0 else "", f"{imp['t']:.4f}", imp["steps"], f"{imp['u_before']:.4f}",
                         f"{imp['u_after']:.4f}"))
    else:
        rows.append((nc.LABELS[key], ", ".join(f"{t:.3f}" for t in m.get("contact_episode_times") or []) or "none",
                     "penalty", "-", "-"))
display(Markdown(nc.md_table(["method", "impact time (s)", "impulse steps", "u1 before", "u1 after"], rows)))
