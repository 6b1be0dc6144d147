"""Tables 1 and 2 (the paper's parameters next to the values used here), shared by the
table1/table2 notebooks: one function builds either table from the configuration.  No solver
logic; the numbers in footnotes are placeholders filled from the figure summaries.
"""
import csv
import math
import os

from mshbm_workflow import nbcommon as nc


def g(x):
    """A parameter value as text (integral floats without the decimal point)."""
    if isinstance(x, float) and x.is_integer():
        return str(int(x))
    return f"{x:g}" if isinstance(x, (int, float)) else str(x)


def parameter_table(cfg, table, fill):
    """``(header, rows, footnotes)`` of Table ``table`` (1: friction, 2: impact).

    ``fill`` fills the placeholders of the footnotes (``wfcore.fill_placeholders`` with the
    figure summaries).
    """
    F = cfg["figures"]
    if table == 1:
        systems = [("Fig. 3", F["fig3"]["system"]), ("Fig. 4", F["fig4"]["system"])]
    else:
        systems = [("Figs. 5–6", F["fig5"]["system"]), ("Figs. 7–8", F["fig8"]["system"])]
    systems = [(label, name, cfg["systems"][name]) for label, name in systems]
    choices = [c for c in cfg["choices"] if c["table"] in (table, "both")]
    keys = {c["key"] for c in choices}
    marks = {}  # footnote letters in order of first mention in the table

    def mark(key):
        if key not in marks:
            marks[key] = chr(ord("a") + len(marks))
        return marks[key]

    def used(fn):
        vals = [(label, fn(s)) for label, _, s in systems]
        if len({g(v) for _, v in vals}) == 1:
            return g(vals[0][1])
        return "; ".join(f"{g(v)} ({label})" for label, v in vals)

    def note(key):
        return f"chosen [{mark(key)}]" if key in keys else ""


    w = cfg["omega_over_pi"]
    num = cfg["numerics"]
    frac = f"{w:g}\\pi" if w != 0.2 else "\\pi/5"
    rows = [("number of masses", "$n$", "3 (Fig. 3), 30 (Fig. 4)" if table == 1 else "5 (Figs. 5–6), 50 (Figs. 7–8)",
             "; ".join(f"{s['n']} ({label})" for label, _, s in systems), "")]
    if table == 1:
        rows += [
            ("masses", "$m_i$", "1", used(lambda s: s["mass_other"]), ""),
            ("spring stiffnesses", "$k_i$", "1", used(lambda s: s["stiffness"]), ""),
            ("damping", "$c_i$", "0", used(lambda s: s["damping"]), ""),
            ("friction coefficient", "$\\mu$", "0.8", used(lambda s: s["friction"]["mu"]), ""),
            ("normal force", "$F_N$", "not given", used(lambda s: s["friction"]["normal_force"]),
             ", ".join(note(f"systems.{n}.friction.normal_force") for _, n, _ in systems
                       if f"systems.{n}.friction.normal_force" in keys)),
            ("arctan smoothing (HBM, eq. 42)", "$\\kappa$", "800 (Fig. 3)", used(lambda s: s["friction"]["kappa"]),
             note(f"systems.{systems[0][1]}.friction.kappa")),
        ]
    else:
        rows += [
            ("mass 1", "$m_1$", "10", used(lambda s: s["mass_first"]), ""),
            ("masses 2 to n", "$m_i$", "1", used(lambda s: s["mass_other"]), ""),
            ("spring stiffnesses", "$k_i$", "1", used(lambda s: s["stiffness"]), ""),
            ("damping", "$c_i$", "0.3", used(lambda s: s["damping"]), ""),
            ("penalty stiffness (HBM, eq. 45)", "$k_c$", "8000", used(lambda s: s["contact"]["penalty_stiffness"]), ""),
            ("penalty damping (HBM, eq. 45)", "$d_c$", "0 (text)", used(lambda s: s["contact"]["penalty_damping"]),
             note(f"systems.{systems[0][1]}.contact.penalty_damping")),
            ("restitution", "$e_N$", "1", used(lambda s: s["contact"]["restitution"]), ""),
            ("contact gap", "$g_{N,0}$", "0.1 (text, Fig. 5)", used(lambda s: s["contact"]["gap"]),
             note(f"systems.{systems[0][1]}.contact.gap")),
        ]
    rows += [
        ("forcing frequency", "$\\omega$", "$\\pi/5$", f"${frac}$ = {math.pi * w:.6f} rad/s", ""),
        ("forcing on the last mass", "$f_{ex,n}$", "$5\\cos(\\omega t)$",
         used(lambda s: f"${g(s['forcing_amplitude'])}\\cos(\\omega t)$"), ""),
        ("chain support, dampers", "", "Fig. 1", "wall – $k_1$ – $m_1$ – … – $m_n$ free; $c_i$ parallel to $k_i$", note("chain_support")),
    ]
    if table == 1:
        rows += [("harmonics, Fig. 3 (HBM / MS-HBM)", "$n_H$", "20 / 3", f"{F['fig3']['hbm_harmonics']} / {F['fig3']['mshbm_harmonics']}", ""),
                 ("harmonics, Fig. 4", "$n_H$", "1, 3, …, 25", ", ".join(map(str, F["fig4"]["harmonics"])), "")]
    else:
        rows += [("harmonics, Figs. 5–6 (HBM / MS-HBM)", "$n_H$", "not given", f"{F['fig5']['hbm_harmonics']} / {F['fig5']['mshbm_harmonics']}",
                  note("figures.fig5.hbm_harmonics")),
                 ("harmonics, Fig. 7", "$n_H$", "3, 9", ", ".join(map(str, F["fig7"]["harmonics"])), ""),
                 ("harmonics, Fig. 8", "$n_H$", "not given", ", ".join(map(str, F["fig8"]["harmonics"])), "as Fig. 4")]
    rows += [
        ("Moreau–Jean steps per period (shooting, MS-HBM)", "$N$", "not given", f"{num['steps']}, $\\theta$ = {g(num['theta'])}", note("numerics.steps")),
        ("reference full shooting", "$N_\\mathrm{ref}$", "not given", f"{num['reference_steps']}", note("numerics.reference_steps")),
        ("AFT samples (HBM)", "$N_s$", "not given",
         "$\\max(512, 16(2n_H+1))$, rounded up to $2^k$" if num["hbm_samples"] == "auto" else g(num["hbm_samples"]), note("numerics.hbm_samples")),
        ("start of Figs. 4/8 solves", "", "nearby frequency", f"{g(cfg['starts']['nearby_factor'])} $\\omega$", note("starts.nearby_factor")),
        ("Newton tolerance", "", "not given", f"{num['tol']:g}", note("numerics.tol")),
        ("effort measure", "", "not given", f"median {cfg['timing']['clock']} time of {cfg['timing']['repeats']} solves "
         f"after {cfg['timing']['warmup']} warm-up, relative to full shooting", note("timing.clock")),
        ("Jacobian", "", "finite differences", num["jacobian"] + (" (step sensitivities)" if num["jacobian"] == "exact" else ""),
         note("numerics.jacobian") + ("; same solution, fewer residual evaluations" if num["jacobian"] == "exact" else "")),
    ]
    header = ["parameter", "symbol", "paper", "used here", "note"]
    for c in choices:  # choices the rows do not mention get the last letters
        mark(c["key"])
    foot = [f"[{marks[c['key']]}] {c['what'][:1].upper() + c['what'][1:]}: {fill(' '.join(c['why'].split()))}"
            for c in sorted(choices, key=lambda c: marks[c["key"]])]
    return header, rows, foot


def build(config, summaries, table, out_md, out_csv):
    """Table ``table`` from the config snapshot and the figure summaries (JSON paths): writes the
    Markdown and CSV files and returns the Markdown."""
    cfg = nc.load_json(config)
    context = {"config": cfg}
    for path in summaries:
        s = nc.load_json(path)
        context[s["figure"]] = s["numbers"]
    header, rows, foot = parameter_table(cfg, table, lambda text: nc.wfcore.fill_placeholders(text, context))
    return write_table(header, rows, foot, out_md, out_csv)


def write_table(header, rows, foot, out_md, out_csv):
    """Write the table as Markdown (with footnotes) and CSV; returns the Markdown."""
    md = nc.md_table(header, rows) + "\n\n" + "\n\n".join(foot) + "\n"
    os.makedirs(os.path.dirname(out_md), exist_ok=True)
    with open(out_md, "w") as fh:
        fh.write(md)
    with open(out_csv, "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(header)
        wr.writerows(rows)
        for f in foot:
            wr.writerow(["footnote", "", "", "", f])
    return md
