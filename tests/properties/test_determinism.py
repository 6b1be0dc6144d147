"""Determinism: the same case and options give bit-identical results across runs and
do not depend on the number of threads.

Each solve runs in a fresh subprocess with OMP/OPENBLAS/MKL/NUMBA_NUM_THREADS = 1 or = 2 and saves
``q_hat``, ``amplitude`` and ``x``; the arrays are compared with ``np.array_equal`` (bit for bit; no
tolerance).  The cases include systems large enough for the threaded BLAS paths (dense LU of the
condensation, matrix products of the monodromy matrix and of the step matrices).
"""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import mshbm
from paper_systems import OMEGA, friction_chain, impact_chain

ROOT = Path(__file__).resolve().parents[2]
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")

#: (name, system expression, method, options) -- the expressions use tests/conftest.py
CASES = [
    ("friction3-mshbm", "friction_chain(3)", "mshbm", dict(harmonics=5, steps=2048)),
    ("friction3-hbm", "friction_chain(3)", "hbm", dict(harmonics=20)),
    # 4096 steps: certified at the default accuracy (2048: error 5.4e-3 against the event-driven flow, estimate
    # 1.01e-2)
    ("impact5-shooting", "impact_chain(5)", "shooting", dict(steps=4096)),
    ("impact50-mshbm-intermediate", "impact_chain(50)", "mshbm-intermediate", dict(harmonics=5, steps=1024)),
    ("friction120-shooting", "friction_chain(120)", "shooting", dict(steps=512, max_iter=8)),
    ("friction400-hbm-uncondensed", "friction_chain(400)", "hbm", dict(harmonics=5, condense=False)),
    ("impact300-mshbm", "impact_chain(300)", "mshbm", dict(harmonics=10, steps=1024)),
    # solve() pins BLAS to one thread by default (blas_threads=1); blas_threads=None leaves the
    # thread count to the environment (see test_threaded_lapack_paths)
    ("friction120-shooting-envthreads", "friction_chain(120)", "shooting", dict(steps=512, max_iter=8, blas_threads=None)),
    ("friction400-hbm-uncondensed-envthreads", "friction_chain(400)", "hbm", dict(harmonics=5, condense=False, blas_threads=None)),
    ("impact300-mshbm-envthreads", "impact_chain(300)", "mshbm", dict(harmonics=10, steps=1024, blas_threads=None)),
]

SCRIPT = textwrap.dedent("""
    import sys
    import numpy as np
    import mshbm
    from paper_systems import OMEGA, friction_chain, impact_chain
    out = {{}}
    for name, expr, method, opts in {cases!r}:
        sol = mshbm.solve(eval(expr), OMEGA, method, **opts)
        out[name + "/q_hat"] = sol.q_hat
        out[name + "/amplitude"] = sol.amplitude
        out[name + "/x"] = sol.x
        out[name + "/success"] = np.array(sol.success)
    np.savez(sys.argv[1], **out)
""")


def run_in_subprocess(path, threads, cases=CASES):
    env = dict(os.environ)
    # the subprocess imports tests/paper_systems.py
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "tests")] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    for v in THREAD_VARS:
        env[v] = str(threads)
    code = SCRIPT.format(cases=[(n, e, m, o) for n, e, m, o in cases])
    subprocess.run([sys.executable, "-c", code, str(path)], env=env, check=True, cwd=str(ROOT), timeout=600)
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("determinism")
    return {label: run_in_subprocess(tmp / f"{label}.npz", threads)
            for label, threads in (("t1a", 1), ("t1b", 1), ("t2", 2))}


def _compare(a, b, env_threads=False):
    assert a.keys() == b.keys()
    diff = []
    for k in sorted(a):
        if ("-envthreads/" in k) != env_threads:
            continue
        if not np.array_equal(a[k], b[k]):
            d = np.max(np.abs(a[k].astype(float) - b[k].astype(float))) if a[k].shape == b[k].shape else "shape"
            diff.append(f"{k}: max |difference| {d}")
    return diff


@pytest.mark.slow
def test_bit_identical_across_runs(runs):
    assert not _compare(runs["t1a"], runs["t1b"])


def test_bit_identical_across_thread_counts(runs):
    diff = _compare(runs["t1a"], runs["t2"])
    assert not diff, "results depend on the number of threads:\n" + "\n".join(diff)


@pytest.mark.xfail(strict=False, reason=(
    "OpenBLAS's multithreaded LU (getrf: np.linalg.inv/solve, scipy lu_factor) rounds differently with "
    "1 and 2 threads for n >~ 100 (dgemm/dgemv do not); solve(blas_threads=None) therefore depends on "
    "OMP/OPENBLAS_NUM_THREADS (e.g. friction120 shooting: ~1e-11 in x via the step matrix W = inv(S)). "
    "The default blas_threads=1 is bit-identical (test above)."))
def test_threaded_lapack_paths(runs):
    diff = _compare(runs["t1a"], runs["t2"], env_threads=True)
    assert not diff, "results with blas_threads=None depend on the thread count:\n" + "\n".join(diff)


def test_lapack_thread_dependence_root_cause():
    """The root cause in isolation: inv/solve of a 240x240 SPD matrix with 1 and 2 BLAS threads.  The solves
    are Newton from the linear start alone (``continuation=False``): two iterations through the 120-DOF step
    matrices, 0.4 s of CPU (the start ladder that followed them took 14 s per solve)."""
    from threadpoolctl import threadpool_limits

    rng = np.random.default_rng(0)
    A = rng.standard_normal((240, 240))
    S = A @ A.T + 240 * np.eye(240)
    res = {}
    for t in (1, 2):
        with threadpool_limits(t, user_api="blas"):
            res[t] = (A @ A.T, np.linalg.inv(S))
    assert np.array_equal(res[1][0], res[2][0])  # matrix products are thread-count independent
    if not np.array_equal(res[1][1], res[2][1]):  # LU may not be: then solve() must pin the threads
        with threadpool_limits(2, user_api="blas"):
            sol = mshbm.solve(friction_chain(120), OMEGA, "shooting", steps=64, max_iter=2, continuation=False)
        with threadpool_limits(1, user_api="blas"):
            ref = mshbm.solve(friction_chain(120), OMEGA, "shooting", steps=64, max_iter=2, continuation=False)
        assert np.array_equal(sol.x, ref.x)  # the default blas_threads=1 shields solve()


def test_cases_converge(runs):
    """The compared solves are real solutions (comparing failures bit for bit would prove little)."""
    for name, *_ in CASES:
        if not name.startswith("friction120-shooting"):  # capped at 8 Newton iterations: only its determinism matters
            assert bool(runs["t1a"][name + "/success"]), name


def test_bit_identical_in_process():
    """Repeated solves in one process (numba caches, module state) give identical bits."""
    for system, method, opts in ((friction_chain(3), "mshbm", dict(harmonics=3, steps=1024)),
                                 (impact_chain(5), "shooting", dict(steps=1024)),
                                 (friction_chain(3), "hbm", dict(harmonics=10))):
        a = mshbm.solve(system, OMEGA, method, **opts)
        b = mshbm.solve(system, OMEGA, method, **opts)
        for attr in ("q_hat", "x", "amplitude", "q_time", "u_time", "lam"):
            assert np.array_equal(getattr(a, attr), getattr(b, attr)), (method, attr)
