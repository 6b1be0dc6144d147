# %% [markdown]
# # Fig. 11 — Nonlinear modes of a jointed beam: backbone and forced responses (beyond the paper)
#
# **Not in the paper.** The amplitude-dependent frequency and damping ratio (the backbone) of the first bending
# mode of a cantilever with a Jenkins joint at mid-span, by the extended periodic motion concept
# (`mshbm.backbone`) with HBM (the Jenkins element) and DLFT (the joint as a light shoe with set-valued Coulomb
# friction), rule `backbone_curve`.  On the same axes the forced responses at several levels of a tip force
# (pointwise `mshbm.solve`, same method): the backbone must pass through their peaks.  The summary (rule
# `backbone_summary`) holds every number shown here, and the timed 50-point backbone of the 100-DOF beam
# (rule `backbone_timing`).  MS-HBM takes the Jenkins joint with Moreau-Jean (its DOF and slider time-stepped,
# 1024 steps per period; the event-driven flow does not take the Jenkins element).  Panel (c): the conservative
# impact oscillator ($e_N = 1$) by shooting and MS-HBM with the exact event-driven flow against its closed form
# T(A) (rule `backbone_impact`).

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/backbone.json"
out_png = "results/figures/fig11.png"
out_pdf = "results/figures/fig11.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

nc.setup()
S = nc.load_json(summary)
N = S["numbers"]
CURVES = S["curves"]
COL = {"hbm": nc.COLORS["hbm"], "dlft": "#2ca02c", "mshbm": nc.COLORS["mshbm"]}
LAB = {"hbm": "HBM (Jenkins)", "dlft": "DLFT (shoe)", "mshbm": "MS-HBM (Jenkins, Moreau-Jean)"}
IMP = S.get("impact")

fig, axes = plt.subplots(1, 3 if IMP else 2, figsize=(11.5 if IMP else 8.0, 3.3))
ax1, ax2 = axes[0], axes[1]
for m, c in CURVES.items():
    b = c["backbone"]
    amp = np.asarray(b["amplitude_tip"]) * 1e3
    order = np.argsort(amp)
    ax1.plot(np.asarray(b["omega"])[order], amp[order], color=COL.get(m, "0.4"), lw=2.0, label=f"backbone, {LAB.get(m, m)}")
    ax2.semilogx(amp[order], 100 * np.asarray(b["damping_ratio"])[order], color=COL.get(m, "0.4"), label=LAB.get(m, m))
    for i, lv in enumerate(c["levels"]):
        sc = lv["scan"]
        ok = np.asarray(sc["success"], dtype=bool)
        w, a = np.asarray(sc["omega"])[ok], np.asarray(sc["amplitude"])[ok] * 1e3
        ax1.plot(w, a, color=COL.get(m, "0.4"), lw=0.7, ls={"hbm": "-", "dlft": "--"}.get(m, ":"),
                 label=f"forced responses, {LAB.get(m, m)}" if i == 0 else None)
        if lv["peak"]:
            ax1.plot(lv["peak"]["omega"], lv["peak"]["amplitude"] * 1e3, "o", ms=4, mfc="none", color=COL.get(m, "0.4"))
ax1.set_yscale("log")
peaks = [lv["peak"]["amplitude"] * 1e3 for c in CURVES.values() for lv in c["levels"] if lv["peak"]]
if peaks:  # the forced responses' range (the backbone reaches far below and above it)
    ax1.set_ylim(0.3 * min(peaks), 2.5 * max(peaks))
