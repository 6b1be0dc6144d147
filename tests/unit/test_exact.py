"""Exact event-driven periodic reference (mshbm.methods.exact)."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mshbm
from mshbm import Contact, Friction, InputError, chain
from mshbm.methods.exact import ExactFlow
from mshbm.methods.exact import exact_periodic

from paper_systems import NORMAL_FORCE, OMEGA, friction_chain, impact_chain

BOUND = 0.8 * NORMAL_FORCE


@pytest.fixture(scope="module")
def fric3():
    sys = friction_chain(3)
    guess = mshbm.solve(sys, OMEGA, "shooting", steps=4096)
    ex = exact_periodic(sys, OMEGA, guess)
    assert ex.success, ex.message
    return sys, ex


@pytest.fixture(scope="module")
def imp5():
    sys = impact_chain(5)
    guess = mshbm.solve(sys, OMEGA, "shooting", steps=4096)
    ex = exact_periodic(sys, OMEGA, guess)
    assert ex.success, ex.message
    return sys, ex


# ----------------------------------------------------------------------------- 1. linear sanity
@pytest.mark.parametrize("damping", [0.0, [0.1, 0.05, 0.2]])
def test_inactive_element_gives_frequency_response(damping):
    omega = 0.9
    sys = chain([1.0, 2.0, 1.5], [1.0, 2.0, 0.5], damping,
                forcing=[{"dof": 2, "amplitude": 5.0}, {"dof": 0, "amplitude": 1.0, "sin": 0.5, "harmonic": 2},
                         {"dof": 1, "constant": 0.3}],
                elements=[Contact(0, 1e6, 1.0)])
    exact = np.zeros((7, 3))
    exact[0] = np.linalg.solve(sys.K, sys.f_hat[0])
    for k in (1, 2):
        F = sys.f_hat[2 * k - 1] - 1j * sys.f_hat[2 * k]
        X = np.linalg.solve(sys.K - (k * omega) ** 2 * sys.M + 1j * k * omega * sys.C, F)
        exact[2 * k - 1], exact[2 * k] = X.real, -X.imag
    ex = exact_periodic(sys, omega, None, samples=512, harmonics=3)
    assert ex.success, ex.message
    assert ex.info["n_events"] == 0
    scale = np.abs(exact).max()
    assert np.abs(ex.q_hat - exact).max() <= 1e-10 * scale
    t = ex.t
    V = mshbm.fourier.basis(t, omega, 3)
    assert np.abs(ex.q - V @ exact).max() <= 1e-10 * scale
    assert np.abs(ex.u - V @ mshbm.fourier.derivative(exact, omega)).max() <= 1e-10 * scale
    # true extrema of the Fourier series on a very fine grid
    tf = np.linspace(0, 2 * np.pi / omega, 200001)
    qf = mshbm.fourier.basis(tf, omega, 3) @ exact
    assert np.allclose(ex.info["amplitude_exact"], 0.5 * (qf.max(0) - qf.min(0)), rtol=1e-9, atol=0)


# ----------------------------------------------------------------------------- 2. bouncing oscillator
def test_bouncing_oscillator_analytic():
    """q'' + q = 0 against a wall at q = gap (e = 1): arcs of -A cos(t - t_c) between impacts.

    One impact per period T requires 2 (pi - theta) = T with cos(theta) = gap / A.
    """
    gap, omega = 0.3, 1.3
    T = 2 * np.pi / omega
    theta = np.pi - T / 2
    A = gap / np.cos(theta)
    v_imp = A * np.sin(theta)
    sys = chain([1.0], 1.0, 0.0, elements=[Contact(0, gap, 1.0)])
    guess = {"q0": [-A * 1.001], "u0": [2e-3], "t0": 1.0}  # near the lowest point, wrong amplitude
    ex = exact_periodic(sys, omega, guess, samples=2048)
    assert ex.success, ex.message
    assert ex.info["n_impacts"] == 1
    imp = ex.info["events"][0]
    assert abs(imp.velocity + v_imp) <= 1e-10 * v_imp  # gamma_N = w^T u = -u before the impact
    assert abs(imp.impulse - 2 * v_imp) <= 1e-10 * v_imp
    assert abs(ex.info["amplitude_exact"][0] - 0.5 * (gap + A)) <= 1e-10 * A
    assert abs(ex.info["q_max"][0] - gap) <= 1e-12 and abs(ex.info["q_min"][0] + A) <= 1e-10 * A
    t_c = imp.t + T / 2  # lowest point half a period after the impact
    phase = np.mod(ex.t - t_c + T / 2, T) - T / 2  # in [-T/2, T/2)
    assert np.abs(ex.q[:, 0] + A * np.cos(phase)).max() <= 1e-10 * A
    inner = np.abs(np.abs(phase) - T / 2) > 1e-9  # away from the velocity jump
    assert np.abs(ex.u[inner, 0] - A * np.sin(phase[inner])).max() <= 1e-10 * A


# ----------------------------------------------------------------------------- exact flow checks
def test_saltation_monodromy_matches_finite_differences(fric3, imp5):
    for sys, ex in (fric3, imp5):
        n = sys.n
        fl = ExactFlow(sys, OMEGA)
        ts, x = ex.info["section_time"], ex.info["state_at_section"]
        z0 = np.concatenate([x, fl.osc(ts)])
        Phi = fl.simulate(ts, z0, jac=True).monodromy[:2 * n]
        F = np.empty_like(Phi)
        for i in range(2 * n):
            zp, zm = z0.copy(), z0.copy()
            zp[i] += 1e-6
            zm[i] -= 1e-6
            F[:, i] = (fl.simulate(ts, zp).end_state[:2 * n] - fl.simulate(ts, zm).end_state[:2 * n]) / 2e-6
        assert np.abs(Phi - F).max() <= 1e-6 * np.abs(Phi).max()


def test_flow_agrees_with_independent_integration(fric3, imp5):
    """One slip phase (friction) and one flight (impact) with DOP853 at tight tolerances."""
    # friction: stick->slip+ to slip+->stick
    sys, ex = fric3
    n, M, K = sys.n, sys.M, sys.K
    ev = ex.info["events"]
    i = next(k for k, e in enumerate(ev) if e.kind == "stick->slip+")
    t0, t1 = ev[i].t, ev[i + 1].t
    assert ev[i + 1].kind == "slip+->stick"
    q0, u0, _ = ex.info["trajectory"].evaluate(t0)

    def rhs(t, y, lam):
        f = sys.forcing(t, OMEGA)[0].copy()
        f[0] += lam
        return np.concatenate([y[n:], np.linalg.solve(M, f - K @ y[:n] - sys.C @ y[n:])])

    stop = lambda t, y, lam: y[n] if t > t0 + 1e-3 else 1.0
    stop.terminal, stop.direction = True, -1
    sol = solve_ivp(rhs, (t0, t0 + 10), np.concatenate([q0[0], u0[0]]), "DOP853", args=(-BOUND,),
                    events=stop, rtol=1e-13, atol=1e-13)
    assert abs(sol.t_events[0][0] - t1) <= 1e-8
    q1, _, _ = ex.info["trajectory"].evaluate(t1)
    assert np.abs(sol.y_events[0][0][:n] - q1[0]).max() <= 1e-8
    # impact: from just after the impact around the period to the next impact
    sys, ex = imp5
    n, M, K = sys.n, sys.M, sys.K
    t_imp = ex.info["events"][0].t
    T = 2 * np.pi / OMEGA
    q0, u0, _ = ex.info["trajectory"].evaluate(t_imp)  # state after the impact
    hit = lambda t, y, lam: 0.1 - y[0] if t > t_imp + 1e-3 else 1.0
    hit.terminal, hit.direction = True, -1
    sol = solve_ivp(rhs, (t_imp, t_imp + 2 * T), np.concatenate([q0[0], u0[0]]), "DOP853", args=(0.0,),
                    events=hit, rtol=1e-13, atol=1e-13)
    assert abs(sol.t_events[0][0] - (t_imp + T)) <= 1e-8
    qm, _, _ = ex.info["trajectory"].evaluate(t_imp - 1e-9)  # just before the impact
    assert np.abs(sol.y_events[0][0][:n] - qm[0]).max() <= 1e-7


# ----------------------------------------------------------------------------- 3. Moreau-Jean / MS-HBM convergence
@pytest.mark.parametrize("case", ["fric3", "imp5"])
def test_moreau_jean_and_mshbm_converge_to_exact(case, request):
    sys, ex = request.getfixturevalue(case)
    ref = ex.info["amplitude_exact"][[0, -1]]
    errs = []
    for N in (1024, 4096, 16384):
        s = mshbm.solve(sys, OMEGA, "shooting", steps=N)
        assert s.success, s.message
        errs.append(np.max(np.abs(s.amplitude[[0, -1]] - ref) / ref))
    # measured (omega = pi/5): friction3 4.0e-5, 2.1e-6, 1.4e-7; impact5 9.4e-3, 3.5e-3, 4.8e-4
    assert errs[0] > errs[1] > errs[2], errs
    assert errs[2] < 1e-3, errs
    s = mshbm.solve(sys, OMEGA, "mshbm", harmonics=9, steps=16384, guess=ex)
    assert s.success, s.message
    err = np.abs(s.amplitude[[0, -1]] - ref) / ref
    assert np.all(err < 1e-2), err


# ----------------------------------------------------------------------------- 4. friction invariants
def test_friction_invariants(fric3):
    sys, ex = fric3
    lam, u1, q1 = ex.lam[:, 0], ex.u[:, 0], ex.q[:, 0]
    assert np.all(np.abs(lam) <= BOUND * (1 + 1e-12))
    ev = ex.info["events"]
    kinds = [e.kind for e in ev]
    assert kinds == ["stick->slip+", "slip+->stick", "stick->slip-", "slip-->stick"]
    T = ex.period
    bounds = [e.t for e in ev] + [ev[0].t + T]
    for k, e in enumerate(ev):
        a, b = bounds[k], bounds[k + 1]
        inside = (np.mod(ex.t - a, T) > 1e-9) & (np.mod(ex.t - a, T) < b - a - 1e-9)
        assert inside.sum() > 10
        new = e.kind.split("->")[1]
        if new == "stick":
            assert np.all(u1[inside] == 0.0)
            assert np.ptp(q1[inside]) == 0.0
            assert np.all(np.abs(lam[inside]) < BOUND)
        else:
            sgn = 1.0 if new == "slip+" else -1.0
            assert np.all(sgn * u1[inside] > 0.0)
            assert np.all(lam[inside] == -sgn * BOUND)
    # the stick ends exactly when the required stick force reaches the friction bound
    for e in ev:
        if e.kind.startswith("stick->"):
            _, _, lam_before = ex.info["trajectory"].evaluate(e.t - 1e-7)
            assert abs(abs(lam_before[0]) - BOUND) <= 1e-6
    assert 0.0 < ex.info["stick_fraction"] < 1.0


# ----------------------------------------------------------------------------- 5. energy balance
def test_energy_balance_friction(fric3):
    """c = 0: external work over one period = friction dissipation = mu F_N * slip distance."""
    sys, ex = fric3
    T = ex.period
    tr = ex.info["trajectory"]
    cuts = np.concatenate([[0.0], [e.t for e in ex.info["events"]], [T]])
    x, w = np.polynomial.legendre.leggauss(40)
    W_ext = D_fric = 0.0
    for a, b in zip(cuts[:-1], cuts[1:]):
        for sa, sb in zip(np.linspace(a, b, 5)[:-1], np.linspace(a, b, 5)[1:]):
            tt = 0.5 * (sb - sa) * x + 0.5 * (sa + sb)
            q, u, lam = tr.evaluate(tt)
            f = sys.forcing(tt, OMEGA)
            W_ext += 0.5 * (sb - sa) * np.sum(w * np.sum(f * u, axis=1))
            D_fric += 0.5 * (sb - sa) * np.sum(w * (-lam * u[:, 0]))
    slip = 0.0
    ev = ex.info["events"]
    for k, e in enumerate(ev):
        if e.kind.startswith("stick->"):
            q_a, _, _ = tr.evaluate(e.t)
            q_b, _, _ = tr.evaluate(ev[(k + 1) % len(ev)].t)
            slip += abs(q_b[0, 0] - q_a[0, 0])
    assert W_ext > 0
    assert abs(W_ext - D_fric) <= 1e-8 * W_ext
    assert abs(BOUND * slip - W_ext) <= 1e-8 * W_ext


# ----------------------------------------------------------------------------- failures and inputs
def test_unsupported_and_failures(imp5):
    sys, ex = imp5
    # several elements are supported (tests/unit/test_event_integrator.py); relative elements are not
    two = chain([1.0, 1.0], 1.0, 0.0, forcing=[{"dof": 1, "amplitude": 1.0}],
                elements=[Friction(0, 0.5, 1.0, relative_to=1), Contact(1, 0.1)])
    with pytest.raises(InputError) as err:
        exact_periodic(two, OMEGA)
    assert err.value.key == "friction.relative_to"
    bad = exact_periodic(sys, OMEGA, ex, max_events=0)
    assert not bad.success and "events in one period" in bad.message


def test_plastic_impact_persistent_contact():
    """e = 0: the mass is pressed against the wall for part of the period (closed contact)."""
    sys = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0, "constant": 0.2}],
                elements=[Contact(0, 0.3, 0.0)])
    ex = exact_periodic(sys, 1.0, None, samples=1024)
    assert ex.success, ex.message
    assert np.all(ex.q[:, 0] <= 0.3 + 1e-12)
    assert np.all(ex.lam[:, 0] >= -1e-12)
    assert 0.0 < ex.info["stick_fraction"] < 1.0
    kinds = {e.kind for e in ex.info["events"]}
    assert "free->closed" in kinds and "closed->free" in kinds


def test_zeno_accumulation_closes_contact():
    """e = 0.5, mass pressed on the wall (undamped, k = 1, f = 1 + 1.5 cos t, gap 0.3).

    Lift-off when the contact force f - k gap vanishes: cos t = -0.7 / 1.5; the
    flight is the same for every e (the mass leaves with zero velocity), then an
    accumulation of impacts ends in closed contact.
    """
    sols = {}
    for e in (0.0, 0.5):
        sys = chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.5, "constant": 1.0}],
                    elements=[Contact(0, 0.3, e)])
        ex = exact_periodic(sys, 1.0, {"q0": [0.3], "u0": [0.0]}, samples=1024)
        assert ex.success, ex.message
        assert ex.q.max() <= 0.3 + 1e-12 and ex.lam.min() >= -1e-12
        lift = [ev.t for ev in ex.info["events"] if ev.kind == "closed->free"]
        assert len(lift) == 1 and abs(lift[0] - np.arccos(-0.7 / 1.5)) <= 1e-12
        sols[e] = ex
    assert sols[0.0].info["n_impacts"] == 1 and sols[0.5].info["n_impacts"] > 10
    assert sols[0.5].info["stick_fraction"] < sols[0.0].info["stick_fraction"]
    a0, a5 = sols[0.0].info["amplitude_exact"], sols[0.5].info["amplitude_exact"]
    assert abs(a0[0] - a5[0]) <= 1e-10
