"""Shared fixtures: the paper's systems (the case files of examples/, tests/paper_systems.py); the quick
workflow, run once per session (tests/integration/test_workflow.py, tests/integration/test_render.py).

The suite runs on all cores with pytest-xdist (``-n auto --dist loadgroup``, pyproject.toml).  The workers
write the work units of their collection (:func:`pytest_collection_modifyitems`) and the controller hands
out whole units (:func:`pytest_xdist_make_scheduler`; xdist's own ``loadgroup`` renames the node ids of
marked tests, which pytest 9 no longer takes into account):

* every test that uses the quick workflow (fixture ``quick_run``) is one unit, so the workflow runs once,
  in one worker; it starts first, being the longest;
* the tests of a module with a module-scoped fixture are one unit, so the fixture's solves run once;
* every other test is a unit of its own.

Units holding a test marked ``slow`` start before the others, so that no worker is left with a long unit
at the end.  While the workers collect, one process compiles the numba kernels into their on-disk cache when
the cache is empty (:func:`pytest_configure`), and the workers wait for it before their first test, so that
they and the workflow's jobs load the kernels instead of compiling them each.
"""
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pytest
from paper_systems import system
from workflow_run import QUICK, TARGET, copy_workflow, run

#: the xdist work unit of the tests that share the quick workflow's run
QUICK_GROUP = "quick-workflow"
#: Snakemake's job-rate window for the quick run (default 100 jobs per 1 s).  After every pass of its scheduling loop
#: Snakemake arms a timer of that window that wakes the loop again, and every job start and end begins another such
#: chain of timers: towards the end of the run some hundred chains wake the loop (a new thread each, and a
#: re-evaluation of the ready jobs) about a hundred times a second.  The main Snakemake process of the quick run took
#: 99 s of CPU with the 1 s window and 12 s with 5 s (2 cores, 911 and 778 s of wall on a loaded machine; the same
#: outputs); the cost is up to 5 s of wall at the end, when the process waits for its last timers
QUICK_RATE = ["--max-jobs-per-timespan", "1000/5s"]
#: (controller) the folder where the xdist workers write the work units of their collection
UNITS_DIR = pytest.StashKey[str]()
#: solves that compile the numba kernels of the package (run once, while the xdist workers collect)
WARM_UP = """
import mshbm
from paper_systems import OMEGA, friction_chain, impact_chain
for system in (friction_chain(3), impact_chain(5)):
    for method, options in (("shooting", dict(steps=256)), ("mshbm", dict(harmonics=3, steps=256)),
                            ("mshbm-intermediate", dict(harmonics=3, steps=256)), ("hbm", dict(harmonics=5)),
                            ("dlft", dict(harmonics=5)), ("dlft", dict(harmonics=5, dlft_predictor="displacement")),
                            ("shooting", dict(steps=256, integrator="event")),
                            ("mshbm", dict(harmonics=3, steps=256, integrator="event"))):
        try:
            mshbm.solve(system, OMEGA, method, **options)
        except mshbm.InputError:
            pass
# HBM's kernel of frictions loaded by a contact (examples/damper2d.yaml)
from mshbm.io import load_case
problem = mshbm.build_problem(load_case("../examples/damper2d.yaml").model, 0.8, "hbm", harmonics=3)[0]
problem.residual(problem.initial_guess())
"""


def _xdist_controller(config):
    """True in the process that distributes the tests to xdist workers (not in a worker, not without -n)."""
    return (not hasattr(config, "workerinput") and config.pluginmanager.hasplugin("xdist")
            and bool(config.getoption("numprocesses", None)) and config.getoption("dist", "no") != "no")


def _numba_cache_is_cold():
    """No numba cache index of the package yet (a fresh clone): its kernels would be compiled by each process."""
    cache = os.environ.get("NUMBA_CACHE_DIR")
    root = Path(cache) if cache else Path(importlib.util.find_spec("mshbm").origin).parent
    return not any(root.rglob("*.nbi"))


