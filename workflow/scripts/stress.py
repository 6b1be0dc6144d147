"""Stress suite of mshbm (GitHub issue 5): numerical stability, stiff settings, poor starts, random systems.

Run by the Snakemake rule ``stress`` (workflow/rules/stress.smk) or directly::

    python workflow/scripts/stress.py --config workflow/stress.yaml [--quick] --out results/stress [--jobs 2]

Writes ``<out>/summary.json`` (every row, counts, convergence rates from poor starts) and
``<out>/summary.md`` (Markdown tables for the paper).  Each row is one solve: case, method,
options, outcome, residual, error against the reference, wall time.  Outcomes:

* ``converged`` -- success=True and the amplitudes agree with the reference within the method's
  tolerance (or no reference exists: column ``reference`` says so);
* ``failed-with-diagnosis`` -- success=False with a message, or :class:`mshbm.InputError` naming a key
  (e.g. ``omega`` on an exactly singular ``H_LL``);
* ``failed-certificate`` -- Newton converged but the certificate (:mod:`mshbm.certificate`) refused the
  answer: success=False with a message naming the failed checks (column ``certificate``);
* ``WRONG`` -- success=True but the error exceeds the tolerance, the residual re-evaluated from the
  unknowns contradicts the claim, NaN/inf or garbage in the solution; or an unexpected exception
  (a crash instead of a diagnosis); or success=False without a message.

References: full shooting with ``reference.steps`` steps at the same omega (from the linear start);
when that fails or disagrees, full shooting started from the solution under test (which then is a
genuine periodic solution of the system, possibly one of several coexisting ones); then shooting at
nearby frequencies; then the same method at a nearby frequency (tolerance + ``nearby_allowance``);
else "no reference".  Systems with more than ``reference.max_dofs`` DOFs use the same method with
``reference.highres_harmonics_factor`` times the harmonics and twice the steps.
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one thread per worker; the workers run side by side

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import multiprocessing  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.linalg as sla  # noqa: E402
import yaml  # noqa: E402

import mshbm  # noqa: E402
from mshbm import Contact, Friction, InputError, chain  # noqa: E402
from mshbm.solvers.continuation import solve_with_continuation  # noqa: E402

OUTCOMES = ("converged", "failed-with-diagnosis", "failed-certificate", "WRONG")
SCHEMA = Path(__file__).resolve().parents[1] / "schemas" / "stress.schema.yaml"


# ----------------------------------------------------------------------------- configuration
def load_config(path):
    """Read and validate ``workflow/stress.yaml`` (jsonschema); raises ``ValueError`` with the failing key."""
    import jsonschema

    with open(path, encoding="utf-8") as fh:
        cfg = yaml.safe_load(fh)
    with open(SCHEMA, encoding="utf-8") as fh:
        schema = yaml.safe_load(fh)
    try:
        jsonschema.validate(cfg, schema)
    except jsonschema.ValidationError as exc:
        where = ".".join(str(p) for p in exc.absolute_path) or "(top level)"
        raise ValueError(f"{path}: {where}: {exc.message}") from None
    for prof in cfg["profiles"].values():
        names = list(prof["resonance"]["systems"]) + list(prof["starts"]["systems"])
        names += [prof["stiff"][k]["system"] for k in ("kappa", "penalty", "harmonics", "steps")]
        for name in names:
            if name not in cfg["systems"]:
                raise ValueError(f"{path}: system {name!r} is not defined under systems")
    return cfg


def build_system(spec, name, kappa=None, penalty=None):
    """A chain of the config (wall - k - m_1 - k - m_2 ... - m_n, forcing on the last mass)."""
    n = int(spec["n"])
    masses = [float(spec["mass_first"])] + [float(spec["mass_other"])] * (n - 1)
    els = []
    if "friction" in spec:
        f = spec["friction"]
        els.append(Friction(0, f["mu"], f["normal_force"], kappa if kappa is not None else f.get("smoothing", 800.0)))
    if "contact" in spec:
        c = spec["contact"]
        els.append(Contact(0, c["gap"], c.get("restitution", 1.0),
                           penalty if penalty is not None else c.get("penalty_stiffness", 8000.0),
                           c.get("penalty_damping", 0.0)))
    return chain(masses, spec["stiffness"], spec["damping"], forcing=[{"dof": n - 1, "amplitude": spec["forcing_amplitude"]}],
                 elements=els, name=name)


def as_list(x):
    return list(x) if isinstance(x, (list, tuple)) else [x]


def linear_resonances(system):
    """Eigenfrequencies (rad/s) of the linear subsystem ``(K_LL, M_LL)`` (element DOFs removed)."""
    Ld = np.setdiff1d(np.arange(system.n), system.nonlinear_dofs)
    if Ld.size == 0:
        return np.zeros(0)
    K = system.dense("K")[np.ix_(Ld, Ld)]
    M = system.dense("M")[np.ix_(Ld, Ld)]
    lam = sla.eigh(K, M, eigvals_only=True)
    return np.sqrt(np.clip(lam, 0.0, None))


def random_system(rng, index, max_dofs):
    """A random chain: masses, stiffnesses and dampings over several decades, one element on a random DOF.

    Returns ``(system, omega, description)``.
    """
    n = int(round(math.exp(rng.uniform(0.0, math.log(max_dofs)))))
    n = min(max(n, 1), max_dofs)
    masses = 10.0 ** rng.uniform(-2, 2, n)
    stiff = 10.0 ** rng.uniform(-2, 2, n)
    zeta = 0.0 if rng.random() < 0.25 else 10.0 ** rng.uniform(-3, -0.5)
    damp = zeta * 2.0 * np.sqrt(stiff * np.minimum(masses, np.roll(masses, 1)))
    d_force = int(rng.integers(n))
    amp = 10.0 ** rng.uniform(-1, 1)
    probe = chain(list(masses), list(stiff), list(damp), forcing=[{"dof": d_force, "amplitude": amp}])
    lam = sla.eigh(probe.dense("K"), probe.dense("M"), eigvals_only=True)
    w = np.sqrt(np.clip(lam, 1e-12, None))
    j = int(rng.integers(min(n, 5)))  # one of the five lowest modes
    omega = float(w[j] * rng.uniform(0.6, 1.4))
    d_el = int(rng.integers(n))
    # amplitude scale of the element DOF in the linear response (for gaps and friction bounds)
    from mshbm.methods.common import linear_response

    qh = linear_response(probe, omega, 1)
    scale = float(np.hypot(qh[1, d_el], qh[2, d_el])) or 1e-3
    if rng.random() < 0.5:
        # friction bound: a fraction of the force the linear response would need at that DOF
        fscale = scale * float(probe.dense("K")[d_el, d_el] + masses[d_el] * omega ** 2)
        bound = fscale * 10.0 ** rng.uniform(-1.5, 0)
        mu = 10.0 ** rng.uniform(-1, 0)
        el = Friction(d_el, mu, bound / mu, smoothing=1000.0 / max(scale * omega, 1e-12))
        kind = f"friction@{d_el}"
    else:
        gap = scale * 10.0 ** rng.uniform(-2, -0.05)
        e = float(rng.choice([0.0, 0.5, 0.9, 1.0]))
        kc = 100.0 * float(np.max(stiff) + np.max(masses) * omega ** 2)
        el = Contact(d_el, gap, e, kc, 0.0)
        kind = f"contact@{d_el}(e={e:g})"
    system = chain(list(masses), list(stiff), list(damp), forcing=[{"dof": d_force, "amplitude": amp}],
                   elements=[el], name=f"random{index}")
    desc = (f"random{index}: n={n}, m in [{masses.min():.2g}, {masses.max():.2g}], "
            f"k in [{stiff.min():.2g}, {stiff.max():.2g}], zeta={zeta:.2g}, {kind}, force@{d_force}")
    return system, omega, desc


# ----------------------------------------------------------------------------- evaluation
def amp_error(amp, ref_amp, floor=0.0):
    """``max_i |A_i - A_ref,i| / max(max_i |A_ref,i|, floor)``."""
    amp, ref_amp = np.asarray(amp, float), np.asarray(ref_amp, float)
    scale = max(float(np.max(np.abs(ref_amp))), float(floor))
    if not np.all(np.isfinite(amp)):
        return math.inf
    if scale == 0.0:
        return float(np.max(np.abs(amp)))
    return float(np.max(np.abs(amp - ref_amp)) / scale)


def solution_finite(sol):
    arrays = [sol.q_hat, sol.q_time, sol.u_time, sol.lam, sol.x, np.array([sol.residual])]
    if sol.impulses is not None:
        arrays.append(sol.impulses)
    return all(np.all(np.isfinite(a)) for a in arrays) and np.all(np.isfinite(sol.amplitude))


def recheck_residual(system, omega, method, opts, sol, factor):
    """Re-evaluate the residual at the returned unknowns; ``(ok, value, bound)``."""
    o = {k: v for k, v in opts.items() if k in ("harmonics", "steps", "theta", "partition", "project", "condense")}
    try:
        problem, _ = mshbm.build_problem(system, omega, method, **o)
        R = problem.residual(np.asarray(sol.x, float), jac=False)[0]
    except Exception as exc:  # noqa: BLE001
        return False, math.nan, f"re-evaluation failed: {type(exc).__name__}: {exc}"
    # the same row scaling as Newton's convergence test (problem.residual_scale: forces by the force
    # scale of the problem, displacements by the size of the solution; mshbm.scaling)
    from mshbm.solvers.newton import scaled_norm

    step = sol.info.get("step_accuracy")
    if step is not None:
        # accepted as periodic to one time step's accuracy (impacts move by whole steps; mshbm.solvers.starts): the
        # residual entries against the jump of the residual when an impact moves by one step
        r = float(np.max(np.abs(R) / np.asarray(step["bound"], dtype=float)))
        bound = 1.0  # the certificate's own bound: re-evaluation must reproduce it, no factor
        return bool(np.isfinite(r) and r <= bound), r, bound
    r = scaled_norm(R, problem.residual_scale(np.asarray(sol.x, float)))
    bound = factor * float(opts.get("tol", 1e-10))
    return bool(np.isfinite(r) and r <= bound), r, bound


class Ctx:
    """Shared settings of one run (picklable)."""

    def __init__(self, cfg):
        self.cfg = cfg
        self.tol = cfg["tolerance"]
        self.ref = cfg["reference"]


class ReferenceTimeout(Exception):
    """A reference solve exceeded ``reference.max_cpu_s`` (the reference is then unavailable)."""


def _prof_alarm(signum, frame):
    raise ReferenceTimeout("reference solve exceeded its CPU budget")


def run_solve(ctx, system, omega, method, opts, *, use_continuation=False, cpu_budget=None):
    """One solve; returns ``(solution or None, exception or None, wall time)``.

    ``cpu_budget`` (s of CPU time, for reference solves only) stops the solve with
    :class:`ReferenceTimeout` (returned as the exception).
    """
    t0 = time.perf_counter()
    old = None
    if cpu_budget:
        old = signal.signal(signal.SIGPROF, _prof_alarm)
        signal.setitimer(signal.ITIMER_PROF, float(cpu_budget))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if use_continuation:
                sol = solve_with_continuation(system, omega, method, stability=False, **opts)
            else:
                sol = mshbm.solve(system, omega, method, stability=False, **opts)  # convergence only
        return sol, None, time.perf_counter() - t0
    except TimeoutError:
        raise
    except Exception as exc:  # noqa: BLE001 -- classified below
        return None, exc, time.perf_counter() - t0
    finally:
        if cpu_budget:
            signal.setitimer(signal.ITIMER_PROF, 0.0)
            signal.signal(signal.SIGPROF, old)


def reference_shooting(ctx, system, omega, guess=None, nearby=True):
    """Shooting reference ``(solution, note, is_nearby)`` or ``(None, why, False)``."""
    if system.n > ctx.ref["max_dofs"]:
        return None, f"no shooting reference (n={system.n} > {ctx.ref['max_dofs']})", False
    steps = int(ctx.ref["steps"])
    trials = [(omega, "same omega", False)]
    if nearby:
        trials += [(omega * (1 + d), f"omega*(1{d:+g})", True) for d in ctx.ref["nearby"]]
    for om, note, near in trials:
        opts = {"steps": steps}
        if guess is not None:
            opts["guess"] = guess
        sol, exc, _ = run_solve(ctx, system, om, "shooting", opts, cpu_budget=ctx.ref.get("max_cpu_s"))
        if isinstance(exc, ReferenceTimeout):
            return None, f"shooting reference exceeded {ctx.ref.get('max_cpu_s')} s CPU", False
        if sol is not None and sol.success and solution_finite(sol):
            start = "from this solution" if guess is not None else "from the linear start"
            return sol, f"shooting N={steps} {start} at {note}", near
    return None, "shooting reference did not converge", False


def row_tolerance(ctx, method, opts):
    """The method's tolerance; ``few_harmonics.tolerance`` for ``n_h <= few_harmonics.max_harmonics``."""
    tol = float(ctx.tol[method])
    few = ctx.cfg.get("few_harmonics")
    if few and method != "shooting" and int(opts.get("harmonics", 5)) <= int(few["max_harmonics"]):
        tol = max(tol, float(few["tolerance"]))
    return tol


