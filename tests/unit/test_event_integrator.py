"""The event-driven integrator for any number of elements (mshbm.integrators.event) against closed forms.

* Budd & Dux (1,1) impact orbit of ``x'' + 2 zeta x' + x = cos(omega t)`` with a stop (tests/closed_forms.py):
  impact time, approach velocity, amplitude and Floquet multipliers (the impact map's Jacobian);
* Den Hartog's undamped Coulomb oscillator in continuous motion, ``X = sqrt(V^2 - (r U)^2)``;
* two uncoupled impact oscillators with different gaps in ONE system (two contacts, events at different
  times): each DOF matches its own closed form, the multipliers are the union of both;
* 2-DOF symmetric systems (two stops, two friction elements) whose in-phase orbit has simultaneous events
  at both elements: each DOF matches the 1-DOF closed form (the coupling spring is never stretched);
* accumulation of impacts (``e_N < 1``): the integrator switches to Moreau-Jean and says so;
* the saltation-corrected monodromy of 2-element flows against central differences of the flow.

Measured numbers (this machine) are in the comments next to the asserted tolerances.
"""
import math
import time

import numpy as np
import pytest

import closed_forms as cf
import mshbm
from mshbm import Contact, Friction, InputError, System, chain
from mshbm.integrators.event import MOREAU, EventError, EventFlow
from mshbm.methods.exact import exact_periodic

OMEGA_BD = 2.3  # stable (1,1) orbit, multipliers 0.1447 +- 0.6827i (closed form)


def den_hartog_amplitude(beta, r):
    """Den Hartog (1931): undamped ``x'' + x = cos(beta t) - r sign(x')`` in continuous motion."""
    V = 1.0 / (1.0 - beta ** 2)
    U = math.sin(math.pi / beta) / (beta * (1.0 + math.cos(math.pi / beta)))
    return math.sqrt(V ** 2 - (r * U) ** 2)


def _harmonic_system(K, C, elements, forced=(0, 1)):
    n = K.shape[0]
    fh = np.zeros((3, n))
    fh[1, list(forced)] = 1.0
    return System(np.eye(n), C, K, fh, elements)


def _impacts(events, element):
    return [e for e in events if e.impulse > 0.0 and e.element == element]


# ----------------------------------------------------------------------------- Budd & Dux
@pytest.mark.slow
def test_budd_dux_11_orbit_shooting_and_exact():
    t0, v = cf.stable_orbit(OMEGA_BD)
    mu_cf = cf.multipliers(OMEGA_BD, t0, v)
    A_cf = cf.amplitude(OMEGA_BD, t0, v)
    s = cf.system()
    sol = mshbm.solve(s, OMEGA_BD, "shooting", integrator="event", steps=1024)
    assert sol.success, sol.message
    imp = [e for e in sol.info["event_list"] if e.impulse > 0]
    assert len(imp) == 1
    # measured: 2.9e-15 (time), 5.2e-15 (velocity), 4.5e-15 (amplitude), 4.9e-15 (multipliers)
    assert abs(imp[0].t - t0) <= 1e-10
    assert abs(-imp[0].velocity - v) <= 1e-10 * v
    assert abs(sol.amplitude[0] - A_cf) <= 1e-9 * A_cf
    np.testing.assert_allclose(np.sort_complex(sol.info["event_multipliers"]), mu_cf, atol=1e-9)
    # the periodic time series against the closed-form free flight
    T = 2 * np.pi / OMEGA_BD
    t = sol.t
    x_cf = np.where(t < t0, cf.free_flight(t, t0 - T, v, OMEGA_BD)[0], cf.free_flight(t, t0, v, OMEGA_BD)[0])
    assert np.abs(sol.q[:, 0] - x_cf).max() <= 1e-10  # measured 5e-15
    # Moreau-Jean at the same number of steps is first order at the impact (measured 2.6e-3 relative); its
    # one-step acceptance (h J = 3.3e-3 D) is not certified (certificate check step_accuracy_size, bound 2e-3),
    # and without integrator='moreau' solve ends with the exact event-driven integrator
    mj = mshbm.solve(s, OMEGA_BD, "shooting", steps=1024, integrator="moreau")
    assert not mj.success and "step_accuracy_size" in mj.message
    assert abs(mj.amplitude[0] - A_cf) > 1e3 * abs(sol.amplitude[0] - A_cf)
    fb = mshbm.solve(s, OMEGA_BD, "shooting", steps=1024)
    assert fb.success and fb.info["integrator"] == "event" and abs(fb.amplitude[0] - A_cf) <= 1e-9 * A_cf
    # the exact reference solver, now on the same engine
    ex = exact_periodic(s, OMEGA_BD, sol)
    assert ex.success and abs(ex.info["amplitude_exact"][0] - A_cf) <= 1e-9 * A_cf
    # MS-HBM with the event integrator (the element DOF is the whole system: no truncation error left)
    ms = mshbm.solve(s, OMEGA_BD, "mshbm", harmonics=5, integrator="event", steps=512)
    assert ms.success, ms.message
    imp = [e for e in ms.info["event_list"] if e.impulse > 0]
    assert len(imp) == 1 and abs(imp[0].t - t0) <= 1e-10  # measured 3.3e-15
    assert abs(ms.amplitude[0] - A_cf) <= 1e-9 * A_cf  # measured 2.6e-15 (absolute)


