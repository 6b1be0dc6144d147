#!/usr/bin/env python
"""Branch-tracing benchmark against pyHarm's own continuation (``pyHarm-os``, Safran).

The time to trace the same frequency-response branch (same omega range, same discretisation) with
each of our methods (``mshbm.sweep``: shooting, MS-HBM, HBM, DLFT) and with pyHarm's FRF analysis
(its predictor-corrector arclength continuation) on the same equations, side by side in one
process, and how far pyHarm's continuation gets.

pyHarm lives in its own virtual environment (rule ``pyharm_env``); as ``bench_pyharm.py`` does, this
script re-runs itself with that interpreter (``--pyharm-python``, ``$PYHARM_PYTHON``; default
``envs/pyharm/bin/python``) with this repository's ``src`` and ``workflow/lib`` on ``PYTHONPATH`` (``pyharmlib.py``: the
environment handling and the pyHarm models of both scripts).  Without pyHarm the JSON gets
``"status": "unavailable"`` with the reason.

Systems and discretisations (the workflow's Fig. 9 branches, config ``branches``, read from
``--config``: the workflow passes its ``results/config.json``; default ``workflow/config.yaml``):

* ``friction3`` (examples/friction3.yaml), omega in [0.55, 1.2].  Ours: shooting and MS-HBM with
  the set-valued Coulomb law and the workflow's steps, HBM (arctan law, kappa = 800) and DLFT (its
  default parameter) with the workflow's n_H; and the two laws pyHarm ships for friction, at
  n_H = 9 and ``NTI_FRICTION`` = 512 AFT samples in both codes (our default sampling for n_H = 9,
  that of the workflow's HBM and DLFT branches):

  - ``jenkins``: elastic Coulomb friction, tangential stiffness ``K_T`` (pyHarm ``Jenkins``,
    ours :class:`mshbm.elements.Jenkins` with HBM).  pyHarm has no arctan-regularised friction; its
    Jenkins element and ours are the same discrete equations (pyHarm's residual at our solution is
    at rounding level, ``same_equations_check``).  A second pair at ``NTI_FRICTION_COARSE`` = 128
    samples, where pyHarm's continuation passes the stick transition near omega = 1;
  - ``dlft`` (full profile): pyHarm ``DLFTFriction`` and our ``dlft``, both with DLFT parameter ``EPS_DLFT``.  The
    two DLFT formulations differ (pyHarm's residual at our solution is not small, and its converged
    point differs); compared through the reference branch below.

* ``impact5`` (examples/impact5.yaml), omega in [0.5, 0.75].  Ours: shooting and MS-HBM
  (set-valued impact law, the workflow's steps and ``max_points``), DLFT, and HBM with the penalty
  law (k_c = 8000, d_c = 0); pyHarm: ``PenaltyUnilateralGap`` (the same penalty law; HBM n_H = 5,
  512 AFT samples in both, the settings of ``bench_pyharm.py``).

pyHarm runs (:func:`specs`): its defaults (solver ``scipyroot`` = MINPACK hybr, tangent
predictor, ``arc_length`` corrector, step doubling/halving ``acceptance``, ``ds0 = ds_max = 1``,
``ds_min = 1e-8``, stop at the omega bounds or two steps at ``ds_min``) from its own start (the
linear response at the first omega); on the impact chain, where that start fails, also from our
converged HBM solution there with the defaults and, in the full profile only, with ``ds_max = 0.1`` and with
``NewtonRaphson`` (``ds_max = 0.05``).  pyHarm's ``DLFTFriction`` pair (``dlft`` above) is also in the full
profile only: these three runs spend their whole budget (about 140 s of the main job's CPU) and the paper quotes
none of their numbers, so the default profile (``snakemake``) keeps the comparisons it quotes.  Each run stops
after a budget of CPU time (:func:`pyharm_budget`): ten times the CPU time of our branch on the same equations
(its twin), at least 10 s and at most ``PYHARM_BUDGET`` (20 s; the full profile 300 s fixed).

Measured per branch: wall and CPU time of this process (untimed warm-up first: numba/jax
compilation; BLAS limited to one thread for both codes; CPU time is the fairer number on a loaded
machine), number of points,
the omega range reached and why it stopped; pyHarm's accepted points also get their residual
(``max |R| / max |f|``, pyHarm's own residual function).  Amplitudes ``(max - min) / 2`` per DOF
(pyHarm's points: the exact extrema of their Fourier series, :func:`mshbm.extrema.fourier_extrema`).
Agreement (:func:`branch_difference`): the max relative amplitude difference of two branches at
the frequencies of the one with fewer points, the other interpolated linearly in omega on its
monotone pieces (folds: the nearest sheet), ``max_dof |A - A'| / max_dof |A'|``; for every branch
against the system's reference (our shooting branch, set-valued law) and for the same-law pairs.
Where the branches are sampled differently that number includes the interpolation error; for the
same-law pairs :func:`pointwise` therefore also runs our solver at a few of pyHarm's points, started
from pyHarm's coefficients, and reports the difference at equal omega.

Usage::

    python workflow/scripts/bench/bench_pyharm_sweep.py --out results/benchmarks/pyharm_sweep.json [--quick] \
        [--config results/config.json] [--pyharm-python envs/pyharm/bin/python]
"""
from __future__ import annotations

