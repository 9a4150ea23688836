"""Parameters of the five-bar linkage: loading, validation and overrides.

The paper's numbers (section 5) and the project's assumptions for the numbers it lacks live in
``data/wang2011.toml``.  :func:`load_params` reads that file (and optionally further files
layered over it), checks every entry and returns a frozen :class:`Params`.  Values are SI
inside the library; the only exception is ``crank_speed_rpm``, kept in r/min because that is
how people state it (``Params.crank_speed_rad_s`` gives rad/s).

The sections ``[geometry]`` and ``[masses]`` are open: their entries are the numbers the
linkage description refers to (``length = "geometry.L1"``), so their names are the file's own.
An entry that nothing refers to is refused with the nearest known name (``L22 = 0.3``: "did
you mean 'geometry.L2'?"), unless it comes from a file whose own ``[linkage]`` a later file
replaced (the paper's L1..L5 under the four-bar's description) or it is declared free, a
number kept for the reader's own use: ``bracket = { value = 0.05, free = true }``.
"""

from __future__ import annotations

import difflib
import math
import re
import warnings
from importlib import resources
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields, replace
from fractions import Fraction
from pathlib import Path
from typing import Any

from ..errors import FivebarError, ParameterError, ValidityWarning, plain, read_toml
from .linkage import Linkage, Material, Section, linkage_from_toml

__all__ = ["Motor", "Motors", "Params", "load_params", "file_entries", "unused_entry", "DEFAULT_PARAMS_PATH",
           "FOURBAR_PARAMS_PATH", "SIXBAR_PARAMS_PATH", "SLIDER_CRANK_PARAMS_PATH", "MOTOR_ONLY"]

#: The parameter file shipped with the package (``fivebar/data/wang2011.toml``, package data
#: read through ``importlib.resources``; ``data/wang2011.toml`` of the repository links to it).
#:
#: :meta hide-value:
DEFAULT_PARAMS_PATH = Path(str(resources.files("fivebar") / "data" / "wang2011.toml"))
#: A four-bar crank-rocker's description, to layer over the defaults:
#: ``load_params([DEFAULT_PARAMS_PATH, FOURBAR_PARAMS_PATH])`` (``fivebar/data/fourbar.toml``).
#:
#: :meta hide-value:
FOURBAR_PARAMS_PATH = Path(str(resources.files("fivebar") / "data" / "fourbar.toml"))
#: The flexible slider-crank of Simeon's benchmark (the IVP test set's problem "crank"), to layer
#: over the defaults: ``load_params([DEFAULT_PARAMS_PATH, SLIDER_CRANK_PARAMS_PATH])``
#: (``fivebar/data/slider_crank.toml``).
#:
#: :meta hide-value:
SLIDER_CRANK_PARAMS_PATH = Path(str(resources.files("fivebar") / "data" / "slider_crank.toml"))
#: A Watt six-bar (two four-bars in series through a bell crank), to layer over the defaults:
#: ``load_params([DEFAULT_PARAMS_PATH, SIXBAR_PARAMS_PATH])`` (``fivebar/data/sixbar.toml``).
#:
#: :meta hide-value:
SIXBAR_PARAMS_PATH = Path(str(resources.files("fivebar") / "data" / "sixbar.toml"))


# --- the schema: dotted TOML key -> (rule, unit) ---------------------------------------------
# rules: "pos" > 0, "nonneg" >= 0, "real" any finite number, "posint" integer > 0,
# "frac" 0 <= x < 1, "slip" 0 < x < 1, "flag" 0 or 1, ("choice", (...)) one of the strings.
_MOTOR_KEYS = {
    "rated_power": ("pos", "W"), "rated_voltage": ("pos", "V"), "rated_speed": ("pos", "rad/s"),
    "e0": ("nonneg", "m"), "eps0": ("nonneg", "m"), "mu0": ("pos", "H/m"),
    "delta0": ("pos", "m"), "k_mu": ("pos", "-"), "W": ("posint", "-"), "K_w": ("pos", "-"),
    "I": ("pos", "A"), "p": ("posint", "-"), "m1": ("pos", "-"), "m2": ("pos", "-"),
    "x_m": ("pos", "ohm"), "r_prime": ("pos", "ohm"), "x_prime": ("nonneg", "ohm"),
    "s": ("slip", "-"), "U_k": ("nonneg", "V"), "m0": ("pos", "kg"), "J0": ("pos", "kg m^2"),
    "l1": ("pos", "m"), "l2": ("pos", "m"), "l3": ("pos", "m"), "L01": ("pos", "m"),
    "R01": ("pos", "m"),
}
_OPTIONAL_MOTOR_KEYS = {"stall_torque": ("pos", "N m"), "rated_current": ("pos", "A")}
#: A motor section is ``[motor<k>]`` (any number of them; a crank of the linkage names the one
#: that drives it), its shaft diameter the entry ``assumptions.shaft_diameter_<k>``.
_MOTOR_SECTION = re.compile(r"motor(\d+)")
_SHAFT_DIAMETER = re.compile(r"assumptions\.shaft_diameter_(\d+)")

