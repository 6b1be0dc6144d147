"""``mshbm backbone`` on the example case files as a user runs it (CLI, --out, --plot), every method where a mode
makes sense: the answers agree across methods and with the linear mode where nothing acts, and the examples a
method does not take exit 2 naming the key."""
import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from mshbm import io
from mshbm.cli import main

EX = Path(__file__).resolve().parents[2] / "examples"


def run(tmp_path, case, method, a0, a1, *extra):
    out, png = tmp_path / f"{method}.json", tmp_path / f"{method}.png"
    code = main(["backbone", str(EX / case), "--method", method, "--amplitude-start", str(a0), "--amplitude-end",
                 str(a1), "--points", "4", "--quiet", "--out", str(out), "--plot", str(png), *extra])
    d = json.loads(out.read_text()) if out.exists() else None
    if d is not None and d["omega"]:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return code, d


def linear_mode(case):
    """``(omega_0, D_0)`` of the undamped mode 0 of the case's (K, M) and its modal damping phi^T C phi / (2 omega_0)."""
    s = io.load_case(str(EX / case)).system
    dense = lambda A: A.toarray() if hasattr(A, "toarray") else np.asarray(A, dtype=float)
    lam, Phi = sla.eigh(dense(s.K), dense(s.M), subset_by_index=[0, 0])
    w0 = float(np.sqrt(lam[0]))
    return w0, float(Phi[:, 0] @ dense(s.C) @ Phi[:, 0]) / (2 * w0)


@pytest.mark.parametrize("method", ["hbm", "dlft", "shooting", "mshbm"])
def test_impact5_below_the_stop_is_the_linear_mode(tmp_path, method):
    """impact5.yaml (gap 0.1 on the heavy mass) for modal amplitudes 0.05..0.3, where the mode does not reach the
    stop: omega and D of the linear mode to 1e-9 (dashpots 0.3 Ns/m parallel to the unit springs, C = 0.3 K: proportional,
    so EPMC's omega and D are the undamped mode's omega_0 and phi^T C phi / (2 omega_0) exactly)."""
    code, d = run(tmp_path, "impact5.yaml", method, 0.05, 0.3)
    assert code == 0 and d["success"] and all(d["certified"]), d and d["message"]
    w0, D0 = linear_mode("impact5.yaml")
    assert np.max(np.abs(np.array(d["omega"]) / w0 - 1)) < 1e-9
    assert np.max(np.abs(np.array(d["damping_ratio"]) / D0 - 1)) < 1e-9


def test_friction3_methods_agree(tmp_path):
    """friction3.yaml (Coulomb friction mu F_N = 4 on the first mass, no dashpots) in macro-slip, modal amplitude
    100..400: DLFT, shooting and MS-HBM (the exact flow) reach a_end; MS-HBM (n_h = 5) agrees with shooting (exact)
    to 1e-5 in omega and D (observed 1.2e-6, 9e-6), DLFT to 5e-4 and 3e-3 (observed 2e-4, 1e-3: its harmonic
    truncation); HBM's regularised friction (smoothing 800) needs more AFT samples than the default and says so."""
    res = {}
    for method in ("dlft", "shooting", "mshbm"):
        code, d = run(tmp_path, "friction3.yaml", method, 100, 400)
        assert code == 0 and d["success"], d and d["message"]
        res[method] = (d["omega"][-1], d["damping_ratio"][-1], d["modal_amplitude"][-1])
    w, D, a = res["shooting"]
    assert a == pytest.approx(400.0, rel=1e-12) and D > 0.005
    assert abs(res["mshbm"][0] / w - 1) < 1e-5 and abs(res["mshbm"][1] / D - 1) < 1e-4
    assert abs(res["dlft"][0] / w - 1) < 5e-4 and abs(res["dlft"][1] / D - 1) < 3e-3
    code, d = run(tmp_path, "friction3.yaml", "hbm", 100, 400)
    assert code == 1 and "--steps" in d["message"]


def test_linear_and_3d_contact_examples(tmp_path, capsys):
    """linear_matrices.yaml: HBM and shooting give the linear mode (omega to 1e-9); DLFT and MS-HBM, which need an
    element, exit 2 naming --method.  cone3d.yaml (a 3-D frictional contact loaded by a unilateral contact): only
    Moreau-Jean takes it (shooting --integrator moreau reaches a_end, certified by its half-steps estimate); HBM and
    DLFT exit 2 naming friction.normal_contact, the event flow friction.cone_partner."""
    w0, _ = linear_mode("linear_matrices.yaml")
    for method in ("hbm", "shooting"):
        code, d = run(tmp_path, "linear_matrices.yaml", method, 0.1, 1.0)
        assert code == 0 and np.max(np.abs(np.array(d["omega"]) / w0 - 1)) < 1e-9
    for method in ("dlft", "mshbm"):
        assert run(tmp_path, "linear_matrices.yaml", method, 0.1, 1.0)[0] == 2
        assert capsys.readouterr().err.startswith("error: --method:")
    code, d = run(tmp_path, "cone3d.yaml", "shooting", 0.5, 2.0, "--integrator", "moreau")
    assert code == 0 and d["success"] and d["integrator"] == "moreau" and max(d["omega_error"]) < 1e-3
    for method, key in (("hbm", "friction.normal_contact"), ("dlft", "friction.normal_contact"),
                        ("shooting", "friction.cone_partner")):
        assert run(tmp_path, "cone3d.yaml", method, 0.5, 2.0)[0] == 2
        assert capsys.readouterr().err.startswith(f"error: {key}:")
