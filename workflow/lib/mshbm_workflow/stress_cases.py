"""Stress suite (workflow/scripts/stress/stress.py): its configuration and the cases it solves.

The configuration (workflow/stress.yaml, validated against workflow/schemas/stress.schema.yaml)
names the paper's systems by their case files (examples/*.yaml, read with ``mshbm.load_case``);
:func:`random_system` draws the random chains; :func:`plan` lists the groups of work of a profile.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import scipy.linalg as sla

from mshbm import Contact, Friction, InputError, chain

from mshbm_workflow import wfcore

SCHEMA = Path(__file__).resolve().parents[2] / "schemas" / "stress.schema.yaml"


def load_config(path):
    """Read and validate ``workflow/stress.yaml`` (jsonschema); raises ``ValueError`` with the failing key."""
    cfg = wfcore.load_validated_yaml(path, SCHEMA)
    for prof in cfg["profiles"].values():
        names = list(prof["resonance"]["systems"]) + list(prof["starts"]["systems"])
        names += [prof["stiff"][k]["system"] for k in ("kappa", "penalty", "harmonics", "steps")]
        for name in names:
            if name not in cfg["systems"]:
                raise ValueError(f"{path}: system {name!r} is not defined under systems")
    for name in cfg["systems"]:
        try:
            load_system(cfg, name)
        except InputError as exc:
            raise ValueError(f"{path}: systems.{name}: {cfg['systems'][name]}: {exc}") from None
    return cfg


def load_system(cfg, name, kappa=None, penalty=None):
    """The system ``name`` of the config: its case file (``systems.<name>``, examples/*.yaml), with the
    arctan smoothing ``kappa`` of its friction element or the penalty stiffness of its contact
    replaced when given."""
    element = {}
    if kappa is not None:
        element["smoothing"] = float(kappa)
    if penalty is not None:
        element["penalty_stiffness"] = float(penalty)
    return wfcore.chain_case(cfg["systems"][name], None, name=name, **element)


def as_list(x):
    return list(x) if isinstance(x, (list, tuple)) else [x]


def linear_resonances(system):
    """Eigenfrequencies (rad/s) of the linear subsystem ``(K_LL, M_LL)`` (element DOFs removed)."""
    Ld = np.setdiff1d(np.arange(system.n), system.nonlinear_dofs)
    if Ld.size == 0:
        return np.zeros(0)
    K = system.dense("K")[np.ix_(Ld, Ld)]
    M = system.dense("M")[np.ix_(Ld, Ld)]
    lam = sla.eigh(K, M, eigvals_only=True)
    return np.sqrt(np.clip(lam, 0.0, None))


def random_system(rng, index, max_dofs):
    """A random chain: masses, stiffnesses and dampings over several decades, one element on a random DOF.

    Returns ``(system, omega, description)``.
    """
    n = int(round(math.exp(rng.uniform(0.0, math.log(max_dofs)))))
    n = min(max(n, 1), max_dofs)
    masses = 10.0 ** rng.uniform(-2, 2, n)
    stiff = 10.0 ** rng.uniform(-2, 2, n)
    zeta = 0.0 if rng.random() < 0.25 else 10.0 ** rng.uniform(-3, -0.5)
    damp = zeta * 2.0 * np.sqrt(stiff * np.minimum(masses, np.roll(masses, 1)))
    d_force = int(rng.integers(n))
    amp = 10.0 ** rng.uniform(-1, 1)
    probe = chain(list(masses), list(stiff), list(damp), forcing=[{"dof": d_force, "amplitude": amp}])
    lam = sla.eigh(probe.dense("K"), probe.dense("M"), eigvals_only=True)
    w = np.sqrt(np.clip(lam, 1e-12, None))
    j = int(rng.integers(min(n, 5)))  # one of the five lowest modes
    omega = float(w[j] * rng.uniform(0.6, 1.4))
    d_el = int(rng.integers(n))
    # amplitude scale of the element DOF in the linear response (for gaps and friction bounds)
    from mshbm.methods.common import linear_response

    qh = linear_response(probe, omega, 1)
    scale = float(np.hypot(qh[1, d_el], qh[2, d_el])) or 1e-3
    if rng.random() < 0.5:
        # friction bound: a fraction of the force the linear response would need at that DOF
        fscale = scale * float(probe.dense("K")[d_el, d_el] + masses[d_el] * omega ** 2)
        bound = fscale * 10.0 ** rng.uniform(-1.5, 0)
        mu = 10.0 ** rng.uniform(-1, 0)
        el = Friction(d_el, mu, bound / mu, smoothing=1000.0 / max(scale * omega, 1e-12))
        kind = f"friction@{d_el}"
    else:
        gap = scale * 10.0 ** rng.uniform(-2, -0.05)
        e = float(rng.choice([0.0, 0.5, 0.9, 1.0]))
        kc = 100.0 * float(np.max(stiff) + np.max(masses) * omega ** 2)
        el = Contact(d_el, gap, e, kc, 0.0)
        kind = f"contact@{d_el}(e={e:g})"
    system = chain(list(masses), list(stiff), list(damp), forcing=[{"dof": d_force, "amplitude": amp}],
                   elements=[el], name=f"random{index}")
    desc = (f"random{index}: n={n}, m in [{masses.min():.2g}, {masses.max():.2g}], "
            f"k in [{stiff.min():.2g}, {stiff.max():.2g}], zeta={zeta:.2g}, {kind}, force@{d_force}")
    return system, omega, desc


def plan(cfg, profile):
    """List of work groups ``(function name, kwargs, label)``."""
    P = cfg["profiles"][profile]
    out = []
    res = P["resonance"]
    for sysname in res["systems"]:
        system = load_system(cfg, sysname)
        g = res["omega_grid"]
        oms = [(float(w), "grid") for w in np.linspace(g["start"], g["stop"], g["num"])] if g["num"] else []
        wr = linear_resonances(system)
        for m in res["resonances"]["modes"]:
            if m >= wr.size:
                continue
            for k in res["resonances"]["harmonics"]:
                for off in res["resonances"]["offsets"]:
                    w = float(wr[m] / k * (1 + off))
                    if g["start"] <= w <= g["stop"]:
                        oms.append((w, f"omega_{m + 1}/{k}*(1{off:+.0e})" if off else f"omega_{m + 1}/{k} exactly"))
        for w, tag in oms:
            out.append(("group_resonance", dict(sysname=sysname, omega=w, tag=tag, methods=res["methods"]),
                        ("resonance", sysname, w)))
    st = P["stiff"]
    for kind in ("kappa", "penalty", "harmonics", "steps"):
        spec = st[kind]
        for opi in as_list(spec["omega_over_pi"]):
            w = float(opi) * math.pi
            if kind in ("kappa", "penalty"):
                values = [float(v) for v in spec["values"]]
            elif kind == "harmonics":
                values = [("mshbm", int(v)) for v in spec["mshbm"]] + [("hbm", int(v)) for v in spec["hbm"]]
            else:
                values = [("mshbm", int(v)) for v in spec["mshbm"]] + [("shooting", int(v)) for v in spec["shooting"]]
                if spec.get("shooting_big"):
                    values.append(("shooting", int(spec["shooting_big"])))
            for v in values:
                out.append(("group_stiff", dict(kind=kind, spec=spec, value=v, omega=w), ("stiff", spec["system"], w)))
    sp = P["starts"]
    for sysname in sp["systems"]:
        for opi in as_list(sp["omega_over_pi"]):
            for method, mo in sp["methods"].items():
                out.append(("group_starts", dict(sysname=sysname, omega=float(opi) * math.pi, method=method,
                                                 mopts=dict(mo), starts=sp["starts"]),
                            ("starts", sysname, float(opi) * math.pi)))
    for i in range(sp.get("random", {}).get("count", 0)):
        for method, mo in sp["methods"].items():
            rnd = {"seed": sp["random"]["seed"], "index": i, "max_dofs": sp["random"]["max_dofs"]}
            out.append(("group_starts", dict(sysname=f"start-random{i}", omega=1.0, method=method, mopts=dict(mo),
                                             starts=sp["starts"], random=rnd), ("starts", f"start-random{i}", None)))
    rd = P["random"]
    for i in range(rd["count"]):
        out.append(("group_random", dict(index=i, seed=rd["seed"], max_dofs=rd["max_dofs"], methods=rd["methods"]),
                    ("random", f"random{i}", None)))
    return out
