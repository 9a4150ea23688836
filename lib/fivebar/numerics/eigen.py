r"""Frozen modes: the one eigensolver of the library.

The undamped modes of one configuration, :math:`\mathbf K\boldsymbol\phi = \omega^2\mathbf M
\boldsymbol\phi`, are solved in the inverse form :math:`\mathbf M\boldsymbol\phi =
\mu\mathbf K\boldsymbol\phi` for the largest :math:`\mu = 1/\omega^2`.  The curvature DOFs
make :math:`\mathbf M` ill-conditioned (eigenvalues from 1e-10 to 1): the usual form gives the
lowest frequencies only to about 1e-8 relative, varying with the BLAS thread count, while the
inverse form gives them to round-off (the lowest modes are what every analysis uses).

Imports nothing of the linkage (numpy and scipy only).  One BLAS thread
(:mod:`fivebar.numerics.blas`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..errors import ComputationError, InputError
from .blas import one_blas_thread

__all__ = ["frozen_modes"]


@one_blas_thread  # small matrices (numerics/blas.py); results independent of the thread count
def frozen_modes(M: ArrayLike, K: ArrayLike, n: int | None = None) -> tuple[NDArray, NDArray]:
    """Lowest ``n`` modes of (K, M): ``omega2`` (rad^2/s^2) ascending, mass-normalised ``Phi``.

    ``w2, Phi = frozen_modes(M, K, n)``; ``M, K`` symmetric positive definite, ``(N, N)`` or
    stacks ``(..., N, N)`` (solved together: Cholesky ``K = L L^T`` and the symmetric
    eigenproblem of ``L^-1 M L^-T``, formed with the inverse of the triangular ``L``).
    ``n=None`` returns all ``N`` modes.  Returns ``w2`` of shape ``(..., n)`` and ``Phi`` of
    shape ``(..., N, n)`` with ``Phi^T M Phi = I``.
    """
    M, K = np.asarray(M, float), np.asarray(K, float)
    if M.shape != K.shape or M.ndim < 2 or M.shape[-1] != M.shape[-2]:
        raise InputError(f"M and K must be square matrices (or stacks) of one shape, got {M.shape} and {K.shape}")
    N = M.shape[-1]
    k = N if n is None else int(n)
    if not 1 <= k <= N:
        raise InputError(f"n = {n!r} modes is not allowed: give 1..{N} (the size of the matrices)")
    if not (np.all(np.isfinite(M)) and np.all(np.isfinite(K))):
        raise ComputationError("the frozen modes cannot be computed: M or K holds entries that are not finite "
                               "(an overflow of the numbers they are made of)")
    try:
        if M.ndim == 2:
            mu, V = scipy.linalg.eigh(M, K, subset_by_index=(N - k, N - 1))
        else:
            Li = np.linalg.inv(np.linalg.cholesky(K))
    except np.linalg.LinAlgError as exc:
        raise ComputationError(f"the frozen modes cannot be computed: K is not positive definite to working "
                               f"precision ({exc})") from None
    if M.ndim > 2:
        # one batched inverse of the triangular factor and products, instead of three batched
        # general solves with it (a third less time for a stack of S configurations)
        LiT = np.swapaxes(Li, -1, -2)
        A = Li @ M @ LiT  # L^-1 M L^-T
        mu, Y = np.linalg.eigh(0.5 * (A + np.swapaxes(A, -1, -2)))
        mu, Y = mu[..., N - k:], Y[..., N - k:]
        V = LiT @ Y  # L^-T Y: V^T K V = I
    mu, V = mu[..., ::-1], V[..., ::-1]  # ascending frequency
    if not np.all(mu > 0):  # (mu = 1 / omega^2 of the highest modes lost in the round-off of M)
        raise ComputationError(
            f"the frozen modes cannot be computed: M is not positive definite to working precision (the "
            f"smallest eigenvalue of M relative to K is {float(np.min(mu)):.3g}, the largest "
            f"{float(np.max(mu)):.3g}): its smallest entries are lost in the round-off of its largest")
    Phi = V / np.sqrt(mu)[..., None, :]  # mass-normalised: Phi^T M Phi = I
    return 1.0 / mu, Phi
