"""Fuzzing the case-file loader and the CLI with hypothesis.

Every input ends in exit code 2 with one line ``error: <key>: <problem>`` naming a key, or -- when the
random case happens to be valid -- in exit code 0 (converged) or 1 (not converged).  Never a traceback,
never exit code 3, never a hang (each example runs under an alarm), and a failed solve never leaves a
result file that claims success.  Solver effort is capped by ``--steps``/``--harmonics`` and by the
``solver`` section of the generated cases so that valid cases are cheap.
"""
import contextlib
import io
import json
import math
import os
import re
import signal
import tempfile

from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mshbm import InputError
from mshbm.cli import main
from mshbm.io import SOLVER_KEYS, TOP_KEYS, load_case, parse_case

#: STRESS_FUZZ_EXAMPLES=5000 STRESS_FUZZ_RANDOM=1 runs a longer, randomised campaign
FUZZ = settings(max_examples=int(os.environ.get("STRESS_FUZZ_EXAMPLES", 200)), deadline=None,
                derandomize=not os.environ.get("STRESS_FUZZ_RANDOM"),
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])
#: seconds one example may take before it counts as a hang
HANG_S = 30
CAPS = ["--steps", "64", "--harmonics", "1"]

BASE = {
    "name": "fuzz",
    "masses": [1.0, 1.0, 1.0],
    "stiffness": 1.0,
    "damping": 0.1,
    "omega": 0.6283185307179586,
    "forcing": [{"dof": 2, "amplitude": 5.0}],
    "friction": {"dof": 0, "mu": 0.8, "normal_force": 9.81, "smoothing": 800.0},
    "solver": {"method": "mshbm", "harmonics": 1, "steps": 64, "max_iter": 8},
}
CONTACT = {"dof": 0, "gap": 0.1, "restitution": 1.0, "penalty_stiffness": 8000.0, "penalty_damping": 0.0}
EXAMPLE = str(Path(__file__).resolve().parents[2] / "examples" / "friction3.yaml")
KEY_ROOTS = set(TOP_KEYS) | {"yaml", "--steps", "--harmonics", "--out", "method", "path"}


# ----------------------------------------------------------------------------- strategies
junk_scalar = st.one_of(
    st.none(), st.booleans(), st.integers(-10 ** 30, 10 ** 30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e308, -1e308, 1e-320, 2 ** 63, 2 ** 64 + 1, float("nan"), float("inf"), 3.5, 1e6]),
    st.text(max_size=12), st.sampled_from(["1", "1e3", "nan", "inf", ".inf", "yes", "", "mshbm", "hbm", "exact"]),
)
junk = st.recursive(junk_scalar, lambda inner: st.one_of(st.lists(inner, max_size=5),
                                                         st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                    max_leaves=12)


def _paths(obj, prefix=()):
    """Every path (tuple of keys/indices) in a nested dict/list."""
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, prefix + (i,))


def _set(obj, path, value, delete=False):
    for p in path[:-1]:
        obj = obj[p]
    if delete:
        if isinstance(obj, dict):
            del obj[path[-1]]
        else:
            obj.pop(path[-1])
    else:
        obj[path[-1]] = value


