r"""The linkage description: bodies (links) and joints, lumped masses, drives and assembly branches.

A planar linkage is written as data, the ``[linkage]`` section of a parameter file.  Two forms
are read.  **Any planar linkage** of revolute and prismatic joints, with one or more closed
loops and one or two driven inputs, is a set of links and joints:

.. code-block:: toml

    [linkage]
    name = "flexible slider-crank"
    assembly = [{ joint = "C", side = "ahead" }]       # one branch per loop (below)

    [linkage.links]                                    # the order is the finite elements' order
    crank = { start = "A", end = "B", length = 0.15, rigid = true }
    rod = { start = "B", end = "C", length = 0.30, elements = 4,
            section = { width = 0.008, thickness = 0.008, bending_depth = 0.008 },
            material = { rho = 7870.0, E = 2.0e11 } }

    [linkage.joints]
    A = { kind = "crank", at = [0.0, 0.0], theta0 = 0.0, ratio = 1.0 }
    B = { kind = "pin" }
    C = { kind = "slider", guide = { at = [0.0, 0.0], angle = 0.0 }, mass = 0.075552 }

* **Links** are straight bars from ``start`` to ``end`` (their angle is that of ``end -
  start``), each with its ``length`` (m), ``elements`` (beam elements of the default mesh) and
  optionally its own ``section = {width, thickness, bending_depth}`` (m) and ``material =
  {rho, E}`` (kg/m^3, Pa); without them a link takes the parameter file's ``[geometry]`` width
  and thickness, ``assumptions.bending_depth`` and ``[material]``.  ``weld = { link = "rocker",
  angle = 2.1 }`` joins a link rigidly to another at their common joint, at ``angle`` (rad,
  anticlockwise) from that link's direction: a body with three or more joints (a bell crank, a
  ternary coupler) is two or more welded arms.  ``rigid = true`` makes a driven crank rigid (no
  elastic DOF: its far joint follows the drive exactly).
* **Joints** (``kind``): ``"crank"``, a revolute on the ground driven by a drive law (``at``,
  ``theta0``, ``ratio``, ``fourier``, ``motor``); ``"ground"``, a revolute on the ground
  (``at``); ``"pin"``, a revolute between the links that meet there (with one link: a free end
  or a point of a body); ``"slider"``, a block pinned to the links that end there and sliding
  on a guide: the ground line ``guide = { at = [x, y], angle = a }`` (its point ``at + s (cos
  a, sin a)``) or the axis of a moving link ``guide = { link = "lever" }`` (through its start and
  end joints); ``drive = { s0 = ..., fourier = [[a1, b1], ...] }`` makes the slider a driven
  input (ground guide only), :math:`s(t) = s_0 + \sum_k a_k\cos k\Omega t + b_k\sin k\Omega t`
  (m).  ``mass`` (kg) is a lumped mass at a pin or the slider block's mass.
* **Drives**: a crank's angle is :math:`\theta(t) = \theta_0 + r\,\Omega t + \sum_k a_k\cos
  k\Omega t + b_k\sin k\Omega t` (rad) with the crank speed :math:`\Omega` of the parameter file,
  its ``ratio`` :math:`r` and ``fourier = [[a1, b1], ...]``; in Python any periodic law can be
  given as a function (:class:`Drive`).  One or two driven inputs (cranks or sliders), as many as
  the mobility.
* **Mobility** (Gruebler): :math:`M = 3(n - 1) - 2(j_R + j_P)` with :math:`n` the bodies (the
  ground, each set of welded links, each slider block), :math:`j_R` the revolutes (at a joint
  where :math:`k` bodies meet, :math:`k - 1`) and :math:`j_P` the prismatic joints (one per
  slider).  It must equal the number of driven inputs; the independent loops number
  :math:`j_R + j_P - n + 1`.
* **Closure and branches**: the kinematics close the loops one after another, as a sequence of
  dyads (two links, or a link and a guide, between known joints: :attr:`Linkage.plan`); each
  dyad has two assembly branches and ``assembly`` names the one of each: for two links meeting
  at ``joint`` (RRR), ``{ joint = "F", side = "left" or "right", line = ["E", "G"] }``: the
  joint on that side of the directed line from ``E`` to ``G`` (its two neighbours); for a link
  ending at a slider on a guide (RRP), ``{ joint = "C", side = "ahead" or "behind" }``: the
  slider ahead of or behind the foot of the perpendicular from the link's other joint, along
  the guide's direction; for a slider on a link whose angle it fixes (RPR), ``{ joint = "B",
  side = "ahead" or "behind" }``: the slider ahead of or behind the link's known joint along the
  link's direction.  A linkage that is not a sequence of dyads (a class-III Assur group) is
  refused.

**The single-loop chain form** of the first descriptions is read too (the paper's five-bar and
the four-bar ship in it): ``chain = ["A", "B", ...]`` lists the joints around the loop from one
ground joint to the other, every link joins two neighbours of the chain, the joints inside the
chain are pins, and ``assembly = { joint = "C", side = "left" }`` puts the pin between the two
undriven links on that side of the directed line from its predecessor to its successor in the
chain.  Its links' finite elements run along the chain.

Any number may instead be the dotted key of a flat entry of the parameter file
(``length = "geometry.L1"``): the description then uses that entry, with its provenance, and
``Params.replace`` of that entry moves the linkage.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..cache import memoised
from ..errors import FivebarError, InputError, ParameterError

__all__ = ["Assembly", "Drive", "Guide", "Joint", "Link", "Linkage", "LinkageError", "Material", "Section", "Step",
           "linkage_from_toml"]


class LinkageError(ParameterError):
    """A linkage description holds a missing, unknown or invalid entry (the message names it)."""


@dataclass(frozen=True)
class Section:
    """Cross-section of a flat bar: ``width`` x ``thickness`` (m), ``bending_depth`` (m) the
    side that lies in the plane of motion."""

    width: float
    thickness: float
    bending_depth: float

    @property
    def area(self) -> float:
        """Area (m^2)."""
        return self.width * self.thickness

    @property
    def I(self) -> float:  # noqa: E743 - the usual name
        """Second moment of area for in-plane bending (m^4): A d^2 / 12 with d = bending_depth."""
        d = self.bending_depth
        return self.area / d * d**3 / 12.0


@dataclass(frozen=True)
class Material:
    """Density ``rho`` (kg/m^3) and Young's modulus ``E`` (Pa)."""

    rho: float
    E: float