_SCHEMA: dict[str, tuple[Any, str]] = {
    "geometry.width": ("pos", "m"),
    "geometry.thickness": ("pos", "m"),
    "material.rho": ("pos", "kg/m^3"),
    "material.E": ("pos", "Pa"),
    "simulation.theta1_0": ("real", "rad"),
    "simulation.theta4_0": ("real", "rad"),
    "simulation.newmark_sigma": ("real", "-"),
    "simulation.newmark_theta": ("real", "-"),
    "simulation.steps_per_period": ("posint", "-"),
    "simulation.scheme": (("choice", ("generalized-alpha", "newmark")), "-"),
    "simulation.rho_infinity": ("unit", "-"),
    "assumptions.crank_speed_rpm": ("pos", "r/min"),
    "assumptions.speed_ratio": ("pos", "-"),
    "assumptions.bending_depth": ("pos", "m"),
    "assumptions.rotary_inertia": ("flag", "-"),
    "assumptions.damping_ratio": ("frac", "-"),
    "assumptions.gravity": ("nonneg", "m/s^2"),
    "assumptions.fourier_terms": ("posint", "-"),
    "assumptions.supply_frequency": ("pos", "Hz"),
    "assumptions.phase_phi10": ("real", "rad"),
    "assumptions.phase_phi20": ("real", "rad"),
    "assumptions.static_eccentricity_angle": ("real", "rad"),
    "assumptions.shaft_E": ("pos", "Pa"),
    "assumptions.shaft_G": ("pos", "Pa"),
    "assumptions.shaft_rho": ("pos", "kg/m^3"),
    "assumptions.gap_flux_density": ("pos", "T"),
    "assumptions.em_variant": (("choice", ("calibrated", "literal")), "-"),
    "assumptions.eccentricity_scale": ("nonneg", "-"),
    "assumptions.yield_stress": ("pos", "Pa"),
    "assumptions.buckling_length_factor": ("pos", "-"),
    "assumptions.strain_measure": (("choice", ("uniform", "corotated", "literal")), "-"),
    "assumptions.damping_model": (("choice", ("modal", "stiffness")), "-"),
}
_ALL_KEYS = dict(_SCHEMA)
#: the assumptions that only the motor elements use (the field, the rotors' eccentricity and
#: whirl, the shafts): a linkage without motors does not use them
MOTOR_ONLY = frozenset({
    "assumptions.supply_frequency", "assumptions.phase_phi10", "assumptions.phase_phi20",
    "assumptions.static_eccentricity_angle", "assumptions.shaft_E", "assumptions.shaft_G",
    "assumptions.shaft_rho", "assumptions.gap_flux_density", "assumptions.em_variant",
    "assumptions.eccentricity_scale"})
#: sections whose entries are free names (the numbers a linkage description refers to)
_OPEN = {"geometry": ("pos", "m"), "masses": ("nonneg", "kg")}

_RULE_TEXT = {
    "pos": "a positive number",
    "nonneg": "a number >= 0",
    "real": "a finite number",
    "posint": "a positive integer",
    "frac": "a number in [0, 1)",
    "unit": "a number in [0, 1]",
    "slip": "a number in (0, 1)",
    "flag": "0 or 1",
}


def _describe(rule: Any, unit: str) -> str:
    text = f"one of {list(rule[1])}" if isinstance(rule, tuple) else _RULE_TEXT[rule]
    return text if unit == "-" else f"{text} ({unit})"


def _motor_rule(key: str) -> tuple[Any, str] | None:
    """The rule of an entry of a motor section or of a motor's shaft diameter (None if the key is
    neither)."""
    section, _, name = key.partition(".")
    if _MOTOR_SECTION.fullmatch(section):
        return _MOTOR_KEYS.get(name) or _OPTIONAL_MOTOR_KEYS.get(name)
    if _SHAFT_DIAMETER.fullmatch(key):
        return ("pos", "m")
    return None


