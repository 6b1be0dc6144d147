"""An interrupt (Ctrl-C, SIGTERM, a CPU limit) while a sweep traces its branch again refined (option ``accuracy``,
:func:`mshbm.branch_accuracy.to_accuracy`) keeps the last complete level's curve: the refined trace had only begun
(the sweep stress suite's rows reported "CPU limit reached before the first point" after a level that had traced the
whole range)."""
import numpy as np
import pytest

import mshbm.branch_accuracy as ba
from mshbm.branch_result import Branch, BranchPoint
from mshbm.interrupt import SweepInterrupted


def _point(omega):
    return BranchPoint(omega=omega, load=1.0, amplitude=np.array([1.0]), x=np.zeros(1), q_hat=np.zeros((3, 1)),
                       iterations=1, residual=0.0, certificate={"passed": False, "failed": ["accuracy"]},
                       floquet_multipliers=np.zeros(0), stable=None, stability_method="none", contact=[])


def _branch(omegas, message):
    b = Branch(success=False, message=message, method="hbm", period=1, parameter="omega")
    b.points = [_point(w) for w in omegas]
    b.accuracy = {"uncertified_points": [0], "largest": {"estimate": 0.02}}
    b.wall_time = 1.0
    return b


@pytest.fixture
def refine_once(monkeypatch):
    monkeypatch.setattr(ba, "refined_options", lambda branch, options: (dict(options, harmonics=18), "truncation"))
    monkeypatch.setattr(ba, "_level", lambda branch, options, kind: {"wall_time_s": 1.0, "points": len(branch.points)})


def test_interrupt_while_refining_keeps_the_complete_level(refine_once):
    level0 = _branch(np.linspace(1.0, 2.0, 30), "reached lam_end = 2 in 30 points")

    def run(options):
        raise SweepInterrupted(_branch([1.0, 1.01], "interrupted after 2 points at lam = 1.01"), KeyboardInterrupt())

    with pytest.raises(SweepInterrupted) as info:
        ba.to_accuracy(run, level0, {"accuracy": 0.01})
    got = info.value.branch
    assert got is level0 and len(got.points) == 30 and got.omega[-1] == 2.0
    assert not got.success and got.counters["interrupted"]
    assert "interrupted while tracing it again refined (truncation) after 2 points" in got.message
    assert isinstance(info.value.cause, KeyboardInterrupt)


def test_interrupt_of_a_refined_level_that_got_as_far_keeps_it(refine_once):
    level0 = _branch(np.linspace(1.0, 1.5, 10), "stopped at lam = 1.5")
    refined = _branch(np.linspace(1.0, 1.6, 40), "interrupted after 40 points at lam = 1.6")

    def run(options):
        raise SweepInterrupted(refined, KeyboardInterrupt())

    with pytest.raises(SweepInterrupted) as info:
        ba.to_accuracy(run, level0, {"accuracy": 0.01})
    assert info.value.branch is refined


def test_interrupt_while_estimating_the_points_keeps_the_traced_branch(monkeypatch):
    """An interrupt while the traced points' accuracy is estimated (re-solves after the trace) keeps the points:
    the branch reached its end, its estimates are marked skipped."""
    import mshbm
    import mshbm.branch as br_mod

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt()

    monkeypatch.setattr(br_mod, "certify_points", interrupted)
    s = mshbm.chain([1.0, 1.0], 1.0, 0.05, forcing=[{"dof": 1, "amplitude": 1.0}],
                    elements=[mshbm.Contact(0, 1000.0, 0.8)])
    with pytest.raises(SweepInterrupted) as info:
        mshbm.sweep(s, 2.0, 1.5, "hbm", harmonics=3, stability=False)
    got = info.value.branch
    assert len(got.points) >= 3 and got.omega[-1] == pytest.approx(1.5, rel=1e-12)
    assert not got.success and got.accuracy["skipped"] == "interrupted" and got.accuracy["reached_end"]
    assert "interrupted while estimating the points' accuracy" in got.message
