"""The BLAS thread limit (fivebar.numerics.blas): applied inside, restored after, bad counts refused."""

import pytest
import scipy.linalg.cython_blas  # noqa: F401  (scipy's BLAS loaded before the first count, as blas_threads loads it)
from threadpoolctl import threadpool_info, threadpool_limits

from fivebar.errors import InputError
from fivebar.numerics.blas import blas_threads


def _blas_threads_now():
    return {lib["filepath"]: lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}


def test_limit_inside_and_restored_after():
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads_now()
        with blas_threads(1):
            inside = _blas_threads_now()
        assert _blas_threads_now() == before
    assert inside and set(inside.values()) == {1}


@pytest.mark.parametrize("bad", [0, -1, 1.5, "2"])
def test_bad_thread_counts_are_refused(bad):
    with pytest.raises(InputError, match=r"k = .* is not allowed: give an integer >= 1"):
        blas_threads(bad)
