"""Frequency sweeps of the impact oscillator across its corners, against closed forms (tests/closed_forms.py).

``x'' + 2 zeta x' + x = cos(omega t)`` with a stop at ``sigma`` and restitution ``r``, by the exact event-driven
flow (shooting and MS-HBM, ``integrator="event"``):

* ``zeta = 0.05, sigma = 1, r = 0.8`` swept down from 1.8: the non-impacting branch (the linear response,
  amplitude ``|G|``) grazes the stop at ``|G| = 1``, ``omega_g = sqrt(1.99)``, where the impacting (1,1) branch
  leaves it *back to higher omega* (a corner of the branch, no fold) up to its fold near 1.75;
* ``zeta = 0.1, sigma = 0.2, r = 0.9`` and ``0.7`` swept up from 0.7: orbits with two impacts per period up to a
  fold, back to a grazing where the second impact vanishes (the (1,1) orbit's near miss touches the stop: the
  closed form's interior maximum of the free flight equals ``sigma``), then the (1,1) branch, whose impact
  crosses the section ``t = 0`` of the shooting unknowns near ``omega = 1.004`` (the unknowns jump from the
  state after the impact to the one before it, while the orbit moves on continuously).
"""
import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

import closed_forms as cf
import mshbm
from mshbm import Contact, chain

EVENT = dict(integrator="event", steps=2048)


def _oscillator(zeta, sigma, r):
    return chain([1.0], 1.0, 2.0 * zeta, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Contact(0, sigma, r)])


def _impacts(point):
    return point.solution.info["contact_margins"][0]["impacts"]


def _amplitude_11(omega, zeta, sigma, r):
    """Amplitudes of the admissible (1,1) orbits at ``omega`` (closed form)."""
    return [cf.amplitude(omega, t0, v, zeta, sigma, r) for t0, v in cf.orbit_11(omega, zeta, sigma, r)
            if cf.admissible(omega, t0, v, zeta, sigma, r)]


def _near_miss_11(omega, zeta, sigma, r):
    """``sigma`` minus the largest interior maximum of the free flight of the (1,1) orbit with ``v > 0``."""
    (t0, v), = [o for o in cf.orbit_11(omega, zeta, sigma, r) if o[1] > 0]
    T = 2.0 * np.pi / omega
    tt = np.linspace(t0, t0 + T, 4001)[1:-1]
    x, xd = cf.free_flight(tt, t0, v, omega, zeta, sigma, r)
    peaks = np.nonzero((xd[:-1] > 0) & (xd[1:] <= 0))[0]
    k = peaks[np.argmax(x[peaks])]
    res = minimize_scalar(lambda t: -cf.free_flight(t, t0, v, omega, zeta, sigma, r)[0], bounds=(tt[k - 1], tt[k + 2]),
                          method="bounded", options={"xatol": 1e-13})
    return sigma + res.fun


@pytest.fixture(scope="module")
def grazing_branch():
    """The impact oscillator (zeta 0.05, stop at 1, e 0.8) swept down from 1.8 to 1.3 by event-driven shooting
    with the default grazing budget: one sweep for the two tests that read it."""
    system = _oscillator(0.05, 1.0, 0.8)
    return system, mshbm.sweep(system, 1.8, 1.3, "shooting", **EVENT)


