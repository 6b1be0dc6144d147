"""Case files (mshbm.io) and the command line (mshbm.cli): examples, JSON output, exit codes,
and one clear line naming the key for every kind of bad input."""
import copy
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import mshbm
from mshbm import InputError
from mshbm.cli import main
from mshbm.io import MAX_FILE_BYTES, Case, load_case, parse_case

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
JSON_KEYS = {"case", "method", "harmonics", "steps", "success", "message", "iterations", "residual",
             "wall_time_s", "amplitude", "period", "omega"}

BASE = {
    "name": "small",
    "masses": [1, 1, 1],
    "stiffness": 1,
    "damping": 0,
    "omega": 0.6283185307179586,
    "forcing": [{"dof": 2, "amplitude": 5}],
    "friction": {"dof": 0, "mu": 0.8, "normal_force": 9.81, "smoothing": 800},
    "solver": {"method": "mshbm", "harmonics": 3, "steps": 512},
}
CONTACT = {"dof": 0, "gap": 0.1, "restitution": 1, "penalty_stiffness": 8000, "penalty_damping": 0}
MATRICES = {
    "M": [[2.0, 0.0], [0.0, 1.0]],
    "C": [[0.1, 0.0], [0.0, 0.1]],
    "K": [[3.0, -1.0], [-1.0, 1.0]],
    "omega": 0.8,
    "forcing": [{"dof": 1, "amplitude": 1.0}],
    "solver": {"method": "hbm", "harmonics": 2},
}


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def write_case(tmp_path, data, name="case.yaml"):
    path = tmp_path / name
    if isinstance(data, (str, bytes)):
        path.write_bytes(data.encode() if isinstance(data, str) else data)
    else:
        path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def printed_amplitudes(out):
    return {int(m.group(1)): float(m.group(2)) for m in re.finditer(r"^\s+dof\s+(\d+)\s+(\S+)$", out, re.M)}


def assert_input_error(code, out, err, key):
    """Exit 2, exactly one stderr line 'error: <key>: ...', no traceback anywhere."""
    assert code == 2, (out, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"error: {key}: "), (lines[0], key)
    assert out == ""


# ----------------------------------------------------------------------------- examples
@pytest.mark.parametrize("name, n, method", [("friction3", 3, "mshbm"), ("impact5", 5, "mshbm"),
                                             ("linear_matrices", 2, "hbm")])
def test_examples_load(name, n, method):
    case = load_case(EXAMPLES / f"{name}.yaml")
    assert isinstance(case, Case)
    assert isinstance(case.system, mshbm.System)
    assert case.system.n == n
    assert case.name == name
    assert case.method == method
    assert case.omega > 0


def test_friction3_example_content():
    case = load_case(EXAMPLES / "friction3.yaml")
    assert case.omega == pytest.approx(np.pi / 5, rel=1e-15)
    assert case.solver == {"method": "mshbm", "harmonics": 3, "steps": 4096}
    (fr,) = case.system.elements
    assert (fr.kind, fr.dof, fr.mu, fr.normal_force, fr.smoothing) == ("friction", 0, 0.8, 5.0, 800.0)
    np.testing.assert_array_equal(case.system.f_hat[1], [0, 0, 5])
    imp = load_case(EXAMPLES / "impact5.yaml")
    (ct,) = imp.system.elements
    assert (ct.kind, ct.dof, ct.gap, ct.restitution, ct.penalty_stiffness, ct.penalty_damping) == \
        ("contact", 0, 0.1, 1.0, 8000.0, 0.0)
    np.testing.assert_array_equal(np.diag(imp.system.dense("M")), [10, 1, 1, 1, 1])
    assert imp.system.dense("C")[0, 0] == pytest.approx(0.6)


