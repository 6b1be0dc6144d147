"""Friction whose normal load comes from a contact: ``Friction(..., normal_contact=c)``.

The model (``examples/damper2d.yaml``): a blade DOF ``q0`` (forced), the damper's tangential DOF ``q1``
carrying the friction and its normal DOF ``q2`` pressed by a constant force ``F0`` onto a stop at
``q2 = gap`` (the contact).  An inclined spring ``k_s`` along ``q0 - q2`` makes the normal load vary
with the blade's motion: while the contact is closed ``lambda_N = F0 - k_s (q2 - q0) - ...``.

Independent checks:

* **constant-load limit**: without the inclined spring the normal DOF is decoupled and rests on the
  stop, ``lambda_N = F0`` exactly (Moreau-Jean: ``P_N = h F0``; HBM: the penalty force
  ``F0 k_c / (k_c + K_22)``): the coupled friction gives the solution of a plain friction with that
  constant normal force (and a preload ``N_0`` adds to it);
* **contact never closed**: no normal load, no friction force: the linear response;
* **Coulomb's cone on every step**, ``|P_T| <= mu P_N`` (attained while slipping) and no penetration;
* **exact sensitivities**: the kernel's ``d(q_N, u_N)/d(q_0, u_0)`` equals central differences of the
  end state and the monodromy product from the status (slip signs included);
* **cross-method agreement**: shooting and MS-HBM (same Moreau-Jean scheme, the blade DOF by harmonic
  balance) agree to the Moreau-Jean accuracy, with the contact always closed and with lift-off;
  HBM (regularised) converges to them as the regularisation stiffens; DLFT (velocity predictor) agrees
  to its penalty-dependent accuracy while the contact stays closed;
* **case files**: bad ``normal_contact`` entries give one line naming the key and exit code 2.
"""
import copy

import numpy as np
import pytest

import mshbm
from tests import discretised
from mshbm import Contact, Friction, InputError, System
from mshbm.integrators import kernels
from mshbm.integrators.moreau_jean import MoreauJean
from mshbm.methods.base import central_difference_jacobian
from mshbm.methods.shooting import ShootingProblem

from integration.test_io_cli import assert_input_error, run, write_case  # shared CLI helpers

OMEGA = 0.8


def damper(k_s=0.6, F0=1.0, mu=0.5, A=1.5, gap=0.0, e=0.0, N0=0.0, kc=1e4, kappa=1e3, coupled=True,
           plain_load=None):
    """The 3-DOF damper model (see the module docstring).  ``plain_load``: a plain friction with this
    constant normal force instead of the coupled one."""
    M = np.diag([1.0, 0.3, 0.3])
    K = np.zeros((3, 3))
    for k, v in ((1.0, [1, 0, 0]), (1.0, [1, -1, 0]), (0.5, [0, 1, 0]), (2.0, [0, 0, 1]), (k_s, [1, 0, -1])):
        v = np.asarray(v, float)
        K += k * np.outer(v, v)
    C = 0.02 * K + 0.01 * M
    f_hat = np.zeros((3, 3))
    f_hat[1, 0], f_hat[0, 2] = A, F0
    fr = (Friction(1, mu, plain_load, smoothing=kappa) if plain_load is not None
          else Friction(1, mu, N0, smoothing=kappa, normal_contact=1 if coupled else None))
    return System(M, C, K, f_hat, [fr, Contact(2, gap, e, penalty_stiffness=kc)], name="damper")


def _solve(system, method, **kw):
    sol = discretised.solve(system, OMEGA, method, **kw)
    assert sol.success, sol.message
    return sol


# ----------------------------------------------------------------------------- constant-load limit
@pytest.mark.parametrize("method, kw", [("shooting", dict(steps=1024)),
                                        ("mshbm", dict(harmonics=7, steps=1024))])