def test_grazing_corner_located_on_the_branch_where_it_happens(grazing_branch):
    """Swept down from 1.8: the grazing at sqrt(1.99) = 1.4106736 lies *outside* the omega interval of the two
    points around it (1.4237 non-impacting, 1.4331 impacting: the branch turns back there).  It used to be
    'located' at 1.4331 (bisection at the middle frequency of that interval) and the corner reported as a fold.
    Now it is located on each side's own piece (measured error 2e-7), no fold at the corner; the points agree
    with the closed forms: |G| without impacts, the (1,1) orbit with them, and the contact is reported active
    exactly at the impacting points."""
    zeta, sigma, r = 0.05, 1.0, 0.8
    _, b = grazing_branch
    assert b.success, b.message
    graz = [f for f in b.bifurcations if f["type"] == "grazing"]
    assert len(graz) == 1 and graz[0]["located"] == "bisection"
    assert abs(graz[0]["omega"] - np.sqrt(1.99)) < 1e-5
    folds = [f["omega"] for f in b.bifurcations if f["type"] == "fold"]
    assert len(folds) == 1 and 1.74 < folds[0] < 1.76  # the impacting branch's own fold, none at the corner
    n_imp = [_impacts(p) for p in b.points]
    assert n_imp[0] == 0 and n_imp[-1] == 1 and sorted(n_imp) == n_imp  # one corner, no return
    for p, k in zip(b.points, n_imp):
        assert p.contact[0]["active"] == (k > 0)
        if k == 0:
            G = 1.0 / abs(1.0 - p.omega ** 2 + 2j * zeta * p.omega)
            assert p.amplitude[0] == pytest.approx(G, rel=1e-8)
        else:
            ref = _amplitude_11(p.omega, zeta, sigma, r)
            assert min(abs(p.amplitude[0] / a - 1.0) for a in ref) < 1e-6


