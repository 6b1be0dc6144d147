"""Elements between two DOFs (``relative_to``).

Independent checks:

* **Den Hartog** (1931): the undamped 1-DOF oscillator ``x'' + x = cos(omega t) - F sign(x')`` in
  continuous slip has the amplitude ``sqrt(V^2 - (F U)^2)``, ``V = 1/(1 - omega^2)``,
  ``U = sin(pi/omega) / (omega (1 + cos(pi/omega)))``.  The same friction *relative* to a second
  DOF held by a stiff, critically damped spring ``k_2`` tends to it as ``k_2 -> inf``: the held DOF's
  velocity after each slip reversal (a force step ``2F`` on it) is ``~ F / sqrt(k_2 m_2)``, so the
  error falls like ``1/sqrt(k_2)`` (measured ratio 2.98 from ``k_2 = 100`` to ``1000``).
* **Change of coordinates**: an element on ``q_0 - q_1`` is a ground element on ``y_0`` in the
  coordinates ``q = T y``, ``y = (q_0 - q_1, q_1)``, with ``T^T M T``, ``T^T C T``, ``T^T K T`` and the
  forcing ``T^T f``.  Moreau-Jean (a linear theta-scheme with the same impulse law) and HBM
  (a Galerkin method) are covariant under this change: both must give the same solution to
  rounding, for friction and for contact, with every method.
* **Two-body impact**: the impulse of a relative contact acts as ``+P`` and ``-P`` on the two bodies:
  the momentum of two free bodies changes over every step only by the forcing's impulse (impacts
  included), and the bodies never penetrate.
"""
import copy

import numpy as np
import pytest

import mshbm
from tests import discretised
from mshbm import Contact, Friction, InputError, System, chain
from mshbm.integrators.moreau_jean import MoreauJean
from mshbm.methods.exact import exact_periodic

from integration.test_io_cli import BASE, assert_input_error, run, write_case  # shared CLI helpers


def den_hartog(omega, F):
    """Den Hartog's amplitude of continuous slip (undamped, unit mass, stiffness and force)."""
    V = 1.0 / (1.0 - omega ** 2)
    U = np.sin(np.pi / omega) / (omega * (1.0 + np.cos(np.pi / omega)))
    return float(np.sqrt(V ** 2 - (F * U) ** 2))


OMEGA_DH, F_DH = 0.6, 0.3
#: HBM's smoothing (s/m) of these tests, given explicitly: with the (stiffer) default the relative element at
#: k_2 = 1e3 needs more than n_H = 15 (the held DOF's resonance sqrt(k_2) lies above 15 omega)
KAPPA_DH = 800.0


def _held(k2, first):
    """Mass 0 on a unit spring, DOF 1 held by a stiff, critically damped spring ``k2``; the friction
    between them is written with ``dof = first``."""
    M = np.diag([1.0, 1.0])
    K = np.diag([1.0, k2])
    C = np.diag([0.0, 2.0 * np.sqrt(k2)])
    f = np.zeros((3, 2))
    f[1, 0] = 1.0
    el = Friction(first, 1.0, F_DH, smoothing=KAPPA_DH, relative_to=1 - first)
    return System(M, C, K, f, [el], name="held")


METHODS = {"shooting": dict(steps=4096), "mshbm": dict(steps=4096, harmonics=15), "hbm": dict(harmonics=15)}


