"""Sweep stress suite (workflow/scripts/stress/sweeps.py): one sweep, its time limit, and its checks.

:func:`run_case` traces one case's branch with :func:`mshbm.sweep` under a CPU-time limit, then re-solves
``checks`` of its points with :func:`mshbm.solve` at the point's own ``omega`` (from solve's default start,
independent of the sweep; when that is not certified or lands elsewhere, from the point's solution,
:func:`run_checks`), and returns the row of the report:

* ``reached`` -- the last point lies at ``omega_end`` (relative 1e-9); ``success`` and ``message`` are the
  sweep's own; a sweep stopped by the time limit says so in ``stop``;
* ``points``, ``cpu_s`` (process CPU time of the sweep, start solve included), ``wall_s``; ``curve``: the
  branch as ``omega`` and the largest amplitude over the DOFs per point;
* ``max_deviation`` -- the largest relative deviation ``max_i |A_i - A_solve,i| / max_i |A_solve,i|`` (``A``
  the amplitude per DOF, ``(max - min) / 2``) over the checks whose solve was certified; ``checks`` per
  check ``{omega, deviation, independent_deviation, start, success, message}``; ``independent_differs``
  counts the checks whose independent solve was certified but away from the point (coexisting solutions);
  ``coexisting`` those among them whose solve from the sweep point stayed on the point (within the tolerance,
  certified or not): the check is then that solve, not the other solution;
* ``exact_deviation`` (cases with ``exact: linear``, an element that never acts, or ``exact: stuck``, friction
  that never slips) -- the same measure against the closed-form linear response at every point of the branch
  (:func:`linear_reference`).

The CPU limit (:func:`cpu_limit`) is a profiling timer (``ITIMER_PROF``: the process's user + system time)
whose signal raises :class:`CpuLimit`, a :class:`KeyboardInterrupt`: the sweep then ends like after Ctrl-C and
its :class:`mshbm.interrupt.SweepInterrupted` carries the points so far.

A case with a ``reduction`` (the automatic Craig-Bampton reduction of a method that integrates stiff DOFs in time,
:func:`mshbm_workflow.sweep_systems.time_reduction`) is swept on the reduced model and certified as ``mshbm
sweep`` certifies it: the reduction's error estimate is added to every point's ``accuracy``
(:func:`mshbm.branch_accuracy.add_reduction`).  Its check solves are :meth:`mshbm.reduction.ReducedModel.solve`
(certified with the same estimate, as ``mshbm solve``), and every amplitude compared (checks, closed forms, the
curve) is on the full model's DOFs (:func:`point_amplitude`).
"""
from __future__ import annotations

import contextlib
import math
import signal
import time
import traceback

import numpy as np

import mshbm
from mshbm.branch_accuracy import add_reduction
from mshbm.interrupt import SweepInterrupted

#: options of mshbm.sweep that are the continuation's (not passed to the check solves)
SWEEP_ONLY = {"ds", "ds_min", "ds_max", "max_points", "predictor", "max_time", "progress", "guess"}


class CpuLimit(KeyboardInterrupt):
    """The CPU-time limit of a sweep or check solve was reached (:func:`cpu_limit`)."""


@contextlib.contextmanager
def cpu_limit(seconds):
    """Raise :class:`CpuLimit` once the process has spent ``seconds`` more CPU time (main thread only)."""
    if seconds is None or seconds <= 0:
        yield
        return

    def handler(signum, frame):
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        raise CpuLimit(f"CPU limit of {seconds:g} s reached")

    old = signal.signal(signal.SIGPROF, handler)
    signal.setitimer(signal.ITIMER_PROF, float(seconds))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        signal.signal(signal.SIGPROF, old)


def deviation(a, ref):
    """``max_i |a_i - ref_i| / max_i |ref_i|`` (relative to the largest reference amplitude)."""
    a, ref = np.asarray(a, float), np.asarray(ref, float)
    scale = float(np.max(np.abs(ref))) if ref.size else 0.0
    if not np.all(np.isfinite(a)) or not np.all(np.isfinite(ref)):
        return math.inf
    if scale == 0.0:
        return 0.0 if float(np.max(np.abs(a))) == 0.0 else math.inf
    return float(np.max(np.abs(a - ref)) / scale)


