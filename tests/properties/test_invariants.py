"""Physical and numerical invariants of the solutions.

* energy balance per period: work of the external force = damper dissipation + friction work
  (+ impact losses for e_N < 1), from the trajectory of shooting and MS-HBM solutions;
* non-penetration ``g_N >= -tol`` at every time point (random systems via hypothesis);
* friction cone ``|lambda_T| <= mu F_N`` and zero slip velocity during stick;
* periodicity: the periodic solution integrated for one more period by the stepper returns to its start;
* Fourier round trip and the dynamic stiffness of eq. (24).

Discrete energy identity of Moreau-Jean with theta = 1/2 (exact, derived from the step): with
``u_mid = (u_k + u_k+1)/2`` and ``f_theta = (f_k + f_k+1)/2``,
``E_k+1 - E_k = h u_mid.f_theta - h u_mid^T C u_mid + u_mid.G P_k`` where
``E = u^T M u / 2 + q^T K q / 2``.  Over a period of a periodic solution the left side vanishes.
"""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mshbm
from tests import discretised
from mshbm import Contact, Friction, chain, condensation, fourier
from mshbm.integrators.moreau_jean import MoreauJean
from paper_systems import OMEGA, friction_chain, impact_chain

SETTINGS = settings(max_examples=40, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


# ----------------------------------------------------------------------------- helpers
def energy_terms(system, sol):
    """(external work, damper dissipation, element losses, E(T) - E(0)) over the solution's period."""
    t, q, u = sol.t, sol.q, sol.u
    h = t[1] - t[0]
    f = system.forcing(t, sol.omega)
    f_mid = 0.5 * (f[:-1] + f[1:])
    u_mid = 0.5 * (u[:-1] + u[1:])
    work = h * np.sum(u_mid * f_mid)
    C = system.dense("C")
    damper = h * np.einsum("ki,ij,kj->", u_mid, C, u_mid)
    losses = 0.0
    td = {int(d): i for i, d in enumerate(sol.time_dofs)}
    for j, el in enumerate(system.elements):
        uj = sol.u_time[:, td[el.dof]]
        losses += -np.sum(el.sign * sol.impulses[:, j] * 0.5 * (uj[:-1] + uj[1:]))
    M, K = system.dense("M"), system.dense("K")
    E = lambda k: 0.5 * u[k] @ M @ u[k] + 0.5 * q[k] @ K @ q[k]
    return work, damper, losses, E(-1) - E(0)


def stored_energy(system, sol):
    """Largest mechanical energy over the period: E(T) - E(0) cancels to round-off of this size."""
    M, K = system.dense("M"), system.dense("K")
    return float(np.max(0.5 * np.einsum("ki,ij,kj->k", sol.u, M, sol.u)
                        + 0.5 * np.einsum("ki,ij,kj->k", sol.q, K, sol.q)))


def contact_gaps(system, sol):
    td = {int(d): i for i, d in enumerate(sol.time_dofs)}
    return [el.gap - sol.q_time[:, td[el.dof]] for el in system.elements if el.kind == "contact"]


@st.composite
def random_chain(draw, element):
    """A small chain (1-5 DOFs) with parameters over two decades and one element on a random DOF."""
    n = draw(st.integers(1, 5))
    dec = st.floats(-1.0, 1.0)
    masses = [10.0 ** draw(dec) for _ in range(n)]
    stiff = [10.0 ** draw(dec) for _ in range(n)]
    zeta = draw(st.sampled_from([0.0, 0.01, 0.1, 0.5]))
    damp = [zeta * 2.0 * np.sqrt(k * m) for k, m in zip(stiff, masses)]
    d_force, d_el = draw(st.integers(0, n - 1)), draw(st.integers(0, n - 1))
    amp = 10.0 ** draw(dec)
    if element == "contact":
        el = Contact(d_el, gap=amp / max(stiff) * 10.0 ** draw(st.floats(-2.0, 0.5)),
                     restitution=draw(st.sampled_from([0.0, 0.5, 1.0])), penalty_stiffness=1e3)
    else:
        el = Friction(d_el, mu=draw(st.floats(0.1, 1.0)), normal_force=amp * 10.0 ** draw(st.floats(-1.5, 0.3)))
    omega = draw(st.floats(0.2, 2.0))
    system = chain(masses, stiff, damp, forcing=[{"dof": d_force, "amplitude": amp}], elements=[el])
    return system, omega


def solutions(system, omega):
    """Shooting and MS-HBM solutions (cheap settings, max 30 Newton iterations each)."""
    out = []
    for method, kw in (("shooting", dict(steps=512)), ("mshbm", dict(harmonics=3, steps=512))):
        try:
            out.append(discretised.solve(system, omega, method, max_iter=30, **kw))
        except mshbm.InputError as exc:  # e.g. omega on a resonance of H_LL: a clear failure
            assert exc.key == "omega", exc
    return out


# ----------------------------------------------------------------------------- energy balance
@pytest.fixture(scope="module")
def paper_solutions():
    cases = {"friction3": friction_chain(3), "impact5": impact_chain(5), "impact5-e0.5": impact_chain(5, e=0.5)}
    out = []
    for name, system in cases.items():
        for method, kw in (("shooting", dict(steps=1024)), ("mshbm", dict(harmonics=5, steps=1024)),
                           ("mshbm", dict(harmonics=15, steps=2048))):
            sol = discretised.solve(system, OMEGA, method, **kw)
            assert sol.success, (name, method, sol.message)
            out.append((name, system, sol))
    return out


def test_energy_balance_per_period(paper_solutions):
    for name, system, sol in paper_solutions:
        work, damper, losses, dE = energy_terms(system, sol)
        assert work > 0, name
        assert damper >= 0 and losses >= -1e-12 * work, (name, damper, losses)
        if system.elements[0].kind == "contact" and system.elements[0].restitution == 1.0:
            assert abs(losses) <= 1e-10 * work  # e_N = 1: impacts conserve energy
        if system.elements[0].kind == "contact" and system.elements[0].restitution < 1.0:
            assert losses > 0.1 * work  # e_N = 0.5: impacts dissipate a good part
        # shooting: exact discrete identity; MS-HBM: the harmonic constraint does no work on the
        # harmonic q_L, so the balance holds up to the time discretisation
        tol = 1e-9 if sol.method == "shooting" else 1e-4
        assert abs(work - damper - losses) <= tol * work, (name, sol.method, sol.harmonics, work, damper, losses)


@SETTINGS
@given(case=random_chain("friction"))
def test_discrete_energy_identity_random_friction(case):
    system, omega = case
    sol = discretised.solve(system, omega, "shooting", steps=256, max_iter=20)
    if not np.all(np.isfinite(sol.q_time)):
        assert not sol.success
        return
    work, damper, losses, dE = energy_terms(system, sol)
    scale = max(abs(work), abs(damper), abs(losses), abs(dE), 1e-300)
    roundoff = 1e-12 * stored_energy(system, sol)
    # holds for every trajectory of the stepper, periodic or not
    assert abs(work - damper - losses - dE) <= 1e-8 * scale + roundoff
    assert losses >= -1e-10 * scale - roundoff  # friction never does positive work
    if sol.success:
        assert abs(dE) <= 1e-6 * scale + 1e-9


# ----------------------------------------------------------------------------- contact
@pytest.mark.slow
@SETTINGS
@given(case=random_chain("contact"))
def test_non_penetration_random_systems(case):
    system, omega = case
    el = system.elements[0]
    for sol in solutions(system, omega):
        if not sol.success:
            assert sol.message  # a diagnosis, never a silent failure
            if not np.all(np.isfinite(sol.q_time)):
                continue
        (g,) = contact_gaps(system, sol)
        if not sol.success:
            g = g[1:]  # t = 0 is the last Newton iterate (unconverged), not an output of the stepper
        scale = max(el.gap, float(np.max(np.abs(sol.q_time))), 1e-12)
        assert g.min() >= -1e-9 * scale, (sol.method, g.min(), sol.success)
        if sol.success:
            # a contact impulse pushes only (normal force >= 0)
            assert sol.impulses.min() >= 0.0


def test_non_penetration_paper_impact(paper_solutions):
    for name, system, sol in paper_solutions:
        if system.elements[0].kind == "contact":
            (g,) = contact_gaps(system, sol)
            assert g.min() >= -1e-12, (name, sol.method, g.min())
            assert sol.impulses.max() > 0  # and the contact does act (impacts)


# ----------------------------------------------------------------------------- friction
def check_friction_cone(system, sol):
    el = system.elements[0]
    h = sol.t[1] - sol.t[0]
    bound = el.mu * el.normal_force
    P = sol.impulses[:, 0]
    assert np.all(np.abs(P) <= h * bound * (1 + 1e-12)), np.abs(P).max() / (h * bound)
    assert np.all(np.abs(sol.lam[:, 0]) <= bound * (1 + 1e-12))
    td = list(sol.time_dofs).index(el.dof)
    u_next = sol.u_time[1:, td]
    stick = np.abs(P) < h * bound * (1 - 1e-9)  # strictly inside the cone: stick
    # velocity scale of the whole solution, floored by the forcing's own scale omega |f|max / max K_ii:
    # a solution that sticks all period has |u| ~ 1e-19 of round-off, which is stick, not a scale
    K = system.dense("K")
    f_max = float(np.max(np.abs(system.forcing(sol.t, sol.omega))))
    scale = max(float(np.max(np.abs(sol.u))), sol.omega * f_max / float(np.max(np.diag(K))))
    assert np.all(np.abs(u_next[stick]) <= 1e-10 * scale), (np.abs(u_next[stick]).max(), scale)
    # slip: the friction impulse opposes the post-step slip velocity
    slip = ~stick & (np.abs(u_next) > 1e-9 * scale)
    assert np.all(P[slip] * u_next[slip] <= 0)
    return stick.mean()


def test_friction_cone_and_stick_paper(paper_solutions):
    for name, system, sol in paper_solutions:
        if system.elements[0].kind == "friction":
            frac = check_friction_cone(system, sol)
            assert 0.1 < frac < 0.9  # pronounced stick-slip (mu F_N = 0.8 * 9.81)


@SETTINGS
@given(case=random_chain("friction"))
def test_friction_cone_random_systems(case):
    system, omega = case
    for sol in solutions(system, omega):
        if np.all(np.isfinite(sol.q_time)) and np.all(np.isfinite(sol.impulses)):
            check_friction_cone(system, sol)


def test_hbm_regularised_friction_inside_cone():
    system = friction_chain(3)
    sol = discretised.solve(system, OMEGA, "hbm", harmonics=10)
    assert sol.success
    assert np.all(np.abs(sol.lam) <= 0.8 * 9.81 * (1 + 1e-12))


# ----------------------------------------------------------------------------- periodicity
def one_more_period(system, sol, theta=0.5):
    h = sol.t[1] - sol.t[0]
    stepper = MoreauJean(system.M, system.C, system.K, system.elements, h, theta)
    B = stepper.increments(system.forcing(sol.t, sol.omega))
    return stepper.run(sol.q[0], sol.u[0], B)


def test_periodicity_one_more_period(paper_solutions):
    for name, system, sol in paper_solutions:
        tr = one_more_period(system, sol)
        scale = float(np.max(np.abs(sol.q)))
        d_end = np.max(np.abs(np.concatenate([tr.q[-1] - sol.q[0], tr.u[-1] - sol.u[0]]))) / scale
        d_traj = np.max(np.abs(tr.q - sol.q)) / scale
        if sol.method == "shooting":
            assert d_end < 1e-9 and d_traj < 1e-9, (name, d_end, d_traj)
        else:
            # MS-HBM: the linear subsystem is harmonic (n_h harmonics): periodic up to truncation
            tol = 1e-2 if sol.harmonics <= 5 else 1e-3
            assert d_end < tol and d_traj < tol, (name, sol.harmonics, d_end, d_traj)


# ----------------------------------------------------------------------------- Fourier and eq. (24)
@settings(max_examples=60, deadline=None, derandomize=True)
@given(n_h=st.integers(0, 12), extra=st.integers(1, 64), n=st.integers(1, 3), seed=st.integers(0, 2 ** 31 - 1),
       log_amp=st.floats(-6, 6))
def test_fourier_round_trip(n_h, extra, n, seed, log_amp):
    rng = np.random.default_rng(seed)
    N = 2 * n_h + extra
    c = rng.standard_normal((2 * n_h + 1, n)) * 10.0 ** log_amp
    x = fourier.ifft(c, N)
    assert np.allclose(fourier.fft(x, n_h), c, rtol=0, atol=1e-12 * np.abs(c).max())
    # IFFT(FFT(x)) = x for a band-limited signal, and IFFT equals V(t)^T x_hat (eq. 3)
    assert np.allclose(fourier.ifft(fourier.fft(x, n_h), N), x, rtol=0, atol=1e-12 * np.abs(c).max())
    omega = 0.7
    t = np.arange(N) * (2 * np.pi / omega) / N
    assert np.allclose(fourier.basis(t, omega, n_h) @ c, x, rtol=0, atol=1e-12 * np.abs(c).max())
    # derivative (eqs. 4-5) against a spectral check: d/dt V^T c = V^T Omega c
    dc = fourier.derivative(c, omega)
    k = np.arange(1, n_h + 1)
    dV = np.zeros((N, 2 * n_h + 1))
    dV[:, 1::2] = -k * omega * np.sin(np.outer(t, k) * omega)
    dV[:, 2::2] = k * omega * np.cos(np.outer(t, k) * omega)
    assert np.allclose(fourier.basis(t, omega, n_h) @ dc, dV @ c, rtol=0, atol=1e-10 * np.abs(c).max() * (1 + n_h))
    if n_h >= 1:  # a harmonic above n_h is not represented: the round trip is not the identity
        hi = np.zeros((2 * n_h + 3, n))
        hi[-2] = 1.0
        if N > 2 * n_h + 2:
            xhi = fourier.ifft(hi, N)
            assert not np.allclose(fourier.ifft(fourier.fft(xhi, n_h), N), xhi)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(n=st.integers(1, 4), k=st.integers(0, 6), omega=st.floats(0.05, 5.0), seed=st.integers(0, 2 ** 31 - 1))
def test_dynamic_stiffness_eq24(n, k, omega, seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((3, n, n))
    M = A[0] @ A[0].T + n * np.eye(n)
    C = A[1] @ A[1].T
    K = A[2] @ A[2].T
    Hk = fourier.real_block(condensation.dynamic_stiffness(M, C, K, k * omega), k)
    S = K - (k * omega) ** 2 * M
    expected = S if k == 0 else np.block([[S, C * k * omega], [-C * k * omega, S]])
    assert np.allclose(Hk, expected, rtol=1e-13, atol=1e-13 * np.abs(expected).max())
    # and it is the harmonic balance of M q'' + C q' + K q for q = V^T q_hat with only harmonic k (eq. 17)
    n_h = max(k, 1)
    q_hat = np.zeros((2 * n_h + 1, n))
    if k == 0:
        q_hat[0] = rng.standard_normal(n)
    else:
        q_hat[2 * k - 1:2 * k + 1] = rng.standard_normal((2, n))
    Nt = 4 * n_h + 8
    d1 = fourier.derivative(q_hat, omega)
    d2 = fourier.derivative(d1, omega)
    r = fourier.ifft(d2, Nt) @ M.T + fourier.ifft(d1, Nt) @ C.T + fourier.ifft(q_hat, Nt) @ K.T
    r_hat = fourier.fft(r, n_h)
    if k == 0:
        assert np.allclose(r_hat[0], Hk @ q_hat[0], atol=1e-10 * (1 + np.abs(Hk).max()))
    else:
        got = np.concatenate([r_hat[2 * k - 1], r_hat[2 * k]])
        want = Hk @ np.concatenate([q_hat[2 * k - 1], q_hat[2 * k]])
        assert np.allclose(got, want, atol=1e-9 * (1 + np.abs(Hk).max()))
