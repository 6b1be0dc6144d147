"""Certified answers only: the convergence test cannot be fooled, every result
carries a certificate, undamped exact resonance is not a solution.

Every test asserts either a clean failure (``success=False`` naming the cause, or an InputError) or a
certified answer against an exact value: closed forms, linear responses from the dynamic stiffness,
the clamped chain, :func:`mshbm.exact_periodic` for one-element systems.
"""
import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import mshbm
from mshbm.certificate import DEFAULT_ACCURACY
from mshbm import Contact, Friction, InputError, System, chain
from paper_systems import system as paper_system

METHODS = ["shooting", "hbm", "mshbm", "mshbm-intermediate"]
OMEGA = np.pi / 5
W1 = 0.4450418679126287  # first eigenfrequency of the free 3-mass chain (wall-k-m-k-m-k-m)
STICK_YAML = """\
masses: [1, 1, 1]
stiffness: 1
omega: 0.4450418679126287
forcing: [{dof: 2, amplitude: 5}]
friction: {dof: 0, mu: 0.8, normal_force: 100}
solver: {harmonics: 3, steps: 1024}
"""


def clamped_amplitudes(w):
    """DOF 0 at rest: the 2-mass chain [[2, -1], [-1, 1]] - w^2 I with 5 cos(wt) on the last mass."""
    H = np.array([[2.0 - w * w, -1.0], [-1.0, 1.0 - w * w]])
    return np.abs(np.linalg.solve(H, [0.0, 5.0]))


def stick_system():
    return chain([1.0] * 3, 1.0, 0.0, forcing=[{"dof": 2, "amplitude": 5.0}],
                 elements=[Friction(0, 0.8, 100.0)])


def friction3():
    return paper_system("friction3")


def impact5():
    return paper_system("impact5")


# ------------------------------------------------------------------------- the stick example
def _stick_tolerance(method):
    # HBM: arctan law (kappa = 800) creeps at ~mu F_N / kappa; shooting: O((omega h)^2) of Moreau-Jean
    return {"hbm": 2e-3, "shooting": 1e-4}.get(method, 1e-8)


@pytest.mark.parametrize("method", METHODS)
def test_stick_case_cli_never_reports_garbage(tmp_path, method):
    case = tmp_path / "stick.yaml"
    case.write_text(STICK_YAML)
    out = tmp_path / "out.json"
    proc = subprocess.run([sys.executable, "-m", "mshbm", "solve", str(case), "--method", method, "--quiet",
                           "--out", str(out)], capture_output=True, text=True, timeout=300)
    data = json.loads(out.read_text())
    exact = clamped_amplitudes(W1)
    if proc.returncode == 0:
        assert data["success"] is True
        assert all(c["passed"] for c in data["certificate"] if c["gating"]), proc.stderr
        assert np.allclose(data["amplitude"][1:], exact, rtol=_stick_tolerance(method))
    else:
        assert proc.returncode == 1 and data["success"] is False, proc.stderr  # EXIT_NOT_CONVERGED
        assert "did not converge" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.parametrize("method", METHODS)
def test_stick_case_api_default_start(method):
    sol = mshbm.solve(stick_system(), W1, method, harmonics=3, steps=1024)
    if sol.success:
        assert np.allclose(sol.amplitude[1:], clamped_amplitudes(W1), rtol=_stick_tolerance(method))
        assert sol.amplitude[0] <= 1e-3 * sol.amplitude.max()
    else:  # a clean failure: Newton's diagnosis and the failed checks are named
        assert "certificate failed" in sol.message and not sol.certificate.passed
        assert all(name in sol.message for name in sol.certificate.failed)


@pytest.mark.parametrize("method", METHODS)
def test_stick_case_from_zero_is_the_clamped_chain(method):
    sol = mshbm.solve(stick_system(), W1, method, harmonics=3, steps=1024, guess="zero")
    assert sol.success, sol.message
    assert sol.certificate.passed
    assert np.allclose(sol.amplitude[1:], clamped_amplitudes(W1), rtol=_stick_tolerance(method))
    assert sol.certificate["friction_cone"].value < 1.0  # stick: strictly inside the cone


