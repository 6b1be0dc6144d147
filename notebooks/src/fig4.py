# %% [markdown]
# # Fig. 4 — work–precision diagram, 30-mass chain with friction
#
# **Paper (Sec. 4.1, Fig. 4):** the 3-DOF friction oscillator is extended to $n = 30$ masses
# (forcing $5\cos\omega t$ on the last mass only).  For $n_H = 1, 3, \dots, 25$ the relative
# amplitude error of mass 1 and of mass $n$ and the calculation effort of HBM and MS-HBM are
# shown, both relative to full shooting ("almost exact").  Every method starts from its own
# solution at a nearby frequency.  Claims: *"the computation effort for a moderate accuracy can
# be reduced drastically by using the MS-HBM approach.  Compared to the HBM, the mixed approach
# shows for all values of $n_H$ more accurate results.  The horizontal plateau of the relative
# error of the mixed method can be explained by the limited resolution of the used Fourier
# transformation and the integration schemes."*
#
# **Here (protocol):** each point is one solve job.  The timed solve at $\omega$ starts from the
# method's own converged solution at the nearby frequency (config `starts.nearby_factor`),
# computed in the same job; if no such solution exists, it starts from the linear response at
# $\omega$ (half-filled marker) — full shooting, the effort reference, is timed from both starts
# and each point is divided by the shooting time *from the same start*.  Effort = median of
# the timed repeats after an untimed warm-up (numba compilation excluded), whole `mshbm.solve`
# call.  Errors are against full shooting with the finer reference step; the dashed black line
# is the error of full shooting with the working step count against that reference (the
# time-discretisation floor).  Points that did not converge from any start are drawn as ×
# at the top of the panels and never as if valid.

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/fig4.json"
out_png = "results/figures/fig4.png"
out_pdf = "results/figures/fig4.pdf"

# %%
import os, sys
sys.path.insert(0, "notebooks") if os.path.isdir("notebooks") else None
import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from matplotlib.lines import Line2D
from matplotlib.transforms import blended_transform_factory
from IPython.display import Markdown, display

nc.setup()
cfg = nc.load_json(config)
S = nc.load_json(summary)
num = S["numbers"]
scfg = cfg["systems"][S["system"]]
n = scfg["n"]
factor = cfg["starts"]["nearby_factor"]
CLOCK = S.get("clock", "wall")

# %% [markdown]
# ## The paper's claims and our numbers

# %%
display(Markdown(nc.claims_table(S)))

# %%
MARK = {"hbm": "o", "mshbm": "s", "mshbm-fd": "D"}
COL = {"hbm": nc.COLORS["hbm"], "mshbm": nc.COLORS["mshbm"], "mshbm-fd": "#ff7f0e"}
LAB = {"hbm": "HBM", "mshbm": "MS-HBM", "mshbm-fd": "MS-HBM vs shooting, both FD Jacobian"}


def series(rows, method):
    return [r for r in rows if r["method"] == method]


def plot_points(ax, rows, method, yfun, connect=True):
    ok = [r for r in rows if r["success"] and yfun(r) is not None]
    if connect and ok:
        ax.plot([r["harmonics"] for r in ok], [yfun(r) for r in ok], color=COL[method], lw=0.9, alpha=0.7,
                ls="--" if method == "mshbm-fd" else "-")
    for r in ok:
        fill = "full" if r["start"] == "nearby" else "left"
        ax.plot(r["harmonics"], yfun(r), marker=MARK[method], color=COL[method], fillstyle=fill, ms=5.5,
                mfc=COL[method] if fill == "full" else COL[method], mfcalt="white", ls="none")
    bad = [r for r in rows if not r["success"]]
    tr = blended_transform_factory(ax.transData, ax.transAxes)
    for r in bad:
        ax.plot(r["harmonics"], 0.955 if method == "hbm" else 0.915, marker="x", color=COL[method], ms=6,
                transform=tr, clip_on=False, ls="none")


