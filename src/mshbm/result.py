"""Periodic solution returned by :func:`mshbm.solve`.

Notation: ``n`` DOFs, ``m`` nonlinear elements, ``N`` time steps per period,
``n_h`` harmonics.  Coefficient arrays follow :mod:`mshbm.fourier`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from . import fourier

__all__ = ["PeriodicSolution"]


@dataclass
class PeriodicSolution:
    """A periodic solution and how it was obtained.

    Attributes
    ----------
    method : str
    omega : float
        Angular frequency of the forcing (rad/s); the period is ``2 pi / omega``.
    harmonics : int
        ``n_h`` of the harmonic part (for shooting: of ``q_hat`` only).
    steps : int
        ``N``, time points per period.
    success : bool
    message : str
    iterations : int
        Newton iterations.
    nfev : int
        Residual evaluations (including line search).
    residual : float
        Final scaled residual ``||R / s||_inf`` (dimensionless; see :mod:`mshbm.scaling`).
    wall_time : float
        Seconds for the whole solve: validation, set-up (condensation,
        factorisations, step matrices), Newton and the time-domain output.
    t : ndarray, shape (N+1,)
        Time grid ``t_k = k T / N``, ``k = 0..N``.
    q_hat : ndarray, shape (2 n_h + 1, n)
        Fourier coefficients of the displacements of all DOFs.
    time_dofs : ndarray of int
        DOFs represented in the time domain (integrated); others come from ``q_hat``.
    q_time, u_time : ndarray, shape (N+1, len(time_dofs))
    lam : ndarray, shape (N+1, m)
        Element forces ``lambda_j`` along ``w_j`` (friction: force on the DOF;
        contact: normal force >= 0).  For time-stepping methods the impulse of
        step ``k`` divided by ``h`` (impacts show as spikes of height ``P/h``).
    impulses : ndarray, shape (N, m) or None
        Impulses per step (time-stepping methods).
    x : ndarray
        Final unknowns of the method.
    info : dict
        Method-specific extras (partition, condition numbers...); ``info["stability"]``: details
        of the stability analysis.
    floquet_multipliers : ndarray of complex, shape (2n,) or (0,)
        Floquet multipliers of the periodic orbit (see :mod:`mshbm.stability`); empty if none.
    stable : bool or None
        ``True``/``False`` from multipliers valid for the nonsmooth flow; ``None`` where that
        cannot be decided (``stability_reason`` says why).
    stability_method : str
        How the multipliers were obtained, e.g. ``"exact-flow-saltation"``, or ``"none: ..."``.
    stability_reason : str
        Why ``stable`` is ``None``, and whether the multipliers belong to another orbit than the reported one
        (empty otherwise).
    stability_orbit : str
        Which orbit the multipliers belong to: ``"reported"`` (the returned solution's own monodromy),
        ``"nearby exact orbit"`` (the exact periodic orbit of the nonsmooth flow found from it, when the
        returned orbit is too far from any orbit of the flow to have multipliers of its own), ``""`` (none).
    elements : list of mshbm.element_outputs.ElementOutput
        Per element: force, relative displacement and velocity over the period, dissipated energy per
        period, stick or contact fraction (:mod:`mshbm.element_outputs`; set by :func:`mshbm.solve`).
    partition : mshbm.methods.base.Partition or None
        The method's DOF sets as index arrays (``time``, ``harmonic``, ``condensed``), the same
        fields for every method.
    conditioning : ndarray, shape (n_h + 1,), or None
        Reciprocal condition numbers of the condensed per-harmonic blocks (``H_LL``; 3.3: ``H_33``).
    time_step : float or None
        Moreau-Jean step ``h = T / N`` (s) of the time-stepped DOFs; ``None`` for HBM/DLFT.
    base : mshbm.support.BaseMotion or None
        The imposed support motion of a system built by :func:`mshbm.support.base_excitation`: ``q_hat``
        then holds the solved coordinates ``z`` of the free DOFs, and :attr:`q_hat_absolute`,
        :attr:`q_hat_relative` those of the whole structure.
    certificate : mshbm.certificate.Certificate or None
        Checks made after Newton (:mod:`mshbm.certificate`); ``success`` requires all
        gating checks to pass.  ``residual`` is the scaled ``||R / s||_inf`` (dimensionless).
    """

    method: str
    omega: float
    harmonics: int
    steps: int
    success: bool
    message: str
    iterations: int
    nfev: int
    residual: float
    wall_time: float
    t: np.ndarray
    q_hat: np.ndarray
    time_dofs: np.ndarray
    q_time: np.ndarray
    u_time: np.ndarray
    lam: np.ndarray
    impulses: np.ndarray | None
    x: np.ndarray
    info: dict = field(default_factory=dict)
    partition: object = None
    conditioning: np.ndarray | None = None
    time_step: float | None = None
    certificate: object = None
    floquet_multipliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))
    stable: bool | None = None
    stability_method: str = "none: not assessed"
    stability_reason: str = "no stability analysis was run"
    stability_orbit: str = ""
    elements: list = field(default_factory=list)
    base: object = None

    @property
    def period(self):
        return 2.0 * np.pi / self.omega

    @property
    def n(self):
        return self.q_hat.shape[1]

    def _assemble(self, which, dofs=None):
        n = self.n
        dofs = np.arange(n) if dofs is None else np.asarray(dofs, dtype=np.int64)
        N = self.t.size - 1
        coef = self.q_hat[:, dofs]
        if which == "u":
            coef = fourier.derivative(coef, self.omega)
        nc = coef.shape[0]
        if not dofs.size:
            out = np.zeros((N, 0))
        elif nc <= 64 and N > 2 * (nc // 2):
            # a (cached) DFT matrix: one BLAS product instead of an FFT per DOF (faster on large systems)
            out = fourier.idft_matrix(N, nc // 2) @ coef
        else:
            out = fourier.ifft(coef, N)
        out = np.vstack([out, out[:1]])
        td = {int(d): i for i, d in enumerate(self.time_dofs)}
        src = self.q_time if which == "q" else self.u_time
        for col, d in enumerate(dofs):
            if int(d) in td:
                out[:, col] = src[:, td[int(d)]]
        return out

    def displacement(self, dofs=None):
        """``q(t_k)`` for the given DOFs (all by default), shape (N+1, len(dofs))."""
        return self._assemble("q", dofs)

    def velocity(self, dofs=None):
        """``u(t_k)``; time-stepped DOFs show true velocity jumps."""
        return self._assemble("u", dofs)

    def initial_state(self):
        """``(q(t_0), u(t_0))`` of all DOFs, each shape (n,): row 0 of :attr:`q` and :attr:`u` (equal to
        round-off) without assembling the time grid of all DOFs (``8 n (N + 1)`` bytes each, 330 MB for
        ``n = 10^4``, ``N = 4096``).  Fourier DOFs: ``V(0)^T q_hat = q_hat_0 + sum_k q_hat_c,k`` and the same
        sum of the velocity's coefficients; time-stepped DOFs: their series at ``t_0``."""
        if "q" in self.__dict__ and "u" in self.__dict__:
            return self.q[0].copy(), self.u[0].copy()
        qh = np.asarray(self.q_hat, dtype=float)
        q0 = qh[0] + qh[1::2].sum(axis=0)
        u0 = fourier.derivative(qh, self.omega)[1::2].sum(axis=0)
        td = np.asarray(self.time_dofs, dtype=np.int64)
        if td.size:
            q0[td] = self.q_time[0]
            u0[td] = self.u_time[0]
        return q0, u0

    @property
    def q_hat_absolute(self):
        """With a support motion (``base``): coefficients of every DOF of the structure in absolute
        coordinates, shape (2 n_h + 1, n_structure) (:meth:`mshbm.support.BaseMotion.absolute_hat`); else
        ``q_hat``."""
        return self.q_hat if self.base is None else self.base.absolute_hat(self.q_hat)

    @property
    def q_hat_relative(self):
        """With a support motion (``base``): coefficients relative to the base's quasi-static motion, shape
        (2 n_h + 1, n_structure) (:meth:`mshbm.support.BaseMotion.relative_hat`); ``None`` without one."""
        return None if self.base is None else self.base.relative_hat(self.q_hat)

    @cached_property
    def q(self):
        """All displacements, shape (N+1, n)."""
        return self.displacement()

    @cached_property
    def u(self):
        """All velocities, shape (N+1, n)."""
        return self.velocity()

    @cached_property
    def amplitude(self):
        """``(max - min) / 2`` of every DOF over one period of its exact representation, shape (n,):
        the extrema of the Fourier series for harmonic DOFs (found exactly, not on the time grid),
        of the time series for time-stepped DOFs (:func:`mshbm.extrema.solution_amplitude`)."""
        from .extrema import solution_amplitude

        return solution_amplitude(self)

    def summary(self):
        """Dict of scalar facts for JSON output."""
        return {
            "method": self.method,
            "harmonics": int(self.harmonics),
            "steps": int(self.steps),
            "omega": float(self.omega),
            "period": float(self.period),
            "success": bool(self.success),
            "message": self.message,
            "iterations": int(self.iterations),
            "nfev": int(self.nfev),
            "residual": float(self.residual),
            "wall_time_s": float(self.wall_time),
            "amplitude": [float(a) for a in self.amplitude],
            "partition": None if self.partition is None else self.partition.as_dict(),
            "time_step": None if self.time_step is None else float(self.time_step),
            "min_rcond": None if self.conditioning is None or not np.size(self.conditioning)
            else float(np.min(self.conditioning)),
            "certificate": None if self.certificate is None else self.certificate.as_list(),
            "accuracy": self.info.get("accuracy"),
            **describe_stability(self),
            "elements": [e.summary() for e in self.elements],
            # a support motion: the structure's DOFs in absolute and relative coordinates (mshbm.support)
            **({"base": self.base.summary(self)} if self.base is not None else {}),
            # HBM: the regularisation of each element's law as used (the default's rule and scale, or as given)
            **({"regularisation": self.info["regularisation"]}
               if isinstance(self.info, dict) and "regularisation" in self.info else {}),
        }


def multipliers_json(mult):
    """``[[re, im], ...]`` of complex multipliers (JSON has no complex numbers)."""
    return [[float(np.real(m)), float(np.imag(m))] for m in np.asarray(mult, dtype=complex).reshape(-1)]


def describe_stability(sol):
    """JSON-ready stability fields of a solution (``floquet_multipliers`` as ``[re, im]`` pairs;
    :mod:`mshbm.stability` sets them)."""
    mult = getattr(sol, "floquet_multipliers", None)
    mult = np.asarray(mult if mult is not None else [], dtype=complex)
    return {"floquet_multipliers": multipliers_json(mult),
            "floquet_max_modulus": float(np.max(np.abs(mult))) if mult.size else None,
            "stable": getattr(sol, "stable", None),
            "stability_method": getattr(sol, "stability_method", "none: not assessed"),
            "stability_reason": getattr(sol, "stability_reason", ""),
            "stability_orbit": getattr(sol, "stability_orbit", "")}
