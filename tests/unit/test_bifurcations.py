"""Bifurcations (mshbm.bifurcations) and the closed forms of the impact oscillator (tests/closed_forms.py).

The damped impact oscillator ``x'' + 0.1 x' + x = cos(omega t)``, stop at ``x = 0.1``, ``r = 0.8``:

* its (1,1) orbit and impact-map multipliers in closed form against the exact event-driven solver
  (amplitude, multipliers of the monodromy with saltation) and against ``solve(..., "shooting")``;
* the period doubling at ``omega_PD = 2.456715356`` (det(J + I) = 0 of the impact map), seen by
  ``mshbm.stability`` on exact solutions on both sides and found by :func:`detect` on branches of the
  closed form and of the exact solver;
* the grazing at ``|G(omega_g)| = sigma``, ``omega_g = 3.315795717`` (the linear response touches the
  stop; the (1,1) orbit's impact velocity goes to 0 there);
* folds and Neimark-Sacker bifurcations on synthetic data.
"""
import numpy as np
import pytest

import closed_forms as cf
import mshbm
from mshbm import bifurcations, stability
from mshbm.bifurcations import BranchPoint, detect
from mshbm.errors import InputError
from mshbm.methods.exact import exact_periodic

#: the derived period-doubling frequency (closed_forms.omega_pd), quoted to check it does not drift
OMEGA_PD = 2.4567153560435933
#: grazing: |G(omega)| = sigma
OMEGA_G = 3.315795717103483


@pytest.fixture(scope="module")
def oscillator():
    return cf.system()


def _exact(system, omega):
    """Exact periodic solution started from the closed-form state half a period after the impact."""
    t0, v = cf.stable_orbit(omega)
    ts = t0 + np.pi / omega
    x, xd = cf.free_flight(ts, t0, v, omega)
    return exact_periodic(system, omega, guess={"q0": np.array([x]), "u0": np.array([xd]), "t0": ts})


def test_closed_form_values():
    assert cf.omega_pd() == pytest.approx(OMEGA_PD, rel=1e-12)
    assert cf.omega_grazing() == pytest.approx(OMEGA_G, rel=1e-12)
    # undamped, sigma = 0 (Budd & Dux setting): the same derivation gives the values of test_stability
    t0, v = next(p for p in cf.orbit_11(2.65, 0.0, 0.0, 0.8) if p[1] > 0)
    np.testing.assert_allclose(cf.multipliers(2.65, t0, v, 0.0, 0.0, 0.8), [-0.88473096, -0.72338375], atol=1e-8)
    for omega in (1.5, 2.2, OMEGA_PD, 3.0):
        t0, v = cf.stable_orbit(omega)
        T = 2 * np.pi / omega
        x1, v1 = cf.free_flight(t0 + T, t0, v, omega)
        assert x1 == pytest.approx(cf.SIGMA, abs=1e-12) and v1 == pytest.approx(v, rel=1e-12)  # periodic
        J = cf.impact_map_jacobian(omega, t0, v)
        assert np.linalg.det(J) == pytest.approx(cf.R ** 2 * np.exp(-2 * cf.ZETA * T), rel=1e-10)
    mu = cf.multipliers(OMEGA_PD, *cf.stable_orbit(OMEGA_PD))
    assert np.min(np.abs(mu + 1)) < 1e-10
    assert cf.stable_orbit(OMEGA_G * 1.001) is None  # no (1,1) orbit beyond grazing


# shooting is not checked at omega = 3.0: there the (1,1) orbit is strongly unstable (mu = -31.6) and
# Moreau-Jean shooting stalls at ||R|| ~ 2e-3 from every start, the exact orbit included (measured;
# 5e-4 with 8192 steps, 1.5e-4 with 16384), so solve() rightly reports no certified solution.
@pytest.mark.parametrize("omega, shoot", [(1.5, True), (2.0, True), (2.3, True), (0.99 * OMEGA_PD, True),
                                          (1.01 * OMEGA_PD, True), (3.0, False)])