@pytest.mark.parametrize("name", ["friction3", "impact5", "linear_matrices"])
def test_cli_example_matches_api(name, tmp_path, capsys):
    out_json = tmp_path / "result.json"
    code, out, err = run(capsys, "solve", EXAMPLES / f"{name}.yaml", "--out", out_json)
    assert code == 0, err
    assert "Traceback" not in out + err
    case = load_case(EXAMPLES / f"{name}.yaml")
    opts = {k: v for k, v in case.solver.items() if k != "method"}
    ref = mshbm.solve(case.system, case.omega, case.method, **opts)
    assert ref.success
    data = json.loads(out_json.read_text())
    assert JSON_KEYS <= set(data)
    assert data["success"] is True and data["case"] == name and data["method"] == case.method
    np.testing.assert_allclose(data["amplitude"], ref.amplitude, rtol=0, atol=1e-12)
    printed = printed_amplitudes(out)
    assert sorted(printed) == list(range(case.system.n))
    np.testing.assert_allclose([printed[d] for d in range(case.system.n)], ref.amplitude, rtol=0, atol=1e-12)
    assert data["omega"] == case.omega and data["period"] == pytest.approx(2 * np.pi / case.omega)
    assert data["harmonics"] == ref.harmonics and data["steps"] == ref.steps
    # the solution itself: the Fourier series of every DOF rebuilt from q_hat at the grid t is the API's
    # displacement there (Fourier DOFs), and the time-stepped DOFs' series are the API's
    q_hat, t = np.array(data["q_hat"]), np.array(data["t"])
    assert q_hat.shape == (2 * ref.harmonics + 1, case.system.n)
    k = np.arange(1, ref.harmonics + 1)
    series = q_hat[0] + np.cos(np.outer(t, k) * case.omega) @ q_hat[1::2] + np.sin(np.outer(t, k) * case.omega) @ q_hat[2::2]
    np.testing.assert_allclose(series, ref.q_hat[0] + np.cos(np.outer(t, k) * case.omega) @ ref.q_hat[1::2]
                               + np.sin(np.outer(t, k) * case.omega) @ ref.q_hat[2::2], rtol=0, atol=1e-12)
    assert data["time_dofs"] == [int(d) for d in ref.time_dofs]
    if ref.time_dofs.size:
        np.testing.assert_allclose(data["q_time"], ref.q_time, rtol=0, atol=1e-12)
        np.testing.assert_allclose(data["u_time"], ref.u_time, rtol=0, atol=1e-12)
    fourier = [d for d in range(case.system.n) if d not in set(data["time_dofs"])]
    np.testing.assert_allclose(series[:, fourier], ref.displacement(fourier), rtol=0, atol=1e-12)


def test_cli_table_fields_and_overrides(tmp_path, capsys):
    out_json = tmp_path / "r.json"
    code, out, err = run(capsys, "solve", EXAMPLES / "friction3.yaml", "--method", "shooting",
                         "--harmonics", "4", "--steps", "512", "--out", out_json)
    assert code == 0, err
    for field in ("method", "harmonics", "steps", "success", "iterations", "residual", "wall time", "amplitude"):
        assert re.search(rf"^{field}\b", out, re.M), field
    assert re.search(r"^method\s+shooting$", out, re.M)
    data = json.loads(out_json.read_text())
    assert (data["method"], data["harmonics"], data["steps"]) == ("shooting", 4, 512)


def test_cli_quiet(tmp_path, capsys):
    path = write_case(tmp_path, BASE)
    code, out, err = run(capsys, "solve", path, "--quiet")
    assert (code, out, err) == (0, "", "")


def test_cli_many_dofs_table_is_shortened(tmp_path, capsys):
    data = copy.deepcopy(BASE)
    data.update(masses=[1.0] * 15, forcing=[{"dof": 14, "amplitude": 5}])
    data["solver"] = {"method": "mshbm", "harmonics": 1, "steps": 256}
    code, out, err = run(capsys, "solve", write_case(tmp_path, data))
    assert code == 0, err
    assert sorted(printed_amplitudes(out)) == [0, 1, 2, 3, 4, 10, 11, 12, 13, 14]
    assert re.search(r"^\s+\.\.\.$", out, re.M)


def test_version(capsys):
    code, out, err = run(capsys, "--version")
    assert code == 0 and out.strip() == f"mshbm {mshbm.__version__}"


