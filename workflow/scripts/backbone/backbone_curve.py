"""The backbone of a jointed beam by one harmonic-balance method, and its forced responses at several levels
(Fig. 11, rule ``backbone_curve``).

The structure: a steel cantilever (``build_fe_model.beam_matrices``, ``n_el`` Hermite elements, 1 m x 0.04 m x
0.01 m), Rayleigh damping ``zeta`` at its first two bending frequencies, and a Jenkins joint (stiffness ``k_t``
N/m, slip force ``mu_N`` N) from the transverse DOF nearest ``x_joint L`` to the ground.  How each method
writes the joint:

* ``hbm`` (and ``mshbm``): the Jenkins element itself (its set-valued law, marched over the AFT samples; MS-HBM:
  the joint's DOF and its slider by Moreau-Jean, :data:`MSHBM_STEPS` steps per period, the rest condensed per
  harmonic);
* ``dlft``: DLFT takes ground Coulomb friction only, so the joint is a shoe, a body of mass
  ``m_s = k_t / (r omega_1)^2`` (``r = body_freq_ratio``, ``omega_1`` the free beam's first bending
  frequency) tied to the joint's DOF by the spring ``k_t``, with Coulomb friction ``mu_N`` to the ground.  As
  ``r`` grows this is the Jenkins element; at ``r = 20`` the shoe is ~5e-4 of the beam's mass.

Notation (:mod:`mshbm.methods.epmc`): ``a`` the mass-normalised modal amplitude of the first harmonic
(kg^1/2 m) of the backbone's mode ``phi`` (of ``(K_0, M)``: the Jenkins joint stuck; DLFT's shoe model: the
shoe free, its friction not being a stiffness); ``D`` the damping ratio.  The two methods' ``a`` therefore differ
by a factor near 1; the figure compares them at equal tip amplitude.

Forcing levels.  ``F cos(omega t)`` at the tip.  The level whose resonance is aimed at modal amplitude
``a_k`` (config ``peak_amplitudes``) is chosen from the method's own backbone by the single-mode energy
balance at phase resonance, ``F_k = 2 D(a_k) omega(a_k)^2 a_k / |phi_tip|`` (so the peaks land from
micro- to macro-slip); where the peak then lies is measured, not assumed.

Forced responses.  Pointwise :func:`mshbm.solve` with warm starts, descending in omega from the top of the
backbone's range ``[omega_min, omega_max]`` widened by ``scan_margin`` (the backbone softens: from above, the
branch climbs to its peak), in ``scan_points`` equal steps over that range, until the amplitude has fallen
below :data:`STOP` times the peak's.  The peak (largest tip amplitude) is refined by Brent's
method on the pointwise solves (tolerance 1e-9 relative in omega).  Its deviation from the backbone:
``omega_peak / omega_bb(a_peak) - 1`` with ``a_peak = |phi^T M Q_1|`` of the peak's solution and ``omega_bb`` the
backbone's omega interpolated by a cubic spline in ``ln a``.  The amplitude peak and the phase resonance
differ by ``O(D^2)``.

DLFT's answer depends on its parameter ``eps`` (:mod:`mshbm.methods.dlft`) where the slip phases are short, and
the backbone's ``eps`` (default rule, on the system with ``C - xi M``) is not the forced response's.  At DLFT's
level of largest deviation the peak is found again with ``eps`` fixed at :data:`EPS_FACTORS` times its default
value there (``penalty_sensitivity``): how far DLFT's own answer moves with ``eps``.

Usage::

    python workflow/scripts/backbone/backbone_curve.py --config results/config.json --method hbm --out hbm.json
"""
from __future__ import annotations

import argparse
import inspect
import json
import math
import time

import numpy as np
import scipy.sparse as sp

import mshbm
from mshbm.methods.epmc import linear_modes
from mshbm_workflow import script_module

fe = script_module("fe", "build_fe_model")

