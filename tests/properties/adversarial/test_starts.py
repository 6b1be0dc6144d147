"""Adversarial cases of the default start strategy (:mod:`mshbm.route.ladder`).

Every case asserts a correct answer against an exact value (closed form, the exact event-driven
orbit of :func:`mshbm.exact_periodic`, or the same discrete problem solved from a known-good
start), or a clean failure (``success=False``, the best residual and the starts tried in the
message and in ``sol.info["starts"]``).  Nothing is checked against ``success`` alone.
"""
import math

import numpy as np
import pytest

import mshbm
from tests import discretised
from mshbm import Contact, Friction, System, chain
from mshbm.methods.common import linear_response
from mshbm.api import build_problem
from mshbm.errors import InputError
from mshbm.methods.exact import exact_periodic
from mshbm.branch import ROUTE
from mshbm.solvers.newton import solve_problem
from paper_systems import system as paper_system

try:
    from mshbm.route import ladder, starts
except ImportError:  # the package before the start strategy (counting the cases wrong there)
    ladder = starts = None
needs_starts = pytest.mark.skipif(starts is None, reason="tests a piece of mshbm.route.ladder")

METHODS = ("shooting", "hbm", "mshbm", "mshbm-intermediate")

# ------------------------------------------------------------------------------------------------
# (a) the stick case: friction sticks for the whole period, exact = chain clamped at DOF 0

W1 = 0.4450418679126287  # first linear eigenfrequency of the free chain


def stick_chain():
    return chain([1, 1, 1], 1.0, forcing=[{"dof": 2, "amplitude": 5.0}], elements=[Friction(0, 0.8, 100.0)])


def clamped_amplitudes(omega):
    """DOF 0 at rest; DOFs 1, 2: the 2-DOF chain (wall-spring 1 - mass - spring - mass) at omega."""
    K = np.array([[2.0, -1.0], [-1.0, 1.0]])
    q = np.linalg.solve(K - omega ** 2 * np.eye(2), [0.0, 5.0])
    return np.array([0.0, abs(q[0]), abs(q[1])])


def test_clamped_amplitudes_of_the_stick_case():
    assert np.allclose(clamped_amplitudes(W1), [0.0, 11.23, 20.24], atol=0.01)


@pytest.mark.parametrize("omega", [0.3, W1, 0.8])
@pytest.mark.parametrize("method", METHODS)
def test_stick_case_converges_to_the_clamped_chain(method, omega):
    sol = discretised.solve(stick_chain(), omega, method, harmonics=3, steps=1024)
    exact = clamped_amplitudes(omega)
    # the friction force needed to hold DOF 0 (the spring force of DOF 1) stays below mu F_N = 80
    assert exact[1] < 80.0
    assert sol.success, sol.message
    amp = sol.amplitude
    if method == "hbm":
        # regularised friction -mu F_N 2/pi arctan(kappa u): "stick" is a damper of slope
        # mu F_N 2/pi kappa = 4.1e4 Ns/m, so DOF 0 creeps with |u| ~ 11.2 / 4.1e4, amplitude ~ 1e-3
        assert amp[0] < 2e-3
        assert np.allclose(amp[1:], exact[1:], rtol=1e-4)
    else:
        # Moreau-Jean with 1024 steps (theta = 1/2): relative error O((omega h)^2) ~ 1e-5
        assert amp[0] < 1e-9 * exact[2]
        assert np.allclose(amp[1:], exact[1:], rtol=2e-5)
    assert "starts" in sol.info and sol.info["start_used"] in {r["start"] for r in sol.info["starts"]}


@needs_starts
@pytest.mark.parametrize("method", METHODS)
def test_residual_check_rejects_the_garbage_of_the_linear_start(method):
    """At the resonance the linear start (amplitude ~1e7..1e16) 'converges' under the old test
    ||R|| <= tol max(1, ||x0||); the physical-units check of :func:`starts.residual_accept` rejects it."""
    system = stick_chain()
    problem, _ = build_problem(system, W1, method, harmonics=3, steps=1024)
    res = solve_problem(problem, problem.initial_guess(None), tol=1e-10, max_iter=50)
    att = ladder.Attempt("linear", problem.initial_guess(None), res, problem)
    assert np.max(np.abs(problem.solution_parts(res.x)["q_hat"])) > 1e6  # the garbage
    assert not ladder.residual_accept(problem, system, W1)(att)


