"""A stuck Jenkins element has no unique slider position; HBM's history law centres the loop (the rule of
:meth:`mshbm.elements.Jenkins.history_law`), so that the harmonic-0 force does not jump with omega and sweeps
through the stuck regime and the slip onset run smoothly."""
import numpy as np
import pytest

import mshbm
from mshbm import System
from mshbm.elements import Jenkins
from mshbm.elements.cone import cone_history_law, frictional_contact

KT, MU, N0 = 3.0, 0.5, 1.0  # bound 0.5


def _samples(a, phi, n=64):
    t = 2 * np.pi * np.arange(n) / n
    return a * np.cos(t + phi) + 0.07 * a * np.cos(2 * t + 3 * phi)  # two harmonics: not symmetric in value


@pytest.mark.parametrize("phi", [0.0, 0.4, 1.3, 2.9])
def test_stuck_loop_is_centred_whatever_the_phase_of_the_last_sample(phi):
    """Range kt (max s - min s) < 2 mu N: lambda = -kt (s - (max s + min s) / 2), whatever sample the march
    starts from (before: -kt (s - s_last), clipped in the first period when s_last sat near an extreme)."""
    el = Jenkins(0, mu=MU, normal_force=N0, tangential_stiffness=KT)
    s = _samples(0.15, phi)  # kt * range ~ 0.9 < 2 b = 1.0
    lam, _ = el.history_law(s)
    mid = 0.5 * (s.max() + s.min())
    assert np.max(np.abs(lam + KT * (s - mid))) <= 1e-14
    assert abs(lam.max() + lam.min()) <= 1e-14 and np.abs(lam).max() < el.bound


def test_stuck_and_slipping_derivatives_equal_central_differences():
    el = Jenkins(0, mu=MU, normal_force=N0, tangential_stiffness=KT)
    n = 64
    t = 2 * np.pi * np.arange(n) / n
    V = np.column_stack([np.ones(n), np.cos(t), np.sin(t), np.cos(2 * t), np.sin(2 * t)])
    for c in (np.array([0.01, 0.1, 0.05, 0.01, -0.004]), np.array([0.0, 0.4, 0.1, 0.03, 0.02])):  # stuck, slips
        lam, D = el.history_law(V @ c, V)
        h = 1e-7
        fd = np.column_stack([(el.history_law(V @ (c + h * e))[0] - el.history_law(V @ (c - h * e))[0]) / (2 * h)
                              for e in np.eye(V.shape[1])])
        assert np.max(np.abs(D - fd)) <= 1e-6 * KT


def test_cone_stuck_loop_along_one_direction_is_the_1d_loop():
    """The 3-D Jenkins pair, moved along its first direction only, stuck: the 1-D centred loop to 1e-14."""
    els = frictional_contact(0, 1, MU, N0, tangential_stiffness=KT)
    s = _samples(0.15, 1.1)
    lam2, _ = cone_history_law(els[0], s, np.zeros_like(s))
    lam1, _ = Jenkins(0, mu=MU, normal_force=N0, tangential_stiffness=KT).history_law(s)
    assert np.max(np.abs(lam2[:, 0] - lam1)) <= 1e-14 and np.max(np.abs(lam2[:, 1])) <= 1e-14


def test_hbm_sweep_of_a_jenkins_joint_through_stick_and_slip_onset():
    """Two masses joined by a Jenkins element (k_t 3, mu N 0.5), forced on mass 0, swept 1.2 -> 2.6 by HBM: the
    joint sticks above resonance and slips below.  Before the centring rule the stuck loop's offset jumped with
    omega and the sweep reported a fold at 2.569 and cycled there (44 points, not reaching the end).  Now: the
    end, no fold, and every 8th point equals a pointwise certified solve (same n_H) to 1e-7."""
    M, K = np.eye(2), np.array([[2.0, -1.0], [-1.0, 2.0]])
    f_hat = np.zeros((3, 2))
    f_hat[1, 0] = 0.2
    s = System(M, 0.01 * K, K, f_hat, [Jenkins(0, mu=MU, normal_force=N0, relative_to=1, tangential_stiffness=KT)],
               name="jenkins-pair")
    br = mshbm.sweep(s, 1.2, 2.6, "hbm", progress=False, harmonics=7)
    assert br.success, br.message
    assert not [b for b in br.bifurcations if b["type"] == "fold"] and len(br) <= 60
    for i in range(0, len(br), 8):
        sol = mshbm.solve(s, float(br.omega[i]), "hbm", harmonics=7)
        assert sol.success, sol.message
        assert np.max(np.abs(br.amplitude[i] / sol.amplitude - 1)) <= 1e-7