# ----------------------------------------------------------------------------- Den Hartog
def test_den_hartog_coulomb_oscillator():
    beta, r = 0.6, 0.3
    X = den_hartog_amplitude(beta, r)
    s = chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Friction(0, 1.0, r)])
    sol = mshbm.solve(s, beta, "shooting", integrator="event", steps=1024)
    assert sol.success, sol.message
    kinds = sorted(e.kind for e in sol.info["event_list"])
    assert kinds == ["slip+->slip-", "slip-->slip+"]  # continuous motion: the formula applies
    assert abs(sol.amplitude[0] / X - 1.0) <= 1e-9  # measured 5.2e-13
    # the extrema of the half-period symmetric orbit: q_max = -q_min = X
    assert abs(sol.info["q_max"][0] - X) <= 1e-9 * X and abs(sol.info["q_min"][0] + X) <= 1e-9 * X
    mj = mshbm.solve(s, beta, "shooting", steps=1024)
    assert abs(mj.amplitude[0] / X - 1.0) > 1e-5  # Moreau-Jean on 1024 steps: measured 3.3e-4
    ms = mshbm.solve(s, beta, "mshbm", harmonics=5, integrator="event", steps=512)
    assert ms.success, ms.message
    assert abs(ms.amplitude[0] / X - 1.0) <= 1e-9  # measured 5.2e-13


# ----------------------------------------------------------------------------- two elements, different times
@pytest.fixture(scope="module")
def two_stops():
    zeta, sig = cf.ZETA, (0.1, 0.15)
    s = _harmonic_system(np.eye(2), 2 * zeta * np.eye(2), [Contact(0, sig[0], cf.R), Contact(1, sig[1], cf.R)])
    orbits = [cf.stable_orbit(OMEGA_BD, sigma=g) for g in sig]
    sol = mshbm.solve(s, OMEGA_BD, "shooting", integrator="event", steps=2048)
    assert sol.success, sol.message
    return s, sig, orbits, sol


def test_two_uncoupled_impact_oscillators_with_different_gaps(two_stops):
    s, sig, orbits, sol = two_stops
    T = 2 * np.pi / OMEGA_BD
    t = sol.t
    ev = sol.info["event_list"]
    for j, (g, (t0, v)) in enumerate(zip(sig, orbits)):
        imp = _impacts(ev, j)
        assert len(imp) == 1
        # measured (DOF 0 / DOF 1, the second at Newton's tolerance): time 2.4e-15 / 6.4e-12, velocity
        # 1.3e-15 / 3.3e-11, time series 2.9e-15 / 1.7e-11, amplitude 1.9e-15 / 2.2e-11
        assert abs(imp[0].t - t0) <= 1e-9 and abs(-imp[0].velocity - v) <= 1e-9 * v
        x_cf = np.where(t < t0, cf.free_flight(t, t0 - T, v, OMEGA_BD, sigma=g)[0],
                        cf.free_flight(t, t0, v, OMEGA_BD, sigma=g)[0])
        assert np.abs(sol.q[:, j] - x_cf).max() <= 1e-9
        A = cf.amplitude(OMEGA_BD, t0, v, sigma=g)
        assert abs(sol.amplitude[j] - A) <= 1e-9 * A
    # the events fall at different times (1.2564 and 1.2884 s)
    assert abs(_impacts(ev, 0)[0].t - _impacts(ev, 1)[0].t) > 0.02
    # block-diagonal flow: the multipliers are those of both closed forms
    mu_cf = np.sort_complex(np.concatenate([cf.multipliers(OMEGA_BD, *o, sigma=g) for g, o in zip(sig, orbits)]))
    np.testing.assert_allclose(np.sort_complex(sol.info["event_multipliers"]), mu_cf, atol=1e-9)  # measured 3e-11


# ----------------------------------------------------------------------------- simultaneous events
def test_simultaneous_impacts_of_a_symmetric_2dof_system():
    """Two equal oscillators coupled by a spring k_c, both forced by cos(omega t), stops at the same gap: the
    in-phase orbit never stretches the spring, so each DOF is the 1-DOF (1,1) orbit and both stops are hit
    at the same instant (one impact LCP with two contacts)."""
    kc, zeta = 0.5, cf.ZETA
    K = np.array([[1 + kc, -kc], [-kc, 1 + kc]])
    s = _harmonic_system(K, 2 * zeta * np.eye(2), [Contact(0, cf.SIGMA, cf.R), Contact(1, cf.SIGMA, cf.R)])
    t0, v = cf.stable_orbit(OMEGA_BD)
    ex = exact_periodic(s, OMEGA_BD, {"q0": [-0.2, -0.2], "u0": [0.0, 0.0], "t0": 0.0})
    assert ex.success, ex.message
    i0, i1 = _impacts(ex.info["events"], 0), _impacts(ex.info["events"], 1)
    assert len(i0) == len(i1) == 1
    assert i0[0].t == i1[0].t  # one event for both contacts
    assert abs(i0[0].t - t0) <= 1e-10 and abs(-i0[0].velocity - v) <= 1e-10 * v  # measured 1.1e-14, 4.7e-14
    A = cf.amplitude(OMEGA_BD, t0, v)
    np.testing.assert_allclose(ex.info["amplitude_exact"], [A, A], rtol=1e-9)  # measured 3.8e-14
    # the in-phase subspace is invariant: the closed-form multipliers are among the monodromy's
    mu = ex.info["floquet_multipliers"]
    for m in cf.multipliers(OMEGA_BD, t0, v):
        assert np.min(np.abs(mu - m)) <= 1e-9


