"""CLI conveniences (mshbm.cli, mshbm.cli_sweep, mshbm.io.overrides, mshbm.interrupt): ``--omega``, ``--set``,
sweeps that keep their points on Ctrl-C / SIGTERM / max_points, the numba compile notice, ``--plot`` errors."""
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml

import mshbm
from mshbm.cli import main
from tests.integration.test_io_cli import run, write_case  # noqa: F401  (the CLI helpers of the CLI tests)
from mshbm.io import load_case

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
#: Den Hartog's oscillator x'' + 0.1 x' + x = cos(omega t) - 0.3 sign(x') (continuous slip above resonance)
DH = {"name": "dh", "masses": [1], "stiffness": 1, "damping": 0.1, "omega": 2,
      "forcing": [{"dof": 0, "amplitude": 1}], "friction": {"dof": 0, "mu": 1, "normal_force": 0.3}}




def assert_input_error(code, out, err, key):
    assert code == 2, (out, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {key}: "), (lines, key)


def _env(**extra):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src")] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep)
                                                                if p])
    env.update(extra)
    return env


def _subprocess(*args, **env):
    return subprocess.run([sys.executable, "-m", "mshbm", *map(str, args)], capture_output=True, text=True,
                          timeout=300, env=_env(**env))


# ----------------------------------------------------------------------------- --omega and --set
def test_omega_and_set_equal_a_case_file_with_those_values(tmp_path, capsys):
    """``--omega 1.5 --set friction.0.normal_force=0.2`` gives the JSON of a case file written with those values
    (the same numbers to the last bit: the same solve)."""
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    code, _, err = run(capsys, "solve", write_case(tmp_path, DH), "--method", "shooting", "--steps", 1024,
                       "--omega", 1.5, "--set", "friction.0.normal_force=0.2", "--out", a, "--quiet")
    assert code == 0, err
    edited = dict(DH, omega=1.5, friction=dict(DH["friction"], normal_force=0.2))
    code, _, err = run(capsys, "solve", write_case(tmp_path, edited, "edited.yaml"), "--method", "shooting",
                       "--steps", 1024, "--out", b, "--quiet")
    assert code == 0, err
    ja, jb = json.loads(a.read_text()), json.loads(b.read_text())
    assert ja["omega"] == 1.5 and ja["amplitude"] == jb["amplitude"]
    # and different from the case file's own values
    code, _, err = run(capsys, "solve", write_case(tmp_path, DH), "--method", "shooting", "--steps", 1024,
                       "--out", b, "--quiet")
    assert json.loads(b.read_text())["amplitude"] != ja["amplitude"]


def test_set_solver_option_and_yaml_values(tmp_path):
    case = load_case(write_case(tmp_path, DH), sets=["solver.harmonics=9", "solver.method=hbm",
                                                     "forcing.0.amplitude=1e-1", "masses.0=2"])
    assert case.solver == {"harmonics": 9, "method": "hbm"}
    assert case.system.f_hat[1, 0] == 0.1 and case.system.M[0, 0] == 2.0
    # a section given as one mapping is its own entry 0; the file itself is not changed
    case = load_case(write_case(tmp_path, DH), sets={"friction.normal_force": 0.5})
    assert case.system.elements[0].normal_force == 0.5
    assert yaml.safe_load((tmp_path / "case.yaml").read_text())["friction"]["normal_force"] == 0.3


@pytest.mark.parametrize("assignment, key", [
    ("friction.0.normal_frce=2", "friction.0.normal_frce"),   # unknown element key
    ("frction.0.mu=1", "frction.0.mu"),                        # unknown section
    ("solver.harmonic=9", "solver.harmonic"),                  # unknown solver option
    ("friction.1.mu=1", "friction.1.mu"),                      # no such entry
    ("contact.0.gap=1", "contact.0.gap"),                      # no such section in the file
    ("omega.x=1", "omega.x"),                                  # a number has no entries
    ("masses.a=1", "masses.a"),                                # a list needs an index
    ("friction.0.normal_force=-1", "friction.normal_force"),   # a bad value: the case's own check
    ("nokey", "--set"),                                        # not KEY=VALUE
])
def test_set_bad_key_exit_2_naming_the_key(assignment, key, tmp_path, capsys):
    path = write_case(tmp_path, DH)
    assert_input_error(*run(capsys, "solve", path, "--set", assignment), key)
    assert_input_error(*run(capsys, "sweep", path, "--omega-start", 1, "--omega-end", 2, "--set", assignment), key)


