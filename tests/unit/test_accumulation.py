"""The accumulation-of-impacts detector (mshbm.accumulation) on cases with a known answer.

A ball under constant gravity g on a stop, restitution e < 1, dropped from height H: first
impact at t_1 = sqrt(2 H / g) with speed v = sqrt(2 g H), then flights 2 e^k v / g, so infinitely
many impacts accumulate at the closed-form Zeno point

    t_inf = t_1 + 2 e v / (g (1 - e))

(equivalently t_0 + 2 v_0 / (g (1 - e)) counted from the impact at t_0 = t_1 with rebound
velocity v_0 = e v).  With e = 1 the flights are all equal: no accumulation.
"""
import numpy as np
import pytest

from mshbm import Contact, chain
from mshbm.accumulation import find_accumulations, from_events, from_impulses
from mshbm.methods.exact import ExactFlow
from mshbm.methods.exact import exact_periodic
from mshbm.integrators.moreau_jean import MoreauJean

G, H = 9.81, 0.5


def ball(e, gap):
    """1 kg ball, no spring, gravity pushing it towards the stop at q = gap."""
    return chain([1.0], 0.0, 0.0, forcing=[{"dof": 0, "amplitude": 0.0, "constant": G}],
                 elements=[Contact(0, gap, e)])


def zeno_time(e):
    t1, v = np.sqrt(2 * H / G), np.sqrt(2 * G * H)
    return t1 + 2 * e * v / (G * (1 - e))


@pytest.mark.parametrize("e", [0.3, 0.5, 0.8])
@pytest.mark.parametrize("gap", [0.0, 1.0])
def test_exact_flow_ball_accumulates_at_the_closed_form_time(e, gap):
    sys = ball(e, gap)
    flow = ExactFlow(sys, 1.0)
    out = flow.simulate(0.0, flow.state(0.0, np.array([gap - H]), np.array([0.0])), duration=1.2 * zeno_time(e))
    events = out.events
    acc = from_events(events)
    assert len(acc) == 1, acc
    a = acc[0]
    assert abs(a.t_inf - zeno_time(e)) <= 1e-9 * zeno_time(e)  # geometric tail: exact to rounding
    assert abs(a.ratio - e) <= 1e-9
    assert abs(a.t_first - np.sqrt(2 * H / G)) <= 1e-12
    # the flow itself closes the contact just before t_inf and the ball then rests on the stop
    # (it drops the tail of bounces after the closing impact, approach speed |gamma|: 2 e |gamma| / (g (1 - e)))
    closing = [ev for ev in events if ev.kind == "free->closed"]
    assert len(closing) == 1
    tail = 2 * e * abs(closing[0].velocity) / (G * (1 - e))
    assert 0.0 < tail <= 1e-3 and abs(a.t_inf - closing[0].t - tail) <= 1e-9
    assert out.end_mode == 4 and abs(out.end_state[0] - gap) <= 1e-12


def test_exact_flow_elastic_ball_does_not_accumulate():
    sys = ball(1.0, 0.0)
    flow = ExactFlow(sys, 1.0)
    out = flow.simulate(0.0, flow.state(0.0, np.array([-H]), np.array([0.0])), duration=5.0)
    impacts = [ev.t for ev in out.events if ev.impulse > 0]
    assert len(impacts) == 8  # t_1 + k 2 t_1, t_1 = 0.319 s
    assert np.allclose(np.diff(impacts), 2 * np.sqrt(2 * H / G), rtol=1e-9)
    assert from_events(out.events) == []


@pytest.mark.parametrize("e", [0.5, 1.0])
def test_moreau_jean_ball(e):
    """Time-stepping (theta = 1/2, h = 1e-4 s): the bounces shrink until the grid cannot separate
    them and the ball rests on the stop with an impulse every step; the detector extrapolates the
    resolved bounces to t_inf within a few steps (e = 0.5) and finds nothing for e = 1."""
    sys = ball(e, 0.0)
    h, T_sim = 1e-4, 3.0
    N = int(round(T_sim / h))
    t = np.arange(N + 1) * h
    mj = MoreauJean(sys.M, sys.C, sys.K, sys.elements, h, 0.5, True)
    tr = mj.run(np.array([-H]), np.array([0.0]), mj.increments(sys.forcing(t, 1.0)))
    acc = from_impulses(t, tr.P[:, 0])
    if e == 1.0:
        assert acc == []
        assert np.count_nonzero(tr.P[:, 0] > 0) >= 4  # it did bounce
        return
    assert len(acc) == 1, acc
    assert abs(acc[0].t_inf - zeno_time(e)) <= 20 * h
    assert abs(acc[0].ratio - e) <= 0.02
    assert np.all(tr.P[int(np.ceil((zeno_time(e) + 20 * h) / h)):, 0] > 0)  # persistent contact after t_inf


def test_periodic_zeno_orbit_of_the_exact_solver():
    """The periodic e = 0.5 orbit of tests/unit/test_exact.py (mass pressed on the stop, lifting off once per
    period) has one accumulation per period, just after its closing impact; e = 0 has a single impact."""
    found = {}
    for e in (0.0, 0.5):
        sys = chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.5, "constant": 1.0}],
                    elements=[Contact(0, 0.3, e)])
        ex = exact_periodic(sys, 1.0, {"q0": [0.3], "u0": [0.0]}, samples=256)
        assert ex.success, ex.message
        found[e] = (from_events(ex.info["events"], period=2 * np.pi), ex.info["events"])
    assert found[0.0][0] == []
    acc, events = found[0.5]
    assert len(acc) == 1
    closing = [ev.t for ev in events if ev.kind == "free->closed"][0]
    assert 0.0 <= (acc[0].t_inf - closing) % (2 * np.pi) <= 1e-3
    assert abs(acc[0].ratio - 0.5) <= 0.05


def test_detector_edge_cases():
    assert find_accumulations([]) == []
    assert find_accumulations([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]) == []  # equal intervals
    geo = 1.0 - 0.5 ** np.arange(10)  # intervals 0.5, 0.25, ...: t_inf = 1
    acc = find_accumulations(geo)
    assert len(acc) == 1 and abs(acc[0].t_inf - 1.0) <= 1e-12 and acc[0].n_impacts == 10
    assert find_accumulations(geo[:3]) == []  # too short to tell
    # periodic data: a sequence crossing t = 0 is one accumulation, reported modulo the period
    T = 10.0
    acc = find_accumulations(np.sort((geo + 9.0) % T), period=T)
    assert len(acc) == 1 and abs(acc[0].t_inf - 0.0) <= 1e-9 or abs(acc[0].t_inf - T) <= 1e-9
