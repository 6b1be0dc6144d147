"""``mshbm backbone``: a case file's nonlinear mode through the command line (exit codes, JSON, plot)."""
import json

import numpy as np

from mshbm.cli import main

CASE = """name: jenkins3
masses: [1, 1, 1]
stiffness: 1
damping: 0.002
omega: 1.0
forcing:
  - {dof: 2, amplitude: 0.1}
friction: {dof: 0, mu: 0.5, normal_force: 0.2, tangential_stiffness: 2.0}
"""


def test_backbone_cli_writes_json_and_plot(tmp_path, capsys):
    case = tmp_path / "j3.yaml"
    case.write_text(CASE)
    out, png = tmp_path / "b.json", tmp_path / "b.png"
    code = main(["backbone", str(case), "--method", "hbm", "--mode", "0", "--amplitude-start", "0.01",
                 "--amplitude-end", "3", "--harmonics", "3", "--points", "12", "--dofs", "0", "2",
                 "--out", str(out), "--plot", str(png)])
    assert code == 0
    d = json.loads(out.read_text())
    assert d["success"] and d["mode"] == 0 and d["dofs"] == [0, 2]
    a, w, D = map(np.array, (d["modal_amplitude"], d["omega"], d["damping_ratio"]))
    assert np.isclose(a[0], 0.01, rtol=1e-12) and np.isclose(a[-1], 3.0, rtol=1e-12)
    assert np.all(np.diff(a) > 0)
    # stuck at small amplitude (the undamped mode with k_t, up to the second order in the dashpots' 0.05 %
    # damping, which is not proportional to K + k_t), softening and friction damping once it slips
    assert abs(w[0] / d["omega_linear"] - 1) < 1e-6 and w[-1] < 0.9 * w[0] and D.max() > 10 * D[0]
    assert len(d["amplitude"][0]) == 2 and len(d["harmonic_content"][0]) == 3
    assert all(c for c in d["certified"]) and max(d["residual"]) <= 1e-7 and d["stable"] == [None] * len(a)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    err = capsys.readouterr().err
    assert "[backbone mode 0] points" in err


def test_backbone_cli_bad_input(tmp_path, capsys):
    case = tmp_path / "j3.yaml"
    case.write_text(CASE)
    for args, key in ((["--amplitude-start", "-1", "--amplitude-end", "1"], "--amplitude-start"),
                      (["--amplitude-start", "1", "--amplitude-end", "2", "--mode", "3"], "--mode"),
                      (["--amplitude-start", "1", "--amplitude-end", "2", "--harmonics", "0"], "--harmonics"),
                      (["--amplitude-start", "1", "--amplitude-end", "2", "--dofs", "9"], "--dofs")):
        assert main(["backbone", str(case), "--quiet", *args]) == 2
        assert capsys.readouterr().err.startswith(f"error: {key}:")


def test_backbone_cli_stopped_early_exits_1_and_writes_points(tmp_path, capsys):
    case = tmp_path / "j3.yaml"
    case.write_text(CASE)
    out = tmp_path / "b.json"
    code = main(["backbone", str(case), "--amplitude-start", "0.01", "--amplitude-end", "3", "--harmonics", "2",
                 "--points", "10", "--max-points", "3", "--quiet", "--out", str(out)])
    assert code == 1
    d = json.loads(out.read_text())
    assert not d["success"] and len(d["omega"]) == 3 and "max_points" in d["message"]
    assert capsys.readouterr().err.startswith("error: backbone stopped early:")


IMPACT = """name: stop1
masses: [2]
stiffness: 3
damping: 0
omega: 1.0
forcing:
  - {dof: 0, amplitude: 0}
contact: {dof: 0, gap: 0.5, restitution: 1}
"""


def test_backbone_cli_shooting_conservative_impact(tmp_path, capsys):
    """--method shooting on an undamped oscillator with an elastic stop: exit 0, D = 0, the shooting
    certificate in the JSON, the period against the closed form 2 (pi - arccos(g / A)) / omega_0."""
    case = tmp_path / "stop1.yaml"
    case.write_text(IMPACT)
    out = tmp_path / "b.json"
    code = main(["backbone", str(case), "--method", "shooting", "--amplitude-start", "0.3",
                 "--amplitude-end", "2", "--points", "4", "--out", str(out)])
    assert code == 0
    d = json.loads(out.read_text())
    assert d["success"] and d["method"] == "shooting" and d["conservative"] and all(d["certified"])
    assert all(d["stable"]) and max(abs(np.array(d["damping_ratio"]))) < 1e-7 and max(d["energy_drift"]) < 1e-7
    A = np.sqrt(2 * np.array(d["energy"]) / 3.0)
    T = 2 * (np.pi - np.arccos(np.minimum(0.5 / A, 1.0))) / np.sqrt(1.5)
    hit = np.array(d["impacts"]) == 1
    assert hit.sum() >= 3 and np.all(A[~hit] < 0.5) and np.all(A[hit] > 0.5)
    assert np.max(np.abs(2 * np.pi / np.array(d["omega"]) / T - 1)) < 1e-6
    assert "[backbone mode 0] points" in capsys.readouterr().err
