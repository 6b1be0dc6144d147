"""Kept factorisations of the sparse condensation (mshbm.condensation.FactorReuse, reuse_factors).

A 2-D spring grid (bandwidth above MAX_BAND, so SuperLU, not the band LU) with sparse matrices: condensations
made inside ``reuse_factors`` at a frequency near an earlier one reuse its LU by the splitting iteration and
agree with a fresh condensation; far away they factorise afresh; outside the context nothing is kept.
"""
import numpy as np
import scipy.sparse as sp

from mshbm import System
from mshbm.condensation import MAX_BAND, Condensation, FactorReuse, reuse_factors


def _grid(nx=24, ny=24, k=1.0e4, m=1.0, zeta_k=1e-4):
    """Masses on an nx x ny grid joined by springs k to their neighbours and to the ground at the edge x = 0;
    Rayleigh damping C = zeta_k K; a unit force on one corner.  Natural numbering: bandwidth nx."""
    n = nx * ny
    idx = np.arange(n).reshape(ny, nx)
    rows, cols, vals = [], [], []

    def spring(a, b):
        rows.extend([a, b, a, b]), cols.extend([a, b, b, a]), vals.extend([k, k, -k, -k])

    for j in range(ny):
        for i in range(nx):
            if i + 1 < nx:
                spring(idx[j, i], idx[j, i + 1])
            if j + 1 < ny:
                spring(idx[j, i], idx[j + 1, i])
        rows.append(idx[j, 0]), cols.append(idx[j, 0]), vals.append(k)  # clamped edge
    K = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    M = sp.identity(n, format="csr") * m
    f = np.zeros((3, n))
    f[1, idx[-1, -1]] = 1.0
    return System(M, zeta_k * K, K, f)


