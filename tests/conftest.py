"""Shared fixtures: the paper's systems (the case files of examples/, tests/paper_systems.py); the quick
workflow, run once per session (tests/integration/test_workflow.py, tests/integration/test_render.py)."""
import pytest
from paper_systems import system
from workflow_run import QUICK, TARGET, copy_workflow, run


@pytest.fixture(scope="session")
def friction3():
    return system("friction3")


@pytest.fixture(scope="session")
def impact5():
    return system("impact5")


@pytest.fixture(scope="session")
def workdir(tmp_path_factory):
    """A temporary copy of the workflow files (never the working tree's results/)."""
    return copy_workflow(tmp_path_factory.mktemp("workflow"))


@pytest.fixture(scope="session")
def quick_run(workdir):
    """Run the quick workflow once per session (a couple of minutes on 2 cores): results/quick/."""
    proc = run(TARGET + ["--cores", "2"] + QUICK, workdir, timeout=900)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
    return workdir / "results" / "quick"