# ----------------------------------------------------------------------------- non-convergence
def test_max_iter_zero_exits_1_and_json_says_failure(tmp_path, capsys):
    data = copy.deepcopy(BASE)
    data["solver"]["max_iter"] = 0
    out_json = tmp_path / "fail.json"
    code, out, err = run(capsys, "solve", write_case(tmp_path, data), "--out", out_json)
    assert code == 1
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: solve did not converge: ")
    assert "Traceback" not in out + err
    result = json.loads(out_json.read_text())
    assert result["success"] is False
    assert JSON_KEYS <= set(result)
    assert re.search(r"^success\s+no$", out, re.M)


@pytest.mark.slow
def test_genuine_failure_exits_1(tmp_path, capsys):
    # MS-HBM on the impact chain needs many Newton iterations from the linear start: one is not enough
    case = yaml.safe_load((EXAMPLES / "impact5.yaml").read_text())
    case["solver"] = {"method": "mshbm", "harmonics": 3, "max_iter": 1}
    path = tmp_path / "impact5_short.yaml"
    path.write_text(yaml.safe_dump(case))
    out_json = tmp_path / "mshbm.json"
    code, out, err = run(capsys, "solve", path, "--out", out_json, "--quiet")
    assert code == 1, err
    assert err.startswith("error: solve did not converge: ") and len(err.strip().splitlines()) == 1
    assert json.loads(out_json.read_text())["success"] is False


# ----------------------------------------------------------------------------- bad input
def _set(path, value):
    """Modifier: set a dotted path (list indices as integers) in a copy of BASE."""
    def apply(d):
        keys = path.split(".")
        target = d
        for k in keys[:-1]:
            target = target[int(k)] if isinstance(target, list) else target[k]
        last = keys[-1]
        if value is _DELETE:
            del target[last]
        elif isinstance(target, list):
            target[int(last)] = value
        else:
            target[last] = value
    return apply


_DELETE = object()


def _contact(**changes):
    def apply(d):
        del d["friction"]
        d["contact"] = {k: v for k, v in {**CONTACT, **changes}.items() if v is not _DELETE}
    return apply


def _matrices(**changes):
    def apply(d):
        d.clear()
        d.update(copy.deepcopy(MATRICES))
        for k, v in changes.items():
            if v is _DELETE:
                del d[k]
            else:
                d[k] = v
    return apply


