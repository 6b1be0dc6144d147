"""The manuscript's conditionals (workflow/scripts/paper/build_paper.py): one pass, no nesting.  A nested
``<!-- if -->`` used to leave its markers in the rendered paper; the build now fails and says why."""
import json
from pathlib import Path

import pytest

from mshbm_workflow import script_module

ROOT = Path(__file__).resolve().parents[2]
build_paper = script_module("paper", "build_paper")


def _build(tmp_path, body):
    (tmp_path / "summary").mkdir()
    (tmp_path / "config.json").write_text(json.dumps({"choices": []}))
    (tmp_path / "summary" / "s.json").write_text(json.dumps({"numbers": {"x": 2, "ok": True}}))
    md = tmp_path / "paper.md"
    md.write_text("# Title\n\n" + body + "\n")
    out = tmp_path / "paper.html"
    build_paper.build(str(md), str(tmp_path), str(out), str(tmp_path / "filled.md"), bench_md="")
    return (tmp_path / "filled.md").read_text()


def test_flat_conditionals_fill(tmp_path):
    text = _build(tmp_path, 'A <!-- if: s["ok"] -->x is {{s.x}}<!-- else -->no<!-- endif --> B '
                            '<!-- if: s["x"] > 5 -->big<!-- endif -->.')
    assert "x is 2" in text and "no" not in text and "big" not in text and "<!--" not in text


def test_a_nested_conditional_fails_the_build(tmp_path):
    with pytest.raises(ValueError, match="nested"):
        _build(tmp_path, '<!-- if: s["ok"] -->outer <!-- if: s["x"] > 1 -->inner<!-- endif --> rest<!-- endif -->')
