"""3-D frictional contact: two frictions linked as cone partners (circular cone ``||lambda_T|| <= mu F_N``,
:mod:`mshbm.elements.cone`).

Independent references:

* **rotating force on an isotropic 2-DOF oscillator** (``m, c, k`` in both tangential directions) with a
  constant normal load ``N``: the steady state is a circular orbit of radius ``r`` solving
  ``|F|^2 = ((k - m w^2) r)^2 + (c w r + mu N)^2``.  Moreau-Jean's periodic orbit is a discrete circle too
  (the scheme commutes with rotations): with ``rho = exp(i w h)``, ``a = 1 - theta + theta rho``,
  ``D = m (rho - 1) + h c a + h^2 k a^2 / (rho - 1)`` its velocity modulus ``s`` solves
  ``|s D + h mu N rho| = h F |a|`` and ``r_h = h |a| s / |rho - 1|`` -- the exact reference of shooting and
  both MS-HBM variants at every step count; ``r_h - r = O(h)`` (the friction impulse acts with the velocity
  at the step's end), shown by the error times ``N`` and by Richardson extrapolation of the solver's radii
  to 1e-6.  HBM (regularised cone) lies within its own regularisation estimate;
* **slip confined to one direction** (a force along ``q0`` only): the pair gives the 1-D friction element's
  solution to 1e-12 (Moreau-Jean: the disk projection is the interval's; HBM: the regularised cone law
  reduces to eq. 42 exactly);
* **varying normal load** (``examples/cone3d.yaml``): Coulomb's cone on every step, no penetration,
  maximal dissipation, shooting = MS-HBM, the kernel = its NumPy twin, sensitivities = central differences;
  DLFT (3-D, the velocity predictor projected onto the disk) = extrapolated shooting, its Jacobian = central
  differences; DLFT is exact on the rotating-force orbit;
* clear refusals (event flow, DLFT) and input errors (inconsistent partners, case files).
"""
from pathlib import Path

import numpy as np
import pytest

import mshbm
from mshbm import Friction, InputError, Jenkins, System, frictional_contact
from mshbm.integrators import kernels
from mshbm.integrators.moreau_jean import MoreauJean
from tests import discretised

ROOT = Path(__file__).resolve().parents[2]
m, c, k, MU, N0, F = 1.0, 0.05, 1.0, 0.3, 1.0, 1.0
W = 0.8


def oscillator(direction="rotating", pair=True, smoothing=None):
    """Isotropic 2-DOF oscillator with a 3-D friction contact at constant normal load ``N0`` (``pair=False``:
    the 1-D friction element on q0 instead)."""
    fh = np.zeros((3, 2))
    fh[1, 0] = F
    if direction == "rotating":
        fh[2, 1] = F
    els = frictional_contact(0, 1, MU, N0, smoothing=smoothing) if pair else [Friction(0, MU, N0, smoothing=smoothing)]
    return System(m * np.eye(2), c * np.eye(2), k * np.eye(2), fh, els, name="cone2")


def radius(w):
    """The circular orbit's radius (closed form)."""
    a, b = (k - m * w * w) ** 2 + (c * w) ** 2, 2 * c * w * MU * N0
    return (-b + np.sqrt(b * b - 4 * a * ((MU * N0) ** 2 - F ** 2))) / (2 * a)


def radius_discrete(w, N, theta=0.5):
    """The Moreau-Jean orbit's radius with ``N`` steps per period (closed form, module docstring)."""
    h = 2 * np.pi / w / N
    rho = np.exp(1j * w * h)
    a = 1 - theta + theta * rho
    D = m * (rho - 1) + h * c * a + h * h * k * a * a / (rho - 1)
    A, B = abs(D) ** 2, 2 * h * MU * N0 * (D * np.conj(rho)).real
    C = (h * MU * N0) ** 2 - (h * F * abs(a)) ** 2
    s = (-B + np.sqrt(B * B - 4 * A * C)) / (2 * A)
    return h * abs(a) * s / abs(rho - 1)


def _solve(system, method, **kw):
    sol = discretised.solve(system, W, method, **kw)
    assert sol.success, sol.message
    return sol


