"""Frequency-response curves (mshbm.sweep, mshbm.solvers.arclength, mshbm.period, ``mshbm sweep``).

Closed forms: the linear FRF; Den Hartog's Coulomb oscillator without stops (the half-period
symmetric solution of ``x'' + 2 zeta x' + x = F cos(omega t + phi) - R`` with ``x(0) = -X, x'(0) = 0,
x(pi/omega) = X, x'(pi/omega) = 0``, solved here from the exact mode flow); a cubic with two folds for
the arclength driver; a period-2 response of the paper's impact chain against a long transient.
"""
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import fsolve

import mshbm
from mshbm import Contact, Friction, chain
from mshbm.cli import main
from mshbm.integrators.moreau_jean import MoreauJean
from mshbm.period import solve as solve_period
from mshbm.solvers.arclength import continuation

ROOT = Path(__file__).resolve().parents[2]


# ----------------------------------------------------------------------------- the generic driver
def test_arclength_passes_and_locates_both_folds_of_a_cubic():
    """x^3 - x - lam = 0 from lam = -1 to 1: S-shaped, folds at lam = +-2/(3 sqrt 3)."""
    res = continuation(lambda x, l: (np.array([x[0] ** 3 - x[0] - l]), np.array([[3 * x[0] ** 2 - 1]])),
                       lambda x, l: np.array([-1.0]), np.array([-1.324717957244746]), -1.0, 1.0,
                       residual_scale=lambda x, l: np.ones(1), unknown_scale=lambda x, l: np.ones(1),
                       lam_scale=1.0, ds0=0.05)
    assert res.success
    lam_f = 2 / (3 * np.sqrt(3))
    assert [f["lam"] for f in res.folds] == pytest.approx([lam_f, -lam_f], rel=1e-3)
    x = np.array([p.x[0] for p in res.points])
    lam = np.array([p.lam for p in res.points])
    np.testing.assert_allclose(x ** 3 - x - lam, 0.0, atol=1e-10)
    assert np.all(np.diff(x) > 0)  # one branch, traversed once through both folds
    assert x[-1] == pytest.approx(1.324717957244746, rel=1e-9) and lam[-1] == 1.0


def _kinked(lam):
    """A branch with a corner at lam = 1: x = (20 (1 - lam), 0) before it, (lam - 1, 5 (lam - 1)) after; the
    incoming and outgoing tangents meet at 98 degrees (cos = -0.146), and lam increases along both pieces."""
    return (np.array([20.0 * (1.0 - lam), 0.0]), np.array([-20.0, 0.0])) if lam < 1.0 else \
        (np.array([lam - 1.0, 5.0 * (lam - 1.0)]), np.array([1.0, 5.0]))


@pytest.mark.parametrize("lam0, lam1", [(0.5, 1.5), (1.5, 0.5)])
def test_arclength_passes_a_corner_of_the_branch_monotonically(lam0, lam1):
    """R(x, lam) = x - g(lam) with g piecewise linear (``_kinked``): dR/dx = I everywhere, dR/dlam jumps at the
    corner.  Before the kink handling the tangent oriented along the previous one pointed back after the
    corner and the continuation cycled at lam = 1 (200 points, max_points); told the smooth pieces
    (``segment``), it keeps the orientation of the curve (sign det [J, g; t]) across the corner, lam is
    monotone, no fold is reported and the corner is listed as a kink."""
    res = continuation(lambda x, l: (x - _kinked(l)[0], np.eye(2)), lambda x, l: -_kinked(l)[1], _kinked(lam0)[0],
                       lam0, lam1, residual_scale=lambda x, l: np.ones(2), unknown_scale=lambda x, l: np.ones(2),
                       lam_scale=1.0, ds0=0.02, ds_max=0.2, segment=lambda x, l: l < 1.0)
    assert res.success, res.message
    lam = np.array([p.lam for p in res.points])
    assert np.all(np.diff(lam) * np.sign(lam1 - lam0) > 0)
    assert lam[-1] == lam1
    for p in res.points:
        np.testing.assert_allclose(p.x, _kinked(p.lam)[0], atol=1e-10)
    assert res.folds == []
    assert len(res.kinks) == 1
    k = res.kinks[0]
    assert min(k["lam"], k["lam_right"]) <= 1.0 <= max(k["lam"], k["lam_right"])


