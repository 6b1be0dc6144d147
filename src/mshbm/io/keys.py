"""The keys of a case file (:mod:`mshbm.io`): the schema that :mod:`mshbm.io.case` checks and
:mod:`mshbm.io.overrides` (``--set``) walks."""

__all__ = ["TOP_KEYS", "CHAIN_KEYS", "MATRIX_KEYS", "FORCING_KEYS", "FRICTION_KEYS", "CONTACT_KEYS", "POLYNOMIAL_KEYS",
           "CUBIC_KEYS", "REDUCE_KEYS", "BASE_KEYS", "SOLVER_KEYS"]

TOP_KEYS = ("name", "masses", "stiffness", "damping", "M", "C", "K", "omega", "forcing",
            "friction", "contact", "polynomial", "cubic", "reduce", "solver", "base")
CHAIN_KEYS = ("masses", "stiffness", "damping")
MATRIX_KEYS = ("M", "C", "K")
FORCING_KEYS = ("dof", "amplitude", "sin", "harmonic", "constant")
#: element keys: default value, or ``...`` when required
#: (``relative_to: J``: the element acts on ``q_dof - q_J`` instead of between ``dof`` and the ground)
#: (``tangential_stiffness: k_t``: elastic friction, a Jenkins element, :class:`mshbm.elements.Jenkins`)
#: (``normal_contact: i``: the normal load is ``normal_force`` (the preload N_0, default 0 then) plus the force
#: of the ``contact`` entry ``i`` (0-based index into the ``contact`` list), :class:`mshbm.elements.Friction`)
#: (``cone_partner: i``: the ``friction`` entry ``i`` (0-based) is the second tangential direction of the same
#: contact point: a 3-D frictional contact with the circular cone, :mod:`mshbm.elements.cone`)
FRICTION_KEYS = {"dof": ..., "mu": ..., "normal_force": ..., "smoothing": None, "relative_to": None,
                 "tangential_stiffness": None, "normal_contact": None, "cone_partner": None}
CONTACT_KEYS = {"dof": ..., "gap": ..., "restitution": 1.0, "penalty_stiffness": None,
                "penalty_damping": 0.0, "relative_to": None}
#: polynomial springs ``lambda = -sum_p k_p s^p`` (:class:`mshbm.elements.Polynomial`): ``coefficients`` a mapping
#: ``{p: k_p}`` (N/m^p, integer powers 1..9); ``cubic``: the shorthand with ``stiffness: k_3`` (N/m^3)
POLYNOMIAL_KEYS = {"dof": ..., "coefficients": ..., "relative_to": None}
CUBIC_KEYS = {"dof": ..., "stiffness": ..., "relative_to": None}
#: ``base:`` imposed motion of base DOFs (:mod:`mshbm.support`): ``dofs`` (list), ``motion`` (items with the
#: keys of FORCING_KEYS, displacements in m, on base DOFs), ``frame`` (auto, absolute, relative)
BASE_KEYS = ("dofs", "motion", "frame")
#: ``reduce:`` (a Craig-Bampton reduction onto the element DOFs, :mod:`mshbm.reduction`)
REDUCE_KEYS = ("method", "modes", "keep")
SOLVER_KEYS = ("method", "harmonics", "steps", "theta", "jacobian", "tol", "max_iter", "partition",
               "condense", "project", "line_search", "continuation", "stability", "dlft_penalty",
               "dlft_predictor", "integrator", "accuracy")
