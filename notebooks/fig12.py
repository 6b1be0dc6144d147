# %% [markdown]
# # Fig. 12 — Two blades with an underplatform damper: frequency-response curves at several normal loads (beyond the paper)
#
# **Not in the paper.** Two cantilever blades bending in two planes (in-plane and out-of-plane tip motion), coupled
# by a light damper through two 3-D frictional contacts (3-D Jenkins: tangential contact stiffness in series with
# Coulomb's disk, the slip direction rotating; constant centrifugal normal load), under an engine-order force with
# an inter-blade phase (rule `upd_frf`, one job per method; DLFT with the contacts' sliders as DOFs, at its own n_h).
# The in-plane tip amplitude of blade 0 against frequency at each normal load, by HBM, MS-HBM and DLFT, with the
# linear limits (no contact; contacts stuck).  The summary (rule `upd_summary`) holds every number shown here.

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/upd.json"
out_png = "results/figures/fig12.png"
out_pdf = "results/figures/fig12.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

nc.setup()
S = nc.load_json(summary)
N = S["numbers"]
CURVES = S["curves"]
LAB = {"hbm": "HBM", "mshbm": "MS-HBM", "dlft": "DLFT"}
STY = {"hbm": "-", "mshbm": "--", "dlft": ":"}

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(8.0, 3.3))
cmap = plt.get_cmap("viridis")
solved = {m: c for m, c in CURVES.items() if not c["refused"]}
w1 = N["omega_1"]
for m, c in solved.items():
    pre = sorted(c["preloads"], key=lambda p: p["mu_N"])
    for k, p in enumerate(pre):
        sc = p["scan"]
        ok = np.asarray(sc["success"], dtype=bool)
        w, a = np.asarray(sc["omega"])[ok] / w1, np.asarray(sc["amplitude"])[ok] * 1e6
        if p["peak"]:  # the refined peak inside the scan
            w = np.append(w, p["peak"]["omega_ratio"])
            a = np.append(a, p["peak"]["amplitude"] * 1e6)
        o = np.argsort(w)
        col = cmap(k / max(1, len(pre) - 1))
        ax1.plot(w[o], a[o], STY.get(m, "-"), color=col, lw=1.0,
                 label=f"μN = {p['mu_N']:g} N" if m == "hbm" else None)
        if p["peak"]:
            ax1.plot(p["peak"]["omega_ratio"], p["peak"]["amplitude"] * 1e6, {"hbm": "o", "dlft": "+"}.get(m, "x"),
                     ms=4, mfc="none", color=col)
ax1.axvline(N["omega_free"] / w1, color="0.6", lw=0.6, ls=":")
ax1.axvline(N["omega_stuck"] / w1, color="0.3", lw=0.6, ls=":")
ax1.set_yscale("log")
ax1.set_ylim(top=ax1.get_ylim()[1] * 4)  # room for the legend above the curves
ax1.set_xlabel("ω / ω₁")
ax1.set_ylabel("in-plane tip amplitude (µm)")
LINE = {"-": "solid", "--": "dashed", ":": "dotted"}
ax1.set_title("(a) blade 0 (" + ", ".join(f"{LINE[STY[m]]} {LAB[m]}" for m in solved) + ")", fontsize=8)
ax1.legend(fontsize=6.5, loc="upper right")
for m, c in solved.items():
    pre = sorted(c["preloads"], key=lambda p: p["mu_N"])
    mu = [p["mu_N"] for p in pre if p["peak"]]
    ax2.loglog(mu, [p["peak"]["amplitude"] * 1e6 for p in pre if p["peak"]], "o" + STY.get(m, "-"),
               mfc="none", label=LAB.get(m, m))
ax2.axhline(N["amp_free"] * 1e6, color="0.6", lw=0.6, ls=":", label="no contact")
ax2.axhline(N["amp_stuck"] * 1e6, color="0.3", lw=0.6, ls=":", label="contacts stuck")
ax2.set_xlabel("slip force μN per contact (N)")
ax2.set_ylabel("peak amplitude (µm)")
ax2.set_title("(b) the peak against the normal load")
ax2.legend(fontsize=7)
for ax in (ax1, ax2):
    ax.grid(alpha=0.3, which="both")
fig.tight_layout()
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## The peaks
#
# Per normal load and method: the peak's frequency and in-plane amplitude (Brent's method on the pointwise
# solves), the out-of-plane amplitude there (the slip is two-dimensional), the method's own error estimate at the
# peak and the job's CPU time for that curve.

# %%
rows = []
for m, c in solved.items():
    for k, p in enumerate(sorted(c["preloads"], key=lambda p: p["mu_N"]), 1):
        pk = p["peak"] or {}
        rows.append((LAB.get(m, m), f"{p['mu_N']:g}", f"{pk.get('omega_ratio', float('nan')):.5f}",
                     f"{1e6 * pk.get('amplitude', float('nan')):.4g}", f"{1e6 * pk.get('amplitude_z', float('nan')):.3g}",
                     f"{pk.get('accuracy_estimate') or float('nan'):.2g}", "yes" if pk.get("certified") else "NO",
                     f"{p['cpu_time_s']:.1f}"))
display(Markdown(nc.md_table(["method", "μN (N)", "ω/ω₁", "in-plane (µm)", "out-of-plane (µm)", "error estimate",
                              "certified", "CPU (s)"], rows)))
if "dlft_max_diff_amp" in N:
    display(Markdown(f"DLFT (n_h = {N['dlft_harmonics']}) against HBM (n_h = {N['harmonics']}): peak amplitudes within "
                     f"{100 * N['dlft_max_diff_amp']:.2g} %, frequencies within {100 * N['dlft_max_diff_omega']:.2g} %; "
                     f"within the sum of the two estimates at every load: {N['dlft_hbm_agree']}."))
refused = [f"{LAB.get(m, m)}: {c['refused']}" for m, c in CURVES.items() if c["refused"]]
display(Markdown("Refused: " + "; ".join(refused) if refused else "No method refused the model."))
