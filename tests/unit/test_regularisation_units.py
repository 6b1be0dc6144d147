"""HBM's regularised laws: defaults from the problem's own scales (the same physics in every unit system)
and the certificate's ``regularisation`` estimate (:mod:`mshbm.methods.hbm_regularisation`).

References: the exact event-driven periodic orbit (:func:`mshbm.exact_periodic`) of the 1-DOF Coulomb
oscillator ``x'' + x = cos(r t) - beta sign(x')`` (Den Hartog's system; ``beta = mu F_N / F``,
``r = omega / omega_0``), and Den Hartog's closed form where the motion has no stops
(``tests/unit/test_dlft.py`` checks the closed form against the exact flow).  The regularisation error at a
fixed discretisation is measured against the same HBM with a law some 400 times stiffer than the default.
"""
import math

import numpy as np
import pytest

import mshbm
from mshbm import Contact, Friction, chain
from mshbm.methods import hbm_regularisation as hr


def den_hartog_closed_form(beta, r):
    """Amplitude of continuous (non-stop) motion, ``X / (F / k)``."""
    V = 1.0 / (1.0 - r ** 2)
    U = math.sin(math.pi / r) / (r * (1.0 + math.cos(math.pi / r)))
    return math.sqrt(V ** 2 - (beta * U) ** 2)


def coulomb(beta, smoothing=None, force=1.0, length=1.0):
    """The oscillator in other units: forces times ``force``, lengths times ``1 / length`` (``length = 1e-3``:
    displacements in mm) -- ``M, C, K`` times ``force * length``, forcing and ``mu F_N`` times ``force``;
    the amplitude is then ``X / length``.  ``force = 1 / length``: forcing and ``mu F_N`` scaled, ``M, C, K``
    not (positive homogeneity)."""
    a = force * length
    return chain([a], a, 0.0, forcing=[{"dof": 0, "amplitude": force}],
                 elements=[Friction(0, 1.0, beta * force, smoothing=smoothing)], name="coulomb")


def impact(penalty_stiffness=None, force=1.0, length=1.0):
    """``x'' + 0.1 x' + x = cos(0.8 t)``, stop at ``x = 0.5`` (``e_N = 1``), in other units as :func:`coulomb`."""
    a = force * length
    return chain([a], a, 0.1 * a, forcing=[{"dof": 0, "amplitude": force}],
                 elements=[Contact(0, 0.5 / length, 1.0, penalty_stiffness=penalty_stiffness)], name="impact")


@pytest.fixture(scope="module")
def stops_case():
    """``beta = 0.6``, ``r = 3`` (the issue's case; short stops, so the exact flow is the reference)."""
    beta, r = 0.6, 3.0
    s = coulomb(beta, smoothing=800.0)
    ex = mshbm.exact_periodic(s, r, guess=mshbm.solve(s, r, "shooting", steps=2048, stability=False))
    assert ex.success and ex.info["stick_fraction"] > 0.0  # stops: Den Hartog's formula does not apply
    return beta, r, float(ex.info["amplitude_exact"][0])


@pytest.fixture(scope="module")
def stops_hbm(stops_case):
    """HBM at n_H = 60 on the stops case (``certified``): ``{smoothing: solution}`` for the default smoothing
    (``None``) and the stiff reference (400 times the default factor over ``V_lin = 3 / 8``), each solved once for
    the tests that compare with them (about 4 s of CPU for the stiff one)."""
    beta, r, _ = stops_case
    stiff = 400.0 * hr.SMOOTHING_FACTOR / 0.375
    return {smoothing: hbm(coulomb(beta, smoothing=smoothing), r, 60) for smoothing in (None, stiff)}


def certified(sol):
    """The discretised equations solved and certified; ``success`` then says whether the combined error estimate
    is within the default accuracy (it need not be here: these tests measure the estimates themselves)."""
    assert sol.certificate is not None and sol.certificate.failed in ([], ["accuracy"]), sol.message
    assert sol.success is sol.certificate["accuracy"].passed
    return True


def hbm(system, omega, n_h):
    sol = mshbm.solve(system, omega, "hbm", harmonics=n_h, stability=False)
    certified(sol)
    return sol


# ----------------------------------------------------------------------------- units
@pytest.mark.parametrize("force, length", [(1e-11, 1e11), (1e-11, 1.0), (1.0, 1e-3), (1e6, 1e-3)])
def test_default_smoothing_gives_the_same_answer_in_other_units(force, length):
    beta, r = 0.6, 3.0
    ref = hbm(coulomb(beta), r, 20)
    sol = hbm(coulomb(beta, force=force, length=length), r, 20)
    # the smoothing scales like 1 / velocity, the answer like a length
    assert sol.info["regularisation"][0]["default"] is True
    assert sol.info["regularisation"][0]["smoothing"] == pytest.approx(
        ref.info["regularisation"][0]["smoothing"] * length, rel=1e-12)
    assert sol.amplitude[0] * length == pytest.approx(ref.amplitude[0], rel=1e-8)
    assert sol.certificate["regularisation"].value == pytest.approx(ref.certificate["regularisation"].value,
                                                                    rel=1e-6)


