"""Stability fields of every solve (mshbm.stability): Floquet multipliers of the nonsmooth flow.

Independent checks:

* the 1-DOF impact oscillator ``x'' + x = cos(omega t)``, ``x <= sigma``, restitution ``e``: its
  (1,1) orbit and the Jacobian of the impact map (impact time, approach velocity) -> (next impact
  time - T, next approach velocity) in closed form (Budd & Dux), one stable and one unstable orbit;
* Den Hartog-type 1-DOF oscillators with Coulomb friction: the verdict and the largest modulus
  against the decay of a perturbation in long simulations (Moreau-Jean for stick-slip; the
  event-driven flow for slip reversals without stick, where the step map cannot see the contraction);
* the paper's 5-DOF impact chain: the flip multiplier against the growth of a perturbation.
"""
import copy
import json

import numpy as np
import pytest
from scipy.optimize import fsolve

import mshbm
from mshbm import Contact, Friction, chain, stability
from mshbm.errors import InputError
from mshbm.result import PeriodicSolution
from mshbm.methods.exact import ExactFlow
from mshbm.methods.exact import exact_periodic
from mshbm.integrators.moreau_jean import MoreauJean

from paper_systems import OMEGA


# ----------------------------------------------------------------------------- closed form (Budd & Dux)
def _free(t, t0, v, omega, sigma, e):
    """Free flight after the impact at ``t0`` with approach velocity ``v`` (rebound ``-e v``)."""
    g = 1.0 / (1.0 - omega ** 2)
    a, b = sigma - g * np.cos(omega * t0), -e * v + g * omega * np.sin(omega * t0)
    tau = t - t0
    x = g * np.cos(omega * t) + a * np.cos(tau) + b * np.sin(tau)
    xd = -g * omega * np.sin(omega * t) - a * np.sin(tau) + b * np.cos(tau)
    return x, xd


def _orbit_11(omega, sigma, e, t_guess, v_guess):
    """Impact time ``t0`` and approach velocity ``v`` of the (1,1) orbit (one impact per period)."""
    T = 2 * np.pi / omega

    def F(p):
        x, xd = _free(p[0] + T, p[0], p[1], omega, sigma, e)
        return [x - sigma, xd - p[1]]

    p, _, ier, msg = fsolve(F, [t_guess, v_guess], full_output=True, xtol=1e-14)
    assert ier == 1 and max(abs(np.array(F(p)))) < 1e-12, msg
    return p[0] % T, p[1]


def _impact_map_jacobian(t0, v, omega, sigma, e):
    """d(t1 - T, v1)/d(t0, v) of the impact map, by hand from the free flight (implicit function theorem)."""
    T = 2 * np.pi / omega
    g = 1.0 / (1.0 - omega ** 2)
    c, s = np.cos(omega * t0), np.sin(omega * t0)
    a, b = sigma - g * c, -e * v + g * omega * s
    ct, st = np.cos(T), np.sin(T)  # tau = t1 - t0 = T on the orbit
    dx_dt0 = g * omega * s * ct + g * omega ** 2 * c * st + a * st - b * ct
    dx_dv = -e * st
    dxd_dt0 = -g * omega * s * st + g * omega ** 2 * c * ct + a * ct + b * st
    dxd_dv = -e * ct
    x1, v1 = _free(t0 + T, t0, v, omega, sigma, e)
    acc = np.cos(omega * (t0 + T)) - x1  # x'' = cos(omega t) - x just before the impact
    dt1_dt0, dt1_dv = -dx_dt0 / v1, -dx_dv / v1
    return np.array([[dt1_dt0, dt1_dv], [dxd_dt0 + acc * dt1_dt0, dxd_dv + acc * dt1_dv]])


def _oscillator(sigma, e):
    return chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.0}], elements=[Contact(0, sigma, e)],
                 name="impact-oscillator")


def _closed_form_solution(omega, sigma, e, t0, v, N=4096, n_h=25):
    """The (1,1) orbit as a PeriodicSolution (what any converged method would return)."""
    T = 2 * np.pi / omega
    t = np.linspace(0.0, T, N + 1)
    before = _free(t, t0 - T, v, omega, sigma, e)
    after = _free(t, t0, v, omega, sigma, e)
    q = np.where(t < t0, before[0], after[0])[:, None]
    u = np.where(t < t0, before[1], after[1])[:, None]
    return PeriodicSolution(method="closed-form", omega=omega, harmonics=n_h, steps=N, success=True,
                            message="closed form", iterations=0, nfev=0, residual=0.0, wall_time=0.0, t=t,
                            q_hat=mshbm.fourier.fft(q[:-1], n_h), time_dofs=np.arange(1), q_time=q, u_time=u,
                            lam=np.zeros((N + 1, 1)), impulses=None, x=np.concatenate([q[0], u[0]]))


