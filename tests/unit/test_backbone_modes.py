"""Nonlinear modes by shooting with the exact event-driven flow (mshbm.backbone(method="shooting")):
the conservative impact oscillator against its closed form, a linear chain's modal frequency and damping
(EPMC in the time domain), and a dissipative impact mode against an independent transient simulation."""
import numpy as np
import pytest
import scipy.linalg as sla
from scipy.integrate import solve_ivp

import mshbm
from mshbm.backbone import backbone
from mshbm.errors import InputError


def impact_period(A, g, omega0):
    """Period of the conservative orbit of m q'' + k q = 0 with a rigid stop at q = g (e_N = 1) and free
    amplitude A (the orbit's minimum is -A): the free flight q = A cos(omega0 t + phi) runs from the stop
    (phase arccos(g/A)) down to -A and back (phase 2 pi - arccos(g/A)), then the impact reverses the
    velocity; so T = 2 (pi - arccos(g / A)) / omega0 for A > g, 2 pi / omega0 below the stop."""
    return 2 * (np.pi - np.arccos(min(g / A, 1.0))) / omega0


def test_conservative_impact_oscillator_closed_form():
    """m = 2, k = 3, gap 0.5, e_N = 1, from below the stop (linear) through grazing to A ~ 3.5 g: the period
    against the amplitude A (from the orbit's energy, sqrt(2 E / k)) follows the closed form to 1e-6 (the
    flow is exact: observed ~1e-10); D = 0, the energy is conserved, one impact per period above the stop,
    and (max - min)/2 of q is (g + A)/2 there."""
    m, k, g = 2.0, 3.0, 0.5
    w0 = np.sqrt(k / m)
    s = mshbm.System([[m]], [[0.0]], [[k]], [0.0], elements=[mshbm.Contact(0, g, 1.0)])
    b = backbone(s, 0.3, 3.0, method="shooting", points=12)
    assert b.success, b.message
    d = b.to_dict()
    assert d["conservative"] and all(d["certified"]) and all(d["stable"])
    A = np.sqrt(2 * np.array(d["energy"]) / k)
    T = 2 * np.pi / b.omega
    err = np.array([T[i] / impact_period(A[i], g, w0) - 1 for i in range(len(b))])
    assert np.max(np.abs(err)) < 1e-6, err
    hit = A > g * (1 + 1e-9)
    assert hit.sum() >= 5 and (~hit).sum() >= 3
    assert np.all(np.array(d["impacts"])[hit] == 1) and np.all(np.array(d["impacts"])[~hit] == 0)
    # exact extrema against the energy's amplitude, to the corrector's tolerance (1e-8 of the displacement)
    assert np.max(np.abs(b.amplitude[hit, 0] - 0.5 * (g + A[hit])) / A[hit]) < 1e-8
    assert np.max(np.abs(b.amplitude[~hit, 0] - A[~hit]) / A[~hit]) < 1e-8
    assert np.max(np.abs(b.damping_ratio)) < 1e-7 and max(d["energy_drift"]) < 1e-7
    # hardening: from omega_0 below the stop to 2 omega_0 as A / g grows (T -> pi / omega_0)
    assert np.max(np.abs(b.omega[~hit] / w0 - 1)) < 1e-12 and np.all(np.diff(b.omega[hit]) > 0)


