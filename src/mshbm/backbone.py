"""Backbone curves: nonlinear modes by the extended periodic motion concept (:func:`backbone`).

The mode ``k`` of a system is traced from modal amplitude ``a_start`` to ``a_end`` by pseudo-arclength
continuation (:func:`mshbm.solvers.arclength.continuation`) in ``lam = ln a`` of the EPMC residual of
:mod:`mshbm.methods.epmc` (harmonic balance: ``method="hbm"`` or ``"dlft"``) or of
:mod:`mshbm.methods.modes` (``method="shooting"``: the exact event-driven flow; for a conservative system,
the conservative nonsmooth mode with ``xi = 0``) or of :mod:`mshbm.methods.modes_mixed` (``method="mshbm"``:
MS-HBM, the element DOFs by that flow, the others condensed per harmonic); with ``integrator="moreau"`` shooting
and MS-HBM step the period by Moreau-Jean instead (:mod:`mshbm.methods.modes_moreau`: any element the stepper
takes; points add ``omega_error`` and ``D_error``, the half-steps estimate, and are certified when both are within
``1e-3``) (notation there: ``a`` the mass-normalised modal
amplitude of the first harmonic in kg^1/2 m, ``omega`` the frequency in rad/s, ``xi`` the artificial
negative damping in 1/s, ``D = xi / (2 omega)`` the modal damping ratio).

Per point: ``modal_amplitude``, ``amplitude`` ((max - min)/2 of the chosen DOFs, m: of the Fourier series
with harmonic balance, exact on the flow with shooting), ``omega``, ``damping_ratio``, ``xi``,
``harmonics`` (``|Q_k|`` of the reference DOF, ``k = 1..n_h``) and the certificate: ``residual_N`` (the
largest HBM residual, N; ``None`` with shooting), ``residual`` (the HBM residual over the force scale
:meth:`~mshbm.methods.epmc.EPMCProblem.force_scale`; with shooting the periodicity ``q(T) - q0`` over the
displacement scale and ``u(T) - u0`` over ``omega`` times it), ``amplitude_residual`` (relative),
``energy_balance`` (relative mismatch of ``xi <q', M q'> = <q', C q'> - <gamma, lambda>``, with shooting
+ the impact losses, over the largest of these mean powers, floor ``1e-12 omega <q', M q'>``) and ``truncation`` (``|Q_nh| / |Q_1|`` at the
reference DOF; an estimate, not gated).  Shooting adds ``periodicity_q`` (m), ``periodicity_u`` (m/s),
``energy_mismatch`` (the same mismatch over the reactive power ``omega <q', M q'>``),
``energy`` (J, at ``t = 0``), ``energy_drift`` (``max |H(t) - H(0)| / H(0)`` over the orbit), ``impacts``
and ``events`` per period, ``moreau_segments`` (the flow's fallback at accumulations of impacts),
``max_multiplier`` (the largest modulus of the Floquet multipliers; of a conservative orbit without its
trivial pair at 1) and the orbit's start state ``q0`` (m), ``u0`` (m/s) at ``t = 0`` (the zero crossing
of the modal coordinate's first harmonic).  ``stable`` is ``None`` for EPMC: the stability of the
artificial autonomous motion says nothing about a forced or free response; for a conservative mode by
shooting (``xi = 0``: an orbit of the free system) it is ``max_multiplier <= 1 + 1e-6`` (an orbit of a
conservative system is at best neutrally stable).

A point is certified when ``residual <= 10 tol``, ``amplitude_residual <= 10 tol`` and
``energy_balance <= 1e-6`` (shooting: or ``energy_mismatch <= 10 tol``: where nothing dissipates Newton
leaves ``xi`` at its tolerance, and the relative balance is rounding over rounding); with shooting also
without Moreau-Jean segments, and for a conservative
system (``C = 0``, elastic impacts, no acting friction) with energy conservation ``energy_drift <= 10 tol``
and ``|D| <= 10 tol``.  MS-HBM: ``residual`` is its residual over its row scales, no energy balance
(``None``), certified by the residuals, no Moreau-Jean segments and (conservative) ``|D| <= 10 tol``; it
adds ``impacts``, ``events`` and ``moreau_segments``.  The backbone succeeds when it reaches ``a_end`` with every point certified.
"""
from __future__ import annotations

