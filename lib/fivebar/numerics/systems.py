r"""Second-order systems for the time integrator: the protocol, a concrete system, step data.

What :func:`fivebar.numerics.newmark.integrate` marches is a generic system

.. math::

    \mathbf M(t)\,\ddot{\mathbf u} + \mathbf C(t)\,\dot{\mathbf u} + \mathbf K(t)\,\mathbf u
    + \mathbf f_{nl}(\mathbf u) = \mathbf F(t),

with ``n`` degrees of freedom and dense matrices.  A model supplies ``M, C, K, F`` (and the
nonlinear force) through a small protocol, :class:`SecondOrderSystem` (the linkage's
:class:`fivebar.model.dynamics.LinkageDynamics` is one); :class:`System` builds one from arrays or
functions of time.  A periodic system can give its matrices at the ``S`` time points of one
period at once, :class:`PeriodicStepData`, which also holds the LU factors of each step's
linear tangent, so that later periods cost only triangular solves.
:func:`consistent_acceleration` solves the equation of motion for the acceleration.  This
module knows nothing of the linkage nor of the schemes.
"""

from __future__ import annotations

import copy
import inspect
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..cache import STORE
from ..errors import ComputationError, InputError, InputTypeError, array, number

__all__ = [
    "PeriodicStepData",
    "SecondOrderSystem",
    "System",
    "consistent_acceleration",
]

Array = NDArray[np.float64]


def _check_system(system: Any) -> None:
    for name in ("matrices", "force"):
        if not callable(getattr(system, name, None)):
            raise InputTypeError(
                f"system = {system!r} ({type(system).__name__}) is not allowed: give a second-order "
                "system with matrices(t) and force(t) (fivebar.numerics.systems.System, or the linkage's dynamics)")

@runtime_checkable
class SecondOrderSystem(Protocol):
    """What :func:`fivebar.numerics.newmark.integrate` needs from a model.

    Required methods: ``matrices(t) -> (M, C, K)``, each ``(n, n)`` (SI units of the model),
    and ``force(t) -> F`` of shape ``(n,)``.  Optional members: ``nonlinear(u, t) -> (f_nl, K_t)``
    (the internal nonlinear force, shape ``(n,)``, and its Jacobian ``d f_nl / d u``,
    ``(n, n)``), absent or ``None`` for a linear system; ``time_invariant: bool`` (True if
    ``M, C, K`` do not depend on ``t``, so one factorisation serves every step);
    ``compiled_nonlinear(step_data) -> (force, rdata, idata)`` or None, the same nonlinear
    force as a compiled function for the compiled loop (``fivebar.numerics._kernels.FORCE_SIG``:
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
        A callable that also has a method ``compiled() -> (force, rdata, idata)``, the same
        force (independent of t) as the compiled loop takes it, is marched there when the
        step data are given (:meth:`compiled_nonlinear`): the modal equations' polynomial force
        of :func:`fivebar.numerics.periodic.modal_period_map` is one.
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
        self._nonlinear_given = nonlinear

    def compiled_nonlinear(self, step_data: PeriodicStepData | None = None) -> tuple | None:
        """The nonlinear force as the compiled loop takes it (``(force, rdata, idata)``, the
        optional member of :class:`SecondOrderSystem`) where the ``nonlinear`` callable given
        provides it (a method ``compiled()``), else None: the Python loop calls ``nonlinear``."""
        get = getattr(self._nonlinear_given, "compiled", None)
        return get() if callable(get) else None

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
    :func:`fivebar.numerics.newmark.integrate` reads ``M, C, K, F`` from here instead of calling the
    system, and caches the LU factorisation of each step's linear tangent (per scheme and
    step), so that later periods cost only triangular solves.  The factors are this object's,
    kept in the library's store (:mod:`fivebar.cache`, so that its byte bound counts them) for
    as long as this object lives, or until the store lets them go (the next period factorises
    again).

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
        self.M, self.C, self.K = out
        #: True if M is the same at every step (a 2-D array was given)
        self.M_constant = arrs[0].ndim == 2
        self.steps, self.n = int(S), int(n)
        self._set_time(F, t0, period)

    def _set_time(self, F: Array, t0: float, period: float) -> None:
        """Set the force ``F`` (an array checked by :func:`~fivebar.errors.array`; its shape
        checked here) and the time points: what :meth:`with_force` changes."""
        S, n = self.steps, self.n
        if F.shape not in ((n,), (S, n)):
            raise InputError(f"F has shape {F.shape}: expected ({S}, {n}) or ({n},)")
        period = number("period", period, low=0.0, low_open=True, unit="s")
        t0 = number("t0", t0, unit="s")
        self.F = np.broadcast_to(F, (S, n))
        self.t0, self.period = float(t0), float(period)
        self.dt = self.period / self.steps
        self._kernel_arrays: tuple[Array, Array, Array, Array] | None = None

    def with_force(self, F: ArrayLike, period: float) -> PeriodicStepData:
        """The same ``M, C, K`` (shared, not checked again) with the force ``F`` and the
        period ``period`` (the same step points on another time scale: the linkage at another
        crank speed), ``F`` and ``period`` checked as the constructor checks them.  A new
        object, with LU caches of its own (its time step differs)."""
        new = copy.copy(self)
        new._set_time(array("F", F), self.t0, period)
        return new

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


def _new_lu_cache(S: int, n: int) -> tuple[Array, NDArray[np.int64], NDArray[np.uint8]]:
    return np.zeros((S, n, n)), np.zeros((S, n), dtype=np.int64), np.zeros(S, dtype=np.uint8)
