"""Frequency-response curves of two blades coupled by an underplatform damper, at several normal loads, by one
harmonic-balance method (Fig. 12, rule ``upd_frf``).

The structure (config ``upd``): two identical steel cantilever blades (``build_fe_model.beam_matrices``, ``n_el``
Hermite elements each, length ``length``, section ``width x height``), each bending in two planes: the
in-plane direction ``y`` (bending across ``height``, the softer plane) and the out-of-plane direction ``z``
(across ``width``), so every blade tip (its platform) moves in the plane ``(y, z)``.  Rayleigh damping
``zeta`` at the blade's two lowest frequencies.  The damper: a rigid body of mass ``damper_mass`` (fraction of
a blade's mass) with the two DOFs ``(d_y, d_z)``, held in its pocket by a soft spring ``retainer`` (fraction of
the blade's in-plane tip stiffness ``k_b = 3 E I_y / L^3``; without it the stiffness matrix is singular).
Two 3-D contact patches, one per platform: :func:`mshbm.frictional_contact` between the tip ``(y_i, z_i)``
and the damper ``(d_y, d_z)``, the 3-D Jenkins law (the tangential contact stiffness
``k_t = contact_stiffness k_b`` in both directions in series with a slider on Coulomb's disk
``||lambda_T|| <= mu N``, the slip direction rotating), with the constant normal load ``N`` (the centrifugal
preload; ``mu N`` in N, config ``preloads``).  HBM does not combine the Jenkins law with a contact-loaded
(varying) normal load (:mod:`mshbm.elements.cone`), so the normal load is constant.

Engine-order forcing: on blade ``i = 0, 1`` the tip force ``F (cos beta, sin beta) cos(omega t - i phi)``
(``F = force`` N, ``beta = force_angle`` deg, inter-blade phase ``phi = interblade_phase`` deg).  With ``phi =
180`` (engine order ``N_b / 2`` of a bladed disk of ``N_b`` blades) the blades move in antiphase and the
damper works; in phase (``phi = 0``) the damper moves with the platforms and dissipates nothing.

The in-plane and out-of-plane responses of a tip have different phases (the planes' resonances differ), so
the relative motion at a patch is an ellipse and the damper slips in 2-D.

Per preload: pointwise :func:`mshbm.solve` with warm starts, descending in omega over ``[omega_lo, omega_hi]``
(fractions of the blade's first frequency ``omega_1``) in ``scan_points`` steps, then the peak of blade 0's
in-plane tip amplitude refined by Brent's method on the pointwise solves, and at the peak the method's own
certified solve (``accuracy`` default: its combined error estimate, :mod:`mshbm.route.refine`).  DLFT takes the
3-D Jenkins contacts as massless slider DOFs carrying the rigid cone (:mod:`mshbm.methods.dlft_terms`); its
error falls like ``1 / n_h`` (the sliders' truncated stick-slip motion), so it runs with ``dlft_harmonics``
(default ``harmonics``).  A method that refuses the model records its InputError.

Usage::

    python workflow/scripts/upd/upd_frf.py --config results/config.json --method hbm --out hbm.json
"""
from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

import mshbm
from mshbm.errors import InputError
from mshbm_workflow import script_module

fe = script_module("fe", "build_fe_model")

#: Young's modulus (Pa) and density (kg/m^3) of the blades (steel, build_fe_model's defaults)
YOUNG, DENSITY = 210e9, 7850.0


