"""Craig-Bampton reduction of a finite-element model to its element DOFs and a few fixed-interface modes.

Notation: the full model ``M q'' + C q' + K q = f_ex(t) + f_nl`` has ``n`` DOFs (:mod:`mshbm.system`).  The
*boundary* ``B`` (``b`` DOFs, physical) holds every DOF an element acts on (``dof`` and ``relative_to``) and
the DOFs the user keeps; the other DOFs are the *interior* ``I``.  With the static constraint modes
``Psi_IB = -K_II^{-1} K_IB`` and the ``n_m`` lowest fixed-interface modes ``Phi_I`` (eigenvectors of
``K_II phi = w^2 M_II phi``, ``M_II``-normalised)::

    q = T q_r,   q_r = (q_B, eta),   T = [[I_b, 0], [Psi_IB, Phi_I]]     (shape (n, b + n_m))

and the reduced model is ``M_r = T^T M T``, ``C_r = T^T C T``, ``K_r = T^T K T`` (dense, exactly
symmetrised), ``f_r = T^T f`` (Craig & Bampton 1968).  The elements act on boundary DOFs, which stay
physical, so their laws are unchanged; reduced DOF ``i < b`` is the full model's DOF ``boundary[i]``.

Why: every method then works on ``b + n_m`` DOFs, and the time-integrated element DOFs carry the model's
effective (Guyan plus coupling) mass instead of the tiny nodal mass of a fine mesh, whose local frequency
``sqrt(K_dd / M_dd)`` is ``10^3``-``10^7`` times ``omega`` (stiff for Moreau-Jean, refused by the event
flow).  The modes above the cut-off are kept quasi-statically by the constraint modes (the reduction is
exact at ``omega = 0``).

Error estimate (:meth:`ReducedModel.error_estimate`): at every harmonic ``k omega`` where the solution has
content, the responses of the boundary DOFs to unit forces on them and to the forcing, computed exactly on the
full model (:meth:`ReducedModel.full_boundary_response`: an iteration preconditioned by the reduction's own
factors, a sparse LU of ``K - (k omega)^2 M + i k omega C`` where it does not contract) and on the reduced one; the largest
relative difference is the certificate entry ``reduction`` (relative error of the linear dynamics the
nonlinear elements see), one of the estimates summed by the gating ``accuracy`` check
(:mod:`mshbm.certificate.combined`).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import InputError
from .system import System

__all__ = ["ReducedModel", "craig_bampton", "REDUCTION_BOUND", "auto_reduction", "method_reduction", "stiff_time_dofs"]

#: the reduction estimate warns above this relative error (the accuracy at which truncation estimates warn)
REDUCTION_BOUND = 1e-2
#: a time-integrated DOF whose local frequency ``sqrt(K_dd / M_dd)`` exceeds this multiple of ``omega`` is stiff
#: (the node of a fine mesh: 10^3-10^7; the lumped bodies of the examples: below 4)
AUTO_STIFF_RATIO = 200.0
#: the automatic reduction keeps the fixed-interface modes up to this multiple of the highest harmonic
#: ``n_h omega`` (at least :data:`AUTO_MIN_MODES`, at most :data:`AUTO_MAX_MODES`); the reduction estimate judges it
AUTO_CUTOFF = 20.0
AUTO_MIN_MODES, AUTO_MAX_MODES = 8, 256


@dataclass
class ReducedModel:
    """A full system, its Craig-Bampton reduction and the map between them (module docstring).

    Attributes
    ----------
    full : System
        The model as the user wrote it (``n`` DOFs).
    system : System
        The reduced model (``b + n_m`` DOFs; the elements renumbered onto the boundary).
    T : ndarray, shape (n, b + n_m)
        ``q = T q_r``.
    boundary : ndarray of int, shape (b,)
        Full-model DOF of reduced DOF ``i < b``.
    frequencies : ndarray, shape (n_m,)
        Fixed-interface natural frequencies kept (rad/s).
    build_time : float
        Seconds to build the reduction.
    auto : dict or None
        Set when the reduction was chosen automatically (:func:`auto_reduction`): the largest stiffness ratio
        ``sqrt(K_dd / M_dd) / omega`` of the time-integrated DOFs and the modes' cut-off (rad/s).
    """

    full: System
    system: System
    T: np.ndarray
    boundary: np.ndarray
    frequencies: np.ndarray
    build_time: float
    _estimates: dict = field(default_factory=dict, repr=False)
    #: interior DOFs, the sparse LU of ``K_II`` and the modes ``Phi_I`` (the error estimate's preconditioner)
    _interior: np.ndarray = field(default=None, repr=False)
    _K_II_lu: object = field(default=None, repr=False)
    _Phi: np.ndarray = field(default=None, repr=False)
    _cache: dict = field(default_factory=dict, repr=False)
    auto: dict = None

    @property
    def n_modes(self):
        return int(self.frequencies.size)

    def reduced_dof(self, dof, key="dofs"):
        """Reduced index of the full-model DOF ``dof``; :class:`InputError` naming ``key`` when it is interior."""
        hit = np.flatnonzero(self.boundary == int(dof))
        if not hit.size:
            raise InputError(key, f"DOF {int(dof)} is interior to the Craig-Bampton reduction: only its boundary "
                                  f"DOFs ({', '.join(map(str, self.boundary.tolist()))}) are physical; add it "
                                  "to reduce.keep")
        return int(hit[0])

    def as_dict(self):
        return {"method": "craig_bampton", "boundary": self.boundary.tolist(), "modes": self.n_modes,
                "n_full": int(self.full.n), "n_reduced": int(self.system.n),
                "highest_mode_rad_s": float(self.frequencies[-1]) if self.frequencies.size else None,
                "build_time_s": float(self.build_time), **({"auto": dict(self.auto)} if self.auto else {})}

    def solve(self, omega, method="mshbm", **options):
        """:func:`mshbm.solve` on the reduced model, the answer on the full model's DOFs (:meth:`expand`)."""
        from .api import solve

        return self.expand(solve(self.system, omega, method, **options))

    def expand(self, sol, estimate=True):
        """The solution ``sol`` of :attr:`system` on the full model's DOFs: ``q_hat = q_hat_r T^T``; the
        time-stepped boundary DOFs keep their time series (time-stepped modal coordinates are represented by
        their Fourier series).  Element outputs name the full model's DOFs (the elements act on boundary DOFs,
        which are physical); the partition names the full model's DOFs too (``time`` and ``harmonic``: the
        boundary DOFs of those sets, ``condensed``: every other DOF, whose motion follows from the reduction's
        modal coordinates and the condensation).  Certificate and stability stay those of the reduced model;
        with ``estimate`` the certificate gets the entry ``reduction`` (:meth:`error_estimate`)."""
        b = self.boundary.size
        B = self.boundary
        td = np.asarray(sol.time_dofs, dtype=np.int64)
        keep = td < b
        info = dict(sol.info)
        info["reduction"] = self.as_dict()
        elements = [dataclasses.replace(e, dof=int(B[e.dof]),
                                        relative_to=None if e.relative_to is None else int(B[e.relative_to]))
                    for e in (sol.elements or [])]
        partition = sol.partition
        if partition is not None:
            t = np.asarray(partition.time, dtype=np.int64)
            h = np.asarray(partition.harmonic, dtype=np.int64)
            t, h = B[t[t < b]], B[h[h < b]]
            partition = dataclasses.replace(partition, time=t, harmonic=h,
                                            condensed=np.setdiff1d(np.arange(self.full.n), np.union1d(t, h)))
        info.pop("amplitude_exact", None)  # the reduced DOFs': the full model's follow
        if not keep.all():  # time-stepped modal coordinates: the mesh's amplitudes from their time series
            info["amplitude_exact"] = self.grid_amplitude(sol)
        out = dataclasses.replace(sol, q_hat=np.asarray(sol.q_hat) @ self.T.T, time_dofs=B[td[keep]],
                                  q_time=np.asarray(sol.q_time)[:, keep], u_time=np.asarray(sol.u_time)[:, keep],
                                  info=info, elements=elements, partition=partition)
        if estimate and sol.certificate is not None:
            from .certificate import Check
            from .certificate.combined import combined_check, gate

            err, note = self.error_estimate(sol)
            info["reduction"]["error_estimate"] = err
            cert = sol.certificate
            cert.checks.append(Check("reduction", err, REDUCTION_BOUND, bool(err <= REDUCTION_BOUND), False, note))
            if "accuracy" in cert:  # the combined estimate of the solve, now with the reduction's
                acc = cert["accuracy"]
                requested = isinstance(sol.info.get("accuracy"), dict) and bool(sol.info["accuracy"].get("requested"))
                gate(out, combined_check(cert, acc.bound, requested))
                if isinstance(out.info.get("accuracy"), dict):
                    out.info["accuracy"] = {**out.info["accuracy"], "estimate": cert["accuracy"].value,
                                            "estimates": {**out.info["accuracy"].get("estimates", {}),
                                                          "reduction": err},
                                            "passed": cert["accuracy"].passed}
        return out

    def grid_amplitude(self, sol, block=2048):
        """``(max - min) / 2`` of every full-model DOF of the reduced solution ``sol``, shape (n,): of
        ``q = T q_r(t)`` on the solution's time grid (time-stepped modal coordinates are carried by their time
        series; their Fourier series of ``n_h`` harmonics alone missed 0.3 % of the largest amplitude on the
        workflow's impacting plate at ``n_h = 5``); the boundary DOFs keep ``sol``'s own amplitudes."""
        Q = np.asarray(sol.displacement())  # (N + 1, b + n_m): time series and the Fourier DOFs on the grid
        amp = np.empty(self.full.n)
        for i in range(0, self.full.n, block):  # rows of T in blocks: (N + 1) x block at a time
            Y = Q @ self.T[i:i + block].T
            amp[i:i + block] = 0.5 * (Y.max(axis=0) - Y.min(axis=0))
        amp[self.boundary] = np.asarray(sol.amplitude)[:self.boundary.size]
        return amp

    def error_estimate(self, sol, content=1e-3):
        """Relative error of the reduced model's linear response at the boundary (module docstring) over the
        harmonics ``k = 1..n_h`` of ``sol`` whose boundary content is at least ``content`` times the largest;
        returns ``(value, note)``."""
        qh = np.asarray(sol.q_hat)[:, :self.boundary.size]
        mags = np.hypot(qh[1::2], qh[2::2]).max(axis=1) if qh.shape[0] > 1 else np.zeros(0)
        fr = np.asarray(self.full.f_hat)
        fm = np.hypot(fr[1::2], fr[2::2]).max(axis=1) if fr.shape[0] > 1 else np.zeros(0)
        top = float(mags.max(initial=0.0))
        ks = [k for k in range(1, mags.size + 1) if mags[k - 1] >= content * top or (k <= fm.size and fm[k - 1] > 0)]
        worst, kw = 0.0, None
        for k in ks:
            key = round(k * float(sol.omega), 12)
            if key not in self._estimates:
                self._estimates[key] = self._receptance_error(k * float(sol.omega), k)
            if self._estimates[key] > worst:
                worst, kw = self._estimates[key], k
        note = ("largest relative difference between the full and the reduced model's linear responses of the "
                f"boundary DOFs (unit forces on them, and the forcing) at the harmonics with content "
                f"({len(ks)} of {mags.size})" + (f"; worst at harmonic {kw}" if kw else ""))
        return worst, note

    def _receptance_error(self, w, k):
        full, red, B = self.full, self.system, self.boundary
        n, b = full.n, B.size
        rhs = np.zeros((n, b + 2))
        rhs[B, np.arange(b)] = 1.0
        fr = np.asarray(full.f_hat)
        if 2 * k < fr.shape[0]:
            rhs[:, b], rhs[:, b + 1] = fr[2 * k - 1], fr[2 * k]
        Xf = self.full_boundary_response(w, rhs)
        Hr = red.K - w * w * red.M + 1j * w * red.C
        Xr = self.T[B] @ np.linalg.solve(Hr, self.T.T @ rhs)
        err = 0.0
        for c in range(b + 2):
            ref = float(np.linalg.norm(Xf[:, c]))
            if ref > 0:
                err = max(err, float(np.linalg.norm(Xr[:, c] - Xf[:, c])) / ref)
        return err

    def full_boundary_response(self, w, rhs, rtol=1e-10, floor=1e-6, max_iter=60):
        """The full model's response ``x_B`` of the boundary DOFs to the loads ``rhs`` (shape ``(n, m)``, N) at
        frequency ``w`` (rad/s): ``H x = rhs`` with ``H = K - w^2 M + i w C``; returns shape ``(b, m)``, m/N.

        Exact (to ``rtol``) without factorising the complex ``H``.  In the coordinates ``x = T_B x_B + E_I y``
        (``T_B = [I_b; Psi_IB]``, the constraint modes; ``y`` the interior motion relative to them) the static
        coupling vanishes (``K_IB + K_II Psi_IB = 0``), so with ``D = -w^2 M + i w C``, ``V = (D T_B)_I``::

            H_II y = r_I - V x_B,     (T_B^T H T_B - V^T H_II^{-1} V) x_B = T_B^T r - V^T H_II^{-1} r_I

        (no cancellation of nodal stiffnesses, only the dynamics enters the coupling).  ``H_II Y = [V, r_I]`` is
        solved by preconditioned Richardson iteration with the reduction's own factors, ``P = Phi (Phi^T H_II
        Phi)^{-1} Phi^T + Q K_II^{-1} Q^T`` (``Q = I - Phi Phi^T M_II``): exact on the kept modes, and on a mode
        ``j`` above them ``P H_II`` has the eigenvalue ``1 + i w beta - (w^2 - i w alpha) / w_j^2`` (Rayleigh
        damping), so the error contracts by about ``(w / w_{n_m+1})^2`` per iteration; it stops when a correction
        is ``rtol`` times ``max|Y|`` (the residual's rounding floor, ``eps |K_II| |Y|``, lies far above the
        dynamic loads ``V``, so the residual cannot measure convergence), or when the corrections stop contracting
        below ``floor`` (the rounding of ``K_II``'s LU on ill-conditioned meshes, ~1e-9 on the 10^4-DOF plate).  When it does not contract (``w`` near or above
        the first mode left out) one sparse LU of ``H`` answers instead."""
        full, B = self.full, self.boundary
        I = self._interior
        if self._K_II_lu is None or not sp.issparse(full.K) or I.size == 0:
            return self._boundary_response_lu(w, rhs)
        b = B.size
        blk = self._blocks()
        D = lambda part: (-w * w) * blk["M" + part] + (1j * w) * blk["C" + part]
        D_II = D("II")
        H_II = blk["KII"] + D_II
        Psi, Phi, MPhi = blk["Psi"], self._Phi, blk["MPhi"]
        V = D("IB").toarray() + D_II @ Psi                                      # (D T_B)_I
        TBHTB = blk["Kg"] + D("BB").toarray() + D("BI") @ Psi + Psi.T @ V        # T_B^T H T_B
        W = np.hstack([V, rhs[I].astype(complex)])
        G = Phi.T @ (H_II @ Phi) if Phi.shape[1] else np.zeros((0, 0))
        lu = self._K_II_lu

        def precondition(R):
            y = Phi @ np.linalg.solve(G, Phi.T @ R) if Phi.shape[1] else np.zeros_like(R)
            Rq = R - MPhi @ (Phi.T @ R)                      # Q^T R
            m = Rq.shape[1]
            Z = lu.solve(np.ascontiguousarray(np.hstack([Rq.real, Rq.imag])))
            Z = Z[:, :m] + 1j * Z[:, m:]
            return y + Z - Phi @ (MPhi.T @ Z)                # + Q K_II^{-1} Q^T R

        Y = precondition(W)
        last = np.inf
        for _ in range(max_iter):
            dY = precondition(W - H_II @ Y)
            Y = Y + dY
            size = float(np.abs(dY).max()) / max(float(np.abs(Y).max()), np.finfo(float).tiny)
            if size <= rtol:
                break
            if size > 0.5 * last:   # not contracting: at the rounding floor of K_II's LU, else the exact LU
                if last <= floor:
                    break
                return self._boundary_response_lu(w, rhs)
            last = size
        else:
            return self._boundary_response_lu(w, rhs)
        S = TBHTB - V.T @ Y[:, :b]
        return np.linalg.solve(S, rhs[B].astype(complex) + Psi.T @ rhs[I] - V.T @ Y[:, b:])

    def _blocks(self):
        """The full model's blocks on the boundary ``B`` and interior ``I`` (sparse), ``Psi_IB``, the Guyan
        stiffness ``K_BB + K_BI Psi_IB`` and ``M_II Phi``, cached."""
        if "blocks" not in self._cache:
            B, I = self.boundary, self._interior
            blk = {}
            for name, A in (("K", self.full.K), ("M", self.full.M), ("C", self.full.C)):
                A = _csr(A)
                A_I, A_B = A[I], A[B]
                blk[name + "II"], blk[name + "IB"] = A_I[:, I].tocsr(), A_I[:, B].tocsr()
                blk[name + "BI"], blk[name + "BB"] = A_B[:, I].tocsr(), A_B[:, B].tocsr()
            blk["Psi"] = self.T[np.ix_(I, np.arange(B.size))]
            blk["Kg"] = blk["KBB"].toarray() + blk["KBI"] @ blk["Psi"]
            blk["MPhi"] = blk["MII"] @ self._Phi
            self._cache["blocks"] = blk
        return self._cache["blocks"]

    def _boundary_response_lu(self, w, rhs):
        full, B = self.full, self.boundary
        H = full.K - w * w * full.M + 1j * w * full.C
        if sp.issparse(H):
            X = spla.splu(sp.csc_matrix(H)).solve(rhs.astype(complex))
        else:
            X = np.linalg.solve(H, rhs.astype(complex))
        return X[B]


