"""Finite-element cantilever beam with a friction joint and an impact stop, written as a case file.

The linear structure is an Euler-Bernoulli beam (length ``L``, rectangular ``b x h`` section,
Young's modulus ``E``, density ``rho``) clamped at ``x = 0`` and free at ``x = L``, meshed with
``n_el`` Hermite cubic elements.  Each node carries a transverse displacement ``w`` and a rotation
``theta = w'``; the clamped node is removed, so DOF ``2 (i-1)`` is ``w`` and ``2 (i-1) + 1`` is
``theta`` of node ``i = 1..n_el`` (``n = 2 n_el`` DOFs).  Element matrices (length ``l``)::

    K_e = E I / l^3  [[12, 6l, -12, 6l], [6l, 4l^2, -6l, 2l^2], [-12, -6l, 12, -6l], [6l, 2l^2, -6l, 4l^2]]
    M_e = rho A l / 420 [[156, 22l, 54, -13l], [22l, 4l^2, 13l, -3l^2], [54, 13l, 156, -22l],
                         [-13l, -3l^2, -22l, 4l^2]]            (consistent mass)

Rayleigh damping ``C = alpha M + beta K`` is chosen for the modal damping ratio ``zeta`` at the
first two bending frequencies (``zeta_r = alpha / (2 w_r) + beta w_r / 2``).

Nonlinear elements (the present element types act between one DOF and the ground):

* a friction joint on the transverse DOF of the node nearest ``x_friction L`` whose bound ``mu F_N``
  is ``friction_ratio`` times the forcing amplitude;
* an impact stop (unilateral contact) at the tip, gap ``gap_ratio`` times the tip amplitude of the
  linear response (no friction, no stop) at the forcing frequency;
* harmonic forcing ``F cos(omega t)`` on the transverse DOF of the node nearest ``x_force L``, at
  ``omega = omega_ratio w_1`` (near the first bending resonance).

With ``bodies=True`` the two elements act instead on two lumped bodies appended to the structure as
DOFs ``n`` (the friction *shoe*, tied to the friction node) and ``n + 1`` (the *pad* of the impact
stop, tied to the tip), each of mass ``m_b = body_mass_ratio rho A L`` on a spring
``k_b = m_b (body_freq_ratio w_1)^2`` (``w_1`` the closed-form beam value): an elastic friction
joint (a Jenkins element with a small slider mass) and a stop hit through a contact pad.  Why: MS-HBM
integrates the element DOFs in time with their own ``M_NN, C_NN, K_NN``; a node DOF of a fine mesh
has ``sqrt(K_dd / M_dd)`` ~ 10^7 ``omega`` and, with Rayleigh damping, ``C_dd / M_dd = beta K_dd / M_dd``
~ 10^12 ``omega`` (10^4-DOF beam), which Moreau-Jean steps resolve badly and the exact event-driven
flow (sub-steps ``h_s <= 1 / (2 ||A||_1)``, ~10^18 per period there) cannot integrate at all; a body
on a spring has ``body_freq_ratio`` as its local frequency ratio, independent of the mesh.

With ``reduce_modes=N`` the case file asks for a Craig-Bampton reduction (``reduce: {method: craig_bampton,
modes: N}``, :mod:`mshbm.reduction`): the element DOFs are the boundary and stay physical nodes, the rest is
``N`` fixed-interface modes plus the static constraint modes, so every method solves ``2 + N`` DOFs and the
time-integrated node DOFs carry the model's effective mass instead of their tiny nodal mass.  This is the
treatment of node DOFs; the bodies are the older workaround.

Conditioning: ``cond(K)`` grows like ``n_el^4`` (~1e14 at 10^4 DOFs).  The rounding errors of a
factorisation of ``K`` (or of ``K - omega^2 M + i omega C``) then shift ``w_1`` by ~1e-3 and the linear
tip response at ``0.98 w_1`` by up to a factor 2, by amounts that depend on the LU ordering and the
processor's BLAS kernels.  Hence every solve here is refined (:class:`RefinedSolver`: residuals with
exact products and compensated sums, corrections from the LU, GMRES on top when plain refinement
stalls) and the frequencies come from subspace iteration with those solves
(:func:`natural_frequencies`): both are the exact answers for the stored ``M``, ``K`` and the Rayleigh
coefficients to ~1e-13, on any processor.  The stored matrices are themselves rounded: their exact
answers differ from those of the exact finite-element model by the sensitivity to ``u``-sized entry
perturbations (``u = 1.1e-16``), ~2e-8 in ``w_1`` of the 5000-element beam (against
:func:`beam_frequencies_factored`, which never forms ``K``) and ~1e-4 in ``w_1`` of the 50 x 49 plate,
whose elements are 12 times narrower than the plate is thick (3e-6 at 50 x 24).  The plate's
matrices are Kronecker products of exact 1-D integrals (:func:`_hermite_1d`), so they do not depend
on the processor either.

The first bending frequencies are checked against the closed-form cantilever values
``w_r = (beta_r L)^2 sqrt(E I / (rho A L^4))`` with ``beta_r L = 1.8751, 4.6941, 7.8548, ...``
(:func:`cantilever_frequencies`).

Outputs (in ``out_dir``): ``M.mtx`` and ``K.mtx`` (Matrix Market, symmetric, sparse), the case file
(default ``beam.yaml``, referring to the matrices by relative path, its header lists the natural
frequencies) and ``modes.json`` (frequencies, parameters, the linear response).

Usage::

    python workflow/scripts/fe/build_fe_model.py OUT_DIR [--n-el 5000] [--case beam.yaml]
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import scipy.io as sio
import scipy.sparse as sp
import scipy.sparse.linalg as spla

#: beta_r L of the clamped-free Euler-Bernoulli beam (roots of cos x cosh x = -1)
CANTILEVER_BETA_L = (1.8751040687119611, 4.6940911329741745, 7.8547574382376126,
                     10.995540734875467, 14.137168391046471)

DEFAULTS = dict(
    n_el=5000,            # elements (n = 2 n_el DOFs)
    length=1.0,           # m
    width=0.04,           # m  (b)
    height=0.01,          # m  (h, bending direction)
    young=210e9,          # Pa (steel)
    density=7850.0,       # kg/m^3
    zeta=0.01,            # Rayleigh damping ratio at the first two bending frequencies
    x_force=0.75,         # forcing node position / L
    force=1.0,            # N, amplitude of F cos(omega t)
    omega_ratio=0.98,     # omega / w_1
    x_friction=0.5,       # friction node position / L
    mu=0.3,               # friction coefficient
    friction_ratio=0.2,   # mu F_N / force
    smoothing=None,       # kappa (s/m) of the HBM regularisation; default 100 / (linear friction DOF velocity)
    gap_ratio=0.5,        # tip gap / linear tip amplitude
    restitution=0.8,      # e_N
    penalty_ratio=100.0,  # HBM penalty stiffness / tip stiffness 3 E I / L^3
    harmonics=5,          # solver.harmonics in the case file
    steps=8192,           # solver.steps (time steps per period of MS-HBM's time-stepped DOFs)
    model="beam",         # "beam" or "plate" (Kirchhoff plate width x height, n_el x ny BFS elements)
    ny=49,                # plate: elements across the width
    poisson=0.3,          # plate: Poisson's ratio
    bodies=False,         # elements on two lumped bodies attached by springs (see module docstring)
    body_mass_ratio=0.01, # mass of each body / structure mass rho A L
    body_freq_ratio=20.0, # sqrt(k_b / m_b) / closed-form w_1 of each body on its spring
    reduce_modes=None,    # fixed-interface modes of a Craig-Bampton reduction (case key reduce:); None: none
)


def section(width, height):
    """Area ``A`` and second moment ``I`` of a ``width x height`` rectangle (bending along height)."""
    return width * height, width * height ** 3 / 12.0


def element_matrices(l, EI, rhoA):
    """Hermite cubic stiffness and consistent mass matrices (4 x 4) of an element of length ``l``."""
    Ke = EI / l ** 3 * np.array([[12, 6 * l, -12, 6 * l],
                                 [6 * l, 4 * l * l, -6 * l, 2 * l * l],
                                 [-12, -6 * l, 12, -6 * l],
                                 [6 * l, 2 * l * l, -6 * l, 4 * l * l]])
    Me = rhoA * l / 420.0 * np.array([[156, 22 * l, 54, -13 * l],
                                      [22 * l, 4 * l * l, 13 * l, -3 * l * l],
                                      [54, 13 * l, 156, -22 * l],
                                      [-13 * l, -3 * l * l, -22 * l, 4 * l * l]])
    return Ke, Me


def _symmetric(M, K):
    """``(M, K)`` made exactly symmetric (the element matrices are, the sums in another order may not be), as
    CSR with sorted indices and no duplicates."""
    out = []
    for A_ in (M, K):
        A_ = sp.csr_matrix(0.5 * (A_ + A_.T))
        A_.sum_duplicates()
        A_.sort_indices()
        out.append(A_)
    return tuple(out)


def beam_matrices(n_el, length=1.0, young=210e9, density=7850.0, width=0.04, height=0.01, clamped=True):
    """Assembled ``(M, K)`` (CSR) of the beam; ``clamped``: node 0 removed (cantilever), else free-free."""
    if int(n_el) < 1:
        raise ValueError(f"n_el must be >= 1, got {n_el}")
    n_el = int(n_el)
    A, I = section(width, height)
    Ke, Me = element_matrices(length / n_el, young * I, density * A)
    dofs = 2 * np.arange(n_el)[:, None] + np.arange(4)[None, :]        # (n_el, 4) global DOFs
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    n_all = 2 * (n_el + 1)
    K = sp.coo_matrix((np.tile(Ke.ravel(), n_el), (rows, cols)), shape=(n_all, n_all)).tocsr()
    M = sp.coo_matrix((np.tile(Me.ravel(), n_el), (rows, cols)), shape=(n_all, n_all)).tocsr()
    if clamped:
        K, M = K[2:, 2:], M[2:, 2:]
    return _symmetric(M, K)


#: integrals of products of the 1-D Hermite shape functions on ``[0, 1]`` (DOFs ``(w, l w')`` per node),
#: as integer matrices and their denominators: ``int N N``, ``int N' N'``, ``int N'' N''``, ``int N'' N``
_HERMITE_INT = (
    (np.array([[156, 22, 54, -13], [22, 4, 13, -3], [54, 13, 156, -22], [-13, -3, -22, 4]]), 420.0),
    (np.array([[36, 3, -36, 3], [3, 4, -3, -1], [-36, -3, 36, -3], [3, -1, -3, 4]]), 30.0),
    (np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]]), 1.0),
    (np.array([[-36, -3, 36, -3], [-33, -4, 3, 1], [36, 3, -36, 3], [-3, 1, 33, -4]]), 30.0),
)


def _hermite_1d(n_el, length, clamped):
    """Global 1-D Hermite matrices ``(int N N, int N' N', int N'' N'', int N'' N)`` on ``n_el`` equal
    elements (DOFs ``(w, l w')`` per node, ``l`` the element length; ``clamped``: node 0 removed).

    The element matrices are the exact integrals, a scalar (``l / 420``, ``1 / (30 l)``, ``1 / l^3``,
    ``1 / (30 l)``) times an integer matrix: every entry is one rounding of that product, the same on
    every processor (no BLAS), and the rigid-body modes of the stiffness stay exact.  Slope DOFs in
    length units (``l w'``): every DOF is a displacement, and the matrices stay well scaled."""
    l = length / n_el
    scales = (l / 420.0, 1.0 / (30.0 * l), 1.0 / l ** 3, 1.0 / (30.0 * l))
    dofs = 2 * np.arange(n_el)[:, None] + np.arange(4)[None, :]
    rows, cols = np.repeat(dofs, 4, axis=1).ravel(), np.tile(dofs, (1, 4)).ravel()
    n_all = 2 * (n_el + 1)
    out = []
    for (E_, _), c in zip(_HERMITE_INT, scales):
        A_ = sp.coo_matrix((np.tile((c * E_).ravel(), n_el), (rows, cols)), shape=(n_all, n_all)).tocsr()
        out.append(A_[2:, 2:] if clamped else A_)
    return out


def plate_matrices(nx, ny, lx=1.0, ly=0.2, thickness=0.01, young=210e9, poisson=0.3, density=7850.0):
    """Kirchhoff plate ``lx x ly`` clamped along ``x = 0``, free elsewhere, ``nx x ny`` conforming
    bicubic Hermite (Bogner-Fox-Schmit) elements; DOFs ``(w, lx_e w_x, ly_e w_y, lx_e ly_e w_xy)`` per
    node (``lx_e, ly_e``: element sizes; all DOFs in metres, which keeps ``K`` well scaled).

    On a tensor mesh the element matrices are Kronecker products of 1-D Hermite matrices, and so are
    the assembled ones: with ``D = E t^3 / (12 (1 - nu^2))`` and the 1-D matrices ``M1 = int N N``,
    ``G1 = int N' N'``, ``K1 = int N'' N''``, ``B1 = int N'' N``::

        M = rho t (M1x (x) M1y)
        K = D (K1x (x) M1y + M1x (x) K1y + nu (B1x (x) B1y^T + B1x^T (x) B1y) + 2 (1 - nu) G1x (x) G1y)

    (the bending energy ``D/2 int w_xx^2 + w_yy^2 + 2 nu w_xx w_yy + 2 (1 - nu) w_xy^2``).  Global DOF
    ``i_x * 2 (ny + 1) + i_y`` couples the x-DOF ``i_x`` (``(w, d/dx)`` of x-node ``i_x + 1``) with
    the y-DOF ``i_y`` (``(w, d/dy)`` of y-node ``i_y // 2``).  Returns ``(M, K)`` as CSR.
    """
    Mx, Gx, Kx, Bx = _hermite_1d(nx, lx, True)
    My, Gy, Ky, By = _hermite_1d(ny, ly, False)
    D = young * thickness ** 3 / (12.0 * (1.0 - poisson ** 2))
    M = density * thickness * sp.kron(Mx, My, format="csr")
    K = D * (sp.kron(Kx, My) + sp.kron(Mx, Ky) + poisson * (sp.kron(Bx, By.T) + sp.kron(Bx.T, By))
             + 2.0 * (1.0 - poisson) * sp.kron(Gx, Gy))
    return _symmetric(M, K)


def plate_w_dof(x_over_L, y_over_L, nx, ny):
    """Transverse DOF ``w`` of the plate node nearest ``(x, y)`` (fractions of ``lx``, ``ly``)."""
    ix = min(max(int(round(x_over_L * nx)), 1), nx) - 1
    iy = min(max(int(round(y_over_L * ny)), 0), ny)
    return (2 * ix) * 2 * (ny + 1) + 2 * iy


def cantilever_frequencies(n_modes, length=1.0, young=210e9, density=7850.0, width=0.04, height=0.01):
    """Closed-form angular frequencies (rad/s) of the first ``n_modes`` bending modes."""
    A, I = section(width, height)
    c = math.sqrt(young * I / (density * A * length ** 4))
    return np.array([bl ** 2 * c for bl in CANTILEVER_BETA_L[:n_modes]])


def _split(a):
    """Dekker's split ``a = hi + lo`` with ``hi``, ``lo`` of at most 26 significant bits each."""
    t = 134217729.0 * a                      # 2^27 + 1
    hi = t - (t - a)
    return hi, a - hi


def _two_sum(a, b):
    """``a + b = s + e`` exactly (Knuth's TwoSum), elementwise."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


class _AccurateMatvec:
    """``A @ x`` of a real sparse matrix with every product exact (Dekker's TwoProduct) and every row sum
    compensated (TwoSum): the result is as accurate as a matvec in twice the working precision, then
    rounded.  Needed for the residuals of ``K``: a smooth ``x`` makes ``K x`` the tiny difference of terms
    ``~ |K| |x|``, ``cond(K)`` (``~ n_el^4``) times larger."""

    def __init__(self, A):
        A = sp.csr_matrix(A)
        A.sum_duplicates()
        n = A.shape[0]
        lens = np.diff(A.indptr)
        width = int(lens.max()) if n else 0
        self.shape = A.shape
        self.cols = np.zeros((width, n), dtype=np.intp)
        vals = np.zeros((width, n))
        row = np.repeat(np.arange(n), lens)
        pos = np.arange(A.nnz) - np.repeat(A.indptr[:-1], lens)
        self.cols[pos, row] = A.indices
        vals[pos, row] = A.data
        self.vals = vals
        self.hi, self.lo = _split(vals)

    def __call__(self, x):
        """``A @ x`` for real ``x`` of shape ``(n,)`` or ``(n, p)``."""
        x = np.asarray(x, dtype=float)
        two_d = x.ndim == 2
        X = x if two_d else x[:, None]
        s = np.zeros((self.shape[0], X.shape[1]))
        e = np.zeros_like(s)
        for k in range(self.vals.shape[0]):
            a, ah, al = self.vals[k][:, None], self.hi[k][:, None], self.lo[k][:, None]
            b = X[self.cols[k]]
            bh, bl = _split(b)
            prod = a * b
            perr = ((ah * bh - prod) + ah * bl + al * bh) + al * bl
            s, serr = _two_sum(s, prod)
            e += serr + perr
        y = s + e
        return y if two_d else y[:, 0]


class RefinedSolver:
    """Solves ``(sum_k c_k A_k) x = b`` (real sparse ``A_k``, real or complex scalars ``c_k``) accurately:
    a sparse LU of the assembled matrix in double precision, then iterative refinement with residuals
    ``b - sum_k c_k (A_k x)`` whose matvecs are exact to twice the working precision
    (:class:`_AccurateMatvec`), until the correction is below ``tol`` times the solution (max norm).

    Why: ``cond(K)`` grows like ``n_el^4`` (~1e14 at 10^4 DOFs), and the rounding of the LU, and even of
    the assembled entries of ``K - w^2 M + i w C``, shifts the solution by percents; the refinement
    converges to the solution of the problem the matrices ``A_k`` (as stored) and scalars ``c_k`` define,
    independently of the ordering of the LU and of the processor's BLAS kernels.
    """

    def __init__(self, terms, permc_spec=None, tol=1e-14, maxiter=30):
        self.terms = [(c, _AccurateMatvec(A)) for c, A in terms]
        H = sum(c * sp.csc_matrix(A) for c, A in terms)
        self.dtype = np.result_type(*[np.asarray(c).dtype for c, _ in terms], float)
        self.lu = spla.splu(sp.csc_matrix(H, dtype=self.dtype), permc_spec=permc_spec)
        self.tol, self.maxiter = tol, maxiter
        self.iterations = 0

    def apply(self, x):
        """``sum_k c_k A_k x`` with accurate matvecs (``x``: ``(n,)`` or ``(n, p)``)."""
        out = 0.0
        for c, A in self.terms:
            Ax = A(x.real) + 1j * A(x.imag) if np.iscomplexobj(x) else A(x)
            out = out + c * Ax
        return out

    def _gmres(self, r):
        """Correction ``H^-1 r`` by GMRES on the accurate operator, preconditioned by the LU (per column)."""
        n = self.lu.shape[0]
        A = spla.LinearOperator((n, n), matvec=lambda v: self.apply(np.ravel(v)), dtype=self.dtype)
        P = spla.LinearOperator((n, n), matvec=lambda v: self.lu.solve(np.ravel(v)), dtype=self.dtype)
        cols = r[:, None] if r.ndim == 1 else r
        out = np.empty_like(cols)
        for j in range(cols.shape[1]):
            out[:, j], _ = spla.gmres(A, cols[:, j], M=P, rtol=1e-10, atol=0.0, restart=40, maxiter=5)
        return out[:, 0] if r.ndim == 1 else out

    def solve(self, b):
        """``x`` with ``(sum_k c_k A_k) x = b`` (``b``: ``(n,)`` or ``(n, p)``); raises if the refinement
        does not converge.  The corrections come from the LU while they shrink at least twofold per
        step, else from GMRES preconditioned by the LU (the LU of a very ill-conditioned matrix can be
        too far off for plain refinement; its error is concentrated on a few smooth vectors, which
        GMRES removes in a few iterations)."""
        b = np.asarray(b, dtype=np.result_type(self.dtype, np.asarray(b).dtype))
        x = self.lu.solve(b)
        last, krylov = np.inf, False
        for it in range(1, self.maxiter + 1):
            r = b - self.apply(x)
            dx = self._gmres(r) if krylov else self.lu.solve(r)
            x = x + dx
            rel = float(np.max(np.abs(dx).max(axis=0) / np.abs(x).max(axis=0)))
            if rel <= self.tol:
                self.iterations = it
                return x
            krylov = krylov or rel > 0.5 * last
            last = rel
        raise RuntimeError(f"iterative refinement did not converge in {self.maxiter} steps "
                           f"(last correction {rel:.1e} of the solution)")


def natural_frequencies(M, K, n_modes=3, permc_spec=None, guard=4, tol=1e-14, maxiter=100, vectors=False):
    """Lowest ``n_modes`` angular frequencies (rad/s) of ``K phi = w^2 M phi``, accurate to ~1e-13.

    Start: ``eigsh`` in shift-invert mode about 0 (``n_modes + guard`` pairs; its factorisation of ``K``,
    ``cond(K) ~ n_el^4``, puts ``w_1`` ~1e-3 off at 10^4 DOFs, by an amount that depends on the
    processor).  Then subspace iteration ``Y = K^-1 M V`` with the refined solves of
    :class:`RefinedSolver` and Rayleigh-Ritz on ``Y`` (accurate ``K Y``), until the Rayleigh quotients
    ``v^T K v / v^T M v`` (accurate ``K v``) of the lowest ``n_modes`` change by less than ``tol``
    (relative); the error of a Rayleigh quotient is quadratic in that of its vector.  With
    ``vectors=True`` also the mode shapes ``(n, n_modes)``.
    """
    import scipy.linalg as sla

    n = M.shape[0]
    p = min(n_modes + guard, n - 1)
    Kacc = _AccurateMatvec(K)
    M = sp.csr_matrix(M)
    if n <= 64:
        lam, V = sla.eigh(K.toarray(), M.toarray())
        V = V[:, :p]
    else:
        v0 = np.ones(n)  # a fixed start vector: the same start on every run
        lam, V = spla.eigsh(K.tocsc(), k=p, M=M.tocsc(), sigma=0.0, which="LM", v0=v0)
        V = V[:, np.argsort(lam)]
    solver = RefinedSolver([(1.0, K)], permc_spec=permc_spec, tol=1e-12)
    rq_old = None
    for _ in range(maxiter):
        Y = solver.solve(M @ V)
        Y = Y / np.sqrt(np.einsum("ij,ij->j", Y, M @ Y))
        Kp, Mp = Y.T @ Kacc(Y), Y.T @ (M @ Y)
        lam, c = sla.eigh(0.5 * (Kp + Kp.T), 0.5 * (Mp + Mp.T))
        V = Y @ c
        rq = np.einsum("ij,ij->j", V, Kacc(V)) / np.einsum("ij,ij->j", V, M @ V)
        order = np.argsort(rq)[:n_modes]
        rq = rq[order]
        if rq_old is not None and np.all(np.abs(rq / rq_old - 1.0) <= tol):
            return (np.sqrt(rq), V[:, order]) if vectors else np.sqrt(rq)
        rq_old = rq
    raise RuntimeError(f"subspace iteration did not converge in {maxiter} steps")


def beam_frequencies_factored(n_el, n_modes=3, length=1.0, young=210e9, density=7850.0, width=0.04, height=0.01):
    """Lowest ``n_modes`` angular frequencies (rad/s) of the clamped beam of :func:`beam_matrices`, with
    ``K`` applied in factored form.

    The Hermite element's curvature is linear, so 2-point Gauss quadrature of ``EI int w''^2`` is exact:
    ``K = R^T W R`` with ``R`` (``2 n_el x 2 n_el``, square for the clamped beam) the curvatures at the
    Gauss points and ``W = EI l / 2``.  Shift-invert with ``K^-1 = R^-1 W^-1 R^-T`` (two sparse triangular-
    like solves with ``R``, whose condition number is the square root of ``K``'s) avoids the rounding of a
    factorisation of ``K`` itself, whose condition number grows like ``n_el^4`` (at 5000 elements plain
    shift-invert ``eigsh`` is off by ~1e-3 in ``w_1``; this function by ~1e-13).  It never forms ``K``:
    it gives the exact model's frequencies, :func:`natural_frequencies` those of the stored (rounded)
    ``K``, 1.6e-8 apart in ``w_1`` at 5000 elements, 1e-10 at 1000."""
    n_el = int(n_el)
    A, I = section(width, height)
    l = length / n_el
    xi = 0.5 * (np.array([-1.0, 1.0]) / math.sqrt(3.0) + 1.0)
    d2 = np.array([-6 + 12 * xi, l * (-4 + 6 * xi), 6 - 12 * xi, l * (-2 + 6 * xi)]).T / l ** 2  # (2 Gauss, 4)
    dofs = 2 * np.arange(n_el)[:, None] + np.arange(4)[None, :] - 2      # clamped node removed
    rows = np.repeat(2 * np.arange(n_el)[:, None] + np.arange(2)[None, :], 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 2)).ravel()
    vals = np.tile(d2.ravel(), n_el)
    keep = cols >= 0
    n = 2 * n_el
    R = sp.csc_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n, n))
    Wq = young * I * l / 2.0
    lu = spla.splu(R)
    op = spla.LinearOperator((n, n), matvec=lambda x: lu.solve(lu.solve(np.ravel(x), trans="T")) / Wq, dtype=float)
    M, K = beam_matrices(n_el, length, young, density, width, height)
    w2 = spla.eigsh(K, k=n_modes, M=M.tocsc(), sigma=0.0, OPinv=op, which="LM", return_eigenvectors=False,
                    v0=np.ones(n))
    return np.sqrt(np.sort(w2))


def rayleigh_coefficients(w1, w2, zeta):
    """``(alpha, beta)`` with damping ratio ``zeta`` at ``w1`` and ``w2``."""
    alpha = 2.0 * zeta * w1 * w2 / (w1 + w2)
    beta = 2.0 * zeta / (w1 + w2)
    return alpha, beta


def node_dof(x_over_L, n_el):
    """Transverse DOF of the node nearest ``x = x_over_L L`` (nodes 1..n_el; node 0 is clamped)."""
    node = min(max(int(round(x_over_L * n_el)), 1), n_el)
    return 2 * (node - 1), node


def linear_response(M, C, K, omega, dof, force, rayleigh=None, permc_spec=None):
    """Complex amplitudes ``Q`` of ``(K - omega^2 M + i omega C) Q = e_dof force``: sparse LU and iterative
    refinement with accurate residuals (:class:`RefinedSolver`), so ``Q`` is the solution of the problem
    the stored ``M, C, K`` define to ~1e-13, on any processor and for any ordering ``permc_spec`` of the LU
    (a plain sparse solve is off by percents at 10^4 DOFs).

    With ``rayleigh = (alpha, beta)`` the damping is ``C = alpha M + beta K`` exactly (``C`` is not used):
    the operator is ``(1 + i omega beta) K + (-omega^2 + i omega alpha) M``.  The rounded entries of a
    stored ``C`` break the near-null space of ``beta K`` (smooth vectors) as those of ``K - omega^2 M``
    would, which at 10^4 DOFs changes the response by ~1e-3 and stops the refinement converging."""
    f = np.zeros(M.shape[0], dtype=complex)
    f[dof] = force
    if rayleigh is not None:
        alpha, beta = rayleigh
        terms = [(1.0 + 1j * omega * beta, K), (-omega ** 2 + 1j * omega * alpha, M)]
    else:
        terms = [(1.0, K), (-omega ** 2, M), (1j * omega, C)]
    return RefinedSolver(terms, permc_spec=permc_spec, tol=1e-13).solve(f)


def attach_bodies(M, K, node_dofs, m_b, k_b):
    """Append one body of mass ``m_b`` per entry of ``node_dofs``, tied to that DOF by a spring ``k_b``.

    Returns ``(M, K)`` (CSR) of size ``n + len(node_dofs)``; body ``j`` is DOF ``n + j``.
    """
    n, nb = M.shape[0], len(node_dofs)
    rows, cols, vals = [], [], []
    for j, d in enumerate(node_dofs):
        b = n + j
        rows += [d, d, b, b]
        cols += [d, b, d, b]
        vals += [k_b, -k_b, -k_b, k_b]
    N = n + nb
    Kb = sp.coo_matrix((vals, (rows, cols)), shape=(N, N))
    Mb = sp.coo_matrix((np.full(nb, float(m_b)), (np.arange(n, N), np.arange(n, N))), shape=(N, N))
    K2 = (sp.block_diag([K, sp.csr_matrix((nb, nb))]) + Kb).tocsr()
    M2 = (sp.block_diag([M, sp.csr_matrix((nb, nb))]) + Mb).tocsr()
    for A_ in (K2, M2):
        A_.sum_duplicates()
        A_.sort_indices()
    return M2, K2


def event_substeps(M, C, K, dofs, omega):
    """Sub-steps per period of the exact event-driven flow (:mod:`mshbm.integrators.event`) for the
    subsystem of ``dofs`` that MS-HBM integrates in time: ``ceil(2 T ||A_s||_1)`` with the balanced
    ``A_s = D^-1 A_xx D`` of ``A_xx = [[0, I], [-M_NN^-1 K_NN, -M_NN^-1 C_NN]]`` (``D`` from LAPACK's gebal,
    no permutation, kept only if it lowers the norm: the rule of ``EventFlow._scaling``), which grows like
    the fastest rate ``max(sqrt(K_NN / M_NN), C_NN / M_NN)``, not like ``K_NN / M_NN``.  The flow refuses a
    subsystem above ``MAX_SUBSTEPS`` per period; this count is reported either way."""
    import scipy.linalg as sla

    ix = np.ix_(dofs, dofs)
    Mn, Cn, Kn = (np.asarray(A.tocsr()[ix].toarray()) for A in (M, C, K))
    Mi = np.linalg.inv(Mn)
    m = len(dofs)
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-Mi @ Kn, -Mi @ Cn]])
    norm = np.abs(A).sum(axis=0).max()
    As, _ = sla.matrix_balance(A, permute=False)
    norm = min(norm, np.abs(As).sum(axis=0).max())
    T = 2.0 * math.pi / omega
    return float(math.ceil(2.0 * T * norm))


def _g(x):
    """Number as a YAML scalar that reads back to the same float."""
    return repr(float(x))


def build_fe_model(out_dir, n_el=None, case_name="beam.yaml", **params):
    """Build the beam, write ``M.mtx``, ``K.mtx``, the case file and ``modes.json`` into ``out_dir``.

    Parameters are those of :data:`DEFAULTS` (keyword arguments override them).

    Returns
    -------
    dict
        The content of ``modes.json`` (frequencies, element placement, parameters).
    """
    p = dict(DEFAULTS)
    unknown = set(params) - set(p)
    if unknown:
        raise TypeError(f"unknown parameters: {', '.join(sorted(unknown))}")
    p.update(params)
    if n_el is not None:
        p["n_el"] = int(n_el)
    n_el = p["n_el"]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    geo = dict(length=p["length"], young=p["young"], density=p["density"], width=p["width"], height=p["height"])
    plate = p["model"] == "plate"
    if plate:  # elements sit at mid-width (y = width / 2); the tip is the middle of the free edge
        ny = int(p["ny"])
        M, K = plate_matrices(n_el, ny, p["length"], p["width"], p["height"], p["young"], p["poisson"],
                              p["density"])
        dof_at = lambda x: (plate_w_dof(x, 0.5, n_el, ny), None)
    else:
        M, K = beam_matrices(n_el, **geo)
        dof_at = lambda x: node_dof(x, n_el)
    n_s = M.shape[0]                           # structure DOFs
    w_s = natural_frequencies(M, K, 3)         # of the structure alone (compared with the closed form)
    w_exact = cantilever_frequencies(3, **geo)
    if plate:  # plate bending modes approach the beam's with E / (1 - nu^2); mode 2 is torsion
        w_exact = w_exact / math.sqrt(1.0 - p["poisson"] ** 2)
    f_dof, f_node = dof_at(p["x_force"])
    r_node_dof, r_node = dof_at(p["x_friction"])
    tip = dof_at(1.0)[0] if plate else n_s - 2
    A, I = section(p["width"], p["height"])
    k_tip = 3.0 * p["young"] * I / p["length"] ** 3
    body = None
    if p["bodies"]:
        m_b = p["body_mass_ratio"] * p["density"] * A * p["length"]
        k_b = m_b * (p["body_freq_ratio"] * cantilever_frequencies(1, **geo)[0]) ** 2
        M, K = attach_bodies(M, K, [r_node_dof, tip], m_b, k_b)
        r_dof, c_dof = n_s, n_s + 1
        body = {"mass": m_b, "stiffness": k_b, "nodes_dofs": [r_node_dof, tip], "dofs": [r_dof, c_dof]}
        w = natural_frequencies(M, K, 3)
    else:
        r_dof, c_dof, w = r_node_dof, tip, w_s
    n = M.shape[0]
    alpha, beta = rayleigh_coefficients(w[0], w[1], p["zeta"])
    C = alpha * M + beta * K
    omega = p["omega_ratio"] * w[0]
    Q = linear_response(M, C, K, omega, f_dof, p["force"], rayleigh=(alpha, beta))
    tip_amp = float(abs(Q[tip]))
    c_amp = float(abs(Q[c_dof]))
    fr_vel = float(omega * abs(Q[r_dof]))
    bound = p["friction_ratio"] * p["force"]
    smoothing = p["smoothing"] if p["smoothing"] is not None else 100.0 / fr_vel
    gap = p["gap_ratio"] * c_amp
    k_pen = p["penalty_ratio"] * (body["stiffness"] if body else k_tip)
    # what MS-HBM integrates in time: the element DOFs with their own M_NN, C_NN, K_NN
    ix = lambda A, d: A.tocsr()[d][:, d].diagonal()
    node_dofs = [r_node_dof, tip]
    Ms_, Ks_ = M[:n_s, :n_s], K[:n_s, :n_s]
    stiff = {"node_dofs": {"omega_local_over_omega": (np.sqrt(ix(Ks_, node_dofs) / ix(Ms_, node_dofs)) / omega).tolist(),
                           "event_substeps_per_period": event_substeps(Ms_, alpha * Ms_ + beta * Ks_, Ks_, node_dofs, omega)}}
    if body is not None:
        bd = body["dofs"]
        stiff["bodies"] = {"omega_local_over_omega": (np.sqrt(ix(K, bd) / ix(M, bd)) / omega).tolist(),
                           "event_substeps_per_period": event_substeps(M, C, K, bd, omega)}
    info = {
        "time_domain_subsystem": stiff,
        "n_el": n_el, "n_dofs": n, "nnz_M": int(M.nnz), "nnz_K": int(K.nnz),
        "n_structure_dofs": n_s, "bodies": body,
        "omega_fe": w_s.tolist(), "omega_exact": w_exact.tolist(),
        "rel_error": (w_s / w_exact - 1.0).tolist(),
        "omega_model": w.tolist(), "f_hz": (w / (2 * math.pi)).tolist(),
        "omega": omega, "rayleigh": {"alpha": alpha, "beta": beta},
        "forcing": {"dof": f_dof, "node": f_node, "amplitude": p["force"]},
        "friction": {"dof": r_dof, "node": r_node, "mu": p["mu"], "normal_force": bound / p["mu"],
                     "smoothing": smoothing},
        "contact": {"dof": c_dof, "node": None if plate else n_el, "gap": gap, "restitution": p["restitution"],
                    "penalty_stiffness": k_pen},
        "linear": {"tip_amplitude": tip_amp, "contact_dof_amplitude": c_amp, "friction_dof_amplitude": float(abs(Q[r_dof])),
                   "friction_dof_velocity": fr_vel},
        "params": p,
    }
    sio.mmwrite(out / "M.mtx", M, comment=f"consistent mass, cantilever Euler-Bernoulli beam, {n_el} elements",
                symmetry="symmetric")
    sio.mmwrite(out / "K.mtx", K, comment=f"stiffness, cantilever Euler-Bernoulli beam, {n_el} elements",
                symmetry="symmetric")
    fr, ct = info["friction"], info["contact"]
    if plate:
        where = (f"# Forcing on w at x = {p['x_force']:g} L, omega = {p['omega_ratio']:g} w_1; friction joint on w at "
                 f"x = {p['x_friction']:g} L; impact stop at the middle of the free edge (all at mid-width),")
        head = [f"# Cantilever Kirchhoff plate (clamped along x = 0), {n_el} x {int(p['ny'])} bicubic Hermite (BFS) "
                f"elements, {n} DOFs (w, l_x w_x, l_y w_y, l_x l_y w_xy per node; l: element sizes), nu = {p['poisson']:g}",
                f"# L = {p['length']:g} m, width x thickness = {p['width']:g} x {p['height']:g} m, "
                f"E = {p['young']:g} Pa, rho = {p['density']:g} kg/m^3",
                "# Written by workflow/scripts/fe/build_fe_model.py (the .mtx files are generated, not stored):",
                f"#   python workflow/scripts/fe/build_fe_model.py <this directory> --model plate --n-el {n_el} "
                f"--ny {int(p['ny'])} --case {case_name}",
                "# Lowest frequencies (refined subspace iteration); the beam formula with E (narrow strip) and with "
                "E/(1-nu^2) (wide plate) bracket the bending modes; torsion modes interleave on wide plates:"]
        head += [f"#   mode {r + 1}: {w[r]:.6g} rad/s ({w[r] / (2 * math.pi):.6g} Hz)" for r in range(3)]
        head += [f"#   beam formula with E: {', '.join(f'{x:.6g}' for x in w_exact * math.sqrt(1 - p['poisson'] ** 2))}"
                 f" rad/s; with E/(1-nu^2): {', '.join(f'{x:.6g}' for x in w_exact)} rad/s", where]
    lines = head if plate else [
        f"# Cantilever Euler-Bernoulli beam, {n_el} Hermite cubic elements, {n} DOFs "
        f"(DOF 2(i-1): w of node i, 2(i-1)+1: its rotation)",
        f"# L = {p['length']:g} m, b x h = {p['width']:g} x {p['height']:g} m, E = {p['young']:g} Pa, "
        f"rho = {p['density']:g} kg/m^3",
        "# Written by workflow/scripts/fe/build_fe_model.py (the .mtx files are generated, not stored):",
        f"#   python workflow/scripts/fe/build_fe_model.py <this directory> --n-el {n_el}",
        "# First bending frequencies (refined subspace iteration) against the closed form (beta_r L)^2 sqrt(EI/(rho A L^4)):",
    ]
    for r in range(0 if plate else 3):
        lines.append(f"#   mode {r + 1}: {w_s[r]:.6g} rad/s ({w_s[r] / (2 * math.pi):.6g} Hz), closed form "
                     f"{w_exact[r]:.6g} rad/s, rel. error {w_s[r] / w_exact[r] - 1:+.2e}")
    if body is not None:
        lines += [f"# Elements on two bodies (DOFs {n_s}: friction shoe at the friction node, {n_s + 1}: pad at the tip), "
                  f"m_b = {body['mass']:.6g} kg each on springs k_b = {body['stiffness']:.6g} N/m "
                  f"(sqrt(k_b/m_b) = {p['body_freq_ratio']:g} x closed-form w_1); with them",
                  f"#   w_1..3 = {', '.join(f'{x:.6g}' for x in w)} rad/s"]
    lines += ([] if plate else [
        f"# Forcing at node {f_node} (x = {f_node / n_el:g} L), omega = {p['omega_ratio']:g} w_1; "
        f"friction joint at node {r_node}; impact stop at the tip,"]) + [
        f"# gap = {p['gap_ratio']:g} x the linear amplitude {c_amp:.6g} m of the contact DOF.  Rayleigh damping: "
        f"zeta = {p['zeta']:g} at w_1 and w_2.",
        f"name: fe_{p['model']}",
        "M: M.mtx",
        "K: K.mtx",
        f"damping: {{alpha: {_g(alpha)}, beta: {_g(beta)}}}",
        f"omega: {_g(omega)}",
        "forcing:",
        f"  - {{dof: {f_dof}, amplitude: {_g(p['force'])}}}",
        f"friction: {{dof: {fr['dof']}, mu: {_g(fr['mu'])}, normal_force: {_g(fr['normal_force'])}, "
        f"smoothing: {_g(fr['smoothing'])}}}",
        f"contact: {{dof: {ct['dof']}, gap: {_g(ct['gap'])}, restitution: {_g(ct['restitution'])}, "
        f"penalty_stiffness: {_g(ct['penalty_stiffness'])}}}",
        f"solver: {{method: mshbm, harmonics: {int(p['harmonics'])}, steps: {int(p['steps'])}}}",
    ]
    if p["reduce_modes"] is not None:
        lines += [f"reduce: {{method: craig_bampton, modes: {int(p['reduce_modes'])}}}"]
    (out / case_name).write_text("\n".join(lines) + "\n")
    (out / "modes.json").write_text(json.dumps(info, indent=1) + "\n")
    return info


def _numeric(key):
    """``key`` is a parameter of :data:`DEFAULTS` with a number (not a flag, not ``n_el``/``ny``) as value."""
    v = DEFAULTS.get(key)
    return key not in ("n_el", "ny") and isinstance(v, (int, float)) and not isinstance(v, bool)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("--n-el", type=int, default=DEFAULTS["n_el"])
    ap.add_argument("--case", default="beam.yaml", help="case file name (in OUT_DIR)")
    ap.add_argument("--model", choices=("beam", "plate"), default="beam")
    ap.add_argument("--ny", type=int, default=DEFAULTS["ny"], help="plate: elements across the width")
    ap.add_argument("--bodies", action="store_true", help="elements on lumped bodies tied to the nodes by springs")
    ap.add_argument("--reduce", type=int, default=None, metavar="N",
                    help="Craig-Bampton reduction onto the element DOFs with N fixed-interface modes (case key reduce:)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override a numeric model parameter, e.g. --set body_freq_ratio=10; keys: "
                         + ", ".join(k for k in DEFAULTS if _numeric(k)))
    args = ap.parse_args(argv)
    if args.reduce is not None and args.reduce < 0:
        ap.error(f"--reduce {args.reduce}: the number of modes must be >= 0")
    extra = {}
    for kv in args.set:
        key, sep, val = kv.partition("=")
        if not sep or not _numeric(key):
            ap.error(f"--set {kv}: expected KEY=VALUE with KEY a numeric parameter")
        try:
            extra[key] = float(val) if isinstance(DEFAULTS[key], float) else int(val)
        except ValueError:
            ap.error(f"--set {kv}: {val!r} is not a number")
    info = build_fe_model(args.out_dir, n_el=args.n_el, case_name=args.case, model=args.model, ny=args.ny,
                          bodies=args.bodies, reduce_modes=args.reduce, **extra)
    print(f"{info['n_dofs']} DOFs; omega_1..3 = {', '.join(f'{x:.6g}' for x in info['omega_fe'])} rad/s "
          f"(rel. errors {', '.join(f'{x:+.1e}' for x in info['rel_error'])}); wrote {args.out_dir}")
    return 0


if __name__ == "__main__" or "snakemake" in globals():
    smk = globals().get("snakemake")
    if smk is not None:
        with open(smk.log[0], "w") as logf:
            sys.stdout = logf
            out_dir = str(Path(smk.output.case).parent)
            info = build_fe_model(out_dir, n_el=int(smk.params.n_el), case_name=Path(smk.output.case).name)
            print(json.dumps({k: info[k] for k in ("n_dofs", "omega_fe", "omega_exact", "rel_error")}))
    else:
        sys.exit(main())
