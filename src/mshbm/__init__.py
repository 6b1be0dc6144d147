"""mshbm: periodic solutions of linear structures with local nonsmooth elements.

Full shooting (Moreau-Jean), HBM-AFT and the mixed shooting-harmonic balance
method of Schreyer & Leine (2016), behind one call::

    import mshbm
    case = mshbm.load_case("case.yaml")
    sol = mshbm.solve(case.system, case.omega, method="mshbm", harmonics=5)
    sol.amplitude

The names of ``__all__`` (and :mod:`mshbm.stability`) are imported at their first use
(PEP 562 module ``__getattr__``), not with the package: a process that only needs a light
submodule (``mshbm.errors``, ``mshbm.outfile``, ``mshbm.fourier``, ...) does not pay for the
solver's imports (NumPy, SciPy, numba and the kernels).
"""
from __future__ import annotations

import importlib

__all__ = ["solve", "build_problem", "residual_omega_derivative", "METHODS", "System", "Element", "Friction",
           "Jenkins", "Contact", "Polynomial", "frictional_contact", "chain", "PeriodicSolution", "InputError",
           "ConvergenceError", "load_case", "exact_periodic", "sweep", "Branch", "continue_forcing",
           "continue_parameter", "switch_period_doubling", "backbone", "Backbone", "base_excitation", "BaseMotion"]
__version__ = "0.1.0"

#: public name -> submodule (relative to the package) that defines it
_LAZY = {
    "solve": ".api", "build_problem": ".api", "residual_omega_derivative": ".api", "METHODS": ".api",
    "Backbone": ".backbone", "backbone": ".backbone",
    "Branch": ".branch", "continue_forcing": ".branch", "sweep": ".branch",
    "continue_parameter": ".parameter",
    "switch_period_doubling": ".switching",
    "Contact": ".elements", "Element": ".elements", "Friction": ".elements", "Jenkins": ".elements",
    "Polynomial": ".elements", "frictional_contact": ".elements",
    "ConvergenceError": ".errors", "InputError": ".errors",
    "exact_periodic": ".methods.exact",
    "PeriodicSolution": ".result",
    "BaseMotion": ".support", "base_excitation": ".support",
    "System": ".system", "chain": ".system",
}


def __getattr__(name):
    """The public object ``name`` (or the submodule ``mshbm.<name>``), imported at first use."""
    module = _LAZY.get(name)
    if module is None:
        # a submodule (``mshbm.io``, ``mshbm.branch``, ...) reached as an attribute, as when the package
        # imported everything eagerly
        if not name.startswith("__"):
            try:
                return importlib.import_module(f".{name}", __name__)
            except ModuleNotFoundError as exc:
                if exc.name != f"{__name__}.{name}":
                    raise
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__) | {"stability"})


def load_case(path, **overrides):
    """Read a YAML case file; see :func:`mshbm.io.load_case`."""
    from .io import load_case as _load

    return _load(path, **overrides)