@pytest.mark.parametrize("mode", [0, 2])
def test_linear_rayleigh_mode_by_shooting(mode):
    """EPMC by shooting on a Rayleigh-damped linear chain: the undamped omega_k and zeta_k to 1e-9 at every
    amplitude (as EPMC with harmonic balance)."""
    M = np.diag([1.0, 2.0, 1.5])
    K = np.array([[3.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    alpha, beta = 0.02, 0.003
    s = mshbm.System(M, alpha * M + beta * K, K, np.zeros(3))
    wk = np.sqrt(sla.eigh(K, M, eigvals_only=True)[mode])
    b = backbone(s, 1e-3, 1e-1, mode=mode, method="shooting", harmonics=3, points=4)
    assert b.success, b.message
    assert np.max(np.abs(b.omega / wk - 1)) < 1e-9
    assert np.max(np.abs(b.damping_ratio / (alpha / (2 * wk) + beta * wk / 2) - 1)) < 1e-9
    d = b.to_dict()
    assert not d["conservative"] and d["stable"] == [None] * len(b) and max(d["energy_balance"]) < 1e-9


def test_dissipative_impact_mode_against_transient_simulation():
    """An impact oscillator with e_N = 0.8 and no dashpot: the artificial damping xi feeds what the impacts
    dissipate (energy balance to 1e-6, certified); an independent simulation of the shifted system
    m q'' - xi m q' + k q = 0 (solve_ivp, rtol 1e-12, impacts as terminal events) from the point's start
    state returns to it after one period T = 2 pi / omega to 1e-8."""
    m, k, g, e = 1.0, 1.0, 0.2, 0.8
    s = mshbm.System([[m]], [[0.0]], [[k]], [0.0], elements=[mshbm.Contact(0, g, e)])
    b = backbone(s, 0.1, 1.0, method="shooting", points=6, steps=64)
    assert b.success, b.message
    d = b.to_dict()
    hit = np.array(d["impacts"]) > 0
    assert not d["conservative"] and all(d["certified"]) and hit.sum() >= 4
    # impacts: the balance of xi's power against the impact losses (relative); below the stop nothing
    # dissipates and xi is zero to the tolerance
    assert max(np.array(d["energy_balance"])[hit]) < 1e-6 and max(np.abs(b.damping_ratio[~hit])) < 1e-7
    p = b.points[-1]
    assert p["impacts"] == 1 and p["damping_ratio"] > 0.01
    xi, w = p["xi"], p["omega"]
    y = np.r_[p["q0"], p["u0"]]
    T = 2 * np.pi / w

    def rhs(t, z):
        return [z[1], xi * z[1] - k / m * z[0]]

    def hit(t, z):
        return g - z[0]
    hit.terminal, hit.direction = True, -1
    t, z, impacts = 0.0, np.array(y[:2]), 0
    while t < T:
        sol = solve_ivp(rhs, (t, T), z, rtol=1e-12, atol=1e-14, events=hit)
        t, z = sol.t[-1], sol.y[:, -1].copy()
        if sol.status == 1:
            z[1] = -e * z[1]
            impacts += 1
    assert impacts == 1
    assert np.max(np.abs(z - y[:2]) / np.r_[p["amplitude"][0], w * p["amplitude"][0]]) < 1e-8


def test_shooting_bad_input():
    s = mshbm.System([[1.0]], [[0.0]], [[1.0]], [0.0], elements=[mshbm.Jenkins(0, 1.0, 0.1, tangential_stiffness=2.0)])
    with pytest.raises(InputError) as exc:
        backbone(s, 0.1, 1.0, method="shooting")
    assert exc.value.key == "friction.tangential_stiffness"
    s = mshbm.System([[1.0]], [[0.0]], [[1.0]], [0.0])
    with pytest.raises(InputError) as exc:
        backbone(s, 0.1, 1.0, method="shooting", steps=4)
    assert exc.value.key == "steps"


def test_coulomb_friction_mode_closed_form():
    """EPMC by shooting with rigid Coulomb friction on the ground (m = 1.5, k = 2, mu F_N = 0.1, no dashpot),
    closed form: between velocity reversals q'' - xi q' + omega_0^2 q = -/+ mu F_N / m, a growing oscillation
    about -/+ r (r = mu F_N / k) whose velocity zeros are pi / omega_d apart (omega_d^2 = omega_0^2 - xi^2/4);
    a symmetric orbit between -X and X (X > r: no sticking) needs X + r = exp(xi pi / (2 omega_d)) (X - r), so
    D = xi / (2 omega_d) = ln((X + r) / (X - r)) / pi and omega = omega_d = omega_0 / sqrt(1 + D^2) (the
    describing function's 2 r / (pi X) for X >> r).  X is the orbit's exact (max - min)/2; observed agreement
    ~1e-8 (the corrector's tolerance), asserted 1e-6; two slip reversals per period, no stick."""
    m, k, muN = 1.5, 2.0, 0.1
    w0, r = np.sqrt(k / m), muN / k
    s = mshbm.System([[m]], [[0.0]], [[k]], [0.0], elements=[mshbm.Friction(0, 1.0, muN)])
    b = backbone(s, 0.2, 5.0, method="shooting", points=8)
    assert b.success, b.message
    X = b.amplitude[:, 0]
    D = np.log((X + r) / (X - r)) / np.pi
    assert X.min() < 4 * r and X.max() > 50 * r
    assert np.max(np.abs(b.damping_ratio / D - 1)) < 1e-6
    assert np.max(np.abs(b.omega / (w0 / np.sqrt(1 + D ** 2)) - 1)) < 1e-8
    d = b.to_dict()
    assert d["events"] == [2] * len(b) and max(d["energy_balance"]) < 1e-6 and not d["conservative"]


def test_impact_mode_started_above_the_stop():
    """a_start beyond the stop: Newton from the linear mode fails there, so the start is traced from below
    the stop; the first point is at a_start and on the closed form."""
    m, k, g = 2.0, 3.0, 0.5
    s = mshbm.System([[m]], [[0.0]], [[k]], [0.0], elements=[mshbm.Contact(0, g, 1.0)])
    b = backbone(s, 1.0, 2.0, method="shooting", points=3)
    assert b.success, b.message
    d = b.to_dict()
    assert np.isclose(b.modal_amplitude[0], 1.0, rtol=1e-12) and min(d["impacts"]) == 1
    A = np.sqrt(2 * np.array(d["energy"]) / k)
    T = np.array([impact_period(x, g, np.sqrt(k / m)) for x in A])
    assert np.max(np.abs(2 * np.pi / b.omega / T - 1)) < 1e-6


@pytest.mark.slow
def test_impact5_grazing_corner_is_passed():
    """examples/impact5.yaml (5-DOF chain, dashpots, a stop at 0.1 on the heavy mass): mode 0 is linear until
    the heavy mass grazes the stop (a_c = 0.4862); there the backbone has a corner where a reverses (omega
    grows with the impacts while a falls to a fold and grows again), which no step in a crosses.  The trace
    restarts beyond it from the DLFT mode, traces back over the fold and on to a_end: every point certified,
    one impact per period beyond the corner, the fold's a below a_c, omega increasing along the impacting
    piece.  MS-HBM likewise.  (about 60 s CPU.)"""
    from mshbm import io
    from pathlib import Path

    case = io.load_case(str(Path(__file__).resolve().parents[2] / "examples" / "impact5.yaml"))
    b = backbone(case.system, 0.4, 0.8, method="shooting", points=10, dofs=[0])
    assert b.success, b.message
    assert "1 corner(s) passed" in b.message
    d = b.to_dict()
    imp = np.array(d["impacts"])
    assert all(d["certified"]) and set(imp) == {0, 1}
    first = int(np.argmax(imp == 1))
    assert np.all(imp[first:] == 1) and np.all(imp[:first] == 0)
    a_c = b.modal_amplitude[first - 1]
    assert abs(b.amplitude[first - 1, 0] - 0.1) < 1e-6  # the last linear point grazes the stop
    assert b.modal_amplitude[first:].min() < 0.9 * a_c and np.all(np.diff(b.omega[first:]) > 0)
    assert np.max(np.abs(b.omega[:first] / b.omega_linear - 1)) < 1e-12
    # MS-HBM (the stop's DOF in time, n_h = 15) passes the same corner and agrees at a_end within the coupling's
    # truncation (observed: omega 5e-6, D 3e-4; at n_h = 5 D is 1.2 % off)
    m = backbone(case.system, 0.4, 0.8, method="mshbm", harmonics=15, points=10, dofs=[0])
    assert m.success, m.message
    assert "1 corner(s) passed" in m.message and all(m.to_dict()["certified"])
    assert abs(m.omega[-1] / b.omega[-1] - 1) < 1e-4 and abs(m.damping_ratio[-1] / b.damping_ratio[-1] - 1) < 1e-3


M3 = np.diag([1.0, 2.0, 1.5])
K3 = np.array([[3.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])


def test_mshbm_mode_against_shooting_friction_chain():
    """EPMC by MS-HBM (n_h = 15: the friction DOF in time by the exact flow, the other two condensed per
    harmonic) against shooting of the whole chain (exact) with Coulomb friction on mass 0 and light mass-
    proportional damping: at both ends of the range (a = 0.5: stick-slip, four events per period; a = 5: two
    slip reversals) omega agrees to 1e-6 and D to 1e-5 (observed 6e-8 and 2e-7: the coupling's truncation)."""
    s = mshbm.System(M3, 0.01 * M3, K3, np.zeros(3), elements=[mshbm.Friction(0, 1.0, 0.05)])
    bm = backbone(s, 0.5, 5.0, method="mshbm", harmonics=15, points=6, dofs=[0])
    bs = backbone(s, 0.5, 5.0, method="shooting", harmonics=5, points=6, dofs=[0])
    assert bm.success, bm.message
    assert bs.success, bs.message
    for i in (0, -1):
        assert bm.modal_amplitude[i] == bs.modal_amplitude[i]
        assert abs(bm.omega[i] / bs.omega[i] - 1) < 1e-6
        assert abs(bm.damping_ratio[i] / bs.damping_ratio[i] - 1) < 1e-5
        assert abs(bm.amplitude[i, 0] / bs.amplitude[i, 0] - 1) < 1e-5
    d = bm.to_dict()
    assert d["events"][0] == 4 and d["events"][-1] == 2 and d["energy_balance"] == [None] * len(bm)
    assert bm.damping_ratio[0] > 3 * bm.damping_ratio[-1] > 3 * 0.01 / (2 * bm.omega[-1])


def test_mshbm_linear_below_the_stop():
    """MS-HBM modes of a Rayleigh-damped chain with a stop far away: the linear omega_k and zeta_k to 1e-9."""
    alpha, beta = 0.02, 0.003
    s = mshbm.System(M3, alpha * M3 + beta * K3, K3, np.zeros(3), elements=[mshbm.Contact(0, 10.0, 1.0)])
    wk = np.sqrt(sla.eigh(K3, M3, eigvals_only=True)[1])
    b = backbone(s, 1e-2, 1.0, mode=1, method="mshbm", harmonics=3, points=3)
    assert b.success, b.message
    assert np.max(np.abs(b.omega / wk - 1)) < 1e-9
    assert np.max(np.abs(b.damping_ratio / (alpha / (2 * wk) + beta * wk / 2) - 1)) < 1e-9


def test_mshbm_conservative_impact_oscillator_closed_form():
    """The conservative impact oscillator by MS-HBM (the one DOF in time; n_h = 5 only for the connectivity):
    T(A) of the closed form to 1e-6 (observed 2e-9) with A from the exact extrema ((max - min)/2 = (g + A)/2
    once it impacts), D = 0."""
    m, k, g = 2.0, 3.0, 0.5
    s = mshbm.System([[m]], [[0.0]], [[k]], [0.0], elements=[mshbm.Contact(0, g, 1.0)])
    b = backbone(s, 0.3, 3.0, method="mshbm", harmonics=5, points=12)
    assert b.success, b.message
    amp = b.amplitude[:, 0]
    hit = np.array(b.to_dict()["impacts"]) > 0
    assert hit.sum() >= 5 and (~hit).sum() >= 3 and np.all(amp[hit] > g) and np.all(amp[~hit] < g)
    A = np.where(hit, 2 * amp - g, amp)
    T = np.array([impact_period(x, g, np.sqrt(k / m)) for x in A])
    assert np.max(np.abs(2 * np.pi / b.omega / T - 1)) < 1e-6
    assert np.max(np.abs(b.damping_ratio)) < 1e-7