def test_simultaneous_slip_reversals_of_a_symmetric_2dof_friction_system():
    beta, r, kc = 0.6, 0.3, 0.7
    X = den_hartog_amplitude(beta, r)
    K = np.array([[1 + kc, -kc], [-kc, 1 + kc]])
    s = _harmonic_system(K, np.zeros((2, 2)), [Friction(0, 1.0, r), Friction(1, 1.0, r)])
    sol = mshbm.solve(s, beta, "shooting", integrator="event", steps=1024)
    assert sol.success, sol.message
    ev = sol.info["event_list"]
    assert len(ev) == 4 and ev[0].t == ev[1].t and ev[2].t == ev[3].t  # both elements at once, twice
    assert {e.element for e in ev} == {0, 1}
    np.testing.assert_allclose(sol.amplitude, [X, X], rtol=1e-9)  # measured 5.2e-13


# ----------------------------------------------------------------------------- accumulation
def test_accumulation_switches_to_moreau_jean_and_says_so():
    """A mass pressed on a stop (e_N = 0.5, damped) lifts off once per period and comes back with an
    accumulation of impacts: the integrator continues with Moreau-Jean for that contact phase."""
    s = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.5, "constant": 1.0}],
              elements=[Contact(0, 0.3, 0.5)])
    fl = EventFlow(s, 1.0)  # accumulation="moreau" is the default of the integrator
    z0 = fl.state(0.0, np.array([0.3]), np.array([0.0]))
    out = fl.simulate(0.0, z0, duration=2 * fl.T, jac=True)
    assert out.switched and not out.monodromy_exact
    assert "Moreau-Jean" in out.message and "accumulation of impacts" in out.message
    seg = out.moreau_segments[0]
    assert seg["t_start"] < seg["t_end"] and seg["steps"] > 0
    # against the exact Zeno closure of the same flow: Moreau-Jean's error over that phase only
    ref = EventFlow(s, 1.0, accumulation="close").simulate(0.0, z0, duration=2 * fl.T)
    assert not ref.switched
    assert np.abs(out.end_state[:2] - ref.end_state[:2]).max() <= 1e-4  # measured 2.2e-7 (4096 steps per period)
    # accumulation="error": a clear error instead
    with pytest.raises(EventError, match="accumulation of impacts"):
        EventFlow(s, 1.0, accumulation="error").simulate(0.0, z0, duration=2 * fl.T)
    # shooting reports it in the solution
    sol = mshbm.solve(s, 1.0, "shooting", integrator="event", steps=1024,
                      guess={"q_hat": np.zeros((3, 1)), "q0": [0.3], "u0": [0.0]})
    assert sol.success, sol.message
    info = sol.info["event_integrator"]
    assert info["switched_to_moreau"] and "Moreau-Jean" in info["message"] and not info["monodromy_exact"]
    ex = exact_periodic(s, 1.0, {"q0": [0.3], "u0": [0.0]})
    assert abs(sol.amplitude[0] / ex.info["amplitude_exact"][0] - 1) <= 1e-4  # measured 8.5e-6
    assert np.all(np.isfinite(sol.lam))


def test_ball_accumulation_in_moreau_mode_and_event_cap():
    G, H = 9.81, 0.5
    s = chain([1.0], 0.0, 0.0, forcing=[{"dof": 0, "amplitude": 0.0, "constant": G}],
              elements=[Contact(0, 0.0, 0.5)])
    fl = EventFlow(s, 1.0)
    out = fl.simulate(0.0, fl.state(0.0, np.array([-H]), np.array([0.0])), duration=2.0)
    t_inf = math.sqrt(2 * H / G) * (1 + 2 * 0.5 / (1 - 0.5))  # Zeno time
    seg = out.moreau_segments[0]
    assert seg["t_start"] < t_inf and seg["t_end"] == pytest.approx(2.0)  # resting on the stop to the end
    assert abs(out.end_state[0]) <= 1e-4 and abs(out.end_state[1]) <= 1e-12
    # e = 1 never accumulates; a cap on events per period ends the run with a clear message
    s1 = chain([1.0], 0.0, 0.0, forcing=[{"dof": 0, "amplitude": 0.0, "constant": G}],
               elements=[Contact(0, 0.0, 1.0)])
    fl = EventFlow(s1, 1.0, max_events=3)
    with pytest.raises(EventError, match="more than 3 events in one period"):
        fl.simulate(0.0, fl.state(0.0, np.array([-H]), np.array([0.0])), duration=5.0)


# ----------------------------------------------------------------------------- monodromy
@pytest.fixture(scope="module")
def friction_and_stop():
    """A 2-mass chain with Coulomb friction on mass 0 and a stop at mass 1, forced at 0.8 rad/s, and its periodic
    solution by shooting (2048 steps; about 7 s of CPU: the Moreau-Jean ladder, then the event-driven integrator
    from its best attempt), solved once for the three tests that start flows from it."""
    omega = 0.8
    s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.5}],
              elements=[Friction(0, 1.0, 0.3), Contact(1, 0.8, 0.7)])
    return s, omega, mshbm.solve(s, omega, "shooting", steps=2048, stability=False)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["friction+contact", "two stops"])
