#!/usr/bin/env python
"""Benchmark of the compiled Moreau-Jean kernel: nanoseconds per step.

Target: >= 10^7 Moreau-Jean steps per second (<= 100 ns/step) for a 1-DOF nonlinear
subsystem with its harmonic coupling forces.

Cases (all on converged periodic states of the paper's systems, omega = pi/5):

* ``1dof_friction_*`` -- the nonlinear subsystem N = {mass 1} of the 3-mass friction chain as
  MS-HBM integrates it (forcing increments include the condensed coupling forces);
* ``1dof_contact_*`` -- N = {mass 1} of the 5-mass impact chain (contact, e = 1);
  each ``plain`` (trajectory only), ``sens`` (end sensitivities w.r.t. (q0, u0, p),
  n_p = 2*5+1 = 11 harmonic parameters, dB of shape (N, 1, 11)) and ``sens_store``
  (also dq_k/d(q0,u0,p) at every step: what MS-HBM's exact Jacobian needs);
* ``3dof_friction_*`` -- the general (array) path: N = masses 1-3 of the 30-mass chain
  (n_p = 33);
* ``full30_plain``, ``full50_plain`` -- whole 30/50-mass chains (dense 30x30 / 50x50 step
  matrices): full shooting's cost per step;
* ``numpy_twin_1dof_friction`` vs ``compiled_1dof_friction_small`` on 2^12 steps: the plain
  NumPy twin ``kernels.moreau_jean_numpy`` against the compiled kernel.

Event-driven flow (``event_measurements``, next to the steps per second above): one period
of :class:`mshbm.integrators.event.EventFlow` on the same converged orbits (MS-HBM with
``integrator="event"``, n_H = 5, and shooting with it), timed as the solvers call it:

* ``event_1dof_{friction,contact}_*`` -- the 1-DOF subsystem of MS-HBM with the coupling forces as
  forcing states; ``plain`` (flow only) and ``jac_fourier`` (monodromy columns for (q0, u0, coupling
  coefficients) and the exact Fourier coefficients with their sensitivities: one MS-HBM residual with
  its Jacobian);
* ``event_full{3,5}_*`` -- the whole 3-mass friction / 5-mass impact chain (shooting's flow), ``plain``
  and ``jac`` (with the saltation-corrected monodromy).

Events per second = events per period / median wall time of one period (events: impacts, stick-slip
transitions, slip reversals, contact openings); also microseconds per period.

Timing: one warm-up call per case (numba compilation excluded), then the cases interleaved
round-robin; ns/step = median wall time / N.

Usage::

    python workflow/scripts/bench/bench_kernel.py --out results/benchmarks/kernel.json [--quick]
"""
from __future__ import annotations

import time


import numpy as np  # noqa: E402

from mshbm_workflow import benchlib as bl  # noqa: E402

TARGET_NS = 100.0  # 10^7 steps per second


def _mixed(system, n_steps, sol, partition=None):
    """The time-domain part of MS-HBM with ``n_steps`` steps per period, at the unknowns of ``sol``."""
    from mshbm.methods.mixed import MixedProblem
    prob = MixedProblem(system, bl.OMEGA, 5, n_steps, partition=partition)
    x = prob.initial_guess(sol)
    p, q0, u0 = prob._split(x)
    td = prob.integrator.part
    B = np.ascontiguousarray(td.B0 + np.einsum("kip,p->ki", td.dB, p))
    return td.stepper, q0, u0, B, np.ascontiguousarray(td.dB)


