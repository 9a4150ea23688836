r"""Assembly of the global matrices of (2.7) from a topology description.

The paper assembles

.. math::

    \mathbf M = \sum_i \mathbf B_i^\top \mathbf R_i^\top \overline{\mathbf M}_i
    \mathbf R_i \mathbf B_i ,\qquad
    \mathbf K = \mathbf K^e_{11} + \mathbf K^e_{21} + \sum_{i=3}^{8}
    \mathbf B_i^\top \mathbf R_i^\top \overline{\mathbf K}_3 \mathbf R_i \mathbf B_i

(section 2, after (2.8)) with hand-typed Boolean matrices :math:`\mathbf B_i` (A.12) and
rotations :math:`\mathbf R_i` (A.11).  Here the B matrices are *derived* from the linkage
description (:class:`fivebar.description.linkage.Linkage`): its chain of links, for the paper's five-bar
A-B-C-D-E of links L1 (A to B), L2 (B to C), L3 (C to D), L4 (D to E), each cut into a chosen
number of elements (the description's mesh, the paper's 1-2-2-1, by default), with these joints:

* the pins share the global x, y translation; each link end keeps its own slope; the
  curvature is zero at a pin end (no moment);
* a driven crank's root does not translate; its curvature is free; its slope is the torsion of
  the motor shaft at its coupling end (for the five-bar U4 at A, U8 at E: the crank is clamped
  to the shaft, erratum E6).  With ``motors=False``, or for a crank without a motor, the root
  is clamped (slope zero) and the motor elements are left out.  ``tie_crank_roots=False`` is
  the literal reading of (A.12), which leaves the crank-root slopes free and K singular;
* a ground pin does not translate; its slope is free and its curvature zero (no moment);
* interior nodes of a link carry x, y, slope and curvature;
* a slider on a ground guide (a prismatic joint) keeps only the translation along its guide:
  the translation normal to the guide is eliminated, the DOF left is the component along it
  (its node's translations are written in the guide's frame), with the slider block's mass
  on it; its links keep their own slopes, with zero curvature (the block is pinned to them).
  A driven slider does not translate (its motion is prescribed), nor does a pin at the far
  end of a rigid driven crank (``rigid = true``: the crank carries no element);
* links welded into one body share the slope at their common joint (the body's rotation) and
  keep their own curvatures there (the weld carries a moment).

Supports and joints are imposed by identifying or eliminating DOFs, never by penalty springs.
Walking the links in the description's order (the chain's, for the chain form), each from
its first to its last finite-element joint, numbers the DOFs; for the paper's five-bar exactly
as the paper does (U1-U8 motors, then u9 ... u32), which :meth:`Model.paper_numbering` shows.
A slider on a moving link is not a joint of this model (the contact point would run along the
guide link's elements): :func:`build_model` refuses it.

Element DOFs are [u1, w1, w1', w1'', u2, w2, w2', w2''] in the element frame (u along the
element from its first to its second node, w to the left); the global translations are
:math:`(X, Y)` with :math:`u = X\cos\beta + Y\sin\beta`, :math:`w = -X\sin\beta + Y\cos\beta`,
or, at a slider node, the translations :math:`(S, N)` along and normal to its guide (angle
:math:`\varphi`) with :math:`\beta - \varphi` in place of :math:`\beta` and :math:`N = 0`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import tomllib

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from .elements import beam_element, motor_element, shape_functions
from .kinematics import RigidState, link_angles
from ..description.linkage import Link, Linkage
from ..description.params import DEFAULT_PARAMS_PATH, Params

__all__ = [
    "Dof",
    "ElementInfo",
    "Model",
    "build_model",
    "paper_b_matrices",
    "PAPER_ELEMENTS_PER_LINK",
]

def __getattr__(name: str):
    # the paper's mesh (Figure 5) and chain, from the default parameter file's description
    if name in ("PAPER_ELEMENTS_PER_LINK", "CHAIN"):
        from ..description.params import load_params

        lk = load_params().linkage
        if name == "PAPER_ELEMENTS_PER_LINK":
            return lk.default_mesh
        return tuple((k.name, lk.chain[i], lk.chain[i + 1]) for i, k in enumerate(lk.links))
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_AXIAL = np.array([1.0, 0, 0, 0, 1.0, 0, 0, 0])


@dataclass(frozen=True)
class Dof:
    """One generalised coordinate: ``kind`` is x, y, s (the translation of a slider along its
    guide), slope, curvature (beam) or the motor's U1..U4 kinds rotor_x, rotor_y,
    torsion_bearing, torsion_coupling; ``where`` names the node ("B", "L2[1]" for interior node
    1 of L2, "motor1"); ``link`` the link whose slope or curvature it is (None for shared
    translations and motor DOFs)."""

    label: str
    kind: str
    where: str
    link: str | None = None


@dataclass(frozen=True)
class ElementInfo:
    """One beam element: its link, index along the link, end fractions and DOF indices.

    ``dofs`` holds, for the 8 local DOFs, the index of the global DOF (or -1 where the local
    DOF is held at zero: translation at a crank root, curvature at a pin, the normal
    translation at a slider).  ``s0, s1`` are the fractions along the link in the direction of
    its elements (:meth:`fivebar.description.linkage.Linkage.fe_ends`: along the chain for the
    chain form).  ``frames`` the angles of its nodes' translation frames.
    """

    link: str
    index: int
    s0: float
    s1: float
    length: float
    dofs: tuple[int, ...]
    #: angle (rad) of the frame of each node's translations: 0 (global x, y), or a slider's guide
    frames: tuple[float, float] = (0.0, 0.0)


@dataclass
class Model:
    """The assembled finite-element structure of the linkage at a fixed topology.

    Build it with :func:`build_model`.  All matrices are in the reduced coordinates ``q``
    (``len(dofs)``); the paper's 32 numbered DOFs are a view, :meth:`paper_numbering`.
    """

    params: Params
    elements_per_link: tuple[int, ...]
    motors: bool
    tie_crank_roots: bool
    dofs: list[Dof]
    elements: list[ElementInfo]
    paper_dofs: list[int]
    motor_dofs: dict[int, tuple[int, int, int, int]]
    node_dofs: dict[str, tuple[int, int]]
    Me: dict[str, NDArray] = field(repr=False)
    Ke: dict[str, NDArray] = field(repr=False)
    Mm: dict[int, NDArray] = field(repr=False)
    Km: dict[int, NDArray] = field(repr=False)
    lumped: dict[str, float] = field(repr=False)
    _motor_link: dict[str, str] = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        """Number of generalised coordinates."""
        return len(self.dofs)

    @property
    def linkage(self) -> Linkage:
        """The linkage description the model is built from."""
        return self.params.linkage

    def _reversed(self, link: str) -> bool:
        """Whether the direction of a link's elements is opposite to its kinematic direction."""
        return self.linkage.fe_reversed(link)

    def _node_link(self, node: str) -> str:
        """The link a translating joint's node is read on: the first link with elements there."""
        return next(k.name for k in self.linkage.links_at(node) if not k.rigid)

    def _node_location(self, node: str) -> tuple[str, float]:
        """(link, fraction along the link's kinematic direction) of a translating node."""
        lk = self.linkage
        if "[" in node:
            link, j = node[:-1].split("[")
            s = int(j) / self.elements_per_link[lk.link_names.index(link)]
        else:  # a joint: an end of the first link with elements there
            link = self._node_link(node)
            s = 1.0 if lk.fe_ends(link)[1] == node else 0.0
        if self._reversed(link):
            s = 1.0 - s
        return link, s

    @property
    def node_frames(self) -> dict[str, float]:
        """Node -> angle (rad) of the frame of its translations, for the slider nodes (whose
        one translation DOF is along the guide); the other nodes' frame is the global one."""
        return {j.name: j.guide.angle for j in self.linkage.sliders  # type: ignore[union-attr]
                if j.name in self.node_dofs}

    @property
    def element_frames(self) -> NDArray:
        """(n_elements, 2) angles (rad) of the translation frames of every element's nodes."""
        return np.array([el.frames for el in self.elements], float).reshape(len(self.elements), 2)

    # --- configuration-dependent matrices --------------------------------------------------
    def element_angles(self, angles: dict[str, NDArray]) -> list[NDArray]:
        """Angle (rad) of each element's axis for the link angles of :func:`link_angles`."""
        out = []
        for el in self.elements:
            beta = np.asarray(angles[el.link], float)
            if self._reversed(el.link):
                beta = beta + np.pi
            out.append(beta)
        return out

    def _rotations(self, beta: NDArray, frames: ArrayLike | None = None, derivative: bool = False) -> NDArray:
        """R (local <- global) of elements at axis angles ``beta`` (...), its nodes'
        translations in frames turned by ``frames`` (..., 2) (rad; None: the global frame);
        ``derivative``: dR/dbeta."""
        beta = np.asarray(beta)
        R = np.zeros(beta.shape + (8, 8))
        if frames is None or not np.any(frames):
            cs = [(np.cos(beta), np.sin(beta))] * 2
        else:
            f = np.asarray(frames, float)
            cs = [(np.cos(beta - f[..., i]), np.sin(beta - f[..., i])) for i in (0, 1)]
        for k, (c, s) in zip((0, 4), cs):
            if derivative:  # d/dbeta of [[c, s], [-s, c]]
                c, s = -s, c
            R[..., k, k] = c
            R[..., k, k + 1] = s
            R[..., k + 1, k] = -s
            R[..., k + 1, k + 1] = c
        if not derivative:
            for k in (2, 3, 6, 7):
                R[..., k, k] = 1.0
        return R

    def matrices(self, *theta: ArrayLike, mode: int | None = None) -> tuple[NDArray, NDArray]:
        """Global mass and stiffness matrices M, K at crank angles (rad), one per driven crank.

        ``M, K = model.matrices(theta1, theta4)`` (the five-bar); with arrays of angles the
        result has shape ``(..., n, n)``.  K holds the structural stiffness (beams and K11 of
        the motors); the electromagnetic K0 of (2.7) is separate.
        """
        angles = link_angles(self.params, *theta, mode=mode)
        shape = np.shape(angles[self.elements[0].link])
        n = self.n
        M = np.zeros(shape + (n, n))
        K = np.zeros(shape + (n, n))
        for el, beta in zip(self.elements, self.element_angles(angles)):
            R = self._rotations(np.broadcast_to(beta, shape), el.frames)
            keep = [i for i, d in enumerate(el.dofs) if d >= 0]
            g = np.array([el.dofs[i] for i in keep])
            Rk = R[..., :, keep]  # local <- kept global
            M[..., g[:, None], g[None, :]] += np.swapaxes(Rk, -1, -2) @ self.Me[el.link] @ Rk
            K[..., g[:, None], g[None, :]] += np.swapaxes(Rk, -1, -2) @ self.Ke[el.link] @ Rk
        for node, m in self.lumped.items():
            for d in self.node_dofs.get(node, ()):  # (a joint that does not translate carries none)
                if d >= 0:
                    M[..., d, d] += m
        for i, idx in self.motor_dofs.items():
            g = np.array(idx)
            M[..., g[:, None], g[None, :]] += self.Mm[i]
            K[..., g[:, None], g[None, :]] += self.Km[i]
        # R^T M R is symmetric only to round-off: make it exactly so
        return 0.5 * (M + np.swapaxes(M, -1, -2)), 0.5 * (K + np.swapaxes(K, -1, -2))

    def corotating_transform(self, *theta: ArrayLike, mode: int | None = None) -> NDArray:
        """T with u = T q~: translations of every node expressed in a frame that turns with it.

        Interior nodes of a link turn with that link; a pin turns with the first link with
        elements there (for the five-bar B, C, D with L1, L2, L3).  Slopes, curvatures, motor DOFs
        and a slider's translation along its fixed guide are unchanged.
        In these coordinates M and K vary with the configuration only through the angles
        between links, so their period means are meaningful (in the global frame they are
        not: averaging smears each link's axial stiffness over every direction).
        Shape ``(..., n, n)``; T is orthogonal.
        """
        angles = link_angles(self.params, *theta, mode=mode)
        shape = np.shape(angles[self.elements[0].link])
        T = np.zeros(shape + (self.n, self.n))
        idx = np.arange(self.n)
        T[..., idx, idx] = 1.0
        for node, (ix, iy) in self.node_dofs.items():
            if iy < 0:  # a slider: its one DOF lies along the fixed guide
                continue
            link = node.split("[")[0] if "[" in node else self._node_link(node)
            c, s = np.cos(angles[link]), np.sin(angles[link])
            T[..., ix, ix], T[..., ix, iy] = c, -s
            T[..., iy, ix], T[..., iy, iy] = s, c
        return T

    # --- rigid-body fields --------------------------------------------------------------
    def _rigid_field(self, state: RigidState, order: int) -> NDArray:
        shape = np.shape(state.angle[self.elements[0].link])
        out = np.zeros(shape + (self.n,))
        g = self.params.gravity if order == 2 else 0.0
        rate = state.omega if order == 1 else state.alpha
        frames = self.node_frames
        for node, (ix, iy) in self.node_dofs.items():
            link, s = self._node_location(node)
            v = state.point(link, s)[order]
            if node in frames:  # a slider: the component along its guide
                phi = frames[node]
                out[..., ix] = v[..., 0] * np.cos(phi) + (v[..., 1] + g) * np.sin(phi)
                continue
            out[..., ix] = v[..., 0]
            out[..., iy] = v[..., 1] + g
        for i, d in enumerate(self.dofs):
            if d.kind == "slope":
                out[..., i] = rate[d.link]
            elif d.kind.startswith("torsion"):
                out[..., i] = rate[self._motor_link[d.where]]
        return out

    def rigid_acceleration(self, state: RigidState) -> NDArray:
        """The rigid acceleration array u_r'' of (2.7) in the generalised coordinates.

        Translation DOFs: the rigid acceleration of the node (global x, y, m/s^2; at a slider
        its component along the guide), plus the gravity assumption (``params.gravity`` along
        -y enters as +g on y); slope DOFs: the
        link's angular acceleration (rad/s^2); curvature DOFs: zero (the quintic shape
        functions reproduce a rigid motion exactly); motor rotor DOFs: zero (the stator is
        fixed); motor torsion DOFs: the crank's angular acceleration.
        """
        return self._rigid_field(state, 2)

    def prescribed_load(self, state: RigidState) -> NDArray:
        r"""The inertial load on the DOFs from the rigid motion of the DOFs the joints eliminate.

        The elastic DOFs of a joint that moves as the drives prescribe (the far joint of a
        rigid crank, a driven slider) or turns with a clamped crank root under a non-uniform
        drive are eliminated, but their rigid acceleration loads the elements they belong to:
        :math:`-\mathbf M_{ke}\ddot{\mathbf u}_{r,e}`, with :math:`\mathbf M_{ke}` the consistent
        mass between the kept and the eliminated DOFs of each element.  Gravity
        (``params.gravity``) is part of that field at every eliminated translation, on the
        ground too: the weight of an element is :math:`\mathbf M_e` times the field
        :math:`g\,\mathbf e_y` on *all* its translations (the translations' shape functions sum
        to one), so leaving out the eliminated ones would drop the share of the weight near
        each pin, a share that vanishes only as the mesh is refined.  Zero without gravity for
        joints on the ground and for crank roots at constant speed (the paper's five-bar).  Shape
        ``(..., n)`` (N, N m); (2.7)'s right-hand side is :math:`-\mathbf M\ddot{\mathbf u}_r`
        plus this.
        """
        shape = np.shape(state.angle[self.elements[0].link])
        out = np.zeros(shape + (self.n,))
        grav = self.params.gravity
        for el, beta in zip(self.elements, self.element_angles(state.angle)):
            a = np.zeros(shape + (8,))
            moving = False
            for node, first in ((0, True), (1, False)):
                loc = 4 * node
                at_end = el.index == 0 if first else el.index == self.elements_per_link[
                    self.linkage.link_names.index(el.link)] - 1
                if not at_end:
                    continue
                joint = self.linkage.fe_ends(el.link)[0 if first else 1]
                if el.dofs[loc] < 0 or el.dofs[loc + 1] < 0:
                    acc = state.acc[joint]
                    ax, ay = acc[..., 0], acc[..., 1] + grav  # gravity along -y: the field +g on y, as in (2.7)
                    phi = el.frames[node]
                    c, sn = np.cos(phi), np.sin(phi)
                    comp = (ax * c + ay * sn, -ax * sn + ay * c)
                    for k in (0, 1):
                        if el.dofs[loc + k] < 0 and np.any(comp[k]):
                            a[..., loc + k] = comp[k]
                            moving = True
                if el.dofs[loc + 2] < 0 and np.any(state.alpha[el.link]):
                    a[..., loc + 2] = state.alpha[el.link]
                    moving = True
            if not moving:
                continue
            R = self._rotations(np.broadcast_to(beta, shape), el.frames)
            Mg = np.swapaxes(R, -1, -2) @ self.Me[el.link] @ R
            keep = [i for i, d in enumerate(el.dofs) if d >= 0]
            g = np.array([el.dofs[i] for i in keep])
            out[..., g] -= np.einsum("...ij,...j->...i", Mg[..., keep, :], a)
        return out

    def rigid_velocity(self, state: RigidState) -> NDArray:
        """The rigid velocity field in the generalised coordinates (as :meth:`rigid_acceleration`,
        one derivative lower).  With unit crank speeds it is the mechanism's rigid-body mode:
        the displacement pattern of a small crank rotation."""
        return self._rigid_field(state, 1)

    # --- elastic displacement fields --------------------------------------------------
    def element_displacements(self, u: ArrayLike, *theta: ArrayLike, mode: int | None = None) -> NDArray:
        """Local DOFs [u1, w1, w1', w1'', u2, w2, w2', w2''] of every element.

        ``u`` has shape ``(..., n)`` and broadcasts with the crank angles (rad, one per driven
        crank); the result has shape ``(..., n_elements, 8)`` (m, rad, 1/m) in each element's
        own frame.
        """
        u = np.asarray(u, float)
        angles = link_angles(self.params, *theta, mode=mode)
        padded = np.concatenate([u, np.zeros(u.shape[:-1] + (1,))], axis=-1)  # index -1 -> 0
        out = []
        for el, beta in zip(self.elements, self.element_angles(angles)):
            R = self._rotations(np.asarray(beta), el.frames)
            out.append((R @ padded[..., list(el.dofs)][..., None])[..., 0])
        return np.stack(out, axis=-2)

    def link_displacement(
        self, u: ArrayLike, *args: Any, derivative: int = 0, mode: int | None = None
    ) -> tuple[NDArray, NDArray]:
        """Elastic (axial, transverse) displacement of the point at fraction ``s`` of a link.

        ``model.link_displacement(u, theta1, theta4, link, s)``: the crank angles (one per
        driven crank), the link's name and ``s``.  ``s`` runs along the link's kinematic
        direction (start to end joint), and the transverse direction is that direction's left
        normal.  ``derivative`` = 1, 2 gives d/dx, d^2/dx^2 along the link (the slope and
        curvature of the deflection).  Works for any mesh: the point is interpolated with the
        element's shape functions.
        """
        *theta, link, s = args
        self._check_link_point(link, s)
        return self.link_point(self.element_displacements(u, *theta, mode=mode), link, s, derivative)

    def _check_link_point(self, link: str, s: float) -> None:
        if not 0.0 <= s <= 1.0:
            raise InputError(f"s = {s!r} is not allowed: give a fraction of the link in [0, 1]")
        if link not in self.linkage.link_names:
            raise InputError(f"link = {link!r} is not allowed: use one of {list(self.linkage.link_names)}")
        if self.linkage.link(link).rigid:
            flexible = [k.name for k in self.linkage.flexible]
            raise InputError(f"link = {link!r} is not allowed: it is rigid (no elastic displacement); use one of "
                             f"{flexible}")

    def link_point(self, q: ArrayLike, link: str, s: float, derivative: int = 0) -> tuple[NDArray, NDArray]:
        """:meth:`link_displacement` from the element displacements ``q`` already computed
        (:meth:`element_displacements`, shape ``(..., n_elements, 8)``): for several points of
        one state history, compute ``q`` once."""
        self._check_link_point(link, s)
        q = np.asarray(q, float)
        rev = self._reversed(link)
        sc = 1.0 - s if rev else s
        els = [i for i, el in enumerate(self.elements) if el.link == link]
        i = next((k for k in els if self.elements[k].s0 <= sc <= self.elements[k].s1))
        el = self.elements[i]
        L_link = el.length * self.elements_per_link[self.linkage.link_names.index(link)]
        N = shape_functions(np.array([(sc - el.s0) * L_link]), el.length, derivative)[0]
        axial = q[..., i, :] @ (N * _AXIAL)
        transverse = q[..., i, :] @ (N * (1 - _AXIAL))
        if rev:  # element frame = link frame turned by pi, and d/dx = -d/dxbar
            sign = (-1.0) ** (derivative + 1)
            axial, transverse = sign * axial, sign * transverse
        return axial, transverse

    def deformed_shape(
        self, u: ArrayLike, *theta: float, scale: float = 1.0, points: int = 41, mode: int | None = None
    ) -> dict[str, NDArray]:
        """Points of the deformed links at one configuration (crank angles ``theta``), for drawing.

        Returns ``{"L1": (points, 2), ...}``: the rigid position of ``points`` equally spaced
        points of each link plus ``scale`` times their elastic displacement (m).
        """
        from .kinematics import positions

        P = positions(self.params, *theta, mode=mode)
        out = {}
        for link, (a, b) in self.linkage.link_ends.items():
            d = P[b] - P[a]
            e = d / np.linalg.norm(d)
            n = np.array([-e[1], e[0]])
            pts = []
            for s in np.linspace(0.0, 1.0, points):
                ax, tr = (0.0, 0.0) if self.linkage.link(link).rigid else \
                    self.link_displacement(u, *theta, link, s, mode=mode)
                pts.append(P[a] + s * d + scale * (ax * e + tr * n))
            out[link] = np.array(pts)
        return out

    # --- views -----------------------------------------------------------------------------
    def paper_numbering(self) -> list[tuple[int, str, int]]:
        """The paper's numbering: (paper number, label, index in q) for u1..u32.

        Two paper DOFs share an index where the crank root is tied to the motor shaft
        (u9 with U4, u31 with U8).
        """
        return [(k + 1, self.dofs[i].label, i) for k, i in enumerate(self.paper_dofs)]

    def B_matrix(self, element: int) -> NDArray:
        """The Boolean matrix B_i (A.12) of beam element ``element`` (0-based) in the paper's
        numbering of the beam DOFs 9..32: shape (8, number of beam DOFs)."""
        beam = self.paper_dofs[8:] if self.motors else self.paper_dofs
        col = {q: j for j, q in enumerate(beam)}
        B = np.zeros((8, len(beam)))
        for r, d in enumerate(self.elements[element].dofs):
            if d >= 0:
                B[r, col[d]] = 1.0
        return B

    def dof_index(self, label: str) -> int:
        """Index in q of the DOF with this label (e.g. ``"L2[1].y"``, ``"U4"``)."""
        for i, d in enumerate(self.dofs):
            if d.label == label:
                return i
        raise KeyError(f"no DOF labelled {label!r}; labels are {[d.label for d in self.dofs]}")


