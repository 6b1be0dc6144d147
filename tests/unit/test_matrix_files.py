"""Matrices from files (mshbm.io.matrices): .mtx/.npz give bit for bit the solution of the same chain
built inline, Rayleigh damping, and one clear line naming the key (exit 2) for every bad matrix file."""
import copy
import shutil
import subprocess
import sys
import zipfile

import numpy as np
from tests import discretised
import pytest
import scipy.io as sio
import scipy.sparse as sp
import yaml

from mshbm import InputError, System
from mshbm.cli import main
from mshbm.io import load_case, parse_case
from mshbm.io import matrices as mio

FRICTION_CHAIN = {
    "name": "chain",
    "masses": [1.0, 1.3, 0.7, 1.1],
    "stiffness": [1.0, 0.9, 1.2, 0.8],
    "damping": [0.05, 0.02, 0.03, 0.01],
    "omega": 0.7,
    "forcing": [{"dof": 3, "amplitude": 2.0}],
    "friction": {"dof": 0, "mu": 0.3, "normal_force": 1.0, "smoothing": 800},
    "solver": {"harmonics": 3, "steps": 512},
}
CONTACT_CHAIN = {
    "name": "impact",
    "masses": [3.0, 1.0, 1.0],
    "stiffness": 1.0,
    "damping": 0.1,
    "omega": 0.6,
    "forcing": [{"dof": 2, "amplitude": 1.0}],
    "contact": {"dof": 0, "gap": 0.2},
    "solver": {"harmonics": 3, "steps": 512},
}
METHODS = ["mshbm", "hbm", "shooting", "mshbm-intermediate"]
ARRAYS = ("x", "q_hat", "q_time", "u_time", "lam", "t")


def write_yaml(path, data):
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def to_files(tmp_path, chain_data, ext, sub="mats"):
    """Write the chain's M, C, K as files (in a subdirectory) and a case file referring to them."""
    s = parse_case(copy.deepcopy(chain_data)).system
    d = tmp_path / sub
    d.mkdir(exist_ok=True)
    for name in "MCK":
        A = sp.csr_matrix(s.dense(name))
        if ext == ".mtx":
            sio.mmwrite(d / f"{name}.mtx", A)
        else:
            sp.save_npz(d / f"{name}.npz", A)
    data = {k: v for k, v in chain_data.items() if k not in ("masses", "stiffness", "damping")}
    data.update(M=f"{sub}/M{ext}", C=f"{sub}/C{ext}", K=f"{sub}/K{ext}")
    return write_yaml(tmp_path / f"files{ext.replace('.', '_')}.yaml", data)


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_input_error(code, out, err, key):
    assert code == 2, (out, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"error: {key}: "), (lines[0], key)


# ----------------------------------------------------------------------------- bit for bit
@pytest.mark.parametrize("ext", [".mtx", ".npz"])
@pytest.mark.parametrize("chain_data", [FRICTION_CHAIN, CONTACT_CHAIN], ids=["friction", "contact"])
def test_matrix_files_bit_for_bit(chain_data, ext, tmp_path):
    inline = load_case(write_yaml(tmp_path / "inline.yaml", chain_data))
    files = load_case(to_files(tmp_path, chain_data, ext))
    for name in "MCK":
        a, b = getattr(inline.system, name), getattr(files.system, name)
        assert type(a) is type(b) and np.array_equal(a, b)
    for method in METHODS:
        # the discretised equations (accuracy=False): the test is that files and inline give the same bits
        r1, r2 = inline.solve(method, accuracy=False), files.solve(method, accuracy=False)
        assert r1.success and r2.success, (method, r1.message, r2.message)
        for arr in ARRAYS:
            assert np.array_equal(getattr(r1, arr), getattr(r2, arr)), (method, arr)
        assert r1.iterations == r2.iterations and r1.residual == r2.residual