def resonance_distance(system, omega, n_h):
    """``min_{k <= n_h, r} |k omega / omega_r - 1|`` over the eigenfrequencies of ``(K_LL, M_LL)``."""
    try:
        wr = linear_resonances(system)
    except Exception:  # noqa: BLE001
        return 0.0
    wr = wr[wr > 0]
    if wr.size == 0:
        return math.inf
    k = np.arange(1, n_h + 1)[:, None]
    return float(np.min(np.abs(k * omega / wr[None, :] - 1.0)))


def linear_scale(system, omega):
    """Largest amplitude of the linear response (elements removed); 0 if it cannot be computed."""
    from mshbm import fourier
    from mshbm.methods.common import linear_response

    try:
        q = fourier.ifft(linear_response(system, omega, 5), 64)
        a = float(np.max(0.5 * (q.max(axis=0) - q.min(axis=0))))
    except Exception:  # noqa: BLE001
        return 0.0
    return a if math.isfinite(a) else 0.0


def evaluate(ctx, row, system, omega, method, opts, sol, exc, ref_cache):
    """Fill outcome/error/residual/reference/message of ``row``.

    Errors are relative to the largest reference amplitude, floored at ``error_floor`` x the largest
    amplitude of the linear response (so that a solution at rest, e.g. permanent stick, is not
    compared relatively to round-off).  References, tried in order until one agrees within the
    tolerance:

    1. full shooting (``reference.steps``) from the linear start at the same omega;
    2. full shooting started from the solution under test (it then is a genuine periodic solution,
       possibly one of several coexisting ones);
    3. HBM only (it solves the regularised model, not the set-valued one): HBM itself with
       ``reference.highres_harmonics_factor`` times the harmonics, started from the solution (the converged answer of its own model);
    4. only if none of 1-3 exists: the same method with that many more harmonics and 2x steps (systems too large
       for shooting), then shooting or the same method at nearby frequencies (tolerance +
       ``nearby_allowance``; skipped within 20x the offset of a resonance of H_LL).

    A solution that disagrees with every reference that exists is WRONG; with none it is "converged
    (no reference)".  ``error_setvalued`` is the error against reference 1 whenever it exists.
    """
    tol = row_tolerance(ctx, method, opts)
    if "floor" not in ref_cache:
        ref_cache["floor"] = float(ctx.cfg.get("error_floor", 1e-3)) * linear_scale(system, omega)
    floor = ref_cache["floor"]
    row["tolerance"] = tol
    row["error"] = None
    row["reference"] = ""
    if exc is not None:
        if isinstance(exc, InputError):
            row.update(outcome="failed-with-diagnosis", message=f"InputError {exc.key}: {exc.problem}", residual=None)
        else:
            row.update(outcome="WRONG", message=f"crash: {type(exc).__name__}: {exc}", residual=None)
        return row
    row["residual"] = float(sol.residual) if math.isfinite(sol.residual) else None
    row["iterations"] = int(sol.iterations)
    row["message"] = " ".join(str(sol.message).split())
    if "continuation" in sol.info:
        row["continuation"] = sol.info["continuation"]["used"]
    cert = getattr(sol, "certificate", None)
    row["certificate"] = None if cert is None else cert.failed
    row["step_accuracy"] = "step_accuracy" in sol.info
    if not sol.success:
        row["outcome"] = "failed-with-diagnosis" if row["message"] else "WRONG"
        if row["message"].startswith("certificate failed"):  # Newton converged, the certificate refused
            row["outcome"] = "failed-certificate"
        if not row["message"]:
            row["message"] = "success=False without a message"
        return row
    if cert is None or not cert.passed:
        row.update(outcome="WRONG", message="success=True without a passed certificate: " + row["message"])
        return row
    if not solution_finite(sol):
        row.update(outcome="WRONG", message="success=True with NaN/inf in the solution: " + row["message"])
        return row
    ok, r, bound = recheck_residual(system, omega, method, opts, sol, ctx.cfg["residual_check_factor"])
    row["residual_recheck"] = r if math.isfinite(r) else None
    if not ok:
        row.update(outcome="WRONG", message=f"success=True but the residual re-evaluates to {r:.3g} > {bound}")
        return row
    amp = sol.amplitude
    tried = []  # (error, allowance, note)

    def agrees(ref_sol, note, allowance=0.0):
        err = amp_error(amp, ref_sol.amplitude, floor)
        tried.append((err, allowance, note))
        if err <= tol + allowance:
            row.update(outcome="converged", error=err, reference=note)
            _garbage(ctx, row, amp, ref_sol.amplitude)
            return True
        return False

    small = system.n <= ctx.ref["max_dofs"]
    # 1. the primary reference (shared by the rows of a group)
    if "primary" not in ref_cache:
        ref_cache["primary"] = reference_shooting(ctx, system, omega, nearby=False)
    ref, note, _ = ref_cache["primary"]
    if ref is not None:
        row["error_setvalued"] = amp_error(amp, ref.amplitude, floor)
        if agrees(ref, note):
            return row
    # 2. shooting from this solution
    if small:
        ref2, note2, _ = reference_shooting(ctx, system, omega, guess=sol, nearby=False)
        if ref2 is not None:
            extra = "" if ref is None else f" (coexisting solution: {row['error_setvalued']:.2g} from the linear-start reference)"
            if agrees(ref2, note2 + extra):
                return row
    # 3. HBM: its own model at a higher resolution
    if method == "hbm":
        ref3, note3 = same_method_highres(ctx, system, omega, method, opts, sol)
        if ref3 is not None:
            extra = "" if ref is None else f"; {row['error_setvalued']:.2g} from set-valued shooting"
            if agrees(ref3, note3 + " (regularised model)" + extra):
                return row
    # 4. weaker references, only when nothing above exists
    if not tried:
        n_h_ref = max(int(opts.get("harmonics", 5)), 10)
        dist = resonance_distance(system, omega, n_h_ref)
        near_ok = dist > 20.0 * max([abs(d) for d in ctx.ref["nearby"]] + [0.0])
        why = "no converged reference"
        if not small and method != "hbm":
            ref4, note4 = same_method_highres(ctx, system, omega, method, opts, sol)
            if ref4 is not None and agrees(ref4, note4):
                return row
            why = note4 if ref4 is None else why
        if not tried and near_ok:
            if small:
                if "nearby" not in ref_cache:
                    ref_cache["nearby"] = reference_shooting(ctx, system, omega, nearby=True)
                refn, noten, _ = ref_cache["nearby"]
                if refn is not None and agrees(refn, noten, float(ctx.cfg["nearby_allowance"])):
                    return row
            if not tried:
                refn, noten = same_method_nearby(ctx, system, omega, method, opts, sol)
                if refn is not None and agrees(refn, noten, float(ctx.cfg["nearby_allowance"])):
                    return row
        elif not tried:
            why += f"; nearby frequencies are no reference within {dist:.1g} of a resonance of H_LL"
        if not tried:
            row.update(outcome="converged", reference=f"no reference ({why})")
            return _garbage(ctx, row, amp, None, system=system, omega=omega)
    err, allowance, note = min(tried, key=lambda t: t[0] - t[1])
    row.update(outcome="WRONG", error=err, reference=note,
               message=f"success=True but error {err:.3g} > tolerance {tol + allowance:g}; " + row["message"])
    return row