def _cases(quick):
    import mshbm
    from mshbm.methods.shooting import ShootingProblem

    N = 1 << (16 if quick else 20)
    N_gen_sens = 1 << (14 if quick else 16)  # dB and Sq_traj of the 3-DOF case are (N, 3, 33..39) arrays
    # whole chains (full shooting's flow) at 2^16 steps: 3.4 us/step at 50 masses, 0.2 s per call, long enough to
    # time (at 2^18 their calls were half of the default profile's measuring time); shooting runs 4096
    N_full = 1 << (14 if quick else 16)
    N_twin = 1 << 12
    cases, meta = {}, {}
    states = {}

    f3 = bl.paper_system("friction3")
    i5 = bl.paper_system("impact5")
    f30 = bl.paper_system("friction30")
    f50 = bl.friction_chain(50)
    sol_f3 = mshbm.solve(f3, bl.OMEGA, "mshbm", harmonics=5, steps=4096)
    sol_i5 = mshbm.solve(i5, bl.OMEGA, "mshbm", harmonics=5, steps=4096)
    sol_f30 = mshbm.solve(f30, bl.OMEGA, "mshbm", harmonics=5, steps=4096)
    sol_f50 = mshbm.solve(f50, bl.OMEGA, "mshbm", harmonics=5, steps=4096)
    for name, s in (("friction3", sol_f3), ("impact5", sol_i5), ("friction30", sol_f30), ("friction50", sol_f50)):
        states[name] = {"success": s.success, "stick_or_closed_fraction": s.info.get("stick_or_closed_fraction")}

    def add(name, N_steps, fn, n_dof, n_s, what):
        cases[name] = fn
        meta[name] = {"steps": int(N_steps), "n_dof": int(n_dof), "n_sensitivity_columns": int(n_s), "what": what}

    for label, system, sol in (("friction", f3, sol_f3), ("contact", i5, sol_i5)):
        st, q0, u0, B, dB = _mixed(system, N, sol)
        n_p = dB.shape[2]
        add(f"1dof_{label}_plain", N, lambda st=st, q0=q0, u0=u0, B=B: st.run(q0, u0, B), 1, 0,
            "trajectory only")
        add(f"1dof_{label}_sens", N,
            lambda st=st, q0=q0, u0=u0, B=B, dB=dB: st.run(q0, u0, B, dB, sensitivities=True), 1, 2 + n_p,
            "end sensitivities w.r.t. (q0, u0, p)")
        add(f"1dof_{label}_sens_store", N,
            lambda st=st, q0=q0, u0=u0, B=B, dB=dB: st.run(q0, u0, B, dB, sensitivities=True,
                                                         store_q_sensitivities=True), 1, 2 + n_p,
            "sensitivities stored at every step (MS-HBM exact Jacobian)")

    # the same 1-DOF friction case at shorter periods (N = 2^12, 2^16): arrays in cache vs. the big run, whose
    # fresh output arrays (q, u, P, status: ~25 bytes/step; + 8 n_s bytes/step when storing sensitivities) are
    # first-touched in every call
    for N_small in sorted({1 << 12, 1 << 16} - {N}):
        st, q0, u0, B, dB = _mixed(f3, N_small, sol_f3)
        add(f"1dof_friction_plain_N{N_small}", N_small, lambda st=st, q0=q0, u0=u0, B=B: st.run(q0, u0, B), 1, 0,
            "trajectory only, shorter run")
        add(f"1dof_friction_sens_store_N{N_small}", N_small,
            lambda st=st, q0=q0, u0=u0, B=B, dB=dB: st.run(q0, u0, B, dB, sensitivities=True,
                                                         store_q_sensitivities=True), 1, 2 + dB.shape[2],
            "sensitivities stored at every step, shorter run")

    st, q0, u0, B, dB = _mixed(f30, N, sol_f30, partition=[0, 1, 2])
    add("3dof_friction_plain", N, lambda st=st, q0=q0, u0=u0, B=B: st.run(q0, u0, B), 3, 0, "trajectory only")
    st, q0, u0, B, dB = _mixed(f30, N_gen_sens, sol_f30, partition=[0, 1, 2])
    add("3dof_friction_sens_store", N_gen_sens,
        lambda st=st, q0=q0, u0=u0, B=B, dB=dB: st.run(q0, u0, B, dB, sensitivities=True,
                                                     store_q_sensitivities=True), 3, 6 + dB.shape[2],
        "sensitivities stored at every step (MS-HBM, partition = masses 1-3)")

    for n, system, sol in ((30, f30, sol_f30), (50, f50, sol_f50)):
        sp_ = ShootingProblem(system, bl.OMEGA, N_full)
        x = sp_.initial_guess(sol)
        add(f"full{n}_plain", N_full, lambda sp_=sp_, x=x: sp_.simulate(x), n, 0,
            f"whole {n}-mass chain (shooting's trajectory)")

    # compiled vs NumPy twin on the same small problem
    from mshbm.integrators import kernels
    st, q0, u0, B, dB = _mixed(f3, N_twin, sol_f3)
    args = (q0, u0, st.Aq, st.Au, st.WG, st.Del, st.MinvG, B, st.theta, st.h, st.kind, st.dof, st.sign,
            st.bound, st.gap, st.e)
    add("compiled_1dof_friction_small", N_twin, lambda st=st, q0=q0, u0=u0, B=B: st.run(q0, u0, B), 1, 0,
        "compiled kernel, same problem as the NumPy twin")
    add("numpy_twin_1dof_friction", N_twin, lambda args=args: kernels.moreau_jean_numpy(*args, project=True), 1, 0,
        "kernels.moreau_jean_numpy (plain NumPy, no sensitivities)")
    # check that the twin and the kernel agree (sanity of the comparison)
    qa = st.run(q0, u0, B).q
    qb = kernels.moreau_jean_numpy(*args, project=True)[0]
    twin_diff = float(np.max(np.abs(qa - qb)))
    return cases, meta, states, twin_diff


