r"""Rigid-body dynamics of the two-degree-of-freedom five-bar (Lagrange's equations).

The rigid linkage of Figure 1 has two degrees of freedom, the crank angles
:math:`\mathbf q = (\theta_1, \theta_4)`.  Every body's velocity is linear in
:math:`\dot{\mathbf q}`: the centre of mass :math:`G_b` of body :math:`b` moves with
:math:`\mathbf v_b = \mathbf J_b(\mathbf q)\,\dot{\mathbf q}` and the body turns with
:math:`\omega_b = \mathbf j_b(\mathbf q)\,\dot{\mathbf q}`.  The kinetic energy

.. math::

    T ={}& \tfrac12 \sum_b \left(m_b \mathbf v_b^2 + I_b \omega_b^2\right)
        + \tfrac12 J_1 \dot\theta_1^2 + \tfrac12 J_2 \dot\theta_4^2
      = \tfrac12 \dot{\mathbf q}^\top \mathbf M(\mathbf q)\, \dot{\mathbf q}, \\
    \mathbf M ={}& \sum_b \left(m_b \mathbf J_b^\top \mathbf J_b + I_b \mathbf j_b^\top \mathbf j_b\right)
        + \operatorname{diag}(J_1, J_2),

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
:func:`fivebar.kinematics.rigid_state` with unit crank speeds.

Bodies (uniform flat bars of mass :math:`\rho A L` with centroidal inertia :math:`mL^2/12`
about the normal to the plane): the cranks L1, L4 and the couplers L2, L3; the lumped masses
:math:`m_{01}` at B and :math:`m_{02}` at C (section 5); the motor rotors
:math:`J_0` (section 5), rigidly coupled to the cranks, on :math:`\theta_1` and
:math:`\theta_4`, optionally with the polar inertia of the motor shafts.  Gravity
(``params.gravity``, an assumption, zero by default) acts along :math:`-y`.

The links' part of :math:`\mathbf M` equals the consistent finite-element mass of
:mod:`fivebar.assembly` projected on the rigid-body velocity fields (tests/test_rigid.py).  The
rotors differ: the torsion shape functions of the motor element (A.3) vanish at the rotor, so
:math:`J_0` drives no elastic DOF there, while here it turns with its crank and resists every
change of crank speed.  At constant crank speed it does no work and drops out of the torques.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import InputError
from .kinematics import crank_laws, rigid_state
from .params import Params

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
    """Masses and inertias of the rigid five-bar (SI).

    Attributes
    ----------
    link_mass
        Mass of each moving link of the description ("L1".."L4") (kg).
    link_inertia
        Moment of inertia of each link about its centre of mass, normal to the plane (kg m^2).
    link_com
        Position of each link's centre of mass as a fraction of its length from its start joint
        (the link's ``start``); 0.5 for a uniform bar (the default, ``None``).
    m01, m02
        Lumped masses at B and C (kg).
    J1, J2
        Rotary inertia turning with crank AB (theta1) and crank ED (theta4): motor rotor, and
        shaft if included (kg m^2).
    """

    link_mass: Mapping[str, float]
    link_inertia: Mapping[str, float]
    link_com: Mapping[str, float] | None = None
    m01: float = 0.0
    m02: float = 0.0
    J1: float = 0.0
    J2: float = 0.0

    def __post_init__(self) -> None:
        bars = list(self.link_mass)
        if self.link_com is None:
            object.__setattr__(self, "link_com", {k: 0.5 for k in bars})
        for name, table in (("link_mass", self.link_mass), ("link_inertia", self.link_inertia), ("link_com", self.link_com)):
            if set(table) != set(bars):
                raise InputError(f"InertiaModel.{name} has keys {sorted(table)}: it must have exactly {bars}")
            for k, v in table.items():
                _nonneg(f"InertiaModel.{name}[{k!r}]", v)
        for name in ("m01", "m02", "J1", "J2"):
            _nonneg(f"InertiaModel.{name}", getattr(self, name))

    def replace(self, **changes) -> "InertiaModel":
        """A copy with some fields changed (validated), e.g. ``model.replace(m02=0.0)``."""
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
        The parameter set: lengths, ``width * thickness`` (the section A), ``rho``, ``m01``,
        ``m02`` and the motors' rotor inertias ``J0`` (section 5).
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
        link_mass=mass, link_inertia=inertia, m01=params.m01, m02=params.m02, J1=rotor(params.motor1), J2=rotor(params.motor2)
    )


@dataclass(frozen=True)
class _Terms:
    M: NDArray  # (..., 2, 2)
    h: NDArray  # (..., 2)
    g: NDArray  # (..., 2)
    T: NDArray  # (...)
    V: NDArray  # (...)


def _terms(
    params: Params, theta1: ArrayLike, theta4: ArrayLike, omega1: ArrayLike, omega4: ArrayLike,
    inertia: InertiaModel | None, mode: int,
) -> _Terms:
    """Mass matrix, velocity, gravity terms and energies in one pass over the kinematics."""
    model = inertia_model(params) if inertia is None else inertia
    t1, t4, w1, w4 = np.broadcast_arrays(*(np.asarray(x, float) for x in (theta1, theta4, omega1, omega4)))
    one, zero = np.ones(t1.shape), np.zeros(t1.shape)
    # three rigid states at once: unit speed of crank 1, unit speed of crank 4, the actual
    # speeds with zero crank accelerations (axis 0)
    st = rigid_state(
        params,
        np.stack([t1, t1, t1]), np.stack([one, zero, w1]), np.stack([zero, zero, zero]),
        np.stack([t4, t4, t4]), np.stack([zero, one, w4]), np.stack([zero, zero, zero]),
        mode,
    )
    points = [st.point(k, model.link_com[k]) + (model.link_mass[k],) for k in model.link_mass]
    points += [(st.pos[j], st.vel[j], st.acc[j], m) for j, m in (("B", model.m01), ("C", model.m02))]
    grav = params.gravity
    M = np.zeros(t1.shape + (2, 2))
    h = np.zeros(t1.shape + (2,))
    g = np.zeros(t1.shape + (2,))
    T = np.zeros(t1.shape)
    V = np.zeros(t1.shape)
    for p, v, a, m in points:
        J = np.stack([v[0], v[1]], axis=-1)  # (..., 2 components, 2 coordinates)
        M += m * np.einsum("...ki,...kj->...ij", J, J)
        h += m * np.einsum("...ki,...k->...i", J, a[2])
        g += m * grav * J[..., 1, :]
        T += 0.5 * m * np.sum(v[2] ** 2, axis=-1)
        V += m * grav * p[0][..., 1]
    for k in model.link_mass:
        I = model.link_inertia[k]
        j = np.stack([st.omega[k][0], st.omega[k][1]], axis=-1)  # (..., 2)
        M += I * j[..., :, None] * j[..., None, :]
        h += I * j * st.alpha[k][2][..., None]
        T += 0.5 * I * st.omega[k][2] ** 2
    M[..., 0, 0] += model.J1
    M[..., 1, 1] += model.J2
    T += 0.5 * (model.J1 * w1**2 + model.J2 * w4**2)
    return _Terms(M=M, h=h, g=g, T=T, V=V)


def _pair(x1: ArrayLike, x4: ArrayLike, shape: tuple[int, ...]) -> NDArray:
    """Stack two per-crank arrays to ``shape + (2,)``, broadcasting both with ``shape``."""
    x1, x4, _ = np.broadcast_arrays(np.asarray(x1, float), np.asarray(x4, float), np.empty(shape))
    return np.stack([x1, x4], axis=-1)


def mass_matrix(
    params: Params, theta1: ArrayLike, theta4: ArrayLike, *, inertia: InertiaModel | None = None, mode: int = 1
) -> NDArray:
    """Mass matrix M(q) of the rigid five-bar in q = (theta1, theta4).

    ``M = mass_matrix(params, theta1, theta4)``

    Parameters
    ----------
    params
        The parameter set.
    theta1, theta4
        Crank angles (rad), broadcast together to a shape ``S``.
    inertia
        Masses and inertias; ``None`` takes :func:`inertia_model` ``(params)``.
    mode
        Assembly mode (:func:`fivebar.kinematics.positions`).

    Returns
    -------
    ndarray, shape ``S + (2, 2)``
        Symmetric positive definite (kg m^2): T = 1/2 q'^T M q'.
    """
    return _terms(params, theta1, theta4, 0.0, 0.0, inertia, mode).M


def velocity_terms(
    params: Params, theta1: ArrayLike, theta4: ArrayLike, omega1: ArrayLike, omega4: ArrayLike,
    *, inertia: InertiaModel | None = None, mode: int = 1,
) -> NDArray:
    """Coriolis and centripetal torques h(q, q') = M' q' - dT/dq (N m).

    ``h = velocity_terms(params, theta1, theta4, omega1, omega4)``

    Parameters
    ----------
    theta1, theta4
        Crank angles (rad).
    omega1, omega4
        Crank angular velocities (rad/s); all four broadcast to a shape ``S``.
    inertia, mode
        See :func:`mass_matrix`.

    Returns
    -------
    ndarray, shape ``S + (2,)``
        Quadratic in (omega1, omega4): the torques the motors must supply at zero crank
        acceleration (without gravity).
    """
    return _terms(params, theta1, theta4, omega1, omega4, inertia, mode).h


def gravity_terms(
    params: Params, theta1: ArrayLike, theta4: ArrayLike, *, inertia: InertiaModel | None = None, mode: int = 1
) -> NDArray:
    """Gravity torques dV/dq for gravity ``params.gravity`` along -y (N m), shape ``S + (2,)``."""
    return _terms(params, theta1, theta4, 0.0, 0.0, inertia, mode).g


def kinetic_energy(
    params: Params, theta1: ArrayLike, theta4: ArrayLike, omega1: ArrayLike, omega4: ArrayLike,
    *, inertia: InertiaModel | None = None, mode: int = 1,
) -> NDArray:
    """Kinetic energy T (J) of links, lumped masses and rotors, shape ``S``.

    Summed body by body, 1/2 m v_G^2 + 1/2 I_G w^2 + 1/2 J q'^2, not through M.
    Arguments as in :func:`velocity_terms`.
    """
    return _terms(params, theta1, theta4, omega1, omega4, inertia, mode).T


def potential_energy(
    params: Params, theta1: ArrayLike, theta4: ArrayLike, *, inertia: InertiaModel | None = None, mode: int = 1
) -> NDArray:
    """Gravitational potential energy V = g sum m y_G (J), zero level y = 0, shape ``S``."""
    return _terms(params, theta1, theta4, 0.0, 0.0, inertia, mode).V


def inverse_dynamics(
    params: Params,
    theta1: ArrayLike, omega1: ArrayLike, alpha1: ArrayLike,
    theta4: ArrayLike, omega4: ArrayLike, alpha4: ArrayLike,
    *, inertia: InertiaModel | None = None, mode: int = 1,
) -> NDArray:
    """Motor torques that drive the rigid linkage along given crank laws.

    ``tau = inverse_dynamics(params, *crank_laws(params, t))``

    tau = M(q) q'' + h(q, q') + g(q), Lagrange's equations of the rigid system.

    Parameters
    ----------
    theta1, omega1, alpha1
        Angle (rad), angular velocity (rad/s) and acceleration (rad/s^2) of crank AB.
    theta4, omega4, alpha4
        The same for crank ED; all six broadcast to a shape ``S``.
    inertia, mode
        See :func:`mass_matrix`.

    Returns
    -------
    ndarray, shape ``S + (2,)``
        (tau1, tau4): torques (N m) of motor 1 on crank AB and motor 2 on crank ED,
        positive anticlockwise.
    """
    tm = _terms(params, theta1, theta4, omega1, omega4, inertia, mode)
    qdd = _pair(alpha1, alpha4, tm.T.shape)
    return np.einsum("...ij,...j->...i", tm.M, qdd) + tm.h + tm.g


def forward_dynamics(
    params: Params,
    theta1: ArrayLike, theta4: ArrayLike, omega1: ArrayLike, omega4: ArrayLike,
    tau1: ArrayLike, tau4: ArrayLike,
    *, inertia: InertiaModel | None = None, mode: int = 1,
) -> NDArray:
    """Crank accelerations q'' = M^-1 (tau - h - g) under given motor torques (N m).

    ``alpha = forward_dynamics(params, theta1, theta4, omega1, omega4, tau1, tau4)``

    Returns
    -------
    ndarray, shape ``S + (2,)``
        (alpha1, alpha4) in rad/s^2.
    """
    tm = _terms(params, theta1, theta4, omega1, omega4, inertia, mode)
    tau = _pair(tau1, tau4, tm.T.shape)
    return np.linalg.solve(tm.M, (tau - tm.h - tm.g)[..., None])[..., 0]


def motor_torques(
    params: Params, t: ArrayLike, crank_speed: float | None = None, *, inertia: InertiaModel | None = None, mode: int = 1
) -> NDArray:
    """Motor torques (N m) along the default crank laws at times ``t`` (s).

    ``tau = motor_torques(params, t)``: :func:`inverse_dynamics` along
    :func:`fivebar.kinematics.crank_laws` (both cranks at constant speed, an assumption), at the
    speed ``crank_speed`` (rad/s; ``None`` takes ``params.crank_speed``).  At constant speed the
    rotor inertias do no work and the torques scale with the square of the speed.

    Returns
    -------
    ndarray, shape ``t.shape + (2,)``
        (tau1, tau4).
    """
    return inverse_dynamics(params, *crank_laws(params, t, crank_speed), inertia=inertia, mode=mode)