def same_method_nearby(ctx, system, omega, method, opts, sol):
    for d in ctx.ref["nearby"]:
        o = dict(opts)
        o["guess"] = sol
        r, exc, _ = run_solve(ctx, system, omega * (1 + d), method, o, cpu_budget=ctx.ref.get("max_cpu_s"))
        if r is not None and r.success and solution_finite(r):
            return r, f"same method at omega*(1{d:+g}), started from this solution"
    return None, "no converged reference at nearby frequencies"


def same_method_highres(ctx, system, omega, method, opts, sol):
    o = dict(opts)
    n_h = int(o.get("harmonics", 5))
    factor = int(ctx.ref.get("highres_harmonics_factor", 3))
    o["harmonics"] = factor * n_h
    o["steps"] = 2 * int(o.get("steps", mshbm.api.default_steps(method, n_h)))
    if method == "hbm":
        o["steps"] = max(o["steps"], mshbm.api.default_steps("hbm", factor * n_h))
    o["guess"] = sol
    r, exc, _ = run_solve(ctx, system, omega, method, o, cpu_budget=ctx.ref.get("max_cpu_s"))
    if isinstance(exc, ReferenceTimeout):
        return None, f"the higher-resolution solve exceeded {ctx.ref.get('max_cpu_s')} s CPU"
    if r is not None and r.success and solution_finite(r):
        return r, f"same method, {factor}x harmonics and 2x steps (n_h={o['harmonics']}, N={o['steps']})"
    return None, "the higher-resolution solve did not converge"


