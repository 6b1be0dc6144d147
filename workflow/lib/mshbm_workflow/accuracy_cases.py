"""Systems, exact references and the plan of the accuracy suite (workflow/scripts/stress/accuracy.py,
configuration workflow/accuracy.yaml).

A *system case* is a dict ``{"id", "family", "params", "scale"}``; :func:`build_system` makes the
:class:`mshbm.System`, :func:`reference` the exact amplitudes ``A_i = (max - min) / 2`` (m, one per DOF) with the
source of the reference.  Families:

``impact``   ``x'' + 2 zeta x' + x = cos(omega t)``, stop at ``sigma``, restitution ``e``: the closed-form (1,1)
             orbit (:func:`mshbm_workflow.accuracy_refs.impact_11`).
``coulomb``  ``x'' + 2 zeta x' + x + R sign(x') = cos(omega t)``: Den Hartog's continuous-motion orbit
             (:func:`mshbm_workflow.accuracy_refs.coulomb`).
``rotating`` isotropic 2-DOF ``m = k = 1``, damping ``c``, rotating force ``(cos, sin)(omega t)``, 3-D friction
             ``mu N``: the circular orbit (:func:`mshbm_workflow.accuracy_refs.rotating_radius`).
``chain``    a random wall-spring-mass chain (``n`` masses) with a stop and a Coulomb slider: the exact event-driven
             flow (shooting, ``integrator="event"``, Newton tolerance ``reference_tol``) is the reference; the
             methods that use that flow are not run on it (they are not independent of it).

``scale`` copies a case in other units: ``{"kind": "force", "factor": s}`` multiplies forcing, normal loads and
gaps by ``s`` (exact amplitudes times ``s``); ``{"kind": "mm"}`` measures lengths in mm (``M, C, K`` times 1e-3 in
N s^2/mm, N s/mm, N/mm; gaps times 1e3; forces unchanged: amplitudes times 1e3).
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from mshbm import Contact, Friction, System, frictional_contact

from .accuracy_refs import coulomb, impact_11, rotating_radius
from .wfcore import load_validated_yaml

__all__ = ["load_config", "plan_systems", "build_system", "reference", "methods_for", "event_methods"]


#: the configuration's schema
SCHEMA = Path(__file__).resolve().parents[2] / "schemas" / "accuracy.schema.yaml"


def load_config(path, schema=SCHEMA):
    """Read and validate workflow/accuracy.yaml; ``ValueError`` naming the failing key."""
    return load_validated_yaml(path, schema)


def _scale(case):
    sc = case.get("scale") or {}
    if sc.get("kind") == "force":
        return 1.0, float(sc["factor"])  # matrix factor, length factor of gaps and amplitudes (= force factor)
    if sc.get("kind") == "mm":
        return 1e-3, 1e3
    return 1.0, 1.0


def build_system(case):
    """The :class:`mshbm.System` of a system case (module docstring)."""
    p, fam = case["params"], case["family"]
    mat, length = _scale(case)
    force = length * mat  # a force scale: k x with k * mat and x * length
    if fam in ("impact", "coulomb"):
        M, C, K = np.eye(1) * mat, np.eye(1) * 2.0 * p["zeta"] * mat, np.eye(1) * mat
        fh = np.zeros((3, 1))
        fh[1, 0] = force
        els = ([Contact(0, p["sigma"] * length, p["e"])] if fam == "impact" else [Friction(0, 1.0, p["R"] * force)])
    elif fam == "rotating":
        M, C, K = np.eye(2) * mat, np.eye(2) * p["c"] * mat, np.eye(2) * mat
        fh = np.zeros((3, 2))
        fh[1, 0] = fh[2, 1] = force
        els = frictional_contact(0, 1, p["mu"], p["N"] * force)
    elif fam == "chain":
        n = len(p["m"])
        M = np.diag(p["m"]) * mat
        K, C = np.zeros((n, n)), np.zeros((n, n))
        for i in range(n):
            for A, v in ((K, p["k"][i]), (C, p["c"][i])):
                A[i, i] += v
                if i > 0:
                    A[i - 1, i - 1] += v
                    A[i - 1, i] -= v
                    A[i, i - 1] -= v
        K, C = K * mat, C * mat
        fh = np.zeros((3, n))
        fh[1, p["force_dof"]] = force
        els = [Contact(p["contact_dof"], p["gap"] * length, p["e"]),
               Friction(p["friction_dof"], 1.0, p["R"] * force)]
    else:
        raise ValueError(f"unknown family {fam!r}")
    return System(M, C, K, fh, els, name=case["id"])


def reference(case, cfg):
    """``(amplitudes (m), source)`` of a system case, or ``(None, why)``."""
    p, fam = case["params"], case["family"]
    _, length = _scale(case)
    if fam == "impact":
        r = impact_11(p["omega"], p["zeta"], p["sigma"], p["e"])
        return (None, "no admissible (1,1) orbit") if r is None else (
            np.array([r["amplitude"] * length]), "closed form (1,1)" + (" sticking" if r.get("sticking") else ""))
    if fam == "coulomb":
        r = coulomb(p["omega"], p["zeta"], p["R"])
        return (None, "no continuous-motion orbit") if r is None else (np.array([r["amplitude"] * length]),
                                                                          "closed form (Den Hartog)")
    if fam == "rotating":
        r = rotating_radius(p["omega"], 1.0, p["c"], 1.0, p["mu"], p["N"], 1.0)
        return (None, "F <= mu N") if r is None else (np.array([r, r]) * length, "closed form (circular orbit)")
    import mshbm

    try:
        sol = mshbm.solve(build_system(case), p["omega"], "shooting", integrator="event", stability=False,
                          tol=float(cfg["reference_tol"]), max_time=float(cfg["max_time_s"]))
    except mshbm.InputError as exc:  # e.g. a contact and a friction element on one DOF
        return None, f"event-driven flow refused: {exc}"[:200]
    if not sol.success:
        return None, "event-driven flow failed: " + str(sol.message)[:200]
    return np.asarray(sol.amplitude, dtype=float), "event-driven flow"


def _grid(spec):
    keys = list(spec)
    for vals in itertools.product(*(spec[k] for k in keys)):
        yield dict(zip(keys, (float(v) for v in vals)))


def _random_chain(rng, index, dofs):
    n = int(rng.integers(dofs[0], dofs[1] + 1))
    m = rng.uniform(0.5, 2.0, n)
    k = rng.uniform(0.5, 2.0, n)
    c = rng.uniform(0.02, 0.1, n) * np.sqrt(k)
    # frequency near one of the lowest two modes of the linear chain (elements removed)
    Kl = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(np.diag(m), Kl)).real))
    omega = float(w[int(rng.integers(0, min(2, n)))] * rng.uniform(0.8, 1.2))
    return {"m": m.tolist(), "k": k.tolist(), "c": c.tolist(), "omega": omega, "force_dof": n - 1,
            "contact_dof": int(rng.integers(0, n)), "gap": float(rng.uniform(0.1, 0.5)),
            "e": float(rng.choice([0.0, 0.5, 0.9])), "friction_dof": int(rng.integers(0, n)),
            "R": float(rng.uniform(0.05, 0.3))}


def plan_systems(prof):
    """The system cases of a profile (without references)."""
    out = []
    for p in _grid(prof.get("impact", {})) if prof.get("impact") else ():
        out.append({"family": "impact", "params": p,
                    "id": "impact z{zeta:g} w{omega:g} s{sigma:g} e{e:g}".format(**p)})
    for p in _grid(prof.get("coulomb", {})) if prof.get("coulomb") else ():
        out.append({"family": "coulomb", "params": p, "id": "coulomb z{zeta:g} w{omega:g} R{R:g}".format(**p)})
    for p in _grid(prof.get("rotating", {})) if prof.get("rotating") else ():
        out.append({"family": "rotating", "params": p,
                    "id": "rotating c{c:g} w{omega:g} muN{N:g}".format(**dict(p, N=p["mu"] * p["N"]))})
    ch = prof.get("chains")
    if ch:
        rng = np.random.default_rng(int(ch["seed"]))
        for i in range(int(ch["count"])):
            p = _random_chain(rng, i, ch["dofs"])
            out.append({"family": "chain", "params": p, "id": f"chain{i} n{len(p['m'])}"})
    for c in out:
        c["scale"] = None
    sc = prof.get("scaled")
    if sc:
        base = list(out)
        for j, c in enumerate(base[::int(sc["every"])]):
            for kind in sc["kinds"]:
                s = {"kind": "force", "factor": float(sc["force_factor"])} if kind == "force" else {"kind": "mm"}
                tag = f"F x{s['factor']:g}" if kind == "force" else "mm"
                out.append(dict(c, scale=s, id=f"{c['id']} [{tag}]"))
    return _interleave(out)


def _interleave(cases):
    """The cases taken in turn from each group (family, and the scaled copies as a group of their own), so that
    a run stopped early has covered every group."""
    groups = {}
    for c in cases:
        groups.setdefault("scaled" if c["scale"] else c["family"], []).append(c)
    out, queues = [], [list(g) for g in groups.values()]
    while any(queues):
        for q in queues:
            if q:
                out.append(q.pop(0))
    return out


#: methods that use the exact event-driven flow (not run where that flow is the reference)
def event_methods(variants):
    return {name for name, v in variants.items() if v.get("integrator") == "event"}


def methods_for(case, variants):
    """The method variants (names of ``variants``) that apply to a system case."""
    names = list(variants)
    if case["family"] == "rotating":  # the 3-D friction pair: no event-driven flow
        names = [n for n in names if variants[n].get("integrator") != "event"]
    if case["family"] == "chain":  # the event flow is the reference
        names = [n for n in names if n not in event_methods(variants)]
    return names
