r"""Periodic orbits of periodically forced systems: shooting, Floquet multipliers, stability.

A *period map* advances the state :math:`\mathbf x` of a periodically forced system over one
period :math:`T` of its forcing, :math:`\mathbf x \mapsto \mathbf P(\mathbf x; p)`, at a
parameter value ``p``.  A periodic orbit is a fixed point,

.. math::

    \mathbf G(\mathbf x; p) = \mathbf P(\mathbf x; p) - \mathbf x = \mathbf 0,

and its *monodromy matrix* :math:`\boldsymbol\Phi = \partial\mathbf P/\partial\mathbf x` at the
fixed point has the Floquet multipliers as eigenvalues: the orbit is asymptotically stable when
all lie inside the unit circle.  :func:`shoot` solves :math:`\mathbf G = \mathbf 0` by Newton's
method with the Jacobian :math:`\boldsymbol\Phi - \mathbf I`.

This module imports nothing of the linkage (like :mod:`fivebar.numerics.newmark`).  The protocol of a
period map (:class:`PeriodMap`) is one callable::

    x_T, Phi = period_map(x, p, jacobian)

returning the state after one period and, if ``jacobian`` is true, the monodromy matrix, or
``None`` where the integrator gives no tangent (then :func:`monodromy` takes finite
differences).  :func:`newmark_map` builds one from a family of second-order systems of the
protocol of :mod:`fivebar.numerics.systems` (:class:`~fivebar.numerics.systems.SecondOrderSystem` integrated by
:func:`~fivebar.numerics.newmark.integrate`), with the monodromy matrix from the integrator's step
tangents.  The state is :math:`\mathbf x = (\mathbf u, \dot{\mathbf u})` at the start of the
period; the alpha schemes carry an algorithmic acceleration as well, which is started, as
:func:`~fivebar.numerics.newmark.integrate` does, from the equation of motion (so the map and its
monodromy matrix are those of :math:`(\mathbf u, \dot{\mathbf u})` with a consistent initial
acceleration).

The multipliers of the discrete map converge to those of the differential equation as
:math:`\Delta t^2` for the second-order schemes (tests: a damped linear oscillator, whose
multipliers are :math:`e^{\lambda_i T}`, and the first instability tongue of Mathieu's equation).
Only non-autonomous systems are meant: the period is that of the forcing, so no phase
condition is needed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ComputationError, InputError, checked
from .modal_equations import Harmonic, ModalSystem, Parametric, _check_inputs
from .blas import one_blas_thread
from .newmark import NewtonConvergenceError, integrate
from .schemes import GENERIC_SCHEME, Scheme
from .systems import PeriodicStepData, SecondOrderSystem, System

__all__ = [
    "Evaluation",
    "PeriodMap",
    "PeriodicNewton",
    "PeriodicOrbit",
    "PeriodicProblem",
    "ShootingError",
    "floquet_multipliers",
    "iterate_map",
    "modal_period_map",
    "monodromy",
    "newmark_map",
    "newton_periodic",
    "shoot",
]

Array = NDArray[np.float64]


class ShootingError(ComputationError):
    """Newton's method on the periodicity condition did not converge (the message says how far)."""


class PeriodMap(Protocol):
    """The state after one period, and (if asked and available) the monodromy matrix.

    ``period_map(x, p, jacobian) -> (x_T, Phi)``: ``x`` the state at the start of the period
    (shape ``(N,)``), ``p`` the parameter (a float, or ``None`` for a fixed system),
    ``jacobian`` whether ``Phi = d x_T / d x`` (``(N, N)``) is wanted; ``Phi`` is ``None`` when
    not asked for or when the integrator gives no tangent.  A failed integration raises a
    :class:`~fivebar.errors.FivebarError` (for example
    :class:`~fivebar.numerics.newmark.NewtonConvergenceError`).

    Optional attributes: ``periods`` (forcing periods per application, 1 if absent) and
    ``concurrent`` (True if calls at two different ``p`` may run at once in two threads; then
    :func:`fivebar.numerics.continuation.continuation` integrates its forward difference in ``p`` beside
    the monodromy period, on a second core; absent: one call at a time).
    """

    def __call__(self, x: Array, p: float | None, jacobian: bool) -> tuple[Array, Array | None]: ...