# ----------------------------------------------------------------------------- rotating force: closed forms
@pytest.mark.parametrize("method", ["shooting", "mshbm", "mshbm-intermediate"])
def test_rotating_force_moreau_jean_is_the_discrete_circle(method):
    """Every step of the periodic orbit lies on the discrete closed form's circle (1e-9 relative), with the
    friction force of full magnitude opposing the end-of-step slip (certificate: cone and dissipation)."""
    for N in (512, 2048):
        sol = _solve(oscillator(), method, steps=N, harmonics=3)
        r = np.hypot(sol.q[:, 0], sol.q[:, 1])
        rd = radius_discrete(W, N)
        assert np.max(np.abs(r - rd)) <= 1e-9 * rd
        cert = sol.certificate
        assert cert["friction_cone"].value <= 1 + 1e-12
        assert cert["cone_dissipation"].gating and cert["cone_dissipation"].value <= 1e-12
        assert abs(np.hypot(sol.lam[:, 0], sol.lam[:, 1]) - MU * N0).max() <= 1e-12  # slips all the time


def test_rotating_force_time_step_error_converges_to_closed_form():
    """``r_h - r`` is first order in ``h`` (``N (r_h - r)`` constant to 2 % from N = 1024 to 65536), and two
    Richardson steps on the shooting radii at N = 1024, 2048, 4096 reach the closed form to 1e-6."""
    r = radius(W)
    err = [N * (radius_discrete(W, N) - r) for N in (1024, 4096, 65536)]
    assert err[0] > 0 and abs(err[1] / err[0] - 1) < 0.02 and abs(err[2] / err[0] - 1) < 0.02
    rs = []
    for N in (1024, 2048, 4096):
        sol = _solve(oscillator(), "shooting", steps=N, harmonics=3)
        rs.append(float(np.mean(np.hypot(sol.q[:, 0], sol.q[:, 1]))))
    r1 = [2 * rs[1] - rs[0], 2 * rs[2] - rs[1]]
    r2 = (4 * r1[1] - r1[0]) / 3
    assert abs(rs[2] - r) > 1e-4 * r  # the raw error is the time step's
    assert abs(r2 - r) <= 1e-6 * r


def test_rotating_force_hbm_within_regularisation_error():
    """HBM with the regularised cone (default kappa) and the default accuracy (its estimates; with accuracy=False
    the regularisation is not estimated): the radius lies within the certificate's regularisation estimate of the
    closed form (measured: 7e-7 against the estimate 3.8e-6), and a 10x stiffer law comes 5x closer at least."""
    r = radius(W)
    sol = _solve(oscillator(), "hbm", harmonics=3, accuracy=None)
    rr = np.hypot(sol.q[:, 0], sol.q[:, 1])
    est = sol.certificate["regularisation"].value
    assert np.max(np.abs(rr - r)) / r <= est <= 1e-5
    kappa = mshbm.methods.hbm_regularisation.resolve(oscillator(), W)[0].elements[0].smoothing
    e1 = abs(np.mean(np.hypot(*_solve(oscillator(smoothing=kappa), "hbm", harmonics=3).q[:, :2].T)) - r)
    e10 = abs(np.mean(np.hypot(*_solve(oscillator(smoothing=10 * kappa), "hbm", harmonics=3).q[:, :2].T)) - r)
    assert e10 <= e1 / 5


def test_rotating_force_dlft_is_the_closed_form():
    """DLFT (set-valued, velocity predictor projected onto the disk): the circular orbit to 1e-12."""
    sol = _solve(oscillator(), "dlft", harmonics=3)
    r = np.hypot(sol.q[:, 0], sol.q[:, 1])
    assert np.max(np.abs(r - radius(W))) <= 1e-12 * radius(W)


@pytest.mark.parametrize("method, kw", [("shooting", dict(steps=1024)), ("mshbm", dict(steps=1024, harmonics=3)),
                                        ("hbm", dict(harmonics=3)), ("dlft", dict(harmonics=3))])
def test_rotating_force_between_two_nodes(method, kw):
    """The contact between two nodes (``relative_to``): two copies of the oscillator driven by opposite rotating
    forces move antisymmetrically, ``q_B = -q_A``, the relative slip is ``2 u_A`` and each node feels the full
    cone opposing its velocity: node A's orbit is the grounded one (discrete closed form to 1e-9 for
    Moreau-Jean, 1e-5 of the continuous closed form for HBM, 1e-12 for DLFT, relative: the demanded force of the
    pair is half the difference of the two nodes' linear residuals)."""
    fh = np.zeros((3, 4))
    fh[1, 0], fh[2, 1], fh[1, 2], fh[2, 3] = F, F, -F, -F
    S = System(m * np.eye(4), c * np.eye(4), k * np.eye(4), fh,
               frictional_contact(0, 1, MU, N0, relative_to=(2, 3, None)))
    sol = _solve(S, method, **kw)
    r = np.hypot(sol.q[:, 0], sol.q[:, 1])
    assert np.max(np.abs(sol.q[:, :2] + sol.q[:, 2:])) <= 1e-12 * r.max()
    ref, tol = {"hbm": (radius(W), 1e-5), "dlft": (radius(W), 1e-12)}.get(method) or (radius_discrete(W, kw["steps"]),
                                                                                      1e-9)
    assert np.max(np.abs(r - ref)) <= tol * ref


