"""Shared fixtures: the paper's systems (parameters as in workflow/config.yaml); the quick workflow,
run once per session (tests/test_workflow.py, tests/test_render.py)."""
import numpy as np
import pytest
from workflow_run import QUICK, TARGET, copy_workflow, run

from mshbm import Contact, Friction, chain

OMEGA = np.pi / 5
#: F_N = 5 (mu*F_N = 4): stick-slip in the 3- and the 30-mass chain (30 % and 34 % stick per period);
#: F_N = 9.81 would lock the 30-mass chain completely (see paper, assumptions)
NORMAL_FORCE = 5.0


def friction_chain(n, kappa=800.0):
    return chain([1.0] * n, 1.0, 0.0, forcing=[{"dof": n - 1, "amplitude": 5.0}],
                 elements=[Friction(0, 0.8, NORMAL_FORCE, kappa)], name=f"friction{n}")


def impact_chain(n, gap=0.1, kc=8000.0, e=1.0):
    return chain([10.0] + [1.0] * (n - 1), 1.0, 0.3, forcing=[{"dof": n - 1, "amplitude": 5.0}],
                 elements=[Contact(0, gap, e, kc, 0.0)], name=f"impact{n}")


@pytest.fixture(scope="session")
def friction3():
    return friction_chain(3)


@pytest.fixture(scope="session")
def impact5():
    return impact_chain(5)


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