#: the methods whose joint is the Jenkins element (the others: the shoe)
JENKINS_METHODS = ("hbm", "mshbm")
#: MS-HBM: Moreau-Jean steps per period of the joint's DOF and its slider (the event-driven flow does not take
#: the Jenkins element), the backbone's and the forced responses' alike
MSHBM_STEPS = 1024
#: per method, the options of the backbone and of the forced solves beyond ``harmonics``
METHOD_OPTIONS = {"mshbm": dict(integrator="moreau", steps=MSHBM_STEPS)}
#: a forced response's scan ends past its peak where the tip amplitude falls below this fraction of the peak's
STOP = 0.4
#: DLFT's ``eps`` relative to its default at the peak, for the sensitivity of the worst peak (module docstring)
EPS_FACTORS = (0.3, 3.0)


def model(cfg, method, forcing=0.0):
    """``(system, facts)``: the jointed beam as ``method`` writes it (module docstring), forcing ``forcing`` N at
    the tip; ``facts``: ``n_dofs``, ``joint_dof``, ``tip_dof``, ``omega_free`` (first bending frequency without
    the joint, rad/s), ``shoe_mass`` (kg, DLFT; else None)."""
    M, K = fe.beam_matrices(int(cfg["n_el"]))
    M, K = sp.csr_matrix(M), sp.csr_matrix(K)
    w = fe.natural_frequencies(M, K, 2)
    alpha, beta = fe.rayleigh_coefficients(w[0], w[1], cfg["zeta"])
    C = alpha * M + beta * K
    n = M.shape[0]
    joint = fe.node_dof(cfg["x_joint"], int(cfg["n_el"]))[0]
    tip = n - 2
    k_t, mu_n = float(cfg["k_t"]), float(cfg["mu_N"])
    shoe_mass = None
    if method in JENKINS_METHODS:
        elements = [mshbm.Jenkins(joint, 1.0, mu_n, tangential_stiffness=k_t)]
    else:
        shoe_mass = k_t / (float(cfg["body_freq_ratio"]) * w[0]) ** 2
        M, K = fe.attach_bodies(M, K, [joint], shoe_mass, k_t)
        C = sp.block_diag([C, sp.csr_matrix((1, 1))]).tocsr()
        elements = [mshbm.Friction(n, 1.0, mu_n)]
    f = np.zeros((3, M.shape[0]))
    f[1, tip] = forcing
    system = mshbm.System(M, C, K, f, elements=elements, name=f"beam-{n}-jenkins-{method}")
    d = inspect.signature(fe.beam_matrices).parameters  # the beam's dimensions and density (its defaults)
    beam_mass = d["density"].default * d["width"].default * d["height"].default * d["length"].default
    return system, dict(n_dofs=int(M.shape[0]), joint_dof=int(joint), tip_dof=int(tip), omega_free=float(w[0]),
                        shoe_mass=shoe_mass, beam_mass=float(beam_mass))


def stuck_mode(cfg):
    """``(omega_0, phi, a_stick)`` of the beam with the joint stuck (the Jenkins model, mass-normalised mode);
    ``a_stick = mu_N / (k_t |phi_joint|)``: the modal amplitude at which the joint's spring force reaches the slip
    force in the linear mode (below it the joint sticks throughout)."""
    s, facts = model(cfg, "hbm")
    w, Phi = linear_modes(s, 1)
    phi = Phi[:, 0]
    return float(w[0]), phi, float(cfg["mu_N"]) / (float(cfg["k_t"]) * abs(phi[facts["joint_dof"]]))


def trace_backbone(cfg, method, a_stick):
    """The method's backbone over config ``amplitude`` (DLFT: from the top down to ``stick_margin a_stick``: its
    velocity predictor leaves the mean friction force undetermined where the joint sticks throughout, a zero row of
    the Jacobian)."""
    s, facts = model(cfg, method)
    a_lo, a_hi = map(float, cfg["amplitude"])
    if method in JENKINS_METHODS:
        a0, a1 = a_lo, a_hi
    else:  # start where the shoe slides (the linear mode of (K, M) with a free shoe is then the right guess)
        # a_stick in this model's coordinate: the stuck mode at a_stick (shoe at rest) projected on its mode
        _, phi_s, _ = stuck_mode(cfg)
        phi_b = linear_modes(s, 1)[1][:, 0]
        a_stick_b = a_stick * abs(phi_b @ (s.M @ np.r_[phi_s, 0.0]))
        a0, a1 = a_hi, max(a_lo, float(cfg["stick_margin"]) * a_stick_b)
    b = mshbm.backbone(s, a0, a1, method=method, harmonics=int(cfg["harmonics"]), points=int(cfg["points"]),
                       dofs=[facts["tip_dof"]], **METHOD_OPTIONS.get(method, {}))
    return b, facts