def _garbage(ctx, row, amp, ref_amp, system=None, omega=None):
    if ref_amp is None:
        from mshbm.methods.common import linear_response

        try:
            qh = linear_response(system, omega, 5)
            scale = float(np.max(np.abs(qh))) * 10 + 1.0
        except Exception:  # noqa: BLE001
            scale = 1.0
    else:
        scale = float(np.max(np.abs(ref_amp))) + 1e-300
    if float(np.max(np.abs(amp))) > ctx.cfg["garbage_factor"] * scale:
        row.update(outcome="WRONG", message=f"garbage: amplitude {np.max(np.abs(amp)):.3g} vs scale {scale:.3g}")
    return row


def opt_text(method, opts):
    parts = []
    for k in ("harmonics", "steps", "guess"):
        if k in opts:
            v = opts[k]
            if k == "guess" and not isinstance(v, str):
                v = f"solution at omega={v.omega:.4g}" if hasattr(v, "omega") else "dict"
            parts.append(f"{ {'harmonics': 'n_h', 'steps': 'N', 'guess': 'guess'}[k] }={v}")
    return ", ".join(parts)


def new_row(category, case, omega, method, opts, **extra):
    row = {"category": category, "case": case, "omega": float(omega), "method": method,
           "options": opt_text(method, opts)}
    row.update(extra)
    return row