def _check(key: str, value: Any) -> Any:
    """Validate one entry; return it as float, int or str."""
    rule, unit = _ALL_KEYS.get(key) or _motor_rule(key) or _OPEN[key.split(".", 1)[0]]
    value = plain(value)  # NumPy numbers as Python ones
    bad = ParameterError(f"{key} = {value!r} is not allowed: it must be {_describe(rule, unit)}")
    if isinstance(rule, tuple):
        if not isinstance(value, str) or value not in rule[1]:
            raise bad
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise bad
    if not math.isfinite(value):
        raise bad
    if rule == "posint":
        if value != int(value) or value <= 0:
            raise bad
        return int(value)
    if rule == "flag":
        if value not in (0, 1):
            raise bad
        return int(value)
    ok = {
        "pos": value > 0,
        "nonneg": value >= 0,
        "real": True,
        "frac": 0 <= value < 1,
        "unit": 0 <= value <= 1,
        "slip": 0 < value < 1,
    }[rule]
    if not ok:
        raise bad
    return float(value)


@dataclass(frozen=True)
class Motor:
    """One controllable motor (section 5 and appendix (A.1)-(A.4), (A.9)-(A.10)).

    All values SI.  ``l1, l2, l3`` are the shaft segments between the element's four nodes
    (rotor at ``x = l1``); the shaft diameter and material are assumptions.
    """

    rated_power: float
    rated_voltage: float
    rated_speed: float
    e0: float
    eps0: float
    mu0: float
    delta0: float
    k_mu: float
    W: int
    K_w: float
    I: float
    p: int
    m1: float
    m2: float
    x_m: float
    r_prime: float
    x_prime: float
    s: float
    U_k: float
    m0: float
    J0: float
    l1: float
    l2: float
    l3: float
    L01: float
    R01: float
    shaft_diameter: float
    shaft_E: float
    shaft_G: float
    shaft_rho: float
    stall_torque: float | None = None
    rated_current: float | None = None

    @property
    def l(self) -> float:  # noqa: E743 - the paper's name
        """Shaft length l = l1 + l2 + l3 (m)."""
        return self.l1 + self.l2 + self.l3


class Motors(Mapping):
    """The motor sections of a parameter file: section name (``"motor1"``) -> :class:`Motor`.

    Read-only and hashable (a :class:`Params` is a cache key); a missing name raises a
    :class:`~fivebar.errors.ParameterError` that lists the sections there are.
    """

    def __init__(self, motors: Mapping[str, Motor]) -> None:
        self._items = tuple(motors.items())

    def __getitem__(self, name: str) -> Motor:
        for key, motor in self._items:
            if key == name:
                return motor
        raise ParameterError(f"motor section {name!r} is not in the parameter file: its motor sections are "
                             f"{list(self)}")

    def __contains__(self, name: object) -> bool:
        return any(key == name for key, _ in self._items)

    def get(self, name: str, default: Any = None) -> Any:
        return self[name] if name in self else default

    def __iter__(self):
        return (key for key, _ in self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __hash__(self) -> int:
        return hash(self._items)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Motors) and self._items == other._items

    def __repr__(self) -> str:
        return f"Motors({dict(self._items)!r})"


