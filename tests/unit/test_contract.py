"""The problem contract (:mod:`mshbm.methods.base`) that every registered method must pass, and the
package's import graph (no cycles)."""
import ast
import re
from pathlib import Path

import numpy as np
import pytest

import mshbm
from mshbm import Contact, Friction, chain
from mshbm.methods.base import Partition, PeriodicProblem
from mshbm.methods.registry import PROBLEMS
from mshbm.options import METHODS

OMEGA = 0.8


def _systems():
    fr = chain([1.0, 1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 2, "amplitude": 2.0}], elements=[Friction(0, 0.3, 1.0)])
    ct = chain([1.0, 1.0], [1.0, 0.5], 0.05, forcing=[{"dof": 1, "amplitude": 1.0}], elements=[Contact(0, 0.3, 1.0, 2000.0)])
    return {"friction": fr, "contact": ct}


SYSTEMS = _systems()


def test_registry_and_options_name_the_same_methods():
    assert set(PROBLEMS) == set(METHODS) == set(mshbm.METHODS)
    assert all(issubclass(cls, PeriodicProblem) for cls in PROBLEMS.values())


@pytest.mark.parametrize("kind", sorted(SYSTEMS))
@pytest.mark.parametrize("method", sorted(METHODS))
def test_contract(method, kind):
    system = SYSTEMS[kind]
    steps = 256
    problem, _ = mshbm.build_problem(system, OMEGA, method, harmonics=3, steps=steps)
    assert isinstance(problem, PeriodicProblem) and problem.method == method
    n_x = problem.n_unknowns
    # any solution (certified or not) serves as a guess; the contract is about the interface.  The solution of
    # this problem: the time-stepping methods keep Moreau-Jean (explicitly, so that a failed solve of the contact
    # system does not end with the event-driven fallback, a different problem)
    keep = {"integrator": "moreau"} if "integrator" in mshbm.options.METHODS[method] else {}
    sol = mshbm.solve(system, OMEGA, method, harmonics=3, steps=steps, stability=False, **keep)
    assert sol.x.shape == (n_x,)
    for guess in (None, "linear", "zero", sol):
        x = problem.initial_guess(guess)
        assert x.shape == (n_x,) and np.all(np.isfinite(x))
    x = sol.x
    # a point off the solution: R and J finite, J against forward differences
    rng = np.random.default_rng(3)
    x1 = x + 1e-2 * (1 + np.abs(x)) * rng.standard_normal(n_x)
    R, J = problem.residual(x1)
    J = J.toarray() if hasattr(J, "toarray") else np.asarray(J)
    assert R.shape == (n_x,) and J.shape == (n_x, n_x) and np.all(np.isfinite(J))
    assert problem.residual(x1, jac=False)[1] is None
    Jfd = np.empty_like(J)
    for i in range(n_x):
        d = 1e-6 * max(1.0, abs(x1[i]))
        xp, xm = x1.copy(), x1.copy()
        xp[i] += d
        xm[i] -= d
        Jfd[:, i] = (problem.residual(xp, jac=False)[0] - problem.residual(xm, jac=False)[0]) / (2 * d)
    # piecewise-smooth residuals: most columns agree to difference accuracy, a kink may spoil a few
    col_err = np.max(np.abs(J - Jfd), axis=0) / (np.max(np.abs(Jfd)) + 1e-300)
    assert np.mean(col_err < 1e-4) >= 0.9, col_err
    s = problem.residual_scale(x1)
    assert s.shape == (n_x,) and np.all(s > 0) and np.all(np.isfinite(s))
    units = problem.residual_units()
    assert units.shape == (n_x,) and set(np.unique(units)) <= {0, 1, 2}
    # dR/domega against central differences of rebuilt problems
    dw = problem.omega_derivative(x1)
    h = 1e-5 * OMEGA
    Rp = mshbm.build_problem(system, OMEGA + h, method, harmonics=3, steps=steps)[0].residual(x1, jac=False)[0]
    Rm = mshbm.build_problem(system, OMEGA - h, method, harmonics=3, steps=steps)[0].residual(x1, jac=False)[0]
    assert np.allclose(dw, (Rp - Rm) / (2 * h), rtol=1e-3, atol=1e-6 * np.max(np.abs(dw)))
    parts = problem.solution_parts(x)
    nt = parts["time_dofs"].size
    assert parts["q_hat"].shape == (7, system.n) and parts["harmonics"] == 3
    assert parts["t"].shape == (problem.steps + 1,)
    assert parts["q_time"].shape == parts["u_time"].shape == (problem.steps + 1, nt)
    assert parts["lam"].shape == (problem.steps + 1, len(system.elements))
    p = problem.partition()
    assert isinstance(p, Partition) and np.array_equal(p.time, parts["time_dofs"])
    covered = np.union1d(np.union1d(p.time, p.harmonic), p.condensed)
    assert np.array_equal(covered, np.arange(system.n)) and not np.intersect1d(p.harmonic, p.condensed).size
    assert (problem.time_step is None) == (p.time.size == 0)
    assert (problem.integrator is None or problem.integrator.stepper is None) == (problem.time_step is None)
    rc = problem.conditioning()
    assert rc is None or (rc.shape in ((4,), (0,)) and np.all(rc > 0))
    assert isinstance(problem.homotopy(), list) and (problem.path_fallback() is None or callable(problem.path_fallback()))
    assert all(np.array_equal(getattr(sol.partition, f), getattr(p, f)) for f in ("time", "harmonic", "condensed"))
    assert sol.time_step == problem.time_step


