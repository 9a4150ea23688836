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
generalised-alpha method at S = 800 (:class:`fivebar.setup.Setup`); the paper's rule is
:data:`fivebar.setup.PAPER_SCHEME`.  Errors and unstable results name the scheme and the remedy.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from .errors import FivebarError, InputError
from .dynamics import LinkageDynamics
from .elements import shape_functions
from .kinematics import LINKS
from .newmark import NewtonConvergenceError, Scheme, integrate
from .params import Params
from .setup import Setup, as_setup, default_scheme, scheme_name

__all__ = ["SteadyState", "SteadyStateError", "march", "shooting", "steady_state"]

_DIRECTIONS = ("transverse", "longitudinal", "chord")


class SteadyStateError(FivebarError, RuntimeError):
    """The periodic steady state was not reached within the allowed periods or iterations."""


@dataclass
class SteadyState:
    """One steady period of the linkage's elastic response.

    Attributes
    ----------
    dynamics
        The :class:`~fivebar.dynamics.LinkageDynamics` that was solved.
    t
        Times (s) of the S + 1 samples, from crank angle 0 to one period.
    u, v
        Elastic displacements and velocities of the linkage subsystem, (S + 1, n) (SI).
    method
        "shooting" or "march".
    scheme
        The time integrator used.
    periods
        Periods integrated (march: to reach the tolerance; shooting: in all, Newton included).
    floquet_multipliers
        Eigenvalues of the monodromy matrix at the orbit (shooting only), largest first.
    """

    dynamics: LinkageDynamics
    t: NDArray
    u: NDArray
    v: NDArray
    method: str
    periods: int
    floquet_multipliers: NDArray | None = None
    residual: float = float("nan")
    scheme: Scheme | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def crank_angle(self) -> NDArray:
        """Angle of crank AB (deg) from its initial angle, at the samples."""
        return np.degrees(self.t * self.dynamics.params.crank_speed)

    @property
    def stable(self) -> bool | None:
        """True if every Floquet multiplier lies inside the unit circle (None after a march)."""
        if self.floquet_multipliers is None:
            return None
        return bool(np.abs(self.floquet_multipliers).max() < 1.0)

    @property
    def note(self) -> str:
        """What the stability of the orbit means, naming the scheme (and a remedy if unstable)."""
        if self.floquet_multipliers is None:
            return f"reached by marching with {_scheme_text(self.scheme)}; no Floquet multipliers"
        rho = float(np.abs(self.floquet_multipliers).max())
        if rho < 1.0:
            return f"stable: largest Floquet multiplier {rho:.3g} with {_scheme_text(self.scheme)} at S = {self.dynamics.steps}"
        return f"unstable: largest Floquet multiplier {rho:.3g}; " + _remedy(self.scheme, self.dynamics.steps)

    def _angles(self):
        return self.dynamics.crank_angles(self.t)

    def midpoint(self, link: str, direction: str = "transverse") -> NDArray:
        """Elastic displacement of the midpoint of a link over the period (mm).

        Parameters
        ----------
        link
            "L1", "L2", "L3" or "L4" (Figure 6 shows L2 and L3).
        direction
            "transverse": the midpoint's elastic displacement projected on the link's normal
            (the left normal of B to C for L2, C to D for L3); it includes the elastic motion
            of the link's end joints.  "longitudinal": projected on the link's axis.  "chord":
            the transverse deflection relative to the chord through the link's deflected ends
            (pure bending, what a mid-span strain gauge senses).
        """
        if link not in LINKS:
            raise InputError(f"link = {link!r} is not allowed: use one of {list(LINKS)}")
        if direction not in _DIRECTIONS:
            raise InputError(f"direction = {direction!r} is not allowed: use one of {list(_DIRECTIONS)}")
        m = self.dynamics.model
        U = self.dynamics.expand(self.u)
        th1, th4 = self._angles()
        ax, tr = m.link_displacement(U, th1, th4, link, 0.5)
        if direction == "longitudinal":
            return 1e3 * ax
        if direction == "transverse":
            return 1e3 * tr
        _, tr0 = m.link_displacement(U, th1, th4, link, 0.0)
        _, tr1 = m.link_displacement(U, th1, th4, link, 1.0)
        return 1e3 * (tr - 0.5 * (tr0 + tr1))

    def peak_to_peak(self, link: str, direction: str = "transverse") -> float:
        """Peak-to-peak value (mm) of :meth:`midpoint` over the period."""
        y = self.midpoint(link, direction)
        return float(y.max() - y.min())

    def bending_stress(self, points: int = 11) -> dict[str, float]:
        """Peak bending stress (Pa) of each link over the period.

        sigma = E (d/2) abs(w'') with d the in-plane depth of the section (assumption
        ``bending_depth``), w'' the elastic curvature evaluated at ``points`` points of every
        element and at every sample of the period.
        """
        key = ("stress", points)
        if key not in self._cache:
            dyn = self.dynamics
            m, p = dyn.model, dyn.params
            th1, th4 = self._angles()
            q = m.element_displacements(dyn.expand(self.u), th1, th4)  # (S+1, nel, 8)
            out: dict[str, float] = {}
            for i, el in enumerate(m.elements):
                N2 = shape_functions(np.linspace(0.0, el.length, points), el.length, derivative=2)
                N2[:, [0, 4]] = 0.0
                kappa = np.abs(q[:, i, :] @ N2.T).max()
                out[el.link] = max(out.get(el.link, 0.0), p.E * 0.5 * p.bending_depth * kappa)
            self._cache[key] = out
        return dict(self._cache[key])


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


