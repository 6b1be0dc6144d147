"""A sweep through a stuck relative Coulomb contact (MS-HBM): the family of stuck solutions is found where its
free direction is exact but ``dR/domega`` lies in the range of ``J`` only to its rounding.

Two unit masses, springs 1 (wall-mass 0, mass 0-mass 1) with dampers 0.02, forced by cos(omega t) on mass 1,
Coulomb friction mu N = 0.25 between the masses (the sweep stress suite's ``chain2-rel-friction``).  The contact
sticks the whole period where the stick force the pair needs, ``|1 - omega^2| / |1 - 2 omega^2|`` of the forcing
without damping, stays within mu N: about 0.913 < omega < 1.22.  There the masses move as one, and the amplitude
of both is the closed form ``1 / |1 - 2 omega^2 + 0.02 i omega|``; the relative position is free inside an interval
(a family of periodic solutions).  The family's null direction is exact (singular value 1e-17 of the largest) while
``[J, dR/domega]`` had its smallest singular value at 1.05e-10 of the largest, just above the one bound used for
both: the point was taken as a fold's neighbour, the tangent pointed along the family, and the sweep turned back
at 0.998 and traced the resonance again down to 0.147 (stopped, "left the parameter range").
"""
import numpy as np
import pytest

import mshbm

OPTIONS = {"harmonics": 7, "steps": 1024}


def _pair():
    return mshbm.chain([1.0, 1.0], 1.0, 0.02, forcing=[{"dof": 1, "amplitude": 1.0}],
                       elements=[mshbm.Friction(1, mu=0.5, normal_force=0.5, relative_to=0)])


def _stuck_amplitude(omega):
    return 1.0 / abs(1.0 - 2.0 * omega ** 2 + 0.02j * omega)


def test_sweep_through_a_stuck_relative_coulomb_contact_reaches_the_end():
    s = _pair()
    br = mshbm.sweep(s, 0.3, 2.0, "mshbm", stability=False, accuracy=False, **OPTIONS)
    assert br.success, br.message
    assert br.omega[-1] == pytest.approx(2.0, rel=1e-12)
    omega = np.asarray(br.omega)
    assert np.all(np.diff(omega) > 0)  # no turn back: there is no fold on this branch
    assert not [b for b in br.bifurcations if b["type"] == "fold"]
    assert len(br) <= 120
    assert br.counters.get("free_points", 0) >= 3  # the stuck stretch was found as a family
    inside = (omega > 0.95) & (omega < 1.15)  # well inside the stuck range
    assert inside.sum() >= 3
    for p in np.asarray(br.points, dtype=object)[inside]:
        ref = _stuck_amplitude(p.omega)
        # the stuck pair: one amplitude for both masses, the closed form within Moreau-Jean's 1024 steps
        assert np.max(np.abs(p.amplitude - ref)) <= 2e-3 * ref, (p.omega, p.amplitude, ref)
    # slipping points against pointwise certified solves (below and above the stuck range)
    for w in (0.6, 1.6):
        i = int(np.argmin(np.abs(omega - w)))
        sol = mshbm.solve(s, float(omega[i]), "mshbm", stability=False, **OPTIONS)
        assert sol.success, sol.message
        ref = np.asarray(sol.amplitude)
        assert np.max(np.abs(br.points[i].amplitude - ref)) <= 5e-3 * np.max(ref)