def test_arclength_records_why_its_corrector_failed():
    """A point rejected by ``accept`` counts as a corrector failure, halves the step, and its reason is kept in
    ``counters["failures"]`` with the parameter of the last point and the step tried."""
    calls = []

    def accept(x, lam, stall):
        calls.append(lam)
        return (False, "test rejection") if len(calls) == 2 else (True, None)  # the first step after the start

    res = continuation(lambda x, l: (np.array([x[0] - 2.0 * l]), np.array([[1.0]])), lambda x, l: np.array([-2.0]),
                       np.array([0.0]), 0.0, 1.0, residual_scale=lambda x, l: np.ones(1),
                       unknown_scale=lambda x, l: np.ones(1), lam_scale=1.0, ds0=0.05, accept=accept)
    assert res.success
    assert res.counters["corrector_failures"] == 1 and res.counters["rejected"] == 1
    assert res.counters["failures"] == [{"lam": 0.0, "ds": 0.05, "reason": "point rejected: test rejection"}]
    assert res.points[1].ds == pytest.approx(0.025, rel=1e-12)


# ----------------------------------------------------------------------------- closed forms
@pytest.mark.slow
def test_linear_branch_matches_exact_frf():
    s = chain([1.0, 2.0], [1.0, 0.5], 0.05, forcing=[{"dof": 1, "amplitude": 1.0}])
    b = mshbm.sweep(s, 0.3, 1.6, "shooting", steps=8192)
    assert b.success and len(b) > 10
    w = b.omega
    assert w[0] == 0.3 and w[-1] == 1.6 and np.all(np.diff(w) > 0)
    H = np.array([np.linalg.solve(s.K - x ** 2 * s.M + 1j * x * s.C, [0.0, 1.0]) for x in w])
    np.testing.assert_allclose(b.amplitude, np.abs(H), rtol=2e-3)  # O((omega h)^2) of Moreau-Jean
    assert all(st is True for st in b.stable)  # damped linear: every point stable


def _den_hartog(w, zeta, F, R):
    A = np.array([[0.0, 1.0], [-1.0, -2 * zeta]])
    E = expm(A * np.pi / w)
    H = F / (1 - w ** 2 + 2j * zeta * w)

    def part(t, phi):
        z = H * np.exp(1j * (w * t + phi))
        return np.array([z.real - R, (1j * w * z).real])

    def res(p):
        X, phi = p
        return E @ (np.array([-X, 0.0]) - part(0.0, phi)) + part(np.pi / w, phi) - np.array([X, 0.0])

    X, phi = fsolve(res, [abs(H), 0.0], xtol=1e-13)
    assert np.max(np.abs(res([X, phi]))) < 1e-12
    return X


@pytest.mark.slow
@pytest.mark.parametrize("method,kw", [("shooting", dict(steps=4096)), ("mshbm", dict(harmonics=20, steps=4096))])
def test_den_hartog_branch_above_resonance(method, kw):
    zeta, F, R = 0.05, 1.0, 0.3
    s = chain([1.0], 1.0, 2 * zeta, forcing=[{"dof": 0, "amplitude": F}], elements=[Friction(0, 1.0, R)])
    b = mshbm.sweep(s, 1.5, 3.0, method, **kw)
    assert b.success and len(b) >= 5
    exact = np.array([_den_hartog(w, zeta, F, R) for w in b.omega])
    np.testing.assert_allclose(b.amplitude[:, 0], exact, rtol=5e-3)
    assert all(p.certificate["passed"] for p in b.points)
    assert all(st is True for st in b.stable)  # exact-flow verdicts (one element)