def check_indices(omegas, count):
    """Indices of ``count`` points of the branch (``omegas`` in branch order) nearest to equally spaced
    frequencies over the range the branch covers; each index once, in branch order."""
    omegas = np.asarray(omegas, float)
    if omegas.size <= count:
        return list(range(omegas.size))
    targets = np.linspace(omegas.min(), omegas.max(), count)
    chosen = []
    for t in targets:
        order = np.argsort(np.abs(omegas - t), kind="stable")
        pick = next((int(i) for i in order if int(i) not in chosen), None)
        if pick is not None:
            chosen.append(pick)
    return sorted(chosen)


def linear_reference(system, omega, stuck=False):
    """Amplitude per DOF of the linear response to the forcing's first harmonic: with the elements removed,
    or (``stuck``) with every friction element stuck for good -- a Jenkins element then is its spring ``k_t``
    (on ``w^T q``), a Coulomb element between a DOF and the ground holds that DOF at rest."""
    import scipy.sparse as sp

    M, C, K = (A.toarray() if sp.issparse(A) else np.array(A, float) for A in (system.M, system.C, system.K))
    f = np.asarray(system.f_hat, float)
    if f.shape[0] != 3 or np.any(f[0] != 0.0):
        raise ValueError("an exact linear reference needs a first-harmonic forcing without constant load")
    F = f[1] - 1j * f[2]
    free = np.ones(system.n, bool)
    if stuck:
        for e in system.elements:
            if e.kind != "friction":
                raise ValueError(f"exact: stuck needs friction elements only, got {e.kind}")
            if isinstance(e, mshbm.Jenkins):
                w = np.zeros(system.n)
                w[e.dof] = 1.0
                if e.relative_to is not None:
                    w[e.relative_to] = -1.0
                K = K + e.tangential_stiffness * np.outer(w, w)
            elif e.relative_to is None:
                free[e.dof] = False
            else:
                raise ValueError("exact: stuck with a relative Coulomb element is not implemented")
    Q = np.zeros(system.n, complex)
    idx = np.flatnonzero(free)
    D = (K - omega ** 2 * M + 1j * omega * C)[np.ix_(idx, idx)]
    Q[idx] = np.linalg.solve(D, F[idx])
    return np.abs(Q)


def _message(exc):
    text = str(exc) or type(exc).__name__
    return f"{type(exc).__name__}: {text}"


def point_amplitude(point, reduction=None):
    """Amplitude per DOF (``(max - min) / 2``) of a branch point, on the full model's DOFs when the branch is of the
    ``reduction``'s reduced model (:meth:`mshbm.reduction.ReducedModel.expand`; NaN without a solution), shape
    (n,)."""
    if reduction is None:
        return np.asarray(point.amplitude, float)
    if point.solution is None:
        return np.full(reduction.full.n, np.nan)
    return np.asarray(reduction.expand(point.solution, estimate=False).amplitude, float)


def run_sweep(system, case, cpu_s, reduction=None):
    """``(branch or None, stop, cpu_s, wall_s, error)``: the case's sweep under the CPU limit; ``stop`` is
    ``"end"``, ``"cpu-limit"``, ``"stopped"`` (the sweep ended before the end of its range) or ``"error"``.
    With a ``reduction`` the sweep is of its reduced model, and a branch that was not interrupted gets the
    reduction's estimate in every point's certificate (:func:`mshbm.branch_accuracy.add_reduction`, in the CPU
    time)."""
    w0, w1 = case["omega"]
    opts = dict(case.get("options") or {})
    opts.setdefault("stability", False)
    t_cpu, t_wall = time.process_time(), time.perf_counter()
    branch, stop, error = None, "stopped", None
    try:
        with cpu_limit(cpu_s):
            branch = mshbm.sweep(system if reduction is None else reduction.system, w0, w1, case["method"], **opts)
            if reduction is not None and len(branch):
                add_reduction(branch, reduction)
    except SweepInterrupted as exc:
        branch = exc.branch
        stop = "cpu-limit" if isinstance(exc.cause, CpuLimit) else "interrupted"
    except CpuLimit:
        stop = "cpu-limit"
    except Exception as exc:  # a crash is a finding of the suite, reported with its traceback
        stop, error = "error", _message(exc) + "\n" + traceback.format_exc(limit=6)
    cpu, wall = time.process_time() - t_cpu, time.perf_counter() - t_wall
    if branch is not None and stop == "stopped" and len(branch) and _at_end(branch.omega[-1], w1):
        stop = "end"
    return branch, stop, cpu, wall, error


