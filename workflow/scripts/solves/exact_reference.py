"""Exact event-driven periodic solution of one system (``mshbm.methods.exact``): the error reference of the
work-precision figures (Figs. 4 and 8) and the impact sequence of Fig. 7.

The time-stepped reference full shooting (``numerics.reference_steps``) has a discretisation error
of its own; against it, the errors of MS-HBM level off at that error (the "plateau" of the paper's
Figs. 4 and 8).  The exact flow has no time step: events (stick/slip transitions, impacts) are
located to machine precision.  Its Newton iteration starts from the converged reference shooting
solution (input ``seed``, the ``.npz`` of the solve), re-converged as a PeriodicSolution so that
``exact_periodic`` can choose its section time away from the events.

Writes ``<results>/solves/<case>/exact.json``: success, message, residual, amplitudes (masses 1 and
n, every mass for n <= 10), the impacts of one period (time, approach velocity, impulse), the
accumulations of impacts found by :mod:`mshbm.accumulation`, the largest Floquet multiplier modulus
of the flow (saltation terms included), and its difference to the reference shooting.  A failure is
recorded with its message (the summaries then fall back to the shooting reference and say so).
"""
import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import mshbm  # noqa: E402
from mshbm.accumulation import from_events  # noqa: E402
from mshbm.methods.exact import exact_periodic  # noqa: E402
from mshbm_workflow.wfcore import build_system, omega as config_omega, write_json  # noqa: E402

#: masses whose amplitudes are all stored when the chain is at most this long
STORE_ALL_DOFS = 10


def run(config, case, seed_npz, out_json, log=print):
    scfg = config["systems"][case]
    system = build_system(scfg, case)
    om = config_omega(config)
    n = system.n
    facts = {"case": case, "method": "exact", "omega": om, "n": n, "element": system.elements[0].kind}
    t0 = time.perf_counter()
    with np.load(seed_npz) as z:
        valid = bool(z["valid"])
        guess = {"q_hat": z["q_hat"].copy(), "q0": z["q0"].copy(), "u0": z["u0"].copy()} if valid else None
    seed = None
    if guess is not None:
        steps = int(config["numerics"]["reference_steps"])
        seed = mshbm.solve(system, om, "shooting", steps=steps, guess=guess, theta=float(config["numerics"]["theta"]))
        log(f"seed: shooting with {steps} steps from the reference solution: {seed.message}")
    sol = exact_periodic(system, om, guess=seed if (seed is not None and seed.success) else None)
    facts["wall_time"] = time.perf_counter() - t0
    facts["success"] = bool(sol.success)
    facts["message"] = sol.message
    facts["residual"] = float(sol.residual)
    facts["iterations"] = int(sol.iterations)
    log(f"exact: {sol.message} ({facts['wall_time']:.2f} s)")
    if sol.success:
        amp = np.asarray(sol.info["amplitude_exact"], dtype=float)
        facts.update(amplitude_first=float(amp[0]), amplitude_last=float(amp[n - 1]),
                     amplitude=[float(a) for a in amp] if n <= STORE_ALL_DOFS else None)
        events = sol.info.get("events") or []
        facts["n_events"] = len(events)
        imp = [e for e in events if e.impulse > 0.0]
        facts["n_impacts"] = len(imp)
        facts["impacts"] = [{"t": float(e.t), "velocity": float(e.velocity), "impulse": float(e.impulse),
                             "kind": e.kind} for e in imp[:200]]
        facts["accumulations"] = [a.as_dict() for a in from_events(events, period=2 * np.pi / om)]
        mult = sol.info.get("floquet_multipliers")
        facts["floquet_max_modulus"] = float(np.max(np.abs(mult))) if mult is not None and len(mult) else None
        if "stick_fraction" in sol.info:
            facts["stick_or_closed_fraction"] = float(sol.info["stick_fraction"])
        if seed is not None and seed.success:
            a_sh = seed.amplitude
            facts["reference_shooting_error_first"] = float(abs(a_sh[0] / amp[0] - 1.0))
            facts["reference_shooting_error_last"] = float(abs(a_sh[n - 1] / amp[n - 1] - 1.0))
    write_json(out_json, facts)
    return facts


if "snakemake" in globals():
    smk = snakemake  # noqa: F821
    with open(smk.log[0], "w") as logf:
        def _log(msg):
            print(msg, file=logf, flush=True)
        run(smk.params.cfg, smk.wildcards.case, smk.input.seed, smk.output[0], log=_log)
elif __name__ == "__main__":
    import yaml

    if len(sys.argv) != 5:
        sys.exit("usage: exact_reference.py CONFIG CASE SEED_NPZ OUT_JSON")
    with open(sys.argv[1]) as fh:
        run(yaml.safe_load(fh), sys.argv[2], sys.argv[3], sys.argv[4])