def solve_and_evaluate(ctx, category, case, system, omega, method, opts, ref_cache, use_continuation=False,
                       **extra):
    sol, exc, wall = run_solve(ctx, system, omega, method, opts, use_continuation=use_continuation)
    row = new_row(category, case, omega, method, opts, **extra)
    if use_continuation:
        row["options"] += (", " if row["options"] else "") + "continuation"
    row["time_s"] = wall
    evaluate(ctx, row, system, omega, method, {k: v for k, v in opts.items()}, sol, exc, ref_cache)
    return row, sol


# ----------------------------------------------------------------------------- groups of work
def group_resonance(ctx, sysname, omega, tag, methods):
    system = build_system(ctx.cfg["systems"][sysname], sysname)
    rows, cache = [], {}
    for method, mo in methods.items():
        mo = dict(mo)
        if method == "shooting" and system.n > mo.pop("max_dofs", 10 ** 9):
            continue
        mo.pop("max_dofs", None)
        row, _ = solve_and_evaluate(ctx, "resonance", sysname, system, omega, method, mo, cache, point=tag)
        rows.append(row)
    return rows


def group_stiff(ctx, kind, spec, value, omega):
    cfg = ctx.cfg
    sysname = spec["system"]
    rows, cache = [], {}
    if kind == "kappa":
        system = build_system(cfg["systems"][sysname], sysname, kappa=value)
        row, _ = solve_and_evaluate(ctx, "stiff", sysname, system, omega, "hbm", {"harmonics": spec["harmonics"]},
                                    cache, point=f"kappa={value:g}")
        rows.append(row)
    elif kind == "penalty":
        system = build_system(cfg["systems"][sysname], sysname, penalty=value)
        row, _ = solve_and_evaluate(ctx, "stiff", sysname, system, omega, "hbm", {"harmonics": spec["harmonics"]},
                                    cache, point=f"k_c={value:g}")
        rows.append(row)
    elif kind == "harmonics":
        system = build_system(cfg["systems"][sysname], sysname)
        method, n_h = value
        opts = {"harmonics": n_h}
        if method != "hbm":
            opts["steps"] = max(spec["steps"], 4 * n_h + 4)
        row, _ = solve_and_evaluate(ctx, "stiff", sysname, system, omega, method, opts, cache, point=f"n_h={n_h}")
        rows.append(row)
    elif kind == "steps":
        system = build_system(cfg["systems"][sysname], sysname)
        method, steps = value
        opts = {"steps": steps}
        if method != "shooting":
            opts["harmonics"] = spec["harmonics"]
        row, _ = solve_and_evaluate(ctx, "stiff", sysname, system, omega, method, opts, cache, point=f"N=2^{int(round(math.log2(steps)))}")
        rows.append(row)
    return rows


