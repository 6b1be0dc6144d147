"""The sensitivities of the event-driven flow through a Moreau-Jean segment (``accumulation="moreau"``, the
integrator's default) against central differences of the flow.

A mass pressed on a stop (``e_N = 0.5``, damped, the system of tests/unit/test_event_integrator.py's accumulation
test) started at ``q = 0.1, u = -0.3`` comes back to the stop within the period with an accumulation of impacts:
the flow switches to Moreau-Jean at the impact that completes it (32 steps).  That impact's time moves with the
initial state, and so do the segment's steps and, where it ends by release, its end.  The product of the step
Jacobians alone missed this (like a monodromy without its saltation matrices): 0.55 off a monodromy of size 0.18,
and Newton on such a residual converged only linearly (ratio 0.3 per iteration on the stopped cantilever's
impacting orbits, workflow/sweeps.yaml beam-stop-cb, event shooting: its sweep crawled at 1071.3 rad/s).  With the
variation of the segment's start time the monodromy is the central difference's to 4e-8 (measured, ``h = 1e-7``;
6.5e-5 at ``h = 1e-5``, the difference's own error).  Orbits without a segment are unchanged (their check: 1e-8).
"""
import numpy as np
import pytest

from mshbm import Contact, chain
from mshbm.integrators.event import EventFlow


def _pressed_mass():
    return chain([1.0], 1.0, 0.1, forcing=[{"dof": 0, "amplitude": 1.5, "constant": 1.0}],
                 elements=[Contact(0, 0.3, 0.5)])


def _central_difference(fl, z0, h, steps):
    F = np.zeros((2, 2))
    for k in range(2):
        e = np.zeros_like(z0)
        e[k] = h
        a, b = fl.simulate(0.0, z0 + e), fl.simulate(0.0, z0 - e)
        # the same segments (steps): the flow is smooth in the initial state on this interval
        assert [s["steps"] for s in a.moreau_segments] == steps == [s["steps"] for s in b.moreau_segments]
        F[:, k] = (a.end_state[:2] - b.end_state[:2]) / (2.0 * h)
    return F


@pytest.mark.parametrize("q0, u0, segments", [(0.1, -0.3, [32]), (0.0, 0.0, [])])
def test_monodromy_through_a_moreau_segment_is_the_central_difference(q0, u0, segments):
    fl = EventFlow(_pressed_mass(), 1.0)
    z0 = fl.state(0.0, np.array([q0]), np.array([u0]))
    out = fl.simulate(0.0, z0, jac=True)
    assert [s["steps"] for s in out.moreau_segments] == segments
    F = _central_difference(fl, z0, 1e-7, segments)
    assert np.abs(F).max() >= 0.1
    # measured 4.1e-8 with a segment (0.55 without the start time's variation), 7.9e-9 without one
    assert np.abs(out.monodromy[:2, :2] - F).max() <= 1e-6