@pytest.mark.parametrize("method", METHODS)
def test_resonant_linear_response_as_guess_is_not_accepted(method):
    """The frictionless response at resonance (~1e16) as an explicit guess, no Newton iteration allowed:
    before the change HBM accepted it (||R|| = 100 <= 1e-10 * 1e16)."""
    from mshbm.methods.common import linear_response

    system = stick_system()
    q_hat = linear_response(system, W1, 3)
    assert np.abs(q_hat).max() > 1e10
    sol = mshbm.solve(system, W1, method, harmonics=3, steps=1024, guess={"q_hat": q_hat}, max_iter=0,
                      continuation=False)
    assert not sol.success
    assert "residual" in sol.message or "convergence" in sol.message
    # with the start ladder (default) the guess is its first rung and is rejected; a later start may succeed,
    # and then with the exact stick solution (the clamped chain), not the resonant one
    sol = mshbm.solve(system, W1, method, harmonics=3, steps=1024, guess={"q_hat": q_hat}, max_iter=0)
    first = sol.info["starts"][0]
    assert first["start"] == "guess" and not first["accepted"]
    if sol.success:
        assert sol.info["start_used"] != "guess"
        assert np.allclose(sol.amplitude[1:], clamped_amplitudes(W1), rtol=_stick_tolerance(method))



def _solves_its_equations(sol):
    """Every check of the discretised equations passed (``success`` may still fail on the default accuracy of
    the error estimates, :mod:`mshbm.route.refine`, which these tests of the other checks do not need)."""
    return sol.certificate is not None and sol.certificate.failed in ([], ["accuracy"])

@pytest.mark.parametrize("factor", [1e3, 1e8])
@pytest.mark.parametrize("method", METHODS)
def test_scaled_solution_as_guess(method, factor):
    """A certified solution times 1e3 / 1e8 as the start: a certified answer equal to the solution or a
    failure, never success elsewhere."""
    ref = mshbm.solve(friction3(), OMEGA, method, harmonics=5, steps=1024)
    assert _solves_its_equations(ref), ref.message
    guess = {"q_hat": factor * ref.q_hat, "q0": factor * ref.q[0], "u0": factor * ref.u[0]}
    sol = mshbm.solve(friction3(), OMEGA, method, harmonics=5, steps=1024, guess=guess)
    if sol.success:
        assert np.allclose(sol.amplitude, ref.amplitude, rtol=1e-6)
    else:
        assert sol.message


# ------------------------------------------------------------------------- undamped exact resonance
def oscillator(omega_n=1.0, c=0.0, elements=()):
    return System([[1.0]], [[c]], [[omega_n ** 2]], [[0.0], [1.0], [0.0]], elements)


@pytest.mark.parametrize("steps", [256, 1024, 4096])
def test_undamped_resonance_shooting_fails_and_names_the_cause(steps):
    """x'' + x = cos t has no periodic solution; Moreau-Jean's answer grows as N^2 (9959 at N = 256)."""
    sol = mshbm.solve(oscillator(), 1.0, "shooting", steps=steps)
    assert not sol.success
    assert "undamped_resonance" in sol.message and "no resolved periodic solution" in sol.message
    assert not sol.certificate["undamped_resonance"].passed


@pytest.mark.parametrize("method", METHODS)
def test_undamped_resonance_with_an_element_that_never_acts(method):
    """A contact 1e6 m away never closes: the 2-mass chain at its eigenfrequency is still undamped resonance."""
    system = chain([1.0, 1.0], 1.0, 0.0, forcing=[{"dof": 1, "amplitude": 1.0}], elements=[Contact(0, 1e6)])
    w = np.sqrt((3 - np.sqrt(5)) / 2)
    try:
        sol = mshbm.solve(system, w, method, harmonics=3, steps=1024)
    except InputError as exc:  # H_LL singular / empty subsystem: a clean error naming the key
        assert exc.key in ("omega", "partition", "method")
        return
    assert not sol.success, sol.message


def test_undamped_resonance_hbm_is_an_input_error():
    with pytest.raises(InputError) as info:
        mshbm.solve(oscillator(), 1.0, "hbm", harmonics=3)
    assert info.value.key == "omega"