@dataclass(frozen=True)
class Params:
    """Frozen, validated parameter set of the five-bar linkage (SI units).

    Build it with :func:`load_params`; derive variants with :meth:`replace`.  ``meta`` maps
    each dotted key (``"geometry.L1"``) to its provenance from the TOML file (printed value
    and source, or the assumption's reason and alternative).  ``linkage`` is the linkage
    description (:class:`fivebar.description.linkage.Linkage`) of the ``[linkage]`` section.  The entries
    of ``[geometry]`` and ``[masses]`` that the description refers to are attributes too
    (``params.L5``, ``params.m01`` for the paper's file), and so is each link's length by the
    link's name (``params.L2``).  ``motors`` maps each motor section of the file to its
    :class:`Motor` (``params.motors["motor1"]``); :attr:`crank_motors` gives the motor of each
    crank the description drives by one.
    """

    linkage: Linkage
    width: float
    thickness: float
    rho: float
    E: float
    theta1_0: float
    theta4_0: float
    newmark_sigma: float
    newmark_theta: float
    steps_per_period: int
    scheme: str
    rho_infinity: float
    motors: Motors
    crank_speed_rpm: float
    speed_ratio: float
    bending_depth: float
    rotary_inertia: int
    damping_ratio: float
    gravity: float
    fourier_terms: int
    supply_frequency: float
    phase_phi10: float
    phase_phi20: float
    static_eccentricity_angle: float
    gap_flux_density: float
    em_variant: str
    eccentricity_scale: float
    yield_stress: float
    buckling_length_factor: float
    strain_measure: str
    damping_model: str
    values: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)
    meta: Mapping[str, Mapping[str, Any]] = field(default_factory=dict, compare=False, repr=False)
    #: the flat entries the linkage description refers to (its numbers by dotted key)
    references: frozenset[str] = field(default=frozenset(), compare=False, repr=False)

    def __getattr__(self, name: str) -> Any:
        # the free entries of [geometry] and [masses] and the links' lengths, read-only
        if name.startswith("_") or name in ("values", "meta", "linkage", "references", "motors"):
            raise AttributeError(name)
        for link in self.linkage.links:
            if link.name == name:
                return link.length
        for section in _OPEN:
            key = f"{section}.{name}"
            if key in self.references or (key in self.values and _is_free(self.meta, key)):
                return self.values[key]
        raise AttributeError(
            f"'Params' object has no attribute {name!r} (the linkage {self.linkage.name!r} has the links "
            f"{list(self.linkage.link_names)})"
        )

    # --- derived quantities ------------------------------------------------------------------
    @property
    def A(self) -> float:
        """Cross-section area of every link (m^2)."""
        return self.width * self.thickness

    @property
    def I(self) -> float:  # noqa: E743 - the paper's name
        """Second moment of area for in-plane bending (m^4): b d^3 / 12, d = bending_depth."""
        d = self.bending_depth
        return self.A / d * d**3 / 12.0

    @property
    def crank_speed_rad_s(self) -> float:
        """Speed of crank AB (rad/s)."""
        return self.crank_speed_rpm * 2.0 * math.pi / 60.0

    @property
    def turns(self) -> int:
        """Turns of the drive phase (Omega t) in one period of the motion: the least common
        denominator q of the cranks' speed ratios read as fractions p/q (1 for the paper's equal
        speeds and for any integer ratio; 2 for ``speed_ratio = 0.5``: crank AB turns twice while
        crank DE turns once).  A ratio that is no fraction of small integers gives 1 here; a
        computation in time refuses it (:func:`fivebar.description.setup.drive_period`)."""
        q = 1
        for joint in self.linkage.cranks:
            if joint.drive is not None:
                d = _ratio_fraction(joint.drive.ratio).denominator
                q = q * d // math.gcd(q, d)
        return q

    @property
    def period(self) -> float:
        """Period of the motion (s): :attr:`turns` turns of the drive phase, 2 pi q / Omega (one turn
        of crank AB for equal speeds and integer speed ratios, two for a speed ratio of 1/2)."""
        return 2.0 * math.pi * self.turns / self.crank_speed_rad_s

    @property
    def crank_motors(self) -> dict[str, Motor]:
        """Crank joint -> the :class:`Motor` that drives it, for every crank of the description
        that names a motor section, in the order of the chain (``Linkage.motors``)."""
        return {joint: self.motors[section] for joint, section in self.linkage.motors}

    @property
    def lengths(self) -> tuple[float, ...]:
        """The links' lengths in the order of the chain, then the frame's (m): (L1, ..., L5)
        for the paper's five-bar."""
        return self.linkage.lengths

    # --- variants ----------------------------------------------------------------------------
    def replace(self, **changes: Any) -> "Params":
        """Return a copy with some entries changed, validated like the file.

        Keys are dotted TOML keys (``**{"motor1.m0": 2.0}``) or bare names that are unique
        (``crank_speed_rpm=120``, ``L1=0.25``); ``linkage=`` takes a whole description (the
        ``[linkage]`` table of a file, as a dict).  A change of entries that the set only keeps in
        a field of their name (the crank speed, the damping ratio, the scheme, ...) checks those
        entries and keeps the rest of the set; any other change validates the whole set again.

        >>> p = load_params().replace(crank_speed_rpm=120)
        """
        values = dict(self.values)
        changed = []
        for key, value in changes.items():
            if key == "linkage":  # a whole description, as the [linkage] table of a file
                values["linkage"] = value
                changed.append("linkage")
                continue
            changed.append(_resolve_key(key, values))
            values[changed[-1]] = value
        if all(k in _FIELD_ONLY and k not in self.references for k in changed):
            # entries that the set holds in a field of their own and nothing else is made of
            # (a new crank speed): checked as _build checks them, the rest of the set as it is
            checked = {k: _check(k, values[k]) for k in changed}
            values.update(checked)
            return replace(self, **{k.split(".", 1)[1]: v for k, v in checked.items()}, values=values,
                           meta=dict(self.meta))
        out = _build(values, dict(self.meta))
        _refuse_unused(out, [(k, "Params.replace") for k in changed if _is_open(k)])
        return out


