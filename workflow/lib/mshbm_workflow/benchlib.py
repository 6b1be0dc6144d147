"""Shared helpers of the benchmark scripts (``bench_*.py``): machine facts, interleaved timing, JSON, plots.

Timing policy: the machine is shared (2 cores, other jobs running), so absolute times
are noisy.  Every benchmark therefore

* warms up each case first (numba compilation and caches excluded),
* runs the cases it compares *interleaved* in one process (round-robin over the
  repeats, so that a load change hits all cases alike; or in alternating blocks of
  consecutive calls, :func:`interleaved_blocks`, where one call is so short that the
  other cases' calls in between would evict its code and data from the caches),
* keeps every repeat time and reports the median (and min).

Ratios of medians measured this way are what the benchmarks' conclusions rest on.
"""
from __future__ import annotations

import datetime as _dt
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from mshbm.outfile import jsonable  # noqa: F401 (the one JSON conversion; re-exported)

__all__ = ["machine_info", "interleaved", "interleaved_blocks", "block_stats", "timed", "stats", "write_json",
           "plot_path", "parser", "profile", "jsonable", "fit_exponent"]


def machine_info():
    """Facts about the machine and the software versions (for the JSON header)."""
    info = {"date": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
            "python": sys.version.split()[0], "platform": platform.platform(),
            "machine": platform.machine(), "cpu_count": os.cpu_count()}
    try:
        info["cpu_affinity"] = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not on Linux
        pass
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    info["cpu_model"] = line.split(":", 1)[1].strip()
                    break
    except OSError:  # pragma: no cover
        pass
    try:
        info["load_average_1_5_15"] = list(os.getloadavg())
    except OSError:  # pragma: no cover
        pass
    for mod in ("numpy", "scipy", "numba", "matplotlib"):
        try:
            info[f"{mod}_version"] = __import__(mod).__version__
        except ImportError:
            info[f"{mod}_version"] = None
    try:
        import mshbm
        info["mshbm_version"] = getattr(mshbm, "__version__", None)
    except ImportError:
        info["mshbm_version"] = None
    return info


def stats(times):
    """``{"times_s": [...], "median_s", "min_s", "repeats"}`` of a list of wall times."""
    t = [float(x) for x in times]
    return {"times_s": t, "median_s": float(np.median(t)) if t else float("nan"),
            "min_s": float(np.min(t)) if t else float("nan"), "repeats": len(t)}


def timed(fn):
    """``(seconds, result)`` of one call."""
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def interleaved(cases, repeats, warmup=1, budget_s=None):
    """Time several callables round-robin.

    Parameters
    ----------
    cases : dict name -> callable (no arguments)
    repeats : int
        Timed calls of each case (fewer if ``budget_s`` runs out; at least one each).
    warmup : int
        Untimed calls of each case first (compilation, caches).
    budget_s : float, optional
        Stop starting new rounds after this many seconds of timed calls.

    Returns
    -------
    dict name -> list of seconds
    """
    for _ in range(warmup):
        for fn in cases.values():
            fn()
    times = {k: [] for k in cases}
    t_start = time.perf_counter()
    for r in range(repeats):
        for k, fn in cases.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
        if budget_s is not None and r >= 0 and time.perf_counter() - t_start > budget_s:
            break
    return times


def interleaved_blocks(cases, rounds, block, warmup=1):
    """Time several callables in alternating blocks: each round runs ``block`` consecutive calls of the
    first case, then ``block`` of the next, and so on; ``rounds`` such rounds.

    Every call is timed.  Against :func:`interleaved` (one call of each in turn), a case's calls run
    after calls of its own, with its code and data in the caches and branch predictors, as in a loop of
    solves, while a load change still hits all cases alike (the rounds alternate).  The first call of a
    block comes after another case's block; its time is the cost of a cold start.

    Parameters
    ----------
    cases : dict name -> callable (no arguments)
    rounds, block : int
        Rounds, and consecutive timed calls of each case per round.
    warmup : int
        Untimed rounds of one call of each case first (compilation, caches).

    Returns
    -------
    dict name -> list of ``rounds`` lists of ``block`` seconds
    """
    for _ in range(warmup):
        for fn in cases.values():
            fn()
    times = {k: [] for k in cases}
    for _ in range(rounds):
        for k, fn in cases.items():
            row = []
            for _ in range(block):
                t0 = time.perf_counter()
                fn()
                row.append(time.perf_counter() - t0)
            times[k].append(row)
    return times