def test_monodromy_of_two_element_flow_against_finite_differences(case, two_stops, friction_and_stop):
    if case == "two stops":
        s, _, _, sol = two_stops
        omega = OMEGA_BD
        x0 = np.concatenate([sol.q[0], sol.u[0]])
    else:
        s, omega, sol = friction_and_stop
        ex = exact_periodic(s, omega, sol)
        assert ex.success, ex.message
        kinds = {e.kind for e in ex.info["events"]}
        assert {"free->free", "slip-->stick", "stick->slip-"} <= kinds  # impacts and stick-slip
        x0 = ex.info["state_at_section"]
    n = s.n
    fl = EventFlow(s, omega)
    ts = 0.1 if case == "two stops" else ex.info["section_time"]
    if case == "two stops":
        x0 = fl.simulate(0.0, fl.state(0.0, x0[:n], x0[n:]), duration=ts).end_state[:2 * n]
    z0 = np.concatenate([x0, fl.osc(ts)])
    t = time.perf_counter()
    out = fl.simulate(ts, z0, jac=True)
    wall = time.perf_counter() - t
    assert out.monodromy_exact
    Phi = out.monodromy[:2 * n]
    F = np.empty_like(Phi)
    d = 1e-6
    for i in range(2 * n):
        zp, zm = z0.copy(), z0.copy()
        zp[i] += d
        zm[i] -= d
        F[:, i] = (fl.simulate(ts, zp).end_state[:2 * n] - fl.simulate(ts, zm).end_state[:2 * n]) / (2 * d)
    # measured: 8.6e-9 (friction+contact), relative to max |Phi|
    assert np.abs(Phi - F).max() <= 1e-6 * np.abs(Phi).max()
    assert wall < 5.0  # one period with sensitivities: measured 2.7 ms (friction+contact), 1.7 ms (two stops)


@pytest.mark.parametrize("case", ["friction+contact", "two stops"])
def test_batched_event_free_sub_steps_give_the_same_flow(case, two_stops, friction_and_stop, monkeypatch):
    """``EventFlow.batch`` (the stability analysis's flows) screens runs of event-free sub-steps at once: the same
    events, end state and monodromy as sub-step by sub-step (to rounding), with far fewer calls of ``locate``."""
    from mshbm.integrators.event import flow as flow_mod

    if case == "two stops":
        s, _, _, sol = two_stops
        omega, ts = OMEGA_BD, 0.1
    else:
        s, omega, sol = friction_and_stop
        ts = 0.37
    n = s.n
    calls = []
    real = flow_mod.locate
    monkeypatch.setattr(flow_mod, "locate", lambda *a: calls.append(1) or real(*a))
    runs = []
    for batch in (False, True):
        fl = EventFlow(s, omega)
        fl.batch, fl.screen = batch, False  # against the sub-step-by-sub-step loop
        z0 = np.concatenate([sol.q[0], sol.u[0], fl.osc(ts)])
        calls.clear()
        out = fl.simulate(ts, z0, duration=3 * fl.T, jac=True)
        runs.append((out, len(calls)))
    (a, na), (b, nb) = runs
    assert len(a.events) >= 3 and [e.kind for e in a.events] == [e.kind for e in b.events]
    assert np.abs(np.array([e.t for e in a.events]) - [e.t for e in b.events]).max() <= 1e-12 * a.events[-1].t
    assert np.abs(a.end_state - b.end_state).max() <= 1e-12 * np.abs(a.end_state).max()
    assert np.abs(a.monodromy - b.monodromy).max() <= 1e-11 * np.abs(a.monodromy).max()
    # measured: 396 -> 41 (friction+contact, 21 events), 388 -> 13 (two stops, 5 events) calls of locate
    assert nb < na / 3


def test_screened_sub_steps_are_bit_identical_to_the_step_by_step_loop(friction_and_stop, monkeypatch):
    """``EventFlow.screen`` (the default) screens runs of event-free sub-steps and advances them one by one with the
    loop's own products: the same events, end state, monodromy and Fourier sums to the bit, with and without the
    forcing states and Fourier coefficients of MS-HBM's coupled flow, and far fewer calls of ``locate``."""
    from mshbm.integrators.event import flow as flow_mod

    s, omega, sol = friction_and_stop  # its start state: the same bits as solved with accuracy=False
    ts = 0.37
    calls = []
    real = flow_mod.locate
    monkeypatch.setattr(flow_mod, "locate", lambda *a: calls.append(1) or real(*a))
    for coupled in (False, True):
        runs = []
        for screen in (False, True):
            fl = EventFlow(s, omega, coupling_harmonics=5 if coupled else None)
            fl.screen = screen
            if coupled:
                fl.set_forcing(np.full((11, 2), 0.01))
            z0 = np.concatenate([sol.q[0], sol.u[0], np.zeros(fl.D - 2 * s.n)])
            kw = dict(jac_cols="all", fourier=5) if coupled else {}
            calls.clear()
            out = fl.simulate(ts, z0, duration=3 * fl.T, jac=True, **kw)
            runs.append((out, len(calls)))
        (a, na), (b, nb) = runs
        assert len(a.events) >= 3 and [(e.kind, e.t) for e in a.events] == [(e.kind, e.t) for e in b.events]
        assert np.array_equal(a.end_state, b.end_state) and np.array_equal(a.monodromy, b.monodromy)
        if coupled:
            assert np.array_equal(a.q_hat, b.q_hat) and np.array_equal(a.q_hat_sensitivity, b.q_hat_sensitivity)
        assert nb < na / 3, (coupled, na, nb)


