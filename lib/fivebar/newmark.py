r"""Implicit Newmark time integration of time-varying nonlinear structural systems.

This module implements section 4 of the paper, eqs. (4.1)-(4.4), for a generic system

.. math::

    \mathbf M(t)\,\ddot{\mathbf u} + \mathbf C(t)\,\dot{\mathbf u} + \mathbf K(t)\,\mathbf u
    + \mathbf f_{nl}(\mathbf u) = \mathbf F(t),

with ``n`` degrees of freedom and dense matrices.  It knows nothing of the five-bar linkage:
the model supplies ``M, C, K, F`` (and the nonlinear force) through a small protocol
(:class:`SecondOrderSystem`, or the concrete :class:`System`).

**The Newmark rule, (4.2)-(4.3).**  One period ``T`` is divided into ``S`` steps, (4.1)
:math:`T = S\,\Delta t`.  With the paper's parameters :math:`(\varsigma, \vartheta)`, here
``(gamma, beta)``,

.. math::

    \dot{\mathbf u}_{n+1} = \dot{\mathbf u}_n
        + \big((1-\gamma)\ddot{\mathbf u}_n + \gamma\,\ddot{\mathbf u}_{n+1}\big)\Delta t,
        \qquad (4.2)

    \mathbf u_{n+1} = \mathbf u_n + \dot{\mathbf u}_n\Delta t
        + \big((\tfrac12-\beta)\ddot{\mathbf u}_n + \beta\,\ddot{\mathbf u}_{n+1}\big)\Delta t^2
        \qquad (4.3)

(the paper prints :math:`\vartheta\,\mathbf u_{t+\Delta t}` in (4.3); the acceleration
:math:`\vartheta\,\ddot{\mathbf u}_{t+\Delta t}` is meant, errata E21).  The rule is
unconditionally stable for :math:`\gamma \ge \tfrac12`,
:math:`\beta \ge \tfrac14(\gamma+\tfrac12)^2`, the condition printed under (4.3).  The
default is the average-acceleration (trapezoidal) rule :math:`\gamma=\tfrac12,\ \beta=\tfrac14`:
second order, no numerical dissipation.  Section 5 prints
:math:`(\varsigma,\vartheta)=(0.25, 0.5)`, outside that region; it is read as
:math:`(0.5, 0.25)` (errata E2) and the printed pair raises :class:`UnstableParametersError`.

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
matrices are precomputed in a :class:`PeriodicStepData`).

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
:class:`Newmark` is :math:`\alpha_m=\alpha_f=0`; :class:`HHT` (Hilber, Hughes & Taylor 1977)
is :math:`\alpha_m=0,\ \alpha_f=-\alpha`, :math:`\alpha\in[-\tfrac13,0]`,
:math:`\gamma=\tfrac12-\alpha`, :math:`\beta=\tfrac14(1-\alpha)^2`, spectral radius
:math:`(1+\alpha)/(1-\alpha)` at :math:`\omega\Delta t\to\infty`;
:class:`GeneralizedAlpha` takes the spectral radius :math:`\rho_\infty\in[0,1]`:
:math:`\alpha_m=(2\rho_\infty-1)/(\rho_\infty+1)`, :math:`\alpha_f=\rho_\infty/(\rho_\infty+1)`,
:math:`\gamma=\tfrac12-\alpha_m+\alpha_f`, :math:`\beta=\tfrac14(1-\alpha_m+\alpha_f)^2`.
All are second order and unconditionally stable for linear systems.

**State and sensitivity.**  The integrator carries :math:`(\mathbf u,\dot{\mathbf u},
\ddot{\mathbf u})`; the initial acceleration is by default the consistent one, from the
equation of motion at :math:`t_0`.  For :class:`Newmark` the carried acceleration satisfies the
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
(``fivebar._kernels``, numba, cached on disk) and nothing else.  Two loops call them: a compiled
loop, whenever the data allow it (per-step matrices from a :class:`PeriodicStepData`, or a
time-invariant system, with no nonlinear force or one the system supplies compiled,
``system.compiled_nonlinear(step_data)``, as :class:`fivebar.dynamics.LinkageDynamics` does with
the beam's strain force), and a Python loop for a generic system with Python callbacks (a
nonlinear force given as a function, time-varying matrices without step data).  The loops
differ only in where the matrices and the nonlinear force come from; the tests hold them equal
to round-off.  The compiled loop evaluates the nonlinear tangent only when a Newton update
follows (and at the converged state when the sensitivity is asked for).  The first call of a
fresh installation compiles the kernels (tens of seconds); later processes load them from the
cache, which heals (a damaged file is discarded and rebuilt with a warning), is read where it
is read-only, and is temporary (removed at exit) where nothing is writable:
``fivebar._jitcache``.

References: N. M. Newmark, J. Eng. Mech. Div. ASCE 85 (1959) 67-94; H. M. Hilber,
T. J. R. Hughes, R. L. Taylor, Earthquake Eng. Struct. Dyn. 5 (1977) 283-292; J. Chung,
G. M. Hulbert, J. Appl. Mech. 60 (1993) 371-375.
"""