def test_den_hartog_branch_dlft_converges_like_one_over_n_h():
    """DLFT along the same branch: the error against the closed form halves when n_H doubles (measured with
    the default velocity predictor 1.01 %, 0.51 %, 0.26 % at n_H = 10, 20, 40; the displacement predictor
    3.8 %, 2.0 %, 0.99 %: its force reverses late at each slip reversal, mshbm.methods.dlft)."""
    zeta, F, R = 0.05, 1.0, 0.3
    s = chain([1.0], 1.0, 2 * zeta, forcing=[{"dof": 0, "amplitude": F}], elements=[Friction(0, 1.0, R)])
    err = {}
    for n_h in (10, 40):
        b = mshbm.sweep(s, 1.5, 3.0, "dlft", harmonics=n_h)
        assert b.success and len(b) >= 5 and b.omega[-1] == pytest.approx(3.0)
        assert all(p.certificate["passed"] for p in b.points)
        assert all(st is True for st in b.stable)
        exact = np.array([_den_hartog(w, zeta, F, R) for w in b.omega])
        err[n_h] = float(np.max(np.abs(b.amplitude[:, 0] / exact - 1.0)))
    assert err[40] < 0.3 * err[10] and err[40] < 0.004


@pytest.mark.parametrize("method", ["hbm", "dlft"])
def test_sweep_without_condensation_equals_condensed(method):
    """``condense=False`` (all DOFs kept, sparse Jacobian) traces the same branch as the condensed
    problem (it used to stop with a traceback in the bordered system)."""
    s = chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}], elements=[Friction(0, 1.0, 0.3)])
    b = mshbm.sweep(s, 1.6, 2.0, method, harmonics=7, condense=False, stability=False, accuracy=False)
    assert b.success and b.omega[-1] == pytest.approx(2.0) and len(b) >= 5
    for i in (1, len(b) // 2, len(b) - 1):  # the condensed solve at the branch's frequencies
        # the same discretised equations, without error estimates on either side (accuracy=False): the branch
        # points and the pointwise solves are certified for those equations
        ref = mshbm.solve(s, b.omega[i], method, harmonics=7, stability=False, accuracy=False)
        assert ref.success
        np.testing.assert_allclose(b.amplitude[i], ref.amplitude, rtol=1e-7)


def test_dlft_branch_of_the_friction_chain_against_mshbm():
    """``mshbm sweep`` with DLFT on the paper's 3-DOF friction chain above its first resonance: the branch
    is traced to the end and approaches MS-HBM's as n_H grows (largest deviation over the branch,
    measured with the default velocity predictor: 8.7 % at n_H = 9, 1.8 % at 25 -- the stick phases of
    mass 1; the displacement predictor: 21 %, 6.1 %)."""
    case = mshbm.load_case(ROOT / "examples" / "friction3.yaml")
    ms = mshbm.sweep(case.system, 0.7, 1.0, "mshbm", harmonics=9, steps=1024, stability=False)
    assert ms.success
    dev = {}
    for n_h in (9, 25):
        b = mshbm.sweep(case.system, 0.7, 1.0, "dlft", harmonics=n_h, stability=False)
        assert b.accuracy["reached_end"] and np.all(np.diff(b.omega) > 0)
        # every point solves its discretised equations; the points whose truncation estimate exceeds the
        # default 1 % say so (and then the branch): the deviations from MS-HBM are above 1 %
        assert all(p.certificate["failed"] in ([], ["accuracy"]) for p in b.points)
        ref = np.stack([np.interp(b.omega, ms.omega, ms.amplitude[:, j]) for j in range(3)], axis=1)
        dev[n_h] = float(np.max(np.abs(b.amplitude / ref - 1.0)))
        assert not b.success and b.accuracy["uncertified_points"] and b.accuracy["largest"]["name"] == "truncation"
        assert b.accuracy["largest"]["estimate"] >= 0.5 * dev[n_h]
    assert dev[25] < 0.5 * dev[9] and dev[25] < 0.03


# ----------------------------------------------------------------------------- a fold of an impact oscillator
@pytest.mark.slow
def test_impact_oscillator_branch_passes_its_fold():
    """x'' + 0.1 x' + x = cos(omega t), stop at 0.5, e = 0.8: the impacting (1,1) branch bends to the right
    and turns back (fold near omega = 1.89); every point is certified and the branch is continuous."""
    s = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Contact(0, 0.5, 0.8)])
    b = mshbm.sweep(s, 1.0, 2.2, "shooting", steps=2000, max_points=60)
    w, a = b.omega, b.amplitude[:, 0]
    assert len(b) == 60
    i = int(np.argmax(w))
    assert 5 < i < len(b) - 5 and 1.85 < w[i] < 1.95
    assert w[-1] < w[i] - 0.01 and a[-1] < a[i] - 0.3  # beyond the fold: back in omega, on the lower part
    assert np.max(np.abs(np.diff(a)) / a[1:]) < 0.2 and np.max(np.abs(np.diff(w)) / w[1:]) < 0.1  # no jumps
    # every point solves its discretised equations (those whose error estimate exceeds 1 % say so)
    assert all(p.certificate["failed"] in ([], ["accuracy"]) for p in b.points)
    assert all(p.contact[0]["active"] for p in b.points)
    assert b.stable[0] is True and b.stable[-1] is False  # the part beyond the fold is unstable
    folds = [f for f in b.bifurcations if f["type"] == "fold"]
    assert len(folds) == 1 and folds[0]["omega"] == pytest.approx(w[i], rel=1e-2)