@pytest.mark.parametrize("method", list(METHODS))
def test_relative_friction_tends_to_den_hartog(method):
    ground = chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Friction(0, 1.0, F_DH, smoothing=KAPPA_DH)])
    amp = lambda s: float(np.max(np.abs(s.displacement([0]))))
    g = discretised.solve(ground, OMEGA_DH, method, **METHODS[method])
    assert g.success
    ref = den_hartog(OMEGA_DH, F_DH)
    err = {}
    for k2 in (1e2, 1e3):
        for first in (0, 1):  # dof / relative_to swapped: the same element (w changes sign)
            s = discretised.solve(_held(k2, first), OMEGA_DH, method, **METHODS[method])
            assert s.success, s.message
            e = abs(amp(s) - amp(g)) / ref
            assert err.setdefault(k2, e) == pytest.approx(e, rel=1e-6, abs=1e-12)
    # the relative element tends to the ground element like 1 / sqrt(k_2) (HBM, regularised: measured 2.16)
    assert (2.5 if method != "hbm" else 1.8) < err[1e2] / err[1e3] < 4.5
    assert err[1e3] < 1e-3
    # and the ground element is Den Hartog's (time stepping: O(h); HBM: its regularisation kappa = 800)
    assert abs(amp(g) - ref) / ref < (1e-4 if method != "hbm" else 1e-2)


# ----------------------------------------------------------------------------- change of coordinates
T = np.array([[1.0, 1.0], [0.0, 1.0]])  # q = T y, y = (q0 - q1, q1)


def _pair(el_rel, el_ground, n=2):
    """The relative system on ``q`` and the ground system on ``y`` (same motion)."""
    M = np.diag([1.0, 2.0, 1.5][:n])
    K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.5, -1.0], [0.0, -1.0, 1.0]])[:n, :n]
    C = 0.05 * K
    f = np.zeros((3, n))
    f[1, 0] = 1.0
    Tn = np.eye(n)
    Tn[:2, :2] = T
    rel = System(M, C, K, f, [el_rel], name="relative")
    ground = System(Tn.T @ M @ Tn, Tn.T @ C @ Tn, Tn.T @ K @ Tn, f @ Tn, [el_ground], name="ground")
    return rel, ground, Tn


ELEMENTS = {
    "friction": (Friction(0, 0.3, 1.0, relative_to=1), Friction(0, 0.3, 1.0)),
    "contact": (Contact(0, 0.2, 0.7, relative_to=1), Contact(0, 0.2, 0.7)),
}
COV = {"shooting": dict(steps=2048), "mshbm": dict(steps=2048, harmonics=10, partition=[0, 1]),
       "hbm": dict(harmonics=10, partition=[0, 1]), "dlft": dict(harmonics=10, partition=[0, 1]),
       "mshbm-intermediate": dict(steps=2048, harmonics=10, partition=[[0, 1], [2]])}


@pytest.mark.parametrize("method", list(COV))
@pytest.mark.parametrize("kind", list(ELEMENTS))
def test_relative_element_is_ground_element_in_relative_coordinates(kind, method):
    rel, ground, Tn = _pair(*ELEMENTS[kind], n=3 if method == "mshbm-intermediate" else 2)
    a = discretised.solve(rel, 0.8, method, **COV[method])
    b = discretised.solve(ground, 0.8, method, **COV[method])
    assert a.success and b.success, (a.message, b.message)
    qa, qb = np.asarray(a.q_hat), np.asarray(b.q_hat) @ Tn.T
    scale = np.abs(qa).max()
    assert np.abs(qa - qb).max() <= 1e-9 * scale
    # the element did act: the linear response differs
    lin = discretised.solve(rel.with_elements([]), 0.8, method, **COV[method])
    assert np.abs(np.asarray(lin.q_hat) - qa).max() > 1e-2 * scale
    # the certificate judged the relative law: friction cone / non-penetration on q0 - q1
    names = {c.name: c for c in a.certificate.checks}
    check = names["friction_cone" if kind == "friction" else "non_penetration"]
    assert check.passed
    if kind == "friction":
        assert 0.99 < check.value <= 1.0 + 1e-9  # slips: the force reaches mu F_N
    else:
        g = 0.2 - (a.displacement([0])[:, 0] - a.displacement([1])[:, 0])
        assert g.min() < 1e-2 * 0.2  # touches
        if method != "dlft":  # and does not penetrate (DLFT: the series' penetration is reported, not gated)
            assert g.min() >= -check.bound