@dataclass(frozen=True)
class Link:
    """A link from joint ``start`` to joint ``end`` (its angle is that of ``end - start``).

    ``rigid``: no elastic DOF (a driven crank only); ``weld``: (link, angle) when the link is
    welded to that link at their common joint, its direction at ``angle`` (rad) from that
    link's.
    """

    name: str
    start: str
    end: str
    length: float
    elements: int
    section: Section
    material: Material
    rigid: bool = False
    weld: tuple[str, float] | None = None

    @property
    def mass(self) -> float:
        """Mass of the bar (kg): rho A L."""
        return self.material.rho * self.section.area * self.length


@dataclass(frozen=True)
class Drive:
    r"""The law of a driven input.

    For a crank, the angle (rad)
    :math:`\theta(t) = \theta_0 + r\Omega t + \sum_k (a_k\cos k\Omega t + b_k\sin k\Omega t)`
    with ``fourier = ((a1, b1), (a2, b2), ...)``; for a driven slider the same law with
    ``ratio = 0`` gives its position along the guide (m).  When ``function`` is given,
    ``function(t, Omega) -> (theta, omega, alpha)`` (arrays shaped like ``t``; it should be
    periodic in :math:`2\pi/\Omega` up to whole turns for a periodic motion, and a function
    of :math:`\Omega t` only, as the Fourier law is: the sampled matrices of
    :class:`fivebar.model.dynamics.LinkageDynamics` are shared between speeds).  A function cannot
    be written in TOML: set it with ``dataclasses.replace`` on the linkage and the parameter
    set (``Params.replace`` rebuilds the linkage from the file's table and drops it).
    """

    theta0: float = 0.0
    ratio: float = 1.0
    fourier: tuple[tuple[float, float], ...] = ()
    function: Callable[[NDArray, float], tuple[ArrayLike, ArrayLike, ArrayLike]] | None = field(
        default=None, compare=False
    )

    def laws(self, t: ArrayLike, speed: float) -> tuple[NDArray, NDArray, NDArray]:
        """(value, rate, acceleration) of the input at times ``t`` (s) for the crank speed
        ``speed`` (rad/s): (rad, rad/s, rad/s^2) for a crank, (m, m/s, m/s^2) for a slider."""
        t = np.asarray(t, float)
        if self.function is not None:
            th, w, a = self.function(t, speed)
            return tuple(np.broadcast_to(np.asarray(x, float), t.shape).copy() for x in (th, w, a))  # type: ignore[return-value]
        W = self.ratio * speed
        z = np.zeros_like(t)
        theta, omega, alpha = self.theta0 + W * t, z + W, z
        for k, (a, b) in enumerate(self.fourier, start=1):
            kW = k * speed
            c, s = np.cos(kW * t), np.sin(kW * t)
            theta = theta + a * c + b * s
            omega = omega + kW * (b * c - a * s)
            alpha = alpha - kW**2 * (a * c + b * s)
        return theta, omega, alpha


@dataclass(frozen=True)
class Guide:
    """The line a slider moves on: the ground line through ``at`` (m) at ``angle`` (rad), or
    the axis of the link ``link`` (through its start and end joints)."""

    at: tuple[float, float] | None = None
    angle: float = 0.0
    link: str | None = None

    @property
    def direction(self) -> NDArray:
        """Unit vector of a ground guide."""
        return np.array([math.cos(self.angle), math.sin(self.angle)])


@dataclass(frozen=True)
class Joint:
    """A joint: ``kind`` "crank" (driven, on the ground), "ground" (a ground revolute), "pin"
    (a revolute between links; with one link, a free end) or "slider" (a block on ``guide``,
    driven when it has a ``drive``); ``at`` the ground coordinates (m), ``motor`` the motor
    section that drives a crank (or None), ``drive`` its law, ``mass`` a lumped mass (kg)."""

    name: str
    kind: str
    at: tuple[float, float] | None = None
    motor: str | None = None
    drive: Drive | None = None
    mass: float = 0.0
    guide: Guide | None = None

    @property
    def on_ground(self) -> bool:
        """A revolute on the ground (crank or ground pin): its position is fixed."""
        return self.kind in ("crank", "ground")

    @property
    def driven(self) -> bool:
        """An input of the linkage: a crank, or a slider with a drive."""
        return self.kind == "crank" or (self.kind == "slider" and self.drive is not None)


@dataclass(frozen=True)
class Assembly:
    """The assembly branch of one dyad: ``joint`` on ``side`` ("left"/"right" of the directed
    line through ``line``, or "ahead"/"behind" along a guide)."""

    joint: str
    side: str
    line: tuple[str, str] | None = None

    @property
    def sign(self) -> float:
        """+1 for "left" or "ahead", -1 for "right" or "behind"."""
        return 1.0 if self.side in ("left", "ahead") else -1.0


