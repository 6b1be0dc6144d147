"""The compiled AFT kernel of HBM against its NumPy twin and against the generic element path."""
import numpy as np
import pytest

import mshbm
from mshbm import fourier
from mshbm.elements import Contact, Friction
from mshbm.methods import hbm_kernels as hk
from mshbm.system import chain



def _against_generic(prob, kernel, x):
    """``prob.residual(x)`` with its compiled kernel (attribute ``kernel``), checked against the generic path (the
    kernel switched off) to 1e-11 of the largest entry; returns ``(R, J)`` of the kernel."""
    R1, J1 = prob.residual(x)
    saved = getattr(prob, kernel)
    setattr(prob, kernel, None)
    R2, J2 = prob.residual(x)
    setattr(prob, kernel, saved)
    np.testing.assert_allclose(R1, R2, rtol=0, atol=1e-11 * np.abs(R2).max())
    np.testing.assert_allclose(J1, J2, rtol=0, atol=1e-11 * np.abs(J2).max())
    return R1, J1

def _matrices(n_h, Ns, omega):
    Vs = fourier.idft_matrix(Ns, n_h)
    VsOm = np.ascontiguousarray(Vs @ fourier.derivative(np.eye(2 * n_h + 1), omega))
    return Vs, VsOm, fourier.dft_matrix(Ns, n_h)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("Ns", [64, 512])
def test_aft_forces_matches_numpy_twin(seed, Ns):
    rng = np.random.default_rng(seed)
    n_h, nN, omega = 5, 3, 0.7
    Vs, VsOm, E = _matrices(n_h, Ns, omega)
    Xn = rng.normal(size=(2 * n_h + 1, nN))
    # friction on column 0, contacts on 1 (closed part of the period) and 2 (with damping), friction on 2
    kind = np.array([0, 1, 1, 0])
    col = np.array([0, 1, 2, 2])
    sign = np.array([1.0, -1.0, -1.0, 1.0])
    p1 = np.array([0.6, 0.5 * rng.random(), -0.2, 0.3])
    p2 = np.array([50.0, 1e3, 2e2, 10.0])
    p3 = np.array([0.0, 0.0, 3.0, 0.0])
    Fn2, Jn2 = hk.aft_forces_numpy(Xn, Vs, VsOm, E, kind, col, sign, p1, p2, p3)
    scale = max(np.abs(Fn2).max(), 1.0)
    # the Jacobian blocks by matrix products (any matrices) and by the trigonometric sums (uniform grid)
    for kw in (np.zeros(0), np.arange(1, n_h + 1) * omega):
        Fn, Jn = np.empty((2 * n_h + 1, nN)), np.empty((2 * n_h + 1, nN, 2 * n_h + 1, nN))
        hk.aft_forces(Xn, Vs, VsOm, E, kind, col, sign, p1, p2, p3, True, Fn, Jn, kw)
        np.testing.assert_allclose(Fn, Fn2, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(Jn, Jn2, rtol=0, atol=1e-12 * max(np.abs(Jn2).max(), 1.0))
        Fn3 = np.empty_like(Fn)
        hk.aft_forces(Xn, Vs, VsOm, E, kind, col, sign, p1, p2, p3, False, Fn3, np.empty((0, 0, 0, 0)), kw)
        np.testing.assert_array_equal(Fn3, Fn)


def test_kernel_path_equals_generic_path():
    """HBMProblem.residual with the kernel equals the generic regularised_forces path (R and J)."""
    s = chain([1.0, 2.0, 1.0], [1.0, 1.0, 1.0], 0.05, forcing=[{"dof": 2, "amplitude": 1.0}],
              elements=[Friction(0, 0.3, 1.0), Contact(2, 0.4, 1.0, penalty_stiffness=500.0,
                                                      penalty_damping=0.5)])
    prob, _ = mshbm.build_problem(s, 0.9, "hbm", harmonics=7, steps=256)
    assert prob._fast is not None
    x = np.random.default_rng(1).normal(size=prob.n_unknowns)
    R1, J1 = _against_generic(prob, "_fast", x)


@pytest.mark.parametrize("seed", range(3))
def test_element_forces_match_the_element_laws(seed):
    """hbm_kernels.element_forces (HBMProblem.solution_parts) equals regularised_forces' lambda."""
    from mshbm.api import build_problem
    from mshbm.elements import regularised_forces

    rng = np.random.default_rng(seed)
    els = [Friction(dof=0, mu=0.4, normal_force=2.0, smoothing=30.0), Contact(dof=2, gap=0.05, penalty_stiffness=500.0,
                                                                           penalty_damping=0.7)]
    s = chain([1.0, 2.0, 1.0], [1.0, 1.0, 1.0], 0.05, forcing=[{"dof": 2, "amplitude": 1.0}], elements=els)
    prob, _ = build_problem(s, 0.9, "hbm", harmonics=4, steps=128)
    assert prob._fast is not None
    x = rng.normal(scale=0.2, size=prob.n_unknowns)
    q, u = prob._time(x)
    lam_ref = regularised_forces(s.elements, prob._ldof, q, u, coupling=True)[0]
    assert np.any(lam_ref[:, 1] > 0) and np.any(lam_ref[:, 1] == 0)  # the contact opens and closes
    lam = prob._element_forces(q, u)
    np.testing.assert_allclose(lam, lam_ref, rtol=1e-14, atol=1e-300)
    np.testing.assert_array_equal(lam[:, 1], lam_ref[:, 1])  # contact: the same arithmetic


@pytest.mark.parametrize("n_h, scale", [(9, 0.3), (9, 3.0), (15, 1.0)])
def test_loaded_friction_kernel_equals_generic_path(n_h, scale):
    """examples/damper2d.yaml (a friction whose normal load is a contact's force, the contact open on part of the
    period at these amplitudes): HBMProblem.residual with the compiled kernel of loaded frictions
    (hbm_kernels.aft_forces_loaded) equals the generic regularised_forces path in R and J, and its Jacobian blocks
    by products (any matrices) equal those by the trigonometric sums."""
    from pathlib import Path
    from mshbm.io import load_case

    case = load_case(Path(__file__).resolve().parents[2] / "examples" / "damper2d.yaml")
    prob, _ = mshbm.build_problem(case.model, 0.9, "hbm", harmonics=n_h)
    assert prob._fast is None and prob._loaded is not None
    x = np.random.default_rng(n_h).normal(scale=scale, size=prob.n_unknowns)
    q, u = prob._time(x)
    lam_n = prob._element_forces(q, u)[:, prob._loaded[6].max()]
    assert np.any(lam_n > 0) and np.any(lam_n == 0)  # the contact opens and closes
    R1, J1 = _against_generic(prob, "_loaded", x)
    assert np.array_equal(prob.residual(x, jac=False)[0], R1)
    nc, nN = 2 * n_h + 1, prob.nl_cols.size
    Xn = np.ascontiguousarray(x.reshape(nc, prob.nR)[:, prob.nl_cols])
    out = []
    for kw in (prob._kw, np.zeros(0)):
        Fn, Jn = np.empty((nc, nN)), np.empty((nc, nN, nc, nN))
        hk.aft_forces_loaded(Xn, prob.Vs, prob.VsOm, prob.E, *prob._loaded, True, Fn, Jn, kw)
        out.append((Fn, Jn))
    np.testing.assert_array_equal(out[0][0], out[1][0])
    np.testing.assert_allclose(out[0][1], out[1][1], rtol=0, atol=1e-11 * np.abs(out[1][1]).max())
