"""Libraries of the reproduction workflow (``workflow/``): what the rules, the stage scripts
(``workflow/scripts/<stage>/``), the notebooks (``notebooks/``) and the tests share.

Installed with the project (``pip install -e .``: ``pyproject.toml`` finds this package under
``workflow/lib``), so that every script, notebook kernel and test imports it by name.

Modules, by concern:

* :mod:`~mshbm_workflow.wfcore` -- the configuration: the systems from their case files, result paths of
  the solves, method labels, JSON I/O, placeholders of the paper, small statistics;
* :mod:`~mshbm_workflow.benchlib` -- the benchmarks' timing (warm-up, interleaved repeats, medians),
  machine facts, plots; :mod:`~mshbm_workflow.pyharmlib` -- pyHarm's models and its own interpreter;
* :mod:`~mshbm_workflow.stress_cases`, :mod:`~mshbm_workflow.stress_judge`,
  :mod:`~mshbm_workflow.stress_report` -- the stress suite: its cases, the verdict on one solve, the report;
* :mod:`~mshbm_workflow.mdrender` -- markdown with math to offline HTML (paper and notebooks);
  :mod:`~mshbm_workflow.nbexport` -- a notebook to self-contained HTML;
* :mod:`~mshbm_workflow.nbcommon`, :mod:`~mshbm_workflow.wpcommon`, :mod:`~mshbm_workflow.tables` -- the
  notebooks' data access and shared plots (work-precision figures, the parameter tables);
* :func:`script_module` -- a stage script imported as a module (tests, tools).
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

#: the workflow's stage scripts, ``<SCRIPTS>/<stage>/<name>.py``
SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"


def script_module(stage, name):
    """The script ``workflow/scripts/<stage>/<name>.py`` imported as the module ``name`` (once; registered in
    ``sys.modules`` so that its functions pickle for worker pools)."""
    if name in sys.modules and getattr(sys.modules[name], "__file__", None) == str(SCRIPTS / stage / f"{name}.py"):
        return sys.modules[name]
    path = SCRIPTS / stage / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