@needs_starts
def test_clamped_response_is_the_exact_stick_solution():
    q_hat = starts.clamped_response(stick_chain(), W1, 3)
    amp = np.abs(q_hat[1])  # cos coefficients: the forcing is 5 cos(omega t), no damping
    assert np.allclose(amp, clamped_amplitudes(W1), rtol=1e-13, atol=1e-13)
    assert np.all(q_hat[2:] == 0.0)


# ------------------------------------------------------------------------------------------------
# (b) the 1-DOF impact oscillator x'' + x = cos(omega t), stop at x = gap, restitution e


def oscillator(gap, e):
    return System([[1.0]], [[0.0]], [[1.0]], [[0.0], [1.0], [0.0]], [Contact(0, gap, e)])


OMEGAS = [float(w) for w in np.linspace(1.2, 3.0, 10)]
OSC_CASES = [(g, e, w) for g in (0.0, 0.1) for e in (0.5, 0.8, 1.0) for w in OMEGAS]
_RESULTS = {}


def _osc_solve(gap, e, omega, method="shooting"):
    key = (gap, e, omega, method)
    if key not in _RESULTS:
        _RESULTS[key] = discretised.solve(oscillator(gap, e), omega, method, steps=2000)
    return _RESULTS[key]


def _check_against_exact(sol, gap, e, omega):
    """A successful result is a T-periodic orbit of the impact oscillator: the exact event-driven
    orbit seeded by it exists and has the same amplitude to the Moreau-Jean accuracy (O(h), h = T/2000)."""
    ex = exact_periodic(oscillator(gap, e), omega, guess=sol)
    assert ex.success, ex.message
    a_ex = ex.info["amplitude_exact"][0]
    assert abs(sol.amplitude[0] - a_ex) <= 1e-2 * a_ex, (sol.amplitude[0], a_ex)  # measured: <= 6.1e-3
    # and the stop is respected
    assert np.max(sol.q[:, 0]) <= gap + 1e-9


def _check_clean_failure(sol):
    assert not sol.success
    assert "no start led to an accepted solution" in sol.message and "best ||R||_inf" in sol.message
    tried = [r["start"] for r in sol.info["starts"]]
    assert tried[0] == "linear" and len(tried) >= 4
    assert math.isfinite(sol.residual)
    assert sol.residual == min(r["residual"] for r in sol.info["starts"])


@pytest.mark.xdist_group("impact-oscillator")  # one worker: they share the solves of _osc_solve
@pytest.mark.slow
@pytest.mark.parametrize("gap,e,omega", OSC_CASES)
def test_impact_oscillator_shooting_default_start(gap, e, omega):
    sol = _osc_solve(gap, e, omega)
    if sol.success:
        _check_against_exact(sol, gap, e, omega)
    else:
        _check_clean_failure(sol)


@pytest.mark.xdist_group("impact-oscillator")  # one worker: they share the solves of _osc_solve
def test_impact_oscillator_share_converged():
    """Before the start strategy 16 of these 60 cases converged (10 of 30 at gap 0, 6 of 30 at gap
    0.1); with the ladder up to the "friction" start 49 (26 + 23); with the "frequency" start (the exact
    orbit continued from an anchor frequency, the section moved off an impact at t = 0) at least 54
    (55 measured: 29 + 26), each checked against the exact orbit above.  At gap 0, e = 1, omega = 2 no
    (1,1) orbit exists (test_no_orbit_at_omega_2_gap_0)."""
    ok = sum(_osc_solve(*c).success for c in OSC_CASES)
    assert ok >= 54, ok