@dataclass(frozen=True)
class PeriodicProblem:
    """A periodically forced second-order system and how to integrate one period of it.

    Attributes
    ----------
    system : SecondOrderSystem
        ``M, C, K, F`` (and optionally ``nonlinear``), periodic in time with ``period``.
    period : float
        Period ``T`` of the forcing (s), > 0.
    steps : int
        Steps per period ``S`` (``dt = T / S``), >= 1.
    t0 : float
        Time at the start of the period (s).
    step_data : PeriodicStepData, optional
        Precomputed per-step matrices (the compiled loop serves them, with a nonlinear force
        the system supplies compiled, :meth:`~fivebar.numerics.systems.System.compiled_nonlinear`);
        default: sampled from the system when the system is linear and time-varying, so that the
        compiled loop serves; else the Python loop calls the system's functions.
    scheme : Scheme, optional
        Time integrator (default :class:`~fivebar.numerics.schemes.Newmark`, average acceleration).
    options : dict
        Further keyword arguments of :func:`~fivebar.numerics.newmark.integrate` (``rtol``,
        ``max_iter``, ``newton`` ...).
    """

    system: SecondOrderSystem
    period: float
    steps: int
    t0: float = 0.0
    step_data: PeriodicStepData | None = None
    scheme: Scheme | None = None
    options: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (isinstance(self.period, (int, float, np.floating)) and math.isfinite(self.period)
                and self.period > 0):
            raise InputError(f"period = {self.period!r} is not allowed: give a finite period > 0 (s)")
        if isinstance(self.steps, bool) or int(self.steps) != self.steps or self.steps < 1:
            raise InputError(f"steps = {self.steps!r} is not allowed: give an integer >= 1 (steps per period)")

    @property
    def dt(self) -> float:
        """Time step ``T / S`` (s)."""
        return float(self.period) / int(self.steps)


def _consistent_directions(problem: PeriodicProblem, u0: Array) -> Array:
    """d(u0, v0, a0) / d(u0, v0) with a0 from the equation of motion at t0 (as integrate starts)."""
    if problem.step_data is not None:
        sd = problem.step_data
        k = round((problem.t0 - sd.t0) / sd.dt) % sd.steps
        M, C, K = sd.M[k], sd.C[k], sd.K[k]
    else:
        M, C, K = (np.asarray(X, float) for X in problem.system.matrices(problem.t0))
    nl = getattr(problem.system, "nonlinear", None)
    if nl is not None:
        K = K + np.asarray(nl(u0, problem.t0)[1], float)
    n = u0.size
    da = -np.linalg.solve(M, np.hstack([K, C]))
    return np.vstack([np.eye(2 * n), da])