def test_large_chain_files_stay_sparse_and_match(tmp_path):
    """n > 200: the inline chain is sparse (chain's rule) and so are the matrices read from files."""
    n = 300
    data = {"masses": [1.0] * n, "stiffness": 1.0, "damping": 0.01, "omega": 0.01,
            "forcing": [{"dof": n - 1, "amplitude": 0.1}],
            "friction": {"dof": 0, "mu": 0.3, "normal_force": 1.0}, "solver": {"harmonics": 2}}
    inline = load_case(write_yaml(tmp_path / "inline.yaml", data))
    files = load_case(to_files(tmp_path, data, ".npz"))
    for name in "MCK":
        a, b = getattr(inline.system, name), getattr(files.system, name)
        assert sp.isspmatrix_csr(a) and sp.isspmatrix_csr(b)
        assert (a != b).nnz == 0
    for method in ("mshbm", "hbm"):
        r1, r2 = inline.solve(method), files.solve(method)
        assert r1.success and r2.success
        assert np.array_equal(r1.x, r2.x) and np.array_equal(r1.q_hat, r2.q_hat)


def test_mixed_inline_and_file_and_absolute_path(tmp_path):
    s = parse_case(copy.deepcopy(FRICTION_CHAIN)).system
    sio.mmwrite(tmp_path / "K.mtx", sp.csr_matrix(s.dense("K")))
    data = {k: v for k, v in FRICTION_CHAIN.items() if k not in ("masses", "stiffness", "damping")}
    data.update(M=s.dense("M").tolist(), C=s.dense("C").tolist(), K=str(tmp_path / "K.mtx"))
    sub = tmp_path / "elsewhere"
    sub.mkdir()
    case = load_case(write_yaml(sub / "case.yaml", data))  # absolute path, case in another dir
    assert np.array_equal(case.system.K, s.dense("K"))
    data["K"] = "../K.mtx"  # relative to the case file, leaving its directory
    assert np.array_equal(load_case(write_yaml(sub / "case.yaml", data)).system.K, s.dense("K"))


# ----------------------------------------------------------------------------- Rayleigh
def test_rayleigh_damping_matrices_and_chain(tmp_path):
    s = parse_case(copy.deepcopy(FRICTION_CHAIN)).system
    M, K = s.dense("M"), s.dense("K")
    data = {k: v for k, v in FRICTION_CHAIN.items() if k not in ("masses", "stiffness", "damping")}
    data.update(M=M.tolist(), K=K.tolist(), damping={"alpha": 0.02, "beta": 0.03})
    mat = parse_case(copy.deepcopy(data)).system
    assert np.array_equal(mat.C, 0.02 * M + 0.03 * K)
    chain_data = {**FRICTION_CHAIN, "damping": {"alpha": 0.02, "beta": 0.03}}
    ch = parse_case(copy.deepcopy(chain_data)).system
    assert np.array_equal(ch.C, 0.02 * M + 0.03 * K)
    assert np.array_equal(parse_case({**chain_data, "damping": {"beta": 0.03}}).system.C, 0.03 * K)
    assert not np.any(parse_case({**chain_data, "damping": {}}).system.C)
    # Rayleigh with matrix files, sparse: the same C
    big = {"masses": [1.0] * 250, "stiffness": 2.0, "omega": 0.1, "forcing": [{"dof": 249, "amplitude": 1}]}
    path = to_files(tmp_path, big, ".mtx")
    d = yaml.safe_load(path.read_text())
    del d["C"]
    d["damping"] = {"alpha": 0.1, "beta": 0.01}
    sysf = load_case(write_yaml(path, d)).system
    sysc = parse_case({**big, "damping": {"alpha": 0.1, "beta": 0.01}}).system
    assert sp.issparse(sysf.C) and (sysf.C != sysc.C).nnz == 0


# ----------------------------------------------------------------------------- bad input
def _files_case(tmp_path, **changes):
    path = to_files(tmp_path, FRICTION_CHAIN, ".mtx")
    data = yaml.safe_load(path.read_text())
    for k, v in changes.items():
        if v is None:
            data.pop(k, None)
        else:
            data[k] = v
    return write_yaml(path, data)


def _write(tmp_path, name, content):
    p = tmp_path / "mats" / name
    p.parent.mkdir(exist_ok=True)
    p.write_bytes(content if isinstance(content, bytes) else content.encode())
    return f"mats/{name}"