def build_model(
    params: Params,
    elements_per_link: tuple[int, ...] | None = None,
    motors: bool = True,
    tie_crank_roots: bool = True,
) -> Model:
    """Number the DOFs, build the element matrices and return the :class:`Model`.

    ``model = build_model(params)`` gives the description's mesh (the paper's 1-2-2-1) with
    its motors.

    Parameters
    ----------
    params
        Parameter set; its ``linkage`` gives the links (length, section, material), joints,
        lumped masses and motors.
    elements_per_link
        Elements on each link in the order of the description (each >= 1, 0 on a rigid link);
        ``None`` is the description's mesh (for the paper's five-bar (1, 2, 2, 1) on L1..L4).
    motors
        Include the motor elements of the motor-driven cranks (DOFs U1-U8 for the five-bar)
        with the crank roots tied to the shaft torsion; ``False`` clamps the crank roots
        (rigid motor shafts).
    tie_crank_roots
        ``False`` gives the literal reading of (A.12): crank-root slopes independent of the
        motors, and free where a crank has no motor (the pin of a rigid crank then translates
        freely): singular K, the free-rotor model's starting point
        (:class:`fivebar.model.free_rotors.FlexibleLinkage`).
    """
    lk = params.linkage
    epl = lk.check_mesh(elements_per_link)
    dofs: list[Dof] = []
    paper: list[int] = []

    def new(label: str, kind: str, where: str, link: str | None = None) -> int:
        dofs.append(Dof(label, kind, where, link))
        paper.append(len(dofs) - 1)
        return len(dofs) - 1

    motor_dofs: dict[int, tuple[int, int, int, int]] = {}
    root_motor: dict[str, int] = {}  # crank joint -> motor ordinal
    motor_link: dict[str, str] = {}  # motor section -> the link it turns
    if motors:
        for i, (joint, section) in enumerate(lk.motors, start=1):
            base = 4 * (i - 1)
            motor_dofs[i] = tuple(
                new(f"U{base + k + 1}", kind, section)
                for k, kind in enumerate(("rotor_x", "rotor_y", "torsion_bearing", "torsion_coupling"))
            )
            root_motor[joint] = i
            motor_link[section] = lk.crank_link(joint).name

    node_dofs: dict[str, tuple[int, int]] = {}
    elements: list[ElementInfo] = []
    body = {name: b for b in lk.bodies for name in b}
    # joints that do not translate elastically: on the ground, a driven slider, the far end of a rigid crank
    fixed = {j.name for j in lk.joints if j.on_ground or (j.kind == "slider" and j.drive is not None)}
    if tie_crank_roots:  # (the literal model leaves a rigid crank free to turn: its pin then translates)
        fixed |= {x for k in lk.links if k.rigid for x in (k.start, k.end) if not lk.joint(x).on_ground}
    shared: dict[tuple[str, tuple[str, ...]], int] = {}  # (joint, body) -> the slope welded arms share

    def slope_at(link: str, joint: str, label_link: str) -> int:
        key = (joint, body[link])
        if key not in shared:
            shared[key] = new(f"{label_link}@{joint}.slope", "slope", joint, label_link)
        return shared[key]

    for k, (lnk, ne) in enumerate(zip(lk.links, epl)):
        if lnk.rigid:
            continue
        link = lnk.name
        first, last = lk.fe_ends(link)
        # nodal DOFs of this link: (x, y, slope, curvature) with -1 for zero
        nodes: list[tuple[int, int, int, int]] = []
        frames = [0.0, 0.0]
        for j in range(ne + 1):
            joint = first if j == 0 else last if j == ne else None
            kind = lk.joint(joint).kind if joint is not None else None
            welded = joint is not None and any(
                x.name != link and not x.rigid and body[x.name] == body[link] for x in lk.links_at(joint))
            if kind == "crank":
                if joint in root_motor and tie_crank_roots:
                    slope = motor_dofs[root_motor[joint]][3]
                    paper.append(slope)  # the paper's u9 / u31 is U4 / U8
                elif joint in root_motor or not tie_crank_roots:
                    slope = slope_at(link, joint, link)
                else:
                    slope = -1
                curv = new(f"{link}@{joint}.curvature", "curvature", joint, link)  # after the slope, as u10, u32
                nodes.append((-1, -1, slope, curv))
            elif kind == "ground":  # a ground pin: no translation, own slope, zero curvature (welded: own)
                slope = slope_at(link, joint, link)
                curv = new(f"{link}@{joint}.curvature", "curvature", joint, link) if welded else -1
                nodes.append((-1, -1, slope, curv))
            elif joint is not None:  # a pin or a slider: shared translation, own slope, zero curvature
                J = lk.joint(joint)
                if joint in fixed:
                    xy = (-1, -1)
                elif J.kind == "slider":  # the translation along the guide; the normal one eliminated
                    if J.guide.link is not None:  # type: ignore[union-attr]
                        raise InputError(
                            f"the slider {joint} moves on the link {J.guide.link}: the finite-element model takes "  # type: ignore[union-attr]
                            "sliders on ground guides only (on a moving link the contact point runs along that "
                            "link's elements); its rigid kinematics are available (fivebar.model.kinematics)")
                    if joint not in node_dofs:
                        node_dofs[joint] = (new(f"{joint}.s", "s", joint), -1)
                    xy = node_dofs[joint]
                    frames[0 if j == 0 else 1] = J.guide.angle  # type: ignore[union-attr]
                else:
                    if joint not in node_dofs:
                        node_dofs[joint] = (new(f"{joint}.x", "x", joint), new(f"{joint}.y", "y", joint))
                    xy = node_dofs[joint]
                slope = slope_at(link, joint, link)
                curv = new(f"{link}@{joint}.curvature", "curvature", joint, link) if welded else -1
                nodes.append((*xy, slope, curv))
            else:  # interior node
                name = f"{link}[{j}]"
                ix, iy = new(f"{name}.x", "x", name), new(f"{name}.y", "y", name)
                node_dofs[name] = (ix, iy)
                slope = new(f"{name}.slope", "slope", name, link)
                curv = new(f"{name}.curvature", "curvature", name, link)
                nodes.append((ix, iy, slope, curv))
        Le = lnk.length / ne
        for j in range(ne):
            a, b = nodes[j], nodes[j + 1]
            fr = (frames[0] if j == 0 else 0.0, frames[1] if j == ne - 1 else 0.0)
            elements.append(
                ElementInfo(link, j, j / ne, (j + 1) / ne, Le, (a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]), fr)
            )

    Me, Ke = {}, {}
    for lnk, ne in zip(lk.links, epl):
        if not lnk.rigid:
            Me[lnk.name], Ke[lnk.name] = _link_element(lnk, ne, params)
    Mm, Km = {}, {}
    for i, (_, section) in enumerate(lk.motors if motors else (), start=1):
        Mm[i], Km[i] = motor_element(params.motors[section])
    model = Model(
        params=params,
        elements_per_link=epl,
        motors=motors,
        tie_crank_roots=tie_crank_roots,
        dofs=dofs,
        elements=elements,
        paper_dofs=paper,
        motor_dofs=motor_dofs,
        node_dofs=node_dofs,
        Me=Me,
        Ke=Ke,
        Mm=Mm,
        Km=Km,
        lumped=lk.masses,
    )
    model._motor_link = motor_link
    return model


def _link_element(link: Link, ne: int, params: Params) -> tuple[NDArray, NDArray]:
    sec, mat = link.section, link.material
    return beam_element(link.length / ne, mat.E, sec.area, sec.I, mat.rho, rotary_inertia=bool(params.rotary_inertia))


def paper_b_matrices() -> dict[int, NDArray]:
    """The B matrices of the beam elements 3..8 as printed in (A.12) (8 x 24 each, global
    DOFs 9..32), read from ``data/paper_b_matrices.toml``."""
    doc = tomllib.loads((DEFAULT_PARAMS_PATH.parent / "paper_b_matrices.toml").read_text())
    out = {}
    for name, pairs in doc["printed"].items():
        B = np.zeros((8, 24))
        for local, glob in pairs:
            B[local - 1, glob - 9] = 1.0
        out[int(name[1:])] = B
    return out