def _csr(A):
    return sp.csr_matrix(A, dtype=float)


def craig_bampton(system, modes, keep=()):
    """Craig-Bampton reduction of ``system`` (module docstring).

    Parameters
    ----------
    system : System
    modes : int
        ``n_m >= 0`` fixed-interface modes to keep (0: Guyan's static reduction).
    keep : sequence of int
        Further full-model DOFs to keep physical (e.g. where results are wanted), besides the element DOFs.

    Returns
    -------
    ReducedModel

    Raises
    ------
    InputError
        ``reduce.modes`` out of range, ``reduce.keep`` not DOFs, or an interior that is not restrained
        (``K_II`` singular: the boundary does not hold the structure's rigid-body motion).
    """
    t0 = time.perf_counter()
    n = system.n
    if system.omega_dependent:
        raise InputError("reduce", "a Craig-Bampton reduction of a system with support motion (base) is not "
                                   "supported: reduce the structure first, then impose the base motion")
    if isinstance(modes, bool) or not isinstance(modes, (int, np.integer)) or modes < 0:
        raise InputError("reduce.modes", f"must be an integer >= 0, got {modes!r}")
    kept = []
    for i, d in enumerate(keep):
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or not 0 <= int(d) < n:
            raise InputError(f"reduce.keep[{i}]", f"must be a DOF in 0..{n - 1}, got {d!r}")
        kept.append(int(d))
    B = np.array(sorted({int(d) for e in system.elements for d in e.dofs} | set(kept)), dtype=np.int64)
    if not B.size:
        raise InputError("reduce", "needs a boundary: the model has no elements and no reduce.keep DOFs")
    I = np.setdiff1d(np.arange(n), B)
    n_i = I.size
    if modes > max(n_i - 1, 0):
        raise InputError("reduce.modes", f"must be below the {n_i} interior DOFs, got {modes}")
    M, C, K = _csr(system.M), _csr(system.C), _csr(system.K)
    K_II, M_II, K_IB = K[I][:, I].tocsc(), M[I][:, I].tocsc(), K[I][:, B]
    try:
        lu = spla.splu(K_II)
        Psi = -lu.solve(K_IB.toarray())
    except RuntimeError:
        lu = None
    if lu is None or not np.all(np.isfinite(Psi)):
        raise InputError("reduce", "the interior stiffness K_II is singular: the boundary (element and kept DOFs) "
                                   "must hold the structure (a free-floating part is not supported)")
    if modes:
        if n_i <= 400:
            lam, Phi = sla.eigh(K_II.toarray(), M_II.toarray(), subset_by_index=[0, modes - 1])
        else:
            op = spla.LinearOperator((n_i, n_i), matvec=lu.solve, dtype=float)
            lam, Phi = spla.eigsh(K_II, k=modes, M=M_II, sigma=0.0, which="LM", OPinv=op)
            order = np.argsort(lam)
            lam, Phi = lam[order], Phi[:, order]
        Phi = Phi / np.sqrt(np.einsum("ij,ij->j", Phi, M_II @ Phi))
        freqs = np.sqrt(np.maximum(lam, 0.0))
    else:
        Phi, freqs = np.zeros((n_i, 0)), np.zeros(0)
    b = B.size
    T = np.zeros((n, b + modes))
    T[B, np.arange(b)] = 1.0
    T[np.ix_(I, np.arange(b))] = Psi
    T[np.ix_(I, np.arange(b, b + modes))] = Phi

    def project(A):
        R = T.T @ (A @ T)
        return 0.5 * (R + R.T)

    Mr, Cr, Kr = project(M), project(C), project(K)
    f_r = np.asarray(system.f_hat) @ T
    col = {int(d): i for i, d in enumerate(B)}
    els = []
    for e in system.elements:
        changes = {"dof": col[int(e.dof)]}
        if e.relative_to is not None:
            changes["relative_to"] = col[int(e.relative_to)]
        els.append(dataclasses.replace(e, **changes))
    red = System(Mr, Cr, Kr, f_r, els, name=f"{system.name} (Craig-Bampton: {b} boundary DOFs + {modes} modes)")
    return ReducedModel(system, red, T, B, freqs, time.perf_counter() - t0, _interior=I,
                        _K_II_lu=lu if sp.issparse(system.K) else None, _Phi=Phi)


