"""A stop on a chain with a consistent (coupled, non-diagonal) mass matrix: MS-HBM with
``impact_mass="effective"`` (impacts act with the effective mass of the whole structure,
mshbm.methods.mass_coupling) against the exact flow of the whole chain, and the default ``"subsystem"`` (impacts
with ``M_NN``), which converges to another orbit.

The chain: a fixed-free bar of three 2-node elements (mass 1 kg, stiffness 1 N/m each, consistent element mass
``m/6 [[2, 1], [1, 2]]``), the root node clamped, so ``M = [[4, 1, 0], [1, 4, 1], [0, 1, 2]] / 6`` couples every
DOF to its neighbours.  A stop (gap 0.5 m, ``e_N = 0.7``) acts on the tip DOF 2, a harmonic force 0.05 N on the
tip, ``omega = 0.5`` rad/s (just below the first natural frequency 0.5296 rad/s): two impacts per period.
Mass-proportional damping ``C = 0.05 M`` (a stiffness-proportional part couples the velocities of N and L, and
MS-HBM's truncation error then decays more slowly, measured ~ n_h^-2.5 instead of ~ n_h^-4 here).

References: the exact event-driven flow of the whole chain (shooting, ``integrator="event"``) and, independent
of it, Moreau-Jean shooting with small steps (first order: error of one step's displacement at an impact).
"""
import numpy as np
import pytest

import mshbm
from mshbm import Contact, System
from mshbm.methods.mass_coupling import impact_compliance, mass_decoupling

M = np.array([[4.0, 1.0, 0.0], [1.0, 4.0, 1.0], [0.0, 1.0, 2.0]]) / 6.0
K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
OMEGA, E_N = 0.5, 0.7


def chain_with_stop():
    f_hat = np.zeros((3, 3))
    f_hat[1, 2] = 0.05
    return System(M, 0.05 * M, K, f_hat, [Contact(2, 0.5, restitution=E_N)], name="consistent-mass chain")


def test_decoupled_mass_is_the_effective_mass():
    s = chain_with_stop()
    dec = mass_decoupling(s, np.array([2]), np.array([0, 1]))
    Ms = np.asarray(dec.system.M)
    assert np.all(Ms[2, :2] == 0.0) and np.all(Ms[:2, 2] == 0.0)
    Minv = np.linalg.inv(M)
    assert abs(Ms[2, 2] - 1.0 / Minv[2, 2]) <= 1e-14  # the Schur complement: 1 / (M^-1)_NN
    assert abs(impact_compliance(s)[2] - Minv[2, 2]) <= 1e-14
    np.testing.assert_array_equal(Ms[:2, :2], M[:2, :2])  # M_LL unchanged
    # the congruence q = T y: y_L = q_L + A q_N
    y = np.array([0.3, -0.2, 0.7])
    np.testing.assert_allclose(dec.to_original(y), dec.T @ y, rtol=0, atol=1e-15)
    # a diagonal mass needs none
    assert mass_decoupling(System(np.eye(3), 0.05 * np.eye(3), K, s.f_hat, s.elements), [2], [0, 1]) is None


@pytest.fixture(scope="module")
def solutions():
    s = chain_with_stop()
    ref = mshbm.solve(s, OMEGA, "shooting", integrator="event", harmonics=40)
    ms = mshbm.solve(s, OMEGA, "mshbm", integrator="event", harmonics=40, impact_mass="effective")
    return s, ref, ms


def _impacts(sol):
    return [e for e in sol.info["event_list"] if e.impulse > 0.0]