#: the largest denominator of a speed ratio read as a fraction, and the tolerance of that reading
RATIO_DENOMINATOR, RATIO_TOL = 1000, 1e-9


def _ratio_fraction(r: float) -> Fraction:
    """A crank's speed ratio as the fraction p/q (q <= :data:`RATIO_DENOMINATOR`) nearest to it;
    ``Fraction(0)`` when none is within :data:`RATIO_TOL` (a motion that never repeats)."""
    frac = Fraction(r).limit_denominator(RATIO_DENOMINATOR)
    return frac if abs(float(frac) - r) <= RATIO_TOL * max(1.0, abs(r)) else Fraction(0)


def _resolve_key(key: str, values: Mapping[str, Any] = {}) -> str:
    if key in _ALL_KEYS or (key.split(".", 1)[0] in _OPEN and "." in key) or _motor_rule(key):
        return key
    known = list(dict.fromkeys(list(_ALL_KEYS) + [k for k in values if _is_open(k) or _motor_rule(k)]))
    matches = [k for k in known if k.split(".", 1)[1] == key]
    if len(matches) == 1:
        return matches[0]
    if len(matches) > 1:
        raise ParameterError(f"parameter name {key!r} is ambiguous: use one of {matches}")
    raise ParameterError(
        f"unknown parameter {key!r}{_nearest(key, known)}: allowed are the dotted keys of data/wang2011.toml "
        f"(for example 'geometry.width', 'assumptions.crank_speed_rpm', or an entry of a [motor<k>] section)"
    )


def _is_open(key: str) -> bool:
    """A free-named entry of an open section ([geometry], [masses]; not one of the schema's, such
    as geometry.width): a number the description may use."""
    return "." in key and key.split(".", 1)[0] in _OPEN and key not in _ALL_KEYS


def _is_free(meta: Mapping[str, Mapping[str, Any]], key: str) -> bool:
    """An open entry declared free in its file (``{ value = ..., free = true }``)."""
    return meta.get(key, {}).get("free") is True


def _nearest(key: str, known: Iterable[str]) -> str:
    """" (did you mean 'geometry.L2'?)" for the known key nearest to ``key`` (difflib), by its
    dotted name or by its bare name; "" if none is near."""
    known = [k for k in known if "." in k]
    section, _, name = key.partition(".") if "." in key else ("", "", key)
    sections = {k.split(".", 1)[0] for k in known} | set(_OPEN)
    if section and section not in sections:  # a misspelt section: the nearest one, the same name
        near = difflib.get_close_matches(section, sorted(sections), n=1, cutoff=0.6)
        if not near:
            return ""
        guess = f"{near[0]}.{name}"
        return f" (did you mean {guess!r}?)" if guess in known or near[0] in _OPEN else \
            f" (did you mean the section [{near[0]}]?)"
    # the names of the same section (L22 -> L2, not geometry.L22 -> geometry.L5), or of any
    same = {k.split(".", 1)[1]: k for k in known if not section or k.split(".", 1)[0] == section}
    near = [same[b] for b in difflib.get_close_matches(name, list(same), n=1, cutoff=0.6)]
    return f" (did you mean {near[0]!r}?)" if near else ""