@pytest.mark.parametrize("omega, t_guess, v_guess, stable", [
    (2.65, 1.15, 0.45, True),    # mu = -0.8847, -0.7234
    (2.80, 1.09, 0.34, False),   # mu = -2.9581, -0.2164: flip instability
])
def test_impact_oscillator_against_impact_map(omega, t_guess, v_guess, stable):
    sigma, e = 0.0, 0.8
    t0, v = _orbit_11(omega, sigma, e, t_guess, v_guess)
    T = 2 * np.pi / omega
    tt = np.linspace(t0, t0 + T, 2001)[1:-1]
    xs = _free(tt, t0, v, omega, sigma, e)[0]
    assert xs.max() < sigma and xs[100:-100].max() < sigma - 1e-2  # admissible: no other contact
    J = _impact_map_jacobian(t0, v, omega, sigma, e)
    assert np.linalg.det(J) == pytest.approx(e ** 2, rel=1e-10)  # the handy check
    mu_ref = np.sort_complex(np.linalg.eigvals(J))
    assert (np.max(np.abs(mu_ref)) < 0.9) if stable else (np.max(np.abs(mu_ref)) > 2.0)
    system = _oscillator(sigma, e)
    # the analysis that solve() runs on its result, applied to the closed-form orbit
    sol = stability.assess(system, _closed_form_solution(omega, sigma, e, t0, v))
    assert sol.stability_method == stability.EXACT
    mu = np.sort_complex(sol.floquet_multipliers)
    assert mu.shape == (2,)
    np.testing.assert_allclose(mu, mu_ref, atol=1e-6)
    assert sol.stable is stable
    assert sol.info["stability"]["n_impacts"] == 1 and sol.info["stability"]["orbit_distance"] < 1e-3  # grid amplitude
    # the exact solver (started from a coarse sample of the orbit) carries the same fields
    ex = exact_periodic(system, omega, guess=_closed_form_solution(omega, sigma, e, t0, v, N=256))
    assert ex.success and ex.stable is stable
    np.testing.assert_allclose(np.sort_complex(ex.floquet_multipliers), mu_ref, atol=1e-6)


# ----------------------------------------------------------------------------- friction
def _den_hartog(zeta, bound):
    return chain([1.0], 1.0, 2 * zeta, forcing=[{"dof": 0, "amplitude": 1.0}],
                 elements=[Friction(0, 1.0, bound)], name="den-hartog")


def test_friction_stick_slip_against_moreau_jean_decay():
    """x'' + 0.1 x' + x = cos(t/2) - 0.5 sign(x'): stick-slip (19 % stick); mu = 0.0577 (and 0)."""
    s, omega, N = _den_hartog(0.05, 0.5), 0.5, 8192
    sol = mshbm.solve(s, omega, "shooting", steps=N)
    assert sol.success and sol.stability_method == stability.EXACT and sol.stable is True
    rho = float(np.max(np.abs(sol.floquet_multipliers)))
    assert sol.info["stability"]["stick_fraction"] > 0.1
    # Moreau-Jean from the (discretely periodic) shooting state and from a perturbed one
    T = 2 * np.pi / omega
    mj = MoreauJean(s.M, s.C, s.K, s.elements, T / N)
    B = mj.increments(s.forcing(np.linspace(0.0, T, N + 1), omega))
    x = np.array([sol.q[0, 0], sol.u[0, 0]])
    y = x + np.array([1e-3, 1e-3])
    dist = []
    for _ in range(4):
        ty, tx = mj.run(y[:1], y[1:], B), mj.run(x[:1], x[1:], B)
        y, x = np.array([ty.q[-1, 0], ty.u[-1, 0]]), np.array([tx.q[-1, 0], tx.u[-1, 0]])
        dist.append(np.max(np.abs(y - x)))
    rate = np.array(dist[1:]) / np.array(dist[:-1])
    np.testing.assert_allclose(rate, rho, rtol=0.02)


