r"""The periodic-orbit engine: a set-up turned into a periodic problem, and its methods by name.

Every caller that needs the linkage's periodic orbit goes through here:
:func:`fivebar.analyses.branches.steady_state` (one set-up), :func:`~fivebar.analyses.branches.follow`
(the continuation of a branch in a parameter), :func:`~fivebar.analyses.branches.brute_force_diagram`
(long marches, the parameter stepped) and :func:`~fivebar.analyses.branches.explain_steady` /
:func:`~fivebar.analyses.branches.describe_speed` (what the linkage does where its orbit is
unstable).  Each asks :func:`orbit_method` for a method of :data:`ORBIT_METHODS` by name, for
what it needs:

* the steady state of one set-up, ``method.steady(setup, tol, warm start)`` (every method);
* the problem's period map in a parameter, ``method.period_map(setup, parameter)``
  (:class:`LinkagePeriodMap`: the Newmark period map with its monodromy matrix), which the
  continuation, the explanation and the brute-force marches iterate.

A method that cannot serve a caller (a march has no monodromy matrix to continue with;
harmonic balance has no period map) is refused there with an error naming it and the methods
that can.  A new method of periodic steady state is one module and one :class:`OrbitMethod`
entry in :data:`ORBIT_METHODS` (:func:`register`).

The problem in a parameter: ``parameter`` is ``"crank_speed_rpm"`` (the set-up's speed) or a
numeric key of the parameter file; :func:`problem_at` is the set-up at a value of it.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from ..description.params import Params
from ..description.setup import Setup, analysis, as_setup
from ..errors import FivebarError, InputError
from ..model.dynamics import linkage_dynamics
from .harmonic_balance import harmonic_balance_steady_state
from .steady import SteadyState, _monodromy_period, _period, _to_tolerance, march, shooting

__all__ = ["CALLERS", "LinkagePeriodMap", "ORBIT_METHODS", "OrbitMethod", "OrbitProblem", "linkage_period_map",
           "orbit_method", "problem_at", "register"]

Array = NDArray[np.float64]

_SPEED = "crank_speed_rpm"


def problem_at(setup: Setup, parameter: str, value: float) -> Setup:
    """The set-up at ``value`` of ``parameter`` (the crank speed, or a key of the parameter file)."""
    if parameter == _SPEED:
        return setup.replace(crank_speed_rpm=float(value))
    return setup.replace(params=setup.params.replace(**{parameter: float(value)}))


def _given(setup: Setup, parameter: str, name: str, value: float) -> float:
    """``value`` of ``parameter``, given by the user as the argument ``name`` (``p_end``,
    ``p0``, ``value``): refused there, naming that argument, if the set-up cannot take it."""
    try:
        problem_at(setup, parameter, value)
    except FivebarError as exc:
        raise InputError(f"{name} = {value!r} is not allowed as a value of {parameter}: {exc}") from None
    return value


def _check_parameter(setup: Setup, parameter: str) -> float:
    """The parameter's present value; a clear error if it is not a numeric entry."""
    if not isinstance(parameter, str):
        raise InputError(f"parameter = {parameter!r} is not allowed: give 'crank_speed_rpm' or a parameter-file key")
    if parameter == _SPEED:
        return float(setup.crank_speed_rpm)
    from ..description.params import _is_open, _resolve_key

    try:  # as Params.replace reads it: a dotted key, or a bare name unique in the set
        key = _resolve_key(parameter, setup.params.values)
    except FivebarError as exc:
        raise InputError(f"parameter = {parameter!r} is not allowed: {exc}") from exc
    if key not in setup.params.values:
        raise InputError(f"parameter = {parameter!r} is not allowed: the parameter set has no entry {key}")
    if _is_open(key) and key not in setup.params.references:
        raise InputError(f"parameter = {parameter!r} is not allowed: the linkage {setup.params.linkage.name!r} "
                         f"does not use {key}, so the motion would not change with it")
    value = setup.params.values[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"parameter = {parameter!r} is not allowed: its value {value!r} is not a number")
    if parameter in ("crank_speed_rpm", "assumptions.crank_speed_rpm"):
        raise InputError("give the crank speed as parameter = 'crank_speed_rpm' (the set-up's field)")
    return float(value)


