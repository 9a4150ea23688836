r"""The linkage's periodic response followed in a parameter: branches, bifurcations, brute force.

The glue between the linkage (:class:`fivebar.description.setup.Setup`, the period map of
:mod:`fivebar.analyses.steady`) and the generic :mod:`fivebar.numerics.periodic` and
:mod:`fivebar.numerics.continuation`:

* :func:`linkage_period_map` (of :mod:`fivebar.analyses.orbits`, the periodic-orbit engine,
  re-exported here): the period map of (2.7) at a value of a parameter (the crank
  speed, or any numeric entry of the parameter file), with its monodromy matrix from the
  integrator's tangent.  The state is the elastic displacement and its derivative in the
  crank angle at crank angle 0, :math:`\mathbf x = (\mathbf u, \mathrm d\mathbf u/\mathrm
  d\theta) = (\mathbf u, \dot{\mathbf u}/\Omega)`: the period :math:`T = 2\pi/\Omega` changes
  with the speed, and in the crank angle the orbit, which the rigid-body load drives at
  multiples of the crank frequency, changes smoothly with it (both halves in metres).  The
  multipliers do not depend on this choice (a similarity transformation of
  :math:`\boldsymbol\Phi`).
* :func:`follow`: the continuation of the periodic steady state from one value of the
  parameter to another, with its Floquet multipliers and located folds, period doublings and
  Neimark-Sacker points (:class:`LinkageBranch`).
* :func:`brute_force_diagram`: the independent second method: long marches, one Poincaré
  sample per period (the state at crank angle 0), the parameter stepped up and then down,
  each value started from the last state of the previous one.
* :func:`describe_speed`: at one speed, what the linkage does: the stable period-1 orbit, or,
  where it is unstable, what a march from it settles on (a period-2 orbit shot and checked, a
  different period-1 orbit, no periodic motion, or a divergence; the generic
  :func:`fivebar.numerics.continuation.settle`).  :func:`explain_steady` gives the same report for a
  solved steady state; ``steady_state(..., explain=True)`` attaches it to its result.
* :func:`steady_state`: the periodic steady state of one set-up by a method of the engine
  (:data:`fivebar.analyses.orbits.ORBIT_METHODS`: shooting, march, harmonic balance), with that
  report on request.

Every function here takes its method by name from the engine (``method=``), through one
problem object (:class:`fivebar.analyses.orbits.OrbitProblem`): a new method is a module and
an entry of the registry, and a method that cannot serve a function is refused there.
:func:`steady_state` lives here, above both the solvers and the report, so that the solvers need
nothing of the branches.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..numerics.continuation import (Branch, ContinuationError, Jump, continuation, iterated_map, jumps, orbits_at,
                                     settle, switch_period_doubling)
from ..errors import FivebarError, InputError, ValidityWarning, checked, flag, number
from ..numerics.newmark import NewtonConvergenceError
from ..description.params import Params
from ..numerics.blas import one_blas_thread
from ..numerics.periodic import PeriodicOrbit, shoot
from ..description.setup import Setup, analysis, as_setup
from .orbits import _SPEED, ORBIT_METHODS, LinkagePeriodMap, OrbitProblem, linkage_period_map, orbit_method
from .steady import SteadyState, _warm_start

__all__ = ["BruteForceDiagram", "LinkageBranch", "LinkagePeriodMap", "SpeedReport", "brute_force_diagram", "describe_speed",
           "explain_steady", "follow", "follow_period_doubling", "linkage_period_map", "steady_state", "STEADY_METHODS"]

Array = NDArray[np.float64]


@dataclass
class LinkageBranch:
    """A followed branch of the linkage's periodic steady state.

    Attributes
    ----------
    branch : Branch
        The generic branch (:class:`fivebar.numerics.continuation.Branch`): its ``p`` are the parameter
        values, ``x`` the states ``(u, du/dtheta)`` at crank angle 0, ``multipliers``,
        ``stable``, ``bifurcations``, ``steps``, ``newton``, ``stats``.
    period_map
        The map it followed (:func:`linkage_period_map`; twice iterated on a period-2 branch).
    parameter : str
    method : str
        The method of the engine (:data:`fivebar.analyses.orbits.ORBIT_METHODS`) whose period
        map was followed ("shooting").
    """

    branch: Branch
    period_map: Any
    parameter: str
    method: str = "shooting"
    _pp: dict = field(default_factory=dict, repr=False)

    @property
    def p(self) -> Array:
        """Parameter values (r/min for the crank speed)."""
        return self.branch.p

    @property
    def stable(self) -> NDArray[np.bool_]:
        """Stability of the points."""
        return self.branch.stable

    @property
    def spectral_radius(self) -> Array:
        """Largest multiplier modulus at the points."""
        return np.abs(self.branch.multipliers).max(axis=1)

    @property
    def bifurcations(self):
        """The located bifurcations (:class:`fivebar.numerics.continuation.Bifurcation`)."""
        return self.branch.bifurcations

    def steady(self, i: int) -> SteadyState:
        """Point ``i`` as a :class:`~fivebar.analyses.steady.SteadyState` (one period integrated)."""
        q = self.branch.points[i]
        base = self.period_map if isinstance(self.period_map, LinkagePeriodMap) else self.period_map.base
        return base.steady(q.x, q.p)

    def peak_to_peak_mm(self, link: str | None = None, direction: str = "transverse") -> Array:
        """Peak-to-peak midpoint deflection (mm) at every point (one period each; on a
        period-2 branch over the first of the two periods); ``link`` defaults to the
        description's first coupler (L2 of the five-bar)."""
        base = self.period_map if isinstance(self.period_map, LinkagePeriodMap) else self.period_map.base
        link = _link(base.setup, link)
        key = (link, direction)
        if key not in self._pp:
            self._pp[key] = np.array([self.steady(i).peak_to_peak_mm(link, direction)
                                      for i in range(len(self.branch.points))])
        return self._pp[key]

    def validity(self) -> "pd.DataFrame":
        """The model's validity at every point, as for a steady state
        (:attr:`fivebar.analyses.steady.SteadyState.validity`, its cheap checks): one row per point with
        the parameter, ``peak stress (MPa)``, ``stress / yield`` (the file's ``yield_stress``),
        ``deflection / length`` (against :data:`fivebar.analyses.steady.DEFLECTION_LIMIT`, the
        small-deflection range), ``compression / Euler load`` (the buckling check of the link
        nearest to buckling, :meth:`fivebar.analyses.response.Response.buckling`), ``stable`` and
        ``valid``.  One period integrated per point (kept)."""
        if "validity" not in self._pp:
            import pandas as pd

            rows = []
            for i, q in enumerate(self.branch.points):
                c = self.steady(i)._checks()
                rows.append({self.parameter: float(q.p), "peak stress (MPa)": c["peak bending stress (MPa)"],
                             "stress / yield": c["stress / yield"], "deflection / length": c["deflection / length"],
                             "compression / Euler load": c["compression / Euler load"],
                             "stable": bool(self.branch.stable[i]), "valid": bool(c["valid"])})
            self._pp["validity"] = pd.DataFrame(rows)
        return self._pp["validity"].copy()

    def orbit_at(self, p: float, tol: float = 1e-10) -> PeriodicOrbit:
        """The branch's orbit at ``p`` exactly: the nearest point's orbit shot at ``p``
        (the first segment of the branch that contains ``p``)."""
        ps = self.p
        for i in range(len(ps) - 1):
            if min(ps[i], ps[i + 1]) <= p <= max(ps[i], ps[i + 1]):
                w = 0.0 if ps[i + 1] == ps[i] else (p - ps[i]) / (ps[i + 1] - ps[i])
                x = (1 - w) * self.branch.points[i].x + w * self.branch.points[i + 1].x
                return shoot(self.period_map, x, p, tol=tol, scale=self.branch.scale)
        raise InputError(f"p = {p!r} is not allowed: the branch covers {ps.min():.6g} to {ps.max():.6g}")

    def orbits_at(self, p: float, segments: Any = None, tol: float = 1e-10) -> list[PeriodicOrbit]:
        """Every orbit of the branch at the parameter value ``p``, shot there
        (:func:`fivebar.numerics.continuation.orbits_at`).

        ``[o.stable for o in branch.orbits_at(197.0)]``: one orbit for each segment of the
        branch that contains ``p`` (of ``segments``, the indices of their first points; default
        all).  Unlike the points of the branch, whose places depend on the step control, these
        orbits depend on ``p`` alone.  Between two folds there are three; the list may be empty
        where the branch does not reach ``p``.
        """
        return orbits_at(self.branch, self.period_map, number("p", p), segments, tol)

    def jumps(self, link: str | None = None) -> list[Jump]:
        """Where a slow sweep of the parameter up or down leaves the branch, and which way
        the response jumps (:func:`fivebar.numerics.continuation.jumps`): one
        :class:`~fivebar.numerics.continuation.Jump` per fold that ends a stable leg, its
        ``before`` and ``after`` the transverse midpoint peak-to-peak (mm) of ``link`` (default
        the first coupler, L2), ``rising`` whether the sweep meets it going up.  A hardening
        oscillator jumps down going up and up going down.

        Returns
        -------
        list of Jump
            In the order of the folds along the branch.
        """
        base = self.period_map if isinstance(self.period_map, LinkagePeriodMap) else self.period_map.base
        link = _link(base.setup, link)
        return jumps(self.branch, self.period_map, lambda x, p: base.steady(x, p).peak_to_peak_mm(link))

    def section_mm(self, link: str | None = None) -> Array:
        """The Poincaré section of every point: the transverse midpoint deflection (mm) of
        ``link`` (default the description's first coupler, L2) at crank angle 0, the coordinate
        :func:`brute_force_diagram` samples."""
        base = self.period_map if isinstance(self.period_map, LinkagePeriodMap) else self.period_map.base
        link = _link(base.setup, link)
        out = []
        for q in self.branch.points:
            dyn = base.dynamics(q.p)[1]
            out.append(_midpoint0(dyn, q.x[: dyn.n], link))
        return np.array(out)

    def validity_at(self, p: float) -> dict[str, Any]:
        """The validity checks (:attr:`fivebar.analyses.steady.SteadyState.validity`, its cheap
        part) of the branch's first orbit at ``p`` (:meth:`orbits_at`, the segment met first
        from the branch's start)."""
        orbits = self.orbits_at(p)
        if not orbits:
            raise InputError(f"p = {p!r} is not allowed: the branch covers {self.p.min():.6g} to {self.p.max():.6g}")
        return dict(self.period_map.steady(orbits[0].x, p)._checks())

    def first_crossing(self, key: str, level: float, xtol: float = 1e-4) -> float | None:
        """The first parameter value where the validity check ``key`` (a column of
        :meth:`validity`: ``"stress / yield"``, ``"deflection / length"``,
        ``"compression / Euler load"``) reaches ``level``, on the branch from its start up to its
        first located bifurcation (the whole branch if it has none); None if it does not.

        The crossing is bracketed by two points of the branch and located by Brent's method on
        orbits shot at the parameter (:meth:`validity_at`), to ``xtol``: it depends on the
        problem, not on the step control.  ``branch.first_crossing("stress / yield", 1.0)``:
        where the links start to yield.
        """
        from scipy.optimize import brentq

        val = self.validity()
        if key not in val:
            raise InputError(f"key = {key!r} is not allowed: use a column of LinkageBranch.validity(): "
                             f"{[c for c in val.columns if c not in (self.parameter, 'stable', 'valid')]}")
        v = val[key].to_numpy(float)
        first = min((b.index for b in self.bifurcations), default=len(v))
        up = np.flatnonzero((v[1:] > level) & (v[:-1] <= level) & (np.arange(len(v) - 1) < first))
        if not up.size:
            return None
        i = int(up[0])
        return float(brentq(lambda p: self.validity_at(p)[key] - level, self.p[i], self.p[i + 1], xtol=xtol))

    def step_check(self, p: float, steps: Any, x: ArrayLike | None = None) -> "pd.DataFrame":
        """The orbit at ``p`` shot again with other numbers of steps per period: is S fine enough?

        ``branch.step_check(196.97, (100, 200, 400))``: one row per S of ``steps`` with the
        transverse midpoint peak-to-peak (mm) of every link of the description and the orbit's
        stability, from the state ``x`` (default: the branch's first orbit at ``p``); the state
        ``(u, du/dtheta)`` at crank angle 0 does not depend on the step.  A row whose orbit
        cannot be shot (near a fold, which moves with the step) holds NaN and stability None.
        """
        import pandas as pd

        base = self.period_map if isinstance(self.period_map, LinkagePeriodMap) else self.period_map.base
        if x is None:
            orbits = self.orbits_at(p)
            if not orbits:
                raise InputError(f"p = {p!r} is not allowed: the branch covers {self.p.min():.6g} to {self.p.max():.6g}")
            x = orbits[0].x
        links = base.setup.params.linkage.link_names
        rows = []
        for S in steps:
            f = OrbitProblem(base.setup.replace(steps_per_period=int(S)), self.parameter).period_map(self.method,
                                                                                                     "follow")
            row: dict[str, Any] = {"S": int(S)}
            try:
                orb = shoot(f, np.asarray(x, float), p, scale=self.branch.scale)
                st = f.steady(orb.x, p)
                row.update({f"{k} p-p (mm)": st.peak_to_peak_mm(k) for k in links})
                row["stable"] = orb.stable
            except FivebarError:
                row.update({f"{k} p-p (mm)": np.nan for k in links})
                row["stable"] = None
            rows.append(row)
        return pd.DataFrame(rows)

    def summary(self, unit: str = "r/min") -> list[str]:
        """One line per located bifurcation."""
        u = unit if self.parameter == _SPEED else ""
        return [b.describe(u) for b in self.bifurcations]


