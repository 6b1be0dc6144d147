"""Resonances of the condensed subsystem and the degenerate intermediate partition (cases of the stress suite).

* ``H_LL(k omega)`` singular (``k omega`` an eigenfrequency of the linear subsystem with the nonlinear DOFs
  clamped) although the full problem is well posed: HBM keeps the resonant DOFs as harmonic unknowns, MS-HBM
  integrates them with ``N``; the answer is checked against full shooting (which condenses nothing).
* ``H_33`` singular for the intermediate variant: the resonant DOFs join subsystem 2; the answer equals
  the standard MS-HBM's (the same truncated equations).
* An undamped mode untouched by any element and forced at its eigenfrequency: no periodic solution exists
  (proved by projecting the equations of motion on the mode), and the error says so.
* An empty default subsystem 2: the intermediate variant is the standard MS-HBM, solved as such.
"""
from __future__ import annotations

import numpy as np
import pytest

import mshbm
from tests import discretised
from mshbm import Friction, chain
from mshbm.condensation import condense_around_resonances, resonant_modes

# three unit masses, unit springs, no damping, friction on mass 0, forcing on mass 2 (examples/friction3.yaml)
K_LL = np.array([[2.0, -1.0], [-1.0, 1.0]])  # masses 1-2 with mass 0 held
W_L = np.sqrt(np.linalg.eigvalsh(K_LL))  # 0.618..., 1.618... rad/s


def friction3():
    return chain([1.0, 1.0, 1.0], 1.0, 0.0, forcing=[{"dof": 2, "amplitude": 5.0}],
                 elements=[Friction(0, 0.8, 5.0, smoothing=800.0)])


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


@pytest.fixture(scope="module")
def shooting_at_resonance():
    sol = discretised.solve(friction3(), W_L[0], "shooting", steps=8192)
    assert sol.success
    return sol


def test_condensation_moves_the_null_space_support():
    """At omega = W_L[0] the null vector of H_LL has both linear DOFs: both move to the kept set, and the
    resulting condensation (nothing left to condense) is regular."""
    s = friction3()
    cond, keep, elim, moved = condense_around_resonances(s, W_L[0], 3, [0], [1, 2])
    assert keep.tolist() == [0, 1, 2] and elim.size == 0
    assert moved == [{"k": 1, "k_omega": pytest.approx(W_L[0], rel=1e-15), "dofs": [1, 2]}]
    # off resonance nothing moves
    _, keep, elim, moved = condense_around_resonances(s, 0.9, 3, [0], [1, 2])
    assert keep.tolist() == [0] and elim.tolist() == [1, 2] and moved == []


def test_mshbm_at_resonance_of_the_linear_subsystem(shooting_at_resonance):
    """Before: InputError "H_LL is singular at harmonic k=1".  Now the resonant DOFs are time-integrated;
    amplitudes agree with full shooting (N = 8192) to 1e-4 relative (measured 2e-5: the step error)."""
    sol = discretised.solve(friction3(), W_L[0], "mshbm", harmonics=5, steps=2048)
    assert sol.success, sol.message
    assert sol.partition.time.tolist() == [0, 1, 2]
    assert "moved to the time-integrated subsystem N" in sol.message
    assert sol.info["notes"] and "[1, 2]" in sol.info["notes"][0]
    assert _rel(sol.amplitude, shooting_at_resonance.amplitude) < 1e-4


def test_hbm_at_resonance_of_the_linear_subsystem(shooting_at_resonance):
    """HBM keeps the resonant DOFs as harmonic unknowns; with the regularised law (kappa = 800) it agrees
    with set-valued shooting to the stress suite's HBM tolerance of 15 % (measured 3.5 %)."""
    sol = discretised.solve(friction3(), W_L[0], "hbm", harmonics=10)
    assert sol.success, sol.message
    assert sol.partition.harmonic.tolist() == [0, 1, 2] and sol.partition.condensed.size == 0
    assert "moved to the harmonic unknowns" in sol.message
    assert _rel(sol.amplitude, shooting_at_resonance.amplitude) < 0.15


def test_superharmonic_resonance_mshbm_matches_shooting():
    """omega = W_L[1] / 2: H_LL singular at harmonic k = 2 only."""
    s = friction3()
    w = W_L[1] / 2
    sol = discretised.solve(s, w, "mshbm", harmonics=5, steps=2048)
    ref = discretised.solve(s, w, "shooting", steps=8192)
    assert sol.success and ref.success
    assert "harmonic k=2" in sol.info["notes"][0]
    assert _rel(sol.amplitude, ref.amplitude) < 1e-3


def test_explicit_partition_keeps_the_error():
    """A partition given by the caller is not changed: the singular block is still an InputError."""
    with pytest.raises(mshbm.InputError) as exc:
        discretised.solve(friction3(), W_L[0], "mshbm", harmonics=1, steps=256, partition=[0])
    assert exc.value.key == "omega" and "H_LL is singular at harmonic k=1" in exc.value.problem