def test_forcing_continuation_reaches_full_load():
    s = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Friction(0, 1.0, 0.3)])
    b = mshbm.continue_forcing(s, 2.0, 4.0, 1.0, "shooting", steps=4096)
    assert b.success and b.parameter == "forcing"
    assert b.load[0] == 4.0 and b.load[-1] == 1.0
    ref = mshbm.solve(s, 2.0, "shooting", steps=4096)
    assert b.amplitude[-1, 0] == pytest.approx(ref.amplitude[0], rel=1e-8)


# ----------------------------------------------------------------------------- period k
@pytest.fixture(scope="module")
def period_2_at_pi_over_5(impact5):
    """The impact chain's 2T response at omega = pi/5 by MS-HBM from the default start (one solve for the two
    tests that ask it; its start ladder takes most of their time).  n_h = 10 per forcing period: with 5 the
    2T orbit's truncation estimate (1.2 %) exceeds the default accuracy."""
    return solve_period(impact5, np.pi / 5, "mshbm", period=2, harmonics=10)


def test_period_2_response_of_the_impact_chain_against_a_transient(impact5, period_2_at_pi_over_5):
    w = np.pi / 5
    sol = period_2_at_pi_over_5
    assert sol.success and sol.info["period"] == 2 and sol.omega == pytest.approx(w / 2)
    assert sol.info["period_k_content"] > 0.1  # a genuine 2T orbit, not the (unstable) T-periodic one
    assert sol.stable is True
    # a long Moreau-Jean transient from rest settles on it
    T, N = 2 * np.pi / w, 2048
    mj = MoreauJean(impact5.M, impact5.C, impact5.K, impact5.elements, T / N)
    B = mj.increments(impact5.forcing(np.linspace(0.0, T, N + 1), w))
    q, u = np.zeros(5), np.zeros(5)
    states = []
    for _ in range(600):
        tr = mj.run(q, u, B)
        q, u = tr.q[-1].copy(), tr.u[-1].copy()
        states.append(tr.q)
    q2 = np.vstack([states[-2], states[-1][1:]])
    assert np.max(np.abs(states[-1][-1] - states[-2][-1])) > 1.0  # not T-periodic
    # 2T-periodic to the step accuracy of the Moreau-Jean map (it moves the impact by whole steps, h = 4.9 ms)
    assert np.max(np.abs(states[-1][-1] - states[-3][-1])) < 2e-3 * np.max(np.abs(q2))
    amp = (q2.max(axis=0) - q2.min(axis=0)) / 2
    np.testing.assert_allclose(sol.amplitude, amp, rtol=5e-3)


