"""The BLAS thread pools: limited where the library's dense problems are small.

The linkage's matrices are tens to a few hundred rows; a threaded BLAS (OpenBLAS's default is a
thread per core) spends more time handing such problems out than solving them, and where
several processes share the cores (a pool of chapter reruns, test workers) the threads contend.
Measured on a 2-core machine (AMD EPYC, OpenBLAS 0.3, 2026-12-04): the frozen modes of
``resonance_speeds`` (one case of chapter 07) 0.85 s with the default threads against 0.31 s
with one.  The limit also makes the results independent of the thread count, which can change
the last bits of a threaded reduction.

Imports nothing of the linkage (the errors module only).
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable
from typing import Any

from ..errors import number

try:  # the pinned environment has it; without it the limits are no-ops
    from threadpoolctl import ThreadpoolController
except ImportError:  # pragma: no cover
    ThreadpoolController = None

__all__ = ["blas_threads", "one_blas_thread"]

_CONTROLLER: Any = None


def blas_threads(k: int | None) -> contextlib.AbstractContextManager[Any]:
    """Context limiting the BLAS thread pools to ``k`` threads, a positive integer (no-op if None or
    threadpoolctl is unavailable): ``with blas_threads(1): ...``."""
    global _CONTROLLER
    if k is None:
        return contextlib.nullcontext()
    k = number("k", k, integer=True, low=1)
    if ThreadpoolController is None:
        return contextlib.nullcontext()
    if _CONTROLLER is None:
        # the controller sees only the BLAS libraries loaded when it is made: load scipy's
        # (used by the LAPACK calls of the Python loop and the BLAS calls of the compiled one)
        import scipy.linalg.cython_blas  # noqa: F401

        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=int(k), user_api="blas")


def one_blas_thread(func: Callable[..., Any]) -> Callable[..., Any]:
    """Decorator: run ``func`` with the BLAS thread pools limited to one thread.

    Threaded BLAS rounds differently with the number of threads; with one thread the results
    of shooting, continuation and the frozen modes do not depend on ``OPENBLAS_NUM_THREADS`` or
    the core count (and the small dense matrices of the linkage are faster on one thread)."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with blas_threads(1):
            return func(*args, **kwargs)

    return wrapper
