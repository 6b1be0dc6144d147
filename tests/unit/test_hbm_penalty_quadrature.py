"""HBM's linear quadrature of the penalty contact (``penalty_quadrature="linear"``, mshbm.methods.hbm).

The contact force is integrated exactly on the linear interpolant of the sampled gap: the residual is
C^1 in q_hat, and the frequency sweep of the 5-mass impact chain (examples/impact5.yaml) is traced from
its default start over [0.5, 0.75] rad/s, where the sampled law folds back (0.531 -> 0.39 rad/s at
n_H = 9) or stalls.
"""
import numpy as np
import pytest

import mshbm
from tests import discretised
from mshbm.api import build_problem
from mshbm.methods.hbm import hat_integrals
from test_hbm_robust import penalty_ode_amplitudes
from paper_systems import impact_chain

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def test_hat_integrals_against_quadrature_and_differences():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=300), rng.normal(size=300)
    a[:20], b[20:40] = 0.0, 0.0  # a sample exactly on the wall
    m = 40_000
    tau = (np.arange(m) + 0.5) / m  # midpoint rule: error O(1/m^2) on the smooth parts, O(1/m^2) at the kink
    pen = np.maximum(0.0, -(a[:, None] + (b - a)[:, None] * tau))
    IL, IR, La, Lb, Ra, Rb = hat_integrals(a, b)
    np.testing.assert_allclose(IL, (pen * (1 - tau)).mean(axis=1), rtol=0, atol=1e-9)
    np.testing.assert_allclose(IR, (pen * tau).mean(axis=1), rtol=0, atol=1e-9)
    e = 1e-7
    ok = (np.abs(a) > 1e-5) & (np.abs(b) > 1e-5)  # away from the kink of max(0, -g) at a sample
    for da, db, dL, dR in ((1, 0, La, Ra), (0, 1, Lb, Rb)):
        p, q = hat_integrals(a + e * da, b + e * db), hat_integrals(a - e * da, b - e * db)
        np.testing.assert_allclose(dL[ok], ((p[0] - q[0]) / (2 * e))[ok], rtol=0, atol=1e-8)
        np.testing.assert_allclose(dR[ok], ((p[1] - q[1]) / (2 * e))[ok], rtol=0, atol=1e-8)


def test_linear_quadrature_is_the_sampled_law_while_the_contact_is_closed():
    """With every sample closed the law is linear in q, and the 1-4-1 hat projection is undone exactly by
    D_k^-1: the two quadratures give the same residual and Jacobian (to rounding)."""
    system = impact_chain(5)
    ps = build_problem(system, 0.6, "hbm", harmonics=7, steps=256)[0]
    pl = build_problem(system, 0.6, "hbm", harmonics=7, steps=256, penalty_quadrature="linear")[0]
    rng = np.random.default_rng(0)
    x = 1e-3 * rng.normal(size=ps.n_unknowns)
    x[0] = 1.0  # mean of q_1 = 1 m, ten times the gap: closed at all samples
    assert np.all(ps._gaps(x) < 0)
    Rs, Js = ps.residual(x)
    Rl, Jl = pl.residual(x)
    np.testing.assert_allclose(Rl, Rs, rtol=0, atol=1e-11 * np.abs(Rs).max())
    np.testing.assert_allclose(Jl, Js, rtol=0, atol=1e-11 * np.abs(Js).max())


@pytest.mark.parametrize("condense", [True, False])
def test_jacobian_of_the_linear_quadrature_against_differences(condense):
    system = impact_chain(5)
    s = discretised.solve(system, 0.6, "hbm", harmonics=10, stability=False, penalty_quadrature="linear",
                    condense=condense)
    assert s.success, s.message
    p = build_problem(system, 0.6, "hbm", harmonics=10, penalty_quadrature="linear", condense=condense)[0]
    x = p.initial_guess(s)
    assert 0 < (p._gaps(x) <= 0).sum() < p.Ns // 10  # partly closed: edges inside sample intervals
    R, J = p.residual(x)
    J = J.toarray() if hasattr(J, "toarray") else J
    h = 1e-6 * np.abs(x).max()
    Jfd = np.column_stack([(p.residual(x + h * e, False)[0] - p.residual(x - h * e, False)[0]) / (2 * h)
                           for e in np.eye(x.size)])
    assert np.abs(J - Jfd).max() <= 1e-8 * np.abs(J).max()
    # the solution's element forces are the samples whose DFT the residual uses: energy balances to rounding
    (eb,) = [c for c in s.certificate.checks if c.name == "energy_balance"]
    assert eb.value < 1e-10


