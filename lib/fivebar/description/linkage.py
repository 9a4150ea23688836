r"""The linkage description: links, joints, lumped masses, drives and the assembly mode.

A single-loop planar linkage of revolute joints is written as data, the ``[linkage]`` section
of a parameter file:

.. code-block:: toml

    [linkage]
    name = "four-bar crank-rocker"
    chain = ["A", "B", "C", "D"]            # the loop, from one ground pivot to the other
    assembly = { joint = "C", side = "left" }

    [linkage.links]                          # in the order of the chain
    crank = { start = "A", end = "B", length = 0.10, elements = 1 }
    coupler = { start = "B", end = "C", length = 0.35, elements = 2 }
    rocker = { start = "D", end = "C", length = 0.30, elements = 2 }

    [linkage.joints]
    A = { kind = "crank", at = [0.0, 0.0], theta0 = 0.0, ratio = 1.0 }
    B = { kind = "pin", mass = 0.142 }
    C = { kind = "pin", mass = 0.092 }
    D = { kind = "ground", at = [0.4, 0.0] }

* ``chain`` lists the joints around the loop; the frame (ground) closes it from the last joint
  back to the first.  The first and last joints are on the ground (``kind = "crank"``, a
  driven crank, or ``"ground"``, a ground pin, each with its coordinates ``at`` in m); every
  other joint is a ``"pin"`` between two links.
* A link joins two neighbours of the chain, in either direction: its angle is that of the
  vector from ``start`` to ``end``.  ``length`` (m), ``elements`` (beam elements in the default
  mesh), and optionally its own ``section = {width, thickness, bending_depth}`` (m) and
  ``material = {rho, E}`` (kg/m^3, Pa); without them the link takes the parameter file's
  ``[geometry]`` width and thickness, ``assumptions.bending_depth`` and ``[material]``.
* A driven crank has a drive law: the angle of the crank link is
  :math:`\theta(t) = \theta_0 + r\,\Omega t + \sum_k a_k\cos k\Omega t + b_k\sin k\Omega t` with
  the crank speed :math:`\Omega` of the parameter file, its ``ratio`` :math:`r` and an optional
  Fourier series ``fourier = [[a1, b1], [a2, b2], ...]`` (rad); in Python any periodic law can
  be given as a function (:class:`Drive`).  ``motor`` names the motor section (``"motor1"``)
  whose shaft drives it, if any.
* ``mass`` (kg) is a lumped mass at a pin.
* ``assembly``: of the two configurations that close the loop, the one with ``joint`` (the pin
  between the two links the drives do not fix) on the ``side`` ("left" or "right") of the
  directed line from its predecessor to its successor in the chain.

Any number may instead be the dotted key of a flat entry of the parameter file
(``length = "geometry.L1"``): the description then uses that entry, with its provenance, and
``Params.replace`` of that entry moves the linkage.  The mobility must be the number of drives
(links - drives = 2), and the two undriven links must meet at a pin.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FivebarError, InputError, ParameterError

__all__ = ["Drive", "Joint", "Link", "Linkage", "LinkageError", "Material", "Section", "linkage_from_toml"]


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
    """A link from joint ``start`` to joint ``end`` (its angle is that of ``end - start``)."""

    name: str
    start: str
    end: str
    length: float
    elements: int
    section: Section
    material: Material


@dataclass(frozen=True)
class Drive:
    r"""The law of a driven crank.

    :math:`\theta(t) = \theta_0 + r\Omega t + \sum_k (a_k\cos k\Omega t + b_k\sin k\Omega t)`
    with ``fourier = ((a1, b1), (a2, b2), ...)``, or, when ``function`` is given,
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
        """(theta, omega, alpha) of the crank at times ``t`` (s) for crank speed ``speed`` (rad/s)."""
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
class Joint:
    """A joint: ``kind`` "crank" (driven, on the ground), "ground" (a ground pin) or "pin"
    (between two links); ``at`` the ground coordinates (m), ``motor`` the motor section that
    drives a crank (or None), ``drive`` its law, ``mass`` a lumped mass (kg)."""

    name: str
    kind: str
    at: tuple[float, float] | None = None
    motor: str | None = None
    drive: Drive | None = None
    mass: float = 0.0


