"""The finite-element beam of the FE example (workflow/scripts/fe/build_fe_model.py): element matrices,
natural frequencies against the closed-form Euler-Bernoulli cantilever, and the case file it writes."""
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import yaml
from dataclasses import replace

import mshbm
from workflow_run import load_script

ROOT = Path(__file__).resolve().parents[2]
fe = load_script("fe/build_fe_model.py")

#: relative tolerance of the numbers of a rebuilt example case file against the committed one
EXAMPLE_RTOL = 1e-9
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _last_digit(s):
    """One unit in the last printed digit of the number ``s`` ("52.4971" -> 1e-4, "-1.64e-08" -> 1e-10)."""
    mant, _, exp = s.lower().partition("e")
    return 10.0 ** (int(exp or 0) - (len(mant.split(".")[1]) if "." in mant else 0))


def _same_data(a, b, where="case"):
    """YAML data ``a`` equals ``b``: same keys, lengths, integers and strings; floats within EXAMPLE_RTOL."""
    if isinstance(b, dict):
        assert isinstance(a, dict) and a.keys() == b.keys(), where
        for k in b:
            _same_data(a[k], b[k], f"{where}.{k}")
    elif isinstance(b, list):
        assert isinstance(a, list) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same_data(x, y, f"{where}[{i}]")
    elif isinstance(b, float):
        assert isinstance(a, float) and a == pytest.approx(b, rel=EXAMPLE_RTOL, abs=0.0), (where, a, b)
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


def assert_example_is_current(new_text, committed_text):
    """A rebuilt case file against the committed one, robust to the last bits of the floating point
    but not loose: the YAML data parsed, every float within EXAMPLE_RTOL (relative), integers and
    strings exact; the comment lines equal with their numbers replaced by a placeholder, and each
    number within one unit of its last printed digit.

    Why EXAMPLE_RTOL = 1e-9: the builder's numbers (frequencies, Rayleigh coefficients, the linear
    amplitude behind ``gap``, ``smoothing``) are the exact answers for the stored matrices to ~1e-13
    (refined solves and eigenpairs): rebuilt with the LU orderings COLAMD, MMD_AT_PLUS_A and NATURAL and
    with OpenBLAS core types Haswell, SandyBridge and Prescott they agree to 6e-14.  1e-9 keeps four
    orders of margin for any processor, while unrefined solves (their differences between machines
    were 1e-9 to 6 % here) fail it."""
    new_comments = [line for line in new_text.splitlines() if line.startswith("#")]
    old_comments = [line for line in committed_text.splitlines() if line.startswith("#")]
    assert len(new_comments) == len(old_comments)
    for a, b in zip(new_comments, old_comments):
        assert _NUMBER.sub("<n>", a) == _NUMBER.sub("<n>", b), (a, b)
        for x, y in zip(_NUMBER.findall(a), _NUMBER.findall(b)):
            assert abs(float(x) - float(y)) <= max(_last_digit(x), _last_digit(y)), (a, b)
    _same_data(yaml.safe_load(new_text), yaml.safe_load(committed_text))


def test_element_matrices_rigid_modes_and_mass():
    """Free-free beam: translation and rotation are zero-energy modes; the kinetic energy of a unit
    translation is rho A L; the matrices are symmetric and M is positive definite."""
    L, n_el = 2.0, 7
    M, K = fe.beam_matrices(n_el, length=L, clamped=False)
    x = np.repeat(np.linspace(0.0, L, n_el + 1), 1)
    trans = np.zeros(M.shape[0]); trans[0::2] = 1.0
    rot = np.zeros(M.shape[0]); rot[0::2] = x; rot[1::2] = 1.0
    scale = abs(K).max()
    assert np.abs(K @ trans).max() <= 1e-12 * scale and np.abs(K @ rot).max() <= 1e-12 * scale
    A, _ = fe.section(0.04, 0.01)
    assert trans @ (M @ trans) == pytest.approx(7850.0 * A * L, rel=1e-13)
    assert (M != M.T).nnz == 0 and (K != K.T).nnz == 0
    np.linalg.cholesky(M.toarray())
    assert M.shape == (2 * (n_el + 1),) * 2 and fe.beam_matrices(n_el)[0].shape == (2 * n_el,) * 2