@pytest.mark.parametrize("omega", [0.45, 0.9, 1.1, 3.0])
@pytest.mark.parametrize("method", ["shooting", "hbm"])
def test_undamped_off_resonance_is_certified_and_exact(method, omega):
    """x'' + x = cos(omega t): amplitude 1 / |1 - omega^2| (closed form); resonance check passes."""
    sol = mshbm.solve(oscillator(), omega, method, harmonics=3, steps=2048)
    assert sol.success, sol.message
    exact = 1.0 / abs(1.0 - omega ** 2)
    tol = 1e-9 if method == "hbm" else 10 * (omega * 2 * np.pi / omega / 2048) ** 2 / abs(1 - omega ** 2)
    assert sol.amplitude[0] == pytest.approx(exact, rel=tol)
    assert sol.certificate["undamped_resonance"].passed


@pytest.mark.parametrize("method", ["shooting", "hbm"])
def test_damped_exact_resonance_is_a_solution(method):
    """x'' + 0.1 x' + x = cos t: amplitude 1 / 0.1 = 10 exactly; damping makes it resolved."""
    sol = mshbm.solve(oscillator(c=0.1), 1.0, method, harmonics=3, steps=4096)
    assert sol.success, sol.message
    assert sol.amplitude[0] == pytest.approx(10.0, rel=1e-9 if method == "hbm" else 1e-5)
    assert "undamped_resonance" not in sol.certificate  # damped mode: not applicable
    e = sol.certificate.info["energy"]
    assert e["input_work"] == pytest.approx(np.pi * 10.0, rel=1e-9 if method == "hbm" else 1e-5)  # pi F A
    assert e["damper_dissipation"] == pytest.approx(e["input_work"], rel=1e-6)


# ------------------------------------------------------------------------- linear responses by hand
@pytest.mark.parametrize("s", [1e-12, 1.0, 1e6])
@pytest.mark.parametrize("method", ["shooting", "hbm"])
def test_damped_linear_chain_against_dynamic_stiffness(method, s):
    """3-mass damped chain, two forcing harmonics; amplitude of every harmonic from H(k omega)^-1 f_k."""
    system = chain([1.0, 2.0, 1.0], [1.0, 2.0, 1.0], 0.05,
                   forcing=[{"dof": 2, "amplitude": 1.0 * s}, {"dof": 0, "sin": 0.5 * s, "harmonic": 2}])
    system = System(system.M * s, system.C * s, system.K * s, system.f_hat)
    w = 0.8
    sol = mshbm.solve(system, w, method, harmonics=4, steps=4096)
    assert sol.success, sol.message
    for k in (1, 2):
        H = system.dense("K") - (k * w) ** 2 * system.dense("M") + 1j * k * w * system.dense("C")
        Z = np.linalg.solve(H, system.f_hat[2 * k - 1] - 1j * system.f_hat[2 * k])
        got = sol.q_hat[2 * k - 1] - 1j * sol.q_hat[2 * k]
        tol = 1e-9 if method == "hbm" else 1e-4
        assert np.max(np.abs(got - Z)) <= tol * np.max(np.abs(Z))
    assert sol.certificate.passed


# ------------------------------------------------------------------------- one-element exact references
@pytest.mark.parametrize("method", METHODS)
def test_friction3_certified_against_exact(method):
    exact = mshbm.exact_periodic(friction3(), OMEGA)
    assert exact.success
    sol = mshbm.solve(friction3(), OMEGA, method, harmonics=9, steps=4096)
    assert _solves_its_equations(sol), sol.message
    tol = {"hbm": 0.03, "shooting": 1e-4}.get(method, 1e-3)
    err = np.max(np.abs(sol.amplitude - exact.amplitude)) / exact.amplitude.max()
    assert err <= tol
    # certified means within the default accuracy; otherwise the combined estimate says so (HBM: 3 %)
    assert sol.success is (sol.certificate["accuracy"].value <= DEFAULT_ACCURACY)
    assert sol.certificate["accuracy"].value >= err
    e = sol.certificate.info["energy"]
    assert e["damper_dissipation"] == 0.0
    assert e["element_dissipation"][0] == pytest.approx(e["input_work"], rel=1e-6)  # all input to friction


@pytest.mark.parametrize("method", ["shooting", "mshbm", "mshbm-intermediate"])
def test_impact5_certified_against_exact(method):
    sol = mshbm.solve(impact5(), OMEGA, method, harmonics=9, steps=4096)
    assert sol.success and sol.certificate.passed, sol.message
    exact = mshbm.exact_periodic(impact5(), OMEGA, guess=sol)
    assert exact.success
    assert np.max(np.abs(sol.amplitude - exact.amplitude)) <= 5e-3 * exact.amplitude.max()
    c = sol.certificate
    assert c["non_penetration"].passed and c["contact_compression"].passed
    assert abs(c["impact_dissipation"].value) <= c["impact_dissipation"].bound  # e_N = 1: no loss


