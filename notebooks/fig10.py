# %% [markdown]
# # Fig. 10 — A finite-element structure with a friction joint and an impact stop (beyond the paper)
#
# **Not in the paper.** The paper's method is meant for "large linear structures with few local
# nonlinearities" and shows only chains.  Here the linear part comes from a finite-element model
# written to Matrix Market files (`workflow/scripts/fe/build_fe_model.py`, rule `fe_model`): a cantilever
# Kirchhoff plate of bicubic Hermite (Bogner–Fox–Schmit) elements with Rayleigh damping.  A friction
# joint acts on a node at mid-length and an impact stop on a node of the free edge; the model is reduced
# onto these two node DOFs (Craig–Bampton with a few fixed-interface modes, `mshbm.reduction`), and every
# method solves the reduced model.  The frequency-response curve
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
LAB = {"mshbm": "MS-HBM", "mshbm-event": "MS-HBM (event-driven)", "hbm": "HBM", "dlft": "DLFT", "shooting": "full shooting"}
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


panels = [("tip", "(a) free edge (node of the stop)"), ("friction_node", "(b) node of the friction joint"),
          ("pad", "(c) pad of the stop (contact DOF)"), ("shoe", "(d) shoe of the friction joint")]
panels = [p for p in panels if any(p[0] in b["amplitude"] for b in B.values())]
fig, axes = plt.subplots(1, len(panels), figsize=(2.7 * len(panels), 3.0), squeeze=False)
for ax, (dof, title) in zip(axes[0], panels):
    for m, b in B.items():
        if dof in b["amplitude"]:
            draw(ax, b, dof, COL.get(m, "0.4"), CURVE.get(m, m))
    if dof == ("pad" if N.get("bodies") else "tip"):
        ax.axhline(N["gap"] * 1e3, color="0.5", lw=0.8, ls="-.", label="gap")
    ax.set_title(title)
    ax.set_xlim(N["omega_start"], N["omega_end"])  # a branch may run out of the range before it stops
    ax.set_xlabel("ω (rad/s)")
    ax.set_ylabel("amplitude (mm)")
    ax.legend(fontsize=7)
fig.tight_layout()
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## The model

# %%
nan = float("nan")
rows = [("mesh", f"{N['n_el']} x {N['ny']} BFS elements" if N["model"] == "plate" else f"{N['n_el']} Hermite beam elements"),
        ("DOFs of the model", f"{N['n_dofs']}" + (f" (structure {N['n_structure_dofs']} + 2 bodies)" if N.get("bodies") else "")),
        ("ω₁ of the model (rad/s)", f"{N['omega_1']:.4f}"),
        ("μ F_N (N), forcing (N), gap (mm)", f"{N['mu_FN']:.3g}, {N['force']:.3g}, {N['gap'] * 1e3:.4g}"),
        ("local frequency / ω of a node DOF (unreduced)", f"{N.get('node_local_ratio', nan):.3g}"),
        ("event-driven sub-steps per period of the node DOFs (unreduced)", f"{N.get('node_event_substeps', nan):.3g}")]
if N.get("reduced"):
    rows += [("reduction: modes, DOFs solved, highest mode kept (rad/s)",
              f"{N['reduce_modes']}, {N['n_reduced_dofs']}, {N['reduction_highest_mode']:.4g}"),
             ("reduction: build time (s, of the single solves' model)", f"{N['reduction_build_s']:.2f}")]
if N.get("bodies"):
    rows += [("bodies: mass (kg), spring (N/m)", f"{N.get('body_mass', nan):.4g}, {N.get('body_stiffness', nan):.4g}"),
             ("local frequency / ω of a body; its event-driven sub-steps", f"{N.get('body_local_ratio', nan):.3g}, {N.get('body_event_substeps', nan):.3g}")]
display(Markdown(nc.md_table(["", "value"], rows)))

# %% [markdown]
# ## Convergence of the reduction in the number of modes
#
# MS-HBM with the exact event-driven flow at the case's frequency, certified at the default accuracy; the
# reduction's error estimate is the largest relative error of the reduced model's linear response at the element
# DOFs over the harmonics the solution carries.

# %%
if N.get("modes_checked"):
    table = [(m, f"{N[f'modes_{m}_tip'] * 1e3:.7g}", f"{N.get(f'modes_{m}_tip_rel_diff', 0.0):.1e}",
              f"{N[f'modes_{m}_estimate']:.2e}", "yes" if N[f"modes_{m}_success"] else "NO",
              f"{N[f'modes_{m}_cpu_time']:.2f}") for m in N["modes_checked"].split(", ")]
    display(Markdown(nc.md_table(["modes", "largest displacement at the stop (mm)", "against the most modes", "reduction estimate",
                                  "certified", "CPU (s)"], table)))

# %% [markdown]
# ## Every branch and every single solve
#
# Time: the whole sweep (start solve, continuation, certificates and stability analyses), one job of
# the workflow, wall and CPU; single solves at the case's frequency (MS-HBM started from the HBM solution),
# certified at the default accuracy (with the reduction's error estimate), CPU time against the target of
# the single solves.

# %%
table = []
for m, b in B.items():
    table.append((CURVE.get(m, m), "yes" if b["success"] else "NO", b["points"],
                  f"{min(b['omega']):.3f}–{max(b['omega']):.3f}" if b["omega"] else "–", f"{b['wall_time_s']:.1f}",
                  "–" if b.get("cpu_time_s") is None else f"{b['cpu_time_s']:.1f}",
                  sum(v is False for v in b["stable"]), sum(v is None for v in b["stable"]),
                  "" if b["success"] else b["message"][:160]))
display(Markdown(nc.md_table(["method", "reached", "points", "ω range", "time (s)", "CPU (s)", "unstable points",
                              "points without stability", "stopped because"], table)))
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
        table.append((LAB.get(r["method"], r["method"]), "–", "–", "–", "–", "–",
                      r["skipped"] + (f"; set-up {c['setup_s']:.2f} s, one period of the state {c['period_state_s']:.2f} s"
                                      if c else "")))
    else:
        cpu = r.get("cpu_time_s")
        est = r.get("reduction_estimate")
        table.append((LAB.get(r["method"], r["method"]), "yes" if r["success"] else "NO", f"{r['wall_time_s']:.2f}",
                      "–" if cpu is None else f"{cpu:.2f}" + (" (≤ target)" if cpu <= N["solve_target_s"] and r["success"] else ""),
                      "–" if est is None else f"{est:.1e}",
                      ", ".join(f"{k} {v * 1e3:.4g} mm" for k, v in r["amplitudes"].items()), r["message"][:120]))
display(Markdown(nc.md_table(["method", "certified", "time (s)", f"CPU (s; target {N['solve_target_s']:g})",
                              "reduction estimate", "amplitudes", "message"], table)))