def _scan_scale(prob: OrbitProblem, method: str, p0: float, p_end: float, count: int = 12) -> Array:
    """Scale of the state from the energy norm of :mod:`fivebar.analyses.steady`: the state enters the
    arclength as ``sqrt(K_ii) u_i / E`` and ``Omega sqrt(M_ii) (du/dtheta)_i / E`` (``K, M`` at
    crank angle 0), with ``E`` the largest energy norm ``sqrt(u K u + v M v)`` of the linear
    model's orbits at ``count`` values across the range and ``Omega`` the speed where it
    occurs: a unit of arclength is the size of the largest orbit of the range."""
    lin = OrbitProblem(prob.setup.replace(nonlinear=False), prob.parameter)
    best = None
    for p in np.linspace(p0, p_end, count):
        s = lin.at(float(p))
        try:
            st = steady_state(s, method=method)
        except FivebarError:
            continue
        dyn = st.dynamics
        sd = dyn.step_data
        E = float(np.sqrt(np.einsum("ki,ij,kj->k", st.u, sd.K[0], st.u)
                          + np.einsum("ki,ij,kj->k", st.v, sd.M[0], st.v)).max())
        if best is None or E > best[0]:
            best = (E, dyn)
    if best is None or not best[0] > 0:
        raise InputError("no orbit of the linear model found across the range to scale the state: give scale=")
    E, dyn = best
    sd = dyn.step_data
    return np.r_[E / np.sqrt(np.diag(sd.K[0])), E / (dyn.params.crank_speed_rad_s * np.sqrt(np.diag(sd.M[0])))]


