r"""Continuation of periodic orbits in a parameter, with their bifurcations.

The periodic orbits of a periodically forced system at parameter :math:`p` are the fixed
points of its period map, :math:`\mathbf G(\mathbf x, p) = \mathbf P(\mathbf x; p) - \mathbf x
= \mathbf 0` (:mod:`fivebar.numerics.periodic`).  Their set is a curve in :math:`(\mathbf x, p)`;
:func:`continuation` follows it by *pseudo-arclength continuation* (Keller 1977): from a point
:math:`\mathbf y_k = (\mathbf x_k, p_k)` with unit tangent :math:`\boldsymbol\tau_k` (the null
vector of :math:`[\boldsymbol\Phi - \mathbf I,\ \mathbf G_p]`), predict
:math:`\mathbf y_k + \Delta s\,\boldsymbol\tau_k` and correct by Newton's method on

.. math::

    \mathbf G(\mathbf x, p) = \mathbf 0, \qquad
    \boldsymbol\tau_k^\top(\mathbf y - \mathbf y_k) = \Delta s ,

whose Jacobian :math:`\begin{bmatrix}\boldsymbol\Phi - \mathbf I & \mathbf G_p\\
\boldsymbol\tau_k^\top\end{bmatrix}` stays regular at a fold (a turning point in ``p``), so the
branch is followed around folds.  The predictor is of second order: the turn of the tangent
over the last step, :math:`\mathbf c = (\boldsymbol\tau_k - \boldsymbol\tau_{k-1})/\Delta s_{k-1}`,
continued across :math:`\boldsymbol\tau_k`, :math:`\mathbf y_k + \Delta s\,\boldsymbol\tau_k +
\tfrac12\Delta s^2(\mathbf c - (\mathbf c^\top\boldsymbol\tau_k)\boldsymbol\tau_k)` (on the
constraint), whose error falls as :math:`\Delta s^3` where the tangent predictor's falls as
:math:`\Delta s^2`: on chapter 13's branch the corrector's iterations fell from 4.0 to 3.5 a point,
the rejected steps from 98 to 54 and the time by a quarter (with the step rule below), with the same
folds to 1e-5 r/min.
Lengths are measured in scaled variables
:math:`(\mathbf x / \mathbf d,\ p / p_s)` (arguments ``scale``, ``p_scale``).  The monodromy
matrix :math:`\boldsymbol\Phi` comes from the period map (the integrator's tangent) and
:math:`\mathbf G_p` from one forward difference in ``p`` (its period integrated in a second
thread beside the monodromy period, where the map is ``concurrent`` and there are two cores:
the same numbers, in the time of the longer period).  The corrector is a chord
iteration with the Jacobian of the last converged point; the Jacobian is refreshed at the
present iterate when an iteration reduces the residual by less than 5 (twice at most) or when
its update, halved three times, still fails to integrate a period or multiplies the residual
by more than 10 (Newton's residual may grow for an iteration on its way; a tenfold growth is
taken for divergence); a step that fails with the present Jacobian too is rejected.  Step-size control: a step whose corrector needs
more than ``max_newton`` iterations (or fails), whose corrector ends farther than half
the step from the predictor, or at whose corrected point the Jacobian cannot be made (a
period from it, or at ``p + dp``, fails to integrate), is halved (down to ``ds_min``); after
a converged step the next is scaled by :math:`\sqrt{0.1\,\Delta s/\delta}`, :math:`\delta` the distance of the
corrected point from the tangent predictor (about :math:`\kappa\Delta s^2/2` on a curve of curvature
:math:`\kappa`: the tangent then turns by about 0.2 rad per step), the factor kept within
0.5 and 2 (at most 1 after more than ``max_newton // 2 + 1`` iterations, or when the step
was just halved: not back at once to the length that failed), the step within
``ds_max``.  The new tangent is oriented by the sign of
:math:`\det[\mathbf J;\ \boldsymbol\tau^\top]`, which a branch of regular points keeps (folds included), and a step
whose tangent turns by more than 60 degrees is halved too: with the state weighted lightly in
the arclength a fold turns within a small arclength, and a long step can jump across it onto
the branch's further course, where orienting along the last tangent would send the
continuation back the way it came.

**Recovery.**  Where the step has been halved below ``ds_min``, the continuation does not stop
at once: from the last point it tries, in order, Newton's method with a fresh Jacobian at every
iterate and three times the iterations, the predictor along the secant through the last two
points, and a step in the parameter alone with the state corrected at that parameter (each at
4 and 1 times ``ds_min``); a point so reached says which (:attr:`BranchPoint.recovery`, and
``Branch.stats["recoveries"]``).  Only when all fail does it raise :class:`ContinuationError`.

**Bifurcations** (the codimension-one ones of a fixed point of a map; Kuznetsov,
*Elements of Applied Bifurcation Theory*, 3rd ed., ch. 4-5; the test functions follow the
practice of AUTO and MatCont):

* *fold* (limit point of cycles, a multiplier through +1): the parameter component
  :math:`\tau_p` of the tangent changes sign;
* *period doubling* (flip, a multiplier through -1): :math:`\det(\boldsymbol\Phi +
  \mathbf I) = \prod_i(\mu_i + 1)` changes sign;
* *Neimark-Sacker* (a complex pair through the unit circle): the bialternate determinant
  :math:`\det(\boldsymbol\Phi\odot\boldsymbol\Phi - \mathbf I) = \prod_{i<j}(\mu_i\mu_j - 1)`
  changes sign and the number of non-real multipliers outside the unit circle changes (the
  determinant vanishes also where two real multipliers have product 1, a neutral saddle).

Between two points whose test function changes sign, the point is located by the Illinois
variant of regula falsi in the arclength (each trial point corrected onto the branch) until
the bracket in arclength is below ``locate_tol`` (scaled units) or the test function below
1e-10; each :class:`Bifurcation` reports its parameter, its multipliers and the bracket.  A
located point is kept only if its critical multiplier lies within ``critical_tol`` (default
0.01) of the unit circle (:meth:`Bifurcation.distance`: ``|mu - 1|`` at a fold, ``|mu + 1|`` at
a period doubling, ``||mu| - 1|`` of a non-real pair at a Neimark-Sacker point); otherwise the
sign change had another cause (the bialternate determinant, for example, also changes sign at
a neutral saddle, and the count of non-real multipliers outside the circle also changes where
a pair outside turns real, so that both can happen within one step with no multiplier on the
circle) and the crossing goes to ``Branch.discarded`` instead of ``Branch.bifurcations``.

**Every change of stability.**  Where the stability changes between two points of the branch
(the largest multiplier's modulus passes 1) and no test function has located a bifurcation
between them (a multiplier through +1 where the branch does not turn in the parameter, a
branch point; or a located crossing whose multiplier was not on the circle), the crossing is
located on the stability itself, :math:`\max_i|\mu_i| - 1`, by the same regula falsi, and
named by the multiplier that crosses: a fold where it is +1 and :math:`\tau_p` changes sign,
a *branch point* where it is +1 and the branch does not turn, a period doubling at -1, a
Neimark-Sacker point where it is not real.  So every change of stability the continuation
passes is a located bifurcation.

**Branch switching at a period doubling.**  At the flip the period-2 orbits form a branch
of fixed points of the twice-iterated map :math:`\mathbf P^2` that crosses the period-1
branch with the tangent :math:`(\mathbf e, 0)`, :math:`\mathbf e` the eigenvector of the
multiplier -1.  :func:`switch_period_doubling` corrects :math:`(\mathbf x^* + h\mathbf e, p^*)`
onto :math:`\mathbf P^2(\mathbf x) = \mathbf x` with the constraint
:math:`\mathbf c^\top(\mathbf y - \mathbf y^*) = h`, :math:`\mathbf c` the direction
:math:`(\mathbf e, 0)` made orthogonal to the period-1 tangent (so that the period-1 branch,
also a fixed-point set of :math:`\mathbf P^2`, is excluded), and continues from there.

**Reproducibility.**  The step control takes discrete decisions (accept, halve, grow) on
quantities computed to rounding error, so a change of rounding changes the path (the points,
their count), though not what is located on it (folds and bifurcations, to their tolerance)
nor where it stops: the orientation by the determinant, the limit on the tangent's turn and
the recovery make the branch followed a property of the problem.  Chapter 13's branch
(150-240 r/min, four folds) gave the same stop and folds, to 0.001 r/min, with three OpenBLAS
kernels, one BLAS thread, numba's generic target, a start perturbed by 1e-10 and the first
step scaled by 0.75 and 1.25; before, one kernel stopped at its second fold and another turned
back there onto the branch already followed.  Threaded BLAS rounds differently
with the number of threads; :func:`continuation` and :func:`switch_period_doubling` therefore
run with one BLAS thread (threadpoolctl; the matrices of a period map are small, for which
one thread is also the faster), so the path does not depend on ``OPENBLAS_NUM_THREADS`` or the
machine's core count.

This module imports nothing of the linkage.  References: H. B. Keller, *Numerical solution of
bifurcation and nonlinear eigenvalue problems* (1977); E. J. Doedel et al., AUTO-07P manual;
A. Dhooge, W. Govaerts, Yu. A. Kuznetsov, MatCont (ACM TOMS 29, 2003).

**What the motion does at an unstable orbit.**  :func:`settle` marches the map from the orbit,
disturbed along its most unstable Floquet direction, and names what the Poincaré samples settle
on: a period-2 orbit (shot on the twice-iterated map, with its multipliers), another period-1
orbit (shot), no periodic motion of period 1 or 2 within the march, or a divergence.
"""

