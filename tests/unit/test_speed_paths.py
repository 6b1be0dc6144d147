"""The fast paths of the HBM solve: each against the plain computation it replaces.

* :meth:`mshbm.System.derived` -- per-system cache of derived invariants: hit while the dependencies are
  the same immutable objects, recomputed when one is replaced, never cached for writeable or sparse ones;
* :func:`mshbm._lapack.lu_solve_batch` -- SciPy's zgetrf/zgetrs from compiled code: bit-identical to
  ``scipy.linalg.lapack`` and its pivot ratios;
* the certificate's compiled per-element pass (``_element_terms``), Parseval sums (``_harmonic_power``)
  and force tail (``_force_tail``) against NumPy formulas;
* :func:`mshbm.fourier.idft_derivative_matrix` equals ``Vs @ Om``.
"""
import numpy as np
from tests import discretised
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from mshbm import certificate as cm
from mshbm import fourier
from mshbm._lapack import lu_solve_batch
from mshbm.elements import Contact
from mshbm.system import System, chain


def _system():
    return chain([1.0, 2.0, 1.5], [3.0, 1.0, 2.0], 0.1, forcing=[{"dof": 2, "amplitude": 1.0}],
                 elements=[Contact(dof=0, gap=0.1, penalty_stiffness=100.0)])


def test_system_arrays_are_read_only():
    s = _system()
    for a in (s.M, s.C, s.K, s.f_hat):
        with pytest.raises(ValueError):
            a[0, 0] = 1.0


def test_derived_cache_hits_and_invalidation():
    s = _system()
    calls = []

    def compute():
        calls.append(1)
        return float(np.trace(s.K))

    assert s.derived("trK", ("K",), compute) == 6.0 + 3.0 - 0.0  # 3+1, 1+2, 2
    assert s.derived("trK", ("K",), compute) == 9.0
    assert len(calls) == 1  # second call: cached
    # a replaced dependency (read-only again) is recomputed
    K2 = 2.0 * np.asarray(s.K)
    K2.flags.writeable = False
    s.K = K2
    assert s.derived("trK", ("K",), compute) == 18.0 and len(calls) == 2
    # a writeable dependency is never cached
    s.K = 3.0 * np.asarray(s.M)
    assert s.derived("trK", ("K",), compute) == 13.5 and s.derived("trK", ("K",), compute) == 13.5
    assert len(calls) == 4
    # sparse: never cached
    s.K = sp.csr_matrix(np.eye(3))
    assert s.derived("trK2", ("K",), lambda: (calls.append(1), 0)[1]) == 0
    s.derived("trK2", ("K",), lambda: (calls.append(1), 0)[1])
    assert len(calls) == 6


def test_derived_cache_is_not_shared_with_copies():
    s = _system()
    s.derived("x", ("f_hat",), lambda: "original")
    new = s.with_elements([])  # copies __dict__
    f = np.asarray(s.f_hat) * 2.0
    f.flags.writeable = False
    new.f_hat = f
    assert new.derived("x", ("f_hat",), lambda: "copy") == "copy"
    assert s.derived("x", ("f_hat",), lambda: "recomputed") == "original"


@pytest.mark.parametrize("n,m", [(1, 1), (4, 2), (9, 5)])
def test_lu_solve_batch_is_scipys_lapack(n, m):
    rng = np.random.default_rng(n)
    H = rng.normal(size=(5, n, n)) + 1j * rng.normal(size=(5, n, n))
    H[2, :, 0] = 0.0  # exactly singular: zero pivot
    rhs = rng.normal(size=(5, n, m)) + 1j * rng.normal(size=(5, n, m))
    sol, rcond = np.empty_like(rhs), np.empty(5)
    lu_solve_batch(H, rhs, sol, rcond)
    getrf, getrs = sla.get_lapack_funcs(("getrf", "getrs"), (H[0],))
    for k in range(5):
        lu, piv, info = getrf(H[k])
        d = np.abs(np.diag(lu))
        if k == 2:
            assert info > 0 and rcond[k] == 0.0
            continue
        assert abs(rcond[k] - d.min() / d.max()) <= 4e-16 * rcond[k]  # |U_ii|: hypot, rounding apart
        x, _ = getrs(lu, piv, rhs[k])
        np.testing.assert_array_equal(sol[k], x)
        np.testing.assert_allclose(H[k] @ sol[k], rhs[k], rtol=0, atol=1e-10 * np.abs(rhs[k]).max() * n)