@analysis
@one_blas_thread
def follow(
    setup: Setup | Params,
    p_end: float,
    parameter: str = _SPEED,
    p0: float | None = None,
    *,
    points: int = 200,
    ds: float | None = None,
    ds_max: float | None = None,
    scale: ArrayLike | None = None,
    state_weight: float = 0.03,
    tol: float = 1e-8,
    method: str = "shooting",
    **kwargs,
) -> LinkageBranch:
    """Continue the linkage's periodic steady state in ``parameter`` from ``p0`` to ``p_end``.

    ``br = follow(fivebar.Setup(params.replace(bending_depth=0.002), motors=False,
    crank_speed_rpm=10), 300)``; ``br.p``, ``br.stable``, ``br.peak_to_peak_mm("L2")``,
    ``br.summary()``.

    Parameters
    ----------
    setup
        The set-up; ``p0`` defaults to its value of the parameter (its crank speed).
    p_end
        Where to stop.
    parameter
        ``"crank_speed_rpm"`` or a numeric parameter-file key (:func:`linkage_period_map`).
    points
        Budget of points (``max_points``); ``ds`` defaults to ``1 / points`` and ``ds_max`` to
        ``10 / points`` (scaled arclength: the whole range of the parameter is 1).  The step is
        set by the curvature of the branch (:func:`fivebar.numerics.continuation.continuation`: the
        tangent turns by about 0.2 rad per step) and by the corrector's iterations; ``ds_max``
        only bounds it where the branch is nearly straight, away from resonances.  On the
        flexible orientation (10-300 r/min, S = 800, nonlinear; the benchmark
        ``benchmarks/bench_continuation.py``) the branch turns back at four folds (169.6, 160.9, 247.7 and
        171.3 r/min); with ``ds_max`` = 1.5 / points the median step was that bound and 200
        points ended at 207.6 r/min, with 10 / points the branch reached 300 r/min in 197
        points (median step 0.0056, largest 0.05).
    scale
        Scale of the state (default: from the energy norm, relative to the largest orbit of
        the linear model at 12 values across the range; see ``_scan_scale``).
    state_weight
        Weight of the state against the parameter in the arclength (AUTO's THU): the state
        enters as ``state_weight * x / scale``, the parameter as ``p / |p_end - p0|``.  The
        linear response of the flexible orientation has a resonance of some mode with some
        harmonic of the crank every few r/min; with weight 1 the arclength follows each of
        them and 200 points reach 130 r/min of 10-300, with 0.1 about 200 r/min, with 0.05
        about 280 r/min, with the default 0.03 the range.  The
        continuation passes folds at any weight (the tangent turns with the branch).
    tol
        Corrector tolerance (scaled residual).
    method
        The method of the periodic-orbit engine (:data:`fivebar.analyses.orbits.ORBIT_METHODS`)
        whose steady state starts the branch and whose period map (with its monodromy matrix)
        is continued: "shooting"; another is refused, naming those that serve.
    **kwargs
        Passed to :func:`fivebar.numerics.continuation.continuation` (``locate_tol``, ``max_newton`` ...).

    Where the continuation cannot go on (the step falls below its smallest, for example
    because the integrator fails on a period), the branch up to there is returned and its
    ``branch.stop`` says why.
    """
    prob = OrbitProblem(setup, parameter)
    f = prob.period_map(method, "follow")
    p0 = prob.value if p0 is None else prob.given("p0", float(p0))
    if not (isinstance(p_end, (int, float)) and math.isfinite(p_end) and p_end != p0):
        raise InputError(f"p_end = {p_end!r} is not allowed: give a finite value other than p0 = {p0!r}")
    prob.given("p_end", float(p_end))
    if isinstance(points, bool) or int(points) != points or points < 2:
        raise InputError(f"points = {points!r} is not allowed: give an integer >= 2")
    if not (isinstance(state_weight, (int, float)) and math.isfinite(state_weight) and state_weight > 0):
        raise InputError(f"state_weight = {state_weight!r} is not allowed: give a positive number")
    D = (_scan_scale(prob, method, p0, p_end) if scale is None else np.asarray(scale, float)) / state_weight
    step = 1.0 / int(points)
    ds = step if ds is None else ds
    ds_max = 10.0 * step if ds_max is None else ds_max
    x0 = f.state(steady_state(prob.at(p0), method=method))
    try:
        br = continuation(f, x0, p0, float(p_end), ds=min(ds, ds_max), ds_max=ds_max,
                          ds_min=kwargs.pop("ds_min", 1e-3 * step), max_points=int(points), scale=D,
                          p_scale=abs(float(p_end) - p0), tol=tol, **kwargs)
    except ContinuationError as exc:
        if exc.branch is None or len(exc.branch.points) < 2:
            raise
        br = exc.branch  # the branch up to the failure; its ``stop`` says why
    return LinkageBranch(br, f, parameter, method)