@dataclass(frozen=True)
class Step:
    """One step of the closure (:attr:`Linkage.plan`).

    ``kind``: "drive" (a crank's link angle from its law), "slide" (a driven slider's point),
    "weld" (a link's angle from the link it is welded to), "walk" (a joint from a known joint
    and the known angle of the link between them), "rrr" (a joint where two links of unknown
    angles meet from two known joints ``known``), "rrp" (a slider at the end of one link of
    unknown angle from the known joint ``known[0]``, on a known guide), "rpr" (the angle of a
    guide link from its known joint ``known[0]`` and the known slider ``joint`` on it).
    ``links`` the links whose angles the step fixes (and, for "walk", the link walked), ``sign``
    the branch (+-1) of a dyad.
    """

    kind: str
    joint: str | None
    links: tuple[str, ...]
    known: tuple[str, ...] = ()
    sign: float = 1.0


@dataclass(frozen=True)
class Linkage:
    """A planar linkage of revolute and prismatic joints (see the module text for the TOML).

    ``links`` in the order of the description (for the chain form, the chain's); ``joints`` in
    the order of the description; ``assembly`` one branch per dyad of :attr:`plan`; ``chain``
    the joints around the loop of the chain form (None for the general form).
    """

    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    assembly: tuple[Assembly, ...]
    chain: tuple[str, ...] | None = None

    # --- derived views ---------------------------------------------------------------------
    def joint(self, name: str) -> Joint:
        """The joint called ``name``."""
        for j in self.joints:
            if j.name == name:
                return j
        raise LinkageError(f"no joint {name!r} in the linkage: its joints are {[j.name for j in self.joints]}")

    def link(self, name: str) -> Link:
        """The link called ``name``."""
        for k in self.links:
            if k.name == name:
                return k
        raise LinkageError(f"no link {name!r} in the linkage: its links are {[k.name for k in self.links]}")

    @property
    def link_ends(self) -> dict[str, tuple[str, str]]:
        """Link name -> (start joint, end joint), the direction of the link angle."""
        return {k.name: (k.start, k.end) for k in self.links}

    @property
    def link_names(self) -> tuple[str, ...]:
        """The links in the order of the description."""
        return tuple(k.name for k in self.links)

    def links_at(self, joint: str) -> tuple[Link, ...]:
        """The links that start or end at ``joint``, in the order of the description."""
        return tuple(k for k in self.links if joint in (k.start, k.end))

    @property
    def lengths(self) -> tuple[float, ...]:
        """Link lengths (m) in the order of the description, then the frame's (the distance of
        the first two ground joints) when there are two or more: (L1, ..., L5) for the paper's
        five-bar."""
        out = tuple(k.length for k in self.links)
        g = self.ground
        if len(g) < 2:
            return out
        a, b = (np.asarray(j.at) for j in g[:2])
        return (*out, float(np.hypot(*(b - a))))

    @property
    def ground(self) -> tuple[Joint, ...]:
        """The revolutes on the ground (cranks and ground pins), in the order of the
        description (of the chain form: its first and last joints)."""
        return tuple(j for j in self.joints if j.on_ground)

    @property
    def inputs(self) -> tuple[Joint, ...]:
        """The driven inputs (cranks and driven sliders) in the order of the description:
        ``theta`` arguments of the kinematics come in this order, one number each (rad for a
        crank, m for a slider)."""
        return tuple(j for j in self.joints if j.driven)

    @property
    def cranks(self) -> tuple[Joint, ...]:
        """The driven inputs (:attr:`inputs`; for the paper's five-bar its two cranks)."""
        return self.inputs

    @property
    def sliders(self) -> tuple[Joint, ...]:
        """The slider joints (driven or not), in the order of the description."""
        return tuple(j for j in self.joints if j.kind == "slider")

    def crank_link(self, joint: str) -> Link:
        """The link that a driven crank ``joint`` turns (the first link at it)."""
        return self.links_at(joint)[0]

    @property
    def motors(self) -> tuple[tuple[str, str], ...]:
        """(crank joint, motor section) of every crank driven by a motor, in input order."""
        return tuple((j.name, j.motor) for j in self.inputs if j.motor)

    def fe_ends(self, link: str) -> tuple[str, str]:
        """(first, last) joint of a link's finite elements: along the chain for the chain
        form, from start to end otherwise."""
        k = self.link(link)
        if self.chain is None:
            return k.start, k.end
        i = self.link_names.index(link)
        return self.chain[i], self.chain[i + 1]

    def fe_reversed(self, link: str) -> bool:
        """Whether a link's finite elements run against its kinematic direction."""
        return self.fe_ends(link)[0] != self.link(link).start

    @property
    def masses(self) -> dict[str, float]:
        """Joint -> lumped mass (kg) of every pin and slider (the block's mass)."""
        return {j.name: j.mass for j in self.joints if j.kind in ("pin", "slider")}

    @property
    def couplers(self) -> tuple[str, ...]:
        """The links with no end on a ground revolute (for the five-bar L2 and L3, whose
        midpoints Figure 6 shows; for a slider-crank its rod)."""
        return tuple(k.name for k in self.links if _between_pins(self, k))

    @property
    def default_mesh(self) -> tuple[int, ...]:
        """Elements per link of the description (its order; 0 for a rigid link)."""
        return tuple(0 if k.rigid else k.elements for k in self.links)

    @property
    def flexible(self) -> tuple[Link, ...]:
        """The links that carry beam elements (every link but the rigid ones)."""
        return tuple(k for k in self.links if not k.rigid)

    def check_mesh(self, elements_per_link: Any, even: bool = False) -> tuple[int, ...]:
        """Validate a mesh (one integer >= 1 per link, the description's order, 0 for a
        rigid link; ``None`` is the description's own); ``even`` asks for even numbers on the
        links with no end on a ground revolute."""
        if elements_per_link is None:
            return self.default_mesh
        n = len(self.links)
        rigid = [k.rigid for k in self.links]
        try:
            epl = tuple(elements_per_link)
            ok = len(epl) == n and all(
                not isinstance(k, bool) and int(k) == k and (k == 0 if r else k >= 1) for k, r in zip(epl, rigid))
        except (TypeError, ValueError):
            ok = False
        names = ", ".join(self.link_names)
        if not ok:
            zero = [k.name for k in self.links if k.rigid]
            rule = f"integers >= 1 (elements on {names})" if not zero else \
                f"integers (elements on {names}): >= 1, and 0 on the rigid {', '.join(zero)}"
            raise InputError(f"elements_per_link = {elements_per_link!r} is not allowed: give {n} {rule}")
        epl = tuple(int(k) for k in epl)
        if even:
            odd = [k.name for k, e in zip(self.links, epl) if e % 2 and _between_pins(self, k)]
            if odd:
                raise InputError(
                    f"elements_per_link = {elements_per_link!r} is not allowed: give {n} positive integers "
                    f"({names}) with even numbers on the links between two pins ({', '.join(odd)} has an odd number)"
                )
        return epl

    # --- structure ---------------------------------------------------------------------------
    @property
    def bodies(self) -> tuple[tuple[str, ...], ...]:
        """The moving bodies: each a tuple of links welded together (a single link otherwise),
        in the order of their first link."""
        return _bodies(self)

    def body_of(self, link: str) -> tuple[str, ...]:
        """The body (welded links) a link belongs to."""
        for b in self.bodies:
            if link in b:
                return b
        raise LinkageError(f"no link {link!r} in the linkage: its links are {list(self.link_names)}")

    @property
    def mobility(self) -> int:
        """Gruebler's mobility 3 (n - 1) - 2 (j_R + j_P) (module text)."""
        return _gruebler(self)[0]

    @property
    def loops(self) -> int:
        """The number of independent loops, j_R + j_P - n + 1."""
        n, jr, jp = _gruebler(self)[1:]
        return jr + jp - n + 1

    @property
    def plan(self) -> tuple[Step, ...]:
        """The closure as a sequence of steps (:class:`Step`): the drives, then the walks and
        welds they allow, a dyad where nothing else can be found, and so on until every joint
        and link angle is known."""
        return _plan(self)