def test_explicit_smoothing_stays_absolute():
    """A given ``smoothing`` is used as given (s/m): in other units it is another law, another answer."""
    beta, r = 0.6, 3.0
    ref = hbm(coulomb(beta, smoothing=800.0), r, 20)
    # forcing and mu F_N times 1e-11, M, C, K unchanged: the exact answer is 1e-11 times the original
    sol = hbm(coulomb(beta, smoothing=800.0, force=1e-11, length=1e11), r, 20)
    assert sol.info["regularisation"][0] == {"element": 0, "kind": "friction", "smoothing": 800.0, "default": False}
    assert sol.amplitude[0] * 1e11 / ref.amplitude[0] - 1.0 > 0.2  # the same kappa at 1e-11 m/s: much softer
    # a 4 x stiffer law changes nothing there (kappa gamma << 1: the law hardly acts), but the estimate is at
    # least the distance of the law from Coulomb's along the solution (its work deficit, ~1): flagged
    check = sol.certificate["regularisation"]
    assert check.value > 0.9 and not check.passed and ("regularised laws' error" in sol.message or "regularisation" in sol.certificate["accuracy"].note)


def test_paper_friction_chain_scaled_by_1e_11_same_answer():
    """The paper's 3-DOF friction oscillator with forcing and ``F_N`` times 1e-11 (the exact answer scales
    exactly): with the default smoothing HBM's answer scales too."""
    import dataclasses
    from pathlib import Path

    c = mshbm.load_case(Path(__file__).resolve().parents[2] / "examples" / "friction3.yaml")
    el = dataclasses.replace(c.system.elements[0], smoothing=None)
    s = c.system.with_elements([el])
    small = mshbm.System(s.M, s.C, s.K, np.asarray(s.f_hat) * 1e-11,
                         [dataclasses.replace(el, normal_force=el.normal_force * 1e-11)])
    a, b = hbm(s, c.omega, 9), hbm(small, c.omega, 9)
    np.testing.assert_allclose(b.amplitude * 1e11, a.amplitude, rtol=1e-8)


@pytest.mark.parametrize("force, length", [(1e-11, 1e11), (1e-11, 1.0), (1.0, 1e-3)])
def test_default_penalty_gives_the_same_answer_in_other_units(force, length):
    ref = hbm(impact(), 0.8, 20)
    sol = hbm(impact(force=force, length=length), 0.8, 20)
    rec, rec0 = sol.info["regularisation"][0], ref.info["regularisation"][0]
    assert rec["default"] and rec["penalty_stiffness"] == pytest.approx(rec0["penalty_stiffness"] * force * length,
                                                                        rel=1e-12)
    assert rec0["penalty_stiffness"] == pytest.approx(hr.PENALTY_FACTOR * (1.0 + 0.8 ** 2), rel=1e-12)
    assert sol.amplitude[0] * length == pytest.approx(ref.amplitude[0], rel=1e-8)
    assert sol.certificate["regularisation"].value == pytest.approx(ref.certificate["regularisation"].value,
                                                                    rel=1e-6)


@pytest.mark.parametrize("system", [coulomb, impact])
def test_dlft_default_penalty_gives_the_same_answer_in_other_units(system):
    """DLFT's default ``eps`` is the condensed dynamic stiffness at the element (scales like a stiffness); its
    law is set-valued, so it has no ``regularisation`` check."""
    omega = 3.0 if system is coulomb else 0.8
    args = (0.6,) if system is coulomb else ()
    ref = mshbm.solve(system(*args), omega, "dlft", harmonics=15, stability=False)
    sol = mshbm.solve(system(*args, force=1e-11, length=1e-3), omega, "dlft", harmonics=15, stability=False)
    assert certified(ref) and certified(sol) and ref.success is sol.success
    assert sol.amplitude[0] * 1e-3 == pytest.approx(ref.amplitude[0], rel=1e-8)
    assert sol.info["dlft_penalty"][0] == pytest.approx(ref.info["dlft_penalty"][0] * 1e-14, rel=1e-12)
    assert "regularisation" not in sol.certificate


# ----------------------------------------------------------------------------- accuracy and the estimate
def test_den_hartog_default_smoothing_within_accuracy(stops_case, stops_hbm):
    """Default smoothing, harmonics enough that the truncation is small (n_H = 60): within the stated 1 % of
    the exact orbit (measured +0.73 %; with the former absolute default 800 s/m: +13.3 %), and the estimate
    (0.56 %) below the stated accuracy."""
    beta, r, A_ex = stops_case
    sol = stops_hbm[None]
    err = sol.amplitude[0] / A_ex - 1.0
    check = sol.certificate["regularisation"]
    assert abs(err) <= hr.REGULARISATION_BOUND
    assert check.gating is False and check.bound == hr.REGULARISATION_BOUND and check.passed
    assert check.value <= abs(err) <= 3.0 * check.value + 0.005  # + the truncation at n_H = 60 (0.4 %)