def fail_band(ax, rows_all):
    """Reserve the top of a log axis for the 'no convergence' markers (above every data point)."""
    if not any(not r["success"] for r in rows_all):
        return
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi * (hi / lo) ** 0.18)
    ax.axhspan(hi * (hi / lo) ** 0.06, ax.get_ylim()[1], color="0.93", zorder=0, lw=0)
    yc = (hi * (hi / lo) ** 0.06 * ax.get_ylim()[1]) ** 0.5
    ax.annotate("n.c.", xy=(0, yc), xycoords=("axes fraction", "data"), xytext=(-3, 0), textcoords="offset points",
                ha="right", va="center", fontsize=7, color="0.3")


rows, fd_rows = S["rows"], S.get("fd_rows") or []
fig, axes = plt.subplots(2, 2, figsize=(7.6, 6.2))
(a1, a2), (a3, a4) = axes
for ax, key, title in ((a1, "err_first", "mass 1"), (a2, "err_last", f"mass {n}")):
    floor = S["shooting_error"]["err_first" if key == "err_first" else "err_last"]
    if floor:
        ax.axhline(floor, color="k", ls="--", lw=0.9)
    ax.set_yscale("log")
    for m in ("hbm", "mshbm"):
        ok = [r for r in series(rows, m) if r["success"]]
        if ok:
            ax.plot([r["harmonics"] for r in ok], [max(r[key], 1e-12) for r in ok], ls="none")
    fail_band(ax, rows)
    for m in ("hbm", "mshbm"):
        plot_points(ax, series(rows, m), m, lambda r, k=key: max(r[k], 1e-12))
    ax.set_title(f"relative amplitude error, {title}")
    ax.set_xlabel("$n_H$")
a3.axhline(1.0, color="k", lw=0.9)
a3.set_yscale("log")
for m, rr in (("hbm", series(rows, "hbm")), ("mshbm", series(rows, "mshbm")), ("mshbm-fd", fd_rows)):
    ok = [r for r in rr if r["success"] and r["effort"]]
    if ok:
        a3.plot([r["harmonics"] for r in ok], [r["effort"] for r in ok], ls="none")
fail_band(a3, rows + fd_rows)
for m in ("hbm", "mshbm"):
    plot_points(a3, series(rows, m), m, lambda r: r["effort"])
plot_points(a3, fd_rows, "mshbm-fd", lambda r: r["effort"])
a3.set_title(f"effort: {CLOCK} time / full shooting")
a3.set_xlabel("$n_H$")
# work-precision: larger of the two errors vs effort
for m, rr in (("hbm", series(rows, "hbm")), ("mshbm", series(rows, "mshbm")), ("mshbm-fd", fd_rows)):
    ok = [r for r in rr if r["success"] and r["effort"]]
    if not ok:
        continue
    x = [r["effort"] for r in ok]
    y = [max(r["err_first"], r["err_last"], 1e-12) for r in ok]
    for r, xi, yi in zip(ok, x, y):
        a4.plot(xi, yi, marker=MARK[m], color=COL[m], ls="none", ms=5,
                fillstyle="full" if r["start"] == "nearby" else "left", mfcalt="white")
    for r, xi, yi in zip(ok, x, y):
        if r["harmonics"] in (1, 3, 5, 9, 25) or len(ok) <= 5:
            a4.annotate(str(r["harmonics"]), (xi, yi), textcoords="offset points", xytext=(3, 2), fontsize=6.5, color=COL[m])
a4.axvline(1.0, color="k", lw=0.9)
a4.set_xscale("log"); a4.set_yscale("log")
a4.set_xlabel(f"effort ({CLOCK} time / full shooting)")
a4.set_title("work-precision: max. error of masses 1 and n")
handles = [Line2D([], [], marker=MARK[m], color=COL[m], ls="-", label=LAB[m]) for m in ("hbm", "mshbm")]
if fd_rows:
    handles.append(Line2D([], [], marker=MARK["mshbm-fd"], color=COL["mshbm-fd"], ls="--", label=LAB["mshbm-fd"]))