def _between_pins(lk: Linkage, link: Link) -> bool:
    return all(lk.joint(j).kind in ("pin", "slider") for j in (link.start, link.end))


# --- structure: bodies, mobility, the closure plan ----------------------------------------------
@memoised
def _bodies(lk: Linkage) -> tuple[tuple[str, ...], ...]:
    parent = {k.name: k.name for k in lk.links}

    def root(x: str) -> str:
        while parent[x] != x:
            x = parent[x]
        return x

    for k in lk.links:
        if k.weld is not None:
            parent[root(k.name)] = root(k.weld[0])
    groups: dict[str, list[str]] = {}
    for k in lk.links:
        groups.setdefault(root(k.name), []).append(k.name)
    order = sorted(groups.values(), key=lambda g: lk.link_names.index(g[0]))
    return tuple(tuple(g) for g in order)


@memoised
def _gruebler(lk: Linkage) -> tuple[int, int, int, int]:
    """(mobility, bodies n with the ground, revolutes, prismatic joints)."""
    body = {name: i for i, b in enumerate(lk.bodies) for name in b}
    n = len(lk.bodies) + 1 + len(lk.sliders)
    jr = jp = 0
    for j in lk.joints:
        at = {body[k.name] for k in lk.links_at(j.name)}
        count = len(at) + (1 if j.on_ground or j.kind == "slider" else 0)
        jr += max(count - 1, 0)
        if j.kind == "slider":
            jp += 1
    return 3 * (n - 1) - 2 * (jr + jp), n, jr, jp