import os
import sys
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
CONFIG = os.path.normpath(os.path.join(HERE, "..", "..", "config.yaml"))

import numpy as np  # noqa: E402

from mshbm_workflow import benchlib as bl  # noqa: E402
from mshbm_workflow import pyharmlib as phl  # noqa: E402
#: friction laws shared with pyHarm: n_H, AFT samples (our default for n_H = 9, as in the workflow's HBM and
#: DLFT branches), Jenkins tangential stiffness (N/m), DLFT parameter (N/m); and the coarser sampling of a
#: second Jenkins pair (where pyHarm's continuation passes)
N_H_FRICTION, NTI_FRICTION, K_T, EPS_DLFT = 9, 512, 100.0, 10.0
NTI_FRICTION_COARSE = 128
#: penalty contact (bench_pyharm.py's settings): n_H, AFT samples
N_H_IMPACT, NTI_IMPACT = 5, 512
#: CPU seconds per pyHarm continuation run, by profile (:func:`pyharm_branch`, :func:`pyharm_budget`): at most
#: PYHARM_BUDGET, and with a factor (quick, default) that factor times the CPU time of our branch on the same
#: equations (its twin), at least PYHARM_BUDGET_MIN.  pyHarm's runs that spend the budget crawl: in a run with
#: 60 s each (friction3 Jenkins and DLFT, impact5 Newton) they reached their final omega (to 1e-4) within the
#: first 2-4 % of their points, so ten times our time decides what the paper reports as well as 60 s did.  The
#: default profile (the main job) caps it at 20 s: the Jenkins run on the friction chain, whose budget the cap
#: binds (ten times our 6.2 s), reached the omega the paper quotes after 39 of its 1281 points in 60 s (about 2 s).
PYHARM_BUDGET = {"quick": 20, "default": 20, "full": 300}
PYHARM_BUDGET_FACTOR = {"quick": 10.0, "default": 10.0, "full": None}
PYHARM_BUDGET_MIN = 10.0
#: a pyHarm point counts as converged when max |R| / max |f| <= this (ours: ||R / s||_inf <= 1e-10 with force
#: rows scaled by the forcing; pyHarm's hybr accepts points with max |R| / max |f| up to ~1e-4 on the impact chain)
RESIDUAL_OK = 1e-8
#: pyHarm points per same-law pair at which our solver is run from pyHarm's solution (:func:`pointwise`)
POINTWISE = 5
#: pyHarm's FRF defaults (FRF_NonLinear.default), written out so that the JSON records them
PYHARM_DEFAULTS = {"solver": "scipyroot", "predictor": "tangent", "corrector": "arc_length",
                   "stepsizer": "acceptance", "ds0": 1.0, "ds_max": 1.0, "ds_min": 1e-8}


# ----------------------------------------------------------------------------- branch comparison
def monotone_segments(omega):
    """Maximal runs of strictly monotone ``omega`` (shape (m,)): a list of ``(i0, i1)`` (inclusive
    index ranges, ``i1 > i0``).  A fold (sign change of the omega increment) or a repeated omega ends a
    run; a fold point belongs to both runs it joins."""
    w = np.asarray(omega, dtype=float).reshape(-1)
    if w.size < 2:
        return []
    s = np.sign(np.diff(w))
    out, i0 = [], None
    for k, sk in enumerate(s):
        if sk == 0:
            if i0 is not None:
                out.append((i0, k))
            i0 = None
            continue
        if i0 is None:
            i0 = k
        elif sk != s[k - 1]:
            out.append((i0, k))
            i0 = k
    if i0 is not None:
        out.append((i0, w.size - 1))
    return out


def branch_difference(omega_a, amp_a, omega_b, amp_b):
    """Relative amplitude difference of branch ``a`` against branch ``b`` at ``a``'s frequencies.

    Parameters
    ----------
    omega_a, omega_b : array, shapes (m_a,), (m_b,)
        Frequencies (rad/s) of the branch points, in branch order (folds allowed).
    amp_a, amp_b : array, shapes (m_a, n), (m_b, n)
        Amplitudes per point and DOF (m).

    Returns
    -------
    dict
        ``max`` and ``median`` over the compared points of
        ``max_dof |A_a - A_b(omega)| / max_dof |A_b(omega)|``, ``points_compared``, ``omega_range``
        (compared frequencies), ``omega_at_max``.  ``A_b(omega)`` is linear interpolation on each
        monotone piece of ``b`` (:func:`monotone_segments`) that contains ``omega``; where several do
        (folds, retraced parts) the nearest is used.  Points of ``a`` outside every piece are not
        compared; with none compared the numbers are ``None``.
    """
    wa = np.asarray(omega_a, dtype=float).reshape(-1)
    wb = np.asarray(omega_b, dtype=float).reshape(-1)
    Aa = np.asarray(amp_a, dtype=float).reshape(wa.size, -1)
    Ab = np.asarray(amp_b, dtype=float).reshape(wb.size, -1)
    if Aa.shape[1] != Ab.shape[1]:
        raise ValueError(f"amplitudes of different DOF counts: {Aa.shape[1]} and {Ab.shape[1]}")
    rel = np.full(wa.size, np.inf)
    for i0, i1 in monotone_segments(wb):
        w, A = wb[i0:i1 + 1], Ab[i0:i1 + 1]
        if w[0] > w[-1]:
            w, A = w[::-1], A[::-1]
        inside = (wa >= w[0]) & (wa <= w[-1])
        if not inside.any():
            continue
        Ai = np.column_stack([np.interp(wa[inside], w, A[:, d]) for d in range(A.shape[1])])
        scale = np.maximum(np.max(np.abs(Ai), axis=1), 1e-300)
        r = np.max(np.abs(Aa[inside] - Ai), axis=1) / scale
        rel[inside] = np.minimum(rel[inside], r)
    ok = np.isfinite(rel)
    if not ok.any():
        return {"max": None, "median": None, "points_compared": 0, "omega_range": None, "omega_at_max": None}
    k = int(np.flatnonzero(ok)[np.argmax(rel[ok])])
    return {"max": float(rel[ok].max()), "median": float(np.median(rel[ok])), "points_compared": int(ok.sum()),
            "omega_range": [float(wa[ok].min()), float(wa[ok].max())], "omega_at_max": float(wa[k])}


