"""Shortcuts of the small HBM solve's set-up and certificate, each against what it replaces.

* :func:`mshbm.scaling.stiffness_scale` remembered per system and omega: the same number as the formula,
  recomputed when a matrix is replaced, bounded in size;
* :func:`mshbm.validate.check_forcing` without an array pass when every harmonic is representable: the same
  errors as before (forcing above ``harmonics`` for HBM, aliasing for time-stepped DOFs);
* :func:`mshbm.methods.common.guess_parts` with ``states=False`` (HBM, DLFT): ``q_hat`` as with states, no
  derived ``q0``/``u0``; a guess's own bad ``q0``/``u0`` still raise;
* the certificate's cached element tables equal the per-call construction and follow ``with_elements``.
"""
import numpy as np
import pytest

import mshbm
from tests import discretised
from mshbm import certificate as cm
from mshbm import scaling, validate
from mshbm.elements import Contact, Friction
from mshbm.errors import InputError
from mshbm.methods.common import guess_parts
from mshbm.system import chain


def _system(harmonic=1):
    return chain([1.0, 2.0, 1.5], [3.0, 1.0, 2.0], [0.1, 0.2, 0.3],
                 forcing=[{"dof": 2, "amplitude": 1.0, "harmonic": harmonic}],
                 elements=[Contact(dof=0, gap=0.1, penalty_stiffness=100.0)])


def _k0(system, omega):
    Kd, Md, Cd = (np.diag(np.asarray(getattr(system, a))) for a in "KMC")
    return float((np.abs(Kd) + omega ** 2 * Md + omega * np.abs(Cd)).max())


def test_stiffness_scale_memo_is_the_formula():
    s = _system()
    for omega in (0.3, 1.7, 0.3, 2.0, 1.7):
        assert scaling.stiffness_scale(s, omega) == _k0(s, omega)  # bit-identical, first call and memo hit
    # |K_ii| + omega^2 M_ii + omega |C_ii| at omega = 2 (K_ii = 4, 3, 2; C_ii = 0.3, 0.5, 0.3): DOF 1,
    # 3 + 4 * 2 + 2 * 0.5 = 12, is the largest
    assert scaling.stiffness_scale(s, 2.0) == pytest.approx(12.0, rel=1e-15)
    K2 = 10.0 * np.asarray(s.K)
    K2.flags.writeable = False
    s.K = K2  # a replaced matrix: no stale value
    assert scaling.stiffness_scale(s, 2.0) == _k0(s, 2.0) == pytest.approx(44.6, rel=1e-15)  # DOF 0: 40 + 4 + 0.6
    for i in range(3 * scaling._STIFFNESS_MEMO):
        scaling.stiffness_scale(s, 1.0 + i)
    memo = s.derived("stiffness_scale", ("K", "M", "C"), dict)
    assert 0 < len(memo) <= scaling._STIFFNESS_MEMO


def test_check_forcing_shortcut_keeps_the_errors():
    s = _system(harmonic=3)
    validate.check_forcing(s, "hbm", 3, 512, np.zeros(0, dtype=np.int64))  # representable: no error
    with pytest.raises(InputError) as e:
        validate.check_forcing(s, "hbm", 2, 512, np.zeros(0, dtype=np.int64))
    assert e.value.key == "harmonics" and "harmonic 3 (on DOF 2)" in str(e.value)
    with pytest.raises(InputError) as e:  # time-stepped: aliasing at steps <= 2k
        validate.check_forcing(s, "shooting", 1, 6, np.arange(3))
    assert e.value.key == "steps"
    validate.check_forcing(s, "shooting", 1, 7, np.arange(3))
    with pytest.raises(InputError) as e:
        discretised.solve(s, 1.0, "hbm", harmonics=2)
    assert e.value.key == "harmonics"
    unforced = chain([1.0], [1.0], 0.1, elements=[Friction(dof=0, mu=0.1, normal_force=1.0)])
    validate.check_forcing(unforced, "hbm", 1, 16, np.zeros(0, dtype=np.int64))


def test_guess_parts_without_states():
    s = _system()
    rng = np.random.default_rng(1)
    q_hat = rng.standard_normal((5, 3))
    a = guess_parts({"q_hat": q_hat}, s, 1.3, 3)
    b = guess_parts({"q_hat": q_hat}, s, 1.3, 3, states=False)
    assert np.array_equal(a[0], b[0]) and a[0].shape == (7, 3)  # zero-padded to n_h = 3
    assert b[1] is None and b[2] is None
    assert np.allclose(a[1], q_hat[0] + q_hat[1] + q_hat[3])  # q(0) = x0 + sum_k xc_k
    with pytest.raises(InputError) as e:
        guess_parts({"q_hat": q_hat, "u0": [0.0, np.inf, 0.0]}, s, 1.3, 3, states=False)
    assert e.value.key == "guess.u0"
    sol = discretised.solve(s, 1.3, "hbm", harmonics=3, stability=False)
    assert sol.success
    c = guess_parts(sol, s, 1.3, 3, states=False)
    # a solution's own states: PeriodicSolution.initial_state() (from the Fourier coefficients, without the time
    # grid of all DOFs), equal to its q(t_0) on the grid to round-off
    q0, u0 = sol.initial_state()
    assert np.array_equal(c[0], sol.q_hat) and np.array_equal(c[1], q0) and np.array_equal(c[2], u0)
    assert np.allclose(c[1], sol.q[0], rtol=0, atol=1e-14 * np.abs(sol.q).max())
    # same iterates from a dict guess with and without the derived states: HBM's solve is unchanged
    g = discretised.solve(s, 1.3, "hbm", harmonics=3, stability=False, guess={"q_hat": sol.q_hat * 1.001})
    assert g.success and np.allclose(g.q_hat, sol.q_hat, rtol=0, atol=1e-9 * np.abs(sol.q_hat).max())


def test_certificate_element_tables_follow_the_elements():
    s = chain([1.0, 2.0, 1.5], [3.0, 1.0, 2.0], 0.1, forcing=[{"dof": 2, "amplitude": 1.0}],
              elements=[Contact(dof=2, gap=0.1, penalty_stiffness=100.0), Friction(dof=0, mu=0.3, normal_force=1.0)])
    el_dofs, col, I, J, sign, fr, ct = cm._element_tables(s)
    assert el_dofs.tolist() == [0, 2] and col == {0: 0, 2: 1}
    assert I.tolist() == [1, 0] and J.tolist() == [-1, -1]
    assert sign.tolist() == [float(e.sign) for e in s.elements]
    assert [j for j, _ in fr] == [1] and [j for j, _ in ct] == [0]
    assert cm.el_dofs_each(s).tolist() == [2, 0]
    assert cm._element_tables(s)[2] is I  # cached
    s2 = s.with_elements([Contact(dof=1, gap=0.2, penalty_stiffness=50.0)])
    el_dofs2, col2, I2, _, _, fr2, ct2 = cm._element_tables(s2)
    assert el_dofs2.tolist() == [1] and I2.tolist() == [0] and fr2 == () and [j for j, _ in ct2] == [0]
    assert cm.el_dofs_each(s2).tolist() == [1]
    with pytest.raises(ValueError):
        I[0] = 5  # shared: read-only