# ----------------------------------------------------------------------------- slip confined to one direction
@pytest.mark.parametrize("method, kw", [("shooting", dict(steps=1024)), ("mshbm", dict(steps=1024, harmonics=5)),
                                        ("hbm", dict(harmonics=5)), ("dlft", dict(harmonics=5))])
def test_slip_in_one_direction_is_the_1d_element(method, kw):
    """A force along q0 only: the 3-D contact's solution is the 1-D friction element's to 1e-12."""
    a = _solve(oscillator("q0", pair=True, smoothing=50.0), method, **kw)
    b = _solve(oscillator("q0", pair=False, smoothing=50.0), method, **kw)
    scale = float(np.abs(b.q[:, 0]).max())
    assert np.max(np.abs(a.q[:, 0] - b.q[:, 0])) <= 1e-12 * scale
    assert np.max(np.abs(a.q[:, 1])) <= 1e-12 * scale
    assert np.max(np.abs(a.lam[:, 0] - b.lam[:, 0])) <= 1e-12 * MU * N0


def test_kernel_one_direction_equals_1d_kernel_stepwise():
    """Trajectories of the kernel from one state: the pair under a force along q0 equals the 1-D element."""
    h = 2 * np.pi / W / 256
    out = []
    for pair in (True, False):
        s = oscillator("q0", pair=pair)
        st = MoreauJean(s.M, s.C, s.K, list(s.elements), h, 0.5, True)
        t = np.linspace(0, 2 * np.pi / W, 257)
        B = st.increments(s.forcing(t, W))
        out.append(st.run(np.array([0.3, 0.0]), np.array([0.0, 0.0]), B))
    assert np.max(np.abs(out[0].q - out[1].q)) <= 1e-13
    assert np.max(np.abs(out[0].P[:, 0] - out[1].P[:, 0])) <= 1e-15


# ----------------------------------------------------------------------------- 3-D Jenkins (tangential stiffness)
KT = 2.0


def jenkins_oscillator(direction="rotating", pair=True):
    fh = np.zeros((3, 2))
    fh[1, 0] = F
    if direction == "rotating":
        fh[2, 1] = F
    els = frictional_contact(0, 1, MU, N0, tangential_stiffness=KT) if pair else [Jenkins(0, MU, N0,
                                                                                          tangential_stiffness=KT)]
    return System(m * np.eye(2), c * np.eye(2), k * np.eye(2), fh, els, name="jenkins2")


def radius_jenkins(w):
    """Rotating force, 3-D Jenkins in steady slip: the slider circles at radius ``rho`` behind the mass by the
    spring's stretch ``beta = mu N / k_t`` (the force ``mu N`` opposes the slider's velocity); with
    ``D = k - m w^2 + i c w``: ``|D (rho + i beta) + i mu N| = F`` and ``r = sqrt(rho^2 + beta^2)``."""
    D, beta = k - m * w * w + 1j * c * w, MU * N0 / KT
    z0 = 1j * (D * beta + MU * N0)
    a, B, C = abs(D) ** 2, 2 * (z0 * np.conj(D)).real, abs(z0) ** 2 - F ** 2
    rho = (-B + np.sqrt(B * B - 4 * a * C)) / (2 * a)
    return float(np.hypot(rho, beta))


@pytest.mark.parametrize("method, key, sizes", [("shooting", "steps", (1024, 2048, 4096)),
                                                ("hbm", "steps", (256, 512, 1024))])