def stiff_time_dofs(system, omega, timed):
    """``(dofs, ratio)``: the DOFs of ``timed`` whose local frequency ``sqrt(K_dd / M_dd)`` exceeds
    :data:`AUTO_STIFF_RATIO` ``omega`` (int array) and the largest ratio ``sqrt(K_dd / M_dd) / omega`` of ``timed``
    (0 when none has mass)."""
    timed = np.asarray(timed, dtype=np.int64)
    if not timed.size:
        return timed, 0.0
    kd = np.asarray(_csr(system.K).diagonal())[timed] if sp.issparse(system.K) else np.diag(system.K)[timed]
    md = np.asarray(_csr(system.M).diagonal())[timed] if sp.issparse(system.M) else np.diag(system.M)[timed]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(md > 0, np.sqrt(np.maximum(kd, 0.0) / np.where(md > 0, md, 1.0)), 0.0) / float(omega)
    return timed[ratio > AUTO_STIFF_RATIO], float(ratio.max(initial=0.0))


def auto_reduction(system, omega, timed, harmonics):
    """The automatic Craig-Bampton reduction of a case without ``reduce:`` for a method that integrates the DOFs
    ``timed`` in time, or ``None`` when none of them is stiff (:func:`stiff_time_dofs`), the model has support
    motion, or the reduction would not shrink it.  Boundary: the element DOFs; modes: the fixed-interface modes
    up to :data:`AUTO_CUTOFF` ``harmonics omega``, at least :data:`AUTO_MIN_MODES` (doubled until the highest
    kept one passes the cut-off).  Its :attr:`ReducedModel.auto` holds the largest stiffness ratio and the cut-off."""
    stiff, ratio = stiff_time_dofs(system, omega, timed)
    if not stiff.size or system.omega_dependent:
        return None
    b = len({int(d) for e in system.elements for d in e.dofs})
    n_i = system.n - b
    modes = min(AUTO_MIN_MODES, n_i - 1)
    if modes < 0 or b + modes >= system.n:
        return None
    cutoff = AUTO_CUTOFF * max(int(harmonics), 1) * float(omega)
    red = craig_bampton(system, modes)
    while red.frequencies.size and red.frequencies[-1] < cutoff and modes < min(AUTO_MAX_MODES, n_i - 1):
        modes = min(2 * modes, AUTO_MAX_MODES, n_i - 1)
        red = craig_bampton(system, modes)
    red.auto = {"stiffness_ratio": ratio, "cutoff_rad_s": cutoff}
    return red


def method_reduction(system, omega, method, options):
    """:func:`auto_reduction` for a solve or sweep with ``method`` and ``options`` at ``omega``: the DOFs the method
    integrates in time (its capabilities, the default partition) and its ``harmonics``; ``None`` when a
    ``partition`` is given (the user chose the time-integrated DOFs) or none of them is stiff."""
    from .methods.capabilities import capabilities

    if "partition" in options:
        return None
    caps = capabilities(method)
    return auto_reduction(system, omega, caps.timed_dofs(system), options.get("harmonics") or caps.default_harmonics)