@pytest.mark.slow
def test_switch_at_the_period_doubling_of_the_impact_oscillator():
    """Budd & Dux's impact oscillator (tests/closed_forms.py): the (1,1) branch by shooting has its period
    doubling at the closed-form omega_PD, within what the estimated errors of the branch points' own multipliers
    allow (the Moreau-Jean orbits' own monodromy, 2048 steps: measured 2.455203 against 2.456715, a multiplier
    error of 0.06 at the slope -41 per rad/s; the estimates are 0.09 and 0.13); switching there gives a
    2T-periodic branch beyond it that is stable (supercritical), with 2T content (harmonics of omega/2
    that are not harmonics of omega; measured 0.48-0.52 of the largest)."""
    import closed_forms as cf  # tests/ is on the path (its conftest.py)
    from mshbm.period import subharmonic_content

    s = cf.system()
    b = mshbm.sweep(s, 2.42, 2.50, "shooting", steps=2048)
    pds = [f for f in b.bifurcations if f["type"] == "period-doubling"]
    assert len(pds) == 1
    p0, p1 = b.points[pds[0]["index"]], b.points[pds[0]["index"] + 1]
    mu0, mu1 = (float(np.min(p.solution.floquet_multipliers.real)) for p in (p0, p1))
    assert mu0 > -1.0 > mu1  # the flip multiplier crosses -1 between the two points
    err = max(p.solution.info["stability"]["multiplier_error"] for p in (p0, p1))
    slope = (mu1 - mu0) / (p1.omega - p0.omega)
    assert abs(pds[0]["omega"] - cf.omega_pd()) <= err / abs(slope) < 1e-2
    b2 = mshbm.switch_period_doubling(s, b, 2.50)
    assert b2.period == 2 and len(b2) >= 5 and b2.origin["type"] == "period-doubling"
    # the exact monodromy's eigenvalue at the branch point next to the bifurcation (measured -0.87)
    assert -1.2 < b2.origin["multiplier"][0] < -0.7 and b2.origin["multiplier"][1] == 0.0
    assert cf.omega_pd() < b2.omega[0] <= 1.01 * cf.omega_pd()
    assert all(subharmonic_content(p.solution, 2) > 0.1 for p in b2.points)
    assert all(p.certificate["failed"] in ([], ["accuracy"]) for p in b2.points)
    assert b2.stable[:3] == [True, True, True]
    with pytest.raises(mshbm.InputError):  # a branch without a period doubling
        mshbm.switch_period_doubling(s, mshbm.sweep(s, 2.0, 2.1, "shooting", steps=512, max_points=3), 2.5)


def test_switch_with_the_event_integrator_reaches_the_period_2_response_at_pi_over_5(impact5):
    """With ``integrator="event"`` the switch solves its start with the event-driven flow too (a 2T orbit of
    Moreau-Jean steps is T-periodic for the exact flow that close to the bifurcation).  The switched branch of
    the impact chain passes omega = pi/5 at the 2T response computed there from the default start: one branch
    (mass-1 amplitudes within 0.5 %; measured 4.145 interpolated against 4.144)."""
    opts = dict(steps=1024, integrator="event")
    b = mshbm.sweep(impact5, 0.60, 0.625, "shooting", **opts)
    pds = [f["omega"] for f in b.bifurcations if f["type"] == "period-doubling"]
    assert len(pds) == 1 and 0.612 < pds[0] < 0.616
    b2 = mshbm.switch_period_doubling(impact5, b, 0.632, **opts)
    assert b2.success, b2.message
    assert b2.period == 2 and pds[0] < b2.omega[0] < 1.01 * pds[0] and b2.omega[-1] == pytest.approx(0.632)
    w = np.pi / 5
    i = int(np.searchsorted(b2.omega, w))
    assert 0 < i < len(b2)
    s = (w - b2.omega[i - 1]) / (b2.omega[i] - b2.omega[i - 1])
    a_interp = (1 - s) * b2.amplitude[i - 1, 0] + s * b2.amplitude[i, 0]
    ref = solve_period(impact5, w, "shooting", period=2, **opts)
    assert ref.success, ref.message
    assert a_interp == pytest.approx(ref.amplitude[0], rel=5e-3)