def test_rotating_force_jenkins_converges_to_closed_form(method, key, sizes):
    """3-D Jenkins under the rotating force: Moreau-Jean (slider DOFs with the disk) and HBM (return mapping on
    the disk over the AFT samples) are first order in the step / sample spacing (raw errors 1e-3); two
    Richardson steps reach the closed form to 1e-6."""
    r = radius_jenkins(W)
    rs = []
    for N in sizes:
        sol = _solve(jenkins_oscillator(), method, harmonics=3, **{key: N})
        rs.append(float(np.mean(np.hypot(sol.q[:, 0], sol.q[:, 1]))))
        assert sol.certificate["friction_cone"].value <= 1 + 1e-12
    r1 = [2 * rs[1] - rs[0], 2 * rs[2] - rs[1]]
    r2 = (4 * r1[1] - r1[0]) / 3
    assert abs(rs[2] - r) > 1e-4 * r
    assert abs(r2 - r) <= 1e-6 * r


def test_cone_history_law_derivative_equals_central_differences():
    """The 3-D Jenkins law's derivative with respect to Fourier coefficients (stick and rotating slip)."""
    from mshbm import fourier
    from mshbm.elements.cone import cone_history_law

    el = jenkins_oscillator().elements[0]
    V = fourier.idft_matrix(64, 3)
    rng = np.random.default_rng(1)
    c = rng.standard_normal((7, 2)) * 0.5
    lam, D = cone_history_law(el, V @ c[:, 0], V @ c[:, 1], V)
    assert np.any(np.hypot(lam[:, 0], lam[:, 1]) >= el.bound * (1 - 1e-12))  # slips
    assert np.any(np.hypot(lam[:, 0], lam[:, 1]) < 0.99 * el.bound)  # and sticks
    eps = 1e-7
    for b in range(2):
        for n in range(7):
            dc = np.zeros_like(c)
            dc[n, b] = eps
            lp = cone_history_law(el, *(V @ (c + dc)).T)[0]
            lm = cone_history_law(el, *(V @ (c - dc)).T)[0]
            assert np.max(np.abs((lp - lm) / (2 * eps) - D[:, :, b, n])) <= 1e-6


@pytest.mark.parametrize("method, kw", [("shooting", dict(steps=512)), ("hbm", dict(harmonics=5, steps=256))])
def test_jenkins_slip_in_one_direction_is_the_1d_jenkins(method, kw):
    a = _solve(jenkins_oscillator("q0", pair=True), method, **kw)
    b = _solve(jenkins_oscillator("q0", pair=False), method, **kw)
    scale = float(np.abs(b.q[:, 0]).max())
    assert np.max(np.abs(a.q[:, 0] - b.q[:, 0])) <= 1e-12 * scale
    assert np.max(np.abs(a.q[:, 1])) <= 1e-12 * scale


# ----------------------------------------------------------------------------- varying normal load
def _cone3d():
    case = mshbm.load_case(ROOT / "examples" / "cone3d.yaml")
    return case.system, case.omega


def test_varying_normal_load_cone_and_non_penetration():
    """examples/cone3d.yaml: the normal load varies (0.43..1.53 N), the contact stays closed; on every step
    ``||P_T|| <= mu P_N`` (attained while slipping), the normal DOF never penetrates, the certificate's cone,
    dissipation and energy checks pass; shooting and MS-HBM agree to Newton's tolerance (same scheme)."""
    S, w = _cone3d()
    a = discretised.solve(S, w, "shooting", steps=2048)
    b = discretised.solve(S, w, "mshbm", steps=2048, harmonics=15)
    for sol in (a, b):
        assert sol.success, sol.message
        P = sol.impulses
        PT, PN = np.hypot(P[:, 0], P[:, 1]), P[:, 2]
        assert np.all(PT <= 0.5 * PN * (1 + 1e-12))
        assert np.min(sol.q[:, 2]) >= -1e-7  # gap 0 (MS-HBM: the Newton tolerance of the closed contact)
        for name in ("friction_cone", "non_penetration", "cone_dissipation", "energy_balance"):
            assert sol.certificate[name].passed, name
    lamN = a.impulses[:, 2] / (2 * np.pi / w / 2048)
    assert lamN.min() < 0.5 and lamN.max() > 1.5  # the load varies
    assert np.max(np.abs(a.q - b.q)) <= 1e-6 * np.abs(a.q).max()


