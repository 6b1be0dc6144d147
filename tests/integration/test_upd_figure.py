"""Fig. 12's measure at test size (workflow/scripts/upd/upd_frf.py): two cantilever blades bending in two planes,
coupled by a light damper through two 3-D Jenkins contacts, under an engine-order force in antiphase.  The curves
by HBM, MS-HBM and DLFT are those of the session's quick workflow (fixture ``quick_run``: rule upd_frf with the quick
configuration's section ``upd``, which is ``CFG`` below, checked key by key).

* The classic trend of an underplatform damper: as the normal load grows, the resonance peak first drops (friction
  damping) and then rises again as the contacts stick, its frequency moving from the resonance without contact
  to the resonance with the contacts stuck (both linear, computed independently from the complex frequency
  response), by HBM, by MS-HBM and by DLFT (the contacts' sliders as DOFs, n_h = 20).
* HBM and MS-HBM agree at every peak within the sum of their own error estimates (amplitude), and in frequency;
  DLFT agrees with HBM within the sum of their estimates at the damped and the nearly stuck load; at the loose
  load (almost free slip) the two differ by 9.7e-5, more than their estimates' sum 6.1e-5 (measured).
* The out-of-plane tip motion at the damped peak is not negligible (two-dimensional slip)."""
import json

import pytest

from mshbm_workflow import script_module

upd = script_module("upd", "upd_frf")

CFG = dict(n_el=2, length=0.1, width=0.012, height=0.008, zeta=0.002, damper_mass=0.05, retainer=0.001,
           contact_stiffness=0.5, force=2.0, force_angle=75, interblade_phase=180, preloads=[0.05, 1.0, 20.0],
           omega_range=[0.9, 1.3], scan_points=11, peak_tol=2e-5, harmonics=5, steps=1024,
           methods=["hbm", "mshbm", "dlft"], dlft_harmonics=20)


@pytest.fixture(scope="module")
def curves(quick_run):
    """``upd.frf(CFG, m, p)`` for each preload ``p`` of CFG, as rule upd_frf wrote them (results/quick/upd/)."""
    cfg = json.loads((quick_run / "config.json").read_text())["upd"]  # the run's section `upd`
    assert {k: cfg.get(k) for k in CFG} == CFG, "config-quick.yaml's `upd` is no longer this test's case"
    out = {}
    for m in ("hbm", "mshbm", "dlft"):
        data = json.loads((quick_run / "upd" / f"{m}.json").read_text())
        assert data["method"] == m and data["refused"] is None
        out[m] = data["preloads"]
        assert [p["mu_N"] for p in out[m]] == CFG["preloads"]
    return out


@pytest.mark.slow
def test_peak_drops_then_rises_with_preload(curves):
    w_free, a_free = upd.linear_peak(CFG, "free")
    w_stuck, a_stuck = upd.linear_peak(CFG, "stuck")
    assert w_stuck > 1.1 * w_free  # the stuck contacts stiffen the antiphase mode markedly
    for m, pre in curves.items():
        peaks = [p["peak"] for p in pre]
        assert all(pk is not None and pk["success"] and pk["certified"] and not pk["at_edge"] for pk in peaks), m
        a = [pk["amplitude"] for pk in peaks]
        w = [pk["omega"] for pk in peaks]
        # drop, then rise: the middle load damps the peak by more than an order of magnitude against both ends
        assert a[1] < 0.1 * a[0] and a[1] < 0.1 * a[2], (m, a)
        # the ends approach the linear limits: loose contact -> the free resonance, tight -> the stuck resonance
        assert abs(w[0] / w_free - 1) < 1e-3 and abs(w[2] / w_stuck - 1) < 2e-3, (m, w, w_free, w_stuck)
        assert a[0] < a_free and a[2] < a_stuck  # friction only removes energy
        assert w_free < w[1] < w_stuck
        # two-dimensional slip at the damped peak: the out-of-plane tip amplitude is a sizable part of the in-plane
        assert peaks[1]["amplitude_z"] > 0.2 * peaks[1]["amplitude"]


@pytest.mark.slow
def test_hbm_and_mshbm_agree_within_their_estimates(curves):
    for a, b in zip(curves["hbm"], curves["mshbm"]):
        pa, pb = a["peak"], b["peak"]
        ea, eb = pa["accuracy_estimate"], pb["accuracy_estimate"]
        assert ea is not None and eb is not None and ea < 1e-2 and eb < 1e-2
        assert abs(pb["amplitude"] / pa["amplitude"] - 1) <= ea + eb, (a["mu_N"], pa["amplitude"], pb["amplitude"], ea, eb)
        assert abs(pb["omega"] / pa["omega"] - 1) <= ea + eb


@pytest.mark.slow
def test_dlft_agrees_with_hbm(curves):
    """DLFT at n_h = 20 (its Jenkins sliders' truncation error falls like 1 / n_h: at the damped peak 4.6 %, 1.8 %,
    0.58 % from HBM at n_h = 5, 10, 20, measured) against HBM at n_h = 5."""
    assert all(p["harmonics"] == 20 for p in curves["dlft"])
    for k, (a, b) in enumerate(zip(curves["hbm"], curves["dlft"])):
        pa, pb = a["peak"], b["peak"]
        ea, eb = pa["accuracy_estimate"], pb["accuracy_estimate"]
        assert pb["certified"] and eb is not None and eb < 1e-2
        d = abs(pb["amplitude"] / pa["amplitude"] - 1)
        assert d <= (ea + eb if k else 2e-4), (a["mu_N"], d, ea, eb)
        assert abs(pb["omega"] / pa["omega"] - 1) <= ea + eb