def _grazing_reference(system, sols, key):
    """omega where the linear fit of ``key`` (``"miss"``: the near-miss gap, ``"v_min"``: the smallest impact
    velocity, both vary linearly in omega next to a grazing of a periodic orbit) over the solutions vanishes."""
    w = np.array([s.info["forcing_omega"] if "forcing_omega" in s.info else 2 * s.omega for s in sols])
    y = np.array([s.info["contact_margins"][0][key] for s in sols])
    a, b = np.polyfit(w, y, 1)
    return -b / a


@pytest.mark.slow
def test_event_period_2_branch_of_the_impact_chain_passes_its_grazing(impact5):
    """The period-2 branch of the impact chain from pi/5: its second impact per 2T loses its velocity
    at omega_g = 0.63935 (a grazing), and the branch goes on with one impact per 2T (a near miss there) to 0.7.
    The event-driven sweep used to stop at 0.63935 (the corrector cycled between the two impact sequences,
    the tangent pointed back after the corner, and a central dR/domega straddled the grazing: spurious
    folds).  Now it reaches 0.7, reports the grazing (bisection) within 1e-3 of omega_g from each side's
    own linear test function (near-miss gap, impact velocity; both fits agree to 1e-5, the impact velocity
    being linear only close to it), no fold there, and the reverse sweep from 0.7 passes the same grazing."""
    opts = dict(integrator="event", steps=2048)
    b = mshbm.sweep(impact5, np.pi / 5, 0.7, "shooting", period=2, **opts)
    assert b.success, b.message
    assert b.omega[-1] == pytest.approx(0.7)
    n_imp = [p.solution.info["contact_margins"][0]["impacts"] for p in b.points]
    assert n_imp[0] == 2 and n_imp[-1] == 1
    # omega_g from solves at fixed omega on each side (not from the sweep's bisection)
    guess_1 = next(p.solution for p in b.points if p.omega > 0.642)
    guess_2 = next(p.solution for p in b.points[::-1] if p.omega < 0.6392)
    one = [solve_period(impact5, w, "shooting", period=2, guess=guess_1, **opts) for w in (0.6396, 0.6400)]
    two = [solve_period(impact5, w, "shooting", period=2, guess=guess_2, **opts) for w in (0.6392, 0.6393)]
    assert all(s.success for s in one + two)
    assert [s.info["contact_margins"][0]["impacts"] for s in one + two] == [1, 1, 2, 2]
    w_miss, w_v = _grazing_reference(impact5, one, "miss"), _grazing_reference(impact5, two, "v_min")
    assert w_miss == pytest.approx(w_v, rel=1e-5)
    assert 0.6390 < w_miss < 0.6396
    graz = [f for f in b.bifurcations if f["type"] == "grazing"]
    assert len(graz) == 1
    assert graz[0]["omega"] == pytest.approx(w_miss, rel=1e-3)
    assert not [f for f in b.bifurcations if f["type"] == "fold" and 0.636 < f["omega"] < 0.642]
    assert b.counters.get("kinks", 0) + b.counters.get("kink_crossings", 0) >= 1
    # the reverse sweep approaches the corner from the one-impact side (the hyperplane of the arclength
    # corrector misses the two-impact piece there: a step at fixed omega crosses it)
    r = mshbm.sweep(impact5, 0.7, np.pi / 5, "shooting", period=2, guess=b.points[-1].solution, **opts)
    assert r.success, r.message
    graz_r = [f for f in r.bifurcations if f["type"] == "grazing"]
    assert len(graz_r) == 1 and graz_r[0]["omega"] == pytest.approx(w_miss, rel=1e-3)
    assert r.amplitude[-1, 0] == pytest.approx(b.amplitude[0, 0], rel=1e-6)