def _bad_cases(tmp_path):
    eye3 = sp.identity(3, format="csr")
    sio.mmwrite(tmp_path / "eye3.mtx", eye3)
    sp.save_npz(tmp_path / "eye3.npz", eye3)
    sio.mmwrite(tmp_path / "rect.mtx", sp.csr_matrix(np.ones((4, 3))))
    np.savez(tmp_path / "dense.npz", a=np.eye(4))
    sio.mmwrite(tmp_path / "nonsym.mtx", sp.csr_matrix(np.diag([1.0, 2.0, 3.0, 4.0]) + np.eye(4, k=1)))
    sio.mmwrite(tmp_path / "indef.mtx", sp.csr_matrix(np.diag([1.0, -2.0, 3.0, 4.0])))
    sio.mmwrite(tmp_path / "cplx.mtx", sp.csr_matrix(np.eye(4) * (1 + 1j)))
    (tmp_path / "adir.mtx").mkdir()
    return [
        ("missing-file", {"K": "mats/nope.mtx"}, "K"),
        ("garbage-mtx", {"M": _write(tmp_path, "g.mtx", "hello world\n1 2 3\n")}, "M"),
        ("truncated-mtx", {"K": _write(tmp_path, "t.mtx", "%%MatrixMarket matrix coordinate real general\n"
                                                          "4 4 5\n1 1 1.0\n2 2 x\n")}, "K"),
        ("garbage-npz", {"C": _write(tmp_path, "g.npz", b"PK\x03\x04 not a zip")}, "C"),
        ("npz-not-sparse", {"M": str(tmp_path / "dense.npz")}, "M"),
        ("non-square", {"K": str(tmp_path / "rect.mtx")}, "K"),
        ("size-mismatch-mtx", {"K": str(tmp_path / "eye3.mtx")}, "K"),
        ("size-mismatch-npz", {"C": str(tmp_path / "eye3.npz")}, "C"),
        ("M-non-symmetric", {"M": str(tmp_path / "nonsym.mtx")}, "M"),
        ("M-not-positive-definite", {"M": str(tmp_path / "indef.mtx")}, "M"),
        ("complex-mtx", {"K": str(tmp_path / "cplx.mtx")}, "K"),
        ("unsupported-extension", {"M": _write(tmp_path, "M.txt", "1 0\n0 1\n")}, "M"),
        ("no-extension", {"K": "eye"}, "K"),
        ("directory", {"K": str(tmp_path / "adir.mtx")}, "K"),
        ("empty-path", {"K": ""}, "K"),
        ("rayleigh-negative", {"damping": {"alpha": -0.1, "beta": 0.0}, "C": None}, "damping.alpha"),
        ("rayleigh-negative-beta", {"damping": {"beta": -1e-3}, "C": None}, "damping.beta"),
        ("rayleigh-unknown-key", {"damping": {"alpha": 0.1, "gamma": 1.0}, "C": None}, "damping.gamma"),
        ("rayleigh-string", {"damping": {"alpha": "0.1"}, "C": None}, "damping.alpha"),
        ("rayleigh-and-C", {"damping": {"alpha": 0.1}}, "damping"),
        ("number-damping-with-matrices", {"damping": 0.1, "C": None}, "M"),
    ]


def test_bad_matrix_files_exit_2(tmp_path, capsys):
    for label, changes, key in _bad_cases(tmp_path):
        path = _files_case(tmp_path, **changes)
        code, out, err = run(capsys, "solve", path)
        assert_input_error(code, out, err, key)
        with pytest.raises(InputError) as info:
            load_case(path)
        assert info.value.key == key, label


def test_chain_rayleigh_bad_input(tmp_path, capsys):
    for damping, key in [({"alpha": -1}, "damping.alpha"), ({"a": 1}, "damping.a"),
                         ({"beta": float("nan")}, "damping.beta")]:
        path = write_yaml(tmp_path / "c.yaml", {**FRICTION_CHAIN, "damping": damping})
        assert_input_error(*run(capsys, "solve", path), key)


