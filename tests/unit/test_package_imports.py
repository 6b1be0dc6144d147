"""The package's public names are imported at their first use (PEP 562 ``__getattr__`` in ``mshbm/__init__``).

* ``import mshbm`` alone loads neither the solver (``mshbm.api``, ``mshbm.branch``) nor SciPy or numba, so a
  process that needs a light submodule (``mshbm.errors``, ``mshbm.outfile``, ``mshbm.fourier``) does not pay
  their start-up (about 0.6 s of CPU);
* every name of ``mshbm.__all__`` is the very object of the module that defines it, ``from mshbm import ...``
  and ``mshbm.<submodule>`` work as with eager imports, and an unknown name is an ``AttributeError``.
"""
import importlib
import subprocess
import sys

import pytest

import mshbm

HEAVY = ("mshbm.api", "mshbm.branch", "mshbm.route.driver", "scipy", "numba")


def _loaded_after(code):
    probe = f"import sys\n{code}\nprint(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.split()


@pytest.mark.parametrize("code", ["import mshbm", "import mshbm.errors", "from mshbm.outfile import jsonable",
                                  "from mshbm import fourier, InputError, __version__"])
def test_light_imports_load_no_solver(code):
    assert _loaded_after(code) == []


def test_first_use_loads_the_solver():
    assert _loaded_after("import mshbm\nmshbm.solve") == list(HEAVY)


@pytest.mark.parametrize("name", mshbm.__all__)
def test_public_names_are_the_defining_objects(name):
    module = mshbm._LAZY.get(name)
    obj = getattr(mshbm, name)
    if module is None:  # defined in the package itself
        assert name == "load_case" and obj.__module__ == "mshbm"
    else:
        assert obj is getattr(importlib.import_module(module, "mshbm"), name)
    assert name in dir(mshbm)


def test_submodules_and_unknown_names():
    from mshbm import Friction, solve, stability  # noqa: F401
    from mshbm.api import solve as api_solve

    assert solve is api_solve and stability is importlib.import_module("mshbm.stability")
    assert mshbm.io.load_case is importlib.import_module("mshbm.io").load_case
    assert mshbm.route.driver.Route is importlib.import_module("mshbm.route.driver").Route
    assert set(mshbm._LAZY) | {"load_case"} == set(mshbm.__all__)
    for missing in ("no_such_name", "__wrapped__"):
        assert not hasattr(mshbm, missing)
    with pytest.raises(AttributeError, match="no_such_name"):
        mshbm.no_such_name  # noqa: B018