@pytest.mark.slow
def test_period_option_of_sweep_reports_forcing_frequency(impact5, period_2_at_pi_over_5):
    # n_h = 10 per forcing period, as the reference solve_period (period_2_at_pi_over_5); the points' error
    # estimates (accuracy) are not asserted here (tests/integration/test_sweep_accuracy.py): off, the points and
    # bifurcations are the same.  The sweep starts from the reference (its first point is solve_period's, the
    # default-start chain that the fixture's test covers; from the default start as well the branch's points agree
    # with these to 3e-10, at 26 s CPU instead of 7): its first point then says that the sweep solves the
    # same problem (n_h per forcing period, the base frequency) as solve_period
    ref = period_2_at_pi_over_5
    b = mshbm.sweep(impact5, np.pi / 5, 0.64, "mshbm", period=2, harmonics=10, max_points=6, accuracy=False,
                    guess=ref)
    assert b.period == 2 and len(b) >= 2
    assert b.omega[0] == pytest.approx(np.pi / 5)
    np.testing.assert_allclose(b.amplitude[0], ref.amplitude, rtol=1e-8)
    # bifurcations are reported at the forcing frequency too (they used to be at omega / period)
    assert all(min(b.omega) * (1 - 1e-6) <= f["omega"] <= max(b.omega) * (1 + 1e-6) for f in b.bifurcations)


# ----------------------------------------------------------------------------- CLI
def _run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_sweep_json_and_plot(tmp_path, capsys):
    case = tmp_path / "dh.yaml"
    case.write_text("name: dh\nmasses: [1]\nstiffness: 1\ndamping: 0.1\nomega: 2\n"
                    "forcing:\n  - {dof: 0, amplitude: 1}\nfriction: {dof: 0, mu: 1, normal_force: 0.3}\n")
    out, png = tmp_path / "b.json", tmp_path / "b.png"
    code, stdout, err = _run(["sweep", case, "--method", "shooting", "--omega-start", 1.5, "--omega-end", 2.5,
                              "--steps", 2048, "--out", out, "--plot", png], capsys)
    assert code == 0, err
    data = json.loads(out.read_text())
    assert data["success"] is True and isinstance(data["message"], str)
    assert data["omega"][0] == 1.5 and data["omega"][-1] == 2.5
    assert len(data["amplitude"]) == len(data["omega"]) == len(data["stable"]) and len(data["amplitude"][0]) == 1
    assert isinstance(data["bifurcations"], list)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_sweep_dlft(tmp_path, capsys):
    out = tmp_path / "b.json"
    code, stdout, err = _run(["sweep", ROOT / "examples" / "friction3.yaml", "--method", "dlft", "--omega-start", 0.7,
                              "--omega-end", 1.0, "--harmonics", 9, "--out", out], capsys)
    # DLFT at n_H = 9 is up to 8.7 % off MS-HBM here (test_dlft_branch_of_the_friction_chain_against_mshbm): the
    # branch reaches its end, its points are reported above the default accuracy, exit 1
    assert code == 1 and "sweep reached the end, but not every point is certified" in err, err
    data = json.loads(out.read_text())
    assert data["success"] is False and data["accuracy"]["reached_end"] and data["omega"][-1] == pytest.approx(1.0)
    assert data["accuracy"]["largest"]["estimate"] > 0.01 and len(data["amplitude"][0]) == 3


