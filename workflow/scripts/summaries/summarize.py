"""Aggregate the solve results of one figure into ``results/summary/<fig>.json``.

Cheap (reads JSON only): errors against the reference full-shooting solution, efforts
against full shooting at the working step count, impacts, stick fractions, Floquet
multipliers, and the paper's claims next to our numbers.  The figure notebooks, the
paper build and the regression tests read these files.

Inputs are given by the rule ``summary`` as named JSON files:
``ref`` (full shooting, reference steps), ``shooting`` (full shooting, working steps) and
``<method>_nh<n>`` for the other solves.
"""
import sys

from mshbm_workflow.summaries.common import system_numbers
from mshbm_workflow.summaries.phase import summarize_fig7
from mshbm_workflow.summaries.timeseries import summarize_timefigure
from mshbm_workflow.summaries.workprecision import summarize_sweep
from mshbm_workflow.wfcore import METHOD_LABELS, load_json, write_json


def main(fig, fcfg, inputs, out_path, clock="wall", scfg=None):
    res = {name: load_json(path) for name, path in inputs.items()}
    out_extra = {k: res[k] for k in ("longrun", "impact_time") if k in res}
    if fig in ("fig3", "fig5", "fig6"):
        out = summarize_timefigure(fig, fcfg, res)
    elif fig in ("fig4", "fig8"):
        out = summarize_sweep(fig, fcfg, res, clock)
    elif fig == "fig7":
        out = summarize_fig7(fcfg, res)
    else:
        raise ValueError(f"no summary for {fig}")
    out["labels"] = METHOD_LABELS
    if "longrun" in out_extra:  # what the system does from rest (figure panels, notebooks)
        out["longrun"] = {k: v for k, v in out_extra["longrun"].items() if k != "amplitude_first_all"}
    if "impact_time" in out_extra:
        out["impact_time"] = out_extra["impact_time"]
    if scfg is not None:
        out["numbers"].update({f"sys_{k}": v for k, v in system_numbers(scfg).items()})
    for key in ("hbm_harmonics", "mshbm_harmonics"):
        if key in fcfg:
            out["numbers"][key] = fcfg[key]
    if "harmonics" in fcfg:
        out["numbers"].update(nh_min=min(fcfg["harmonics"]), nh_max=max(fcfg["harmonics"]),
                              nh_list=", ".join(map(str, fcfg["harmonics"])))
    write_json(out_path, out)
    return out


if "snakemake" in globals():
    smk = snakemake  # noqa: F821
    with open(smk.log[0], "w") as logf:
        sys.stdout = logf
        named = {k: v for k, v in smk.input.items()}
        s = main(smk.wildcards.fig, smk.params.figure, named, smk.output[0], smk.params.clock, smk.params.system)
        for c in s["claims"]:
            print(f"{c['verdict']:>12}: {c['paper']} | ours: {c['ours']}")