import math
import re
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from ._blas import blas_threads
from .errors import InputError
from .methods.modes_common import ENERGY_TOL, MOREAU_STEPS, SHOOTING_STEPS  # noqa: F401  (re-exported)
from .methods.modes_registry import MODE_METHODS, mode_problem
from .solvers.arclength import continuation
from .system import System

__all__ = ["backbone", "Backbone"]


@dataclass
class Backbone:
    """A traced backbone: per-point lists (see the module docstring) and the outcome."""

    success: bool
    message: str
    mode: int
    method: str
    harmonics: int
    steps: int
    dofs: list
    omega_linear: float
    conservative: bool = False
    integrator: str | None = None
    points: list = field(default_factory=list)
    #: the per-point fields of the method besides the common ones (module docstring)
    point_keys: tuple = ()
    #: what ``stable`` means
    stability_note: str = "not defined for the EPMC's artificial autonomous motion"
    wall_time: float = 0.0
    cpu_time: float = 0.0

    def __len__(self):
        return len(self.points)

    def _col(self, key):
        return np.array([p[key] for p in self.points], dtype=float)

    @property
    def modal_amplitude(self):
        return self._col("modal_amplitude")

    @property
    def omega(self):
        return self._col("omega")

    @property
    def damping_ratio(self):
        return self._col("damping_ratio")

    @property
    def amplitude(self):
        """(max - min)/2 of the chosen DOFs, shape ``(P, len(dofs))`` (m)."""
        return np.array([p["amplitude"] for p in self.points], dtype=float).reshape(len(self.points), -1)

    def to_dict(self):
        keys = ("modal_amplitude", "omega", "damping_ratio", "xi", "residual_N", "residual",
                "amplitude_residual", "energy_balance", "truncation", "certified")
        out = {"success": bool(self.success), "message": self.message, "mode": self.mode, "method": self.method,
               "harmonics": self.harmonics, "steps": self.steps, "dofs": list(self.dofs),
               "omega_linear": self.omega_linear, "wall_time_s": self.wall_time, "cpu_time_s": self.cpu_time,
               "conservative": self.conservative,
               "stable": [p.get("stable") for p in self.points],
               "stability_note": self.stability_note}
        out["integrator"] = self.integrator
        for k in keys + tuple(self.point_keys):
            out[k] = [p[k] for p in self.points]
        out["amplitude"] = [list(map(float, p["amplitude"])) for p in self.points]
        out["harmonic_content"] = [p["harmonics"] for p in self.points]
        return out


class _Progress:
    def __init__(self, enabled, label, a_ref):
        self.enabled = enabled is True and sys.stderr.isatty() or enabled == "always"
        self.label, self.a_ref = label, a_ref
        self.offset = 0  # points traced before the current continuation (restarts past corners)

    def __call__(self, point, n, ds):
        if self.enabled:
            y = point.x
            print(f"\r[backbone {self.label}] points {n + self.offset:4d}  a {self.a_ref * math.exp(point.lam):10.4g}  omega {y[-2]:10.6g}  "
                  f"D {y[-1] / (2 * y[-2]):9.3e}  step {ds:.3g}   ", end="", file=sys.stderr, flush=True)

    def close(self):
        if self.enabled:
            print(file=sys.stderr)


