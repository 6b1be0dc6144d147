"""``mshbm.solve`` for the tests of the discretised equations (Newton's robustness, starts, kernels, element
laws, cross-method agreement at fixed n_H and steps): ``accuracy=False``, so ``success`` certifies the
discretised equations only, as these tests assert; the accuracy rule and its estimates have their own tests
(tests/unit/test_accuracy_estimates.py, test_regularisation_units.py, test_model_substitution.py)."""
import mshbm


def solve(*args, **options):
    options.setdefault("accuracy", False)
    return mshbm.solve(*args, **options)
