"""mshbm: periodic solutions of linear structures with local nonsmooth elements.

Full shooting (Moreau-Jean), HBM-AFT and the mixed shooting-harmonic balance
method of Schreyer & Leine (2016), behind one call::

    import mshbm
    case = mshbm.load_case("case.yaml")
    sol = mshbm.solve(case.system, case.omega, method="mshbm", harmonics=5)
    sol.amplitude
"""
from . import stability  # noqa: F401  (mshbm.stability: Floquet multipliers and verdicts)
from .api import METHODS, build_problem, residual_omega_derivative, solve
from .backbone import Backbone, backbone
from .branch import Branch, continue_forcing, sweep
from .parameter import continue_parameter
from .switching import switch_period_doubling
from .elements import Contact, Element, Friction, Jenkins, Polynomial, frictional_contact
from .errors import ConvergenceError, InputError
from .methods.exact import exact_periodic
from .result import PeriodicSolution
from .support import BaseMotion, base_excitation
from .system import System, chain

__all__ = ["solve", "build_problem", "residual_omega_derivative", "METHODS", "System", "Element", "Friction",
           "Jenkins", "Contact", "Polynomial", "frictional_contact", "chain", "PeriodicSolution", "InputError",
           "ConvergenceError", "load_case", "exact_periodic", "sweep", "Branch", "continue_forcing",
           "continue_parameter", "switch_period_doubling", "backbone", "Backbone", "base_excitation", "BaseMotion"]
__version__ = "0.1.0"


def load_case(path, **overrides):
    """Read a YAML case file; see :func:`mshbm.io.load_case`."""
    from .io import load_case as _load

    return _load(path, **overrides)
