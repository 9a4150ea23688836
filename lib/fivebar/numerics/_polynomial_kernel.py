r"""The quadratic and cubic restoring force of the modal equations (3.4), compiled.

:func:`polynomial_force` is the force of ``fivebar.numerics.periodic._PolynomialForce`` in the
form the compiled time loop takes a nonlinear force (``fivebar.numerics._kernels.FORCE_SIG``:
``force(u, k, rdata, idata, f, Kt, tangent)``), so that the period map of the modal equations
(:func:`fivebar.numerics.periodic.modal_period_map`) runs in the compiled loop instead of the
Python loop with a callback at every Newton iteration.  Its data, made by
:func:`pack_polynomial`: ``rdata`` the coefficients :math:`\delta_{rst}`, :math:`\gamma_{rstu}`
and the two symmetrised tensors of the tangent (made once, by ``_PolynomialForce``), flat;
``idata = [n]``.  The force does not
depend on the step point ``k``.  The tests hold it equal to the numpy form
(``_PolynomialForce.__call__``) to round-off.  Loaded (and cached on disk) by
:func:`fivebar.numerics._jitcache.import_cached`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._kernels import FORCE_SIG

__all__ = ["pack_polynomial", "polynomial_force"]


@njit(cache=True)
def polynomial_force(u, k, rdata, idata, f, Kt, tangent):
    r""":math:`f_r = -\sum_{s,t}\delta_{rst}u_s u_t - \sum_{s,t,v}\gamma_{rstv}u_s u_t u_v` and,
    if ``tangent``, :math:`K_{t,rs} = \partial f_r/\partial u_s` (``k`` is not used)."""
    n = idata[0]
    n2, n3 = n * n, n * n * n
    d0, g0 = 0, n3  # delta (n, n, n), gamma (n, n, n, n)
    dt0, gt0 = n3 + n3 * n, 2 * n3 + n3 * n  # delta + its transpose, gamma's three orderings
    for r in range(n):
        acc = 0.0
        for s in range(n):
            us = u[s]
            for t in range(n):
                ust = us * u[t]
                acc += rdata[d0 + r * n2 + s * n + t] * ust
                base = g0 + r * n3 + s * n2 + t * n
                for v in range(n):
                    acc += rdata[base + v] * ust * u[v]
        f[r] = -acc
    if tangent:
        for r in range(n):
            for s in range(n):
                acc = 0.0
                for t in range(n):
                    acc += rdata[dt0 + r * n2 + s * n + t] * u[t]
                    base = gt0 + r * n3 + s * n2 + t * n
                    for v in range(n):
                        acc += rdata[base + v] * u[t] * u[v]
                Kt[r, s] = -acc


def pack_polynomial(delta: np.ndarray, gamma: np.ndarray, dsym: np.ndarray,
                    gsym: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rdata, idata)`` of :func:`polynomial_force` for the coefficients ``delta`` (n, n, n) and
    ``gamma`` (n, n, n, n) and the tangent's tensors made from them (``_PolynomialForce``'s
    ``dsym``, ``gsym``)."""
    n = np.shape(delta)[0]
    rdata = np.concatenate([np.ravel(X).astype(float) for X in (delta, gamma, dsym, gsym)])
    return rdata, np.array([n], dtype=np.int64)


__jit_signatures__ = {"polynomial_force": (FORCE_SIG,)}