class LinkagePeriodMap:
    """The linkage's period map in a parameter (a :class:`fivebar.numerics.periodic.PeriodMap`); made by
    :func:`linkage_period_map`.

    Calling it, ``f(x, p, jacobian)``, integrates one period of the set-up at parameter value
    ``p`` from the state ``x = (u, du/dtheta)`` at crank angle 0.  Besides: ``f.dynamics(p)``
    (the set-up and its :class:`~fivebar.model.dynamics.LinkageDynamics` at ``p``, the last four
    kept), ``f.state(steady)`` (the state of a :class:`~fivebar.analyses.steady.SteadyState`),
    ``f.steady(x, p)`` (one stored period from ``x``, a ``SteadyState``).
    """

    periods = 1
    #: calls at two values may run at once in two threads (the compiled period releases the
    #: GIL; the dynamics at each value are the map's own): the continuation's forward
    #: difference in the parameter runs beside the monodromy period
    concurrent = True

    def __init__(self, setup: Setup, parameter: str) -> None:
        self.setup, self.parameter = setup, parameter
        self._dyn: dict[float, Any] = {}
        self._lock = threading.Lock()

    def dynamics(self, p: float):
        """The set-up's dynamics at ``p`` (the last four kept here, not in the library's store:
        the store's if it has them, else built)."""
        p = float(p)
        with self._lock:
            hit = self._dyn.get(p)
        if hit is None:  # built outside the lock: another thread's value goes on meanwhile
            try:
                s = problem_at(self.setup, self.parameter, p)
            except FivebarError as exc:  # a value the map was asked for, not one the user gave
                raise InputError(f"the period map in {self.parameter} cannot be evaluated at {p!r} (a value "
                                 f"between those given, reached by the computation): {exc}") from None
            hit = (s, linkage_dynamics(s, keep=False))
            with self._lock:
                while len(self._dyn) >= 4:
                    self._dyn.pop(next(iter(self._dyn)))
                self._dyn[p] = hit
        return hit

    def __call__(self, x, p=None, jacobian=False):
        s, dyn = self.dynamics(self.setup_value() if p is None else p)
        n = dyn.n
        W = dyn.params.crank_speed_rad_s
        x = np.asarray(x, float)
        u0, v0 = x[:n], W * x[n:]
        if jacobian:
            res, Phi = _monodromy_period(dyn, np.r_[u0, v0], s.scheme, store="last")
            Phi = np.array(Phi)
            Phi[n:, :] /= W
            Phi[:, n:] *= W
        else:
            res, Phi = _period(dyn, u0, v0, s.scheme, store="last"), None
        return np.r_[res.u[-1], res.v[-1] / W], Phi

    def setup_value(self) -> float:
        return _check_parameter(self.setup, self.parameter)

    def __getstate__(self) -> dict:  # a lock is not pickled (a process pool's worker gets a new one)
        return {k: v for k, v in self.__dict__.items() if k != "_lock"}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def state(self, st: SteadyState) -> Array:
        """The map's state of a steady period (at crank angle 0)."""
        return np.r_[st.u[0], st.v[0] / st.dynamics.params.crank_speed_rad_s]

    def steady(self, x: Array, p: float) -> SteadyState:
        """One stored period from the state ``x`` at ``p`` (a :class:`SteadyState`)."""
        s, dyn = self.dynamics(p)
        n = dyn.n
        res = _period(dyn, x[:n], dyn.params.crank_speed_rad_s * x[n:], s.scheme)
        return SteadyState(dyn, res.t, res.u, res.v, "continuation", 1, scheme=s.scheme)


@analysis
def linkage_period_map(setup: Setup | Params, parameter: str = _SPEED) -> LinkagePeriodMap:
    """The linkage's period map in ``parameter`` (a :class:`fivebar.numerics.periodic.PeriodMap`).

    ``f = linkage_period_map(fivebar.Setup(params, motors=False))``;
    ``x_T, Phi = f(x, 120.0, True)`` at 120 r/min, ``x = (u, du/dtheta)`` at crank angle 0
    (metres, metres per radian), ``Phi`` the monodromy matrix in that state.

    Parameters
    ----------
    setup
        The set-up (its S, scheme, mesh, motors, nonlinearity are used at every value).
    parameter
        ``"crank_speed_rpm"`` (the set-up's speed) or a numeric key of the parameter file
        (``"bending_depth"``, ``"motor1.m0"`` ...: see :meth:`fivebar.description.params.Params.replace`).
    """
    s = as_setup(setup)
    _check_parameter(s, parameter)
    return LinkagePeriodMap(s, parameter)


#: What each caller of the engine needs of a method (the names :func:`orbit_method` checks).
CALLERS = {
    "steady_state": "the steady state of one set-up",
    "follow": "the continuation of a branch (a period map with its monodromy matrix)",
    "brute_force": "long marches of the period map, one Poincare sample per period",
    "explain": "shooting on the period map (Floquet multipliers) and a march from the orbit",
}


