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

Conditioning: ``cond(K)`` of the beam grows like ``n_el^4``.  At 5000 elements (10^4 DOFs) the
rounding errors of any factorisation of ``K`` shift ``w_1`` by ~1e-3 (eigsh with SuperLU: -1.3e-3,
banded Cholesky: -0.9e-3, a factorisation ``K = R^T W R`` by curvature at Gauss points: -3e-13) and
the linear tip response at ``0.98 w_1`` by a factor 2; use ``n_el`` <= 1000 for the beam, or the
plate for 10^4 DOFs (100 x 24 elements: ``w_1`` converges monotonically, 52.690, 52.660, 52.651
rad/s at 25 x 6, 50 x 12, 100 x 24).

The first bending frequencies come from ``scipy.sparse.linalg.eigsh`` in shift-invert mode and are
checked against the closed-form cantilever values ``w_r = (beta_r L)^2 sqrt(E I / (rho A L^4))``
with ``beta_r L = 1.8751, 4.6941, 7.8548, ...`` (:func:`cantilever_frequencies`).

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
    # exactly symmetric (the element matrices are, the sums in another order may not be)
    K = sp.csr_matrix(0.5 * (K + K.T))
    M = sp.csr_matrix(0.5 * (M + M.T))
    for A_ in (K, M):
        A_.sum_duplicates()
        A_.sort_indices()
    return M, K


def _hermite_1d(n_el, length, clamped):
    """Global 1-D Hermite matrices ``(int N N, int N' N', int N'' N'', int N'' N)`` on ``n_el`` equal
    elements (DOFs ``(w, l w')`` per node, ``l`` the element length; ``clamped``: node 0 removed), by
    5-point Gauss quadrature."""
    l = length / n_el
    g, wg = np.polynomial.legendre.leggauss(5)
    xi = 0.5 * (g + 1.0)                      # in [0, 1]
    wq = 0.5 * wg * l
    N = np.array([1 - 3 * xi**2 + 2 * xi**3, l * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, l * (-xi**2 + xi**3)])
    d1 = np.array([-6 * xi + 6 * xi**2, l * (1 - 4 * xi + 3 * xi**2), 6 * xi - 6 * xi**2, l * (-2 * xi + 3 * xi**2)]) / l
    d2 = np.array([-6 + 12 * xi, l * (-4 + 6 * xi), 6 - 12 * xi, l * (-2 + 6 * xi)]) / l**2
    elems = [(N * wq) @ N.T, (d1 * wq) @ d1.T, (d2 * wq) @ d2.T, (d2 * wq) @ N.T]
    dofs = 2 * np.arange(n_el)[:, None] + np.arange(4)[None, :]
    rows, cols = np.repeat(dofs, 4, axis=1).ravel(), np.tile(dofs, (1, 4)).ravel()
    n_all = 2 * (n_el + 1)
    # slope DOFs in length units (l w'): every DOF is a displacement, and the matrices stay well scaled
    S = sp.diags(np.tile([1.0, 1.0 / l], n_el + 1))
    out = []
    for E_ in elems:
        A_ = sp.coo_matrix((np.tile(E_.ravel(), n_el), (rows, cols)), shape=(n_all, n_all)).tocsr()
        A_ = (S @ A_ @ S).tocsr()
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
    K = sp.csr_matrix(0.5 * (K + K.T))
    M = sp.csr_matrix(0.5 * (M + M.T))
    for A_ in (K, M):
        A_.sum_duplicates()
        A_.sort_indices()
    return M, K


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


def natural_frequencies(M, K, n_modes=3):
    """Lowest ``n_modes`` angular frequencies (rad/s): ``eigsh`` in shift-invert mode about 0."""
    v0 = np.ones(M.shape[0])  # a fixed start vector: the same frequencies (to the last bit) on every run
    w2 = spla.eigsh(K.tocsc(), k=n_modes, M=M.tocsc(), sigma=0.0, which="LM", return_eigenvectors=False, v0=v0)
    return np.sqrt(np.sort(w2))


def beam_frequencies_factored(n_el, n_modes=3, length=1.0, young=210e9, density=7850.0, width=0.04, height=0.01):
    """Lowest ``n_modes`` angular frequencies (rad/s) of the clamped beam of :func:`beam_matrices`, with
    ``K`` applied in factored form.

    The Hermite element's curvature is linear, so 2-point Gauss quadrature of ``EI int w''^2`` is exact:
    ``K = R^T W R`` with ``R`` (``2 n_el x 2 n_el``, square for the clamped beam) the curvatures at the
    Gauss points and ``W = EI l / 2``.  Shift-invert with ``K^-1 = R^-1 W^-1 R^-T`` (two sparse triangular-
    like solves with ``R``, whose condition number is the square root of ``K``'s) avoids the rounding of a
    factorisation of ``K`` itself, whose condition number grows like ``n_el^4`` (at 5000 elements
    :func:`natural_frequencies` is off by ~1e-3 in ``w_1``; this function by ~1e-13)."""
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


def linear_response(M, C, K, omega, dof, force):
    """Complex amplitudes ``Q`` of ``(K - omega^2 M + i omega C) Q = e_dof force`` (sparse LU)."""
    H = (K - omega ** 2 * M + 1j * omega * C).tocsc()
    f = np.zeros(M.shape[0], dtype=complex)
    f[dof] = force
    return spla.spsolve(H, f)


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
    Q = linear_response(M, C, K, omega, f_dof, p["force"])
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
                "# Lowest frequencies (eigsh, shift-invert); the beam formula with E (narrow strip) and with "
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
        "# First bending frequencies (eigsh, shift-invert) against the closed form (beta_r L)^2 sqrt(EI/(rho A L^4)):",
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
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override a numeric model parameter, e.g. --set body_freq_ratio=10; keys: "
                         + ", ".join(k for k in DEFAULTS if _numeric(k)))
    args = ap.parse_args(argv)
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
                          bodies=args.bodies, **extra)
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