@pytest.mark.parametrize("n_el", [100, 2000])
def test_cantilever_frequencies_match_closed_form(n_el):
    """First three bending frequencies within 0.1 % of (beta_r L)^2 sqrt(EI / (rho A L^4))."""
    M, K = fe.beam_matrices(n_el)
    w = fe.natural_frequencies(M, K, 3)
    w_exact = fe.cantilever_frequencies(3)
    assert np.all(np.abs(w / w_exact - 1.0) < 1e-3), w / w_exact - 1.0
    # Hermite cubics converge fast: the coarse mesh is already far inside the bound
    if n_el == 100:
        assert np.all(np.abs(w / w_exact - 1.0) < 1e-6)


def test_closed_form_roots():
    """beta_r L are roots of 1 + cos x cosh x (the clamped-free frequency equation)."""
    for bl in fe.CANTILEVER_BETA_L:
        assert abs(1.0 + math.cos(bl) * math.cosh(bl)) < 1e-9 * math.cosh(bl)


def test_rayleigh_coefficients_give_zeta_at_both_frequencies():
    a, b = fe.rayleigh_coefficients(50.0, 300.0, 0.02)
    for w in (50.0, 300.0):
        assert a / (2 * w) + b * w / 2 == pytest.approx(0.02, rel=1e-14)


def test_build_writes_loadable_case(tmp_path):
    """The case file of a 20-element beam as mshbm loads it.  The mesh is coarse so that mshbm's own linear
    solve (a plain LU of K - w^2 M + i w C) is accurate to the 1e-8 of the last check: its rounding error
    is 5e-10 here, 1.1e-8 at 40 elements (cond ~ n_el^4), while the builder's refined response is exact."""
    info = fe.build_fe_model(tmp_path, n_el=20)
    case = mshbm.load_case(tmp_path / "beam.yaml")
    s = case.system
    assert s.n == 40 == info["n_dofs"]
    M, K = fe.beam_matrices(20)
    assert np.array_equal(s.M, M.toarray()) and np.array_equal(s.K, K.toarray())
    a, b = info["rayleigh"]["alpha"], info["rayleigh"]["beta"]
    assert np.array_equal(s.C, a * M.toarray() + b * K.toarray())
    assert case.omega == info["omega"] == fe.DEFAULTS["omega_ratio"] * info["omega_fe"][0]
    kinds = {e.kind: e for e in s.elements}
    assert kinds["contact"].dof == s.n - 2 and kinds["friction"].dof == info["friction"]["dof"]
    assert kinds["contact"].gap == pytest.approx(fe.DEFAULTS["gap_ratio"] * info["linear"]["tip_amplitude"])
    assert kinds["friction"].bound == pytest.approx(fe.DEFAULTS["friction_ratio"] * fe.DEFAULTS["force"])
    assert json.loads((tmp_path / "modes.json").read_text())["n_dofs"] == 40
    # the linear response in the file equals mshbm's linear HBM solve without elements
    lin = mshbm.solve(s.with_elements(()), case.omega, "hbm", harmonics=1)
    tip = np.hypot(*lin.q_hat[1:3, s.n - 2])
    assert tip == pytest.approx(info["linear"]["tip_amplitude"], rel=1e-8)


def test_large_model_stays_sparse_and_example_is_current(tmp_path):
    """10^4 DOFs: read as CSR matrices (nothing dense n x n in the System); the committed example
    case file is the one the script writes (:func:`assert_example_is_current`)."""
    fe.build_fe_model(tmp_path, n_el=5000)
    assert_example_is_current((tmp_path / "beam.yaml").read_text(),
                              (ROOT / "examples" / "fe_beam" / "beam.yaml").read_text())
    s = mshbm.load_case(tmp_path / "beam.yaml").system
    assert s.n == 10_000
    assert all(sp.isspmatrix_csr(getattr(s, k)) for k in "MCK")
    assert s.K.nnz < 10 * s.n


