# Helpers shared by the rule files; included first by workflow/Snakefile.
# All functions of the workflow live here, the other files hold rules only.
import hashlib
import importlib.util
import os
import sys

import yaml

from mshbm_workflow import wfcore

# Benchmarks (`benchmark:`, results/logs/times/): only the rules whose jobs run for more than a few seconds.  Snakemake
# samples a benchmarked job's process tree every 0.5 s for its first 15 s, in the main Snakemake process, scanning
# every process of the machine for the job's children each time (a few ms of CPU per sample; in a profile of a
# short run, a quarter of the main process's CPU).  The short jobs (solves, notebooks, figure summaries, the
# snapshot) have none; a solve records its own wall and CPU times in its JSON.

# Priorities: among the jobs that are ready, Snakemake starts those of higher `priority:` first.  The long jobs
# (finite-element curves and their models, the damper's and the backbones' curves, the stand-alone benchmarks,
# the accuracy suite, the long simulations) and the configuration snapshot most of them read have priorities
# 1-5, so that on a few cores they run next to the many short solves and notebooks instead of after them (the
# quick run's finite-element curve used to start last and end it alone).
#: the workflow's libraries (the package mshbm_workflow); rules name the modules they use as inputs
WF_LIB = "workflow/lib/mshbm_workflow"

# the systems are defined by their case files (examples/*.yaml); fill in their parameters once
wfcore.resolve_systems(config)
R = config["results_dir"].rstrip("/")
NUMERICS = config["numerics"]
#: figure/table -> rules -> notebook -> method modules (workflow/manifest.yaml, rendered in README.md)
with open("workflow/manifest.yaml", encoding="utf-8") as _fh:
    MANIFEST = yaml.safe_load(_fh)
validate(MANIFEST, "../schemas/manifest.schema.yaml")
#: one notebook notebooks/<name>.py per figure and table (rule `notebook`)
NOTEBOOKS = list(MANIFEST)
FIGURES = [n for n in NOTEBOOKS if n.startswith("fig")]
TABLES = [n for n in NOTEBOOKS if n.startswith("table")]
#: figures whose data come from solves (summary rule)
SUMMARIZED = [n for n in NOTEBOOKS if "summary" in MANIFEST[n]["data"]]


def _check_config():
    """Consistency checks the JSON schema cannot express."""
    problems = []
    for fig in SUMMARIZED:
        fcfg = config["figures"][fig]
        for key in ("system", "check_system"):
            if key in fcfg and fcfg[key] not in config["systems"]:
                problems.append(f"figures.{fig}.{key}: unknown system {fcfg[key]!r}")
    if NUMERICS["reference_steps"] == NUMERICS["steps"]:
        problems.append("numerics.reference_steps must differ from numerics.steps "
                        "(the reference is untimed, full shooting at `steps` is the timed effort reference)")
    f7, f8 = config["figures"]["fig7"], config["figures"]["fig8"]
    if f7["system"] != f8["system"] or not set(f7["harmonics"]) <= set(f8["harmonics"]):
        problems.append("figures.fig7 must use the system of fig8 and a subset of its harmonics "
                        "(Fig. 7 shows solutions of the Fig. 8 sweep)")
    for fig in ("fig5", "fig6"):
        if config["figures"][fig] != config["figures"]["fig5" if fig == "fig6" else "fig6"]:
            problems.append("figures.fig5 and figures.fig6 must be equal (one set of solves)")
            break
    for fig in ("fig4", "fig8"):
        if not config["systems"][config["figures"][fig]["system"]]["timed"]:
            problems.append(f"the system of figures.{fig} must be timed (work-precision diagram)")
    if problems:
        joined = "\n  ".join(problems)
        raise ValueError(f"invalid configuration:\n  {joined}")


_check_config()


