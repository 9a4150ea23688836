r"""Rigid-body kinematics of a planar linkage of revolute and prismatic joints.

The linkage is the description of the parameter file (:class:`fivebar.description.linkage.Linkage`;
the paper's five-bar of Figure 1 by default).  Its drives fix the inputs (a crank's angle, a
slider's position on its guide); the rest of the linkage follows by the description's plan
(:attr:`~fivebar.description.linkage.Linkage.plan`), one step after another: a link of known
angle carries a joint from its other end ("walk"), welded links turn together, and each loop is
closed by one dyad, whose loop equations are solved by Newton's method from the closed-form
start of the branch the description names:

* two links :math:`i, j` of unknown angles meeting at a joint :math:`X` from the known joints
  :math:`p, q` (RRR):

  .. math::

      \boldsymbol\Phi(\beta_i, \beta_j) = \sigma_i L_i\,\mathbf e(\beta_i)
      + \sigma_j L_j\,\mathbf e(\beta_j) - (\mathbf r_q - \mathbf r_p) = \mathbf 0 ,
      \qquad \mathbf e(\beta) = (\cos\beta, \sin\beta),

  :math:`\sigma = \pm 1` as the link points from :math:`p` to :math:`X` (from :math:`X` to
  :math:`q`) or against, started from the intersection of the two circles on the named side
  of the line :math:`p \to q`;
* a link of unknown angle from a known joint :math:`p` to a slider :math:`X` on a known guide
  :math:`\mathbf o + s\,\mathbf g` (RRP): :math:`\boldsymbol\Phi(\beta, s) = \mathbf r_p +
  \sigma L\,\mathbf e(\beta) - \mathbf o - s\,\mathbf g = \mathbf 0`, started from the
  intersection of the circle and the line ahead of or behind the foot of the perpendicular;
* a guide link of unknown angle through its known joint :math:`c` and a known slider
  :math:`X` on it (RPR): :math:`\mathbf r_X - \mathbf r_c = s\,\mathbf e(\beta)`, in closed form.

For one loop this start is already the root, so Newton stops at once unless round-off asks for
a step; no configuration of one branch is continuous with one of the other except through a
dead point.  The first and second time derivatives of each dyad's loop equations give its
velocities and accelerations from a 2 x 2 linear system with the dyad's constraint Jacobian
(for RRR :math:`[\sigma_i L_i \mathbf n(\beta_i),\ \sigma_j L_j \mathbf n(\beta_j)]`), singular
exactly at a dead point (for RRR the two links collinear, for RRP the link normal to the guide,
for RPR the slider on the guide link's joint): there, and where a loop cannot close, a
:class:`GeometryError` names the inputs and the dyad.

For the paper's five-bar: ground pivots :math:`A = (0, 0)` and :math:`E = (L_5, 0)`; crank AB
(:math:`L_1`) at angle :math:`\theta_1`, crank ED (:math:`L_4`) at angle :math:`\theta_4`, both
anticlockwise from the x axis; couplers BC (:math:`L_2`) and CD (:math:`L_3`) pinned at C, one
RRR dyad.  It has no dead point: :math:`50 \le |BD| \le 750` mm against :math:`L_2 + L_3 = 800`
mm.

The inputs are passed in the order of the description's driven inputs (``Linkage.inputs``),
an angle (rad) for a crank and a position along the guide (m) for a driven slider:
``positions(params, theta1, theta4)`` for the five-bar, ``positions(params, theta)`` for a
four-bar or a slider-crank.

The rigid motion is the "given trajectory" of the kineto-elastodynamic model: the elastic
equation (2.7) is driven by the rigid accelerations :math:`\ddot{\mathbf u}_r` computed here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
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
    """A loop cannot close for the given inputs."""


class DeadPointError(GeometryError):
    """The constraint Jacobian of a dyad is singular (for two links meeting at a joint: they are
    collinear): the rigid velocities are not defined at these inputs."""


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


def _cross(a: NDArray, b: NDArray) -> NDArray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _check_mode(mode: int) -> None:
    if mode not in (1, -1):
        raise InputError(
            f"assembly mode {mode!r} is not allowed: use +1 (the description's assembly mode, for the five-bar "
            "C to the left of B->D) or -1 (the other)"
        )


def _inputs_text(lk: Linkage) -> tuple[str, str]:
    """("crank(s)", "crank angles") when every input is a crank, else ("input(s)", "inputs")."""
    if all(j.kind == "crank" for j in lk.inputs):
        return "crank(s)", "crank angles"
    return "input(s)", "inputs"


def _split(lk: Linkage, args: tuple, per: int, mode: int | None, what: str) -> tuple[list[NDArray], int]:
    """Input arguments (``per`` per driven input) and the mode, which may also come last, positionally."""
    n = per * len(lk.inputs)
    if len(args) == n + 1 and mode is None:
        args, mode = args[:-1], args[-1]
    if len(args) != n:
        names = ", ".join(j.name for j in lk.inputs)
        raise InputError(
            f"{len(args)} {what} given: the linkage {lk.name!r} has {len(lk.inputs)} driven {_inputs_text(lk)[0]} "
            f"({names}), which take {n}"
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
    """The inputs at flat index ``i``: "crank angles A = 10 deg, ..." (a slider in mm)."""
    parts = [f"{j.name} = {np.degrees(t.ravel()[i]):.6g} deg" if j.kind == "crank" else
             f"{j.name} = {1e3 * t.ravel()[i]:.6g} mm" for j, t in zip(lk.inputs, theta)]
    return f"{_inputs_text(lk)[1]} " + ", ".join(parts)


def _guide(lk: Linkage, joint: str, P, V, A, beta, w, al, shape, order: int):
    """Origin, direction (unit) and its angle of the guide of slider ``joint``, with the origin's
    velocity and acceleration and the direction's rates (zero for a ground guide)."""
    g = lk.joint(joint).guide
    if g.link is None:  # type: ignore[union-attr]
        o = np.zeros(shape + (2,)) + np.asarray(g.at, float)  # type: ignore[union-attr]
        phi = np.zeros(shape) + g.angle  # type: ignore[union-attr]
        zero2, zero = np.zeros(shape + (2,)), np.zeros(shape)
        return o, phi, zero2, zero2, zero, zero
    lever = lk.link(g.link)  # type: ignore[union-attr]
    if not order:
        return P[lever.start], beta[lever.name], None, None, None, None
    return P[lever.start], beta[lever.name], V[lever.start], A[lever.start], w[lever.name], al[lever.name]


