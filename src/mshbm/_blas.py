"""BLAS thread pinning shared by :func:`mshbm.solve`, the continuation driver and the exact solver.

``threadpoolctl.threadpool_limits`` rescans every loaded shared library on each call
(1.4 ms here, about 6 ms in an environment with more native libraries), which dominated
the solve of a 5-mass chain.  A :class:`threadpoolctl.ThreadpoolController` created once
(after numpy and scipy are imported) makes entering the limit cost about 35 µs; reading and setting
the BLAS libraries' thread counts directly (:func:`blas_threads`) a few µs.
"""
from __future__ import annotations

import contextlib

from threadpoolctl import ThreadpoolController

from .errors import InputError

_CONTROLLER = None


def controller():
    """The process-wide controller (created on first use; numpy and scipy are loaded by then)."""
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER


def check_threads(k):
    """``k`` if it is a valid ``blas_threads`` option (a positive int or None), else InputError."""
    if k is not None and (isinstance(k, bool) or not isinstance(k, int) or k < 1):
        raise InputError("blas_threads", f"must be a positive integer or None, got {k!r}")
    return k


def _blas_libs():
    """Controllers of the loaded BLAS libraries (selected once, like the controller)."""
    global _BLAS_LIBS
    if _BLAS_LIBS is None:
        _BLAS_LIBS = controller().select(user_api="blas").lib_controllers
    return _BLAS_LIBS


_BLAS_LIBS = None


@contextlib.contextmanager
def blas_threads(k):
    """Limit the BLAS threads of numpy/scipy to ``k`` inside the block (``None``: leave as is).

    What ``controller().limit(limits=k, user_api="blas")`` does, without its snapshot of every
    library's full info: each BLAS library's thread count is read, set to ``k`` where it differs,
    and set back on exit."""
    if k is None:
        yield
        return
    k = int(k)
    changed = []
    try:
        for lib in _blas_libs():
            n = lib.get_num_threads()
            if n != k:
                lib.set_num_threads(k)
                changed.append((lib, n))
        yield
    finally:
        for lib, n in reversed(changed):
            lib.set_num_threads(n)