@pytest.mark.xdist_group("impact-oscillator")  # one worker: they share the solves of _osc_solve
@pytest.mark.parametrize("omega", [1.4, 1.6])
def test_elastic_impacts_at_the_section_closed_form(omega):
    """Gap 0, e = 1, omega in (1, 2): the (1,1) orbit x = c (cos omega t - cos t - tan(pi/omega) sin t),
    c = 1 / (1 - omega^2), impacts at t = 0, i.e. at the Poincare section, where the state is ambiguous to one
    step; the ladder failed here before.  The "frequency" start reaches it (anchor 0.85 omega, exact orbit
    continued, section moved); amplitude within the Moreau-Jean accuracy (O(h), h = T/2000; measured 0.36 %
    and 0.02 %) of the closed form.  Since the certificate's ``step_accuracy_size`` (h J / D <= 2e-3; here the
    frequency start's one-step acceptance has h J = 6.1e-3 at omega = 1.6) the Moreau-Jean answer is not
    certified and ``solve`` ends with the exact event-driven integrator (``info["integrator"] == "event"``),
    whose series holds one limit of the velocity at t = 0 and T (the reversal between the neighbouring samples)."""
    sol = _osc_solve(0.0, 1.0, omega)
    assert sol.success, sol.message
    c = 1.0 / (1.0 - omega ** 2)
    t = np.linspace(0.0, 2 * np.pi / omega, 200001)
    x = c * (np.cos(omega * t) - np.cos(t) - np.tan(np.pi / omega) * np.sin(t))
    assert np.max(x) <= 0.0
    a = (np.max(x) - np.min(x)) / 2
    assert abs(sol.amplitude[0] - a) <= 5e-3 * a, (sol.amplitude[0], a)
    # the reported time series is in the original time: the impact (velocity reversal) is at t = 0 = T
    u = sol.u[:, 0]
    if sol.info.get("integrator") == "event":
        # the event-driven series: t = 0 and T hold the same limit of the velocity (pre- or post-impact); the
        # approach is the last step before T, the rebound (e = 1) the first step after 0
        assert abs(u[0] - u[-1]) <= 1e-9 * abs(u[0])
        assert u[-2] > 0.0 > u[1] and abs(abs(u[1]) - abs(u[-2])) <= 0.02 * abs(u[1])
    else:
        assert u[0] < 0.0 < u[-2] and abs(abs(u[0]) - abs(u[-2])) <= 0.02 * abs(u[0])


@pytest.mark.xdist_group("impact-oscillator")  # one worker: they share the solves of _osc_solve
def test_no_orbit_at_omega_2_gap_0():
    """Gap 0, e = 1: a (1,1) orbit needs free flight from x = 0 to x = 0 over T = pi = half the natural period,
    which forces cos(phi) = 0 and sin(phi) = 0 at once (no solution): a clean failure, not a wrong orbit."""
    _check_clean_failure(_osc_solve(0.0, 1.0, 2.0))


@pytest.mark.parametrize("method", ["shooting", "mshbm"])
def test_impact_oscillator_stable_orbit_at_omega_1_5(method):
    """omega = 1.5, gap 0.1, e = 0.7: the (1,1) orbit is stable (multipliers of modulus e = 0.7), yet
    both methods stalled at iteration 1; the Moreau-Jean map has no exact periodic point there
    (impact time quantised to the grid), so the answer is periodic to one step's accuracy."""
    sol = discretised.solve(oscillator(0.1, 0.7), 1.5, method, steps=2000)
    assert sol.success, sol.message
    ex = exact_periodic(oscillator(0.1, 0.7), 1.5)
    assert ex.success and np.max(np.abs(ex.info["floquet_multipliers"])) < 1.0
    a_ex = ex.info["amplitude_exact"][0]
    assert abs(sol.amplitude[0] - a_ex) <= 1e-2 * a_ex


def test_no_exact_periodic_point_of_the_discrete_map():
    """The stall is not a start problem: from the exact orbit itself, Newton on the Moreau-Jean
    residual stops at ||R|| = O(h) (no root), and the level falls with the step."""
    system = oscillator(0.1, 0.7)
    ex = exact_periodic(system, 1.5)
    levels = []
    for N in (2000, 8000):
        p, _ = build_problem(system, 1.5, "shooting", steps=N)
        r = solve_problem(p, np.array([ex.q[0, 0], ex.u[0, 0]]), tol=1e-12, fallback=False)
        assert not r.success
        levels.append(r.residual_norm)
    assert 1e-4 < levels[0] < 2 * 2 * np.pi / 1.5 / 2000 * 1.5  # ~ h omega
    assert levels[1] < levels[0] / 3


