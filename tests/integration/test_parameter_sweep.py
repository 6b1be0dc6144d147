"""Branches in parameters other than omega (mshbm.parameter, ``mshbm sweep --parameter KEY``).

Closed forms: a linear system's response is exactly linear in the forcing amplitude; Den Hartog's Coulomb
oscillator (continuous slip, no stops; ``_den_hartog`` of test_sweep) in its friction load R, traced with the
exact event-driven flow; and every point against a pointwise certified solve at its parameter value.
"""
import json

import numpy as np
import pytest
import yaml

import mshbm
from mshbm import Friction, InputError, chain
from mshbm.cli import main
from mshbm.io import load_case
from mshbm.parameter import sweep_case

from test_sweep import _den_hartog  # this folder is on sys.path (pytest's rootdir-less test folders)

ZETA, F, W = 0.05, 1.0, 2.0


def den_hartog_system(R):
    return chain([1.0], 1.0, 2 * ZETA, forcing=[{"dof": 0, "amplitude": F}], elements=[Friction(0, 1.0, R)])


def test_preload_branch_against_den_hartog_and_pointwise_solves():
    """R from 0.05 to 0.3 at omega = 2 (continuous slip): every point within 1e-9 of the closed form and of
    mshbm.solve at its R (event-driven shooting is exact up to Newton's tolerance)."""
    b = mshbm.continue_parameter(den_hartog_system, 0.05, 0.3, W, "shooting", name="R", integrator="event")
    assert b.success and b.parameter == "R" and 5 <= len(b) <= 60
    assert b.values[0] == 0.05 and b.values[-1] == 0.3 and np.all(np.diff(b.values) > 0)
    assert np.all(b.omega == W)
    exact = np.array([_den_hartog(W, ZETA, F, R) for R in b.values])
    np.testing.assert_allclose(b.amplitude[:, 0], exact, rtol=1e-9)
    assert np.all(np.diff(b.amplitude[:, 0]) < 0)  # more friction, less motion
    for i in (1, len(b) // 2, len(b) - 2):
        ref = mshbm.solve(den_hartog_system(b.values[i]), W, "shooting", integrator="event")
        assert ref.success and b.amplitude[i, 0] == pytest.approx(ref.amplitude[0], rel=1e-9)
    assert all(p.certificate["passed"] for p in b.points)
    d = b.to_dict()
    assert d["parameter"] == "R" and d["parameter_values"] == list(b.values)
    assert [p["value"] for p in d["points"]] == list(b.values)


def test_preload_from_zero_through_sticking(tmp_path):
    """From the linear oscillator (preload 0, outside which the preload is inadmissible: the branch starts at
    the boundary) until the mass sticks: the start equals the linear closed form |H|, the end is at rest."""
    path = tmp_path / "dh.yaml"
    path.write_text(yaml.safe_dump({"masses": [1], "stiffness": 1, "damping": 0.1, "omega": 1.2,
                                    "forcing": [{"dof": 0, "amplitude": 1}],
                                    "friction": {"dof": 0, "mu": 1, "normal_force": 0.3}}))
    b = sweep_case(load_case(path), "friction.0.normal_force", 0.0, 1.5, method="shooting", integrator="event")
    assert b.success and b.values[0] == 0.0 and b.values[-1] == 1.5
    assert b.amplitude[0, 0] == pytest.approx(1.0 / abs(1 - 1.2 ** 2 + 0.12j), rel=1e-10)
    # F = 1 < mu N = 1.5 beyond the static limit the mass sticks: amplitude 0 (to the solver's tolerance)
    assert b.amplitude[-1, 0] < 1e-8
    i = len(b) // 2
    ref = load_case(path, sets={"friction.0.normal_force": float(b.values[i])}).solve("shooting", integrator="event")
    assert b.amplitude[i, 0] == pytest.approx(ref.amplitude[0], rel=1e-8, abs=1e-12)


LINEAR = {"name": "lin2", "M": [[2.0, 0.0], [0.0, 1.0]], "C": [[0.15, -0.05], [-0.05, 0.05]],
          "K": [[3.0, -1.0], [-1.0, 1.0]], "omega": 0.8, "forcing": [{"dof": 1, "amplitude": 1.0}],
          "solver": {"method": "hbm", "harmonics": 1}}


def test_cli_forcing_amplitude_sweep_is_exactly_linear(tmp_path, capsys):
    """``mshbm sweep --parameter forcing.0.amplitude`` on a linear 2-DOF system: the harmonic coefficients are
    ``a H(omega) e_1`` (closed form) and the amplitude over ``a`` is constant; the JSON labels the parameter."""
    case = tmp_path / "lin.yaml"
    case.write_text(yaml.safe_dump(LINEAR))
    out, png = tmp_path / "b.json", tmp_path / "b.png"
    code = main([str(a) for a in ["sweep", case, "--parameter", "forcing.0.amplitude", "--start", 0.5, "--end", 3,
                                  "--omega", 0.9, "--out", out, "--plot", png]])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    assert "parameter   forcing.0.amplitude at omega = 0.9" in stdout
    data = json.loads(out.read_text())
    assert data["parameter"] == "forcing.0.amplitude" and data["success"] is True
    a = np.array(data["parameter_values"])
    assert a[0] == 0.5 and a[-1] == 3.0 and np.all(np.asarray(data["omega"]) == 0.9)
    M, C, K = (np.array(LINEAR[k]) for k in "MCK")
    H = np.linalg.solve(K - 0.81 * M + 0.9j * C, [0.0, 1.0])  # q = Re(a H e^{i w t})
    amp = np.array(data["amplitude"])
    np.testing.assert_allclose(amp / a[:, None], np.abs(H)[None, :].repeat(len(a), 0), rtol=1e-9)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the same from the API: the coefficients a (Re H, -Im H) of cos and sin, and a pointwise solve
    br = sweep_case(load_case(case), "forcing.0.amplitude", 0.5, 3.0, omega=0.9)
    assert br.success and np.all(br.values == a)
    for p in br.points:
        np.testing.assert_allclose(p.q_hat[1:3], p.value * np.array([H.real, -H.imag]), rtol=1e-10, atol=1e-13)
    ref = load_case(case, sets=[f"forcing.0.amplitude={float(br.values[2])!r}", "omega=0.9"]).solve()
    np.testing.assert_allclose(br.amplitude[2], ref.amplitude, rtol=1e-10)


@pytest.mark.parametrize("argv, key", [
    (["--parameter", "friction.0.normal_force", "--start", 0.1], "--end"),
    (["--parameter", "friction.0.normal_force", "--start", 0.1, "--end", 1, "--omega-start", 1], "--omega-start"),
    (["--parameter", "friction.0.dof", "--start", 0.1, "--end", 0.5], "friction.0.dof"),
    (["--parameter", "friction.0.normal_frce", "--start", 0.1, "--end", 0.5], "friction.0.normal_frce"),
    (["--parameter", "solver.harmonics", "--start", 1, "--end", 5], "solver.harmonics"),
    (["--parameter", "friction.0.normal_force", "--start", -1, "--end", 0.5], "friction.normal_force"),
    (["--omega-start", 1, "--omega-end", 2, "--omega", 1.5], "--omega"),
    (["--omega-start", 1], "--omega-end"),
])
def test_cli_parameter_sweep_bad_input_exit_2(argv, key, tmp_path, capsys):
    case = tmp_path / "dh.yaml"
    case.write_text(yaml.safe_dump({"masses": [1], "stiffness": 1, "damping": 0.1, "omega": 2,
                                    "forcing": [{"dof": 0, "amplitude": 1}],
                                    "friction": {"dof": 0, "mu": 1, "normal_force": 0.3}}))
    code = main([str(a) for a in ["sweep", case] + argv])
    out, err = capsys.readouterr()
    assert code == 2 and "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {key}:"), lines


