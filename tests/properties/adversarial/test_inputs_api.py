"""Adversarial input through the Python API: forcing the method cannot represent,
bad partitions, bad guesses, free-free structures, the float range, and no RuntimeWarnings.

Each case asserts an InputError naming the key, or a correct answer against an exact value
(linear systems: the closed-form steady state, computed here independently of mshbm)."""
import warnings

import numpy as np
import pytest

import mshbm
from mshbm import Contact, Friction, InputError, System, chain

METHODS = ("hbm", "mshbm", "mshbm-intermediate", "shooting")


def key_of(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning on the way is a failure too
        with pytest.raises(InputError) as info:
            fn(*args, **kwargs)
    return info.value.key, info.value.problem


def exact_linear(M, C, K, f_hat, omega):
    """Closed-form steady state q_hat (rows [q0, qc_1, qs_1, ...]) of M q'' + C q' + K q = f(t)."""
    f_hat = np.asarray(f_hat, float)
    out = np.zeros_like(f_hat)
    out[0] = np.linalg.solve(K, f_hat[0])
    for k in range(1, (f_hat.shape[0] - 1) // 2 + 1):
        H = K - (k * omega) ** 2 * M + 1j * k * omega * C
        Q = np.linalg.solve(H, f_hat[2 * k - 1] - 1j * f_hat[2 * k])
        out[2 * k - 1], out[2 * k] = Q.real, -Q.imag
    return out


def chain3(forcing, elements=(Friction(0, 0.5, 1.0),), c=0.1):
    return chain([1.0, 1.0, 1.0], 1.0, c, forcing=forcing, elements=list(elements))


def opts(method, **kw):
    base = {"harmonics": 2, "steps": 256}
    base.update(kw)
    return base


# ----------------------------------------------------------------------------- forcing
@pytest.mark.parametrize("method, partition, dof, key", [
    ("hbm", None, 2, "harmonics"),                       # harmonic 3 > harmonics=2 (base: all zeros, success)
    ("hbm", None, 0, "harmonics"),                       # ... also on the element DOF
    ("mshbm", None, 2, "harmonics"),                     # on the linear (harmonic) subsystem
    ("mshbm-intermediate", [[0], [1]], 2, "harmonics"),  # on subsystem 3
    ("mshbm-intermediate", [[0], [1]], 1, "harmonics"),  # on subsystem 2
])
def test_forcing_above_harmonics_is_an_input_error(method, partition, dof, key):
    s = chain3([{"dof": dof, "amplitude": 1.0, "harmonic": 3}])
    kw = opts(method) if partition is None else opts(method, partition=partition)
    k, problem = key_of(mshbm.solve, s, 0.7, method, **kw)
    assert k == key and "harmonic 3" in problem


def test_sine_only_forcing_above_harmonics_is_an_input_error():
    s = chain3([{"dof": 2, "sin": 1.0, "harmonic": 4}])
    assert key_of(mshbm.solve, s, 0.7, "hbm", harmonics=3)[0] == "harmonics"


@pytest.mark.parametrize("method, kw", [
    ("shooting", dict(steps=8)),                         # harmonic 4 needs steps > 8 (aliasing)
    ("mshbm", dict(harmonics=2, steps=8)),               # on the time-stepped DOF 0
    ("mshbm-intermediate", dict(harmonics=2, steps=8, partition=[[0], [1]])),
])
def test_forcing_aliased_by_steps_is_an_input_error(method, kw):
    s = chain3([{"dof": 0, "amplitude": 1.0, "harmonic": 4}])
    k, problem = key_of(mshbm.solve, s, 0.7, method, **kw)
    assert k == "steps" and "aliasing" in problem


def test_forcing_harmonics_are_included_exactly_by_hbm():
    """HBM with harmonics >= the forcing's: the linear steady state, coefficient by coefficient."""
    f = [{"dof": 2, "amplitude": 1.0, "harmonic": 3}, {"dof": 1, "sin": 0.5, "harmonic": 2},
         {"dof": 0, "constant": 0.3}]
    s = chain3(f, elements=())
    sol = mshbm.solve(s, 0.7, "hbm", harmonics=3)
    ref = exact_linear(s.dense("M"), s.dense("C"), s.dense("K"), s.f_hat, 0.7)
    assert sol.success
    np.testing.assert_allclose(sol.q_hat, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_forcing_above_harmonics_on_time_stepped_dof_is_included_by_mshbm():
    """MS-HBM integrates its DOFs in time: forcing above n_h there is represented (up to O(h^2))."""
    s = chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.0, "harmonic": 3}],
              elements=[Friction(0, 0.0, 0.0)])               # mu F_N = 0: a linear oscillator
    sol = mshbm.solve(s, 0.7, "mshbm", harmonics=1, steps=4096)
    H = 1.0 - (3 * 0.7) ** 2 + 1j * 3 * 0.7 * 0.1
    assert sol.success
    assert sol.amplitude[0] == pytest.approx(1.0 / abs(H), rel=1e-5)