def model(cfg, mu_n, kind="jenkins"):
    """``(system, facts)``: the two blades and the damper at slip force ``mu_n`` N per patch.  ``kind``:
    ``"jenkins"`` (the model), ``"stuck"`` (the patches as springs ``k_t``, no friction), ``"free"`` (no contact).
    ``facts``: DOF indices ``tips`` (``[(y_0, z_0), (y_1, z_1)]``), ``damper`` (``(d_y, d_z)``), ``k_b``, ``k_t``,
    ``blade_mass``, ``omega_1`` (blade's first frequency, rad/s), ``omega_2``."""
    n_el, L, b, h = int(cfg["n_el"]), float(cfg["length"]), float(cfg["width"]), float(cfg["height"])
    My, Ky = fe.beam_matrices(n_el, length=L, width=b, height=h)
    Mz, Kz = fe.beam_matrices(n_el, length=L, width=h, height=b)
    nb = My.shape[0]
    Mb, Kb = sp.block_diag([My, Mz]).tocsr(), sp.block_diag([Ky, Kz]).tocsr()
    w = fe.natural_frequencies(Mb, Kb, 2)
    alpha, beta = fe.rayleigh_coefficients(w[0], w[1], float(cfg["zeta"]))
    k_b = 3.0 * YOUNG * (b * h ** 3 / 12.0) / L ** 3
    blade_mass = DENSITY * b * h * L
    m_d, k_d = float(cfg["damper_mass"]) * blade_mass, float(cfg["retainer"]) * k_b
    k_t = float(cfg["contact_stiffness"]) * k_b
    M = sp.block_diag([Mb, Mb, sp.diags([m_d, m_d])]).tocsr()
    K = sp.block_diag([Kb, Kb, sp.diags([k_d, k_d])]).tocsr()
    C = sp.block_diag([alpha * Mb + beta * Kb] * 2 + [sp.csr_matrix((2, 2))]).tocsr()
    n = M.shape[0]
    tips = [(nb - 2, 2 * nb - 2), (2 * nb + nb - 2, 2 * nb + 2 * nb - 2)]
    damper = (n - 2, n - 1)
    F, bf, ph = float(cfg["force"]), math.radians(float(cfg["force_angle"])), math.radians(float(cfg["interblade_phase"]))
    f = np.zeros((3, n))
    for i, (ty, tz) in enumerate(tips):
        for d, c in ((ty, math.cos(bf)), (tz, math.sin(bf))):
            f[1, d] = F * c * math.cos(i * ph)  # F c cos(omega t - i phi) = F c (cos(i phi) cos + sin(i phi) sin)
            f[2, d] = F * c * math.sin(i * ph)
    elements = []
    if kind == "jenkins":
        for i, (ty, tz) in enumerate(tips):
            elements += mshbm.frictional_contact(ty, tz, 1.0, mu_n, relative_to=(*damper, None),
                                                 tangential_stiffness=k_t, first=2 * i)
    elif kind == "stuck":
        K = K.tolil()
        for ty, tz in tips:
            for a, d in ((ty, damper[0]), (tz, damper[1])):
                K[a, a] += k_t
                K[d, d] += k_t
                K[a, d] -= k_t
                K[d, a] -= k_t
        K = K.tocsr()
    system = mshbm.System(M, C, K, f, elements=elements, name=f"upd-{kind}-{mu_n:g}")
    return system, dict(n_dofs=int(n), tips=tips, damper=damper, k_b=k_b, k_t=k_t, blade_mass=blade_mass,
                        damper_mass=m_d, omega_1=float(w[0]), omega_2=float(w[1]))


def linear_peak(cfg, kind):
    """Peak ``(omega, amplitude)`` of blade 0's in-plane tip amplitude of the linear system ``kind`` (``"free"``
    or ``"stuck"``) in the scan window: the frequency response ``(K - omega^2 M + i omega C)^-1 f`` maximised
    by Brent's method around the densest grid's maximum."""
    from scipy.optimize import minimize_scalar

    s, facts = model(cfg, 0.0, kind)
    M, C, K = (x.toarray() if sp.issparse(x) else np.asarray(x) for x in (s.M, s.C, s.K))
    fc = np.asarray(s.f_hat)[1] - 1j * np.asarray(s.f_hat)[2]
    ty = facts["tips"][0][0]

    def amp(w):
        return abs(sla.solve(K - w * w * M + 1j * w * C, fc)[ty])

    w1 = facts["omega_1"]
    grid = np.linspace(float(cfg["omega_range"][0]) * w1, float(cfg["omega_range"][1]) * w1, 4001)
    a = np.array([amp(w) for w in grid])
    i = int(np.clip(np.argmax(a), 1, len(grid) - 2))
    res = minimize_scalar(lambda w: -amp(w), bracket=(grid[i - 1], grid[i], grid[i + 1]), tol=1e-10)
    return float(res.x), float(-res.fun)


def accuracy_estimate(sol):
    """The combined error estimate of a certified solve (None if the certificate has none)."""
    acc = (sol.info or {}).get("accuracy") or {}
    return acc.get("estimate")


