"""Sweeps of a Jenkins joint through slip onset by the time-stepped methods (MS-HBM, shooting).

Two masses joined by a Jenkins element (k_t 3, mu N 0.5), forced by 0.6 cos(omega t) on mass 0: the joint sticks the
whole period from 1.2 to about 2.33 and slips above.  While it sticks, the slider's position is free inside the range
where the stick force stays within its bound (a family of periodic solutions); the sweep takes the member with the
stick force centred in [-mu N, mu N] (:mod:`mshbm.methods.stuck_gauge`, HBM's rule for its stuck loops), so the
branch goes on continuously into slip.  Held at the offset where the branch brought it, the slider met the range's
edge on one side first: MS-HBM cycled between spurious folds near 1.5 (144 points, stopped), shooting left the range.
Inside slip, at 2.4887, the slider's velocity at t = 0 (a state of Moreau-Jean's massless slider) jumps from its
slip velocity to 0 where its stick phase crosses the section t = 0: the arclength corrector turned back there and
cycled (stopped: "came back to its point"); a step at fixed omega across it goes on (``cross_cycle``).
References: HBM's pointwise certified solves (its stuck loops are centred, the same n_H), within the Moreau-Jean time
discretisation of 512 steps (measured 3.4e-4 and 1.8e-4).
"""
import numpy as np
import pytest

import mshbm
from mshbm import Jenkins, System

MU, N0, KT = 0.5, 1.0, 3.0


def _pair():
    M, K = np.eye(2), np.array([[2.0, -1.0], [-1.0, 2.0]])
    f_hat = np.zeros((3, 2))
    f_hat[1, 0] = 0.6
    return System(M, 0.01 * K, K, f_hat, [Jenkins(0, mu=MU, normal_force=N0, relative_to=1, tangential_stiffness=KT)],
                  name="jenkins-pair")


@pytest.mark.parametrize("method, options", [("mshbm", {"harmonics": 7, "steps": 512}), ("shooting", {"steps": 512})])
def test_sweep_of_a_jenkins_joint_passes_slip_onset(method, options):
    s = _pair()
    br = mshbm.sweep(s, 1.2, 2.6, method, stability=False, accuracy=False, **options)
    assert br.success, br.message
    assert br.omega[-1] == pytest.approx(2.6, rel=1e-12)
    assert len(br) <= 60 and not [b for b in br.bifurcations if b["type"] == "fold"]
    assert br.counters.get("gauged", 0) >= 5  # the stuck stretch was traced on centred members
    stuck = slipping = 0
    for i in range(len(br)):
        lam = np.asarray(br.points[i].solution.lam, float)[:-1, 0]
        if np.max(np.abs(lam)) < 0.999 * MU * N0:  # stuck the whole period: the stick force is centred
            stuck += 1
            assert abs(lam.max() + lam.min()) <= 1e-8 * MU * N0, (br.omega[i], lam.max(), lam.min())
        else:
            slipping += 1
        if i % 6 == 0 or i == len(br) - 1:
            ref = mshbm.solve(s, float(br.omega[i]), "hbm", harmonics=7, stability=False)
            assert ref.success, ref.message
            dev = np.max(np.abs(br.amplitude[i] - ref.amplitude)) / np.max(ref.amplitude)
            assert dev <= 1e-3, (br.omega[i], dev)
    assert stuck >= 5 and slipping >= 3