# ----------------------------------------------------------------------------- partitions
@pytest.mark.parametrize("method, partition", [
    ("mshbm-intermediate", [[0], [1, 1]]),      # base: halves DOF 1's amplitude, success
    ("mshbm-intermediate", [[0, 0], [1]]),      # base: LinAlgError
    ("mshbm-intermediate", [[0], [0, 1]]),      # overlapping subsystems
    ("mshbm-intermediate", [[0], [9]]),         # out of range
    ("mshbm-intermediate", [[0], [-1]]),
    ("mshbm-intermediate", [[1], [2]]),         # element DOF 0 missing from subsystem 1
    ("mshbm-intermediate", [[], [1]]),          # empty subsystem 1
    ("mshbm-intermediate", [[0], []]),          # empty subsystem 2
    ("mshbm-intermediate", [0, 1]),             # flat: wrong nesting (base: read as ([0], [1]))
    ("mshbm-intermediate", [[0], [1], [2]]),    # three subsystems
    ("mshbm-intermediate", [[0], [[1]]]),       # nested too deep
    ("mshbm-intermediate", [[0.5], [1]]),       # not an integer (base: truncated to 0)
    ("mshbm-intermediate", [[True], [1]]),      # a boolean is not a DOF
    ("mshbm-intermediate", "0,1"),
    ("mshbm", [[0], [1]]),                      # nested list for the flat method (base: flattened)
    ("mshbm", [0, 0]),
    ("mshbm", [1]),                             # element DOF missing
    ("mshbm", []),
    ("mshbm", [0, 3]),
    ("hbm", [0, 0]),
    ("hbm", [0.5]),
    ("hbm", [True]),
])
def test_bad_partition_is_an_input_error(method, partition):
    s = chain3([{"dof": 2, "amplitude": 1.0}])
    assert key_of(mshbm.solve, s, 0.7, method, harmonics=2, steps=128, partition=partition)[0] == "partition"


def test_numpy_partition_pair_is_accepted_and_exact_on_a_linear_subsystem():
    """A valid (N1, N2) as numpy arrays: the harmonic DOFs of a linear system with mu F_N = 0 are
    the closed-form steady state up to the O(h^2) coupling of the time-stepped DOF."""
    s = chain3([{"dof": 2, "amplitude": 1.0}], elements=(Friction(0, 0.0, 0.0),))
    sol = mshbm.solve(s, 0.7, "mshbm-intermediate", harmonics=2, steps=4096,
                      partition=(np.array([0]), np.array([1])))
    ref = exact_linear(s.dense("M"), s.dense("C"), s.dense("K"), s.forcing_hat(2), 0.7)
    amp = np.hypot(ref[1], ref[2])
    assert sol.success
    np.testing.assert_allclose(sol.amplitude, amp, rtol=1e-5)


# ----------------------------------------------------------------------------- guesses
def linear3():
    return chain3([{"dof": 2, "amplitude": 1.0}], elements=())


@pytest.mark.parametrize("guess, key", [
    ({"q_hat": np.zeros((5, 4))}, "guess.q_hat"),             # wrong number of DOFs
    ({"q_hat": np.zeros(3)}, "guess.q_hat"),                  # 1-D
    ({"q_hat": np.zeros((4, 3))}, "guess.q_hat"),             # even number of rows
    ({"q_hat": np.zeros((5, 3)), "q0": np.zeros(4)}, "guess.q0"),        # base: ValueError (shooting)
    ({"q_hat": np.zeros((5, 3)), "q0": np.zeros((2, 3))}, "guess.q0"),   # base: ValueError
    ({"q_hat": np.zeros((5, 3)), "u0": np.zeros(2)}, "guess.u0"),
    ({"q_hat": np.full((5, 3), np.nan)}, "guess.q_hat"),
    ({"q_hat": np.zeros((5, 3)), "q0": [0.0, np.inf, 0.0]}, "guess.q0"),
    ({"q_hat": np.full((5, 3), 1e300)}, "guess.q_hat"),       # absurd size (base: overflow warnings)
    ({"q_hat": np.zeros((5, 3)), "u0": [1e200, 0.0, 0.0]}, "guess.u0"),
    ({"q_hat": [["a"] * 3] * 5}, "guess.q_hat"),               # base: bare ValueError
    ({"q_hat": "zero"}, "guess.q_hat"),
    ({"q_hat": np.zeros((5, 3)) + 1j}, "guess.q_hat"),        # base: imaginary part dropped silently
    ({"q_hat": [[0.0, 0.0, 0.0], [0.0, 0.0]]}, "guess.q_hat"),  # ragged
    ({"q_hat": np.zeros((5, 3)), "qhat": 1}, "guess.qhat"),    # misspelt key, silently ignored before
    ({"q0": np.zeros(3)}, "guess"),
    ("foo", "guess"),
    (np.zeros(3), "guess"),
    (5, "guess"),
])
@pytest.mark.parametrize("method", ["hbm", "shooting"])
def test_bad_guess_is_an_input_error(guess, key, method):
    assert key_of(mshbm.solve, linear3(), 0.7, method, harmonics=2, steps=64, guess=guess)[0] == key