# ----------------------------------------------------------------------------- inputs
def test_inputs():
    s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.0}],
              elements=[Friction(0, 1.0, 0.3, relative_to=1)])
    with pytest.raises(InputError) as err:
        EventFlow(s, 1.0)
    assert err.value.key == "friction.relative_to"
    with pytest.raises(InputError) as err:
        EventFlow(chain([1.0], 1.0), 1.0, accumulation="ignore")
    assert err.value.key == "accumulation"
    from mshbm.integrators import event

    with pytest.raises(InputError) as err:
        EventFlow(chain([1.0] * (event.MAX_DOFS + 1), 1.0, sparse=True), 1.0)
    assert err.value.key == "integrator" and "dense" in err.value.problem
    with pytest.raises(InputError) as err:
        mshbm.solve(chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0}]), 1.0, "shooting",
                    integrator="rk4")
    assert err.value.key == "integrator"
    with pytest.raises(InputError) as err:
        mshbm.solve(chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0}]), 1.0, "hbm",
                    integrator="event")
    assert err.value.key == "integrator"


def test_cli_integrator_option(tmp_path):
    import json
    from pathlib import Path

    from mshbm.cli import main
    from mshbm.io import load_case

    case = Path(__file__).resolve().parents[2] / "examples" / "impact5.yaml"
    out = tmp_path / "r.json"
    assert main(["solve", str(case), "--method", "shooting", "--integrator", "event", "--steps", "512",
                 "--out", str(out), "--quiet"]) == 0
    amp = np.array(json.loads(out.read_text())["amplitude"])
    c = load_case(case)
    ex = exact_periodic(c.system, c.omega, mshbm.solve(c.system, c.omega, "shooting", steps=2048, stability=False))
    assert ex.success
    np.testing.assert_allclose(amp, ex.info["amplitude_exact"], rtol=1e-9)  # the same exact orbit
    assert main(["solve", str(case), "--method", "shooting", "--integrator", "rk4", "--quiet"]) == 2


# ----------------------------------------------------------------------------- MS-HBM with the event integrator
def _coupled_flow():
    """A 2-DOF chain with friction and a contact, and its flow with coupling forces ``F_c`` (n_c = 3) as
    forcing states: ``(system, omega, F_c, flow)``."""
    omega = 0.8
    s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.5}],
              elements=[Friction(0, 1.0, 0.3), Contact(1, 0.8, 0.7)])
    Fc = np.zeros((7, 2))
    Fc[0, 0], Fc[1, 0], Fc[2, 1], Fc[5, 1] = 0.05, 0.3, -0.2, 0.1
    fl = EventFlow(s, omega, coupling_harmonics=3)
    fl.set_forcing(Fc)
    return s, omega, Fc, fl


def test_forcing_states_and_exact_fourier_coefficients():
    """The coupling force as forcing states: the same flow as the force in f_hat, its sensitivities and those
    of the exact Fourier coefficients against central differences."""
    s, omega, Fc, fl = _coupled_flow()
    fh = np.zeros((7, 2))
    fh[:3] = s.f_hat
    ref = EventFlow(System(s.M, s.C, s.K, fh + Fc, s.elements), omega)
    q0, u0 = np.array([0.5, -1.0]), np.array([0.2, 0.1])
    a = fl.simulate(0.0, fl.state(0.0, q0, u0), jac=True, jac_cols="all", fourier=5)
    b = ref.simulate(0.0, ref.state(0.0, q0, u0), jac=True)
    assert len(a.events) >= 4
    assert np.abs(a.end_state[:4] - b.end_state[:4]).max() <= 1e-12  # measured 1.6e-15
    assert np.abs(a.monodromy[:4, :4] - b.monodromy[:4, :4]).max() <= 1e-12
    # Fourier coefficients against a fine trapezoidal rule (the orbit is not periodic: no FFT)
    tt = np.linspace(0.0, fl.T, 200001)
    q = fl.simulate(0.0, fl.state(0.0, q0, u0), sample_times=tt).samples[:2].T
    B = fl._fourier_basis(tt, 5)
    w = np.full(11, 2.0 / fl.T)
    w[0] = 1.0 / fl.T
    qh = np.trapezoid(B[:, :, None] * q[:, None, :], tt, axis=0) * w[:, None]
    assert np.abs(qh - a.q_hat).max() <= 1e-9  # measured 2.1e-10 (the trapezoidal rule's error)
    # sensitivities to q0, u0 and F_c (the forcing states at t = 0 are F_c) against central differences
    cols = fl.jac_columns("all")
    z0 = fl.state(0.0, q0, u0)
    err_q = err_z = 0.0
    d = 1e-6
    for c_i, c in enumerate(cols):
        if c < 4:
            zp, zm = z0.copy(), z0.copy()
            zp[c] += d
            zm[c] -= d
            op, om = fl.simulate(0.0, zp, fourier=5), fl.simulate(0.0, zm, fourier=5)
        else:
            k, i = divmod(c - fl.iy, 2)
            Fp, Fm = Fc.copy(), Fc.copy()
            Fp[k, i] += d
            Fm[k, i] -= d
            fl.set_forcing(Fp)
            op = fl.simulate(0.0, z0, fourier=5)
            fl.set_forcing(Fm)
            om = fl.simulate(0.0, z0, fourier=5)
            fl.set_forcing(Fc)
        err_q = max(err_q, np.abs((op.q_hat - om.q_hat) / (2 * d) - a.q_hat_sensitivity[:, :, c_i]).max())
        err_z = max(err_z, np.abs((op.end_state[:4] - om.end_state[:4]) / (2 * d) - a.monodromy[:4, c_i]).max())
    # measured 2.1e-9 and 4.7e-9 (central differences), against max |.| ~ 2.2 and 3.5
    assert err_q <= 1e-6 and err_z <= 1e-6