def _refuse_unused(params: "Params", entries: list[tuple[str, str]]) -> None:
    """Refuse the open entries ``(key, where)`` that the linkage description does not use and
    that are not declared free: a typo (``L22`` for ``L2``) would otherwise be kept and ignored."""
    bad = [(k, w) for k, w in entries if k not in params.references and not _is_free(params.meta, k)]
    if not bad:
        return
    used = sorted(params.references & {k for k in params.values if _is_open(k)})
    known = used + [k for k in params.values if _is_open(k) and _is_free(params.meta, k)]
    lines = [f"{k} = {params.values.get(k)!r} ({w}){_nearest(k, known)}" for k, w in bad[:3]]
    more = f"; and {len(bad) - 3} more" if len(bad) > 3 else ""
    name = params.linkage.name or "of the file"
    raise ParameterError(
        f"{len(bad)} unknown {'entry' if len(bad) == 1 else 'entries'} of [geometry]/[masses], which the "
        f"linkage {name!r} does not use: {'; '.join(lines)}{more}.  It uses "
        f"{', '.join(used) if used else 'none of them'}; an entry kept for another use must be declared "
        "free: name = { value = ..., free = true }")


def file_entries(path: str | Path) -> dict[str, Any]:
    """The entries of one parameter file as :func:`load_params` layers them: dotted key -> value
    (the ``value`` of a table entry), and ``"linkage"`` -> its ``[linkage]`` table if it has one.
    Unknown keys are refused as there (:class:`~fivebar.errors.ParameterError`)."""
    return _flatten(read_toml(path, "parameter file path", ParameterError), str(path))[0]


def unused_entry(params: "Params", key: str, book: "Params | None" = None) -> str:
    """Why the linkage of ``params`` does not use the entry ``key`` ("" if it does): a number of
    ``[geometry]``/``[masses]`` or of another description (``book``'s, e.g. the paper's five-bar:
    its ``simulation.theta4_0``, ``assumptions.speed_ratio``) that this description does not
    refer to, a motor section (or shaft diameter) no crank of it names, an assumption of the motor
    elements when no crank has a motor.  ``"linkage"`` is never unused here (a later file's
    ``[linkage]`` replaces the description)."""
    name = params.linkage.name or "the linkage"
    motors = {sec for _, sec in params.linkage.motors}
    section = key.split(".", 1)[0]
    free = _is_free(params.meta, key) or (book is not None and _is_free(book.meta, key))
    if _is_open(key):
        return "" if key in params.references or free else f"not a number of the {name}"
    if book is not None and key in book.references and key not in params.references:
        return f"a number of the {book.linkage.name or 'book'}, not of the {name}"
    m = _MOTOR_SECTION.fullmatch(section) or _SHAFT_DIAMETER.fullmatch(key)
    if m and f"motor{m.group(1)}" not in motors:
        return f"the {name} has no crank driven by motor{m.group(1)}"
    if key in MOTOR_ONLY and not motors:
        return f"it acts on the motor elements, and the {name} has none"
    return ""


def _flatten(doc: Mapping[str, Any], origin: str) -> tuple[dict[str, Any], dict[str, dict]]:
    """Dotted key -> value, and dotted key -> metadata, from one parsed TOML document."""
    values: dict[str, Any] = {}
    meta: dict[str, dict] = {}
    for section, entries in doc.items():
        if not isinstance(entries, Mapping):
            raise ParameterError(f"{origin}: top-level entry {section!r} must be a [section]")
        if section == "linkage":  # the description, read whole (a later file's replaces it)
            values["linkage"] = entries
            meta["linkage"] = {"file": origin}
            continue
        for name, entry in entries.items():
            key = _resolve_key(f"{section}.{name}")
            if isinstance(entry, Mapping):
                if "value" not in entry:
                    raise ParameterError(f"{origin}: {key} has no 'value'")
                values[key] = entry["value"]
                meta[key] = {k: v for k, v in entry.items() if k != "value"} | {"file": origin}
                if "free" in entry and (not isinstance(entry["free"], bool) or not _is_open(key)):
                    raise ParameterError(f"{origin}: {key}.free = {entry['free']!r} is not allowed: only an entry of "
                                         "[geometry] or [masses] may be declared free, with true or false")
            else:
                values[key] = entry
                meta[key] = {"file": origin, "source": f"override in {origin}"}
    return values, meta


#: The entries of the schema that :func:`_build` only checks (:func:`_check`) and keeps in the
#: field of :class:`Params` of their name: the section, the material, the motors and the
#: linkage description are made of other entries (or of any entry the description refers to,
#: the set's ``references``), and ``bending_depth``, a field too, is checked against the
#: section's sides (:data:`_CROSS_CHECKED`).  :meth:`Params.replace` of such entries alone
#: checks them and keeps the rest of the set as it is (a new crank speed costs one check).
_CROSS_CHECKED = frozenset({"assumptions.bending_depth"})
_FIELD_ONLY = frozenset(k for k in _SCHEMA if k.split(".", 1)[0] in ("simulation", "assumptions")
                        and k.split(".", 1)[1] in {f.name for f in fields(Params)}) - _CROSS_CHECKED


