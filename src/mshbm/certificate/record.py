"""The record of a certificate: one :class:`Check` per check, and the :class:`Certificate` that holds them,
decides ``passed`` (every gating check passed) and words the message of failures and warnings."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

__all__ = ["Check", "Certificate", "SUPERSEDED"]

#: heuristic checks that the a-posteriori estimate ``truncation`` (:mod:`mshbm.route.refine`) supersedes: they stay
#: in the certificate, but are no warning once it is there
SUPERSEDED = ("truncation_solution", "truncation_force")


@dataclass
class Check:
    """One check: ``passed`` is ``value <= bound`` (``undamped_resonance``: ``value > bound``)."""

    name: str
    value: float | None
    bound: float | None
    passed: bool
    gating: bool = True
    note: str = ""

    def as_dict(self):
        d = asdict(self)
        for k in ("value", "bound"):
            v = d[k]
            d[k] = None if v is None or not np.isfinite(v) else float(v)
        d["passed"], d["gating"] = bool(d["passed"]), bool(d["gating"])
        return d


@dataclass
class Certificate:
    """The checks of one solution (see the module docstring); ``passed``: every gating check passed."""

    checks: list = field(default_factory=list)
    info: dict = field(default_factory=dict)

    @property
    def passed(self):
        return all(c.passed for c in self.checks if c.gating)

    @property
    def failed(self):
        """Names of the gating checks that failed."""
        return [c.name for c in self.checks if c.gating and not c.passed]

    @property
    def warnings(self):
        """Names of the non-gating checks above their bound (the heuristic truncation checks only while no
        a-posteriori ``truncation`` estimate supersedes them; ``model_substitution`` is named in the message of
        every solution that makes one, :func:`mshbm.certificate.apply_certificate`)."""
        return [c.name for c in self._above() if c.name != "model_substitution"]

    def _above(self):
        superseded = SUPERSEDED if "truncation" in self else ()
        return [c for c in self.checks if not c.gating and not c.passed and c.value is not None
                and c.name not in superseded]

    def __getitem__(self, name):
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(name)

    def __contains__(self, name):
        return any(c.name == name for c in self.checks)

    def as_list(self):
        """JSON-ready list of dicts ``{name, value, bound, passed, gating, note}``."""
        return [c.as_dict() for c in self.checks]

    def describe_warnings(self, only=None):
        """The non-gating checks above their bound (the harmonic truncation estimates), for the message of a
        certified solution; ``""`` when there are none.  ``only``: the check of that name only."""
        above = [c for c in self._above() if c.bound is not None and (only is None or c.name == only)]
        parts = [f"{c.name} {c.value:.3g} > {c.bound:.3g}" + (f" ({c.note})" if c.note else "")
                 for c in above if c.name in ("truncation", *SUPERSEDED)]
        out = []
        if parts:
            out.append("the harmonic truncation error may exceed its bound: " + ", ".join(parts)
                       + "; more harmonics (option harmonics) reduce it")
        out += [f"the time discretisation error may exceed the accuracy: {c.value:.3g} > {c.bound:.3g} ({c.note}); "
                "more steps (option steps) reduce it" for c in above if c.name == "time_discretisation"]
        out += [f"one step's accuracy is {c.value:.3g} of the orbit's size (> {c.bound:.3g}); more steps (option "
                "steps) reduce it" for c in above if c.name == "step_accuracy_size"]
        out += [f"the regularised laws' error is estimated at {c.value:.3g} of the amplitude (> {c.bound:.3g}); a "
                "stiffer law (friction smoothing, contact penalty_stiffness) reduces it" for c in above
                if c.name == "regularisation"]
        return "; ".join(out)

    def describe_failures(self):
        parts = []
        for c in self.checks:
            if c.gating and not c.passed:
                v = "n/a" if c.value is None else f"{c.value:.3g}"
                b = "n/a" if c.bound is None else f"{c.bound:.3g}"
                rel = "<=" if c.name == "undamped_resonance" else ">"
                if c.value is not None and c.bound is not None and c.name != "undamped_resonance" \
                        and c.value <= c.bound:
                    rel = "<="  # failed for another reason its note gives (accuracy: a missing estimate)
                parts.append(f"{c.name} ({v} {rel} bound {b}{': ' + c.note if c.note else ''})")
        return ", ".join(parts)
