"""Per-element outputs (mshbm.element_outputs) against closed forms: the work of Coulomb friction in
continuous sliding, the Masing loop of a Jenkins element, the energy lost at the impacts of the exact
(1,1) orbit of the impact oscillator; and their JSON (API summary and the CLI's solve output)."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mshbm
from mshbm import Friction, Jenkins, chain
from tests import closed_forms as cf

ROOT = Path(__file__).resolve().parents[2]


def _oscillator(element, F=1.0):
    return chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": F}], elements=[element])


def test_coulomb_sliding_dissipates_four_mu_n_times_amplitude():
    """x'' + 0.1 x' + x + mu N sgn(x') = cos(1.5 t), mu N = 0.3: the mass slides throughout (no stop), the
    friction force has constant magnitude against the velocity, so it dissipates mu N times the path,
    4 mu N a, per period (a = (max - min) / 2 of x)."""
    mu, Nn = 0.3, 1.0
    s = _oscillator(Friction(0, mu, Nn))
    sol = mshbm.solve(s, 1.5, "shooting", integrator="event")
    assert sol.success
    (e,) = sol.elements
    a = float(sol.amplitude[0])
    assert e.kind == "friction" and e.dof == 0 and e.relative_to is None
    assert e.relative_amplitude == pytest.approx(a, rel=1e-6)
    assert e.dissipated_energy == pytest.approx(4.0 * mu * Nn * a, rel=1e-6)
    assert e.stick_fraction == 0.0 and e.contact_fraction is None
    # the force stays on the cone with the sign opposite to the sliding velocity
    moving = np.abs(e.relative_velocity[:-1]) > 1e-6 * np.abs(e.relative_velocity).max()
    assert np.allclose(e.force[:-1][moving], -mu * Nn * np.sign(e.relative_velocity[:-1][moving]), rtol=1e-12)
    # the element's dissipation closes the energy balance with the damper's
    en = sol.certificate.info["energy"]
    assert e.dissipated_energy + en["damper_dissipation"] == pytest.approx(en["input_work"], rel=1e-6)


@pytest.mark.parametrize("method, options", [("hbm", {"harmonics": 15}), ("mshbm", {})])
def test_jenkins_loop_dissipates_the_masing_energy(method, options):
    """A Jenkins element (k_t = 5, slip force 0.2) whose relative displacement has one maximum and one minimum
    per period traces the Masing loop: it dissipates 4 mu N (a - mu N / k_t) per period whatever the shape of
    the motion between the turning points; it sticks after each reversal for a part of the period."""
    kt, b = 5.0, 0.2
    sol = mshbm.solve(_oscillator(Jenkins(0, 1.0, b, tangential_stiffness=kt)), 1.5, method, **options)
    assert sol.success
    (e,) = sol.elements
    a = e.relative_amplitude
    assert a > b / kt
    assert e.dissipated_energy == pytest.approx(4.0 * b * (a - b / kt), rel=1e-5)
    assert 0.05 < e.stick_fraction < 0.5
    assert np.max(np.abs(e.force)) == pytest.approx(b, rel=1e-12)


def test_stuck_jenkins_is_a_spring_that_dissipates_nothing():
    """A slip force far above the spring force: the element is the linear spring k_t throughout."""
    kt = 5.0
    sol = mshbm.solve(_oscillator(Jenkins(0, 1.0, 10.0, tangential_stiffness=kt)), 1.5, "hbm", harmonics=5)
    assert sol.success
    (e,) = sol.elements
    assert e.stick_fraction == 1.0
    assert abs(e.dissipated_energy) <= 1e-12 * kt * e.relative_amplitude ** 2
    assert 0.5 * np.ptp(e.force) == pytest.approx(kt * e.relative_amplitude, rel=1e-10)


@pytest.mark.parametrize("N", [512, 4096])
def test_impact_dissipation_of_the_exact_orbit(N):
    """The stable (1,1) orbit of x'' + 0.1 x' + x = cos(2 t), stop at 0.1, e_N = 0.8 (tests/closed_forms.py):
    one impact per period at approach velocity v loses v^2 (1 - e_N^2) / 2, exactly at any step count (the
    event flow's impacts are summed from its event list).  Moreau-Jean's discrete work is first order."""
    omega = 2.0
    _, v = cf.stable_orbit(omega)
    sol = mshbm.solve(cf.system(), omega, "shooting", integrator="event", steps=N)
    assert sol.success
    (e,) = sol.elements
    assert e.kind == "contact"
    assert e.dissipated_energy == pytest.approx(0.5 * v * v * (1.0 - cf.R ** 2), rel=1e-9)
    assert e.contact_fraction == pytest.approx(1.0 / N, abs=1e-15)
    # the gap g_N = gap + w^T q closes at the impact and is open otherwise
    assert cf.SIGMA + e.relative_displacement.min() >= -1e-9
    mj = mshbm.solve(cf.system(), omega, "mshbm", steps=N)
    assert mj.certificate.failed in ([], ["accuracy"])  # at 512 steps not within the default 1 %
    assert mj.elements[0].dissipated_energy == pytest.approx(0.5 * v * v * (1.0 - cf.R ** 2), rel=20.0 / N)


def test_relative_friction_reports_the_relative_motion():
    """A friction element between DOFs 0 and 1 of a 2-DOF chain: its relative displacement is q_0 - q_1."""
    s = chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.0}],
              elements=[Friction(0, 0.5, 0.4, relative_to=1)])
    sol = mshbm.solve(s, 1.2, "mshbm")
    assert sol.success
    (e,) = sol.elements
    q = sol.displacement([0, 1])
    assert e.relative_to == 1
    assert np.allclose(e.relative_displacement, q[:, 0] - q[:, 1], rtol=0, atol=1e-14 * np.abs(q).max())
    en = sol.certificate.info["energy"]
    assert e.dissipated_energy == pytest.approx(en["element_dissipation"][0], rel=1e-15)
    assert e.dissipated_energy > 0


def test_summary_and_cli_json_carry_the_element_outputs(tmp_path):
    sol = mshbm.solve(_oscillator(Friction(0, 0.3, 1.0)), 1.5, "mshbm")
    (d,) = sol.summary()["elements"]
    assert d["kind"] == "friction" and d["dissipated_energy"] == sol.elements[0].dissipated_energy
    assert "force" not in d  # scalars only in the summary (sweep points); series in the solve output
    out = tmp_path / "r.json"
    proc = subprocess.run([sys.executable, "-m", "mshbm", "solve", ROOT / "examples" / "impact5.yaml", "--quiet",
                           "--out", out], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    data = json.loads(out.read_text())
    assert len(data["elements"]) >= 1
    for el in data["elements"]:
        assert el["kind"] == "contact"
        assert len(el["force"]) == len(el["relative_displacement"]) == len(data["t"]) == data["steps"] + 1
        assert 0.0 < el["contact_fraction"] < 1.0
        assert el["dissipated_energy"] >= -1e-9
