"""YAML case files.

A case file is a top-level mapping.  A wall-spring-mass chain (see
:func:`mshbm.system.chain`)::

    name: friction3                  # optional, default: the file name
    masses: [1, 1, 1]                # one per DOF, each > 0
    stiffness: 1                     # number or list (one per spring), >= 0
    damping: 0                       # same shape as stiffness, default 0
    omega: 0.6283185307179586        # forcing frequency (rad/s), > 0
    forcing:                         # amplitude*cos(k w t) + sin*sin(k w t) + constant
      - {dof: 2, amplitude: 5}       #   on a 0-based DOF (k = harmonic, default 1)
    friction: {dof: 0, mu: 0.8, normal_force: 9.81, smoothing: 800}   # smoothing (HBM): optional
    # or: contact: {dof: 0, gap: 0.1, restitution: 1, penalty_stiffness: 8000, penalty_damping: 0}
    # (smoothing, penalty_stiffness left out: from the problem's scales, mshbm.methods.hbm_regularisation)
    # friction/contact may also be lists of such mappings
    # friction with its normal load from a contact (a blade damper, examples/damper2d.yaml):
    #   friction: {dof: 1, mu: 0.5, normal_contact: 0}   # bound mu (normal_force + lambda_N(t)),
    #   contact: {dof: 2, gap: 0, restitution: 0}        # normal_contact indexes the contact list;
    #                                                    # normal_force (the preload) defaults to 0
    # a 3-D frictional contact (circular cone ||lambda_T|| <= mu F_N, examples/cone3d.yaml): two friction
    # entries naming each other by their index in the friction list; the keys mu, normal_force,
    # normal_contact, smoothing, tangential_stiffness left out of one are its partner's (stated in both:
    # they must be equal):
    #   friction: [{dof: 0, mu: 0.3, normal_force: 1, cone_partner: 1},   # + normal_contact: i (optional)
    #              {dof: 1, cone_partner: 0}]
    # a forcing harmonic k needs harmonics >= k (HBM; the harmonic DOFs of MS-HBM) and steps > 2k
    # (time-stepped DOFs): otherwise the case is refused, never truncated (README: "What mshbm refuses")
    solver: {method: mshbm, harmonics: 3, steps: 4096}   # optional defaults for solve
    # (solver.stability: true, false or "auto" -- Floquet multipliers, see mshbm.stability)

or a general structure by its matrices (instead of masses/stiffness/damping)::

    M: [[1, 0], [0, 2]]
    C: [[0.1, 0], [0, 0.1]]          # optional, default 0
    K: [[2, -1], [-1, 1]]

``M``, ``C`` and ``K`` may also be paths to matrix files (Matrix Market ``.mtx`` or
``scipy.sparse`` ``.npz``, relative to the case file), and ``damping: {alpha: a, beta: b}`` gives
Rayleigh damping ``C = a M + b K`` for matrices and chains (:mod:`mshbm.io.matrices` states the
path rules, the size limits and when the matrices are kept sparse)::

    M: beam_M.mtx
    K: beam_K.mtx
    damping: {alpha: 0.5, beta: 1.0e-5}

Numbers follow YAML 1.2 as most readers expect: ``1e3`` and ``1.0e+3`` are floats, ``.inf`` and
``.nan`` are floats (and rejected where a finite value is needed).  The YAML 1.1 traps are input
errors naming the key, never silently converted: sexagesimal numbers (``1:30``, which YAML 1.1
reads as 90), numbers with a leading zero (``010``: octal 8 in YAML 1.1, 10 in YAML 1.2) and
YAML 1.2 octal (``0o10``); ``yes``/``no``/``on``/``off`` (booleans in YAML 1.1) are rejected
where a number is expected.  Hexadecimal (``0x1A``) and digit separators (``1_000``) are read
as the numbers they denote.

Entries can be overridden without editing the file by their dotted keys (:mod:`mshbm.io.overrides`;
``load_case(path, sets={"friction.0.normal_force": 2.5})``, ``mshbm solve CASE --set KEY=VALUE``).

Every problem is reported as :class:`mshbm.InputError` whose ``key`` is the
dotted name of the offending entry (``friction.mu``, ``forcing[0].dof``,
``solver.harmonics``, ...).  Reading is defensive: files over 10 MB, nesting
deeper than 32 levels and alias expansions beyond 5 million values are
rejected before anything big is built; so are matrix files over 320 MB or
declaring more than 5 million rows or stored entries.
"""
from .case import (CHAIN_KEYS, CONTACT_KEYS, FORCING_KEYS, FRICTION_KEYS, MATRIX_KEYS, MAX_FORCING_HARMONIC,  # noqa: F401
                   SOLVER_KEYS, TOP_KEYS, Case, load_case, parse_case)
from .yaml import MAX_DEPTH, MAX_FILE_BYTES, MAX_VALUES  # noqa: F401

__all__ = ["Case", "load_case", "parse_case", "MAX_FILE_BYTES"]