def _at_end(omega, end):
    return abs(float(omega) - float(end)) <= 1e-9 * max(abs(float(end)), 1.0)


def _solve(system, omega, method, opts, guess, cpu_s, reduction=None):
    """``(solution or None, message)`` of one check solve under the CPU limit; with a ``reduction``, of its
    reduced model from ``guess`` (a point of the reduced model's branch) on the full model's DOFs, certified
    with the reduction's estimate (:meth:`mshbm.reduction.ReducedModel.solve`)."""
    try:
        with cpu_limit(cpu_s):
            if reduction is None:
                sol = mshbm.solve(system, float(omega), method, guess=guess, **opts)
            else:
                sol = reduction.solve(float(omega), method, guess=guess, **opts)
    except (CpuLimit, Exception) as exc:
        return None, _message(exc)[:300]
    return sol, str(sol.message)[:300]


def run_checks(system, case, branch, count, cpu_s, budget_s, tol, reduction=None):
    """The pointwise solves at ``count`` points of ``branch`` (of ``reduction``'s reduced model when given: the
    solves are then :meth:`mshbm.reduction.ReducedModel.solve`, the amplitudes compared on the full model's DOFs).

    At each point, :func:`mshbm.solve` from its default start (independent of the sweep); when that is not
    certified or deviates by more than ``tol`` (another of coexisting solutions, or a wrong point), again from
    the sweep point's solution.  When that one converges to the point (within ``tol``) while the independent one is
    certified away from it, the two solutions coexist (``coexisting``): the check is the solve from the point, its
    ``deviation`` set only when it is certified (a converged solve failing only on its accuracy leaves the check
    not certified, not a deviation of the size of the distance between the two solutions).  Otherwise the
    check's ``deviation`` is the smaller certified one (``start`` says which);
    ``independent_deviation`` keeps the first, ``point_deviation`` and ``point_message`` the second
    (``message`` is the first's).  Checks stop once ``budget_s`` CPU seconds are spent."""
    method = case["method"]
    opts = {k: v for k, v in (case.get("options") or {}).items() if k not in SWEEP_ONLY}
    opts["stability"] = False
    out, t_all = [], time.process_time()
    for i in check_indices(branch.omega, count):
        p = branch.points[i]
        rec = {"index": int(i), "omega": float(p.omega), "start": None, "success": False, "deviation": None,
               "independent_deviation": None, "message": ""}
        if time.process_time() - t_all > budget_s:
            rec["message"] = f"not solved: the checks' CPU budget of {budget_s:g} s was spent"
            rec["cpu_s"] = 0.0
            out.append(rec)
            continue
        t0 = time.process_time()
        amp = point_amplitude(p, reduction)
        sol, msg = _solve(system, p.omega, method, opts, None, cpu_s, reduction)
        rec.update(start="default", message=msg)
        if sol is not None and sol.success:
            rec.update(success=True, deviation=deviation(amp, sol.amplitude))
            rec["independent_deviation"] = rec["deviation"]
        if (rec["deviation"] is None or rec["deviation"] > tol) and p.solution is not None:
            sol, msg = _solve(system, p.omega, method, opts, p.solution, cpu_s, reduction)
            rec["point_message"] = msg
            d = deviation(amp, sol.amplitude) if _converged(sol) else None
            if d is not None:
                rec["point_deviation"] = d
            if d is not None and d <= tol and rec["deviation"] is not None:
                # the solve from the sweep point stays on it, the independent one is certified elsewhere: two
                # coexisting solutions, not a deviation of the sweep; the check is the solve from the point
                # (certified or not: a point whose own solve is not certified is not counted as within)
                rec.update(start="sweep point", coexisting=True, success=bool(sol.success),
                           deviation=d if sol.success else None)
            elif sol is not None and sol.success:
                if rec["deviation"] is None or d < rec["deviation"]:
                    rec.update(start="sweep point", success=True, deviation=d)
            elif rec["deviation"] is None:
                rec["start"] = "sweep point"
        rec["cpu_s"] = time.process_time() - t0
        out.append(rec)
    return out


