"""The frequency-amplitude curve of the conservative impact oscillator (e_N = 1) against its closed form (Fig. 11c,
rule ``backbone_impact``).

``m q'' + k q = lambda``, a rigid stop at ``q = g`` with Newton's law ``e_N = 1``, no damping: its nonlinear mode
is a family of periodic orbits of the free system (:mod:`mshbm.methods.modes`, ``xi = 0``).  Traced by
``mshbm.backbone`` with the exact event-driven flow, by shooting and by MS-HBM (the one DOF in time, ``n_h``
harmonics only for the connectivity), from ``a_start`` (below the stop: the linear orbit) to ``a_end``.  The
free amplitude ``A`` (the orbit's minimum is ``-A``) from the exact extrema, ``(max - min)/2 = (g + A)/2`` once
it impacts; the closed form: the free flight from the stop to ``-A`` and back, ``T(A) = 2 (pi - arccos(g / A)) /
omega_0`` (``2 pi / omega_0`` below the stop), so ``omega / omega_0`` grows from 1 to 2 as ``A / g`` grows.
Per method the largest ``|T / T(A) - 1|``, the largest ``|D|``, the points and the CPU time.

Parameters: config ``backbone.impact`` (``m``, ``k``, ``gap``, ``amplitude`` [a_start, a_end], ``points``,
``harmonics``).

Usage::

    python workflow/scripts/backbone/impact_backbone.py --config results/config.json --out impact.json
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

import mshbm

METHODS = ("shooting", "mshbm")


def closed_form_period(A, g, omega0):
    """``T(A)`` of the conservative impact oscillator (module docstring), s."""
    return 2 * (np.pi - np.arccos(np.minimum(g / np.asarray(A, dtype=float), 1.0))) / omega0


def run(cfg):
    m, k, g = float(cfg["m"]), float(cfg["k"]), float(cfg["gap"])
    w0 = float(np.sqrt(k / m))
    s = mshbm.System([[m]], [[0.0]], [[k]], [0.0], elements=[mshbm.Contact(0, g, 1.0)], name="impact-oscillator")
    a0, a1 = map(float, cfg["amplitude"])
    out = dict(model=dict(cfg, omega0=w0), methods={})
    for method in METHODS:
        c0 = time.process_time()
        b = mshbm.backbone(s, a0, a1, method=method, harmonics=int(cfg["harmonics"]), points=int(cfg["points"]))
        cpu = time.process_time() - c0
        d = b.to_dict()
        amp = b.amplitude[:, 0]
        hit = np.array(d["impacts"]) > 0
        A = np.where(hit, 2 * amp - g, amp)
        T = 2 * np.pi / b.omega
        err = T / closed_form_period(A, g, w0) - 1
        out["methods"][method] = dict(success=b.success, message=b.message, points=len(b), cpu_time_s=cpu,
                                      omega=b.omega.tolist(), A=A.tolist(), impacts=d["impacts"],
                                      damping_ratio=b.damping_ratio.tolist(), period_error=err.tolist(),
                                      max_period_error=float(np.max(np.abs(err))) if len(b) else None,
                                      max_abs_D=float(np.max(np.abs(b.damping_ratio))) if len(b) else None,
                                      certified=d["certified"])
    A = np.linspace(0.0, a1 * 1.1 / np.sqrt(m), 400)[1:]  # the closed form over the range drawn
    out["closed_form"] = dict(A=A.tolist(), omega=(2 * np.pi / closed_form_period(A, g, w0)).tolist())
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", required=True, help="results/config.json (section `backbone.impact`)")
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    with open(args.config) as fh:
        cfg = json.load(fh)["backbone"]["impact"]
    out = run(cfg)
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps({mth: {k: v[k] for k in ("success", "points", "max_period_error", "max_abs_D", "cpu_time_s")}
                      for mth, v in out["methods"].items()}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