def _event_cases():
    """One period of the event-driven flow on converged orbits (module docstring): callables, metadata
    (events per period) and the converged states."""
    import mshbm
    from mshbm.methods.mixed import MixedProblem
    from mshbm.methods.shooting import ShootingProblem

    cases, meta, states = {}, {}, {}
    n_h = 5
    for label, name in (("friction", "friction3"), ("contact", "impact5")):
        system = bl.paper_system(name)
        sol = mshbm.solve(system, bl.OMEGA, "mshbm", harmonics=n_h, steps=256, integrator="event")
        states[f"{name}_mshbm_event"] = {"success": bool(sol.success)}
        prob = MixedProblem(system, bl.OMEGA, n_h, 256, integrator="event")
        x = prob.initial_guess(sol)
        p, q0, u0 = prob._split(x)
        fl = prob.integrator.flow
        fl.set_forcing((prob.integrator.c0 + prob.integrator.Tr @ p).reshape(prob.nc, prob._time.size))
        z0 = fl.state(0.0, q0, u0)
        n_ev = len(fl.simulate(0.0, z0).events)
        for kind, kw, what in (("plain", {}, "one period, flow only"),
                               ("jac_fourier", dict(jac=True, jac_cols="all", fourier=n_h),
                                "one period with monodromy (q0, u0, coupling) and exact Fourier coefficients "
                                "(one MS-HBM residual + Jacobian)")):
            key = f"event_1dof_{label}_{kind}"
            cases[key] = lambda fl=fl, z0=z0, kw=kw: fl.simulate(0.0, z0, **kw)
            meta[key] = {"events_per_period": n_ev, "n_dof": 1, "system": name, "what": what}
        sol = mshbm.solve(system, bl.OMEGA, "shooting", steps=256, integrator="event")
        states[f"{name}_shooting_event"] = {"success": bool(sol.success)}
        sp_ = ShootingProblem(system, bl.OMEGA, 256, integrator="event")
        x = sp_.initial_guess(sol)
        fl = sp_.integrator.flow
        z0 = fl.state(0.0, x[:system.n], x[system.n:])
        n_ev = len(fl.simulate(0.0, z0).events)
        for kind, kw, what in (("plain", {}, "one period, flow only"),
                               ("jac", dict(jac=True), "one period with the saltation-corrected monodromy "
                                                      "(one shooting residual + Jacobian)")):
            key = f"event_full{system.n}_{label}_{kind}"
            cases[key] = lambda fl=fl, z0=z0, kw=kw: fl.simulate(0.0, z0, **kw)
            meta[key] = {"events_per_period": n_ev, "n_dof": int(system.n), "system": name, "what": what}
    return cases, meta, states


