"""workflow/manifest.yaml, figure -> rules -> notebook -> method modules: valid, complete, true and
shown in README.md.  (The workflow itself reads it: tests/integration/test_workflow.py runs the notebooks it lists.)"""
import importlib.util
import re

import pytest
from workflow_run import ROOT

from mshbm_workflow import script_module  # noqa: E402

manifest_table = script_module("paper", "manifest_table")

MANIFEST = manifest_table.load()


def test_manifest_matches_its_schema():
    from snakemake.utils import validate

    validate(MANIFEST, str(ROOT / "workflow" / "schemas" / "manifest.schema.yaml"))


def test_readme_shows_the_manifest():
    shown = manifest_table.readme_table((ROOT / "README.md").read_text(encoding="utf-8"))
    assert shown == manifest_table.table(MANIFEST), "python workflow/scripts/paper/manifest_table.py --write"
    assert "## Where each figure comes from" in (ROOT / "README.md").read_text(encoding="utf-8")


def test_every_figure_and_table_of_the_paper_is_listed():
    paper = (ROOT / "paper" / "paper.md").read_text(encoding="utf-8")
    used = set(re.findall(r"\]\(figures/(fig\d+)\.png\)|\{\{include:(table\d+)\}\}", paper))
    names = {a or b for a, b in used}
    assert {f"fig{i}" for i in range(1, 9)} | {"table1", "table2"} <= set(MANIFEST)
    assert names == set(MANIFEST), set(MANIFEST) ^ names  # every listed figure and table is in the paper


@pytest.mark.parametrize("name", list(MANIFEST))
def test_notebook_rules_and_modules_exist(name):
    entry = MANIFEST[name]
    assert (ROOT / "notebooks" / f"{name}.py").is_file()
    rules = (ROOT / "workflow" / "rules").glob("*.smk")
    defined = set(re.findall(r"^\s*rule (\w+):", "\n".join(p.read_text() for p in rules), re.M))
    assert set(entry["rules"]) <= defined, set(entry["rules"]) - defined
    for module in entry["methods"]:
        assert (ROOT / manifest_table.module_path(module)).is_file(), module
        assert importlib.util.find_spec(module) is not None, module