def _solve(lk: Linkage, theta: list[NDArray], omega: list[NDArray] | None, alpha: list[NDArray] | None,
           mode: int, order: int) -> tuple:
    """Joint positions (and velocities, accelerations for ``order`` 2), link angles (and rates)
    and the sliders' coordinates along their guides, by the description's plan."""
    shape = theta[0].shape if theta else ()
    P: dict[str, NDArray] = {}
    V: dict[str, NDArray] = {}
    A: dict[str, NDArray] = {}
    beta: dict[str, NDArray] = {}
    w: dict[str, NDArray] = {}
    al: dict[str, NDArray] = {}
    slide: dict[str, tuple[NDArray, ...]] = {}
    zero = np.zeros(shape + (2,))
    for j in lk.ground:
        P[j.name] = np.zeros(shape + (2,)) + np.asarray(j.at, float)
        V[j.name] = A[j.name] = zero
    index = {j.name: i for i, j in enumerate(lk.inputs)}
    links = {k.name: k for k in lk.links}
    for st in lk.plan:
        if st.kind == "drive":
            k, i = links[st.links[0]], index[st.joint]  # type: ignore[index]
            th = theta[i]
            beta[k.name] = th if k.start == st.joint else th + np.pi
            if order:
                w[k.name], al[k.name] = omega[i], alpha[i]  # type: ignore[index]
        elif st.kind == "slide":
            j, i = lk.joint(st.joint), index[st.joint]  # type: ignore[arg-type]
            g = j.guide.direction  # type: ignore[union-attr]
            s = theta[i]
            P[j.name] = np.asarray(j.guide.at, float) + s[..., None] * g  # type: ignore[union-attr]
            slide[j.name] = (s,)
            if order:
                V[j.name] = omega[i][..., None] * g  # type: ignore[index]
                A[j.name] = alpha[i][..., None] * g  # type: ignore[index]
                slide[j.name] = (s, omega[i], alpha[i])  # type: ignore[index]
        elif st.kind == "weld":
            target, source = links[st.links[0]], links[st.links[1]]
            rel = target.weld[1] if target.weld and target.weld[0] == source.name else -source.weld[1]  # type: ignore[index]
            beta[target.name] = beta[source.name] + rel
            if order:
                w[target.name], al[target.name] = w[source.name], al[source.name]
        elif st.kind == "walk":
            k, a, b = links[st.links[0]], st.known[0], st.joint
            sL = (1.0 if k.start == a else -1.0) * k.length
            P[b] = P[a] + sL * _e(beta[k.name])  # type: ignore[index]
            if order:
                V[b] = V[a] + sL * w[k.name][..., None] * _n(beta[k.name])  # type: ignore[index]
                A[b] = A[a] + sL * (al[k.name][..., None] * _n(beta[k.name])  # type: ignore[index]
                                    - (w[k.name] ** 2)[..., None] * _e(beta[k.name]))
        elif st.kind == "rrr":
            _rrr(lk, st, links, P, V, A, beta, w, al, theta, mode, order)
        elif st.kind == "rrp":
            _rrp(lk, st, links, P, V, A, beta, w, al, slide, theta, mode, order, shape)
        else:
            _rpr(lk, st, links, P, V, A, beta, w, al, slide, theta, mode, order)
    return P, V, A, beta, w, al, slide