def group_starts(ctx, sysname, omega, method, mopts, starts, random=None):
    """Poor starts with and without continuation; the far guesses are the method's own solutions."""
    if random is not None:
        rng = np.random.default_rng([random["seed"], 1000 + random["index"]])
        system, omega, desc = random_system(rng, random["index"], random["max_dofs"])
        system.name = sysname
    else:
        system = build_system(ctx.cfg["systems"][sysname], sysname)
    rows, cache = [], {}
    guesses = {}
    for s in starts:
        if s in ("zero", "linear"):
            guesses[s] = s
        else:
            om_g = omega * (0.5 if s == "half" else 2.0)
            g, exc, _ = run_solve(ctx, system, om_g, method, dict(mopts))
            guesses[s] = g if g is not None else "zero"
    for s in starts:
        for cont in (False, True):
            opts = dict(mopts)
            opts["guess"] = guesses[s]
            row, _ = solve_and_evaluate(ctx, "starts", sysname, system, omega, method, opts, cache,
                                        use_continuation=cont, start=s,
                                        guess_converged=bool(getattr(guesses[s], "success", True)))
            rows.append(row)
    return rows


def group_random(ctx, index, seed, max_dofs, methods):
    rng = np.random.default_rng([seed, index])
    system, omega, desc = random_system(rng, index, max_dofs)
    rows, cache = [], {}
    for method, mo in methods.items():
        mo = dict(mo)
        if system.n > mo.pop("max_dofs", 10 ** 9):
            continue
        row, _ = solve_and_evaluate(ctx, "random", system.name, system, omega, method, mo, cache, point=desc)
        rows.append(row)
    return rows


def _alarm(signum, frame):
    raise TimeoutError("group timed out")


def run_group(args):
    """Worker entry: ``(ctx, name, kwargs) -> rows`` with a wall-clock limit."""
    ctx, fname, kwargs, label = args
    fn = globals()[fname]
    t0 = time.perf_counter()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(int(math.ceil(ctx.cfg["group_timeout_s"])))
    try:
        rows = fn(ctx, **kwargs)
    except TimeoutError:
        rows = [{"category": label[0], "case": label[1], "omega": label[2], "method": "(group)", "options": "",
                 "outcome": "failed-with-diagnosis", "residual": None, "error": None, "reference": "",
                 "message": f"stress harness: group exceeded {ctx.cfg['group_timeout_s']} s", "timeout": True}]
    except Exception as exc:  # noqa: BLE001 -- a crash of the harness or the library: a WRONG row
        rows = [{"category": label[0], "case": label[1], "omega": label[2], "method": "(group)", "options": "",
                 "outcome": "WRONG", "residual": None, "error": None, "reference": "",
                 "message": f"crash: {type(exc).__name__}: {exc} | " + " ".join(traceback.format_exc().split()[-40:])}]
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    for r in rows:
        r.setdefault("time_s", None)
    return label, rows, time.perf_counter() - t0


