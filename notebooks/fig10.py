# %% [markdown]
# # Fig. 10 — A finite-element structure with a friction joint and an impact stop (beyond the paper)
#
# **Not in the paper.** The paper's method is meant for "large linear structures with few local
# nonlinearities" and shows only chains.  Here the linear part comes from a finite-element model
# written to Matrix Market files (`workflow/scripts/fe/build_fe_model.py`, rule `fe_model`): a cantilever
# Kirchhoff plate of bicubic Hermite (Bogner–Fox–Schmit) elements with Rayleigh damping.  A friction
# joint acts at mid-length and an impact stop at the free edge, each on a small lumped body (the shoe
# of the joint, the pad of the stop) tied to its node by a spring.  The frequency-response curve
# around the first bending resonance comes from `mshbm.sweep` with each method (rule `fe_sweep`),
# single solves at one frequency are timed (rule `fe_example`), and the summary (rule `fe_summary`)
# holds every number shown here.  Solid: stable; dashed: unstable; dotted: no valid stability estimate.

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/fe.json"
out_png = "results/figures/fig10.png"
out_pdf = "results/figures/fig10.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

nc.setup()
cfg = nc.load_json(config)
S = nc.load_json(summary)
N = S["numbers"]
B = S["branches"]

COL = {"mshbm": nc.COLORS["mshbm"], "hbm": nc.COLORS["hbm"], "dlft": "#2ca02c", "shooting": "k"}
LAB = {"mshbm": "MS-HBM", "hbm": "HBM", "dlft": "DLFT", "shooting": "full shooting"}
CURVE = dict(LAB)  # the curves' labels name their time integration (config fe_example.sweep_options)
for m in B:
    if N.get(f"{m}_integrator") == "event" and m in CURVE:
        CURVE[m] += " (event-driven)"


def draw(ax, b, dof, color, label):
    """The branch with its stability: one line per run of equal verdicts (overlapping one point)."""
    w = np.asarray(b["omega"], dtype=float)
    a = np.asarray(b["amplitude"][dof], dtype=float) * 1e3
    st = b["stable"]
    i, first = 0, True
    while i < len(w):
        j = i
        while j + 1 < len(w) and st[j + 1] == st[i]:
            j += 1
        ls = "-" if st[i] is True else ("--" if st[i] is False else ":")
        seg = slice(i, min(j + 2, len(w)))
        ax.plot(w[seg], a[seg], ls=ls, color=color, label=label if first else None)
        first = False
        i = j + 1


panels = [("tip", "(a) free edge (structure node)"), ("pad", "(b) pad of the stop (contact DOF)"),
          ("shoe", "(c) shoe of the friction joint")]
panels = [p for p in panels if any(p[0] in b["amplitude"] for b in B.values())]
fig, axes = plt.subplots(1, len(panels), figsize=(2.7 * len(panels), 3.0), squeeze=False)
for ax, (dof, title) in zip(axes[0], panels):
    for m, b in B.items():
        if dof in b["amplitude"]:
            draw(ax, b, dof, COL.get(m, "0.4"), CURVE.get(m, m))
    if dof == "pad":
        ax.axhline(N["gap"] * 1e3, color="0.5", lw=0.8, ls="-.", label="gap")
    ax.set_title(title)
    ax.set_xlabel("ω (rad/s)")
    ax.set_ylabel("amplitude (mm)")
    ax.legend(fontsize=7)
fig.tight_layout()
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## The model

# %%
rows = [("mesh", f"{N['n_el']} x {N['ny']} BFS elements" if N["model"] == "plate" else f"{N['n_el']} Hermite beam elements"),
        ("DOFs (structure + bodies)", f"{N['n_structure_dofs']} + {N['n_dofs'] - N['n_structure_dofs']}"),
        ("ω₁ of the model (rad/s)", f"{N['omega_1']:.4f}"),
        ("bodies: mass (kg), spring (N/m)", f"{N.get('body_mass', float('nan')):.4g}, {N.get('body_stiffness', float('nan')):.4g}"),
        ("μ F_N (N), forcing (N), gap (mm)", f"{N['mu_FN']:.3g}, {N['force']:.3g}, {N['gap'] * 1e3:.4g}"),
        ("local frequency / ω of a node DOF, of a body", f"{N.get('node_local_ratio', float('nan')):.3g}, {N.get('body_local_ratio', float('nan')):.3g}"),
        ("event-driven sub-steps per period: node DOFs, bodies", f"{N.get('node_event_substeps', float('nan')):.3g}, {N.get('body_event_substeps', float('nan')):.3g}")]
display(Markdown(nc.md_table(["", "value"], rows)))

# %% [markdown]
# ## Every branch and every single solve
#
# Time: the whole sweep (start solve, continuation, certificates and stability analyses), one job of
# the workflow; single solves at the case's frequency (MS-HBM started from the HBM solution).

# %%
table = []
for m, b in B.items():
    table.append((CURVE.get(m, m), "yes" if b["success"] else "NO", b["points"],
                  f"{min(b['omega']):.3f}–{max(b['omega']):.3f}" if b["omega"] else "–", f"{b['wall_time_s']:.1f}",
                  sum(v is False for v in b["stable"]), "" if b["success"] else b["message"][:160]))
display(Markdown(nc.md_table(["method", "reached", "points", "ω range", "time (s)", "unstable points",
                              "stopped because"], table)))
# %% [markdown]
# Cost of each curve: DOFs of its model, time per point, corrector iterations and failures, and the sparse
# factorisations of the condensation against the solves refined from kept LUs (`mshbm.condensation.FactorReuse`).

# %%
table = [(CURVE.get(m, m), N.get(f"{m}_n_dofs"), f"{N[f'{m}_time_per_point']:.2f}", N.get(f"{m}_corrector_iterations"),
          N.get(f"{m}_corrector_failures"), N.get(f"{m}_factorisations"), N.get(f"{m}_refined")) for m in B]
display(Markdown(nc.md_table(["method", "DOFs", "s per point", "corrector iterations", "corrector failures",
                              "factorisations", "refined solves"], table)))
table = []
for r in S["solves"]:
    if "skipped" in r:
        c = r.get("cost") or {}
        table.append((LAB.get(r["method"], r["method"]), "–", "–", "–",
                      r["skipped"] + (f"; set-up {c['setup_s']:.2f} s, one period of the state {c['period_state_s']:.2f} s"
                                      if c else "")))
    else:
        table.append((LAB.get(r["method"], r["method"]), "yes" if r["success"] else "NO", f"{r['wall_time_s']:.2f}",
                      ", ".join(f"{k} {v * 1e3:.4g} mm" for k, v in r["amplitudes"].items()), r["message"][:120]))
display(Markdown(nc.md_table(["method", "certified", "time (s)", "amplitudes", "message"], table)))