def _dynamics_and_scheme(dyn, scheme: Scheme | None):
    """Accept a LinkageDynamics, a Setup or a Params; return the dynamics and the scheme."""
    if isinstance(dyn, LinkageDynamics):
        return dyn, default_scheme(dyn.params) if scheme is None else scheme
    s = as_setup(dyn, scheme=scheme)
    return s.dynamics(), s.scheme


def _energy_norm(dyn: LinkageDynamics, u: NDArray, v: NDArray) -> NDArray:
    sd = dyn.step_data
    M, K = sd.M[0], sd.K[0]
    return np.sqrt(np.einsum("...i,ij,...j->...", u, K, u) + np.einsum("...i,ij,...j->...", v, M, v))


def _initial_state(dyn: LinkageDynamics) -> tuple[NDArray, NDArray]:
    """Quasi-static state at t = 0: K u + f_nl(u) = F, v = d/dt of it (central difference).

    With the nonlinearity the state solves the nonlinear static equation
    (:meth:`~fivebar.dynamics.LinkageDynamics.static_equilibrium`), not the linear K^-1 F: for
    a thin section (2 mm side in plane) the linear deflection lies where f_nl is a hundred
    times the load, and the first step's Newton iteration diverged from it.
    """
    h = dyn.dt
    if dyn.nonlinear is None:
        us = dyn.quasi_static(np.array([-h, 0.0, h]))
    else:
        us = [dyn.static_equilibrium(t) for t in (-h, 0.0, h)]
    return us[1], (us[2] - us[0]) / (2 * h)


def _period(dyn, u0, v0, scheme, store="all", sensitivity=False, rtol=1e-10, max_iter=20):
    """One period of the Newmark map from (u0, v0) at t = 0.

    Newton: full first (the step's tangent refactorised per iteration: for this small system
    cheaper than the extra force evaluations of modified Newton, about 2 against 3.7
    iterations per step on the orbit, and robust to the large updates of shooting), modified
    Newton (the cached linear tangent) if that fails: from rest the excited stiff modes make
    the a_{n+1} = a_n predictor poor, and full Newton can cycle where modified Newton converges.
    """
    kw = dict(step_data=dyn.step_data, store=store, sensitivity=sensitivity, rtol=rtol,
              max_iter=max_iter)
    try:
        return integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps, scheme, newton="full", **kw)
    except NewtonConvergenceError as first:
        if dyn.nonlinear is None:
            raise
        try:
            return integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps, scheme, newton="modified", **kw)
        except NewtonConvergenceError as second:
            raise NewtonConvergenceError(
                f"{second} (modified Newton; full Newton failed too: {first})",
                second.t, second.residual, second.iterations) from first