@st.composite
def mutated_case(draw):
    """A valid small case with 1-3 mutations: a value replaced by junk, a key deleted, an unknown key, a DOF
    out of range, a huge or non-finite number.  Returns ``(data, first mutated top-level key or None)``."""
    data = json.loads(json.dumps(BASE))
    if draw(st.booleans()):
        del data["friction"]
        data["contact"] = dict(CONTACT)
    if draw(st.booleans()):
        data["solver"]["method"] = draw(st.sampled_from(["shooting", "hbm", "mshbm", "mshbm-intermediate"]))
    first = None
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(data) if p]
        path = draw(st.sampled_from(paths))
        kind = draw(st.sampled_from(["junk", "delete", "unknown", "dof", "number"]))
        if kind == "junk":
            _set(data, path, draw(junk))
        elif kind == "delete":
            _set(data, path, None, delete=True)
        elif kind == "unknown":
            tgt = data
            for p in path[:-1]:
                tgt = tgt[p]
            if not isinstance(tgt, dict):
                continue
            tgt[draw(st.sampled_from(["mass", "omgea", "frictions", "dofs", "x", "Solver", "steps"]))] = 1
        elif kind == "dof":
            _set(data, path, draw(st.sampled_from([-1, 3, 99, 10 ** 9, 2.5, "0"])))
        else:
            _set(data, path, draw(st.sampled_from([float("nan"), float("inf"), -float("inf"), 1e308, -1e308,
                                                   1e30, -5.0, 0.0, 10 ** 20])))
        first = first or path[0]
    # keep valid cases cheap: the solver section may be mutated, but never asks for a long run
    solver = data.get("solver")
    if isinstance(solver, dict):
        for key, cap in (("steps", 4096), ("max_iter", 50), ("harmonics", 20)):
            v = solver.get(key)
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > cap:
                solver[key] = cap
    return data, first


yaml_fragments = st.sampled_from([
    "masses: [1, 1, 1]", "masses: [1, 1", "masses: 1", "masses: [a, b]", "stiffness: 1", "stiffness: [1, -1, 1]",
    "damping: .nan", "omega: 0.628", "omega: -1", "omega: .inf", "omega: 1e400", "omega:", "omega: '0.6'",
    "forcing: [{dof: 2, amplitude: 5}]", "forcing: [{dof: 7, amplitude: 5}]", "forcing: {dof: 0}",
    "forcing: [{amplitude: 5}]", "friction: {dof: 0, mu: 0.8, normal_force: 9.81}", "friction: {dof: 0}",
    "friction: [{dof: 0, mu: 0.8, normal_force: 1}, {dof: 0, mu: 0.8, normal_force: 1}]",
    "contact: {dof: 0, gap: 0.1}", "contact: {dof: 0, gap: -0.1, restitution: 2}",
    "solver: {method: mshbm, harmonics: 1, steps: 64}", "solver: {method: nope}", "solver: {harmonics: 1.5}",
    "solver: {steps: 2}", "solver: {tol: 0}", "solver: []", "M: [[1, 0], [0, 1]]", "K: [[1, -1], [-1, 1]]",
    "C: [[0]]", "M: [[1, 2], [2, 1]]", "name: [x]", "&a [*a]", "a: &a [1, *a]", "? [1]\n: 2", "!!python/object:os.system {}",
    "key: !!binary aGVsbG8=", "- 1\n- 2", "{", "}", "\t", "'unterminated", "x: 'y", "---", "...", "%YAML 1.1",
    "masses: [1, 1, 1]\nmasses: [2]", "omega: 0x10", "omega: 0o7", "omega: 1_000", "omega: 1.0e+3", "~",
    "solver: {max_iter: 5, steps: 64, harmonics: 1}", "stiffness: 1e3", "friction: {dof: 0, mu: 0.8, normal_force: 1e308}",
])
yaml_text = st.one_of(
    st.text(max_size=200),
    st.lists(yaml_fragments, min_size=1, max_size=8).map("\n".join),
    st.binary(max_size=100).map(lambda b: b.decode("latin-1")),
)


# ----------------------------------------------------------------------------- helpers
class _Hang(Exception):
    pass


@contextlib.contextmanager
def no_hang(seconds=HANG_S):
    def handler(signum, frame):
        raise _Hang(f"example took more than {seconds} s")

    old = signal.signal(signal.SIGALRM, handler)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def run_cli(argv):
    err, out = io.StringIO(), io.StringIO()
    with no_hang(), contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def _has_empty_key(obj):
    if isinstance(obj, dict):
        return any(not str(k).strip() or _has_empty_key(v) for k, v in obj.items())
    if isinstance(obj, list):
        return any(_has_empty_key(v) for v in obj)
    return False


