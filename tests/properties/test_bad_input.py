"""API-level bad input: System, chain, Friction/Contact and solve raise mshbm.InputError whose
``key`` names the offending key, before any expensive work."""
import numpy as np
import pytest
import scipy.sparse as sp

import mshbm
from mshbm import Contact, Friction, InputError, System, chain

OMEGA = np.pi / 5
I2 = np.eye(2)
K2 = np.array([[2.0, -1.0], [-1.0, 1.0]])
F2 = np.array([[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]])


def key_of(fn, *args, **kwargs):
    with pytest.raises(InputError) as info:
        fn(*args, **kwargs)
    assert isinstance(info.value, ValueError)  # InputError is a ValueError
    assert str(info.value).startswith(info.value.key + ": ")
    return info.value.key


def small():
    return chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}],
                 elements=[Friction(0, 0.5, 1.0)])


# ----------------------------------------------------------------------------- System matrices
@pytest.mark.parametrize("M, C, K, key", [
    (np.ones((2, 3)), I2, K2, "M"),                         # non-square
    (np.ones(3), I2, K2, "M"),                              # not 2-D
    (np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 0)), "M"),
    (I2, np.eye(3), K2, "C"),                               # mismatched
    (I2, I2, np.ones((2, 3)), "K"),                         # non-square
    (I2, I2, np.eye(3), "K"),                               # mismatched
    (np.array([[1.0, 0.5], [0.0, 1.0]]), I2, K2, "M"),     # non-symmetric
    (np.array([[1.0, 2.0], [2.0, 1.0]]), I2, K2, "M"),     # indefinite
    (np.array([[0.0, 0.0], [0.0, 1.0]]), I2, K2, "M"),     # singular
    (-I2, I2, K2, "M"),                                     # negative definite
    (np.array([[1.0, np.nan], [np.nan, 1.0]]), I2, K2, "M"),
    (I2, np.array([[np.inf, 0.0], [0.0, 1.0]]), K2, "C"),
    (I2, I2, np.array([[2.0, -1.0], [-1.0, np.nan]]), "K"),
    ([["a", 0], [0, 1]], I2, K2, "M"),                      # not numeric
    (sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]])), I2, K2, "M"),   # sparse indefinite
    (sp.diags([1.0, -1.0]).tocsr(), I2, K2, "M"),                        # sparse, negative diagonal
    (I2, sp.csr_matrix(np.eye(3)), K2, "C"),
    (I2, I2, sp.csr_matrix(np.array([[np.nan, 0.0], [0.0, 1.0]])), "K"),
    (I2, np.array([[0.1, 0.3], [-0.3, 0.1]]), K2, "C"),    # gyroscopic
    (I2, I2, np.array([[2.0, -1.0], [-0.9, 1.0]]), "K"),   # circulatory
    (I2, sp.csr_matrix(np.array([[0.1, 0.3], [-0.3, 0.1]])), K2, "C"),
    (I2, I2, sp.csr_matrix(np.array([[2.0, -1.0], [-1.0 + 1e-8, 1.0]])), "K"),
], ids=["M-nonsquare", "M-1d", "M-empty", "C-mismatch", "K-nonsquare", "K-mismatch", "M-nonsymmetric",
        "M-indefinite", "M-singular", "M-negative", "M-nan", "C-inf", "K-nan", "M-string",
        "M-sparse-indefinite", "M-sparse-negative", "C-sparse-mismatch", "K-sparse-nan",
        "C-nonsymmetric", "K-nonsymmetric", "C-sparse-nonsymmetric", "K-sparse-nonsymmetric"])
def test_system_matrices(M, C, K, key):
    assert key_of(System, M, C, K, F2) == key


@pytest.mark.parametrize("f_hat", [
    np.array([[0.0, np.nan], [0.0, 1.0], [0.0, 0.0]]),
    np.array([[0.0, 0.0], [0.0, np.inf], [0.0, 0.0]]),
    np.zeros((2, 2)),            # even number of rows
    np.zeros((3, 3)),            # wrong number of DOFs
    np.zeros(5),                 # 1-D of wrong length
], ids=["nan", "inf", "even-rows", "wrong-n", "1d-wrong-length"])
def test_system_forcing(f_hat):
    assert key_of(System, I2, I2, K2, f_hat) == "forcing"


