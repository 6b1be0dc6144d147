"""Polynomial springs (:class:`mshbm.Polynomial`): the law, the case file, the Moreau-Jean kernel (twin and
sensitivities), and the Duffing oscillator ``m x'' + c x' + k x + k3 x^3 = F cos(omega t)`` against closed
forms (linear limit, the single-harmonic frequency-amplitude relation and its folds) and across methods."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

import mshbm
from mshbm import Contact, Friction, InputError, Jenkins, Polynomial, chain
from mshbm.integrators import kernels
from mshbm.integrators.moreau_jean import MoreauJean

M_, C_, K_, K3, F_ = 1.0, 0.05, 1.0, 0.5, 0.1


def duffing(F=F_, k3=K3):
    return chain([M_], [K_], [C_], forcing=[{"dof": 0, "amplitude": F}], elements=[Polynomial(0, {3: k3})])


def amplitude_h1(sol):
    """``A = |first harmonic|`` of DOF 0."""
    qh = np.asarray(sol.q_hat)
    return float(np.hypot(qh[1, 0], qh[2, 0]))


def relation(A, omega, F=F_, k3=K3):
    """The single-harmonic frequency-amplitude relation ``((k - m w^2) A + 3/4 k3 A^3)^2 + (c w A)^2 - F^2``."""
    return ((K_ - M_ * omega ** 2) * A + 0.75 * k3 * A ** 3) ** 2 + (C_ * omega * A) ** 2 - F ** 2


# ------------------------------------------------------------------------------------------------ the element
def test_law_derivative_and_potential():
    el = Polynomial(0, {1: 2.0, 3: 0.5, 2: -0.3})
    assert el.coefficients == ((1, 2.0), (2, -0.3), (3, 0.5))
    s = np.linspace(-1.3, 1.7, 7)
    lam, dlam, dg = el.regularised_law(s, np.zeros_like(s))
    assert dg is None
    assert np.allclose(lam, -(2.0 * s - 0.3 * s ** 2 + 0.5 * s ** 3), rtol=0, atol=1e-15)
    assert np.allclose(dlam, -(2.0 - 0.6 * s + 1.5 * s ** 2), rtol=0, atol=1e-15)
    e = 1e-6  # lambda = -dV/ds
    assert np.allclose(-(el.potential(s + e) - el.potential(s - e)) / (2 * e), lam, rtol=0, atol=1e-9)
    assert el.scaled(4.0) is el and not el.bounded and not el.unilateral and el.smooth
    rel = Polynomial.cubic(2, 0.7, relative_to=0)
    assert rel.coefficients == ((3, 0.7),) and rel.dofs == (2, 0) and rel.direction == [(2, 1.0), (0, -1.0)]


@pytest.mark.parametrize("coefficients, key", [({0: 1.0}, "polynomial.coefficients"),
                                               ({3: float("nan")}, "polynomial.coefficients.3"),
                                               ({3: 0.0}, "polynomial.coefficients"),
                                               ("x", "polynomial.coefficients"),
                                               ({2.5: 1.0}, "polynomial.coefficients")])
def test_bad_coefficients_are_input_errors(coefficients, key):
    with pytest.raises(InputError) as exc:
        Polynomial(0, coefficients)
    assert exc.value.key == key


def test_case_file_sections(tmp_path):
    p = tmp_path / "duffing.yaml"
    p.write_text("masses: [1.0, 2.0]\nstiffness: [1.0, 1.0]\nomega: 1.0\nforcing: {dof: 1, amplitude: 0.1}\n"
                 "friction: {dof: 0, mu: 0.3, normal_force: 1.0}\n"
                 "polynomial: {dof: 1, relative_to: 0, coefficients: {2: 0.1, 3: 0.5}}\n"
                 "cubic: [{dof: 0, stiffness: 2.0}]\n")
    case = mshbm.load_case(p)
    els = case.system.elements
    assert [e.kind for e in els] == ["friction", "polynomial", "polynomial"]
    assert els[1] == Polynomial(1, {2: 0.1, 3: 0.5}, relative_to=0) and els[2] == Polynomial(0, {3: 2.0})
    # --set: a coefficient by its power, the cubic shorthand by its key
    case = mshbm.load_case(p, sets=["polynomial.0.coefficients.3=1.5", "polynomial.coefficients.5=0.25",
                                    "cubic.0.stiffness=3.0"])
    assert case.system.elements[1].coefficients == ((2, 0.1), (3, 1.5), (5, 0.25))
    assert case.system.elements[2].coefficients == ((3, 3.0),)
    with pytest.raises(InputError) as exc:
        mshbm.load_case(p, sets=["polynomial.0.coefficients.x=1"])
    assert exc.value.key == "polynomial.0.coefficients.x"
    with pytest.raises(InputError) as exc:
        mshbm.load_case(p, cubic=[{"dof": 0}])
    assert exc.value.key == "cubic[0].stiffness"
    with pytest.raises(InputError) as exc:
        mshbm.load_case(p, polynomial=[{"dof": 0, "coefficients": {3: "a"}}])
    assert exc.value.key == "polynomial[0].coefficients.3"
    with pytest.raises(InputError) as exc:
        mshbm.load_case(p, polynomial={"dof": 0, "coefficients": {3: 1.0}})  # DOF 0 has the cubic spring
    assert exc.value.key == "cubic[0].dof"


def test_event_flow_refuses_with_a_clear_error():
    with pytest.raises(InputError) as exc:
        mshbm.solve(duffing(), 1.2, method="shooting", integrator="event")
    assert exc.value.key == "polynomial.dof" and "moreau" in str(exc.value)


# ------------------------------------------------------------------------------------------------ the kernel
CASES = {
    "scalar": (1, [Polynomial(0, {3: 2.0, 2: 0.5})]),
    "with_friction_contact": (4, [Friction(0, 0.3, 1.0), Contact(1, 0.25, 0.8), Polynomial(2, {3: 3.0}),
                                  Polynomial(3, {1: 0.5, 3: 1.0}, relative_to=1)]),
    "relative_first": (4, [Polynomial(3, {3: 2.0}, relative_to=0), Friction(3, 0.2, 1.0, relative_to=1)]),
    "with_jenkins": (4, [Jenkins(0, 0.5, 1.0, tangential_stiffness=20.0), Polynomial(0, {3: 2.0}),
                         Polynomial(2, {2: 0.1, 3: 1.0}, relative_to=1)]),  # a massless slider DOF appended
}


def _setup(name, N=600, theta=0.5):
    n, els = CASES[name]
    sys = chain([1.0, 2.0, 1.0, 1.5][:n], 1.0, 0.05, forcing=[{"dof": n - 1, "amplitude": 3.0 if n > 1 else 0.5}],
                elements=els)
    omega = 0.8
    h = 2 * np.pi / omega / N
    st = MoreauJean(sys.M, sys.C, sys.K, sys.elements, h, theta)
    B = st.increments(sys.forcing(np.arange(N + 1) * h, omega))
    q0, u0 = st.with_slider_state(np.array([0.1, -0.2, 0.05, 0.0])[:n], np.array([0.5, 0.0, -0.3, 0.2])[:n])
    return sys, st, B, q0, u0


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("theta", [0.5, 0.75])
def test_kernel_matches_numpy_twin(name, theta):
    sys, st, B, q0, u0 = _setup(name, theta=theta)
    tr = st.run(q0, u0, B)
    q, u, P = kernels.moreau_jean_numpy(q0, u0, st.Aq, st.Au, st.WG, st.Del, st.MinvG, B, st.theta, st.h,
                                        st.kind, st.dof, st.sign, st.bound, st.gap, st.e, dof2=st.dof2,
                                        n_slider=st.n - st.n_structure, poly=st.poly)
    smooth = st.kind == kernels.KIND_SMOOTH
    assert np.all(np.abs(P[:, smooth]).max(axis=0) > 0)
    assert np.allclose(tr.q, q, rtol=0, atol=1e-11) and np.allclose(tr.u, u, rtol=0, atol=1e-11)
    assert np.allclose(tr.P, P, rtol=0, atol=1e-11)
    # the smooth impulse is h lambda(w^T q_M), q_M = q + h/2 u at the start of the step
    for j in np.flatnonzero(smooth):
        el = sys.elements[j]
        s_mid = el.local((tr.q[:-1] + 0.5 * st.h * tr.u[:-1])[:, :st.n_structure])
        assert np.allclose(tr.P[:, j], st.h * el.law(s_mid)[0], rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("name", list(CASES))
def test_sensitivities_match_finite_differences(name):
    sys, st, B, q0, u0 = _setup(name, N=300)
    n = st.n
    tr = st.run(q0, u0, B, sensitivities=True)
    Phi = np.vstack([tr.Sq, tr.Su])
    x = np.concatenate([q0, u0])
    d, worst, used = 1e-7, 0.0, 0
    for i in range(2 * n):
        xp, xm = x.copy(), x.copy()
        xp[i] += d
        xm[i] -= d
        tp, tm = st.run(xp[:n], xp[n:], B), st.run(xm[:n], xm[n:], B)
        if not (np.array_equal(tp.status, tr.status) and np.array_equal(tm.status, tr.status)):
            continue  # an active-set change: the difference quotient is not the derivative
        fd = (np.concatenate([tp.q[-1], tp.u[-1]]) - np.concatenate([tm.q[-1], tm.u[-1]])) / (2 * d)
        worst = max(worst, float(np.abs(fd - Phi[:, i]).max()) / float(np.abs(Phi).max()))
        used += 1
    assert used >= n and worst < 1e-6
    with pytest.raises(ValueError, match="polynomial spring"):
        st.monodromy(tr.status, tr.P)


# ------------------------------------------------------------------------------------------------ Duffing
def test_small_amplitude_is_the_linear_response():
    F, omega = 1e-4, 1.2
    sol = mshbm.solve(duffing(F=F), omega, method="hbm", harmonics=5, stability=False)
    A_lin = F / np.hypot(K_ - M_ * omega ** 2, C_ * omega)
    assert sol.success
    # relative deviation of the cubic term: ~ 3/4 k3 A^2 / |k - m w^2| = 6e-8
    assert abs(amplitude_h1(sol) - A_lin) / A_lin < 3e-7
    assert abs(amplitude_h1(sol) - A_lin) / A_lin > 1e-9  # and it is there


@pytest.mark.parametrize("omega", [0.9, 1.2, 1.5])
def test_single_harmonic_hbm_is_the_classical_relation(omega):
    sol = mshbm.solve(duffing(), omega, method="hbm", harmonics=1, steps=16, stability=False)
    assert sol.success
    A = amplitude_h1(sol)
    assert abs(relation(A, omega)) / F_ ** 2 < 1e-9
    A_lin = F_ / np.hypot(K_ - M_ * omega ** 2, C_ * omega)
    assert abs(A - A_lin) / A_lin > 1e-3  # the cubic term matters here


def test_shooting_and_hbm_agree_with_an_independent_transient():
    omega = 1.2
    hbm = mshbm.solve(duffing(), omega, method="hbm", harmonics=25, stability=False)
    sh = mshbm.solve(duffing(), omega, method="shooting", steps=20000, stability=False)
    assert hbm.success and sh.success
    # independent reference: scipy's RK from HBM's state at t = 0 returns to it after one period
    T = 2 * np.pi / omega
    rhs = lambda t, y: [y[1], (F_ * np.cos(omega * t) - C_ * y[1] - K_ * y[0] - K3 * y[0] ** 3) / M_]
    y0 = [hbm.q[0, 0], hbm.u[0, 0]]
    end = solve_ivp(rhs, (0.0, T), y0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    A = float(hbm.amplitude[0])
    assert np.abs(end - y0).max() < 1e-9 * max(A, A * omega)
    # Moreau-Jean's midpoint scheme is second order: 20000 steps per period agree to 1e-6
    assert abs(float(sh.amplitude[0]) - A) / A < 1e-6
    assert np.abs(sh.q[0] - hbm.q[0]).max() / A < 1e-6


def test_hardening_folds_located_by_the_sweep():
    br = mshbm.sweep(duffing(), 0.8, 1.8, method="hbm", harmonics=1, steps=16, stability=False)
    found = sorted((b["omega"], b["index"]) for b in br.bifurcations if b["type"] == "fold")
    assert len(found) == 2
    folds = [w for w, _ in found]
    # closed form of the single-harmonic relation: G(A, w) = 0 and dG/dA = 0
    dG = lambda A, w: 2 * ((K_ - M_ * w * w) * A + 0.75 * K3 * A ** 3) * ((K_ - M_ * w * w) + 2.25 * K3 * A ** 2) \
        + 2 * (C_ * w) ** 2 * A
    exact = []
    for w0, i in found:
        A0 = amplitude_h1(br.points[i].solution)
        A, w = fsolve(lambda z: [relation(z[0], z[1]) / F_ ** 2, dG(z[0], z[1]) / F_ ** 2], [A0, w0], xtol=1e-12)
        assert abs(relation(A, w)) < 1e-12
        exact.append(w)
    exact = sorted(exact)
    assert np.allclose(folds, exact, rtol=1e-7, atol=0)
    assert exact[0] < 1.2 < exact[1]  # the bistable band of the hardening branch
    # with 7 harmonics the folds move by the higher harmonics' share (third harmonic ~ k3 A^3 / 32)
    br7 = mshbm.sweep(duffing(), 0.8, 1.8, method="hbm", harmonics=7, stability=False)
    folds7 = sorted(b["omega"] for b in br7.bifurcations if b["type"] == "fold")
    assert len(folds7) == 2 and np.allclose(folds7, exact, rtol=5e-3, atol=0)


# ------------------------------------------------------------------------------------------------ with elements
def _acc(sol):
    return next(c.value for c in sol.certificate.checks if c.name == "accuracy")


def test_with_friction_ms_hbm_agrees_with_shooting():
    """Cubic springs to the ground and between the friction DOF and its neighbour; DOF 2 is linear (condensed
    in MS-HBM).  The friction sticks and slips; every time-domain method and DLFT agree."""
    els = [Friction(0, 0.3, 1.5), Polynomial(0, {3: 0.8}), Polynomial(1, {3: 0.3}, relative_to=0)]
    sys = chain([1.0, 1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 2, "amplitude": 0.5}], elements=els)
    omega, N = 1.0, 4000
    sh = mshbm.solve(sys, omega, method="shooting", steps=N, stability=False)
    ms = mshbm.solve(sys, omega, method="mshbm", harmonics=10, steps=N, stability=False)
    mi = mshbm.solve(sys, omega, method="mshbm-intermediate", harmonics=10, steps=N, stability=False)
    assert sh.success and ms.success and mi.success, (sh.message, ms.message, mi.message)
    assert 0.05 < sh.elements[0].stick_fraction < 0.95  # the friction sticks and slips
    A = np.asarray(sh.amplitude)
    for s in (ms, mi):  # measured 1.9e-6: stick-slip transitions on the grid, the condensed linear DOF's harmonics
        diff = np.abs(np.asarray(s.amplitude) - A).max() / A.max()
        assert diff <= _acc(sh) + _acc(s) and diff < 5e-6
    dl = mshbm.solve(sys, omega, method="dlft", harmonics=30, stability=False)  # set-valued, truncated series
    assert np.abs(np.asarray(dl.amplitude) - A).max() / A.max() < 2e-2
    for s in (sh, ms, mi, dl):
        law = next(c for c in s.certificate.checks if c.name == "spring_law")
        assert law.passed and law.value < 1e-12


def test_with_a_contact_ms_hbm_agrees_with_shooting_within_the_estimates():
    """Impacts on DOF 1 with cubic springs: MS-HBM (both variants) and shooting agree within the sum of their
    own accuracy estimates (time discretisation of the impacts, truncation)."""
    els = [Contact(1, 0.074, 1.0), Polynomial(1, {3: 0.3}, relative_to=0), Polynomial(0, {3: 0.5})]
    sys = chain([1.0, 1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 2, "amplitude": 0.3}], elements=els)
    omega, N = 1.6, 4000
    sh = mshbm.solve(sys, omega, method="shooting", steps=N, stability=False)
    assert sh.success and np.asarray(sh.impulses)[:, 0].max() > 0  # impacts
    A = np.asarray(sh.amplitude)
    for method in ("mshbm", "mshbm-intermediate"):
        s = mshbm.solve(sys, omega, method=method, harmonics=20, steps=N, stability=False)
        assert s.success, s.message
        diff = np.abs(np.asarray(s.amplitude) - A).max() / A.max()  # measured 1.6e-4
        assert diff <= _acc(sh) + _acc(s)
        assert diff < 1e-3


def test_regularisation_estimate_is_zero_for_the_spring():
    """The spring is exact in HBM: the stiffened law is the same element, and its distance from the
    set-valued law is nothing (only the friction contributes)."""
    from mshbm.methods.hbm_regularisation import law_distance, regularised

    el = Polynomial(0, {3: 0.8})
    assert el.scaled(4.0) is el and not regularised(duffing())
    sys = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 0.5}], elements=[el])
    sol = mshbm.solve(sys, 1.0, method="hbm", harmonics=7, stability=False)
    assert sol.success and law_distance(sys, sol) == 0.0
    assert all(c.name != "regularisation" for c in sol.certificate.checks)
    work = next(c for c in sol.certificate.checks if c.name == "spring_work")
    assert work.gating and work.value < 1e-12


def test_ms_hbm_blocks_with_springs_agree_with_shooting():
    """Springs on DOFs the linear DOF 1 separates: MS-HBM integrates the subsystem as independent blocks
    (:func:`mshbm.integrators.subsystem._blocks`), and agrees with shooting (measured 2.0e-6)."""
    from mshbm.integrators.subsystem import _blocks

    els = [Friction(0, 0.3, 1.5), Polynomial(0, {3: 0.8}), Polynomial(2, {3: 0.5}),
           Polynomial(4, {3: 0.3}, relative_to=3)]
    sys = chain([1.0] * 5, 1.0, 0.05, forcing=[{"dof": 4, "amplitude": 0.5}], elements=els)
    d = np.array([0, 2, 3, 4])
    sub = lambda A: np.asarray(A)[np.ix_(d, d)]
    parts = _blocks(sub(sys.M), sub(sys.C), sub(sys.K), [e.renumbered({0: 0, 2: 1, 3: 2, 4: 3}) for e in els])
    assert [p[1].tolist() for p in parts] == [[0, 1], [2, 3]]
    sh = mshbm.solve(sys, 1.0, method="shooting", steps=4000, stability=False)
    ms = mshbm.solve(sys, 1.0, method="mshbm", harmonics=10, steps=4000, stability=False)
    assert sh.success and ms.success and list(ms.time_dofs) == [0, 2, 3, 4]
    diff = np.abs(ms.amplitude - sh.amplitude).max() / sh.amplitude.max()
    assert diff <= _acc(sh) + _acc(ms) and diff < 5e-6


def test_dlft_is_hbm_for_the_spring_alone():
    """No Lagrangian term: DLFT's residual is HBM's (AFT of the same exact law)."""
    hbm = mshbm.solve(duffing(), 1.2, method="hbm", harmonics=9, stability=False)
    dl = mshbm.solve(duffing(), 1.2, method="dlft", harmonics=9, stability=False)
    assert hbm.success and dl.success
    assert np.abs(np.asarray(dl.q_hat) - np.asarray(hbm.q_hat)).max() < 1e-12 * float(hbm.amplitude[0])


@pytest.mark.parametrize("predictor", ["velocity", "displacement"])
@pytest.mark.parametrize("condense", [True, False])
def test_dlft_jacobian_with_springs_matches_differences(predictor, condense):
    """The smooth forces enter the force the linear part demands of the Lagrangian elements on the same DOF:
    the exact Jacobian against central differences (a spring first in the element list, relative springs)."""
    from mshbm.methods.dlft import DLFTProblem

    els = [Polynomial(1, {3: 0.3, 2: 0.2}, relative_to=0), Friction(0, 0.3, 1.0), Contact(1, 0.2),
           Polynomial(0, {3: 0.8})]
    sys = chain([1.0, 1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 2, "amplitude": 0.3}], elements=els)
    p = DLFTProblem(sys, 1.0, 5, 64, condense=condense, dlft_predictor=predictor)
    x = p.initial_guess() + 0.2 * np.random.default_rng(0).standard_normal(p.n_unknowns)
    R, J = p.residual(x)
    J = J.toarray() if hasattr(J, "toarray") else J
    d = 1e-7
    fd = np.column_stack([(p.residual(x + d * e, jac=False)[0] - p.residual(x - d * e, jac=False)[0]) / (2 * d)
                          for e in np.eye(x.size)])
    assert np.abs(J - fd).max() / np.abs(J).max() < 1e-8
    lam = p.solution_parts(x)["lam"]
    s = els[0].local(p.Vs @ p.full_coefficients(x))  # w^T q on the AFT samples
    assert np.allclose(lam[:-1, 0], els[0].law(s)[0], rtol=0, atol=1e-12)


def test_backbone_is_the_single_harmonic_one():
    """EPMC on the undamped Duffing oscillator at n_h = 1: omega^2 = (k + 3/4 k3 a^2) / m (m = 1: the modal
    amplitude is the amplitude), damping ratio 0 (the spring is conservative)."""
    sys = chain([M_], [K_], [0.0], elements=[Polynomial(0, {3: K3})])
    bb = mshbm.backbone(sys, 0.01, 1.0, method="hbm", harmonics=1, steps=16)
    a, w = np.asarray(bb.modal_amplitude), np.asarray(bb.omega)
    assert a.size > 10 and a.max() >= 1.0 - 1e-9
    assert np.abs(w ** 2 - (K_ + 0.75 * K3 * a ** 2) / M_).max() < 1e-9
    assert np.abs(np.asarray(bb.damping_ratio)).max() < 1e-12


def test_stability_of_the_three_coexisting_orbits():
    """Inside the fold band the hardening Duffing oscillator has three orbits (roots of the single-harmonic
    relation, a cubic in A^2): the middle one a saddle.  The multipliers come from the Moreau-Jean step map
    (forward sensitivities through the spring); Liouville: mu_1 mu_2 = exp(-c T / m), so a stable orbit's
    complex pair has |mu| = exp(-c T / (2 m))."""
    omega = 1.25
    a, b = K_ - M_ * omega ** 2, 0.75 * K3
    X = np.roots([b * b, 2 * a * b, a * a + (C_ * omega) ** 2, -F_ ** 2])
    amps = np.sqrt(np.sort(X[np.abs(X.imag) < 1e-12].real))
    assert amps.size == 3
    liouville = np.exp(-C_ * 2 * np.pi / omega / M_)
    for i, A in enumerate(amps):
        phi = np.arctan2(C_ * omega, a + b * A * A)
        qh = np.zeros((3, 1))
        qh[1, 0], qh[2, 0] = A * np.cos(phi), A * np.sin(phi)
        sol = mshbm.solve(duffing(), omega, method="hbm", harmonics=5, guess={"q_hat": qh})
        assert sol.success and abs(float(sol.amplitude[0]) - A) / A < 2e-2  # the branch the guess is on
        mu = np.asarray(sol.floquet_multipliers)
        assert abs(np.prod(mu).real - liouville) < 1e-4 * liouville
        if i == 1:
            assert sol.stable is False and np.max(np.abs(mu)) > 1.2
        else:
            assert sol.stable is True and abs(np.max(np.abs(mu)) - np.sqrt(liouville)) < 1e-4


# ------------------------------------------------------------------------------- with base excitation
@pytest.mark.parametrize("omega", [0.9, 1.3])
def test_duffing_on_a_shaker_table_is_the_forced_duffing(omega):
    """A mass on a shaker table (DOF 1, x_b = Y cos wt) through a linear spring, a damper and a cubic spring
    (relative_to the table): relative to the table, m z'' + c z' + k z + k3 z^3 = m w^2 Y cos wt, so HBM at
    n_H = 1 satisfies the single-harmonic relation with F = m w^2 Y to 1e-9, and Moreau-Jean shooting agrees
    with HBM at n_H = 25 to 1e-5 (its second-order step error at 8000 steps)."""
    from mshbm.support import base_excitation

    Y = F_ / (M_ * omega ** 2)
    K = np.array([[K_, -K_], [-K_, K_]])
    C = np.array([[C_, -C_], [-C_, C_]])
    M = np.diag([M_, 3.0])
    s = base_excitation(M, C, K, [1], np.array([0.0, Y, 0.0]), elements=[Polynomial(0, {3: K3}, relative_to=1)])
    assert s.base.frame == "relative"
    h1 = mshbm.solve(s, omega, method="hbm", harmonics=1, steps=16, stability=False)
    assert h1.success
    assert abs(relation(amplitude_h1(h1), omega)) / F_ ** 2 < 1e-9
    h25 = mshbm.solve(s, omega, method="hbm", harmonics=25, stability=False)
    sh = mshbm.solve(s, omega, method="shooting", steps=8000, stability=False)
    assert h25.success and sh.success
    A = float(h25.amplitude[0])
    assert abs(float(sh.amplitude[0]) - A) / A < 1e-5


@pytest.mark.parametrize("spring_first", [False, True])
def test_kernel_matches_numpy_twin_with_a_cone_and_its_contact(spring_first):
    """A 3-D frictional contact (cone pair on DOFs 0, 1 loaded by a contact on DOF 2) and cubic springs, in
    either order of the element list: the compiled kernel equals its NumPy twin to 1e-11, the cone holds at
    every step (||P_T|| <= mu (h N_0 + P_N)) and the springs' impulses are h lambda(w^T q_M)."""
    from mshbm import frictional_contact

    springs = [Polynomial(3, {3: 2.0}), Polynomial(2, {3: 1.0}, relative_to=3)]
    first = len(springs) if spring_first else 0
    cone = frictional_contact(0, 1, 0.4, 0.2, normal=2, gap=0.05, restitution=0.5, first=first)
    els = springs + cone if spring_first else cone + springs
    sys = chain([1.0, 2.0, 1.0, 1.5], 1.0, 0.05, forcing=[{"dof": 0, "amplitude": 2.0},
                                                          {"dof": 1, "sin": 2.0}, {"dof": 3, "amplitude": 1.0}],
                elements=els)
    omega, N = 0.8, 600
    h = 2 * np.pi / omega / N
    st = MoreauJean(sys.M, sys.C, sys.K, sys.elements, h, 0.5)
    B = st.increments(sys.forcing(np.arange(N + 1) * h, omega))
    q0, u0 = np.array([0.1, -0.2, 0.05, 0.0]), np.array([0.5, 0.0, -0.3, 0.2])
    tr = st.run(q0, u0, B)
    q, u, P = kernels.moreau_jean_numpy(q0, u0, st.Aq, st.Au, st.WG, st.Del, st.MinvG, B, st.theta, st.h,
                                        st.kind, st.dof, st.sign, st.bound, st.gap, st.e, dof2=st.dof2,
                                        nsrc=st.nsrc, mu_n=st.mu_n, tpair=st.tpair, poly=st.poly)
    assert np.allclose(tr.q, q, rtol=0, atol=1e-11) and np.allclose(tr.u, u, rtol=0, atol=1e-11)
    assert np.allclose(tr.P, P, rtol=0, atol=1e-11)
    j1, j2, c = first, first + 1, first + 2
    assert np.max(P[:, c]) > 0 and np.max(np.hypot(P[:, j1], P[:, j2])) > 0  # the contact and the cone act
    assert np.all(np.hypot(P[:, j1], P[:, j2]) <= 0.4 * (h * 0.2 + P[:, c]) * (1 + 1e-12) + 1e-15)
    for j in np.flatnonzero(st.kind == kernels.KIND_SMOOTH):
        s_mid = sys.elements[j].local(tr.q[:-1] + 0.5 * h * tr.u[:-1])
        assert np.allclose(tr.P[:, j], h * sys.elements[j].law(s_mid)[0], rtol=1e-13, atol=1e-15)