def _converged(sol):
    """Whether ``sol`` is a solve that converged and whose certificate fails, if at all, only on its accuracy (its
    amplitudes are then those of a solution of the discretised equations)."""
    if sol is None:
        return False
    if sol.success:
        return True
    cert = getattr(sol, "certificate", None)
    return cert is not None and set(cert.failed) <= {"accuracy"} and np.all(np.isfinite(sol.amplitude))


def bifurcations(branch):
    """The branch's located events ``[{type, omega}]`` (fold, grazing, period doubling, Neimark-Sacker)."""
    out = []
    for b in branch.bifurcations if branch is not None else ():
        w = b.get("omega", b.get("lam"))
        out.append({"type": str(b.get("type", "?")), "omega": None if w is None else float(w),
                    "located": b.get("located")})
    return out


def run_case(case, system, suite, reduction=None):
    """The report row of one case (module docstring); ``suite``: ``cpu_limit_s``, ``checks``,
    ``check_cpu_s``, ``check_budget_s``, ``tolerance``; ``reduction``: the automatic reduction of ``system`` the
    case is swept on (``None``: ``system`` itself)."""
    cpu_s = float(case.get("cpu_limit_s", suite["cpu_limit_s"]))
    branch, stop, cpu, wall, error = run_sweep(system, case, cpu_s, reduction)
    w0, w1 = case["omega"]
    row = {"name": case["name"], "system": case["system"], "method": case["method"],
           "label": case.get("label", case["method"]), "options": case.get("options") or {},
           "omega_start": float(w0), "omega_end": float(w1), "dofs": int(system.n),
           "cpu_limit_s": cpu_s, "cpu_s": cpu, "wall_s": wall, "stop": stop, "error": error}
    if reduction is not None:
        row.update(reduced_dofs=int(reduction.system.n), reduction=reduction.as_dict())
    if branch is None:
        msg = error or (f"CPU limit of {cpu_s:g} s reached before the first point" if stop == "cpu-limit" else stop)
        row.update(success=False, reached=False, points=0, message=msg, omega_last=None,
                   bifurcations=[], checks=[], max_deviation=None, checks_certified=0, within=False)
        return row
    pts = len(branch)
    amps = [point_amplitude(p, reduction) for p in branch.points]
    row.update(success=bool(branch.success), points=pts,
               reached=bool(pts and _at_end(branch.omega[-1], w1)),
               message=str(branch.message), omega_last=float(branch.omega[-1]) if pts else None,
               omega_min=float(branch.omega.min()) if pts else None,
               omega_max=float(branch.omega.max()) if pts else None,
               bifurcations=bifurcations(branch), counters=_plain(branch.counters),
               curve={"omega": [float(w) for w in branch.omega],
                      "amplitude_max": [float(np.max(a)) for a in amps]})
    if stop == "cpu-limit":
        row["message"] = f"CPU limit of {cpu_s:g} s reached ({row['message']})"
    if case.get("exact") in ("linear", "stuck") and pts:
        stuck = case["exact"] == "stuck"
        row["exact_deviation"] = max(deviation(a, linear_reference(system, p.omega, stuck))
                                     for p, a in zip(branch.points, amps))
    tol = float(case.get("tolerance", suite["tolerance"]))
    checks = run_checks(system, case, branch, int(suite["checks"]), float(suite["check_cpu_s"]),
                        float(suite["check_budget_s"]), tol, reduction) if pts else []
    devs = [c["deviation"] for c in checks if c["deviation"] is not None]
    row.update(checks=checks, checks_certified=len(devs), max_deviation=max(devs) if devs else None,
               checks_cpu_s=sum(c["cpu_s"] for c in checks), tolerance=tol,
               independent_differs=sum(c["start"] == "sweep point" and c["independent_deviation"] is not None
                                       for c in checks),
               coexisting=sum(bool(c.get("coexisting")) for c in checks))
    row["within"] = bool(checks and len(devs) == len(checks) and max(devs) <= tol)
    return row


def _plain(obj):
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, (bool, int, float, str)) or obj is None:
        return obj
    return str(obj)
