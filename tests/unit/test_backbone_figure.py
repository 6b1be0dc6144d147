"""Fig. 11's measure at test size (workflow/scripts/backbone/backbone_curve.py): the backbone of a cantilever with a
Jenkins joint passes through the peaks of its forced responses at five levels from micro- to macro-slip, within
0.5 % in frequency, by HBM (the Jenkins element), DLFT (the joint as a light shoe with ground Coulomb friction) and
MS-HBM (the Jenkins joint's DOF and slider by Moreau-Jean); and the conservative impact oscillator's backbone (Fig.
11c, workflow/scripts/backbone/impact_backbone.py) against its closed form.

The coarse beam (4 Hermite elements) keeps the joint's softening (about 7 % in omega between stuck and sliding),
so a backbone that missed the peaks by its own slope would fail: the peaks span several percent in omega."""
import numpy as np
import pytest

from mshbm_workflow import script_module

backbone_curve = script_module("backbone", "backbone_curve")

CFG = dict(n_el=4, zeta=0.002, k_t=3000.0, mu_N=1.0, x_joint=0.5, body_freq_ratio=20.0, harmonics=5, points=25,
           amplitude=[1e-4, 1e-1], stick_margin=1.05, peak_amplitudes=[1.5e-3, 3e-3, 6e-3, 1.2e-2, 3e-2],
           scan_points=60, scan_margin=0.01, methods=["hbm", "dlft"], deviation_goal=0.005, time_goal=20.0)


@pytest.mark.parametrize("method", ["hbm", "dlft", "mshbm"])
def test_backbone_passes_through_forced_peaks_of_jointed_beam(method):
    out = backbone_curve.run(CFG, method, sensitivity=False)
    b, model = out["backbone"], out["model"]
    assert b["success"], b["message"]
    assert all(b["certified"])
    # stuck joint (HBM's smallest amplitudes): the linear mode phi of (K + k_t e e^T, M), omega_0 and the modal damping
    # phi^T C phi / (2 omega_0); the Rayleigh C is not proportional to the stuck stiffness, which moves both at second
    # order in the damping (D^2 ~ 3.5e-6 times the non-proportional part)
    if method in ("hbm", "mshbm"):
        from mshbm.methods.epmc import linear_modes

        s, _ = backbone_curve.model(CFG, "hbm")
        w0, Phi = linear_modes(s, 1)
        D0 = float(Phi[:, 0] @ (s.C @ Phi[:, 0])) / (2 * w0[0])
        i = int(np.argmin(b["modal_amplitude"]))
        # MS-HBM: Moreau-Jean's trapezoidal phase error (omega h)^2 / 12 = 3.1e-6 at 1024 steps (the stuck joint's
        # DOF oscillates with the mode) moves omega; D by the same order
        tol_w, tol_D = (1e-8, 1e-7) if method == "hbm" else (1e-5, 1e-4)
        assert abs(b["omega"][i] / model["omega_stuck"] - 1) < tol_w
        assert abs(b["damping_ratio"][i] / D0 - 1) < tol_D
    peaks = [lv["peak"] for lv in out["levels"]]
    assert len(peaks) == 5 and all(p is not None and p["success"] and p["inside_backbone"] for p in peaks)
    a = np.array([p["modal_amplitude"] for p in peaks])
    w = np.array([p["omega"] for p in peaks])
    # from micro- to macro-slip: increasing amplitudes, decreasing frequencies over several percent
    assert np.all(np.diff(a) > 0) and np.all(np.diff(w) < 0)
    assert a[0] < 2 * model["a_stick"] and a[-1] > 20 * model["a_stick"]
    assert w[0] / w[-1] - 1 > 0.02
    dev = np.array([p["deviation"] for p in peaks])
    assert np.max(np.abs(dev)) < 5e-3, dev
    assert out["max_abs_deviation"] == pytest.approx(np.max(np.abs(dev)))


def test_impact_oscillator_backbone_against_closed_form():
    """Fig. 11c: the conservative impact oscillator (m = 2, k = 3, gap 0.5, e_N = 1) by shooting and MS-HBM with the
    event-driven flow from below the stop to A ~ 6 gap: T(A) of the closed form to 1e-6 (observed 2e-9 / 1e-9), D = 0
    to 1e-8, points below and above the stop, omega / omega_0 from 1 past 1.5."""
    impact = script_module("backbone", "impact_backbone")
    out = impact.run(dict(m=2.0, k=3.0, gap=0.5, amplitude=[0.3, 3.0], points=12, harmonics=5))
    w0 = out["model"]["omega0"]
    for m in ("shooting", "mshbm"):
        r = out["methods"][m]
        assert r["success"], r["message"]
        assert r["max_period_error"] < 1e-6 and r["max_abs_D"] < 1e-8 and all(r["certified"])
        hit = np.array(r["impacts"]) > 0
        assert hit.sum() >= 4 and (~hit).sum() >= 2
        assert abs(min(r["omega"]) / w0 - 1) < 1e-10 and max(r["omega"]) / w0 > 1.5