def _imports(path, package_root):
    """Modules of the package that ``path`` imports (anywhere in the file, lazy imports included)."""
    rel = path.relative_to(package_root.parent).with_suffix("")
    parts = list(rel.parts)
    pkg = parts[:-1] if parts[-1] != "__init__" else parts[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[: len(pkg) - node.level + 1]
                mod = base + (node.module.split(".") if node.module else [])
            elif node.module and node.module.startswith("mshbm"):
                mod = node.module.split(".")
            else:
                continue
            for alias in node.names:
                cand = ".".join(mod + [alias.name])
                out.add(cand if (package_root.parent / Path(*cand.split("."))).with_suffix(".py").exists()
                        or (package_root.parent / Path(*cand.split(".")) / "__init__.py").exists()
                        else ".".join(mod))
    return out


def test_no_import_cycle():
    root = Path(mshbm.__file__).parent
    graph = {}
    for path in root.rglob("*.py"):
        name = ".".join(path.relative_to(root.parent).with_suffix("").parts).removesuffix(".__init__")
        graph[name] = {m for m in _imports(path, root) if m != name}
    # packages import their children for re-export only; a cycle through a package's __init__ is not
    # one between modules
    packages = {n for n in graph if (root.parent / Path(*n.split("."))).is_dir()}
    graph = {n: {m for m in deps if m not in packages} for n, deps in graph.items() if n not in packages}
    state, stack = {}, []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                raise AssertionError("import cycle: " + " -> ".join(stack[stack.index(m):] + [m]))
            if m not in state:
                visit(m)
        stack.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n)
    assert "mshbm.api" in graph and "mshbm.route.continuation" in graph["mshbm.api"]


def test_nothing_probes_a_problem():
    """No solver or driver probes a problem object for attributes: the contract declares them."""
    root = Path(mshbm.__file__).parent
    for path in list((root / "solvers").glob("*.py")) + list((root / "route").glob("*.py")) \
            + list((root / "certificate").glob("*.py")) \
            + [root / n for n in ("api.py", "branch.py", "period.py", "subharmonic.py", "hill.py")]:
        text = path.read_text()
        for probe in ("hasattr(problem", "getattr(problem", "__self__", "hasattr(self.problem"):
            assert probe not in text, f"{path.name}: {probe}"


#: a test of a method's name: ``method == ...``, ``method != ...``, ``method in (...)``, ``problem.method``
_NAME_TEST = re.compile(r"\bmethod\s*(==|!=)|\bmethod\s+(not\s+)?in\s*\(|\bproblem\.method\b")


def test_checks_ask_capabilities_not_method_names():
    """The certificate, the option and input checks, the stability analyses and the case reader read what
    differs between methods from the declarations (:mod:`mshbm.methods.capabilities`, the problem's declared
    representation in :mod:`mshbm.methods.base`), never from a test of the method's name."""
    root = Path(mshbm.__file__).parent
    paths = list((root / "certificate").glob("*.py")) + list((root / "io").glob("*.py")) + [
        root / n for n in ("validate.py", "options.py", "hill.py", "stability.py", "bifurcations.py", "floquet.py")]
    for path in paths:
        for i, line in enumerate(path.read_text().splitlines(), 1):
            assert not _NAME_TEST.search(line), f"{path.name}:{i}: {line.strip()}"


def test_capability_table_names_the_registered_methods():
    """Every registered method has a capability declaration, and the option table is read from it."""
    from mshbm.methods.capabilities import CAPABILITIES

    assert list(CAPABILITIES) == list(METHODS) and set(CAPABILITIES) == set(PROBLEMS)
    assert all(METHODS[m] == c.options for m, c in CAPABILITIES.items())