@pytest.mark.parametrize("N0", [0.0, 0.4])
def test_constant_load_limit_equals_plain_friction(method, kw, N0):
    """k_s = 0: the normal DOF rests on the stop and lambda_N is constant on every step.

    Moreau-Jean's velocity-level contact law (``e = 0``) keeps a closed contact closed anywhere within
    ``O(h^2 F0 / m)`` of the stop (measured: MS-HBM's Newton stops at ``q2 = -7.1e-7``, shooting's at 0),
    and then ``lambda_N = F0 - K_22 q2``: the reference is the plain friction with the normal force that
    the coupled solution actually has, ``N_0 + P_N / h``, constant along the orbit (``= N_0 + F0`` when
    ``q2 = 0``).  The tangential and blade DOFs then agree to Newton's tolerance."""
    F0 = 1.0 - N0
    h = 2 * np.pi / OMEGA / kw["steps"]
    a = _solve(damper(k_s=0.0, F0=F0, N0=N0), method, **kw)
    PN = a.impulses[:, 1]
    assert np.abs(PN - PN[0]).max() <= 1e-12 * PN[0]  # constant normal load
    assert PN[0] / h == pytest.approx(F0 - 2.0 * float(a.q[0, 2]), rel=1e-9)  # F0 - K_22 q2 (q2 <= 0)
    if method == "shooting":
        assert abs(float(a.q[0, 2])) <= 1e-15 and PN[0] / h == pytest.approx(F0, rel=1e-12)
    load = N0 + PN[0] / h
    b = _solve(damper(k_s=0.0, F0=1.0, plain_load=load), method, **kw)
    scale = np.abs(b.q_hat).max()
    assert np.abs(np.asarray(a.q_hat)[:, :2] - np.asarray(b.q_hat)[:, :2]).max() <= 1e-8 * scale
    assert np.abs(a.q[:, :2] - b.q[:, :2]).max() <= 1e-8 * scale
    # the friction force is really limited by the contact's force: it slips at mu (N0 + lambda_N)
    assert np.abs(a.impulses[:, 0]).max() == pytest.approx(0.5 * h * load, rel=1e-12)


def test_constant_load_limit_hbm():
    """HBM: the penalty force of the decoupled normal DOF is F0 k_c / (k_c + K_22) exactly."""
    kc, F0 = 1e4, 1.0
    N = F0 * kc / (kc + 2.0)
    a = _solve(damper(k_s=0.0, F0=F0, kc=kc), "hbm", harmonics=9)
    b = _solve(damper(k_s=0.0, F0=F0, kc=kc, plain_load=N), "hbm", harmonics=9)
    scale = np.abs(b.q_hat).max()
    assert np.abs(np.asarray(a.q_hat) - np.asarray(b.q_hat)).max() <= 1e-9 * scale
    assert np.allclose(a.lam[:, 1], N, rtol=1e-10, atol=0)


# ----------------------------------------------------------------------------- contact never closed
@pytest.mark.parametrize("method, kw", [("shooting", dict(steps=1024)), ("mshbm", dict(harmonics=7, steps=1024)),
                                        ("hbm", dict(harmonics=7))])
def test_contact_never_closed_gives_the_linear_response(method, kw):
    """Gap 10, no pressing force: lambda_N = 0, hence lambda_T = 0: the response of the structure alone."""
    s = damper(F0=0.0, gap=10.0)
    a = _solve(s, method, **kw)
    # the structure alone (MS-HBM needs an element: a plain friction without load, which never acts)
    lin = _solve(s.with_elements([]) if method != "mshbm" else damper(F0=0.0, gap=10.0, plain_load=0.0),
                 method, **kw)
    assert np.abs(a.lam).max() == 0.0
    assert np.asarray(a.q)[:, 2].max() < 10.0  # never reaches the stop
    scale = np.abs(lin.q_hat).max()
    assert np.abs(np.asarray(a.q_hat) - np.asarray(lin.q_hat)).max() <= 1e-8 * scale


# ----------------------------------------------------------------------------- cone, penetration
@pytest.mark.parametrize("F0, lift_off", [(1.0, False), (0.3, True)])
def test_cone_holds_on_every_step_and_no_penetration(F0, lift_off):
    sol = _solve(damper(F0=F0), "shooting", steps=2048)
    P = sol.impulses
    PT, PN = P[:, 0], P[:, 1]
    scale = np.abs(P).max()
    assert np.all(np.abs(PT) <= 0.5 * PN + 1e-14 * scale)
    assert np.all(PN >= 0.0)
    assert np.all(0.0 - np.asarray(sol.q)[:, 2] >= -1e-12)  # g_N = gap - q2 >= 0
    slip = np.abs(PT) >= 0.5 * PN * (1 - 1e-12)
    assert slip.mean() > 0.3 and (~slip).mean() > 0.05  # stick-slip, the bound attained while slipping
    open_ = PN == 0.0
    assert bool(open_.any()) == lift_off
    assert np.all(PT[open_] == 0.0)  # lift-off: no friction
    closed = ~open_
    assert PN[closed].max() > 2 * PN[closed].min()  # the normal load varies along the period
    cone = sol.certificate["friction_cone"]
    assert cone.passed and cone.value == pytest.approx(1.0, abs=1e-9)


