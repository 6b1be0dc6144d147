"""MS-HBM with many nonlinear DOFs: the block-wise time integration of the
nonlinear subsystem, the banded condensation and the linear start from the condensation give the same
numbers as the dense implementation they replace.

* The 2000-mass chain with 20 friction elements: amplitudes against a stored reference, computed by the
  previous implementation (dense sensitivities of the whole subsystem with respect to all unknowns,
  SuperLU condensation; commit 1065b26, same options).  Tolerance 1e-9 relative: Newton stops at a
  scaled residual of 1e-10 (the two implementations agreed to 4e-15 on this machine).
* Residual and Jacobian of the block-wise integration against the one-block integration (the previous
  code path, forced by disabling the block split) at the same unknowns, for friction, contact and Jenkins
  elements in one chain and for Section 3.3: equal to rounding.
* Banded LU against SuperLU and dense solves; the linear start from the condensation against the
  linear response of the whole structure.
"""
import numpy as np
import pytest
import scipy.sparse as sp

import mshbm
from mshbm import Contact, Friction, Jenkins, chain
from mshbm.condensation import Banded, Condensation, solve_dynamic
from mshbm.integrators import subsystem
from mshbm.methods.common import linear_response
from mshbm.methods.registry import build_problem

OMEGA = np.pi / 5


def spread_chain(n, m, damping=0.01):
    """``m`` friction elements (mu 0.8, F_N 5) spread along ``n`` masses, each element's mass forced by
    5 cos(omega t) (workflow/scripts/bench/bench_nlscaling.py): every element sticks and slips."""
    dofs = [int(round((i + 0.5) * n / m)) for i in range(m)]
    return chain([1.0] * n, 1.0, damping, forcing=[{"dof": d, "amplitude": 5.0} for d in dofs],
                 elements=[Friction(d, 0.8, 5.0, 800.0) for d in dofs])


# amplitudes (max - min) / 2 of the 2000-mass chain with 20 elements, by the previous implementation
REF_ELEMENT_MASSES = np.array([
    1.3993539493429314, 1.531444067176491, 1.313766329361814, 1.1990228648744181, 1.2041880924962762,
    1.2279160740022728, 1.2349777070526136, 1.232783755498499, 1.2306540246385271, 1.2302999962941805,
    1.2304576931466227, 1.2306090662649591, 1.23138298445892, 1.232795199312962, 1.231345451882199,
    1.2214261322581579, 1.2113879086793553, 1.2451284871569688, 1.3542453760902706, 1.379295224645663])
REF_OTHER = {0: 1.0839809119596227, 1: 1.7188568881786375, 999: 1.34083814291992, 1999: 1.6073572950636572}


def test_chain_2000_masses_20_friction_elements_matches_previous_implementation():
    system = spread_chain(2000, 20)
    sol = mshbm.solve(system, OMEGA, "mshbm", harmonics=5, steps=4096, stability=False)
    assert sol.success, sol.message
    amp = np.asarray(sol.amplitude)
    dofs = [el.dof for el in system.elements]
    np.testing.assert_allclose(amp[dofs], REF_ELEMENT_MASSES, rtol=1e-9, atol=0)
    for d, a in REF_OTHER.items():
        assert abs(amp[d] - a) <= 1e-9 * a, (d, amp[d], a)
    # the element time series stick and slip (not all stuck, not all sliding)
    stick = np.asarray(sol.info["stick_or_closed_fraction"])
    assert np.all((stick > 0.2) & (stick < 0.8)), stick


def _one_block(monkeypatch):
    monkeypatch.setattr(subsystem, "_blocks", lambda *a, **k: None)


def _mixed_chain():
    # friction, contact, a Jenkins element (one slider DOF) and a relative friction pair: four blocks, one
    # of two DOFs; forcing on several masses
    els = [Friction(3, 0.5, 2.0), Contact(10, 0.2, 0.8), Jenkins(16, 0.6, 1.5, tangential_stiffness=4.0),
           Friction(22, 0.4, 1.0, relative_to=23)]
    return chain([1.0] * 30, 1.0, 0.02, elements=els,
                 forcing=[{"dof": 29, "amplitude": 2.0}, {"dof": 3, "amplitude": 1.5}, {"dof": 16, "amplitude": 1.0}])


