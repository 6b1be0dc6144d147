"""The elements own their laws (mshbm.elements): regularised laws and their derivatives against finite
differences, the impulse projection against the set-valued law and against the compiled kernel, and the
homotopy scalings (``scaled`` changes the regularisation only, ``bound_scaled`` the friction bound)."""
import numpy as np
import pytest

import mshbm
import mshbm.system
from mshbm.elements import ELEMENT_TYPES, Contact, Element, Friction, regularised_forces
from mshbm.integrators import kernels
from mshbm.integrators.moreau_jean import MoreauJean

ELEMENTS = {
    "friction": Friction(0, 0.8, 5.0, 800.0),
    "friction_soft": Friction(0, 0.3, 2.0, 3.0),
    "contact": Contact(0, 0.1, 1.0, 8000.0, 0.0),
    "contact_damped": Contact(0, 0.05, 0.5, 2000.0, 30.0),
}


def test_public_names_are_the_element_classes():
    assert mshbm.Friction is Friction and mshbm.Contact is Contact and mshbm.Element is Element
    assert mshbm.system.Friction is Friction and mshbm.system.Contact is Contact
    assert ELEMENT_TYPES == {"friction": Friction, "contact": Contact, "polynomial": mshbm.Polynomial}
    assert Friction(0, 0.1, 1.0).kernel_parameters(0.01)[0] == kernels.KIND_FRICTION
    assert mshbm.Polynomial(0, {3: 1.0}).kernel_parameters(0.01)[0] == kernels.KIND_SMOOTH
    assert Contact(0, 0.1).kernel_parameters(0.01)[0] == kernels.KIND_CONTACT


def test_system_rejects_what_is_not_an_element():
    with pytest.raises(mshbm.InputError) as exc:
        mshbm.chain([1.0], 1.0, elements=["friction"])
    assert exc.value.key == "elements[0]"


def _samples(el, rng):
    """Local displacements ``s = w^T q`` and velocities ``gamma``, away from a contact's kink at g_N = 0."""
    s = rng.uniform(-0.3, 0.3, 200)
    if el.unilateral:
        g = el.gap + s
        s = s[np.abs(g) > 1e-3]
    return s, rng.uniform(-0.02, 0.02, s.size)


@pytest.mark.parametrize("name", list(ELEMENTS))
def test_regularised_law_derivatives_match_central_differences(name):
    el = ELEMENTS[name]
    s, g = _samples(el, np.random.default_rng(1))
    lam, dls, dlg = el.regularised_law(s, g)
    dls = np.zeros_like(s) if dls is None else dls
    dlg = np.zeros_like(s) if dlg is None else dlg
    for x, dx_, d in ((s, 1e-7, dls), (g, 1e-9, dlg)):
        xp, xm = x + dx_, x - dx_
        args_p = (xp, g) if x is s else (s, xp)
        args_m = (xm, g) if x is s else (s, xm)
        fd = (el.regularised_law(*args_p)[0] - el.regularised_law(*args_m)[0]) / (2 * dx_)
        scale = max(np.abs(d).max(), 1.0)
        assert np.max(np.abs(fd - d)) <= 1e-5 * scale, name
    assert np.abs(lam).max() > 0  # the law acted on the samples


def test_regularised_forces_jacobian_matches_finite_differences():
    """Generalised forces ``w lambda`` on two DOFs (friction and contact on DOF 0, friction on DOF 1)."""
    els = [Friction(0, 0.5, 2.0, 50.0), Contact(0, 0.05, 1.0, 3000.0, 20.0), Friction(1, 0.2, 1.0, 200.0)]
    rng = np.random.default_rng(7)
    q = rng.uniform(-0.2, 0.2, (64, 2))
    u = rng.uniform(-0.05, 0.05, (64, 2))
    q = q[np.abs(0.05 - q[:, 0]) > 1e-3]
    u = u[:q.shape[0]]
    lam, f, dfdq, dfdu = regularised_forces(els, [0, 0, 1], q, u)
    assert np.array_equal(f[:, 0], els[0].sign * lam[:, 0] + els[1].sign * lam[:, 1])
    for arr, d, step in ((q, dfdq, 1e-7), (u, dfdu, 1e-9)):
        for i in range(2):
            ap, am = arr.copy(), arr.copy()
            ap[:, i] += step
            am[:, i] -= step
            fp = regularised_forces(els, [0, 0, 1], ap if arr is q else q, ap if arr is u else u)[1]
            fm = regularised_forces(els, [0, 0, 1], am if arr is q else q, am if arr is u else u)[1]
            fd = (fp - fm) / (2 * step)
            assert np.max(np.abs(fd[:, i] - d[:, i])) <= 1e-5 * max(np.abs(d).max(), 1.0)
            assert np.max(np.abs(fd[:, 1 - i])) <= 1e-6  # single-DOF elements: diagonal only


