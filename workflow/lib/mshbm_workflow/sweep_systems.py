"""Sweep stress suite (workflow/scripts/stress/sweeps.py): the systems its sweeps trace.

A system of workflow/sweeps.yaml (``systems.<name>``) is one of

* ``{case: examples/X.yaml, set: {dotted.key: value}}`` -- a case file (:func:`mshbm.load_case`, ``set`` as
  ``mshbm solve --set``);
* ``{chain: {masses, stiffness, damping, forcing, elements}}`` -- :func:`mshbm.chain` (wall - spring - mass
  chain; ``forcing`` items as for :func:`mshbm.chain`);
* ``{beam: {...}}`` -- a cantilever Euler-Bernoulli beam of Hermite cubic elements
  (``build_fe_model.beam_matrices`` of workflow/scripts/fe), optionally a second cantilever (``second``: a lap
  joint between the two tips), lumped ``bodies`` tied to nodes by springs, and a Craig-Bampton reduction
  (``reduce: {modes: n_m}``, :func:`mshbm.reduction.craig_bampton`);
* ``{plate: {...}}`` -- a Kirchhoff plate clamped along one edge (``build_fe_model.plate_matrices``), with the
  same ``bodies``, ``elements`` and ``reduce``.

Elements (``elements``, a list): ``{type: friction | jenkins | contact, at: <where>, relative_to: <where>, ...}``
with the element's own parameters (``mu``, ``normal_force``, ``tangential_stiffness``, ``smoothing``, ``gap``,
``gap_ratio``, ``restitution``, ``penalty_stiffness``).  ``<where>`` is a DOF (chains), a node position
``x`` in (0, 1] of the beam's length (``{x: 1.0}``; ``{x: 1.0, beam: 2}`` on the second beam), a plate point
``{x, y}``, or ``{body: j}`` (body ``j`` of ``bodies``).  ``gap_ratio``: the gap is that fraction of the linear
amplitude of the element's DOF at the structure's first natural frequency ``w_1`` (elements removed), so that
the stop is hit near resonance in any units.

FE notation: ``n_el`` elements, ``L`` the length, ``b x h`` the section, ``E``, ``rho``; DOF ``2 (i - 1)`` is
``w`` of node ``i``; Rayleigh damping ``C = alpha M + beta K`` with the ratio ``zeta`` at the first two
natural frequencies; ``w_1`` (rad/s) the first natural frequency of the structure without elements (bodies
included).  Forcing ``{at: <where>, amplitude: F}`` (N, ``F cos(omega t)``).

Automatic reduction (:func:`time_reduction`): a system without ``reduce:`` (a chain, a beam or plate without it, a
case file without it) that a sweep's method integrates in time on stiff DOFs (the nodes of a fine mesh: local
frequency ``sqrt(K_dd / M_dd)`` above 200 ``omega``) is swept on the package's automatic Craig-Bampton reduction
(:func:`mshbm.reduction.auto_reduction`, as ``mshbm solve`` and ``mshbm sweep`` do for a case file), with its
error estimate in every point's certificate (workflow/lib/mshbm_workflow/sweep_runner.py).
"""
from __future__ import annotations

import importlib.util
from functools import lru_cache
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

import mshbm
from mshbm import Contact, Friction, Jenkins, System
from mshbm.reduction import craig_bampton, method_reduction

ROOT = Path(__file__).resolve().parents[3]