def newmark_map(family: PeriodicProblem | Callable[[float | None], PeriodicProblem],
                periods: int = 1) -> PeriodMap:
    """A :class:`PeriodMap` from a second-order system (or a family of them in a parameter).

    ``f = newmark_map(problem)`` (fixed system: ``p`` is ignored) or
    ``f = newmark_map(lambda p: PeriodicProblem(...))`` (a family, for continuation; the last
    problem built is kept, so repeated calls at one ``p`` build it once); then
    ``x_T, Phi = f(x, p, jacobian=True)`` with ``x = (u0, v0)``.

    Parameters
    ----------
    family : PeriodicProblem or callable ``p -> PeriodicProblem``
        The system and how to integrate it (period, steps, scheme, integrator options).
    periods : int
        Forcing periods per map application (2 for the map of a period-2 orbit).

    Returns
    -------
    PeriodMap
        Its monodromy matrix is the product of the integrator's step tangents (the exact
        derivative of the discrete map).
    """
    if isinstance(periods, bool) or int(periods) != periods or periods < 1:
        raise InputError(f"periods = {periods!r} is not allowed: give an integer >= 1")
    periods = int(periods)
    last: dict[str, Any] = {}

    def problem_at(p):
        if isinstance(family, PeriodicProblem):
            return family
        if "p" not in last or last["p"] != p:
            prob = family(p)
            if not isinstance(prob, PeriodicProblem):
                raise InputError(f"the family returned {type(prob).__name__}, expected a PeriodicProblem")
            last["p"], last["problem"] = p, _with_step_data(prob)
        return last["problem"]

    def period_map(x, p=None, jacobian=False):
        prob = problem_at(p)
        x = np.asarray(x, float)
        n = x.size // 2
        scheme = GENERIC_SCHEME if prob.scheme is None else prob.scheme
        kw = dict(prob.options)
        kw.setdefault("store", "last")
        if prob.step_data is not None:
            kw["step_data"] = prob.step_data
        if jacobian:
            if scheme.is_newmark:
                kw.update(sensitivity="uv")
            else:
                kw.update(sensitivity="uva", directions=_consistent_directions(prob, x[:n]))
        res = integrate(prob.system, x[:n], x[n:], prob.t0, prob.dt, periods * prob.steps, scheme, **kw)
        xT = np.concatenate([res.u[-1], res.v[-1]])
        Phi = res.monodromy[: 2 * n] if jacobian else None
        return xT, Phi

    return period_map


