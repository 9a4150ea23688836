r"""The periodic steady state of (2.7): marching, shooting, and Floquet stability.

The paper obtains "the stable dynamic response" by marching the Newmark scheme (4.1)-(4.4)
from an initial state until the motion repeats (section 4).  Two routes are offered:

* :func:`march`: period after period from a given state, until the change of the state over one
  period, measured in the energy norm
  :math:`\|(\Delta\mathbf u, \Delta\dot{\mathbf u})\|^2 = \Delta\mathbf u^\top\mathbf K
  \Delta\mathbf u + \Delta\dot{\mathbf u}^\top\mathbf M\Delta\dot{\mathbf u}`
  relative to the largest energy norm of the state over the period, is below ``tol``;
* :func:`shooting`: Newton's method on the periodicity condition
  :math:`\mathbf x(T; \mathbf x_0) - \mathbf x_0 = \mathbf 0`, :math:`\mathbf x = (\mathbf u,
  \dot{\mathbf u})`, with the Jacobian :math:`\boldsymbol\Phi - \mathbf I` from the monodromy
  matrix :math:`\boldsymbol\Phi = \partial\mathbf x(T)/\partial\mathbf x_0` of the discrete
  Newmark map (the product of the step tangents).  The eigenvalues of :math:`\boldsymbol\Phi` at
  the periodic orbit are its Floquet multipliers: the orbit is asymptotically stable when all
  lie inside the unit circle.

The average-acceleration rule does not damp modes far above :math:`1/\Delta t` (the links'
axial modes, the curvature DOFs): their one-step amplification tends to :math:`-1`, so over an
even number of steps their multiplier approaches :math:`+1` and :math:`\mathbf I -
\boldsymbol\Phi` becomes ill-conditioned; heavily damped stiff modes behave alike.  The shooting
Newton step is therefore solved in the least-squares sense, and damped: a step that does not
reduce the periodicity residual is halved.  Worse, at S = 100 the paper's rule has an unstable
discrete orbit (errata E26), so the default scheme is the parameter file's dissipative
generalised-alpha method at S = 800 (:class:`fivebar.description.setup.Setup`); the paper's rule is
:data:`fivebar.description.setup.PAPER_SCHEME`.  Errors and unstable results name the scheme and the remedy.

**Cost.**  Shooting factorises its Jacobian once and reuses it (the chord method; for the
linear model one period with the monodromy matrix and one without reach the orbit).  Above
32 DOFs (finer meshes) it applies Newton's step on the lowest frozen modes only and a
fixed-point step on the rest (the Newton-Picard method), which the dissipative scheme
contracts strongly in one period.  ``steady_state(params, tol=0.01)`` chooses S itself for a
requested accuracy of the midpoint deflections: for 1 % it takes S = 100 to 200 up to
600 r/min with the motors off (``benchmarks/bench_story.py``).  A further speed of the same
problem starts from the last speed's orbits and monodromy matrices (see ``steady_state``):
at 300 r/min one or two periods per S, none of them with a monodromy matrix.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from ..cache import STORE
from ..errors import FivebarError, InputError, ValidityWarning, array, flag, number
from ..model.dynamics import LinkageDynamics, linkage_dynamics
from ..numerics.eigen import frozen_modes
from ..numerics.newmark import NewtonConvergenceError, integrate
from ..numerics.periodic import ShootingError, newton_periodic
from ..numerics.schemes import Scheme
from ..description.params import Params
from .response import Response, _problem
from ..description.setup import Setup, analysis, as_setup, default_scheme, min_steps_per_period, scheme_name

__all__ = ["DEFLECTION_LIMIT", "SteadyState", "SteadyStateError", "ValidityWarning", "march", "shooting"]

#: bounds of the iteration limits: :func:`march` periods, :func:`shooting` Newton iterations
MAX_PERIODS, MAX_SHOOTING_ITER = 100_000, 1000


class SteadyStateError(FivebarError, RuntimeError):
    """The periodic steady state was not reached within the allowed periods or iterations."""


#: The small-deflection range of the beam model: the midpoint deflection of a link relative to
#: its chord, divided by the link's length.  At 0.1 the linear (small-deflection) estimate of a
#: cantilever's tip deflection under a tip load is 1 % above the exact elastica (Bisshopp and
#: Drucker, Quart. Appl. Math. 3 (1945) 272-275; a test of the library solves the elastica),
#: and the error grows as the square of the deflection (4 % at 0.2).
DEFLECTION_LIMIT = 0.1
#: An estimated discretisation error (S against 2 S) above this is reported in the note.
ACCURACY_LIMIT = 0.01


@dataclass
class SteadyState(Response):
    """One steady period of the linkage's elastic response: a :class:`fivebar.analyses.response.Response`
    (``t``, ``u``, ``v``, ``dynamics``, ``midpoint_mm``, ``deflection_mm``, ``peak_to_peak_mm``,
    ``bending_stress``) with the data of the periodic orbit.

    Attributes
    ----------
    dynamics
        The :class:`~fivebar.model.dynamics.LinkageDynamics` that was solved.
    t
        Times (s) of the S + 1 samples, from crank angle 0 to one period.
    u, v
        Elastic displacements and velocities of the linkage subsystem, (S + 1, n) (SI).
    method
        "shooting", "march" or "continuation".
    periods
        Periods integrated (march: to reach the tolerance; shooting: in all, Newton included;
        not the one that computes the Floquet multipliers of a nonlinear orbit when asked).
    residual
        The relative periodicity residual (shooting) or change over the last period (march),
        energy norm.
    accuracy
        With ``steady_state(..., tol=...)``: the tolerance asked for, the S compared and the
        estimated error of the midpoint deflections (see :func:`~fivebar.analyses.branches.steady_state`); else None.
    scheme
        The time integrator used.
    setup
        The set-up solved (the problem).
    """

    periods: int = 0
    _floquet: Any = field(default=None, repr=False)
    residual: float = float("nan")
    accuracy: dict | None = None

    @property
    def floquet_multipliers(self) -> NDArray | None:
        """Eigenvalues of the monodromy matrix at the orbit, largest first (None after a march).

        After shooting a nonlinear model they are computed on first access (one more period
        with the monodromy matrix, at the converged orbit; not counted in :attr:`periods`).
        """
        if callable(self._floquet):
            self._floquet = _multipliers(self._floquet())
        return self._floquet

    @property
    def stable(self) -> bool | None:
        """True if every Floquet multiplier lies inside the unit circle (None after a march)."""
        if self.floquet_multipliers is None:
            return None
        return bool(np.abs(self.floquet_multipliers).max() < 1.0)

    @property
    def note(self) -> str:
        """What the stability of the orbit means, naming the scheme (and a remedy if unstable);
        after ``steady_state(..., tol=...)`` also the step it chose and why."""
        chosen = "" if self.accuracy is None else "; " + self.accuracy["choice"]
        outside = self._outside()
        tail = chosen + ("" if not outside else "; OUTSIDE THE MODEL'S VALIDITY: " + "; ".join(outside))
        if self.floquet_multipliers is None:
            return f"reached by marching with {_scheme_text(self.scheme)}; no Floquet multipliers" + tail
        rho = float(np.abs(self.floquet_multipliers).max())
        if rho < 1.0:
            return (f"stable: largest Floquet multiplier {rho:.3g} with {_scheme_text(self.scheme)} at "
                    f"S = {self.dynamics.steps_per_period}" + tail)
        found = self._cache.get("explained")
        found = ("; what a march from it settles on: " + found.text if found is not None else
                 "; steady_state(..., explain=True) names what a march from it settles on")
        return (f"unstable: largest Floquet multiplier {rho:.3g}; " + _remedy(self.scheme, self.dynamics.steps_per_period)
                + found + tail)

    @property
    def explained(self):
        """Where the orbit is unstable and ``steady_state(..., explain=True)`` was asked: what a
        march from it settles on (a :class:`fivebar.analyses.branches.SpeedReport`: its ``kind``,
        ``text``, the orbit ``found``); else None."""
        return self._cache.get("explained")

    @property
    def validity(self) -> dict[str, Any]:
        """The checks a careful analyst makes of this result, and whether it passes them.

        Keys: ``"peak bending stress (MPa)"`` and its ``"stress link"``, ``"yield stress (MPa)"``
        (the file's ``yield_stress``), ``"stress / yield"``; ``"deflection / length"`` (the
        largest midpoint deflection relative to the chord, over the period, divided by the link's
        length) and its ``"deflection link"``, ``"deflection limit"`` (:data:`DEFLECTION_LIMIT`,
        the small-deflection range); ``"largest compression (N)"``, ``"Euler load (N)"`` (the
        lower of the in-plane and out-of-plane Euler loads, pinned ends) and their ratio
        ``"compression / Euler load"`` of the ``"buckling link"``, the link nearest to buckling
        (:meth:`~fivebar.analyses.response.Response.buckling`); ``"speed ratio"`` and ``"period (s)"`` (the drive is
        periodic: :func:`fivebar.description.setup.drive_period`); ``"S error estimate"``, the relative change
        of the transverse midpoint deflections of L2 and L3 from S to ``"S compared"`` (from
        ``steady_state(..., tol=...)``, or computed here at 2 S where it is cheap: the linear
        model up to 32 DOFs; else None until :meth:`check_accuracy`); ``"valid"`` (stress
        below yield, deflection within the limit and compression below the Euler load) and
        ``"reasons"`` (what is outside).
        """
        out = dict(self._checks())
        if self.accuracy is not None:
            est = {"S error estimate": self.accuracy["estimate"],
                   "S compared": (self.accuracy["compared_with"], self.accuracy["steps"])}
        elif "accuracy" in self._cache or (self.dynamics.nonlinear is None and self.dynamics.n <= _DENSE_MAX_DOFS):
            est = self.check_accuracy()
        else:
            est = {"S error estimate": None, "S compared": None}
        out.update(est)
        return out

    def check_accuracy(self) -> dict[str, Any]:
        """The discretisation error of this S estimated against 2 S (one more steady state at
        2 S, by shooting from this orbit); the result is kept in :attr:`validity`."""
        if "accuracy" not in self._cache:
            dyn = self.dynamics
            fine = shooting(self.setup.replace(steps_per_period=2 * dyn.steps_per_period, scheme=self.scheme),
                            self.u[0], self.v[0])
            self._cache["accuracy"] = {"S error estimate": float(_deflection_change(self, fine)),
                                       "S compared": (dyn.steps_per_period, 2 * dyn.steps_per_period)}
        return dict(self._cache["accuracy"])

    def _checks(self) -> dict[str, Any]:
        """The cheap checks of :attr:`validity` (stress, deflection, periodicity)."""
        if "checks" not in self._cache:
            from ..description.setup import drive_period

            p = self.dynamics.params
            stress = self.bending_stress()
            s_link = max(stress, key=stress.get)
            lengths = {k.name: k.length for k in p.linkage.flexible}  # (a rigid link does not deflect)
            defl = {k: float(np.abs(self.midpoint_mm(k, "chord")).max()) * 1e-3 / L for k, L in lengths.items()}
            d_link = max(defl, key=defl.get)
            buck = self.buckling()
            b_link = max(buck, key=lambda k: buck[k]["compression / Euler load"])
            ratio, period = drive_period(p)
            c = {"peak bending stress (MPa)": float(stress[s_link]) / 1e6, "stress link": s_link,
                 "yield stress (MPa)": p.yield_stress / 1e6, "stress / yield": float(stress[s_link]) / p.yield_stress,
                 "deflection / length": defl[d_link], "deflection link": d_link,
                 "deflection limit": DEFLECTION_LIMIT,
                 "largest compression (N)": buck[b_link]["largest compression (N)"],
                 "Euler load (N)": min(buck[b_link]["Euler load in plane (N)"], buck[b_link]["Euler load out of plane (N)"]),
                 "compression / Euler load": buck[b_link]["compression / Euler load"], "buckling link": b_link,
                 "speed ratio": str(ratio), "period (s)": period}
            reasons = []
            if c["stress / yield"] >= 1.0:
                reasons.append(f"peak bending stress {c['peak bending stress (MPa)']:.4g} MPa in {s_link} is "
                               f"above the yield stress {c['yield stress (MPa)']:.4g} MPa (yield_stress)")
            if c["deflection / length"] > DEFLECTION_LIMIT:
                reasons.append(f"the midpoint deflection of {d_link} is {c['deflection / length']:.3g} of its "
                               f"length, past the small-deflection range ({DEFLECTION_LIMIT:g})")
            if c["compression / Euler load"] >= 1.0:
                reasons.append(f"the largest compressive axial force of {b_link}, {c['largest compression (N)']:.4g} N, "
                               f"reaches its Euler load {c['Euler load (N)']:.4g} N (it would buckle)")
            c["valid"] = not reasons
            c["reasons"] = reasons
            self._cache["checks"] = c
        return self._cache["checks"]

    def _outside(self) -> list[str]:
        """What of :attr:`validity` is outside the model's range (the cheap checks, and the
        accuracy estimate where it is known)."""
        out = list(self._checks()["reasons"])
        est = None
        if self.accuracy is not None:
            est = (self.accuracy["estimate"], (self.accuracy["compared_with"], self.accuracy["steps"]))
        elif "accuracy" in self._cache:
            est = (self._cache["accuracy"]["S error estimate"], self._cache["accuracy"]["S compared"])
        if est is not None and est[0] > ACCURACY_LIMIT and self.accuracy is None:
            out.append(f"S = {est[1][0]} is about {100 * est[0]:.2g} % off S = {est[1][1]} on the midpoint "
                       "deflections of the couplers: give a larger steps_per_period or tol")
        return out


def _scheme_text(scheme: Scheme | None) -> str:
    return "an unknown scheme" if scheme is None else scheme_name(scheme)


def _remedy(scheme: Scheme | None, S: int) -> str:
    """Why a march or an orbit may fail because of the scheme, and what to do."""
    if scheme is not None and scheme.rho_infinity >= 1.0:
        return (f"{scheme_name(scheme)} does not damp the unresolved modes, and at S = {S} its discrete "
                "periodic orbit of the time-varying (2.7) can be unstable (errata E26): use the default "
                "scheme (fivebar.Setup(params).scheme, generalised-alpha) or S >= 800")
    return (f"with {_scheme_text(scheme)} at S = {S}: if a finer step (larger steps_per_period) does not "
            "change this, the instability is physical (for example the divergence of the lowest mode, "
            "errata E28)")


def _energy_norm(dyn: LinkageDynamics, u: NDArray, v: NDArray) -> NDArray:
    """sqrt(u K0 u + v M0 v) of a state or of every row of (steps, n) arrays, with K and M at t = 0.

    The products go to BLAS first (``u @ K``): the three-operand ``einsum`` over a period's
    states took 1.4 ms at S = 800 (26 DOFs), this 0.08 ms, and shooting takes it once a period."""
    sd = dyn.step_data
    M, K = sd.M[0], sd.K[0]
    return np.sqrt(np.einsum("...i,...i->...", u @ K, u) + np.einsum("...i,...i->...", v @ M, v))


def _initial_state(dyn: LinkageDynamics) -> tuple[NDArray, NDArray]:
    """Quasi-static state at t = 0: K u + f_nl(u) = F, v = d/dt of it (central difference).

    With the nonlinearity the state solves the nonlinear static equation
    (:meth:`~fivebar.model.dynamics.LinkageDynamics.static_equilibrium`), not the linear K^-1 F: for
    a thin section (2 mm side in plane) the linear deflection lies where f_nl is a hundred
    times the load, and the first step's Newton iteration diverged from it.
    """
    h = dyn.dt
    if dyn.nonlinear is None:  # at the step times -h (= T - h), 0 and h: the sampled K and F
        sd = dyn.step_data
        k = [sd.steps - 1, 0, 1]
        us = np.linalg.solve(sd.K[k], sd.F[k][..., None])[..., 0]
    else:
        u0 = dyn.static_equilibrium(0.0)
        us = [dyn.static_equilibrium(-h, start=u0), u0, dyn.static_equilibrium(h, start=u0)]
    return us[1], (us[2] - us[0]) / (2 * h)


def _period(dyn, u0, v0, scheme, store="all", sensitivity=False, rtol=1e-10, max_iter=20, directions=None):
    """One period of the Newmark map from (u0, v0) at t = 0.

    Newton's iteration of each step: for a small model (up to :data:`_DENSE_MAX_DOFS` DOFs)
    full Newton first (the step's tangent refactorised per iteration: about 1.3 against 3.1
    iterations per step on the default orientation's orbit at S = 100, from the extrapolated
    first iterate of :func:`fivebar.numerics.newmark.integrate`, at the same cost when the linear
    tangent's factors are cached and less where they are not, as at every new speed of a
    continuation; and robust to the large updates of shooting), modified Newton (the cached
    linear tangent) if that fails: from rest the excited stiff modes make the history rough,
    and full Newton can cycle where modified Newton converges; on the flexible orientation
    (S = 800) modified Newton does not converge in the first step of the orbit.  For a larger
    model the order is the other way round: a factorisation costs n^3 against the n^2 of an
    iteration with the cached one (on the (4,8,8,4) mesh, 98 DOFs, one period at S = 100
    takes 24 ms with full Newton and 19 ms with modified Newton, its factors cached).
    """
    kw = dict(step_data=dyn.step_data, store=store, sensitivity=sensitivity, rtol=rtol,
              max_iter=max_iter, directions=directions)
    if dyn.nonlinear is None:
        return integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps_per_period, scheme, newton="full", **kw)
    order = ("full", "modified") if dyn.n <= _DENSE_MAX_DOFS else ("modified", "full")
    try:
        return integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps_per_period, scheme, newton=order[0], **kw)
    except NewtonConvergenceError as first:
        try:
            return integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps_per_period, scheme, newton=order[1], **kw)
        except NewtonConvergenceError as second:
            raise NewtonConvergenceError(
                f"{second} ({order[1]} Newton; {order[0]} Newton failed too: {first})",
                second.t, second.residual, second.iterations) from first


@analysis
def march(
    setup: Setup | Params,
    u0: NDArray | None = None,
    v0: NDArray | None = None,
    tol: float = 1e-6,
    max_periods: int = 2000,
) -> SteadyState:
    """March period by period until the state repeats to ``tol`` (relative, energy norm).

    ``setup`` is the problem, a :class:`fivebar.description.setup.Setup` (its S, scheme, ...) or a
    :class:`fivebar.description.params.Params` (``Setup(params)``).  ``u0, v0`` default to rest (zeros).  Raises :class:`SteadyStateError` after
    ``max_periods`` periods, naming the last relative change, and a
    :class:`~fivebar.numerics.newmark.NewtonConvergenceError` naming the scheme and the remedy if a
    step fails.
    """
    tol = number("tol", tol, low=0.0, low_open=True)
    max_periods = number("max_periods", max_periods, integer=True, low=1, high=MAX_PERIODS)
    dyn, scheme, setup = _problem(setup)
    u = np.zeros(dyn.n) if u0 is None else array("u0", u0, shape=(dyn.n,))
    v = np.zeros(dyn.n) if v0 is None else array("v0", v0, shape=(dyn.n,))
    change = np.inf
    changes: list[float] = []
    for k in range(1, max_periods + 1):
        try:
            res = _period(dyn, u, v, scheme)
        except NewtonConvergenceError as exc:
            raise NewtonConvergenceError(
                f"marching failed in period {k}: {exc}. " + _remedy(scheme, dyn.steps_per_period),
                exc.t, exc.residual, exc.iterations) from exc
        if not (np.all(np.isfinite(res.u[-1])) and np.all(np.isfinite(res.v[-1]))):
            raise SteadyStateError(
                f"the march diverged in period {k}: the state grew past the largest double (it is no longer "
                "finite) from " + ("rest" if u0 is None and v0 is None else "the given u0, v0") + "; "
                + _remedy(scheme, dyn.steps_per_period))
        scale = _energy_norm(dyn, res.u, res.v).max()
        change = float(_energy_norm(dyn, res.u[-1] - u, res.v[-1] - v)) / max(scale, 1e-300)
        u, v = res.u[-1], res.v[-1]
        changes.append(change)
        if change <= tol:
            return SteadyState(dyn, res.t, res.u, res.v, "march", k, residual=change, scheme=scheme)
    # a change still falling steadily is a slow decay (light damping), not an instability
    recent = changes[-min(len(changes), 20):]
    if len(recent) >= 2 and recent[-1] < recent[0] and np.isfinite(recent[-1]):
        rate = (recent[-1] / recent[0]) ** (1.0 / (len(recent) - 1))
        more = int(np.ceil(np.log(tol / change) / np.log(rate))) if rate < 1 else None
        cause = (f"the change is still falling, by a factor {rate:.4g} per period (the transient "
                 "decays slowly: light damping)"
                 + (f", and would reach the tolerance in about {more} more periods" if more else "")
                 + ": give a larger max_periods, or use shooting (steady_state(..., method='shooting'))")
    else:
        cause = _remedy(scheme, dyn.steps_per_period)
    raise SteadyStateError(
        f"no periodic steady state after {max_periods} periods (max_periods): the last relative change "
        f"over one period was {change:.3e} (tolerance {tol:.1e}); " + cause
    )


@analysis
def shooting(
    setup: Setup | Params,
    u0: NDArray | None = None,
    v0: NDArray | None = None,
    tol: float = 1e-10,
    max_iter: int = 20,
) -> SteadyState:
    r"""Damped Newton's method on the periodicity condition, with the Newmark monodromy matrix.

    ``setup`` is the problem, a :class:`fivebar.description.setup.Setup` (its S, scheme, ...) or a
    :class:`fivebar.description.params.Params` (``Setup(params)``).  ``u0, v0`` default to the quasi-static state at t = 0.  Converged when the relative
    periodicity residual (energy norm) is below ``tol``.  A Newton step that does not reduce
    the residual (or whose period fails to integrate) is halved, up to 10 times; where none does
    and the residual is within ten times ``tol``, the orbit is taken as converged to the round-off
    of the period map (its ``residual`` says how far).  The returned
    state carries the Floquet multipliers of the orbit.

    Where Newton's method fails from the start (with a dissipative scheme, as the default), the
    linkage is marched from that start until the change over a period is below 1e-3 (at most
    200 periods) and Newton's method starts again from there: a damped, stable linkage settles
    near its orbit, which Newton's step from the quasi-static state can miss when the
    deflections are large.  ``periods`` then counts the march too.

    The Jacobian :math:`\boldsymbol\Phi - \mathbf I` is factorised once and reused while it
    serves (the chord method): for the linear model :math:`\boldsymbol\Phi` does not depend on
    the state, so one period with the monodromy matrix and one without reach the orbit; with
    the nonlinearity a fresh :math:`\boldsymbol\Phi` is taken when the residual falls by
    less than a factor 10 in a step, or when a step with the old one fails.  The Floquet
    multipliers of a nonlinear orbit are computed when first asked for.
    """
    return _shooting(setup, u0, v0, tol, max_iter)


#: where Newton's method on periodicity fails from its start, :func:`shooting` marches from that
#: start until the change over a period falls below this (relative, energy norm), at most
#: :data:`_SETTLE_PERIODS` periods, and shoots again from where the march got to
_SETTLE_TOL, _SETTLE_PERIODS = 1e-3, 200


def _shooting(setup, u0, v0, tol, max_iter, monodromy: NDArray | None = None) -> SteadyState:
    """:func:`shooting` (see :func:`_newton_orbit`); where Newton's method fails from the start
    (no step along its direction reduces the residual, or it does not converge), and the scheme
    is dissipative, the march from that start settles first (:func:`_settle`) and Newton's method
    starts again from there: the orbit a damped, stable linkage settles on, which the Newton step
    from the quasi-static state can miss when the deflections are large (the steel five-bar of
    ``examples/params/steel_heavy_ratio2.toml``, 2 mm side in the plane, at 60 r/min: six periods
    of march, then five of shooting).  A cold start (no u0, v0) that still fails starts from the
    orbit at S / 2 (:func:`_from_coarser`).  The result is a function of the arguments alone."""
    try:
        return _newton_orbit(setup, u0, v0, tol, max_iter, monodromy)
    except (SteadyStateError, NewtonConvergenceError) as first:
        dyn, scheme, s = _problem(setup)
        try:
            return _settled_orbit(dyn, scheme, s, u0, v0, tol, max_iter, first)
        except (SteadyStateError, NewtonConvergenceError):
            if u0 is None and v0 is None:  # a cold start
                return _from_coarser(s, tol, max_iter, first)
            raise


def _settled_orbit(dyn, scheme, setup, u0, v0, tol, max_iter, first: Exception) -> SteadyState:
    """:func:`_shooting`'s march from the start that Newton's method failed from (``first``, raised
    again where the scheme has no dissipation to settle with), then Newton's method from there."""
    if scheme.rho_infinity >= 1.0:
        raise first
    if u0 is None or v0 is None:
        us, vs = _initial_state(dyn)
        u0 = us if u0 is None else u0
        v0 = vs if v0 is None else v0
    try:
        u, v, k, change = _settle(dyn, scheme, np.asarray(u0, float), np.asarray(v0, float), _SETTLE_TOL,
                                  _SETTLE_PERIODS)
    except (SteadyStateError, NewtonConvergenceError) as exc:
        raise first from exc
    try:
        out = _newton_orbit(setup, u, v, tol, max_iter)
    except (SteadyStateError, NewtonConvergenceError) as second:
        raise SteadyStateError(
            f"{first}; then a march of {k} periods from the same start (last relative change over a period "
            f"{change:.2e}) and shooting from there failed too: {second}") from second
    out.periods += k
    return out


