"""SciPy functions that only some solves call, imported at their first call instead of with :mod:`mshbm`.

``scipy.optimize`` (Brent's root finder of the event location, the event trajectories and the friction kernels)
and ``scipy.spatial`` (the k-d tree of Hill's method) add about 0.25 s of CPU to every process that imports
``mshbm``; most of the workflow's jobs (HBM, DLFT and Moreau-Jean solves, summaries, figures) never call them.
"""
from __future__ import annotations

__all__ = ["brentq", "cKDTree"]


def brentq(f, a, b, **options):
    """:func:`scipy.optimize.brentq` (the same arguments and result)."""
    from scipy.optimize import brentq as _brentq

    return _brentq(f, a, b, **options)


def cKDTree(data, **options):  # noqa: N802 -- SciPy's name
    """:class:`scipy.spatial.cKDTree` of ``data`` (the same arguments)."""
    from scipy.spatial import cKDTree as _tree

    return _tree(data, **options)
