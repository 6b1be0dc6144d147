"""A branch that turns back onto the part already traced (a false reversal, as on the jittery plateau of a
time-stepping method's response) is not followed backwards out of the range: the turn is bridged as a gap onwards
(:meth:`mshbm.solvers.arclength_fallbacks.Fallbacks.retraced`); a genuine fold is still traced and reported."""
import numpy as np

from mshbm.solvers.arclength import continuation

B, EPS = 0.02, 0.005  # zigzag of the curve near x = 1: lam = x - B w(x) sin(x / EPS), B / EPS = 4 (micro-folds)


def _win(x):
    return np.exp(-((x - 1.0) / 0.1) ** 8)


def _zigzag(x, lam):
    s = x[0]
    dwin = _win(s) * (-8 * ((s - 1.0) / 0.1) ** 7 / 0.1)
    R = np.array([lam - s + B * _win(s) * np.sin(s / EPS)])
    J = np.array([[-1 + B * (dwin * np.sin(s / EPS) + _win(s) * np.cos(s / EPS) / EPS)]])
    return R, J


def _run(residual, d_lam, x0, lam0, lam_end):
    one = lambda x, lam: np.ones(1)  # noqa: E731
    return continuation(residual, d_lam, np.array([x0]), lam0, lam_end, residual_scale=one, unknown_scale=one,
                        lam_scale=1.0, ds0=0.02, ds_max=0.2, max_points=300, predicted=0.02, ds_rough=0.1)


def test_turn_back_onto_the_traced_branch_is_bridged_onwards():
    # without the retrace test this trace turned back at lam = 1.103 and left the range at lam = -1.13 after
    # 115 points and 11 folds, following the curve it had traced, backwards
    res = _run(_zigzag, lambda x, lam: np.array([1.0]), 0.0, 0.0, 2.0)
    assert res.success, res.message
    lam = np.array([p.lam for p in res.points])
    assert lam[-1] == 2.0 and len(lam) <= 40
    assert res.counters["retraces"] == 1 and "gap" in res.message
    i = int(np.argmax(lam > 1.2))  # past the zigzag: forward only, every point on the curve
    assert np.all(np.diff(lam[i - 1:]) > 0)
    for p in res.points:
        assert abs(_zigzag(p.x, p.lam)[0][0]) <= 1e-10
    assert lam.min() >= 0.0


def test_a_genuine_fold_is_traced_and_not_taken_for_a_retrace():
    # x^2 + lam - 2 = 0 from (x, lam) = (1, 1) towards lam = 3: a fold at lam = 2, then the sheet x < 0 back
    fold = lambda x, lam: (np.array([x[0] ** 2 + lam - 2.0]), np.array([[2.0 * x[0]]]))  # noqa: E731
    res = _run(fold, lambda x, lam: np.array([1.0]), 1.0, 1.0, 3.0)
    assert not res.success and "left the parameter range" in res.message
    assert "retraces" not in res.counters
    assert len(res.folds) == 1 and abs(res.folds[0]["lam"] - 2.0) <= 2e-3
    assert res.points[-1].x[0] < -1.0  # on the other sheet, back in lam