class _Doubled:
    """The twice-iterated linkage map, knowing its base (for stored periods)."""

    periods = 2

    def __init__(self, base: LinkagePeriodMap) -> None:
        self.base = base
        self._f = iterated_map(base, 2)
        self.concurrent = self._f.concurrent  # as its base

    def __call__(self, x, p=None, jacobian=False):
        return self._f(x, p, jacobian)


@checked
def follow_period_doubling(branch: LinkageBranch, index: int, p_end: float, *, h: float = 0.05,
                           points: int = 100, **kwargs) -> LinkageBranch:
    """Switch at ``branch.bifurcations[index]`` (a period doubling) onto the period-2 branch
    and follow it towards ``p_end`` (:func:`fivebar.numerics.continuation.switch_period_doubling`).

    ``h`` is the first period-2 point's distance from the bifurcation along the critical
    eigenvector, relative to the size of the orbit there (scaled norm).
    """
    b = branch.bifurcations[index]
    if b.kind != "period doubling":
        raise InputError(f"branch.bifurcations[{index}] is a {b.kind}, not a period doubling")
    f = branch.period_map
    h = float(h) * float(np.linalg.norm(b.x / branch.branch.scale))
    br = switch_period_doubling(f, b, float(p_end), h=h, scale=branch.branch.scale,
                                p_scale=branch.branch.p_scale, max_points=int(points),
                                ds=kwargs.pop("ds", 0.5 / points), ds_max=kwargs.pop("ds_max", 2.0 / points), **kwargs)
    return LinkageBranch(br, _Doubled(f), branch.parameter, branch.method)