@memoised
def _plan(lk: Linkage) -> tuple[Step, ...]:
    """Decompose the linkage into a sequence of steps (:class:`Step`); raise LinkageError where
    it is not a sequence of dyads or a branch is not named."""
    links = {k.name: k for k in lk.links}
    points = {j.name for j in lk.joints if j.on_ground}
    angles: set[str] = set()
    steps: list[Step] = []
    branch = {a.joint: a for a in lk.assembly}
    used: set[str] = set()

    def other(k: Link, j: str) -> str:
        return k.end if k.start == j else k.start

    for j in lk.inputs:
        if j.kind == "crank":
            k = lk.crank_link(j.name)
            steps.append(Step("drive", j.name, (k.name,)))
            angles.add(k.name)
        else:
            steps.append(Step("slide", j.name, ()))
            points.add(j.name)

    def propagate() -> bool:
        moved = False
        again = True
        while again:
            again = False
            for k in lk.links:  # welds: a link's angle from the one it is welded to, or back
                if k.weld is None:
                    continue
                base = k.weld[0]
                if base in angles and k.name not in angles:
                    steps.append(Step("weld", None, (k.name, base)))
                    angles.add(k.name)
                    again = moved = True
                elif k.name in angles and base not in angles:
                    steps.append(Step("weld", None, (base, k.name)))
                    angles.add(base)
                    again = moved = True
            for k in lk.links:  # walks: a joint from a known joint and a known angle
                if k.name in angles and (k.start in points) != (k.end in points):
                    a = k.start if k.start in points else k.end
                    steps.append(Step("walk", other(k, a), (k.name,), (a,)))
                    points.add(other(k, a))
                    again = moved = True
        return moved

    def need(joint: str, kinds: tuple[str, ...], what: str) -> Assembly:
        a = branch.get(joint)
        example = {"left": 'side = "left" or "right"', "ahead": 'side = "ahead" or "behind"'}[kinds[0]]
        if a is None:
            raise LinkageError(f"linkage.assembly: the loop closed at joint {joint} ({what}) needs its branch: "
                               f"{{ joint = {joint!r}, {example}" + (", line = [...] }" if kinds[0] == "left" else " }"))
        if a.side not in kinds:
            raise LinkageError(f"linkage.assembly: joint {joint} ({what}) has side = {a.side!r}: use {example}")
        used.add(joint)
        return a

    while True:
        propagate()
        if len(points) == len(lk.joints) and len(angles) == len(lk.links):
            break
        step = None
        for j in lk.joints:  # dyads, in the order of the description
            if j.name in points:
                continue
            cand = [k for k in lk.links_at(j.name) if k.name not in angles and other(k, j.name) in points]
            if j.kind == "slider" and j.drive is None and cand:
                g = j.guide
                if g.link is None or (g.link in angles and links[g.link].start in points):  # type: ignore[union-attr]
                    k = cand[0]
                    a = need(j.name, ("ahead", "behind"), f"link {k.name} and the guide of the slider {j.name}")
                    step = Step("rrp", j.name, (k.name,), (other(k, j.name),), a.sign)
                    break
            elif j.kind != "slider" and len(cand) >= 2:
                k1, k2 = cand[:2]
                p, q = other(k1, j.name), other(k2, j.name)
                a = need(j.name, ("left", "right"), f"links {k1.name} and {k2.name}")
                if a.line is None or set(a.line) != {p, q}:
                    raise LinkageError(
                        f"linkage.assembly: joint {j.name} closes the links {k1.name} and {k2.name} between the "
                        f"joints {p} and {q}: its entry must name them, line = [{p!r}, {q!r}] (or the reverse), "
                        f"not {list(a.line) if a.line else None}")
                if a.line == (q, p):
                    k1, k2, p, q = k2, k1, q, p
                step = Step("rrr", j.name, (k1.name, k2.name), (p, q), a.sign)
                break
        if step is None:
            for j in lk.sliders:  # a guide link's angle from its known joint and a known slider on it
                g = j.guide
                if j.drive is not None or g.link is None or j.name not in points or g.link in angles:  # type: ignore[union-attr]
                    continue
                lever = links[g.link]  # type: ignore[index]
                pivot = [x for x in (lever.start, lever.end) if x in points]
                if pivot:
                    a = need(j.name, ("ahead", "behind"), f"the slider {j.name} on link {lever.name}")
                    step = Step("rpr", j.name, (lever.name,), (pivot[0],), a.sign)
                    break
        if step is None:
            missing = [j.name for j in lk.joints if j.name not in points]
            loose = [k.name for k in lk.links if k.name not in angles]
            raise LinkageError(
                f"the linkage {lk.name!r} cannot be closed as a sequence of dyads: joints {missing} and links {loose} "
                "stay unknown after the drives, walks along known links and the dyads (two links between known "
                "joints, a link and a guide) are used up; a class-III group (three or more links closed only "
                "together) is not supported, and a linkage of too few drives is refused by its mobility")
        steps.append(step)
        if step.kind == "rpr":
            angles.add(step.links[0])
        else:
            points.add(step.joint)  # type: ignore[arg-type]
            angles.update(step.links)
    extra = sorted(set(branch) - used)
    if extra:
        raise LinkageError(f"linkage.assembly names joints {extra}, which close no loop: the dyads of the linkage close "
                           f"at {sorted(used) or 'no joint'}")
    return tuple(steps)


# --- loading from TOML ---------------------------------------------------------------------
_KINDS = ("crank", "ground", "pin", "slider")
_META = {"printed", "source", "reason", "alternative", "unit", "read_as"}


def _number(where: str, value: Any, rule: str, resolve: Callable[[str], Any]) -> float:
    if isinstance(value, str):
        try:
            value = resolve(value)
        except FivebarError as exc:
            raise LinkageError(f"{where} = {value!r}: {exc}") from None
    text = {"pos": "a positive number", "nonneg": "a number >= 0", "real": "a finite number",
            "posint": "a positive integer"}[rule]
    bad = LinkageError(f"{where} = {value!r} is not allowed: it must be {text}")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise bad
    if rule == "posint":
        if value != int(value) or value < 1:
            raise bad
        return int(value)
    if (rule == "pos" and value <= 0) or (rule == "nonneg" and value < 0):
        raise bad
    return float(value)


def _table(where: str, value: Any) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise LinkageError(f"{where} = {value!r} is not allowed: it must be a table")
    return value


def _unknown_keys(where: str, entry: Mapping[str, Any], allowed: set[str]) -> None:
    extra = sorted(set(entry) - allowed - _META)
    if extra:
        raise LinkageError(f"{where}: unknown entries {extra}; allowed are {sorted(allowed)}")


def _point(where: str, at: Any, resolve) -> tuple[float, float]:
    if not isinstance(at, list) or len(at) != 2:
        raise LinkageError(f"{where} = {at!r} is not allowed: give the ground coordinates [x, y] (m)")
    return tuple(_number(f"{where}[{i}]", v, "real", resolve) for i, v in enumerate(at))  # type: ignore[return-value]


def _fourier(where: str, fourier: Any, resolve) -> tuple[tuple[float, float], ...]:
    if not isinstance(fourier, list) or not all(isinstance(p, list) and len(p) == 2 for p in fourier):
        raise LinkageError(f"{where} = {fourier!r} is not allowed: give [[a1, b1], [a2, b2], ...]")
    return tuple((_number(f"{where}[{k}][0]", a, "real", resolve), _number(f"{where}[{k}][1]", b, "real", resolve))
                 for k, (a, b) in enumerate(fourier))