def key_root(key):
    return re.split(r"[.\[]", key, maxsplit=1)[0]


def names_a_key(key, text):
    """The reported key is a known key, or a key written in the input (e.g. an unknown one)."""
    if key_root(key) in KEY_ROOTS:
        return True
    if key in ("None", "True", "False", "null") or re.fullmatch(r"[-+0-9.e]+|inf|-inf|nan", key):
        return True  # a non-string YAML key (null, ?, yes, 0x10, ...) is shown by its Python value
    if len(key) >= 2 and key[0] == key[-1] and key[0] in "'\"":
        return True  # a blank or unprintable key shown as its repr (once io._keyname does so)
    name = key[:-3] if key.endswith("...") else key  # long keys are shortened by io._keyname
    return bool(name) and (name in text or key_root(name) in text)


def check_cli_result(code, out, err, out_file, case_path, text=""):
    assert "Traceback" not in err and "Traceback" not in out
    assert code in (0, 1, 2), (code, err)
    if code == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        m = re.match(r"^error: (.*?): (.+)$", lines[0])
        assert m, lines[0]
        key = m.group(1)
        if not key.strip():  # an empty key in the file is reported as "" (see test_empty_key_is_named)
            assert re.search(r"^\s*(''|\"\"|\?)", text, re.M) or ": " in text, lines[0]
            return key
        assert names_a_key(key, text) or key == str(case_path), (key, text)
        assert not os.path.exists(out_file), "exit 2 must not write a result"
        return key
    # 0 or 1: the case was valid; the result file never claims success for a failed solve
    assert os.path.exists(out_file)
    with open(out_file, encoding="utf-8") as fh:
        payload = json.load(fh)
    assert payload["success"] is (code == 0), payload
    if code == 1:
        assert err.strip().startswith("error: solve did not converge"), err
    for a in payload["amplitude"]:
        assert a is None or math.isfinite(a)
    return None


def cli_on_text(text, extra=CAPS):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "case.yaml")
        with open(path, "w", encoding="utf-8", errors="surrogatepass") as fh:
            fh.write(text)
        out_file = os.path.join(tmp, "result.json")
        code, out, err = run_cli(["solve", path, "--quiet", "--out", out_file, *extra])
        return code, check_cli_result(code, out, err, out_file, path, text)


# ----------------------------------------------------------------------------- tests
def test_base_case_is_valid_and_cheap():
    code, key = cli_on_text(yaml.safe_dump(BASE))
    assert code in (0, 1) and key is None


@FUZZ
@given(text=yaml_text)
def test_cli_random_yaml_text(text):
    cli_on_text(text)


@FUZZ
@given(case=mutated_case())
def test_cli_mutated_cases(case):
    data, first = case
    text = yaml.safe_dump(data, allow_unicode=True)
    code, key = cli_on_text(text)
    if code == 2 and first in TOP_KEYS and first not in ("masses", "M", "name"):
        # a mutated entry is reported by its own key, or by one that depends on it (sizes, cross-checks)
        assert names_a_key(key, text)


@FUZZ
@given(data=st.one_of(junk, st.dictionaries(st.sampled_from(list(TOP_KEYS) + ["x"]), junk, max_size=6),
                      mutated_case().map(lambda c: c[0])))
def test_parse_case_raises_only_input_error(data):
    with no_hang():
        try:
            case = parse_case(data, name="fuzz")
        except InputError as exc:
            # a blank key of the file (e.g. "" or "\n") is reported as itself: see test_empty_key_is_named
            assert exc.key.strip() or _has_empty_key(data), exc
            return
        # valid: a capped solve either returns (success or a diagnosis) or raises InputError
        try:
            sol = case.solve(steps=64, harmonics=1, max_iter=5)
        except InputError as exc:
            assert exc.key
            return
        assert isinstance(sol.success, bool)
        if sol.success:
            assert np.all(np.isfinite(sol.amplitude))
        else:
            assert sol.message