def plot(data, png):
    plt = bl.pyplot()
    names = list(data["measurements"])
    ns = [data["measurements"][k]["ns_per_step_median"] for k in names]
    fig, ax = plt.subplots(figsize=(9, 4.8))
    colors = ["tab:red" if "numpy" in k else ("tab:blue" if k.startswith("1dof") else "tab:gray") for k in names]
    ax.barh(range(len(names)), ns, color=colors)
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels(names, fontsize=8)
    ax.set_xscale("log")
    ax.axvline(TARGET_NS, color="k", ls="--", lw=1, label="target 100 ns/step (10^7 steps/s)")
    for i, v in enumerate(ns):
        ax.text(v, i, f" {v:.3g}", va="center", fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("ns per Moreau-Jean step (median)")
    ax.set_title(f"Moreau-Jean kernel cost per step ({data['machine']['cpu_count']} cores, shared)", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def main(argv=None):
    args = bl.parser(__doc__.splitlines()[1], "results/benchmarks/kernel.json").parse_args(argv)
    bl.profile(args)  # no separate full sweep: default and full are the same
    t_begin = time.perf_counter()
    repeats = 3 if args.quick else 7
    cases, meta, states, twin_diff = _cases(args.quick)
    # NumPy twin is slow (~tens of us/step): time it on its own few repeats, interleaved with its compiled peer
    slow = {k: cases.pop(k) for k in ("numpy_twin_1dof_friction", "compiled_1dof_friction_small")}
    times = bl.interleaved(cases, repeats, warmup=1, budget_s=15 if args.quick else 240)
    times.update(bl.interleaved(slow, 3, warmup=1))
    meas = {}
    for k, ts in times.items():
        s = bl.stats(ts)
        N = meta[k]["steps"]
        meas[k] = dict(meta[k], **s, ns_per_step_median=1e9 * s["median_s"] / N, ns_per_step_min=1e9 * s["min_s"] / N,
                       ns_per_step_all=[1e9 * t / N for t in ts], steps_per_second_median=N / s["median_s"])
    ev_cases, ev_meta, ev_states = _event_cases()
    states.update(ev_states)
    ev_times = bl.interleaved(ev_cases, repeats, warmup=1, budget_s=10 if args.quick else 60)
    ev_meas = {}
    for k, ts in ev_times.items():
        s = bl.stats(ts)
        n_ev = ev_meta[k]["events_per_period"]
        ev_meas[k] = dict(ev_meta[k], **s, us_per_period_median=1e6 * s["median_s"],
                          events_per_second_median=n_ev / s["median_s"] if n_ev else None,
                          us_per_event_median=1e6 * s["median_s"] / n_ev if n_ev else None)
    ratio = meas["numpy_twin_1dof_friction"]["ns_per_step_median"] / meas["compiled_1dof_friction_small"]["ns_per_step_median"]
    one_dof = {k: v["ns_per_step_median"] for k, v in meas.items() if k.startswith("1dof") and "_N" not in k}
    target = {
        "statement": ">= 10^7 Moreau-Jean steps per second (<= 100 ns/step) for a 1-DOF nonlinear subsystem "
                     "with its harmonic coupling forces",
        "target_ns_per_step": TARGET_NS,
        "ns_per_step_1dof": one_dof,
        "met_plain": all(v <= TARGET_NS for k, v in one_dof.items() if k.endswith("plain")),
        "met_with_sensitivities": all(v <= TARGET_NS for k, v in one_dof.items() if "sens" in k),
    }
    data = {"benchmark": "kernel", "quick": bool(args.quick), "machine": bl.machine_info(),
            "method": "median of interleaved repeats after one warm-up call per case; ns/step = time / steps",
            "omega": bl.OMEGA, "harmonics": 5, "states": states, "measurements": meas,
            "event_measurements": ev_meas,
            "numpy_twin_over_compiled_ratio": ratio, "numpy_twin_max_abs_difference_q": twin_diff,
            "target": target, "total_wall_s": time.perf_counter() - t_begin}
    data["summary"] = {"ns_per_step_1dof": one_dof, "target_met_plain": target["met_plain"],
                       "target_met_with_sensitivities": target["met_with_sensitivities"],
                       "ns_per_step_general": {k: meas[k]["ns_per_step_median"] for k in
                                               ("3dof_friction_plain", "3dof_friction_sens_store", "full30_plain",
                                                "full50_plain")},
                       "numpy_twin_over_compiled": ratio,
                       "events_per_second": {k: v["events_per_second_median"] for k, v in ev_meas.items()},
                       "events_per_period": {k: v["events_per_period"] for k, v in ev_meas.items()},
                       "us_per_event_period": {k: v["us_per_period_median"] for k, v in ev_meas.items()},
                       "steps_per_second_1dof": {k: 1e9 / v for k, v in one_dof.items()}}
    out = bl.write_json(args.out, data)
    plot(data, bl.plot_path(out))
    for k, v in meas.items():
        print(f"{k:32s} N={v['steps']:8d}  {v['ns_per_step_median']:10.1f} ns/step (min {v['ns_per_step_min']:.1f})")
    for k, v in ev_meas.items():
        print(f"{k:32s} {v['events_per_period']:4d} events/period  {v['us_per_period_median']:10.1f} us/period  "
              f"{v['events_per_second_median'] or 0:10.3g} events/s")
    print(f"NumPy twin / compiled: {ratio:.0f}x;  target met (plain): {target['met_plain']}, "
          f"(with sensitivities): {target['met_with_sensitivities']}")
    print(f"wrote {out} and {bl.plot_path(out)} in {time.perf_counter() - t_begin:.1f} s")
    return data


if __name__ == "__main__":
    main()
