"""Shared fixtures: the paper's systems (parameters as in workflow/config.yaml)."""
import numpy as np
import pytest

from mshbm import Contact, Friction, chain

OMEGA = np.pi / 5
#: F_N = 5 (mu*F_N = 4): stick-slip in the 3- and the 30-mass chain (30 % and 34 % stick per period);
#: F_N = 9.81 would lock the 30-mass chain completely (see paper, assumptions)
NORMAL_FORCE = 5.0


def friction_chain(n, kappa=800.0):
    return chain([1.0] * n, 1.0, 0.0, forcing=[{"dof": n - 1, "amplitude": 5.0}],
                 elements=[Friction(0, 0.8, NORMAL_FORCE, kappa)], name=f"friction{n}")


def impact_chain(n, gap=0.1, kc=8000.0, e=1.0):
    return chain([10.0] + [1.0] * (n - 1), 1.0, 0.3, forcing=[{"dof": n - 1, "amplitude": 5.0}],
                 elements=[Contact(0, gap, e, kc, 0.0)], name=f"impact{n}")


@pytest.fixture(scope="session")
def friction3():
    return friction_chain(3)


@pytest.fixture(scope="session")
def impact5():
    return impact_chain(5)
