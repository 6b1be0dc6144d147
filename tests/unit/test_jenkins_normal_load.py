"""3-D Jenkins with a contact-loaded normal (``examples/cone3d.yaml`` with ``tangential_stiffness``): the sliders'
disk bound ``mu (N_0 + lambda_N(t))`` follows the structure's rigid normal contact (time stepping: the kernel's
contact-loaded cone block on the massless slider DOFs; DLFT: the velocity predictor's per-sample bound on the
sliders).  HBM refuses (its return mapping marches with a constant bound).

Independent references (measured numbers in the tests):

* shooting (Moreau-Jean, first order in h) and DLFT (harmonic balance with the sliders' harmonics): the raw
  shooting error at N = 2048 is ~1e-3 of the amplitude scale; its Richardson extrapolation from N = 1024, 2048
  comes within 3.6e-5 of DLFT (n_h = 15, itself converged to 1e-6: n_h = 45 moves it by 6e-7); MS-HBM (N = 2048,
  n_h = 15) agrees with shooting at the same step to 2.4e-5;
* ``k_t -> inf``: the rigid 3-D contact, approached like ``1 / k_t`` (DLFT at k_t = 200 and 2000 against the
  rigid cone: the error falls tenfold).
"""
import numpy as np
import pytest

import mshbm
from mshbm import InputError
from mshbm.elements.friction import Jenkins
from tests.unit.test_cone import ROOT

CASE = mshbm.load_case(ROOT / "examples" / "cone3d.yaml")


def jenkins(kt):
    S = CASE.system
    return S.with_elements([Jenkins(e.dof, e.mu, e.normal_force, e.smoothing, normal_contact=e.normal_contact,
                                    cone_partner=e.cone_partner, tangential_stiffness=kt) if e.bounded else e
                            for e in S.elements])


def _q(sol, n=7):
    assert sol.success, sol.message
    return np.asarray(sol.q_hat)[:n]


def test_shooting_mshbm_and_dlft_agree():
    S = jenkins(20.0)
    sh = {N: mshbm.solve(S, CASE.omega, "shooting", steps=N, accuracy=False) for N in (1024, 2048)}
    dl = _q(mshbm.solve(S, CASE.omega, "dlft", harmonics=15, accuracy=False))
    scale = np.abs(dl).max()
    raw = np.abs(_q(sh[2048]) - dl).max() / scale
    rich = np.abs(2 * _q(sh[2048]) - _q(sh[1024]) - dl).max() / scale
    assert raw > 3e-4 and rich < 5e-5 and rich < raw / 15
    for s in sh.values():  # the cone with the contact's per-sample bound, on every step
        names = {c.name: c for c in s.certificate.checks}
        assert names["friction_cone"].passed and names["friction_cone"].value > 0.99  # and it slips
    ms = _q(mshbm.solve(S, CASE.omega, "mshbm", steps=2048, harmonics=15, accuracy=False))
    assert np.abs(ms - _q(sh[2048])).max() / scale < 5e-5
    # the normal load varies: the contact force is not constant over the period
    lam_n = np.asarray(sh[2048].lam)[:, 2]
    assert lam_n.min() >= -1e-9 and lam_n.max() - lam_n.min() > 0.1 * lam_n.max()


def test_stiff_jenkins_tends_to_the_rigid_cone():
    rigid = _q(mshbm.solve(CASE.system, CASE.omega, "dlft", harmonics=15, accuracy=False))
    err = [np.abs(_q(mshbm.solve(jenkins(kt), CASE.omega, "dlft", harmonics=15, accuracy=False)) - rigid).max()
           for kt in (200.0, 2000.0)]
    assert 7.0 < err[0] / err[1] < 13.0 and err[1] < 1e-3 * np.abs(rigid).max()


def test_hbm_refuses():
    with pytest.raises(InputError) as exc:
        mshbm.solve(jenkins(20.0), CASE.omega, "hbm", harmonics=5)
    assert exc.value.key == "friction.normal_contact" and "constant bound" in str(exc.value)
