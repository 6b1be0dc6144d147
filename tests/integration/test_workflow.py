"""The Snakemake workflow: lint, dry run of the full workflow, the quick workflow end to end.

The quick workflow (workflow/config-quick.yaml) runs in a temporary copy of the workflow files
(workflow/, notebooks/, paper/), so it never touches results/ or .snakemake/ of the
working tree.  Its summaries are compared with tests/reference/quick.json (tolerances per
quantity, see tests/reference/README.md); wall times are never asserted.
"""
import json
import re

import pytest
from workflow_run import QUICK, ROOT, TARGET, copy_workflow, reference_failures, run

FIGURES = [f"fig{i}" for i in range(1, 13)]  # Figs. 1-8 of the paper, Fig. 9 (frequency-response curves), Fig. 10 (FE example), Fig. 11 (backbones), Fig. 12 (underplatform damper)
TABLES = ["table1", "table2"]
#: the one lint we accept: the software environment is the pinned venv (environment.txt), not conda
ACCEPTED_LINT = "Specify a conda environment or container for each rule."

# fixtures `workdir` (a temporary copy of the workflow) and `quick_run` (the quick workflow, run once
# per session and shared with tests/integration/test_render.py): tests/conftest.py


def test_every_notebook_source_is_a_parameterised_percent_notebook():
    """notebooks/<name>.py is the only source of a figure's notebook (jupytext percent format, converted
    by the notebook rule at run time) with one papermill parameters cell
    that declares the configuration and the figure's or table's outputs."""
    import jupytext

    for name in FIGURES + TABLES:
        nb = jupytext.read(ROOT / "notebooks" / f"{name}.py", fmt="py:percent")
        tagged = [c for c in nb.cells if "parameters" in c.metadata.get("tags", [])]
        assert len(tagged) == 1 and tagged[0].cell_type == "code", name
        outs = ("out_png", "out_pdf") if name in FIGURES else ("out_md", "out_csv")
        for param in ("config",) + outs:
            assert re.search(rf"^{param} = ", tagged[0].source, re.M), (name, param)
        assert nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# "), name


def test_lint(workdir):
    proc = run(["--lint"], workdir, timeout=120)
    out = proc.stdout + proc.stderr
    assert "Traceback" not in out, out[-3000:]
    titles = re.findall(r"^\s+\* (.+?):\s*$", out, re.M)
    unexpected = [t for t in titles if t != ACCEPTED_LINT]
    assert not unexpected, out[-5000:]


def test_dry_run_of_the_full_workflow(workdir):
    proc = run(["-n", "--cores", "2"], workdir, timeout=120)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = proc.stdout + proc.stderr
    for name in ["solve", "summary", "paper", "all", "config_snapshot"]:
        assert re.search(rf"^{re.escape(name)}\s+\d+\s*$", out, re.M), f"no {name} job in the dry run"
    # one job of rule `notebook` per figure, of `notebook_table` per table
    assert re.search(rf"^notebook\s+{len(FIGURES)}\s*$", out, re.M), out[-3000:]
    assert re.search(rf"^notebook_table\s+{len(TABLES)}\s*$", out, re.M), out[-3000:]
    n_solves = int(re.search(r"^solve\s+(\d+)\s*$", out, re.M).group(1))
    assert n_solves >= 60  # 2 sweeps x 13 n_H x 2 methods + references + Figs. 3, 5


def test_config_schema_rejects_invalid_values():
    import yaml
    from snakemake.exceptions import WorkflowError
    from snakemake.utils import validate

    cfg = yaml.safe_load((ROOT / "workflow" / "config.yaml").read_text())
    validate(cfg, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))
    bad = json.loads(json.dumps(cfg))
    bad["systems"]["impact5"]["case"] = "impact5.yaml"  # case files are named examples/<name>.yaml
    with pytest.raises(WorkflowError):
        validate(bad, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))
    bad = json.loads(json.dumps(cfg))
    bad["systems"]["impact5"]["timed"] = "yes"
    with pytest.raises(WorkflowError):
        validate(bad, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))
    bad = json.loads(json.dumps(cfg))
    bad["numerics"]["stepz"] = bad["numerics"].pop("steps")
    with pytest.raises(WorkflowError):
        validate(bad, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))
    for value in ({"shootin": 100}, {"shooting": 0}, {"shooting": 1.5}):   # unknown method, n < 1, not an integer
        bad = json.loads(json.dumps(cfg))
        bad["benchmarks"]["scaling_max_n"] = value
        with pytest.raises(WorkflowError):
            validate(bad, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))
    for key, value in (("reduce_modes", -1), ("reduce_modes", 2.5), ("mode_convergence", [4, "x"])):
        bad = json.loads(json.dumps(cfg))
        bad["fe_example"][key] = value
        with pytest.raises(WorkflowError):
            validate(bad, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))