def _solver_digest():
    """Digest of the source of the installed solver package (without importing it).

    The workflow's one way of tracking solver changes: every rule whose script runs the solver (solve,
    exact_reference, longrun, impact_time, intermediate_demo, stress, the benchmarks) has the parameter
    ``solver=SOLVER_DIGEST``, and Snakemake reruns a job whose parameters changed.  A change of the
    solver reruns those jobs, a touched but unchanged file does not."""
    spec = importlib.util.find_spec("mshbm")
    h = hashlib.sha256()
    for path in sorted(Path(spec.origin).parent.rglob("*.py")):
        h.update(path.relative_to(Path(spec.origin).parent).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


SOLVER_DIGEST = _solver_digest()


def solve_file(case, method, nh=None, reference=False, ext="json"):
    """Result file of one solve (see rule `solve`)."""
    stem = wfcore.solve_stem(config, case, method, nh, reference)
    return f"{stem}.{ext}"


#: the harmonic methods of the work-precision figures (Figs. 4, 8), each at every n_H of the figure
SWEEP_METHODS = ("hbm", "mshbm", "dlft")


def figure_solves(fig, ext="json"):
    """Named solve results a figure needs: ref, shooting, <method>_nh<n>."""
    fcfg = config["figures"][fig]
    case = fcfg["system"]
    out = {"ref": solve_file(case, "shooting", reference=True, ext=ext),
           "shooting": solve_file(case, "shooting", ext=ext)}
    if fcfg.get("check_system"):
        out["check"] = solve_file(fcfg["check_system"], "shooting", ext=ext)
    if "harmonics" in fcfg:
        for method in SWEEP_METHODS:
            for nh in fcfg["harmonics"]:
                out[f"{method}_nh{nh}"] = solve_file(case, method, nh, ext=ext)
        if fcfg.get("fd_harmonics"):
            out["shooting-fd"] = solve_file(case, "shooting-fd", ext=ext)
            for nh in fcfg["fd_harmonics"]:
                out[f"mshbm-fd_nh{nh}"] = solve_file(case, "mshbm-fd", nh, ext=ext)
    else:
        out[f"hbm_nh{fcfg['hbm_harmonics']}"] = solve_file(case, "hbm", fcfg["hbm_harmonics"], ext=ext)
        out[f"mshbm_nh{fcfg['mshbm_harmonics']}"] = solve_file(case, "mshbm", fcfg["mshbm_harmonics"], ext=ext)
    return out


#: figures whose solutions are compared with the exact event-driven periodic solution (see exact_reference);
#: Figs. 4 and 8 measure their errors against it, Fig. 7 takes its impact sequence from it
EXACT_FIGURES = ["fig4", "fig7", "fig8"]


def exact_file(case):
    """Exact event-driven periodic solution of a system (rule ``exact_reference``)."""
    return f"{R}/solves/{case}/exact.json"


#: the frequency-response curves of Fig. 9 by name (rules/branches.smk; config `branches` is a list, so
#: that a second config file replaces it whole)
BRANCHES = {b["name"]: b for b in config.get("branches") or []}


def branch_files():
    """Every branch job's output (rule `branch`)."""
    return [f"{R}/branches/{name}/{method}.json" for name, b in BRANCHES.items() for method in b["methods"]]


#: summaries beyond the figures' (other rule files append theirs); the paper reads every one
EXTRA_SUMMARIES = []


#: systems of the impact figures whose long simulations from rest are shown next to their periodic orbits
LONGRUN_CASES = sorted({config["figures"][f]["system"] for f in ("fig5", "fig6", "fig7")})
#: figures whose summaries read the long simulation of their system (rule longrun)
LONGRUN_FIGS = ["fig5", "fig6", "fig7"]


def longrun_file(case, ext="json"):
    return f"{R}/longrun/{case}.{ext}"


def summary_inputs(fig):
    """Named inputs of the summary rule: the figure's solves, where used the exact reference (Figs. 4, 7, 8),
    and the long simulation of its system (impact figures 5-7)."""
    out = figure_solves(fig)
    if fig in EXACT_FIGURES:
        out["exact"] = exact_file(config["figures"][fig]["system"])
    if fig in LONGRUN_FIGS:
        out["longrun"] = longrun_file(config["figures"][fig]["system"])
    if fig == "fig6":
        out["impact_time"] = f"{R}/longrun/impact_time_{config['figures']['fig6']['system']}.json"
    return out


def notebook_outputs(name):
    """Outputs of the notebook job of a figure (rule notebook) or a table (rule notebook_table)."""
    outs = {"nb": f"{R}/notebooks/{name}.ipynb", "html": f"{R}/notebooks/{name}.html"}
    if name in FIGURES:
        outs.update(png=f"{R}/figures/{name}.png", pdf=f"{R}/figures/{name}.pdf")
    else:
        outs.update(md=f"{R}/tables/{name}.md", csv=f"{R}/tables/{name}.csv")
    return outs


# ----------------------------------------------------------------------------- benchmarks
#: the `benchmarks` section of the config (None: no benchmarks, no Performance section)
BENCH = config.get("benchmarks")
#: the interpreter running Snakemake (the one with mshbm installed), not whatever `python` is on PATH:
#: rule pyharm_env builds pyHarm's venv with it
BENCH_PY = sys.executable


#: pyHarm's own virtual environment, built by rule pyharm_env from workflow/envs/pyharm.txt and reused by
#: later runs; $PYHARM_PYTHON (an interpreter that imports pyHarm) overrides it and skips the rule
PYHARM_ENV = "envs/pyharm"
PYHARM_PYTHON = os.environ.get("PYHARM_PYTHON")
#: the stand-alone benchmarks that run in pyHarm's environment (scripts/bench/bench_<name>.py re-run themselves there)
PYHARM_BENCHES = ("pyharm", "pyharm_sweep")


def bench_inputs(w):
    """Extra inputs of a stand-alone benchmark: pyHarm's environment and the library pyharmlib for `pyharm` and
    `pyharm_sweep`."""
    inputs = {}
    if w.bench in PYHARM_BENCHES:
        inputs["pyharmlib"] = f"{WF_LIB}/pyharmlib.py"  # their shared pyHarm plumbing
    if w.bench in PYHARM_BENCHES and not PYHARM_PYTHON:
        inputs["pyharm_env"] = f"{PYHARM_ENV}/installed.txt"
    if w.bench == "pyharm_sweep":  # its branches are the config's (`branches` friction3, impact5)
        inputs["config"] = f"{R}/config.json"
    return inputs


def bench_args(w):
    """Extra arguments of a stand-alone benchmark script (the interpreter with pyHarm)."""
    args = []
    if w.bench in PYHARM_BENCHES:
        args += ["--pyharm-python", PYHARM_PYTHON or os.path.join(PYHARM_ENV, "bin", "python")]
    if w.bench == "pyharm_sweep":
        args += ["--config", f"{R}/config.json"]
    if w.bench == "scaling":
        grid = BENCH.get("full", {}) if w.bdir == "benchmarks-full" else BENCH
        args += [f"--max-n={m}={n}" for m, n in (grid.get("scaling_max_n") or {}).items()]
    return args


def bench_profile(w):
    """Profile of the stand-alone benchmark scripts for an output directory (rule bench_standalone)."""
    return "full" if w.bdir == "benchmarks-full" else BENCH.get("profile", "default")


#: rule files added later may append their final outputs here to make them part of `rule all`
EXTRA_TARGETS = []


def reproduction_targets():
    """The paper, every figure, table and rendered notebook."""
    out = [f"{R}/paper/paper.html"]
    for name in NOTEBOOKS:
        out += list(notebook_outputs(name).values())
    return out


def all_targets():
    return reproduction_targets() + EXTRA_TARGETS


# ----------------------------------------------------------------------------- solves
def _is_reference(w):
    return wfcore.split_method(w.method)[0] == "shooting" and int(w.steps) == NUMERICS["reference_steps"]


def solve_inputs(w):
    """The system's case file; for HBM, which is restarted from these converged solutions when it fails
    from every start (display only), the fallback solutions."""
    scfg = config["systems"][w.case]
    if w.method != "hbm":
        return {"case": scfg["case"]}
    return {"case": scfg["case"],
            "fallback": [solve_file(w.case, m, int(w.nh), ext="npz") for m in scfg["hbm_fallback"]]}


def solve_params(w):
    """Exactly the configuration a solve depends on (a change reruns only the affected solves)."""
    scfg = config["systems"][w.case]
    reference = _is_reference(w)
    numerics = {k: NUMERICS[k] for k in ("tol", "max_iter")}
    base, jac = wfcore.split_method(w.method)
    if base != "hbm":
        numerics.update(theta=NUMERICS["theta"], jacobian=jac or NUMERICS["jacobian"])
    cfg = {"omega_over_pi": config["omega_over_pi"], "numerics": numerics,
           "systems": {w.case: scfg}, "starts": config["starts"],
           "timing": {k: config["timing"][k] for k in ("warmup", "repeats")}}
    if "nearby" not in scfg["starts"]:
        cfg["starts"] = {}
    if not scfg["timed"] or reference:
        cfg["timing"] = {}
    return cfg


# ----------------------------------------------------------------------------- notebooks
#: code the notebooks import (a change reruns the notebooks); not passed as a parameter
NB_HELPERS = [f"{WF_LIB}/{name}.py" for name in ("nbcommon", "tables", "wpcommon", "wfcore",
                                                   # the HTML rendering (markdown, math, offline template)
                                                   "mdrender", "nbexport")] + ["workflow/templates/offline/index.html.j2"]


def npz_inputs(fig):
    return {f"npz_{k}": v for k, v in figure_solves(fig, ext="npz").items()}


def notebook_inputs(name):
    """The data inputs of a notebook job as declared in workflow/manifest.yaml (`data`)."""
    data = MANIFEST[name]["data"]
    out = {}
    if "summaries" in data:
        out["summaries"] = expand(f"{R}/summary/{{fig}}.json", fig=SUMMARIZED)
    if "summary" in data:
        out["summary"] = f"{R}/summary/{name}.json"
    if "npz" in data:
        out.update(npz_inputs(name))
    if "longrun" in data:
        out["npz_longrun"] = longrun_file(config["figures"][name]["system"], "npz")
    if "branches" in data:
        out["summary"] = f"{R}/summary/branches.json"
    if "fe" in data:
        out["summary"] = f"{R}/summary/fe.json"
    if "backbone" in data:
        out["summary"] = f"{R}/summary/backbone.json"
    if "upd" in data:
        out["summary"] = f"{R}/summary/upd.json"
    return out


# ----------------------------------------------------------------------------- finite-element example
def fe_model_argv(w, output):
    """Command line of build_fe_model.py for mesh `w.mesh` of config `fe_example` (rule fe_model)."""
    FE = config["fe_example"]
    mesh = FE["meshes"][w.mesh]
    argv = [os.path.dirname(output.case), "--model", FE["model"], "--n-el", str(mesh["n_el"]),
            "--ny", str(mesh.get("ny", 1)), "--case", os.path.basename(output.case)]
    if FE["bodies"]:
        argv.append("--bodies")
    if FE.get("reduce_modes") is not None:
        argv += ["--reduce", str(FE["reduce_modes"])]
    for key in ("body_freq_ratio", "body_mass_ratio", "width", "gap_ratio", "friction_ratio", "zeta"):
        if key in FE:
            argv += ["--set", f"{key}={FE[key]}"]
    argv += ["--set", f"steps={FE['steps']}", "--set", f"harmonics={FE['harmonics']}"]
    return argv