def test_ms_hbm_variants_with_linear_dofs_lift_off_and_impacts():
    """The contact point of cone3d driven through two linear DOFs (condensed by MS-HBM, harmonic in the
    intermediate variant's subsystem 2): the contact lifts off and closes with impacts; both MS-HBM variants
    agree with shooting (the same Moreau-Jean scheme) to their truncation, 1e-4 of the amplitude (measured
    3e-5 at n_H = 15), and Coulomb's cone holds on every step."""
    S0, w = _cone3d()
    M, K = np.zeros((5, 5)), np.zeros((5, 5))
    M[:3, :3], K[:3, :3] = S0.M, S0.K
    M[3, 3] = M[4, 4] = 2.0
    for kk, v in ((1.5, [1, 0, 0, -1, 0]), (1.0, [0, 0, 0, 1, 0]), (1.5, [0, 1, 0, 0, -1]), (1.0, [0, 0, 0, 0, 1])):
        v = np.array(v, float)
        K += kk * np.outer(v, v)
    fh = np.zeros((3, 5))
    fh[1, 3], fh[2, 4], fh[0, 2] = 1.5, 1.5, 1.0
    S = System(M, 0.01 * M + 0.02 * K, K, fh, frictional_contact(0, 1, 0.5, normal=2, gap=0.0, restitution=0.0))
    ref = _solve(S, "shooting", steps=2048)
    assert ref.lam[:, 2].min() == 0.0 and ref.lam[:, 2].max() > 10.0  # lift-off, impacts
    for method, kw in (("mshbm", {}), ("mshbm-intermediate", dict(partition=([0, 1, 2], [3, 4])))):
        sol = _solve(S, method, steps=2048, harmonics=15, **kw)
        assert np.max(np.abs(sol.amplitude - ref.amplitude)) <= 1e-4 * ref.amplitude.max()
        P = sol.impulses
        assert np.all(np.hypot(P[:, 0], P[:, 1]) <= 0.5 * P[:, 2] * (1 + 1e-12) + 1e-300)


def test_varying_normal_load_hbm_agrees_with_shooting():
    """HBM (regularised cone, penalty contact) agrees with shooting to the sum of the Moreau-Jean step error
    (O(h), measured 2e-4 at 2048 steps) and the regularisation's (measured 6e-5): 1e-3 of the amplitude."""
    S, w = _cone3d()
    a = discretised.solve(S, w, "shooting", steps=2048)
    hb = discretised.solve(S, w, "hbm", harmonics=15)
    assert a.success and hb.success, hb.message
    amp = np.abs(a.amplitude[:2])
    assert np.max(np.abs(hb.amplitude[:2] - amp)) <= 1e-3 * amp.max()
    assert hb.certificate["friction_cone"].value <= 1.0


def test_varying_normal_load_dlft():
    """DLFT (3-D, velocity predictor): its Jacobian equals central differences of its residual (off the
    solution, slip and stick samples and a varying bound), and its amplitudes agree with shooting's
    Richardson-extrapolated ones (Moreau-Jean is first order: 2 A(4096) - A(2048)) to 2e-6 (measured 3.6e-7;
    the raw 4096-step amplitudes differ by 4.9e-4)."""
    from mshbm.methods.base import central_difference_jacobian
    from mshbm.methods.dlft import DLFTProblem

    S, w = _cone3d()
    d = discretised.solve(S, w, "dlft", harmonics=15)
    assert d.success, d.message
    sh = [discretised.solve(S, w, "shooting", steps=N) for N in (2048, 4096)]
    ext = 2 * sh[1].amplitude[:2] - sh[0].amplitude[:2]
    assert np.max(np.abs(d.amplitude[:2] - ext)) <= 2e-6 * ext.max()
    prob = DLFTProblem(S, w, 15, d.steps)
    x = np.asarray(d.x) + 1e-3 * np.random.default_rng(0).standard_normal(np.size(d.x))
    R, J = prob.residual(x)
    Jfd = central_difference_jacobian(lambda z: prob.residual(z, jac=False)[0], x, 1e-7)
    assert np.max(np.abs(np.asarray(J) - Jfd)) <= 1e-7 * np.abs(Jfd).max()


@pytest.mark.parametrize("jenkins", [False, True])
def test_hbm_jacobian_equals_central_differences(jenkins):
    """HBM's residual Jacobian with the regularised cone, its penalty contact and the varying bound (cone3d), and
    with the 3-D Jenkins law: central differences of the residual (off the solution)."""
    from mshbm.methods.base import central_difference_jacobian
    from mshbm.methods.hbm import HBMProblem
    from mshbm.methods.hbm_regularisation import resolve

    if jenkins:
        S, w = jenkins_oscillator(), W
    else:
        S, w = _cone3d()
        S = resolve(S, w)[0]
    prob = HBMProblem(S, w, 5, 64)
    x = prob.initial_guess("linear") + 0.05 * np.random.default_rng(2).standard_normal(prob.n_unknowns)
    R, J = prob.residual(x)
    Jfd = central_difference_jacobian(lambda z: prob.residual(z, jac=False)[0], x, 1e-7)
    assert np.max(np.abs(np.asarray(J) - Jfd)) <= 1e-6 * np.abs(Jfd).max()