def _build(values: Mapping[str, Any], meta: Mapping[str, Mapping[str, Any]]) -> Params:
    checked: dict[str, Any] = {}
    for key in _SCHEMA:
        if key not in values:
            rule, unit = _SCHEMA[key]
            raise ParameterError(f"{key} is missing: it must be {_describe(rule, unit)}")
        checked[key] = _check(key, values[key])
    for key in values:
        if key.split(".", 1)[0] in _OPEN or _motor_rule(key):
            checked[key] = _check(key, values[key])
    sections = sorted({k.split(".", 1)[0] for k in checked if _MOTOR_SECTION.fullmatch(k.split(".", 1)[0])},
                      key=lambda sec: int(_MOTOR_SECTION.fullmatch(sec).group(1)))
    for sec in sections:
        number = _MOTOR_SECTION.fullmatch(sec).group(1)
        for key in [f"{sec}.{k}" for k in _MOTOR_KEYS] + [f"assumptions.shaft_diameter_{number}"]:
            if key not in checked:
                raise ParameterError(f"{key} is missing: it must be {_describe(*_motor_rule(key))}")
    if "linkage" not in values:
        raise ParameterError("the [linkage] section is missing: it describes the links, joints and drives")

    a = {k.split(".", 1)[1]: v for k, v in checked.items() if k.startswith("assumptions.")}

    def motor(sec: str) -> Motor:
        kw = {k.split(".", 1)[1]: v for k, v in checked.items() if k.startswith(f"{sec}.")}
        return Motor(
            **kw,
            shaft_diameter=a[f"shaft_diameter_{_MOTOR_SECTION.fullmatch(sec).group(1)}"],
            shaft_E=a["shaft_E"],
            shaft_G=a["shaft_G"],
            shaft_rho=a["shaft_rho"],
        )

    top = {
        k.split(".", 1)[1]: v
        for k, v in checked.items()
        if k.split(".", 1)[0] in ("geometry", "material", "masses", "simulation")
    }
    # (the one check of an entry against others: _CROSS_CHECKED)
    d, sides = a["bending_depth"], (checked["geometry.width"], checked["geometry.thickness"])
    if not any(math.isclose(d, side, rel_tol=1e-9) for side in sides):
        raise ParameterError(
            f"assumptions.bending_depth = {d!r} is not allowed: it must be one side of the links' "
            f"section, geometry.width = {sides[0]!r} or geometry.thickness = {sides[1]!r} (m)")
    own = {f.name for f in fields(Params)}
    top = {k: v for k, v in top.items() if k in own}
    top.update({k: v for k, v in a.items() if k in own})

    used: set[str] = set()

    def resolve(ref: str) -> Any:
        key = _resolve_key(ref, checked)
        used.add(key)
        if key not in checked:
            raise ParameterError(f"{key} is missing from the parameter file, and the linkage refers to it")
        return checked[key]

    linkage = linkage_from_toml(
        values["linkage"], resolve,
        Section(checked["geometry.width"], checked["geometry.thickness"], a["bending_depth"]),
        Material(checked["material.rho"], checked["material.E"]),
        motors=tuple(sections),
    )
    checked["linkage"] = values["linkage"]
    _warn_unresolved_angles(checked, linkage)
    return Params(**top, linkage=linkage, motors=Motors({sec: motor(sec) for sec in sections}), values=checked,
                  meta=dict(meta), references=frozenset(used))


def _unresolved_model(params: "Params", exc: Exception) -> ParameterError:
    """The error of a model whose frozen modes cannot be computed (``exc``, from
    :func:`fivebar.numerics.eigen.frozen_modes`): its mass and stiffness span more than double precision
    resolves; the message names the entries they are made of."""
    masses = {k: params.values[k] for k in sorted(params.references) if k.startswith("masses.")}
    return ParameterError(
        f"the linkage's model cannot be solved with these parameters ({exc}). Check material.rho = "
        f"{params.rho!r} kg/m^3 and material.E = {params.E!r} Pa (aluminium: 2700 kg/m^3 and 70e9 Pa), the "
        f"section geometry.width = {params.width!r} x geometry.thickness = {params.thickness!r} m"
        + (f" and the lumped masses {masses} (kg)" if masses else "")
        + ": a link whose own mass or stiffness is many orders of magnitude from the rest of the model "
        "leaves its highest modes below the round-off of the matrices")