@FUZZ
@given(argv=st.lists(st.one_of(st.sampled_from(["solve", "--method", "hbm", "mshbm", "nope", "--steps", "--harmonics",
                                                 "-1", "0", "64", "1e3", "--out", "--quiet", "--help", "--version",
                                                 EXAMPLE, "missing.yaml", "/", "--bogus"]),
                               st.text(max_size=10)), max_size=6))
def test_cli_random_arguments(argv):
    argv = [a for a in argv if a not in ("--help", "--version")]  # those print and exit 0 (tested in test_io_cli)
    # a NUL byte cannot reach argv from a shell (C strings); the API-level defect is test_nul_byte_path
    argv = [a.replace("\x00", "") for a in argv]
    with tempfile.TemporaryDirectory() as tmp:
        # never run a full-size solve: a valid case file gets the effort caps
        if "solve" in argv and "--steps" not in argv:
            argv = argv + ["--steps", "64", "--harmonics", "1"]
        argv = [os.path.join(tmp, "o.json") if a == "--out-target" else a for a in argv]
        code, out, err = run_cli(argv)
    assert "Traceback" not in err
    assert code in (0, 1, 2), (argv, code, err)
    if code == 2:
        assert err.strip(), argv
        last = err.strip().splitlines()[-1]
        assert last.startswith("error:") or "usage:" in err, err


def test_failed_solve_writes_no_success(tmp_path):
    """A case that cannot converge in 1 iteration from its one start (no start ladder): exit 1, and the result
    file says success false."""
    data = json.loads(json.dumps(BASE))
    data["solver"]["max_iter"] = 1
    data["solver"]["tol"] = 1e-15
    data["solver"]["continuation"] = False
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    out_file = tmp_path / "r.json"
    code, out, err = run_cli(["solve", str(path), "--quiet", "--out", str(out_file), *CAPS])
    assert code == 1, err
    assert json.loads(out_file.read_text())["success"] is False


def test_failed_solve_does_not_overwrite_with_success(tmp_path):
    """An invalid case leaves an existing result file untouched (no stale success is produced either)."""
    out_file = tmp_path / "r.json"
    out_file.write_text('{"success": false}')
    path = tmp_path / "case.yaml"
    path.write_text("masses: [1, 1]\nstiffness: 1\nomega: .nan\n")
    code, out, err = run_cli(["solve", str(path), "--quiet", "--out", str(out_file)])
    assert code == 2 and err.startswith("error: omega:")
    assert json.loads(out_file.read_text()) == {"success": False}


@pytest.mark.parametrize("omega", [1e300, 1e-300,
                                   1e100, 1e-100, 1e-9, 1e10])
def test_extreme_omega_is_cheap_and_clear(tmp_path, omega):
    data = json.loads(json.dumps(BASE))
    data["omega"] = omega
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    out_file = tmp_path / "r.json"
    code, out, err = run_cli(["solve", str(path), "--quiet", "--out", str(out_file), *CAPS])
    check_cli_result(code, out, err, str(out_file), path)


def test_load_case_overrides_fuzz_keys():
    with pytest.raises(InputError) as info:
        load_case(EXAMPLE, omgea=1.0)
    assert info.value.key == "omgea"
    for key in SOLVER_KEYS:
        try:
            load_case(EXAMPLE, **{key: float("nan")})
        except InputError as exc:
            assert key_root(exc.key) in KEY_ROOTS


def test_empty_key_is_named(tmp_path):
    path = tmp_path / "case.yaml"
    path.write_text("'': 1\nmasses: [1]\nstiffness: 1\nomega: 1\n")
    code, out, err = run_cli(["solve", str(path), "--quiet"])
    assert code == 2
    assert not err.startswith("error: : "), err


def test_nul_byte_path():
    with pytest.raises(InputError):
        load_case("case\x00.yaml")