@pytest.mark.xdist_group("impact-oscillator")  # one worker: they share the solves of _osc_solve
@pytest.mark.parametrize("gap,e,omega", [(0.1, 0.5, 1.2), (0.1, 0.5, 2.6), (0.1, 0.8, 1.6),
                                         (0.1, 0.8, 2.4), (0.0, 0.5, 2.6), (0.0, 0.8, 3.0)])
def test_impact_oscillator_mshbm_default_start(gap, e, omega):
    sol = _osc_solve(gap, e, omega, "mshbm")
    assert sol.success, sol.message  # all six failed before (stall or line search)
    _check_against_exact(sol, gap, e, omega)


@pytest.mark.xdist_group("impact-oscillator")  # one worker: they share the solves of _osc_solve
def test_impact_oscillator_garbage_orbit_is_not_success():
    """e = 1, omega = 2: the transient runs away to an 'orbit' of amplitude 1e13 whose residual is
    small relative to its own size; relative to the physical scale it is not a solution."""
    sol = _osc_solve(0.0, 1.0, 2.0)
    if sol.success:
        _check_against_exact(sol, 0.0, 1.0, 2.0)
    else:
        _check_clean_failure(sol)
        assert sol.amplitude[0] > 1e6 or sol.residual > 1e-3


# ------------------------------------------------------------------------------------------------
# (c) the paper's 50-mass impact chain at 0.98 omega: MS-HBM stalled from the linear start


def impact50():
    return paper_system("impact50")


@pytest.fixture(scope="module")
def impact50_reference():
    system = impact50()
    w = 0.98 * math.pi / 5
    shoot = discretised.solve(system, w, "shooting", steps=4096)
    assert shoot.success and shoot.info.get("start_used", "linear") == "linear"
    return system, w, shoot


@pytest.mark.parametrize("method", ["mshbm", "mshbm-intermediate"])
@pytest.mark.parametrize("n_h", [3, 9])
def test_impact50_at_098_omega(impact50_reference, method, n_h):
    """The linear start cycles the impact across the section t = 0 = T (an impact at step 4064,
    4067, ... 4095, then gone); the shifted section converges, to a strict root of the discrete
    problem.  The discrete problem can have several roots whose impacts differ by a time step
    (mshbm-intermediate, n_h = 3: the root from the default start and the one Newton finds from the
    shooting orbit both have residual ~1e-15 and differ by 2e-3 in mass 1's amplitude), so the
    answer is checked against full shooting, to the truncation error of n_h harmonics, as is the
    root found from the shooting orbit."""
    system, w, shoot = impact50_reference
    sol = discretised.solve(system, w, method, harmonics=n_h, steps=4096)
    assert sol.success, sol.message
    assert sol.residual < 1e-12 and "step_accuracy" not in sol.info
    ref = discretised.solve(system, w, method, harmonics=n_h, steps=4096, guess=shoot)
    assert ref.success and ref.residual < 1e-12
    for s in (sol, ref):
        assert abs(s.amplitude[0] / shoot.amplitude[0] - 1) < (1e-2 if n_h == 3 else 1e-3)
        assert abs(s.amplitude[-1] / shoot.amplitude[-1] - 1) < 1e-4


# ------------------------------------------------------------------------------------------------
# the pieces of the strategy


@needs_starts
@pytest.mark.parametrize("t0", [0.0, 0.37, 2.5])
def test_shifted_system_is_the_time_shifted_forcing(t0):
    system = chain([1.0, 2.0], [1.0, 3.0], 0.1, forcing=[{"dof": 1, "amplitude": 2.0, "sin": 0.5},
                                                          {"dof": 0, "amplitude": 1.0, "harmonic": 3}])
    w = 0.7
    t = np.linspace(0.0, 9.0, 50)
    assert np.allclose(starts.shifted_system(system, t0, w).forcing(t, w), system.forcing(t + t0, w),
                       rtol=0, atol=1e-13)
    # the linear response of the shifted system is the shifted linear response
    q_s = linear_response(starts.shifted_system(system, t0, w), w, 3)
    assert np.allclose(q_s, starts.shift_hat(linear_response(system, w, 3), w, t0), rtol=0, atol=1e-12)