@dataclass
class BruteForceDiagram:
    """Poincaré samples of long marches, the parameter stepped up then down.

    Attributes
    ----------
    p : ndarray (m,)
        Parameter values in the order marched (up, then down).
    direction : ndarray (m,) of str
        "up" or "down".
    samples_mm : ndarray (m, k)
        Transverse deflection of the midpoint of ``link`` (mm) at crank angle 0 over the last
        ``k`` periods of each march (one sample per period).
    states : ndarray (m, 2 n)
        The last state ``(u, du/dtheta)`` at each value.
    change : ndarray (m,)
        Largest change of the sample over the last ``k`` periods relative to its size: about 0 for
        a period-1 motion.
    diverged : ndarray (m,) of bool
        The march failed (a Newton step of the integrator did not converge).
    link : str
        The link sampled (``brute_force_diagram(..., link=)``; by default the description's first
        coupler, L2 of the five-bar).
    """

    p: Array
    direction: NDArray
    samples_mm: Array
    states: Array
    change: Array
    diverged: NDArray[np.bool_]
    link: str

    def period(self, rtol: float = 1e-6) -> NDArray[np.int_]:
        """Smallest period (1, 2, 3, 4) that the samples repeat with to ``rtol`` of their
        spread or size, else 0 (none found: quasi-periodic, chaotic or not yet settled)."""
        out = np.zeros(len(self.p), dtype=int)
        for i, y in enumerate(self.samples_mm):
            if self.diverged[i]:
                continue
            ref = max(float(np.abs(y).max()), 1e-300)
            for k in (1, 2, 3, 4):
                if y.size > k and np.abs(y[k:] - y[:-k]).max() <= rtol * ref:
                    out[i] = k
                    break
        return out


def _link(setup: Setup, link: str | None) -> str:
    """``link``, checked against the linkage description; ``None``: its first coupler (the
    first link between two pins: L2 of the five-bar, the coupler of a four-bar)."""
    linkage = setup.params.linkage
    if link is None:
        return linkage.couplers[0]
    if link not in linkage.link_names:
        raise InputError(f"link = {link!r} is not allowed: give one of the links {list(linkage.link_names)}")
    return link


