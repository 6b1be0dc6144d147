"""mshbm.sweep's option ``grazings``: a grazing between two points of a frequency sweep is located by solves on
both sides (``"bisection"``, the default) or placed by interpolating the two points' test functions
(``"interpolation"``, no solves; the finite-element curves of the quick workflow, whose grazings no figure shows).

The case: the period-2 branch of the impact chain from pi/5, whose second impact per 2T grazes at
omega_g = 0.63935 (tests/integration/test_sweep.py locates it from solves at fixed omega on both sides)."""
import numpy as np
import pytest

import mshbm

OPTS = dict(integrator="event", steps=2048)


@pytest.mark.slow
def test_interpolated_grazing_lies_between_its_points_and_the_points_are_the_bisected_sweeps(impact5):
    b = mshbm.sweep(impact5, np.pi / 5, 0.645, "shooting", period=2, grazings="interpolation", **OPTS)
    assert b.success, b.message
    graz = [f for f in b.bifurcations if f["type"] == "grazing"]
    assert len(graz) == 1 and graz[0]["located"] == "interpolation", b.bifurcations
    i = graz[0]["index"]  # the bracket: points i and i + 1
    lo, hi = sorted((b.omega[i], b.omega[i + 1]))
    assert lo <= graz[0]["omega"] <= hi
    assert lo < 0.63935 < hi  # the bracket holds the grazing located from both sides
    n_imp = [p.solution.info["contact_margins"][0]["impacts"] for p in b.points]
    assert (n_imp[i], n_imp[i + 1]) == (2, 1)
    # the option places the grazing only: the branch's points are those of the default (bisection)
    d = mshbm.sweep(impact5, np.pi / 5, 0.645, "shooting", period=2, **OPTS)
    assert [f["located"] for f in d.bifurcations if f["type"] == "grazing"] == ["bisection"]
    np.testing.assert_array_equal(b.omega, d.omega)
    np.testing.assert_array_equal(b.amplitude, d.amplitude)


def test_grazings_option_rejects_unknown_values(impact5):
    with pytest.raises(mshbm.InputError, match="grazings"):
        mshbm.sweep(impact5, 0.6, 0.61, "hbm", harmonics=3, grazings="bisect")