from __future__ import annotations

import math
import os
import threading
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ComputationError, FivebarError, InputError, array, checked, number
from .blas import one_blas_thread
from .periodic import PeriodMap, PeriodicOrbit, floquet_multipliers, monodromy, shoot

__all__ = [
    "Bifurcation",
    "Branch",
    "BranchPoint",
    "ContinuationError",
    "ResidualProblem",
    "continuation",
    "Settled",
    "iterated_map",
    "Jump",
    "jumps",
    "orbits_at",
    "settle",
    "switch_period_doubling",
]

Array = NDArray[np.float64]

_KINDS = ("fold", "period doubling", "Neimark-Sacker")
# what the map applications of a continuation are spent on (``Branch.stats["by purpose"]``)
_PURPOSES = ("start", "corrector", "rejected", "multipliers", "locate", "recovery")
#: A step is accepted only if the branch's tangent turns by less than this (60 degrees) from the
#: last point to the new one: a larger turn means the step jumped across a sharp fold (or onto
#: another part of the branch), and the located bifurcations between the two would be guesses.
_MAX_TURN_COS = 0.5
#: What :func:`continuation` tries, in this order, from the last point when the step has been
#: halved below ``ds_min`` (:func:`_recover`).
_RECOVERIES = ("full Newton", "secant predictor", "natural parameter")


class ContinuationError(ComputationError):
    """The continuation could not proceed (the message names the parameter and the step).

    Its attribute ``branch`` holds the :class:`Branch` up to the failure."""

    branch: "Branch | None" = None


@dataclass
class BranchPoint:
    """One converged point of a branch.

    Attributes
    ----------
    x : ndarray (N,)
        Orbit (state at the start of the period).
    p : float
        Parameter.
    multipliers : ndarray (N,) complex
        Floquet multipliers, largest modulus first.
    tangent : ndarray (N + 1,)
        Unit tangent in the scaled variables ``(x / scale, p / p_scale)``.
    step : float
        Arclength step (scaled) that reached this point (0 for the first).
    newton : int
        Corrector iterations that reached it.
    residual : float
        Scaled periodicity residual ``||G / scale||``.
    recovery : str
        How the step that reached it was made when the ordinary step failed down to
        ``ds_min`` (one of "full Newton", "secant predictor", "natural parameter", tried in that order; "" for an ordinary step).
    """

    x: Array
    p: float
    multipliers: NDArray[np.complex128]
    tangent: Array
    step: float = 0.0
    newton: int = 0
    residual: float = 0.0
    recovery: str = ""

    @property
    def stable(self) -> bool:
        """True if every multiplier lies strictly inside the unit circle."""
        return bool(np.abs(self.multipliers).max() < 1.0)


@dataclass
class Bifurcation:
    """A located bifurcation of the branch.

    Attributes
    ----------
    kind : str
        "fold", "period doubling" or "Neimark-Sacker"; "branch point" where a multiplier
        crosses +1 and the branch does not turn in the parameter.
    p : float
        Parameter at the located point.
    x : ndarray
        Orbit there.
    multipliers : ndarray complex
        Its Floquet multipliers (largest modulus first); the critical one is
        :attr:`critical`.
    index : int
        The bifurcation lies between branch points ``index`` and ``index + 1``.
    p_bracket : tuple of float
        Parameter values at the ends of the final bracket (the location's uncertainty).
    test : float
        Test function at the located point.
    """

    kind: str
    p: float
    x: Array
    multipliers: NDArray[np.complex128]
    index: int
    p_bracket: tuple[float, float]
    test: float
    tangent: Array = field(default=None, repr=False)
    periods: int = 1

    @property
    def critical(self) -> complex:
        """The crossing multiplier: nearest +1 (fold, branch point), -1 (period doubling) or,
        for Neimark-Sacker, the non-real one nearest the unit circle (positive imaginary part)."""
        mu = self.multipliers
        if self.kind in ("fold", "branch point"):
            return complex(mu[np.argmin(np.abs(mu - 1.0))])
        if self.kind == "period doubling":
            return complex(mu[np.argmin(np.abs(mu + 1.0))])
        cx = mu[np.abs(mu.imag) > 1e-12 * np.maximum(1, np.abs(mu))]
        cx = cx[cx.imag > 0]
        return complex(cx[np.argmin(np.abs(np.abs(cx) - 1))]) if cx.size else complex("nan")

    def distance(self) -> float:
        """Distance of the critical multiplier from the unit circle where this kind crosses it:
        ``|mu - 1|`` (fold), ``|mu + 1|`` (period doubling), ``||mu| - 1|`` (Neimark-Sacker;
        infinite where no multiplier is non-real)."""
        c = self.critical
        if self.kind in ("fold", "branch point"):
            return abs(c - 1.0)
        if self.kind == "period doubling":
            return abs(c + 1.0)
        return abs(abs(c) - 1.0) if math.isfinite(c.real) else math.inf

    def describe(self, unit: str = "") -> str:
        """One line: kind, parameter, bracket and critical multiplier."""
        u = f" {unit}" if unit else ""
        c = self.critical
        lo, hi = self.p_bracket
        return (f"{self.kind} at p = {self.p:.8g}{u} (bracket {min(lo, hi):.8g} to {max(lo, hi):.8g}), "
                f"critical multiplier {c.real:+.5f}{c.imag:+.5f}i (|mu| = {abs(c):.5f})")


@dataclass
class Branch:
    """A followed branch of periodic orbits.

    Attributes
    ----------
    points : list of BranchPoint
    bifurcations : list of Bifurcation
    periods : int
        Forcing periods per map application (2 on a period-2 branch).
    scale, p_scale
        The scaling of the arclength.
    stats : dict
        Counts: map applications (``periods``, each monodromy matrix's period among them),
        monodromy matrices, rejected steps, Newton iterations; and ``"by purpose"``: the
        periods, monodromies and corrector iterations of ``"start"`` (the shooting of the first
        orbit and its Jacobian), ``"corrector"`` (the accepted steps' corrections),
        ``"rejected"`` (those of the steps rejected), ``"multipliers"`` (the Jacobian at each
        accepted point: its tangent and multipliers) and ``"locate"`` (the bifurcations').
    stop : str
        Why it stopped.
    discarded : list of Bifurcation
        Sign changes of a test function whose located point has no critical multiplier within
        ``critical_tol`` of the unit circle (:func:`continuation`): not bifurcations, kept to
        show what was found there.
    """

    points: list[BranchPoint]
    bifurcations: list[Bifurcation]
    periods: int
    scale: Array
    p_scale: float
    stats: dict
    stop: str = ""
    discarded: list[Bifurcation] = field(default_factory=list)

    @property
    def p(self) -> Array:
        """Parameter at the points."""
        return np.array([q.p for q in self.points])

    @property
    def x(self) -> Array:
        """Orbits at the points, (len, N)."""
        return np.array([q.x for q in self.points])

    @property
    def multipliers(self) -> NDArray[np.complex128]:
        """Multipliers at the points, (len, N)."""
        return np.array([q.multipliers for q in self.points])

    @property
    def stable(self) -> NDArray[np.bool_]:
        """Stability at the points."""
        return np.array([q.stable for q in self.points])

    @property
    def steps(self) -> Array:
        """Arclength steps (scaled) of the points after the first."""
        return np.array([q.step for q in self.points[1:]])

    @property
    def newton(self) -> NDArray[np.int_]:
        """Corrector iterations of the points after the first."""
        return np.array([q.newton for q in self.points[1:]], dtype=int)