def test_guess_from_another_system_size_is_an_input_error():
    other = mshbm.solve(chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}]), 0.7, "hbm",
                        harmonics=2)
    for method in ("hbm", "shooting"):
        assert key_of(mshbm.solve, linear3(), 0.7, method, harmonics=2, guess=other)[0] == "guess"


def linear3_element():
    """The 3-mass chain with a friction element of bound mu F_N = 0: linear, but HBM has unknowns."""
    return chain3([{"dof": 2, "amplitude": 1.0}], elements=(Friction(0, 0.0, 0.0),))


@pytest.mark.parametrize("make_guess", [
    lambda s: mshbm.solve(s, 0.7, "shooting", harmonics=6, steps=64),     # other method, more harmonics
    lambda s: mshbm.solve(s, 0.9, "hbm", harmonics=1),                     # other frequency, fewer
    lambda s: {"q_hat": 1e3 * np.ones((5, 3))},                            # far away, but finite
    lambda s: {"q_hat": np.zeros((1, 3)), "q0": [1.0, 2.0, 3.0], "u0": [0.0, 0.0, -1.0]},
    lambda s: "zero",
], ids=["shooting-solution", "other-omega", "far", "q0-u0", "zero"])
def test_valid_guesses_reach_the_exact_linear_answer(make_guess):
    s = linear3_element()
    sol = mshbm.solve(s, 0.7, "hbm", harmonics=2, guess=make_guess(s))
    ref = exact_linear(s.dense("M"), s.dense("C"), s.dense("K"), s.forcing_hat(2), 0.7)
    assert sol.success
    np.testing.assert_allclose(sol.q_hat, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


@pytest.mark.parametrize("size", [1e20, 1e140])
@pytest.mark.parametrize("method", ["hbm", "mshbm", "shooting"])
def test_huge_but_finite_guess_gives_no_false_success(method, size):
    s = linear3_element()
    sol = mshbm.solve(s, 0.7, method, harmonics=2, steps=4096, guess={"q_hat": np.full((5, 3), size)})
    ref = exact_linear(s.dense("M"), s.dense("C"), s.dense("K"), s.forcing_hat(2), 0.7)
    amp = np.hypot(ref[1], ref[2])
    assert not sol.success or np.allclose(sol.amplitude, amp, rtol=1e-4)


# ----------------------------------------------------------------------------- free-free structures
KFF = np.array([[1.0, -1.0], [-1.0, 1.0]])


@pytest.mark.parametrize("method", ["hbm", "shooting"])
def test_free_free_without_elements_is_named(method):
    s = System(np.eye(2), 0.1 * np.eye(2), KFF, [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    key, problem = key_of(mshbm.solve, s, 1.0, method, harmonics=2, steps=128)
    assert key == "K" and "free-free" in problem          # base: "omega: ... move omega", or success


def test_free_free_with_partition_is_named():
    s = System(np.eye(2), 0.1 * np.eye(2), KFF, [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    key, problem = key_of(mshbm.solve, s, 1.0, "mshbm", harmonics=2, steps=128, partition=[0])
    assert key == "K" and "free-free" in problem


@pytest.mark.parametrize("method", METHODS)
def test_free_free_with_friction_is_named(method):
    s = System(np.eye(2), 0.1 * np.eye(2), KFF, [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], [Friction(0, 0.5, 0.1)])
    key, problem = key_of(mshbm.solve, s, 1.0, method, harmonics=2, steps=128)
    assert key == "K" and "free-free" in problem and "friction" in problem


def test_free_free_held_by_a_contact_is_solved_exactly():
    """A contact may ground a free-free structure: pressed by a constant force that the harmonic
    part never overcomes, DOF 0 rests on the stop (q_0 = 0) and DOF 1 is a grounded oscillator."""
    f_hat = [[0.0, 10.0], [0.0, 1.0], [0.0, 0.0]]
    s = System(np.eye(2), 0.1 * np.eye(2), KFF, f_hat, [Contact(0, 0.0, 0.0)])
    sol = mshbm.solve(s, 0.5, "shooting", steps=2048)
    H = 1.0 - 0.25 + 1j * 0.5 * 0.1      # m=1, k=1 to the clamped DOF 0, c=0.1 to ground
    assert sol.success
    assert sol.amplitude[0] == pytest.approx(0.0, abs=1e-9)
    assert sol.amplitude[1] == pytest.approx(1.0 / abs(H), rel=1e-5)


# ----------------------------------------------------------------------------- float range
@pytest.mark.parametrize("build, omega, key", [
    (lambda: chain([1e200, 1e200], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}],
                   elements=[Friction(0, 0.5, 1.0)]), 1e60, "omega"),     # (k omega)^2 M overflows
    (lambda: chain([1.0, 1.0, 1.0], 1e300, 0.1, forcing=[{"dof": 2, "amplitude": 1.0}],
                   elements=[Friction(0, 0.5, 1.0)]), 1.0, "K"),
    (lambda: chain([1.0, 1.0, 1.0], 1.0, 1e300, forcing=[{"dof": 2, "amplitude": 1.0}],
                   elements=[Friction(0, 0.5, 1.0)]), 1e10, "omega"),     # base: "H_LL is singular"
    (lambda: chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1e300}],
                   elements=[Friction(0, 0.5, 1.0)]), 1.0, "forcing"),
    (lambda: chain([1.0, 1.0], 1.0, 0.1, forcing=[{"dof": 1, "amplitude": 1.0}],
                   elements=[Friction(0, 0.5, 1e300)]), 1.0, "friction.normal_force"),
])
@pytest.mark.parametrize("method", ["hbm", "mshbm", "shooting"])
def test_overflow_is_named_not_singular(build, omega, key, method):
    k, problem = key_of(mshbm.solve, build(), omega, method, harmonics=2, steps=128)
    assert k == key and "float range" in problem and "singular" not in problem