def _split(system):
    n = system.n
    keep = np.array([n - 1, n // 2])
    return keep, np.setdiff1d(np.arange(n), keep)


def _close(a, b, rtol):
    scale = np.max(np.abs(b))
    return float(np.max(np.abs(a - b))) <= rtol * scale


def test_the_grid_takes_the_superlu_path():
    s = _grid()
    i, j = s.K.nonzero()
    assert int(np.max(np.abs(i - j))) > MAX_BAND
    keep, elim = _split(s)
    assert elim.size > 400  # not the dense path


def test_nearby_frequency_reuses_the_lu_and_agrees_with_a_fresh_condensation():
    s = _grid()
    keep, elim = _split(s)
    n_h, omega = 3, 0.37 * np.sqrt(1.0e4)  # between grid modes
    with reuse_factors() as reuse:
        Condensation(s, omega, n_h, keep, elim)
        assert reuse.counters["factorisations"] == n_h + 1
        for rel in (1e-6, -1e-6, 1e-4):
            w = omega * (1 + rel)
            c = Condensation(s, w, n_h, keep, elim)
        assert reuse.counters["factorisations"] == n_h + 1  # no new factorisation
        assert reuse.counters["refined"] == 3 * (n_h + 1)
        assert reuse.counters["refine_failures"] == 0
    fresh = Condensation(s, w, n_h, keep, elim)  # outside the context: a fresh LU
    for a in ("T", "g", "z", "Z"):
        assert _close(getattr(c, a), getattr(fresh, a), 1e-9), a


def test_far_frequency_factorises_afresh_and_replaces_the_kept_lu():
    s = _grid()
    keep, elim = _split(s)
    n_h, omega = 2, 0.37 * np.sqrt(1.0e4)
    reuse = FactorReuse()
    with reuse_factors(reuse):
        Condensation(s, omega, n_h, keep, elim)
        c = Condensation(s, 1.9 * omega, n_h, keep, elim)
    # k = 0 (K_EE alone) is refined exactly; k = 1, 2 moved by 90 % across grid modes: no convergence
    assert reuse.counters["refine_failures"] >= 1
    assert reuse.counters["factorisations"] == n_h + 1 + reuse.counters["refine_failures"]
    kept_w = sorted(w for (key, k), (w, _, _) in reuse.kept.items() if k > 0)
    assert any(abs(w - 1.9 * omega * k) < 1e-12 for w in kept_w for k in (1, 2))
    fresh = Condensation(s, 1.9 * omega, n_h, keep, elim)
    for a in ("T", "g"):
        assert _close(getattr(c, a), getattr(fresh, a), 1e-9), a


def test_nothing_is_kept_outside_the_context():
    s = _grid(nx=20, ny=22)
    keep, elim = _split(s)
    reuse = FactorReuse()
    with reuse_factors(reuse):
        pass
    Condensation(s, 30.0, 1, keep, elim)
    assert reuse.counters == {"factorisations": 0, "refined": 0, "refine_iterations": 0, "refine_failures": 0}
    assert reuse.kept == {}


def test_reused_condensation_is_smooth_in_omega():
    """The central difference of T over omega (1 +- h) converges like h^2 with one kept LU (the property that
    makes dR/domega and a continuation corrector work): the differences at h and h/2 agree to O(h^2)."""
    s = _grid()
    keep, elim = _split(s)
    omega = 0.37 * np.sqrt(1.0e4)
    with reuse_factors():
        Condensation(s, omega, 1, keep, elim)
        d = []
        for h in (1e-6, 5e-7):
            Tp = Condensation(s, omega * (1 + h), 1, keep, elim).T[1]
            Tm = Condensation(s, omega * (1 - h), 1, keep, elim).T[1]
            d.append((Tp - Tm) / (2 * h * omega))
    assert np.max(np.abs(d[0])) > 0
    assert _close(d[1], d[0], 1e-6)


def test_omega_slope_is_the_derivative_of_T_and_g():
    """:meth:`Condensation.omega_slope` (sparse path, symmetric M, C, K; from Z and z alone) against central
    differences of reused condensations: the difference at h converges to it like h^2 (each tenth of h shrinks the
    gap by ~100, measured 5.9e-3, 5.9e-5, 5.9e-7 at h = 1e-3, 1e-4, 1e-5); dT and dg are zero at k = 0."""
    s = _grid()
    keep, elim = _split(s)
    n_h, omega = 2, 0.37 * np.sqrt(1.0e4)
    with reuse_factors():
        c = Condensation(s, omega, n_h, keep, elim)
        dT, dg = c.omega_slope()
        assert np.all(dT[0] == 0) and np.all(dg[0] == 0)
        gaps = []
        for h in (1e-3, 1e-4, 1e-5):
            cp = Condensation(s, omega * (1 + h), n_h, keep, elim)
            cm = Condensation(s, omega * (1 - h), n_h, keep, elim)
            fT, fg = (cp.T - cm.T) / (2 * h * omega), (cp.g - cm.g) / (2 * h * omega)
            gaps.append(max(float(np.max(np.abs(fT[k] - dT[k])) / np.max(np.abs(dT[k]))) for k in (1, 2)))
            assert _close(fg[1:], dg[1:], 1e-5)
    assert gaps[2] < 1e-6
    assert all(0.005 < b / a < 0.02 for a, b in zip(gaps, gaps[1:]))  # h^2: the slope is the derivative
    # shifted: T and g to first order, z and Z left out
    d = 1e-6 * omega
    sh = c.shifted(d)
    assert sh.z is None and sh.Z is None and sh.shifted(d) is None
    assert np.array_equal(sh.T, c.T + d * dT) and np.array_equal(sh.g, c.g + d * dg)


def test_omega_slope_is_none_where_it_does_not_apply():
    """The dense path (few eliminated DOFs) and a non-symmetric C have no slope (H_RE H_EE^-1 = Z^T fails)."""
    s = _grid(nx=10, ny=10)
    keep, elim = _split(s)
    assert Condensation(s, 30.0, 1, keep, elim).omega_slope() is None  # n_E < 400: dense
    s = _grid()
    keep, elim = _split(s)
    C = s.C.tolil()
    C[0, 1] += 1e-12  # symmetric to 3e-13 (accepted by System), not exactly
    s2 = System(s.M, C.tocsr(), s.K, np.zeros((3, s.n)))
    assert Condensation(s2, 30.0, 1, keep, elim).omega_slope() is None


def test_mixed_problem_nearby_gives_the_rebuilt_omega_derivative():
    """MS-HBM's dR/domega from problems whose condensation is shifted to first order (``nearby``) equals the
    one from fully rebuilt problems to the rounding of the difference (sparse 576-DOF grid, a friction
    element on the forced corner)."""
    import mshbm

    s0 = _grid()
    n = s0.n
    s = System(s0.M, s0.C, s0.K, s0.forcing_hat(1), elements=[mshbm.Friction(dof=n - 1, mu=0.5, normal_force=1e-3)])
    omega = 0.37 * np.sqrt(1.0e4)
    with reuse_factors():
        p, _ = mshbm.build_problem(s, omega, "mshbm", harmonics=3, steps=256)
        x = p.initial_guess("linear")
        new = p.omega_derivative(x)
        p.nearby = p.rebuilt  # the fully rebuilt problems
        old = p.omega_derivative(x)
    assert np.max(np.abs(new)) > 0
    assert _close(new, old, 1e-6)