def iterated_map(period_map: PeriodMap, k: int = 2) -> PeriodMap:
    """The map applied ``k`` times (the period-``k`` map), with the monodromy matrix by the
    chain rule (None if the map gives none: then finite differences serve)."""
    if isinstance(k, bool) or int(k) != k or k < 1:
        raise InputError(f"k = {k!r} is not allowed: give an integer >= 1")

    def f(x, p=None, jacobian=False):
        Js = []
        for _ in range(int(k)):
            x, J = period_map(x, p, jacobian)
            Js.append(J)
        if not jacobian or any(J is None for J in Js):
            return x, None
        Phi = Js[0]
        for J in Js[1:]:
            Phi = J @ Phi
        return x, Phi

    f.periods = int(k) * getattr(period_map, "periods", 1)  # type: ignore[attr-defined]
    f.concurrent = bool(getattr(period_map, "concurrent", False))  # type: ignore[attr-defined]
    return f


class _Problem:
    """G, its Jacobian and the tangent in the scaled variables."""

    def __init__(self, period_map, D, ps, dp):
        self.f, self.D, self.ps, self.dp = period_map, D, ps, dp
        self.concurrent = bool(getattr(period_map, "concurrent", False)) and _cores() > 1
        self.stats = {"periods": 0, "monodromies": 0, "newton": 0, "rejected": 0,
                      "by purpose": {k: {"periods": 0, "monodromies": 0, "newton": 0} for k in _PURPOSES}}
        self.purpose = "start"
        self.orientation = 1.0

    def count(self, periods: int = 0, monodromies: int = 0, newton: int = 0) -> None:
        """Charge map applications (monodromy matrices among them) and corrector iterations to
        the present purpose."""
        c = self.stats["by purpose"][self.purpose]
        for k, v in (("periods", periods), ("monodromies", monodromies), ("newton", newton)):
            self.stats[k] += v
            c[k] += v

    def move(self, before: dict, source: str, to: str) -> None:
        """Move what ``source`` spent since ``before`` (a copy of its count) to ``to``."""
        c, r = self.stats["by purpose"][source], self.stats["by purpose"][to]
        for k in r:
            r[k] += c[k] - before[k]
            c[k] = before[k]

    def G(self, y):
        x, p = self.D * y[:-1], self.ps * y[-1]
        self.count(1)
        return (self.f(x, p, False)[0] - x) / self.D

    def jac(self, y):
        """Scaled [Phi - I, G_p] at y, the scaled G there, and Phi (unscaled).

        The period at ``p + dp`` of the forward difference runs in a second thread beside the
        monodromy period when the map allows it (``concurrent``) and the process has two cores;
        the numbers and the counts are those of the serial order (the difference's period is
        counted only if the monodromy's succeeded, as when it follows it)."""
        x, p = self.D * y[:-1], self.ps * y[-1]
        h = self.dp * max(1.0, abs(y[-1]))
        self.count(1, 1)  # (counted before: a period that fails is work done too)
        (xT, Phi), xh = _beside(lambda: monodromy(self.f, x, p, self.D),
                                lambda: self.f(x, p + self.ps * h, False)[0], self.concurrent)
        g = (xT - x) / self.D
        self.count(1)
        gp = ((xh - x) / self.D - g) / h
        A = (Phi / self.D[:, None]) * self.D[None, :] - np.eye(x.size)
        return np.hstack([A, gp[:, None]]), g, Phi


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _beside(first, second, concurrent: bool):
    """``(first(), second())``; with ``concurrent``, ``second`` runs in another thread while
    ``first`` runs in this one, and both have ended on return.  An error of ``first`` is raised
    before one of ``second`` (the serial order's)."""
    if not concurrent:
        return first(), second()
    out: dict = {}

    def run():
        try:
            out["value"] = second()
        except BaseException as exc:  # noqa: BLE001 (raised in this thread below)
            out["error"] = exc

    worker = threading.Thread(target=run, name="fivebar-dp", daemon=True)
    worker.start()
    try:
        a = first()
    finally:
        worker.join()
    if "error" in out:
        raise out["error"]
    return a, out["value"]


def _tangent(J: Array, prev: Array | None) -> Array:
    """Unit null vector of J (N x (N+1)), oriented along ``prev``."""
    if prev is not None:
        B = np.vstack([J, prev])
        rhs = np.zeros(J.shape[0] + 1)
        rhs[-1] = 1.0
        try:
            t = np.linalg.solve(B, rhs)
            if np.all(np.isfinite(t)):
                return t / np.linalg.norm(t)
        except np.linalg.LinAlgError:
            pass
    _, _, Vt = np.linalg.svd(J)
    t = Vt[-1]
    if prev is not None and t @ prev < 0:
        t = -t
    return t


def _orientation(J: Array, t: Array) -> float:
    """The sign of ``det([J; t^T])``: it keeps its sign along a branch of regular points (folds
    included) when the tangent keeps its orientation, and changes it where the tangent turns
    back.  A step that jumps across a sharp fold onto the branch's further course lands where
    the previous tangent points back along the branch; the sign tells the true direction (Allgower
    and Georg, *Introduction to Numerical Continuation Methods*, 2003, sec. 2.1)."""
    sign, _ = np.linalg.slogdet(np.vstack([J, t]))
    return float(sign)


def _tests(mu: NDArray[np.complex128], tangent: Array) -> dict[str, float]:
    """Test functions, each continuous along the branch: fold tau_p (the parameter component of
    the tangent); period doubling det(Phi + I) = prod(mu + 1); Neimark-Sacker the bialternate
    determinant det(Phi (.) Phi - I) = prod_{i<j}(mu_i mu_j - 1)."""
    i, j = np.triu_indices(mu.size, 1)
    return {
        "fold": float(tangent[-1]),
        "period doubling": float(np.prod(mu + 1.0).real),
        "Neimark-Sacker": float(np.prod(mu[i] * mu[j] - 1.0).real),
        # not a bifurcation's test: the stability itself, where no test above locates its change
        "stability": float(np.abs(mu).max() - 1.0),
    }


def _outside_nonreal(mu: NDArray[np.complex128]) -> int:
    """Non-real multipliers outside the unit circle."""
    real = np.abs(mu.imag) <= 1e-9 * np.maximum(1.0, np.abs(mu))
    return int(np.count_nonzero(~real & (np.abs(mu) > 1)))