@pytest.mark.parametrize("element, key", [
    (Friction(2, 0.5, 1.0), "friction.dof"),
    (Contact(5, 0.1), "contact.dof"),
], ids=["friction", "contact"])
def test_system_element_dof_out_of_range(element, key):
    assert key_of(System, I2, I2, K2, F2, [element]) == key


def test_system_rejects_foreign_elements_and_duplicates():
    assert key_of(System, I2, I2, K2, F2, ["friction"]) == "elements[0]"
    assert key_of(System, I2, I2, K2, F2, [Friction(0, 0.5, 1.0), Friction(0, 0.2, 1.0)]) == "friction.dof"


# ----------------------------------------------------------------------------- elements
@pytest.mark.parametrize("kwargs, key", [
    (dict(dof=0, mu=-0.1, normal_force=1.0), "friction.mu"),
    (dict(dof=0, mu=0.5, normal_force=-1.0), "friction.normal_force"),
    (dict(dof=0, mu=np.nan, normal_force=1.0), "friction.mu"),
    (dict(dof=0, mu=0.5, normal_force=np.inf), "friction.normal_force"),
    (dict(dof=0, mu="0.5", normal_force=1.0), "friction.mu"),
    (dict(dof=0, mu=True, normal_force=1.0), "friction.mu"),
    (dict(dof=0, mu=0.5, normal_force=1.0, smoothing=0.0), "friction.smoothing"),
    (dict(dof=0, mu=0.5, normal_force=1.0, smoothing=-800.0), "friction.smoothing"),
    (dict(dof=0.5, mu=0.5, normal_force=1.0), "friction.dof"),
    (dict(dof="0", mu=0.5, normal_force=1.0), "friction.dof"),
])
def test_friction(kwargs, key):
    assert key_of(Friction, **kwargs) == key


@pytest.mark.parametrize("kwargs, key", [
    (dict(dof=0, gap=-0.1), "contact.gap"),
    (dict(dof=0, gap=np.nan), "contact.gap"),
    (dict(dof=0, gap=0.1, restitution=1.5), "contact.restitution"),
    (dict(dof=0, gap=0.1, restitution=-0.1), "contact.restitution"),
    (dict(dof=0, gap=0.1, restitution=np.nan), "contact.restitution"),
    (dict(dof=0, gap=0.1, penalty_stiffness=0.0), "contact.penalty_stiffness"),
    (dict(dof=0, gap=0.1, penalty_stiffness=np.inf), "contact.penalty_stiffness"),
    (dict(dof=0, gap=0.1, penalty_damping=-1.0), "contact.penalty_damping"),
    (dict(dof=None, gap=0.1), "contact.dof"),
])
def test_contact(kwargs, key):
    assert key_of(Contact, **kwargs) == key


def test_valid_edge_values_accepted():
    assert Contact(0, 0.0, 0.0).restitution == 0.0      # zero gap, plastic impact
    assert Contact(0, 0.0, 1.0).restitution == 1.0
    assert Friction(0, 0.0, 0.0).bound == 0.0
    assert chain([1.0], 0.0).n == 1                     # zero stiffness is allowed


