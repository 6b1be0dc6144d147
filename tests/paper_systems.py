"""The paper's systems for the tests: the case files of ``examples/`` (one definition, read with
:func:`mshbm.load_case` through ``workflow/lib/mshbm_workflow/wfcore.py``, as the workflow, the stress suite and
the benchmarks read them).

``system("impact50")`` is a paper system as the figures use it; :func:`friction_chain` and
:func:`impact_chain` are the parameterised families (the 3-DOF friction and 5-DOF impact systems with
``n`` masses and, optionally, another element parameter) for scaling and robustness tests.
"""

from mshbm_workflow import wfcore  # noqa: E402

EXAMPLES = wfcore.EXAMPLES


def case(name, **overrides):
    """:class:`mshbm.Case` of ``examples/<name>.yaml`` (``overrides`` as in :func:`mshbm.load_case`)."""
    return wfcore.load_case(name, **overrides)


def system(name):
    """The :class:`mshbm.System` of ``examples/<name>.yaml``."""
    return case(name).system


#: forcing frequency of the paper's systems (pi/5 rad/s)
OMEGA = case("friction3").omega
#: F_N = 5 (mu*F_N = 4): stick-slip in the 3- and the 30-mass chain (30 % and 34 % stick per period);
#: F_N = 9.81 would lock the 30-mass chain completely (see paper, assumptions)
NORMAL_FORCE = system("friction3").elements[0].normal_force


def friction_chain(n, kappa=None):
    """examples/friction3.yaml with ``n`` masses (and arctan smoothing ``kappa`` if given)."""
    return wfcore.chain_case("friction3", n, **({} if kappa is None else {"smoothing": kappa}))


def impact_chain(n, gap=None, kc=None, e=None):
    """examples/impact5.yaml with ``n`` masses (gap, penalty stiffness ``kc``, restitution ``e`` if given)."""
    el = {k: v for k, v in (("gap", gap), ("penalty_stiffness", kc), ("restitution", e)) if v is not None}
    return wfcore.chain_case("impact5", n, **el)