@checked
@one_blas_thread
def continuation(
    period_map: PeriodMap | ResidualProblem,
    x0: ArrayLike,
    p0: float,
    p_end: float,
    *,
    ds: float = 0.05,
    ds_min: float = 1e-6,
    ds_max: float = 0.5,
    max_points: int = 500,
    scale: ArrayLike | None = None,
    p_scale: float = 1.0,
    tol: float = 1e-10,
    max_newton: int = 10,
    dp: float = 1e-6,
    locate: bool = True,
    locate_tol: float = 1e-7,
    critical_tol: float = 0.01,
    tangent: ArrayLike | None = None,
    p_bounds: tuple[float, float] | None = None,
) -> Branch:
    r"""Follow the periodic orbits of ``period_map`` from ``(x0, p0)`` towards ``p_end``.

    ``branch = continuation(f, x0, p0, p_end)``; ``branch.p``, ``branch.x``,
    ``branch.multipliers``, ``branch.stable``, ``branch.bifurcations``.

    Parameters
    ----------
    period_map : PeriodMap or ResidualProblem
        ``(x, p, jacobian) -> (x_T, Phi)`` (:func:`fivebar.numerics.periodic.newmark_map` of a family),
        or a :class:`ResidualProblem` (its zeros R(x, p) = 0 followed instead of fixed points:
        harmonic balance, :class:`fivebar.numerics.harmonic_balance.HarmonicBalanceFamily`).
    x0 : array_like (N,)
        A guess of the orbit at ``p0``; shot first (:func:`fivebar.numerics.periodic.shoot`; for a
        residual problem, Newton's method on R).
    p0, p_end : float
        Start; the continuation stops when ``p`` passes ``p_end`` (the last point is corrected
        onto ``p = p_end``), leaves ``p_bounds``, or after ``max_points`` points.
    ds, ds_min, ds_max : float
        First, smallest and largest arclength step in the scaled variables.
    scale : array_like (N,), optional
        Scale ``d`` of the state (arclength in ``x / d``); default the largest component of
        the orbit shot at ``p0``, for every component.
    p_scale : float
        Scale of the parameter (arclength in ``p / p_scale``).
    tol : float
        Corrector convergence: scaled residual ``||G / d||`` and scaled update below ``tol``
        (relative to ``max(1, ||y||)``).
    max_newton : int
        Corrector iterations before the step is halved.
    dp : float
        Relative forward-difference step of ``G_p`` (of ``max(1, |p / p_scale|)``).
    locate : bool
        Locate the bifurcations (else they are reported at the first point past them).
    locate_tol : float
        Stated tolerance of the location: the arclength bracket (scaled) at the end.
    critical_tol : float
        A located bifurcation is kept only if its critical multiplier lies within this of the
        unit circle (:meth:`Bifurcation.distance`); else it goes to ``Branch.discarded``.
    tangent : array_like (N + 1,), optional
        Initial direction (scaled); default the tangent oriented towards ``p_end``.
    p_bounds : (float, float), optional
        Stop when ``p`` leaves this interval (default the interval of ``p0, p_end``, widened
        by its length on the side of ``p0``, so a branch that turns back at a fold may go on).

    Returns
    -------
    Branch

    Raises
    ------
    ContinuationError
        The step fell below ``ds_min`` (its ``branch`` attribute holds the points so far).
    """
    for name, v in (("ds", ds), ("ds_min", ds_min), ("ds_max", ds_max), ("p_scale", p_scale),
                    ("tol", tol), ("locate_tol", locate_tol), ("critical_tol", critical_tol), ("dp", dp)):
        if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
            raise InputError(f"{name} = {v!r} is not allowed: give a finite positive number")
    if not ds_min <= ds <= ds_max:
        raise InputError(f"ds = {ds!r} is not allowed: it must lie in [ds_min, ds_max] = [{ds_min}, {ds_max}]")
    if not (math.isfinite(p0) and math.isfinite(p_end) and p0 != p_end):
        raise InputError(f"p0 = {p0!r}, p_end = {p_end!r} are not allowed: give two different finite values")
    periods = getattr(period_map, "periods", 1)
    x0 = array("x0", x0, shape=(None,))
    if tangent is not None:
        tangent = array("tangent", tangent, shape=(x0.size + 1,))
        if not np.any(tangent):
            raise InputError(f"tangent = {tangent!r} is not allowed: give a direction (not zero) of shape "
                             f"({x0.size + 1},), the state's {x0.size} components and the parameter")
    if p_bounds is not None:
        try:
            lo, hi = (number("p_bounds", v) for v in p_bounds)
        except (TypeError, ValueError):
            raise InputError(f"p_bounds = {p_bounds!r} is not allowed: give (low, high), two finite numbers, or None") from None
        if not lo < hi or not lo <= p0 <= hi:
            raise InputError(f"p_bounds = {p_bounds!r} is not allowed: give (low, high) with low < high and "
                             f"low <= p0 <= high (p0 = {p0!r}), or None for the default")
        p_bounds = (lo, hi)
    if scale is None:
        orb0 = _first_orbit(period_map, x0, p0, tol=tol)
        big = float(np.abs(orb0.x).max())
        D = np.full(x0.size, big if big > 0 else 1.0)
    else:
        D = np.asarray(scale, float)
        if D.shape != x0.shape or not np.all(D > 0):
            raise InputError(f"scale has shape {D.shape} or non-positive entries: give ({x0.size},) positive values")
        orb0 = _first_orbit(period_map, x0, p0, tol=tol, scale=D)
    x0 = orb0.x
    span = abs(p_end - p0)
    if p_bounds is None:
        p_bounds = (min(p0, p_end) - span * (p0 < p_end), max(p0, p_end) + span * (p0 > p_end))
    prob = _problem_of(period_map, D, float(p_scale), dp)
    prob.count(orb0.periods, orb0.iterations + 1)  # the shooting of the first orbit
    sgn = 1.0 if p_end > p0 else -1.0

    y = np.concatenate([x0 / D, [p0 / p_scale]])
    J, g, Phi = prob.jac(y)
    if tangent is None:
        t = _tangent(J, np.r_[np.zeros(x0.size), sgn])
    else:
        t = _tangent(J, np.asarray(tangent, float))
    prob.orientation = _orientation(J, t)  # the branch's sign of det([J; t^T]) (see _step)
    pts = [BranchPoint(x0.copy(), float(p0), floquet_multipliers(Phi), t, 0.0, 0,
                       float(np.linalg.norm(g)))]
    bifs: list[Bifurcation] = []
    discarded: list[Bifurcation] = []
    Jc = J  # the chord Jacobian (of the last converged point)
    h = float(ds)
    stop = f"max_points = {max_points} reached"
    recoveries: list[tuple[float, str]] = []
    prob.stats["recoveries"] = recoveries
    while len(pts) < max_points:
        yk, tk = y, t
        recovery = ""
        halved = False
        bend = None  # the predictor's second-order term per ds^2: the tangent's turn over the last step, across tk
        if len(pts) > 1 and pts[-1].step > 0:
            c = (tk - pts[-2].tangent) / pts[-1].step
            bend = 0.5 * (c - (c @ tk) * tk)
        while True:
            prob.purpose = "corrector"
            before = dict(prob.stats["by purpose"]["corrector"])
            target = None
            yp = yk + h * tk
            if (yp[-1] * p_scale - p_end) * sgn > 0 and (yk[-1] * p_scale - p_end) * sgn < 0 and tk[-1] * sgn > 0:
                target = p_end / p_scale  # the last point: on p = p_end
            start = yp + h * h * bend if bend is not None and target is None else None
            got = _step(prob, yk, tk, h, Jc, tol, max_newton, target, start=start)
            if got is not None:
                break
            prob.stats["rejected"] += 1
            prob.move(before, "corrector", "rejected")
            h *= 0.5
            halved = True
            if h < ds_min:
                prob.purpose = "recovery"
                got, recovery, h, target = _recover(prob, pts, yk, tk, ds_min, Jc, tol, max_newton, D, p_scale,
                                                    (p_end / p_scale, sgn))
                if got is None:
                    err = ContinuationError(
                        f"continuation: the step fell below ds_min = {ds_min:g} at p = {yk[-1] * p_scale:.8g} "
                        f"after {len(pts)} points (the corrector did not converge in {max_newton} iterations, "
                        f"or a period of the map failed), and no recovery ({', '.join(_RECOVERIES)}) made a step")
                    err.branch = Branch(pts, bifs, periods, D, float(p_scale), prob.stats, str(err), discarded)
                    raise err
                recoveries.append((float(yk[-1] * p_scale), recovery))
                break
        res, dist, (J1, g1, Phi1), t1 = got
        y1, it = res
        mu1 = floquet_multipliers(Phi1)
        step = float(tk @ (y1 - yk))
        q = BranchPoint(D * y1[:-1], float(y1[-1] * p_scale), mu1, t1, step, it, float(np.linalg.norm(g1)),
                        recovery)
        prev = pts[-1]
        pts.append(q)
        Jk, Jc = Jc, J1  # the Jacobians at the last point (the locator's chord) and at the new one
        prob.purpose = "locate"
        found = _detect(prob, prev, q, len(pts) - 2, yk, tk, step, locate, locate_tol, periods, tol, max_newton, Jk)
        if locate and prev.stable != q.stable and not any(
                located and bif.distance() <= critical_tol for bif, located in found):
            # the stability changes between the points and no test function located it (none changed sign, its
            # location failed, or its point had no multiplier on the circle): locate it on the stability itself
            bif, located = _locate_change(prob, prev, q, len(pts) - 2, yk, tk, step, locate_tol, periods, tol,
                                          max_newton, Jk)
            if located and bif.distance() <= critical_tol:  # it replaces the reports at the point past it
                found = [(b, loc) for b, loc in found if loc] + [(bif, True)]
        for bif, located in found:
            (discarded if located and not bif.distance() <= critical_tol else bifs).append(bif)
        y, t = y1, t1
        if target is not None:
            stop = f"p_end = {p_end:g} reached"
            break
        if not p_bounds[0] <= q.p <= p_bounds[1]:
            stop = f"p = {q.p:.6g} left p_bounds = {p_bounds}"
            break
        factor = min(2.0, max(0.5, math.sqrt(0.1 * h / max(dist, 1e-300))))
        if it > max_newton // 2 + 1 or halved:  # (a step just halved: not back at once to the one that failed)
            factor = min(factor, 1.0)
        h = min(ds_max, h * factor)
    return Branch(pts, bifs, periods, D, float(p_scale), prob.stats, stop, discarded)