def _rrr(lk, st, links, P, V, A, beta, w, al, theta, mode, order) -> None:
    ki, kj = links[st.links[0]], links[st.links[1]]
    X, (pn, qn) = st.joint, st.known
    p, q = P[pn], P[qn]
    Li, Lj = ki.length, kj.length
    d = q - p
    r = np.hypot(d[..., 0], d[..., 1])
    bad = (r > Li + Lj) | (r < abs(Li - Lj)) | (r == 0)
    if np.any(bad):
        k = np.flatnonzero(bad.ravel())[0]
        raise GeometryError(
            f"the loop cannot close at {_where(lk, theta, k)}: |{pn}{qn}| = {1e3 * r.ravel()[k]:.6g} mm "
            f"must lie in [{1e3 * abs(Li - Lj):.6g}, {1e3 * (Li + Lj):.6g}] mm "
            f"(|{ki.name} - {kj.name}|, {ki.name} + {kj.name})"
        )
    a = (Li**2 - Lj**2 + r**2) / (2 * r)
    h = np.sqrt(np.maximum(Li**2 - a**2, 0.0))
    u = d / r[..., None]
    perp = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    side = mode * st.sign
    Xp = p + a[..., None] * u + side * h[..., None] * perp
    # Newton on Phi(beta_i, beta_j) = 0 from this start (a step only where round-off leaves a residual)
    si, sj = (1.0 if ki.start == pn else -1.0) * Li, (1.0 if kj.start == X else -1.0) * Lj
    bi = _angle(si * (Xp - p))
    bj = _angle(sj * (q - Xp))
    for _ in range(8):
        res = si * _e(bi) + sj * _e(bj) - d
        if np.all(np.abs(res) <= 1e-13 * (Li + Lj)):
            break
        J = np.stack([si * _n(bi), sj * _n(bj)], axis=-1)
        step = np.linalg.solve(J, -res[..., None])[..., 0]
        bi, bj = bi + step[..., 0], bj + step[..., 1]
        Xp = p + si * _e(bi)
    P[X] = Xp
    b_i, b_j = (_angle(P[k.end] - P[k.start]) for k in (ki, kj))
    beta[ki.name], beta[kj.name] = b_i, b_j
    if not order:
        return
    # the differentiated loop equations: [s_i n_i, s_j n_j] [w_i, w_j]^T = v_q - v_p
    Amat = np.stack([si * _n(b_i), sj * _n(b_j)], axis=-1)  # (..., 2, 2)
    det = np.abs(np.linalg.det(Amat)) / (Li * Lj)
    if np.any(det < 1e-9):
        k = np.flatnonzero((det < 1e-9).ravel())[0]
        raise DeadPointError(
            f"dead point at {_where(lk, theta, k)}: the links {ki.name} and {kj.name} are collinear, "
            "so the constraint Jacobian is singular and the rigid velocities are not defined"
        )
    wij = np.linalg.solve(Amat, (V[qn] - V[pn])[..., None])[..., 0]
    w[ki.name], w[kj.name] = wij[..., 0], wij[..., 1]
    rhs = A[qn] - A[pn] + si * (w[ki.name] ** 2)[..., None] * _e(b_i) + sj * (w[kj.name] ** 2)[..., None] * _e(b_j)
    aij = np.linalg.solve(Amat, rhs[..., None])[..., 0]
    al[ki.name], al[kj.name] = aij[..., 0], aij[..., 1]
    V[X] = V[pn] + si * w[ki.name][..., None] * _n(b_i)
    A[X] = A[pn] + si * (al[ki.name][..., None] * _n(b_i) - (w[ki.name] ** 2)[..., None] * _e(b_i))