def compare(entry_a, entry_b):
    """:func:`branch_difference` of two branch entries, evaluated at the points of the one with fewer
    points (the denser one interpolated); ``evaluated_at`` names it."""
    a, b = (entry_a, entry_b) if len(entry_a["omega"]) <= len(entry_b["omega"]) else (entry_b, entry_a)
    if len(a["omega"]) == 0 or len(b["omega"]) < 2:
        return {"max": None, "median": None, "points_compared": 0, "omega_range": None, "omega_at_max": None,
                "evaluated_at": a["name"]}
    d = branch_difference(a["omega"], a["amplitude"], b["omega"], b["amplitude"])
    d["evaluated_at"] = a["name"]
    return d


def unavailable(out, what, error):
    """The JSON and PNG without a pyHarm comparison (:func:`pyharmlib.unavailable`)."""
    return phl.unavailable(out, "pyharm_sweep", what, error, "pyHarm branch comparison unavailable")


# ----------------------------------------------------------------------------- the systems
def load_config(path=None):
    """The workflow configuration: ``path`` (the workflow's ``results/config.json`` or a YAML file),
    default workflow/config.yaml."""
    import json

    from mshbm.io.yaml import load_yaml, read_text

    path = path or CONFIG
    if str(path).endswith(".json"):
        with open(path) as fh:
            return json.load(fh)
    return load_yaml(read_text(path))


def branch_config(config, name):
    """``branches`` entry ``name`` of the configuration (omega range, methods, max_points) and the case
    file of its system."""
    b = next((b for b in config["branches"] if b["name"] == name), None)
    if b is None:
        raise KeyError(f"the configuration has no branch {name!r} (config `branches`)")
    return b, config["systems"][b["system"]]["case"]