def test_plate_with_nu_zero_has_the_beam_bending_modes():
    """Kirchhoff plate (BFS elements, Kronecker assembly) with nu = 0: the beam modes w = phi(x) are exact
    plate modes, so the closed-form cantilever frequencies (EI -> D b) appear in the plate spectrum."""
    b = 0.2
    M, K = fe.plate_matrices(20, 4, lx=1.0, ly=b, thickness=0.01, poisson=0.0)
    assert M.shape == (4 * 20 * 5,) * 2 and (K != K.T).nnz == 0
    w = fe.natural_frequencies(M, K, 8)
    for w_r in fe.cantilever_frequencies(3, width=b, height=0.01):
        assert np.min(np.abs(w / w_r - 1.0)) < 1e-4
    # free-free in y, clamped in x: a rigid y-translation of the clamped edge is not a DOF; K is definite
    assert np.all(w > 0)


def test_plate_dof_index():
    nx, ny = 10, 4
    assert fe.plate_w_dof(1.0, 0.5, nx, ny) == (2 * (nx - 1)) * 2 * (ny + 1) + 2 * 2
    assert fe.plate_w_dof(0.0, 0.0, nx, ny) == 0


@pytest.mark.slow
def test_plate_example_is_current(tmp_path):
    """The committed 10^4-DOF plate case file is the one the script writes (:func:`assert_example_is_current`)."""
    fe.build_fe_model(tmp_path, n_el=50, case_name="plate.yaml", model="plate", ny=49)
    assert_example_is_current((tmp_path / "plate.yaml").read_text(),
                              (ROOT / "examples" / "fe_plate" / "plate.yaml").read_text())
    s = mshbm.load_case(tmp_path / "plate.yaml").system
    assert s.n == 10_000 and all(sp.isspmatrix_csr(getattr(s, k)) for k in "MCK")


@pytest.fixture(scope="module")
def plate_mu0(tmp_path_factory):
    """The 480-DOF plate of the FE example with mu = 0 and no stop: the exact answer is the linear one."""
    d = tmp_path_factory.mktemp("plate")
    fe.build_fe_model(d, n_el=20, case_name="plate.yaml", model="plate", ny=5)
    case = mshbm.load_case(d / "plate.yaml")
    s = case.system
    fr = [replace(e, mu=0.0) for e in s.elements if e.kind == "friction"]
    s0 = s.with_elements(fr)
    w = case.omega
    F = s.forcing_hat(1)
    X = spla.spsolve(sp.csc_matrix(s.K - w ** 2 * s.M + 1j * w * s.C), F[1] - 1j * F[2])
    return s0, w, fr[0].dof, float(np.abs(X[fr[0].dof]))


@pytest.mark.slow
def test_mshbm_on_a_stiff_fe_dof_is_never_certified_wrong(plate_mu0):
    """MS-HBM time-steps the friction DOF of a plate node: sqrt(K_dd / M_dd) / omega ~ 3e4 with Rayleigh
    damping beta K_dd, the condensed compliance amplifying the scheme's frequency warping ~1e7 times.
    Measured errors against the linear answer: -83 % (256 steps), -16 % (1024), -0.96 % (4096),
    -0.06 % (16384).  The certificate's first-order time_warping estimate 5.5, 0.34, 0.021, 0.0013 rejects
    the first two (gross under-resolution); the step-refinement estimate time_discretisation (against N/2
    steps: 3.0 % at 4096) holds the third to the default accuracy 1 %: only 16384 steps are a success."""
    s0, w, d, lin = plate_mu0
    for steps, warp_ok, ok in ((256, False, False), (1024, False, False), (4096, True, False), (16384, True, True)):
        sol = mshbm.solve(s0, w, "mshbm", harmonics=5, steps=steps, stability=False)
        cert = sol.certificate
        err = abs(sol.amplitude[d] / lin - 1.0)
        assert cert["time_warping"].passed is warp_ok
        assert sol.success is ok, (steps, sol.message)
        if warp_ok:  # the solve's estimate bounds the error
            assert err <= cert["time_discretisation"].value <= 10.0 * err
            assert cert.failed == ([] if ok else ["accuracy"])
        else:
            assert err > 0.1 and "time_warping" in sol.message


