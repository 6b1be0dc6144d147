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
# impact; the HBM velocity is the derivative of a truncated Fourier series.  The T-periodic orbit
# is unstable (flip, see the title), so the right panel shows what the chain does from rest: the
# exact event-driven flow after many periods (rule `longrun`).  Why our impact time differs from
# the paper's is tested at the end (rule `impact_time`).

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/fig6.json"
npz = {}
out_png = "results/figures/fig6.png"
out_pdf = "results/figures/fig6.pdf"

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
fig, (ax, axz, axr) = plt.subplots(1, 3, figsize=(9.6, 3.3), gridspec_kw={"width_ratios": [2.2, 1, 2.2]})
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
    axz.set_title(f"zoom, t = {t_imp:.3f} s", fontsize=8)
if sol["hbm"] is None:
    ax.plot([], [], color=nc.COLORS["hbm"], marker="x", ls="none",
            label=f"HBM ($n_H$ = {S['hbm_harmonics']}): no convergence, not drawn")
ax.set_xlabel("t (s)"); axz.set_xlabel("t (s)")
ax.set_ylabel(r"$u_1 = \dot q_1$ (m/s)")
ax.set_xlim(0, sol["shooting"]["t"][-1])
ax.legend(loc="upper left", fontsize=7, framealpha=0.9)
ax.set_title("velocity of mass 1 on the T-periodic orbit", fontsize=8)
fig.suptitle(f"5-DOF impact oscillator: the T-periodic orbit is {nc.stability_short(num, 'reference')}", fontsize=8.5)
# right: the response from rest next to the T-periodic orbit (drawn twice)
lr = nc.load_npz(npz["longrun"]) if "longrun" in npz else None
if lr is not None:
    LR = S["longrun"]
    T = sol["shooting"]["t"][-1]
    t0 = lr["t"][0]
    per = LR["response_period"]
    axr.plot(lr["t"] - t0, lr["u1"], color="tab:orange", lw=1.3,
             label=f"from rest, periods {LR['last_periods'][0] + 1}–{LR['last_periods'][-1] + 1} (exact flow)")
    d = sol["shooting"]
    k = int(np.ceil((lr["t"][-1] - t0) / T)) + 1
    tt = np.concatenate([d["t"][:-1] + j * T for j in range(k)])
    uu = np.concatenate([d["u"][:-1, 0]] * k)
    sel = tt <= lr["t"][-1] - t0
    axr.plot(tt[sel], uu[sel], color="k", lw=0.9, ls="--", label="T-periodic orbit (unstable)" if
             num.get("reference_stable") is False else "T-periodic orbit")
    axr.set_xlabel(f"t - {t0:.0f} s")
    axr.set_title((f"from rest: period-{per} response" if per else "from rest: no periodic response") +
                  (f", mass-1 amplitude {LR['amplitude_first_max']:.2f} / {LR['amplitude_first_min']:.2f} m"
                   if per and per > 1 else ""), fontsize=8)
    axr.legend(loc="lower left", fontsize=6.5, framealpha=0.9)
else:
    axr.set_visible(False)
fig.tight_layout()
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


# %% [markdown]
# ## What the chain does next to the unstable T-periodic orbit

# %%
display(Markdown(nc.longrun_table(S)))

# %% [markdown]
# ## Why the impact is not at the paper's t = 0.55 s: candidates
#
# Each candidate changes one thing the paper leaves open (the forcing phase, i.e. sin vs cos and
# the time origin; the chain's supports; the forced mass) and gives the impact times of its
# T-periodic orbit and of the response reached from rest.  Coexisting T-periodic orbits were
# searched by exact shooting from many starts.  Numbers: rule `impact_time`.

# %%
IT = S.get("impact_time")
if IT:
    rows = []
    for c in IT["candidates"]:
        o, r = c["periodic_orbit"], c["from_rest"]
        orbit_txt = (", ".join(f"{i['t']:.3f}" for i in o["impacts"]) + " s; " +
                     ("stable" if o["stable"] else "unstable" if o["stable"] is False else "undecided") +
                     f" (largest multiplier modulus {o['max_modulus']:.3f})") if o.get("success") else f"not found ({o['message'][:60]})"
        rest_txt = (f"period {r['response_period']} T: " if r["response_period"] else "not periodic: ") + \
            "; ".join((", ".join(f"{i['t']:.3f}" for i in imps) + " s") if imps else "none"
                      for imps in r["impacts_last"])
        rows.append((c["name"], c["what"], orbit_txt, rest_txt))
    display(Markdown(nc.md_table(["candidate", "what changes", "T-periodic orbit: impact times, stability",
                                  "response from rest: impact times per period"], rows)))
    cl = IT["closest"]
    print(f"coexisting T-periodic orbits found: {IT['n_coexisting_orbits']} (from {IT['n_coexisting_starts']} starts)")
    print(f"closest to the paper's {IT['paper_impact_time']} s: {cl['name']}, {cl['which']}: t = {cl['t']:.3f} s "
          f"({cl['distance']:.3f} s away)")