@pytest.mark.parametrize("method", ["mshbm", "mshbm-intermediate"])
def test_blockwise_residual_and_jacobian_equal_one_block(method, monkeypatch):
    system = _mixed_chain()
    opts = dict(harmonics=3, steps=512)
    blocked, _ = build_problem(system, OMEGA, method, **opts)
    assert blocked.integrator.part.blocks is not None and len(blocked.integrator.part.blocks) == 4
    rng = np.random.default_rng(3)
    x = blocked.initial_guess("linear")
    x = x + 0.05 * rng.standard_normal(x.size) * max(1.0, np.abs(x).max())
    R1, J1 = blocked.residual(x)
    with monkeypatch.context() as mp:
        _one_block(mp)
        whole, _ = build_problem(system, OMEGA, method, **opts)
        assert whole.integrator.part.blocks is None
        R0, J0 = whole.residual(x)
    np.testing.assert_allclose(R1, R0, rtol=0, atol=1e-12 * np.abs(R0).max())
    np.testing.assert_allclose(J1, J0, rtol=0, atol=1e-11 * np.abs(J0).max())
    # the trajectories themselves (all integrated states, impulses, element statuses)
    p, q0, u0 = blocked._split(x)
    t1 = blocked.integrator.part.run(q0, u0, p, sens=False)
    t0 = whole.integrator.part.run(q0, u0, p, sens=False)
    np.testing.assert_allclose(t1.q, t0.q, rtol=0, atol=1e-12 * np.abs(t0.q).max())
    np.testing.assert_array_equal(t1.status, t0.status)


def test_blockwise_solution_equals_one_block(monkeypatch):
    system = spread_chain(120, 6)
    a = mshbm.solve(system, OMEGA, "mshbm", harmonics=5, steps=2048, stability=False)
    with monkeypatch.context() as mp:
        _one_block(mp)
        b = mshbm.solve(system, OMEGA, "mshbm", harmonics=5, steps=2048, stability=False)
    assert a.success and b.success
    np.testing.assert_allclose(a.amplitude, b.amplitude, rtol=1e-10, atol=0)
    np.testing.assert_allclose(a.q_hat, b.q_hat, rtol=0, atol=1e-9 * np.abs(b.q_hat).max())


def test_adjacent_elements_form_one_block():
    els = [Friction(4, 0.5, 1.0), Friction(5, 0.5, 1.0), Friction(20, 0.5, 1.0)]
    system = chain([1.0] * 30, 1.0, 0.01, elements=els, forcing=[{"dof": 29, "amplitude": 1.0}])
    problem, _ = build_problem(system, OMEGA, "mshbm", harmonics=2, steps=256)
    blocks = sorted(tuple(int(d) for d in b.dofs) for b in problem.integrator.part.blocks)
    assert blocks == [(0, 1), (2,)]  # subsystem numbering: DOFs 4, 5 coupled by their spring; DOF 20 alone


def _chain_matrices(n, damping=0.01):
    system = chain([1.0 + 0.1 * (i % 3) for i in range(n)], 1.0, damping)
    return system.M, system.C, system.K


def test_banded_solve_equals_sparse_and_dense():
    M, C, K = _chain_matrices(500)
    band = Banded.build(M, C, K)
    assert band is not None and (band.kl, band.ku) == (1, 1)
    rhs = np.random.default_rng(0).standard_normal((500, 3)) + 0j
    for w in (0.0, 0.7, 1.9):
        H = (K - w ** 2 * M + 1j * w * C).toarray()
        x_dense = np.linalg.solve(H, rhs)
        x_band = band.solve(band.factor(w), rhs)
        x_lu = sp.linalg.splu(sp.csc_matrix(H)).solve(rhs)
        scale = np.abs(x_dense).max()
        assert np.abs(x_band - x_dense).max() <= 1e-10 * scale
        assert np.abs(x_lu - x_dense).max() <= 1e-10 * scale
        assert np.abs(solve_dynamic(M, C, K, w, rhs) - x_dense).max() <= 1e-10 * scale
    # a wide band is left to SuperLU
    wide = sp.csr_matrix(sp.diags([np.ones(480), 2 * np.ones(500), np.ones(480)], [-20, 0, 20]))
    assert Banded.build(wide, wide, wide) is None


def test_banded_condensation_equals_dense_condensation():
    system = spread_chain(600, 3)
    keep = np.array([el.dof for el in system.elements])
    elim = np.setdiff1d(np.arange(system.n), keep)
    sparse_c = Condensation(system, OMEGA, 4, keep, elim)  # n_E > 400, sparse: banded LU
    dense_sys = mshbm.System(system.M.toarray(), system.C.toarray(), system.K.toarray(),
                             system.f_hat, system.elements)
    dense_c = Condensation(dense_sys, OMEGA, 4, keep, elim)
    for a in ("z", "Z", "T", "g"):
        A, B = getattr(sparse_c, a), getattr(dense_c, a)
        assert np.abs(A - B).max() <= 1e-10 * np.abs(B).max(), a
    assert np.all(sparse_c.rcond > 0)


def test_linear_start_from_condensation_equals_linear_response():
    system = spread_chain(700, 4)
    problem, _ = build_problem(system, OMEGA, "mshbm", harmonics=5, steps=1024)
    q_hat, q0, u0 = problem._linear_parts()
    full = linear_response(system, OMEGA, 5)[:, problem.Nd]
    np.testing.assert_allclose(q_hat, full, rtol=0, atol=1e-11 * np.abs(full).max())
    np.testing.assert_allclose(q0, full[0] + full[1::2].sum(axis=0), rtol=0, atol=1e-11 * np.abs(full).max())