# ----------------------------------------------------------------------------- chain
@pytest.mark.parametrize("kwargs, key", [
    (dict(masses=[1.0, 0.0], stiffness=1.0), "masses[1]"),
    (dict(masses=[-1.0, 1.0], stiffness=1.0), "masses[0]"),
    (dict(masses=[1.0, np.nan], stiffness=1.0), "masses[1]"),
    (dict(masses=[1.0, np.inf], stiffness=1.0), "masses[1]"),
    (dict(masses=[1.0, "1"], stiffness=1.0), "masses[1]"),
    (dict(masses=3.0, stiffness=1.0), "masses"),
    (dict(masses=[], stiffness=1.0), "masses"),
    (dict(masses=[1.0, 1.0], stiffness=[1.0, -1.0]), "stiffness[1]"),
    (dict(masses=[1.0, 1.0], stiffness=[1.0, np.nan]), "stiffness[1]"),
    (dict(masses=[1.0, 1.0], stiffness=[1.0]), "stiffness"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, damping=[0.0, -0.3]), "damping[1]"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, damping=[0.0, 0.1, 0.2]), "damping"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[{"dof": 2, "amplitude": 1.0}]), "forcing[0].dof"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[{"dof": -1, "amplitude": 1.0}]), "forcing[0].dof"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[{"amplitude": 1.0}]), "forcing[0].dof"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[{"dof": 0, "amplitude": np.nan}]), "forcing[0].amplitude"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[{"dof": 0, "sin": np.inf}]), "forcing[0].sin"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[{"dof": 0, "constant": "1"}]), "forcing[0].constant"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[{"dof": 0, "harmonic": 0}]), "forcing[0].harmonic"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[{"dof": 0, "phase": 1.0}]), "forcing[0].phase"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, forcing=[5.0]), "forcing[0]"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, elements=[Friction(3, 0.5, 1.0)]), "friction.dof"),
    (dict(masses=[1.0, 1.0], stiffness=1.0, elements=[Contact(2, 0.1)]), "contact.dof"),
])
def test_chain(kwargs, key):
    assert key_of(chain, **kwargs) == key


def test_chain_sparse_same_checks():
    assert key_of(chain, [1.0] * 300, [1.0] * 299 + [-1.0]) == "stiffness[299]"
    assert key_of(chain, [1.0] * 300, 1.0, elements=[Friction(300, 0.5, 1.0)]) == "friction.dof"


# ----------------------------------------------------------------------------- solve
@pytest.mark.parametrize("omega", [0.0, -1.0, np.nan, np.inf, -np.inf, "1.0", None, True],
                         ids=["zero", "negative", "nan", "inf", "-inf", "string", "none", "bool"])
def test_solve_omega(omega):
    assert key_of(mshbm.solve, small(), omega, "mshbm", harmonics=1, steps=256) == "omega"


@pytest.mark.parametrize("method, options, key", [
    ("mshbm", dict(harmonics=0), "harmonics"),
    ("hbm", dict(harmonics=-3), "harmonics"),
    ("mshbm", dict(harmonics=2.5), "harmonics"),
    ("mshbm", dict(harmonics=True), "harmonics"),
    ("mshbm", dict(harmonics=10 ** 6), "harmonics"),
    ("mshbm", dict(harmonics=5, steps=10), "steps"),       # too few for 5 harmonics
    ("shooting", dict(steps=4), "steps"),
    ("hbm", dict(steps=0), "steps"),
    ("mshbm", dict(steps="many"), "steps"),
    ("mshbm", dict(steps=1 << 30), "steps"),
    ("newton", dict(), "method"),
    ("MSHBM", dict(), "method"),
    ("mshbm", dict(harmonic=3), "harmonic"),              # typo: unknown option
    ("hbm", dict(theta=0.5), "theta"),                    # not an HBM option
    ("shooting", dict(partition=[0]), "partition"),       # not a shooting option
    ("mshbm", dict(theta=0.3), "theta"),
    ("mshbm", dict(jacobian="numeric"), "jacobian"),
    ("mshbm", dict(tol=0.0), "tol"),
    ("mshbm", dict(tol=np.nan), "tol"),
    ("mshbm", dict(max_iter=-1), "max_iter"),
    ("mshbm", dict(partition=[0, 5]), "partition"),
    ("mshbm", dict(partition=[1]), "partition"),          # misses the friction DOF
    ("mshbm", dict(partition=[0, 0]), "partition"),
])
def test_solve_options(method, options, key):
    opts = {"harmonics": 1, "steps": 256, **options}
    assert key_of(mshbm.solve, small(), OMEGA, method, **opts) == key


def test_solve_system_type():
    assert key_of(mshbm.solve, "system", OMEGA) == "system"