def test_chain_with_overflowing_springs_names_K_without_warnings():
    assert key_of(chain, [1.0, 1.0, 1.0], [1.0, 1e308, 1e308])[0] == "K"


@pytest.mark.parametrize("method", ["hbm", "mshbm", "shooting"])
def test_no_runtime_warning_from_a_huge_guess(method):
    """Guesses up to the limit (1e150) run without a single RuntimeWarning (turned into errors here)
    and give finite amplitudes; beyond it they are refused (see test_bad_guess_is_an_input_error)."""
    s = linear3_element()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = mshbm.solve(s, 0.7, method, harmonics=2, steps=256, guess={"q_hat": np.full((5, 3), 1e149)})
        amp = sol.amplitude
    assert np.all(np.isfinite(amp))


@pytest.mark.parametrize("scale", [1e160, 1e240])
@pytest.mark.parametrize("method", ["hbm", "mshbm", "shooting"])
def test_huge_units_give_the_same_answer_or_name_overflow(method, scale):
    """M, C, K, f and mu F_N of the friction chain times ``scale`` (within the float limit): the
    displacements are those of scale 1, or the solve fails with a message naming overflow -- never a
    RuntimeWarning, never "singular"."""
    def build(sc):
        return chain([sc, sc, sc], sc, 0.1 * sc, forcing=[{"dof": 2, "amplitude": 5 * sc}],
                     elements=[Friction(0, 0.8, 1.0 * sc)])
    ref = mshbm.solve(build(1.0), 0.6, method, harmonics=3, steps=512)
    assert ref.success
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = mshbm.solve(build(scale), 0.6, method, harmonics=3, steps=512)
    if sol.success:
        np.testing.assert_allclose(sol.amplitude, ref.amplitude, rtol=1e-8)
    else:
        assert sol.message.startswith("overflow") and "singular" not in sol.message


@pytest.mark.parametrize("method", ["mshbm", "mshbm-intermediate"])
def test_continuation_path_checks_inputs_too(method):
    s = chain3([{"dof": 2, "amplitude": 1.0, "harmonic": 3}])
    assert key_of(mshbm.solve, s, 0.7, method, harmonics=2, steps=128, continuation=True)[0] == "harmonics"


def test_failed_solution_with_nan_is_refused_as_guess():
    import dataclasses

    good = mshbm.solve(linear3_element(), 0.7, "hbm", harmonics=2)
    bad = dataclasses.replace(good, q_hat=np.full_like(good.q_hat, np.nan))
    assert key_of(mshbm.solve, linear3_element(), 0.7, "hbm", harmonics=2, guess=bad)[0] == "guess"
