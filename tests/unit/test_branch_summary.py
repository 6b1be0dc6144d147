"""workflow/scripts/branches/branch_summary.py: the paper's numbers of the frequency-response curves (Fig. 9)."""
from pathlib import Path

import pytest
from workflow_run import load_script

ROOT = Path(__file__).resolve().parents[2]


def _module():
    return load_script("branches/branch_summary.py")


def _branch(label, method, omega, amp, bif=()):
    return {"name": "imp", "label": label, "method": method, "period": 1, "system": "s", "success": True,
            "message": "ok", "wall_time_s": 1.0, "omega": list(omega), "amplitude": [[a, 0.0] for a in amp],
            "stable": [True] * len(omega), "bifurcations": list(bif), "options": {"steps": 64}}


def test_deviation_from_the_event_curve_and_pd_shift():
    bs = _module()
    ref = _branch("shooting-event", "shooting", [0.5, 0.6, 0.7], [1.0, 2.0, 3.0],
                  [{"type": "period-doubling", "omega": 0.61}])
    # HBM: 10 % high at 0.55 (reference interpolated: 1.5), 2 % low at 0.7; a point outside the range is skipped
    hbm = _branch("hbm", "hbm", [0.45, 0.55, 0.7], [9.0, 1.65, 2.94])
    sh = _branch("shooting", "shooting", [0.5, 0.7], [1.0, 3.0], [{"type": "period-doubling", "omega": 0.6161}])
    ev = _branch("shooting-event", "shooting", [0.5, 0.7], [1.0, 3.0], [{"type": "period-doubling", "omega": 0.61}])
    num = bs.summarize([ref, hbm])["numbers"]
    assert num["imp_hbm_dev_event"] == pytest.approx(0.10, rel=1e-12)
    assert num["imp_hbm_dev_event_omega"] == 0.55
    assert "imp_shooting_event_dev_event" not in num  # the reference is not compared with itself
    num = bs.summarize([sh, ev])["numbers"]
    assert num["imp_shooting_pd_shift"] == pytest.approx(0.6161 / 0.61 - 1, rel=1e-12)
    assert num["imp_shooting_dev_event"] == pytest.approx(0.0, abs=1e-15)
