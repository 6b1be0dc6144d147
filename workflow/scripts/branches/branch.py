#!/usr/bin/env python
"""One frequency-response curve of the workflow (Fig. 9): ``mshbm.sweep`` of one system with one
method over the config's frequency range (config ``branches.<name>``), timed, written as JSON.

``--method`` is the curve's label in ``branches.<name>.methods``: the method itself, or a label whose options
name the method (``mshbm-event: {method: mshbm, integrator: event}``), so that one method can be traced
twice with different options.

    python workflow/scripts/branches/branch.py --config results/config.json --branch friction3 --method mshbm \
        --out results/branches/friction3/mshbm.json

The JSON is :meth:`mshbm.branch.Branch.to_dict` without the per-point details, plus ``name``, ``label``,
``system``, ``options`` (what the sweep was given) and ``wall_time_s`` (the whole sweep: start solve,
continuation, certificates and stability analyses).  A sweep that stops early is a result, not an
error: ``success`` is false and ``message`` says where and why.

A branch with ``switch: {omega_end: W}`` is the period-``2k`` branch born at the first period doubling of the
period-``k`` sweep over ``omega`` (:func:`mshbm.switch_period_doubling`), traced to ``W``; the wall time covers
both sweeps and ``options.parent`` records the period-``k`` one.
"""
from __future__ import annotations

import argparse
import json
import os
import time

import mshbm
from mshbm_workflow.wfcore import load_case

#: the sweeps report every accepted point (points, omega, step) on stderr, the job's log
PROGRESS = "always"


def run(config, name, label, out):
    bcfg = next(b for b in config["branches"] if b["name"] == name)
    opts = dict(bcfg["methods"][label])
    method = opts.pop("method", label)
    period = int(bcfg.get("period", 1))
    w0, w1 = (float(w) for w in bcfg["omega"])
    system = load_case(config["systems"][bcfg["system"]]["case"]).system
    if "max_points" in bcfg:
        opts["max_points"] = int(bcfg["max_points"])
    if bcfg.get("accuracy") is False:  # no per-point error estimates: the discretised equations only
        opts["accuracy"] = False
    t0 = time.perf_counter()
    extra = {}
    if "switch" in bcfg:
        # the period-k sweep over omega locates the period doubling; the branch is the period-2k one born there
        parent = mshbm.sweep(system, w0, w1, method, period=period, progress=PROGRESS, **opts)
        w_end = float(bcfg["switch"]["omega_end"])
        b = mshbm.switch_period_doubling(system, parent, w_end, **opts)
        extra = {"parent": {"omega": [w0, w1], "period": period, "success": parent.success,
                            "points": len(parent), "message": parent.message,
                            "bifurcations": parent.bifurcations}, "omega_end": w_end}
    else:
        b = mshbm.sweep(system, w0, w1, method, period=period, progress=PROGRESS, **opts)
    wall = time.perf_counter() - t0
    d = b.to_dict()
    d.pop("points", None)
    d.update(name=name, label=label, system=bcfg["system"], options=dict(opts, period=period, omega=[w0, w1], **extra),
             wall_time_s=wall, n_dofs=system.n)
    from mshbm.outfile import jsonable

    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(out, "w") as fh:
        json.dump(jsonable(d), fh, indent=1, allow_nan=False)
    print(f"{name} {label} ({method}) period {period}: {b.message} ({len(b)} points, {wall:.2f} s)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--branch", required=True)
    ap.add_argument("--method", required=True, help="the curve's label in config branches.<name>.methods")
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    with open(a.config) as fh:
        config = json.load(fh)
    run(config, a.branch, a.method, a.out)


if __name__ == "__main__":
    main()