def test_friction_slip_reversal_contracts_without_damping():
    """Undamped, no stick: the contraction comes only from the saltation at the slip reversals
    (mu = -0.086 +- 0.284i, |mu| = 0.296); the Moreau-Jean step map sees none (|mu| = 1)."""
    s, omega = _den_hartog(0.0, 0.3), 0.6
    sol = mshbm.solve(s, omega, "shooting", steps=4096)
    assert sol.success and sol.stable is True and sol.info["stability"]["stick_fraction"] == 0.0
    rho = float(np.max(np.abs(sol.floquet_multipliers)))
    assert 0.25 < rho < 0.35
    np.testing.assert_allclose(np.abs(sol.info["step_map_multipliers"]), 1.0, atol=1e-9)
    # event-driven simulation of a perturbed state: geometric mean decay over 6 periods
    ex = exact_periodic(s, omega, guess=sol)
    x, ts = ex.info["state_at_section"], ex.info["section_time"]
    fl = ExactFlow(s, omega)
    z0 = fl.state(ts, x[:1] + 1e-4, x[1:])
    out = fl.simulate(ts, z0, duration=6 * fl.T, sample_times=ts + fl.T * np.arange(1, 7) - 1e-12)
    dist = np.max(np.abs(out.samples[:2].T - x), axis=1)
    rate = (dist[-1] / dist[0]) ** (1.0 / 5.0)
    assert rate == pytest.approx(rho, rel=0.05)


# ----------------------------------------------------------------------------- the paper's chain
def test_impact_chain_flip_instability(impact5):
    sol = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3, accuracy=0.05)  # n_H = 3: ~1 % truncation
    assert sol.success and sol.stable is False and sol.stability_method == stability.EXACT
    # the multipliers of the reported MS-HBM orbit (its own monodromy), within their estimated error of those of the
    # exact periodic orbit (-1.10846; measured: -1.10878, error estimate 6.3e-4)
    assert sol.stability_orbit == stability.REPORTED
    i = int(np.argmax(np.abs(sol.floquet_multipliers)))
    mu = sol.floquet_multipliers[i]
    err = sol.info["stability"]["multiplier_error"]
    assert abs(mu.imag) < 1e-12 and abs(mu.real + 1.10846) <= err < 2e-3
    # the perturbation along the flip eigenvector grows by |mu| per period, alternating its sign
    ex = exact_periodic(impact5, OMEGA, guess=sol)
    x, ts = ex.info["state_at_section"], ex.info["section_time"]
    w, V = np.linalg.eig(ex.info["monodromy"])
    vec = np.real(V[:, np.argmin(np.abs(w - mu))])
    fl = ExactFlow(impact5, OMEGA)
    z0 = np.concatenate([x + 1e-6 * vec / np.max(np.abs(vec)), fl.osc(ts)])
    out = fl.simulate(ts, z0, duration=8 * fl.T, sample_times=ts + fl.T * np.arange(1, 9) - 1e-12)
    d = (out.samples[:2 * impact5.n].T - x) @ vec
    assert np.all(d[1:] * d[:-1] < 0)  # flip: the sign alternates
    rate = (abs(d[-1]) / abs(d[0])) ** (1.0 / 7.0)
    assert rate == pytest.approx(abs(mu), rel=0.01)


def test_moreau_jean_step_map_is_no_verdict_at_impacts(impact5):
    """Shooting's own (discrete-map) multipliers are kept only as an estimate in info."""
    sol = mshbm.solve(impact5, OMEGA, "shooting", steps=2048)
    assert sol.info["step_map_impacts"] is True
    assert np.max(np.abs(sol.info["step_map_multipliers"])) < 0.9  # the wrong, "stable" answer
    assert sol.stable is False and np.max(np.abs(sol.floquet_multipliers)) > 1.1


def test_hbm_gets_the_flow_verdict(friction3):
    """The nonsmooth flow's monodromy along the reported HBM orbit (not HBM's regularised law): its largest
    modulus within the estimated error of the exact orbit's 0.96662 (measured 0.96708, error estimate 9.3e-4)."""
    sol = mshbm.solve(friction3, OMEGA, "hbm", harmonics=20)
    assert sol.success and sol.stability_method == stability.EXACT and sol.stable is True
    assert sol.stability_orbit == stability.REPORTED
    err = sol.info["stability"]["multiplier_error"]
    assert abs(np.max(np.abs(sol.floquet_multipliers)) - 0.96662) <= err < 2e-3
    assert sol.info["stability"]["orbit_distance"] < 0.01