def _positive(key, value):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(key, f"must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise InputError(key, f"must be finite and > 0, got {value}")
    return value


def backbone(system, amplitude_start, amplitude_end, mode=0, method="hbm", harmonics=5, steps=None, dofs=None,
             points=50, max_points=None, tol=1e-8, progress=False, max_time=None, integrator=None):
    """Backbone of mode ``mode``: frequency and damping ratio against modal amplitude (EPMC).

    Parameters
    ----------
    system : System
    amplitude_start, amplitude_end : float
        Modal amplitudes ``a`` (kg^1/2 m, :mod:`mshbm.methods.epmc`) of the first and the last point; either
        order.
    mode : int
        0-based mode of the linear system with the Jenkins joints stuck.
    method : {"hbm", "dlft", "shooting", "mshbm"}
        HBM-AFT (regularised Coulomb friction, the set-valued Jenkins law, penalty contacts), DLFT (set-valued
        Coulomb friction on the ground and unilateral contact) or shooting with the exact event-driven flow
        (set-valued friction on the ground and unilateral contacts with Newton's impact law, any ``e_N``;
        :mod:`mshbm.methods.modes`), or MS-HBM with that flow for the element DOFs
        (:mod:`mshbm.methods.modes_mixed`).
    harmonics : int
        ``n_h`` (default 5); with shooting only the reported harmonic content.
    steps : int, optional
        AFT samples per period (default :func:`mshbm.options.aft_steps`); with shooting the output samples
        per period of a point and the Moreau-Jean steps of the flow's fallback (default 256; MS-HBM
        ``max(256, 4 n_h)``).
    dofs : list of int, optional
        DOFs whose amplitude is reported (default: the reference DOF, the largest entry of the mode).
    points : int
        Aimed number of points: the largest arclength step is ``sqrt(2) |ln(a_end / a_start)| / (points - 1)``
        (steps shrink where the curve bends or Newton is slow).
    max_points : int, optional
        Most points (default ``4 points + 10``).
    tol : float
        Corrector tolerance on the scaled residual (default 1e-8: the condensed residual of a stiff
        finite-element model carries the rounding of the condensation, about ``cond(H_LL) eps`` of the
        elastic forces, and moves with it when omega changes; 1e-10 stalls the corrector on the 100-DOF beam).
    progress : bool or "always"
        Progress on stderr (a terminal only, or always).
    max_time : float, optional
        Wall-time limit (s).
    integrator : {"event", "moreau"}, optional
        Shooting and MS-HBM only: the exact event-driven flow (default) or Moreau-Jean time stepping
        (:mod:`mshbm.methods.modes_moreau`: every element the stepper takes, Jenkins joints as sliders; ``steps``
        Moreau-Jean steps per period, default 1024; a point is certified only when the half-steps estimate of
        its error is within ``MOREAU_OMEGA_TOL`` in omega (relative) and ``MOREAU_D_TOL`` in D; a conservative
        system with impacts is refused: its orbit family with ``xi = 0`` does not exist for the discrete
        scheme).

    Returns
    -------
    Backbone
    """
    if not isinstance(system, System):
        raise InputError("system", f"must be a mshbm.System, got {type(system).__name__}")
    if method not in MODE_METHODS:
        raise InputError("method", f"backbone supports {', '.join(MODE_METHODS)}, got {method!r}")
    a0, a1 = _positive("amplitude_start", amplitude_start), _positive("amplitude_end", amplitude_end)
    if a0 == a1:
        raise InputError("amplitude_end", "must differ from amplitude_start")
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 2:
        raise InputError("points", f"must be an integer >= 2, got {points!r}")
    max_points = 4 * int(points) + 10 if max_points is None else max_points
    if isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer)) or max_points < 2:
        raise InputError("max_points", f"must be an integer >= 2, got {max_points!r}")
    steps_given = steps is not None
    prob, steps = mode_problem(system, mode, method, harmonics, steps, integrator)
    # the event-driven flow: the branch has corners where the event sequence changes (a grazing impact): the
    # event sequence marks its smooth pieces, and a step at fixed a crosses a corner the corrector cannot turn
    flow = prob.event_flow
    if dofs is None:
        dofs = [prob.ref_dof]
    dofs = [int(d) for d in dofs]
    for d in dofs:
        if not 0 <= d < system.n:
            raise InputError("dofs", f"DOF {d} out of range 0..{system.n - 1}")
    prob.a_ref = math.e * max(a0, a1)  # lam = ln(a / a_ref) < 0 throughout (see mshbm.methods.epmc)
    lam0, lam1 = math.log(a0 / prob.a_ref), math.log(a1 / prob.a_ref)
    ds_max = math.sqrt(2.0) * abs(lam1 - lam0) / (points - 1)
    t0, c0 = time.perf_counter(), time.process_time()
    pts = []

    def accept(y, lam, stall):
        pt = prob.point(y, lam, dofs)
        pt["certified"] = bool(prob.certify(pt, tol))
        return pt["certified"] or pt["residual"] <= 10 * tol, pt

    show = _Progress(progress, f"mode {mode}", prob.a_ref)

    opts = dict(residual_scale=prob.residual_scale, unknown_scale=prob.unknown_scale, lam_scale=1.0, ds0=ds_max,
                ds_min=1e-6 * max(ds_max, 1e-3), ds_max=ds_max, tol=tol, accept=accept, callback=show,
                max_time=max_time, natural_fallback=False, kink_crossing=flow, early_polish=False,
                segment=prob.segment if flow else None, lam_limits=(min(lam0, lam1) - 1.0, max(lam0, lam1) + 1.0))

    def trace(y_start, lam_start, n_max):
        return continuation(prob.residual, prob.d_lam, y_start, lam_start, lam1, **{**opts, "max_points": n_max})

    try:
        # one BLAS thread, as mshbm.solve and mshbm.sweep: the many small LUs of the condensation (and the
        # event flow's small matrix exponentials) are ~10^3-10^4 times slower with OpenBLAS's threads on a
        # loaded machine
        with blas_threads(1):
            y0 = prob.start(a0)
            res = trace(y0, lam0, max_points)
            found = [(p.x, p.lam, p.payload) for p in res.points]
            bridged = []
            # shooting, MS-HBM: a corner where a reverses (a grazing impact): restart beyond it from the harmonic-balance
            # mode, trace back from there to the corner (the fold between) and on to a_end
            while (flow and not res.success and res.message.startswith("step size below ds_min") and found
                   and len(bridged) < 3 and len(found) < max_points):
                if max_time is not None:
                    opts["max_time"] = max_time - (time.perf_counter() - t0)
                lam_c = found[-1][1]
                hop = prob.restart_past_corner(lam_c, lam1, tol=tol)
                if hop is None:
                    break
                bridged.append(prob.a_ref * math.exp(lam_c))
                # back from the restart over the fold to the corner: the points on the restart's smooth piece
                # (the same event sequence; past the corner the trace would go on down the other piece)
                show.offset = len(found)
                back = continuation(prob.residual, prob.d_lam, hop[0], hop[1], lam_c - 1.0,
                                    **{**opts, "max_points": max(10, max_points - len(found)) // 2, "ds0": ds_max / 2,
                                       "ds_max": ds_max / 2})
                piece = []
                for p in back.points[1:]:
                    if p.segment is None or p.segment != back.points[0].segment:
                        break
                    piece.append((p.x, p.lam, p.payload))
                found += piece[::-1]
                show.offset = len(found)
                res = trace(hop[0], hop[1], max(2, max_points - len(found)))
                found += [(p.x, p.lam, p.payload) for p in res.points]
    finally:
        show.close()
    for x, lam, payload in found:
        pt = payload if payload is not None else accept(x, lam, None)[1]
        pt.setdefault("certified", False)
        pt.setdefault("stable", None)
        pt.pop("q_hat", None)
        pts.append(pt)
    bad = [i for i, p in enumerate(pts) if not p["certified"]]
    success = bool(res.success) and not bad
    # the driver's messages name the parameter lam = ln(a / a_ref): say a
    msg = re.sub(r"lam_end = \S+ in", f"a_end = {a1:.6g} in", res.message)
    msg = re.sub(r"lam(?:_end)? = (-?[0-9.e+-]+)", lambda m: f"a = {prob.a_ref * math.exp(float(m.group(1))):.6g}",
                 msg).replace("lam", "ln a")
    if bridged:
        msg = re.sub(r" in \d+ points", f" in {len(found)} points", msg)
        msg += f" (after {len(bridged)} corner(s) passed by a restart from the DLFT mode, at a = " + \
            ", ".join(f"{a:.6g}" for a in bridged) + ")"
    msg = msg if not bad else f"{msg}; {len(bad)} point(s) not certified (first: {bad[0]})"
    if not success:
        msg += prob.failure_hint(len(found), steps_given)
    return Backbone(success=success, message=msg, mode=int(mode), method=method, harmonics=int(harmonics),
                    steps=int(steps), dofs=dofs, omega_linear=prob.omega0,
                    conservative=bool(prob.conservative), points=pts, integrator=prob.integrator,
                    point_keys=tuple(prob.point_keys), stability_note=prob.stability_note(),
                    wall_time=time.perf_counter() - t0, cpu_time=time.process_time() - c0)