def test_relative_friction_against_exact_flow_of_relative_coordinates():
    """Shooting and MS-HBM on the relative element converge to the exact (event-driven) solution of
    the ground element in relative coordinates, at the order of the step."""
    rel, ground, Tn = _pair(*ELEMENTS["friction"])
    ex = exact_periodic(ground, 0.8, samples=2048, harmonics=10)
    assert ex.success
    ref = np.asarray(ex.q_hat)[:3] @ Tn.T
    errs = []
    for steps in (1024, 4096):
        s = discretised.solve(rel, 0.8, "shooting", steps=steps)
        errs.append(np.abs(np.asarray(s.q_hat)[:3] - ref).max() / np.abs(ref).max())
    assert errs[1] < 1e-4 and errs[0] / errs[1] > 3.0


def test_exact_flow_and_stability_of_relative_elements():
    rel, _, _ = _pair(*ELEMENTS["friction"])
    with pytest.raises(InputError) as info:
        exact_periodic(rel, 0.8)
    assert info.value.key == "friction.relative_to"
    sol = discretised.solve(rel, 0.8, "shooting", steps=1024)
    assert sol.success
    assert "relative" in sol.stability_reason
    assert sol.stable is None  # stick phases: the step map has no saltation terms, no verdict


# ----------------------------------------------------------------------------- two-body impact
def test_two_body_impact_conserves_momentum_and_does_not_penetrate():
    """Two free bodies pushed together (q_0 - q_1 <= 0.1): momentum changes only by the forcing."""
    m = np.array([1.0, 3.0])
    M, Z = np.diag(m), np.zeros((2, 2))
    for e in (1.0, 0.5, 0.0):
        st = MoreauJean(M, Z, Z, [Contact(0, 0.1, e, relative_to=1)], h=1e-3)
        N = 10000
        F = np.tile([0.7, -0.2], (N + 1, 1))
        B = st.increments(F)
        tr = st.run(np.zeros(2), np.array([0.5, -0.4]), B)
        assert np.count_nonzero(tr.P[:, 0] > 0) >= 3  # impacts (and contact phases for e < 1)
        p = tr.u @ m
        np.testing.assert_allclose(np.diff(p), 1e-3 * 0.5, rtol=0, atol=1e-12)
        g = 0.1 - (tr.q[:, 0] - tr.q[:, 1])
        assert g.min() >= -1e-12
        if e == 1.0:  # elastic impacts: the relative velocity reverses
            k = int(np.flatnonzero(tr.P[:, 0] > 0)[0])
            v_before = tr.u[k, 0] - tr.u[k, 1]
            v_after = tr.u[k + 1, 0] - tr.u[k + 1, 1]
            assert v_after == pytest.approx(-v_before, abs=2e-3 * abs(v_before))


def test_two_body_periodic_impacts_all_methods():
    """Two bodies on springs knocking on each other: shooting, MS-HBM and HBM agree; no penetration."""
    M = np.diag([1.0, 2.0])
    K = np.diag([1.0, 3.0])
    C = 0.05 * K
    f = np.zeros((3, 2))
    f[1, 0], f[1, 1] = 1.5, -0.75
    s = System(M, C, K, f, [Contact(0, 0.5, 1.0, relative_to=1)])  # HBM penalty: elastic
    out = {}
    for method, opt in (("shooting", dict(steps=4096)), ("mshbm", dict(steps=4096, harmonics=15)),
                        ("hbm", dict(harmonics=15, steps=1024))):
        sol = discretised.solve(s, 1.2, method, **opt)
        assert sol.success, sol.message
        g = 0.5 - (sol.displacement([0])[:, 0] - sol.displacement([1])[:, 0])
        if method == "hbm":  # penalty: penetrates by ~ lambda / k_c (measured 0.0074)
            assert -0.02 < g.min() < 0.0
        else:  # set-valued: touches (linear response: g down to -3.1), never penetrates
            assert 0.0 <= g.min() < 1e-5
        out[method] = np.asarray(sol.q_hat)[1:3]
    ref = np.abs(out["shooting"]).max()
    assert np.abs(out["mshbm"] - out["shooting"]).max() < 1e-6 * ref
    assert np.abs(out["hbm"] - out["shooting"]).max() < 5e-2 * ref  # measured 2.7 %: penalty, n_h = 15