def _crank(where: str, name: str, e: Mapping[str, Any], resolve, motors: tuple[str, ...]) -> Joint:
    at = _point(f"{where}.at", e.get("at"), resolve)
    motor = e.get("motor")
    if motor is not None and motor not in motors:
        raise LinkageError(f"{where}.motor = {motor!r} is not allowed: use one of {list(motors)} or leave it out")
    drive = Drive(
        theta0=_number(f"{where}.theta0", e.get("theta0", 0.0), "real", resolve),
        ratio=_number(f"{where}.ratio", e.get("ratio", 1.0), "pos", resolve),
        fourier=_fourier(f"{where}.fourier", e.get("fourier", []), resolve),
    )
    return Joint(name, "crank", at=at, motor=motor, drive=drive)


def _link(where: str, name: str, e: Mapping[str, Any], resolve, section: Section, material: Material,
          general: bool) -> Link:
    allowed = {"start", "end", "length", "elements", "section", "material"} | ({"rigid", "weld"} if general else set())
    _unknown_keys(where, e, allowed)
    sec, mat = section, material
    if "section" in e:
        d = _table(f"{where}.section", e["section"])
        _unknown_keys(f"{where}.section", d, {"width", "thickness", "bending_depth"})
        sec = Section(*(_number(f"{where}.section.{k}", d.get(k, getattr(section, k)), "pos", resolve)
                        for k in ("width", "thickness", "bending_depth")))
    if "material" in e:
        d = _table(f"{where}.material", e["material"])
        _unknown_keys(f"{where}.material", d, {"rho", "E"})
        mat = Material(*(_number(f"{where}.material.{k}", d.get(k, getattr(material, k)), "pos", resolve)
                         for k in ("rho", "E")))
    if "length" not in e:
        raise LinkageError(f"{where}.length is missing: it must be a positive number (m)")
    rigid = e.get("rigid", False)
    if not isinstance(rigid, bool):
        raise LinkageError(f"{where}.rigid = {rigid!r} is not allowed: use true or false")
    weld = None
    if "weld" in e:
        w = _table(f"{where}.weld", e["weld"])
        _unknown_keys(f"{where}.weld", w, {"link", "angle"})
        if not isinstance(w.get("link"), str):
            raise LinkageError(f"{where}.weld.link = {w.get('link')!r} is not allowed: name the link it is welded to")
        weld = (w["link"], _number(f"{where}.weld.angle", w.get("angle", 0.0), "real", resolve))
    return Link(
        name, e.get("start"), e.get("end"),  # type: ignore[arg-type]
        length=_number(f"{where}.length", e["length"], "pos", resolve),
        elements=_number(f"{where}.elements", e.get("elements", 1), "posint", resolve),  # type: ignore[arg-type]
        section=sec, material=mat, rigid=rigid, weld=weld,
    )


def linkage_from_toml(
    doc: Mapping[str, Any],
    resolve: Callable[[str], Any],
    section: Section,
    material: Material,
    motors: tuple[str, ...] = (),
) -> Linkage:
    """Build and validate a :class:`Linkage` from a parsed ``[linkage]`` table.

    ``resolve(key)`` returns the value of a flat parameter entry named by a string (it raises
    for an unknown key); ``section`` and ``material`` are the defaults of links that give none;
    ``motors`` the motor sections a crank may name.

    Raises
    ------
    LinkageError
        For a missing, unknown or invalid entry, a joint that names no link or a link that names
        no joint, a mobility (Gruebler) other than the number of driven inputs, a linkage that is
        not a sequence of dyads, or an assembly branch that is missing or names the wrong
        joints; the message names the entry and the reason.
    """
    doc = _table("linkage", doc)
    if "chain" in doc:
        lk = _chain_form(doc, resolve, section, material, motors)
    else:
        lk = _general_form(doc, resolve, section, material, motors)
    _check_structure(lk)
    return lk


def _check_structure(lk: Linkage) -> None:
    """The checks of both forms: drives, mobility, welds, rigid links, the plan."""
    inputs = lk.inputs
    if not 1 <= len(inputs) <= 2:
        raise LinkageError(f"the linkage {lk.name!r} has {len(inputs)} driven inputs: give one or two (a crank, or a "
                           "slider with a drive)")
    m, n, jr, jp = _gruebler(lk)
    if m != len(inputs):
        raise LinkageError(
            f"the linkage {lk.name!r} has mobility {m} (Gruebler: 3 (n - 1) - 2 (j_R + j_P) = 3 x ({n} - 1) - 2 x "
            f"({jr} + {jp}), with n = {n} bodies counting the ground and the slider blocks, j_R = {jr} revolutes, "
            f"j_P = {jp} prismatic joints) but {len(inputs)} driven input(s) ({', '.join(j.name for j in inputs)}): "
            "the mobility must be the number of driven inputs")
    for k in lk.links:
        if k.rigid:
            at = [j for j in (k.start, k.end) if lk.joint(j).kind == "crank"]
            if not at or len(lk.links_at(at[0])) != 1 or k.weld is not None or any(
                    x.weld and x.weld[0] == k.name for x in lk.links):
                raise LinkageError(
                    f"linkage.links.{k.name}.rigid = true is not allowed: only a driven crank, alone at its crank "
                    "joint and welded to nothing, may be rigid (its far joint then follows the drive; another rigid "
                    "body would need rigid-body coordinates of its own, which the model does not have)")
            if lk.joint(at[0]).motor:
                raise LinkageError(f"linkage.links.{k.name}.rigid = true is not allowed: its crank {at[0]} names a "
                                   "motor, whose shaft twists the crank's root: a motor-driven crank is flexible")
    lk.plan  # noqa: B018 - raises for a linkage that is not a sequence of dyads