def test_event_mshbm_agrees_with_event_shooting(solutions):
    s, ref, ms = solutions
    assert ref.success, ref.message
    assert ms.success, ms.message
    A = float(np.max(ref.amplitude))
    # all Fourier coefficients (40 harmonics, 3 DOFs): measured 4.5e-7 of the amplitude
    assert np.max(np.abs(ms.q_hat - ref.q_hat)) <= 1e-6 * A
    # the contact DOF's amplitude (exact extrema of the flow): measured 3.1e-7 relative
    assert abs(ms.amplitude[2] / ref.amplitude[2] - 1.0) <= 1e-6
    # the other DOFs' amplitudes from their 40 harmonics: a truncated Fourier series of q_L = y_L - A q_N,
    # whose velocity jumps at the impacts the series smooths: measured 2.1e-5, 4.9e-6 relative
    np.testing.assert_allclose(ms.amplitude[:2], ref.amplitude[:2], rtol=1e-4)
    # the impacts: the same number, times and impulses (measured 1.2e-6 s in T = 12.6 s, 1.5e-6 relative)
    im, ir = _impacts(ms), _impacts(ref)
    assert len(im) == len(ir) == 2
    for a, b in zip(im, ir):
        assert abs(a.t - b.t) <= 1e-5 and abs(a.impulse / b.impulse - 1.0) <= 1e-5
        # Newton's law with the effective mass of the whole chain, 1 / (M^-1)_22 (not M_22 = 1/3 kg)
        m_eff = 1.0 / np.linalg.inv(M)[2, 2]
        assert abs(a.impulse - (1.0 + E_N) * m_eff * abs(a.velocity)) <= 1e-12 * a.impulse


def test_moreau_jean_shooting_with_small_steps_agrees(solutions):
    s, ref, _ = solutions
    steps = 8192
    mj = mshbm.solve(s, OMEGA, "shooting", integrator="moreau", steps=steps)
    assert mj.success, mj.message
    h = 2.0 * np.pi / OMEGA / steps
    jump = max((1.0 + E_N) * abs(e.velocity) for e in _impacts(ref))
    # first order: an impact is placed within one step; measured 3.5e-5 m against the bound 4.2e-4 m
    assert np.max(np.abs(mj.amplitude - ref.amplitude)) <= h * jump


def test_subsystem_mass_converges_to_another_orbit(solutions):
    """``impact_mass="subsystem"``: the impact acts with ``M_22 = 1/3 kg`` instead of the effective
    ``1 / (M^-1)_22``; the momentum the other DOFs take reaches the tip only through the truncated coupling force,
    so the error does not fall with the harmonics (measured below)."""
    s, ref, _ = solutions
    sub = mshbm.solve(s, OMEGA, "mshbm", integrator="event", harmonics=40, impact_mass="subsystem")
    A = float(np.max(ref.amplitude))
    err = np.max(np.abs(sub.q_hat - ref.q_hat)) / A
    assert err > 1e-3, err  # measured 5.3e-3 (3.9e-3 with 20 harmonics); effective mass: 4.5e-7
    # ... and says so: the certificate names the substituted impact mass (M_22 = 1/3 kg against the structure's
    # 1 / (M^-1)_22) and the solve estimates its effect (the re-solve with the effective mass, non-gating by
    # itself, summed into the gating accuracy): within a factor 2 of the amplitude error against the exact flow
    (check,) = [c for c in sub.certificate.checks if c.name == "model_substitution"]
    err_amp = float(np.max(np.abs(sub.amplitude - ref.amplitude))) / A
    assert not check.gating and 0.5 * err_amp <= check.value <= 2.0 * err_amp, (check.value, err_amp)
    assert "model_substitution" in sub.certificate["accuracy"].note
    M = s.M.toarray() if hasattr(s.M, "toarray") else np.asarray(s.M)
    m_eff = 1.0 / np.linalg.inv(M)[2, 2]
    (named,) = sub.certificate.info["model_substitution"]["substitutions"]
    assert named["key"] == "impact_mass" and named["represented"] == pytest.approx(M[2, 2], rel=1e-12)
    assert named["model"] == pytest.approx(m_eff, rel=1e-12) and abs(m_eff - M[2, 2]) > 1e-3 * M[2, 2]
    assert "impact mass of element 0" in sub.message
    _, _, ms = solutions
    assert "model_substitution" not in [c.name for c in ms.certificate.checks]


def test_impact_mass_option_is_checked():
    with pytest.raises(mshbm.InputError) as e:
        mshbm.solve(chain_with_stop(), OMEGA, "mshbm", impact_mass="lumped")
    assert e.value.key == "impact_mass"
    with pytest.raises(mshbm.InputError) as e:
        mshbm.solve(chain_with_stop(), OMEGA, "shooting", impact_mass="effective")
    assert e.value.key == "impact_mass"