def modal_period_map(system: ModalSystem, harmonics: "list[Harmonic] | tuple" = (),
                     parametric: "list[Parametric] | tuple" = (), *, period: float | None = None,
                     steps: int = 200, scheme: Scheme | None = None) -> PeriodMap:
    r"""The period map of the modal equations (3.4), with the excitation frequency as parameter.

    ``f = modal_period_map(system, [Harmonic(1.0, [F])])``; ``shoot(f, x0, p=1.1)`` is the
    periodic response of the modes forced at 1.1 rad/s; ``continuation(f, x0, 0.9, 1.4)``
    follows it over the forcing frequency.

    At the parameter :math:`p` every frequency of ``harmonics`` and ``parametric`` is
    multiplied by :math:`p` (``p = 1``: the system as given), and the map advances

    .. math::

        \ddot\eta_r + 2\zeta_r\omega_r\dot\eta_r + \omega_r^2\eta_r + \sum_s\alpha_{rs}\eta_s
        + \sum_{j,s}P^{(j)}_{rs}\cos(p\,\Omega^P_j t + \varphi_j)\,\eta_s
        \\
        - \sum_{s,t}\delta_{rst}\eta_s\eta_t - \sum_{s,t,u}\gamma_{rstu}\eta_s\eta_t\eta_u
        = \sum_j F_{rj}\cos(p\,\Omega_j t + \tau_{rj})

    (:meth:`fivebar.numerics.modal_equations.ModalSystem.acceleration`) over ``period / p``
    with ``steps`` steps of ``scheme``, the state :math:`(\boldsymbol\eta, \dot{\boldsymbol\eta})`
    at :math:`t = 0`.  The numerical counterpart of the multiple-scales solution
    (:mod:`fivebar.numerics.multiscale`) of the same equations: its orbits, their Floquet
    multipliers and their branches (:mod:`fivebar.numerics.continuation`) check the first
    approximation and its stability.

    Parameters
    ----------
    system : ModalSystem
    harmonics, parametric : sequences of Harmonic, Parametric
        The excitation at ``p = 1`` (frequencies in rad/s).
    period : float, optional
        The excitation's period at ``p = 1`` (s); default :math:`2\pi/\Omega_{min}`, the lowest
        non-zero frequency of the excitation (every other must be a whole multiple of it).
    steps : int
        Steps per period (>= 8).
    scheme : Scheme, optional
        Default :data:`fivebar.numerics.schemes.GENERIC_SCHEME`.

    Returns
    -------
    PeriodMap
        ``(x, p, jacobian) -> (x_T, Phi)``, with ``x = (eta, eta_dot)``.
    """
    _check_inputs(system, harmonics, parametric)
    if isinstance(steps, bool) or int(steps) != steps or steps < 8:
        raise InputError(f"steps = {steps!r} is not allowed: give an integer >= 8")
    freqs = [h.frequency for h in harmonics] + [q.frequency for q in parametric]
    nonzero = [f for f in freqs if f > 0]
    if period is None:
        if not nonzero:
            raise InputError("period = None is not allowed without an excitation frequency: give the period (s)")
        period = 2 * math.pi / min(nonzero)
    period = float(period)
    if not (math.isfinite(period) and period > 0):
        raise InputError(f"period = {period!r} is not allowed: give a positive period (s)")
    for f in nonzero:
        k = f * period / (2 * math.pi)
        if abs(k - round(k)) > 1e-9 * max(1.0, k):
            raise InputError(f"period = {period!r} s is not allowed: the excitation frequency {f!r} rad/s "
                             f"is not a whole multiple of 2 pi / period")
    n = system.n_modes
    w, zeta = system.w, system.zeta
    C = np.diag(2 * zeta * w)
    K0 = np.diag(w**2) + system.alpha
    delta, gamma = system.delta, system.gamma
    has_nl = bool(np.any(delta) or np.any(gamma))
    nonlinear = _PolynomialForce(delta, gamma)

    def family(p):
        p = float(p if p is not None else 1.0)
        if not (math.isfinite(p) and p > 0):
            raise InputError(f"p = {p!r} is not allowed: the frequency factor must be positive")

        def K(t):  # K(t), at a time or at an array of times (..., n, n)
            t = np.asarray(t, float)
            return K0 + sum(np.cos(p * q.frequency * t + q.phase)[..., None, None] * q.stiffness for q in parametric)

        def force(t):  # F(t), at a time or at an array of times (..., n)
            t = np.asarray(t, float)
            return sum((h.amplitude * np.cos(p * h.frequency * t[..., None] + h.phase) for h in harmonics),
                       np.zeros(t.shape + (n,)))

        sysm = System(np.eye(n), C, K if parametric else K0, force=force if harmonics else None,
                      nonlinear=nonlinear if has_nl else None)
        # K and F at the S step times at once (the times as PeriodicStepData.from_system takes
        # them): the compiled loop reads them there
        T, S = period / p, int(steps)
        ts = T * np.arange(S) / S
        sd = PeriodicStepData(np.eye(n), C, K(ts) if parametric else K0, force(ts), 0.0, T)
        return PeriodicProblem(sysm, T, S, step_data=sd, scheme=scheme)

    return newmark_map(family)


