"""One linkage set-up: parameters, crank speed, S, motors, nonlinearity, mesh and scheme.

The problem object.  Every analysis of the linkage (:func:`fivebar.analyses.branches.steady_state`,
:func:`fivebar.analyses.sweep.speed_sweep`, the resonance tables, the multiple scales, the control
simulation, the continuation) takes a :class:`Setup` or a :class:`~fivebar.description.params.Params`
(meaning ``Setup(params)``; :func:`as_setup` turns it into one) and only options of its own: a
field of the set-up given to an analysis as a keyword is refused (:func:`analysis`), so each
default lives once.  A field left ``None`` takes the parameter file's entry
(``Setup(params).steps_per_period == params.steps_per_period``), and the time integrator is
built from the file's ``[simulation] scheme`` and ``rho_infinity`` (errata E26).
:class:`~fivebar.model.dynamics.LinkageDynamics` samples a set-up's equation of motion
(:func:`~fivebar.model.dynamics.linkage_dynamics`, built once).

>>> s = Setup(load_params(), crank_speed_rpm=300)
>>> steady_state(s.replace(steps_per_period=1600))
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
import math
from fractions import Fraction
from typing import Any

from ..errors import InputError, InputTypeError, checker, flag, memory, number
from ..numerics.schemes import GeneralizedAlpha, Newmark, Scheme
from .params import RATIO_DENOMINATOR, Params, _ratio_fraction

__all__ = ["PAPER_SCHEME", "SETUP_FIELDS", "Setup", "analysis", "as_setup", "default_scheme", "drive_period", "fourier_harmonics",
           "min_steps_per_period",
           "scheme_name"]

#: The paper's rule (section 5, read as gamma = 1/2, beta = 1/4: errata E2): the
#: average-acceleration Newmark method.  At S = 100 its periodic orbit of the linkage is
#: numerically unstable (errata E26); the chapters use it by this name where they reproduce
#: the paper or show E26.
PAPER_SCHEME: Newmark = Newmark(gamma=0.5, beta=0.25)


def default_scheme(params: Params) -> Scheme:
    """The time integrator the parameter file chooses (``[simulation] scheme``)."""
    if params.scheme == "newmark":
        return PAPER_SCHEME
    return GeneralizedAlpha(params.rho_infinity)


def scheme_name(scheme: Scheme) -> str:
    """A short name of a scheme for messages: "the paper's average-acceleration rule", ..."""
    if isinstance(scheme, Newmark):
        if scheme.gamma == 0.5 and scheme.beta == 0.25:
            return "the paper's average-acceleration rule (Newmark gamma = 1/2, beta = 1/4)"
        return f"Newmark (gamma = {scheme.gamma:g}, beta = {scheme.beta:g})"
    if isinstance(scheme, GeneralizedAlpha):
        return f"generalised-alpha (rho_inf = {scheme.rho_infinity:g})"
    return type(scheme).__name__


def fourier_harmonics(params: Params) -> int:
    """The harmonics of the period's fundamental 2 pi / T that carry ``fourier_terms`` (m)
    harmonics of every crank: m max(p, q) for a speed ratio p/q (m for the paper's equal speeds;
    2 m at a ratio of 2, whose crank DE turns at twice the fundamental, and at 1/2, whose period
    is two turns of crank AB).  The default length of every Fourier series (2.10) of the motion.
    """
    turns = params.turns
    # crank j turns r_j q times per period: its k-th harmonic is the fundamental's k r_j q-th
    most = max([abs(_ratio_fraction(j.drive.ratio)) * turns for j in params.linkage.cranks if j.drive is not None]
               + [Fraction(1)])
    return int(params.fourier_terms) * math.ceil(most)


def min_steps_per_period(params: Params) -> int:
    """Smallest S that resolves the motion: 2 h + 1 for the h = :func:`fourier_harmonics`
    harmonics of (2.10) (h = m, the ``fourier_terms``, at equal crank speeds).

    The rigid-body load of one period carries harmonics up to m times each crank's frequency
    (assumption ``fourier_terms``); fewer than 2 h + 1 samples per period alias them.
    """
    return 2 * fourier_harmonics(params) + 1


def drive_period(params: Params) -> tuple[Any, float]:
    """The speed ratio as a fraction and the period of the motion it implies (s).

    ``ratio, T = drive_period(params)``.  Crank DE turns ``speed_ratio`` times per turn of
    crank AB; the motion repeats after q turns of AB when the ratio is p/q in lowest terms
    (``params.period``, :attr:`~fivebar.description.params.Params.turns`).  A ratio that is no
    fraction p/q with q <= 1000 (within 1e-9) raises :class:`~fivebar.errors.InputError`: the
    motion never repeats and there is no periodic steady state.
    """
    for joint in params.linkage.cranks:
        r = joint.drive.ratio if joint.drive is not None else 1.0
        if r == 0.0:
            continue  # an oscillating input (a driven slider's law): it repeats every turn of the drive phase
        if _ratio_fraction(r) == 0:
            name = "speed_ratio" if math.isclose(r, params.speed_ratio) else f"the speed ratio of crank {joint.name}"
            raise InputError(
                f"{name} = {r!r} is not allowed: it is not a ratio of small integers (p/q, q <= "
                f"{RATIO_DENOMINATOR}), so the crank motion never repeats and the linkage has no periodic "
                "steady state; give a ratio p/q such as 2 or 0.5 (crank DE turns p times while crank AB turns q times)")
    return _ratio_fraction(params.speed_ratio), params.period


def _estimated_dofs(epl: tuple[int, int, int, int] | None, motors: bool) -> int:
    """An upper estimate of the DOFs of a mesh: 4 per element and joint, 8 of the motors."""
    elements = 6 if epl is None else sum(epl)
    return 4 * elements + (8 if motors else 0)


@dataclass(frozen=True)
class Setup:
    """A linkage computation's set-up; ``None`` fields take the parameter file's entries.

    ``s = Setup(params)``; ``s.replace(crank_speed_rpm=300)``;
    ``linkage_dynamics(s)`` (:func:`fivebar.model.dynamics.linkage_dynamics`).

    Attributes
    ----------
    params
        The parameter set (:func:`fivebar.description.params.load_params`).
    crank_speed_rpm
        Speed of both cranks (r/min); default ``params.crank_speed_rpm``.
    steps_per_period
        S of (4.1); default ``params.steps_per_period``.  At least
        :func:`min_steps_per_period` (2 m + 1).
    motors
        ``False`` clamps the crank roots and leaves the motor elements out.
    nonlinear
        ``False`` drops the geometric nonlinearity f_nl.
    elements_per_link
        Mesh (elements in L1..L4); default the paper's (1, 2, 2, 1).
    scheme
        Time integrator; default :func:`default_scheme` of the parameters (generalised-alpha,
        errata E26).  The paper's rule is :data:`PAPER_SCHEME`.
    """

    params: Params
    crank_speed_rpm: float | None = None
    steps_per_period: int | None = None
    motors: bool = True
    nonlinear: bool = True
    elements_per_link: tuple[int, int, int, int] | None = None
    scheme: Scheme | None = None

    def __post_init__(self) -> None:
        p = self.params
        if not isinstance(p, Params):
            raise InputTypeError(f"params must be a fivebar.Params (load_params()), got {type(p).__name__}")
        rpm = p.crank_speed_rpm if self.crank_speed_rpm is None else self.crank_speed_rpm
        rpm = number("crank_speed_rpm", rpm, low=0, low_open=True, unit="r/min")
        S_min = min_steps_per_period(p)
        S = p.steps_per_period if self.steps_per_period is None else self.steps_per_period
        S = number("steps_per_period", S, integer=True)
        if S < S_min:
            raise InputError(
                f"steps_per_period = {S!r} is too small to resolve the motion: give an integer >= {S_min}; the "
                f"load of (2.10) has {fourier_harmonics(p)} harmonics of the period's fundamental ({p.fourier_terms} "
                f"of each crank's frequency: fourier_terms), which need at least {S_min} steps per period "
                f"(2 m + 1); the parameter file's default is "
                f"{p.steps_per_period}"
            )
        for name in ("motors", "nonlinear"):
            object.__setattr__(self, name, flag(name, getattr(self, name)))
        epl = self.elements_per_link
        if epl is not None:
            epl = p.linkage.check_mesh(epl)
        drive_period(p)
        scheme = default_scheme(p) if self.scheme is None else self.scheme
        if not isinstance(scheme, Scheme):
            raise InputTypeError(
                f"scheme must be a fivebar.numerics.schemes.Scheme (Newmark, HHT, GeneralizedAlpha), got {type(scheme).__name__}"
            )
        object.__setattr__(self, "crank_speed_rpm", rpm)
        object.__setattr__(self, "steps_per_period", S)
        object.__setattr__(self, "elements_per_link", epl)
        object.__setattr__(self, "scheme", scheme)

    def replace(self, **changes: Any) -> "Setup":
        """A copy with some fields changed (validated again)."""
        names = {f.name for f in fields(self) if f.init}
        bad = sorted(set(changes) - names)
        if bad:
            raise InputError(f"unknown Setup field(s) {bad}: allowed are {sorted(names)}")
        return replace(self, **changes)

    @property
    def run_params(self) -> Params:
        """The parameters at this set-up's crank speed."""
        if self.crank_speed_rpm == self.params.crank_speed_rpm:
            return self.params
        return self.params.replace(**{"assumptions.crank_speed_rpm": self.crank_speed_rpm})

    def _check_memory(self) -> None:
        """Refuse a set-up whose sampled matrices would not fit in memory (a MemoryError of
        :func:`fivebar.errors.memory`, naming S and the mesh)."""
        n = _estimated_dofs(self.elements_per_link, self.motors)
        S = self.steps_per_period
        # the step matrices M, C, K of every step and the step tangent's LU cache
        memory(4.0 * S * n * n * 8,
               f"the step matrices of steps_per_period = {S} steps with about {n} DOFs "
               f"(elements_per_link = {self.elements_per_link or (1, 2, 2, 1)})",
               "give a smaller steps_per_period or a coarser elements_per_link")