def test_compliance_of_a_relative_contact_and_the_impact_masses_named():
    """``impact_compliance`` holds ``(M_TT)^-1`` between the element DOFs: ``w^T M^-1 w`` of a relative contact
    ``w = e_2 - e_0`` (off-diagonal entries included) for the whole chain and for the subsystem ``T = {0, 2}``;
    MS-HBM's ``impact_masses`` and the penalty restitution use it."""
    from mshbm.certificate.substitution import _penalty_restitution
    from mshbm.methods.mixed import MixedProblem

    el = Contact(2, 0.5, restitution=E_N, relative_to=0)
    s = chain_with_stop().with_elements([el])
    w = np.array([-1.0, 0.0, 1.0])
    Minv = np.linalg.inv(M)
    c = impact_compliance(s)
    assert abs(c.of(el) - w @ Minv @ w) <= 1e-14 * (w @ Minv @ w)
    assert abs(c.entry(0, 2) - Minv[0, 2]) <= 1e-15 and abs(c[0] - Minv[0, 0]) <= 1e-14
    M_TT = M[np.ix_([0, 2], [0, 2])]
    w_T = np.array([-1.0, 1.0])
    sub = impact_compliance(s, [0, 2])
    assert abs(sub.of(el) - w_T @ np.linalg.solve(M_TT, w_T)) <= 1e-14 * sub.of(el)
    assert impact_compliance(s, [2]).of(el) is None  # DOF 0 not integrated in time
    p = MixedProblem(s, OMEGA, harmonics=4, steps=64, partition=[0, 2])
    ((j, m_model, m_used),) = p.impact_masses()
    assert j == 0 and abs(m_model * (w @ Minv @ w) - 1.0) <= 1e-13
    assert abs(m_used * (w_T @ np.linalg.solve(M_TT, w_T)) - 1.0) <= 1e-13
    # the penalty contact's restitution: exp(-pi z / sqrt(1 - z^2)) with z = d_c / (2 sqrt(k_c m)), m = 1/(w^T M^-1 w)
    pen = Contact(2, 0.5, restitution=E_N, relative_to=0, penalty_stiffness=100.0, penalty_damping=0.5)
    z = 0.5 / (2.0 * np.sqrt(100.0 / (w @ Minv @ w)))
    assert _penalty_restitution(s.with_elements([pen]), pen) == pytest.approx(np.exp(-np.pi * z / np.sqrt(1 - z * z)),
                                                                            rel=1e-13)


def test_default_impact_mass_follows_the_integrator(solutions):
    """Without ``impact_mass``: the effective mass with the event-driven flow (the model's law; its ladder starts
    with the exact orbit), the subsystem mass with Moreau-Jean steps, whose answer then carries the estimate of
    the substitution (the re-solve with the effective mass and the event flow) in its combined accuracy."""
    from mshbm.methods.mixed import MixedProblem

    s = chain_with_stop()
    ev = MixedProblem(s, OMEGA, harmonics=4, steps=64, integrator="event")
    mj = MixedProblem(s, OMEGA, harmonics=4, steps=64)
    assert ev.impact_mass == "effective" and ev.decoupling is not None and ev.impact_masses() == []
    assert ev.preferred_starts == ("exact", "transient")
    assert mj.impact_mass == "subsystem" and mj.decoupling is None and len(mj.impact_masses()) == 1
    sol = mshbm.solve(s, OMEGA, "mshbm", harmonics=10, steps=4096, stability=False)
    assert sol.info.get("integrator") != "event"  # (at 2048 steps Moreau-Jean fails and the event fallback,
    # with its default effective mass, answers)
    chk = sol.certificate["model_substitution"]
    _, ref, _ = solutions
    err = float(np.max(np.abs(sol.amplitude - ref.amplitude))) / float(np.max(ref.amplitude))
    # measured 4.3e-3 against an amplitude error of 5.3e-3 of the answer (subsystem law and 4096 steps)
    assert 1e-3 < chk.value and 0.5 * err <= chk.value <= 2.0 * err, (chk.value, err)
    assert "model_substitution" in sol.certificate["accuracy"].note
    assert sol.certificate["accuracy"].value >= chk.value
