"""The cost of a sweep's points: what each point pays for, against the same numbers computed as mshbm.solve does.

* ``model_substitution`` (HBM's penalty law in place of Newton's impact law with ``e_N < 1``: two exact
  event-driven periodic solves) is one of the points' error estimates (:mod:`mshbm.branch_accuracy`): made at the
  estimated points, interpolated between them, not at every point's certificate;
* ``dR/dlam`` (for a frequency: the residuals of two rebuilt problems) is evaluated by Newton at fixed ``lam`` only
  at the point it returns (:func:`mshbm.solvers.arclength.continuation`).
"""
from __future__ import annotations

import numpy as np
import pytest

import mshbm
import mshbm.methods.exact as exact_module
from mshbm.solvers.arclength import continuation

# x'' + 0.1 x' + x = cos(omega t), a stop at x = 1 with e_N = 0.8: impacting on 1.2 <= omega <= 1.4
OSC = dict(masses=[1.0], stiffness=1.0, damping=0.1, forcing=[{"dof": 0, "amplitude": 1.0}])


@pytest.fixture
def exact_calls(monkeypatch):
    calls = []
    original = exact_module.exact_periodic

    def counted(*args, **kwargs):
        calls.append(args[1] if len(args) > 1 else kwargs.get("omega"))
        return original(*args, **kwargs)

    monkeypatch.setattr(exact_module, "exact_periodic", counted)
    return calls


def test_hbm_sweep_estimates_model_substitution_at_its_estimated_points_only(exact_calls):
    osc = mshbm.chain(**OSC, elements=[mshbm.Contact(0, gap=1.0, restitution=0.8)])
    br = mshbm.sweep(osc, 1.2, 1.4, "hbm", harmonics=20, stability=False)
    P, est = len(br.points), br.accuracy["estimated_points"]
    assert br.omega[-1] == pytest.approx(1.4, rel=1e-12)
    assert P >= 12 and len(est) < P
    # two exact orbits per estimated point (and the start solve's, and each estimate re-solve's own certificate),
    # not two per point: with the check in every point's certificate it took 2 P more
    assert len(exact_calls) < 2 * P
    values = {i: br.points[i].certificate["accuracy"]["estimates"]["model_substitution"] for i in range(P)}
    assert all(v > 0.002 for v in values.values())  # an impacting orbit: e_N = 0.8 vs 1 changes it by 0.3-2 %
    # at an estimated point: the value of mshbm.solve's certificate at that omega, from that point
    i = est[len(est) // 2]
    sol = mshbm.solve(osc, br.points[i].omega, "hbm", harmonics=20, stability=False, guess=br.points[i].solution)
    assert sol.certificate["model_substitution"].value == pytest.approx(values[i], rel=1e-6)
    # elsewhere: the larger value of the two neighbouring estimated points
    for j in range(P):
        if j not in est:
            a, b = max(k for k in est if k < j), min(k for k in est if k > j)
            assert values[j] == max(values[a], values[b])


def test_newton_at_fixed_lam_evaluates_dR_dlam_only_at_its_root():
    # R(x, lam) = x^3 + x - lam: Newton from x = 3 at lam = 1 takes several iterations to x = 0.6823278...
    calls = []

    def residual(x, lam):
        return np.array([x[0] ** 3 + x[0] - lam]), np.array([[3 * x[0] ** 2 + 1.0]])

    def d_lam(x, lam):
        calls.append(float(x[0]))
        return np.array([-1.0])

    res = continuation(residual, d_lam, np.array([3.0]), 1.0, 2.0, residual_scale=lambda x, lam: np.ones(1),
                       unknown_scale=lambda x, lam: np.ones(1), max_points=1, tol=1e-12)
    root = 0.6823278038280193
    assert res.points[0].x[0] == pytest.approx(root, abs=1e-12)
    assert res.points[0].iterations >= 4
    assert len(calls) == 1 and calls[0] == pytest.approx(root, abs=1e-12)
    # the start's tangent uses it: dx/dlam = 1 / (3 x^2 + 1)
    assert res.points[0].dx / res.points[0].dlam == pytest.approx(1.0 / (3 * root ** 2 + 1.0), rel=1e-10)