def test_limits_checked_before_reading(tmp_path, monkeypatch, capsys):
    """A header declaring too many entries, a file over the byte limit, a zip bomb: refused unread."""
    p = tmp_path / "huge.mtx"
    p.write_text(f"%%MatrixMarket matrix coordinate real general\n10 10 {mio.MAX_VALUES + 1}\n1 1 1.0\n")
    read = []
    monkeypatch.setattr(sio, "mmread", lambda *a, **k: read.append(a))
    with pytest.raises(InputError, match="entries") as info:
        mio.read_matrix_file("K", str(p))
    assert info.value.key == "K" and not read
    p.write_text(f"%%MatrixMarket matrix coordinate real general\n{mio.MAX_VALUES + 1} "
                 f"{mio.MAX_VALUES + 1} 1\n1 1 1.0\n")
    with pytest.raises(InputError, match="rows"):
        mio.read_matrix_file("K", str(p))
    monkeypatch.undo()
    # byte limit: a sparse file (no disk use) larger than the limit
    big = tmp_path / "big.mtx"
    with open(big, "wb") as fh:
        fh.truncate(mio.MAX_MATRIX_FILE_BYTES + 1)
    with pytest.raises(InputError, match="limited to") as info:
        mio.read_matrix_file("M", str(big))
    assert info.value.key == "M"
    # zip bomb: a member that inflates beyond the limit is refused from the zip directory
    bomb = tmp_path / "bomb.npz"
    with zipfile.ZipFile(bomb, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        with zf.open("data.npy", "w", force_zip64=True) as fh:
            chunk = b"\0" * 2**20
            for _ in range(mio._NPZ_MEMBER_BYTES // 2**20 + 1):
                fh.write(chunk)
        zf.writestr("format.npy", b"")
    assert bomb.stat().st_size < 2**20
    with pytest.raises(InputError, match="unpacks to") as info:
        mio.read_matrix_file("C", str(bomb))
    assert info.value.key == "C"


def test_large_sparse_mass_positive_definite_check():
    """n > 3000, not diagonally dominant: the symmetric sparse factorisation decides (fast)."""
    from mshbm.system import _check_positive_definite
    n = 4000
    off = np.ones(n - 1)
    pd = sp.diags([off, 2.01 * np.ones(n), off], [-1, 0, 1], format="csr")       # eigenvalues > 0.01
    indefinite = sp.diags([off, 1.5 * np.ones(n), off], [-1, 0, 1], format="csr")  # eigenvalues down to -0.5
    _check_positive_definite(pd)
    with pytest.raises(InputError, match="positive definite") as info:
        _check_positive_definite(indefinite)
    assert info.value.key == "M"


# ----------------------------------------------------------------------------- malformed raw arrays
def _raw(A, fmt):
    """The arrays scipy.sparse.save_npz writes for ``A`` in format ``fmt`` (a dict, to corrupt)."""
    B = sp.csr_matrix(A).asformat(fmt)
    out = {"format": np.array(fmt), "shape": np.array(B.shape)}
    if fmt in ("csr", "csc", "bsr"):
        out.update(data=B.data, indices=B.indices, indptr=B.indptr)
    elif fmt == "dia":
        out.update(data=B.data, offsets=B.offsets)
    else:
        out.update(data=B.data, row=B.row, col=B.col)
    return out


def _malformed(K):
    """(label, {member: array or None to drop}) of .npz files written from ``K`` (4x4 tridiagonal)."""
    csr = _raw(K, "csr")
    nnz = csr["data"].size

    def csr_with(**kw):
        return {**csr, **kw}

    def edit(arr, i, v):
        arr = arr.copy()
        arr[i] = v
        return arr

    coo = _raw(K, "coo")
    bsr = sp.bsr_matrix(sp.csr_matrix(K), blocksize=(2, 2))
    bsr = {"format": np.array("bsr"), "shape": np.array(bsr.shape), "data": bsr.data, "indices": bsr.indices,
           "indptr": bsr.indptr}
    dia = _raw(K, "dia")
    return [
        ("csr-index-too-large", csr_with(indices=edit(csr["indices"], 1, 9))),
        ("csr-index-negative", csr_with(indices=edit(csr["indices"], 0, -3))),
        ("csr-indptr-not-monotone", csr_with(indptr=edit(csr["indptr"], 2, 1))),
        ("csr-indptr-wrong-length", csr_with(indptr=csr["indptr"][:-1])),
        ("csr-indptr-not-from-0", csr_with(indptr=csr["indptr"] + 1)),
        ("csr-indptr-last-not-nnz", csr_with(indptr=edit(csr["indptr"], -1, nnz - 1))),
        ("csr-indptr-beyond-nnz", csr_with(indptr=edit(csr["indptr"], 2, nnz + 5))),
        ("csr-data-indices-lengths", csr_with(data=csr["data"][:-1])),
        ("csr-float-indices", csr_with(indices=csr["indices"].astype(float))),
        ("csr-2d-data", csr_with(data=csr["data"].reshape(1, -1))),
        ("csr-missing-indptr", csr_with(indptr=None)),
        ("csr-nan", csr_with(data=edit(csr["data"], 0, np.nan))),
        ("csr-inf", csr_with(data=edit(csr["data"], 3, -np.inf))),
        ("csr-complex", csr_with(data=csr["data"].astype(complex))),
        ("csr-text-data", csr_with(data=np.array(["a"] * nnz))),
        ("csc-index-too-large", {**_raw(K, "csc"), "indices": edit(_raw(K, "csc")["indices"], -1, 4)}),
        ("coo-row-too-large", {**coo, "row": edit(coo["row"], 0, 4)}),
        ("coo-col-negative", {**coo, "col": edit(coo["col"], 2, -1)}),
        ("coo-lengths", {**coo, "col": coo["col"][:-1]}),
        ("coo-coords-too-large", {**coo, "row": None, "col": None,
                                  "coords": np.array([coo["row"], edit(coo["col"], 0, 7)])}),
        ("bsr-index-too-large", {**bsr, "indices": edit(bsr["indices"], 0, 2)}),
        ("bsr-blocks-do-not-tile", {**bsr, "data": np.ones((bsr["data"].shape[0], 3, 3))}),
        ("bsr-indptr-last-not-nnz", {**bsr, "indptr": np.array([0, 2, 1])}),
        ("dia-offset-outside", {**dia, "offsets": edit(dia["offsets"], 0, 4)}),
        ("dia-offsets-repeated", {**dia, "offsets": np.full_like(dia["offsets"], 0)}),
        ("dia-offsets-count", {**dia, "offsets": dia["offsets"][:-1]}),
        ("shape-smaller-than-indices", {**csr, "shape": np.array([3, 3]), "indptr": csr["indptr"][:4]}),
    ]


def _write_npz(path, arrays):
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})
    return path


