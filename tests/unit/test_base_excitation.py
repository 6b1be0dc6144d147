"""Base excitation (mshbm.support): a 1-DOF oscillator (mass m, spring k and damper c to a table of imposed
motion y(t)) against closed forms, and a stop on the table against the equivalent forced problem."""
import numpy as np
import pytest

import mshbm
from mshbm import Contact, InputError, base_excitation, fourier

m, k, c = 1.0, 4.0, 0.3
Y = 0.01
#: the structure: DOF 0 the mass, DOF 1 the table (its mass and stiffness rows are dropped)
M = np.diag([m, 5.0])
K = np.array([[k, -k], [-k, k]])
C = np.array([[c, -c], [-c, c]])
#: base motion y = Y cos(w t) + 0.3 Y sin(2 w t): two harmonics, cosine and sine parts
X_HAT = [0.0, Y, 0.0, 0.0, 0.3 * Y]


def transmissibility(w):
    """Complex ``X / Y`` of the absolute mass motion per unit table motion at frequency ``w``."""
    return (k + 1j * c * w) / (k - m * w * w + 1j * c * w)


def closed_form_absolute(w):
    Yk = fourier.to_complex(np.array(X_HAT)[:, None])[:, 0]  # (3,) complex table harmonics
    X = np.array([Yk[h] * transmissibility(h * w) for h in range(3)])
    return X


FAR = 10.0  # a stop that is never reached (the amplitudes are ~0.1)
FRAMES = {"absolute": Contact(dof=0, gap=FAR), "relative": Contact(dof=0, gap=FAR, relative_to=1)}
METHODS = [("hbm", {"harmonics": 3}), ("dlft", {"harmonics": 3}),
           ("shooting", {"steps": 256, "integrator": "event", "harmonics": 3}),
           ("mshbm", {"harmonics": 3, "steps": 256, "integrator": "event"})]


@pytest.mark.parametrize("frame", sorted(FRAMES))
@pytest.mark.parametrize("method,opts", METHODS, ids=[mt for mt, _ in METHODS])
def test_transmissibility_closed_form(frame, method, opts):
    sys = base_excitation(M, C, K, [1], X_HAT, elements=[FRAMES[frame]])
    assert sys.base.frame == frame and sys.n == 1
    for w in (1.3, 2.0, 3.1):
        sol = mshbm.solve(sys, w, method=method, guess="zero", **opts)
        assert sol.success, sol.message
        got = fourier.to_complex(sol.q_hat_absolute)[:3, 0]
        want = closed_form_absolute(w)
        assert np.max(np.abs(got - want)) <= 1e-9 * Y
        assert abs(abs(got[1]) / Y - abs(transmissibility(w))) <= 1e-9 * abs(transmissibility(w))
        # the table rows are the imposed motion; relative = absolute - table (rigid carriage, R_qs = 1)
        assert np.array_equal(sol.q_hat_absolute[:5, 1], X_HAT)
        assert np.allclose(sol.q_hat_relative[:, 0], sol.q_hat_absolute[:, 0] - sol.q_hat_absolute[:, 1],
                           rtol=0, atol=1e-15)


def test_omega_derivative_closed_form():
    """dR/domega of HBM includes the forcing's slope: for z (relative frame), m z'' + c z' + k z =
    -m y'' = m w^2 Y cos(w t), harmonic 1 rows (cos, sin) of R = H(w) z - F(w)."""
    sys = base_excitation(M, C, K, [1], [0.0, Y, 0.0], elements=[FRAMES["relative"]])
    w = 2.0
    prob, _ = mshbm.build_problem(sys, w, "hbm", harmonics=1, steps=64)
    x = np.array([0.0, 0.0123, -0.0456])  # z = a cos + b sin at arbitrary coefficients
    a, b = x[1], x[2]
    want = np.array([0.0, -2 * m * w * a + c * b - 2 * m * w * Y, -2 * m * w * b - c * a])
    got = prob.omega_derivative(x)
    assert np.max(np.abs(got - want)) <= 1e-8 * np.max(np.abs(want))


