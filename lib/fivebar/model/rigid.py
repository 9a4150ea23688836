r"""Rigid-body dynamics of the linkage of the description (Lagrange's equations).

The rigid linkage has as many degrees of freedom as the description has driven inputs, their
coordinates in the description's order (``Linkage.inputs``): :math:`\mathbf q = (\theta_1,
\theta_4)` for the five-bar of Figure 1, one angle for a four-bar or a slider-crank, a slider's
position (m) for a driven slider (its "torque" is then the force along the guide, N).  Every body's velocity is linear in
:math:`\dot{\mathbf q}`: the centre of mass :math:`G_b` of body :math:`b` moves with
:math:`\mathbf v_b = \mathbf J_b(\mathbf q)\,\dot{\mathbf q}` and the body turns with
:math:`\omega_b = \mathbf j_b(\mathbf q)\,\dot{\mathbf q}`.  The kinetic energy

.. math::

    T ={}& \tfrac12 \sum_b \left(m_b \mathbf v_b^2 + I_b \omega_b^2\right)
        + \tfrac12 \sum_i J_i \dot q_i^2
      = \tfrac12 \dot{\mathbf q}^\top \mathbf M(\mathbf q)\, \dot{\mathbf q}, \\
    \mathbf M ={}& \sum_b \left(m_b \mathbf J_b^\top \mathbf J_b + I_b \mathbf j_b^\top \mathbf j_b\right)
        + \operatorname{diag}(J_i),

and Lagrange's equations (the rigid counterpart of (2.6)) give the motor torques

.. math::

    \boldsymbol\tau ={}& \mathbf M(\mathbf q)\,\ddot{\mathbf q} + \mathbf h(\mathbf q, \dot{\mathbf q})
        + \mathbf g(\mathbf q), \\
    \mathbf h ={}& \dot{\mathbf M}\dot{\mathbf q} - \frac{\partial T}{\partial \mathbf q}
      = \sum_b \left(m_b \mathbf J_b^\top \mathbf a_{b,0} + I_b \mathbf j_b^\top \alpha_{b,0}\right), \\
    \mathbf g ={}& \frac{\partial V}{\partial \mathbf q} = g \sum_b m_b \mathbf J_b^\top \mathbf e_y ,

where :math:`\mathbf a_{b,0}` and :math:`\alpha_{b,0}` are the acceleration and angular
acceleration of body :math:`b` for the actual :math:`\dot{\mathbf q}` and
:math:`\ddot{\mathbf q} = 0` (exact, since accelerations are affine in :math:`\ddot{\mathbf q}`
with the Jacobians as slope).  The Jacobians and :math:`\mathbf a_{b,0}` come from
:func:`fivebar.model.kinematics.rigid_state` with unit crank speeds.

Bodies (uniform flat bars of mass :math:`\rho A L` with centroidal inertia :math:`mL^2/12`
about the normal to the plane): the moving links of the description (for the five-bar the
cranks L1, L4 and the couplers L2, L3); the lumped masses at its pins (:math:`m_{01}` at B and
:math:`m_{02}` at C, section 5) and the slider blocks (point masses that do not turn); the rotor :math:`J_0` of the motor section each crank names
(section 5), rigidly coupled to its crank, optionally with the polar inertia of the motor
shaft (a crank without a motor has none).  Gravity (``params.gravity``, an assumption, zero by
default) acts along :math:`-y`.

The links' part of :math:`\mathbf M` equals the consistent finite-element mass of
:mod:`fivebar.model.assembly` projected on the rigid-body velocity fields (checked by the library's tests).  The
rotors differ: the torsion shape functions of the motor element (A.3) vanish at the rotor, so
:math:`J_0` drives no elastic DOF there, while here it turns with its crank and resists every
change of crank speed.  At constant crank speed it does no work and drops out of the torques.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from .kinematics import _split, crank_laws, rigid_state
from ..description.params import Params

__all__ = [
    "InertiaModel",
    "inertia_model",
    "mass_matrix",
    "velocity_terms",
    "gravity_terms",
    "inverse_dynamics",
    "forward_dynamics",
    "kinetic_energy",
    "potential_energy",
    "motor_torques",
]

@dataclass(frozen=True)
class InertiaModel:
    """Masses and inertias of the rigid linkage (SI).

    Attributes
    ----------
    link_mass
        Mass of each moving link of the description (kg), by link name ("L1".."L4" for the
        five-bar).
    link_inertia
        Moment of inertia of each link about its centre of mass, normal to the plane (kg m^2).
    link_com
        Position of each link's centre of mass as a fraction of its length from its start joint
        (the link's ``start``); 0.5 for a uniform bar (the default, ``None``).
    masses
        Lumped mass at each pin that carries one, by joint name (kg): ``{"B": m01, "C": m02}``
        for the five-bar.
    rotors
        Rotary inertia turning with each crank, by the crank's joint (kg m^2): the motor rotor,
        and its shaft if included (``{"A": J1, "E": J2}`` for the five-bar); a crank that is
        not in the mapping has none.
    """

    link_mass: Mapping[str, float]
    link_inertia: Mapping[str, float]
    link_com: Mapping[str, float] | None = None
    masses: Mapping[str, float] = field(default_factory=dict)
    rotors: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        bars = list(self.link_mass)
        if self.link_com is None:
            object.__setattr__(self, "link_com", {k: 0.5 for k in bars})
        for name, table in (("link_mass", self.link_mass), ("link_inertia", self.link_inertia), ("link_com", self.link_com)):
            if set(table) != set(bars):
                raise InputError(f"InertiaModel.{name} has keys {sorted(table)}: it must have exactly {bars}")
            for k, v in table.items():
                _nonneg(f"InertiaModel.{name}[{k!r}]", v)
        for name in ("masses", "rotors"):
            for k, v in getattr(self, name).items():
                _nonneg(f"InertiaModel.{name}[{k!r}]", v)

    def replace(self, **changes) -> "InertiaModel":
        """A copy with some fields changed (validated), e.g. ``model.replace(rotors={})``."""
        return replace(self, **changes)


def _nonneg(name: str, value: float) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) or not math.isfinite(value) or value < 0:
        raise InputError(f"{name} = {value!r} is not allowed: it must be a finite number >= 0")


def inertia_model(params: Params, shaft_inertia: bool = False) -> InertiaModel:
    """The masses and inertias of the rigid model from the parameters.

    ``model = inertia_model(params)``

    Parameters
    ----------
    params
        The parameter set: the description's links (length, section, material), the lumped
        masses at its pins and the rotor inertia ``J0`` (section 5) of the motor each crank
        names (:attr:`fivebar.description.params.Params.crank_motors`).
    shaft_inertia
        Add the polar inertia of each motor shaft, :math:`\\rho_s (\\pi d^4/32) (l_1+l_2+l_3)`
        (shaft diameter and material are assumptions), to the rotor inertia.  Off by default:
        a manufacturer's rotor inertia normally includes its shaft.

    Returns
    -------
    InertiaModel
    """
    links = params.linkage.links
    lengths = {k.name: k.length for k in links}
    mass = {k.name: k.material.rho * k.section.area * k.length for k in links}
    inertia = {k: mass[k] * lengths[k] ** 2 / 12.0 for k in lengths}

    def rotor(m) -> float:
        J = m.J0
        if shaft_inertia:
            J += m.shaft_rho * math.pi * m.shaft_diameter**4 / 32.0 * (m.l1 + m.l2 + m.l3)
        return J

    return InertiaModel(
        link_mass=mass, link_inertia=inertia, masses=dict(params.linkage.masses),
        rotors={joint: rotor(m) for joint, m in params.crank_motors.items()},
    )


@dataclass(frozen=True)
class _Terms:
    M: NDArray  # (..., n, n), n the number of driven cranks
    h: NDArray  # (..., n)
    g: NDArray  # (..., n)
    T: NDArray  # (...)
    V: NDArray  # (...)


def _check_keys(model: InertiaModel, params: Params) -> None:
    """The inertia model's links, pins and cranks must be the description's."""
    lk = params.linkage
    for name, table, allowed in (("link_mass", model.link_mass, lk.link_names),
                                 ("masses", model.masses, list(lk.masses)),
                                 ("rotors", model.rotors, [j.name for j in lk.inputs if j.kind == "crank"])):
        bad = sorted(set(table) - set(allowed))
        if bad:
            raise InputError(f"InertiaModel.{name} names {bad}, which the linkage {lk.name!r} does not have: "
                             f"use {list(allowed)}")


def _terms(params: Params, theta: list[NDArray], omega: list[NDArray], inertia: InertiaModel | None,
           mode: int) -> _Terms:
    """Mass matrix, velocity, gravity terms and energies in one pass over the kinematics, for
    the crank angles ``theta`` and speeds ``omega`` (one array per driven crank, chain order)."""
    model = inertia_model(params) if inertia is None else inertia
    _check_keys(model, params)
    cranks = [j.name for j in params.linkage.cranks]
    n = len(cranks)
    arrs = np.broadcast_arrays(*theta, *omega)
    th, w = arrs[:n], arrs[n:]
    shape = th[0].shape
    one, zero = np.ones(shape), np.zeros(shape)
    # n + 1 rigid states at once (axis 0): unit speed of each crank in turn, then the actual
    # speeds, all with zero crank accelerations
    laws = []
    for i in range(n):
        laws += [np.stack([th[i]] * (n + 1)), np.stack([one if k == i else zero for k in range(n)] + [w[i]]),
                 np.stack([zero] * (n + 1))]
    st = rigid_state(params, *laws, mode=mode)
    points = [st.point(k, model.link_com[k]) + (model.link_mass[k],) for k in model.link_mass]
    points += [(st.pos[j], st.vel[j], st.acc[j], m) for j, m in model.masses.items()]
    grav = params.gravity
    M = np.zeros(shape + (n, n))
    h = np.zeros(shape + (n,))
    g = np.zeros(shape + (n,))
    T = np.zeros(shape)
    V = np.zeros(shape)
    for p, v, a, m in points:
        J = np.stack([v[i] for i in range(n)], axis=-1)  # (..., 2 components, n coordinates)
        M += m * np.einsum("...ki,...kj->...ij", J, J)
        h += m * np.einsum("...ki,...k->...i", J, a[n])
        g += m * grav * J[..., 1, :]
        T += 0.5 * m * np.sum(v[n] ** 2, axis=-1)
        V += m * grav * p[0][..., 1]
    for k in model.link_mass:
        I = model.link_inertia[k]
        j = np.stack([st.omega[k][i] for i in range(n)], axis=-1)  # (..., n)
        M += I * j[..., :, None] * j[..., None, :]
        h += I * j * st.alpha[k][n][..., None]
        T += 0.5 * I * st.omega[k][n] ** 2
    for i, joint in enumerate(cranks):
        J = model.rotors.get(joint, 0.0)
        M[..., i, i] += J
        T += 0.5 * J * w[i] ** 2
    return _Terms(M=M, h=h, g=g, T=T, V=V)


def _args(params: Params, args: tuple, per: int, what: str) -> list[NDArray]:
    """``per`` arrays per driven crank (checked against the description), broadcast."""
    return _split(params.linkage, args, per, 1, what)[0]


def _at_rest(params: Params, theta: tuple, inertia: InertiaModel | None, mode: int) -> _Terms:
    """The terms at the crank angles ``theta`` (one per crank) with the cranks at rest."""
    th = _args(params, theta, 1, "crank angles")
    return _terms(params, th, [np.zeros_like(x) for x in th], inertia, mode)


def _moving(params: Params, angles_and_speeds: tuple, inertia: InertiaModel | None, mode: int) -> _Terms:
    """The terms at the crank angles and speeds (all angles, then all speeds)."""
    x = _args(params, angles_and_speeds, 2, "crank angles and speeds")
    n = len(x) // 2
    return _terms(params, x[:n], x[n:], inertia, mode)


def _stack(x: list[NDArray], shape: tuple[int, ...]) -> NDArray:
    """Per-crank arrays stacked to ``shape + (n,)``, broadcast with ``shape``."""
    return np.stack(np.broadcast_arrays(*x, np.empty(shape))[:-1], axis=-1)


def mass_matrix(params: Params, *theta: ArrayLike, inertia: InertiaModel | None = None, mode: int = 1) -> NDArray:
    """Mass matrix M(q) of the rigid linkage in q = the crank angles.

    ``M = mass_matrix(params, theta1, theta4)`` for the five-bar, ``mass_matrix(params, theta)``
    for a four-bar.

    Parameters
    ----------
    params
        The parameter set.
    *theta
        Crank angles (rad), one per driven crank of the description (chain order), broadcast
        together to a shape ``S``.
    inertia
        Masses and inertias; ``None`` takes :func:`inertia_model` ``(params)``.
    mode
        Assembly mode (:func:`fivebar.model.kinematics.positions`).

    Returns
    -------
    ndarray, shape ``S + (n, n)``
        Symmetric positive definite (kg m^2): T = 1/2 q'^T M q', n the number of cranks.
    """
    return _at_rest(params, theta, inertia, mode).M


def velocity_terms(params: Params, *angles_and_speeds: ArrayLike, inertia: InertiaModel | None = None,
                   mode: int = 1) -> NDArray:
    """Coriolis and centripetal torques h(q, q') = M' q' - dT/dq (N m).

    ``h = velocity_terms(params, theta1, theta4, omega1, omega4)`` for the five-bar.

    Parameters
    ----------
    *angles_and_speeds
        The crank angles (rad), then the crank angular velocities (rad/s), one of each per
        driven crank (chain order); all broadcast to a shape ``S``.
    inertia, mode
        See :func:`mass_matrix`.

    Returns
    -------
    ndarray, shape ``S + (n,)``
        Quadratic in the crank speeds: the torques the motors must supply at zero crank
        acceleration (without gravity).
    """
    return _moving(params, angles_and_speeds, inertia, mode).h


def gravity_terms(params: Params, *theta: ArrayLike, inertia: InertiaModel | None = None, mode: int = 1) -> NDArray:
    """Gravity torques dV/dq for gravity ``params.gravity`` along -y (N m), shape ``S + (n,)``;
    arguments as in :func:`mass_matrix`."""
    return _at_rest(params, theta, inertia, mode).g


def kinetic_energy(params: Params, *angles_and_speeds: ArrayLike, inertia: InertiaModel | None = None,
                   mode: int = 1) -> NDArray:
    """Kinetic energy T (J) of links, lumped masses and rotors, shape ``S``.

    Summed body by body, 1/2 m v_G^2 + 1/2 I_G w^2 + 1/2 J q'^2, not through M.
    Arguments as in :func:`velocity_terms`.
    """
    return _moving(params, angles_and_speeds, inertia, mode).T


def potential_energy(params: Params, *theta: ArrayLike, inertia: InertiaModel | None = None, mode: int = 1) -> NDArray:
    """Gravitational potential energy V = g sum m y_G (J), zero level y = 0, shape ``S``;
    arguments as in :func:`mass_matrix`."""
    return _at_rest(params, theta, inertia, mode).V


def inverse_dynamics(params: Params, *laws: ArrayLike, inertia: InertiaModel | None = None, mode: int = 1) -> NDArray:
    """Motor torques that drive the rigid linkage along given crank laws.

    ``tau = inverse_dynamics(params, *crank_laws(params, t))``; for the five-bar
    ``inverse_dynamics(params, theta1, omega1, alpha1, theta4, omega4, alpha4)``.

    tau = M(q) q'' + h(q, q') + g(q), Lagrange's equations of the rigid system.

    Parameters
    ----------
    *laws
        Per driven crank (chain order) its angle (rad), angular velocity (rad/s) and angular
        acceleration (rad/s^2), as :func:`fivebar.model.kinematics.rigid_state` takes them; all
        broadcast to a shape ``S``.
    inertia, mode
        See :func:`mass_matrix`.

    Returns
    -------
    ndarray, shape ``S + (n,)``
        The torque (N m) on each crank, positive anticlockwise: (tau1, tau4) of motor 1 on
        crank AB and motor 2 on crank ED for the five-bar.
    """
    x = _args(params, laws, 3, "crank law arrays")
    tm = _terms(params, x[0::3], x[1::3], inertia, mode)
    qdd = _stack(x[2::3], tm.T.shape)
    return np.einsum("...ij,...j->...i", tm.M, qdd) + tm.h + tm.g


def forward_dynamics(params: Params, *state_and_torques: ArrayLike, inertia: InertiaModel | None = None,
                     mode: int = 1) -> NDArray:
    """Crank accelerations q'' = M^-1 (tau - h - g) under given motor torques (N m).

    ``alpha = forward_dynamics(params, theta1, theta4, omega1, omega4, tau1, tau4)`` for the
    five-bar: the crank angles (rad), then the crank speeds (rad/s), then the torques (N m),
    one of each per driven crank (chain order).

    Returns
    -------
    ndarray, shape ``S + (n,)``
        The crank accelerations (rad/s^2): (alpha1, alpha4) for the five-bar.
    """
    x = _args(params, state_and_torques, 3, "crank angles, speeds and torques")
    n = len(x) // 3
    tm = _terms(params, x[:n], x[n:2 * n], inertia, mode)
    tau = _stack(x[2 * n:], tm.T.shape)
    return np.linalg.solve(tm.M, (tau - tm.h - tm.g)[..., None])[..., 0]


def motor_torques(
    params: Params, t: ArrayLike, crank_speed_rad_s: float | None = None, *, inertia: InertiaModel | None = None, mode: int = 1
) -> NDArray:
    """Motor torques (N m) along the default crank laws at times ``t`` (s).

    ``tau = motor_torques(params, t)``: :func:`inverse_dynamics` along
    :func:`fivebar.model.kinematics.crank_laws` (both cranks at constant speed, an assumption), at the
    speed ``crank_speed_rad_s`` (rad/s; ``None`` takes ``params.crank_speed_rad_s``).  At constant speed the
    rotor inertias do no work and the torques scale with the square of the speed.

    Returns
    -------
    ndarray, shape ``t.shape + (n,)``
        The torque on each driven crank: (tau1, tau4) for the five-bar.
    """
    return inverse_dynamics(params, *crank_laws(params, t, crank_speed_rad_s), inertia=inertia, mode=mode)