def _step(prob: _Problem, yk: Array, tk: Array, h: float, Jc: Array, tol: float, max_newton: int,
          target: float | None, **kw):
    """One step from ``yk`` along ``tk``: the corrected point, its distance from the predictor,
    the Jacobian there and its tangent ``((y, iterations), dist, (J, g, Phi), t)``, or None if
    the step is rejected: the corrector fails (:func:`_correct`), it ends farther than half the
    step from the predictor, the Jacobian cannot be made at the new point (a period from it, or
    at ``p + dp``, fails), or the tangent turns by more than 60 degrees (:data:`_MAX_TURN_COS`).
    The new tangent is oriented along the secant from ``yk`` to the new point, not along ``tk``:
    a step that passes a sharp fold then goes on beyond it instead of turning back."""
    res = _correct(prob, yk, tk, h, Jc, tol, max_newton, target, **kw)
    if res is None:
        return None
    yp = yk + h * tk
    dist = float(np.linalg.norm(res[0] - yp))
    if target is None and dist > 0.5 * h:
        return None  # the corrector went far from the predictor (the curve turns too fast)
    before = dict(prob.stats["by purpose"][prob.purpose])
    try:  # the Jacobian at the new point: its multipliers and tangent
        J1, g1, Phi1 = prob.jac(res[0])
    except FivebarError:  # a period from it (or at p + dp) fails: rejected too
        return None
    secant = res[0] - yk
    t1 = _tangent(J1, secant / max(float(np.linalg.norm(secant)), 1e-300))
    if _orientation(J1, t1) != prob.orientation:
        t1 = -t1
    if float(t1 @ tk) < _MAX_TURN_COS:
        return None
    prob.move(before, prob.purpose, "multipliers")
    return res, dist, (J1, g1, Phi1), t1


def _recover(prob: _Problem, pts: list, yk: Array, tk: Array, ds_min: float, Jc: Array, tol: float,
             max_newton: int, D: Array, p_scale: float, end: tuple[float, float]):
    """A step from the last point ``yk`` after the ordinary step failed down to ``ds_min``:
    ``(step, name, h, target)`` (:func:`_step`'s result, the recovery's name, the step made and
    the parameter it was corrected onto, ``end[0]`` when the step passed the end, the scaled
    ``p_end``, in the direction ``end[1]``; else None) or ``(None, "", 0, None)``.  Tried in order (``_RECOVERIES``), each at 4 and then 1 times
    ``ds_min``: *full Newton*, the corrector with a fresh Jacobian at every iteration, damped,
    and three times the iterations; *secant predictor*, the predictor and the constraint along
    the secant through the last two points instead of the tangent (the tangent at a point
    just past a sharp fold can lie off the branch's further course); *natural parameter*, the
    parameter stepped by the tangent's share and the state corrected at that fixed parameter
    (away from a fold, where the tangent's parameter component is not small)."""
    ways = [("full Newton", tk, dict(full=True), 3 * max_newton, False)]
    if len(pts) >= 2:
        prev = np.r_[pts[-2].x / D, pts[-2].p / p_scale]
        sec = yk - prev
        if float(np.linalg.norm(sec)) > 0:
            sec = sec / np.linalg.norm(sec)
            if float(sec @ tk) > 0:
                ways.append(("secant predictor", sec, dict(full=True), 3 * max_newton, False))
    if abs(float(tk[-1])) > 0.1:
        ways.append(("natural parameter", tk, dict(full=True), 3 * max_newton, True))
    p_end, sgn = end
    for name, direction, kw, iters, natural in ways:
        for h in (4.0 * ds_min, ds_min):
            target = float(yk[-1] + h * direction[-1]) if natural else None
            if (yk[-1] + h * direction[-1] - p_end) * sgn > 0 > (yk[-1] - p_end) * sgn and direction[-1] * sgn > 0:
                target = p_end  # the last point: on p = p_end
            got = _step(prob, yk, direction, h, Jc, tol, iters, target, give_up=False, **kw)
            if got is not None and float(got[3] @ tk) >= _MAX_TURN_COS:
                return got, name, h, target if target == p_end else None
    return None, "", 0.0, None


def _correct(prob: _Problem, yk: Array, tk: Array, h: float, Jc: Array, tol: float,
             max_newton: int, target: float | None, start: Array | None = None, give_up: bool = True,
             full: bool = False):
    """Damped chord-Newton corrector from the predictor; ``(y, iterations)`` or None.

    An update whose period fails to integrate, or that multiplies the residual by more than
    10, is halved (three times at most).  The corrector gives up (None: the step is rejected)
    when the full update of a fresh Jacobian fails to integrate a period, or when the full
    updates of two fresh Jacobians in a row do not reduce the residual: Newton's own direction
    then leads out of its basin, and the damped trials and further Jacobians that would follow
    cost about twice as many periods as the halved step, and rarely converge (on the flexible
    orientation's benchmark branch: 84 of the 109 rejected steps that took a fresh Jacobian
    grew the residual with it, against 2 of the 167 accepted ones, and no accepted step had two
    such updates in a row).  ``target``: correct onto ``p = target`` instead of the arclength
    constraint.  ``start``: the first iterate (on the constraint ``tk (y - yk) = h``) instead
    of the tangent predictor ``yk + h tk``.  ``give_up``: False for a point between two points
    of the branch (the locator's trials), which is not abandoned early: there the alternative is
    not a shorter step but a lost location.  ``full``: Newton's method, the Jacobian taken at
    every iterate, instead of the chord iteration."""
    y = yk + h * tk if start is None else np.array(start, float)
    if target is not None:
        y[-1] = target
    row = np.zeros_like(tk)
    row[-1] = 1.0
    B = np.vstack([Jc, row if target is not None else tk])
    refreshed = 0
    grew = 0  # fresh Jacobians in a row whose full update did not reduce the residual
    prev_norm = math.inf

    def residual(y):
        try:
            g = prob.G(y)
        except FivebarError:
            return None
        return g if np.all(np.isfinite(g)) else None

    def constraint(y):
        return (y[-1] - target) if target is not None else float(tk @ (y - yk) - h)

    def fresh(y):
        try:
            J, _, _ = prob.jac(y)
        except FivebarError:
            return None
        return np.vstack([J, row if target is not None else tk])

    g = residual(y)
    if g is None:
        return None
    for it in range(1, max_newton + 1):
        r = np.concatenate([g, [constraint(y)]])
        rn = float(np.linalg.norm(r))
        current = False  # B is the Jacobian at this y
        if full or (rn > 0.2 * prev_norm and refreshed < 2):  # the chord is slow: fresh Jacobian
            B = fresh(y)
            if B is None:
                return None
            refreshed += 1
            current = True
        prev_norm = rn
        floor = tol * max(1.0, float(np.linalg.norm(y[:-1])))
        while True:
            try:
                dy = np.linalg.solve(B, -r)
            except np.linalg.LinAlgError:
                return None
            lam, gt = 1.0, None
            for _ in range(4):
                gt = residual(y + lam * dy)
                rt = None if gt is None else float(np.linalg.norm(np.r_[gt, constraint(y + lam * dy)]))
                if give_up and current and lam == 1.0:  # Newton's own update: out of the basin?
                    if rt is None:
                        return None
                    grew = grew + 1 if rt >= rn else 0
                    if grew >= 2:
                        return None
                if rt is not None and (rt < 10.0 * rn or np.linalg.norm(gt) <= floor):
                    break
                gt = None
                lam *= 0.5
            if gt is not None:
                break
            if current:  # not even the fresh Jacobian's direction reduces the residual
                return None
            B = fresh(y)  # the chord's direction failed: take the Jacobian here
            if B is None:
                return None
            current = True
        y, g = y + lam * dy, gt
        prob.count(newton=1)
        if lam == 1.0 and (np.linalg.norm(g) <= floor or np.linalg.norm(dy) <= tol * max(1.0, np.linalg.norm(y))):
            return y, it
    return None


