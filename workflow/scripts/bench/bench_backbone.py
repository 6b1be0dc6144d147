"""Benchmark: the backbone (EPMC, :func:`mshbm.backbone`) of the first bending mode of a 100-DOF
finite-element cantilever with one Jenkins joint, and the peaks of forced responses against it.

Beam: ``build_fe_model.beam_matrices`` with 50 Hermite elements (100 DOFs; steel, 1 m x 0.04 m x 0.01 m),
Rayleigh damping ``zeta = ZETA`` at the first two bending frequencies; the joint: a Jenkins element (stiffness
``K_T``, slip force ``MU_N``) from the transverse DOF at mid-span to the ground.  Timing: the process CPU time
of one 50-point backbone (``points=50``, modal amplitude ``A_START .. A_END``, ``n_h = 5``), a goal of 20 s.

The peaks of forced responses against the backbone are tested on a 3-DOF chain
(``tests/unit/test_backbone.py::test_backbone_passes_through_forced_peaks``) and measured on a jointed beam
(Fig. 11, ``workflow/scripts/backbone/backbone_curve.py``).  Run by rule ``backbone_timing``
(``results/backbone/timing.json``, quoted in the paper's Sec. 5.9) or stand-alone:
``python workflow/scripts/bench/bench_backbone.py [--out F]`` (measure with ``OPENBLAS_NUM_THREADS=1`` on a
shared machine; ``mshbm.backbone`` itself runs its BLAS on one thread).
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

import mshbm

_spec = importlib.util.spec_from_file_location(
    "build_fe_model", Path(__file__).resolve().parents[1] / "fe" / "build_fe_model.py")
fe = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fe)

N_EL, ZETA, K_T, MU_N = 50, 0.002, 1e4, 1.0
A_START, A_END, N_H, POINTS = 1e-5, 1e-1, 5, 50


def beam(zeta=ZETA, k_t=K_T, mu_n=MU_N, forcing=0.0):
    """The 100-DOF beam with the joint at mid-span (``System``; forcing ``forcing`` N at the tip)."""
    M, K = fe.beam_matrices(N_EL)
    M, K = sp.csr_matrix(M), sp.csr_matrix(K)
    w = fe.natural_frequencies(M, K, 2)
    alpha, beta = fe.rayleigh_coefficients(w[0], w[1], zeta)
    n = M.shape[0]
    f = np.zeros((3, n))
    f[1, n - 2] = forcing
    joint = fe.node_dof(0.5, N_EL)[0]
    return mshbm.System(M, alpha * M + beta * K, K, f, elements=[mshbm.Jenkins(joint, 1.0, mu_n,
                                                                               tangential_stiffness=k_t)],
                        name="fe-beam-100-jenkins")


def time_backbone(points=POINTS):
    s = beam()
    c0, t0 = time.process_time(), time.perf_counter()
    b = mshbm.backbone(s, A_START, A_END, harmonics=N_H, points=points, dofs=[s.n - 2])
    return b, time.process_time() - c0, time.perf_counter() - t0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    b, cpu, wall = time_backbone()
    row = dict(system="fe-beam-100-jenkins", n_dofs=100, harmonics=N_H, steps=b.steps, points=len(b),
               success=b.success, cpu_time_s=cpu, wall_time_s=wall,
               omega=[float(b.omega[0]), float(b.omega[-1])], damping_ratio=[float(b.damping_ratio[0]),
                                                                            float(b.damping_ratio.max())])
    print(json.dumps(row, indent=1))
    if args.out:
        Path(args.out).write_text(json.dumps(row, indent=1) + "\n")


if __name__ == "__main__":
    main()