@dataclass(frozen=True)
class OrbitMethod:
    """A method of the periodic-orbit engine (an entry of :data:`ORBIT_METHODS`).

    Attributes
    ----------
    name : str
        The name callers give (``method=``).
    steady : callable
        ``steady(setup, tol, memo) -> SteadyState``: the periodic steady state of one set-up
        (``tol`` None: at the set-up's S; ``memo`` the warm start of ``steady_state(...,
        start=)``, checked, or None).
    period_map : callable or None
        ``period_map(setup, parameter)``: the set-up's period map in ``parameter`` (a
        :class:`fivebar.numerics.periodic.PeriodMap`, as :class:`LinkagePeriodMap`); None if the
        method has none.
    serves : frozenset of str
        The callers (keys of :data:`CALLERS`) it serves.
    """

    name: str
    steady: Callable[[Setup, float | None, dict | None], SteadyState]
    period_map: Callable[[Setup, str], Any] | None = None
    serves: frozenset = frozenset({"steady_state"})

    def __post_init__(self) -> None:
        unknown = set(self.serves) - set(CALLERS)
        if unknown:
            raise InputError(f"serves = {sorted(unknown)!r} is not allowed: give callers of {sorted(CALLERS)}")
        if set(self.serves) - {"steady_state"} and self.period_map is None:
            raise InputError(f"the method {self.name!r} serves {sorted(self.serves)} but has no period_map")


#: The methods of the engine, by name.  ``steady_state``, ``follow``, ``brute_force_diagram`` and
#: the explanations take theirs from here (:func:`orbit_method`).
#:
#: :meta hide-value:
ORBIT_METHODS: dict[str, OrbitMethod] = {}


def register(method: OrbitMethod) -> OrbitMethod:
    """Add ``method`` to :data:`ORBIT_METHODS` (a new name; an existing one is refused)."""
    if not isinstance(method, OrbitMethod):
        raise InputError(f"method = {method!r} is not allowed: give an OrbitMethod")
    if method.name in ORBIT_METHODS:
        raise InputError(f"a method named {method.name!r} is registered already")
    ORBIT_METHODS[method.name] = method
    return method


def orbit_method(name: str, caller: str) -> OrbitMethod:
    """The method ``name`` of :data:`ORBIT_METHODS` for ``caller`` (a key of :data:`CALLERS`);
    a clear error naming the method and the methods allowed there if it is unknown or cannot
    serve that caller."""
    allowed = [m for m, entry in ORBIT_METHODS.items() if caller in entry.serves]
    names = ", ".join(repr(m) for m in allowed)
    if not isinstance(name, str) or name not in ORBIT_METHODS:
        raise InputError(f"method = {name!r} is not allowed: use one of {names}")
    if caller not in ORBIT_METHODS[name].serves:
        raise InputError(f"method = {name!r} is not allowed for {caller} ({CALLERS[caller]}): use one of {names}")
    return ORBIT_METHODS[name]


def _time_domain(solve, method: str):
    """A steady state in the time domain: at the set-up's S, or with ``tol`` at S = 50, 100,
    200, ... until two successive S agree (:func:`fivebar.analyses.steady._to_tolerance`)."""

    def run(s: Setup, tol: float | None, memo: dict | None) -> SteadyState:
        return solve(s) if tol is None else _to_tolerance(s, method, tol, memo)
    return run


def _by_harmonic_balance(s: Setup, tol: float | None, memo: dict | None) -> SteadyState:
    return harmonic_balance_steady_state(s, tol)  # (a warm start is refused before: shooting only)


register(OrbitMethod("shooting", _time_domain(shooting, "shooting"), LinkagePeriodMap,
                     frozenset({"steady_state", "follow", "explain"})))
register(OrbitMethod("march", _time_domain(march, "march"), LinkagePeriodMap,
                     frozenset({"steady_state", "brute_force"})))
register(OrbitMethod("harmonic_balance", _by_harmonic_balance))


class OrbitProblem:
    """A set-up turned into a periodic problem in a parameter: what every caller of the engine
    holds, and asks of a method by name.

    ``prob = OrbitProblem(setup, "crank_speed_rpm")``; ``prob.value`` (the set-up's value of the
    parameter), ``prob.at(p)`` (the set-up at ``p``), ``prob.steady("shooting", "follow", p)``
    (the steady state there), ``prob.period_map("march", "brute_force")`` (the period map the
    method iterates).  A method that cannot serve the caller is refused (:func:`orbit_method`).
    """

    def __init__(self, setup: Setup | Params, parameter: str = _SPEED) -> None:
        self.setup = as_setup(setup)
        self.parameter = parameter
        self.value = _check_parameter(self.setup, parameter)

    def at(self, p: float | None = None) -> Setup:
        """The set-up at ``p`` (None: the set-up itself)."""
        return self.setup if p is None else problem_at(self.setup, self.parameter, p)

    def given(self, name: str, value: float) -> float:
        """``value`` of the parameter given as the argument ``name``: refused, naming it, if the
        set-up cannot take it."""
        return _given(self.setup, self.parameter, name, value)

    def steady(self, method: str, caller: str, p: float | None = None, tol: float | None = None,
               memo: dict | None = None) -> SteadyState:
        """The steady state at ``p`` by ``method`` (checked for ``caller``)."""
        return orbit_method(method, caller).steady(self.at(p), tol, memo)

    def period_map(self, method: str, caller: str):
        """The period map of ``method`` (checked for ``caller``) in the parameter."""
        return orbit_method(method, caller).period_map(self.setup, self.parameter)