def _detect(prob, a: BranchPoint, b: BranchPoint, index, yk, tk, step, locate, locate_tol,
            periods, tol, max_newton, Jk=None) -> list[tuple[Bifurcation, bool]]:
    """Bifurcations between the points a and b (b reached from yk along tk with ``step``), each
    with whether it was located (else it is reported at b)."""
    out = []
    ta, tb = _tests(a.multipliers, a.tangent), _tests(b.multipliers, b.tangent)
    changed = {kind: ta[kind] * tb[kind] < 0 for kind in _KINDS}
    # the bialternate determinant also vanishes where two real multipliers have product 1
    changed["Neimark-Sacker"] &= _outside_nonreal(a.multipliers) != _outside_nonreal(b.multipliers)
    for kind in _KINDS:
        if not changed[kind]:
            continue
        fa, fb = ta[kind], tb[kind]
        if locate and math.isfinite(fa) and math.isfinite(fb) and fa * fb < 0:
            out.append(_locate(prob, kind, a, b, index, yk, tk, step, fa, fb, locate_tol, periods, tol, max_newton, Jk))
        else:  # reported at the first point past it
            out.append((Bifurcation(kind, b.p, b.x, b.multipliers, index, (a.p, b.p),
                                    fb, b.tangent, periods), False))
    return out


def _locate_change(prob, a: BranchPoint, b: BranchPoint, index, yk, tk, step, locate_tol, periods, tol,
                   max_newton, Jk=None) -> tuple[Bifurcation, bool]:
    """The change of stability between the points a and b, located where the largest multiplier's
    modulus passes 1 (:func:`_locate` on the test "stability") and named by the multiplier that
    crosses there: +1 a fold (the branch turns: its tangent's parameter component changes sign)
    or a branch point, -1 a period doubling, a non-real one a Neimark-Sacker point."""
    ta, tb = _tests(a.multipliers, a.tangent), _tests(b.multipliers, b.tangent)
    bif, located = _locate(prob, "stability", a, b, index, yk, tk, step, ta["stability"], tb["stability"],
                           locate_tol, periods, tol, max_newton, Jk)
    mu = bif.multipliers
    c = mu[np.argmin(np.abs(np.abs(mu) - 1.0))]  # the one on the circle
    if abs(c.imag) > 1e-6 * max(1.0, abs(c)):
        kind = "Neimark-Sacker"
    elif c.real < 0:
        kind = "period doubling"
    else:
        kind = "fold" if ta["fold"] * tb["fold"] < 0 else "branch point"
    return Bifurcation(kind, bif.p, bif.x, bif.multipliers, bif.index, bif.p_bracket, bif.test, bif.tangent,
                       bif.periods), located


def _locate(prob, kind, a, b, index, yk, tk, step, fa, fb, locate_tol, periods, tol, max_newton, Jc=None):
    """Illinois regula falsi on the arclength s in (0, step); the bifurcation and whether it
    was located (else it is reported at b).  ``Jc``: the Jacobian at ``yk`` (the last point's,
    which the continuation has; else computed here).  Each trial point is corrected from the
    chord between the two corrected points that bracket it (both on the branch and on their
    constraints, so the chord's point at s is on its constraint): nearer the branch than the
    tangent predictor from ``yk``, which on a long step bending through a fold left the
    corrector's basin (on the flexible orientation's benchmark branch a period doubling at
    246.1 r/min was found by its sign change and then lost so)."""
    D, ps = prob.D, prob.ps
    s0, s1 = 0.0, step
    y0, y1 = yk, np.r_[b.x / D, b.p / ps]  # the corrected points at s0, s1
    f0, f1 = fa, fb
    q0, q1 = a.p, b.p  # parameters at s0, s1
    side = 0
    best = None
    failed = 0  # trials whose point or Jacobian could not be made: the next ones inside the bracket
    for _ in range(60):
        if abs(s1 - s0) <= locate_tol:
            break
        s = s1 - f1 * (s1 - s0) / (f1 - f0)
        if not (min(s0, s1) < s < max(s0, s1)):
            s = 0.5 * (s0 + s1)
        if failed:
            s = s0 + (0.5, 0.25, 0.75)[failed - 1] * (s1 - s0)
        if Jc is None:
            Jc, _, _ = prob.jac(yk)
        res = _correct(prob, yk, tk, s, Jc, tol, 3 * max_newton, None,
                       start=y0 + (s - s0) / (s1 - s0) * (y1 - y0), give_up=False)
        J = None
        if res is not None:
            y, _ = res
            try:
                J, g, Phi = prob.jac(y)
            except FivebarError:  # a period from the trial point fails to integrate
                pass
        if J is None:  # no point there, or no Jacobian at it
            failed += 1
            if failed > 3:
                break
            continue
        failed = 0
        t = _tangent(J, tk)
        mu = floquet_multipliers(Phi)
        f = _tests(mu, t)[kind]
        if not math.isfinite(f):
            break
        best = (y, mu, t, f)
        if f * f1 < 0:
            s0, f0, q0, y0 = s1, f1, q1, y1
            side = 0
        else:
            f0 = 0.5 * f0 if side == 1 else f0
            side = 1
        s1, f1, q1, y1 = s, f, float(y[-1] * ps), y
        if abs(f) <= 1e-10:
            s0, q0 = s1, q1
            break
    pl, ph = q0, q1
    if best is None:
        return Bifurcation(kind, b.p, b.x, b.multipliers, index, (a.p, b.p), fb, b.tangent, periods), False
    y, mu, t, f = best
    return Bifurcation(kind, float(y[-1] * ps), D * y[:-1], mu, index, (float(pl), float(ph)), float(f), t,
                       periods), True


def _state_scale(x: NDArray, scale: ArrayLike | None) -> NDArray:
    """The scale of each state entry: ``scale`` checked, or the largest entry of ``x`` (1 when ``x`` is 0)."""
    if scale is None:
        big = float(np.abs(x).max())
        return np.full(x.size, big if big > 0 else 1.0)
    D = np.asarray(scale, float)
    if D.shape != x.shape or not np.all(D > 0):
        raise InputError(f"scale has shape {D.shape} or non-positive entries: give ({x.size},) positive values")
    return D