#: the fields of a problem, which no analysis takes as a keyword of its own
SETUP_FIELDS = tuple(f.name for f in fields(Setup) if f.init and f.name != "params")


def as_setup(setup: Setup | Params, argument: str = "setup") -> Setup:
    """The problem as a :class:`Setup`: a Setup as it is, a Params as ``Setup(params)`` (every
    field the parameter file's); anything else raises :class:`~fivebar.errors.InputTypeError`
    naming ``argument`` (the caller's name of ``setup``)."""
    if isinstance(setup, Setup):
        return setup
    if isinstance(setup, Params):
        return Setup(setup)
    raise InputTypeError(
        f"{argument} = {setup!r} ({type(setup).__name__}) is not allowed: give a fivebar.Setup or a "
        "fivebar.Params (fivebar.load_params() or fivebar.Setup(params, ...))"
    )


def analysis(fn: Callable) -> Callable:
    """Mark ``fn`` as an analysis of a problem (its first argument, a Setup or a Params): a
    field of :class:`Setup` passed to it as a keyword (``steady_state(params,
    steps_per_period=400)``) raises :class:`~fivebar.errors.InputError` naming the keyword
    and saying where it belongs, ``Setup(params, ...)`` or ``setup.replace(...)``; the set-up
    says it, once.  Every argument is then checked by the library's validation layer
    (:func:`fivebar.errors.checked`: by its annotation and name)."""
    own = set(inspect.signature(fn).parameters)
    refused = [name for name in SETUP_FIELDS if name not in own]
    check = checker(fn)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        bad = [k for k in kwargs if k in refused]
        if bad:
            given = ", ".join(f"{k}={kwargs[k]!r}" for k in bad)
            raise InputError(
                f"{fn.__name__}(..., {given}) is not allowed: {', '.join(bad)} "
                f"{'is a field' if len(bad) == 1 else 'are fields'} of the problem, not an option of "
                f"{fn.__name__}; give {'it' if len(bad) == 1 else 'them'} in the set-up: "
                f"{fn.__name__}(fivebar.Setup(params, {given}), ...) or "
                f"{fn.__name__}(setup.replace({given}), ...)")
        args, kwargs = check(args, kwargs)
        return fn(*args, **kwargs)
    return wrapper
