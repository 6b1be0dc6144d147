"""Moreau-Jean time-stepping of ``M q'' + C q' + K q = f(t) + G lambda`` (thin layer over the kernel).

Notation: ``q, u`` displacement and velocity (shape ``(n,)``), ``h`` the step,
``theta`` the scheme parameter (1/2: trapezoidal, energy-conserving for the
linear part), ``P`` contact/friction impulses per step (shape ``(m,)``).
See :mod:`mshbm.integrators.kernels` for the step itself.

Jenkins elements (:class:`mshbm.elements.Jenkins`) are integrated as one massless slider DOF each,
appended after the ``n_structure`` DOFs of the structure (:func:`_with_sliders`) and stepped with
``theta = 1`` (per-DOF ``theta``: ``W = (M + h C Theta + h^2 K Theta^2)^-1``); states of the
structure alone are completed by :meth:`MoreauJean.with_slider_state`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from . import kernels
from ..errors import InputError

__all__ = ["MoreauJean", "Trajectory"]

#: machine-independent work counters of every :meth:`MoreauJean.run` in this process (reset and read by
#: callers that report effort): ``runs`` integrations, ``steps`` time steps, ``dof_steps`` time steps times
#: integrated DOFs, ``sensitivity_steps`` time steps times propagated sensitivity columns
WORK = {"runs": 0, "steps": 0, "dof_steps": 0, "sensitivity_steps": 0}

#: largest subsystem for which the dense step matrices are built (memory ~ 24 n^2 bytes)
MAX_DENSE_DOFS = 6000
#: floats kept per stepper by :meth:`MoreauJean.monodromy` (step Jacobians and their powers by active set; 32 MB)
JACOBIAN_CACHE_FLOATS = 4_000_000
#: ... and at most this many matrices
JACOBIAN_CACHE_ENTRIES = 256


@dataclass
class Trajectory:
    """Output of :meth:`MoreauJean.run`.

    Attributes
    ----------
    q, u : ndarray, shape (N+1, n)
        States at ``t_k = t0 + k h``.
    P : ndarray, shape (N, m)
        Impulse of each element over step ``k`` (force ~ ``P / h``).
    status : ndarray, shape (N, m), int8
        0 open, 1 slip, 2 stick, 3 closed (see :mod:`mshbm.integrators.kernels`).
    Sq, Su : ndarray, shape (n, n_s)
        ``d(q_N, u_N)/d(q0, u0, p)`` at the end, if sensitivities were asked for.
    Sq_traj : ndarray, shape (N+1, n, n_s)
        ``dq_k/d(q0, u0, p)`` at every step, if asked for.
    q_hat_sensitivity : ndarray or None
        Set by callers that project ``Sq_traj`` onto Fourier coefficients (MS-HBM,
        :mod:`mshbm.methods.mixed`); ``None`` from :meth:`MoreauJean.run`.
    """

    q: np.ndarray
    u: np.ndarray
    P: np.ndarray
    status: np.ndarray
    Sq: np.ndarray
    Su: np.ndarray
    Sq_traj: np.ndarray
    pgs_iterations: int
    q_hat_sensitivity: np.ndarray = None


def _with_sliders(M, C, K, elements):
    """Matrices and elements with one massless slider DOF ``z`` per Jenkins element.

    A Jenkins element (spring ``k_t`` in series with a Coulomb slider, :class:`mshbm.elements.Jenkins`)
    is a DOF ``z`` without mass, tied to ``s = w^T q`` by the spring (``K += k_t [w; -e_z][w; -e_z]^T``)
    and carrying rigid Coulomb friction on ``z``.  The step matrix ``M + h theta C + (h theta)^2 K``
    stays regular (``K_zz = k_t``); with no mass the slider's balance is the quasi-static
    ``lambda = -k_t (s_theta - z_theta)``, ``|lambda| <= mu F_N`` at every step: the friction impulse on
    ``z`` is ``h lambda``, the element's force on the structure.  Returns ``(M, C, K, elements,
    sliders)`` with ``sliders`` the list of ``(element index, slider DOF)``.
    """
    from ..elements import Friction

    jen = [j for j, el in enumerate(elements) if getattr(el, "history", False)]
    if not jen:
        return M, C, K, list(elements), []
    n = M.shape[0]
    na = n + len(jen)
    Ma, Ca, Ka = (np.zeros((na, na)) for _ in range(3))
    Ma[:n, :n], Ca[:n, :n], Ka[:n, :n] = M, C, K
    out, sliders = list(elements), []
    for i, j in enumerate(jen):
        el = elements[j]
        z = n + i
        v = np.zeros(na)
        for d, w in el.direction:
            v[d] = w
        v[z] = -1.0
        Ka += el.tangential_stiffness * np.outer(v, v)
        out[j] = Friction(z, el.mu, el.normal_force, el.smoothing, cone_partner=el.cone_partner,  # 3-D: a disk
                          normal_contact=el.normal_contact)  # the bound mu (N_0 + lambda_N) of the structure's contact
        sliders.append((j, z))
    return Ma, Ca, Ka, out, sliders


class MoreauJean:
    """Moreau-Jean integrator for a (sub)system with local elements.

    Parameters
    ----------
    M, C, K : array_like, shape (n, n)
        Matrices of the integrated (sub)system (dense or sparse).
    elements : sequence of mshbm.elements.Element
        Elements whose ``dof`` is an index *into this (sub)system*; each gives its kernel
        parameters (:meth:`~mshbm.elements.Element.kernel_parameters`).
    h : float
        Time step (s).
    theta : float
        Scheme parameter in ``[1/2, 1]``.
    project : bool
        Project penetrating contacts back onto ``g_N = 0`` after a step.
    tol, max_iter :
        Tolerance and iteration limit of the projected Gauss-Seidel solver
        (used only with several elements).
    """

    def __init__(self, M, C, K, elements, h, theta=0.5, project=True, tol=1e-14, max_iter=500):
        n = M.shape[0]
        if n > MAX_DENSE_DOFS:
            raise InputError("method", f"time-stepping {n} DOFs needs dense {n}x{n} step matrices; "
                             f"use 'mshbm' or 'hbm' for systems with more than {MAX_DENSE_DOFS} DOFs")
        dense = lambda A: A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)
        M, C, K = dense(M), dense(C), dense(K)
        #: DOFs of the structure; ``n`` counts also one massless slider DOF per Jenkins element
        self.n_structure = n
        M, C, K, elements, self.sliders = _with_sliders(M, C, K, elements)
        self.Ktilde = K
        n = M.shape[0]
        self.n, self.h, self.theta = n, float(h), float(theta)
        if not self.sliders:
            S = M + h * theta * C + (h * theta) ** 2 * K
            self.W = np.linalg.inv(S)
            self.Aq = np.ascontiguousarray(h * self.W @ K)
            self.Au = np.ascontiguousarray(h * self.W @ C + h * h * theta * self.W @ K)
        else:  # per-DOF theta: 1 on the massless sliders (their velocity is then no state)
            th = self.theta_dofs
            S = M + h * C * th + h * h * K * (th * th)
            self.W = np.linalg.inv(S)
            self.Aq = np.ascontiguousarray(h * self.W @ K)
            self.Au = np.ascontiguousarray(h * self.W @ C + h * h * self.W @ (K * th))
        m = len(elements)
        G = np.zeros((n, m))
        self.kind = np.zeros(m, dtype=np.int64)
        self.dof = np.zeros(m, dtype=np.int64)
        self.dof2 = np.full(m, -1, dtype=np.int64)  # second DOF of relative elements, -1: ground
        self.sign = np.zeros(m)
        self.bound = np.zeros(m)
        self.gap = np.zeros(m)
        self.e = np.zeros(m)
        #: normal-load coupling: index of the contact loading friction ``j`` (-1: none) and its ``mu``
        self.nsrc = np.full(m, -1, dtype=np.int64)
        self.mu_n = np.zeros(m)
        #: coefficients of the smooth elements (polynomial springs, kind 2): ``lambda_j = sum_p poly[j, p] s^p``
        order = max([max(el.powers) for el in elements if getattr(el, "smooth", False)], default=0)
        self.poly = np.zeros((m, order + 1))
        #: cone partners (the two tangential directions of a 3-D contact), -1: none
        self.tpair = np.full(m, -1, dtype=np.int64)
        for j, el in enumerate(elements):
            for d, w in el.direction:
                G[d, j] = w
            self.dof[j], self.sign[j] = el.dof, el.sign
            if el.relative_to is not None:
                self.dof2[j] = el.relative_to
            self.kind[j], self.bound[j], self.gap[j], self.e[j] = el.kernel_parameters(h)
            self.nsrc[j], self.mu_n[j] = el.kernel_coupling()
            if getattr(el, "smooth", False):
                self.poly[j] = el.kernel_polynomial(order)
            self.tpair[j] = el.kernel_partner()
        for j in np.flatnonzero(self.nsrc >= 0):
            c = int(self.nsrc[j])
            if not (0 <= c < m and c != j and self.kind[c] == kernels.KIND_CONTACT):
                raise InputError("friction.normal_contact", f"element {c} is not a contact element of this "
                                 f"(sub)system of {m} elements")
        self.G = G
        self.WG = np.ascontiguousarray(self.W @ G)
        self.Del = np.ascontiguousarray(G.T @ self.WG)
        # M^-1 G on the massive block (the slider DOFs are massless; contacts act on the structure only)
        ns = self.n_structure
        MinvG = np.zeros((n, m))
        MinvG[:ns] = np.linalg.solve(M[:ns, :ns], G[:ns])
        self.MinvG = np.ascontiguousarray(MinvG)
        self.project = bool(project)
        self.tol, self.max_iter = float(tol), int(max_iter)

    @property
    def m(self):
        return self.kind.size

    @property
    def smooth(self):
        """True if a smooth element (polynomial spring) acts: its force is evaluated explicitly at
        ``q_M = q + h/2 u`` (:mod:`mshbm.integrators.kernels`), so the step Jacobian depends on the state and
        the monodromy comes from the forward sensitivities (:meth:`run` with ``sensitivities``), not from
        :meth:`monodromy`."""
        return bool(np.any(self.kind == kernels.KIND_SMOOTH))

    @property
    def theta_dofs(self):
        """Scheme parameter per integrated DOF (``theta``; 1 on the slider DOFs of Jenkins elements)."""
        th = np.full(self.n, self.theta)
        th[self.n_structure:] = 1.0
        return th

    def with_slider_state(self, q0, u0):
        """``(q0, u0)`` of the structure completed by the slider DOFs: each slider at rest relative to its
        spring (``z = w^T q0``, ``lambda = 0``) and moving with it (``u_z = w^T u0``); states that already
        hold the sliders are returned as they are."""
        q0, u0 = np.asarray(q0, dtype=float), np.asarray(u0, dtype=float)
        if not self.sliders or q0.shape[0] == self.n:
            return q0, u0
        K = self.Ktilde
        ns = self.n_structure
        zq = np.array([-(K[z, :ns] @ q0[:ns]) / K[z, z] for _, z in self.sliders])
        zu = np.array([-(K[z, :ns] @ u0[:ns]) / K[z, z] for _, z in self.sliders])
        return np.concatenate([q0, zq]), np.concatenate([u0, zu])

    def increments(self, F):
        """Forcing increments ``b_k = h W f_theta,k`` from forces at the grid points.

        Parameters
        ----------
        F : ndarray, shape (N+1, n) or (N+1, n, n_p)
            Force (or its parameter derivative) at ``t_0 .. t_N``.

        Returns
        -------
        ndarray, shape (N, n) or (N, n, n_p)
        """
        F = np.asarray(F, dtype=float)
        if F.shape[1] == self.n_structure < self.n:  # no force on the slider DOFs
            F = np.concatenate([F, np.zeros((F.shape[0], self.n - self.n_structure) + F.shape[2:])], axis=1)
        Ft = (1.0 - self.theta) * F[:-1] + self.theta * F[1:]
        if F.ndim == 2:
            return np.ascontiguousarray(self.h * Ft @ self.W.T)
        return np.ascontiguousarray(self.h * np.einsum("il,klp->kip", self.W, Ft))

    def run(self, q0, u0, B, dB=None, sensitivities=False, store_q_sensitivities=False):
        """Integrate ``len(B)`` steps from ``(q0, u0)``.

        Parameters
        ----------
        q0, u0 : ndarray, shape (n,)
        B : ndarray, shape (N, n)
            Forcing increments from :meth:`increments`.
        dB : ndarray, shape (N, n, n_p), optional
            Derivatives of ``B`` with respect to parameters ``p``.
        sensitivities : bool
            Propagate ``d(q, u)/d(q0, u0, p)``.
        store_q_sensitivities : bool
            Keep ``dq_k/d(q0, u0, p)`` for every step.

        Returns
        -------
        Trajectory
        """
        q0, u0 = self.with_slider_state(q0, u0)
        N = B.shape[0]
        if dB is None:
            dB = np.zeros((N, self.n, 0))
        WORK["runs"] += 1
        WORK["steps"] += N
        WORK["dof_steps"] += N * self.n
        if sensitivities or store_q_sensitivities:
            WORK["sensitivity_steps"] += N * (2 * self.n + dB.shape[2])
        out = kernels.moreau_jean(
            np.ascontiguousarray(q0, dtype=float), np.ascontiguousarray(u0, dtype=float),
            self.Aq, self.Au, self.WG, self.Del, self.MinvG,
            np.ascontiguousarray(B, dtype=float), np.ascontiguousarray(dB, dtype=float),
            self.theta, self.h, self.kind, self.dof, self.dof2, self.sign, self.bound, self.gap, self.e,
            self.nsrc, self.mu_n, self.tpair, self.project, bool(sensitivities or store_q_sensitivities),
            bool(store_q_sensitivities), self.tol, self.max_iter, self.n - self.n_structure, self.poly)
        return Trajectory(*out)

    @property
    def coupled(self):
        """True if a friction element takes its normal load from a contact (:attr:`nsrc`)."""
        return bool(np.any(self.nsrc >= 0))

    def slip_signs(self, P):
        """``sign(P_j)`` of the normal-load-coupled friction elements per step (0 elsewhere), shape (N, m):
        with :meth:`monodromy` the direction of the slip whose bound follows the contact impulse."""
        S = np.zeros(P.shape, dtype=np.int64)
        cols = np.flatnonzero(self.nsrc >= 0)
        S[:, cols] = np.sign(P[:, cols]).astype(np.int64)
        return S

    def step_jacobian(self, pattern, slip_sign=None):
        """Jacobian ``d(q+, u+)/d(q, u)`` of one step for an active-set pattern.

        Parameters
        ----------
        pattern : sequence of int, length m
            Status codes of the elements in that step (see :mod:`mshbm.integrators.kernels`).
        slip_sign : sequence of int, length m, optional
            ``sign(P_j)`` of slipping friction elements whose bound follows a closed contact
            (``dP_j = sign(P_j) mu dP_c``); needed only for such elements (:attr:`coupled`).

        Returns
        -------
        ndarray, shape (2n, 2n)
        """
        n, h = self.n, self.h
        I, dUf, dU, dQ0 = self._jacobian_parts()
        pattern = np.asarray(pattern, dtype=np.int64)
        base = pattern & 3
        eq = base >= kernels.STATUS_STICK
        slip = np.zeros_like(eq)
        for j in np.flatnonzero(self.nsrc >= 0):
            c = self.nsrc[j]
            if base[j] == kernels.STATUS_SLIP and base[c] == kernels.STATUS_CLOSED:
                if slip_sign is None or slip_sign[j] == 0:
                    raise ValueError("step_jacobian: a friction element slips with the bound of a closed "
                                     "contact; pass slip_sign (MoreauJean.slip_signs)")
                slip[j] = True
        for j in np.flatnonzero(self.tpair >= 0):
            if base[j] == kernels.STATUS_SLIP:
                raise InputError("friction.cone_partner", "the step Jacobian of a 3-D frictional contact in slip "
                                 "depends on the slip direction, not on the active set alone: use the kernel's "
                                 "sensitivities (run(..., sensitivities=True))")
        E = np.flatnonzero(eq | slip)
        dUn = dUf.copy()
        if E.size:
            rows = np.zeros((E.size, 2 * n))
            A = np.zeros((E.size, E.size))
            where = {int(j): a for a, j in enumerate(E)}
            for a, j in enumerate(E):
                if slip[j]:  # dP_j - sign(P_j) mu dP_c = 0
                    A[a, a] = 1.0
                    A[a, where[int(self.nsrc[j])]] = -float(slip_sign[j]) * self.mu_n[j]
                    continue
                ee = self.e[j] if self.kind[j] == kernels.KIND_CONTACT else 0.0
                rows[a] = -(self.G[:, j] @ dUf + ee * (self.G[:, j] @ dU))
                A[a] = self.Del[j, E]
            dP = np.linalg.solve(A, rows)
            dUn += self.WG[:, E] @ dP
        thd = self.theta_dofs[:, None]
        dQn = dQ0 + h * thd * dUn
        for j in np.flatnonzero(pattern & kernels.STATUS_PROJECTED):
            w = self.G[:, j] @ self.MinvG[:, j]
            dQn = dQn - np.outer(self.MinvG[:, j], (self.G[:, j] @ dQn) / w)
        return np.vstack([dQn, dUn])

    def _jacobian_parts(self):
        """The pattern-independent pieces of :meth:`step_jacobian` (formed once): ``I``, ``d u_free / d(q, u)``,
        ``d u / d(q, u)`` and the ``d q+ / d(q, u)`` part without ``u+``."""
        parts = self.__dict__.get("_jac_parts")
        if parts is None:
            n, h = self.n, self.h
            I = np.eye(n)
            thd = self.theta_dofs[:, None]
            parts = self._jac_parts = (I, np.hstack([-self.Aq, I - self.Au]), np.hstack([np.zeros((n, n)), I]),
                                       np.hstack([I, h * (1 - thd) * I]))
        return parts

    def _cached(self, key, make):
        """``make()`` kept per stepper under ``key`` (step Jacobians and their powers of :meth:`monodromy`, which
        Newton's iterations ask again for the same active sets), within :data:`JACOBIAN_CACHE_FLOATS`."""
        cache = self.__dict__.setdefault("_jac_cache", {})
        value = cache.get(key)
        if value is None:
            value = make()
            size = 4 * self.n * self.n
            if size * (len(cache) + 1) > JACOBIAN_CACHE_FLOATS or len(cache) >= JACOBIAN_CACHE_ENTRIES:
                cache.clear()
            if size <= JACOBIAN_CACHE_FLOATS:
                cache[key] = value
        return value

    def monodromy(self, status, P=None):
        """Product of the step Jacobians along a trajectory, from its status array (and, with
        normal-load-coupled friction, :attr:`coupled`, its impulses ``P``: the slip directions).

        Consecutive steps with the same active set share one Jacobian, so the
        product is formed from matrix powers of runs: cost
        ``O(runs * log(run length) * n^3)`` instead of ``O(N n^3)``.

        Parameters
        ----------
        status : ndarray, shape (N, m)
        P : ndarray, shape (N, m), optional
            Impulses of the trajectory; required when :attr:`coupled`.

        Returns
        -------
        ndarray, shape (2n, 2n)
        """
        if self.smooth:
            raise ValueError("monodromy: a polynomial spring makes the step Jacobian depend on the state; "
                             "integrate with sensitivities=True (Trajectory.Sq, Su) instead")
        N = status.shape[0]
        Phi = np.eye(2 * self.n)
        cache = {}
        if self.m == 0:
            return np.linalg.matrix_power(self._cached((), lambda: self.step_jacobian(())), N)
        signs = None
        if self.coupled:
            if P is None:
                raise ValueError("monodromy: friction with a normal load from a contact needs the impulses P")
            signs = self.slip_signs(np.asarray(P))
            ext = np.hstack([status.astype(np.int64), signs])
            codes = np.unique(ext, axis=0, return_inverse=True)[1].reshape(-1)
        else:
            codes = status.astype(np.int64) @ (8 ** np.arange(self.m))
        change = np.flatnonzero(np.diff(codes)) + 1
        starts = np.concatenate([[0], change])
        ends = np.concatenate([change, [N]])
        for s, e in zip(starts, ends):
            key = int(codes[s])
            if key not in cache:
                # the active set (and slip signs) of the run: its step Jacobian, kept across calls by that pattern
                pat = (status[s].astype(np.int64).tobytes(), None if signs is None else signs[s].tobytes())
                jac = self._cached(pat, lambda: self.step_jacobian(status[s], None if signs is None else signs[s]))
                cache[key] = (pat, jac)
            pat, jac = cache[key]
            k = int(e - s)
            Jk = jac if k == 1 else self._cached((pat, k), lambda: np.linalg.matrix_power(jac, k))
            Phi = Jk @ Phi
        return Phi