def specs(profile, config=None):
    """The systems, our runs and pyHarm's runs of a profile.

    ``config``: the workflow configuration (default :func:`load_config`); its branches ``friction3``
    and ``impact5`` give the omega ranges, our methods' options and ``max_points``.
    Returns a list of dicts ``{name, case, omega: [w0, w1], ours: [run], pyharm: [run], reference,
    pairs}``; our run ``{name, method, options, law[, element]}``, pyHarm's ``{name, law, start, analysis}``.
    """
    quick, full = profile == "quick", profile == "full"
    config = load_config() if config is None else config
    (f_cfg, f_case), (i_cfg, i_case) = branch_config(config, "friction3"), branch_config(config, "impact5")
    fm, im = f_cfg["methods"], i_cfg["methods"]
    out = []
    # ---- friction3
    w = [0.55, 0.7] if quick else [float(v) for v in f_cfg["omega"]]
    jen = {"harmonics": N_H_FRICTION, "steps": NTI_FRICTION}
    coarse = {"harmonics": N_H_FRICTION, "steps": NTI_FRICTION_COARSE}
    ours = [
        {"name": "shooting", "method": "shooting", "law": "set-valued Coulomb",
         "options": dict(fm["shooting"])},
        {"name": "mshbm", "method": "mshbm", "law": "set-valued Coulomb",
         "options": dict(fm["mshbm"])},
        {"name": "hbm", "method": "hbm", "law": "arctan (kappa from the case file)", "options": dict(fm["hbm"])},
        {"name": "dlft", "method": "dlft", "law": "set-valued Coulomb (DLFT, default parameter)",
         "options": dict(fm["dlft"])},
        {"name": "hbm-jenkins", "method": "hbm", "law": "jenkins", "element": {"tangential_stiffness": K_T},
         "options": dict(jen)},
        {"name": f"hbm-jenkins-{NTI_FRICTION_COARSE}", "method": "hbm", "law": "jenkins",
         "element": {"tangential_stiffness": K_T}, "options": dict(coarse)},
    ]
    # pyHarm from its own start (the linear response); from our start it reached the same omega to 1e-9
    # in the measurements of the development runs, so only the impact chain (where its start fails) has both
    py = [{"name": "pyharm-jenkins", "law": "jenkins", "start": "linear", "twin": "hbm-jenkins", "analysis": {}},
          {"name": f"pyharm-jenkins-{NTI_FRICTION_COARSE}", "law": "jenkins", "start": "linear",
           "twin": f"hbm-jenkins-{NTI_FRICTION_COARSE}", "analysis": {}}]
    if full:  # pyHarm's DLFT spends its whole budget (about 20 s of CPU) and the paper quotes none of its numbers
        ours.append({"name": "dlft-eps", "method": "dlft", "law": "dlft", "options": dict(jen, dlft_penalty=EPS_DLFT)})
        py.append({"name": "pyharm-dlft", "law": "dlft", "start": "linear", "twin": "dlft-eps", "analysis": {}})
    _estimates_as_branch(ours, f_cfg)
    out.append({"name": "friction3", "case": f_case, "omega": w, "ours": ours, "pyharm": py,
                "reference": "shooting",
                "pairs": [(r["twin"], r["name"]) for r in py]})
    # ---- impact5
    w = [0.5, 0.56] if quick else [float(v) for v in i_cfg["omega"]]
    mp = {} if quick else {"max_points": int(i_cfg["max_points"])}
    hb = {"harmonics": N_H_IMPACT, "steps": NTI_IMPACT}
    ours = [
        {"name": "shooting", "method": "shooting", "law": "set-valued impact (Newton, e_N)",
         "options": dict({"steps": 512} if quick else im["shooting"], **mp)},
        {"name": "mshbm", "method": "mshbm", "law": "set-valued impact (Newton, e_N)",
         "options": dict({"harmonics": 5, "steps": 1024} if quick else im["mshbm"], **mp)},
        # the penalty law at the AFT samples, as pyHarm evaluates it (sweep's default for contacts is the linear
        # quadrature, mshbm.methods.hbm): the same equations
        {"name": "hbm", "method": "hbm", "law": "penalty", "options": dict(hb, penalty_quadrature="samples", **mp)},
        {"name": "dlft", "method": "dlft", "law": "set-valued contact (DLFT, default parameter)",
         "options": dict(hb, **mp)},
    ]
    if not quick:  # the labelled variants of the Fig. 9 branch (e.g. mshbm-event: the exact event-driven flow)
        for label, opts in im.items():
            # the curves above keep their settings (hbm: n_H and the sampled law of pyHarm's twin; Fig. 9's own
            # HBM curve, n_H = 40 with the linear quadrature, would replace the twin of the same name)
            if label not in {r["name"] for r in ours}:
                o = {k: v for k, v in opts.items() if k != "method"}
                ours.append({"name": label, "method": opts.get("method", label),
                             "law": "set-valued impact (Newton, e_N), " + (
                                 "event-driven flow" if o.get("integrator") == "event" else "Moreau-Jean"),
                             "options": dict(o, **mp)})
    py = [{"name": "pyharm-penalty-linear", "law": "penalty", "start": "linear", "twin": "hbm", "analysis": {}},
          {"name": "pyharm-penalty-ours", "law": "penalty", "start": "ours", "twin": "hbm", "analysis": {}}]
    if full:  # two more step controls from our start: each spends its budget (about 60 s of CPU) where the
        # default run stalls, and the paper quotes the default run only
        py += [{"name": "pyharm-penalty-ours-ds0.1", "law": "penalty", "start": "ours", "twin": "hbm",
                "analysis": {"ds0": 0.1, "ds_max": 0.1}},
               {"name": "pyharm-penalty-ours-newton", "law": "penalty", "start": "ours", "twin": "hbm",
                "analysis": {"solver": "NewtonRaphson", "ds0": 0.05, "ds_max": 0.05}}]
    _estimates_as_branch(ours, i_cfg)
    out.append({"name": "impact5", "case": i_case, "omega": w, "ours": ours, "pyharm": py,
                "reference": "shooting",
                "pairs": [(r["twin"], r["name"]) for r in py]})
    return out


def _estimates_as_branch(ours, branch):
    """Our runs make per-point error estimates as the workflow's curve of the system does (its branch's
    ``accuracy``; ``false`` in the main run: the discretised equations only, as pyHarm solves them)."""
    if branch.get("accuracy") is False:
        for run in ours:
            run["options"]["accuracy"] = False


def our_system(case, element=None):
    from mshbm_workflow import wfcore

    return wfcore.chain_case(case, **(element or {}))


def twin_of(spec, run):
    """Our run with the same law and discretisation as pyHarm's ``run`` (its ``twin``): its system, start, n_H
    and AFT samples."""
    return next(r for r in spec["ours"] if r["name"] == run["twin"])


# ----------------------------------------------------------------------------- pyHarm side
def _timeout_str(seconds):
    s = int(max(1, round(seconds)))
    return f"{s // 86400:02d}:{s % 86400 // 3600:02d}:{s % 3600 // 60:02d}:{s % 60:02d}"