@pytest.mark.slow
def test_requested_accuracy_refines_the_steps_on_the_plate(plate_mu0):
    """From 2048 steps (3.9 % low, estimate 6.2 %) accuracy=1e-2 doubles the steps to 8192 (0.24 % low,
    estimate 0.72 %)."""
    s0, w, d, lin = plate_mu0
    sol = mshbm.solve(s0, w, "mshbm", harmonics=5, steps=2048, stability=False, accuracy=1e-2)
    assert sol.success, sol.message
    assert [lv["steps"] for lv in sol.info["accuracy"]["levels"]] == [2048, 4096, 8192]
    assert abs(sol.amplitude[d] / lin - 1.0) <= sol.certificate["time_discretisation"].value <= 1e-2


def test_bodies_are_tied_by_springs_and_carry_the_elements(tmp_path):
    """bodies=True appends two DOFs (shoe, pad) of mass m_b tied by k_b to the friction node and the tip:
    a rigid translation of structure node and body together stores no energy in the tie, the bodies add
    exactly 2 m_b of mass, and the case puts friction and contact on the bodies."""
    info = fe.build_fe_model(tmp_path, n_el=8, case_name="fe.yaml", model="plate", ny=2, bodies=True)
    s = mshbm.load_case(tmp_path / "fe.yaml").system
    n_s = info["n_structure_dofs"]
    assert s.n == n_s + 2 == info["n_dofs"]
    M0, K0 = fe.plate_matrices(8, 2, 1.0, 0.04, 0.01)
    K, M = np.asarray(s.K.toarray() if sp.issparse(s.K) else s.K), np.asarray(s.M.toarray() if sp.issparse(s.M) else s.M)
    b = info["bodies"]
    A, _ = fe.section(0.04, 0.01)
    m_b = fe.DEFAULTS["body_mass_ratio"] * 7850.0 * A * 1.0
    k_b = m_b * (fe.DEFAULTS["body_freq_ratio"] * fe.cantilever_frequencies(1)[0]) ** 2
    assert b["mass"] == pytest.approx(m_b, rel=1e-15) and b["stiffness"] == pytest.approx(k_b, rel=1e-15)
    assert np.array_equal(M[:n_s, :n_s], M0.toarray()) and M[n_s, n_s] == M[n_s + 1, n_s + 1] == m_b
    for node, body in zip(b["nodes_dofs"], b["dofs"]):
        e = np.zeros(s.n); e[[node, body]] = 1.0
        assert abs(e @ (K - np.pad(K0.toarray(), ((0, 2), (0, 2)))) @ e) <= 1e-9 * k_b  # the tie: no energy
        assert K[body, body] == k_b and K[node, body] == -k_b
    kinds = {e.kind: e.dof for e in s.elements}
    assert kinds == {"friction": n_s, "contact": n_s + 1}
    # the bodies' own frequency is body_freq_ratio w_1 (closed form), independent of the mesh
    r = info["time_domain_subsystem"]["bodies"]["omega_local_over_omega"]
    assert r[0] == pytest.approx(fe.DEFAULTS["body_freq_ratio"] * fe.cantilever_frequencies(1)[0] / info["omega"], rel=1e-12)


def test_event_substeps_follow_the_fastest_rate_and_the_flow():
    """One DOF (m, c, k) with k/m = (100 omega)^2: the unbalanced rule ceil(2 T max(k/m, 1 + c/m)) asked for
    ~1.3e6 sub-steps; the balanced one follows the fastest rate, ~2 T (sqrt(k/m) + c/m) (within a factor 2),
    and equals the count of the event-driven flow itself (EventFlow.substeps, at least its 128)."""
    from mshbm import System
    from mshbm.integrators.event import EventFlow

    w = 10.0
    m, c, k = 2.0, 3.0, 2.0 * (100 * w) ** 2
    M, C, K = (sp.csr_matrix(np.array([[v]])) for v in (m, c, k))
    T = 2 * math.pi / w
    n_s = fe.event_substeps(M, C, K, [0], w)
    rate = math.sqrt(k / m) + c / m
    assert 2 * T * rate / 2 <= n_s <= 2 * T * rate * 2
    assert n_s < 1e-2 * math.ceil(2 * T * max(k / m, 1 + c / m))
    flow = EventFlow(System(np.array([[m]]), np.array([[c]]), np.array([[k]]), np.zeros((3, 1))), w)
    assert flow.substeps == max(128, int(n_s))