def test_kernel_matches_numpy_twin_with_coupling():
    s = damper(F0=0.3)
    N = 2048
    T = 2 * np.pi / OMEGA
    sol = _solve(s, "shooting", steps=N)
    st = MoreauJean(s.M, s.C, s.K, s.elements, T / N)
    t = np.linspace(0, T, N + 1)
    B = st.increments(s.forcing(t, OMEGA))
    tr = st.run(sol.q[0], sol.u[0], B)
    q, u, P = kernels.moreau_jean_numpy(sol.q[0], sol.u[0], st.Aq, st.Au, st.WG, st.Del, st.MinvG, B, st.theta,
                                        st.h, st.kind, st.dof, st.sign, st.bound, st.gap, st.e,
                                        nsrc=st.nsrc, mu_n=st.mu_n)
    assert np.abs(q - tr.q).max() <= 1e-10 * np.abs(tr.q).max()
    assert np.abs(P - tr.P).max() <= 1e-10 * np.abs(tr.P).max()


@pytest.mark.parametrize("mu", [0.5, 2.0])
def test_local_problem_solved_exactly_with_strong_delassus_coupling(mu):
    """A mass coupling M_12 = 0.2 between the tangential and normal DOFs (D_TN / D_TT = 0.67): the pair
    (friction, contact) is one exactly solved block; measured: 2 sweeps per step (the scalar projected
    Gauss-Seidel did not converge in 500 sweeps for mu = 2).  Checked on every step from the velocities
    alone: stick gamma_T+ = 0, slip P_T = -+mu P_N against the sign of gamma_T+, closed gamma_N+ = 0
    (e = 0), open P_N = 0."""
    s = damper(F0=0.3, mu=mu)
    M = s.dense("M").copy()
    M[1, 2] = M[2, 1] = 0.2
    s = System(M, s.C, s.K, s.f_hat, s.elements)
    N, T = 2048, 2 * np.pi / OMEGA
    sol = _solve(s, "shooting", steps=N)
    st = MoreauJean(s.M, s.C, s.K, s.elements, T / N)
    tr = st.run(sol.q[0], sol.u[0], st.increments(s.forcing(np.linspace(0, T, N + 1), OMEGA)))
    assert tr.pgs_iterations <= 3
    assert st.Del[0, 1] / st.Del[0, 0] > 0.6
    PT, PN = tr.P[:, 0], tr.P[:, 1]
    gT, gN = tr.u[1:, 1], -tr.u[1:, 2]
    vs = np.abs(tr.u).max()
    base = tr.status & 3
    stick, slip = base[:, 0] == kernels.STATUS_STICK, base[:, 0] == kernels.STATUS_SLIP
    closed = base[:, 1] == kernels.STATUS_CLOSED
    assert stick.any() and slip.any() and closed.any() and (~closed).any()
    assert np.abs(gT[stick]).max() <= 1e-12 * vs
    assert np.allclose(np.abs(PT[slip]), mu * PN[slip], rtol=1e-12, atol=0)
    assert np.all(PT[slip] * gT[slip] <= 1e-12 * vs * np.abs(PT[slip]))
    assert np.all(np.abs(PT) <= mu * PN * (1 + 1e-12))
    assert np.abs(gN[closed]).max() <= 1e-12 * vs
    assert np.all(PN[~closed] == 0.0)