def pyharm_input(system, law, w0, w1, n_h, nti, analysis, timeout_s):
    """pyHarm input dict: one ``substructure`` (our M, C, K, one DOF per node), a ``CosinusForcing``,
    the element as connector to the ground, system ``Base`` without adimensionalisation, one FRF
    analysis over ``[w0, w1]`` with pyHarm's defaults updated by ``analysis`` (:func:`pyharmlib.model_input`,
    :func:`pyharmlib.connector`)."""
    conn = phl.connector(system, law, eps_dlft=EPS_DLFT)
    ana = dict(PYHARM_DEFAULTS, study="frf", puls_inf=float(w0), puls_sup=float(w1), verbose=False,
               stopper_options={"timeout": {"status": True, "timeout": _timeout_str(timeout_s)}})
    ana.update(analysis)
    return phl.model_input(system, n_h, nti, conn, {"frf": ana}, element_name="element")


def reach_fraction(omega, rtol=1e-4):
    """Fraction of a branch's points (``omega``, shape (m,), in branch order) passed before the first point
    within ``rtol`` of the largest omega: how early a run that ends on a budget got where it ended (``None``
    without points)."""
    w = np.asarray(omega, dtype=float).reshape(-1)
    if w.size == 0:
        return None
    top = float(w.max())
    return float(np.argmax(w >= top - rtol * abs(top)) / w.size)


def pyharm_budget(profile, twin_cpu_s):
    """CPU seconds of one pyHarm continuation run: ``min(PYHARM_BUDGET, max(PYHARM_BUDGET_MIN, factor *
    twin_cpu_s))`` with the profile's factor (``PYHARM_BUDGET_FACTOR``; ``None``, or no twin time: the fixed
    ``PYHARM_BUDGET``); ``twin_cpu_s`` is the CPU time of our branch on the same equations."""
    cap, factor = float(PYHARM_BUDGET[profile]), PYHARM_BUDGET_FACTOR[profile]
    if factor is None or twin_cpu_s is None:
        return cap
    return min(cap, max(PYHARM_BUDGET_MIN, factor * float(twin_cpu_s)))


def pyharm_branch(system, run, w0, w1, n_h, nti, x0, budget_s):
    """pyHarm's continuation from ``x0`` (``q_hat`` (2 n_h + 1, n), or None: its linear start): the entry.

    pyHarm's FRF ``Solve`` loop (``initialise``, then ``makeStep`` and ``purge_jacobians`` until its stop
    criterion holds), driven here so that it also stops after ``budget_s`` seconds of *CPU* time of this
    process (pyHarm's own timeout counts wall time, which on a shared machine depends on the load)."""
    import pyHarm
    from mshbm.extrema import fourier_extrema

    n = system.n
    inp = pyharm_input(system, run["law"], w0, w1, n_h, nti, run["analysis"], 100 * budget_s + 3600)
    start = None if x0 is None else np.asarray(x0, float).reshape(-1)
    # warm-up (compilation of pyHarm's numba kernels): model and first point, untimed
    warm = pyHarm.Maestro(inp)
    warm.nls["frf"].initialise(None if start is None else start.copy())
    t0, c0 = time.perf_counter(), time.process_time()
    maestro = pyHarm.Maestro(inp)
    ana = maestro.nls["frf"]
    ana.initialise(None if start is None else start.copy())
    k, over_budget = 1, False
    while not ana.stopper.getStopCriterionStatus(ana.SolList[-1], ana.SolList):
        if time.process_time() - c0 > budget_s:
            over_budget = True
            break
        ana.makeStep(index_insolve=k)
        ana.purge_jacobians()
        k += 1
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    sols = ana.SolList
    acc = [s for s in sols if s.flag_accepted]
    f_max = float(np.max(np.abs(system.f_hat)))
    omega, amp, res = [], [], []
    for s in acc:
        x = np.asarray(s.x, dtype=float)
        q_hat = x[:-1].reshape(2 * n_h + 1, n)
        hi, lo = fourier_extrema(q_hat)
        omega.append(float(x[-1]))
        amp.append((0.5 * (hi - lo)).tolist())
        res.append(float(np.max(np.abs(np.asarray(maestro.system.Residual(x))))) / f_max)
    omega = np.array(omega)
    res = np.array(res)
    conv = res <= RESIDUAL_OK
    a = ana.analysis_options
    if len(acc) and omega[-1] >= a["puls_sup"] * (1 - 1e-6):
        stop = "reached omega_end"
    elif len(acc) > 1 and omega[-1] <= a["puls_inf"] * (1 + 1e-6):
        stop = "turned back and left the range at omega_start"
    elif over_budget:
        stop = f"CPU-time budget ({budget_s:.3g} s) spent"
    elif len(sols) >= 2 and sols[-1].ds == a["ds_min"] and sols[-2].ds == a["ds_min"]:
        stop = "step size at ds_min (stalled)"
    else:
        stop = "stopped"
    first_ok = bool(len(acc) and conv[0])
    entry = {"reach_fraction": reach_fraction(omega[conv]), "name": run["name"], "code": "pyharm", "law": run["law"], "start": run["start"],
             "analysis": {k: a[k] for k in ("solver", "predictor", "corrector", "stepsizer", "ds0", "ds_max", "ds_min")},
             "harmonics": n_h, "aft_samples": nti, "wall_time_s": wall, "cpu_time_s": cpu, "cpu_budget_s": budget_s,
             "points": int(len(acc)),
             "solutions_tried": int(len(sols)), "points_converged": int(conv.sum()),
             "start_converged": first_ok, "stop": stop,
             "omega_reached": float(omega[conv].max()) if conv.any() else None,
             "omega_reached_accepted": float(omega.max()) if len(acc) else None,
             "omega_last": float(omega[-1]) if len(acc) else None,
             "reached_end": bool(conv.any() and omega[conv].max() >= w1 * (1 - 1e-6)),
             "max_scaled_residual": float(res.max()) if len(acc) else None,
             "omega": omega[conv].tolist(), "amplitude": [amp[i] for i in np.flatnonzero(conv)],
             "residual_note": f"omega/amplitude hold the accepted points with max|R|/max|f| <= {RESIDUAL_OK:g}"}
    q_hats = [np.asarray(acc[i].x[:-1], dtype=float).reshape(2 * n_h + 1, n) for i in np.flatnonzero(conv)]
    return entry, (q_hats, res[conv].tolist())