def test_the_workflow_validates_the_stress_config(tmp_path):
    """workflow/stress.yaml is validated by Snakemake when the workflow is parsed (not only by the
    script, at the end of a run): an invalid value stops even a dry run, naming the key."""
    wd = copy_workflow(tmp_path)
    cfg = wd / "workflow" / "stress.yaml"
    cfg.write_text(cfg.read_text().replace("\ntolerance:\n", "\ntolerance:\n  hbm-typo: 0.1\n", 1))
    proc = run(TARGET + ["-n", "--cores", "1"] + QUICK, wd, timeout=120)
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0 and "hbm-typo" in out, out[-3000:]


@pytest.mark.slow
def test_quick_workflow_outputs(quick_run):
    for name in FIGURES:
        for ext in ("png", "pdf"):
            assert (quick_run / "figures" / f"{name}.{ext}").stat().st_size > 1000
    for name in TABLES:
        assert "|" in (quick_run / "tables" / f"{name}.md").read_text()
        assert (quick_run / "tables" / f"{name}.csv").exists()
    for name in FIGURES + TABLES:
        nb = json.loads((quick_run / "notebooks" / f"{name}.ipynb").read_text())
        errors = [o for c in nb["cells"] if c["cell_type"] == "code" for o in c.get("outputs", [])
                  if o.get("output_type") == "error"]
        assert not errors, (name, errors)
        assert "<html" in (quick_run / "notebooks" / f"{name}.html").read_text()[:2000].lower()
    # every solve wrote its facts; failures are recorded with a message, never dropped
    for path in (quick_run / "solves").rglob("*.json"):
        facts = json.loads(path.read_text())
        assert isinstance(facts["success"], bool)
        if not facts["success"]:
            assert facts["message"], path


@pytest.mark.slow
def test_quick_workflow_matches_references(quick_run):
    failures = reference_failures(quick_run / "summary")
    assert not failures, "\n".join(failures) + (
        "\n(if the change is intended, regenerate: python workflow/scripts/paper/update_references.py)")