def _midpoint0(dyn, u: Array, link: str) -> float:
    """The transverse midpoint deflection (mm) of ``link`` in state ``u`` at crank angle 0."""
    _, tr = dyn.model.link_displacement(dyn.expand(u[None, :]), *dyn.crank_angles(np.zeros(1)), link, 0.5)
    return float(1e3 * tr[0])


@analysis
@one_blas_thread
def brute_force_diagram(
    setup: Setup | Params,
    values: ArrayLike,
    parameter: str = _SPEED,
    *,
    transient: int = 200,
    samples: int = 16,
    link: str | None = None,
    both_ways: bool = True,
    method: str = "march",
) -> BruteForceDiagram:
    """The bifurcation diagram by brute force: march, sample once per period, step the parameter.

    At each value (``values`` in order, then reversed if ``both_ways``) the linkage is marched
    ``transient`` periods from the last state of the previous value (the first from the
    quasi-static start of :func:`fivebar.analyses.steady.shooting`'s default, marched from rest), then
    ``samples`` more periods, whose states at crank angle 0 are the Poincaré samples.  A value
    whose march fails restarts the next one from rest.  Independent of the continuation: it
    uses only the integrator's periods, no Newton on periodicity, no monodromy matrix: the
    period map of ``method`` ("march", :data:`fivebar.analyses.orbits.ORBIT_METHODS`; another is
    refused, naming those that serve).
    """
    prob = OrbitProblem(setup, parameter)
    s = prob.setup
    link = _link(s, link)
    f = prob.period_map(method, "brute_force")
    vals = np.asarray(values, float).ravel()
    if vals.size < 1 or not np.all(np.isfinite(vals)):
        raise InputError(f"values = {values!r} is not allowed: give finite parameter values")
    for v in vals:
        prob.given("values", float(v))
    order = np.r_[vals, vals[::-1]] if both_ways else vals
    dirs = np.array(["up"] * vals.size + (["down"] * vals.size if both_ways else []))
    x = None
    P, X, Y, CH, DV = [], [], [], [], []
    for p in order:
        _, dyn = f.dynamics(p)
        n = dyn.n
        xs = np.zeros(2 * n) if x is None else x
        ys = []
        ok = True
        try:
            for k in range(int(transient) + int(samples)):
                xs = f(xs, p, False)[0]
                if k >= int(transient):
                    ys.append(_midpoint0(dyn, xs[:n], link))
        except (NewtonConvergenceError, FivebarError):
            ok = False
        if ok and np.all(np.isfinite(xs)):
            y = np.array(ys)
            CH.append(float(np.ptp(y) / max(np.abs(y).max(), 1e-300)))
            x = xs
        else:
            y = np.full(int(samples), np.nan)
            CH.append(math.nan)
            x = None
            xs = np.full(2 * n, np.nan)
        P.append(p)
        X.append(xs)
        Y.append(y)
        DV.append(not ok)
    return BruteForceDiagram(np.array(P), dirs, np.array(Y), np.array(X), np.array(CH), np.array(DV), link)


@dataclass
class SpeedReport:
    """What the linkage does at one value of the parameter (:func:`describe_speed`).

    Attributes
    ----------
    text : str
        One sentence.
    kind : str
        "stable period-1", "period-2", "other period-1", "no periodic motion" or "diverges".
    orbit : PeriodicOrbit or None
        The period-1 orbit shot there (stable or not).
    found : PeriodicOrbit or None
        What the march settled on (a period-2 orbit of the twice-iterated map, or another
        period-1 orbit), shot and with its multipliers.
    """

    text: str
    kind: str
    orbit: PeriodicOrbit | None
    found: PeriodicOrbit | None = None


@analysis
@one_blas_thread
def describe_speed(setup: Setup | Params, value: float | None = None, parameter: str = _SPEED, *,
                   periods: int = 400, branch: LinkageBranch | None = None, method: str = "shooting") -> SpeedReport:
    """At one speed (or value of ``parameter``): the stable period-1 orbit, or what is found there.

    Shoots the period-1 orbit; if it is stable, says so.  Otherwise marches ``periods``
    periods from it, disturbed along its most unstable Floquet direction (by 1 % of its
    size), and names what the Poincaré samples settle on (:func:`fivebar.numerics.continuation.settle`):
    a period-2 orbit (shot on the twice-iterated map, its multipliers given), another period-1
    orbit, no periodic motion within the march, or a divergence.  With ``branch`` the nearest
    located bifurcation is named as well ("period doubling at ... r/min; stable period-2
    orbit ...").  ``steady_state(..., explain=True)`` gives the same report for the orbit it
    solved (:attr:`fivebar.analyses.steady.SteadyState.explained`).  ``method``: the method of
    :data:`fivebar.analyses.orbits.ORBIT_METHODS` that solves and shoots the orbit and marches
    from it ("shooting"; another is refused, naming those that serve).
    """
    prob = OrbitProblem(setup, parameter)
    f = prob.period_map(method, "explain")
    p = prob.value if value is None else prob.given("value", float(value))
    try:
        st = steady_state(prob.at(p), method=method)
    except FivebarError as exc:
        return SpeedReport(f"at {p:.6g}{_unit(parameter)}: no period-1 orbit found by shooting "
                           f"({type(exc).__name__}: {exc})", "no periodic motion", None)
    return _describe(f, p, st, periods, branch)


