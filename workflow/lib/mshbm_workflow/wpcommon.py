"""Work-precision figures (Figs. 4 and 8): the plot and tables shared by both notebooks.

Plotting only, no solver logic; the numbers come from results/summary/fig{4,8}.json.
"""
from matplotlib.lines import Line2D
from matplotlib.transforms import blended_transform_factory
import matplotlib.pyplot as plt

from mshbm_workflow import nbcommon as nc

MARK = {"hbm": "o", "mshbm": "s", "dlft": "^", "mshbm-fd": "D"}
COL = {"hbm": nc.COLORS["hbm"], "mshbm": nc.COLORS["mshbm"], "dlft": "#2ca02c", "mshbm-fd": "#ff7f0e"}
LAB = {"hbm": "HBM", "mshbm": "MS-HBM", "dlft": "DLFT", "mshbm-fd": "MS-HBM vs shooting, both FD Jacobian"}
#: the y position (axes fraction) of each method's "no convergence" markers
FAIL_Y = {"hbm": 0.955, "mshbm": 0.915, "dlft": 0.875, "mshbm-fd": 0.915}


def methods(rows):
    """The harmonic methods of the sweep, in plotting order (DLFT only where the workflow solved it)."""
    return [m for m in ("hbm", "mshbm", "dlft") if any(r["method"] == m for r in rows)]


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
        ax.plot(r["harmonics"], FAIL_Y[method], marker="x", color=COL[method], ms=6,
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




def ref_label(cfg, S):
    """What the errors are measured against (the exact solution unless it failed)."""
    if S.get("error_reference") == "exact":
        return "exact event-driven solution"
    return f"reference full shooting, N = {cfg['numerics']['reference_steps']}"


def plot(cfg, S, out_png, out_pdf):
    """Errors of masses 1 and n, effort and work-precision panels; returns ``(rows, fd_rows)``."""
    scfg = cfg["systems"][S["system"]]
    n = scfg["n"]
    factor = cfg["starts"]["nearby_factor"]
    CLOCK = S.get("clock", "wall")
    rows, fd_rows = S["rows"], S.get("fd_rows") or []
    fig, axes = plt.subplots(2, 2, figsize=(7.6, 6.2))
    (a1, a2), (a3, a4) = axes
    for ax, key, title in ((a1, "err_first", "mass 1"), (a2, "err_last", f"mass {n}")):
        floor = S["shooting_error"]["err_first" if key == "err_first" else "err_last"]
        if floor:
            ax.axhline(floor, color="k", ls="--", lw=0.9)
        ax.set_yscale("log")
        for m in methods(rows):
            ok = [r for r in series(rows, m) if r["success"]]
            if ok:
                ax.plot([r["harmonics"] for r in ok], [max(r[key], 1e-12) for r in ok], ls="none")
        fail_band(ax, rows)
        for m in methods(rows):
            plot_points(ax, series(rows, m), m, lambda r, k=key: max(r[k], 1e-12))
        ax.set_title(f"relative amplitude error, {title}")
        ax.set_xlabel("$n_H$")
    a3.axhline(1.0, color="k", lw=0.9)
    a3.set_yscale("log")
    for m, rr in [(m, series(rows, m)) for m in methods(rows)] + [("mshbm-fd", fd_rows)]:
        ok = [r for r in rr if r["success"] and r["effort"]]
        if ok:
            a3.plot([r["harmonics"] for r in ok], [r["effort"] for r in ok], ls="none")
    fail_band(a3, rows + fd_rows)
    for m in methods(rows):
        plot_points(a3, series(rows, m), m, lambda r: r["effort"])
    plot_points(a3, fd_rows, "mshbm-fd", lambda r: r["effort"])
    a3.set_title(f"effort: {CLOCK} time / full shooting")
    a3.set_xlabel("$n_H$")
    # work-precision: larger of the two errors vs effort
    for m, rr in [(m, series(rows, m)) for m in methods(rows)] + [("mshbm-fd", fd_rows)]:
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
    handles = [Line2D([], [], marker=MARK[m], color=COL[m], ls="-", label=LAB[m]) for m in methods(rows)]
    if fd_rows:
        handles.append(Line2D([], [], marker=MARK["mshbm-fd"], color=COL["mshbm-fd"], ls="--", label=LAB["mshbm-fd"]))
    handles += [Line2D([], [], marker="s", color="0.3", ls="none", label=f"start: own solution at {factor:g} ω"),
                Line2D([], [], marker="s", color="0.3", fillstyle="left", mfcalt="white", ls="none",
                       label="start: linear response at ω (nearby failed)"),
                Line2D([], [], marker="x", color="0.3", ls="none", label="no convergence from any start"),
                Line2D([], [], color="k", ls="--", label=f"full shooting, N = {cfg['numerics']['steps']}, vs {ref_label(cfg, S)}")]
    fig.legend(handles=handles, loc="lower center", ncol=2, fontsize=7, bbox_to_anchor=(0.5, -0.1))
    fig.suptitle(f"{scfg['title']}: {n} masses; errors against the {ref_label(cfg, S)};\n"
                 f"the periodic orbit of the reference full shooting is {nc.stability_short(S['numbers'], 'reference')}",
                 fontsize=8.5)
    fig.tight_layout()
    nc.save(fig, out_png, out_pdf)
    return rows, fd_rows


def points_table(rr, n, CLOCK):
    """All points of the sweep as a Markdown table."""
    out = []
    for r in rr:
        out.append((r["method"], r["harmonics"], "yes" if r["success"] else "NO", r["start"] or "-",
                    r["iterations"] if r["success"] else "-",
                    nc.fmt(r["err_first"], "pct") if r["success"] else "-",
                    nc.fmt(r["err_last"], "pct") if r["success"] else "-",
                    r.get("nfev") if r["success"] and r.get("nfev") is not None else "-",
                    nc.fmt(r.get("dof_steps"), "g") if r["success"] else "-",
                    nc.fmt(r["time_median"], "f4") if r["success"] else "-",
                    nc.fmt(r["effort"], "f3") if r["success"] else "-",
                    nc.fmt(r.get("effort_cpu", r.get("effort_wall")), "f3") if r["success"] else "-",
                    (r.get("effort_ref_start") or "-") if r["success"] else "-",
                    "" if r["success"] else (r["message"] or "")[:160]))
    return nc.md_table(["method", "n_H", "converged", "start", "Newton it.", "err. mass 1", f"err. mass {n}",
                        "residual eval.", "DOF-steps", f"{CLOCK} time (s)", "effort", "effort (other clock)", "shooting start (effort ref.)",
                        "failure"], out)



def reference_table(cfg, S):
    """The reference and effort-reference solutions with their Floquet multipliers."""
    rows2 = []
    ex = S.get("exact") or {}
    if ex:
        rows2.append(("exact event-driven solution (mshbm.methods.exact)" + (" (error reference)" if S.get("error_reference") == "exact" else ""),
                      "yes" if ex.get("success") else "NO", "reference shooting", ex.get("iterations"),
                      nc.fmt(ex.get("amplitude_first"), "g"), nc.fmt(ex.get("amplitude_last"), "g"),
                      nc.fmt(ex.get("floquet_max_modulus"), "f6"), nc.fmt(ex.get("stick_or_closed_fraction"), "pct3"),
                      f"{ex['wall_time']:.3f} s" if ex.get("wall_time") else ""))
    reflabel = "error reference" if S.get("error_reference") != "exact" else "seed of the exact solution"
    for key, label in (("reference", f"full shooting, N = {cfg['numerics']['reference_steps']} ({reflabel})"),
                       ("shooting", f"full shooting, N = {cfg['numerics']['steps']} (effort reference)"),
                       ("shooting_fd", f"full shooting, N = {cfg['numerics']['steps']}, FD Jacobian"),
                       ("check", "check system (see Table footnote)")):
        m = S.get(key)
        if not m:
            continue
        rows2.append((label, "yes" if m["success"] else "NO", m.get("start_used"), m.get("iterations"),
                      nc.fmt(m.get("amplitude_first"), "g"), nc.fmt(m.get("amplitude_last"), "g"),
                      nc.stability_cell(m), nc.fmt(m.get("stick_or_closed_fraction"), "pct3"),
                      ", ".join(f"{k}: {v:.4f} s" for k, v in (m.get("wall_time_median_by_start") or {}).items() if v)))
    return (nc.md_table(["solution", "converged", "start", "Newton it.", "amp. mass 1", f"amp. mass n",
                                  "stability (max. Floquet modulus)", "stick fraction m1 / impulse",
                                  "median time by start"], rows2))


class WorkPrecision:
    """One work-precision figure (Fig. 4 or 8) from the run's configuration snapshot ``config`` and the
    figure's summary ``summary`` (JSON paths): what both notebooks show, in the order they show it."""

    def __init__(self, config, summary):
        nc.setup()
        self.cfg = nc.load_json(config)
        self.S = nc.load_json(summary)
        #: number of masses of the figure's chain
        self.n = self.cfg["systems"][self.S["system"]]["n"]
        #: the clock of the efforts (config ``timing.clock``)
        self.clock = self.S.get("clock", "wall")
        self.rows, self.fd_rows = [], []

    def claims(self):
        """Markdown table: the paper's claims next to our numbers."""
        return nc.claims_table(self.S)

    def plot(self, out_png, out_pdf):
        """The figure (error and effort against n_H), written to ``out_png`` and ``out_pdf``."""
        self.rows, self.fd_rows = plot(self.cfg, self.S, out_png, out_pdf)

    def points(self):
        """Markdown table of every point plotted (after :meth:`plot`)."""
        return points_table(self.rows + self.fd_rows, self.n, self.clock)

    def references(self):
        """Markdown table of the reference solutions and their stability."""
        return reference_table(self.cfg, self.S)