def block_stats(rows):
    """:func:`stats` of all calls of :func:`interleaved_blocks` (``rows``: its list of rounds), with
    ``first_of_block`` (the calls after another case's block) and ``rest_of_block`` (medians and minima)
    and the ``rounds`` and ``block`` sizes."""
    allt = [t for row in rows for t in row]
    out = stats(allt)
    first = [row[0] for row in rows]
    rest = [t for row in rows for t in row[1:]]
    out.update(rounds=len(rows), block=len(rows[0]) if rows else 0,
               first_of_block={"median_s": float(np.median(first)) if first else float("nan"),
                               "min_s": float(np.min(first)) if first else float("nan")},
               rest_of_block={"median_s": float(np.median(rest)) if rest else float("nan"),
                              "min_s": float(np.min(rest)) if rest else float("nan")})
    return out


def fit_exponent(n, t):
    """Least-squares slope of ``log t`` against ``log n`` (``nan`` with fewer than two points)."""
    n, t = np.asarray(n, float), np.asarray(t, float)
    ok = np.isfinite(n) & np.isfinite(t) & (n > 0) & (t > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(n[ok]), np.log(t[ok]), 1)[0])


def write_json(path, data):
    """Write ``data`` as JSON (non-finite floats as ``null``; :func:`wfcore.write_json`); returns the path."""
    return wfcore.write_json(path, data, allow_nan=False)


def plot_path(out):
    """The PNG next to the JSON ``out``."""
    return Path(out).with_suffix(".png")


def parser(description, default_out):
    import argparse
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--out", default=default_out, help=f"output JSON (default {default_out}); the PNG goes next to it")
    p.add_argument("--profile", choices=("quick", "default", "full"), default="default",
                   help="size of the benchmark: quick (< 40 s, tests), default (part of `snakemake`), "
                        "full (the long sweeps, `snakemake benchmarks_full`); scripts without a separate "
                        "full sweep run their default for full")
    p.add_argument("--quick", action="store_true", help="same as --profile quick")
    return p


def profile(args):
    """The profile selected by ``--profile`` / ``--quick``; also sets ``args.quick``."""
    prof = "quick" if args.quick else args.profile
    args.quick = prof == "quick"
    return prof


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


# ----------------------------------------------------------------------------- the paper's systems
# The systems are the case files of examples/ (wfcore.load_case); the chains of other lengths are
# the same parameters with n masses (wfcore.chain_case), the families of the scaling benchmarks.
from mshbm_workflow import wfcore  # noqa: E402

#: forcing frequency of the paper's examples (rad/s), from examples/friction3.yaml
OMEGA = wfcore.load_case("friction3").omega
#: friction normal force of the paper's friction systems (mu F_N = 4), from examples/friction3.yaml
NORMAL_FORCE = wfcore.load_case("friction3").system.elements[0].normal_force


def paper_system(name):
    """A paper system by its case file name (``"friction3"``, ``"impact50"``, ...; examples/)."""
    return wfcore.load_case(name).system


def friction_chain(n, kappa=None):
    """examples/friction3.yaml with ``n`` masses (its kappa replaced by ``kappa`` if given)."""
    return wfcore.chain_case("friction3", n, **({} if kappa is None else {"smoothing": kappa}))


def impact_chain(n, gap=None, kc=None, e=None):
    """examples/impact5.yaml with ``n`` masses (gap, penalty stiffness, restitution replaced if given)."""
    el = {k: v for k, v in (("gap", gap), ("penalty_stiffness", kc), ("restitution", e)) if v is not None}
    return wfcore.chain_case("impact5", n, **el)


# ----------------------------------------------------------------------------- memory
def _status_kb(key):
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(key + ":"):
                    return int(line.split()[1])
    except OSError:  # pragma: no cover - not Linux
        return None
    return None


class PeakRSS:
    """Peak resident memory of this process during a ``with`` block (Linux).

    Resets the kernel's high-water mark (``/proc/self/clear_refs`` <- 5) on entry and reads
    ``VmHWM`` on exit.  ``extra_mb`` is the peak minus the resident size at entry: the memory
    the block needed on top of what was already allocated.  ``None`` where unsupported.
    """

    def __enter__(self):
        self.peak_mb = self.extra_mb = None
        self._ok = False
        try:
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")
            self._ok = True
        except OSError:  # pragma: no cover
            pass
        self.start_kb = _status_kb("VmRSS")
        return self

    def __exit__(self, *exc):
        hwm = _status_kb("VmHWM")
        if self._ok and hwm is not None and self.start_kb is not None:
            self.peak_mb = hwm / 1024.0
            self.extra_mb = (hwm - self.start_kb) / 1024.0
        return False