def _stepper(h):
    S, w = _cone3d()
    st = MoreauJean(np.asarray(S.M), np.asarray(S.C), np.asarray(S.K), list(S.elements), h, 0.5, True)
    t = np.arange(151) * h
    return st, st.increments(S.forcing(t, w))


def test_kernel_equals_numpy_twin_with_rotating_slip():
    """The compiled kernel and its NumPy twin (the disk by bisection instead of Newton's iteration) agree on
    150 steps of rotating slip with a varying normal load."""
    h = 2 * np.pi / 0.8 / 512
    st, B = _stepper(h)
    q0, u0 = np.array([0.5, -0.8, 0.0]), np.array([0.3, 0.9, 0.0])
    tr = st.run(q0, u0, B)
    assert np.any((tr.status[:, 0] & 3) == kernels.STATUS_SLIP) and np.any(np.abs(tr.P[:, 1]) > 1e-3)
    q, u, P = kernels.moreau_jean_numpy(q0, u0, st.Aq, st.Au, st.WG, st.Del, st.MinvG, B, st.theta, st.h, st.kind,
                                        st.dof, st.sign, st.bound, st.gap, st.e, dof2=st.dof2, nsrc=st.nsrc,
                                        mu_n=st.mu_n, tpair=st.tpair)
    assert np.max(np.abs(q - tr.q)) <= 1e-10 and np.max(np.abs(P - tr.P)) <= 1e-12


def test_kernel_sensitivities_with_rotating_slip_equal_central_differences():
    """``d(q_N, u_N)/d(q_0, u_0)`` of the kernel (rotating slip, closed contact) = central differences."""
    h = 2 * np.pi / 0.8 / 512
    st, B = _stepper(h)
    B = B[:120]
    x0 = np.array([0.5, -0.8, 0.0, 0.3, 0.9, 0.0])
    tr = st.run(x0[:3], x0[3:], B, sensitivities=True)
    J = np.vstack([tr.Sq[:, :6], tr.Su[:, :6]])
    Jfd = np.zeros((6, 6))
    eps = 1e-7
    for i in range(6):
        if i in (2, 5):  # the normal DOF on the stop: one-sided (a closed contact), skip its columns
            continue
        d = np.zeros(6)
        d[i] = eps
        e = [st.run((x0 + s * d)[:3], (x0 + s * d)[3:], B) for s in (1, -1)]
        Jfd[:, i] = (np.concatenate([e[0].q[-1], e[0].u[-1]]) - np.concatenate([e[1].q[-1], e[1].u[-1]])) / (2 * eps)
    cols = [0, 1, 3, 4]
    assert np.max(np.abs(J[:, cols] - Jfd[:, cols])) <= 1e-6 * max(1.0, np.abs(J[:, cols]).max())


def test_triple_block_solves_the_local_cone_problem_exactly():
    """The cone and its contact as one exactly solved block (:func:`_triple_solve`): on random Delassus blocks
    (symmetric positive definite, normal-tangential coupling up to 0.6, mu up to 1.5) every returned impulse
    satisfies the local law -- P_N >= 0, gamma_N >= 0, P_N gamma_N = 0, ||P_T|| <= mu P_N (+ preload), stick with
    gamma_T = 0 or slip with gamma_T = -alpha P_T, alpha >= 0."""
    from mshbm.integrators.local_problem import _triple_solve

    rng = np.random.default_rng(3)
    found = {"stick": 0, "slip": 0, "open": 0}
    for _ in range(400):
        L = rng.standard_normal((3, 3)) * 0.4 + np.eye(3)
        A = L @ L.T
        d = np.sqrt(np.diag(A))
        A[:2, 2] = A[2, :2] = np.clip(A[:2, 2], -0.6 * d[:2] * d[2], 0.6 * d[:2] * d[2])
        if np.min(np.linalg.eigvalsh(A)) <= 0.05:
            continue
        g = rng.standard_normal(3)
        mu, bT = rng.uniform(0.1, 1.5), rng.uniform(0.0, 0.3)
        p1, p2, pn, ok = _triple_solve(g[0], g[1], g[2], A[0, 0], A[0, 1], A[1, 1], A[0, 2], A[1, 2], A[2, 0], A[2, 1],
                                       A[2, 2], bT, mu, True)
        assert ok
        P = np.array([p1, p2, pn])
        gam = g + A @ P
        tol = 1e-9 * (1 + np.abs(g).max())
        b = bT + mu * pn
        assert pn >= 0 and gam[2] >= -tol and abs(pn * gam[2]) <= tol * (1 + pn)
        nT = np.hypot(p1, p2)
        assert nT <= b * (1 + 1e-12) + 1e-15
        if nT < b * (1 - 1e-9):
            assert np.hypot(gam[0], gam[1]) <= tol
            found["stick"] += 1
        else:
            cross = p1 * gam[1] - p2 * gam[0]
            assert abs(cross) <= tol * (1 + nT) and p1 * gam[0] + p2 * gam[1] <= tol * (1 + nT)
            found["slip" if pn > 0 else "open"] += 1
    assert min(found.values()) >= 20, found


