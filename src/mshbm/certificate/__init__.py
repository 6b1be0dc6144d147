"""Certificate of a periodic solution: checks made after Newton, independently of its bookkeeping.

A result of :func:`mshbm.solve` reports ``success=True`` only when Newton converged *and* every gating
check passed.  Each check has a ``name``, a ``value``, a ``bound`` (same units), ``passed`` and
``gating``; the list is ``PeriodicSolution.certificate`` and the ``"certificate"`` entry of
``summary()`` / the CLI JSON.  The checks read what differs between methods from the problem's declared
representation (:mod:`mshbm.methods.base`: ``fourier_all_dofs``, ``penalty_contact``,
``lagrangian_contact``, ``harmonic_truncation``, ``time_integrated_subset``,
``certify_connectivity_work``), never from the method's name.

Notation as in the paper: ``M, C, K``, ``q, u``, ``omega``, ``T = 2 pi / omega``, ``N`` time points per
period (``h = T / N``), ``n_h`` harmonics, element force ``lambda`` along ``w``.  Scales
(:mod:`mshbm.scaling`): ``F`` the force scale of the problem, ``D = max(D_0, max |q|)`` the displacement
size of the solution, ``V = max(omega D, max |u|)``.

The checks, in the order :func:`certify` appends them, and the module that defines each:

* ``residual``, ``periodicity``, ``step_accuracy_size`` -- :mod:`mshbm.certificate.accuracy`;
* ``time_warping`` -- :mod:`mshbm.certificate.linear`;
* ``friction_cone``, ``non_penetration``, ``contact_compression`` -- :mod:`mshbm.certificate.laws`;
* ``energy_balance``, ``connectivity_work``, ``friction_dissipation``, ``impact_dissipation`` --
  :mod:`mshbm.certificate.energy`;
* ``undamped_resonance`` -- :mod:`mshbm.certificate.linear`;
* ``truncation_solution``, ``truncation_force`` (reported, not gating) -- :mod:`mshbm.certificate.truncation`;
* ``model_substitution`` (reported, not gating; only where a method substitutes a contact law) --
  :mod:`mshbm.certificate.substitution`;
* ``regularisation`` (reported, not gating; HBM with regularised laws, appended by the solve route after the
  others: it re-solves the problem) -- :mod:`mshbm.methods.hbm_regularisation`.

:func:`mshbm.solve` then adds the a-posteriori error estimates ``truncation`` and ``time_discretisation``
(:mod:`mshbm.route.refine`: re-solves on a coarser discretisation) and the gating check ``accuracy``, their
sum with the other estimates present (``regularisation``, ``model_substitution``) against the requested or
default accuracy (:mod:`mshbm.certificate.combined`).

:mod:`mshbm.certificate.record` holds the :class:`Check` and :class:`Certificate` records,
:mod:`mshbm.certificate.kernels` the compiled passes over the grid, :mod:`mshbm.certificate.verdict` the
assembly (:func:`certify`, :func:`apply_certificate`).
"""
from . import kernels
from .accuracy import STEP_ACCURACY_NOTE, STEP_ACCURACY_SIZE_BOUND, STEP_ACCURACY_SIZE_NOTE
from .combined import DEFAULT_ACCURACY, ESTIMATES, combined_check
from .energy import CONNECTIVITY_WORK_BOUND, ENERGY_TOL, MAX_GRID_VALUES
from .laws import el_dofs_each, element_tables
from .linear import MAX_EIG_DOFS, TIME_DISCRETISATION_BOUND
from .record import Certificate, Check
from .substitution import MODEL_SUBSTITUTION_BOUND
from .truncation import TRUNCATION_BOUND
from .verdict import apply_certificate, certify

# the compiled passes and the element table under the names the speed and overhead tests use
_element_terms = kernels.element_terms
_element_terms_fourier = kernels.element_terms_fourier
_harmonic_power = kernels.harmonic_power
_force_tail = kernels.force_tail
_element_tables = element_tables

__all__ = ["Check", "Certificate", "DEFAULT_ACCURACY", "ESTIMATES", "combined_check", "certify", "apply_certificate", "ENERGY_TOL", "CONNECTIVITY_WORK_BOUND",
           "MAX_GRID_VALUES", "MAX_EIG_DOFS", "TIME_DISCRETISATION_BOUND", "TRUNCATION_BOUND",
           "STEP_ACCURACY_NOTE", "STEP_ACCURACY_SIZE_BOUND", "STEP_ACCURACY_SIZE_NOTE", "el_dofs_each",
           "MODEL_SUBSTITUTION_BOUND"]