class _PolynomialForce:
    r"""The restoring force of the modal equations' quadratic and cubic terms,
    :math:`f_r = -\sum\delta_{rst}\eta_s\eta_t - \sum\gamma_{rstu}\eta_s\eta_t\eta_u` (on the
    left of :math:`\ddot{\boldsymbol\eta} + \dots + \mathbf f = \mathbf F`), and its tangent:
    ``u -> (f, K_t)`` in numpy, and the same compiled (:meth:`compiled`, the compiled loop's
    form, ``fivebar.numerics._polynomial_kernel``), so that the period map runs in the compiled
    loop rather than in the Python loop with this callback at every Newton iteration."""

    def __init__(self, delta: Array, gamma: Array) -> None:
        self.delta, self.gamma = delta, gamma
        # the tangent's tensors: d/du_s of delta_rst u_s u_t and of gamma_rstu u_s u_t u_u
        self.dsym = delta + delta.transpose(0, 2, 1)
        self.gsym = gamma + gamma.transpose(0, 2, 1, 3) + gamma.transpose(0, 3, 2, 1)
        self._compiled: tuple | None = None

    def __call__(self, u: Array) -> tuple[Array, Array]:
        f = -(np.einsum("rst,s,t->r", self.delta, u, u) + np.einsum("rstu,s,t,u->r", self.gamma, u, u, u))
        Kt = -(np.einsum("rst,t->rs", self.dsym, u) + np.einsum("rstu,t,u->rs", self.gsym, u, u))
        return f, Kt

    def compiled(self) -> tuple:
        """``(force, rdata, idata)`` for the compiled loop (compiled once, then cached on disk)."""
        if self._compiled is None:
            from ._jitcache import import_cached  # here: numba is heavy

            kern = import_cached(f"{__package__}._polynomial_kernel")
            self._compiled = (kern.polynomial_force,) + kern.pack_polynomial(self.delta, self.gamma, self.dsym,
                                                                             self.gsym)
        return self._compiled


def _with_step_data(prob: PeriodicProblem) -> PeriodicProblem:
    """Sample the per-step matrices of a linear time-varying system (the compiled loop serves it)."""
    if prob.step_data is not None or getattr(prob.system, "nonlinear", None) is not None:
        return prob
    if getattr(prob.system, "time_invariant", False):
        return prob
    sd = PeriodicStepData.from_system(prob.system, prob.t0, prob.period, prob.steps)
    return PeriodicProblem(prob.system, prob.period, prob.steps, prob.t0, sd, prob.scheme, prob.options)


def iterate_map(period_map: PeriodMap, x0: ArrayLike, p: float | None = None,
                periods: int = 1) -> Array:
    """The states after 0, 1, ..., ``periods`` applications of the map: the Poincaré samples
    of a march (shape ``(periods + 1, N)``)."""
    x = np.asarray(x0, float)
    out = [x]
    for _ in range(int(periods)):
        x = period_map(x, p, False)[0]
        out.append(x)
    return np.array(out)


def monodromy(period_map: PeriodMap, x: ArrayLike, p: float | None = None,
              scale: ArrayLike | None = None, step: float = 1e-5) -> tuple[Array, Array]:
    """``(x_T, Phi)``: the map and its monodromy matrix at ``x``; the integrator's tangent where
    the map provides it, else forward differences with steps ``step * scale`` (``scale``
    defaults to ``max(|x_i|, |P_i(x)|, 1e-3 max_j max(|x_j|, |P_j(x)|))`` per component, or 1
    where all vanish)."""
    x = np.asarray(x, float)
    xT, Phi = period_map(x, p, True)
    if Phi is not None:
        return np.asarray(xT, float), np.asarray(Phi, float)
    s = _scale(np.maximum(np.abs(x), np.abs(xT)), scale)
    Phi = np.empty((x.size, x.size))
    for i in range(x.size):
        h = step * s[i]
        e = x.copy()
        e[i] += h
        Phi[:, i] = (period_map(e, p, False)[0] - xT) / h
    return np.asarray(xT, float), Phi


def _scale(x: Array, scale: ArrayLike | None) -> Array:
    if scale is not None:
        s = np.asarray(scale, float)
        if s.shape != x.shape or not np.all(s > 0):
            raise InputError(f"scale has shape {s.shape} or non-positive entries: give ({x.size},) positive values")
        return s
    big = float(np.abs(x).max()) if x.size else 0.0
    return np.maximum(np.abs(x), 1e-3 * big) if big > 0 else np.ones_like(x)


def floquet_multipliers(Phi: ArrayLike) -> NDArray[np.complex128]:
    """Eigenvalues of a monodromy matrix, largest modulus first."""
    mu = np.linalg.eigvals(np.asarray(Phi, float)).astype(complex)
    return mu[np.lexsort((-mu.imag, -np.abs(mu)))]