# ----------------------------------------------------------------------------- input
def test_element_constructor_rejects_bad_relative_to():
    with pytest.raises(InputError) as info:
        Friction(1, 0.3, 1.0, relative_to=1)
    assert info.value.key == "friction.relative_to"
    with pytest.raises(InputError) as info:
        Contact(0, 0.1, relative_to="1")
    assert info.value.key == "contact.relative_to"
    with pytest.raises(InputError) as info:
        chain([1.0, 1.0], 1.0, elements=[Friction(0, 0.3, 1.0, relative_to=2)])
    assert info.value.key == "friction.relative_to"


def _friction(**kw):
    def modify(data):
        data["friction"] = {**data["friction"], **kw}
    return modify


@pytest.mark.parametrize("modify, key", [
    (_friction(relative_to=0), "friction.relative_to"),
    (_friction(relative_to=3), "friction.relative_to"),
    (_friction(relative_to=-1), "friction.relative_to"),
    (_friction(relative_to="one"), "friction.relative_to"),
    (_friction(relative_to=1.5), "friction.relative_to"),
], ids=["equal-dof", "out-of-range", "negative", "string", "non-integer"])
def test_bad_relative_to_in_case_file_exit_2(modify, key, tmp_path, capsys):
    data = copy.deepcopy(BASE)
    modify(data)
    path = write_case(tmp_path, data)
    code, out, err = run(capsys, "solve", path)
    assert_input_error(code, out, err, key)


def test_relative_to_in_case_file(tmp_path, capsys):
    data = copy.deepcopy(BASE)
    data["friction"] = {**data["friction"], "relative_to": 1}
    case = mshbm.load_case(write_case(tmp_path, data))
    (el,) = case.system.elements
    assert el.dofs == (0, 1) and el.relative


# ============================================================================= Jenkins (elastic friction)
from mshbm import Jenkins  # noqa: E402


def _loop(el, a, Ns=2048):
    """Force of ``el`` under ``s = a cos(t)`` and the energy it dissipates over the cycle."""
    t = np.arange(Ns) * (2 * np.pi / Ns)
    s, v = a * np.cos(t), -a * np.sin(t)
    lam, D = el.history_law(s)
    return lam, D, s, -float(np.sum(lam * v)) * (2 * np.pi / Ns)


@pytest.mark.parametrize("kt", [5.0, 10.0, 100.0])
def test_jenkins_hysteresis_energy_is_masing_closed_form(kt):
    """Energy per cycle = area of the loop = 4 mu F_N (a - mu F_N / k_t) (slipping, a > mu F_N / k_t)."""
    el = Jenkins(0, 1.0, 0.5, tangential_stiffness=kt)
    a = 0.3
    lam, _, s, W = _loop(el, a)
    exact = 4 * 0.5 * (a - 0.5 / kt)
    assert W == pytest.approx(exact, rel=1e-5)
    assert np.abs(lam).max() == pytest.approx(0.5, rel=0, abs=1e-15)  # slides at mu F_N
    # no slip for a <= mu F_N / (2 k_t)... fully elastic: lambda = -k_t (s - z), no dissipation
    lam, _, s, W = _loop(el, 0.4 * 0.5 / kt)
    assert abs(W) < 1e-12 and np.ptp(lam + kt * s) < 1e-12


def test_jenkins_tends_to_coulomb_like_one_over_kt():
    """The dissipated energy differs from rigid Coulomb's 4 mu F_N a by 4 (mu F_N)^2 / k_t."""
    a, b = 0.3, 0.5
    errs = []
    for kt in (1e2, 1e3, 1e4):
        lam, _, _, W = _loop(Jenkins(0, 1.0, b, tangential_stiffness=kt), a, 8192)
        errs.append(abs(W - 4 * b * a))
    np.testing.assert_allclose(errs, [4 * b * b / kt for kt in (1e2, 1e3, 1e4)], rtol=2e-3)