def _omega_of(b):
    """``omega_bb(a)``: cubic spline of the backbone's omega in ``ln a`` (points sorted by amplitude)."""
    from scipy.interpolate import CubicSpline

    a, w = b.modal_amplitude, b.omega
    order = np.argsort(a)
    return CubicSpline(np.log(a[order]), w[order]), (float(a.min()), float(a.max()))


def forced_level(cfg, method, b, phi, a_target, omega_bb):
    """Scan and peak of the forced response aimed at modal amplitude ``a_target`` (module docstring); ``phi`` the
    mode of the backbone's amplitude ``a``."""
    from scipy.interpolate import interp1d
    from scipy.optimize import minimize_scalar

    order = np.argsort(b.modal_amplitude)
    D_of = interp1d(np.log(b.modal_amplitude[order]), b.damping_ratio[order])
    s0, facts = model(cfg, method)
    tip = facts["tip_dof"]
    w_t = float(omega_bb(math.log(a_target)))
    force = 2.0 * float(D_of(math.log(a_target))) * w_t ** 2 * a_target / abs(phi[tip])
    s, _ = model(cfg, method, forcing=force)
    v = np.asarray(s.M @ phi).reshape(-1)
    opts = dict(method=method, harmonics=int(cfg["harmonics"]), stability=False,
                accuracy=False, **METHOD_OPTIONS.get(method, {}))
    margin = float(cfg["scan_margin"])
    w_lo, w_hi = (1 - margin) * float(b.omega.min()), (1 + margin) * float(b.omega.max())
    dw = (w_hi - w_lo) / (int(cfg["scan_points"]) - 1)
    w = w_hi

    def modal(sol):
        return float(abs(v @ (sol.q_hat[1] - 1j * sol.q_hat[2])))

    scan = dict(omega=[], amplitude=[], modal_amplitude=[], success=[])
    guess, best = None, (-1.0, None, None)
    while w >= w_lo:
        sol = mshbm.solve(s, w, guess=guess, **opts)
        scan["omega"].append(w)
        scan["success"].append(bool(sol.success))
        scan["amplitude"].append(float(sol.amplitude[tip]))
        scan["modal_amplitude"].append(modal(sol))
        if sol.success:
            guess = sol
            if sol.amplitude[tip] > best[0]:
                best = (float(sol.amplitude[tip]), w, sol)
            elif sol.amplitude[tip] < STOP * best[0]:
                break
        w -= dw
    out = dict(force=force, target_modal_amplitude=a_target, scan=scan, peak=None)
    if best[2] is None:
        return out
    _, w0, sol0 = best
    sols = {}

    def minus_amplitude(x):
        sols[x] = mshbm.solve(s, x, guess=sol0, **opts)
        return -sols[x].amplitude[tip] if sols[x].success else 0.0

    res = minimize_scalar(minus_amplitude, bracket=(w0 + dw, w0, w0 - dw), tol=1e-9)
    wp = float(res.x)
    sol = sols.get(wp) or mshbm.solve(s, wp, guess=sol0, **opts)
    a_p = modal(sol)
    lo, hi = omega_bb.x[0], omega_bb.x[-1]
    inside = lo <= math.log(a_p) <= hi
    w_bb = float(omega_bb(math.log(a_p))) if inside else None
    out["peak"] = dict(omega=wp, amplitude=float(sol.amplitude[tip]), modal_amplitude=a_p, success=bool(sol.success),
                       omega_backbone=w_bb, deviation=(wp / w_bb - 1.0) if inside else None,
                       inside_backbone=bool(inside))
    return out


