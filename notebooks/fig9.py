# %% [markdown]
# # Fig. 9 — Frequency-response curves with stability and bifurcations (beyond the paper)
#
# **Not in the paper.** The paper compares the methods at one frequency, π/5.  What users of the
# field compute is the *frequency-response curve*: the branch of periodic solutions through
# resonance, with its stable and unstable parts and its bifurcations.  `mshbm.sweep` traces it by
# pseudo-arclength continuation in ω for every method (config `branches`, rule `branch`): every point
# is certified, its stability comes from `mshbm.stability` (exact event-driven Floquet multipliers with
# saltation terms for one element, Hill's method for HBM without contacts, none where no valid
# estimate exists), and period doubling, Neimark–Sacker, folds and grazing are located along it.
#
# (a) The 3-DOF friction chain (Table 1) over its resonances; (b) the 5-DOF impact chain (Table 2)
# around π/5, its T-periodic branch, the 2T-periodic branch on which the chain settles from rest
# at π/5, and the 2T-periodic branch born at the period doubling of the T-periodic one, found by branch
# switching (`mshbm.switch_period_doubling`: the eigenvector of the multiplier −1 of the exact monodromy),
# traced with the exact event-driven flow; it passes π/5 through the response from rest (paper Section 5.7).  Solid: stable; dashed: unstable; dotted: no valid stability estimate.

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/branches.json"
out_png = "results/figures/fig9.png"
out_pdf = "results/figures/fig9.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from matplotlib.lines import Line2D
from IPython.display import Markdown, display

nc.setup()
cfg = nc.load_json(config)
S = nc.load_json(summary)
rows = S["rows"]

COL = {"shooting": "k", "mshbm": nc.COLORS["mshbm"], "hbm": nc.COLORS["hbm"], "dlft": "#2ca02c",
       "mshbm-intermediate": "#ff7f0e", "shooting-event": "#17becf", "mshbm-event": "#e377c2"}
LAB = {"shooting": "full shooting", "mshbm": "MS-HBM", "hbm": "HBM", "dlft": "DLFT",
       "mshbm-intermediate": "MS-HBM (Sec. 3.3)", "shooting-event": "full shooting, event-driven",
       "mshbm-event": "MS-HBM, event-driven"}


def key(r):
    """The curve's label (config branches.<name>.methods): the method, or a variant of it."""
    return r.get("label", r["method"])
BIF = {"period-doubling": ("s", "period doubling"), "neimark-sacker": ("D", "Neimark–Sacker"),
       "fold": ("^", "fold"), "grazing": ("x", "grazing")}
P2_COL = "#9467bd"
PD_COL = "#8c564b"


def draw(ax, r, dof, color, label):
    """The branch with its stability: one line per run of equal verdicts."""
    w = np.asarray(r["omega"], dtype=float)
    a = np.asarray(r["amplitude"], dtype=float)[:, dof] if r["amplitude"] else np.zeros(0)
    st = r["stable"]
    i = 0
    first = True
    while i < len(w):
        j = i
        while j + 1 < len(w) and st[j + 1] == st[i]:
            j += 1
        ls = "-" if st[i] is True else ("--" if st[i] is False else ":")
        seg = slice(i, min(j + 2, len(w)))  # overlap one point: no gaps between runs
        ax.plot(w[seg], a[seg], ls=ls, color=color, lw=1.3 if key(r) == "shooting" else 1.1,
                label=label if first else None, alpha=0.9)
        first = False
        i = j + 1
    for b in r["bifurcations"]:
        if b["type"] in BIF and len(w):
            mk = BIF[b["type"]][0]
            k = min(int(b.get("index", 0)), len(w) - 1)
            ax.plot(b["omega"], np.interp(b["omega"], np.sort(w), a[np.argsort(w)]) if b["type"] != "fold"
                    else a[k], mk, color=color, mfc="white", ms=6, mew=1.3)


panels = [("friction3", 0, "(a) 3-DOF friction chain: mass 1"), ("impact5", 0, "(b) 5-DOF impact chain: mass 1")]
present = [p for p in panels if any(r["name"].startswith(p[0]) for r in rows)]
fig, axes = plt.subplots(1, len(present), figsize=(7.6 if len(present) > 1 else 4.2, 3.6), squeeze=False)
for ax, (name, dof, title) in zip(axes[0], present):
    for r in rows:
        if r["name"] == name:
            draw(ax, r, dof, COL.get(key(r), "0.3"), LAB.get(key(r), key(r)))
        elif r["name"].startswith(name) and r["period"] > 1 and r["options"].get("parent"):
            draw(ax, r, dof, PD_COL, f"period {r['period']}, from the PD")
        elif r["name"].startswith(name) and r["period"] > 1:
            draw(ax, r, dof, P2_COL, f"period {r['period']}, from π/5")
    if name == "impact5":
        ax.axvline(np.pi / 5, color="0.6", lw=0.7, ls=":")
        ax.annotate("π/5", (np.pi / 5, 0.02), xycoords=("data", "axes fraction"), fontsize=7, color="0.4")
    ax.set_title(title)
    ax.set_xlabel("ω (rad/s)")
    ax.set_ylabel("amplitude (m)")
    ax.grid(alpha=0.3)
    if name == "friction3":
        ax.legend(fontsize=6.5, loc="upper right")
    else:  # room above the resonance peak for the legend, clear of the curves
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi + 0.45 * (hi - lo))
        ax.legend(fontsize=6, loc="upper left", ncol=2)
handles = [Line2D([], [], color="0.3", ls="-", label="stable"), Line2D([], [], color="0.3", ls="--", label="unstable"),
           Line2D([], [], color="0.3", ls=":", label="no valid estimate")]
handles += [Line2D([], [], marker=m, color="0.3", mfc="white", ls="none", label=l) for m, l in BIF.values()]
fig.legend(handles=handles, loc="lower center", ncol=7, fontsize=6.5, bbox_to_anchor=(0.5, -0.04))
fig.tight_layout(rect=(0, 0.06, 1, 1))
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## Every branch
#
# `reached`: the sweep reached the end of its range with every point certified; otherwise its message
# says where and why it stopped.  Time: the whole sweep (start solve, continuation, certificates and
# stability analyses), one job of the workflow.

# %%
table = []
for r in rows:
    bifs = ", ".join(f"{b['type']} {b['omega']:.4f}" for b in r["bifurcations"][:6]) + \
        (" …" if len(r["bifurcations"]) > 6 else "")
    table.append((r["name"], LAB.get(key(r), key(r)), r["period"], "yes" if r["success"] else "NO", r["points"],
                  f"{min(r['omega']):.4f}–{max(r['omega']):.4f}" if r["omega"] else "–",
                  f"{r['wall_time_s']:.2f}", sum(v is False for v in r["stable"]), bifs or "–",
                  "" if r["success"] else r["message"][:160]))
display(Markdown(nc.md_table(["branch", "method", "period", "reached", "points", "ω range", "time (s)",
                              "unstable points", "bifurcations", "stopped because"], table)))