@pytest.fixture
def malformed_files(tmp_path):
    """(label, case path) for every malformed K.npz, the other matrices good .mtx files."""
    K = parse_case(copy.deepcopy(FRICTION_CHAIN)).system.dense("K")
    out = []
    for label, arrays in _malformed(K):
        _write_npz(tmp_path / f"{label}.npz", arrays)
        out.append((label, _files_case(tmp_path, K=str(tmp_path / f"{label}.npz"))))
        shutil.copy(out[-1][1], tmp_path / f"{label}.yaml")
        out[-1] = (label, tmp_path / f"{label}.yaml")
    return out


def test_good_raw_arrays_read_as_save_npz(tmp_path):
    """The raw arrays of every format, written with numpy.savez, read as the matrix itself."""
    K = parse_case(copy.deepcopy(FRICTION_CHAIN)).system.dense("K")
    for fmt in ("csr", "csc", "coo", "bsr", "dia"):
        A = mio.read_matrix_file("K", str(_write_npz(tmp_path / f"{fmt}.npz", _raw(K, fmt))))
        assert np.array_equal(A.toarray(), K), fmt
    coo = _raw(K, "coo")
    coords = {**coo, "coords": np.array([coo.pop("row"), coo.pop("col")])}
    A = mio.read_matrix_file("K", str(_write_npz(tmp_path / "coords.npz", coords)))
    assert np.array_equal(A.toarray(), K)


def test_malformed_npz_is_an_input_error_naming_the_key(malformed_files, capsys):
    for label, path in malformed_files:
        with pytest.raises(InputError) as info:
            load_case(path)
        assert info.value.key == "K", (label, str(info.value))
        code, out, err = run(capsys, "solve", path)
        assert_input_error(code, out, err, "K")