def test_unknown_key_suggests_the_close_one(tmp_path, capsys):
    code, out, err = run(capsys, "solve", write_case(tmp_path, DH), "--set", "solver.harmonic=9")
    assert "did you mean 'harmonics'?" in err


def test_omega_errors_name_omega(tmp_path, capsys):
    path = write_case(tmp_path, DH)
    assert_input_error(*run(capsys, "solve", path, "--omega", -1), "--omega")
    code, out, err = run(capsys, "solve", path, "--omega", "fast")
    assert code == 2 and "--omega" in err and "Traceback" not in err


def test_set_in_a_subprocess(tmp_path):
    out = tmp_path / "r.json"
    proc = _subprocess("solve", write_case(tmp_path, DH), "--method", "shooting", "--steps", 512, "--quiet",
                       "--set", "friction.0.normal_force=0", "--omega", 0.5, "--out", out)
    assert proc.returncode == 0, proc.stderr
    # normal_force 0: the linear oscillator, |H| = 1 / |1 - w^2 + 0.1 i w| at w = 0.5 (Moreau-Jean: O((w h)^2))
    exact = 1.0 / abs(1 - 0.25 + 0.05j)
    assert json.loads(out.read_text())["amplitude"][0] == pytest.approx(exact, rel=1e-4)
    proc = _subprocess("solve", write_case(tmp_path, DH), "--set", "friction.0.normal_forc=1")
    assert proc.returncode == 2 and proc.stderr.startswith("error: friction.0.normal_forc: unknown key")
    assert len(proc.stderr.strip().splitlines()) == 1


# ----------------------------------------------------------------------------- --plot errors
def test_plot_errors_name_plot(tmp_path, capsys):
    path = write_case(tmp_path, DH)
    base = ["sweep", path, "--omega-start", 1.5, "--omega-end", 2.5]
    assert_input_error(*run(capsys, *base, "--plot", tmp_path / "no" / "b.png"), "--plot")
    assert_input_error(*run(capsys, *base, "--plot", tmp_path), "--plot")
    assert_input_error(*run(capsys, *base, "--plot", path), "--plot")  # never the case file
    assert_input_error(*run(capsys, *base, "--out", tmp_path / "no" / "b.json"), "--out")