def _general_form(doc, resolve, section, material, motors) -> Linkage:
    _unknown_keys("linkage", doc, {"name", "assembly", "links", "joints"})
    for key in ("links", "joints"):
        if key not in doc:
            raise LinkageError(f"linkage.{key} is missing")
    jdoc = _table("linkage.joints", doc["joints"])
    ldoc = _table("linkage.links", doc["links"])
    if not jdoc or not ldoc:
        raise LinkageError("linkage.links and linkage.joints must each name at least one entry")
    links = []
    for name, e in ldoc.items():
        where = f"linkage.links.{name}"
        e = _table(where, e)
        lnk = _link(where, name, e, resolve, section, material, general=True)
        for end in ("start", "end"):
            j = getattr(lnk, end)
            if not isinstance(j, str) or j not in jdoc:
                raise LinkageError(f"{where}.{end} = {j!r} names no joint of linkage.joints: its joints are {sorted(jdoc)}")
        if lnk.start == lnk.end:
            raise LinkageError(f"{where}: start = end = {lnk.start!r} is not allowed: a link joins two joints")
        links.append(lnk)
    names = [k.name for k in links]
    for k in links:
        if k.weld is not None:
            base = k.weld[0]
            if base not in names or base == k.name:
                raise LinkageError(f"linkage.links.{k.name}.weld.link = {base!r} names no other link: its links are {names}")
            b = links[names.index(base)]
            if not {k.start, k.end} & {b.start, b.end}:
                raise LinkageError(f"linkage.links.{k.name}.weld: {k.name} ({k.start}-{k.end}) and {base} "
                                   f"({b.start}-{b.end}) have no joint in common, where a weld would join them")
    joints = []
    for name, e in jdoc.items():
        where = f"linkage.joints.{name}"
        e = _table(where, e)
        kind = e.get("kind")
        if kind not in _KINDS:
            raise LinkageError(f"{where}.kind = {kind!r} is not allowed: use one of {list(_KINDS)}")
        if not any(name in (k.start, k.end) for k in links):
            raise LinkageError(f"{where} names no body: no link starts or ends at {name}, and a joint joins bodies "
                               "(give the links that meet there, or remove the joint)")
        if kind == "crank":
            _unknown_keys(where, e, {"kind", "at", "motor", "theta0", "ratio", "fourier"})
            joints.append(_crank(where, name, e, resolve, motors))
        elif kind == "ground":
            _unknown_keys(where, e, {"kind", "at"})
            joints.append(Joint(name, kind, at=_point(f"{where}.at", e.get("at"), resolve)))
        elif kind == "pin":
            _unknown_keys(where, e, {"kind", "mass"})
            joints.append(Joint(name, kind, mass=_number(f"{where}.mass", e.get("mass", 0.0), "nonneg", resolve)))
        else:
            _unknown_keys(where, e, {"kind", "mass", "guide", "drive"})
            g = _table(f"{where}.guide", e.get("guide"))
            if "link" in g:
                _unknown_keys(f"{where}.guide", g, {"link"})
                if g["link"] not in names:
                    raise LinkageError(f"{where}.guide.link = {g['link']!r} names no link: its links are {names}")
                if name in (links[names.index(g["link"])].start, links[names.index(g["link"])].end):
                    raise LinkageError(f"{where}.guide.link = {g['link']!r} is not allowed: the slider {name} is a joint "
                                       "of that link; it must slide on another body's link")
                guide = Guide(link=g["link"])
            else:
                _unknown_keys(f"{where}.guide", g, {"at", "angle"})
                guide = Guide(at=_point(f"{where}.guide.at", g.get("at"), resolve),
                              angle=_number(f"{where}.guide.angle", g.get("angle", 0.0), "real", resolve))
            drive = None
            if "drive" in e:
                d = _table(f"{where}.drive", e["drive"])
                _unknown_keys(f"{where}.drive", d, {"s0", "fourier"})
                if guide.link is not None:
                    raise LinkageError(f"{where}.drive is not allowed: a driven slider moves on a ground guide "
                                       "(guide = { at = [x, y], angle = a })")
                drive = Drive(theta0=_number(f"{where}.drive.s0", d.get("s0", 0.0), "real", resolve), ratio=0.0,
                              fourier=_fourier(f"{where}.drive.fourier", d.get("fourier", []), resolve))
            joints.append(Joint(name, kind, mass=_number(f"{where}.mass", e.get("mass", 0.0), "nonneg", resolve),
                                guide=guide, drive=drive))
    assembly = _assembly(doc.get("assembly", []), [j.name for j in joints])
    return Linkage(str(doc.get("name", "")), tuple(links), tuple(joints), assembly)