def test_structure_of_the_forcing_state_sensitivities_and_the_structured_products():
    """The fast paths of MS-HBM's flow rely on the structure of ``Phi`` with forcing-state columns: zero rows
    for the oscillator, and in the forcing-state rows only the 2 x 2 rotation block of each pair (the
    constants' diagonal), through events (impacts, stick, slip).  Given it, the structured products
    (``emul``, ``amul`` with ``sens``) and the structured Taylor powers of a state equal the dense ones."""
    s, omega, Fc, fl = _coupled_flow()
    z0 = fl.state(0.0, np.array([0.5, -1.0]), np.array([0.2, 0.1]))
    out = fl.simulate(0.0, z0, jac=True, jac_cols="all", fourier=5)
    kinds = {e.kind for e in out.events}
    assert any(e.impulse > 0 for e in out.events) and any("stick" in k for k in kinds)
    Phi, n, iy = out.monodromy, fl.n, fl.iy
    assert np.all(Phi[2 * n:iy] == 0.0)
    Py = Phi[iy:]
    mask = np.zeros(Py.shape, dtype=bool)
    i0 = np.arange(n)
    mask[i0, 2 * n + i0] = True
    for a_, b_ in ((fl._yc, fl._yc), (fl._yc, fl._ys), (fl._ys, fl._yc), (fl._ys, fl._ys)):
        mask[a_, 2 * n + b_] = True
    assert np.all(Py[~mask] == 0.0)
    # the rotation blocks: cos / sin of k omega T (one period), to rounding
    k = np.repeat(np.arange(1, 4), n)
    assert np.allclose(Py[fl._yc, 2 * n + fl._yc], np.cos(k * omega * fl.T), atol=1e-12)
    assert np.allclose(Py[fl._yc, 2 * n + fl._ys], np.sin(k * omega * fl.T), atol=1e-12)
    # structured products against the dense ones, for every mode met
    rng = np.random.default_rng(3)
    P = Phi.copy()
    P[:2 * n] += rng.standard_normal((2 * n, P.shape[1]))
    for md in (fl.mode(st) for st in list(fl._modes)):
        if md is None:
            continue
        dense_E, dense_A = md.E @ P, md.A @ P
        assert np.abs(fl.emul(md, P.copy(), sens=True) - dense_E).max() <= 1e-13 * np.abs(dense_E).max()
        assert np.abs(fl.amul(md, P, sens=True) - dense_A).max() <= 1e-13 * np.abs(dense_A).max()
        z = rng.standard_normal(fl.D)
        W = fl.powers(md, z)
        Wd = np.empty_like(W)
        Wd[:, 0] = z
        for j in range(1, md.n_taylor):
            Wd[:, j] = md.A @ Wd[:, j - 1] / j
        assert np.abs(W - Wd).max() <= 1e-13 * np.abs(Wd).max()


def test_mode_exponentials_are_shared_between_flows_of_the_same_problem_only():
    """A second flow of the same system and frequency reuses the exponentials of its modes (and gives the
    same numbers); another frequency does not."""
    s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.5}], elements=[Contact(1, 0.8, 0.7)])
    a, b, c = (EventFlow(s, w, coupling_harmonics=2) for w in (0.8, 0.8, 0.81))
    st = next(iter(a._modes))
    assert a.mode(st).E is b.mode(st).E and a.mode(st).E is not c.mode(st).E
    z0 = a.state(0.0, np.array([0.1, 0.2]), np.zeros(2))
    ra, rb = (f.simulate(0.0, z0, jac=True, jac_cols="all", fourier=2) for f in (a, b))
    assert np.array_equal(ra.q_hat, rb.q_hat) and np.array_equal(ra.q_hat_sensitivity, rb.q_hat_sensitivity)


def test_mshbm_event_converges_to_the_exact_orbit_with_the_harmonics():
    """The paper's 5-DOF impact chain: with the event integrator MS-HBM's only error is the harmonic
    truncation of the coupling; with Moreau-Jean it plateaus at the time-discretisation error."""
    from paper_systems import OMEGA, impact_chain

    s = impact_chain(5)
    g = mshbm.solve(s, OMEGA, "shooting", steps=4096, stability=False)
    ex = exact_periodic(s, OMEGA, g)
    assert ex.success
    ref = ex.info["amplitude_exact"]
    err = {}
    for nh in (9, 27, 81):
        sol = mshbm.solve(s, OMEGA, "mshbm", harmonics=nh, integrator="event", steps=1024, guess=g,
                          stability=False)
        assert sol.success, sol.message
        err[nh] = np.abs(sol.amplitude - ref).max() / np.abs(ref).max()
    # measured 3.65e-4, 4.81e-5, 3.08e-7
    assert err[9] > err[27] > err[81] and err[81] < 1e-6
    mj = mshbm.solve(s, OMEGA, "mshbm", harmonics=81, steps=4096, guess=g, stability=False)
    assert np.abs(mj.amplitude - ref).max() / np.abs(ref).max() > 1e-3  # measured 2.77e-3
    inter = mshbm.solve(s, OMEGA, "mshbm-intermediate", harmonics=27, integrator="event", steps=1024, guess=g,
                        stability=False)
    assert inter.success
    assert np.abs(inter.amplitude - ref).max() / np.abs(ref).max() < 1e-4  # measured 4.81e-5