SWEEPS = [("hbm", {"harmonics": 1, "steps": 64}), ("shooting", {"steps": 128, "integrator": "event"}),
          ("mshbm", {"harmonics": 2, "steps": 128, "integrator": "event"})]


@pytest.mark.parametrize("method,opts", SWEEPS, ids=[mt for mt, _ in SWEEPS])
def test_sweep_points_on_closed_form(method, opts):
    """The frequency continuation (its tangent from dR/domega) through the resonance: every point on
    the transmissibility curve."""
    sys = base_excitation(M, C, K, [1], [0.0, Y, 0.0], elements=[FRAMES["relative"]])
    br = mshbm.sweep(sys, 1.0, 3.0, method=method, **opts)
    assert br.success, br.message
    assert br.points[-1].omega == pytest.approx(3.0)
    w = np.array([p.omega for p in br.points])
    w_peak = w[np.argmax([abs(transmissibility(x)) for x in w])]
    assert np.sum(np.abs(w / w_peak - 1) <= 0.1) >= 4  # the resonance resolved (steps grow only where it is smooth)
    for p in br.points:
        qa = p.solution.q_hat_absolute
        got = complex(qa[1, 0], -qa[2, 0])
        assert abs(got - Y * transmissibility(p.omega)) <= 1e-9 * Y * abs(transmissibility(p.omega))


STOP_METHODS = [("shooting", {"steps": 512}), ("mshbm", {"harmonics": 8, "steps": 512}),
                ("hbm", {"harmonics": 8, "steps": 256}), ("dlft", {"harmonics": 8, "steps": 256}),
                ("shooting", {"steps": 512, "integrator": "event"})]


@pytest.mark.parametrize("method,opts", STOP_METHODS, ids=[f"{mt}-{o.get('integrator', '')}" for mt, o in STOP_METHODS])
def test_stop_on_table_equals_forced_problem(method, opts):
    """A stop on the shaker table (gap 0.04 relative to the table, restitution 0.7): the relative-coordinate
    problem is the 1-DOF oscillator forced by -m y'' = m w^2 Y cos(w t)."""
    w, g = 2.0, 0.04
    sys = base_excitation(M, C, K, [1], [0.0, Y, 0.0], elements=[Contact(dof=0, gap=g, relative_to=1, restitution=0.7)])
    ref = mshbm.System([[m]], [[c]], [[k]], [[0.0], [m * w * w * Y], [0.0]], [Contact(dof=0, gap=g, restitution=0.7)])
    a = mshbm.solve(sys, w, method=method, **opts)
    b = mshbm.solve(ref, w, method=method, **opts)
    assert np.max(np.abs(a.q_hat - b.q_hat)) <= 1e-12 * np.max(np.abs(b.q_hat))
    assert np.max(a.displacement()[:, 0]) >= 0.99 * g  # the stop is reached (between samples)
    assert a.success == b.success
    assert np.max(np.abs(a.q_hat_relative[:, 0] - b.q_hat[:, 0])) <= 1e-12 * np.max(np.abs(b.q_hat))
    energy = [ch for ch in a.certificate.checks if ch.name == "energy_balance"]
    assert len(energy) == 1 and energy[0].passed
    if opts.get("integrator") == "event":
        assert a.success, a.message


def test_ground_stop_absolute_frame_equals_forced_problem():
    """Absolute frame with a stop to the fixed ground: m x'' + c x' + k x = k y + c y', y = Y cos(w t), i.e. the
    forcing k Y cos(w t) - c w Y sin(w t) (its sine part depends on omega)."""
    w, g = 2.0, 0.04
    sys = base_excitation(M, C, K, [1], [0.0, Y, 0.0], elements=[Contact(dof=0, gap=g)])
    assert sys.base.frame == "absolute"
    ref = mshbm.System([[m]], [[c]], [[k]], [[0.0], [k * Y], [-c * w * Y]], [Contact(dof=0, gap=g)])
    for method, opts in (("hbm", {"harmonics": 8, "steps": 256}), ("shooting", {"steps": 512, "integrator": "event"})):
        a = mshbm.solve(sys, w, method=method, **opts)
        b = mshbm.solve(ref, w, method=method, **opts)
        assert np.max(np.abs(a.q_hat - b.q_hat)) <= 1e-12 * np.max(np.abs(b.q_hat))
        assert np.max(a.displacement()[:, 0]) >= 0.99 * g  # the stop is reached (between samples)


