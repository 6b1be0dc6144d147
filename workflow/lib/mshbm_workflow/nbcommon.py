"""Plotting style and small readers shared by the figure/table notebooks (no solver logic).

The notebooks run with the repository root as working directory (the workflow starts them
there); opened from notebooks/ they step up one directory first.
"""
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

if not os.path.isdir("workflow") and os.path.isdir(os.path.join("..", "workflow")):
    os.chdir("..")
from mshbm_workflow import wfcore  # noqa: E402

COLORS = {"reference": "k", "shooting": "k", "mshbm": "#d62728", "hbm": "#1f77b4"}
LABELS = {"reference": "full shooting (reference)", "shooting": "full shooting", "mshbm": "MS-HBM",
          "hbm": "HBM"}
STYLES = {"reference": "-", "shooting": "-", "mshbm": "--", "hbm": "-"}


def setup():
    plt.rcParams.update({
        "figure.dpi": 110, "savefig.dpi": 150, "font.size": 9, "axes.titlesize": 9, "axes.labelsize": 9,
        "legend.fontsize": 8, "xtick.labelsize": 8, "ytick.labelsize": 8, "axes.grid": True,
        "grid.alpha": 0.3, "lines.linewidth": 1.2, "savefig.bbox": "tight",
        "svg.hashsalt": "mshbm", "pdf.fonttype": 42,
    })


def load_json(path):
    with open(path) as fh:
        return json.load(fh)


def load_npz(path):
    """Arrays of a converged solution, or ``None`` when the solve did not converge."""
    with np.load(path) as z:
        if not bool(z["valid"]):
            return None
        return {k: z[k] for k in z.files}


def save(fig, png, pdf):
    """Write the figure as PNG and PDF and show the PNG in the notebook (Agg draws nothing inline)."""
    os.makedirs(os.path.dirname(png) or ".", exist_ok=True)
    fig.savefig(png)
    fig.savefig(pdf, metadata={"CreationDate": None, "ModDate": None})
    plt.close(fig)
    try:
        from IPython.display import Image, display

        display(Image(filename=png))
    except ImportError:  # plain Python
        pass


def md_table(header, rows):
    """A Markdown table (``wfcore.md_table``) with the paper's symbols as math (``n_H`` -> $n_H$)."""
    from mshbm_workflow import mdrender

    return mdrender.notation(wfcore.md_table(header, rows))


def claims_table(summary):
    """Markdown table: the paper's claim, our measured numbers, verdict."""
    return md_table(["paper claims", "we measure", "verdict"],
                    [(c["paper"], c["ours"], f"**{c['verdict']}**") for c in summary["claims"]])


def fmt(value, f=None):
    return wfcore.format_value(value, f)


def start_text(start, factor=None):
    near = f"own solution at {factor:g} omega" if factor else "own solution at the nearby frequency"
    return {"linear": "linear response at omega, then Newton", "nearby": f"{near}, then Newton",
            None: "no converged solution"}.get(start, start)


def time_figure_solutions(cfg, S, npz):
    """Solutions and legend labels of a figure comparing shooting, MS-HBM and HBM in time (Figs. 5, 6).

    Returns ``(scfg, sol, label)``: the system's config, ``{method: arrays or None}`` (None: the
    solve did not converge, never drawn) and ``{method: legend label}``.
    """
    nh_hbm, nh_ms = S["hbm_harmonics"], S["mshbm_harmonics"]
    scfg = cfg["systems"][S["system"]]
    sol = {"shooting": load_npz(npz["shooting"]), "mshbm": load_npz(npz[f"mshbm_nh{nh_ms}"]),
           "hbm": load_npz(npz[f"hbm_nh{nh_hbm}"])}
    label = {"shooting": f"full shooting (N = {cfg['numerics']['steps']})", "mshbm": f"MS-HBM, $n_H$ = {nh_ms}",
             "hbm": f"HBM, $n_H$ = {nh_hbm}, $k_c$ = {scfg['contact']['penalty_stiffness']:g}"}
    return scfg, sol, label


def stability_short(num, prefix="reference"):
    """Stability of an orbit for a figure title, from summary numbers (mshbm.stability via the solve JSON)."""
    word = num.get(f"{prefix}_stability_word")
    if word is None:
        return "stability not assessed"
    if word == "undecided":
        return "stability undecided"
    rho = num.get(f"{prefix}_floquet")
    return f"{word}: dominant Floquet multiplier {num.get(f'{prefix}_mu')} (|μ| = {rho:.4f})"


def stability_cell(m):
    """Stability of one solve result for a table cell: verdict and largest multiplier modulus."""
    if not m.get("success"):
        return "-"
    st, rho = m.get("stable"), m.get("floquet_max_modulus")
    word = {True: "stable", False: "UNSTABLE", None: "undecided"}[st]
    return f"{word} ({rho:.4f})" if rho is not None else word


def longrun_table(S):
    """What the system does next to its periodic orbit: the long simulation from rest (rule longrun)."""
    lr = S.get("longrun")
    if not lr:
        return "(no long simulation for this figure)"
    per = lr["response_period"]
    rows = [("simulated", f"{lr['periods']} periods from rest (q = u = 0 at t = 0), exact event-driven flow"),
            ("response", f"period {per} T" if per else
             f"not periodic within {lr['periods']} periods (end states of the last {lr['tail']} periods repeat "
             f"after no p <= 8)"),
            ("amplitude of mass 1 in the last periods (exact flow)",
             ", ".join(f"{a:.4f}" for a in lr["amplitude_first_last"])),
            (f"the same, Moreau–Jean (N = {lr['moreau_jean']['steps']})",
             ", ".join(f"{a:.4f}" for a in lr["moreau_jean"]["amplitude_first_last"])),
            ("impacts per period (last periods)", ", ".join(map(str, lr["impacts_per_period_last"]))),
            ("impact times mod T, u1 before (last periods)",
             "; ".join(", ".join(f"{i['t_mod_T']:.3f} s ({i['u_before']:.3f} m/s)" for i in imps) or "none"
                       for imps in lr["impacts_last"]))]
    if not per:
        lo, hi = lr["amplitude_first_tail_range"]
        rows.append((f"range of the mass-1 amplitude over the last {lr['tail']} periods", f"{lo:.4f} – {hi:.4f}"))
    orb = lr.get("response_orbit")
    if orb and orb.get("success"):
        dom = orb["dominant_multiplier"]
        rows.append((f"the {per}T-periodic orbit (exact shooting on the {per}T map)",
                     f"{'stable' if orb['stable'] else 'unstable' if orb['stable'] is False else 'undecided'}, "
                     f"largest multiplier modulus {orb['max_modulus']:.4f} (dominant {dom[0]:.4f}{dom[1]:+.4f}i), amplitude of "
                     f"mass 1 over {per}T {orb['amplitude_first']:.4f}"))
    return md_table(["", "long simulation from rest"], rows)
