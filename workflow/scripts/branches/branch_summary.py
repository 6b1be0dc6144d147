#!/usr/bin/env python
"""Summary of the frequency-response curves (Fig. 9): the branches of rule ``branch`` and the numbers of
the paper (``{{branches.<key>}}``).

    python workflow/scripts/branches/branch_summary.py --out results/summary/branches.json BRANCH.json ...

Numbers per branch ``<name>_<label>`` (the label of the curve in the config, ``-`` as ``_``) (period-k branches are their own names): ``ok`` (reached the end
of the range), ``points``, ``time`` (s), ``omega_reached`` (the last frequency of the branch), ``stable``,
``unstable`` and ``undecided`` point counts, ``amp_at_pi5`` (mass 1 at the paper's ω = π/5, interpolated), and per bifurcation type the first frequency found
(``pd``, ``ns``, ``fold``, ``grazing``; null if none).  Where a method is traced both with Moreau–Jean
steps (label ``<method>``) and with the event-driven flow (label ``<method>-event``): ``<name>_<method>_pd_shift``,
the relative shift of the first period doubling, pd(Moreau–Jean) / pd(event-driven) − 1.  Where the name has a
``shooting-event`` curve (the exact reference): ``<p>_dev_event``, the largest relative deviation of every other
curve's mass-1 amplitude from it, and ``<p>_dev_event_omega``, where.
"""
from __future__ import annotations

import argparse
import json
import math
import os

KEYS = {"period-doubling": "pd", "neimark-sacker": "ns", "fold": "fold", "grazing": "grazing"}


def amplitude_at(omega, amplitude, w, dof=0):
    """The amplitude of ``dof`` at frequency ``w``, interpolated linearly between the first two consecutive
    points of the branch that bracket ``w``; None if no segment does."""
    for i in range(len(omega) - 1):
        a, b = omega[i], omega[i + 1]
        if min(a, b) <= w <= max(a, b) and a != b:
            s = (w - a) / (b - a)
            return (1 - s) * amplitude[i][dof] + s * amplitude[i + 1][dof]
    return None


def prefix(name, label):
    """The paper's key prefix of a curve: ``<name>_<label>`` with ``-`` as ``_``."""
    return f"{name}_{label.replace('-', '_')}"


def summarize(branches):
    num, rows = {}, []
    for b in branches:
        label = b.get("label", b["method"])
        p = prefix(b["name"], label)
        st = b["stable"]
        omega = b["omega"]
        num[f"{p}_ok"] = bool(b["success"])
        num[f"{p}_message"] = b["message"]  # where and why a sweep stopped
        num[f"{p}_points"] = len(omega)
        num[f"{p}_time"] = float(b["wall_time_s"])
        num[f"{p}_steps"] = b["options"].get("steps")  # time steps (or event-search sub-steps) per period
        num[f"{p}_harmonics"] = b["options"].get("harmonics")  # n_h of HBM, DLFT and MS-HBM (None: shooting)
        num[f"{p}_omega_reached"] = omega[-1] if omega else None
        num[f"{p}_omega_min"] = min(omega) if omega else None
        num[f"{p}_omega_max"] = max(omega) if omega else None
        num[f"{p}_stable"] = sum(v is True for v in st)
        num[f"{p}_unstable"] = sum(v is False for v in st)
        num[f"{p}_undecided"] = sum(v is None for v in st)
        num[f"{p}_stable_first"] = st[0] if st else None  # the verdict at the start frequency
        num[f"{p}_amp_first"] = b["amplitude"][0][0] if b["amplitude"] else None  # DOF 0 at the start
        num[f"{p}_amp_last"] = b["amplitude"][-1][0] if b["amplitude"] else None  # DOF 0 at the end
        num[f"{p}_amp_at_pi5"] = amplitude_at(omega, b["amplitude"], math.pi / 5)  # DOF 0 at the paper's omega
        for t, k in KEYS.items():
            ws = [f["omega"] for f in b["bifurcations"] if f["type"] == t]
            num[f"{p}_{k}"] = min(ws) if ws else None
            num[f"{p}_{k}_count"] = len(ws)
        rows.append({"name": b["name"], "label": label, "method": b["method"], "period": b["period"], "system": b["system"],
                     "success": b["success"], "message": b["message"], "points": len(omega),
                     "wall_time_s": b["wall_time_s"], "omega": omega, "amplitude": b["amplitude"], "stable": st,
                     "bifurcations": b["bifurcations"], "options": b["options"], "n_dofs": b.get("n_dofs")})
    # a method traced twice, with Moreau-Jean steps and with the exact event-driven flow: the relative shift of
    # its first period doubling, <name>_<method>_pd_shift = pd(Moreau-Jean) / pd(event-driven) - 1
    for r in rows:
        p = prefix(r["name"], r["label"])
        ev = f"{p}_event_pd"
        if num.get(ev) and num.get(f"{p}_pd"):
            num[f"{p}_pd_shift"] = num[f"{p}_pd"] / num[ev] - 1.0
    # every curve of a name that also has the exact event-driven shooting curve (label "shooting-event"):
    # <p>_dev_event = max over the curve's points of |A / A_event - 1| (mass 1, the event curve interpolated
    # at the point's omega, points outside its range skipped) and <p>_dev_event_omega where it occurs
    for r in rows:
        ref = next((q for q in rows if q["name"] == r["name"] and q["label"] == "shooting-event"), None)
        if ref is None or ref is r:
            continue
        devs = []
        for w, a in zip(r["omega"], r["amplitude"]):
            a_ref = amplitude_at(ref["omega"], ref["amplitude"], w)
            if a_ref:
                devs.append((abs(a[0] / a_ref - 1.0), w))
        p = prefix(r["name"], r["label"])
        dev, w_dev = max(devs) if devs else (None, None)
        num[f"{p}_dev_event"], num[f"{p}_dev_event_omega"] = dev, w_dev
    return {"rows": rows, "numbers": num}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("branches", nargs="+")
    a = ap.parse_args(argv)
    data = []
    for path in a.branches:
        with open(path) as fh:
            data.append(json.load(fh))
    out = summarize(data)
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    with open(a.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(f"{len(data)} branches -> {a.out}")


if __name__ == "__main__":
    main()
