r"""Rigid-body kinematics of the five-bar linkage (Figure 1 of the paper).

Ground pivots :math:`A = (0, 0)` and :math:`E = (L_5, 0)`; crank AB (:math:`L_1`) at angle
:math:`\theta_1`, crank ED (:math:`L_4`) at angle :math:`\theta_4`, both measured
anticlockwise from the x axis (the direction A to E); couplers BC (:math:`L_2`) and CD
(:math:`L_3`) pinned at C.  The loop closes by

.. math::

    \mathbf r_B + L_2 \mathbf e(\beta_2) + L_3 \mathbf e(\beta_3) = \mathbf r_D ,
    \qquad \mathbf e(\beta) = (\cos\beta, \sin\beta),

with :math:`\beta_2` the angle of B to C and :math:`\beta_3` the angle of C to D.  Its first
and second time derivatives give the coupler angular velocities and accelerations (a 2 x 2
linear system, singular only when the couplers are collinear, which this linkage never
reaches: :math:`50 \le |BD| \le 750` mm against :math:`L_2 + L_3 = 800` mm).

The rigid motion is the "given trajectory" of the kineto-elastodynamic model: the elastic
equation (2.7) is driven by the rigid accelerations :math:`\ddot{\mathbf u}_r` computed here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FivebarError, InputError
from .params import Params

__all__ = [
    "GeometryError",
    "LINKS",
    "RigidState",
    "positions",
    "link_angles",
    "rigid_state",
    "constant_speed_laws",
    "crank_laws",
]

#: Link name -> (start joint, end joint) in the direction used for the link angle.
LINKS = {"L1": ("A", "B"), "L2": ("B", "C"), "L3": ("C", "D"), "L4": ("E", "D")}


class GeometryError(FivebarError, ValueError):
    """The loop cannot close for the given crank angles."""


def _e(beta: NDArray) -> NDArray:
    return np.stack([np.cos(beta), np.sin(beta)], axis=-1)


def _n(beta: NDArray) -> NDArray:
    return np.stack([-np.sin(beta), np.cos(beta)], axis=-1)


def _angle(d: NDArray) -> NDArray:
    return np.arctan2(d[..., 1], d[..., 0])


def _check_mode(mode: int) -> None:
    if mode not in (1, -1):
        raise InputError(f"assembly mode {mode!r} is not allowed: use +1 (C to the left of B->D) or -1")


def positions(params: Params, theta1: ArrayLike, theta4: ArrayLike, mode: int = 1) -> dict[str, NDArray]:
    """Joint coordinates for given crank angles.

    Parameters
    ----------
    params
        The parameter set (lengths L1..L5 in m).
    theta1, theta4
        Crank angles (rad) of AB and ED, anticlockwise from the x axis; broadcast together.
    mode
        Assembly mode: +1 puts C to the left of the directed line B to D (above AE at
        theta1 = theta4 = 0), -1 to the right.

    Returns
    -------
    dict
        ``{"A", "B", "C", "D", "E"}`` -> arrays of shape ``(..., 2)`` in m.

    Raises
    ------
    GeometryError
        If the distance BD is outside [abs(L2 - L3), L2 + L3]; the message names the crank
        angles and the distance BD.
    """
    _check_mode(mode)
    t1, t4 = np.broadcast_arrays(np.asarray(theta1, float), np.asarray(theta4, float))
    L1, L2, L3, L4, L5 = params.lengths
    A = np.zeros(t1.shape + (2,))
    E = A + np.array([L5, 0.0])
    B = A + L1 * _e(t1)
    D = E + L4 * _e(t4)
    d = D - B
    r = np.hypot(d[..., 0], d[..., 1])
    bad = (r > L2 + L3) | (r < abs(L2 - L3)) | (r == 0)
    if np.any(bad):
        i = np.flatnonzero(bad.ravel())[0]
        raise GeometryError(
            f"the loop cannot close at theta1 = {np.degrees(t1.ravel()[i]):.6g} deg, "
            f"theta4 = {np.degrees(t4.ravel()[i]):.6g} deg: |BD| = {1e3 * r.ravel()[i]:.6g} mm "
            f"must lie in [{1e3 * abs(L2 - L3):.6g}, {1e3 * (L2 + L3):.6g}] mm (|L2 - L3|, L2 + L3)"
        )
    a = (L2**2 - L3**2 + r**2) / (2 * r)
    h = np.sqrt(np.maximum(L2**2 - a**2, 0.0))
    u = d / r[..., None]
    perp = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    C = B + a[..., None] * u + mode * h[..., None] * perp
    return {"A": A, "B": B, "C": C, "D": D, "E": E}


def link_angles(params: Params, theta1: ArrayLike, theta4: ArrayLike, mode: int = 1) -> dict[str, NDArray]:
    """Angles (rad) of the links L1 (A->B), L2 (B->C), L3 (C->D), L4 (E->D) to the x axis."""
    P = positions(params, theta1, theta4, mode)
    return {name: _angle(P[e] - P[s]) for name, (s, e) in LINKS.items()}


@dataclass(frozen=True)
class RigidState:
    """Rigid-body state of the linkage at one or many instants.

    ``pos``, ``vel``, ``acc`` map joints "A".."E" to arrays ``(..., 2)`` (m, m/s, m/s^2);
    ``angle``, ``omega``, ``alpha`` map links "L1".."L4" to arrays ``(...)`` (rad, rad/s,
    rad/s^2), with the link directions of :data:`LINKS`.
    """

    pos: dict[str, NDArray]
    vel: dict[str, NDArray]
    acc: dict[str, NDArray]
    angle: dict[str, NDArray]
    omega: dict[str, NDArray]
    alpha: dict[str, NDArray]

    def point(self, link: str, s: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
        """Position, velocity and acceleration of the point at fraction ``s`` along a link.

        ``s = 0`` is the link's start joint and ``s = 1`` its end joint (:data:`LINKS`).
        Returns three arrays of shape ``(..., 2)`` (m, m/s, m/s^2).
        """
        start, end = LINKS[link]
        L = np.linalg.norm(self.pos[end] - self.pos[start], axis=-1)
        s = np.asarray(s, float)
        b, w, al = self.angle[link], self.omega[link], self.alpha[link]
        ell = (s * L)[..., None]
        p = self.pos[start] + ell * _e(b)
        v = self.vel[start] + ell * w[..., None] * _n(b)
        a = self.acc[start] + ell * (al[..., None] * _n(b) - (w**2)[..., None] * _e(b))
        return p, v, a


def rigid_state(
    params: Params,
    theta1: ArrayLike,
    omega1: ArrayLike,
    alpha1: ArrayLike,
    theta4: ArrayLike,
    omega4: ArrayLike,
    alpha4: ArrayLike,
    mode: int = 1,
) -> RigidState:
    """Positions, velocities and accelerations for crank laws given with their derivatives.

    ``state = rigid_state(params, *crank_laws(params, t))``

    Parameters
    ----------
    theta1, omega1, alpha1
        Angle (rad), angular velocity (rad/s) and angular acceleration (rad/s^2) of crank AB.
    theta4, omega4, alpha4
        The same for crank ED.
    mode
        Assembly mode, see :func:`positions`.
    """
    t1, w1, a1, t4, w4, a4 = np.broadcast_arrays(
        *(np.asarray(x, float) for x in (theta1, omega1, alpha1, theta4, omega4, alpha4))
    )
    L1, L2, L3, L4, L5 = params.lengths
    P = positions(params, t1, t4, mode)
    zero = np.zeros(t1.shape + (2,))
    vB = L1 * w1[..., None] * _n(t1)
    aB = L1 * (a1[..., None] * _n(t1) - (w1**2)[..., None] * _e(t1))
    vD = L4 * w4[..., None] * _n(t4)
    aD = L4 * (a4[..., None] * _n(t4) - (w4**2)[..., None] * _e(t4))
    b2 = _angle(P["C"] - P["B"])
    b3 = _angle(P["D"] - P["C"])
    # [L2 n2, L3 n3] [w2, w3]^T = vD - vB
    Amat = np.stack([L2 * _n(b2), L3 * _n(b3)], axis=-1)  # (..., 2, 2)
    w23 = np.linalg.solve(Amat, (vD - vB)[..., None])[..., 0]
    w2, w3 = w23[..., 0], w23[..., 1]
    rhs = aD - aB + L2 * (w2**2)[..., None] * _e(b2) + L3 * (w3**2)[..., None] * _e(b3)
    a23 = np.linalg.solve(Amat, rhs[..., None])[..., 0]
    al2, al3 = a23[..., 0], a23[..., 1]
    vC = vB + L2 * w2[..., None] * _n(b2)
    aC = aB + L2 * (al2[..., None] * _n(b2) - (w2**2)[..., None] * _e(b2))
    return RigidState(
        pos=P,
        vel={"A": zero, "B": vB, "C": vC, "D": vD, "E": zero},
        acc={"A": zero, "B": aB, "C": aC, "D": aD, "E": zero},
        angle={"L1": t1, "L2": b2, "L3": b3, "L4": t4},
        omega={"L1": w1, "L2": w2, "L3": w3, "L4": w4},
        alpha={"L1": a1, "L2": al2, "L3": al3, "L4": a4},
    )


def crank_laws(
    params: Params, t: ArrayLike, crank_speed: float | None = None
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray, NDArray]:
    """The default crank laws: both cranks at constant speed from their initial angles.

    theta1 = theta1_0 + Omega t, theta4 = theta4_0 + speed_ratio Omega t (assumptions
    ``crank_speed_rpm`` and ``speed_ratio``; the paper starts both cranks at 0 deg).

    Parameters
    ----------
    t
        Times (s).
    crank_speed
        Omega (rad/s); ``None`` takes ``params.crank_speed``.

    Returns
    -------
    tuple
        ``(theta1, omega1, alpha1, theta4, omega4, alpha4)``, each shaped like ``t``.
    """
    t = np.asarray(t, float)
    W = params.crank_speed if crank_speed is None else float(crank_speed)
    if not np.isfinite(W) or W <= 0:
        raise InputError(f"crank_speed = {crank_speed!r} is not allowed: it must be a positive number (rad/s)")
    W4 = params.speed_ratio * W
    z = np.zeros_like(t)
    return (
        params.theta1_0 + W * t,
        z + W,
        z,
        params.theta4_0 + W4 * t,
        z + W4,
        z,
    )


def constant_speed_laws(params: Params, t: ArrayLike, crank_speed: float | None = None) -> RigidState:
    """Rigid state along the default crank laws (:func:`crank_laws`) at times ``t`` (s)."""
    return rigid_state(params, *crank_laws(params, t, crank_speed))
