"""A gap of the continuation on an impacting branch is bridged on that branch, not by a jump to another solution.

The cantilever with a tip stop of workflow/sweeps.yaml (beam-stop-cb: 0.1 m steel, gap 1 mm, e = 0.7, 0.2 N at the
tip) on 10 elements, Craig-Bampton with the tip DOF and two modes (3 DOFs), by event shooting with the Zeno closure
(``accumulation="close"``), swept up from 0.9 w_1: the linear response grazes the stop at 0.977 w_1 and the impacting
branch leans to higher frequencies, gaining impacts per period (1, 2, 3, 4) at corners a fraction of a per cent
apart.  At 1.0263 w_1 the arclength steps turn back onto the part already traced (a corner, no fold), and the gap
bridged there was one natural-parameter step of 0.5 ds0 (9.4 rad/s) by Newton from the last point, then the
pointwise solve: it landed on the orbit without impacts at 1.0353 w_1 ("landed off the branch"), and the sweep went on
along the linear response, the impacting branch above 1.026 w_1 and its fold (1.069 w_1) untraced.  A gap's point off
the branch is now replaced by Newton from the last point at a fraction of the step
(:meth:`mshbm.solvers.arclength_fallbacks.Fallbacks.nearer_on_branch`): 1.0308 w_1, four impacts per period.
References: the linear response in closed form, ``|(K - w^2 M + i w C)^-1 F|``, at the points without impacts before
the grazing; pointwise certified solves at the impacting points after the gap.  (The first 50 points only, one BLAS
thread: the trace beyond them passes more corners, and which steps it takes there depends on the rounding; measured
15 s CPU with the solves.)
"""
import numpy as np
import pytest

import mshbm
from mshbm._blas import blas_threads
from mshbm_workflow import sweep_systems

OPTIONS = dict(integrator="event", accumulation="close", steps=1024)


def _linear_amplitudes(system, omega):
    M, C, K = (np.asarray(A.toarray() if hasattr(A, "toarray") else A, float) for A in (system.M, system.C, system.K))
    f = np.asarray(system.f_hat, float)
    return np.abs(np.linalg.solve(K - omega ** 2 * M + 1j * omega * C, f[1] - 1j * f[2]))


def _impacts(point):
    return len(point.solution.info["event_list"])


@pytest.fixture(scope="module")
def cantilever():
    spec = {"beam": {"n_el": 10, "length": 0.1, "width": 0.01, "height": 0.002, "zeta": 0.01,
                     "forcing": [{"at": {"x": 1.0}, "amplitude": 0.2}],
                     "elements": [{"type": "contact", "at": {"x": 1.0}, "gap": 0.001, "restitution": 0.7}],
                     "reduce": {"modes": 2}}}
    system, w1, _ = sweep_systems.build(spec, "cantilever-stop")
    assert system.n == 3
    with blas_threads(1):  # the steps past the corners depend on the rounding: one BLAS thread, one path
        branch = mshbm.sweep(system, 0.9 * w1, 1.1 * w1, "shooting", stability=False, max_points=50, **OPTIONS)
    return system, w1, branch


def test_gap_on_the_impacting_branch_stays_on_it(cantilever):
    system, w1, b = cantilever
    om = np.asarray(b.omega) / w1
    hit = np.array([_impacts(p) > 0 for p in b.points])
    first = int(np.argmax(hit))
    assert 0.977 < om[first] < 1.0
    # after the grazing every point impacts (before: the gap's point at 1.0353 w_1 and all after it did not)
    assert hit[first:].all(), [(round(w, 5), _impacts(p)) for w, p in zip(om, b.points)]
    assert len(b.points) == 50, b.message
    assert b.counters.get("gaps", 0) >= 1 and "jumps" not in b.counters, b.counters
    assert om.max() > 1.035  # measured 1.0364 (four and three impacts per period)
    # the points before the grazing are the linear response
    worst = 0.0
    for p in b.points[:first]:
        ref = _linear_amplitudes(system, p.omega)
        worst = max(worst, float(np.max(np.abs(p.amplitude - ref)) / np.max(ref)))
    assert worst <= 1e-8, worst


def test_points_after_the_gap_are_certified_impacting_solves(cantilever):
    system, w1, b = cantilever
    for p in b.points[-3:]:
        sol = mshbm.solve(system, p.omega, "shooting", guess=p.solution, stability=False, **OPTIONS)
        assert sol.success, sol.message
        assert len(sol.info["event_list"]) > 0
        dev = float(np.max(np.abs(sol.amplitude - p.amplitude)) / np.max(p.amplitude))
        assert dev <= 1e-8, (p.omega / w1, dev)
        # not the orbit without impacts (the linear response, whose tip stays below the stop there)
        lin = _linear_amplitudes(system, p.omega)
        assert np.max(np.abs(p.amplitude - lin)) / np.max(lin) > 0.05