def test_api_bad_family():
    with pytest.raises(InputError) as info:
        mshbm.continue_parameter(den_hartog_system, 0.1, 0.1, W)
    assert info.value.key == "lam_end"
    with pytest.raises(InputError) as info:
        mshbm.continue_parameter(lambda R: "no system", 0.1, 0.2, W)
    assert info.value.key == "family"
    with pytest.raises(InputError) as info:  # the end of the range is inadmissible: the element's own error
        mshbm.continue_parameter(den_hartog_system, 0.1, -0.2, W)
    assert "normal_force" in info.value.key


def test_cli_preload_sweep_against_cli_solves(tmp_path, capsys):
    """``mshbm sweep --parameter friction.0.normal_force`` against ``mshbm solve --set friction.0.normal_force=R``
    at a point of the branch, and both against Den Hartog's closed form (event-driven shooting)."""
    case = tmp_path / "dh.yaml"
    case.write_text(yaml.safe_dump({"masses": [1], "stiffness": 1, "damping": 2 * ZETA, "omega": W,
                                    "forcing": [{"dof": 0, "amplitude": F}],
                                    "friction": {"dof": 0, "mu": 1, "normal_force": 0.2},
                                    "solver": {"method": "shooting", "integrator": "event"}}))
    out, one = tmp_path / "b.json", tmp_path / "s.json"
    code = main([str(a) for a in ["sweep", case, "--parameter", "friction.0.normal_force", "--start", 0.05,
                                  "--end", 0.3, "--out", out, "--quiet"]])
    assert code == 0, capsys.readouterr().err
    data = json.loads(out.read_text())
    R = np.array(data["parameter_values"])
    amp = np.array(data["amplitude"])[:, 0]
    np.testing.assert_allclose(amp, [_den_hartog(W, ZETA, F, r) for r in R], rtol=1e-9)
    i = len(R) // 2
    code = main([str(a) for a in ["solve", case, "--set", f"friction.0.normal_force={float(R[i])!r}", "--out", one,
                                  "--quiet"]])
    assert code == 0, capsys.readouterr().err
    assert json.loads(one.read_text())["amplitude"][0] == pytest.approx(amp[i], rel=1e-9)
    # --parameter omega with --start/--end is the frequency sweep
    code = main([str(a) for a in ["sweep", case, "--parameter", "omega", "--start", 1.8, "--end", 2.2, "--out", out,
                                  "--quiet"]])
    data = json.loads(out.read_text())
    assert code == 0 and data["parameter"] == "omega" and data["omega"][0] == 1.8 and data["omega"][-1] == 2.2


