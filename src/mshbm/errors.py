"""Exceptions raised by mshbm.

``InputError`` names the offending key so that the CLI can print one line
``error: <key>: <problem>`` and exit with code 2.
"""


class InputError(ValueError):
    """Invalid user input (system, case file or solver option).

    Parameters
    ----------
    key : str
        Dotted name of the offending key, e.g. ``"friction.mu"``.
    problem : str
        What is wrong with it.
    """

    def __init__(self, key, problem):
        self.key = str(key)
        self.problem = str(problem)
        super().__init__(f"{self.key}: {self.problem}")


class ConvergenceError(RuntimeError):
    """Raised only on request (``solve(..., raise_on_failure=True)``)."""