@pytest.mark.parametrize("F0", [1.0, 0.3])
def test_sensitivities_are_exact(F0):
    """d(q_N, u_N)/d(q_0, u_0) of the kernel = central differences = monodromy from status and slip signs."""
    s = damper(F0=F0)
    prob = ShootingProblem(s, OMEGA, 2048)
    sol = _solve(s, "shooting", steps=2048)
    x = np.concatenate([sol.q[0], sol.u[0]])
    tr = prob.stepper.run(x[:3], x[3:], prob.B, sensitivities=True)
    S = np.vstack([tr.Sq, tr.Su])
    slipping = (tr.status[:, 0] == kernels.STATUS_SLIP) & ((tr.status[:, 1] & 3) == kernels.STATUS_CLOSED)
    assert slipping.sum() > 100  # the coupled rows are exercised
    Phi = prob.stepper.monodromy(tr.status, tr.P)
    assert np.abs(S - Phi).max() <= 1e-10 * np.abs(S).max()

    def end(xp):
        t = prob.stepper.run(xp[:3], xp[3:], prob.B)
        return np.concatenate([t.q[-1], t.u[-1]])

    # on the orbit the normal DOF rests exactly on the stop, a kink of the step map in q2 (the
    # differences in q2 straddle it: measured 1.08 against the kernel's one-sided 0); off the orbit
    # (q2 = 1e-3 into the stop: projected onto it in the first step) every column is smooth
    x = x + 1e-3
    tr = prob.stepper.run(x[:3], x[3:], prob.B, sensitivities=True)
    S = np.vstack([tr.Sq, tr.Su])
    FD = np.zeros((6, 6))
    for i in range(6):
        d = np.zeros(6)
        d[i] = 1e-7
        FD[:, i] = (end(x + d) - end(x - d)) / 2e-7
    assert np.abs(S - FD).max() <= 1e-6 * np.abs(S).max()
    with pytest.raises(ValueError, match="impulses"):
        prob.stepper.monodromy(tr.status)


def test_hbm_jacobian_against_differences():
    from mshbm.api import build_problem

    s = damper(F0=0.3, kappa=100, kc=100)
    ref = _solve(damper(F0=0.3), "shooting", steps=1024)
    for condense in (True, False):
        p = build_problem(s, OMEGA, "hbm", harmonics=5, steps=512, condense=condense)[0]
        x = p.initial_guess({"q_hat": ref.q_hat})
        _, J = p.residual(x)
        J = J.toarray() if hasattr(J, "toarray") else J
        FD = central_difference_jacobian(lambda y: p.residual(y, jac=False)[0], x, rel_step=1e-7)
        assert np.abs(J - FD).max() <= 1e-7 * np.abs(J).max()


# ----------------------------------------------------------------------------- cross-method agreement
@pytest.mark.parametrize("method", ["mshbm", "mshbm-intermediate"])
@pytest.mark.parametrize("F0", [1.0, 0.3], ids=["closed", "lift-off"])
def test_shooting_and_mshbm_agree(F0, method):
    """Same Moreau-Jean scheme (8192 steps); MS-HBM with 15 harmonics on the blade DOF.  Measured
    relative differences of the amplitudes: 1e-6 (closed), 3e-6 (lift-off); Moreau-Jean's own error
    (2048 against 8192 steps): 1e-5 (closed), 1.2e-4 (lift-off)."""
    a = _solve(damper(F0=F0), "shooting", steps=8192)
    b = _solve(damper(F0=F0), method, harmonics=15, steps=8192)
    amp_a, amp_b = np.asarray(a.amplitude), np.asarray(b.amplitude)
    assert np.abs(amp_a - amp_b).max() <= 2e-5 * amp_a.max()
    assert np.abs(a.q - b.q).max() <= 2e-5 * np.abs(a.q).max()


def test_hbm_converges_to_shooting_as_the_regularisation_stiffens():
    """Contact always closed, the load varying: HBM (31 harmonics) against shooting (8192 steps).
    Measured relative errors of the amplitudes: 0.95 % (kappa = 1e3, k_c = 1e4), 0.29 % (1e4, 1e5)."""
    ref = np.asarray(_solve(damper(), "shooting", steps=8192).amplitude)
    errs = []
    for kappa, kc in ((1e3, 1e4), (1e4, 1e5)):
        amp = np.asarray(_solve(damper(kappa=kappa, kc=kc), "hbm", harmonics=31, steps=4096).amplitude)
        errs.append(np.abs(amp[:2] - ref[:2]).max() / ref[:2].max())
    assert errs[1] <= 0.005
    assert errs[1] < errs[0] / 2


