"""Branch switching at a period doubling: the branch of period ``2k`` born on a branch of period ``k``
(:func:`switch_period_doubling`).

Notation: ``n`` DOFs, ``omega`` the forcing frequency (rad/s), ``T = 2 pi / omega``; a branch of period ``k``
holds ``kT``-periodic solutions (:mod:`mshbm.subharmonic`), ``Phi`` the monodromy over ``kT``.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from .branch import ROUTE, Branch, _check_number, sweep
from .errors import InputError
from .methods.registry import build_problem
from .route.options import only
from .subharmonic import PERIOD_K_TOL, subharmonic_content, subharmonic_system

__all__ = ["switch_period_doubling"]


def switch_period_doubling(system, branch, omega_end, bifurcation=None, offset=5e-3, size=0.05, **options):
    """The branch of period ``2k`` born at a period doubling of ``branch`` (period ``k``), traced to ``omega_end``.

    At the branch point next to the bifurcation, the monodromy of the ``kT`` orbit (full shooting's
    Jacobian ``Phi - I`` at the orbit's state, with the orbit's steps per period) gives the eigenvector
    ``v`` of the multiplier nearest ``-1``.  The ``2kT``-periodic problem is then solved by full shooting
    at ``omega_pd (1 +- offset)`` from the orbit's state perturbed by ``+- size D v`` (``D`` its largest
    displacement), on the side towards ``omega_end`` first, then from the default starts of
    :func:`mshbm.period.solve` there (Newton from an explicit guess does not accept impacting
    Moreau-Jean orbits that are periodic only to one time step); a certified solution with ``2kT`` content
    (:func:`mshbm.subharmonic.subharmonic_content` at least :data:`mshbm.subharmonic.PERIOD_K_TOL`) starts
    :func:`sweep` with ``period=2k`` and the branch's method (``options``: its options; ``steps`` per
    forcing period defaults to the branch's).  The result's ``origin`` records the bifurcation; a
    failure is a :class:`Branch` with ``success=False`` and a message listing the starts tried.
    """
    if not isinstance(branch, Branch) or branch.parameter != "omega" or not branch.points:
        raise InputError("branch", "must be a non-empty frequency branch (mshbm.sweep)")
    pds = [b for b in branch.bifurcations if b.get("type") == "period-doubling"]
    bif = bifurcation if bifurcation is not None else (pds[0] if pds else None)
    if bif is None or bif.get("type") != "period-doubling":
        raise InputError("bifurcation", "the branch has no period-doubling bifurcation to switch at")
    omega_end = _check_number("omega_end", omega_end)
    t0 = time.perf_counter()
    k, method, n = int(branch.period), branch.method, system.n
    i = min(max(int(bif.get("index", 0)), 0), len(branch.points) - 1)
    sol1 = branch.points[i].solution
    N = max(int(sol1.steps) // k, 16)  # steps per forcing period
    sys_k = subharmonic_system(system, k)
    try:  # the exact event-driven monodromy over kT from t = 0 (saltation terms at impacts and stick-slip)
        from .methods.exact import ExactFlow

        flow = ExactFlow(sys_k, float(sol1.omega))
        Phi = np.asarray(flow.simulate(0.0, flow.state(0.0, sol1.q[0], sol1.u[0]), jac=True).monodromy)[:2 * n]
        if not np.all(np.isfinite(Phi)):
            raise ValueError("non-finite monodromy")
        how = "exact event-driven monodromy"
    except Exception:  # noqa: BLE001 -- several elements: the Moreau-Jean map (valid without impacts)
        prob, _ = build_problem(sys_k, float(sol1.omega), "shooting", steps=k * N)
        q1, u1 = sol1.initial_state()
        x1 = prob.initial_guess({"q_hat": sol1.q_hat, "q0": q1, "u0": u1})
        _, J = prob.residual(x1)
        J = J.toarray() if hasattr(J, "toarray") else np.asarray(J)
        half = x1.size // 2
        keep = np.r_[np.arange(n), half + np.arange(n)]
        Phi = (J + np.eye(J.shape[0]))[np.ix_(keep, keep)]  # shooting: R = x(kT) - x(0), J = Phi - I
        how = "Moreau-Jean step-map monodromy"
    mu, V = np.linalg.eig(Phi)
    j = int(np.argmin(np.abs(mu + 1.0)))
    v = np.real(V[:, j])
    vq, vu = v[:n], v[n:2 * n]
    D = max(float(np.max(np.abs(sol1.q))), 1e-300)
    eps = size * D / max(float(np.max(np.abs(vq))), 1e-300)
    qh1 = np.asarray(sol1.q_hat, dtype=float)
    nh1 = (qh1.shape[0] - 1) // 2
    qh2 = np.zeros((4 * nh1 + 1, n))  # harmonic j of omega/k is harmonic 2j of omega/2k
    qh2[0] = qh1[0]
    qh2[3::4], qh2[4::4] = qh1[1::2], qh1[2::2]
    w_pd = float(bif["omega"])
    toward = 1.0 if omega_end > w_pd else -1.0
    # the start is solved with the branch's own time integration: a 2T orbit of Moreau-Jean steps near the
    # bifurcation need not be one of the event-driven flow (their period doublings differ by the step error)
    sh_opts = only(options, "theta", "tol", "max_iter", "integrator")
    tried, start = [], None
    for side in (toward, -toward):
        w0 = w_pd * (1.0 + side * offset)
        for sign in (1.0, -1.0, None):
            # the orbit perturbed along +-v; then the default starts of mshbm.period (its start ladder, whose
            # acceptance knows impacting Moreau-Jean orbits periodic to one step, and a transient from rest)
            guess = None if sign is None else \
                {"q_hat": qh2, "q0": sol1.q[0] + sign * eps * vq, "u0": sol1.u[0] + sign * eps * vu}
            # (certified for its discretised equations, as the branch it starts: no error estimates)
            sh = replace(ROUTE, estimate=False).solve_period(system, w0, "shooting", period=2 * k, steps=N,
                                                              guess=guess, stability=False, **sh_opts)
            content = subharmonic_content(sh, 2) if sh.success else 0.0
            label = "default starts" if sign is None else ("+v" if sign > 0 else "-v")
            tried.append(f"omega = {w0:.6g}, {label}: "
                         + ("certified" if sh.success else "not certified") + f", 2kT content {content:.1e}")
            if sh.success and content >= PERIOD_K_TOL:
                start = (w0, sh, label)
                break
        if start is not None:
            break
    if start is None:
        return Branch(success=False, method=method, period=2 * k, origin=dict(bif, period=k),
                      message=f"no period-{2 * k} solution found next to the period doubling at omega = {w_pd:.6g} "
                              f"(multiplier {mu[j]:.4g} of the {how}); tried: " + "; ".join(tried),
                      wall_time=time.perf_counter() - t0)
    w0, sh, label = start
    opts = dict(options)
    opts.setdefault("steps", N)
    if label != "default starts":  # the period-2k orbit found from +-v starts the sweep (any method)
        opts.setdefault("guess", sh)
    out = sweep(system, w0, omega_end, method, period=2 * k, **opts)
    out.origin = dict(type="period-doubling", omega=w_pd, period=k, multiplier=[float(mu[j].real), float(mu[j].imag)],
                      eigenvector_from=how, start_omega=w0, start=label)
    out.wall_time = time.perf_counter() - t0  # the switch (eigenvector, period-2k start) included
    return out