@pytest.mark.parametrize("smoothing", [800.0, 8000.0, None])
def test_regularisation_estimate_brackets_the_error(stops_case, stops_hbm, smoothing):
    """At a fixed discretisation (n_H = 60) the estimate lies between the regularisation error (against the same
    HBM with kappa = 3.2e7 s/m) and 3 times it.  Measured ratios: 1.06 (800 s/m, error 12.9 %), 1.29
    (8000 s/m, 2.7 %), 1.73 (default, 1e5 s/m: 0.33 %)."""
    beta, r, A_ex = stops_case
    stiff = stops_hbm[400.0 * hr.SMOOTHING_FACTOR / 0.375]  # V_lin = 3 / 8
    sol = stops_hbm[None] if smoothing is None else hbm(coulomb(beta, smoothing=smoothing), r, 60)
    true = abs(sol.amplitude[0] / stiff.amplitude[0] - 1.0)
    est = sol.certificate["regularisation"].value
    assert true <= est <= 3.0 * true
    if smoothing == 800.0:  # the former default: flagged, not hidden
        assert not sol.certificate["regularisation"].passed and ("regularised laws' error" in sol.message or "regularisation" in sol.certificate["accuracy"].note)


@pytest.mark.parametrize("smoothing", [800.0, None])
def test_long_stops_estimate_flags_the_error(smoothing):
    """``beta = 0.8``, ``r = 2.5`` (mass sticks 36 % of the period; the issue's +49 % at 800 s/m), n_H = 60:
    the estimate is within a factor 1.5 of the error against the exact orbit (measured: 800 s/m, error 47.2 %,
    estimate 38.4 %; default, 8.7e4 s/m: 2.2 % and 2.1 %), above the stated 1 % in both, and the message warns."""
    beta, r = 0.8, 2.5
    s = coulomb(beta, smoothing=800.0)
    ex = mshbm.exact_periodic(s, r, guess=mshbm.solve(s, r, "shooting", steps=2048, stability=False))
    assert ex.success and ex.info["stick_fraction"] > 0.3
    sol = hbm(coulomb(beta, smoothing=smoothing), r, 60)
    err = abs(sol.amplitude[0] / ex.info["amplitude_exact"][0] - 1.0)
    est = sol.certificate["regularisation"].value
    assert err / 1.5 <= est <= 1.5 * err
    assert est > hr.REGULARISATION_BOUND and ("regularised laws' error" in sol.message or "regularisation" in sol.certificate["accuracy"].note)


def test_regularisation_estimate_continuous_motion():
    """Den Hartog's closed form (beta = 0.3, r = 0.6, no stops): HBM at n_H = 60 with the default smoothing
    within 0.2 % of it (the truncation: -0.11 %), the regularisation error (5.6e-6) bracketed by the estimate
    (8.4e-6)."""
    beta, r = 0.3, 0.6
    X = den_hartog_closed_form(beta, r)
    sol = hbm(coulomb(beta), r, 60)
    stiff = hbm(coulomb(beta, smoothing=400.0 * sol.info["regularisation"][0]["smoothing"]), r, 60)
    assert abs(sol.amplitude[0] / X - 1.0) <= 2e-3
    true = abs(sol.amplitude[0] / stiff.amplitude[0] - 1.0)
    est = sol.certificate["regularisation"].value
    assert true <= est <= 3.0 * true


def test_unforced_velocity_scale_falls_back():
    """A static load only: the linear response has no velocity, the scale is ``omega F / k_w`` (finite)."""
    s = chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 0.0, "constant": 1.0}],
              elements=[Friction(0, 0.5, 1.0)])
    system, record = hr.resolve(s, 1.0)
    k_w = 1.0 / np.linalg.inv(np.array([[2.0, -1.0], [-1.0, 1.0]]) + np.eye(2))[0, 0]
    assert record[0]["default"] and record[0]["linear_velocity"] == 0.0
    assert record[0]["velocity_scale"] == pytest.approx(1.0 * 1.0 / k_w, rel=1e-12)
    assert system.elements[0].smoothing == pytest.approx(hr.SMOOTHING_FACTOR * k_w, rel=1e-12)


def test_undamped_resonance_velocity_scale_is_capped():
    """At the undamped resonance of the chain without its friction the linear response is unbounded; the
    velocity scale is then ``omega F / k_w`` and HBM holds the stick (the clamped chain's amplitudes)."""
    w1 = 0.4450418679126287
    s = chain([1.0] * 3, 1.0, 0.0, forcing=[{"dof": 2, "amplitude": 5.0}], elements=[Friction(0, 0.8, 100.0)])
    _, record = hr.resolve(s, w1)
    assert record[0]["linear_velocity"] > 1e6 and record[0]["velocity_scale"] == record[0]["force_velocity"] < 10.0
    sol = mshbm.solve(s, w1, "hbm", harmonics=3, steps=1024, guess="zero", stability=False)
    H = np.array([[2.0 - w1 ** 2, -1.0], [-1.0, 1.0 - w1 ** 2]])
    assert certified(sol) and np.allclose(sol.amplitude[1:], np.abs(np.linalg.solve(H, [0.0, 5.0])), rtol=1e-4)