def same_equations_check(system, run, w0, n_h, nti, q_hat):
    """pyHarm's residual (max |R| / max |f|) at our solution ``q_hat`` of the same law at ``w0``."""
    import pyHarm

    inp = pyharm_input(system, run["law"], w0, 1.01 * w0, n_h, nti, {}, 60)
    m = pyHarm.Maestro(inp)
    x = np.concatenate([np.asarray(q_hat, float).reshape(-1), [w0]])
    return float(np.max(np.abs(np.asarray(m.system.Residual(x))))) / float(np.max(np.abs(system.f_hat)))


# ----------------------------------------------------------------------------- our side
def our_branch(system, run, w0, w1, bare=False):
    """``mshbm.sweep`` of one method (after an untimed warm-up solve): the entry and the start solution.

    ``bare``: also time the sweep as pyHarm's continuation runs, for the same-law twins of pyHarm's runs:
    from our converged start (``guess``: the start solve then takes one Newton step) and without the
    stability analysis (``stability=False``; the certificate of every point stays), entry
    ``continuation_only``."""
    import mshbm
    from mshbm.branch import _CONT_KEYS

    opts = dict(run["options"])
    solve_opts = {k: v for k, v in opts.items() if k not in _CONT_KEYS}
    start = mshbm.solve(system, w0, run["method"], stability=False, **solve_opts)  # warm-up (compilation)
    t0, c0 = time.perf_counter(), time.process_time()
    b = mshbm.sweep(system, w0, w1, run["method"], **opts)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    om = b.omega
    entry = {"name": run["name"], "code": "mshbm", "method": run["method"], "law": run["law"],
             "options": dict(opts, **({"element": run["element"]} if run.get("element") else {})),
             "wall_time_s": wall, "cpu_time_s": cpu, "points": len(b), "success": bool(b.success),
             "message": b.message,
             "omega_reached": float(om.max()) if len(b) else None, "omega_last": float(om[-1]) if len(b) else None,
             "reached_end": bool(len(b) and om.max() >= w1 * (1 - 1e-6)),
             "counters": b.counters,
             "bifurcations": [{"type": x["type"], "omega": x.get("omega")} for x in b.bifurcations],
             "omega": om.tolist(), "amplitude": b.amplitude.tolist(), "stable": b.stable}
    if bare and start.success:
        t0, c0 = time.perf_counter(), time.process_time()
        b2 = mshbm.sweep(system, w0, w1, run["method"], guess={"q_hat": start.q_hat}, stability=False, **opts)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        entry["continuation_only"] = {
            "what": "mshbm.sweep(..., guess=our start solution, stability=False)", "wall_time_s": wall,
            "cpu_time_s": cpu, "points": len(b2), "success": bool(b2.success),
            "omega_reached": float(b2.omega.max()) if len(b2) else None}
    return entry, start


