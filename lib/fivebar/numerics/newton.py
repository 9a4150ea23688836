"""Newton-Raphson with step halving, for a small system of nonlinear equations.

The root finder of the multiple-scales steady states (:meth:`fivebar.numerics.multiscale.SlowFlow.steady_state`);
it knows nothing of multiple scales or of the linkage.  Its one error is the library's error of
every Newton iteration, :class:`fivebar.numerics.newmark.NewtonConvergenceError`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError, InputTypeError
from .newmark import NewtonConvergenceError

__all__ = ["newton"]

Array = NDArray[np.float64]


def _newton_error(message: str, residual: float, iterations: int, t: float | None = None) -> NewtonConvergenceError:
    return NewtonConvergenceError(message, t, residual, iterations)


def _fd_jacobian(fun: Callable[[Array], Array], x: Array, r: Array) -> Array:
    J = np.empty((r.size, x.size))
    for k in range(x.size):
        h = 1e-7 * max(1.0, abs(x[k]))
        xp = x.copy()
        xp[k] += h
        J[:, k] = (np.asarray(fun(xp), float) - r) / h
    return J


def newton(
    fun: Callable[[Array], ArrayLike],
    x0: ArrayLike,
    jac: Callable[[Array], ArrayLike] | None = None,
    *,
    tol: float = 1e-10,
    maxiter: int = 50,
    t: float | None = None,
) -> Array:
    """Solve ``fun(x) = 0`` by Newton-Raphson with step halving.

    Call forms::

        x = newton(fun, x0)                 # finite-difference Jacobian
        x = newton(fun, x0, jac, tol=1e-12)

    Parameters
    ----------
    fun : callable ``x -> r``
        Residual, same length as ``x``.
    x0 : array_like (m,)
        Initial guess.
    jac : callable ``x -> (m, m)``, optional
        Jacobian of ``fun``; default forward differences.
    tol : float
        Converged when ``max|fun(x)| <= tol`` (units of ``fun``).
    maxiter : int
        Maximum Newton iterations.
    t : float, optional
        Time (s) the solve belongs to; only quoted in the error message.

    Returns
    -------
    ndarray (m,)

    Raises
    ------
    NewtonConvergenceError
        No convergence in ``maxiter`` iterations, a singular Jacobian, a non-finite residual or
        a step that no halving makes decrease the residual; the message names the residual,
        the iterations and (if given) the time.
    fivebar.errors.InputError
        ``x0`` not a finite real array, ``tol`` < 0 or ``maxiter`` < 1.
    """
    if not callable(fun):
        raise InputTypeError(f"fun is a {type(fun).__name__}: it must be a callable x -> residual")
    try:
        x = np.array(x0, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"x0 = {x0!r} is not allowed: it must be a real array") from None
    if not np.all(np.isfinite(x)):
        raise InputError(f"x0 = {x0!r} is not allowed: it must be finite")
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating)) or not (math.isfinite(tol) and tol >= 0):
        raise InputError(f"tol = {tol!r} is not allowed: it must be a finite number >= 0 (units of fun)")
    if isinstance(maxiter, bool) or not isinstance(maxiter, (int, np.integer)) or maxiter < 1:
        raise InputError(f"maxiter = {maxiter!r} is not allowed: it must be an integer >= 1")
    at = "" if t is None else f" at t = {t:.9g} s"
    r = np.asarray(fun(x), dtype=float).ravel()
    norm = float(np.max(np.abs(r))) if r.size else 0.0
    if not np.isfinite(norm):
        raise _newton_error(f"Newton-Raphson{at}: residual is not finite at the initial guess", norm, 0, t)
    for it in range(maxiter):
        if norm <= tol:
            return x
        J = np.asarray(jac(x), float) if jac is not None else _fd_jacobian(fun, x, r)
        try:
            dx = np.linalg.solve(J, -r)
        except np.linalg.LinAlgError:
            dx = np.full_like(x, np.nan)
        if not np.all(np.isfinite(dx)):
            raise _newton_error(
                f"Newton-Raphson{at}: singular Jacobian after {it} iterations (residual {norm:.3e})", norm, it, t
            )
        lam = 1.0
        for _ in range(40):
            xn = x + lam * dx
            rn = np.asarray(fun(xn), dtype=float).ravel()
            nn = float(np.max(np.abs(rn)))
            if np.isfinite(nn) and (nn < norm or nn <= tol):
                break
            lam *= 0.5
        else:
            raise _newton_error(
                f"Newton-Raphson{at}: no step along the Newton direction reduces the residual "
                f"{norm:.3e} (tol {tol:.3e}) after {it + 1} iterations",
                norm, it + 1, t,
            )
        x, r, norm = xn, rn, nn
    if norm <= tol:
        return x
    raise _newton_error(
        f"Newton-Raphson{at} did not converge: residual {norm:.3e} > tol {tol:.3e} after {maxiter} iterations",
        norm, maxiter, t,
    )
