r"""An independent, fully coupled flexible multibody model of the linkage (Exudyn).

The kineto-elastodynamic (KED) model of the paper, (2.7), prescribes the rigid motion and lets
the links vibrate about it.  Here the same linkage is built as a flexible multibody system in
Exudyn (J. Gerstmayr, Multibody System Dynamics 60, 2024, 533-561), which solves the coupled equations of motion

.. math::

    \mathbf M(\mathbf q)\ddot{\mathbf q} + \mathbf f(\mathbf q, \dot{\mathbf q}) +
    \mathbf C_{\mathbf q}^\top\boldsymbol\lambda = \mathbf 0 ,\qquad
    \mathbf c(\mathbf q, t) = \mathbf 0

in absolute coordinates: no split into rigid and elastic motion, so the terms KED drops
(elastic Coriolis and centripetal terms, centrifugal stiffening, the change of geometry with
deflection) are all present.

* Links: planar ANCF cable elements (``ObjectANCFCable2D``, Euler-Bernoulli, cubic in position,
  exact axial strain and curvature; J. Gerstmayr and H. Irschik, Journal of Sound and
  Vibration 318, 2008, 461-487), axial stiffness ``E A``,
  bending stiffness ``E I`` with the in-plane depth ``params.bending_depth``, mass per length
  ``rho A`` (no rotary inertia: the library's ``rotary_inertia`` term has no counterpart).
* The linkage is the parameter file's description (:class:`fivebar.description.linkage.Linkage`; the
  paper's five-bar by default, or any linkage it describes with cranks at constant speed).
* Pins (B, C, D of the five-bar): the position coordinates of the link ends are tied, slopes
  free.  Ground pins: position fixed, slope free.  A slider on a ground guide (a prismatic
  joint): its links' ends tied, and the node kept on the guide by a constraint on its normal
  coordinate, :math:`-\sin\varphi\,x + \cos\varphi\,y = \mathrm{const}`, the coordinate along
  the guide free, with the slider's mass on it.  A joint at the end of a rigid crank: its
  position prescribed by the drive.  Links welded into one body: their ends' positions tied
  and their slope vectors kept at the weld's angle, :math:`\mathbf R(\psi)\mathbf r'_1 \times
  \mathbf r'_2 = 0`.
* Lumped masses (``m01`` at B and ``m02`` at C of the five-bar: ``ObjectGenericODE2`` mass
  matrices on the position coordinates of the pin node).
* Crank roots (A and E of the five-bar): position fixed, and the slope vector of the root node
  kept along the prescribed crank angle, :math:`-\sin\theta\,r'_x + \cos\theta\,r'_y = 0` (a
  clamped cross section turned by the motor, a user-function constraint); the drive is at
  constant speed (the description's ``ratio`` times the crank speed).  The crank speed ramps up over
  ``ramp_periods`` periods with a quintic smooth step and stays constant after, so that the
  crank angle is :math:`\theta_0 + \Omega (t - T_r/2)` after the ramp (an even number of ramp
  periods puts crank angle 0 at whole periods).
* Damping: Kelvin-Voigt material damping, bending moment :math:`EI(\kappa + \beta\dot\kappa)`
  and axial force :math:`EA(\varepsilon + \beta\dot\varepsilon)`.  Being stiffness
  proportional it damps no rigid motion and gives mode :math:`k` the ratio
  :math:`\zeta_k = \beta\omega_k/2`; :math:`\beta = 2\zeta/\omega_1` matches the library's
  modal damping ratio :math:`\zeta` on the lowest mode of the frozen linkage at crank angle 0
  (higher modes are damped more, :math:`\zeta\omega_k/\omega_1`).
* Gravity ``params.gravity`` along -y when it is not zero.

Midpoint deflections are measured as in :meth:`fivebar.analyses.response.Response.midpoint_mm`: the
displacement of the link's midpoint from its rigid-body position (the kinematics at the same
crank angles), projected on the rigid link's normal ("transverse") or axis ("longitudinal");
"chord" subtracts the mean transverse displacement of the two ends.

Exudyn is imported inside the functions: ``import fivebar`` does not need it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..errors import ComputationError, InputError
from ..model.kinematics import crank_laws, link_angles, positions
from ..description.params import Params
from ..description.setup import Setup, analysis, as_setup
from .response import DIRECTIONS

__all__ = [
    "INTEGRATION_STEPS",
    "MultibodyError",
    "MultibodyModel",
    "MultibodySteadyState",
    "build",
    "frozen_system",
    "multibody_frequencies",
    "multibody_steady_state",
]

#: default mesh: twice the description's elements on every link (for the five-bar (2, 4, 4, 2)
#: on L1..L4: couplers even, so a node sits at the midpoint)
DEFAULT_ELEMENTS = None
#: the least time steps per crank turn of :func:`multibody_steady_state` by default
INTEGRATION_STEPS = 400


class MultibodyError(ComputationError):
    """The multibody model could not be built or did not reach a periodic steady state."""


def _exudyn():
    try:
        import exudyn
        import exudyn.itemInterface  # noqa: F401
        import exudyn.solver  # noqa: F401
    except ImportError as err:  # pragma: no cover - exercised only without exudyn
        raise MultibodyError(
            "the multibody model needs the package exudyn (pip install exudyn==1.13.6, "
            "pinned in requirements-lock.txt)"
        ) from err
    return exudyn


def _check_mesh(params: Params, elements_per_link) -> tuple[int, ...]:
    lk = params.linkage
    if elements_per_link is None:
        return tuple(2 * k for k in lk.default_mesh)
    return lk.check_mesh(elements_per_link, even=True)


def _theta(params: Params, theta1, theta4) -> tuple[float, ...]:
    """The crank angles: (theta1, theta4) for two cranks, (theta1,) for one; None: the
    initial angles of the drives."""
    n = len(params.linkage.cranks)
    if theta1 is None and theta4 is None:
        return tuple(float(x) for x in crank_laws(params, 0.0)[0::3])
    th = (theta1,) if n == 1 else (theta1, theta4)
    if n == 1 and theta4 is not None:
        raise InputError(f"theta4 = {theta4!r} is not allowed: the linkage has one driven crank")
    return tuple(float(x) for x in th)


def _smooth_angle(t: float, W: float, Tr: float) -> tuple[float, float, float]:
    """Crank angle offset, speed, acceleration for the quintic speed ramp over Tr."""
    if Tr <= 0 or t >= Tr:
        return W * (t - 0.5 * Tr), W, 0.0
    if t <= 0:
        return 0.0, 0.0, 0.0
    x = t / Tr
    G = 2.5 * x**4 - 3 * x**5 + x**6  # integral of the smooth step 10x^3 - 15x^4 + 6x^5
    s = 10 * x**3 - 15 * x**4 + 6 * x**5
    ds = (30 * x**2 - 60 * x**3 + 30 * x**4) / Tr
    return W * Tr * G, W * s, W * ds


@dataclass
class MultibodyModel:
    """An assembled Exudyn system of the linkage and the bookkeeping to read it."""

    params: Params
    elements_per_link: tuple[int, ...]
    SC: object = field(repr=False)
    mbs: object = field(repr=False)
    #: per link, the Exudyn node numbers along the link's kinematic direction (start to end)
    nodes: dict[str, list[int]] = field(repr=False)
    #: per link, the ODE2 coordinate indices (x, y) of each node along the link
    coords: dict[str, NDArray] = field(repr=False)
    #: reference positions (m) of the nodes, per link, (nodes, 2)
    reference: dict[str, NDArray] = field(repr=False)
    beta: float = 0.0
    #: the crank angles (rad) of the built configuration, one per driven crank
    theta: tuple[float, ...] = ()


def build(
    params: Params,
    theta1: float | None = None,
    theta4: float | None = None,
    elements_per_link=DEFAULT_ELEMENTS,
    beta: float = 0.0,
    crank_speed_rad_s: float = 0.0,
    ramp: float = 0.0,
) -> MultibodyModel:
    """Build the Exudyn model in the configuration of crank angles ``theta1, theta4`` (rad).

    ``theta1, theta4`` (``theta1`` alone for a linkage with one driven crank) default to the
    drives' initial angles (``params.theta1_0, params.theta4_0`` for the five-bar).  The root
    slopes follow ``theta + offset(t)`` with the ramped crank law of speed ``crank_speed_rad_s``
    (rad/s, times each drive's ratio; 0: frozen) and ramp time ``ramp`` (s).  ``beta`` is the
    Kelvin-Voigt damping time (s).
    """
    exu = _exudyn()
    ii = exu.itemInterface
    lk = params.linkage
    epl = _check_mesh(params, elements_per_link)
    th = _theta(params, theta1, theta4)
    for j in lk.inputs:
        if j.kind != "crank" or j.drive.fourier or j.drive.function is not None:  # type: ignore[union-attr]
            raise InputError(f"the drive of {j.kind} {j.name} is not a crank at constant speed: the multibody model "
                             "drives its cranks at constant speed only")
    P = positions(params, *th)
    ang = link_angles(params, *th)

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddNode(ii.NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    mground = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    mground_all = mbs.AddMarker(ii.MarkerNodeCoordinates(nodeNumber=ground))
    nodes: dict[str, list[int]] = {}
    reference: dict[str, NDArray] = {}
    bodies = []
    for k, lnk in enumerate(lk.links):
        if lnk.rigid:  # no elements: its joints follow the drive (below)
            continue
        link, a, b = lnk.name, lnk.start, lnk.end
        EA, EI = lnk.material.E * lnk.section.area, lnk.material.E * lnk.section.I
        rhoA = lnk.material.rho * lnk.section.area
        n_el = epl[k]
        e = np.array([np.cos(ang[link]), np.sin(ang[link])])
        pts = P[a] + np.linspace(0.0, 1.0, n_el + 1)[:, None] * (P[b] - P[a])
        reference[link] = pts
        nn = [mbs.AddNode(ii.NodePoint2DSlope1(referenceCoordinates=[*p, *e])) for p in pts]
        nodes[link] = nn
        L_el = float(np.linalg.norm(P[b] - P[a])) / n_el
        for i in range(n_el):
            bodies.append(mbs.AddObject(ii.ObjectANCFCable2D(
                nodeNumbers=[nn[i], nn[i + 1]], length=L_el, massPerLength=rhoA,
                bendingStiffness=EI, axialStiffness=EA,
                bendingDamping=beta * EI, axialDamping=beta * EA,
                useReducedOrderIntegration=0)))

    def tie(n0: int, c0: int, n1: int | None, c1: int = 0) -> None:
        m0 = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=n0, coordinate=c0))
        m1 = mground if n1 is None else mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=n1, coordinate=c1))
        mbs.AddObject(ii.CoordinateConstraint(markerNumbers=[m1, m0]))

    def node_at(link, joint: str) -> int:
        return nodes[link.name][0 if link.start == joint else -1]

    flexible = {j.name: [k for k in lk.links_at(j.name) if not k.rigid] for j in lk.joints}
    # ground joints (crank roots and ground pins): position fixed; pins and sliders: the link ends tied
    for j in lk.ground:
        for lnk in flexible[j.name]:
            tie(node_at(lnk, j.name), 0, None)
            tie(node_at(lnk, j.name), 1, None)
    for j in lk.joints:
        at = flexible[j.name]
        if j.on_ground or len(at) < 2:
            continue
        for lnk in at[1:]:
            for c in (0, 1):
                tie(node_at(at[0], j.name), c, node_at(lnk, j.name), c)

    # clamped, driven root cross-sections: slope vector along the crank link's angle theta(t)
    drives = []
    for joint, th0 in zip(lk.inputs, th):
        link = lk.crank_link(joint.name)
        if link.rigid:
            continue
        th0 = th0 if link.start == joint.name else th0 + np.pi
        drives.append((node_at(link, joint.name), th0, joint.drive.ratio * crank_speed_rad_s))  # type: ignore[union-attr]
    for root, th0, W in drives:
        mk = mbs.AddMarker(ii.MarkerNodeCoordinates(nodeNumber=root))

        def constraint(mbs_, t, item, q, q_t, velocityLevel, th0=th0, W=W):
            off, w, _ = _smooth_angle(t, W, ramp)
            th = th0 + off
            s, c = np.sin(th), np.cos(th)
            sx, sy = q[2], q[3]  # MarkerNodeCoordinates of this node: reference included
            if velocityLevel:
                return [-s * q_t[2] + c * q_t[3] - w * (c * sx + s * sy)]
            return [-s * sx + c * sy]

        def jacobian(mbs_, t, item, q, q_t, velocityLevel, th0=th0, W=W):
            th = th0 + _smooth_angle(t, W, ramp)[0]
            J = np.zeros((1, 4))
            J[0, 2], J[0, 3] = -np.sin(th), np.cos(th)
            return J

        mbs.AddObject(ii.ObjectConnectorCoordinateVector(
            markerNumbers=[mground_all, mk], scalingMarker0=np.zeros((1, 1)),
            constraintUserFunction=constraint, jacobianUserFunction=jacobian))
    _joint_constraints(lk, P, ang, flexible, node_at, constraint_vector(mbs, ii, mground_all), crank_speed_rad_s,
                       ramp)

    # lumped masses at pins (B at the end of L1 and C at the end of L2 for the five-bar) and sliders
    lumped = [(node_at(flexible[j][0], j), m) for j, m in lk.masses.items()
              if m > 0 and flexible[j] and not lk.joint(j).on_ground and not _follows_drive(lk, j)]
    for node, m in lumped:
        mbs.AddObject(ii.ObjectGenericODE2(nodeNumbers=[node],
                                           massMatrix=np.diag([m, m, 0.0, 0.0]),
                                           stiffnessMatrix=np.zeros((4, 4))))
    if params.gravity:
        g = params.gravity
        for b in bodies:
            mm = mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=b))
            mbs.AddLoad(ii.LoadMassProportional(markerNumber=mm, loadVector=[0.0, -g, 0.0]))
        for node, m in lumped:
            mp = mbs.AddMarker(ii.MarkerNodePosition(nodeNumber=node))
            mbs.AddLoad(ii.LoadForceVector(markerNumber=mp, loadVector=[0.0, -m * g, 0.0]))
    mbs.Assemble()
    coords = {link: np.array([list(mbs.systemData.GetNodeLTGODE2(n))[:2] for n in nn])
              for link, nn in nodes.items()}
    return MultibodyModel(params, epl, SC, mbs, nodes, coords, reference, beta, th)


def constraint_vector(mbs, ii, mground_all: int):
    """``add(node, n_eq, value, jac, other=None)``: a constraint of ``n_eq`` equations on the
    coordinates (reference included) of ``node`` (after those of ``other``, when given), with
    ``value(t, q, q_t, velocity_level)`` and its Jacobian ``jac(t, q)`` (Exudyn's
    ObjectConnectorCoordinateVector with user functions)."""

    def add(node: int, n_eq: int, value, jac, other: int | None = None) -> None:
        markers = [mground_all if other is None else mbs.AddMarker(ii.MarkerNodeCoordinates(nodeNumber=other)),
                   mbs.AddMarker(ii.MarkerNodeCoordinates(nodeNumber=node))]
        mbs.AddObject(ii.ObjectConnectorCoordinateVector(
            markerNumbers=markers, scalingMarker0=np.zeros((n_eq, 1)),
            constraintUserFunction=lambda mbs_, t, item, q, q_t, vel: value(t, np.asarray(q), np.asarray(q_t), vel),
            jacobianUserFunction=lambda mbs_, t, item, q, q_t, vel: jac(t, np.asarray(q))))
    return add


def _follows_drive(lk, joint: str) -> bool:
    """A joint at the far end of a rigid driven crank: it moves as the drive prescribes."""
    return any(k.rigid for k in lk.links_at(joint))


def _joint_constraints(lk, P, ang, flexible, node_at, add, crank_speed_rad_s: float, ramp: float) -> None:
    """The constraints beyond pins and clamped crank roots: a slider's node kept on its ground
    guide (the normal coordinate, -sin(phi) x + cos(phi) y = const), a joint at the end of a
    rigid crank moved by the drive, and welded arms kept at their angle at a common joint."""
    for j in lk.joints:
        at = flexible[j.name]
        if not at:
            continue
        node = node_at(at[0], j.name)
        if j.kind == "slider":
            if j.guide.link is not None or j.drive is not None:
                raise MultibodyError(f"the multibody model takes sliders on ground guides that are not driven; the "
                                     f"slider {j.name} is {'on the link ' + j.guide.link if j.guide.link else 'driven'}")
            sg, cg = np.sin(j.guide.angle), np.cos(j.guide.angle)
            level = -sg * j.guide.at[0] + cg * j.guide.at[1]

            def value(t, q, q_t, vel, sg=sg, cg=cg, level=level):
                return [-sg * q_t[0] + cg * q_t[1]] if vel else [-sg * q[0] + cg * q[1] - level]

            def jac(t, q, sg=sg, cg=cg):
                J = np.zeros((1, 4))
                J[0, 0], J[0, 1] = -sg, cg
                return J
            add(node, 1, value, jac)
        elif _follows_drive(lk, j.name) and not j.on_ground:
            crank = next(k for k in lk.links_at(j.name) if k.rigid)
            pivot = crank.start if lk.joint(crank.start).kind == "crank" else crank.end
            W = lk.joint(pivot).drive.ratio * crank_speed_rad_s
            c0, r0 = np.asarray(P[pivot], float), np.asarray(P[j.name] - P[pivot], float)

            def value(t, q, q_t, vel, c0=c0, r0=r0, W=W):
                off, w, _ = _smooth_angle(t, W, ramp)
                c, s = np.cos(off), np.sin(off)
                r = np.array([c * r0[0] - s * r0[1], s * r0[0] + c * r0[1]])
                if vel:
                    return [q_t[0] + w * r[1], q_t[1] - w * r[0]]
                return [q[0] - c0[0] - r[0], q[1] - c0[1] - r[1]]

            def jac(t, q):
                J = np.zeros((2, 4))
                J[0, 0] = J[1, 1] = 1.0
                return J
            add(node, 2, value, jac)
        first = {}
        for lnk in at:  # welded arms: the slope of each kept at its angle to the body's first arm here
            body = lk.body_of(lnk.name)
            if len(body) < 2:
                continue
            if body not in first:
                first[body] = lnk
                continue
            base = first[body]
            psi = float(ang[lnk.name] - ang[base.name])
            cp, sp = np.cos(psi), np.sin(psi)

            def weld_jac(t, q, cp=cp, sp=sp):
                s1, s2 = q[2:4], q[6:8]  # (the base arm's node, then this arm's)
                r = np.array([cp * s1[0] - sp * s1[1], sp * s1[0] + cp * s1[1]])
                J = np.zeros((1, 8))
                J[0, 2], J[0, 3] = cp * s2[1] - sp * s2[0], -sp * s2[1] - cp * s2[0]
                J[0, 6], J[0, 7] = -r[1], r[0]
                return J

            def weld(t, q, q_t, vel, cp=cp, sp=sp, weld_jac=weld_jac):
                if vel:  # the constraint is free of t: its rate is J q'
                    return [float(weld_jac(t, q)[0] @ q_t)]
                s1, s2 = q[2:4], q[6:8]
                r = np.array([cp * s1[0] - sp * s1[1], sp * s1[0] + cp * s1[1]])
                return [r[0] * s2[1] - r[1] * s2[0]]
            add(node_at(lnk, j.name), 1, weld, weld_jac, other=node_at(base, j.name))


@analysis
def frozen_system(
    setup: Setup | Params, theta1: float, theta4: float | None = None, beta: float = 0.0
) -> tuple[NDArray, NDArray, NDArray]:
    """Mass, stiffness and damping matrices of the frozen linkage, in the constraints' null space.

    ``M, K, D = frozen_system(fivebar.Setup(params, elements_per_link=(2, 4, 4, 2)), theta1,
    theta4)`` (SI): the Exudyn system linearised at the undeformed configuration of the crank
    angles (rad; ``theta1`` alone for one driven crank), roots clamped.  ``setup``: the problem
    (its parameters and its mesh ``elements_per_link``, ANCF elements per link, even on the
    links between two pins; ``None``, or a Params: twice the description's mesh); ``beta`` the
    Kelvin-Voigt damping time (s).
    """
    exu = _exudyn()
    s = as_setup(setup)
    model = build(s.params, theta1, theta4, _mesh(s), beta=beta)
    M, K, D = exu.solver.ComputeLinearizedSystem(model.mbs, exu.SimulationSettings(),
                                                 projectIntoConstraintNullspace=True)[:3]
    return np.asarray(M), np.asarray(K), np.asarray(D)


@analysis
def multibody_frequencies(
    setup: Setup | Params, theta1: float, theta4: float | None = None, n_modes: int = 6
) -> NDArray:
    """The ``n_modes`` lowest natural frequencies (Hz) of the frozen linkage, crank roots clamped.

    ``f = multibody_frequencies(setup, theta1, theta4)``: Exudyn's linearisation at the
    undeformed configuration of the crank angles ``theta1, theta4`` (rad; ``theta1`` alone for
    one driven crank), projected on the null space of the constraints; the set-up's parameters
    and mesh (:func:`frozen_system`).  Compare with
    ``fivebar.natural_frequencies(fivebar.Setup(params, motors=False), theta1, theta4, n_modes=n_modes)``.
    """
    import scipy.linalg

    if isinstance(n_modes, bool) or int(n_modes) != n_modes or n_modes < 1:
        raise InputError(f"n_modes = {n_modes!r} is not allowed: give a positive integer number of modes")
    M, K, _ = frozen_system(setup, theta1, theta4)
    w2 = scipy.linalg.eigh(K, M, eigvals_only=True)
    if len(w2) < n_modes:
        raise InputError(f"n_modes = {n_modes!r} is not allowed: the model has {len(w2)} modes")
    return np.sqrt(np.clip(w2[: int(n_modes)], 0.0, None)) / (2 * np.pi)


@analysis
def damping_ratios(
    setup: Setup | Params, theta1: float, theta4: float | None, beta: float, n: int = 6
) -> tuple[NDArray, NDArray]:
    """Frequencies (Hz) and damping ratios of the ``n`` lowest modes of the damped frozen model.

    From the complex eigenvalues of the first-order form of (M, D, K) with damping time
    ``beta`` (s): zeta = -Re(lambda) / abs(lambda); the set-up's parameters and mesh
    (:func:`frozen_system`).
    """
    import scipy.linalg

    M, K, D = frozen_system(setup, theta1, theta4, beta)
    m = len(M)
    Z, I = np.zeros((m, m)), np.eye(m)
    lam = scipy.linalg.eigvals(np.block([[Z, I], [-np.linalg.solve(M, K), -np.linalg.solve(M, D)]]))
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))][:n]
    return np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)


@dataclass
class MultibodySteadyState:
    """One steady period of the multibody model, read like :class:`fivebar.analyses.steady.SteadyState`
    (the same accessors: ``t``, ``params``, ``crank_angle_deg``, ``deflection_mm``,
    ``midpoint_mm``, ``peak_to_peak_mm``, ``method``).

    Attributes
    ----------
    t
        Times (s) of the S + 1 samples from crank angle 0 over one period (from 0).
    positions
        Per link, node positions (m) at the samples, (S + 1, nodes, 2).
    periods
        Periods simulated (ramp included).
    periodicity_error
        max abs(y_last - y_previous) / peak-to-peak(y_last) over the transverse midpoint
        curves of the couplers (L2 and L3 of the five-bar): the change over the last period.
    seconds
        Wall-clock time of the simulation.
    """

    params: Params
    t: NDArray
    positions: dict[str, NDArray]
    periods: int
    periodicity_error: float
    seconds: float
    elements_per_link: tuple[int, ...]
    integration_steps: int

    @property
    def crank_angle_deg(self) -> NDArray:
        """Angle of crank AB (deg) from its initial angle, at the samples."""
        return np.degrees(self.t * self.params.crank_speed_rad_s)

    def _rigid(self, link: str):
        p = self.params
        P = positions(p, *crank_laws(p, self.t)[0::3])
        a, b = p.linkage.link_ends[link]
        d = P[b] - P[a]
        e = d / np.linalg.norm(d, axis=-1, keepdims=True)
        nrm = np.stack([-e[..., 1], e[..., 0]], axis=-1)
        return P[a], d, e, nrm

    def _displacement(self, link: str, s: float) -> tuple[NDArray, NDArray]:
        Pa, d, e, nrm = self._rigid(link)
        pos = self.positions[link]
        i = int(round(s * (pos.shape[1] - 1)))
        u = pos[:, i, :] - (Pa + s * d)
        return np.sum(u * e, axis=-1), np.sum(u * nrm, axis=-1)

    def deflection_mm(self, link: str, s: float = 0.5, direction: str = "transverse") -> NDArray:
        """Elastic displacement (mm) of the node at ``s`` (0 to 1 from the link's first end) of a
        link over the period.

        Same definitions, directions and signs as :meth:`fivebar.analyses.response.Response.deflection_mm`;
        ``s`` must fall on a node of the link's mesh.
        """
        names = self.params.linkage.link_names
        if link not in names:
            raise InputError(f"link = {link!r} is not allowed: use one of {list(names)}")
        if direction not in DIRECTIONS:
            raise InputError(f"direction = {direction!r} is not allowed: use one of {list(DIRECTIONS)}")
        nodes = self.positions[link].shape[1] - 1
        if not (0.0 <= s <= 1.0) or abs(s * nodes - round(s * nodes)) > 1e-9:
            raise InputError(f"s = {s!r} is not allowed for link = {link!r}: its {nodes} elements have nodes at "
                             f"multiples of 1/{nodes}" + (" (no node at its midpoint in this mesh)"
                                                          if s == 0.5 else ""))
        ax, tr = self._displacement(link, s)
        if direction == "longitudinal":
            return 1e3 * ax
        if direction == "transverse":
            return 1e3 * tr
        _, tr0 = self._displacement(link, 0.0)
        _, tr1 = self._displacement(link, 1.0)
        return 1e3 * (tr - ((1.0 - s) * tr0 + s * tr1))

    def midpoint_mm(self, link: str, direction: str = "transverse") -> NDArray:
        """Elastic displacement (mm) of the midpoint of a link over the period:
        :meth:`deflection_mm` at ``s = 0.5`` (the mesh has a node there on the couplers).

        Same definitions, directions and signs as :meth:`fivebar.analyses.response.Response.midpoint_mm`.
        """
        return self.deflection_mm(link, 0.5, direction)

    def peak_to_peak_mm(self, link: str, direction: str = "transverse") -> float:
        """Peak-to-peak value (mm) of :meth:`midpoint_mm` over the period."""
        y = self.midpoint_mm(link, direction)
        return float(y.max() - y.min())

    @property
    def method(self) -> str:
        """What computed it: "multibody" (Exudyn), as the ``method`` of a :class:`fivebar.analyses.response.Response`."""
        return "multibody"


@analysis
def multibody_steady_state(
    setup: Setup | Params,
    *,
    integration_steps: int | None = None,
    tol: float = 1e-3,
    ramp_periods: int = 2,
    max_periods: int = 200,
    damping_mode: int = 1,
) -> MultibodySteadyState:
    """Periodic steady state of the fully coupled multibody model (Exudyn).

    ``res = multibody_steady_state(fivebar.Setup(params, crank_speed_rpm=600, steps_per_period=100,
    elements_per_link=(2, 4, 4, 2)))``; ``res.midpoint_mm("L2", "chord")`` (mm at the S + 1
    crank angles of one period from 0, as ``steady_state``).

    Parameters
    ----------
    setup
        The problem: a :class:`fivebar.description.setup.Setup`, of which the multibody model
        takes the parameters, the crank speed, S (the samples per period, which must divide
        ``integration_steps``) and the mesh ``elements_per_link`` (ANCF elements per link in
        chain order, L1..L4 for the five-bar, even on the links between two pins; ``None``:
        twice the description's mesh); or a Params (``Setup(params)``).  Its cranks turn at
        constant speed (no motors); the ANCF elements are geometrically nonlinear and Exudyn
        integrates with its own generalised-alpha scheme (spectral radius 0.8), so the set-up's
        ``motors``, ``nonlinear`` and ``scheme`` do not apply.
    integration_steps
        Time steps of the generalised-alpha integrator per crank turn, a multiple of S; default
        the least multiple of S that is at least :data:`INTEGRATION_STEPS` (400).
    tol
        Stop when the transverse midpoint curves of the couplers (L2 and L3 of the five-bar)
        change over one period by less than ``tol`` times their peak-to-peak value.
    ramp_periods
        Duration of the smooth run-up of the crank speed, in periods (even).
    damping_mode
        The frozen mode (1 = lowest, at the initial crank angles) on which the Kelvin-Voigt
        damping gives ``params.damping_ratio``.
    """
    exu = _exudyn()
    s = as_setup(setup)
    params = s.run_params
    elements_per_link = _mesh(s)
    S = int(s.steps_per_period)
    steps_per_period = S * -(-INTEGRATION_STEPS // S) if integration_steps is None else int(integration_steps)
    if steps_per_period < 1 or steps_per_period % S:
        raise InputError(f"integration_steps = {integration_steps!r} is not allowed: give a multiple of "
                         f"the set-up's samples per period S = {S} (steps_per_period)")
    if ramp_periods < 0 or ramp_periods % 2:
        raise InputError(f"ramp_periods = {ramp_periods!r} is not allowed: give an even number >= 0")
    if not tol > 0:
        raise InputError(f"tol = {tol!r} is not allowed: give a positive relative tolerance")
    T, W = params.period, params.crank_speed_rad_s
    th0 = _theta(params, None, None)
    f = multibody_frequencies(s, th0[0], th0[1] if len(th0) > 1 else None, damping_mode)
    beta = 2 * params.damping_ratio / (2 * np.pi * f[damping_mode - 1])
    t0 = time.perf_counter()
    model = build(params, elements_per_link=elements_per_link, beta=beta, crank_speed_rad_s=W,
                  ramp=ramp_periods * T)
    mbs = model.mbs
    sub = steps_per_period // S
    dt = T / steps_per_period
    links = [k.name for k in params.linkage.flexible]
    couplers = params.linkage.couplers
    ref = {k: model.reference[k] for k in links}
    record: list[dict[str, NDArray]] = []
    state = {"step": 0, "error": np.inf, "periods": 0}

    def sample() -> dict[str, NDArray]:
        q = np.asarray(mbs.systemData.GetODE2Coordinates())
        return {k: ref[k] + q[model.coords[k]] for k in links}

    def pre_step(mbs_, t):
        # called before the step that ends at t: the state is that of t - dt
        k = int(round(t / dt)) - 1
        if k % sub == 0 and k // sub == len(record):
            record.append(sample())
            n_samples = len(record) - 1
            if n_samples and n_samples % S == 0:
                periods = n_samples // S
                state["periods"] = periods
                if periods >= ramp_periods + 2:
                    now = _steady(params, record[-S - 1:], ramp_periods)
                    before = _steady(params, record[-2 * S - 1: -S], ramp_periods)
                    err = 0.0
                    for link in couplers:
                        y, y0 = now.midpoint_mm(link), before.midpoint_mm(link)
                        err = max(err, float(np.abs(y - y0).max() / max(np.ptp(y), 1e-300)))
                    state["error"] = err
                    if err <= tol:
                        return False
        return True

    mbs.SetPreStepUserFunction(pre_step)
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.numberOfSteps = steps_per_period * max_periods + 1
    ti.endTime = dt * ti.numberOfSteps
    ti.generalizedAlpha.spectralRadius = 0.8
    ti.newton.relativeTolerance = 1e-9
    ti.newton.absoluteTolerance = 1e-6
    ti.verboseMode = 0
    ti.adaptiveStep = False
    ss.solution.file.write = False
    ss.show.statistics = False
    ss.show.computationTime = False
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    console = exu.config.printToConsole
    exu.config.printToConsole = False  # Exudyn warns about the Python user functions' allocations
    try:
        mbs.SolveDynamic(ss)
    except Exception as err:  # Exudyn raises its own error types
        raise MultibodyError(f"Exudyn's dynamic solver failed at t = {mbs.systemData.GetTime():.6g} s: {err}") from err
    finally:
        exu.config.printToConsole = console
    seconds = time.perf_counter() - t0
    if state["error"] > tol:
        raise MultibodyError(
            f"no periodic steady state after {state['periods']} periods: the last relative change over "
            f"one period was {state['error']:.3e} (tolerance {tol:.1e})")
    res = _steady(params, record[-S - 1:], ramp_periods)
    res.periods = state["periods"]
    res.periodicity_error = state["error"]
    res.seconds = seconds
    res.elements_per_link = model.elements_per_link
    res.integration_steps = steps_per_period
    return res


def _mesh(setup: Setup):
    """The multibody mesh of a set-up: its ``elements_per_link``, or (None) the default
    :data:`DEFAULT_ELEMENTS` (twice the description's)."""
    return DEFAULT_ELEMENTS if setup.elements_per_link is None else setup.elements_per_link


def _steady(params: Params, rec: list[dict[str, NDArray]], ramp_periods: int) -> MultibodySteadyState:
    S = len(rec) - 1
    t = np.arange(S + 1) * params.period / S
    pos = {k.name: np.array([r[k.name] for r in rec]) for k in params.linkage.flexible}
    return MultibodySteadyState(params, t, pos, 0, np.nan, np.nan, (), 0)