def test_sweep_with_the_event_integrator_follows_den_hartog_exactly():
    """Frequency continuation of the damped Coulomb oscillator x'' + 2 zeta x' + x = F cos(omega t) - R sign(x')
    above resonance (continuous motion): every point against the half-period closed form (the symmetric
    solution x(0) = -X, x(pi/omega) = X from the exact linear flow)."""
    from scipy.linalg import expm
    from scipy.optimize import fsolve

    zeta, F, R = 0.05, 1.0, 0.3

    def closed_form(w):
        E = expm(np.array([[0.0, 1.0], [-1.0, -2 * zeta]]) * np.pi / w)
        H = F / (1 - w ** 2 + 2j * zeta * w)

        def part(t, phi):
            z = H * np.exp(1j * (w * t + phi))
            return np.array([z.real - R, (1j * w * z).real])

        def res(p):
            return E @ (np.array([-p[0], 0.0]) - part(0.0, p[1])) + part(np.pi / w, p[1]) - np.array([p[0], 0.0])

        p = fsolve(res, [abs(H), 0.0], xtol=1e-13)
        assert np.max(np.abs(res(p))) < 1e-12
        return p[0]

    s = chain([1.0], 1.0, 2 * zeta, forcing=[{"dof": 0, "amplitude": F}], elements=[Friction(0, 1.0, R)])
    b = mshbm.sweep(s, 1.5, 3.0, "shooting", steps=512, integrator="event")
    assert b.success and len(b) >= 5
    exact = np.array([closed_form(w) for w in b.omega])
    # measured 4.8e-11 (Moreau-Jean with 4096 steps: 5e-3 is the bound of tests/integration/test_sweep.py)
    np.testing.assert_allclose(b.amplitude[:, 0], exact, rtol=1e-8)


def test_a_stiff_subsystem_is_refused_at_once_not_integrated_for_hours():
    """A stiff, heavily damped DOF (a finite-element node: ||A|| ~ 1e12 1/s) would need ~1e13 sub-steps per
    period of the event search; the flow says so with the key ``integrator`` at construction (measured: 8 ms),
    for shooting as for the flow itself, instead of running on (the FE example's MS-HBM(event) never ended)."""
    import time

    from mshbm.integrators.event import MAX_SUBSTEPS

    M = np.diag([1.0, 1e-6])
    K = np.array([[1.0 + 1e6, -1e6], [-1e6, 1e6]])
    f = np.zeros((3, 2))
    f[1, 0] = 1.0
    s = mshbm.System(M, 1e-3 * K, K, f, [mshbm.Friction(dof=1, mu=0.5, normal_force=0.1)])
    t0 = time.perf_counter()
    with pytest.raises(mshbm.InputError) as exc:
        mshbm.solve(s, 1.0, "shooting", integrator="event")
    assert exc.value.key == "integrator" and "sub-steps per period" in exc.value.problem
    assert time.perf_counter() - t0 < 5.0
    # the same structure with a unit mass and unit springs on the friction DOF stays within the grid
    s2 = mshbm.System(np.eye(2), np.zeros((2, 2)), np.array([[2.0, -1.0], [-1.0, 1.0]]), f,
                      [mshbm.Friction(dof=1, mu=0.5, normal_force=0.1)])
    flow = EventFlow(s2, 1.0)
    assert flow.substeps <= MAX_SUBSTEPS


def test_stiff_but_lightly_damped_dof_gets_a_balanced_sub_step_and_the_exact_orbit():
    """The Budd & Dux orbit in a time unit ``w = 2^14`` times shorter: ``x'' + 2 zeta w x' + w^2 x =
    w^2 cos(Omega t)``, ``Omega = 2.3 w``, the same stop.  In ``tau = w t`` it is the closed-form orbit: impact
    time ``t0 / w``, approach velocity ``w v``, the same amplitude and multipliers.  The unscaled 1-norm of
    ``A_xx`` (``w^2``, displacement and velocity units mixed) asked for 2 T w^2 = 9.0e4 sub-steps per period
    (refused, > 2^16); the balanced norm (``~w``) for ``2 T w ~ 9``, so the minimum 128 applies."""
    w = 2.0 ** 14
    t0, v = cf.stable_orbit(OMEGA_BD)
    mu_cf = cf.multipliers(OMEGA_BD, t0, v)
    A_cf = cf.amplitude(OMEGA_BD, t0, v)
    s = mshbm.chain([1.0], w ** 2, 2.0 * cf.ZETA * w, forcing=[{"dof": 0, "amplitude": w ** 2}],
                    elements=[Contact(0, cf.SIGMA, cf.R)], name="stiff-impact-oscillator")
    Om = OMEGA_BD * w
    T = 2 * np.pi / Om
    flow = EventFlow(s, Om)
    assert 2 * T * w ** 2 > 2 ** 16  # the former rule's count: refused
    assert flow.substeps == 128
    md = flow.mode(flow.select(flow.state(0.0, np.zeros(1), np.zeros(1)))[0])
    assert w <= md.norm_xx <= 2.0 * w  # balanced norm: within a factor 2 of the fastest eigenvalue ~ w
    sol = mshbm.solve(s, Om, "shooting", integrator="event", steps=1024)
    assert sol.success, sol.message
    imp = [e for e in sol.info["event_list"] if e.impulse > 0]
    assert len(imp) == 1
    # measured: 3.9e-14 (time x w), 3.4e-13 (velocity), 1.3e-13 (amplitude), 2.0e-13 (multipliers)
    assert abs(imp[0].t * w - t0) <= 1e-10
    assert abs(-imp[0].velocity / w - v) <= 1e-10 * v
    assert abs(sol.amplitude[0] - A_cf) <= 1e-9 * A_cf
    np.testing.assert_allclose(np.sort_complex(sol.info["event_multipliers"]), mu_cf, atol=1e-9)
    x_cf = np.where(sol.t * w < t0, cf.free_flight(sol.t * w, t0 - 2 * np.pi / OMEGA_BD, v, OMEGA_BD)[0],
                    cf.free_flight(sol.t * w, t0, v, OMEGA_BD)[0])
    assert np.abs(sol.q[:, 0] - x_cf).max() <= 1e-10


