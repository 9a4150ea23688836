r"""Implicit time integration of time-varying nonlinear structural systems, (4.1)-(4.4).

This module implements section 4 of the paper, eqs. (4.1)-(4.4), for a generic system

.. math::

    \mathbf M(t)\,\ddot{\mathbf u} + \mathbf C(t)\,\dot{\mathbf u} + \mathbf K(t)\,\mathbf u
    + \mathbf f_{nl}(\mathbf u) = \mathbf F(t),

with ``n`` degrees of freedom and dense matrices.  It knows nothing of the five-bar linkage:
the model supplies ``M, C, K, F`` (and the nonlinear force) through a small protocol
(:class:`fivebar.numerics.systems.SecondOrderSystem`, or the concrete :class:`fivebar.numerics.systems.System`).
The schemes (Newmark's rule (4.2)-(4.3) and the dissipative alpha schemes, with their stability
conditions) are :mod:`fivebar.numerics.schemes`; this module is the integrator, :func:`integrate`.

**The equation at** :math:`t_{n+1}` **, (4.4).**  Writing
:math:`\tilde{\mathbf u} = \mathbf u_n + \Delta t\,\dot{\mathbf u}_n
+ (\tfrac12-\beta)\Delta t^2\ddot{\mathbf u}_n` and
:math:`\tilde{\mathbf v} = \dot{\mathbf u}_n + (1-\gamma)\Delta t\,\ddot{\mathbf u}_n`, (4.2)-(4.3)
give :math:`\ddot{\mathbf u}_{n+1} = (\mathbf u_{n+1}-\tilde{\mathbf u})/(\beta\Delta t^2)` and
:math:`\dot{\mathbf u}_{n+1} = \tilde{\mathbf v} + \gamma\Delta t\,\ddot{\mathbf u}_{n+1}`;
substituted into the equation of motion at :math:`t_{n+1}` they leave the residual

.. math::

    \mathbf R(\mathbf u_{n+1}) = \mathbf M_{n+1}\ddot{\mathbf u}_{n+1}
        + \mathbf C_{n+1}\dot{\mathbf u}_{n+1} + \mathbf K_{n+1}\mathbf u_{n+1}
        + \mathbf f_{nl}(\mathbf u_{n+1}) - \mathbf F_{n+1} = \mathbf 0,

solved by Newton-Raphson with the consistent tangent

.. math::

    \mathbf S = \frac{\mathbf M_{n+1}}{\beta\Delta t^2}
        + \frac{\gamma\,\mathbf C_{n+1}}{\beta\Delta t} + \mathbf K_{n+1}
        + \mathbf K_t(\mathbf u_{n+1}),
    \qquad \mathbf K_t = \partial\mathbf f_{nl}/\partial\mathbf u .

A linear system (no ``f_nl``) takes one solve per step.  Factorisations are reused when the
tangent does not change (time-invariant linear systems, or periodic systems whose per-step
matrices are precomputed in a :class:`fivebar.numerics.systems.PeriodicStepData`).

**Numerical dissipation (optional).**  The generalised-alpha family of Chung & Hulbert (1993)
evaluates the equation at intermediate points, with forces interpolated between
:math:`t_n` and :math:`t_{n+1}`:

.. math::

    & \bar{\mathbf M}\big((1-\alpha_m)\ddot{\mathbf u}_{n+1} + \alpha_m\ddot{\mathbf u}_n\big)
    + (1-\alpha_f)\,\mathbf g_{n+1} + \alpha_f\,\mathbf g_n = \mathbf 0, \\
    & \mathbf g = \mathbf C\dot{\mathbf u} + \mathbf K\mathbf u
        + \mathbf f_{nl}(\mathbf u) - \mathbf F,

with :math:`\bar{\mathbf M} = (1-\alpha_f)\mathbf M_{n+1} + \alpha_f\mathbf M_n` (the mass at
the time :math:`t_{n+1-\alpha_f}` where the forces are taken: with a time-varying mass,
:math:`\mathbf M_{n+1}` there would make the scheme first order) and the tangent
:math:`\mathbf S = (1-\alpha_m)\bar{\mathbf M}/(\beta\Delta t^2)
+ (1-\alpha_f)\big(\gamma\mathbf C_{n+1}/(\beta\Delta t) + \mathbf K_{n+1} + \mathbf K_t\big)`.
:class:`~fivebar.numerics.schemes.Newmark` is :math:`\alpha_m=\alpha_f=0`;
:class:`~fivebar.numerics.schemes.HHT` and :class:`~fivebar.numerics.schemes.GeneralizedAlpha` set the alphas
from one parameter each (:mod:`fivebar.numerics.schemes`).

**State and sensitivity.**  The integrator carries :math:`(\mathbf u,\dot{\mathbf u},
\ddot{\mathbf u})`; the initial acceleration is by default the consistent one, from the
equation of motion at :math:`t_0`.  For :class:`~fivebar.numerics.schemes.Newmark` the carried acceleration satisfies the
equation at every step, so the one-step map is a map of :math:`(\mathbf u, \dot{\mathbf u})`
(dimension :math:`2n`); the alpha schemes carry an *algorithmic* acceleration that is a genuine
third state (dimension :math:`3n`): restarting them from the consistent acceleration every step
would make them first order.  ``integrate(..., sensitivity=...)`` returns the product of the
step Jacobians (the monodromy matrix over a period, for shooting), obtained by linearising each
converged step: with the converged tangent :math:`\mathbf S`,

.. math::

    \delta\mathbf u_{n+1} ={}& -\mathbf S^{-1}\Big((1-\alpha_m)\bar{\mathbf M}\,\delta\mathbf a^*
      + (1-\alpha_f)\mathbf C_{n+1}\,\delta\mathbf v^* \\
      &+ \alpha_m\bar{\mathbf M}\,\delta\ddot{\mathbf u}_n
      + \alpha_f\big((\mathbf K_n+\mathbf K_{t,n})\,\delta\mathbf u_n
      + \mathbf C_n\,\delta\dot{\mathbf u}_n\big)\Big),

:math:`\delta\mathbf a^* = -\delta\tilde{\mathbf u}/(\beta\Delta t^2)`,
:math:`\delta\mathbf v^* = \delta\tilde{\mathbf v} + \gamma\Delta t\,\delta\mathbf a^*`, then
:math:`\delta\ddot{\mathbf u}_{n+1}
= (\delta\mathbf u_{n+1}-\delta\tilde{\mathbf u})/(\beta\Delta t^2)`
and :math:`\delta\dot{\mathbf u}_{n+1} = \delta\tilde{\mathbf v} + \gamma\Delta t\,
\delta\ddot{\mathbf u}_{n+1}`.

**The step, written once; two loops.**  The step's algebra (the scheme's coefficients, the
predictors, the residual and its reference norm, the Newton test and update, the tangent and its
LU, the alpha history, the sensitivity step) is a set of small compiled functions
(``fivebar.numerics._kernels``, numba, cached on disk) and nothing else.  Two loops call them: a compiled
loop, whenever the data allow it (per-step matrices from a :class:`~fivebar.numerics.systems.PeriodicStepData`, or a
time-invariant system, with no nonlinear force or one the system supplies compiled,
``system.compiled_nonlinear(step_data)``, as :class:`fivebar.model.dynamics.LinkageDynamics` does with
the beam's strain force and :func:`fivebar.numerics.periodic.modal_period_map` with the modal
equations' quadratic and cubic force), and a Python loop for a generic system with Python callbacks (a
nonlinear force given as a function, time-varying matrices without step data).  The loops
differ only in where the matrices and the nonlinear force come from; the tests hold them equal
to round-off.  Newton's iteration of a nonlinear step starts from the acceleration
extrapolated over the steps before (quadratically once two lie behind:
:math:`3\ddot{\mathbf u}_n - 3\ddot{\mathbf u}_{n-1} + \ddot{\mathbf u}_{n-2}`, an error of
order :math:`\Delta t^3` on a smooth response, where :math:`\ddot{\mathbf u}_{n+1} =
\ddot{\mathbf u}_n` errs by order :math:`\Delta t`), and again from :math:`\ddot{\mathbf u}_n`
if it fails from there (a start that excites the stiff modes makes the history rough); on the
linkage's orbits this takes about 1.1 iterations per step instead of 2.  The compiled loop
evaluates the nonlinear tangent with the force at the first iterate (an update nearly always
follows) and after that only when an update follows (and at the converged state when the
sensitivity is asked for).  The first call of a
fresh installation compiles the kernels (tens of seconds); later processes load them from the
cache, which heals (a damaged file is discarded and rebuilt with a warning), is read where it
is read-only, and is temporary (removed at exit) where nothing is writable:
``fivebar.numerics._jitcache``.

References: N. M. Newmark, J. Eng. Mech. Div. ASCE 85 (1959) 67-94; J. Chung,
G. M. Hulbert, J. Appl. Mech. 60 (1993) 371-375.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FivebarError, InputError, InputTypeError, array, choice, memory, number
from .blas import blas_threads as _limit_blas
from .schemes import GENERIC_SCHEME, Scheme, _check_scheme
from .systems import PeriodicStepData, SecondOrderSystem, _check_system, _checked, _new_lu_cache, _nonlinear_at


__all__ = [
    "MAX_ITER",
    "NewmarkResult",
    "NewtonConvergenceError",
    "integrate",
]

Array = NDArray[np.float64]

#: The largest ``max_iter`` (Newton iterations per step) :func:`integrate` accepts: far above
#: what a converging step takes (a few), and a bound on the time a step can spend.
MAX_ITER = 1000


class NewtonConvergenceError(FivebarError, RuntimeError):
    """The Newton-Raphson iteration of one time step did not converge.

    Attributes
    ----------
    t : float
        Time at the end of the failed step (s).
    residual : float
        Norm of the last residual.
    iterations : int
        Newton iterations (linear solves) made in the step.
    """

    def __init__(self, message: str, t: float, residual: float, iterations: int) -> None:
        super().__init__(message)
        self.t = t
        self.residual = residual
        self.iterations = iterations



# --- result -----------------------------------------------------------------------------------
@dataclass
class NewmarkResult:
    """Output of :func:`integrate`.

    Attributes
    ----------
    t : ndarray (N,)
        Times of the stored states (s).
    u, v, a : ndarray (N, n)
        Displacement, velocity, acceleration at those times.
    iterations : ndarray (nsteps,) of int
        Newton iterations (linear solves) per step (1 for a linear system).
    monodromy : ndarray or None
        Product of the step Jacobians, ``d x_N / d x_0`` with ``x = (u, v)`` (2n x 2n, the
        initial acceleration consistent) or ``x = (u, v, a)`` (3n x 3n), if requested.
    state : str or None
        ``"uv"`` or ``"uva"``: the state the monodromy refers to.
    scheme : Scheme
    """

    t: Array
    u: Array
    v: Array
    a: Array
    iterations: NDArray[np.int_]
    scheme: Scheme
    monodromy: Array | None = None
    state: str | None = None


# --- the integrator ---------------------------------------------------------------------------
def integrate(
    system: SecondOrderSystem,
    u0: ArrayLike,
    v0: ArrayLike,
    t0: float,
    dt: float,
    nsteps: int,
    scheme: Scheme | None = None,
    *,
    a0: ArrayLike | None = None,
    step_data: PeriodicStepData | None = None,
    rtol: float = 1e-10,
    xtol: float = 1e-12,
    atol: float = 0.0,
    max_iter: int = 20,
    newton: Literal["full", "modified"] = "full",
    sensitivity: bool | Literal["uv", "uva"] = False,
    store: Literal["all", "last"] = "all",
    blas_threads: int | None = 1,
    directions: ArrayLike | None = None,
) -> NewmarkResult:
    r"""March ``M u'' + C u' + K u + f_nl(u) = F`` over ``nsteps`` steps, (4.1)-(4.4).

    Call forms::

        res = integrate(system, u0, v0, t0, dt, nsteps)                      # (4.2)-(4.4)
        res = integrate(system, u0, v0, t0, T / S, S, sensitivity=True)      # + monodromy
        res = integrate(system, u0, v0, t0, dt, n, HHT(-0.1))                # dissipative

    Parameters
    ----------
    system : SecondOrderSystem
        Supplies ``matrices(t)``, ``force(t)`` and optionally ``nonlinear(u, t)``.
    u0, v0 : array_like (n,)
        Initial displacement and velocity (SI).
    t0 : float
        Initial time (s).
    dt : float
        Time step (s), > 0; ``T = S dt`` (4.1).
    nsteps : int
        Number of steps, >= 0.
    scheme : Scheme, optional
        :class:`~fivebar.numerics.schemes.Newmark` (default: gamma = 1/2, beta = 1/4),
        :class:`~fivebar.numerics.schemes.HHT` or :class:`~fivebar.numerics.schemes.GeneralizedAlpha`.
    a0 : array_like (n,), optional
        Initial acceleration; default the consistent one from the equation at ``t0``.
    step_data : PeriodicStepData, optional
        Precomputed per-step ``M, C, K, F`` of a periodic system; its ``dt`` must equal ``dt``
        and ``t0`` must fall on one of its time points (modulo the period).
    rtol : float
        Newton convergence: ``||R|| <= rtol * ref + atol``, ``ref`` the sum of the norms of the
        terms of the residual (inertia, damping, stiffness, nonlinear and external forces).
    xtol : float
        Newton convergence, alternatively: increment ``||du|| <= xtol * ||u||``.
    atol : float
        Absolute residual tolerance (force units), default 0.
    max_iter : int
        Maximum Newton iterations (linear solves) per step.
    newton : {"full", "modified"}
        "full": the consistent tangent, refactorised every iteration (quadratic convergence).
        "modified": the linear part of the tangent only (without ``K_t``), whose factorisation
        is reused (cached per step with ``step_data``); linear convergence, cheaper steps.
    sensitivity : bool or {"uv", "uva"}
        Also return the product of the step Jacobians.  "uv": ``d(u_N, v_N)/d(u_0, v_0)`` with
        the initial acceleration consistent (2n x 2n; requires ``a0=None``); the exact
        monodromy of the discrete map for :class:`~fivebar.numerics.schemes.Newmark`.  "uva": ``d(u_N, v_N, a_N) /
        d(u_0, v_0, a_0)`` (3n x 3n), the state of the alpha schemes.  True picks "uv" for
        Newmark and "uva" otherwise.
    directions : array_like (2n, m) or (3n, m), optional
        With ``sensitivity``: propagate only these ``m`` directions of the initial state
        (``(u, v)`` for "uv", ``(u, v, a)`` for "uva") and return ``monodromy`` = the product
        of the step Jacobians times ``directions``, shape (2n, m) or (3n, m): the
        matrix-free monodromy products of a Newton-Krylov shooting, at a cost that grows with
        ``m`` instead of ``n``.
    store : {"all", "last"}
        Keep every state, or only the initial and final ones.
    blas_threads : int or None
        BLAS threads while marching (via threadpoolctl, if installed).  Default 1: the
        per-step operations (n up to a few hundred) are too small to gain from threads, and
        threaded BLAS on a busy machine made them 10-50 times slower in our benchmarks.
        None leaves the BLAS setting alone.

    Returns
    -------
    NewmarkResult

    Raises
    ------
    fivebar.errors.InputError
        Bad ``dt``, ``nsteps``, ``max_iter`` (at most :data:`MAX_ITER`), shapes, non-finite
        initial state, mismatched ``step_data``.
    fivebar.errors.ResourceError
        The stored states would not fit in the available memory (checked before allocating).
    NewtonConvergenceError
        A step whose Newton iteration does not converge within ``max_iter`` (the message names
        the time, the residual norm and the iterations), or a singular tangent.
    """
    scheme = GENERIC_SCHEME if scheme is None else scheme
    _check_scheme(scheme)
    _check_system(system)
    dt = number("dt", dt, low=0.0, low_open=True, unit="s")
    t0 = number("t0", t0, unit="s")
    nsteps = number("nsteps", nsteps, integer=True, low=0)
    max_iter = number("max_iter", max_iter, integer=True, low=1, high=MAX_ITER)
    rtol = number("rtol", rtol, low=0.0)
    xtol = number("xtol", xtol, low=0.0)
    atol = number("atol", atol, low=0.0)
    choice("newton", newton, ("full", "modified"))
    choice("store", store, ("all", "last"))
    if sensitivity is True:
        sensitivity = "uv" if scheme.is_newmark else "uva"
    if sensitivity is None:
        sensitivity = False
    choice("sensitivity", sensitivity, (False, "uv", "uva"))
    if sensitivity == "uv" and a0 is not None:
        raise InputError(f"a0 = {a0!r} is not allowed with sensitivity='uv', which differentiates "
                         "through the consistent initial acceleration: leave a0=None")
    if directions is not None:
        if not sensitivity:
            raise InputError("directions needs sensitivity='uv' or 'uva' (the state they refer to), "
                             f"got sensitivity={sensitivity!r}")
        directions = array("directions", directions)
        if directions.ndim == 1:
            directions = directions[:, None]
        nx = np.size(u0) * (2 if sensitivity == "uv" else 3)
        if directions.ndim != 2 or directions.shape[0] != nx:
            raise InputError(f"directions has shape {directions.shape}: expected finite ({nx}, m) "
                             f"for sensitivity={sensitivity!r} and {np.size(u0)} DOFs")
    if blas_threads is not None:
        blas_threads = number("blas_threads", blas_threads, integer=True, low=1)
    n = int(np.size(u0))
    nstore = nsteps + 1 if store == "all" else 2
    memory(8.0 * nstore * (3 * n + 1), f"the stored states of nsteps = {nsteps} steps of {n} DOFs",
           "give fewer nsteps or store='last'")
    with _limit_blas(blas_threads):
        return _march(system, u0, v0, t0, dt, nsteps, scheme, a0, step_data, rtol, xtol, atol,
                      max_iter, newton, sensitivity, store, directions)


def _march(system: SecondOrderSystem, u0: ArrayLike, v0: ArrayLike, t0: float, dt: float,
           nsteps: int, scheme: Scheme, a0: ArrayLike | None, step_data: PeriodicStepData | None,
           rtol: float, xtol: float, atol: float, max_iter: int, newton: str, sensitivity: Any,
           store: str, directions: Array | None = None) -> NewmarkResult:
    """The body of :func:`integrate` (arguments checked there)."""
    u = np.array(array("u0", u0)).ravel()
    n = u.size
    v = np.array(array("v0", v0)).ravel()
    if v.shape != (n,):
        raise InputError(f"v0 has shape {v.shape}: expected ({n},) like u0")

    nl = getattr(system, "nonlinear", None)
    linear = nl is None
    time_invariant = bool(getattr(system, "time_invariant", False)) and step_data is None

    # --- access to the per-step data ---------------------------------------------------------
    if step_data is not None:
        sd = step_data
        if not isinstance(sd, PeriodicStepData):
            raise InputTypeError(f"step_data = {sd!r} is not allowed: give a PeriodicStepData or None")
        if sd.n != n:
            raise InputError(f"step_data has n = {sd.n} DOFs and the initial state u0 has {n}: "
                             "give step data of the same system")
        if abs(sd.dt - dt) > 1e-12 * dt:
            raise InputError(f"dt = {dt!r} differs from step_data.dt = {sd.dt!r} (period / steps)")
        off = (t0 - sd.t0) / dt
        k0 = round(off)
        if abs(off - k0) > 1e-8 * max(1.0, abs(off)):
            raise InputError(f"t0 = {t0!r} is not a time point of step_data "
                             f"(t0 + k dt, t0={sd.t0!r}, dt={dt!r})")
        k0 %= sd.steps
        Ms, Cs, Ks, Fs = sd.kernel_arrays()

        def data(j: int) -> tuple[Array, Array, Array, Array]:
            k = k0 + j
            return Ms[k % len(Ms)], Cs[k % len(Cs)], Ks[k % len(Ks)], Fs[k % len(Fs)]
    else:
        sd = None
        k0 = 0
        fixed: list[Array] = []  # M, C, K of a time-invariant system, read once

        def data(j: int) -> tuple[Array, Array, Array, Array]:
            t = t0 + j * dt
            at = "t0" if j == 0 else f"t = {t:.9g} s"
            if fixed:
                M, C, K = fixed
            else:
                M, C, K = (_checked(f"system: {name}({at})", X, (n, n))
                           for name, X in zip("MCK", system.matrices(t)))
                if time_invariant:
                    fixed.extend((M, C, K))
            return M, C, K, _checked(f"system: F({at})", system.force(t), (n,))

    kern = _kernels()
    c = kern.coefficients(float(scheme.gamma), float(scheme.beta), float(scheme.alpha_m),
                          float(scheme.alpha_f), dt)
    alpha = not scheme.is_newmark
    M0, C0, K0, F0 = data(0)
    if sd is not None:
        for name, Y, shape in (("M", M0, (n, n)), ("C", C0, (n, n)), ("K", K0, (n, n)), ("F", F0, (n,))):
            _checked(f"system: {name}(t0)", Y, shape)

    if linear:
        fnl0 = np.zeros(n)
        Kt0 = np.zeros((n, n))
    else:
        fnl0, Kt0 = _nonlinear_at(nl, u, t0, n)
    if a0 is None:
        try:
            a = np.linalg.solve(M0, F0 - C0 @ v - K0 @ u - fnl0)
        except np.linalg.LinAlgError as exc:
            raise InputError(
                f"a0 = None is not allowed here: the mass matrix at t0 = {t0!r} is singular, so the "
                "initial acceleration cannot be computed; pass a0 explicitly") from exc
    else:
        a = np.array(array("a0", a0)).ravel()
        if a.shape != (n,):
            raise InputError(f"a0 has shape {a.shape}: expected ({n},) like u0")

    # --- the state (u, v, a, g), g = C v + K u + f_nl - F the history of the alpha schemes ---
    x = np.zeros((4, n))
    x[0], x[1], x[2] = u, v, a
    if alpha:
        x[3] = C0 @ v + K0 @ u + fnl0 - F0

    # --- storage -------------------------------------------------------------------------
    nstore = nsteps + 1 if store == "all" else 2
    T = t0 + np.arange(nstore) * dt
    if store == "last":
        T[1] = t0 + nsteps * dt
    X = np.empty((3, nstore, n))
    X[:, 0] = x[:3]
    iters = np.ones(nsteps, dtype=np.int64)

    # sensitivity: d(u, v, a)_n / d(initial state), blocks of shape (n, m)
    if sensitivity:
        if sensitivity == "uv":
            Pu = np.hstack([np.eye(n), np.zeros((n, n))])
            Pv = np.hstack([np.zeros((n, n)), np.eye(n)])
            Pa = -np.linalg.solve(M0, np.hstack([K0 + Kt0, C0]))
        else:
            Pu = np.hstack([np.eye(n), np.zeros((n, 2 * n))])
            Pv = np.hstack([np.zeros((n, n)), np.eye(n), np.zeros((n, n))])
            Pa = np.hstack([np.zeros((n, 2 * n)), np.eye(n)])
        if directions is not None:  # only the products with the given directions
            Pu, Pv, Pa = (P @ directions for P in (Pu, Pv, Pa))
        P = np.ascontiguousarray(np.stack([Pu, Pv, Pa]), dtype=float)
    else:
        P = np.zeros((3, n, 0))

    # the LU cache of the linear tangent: per step point of the step data, else one slot (and
    # one unused slot for full Newton on a nonlinear system, which factorises the consistent
    # tangent and never the linear one)
    M_const = time_invariant or (sd is not None and sd.M_constant)
    key = (float(c[kern.CM]), float(c[kern.CC]), float(c[kern.CK]),
           0.0 if M_const else float(scheme.alpha_f))
    uses_cache = linear or newton == "modified"
    cache = sd.lu_cache(key) if sd is not None and uses_cache else _new_lu_cache(1, n)
    tol = np.array([rtol, xtol, atol])

    compiled_nl = None
    if not linear and sd is not None:
        get = getattr(system, "compiled_nonlinear", None)
        compiled_nl = get(sd) if callable(get) else None
    if _USE_KERNELS and (sd is not None or time_invariant) and (linear or compiled_nl is not None):
        if sd is None:  # time-invariant: M, C, K once, the force at every step
            Ms, Cs, Ks = (X_[None] for X_ in (M0, C0, K0))
            Fs = np.empty((nsteps + 1, n))
            Fs[0] = F0
            for j in range(1, nsteps + 1):
                Fs[j] = data(j)[3]
        force, rdata, idata = compiled_nl or (kern.no_force, np.zeros(1), np.zeros(1, np.int64))
        info = np.zeros(7)
        status = kern.march(Ms, Cs, Ks, Fs, int(k0), c, x, int(nsteps), float(t0), force, rdata,
                            idata, not linear, np.ascontiguousarray(Kt0), tol, int(max_iter),
                            newton == "full", *cache, P, X, iters, info)
        if status != kern.OK:
            raise _step_error(kern, status, info, rtol, atol, max_iter)
    else:
        _march_python(kern, c, x, P, data, nl, t0, nsteps, k0, M_const, sd is None and not time_invariant,
                      Kt0, cache, tol, max_iter, newton == "full", X, iters)
    if store == "last":
        X[:, 1] = x[:3]

    mono = None
    state = None
    if sensitivity:
        state = str(sensitivity)
        mono = np.vstack(P[:2]) if sensitivity == "uv" else np.vstack(P)
    return NewmarkResult(t=T, u=X[0], v=X[1], a=X[2], iterations=iters, scheme=scheme,
                         monodromy=mono, state=state)


def _march_python(kern, c, x, P, data, nl, t0, nsteps, k0, M_const, refactor, Kt0, cache, tol,
                  max_iter, full, X, iters) -> None:
    """The time loop in Python, for systems the compiled loop cannot serve (Python callbacks
    of a generic :class:`~fivebar.numerics.systems.SecondOrderSystem`, time-varying systems without step data): the
    step is the compiled loop's, its pieces (``fivebar.numerics._kernels``) called from here, with the
    system's matrices and nonlinear force from its callbacks.  Arguments as
    ``fivebar.numerics._kernels.march`` takes them; ``refactor``: factorise the linear tangent anew
    every step (time-varying matrices)."""
    n = x.shape[1]
    linear = nl is None
    w = np.zeros((kern.NWORK, n))
    fnl, Kt, Ktp = np.zeros(n), np.zeros((n, n)), np.array(Kt0)
    St, piv, Mbw = np.empty((n, n)), np.empty(n, np.int64), np.empty((n, n))
    sens = P.shape[2] > 0
    PW, A = np.empty((3, n, P.shape[2])), np.empty((n, 3 * n))
    store = X.shape[1] == nsteps + 1
    LUc, pivc, have = cache
    info = np.zeros(7)
    Mp, Cp, Kp, _ = data(0)
    dt = float(c[kern.DT])

    def fail(status: int, j: int, t: float, **what: float) -> NewtonConvergenceError:
        info[:] = (j, t, what.get("rn", 0.0), what.get("k_it", 0), what.get("dmin", 0.0),
                   what.get("dmax", 0.0), what.get("ref", 0.0))
        return _step_error(kern, status, info, tol[0], tol[2], max_iter)

    for j in range(1, nsteps + 1):
        t = t0 + j * dt
        M, C, K, F = data(j)
        Mb = kern.inertia_mass(c, M, Mp, M_const, Mbw)
        li = (k0 + j) % LUc.shape[0]
        if refactor:
            have[li] = 0
        if linear:
            kern.predict(c, Mb, x, w, 0)
            ok, dmin, dmax = kern.linear_step(c, Mb, C, K, F, fnl, x, w, LUc, pivc, have, li)
            if not ok:
                raise fail(kern.SINGULAR, j, t, dmin=dmin, dmax=dmax)
            LU, LP = LUc[li], pivc[li]
        else:
            order = kern.guess_order(j)  # as the compiled loop: extrapolated, from a_n, from u_n
            while True:
                kern.predict(c, Mb, x, w, order)
                status, k_it, what = _newton_python(kern, c, Mb, C, K, F, fnl, Kt, w, nl, t, n, tol,
                                                    max_iter, full, LUc, pivc, have, li, St, piv)
                if status in (kern.OK, kern.SINGULAR) or order < 0:
                    break
                order = 0 if order > 0 else -1
            if status != kern.OK:
                raise fail(status, j, t, **what)
            iters[j - 1] = k_it
            if sens:  # the consistent tangent at the converged u_{n+1} (Kt evaluated there)
                ok, dmin, dmax = kern.tangent_lu(c, Mb, C, K, Kt, True, St, piv)
                if not ok:
                    raise fail(kern.SINGULAR, j, t, dmin=dmin, dmax=dmax)
            LU, LP = St, piv
        if sens:
            kern.sensitivity(c, LU, LP, Mb, C, Kp, Cp, Kt, Ktp, not linear, P, PW, A)
        kern.finish(c, C, K, F, fnl, x, w)
        if store:
            X[:, j] = x[:3]
        Mp, Cp, Kp = M, C, K


def _newton_python(kern, c, Mb, C, K, F, fnl, Kt, w, nl, t, n, tol, max_iter, full, LUc, pivc,
                   have, li, St, piv) -> tuple[int, int, dict]:
    """Newton's iteration of a nonlinear step of the Python loop (``fivebar.numerics._kernels.newton``
    with the force from the system's callback): ``(status, iterations, what)``, ``what`` the
    figures of a failure for :func:`_step_error`."""
    k_it = 0
    du_norm = math.inf
    while True:
        fnl[:], Kt[:] = _nonlinear_at(nl, w[kern.U1], t, n)
        rn, ref = kern.residual(c, Mb, C, K, F, fnl, w, True)
        if not math.isfinite(rn):
            return kern.NOT_FINITE, k_it, dict(rn=rn, k_it=k_it)
        if kern.converged(rn, ref, du_norm, w, tol):
            return kern.OK, k_it, {}
        if k_it >= max_iter:
            return kern.NO_CONVERGENCE, k_it, dict(rn=rn, k_it=k_it, ref=ref)
        if full:
            ok, dmin, dmax = kern.tangent_lu(c, Mb, C, K, Kt, True, St, piv)
        else:
            ok, dmin, dmax = kern.linear_lu(c, Mb, C, K, LUc, pivc, have, li)
        if not ok:
            return kern.SINGULAR, k_it, dict(dmin=dmin, dmax=dmax)
        du_norm = kern.correct(St, piv, w) if full else kern.correct(LUc[li], pivc[li], w)
        k_it += 1


def _step_error(kern: Any, status: int, info: Array, rtol: float, atol: float,
                max_iter: int) -> NewtonConvergenceError:
    """The error of a failed step (either loop), from its status code and ``info``."""
    j, t, rn, k_it, dmin, dmax, ref = info
    j, k_it = int(j), int(k_it)
    if status == kern.NOT_FINITE:
        return NewtonConvergenceError(
            f"Newton-Raphson diverged in step {j} at t = {t:.9g} s: residual norm {rn} "
            f"(not finite) after {k_it} iterations", t, rn, k_it)
    if status == kern.NO_CONVERGENCE:
        return NewtonConvergenceError(
            f"Newton-Raphson did not converge in step {j} at t = {t:.9g} s: residual "
            f"norm {rn:.3e} (tolerance {rtol:.1e} x {ref:.3e} + {atol:.1e}) after "
            f"{k_it} iterations (max_iter={max_iter})", t, rn, k_it)
    return NewtonConvergenceError(
        f"the effective stiffness (tangent) at t = {t:.9g} s is singular or not finite "
        f"(smallest/largest pivot {dmin:.3e}/{dmax:.3e})", t, math.nan, 0)


#: Use the compiled loop where it serves (a switch for benchmarks and comparison tests); the
#: Python loop serves otherwise, with the same compiled step.
_USE_KERNELS = True
_KERNELS: Any = None


def _kernels() -> Any:
    """The compiled step and loop (``fivebar.numerics._kernels``), imported on first use (numba is
    heavy) with the healing disk cache of :mod:`fivebar.numerics._jitcache`."""
    global _KERNELS
    if _KERNELS is None:
        from ._jitcache import import_cached

        _KERNELS = import_cached(f"{__package__}._kernels")
    return _KERNELS