@pytest.mark.slow
def test_paper_html_is_self_contained_and_complete(quick_run):
    page = (quick_run / "paper" / "paper.html").read_text()
    for name in FIGURES:
        m = re.search(rf'<figure id="{name}"><img alt="[^"]*" src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
        assert m and len(m.group(1)) > 1000, f"figure {name} missing from the paper"
    for name in TABLES:
        m = re.search(rf'<div class="table" id="{name}">\s*(?:<div class="table-scroll">\s*)?<table>(.*?)</table>',
                      page, re.S)
        assert m and m.group(1).count("<tr>") >= 5, f"table {name} missing from the paper"
    assert "{{" not in page and "}}" not in page  # every placeholder filled
    assert not re.search(r'(src|href)="(https?:)?//', page)  # nothing loaded from elsewhere


@pytest.mark.slow
def test_rerun_with_nothing_changed_does_nothing(quick_run, workdir):
    proc = run(TARGET + ["-n", "--cores", "2"] + QUICK, workdir, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Nothing to be done" in proc.stdout + proc.stderr, (proc.stdout + proc.stderr)[-3000:]


@pytest.mark.slow
def test_editing_a_notebook_reruns_that_figure_and_the_paper_only(quick_run, workdir):
    """The notebook's source is the rule's input: an edited notebooks/fig3.py reruns the fig3 job and
    the paper, nothing else; restored, nothing (Snakemake compares the content, not only the time)."""
    src = workdir / "notebooks" / "fig3.py"
    text = src.read_bytes()
    src.write_bytes(text + b"\n# %%\nprint('an edit')\n")
    try:
        proc = run(TARGET + ["-n", "--cores", "2"] + QUICK, workdir, timeout=120)
    finally:
        src.write_bytes(text)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    table = out[out.index("Job stats:"):out.index("total")]
    jobs = dict(re.findall(r"^(\w+)\s+(\d+)\s*$", table, re.M))
    assert jobs == {"notebook": "1", "paper": "1", "reproduction": "1"}, out[-3000:]
    assert "wildcards: name=fig3" in out, out[-3000:]
    proc = run(TARGET + ["-n", "--cores", "2"] + QUICK, workdir, timeout=120)
    assert "Nothing to be done" in proc.stdout + proc.stderr, (proc.stdout + proc.stderr)[-3000:]


@pytest.mark.slow
def test_quick_benchmarks(quick_run):
    """The quick benchmarks (part of the quick workflow, embedded in its paper): the exact reference
    is converged, full shooting shows its known orders against it, and every method converged.
    Times are never asserted; the accuracy numbers are (bounds with a margin of >= 2x, see the
    measured values in the comments)."""
    bench = quick_run / "benchmarks"
    digest = json.loads((bench / "summary.json").read_text())
    assert (bench / "workprecision.png").stat().st_size > 1000
    assert "Work–precision against the exact reference" in (quick_run / "paper" / "paper.html").read_text()
    orders = {"friction3": (1.6, 2.4), "impact5": (0.7, 1.3)}  # measured 1.98 and 0.96
    for system, (lo, hi) in orders.items():
        d = json.loads((bench / f"workprecision_{system}.json").read_text())
        conv = d["reference"]["convergence"]
        assert conv["all_converged"] and conv["max_relative_difference"] < 1e-9, conv  # measured ~1e-14
        assert lo <= d["targets"]["shooting_order"] <= hi, d["targets"]["shooting_order"]
        assert all(r["success"] for r in d["rows"]), [r for r in d["rows"] if not r["success"]]
        best = {m: min(r["error"] for r in d["rows"] if r["method"] == m) for m in ("shooting", "mshbm", "hbm")}
        # MS-HBM (time-stepped contact) is far more accurate than HBM (penalty/arctan law)
        assert best["mshbm"] < 0.1 * best["hbm"], best
        assert digest["workprecision"][system]["reference_convergence"]["all_converged"]
    # friction: MS-HBM with 9 harmonics and 2048 steps within 2e-5 (measured 5.2e-6)
    d = json.loads((bench / "workprecision_friction3.json").read_text())
    r = [r for r in d["rows"] if r["method"] == "mshbm" and r["harmonics"] == 9 and r["steps"] == 2048][0]
    assert r["error"] < 2e-5, r["error"]
    _check_event_rows(bench)


def _check_event_rows(bench):
    """The event-driven variants of the quick benchmarks.  Shooting (event) is exact up to
    Newton's tolerance (measured 2.2e-12 friction3, 4.4e-11 impact5); MS-HBM (event) has only the
    harmonic truncation, so 9 harmonics are > 10x more accurate than 3 (measured 420x, 27x) and within
    2e-6 on friction3 (measured 5.2e-7); the goal check is recorded consistently."""
    for system in ("friction3", "impact5"):
        d = json.loads((bench / f"workprecision_{system}.json").read_text())
        ev = {(r["method"], r["harmonics"]): r for r in d["rows"] if r["integrator"] == "event"}
        assert set(ev) == {("shooting-event", None), ("mshbm-event", 3), ("mshbm-event", 9)}, set(ev)
        assert ev[("shooting-event", None)]["error"] < 1e-9, ev[("shooting-event", None)]
        assert ev[("mshbm-event", 9)]["error"] < 0.1 * ev[("mshbm-event", 3)]["error"]
        g = d["targets"]["event_goal"]
        assert (g["ratio"] is None) == (g["mshbm_event"] is None or g["shooting"] is None), g
        if g["ratio"] is not None:
            assert g["mshbm_event"]["error"] <= 1e-6 and g["shooting"]["error"] <= 1e-3
            assert g["ratio"] == g["shooting"]["time_s"] / g["mshbm_event"]["time_s"] and g["met"] == (g["ratio"] > 1)
    d = json.loads((bench / "workprecision_friction3.json").read_text())
    assert [r["error"] for r in d["rows"] if r["method"] == "mshbm-event" and r["harmonics"] == 9][0] < 2e-6