def march(
    dyn: LinkageDynamics | Setup | Params,
    u0: NDArray | None = None,
    v0: NDArray | None = None,
    tol: float = 1e-6,
    max_periods: int = 2000,
    scheme: Scheme | None = None,
) -> SteadyState:
    """March period by period until the state repeats to ``tol`` (relative, energy norm).

    ``dyn`` is a :class:`~fivebar.dynamics.LinkageDynamics`, a :class:`fivebar.setup.Setup` or a
    :class:`fivebar.params.Params`; ``scheme`` defaults to the set-up's (the parameter file's).
    ``u0, v0`` default to rest (zeros).  Raises :class:`SteadyStateError` after
    ``max_periods`` periods, naming the last relative change, and a
    :class:`~fivebar.newmark.NewtonConvergenceError` naming the scheme and the remedy if a
    step fails.
    """
    if not tol > 0:
        raise InputError(f"tol = {tol!r} is not allowed: give a positive relative tolerance")
    dyn, scheme = _dynamics_and_scheme(dyn, scheme)
    u = np.zeros(dyn.n) if u0 is None else np.asarray(u0, float)
    v = np.zeros(dyn.n) if v0 is None else np.asarray(v0, float)
    change = np.inf
    for k in range(1, max_periods + 1):
        try:
            res = _period(dyn, u, v, scheme)
        except NewtonConvergenceError as exc:
            raise NewtonConvergenceError(
                f"marching failed in period {k}: {exc}. " + _remedy(scheme, dyn.steps),
                exc.t, exc.residual, exc.iterations) from exc
        scale = _energy_norm(dyn, res.u, res.v).max()
        change = float(_energy_norm(dyn, res.u[-1] - u, res.v[-1] - v)) / max(scale, 1e-300)
        u, v = res.u[-1], res.v[-1]
        if change <= tol:
            return SteadyState(dyn, res.t, res.u, res.v, "march", k, residual=change, scheme=scheme)
    raise SteadyStateError(
        f"no periodic steady state after {max_periods} periods: the last relative change over "
        f"one period was {change:.3e} (tolerance {tol:.1e}); " + _remedy(scheme, dyn.steps)
    )


def shooting(
    dyn: LinkageDynamics | Setup | Params,
    u0: NDArray | None = None,
    v0: NDArray | None = None,
    tol: float = 1e-10,
    max_iter: int = 20,
    scheme: Scheme | None = None,
) -> SteadyState:
    """Damped Newton's method on the periodicity condition, with the Newmark monodromy matrix.

    ``dyn`` is a :class:`~fivebar.dynamics.LinkageDynamics`, a :class:`fivebar.setup.Setup` or a
    :class:`fivebar.params.Params`; ``scheme`` defaults to the set-up's (the parameter file's).
    ``u0, v0`` default to the quasi-static state at t = 0.  Converged when the relative
    periodicity residual (energy norm) is below ``tol``.  A Newton step that does not reduce
    the residual (or whose period fails to integrate) is halved, up to 10 times.  The returned
    state carries the Floquet multipliers of the orbit.
    """
    if not tol > 0:
        raise InputError(f"tol = {tol!r} is not allowed: give a positive relative tolerance")
    dyn, scheme = _dynamics_and_scheme(dyn, scheme)
    if u0 is None or v0 is None:
        us, vs = _initial_state(dyn)
        u0 = us if u0 is None else u0
        v0 = vs if v0 is None else v0
    n = dyn.n
    mode = "uv" if scheme.is_newmark else "uva"
    sd = dyn.step_data
    D = np.sqrt(np.concatenate([np.diag(sd.K[0]), np.diag(sd.M[0])]))

    def evaluate(x):
        """Period map at x: the result, the (u, v) monodromy, the absolute and relative residual."""
        res = _period(dyn, x[:n], x[n:], scheme, sensitivity=mode)
        Phi = res.monodromy[: 2 * n, : 2 * n] if mode == "uv" else _uv_monodromy(dyn, res.monodromy, n)
        g = np.concatenate([res.u[-1], res.v[-1]]) - x
        a = float(_energy_norm(dyn, g[:n], g[n:]))
        scale = _energy_norm(dyn, res.u, res.v).max()
        if not (np.isfinite(a) and np.isfinite(scale)):
            raise NewtonConvergenceError("the period's motion is not finite", float(dyn.period), np.inf, 0)
        return res, Phi, g, a, a / max(scale, 1e-300)

    x = np.concatenate([np.asarray(u0, float), np.asarray(v0, float)])
    try:
        try:
            res, Phi, g, a, r = evaluate(x)
        except NewtonConvergenceError:
            # a non-dissipative scheme can blow up within one period from the quasi-static
            # start (errata E26): start instead from the orbit of the dissipative default
            fallback = default_scheme(dyn.params)
            if scheme.rho_infinity < 1.0 or fallback.rho_infinity >= 1.0:
                raise
            start = shooting(dyn, u0, v0, tol=tol, max_iter=max_iter, scheme=fallback)
            x = np.concatenate([start.u[0], start.v[0]])
            res, Phi, g, a, r = evaluate(x)
    except NewtonConvergenceError as exc:
        raise NewtonConvergenceError(
            f"shooting could not integrate the first period: {exc}. " + _remedy(scheme, dyn.steps),
            exc.t, exc.residual, exc.iterations) from exc
    periods = 1
    for it in range(1, max_iter + 1):
        if r <= tol:
            mult = scipy.linalg.eigvals(Phi)
            mult = mult[np.argsort(-np.abs(mult))]
            return SteadyState(dyn, res.t, res.u, res.v, "shooting", periods, mult, residual=r, scheme=scheme)
        # Newton step on the periodicity condition, scaled so that every DOF counts by its
        # energy (the state mixes metres, radians and curvatures)
        A = D[:, None] * (Phi - np.eye(2 * n)) / D[None, :]
        y = scipy.linalg.lstsq(A, -D * g, cond=1e-14)[0] / D
        lam = 1.0
        for _ in range(11):
            try:
                trial = evaluate(x + lam * y)
                periods += 1
                if trial[3] < a or trial[4] <= tol:
                    break
            except NewtonConvergenceError:
                periods += 1
            lam *= 0.5
        else:
            raise SteadyStateError(
                f"shooting: no step along the Newton direction (halved 10 times) reduces the "
                f"periodicity residual {r:.3e} in iteration {it}; " + _remedy(scheme, dyn.steps)
            )
        x = x + lam * y
        res, Phi, g, a, r = trial
    if r <= tol:
        mult = scipy.linalg.eigvals(Phi)
        mult = mult[np.argsort(-np.abs(mult))]
        return SteadyState(dyn, res.t, res.u, res.v, "shooting", periods, mult, residual=r, scheme=scheme)
    raise SteadyStateError(
        f"shooting did not converge in {max_iter} Newton iterations: relative periodicity "
        f"residual {r:.3e} (tolerance {tol:.1e}); " + _remedy(scheme, dyn.steps)
    )