def _soft_structure_with_stiff_bodies(restitution=0.8, mu_fn=1.2):
    """A soft DOF (``omega_0 = 1``) carrying two bodies of 1/100 its mass on springs at 20 ``omega_0`` (the FE
    example's bodies in miniature), friction on body 1, a stop (gap 2) on body 2, forced on DOF 0."""
    kb = 400.0 * 0.01
    M = np.diag([1.0, 0.01, 0.01])
    K = np.array([[1.0 + 2 * kb, -kb, -kb], [-kb, kb, 0.0], [-kb, 0.0, kb]])
    f = np.zeros((3, 3))
    f[1, 0] = 1.0
    return System(M, 0.02 * M + 1e-4 * K, K, f, [Friction(dof=1, mu=0.3, normal_force=mu_fn),
                                                  Contact(2, 2.0, restitution)])


def test_balanced_grid_finds_the_same_events_as_the_former_fine_grid():
    """Event detection is not weakened by the balanced sub-step: on stiff bodies (``K/M = 400``) the
    balanced rule takes 405 sub-steps per period, the former unscaled rule 11296; over 5 periods (213 events:
    stick-slip, impacts, accumulations closed) both grids find the same event sequence, at the same times.
    Measured: largest time difference 1.5e-11 s, end state 8.8e-10 (relative; both grids differ by as much
    from a 30000-sub-step grid: 1.6e-10 / 1.8e-10 s in the times)."""
    import math

    s, om = _soft_structure_with_stiff_bodies(mu_fn=0.2 * 0.01 * 400 * 0.5), 0.9
    fl = EventFlow(s, om, accumulation="close")
    z0 = fl.state(0.0, np.array([3.0, 3.0, 3.0]), np.zeros(3))
    a = fl.simulate(0.0, z0, duration=5 * fl.T, jac=True)
    ns_old = math.ceil(2 * fl.T * max(np.abs(md.A[:6, :6]).sum(axis=0).max() for md in fl._modes.values() if md))
    w_max = 2 * fl.T * math.sqrt(400.0)  # 2 T omega_max: the balanced count within a factor 2 (measured 1.45)
    assert w_max <= fl.substeps <= 2 * w_max and ns_old >= 20 * fl.substeps  # not ~2 T omega_max^2
    fine = EventFlow(s, om, substeps=ns_old, accumulation="close")
    b = fine.simulate(0.0, z0, duration=5 * fl.T, jac=True)
    assert len(a.events) == len(b.events) > 100
    assert [e.kind for e in a.events] == [e.kind for e in b.events]
    assert max(abs(x.t - y.t) for x, y in zip(a.events, b.events)) <= 1e-9
    assert np.abs(a.end_state[:6] - b.end_state[:6]).max() <= 1e-7 * np.abs(b.end_state[:6]).max()


@pytest.mark.slow
def test_mshbm_event_with_zeno_closure_converges_where_the_moreau_fallback_stalls():
    """``accumulation="close"`` (MS-HBM and shooting with ``integrator="event"``): accumulating impacts are
    closed (exact up to the dropped tail), so the flow and its monodromy stay exact and Newton converges;
    with the default Moreau-Jean fallback MS-HBM stalls on this system (measured: best scaled residual 9.6e-2).
    MS-HBM (9 harmonics on the soft DOF) against shooting on the whole system, both exact flows: measured
    relative differences 0.7 %, 1.3 %, 0.13 % (DOFs 0, 1, 2)."""
    s, om = _soft_structure_with_stiff_bodies(), 0.9
    ms = mshbm.solve(s, om, "mshbm", harmonics=9, integrator="event", accumulation="close")
    assert ms.success, ms.message
    ei = ms.info["event_integrator"]
    assert ei["monodromy_exact"] and not ei["switched_to_moreau"] and ei["impacts"] > 10
    # the reference from the start that the default ladder accepts (its clamped start, after 18 s CPU of a linear
    # start that does not converge): the same solution, bit for bit
    from mshbm.route.starts import clamped_response, hat_guess

    opts = dict(integrator="event", accumulation="close")
    clamped = hat_guess(clamped_response(s, om, mshbm.build_problem(s, om, "shooting", **opts)[0].n_h), om)
    sh = mshbm.solve(s, om, "shooting", guess=clamped, **opts)
    assert sh.success and sh.info["event_integrator"]["monodromy_exact"]
    np.testing.assert_allclose(ms.amplitude, sh.amplitude, rtol=0.02)
    assert abs(ms.amplitude[2] - sh.amplitude[2]) <= 3e-3 * sh.amplitude[2]
    with pytest.raises(InputError) as exc:
        mshbm.solve(s, om, "mshbm", accumulation="close")  # Moreau-Jean integrator: nothing to close
    assert exc.value.key == "accumulation"
    with pytest.raises(InputError) as exc:
        mshbm.solve(s, om, "mshbm", integrator="event", accumulation="zeno")
    assert exc.value.key == "accumulation"