def test_element_bound_per_sample_and_scaling():
    fr = Friction(0, 0.5, 0.2, normal_contact=1)
    lam = np.array([[0.0, 1.0], [0.0, 0.0], [0.0, -3.0]])  # a negative (penalty) force is no load
    assert np.allclose(fr.bound_samples(lam), [0.5 * 1.2, 0.5 * 0.2, 0.5 * 0.2], rtol=1e-15)
    assert fr.kernel_coupling() == (1, 0.5) and Friction(0, 0.5, 1.0).kernel_coupling() == (-1, 0.0)
    assert Friction(0, 0.5, 0.0, normal_contact=1).acts and not Friction(0, 0.5, 0.0).acts
    half = fr.bound_scaled(0.5)  # the whole bound mu (N_0 + lambda_N) times 0.5
    assert np.allclose(half.bound_samples(lam), 0.5 * fr.bound_samples(lam), rtol=1e-15)
    with pytest.raises(TypeError):
        fr.regularised_law(np.zeros(2), np.zeros(2))  # needs the contact force: coupled_law


# ----------------------------------------------------------------------------- inputs
def test_python_api_errors():
    M, K = np.eye(2), np.eye(2)
    f = np.zeros((3, 2))
    with pytest.raises(InputError) as exc:
        System(M, 0 * K, K, f, [Friction(0, 0.5, 0.0, normal_contact=3), Contact(1, 0.0)])
    assert exc.value.key == "friction.normal_contact"
    with pytest.raises(InputError) as exc:
        System(M, 0 * K, K, f, [Friction(0, 0.5, 0.0, normal_contact=1), Friction(1, 0.5, 1.0)])
    assert exc.value.key == "friction.normal_contact" and "is a friction" in str(exc.value)
    with pytest.raises(InputError) as exc:
        System(M, 0 * K, K, f, [Friction(0, 0.5, 0.0, normal_contact=1), Contact(0, 0.0)])
    assert exc.value.key == "friction.normal_contact" and "own DOF" in str(exc.value)
    with pytest.raises(InputError) as exc:
        Friction(0, 0.5, 0.0, normal_contact=-1)
    assert exc.value.key == "friction.normal_contact"


def test_exact_flow_rejects_it_cleanly():
    """The event-driven flow does not support the coupling (``Element.normal_contact`` is the flag)."""
    from mshbm.methods.exact import exact_periodic

    with pytest.raises(InputError):
        exact_periodic(damper(), OMEGA)


def test_dlft_displacement_predictor_rejects_it_cleanly():
    with pytest.raises(InputError) as exc:
        discretised.solve(damper(), OMEGA, "dlft", harmonics=5, dlft_predictor="displacement")
    assert exc.value.key == "friction.normal_contact"


def test_dlft_jacobian_against_differences():
    from mshbm.api import build_problem

    for F0 in (1.0, 0.3):
        ref = _solve(damper(F0=F0), "shooting", steps=1024)
        p = build_problem(damper(F0=F0), OMEGA, "dlft", harmonics=7, steps=512)[0]
        x = p.initial_guess({"q_hat": ref.q_hat}) + 1e-3
        _, J = p.residual(x)
        FD = central_difference_jacobian(lambda y: p.residual(y, jac=False)[0], x, rel_step=1e-7)
        assert np.abs(J - FD).max() <= 1e-7 * np.abs(J).max()


def test_dlft_agrees_with_shooting_while_the_contact_is_closed():
    """Velocity predictor, 15 harmonics (DLFT's own error depends on its penalty): measured relative
    amplitude differences 0.14 % (q0), 0.29 % (q1) against shooting with 8192 steps."""
    ref = np.asarray(_solve(damper(), "shooting", steps=8192).amplitude)
    sol = _solve(damper(), "dlft", harmonics=15)
    amp = np.asarray(sol.amplitude)
    assert np.abs(amp[:2] - ref[:2]).max() <= 0.005 * ref[:2].max()
    lam = np.asarray(sol.lam)
    assert np.all(np.abs(lam[:, 0]) <= 0.5 * lam[:, 1] * (1 + 1e-12))  # the cone on every sample
    assert lam[:, 1].max() > 2 * lam[:, 1].min() > 0  # closed, the load varying


