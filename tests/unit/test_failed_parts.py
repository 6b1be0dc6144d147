"""A method whose event-driven flow fails at its converged unknowns reports non-finite solution parts with
the reason (``info["failure"]``), which the driver turns into a failed result (shooting and MS-HBM share
:func:`mshbm.methods.common.failed_parts`)."""
from pathlib import Path

import numpy as np

import mshbm
from mshbm.integrators.event import EventError
from mshbm.io.case import load_case

ROOT = Path(__file__).resolve().parents[2]


def _check(parts, N, hat_shape, n_time, n_el):
    assert parts["q_hat"].shape == hat_shape and np.isnan(parts["q_hat"]).all()
    for key, shape in (("q_time", (N + 1, n_time)), ("u_time", (N + 1, n_time)), ("lam", (N + 1, n_el)),
                       ("impulses", (N, n_el))):
        assert parts[key].shape == shape and np.isnan(parts[key]).all(), key
    assert parts["t"].shape == (N + 1,)
    assert parts["info"]["failure"].startswith("the event-driven flow failed at the solution")


def test_shooting_and_mshbm_report_a_failed_flow():
    system = load_case(ROOT / "examples" / "impact5.yaml").system
    p, _ = mshbm.build_problem(system, 0.6, "shooting", integrator="event", steps=64, harmonics=5)

    def boom(*a, **k):
        raise EventError("test")

    p.integrator.flow.simulate = boom
    parts = p.solution_parts(np.zeros(2 * system.n))
    _check(parts, 64, (11, system.n), system.n, 1)
    assert parts["harmonics"] == 5 and "EventError: test" in parts["info"]["failure"]

    m, _ = mshbm.build_problem(system, 0.6, "mshbm", integrator="event", steps=64, harmonics=3)
    m.integrator.flow.simulate = boom
    parts = m.solution_parts(np.zeros(m.initial_guess("linear").size))
    _check(parts, 64, (7, system.n), 1, 1)
    assert parts["harmonics"] == 3
