"""The command line on adversarial case files: forcing the method cannot represent,
bad partitions, free-free structures, overflow.  Each: exit code 2 and one line ``error: <key>: ...``
without traceback or RuntimeWarning, or exit 0 with the exact answer."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mshbm.cli import main

CHAIN = """masses: [1, 1, 1]
stiffness: 1
damping: 0.1
omega: 0.7
forcing: [{dof: 2, amplitude: 1, harmonic: 3}]
friction: {dof: 0, mu: 0.5, normal_force: 1}
"""


def run(capsys, tmp_path, text, *args):
    path = tmp_path / "case.yaml"
    path.write_text(text)
    code = main(["solve", str(path), "--quiet", *args])
    out, err = capsys.readouterr()
    return code, out, err


def assert_input_error(result, key, *words):
    code, out, err = result
    assert code == 2, (out, err)
    assert "Traceback" not in out + err and "Warning" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {key}: "), err
    for w in words:
        assert w in lines[0], lines[0]


@pytest.mark.parametrize("method", ["hbm", "mshbm", "mshbm-intermediate"])
def test_forcing_above_solver_harmonics(capsys, tmp_path, method):
    text = CHAIN + f"solver: {{method: {method}, harmonics: 2, steps: 256}}\n"
    assert_input_error(run(capsys, tmp_path, text), "solver.harmonics", "harmonic 3")


def test_forcing_above_cli_harmonics(capsys, tmp_path):
    text = CHAIN + "solver: {method: hbm}\n"
    assert_input_error(run(capsys, tmp_path, text, "--harmonics", "2"), "--harmonics", "harmonic 3")


def test_forcing_above_default_harmonics(capsys, tmp_path):
    text = CHAIN.replace("harmonic: 3", "harmonic: 7") + "solver: {method: hbm}\n"
    assert_input_error(run(capsys, tmp_path, text), "harmonics", "harmonic 7")


def test_forcing_aliased_by_cli_steps(capsys, tmp_path):
    text = CHAIN.replace("{dof: 2, amplitude: 1, harmonic: 3}", "{dof: 0, amplitude: 1, harmonic: 4}")
    assert_input_error(run(capsys, tmp_path, text, "--method", "shooting", "--steps", "8"), "--steps", "aliasing")


@pytest.mark.parametrize("partition", ["[[0], [1, 1]]", "[[0, 0], [1]]", "[[0], [0, 1]]", "[[1], [2]]",
                                       "[0, 1]", "[[0], [1], [2]]"])
def test_bad_intermediate_partition(capsys, tmp_path, partition):
    text = CHAIN.replace("harmonic: 3", "harmonic: 1") + \
        f"solver: {{method: mshbm-intermediate, harmonics: 2, steps: 256, partition: {partition}}}\n"
    assert_input_error(run(capsys, tmp_path, text), "solver.partition")


@pytest.mark.parametrize("text", [
    "M: [[1, 0], [0, 1]]\nK: [[1, -1], [-1, 1]]\nomega: 1\nforcing: [{dof: 1, amplitude: 1}]\n"
    "solver: {method: hbm}\n",
    "masses: [1, 1]\nstiffness: [0, 1]\ndamping: 0.1\nomega: 1\nforcing: [{dof: 1, amplitude: 1}]\n"
    "friction: {dof: 0, mu: 0.5, normal_force: 1}\nsolver: {method: mshbm, steps: 256}\n",
    "masses: [1, 1]\nstiffness: [0, 1]\ndamping: 0.1\nomega: 1\nforcing: [{dof: 1, amplitude: 1}]\n"
    "solver: {method: shooting, steps: 256}\n",
], ids=["matrices-hbm", "chain-friction-mshbm", "chain-shooting"])
def test_free_free_structure_is_named(capsys, tmp_path, text):
    assert_input_error(run(capsys, tmp_path, text), "K", "free-free")


@pytest.mark.parametrize("text, key", [
    ("masses: [1e200, 1e200]\nstiffness: 1\ndamping: 0.1\nomega: 1e60\nforcing: [{dof: 1, amplitude: 1}]\n"
     "friction: {dof: 0, mu: 0.5, normal_force: 1}\nsolver: {method: hbm}\n", "omega"),
    ("masses: [1, 1]\nstiffness: 1\ndamping: 1e300\nomega: 1e10\nforcing: [{dof: 1, amplitude: 1}]\n"
     "friction: {dof: 0, mu: 0.5, normal_force: 1}\nsolver: {method: mshbm, steps: 256}\n", "omega"),
    ("masses: [1, 1]\nstiffness: 1\ndamping: 0.1\nomega: 1\nforcing: [{dof: 1, amplitude: 1e300}]\n"
     "friction: {dof: 0, mu: 0.5, normal_force: 1}\nsolver: {method: shooting, steps: 256}\n", "forcing"),
], ids=["mass-omega", "damping-omega", "forcing"])
def test_overflow_is_named(capsys, tmp_path, text, key):
    assert_input_error(run(capsys, tmp_path, text), key, "float range")


def test_no_warning_reaches_stderr_in_a_subprocess(tmp_path):
    """With warnings shown (-W default), an overflowing case prints exactly one error line."""
    path = tmp_path / "case.yaml"
    path.write_text("masses: [1e200, 1e200]\nstiffness: 1\ndamping: 0.1\nomega: 1e60\n"
                    "forcing: [{dof: 1, amplitude: 1}]\nfriction: {dof: 0, mu: 0.5, normal_force: 1}\n"
                    "solver: {method: shooting, steps: 64}\n")
    proc = subprocess.run([sys.executable, "-W", "default", "-m", "mshbm.cli", "solve", str(path), "--quiet"],
                          capture_output=True, text=True, timeout=120, env={**os.environ})
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()]
    assert proc.stderr.startswith("error: omega: ") and "Warning" not in proc.stderr


def test_linear_multi_harmonic_case_gives_exact_amplitudes(capsys, tmp_path):
    """Forcing at harmonics 1 and 2 with harmonics: 2 is represented exactly: the JSON amplitudes of
    an undamped 1-DOF oscillator are the closed-form extrema of A1 cos + A2 cos 2 (base: ~1e-6 off)."""
    text = ("masses: [1]\nstiffness: 1\nomega: 0.37\nforcing: [{dof: 0, amplitude: 1}, "
            "{dof: 0, amplitude: 0.3, harmonic: 2}]\nsolver: {method: hbm, harmonics: 2}\n")
    out = tmp_path / "r.json"
    code, _, err = run(capsys, tmp_path, text, "--out", str(out))
    assert code == 0, err
    A1, A2 = 1 / (1 - 0.37 ** 2), 0.3 / (1 - 0.74 ** 2)
    x = -A1 / (4 * A2)
    vals = [A1 + A2, -A1 + A2, A1 * x + A2 * (2 * x * x - 1)]
    amp = json.loads(out.read_text())["amplitude"][0]
    assert amp == pytest.approx(0.5 * (max(vals) - min(vals)), rel=1e-13)
    assert np.isfinite(amp)
