"""pyHarm plumbing shared by ``bench_pyharm.py`` and ``bench_pyharm_sweep.py``: pyHarm's environment and
our systems as pyHarm models.

pyHarm (``pyHarm-os``, Safran) pins an old jax, so it lives in its own virtual environment: the workflow
builds it (rule ``pyharm_env``: ``envs/pyharm`` from ``workflow/envs/pyharm.txt``) and passes
``--pyharm-python``; ``$PYHARM_PYTHON`` overrides both (default without either:
``envs/pyharm/bin/python``).  A benchmark run from our environment re-runs itself with that interpreter
(:func:`dispatch`), with this repository's ``src`` and ``workflow/lib`` on ``PYTHONPATH`` (mshbm needs only numpy, scipy, numba,
pyyaml and threadpoolctl, which that environment has), so that both codes are timed side by side in one
process.  If pyHarm cannot be run, the benchmark's JSON gets ``"status": "unavailable"`` with the error
text and its PNG says so (:func:`unavailable`).

Models (:func:`model_input`): one ``substructure`` with our ``M, C, K`` (one DOF per node, ``G = 0``), a
``CosinusForcing`` on the forced DOF of ``system.f_hat`` (harmonic 1), our first element as a connector to
the ground (:func:`connector`), system ``Base`` without adimensionalisation.
"""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

from mshbm_workflow import benchlib as bl

__all__ = ["DEFAULT_PYHARM_PYTHON", "REPO_SRC", "add_argument", "connector", "dispatch", "model_input",
           "mshbm_parent", "prepare", "unavailable"]

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_SRC = os.path.normpath(os.path.join(HERE, "..", "..", "..", "src"))
#: the directory holding this package (workflow/lib), for the pyHarm child process
LIB = os.path.dirname(HERE)
DEFAULT_PYHARM_PYTHON = os.path.join("envs", "pyharm", "bin", "python")


# ----------------------------------------------------------------------------- environment
def mshbm_parent():
    """Directory holding the ``mshbm`` package this interpreter imports (for the pyHarm child process;
    the workflow may run from a copy without ``src/``)."""
    try:
        import mshbm
    except ImportError:
        return REPO_SRC
    return os.path.dirname(os.path.dirname(os.path.abspath(mshbm.__file__)))


def add_argument(ap):
    """``--pyharm-python`` on a benchmark's argument parser."""
    ap.add_argument("--pyharm-python", default=None,
                    help=f"interpreter with pyHarm ($PYHARM_PYTHON overrides; default {DEFAULT_PYHARM_PYTHON})")


def unavailable(out, benchmark, what, error, figure_text, extra=None):
    """Write the JSON of a benchmark that could not compare with pyHarm, and a PNG that says why.

    Parameters
    ----------
    out : str
        Output JSON path (the PNG goes next to it).
    benchmark : str
        ``"pyharm"`` or ``"pyharm_sweep"``.
    what, error : str
        The step that failed and its error text.
    figure_text : str
        Start of the PNG's sentence (``"<figure_text>: <what>"``).
    extra : dict, optional
        More top-level fields (before the summary).
    """
    data = {"benchmark": benchmark, "status": "unavailable", "what_failed": what, "error": error,
            "machine": bl.machine_info()}
    if extra:
        data.update(extra)
    data["summary"] = {"status": "unavailable", "what_failed": what, "error": error}
    out = bl.write_json(out, data)
    plt = bl.pyplot()
    fig, ax = plt.subplots(figsize=(6, 1.6))
    ax.axis("off")
    ax.text(0.5, 0.5, f"{figure_text}: {what}", ha="center", va="center", fontsize=9, wrap=True)
    fig.savefig(bl.plot_path(out), dpi=100)
    plt.close(fig)
    print(f"pyHarm unavailable: {what}\n{error}")
    return data


def prepare(fail):
    """In pyHarm's environment, before the measurements: import pyHarm and mshbm, silence pyHarm's logging
    and warnings.  Returns the ``pyHarm`` module, or ``fail(what, error)``'s value (a benchmark's
    unavailable JSON) with ``None`` as ``(None, value)``: ``(pyHarm, None)`` on success."""
    try:
        import pyHarm
    except Exception as exc:  # pragma: no cover - depends on the environment
        return None, fail("import pyHarm", f"{type(exc).__name__}: {exc}")
    try:
        import mshbm  # noqa: F401
    except Exception as exc:
        return None, fail("import mshbm in the pyHarm environment (needs numpy, scipy, numba, pyyaml, "
                          "threadpoolctl)", f"{type(exc).__name__}: {exc}")
    import logging
    import warnings

    logging.disable(logging.CRITICAL)  # pyHarm logs every solve and step
    warnings.filterwarnings("ignore")
    return pyHarm, None