def test_unforced_system_rests():
    system = chain([1.0, 1.0], 1.0, 0.1, forcing=[], elements=[Friction(0, 0.5, 1.0)])
    for method in METHODS:
        sol = mshbm.solve(system, 1.0, method, harmonics=3, steps=256)
        assert sol.success, (method, sol.message)
        assert np.max(np.abs(sol.amplitude)) == 0.0


# ------------------------------------------------------------------------- each check can fail
def _certify(system, sol, **opts):
    from mshbm.api import build_problem
    from mshbm.certificate import certify

    problem, _ = build_problem(system, sol.omega, sol.method, **opts)
    return certify(problem, sol, 1e-10)


@pytest.mark.parametrize("method", ["shooting", "mshbm"])
def test_check_friction_cone_detects_a_force_outside(method):
    sol = mshbm.solve(friction3(), OMEGA, method, harmonics=5, steps=1024)
    assert sol.certificate["friction_cone"].value == pytest.approx(1.0, rel=1e-9)  # slips: on the cone
    sol.lam = 1.5 * sol.lam
    c = _certify(friction3(), sol, harmonics=5, steps=1024)
    assert not c["friction_cone"].passed and "friction_cone" in c.failed


@pytest.mark.parametrize("method", ["shooting", "mshbm", "hbm"])
def test_check_non_penetration_detects_a_smaller_gap(method):
    sol = mshbm.solve(impact5(), OMEGA, method, harmonics=5, steps=1024)
    assert _solves_its_equations(sol), sol.message
    other = impact5().with_elements([Contact(0, 0.05, 1.0, 8000.0, 0.0)])
    c = _certify(other, sol, harmonics=5, steps=1024)
    assert not c["non_penetration"].passed
    assert c["non_penetration"].value == pytest.approx(sol.displacement([0]).max() - 0.05, rel=1e-12)


@pytest.mark.parametrize("method", ["shooting", "mshbm-intermediate"])
def test_check_periodicity_and_energy_detect_tampering(method):
    sol = mshbm.solve(impact5(), OMEGA, method, harmonics=5, steps=1024)
    assert _solves_its_equations(sol), sol.message
    sol.u_time = sol.u_time.copy()
    sol.u_time[-1] += 0.01
    c = _certify(impact5(), sol, harmonics=5, steps=1024)
    assert not c["periodicity"].passed
    sol2 = mshbm.solve(friction3(), OMEGA, method, harmonics=5, steps=1024)
    d_fric = sol2.certificate.info["energy"]["element_dissipation"][0]
    sol2.impulses = 0.5 * sol2.impulses  # half the friction work: the energy no longer balances
    c2 = _certify(friction3(), sol2, harmonics=5, steps=1024)
    assert not c2["energy_balance"].passed
    assert c2.info["energy"]["imbalance"] == pytest.approx(0.5 * d_fric, rel=1e-4)  # + O((n_h omega h)^2)


def test_check_residual_is_reevaluated():
    sol = mshbm.solve(friction3(), OMEGA, "mshbm", harmonics=5, steps=1024)
    sol.x = sol.x * (1 + 1e-6)
    c = _certify(friction3(), sol, harmonics=5, steps=1024)
    assert not c["residual"].passed and c["residual"].value > 1e-8


def test_summary_and_json_hold_the_certificate(tmp_path):
    sol = mshbm.solve(impact5(), OMEGA, "mshbm", harmonics=5, steps=1024)
    summ = sol.summary()
    names = [c["name"] for c in summ["certificate"]]
    assert names[:2] == ["residual", "periodicity"]
    assert {"non_penetration", "contact_compression", "energy_balance", "impact_dissipation",
            "truncation_solution", "truncation_force"} <= set(names)
    for c in summ["certificate"]:
        assert set(c) == {"name", "value", "bound", "passed", "gating", "note"}
    trunc = [c for c in summ["certificate"] if c["name"].startswith("truncation")]
    assert all(not c["gating"] for c in trunc)
    json.dumps(summ, allow_nan=False)
