r"""Rigid-body kinematics of a single-loop planar linkage of revolute joints.

The linkage is the description of the parameter file (:class:`fivebar.description.linkage.Linkage`; the
paper's five-bar of Figure 1 by default): a chain of links from one ground pivot to the other,
closed by the frame.  The drives fix the angles of the cranks; the two other links close the
loop,

.. math::

    \boldsymbol\Phi(\boldsymbol\beta) = \sum_k \sigma_k L_k\,\mathbf e(\beta_k)
    - (\mathbf r_{\mathrm{last}} - \mathbf r_{\mathrm{first}}) = \mathbf 0 ,
    \qquad \mathbf e(\beta) = (\cos\beta, \sin\beta),

summed over the links in chain order, :math:`\sigma_k = \pm 1` as link :math:`k` points along
the chain or against it (its angle :math:`\beta_k` is that of the vector from its start joint
to its end joint).  The two unknown angles are found by Newton's method on
:math:`\boldsymbol\Phi`, started from the configuration of the assembly mode (the pin between
the two unknown links on the side of the line through its neighbours that the description
names; for one loop this start is already the root, so Newton stops at once unless round-off
asks for a step); no configuration of one mode is continuous with one of the other except
through a dead point.  The first and second time derivatives of :math:`\boldsymbol\Phi` give
the unknown links' angular velocities and accelerations from a 2 x 2 linear system with the
constraint Jacobian :math:`[\sigma_i L_i \mathbf n(\beta_i),\ \sigma_j L_j \mathbf n(\beta_j)]`,
singular exactly at a dead point (the two links collinear): there, and where the loop cannot
close, a :class:`GeometryError` names the crank angles.

For the paper's five-bar: ground pivots :math:`A = (0, 0)` and :math:`E = (L_5, 0)`; crank AB
(:math:`L_1`) at angle :math:`\theta_1`, crank ED (:math:`L_4`) at angle :math:`\theta_4`, both
anticlockwise from the x axis; couplers BC (:math:`L_2`) and CD (:math:`L_3`) pinned at C.  It
has no dead point: :math:`50 \le |BD| \le 750` mm against :math:`L_2 + L_3 = 800` mm.

Crank angles are passed in the order of the description's cranks
(``Linkage.cranks``): ``positions(params, theta1, theta4)`` for the
five-bar, ``positions(params, theta)`` for a four-bar.

The rigid motion is the "given trajectory" of the kineto-elastodynamic model: the elastic
equation (2.7) is driven by the rigid accelerations :math:`\ddot{\mathbf u}_r` computed here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FivebarError, InputError, checked
from ..description.linkage import Linkage
from ..description.params import Params

__all__ = [
    "DeadPointError",
    "GeometryError",
    "LINKS",
    "RigidState",
    "positions",
    "link_angles",
    "rigid_state",
    "constant_speed_laws",
    "crank_laws",
]


class GeometryError(FivebarError, ValueError):
    """The loop cannot close for the given crank angles."""


class DeadPointError(GeometryError):
    """The constraint Jacobian is singular (the two closing links are collinear): the rigid
    velocities are not defined at these crank angles."""


def __getattr__(name: str) -> Any:
    # LINKS: link name -> (start joint, end joint) of the default parameter file's linkage
    if name == "LINKS":
        from ..description.params import load_params

        return load_params().linkage.link_ends
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _e(beta: NDArray) -> NDArray:
    return np.stack([np.cos(beta), np.sin(beta)], axis=-1)


def _n(beta: NDArray) -> NDArray:
    return np.stack([-np.sin(beta), np.cos(beta)], axis=-1)


def _angle(d: NDArray) -> NDArray:
    return np.arctan2(d[..., 1], d[..., 0])


def _check_mode(mode: int) -> None:
    if mode not in (1, -1):
        raise InputError(
            f"assembly mode {mode!r} is not allowed: use +1 (the description's assembly mode, for the five-bar "
            "C to the left of B->D) or -1 (the other)"
        )


def _split(lk: Linkage, args: tuple, per: int, mode: int | None, what: str) -> tuple[list[NDArray], int]:
    """Crank arguments (``per`` per crank) and the mode, which may also come last, positionally."""
    n = per * len(lk.cranks)
    if len(args) == n + 1 and mode is None:
        args, mode = args[:-1], args[-1]
    if len(args) != n:
        names = ", ".join(j.name for j in lk.cranks)
        raise InputError(
            f"{len(args)} {what} given: the linkage {lk.name!r} has {len(lk.cranks)} driven crank(s) ({names}), "
            f"which take {n}"
        )
    mode = 1 if mode is None else mode
    _check_mode(mode)
    arrays = [np.asarray(x, float) for x in args]
    try:
        return list(np.broadcast_arrays(*arrays)), mode
    except ValueError:
        raise InputError(f"{what} of shapes {', '.join(str(a.shape) for a in arrays)} are not allowed: they must "
                         "broadcast together (one shape, or scalars)") from None


def _where(lk: Linkage, theta: list[NDArray], i: int) -> str:
    return ", ".join(f"{j.name} = {np.degrees(t.ravel()[i]):.6g} deg" for j, t in zip(lk.cranks, theta))


def _crank_angles(lk: Linkage, theta: list[NDArray]) -> dict[int, NDArray]:
    """Chain index of each driven link -> its angle (rad) for the crank angles ``theta``."""
    out = {}
    for joint, th in zip(lk.cranks, theta):
        k = 0 if joint.name == lk.chain[0] else len(lk.links) - 1
        out[k] = th if lk.links[k].start == joint.name else th + np.pi
    return out


def _close(lk: Linkage, theta: list[NDArray], mode: int) -> tuple[dict[str, NDArray], dict[str, NDArray]]:
    """Joint positions and link angles: walk from both ground pivots to the assembly joint,
    then Newton on the loop equations from the assembly mode's start."""
    shape = theta[0].shape if theta else ()
    chain, links = lk.chain, lk.links
    i, j = lk.unknown
    beta = {k: b for k, b in _crank_angles(lk, theta).items()}
    P: dict[str, NDArray] = {}
    P[chain[0]] = np.zeros(shape + (2,)) + np.asarray(lk.ground[0].at, float)
    for k in range(0, i):
        P[chain[k + 1]] = P[chain[k]] + (lk.chain_sign(k) * links[k].length) * _e(beta[k])
    P[chain[-1]] = np.zeros(shape + (2,)) + np.asarray(lk.ground[1].at, float)
    for k in range(len(links) - 1, j, -1):
        P[chain[k]] = P[chain[k + 1]] + (-lk.chain_sign(k) * links[k].length) * _e(beta[k])
    # start: the assembly joint X from its neighbours p and q (two circles), on the mode's side
    p, q = P[chain[i]], P[chain[j + 1]]
    Li, Lj = links[i].length, links[j].length
    d = q - p
    r = np.hypot(d[..., 0], d[..., 1])
    bad = (r > Li + Lj) | (r < abs(Li - Lj)) | (r == 0)
    if np.any(bad):
        k = np.flatnonzero(bad.ravel())[0]
        pq = f"{chain[i]}{chain[j + 1]}"
        raise GeometryError(
            f"the loop cannot close at crank angles {_where(lk, theta, k)}: |{pq}| = {1e3 * r.ravel()[k]:.6g} mm "
            f"must lie in [{1e3 * abs(Li - Lj):.6g}, {1e3 * (Li + Lj):.6g}] mm "
            f"(|{links[i].name} - {links[j].name}|, {links[i].name} + {links[j].name})"
        )
    a = (Li**2 - Lj**2 + r**2) / (2 * r)
    h = np.sqrt(np.maximum(Li**2 - a**2, 0.0))
    u = d / r[..., None]
    perp = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    side = mode * (1 if lk.assembly_side == "left" else -1)
    X = p + a[..., None] * u + side * h[..., None] * perp
    # Newton on Phi(beta_i, beta_j) = 0 from this start (a step only where round-off leaves a residual)
    si, sj = lk.chain_sign(i) * Li, lk.chain_sign(j) * Lj
    bi = _angle(si * (X - p))
    bj = _angle(sj * (q - X))
    for _ in range(8):
        res = si * _e(bi) + sj * _e(bj) - d
        if np.all(np.abs(res) <= 1e-13 * (Li + Lj)):
            break
        J = np.stack([si * _n(bi), sj * _n(bj)], axis=-1)
        step = np.linalg.solve(J, -res[..., None])[..., 0]
        bi, bj = bi + step[..., 0], bj + step[..., 1]
        X = p + si * _e(bi)
    P[chain[j]] = X
    return P, {"unknown": (bi, bj)}