def test_set_option_parses_numbers_and_rejects_others(tmp_path, capsys):
    assert fe.main([str(tmp_path), "--model", "plate", "--n-el", "4", "--ny", "2", "--bodies", "--case", "x.yaml",
                    "--set", "body_freq_ratio=10", "--set", "steps=512"]) == 0
    info = json.loads((tmp_path / "modes.json").read_text())
    assert info["params"]["body_freq_ratio"] == 10.0 and info["params"]["steps"] == 512
    for bad in ("bodies=1", "n_el=3", "nokey=1", "zeta=abc"):
        with pytest.raises(SystemExit) as e:
            fe.main([str(tmp_path), "--set", bad])
        assert e.value.code == 2


def test_first_frequency_error_at_5000_elements_is_rounding_not_discretisation():
    """At 5000 elements eigsh (SuperLU factorisation of K, cond(K) ~ n_el^4) puts w_1 1.3e-3 below the
    closed form while w_2 is 3.8e-5 off: the absolute error of the eigenvalue is about the same for every
    mode, i.e. rounding.  Applying K^-1 through its exact factorisation K = R^T W R (curvatures at the
    Gauss points) gives the closed form to 1e-9 for all three modes: the element, the boundary condition,
    the consistent mass and the constants (1.8751...)^2 are right."""
    w_exact = fe.cantilever_frequencies(3)
    w_rt = fe.beam_frequencies_factored(5000, 3)
    assert np.all(np.abs(w_rt / w_exact - 1.0) < 1e-9), w_rt / w_exact - 1.0
    # R^T W R is K (to rounding of the entries)
    M, K = fe.beam_matrices(50)
    assert np.allclose(fe.beam_frequencies_factored(50, 3), fe.natural_frequencies(M, K, 3), rtol=1e-10, atol=0)


def test_refined_frequencies_are_those_of_the_stored_matrices():
    """5000-element beam (cond(K) ~ 1e14; plain shift-invert eigsh: w_1 1.3e-3 low, by an amount that
    depends on the processor): the refined frequencies do not depend on the LU ordering (measured
    2e-15 apart) and are within 3e-8 of the factored K = R^T W R (measured 1.6e-8, 2.9e-9, 8.9e-10):
    the stored K's entries are rounded, and that rounding alone moves w_1 by ~u n_el^3; the refined
    value equals the Rayleigh quotient of the stored K at the factored eigenvector to 2e-15."""
    M, K = fe.beam_matrices(5000)
    w = fe.natural_frequencies(M, K, 3)
    assert np.allclose(fe.natural_frequencies(M, K, 3, permc_spec="NATURAL"), w, rtol=1e-13, atol=0)
    assert np.allclose(w, fe.beam_frequencies_factored(5000, 3), rtol=3e-8, atol=0)


def test_plate_with_nu_zero_has_the_beam_element_frequencies_on_a_fine_mesh():
    """400 x 2 plate with nu = 0 (cond(K) ~ 400^4): its x-bending modes are exactly those of the 400-element
    Hermite beam, whose frequencies beam_frequencies_factored gives without forming K.  Refined: within
    1e-10 (measured 2.9e-11, 5.1e-12, 1.6e-12); plain shift-invert eigsh was 3.5e-8 off in w_1."""
    b = 0.2
    M, K = fe.plate_matrices(400, 2, lx=1.0, ly=b, thickness=0.01, poisson=0.0)
    w = fe.natural_frequencies(M, K, 8)
    for w_r in fe.beam_frequencies_factored(400, 3, width=b, height=0.01):
        assert np.min(np.abs(w / w_r - 1.0)) < 1e-10