def pytest_configure(config):
    if not _xdist_controller(config):
        return
    units = config.stash[UNITS_DIR] = tempfile.mkdtemp(prefix="pytest-units-")
    done = Path(units) / "warm-up.done"
    if not _numba_cache_is_cold():
        done.touch()
        return
    tests = Path(__file__).resolve().parent
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(tests), os.environ.get("PYTHONPATH")])))
    proc = subprocess.Popen([sys.executable, "-c", WARM_UP], env=env, cwd=tests,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def finish():  # the workers collect meanwhile and wait for this file before their first test
        try:
            proc.wait(timeout=600)
        except subprocess.TimeoutExpired:
            proc.kill()
        done.touch()

    threading.Thread(target=finish, daemon=True).start()


def pytest_collection_finish(session):
    """(in an xdist worker) Wait for the compilation of the numba kernels (:func:`pytest_configure`)."""
    units_dir = getattr(session.config, "workerinput", {}).get("units_dir")
    if units_dir is None:
        return
    deadline = time.monotonic() + 660
    while not (Path(units_dir) / "warm-up.done").exists() and time.monotonic() < deadline:
        time.sleep(0.2)


def pytest_unconfigure(config):
    if UNITS_DIR in config.stash:
        shutil.rmtree(config.stash[UNITS_DIR], ignore_errors=True)


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """(xdist, in the controller) Tell each worker where to write the work units of its collection."""
    if UNITS_DIR in node.config.stash:
        node.workerinput["units_dir"] = node.config.stash[UNITS_DIR]


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """(xdist, in the controller) ``--dist loadgroup`` by the work units that the workers wrote: one unit
    goes to one worker, the units in the workers' collection order."""
    if config.getoption("dist", "no") != "loadgroup" or UNITS_DIR not in config.stash:
        return None
    from xdist.scheduler import LoadScopeScheduling

    units_dir = Path(config.stash[UNITS_DIR])

    class UnitScheduling(LoadScopeScheduling):
        units = None

        def _split_scope(self, nodeid):
            if self.units is None:  # the workers wrote their (identical) units before reporting their collection
                self.units = json.loads(next(iter(sorted(units_dir.glob("*.json")))).read_text())
            return self.units.get(nodeid) or nodeid

    return UnitScheduling(config, log)


def _module_fixture(item):
    """True if the test uses a fixture of module (or wider) scope other than the session's."""
    info = getattr(item, "_fixtureinfo", None)
    defs = info.name2fixturedefs.values() if info is not None else ()
    return any(d.scope in ("module", "class", "package") for fixturedefs in defs for d in fixturedefs)


def _units(items):
    """The work unit of each test (None: a unit of its own).  A test that asks for fixtures by name
    (``request.getfixturevalue``) joins its module's unit if the module has one; an ``xdist_group``
    mark names a unit of its own."""
    units = {}
    for item in items:
        mark = item.get_closest_marker("xdist_group")
        if mark is not None:
            units[item.nodeid] = str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))
        elif "quick_run" in item.fixturenames:
            units[item.nodeid] = QUICK_GROUP
        else:
            units[item.nodeid] = item.nodeid.split("::")[0] if _module_fixture(item) else None
    grouped = set(units.values())
    for item in items:
        module = item.nodeid.split("::")[0]
        own = getattr(getattr(item, "_fixtureinfo", None), "argnames", ())
        if units[item.nodeid] is None and "request" in own and module in grouped:
            units[item.nodeid] = module
    return units


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """(in an xdist worker) Order the tests, the quick workflow's unit first, then the units with a test
    marked ``slow``, and write the units for the controller's scheduler."""
    units_dir = getattr(config, "workerinput", {}).get("units_dir")
    if units_dir is None:
        return
    units = _units(items)
    long_units = {units[i.nodeid] or i.nodeid for i in items if i.get_closest_marker("slow")}
    rank = {}
    for item in items:
        unit = units[item.nodeid] or item.nodeid
        rank[item.nodeid] = 0 if unit == QUICK_GROUP else 1 if unit in long_units else 2
    items.sort(key=lambda item: rank[item.nodeid])  # stable: collection order within a rank
    path = Path(units_dir) / f"{config.workerinput['workerid']}.json"
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({k: v for k, v in units.items() if v is not None}))
    tmp.replace(path)


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
    # about 8 min on 2 idle cores; the limit only guards against a hung run (on a loaded machine 900 s was too
    # little, and every test of the unit then errored)
    # greedy job selection: the default ILP scheduler starts the CBC solver once per finished job (about 0.1 s of
    # wall each, while a core waits); the rules' priorities order the long jobs first either way
    proc = run(TARGET + ["--cores", "2", "--scheduler", "greedy"] + QUICK_RATE + QUICK, workdir, timeout=2400)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
    return workdir / "results" / "quick"