@checked
def positions(params: Params, *theta: ArrayLike, mode: int | None = None) -> dict[str, NDArray]:
    """Joint coordinates for given crank angles.

    ``P = positions(params, theta1, theta4)`` (the five-bar), ``positions(params, theta)`` (a
    four-bar).

    Parameters
    ----------
    params
        The parameter set; its ``linkage`` is the description.
    *theta
        Crank angles (rad), one per driven crank in the order of the chain, anticlockwise
        from the x axis; broadcast together.
    mode
        Assembly mode: +1 the description's (for the five-bar, C to the left of the directed
        line B to D, above AE at theta1 = theta4 = 0), -1 the other.  May also be given as a
        last positional argument.

    Returns
    -------
    dict
        Joint name -> array of shape ``(..., 2)`` in m.

    Raises
    ------
    GeometryError
        If the loop cannot close; the message names the crank angles and the distance that
        the two closing links cannot span.
    """
    lk = params.linkage
    th, mode = _split(lk, theta, 1, mode, "crank angle(s)")
    return _close(lk, th, mode)[0]


@checked
def link_angles(params: Params, *theta: ArrayLike, mode: int | None = None) -> dict[str, NDArray]:
    """Angles (rad) of the links to the x axis (each from its start to its end joint), for
    crank angles as in :func:`positions`."""
    P = positions(params, *theta, mode=mode)
    return {k.name: _angle(P[k.end] - P[k.start]) for k in params.linkage.links}