# ----------------------------------------------------------------------------- options and fallbacks
def test_stability_option(impact5, monkeypatch):
    off = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3, stability=False)
    assert off.stable is None and off.floquet_multipliers.size == 0 and off.stability_method.startswith("none")
    assert "stability=False" in off.stability_reason
    with pytest.raises(InputError) as exc:
        mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3, stability="yes")
    assert exc.value.key == "stability"
    monkeypatch.setattr(stability, "MAX_EXACT_DOFS", 4)
    big = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3)
    assert big.stable is None and "stability=True" in big.stability_reason and big.floquet_multipliers.size == 0
    forced = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3, stability=True)
    assert forced.stable is False and forced.stability_method == stability.EXACT


def test_unconverged_solution_has_no_verdict(impact5):
    sol = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3, max_iter=0, continuation=False)
    assert not sol.success and sol.stable is None and sol.floquet_multipliers.size == 0


def test_several_elements_get_the_exact_flow_verdict():
    """Several elements: the exact event-driven flow decides, as for one element."""
    # contact far away (never touched) and friction with bound 0 on another DOF: the linear flow
    far = chain([1.0, 1.0], 1.0, 0.2, forcing=[{"dof": 1, "amplitude": 1.0}],
                elements=[Contact(0, 100.0, 1.0), Friction(1, 0.0, 1.0)])
    sol = mshbm.solve(far, OMEGA, "shooting", steps=2048)
    assert sol.stability_method == stability.EXACT and sol.stable is True
    alone = mshbm.solve(chain([1.0, 1.0], 1.0, 0.2, forcing=[{"dof": 1, "amplitude": 1.0}]), OMEGA, "shooting",
                        steps=2048)
    assert alone.stability_method == stability.EXACT
    np.testing.assert_allclose(np.sort(np.abs(sol.floquet_multipliers)), np.sort(np.abs(alone.floquet_multipliers)),
                               atol=1e-10)  # measured: equal
    # with impacts (and slip reversals): an exact verdict, checked against the decay of a perturbation along
    # the dominant eigenvector in an event-driven simulation over 8 periods
    for bound, rel in ((0.0, 1e-3), (0.2, 0.05)):  # measured: 1.3e-5 (real multiplier), 1.9e-2 (complex pair)
        hit = chain([1.0, 1.0], 1.0, 0.2, forcing=[{"dof": 1, "amplitude": 1.0}],
                    elements=[Contact(0, 0.05, 1.0), Friction(1, bound, 1.0)])
        sol = mshbm.solve(hit, OMEGA, "shooting", steps=2048)
        assert sol.success and sol.stability_method == stability.EXACT and sol.stable is True
        assert sol.floquet_multipliers.size == 4
        ex = exact_periodic(hit, OMEGA, guess=sol)
        assert ex.info["n_impacts"] >= 3
        x, ts = ex.info["state_at_section"], ex.info["section_time"]
        w, V = np.linalg.eig(ex.info["monodromy"])
        rho = float(np.max(np.abs(w)))
        # the Moreau-Jean orbit's own multipliers (2048 steps) are within their estimated error of the exact orbit's
        # (measured: 0.5412 against 0.5219, estimate 0.039; 0.3825 against 0.3772, estimate 0.011)
        assert abs(rho - float(np.max(np.abs(sol.floquet_multipliers)))) <= sol.info["stability"]["multiplier_error"]
        vec = np.real(V[:, np.argmax(np.abs(w))])
        fl = ExactFlow(hit, OMEGA)
        z0 = np.concatenate([x + 1e-6 * vec / np.max(np.abs(vec)), fl.osc(ts)])
        out = fl.simulate(ts, z0, duration=8 * fl.T, sample_times=ts + fl.T * np.arange(1, 9) - 1e-12)
        dist = np.max(np.abs(out.samples[:4].T - x), axis=1)
        assert (dist[-1] / dist[0]) ** (1.0 / 7.0) == pytest.approx(rho, rel=rel)