def test_build_problem_validates_like_solve():
    assert key_of(mshbm.build_problem, small(), -1.0) == "omega"
    assert key_of(mshbm.build_problem, small(), OMEGA, "mshbm", harmonics=0) == "harmonics"


def test_valid_small_solve_still_works():
    # 512 steps: certified at the default accuracy (256: error 2.9e-3 against the event-driven flow, estimate
    # 1.16e-2; 512: 2.8e-3, 6.9e-3)
    sol = mshbm.solve(small(), OMEGA, "mshbm", harmonics=1, steps=512)
    assert sol.success and np.all(np.isfinite(sol.amplitude))


def test_linear_system_with_mixed_method_names_method():
    import mshbm
    from mshbm import chain
    s = chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}])
    for method in ("mshbm", "mshbm-intermediate"):
        with pytest.raises(mshbm.InputError) as exc:
            mshbm.solve(s, 1.0, method)
        assert exc.value.key == "method"


@pytest.mark.parametrize("key", ["condense", "line_search", "continuation"])
def test_boolean_options_reject_strings(key):
    import mshbm
    from mshbm import chain
    s = chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}])
    with pytest.raises(mshbm.InputError) as exc:
        mshbm.solve(s, 1.0, "hbm", **{key: "no"})
    assert exc.value.key == key


def test_forcing_harmonic_is_capped():
    import mshbm
    from mshbm import chain
    with pytest.raises(mshbm.InputError) as exc:
        chain([1.0], 1.0, 0.0, forcing=[{"dof": 0, "amplitude": 1.0, "harmonic": 10 ** 9}])
    assert exc.value.key == "forcing[0].harmonic"


def test_singular_block_is_named_in_the_message():
    """Exactly on a resonance of the eliminated subsystem of an explicit partition the error names that block
    (the default partition keeps the resonant DOFs instead: tests/unit/test_resonant_condensation.py)."""
    import mshbm
    from mshbm import Friction, chain
    s = chain([1.0, 1.0, 1.0], 1.0, 0.0, forcing=[{"dof": 2, "amplitude": 1.0}], elements=[Friction(0, 0.8, 5.0)])
    K_LL = np.array([[2.0, -1.0], [-1.0, 1.0]])  # masses 2-3 with mass 1 held
    w = float(np.sqrt(np.linalg.eigvalsh(K_LL)[0]))
    with pytest.raises(mshbm.InputError) as exc:
        mshbm.solve(s, w, "mshbm", harmonics=1, steps=256, partition=[0])
    assert exc.value.key == "omega" and "H_LL is singular at harmonic k=1" in exc.value.problem


@pytest.mark.parametrize("method", ["shooting", "mshbm"])
@pytest.mark.parametrize("integrator", ["moreau", "event"])
def test_friction_and_contact_on_one_dof_is_refused_by_time_integration(method, integrator):
    """A stop and a slider on the same DOF: their forces along it are not unique while the contact is closed
    (Moreau-Jean's step Jacobian is singular: it raised LinAlgError / ZeroDivisionError; the event flow ended in
    'overflow').  Refused naming ``elements``; a polynomial spring on that DOF is no constraint and is fine."""
    import mshbm
    from mshbm import Contact, Friction, InputError, Polynomial, System

    f = np.zeros((3, 1))
    f[1, 0] = 1.0
    s = System(np.eye(1), 0.1 * np.eye(1), np.eye(1), f, [Contact(0, 0.3, 0.5), Friction(0, 1.0, 0.2)])
    with pytest.raises(InputError) as e:
        mshbm.solve(s, 0.5, method, integrator=integrator, accuracy=False)
    assert e.value.key == "elements" and "DOF 0 carries contact and friction" in e.value.problem
    ok = System(np.eye(1), 0.1 * np.eye(1), np.eye(1), f, [Contact(0, 0.3, 0.5), Polynomial(0, {3: 0.1})])
    from mshbm.elements.base import dependent_directions
    assert dependent_directions(ok.elements) is None
