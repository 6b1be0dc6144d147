# %% [markdown]
# # Fig. 3 — 3-DOF friction oscillator over one period
#
# **Paper (Sec. 4.1, Fig. 3):** displacements of the three masses and the friction force for the
# periodic solution with $T = 10$ s ($\omega = \pi/5$).  Mass 1 shows *pronounced stick–slip*.
# Full HBM with $n_H = 20$ harmonics and the arctan-regularised law ($\kappa = 800$, eq. 42) is
# compared with MS-HBM with only $n_H = 3$ and with full shooting; the paper finds that *"the mixed
# method approximates much better the results of the full shooting method"*, because HBM both
# smooths the law and represents the friction force by a truncated Fourier series.
#
# **Here:** all three solutions come from the workflow's solve jobs (`results/solves/`); this
# notebook only plots them.  Every solve starts from the linear response at $\omega$ (no
# friction) and Newton converges from there.  Errors are relative amplitude errors, amplitude
# $=(\max-\min)/2$ over one period, against the reference full shooting with the finer step
# (config `numerics.reference_steps`).

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/fig3.json"
npz = {}
out_png = "results/figures/fig3.png"
out_pdf = "results/figures/fig3.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

nc.setup()
cfg = nc.load_json(config)
S = nc.load_json(summary)
num = S["numbers"]
nh_hbm, nh_ms = S["hbm_harmonics"], S["mshbm_harmonics"]
sol = {"shooting": nc.load_npz(npz["shooting"]), "mshbm": nc.load_npz(npz[f"mshbm_nh{nh_ms}"]),
       "hbm": nc.load_npz(npz[f"hbm_nh{nh_hbm}"])}
label = {"shooting": f"full shooting (N = {cfg['numerics']['steps']})", "mshbm": f"MS-HBM, $n_H$ = {nh_ms}",
         "hbm": fr"HBM, $n_H$ = {nh_hbm}, $\kappa$ = {cfg['systems'][S['system']]['friction']['kappa']:g}"}

# %% [markdown]
# ## The paper's claims and our numbers

# %%
display(Markdown(nc.claims_table(S)))

# %%
fig, axes = plt.subplots(4, 1, figsize=(6.4, 7.2), sharex=True)
order = ["hbm", "mshbm", "shooting"]
for m in order:
    d = sol[m]
    if d is None:
        continue
    kw = dict(color=nc.COLORS[m], ls=nc.STYLES[m], lw=1.6 if m == "shooting" else 1.2, label=label[m], zorder=3 if m != "shooting" else 2)
    for i in range(3):
        axes[i].plot(d["t"], d["q"][:, i], **kw)
    axes[3].plot(d["t"], d["lam"][:, 0], **kw)
# stick phases of mass 1 (full shooting): |u_1| = 0
d = sol["shooting"]
stick = np.abs(d["u"][:-1, 0]) < 1e-9 * np.abs(d["u"][:, 0]).max()
for s, n in nc.wfcore.runs(stick):
    for ax in axes:
        ax.axvspan(d["t"][s], d["t"][min(s + n, len(d["t"]) - 1)], color="0.85", lw=0, zorder=0)
for i in range(3):
    axes[i].set_ylabel(f"$q_{i + 1}$ (m)")
axes[3].set_ylabel(r"friction force $\lambda_T$ (N)")
bound = num["friction_bound"]
for b in (bound, -bound):
    axes[3].axhline(b, color="0.5", lw=0.7, ls=":")
axes[3].set_xlabel("t (s)")
axes[3].set_xlim(0, d["t"][-1])
for m in ("hbm", "mshbm"):
    if sol[m] is None:
        axes[0].plot([], [], color=nc.COLORS[m], marker="x", ls="none", label=f"{label[m]}: no convergence, not drawn")
axes[0].legend(loc="lower left", ncol=1, framealpha=0.9)
axes[0].set_title(f"3-DOF friction oscillator, T = {d['t'][-1]:.3g} s: grey = stick of mass 1 "
                  f"({nc.fmt(num['stick_fraction_shooting'], 'pct')} of the period, full shooting)\n"
                  f"periodic orbit {nc.stability_short(num, 'reference')}", fontsize=8)
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## Solver facts
#
# Newton iterations, start, amplitudes and errors of each solution shown (and of the reference).
# Stability: the Floquet multipliers of each orbit come from the exact event-driven flow with its
# saltation terms at the stick-slip transitions and slip reversals (`mshbm.stability`, started from
# the converged solution of each method); the undamped chain has no viscous dissipation, so the
# largest modulus is close to 1 (dry friction is the only dissipation).

# %%
rows = []
for key in ("reference", "shooting", "mshbm", "hbm"):
    m = S["methods"][key]
    err = S["errors"].get(key, {})
    amps = m.get("amplitude") or []
    rows.append((nc.LABELS[key], m["harmonics"] if key in ("mshbm", "hbm") else "-", m["steps"],
                 "yes" if m["success"] else "NO", nc.start_text(m.get("start_used")), m.get("iterations"),
                 ", ".join(f"{a:.4f}" for a in amps),
                 nc.fmt(err.get("err_max"), "pct") if err else "(reference)",
                 nc.fmt(m.get("stick_or_closed_fraction"), "pct") if m.get("stick_or_closed_fraction") is not None else "-",
                 nc.stability_cell(m)))
display(Markdown(nc.md_table(["method", "n_H", "steps", "converged", "start", "Newton it.", "amplitudes m1..m3 (m)",
                              "max. rel. amplitude error", "stick fraction m1", "stability (max. Floquet modulus)"],
                             rows)))
for key in ("mshbm", "hbm"):
    m = S["methods"][key]
    if not m["success"]:
        print(f"{key}: {m['message']}")