def run_system(spec, profile, log):
    w0, w1 = spec["omega"]
    entries, starts, errors = {}, {}, {}
    twins = {r["twin"] for r in spec["pyharm"]}
    for run in spec["ours"]:
        system = our_system(spec["case"], run.get("element"))
        try:
            e, start = our_branch(system, run, w0, w1, bare=run["name"] in twins)
        except Exception:
            errors[run["name"]] = traceback.format_exc()
            log(f"  {spec['name']} {run['name']}: FAILED\n{errors[run['name']]}")
            continue
        entries[run["name"]] = e
        starts[run["name"]] = start
        log(f"  {spec['name']} ours {run['name']:16s} {e['wall_time_s']:8.2f} s (CPU {e['cpu_time_s']:7.2f} s) "
            f"{e['points']:4d} points, omega up to "
            f"{e['omega_reached']:.4f}: {e['message'][:120]}"
            + (f"; from our start without stability: CPU {e['continuation_only']['cpu_time_s']:.2f} s, "
               f"{e['continuation_only']['points']} points" if e.get("continuation_only") else ""))
    checks, q_hats = {}, {}
    for run in spec["pyharm"]:
        twin = twin_of(spec, run)
        n_h, nti = int(twin["options"]["harmonics"]), int(twin["options"]["steps"])
        system = our_system(spec["case"], twin.get("element"))
        start = starts.get(twin["name"])
        x0 = None
        if run["start"] == "ours":
            if start is None or not start.success:
                errors[run["name"]] = f"no converged start from our {twin['name']} at omega = {w0}"
                continue
            x0 = start.q_hat
        try:
            budget = pyharm_budget(profile, (entries.get(twin["name"]) or {}).get("cpu_time_s"))
            e, q_hats[run["name"]] = pyharm_branch(system, run, w0, w1, n_h, nti, x0, budget)
            if start is not None and start.success and twin["name"] not in checks:
                checks[twin["name"]] = {"law": run["law"], "omega": w0, "harmonics": n_h, "aft_samples": nti,
                                        "pyharm_residual_at_our_solution": same_equations_check(
                                            system, run, w0, n_h, nti, start.q_hat)}
        except Exception:
            errors[run["name"]] = traceback.format_exc()
            log(f"  {spec['name']} {run['name']}: FAILED\n{errors[run['name']]}")
            continue
        e["start_from"] = twin["name"] if run["start"] == "ours" else "pyHarm's linear response"
        entries[run["name"]] = e
        log(f"  {spec['name']} {run['name']:27s} {e['wall_time_s']:8.2f} s (CPU {e['cpu_time_s']:7.2f} s) "
            f"{e['points']:5d} points "
            f"({e['points_converged']} converged), omega up to {e['omega_reached']}, last {e['omega_last']}: "
            f"{e['stop']}")
    ref = entries.get(spec["reference"])
    for name, e in entries.items():
        e["vs_reference"] = compare(e, ref) if ref is not None and name != spec["reference"] else None
    pairs = []
    for a, b in spec["pairs"]:
        if a in entries and b in entries:
            twin = next(r for r in spec["ours"] if r["name"] == a)
            pairs.append(dict(compare(entries[a], entries[b]), ours=a, pyharm=b, law=law_of(spec, b),
                              pointwise=pointwise(our_system(spec["case"], twin.get("element")), twin,
                                                  entries[b], *q_hats.get(b, ([], [])))))
    return {"omega": [w0, w1], "reference": spec["reference"], "entries": entries, "same_law_pairs": pairs, "same_equations_check": checks, "errors": errors}


def pointwise(system, run, entry, q_hats, residuals, n_points=POINTWISE):
    """Our solve at ``n_points`` of pyHarm's converged points (evenly spaced along its branch), started
    from pyHarm's coefficients there (if that fails: from our default start): per point the relative
    amplitude difference ``max_dof |A - A_py| / max_dof |A_py|`` and coefficient difference
    ``max |dq| / max |q_py|``, and their maxima over the points where our solve converged; the agreement of
    the two codes at equal omega, free of the interpolation in :func:`branch_difference`."""
    import mshbm
    from mshbm.branch import _CONT_KEYS

    if not q_hats:
        return None
    opts = {k: v for k, v in run["options"].items() if k not in _CONT_KEYS}
    idx = np.unique(np.linspace(0, len(q_hats) - 1, min(n_points, len(q_hats))).round().astype(int))
    pts = []
    for i in idx:
        w = entry["omega"][i]
        start = "pyHarm's point"
        sol = mshbm.solve(system, w, run["method"], guess={"q_hat": q_hats[i]}, stability=False, **opts)
        if not sol.success:
            start = "our default start"
            sol = mshbm.solve(system, w, run["method"], stability=False, **opts)
        A_py = np.asarray(entry["amplitude"][i])
        ok = bool(sol.success)
        pts.append({"omega": float(w), "pyharm_scaled_residual": float(residuals[i]), "ours_converged": ok,
                    "ours_start": start,
                    "amplitude_difference": float(np.max(np.abs(sol.amplitude - A_py)) / np.max(np.abs(A_py)))
                    if ok else None,
                    "coefficient_difference": float(np.max(np.abs(sol.q_hat - q_hats[i])) / np.max(np.abs(q_hats[i])))
                    if ok else None})
    ok = [p for p in pts if p["ours_converged"]]
    return {"points": pts, "compared": len(ok),
            "max_relative_amplitude_difference": max(p["amplitude_difference"] for p in ok) if ok else None,
            "max_relative_coefficient_difference": max(p["coefficient_difference"] for p in ok) if ok else None}


def law_of(spec, pyharm_name):
    return next(r["law"] for r in spec["pyharm"] if r["name"] == pyharm_name)


def summarise(systems):
    out = {}
    for name, s in systems.items():
        rows = {}
        for k, e in s["entries"].items():
            rows[k] = {"wall_time_s": e["wall_time_s"], "cpu_time_s": e["cpu_time_s"], "points": e["points"],
                       "omega_reached": e["omega_reached"],
                       "continuation_only_cpu_time_s": (e.get("continuation_only") or {}).get("cpu_time_s"),
                       "reached_end": e["reached_end"],
                       "vs_reference_max": (e.get("vs_reference") or {}).get("max")}
            if e["code"] == "pyharm":
                rows[k]["stop"] = e["stop"]
                rows[k]["cpu_budget_s"] = e.get("cpu_budget_s")
                rows[k]["reach_fraction"] = e.get("reach_fraction")
        out[name] = {"branches": rows,
                     "same_law_pairs": [dict({k: p[k] for k in ("ours", "pyharm", "max", "points_compared",
                                                                "omega_range")},
                                             pointwise_amplitude_max=(p["pointwise"] or {}).get(
                                                 "max_relative_amplitude_difference"))
                                        for p in s["same_law_pairs"]]}
    return out


