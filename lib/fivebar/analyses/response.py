r"""One result type for the linkage's elastic motion in time.

A :class:`Response` holds the samples of a motion of the linkage subsystem of (2.7): the
times ``t``, the elastic displacements ``u`` and velocities ``v`` of the kept DOFs, and the
:class:`~fivebar.model.dynamics.LinkageDynamics` they belong to, and reads them as an engineer
does: the displacement of a point of a link (:meth:`Response.deflection_mm`, the midpoint
:meth:`Response.midpoint_mm` that Figure 6 shows), its peak-to-peak value, the peak bending
stress of every link (:func:`fivebar.book.plotting.response_plot` draws it).  Every computation in time returns one, as python-control's
``TimeResponseData`` serves every simulation:

* the periodic steady state (:func:`fivebar.analyses.steady.shooting`, :func:`fivebar.analyses.steady.march`,
  :func:`fivebar.analyses.branches.steady_state`, a point of a branch): a
  :class:`fivebar.analyses.steady.SteadyState`, a Response with the Floquet data, accuracy, note and
  validity of the orbit;
* a transient from a given state (:func:`transient`): the Newmark march without the
  periodicity condition;
* the quasi-static deflection :math:`\mathbf K(t)^{-1}\mathbf F(t)` (:func:`quasi_static`);
* scipy's implicit Radau integrator on the first-order form of (2.7) (:func:`radau`), the
  independent reference of the Newmark solution;
* the multiple-scales first approximation (3.6)-(3.7)
  (:class:`fivebar.analyses.linkage_multiscale.MultipleScalesResponse`).

A Response can also be built from any displacement field of the kept DOFs:
``Response(dyn, t, u, v, "modal quasi-static")``.  The multibody model's result
(:class:`fivebar.analyses.multibody.MultibodySteadyState`) has the same accessor names.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..cache import memoised
from ..model.dynamics import LinkageDynamics, linkage_dynamics
from ..model.elements import euler_loads, shape_functions
from ..model.nonlinear import _slopes
from ..errors import ComputationError, InputError, array, number
from ..numerics.newmark import integrate
from ..numerics.schemes import Scheme
from ..description.params import Params
from ..description.setup import Setup, analysis, as_setup

__all__ = ["DIRECTIONS", "Response", "quasi_static", "radau", "transient"]

#: the directions of :meth:`Response.deflection_mm` and :meth:`Response.midpoint_mm`
DIRECTIONS = ("transverse", "longitudinal", "chord")
#: bound of the periods of :func:`transient`
MAX_TRANSIENT_PERIODS = 100_000


@dataclass
class Response:
    """The linkage's elastic motion at a sequence of times.

    Attributes
    ----------
    dynamics
        The :class:`~fivebar.model.dynamics.LinkageDynamics` whose kept DOFs ``u`` and ``v`` are.
    t
        Times (s) of the N samples.
    u, v
        Elastic displacements and velocities of the linkage subsystem, (N, n) (SI).
    method
        What computed it: "shooting", "march", "continuation" (steady states), "transient",
        "quasi-static", "radau", "multiple scales", or the name given.
    scheme
        The time integrator (None where none was used).
    solver
        The integrator's own record, where there is one (the
        :class:`fivebar.numerics.newmark.NewmarkResult` of a transient, with its Newton iterations per
        step; scipy's ``OdeResult`` of :func:`radau`), else None.
    """

    dynamics: LinkageDynamics
    t: NDArray
    u: NDArray
    v: NDArray
    method: str = "response"
    scheme: Scheme | None = field(default=None, kw_only=True)
    solver: Any = field(default=None, repr=False, kw_only=True)
    _cache: dict = field(default_factory=dict, repr=False, kw_only=True)

    def __post_init__(self) -> None:
        if not isinstance(self.dynamics, LinkageDynamics):
            raise InputError(f"dynamics = {type(self.dynamics).__name__} is not allowed: give a "
                             "fivebar.model.dynamics.LinkageDynamics (linkage_dynamics(Setup(...)))")
        n = self.dynamics.n
        self.t = array("t", self.t, shape=(None,))
        N = len(self.t)
        self.u = array("u", self.u, shape=(N, n), finite=False)
        self.v = array("v", self.v, shape=(N, n), finite=False)

    # --- what it is ---------------------------------------------------------------------------
    @property
    def setup(self) -> Setup:
        """The problem solved: the dynamics' set-up with this result's scheme.  (Set-ups that
        differ only in the scheme share one :class:`~fivebar.model.dynamics.LinkageDynamics`,
        built by whichever was solved first, so its ``setup`` may name another scheme.)"""
        s = self.dynamics.setup
        if self.scheme is None or s.scheme == self.scheme:
            return s
        return s.replace(scheme=self.scheme)

    @property
    def params(self) -> Params:
        """The parameter set of the model (``dynamics.params``)."""
        return self.dynamics.params

    @property
    def crank_angle_deg(self) -> NDArray:
        """Angle of crank AB (deg) from its initial angle, at the samples."""
        return np.degrees(self.t * self.dynamics.params.crank_speed_rad_s)

    def period(self, k: int) -> Response:
        """The samples of period ``k`` (0 first), S + 1 of them from ``k T`` to ``(k + 1) T``,
        as a Response of the same method (a response sampled at the S step times per period,
        as :func:`transient` gives)."""
        dyn = self.dynamics
        S = dyn.steps_per_period
        n_periods = (len(self.t) - 1) // S
        k = number("k", k, integer=True, low=0, high=max(n_periods - 1, 0))
        i = k * S
        if n_periods < 1 or not np.allclose(np.diff(self.t[i:i + S + 1]), dyn.dt, rtol=1e-9, atol=0.0):
            raise InputError(f"k = {k!r} is not allowed: this response ({len(self.t)} samples) does not hold "
                             f"period {k} sampled at the S = {S} step times")
        sl = slice(i, i + S + 1)
        return Response(dyn, self.t[sl], self.u[sl], self.v[sl], self.method,
                        scheme=self.scheme)

    # --- displacements ------------------------------------------------------------------------
    def deflection_mm(self, link: str, s: float = 0.5, direction: str = "transverse") -> NDArray:
        """Elastic displacement (mm) of the point at ``s`` (0 to 1 from the link's first end)
        of a link, at the samples.

        Parameters
        ----------
        link
            A link of the description ("L1" ... "L4" for the five-bar).
        s
            Position along the link as a fraction of its length (0.5: the midpoint).
        direction
            "transverse": the elastic displacement of the point projected on the link's normal
            (the left normal of its first to its second end); it includes the elastic motion of
            the link's end joints.  "longitudinal": projected on the link's axis.  "chord": the
            transverse deflection relative to the chord through the link's deflected ends
            (pure bending; at the midpoint, what a mid-span strain gauge senses).
        """
        names = self.dynamics.params.linkage.link_names
        if link not in names:
            raise InputError(f"link = {link!r} is not allowed: use one of {list(names)}")
        if direction not in DIRECTIONS:
            raise InputError(f"direction = {direction!r} is not allowed: use one of {list(DIRECTIONS)}")
        s = number("s", s, low=0.0, high=1.0)
        m = self.dynamics.model
        q = self._element_displacements()
        ax, tr = m.link_point(q, link, s)
        if direction == "longitudinal":
            return 1e3 * ax
        if direction == "transverse":
            return 1e3 * tr
        _, tr0 = m.link_point(q, link, 0.0)
        _, tr1 = m.link_point(q, link, 1.0)
        return 1e3 * (tr - ((1.0 - s) * tr0 + s * tr1))

    def midpoint_mm(self, link: str, direction: str = "transverse") -> NDArray:
        """Elastic displacement (mm) of the midpoint of a link at the samples:
        :meth:`deflection_mm` at ``s = 0.5`` (the directions are defined there; Figure 6 shows
        the transverse ones of L2 and L3)."""
        return self.deflection_mm(link, 0.5, direction)

    def peak_to_peak_mm(self, link: str, direction: str = "transverse") -> float:
        """Peak-to-peak value (mm) of :meth:`midpoint_mm` over the samples."""
        y = self.midpoint_mm(link, direction)
        return float(y.max() - y.min())

    def _angles(self):
        return self.dynamics.crank_angles(self.t)

    def _element_displacements(self) -> NDArray:
        """The elements' local DOFs at the samples, (N, n_elements, 8), computed once for every
        deflection and stress of this result."""
        if "q" not in self._cache:
            self._cache["q"] = self.dynamics.model.element_displacements(self.dynamics.expand(self.u),
                                                                         *self._angles())
        return self._cache["q"]

    def axial_force(self, link: str) -> NDArray:
        r"""Axial (membrane) force (N, tension positive) of each element of a link at the
        samples, shape ``(samples, elements)``, the elements from the link's start to its end.

        The element's mean of :math:`EA\,\epsilon` with :math:`\epsilon = V' + e`: the stretch of
        its linear axial field, plus, where the model keeps the geometric nonlinearity, the mean
        of the nonlinear strain :math:`e = \frac12 W'^2` (the same for every strain measure of
        :mod:`fivebar.model.nonlinear`; the uniform measure's at every point).  It is the force
        of the elastic deformation; the rigid-body inertia it balances is the load of (2.7).
        """
        m = self.dynamics.model
        m._check_link_point(link, 0.5)
        q = self._element_displacements()  # (N, nel, 8) in the elements' frames
        lk = m.linkage.link(link)
        EA = lk.material.E * lk.section.area
        idx = [i for i, el in enumerate(m.elements) if el.link == link]
        out = []
        for i in idx:
            el = m.elements[i]
            Vp = (q[:, i, 4] - q[:, i, 0]) / el.length
            if self.dynamics.nonlinear is not None:
                w, g = _slopes(el.length)  # Gauss weights and slope shapes
                Wp = q[:, i, :] @ g.T
                Vp = Vp + 0.5 * (Wp * Wp) @ w / el.length
            out.append(EA * Vp)
        out = np.stack(out, axis=-1)
        return out[:, ::-1] if m._reversed(link) else out

    def bending_stress(self, points: int = 11) -> dict[str, float]:
        """Peak bending stress (Pa) of each link over the samples.

        sigma = E (d/2) abs(w'') with d the in-plane depth of the section (assumption
        ``bending_depth``), w'' the elastic curvature evaluated at ``points`` points of every
        element and at every sample.
        """
        points = number("points", points, integer=True, low=2, high=10_000)
        key = ("stress", points)
        if key not in self._cache:
            dyn = self.dynamics
            m, p = dyn.model, dyn.params
            q = self._element_displacements()  # (N, nel, 8)
            out: dict[str, float] = {}
            for i, el in enumerate(m.elements):
                N2 = _curvature_shapes(el.length, points)
                kappa = np.abs(q[:, i, :] @ N2.T).max()
                link = m.linkage.link(el.link)  # its own material and section
                out[el.link] = max(out.get(el.link, 0.0), link.material.E * 0.5 * link.section.bending_depth * kappa)
            self._cache[key] = out
        return dict(self._cache[key])

    def buckling(self, effective_length_factor: float | None = None) -> dict[str, dict[str, float]]:
        """The buckling check of every link: its largest compressive axial force over the samples
        against its Euler loads in and out of the plane of motion.

        ``response.buckling()["L2"]["compression / Euler load"]``.  For each link: ``"largest
        compression (N)"`` (the largest of :math:`-N` over its elements and the samples, 0 if it
        is in tension throughout; :meth:`axial_force`), ``"Euler load in plane (N)"`` and
        ``"Euler load out of plane (N)"`` (:func:`fivebar.model.elements.euler_loads` with
        ``effective_length_factor``, by default the parameter file's assumption
        ``buckling_length_factor``), and ``"compression / Euler load"``, against the lower of
        the two (the link buckles at 1).
        """
        params = self.dynamics.params
        if effective_length_factor is None:
            effective_length_factor = params.buckling_length_factor
        links = {k.name: k for k in params.linkage.links}
        out = {}
        for name in dict.fromkeys(el.link for el in self.dynamics.model.elements):  # the elastic links
            comp = float(max(0.0, -self.axial_force(name).min()))
            p_in, p_out = euler_loads(links[name], effective_length_factor)
            out[name] = {"largest compression (N)": comp, "Euler load in plane (N)": p_in,
                         "Euler load out of plane (N)": p_out, "compression / Euler load": comp / min(p_in, p_out)}
        return out


@memoised
def _curvature_shapes(length: float, points: int) -> NDArray:
    """Second derivatives of the shape functions at ``points`` points of an element, the
    axial DOFs zeroed (read-only; the same for every result of a mesh)."""
    N2 = shape_functions(np.linspace(0.0, length, points), length, derivative=2)
    N2[:, [0, 4]] = 0.0
    N2.flags.writeable = False
    return N2


def _problem(setup: Setup | Params, argument: str = "setup") -> tuple[LinkageDynamics, Scheme, Setup]:
    """The dynamics, the scheme and the set-up of a problem (a Setup, or a Params)."""
    s = as_setup(setup, argument)
    return linkage_dynamics(s), s.scheme, s


def _resolve(setup):
    """(dynamics, scheme, setup) of a problem (a Setup, or a Params)."""
    return _problem(setup)


@analysis
def transient(
    setup: Setup | Params,
    periods: int = 1,
    u0: ArrayLike | None = None,
    v0: ArrayLike | None = None,
    *,
    newton: str = "full",
) -> Response:
    """The motion from a given state at t = 0 over ``periods`` periods, by the implicit scheme
    (S steps per period, every step stored): the march without the periodicity condition.

    ``r = transient(setup, 4)``; ``r.period(3).peak_to_peak_mm("L2")``.

    Parameters
    ----------
    setup
        The problem, a :class:`fivebar.description.setup.Setup` (its S and scheme, ...) or a Params
        (``Setup(params)``).
    periods
        Periods to integrate (S steps each).
    u0, v0
        The state at t = 0 (default: rest).
    newton
        "full" or "modified" Newton iterations in each step (:func:`fivebar.numerics.newmark.integrate`).

    Returns
    -------
    Response
        ``method == "transient"``, ``periods * S + 1`` samples; ``solver`` is the
        :class:`~fivebar.numerics.newmark.NewmarkResult`.
    """
    periods = number("periods", periods, integer=True, low=1, high=MAX_TRANSIENT_PERIODS)
    dyn, scheme, _ = _resolve(setup)
    u = np.zeros(dyn.n) if u0 is None else array("u0", u0, shape=(dyn.n,))
    v = np.zeros(dyn.n) if v0 is None else array("v0", v0, shape=(dyn.n,))
    res = integrate(dyn, u, v, 0.0, dyn.dt, periods * dyn.steps_per_period, scheme, step_data=dyn.step_data, newton=newton)
    return Response(dyn, res.t, res.u, res.v, "transient", scheme=scheme, solver=res)


@analysis
def quasi_static(setup: Setup | Params, t: ArrayLike | None = None) -> Response:
    r"""The quasi-static deflection :math:`\mathbf K(t)^{-1}\mathbf F(t)` of the linear
    subsystem (the response to a slow inertial load), as a Response.

    ``t`` None: at the S step times and the period's end (S + 1 samples, the last equal to the
    first), from the sampled matrices, with the velocity by the periodic central difference
    over the step (second order in the step, as the quasi-static start of
    :func:`fivebar.analyses.steady.shooting`); else at the times ``t`` (s), with the velocity by a
    central difference over a millionth of the period.  ``method == "quasi-static"``.
    """
    dyn = _resolve(setup)[0]
    if t is None:
        sd = dyn.step_data
        qs = np.linalg.solve(sd.K, sd.F[..., None])[..., 0]
        vs = (np.roll(qs, -1, axis=0) - np.roll(qs, 1, axis=0)) / (2 * dyn.dt)
        times = np.arange(dyn.steps_per_period + 1) * dyn.dt
        return Response(dyn, times, np.concatenate([qs, qs[:1]]), np.concatenate([vs, vs[:1]]), "quasi-static")
    times = array("t", t, shape=(None,))
    if len(times) < 1:
        raise InputError(f"t = {t!r} is not allowed: give at least one time (s), or None")
    h = 1e-6 * dyn.period
    qs = dyn.quasi_static(times)
    vs = (dyn.quasi_static(times + h) - dyn.quasi_static(times - h)) / (2 * h)
    return Response(dyn, times, qs, vs, "quasi-static")


@analysis
def radau(
    setup: Setup | Params,
    t: ArrayLike,
    u0: ArrayLike | None = None,
    v0: ArrayLike | None = None,
    *,
    rtol: float = 1e-6,
    atol: float = 1e-13,
) -> Response:
    r"""The motion from (u0, v0) at ``t[0]`` by scipy's implicit Radau method on the
    first-order form of (2.7), sampled at ``t``: the independent reference of the Newmark
    solution.

    The state :math:`\mathbf x = (\mathbf u, \dot{\mathbf u})` obeys
    :math:`\dot{\mathbf x} = (\dot{\mathbf u}, \mathbf M^{-1}(\mathbf F - \mathbf C\dot{\mathbf u}
    - \mathbf K\mathbf u - \mathbf f_{nl}))` with M, C, K, F evaluated at every time the
    integrator asks for (not interpolated from the step samples), and the exact Jacobian.  The
    stiffest mode (about 1.2e5 rad/s) makes Radau slow: use it on windows of a period.

    Parameters
    ----------
    setup
        The problem, a :class:`fivebar.description.setup.Setup` or a Params (``Setup(params)``).
    t
        Increasing sample times (s), at least two; the integration runs from ``t[0]`` to ``t[-1]``.
    u0, v0
        The state at ``t[0]`` (default: rest).
    rtol, atol
        Tolerances of ``scipy.integrate.solve_ivp`` (atol in the state's units, m and m/s).

    Returns
    -------
    Response
        ``method == "radau"``; ``solver`` is scipy's ``OdeResult`` (``nfev``, ``njev``,
        ``nlu``).  Raises :class:`fivebar.errors.ComputationError` if the integrator fails.
    """
    import scipy.integrate

    dyn = _resolve(setup)[0]
    ts = array("t", t, shape=(None,))
    if len(ts) < 2 or np.any(np.diff(ts) <= 0):
        raise InputError(f"t = {t!r} is not allowed: give at least two increasing times (s)")
    rtol = number("rtol", rtol, low=0.0, low_open=True)
    atol = number("atol", atol, low=0.0, low_open=True)
    m = dyn.n
    u = np.zeros(m) if u0 is None else array("u0", u0, shape=(m,))
    v = np.zeros(m) if v0 is None else array("v0", v0, shape=(m,))
    nl = dyn.nonlinear

    def rhs(time, x):
        M, C, K, F = dyn._sample(np.asarray(time))
        load = F - C @ x[m:] - K @ x[:m]
        if nl is not None:
            load = load - nl(x[:m], float(time))[0]
        return np.concatenate([x[m:], np.linalg.solve(M, load)])

    def jac(time, x):
        M, C, K = dyn.matrices(time)
        if nl is not None:
            K = K + nl(x[:m], float(time))[1]
        return np.block([[np.zeros((m, m)), np.eye(m)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])

    sol = scipy.integrate.solve_ivp(rhs, (ts[0], ts[-1]), np.concatenate([u, v]), method="Radau", t_eval=ts,
                                    rtol=rtol, atol=atol, jac=jac)
    if not sol.success:
        raise ComputationError(f"scipy's Radau failed between t = {ts[0]:.6g} and {ts[-1]:.6g} s: {sol.message}")
    return Response(dyn, ts, sol.y[:m].T, sol.y[m:].T, "radau", solver=sol)