@one_blas_thread
@checked
def switch_period_doubling(
    period_map: PeriodMap,
    bif: Bifurcation,
    p_end: float,
    *,
    h: float = 1e-2,
    scale: ArrayLike | None = None,
    p_scale: float = 1.0,
    tol: float = 1e-10,
    max_newton: int = 20,
    **kwargs,
) -> Branch:
    r"""Switch onto the period-2 branch at a located period doubling and follow it.

    Parameters
    ----------
    period_map : PeriodMap
        The map of the period-1 branch (its twice-iterated map is built here).
    bif : Bifurcation
        A period doubling of a branch of ``period_map`` (``bif.kind == "period doubling"``).
    p_end : float
        Continue the period-2 branch towards this parameter.  The branch leaves the
        bifurcation towards the side where it exists, whatever ``p_end``; ``p_end`` only
        decides where it stops (on the other side it stops at ``p_bounds`` or
        ``max_points``).
    h : float
        Distance from the bifurcation along the critical eigenvector (scaled) of the first
        period-2 point (the step of the integration failing there is reported as a
        :class:`ContinuationError`).
    scale, p_scale, tol
        As in :func:`continuation` (``scale`` default: the branch's, ``bif`` does not carry it:
        the largest component of the orbit, or 1).
    **kwargs
        Passed to :func:`continuation` (``ds``, ``ds_max``, ``max_points``, ``locate`` ...).

    Returns
    -------
    Branch
        Of the twice-iterated map (``periods`` = 2): its ``x`` are the period-2 orbits'
        states at the start of every other period; the other iterate is ``period_map(x)``.
    """
    if bif.kind != "period doubling":
        raise InputError(f"bif.kind = {bif.kind!r} is not allowed: give a period doubling")
    f2 = iterated_map(period_map, 2)
    x = np.asarray(bif.x, float)
    D = _state_scale(x, scale)
    prob = _Problem(f2, D, float(p_scale), kwargs.get("dp", 1e-6))
    ys = np.concatenate([x / D, [bif.p / p_scale]])
    _, Phi = monodromy(period_map, x, bif.p, D)
    w, V = np.linalg.eig((Phi / D[:, None]) * D[None, :])
    e = np.real(V[:, np.argmin(np.abs(w + 1))])
    e /= np.linalg.norm(e)
    c = np.r_[e, 0.0]
    t1 = bif.tangent
    if t1 is not None and np.size(t1) == c.size:
        c = c - (c @ t1) * t1
        c /= np.linalg.norm(c)
    y = ys + h * c
    ok = False
    g = np.full(x.size, np.nan)
    try:
        for _ in range(max_newton):
            g = prob.G(y)
            r = np.concatenate([g, [c @ (y - ys) - h]])
            if np.linalg.norm(g) <= tol * max(1.0, np.linalg.norm(y[:-1])):
                ok = True
                break
            J = prob.jac(y)[0]
            y = y + np.linalg.solve(np.vstack([J, c]), -r)
    except (FivebarError, np.linalg.LinAlgError):
        ok = False
    if not ok:
        raise ContinuationError(
            f"branch switching at the period doubling p = {bif.p:.8g}: no period-2 orbit found at "
            f"distance h = {h:g} (residual {np.linalg.norm(g):.3e}); try a smaller or larger h")
    x2 = D * y[:-1]
    p2 = float(y[-1] * p_scale)
    x1 = period_map(x2, p2, False)[0]
    if np.linalg.norm((x1 - x2) / D) < 1e-3 * h:
        raise ContinuationError(
            f"branch switching at p = {bif.p:.8g} fell back onto the period-1 branch (h = {h:g}); try a larger h")
    J2 = prob.jac(y)[0]
    t = _tangent(J2, c)
    return continuation(f2, x2, p2, p_end, scale=D, p_scale=p_scale, tol=tol, tangent=t, **kwargs)


@dataclass
class Settled:
    r"""What a march from an unstable periodic orbit settles on (:func:`settle`).

    Attributes
    ----------
    kind : str
        "period-2", "other period-1", "no periodic motion" (of period 1 or 2 within the
        march: quasi-periodic, chaotic or slowly settling) or "diverges" (a period failed or
        the state is no longer finite).
    found : PeriodicOrbit or None
        The orbit it settles on, shot from the last sample: of the twice-iterated map for a
        period-2 orbit (its ``x`` is one of the two iterates, its multipliers those of
        :math:`\mathbf P^2`), of the map for another period-1 orbit; None otherwise.
    samples : ndarray (m, N)
        The Poincaré samples of the march (the disturbed start first; up to the failure for
        a divergence).
    """

    kind: str
    found: PeriodicOrbit | None
    samples: Array


@checked
@one_blas_thread
def settle(period_map: PeriodMap, orbit: PeriodicOrbit, p: float | None = None, *, periods: int = 400,
           scale: ArrayLike | None = None, disturbance: float = 0.01, rtol: float = 1e-4,
           tol: float = 1e-10) -> Settled:
    r"""March the map from an (unstable) orbit and name what it settles on.

    ``s = settle(f, shoot(f, x0, p), p)``; ``s.kind``, ``s.found.multipliers``.

    The start is ``orbit.x + disturbance * d * e`` (the sign of ``disturbance`` picks the side),
    ``e`` the real part of the eigenvector of
    the largest multiplier (in the scaled variables ``x / d``, normalised to a largest entry
    1), ``d`` = ``scale`` (default: the largest entry of ``orbit.x`` for every component, or 1
    where the orbit is 0).  After ``periods`` map applications the last eight samples decide,
    with ``size`` their largest entry: period 2 if every sample repeats the one two before to
    ``rtol * size`` and differs from the one before by more than ``10 rtol * size``; period 1
    if every sample repeats the one before to ``rtol * size``.  The orbit found is then shot
    (:func:`fivebar.numerics.periodic.shoot`, ``tol``) from the last sample, so it is a fixed point of the
    map (or of its square) with its own multipliers, not the march's approximation.
    """
    if isinstance(periods, bool) or int(periods) != periods or periods < 8:
        raise InputError(f"periods = {periods!r} is not allowed: give an integer >= 8")
    for name, v in (("disturbance", disturbance), ("rtol", rtol), ("tol", tol)):
        if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and (v > 0 or name == "disturbance" and v)):
            raise InputError(f"{name} = {v!r} is not allowed: give a finite "
                             + ("non-zero number (its sign picks the side)" if name == "disturbance" else "positive number"))
    x0 = np.asarray(orbit.x, float)
    D = _state_scale(x0, scale)
    w, V = np.linalg.eig((orbit.monodromy / D[:, None]) * D[None, :])
    e = np.real(V[:, np.argmax(np.abs(w))])
    x = x0 + float(disturbance) * D * e / np.abs(e).max()
    xs = [x]
    try:
        for _ in range(int(periods)):
            x = period_map(x, p, False)[0]
            if not np.all(np.isfinite(x)):
                break
            xs.append(x)
    except FivebarError:
        return Settled("diverges", None, np.array(xs))
    xs = np.array(xs)
    if len(xs) <= int(periods):
        return Settled("diverges", None, xs)
    last = xs[-8:]
    size = max(float(np.abs(last).max()), 1e-300)
    one = float(np.abs(last[1:] - last[:-1]).max())
    two = float(np.abs(last[2:] - last[:-2]).max())
    try:
        if two <= rtol * size < 0.1 * one:
            return Settled("period-2", shoot(iterated_map(period_map, 2), last[-1], p, tol=tol, scale=D), xs)
        if one <= rtol * size:
            return Settled("other period-1", shoot(period_map, last[-1], p, tol=tol, scale=D), xs)
    except FivebarError:
        pass  # the samples looked periodic but no orbit is shot from them: not settled
    return Settled("no periodic motion", None, xs)


