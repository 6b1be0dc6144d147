"""Section 3.3 demonstration (workflow/scripts/solves/intermediate_demo.py) at toy size.

Both MS-HBM variants solve the same equations on the chain with n_1 friction masses coupled to the
rest through mass n_1 + 1, so they must give the same solution with the same Newton iterations; the
intermediate variant carries 2 n_H + 1 harmonic unknowns instead of n_1 (2 n_H + 1), which fixes the
ratio of the propagated sensitivity work exactly.
"""

import numpy as np

from mshbm_workflow import script_module  # noqa: E402

demo = script_module("solves", "intermediate_demo")

CONFIG = {
    "omega_over_pi": 0.2,
    "numerics": {"tol": 1e-10, "max_iter": 50},
    "intermediate_demo": {"n": 8, "friction_masses": [1, 3], "mass": 1.0, "stiffness": 1.0, "damping": 0.02,
                          "forcing_amplitude": 5.0, "friction": {"mu": 0.8, "normal_force": 1.5},
                          "harmonics": [3], "steps": [512], "reference_steps": 2048, "repeats": 1},
}


def test_intermediate_variant_same_solution_less_work():
    rows, cases, machine = demo.run(CONFIG, log=lambda *_: None)
    assert len(rows) == 4 and all(r["success"] for r in rows), [r["message"] for r in rows]
    num = demo.numbers(rows, cases, CONFIG["intermediate_demo"], machine)
    assert num["same_iterations"] and num["max_difference"] < 1e-9
    nc = 2 * 3 + 1
    for n1 in (1, 3):
        by = {r["method"]: r for r in rows if r["friction_masses"] == n1}
        a, b = by["mshbm"], by["mshbm-intermediate"]
        assert a["unknowns"] == n1 * nc + 2 * n1 and b["unknowns"] == nc + 2 * n1
        assert b["partition"]["time"] == list(range(n1)) and b["partition"]["harmonic"] == [n1]
        # sensitivity columns per step: 2 n_1 (state) + harmonic unknowns, same number of runs
        ratio = a["work"]["sensitivity_steps"] / b["work"]["sensitivity_steps"]
        assert np.isclose(ratio, (2 * n1 + n1 * nc) / (2 * n1 + nc), rtol=1e-12)
        assert a["work"]["steps"] == b["work"]["steps"]
    assert num["sens_ratio_nhmax_one"] == 1.0 and num["sens_ratio_nhmax_big"] > 2
    assert num["n1_one"] == 1 and num["n1_big"] == 3
    # the reference is converged full shooting; MS-HBM with n_H = 3 is close to it
    assert num["err_max_big"] < 0.05
    table = demo.table(rows)
    assert table.count("\n") == 3 and "speed-up of 3.3" in table