def _from_coarser(setup: Setup, tol, max_iter, first: Exception) -> SteadyState:
    """The cold start's last resort: where neither Newton's method nor a march gets away from the
    quasi-static state at S (the first step's Newton iteration stalls), shoot from the orbit at
    S / 2, as ``steady_state(..., tol=...)`` starts each S from the coarser one (the state at
    t = 0 is a step time of both).  The orbit at S / 2 is itself a cold start (with this resort
    down to the fewest steps the parameters allow).  Found on the flexible orientation at
    30 r/min with 3 % damping (``examples/params/flexible_slow_damped.toml``): at S = 100 the first
    step from the quasi-static state does not converge, from the orbit at S = 50 every step
    does.  Raises ``first`` (the cold start's failure) where S cannot be halved or the coarser
    start fails too."""
    S = setup.steps_per_period
    if S % 2 or S // 2 < min_steps_per_period(setup.params):
        raise first
    try:
        coarse = _shooting(setup.replace(steps_per_period=S // 2), None, None, tol, max_iter)
        out = _newton_orbit(setup, coarse.u[0], coarse.v[0], tol, max_iter)
    except (SteadyStateError, NewtonConvergenceError) as exc:
        raise first from exc
    out.periods += coarse.periods
    return out


def _settle(dyn: LinkageDynamics, scheme: Scheme, u: NDArray, v: NDArray, tol: float,
            max_periods: int) -> tuple[NDArray, NDArray, int, float]:
    """March from (u, v) until the relative change over a period (energy norm) is below ``tol``,
    for at most ``max_periods``, or until the change has not fallen to a new least value for 20
    periods (the motion does not settle): the state reached, the periods and the last change.
    Raises :class:`SteadyStateError` where the motion is no longer finite."""
    change, least, at = np.inf, np.inf, 0
    for k in range(1, max_periods + 1):
        res = _period(dyn, u, v, scheme)
        if not (np.all(np.isfinite(res.u[-1])) and np.all(np.isfinite(res.v[-1]))):
            raise SteadyStateError(f"the march diverged in period {k}")
        scale = _energy_norm(dyn, res.u, res.v).max()
        change = float(_energy_norm(dyn, res.u[-1] - u, res.v[-1] - v)) / max(scale, 1e-300)
        u, v = res.u[-1], res.v[-1]
        if change < least:
            least, at = change, k
        if change <= tol or k - at >= 20:
            break
    return u, v, k, change


def _newton_orbit(setup, u0, v0, tol, max_iter, monodromy: NDArray | None = None) -> SteadyState:
    """Newton's method of :func:`shooting`, optionally started with ``monodromy`` (up to 32 DOFs): a monodromy
    matrix (2 n, 2 n) of a nearby problem (the same model at a neighbouring speed) as the chord
    iteration's first Jacobian; the orbit's own replaces it when a step with it falls short, as
    with a stale one.  The orbit's own monodromy matrix, when one was taken, is kept with the
    result (``_cache["monodromy"]``, for the next problem of a sequence)."""
    _monodromy = monodromy
    tol = number("tol", tol, low=0.0, low_open=True)
    max_iter = number("max_iter", max_iter, integer=True, low=1, high=MAX_SHOOTING_ITER)
    dyn, scheme, setup = _problem(setup)
    n = dyn.n
    if u0 is not None:
        u0 = array("u0", u0, shape=(n,))
    if v0 is not None:
        v0 = array("v0", v0, shape=(n,))
    if u0 is None or v0 is None:
        us, vs = _initial_state(dyn)
        u0 = us if u0 is None else u0
        v0 = vs if v0 is None else v0
    linear = dyn.nonlinear is None
    sd = dyn.step_data
    D = np.sqrt(np.concatenate([np.diag(sd.K[0]), np.diag(sd.M[0])]))
    full = np.diag(1.0 / D)  # every direction of (u, v): Newton's method
    V = _picard_basis(dyn, scheme, D)  # None: the model is small, or the scheme not dissipative
    if V is None:
        V = full

    def evaluate(x, jacobian):
        """Period map at x (an :data:`~fivebar.numerics.periodic.Evaluation`): the state after it,
        monodromy times V (or None), residual, its absolute and relative size (energy norm), the
        period's result."""
        if jacobian:
            res, W = _monodromy_period(dyn, x, scheme, V)
        else:
            res, W = _period(dyn, x[:n], x[n:], scheme), None
        xT = np.concatenate([res.u[-1], res.v[-1]])
        g = xT - x
        a = float(_energy_norm(dyn, g[:n], g[n:]))
        scale = _energy_norm(dyn, res.u, res.v).max()
        if not (np.isfinite(a) and np.isfinite(scale)):
            raise NewtonConvergenceError("the period's motion is not finite", float(dyn.period), np.inf, 0)
        return xT, W, g, a, a / max(scale, 1e-300), res

    x = np.concatenate([np.asarray(u0, float), np.asarray(v0, float)])
    given = _monodromy is not None and V is full and np.shape(_monodromy) == (2 * n, 2 * n)
    try:
        try:
            first = evaluate(x, not given)
            W = first[1]
            if given:
                W = np.asarray(_monodromy, float) / D[None, :]  # Phi V, V = diag(1 / D)
        except NewtonConvergenceError:
            # a non-dissipative scheme can blow up within one period from the quasi-static
            # start (errata E26): start instead from the orbit of the dissipative default
            fallback = default_scheme(dyn.params)
            if scheme.rho_infinity < 1.0 or fallback.rho_infinity >= 1.0:
                raise
            start = shooting(setup.replace(scheme=fallback), u0, v0, tol=tol, max_iter=max_iter)
            x = np.concatenate([start.u[0], start.v[0]])
            first = evaluate(x, True)
            W = first[1]
    except NewtonConvergenceError as exc:
        raise NewtonConvergenceError(
            f"shooting could not integrate the first period: {exc}. " + _remedy(scheme, dyn.steps_per_period),
            exc.t, exc.residual, exc.iterations) from exc
    solve = _given_step(_monodromy, W, V, D) if given else None

    def widen() -> bool:
        """Where the modes left to Picard's iteration decay too slowly: Newton on every direction
        (W is of the reduced basis until the next period with a monodromy matrix)."""
        nonlocal V
        if V is full:
            return False
        V = full
        return True

    try:
        out = newton_periodic(evaluate, x, first, lambda W: _newton_step(W, V, D), tol=tol, max_iter=max_iter,
                              solve=solve, given=given, linear=linear, widen=widen)
    except ShootingError as exc:
        if getattr(exc, "kind", None) == "no step":
            raise SteadyStateError(f"{exc}; " + _remedy(scheme, dyn.steps_per_period)) from None
        raise SteadyStateError(
            f"shooting did not converge in {max_iter} Newton iterations (max_iter): relative periodicity "
            f"residual {exc.residual:.3e} (tolerance {tol:.1e}); if the residual was still falling, give a larger "
            "max_iter or start from a nearby orbit (u0, v0); " + _remedy(scheme, dyn.steps_per_period)) from None
    x, res, W = out.x, out.evaluation[5], out.W
    if out.current and V is full:
        floquet = _Constant(W * D[None, :])  # W = Phi diag(1 / D)
    else:
        floquet = _OrbitMonodromy(dyn, scheme, x)
    st = SteadyState(dyn, res.t, res.u, res.v, "shooting", out.evaluations, floquet, residual=out.residual,
                     scheme=scheme)
    if V is full and out.own:
        st._cache["monodromy"] = W * D[None, :]
    return st


#: shooting takes the whole monodromy matrix up to this many DOFs, and above them (with a
#: dissipative scheme) Newton's method on the lowest frozen modes and Picard's on the rest
_DENSE_MAX_DOFS, _PICARD_MODES = 32, 12


def _picard_basis(dyn: LinkageDynamics, scheme: Scheme, D: NDArray) -> NDArray | None:
    r"""The subspace of the Newton-Picard method, or None for Newton's method on all of (u, v).

    With a dissipative scheme the monodromy matrix contracts every mode but the lowest few
    strongly in one period (Floquet multipliers of 0.13 and below at 300 r/min, 0.47 and
    below at 1200 r/min, largest first; the unresolved modes are damped by the scheme), so
    Newton's method is needed only on the lowest modes and a fixed-point (Picard) iteration
    serves the rest (Lust, Roose, Spence and Champneys 1998, "An adaptive Newton-Picard
    algorithm with subspace iteration for computing periodic solutions", SIAM J. Sci. Comput.
    19: 1188-1209).  The basis is the (u, 0) and (0, v) directions of the
    :data:`_PICARD_MODES` lowest frozen modes at t = 0, orthonormal in the energy scaling D;
    the monodromy matrix is then propagated along 2 x 12 directions instead of 2 n.
    """
    if dyn.n <= _DENSE_MAX_DOFS or scheme.rho_infinity >= 1.0:
        return None
    sd = dyn.step_data
    p = min(_PICARD_MODES, dyn.n)
    K0 = sd.K[0]  # symmetric part: with Kelvin-Voigt damping K holds a small circulatory term
    _, modes = frozen_modes(sd.M[0], 0.5 * (K0 + K0.T), p)
    n = dyn.n
    V = np.zeros((2 * n, 2 * p))
    V[:n, :p], V[n:, p:] = modes, modes
    Q, _ = np.linalg.qr(D[:, None] * V)
    return Q / D[:, None]


def _monodromy_period(dyn: LinkageDynamics, x: NDArray, scheme: Scheme, V: NDArray | None = None,
                      store: str = "all"):
    """One period from x = (u0, v0) and the monodromy matrix ``dx(T) / dx0`` of (u, v) times
    ``V`` (2 n, m) (``None``: the matrix itself).

    Newmark's step carries (u, v); the alpha schemes carry the acceleration too, and only
    directions of (u, v) with a0 following from the equation of motion at t = 0 are
    propagated (:func:`_consistent_directions`), not all 3 n of (u, v, a).
    """
    n = dyn.n
    V = np.eye(2 * n) if V is None else V
    if scheme.is_newmark:
        res = _period(dyn, x[:n], x[n:], scheme, store=store, sensitivity="uv", directions=V)
    else:
        res = _period(dyn, x[:n], x[n:], scheme, store=store, sensitivity="uva",
                      directions=_consistent_directions(dyn, x[:n]) @ V)
    return res, res.monodromy[: 2 * n]


def _consistent_directions(dyn: LinkageDynamics, u0: NDArray) -> NDArray:
    """d(u0, v0, a0) / d(u0, v0), (3 n, 2 n), with a0 = M^-1 (F - C v0 - K u0 - f_nl(u0)) at
    t = 0 (as :func:`~fivebar.numerics.newmark.integrate` starts)."""
    sd = dyn.step_data
    M, C, K = sd.M[0], sd.C[0], sd.K[0]
    if dyn.nonlinear is not None:
        K = K + dyn.nonlinear(u0, 0.0)[1]
    da = -np.linalg.solve(M, np.hstack([K, C]))
    return np.vstack([np.eye(2 * dyn.n), da])


def _newton_step(W: NDArray, V: NDArray, D: NDArray):
    r"""``g -> y``, the (Newton-Picard) step towards x(T) = x from the residual g = x(T) - x.

    ``W`` is the monodromy matrix times the basis ``V`` (2 n, m), orthonormal in the energy
    scaling D.  Along V the step solves :math:`\mathbf V^\top(\boldsymbol\Phi - \mathbf I)\mathbf y
    = -\mathbf V^\top\mathbf g` (Newton), across it the step is the residual itself (Picard);
    with V every direction (``diag(1 / D)``) this is Newton's step with the whole matrix.
    Least squares, factorised once (SVD) for the chord iterations: singular values below
    1e-14 of the largest are dropped, as ``scipy.linalg.lstsq(..., cond=1e-14)`` does (the
    average-acceleration rule leaves multipliers near 1 on the unresolved modes, see the
    module docstring).
    """
    Vs, Ws = D[:, None] * V, D[:, None] * W
    B = Vs.T @ Ws - np.eye(V.shape[1])
    U, sv, Zt = scipy.linalg.svd(B)
    k = int(np.count_nonzero(sv > 1e-14 * sv[0]))
    U, sv, Zt = U[:, :k], sv[:k], Zt[:k]

    def step(g):
        h = D * g
        c = Vs.T @ h
        return (Vs @ (Zt.T @ ((U.T @ -c) / sv)) + (h - Vs @ c)) / D
    return step


def _given_step(Phi: NDArray, W: NDArray, V: NDArray, D: NDArray):
    """:func:`_newton_step` of a given monodromy matrix ``Phi`` (``W = Phi V``), factorised once
    for the same array and scaling (kept in the library's store: a remembered matrix serves
    several speeds)."""
    key = ("steady.given_step", id(Phi))  # the entry holds Phi: its id is not reused meanwhile
    hit = STORE.lookup(key)
    if hit is not None and hit[0] is Phi and np.array_equal(hit[1], D):
        return hit[2]
    solve = _newton_step(W, V, D)
    STORE.put(key, (Phi, D.copy(), solve))
    return solve


def _multipliers(Phi: NDArray) -> NDArray:
    """Eigenvalues of a monodromy matrix, largest modulus first."""
    mult = scipy.linalg.eigvals(Phi)
    return mult[np.argsort(-np.abs(mult))]


class _Constant:
    """A monodromy matrix already at hand (picklable, unlike a lambda)."""

    def __init__(self, Phi: NDArray) -> None:
        self.Phi = Phi

    def __call__(self) -> NDArray:
        return self.Phi


class _OrbitMonodromy:
    """The monodromy matrix at a converged nonlinear orbit, computed when asked for."""

    def __init__(self, dyn: LinkageDynamics, scheme: Scheme, x: NDArray) -> None:
        self.dyn, self.scheme, self.x = dyn, scheme, x

    def __call__(self) -> NDArray:
        return _monodromy_period(self.dyn, self.x, self.scheme, store="last")[1]


#: first S of the doubling sequence of ``steady_state(..., tol=...)``, and the largest it tries
_TOL_FIRST_STEPS, _TOL_MAX_STEPS = 50, 12800


#: a warm start predicts the orbit only within this relative change of the speed
_PREDICT_RANGE = 0.25


def _warm_start(start: SteadyState, s: Setup, method: str, tol: float | None) -> dict:
    """The predictor carried by ``start`` (a result of ``steady_state(..., tol=tol)`` of the same
    set-up at another speed), checked: an error names what does not match."""
    if not isinstance(start, SteadyState):
        raise InputError(f"start = {start!r} is not allowed: give the SteadyState of an earlier "
                         "steady_state(..., tol=...) call of the same set-up at a nearby speed")
    if tol is None or method != "shooting":
        raise InputError("start is not allowed here: a warm start serves steady_state(..., tol=...) with "
                         f"method='shooting' (got tol = {tol!r}, method = {method!r})")
    memo = start._cache.get("orbits")
    if memo is None or memo["tol"] != tol:
        raise InputError(f"start is not allowed: it was not solved by steady_state(..., tol={tol!r}) "
                         "(its orbits at each S are needed)")
    same = dict(crank_speed_rpm=1.0, steps_per_period=100)  # (with tol, the set-up's S is not used)
    if start.setup is None or start.setup.replace(**same) != s.replace(**same):
        raise InputError("start is not allowed: it was solved for another set-up (only the crank speed may "
                         "differ)")
    if abs(s.crank_speed_rpm / memo["rpm"] - 1.0) > _PREDICT_RANGE:
        raise InputError(f"start is not allowed: its speed {memo['rpm']:g} r/min is more than "
                         f"{100 * _PREDICT_RANGE:g} % from {s.crank_speed_rpm:g} r/min")
    return memo


def _to_tolerance(s: Setup, method: str, tol: float, memo: dict | None = None) -> SteadyState:
    """Steady states at S = 50, 100, 200, ... until two successive ones agree to ``tol``.

    Each S starts from the orbit of the coarser S.  With a warm start (``memo``, the orbits of
    a result at a nearby speed of the same problem, :func:`_warm_start`), every S starts from
    that result's orbit at that S, scaled as the quasi-static response scales with the speed (u as its square, v
    as its cube; at the finer S the coarser S's new orbit plus the remembered difference of
    the two), and takes the remembered monodromy matrix of that S as the chord iteration's
    Jacobian: one to three periods without a monodromy matrix per S (where the multipliers
    turn quickly with the speed, as near 600 r/min, a neighbouring speed's matrix falls short;
    from then on that S takes its own, one period with it, and so do the finer S, without
    trying theirs: the modes that turn are resolved at every S, and at 600 r/min the matrix fell
    short at each S of 50, 100, 200, two wasted periods each).  The S tried and chosen
    are those of a first call (50, 100, ...), and the orbits differ from a first call's only
    within the inner tolerance of the orbit (relative periodicity residual 1e-3 ``tol``, at
    most 1e-6).
    """
    inner = min(1e-6, 1e-3 * tol)  # the orbit to well below tol: residual of shooting, change of march
    S_min = max(_TOL_FIRST_STEPS, min_steps_per_period(s.params))
    S = S_min
    solved: list[SteadyState] = []
    stale: set[int] = set() if memo is None else set(memo["stale"])
    prev: SteadyState | None = None
    tried: list[str] = []
    while S <= _TOL_MAX_STEPS:
        sS = s.replace(steps_per_period=S)
        dyn = linkage_dynamics(sS)
        try:
            if method == "shooting":
                if prev is not None:
                    # the coarser orbit, plus the difference of the two S at the last speed; this
                    # S's monodromy matrix at the last speed, or the orbit's own (the coarser S's
                    # is a poor guide: its unresolved modes differ)
                    x = np.concatenate([prev.u[0], prev.v[0]])
                    lo = prev.dynamics.steps_per_period
                    if memo is not None and lo in memo["x"] and S in memo["x"]:
                        x = x + _predict(memo, S, s.crank_speed_rpm) - _predict(memo, lo, s.crank_speed_rpm)
                    n = dyn.n
                    start = (x[:n], x[n:])
                elif memo is not None and S in memo["x"]:  # the remembered orbit, scaled to this speed
                    x, n = _predict(memo, S, s.crank_speed_rpm), dyn.n
                    start = (x[:n], x[n:])
                else:
                    start = (None, None)
                # the last speed's monodromy matrix of this S as the first Jacobian, unless it fell
                # short at this S or a coarser one, in this call or before (the modes whose multipliers
                # turn quickly with the speed are resolved at every S: the finer S take their own too)
                short = any(k <= S for k in stale)
                Phi = None if memo is None or start[0] is None or short else memo["monodromy"].get(S)
                cur = _shooting(sS, *start, inner, shooting.__wrapped__.__defaults__[3],  # its max_iter
                                monodromy=Phi)
                if Phi is not None and "monodromy" in cur._cache:
                    stale.add(S)  # the last speed's matrix fell short: this S and the finer take their own
            else:
                cur = march(sS, tol=inner)
        except (NewtonConvergenceError, SteadyStateError) as exc:
            tried.append(f"S = {S}: failed ({type(exc).__name__})")
            prev, S = None, 2 * S
            continue
        solved.append(cur)
        if prev is not None:
            err = _deflection_change(prev, cur)
            tried.append(f"S = {prev.dynamics.steps_per_period} to {S}: {err:.2e}")
            if err <= tol:
                cur.accuracy = {
                    "tol": tol, "estimate": err, "steps": S, "compared_with": prev.dynamics.steps_per_period,
                    "method": method, "tried": tried,
                    "choice": (f"S = {S} chosen for tol = {tol:g} ({method}): the transverse midpoint "
                               f"deflections of {' and '.join(s.params.linkage.couplers)} changed by at most "
                               f"{err:.2g} of their peak-to-peak "
                               f"value from S = {prev.dynamics.steps_per_period} to S = {S}")}
                if method == "shooting":
                    cur._cache["orbits"] = _orbits(memo, tol, s.crank_speed_rpm, solved, stale)
                return cur
        prev, S = cur, 2 * S
    raise SteadyStateError(
        f"no S up to {_TOL_MAX_STEPS} reaches tol = {tol:g} on the midpoint deflections of "
        f"{' and '.join(s.params.linkage.couplers)} "
        f"({'; '.join(tried)}); ask for a larger tol, or solve at a given S (steps_per_period)")


def _scaled(x: NDArray, ratio: float) -> NDArray:
    """A state (u, v) at t = 0 scaled to a speed ``ratio`` times its own, as the quasi-static
    response scales (u with the square of the speed, v = du/dt with its cube)."""
    n = len(x) // 2
    return np.concatenate([ratio ** 2 * x[:n], ratio ** 3 * x[n:]])


def _predict(memo: dict, S: int, rpm: float) -> NDArray:
    """The orbit's state at t = 0 at ``rpm`` and S from the remembered ones: the last speed's,
    scaled (:func:`_scaled`), and with the speed before it (when it lies on the same side, no
    farther than twice the step) the secant through the two scaled states."""
    x1, rpm1 = memo["x"][S], memo["rpm"]
    z = _scaled(x1, 1.0 / rpm1)
    before = memo.get("before")
    if before is not None and S in before["x"]:
        step = rpm1 - before["rpm"]
        if step != 0.0 and 0.0 < (rpm - rpm1) / step <= 2.0:
            z = z + (rpm - rpm1) / step * (z - _scaled(before["x"][S], 1.0 / before["rpm"]))
    return _scaled(z, rpm)


def _orbits(memo: dict | None, tol: float, rpm: float, solved: list[SteadyState], stale: set[int]) -> dict:
    """The orbits solved at ``rpm`` (and their monodromy matrices; where none was taken, the
    warm start's stays) as the predictor of a next speed (``steady_state(..., start=)``), with
    the S at which a neighbouring speed's matrix proved too stale to serve."""
    out = {"tol": tol, "rpm": rpm, "x": {}, "monodromy": {} if memo is None else dict(memo["monodromy"]),
           "stale": set(stale), "before": None if memo is None else {"rpm": memo["rpm"], "x": memo["x"]}}
    for r in solved:
        S = r.dynamics.steps_per_period
        out["x"][S] = np.concatenate([r.u[0], r.v[0]])
        if "monodromy" in r._cache:  # else the one of an earlier speed stays (the chord method's guide)
            out["monodromy"][S] = r._cache["monodromy"]
    return out


def _deflection_change(coarse: SteadyState, fine: SteadyState) -> float:
    """Largest change of the transverse midpoint deflection of L2 and L3 from ``coarse`` (S) to
    ``fine`` (2 S) at the S + 1 common samples, relative to the finer peak-to-peak value."""
    out = 0.0
    for link in fine.dynamics.params.linkage.couplers:  # the links between two pins (Figure 6: L2, L3)
        yc, yf = coarse.midpoint_mm(link), fine.midpoint_mm(link)
        out = max(out, float(np.abs(yc - yf[::2]).max() / max(np.ptp(yf), 1e-300)))
    return out