def test_exact_solver_and_shooting_match_the_closed_form(oscillator, omega, shoot):
    t0, v = cf.stable_orbit(omega)
    A = cf.amplitude(omega, t0, v)
    mu_ref = cf.multipliers(omega, t0, v)
    ex = _exact(oscillator, omega)
    assert ex.success and ex.info["n_impacts"] == 1
    assert ex.info["amplitude_exact"][0] == pytest.approx(A, rel=1e-8)
    np.testing.assert_allclose(np.sort_complex(ex.floquet_multipliers), mu_ref, atol=1e-6 * max(1, np.abs(mu_ref).max()))
    if not shoot:
        return
    sh = mshbm.solve(oscillator, omega, "shooting")  # default start ladder, 4096 Moreau-Jean steps
    assert sh.success
    assert sh.amplitude[0] == pytest.approx(A, rel=5e-3)
    # the stability analysis of solve(): the exact flow's monodromy with saltation along the reported (Moreau-Jean)
    # orbit, which lies within 1e-4..2e-3 of the exact one: its largest modulus within the estimated error of the
    # closed form's (below the period doubling the pair's modulus r e^{-zeta T} is the same on every orbit), the
    # multipliers within a few orbit distances (measured: |d mu| / distance <= 2.4)
    st = sh.info["stability"]
    assert sh.stability_method == stability.EXACT and sh.stability_orbit == stability.REPORTED
    mu = np.sort_complex(sh.floquet_multipliers)
    assert abs(np.abs(mu).max() - np.abs(mu_ref).max()) <= st["multiplier_error"] + 1e-12
    np.testing.assert_allclose(mu, mu_ref, atol=5 * st["orbit_distance"] * max(1, np.abs(mu_ref).max()))
    assert sh.stable is bool(np.abs(mu_ref).max() < 1)


def test_period_doubling_seen_by_the_exact_flow(oscillator):
    """A multiplier passes -1 between 0.99 and 1.01 omega_PD: stable before, flip-unstable after."""
    below, above = _exact(oscillator, 0.99 * OMEGA_PD), _exact(oscillator, 1.01 * OMEGA_PD)
    assert below.stable is True and above.stable is False
    mu = above.floquet_multipliers
    big = mu[np.argmax(np.abs(mu))]
    assert abs(big.imag) < 1e-9 and big.real < -1.0
    assert np.max(np.abs(below.floquet_multipliers)) < 1.0
    # and detect() on these exact points, refined by bisection with exact solves
    locate = lambda kind, a, b: _exact_point(oscillator, 0.5 * (a.omega + b.omega))
    found = detect([_exact_point(oscillator, 0.99 * OMEGA_PD), _exact_point(oscillator, 1.01 * OMEGA_PD)],
                   locate=locate)
    assert [b.type for b in found] == ["period-doubling"]
    assert found[0].located == "bisection"
    assert found[0].omega == pytest.approx(OMEGA_PD, rel=1e-3)


def _exact_point(system, omega):
    ex = _exact(system, omega)
    assert ex.success
    return BranchPoint(omega, x=ex, multipliers=ex.floquet_multipliers, contact_active=ex.info["n_impacts"] > 0)


def _closed_form_point(omega):
    """Branch record of the response at omega: the (1,1) orbit below grazing, the linear response above."""
    p = cf.stable_orbit(omega)
    if p is None:  # no contact: linear response, gap = sigma - |G|
        G = 1 / (1 - omega ** 2 + 2j * cf.ZETA * omega)
        lam = -cf.ZETA + 1j * np.sqrt(1 - cf.ZETA ** 2)
        T = 2 * np.pi / omega
        return BranchPoint(omega, multipliers=np.exp(np.array([lam, lam.conjugate()]) * T),
                           contact_active=False, gap=cf.SIGMA - abs(G))
    return BranchPoint(omega, multipliers=cf.multipliers(omega, *p), contact_active=True, gap=-p[1])


def test_detect_on_the_closed_form_branch():
    omegas = np.arange(1.5, 3.6, 0.07)
    pts = [_closed_form_point(w) for w in omegas]
    found = detect(pts)
    assert [b.type for b in found] == ["period-doubling", "grazing"]
    pd, gr = found
    assert pd.omega == pytest.approx(OMEGA_PD, rel=2e-3)  # measured 0.085 % (det(J + I) interpolated)
    assert omegas[pd.index] < OMEGA_PD < omegas[pd.index + 1]
    assert gr.omega == pytest.approx(OMEGA_G, rel=1e-2)
    assert pd.as_dict() == {"type": "period-doubling", "omega": pd.omega, "index": pd.index}
    # refined by bisection on the closed form
    locate = lambda kind, a, b: _closed_form_point(0.5 * (a.omega + b.omega))
    found = detect(pts, locate=locate, rel_tol=1e-5)
    assert [b.located for b in found] == ["bisection", "bisection"]
    assert found[0].omega == pytest.approx(OMEGA_PD, rel=1e-5)
    assert found[1].omega == pytest.approx(OMEGA_G, rel=1e-5)
    # the same branch walked downwards
    back = detect(pts[::-1])
    assert [b.type for b in back] == ["grazing", "period-doubling"]
    assert back[1].omega == pytest.approx(OMEGA_PD, rel=1e-2)


def test_detect_on_an_exact_solver_branch(oscillator):
    omegas = np.arange(2.2, 2.75, 0.05)
    pts = [_exact_point(oscillator, w) for w in omegas]
    found = detect(pts)
    assert [b.type for b in found] == ["period-doubling"]
    assert found[0].omega == pytest.approx(OMEGA_PD, rel=2e-3)  # measured 0.022 %
    assert all(p.contact_active for p in pts)