ax1.set_xlabel("ω (rad/s)")
ax1.set_ylabel("tip amplitude (mm)")
ax1.set_title("(a) frequency: backbone and forced responses")
ax1.legend(fontsize=6.5, loc="upper right")
ax2.set_xlabel("tip amplitude (mm)")
ax2.set_ylabel("damping ratio D (%)")
ax2.set_title("(b) damping ratio")
ax2.legend(fontsize=7)
if IMP:  # (c) the conservative impact oscillator against its closed form
    ax3 = axes[2]
    w0, g = IMP["model"]["omega0"], IMP["model"]["gap"]
    cf = IMP["closed_form"]
    ax3.plot(np.asarray(cf["omega"]) / w0, np.asarray(cf["A"]) / g, color="0.2", lw=1.0, label="closed form T(A)")
    for m, mk in (("shooting", "o"), ("mshbm", "x")):
        r = IMP["methods"].get(m)
        if r:
            ax3.plot(np.asarray(r["omega"]) / w0, np.asarray(r["A"]) / g, mk, ms=4, mfc="none",
                     color=nc.COLORS.get(m, "0.4"), label=f"{'shooting' if m == 'shooting' else 'MS-HBM'} (event flow)")
    ax3.axhline(1.0, color="0.6", lw=0.6, ls=":")
    ax3.set_xlabel(r"$\omega / \omega_0$")
    ax3.set_ylabel("free amplitude A / gap")
    ax3.set_title("(c) impact oscillator, $e_N = 1$")
    ax3.legend(fontsize=7, loc="upper left")
for ax in axes:
    ax.grid(alpha=0.3, which="both")
fig.tight_layout()
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## The backbones
#
# ω and D at the smallest and the largest amplitude, and the CPU time of the backbone alone and of the whole job
# (backbone and forced responses).  DLFT's curve starts where the shoe slides and ends just above the onset of
# slip (`stick_margin`), since its velocity predictor leaves the mean friction force undetermined where the joint
# sticks throughout.

# %%
rows = []
for m, c in CURVES.items():
    rows.append((LAB.get(m, m), "yes" if N[f"{m}_success"] else "NO: " + N[f"{m}_message"][:100], N[f"{m}_points"],
                 f"{N[f'{m}_a_min']:.3g}–{N[f'{m}_a_max']:.3g}", f"{N[f'{m}_omega_min']:.4f}–{N[f'{m}_omega_max']:.4f}",
                 f"{100 * N[f'{m}_D_at_a_min']:.3f}", f"{100 * N[f'{m}_D_max']:.3f}", f"{N[f'{m}_backbone_cpu_s']:.1f}",
                 f"{N[f'{m}_cpu_s']:.1f}"))
display(Markdown(nc.md_table(["method", "reached", "points", "modal amplitude", "ω (rad/s)", "D at smallest a (%)",
                              "largest D (%)", "backbone CPU (s)", "job CPU (s)"], rows)))

# %% [markdown]
# ## The peaks against the backbone
#
# Each level's force is chosen from the method's backbone so that its peak lands near the aimed modal amplitude;
# the peak (largest tip amplitude, refined by Brent's method) is then compared with the backbone's ω at the peak's
# own modal amplitude.

# %%
rows = []
for m, c in CURVES.items():
    for lv in c["levels"]:
        p = lv["peak"] or {}
        dev = p.get("deviation")
        rows.append((LAB.get(m, m), f"{lv['force']:.4g}", f"{lv['target_modal_amplitude']:.3g}",
                     f"{p['modal_amplitude']:.4g}" if p else "–", f"{p['omega']:.5f}" if p else "–",
                     f"{p['omega_backbone']:.5f}" if p.get("omega_backbone") else "–",
                     f"{100 * dev:+.4f}" if dev is not None else "outside the backbone", len(lv["scan"]["omega"])))
display(Markdown(nc.md_table(["method", "force (N)", "aimed a", "peak's a", "peak ω", "backbone ω", "deviation (%)",
                              "solves of the scan"], rows)))
display(Markdown(f"Largest deviation {100 * N['max_deviation']:.4f} % (goal {100 * N['deviation_goal']:.2g} %); "
                 f"50-point backbone of the {N['timing_n_dofs']}-DOF beam: {N['timing_points']} points in "
                 f"{N['timing_cpu_s']:.2f} s of CPU (goal {N['time_goal']:g} s)."))
if IMP:
    display(Markdown("Impact oscillator ($e_N = 1$), against the closed form T(A): " + "; ".join(
        f"{'shooting' if m == 'shooting' else 'MS-HBM'} {N[f'impact_{m}_points']} points, largest |T/T(A) - 1| "
        f"{N[f'impact_{m}_period_error']:.2g}, largest |D| {N[f'impact_{m}_D_max']:.2g}, {N[f'impact_{m}_cpu_s']:.1f} s CPU"
        for m in IMP["methods"]) + f"; ω/ω₀ up to {N['impact_omega_ratio_max']:.3f}."))