from __future__ import annotations

import contextlib
import inspect
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .cache import STORE
from .errors import ComputationError, FivebarError, InputError, InputTypeError, array, choice, flag, memory, number

try:  # optional: limit BLAS threads inside the time loop (see ``integrate(blas_threads=...)``)
    from threadpoolctl import ThreadpoolController
except ImportError:  # pragma: no cover - the pinned environment has it
    ThreadpoolController = None

__all__ = [
    "GENERIC_SCHEME",
    "GeneralizedAlpha",
    "HHT",
    "MAX_ITER",
    "Newmark",
    "NewmarkResult",
    "NewtonConvergenceError",
    "PeriodicStepData",
    "Scheme",
    "SecondOrderSystem",
    "System",
    "UnstableParametersError",
    "UnstableParametersWarning",
    "amplification_matrix",
    "consistent_acceleration",
    "integrate",
]

Array = NDArray[np.float64]

#: The largest ``max_iter`` (Newton iterations per step) :func:`integrate` accepts: far above
#: what a converging step takes (a few), and a bound on the time a step can spend.
MAX_ITER = 1000


# --- errors -----------------------------------------------------------------------------------
class UnstableParametersError(FivebarError, ValueError):
    """Integration parameters outside the unconditionally stable region."""


class UnstableParametersWarning(RuntimeWarning):
    """Parameters outside the unconditionally stable region were accepted on request."""


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


# --- schemes ----------------------------------------------------------------------------------
class Scheme:
    """Base of the time-stepping schemes: the four generalised-alpha parameters.

    Subclasses define ``gamma``, ``beta``, ``alpha_m`` and ``alpha_f`` (dimensionless).
    """

    gamma: float
    beta: float
    alpha_m: float
    alpha_f: float

    @property
    def rho_infinity(self) -> float:
        """Spectral radius of the one-step map as ``omega dt -> infinity``."""
        raise NotImplementedError

    @property
    def is_newmark(self) -> bool:
        """True if the scheme is plain Newmark (no alpha terms): the state is (u, v)."""
        return self.alpha_m == 0.0 and self.alpha_f == 0.0


