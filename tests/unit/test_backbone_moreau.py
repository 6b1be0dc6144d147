"""Nonlinear modes with Moreau-Jean time stepping (mshbm.backbone(integrator="moreau"), shooting and MS-HBM):
against the exact event-driven flow's backbone, the half-steps error estimate against the true error, Jenkins
joints (beyond the event flow) by shooting against MS-HBM, and the refusals."""
import numpy as np
import pytest

import mshbm
from mshbm.backbone import backbone
from mshbm.errors import InputError
from mshbm.methods.modes_moreau import MOREAU_D_TOL, MOREAU_OMEGA_TOL

M3 = np.eye(3)
K3 = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])


def coulomb_chain():
    """3-DOF chain, Rayleigh dashpots 0.01 K, Coulomb friction mu F_N = 0.3 between DOF 0 and the ground."""
    return mshbm.System(M3, 0.01 * K3, K3, np.zeros((3, 3)), elements=[mshbm.Friction(0, 1.0, 0.3)])


@pytest.mark.parametrize("method", ["shooting", "mshbm"])
def test_moreau_mode_against_event_flow(method):
    """Moreau-Jean (1024 steps) against the exact flow's backbone (shooting with the event-driven flow) at the
    same modal amplitudes: omega and D within the certificate's tolerances, and the true error within 3 times
    the point's own half-steps estimate (order 1: the estimate is the error; observed omega 2e-5 / 5e-6 and D
    4e-6 / 6e-6 relative to the event flow, shooting / MS-HBM n_h = 5)."""
    s = coulomb_chain()
    ref = backbone(s, 3.0, 6.0, method="shooting", points=4)
    b = backbone(s, 3.0, 6.0, method=method, integrator="moreau", points=4, harmonics=5)
    assert ref.success and b.success, (ref.message, b.message)
    d = b.to_dict()
    assert d["integrator"] == "moreau" and all(d["certified"])
    a_ref = ref.modal_amplitude
    w = np.interp(b.modal_amplitude, a_ref, ref.omega)
    D = np.interp(b.modal_amplitude, a_ref, ref.damping_ratio)
    # the reference interpolated linearly between its points: compare at the shared end points exactly
    for i in (0, -1):
        ew, eD = abs(b.omega[i] / w[i] - 1), abs(b.damping_ratio[i] - D[i])
        assert ew < MOREAU_OMEGA_TOL and eD < MOREAU_D_TOL
        if method == "shooting":  # the whole error is the time stepping's (MS-HBM adds the truncation)
            assert ew <= 3 * d["omega_error"][i] + 1e-9 and eD <= 3 * d["D_error"][i] + 1e-9
    assert max(d["omega_error"]) < 1e-4 and max(d["D_error"]) < 1e-4


def test_moreau_jenkins_joint_shooting_and_mshbm():
    """A Jenkins joint (DOF 0 to the ground, k_t = 2, slip force 0.2; the event flow does not take it): the
    stuck mode at small amplitude (omega of K + k_t e_0 e_0^T to 1e-5: the trapezoidal rule's phase error
    (omega h)^2 / 12 = 3.1e-6 at 1024 steps, observed 3.1e-6), softening and friction damping once it
    slips, and shooting and MS-HBM (n_h = 7) agree where it slips (omega 1e-3, D 5e-3 absolute)."""
    s = mshbm.System(M3, 0.002 * K3, K3, np.zeros((3, 3)),
                     elements=[mshbm.Jenkins(0, 1.0, 0.2, tangential_stiffness=2.0)])
    K0 = K3.copy()
    K0[0, 0] += 2.0
    w_stuck = np.sqrt(np.linalg.eigvalsh(K0)[0])
    sh = backbone(s, 0.01, 2.0, method="shooting", integrator="moreau", points=6, harmonics=7)
    mx = backbone(s, 0.01, 2.0, method="mshbm", integrator="moreau", points=6, harmonics=7)
    assert sh.success and mx.success, (sh.message, mx.message)
    for b in (sh, mx):
        assert abs(b.omega[0] / w_stuck - 1) < 1e-5
        assert b.omega[-1] < 0.95 * b.omega[0] and b.damping_ratio.max() > 5 * b.damping_ratio[0]
    assert abs(mx.omega[-1] / sh.omega[-1] - 1) < 1e-3 and abs(mx.damping_ratio[-1] - sh.damping_ratio[-1]) < 5e-3


def test_moreau_refusals():
    """A conservative impact oscillator (C = 0, e_N = 1) with Moreau-Jean: refused on 'integrator' (its orbit
    family with xi = 0 does not exist for the discrete scheme), by shooting and MS-HBM; 'integrator' with a
    harmonic-balance method, an unknown integrator and odd Moreau-Jean steps: refused on their keys."""
    s = mshbm.System([[1.0]], [[0.0]], [[1.0]], [0.0], elements=[mshbm.Contact(0, 0.5, 1.0)])
    for method in ("shooting", "mshbm"):
        with pytest.raises(InputError) as exc:
            backbone(s, 0.1, 1.0, method=method, integrator="moreau")
        assert exc.value.key == "integrator" and "event" in exc.value.problem
    c = coulomb_chain()
    for kw, key in ((dict(method="hbm", integrator="moreau"), "integrator"),
                    (dict(method="shooting", integrator="rk4"), "integrator"),
                    (dict(method="shooting", integrator="moreau", steps=1001), "steps")):
        with pytest.raises(InputError) as exc:
            backbone(c, 1.0, 2.0, **kw)
        assert exc.value.key == key