def test_jenkins_jacobian_matches_finite_differences():
    el = Jenkins(0, 1.0, 0.5, tangential_stiffness=10.0)
    rng = np.random.default_rng(3)
    Ns = 64
    s = 0.3 * np.cos(np.arange(Ns) * 2 * np.pi / Ns) + 0.01 * rng.standard_normal(Ns)
    lam, D = el.history_law(s)
    d = 1e-7
    for i in (0, 5, 31, Ns - 1):
        sp_ = s.copy()
        sp_[i] += d
        np.testing.assert_allclose((el.history_law(sp_)[0] - lam) / d, D[:, i], rtol=0, atol=1e-6)


def test_jenkins_hbm_linear_while_sticking():
    """mu F_N huge: the structure is linear with K + k_t e_0 e_0^T (harmonics exact; the mean is fixed
    by the AFT convention lambda = 0 at the last sample of the first march)."""
    kt = 5.0
    s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 0.1}],
              elements=[Jenkins(0, 1.0, 100.0, tangential_stiffness=kt)])
    sol = discretised.solve(s, 0.8, "hbm", harmonics=5, steps=256)
    assert sol.success
    K = s.dense("K").copy()
    K[0, 0] += kt
    lin = discretised.solve(System(s.M, s.C, K, s.f_hat), 0.8, "hbm", harmonics=5)
    qa, qb = np.asarray(sol.q_hat), np.asarray(lin.q_hat)
    assert np.abs(qa[1:] - qb[1:]).max() <= 1e-12 * np.abs(qb).max()
    assert sol.stable is None and "Jenkins" in sol.stability_reason


def test_jenkins_hbm_tends_to_coulomb():
    """Den Hartog's oscillator with a Jenkins element: HBM (n_H = 15) converges as k_t grows; the
    steps between k_t = 1e2, 1e3, 1e4, 1e6 shrink (measured 0.035, 0.0089, 0.0013 in the first harmonic)
    and the limit lies within HBM's truncation of Den Hartog's exact amplitude."""
    amps = {}
    for kt in (1e2, 1e3, 1e4, 1e6):
        s = chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.0}],
                  elements=[Jenkins(0, 1.0, F_DH, tangential_stiffness=kt)])
        sol = discretised.solve(s, OMEGA_DH, "hbm", harmonics=15, steps=1024)
        assert sol.success
        amps[kt] = float(np.max(np.abs(sol.displacement([0]))))
        # energy: the friction work balances the input (certificate) and the loop slides at mu F_N
        assert {c.name: c for c in sol.certificate.checks}["friction_cone"].value == pytest.approx(1.0, abs=1e-12)
    d = [abs(amps[k] - amps[1e6]) for k in (1e2, 1e3, 1e4)]
    assert d[0] > 3 * d[1] > 9 * d[2]
    assert abs(amps[1e6] - den_hartog(OMEGA_DH, F_DH)) / den_hartog(OMEGA_DH, F_DH) < 1e-2


def test_jenkins_relative_equals_ground_in_relative_coordinates():
    rel, ground, Tn = _pair(Jenkins(0, 0.3, 1.0, tangential_stiffness=20.0, relative_to=1),
                            Jenkins(0, 0.3, 1.0, tangential_stiffness=20.0))
    a = discretised.solve(rel, 0.8, "hbm", harmonics=10, steps=512)
    b = discretised.solve(ground, 0.8, "hbm", harmonics=10, steps=512)
    assert a.success and b.success
    qa, qb = np.asarray(a.q_hat), np.asarray(b.q_hat) @ Tn.T
    assert np.abs(qa - qb).max() <= 1e-9 * np.abs(qa).max()