def test_strong_normal_tangential_coupling_converges_in_one_block_sweep():
    """A mass coupling of the tangential and normal DOFs (D_TN / D_TT = 0.6) and mu = 2: the exact block solves
    each step's local problem in one sweep (2 to confirm; the scalar sweeps needed 36)."""
    mc, mu = 0.6, 2.0
    M = np.array([[1, 0, mc], [0, 1, 0], [mc, 0, 1.0]])
    K = np.array([[1.6, 0, -0.6], [0, 1, 0], [-0.6, 0, 2.6]])
    fh = np.zeros((3, 3))
    fh[1, 0], fh[2, 1], fh[0, 2] = 1, 1, 1
    S = System(M, 0.01 * M + 0.02 * K, K, fh, frictional_contact(0, 1, mu, normal=2))
    h = 2 * np.pi / W / 1024
    st = MoreauJean(M, S.C, K, list(S.elements), h, 0.5, True)
    tr = st.run(np.array([0.5, -0.8, 0.0]), np.array([0.3, 0.9, 0.0]),
                st.increments(S.forcing(np.linspace(0, 2 * np.pi / W, 1025), W)))
    assert tr.pgs_iterations <= 2
    assert np.all(np.hypot(tr.P[:, 0], tr.P[:, 1]) <= mu * tr.P[:, 2] * (1 + 1e-12))
    assert np.any((tr.status[:, 0] & 3) == kernels.STATUS_SLIP) and np.any(tr.P[:, 2] > 0)
    B = st.increments(S.forcing(np.linspace(0, 2 * np.pi / W, 1025), W))  # the NumPy twin (bisections)
    q, u, P = kernels.moreau_jean_numpy(np.array([0.5, -0.8, 0.0]), np.array([0.3, 0.9, 0.0]), st.Aq, st.Au, st.WG,
                                        st.Del, st.MinvG, B[:40], st.theta, st.h, st.kind, st.dof, st.sign, st.bound,
                                        st.gap, st.e, dof2=st.dof2, nsrc=st.nsrc, mu_n=st.mu_n, tpair=st.tpair)
    assert np.max(np.abs(q - tr.q[:41])) <= 1e-10 and np.max(np.abs(P - tr.P[:40])) <= 1e-12


# ----------------------------------------------------------------------------- refusals and input errors
def test_event_flow_refuses_with_the_element_named():
    with pytest.raises(InputError) as exc:
        mshbm.solve(oscillator(), W, "shooting", integrator="event", steps=256)
    assert exc.value.key == "friction.cone_partner" and "moreau" in str(exc.value)


def test_dlft_displacement_predictor_refuses():
    with pytest.raises(InputError) as exc:
        mshbm.solve(oscillator(), W, "dlft", harmonics=3, dlft_predictor="displacement")
    assert exc.value.key == "friction.cone_partner" and "velocity" in str(exc.value)


@pytest.mark.parametrize("els, what", [
    (lambda: [Friction(0, MU, N0, cone_partner=1), Friction(1, MU, N0)], "naming 0 back"),
    (lambda: [Friction(0, MU, N0, cone_partner=1), Friction(1, 2 * MU, N0, cone_partner=0)], "same mu"),
    (lambda: [Friction(0, MU, N0, cone_partner=5), Friction(1, MU, N0, cone_partner=0)], "no other element"),
])
def test_inconsistent_partners_are_input_errors(els, what):
    with pytest.raises(InputError) as exc:
        System(np.eye(2), np.zeros((2, 2)), np.eye(2), np.zeros((3, 2)), els())
    assert exc.value.key == "friction.cone_partner" and what in str(exc.value)