@dataclass
class PeriodicOrbit:
    """A fixed point of a period map and its Floquet multipliers.

    Attributes
    ----------
    x : ndarray (N,)
        State at the start of the period.
    p : float or None
        Parameter value.
    monodromy : ndarray (N, N)
        Monodromy matrix at ``x``.
    residual : float
        ``||P(x) - x|| / max(||x||, ||P(x)||)`` (scaled norm), the periodicity residual.
    iterations : int
        Newton iterations of :func:`shoot`.
    periods : int
        Map applications spent (finite differences included).
    """

    x: Array
    p: float | None
    monodromy: Array
    residual: float
    iterations: int = 0
    periods: int = 0

    @property
    def multipliers(self) -> NDArray[np.complex128]:
        """Floquet multipliers, largest modulus first."""
        return floquet_multipliers(self.monodromy)

    @property
    def spectral_radius(self) -> float:
        """Largest modulus of the multipliers."""
        return float(np.abs(self.multipliers).max())

    @property
    def stable(self) -> bool:
        """True if every multiplier lies strictly inside the unit circle."""
        return self.spectral_radius < 1.0


#: a period's evaluation for :func:`newton_periodic`: ``(x_T, W, g, a, r, data)``, the state after
#: one period, the monodromy matrix (times the present basis; None when not asked), the residual
#: ``g = x_T - x``, its absolute and relative size, and what the caller keeps of the period
Evaluation = tuple


@dataclass
class PeriodicNewton:
    """What :func:`newton_periodic` ends with.

    Attributes
    ----------
    x : ndarray
        The orbit's state at the start of the period.
    evaluation : tuple
        The last :data:`Evaluation` at ``x`` (its ``W`` may be None).
    W : ndarray
        The last monodromy matrix taken (times the basis): at ``x`` if ``current``.
    current : bool
        ``W`` is the Jacobian at ``x`` (or, for a linear map, anywhere).
    own : bool
        ``W`` was taken on this problem (not the one given to start with).
    residual : float
        The relative residual at ``x``.
    iterations : int
        Newton steps taken.
    evaluations : int
        Periods evaluated (with or without the monodromy matrix).
    floor : bool
        Accepted at the round-off floor of the map (within ``roundoff`` times ``tol``).
    """

    x: Array
    evaluation: Evaluation
    W: Any
    current: bool
    own: bool
    residual: float
    iterations: int
    evaluations: int
    floor: bool = False


#: a residual that no Newton step reduces is accepted when it is within this factor of the tolerance:
#: the round-off floor of the period map (the paper's rule at S = 3200 stopped at 1.006e-10 against
#: 1e-10; the linear model of the flexible orientation at 30 r/min, S = 200, at 1.029e-10 with
#: OpenBLAS's AVX-512 kernels and below 1e-10 with its Haswell ones)
ROUNDOFF = 10.0


class _NoConvergence(ShootingError):
    """:func:`newton_periodic` failed: ``kind`` "no step" (no halved step reduces the residual,
    in ``iteration``) or "max_iter"; ``residual`` the relative residual then."""

    def __init__(self, message: str, kind: str, iteration: int, residual: float) -> None:
        super().__init__(message)
        self.kind, self.iteration, self.residual = kind, iteration, residual