@dataclass(frozen=True)
class Newmark(Scheme):
    """Newmark's rule (4.2)-(4.3) with ``(gamma, beta)`` = the paper's (varsigma, vartheta).

    Parameters
    ----------
    gamma, beta : float
        Newmark parameters (dimensionless).  Default 1/2, 1/4: average acceleration
        (trapezoidal rule), the reading of the paper's section 5 (errata E2).
    allow_unstable : bool
        Accept parameters outside the unconditionally stable region ``gamma >= 1/2``,
        ``beta >= (gamma + 1/2)^2 / 4`` with an :class:`UnstableParametersWarning` instead of
        raising :class:`UnstableParametersError`.

    Raises
    ------
    UnstableParametersError
        Parameters outside the stable region (unless ``allow_unstable``), or ``beta <= 0``
        (not an implicit scheme; never allowed), or a non-finite value.
    """

    gamma: float = 0.5
    beta: float = 0.25
    allow_unstable: bool = False
    alpha_m: float = field(default=0.0, init=False)
    alpha_f: float = field(default=0.0, init=False)

    @property
    def rho_infinity(self) -> float:
        """Spectral radius as ``omega dt -> infinity``: roots of ``l^2 - tr l + det``.

        With ``tr = (2 beta - gamma - 1/2) / beta`` and ``det = (1/2 + beta - gamma) / beta``
        (the limit of the undamped one-step map on ``(v, a)``); 1 for the default rule.
        """
        g, b = self.gamma, self.beta
        tr, det = (2 * b - g - 0.5) / b, (0.5 + b - g) / b
        disc = tr * tr - 4 * det
        if disc < 0:
            return math.sqrt(det)
        return max(abs(tr + math.sqrt(disc)), abs(tr - math.sqrt(disc))) / 2

    def __post_init__(self) -> None:
        g = number("gamma", self.gamma, error=UnstableParametersError)
        b = number("beta", self.beta, error=UnstableParametersError)
        object.__setattr__(self, "gamma", g)
        object.__setattr__(self, "beta", b)
        object.__setattr__(self, "allow_unstable", flag("allow_unstable", self.allow_unstable))
        if b <= 0.0:
            raise UnstableParametersError(
                f"Newmark beta={b!r} must be > 0 for the implicit scheme (beta = 0 is the explicit "
                "central-difference rule, not implemented here); the default is beta = 0.25"
            )
        bmin = 0.25 * (g + 0.5) ** 2
        if g < 0.5 or b < bmin * (1.0 - 1e-12):
            msg = (
                f"Newmark parameters gamma={g!r}, beta={b!r} are outside the unconditionally "
                f"stable region gamma >= 0.5 and beta >= (gamma + 0.5)^2 / 4 (= {bmin:.6g} here), "
                "the condition stated under (4.3) of the paper. Note: the paper's section 5 prints "
                "(varsigma, vartheta) = (0.25, 0.5), which is such a case; the book reads it as "
                "(0.5, 0.25), the average-acceleration rule (errata E2). "
            )
            if not self.allow_unstable:
                raise UnstableParametersError(msg + "Pass allow_unstable=True to use them anyway.")
            warnings.warn(msg + "Accepted because allow_unstable=True.", UnstableParametersWarning,
                          stacklevel=3)


#: The scheme of the generic integrator when none is given (``integrate``, the generic
#: periodic-orbit tools of :mod:`fivebar.periodic`): the average-acceleration rule.  The
#: linkage's default is the parameter file's (:func:`fivebar.setup.default_scheme`).
GENERIC_SCHEME: Newmark = Newmark()


@dataclass(frozen=True)
class HHT(Scheme):
    """Hilber-Hughes-Taylor alpha method: Newmark with numerical dissipation.

    Parameters
    ----------
    alpha : float
        In ``[-1/3, 0]`` (dimensionless); 0 is the average-acceleration rule.  Sets
        ``gamma = (1 - 2 alpha) / 2`` and ``beta = (1 - alpha)^2 / 4``; the spectral radius as
        ``omega dt -> infinity`` is ``(1 + alpha) / (1 - alpha)``.
    """

    alpha: float = -0.05

    def __post_init__(self) -> None:
        a = number("alpha", self.alpha, error=UnstableParametersError)
        object.__setattr__(self, "alpha", a)
        if not -1.0 / 3.0 - 1e-15 <= a <= 0.0:
            raise UnstableParametersError(
                f"HHT alpha={a!r} must lie in [-1/3, 0] (the range where the scheme is second "
                "order and unconditionally stable); alpha = 0 is the average-acceleration rule"
            )

    @property
    def rho_infinity(self) -> float:
        """Spectral radius as ``omega dt -> infinity``: ``(1 + alpha) / (1 - alpha)``."""
        return (1.0 + self.alpha) / (1.0 - self.alpha)

    @property
    def gamma(self) -> float:  # type: ignore[override]
        return 0.5 - self.alpha

    @property
    def beta(self) -> float:  # type: ignore[override]
        return 0.25 * (1.0 - self.alpha) ** 2

    @property
    def alpha_m(self) -> float:  # type: ignore[override]
        return 0.0

    @property
    def alpha_f(self) -> float:  # type: ignore[override]
        return -self.alpha