def _assembly(value: Any, joints: list[str]) -> tuple[Assembly, ...]:
    entries = [value] if isinstance(value, Mapping) else value
    if not isinstance(entries, list):
        raise LinkageError(f"linkage.assembly = {value!r} is not allowed: give a table or a list of tables "
                           "{ joint, side, line }")
    out = []
    for i, a in enumerate(entries):
        where = f"linkage.assembly[{i}]"
        a = _table(where, a)
        _unknown_keys(where, a, {"joint", "side", "line"})
        if a.get("joint") not in joints:
            raise LinkageError(f"{where}.joint = {a.get('joint')!r} is not allowed: use one of the joints {joints}")
        if a.get("side") not in ("left", "right", "ahead", "behind"):
            raise LinkageError(f"{where}.side = {a.get('side')!r} is not allowed: use 'left' or 'right' (two links "
                               "meeting at the joint) or 'ahead' or 'behind' (a slider)")
        line = a.get("line")
        if line is not None and (not isinstance(line, list) or len(line) != 2 or not all(x in joints for x in line)):
            raise LinkageError(f"{where}.line = {line!r} is not allowed: give two joints [from, to]")
        out.append(Assembly(a["joint"], a["side"], None if line is None else tuple(line)))
    if len({a.joint for a in out}) != len(out):
        raise LinkageError("linkage.assembly names a joint twice: give one branch per joint")
    return tuple(out)


def _chain_form(doc, resolve, section, material, motors) -> Linkage:
    """The single-loop chain form (the paper's five-bar, the four-bar)."""
    _unknown_keys("linkage", doc, {"name", "chain", "assembly", "links", "joints"})
    for key in ("chain", "assembly", "links", "joints"):
        if key not in doc:
            raise LinkageError(f"linkage.{key} is missing")
    chain = doc["chain"]
    if (not isinstance(chain, list) or len(chain) < 4 or not all(isinstance(c, str) for c in chain)
            or len(set(chain)) != len(chain)):
        raise LinkageError(
            f"linkage.chain = {chain!r} is not allowed: give the names of at least 4 distinct joints around "
            "the loop, from one ground pivot to the other"
        )
    chain = tuple(chain)
    jdoc = _table("linkage.joints", doc["joints"])
    if set(jdoc) != set(chain):
        raise LinkageError(
            f"linkage.joints {sorted(jdoc)} must be exactly the joints of linkage.chain {list(chain)}"
        )
    joints: dict[str, Joint] = {}
    for pos, name in enumerate(chain):
        where = f"linkage.joints.{name}"
        e = _table(where, jdoc[name])
        kind = e.get("kind")
        ends = pos in (0, len(chain) - 1)
        allowed_kinds = ("crank", "ground") if ends else ("pin",)
        if kind not in allowed_kinds:
            place = "an end of the chain (on the ground)" if ends else "inside the chain (between two links)"
            raise LinkageError(f"{where}.kind = {kind!r} is not allowed: a joint at {place} is one of {list(allowed_kinds)}")
        if kind == "pin":
            _unknown_keys(where, e, {"kind", "mass"})
            joints[name] = Joint(name, kind, mass=_number(f"{where}.mass", e.get("mass", 0.0), "nonneg", resolve))
            continue
        if kind == "ground":
            _unknown_keys(where, e, {"kind", "at"})
            joints[name] = Joint(name, kind, at=_point(f"{where}.at", e.get("at"), resolve))
            continue
        _unknown_keys(where, e, {"kind", "at", "motor", "theta0", "ratio", "fourier"})
        joints[name] = _crank(where, name, e, resolve, motors)

    ldoc = _table("linkage.links", doc["links"])
    if len(ldoc) != len(chain) - 1:
        raise LinkageError(
            f"linkage.links has {len(ldoc)} links, but the chain {list(chain)} needs {len(chain) - 1} (one between "
            "each pair of neighbours)"
        )
    by_pair: dict[frozenset, Link] = {}
    for name, e in ldoc.items():
        where = f"linkage.links.{name}"
        e = _table(where, e)
        _unknown_keys(where, e, {"start", "end", "length", "elements", "section", "material"})
        s, t = e.get("start"), e.get("end")
        pair = frozenset((s, t))
        ok = any(pair == frozenset(chain[i:i + 2]) for i in range(len(chain) - 1))
        if not ok or s == t:
            raise LinkageError(
                f"{where}: start = {s!r}, end = {t!r} is not allowed: a link joins two neighbours of linkage.chain {list(chain)}"
            )
        if pair in by_pair:
            raise LinkageError(f"{where} joins {s} and {t}, as link {by_pair[pair].name!r} does already")
        by_pair[pair] = _link(where, name, e, resolve, section, material, general=False)
    links = tuple(by_pair[frozenset(chain[i:i + 2])] for i in range(len(chain) - 1))

    cranks = [j for j in (joints[chain[0]], joints[chain[-1]]) if j.kind == "crank"]
    if len(links) - len(cranks) != 2:
        raise LinkageError(
            f"the linkage has {len(links)} links and {len(cranks)} driven cranks: a single loop is driven by "
            f"{len(links) - 2} cranks (links - 2), so that the two other links close it"
        )
    a = _table("linkage.assembly", doc["assembly"])
    _unknown_keys("linkage.assembly", a, {"joint", "side"})
    aj, side = a.get("joint"), a.get("side")
    if side not in ("left", "right"):
        raise LinkageError(f"linkage.assembly.side = {side!r} is not allowed: use 'left' or 'right'")
    if aj not in chain[1:-1]:
        raise LinkageError(f"linkage.assembly.joint = {aj!r} is not allowed: use one of the pins {list(chain[1:-1])}")
    i = chain.index(aj)
    driven = {0} if joints[chain[0]].kind == "crank" else set()
    if joints[chain[-1]].kind == "crank":
        driven.add(len(links) - 1)
    free = [k for k in range(len(links)) if k not in driven]
    if free != [i - 1, i]:
        raise LinkageError(
            f"linkage.assembly.joint = {aj!r} is not allowed: it must be the pin between the two undriven links "
            f"({', '.join(links[k].name for k in free)})"
        )
    return Linkage(str(doc.get("name", "")), links, tuple(joints[c] for c in chain),
                   (Assembly(aj, side, (chain[i - 1], chain[i + 1])),), chain)
