"""The accuracy suite (workflow/scripts/stress/accuracy.py): its exact references against independent closed forms,
and its quick profile -- no certified success outside its accuracy, the exact event-driven variants within it on
every case, every failure diagnosed, and the unit-scaled copy read like the original.

The quick profile is the quick workflow's run of it (rule accuracy_quick, < 60 s CPU of solves after the warm-up):
the event-driven shooting and MS-HBM, HBM and DLFT on two closed-form impact orbits (restitution 0 with a sticking
phase, and 0.5), Den Hartog's damped Coulomb oscillator, and the first system with forcing and gap scaled by 1e-11;
default settings and ``accuracy`` 1e-2, 1e-3.
"""
import json
import math
from pathlib import Path

import numpy as np
import pytest

import closed_forms as cf
import mshbm
from mshbm_workflow import accuracy_refs as ar
from mshbm_workflow.accuracy_cases import build_system, load_config, methods_for, plan_systems, reference

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "workflow" / "accuracy.yaml"


# ----------------------------------------------------------------------------- the references
@pytest.mark.parametrize("omega", [1.5, 2.0, 2.2, 2.44])
def test_impact_orbit_equals_the_tests_closed_form(omega):
    """Two derivations of the (1,1) orbit (tests/closed_forms.py and accuracy_refs) give the same orbit."""
    t0, v = cf.stable_orbit(omega)
    r = ar.impact_11(omega, cf.ZETA, cf.SIGMA, cf.R)
    assert r["stable"] and r["t0"] == pytest.approx(t0, abs=1e-12) and r["v"] == pytest.approx(v, rel=1e-12)
    assert r["amplitude"] == pytest.approx(cf.amplitude(omega, t0, v), rel=1e-12)
    rho = max(abs(cf.multipliers(omega, t0, v)))
    assert r["spectral_radius"] == pytest.approx(rho, rel=1e-5)  # central differences against the exact Jacobian


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_impact_orbits_with_restitution_against_the_event_flow(e):
    """x'' + 0.2 x' + x = cos 1.2 t, stop at 0.2: the closed forms 0.779 (plastic: a sticking phase), 0.645, 0.512
    equal the exact event-driven flow to 1e-9."""
    r = ar.impact_11(1.2, 0.1, 0.2, e)
    assert r["amplitude"] == pytest.approx({0.0: 0.7787, 0.5: 0.6451, 1.0: 0.5124}[e], abs=1e-4)
    assert r.get("sticking", False) is (e == 0.0)
    case = {"id": "t", "family": "impact", "scale": None, "params": {"zeta": 0.1, "omega": 1.2, "sigma": 0.2, "e": e}}
    ev = mshbm.solve(build_system(case), 1.2, "shooting", integrator="event", stability=False, tol=1e-12)
    assert ev.success and ev.amplitude[0] == pytest.approx(r["amplitude"], rel=1e-9)


@pytest.mark.parametrize("omega,R", [(0.6, 0.3), (2.0, 0.2), (0.5, 0.1)])
def test_coulomb_orbit_is_den_hartogs_formula_undamped(omega, R):
    r = ar.coulomb(omega, 0.0, R)
    assert r is not None and r["amplitude"] == pytest.approx(ar.den_hartog(omega, R), rel=1e-10)


def test_rotating_radius_balances_the_forces():
    r = ar.rotating_radius(0.8, 1.0, 0.05, 1.0, 0.3, 1.0, 1.0)
    assert ((1.0 - 0.64) * r) ** 2 + (0.05 * 0.8 * r + 0.3) ** 2 == pytest.approx(1.0, rel=1e-14)
    assert ar.rotating_radius(0.8, 1.0, 0.05, 1.0, 0.5, 2.0, 1.0) is None  # mu N >= F: no sliding orbit


def test_scaled_copies_scale_the_reference_exactly():
    cfg = load_config(CONFIG)
    cases = plan_systems(cfg["profiles"]["full"])
    base = {c["id"]: c for c in cases if c["scale"] is None}
    scaled = [c for c in cases if c["scale"] is not None and c["family"] != "chain"]
    assert scaled and {c["scale"]["kind"] for c in scaled} == {"force", "mm"}
    for c in scaled:
        b = base[c["id"].split(" [")[0]]
        ref, _ = reference(c, cfg)
        ref0, _ = reference(b, cfg)
        f = c["scale"]["factor"] if c["scale"]["kind"] == "force" else 1e3
        assert np.allclose(ref, f * ref0, rtol=1e-12, atol=0)
    # at least 200 (system, method, setting) cases in the full profile, every family present
    prof = cfg["profiles"]["full"]
    variants = {n: cfg["methods"][n] for n in prof["methods"]}
    per_system = 2 if prof.get("rotate_accuracies") else 1 + len(cfg["accuracies"])
    assert sum(len(methods_for(c, variants)) for c in cases) * per_system >= 200
    fams = {c["family"] for c in cases}
    assert fams == {"impact", "coulomb", "rotating", "chain"}
    assert {c["params"]["e"] for c in cases if c["family"] == "impact"} >= {0.0, 0.5, 0.9}


# ----------------------------------------------------------------------------- the quick profile
@pytest.fixture(scope="module")
def quick(quick_run):
    """The quick profile as the quick workflow's job ran it (rule accuracy_quick: this script with
    ``--config workflow/accuracy.yaml --quick``; fixture ``quick_run``, tests/conftest.py), not a second run."""
    out = quick_run / "accuracy-quick"

    def reject(name):
        raise AssertionError(f"{name} in the JSON summary")

    return json.loads((out / "summary.json").read_text(), parse_constant=reject), (out / "summary.md").read_text()


def test_quick_profile_has_no_success_outside_its_accuracy(quick):
    s, md = quick
    assert s["totals"]["cases"] == len(s["rows"]) >= 40
    out = [r for r in s["rows"] if r["outcome"] in ("OUT", "crash")]
    assert not out, json.dumps(out, indent=1)[:3000]
    assert s["numbers"]["out"] == 0 and s["numbers"]["crash"] == 0 and not s["partial"]
    for r in s["rows"]:
        if r["outcome"] == "within":
            assert r["error"] <= r["accuracy"] and r["estimate"] <= r["accuracy"]
        if r["outcome"] == "failed":  # a diagnosis naming the estimate or the check
            assert r["diagnosis"] and r["message"]
            assert r["diagnosis"].startswith(("accuracy:", "certificate:", "time budget", "no solution"))
    assert "| **total** |" in md and "OUT" in md


def test_event_driven_variants_are_exact_on_every_quick_case(quick):
    s, _ = quick
    ev = [r for r in s["rows"] if r["method"] in ("shooting-event", "mshbm-event")]
    assert ev and all(r["outcome"] == "within" and r["error"] < 1e-8 for r in ev)


def test_requested_accuracy_is_met_where_harmonic_methods_succeed(quick):
    """HBM and DLFT on Den Hartog's oscillator: the default 1 % is not met at n_H = 5 (truncation named), 1e-2 and
    1e-3 are, by refining n_H; the errors are below the requests."""
    s, _ = quick
    rows = {(r["method"], r["setting"]): r for r in s["rows"] if r["system"].startswith("coulomb")}
    for m in ("hbm", "dlft"):
        for a in (0.01, 0.001):
            r = rows[(m, a)]
            assert r["outcome"] == "within" and r["error"] <= a and r["harmonics"] > 5, r


def test_quick_profile_cpu_budget(quick):
    s, _ = quick
    assert s["cpu_s"] - s["warm_up_cpu_s"] < 60.0, s["cpu_s"]