# ----------------------------------------------------------------------------- max_points and interrupts
def test_max_points_writes_json_and_plot_exit_1(tmp_path, capsys):
    out, png = tmp_path / "b.json", tmp_path / "b.png"
    code, _, err = run(capsys, "sweep", write_case(tmp_path, DH), "--method", "shooting", "--steps", 1024,
                       "--omega-start", 1.5, "--omega-end", 2.5, "--max-points", 3, "--out", out, "--plot", png,
                       "--quiet")
    assert code == 1 and err.startswith("error: sweep stopped early: stopped after 3 points (max_points)")
    data = json.loads(out.read_text())
    assert data["success"] is False and len(data["omega"]) == 3 and data["omega"][0] == 1.5
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupted_sweep_writes_its_points(sig, code, tmp_path):
    """A running sweep gets SIGINT (Ctrl-C) or SIGTERM after its 4th point: it writes the points so far (JSON and
    plot, ``success`` false, ``counters.interrupted``) and exits 130 / 143; the points are the branch's (the
    first one equals a solve at the start frequency)."""
    out, png = tmp_path / "b.json", tmp_path / "b.png"
    argv = ["sweep", write_case(tmp_path, DH), "--method", "shooting", "--steps", 2048, "--omega-start", 0.5,
            "--omega-end", 4, "--max-points", 400, "--out", out, "--plot", png]
    # SIGINT back to its default in the child: a shell's background job (nohup ... &) starts with SIGINT ignored, and
    # Python then installs no KeyboardInterrupt handler, so the test measured the launcher, not the CLI
    proc = subprocess.Popen([sys.executable, "-m", "mshbm", *map(str, argv)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=_env(),
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    watchdog = threading.Timer(240, proc.kill)
    watchdog.start()
    try:
        seen = b""
        while b"points    4 " not in seen:
            chunk = proc.stderr.read1(4096)
            if not chunk:
                break
            seen += chunk
        assert b"points    4 " in seen, seen.decode(errors="replace")[-2000:]
        proc.send_signal(sig)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        watchdog.cancel()
    stderr = (seen + stderr).decode(errors="replace")
    assert proc.returncode == code, stderr[-2000:]
    assert "Traceback" not in stderr
    last = stderr.strip().splitlines()[-1]
    assert last.startswith("error: interrupted after ") and ("SIGTERM" if code == 143 else "SIGINT") in last
    data = json.loads(out.read_text())
    n = len(data["omega"])
    assert data["success"] is False and data["counters"]["interrupted"] is True
    assert 4 <= n < 400 and data["omega"][0] == 0.5 and data["omega"][-1] < 4
    assert len(data["amplitude"]) == len(data["stable"]) == len(data["points"]) == n
    assert data["message"].startswith(f"interrupted after {n} points")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ref = mshbm.solve(load_case(tmp_path / "case.yaml").system, 0.5, "shooting", steps=2048)
    assert data["amplitude"][0][0] == pytest.approx(float(ref.amplitude[0]), rel=1e-9)


def test_api_interrupt_carries_the_branch(monkeypatch):
    """In the API the interrupt is a KeyboardInterrupt (a script still stops) carrying the points so far."""
    from mshbm import chain, Friction
    from mshbm.interrupt import SweepInterrupted

    s = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Friction(0, 1.0, 0.3)])
    calls = {"n": 0}
    import mshbm.branch as branch

    real = branch._Tracer.point

    def point(self, *args, **kw):  # Ctrl-C while the 4th point is being certified
        calls["n"] += 1
        if calls["n"] == 4:
            raise KeyboardInterrupt
        return real(self, *args, **kw)

    monkeypatch.setattr(branch._Tracer, "point", point)
    with pytest.raises(KeyboardInterrupt) as info:
        mshbm.sweep(s, 1.5, 2.5, "shooting", steps=1024)
    assert isinstance(info.value, SweepInterrupted)
    b = info.value.branch
    assert len(b) == 3 and not b.success and b.counters["interrupted"] and b.omega[0] == 1.5
    assert b.message.startswith("interrupted after 3 points")


# ----------------------------------------------------------------------------- the numba notice
def test_compile_notice_only_when_numba_compiles(tmp_path):
    """With an empty numba cache (NUMBA_CACHE_DIR) the kernels compile: one notice line on stderr; the second
    run loads them from that cache: stderr stays empty.  ``--quiet`` never prints it."""
    cache = tmp_path / "numba-cache"
    cache.mkdir()
    args = ("solve", EXAMPLES / "linear_matrices.yaml", "--method", "hbm", "--out", tmp_path / "r.json")
    t = time.perf_counter()
    cold = _subprocess(*args, NUMBA_CACHE_DIR=str(cache))
    assert cold.returncode == 0, cold.stderr
    lines = cold.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mshbm: compiling numba kernels"), cold.stderr
    assert any(cache.iterdir())  # it did compile into the empty cache
    warm = _subprocess(*args, NUMBA_CACHE_DIR=str(cache))
    assert warm.returncode == 0 and warm.stderr == "", warm.stderr
    cache2 = tmp_path / "numba-cache-2"
    cache2.mkdir()
    quiet = _subprocess(*args, "--quiet", NUMBA_CACHE_DIR=str(cache2))
    assert quiet.returncode == 0 and quiet.stderr == "" and any(cache2.iterdir())
    assert time.perf_counter() - t < 600
