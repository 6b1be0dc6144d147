"""Running the workflow from the tests: a temporary copy of its files, Snakemake as a subprocess.

The quick workflow (workflow/config-quick.yaml) runs once per test session (fixture ``quick_run``
in conftest.py), in a temporary copy of the workflow files (Snakefile, workflow/, notebooks/,
paper/, examples/), so it never touches results/ or .snakemake/ of the working tree.
"""
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SNAKEMAKE = [sys.executable, "-m", "snakemake"]
WORKFLOW_FILES = ["Snakefile", "workflow", "notebooks", "paper", "examples"]
QUICK = ["--configfile", "workflow/config-quick.yaml"]
#: the paper's outputs (rule `all` may also hold targets of other rule files, e.g. the stress suite)
TARGET = ["reproduction"]


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
