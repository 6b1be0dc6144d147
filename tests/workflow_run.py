"""Running the workflow from the tests: a temporary copy of its files, Snakemake as a subprocess.

The quick workflow (workflow/config-quick.yaml) runs once per test session (fixture ``quick_run``
in conftest.py), in a temporary copy of the workflow files (workflow/ with its Snakefile, notebooks/,
paper/, examples/), so it never touches results/ or .snakemake/ of the working tree.  Snakemake runs
from the copy's root and finds workflow/Snakefile there, as it does in the repository.
"""
import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SNAKEMAKE = [sys.executable, "-m", "snakemake"]
WORKFLOW_FILES = ["workflow", "notebooks", "paper", "examples"]
QUICK = ["--configfile", "workflow/config-quick.yaml"]
#: the paper's outputs (rule `all` may also hold targets of other rule files, e.g. the stress suite)
TARGET = ["reproduction"]


def load_script(relpath):
    """The workflow script ``workflow/scripts/<relpath>`` (e.g. ``"fe/build_fe_model.py"``) as a module, to call
    its functions (its ``main(argv)`` as ``workflow/scripts/cli_job.py`` runs it)."""
    path = ROOT / "workflow" / "scripts" / relpath
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def copy_workflow(dst):
    ignore = shutil.ignore_patterns("__pycache__", ".ipynb_checkpoints", "results", ".snakemake")
    for name in WORKFLOW_FILES:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dst / name, ignore=ignore)
        else:
            shutil.copy2(src, dst / name)
    return dst


def run(args, cwd, timeout=600):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run(SNAKEMAKE + args, cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env)


def reference_failures(summary_dir, figures=None):
    """Differences of the summaries in ``summary_dir`` from tests/reference/quick.json (tolerances per
    quantity, see tests/reference/README.md), for all figures of the reference or only ``figures``."""
    ref = json.loads((ROOT / "tests" / "reference" / "quick.json").read_text())
    failures = []
    for item in ref["values"]:
        if figures is not None and item["figure"] not in figures:
            continue
        summary = json.loads((Path(summary_dir) / f"{item['figure']}.json").read_text())["numbers"]
        if item["key"] not in summary:
            failures.append(f"{item['figure']}.{item['key']}: missing")
            continue
        got, want = summary[item["key"]], item["value"]
        if item["kind"] == "exact" or want is None or got is None or isinstance(want, (bool, str)):
            ok = got == want
        else:
            ok = math.isclose(got, want, rel_tol=item["rtol"], abs_tol=item["atol"])
        if not ok:
            failures.append(f"{item['figure']}.{item['key']}: got {got!r}, reference {want!r} "
                            f"(rtol {item['rtol']}, atol {item['atol']})")
    return failures