def test_jacobian_is_continuous_where_the_sampled_one_jumps():
    """Along a line in q_hat that moves the contact edges across samples, the linear quadrature's Jacobian
    changes in proportion to the step; the sampled law's jumps by k_c-sized steps (why its branch kinks)."""
    system = impact_chain(5)
    s = discretised.solve(system, 0.6, "hbm", harmonics=10, stability=False)
    jumps = {}
    for quad in ("samples", "linear"):
        p = build_problem(system, 0.6, "hbm", harmonics=10, penalty_quadrature=quad)[0]
        x0 = p.initial_guess(s)
        d = np.zeros_like(x0)
        d[0] = 0.05  # the mean of q_1 up by 5 cm (half the gap): the contact window widens
        Js = [p.residual(x0 + t * d)[1] for t in np.linspace(0.0, 1.0, 201)]
        jumps[quad] = max(np.abs(b - a).max() for a, b in zip(Js, Js[1:]))
        n_switch = (p._gaps(x0 + d) <= 0).sum() - (p._gaps(x0) <= 0).sum()
        assert n_switch >= 1  # the path crosses sample switches
    # one sample entering the contact changes the mean row's entry by k_c / N_s (E[0, s] = 1 / N_s)
    assert jumps["samples"] >= 0.99 * 8000.0 / p.Ns, jumps
    assert jumps["linear"] < 0.05 * jumps["samples"], jumps


@pytest.fixture(scope="module")
def impact5():
    return mshbm.load_case(ROOT / "examples" / "impact5.yaml").system


@pytest.fixture(scope="module")
def event_branch(impact5):
    b = mshbm.sweep(impact5, 0.5, 0.75, "shooting", integrator="event", steps=1024)
    assert b.success, b.message
    return b


@pytest.mark.slow
def test_hbm_sweep_traces_the_impact_chain_branch(impact5, event_branch):
    """``mshbm.sweep`` with HBM from the default start over [0.5, 0.75] rad/s (examples/impact5.yaml,
    k_c = 8000).  Measured (n_H = 20, 156 points, ~12 s): monotone in omega (no spurious fold), mass 1
    within 2.4 %, 4.0 %, 2.8 % of the penalty model's exact periodic orbit at 0.55, 0.62, 0.70 rad/s
    (HBM's truncation error; 0.5-0.9 % at n_H = 40), and within 15.6 % of the exact impact branch
    (the penalty model's own error, ~10 % at 0.62 rad/s for k_c = 8000, 2.8 % for 8e4, 0.7 % for 8e5:
    the contact lasts ~1 % of the period); its period doubling within 1e-3 of the event branch's."""
    b = mshbm.sweep(impact5, 0.5, 0.75, "hbm", harmonics=20)
    # traced to the end; its points are up to 15.6 % off the impact branch, and say so (not certified at 1 %)
    assert b.accuracy["reached_end"] and not b.success, b.message
    assert all(p.certificate["failed"] == ["accuracy"] for p in b.points)
    assert b.omega[0] == 0.5 and b.omega[-1] == 0.75
    assert np.all(np.diff(b.omega) > 0)
    assert not [f for f in b.bifurcations if f["type"] == "fold"]
    a1 = b.amplitude[:, 0]
    for om in (0.55, 0.62, 0.70):
        i = int(np.argmin(np.abs(b.omega - om)))
        sol = b.points[i].solution
        ref = penalty_ode_amplitudes(impact5, b.omega[i], np.concatenate([sol.q[0], sol.u[0]]))
        assert abs(a1[i] / ref[0] - 1) < 0.05, (om, a1[i], ref[0])
    dev = np.abs(a1 / np.interp(b.omega, event_branch.omega, event_branch.amplitude[:, 0]) - 1)
    assert dev.max() < 0.17, dev.max()
    assert b.accuracy["largest"]["estimate"] >= dev.max()
    pd_h = [f["omega"] for f in b.bifurcations if f["type"] == "period-doubling"]
    pd_e = [f["omega"] for f in event_branch.bifurcations if f["type"] == "period-doubling"]
    assert pd_e and pd_h
    assert abs(pd_h[0] / pd_e[0] - 1) < 1e-3, (pd_h, pd_e)


def test_sampled_quadrature_is_kept_on_request_and_checked(impact5):
    with pytest.raises(mshbm.InputError, match="penalty_quadrature"):
        discretised.solve(impact5, 0.6, "hbm", harmonics=5, penalty_quadrature="trapezoid")
    damped = impact5.with_elements([mshbm.Contact(0, 0.1, 1.0, 8000.0, 5.0)])
    with pytest.raises(mshbm.InputError, match="penalty_quadrature"):
        discretised.solve(damped, 0.6, "hbm", harmonics=5, penalty_quadrature="linear")
    b = mshbm.sweep(impact5, 0.5, 0.53, "hbm", harmonics=9, penalty_quadrature="samples", stability=False,
                    max_points=40)
    # the sampled equations' branch at the default 512 samples: a fold at 0.531 rad/s turns it back
    assert [f for f in b.bifurcations if f["type"] == "fold"] or not b.success
