"""Cross-method agreement on the paper's 3-DOF friction and 5-DOF impact systems (Tables 1-2)."""
import numpy as np
import pytest

import mshbm
from tests import discretised
from paper_systems import NORMAL_FORCE, OMEGA, friction_chain, impact_chain


@pytest.fixture(scope="module")
def shooting_refs(friction3, impact5):
    return {name: discretised.solve(s, OMEGA, "shooting", steps=8192)
            for name, s in (("friction3", friction3), ("impact5", impact5))}


@pytest.mark.parametrize("method", ["mshbm", "mshbm-intermediate"])
@pytest.mark.parametrize("name", ["friction3", "impact5"])
def test_mixed_approaches_shooting(shooting_refs, friction3, impact5, name, method):
    sys = {"friction3": friction3, "impact5": impact5}[name]
    ref = shooting_refs[name]
    assert ref.success
    n = sys.n
    errs = []
    for n_h in (1, 3, 9):
        s = discretised.solve(sys, OMEGA, method, harmonics=n_h, steps=8192, guess=ref)
        assert s.success, s.message
        errs.append(np.abs(s.amplitude[[0, n - 1]] / ref.amplitude[[0, n - 1]] - 1))
    errs = np.array(errs)
    assert np.all(errs[-1] < 0.01), errs  # within 1 % at the largest n_H
    assert errs[-1].max() < errs[0].max()  # and better than with one harmonic


def test_hbm_approaches_shooting_as_kappa_grows(shooting_refs):
    ref = shooting_refs["friction3"]
    errs = []
    for kappa in (10.0, 100.0, 1000.0):
        s = discretised.solve(friction_chain(3, kappa), OMEGA, "hbm", harmonics=40, guess=ref)
        assert s.success, s.message
        errs.append(np.max(np.abs(s.amplitude[[0, 2]] / ref.amplitude[[0, 2]] - 1)))
    assert errs[0] > errs[1] > errs[2], errs
    assert errs[2] < 0.01


def test_exact_and_fd_jacobians_give_the_same_solution(friction3):
    a = discretised.solve(friction3, OMEGA, "mshbm", harmonics=3, steps=2048, jacobian="exact")
    b = discretised.solve(friction3, OMEGA, "mshbm", harmonics=3, steps=2048, jacobian="fd")
    assert a.success and b.success
    assert np.allclose(a.x, b.x, rtol=0, atol=1e-8)
    c = discretised.solve(friction3, OMEGA, "shooting", steps=2048, jacobian="fd")
    d = discretised.solve(friction3, OMEGA, "shooting", steps=2048)
    assert np.allclose(c.x, d.x, rtol=0, atol=1e-8)


def test_mixed_solution_invariants(impact5, friction3):
    s = discretised.solve(impact5, OMEGA, "mshbm", harmonics=5)
    assert s.success
    assert (0.1 - s.q[:, 0]).min() >= -1e-12  # non-penetration at every time point
    assert s.info["connectivity_defect"] < 1e-8
    f = discretised.solve(friction3, OMEGA, "mshbm", harmonics=3)
    assert np.all(np.abs(f.lam[:, 0]) <= 0.8 * NORMAL_FORCE * (1 + 1e-12))  # friction cone
    assert 0.25 < f.info["stick_or_closed_fraction"][0] < 0.45  # pronounced stick-slip (0.30 measured)


def test_shooting_periodicity_and_floquet(impact5):
    s = discretised.solve(impact5, OMEGA, "shooting", steps=4096)
    assert s.success
    assert np.allclose(s.q[0], s.q[-1], atol=1e-10) and np.allclose(s.u[0], s.u[-1], atol=1e-10)
    mult = s.floquet_multipliers  # exact flow with saltation terms (mshbm.stability)
    assert mult.shape == (10,) and s.stability_method == "exact-flow-saltation"
    # damped chain: the product of multipliers is det(monodromy) < 1
    assert np.prod(np.abs(mult)) < 1.0