def _uv_monodromy(dyn: LinkageDynamics, Phi3: NDArray, n: int) -> NDArray:
    """Reduce d(u, v, a)_T / d(u, v, a)_0 to (u, v) with a_0 consistent with the equation."""
    sd = dyn.step_data
    M, C, K = sd.M[0], sd.C[0], sd.K[0]
    da = -np.linalg.solve(M, np.hstack([K, C]))  # d a0 / d(u0, v0), linear part
    E = np.vstack([np.eye(2 * n), da])
    return (Phi3 @ E)[: 2 * n]


def steady_state(
    setup: Setup | Params,
    method: str = "shooting",
    steps_per_period: int | None = None,
    crank_speed_rpm: float | None = None,
    motors: bool | None = None,
    nonlinear: bool | None = None,
    scheme: Scheme | None = None,
    elements_per_link: tuple[int, int, int, int] | None = None,
) -> SteadyState:
    """The periodic steady state of the linkage over one period of the motion.

    ``res = steady_state(params)`` or ``steady_state(fivebar.Setup(params, ...))``;
    ``res.midpoint("L2", "transverse")`` (mm over the S + 1 samples from crank angle 0),
    ``res.floquet_multipliers``, ``res.stable``, ``res.note``, ``res.bending_stress()`` (Pa).

    Parameters
    ----------
    setup
        A :class:`fivebar.setup.Setup`, or a :class:`fivebar.params.Params` (all other settings from the
        parameter file: S = ``steps_per_period``, the ``[simulation] scheme``).
    method
        "shooting" (damped Newton on periodicity, with Floquet multipliers) or "march" (period
        by period from rest).
    steps_per_period, crank_speed_rpm, motors, nonlinear, scheme, elements_per_link
        Override the set-up's fields (``None`` keeps them): see :class:`fivebar.setup.Setup`.  The
        paper's rule is ``scheme=fivebar.PAPER_SCHEME``.
    """
    if method not in ("shooting", "march"):
        raise InputError(f"method = {method!r} is not allowed: use 'shooting' or 'march'")
    s = as_setup(setup, steps_per_period=steps_per_period, crank_speed_rpm=crank_speed_rpm, motors=motors,
                 nonlinear=nonlinear, scheme=scheme, elements_per_link=elements_per_link)
    if method == "shooting":
        return shooting(s)
    return march(s)