@needs_starts
def test_section_shift_avoids_events():
    parts = {"impulses": np.zeros((100, 1)), "t": np.linspace(0, 1, 101)}
    parts["impulses"][[3, 97]] = 1.0
    system = oscillator(0.0, 0.5)
    assert starts.section_shift(parts, system, 100) == 50
    parts["impulses"][:] = 0.0
    parts["impulses"][[40]] = 1.0
    k = starts.section_shift(parts, system, 100)
    assert min(abs(k - 40), 100 - abs(k - 40)) == 50


@needs_starts
def test_failure_reports_best_residual_and_every_start():
    """With a predicate that accepts nothing every applicable start is tried, and the attempt with
    the smallest residual is returned as a failure."""
    system = stick_chain()
    problem, _ = build_problem(system, W1, "mshbm", harmonics=3, steps=256)
    res = ladder.solve_from_starts(problem, "mshbm", system, W1, dict(tol=1e-10, max_iter=20),
                                   lambda a: False, solve_options=dict(harmonics=3, steps=256),
                                   transient_periods=(2,), route=ROUTE)
    tried = [r["start"] for r in res.info["starts"]]
    assert tried == ["linear", "clamped", "zero", "exact", "transient", "forcing", "friction", "frequency"]
    assert not res.success and res.info["start_used"] is None
    assert res.residual_norm == min(r["residual"] for r in res.info["starts"])
    assert "best ||R||_inf" in res.message and all(s in res.message for s in tried)
    assert res.nit == sum(r["iterations"] + r["extra_iterations"] for r in res.info["starts"])


@needs_starts
def test_explicit_guess_is_tried_first():
    system = stick_chain()
    problem, _ = build_problem(system, W1, "mshbm", harmonics=3, steps=256)
    g = {"q_hat": starts.clamped_response(system, W1, 3)}
    res = ladder.solve_from_starts(problem, "mshbm", system, W1, dict(tol=1e-10), 
                                   ladder.residual_accept(problem, system, W1), guess=g,
                                   solve_options=dict(harmonics=3, steps=256), route=ROUTE)
    assert res.success and res.info["start_used"] == "guess" and len(res.info["starts"]) == 1
    amp = problem.solution_parts(res.x)["q_hat"][1]
    assert np.allclose(np.abs(amp), clamped_amplitudes(W1), rtol=1e-4, atol=1e-9)


@needs_starts
def test_unknown_start_is_an_input_error():
    system = stick_chain()
    problem, _ = build_problem(system, W1, "mshbm", harmonics=3, steps=256)
    with pytest.raises(InputError, match="starts"):
        ladder.solve_from_starts(problem, "mshbm", system, W1, {}, lambda a: True, starts=("linear", "random"),
                                 route=ROUTE)


def test_explicit_guess_is_the_first_rung_and_continuation_false_a_single_start():
    """A good explicit guess is accepted as the ladder's first start (one record); ``continuation=False``
    runs Newton from the start alone (no ladder)."""
    system = stick_chain()
    sol = discretised.solve(system, 0.3, "mshbm", harmonics=3, steps=256, guess="linear")
    assert sol.info["start_used"] == "guess" and len(sol.info["starts"]) == 1
    assert np.allclose(sol.amplitude[1:], clamped_amplitudes(0.3)[1:], rtol=1e-3)
    sol = discretised.solve(system, 0.3, "mshbm", harmonics=3, steps=256, continuation=False)
    assert "starts" not in sol.info
    assert np.allclose(sol.amplitude[1:], clamped_amplitudes(0.3)[1:], rtol=1e-3)
    assert not ROUTE.single_start  # the public route is not left inside a ladder


