"""Named solve strategies (mshbm.strategies): nearby-frequency start, linear start, restart from
another method's solution."""
import numpy as np
import pytest

import mshbm
from mshbm import strategies
from paper_systems import OMEGA, system

KW = dict(harmonics=3, steps=1024, stability=False)


def test_nearby_start_reaches_the_linear_start_solution():
    sys3 = system("friction3")
    start = strategies.nearby_start(sys3, OMEGA, "mshbm", 0.98, **KW)
    assert start.ok and start.name == "nearby" and start.omega == 0.98 * OMEGA
    assert start.source.success and start.source.omega == pytest.approx(0.98 * OMEGA)
    near = strategies.solve_from(start, sys3, OMEGA, "mshbm", **KW)
    lin = strategies.solve_from(strategies.linear_start(), sys3, OMEGA, "mshbm", **KW)
    assert near.success and lin.success
    np.testing.assert_allclose(near.amplitude, lin.amplitude, rtol=1e-7)
    # the same solves as calling mshbm.solve by hand
    by_hand = mshbm.solve(sys3, OMEGA, "mshbm", guess=mshbm.solve(sys3, 0.98 * OMEGA, "mshbm", **KW), **KW)
    np.testing.assert_array_equal(near.x, by_hand.x)


def test_restart_from_another_method():
    sys3 = system("friction3")
    src = mshbm.solve(sys3, OMEGA, "mshbm", **KW)
    start = strategies.restart_start(src, "mshbm solution at omega")
    assert start.ok and start.guess is src
    hbm = strategies.solve_from(start, sys3, OMEGA, "hbm", harmonics=20, stability=False)
    own = mshbm.solve(sys3, OMEGA, "hbm", harmonics=20, stability=False)
    assert hbm.success and own.success
    # the same HBM solution as from its own start, and close to the set-valued one (regularised law)
    np.testing.assert_allclose(hbm.amplitude, own.amplitude, rtol=1e-6)
    assert np.max(np.abs(hbm.amplitude - src.amplitude)) <= 0.15 * np.max(src.amplitude)


def test_missing_starts_are_refused():
    assert not strategies.restart_start(None).ok
    with pytest.raises(ValueError, match="does not exist"):
        strategies.solve_from(strategies.restart_start(None, "x"), system("friction3"), OMEGA, "mshbm", **KW)