def test_friction_projection_is_the_coulomb_law():
    el = Friction(0, 0.5, 2.0)
    h = 0.01
    p = np.linspace(-0.05, 0.05, 101)
    P = el.project(p, h)
    assert np.all(np.abs(P) <= h * el.bound)
    inside = np.abs(p) <= h * el.bound
    assert np.array_equal(P[inside], p[inside])  # stick: the impulse is admissible as it is
    assert np.all(P[~inside] == np.sign(p[~inside]) * h * el.bound)  # slip: at the bound
    assert np.array_equal(Friction(0, 0.0, 2.0).project(p, h), np.zeros_like(p))


def test_contact_projection_is_non_penetration():
    el = Contact(0, 0.1, 0.5)
    p = np.linspace(-1.0, 1.0, 101)
    P = el.project(p, 0.01)
    assert np.all(P >= 0.0)
    assert np.array_equal(P[p >= 0], p[p >= 0]) and np.all(P[p < 0] == 0.0)


@pytest.mark.parametrize("el,q0,u0,status", [
    (Friction(0, 0.5, 1.0), 0.1, 0.5, kernels.STATUS_SLIP),      # the free velocity needs more than the bound
    (Friction(0, 0.5, 1.0), 0.1, 0.002, kernels.STATUS_STICK),
    (Contact(0, 0.1, 1.0), 0.099, 2.0, kernels.STATUS_CLOSED),   # impact, e = 1
    (Contact(0, 0.1, 0.5), 0.0999, 0.3, kernels.STATUS_CLOSED),  # impact, e = 1/2
    (Contact(0, 0.1, 0.5), 0.0, 0.3, kernels.STATUS_OPEN),
])
def test_kernel_step_applies_the_element_projection(el, q0, u0, status):
    """One Moreau-Jean step of one DOF: the kernel's impulse is the element's projection of the impulse
    that would cancel the relative velocity (``gamma+ + e gamma- = 0``), and the result obeys the law."""
    M, C, K = np.array([[1.0]]), np.array([[0.1]]), np.array([[1.0]])
    h = 0.01
    st = MoreauJean(M, C, K, [el], h, 0.5)
    B = np.array([[0.002]])
    tr = st.run(np.array([q0]), np.array([u0]), B)
    assert tr.status[0, 0] & 3 == status
    P = tr.P[0, 0]
    uf = u0 + B[0, 0] - st.Aq[0, 0] * q0 - st.Au[0, 0] * u0
    w = el.sign
    qfree = q0 + h * 0.5 * (u0 + uf)
    closed = not el.unilateral or el.gap + w * qfree <= 0.0
    r = w * uf + (el.restitution * w * u0 if el.unilateral else 0.0)
    p_free = -r / st.Del[0, 0] if closed else 0.0
    assert P == pytest.approx(float(el.project(p_free, h)), rel=1e-12, abs=1e-15)
    gamma_plus = w * tr.u[1, 0]
    if el.bounded:
        assert abs(P) <= h * el.bound * (1 + 1e-12)
        if abs(P) < h * el.bound * (1 - 1e-9):
            assert abs(gamma_plus) <= 1e-12  # stick
        else:
            assert P * gamma_plus <= 0.0  # slip: the friction impulse opposes the motion
    else:
        assert P >= 0.0
        if P > 0:
            assert gamma_plus + el.restitution * w * u0 == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("name", list(ELEMENTS))