def test_jenkins_exact_flow_is_a_clean_input_error():
    s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.0}],
              elements=[Jenkins(0, 1.0, 0.3, tangential_stiffness=10.0)])
    with pytest.raises(InputError) as info:
        exact_periodic(s, 0.8)
    assert info.value.key == "friction.tangential_stiffness"


JEN_METHODS = {"hbm": dict(harmonics=15, steps=1024), "shooting": dict(steps=4096),
               "mshbm": dict(harmonics=15, steps=4096),
               "mshbm-intermediate": dict(harmonics=15, steps=4096, partition=[[0, 1], [2]])}


@pytest.mark.parametrize("relative", [None, 1])
def test_jenkins_all_methods_agree(relative):
    """Shooting and both MS-HBM variants (massless slider DOF) against HBM (two-period march):
    measured 2.8e-5 (ground) and 4.6e-5 (relative) in the harmonics; every solution certified."""
    s = chain([1.0, 2.0, 1.5], 1.0, 0.05, forcing=[{"dof": 2, "amplitude": 1.5}],
              elements=[Jenkins(0, 1.0, 0.4, tangential_stiffness=8.0, relative_to=relative)])
    out = {}
    for method, opt in JEN_METHODS.items():
        sol = discretised.solve(s, 0.8, method, **opt)
        assert sol.success, (method, sol.message)
        assert sol.stable is None and "Jenkins" in sol.stability_reason
        # the reported solution has the structure's 3 DOFs (the sliders are not reported)
        td = np.asarray(sol.time_dofs)
        assert np.asarray(sol.q_hat).shape[1] == 3 and np.asarray(sol.q_time).shape[1] == td.size
        assert td.size == 0 or td.max() < 3
        out[method] = np.asarray(sol.q_hat)[1:11]
        assert {c.name: c for c in sol.certificate.checks}["friction_cone"].value == pytest.approx(1.0, abs=1e-9)
    ref = np.abs(out["hbm"]).max()
    for method in ("shooting", "mshbm", "mshbm-intermediate"):
        assert np.abs(out[method] - out["hbm"]).max() < 1e-4 * ref


@pytest.mark.parametrize("method", ["shooting", "mshbm"])
def test_jenkins_time_stepping_linear_while_sticking(method):
    kt = 5.0
    s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 0.1}],
              elements=[Jenkins(0, 1.0, 100.0, tangential_stiffness=kt)])
    opt = dict(steps=2048) if method == "shooting" else dict(steps=2048, harmonics=5, partition=[0, 1])
    sol = discretised.solve(s, 0.8, method, **opt)
    assert sol.success
    K = s.dense("K").copy()
    K[0, 0] += kt
    lin = discretised.solve(System(s.M, s.C, K, s.f_hat), 0.8, method, **opt)
    qa, qb = np.asarray(sol.q_hat), np.asarray(lin.q_hat)
    assert np.abs(qa[1:] - qb[1:]).max() <= 1e-11 * np.abs(qb).max()  # measured 2e-14


@pytest.mark.parametrize("method", ["shooting", "mshbm", "hbm"])
def test_jenkins_dissipation_is_the_masing_loop(method):
    """A heavy mass (1e4 kg) driven to s ~ a cos t carries a Jenkins element: the work it dissipates
    per period is 4 mu F_N (a - mu F_N / k_t).  Time stepping: the scheme's discrete work
    -sum lambda_k (q_k+1 - q_k) (measured 1.0e-5 at 1024 steps, 4.8e-7 at 4096: second order);
    HBM: the trapezoidal loop area (measured 1.8e-7)."""
    m0, a, b, kt = 1e4, 0.3, 0.5, 10.0
    F0 = a * (0.25 * m0 - m0)
    s = System(np.array([[m0]]), np.array([[0.0]]), np.array([[0.25 * m0]]), np.array([[0.0], [F0], [0.0]]),
               [Jenkins(0, 1.0, b, tangential_stiffness=kt)])
    opt = {"shooting": dict(steps=4096), "mshbm": dict(harmonics=10, steps=4096),
           "hbm": dict(harmonics=25, steps=4096)}[method]
    sol = discretised.solve(s, 1.0, method, **opt)
    assert sol.success
    q, lam = sol.displacement([0])[:, 0], np.asarray(sol.lam)[:, 0]
    amp = 0.5 * (q.max() - q.min())
    if method == "hbm":
        W = -float(np.sum(0.5 * (lam[1:] + lam[:-1]) * np.diff(q)))
    else:
        W = -float(np.sum(lam[:-1] * np.diff(q)))
    assert W == pytest.approx(4 * b * (amp - b / kt), rel=2e-6)