def test_forcing_amplitude_branch_of_the_impact_oscillator_against_closed_forms():
    """x'' + 0.1 x' + x = a cos(1.5 t), stop at 1 (e = 0.8), a from a_g / 2 to 1.5 a_g (a_g = 1 / |G|, the
    grazing): with x = a y this is the (1,1) orbit family of tests/closed_forms.py with the stop at 1 / a.
    Every point (non-impacting: a |G|; impacting: a (1,1) orbit) within 1e-9 of the closed forms (event-driven
    shooting), and the fold of the impacting branch in a where the two (1,1) orbits merge (|gamma| = rho,
    gamma linear in the stop) within 1e-8."""
    import closed_forms as cf  # tests/ is on the path (its conftest.py)

    w, zeta, r = 1.5, 0.05, 0.8

    def family(a):
        return chain([1.0], 1.0, 2 * zeta, forcing=[{"dof": 0, "amplitude": a}],
                     elements=[mshbm.Contact(0, 1.0, r)])

    G = abs(cf._G(w, zeta))
    (p11, p12), (p21, p22) = cf.phi_h(2 * np.pi / w, zeta)
    k = 1.0 + p22 * r
    alpha = -p21 * G + k * (p11 - 1.0) * G / (r * p12)
    beta = -k * G * w / r - (1.0 - p22) * G * w
    a_fold = abs(p21 - k * (p11 - 1.0) / (r * p12)) / np.hypot(alpha, beta)  # 1 / sigma at |gamma| = rho
    b = mshbm.continue_parameter(family, 0.5 / G, 1.5 / G, w, "shooting", name="a", integrator="event")
    assert b.success and b.values[-1] == pytest.approx(1.5 / G, rel=1e-12)
    kinds = []
    for p in b.points:
        a = p.value
        cands = [(a * G, "linear")] + [(a * cf.amplitude(w, t0, v, zeta, 1 / a, r), "(1,1)")
                                       for t0, v in cf.orbit_11(w, zeta, 1 / a, r) if v > 0]
        exact, kind = min(cands, key=lambda c: abs(c[0] - p.amplitude[0]))
        assert p.amplitude[0] == pytest.approx(exact, rel=1e-9), (a, kind)
        kinds.append(kind)
    assert kinds.count("linear") >= 5 and kinds.count("(1,1)") >= 10
    located = [f for f in b.bifurcations if f["type"] == "fold" and f["located"] is True]
    assert any(abs(f["value"] / a_fold - 1) < 1e-8 for f in located), (a_fold, b.bifurcations)