def test_stability_change_matches_the_period_doubling(oscillator):
    """Stable below omega_PD, unstable above, on the closed-form branch (no other change in between)."""
    for w in np.linspace(1.5, 0.995 * OMEGA_PD, 12):
        assert np.abs(cf.multipliers(w, *cf.stable_orbit(w))).max() < 1
    for w in np.linspace(1.005 * OMEGA_PD, 0.995 * OMEGA_G, 12):
        assert np.abs(cf.multipliers(w, *cf.stable_orbit(w))).max() > 1


# ----------------------------------------------------------------------------- synthetic data
def _fold_branch(ds=0.13):
    """omega(s) = 2 - (s - 1)^2 (a turning point at omega = 2), unit tangent (d omega, d a)/ds normalised."""
    s = np.arange(0.0, 2.0 + 1e-9, ds)
    w = 2.0 - (s - 1.0) ** 2
    dw, da = -2.0 * (s - 1.0), np.ones_like(s)
    t = dw / np.hypot(dw, da)
    return s, [BranchPoint(wi, x=si, tangent_omega=ti) for wi, si, ti in zip(w, s, t)]


def test_fold_on_synthetic_tangent():
    s, pts = _fold_branch()
    found = detect(pts)
    assert [b.type for b in found] == ["fold"]
    assert found[0].omega == pytest.approx(2.0, rel=1e-2)
    assert s[found[0].index] < 1.0 < s[found[0].index + 1]

    def locate(kind, a, b):
        sm = 0.5 * (a.x + b.x)
        dw = -2.0 * (sm - 1.0)
        return {"omega": 2.0 - (sm - 1.0) ** 2, "x": sm, "tangent_omega": dw / np.hypot(dw, 1.0)}

    fine = detect(pts, locate=locate, rel_tol=1e-6)
    assert fine[0].omega == pytest.approx(2.0, rel=1e-6)
    # two folds (an S-shaped branch): omega = s^3 - 3 s has turning points at s = -1 (omega 2), s = 1 (-2)
    s = np.linspace(-2.1, 2.2, 23)
    pts = [{"omega": si ** 3 - 3 * si + 10.0, "tangent_omega": 3 * si ** 2 - 3} for si in s]
    found = detect(pts)
    assert [b.type for b in found] == ["fold", "fold"]
    assert found[0].omega == pytest.approx(12.0, rel=1e-2) and found[1].omega == pytest.approx(8.0, rel=1e-2)


def _ns_point(w):
    r, phi = 0.8 + 0.1 * (w - 1.0), 2.0 + 0.1 * w  # |mu| = 1 at omega = 3
    return {"omega": w, "multipliers": [r * np.exp(1j * phi), r * np.exp(-1j * phi), 0.3, -0.2]}


def test_neimark_sacker_on_synthetic_multipliers():
    pts = [_ns_point(w) for w in np.arange(1.0, 4.0, 0.17)]
    found = detect(pts)
    assert [b.type for b in found] == ["neimark-sacker"]
    assert found[0].omega == pytest.approx(3.0, rel=1e-2)
    fine = detect(pts, locate=lambda k, a, b: _ns_point(0.5 * (a.omega + b.omega)), rel_tol=1e-6)
    assert fine[0].omega == pytest.approx(3.0, rel=1e-6)
    # a complex pair through the circle with negative real parts is still NS, not PD
    pts = [{"omega": w, "multipliers": [(0.8 + 0.1 * w) * np.exp(2.8j), (0.8 + 0.1 * w) * np.exp(-2.8j)]}
           for w in np.arange(0.0, 4.0, 0.3)]
    assert [b.type for b in detect(pts)] == ["neimark-sacker"]


def test_period_doubling_on_synthetic_multipliers_and_missing_data():
    mu = lambda w: [-0.5 - 0.5 * (w - 1.0), 0.1]  # -1 at omega = 2
    pts = [{"omega": w, "multipliers": mu(w)} for w in np.arange(1.0, 3.0, 0.11)]
    pts[9]["multipliers"] = None  # omega = 1.99: no reliable estimate; the event is bracketed by 8 and 10
    pts[10]["multipliers"] = None
    found = detect(pts)
    assert [b.type for b in found] == ["period-doubling"]
    assert (found[0].index, found[0].index_right) == (8, 11)
    assert found[0].omega == pytest.approx(2.0, rel=1e-2)
    # a multiplier that returns inside: two events; no event without a crossing
    pts = [{"omega": w, "multipliers": [-1.2 + 0.3 * (w - 1.5) ** 2, 0.5]} for w in np.linspace(0.0, 3.0, 31)]
    assert [b.type for b in detect(pts)] == ["period-doubling", "period-doubling"]
    assert detect([{"omega": w, "multipliers": [0.5, -0.9]} for w in (1.0, 2.0, 3.0)]) == []