def test_intermediate_resonant_subsystem3_joins_subsystem2():
    """friction3 at omega = 1: default subsystems 1 = {0}, 2 = {1}, 3 = {2} with H_33 = 1 - omega^2 = 0.
    DOF 2 joins subsystem 2; the answer equals the standard MS-HBM's (the same truncated equations) to
    1e-10 relative."""
    s = friction3()
    a = discretised.solve(s, 1.0, "mshbm-intermediate", harmonics=5, steps=2048)
    b = discretised.solve(s, 1.0, "mshbm", harmonics=5, steps=2048)
    assert a.success and b.success, (a.message, b.message)
    assert a.partition.harmonic.tolist() == [1, 2] and a.partition.condensed.size == 0
    assert "H_33 singular at harmonic k=1" in a.info["notes"][0] and "subsystem 2" in a.message
    assert _rel(a.q_hat, b.q_hat) < 1e-10


def test_intermediate_empty_subsystem2_is_standard_mshbm():
    """A friction DOF coupled to nothing else (its own spring to ground; the forced chain beside it): the
    default subsystem 2 is empty, the intermediate variant is the standard MS-HBM and gives its answer."""
    M = np.eye(3)
    K = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    C = 0.05 * K
    f_hat = np.zeros((3, 3))
    f_hat[1, 0] = 1.0  # cos on the friction DOF
    f_hat[1, 2] = 2.0  # and on the chain
    s = mshbm.System(M, C, K, f_hat, [Friction(0, 0.5, 1.0)])
    a = discretised.solve(s, 0.8, "mshbm-intermediate", harmonics=5, steps=1024)
    b = discretised.solve(s, 0.8, "mshbm", harmonics=5, steps=1024)
    assert a.success and b.success, (a.message, b.message)
    assert a.method == "mshbm-intermediate"
    assert "solved as such" in a.message and "Section 3.2" in a.info["notes"][0]
    assert _rel(a.q_hat, b.q_hat) < 1e-12
    # the chain's response is the linear one (decoupled from the friction DOF), a closed form
    H = K[1:, 1:] - 0.8 ** 2 * M[1:, 1:] + 0.8j * C[1:, 1:]
    X = np.linalg.solve(H, np.array([0.0, 2.0]))
    assert a.amplitude[1:] == pytest.approx(np.abs(X), rel=1e-9)
    # an explicit partition with an empty subsystem 2 stays an error naming the key
    with pytest.raises(mshbm.InputError) as exc:
        discretised.solve(s, 0.8, "mshbm-intermediate", harmonics=5, steps=1024, partition=[[0], []])
    assert exc.value.key == "partition"


def _decoupled(forcing_on_mode):
    """Friction DOF 0 on its own spring; DOFs 1-2 an undamped chain no element touches (eigenfrequencies
    W_L), forced on DOF 2 (or not)."""
    M = np.eye(3)
    K = np.zeros((3, 3))
    K[0, 0] = 1.0
    K[1:, 1:] = K_LL
    C = np.zeros((3, 3))
    C[0, 0] = 0.1
    f_hat = np.zeros((3, 3))
    f_hat[1, 0] = 1.0
    if forcing_on_mode:
        f_hat[1, 2] = 1.0
    return mshbm.System(M, C, K, f_hat, [Friction(0, 0.5, 0.5)])


@pytest.mark.parametrize("method", ["mshbm", "hbm"])
def test_forced_undamped_mode_without_element_has_no_periodic_solution(method):
    """Projected on the mode v (H_k v = 0, v = 0 on the friction DOF) the k-th harmonic of the equations of
    motion reads 0 = v^T F_k != 0 for every periodic motion: the error says that none exists."""
    s = _decoupled(True)
    v = np.linalg.eigh(K_LL)[1][:, 0]
    assert abs(v @ np.array([0.0, 1.0])) > 0.1  # the forcing drives the mode
    with pytest.raises(mshbm.InputError) as exc:
        discretised.solve(s, W_L[0], method, harmonics=3, steps=256)
    assert exc.value.key == "omega"
    assert "no periodic solution exists" in exc.value.problem and "DOFs [1, 2]" in exc.value.problem


def test_unforced_undamped_mode_without_element_is_not_unique():
    s = _decoupled(False)
    modes = resonant_modes(s, W_L[0], 1, [0], [1, 2])
    assert modes["no_solution"] is None and "not unique" in modes["not_unique"]
    with pytest.raises(mshbm.InputError) as exc:
        discretised.solve(s, W_L[0], "mshbm", harmonics=3, steps=256)
    assert exc.value.key == "omega" and "not unique" in exc.value.problem