DAMPER_CASE = {
    "name": "damper",
    "M": [[1.0, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, 0.0, 0.3]],
    "K": [[2.6, -1.0, -0.6], [-1.0, 1.5, 0.0], [-0.6, 0.0, 2.6]],
    "damping": {"alpha": 0.01, "beta": 0.02},
    "omega": 0.8,
    "forcing": [{"dof": 0, "amplitude": 1.5}, {"dof": 2, "constant": 1.0}],
    "friction": {"dof": 1, "mu": 0.5, "normal_contact": 0, "smoothing": 1000},
    "contact": {"dof": 2, "gap": 0, "restitution": 0, "penalty_stiffness": 10000},
    "solver": {"method": "shooting", "steps": 1024},
}


def test_case_file_builds_the_damper(tmp_path):
    case = mshbm.load_case(write_case(tmp_path, DAMPER_CASE))
    fr, ct = case.system.elements
    assert fr.normal_contact == 1 and fr.normal_force == 0.0 and ct.unilateral
    ref = damper(kc=1e4)
    assert np.allclose(case.system.dense("K"), ref.dense("K")) and np.allclose(case.system.dense("C"), ref.dense("C"))
    a = discretised.solve(case.system, 0.8, "shooting", steps=1024)
    b = _solve(ref, "shooting", steps=1024)
    assert a.success and np.abs(a.q - b.q).max() <= 1e-10 * np.abs(b.q).max()


def test_example_file_is_the_damper():
    from pathlib import Path

    case = mshbm.load_case(Path(__file__).resolve().parents[2] / "examples" / "damper2d.yaml")
    fr, ct = case.system.elements
    assert fr.normal_contact == 1 and ct.dof == 2
    assert np.allclose(case.system.dense("K"), damper().dense("K"))


def _with(section, **kw):
    def modify(data):
        data[section] = {**data[section], **kw}
    return modify


def _two_frictions(data):
    data["friction"] = [data["friction"], {"dof": 0, "mu": 0.5, "normal_contact": 1}]


@pytest.mark.parametrize("modify, key", [
    (_with("friction", normal_contact=1), "friction.normal_contact"),
    (_with("friction", normal_contact=-1), "friction.normal_contact"),
    (_with("friction", normal_contact="contact"), "friction.normal_contact"),
    (_with("friction", normal_contact=0.5), "friction.normal_contact"),
    (_with("friction", dof=2), "friction.normal_contact"),
    (_with("friction", mu=-0.5), "friction.mu"),
    (_with("friction", normal_force=-1.0), "friction.normal_force"),
    (lambda d: (_with("friction", tangential_stiffness=10.0)(d), d.update(solver={"method": "hbm", "harmonics": 5})),
     "friction.normal_contact"),  # Jenkins with a contact-loaded bound: HBM only refuses
    (_two_frictions, "friction[1].normal_contact"),
], ids=["unknown-index", "negative", "string", "non-integer", "same-dof", "negative-mu", "negative-preload",
        "jenkins", "list-index"])
def test_bad_normal_contact_in_case_file_exit_2(modify, key, tmp_path, capsys):
    data = copy.deepcopy(DAMPER_CASE)
    modify(data)
    code, out, err = run(capsys, "solve", write_case(tmp_path, data))
    assert_input_error(code, out, err, key)


def test_missing_normal_force_still_required_without_contact(tmp_path, capsys):
    data = copy.deepcopy(DAMPER_CASE)
    data["friction"] = {"dof": 1, "mu": 0.5}
    code, out, err = run(capsys, "solve", write_case(tmp_path, data))
    assert_input_error(code, out, err, "friction.normal_force")


def test_dlft_displacement_predictor_in_case_file_exit_2(tmp_path, capsys):
    data = copy.deepcopy(DAMPER_CASE)
    data["solver"] = {"method": "dlft", "harmonics": 5, "dlft_predictor": "displacement"}
    code, out, err = run(capsys, "solve", write_case(tmp_path, data))
    assert_input_error(code, out, err, "friction.normal_contact")