def _graze_point(w, w_g=2.0):
    """A branch of impacting orbits whose second impact loses its velocity at w_g: two impacts below
    (velocity margin -(w_g - w) ... linear), one above (near-miss gap 3 (w - w_g)); its multiplier runs off
    to -infinity like -1 / v just below w_g (a saltation matrix's 1 / v), as the exact flow's do."""
    if w < w_g:
        return {"omega": w, "contact_active": True, "gap": -1.0, "impacts": 2, "impact_margin": -(w_g - w),
                "miss_margin": 0.8, "multipliers": [-0.5 - 0.01 / (w_g - w), 0.3]}
    return {"omega": w, "contact_active": True, "gap": -1.0, "impacts": 1, "impact_margin": -1.2,
            "miss_margin": 3.0 * (w - w_g), "multipliers": [-0.6, 0.3]}


def test_grazing_between_impacting_orbits_on_synthetic_records():
    """The impact count changes between impacting orbits (contact active on both sides): a grazing, located from
    the impact margin on the side with more impacts and the near-miss margin on the other (both linear, zero
    at w_g); the multiplier through -1 next to it (the 1 / v of the vanishing impact) is not a period doubling
    of its own when the impact counts differ, but a real one on the two-impact side is kept."""
    ws = [1.0, 1.4, 1.7, 1.95, 1.99, 2.3, 2.6]
    found = detect([_graze_point(w) for w in ws])
    # mu = -0.5 - 0.01 / (2 - w): -0.7 at 1.95, -1.5 at 1.99 (a period doubling at 1.98 on the two-impact side),
    # -0.6 on the one-impact side (its count change across the grazing is the grazing's)
    assert [(b.type, b.index) for b in found] == [("period-doubling", 3), ("grazing", 4)]
    assert 1.95 < found[0].omega < 1.99  # interpolated in its bracket (1.965: det(Phi + I) is not linear there)
    assert found[1].omega == pytest.approx(2.0, abs=0.01)  # margins -0.01 and 0.9: interpolated 1.9934
    # bisection with records on the branch: to rel_tol
    fine = detect([_graze_point(w) for w in ws], rel_tol=1e-6, types=["grazing"],
                  locate=lambda k, a, b: _graze_point(0.5 * (a.omega + b.omega)))
    assert len(fine) == 1 and fine[0].located == "bisection"
    assert fine[0].omega == pytest.approx(2.0, rel=1e-6)


def test_bad_input():
    with pytest.raises(InputError, match="types"):
        detect([], types=["hopf"])
    with pytest.raises(InputError, match="omega"):
        detect([{"multipliers": [0.5]}])
    with pytest.raises(InputError, match="points"):
        detect([1.0])
    with pytest.raises(InputError, match="rel_tol"):
        detect([], rel_tol=0)
    assert bifurcations.TYPES == ("fold", "period-doubling", "neimark-sacker", "grazing")


def test_grazing_on_an_exact_solver_branch(oscillator):
    """Through omega_g from the default start of the exact solver: the (1,1) orbit (unstable, one impact)
    below, the linear response (no contact) above; point_from_solution gives the records."""
    from mshbm.bifurcations import point_from_solution

    exact = lambda w, guess=None: point_from_solution(oscillator, exact_periodic(oscillator, w, guess=guess))
    pts = [exact(w) for w in np.arange(3.20, 3.45, 0.04)]
    assert [p.contact_active for p in pts] == [True] * 3 + [False] * 4
    assert all(p.multipliers is not None and p.multipliers.size == 2 for p in pts)
    found = detect(pts)
    assert [b.type for b in found] == ["grazing"]  # the multipliers' jump there is no period doubling
    assert found[0].omega == pytest.approx(OMEGA_G, rel=2e-3)  # measured 0.12 %

    def locate(kind, a, b):  # from the bracketing solutions; the orbit with the tiny impact velocity
        w = 0.5 * (a.omega + b.omega)  # just below omega_g defeats the exact solver (measured at 3.315)
        for guess in (a.x, b.x):
            p = exact(w, guess)
            if p.contact_active is not None:
                return p
        return None

    fine = detect(pts, locate=locate)
    assert fine[0].located == "bisection" and fine[0].omega == pytest.approx(OMEGA_G, rel=1e-3)  # measured 0.057 %
    # a failed solve gives a record without data
    bad = mshbm.solve(oscillator, 3.0, "shooting", max_iter=0, guess="zero", stability=False)
    p = point_from_solution(oscillator, bad)
    assert not bad.success and p.multipliers is None and p.contact_active is None