def _rrp(lk, st, links, P, V, A, beta, w, al, slide, theta, mode, order, shape) -> None:
    k, X, pn = links[st.links[0]], st.joint, st.known[0]
    p = P[pn]
    L = k.length
    o, phi, Vo, Ao, wg, ag = _guide(lk, X, P, V, A, beta, w, al, shape, order)
    g = _e(phi)
    d = p - o
    along = np.sum(d * g, axis=-1)
    off = _cross(g, d)  # signed distance of p from the guide
    h2 = L**2 - off**2
    if np.any(h2 < 0):
        i = np.flatnonzero((h2 < 0).ravel())[0]
        raise GeometryError(
            f"the loop cannot close at {_where(lk, theta, i)}: joint {pn} lies {1e3 * abs(off.ravel()[i]):.6g} mm from "
            f"the guide of the slider {X}, farther than the length of {k.name}, {1e3 * L:.6g} mm")
    s = along + (mode * st.sign) * np.sqrt(np.maximum(h2, 0.0))
    sL = (1.0 if k.start == pn else -1.0) * L
    b = _angle(sL * (o + s[..., None] * g - p))
    for _ in range(8):  # Newton on p + sL e(b) - o - s g = 0
        res = p + sL * _e(b) - o - s[..., None] * g
        if np.all(np.abs(res) <= 1e-13 * L):
            break
        J = np.stack([sL * _n(b), -g], axis=-1)
        step = np.linalg.solve(J, -res[..., None])[..., 0]
        b, s = b + step[..., 0], s + step[..., 1]
    P[X] = p + sL * _e(b)
    beta[k.name] = bk = _angle(P[k.end] - P[k.start])
    slide[X] = (s,)
    if not order:
        return
    ng = _n(phi)
    Amat = np.stack([sL * _n(bk), -g], axis=-1)
    det = np.abs(np.linalg.det(Amat)) / L
    if np.any(det < 1e-9):
        i = np.flatnonzero((det < 1e-9).ravel())[0]
        raise DeadPointError(
            f"dead point at {_where(lk, theta, i)}: the link {k.name} is normal to the guide of the slider {X}, "
            "so the constraint Jacobian is singular and the rigid velocities are not defined")
    rhs = Vo + (s * wg)[..., None] * ng - V[pn]
    x = np.linalg.solve(Amat, rhs[..., None])[..., 0]
    w[k.name], sd = x[..., 0], x[..., 1]
    rhs = (Ao + (2.0 * sd * wg)[..., None] * ng + s[..., None] * (ag[..., None] * ng - (wg**2)[..., None] * g)
           - A[pn] + sL * (w[k.name] ** 2)[..., None] * _e(bk))
    x = np.linalg.solve(Amat, rhs[..., None])[..., 0]
    al[k.name], sdd = x[..., 0], x[..., 1]
    V[X] = V[pn] + sL * w[k.name][..., None] * _n(bk)
    A[X] = A[pn] + sL * (al[k.name][..., None] * _n(bk) - (w[k.name] ** 2)[..., None] * _e(bk))
    slide[X] = (s, sd, sdd)