BAD = [
    # structure
    ("unknown-top-key", _set("mass", [1]), "mass"),
    ("unknown-friction-key", _set("friction.coef", 0.3), "friction.coef"),
    ("unknown-contact-key", _contact(stiffness=3), "contact.stiffness"),
    ("unknown-solver-key", _set("solver.order", 3), "solver.order"),
    ("unknown-forcing-key", _set("forcing.0.phase", 0.1), "forcing[0].phase"),
    ("missing-masses", _set("masses", _DELETE), "masses"),
    ("missing-stiffness", _set("stiffness", _DELETE), "stiffness"),
    ("missing-omega", _set("omega", _DELETE), "omega"),
    ("missing-mu", _set("friction.mu", _DELETE), "friction.mu"),
    ("missing-gap", _contact(gap=_DELETE), "contact.gap"),
    ("missing-forcing-dof", _set("forcing.0.dof", _DELETE), "forcing[0].dof"),
    ("chain-and-matrices", _set("M", [[1, 0, 0], [0, 1, 0], [0, 0, 1]]), "M"),
    ("friction-not-mapping", _set("friction", 0.8), "friction"),
    ("solver-not-mapping", _set("solver", "mshbm"), "solver"),
    ("forcing-not-list", _set("forcing", "5 cos"), "forcing"),
    ("forcing-item-not-mapping", _set("forcing", [5]), "forcing[0]"),
    ("name-not-string", _set("name", 5), "name"),
    # wrong types
    ("mass-string", _set("masses", ["1", 1, 1]), "masses[0]"),
    ("masses-scalar", _set("masses", 3), "masses"),
    ("masses-empty", _set("masses", []), "masses"),
    ("omega-string", _set("omega", "fast"), "omega"),
    ("omega-bool", _set("omega", True), "omega"),
    ("stiffness-bool", _set("stiffness", True), "stiffness"),
    ("stiffness-mapping", _set("stiffness", {"a": 1}), "stiffness"),
    ("mu-string", _set("friction.mu", "0.8"), "friction.mu"),
    ("dof-float", _set("friction.dof", 0.5), "friction.dof"),
    ("amplitude-string", _set("forcing.0.amplitude", "five"), "forcing[0].amplitude"),
    ("harmonics-string", _set("solver.harmonics", "3"), "solver.harmonics"),
    ("condense-number", _set("solver", {"method": "hbm", "condense": 1}), "solver.condense"),
    ("jacobian-bad", _set("solver.jacobian", "approx"), "solver.jacobian"),
    # NaN / inf
    ("omega-nan", _set("omega", float("nan")), "omega"),
    ("omega-inf", _set("omega", float("inf")), "omega"),
    ("mass-inf", _set("masses", [float("inf"), 1, 1]), "masses[0]"),
    ("stiffness-nan", _set("stiffness", [1, float("nan"), 1]), "stiffness[1]"),
    ("amplitude-nan", _set("forcing.0.amplitude", float("nan")), "forcing[0].amplitude"),
    ("normal-force-inf", _set("friction.normal_force", float("inf")), "friction.normal_force"),
    ("omega-huge-int", _set("omega", 10 ** 400), "omega"),
    # values
    ("mass-zero", _set("masses", [1, 0, 1]), "masses[1]"),
    ("mass-negative", _set("masses", [-1, 1, 1]), "masses[0]"),
    ("stiffness-negative", _set("stiffness", -1), "stiffness"),
    ("stiffness-negative-item", _set("stiffness", [1, 1, -2]), "stiffness[2]"),
    ("stiffness-wrong-length", _set("stiffness", [1, 1]), "stiffness"),
    ("damping-negative", _set("damping", [0, -0.1, 0]), "damping[1]"),
    ("mu-negative", _set("friction.mu", -0.8), "friction.mu"),
    ("normal-force-negative", _set("friction.normal_force", -9.81), "friction.normal_force"),
    ("smoothing-zero", _set("friction.smoothing", 0), "friction.smoothing"),
    ("restitution-above-1", _contact(restitution=1.5), "contact.restitution"),
    ("restitution-below-0", _contact(restitution=-0.1), "contact.restitution"),
    ("gap-negative", _contact(gap=-0.1), "contact.gap"),
    ("penalty-stiffness-zero", _contact(penalty_stiffness=0), "contact.penalty_stiffness"),
    ("omega-zero", _set("omega", 0), "omega"),
    ("omega-negative", _set("omega", -1.0), "omega"),
    ("forcing-dof-out-of-range", _set("forcing.0.dof", 3), "forcing[0].dof"),
    ("forcing-dof-negative", _set("forcing.0.dof", -1), "forcing[0].dof"),
    ("forcing-harmonic-zero", _set("forcing.0.harmonic", 0), "forcing[0].harmonic"),
    ("forcing-harmonic-huge", _set("forcing.0.harmonic", 10 ** 9), "forcing[0].harmonic"),
    ("friction-dof-out-of-range", _set("friction.dof", 5), "friction.dof"),
    ("contact-dof-out-of-range", _contact(dof=3), "contact.dof"),
    ("friction-list-item", _set("friction", [BASE["friction"], {"dof": 1, "mu": -1, "normal_force": 1}]),
     "friction[1].mu"),
    ("friction-list-duplicate-dof", _set("friction", [BASE["friction"], BASE["friction"]]), "friction[1].dof"),
    ("harmonics-zero", _set("solver.harmonics", 0), "solver.harmonics"),
    ("steps-too-few", _set("solver.steps", 4), "solver.steps"),
    ("steps-too-few-for-harmonics", _set("solver", {"harmonics": 5, "steps": 10}), "solver.steps"),
    ("max-iter-negative", _set("solver.max_iter", -1), "solver.max_iter"),
    ("theta-out-of-range", _set("solver.theta", 0.2), "solver.theta"),
    ("tol-zero", _set("solver.tol", 0), "solver.tol"),
    ("unknown-method", _set("solver.method", "newton"), "solver.method"),
    ("option-not-of-method", _set("solver", {"method": "hbm", "theta": 0.5}), "solver.theta"),
    ("partition-out-of-range", _set("solver.partition", [0, 7]), "solver.partition[1]"),
    ("partition-missing-element-dof", _set("solver.partition", [1]), "solver.partition"),
    # matrices
    ("M-not-square", _matrices(M=[[1, 0], [0]]), "M"),
    ("M-not-list", _matrices(M="eye"), "M"),
    ("K-wrong-size", _matrices(K=[[1, 0, 0], [0, 1, 0], [0, 0, 1]]), "K"),
    ("C-wrong-size", _matrices(C=[[1]]), "C"),
    ("M-non-symmetric", _matrices(M=[[2, 1], [0, 1]]), "M"),
    ("M-not-positive-definite", _matrices(M=[[1, 2], [2, 1]]), "M"),
    ("M-entry-string", _matrices(M=[[2, "0"], [0, 1]]), "M[0][1]"),
    ("K-entry-nan", _matrices(K=[[3, -1], [-1, float("nan")]]), "K[1][1]"),
    ("missing-K", _matrices(K=_DELETE), "K"),
    ("matrix-forcing-dof", _matrices(forcing=[{"dof": 2, "amplitude": 1}]), "forcing[0].dof"),
]