def dispatch(args, script, child_args, run_here, fail):
    """A pyHarm benchmark's ``main``: :func:`run_here` (``run_here(args)``) where pyHarm imports, else the
    script re-run with pyHarm's interpreter (``$PYHARM_PYTHON``, ``args.pyharm_python`` or
    :data:`DEFAULT_PYHARM_PYTHON`) as ``script --out args.out *child_args``.  ``fail(what, error)`` writes
    the benchmark's unavailable outputs (no interpreter, pyHarm missing in it, the child failed before
    writing its JSON)."""
    try:
        import pyHarm  # noqa: F401
    except ImportError as exc:
        first_error = f"{type(exc).__name__}: {exc}"
    else:
        return run_here(args)
    py = os.environ.get("PYHARM_PYTHON") or args.pyharm_python or DEFAULT_PYHARM_PYTHON
    if os.environ.get("_BENCH_PYHARM_CHILD"):
        return fail(f"import pyHarm with {sys.executable}", first_error)
    if not os.path.exists(py):
        return fail("find a Python with pyHarm", f"{first_error} (in {sys.executable}); "
                    f"{py} does not exist (create it: snakemake --cores 1 "
                    f"{os.path.join('envs', 'pyharm', 'installed.txt')}, or set $PYHARM_PYTHON)")
    env = dict(os.environ, _BENCH_PYHARM_CHILD="1",
               PYTHONPATH=os.pathsep.join([REPO_SRC, mshbm_parent(), LIB]
                                          + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    cmd = [py, os.path.abspath(script), "--out", args.out] + list(child_args)
    print(f"re-running with the pyHarm environment: {' '.join(cmd)}", flush=True)
    proc = subprocess.run(cmd, env=env)
    if proc.returncode != 0 and not os.path.exists(args.out):
        return fail(f"run with {py}", f"exit code {proc.returncode}")
    return None


# ----------------------------------------------------------------------------- models
def connector(system, law, eps_dlft=None):
    """pyHarm connector of ``system.elements[0]`` (to the ground, on its DOF) for ``law``:

    * ``"penalty"`` -- ``PenaltyUnilateralGap`` (contact when ``q >= g``, force ``k (q - g)``) with our
      ``k_c`` and gap;
    * ``"jenkins"`` -- ``Jenkins`` (elastic Coulomb friction) with our ``mu``, ``F_N`` and ``k_t``;
    * ``"dlft"`` -- ``DLFTFriction`` with our ``mu``, ``F_N`` and DLFT parameter ``eps_dlft`` (N/m).
    """
    el = system.elements[0]
    if law == "jenkins":
        conn = {"type": "Jenkins", "mu": float(el.mu), "N0": float(el.normal_force),
                "k": float(el.tangential_stiffness)}
    elif law == "dlft":
        conn = {"type": "DLFTFriction", "mu": float(el.mu), "N0": float(el.normal_force), "eps": eps_dlft}
    elif law == "penalty":
        conn = {"type": "PenaltyUnilateralGap", "k": float(el.penalty_stiffness), "g": float(el.gap)}
    else:
        raise ValueError(f"unknown law {law!r}")
    conn.update({"connect": {"chain": [int(el.dof)]}, "dirs": [0]})
    return conn


def model_input(system, n_h, nti, element, analysis, element_name="element"):
    """pyHarm input dict of ``system`` (see the module docstring) with the connector ``element``
    (:func:`connector`, named ``element_name``) and the analyses ``analysis`` (``{name: options}``).

    Parameters
    ----------
    system : mshbm.System
        A chain forced at harmonic 1 on one DOF.
    n_h, nti : int
        Harmonics and AFT samples per period (pyHarm ``nh``, ``nti``).
    """
    M, C, K = (system.dense(a) for a in "MCK")
    f_dof = int(np.flatnonzero(system.f_hat[1])[0])
    return {"system": {"type": "Base", "nh": int(n_h), "nti": int(nti),
                       "adim": {"status": False, "lc": 1.0, "wc": 1.0}},
            "substructures": {"chain": {"type": "substructure", "ndofs": 1,
                                        "matrix": {"M": M, "C": C, "K": K, "G": 0.0 * M}}},
            "connectors": {"force": {"type": "CosinusForcing", "amp": float(system.f_hat[1, f_dof]),
                                     "connect": {"chain": [f_dof]}, "dirs": [0]},
                           element_name: element},
            "analysis": analysis}