def _rpr(lk, st, links, P, V, A, beta, w, al, slide, theta, mode, order) -> None:
    G, X, c = links[st.links[0]], st.joint, st.known[0]
    d = P[X] - P[c]
    r = np.hypot(d[..., 0], d[..., 1])
    if np.any(r <= 1e-12 * G.length):
        i = np.flatnonzero((r <= 1e-12 * G.length).ravel())[0]
        raise GeometryError(f"the loop cannot close at {_where(lk, theta, i)}: the slider {X} sits on the joint {c} "
                            f"of its guide {G.name}, whose angle it then leaves undefined")
    side = mode * st.sign
    bg = _angle(side * d)
    s = side * r
    beta[G.name] = bg
    s0 = s if c == G.start else s + G.length  # measured from the guide link's start
    slide[X] = (s0,)
    if not order:
        return
    e, n = _e(bg), _n(bg)
    # [e, s n] [s', w]^T = v_X - v_c ;  [e, s n] [s'', alpha]^T = a_X - a_c - 2 s' w n + s w^2 e
    Amat = np.stack([e, s[..., None] * n], axis=-1)
    x = np.linalg.solve(Amat, (V[X] - V[c])[..., None])[..., 0]
    sd, w[G.name] = x[..., 0], x[..., 1]
    rhs = A[X] - A[c] - (2.0 * sd * w[G.name])[..., None] * n + (s * w[G.name] ** 2)[..., None] * e
    x = np.linalg.solve(Amat, rhs[..., None])[..., 0]
    sdd, al[G.name] = x[..., 0], x[..., 1]
    slide[X] = (s0, sd, sdd)


@checked
def positions(params: Params, *theta: ArrayLike, mode: int | None = None) -> dict[str, NDArray]:
    """Joint coordinates for given inputs.

    ``P = positions(params, theta1, theta4)`` (the five-bar), ``positions(params, theta)`` (a
    four-bar, a slider-crank).

    Parameters
    ----------
    params
        The parameter set; its ``linkage`` is the description.
    *theta
        The inputs, one per driven input in the order of the description (``Linkage.inputs``):
        a crank's angle (rad, anticlockwise from the x axis) or a driven slider's position on
        its guide (m); broadcast together.
    mode
        Assembly mode: +1 the description's branches (for the five-bar, C to the left of the
        directed line B to D, above AE at theta1 = theta4 = 0), -1 the other branch of every
        dyad.  May also be given as a last positional argument.

    Returns
    -------
    dict
        Joint name -> array of shape ``(..., 2)`` in m.

    Raises
    ------
    GeometryError
        If a loop cannot close; the message names the inputs and the distance that the dyad's
        links cannot span.
    """
    lk = params.linkage
    th, mode = _split(lk, theta, 1, mode, "crank angle(s)" if _inputs_text(lk)[0] == "crank(s)" else "input(s)")
    return _solve(lk, th, None, None, mode, 0)[0]


@checked
def link_angles(params: Params, *theta: ArrayLike, mode: int | None = None) -> dict[str, NDArray]:
    """Angles (rad) of the links to the x axis (each from its start to its end joint), for
    inputs as in :func:`positions`."""
    P = positions(params, *theta, mode=mode)
    return {k.name: _angle(P[k.end] - P[k.start]) for k in params.linkage.links}


