"""``mshbm solve ... --out PATH``: writes into the path given, keeps permissions
(or the umask), writes through symlinks, FIFOs and character devices instead of replacing them,
and never overwrites the case file.  Refusals: exit code 2 and one line ``error: --out: ...``."""
import json
import os
import stat
import sys

import pytest

from mshbm.cli import main

CASE = """name: lin
M: [[2.0, 0.0], [0.0, 1.0]]
C: [[0.15, -0.05], [-0.05, 0.05]]
K: [[3.0, -1.0], [-1.0, 1.0]]
omega: 0.8
forcing: [{dof: 1, amplitude: 1.0}]
solver: {method: hbm, harmonics: 2}
"""


@pytest.fixture
def case(tmp_path):
    p = tmp_path / "case.yaml"
    p.write_text(CASE)
    return p


def run(capsys, *argv):
    code = main(["solve", *map(str, argv), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


def assert_refused(code, out, err):
    assert code == 2, (out, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --out: "), err


def assert_result(text):
    data = json.loads(text)
    assert data["case"] == "lin" and data["success"] is True and len(data["amplitude"]) == 2


@pytest.fixture
def umask():
    old = os.umask(0o022)
    yield lambda m: os.umask(m)
    os.umask(old)


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_new_file_gets_the_umask(capsys, case, tmp_path, umask, mask, mode):
    umask(mask)
    out = tmp_path / "r.json"
    assert run(capsys, case, "--out", out)[0] == 0
    assert stat.S_IMODE(os.stat(out).st_mode) == mode          # base: 0600 whatever the umask
    assert_result(out.read_text())


@pytest.mark.parametrize("mode", [0o640, 0o604, 0o755])
def test_existing_file_keeps_its_permissions(capsys, case, tmp_path, mode):
    out = tmp_path / "r.json"
    out.write_text("old")
    os.chmod(out, mode)
    assert run(capsys, case, "--out", out)[0] == 0
    assert stat.S_IMODE(os.stat(out).st_mode) == mode
    assert_result(out.read_text())


def test_symlink_is_written_through(capsys, case, tmp_path):
    target = tmp_path / "data" / "r.json"
    target.parent.mkdir()
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(os.path.join("data", "r.json"))        # relative link
    assert run(capsys, case, "--out", link)[0] == 0
    assert link.is_symlink() and os.readlink(link) == os.path.join("data", "r.json")
    assert_result(target.read_text())


def test_dangling_symlink_creates_its_target(capsys, case, tmp_path):
    link = tmp_path / "link.json"
    link.symlink_to(tmp_path / "new.json")
    assert run(capsys, case, "--out", link)[0] == 0
    assert link.is_symlink()
    assert_result((tmp_path / "new.json").read_text())


def test_hard_link_keeps_all_names(capsys, case, tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text("old")
    os.link(a, b)
    assert run(capsys, case, "--out", a)[0] == 0
    assert os.stat(a).st_ino == os.stat(b).st_ino
    assert_result(b.read_text())                               # base: b keeps "old"


def test_fifo_with_a_reader_is_written_through(capsys, case, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    rfd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)          # a reader (the JSON fits the pipe buffer)
    try:
        code = run(capsys, case, "--out", fifo)[0]
        text = os.read(rfd, 1 << 16).decode()
    finally:
        os.close(rfd)
    assert code == 0
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)             # base: replaced by a regular file
    assert_result(text)


def test_fifo_without_reader_is_refused_not_blocking(capsys, case, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    assert_refused(*run(capsys, case, "--out", fifo))
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


# Character devices and /dev/stdout are reached through links in tmp_path: run against an unsafe
# implementation (as root), a direct "--out /dev/null" would replace the machine's /dev/null.
def test_character_device_is_written_through(capsys, case, tmp_path):
    link = tmp_path / "null.json"
    link.symlink_to(os.devnull)
    assert run(capsys, case, "--out", link)[0] == 0
    assert link.is_symlink() and stat.S_ISCHR(os.stat(link).st_mode)     # base: link replaced by a file


def test_stdout_pipe_is_written_through(case, tmp_path):
    """``--out /dev/stdout`` with stdout a pipe (here via a link to /proc/self/fd/1)."""
    import subprocess

    link = tmp_path / "stdout.json"
    link.symlink_to("/proc/self/fd/1")
    proc = subprocess.run([sys.executable, "-m", "mshbm.cli", "solve", str(case), "--out", str(link),
                           "--quiet"], capture_output=True, text=True, timeout=120, env={**os.environ})
    assert proc.returncode == 0, proc.stderr
    assert link.is_symlink()
    assert_result(proc.stdout)


@pytest.mark.parametrize("how", ["same", "relative", "symlink", "hardlink", "dotdot"])
def test_case_file_is_never_overwritten(capsys, case, tmp_path, monkeypatch, how):
    monkeypatch.chdir(tmp_path)
    if how == "same":
        out = case
    elif how == "relative":
        out = "case.yaml"
    elif how == "dotdot":
        (tmp_path / "sub").mkdir()
        out = os.path.join("sub", "..", "case.yaml")
    elif how == "symlink":
        out = tmp_path / "alias.json"
        out.symlink_to(case)
    else:
        out = tmp_path / "hard.yaml"
        os.link(case, out)
    assert_refused(*run(capsys, case, "--out", out))
    assert case.read_text() == CASE


def test_directory_and_empty_path_are_refused(capsys, case, tmp_path):
    assert_refused(*run(capsys, case, "--out", tmp_path))
    assert_refused(*run(capsys, case, "--out", ""))
    assert_refused(*run(capsys, case, "--out", tmp_path / "missing" / "r.json"))


def test_socket_is_refused(capsys, case, tmp_path):
    import socket

    path = tmp_path / "s.sock"
    srv = socket.socket(socket.AF_UNIX)
    srv.bind(str(path))
    try:
        assert_refused(*run(capsys, case, "--out", path))
        assert stat.S_ISSOCK(os.lstat(path).st_mode)
    finally:
        srv.close()


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write any file")
def test_read_only_file_is_refused(capsys, case, tmp_path):
    out = tmp_path / "ro.json"
    out.write_text("keep")
    os.chmod(out, 0o444)
    assert_refused(*run(capsys, case, "--out", out))
    assert out.read_text() == "keep"
