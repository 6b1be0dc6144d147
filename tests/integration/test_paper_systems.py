"""The paper's systems are defined once, by the case files of examples/: the workflow config, the stress
suite, the benchmarks and the tests load them (tests/paper_systems.py, workflow/lib/mshbm_workflow/wfcore.py)."""
from pathlib import Path

import numpy as np
import pytest
import yaml

import paper_systems as ps

ROOT = Path(__file__).resolve().parents[2]
from mshbm_workflow import wfcore  # noqa: E402


def _same(a, b):
    return (all(np.array_equal(np.asarray(a.dense(k)), np.asarray(b.dense(k))) for k in "MCK")
            and np.array_equal(a.f_hat, b.f_hat) and a.elements == b.elements)


def _config_systems():
    out = {}
    for name in ("config.yaml", "config-quick.yaml"):
        out.update(yaml.safe_load((ROOT / "workflow" / name).read_text())["systems"])
    return out


def test_every_configured_system_is_a_case_file():
    systems = _config_systems()
    assert {"friction3", "friction30", "impact5", "impact50"} <= set(systems)
    for name, scfg in systems.items():
        assert scfg["case"] == f"examples/{name}.yaml" and (ROOT / scfg["case"]).is_file()
    stress = yaml.safe_load((ROOT / "workflow" / "stress.yaml").read_text())["systems"]
    assert all(stress[name] == systems[name]["case"] for name in stress)


def test_resolved_parameters_are_the_paper_tables():
    """Tables 1 and 2 of the paper (F_N = 5 is the reproduction's choice) as derived from the case files."""
    cfg = wfcore.resolve_systems({"systems": _config_systems()})["systems"]
    for name in ("friction3", "friction30"):
        s = cfg[name]
        assert (s["mass_first"], s["mass_other"], s["stiffness"], s["damping"], s["forcing_amplitude"]) == (1, 1, 1, 0, 5)
        assert s["friction"] == {"mu": 0.8, "normal_force": 5.0, "kappa": 800.0}
    assert cfg["friction30w"]["friction"]["normal_force"] == 9.81
    for name in ("impact5", "impact50"):
        s = cfg[name]
        assert (s["mass_first"], s["mass_other"], s["stiffness"], s["damping"], s["forcing_amplitude"]) == (10, 1, 1, 0.3, 5)
        assert s["contact"] == {"gap": 0.1, "restitution": 1.0, "penalty_stiffness": 8000.0, "penalty_damping": 0.0}
    assert [cfg[k]["n"] for k in ("friction3", "friction30", "impact5", "impact50")] == [3, 30, 5, 50]


def test_families_contain_the_paper_systems():
    for n in (3, 30):
        assert _same(ps.friction_chain(n), ps.system(f"friction{n}"))
    for n in (5, 50):
        assert _same(ps.impact_chain(n), ps.system(f"impact{n}"))
    soft = ps.friction_chain(3, kappa=1e5)
    assert soft.elements[0].smoothing == 1e5 and _same(soft.with_elements(ps.system("friction3").elements),
                                                       ps.system("friction3"))
    assert ps.impact_chain(5, kc=1e3, e=0.5).elements[0].penalty_stiffness == 1e3


def test_chain_parameters_refuse_other_systems():
    from mshbm import Friction, chain

    other = chain([1.0, 2.0, 1.0], 1.0, 0.0, forcing=[{"dof": 2, "amplitude": 5.0}], elements=[Friction(0, 0.8, 5.0)])
    with pytest.raises(ValueError, match="not a chain of the paper's form"):
        wfcore.chain_parameters(other)