@pytest.mark.parametrize("factor", [1e-3, 0.1, 10.0])
def test_scaled_changes_the_regularisation_only(name, factor):
    el = ELEMENTS[name]
    sc = el.scaled(factor)
    assert type(sc) is type(el) and sc.dof == el.dof
    # the set-valued law (and so time stepping and the exact flow) is unchanged
    for h in (1e-3, 0.1):
        assert sc.kernel_parameters(h) == el.kernel_parameters(h)
    p = np.linspace(-2.0, 2.0, 41)
    assert np.array_equal(sc.project(p, 0.1), el.project(p, 0.1))
    if el.bounded:
        assert sc.bound == el.bound and sc.smoothing == pytest.approx(factor * el.smoothing, rel=1e-15)
        # limits of the regularised law: |lambda| < mu F_N, opposite to the slip, -> mu F_N for large slip
        g = np.array([-1e6, -1.0, -1e-3, 1e-3, 1.0, 1e6]) / sc.smoothing
        lam = sc.regularised_law(np.zeros_like(g), g)[0]
        assert np.all(np.abs(lam) < sc.bound) and np.all(lam * g < 0)
        assert np.abs(lam[[0, -1]]).min() >= sc.bound * (1 - 1e-6)
    else:
        assert (sc.gap, sc.restitution) == (el.gap, el.restitution)
        assert sc.penalty_stiffness == pytest.approx(factor * el.penalty_stiffness, rel=1e-15)
        # open (g_N > 0): no force for any regularisation; closed: lambda >= 0 when approaching
        s = np.array([-0.5, -0.01]) * el.gap
        assert np.all(sc.regularised_law(s, np.array([1.0, -1.0]))[0] == 0.0)
        lam = sc.regularised_law(np.array([-el.gap - 0.01]), np.array([-0.1]))[0]  # penetrated by 1 cm
        assert lam[0] > 0.0


def test_friction_regularisation_tends_to_the_set_valued_law():
    """``|lambda + mu F_N sign(gamma)| <= mu F_N 2 / (pi kappa |gamma|)`` (arctan's tail)."""
    el = Friction(0, 0.8, 5.0, 10.0)
    g = np.array([-0.3, -0.01, 0.02, 0.5])
    for f in (1.0, 1e2, 1e4):
        sc = el.scaled(f)
        lam = sc.regularised_law(np.zeros_like(g), g)[0]
        err = np.abs(lam + el.bound * np.sign(g))
        assert np.all(err <= el.bound * 2 / (np.pi * sc.smoothing * np.abs(g)))
    assert err.max() < 1e-3 * el.bound


def test_bound_scaled_and_renumbered():
    fr, ct = Friction(3, 0.5, 2.0, 40.0), Contact(2, 0.1, 0.7, 100.0, 1.0)
    assert fr.bound_scaled(0.25).bound == pytest.approx(0.25 * fr.bound) and fr.bound_scaled(0.25).smoothing == 40.0
    assert ct.bound_scaled(0.25) is ct
    assert fr.renumbered({3: 0}) == Friction(0, 0.5, 2.0, 40.0)
    assert ct.renumbered({2: 1}) == Contact(1, 0.1, 0.7, 100.0, 1.0)
    assert Friction(0, 0.0, 1.0).acts is False and fr.acts and ct.acts


def test_homotopies_of_a_system_delegate_to_the_elements():
    """``hbm.scaled_regularisation`` and ``continuation.scaled_system`` change each element as its own
    :meth:`scaled` / :meth:`bound_scaled` says; the matrices are shared."""
    from mshbm.methods.hbm import scaled_regularisation
    from mshbm.route.continuation import scaled_system

    els = [Friction(0, 0.5, 2.0, 40.0), Contact(1, 0.1, 0.7, 100.0, 1.0)]
    system = mshbm.chain([1.0, 2.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}], elements=els)
    soft = scaled_regularisation(system, 0.01)
    assert soft.elements == tuple(e.scaled(0.01) for e in els) and soft.K is system.K
    assert soft.elements[0].smoothing == pytest.approx(0.4) and soft.elements[1].penalty_damping == pytest.approx(0.01)
    light = scaled_system(system, forcing=0.5, friction=0.25)
    assert light.elements == (els[0].bound_scaled(0.25), els[1]) and light.M is system.M
    assert np.array_equal(light.f_hat, 0.5 * system.f_hat)