@dataclass(frozen=True)
class Linkage:
    """A single-loop planar linkage of revolute joints (see the module text for the TOML).

    ``links`` are in the order of the chain; ``chain`` lists the joints around the loop.
    """

    name: str
    chain: tuple[str, ...]
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    assembly_joint: str
    assembly_side: str

    # --- derived views ---------------------------------------------------------------------
    def joint(self, name: str) -> Joint:
        """The joint called ``name``."""
        for j in self.joints:
            if j.name == name:
                return j
        raise LinkageError(f"no joint {name!r} in the linkage: its joints are {list(self.chain)}")

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
        """The links in the order of the chain."""
        return tuple(k.name for k in self.links)

    @property
    def lengths(self) -> tuple[float, ...]:
        """Link lengths (m) in the order of the chain, then the frame (the ground pivots'
        distance)."""
        a, b = (np.asarray(j.at) for j in self.ground)
        return (*(k.length for k in self.links), float(np.hypot(*(b - a))))

    @property
    def ground(self) -> tuple[Joint, Joint]:
        """The first and last joints of the chain (both on the ground)."""
        return self.joint(self.chain[0]), self.joint(self.chain[-1])

    @property
    def cranks(self) -> tuple[Joint, ...]:
        """The driven cranks' joints, in the order of the chain (their angles are the
        configuration's coordinates: ``theta`` arguments come in this order)."""
        return tuple(j for j in self.ground if j.kind == "crank")

    def crank_link(self, joint: str) -> Link:
        """The link that turns about the ground joint ``joint``."""
        return self.links[0] if joint == self.chain[0] else self.links[-1]

    @property
    def motors(self) -> tuple[tuple[str, str], ...]:
        """(crank joint, motor section) of every crank driven by a motor, in chain order."""
        return tuple((j.name, j.motor) for j in self.cranks if j.motor)

    def chain_sign(self, k: int) -> float:
        """+1 if link ``k`` (chain order) points along the chain, -1 if against it."""
        return 1.0 if self.links[k].start == self.chain[k] else -1.0

    @property
    def unknown(self) -> tuple[int, int]:
        """Chain indices of the two links the drives do not fix (they meet at the assembly joint)."""
        i = self.chain.index(self.assembly_joint)
        return i - 1, i

    @property
    def masses(self) -> dict[str, float]:
        """Pin -> lumped mass (kg) of every pin that carries a ``mass`` entry."""
        return {j.name: j.mass for j in self.joints if j.kind == "pin"}

    @property
    def couplers(self) -> tuple[str, ...]:
        """The links between two pins (for the five-bar L2 and L3, whose midpoints Figure 6 shows)."""
        return tuple(k.name for k in self.links if _between_pins(self, k))

    @property
    def default_mesh(self) -> tuple[int, ...]:
        """Elements per link of the description (chain order)."""
        return tuple(k.elements for k in self.links)

    def check_mesh(self, elements_per_link: Any, even: bool = False) -> tuple[int, ...]:
        """Validate a mesh (one integer >= 1 per link, chain order; ``None`` is the
        description's own); ``even`` asks for even numbers on the links between two pins."""
        if elements_per_link is None:
            return self.default_mesh
        n = len(self.links)
        try:
            epl = tuple(elements_per_link)
            ok = len(epl) == n and all(not isinstance(k, bool) and int(k) == k and k >= 1 for k in epl)
        except (TypeError, ValueError):
            ok = False
        names = ", ".join(self.link_names)
        if not ok:
            raise InputError(
                f"elements_per_link = {elements_per_link!r} is not allowed: give {n} integers >= 1 "
                f"(elements on {names})"
            )
        epl = tuple(int(k) for k in epl)
        if even:
            odd = [k.name for k, e in zip(self.links, epl) if e % 2 and _between_pins(self, k)]
            if odd:
                raise InputError(
                    f"elements_per_link = {elements_per_link!r} is not allowed: give {n} positive integers "
                    f"({names}) with even numbers on the links between two pins ({', '.join(odd)} has an odd number)"
                )
        return epl


def _between_pins(lk: Linkage, link: Link) -> bool:
    return all(lk.joint(j).kind == "pin" for j in (link.start, link.end))


# --- loading from TOML ---------------------------------------------------------------------
_KINDS = ("crank", "ground", "pin")


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
    extra = sorted(set(entry) - allowed - {"printed", "source", "reason", "alternative", "unit", "read_as"})
    if extra:
        raise LinkageError(f"{where}: unknown entries {extra}; allowed are {sorted(allowed)}")


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
        For a missing, unknown or invalid entry, a chain that is not a single loop, a mobility
        other than the number of drives, or an assembly joint that is not the pin between the
        two undriven links; the message names the entry.
    """
    doc = _table("linkage", doc)
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
        keys = {"kind", "at"} | ({"motor", "theta0", "ratio", "fourier"} if kind == "crank" else set())
        _unknown_keys(where, e, keys)
        at = e.get("at")
        if not isinstance(at, list) or len(at) != 2:
            raise LinkageError(f"{where}.at = {at!r} is not allowed: give the ground coordinates [x, y] (m)")
        xy = tuple(_number(f"{where}.at[{i}]", v, "real", resolve) for i, v in enumerate(at))
        if kind == "ground":
            joints[name] = Joint(name, kind, at=xy)  # type: ignore[arg-type]
            continue
        motor = e.get("motor")
        if motor is not None and motor not in motors:
            raise LinkageError(f"{where}.motor = {motor!r} is not allowed: use one of {list(motors)} or leave it out")
        fourier = e.get("fourier", [])
        if not isinstance(fourier, list) or not all(isinstance(p, list) and len(p) == 2 for p in fourier):
            raise LinkageError(f"{where}.fourier = {fourier!r} is not allowed: give [[a1, b1], [a2, b2], ...] (rad)")
        drive = Drive(
            theta0=_number(f"{where}.theta0", e.get("theta0", 0.0), "real", resolve),
            ratio=_number(f"{where}.ratio", e.get("ratio", 1.0), "pos", resolve),
            fourier=tuple((_number(f"{where}.fourier[{k}][0]", a, "real", resolve),
                           _number(f"{where}.fourier[{k}][1]", b, "real", resolve)) for k, (a, b) in enumerate(fourier)),
        )
        joints[name] = Joint(name, kind, at=xy, motor=motor, drive=drive)  # type: ignore[arg-type]

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
        by_pair[pair] = Link(
            name, s, t,
            length=_number(f"{where}.length", e["length"], "pos", resolve),
            elements=_number(f"{where}.elements", e.get("elements", 1), "posint", resolve),  # type: ignore[arg-type]
            section=sec, material=mat,
        )
    links = tuple(by_pair[frozenset(chain[i:i + 2])] for i in range(len(chain) - 1))
    for k, lk in ((0, links[0]), (-1, links[-1])):
        j = joints[chain[k]]
        if j.kind == "crank" and j.name not in (lk.start, lk.end):  # pragma: no cover - guaranteed by the chain
            raise LinkageError(f"crank {j.name} does not carry link {lk.name}")

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
    return Linkage(str(doc.get("name", "")), chain, links, tuple(joints[c] for c in chain), aj, side)