def test_idft_derivative_matrix_equals_the_product():
    for N, n_h, w in ((512, 5, 0.63), (64, 3, 13.1), (16, 1, 1e-3)):
        A = fourier.idft_derivative_matrix(N, n_h, w)
        np.testing.assert_array_equal(A, fourier.idft_matrix(N, n_h) @ fourier.derivative(np.eye(2 * n_h + 1), w))


def test_element_terms_match_numpy():
    rng = np.random.default_rng(3)
    N, ne = 64, 3
    q, u = rng.normal(size=(N + 1, ne)), rng.normal(size=(N + 1, ne))
    lam = rng.normal(size=(N + 1, 3))
    lam[:, 2] = 0.0
    I, J, sign = np.array([0, 1, 2]), np.array([-1, 2, -1]), np.array([-1.0, 1.0, 1.0])
    out = np.empty((3, 8))
    cm._element_terms(q, u, lam, I, J, sign, N, out)
    for j in range(3):
        wq = sign[j] * (q[:, I[j]] - (q[:, J[j]] if J[j] >= 0 else 0.0))
        wu = sign[j] * (u[:, I[j]] - (u[:, J[j]] if J[j] >= 0 else 0.0))
        uj = sign[j] * wu
        ref = [wq.min(), np.abs(wu).max(), lam[:, j].max(), lam[:, j].min(), np.abs(lam[:, j]).max(),
               np.sum(sign[j] * lam[:-1, j] * uj[:-1]), np.sum(np.abs(lam[:-1, j] * uj[:-1])),
               float(np.any(np.abs(lam[:, j]) > 0))]
        np.testing.assert_allclose(out[j], ref, rtol=1e-13, atol=1e-13)
    q[5, 1] = np.nan  # NaN propagates like NumPy's min/max
    cm._element_terms(q, u, lam, I, J, sign, N, out)
    assert np.isnan(out[1, 0]) and not np.isnan(out[0, 0]) and not np.isnan(out[2, 0])
    assert not np.isnan(out[1, 1])  # u has no NaN


def test_harmonic_power_and_force_tail_match_numpy():
    rng = np.random.default_rng(4)
    n_h, n, omega, T = 4, 3, 0.8, 2 * np.pi / 0.8
    qh, fh = rng.normal(size=(2 * n_h + 1, n)), rng.normal(size=(2 * n_h + 1, n))
    Cm = rng.normal(size=(n, n))
    Cm = Cm + Cm.T
    out = np.empty(3)
    cm._harmonic_power(qh, fh, Cm, omega, out)
    kw = np.arange(1, n_h + 1)[:, None] * omega
    a, b = qh[1::2], qh[2::2]
    pw = kw * (fh[1::2] * b - fh[2::2] * a)
    D_C = np.sum((kw * a) * (Cm @ (kw * a).T).T) + np.sum((kw * b) * (Cm @ (kw * b).T).T)
    np.testing.assert_allclose(out, [pw.sum(), np.abs(pw).sum(), D_C], rtol=1e-12)
    assert abs(0.5 * T * out[2] - 0.5 * T * D_C) <= 1e-12 * abs(0.5 * T * D_C)
    Z = rng.normal(size=(33, 2)) + 1j * rng.normal(size=(33, 2))
    Kd, Md, Cd = rng.random(n) + 1, rng.random(n) + 1, rng.random(n)
    d = np.array([2, 0])
    tail = np.empty(2)
    cm._force_tail(Z, Kd, Md, Cd, d, omega, n_h, tail)
    k = np.arange(n_h + 1, 33)[:, None] * omega
    Hd = np.abs(Kd[d] - k ** 2 * Md[d] + 1j * k * Cd[d])
    np.testing.assert_allclose(tail, np.sqrt(((np.abs(Z[n_h + 1:]) / Hd) ** 2).sum(axis=0)), rtol=1e-13)