def _unit(parameter: str) -> str:
    return " r/min" if parameter == _SPEED else ""


@checked
def explain_steady(st: SteadyState, periods: int = 400, method: str = "shooting") -> SpeedReport:
    """:func:`describe_speed`'s report for a solved steady state ``st`` (its set-up and speed),
    without solving it again: what ``steady_state(..., explain=True)`` attaches.  ``method``:
    the method of :data:`fivebar.analyses.orbits.ORBIT_METHODS` whose period map is shot and
    marched ("shooting"; another is refused, naming those that serve)."""
    if st.setup is None:
        raise InputError("explain needs the set-up of the result: solve with a fivebar.Setup or Params")
    prob = OrbitProblem(st.setup)
    f = prob.period_map(method, "explain")
    return _describe(f, prob.value, st, periods, None)


def _describe(f: LinkagePeriodMap, p: float, st: SteadyState, periods: int,
              branch: LinkageBranch | None) -> SpeedReport:
    """The report at ``p`` from the steady state ``st`` found there (shot again on the map to
    its tolerance, one or two periods from a converged orbit)."""
    unit = _unit(f.parameter)
    where = f"at {p:.6g}{unit}"
    cause = ""
    if branch is not None and branch.bifurcations:
        near = min(branch.bifurcations, key=lambda b: abs(b.p - p))
        cause = f"{near.kind} at {near.p:.6g}{unit} (critical multiplier {near.critical.real:+.4f}" \
                f"{near.critical.imag:+.4f}i); "
    x0 = f.state(st)
    D = np.full(x0.size, max(float(np.abs(x0).max()), 1e-12))
    try:
        orb = shoot(f, x0, p, scale=D)
    except FivebarError as exc:
        return SpeedReport(f"{where}: no period-1 orbit found by shooting ({type(exc).__name__}: {exc})",
                           "no periodic motion", None)
    mu = orb.multipliers
    if orb.stable:
        return SpeedReport(f"{where}: stable period-1 orbit, largest Floquet multiplier |mu| = "
                           f"{abs(mu[0]):.4g}", "stable period-1", orb)
    head = f"{where}: the period-1 orbit is unstable (multiplier {mu[0].real:+.4f}{mu[0].imag:+.4f}i); " + cause
    out = settle(f, orb, p, periods=int(periods), scale=D)
    if out.kind == "diverges":
        return SpeedReport(head + "a march from it fails or diverges: the motion leaves the model's range "
                           "(divergence)", "diverges", orb)
    if out.kind == "period-2":
        o2 = out.found
        state = "stable" if o2.stable else "unstable"
        _, dyn = f.dynamics(p)
        link = _link(f.setup, None)
        y1 = _midpoint0(dyn, o2.x[:dyn.n], link)
        y2 = _midpoint0(dyn, f(o2.x, p, False)[0][:dyn.n], link)
        return SpeedReport(head + f"{state} period-2 orbit ({link} midpoint at crank angle 0 alternating "
                           f"{y1:.4g} / {y2:.4g} mm; largest multiplier of the twice-iterated map |mu| = "
                           f"{o2.spectral_radius:.4g})", "period-2", orb, o2)
    if out.kind == "other period-1":
        o1 = out.found
        state = "stable" if o1.stable else "unstable"
        return SpeedReport(head + f"a march from it settles on another, {state} period-1 orbit (|mu| = "
                           f"{o1.spectral_radius:.4g}, state differing by "
                           f"{np.abs(o1.x - orb.x).max() / max(np.abs(orb.x).max(), 1e-300):.3g} of its size)",
                           "other period-1", orb, o1)
    return SpeedReport(head + f"no periodic motion of period 1 or 2 within {periods} periods "
                       "(quasi-periodic, chaotic or slowly settling)", "no periodic motion", orb)


#: The methods of :func:`steady_state` and the other callers of the engine, by name
#: (:data:`fivebar.analyses.orbits.ORBIT_METHODS`, the same registry).
#:
#: :meta hide-value:
STEADY_METHODS = ORBIT_METHODS