def test_jenkins_time_stepping_tends_to_coulomb():
    """Den Hartog's oscillator, shooting with 4096 steps: Jenkins -> Coulomb in the same scheme.  The
    elastic phase after a velocity reversal lasts ~ sqrt(2 mu F_N / (k_t |s''|)), so the amplitude
    error falls like k_t^(-1/2) (measured 0.0237, 0.0072, 0.0023 for k_t = 1e2, 1e3, 1e4)."""
    amp = lambda sol: float(np.max(np.abs(sol.displacement([0]))))
    c = discretised.solve(chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.0}],
                          elements=[Friction(0, 1.0, F_DH)]), OMEGA_DH, "shooting", steps=4096)
    err = []
    for kt in (1e2, 1e3, 1e4):
        s = chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.0}],
                  elements=[Jenkins(0, 1.0, F_DH, tangential_stiffness=kt)])
        sol = discretised.solve(s, OMEGA_DH, "shooting", steps=4096)
        assert sol.success
        err.append(abs(amp(sol) - amp(c)))
    assert all(2.8 < err[i] / err[i + 1] < 3.8 for i in range(2))
    assert err[-1] < 3e-3


@pytest.mark.parametrize("value, ids", [(0, "zero"), (-5.0, "negative"), ("stiff", "string"),
                                        (float("inf"), "inf")])
def test_bad_tangential_stiffness_exit_2(value, ids, tmp_path, capsys):
    data = copy.deepcopy(BASE)
    data["friction"] = {**data["friction"], "tangential_stiffness": value}
    data["solver"] = {"method": "hbm", "harmonics": 2}
    code, out, err = run(capsys, "solve", write_case(tmp_path, data))
    assert_input_error(code, out, err, "friction.tangential_stiffness")


def test_tangential_stiffness_in_case_file(tmp_path):
    data = copy.deepcopy(BASE)
    data["friction"] = {**data["friction"], "tangential_stiffness": 50.0}
    (el,) = mshbm.load_case(write_case(tmp_path, data)).system.elements
    assert isinstance(el, Jenkins) and el.tangential_stiffness == 50.0 and el.history


@pytest.mark.parametrize("relative", [False, True])
def test_hbm_jacobian_with_jenkins_and_relative_elements_matches_finite_differences(relative):
    els = [Jenkins(0, 1.0, 0.4, tangential_stiffness=8.0, relative_to=1 if relative else None),
           Friction(2, 0.3, 0.5, relative_to=1 if relative else None),
           Contact(1, 0.3, penalty_stiffness=50.0, relative_to=2 if relative else None)]
    s = chain([1.0, 2.0, 1.5], 1.0, 0.05, forcing=[{"dof": 2, "amplitude": 1.5}], elements=els)
    prob, _ = mshbm.build_problem(s, 0.8, "hbm", harmonics=4, steps=128)
    x = prob.initial_guess("linear") * 1.3 + 0.01
    R, J = prob.residual(x)
    J = J.toarray() if hasattr(J, "toarray") else J
    d = 1e-7
    worst = 0.0
    for i in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp[i] += d
        xm[i] -= d
        fd = (prob.residual(xp, jac=False)[0] - prob.residual(xm, jac=False)[0]) / (2 * d)
        worst = max(worst, np.abs(fd - J[:, i]).max() / max(1.0, np.abs(J[:, i]).max()))
    assert worst < 1e-5
