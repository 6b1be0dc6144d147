"""The automatic Craig-Bampton reduction of a case file without ``reduce:`` (:meth:`mshbm.io.Case.solve`,
:func:`mshbm.reduction.auto_reduction`): a time-integrating method whose element DOFs are the nodes of a fine mesh
(local frequency ``sqrt(K_dd / M_dd)`` far above omega) solves the reduced model and reports on the mesh's DOFs;
``reduce: none`` solves the model as written (refused by the event flow); the paper's chains are never reduced."""
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import yaml

from mshbm import InputError
from mshbm.io import load_case
from mshbm.reduction import AUTO_STIFF_RATIO, craig_bampton

from test_reduction import blade

ROOT = Path(__file__).resolve().parents[2]


def _write_case(tmp_path, reduce=None):
    """The 40-element blade with a stop on its tip node (tests/unit/test_reduction.py) as .mtx files and a case
    file at w_1 (Rayleigh damping given as the matrix C)."""
    s, w1, tip = blade()
    for name in "MCK":
        scipy.io.mmwrite(str(tmp_path / f"{name}.mtx"), getattr(s, name))
    data = {"name": "blade", "M": "M.mtx", "C": "C.mtx", "K": "K.mtx", "omega": float(1.01 * w1),
            "forcing": [{"dof": int(tip), "amplitude": float(np.asarray(s.f_hat)[1, tip])}],
            "contact": {"dof": int(tip), "gap": 1e-3, "restitution": 0.7},
            "solver": {"method": "mshbm", "harmonics": 10, "steps": 1024}}
    if reduce is not None:
        data["reduce"] = reduce
    path = tmp_path / "blade.yaml"
    path.write_text(yaml.safe_dump(data))
    return path, s, w1, tip


def test_stop_on_a_mesh_node_is_solved_on_an_automatic_reduction(tmp_path):
    """Event shooting of the case as written: the tip node's own frequency is thousands of times w_1, so the
    case reduces itself onto the tip DOF and fixed-interface modes up to 20 n_H omega; the answer is certified,
    on the mesh's 80 DOFs, says so in its message and info, and equals the solve of the same reduction given
    explicitly (``reduce: {modes: m}``) to rounding; its reduction estimate is below the default accuracy."""
    path, s, w1, tip = _write_case(tmp_path)
    case = load_case(path)
    sol = case.solve("shooting", integrator="event", stability=False)
    assert sol.success, sol.message
    auto = sol.info["reduction"]
    assert auto["auto"]["stiffness_ratio"] > AUTO_STIFF_RATIO
    assert auto["boundary"] == [tip] and auto["n_full"] == s.n
    assert auto["highest_mode_rad_s"] >= auto["auto"]["cutoff_rad_s"]
    assert "automatic Craig-Bampton reduction" in sol.message
    assert np.asarray(sol.amplitude).shape == (s.n,)
    given = load_case(_write_case(tmp_path, {"method": "craig_bampton", "modes": auto["modes"]})[0])
    ref = given.solve("shooting", integrator="event", stability=False)
    assert ref.success, ref.message
    assert np.abs(np.asarray(sol.amplitude) - np.asarray(ref.amplitude)).max() <= 1e-9 * np.max(ref.amplitude)
    assert sol.info["accuracy"]["estimates"]["reduction"] < 1e-2


def test_mshbm_on_the_automatic_reduction_agrees_with_event_shooting(tmp_path):
    """Event MS-HBM (n_H = 10) of the same case as written: certified, within 0.5 % of event shooting's tip
    amplitude on the automatic reduction (the converged reference of tests/unit/test_beam_stop_points.py is within
    0.35 % of it)."""
    path, s, w1, tip = _write_case(tmp_path)
    case = load_case(path)
    sol = case.solve("mshbm", integrator="event", stability=False)
    ref = case.solve("shooting", integrator="event", stability=False)
    assert sol.success and ref.success, (sol.message, ref.message)
    assert sol.amplitude[tip] == pytest.approx(ref.amplitude[tip], rel=5e-3)


def test_reduce_none_solves_the_model_as_written(tmp_path):
    """``reduce: none``: no reduction; the event flow refuses the stiff tip node (its sub-step count)."""
    path, *_ = _write_case(tmp_path, "none")
    case = load_case(path)
    assert case.automatic_reduction("mshbm", {}) is None
    with pytest.raises(InputError, match="sub-steps"):
        case.solve("mshbm", integrator="event", stability=False)


@pytest.mark.parametrize("name", ["friction3", "impact5", "damper2d", "cone3d", "friction30"])
def test_the_examples_are_not_reduced(name):
    """The examples' element DOFs are masses of the structure (local frequency below 4 omega): no reduction for
    any time-integrating method."""
    case = load_case(ROOT / "examples" / f"{name}.yaml")
    for method in ("shooting", "mshbm", "mshbm-intermediate"):
        assert case.automatic_reduction(method, {}) is None


def test_the_automatic_modes_pass_the_cut_off():
    """8 fixed-interface modes at least, doubled until the highest passes 20 n_H omega."""
    from mshbm.reduction import auto_reduction

    s, w1, tip = blade()
    red = auto_reduction(s, w1, np.array([tip]), 10)
    assert red.n_modes >= 8 and red.frequencies[-1] >= 20 * 10 * w1
    half = craig_bampton(s, red.n_modes // 2)
    assert red.n_modes == 8 or half.frequencies[-1] < 20 * 10 * w1
