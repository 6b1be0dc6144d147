"""The layers of the solve route, read from the source: the numerics (mshbm.solvers) import nothing above
them, the route (mshbm.route) never calls up into the public API or the sweep (it gets the sweep as a
component), no global slot or context variable guards against recursion, and no module outside mshbm.methods
asks a method's name (they ask the problem's declarations)."""
import ast
import re
from pathlib import Path

import mshbm
from mshbm.branch import ROUTE, trace
from mshbm.route.driver import Route

ROOT = Path(mshbm.__file__).parent


def _package_imports(path):
    """Modules of mshbm that ``path`` imports (relative imports resolved), anywhere in the file."""
    pkg = list(path.relative_to(ROOT.parent).with_suffix("").parts[:-1])
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[: len(pkg) - node.level + 1]
                mod = ".".join(base + (node.module.split(".") if node.module else []))
                out.update(f"{mod}.{a.name}" for a in node.names)
                out.add(mod)
            elif node.module and node.module.startswith("mshbm"):
                out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("mshbm"))
    return out


def test_numerics_import_nothing_above_them():
    for path in (ROOT / "solvers").glob("*.py"):
        for mod in _package_imports(path):
            assert mod.startswith(("mshbm.solvers", "mshbm._lapack")), f"{path.name} imports {mod}"


def test_the_route_does_not_call_up():
    above = ("mshbm.api", "mshbm.branch", "mshbm.period", "mshbm.switching", "mshbm.strategies", "mshbm.cli")
    for path in (ROOT / "route").glob("*.py"):
        for mod in _package_imports(path):
            assert not mod.startswith(above), f"route/{path.name} imports {mod}"


def test_no_slot_or_context_variable_against_recursion():
    for path in list((ROOT / "route").glob("*.py")) + [ROOT / n for n in ("branch.py", "branch_tracer.py",
                                                                            "branch_result.py", "period.py")]:
        text = path.read_text()
        assert "contextvars" not in text and "ContextVar" not in text, path.name
        assert not re.search(r"^[A-Z_]+ = \[None\]", text, re.M), f"{path.name}: a module-level slot"


def test_no_method_name_tests_outside_the_methods():
    """Only ``mshbm.methods`` (the problems and their registries) may ask which method it is: the route, the sweep,
    the certificate, the stability analysis and the backbone driver ask the problem's declarations."""
    names = r"\"(shooting|hbm|mshbm|mshbm-intermediate|dlft)\""
    test = re.compile(rf"(method\s*(==|!=)\s*{names}|method\s+(not\s+)?in\s*\(|\.method\s*==)")
    paths = [p for p in ROOT.rglob("*.py") if "methods" not in p.relative_to(ROOT).parts]
    assert len(paths) > 40 and ROOT / "backbone.py" in paths and ROOT / "route" / "driver.py" in paths
    for path in paths:
        for i, line in enumerate(path.read_text().splitlines(), 1):
            assert not test.search(line), f"{path.name}:{i}: {line.strip()}"


def test_the_public_route_carries_the_sweep_and_nothing_else():
    assert isinstance(ROUTE, Route) and ROUTE.sweep is trace
    assert ROUTE.deadline is None and not ROUTE.single_start and not ROUTE.in_frequency
    nested = ROUTE.single().anchor(5.0)
    assert nested.deadline == 5.0 and nested.in_frequency and not nested.single_start
    assert ROUTE.tightened(3.0).tightened(4.0).deadline == 3.0