#: The largest angle (rad) whose round-off a double keeps below 1e-9 rad (a million turns):
#: beyond it the crank angle theta0 + Omega t is not resolved as the model needs.
ANGLE_LIMIT = 2.0 * math.pi * 1e6


def _warn_unresolved_angles(checked: Mapping[str, Any], linkage: Linkage) -> None:
    """A :class:`~fivebar.errors.ValidityWarning` for every angle (rad) of the set, and every
    initial crank angle of the description, beyond :data:`ANGLE_LIMIT`: legal numbers, but a
    double resolves an angle of 1e20 rad only to 1.6e4 rad, so the crank angle theta0 + Omega t
    does not advance as the model needs and every result from it is meaningless."""
    angles = {k: v for k, v in checked.items() if (_ALL_KEYS.get(k) or (None, ""))[1] == "rad"}
    angles.update({f"linkage.joints.{j.name}.theta0": j.drive.theta0 for j in linkage.cranks if j.drive})
    big = {k: v for k, v in angles.items() if abs(v) > ANGLE_LIMIT}
    if big:
        worst = max(big.values(), key=abs)
        warnings.warn(
            ", ".join(f"{k} = {v:g} rad" for k, v in big.items()) + (" is" if len(big) == 1 else " are")
            + " beyond what the model resolves: a double "
            f"spaces angles near {worst:g} rad {math.ulp(worst):.2g} rad apart (above {ANGLE_LIMIT:.3g} rad, a "
            "million turns, the round-off passes 1e-9 rad), so the crank angle theta0 + Omega t does not advance "
            "as it should and every result is meaningless; give the angle modulo 2 pi "
            "(math.remainder(angle, 2 * math.pi))", ValidityWarning,
            stacklevel=4)  # (this, _build, load_params or Params.replace, the caller)


def load_params(
    path: str | Path | Iterable[str | Path] | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> Params:
    """Load, validate and freeze the parameters.

    ``p = load_params()``; ``p = load_params([base, mine])``; ``p = load_params(overrides=...)``

    Parameters
    ----------
    path
        A TOML file, or a sequence of files layered in order (later files override earlier
        ones, entry by entry); the first must be complete.  ``None`` loads
        ``data/wang2011.toml``.  To layer your own file over the defaults:
        ``load_params([fivebar.DEFAULT_PARAMS_PATH, "mine.toml"])``.
    overrides
        Dotted or unique bare keys and values applied last, e.g. ``{"crank_speed_rpm": 120}``.

    Returns
    -------
    Params
        The frozen parameter set.

    Raises
    ------
    ParameterError
        For a missing, unknown, non-numeric, negative or otherwise invalid entry; the message
        names the key, the value and what is allowed.
    """
    if path is None:
        paths = [DEFAULT_PARAMS_PATH]
    elif isinstance(path, (str, Path)):
        paths = [Path(path)]
    else:
        try:
            paths = [Path(p) for p in path]
        except TypeError:
            raise ParameterError(f"path = {path!r} is not allowed: give a TOML file, a sequence "
                                 "of them, or None for the package's wang2011.toml") from None
    if overrides is not None and not isinstance(overrides, Mapping):
        raise ParameterError(f"overrides = {overrides!r} is not allowed: give a mapping of keys "
                             "to values, e.g. {'crank_speed_rpm': 120}")
    values: dict[str, Any] = {}
    meta: dict[str, dict] = {}
    layers = []
    for p in paths:
        doc = read_toml(p, "parameter file path", ParameterError)
        layers.append(_flatten(doc, str(p)))
    for v, m in layers:
        values.update(v)
        for k, mk in m.items():
            meta[k] = {**meta.get(k, {}), **mk}
    given = []
    for key, value in (overrides or {}).items():
        k = _resolve_key(key, values)
        values[k] = value
        meta[k] = {**meta.get(k, {}), "source": "override in code"}
        if _is_open(k):
            given.append((k, "overrides"))
    params = _build(values, meta)
    # the open entries must be used by the description, except those of a file whose own
    # [linkage] a later file replaced (they belong to that description) and those declared free
    for i, (v, _) in enumerate(layers):
        if "linkage" in v and any("linkage" in later for later, _ in layers[i + 1:]):
            continue
        given += [(k, paths[i].name) for k in v if _is_open(k)]
    _refuse_unused(params, given)
    return params