def penalty_sensitivity(cfg, level, index):
    """DLFT's peak of ``level`` (number ``index``, 1-based) with ``eps`` fixed at :data:`EPS_FACTORS` times its
    default at the peak (bounded Brent over +-1 % of the peak's omega)."""
    from scipy.optimize import minimize_scalar

    from mshbm.methods.dlft import DLFTProblem
    from mshbm.options import aft_steps

    s, facts = model(cfg, "dlft", forcing=level["force"])
    tip, w0, nh = facts["tip_dof"], level["peak"]["omega"], int(cfg["harmonics"])
    eps0 = float(DLFTProblem(s, w0, nh, aft_steps(nh)).eps[0])
    start = mshbm.solve(s, w0, method="dlft", harmonics=nh, stability=False, accuracy=False)
    peaks = []
    for f in EPS_FACTORS:
        opts = dict(method="dlft", harmonics=nh, stability=False, accuracy=False, dlft_penalty=f * eps0)
        guess = mshbm.solve(s, w0, guess=start, **opts)

        def minus_amplitude(x):
            sol = mshbm.solve(s, x, guess=guess, **opts)
            return -sol.amplitude[tip] if sol.success else 0.0

        res = minimize_scalar(minus_amplitude, bounds=(0.99 * w0, 1.01 * w0), method="bounded",
                              options=dict(xatol=1e-6 * w0))
        peaks.append(float(res.x))
    allw = peaks + [w0]
    return dict(level=index, eps_default=eps0, factors=list(EPS_FACTORS), omega_peak=peaks, omega_peak_default=w0,
                spread=(max(allw) - min(allw)) / w0)


def run(cfg, method, sensitivity=True):
    """Everything of one method (the JSON written by :func:`main`); ``sensitivity``: DLFT's
    :func:`penalty_sensitivity` too."""
    c0, t0 = time.process_time(), time.perf_counter()
    omega_0, phi, a_stick = stuck_mode(cfg)
    b, facts = trace_backbone(cfg, method, a_stick)
    bb_cpu = time.process_time() - c0
    out = dict(method=method, model=dict(cfg, **facts, omega_stuck=omega_0, a_stick=a_stick),
               backbone=dict(b.to_dict(), amplitude_tip=[float(x) for x in b.amplitude[:, 0]], cpu_time_s=bb_cpu),
               levels=[])
    out["backbone"].pop("harmonic_content", None)
    if len(b) >= 4:
        omega_bb, _ = _omega_of(b)
        # the backbone's own mode (DLFT: of (K, M) with the shoe free, mshbm.methods.epmc), so that a_peak and the
        # backbone's a are the same coordinate
        phi_b = linear_modes(model(cfg, method)[0], 1)[1][:, 0]
        for a_k in cfg["peak_amplitudes"]:
            out["levels"].append(forced_level(cfg, method, b, phi_b, float(a_k), omega_bb))
    dev = [lv["peak"]["deviation"] for lv in out["levels"] if lv["peak"] and lv["peak"]["deviation"] is not None]
    out["max_abs_deviation"] = max(map(abs, dev)) if dev else None
    out["levels_measured"] = len(dev)
    if method == "dlft" and dev and sensitivity:
        i = max((k for k, lv in enumerate(out["levels"]) if lv["peak"] and lv["peak"]["deviation"] is not None),
                key=lambda k: abs(out["levels"][k]["peak"]["deviation"]))
        out["penalty_sensitivity"] = penalty_sensitivity(cfg, out["levels"][i], i + 1)
    out["cpu_time_s"] = time.process_time() - c0
    out["wall_time_s"] = time.perf_counter() - t0
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", required=True, help="results/config.json (section `backbone`)")
    p.add_argument("--method", required=True, choices=("hbm", "dlft", "mshbm"))
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    with open(args.config) as fh:
        cfg = json.load(fh)["backbone"]
    out = run(cfg, args.method)
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps({k: out[k] for k in ("method", "max_abs_deviation", "levels_measured", "cpu_time_s")}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