@dataclass(frozen=True)
class RigidState:
    """Rigid-body state of the linkage at one or many instants.

    ``pos``, ``vel``, ``acc`` map joints to arrays ``(..., 2)`` (m, m/s, m/s^2); ``angle``,
    ``omega``, ``alpha`` map links to arrays ``(...)`` (rad, rad/s, rad/s^2), with the links'
    directions ``ends`` (link -> (start joint, end joint)); ``slide``, ``slide_rate``,
    ``slide_acc`` map each slider to its position along its guide (m, from the guide's point
    ``at`` or from its guide link's start) and its rates (m/s, m/s^2).
    """

    pos: dict[str, NDArray]
    vel: dict[str, NDArray]
    acc: dict[str, NDArray]
    angle: dict[str, NDArray]
    omega: dict[str, NDArray]
    alpha: dict[str, NDArray]
    ends: Mapping[str, tuple[str, str]]
    slide: dict[str, NDArray] = field(default_factory=dict)
    slide_rate: dict[str, NDArray] = field(default_factory=dict)
    slide_acc: dict[str, NDArray] = field(default_factory=dict)

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
    """Positions, velocities and accelerations for input laws given with their derivatives.

    ``state = rigid_state(params, *crank_laws(params, t))``; for the five-bar
    ``rigid_state(params, theta1, omega1, alpha1, theta4, omega4, alpha4)``.

    Parameters
    ----------
    *laws
        Per driven input (the description's order) its value, rate and acceleration: a crank's
        angle (rad), angular velocity (rad/s) and angular acceleration (rad/s^2), a driven
        slider's position (m), velocity (m/s) and acceleration (m/s^2); broadcast together.
    mode
        Assembly mode, see :func:`positions` (also accepted as a last positional argument).

    Raises
    ------
    GeometryError
        Where a loop cannot close; :class:`DeadPointError` where a dyad's constraint Jacobian is
        singular (two closing links collinear, a link normal to its slider's guide), naming the
        inputs.
    """
    lk = params.linkage
    arrs, mode = _split(lk, laws, 3, mode, "crank law arrays" if _inputs_text(lk)[0] == "crank(s)" else "input law arrays")
    theta, omega, alpha = arrs[0::3], arrs[1::3], arrs[2::3]
    P, V, A, beta, w, al, slide = _solve(lk, theta, omega, alpha, mode, 2)
    names = [j.name for j in lk.joints]
    return RigidState(
        pos={c: P[c] for c in names},
        vel={c: V[c] for c in names},
        acc={c: A[c] for c in names},
        angle={k.name: beta[k.name] for k in lk.links},
        omega={k.name: w[k.name] for k in lk.links},
        alpha={k.name: al[k.name] for k in lk.links},
        ends=lk.link_ends,
        slide={j: v[0] for j, v in slide.items()},
        slide_rate={j: v[1] for j, v in slide.items()},
        slide_acc={j: v[2] for j, v in slide.items()},
    )


def crank_laws(params: Params, t: ArrayLike, crank_speed_rad_s: float | None = None) -> tuple[NDArray, ...]:
    """The drive laws of the description's driven inputs at times ``t`` (s).

    For the paper's five-bar both cranks turn at constant speed from their initial angles:
    theta1 = theta1_0 + Omega t, theta4 = theta4_0 + speed_ratio Omega t (assumptions
    ``crank_speed_rpm`` and ``speed_ratio``; the paper starts both cranks at 0 deg).  In
    general each input follows its :class:`fivebar.description.linkage.Drive` (a driven
    slider's position in m, periodic with the crank speed's period).

    Parameters
    ----------
    t
        Times (s).
    crank_speed_rad_s
        Omega (rad/s); ``None`` takes ``params.crank_speed_rad_s``.

    Returns
    -------
    tuple
        ``(theta, omega, alpha)`` of each driven input in the description's order, each shaped
        like ``t``: for the five-bar ``(theta1, omega1, alpha1, theta4, omega4, alpha4)``.
    """
    t = np.asarray(t, float)
    W = params.crank_speed_rad_s if crank_speed_rad_s is None else float(crank_speed_rad_s)
    if not np.isfinite(W) or W <= 0:
        raise InputError(f"crank_speed_rad_s = {crank_speed_rad_s!r} is not allowed: it must be a positive number (rad/s)")
    out: list[NDArray] = []
    for joint in params.linkage.inputs:
        out.extend(joint.drive.laws(t, W))  # type: ignore[union-attr]
    return tuple(out)


def constant_speed_laws(params: Params, t: ArrayLike, crank_speed_rad_s: float | None = None) -> RigidState:
    """Rigid state along the default crank laws (:func:`crank_laws`) at times ``t`` (s)."""
    return rigid_state(params, *crank_laws(params, t, crank_speed_rad_s))