def frf(cfg, method, mu_n):
    """Scan and peak at slip force ``mu_n`` (module docstring)."""
    from scipy.optimize import minimize_scalar

    c0 = time.process_time()
    s, facts = model(cfg, mu_n)
    ty, tz = facts["tips"][0]
    w1 = facts["omega_1"]
    nh = int(cfg.get("dlft_harmonics") or cfg["harmonics"]) if method == "dlft" else int(cfg["harmonics"])
    opts = dict(method=method, harmonics=nh, stability=False, accuracy=False)
    if method != "hbm":
        opts["steps"] = int(cfg["steps"])
    lo, hi = (float(x) * w1 for x in cfg["omega_range"])
    grid = np.linspace(hi, lo, int(cfg["scan_points"]))
    scan = dict(omega=[], amplitude=[], amplitude_z=[], success=[])
    guess, best = "linear", (-1.0, None, None)
    for w in grid:
        sol = mshbm.solve(s, float(w), guess=guess, **opts)
        scan["omega"].append(float(w))
        scan["success"].append(bool(sol.success))
        scan["amplitude"].append(float(sol.amplitude[ty]))
        scan["amplitude_z"].append(float(sol.amplitude[tz]))
        if sol.success:
            guess = sol
            if sol.amplitude[ty] > best[0]:
                best = (float(sol.amplitude[ty]), float(w), sol)
    out = dict(mu_N=mu_n, harmonics=nh, scan=scan, peak=None)
    if best[2] is None:
        out["cpu_time_s"] = time.process_time() - c0
        return out
    _, w0, sol0 = best
    dw = float(grid[0] - grid[1])
    sols = {}

    def minus_amplitude(x):
        near = min(sols, key=lambda y: abs(y - x)) if sols else None  # warm start from the nearest solve
        sols[x] = mshbm.solve(s, x, guess=sols[near] if near is not None and sols[near].success else sol0, **opts)
        return -sols[x].amplitude[ty] if sols[x].success else 0.0

    a, c = min(w0 + dw, hi), max(w0 - dw, lo)
    if a > w0 > c:
        res = minimize_scalar(minus_amplitude, bounds=(c, a), method="bounded",
                              options=dict(xatol=float(cfg["peak_tol"]) * w1))
        wp = float(res.x)
    else:  # the largest amplitude at the window's edge: no interior peak
        wp = w0
    sol = sols.get(wp) or mshbm.solve(s, wp, guess=sol0, **opts)
    # the method's own certificate and error estimate at the peak
    cert = mshbm.solve(s, wp, guess=sol, **dict(opts, accuracy=None))
    els = cert.elements or []
    slip = [1.0 - float(e.get("stick_fraction", 1.0)) for e in els if isinstance(e, dict) and "stick_fraction" in e]
    out["peak"] = dict(omega=wp, omega_ratio=wp / w1, amplitude=float(sol.amplitude[ty]),
                       amplitude_z=float(sol.amplitude[tz]), success=bool(sol.success),
                       certified=bool(cert.success), certificate_message=str(cert.message),
                       accuracy_estimate=accuracy_estimate(cert), at_edge=not (a > w0 > c),
                       slip_fraction=max(slip) if slip else None)
    out["cpu_time_s"] = time.process_time() - c0
    return out


def run(cfg, method):
    """Everything of one method (the JSON written by :func:`main`)."""
    c0, t0 = time.process_time(), time.perf_counter()
    _, facts = model(cfg, 1.0)
    out = dict(method=method, model=dict(cfg, **{k: v for k, v in facts.items() if k not in ("tips", "damper")}),
               free=dict(zip(("omega", "amplitude"), linear_peak(cfg, "free"))),
               stuck=dict(zip(("omega", "amplitude"), linear_peak(cfg, "stuck"))),
               preloads=[], refused=None)
    try:
        for mu_n in cfg["preloads"]:
            out["preloads"].append(frf(cfg, method, float(mu_n)))
            pk = out["preloads"][-1]["peak"]  # progress in the rule's log
            print(f"{method} mu_N = {mu_n}: peak at omega / omega_1 = {pk and pk['omega_ratio']} "
                  f"({time.process_time() - c0:.1f} s CPU so far)", flush=True)
    except InputError as exc:  # a method that does not take the model
        out["refused"] = str(exc)
        out["preloads"] = []
    out["cpu_time_s"] = time.process_time() - c0
    out["wall_time_s"] = time.perf_counter() - t0
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", required=True, help="results/config.json (section `upd`)")
    p.add_argument("--method", required=True, choices=("hbm", "dlft", "mshbm"))
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    with open(args.config) as fh:
        cfg = json.load(fh)["upd"]
    out = run(cfg, args.method)
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps(dict(method=out["method"], refused=out["refused"], cpu_time_s=out["cpu_time_s"],
                          peaks=[(p["mu_N"], p["peak"] and p["peak"]["omega_ratio"], p["peak"] and p["peak"]["amplitude"])
                                 for p in out["preloads"]])))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