@dataclass(frozen=True)
class RigidState:
    """Rigid-body state of the linkage at one or many instants.

    ``pos``, ``vel``, ``acc`` map joints to arrays ``(..., 2)`` (m, m/s, m/s^2); ``angle``,
    ``omega``, ``alpha`` map links to arrays ``(...)`` (rad, rad/s, rad/s^2), with the links'
    directions ``ends`` (link -> (start joint, end joint)).
    """

    pos: dict[str, NDArray]
    vel: dict[str, NDArray]
    acc: dict[str, NDArray]
    angle: dict[str, NDArray]
    omega: dict[str, NDArray]
    alpha: dict[str, NDArray]
    ends: Mapping[str, tuple[str, str]]

    def point(self, link: str, s: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
        """Position, velocity and acceleration of the point at fraction ``s`` along a link.

        ``s = 0`` is the link's start joint and ``s = 1`` its end joint.
        Returns three arrays of shape ``(..., 2)`` (m, m/s, m/s^2).
        """
        start, end = self.ends[link]
        L = np.linalg.norm(self.pos[end] - self.pos[start], axis=-1)
        s = np.asarray(s, float)
        b, w, al = self.angle[link], self.omega[link], self.alpha[link]
        ell = (s * L)[..., None]
        p = self.pos[start] + ell * _e(b)
        v = self.vel[start] + ell * w[..., None] * _n(b)
        a = self.acc[start] + ell * (al[..., None] * _n(b) - (w**2)[..., None] * _e(b))
        return p, v, a


def rigid_state(params: Params, *laws: ArrayLike, mode: int | None = None) -> RigidState:
    """Positions, velocities and accelerations for crank laws given with their derivatives.

    ``state = rigid_state(params, *crank_laws(params, t))``; for the five-bar
    ``rigid_state(params, theta1, omega1, alpha1, theta4, omega4, alpha4)``.

    Parameters
    ----------
    *laws
        Per driven crank (chain order) its angle (rad), angular velocity (rad/s) and angular
        acceleration (rad/s^2); broadcast together.
    mode
        Assembly mode, see :func:`positions` (also accepted as a last positional argument).

    Raises
    ------
    GeometryError
        Where the loop cannot close; :class:`DeadPointError` where the constraint Jacobian is
        singular (the closing links collinear), naming the crank angles.
    """
    lk = params.linkage
    arrs, mode = _split(lk, laws, 3, mode, "crank law arrays")
    theta, omega, alpha = arrs[0::3], arrs[1::3], arrs[2::3]
    P, un = _close(lk, theta, mode)
    chain, links = lk.chain, lk.links
    i, j = lk.unknown
    n = len(links)
    shape = theta[0].shape
    beta = _crank_angles(lk, theta)
    w = {k: omega[c] for c, k in enumerate(sorted(beta))}
    al = {k: alpha[c] for c, k in enumerate(sorted(beta))}
    b_i, b_j = (_angle(P[links[k].end] - P[links[k].start]) for k in (i, j))
    beta[i], beta[j] = b_i, b_j
    zero = np.zeros(shape + (2,))
    V = {chain[0]: zero, chain[-1]: zero}
    Acc = {chain[0]: zero, chain[-1]: zero}
    for k in range(0, i):
        sL = lk.chain_sign(k) * links[k].length
        V[chain[k + 1]] = V[chain[k]] + sL * w[k][..., None] * _n(beta[k])
        Acc[chain[k + 1]] = Acc[chain[k]] + sL * (al[k][..., None] * _n(beta[k]) - (w[k] ** 2)[..., None] * _e(beta[k]))
    for k in range(n - 1, j, -1):
        sL = -lk.chain_sign(k) * links[k].length
        V[chain[k]] = V[chain[k + 1]] + sL * w[k][..., None] * _n(beta[k])
        Acc[chain[k]] = Acc[chain[k + 1]] + sL * (al[k][..., None] * _n(beta[k]) - (w[k] ** 2)[..., None] * _e(beta[k]))
    si, sj = lk.chain_sign(i) * links[i].length, lk.chain_sign(j) * links[j].length
    p, q = chain[i], chain[j + 1]
    # the differentiated loop equations: [s_i n_i, s_j n_j] [w_i, w_j]^T = v_q - v_p
    Amat = np.stack([si * _n(b_i), sj * _n(b_j)], axis=-1)  # (..., 2, 2)
    det = np.abs(np.linalg.det(Amat)) / (links[i].length * links[j].length)
    if np.any(det < 1e-9):
        k = np.flatnonzero((det < 1e-9).ravel())[0]
        raise DeadPointError(
            f"dead point at crank angles {_where(lk, theta, k)}: the links {links[i].name} and {links[j].name} are collinear, "
            "so the constraint Jacobian is singular and the rigid velocities are not defined"
        )
    wij = np.linalg.solve(Amat, (V[q] - V[p])[..., None])[..., 0]
    w[i], w[j] = wij[..., 0], wij[..., 1]
    rhs = Acc[q] - Acc[p] + si * (w[i] ** 2)[..., None] * _e(b_i) + sj * (w[j] ** 2)[..., None] * _e(b_j)
    aij = np.linalg.solve(Amat, rhs[..., None])[..., 0]
    al[i], al[j] = aij[..., 0], aij[..., 1]
    X = chain[j]
    V[X] = V[p] + si * w[i][..., None] * _n(b_i)
    Acc[X] = Acc[p] + si * (al[i][..., None] * _n(b_i) - (w[i] ** 2)[..., None] * _e(b_i))
    names = [k.name for k in links]
    return RigidState(
        pos={c: P[c] for c in chain},
        vel={c: V[c] for c in chain},
        acc={c: Acc[c] for c in chain},
        angle={names[k]: beta[k] for k in range(n)},
        omega={names[k]: w[k] for k in range(n)},
        alpha={names[k]: al[k] for k in range(n)},
        ends=lk.link_ends,
    )


def crank_laws(params: Params, t: ArrayLike, crank_speed_rad_s: float | None = None) -> tuple[NDArray, ...]:
    """The drive laws of the description's cranks at times ``t`` (s).

    For the paper's five-bar both cranks turn at constant speed from their initial angles:
    theta1 = theta1_0 + Omega t, theta4 = theta4_0 + speed_ratio Omega t (assumptions
    ``crank_speed_rpm`` and ``speed_ratio``; the paper starts both cranks at 0 deg).  In
    general each crank follows its :class:`fivebar.description.linkage.Drive`.

    Parameters
    ----------
    t
        Times (s).
    crank_speed_rad_s
        Omega (rad/s); ``None`` takes ``params.crank_speed_rad_s``.

    Returns
    -------
    tuple
        ``(theta, omega, alpha)`` of each crank in chain order, each shaped like ``t``: for the
        five-bar ``(theta1, omega1, alpha1, theta4, omega4, alpha4)``.
    """
    t = np.asarray(t, float)
    W = params.crank_speed_rad_s if crank_speed_rad_s is None else float(crank_speed_rad_s)
    if not np.isfinite(W) or W <= 0:
        raise InputError(f"crank_speed_rad_s = {crank_speed_rad_s!r} is not allowed: it must be a positive number (rad/s)")
    out: list[NDArray] = []
    for joint in params.linkage.cranks:
        out.extend(joint.drive.laws(t, W))  # type: ignore[union-attr]
    return tuple(out)


def constant_speed_laws(params: Params, t: ArrayLike, crank_speed_rad_s: float | None = None) -> RigidState:
    """Rigid state along the default crank laws (:func:`crank_laws`) at times ``t`` (s)."""
    return rigid_state(params, *crank_laws(params, t, crank_speed_rad_s))
