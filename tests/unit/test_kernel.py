"""The compiled Moreau-Jean kernel against its plain NumPy twin; exact sensitivities against differences."""
import numpy as np
import pytest

from mshbm import Contact, Friction, Jenkins, chain
from mshbm.integrators import kernels
from mshbm.integrators.moreau_jean import MoreauJean


def _setup(elements, n=4, N=600, theta=0.5, c=0.05):
    sys = chain([1.0, 2.0, 1.0, 1.5][:n], 1.0, c, forcing=[{"dof": n - 1, "amplitude": 3.0 if n > 1 else 0.5}],
                elements=elements)
    omega = 0.8
    h = 2 * np.pi / omega / N
    st = MoreauJean(sys.M, sys.C, sys.K, sys.elements, h, theta)
    t = np.arange(N + 1) * h
    B = st.increments(sys.forcing(t, omega))
    return sys, st, B


CASES = {
    "friction": [Friction(0, 0.5, 1.0)],
    "contact_e1": [Contact(0, 0.2, 1.0)],
    "contact_e05": [Contact(1, 0.3, 0.5)],
    "two_elements": [Friction(0, 0.3, 1.0), Contact(1, 0.25, 0.8)],
    "three_elements": [Friction(0, 0.3, 1.0), Friction(2, 0.2, 1.0), Contact(1, 0.25, 0.0)],
    # elements between two DOFs (w = sign (e_I - e_J)): the kernel's dof2 path
    "relative_friction": [Friction(3, 0.4, 1.0, relative_to=1)],
    "relative_contact": [Contact(3, 0.1, 0.6, relative_to=2)],
    "relative_mixed": [Friction(0, 0.3, 1.0, relative_to=1), Contact(3, 0.1, 0.8, relative_to=2),
                       Contact(1, 0.25, 1.0)],
    # Jenkins elements: massless slider DOFs appended by MoreauJean, stepped with theta = 1 (n_slider)
    "jenkins": [Jenkins(0, 0.5, 1.0, tangential_stiffness=20.0)],
    "jenkins_relative_mixed": [Jenkins(3, 0.4, 1.0, tangential_stiffness=5.0, relative_to=1),
                               Contact(2, 0.2, 0.9), Jenkins(0, 0.3, 1.0, tangential_stiffness=50.0)],
}
#: one DOF and one element take the scalar fast path of the kernel
SCALAR = {"scalar_friction": [Friction(0, 0.5, 0.3)], "scalar_contact_e1": [Contact(0, 0.2, 1.0)],
          "scalar_contact_e03": [Contact(0, 0.1, 0.3)]}


def _start(n):
    return np.array([0.1, -0.2, 0.05, 0.0])[:n], np.array([0.5, 0.0, -0.3, 0.2])[:n]


@pytest.mark.parametrize("name", list(CASES) + list(SCALAR))
@pytest.mark.parametrize("theta", [0.5, 0.75])
def test_kernel_matches_numpy(name, theta):
    els = {**CASES, **SCALAR}[name]
    n = 1 if name in SCALAR else 4
    sys, st, B = _setup(els, n=n, theta=theta)
    q0, u0 = st.with_slider_state(*_start(n))  # Jenkins: the sliders' state appended
    tr = st.run(q0, u0, B)
    q, u, P = kernels.moreau_jean_numpy(q0, u0, st.Aq, st.Au, st.WG, st.Del, st.MinvG, B, st.theta, st.h,
                                        st.kind, st.dof, st.sign, st.bound, st.gap, st.e, dof2=st.dof2,
                                        n_slider=st.n - st.n_structure)
    assert np.abs(P).max() > 0  # the elements did act
    assert np.allclose(tr.q, q, rtol=0, atol=1e-11)
    assert np.allclose(tr.u, u, rtol=0, atol=1e-11)
    assert np.allclose(tr.P, P, rtol=0, atol=1e-11)


@pytest.mark.parametrize("name", list(CASES) + list(SCALAR))
def test_sensitivities_match_finite_differences_and_runs(name):
    n = 1 if name in SCALAR else 4
    sys, st, B = _setup({**CASES, **SCALAR}[name], n=n, N=300)
    x = np.concatenate(st.with_slider_state(*_start(n)))
    n = st.n  # with the Jenkins sliders
    tr = st.run(x[:n], x[n:], B, sensitivities=True)
    Phi = np.vstack([tr.Sq, tr.Su])
    # run-length product of step Jacobians (used by full shooting) is the same matrix
    assert np.allclose(st.monodromy(tr.status), Phi, rtol=0, atol=1e-10 * np.abs(Phi).max())
    end = np.concatenate([tr.q[-1], tr.u[-1]])
    d = 1e-7
    worst = 0.0
    for i in range(2 * n):
        xp = x.copy()
        xp[i] += d
        tp = st.run(xp[:n], xp[n:], B)
        if not np.array_equal(tp.status, tr.status):
            continue  # the active set changed: the map is not differentiable across it
        fd = (np.concatenate([tp.q[-1], tp.u[-1]]) - end) / d
        worst = max(worst, np.abs(fd - Phi[:, i]).max() / max(1.0, np.abs(Phi[:, i]).max()))
    assert worst < 1e-5


def test_single_step_friction_closed_form():
    """One friction element: stick iff |gamma_free| <= W_dd h mu F_N, then gamma+ = 0."""
    sys, st, B = _setup([Friction(0, 0.5, 1.0)], N=200)
    q0, u0 = np.zeros(4), np.array([1e-4, 0, 0, 0])
    tr = st.run(q0, u0, B[:1])
    assert tr.status[0, 0] == kernels.STATUS_STICK
    assert abs(tr.u[1, 0]) < 1e-15
    tr = st.run(q0, np.array([5.0, 0, 0, 0]), B[:1])
    assert tr.status[0, 0] == kernels.STATUS_SLIP
    assert np.isclose(tr.P[0, 0], -st.bound[0])


def test_parameter_sensitivities_scalar_path():
    """d(q, u)/dp through the forcing derivative dB (as used by MS-HBM) against differences."""
    rng = np.random.default_rng(5)
    sys1, st1, B1 = _setup([Friction(0, 0.5, 0.3)], n=1, N=400)
    N, n_p = B1.shape[0], 3
    dB = rng.standard_normal((N, 1, n_p)) * 1e-3
    p = rng.standard_normal(n_p)
    run = lambda pp: st1.run(np.array([0.1]), np.array([0.2]), B1 + dB @ pp, dB, sensitivities=True,
                             store_q_sensitivities=True)
    tr = run(p)
    for i in range(n_p):
        d = np.zeros(n_p)
        d[i] = 1e-7
        tp = run(p + d)
        if np.array_equal(tp.status, tr.status):
            assert np.allclose((tp.q[-1] - tr.q[-1]) / 1e-7, tr.Sq[:, 2 + i], atol=1e-5)
            assert np.allclose((tp.q[:, 0] - tr.q[:, 0]) / 1e-7, tr.Sq_traj[:, 0, 2 + i], atol=1e-5)