def _old_solve(J, R, s):
    """The Newton step through SciPy's LAPACK wrappers, as mshbm.solvers.newton._solve computes it without
    its compiled kernel."""
    J, R = J / s[:, None], R / s
    if np.all(np.isfinite(J)):
        lu, piv, info = sla.lapack.dgetrf(J)
        if info == 0:
            anorm = float(np.max(np.abs(J).sum(axis=0), initial=0.0))
            rcond, _ = sla.lapack.dgecon(lu, anorm, norm="1")
            if rcond > 1e-15:
                return sla.lapack.dgetrs(lu, piv, R)[0], True
    return np.linalg.lstsq(J, R, rcond=None)[0], False


@pytest.mark.parametrize("n", [1, 11, 40])
def test_newton_step_kernel_is_scipys_lapack(n):
    from mshbm._lapack import scaled_lu_solve
    from mshbm.solvers.newton import _solve

    rng = np.random.default_rng(n)
    for case in range(4):
        J = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-3, 3, size=(n, 1))
        R, s = rng.normal(size=n), 10.0 ** rng.uniform(-2, 2, size=n)
        if case == 1 and n > 1:
            J[:, 0] = J[:, 1]  # exactly singular: least squares
        if case == 2 and n > 1:
            J[:, 0] = J[:, 1] * (1.0 + 1e-17)  # numerically singular (rcond below 1e-15)
        if case == 3:  # not finite: the kernel declines (the caller's least squares is not run here: LAPACK's
            J[0, 0] = np.inf  # SVD does not return on inf; Newton stops on a non-finite Jacobian before)
            assert not scaled_lu_solve(J, R, s, 1e-15, np.empty(n))
            continue
        ref, used_lu = _old_solve(J, R, s)
        dx = np.empty(n)
        assert bool(scaled_lu_solve(J, R, s, 1e-15, dx)) == used_lu
        np.testing.assert_array_equal(_solve(J, R, s), ref)


def test_fourier_element_terms_match_the_stored_grid():
    """The certificate's pass over a Fourier solution (HBM) equals the pass over its stored grid values."""
    import mshbm

    els = [Contact(dof=0, gap=0.02, penalty_stiffness=300.0, penalty_damping=0.5),
           Contact(dof=1, gap=0.05, penalty_stiffness=200.0, relative_to=2)]
    s = chain([1.0, 2.0, 1.5], [3.0, 1.0, 2.0], 0.1, forcing=[{"dof": 2, "amplitude": 1.0}], elements=els)
    sol = discretised.solve(s, 1.1, "hbm", harmonics=4, steps=128, stability=False)
    assert sol.success, sol.message
    dofs = np.array([0, 1, 2])
    I, J, sign = np.array([0, 1]), np.array([-1, 2]), np.array([e.sign for e in els], dtype=float)
    lam = np.ascontiguousarray(sol.lam)
    N = sol.t.size - 1
    ref = np.empty((2, 8))
    qe, ue = sol.displacement(dofs), sol.velocity(dofs)
    cm._element_terms(qe, ue, lam, I, J, sign, N, ref)
    out = np.empty((2, 8))
    umax = cm._element_terms_fourier(np.ascontiguousarray(sol.q_hat[:, dofs]), fourier.idft_matrix(N, 4), sol.omega,
                                     lam, I, J, sign, N, out)
    scale = np.maximum(np.abs(ref), 1e-12)
    assert np.all(np.abs(out - ref) <= 1e-12 * scale.max(axis=0))
    assert abs(umax - np.abs(ue).max()) <= 1e-12 * np.abs(ue).max()
    assert ref[0, 2] > 0 and ref[1, 2] > 0  # both contacts close