def test_linear_response_is_refined_and_converges_with_the_mesh():
    """Cantilever at omega = 0.98 w_1 (closed form) with Rayleigh damping for zeta = 0.01 at the closed-form
    w_1, w_2, so every mesh solves the same continuous problem.  The refined tip amplitude does not
    depend on the LU ordering (measured 2e-16 apart at 1000 elements, where plain spsolve with the
    orderings COLAMD, MMD_AT_PLUS_A and NATURAL differed by 7e-4; at 2000 elements by 6 %), and 500 and
    1000 elements agree within 1e-8 (measured 3.8e-9: the rounding of the stored K's entries, growing
    like n_el^2, not discretisation).  The stored C = alpha M + beta K is not used: its rounded entries
    move the answer by 7e-5 at 2000 elements."""
    w_ex = fe.cantilever_frequencies(2)
    ab = fe.rayleigh_coefficients(w_ex[0], w_ex[1], 0.01)
    omega = 0.98 * w_ex[0]
    tip = {}
    for n_el in (500, 1000):
        M, K = fe.beam_matrices(n_el)
        f_dof, _ = fe.node_dof(0.75, n_el)
        amps = [abs(fe.linear_response(M, None, K, omega, f_dof, 1.0, rayleigh=ab, permc_spec=ps)[-2])
                for ps in ("COLAMD", "MMD_AT_PLUS_A", "NATURAL")]
        assert np.allclose(amps, amps[0], rtol=1e-12, atol=0), amps
        tip[n_el] = amps[0]
    assert tip[1000] == pytest.approx(tip[500], rel=1e-8)
    # with a stored C the refinement solves that problem: on a coarse mesh the same answer to the effect of
    # the rounding of C's entries (measured 1e-11 at 40 elements)
    M, K = fe.beam_matrices(40)
    C = ab[0] * M + ab[1] * K
    f_dof, _ = fe.node_dof(0.75, 40)
    Q = fe.linear_response(M, C, K, omega, f_dof, 1.0)
    Q_r = fe.linear_response(M, None, K, omega, f_dof, 1.0, rayleigh=ab)
    assert np.abs(Q - Q_r).max() <= 1e-10 * np.abs(Q_r).max()


def test_reduce_option_writes_a_craig_bampton_case_on_the_node_dofs(tmp_path):
    """--reduce N (no bodies): the case file asks for a Craig-Bampton reduction with N modes, the elements act on
    the plate's node DOFs (the friction node at mid-length, the tip), and the loaded case solves 2 + N DOFs whose
    first two are those nodes; a negative count is refused with exit code 2."""
    assert fe.main([str(tmp_path), "--model", "plate", "--n-el", "6", "--ny", "2", "--case", "x.yaml",
                    "--reduce", "3"]) == 0
    info = json.loads((tmp_path / "modes.json").read_text())
    assert info["bodies"] is None and info["params"]["reduce_modes"] == 3
    assert "reduce: {method: craig_bampton, modes: 3}" in (tmp_path / "x.yaml").read_text().splitlines()
    case = mshbm.load_case(tmp_path / "x.yaml")
    rm = case.reduction
    assert case.system.n == info["n_dofs"] == 72 and case.model.n == 2 + 3 == rm.system.n
    fr, ct = info["friction"]["dof"], info["contact"]["dof"]
    assert sorted(rm.boundary.tolist()) == sorted([fr, ct])
    assert fr == fe.plate_w_dof(0.5, 0.5, 6, 2) and ct == fe.plate_w_dof(1.0, 0.5, 6, 2)
    assert {e.kind: e.dof for e in rm.system.elements} == {"friction": rm.reduced_dof(fr),
                                                            "contact": rm.reduced_dof(ct)}
    with pytest.raises(SystemExit) as e:
        fe.main([str(tmp_path), "--reduce", "-1"])
    assert e.value.code == 2