def test_json_fields(impact5, tmp_path):
    sol = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3)
    summ = json.loads(json.dumps(sol.summary()))
    pairs = np.array(summ["floquet_multipliers"])
    assert pairs.shape == (10, 2)
    np.testing.assert_allclose(pairs[:, 0] + 1j * pairs[:, 1], sol.floquet_multipliers)
    assert summ["stable"] is False and summ["stability_method"] == stability.EXACT
    assert abs(summ["floquet_max_modulus"] - 1.10846) <= sol.info["stability"]["multiplier_error"]
    assert summ["stability_orbit"] == stability.REPORTED
    # the CLI writes the same keys
    from mshbm.cli import main

    case = tmp_path / "c.yaml"
    case.write_text("masses: [10, 1, 1, 1, 1]\nstiffness: 1\ndamping: 0.3\nomega: 0.6283185307179586\n"
                    "forcing: [{dof: 4, amplitude: 5}]\ncontact: {dof: 0, gap: 0.1}\n"
                    "solver: {method: mshbm, harmonics: 3, stability: auto, accuracy: 0.05}\n")
    out = tmp_path / "o.json"
    assert main(["solve", str(case), "--out", str(out), "--quiet"]) == 0
    data = json.loads(out.read_text())
    assert data["stable"] is False and len(data["floquet_multipliers"]) == 10
    assert data["stability_method"] == stability.EXACT
    case.write_text(case.read_text().replace("stability: auto", "stability: maybe"))
    assert main(["solve", str(case), "--quiet"]) == 2


def test_nearby_exact_orbit_continued_from_the_previous_point(impact5):
    """Along a branch the previous point's exact orbit starts the next one's (``seed``): the same orbit and
    multipliers as from the reported orbit's own state, from a start much closer to it; a seed without an exact
    orbit (multipliers of its own) is ignored; a failed continuation one small step away is not retried from the
    reported orbit (stability.SEED_CLOSE)."""
    prev = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=1)  # n_H = 1: ~11 % from the exact orbit (measured)
    assert prev.stability_orbit == stability.NEARBY and len(prev.info["stability"]["exact_state"]) == 2 * impact5.n
    sol = mshbm.solve(impact5, 1.002 * OMEGA, "mshbm", harmonics=1, stability=False, guess=prev)
    plain, seeded = copy.deepcopy(sol), copy.deepcopy(sol)
    stability.assess(impact5, plain, "auto")
    stability.assess(impact5, seeded, "auto", seed=prev)
    a, b = plain.info["stability"], seeded.info["stability"]
    assert plain.stability_orbit == seeded.stability_orbit == stability.NEARBY and plain.stable == seeded.stable
    assert (a["exact_start"], b["exact_start"]) == ("reported", "seed")
    # the seed starts the Newton closer: its first periodicity residual |x(t_s + T) - x| (measured: 0.053 against
    # 1.08 from the reported state, 3 iterations each to 1e-11 here; on the FE plate 2-7 against 6-18 iterations)
    assert b["exact_start_residual"] < 0.1 * a["exact_start_residual"]
    assert b["exact_iterations"] <= a["exact_iterations"]
    np.testing.assert_allclose(np.sort_complex(seeded.floquet_multipliers), np.sort_complex(plain.floquet_multipliers),
                               atol=1e-9)
    np.testing.assert_allclose(b["exact_amplitude"], a["exact_amplitude"], rtol=1e-9)
    own = mshbm.solve(impact5, OMEGA, "mshbm", harmonics=3, accuracy=0.05)  # its own multipliers: no exact orbit
    assert own.stability_orbit == stability.REPORTED
    again = stability.assess(impact5, copy.deepcopy(sol), "auto", seed=own)
    assert again.info["stability"]["exact_start"] == "reported"
    # a continued orbit whose Newton fails (here a broken seed state) one small step away is the analysis's answer
    # (no second start from the reported orbit); after a larger step the reported orbit's start is tried
    bad = copy.deepcopy(prev)
    bad.info["stability"]["exact_state"] = [float("nan")] * (2 * impact5.n)
    near = stability.assess(impact5, copy.deepcopy(sol), "auto", seed=bad)
    assert near.stability_orbit != stability.NEARBY and "continued from the exact orbit at" in near.stability_reason
    far = mshbm.solve(impact5, 1.02 * OMEGA, "mshbm", harmonics=1, stability=False, guess=prev)
    assert abs(far.omega / bad.omega - 1.0) > stability.SEED_CLOSE
    far = stability.assess(impact5, far, "auto", seed=bad)
    assert far.stability_orbit == stability.NEARBY and far.info["stability"]["exact_start"] == "reported"