@pytest.mark.parametrize("label", ["csr-index-too-large", "csr-indptr-not-monotone", "coo-row-too-large"])
def test_malformed_npz_cli_process_exit_2(malformed_files, label):
    """A real process: exit 2 and one line naming the key (no crash after 'success')."""
    path = dict(malformed_files)[label]
    proc = subprocess.run([sys.executable, "-m", "mshbm", "solve", str(path)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2, (proc.returncode, proc.stdout[-300:], proc.stderr[-300:])
    assert "Traceback" not in proc.stdout + proc.stderr and "success" not in proc.stdout
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()]
    assert proc.stderr.startswith("error: K: ")


def test_malformed_mtx_is_an_input_error_naming_the_key(tmp_path, capsys):
    head = "%%MatrixMarket matrix coordinate real general\n4 4 4\n"
    cases = {
        "row-too-large": head + "1 1 1.0\n2 2 1.0\n3 3 1.0\n5 4 1.0\n",
        "index-zero": head + "0 1 1.0\n2 2 1.0\n3 3 1.0\n4 4 1.0\n",
        "nan": head + "1 1 nan\n2 2 1.0\n3 3 1.0\n4 4 1.0\n",
        "inf": head + "1 1 1.0\n2 2 inf\n3 3 1.0\n4 4 1.0\n",
        "overflow": head + "1 1 1.0\n2 2 1.0\n3 3 1e400\n4 4 1.0\n",
        "array-nan": "%%MatrixMarket matrix array real general\n4 4\n" + "1\n0\n0\n0\n" * 3 + "0\n0\n0\nnan\n",
    }
    for label, text in cases.items():
        p = tmp_path / f"{label}.mtx"
        p.write_text(text)
        with pytest.raises(InputError) as info:
            mio.read_matrix_file("C", str(p))
        assert info.value.key == "C", label
        path = _files_case(tmp_path, C=str(p))
        assert_input_error(*run(capsys, "solve", path), "C")


# ----------------------------------------------------------------------------- symmetry of M, C, K
def test_non_symmetric_matrices_are_input_errors(tmp_path, capsys):
    """Circulatory (skew K) and gyroscopic (skew C) terms, from files and inline: exit 2 naming the
    key, with the measured relative asymmetry and the tolerance in the message."""
    s = parse_case(copy.deepcopy(FRICTION_CHAIN)).system
    skew = np.zeros((4, 4))
    skew[0, 1], skew[1, 0] = 0.05, -0.05
    for name in "CK":
        A = s.dense(name) + skew
        sp.save_npz(tmp_path / f"{name}skew.npz", sp.csr_matrix(A))
        file_case = _files_case(tmp_path, **{name: str(tmp_path / f"{name}skew.npz")})
        data = {k: v for k, v in FRICTION_CHAIN.items() if k not in ("masses", "stiffness", "damping")}
        data.update(M=s.dense("M").tolist(), C=s.dense("C").tolist(), K=s.dense("K").tolist())
        data[name] = A.tolist()
        inline_case = write_yaml(tmp_path / f"inline_{name}.yaml", data)
        for path in (file_case, inline_case):
            with pytest.raises(InputError, match=r"relative asymmetry .* exceeds 1e-10") as info:
                load_case(path)
            assert info.value.key == name
            code, out, err = run(capsys, "solve", path)
            assert_input_error(code, out, err, name)
        proc = subprocess.run([sys.executable, "-m", "mshbm", "solve", str(inline_case)], capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 2 and proc.stderr.startswith(f"error: {name}: ")
        assert proc.stderr.strip().splitlines() == [proc.stderr.strip()] and "Traceback" not in proc.stderr
    # the API too, dense and sparse; rounding-level asymmetry is accepted
    M, C, K = (s.dense(k) for k in "MCK")
    for key, mats in (("K", (M, C, K + skew)), ("C", (M, C + skew, K)),
                      ("K", (M, C, sp.csr_matrix(K + skew))), ("C", (M, sp.csr_matrix(C + skew), K))):
        with pytest.raises(InputError) as info:
            System(*mats, s.f_hat)
        assert info.value.key == key
    tiny = np.zeros((4, 4))
    tiny[0, 1] = 1e-13 * np.abs(K).max()
    System(M, C + tiny * np.abs(C).max() / np.abs(K).max(), K + tiny, s.f_hat)