@dataclass(frozen=True)
class GeneralizedAlpha(Scheme):
    """Chung-Hulbert generalised-alpha method with prescribed high-frequency dissipation.

    Parameters
    ----------
    rho_inf : float
        Spectral radius of the one-step map as ``omega dt -> infinity``, in ``[0, 1]``
        (dimensionless); 1 gives no dissipation (the average-acceleration rule's limit),
        0 annihilates the highest modes in one step.
    """

    rho_inf: float = 0.8

    def __post_init__(self) -> None:
        r = number("rho_inf", self.rho_inf, error=UnstableParametersError)
        object.__setattr__(self, "rho_inf", r)
        if not 0.0 <= r <= 1.0:
            raise UnstableParametersError(
                f"generalised-alpha rho_inf={r!r} must lie in [0, 1] (the spectral radius at "
                "omega dt -> infinity; values above 1 are unstable)"
            )

    @property
    def rho_infinity(self) -> float:
        """Spectral radius as ``omega dt -> infinity``: ``rho_inf`` by construction."""
        return float(self.rho_inf)

    @property
    def alpha_m(self) -> float:  # type: ignore[override]
        return (2.0 * self.rho_inf - 1.0) / (self.rho_inf + 1.0)

    @property
    def alpha_f(self) -> float:  # type: ignore[override]
        return self.rho_inf / (self.rho_inf + 1.0)

    @property
    def gamma(self) -> float:  # type: ignore[override]
        return 0.5 - self.alpha_m + self.alpha_f

    @property
    def beta(self) -> float:  # type: ignore[override]
        return 0.25 * (1.0 - self.alpha_m + self.alpha_f) ** 2