def test_poor_explicit_guess_falls_back_to_the_ladder():
    """Newton from a poor guess (rest, far from the stick orbit) is the first rung; when it is not accepted
    the default starts follow, and the answer is the closed-form stick orbit."""
    system = stick_chain()
    direct = discretised.solve(system, W1, "mshbm", harmonics=3, steps=256, guess="zero", continuation=False)
    sol = discretised.solve(system, W1, "mshbm", harmonics=3, steps=256, guess="zero")
    assert sol.success, sol.message
    assert sol.info["starts"][0]["start"] == "guess"
    assert np.allclose(np.abs(sol.q_hat[1]), clamped_amplitudes(W1), rtol=1e-4, atol=1e-9)
    if not direct.success:
        assert sol.info["start_used"] != "guess"


@pytest.mark.parametrize("scale", [1e-12, 1e-6, 1e4, 1e6])
@pytest.mark.parametrize("method", ["shooting", "mshbm", "mshbm-intermediate"])
def test_unit_scaling_gives_the_same_start_and_answer(method, scale):
    """M, C, K, f and mu F_N times s: the physical scales move with the units, the accepted start and
    the displacements do not.  (HBM is left out: its Newton test ||R|| <= tol max(1, ||x0||) is in
    force units and not scale-invariant, which the certificate's test replaces.)"""
    base = discretised.solve(stick_chain(), W1, method, harmonics=3, steps=512)
    sys_s = chain([scale] * 3, scale, forcing=[{"dof": 2, "amplitude": 5.0 * scale}],
                  elements=[Friction(0, 0.8, 100.0 * scale)])
    sol = discretised.solve(sys_s, W1, method, harmonics=3, steps=512)
    assert sol.success and sol.info["start_used"] == base.info["start_used"] == "clamped"
    assert np.allclose(sol.amplitude, base.amplitude, rtol=1e-9, atol=1e-9 * base.amplitude.max())
    assert np.allclose(base.amplitude, clamped_amplitudes(W1), rtol=1e-4)


@pytest.mark.parametrize("method", ["shooting", "mshbm"])
def test_continuation_true_without_guess_runs_the_start_ladder(method):
    """continuation=True stalled at iteration 1 before (omega = 1.5, gap 0.1, e = 0.7)."""
    sol = discretised.solve(oscillator(0.1, 0.7), 1.5, method, steps=2000, continuation=True)
    assert sol.success, sol.message
    ex = exact_periodic(oscillator(0.1, 0.7), 1.5)
    assert abs(sol.amplitude[0] / ex.info["amplitude_exact"][0] - 1) < 1e-2


# ------------------------------------------------------------------------------------------------
# the 3-mass friction chain over friction bounds and frequencies (exact event-driven reference)

FRICTION_CASES = [(fn, w) for fn in (5.0, 25.0, 100.0) for w in (0.3, W1, 0.6, 0.9, 1.247, 1.5)]


@pytest.mark.parametrize("method", ["shooting", "mshbm", "mshbm-intermediate"])
@pytest.mark.parametrize("normal_force,omega", FRICTION_CASES)
def test_friction_chain_default_start(normal_force, omega, method):
    """Stick, stick-slip and slip; successes are checked against the exact orbit (1024 steps; MS-HBM
    with 5 harmonics: truncation error up to 0.3 %).  At the first eigenfrequency with mu F_N = 4 the
    friction cannot balance the resonant forcing: the exact solver finds no periodic orbit and the
    time-stepping map has only spurious ones (amplitude ~1e6); this must be a clean failure (before:
    success with amplitudes 5e6..2e7)."""
    system = chain([1, 1, 1], 1.0, forcing=[{"dof": 2, "amplitude": 5.0}],
                   elements=[Friction(0, 0.8, normal_force)])
    sol = discretised.solve(system, omega, method, harmonics=5, steps=1024)
    if normal_force == 5.0 and omega == W1:
        _check_clean_failure(sol)
        assert not exact_periodic(system, omega, guess=sol, max_iter=10).success
        return
    assert sol.success, sol.message
    ex = exact_periodic(system, omega, guess=sol)
    assert ex.success, ex.message
    a_ex = ex.info["amplitude_exact"]
    assert np.allclose(sol.amplitude, a_ex, rtol=5e-3, atol=1e-6 * a_ex.max()), (sol.amplitude, a_ex)
