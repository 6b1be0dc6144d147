"""YAML 1.1 traps in case files.  Chosen rule (mshbm.io docstring): sexagesimal
(``1:30``), leading-zero (``010``) and ``0o`` octal numbers are errors naming the key; booleans
(yes/no/on/off) are not numbers; ``1e3`` is a float; hexadecimal and ``1_000`` are read as written.
CLI: exit code 2 and one line ``error: <key>: ...``."""
import pytest

from mshbm.cli import main
from mshbm.io import load_case

BASE = """masses: [1, 1, 1]
stiffness: 1
damping: 0.1
omega: 0.7
forcing: [{dof: 2, amplitude: 1}]
friction: {dof: 0, mu: 0.5, normal_force: 1}
solver: {method: hbm, harmonics: 3}
"""


def case_text(**repl):
    text = BASE
    for old, new in repl.items():
        old = {"omega": "omega: 0.7", "masses": "masses: [1, 1, 1]", "stiffness": "stiffness: 1",
               "damping": "damping: 0.1", "forcing": "forcing: [{dof: 2, amplitude: 1}]",
               "friction": "friction: {dof: 0, mu: 0.5, normal_force: 1}",
               "solver": "solver: {method: hbm, harmonics: 3}"}[old]
        text = text.replace(old, new)
    return text


def run_cli(capsys, tmp_path, text):
    path = tmp_path / "case.yaml"
    path.write_text(text)
    code = main(["solve", str(path), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("section, line, key", [
    ("omega", "omega: 1:30", "omega"),                                   # base: read as 90
    ("omega", "omega: -1:30.5", "omega"),
    ("omega", "omega: 1:30:00", "omega"),
    ("omega", "omega: 010", "omega"),                                    # base: read as 8
    ("omega", "omega: 0o10", "omega"),
    ("masses", "masses: [1, 010, 1]", "masses[1]"),
    ("masses", "masses: [1, 1, 0:30]", "masses[2]"),
    ("stiffness", "stiffness: [1, 1, 07]", "stiffness[2]"),
    ("damping", "damping: 00", "damping"),
    ("forcing", "forcing: [{dof: 02, amplitude: 1}]", "forcing[0].dof"),
    ("forcing", "forcing: [{dof: 2, amplitude: 1, harmonic: 01}]", "forcing[0].harmonic"),
    ("forcing", "forcing: [{dof: 2, amplitude: 2:00}]", "forcing[0].amplitude"),
    ("friction", "friction: {dof: 0, mu: 0:30, normal_force: 1}", "friction.mu"),
    ("friction", "friction: {dof: 0, mu: 0.5, normal_force: 010}", "friction.normal_force"),
    ("solver", "solver: {method: hbm, harmonics: 0o3}", "solver.harmonics"),
    ("solver", "solver: {method: hbm, harmonics: 3, steps: 01024}", "solver.steps"),
    # other YAML 1.1 traps: booleans and non-finite floats where numbers are expected
    ("omega", "omega: yes", "omega"),
    ("omega", "omega: .inf", "omega"),
    ("omega", "omega: .nan", "omega"),
    ("masses", "masses: [1, on, 1]", "masses[1]"),
    ("forcing", "forcing: [{dof: no, amplitude: 1}]", "forcing[0].dof"),
    ("friction", "friction: {dof: 0, mu: off, normal_force: 1}", "friction.mu"),
    ("solver", "solver: {method: hbm, harmonics: y}", "solver.harmonics"),
    ("stiffness", "stiffness: -.inf", "stiffness"),
    ("omega", "omega: 0,7", "omega"),                                    # decimal comma: a string
])
def test_yaml11_numbers_are_errors_naming_the_key(capsys, tmp_path, section, line, key):
    code, out, err = run_cli(capsys, tmp_path, case_text(**{section: line}))
    assert code == 2, (out, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {key}: "), err


@pytest.mark.parametrize("line, attr, value", [
    ("omega: 1e0", "omega", 1.0),
    ("omega: 7e-1", "omega", 0.7),
    ("omega: 1.0e+0", "omega", 1.0),
    ("omega: 1E0", "omega", 1.0),
    ("omega: +.5", "omega", 0.5),
    ("omega: 0.5", "omega", 0.5),
    ("omega: 1_000", "omega", 1000.0),
    ("omega: 0x10", "omega", 16.0),
])
def test_unambiguous_numbers_are_read_as_written(tmp_path, line, attr, value):
    path = tmp_path / "case.yaml"
    path.write_text(case_text(omega=line))
    assert getattr(load_case(path), attr) == value


def test_number_like_name_is_kept_as_text(tmp_path):
    path = tmp_path / "case.yaml"
    path.write_text("name: 1:30\n" + BASE)
    assert load_case(path).name == "1:30"                      # base: error (read as the int 90)


def test_exponent_without_dot_in_harmonics(tmp_path):
    path = tmp_path / "case.yaml"
    path.write_text(case_text(solver="solver: {method: hbm, harmonics: 3e0}"))
    assert load_case(path).solver["harmonics"] == 3
