"""Stopping a sweep early (Ctrl-C, SIGTERM) without losing its points.

* :class:`SweepInterrupted` -- what :func:`mshbm.sweep` (and :func:`mshbm.continue_forcing`,
  :func:`mshbm.parameter.continue_parameter`) raise when interrupted: a :class:`KeyboardInterrupt`
  (so an interrupted script still stops) carrying ``branch``, the :class:`mshbm.Branch` of the points
  accepted so far (``success`` False, its ``message`` says where it stopped, ``counters["interrupted"]``).
* :class:`Collector` keeps the points the continuation accepted; :func:`interrupted_result` makes them the
  continuation's result: folds are the sign changes of the tangent's ``lam`` component between accepted
  points, reported at the extreme point and ``"located": False`` (the continuation's own fold location
  was cut short).
* :func:`terminate_as_interrupt` -- a context in which SIGTERM raises :class:`Terminated` (a
  :class:`KeyboardInterrupt`), so that ``kill PID`` ends a sweep like Ctrl-C does (the CLI's exit
  codes: 130 after SIGINT, 143 after SIGTERM, 128 + the signal number).
"""
from __future__ import annotations

import contextlib
import signal

from .solvers.arclength_parts import ContinuationResult

__all__ = ["Collector", "SweepInterrupted", "Terminated", "interrupted_result", "terminate_as_interrupt"]


class Collector:
    """A continuation's ``callback`` that keeps the accepted points (``points``), then calls ``callback``."""

    def __init__(self, callback=None):
        self.points, self.callback = [], callback

    def __call__(self, point, n, ds):
        self.points.append(point)
        if self.callback is not None:
            self.callback(point, n, ds)


class Terminated(KeyboardInterrupt):
    """SIGTERM received (inside :func:`terminate_as_interrupt`)."""

    signum = signal.SIGTERM


class SweepInterrupted(KeyboardInterrupt):
    """A sweep interrupted by the user; ``branch`` holds the points so far, ``cause`` the original
    :class:`KeyboardInterrupt` (a :class:`Terminated` after SIGTERM)."""

    def __init__(self, branch, cause=None):
        super().__init__(branch.message)
        self.branch = branch
        self.cause = cause

    @property
    def signum(self):
        return getattr(self.cause, "signum", signal.SIGINT)


def interrupted_result(points, counters=None):
    """A :class:`ContinuationResult` of the accepted ``points`` (``ContinuationPoint`` s), not successful."""
    folds = []
    for i in range(1, len(points)):
        a, b = points[i - 1], points[i]
        if a.dlam * b.dlam < 0 and a.stall is None and b.stall is None:
            folds.append({"lam": float(max(a.lam, b.lam) if a.dlam > 0 else min(a.lam, b.lam)), "x": b.x,
                          "index": i, "located": False, "note": "the sweep was interrupted: not located"})
    where = f" at lam = {points[-1].lam:.6g}" if points else " before the first point"
    counters = dict(counters or {}, interrupted=True)
    return ContinuationResult(list(points), False, f"interrupted after {len(points)} points{where}", folds,
                              counters)


@contextlib.contextmanager
def terminate_as_interrupt():
    """SIGTERM raises :class:`Terminated` inside the block (main thread only; elsewhere a no-op)."""
    def handler(signum, frame):
        raise Terminated()

    try:
        old = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