@lru_cache(maxsize=1)
def _fe():
    """workflow/scripts/fe/build_fe_model.py as a module (its beam and plate matrices, bodies, Rayleigh
    coefficients): the suite builds its FE models with the same elements as the FE example."""
    path = ROOT / "workflow" / "scripts" / "fe" / "build_fe_model.py"
    spec = importlib.util.spec_from_file_location("build_fe_model", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def natural_frequencies(M, K, count=2):
    """The ``count`` lowest natural frequencies (rad/s) of ``(M, K)`` (dense, for the suite's small models)."""
    M = M.toarray() if sp.issparse(M) else np.asarray(M, float)
    K = K.toarray() if sp.issparse(K) else np.asarray(K, float)
    lam = sla.eigh(K, M, eigvals_only=True, subset_by_index=[0, count - 1])
    return np.sqrt(np.maximum(lam, 0.0))


def linear_amplitude(system, omega, dof, relative_to=None):
    """Amplitude of DOF ``dof`` (of ``q_dof - q_relative_to``) in the linear response (elements removed) to
    the first-harmonic forcing."""
    M, C, K = (A.toarray() if sp.issparse(A) else np.asarray(A, float) for A in (system.M, system.C, system.K))
    f = np.asarray(system.f_hat, float)
    F = f[1] - 1j * f[2] if f.shape[0] > 2 else f[1]   # rows: constant, cos, sin of harmonic 1
    Q = np.linalg.solve(K - omega ** 2 * M + 1j * omega * C, F)
    return float(abs(Q[dof] - (0.0 if relative_to is None else Q[relative_to])))


# ------------------------------------------------------------------------------------------------ FE models
class _Mesh:
    """DOF lookup of a beam (or two) / plate model, and its bodies."""

    def __init__(self, kind, spec, n_struct, offsets):
        self.kind, self.spec, self.n_struct, self.offsets = kind, spec, n_struct, offsets
        self.bodies = []

    def dof(self, where):
        if isinstance(where, (int, np.integer)) and not isinstance(where, bool):
            return int(where)
        if "body" in where:
            return self.n_struct + int(where["body"])
        if self.kind == "beam":
            beam = int(where.get("beam", 1))
            n_el = self.spec["n_el"] if beam == 1 else self.spec["second"]["n_el"]
            d, _ = _fe().node_dof(float(where["x"]), n_el)
            return self.offsets[beam - 1] + d
        return _fe().plate_w_dof(float(where["x"]), float(where.get("y", 0.0)), self.spec["nx"], self.spec["ny"])


def _beam_structure(spec):
    fe = _fe()
    geo = {k: spec[k] for k in ("length", "young", "density", "width", "height") if k in spec}
    M1, K1 = fe.beam_matrices(spec["n_el"], **geo)
    blocks_M, blocks_K, offsets = [M1], [K1], [0]
    if "second" in spec:
        s2 = dict(geo, **{k: v for k, v in spec["second"].items() if k != "n_el"})
        M2, K2 = fe.beam_matrices(spec["second"]["n_el"], **s2)
        offsets.append(M1.shape[0])
        blocks_M.append(M2)
        blocks_K.append(K2)
    M = sp.block_diag(blocks_M, format="csr")
    K = sp.block_diag(blocks_K, format="csr")
    return M, K, offsets


def _plate_structure(spec):
    keys = ("lx", "ly", "thickness", "young", "poisson", "density")
    M, K = _fe().plate_matrices(spec["nx"], spec["ny"], **{k: spec[k] for k in keys if k in spec})
    return M, K, [0]


def _element(kind, dof, rel, params):
    params = dict(params)
    params.pop("gap_ratio", None)
    if kind == "contact":
        return Contact(dof, relative_to=rel, **params)
    if kind == "jenkins":
        return Jenkins(dof, relative_to=rel, **params)
    if kind == "friction":
        return Friction(dof, relative_to=rel, **params)
    raise ValueError(f"element type {kind!r} (friction, jenkins or contact)")


def _elements(specs, dof_of, linear_system=None, w1=None):
    """The elements of ``specs`` (module docstring); ``gap_ratio`` needs the linear system and ``w_1``."""
    out = []
    for e in specs or ():
        e = dict(e)
        kind = e.pop("type")
        dof = dof_of(e.pop("at"))
        rel = e.pop("relative_to", None)
        rel = None if rel is None else dof_of(rel)
        if "gap_ratio" in e:
            amp = linear_amplitude(linear_system, w1, dof, rel)
            e["gap"] = float(e["gap_ratio"]) * amp
        out.append(_element(kind, dof, rel, e))
    return out


def fe_system(kind, spec, name):
    """``(system, w_1, info)`` of a ``beam`` or ``plate`` spec (module docstring); ``info`` describes the model
    (DOFs, ``w_1``, the reduction)."""
    fe = _fe()
    M, K, offsets = _beam_structure(spec) if kind == "beam" else _plate_structure(spec)
    mesh = _Mesh(kind, spec, M.shape[0], offsets)
    w1_struct = natural_frequencies(M, K, 1)[0]
    bodies = spec.get("bodies") or []
    if bodies:
        m_total = float(M.sum()) if kind == "plate" else float(np.sum(M.diagonal()))
        nodes, masses, springs = [], [], []
        for b in bodies:
            m_b = float(b.get("mass_ratio", 0.01)) * m_total
            nodes.append(mesh.dof(b["at"]))
            masses.append(m_b)
            springs.append(m_b * (float(b.get("freq_ratio", 20.0)) * w1_struct) ** 2)
        for node, m_b, k_b in zip(nodes, masses, springs):
            M, K = fe.attach_bodies(M, K, [node], m_b, k_b)
    w = natural_frequencies(M, K, 2)
    alpha, beta = fe.rayleigh_coefficients(w[0], w[1], float(spec.get("zeta", 0.01)))
    C = alpha * M + beta * K
    n = M.shape[0]
    f_hat = np.zeros((3, n))
    for item in spec["forcing"]:
        f_hat[1, mesh.dof(item["at"])] += float(item["amplitude"])
    linear = System(M, C, K, f_hat, (), name=name)
    elements = _elements(spec.get("elements"), mesh.dof, linear, w[0])
    system = System(M, C, K, f_hat, elements, name=name)
    info = {"dofs": n, "w1": float(w[0]), "w2": float(w[1]), "alpha": float(alpha), "beta": float(beta),
            "auto_reduce": not spec.get("reduce")}
    if spec.get("reduce"):
        red = craig_bampton(system, int(spec["reduce"]["modes"]), keep=[mesh.dof(k) for k in
                                                                         spec["reduce"].get("keep", [])])
        system = red.system
        system.name = name
        info.update(reduced_dofs=int(system.n), reduction_modes=int(spec["reduce"]["modes"]))
    return system, float(w[0]), info


# --------------------------------------------------------------------------------------------- other systems
def chain_system(spec, name):
    """``(system, w_1, info)`` of a ``chain`` spec: :func:`mshbm.chain` with elements at DOFs."""
    masses = [float(m) for m in spec["masses"]]
    forcing = [dict(f) for f in spec["forcing"]]
    linear = mshbm.chain(masses, spec["stiffness"], spec.get("damping", 0.0), forcing=forcing, name=name)
    M, K = linear.M, linear.K
    w1 = natural_frequencies(M, K, 1)[0]
    elements = _elements(spec.get("elements"), int, linear, w1)
    system = mshbm.chain(masses, spec["stiffness"], spec.get("damping", 0.0), forcing=forcing, elements=elements,
                         name=name)
    return system, float(w1), {"dofs": len(masses), "w1": float(w1), "auto_reduce": True}


def case_system(spec, name):
    """``(system, w_1, info)`` of a case file (``case``), with ``set`` assignments."""
    sets = [f"{k}={v}" for k, v in (spec.get("set") or {}).items()]
    case = mshbm.load_case(ROOT / spec["case"], sets=sets or None)
    system = case.system
    system.name = name
    w1 = natural_frequencies(system.M, system.K, 1)[0]
    return system, float(w1), {"dofs": int(system.n), "w1": float(w1), "case": spec["case"],
                                "auto_reduce": bool(case.auto_reduce and case.reduction is None)}


def build(spec, name):
    """``(system, w_1, info)`` of the suite's system spec (module docstring)."""
    if "case" in spec:
        return case_system(spec, name)
    if "chain" in spec:
        return chain_system(spec["chain"], name)
    if "beam" in spec:
        return fe_system("beam", spec["beam"], name)
    if "plate" in spec:
        return fe_system("plate", spec["plate"], name)
    raise ValueError(f"system {name}: one of case, chain, beam, plate")


def time_reduction(system, info, method, options, omega):
    """The automatic Craig-Bampton reduction a sweep of ``system`` with ``method`` and ``options`` (the sweep's,
    ``harmonics`` among them) is traced on, or ``None``: :func:`mshbm.reduction.auto_reduction` at ``omega`` (rad/s,
    the range's highest, as ``mshbm sweep``) when ``info["auto_reduce"]`` (the system has no ``reduce:``), no
    ``partition`` is given and the method integrates stiff DOFs in time (module docstring)."""
    if not info.get("auto_reduce"):
        return None
    return method_reduction(system, float(omega), method, options)