def newton_periodic(evaluate: Callable[[Array, bool], Evaluation], x: ArrayLike, first: Evaluation,
                    factorise: Callable[[Any], Callable[[Array], Array]], *, tol: float, max_iter: int,
                    newton: str = "chord", solve: Callable[[Array], Array] | None = None,
                    given: bool = False, linear: bool = False, roundoff: float = ROUNDOFF,
                    widen: Callable[[], bool] | None = None) -> PeriodicNewton:
    r"""Damped Newton's method on the periodicity condition :math:`\mathbf P(\mathbf x) - \mathbf x = \mathbf 0`:
    the one loop of shooting, which :func:`shoot` (any period map) and the linkage's
    :func:`fivebar.analyses.steady.shooting` (its energy norm and Newton-Picard step) configure.

    ``evaluate(x, jacobian)`` gives one period's :data:`Evaluation` from ``x`` (the monodromy
    matrix times the present basis when ``jacobian``), and raises
    :class:`~fivebar.numerics.newmark.NewtonConvergenceError` where the period cannot be
    integrated; ``first`` is its evaluation at the start ``x``.  ``factorise(W)`` returns the
    step ``g -> y`` towards the orbit (factorised once).  A step whose period fails, or that
    does not reduce the residual's absolute size, is halved, up to 10 times.

    ``newton``: ``"full"`` takes the monodromy matrix at every new iterate (one more period
    with it after each accepted step); ``"chord"`` keeps the factorised Jacobian while the
    residual falls by a factor 10 a step (a linear map's matrix, when ``linear``, does not
    change), takes the next trial's matrix when it falls slower, and takes a fresh one at the
    iterate when a step with a stale one fails.  ``solve`` and ``given``: a step from a
    Jacobian given to start with (not the problem's own).  ``widen()``, called when the residual
    falls slowly with a current Jacobian, may widen the basis of the matrix (Newton-Picard to
    Newton) and then returns True: the Jacobian is then stale.  Where no halved step reduces a
    residual within ``roundoff`` times ``tol``, the iterate is accepted (the round-off floor
    of the map).  Converged when the relative residual is at most ``tol``.

    Raises :class:`ShootingError` (its ``kind``, ``iteration`` and ``residual`` say how).
    """
    if newton not in ("chord", "full"):
        raise InputError(f"newton = {newton!r} is not allowed: give 'chord' or 'full'")
    x = np.asarray(x, float)
    ev = first
    W = ev[1]
    evaluations = 1
    solve = factorise(W) if solve is None else solve
    current = own = not given
    refresh = False  # evaluate the next trial with its monodromy matrix
    floor = False
    r = ev[4]
    for it in range(max_iter + 1):
        if r <= tol or floor:
            return PeriodicNewton(x, ev, W, current, own, r, it, evaluations, floor)
        if it == max_iter:
            break
        a = ev[3]
        y = solve(ev[2])
        lam = 1.0
        for _ in range(11):
            try:
                trial = evaluate(x + lam * y, refresh)
                evaluations += 1
                if np.isfinite(trial[3]) and (trial[3] < a or trial[4] <= tol):
                    break
            except NewtonConvergenceError:
                evaluations += 1
            if not current:  # the Jacobian is stale: take it at x and try the full step again
                W = evaluate(x, True)[1]
                evaluations += 1
                solve, current, own = factorise(W), True, True
                y, lam = solve(ev[2]), 1.0
                continue
            lam *= 0.5
        else:
            if r <= roundoff * tol:  # as periodic as the map's round-off lets it be (residual kept)
                floor = True
                continue
            raise _NoConvergence(
                f"shooting: no step along the Newton direction (halved 10 times) reduces the periodicity "
                f"residual {r:.3e} in iteration {it + 1}", "no step", it + 1, r)
        x = x + lam * y
        if newton == "full":
            fresh = evaluate(x, True)
            evaluations += 1
            W, solve, current, own = fresh[1], factorise(fresh[1]), True, True
            if trial[4] <= tol:  # converged: the matrix at x, the trial's residual
                ev, r = (fresh[0], fresh[1]) + tuple(trial[2:]), trial[4]
                continue
            ev, r = fresh, fresh[4]
            continue
        slow = trial[3] > 0.1 * a
        ev, r = trial, trial[4]
        if trial[1] is not None:
            W, solve, current, own = trial[1], factorise(trial[1]), True, True
        else:
            current = linear and own  # a given matrix is not this orbit's, even if linear
        if slow and current and widen is not None and widen():
            current = own = False
        refresh = slow and not current
    raise _NoConvergence(
        f"shooting did not converge in {max_iter} Newton iterations: periodicity residual {r:.3e} "
        f"(tolerance {tol:.1e})", "max_iter", max_iter, r)