def test_case_file_cone_partner(tmp_path):
    S, _ = _cone3d()
    assert S.elements[0].cone_partner == 1 and S.elements[1].cone_partner == 0
    assert S.elements[0].normal_contact == 2
    bad = (ROOT / "examples" / "cone3d.yaml").read_text().replace("cone_partner: 0}", "cone_partner: 1}")
    p = tmp_path / "bad.yaml"
    p.write_text(bad)
    with pytest.raises(InputError) as exc:
        mshbm.load_case(p)
    assert "cone_partner" in exc.value.key
    # the second entry states only dof and cone_partner: it takes mu and normal_contact from its partner, so
    # one value (and a --set or a parameter sweep of friction.0.mu) sets the cone's
    p.write_text((ROOT / "examples" / "cone3d.yaml").read_text().replace("mu: 0.5", "mu: 0.4"))
    els = mshbm.load_case(p).system.elements
    assert els[0].mu == els[1].mu == 0.4 and els[1].normal_contact == 2
    p.write_text((ROOT / "examples" / "cone3d.yaml").read_text().replace("{dof: 1, cone_partner: 0}",
                                                                          "{dof: 1, cone_partner: 0, mu: 0.3}"))
    with pytest.raises(InputError) as exc:  # stated differently: refused
        mshbm.load_case(p)
    assert "same mu" in str(exc.value)


def test_cone_history_law_is_periodic_in_elliptic_partial_slip():
    """An elliptic relative motion in partial slip: the disk's return mapping forgets its start only
    geometrically (a slip phase removes the state's component along the slip direction and shrinks the other),
    so the law must march to the periodic state: one more period from the returned last sample reproduces every
    sample, and the derivative (through the periodic start's fixed point) equals central differences."""
    from mshbm import fourier
    from mshbm.elements.cone import cone_history_law

    el = jenkins_oscillator().elements[0]
    kt, bnd = el.tangential_stiffness, el.bound
    Ns = 256
    V = fourier.idft_matrix(Ns, 1)  # columns: 1, cos, sin
    c = np.zeros((3, 2))
    c[1, 0] = 1.3 * bnd / kt  # in-phase with cos in direction 1, a small ellipse axis along direction 2
    c[2, 1] = 0.3 * bnd / kt
    lam, D = cone_history_law(el, V @ c[:, 0], V @ c[:, 1], V)
    norm = np.hypot(lam[:, 0], lam[:, 1])
    assert np.any(norm >= bnd * (1 - 1e-12)) and np.any(norm < 0.99 * bnd)  # partial slip
    s = np.stack([V @ c[:, 0], V @ c[:, 1]], axis=1)
    prev, again = lam[-1], np.zeros_like(lam)
    for k in range(Ns):  # one more period of the return mapping from the returned state
        t = prev - kt * (s[k] - s[k - 1])
        nt = np.hypot(*t)
        prev = again[k] = t if nt <= bnd else bnd * t / nt
    assert np.max(np.abs(again - lam)) <= 1e-12 * bnd
    eps = 1e-9
    for b in range(2):
        for n in range(3):
            dc = np.zeros_like(c)
            dc[n, b] = eps
            lp = cone_history_law(el, *(V @ (c + dc)).T)[0]
            lm = cone_history_law(el, *(V @ (c - dc)).T)[0]
            assert np.max(np.abs((lp - lm) / (2 * eps) - D[:, :, b, n])) <= 1e-6 * kt


def test_jenkins_cone_with_normal_contact_exits_2_naming_the_key(tmp_path, capsys):
    """3-D Jenkins (tangential stiffness) whose normal load comes from a contact (a varying N, a normal preload on
    a contact): HBM refuses (its return mapping has a constant bound), the CLI exits 2 naming
    ``friction.normal_contact``; the other methods take it (``tests/unit/test_jenkins_normal_load.py``)."""
    import yaml

    from integration.test_io_cli import assert_input_error, run, write_case

    data = yaml.safe_load((ROOT / "examples" / "cone3d.yaml").read_text())
    for f in data["friction"]:
        f["tangential_stiffness"] = 5.0
    data["solver"] = {"method": "hbm", "harmonics": 5}
    code, out, err = run(capsys, "solve", write_case(tmp_path, data))
    assert_input_error(code, out, err, "friction.normal_contact")
