"""Plotting style and small readers shared by the figure/table notebooks (no solver logic).

The notebooks run with the repository root as working directory (the workflow starts them
there); opened from notebooks/ they step up one directory first.
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

if not os.path.isdir("workflow") and os.path.isdir(os.path.join("..", "workflow")):
    os.chdir("..")
sys.path.insert(0, os.path.join("workflow", "scripts"))
import wfcore  # noqa: E402

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
    import mdrender

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