@checked
@one_blas_thread
def shoot(period_map: PeriodMap, x0: ArrayLike, p: float | None = None, tol: float = 1e-10,
          max_iter: int = 30, scale: ArrayLike | None = None) -> PeriodicOrbit:
    r"""Newton's method on :math:`\mathbf P(\mathbf x; p) - \mathbf x = \mathbf 0`.

    Each iteration takes the monodromy matrix at the present ``x`` (:func:`monodromy`) and
    solves :math:`(\boldsymbol\Phi - \mathbf I)\,\delta\mathbf x = -\mathbf G` in the least
    squares sense in the scaled variables ``x / scale`` (singular values below 1e-13 of the
    largest dropped: a multiplier at 1 leaves the orbit undetermined along its eigenvector,
    see :mod:`fivebar.numerics.continuation`); a step that does not reduce the residual is halved, up to
    10 times.  Where no halved step reduces a residual within ``ROUNDOFF`` (10) times ``tol``, the
    iterate is taken as converged (the map's round-off floor, which depends on the BLAS kernels).

    Parameters
    ----------
    period_map : PeriodMap
    x0 : array_like (N,)
        Start.
    p : float, optional
        Parameter passed to the map.
    tol : float
        Converged when the scaled residual ``||G|| / max(||x||, ||P(x)||, tiny)`` is at most
        ``tol`` (the norm of ``x / scale``); ``scale`` defaults to ones.
    max_iter : int
        Newton iterations at most.

    Returns
    -------
    PeriodicOrbit
        With the monodromy matrix at the converged ``x`` (one more map application with the
        tangent when the last Newton step moved ``x``).

    Raises
    ------
    ShootingError
        No convergence in ``max_iter`` iterations, or no halved step reduces the residual.
    """
    if not tol > 0:
        raise InputError(f"tol = {tol!r} is not allowed: give a positive tolerance")
    x = np.array(x0, dtype=float)
    D = np.ones_like(x) if scale is None else _scale(x, scale)
    count = [0]

    def counted(x, p, jacobian):
        count[0] += 1
        return period_map(x, p, jacobian)

    def evaluate(x, jacobian):
        if jacobian:
            xT, Phi = monodromy(counted, x, p, scale)
        else:
            xT, Phi = counted(x, p, False)[0], None
        g = xT - x
        a = float(np.linalg.norm(g / D))
        ref = max(float(np.linalg.norm(x / D)), float(np.linalg.norm(xT / D)), 1e-300)
        return xT, Phi, g, a, a / ref, None

    def factorise(Phi):
        J = (Phi * (1.0 / D)[:, None]) * D[None, :] - np.eye(x.size)  # scaled Phi - I
        return lambda g: D * _lstsq(J, -(g / D))

    try:
        out = newton_periodic(evaluate, x, evaluate(x, True), factorise, tol=tol, max_iter=max_iter, newton="full")
    except _NoConvergence as exc:
        if exc.kind == "no step":
            raise ShootingError(f"{exc} (p = {p!r})") from None
        raise ShootingError(
            f"shooting did not converge in {max_iter} Newton iterations: scaled periodicity residual "
            f"{exc.residual:.3e} (tolerance {tol:.1e}) at p = {p!r}") from None
    return PeriodicOrbit(out.x, p, out.W, out.residual, out.iterations, count[0])


def _lstsq(J: Array, b: Array, rcond: float = 1e-13) -> Array:
    U, s, Vt = np.linalg.svd(J)
    k = int(np.count_nonzero(s > rcond * s[0])) if s.size and s[0] > 0 else 0
    return Vt[:k].T @ ((U[:, :k].T @ b) / s[:k])