def test_refusals():
    with pytest.raises(InputError, match="base DOF"):  # the base DOF named as the element's dof
        base_excitation(M, C, K, [1], X_HAT, elements=[Contact(dof=1, gap=1.0, relative_to=0)])
    with pytest.raises(InputError, match="base motion"):  # a ground stop while the mass rides the table
        base_excitation(M, C, K, [1], X_HAT, elements=[Contact(dof=0, gap=1.0)], frame="relative")
    with pytest.raises(InputError, match="base.frame"):
        base_excitation(M, C, K, [1], X_HAT, frame="moving")
    with pytest.raises(InputError, match="base.dofs"):
        base_excitation(M, C, K, [2], X_HAT)
    with pytest.raises(InputError, match="no free DOF"):
        base_excitation(M, C, K, [0, 1], np.zeros((3, 2)))
    with pytest.raises(InputError, match="base.amplitude"):
        base_excitation(M, C, K, [1], [0.0, Y])
    with pytest.raises(InputError, match="forcing"):
        base_excitation(M, C, K, [1], X_HAT, f_hat=[[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    sys = base_excitation(M, C, K, [1], X_HAT)
    with pytest.raises(InputError, match="period"):
        mshbm.solve(sys, 2.0, method="hbm", period=2)
    from mshbm.reduction import craig_bampton
    with pytest.raises(InputError, match="reduce"):
        craig_bampton(sys, 0, keep=[0])


def test_untuned_forcing_is_undefined():
    """The system on its own has no forcing value: f_hat is NaN until tuned to a frequency (System.at)."""
    sys = base_excitation(M, C, K, [1], [0.0, Y, 0.0])
    assert np.all(np.isnan(sys.f_hat))
    with pytest.raises(ValueError):
        sys.forcing_hat(1)
    w = 1.7
    tuned = sys.at(w)
    assert tuned.at(w) is tuned and sys.forcing_hat(1, w).tolist() == tuned.forcing_hat(1).tolist()
    # absolute frame: k Y cos - c w Y sin
    assert np.allclose(tuned.f_hat[:, 0], [0.0, k * Y, -c * w * Y], rtol=1e-15, atol=0)
    assert np.allclose(sys.f_hat_omega_derivative(w)[:, 0], [0.0, 0.0, -c * Y], rtol=1e-15, atol=0)


CASE = {"name": "shaker", "M": M.tolist(), "K": K.tolist(), "C": C.tolist(), "omega": 2.0,
        "base": {"dofs": [1], "motion": [{"dof": 1, "amplitude": Y}, {"dof": 1, "harmonic": 2, "sin": 0.3 * Y}]},
        "contact": [{"dof": 0, "relative_to": 1, "gap": FAR}],
        "solver": {"method": "hbm", "harmonics": 3}}


def test_case_file_section_and_json_fields():
    from mshbm.io import parse_case

    case = parse_case(CASE)
    assert case.system.n == 1 and case.system.base.frame == "relative"
    sol = mshbm.solve(case.system, 2.0, method="hbm", harmonics=3)
    assert sol.success, sol.message
    want = closed_form_absolute(2.0)
    assert np.max(np.abs(fourier.to_complex(sol.q_hat_absolute)[:3, 0] - want)) <= 1e-9 * Y
    out = sol.summary()["base"]
    assert out["dofs"] == [1] and out["free"] == [0] and out["frame"] == "relative"
    assert np.allclose(out["q_hat_absolute"], sol.q_hat_absolute, rtol=0, atol=0)
    assert np.allclose(out["q_hat_relative"], sol.q_hat_relative, rtol=0, atol=0)
    y = Y * np.cos(2.0 * sol.t) + 0.3 * Y * np.sin(4.0 * sol.t)  # the table's motion on the solution's grid
    assert out["amplitude_absolute"][1] == pytest.approx(0.5 * (y.max() - y.min()), rel=1e-14)
    assert out["amplitude_relative"][1] == 0.0
    # --set reaches the base section (a parameter branch in the base amplitude uses it)
    from mshbm.io.overrides import apply_sets
    case2 = parse_case(apply_sets(CASE, {"base.motion.0.amplitude": 2 * Y}))
    assert np.allclose(case2.system.f_hat_at(2.0), case.system.f_hat_at(2.0) * [[1], [2], [2], [1], [1]],
                       rtol=1e-15, atol=0)


@pytest.mark.parametrize("change,key", [
    ({"base": {"dofs": [1], "motion": [{"dof": 0, "amplitude": Y}]}}, "base.motion[0].dof"),
    ({"base": {"dofs": [2], "motion": []}}, "base.dofs[0]"),
    ({"base": {"dofs": [1]}}, "base.motion"),
    ({"base": {"dofs": [1], "motion": [], "speed": 1}}, "base.speed"),
    ({"base": {"dofs": [1], "motion": [], "frame": "absolute"}}, "contact[0].relative_to"),
    ({"solver": {"method": "hbm", "partition": [0]}}, "solver.partition"),
    ({"forcing": [{"dof": 1, "amplitude": 1.0}]}, "forcing"),
])
def test_case_file_errors_name_the_key(change, key):
    from mshbm.io import parse_case

    with pytest.raises(InputError) as exc:
        parse_case({**CASE, **change})
    assert exc.value.key == key


def _z_closed(w):
    """Relative-frame coefficients of z for y = Y cos(w t): m z'' + c z' + k z = m w^2 Y cos(w t)."""
    Z = m * w * w * Y / (k - m * w * w + 1j * c * w)
    return Z


@pytest.mark.parametrize("method,opts", [("hbm", {"harmonics": 1, "steps": 64}),
                                         ("shooting", {"steps": 256, "integrator": "event"})])
def test_continuation_tangent_closed_form(method, opts):
    """The tangent of the frequency continuation, dx/domega = -J^-1 dR/domega, equals the slope of the closed-form
    solution in the method's unknowns (HBM: coefficients; shooting: q(0), u(0))."""
    sys = base_excitation(M, C, K, [1], [0.0, Y, 0.0], elements=[FRAMES["relative"]])
    unknowns = {"hbm": lambda Z, w: np.array([0.0, Z.real, -Z.imag]),
                "shooting": lambda Z, w: np.array([Z.real, (1j * w * Z).real])}[method]
    for w in (1.5, 2.0, 2.6):
        prob, _ = mshbm.build_problem(sys, w, method, **opts)
        x = unknowns(_z_closed(w), w)
        R, J = prob.residual(x)
        J = J.toarray() if hasattr(J, "toarray") else np.asarray(J)
        assert np.max(np.abs(R)) <= 1e-12 * np.max(np.abs(prob.residual_scale(x)))  # x solves R = 0
        tangent = -np.linalg.solve(J, prob.omega_derivative(x))
        d = 1e-5
        want = (unknowns(_z_closed(w + d), w + d) - unknowns(_z_closed(w - d), w - d)) / (2 * d)
        assert np.max(np.abs(tangent - want)) <= 1e-6 * np.max(np.abs(want))


def test_two_masses_on_table_equal_forced_problem():
    """Two masses on a table (DOF 0), friction between mass 1 and the table and a stop between the masses: the
    relative frame (R = [1, 1]) is the chain forced by -M_ff 1 y''; dense and sparse matrices agree."""
    import scipy.sparse as sp
    from mshbm import Friction

    Mt = np.diag([3.0, 1.0, 0.5])
    Kt = np.array([[2.0, -2.0, 0.0], [-2.0, 3.0, -1.0], [0.0, -1.0, 1.0]])
    Ct = 0.02 * Kt
    w, Yt = 1.1, 0.2
    els = [Friction(dof=1, relative_to=0, mu=0.3, normal_force=1.0), Contact(dof=2, relative_to=1, gap=0.05)]
    sys = base_excitation(Mt, Ct, Kt, [0], [0.0, Yt, 0.0], elements=els)
    assert sys.base.frame == "relative" and np.allclose(sys.base.R, 1.0, rtol=0, atol=1e-14)
    f = np.zeros((3, 2))
    f[1] = np.diag(Mt)[1:] * w * w * Yt
    ref = mshbm.System(Mt[1:, 1:], Ct[1:, 1:], Kt[1:, 1:], f,
                       [Friction(dof=0, mu=0.3, normal_force=1.0), Contact(dof=1, relative_to=0, gap=0.05)])
    sps = base_excitation(sp.csr_matrix(Mt), sp.csr_matrix(Ct), sp.csr_matrix(Kt), [0], [0.0, Yt, 0.0], elements=els)
    opts = {"harmonics": 5, "steps": 1024}
    a, b, s = (mshbm.solve(x, w, method="mshbm", **opts) for x in (sys, ref, sps))
    scale = np.max(np.abs(b.q_hat))
    assert np.max(np.abs(a.q_hat - b.q_hat)) <= 1e-12 * scale and np.max(np.abs(s.q_hat - b.q_hat)) <= 1e-10 * scale
    assert a.success and b.success, a.message
    fr, ct = a.elements
    assert 0.0 < fr.stick_fraction < 1.0 and ct.contact_fraction > 0.0  # stick-slip, and the stop is hit


def test_cli_solve_writes_absolute_and_relative(tmp_path):
    """``mshbm solve --out``: exit 0 and the JSON field ``base`` (the case of the README's example, event shooting)."""
    import json

    import yaml
    from mshbm.cli import main

    case = {**CASE, "contact": [{"dof": 0, "relative_to": 1, "gap": 0.04, "restitution": 0.7}],
            "base": {"dofs": [1], "motion": [{"dof": 1, "amplitude": Y}]},
            "solver": {"method": "shooting", "steps": 512, "integrator": "event"}}
    path, out = tmp_path / "shaker.yaml", tmp_path / "out.json"
    path.write_text(yaml.safe_dump(case))
    assert main(["solve", str(path), "--quiet", "--out", str(out)]) == 0
    payload = json.loads(out.read_text())
    base = payload["base"]
    qa, qr = np.array(base["q_hat_absolute"]), np.array(base["q_hat_relative"])
    assert qa.shape[1] == 2 and np.array_equal(qa[:3, 1], [0.0, Y, 0.0]) and not np.any(qr[:, 1])
    assert np.allclose(qa[:, 0] - qa[:, 1], qr[:, 0], rtol=0, atol=1e-15)
    # relative amplitude on the grid vs the exact extrema of z (the solve's own "amplitude"): the table carries z
    assert base["amplitude_relative"][0] == pytest.approx(payload["amplitude"][0], rel=1e-3)
    assert main(["solve", str(path), "--quiet", "--set", "base.frame=absolute"]) == 2


def test_two_base_dofs_in_any_order():
    """A mass between two supports moving differently: X_hat's columns follow base_dofs' order; the absolute
    response is (K_ff - w^2 M_ff + i w C_ff)^-1 (k1 + i w c1) Y1 + (k2 + i w c2) Y2 (HBM)."""
    k1, k2, c1, c2 = 3.0, 1.0, 0.2, 0.1
    Kt = np.array([[k1 + k2, -k1, -k2], [-k1, k1, 0.0], [-k2, 0.0, k2]])
    Ct = np.array([[c1 + c2, -c1, -c2], [-c1, c1, 0.0], [-c2, 0.0, c2]])
    Mt = np.diag([1.0, 2.0, 2.0])
    Y1, Y2 = [0.0, 0.01, 0.0], [0.0, 0.0, 0.02]
    w = 1.4
    want = ((k1 + 1j * w * c1) * 0.01 + (k2 + 1j * w * c2) * (-0.02j)) / (k1 + k2 - w * w + 1j * w * (c1 + c2))
    for dofs, X in (([1, 2], np.column_stack([Y1, Y2])), ([2, 1], np.column_stack([Y2, Y1]))):
        sys = base_excitation(Mt, Ct, Kt, dofs, X)
        sol = mshbm.solve(sys, w, method="hbm", harmonics=1, guess="zero")
        got = fourier.to_complex(sol.q_hat_absolute)[1]
        assert abs(got[0] - want) <= 1e-12 * abs(want)
        assert np.allclose(got[1:], [0.01, -0.02j], rtol=0, atol=0)