@pytest.mark.parametrize("argv,key", [
    (["--omega-start", -1, "--omega-end", 2], "--omega-start"),
    (["--omega-start", 1, "--omega-end", 2, "--period", 0], "--period"),
    (["--omega-start", 1, "--omega-end", 2, "--dofs", 7], "--dofs"),
    (["--omega-start", 1, "--omega-end", 1], "--omega-end"),
])
def test_cli_sweep_bad_input_exit_2(argv, key, tmp_path, capsys):
    code, out, err = _run(["sweep", ROOT / "examples" / "impact5.yaml"] + argv, capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {key}:")


def test_cli_sweep_early_stop_exit_1(tmp_path, capsys):
    out = tmp_path / "b.json"
    code, _, err = _run(["sweep", ROOT / "examples" / "impact5.yaml", "--method", "shooting", "--steps", 1024,
                         "--omega-start", 0.6, "--omega-end", 0.9, "--max-points", 3, "--out", out, "--quiet"], capsys)
    assert code == 1 and err.startswith("error: sweep stopped early")
    data = json.loads(out.read_text())
    assert data["success"] is False and len(data["omega"]) == 3


def test_cli_sweep_event_integrator_locates_the_period_doubling(tmp_path, capsys):
    """``--integrator event`` reaches the sweep: with the exact event-driven flow shooting and MS-HBM trace the
    impact chain's T-periodic branch through its period doubling and locate it at the same frequency (0.1 %;
    with Moreau-Jean steps the impacts move by whole steps and the located point shifts by about 0.2 %)."""
    pd = {}
    for method, extra in (("shooting", []), ("mshbm", ["--harmonics", 5])):
        out = tmp_path / f"{method}.json"
        code, _, err = _run(["sweep", ROOT / "examples" / "impact5.yaml", "--method", method, "--integrator",
                             "event", "--steps", 512, *extra, "--omega-start", 0.6, "--omega-end", 0.63,
                             "--out", out, "--quiet"], capsys)
        assert code == 0, err
        data = json.loads(out.read_text())
        assert data["success"] is True and data["omega"][-1] == pytest.approx(0.63)
        pds = [b["omega"] for b in data["bifurcations"] if b["type"] == "period-doubling"]
        assert len(pds) == 1, data["bifurcations"]
        pd[method] = pds[0]
        st = data["stable"]  # stable below the period doubling, unstable above it
        assert st[0] is True and st[-1] is False
    assert 0.6 < pd["shooting"] < 0.63
    assert pd["mshbm"] == pytest.approx(pd["shooting"], rel=1e-3)


def test_sweep_figure_styles_per_dof_and_stability():
    """Each DOF keeps its colour whatever the verdict; solid stable, dashed unstable, dotted undecided (one
    polyline per run); a segment between different verdicts is undecided."""
    import matplotlib.pyplot as plt
    from types import SimpleNamespace

    from mshbm.cli_sweep import figure

    w = np.linspace(1.0, 2.0, 7)
    A = np.column_stack([w, 2 * w])
    br = SimpleNamespace(omega=w, amplitude=A, stable=[True, True, True, False, False, None, None],
                         bifurcations=[{"type": "fold", "omega": 1.5}])
    fig = figure(br, [0, 1])
    lines = [ln for ln in fig.axes[0].lines if len(ln.get_xdata()) > 1]
    assert len(lines) == 2 * 4  # per DOF: stable run, the True->False segment, unstable run, undecided tail
    for d in (0, 1):
        mine = [ln for ln in lines if np.allclose(ln.get_ydata(), A[:, d][np.searchsorted(w, ln.get_xdata())])]
        assert [ln.get_linestyle() for ln in mine] == ["-", ":", "--", ":"]
        assert len({ln.get_color() for ln in mine}) == 1
    assert lines[0].get_color() != lines[4].get_color()
    plt.close(fig)