def plan(cfg, profile):
    """List of work groups ``(function name, kwargs, label)``."""
    P = cfg["profiles"][profile]
    out = []
    res = P["resonance"]
    for sysname in res["systems"]:
        system = build_system(cfg["systems"][sysname], sysname)
        g = res["omega_grid"]
        oms = [(float(w), "grid") for w in np.linspace(g["start"], g["stop"], g["num"])] if g["num"] else []
        wr = linear_resonances(system)
        for m in res["resonances"]["modes"]:
            if m >= wr.size:
                continue
            for k in res["resonances"]["harmonics"]:
                for off in res["resonances"]["offsets"]:
                    w = float(wr[m] / k * (1 + off))
                    if g["start"] <= w <= g["stop"]:
                        oms.append((w, f"omega_{m + 1}/{k}*(1{off:+.0e})" if off else f"omega_{m + 1}/{k} exactly"))
        for w, tag in oms:
            out.append(("group_resonance", dict(sysname=sysname, omega=w, tag=tag, methods=res["methods"]),
                        ("resonance", sysname, w)))
    st = P["stiff"]
    for kind in ("kappa", "penalty", "harmonics", "steps"):
        spec = st[kind]
        for opi in as_list(spec["omega_over_pi"]):
            w = float(opi) * math.pi
            if kind in ("kappa", "penalty"):
                values = [float(v) for v in spec["values"]]
            elif kind == "harmonics":
                values = [("mshbm", int(v)) for v in spec["mshbm"]] + [("hbm", int(v)) for v in spec["hbm"]]
            else:
                values = [("mshbm", int(v)) for v in spec["mshbm"]] + [("shooting", int(v)) for v in spec["shooting"]]
                if spec.get("shooting_big"):
                    values.append(("shooting", int(spec["shooting_big"])))
            for v in values:
                out.append(("group_stiff", dict(kind=kind, spec=spec, value=v, omega=w), ("stiff", spec["system"], w)))
    sp = P["starts"]
    for sysname in sp["systems"]:
        for opi in as_list(sp["omega_over_pi"]):
            for method, mo in sp["methods"].items():
                out.append(("group_starts", dict(sysname=sysname, omega=float(opi) * math.pi, method=method,
                                                 mopts=dict(mo), starts=sp["starts"]),
                            ("starts", sysname, float(opi) * math.pi)))
    for i in range(sp.get("random", {}).get("count", 0)):
        for method, mo in sp["methods"].items():
            rnd = {"seed": sp["random"]["seed"], "index": i, "max_dofs": sp["random"]["max_dofs"]}
            out.append(("group_starts", dict(sysname=f"start-random{i}", omega=1.0, method=method, mopts=dict(mo),
                                             starts=sp["starts"], random=rnd), ("starts", f"start-random{i}", None)))
    rd = P["random"]
    for i in range(rd["count"]):
        out.append(("group_random", dict(index=i, seed=rd["seed"], max_dofs=rd["max_dofs"], methods=rd["methods"]),
                    ("random", f"random{i}", None)))
    return out


# ----------------------------------------------------------------------------- reporting
def start_rates(rows):
    """Convergence rates from poor starts per (method, start, with/without continuation).

    ``rate`` counts every problem; ``rate_solvable`` only the problems (case, omega, method) where at
    least one start (with or without continuation) converged.
    """
    solvable = set()
    for r in rows:
        if r["category"] == "starts" and r["outcome"] == "converged":
            solvable.add((r["case"], r["omega"], r["method"]))
    rates = {}
    for r in rows:
        if r["category"] != "starts" or r["method"] == "(group)":
            continue
        key = (r["method"], r["start"], "with" if "continuation" in r["options"] else "without")
        c = rates.setdefault(key, [0, 0, 0, 0])
        ok = r["outcome"] == "converged"
        c[0] += ok
        c[1] += 1
        if (r["case"], r["omega"], r["method"]) in solvable:
            c[2] += ok
            c[3] += 1
    out = []
    for (m, s, w), (ok, tot, oks, tots) in sorted(rates.items()):
        out.append({"method": m, "start": s, "continuation": w, "converged": ok, "total": tot,
                    "rate": ok / tot if tot else None, "converged_solvable": oks, "solvable": tots,
                    "rate_solvable": oks / tots if tots else None})
    return out


def _fmt(x, spec=".2e"):
    if x is None:
        return "–"
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    return format(x, spec)