@analysis
def steady_state(
    setup: Setup | Params,
    method: str = "shooting",
    tol: float | None = None,
    explain: bool = False,
    start: SteadyState | None = None,
) -> SteadyState:
    """The periodic steady state of the linkage over one period of the motion.

    ``res = steady_state(params)`` or ``steady_state(setup.replace(crank_speed_rpm=300,
    steps_per_period=1600))``;
    ``res.midpoint_mm("L2", "transverse")`` (mm over the S + 1 samples from crank angle 0),
    ``res.floquet_multipliers``, ``res.stable``, ``res.note``, ``res.bending_stress()`` (Pa).
    ``steady_state(params, tol=0.01)`` chooses S itself for 1 % on the midpoint deflections
    (fastest for a given accuracy, see ``tol``).

    Parameters
    ----------
    setup
        The problem: a :class:`fivebar.description.setup.Setup` (crank speed, S, motors, nonlinearity,
        mesh, scheme; the paper's rule is ``Setup(params, scheme=fivebar.PAPER_SCHEME)``), or a
        :class:`fivebar.description.params.Params` meaning ``Setup(params)`` (every setting from the
        parameter file: S = ``steps_per_period``, the ``[simulation] scheme``).
    method
        A name of :data:`STEADY_METHODS`: "shooting" (damped Newton on periodicity, with Floquet
        multipliers), "march" (period by period from rest) or "harmonic_balance" (a Fourier
        series of the period, with Hill's stability;
        :func:`fivebar.analyses.harmonic_balance.harmonic_balance_steady_state`: with ``tol``
        the number of harmonics is chosen for the accuracy, without it the parameter file's
        ``fourier_terms``; the result is sampled at the set-up's S, which sets no step).
    tol
        Relative accuracy asked of the transverse midpoint deflections of L2 and L3 over the
        period (Figure 6), for example 0.01; ``None`` (default) solves at the set-up's S.  With
        ``tol`` the library chooses S (the set-up's S is not used): it solves at S = 50, 100, 200, ... (each from the previous
        orbit, sampling no step time twice; with ``start``, each from that result's orbit at
        the same S, scaled) until the deflection curves of two successive S
        differ by at most ``tol`` of their peak-to-peak value at every sample, and returns the
        finer one.  For the second-order schemes that change over-estimates the finer
        solution's error in the asymptotic range (about three times).  ``res.accuracy`` holds
        the S compared, the estimate and every step tried; ``res.note`` says what was chosen.
    explain
        Where the orbit is unstable (``res.stable`` False, ``res.note`` says so), also find
        what the linkage does there: a march of 400 periods from the orbit, disturbed along
        its most unstable Floquet direction, names a period-2 orbit, another period-1 orbit,
        no periodic motion or a divergence (:func:`fivebar.analyses.branches.explain_steady`, the report of
        :func:`fivebar.analyses.branches.describe_speed`, which with a followed branch also names the
        nearest bifurcation).  The report is ``res.explained`` and ends ``res.note``.  Default False: an unstable orbit costs nothing
        more (its note says how to ask).  Needs ``method="shooting"`` (the multipliers);
        computes the multipliers of a nonlinear orbit (one period with the monodromy matrix).
    start
        A warm start (``tol`` and shooting only): the result of ``steady_state(..., tol=tol)``
        for the same set-up at a nearby crank speed (within 25 %), for example the last speed
        of a sweep.  Each S then starts from that result's orbit at the same S, scaled to this
        speed, with its monodromy matrix as the first Jacobian (and, when that result was
        itself warm-started, the secant through both speeds): one to three periods without a
        monodromy matrix per S instead of a solve from the quasi-static state.  The S tried and
        chosen are those of a cold start, and the orbit differs from a cold start's only within
        the inner tolerance of shooting.  Nothing is remembered between calls: the same
        arguments give the same result, to the last bit, whatever was computed before.
    """
    orbit_method(method, "steady_state")
    explain = flag("explain", explain)
    if explain and "explain" not in ORBIT_METHODS[method].serves:
        raise InputError(f"explain = True and method = {method!r} are not allowed together: explain needs the "
                         "Floquet multipliers of shooting (method='shooting')")
    if tol is not None:
        tol = number("tol", tol, low=0.0, high=1.0, low_open=True, high_open=True)
    s = as_setup(setup)
    memo = None if start is None else _warm_start(start, s, method, tol)
    res = OrbitProblem(s).steady(method, "steady_state", tol=None if tol is None else float(tol), memo=memo)
    if explain and res.stable is False:
        res._cache["explained"] = explain_steady(res, method=method)
    outside = res._outside()
    if outside:
        warnings.warn(f"the steady state at {s.crank_speed_rpm:g} r/min is outside the model's validity: "
                      + "; ".join(outside) + " (SteadyState.validity has the checks)", ValidityWarning,
                      stacklevel=3)  # (steady_state, its analysis wrapper, the caller)
    return res