def run_here(args):
    t_begin = time.perf_counter()
    pyHarm, failed = phl.prepare(lambda what, error: unavailable(args.out, what, error))
    if pyHarm is None:
        return failed
    profile = "quick" if args.quick else args.profile
    systems = {}
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):  # both codes single-threaded (mshbm.sweep's default; pyHarm's numpy/scipy)
        for spec in specs(profile, load_config(args.config)):
            try:
                systems[spec["name"]] = run_system(spec, profile, lambda m: print(m, flush=True))
            except Exception:
                systems[spec["name"]] = {"status": "failed", "error": traceback.format_exc(), "entries": {},
                                         "same_law_pairs": []}
    failed = any(s.get("status") == "failed" or s.get("errors") for s in systems.values())
    data = {"benchmark": "pyharm_sweep", "status": "partial" if failed else "ok", "profile": profile,
            "quick": bool(args.quick), "machine": bl.machine_info(),
            "pyharm_version": getattr(pyHarm, "__version__", None), "python_executable": sys.executable,
            "settings": {"friction": {"harmonics": N_H_FRICTION, "aft_samples": NTI_FRICTION,
                                      "aft_samples_coarse_jenkins_pair": NTI_FRICTION_COARSE, "jenkins_k_t": K_T,
                                      "dlft_eps": EPS_DLFT},
                         "impact": {"harmonics": N_H_IMPACT, "aft_samples": NTI_IMPACT},
                         "pyharm_defaults": PYHARM_DEFAULTS, "pyharm_cpu_budget_s": {
                             "max": PYHARM_BUDGET[profile], "factor_of_twin": PYHARM_BUDGET_FACTOR[profile],
                             "min": PYHARM_BUDGET_MIN, "per_run": "entries[...].cpu_budget_s"},
                         "residual_ok": RESIDUAL_OK,
                         "timing": "wall and CPU time of mshbm.sweep (start solve, continuation, certificates, "
                                   "stability) and of pyHarm.Maestro(input) + its FRF continuation, each after an "
                                   "untimed warm-up, one BLAS thread"},
            "systems": systems, "total_wall_s": None}
    data["summary"] = {"status": data["status"], "per_system": summarise(systems)}
    data["total_wall_s"] = time.perf_counter() - t_begin
    out = bl.write_json(args.out, data)
    plot(data, bl.plot_path(out))
    print(f"wrote {out} and {bl.plot_path(out)} in {data['total_wall_s']:.1f} s")
    return data


def plot(data, png):
    import matplotlib.ticker

    plt = bl.pyplot()
    systems = {k: s for k, s in data["systems"].items() if s.get("entries")}
    fig, axes = plt.subplots(2, max(1, len(systems)), figsize=(6.2 * max(1, len(systems)), 8.5), squeeze=False)
    for j, (name, s) in enumerate(systems.items()):
        ax = axes[0, j]
        for k, e in s["entries"].items():
            if not e["omega"]:
                continue
            A = np.array(e["amplitude"])
            if e["code"] == "pyharm":
                ax.plot(e["omega"], A[:, 0], ".", ms=2.5, label=k)
                ax.plot(e["omega"][-1], A[-1, 0], "kx", ms=6)
            else:
                ax.plot(e["omega"], A[:, 0], "-", lw=1.2, label=k)
        ax.set_xlim(*s["omega"])
        ax.set_xlabel("omega (rad/s)")
        ax.set_ylabel("amplitude of DOF 1 (m)")
        ax.set_title(f"{name}: branches (x: pyHarm's last point)", fontsize=9)
        ax.legend(fontsize=6, ncol=2)
        ax = axes[1, j]
        names = list(s["entries"])
        t = [s["entries"][k]["cpu_time_s"] for k in names]
        colors = ["C0" if s["entries"][k]["code"] == "mshbm" else "C3" for k in names]
        ax.barh(range(len(names)), t, color=colors)
        for i, k in enumerate(names):
            e = s["entries"][k]
            reach = e["omega_reached"]
            ax.text(t[i], i, f" {e['points']} pts, to {reach:.3f}" if reach is not None else " no point",
                    va="center", fontsize=6)
        ax.set_yticks(range(len(names)))
        ax.set_yticklabels(names, fontsize=7)
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("CPU time (s); blue: mshbm.sweep, red: pyHarm")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = bl.parser(__doc__.splitlines()[0], "results/benchmarks/pyharm_sweep.json")
    phl.add_argument(ap)
    ap.add_argument("--config", default=None,
                    help="workflow configuration with the branches friction3 and impact5 (the workflow's "
                         "results/config.json, or a YAML file; default workflow/config.yaml)")
    args = ap.parse_args(argv)
    prof = bl.profile(args)
    args.out = os.path.abspath(args.out)
    if args.config:
        args.config = os.path.abspath(args.config)
    return phl.dispatch(args, __file__, ["--profile", prof] + (["--config", args.config] if args.config else []),
                        run_here, lambda what, error: unavailable(args.out, what, error))


if __name__ == "__main__":
    main()