def orbits_at(branch: Branch, period_map: PeriodMap, p: float, segments=None, tol: float = 1e-10) -> list[PeriodicOrbit]:
    """Every orbit of ``branch`` at the parameter ``p``, shot there.

    One orbit for each segment of the branch (between consecutive points) that contains ``p``
    (of ``segments``, the indices of their first points; default all): shot at ``p`` from the
    state interpolated between the segment's ends, else from the nearer end, else the farther;
    an orbit equal (to 1e-6 of its largest entry) to one already found is not repeated, and a
    segment whose orbit cannot be shot is left out.  Unlike the branch's points, whose places
    depend on the step control, the orbits depend on ``p`` alone: where the branch has folded,
    there are several (three between two folds).
    """
    p = float(p)
    pts = branch.points
    ps = np.array([q.p for q in pts])
    out: list[PeriodicOrbit] = []
    for i in (range(len(ps) - 1) if segments is None else segments):
        lo, hi = sorted((ps[i], ps[i + 1]))
        if not (lo <= p <= hi and hi > lo):
            continue
        w = (p - ps[i]) / (ps[i + 1] - ps[i])
        xa, xb = pts[i].x, pts[i + 1].x
        orb = None
        for x in ((1 - w) * xa + w * xb, *((xa, xb) if w < 0.5 else (xb, xa))):
            try:
                orb = shoot(period_map, x, p, tol=tol, scale=branch.scale)
                break
            except FivebarError:
                orb = None
        if orb is not None and not any(np.abs(orb.x - o.x).max() <= 1e-6 * np.abs(o.x).max() for o in out):
            out.append(orb)
    return out


@dataclass
class Jump:
    """Where a slow sweep of the parameter leaves the branch at a fold (:func:`jumps`).

    Attributes
    ----------
    p : float
        The fold.
    rising : bool
        True: met when the parameter rises past ``p`` (the stable leg lies below ``p``); False:
        when it falls.
    before : float
        The measure of the orbit at the fold.
    after : list of float
        The measures of the stable orbits of the branch just past the fold, where the motion
        lands (empty if the branch has none there: it may land off the branch).
    """

    p: float
    rising: bool
    before: float
    after: list

    @property
    def direction(self) -> str:
        """"up" or "down": the measure grows or falls in the jump (to the nearest stable orbit
        past the fold); "off the branch" if the branch has no stable orbit there."""
        if not self.after:
            return "off the branch"
        target = min(self.after, key=lambda a: abs(a - self.before))
        return "up" if target > self.before else "down"


def jumps(branch: Branch, period_map: PeriodMap, measure, dp: float | None = None) -> list[Jump]:
    r"""The jumps of a slow sweep of the parameter along a branch: one at every fold that ends a
    stable leg.

    ``[(j.p, j.rising, j.direction) for j in jumps(br, f, lambda x, p: abs(x[0]))]``.

    At a fold the stable leg that reaches it (the neighbouring point of the branch that is
    stable) ends; a sweep that goes on past the fold in the same direction must leave for
    another stable orbit.  The orbits of the branch at ``p_fold +- dp`` (the side past the fold,
    :func:`orbits_at`) are shot and the stable ones kept; ``measure(x, p)`` (a number: an
    amplitude, a peak-to-peak) compares them with the fold's orbit.  A hardening oscillator
    jumps down when the parameter (the forcing frequency) rises past its upper fold and up when
    it falls past its lower one; a softening one the other way round.

    Parameters
    ----------
    branch : Branch
    period_map : PeriodMap
        The map the branch follows.
    measure : callable ``(x, p) -> float``
    dp : float, optional
        How far past the fold (default 1e-4 of the branch's parameter range).
    """
    ps = np.array([q.p for q in branch.points])
    if dp is None:
        dp = 1e-4 * max(float(ps.max() - ps.min()), 1e-12)
    out = []
    for b in sorted((b for b in branch.bifurcations if b.kind == "fold"), key=lambda b: b.index):
        before, after_fold = branch.points[b.index], branch.points[b.index + 1]
        if not (before.stable or after_fold.stable):
            continue
        # the branch arrives at the fold with p rising (a maximum of p) or falling (a minimum):
        # the sign of the tangent's p-component at the point before it (p at the points beside a
        # fold may differ from the fold's by less than its location's tolerance)
        maximum = before.tangent[-1] > 0
        side = 1.0 if maximum else -1.0  # the legs lie below a maximum: a rising sweep meets it
        past = b.p + side * dp
        after = [float(measure(o.x, past)) for o in orbits_at(branch, period_map, past) if o.stable]
        out.append(Jump(float(b.p), side > 0, float(measure(b.x, b.p)), after))
    return out


# ==================================================================================================
# Residual problems.  Everything continuation() needs to follow the zeros of R(x, p) = 0 (harmonic
# balance) instead of the fixed points of a period map is in this section: _first_orbit and
# _problem_of choose by the kind of problem, and _ResidualProblem gives the corrector, the step
# control and the bifurcation tests (unchanged) the same G(y) and jac(y) -> (J, g, Phi) as _Problem.
# ==================================================================================================

@runtime_checkable
class ResidualProblem(Protocol):
    """A family of periodic solutions given by a residual R(x, p) = 0, to be continued.

    ``residual(x, p) -> R`` (N,): zero at a solution, measured in the units of x (the
    problem's own scaling: the continuation's tolerances compare it with x);
    ``jacobian(x, p) -> (R_x (N, N), R_p (N,))``; ``monodromy(x, p) -> Phi`` (2 n, 2 n), a
    monodromy matrix whose eigenvalues are the solution's Floquet multipliers (harmonic
    balance: Hill's, :class:`fivebar.numerics.harmonic_balance.HarmonicBalanceFamily`).  ``Branch.stats``
    counts a residual as a "period" and a Jacobian (with its multipliers) as a "monodromy".
    :func:`switch_period_doubling` and :func:`settle` need a period map.
    """

    def residual(self, x: Array, p: float) -> Array: ...

    def jacobian(self, x: Array, p: float) -> tuple[Array, Array]: ...

    def monodromy(self, x: Array, p: float) -> Array: ...


def _problem_of(problem, D: Array, ps: float, dp: float) -> _Problem:
    """The continuation's problem object of a period map or of a residual problem."""
    if isinstance(problem, ResidualProblem):
        return _ResidualProblem(problem, D, ps, dp)
    return _Problem(problem, D, ps, dp)


class _ResidualProblem(_Problem):
    """G = R / D and its Jacobian [R_x, R_p] in the scaled variables, Phi from the problem."""

    def G(self, y):
        x, p = self.D * y[:-1], self.ps * y[-1]
        self.count(1)
        return np.asarray(self.f.residual(x, p), float) / self.D

    def jac(self, y):
        x, p = self.D * y[:-1], self.ps * y[-1]
        self.count(1, 1)
        Rx, Rp = self.f.jacobian(x, p)
        g = np.asarray(self.f.residual(x, p), float) / self.D
        J = np.hstack([np.asarray(Rx, float) * self.D[None, :] / self.D[:, None],
                       (np.asarray(Rp, float) * self.ps / self.D)[:, None]])
        return J, g, np.asarray(self.f.monodromy(x, p), float)


def _first_orbit(problem, x0: Array, p: float, tol: float, scale: Array | None = None,
                 max_iter: int = 30) -> PeriodicOrbit:
    """The first orbit: :func:`fivebar.periodic.shoot` of a period map, or Newton's method on
    R(x, p0) = 0 of a residual problem (a step that does not reduce the scaled residual is
    halved, up to 10 times; converged when the scaled residual is at most ``tol`` of the scaled
    state, as the corrector's test)."""
    if not isinstance(problem, ResidualProblem):
        return shoot(problem, x0, p, tol=tol) if scale is None else shoot(problem, x0, p, tol=tol, scale=scale)
    x = np.array(x0, float)
    D = np.ones_like(x) if scale is None else np.asarray(scale, float)
    count = 1
    g = np.asarray(problem.residual(x, p), float) / D
    for it in range(max_iter + 1):
        r = float(np.linalg.norm(g))
        if r <= tol * max(1.0, float(np.linalg.norm(x / D))):
            return PeriodicOrbit(x, p, np.asarray(problem.monodromy(x, p), float), r, it, count)
        if it == max_iter:
            break
        dx = -np.linalg.solve(np.asarray(problem.jacobian(x, p)[0], float), g * D)
        lam = 1.0
        for _ in range(11):
            gt = np.asarray(problem.residual(x + lam * dx, p), float) / D
            count += 1
            if np.all(np.isfinite(gt)) and np.linalg.norm(gt) < r:
                break
            lam *= 0.5
        else:
            break
        x, g = x + lam * dx, gt
    raise ContinuationError(f"continuation: Newton's method on the residual did not converge at p = {p:.8g} "
                            f"(scaled residual {np.linalg.norm(g):.3e}); give a better x0")