handles += [Line2D([], [], marker="s", color="0.3", ls="none", label=f"start: own solution at {factor:g} ω"),
            Line2D([], [], marker="s", color="0.3", fillstyle="left", mfcalt="white", ls="none",
                   label="start: linear response at ω (nearby failed)"),
            Line2D([], [], marker="x", color="0.3", ls="none", label="no convergence from any start"),
            Line2D([], [], color="k", ls="--", label=f"full shooting, N = {cfg['numerics']['steps']}, vs reference")]
fig.legend(handles=handles, loc="lower center", ncol=2, fontsize=7, bbox_to_anchor=(0.5, -0.1))
fig.suptitle(f"{scfg['title']}: {n} masses, reference full shooting N = {cfg['numerics']['reference_steps']}", fontsize=9)
fig.tight_layout()
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# ## All points
#
# `effort` = median time of the method / median time of full shooting from the same start
# (clock: config `timing.clock`; `effort (other clock)` uses the other one — wall time vs.
# process CPU time — as a check of the timing noise).  `start` is the start actually used
# (`nearby`: the paper's protocol).

# %%
def table(rr):
    out = []
    for r in rr:
        out.append((r["method"], r["harmonics"], "yes" if r["success"] else "NO", r["start"] or "-",
                    r["iterations"] if r["success"] else "-",
                    nc.fmt(r["err_first"], "pct") if r["success"] else "-",
                    nc.fmt(r["err_last"], "pct") if r["success"] else "-",
                    nc.fmt(r["time_median"], "f4") if r["success"] else "-",
                    nc.fmt(r["effort"], "f3") if r["success"] else "-",
                    nc.fmt(r.get("effort_cpu", r.get("effort_wall")), "f3") if r["success"] else "-",
                    (r.get("effort_ref_start") or "-") if r["success"] else "-",
                    "" if r["success"] else (r["message"] or "")[:160]))
    return nc.md_table(["method", "n_H", "converged", "start", "Newton it.", "err. mass 1", f"err. mass {n}",
                        f"{CLOCK} time (s)", "effort", "effort (other clock)", "shooting start (effort ref.)",
                        "failure"], out)


display(Markdown(table(rows + fd_rows)))

# %% [markdown]
# ## Reference solutions
#
# The reference and the effort reference are full shooting solutions reached from the solution at
# the nearby frequency (Newton).  Their Floquet multipliers (monodromy matrix) are reported; for
# the undamped friction chain the largest modulus is close to 1.

# %%
rows2 = []
for key, label in (("reference", f"full shooting, N = {cfg['numerics']['reference_steps']} (error reference)"),
                   ("shooting", f"full shooting, N = {cfg['numerics']['steps']} (effort reference)"),
                   ("shooting_fd", f"full shooting, N = {cfg['numerics']['steps']}, FD Jacobian"),
                   ("check", "check system (see Table footnote)")):
    m = S.get(key)
    if not m:
        continue
    rows2.append((label, "yes" if m["success"] else "NO", m.get("start_used"), m.get("iterations"),
                  nc.fmt(m.get("amplitude_first"), "g"), nc.fmt(m.get("amplitude_last"), "g"),
                  nc.fmt(m.get("floquet_max_modulus"), "f6"), nc.fmt(m.get("stick_or_closed_fraction"), "pct3"),
                  ", ".join(f"{k}: {v:.4f} s" for k, v in (m.get("wall_time_median_by_start") or {}).items() if v)))
display(Markdown(nc.md_table(["solution", "converged", "start", "Newton it.", "amp. mass 1", f"amp. mass n",
                              "max. Floquet modulus", "stick fraction m1 / impulse", "median time by start"], rows2)))