@pytest.mark.parametrize("modify, key", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_case_exit_2(modify, key, tmp_path, capsys):
    data = copy.deepcopy(BASE)
    modify(data)
    path = write_case(tmp_path, data)
    code, out, err = run(capsys, "solve", path)
    assert_input_error(code, out, err, key)
    with pytest.raises(InputError) as info:
        load_case(path).solve()
    assert info.value.key == key


RAW_BAD = [
    ("invalid-yaml", "masses: [1, 2\nomega: 1\n", "yaml"),
    ("tab-indent", "masses:\n\t- 1\n", "yaml"),
    ("top-level-list", "- 1\n- 2\n", "yaml"),
    ("top-level-scalar", "hello\n", "yaml"),
    ("empty-file", "", "yaml"),
    ("duplicate-key", "masses: [1]\nstiffness: 1\nomega: 1\nomega: 2\n", "yaml"),
    ("two-documents", "omega: 1\n---\nomega: 2\n", "yaml"),
    ("python-tag", "omega: !!python/object/apply:os.system ['echo hi']\n", "yaml"),
    ("deep-nesting", "masses: " + "[" * 100_000 + "\n", "yaml"),
    ("deep-block-nesting", "".join("  " * i + f"k{i}:\n" for i in range(200)), "yaml"),
    ("recursive-alias", "masses: &a [1, *a]\nstiffness: 1\nomega: 1\n", "yaml"),
    ("alias-bomb", "a: &a [1,1,1,1,1,1,1,1,1,1]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a,*a]\n"
                   "c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b,*b]\nd: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c,*c]\n"
                   "e: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d,*d]\nf: &f [*e,*e,*e,*e,*e,*e,*e,*e,*e,*e]\n"
                   "g: &g [*f,*f,*f,*f,*f,*f,*f,*f,*f,*f]\nmasses: *g\n", "yaml"),
    ("not-utf8", b"masses: [1]\nname: \xff\xfe\n", "yaml"),
    ("nul-byte", "masses: [1]\x00\n", "yaml"),
    ("yaml-nan", "masses: [1]\nstiffness: 1\nomega: .nan\n", "omega"),
    ("yaml-inf-mass", "masses: [.inf]\nstiffness: 1\nomega: 1\n", "masses[0]"),
    ("yaml-quoted-number", "masses: [1]\nstiffness: 1\nomega: '0.5'\n", "omega"),
    ("yaml-exponent-overflow", "masses: [1]\nstiffness: 1\nomega: 1e400\n", "omega"),
    ("yaml-yes-as-number", "masses: [1]\nstiffness: yes\nomega: 1\n", "stiffness"),
    ("yaml-date", "masses: [1]\nstiffness: 1\nomega: 2024-01-01\n", "omega"),
]


@pytest.mark.parametrize("text, key", [b[1:] for b in RAW_BAD], ids=[b[0] for b in RAW_BAD])
def test_bad_yaml_exit_2(text, key, tmp_path, capsys):
    path = write_case(tmp_path, text)
    code, out, err = run(capsys, "solve", path)
    assert_input_error(code, out, err, key)


def test_invalid_yaml_names_the_line(tmp_path, capsys):
    code, out, err = run(capsys, "solve", write_case(tmp_path, "masses: [1]\nomega: 1\nfriction: {dof: 0\n"))
    assert_input_error(code, out, err, "yaml")
    assert "line 4" in err or "line 3" in err


def test_unknown_key_lists_allowed_and_suggests(tmp_path, capsys):
    data = copy.deepcopy(BASE)
    data["mases"] = data.pop("masses")
    code, out, err = run(capsys, "solve", write_case(tmp_path, data))
    assert_input_error(code, out, err, "mases")
    assert "allowed:" in err and "masses" in err and "did you mean 'masses'" in err


def test_missing_and_unreadable_files(tmp_path, capsys):
    missing = tmp_path / "nope.yaml"
    assert_input_error(*run(capsys, "solve", missing), str(missing))
    assert_input_error(*run(capsys, "solve", tmp_path), str(tmp_path))


def test_huge_file_rejected_quickly(tmp_path, capsys):
    path = tmp_path / "huge.yaml"
    with open(path, "wb") as fh:
        fh.write(b"omega: 1\n")
        fh.write(b"#" * (MAX_FILE_BYTES + 10) + b"\n")
    assert_input_error(*run(capsys, "solve", path), str(path))


def test_cli_option_errors(tmp_path, capsys):
    path = write_case(tmp_path, BASE)
    assert_input_error(*run(capsys, "solve", path, "--harmonics", "0"), "--harmonics")
    assert_input_error(*run(capsys, "solve", path, "--steps", "2"), "--steps")
    assert_input_error(*run(capsys, "solve", path, "--out", tmp_path / "no" / "dir" / "r.json"), "--out")
    assert_input_error(*run(capsys, "solve", path, "--out", tmp_path), "--out")


def test_linear_system_with_mshbm_is_input_error(capsys):
    code, out, err = run(capsys, "solve", EXAMPLES / "linear_matrices.yaml", "--method", "mshbm")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err


@pytest.mark.parametrize("argv", [["solve", "x.yaml", "--method", "newton"], ["solve"], [],
                                  ["solve", "x.yaml", "--harmonics", "three"], ["frobnicate"]])
def test_usage_errors_exit_2(argv, capsys):
    code, out, err = run(capsys, *argv)
    assert code == 2 and "Traceback" not in out + err
    assert "error" in err


def test_internal_error_exit_3(monkeypatch, capsys):
    def boom(path, **kw):
        raise RuntimeError("kaboom")

    monkeypatch.setattr("mshbm.io.load_case", boom)
    code, out, err = run(capsys, "solve", EXAMPLES / "friction3.yaml")
    assert code == 3
    assert err.strip() == "error: internal: RuntimeError: kaboom"


def test_keyboard_interrupt_exit_130(monkeypatch, capsys):
    def interrupt(path, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr("mshbm.io.load_case", interrupt)
    code, out, err = run(capsys, "solve", EXAMPLES / "friction3.yaml")
    assert code == 130 and "Traceback" not in err


# ----------------------------------------------------------------------------- load_case API
def test_overrides_and_solve_defaults(tmp_path):
    path = write_case(tmp_path, BASE)
    case = load_case(path, omega=0.5, harmonics=1, method="shooting", theta=0.5)
    assert case.omega == 0.5
    assert case.solver == {"method": "shooting", "harmonics": 1, "steps": 512, "theta": 0.5}
    # hbm does not take theta: a default of the solver section that does not apply is dropped
    sol = case.solve("hbm", steps=256)
    assert sol.method == "hbm" and sol.steps == 256 and sol.harmonics == 1
    # explicit options are passed through and validated by mshbm.solve
    with pytest.raises(InputError) as info:
        case.solve("hbm", theta=0.5)
    assert info.value.key == "theta"
    with pytest.raises(InputError) as info:
        load_case(path, speed=3)
    assert info.value.key == "speed"
    with pytest.raises(InputError) as info:
        load_case(path, friction=None, contact={"dof": 0, "gap": -1})
    assert info.value.key == "contact.gap"


def test_case_solve_equals_api_solve(tmp_path):
    case = load_case(write_case(tmp_path, BASE))
    a = case.solve()
    b = mshbm.solve(case.system, case.omega, "mshbm", harmonics=3, steps=512)
    assert a.success and b.success
    np.testing.assert_array_equal(a.amplitude, b.amplitude)


def test_float_exponents_and_defaults(tmp_path):
    text = ("masses: [10, 1]\nstiffness: [1, 2]\nomega: 6.283e-1\n"
            "contact: {dof: 0, gap: 1e-1, penalty_stiffness: 8e3}\n")
    case = load_case(write_case(tmp_path, text))
    (ct,) = case.system.elements
    assert (ct.gap, ct.restitution, ct.penalty_stiffness, ct.penalty_damping) == (0.1, 1.0, 8000.0, 0.0)
    assert case.omega == pytest.approx(0.6283)
    assert case.name == "case" and case.solver == {} and case.method == "mshbm"
    np.testing.assert_array_equal(case.system.dense("C"), 0)
    np.testing.assert_array_equal(case.system.dense("K"), [[3, -2], [-2, 2]])
    np.testing.assert_array_equal(case.system.f_hat, 0)


def test_friction_and_contact_lists_and_forcing_terms(tmp_path):
    data = copy.deepcopy(BASE)
    data["friction"] = [{"dof": 0, "mu": 0.8, "normal_force": 9.81}, {"dof": 2, "mu": 0.1, "normal_force": 1}]
    data["contact"] = [CONTACT]
    data["forcing"] = [{"dof": 2, "amplitude": 5}, {"dof": 1, "sin": 2, "harmonic": 3, "constant": 0.5}]
    case = load_case(write_case(tmp_path, data))
    kinds = sorted((e.kind, e.dof) for e in case.system.elements)
    assert kinds == [("contact", 0), ("friction", 0), ("friction", 2)]
    f = case.system.f_hat
    assert f.shape == (7, 3)
    assert f[1, 2] == 5 and f[6, 1] == 2 and f[0, 1] == 0.5 and np.count_nonzero(f) == 3


def test_matrix_case_matches_chain(tmp_path):
    chain_case = load_case(write_case(tmp_path, BASE, "chain.yaml"))
    s = chain_case.system
    data = {k: v for k, v in BASE.items() if k not in ("masses", "stiffness", "damping")}
    data.update(M=s.dense("M").tolist(), C=s.dense("C").tolist(), K=s.dense("K").tolist())
    mat_case = load_case(write_case(tmp_path, data, "matrices.yaml"))
    for name in "MCK":
        np.testing.assert_array_equal(mat_case.system.dense(name), s.dense(name))
    np.testing.assert_array_equal(mat_case.system.f_hat, s.f_hat)
    assert mat_case.system.elements == s.elements


def test_parse_case_accepts_dicts():
    case = parse_case(copy.deepcopy(MATRICES), name="m")
    assert case.name == "m" and case.system.n == 2
    with pytest.raises(InputError) as info:
        parse_case([1, 2])
    assert info.value.key == "yaml"


# ----------------------------------------------------------------------------- real processes
def _subprocess(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "mshbm", *map(str, args)], capture_output=True, text=True,
                          timeout=120, cwd=cwd)


def test_subprocess_success_writes_json(tmp_path):
    out_json = tmp_path / "r.json"
    proc = _subprocess("solve", EXAMPLES / "friction3.yaml", "--harmonics", "3", "--steps", "512",
                       "--out", out_json, "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "" and proc.stderr == ""
    data = json.loads(out_json.read_text())
    assert data["success"] is True and len(data["amplitude"]) == 3
    assert all(math.isfinite(a) for a in data["amplitude"])


def test_subprocess_bad_input_one_line(tmp_path):
    data = copy.deepcopy(BASE)
    data["friction"]["mu"] = -0.8
    proc = _subprocess("solve", write_case(tmp_path, data))
    assert proc.returncode == 2
    assert "Traceback" not in proc.stdout + proc.stderr
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()]
    assert proc.stderr.startswith("error: friction.mu: ")


def test_subprocess_hostile_yaml_no_crash(tmp_path):
    # the libyaml composer would overflow the C stack on this; it must be a clean exit 2
    path = write_case(tmp_path, "masses: " + "[" * 1_000_000 + "\n")
    proc = _subprocess("solve", path)
    assert proc.returncode == 2, (proc.returncode, proc.stderr[-500:])
    assert "Traceback" not in proc.stdout + proc.stderr
    assert proc.stderr.startswith("error: yaml: ") and len(proc.stderr.strip().splitlines()) == 1


def test_alias_depth_and_short_messages(tmp_path, capsys):
    # anchors each wrapping the previous: shallow text, deep data
    lines = ["a0: &a0 [1]"] + [f"a{i}: &a{i} [*a{i - 1}]" for i in range(1, 40)] + ["masses: *a39"]
    code, out, err = run(capsys, "solve", write_case(tmp_path, "\n".join(lines) + "\n"))
    assert_input_error(code, out, err, "yaml")
    # a big value in the wrong place gives a short message
    text = "big: &big [" + ", ".join(["1"] * 100_000) + "]\n"
    text = text.replace("big: ", "", 1).join(["masses: [1]\nstiffness: 1\nomega: ", ""])
    code, out, err = run(capsys, "solve", write_case(tmp_path, text))
    assert_input_error(code, out, err, "omega")
    assert len(err) < 200
    long_key = "x" * 10_000
    code, out, err = run(capsys, "solve", write_case(tmp_path, {**BASE, long_key: 1}))
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith("error: xxx") and len(err) < 400


# ----------------------------------------------------------------------------- accuracy
def test_cli_states_the_error_estimate_and_json_carries_it(tmp_path, capsys):
    """The table's one-line ``error estimate`` row and the JSON's ``accuracy`` entry: the combined estimate, its
    parts and the accuracy they are held to (default 1e-2; ``--accuracy`` and ``solver.accuracy`` request one)."""
    out_json = tmp_path / "r.json"
    path = write_case(tmp_path, BASE)
    code, out, err = run(capsys, "solve", path, "--out", str(out_json))
    assert code == 0, err
    data = json.loads(out_json.read_text())
    acc = data["accuracy"]
    assert acc["accuracy"] == 1e-2 and not acc["requested"] and acc["passed"]
    assert set(acc["estimates"]) == {"truncation", "time_discretisation"}
    assert acc["estimate"] == pytest.approx(sum(acc["estimates"].values()), rel=1e-12) and acc["estimate"] <= 1e-2
    (row,) = [c for c in data["certificate"] if c["name"] == "accuracy"]
    assert row["gating"] and row["passed"] and row["value"] == acc["estimate"]
    line = [ln for ln in out.splitlines() if ln.startswith("error estimate")]
    assert len(line) == 1 and f"{acc['estimate']:.1e} <= 1e-02 (default)" in line[0] and "truncation" in line[0]
    # requested on the command line: refined until met (or failed naming the estimate)
    code, out, err = run(capsys, "solve", path, "--accuracy", "1e-4", "--out", str(out_json))
    acc = json.loads(out_json.read_text())["accuracy"]
    assert acc["requested"] and acc["accuracy"] == 1e-4
    assert (code == 0 and acc["passed"] and acc["estimate"] <= 1e-4) or (code == 1 and "accuracy" in err)
    # requested in the case file
    data = copy.deepcopy(BASE)
    data["solver"]["accuracy"] = 1e-3
    code, out, err = run(capsys, "solve", write_case(tmp_path, data), "--out", str(out_json))
    acc = json.loads(out_json.read_text())["accuracy"]
    assert acc["requested"] and acc["accuracy"] == 1e-3 and "(requested)" in out


@pytest.mark.parametrize("value", [0, -0.1, 0.9, "tight", True])
def test_bad_accuracy_in_the_case_file_names_the_key(tmp_path, capsys, value):
    data = copy.deepcopy(BASE)
    data["solver"]["accuracy"] = value
    assert_input_error(*run(capsys, "solve", write_case(tmp_path, data)), "solver.accuracy")


def test_bad_accuracy_on_the_command_line_names_the_option(tmp_path, capsys):
    assert_input_error(*run(capsys, "solve", write_case(tmp_path, BASE), "--accuracy", "0.9"), "--accuracy")