def markdown(summary):
    rows = summary["rows"]
    lines = [f"# mshbm stress suite ({summary['profile']})", "",
             f"{len(rows)} solves in {summary['wall_time_s']:.0f} s on {summary['jobs']} worker(s); "
             "outcomes: " + ", ".join(f"{k}: {v}" for k, v in summary["counts"].items()) + ".", "",
             f"Error: max_i |A_i - A_ref,i| / max(max_i |A_ref,i|, {summary['error_floor']:g} max_i |A_lin,i|) (A: half peak-to-peak amplitude over one period; A_lin: linear response without the elements). "
             "Tolerances: " + ", ".join(f"{k} {v:g}" for k, v in summary["tolerance"].items()) + ".", ""]
    cats = [("resonance", "Near-resonant harmonics (c = 0)"), ("stiff", "Stiff regularisations, many harmonics, tiny steps"),
            ("starts", "Poor starts"), ("random", "Random chains")]
    for cat, title in cats:
        sel = [r for r in rows if r["category"] == cat]
        if not sel:
            continue
        lines += [f"## {title}", "",
                  "| case | omega | point | method | options | outcome | residual | error | time (s) | reference / message |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in sel:
            note = r.get("reference") or ""
            if r["outcome"] != "converged":
                note = r.get("message", "")
            note = note.replace("|", "\\|")
            if len(note) > 140:
                note = note[:137] + "..."
            point = r.get("point") or r.get("start") or ""
            if cat == "random":
                point = point.split(": ", 1)[-1]
            lines.append(f"| {r['case']} | {_fmt(r.get('omega'), '.6g')} | {point} | {r['method']} | {r['options']} | "
                         f"{'**WRONG**' if r['outcome'] == 'WRONG' else r['outcome']} | {_fmt(r.get('residual'))} | "
                         f"{_fmt(r.get('error'))} | {_fmt(r.get('time_s'), '.2f')} | {note} |")
        lines.append("")
    cf = [r for r in rows if r["outcome"] == "failed-certificate"]
    lines += ["## Certificate failures", "",
              f"{len(cf)} solve(s) where Newton converged but the certificate (mshbm.certificate) refused the answer"
              + (":" if cf else "."), ""]
    if cf:
        from collections import Counter

        by = Counter((r["method"], ", ".join(r.get("certificate") or [])) for r in cf)
        lines += ["| method | failed checks | solves |", "|---|---|---|"]
        lines += [f"| {m} | {c} | {k} |" for (m, c), k in sorted(by.items())]
        lines.append("")
    if summary["start_rates"]:
        lines += ["## Convergence from poor starts", "",
                  "Solvable: problems (case, omega, method) where at least one start converged.", "",
                  "| method | start | continuation fallback | converged (all) | rate | converged (solvable) | rate |",
                  "|---|---|---|---|---|---|---|"]
        for s in summary["start_rates"]:
            lines.append(f"| {s['method']} | {s['start']} | {s['continuation']} | {s['converged']}/{s['total']} | "
                         f"{_fmt(s['rate'], '.0%')} | {s['converged_solvable']}/{s['solvable']} | "
                         f"{_fmt(s['rate_solvable'], '.0%')} |")
        lines.append("")
    return "\n".join(lines) + "\n"


def json_safe(obj):
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, (bool, str)) or obj is None:
        return obj
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    try:
        x = float(obj)
    except (TypeError, ValueError):
        return str(obj)
    return x if math.isfinite(x) else None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--config", default="workflow/stress.yaml")
    ap.add_argument("--out", default="results/stress")
    ap.add_argument("--quick", action="store_true", help="the quick profile (a few points per category)")
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--only", default=None, help="run only this category (resonance, stiff, starts, random)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    try:
        cfg = load_config(args.config)
    except (OSError, ValueError, yaml.YAMLError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    profile = "quick" if args.quick else "full"
    groups = plan(cfg, profile)
    if args.only:
        groups = [g for g in groups if g[2][0] == args.only]
    ctx = Ctx(cfg)
    work = [(ctx, f, kw, label) for f, kw, label in groups]
    # the expensive groups first (better packing on few workers)
    order = sorted(range(len(work)), key=lambda i: -_cost_hint(work[i]))
    results = [None] * len(work)
    jobs = max(1, int(args.jobs))
    print(f"stress ({profile}): {len(work)} groups on {jobs} worker(s)", file=sys.stderr, flush=True)
    if jobs == 1:
        for i in order:
            results[i] = run_group(work[i])
            _progress(results[i])
    else:
        ctx_mp = multiprocessing.get_context("fork")
        with ctx_mp.Pool(jobs, maxtasksperchild=20) as pool:
            for i, res in zip(order, pool.imap(run_group, [work[i] for i in order])):
                results[i] = res
                _progress(res)
    rows = [r for _, rs, _ in results for r in rs]
    counts = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES}
    summary = {"profile": profile, "config": str(args.config), "jobs": jobs, "tolerance": cfg["tolerance"],
               "error_floor": cfg["error_floor"], "few_harmonics": cfg.get("few_harmonics"),
               "counts": counts, "rows": rows, "start_rates": start_rates(rows),
               "timeouts": sum(bool(r.get("timeout")) for r in rows),
               "wall_time_s": time.perf_counter() - t0,
               "group_times_s": [{"label": list(lbl), "time_s": t} for lbl, _, t in results],
               "mshbm_version": mshbm.__version__}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = json_safe(summary)
    (out / "summary.json").write_text(json.dumps(summary, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    (out / "summary.md").write_text(markdown(summary), encoding="utf-8")
    print(f"stress ({profile}): {len(rows)} rows, {counts}, {summary['wall_time_s']:.1f} s -> {out}/summary.{{json,md}}",
          file=sys.stderr)
    return 0


def _cost_hint(item):
    _, fname, kw, _ = item
    if fname == "group_stiff" and kw["kind"] == "steps":
        return kw["value"][1] / 1000.0
    if fname == "group_starts":
        return 50.0
    if fname == "group_random":
        return 20.0
    return 1.0


def _progress(res):
    label, rows, t = res
    bad = [r for r in rows if r["outcome"] == "WRONG"]
    print(f"  {label[0]:<9} {label[1]:<10} {'' if label[2] is None else f'{label[2]:.6g}':<10} {t:6.1f} s"
          f"{'  WRONG: ' + '; '.join(r['method'] + ' ' + r['message'][:100] for r in bad) if bad else ''}",
          file=sys.stderr, flush=True)


if __name__ == "__main__":
    sys.exit(main())