def amplification_matrix(scheme: Scheme, omega_dt: float, zeta: float = 0.0) -> Array:
    r"""One-step amplification matrix of a scheme for the free oscillator.

    For :math:`\ddot u + 2\zeta\omega\dot u + \omega^2 u = 0` the scheme maps
    :math:`x_n = (u_n,\ \Delta t\,\dot u_n,\ \Delta t^2\ddot u_n)` to :math:`x_{n+1} = A x_n`.
    Its eigenvalues give the numerical damping and period error (for :class:`Newmark` one
    eigenvalue is 0: the acceleration is slaved to (u, v)).

    Parameters
    ----------
    scheme : Scheme
        The time-stepping scheme.
    omega_dt : float
        :math:`\Omega = \omega\Delta t` (rad), >= 0.
    zeta : float
        Damping ratio (dimensionless), >= 0.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    _check_scheme(scheme)
    W = number("omega_dt", omega_dt, low=0.0)
    zeta = number("zeta", zeta, low=0.0)
    g, b, am, af = scheme.gamma, scheme.beta, scheme.alpha_m, scheme.alpha_f
    c, k = 2.0 * zeta * W, W * W  # scaled damping and stiffness (dt = 1, m = 1)
    # predictors as rows acting on x = (u, v, a) with dt = 1
    P_u = np.array([1.0, 1.0, 0.5 - b])
    P_v = np.array([0.0, 1.0, 1.0 - g])
    # residual: (1-am) a1 + am a0 + (1-af)(c v1 + k u1) + af (c v0 + k u0) = 0,
    # u1 = P_u x + b a1, v1 = P_v x + g a1
    lhs = (1 - am) + (1 - af) * (c * g + k * b)
    rhs = -(am * np.array([0.0, 0.0, 1.0]) + (1 - af) * (c * P_v + k * P_u)
            + af * np.array([k, c, 0.0]))
    a1 = rhs / lhs
    return np.vstack([P_u + b * a1, P_v + g * a1, a1])


def _check_scheme(scheme: Any) -> None:
    if not isinstance(scheme, Scheme):
        raise InputTypeError(
            f"scheme = {scheme!r} ({type(scheme).__name__}) is not allowed: give a Newmark, HHT or "
            "GeneralizedAlpha instance")


# --- systems ----------------------------------------------------------------------------------
def _check_system(system: Any) -> None:
    for name in ("matrices", "force"):
        if not callable(getattr(system, name, None)):
            raise InputTypeError(
                f"system = {system!r} ({type(system).__name__}) is not allowed: give a second-order "
                "system with matrices(t) and force(t) (fivebar.newmark.System, or the linkage's dynamics)")

@runtime_checkable
class SecondOrderSystem(Protocol):
    """What :func:`integrate` needs from a model.

    Required methods: ``matrices(t) -> (M, C, K)``, each ``(n, n)`` (SI units of the model),
    and ``force(t) -> F`` of shape ``(n,)``.  Optional members: ``nonlinear(u, t) -> (f_nl, K_t)``
    (the internal nonlinear force, shape ``(n,)``, and its Jacobian ``d f_nl / d u``,
    ``(n, n)``), absent or ``None`` for a linear system; ``time_invariant: bool`` (True if
    ``M, C, K`` do not depend on ``t``, so one factorisation serves every step);
    ``compiled_nonlinear(step_data) -> (force, rdata, idata)`` or None, the same nonlinear
    force as a compiled function for the compiled loop (``fivebar._kernels.FORCE_SIG``:
    ``force(u, k, rdata, idata, f, Kt, tangent)`` at the state ``u`` and step point ``k`` of
    ``step_data``, its data in the float and integer arrays ``rdata``, ``idata``).
    """

    def matrices(self, t: float) -> tuple[Array, Array, Array]: ...

    def force(self, t: float) -> Array: ...


MatrixSpec = ArrayLike | Callable[[float], ArrayLike]


class System:
    """A concrete :class:`SecondOrderSystem` from arrays or functions of time.

    Parameters
    ----------
    M, C, K : array_like (n, n) or callable ``t -> (n, n)``
        Mass, damping and stiffness (SI).  Arrays are constant in time.
    force : None, array_like (n,) or callable ``t -> (n,)``
        External force ``F(t)``; None is zero.
    nonlinear : None or callable ``(u, t) -> (f_nl, K_t)`` or ``u -> (f_nl, K_t)``
        Internal nonlinear force and its tangent ``d f_nl / d u``; None for a linear system.
    """

    def __init__(
        self,
        M: MatrixSpec,
        C: MatrixSpec,
        K: MatrixSpec,
        force: None | ArrayLike | Callable[[float], ArrayLike] = None,
        nonlinear: None | Callable[[Array], tuple[Array, Array]] = None,
    ) -> None:
        self._mats: list[Any] = []
        n = None
        for name, X in (("M", M), ("C", C), ("K", K)):
            if callable(X):
                self._mats.append(X)
            else:
                A = np.array(array(name, X, shape=(n, n) if n is not None else None))
                if A.ndim != 2 or A.shape[0] != A.shape[1]:
                    raise InputError(f"{name} has shape {A.shape}: expected a square matrix (n, n)")
                n = A.shape[0]
                self._mats.append(A)
        self.time_invariant = not any(callable(X) for X in self._mats)
        if n is None:
            n = np.shape(self._mats[0](0.0))[0]
        self.n = int(n)
        if force is None:
            zero = np.zeros(self.n)
            self._force: Callable[[float], Array] = lambda t: zero
        elif callable(force):
            self._force = lambda t: np.asarray(force(t), dtype=float)
        else:
            F = np.array(array("force", force, shape=(self.n,)))
            self._force = lambda t: F
        if nonlinear is not None and not callable(nonlinear):
            raise InputTypeError(f"nonlinear = {nonlinear!r} is not allowed: give None or a callable "
                                 "(u, t) -> (f_nl, K_t) or u -> (f_nl, K_t)")
        if nonlinear is not None and _positional_arity(nonlinear) == 1:
            self.nonlinear = lambda u, t: nonlinear(u)  # time-independent f_nl(u)
        else:
            self.nonlinear = nonlinear

    def matrices(self, t: float) -> tuple[Array, Array, Array]:
        """``(M, C, K)`` at time ``t`` (s)."""
        out = [X(t) if callable(X) else X for X in self._mats]
        return tuple(np.asarray(X, dtype=float) for X in out)  # type: ignore[return-value]

    def force(self, t: float) -> Array:
        """External force ``F(t)``, shape ``(n,)``."""
        return self._force(t)


def _positional_arity(f: Callable) -> int:
    """Number of positional parameters of a callable (2 if it cannot be inspected)."""
    try:
        params = inspect.signature(f).parameters.values()
    except (TypeError, ValueError):
        return 2
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    if any(p.kind == inspect.Parameter.VAR_POSITIONAL for p in params):
        return 2
    return sum(p.kind in kinds for p in params)


class PeriodicStepData:
    """Matrices and forces of a periodic system at the ``S`` time points of one period.

    Time point ``k`` is ``t0 + k * period / S``; point ``S`` equals point 0 (periodicity).
    :func:`integrate` reads ``M, C, K, F`` from here instead of calling the system, and caches
    the LU factorisation of each step's linear tangent (per scheme and step), so that later
    periods cost only triangular solves.  The factors are this object's, kept in the library's
    store (:mod:`fivebar.cache`, so that its byte bound counts them) for as long as this object
    lives, or until the store lets them go (the next period factorises again).

    Parameters
    ----------
    M, C, K : array_like, shape (S, n, n) or (n, n)
        Per-step matrices (a 2-D array is the same at every step).
    F : array_like, shape (S, n) or (n,)
        Per-step external force.
    t0 : float
        Time of point 0 (s).
    period : float
        Period ``T = S dt`` (s), (4.1).
    """

    def __init__(self, M: ArrayLike, C: ArrayLike, K: ArrayLike, F: ArrayLike, t0: float,
                 period: float) -> None:
        arrs = [array(name, X) for name, X in (("M", M), ("C", C), ("K", K))]
        F = array("F", F)
        S = next((X.shape[0] for X in arrs if X.ndim == 3), F.shape[0] if F.ndim == 2 else None)
        if S is None:
            raise InputError(
                f"M, C, K have shapes {[X.shape for X in arrs]} and F {F.shape}: PeriodicStepData needs "
                "at least one per-step array (shape (S, n, n) or (S, n))")
        n = arrs[0].shape[-1]
        out = []
        for name, X in zip(("M", "C", "K"), arrs):
            if X.shape not in ((n, n), (S, n, n)):
                raise InputError(
                    f"{name} has shape {X.shape}: expected ({S}, {n}, {n}) or ({n}, {n})")
            out.append(np.broadcast_to(X, (S, n, n)))
        if F.shape not in ((n,), (S, n)):
            raise InputError(f"F has shape {F.shape}: expected ({S}, {n}) or ({n},)")
        period = number("period", period, low=0.0, low_open=True, unit="s")
        t0 = number("t0", t0, unit="s")
        self.M, self.C, self.K = out
        #: True if M is the same at every step (a 2-D array was given)
        self.M_constant = arrs[0].ndim == 2
        self.F = np.broadcast_to(F, (S, n))
        self.t0, self.period, self.steps, self.n = float(t0), float(period), int(S), int(n)
        self.dt = self.period / self.steps
        self._kernel_arrays: tuple[Array, Array, Array, Array] | None = None

    @classmethod
    def from_system(cls, system: SecondOrderSystem, t0: float, period: float,
                    steps: int) -> PeriodicStepData:
        """Sample ``system.matrices`` and ``system.force`` at ``t0 + k period/steps``, k < steps."""
        steps = number("steps", steps, integer=True, low=1)
        ts = t0 + period * np.arange(steps) / steps
        mats = [system.matrices(float(t)) for t in ts]
        return cls(
            np.array([m[0] for m in mats]), np.array([m[1] for m in mats]),
            np.array([m[2] for m in mats]),
            np.array([system.force(float(t)) for t in ts]), t0, period,
        )

    def kernel_arrays(self) -> tuple[Array, Array, Array, Array]:
        """``M, C, K, F`` as contiguous arrays for the time loop; an array that is the same at
        every step is given once (leading dimension 1)."""
        if self._kernel_arrays is None:
            self._kernel_arrays = tuple(
                np.ascontiguousarray(X[:1] if X.strides[0] == 0 else X, dtype=float)
                for X in (self.M, self.C, self.K, self.F))
        return self._kernel_arrays

    def lu_cache(self, key: tuple[float, float, float, float]) -> tuple[Any, Any, Any]:
        """The per-step LU cache of the linear tangent, ``(LU, piv, filled)``, for ``key =
        (cM, cC, cK, alpha_f)``: the factors of ``cM Mb + cC C_k + cK K_k`` with ``Mb = (1 -
        alpha_f) M_k + alpha_f M_{k-1}`` (``alpha_f`` 0 when M is constant) at each step point
        ``k``, filled lazily by the time loop (either loop: one cache).  Kept in the library's
        store with this object as its owner."""
        slot = ("newmark.lu", id(self))
        factors = STORE.lookup(slot)  # (an entry of an object gone is forgotten before this)
        if factors is None or key not in factors:
            factors = dict(factors or {})
            factors[key] = _new_lu_cache(self.steps, self.n)
            STORE.put(slot, factors, owner=self)
        return factors[key]

    def _lu_factors(self) -> dict[tuple[float, float, float, float], tuple[Any, Any, Any]]:
        """The LU caches of :meth:`lu_cache` held now, by key (empty when the store has let
        them go)."""
        return dict(STORE.lookup(("newmark.lu", id(self)), None, touch=False) or {})


_CONTROLLER: Any = None


def _blas_threads(k: int | None) -> contextlib.AbstractContextManager[Any]:
    """Context limiting the BLAS thread pools to ``k`` threads (no-op if None or unavailable)."""
    global _CONTROLLER
    if k is None or ThreadpoolController is None:
        return contextlib.nullcontext()
    if _CONTROLLER is None:
        # the controller sees only the BLAS libraries loaded when it is made: load scipy's
        # (used by the LAPACK calls of the Python loop and the BLAS calls of the compiled one)
        import scipy.linalg.cython_blas  # noqa: F401

        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=int(k), user_api="blas")


def consistent_acceleration(system: SecondOrderSystem, t: float, u: ArrayLike,
                            v: ArrayLike) -> Array:
    """Acceleration from the equation of motion: ``M(t) a = F(t) - C v - K u - f_nl(u)``.

    Parameters
    ----------
    system : SecondOrderSystem
    t : float
        Time (s).
    u, v : array_like (n,)
        Displacement and velocity (model units, SI).

    Returns
    -------
    ndarray (n,)
        Acceleration.
    """
    _check_system(system)
    t = number("t", t, unit="s")
    u = array("u", u)
    n = u.size
    u, v = u.ravel(), array("v", v, shape=(n,))
    M, C, K = (_checked(f"system: {name}(t = {t:.9g} s)", X, (n, n))
               for name, X in zip("MCK", system.matrices(t)))
    rhs = _checked(f"system: F(t = {t:.9g} s)", system.force(t), (n,)) - C @ v - K @ u
    nl = getattr(system, "nonlinear", None)
    if nl is not None:
        rhs = rhs - _nonlinear_at(nl, u, t, n)[0]
    try:
        return np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError as exc:
        raise ComputationError(
            f"the mass matrix at t = {t:.9g} s is singular; pass a0 explicitly") from exc


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
        res = integrate(system, u0, v0, t0, dt, n, GeneralizedAlpha(0.8))    # dissipative

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
        :class:`Newmark` (default: gamma = 1/2, beta = 1/4), :class:`HHT` or
        :class:`GeneralizedAlpha`.
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
        monodromy of the discrete map for :class:`Newmark`.  "uva": ``d(u_N, v_N, a_N) /
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
    with _blas_threads(blas_threads):
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

    # the LU cache of the linear tangent: per step point of the step data, else one slot
    M_const = time_invariant or (sd is not None and sd.M_constant)
    key = (float(c[kern.CM]), float(c[kern.CC]), float(c[kern.CK]),
           0.0 if M_const else float(scheme.alpha_f))
    cache = sd.lu_cache(key) if sd is not None else _new_lu_cache(1, n)
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


def _checked(name: str, value: ArrayLike, shape: tuple[int, ...]) -> Array:
    """A matrix or vector of the system as a contiguous float array of the expected shape."""
    X = np.ascontiguousarray(value, dtype=float)
    if X.shape != shape:
        raise InputError(f"{name} has shape {X.shape}: expected {shape} for u0 of {shape[0]} DOFs")
    return X


def _nonlinear_at(nl: Callable, u: Array, t: float, n: int) -> tuple[Array, Array]:
    """``system.nonlinear(u, t)`` checked: the force (n,) and its tangent (n, n)."""
    f, Kt = nl(u.copy(), t)
    return (_checked(f"system: nonlinear force at t = {t:.9g} s", f, (n,)),
            _checked(f"system: nonlinear tangent at t = {t:.9g} s", Kt, (n, n)))


def _march_python(kern, c, x, P, data, nl, t0, nsteps, k0, M_const, refactor, Kt0, cache, tol,
                  max_iter, full, X, iters) -> None:
    """The time loop in Python, for systems the compiled loop cannot serve (Python callbacks
    of a generic :class:`SecondOrderSystem`, time-varying systems without step data): the
    step is the compiled loop's, its pieces (``fivebar._kernels``) called from here, with the
    system's matrices and nonlinear force from its callbacks.  Arguments as
    ``fivebar._kernels.march`` takes them; ``refactor``: factorise the linear tangent anew
    every step (time-varying matrices)."""
    n = x.shape[1]
    linear = nl is None
    w = np.zeros((kern.NWORK, n))
    fnl, Kt, Ktp = np.zeros(n), np.zeros((n, n)), np.array(Kt0)
    St, piv, Mbw = np.empty((n, n)), np.empty(n, np.int64), np.empty((n, n))
    sens = P.shape[2] > 0
    PW = np.empty((6, n, P.shape[2]))
    store = X.shape[1] == nsteps + 1
    LUc, pivc, have = cache
    info = np.zeros(7)
    u1 = w[kern.U1]
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
        kern.predict(c, Mb, x, w)
        li = (k0 + j) % LUc.shape[0]
        if refactor:
            have[li] = 0
        if linear:
            ok, dmin, dmax = kern.linear_step(c, Mb, C, K, F, fnl, x, w, LUc, pivc, have, li)
            if not ok:
                raise fail(kern.SINGULAR, j, t, dmin=dmin, dmax=dmax)
            LU, LP = LUc[li], pivc[li]
        else:
            k_it = 0
            du_norm = math.inf
            while True:
                fnl[:], Kt[:] = _nonlinear_at(nl, u1, t, n)
                rn, ref = kern.residual(c, Mb, C, K, F, fnl, w, True)
                if not math.isfinite(rn):
                    raise fail(kern.NOT_FINITE, j, t, rn=rn, k_it=k_it)
                if kern.converged(rn, ref, du_norm, w, tol):
                    break
                if k_it >= max_iter:
                    raise fail(kern.NO_CONVERGENCE, j, t, rn=rn, k_it=k_it, ref=ref)
                if full:
                    ok, dmin, dmax = kern.tangent_lu(c, Mb, C, K, Kt, True, St, piv)
                    if not ok:
                        raise fail(kern.SINGULAR, j, t, dmin=dmin, dmax=dmax)
                    du_norm = kern.correct(St, piv, w)
                else:
                    ok, dmin, dmax = kern.linear_lu(c, Mb, C, K, LUc, pivc, have, li)
                    if not ok:
                        raise fail(kern.SINGULAR, j, t, dmin=dmin, dmax=dmax)
                    du_norm = kern.correct(LUc[li], pivc[li], w)
                k_it += 1
            iters[j - 1] = k_it
            if sens:  # the consistent tangent at the converged u_{n+1} (Kt evaluated there)
                ok, dmin, dmax = kern.tangent_lu(c, Mb, C, K, Kt, True, St, piv)
                if not ok:
                    raise fail(kern.SINGULAR, j, t, dmin=dmin, dmax=dmax)
            LU, LP = St, piv
        if sens:
            kern.sensitivity(c, LU, LP, Mb, C, Kp, Cp, Kt, Ktp, not linear, P, PW)
        kern.finish(c, C, K, F, fnl, x, w)
        if store:
            X[:, j] = x[:3]
        Mp, Cp, Kp = M, C, K


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
    """The compiled step and loop (``fivebar._kernels``), imported on first use (numba is
    heavy) with the healing disk cache of :mod:`fivebar._jitcache`."""
    global _KERNELS
    if _KERNELS is None:
        from ._jitcache import import_cached

        _KERNELS = import_cached(f"{__package__}._kernels")
    return _KERNELS


def _new_lu_cache(S: int, n: int) -> tuple[Array, NDArray[np.int64], NDArray[np.uint8]]:
    return np.zeros((S, n, n)), np.zeros((S, n), dtype=np.int64), np.zeros(S, dtype=np.uint8)