@pytest.mark.parametrize("r, method", [(0.9, "shooting"), (0.7, "shooting"), (0.9, "mshbm"), (0.7, "mshbm")])
def test_sweep_passes_an_impact_crossing_the_section(r, method):
    """Swept up from 0.7 to 1.6, both methods used to stop at omega = 1.004-1.008, where the (1,1) orbit's impact
    crosses t = 0: the unknowns (the state at t = 0) jump there, no arclength step nor a step at fixed omega
    from the last point reaches the other side.  A step at fixed omega from the state extrapolated to the
    section from the other side of the impact crosses it (counter ``restarts``).  The (1,1) points agree with
    the closed form (amplitude to 1e-6) and with pointwise solves; the grazing where the second impact
    vanishes is located to 1e-4 of the closed form's (near miss = 0), with no fold at that corner."""
    zeta, sigma = 0.1, 0.2
    s = _oscillator(zeta, sigma, r)
    b = mshbm.sweep(s, 0.7, 1.6, method, **EVENT)
    assert b.success, b.message
    assert b.omega[-1] == pytest.approx(1.6)
    assert b.counters.get("restarts", 0) >= 1
    one = [p for p in b.points if _impacts(p) == 1]
    assert len(one) >= 10 and min(p.omega for p in one) < 1.0 < max(p.omega for p in one)
    for p in one:
        ref = _amplitude_11(p.omega, zeta, sigma, r)
        assert min(abs(p.amplitude[0] / a - 1.0) for a in ref) < 1e-6
    for p in one[-1::-len(one) // 3]:  # pointwise solves at a few of them
        ref = mshbm.solve(s, p.omega, method, accuracy=False, **EVENT)
        assert ref.success and p.amplitude[0] == pytest.approx(ref.amplitude[0], rel=1e-8)
    w_g = brentq(lambda w: _near_miss_11(w, zeta, sigma, r), 0.85, 0.95, xtol=1e-12)
    graz = [f["omega"] for f in b.bifurcations if f["type"] == "grazing"]
    assert len(graz) == 1 and abs(graz[0] - w_g) < 1e-4
    folds = [f["omega"] for f in b.bifurcations if f["type"] == "fold"]
    assert len(folds) == 1 and folds[0] > graz[0] + 0.01  # the two-impact branch's fold only


def test_arclength_bridges_a_jump_of_the_branch_by_a_natural_parameter_step():
    """x = lam for lam < 0.5 and x = lam + 1 beyond: the arclength corrector cannot pass the jump, nor a step at
    fixed lam within the jump guard.  The continuation used to stop there; now one natural-parameter step (Newton
    at fixed lam from the last point) bridges it, the gap is recorded (kink ``"gap"``, counter ``gaps``, the
    message), and arclength steps go on to the end; every point solves the equation."""
    from mshbm.solvers.arclength import continuation

    f = lambda lam: lam + (1.0 if lam >= 0.5 else 0.0)  # noqa: E731
    res = continuation(lambda x, lam: (np.array([x[0] - f(lam)]), np.array([[1.0]])),
                       lambda x, lam: np.array([-1.0]), np.array([0.0]), 0.0, 1.0,
                       residual_scale=lambda x, lam: np.ones(1), unknown_scale=lambda x, lam: np.ones(1),
                       lam_scale=1.0, ds0=0.05)
    assert res.success, res.message
    assert res.points[-1].lam == 1.0 and res.points[-1].x[0] == pytest.approx(2.0, abs=1e-12)
    for p in res.points:
        assert p.x[0] == pytest.approx(f(p.lam), abs=1e-10)
    gaps = [k for k in res.kinks if k.get("gap")]
    assert len(gaps) == 1 and res.counters["gaps"] == 1
    assert gaps[0]["lam"] < 0.5 <= gaps[0]["lam_right"] < 0.5 + 0.05
    assert "gap(s) bridged" in res.message and res.folds == []
    off = continuation(lambda x, lam: (np.array([x[0] - f(lam)]), np.array([[1.0]])),
                       lambda x, lam: np.array([-1.0]), np.array([0.0]), 0.0, 1.0,
                       residual_scale=lambda x, lam: np.ones(1), unknown_scale=lambda x, lam: np.ones(1),
                       lam_scale=1.0, ds0=0.05, natural_fallback=False)
    assert not off.success and off.points[-1].lam < 0.5  # without the fallback it stops at the jump


def test_damper2d_sweep_reports_no_spurious_folds():
    """examples/damper2d.yaml with its MS-HBM settings (n_h = 15, 2048 Moreau-Jean steps) from 0.6: between 0.62
    and 0.65 the corrector accepted points at step accuracy only (residual up to 8e-3) that lay off the curve
    (up to 1.2 % in the blade's amplitude, 1 % ahead in omega), so that the omega sequence went back once and
    on again; that was reported as two folds (0.6406 and 0.6308).  Now such a point is first solved exactly at
    its omega (Newton with a line search from the last point; counter ``stall_solved``), and a reversal at
    step-accuracy points is a fold only when the next point keeps it: no fold, every point but the end point
    exact (measured: 12 points on 0.6 -> 0.7; the whole 0.6 -> 1.2 in 88 points, 51 s CPU, no fold, within
    0.41 % of pointwise solves from their default start).  The exact points agree with pointwise solves (blade
    amplitude, 0.5 %: measured 0.16 % at most; a stuck damper's offset is not unique)."""
    from mshbm.io import load_case

    case = load_case(__import__("pathlib").Path(__file__).resolve().parents[2] / "examples" / "damper2d.yaml")
    opts = dict(harmonics=15, steps=2048)
    b = mshbm.sweep(case.model, 0.6, 0.7, "mshbm", **opts)
    assert b.success, b.message
    assert b.omega[-1] == pytest.approx(0.7)
    assert [f for f in b.bifurcations if f["type"] == "fold"] == []
    assert all(p.certificate["passed"] for p in b.points)
    exact = [p for p in b.points if p.residual <= 1e-8 and 0.6 < p.omega < 0.7]
    assert b.counters.get("stall_solved", 0) >= 1 and len(exact) >= 6
    assert sum(p.residual > 1e-8 for p in b.points) <= 2  # measured 1 (the end point, 5e-5)
    for p in exact[1::2]:
        ref = mshbm.solve(case.model, p.omega, "mshbm", accuracy=False, **opts)
        assert ref.success and p.amplitude[0] == pytest.approx(ref.amplitude[0], rel=5e-3)


def test_point_reports_the_gap_of_a_relative_contact():
    """A contact between two DOFs (gap 5, never reached) on a linear 2-DOF chain: the sweep point's ``min_gap``
    is ``gap + min_t sign (q_0 - q_1)`` = ``gap - |Q_0 - Q_1|`` of the linear response (it used to take
    ``gap - max q_0``), and the contact is reported inactive."""
    gap = 5.0
    s = chain([1.0, 1.0], [1.0, 1.0], 0.05, forcing=[{"dof": 1, "amplitude": 1.0}],
              elements=[Contact(0, gap, 0.8, relative_to=1)])
    br = mshbm.sweep(s, 0.3, 0.45, method="hbm", harmonics=3, stability=False, max_points=400)
    assert br.success and len(br) >= 2
    for p in br.points:
        w = float(p.omega)
        H = np.asarray(s.K) - w * w * np.asarray(s.M) + 1j * w * np.asarray(s.C)
        Q = np.linalg.solve(H, np.array([0.0, 1.0]))
        rec = p.contact[0]
        assert rec["min_gap"] == pytest.approx(gap - abs(Q[0] - Q[1]), abs=2e-3 * abs(Q[0] - Q[1]))
        assert not rec["active"]
        # the old formula gap - max q_0 differs by more than the tolerance here
        assert abs(rec["min_gap"] - (gap - abs(Q[0]))) > 1e-2


def test_grazing_location_within_its_budget(grazing_branch, monkeypatch):
    """The grazing bisection spends at most its budget (branch.LOCATE_SHARE of the trace's work, at least
    LOCATE_FLOOR residual evaluations).  With the default the corner's grazing is located to 1e-5 (test above)
    within it; with no budget at all the same sweep gives the same points, places the grazing by interpolation
    between its two branch points (around the corner sqrt(1.99) lies outside their omega interval: 0.02 off)
    and says in its message that the location stopped at its budget."""
    from mshbm import branch as branch_mod

    system, full = grazing_branch
    assert "budget" not in full.message
    monkeypatch.setattr(branch_mod, "LOCATE_FLOOR", 0)
    monkeypatch.setattr(branch_mod, "LOCATE_SHARE", 0.0)
    b = mshbm.sweep(system, 1.8, 1.3, "shooting", **EVENT)
    assert b.success and "grazings located to the brackets reached within their budget" in b.message, b.message
    assert np.array_equal(b.omega, full.omega)
    graz, = [f for f in b.bifurcations if f["type"] == "grazing"]
    graz_full, = [f for f in full.bifurcations if f["type"] == "grazing"]
    assert graz["located"] == "interpolation" and graz["index"] == graz_full["index"]
    i = graz["index"]
    lo, hi = sorted((b.omega[i], b.omega[i + 1]))
    assert lo <= graz["omega"] <= hi
    assert 0.01 < abs(graz["omega"] - np.sqrt(1.99)) < 0.03



def test_a_wild_grazing_extrapolation_is_no_estimate(grazing_branch, monkeypatch):
    """A side's test function that is nearly flat extrapolates its grazing far away (beam-stop-cb by event shooting:
    omega = -1.4e5 rad/s from points near 1080 rad/s; the locator solved there and the sweep ended in an InputError
    after its trace).  Such an extrapolation (farther than half the frequency from the side's nearest point) is
    none: with every side's test function made nearly flat the same sweep gives the same points and places the
    grazing between its branch points (bisected at the bracket's middle), not at the absurd extrapolation."""
    from mshbm import bifurcations

    system, full = grazing_branch
    real = bifurcations._side_value

    def flat(kind, p, other):
        v = real(kind, p, other)
        return None if v is None else 1.0 + 1e-9 * v  # a zero far away, at about 1e9 / slope

    monkeypatch.setattr(bifurcations, "_side_value", flat)
    b = mshbm.sweep(system, 1.8, 1.3, "shooting", **EVENT)
    assert b.success, b.message
    assert np.array_equal(b.omega, full.omega)
    graz = [f for f in b.bifurcations if f["type"] == "grazing"]
    assert graz and all(1.3 <= g["omega"] <= 1.8 for g in graz), graz
