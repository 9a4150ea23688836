"""The units contract (issue 21.6): SI at the API, or the unit in the name.

The test walks the public API, every module documented in book/api.md: every public function,
class, method, property and dataclass field, and every documented parameter.  A docstring that
says a value is in a unit other than SI (mm, µm, deg, r/min, MPa, ms, µs, kW, %) must belong to
a name that carries the unit (``_mm``, ``_um``, ``_deg``, ``_rpm``, ``_mpa``, ``_ms``, ``_us``,
``_kw``, ``_pct``):

* a parameter or field (numpydoc ``Parameters``, ``Other Parameters``, ``Attributes``, or a
  dataclass field described in the class's prose as ````name```` followed by its unit): the
  parameter's or field's name;
* a return value (a ``Returns`` or ``Yields`` entry that is not a table, mapping, tuple or
  object; or, without such a section, the summary paragraph of a function, method or
  property): the function's, method's or property's name.

What a value "is in" is read from the docstring's phrases: "in mm", "(mm)", "[mm]", ", mm".
Inline literals (````"L2 p-p (um)"````, ````crank_speed_rpm````) are removed first: a DataFrame
column or dict key whose name carries the unit, "(mm)", satisfies the rule by its name.
The two exceptions are listed in ALLOWED with their reason.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# unit as a docstring writes it -> the token the name must contain
UNITS = {"mm": "mm", "µm": "um", "um": "um", "deg": "deg", "degree": "deg", "degrees": "deg",
         "r/min": "rpm", "rpm": "rpm", "MPa": "mpa", "ms": "ms", "µs": "us", "us": "us",
         "kW": "kw", "%": "pct", "percent": "pct"}
_UNIT = "|".join(re.escape(u) for u in sorted(UNITS, key=len, reverse=True))
UNIT_PHRASE = re.compile(r"(?:\bin |\(|\[|, )(" + _UNIT + r")(?=[\s,;:.)\]]|$)")
LITERAL = re.compile(r"``.*?``|`[^`]*`")
SECTION_PARAMS = {"Parameters", "Other Parameters", "Attributes"}
SECTION_RETURNS = {"Returns", "Yields"}
# a return that is a container: its units are in its columns/keys/fields (checked there)
CONTAINER = re.compile(r"DataFrame|dict|tuple|list of|Mapping|\b[A-Z][a-z]+[A-Z]\w*|\b[A-Z][a-z]{3,}\b")

ALLOWED = {
    ("fivebar.book.plotting.draw_linkage", "scale"):
        "a factor from m to the plot's units (1e3 draws in mm), not a length",
    ("fivebar.analyses.branches.LinkageBranch.p", "p"):
        "the values of the continued entry, in that entry's unit: its name carries it (crank_speed_rpm)",
}


def api_modules() -> list[str]:
    return re.findall(r"automodule:: (fivebar[\w.]*)", (ROOT / "book" / "api.md").read_text())


def name_has_unit(name: str, unit: str) -> bool:
    token = UNITS[unit]
    parts = name.lower().split("_")
    return token in parts or (token == "pct" and "percent" in parts)


def units_in(text: str) -> list[str]:
    return sorted({m.group(1) for m in UNIT_PHRASE.finditer(LITERAL.sub(" ", text))})


def sections(doc: str) -> dict[str, list[tuple[str, str]]]:
    """numpydoc sections -> [(entry header, entry description)]; "" -> [("", summary)]."""
    lines = doc.splitlines()
    out: dict[str, list[tuple[str, str]]] = {"": []}
    current, body = "", []
    i = 0
    while i < len(lines):
        if i + 1 < len(lines) and lines[i].strip() and re.fullmatch(r"-{3,}", lines[i + 1].strip()):
            current = lines[i].strip()
            out.setdefault(current, [])
            i += 2
            continue
        line = lines[i]
        if current == "":
            body.append(line)
        elif line.strip() and not line.startswith(" "):
            out[current].append((line.strip(), ""))
        elif out[current]:
            head, desc = out[current][-1]
            out[current][-1] = (head, desc + " " + line.strip())
        i += 1
    summary = "\n".join(body).strip().split("\n\n")[0]
    out[""] = [("", summary)]
    return out


def check_doc(qualname: str, obj, doc: str, fields: list[str] = ()) -> list[str]:
    """Violations of the rule in one docstring; ``qualname`` names the object documented."""
    bad = []
    short = qualname.rsplit(".", 1)[-1]

    def need(name: str, text: str, what: str) -> None:
        if (qualname, name) in ALLOWED:
            return
        for unit in units_in(text):
            if not name_has_unit(name, unit):
                bad.append(f"{qualname}: {what} {name!r} is documented in {unit} "
                           f"but its name has no _{UNITS[unit]}: {text.strip()[:120]!r}")

    secs = sections(doc)
    for sec in SECTION_PARAMS:
        for head, desc in secs.get(sec, []):
            names, _, typ = head.partition(":")
            for name in names.split(","):
                name = name.strip().lstrip("*")
                if name:
                    need(name, typ + " " + desc, "parameter" if sec != "Attributes" else "field")
    returns = [e for sec in SECTION_RETURNS for e in secs.get(sec, [])]
    is_callable = inspect.isfunction(obj) or isinstance(obj, property)
    if is_callable:
        for head, desc in returns:
            typ = head.partition(":")[2] if ":" in head else head
            if not CONTAINER.search(LITERAL.sub(" ", typ)):
                need(short, typ + " " + desc, "return value of")
        target = obj.fget if isinstance(obj, property) else obj
        annotation = str(inspect.signature(target).return_annotation)
        if not returns and not re.search(r"DataFrame|dict|Mapping", annotation):
            need(short, secs[""][0][1], "return value of")
    documented = {n.strip().lstrip("*") for sec in SECTION_PARAMS for head, _ in secs.get(sec, [])
                  for n in head.partition(":")[0].split(",")}
    for field in [f for f in fields if f not in documented]:  # fields described in the prose
        first_section = re.search(r"^\S.*\n-{3,}$", doc, re.M)
        prose = doc[: first_section.start()] if first_section else doc
        for m in re.finditer(r"``" + re.escape(field) + r"``", prose):
            rest = prose[m.end():]
            nxt = re.search(r"``|\n\n|(?<=[a-z)])\.\s", rest)
            need(field, rest[: nxt.start() if nxt else len(rest)], "field")
    return bad


def api_objects():
    """(qualified name, object, docstring, dataclass fields) of every public API object."""
    for modname in api_modules():
        mod = importlib.import_module(modname)
        names = getattr(mod, "__all__", None) or [n for n in vars(mod) if not n.startswith("_")]
        for name in names:
            obj = getattr(mod, name)
            if getattr(obj, "__module__", None) != modname:
                continue  # re-exported: checked where it is defined
            qual = f"{modname}.{name}"
            if inspect.isfunction(obj):
                yield qual, obj, inspect.getdoc(obj) or "", []
            elif inspect.isclass(obj):
                fields = [f.name for f in dataclasses.fields(obj)] if dataclasses.is_dataclass(obj) else []
                yield qual, obj, inspect.getdoc(obj) or "", fields
                for attr, member in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    if isinstance(member, (staticmethod, classmethod)):
                        member = member.__func__
                    if inspect.isfunction(member) or isinstance(member, property):
                        target = member.fget if isinstance(member, property) else member
                        yield f"{qual}.{attr}", member, inspect.getdoc(target) or "", []


def violations() -> list[str]:
    out = []
    for qual, obj, doc, fields in api_objects():
        out += check_doc(qual, obj, doc, fields)
    return out


def test_the_api_walk_sees_the_library():
    objs = {q for q, *_ in api_objects()}
    # the renamed names of issue 21.6 are walked (a walk that sees nothing checks nothing)
    for q in ("fivebar.analyses.response.Response.midpoint_mm", "fivebar.analyses.response.Response.crank_angle_deg",
              "fivebar.analyses.response.Response.peak_to_peak_mm", "fivebar.book.animation.LinkageFrames",
              "fivebar.description.setup.Setup", "fivebar.analyses.branches.steady_state"):
        assert q in objs
    assert len(objs) > 300


def test_public_names_carry_their_non_si_units():
    bad = violations()
    assert not bad, "the unit is not in the name:\n" + "\n".join(bad)


def test_allowed_exceptions_still_exist():
    objs = {q: (o, d, f) for q, o, d, f in api_objects()}
    for qual, name in ALLOWED:
        assert qual in objs, f"ALLOWED names {qual}, which is no longer in the API: drop it"


def _planted(doc: str):
    def f(gap):
        pass
    f.__doc__ = doc
    return f


@pytest.mark.parametrize("doc, expected", [
    ("Gap of the joint (mm).", "return value of 'f'"),
    ("Gap.\n\nParameters\n----------\ngap : float\n    Clearance in µm.\n", "parameter 'gap'"),
    ("Gap.\n\nReturns\n-------\nfloat\n    The angle in degrees.\n", "return value of 'f'"),
    ("Gap.\n\nAttributes\n----------\nspeed : float\n    Crank speed (r/min).\n", "field 'speed'"),
])
def test_the_rule_catches_a_planted_violation(doc, expected):
    bad = check_doc("planted.f", _planted(doc), doc)
    assert len(bad) == 1 and expected in bad[0]


@pytest.mark.parametrize("doc", [
    "Gap of the joint in m.",
    "Peak-to-peak value (mm).\n\nReturns\n-------\nDataFrame\n    Columns ``gap (mm)``.\n",
    "Within 1 % of the converged value.",
    "Gap.\n\nParameters\n----------\ngap_mm : float\n    Clearance (mm).\n",
])
def test_the_rule_accepts_si_units_and_named_units(doc):
    f = _planted(doc)
    f.__name__ = "f"
    assert check_doc("planted.f", f, doc) == []


def test_dataclass_fields_in_prose():
    doc = "Frames.\n\n``frames`` (PNG bytes), ``interval`` (ms between frames), ``peak_mm`` (mm)."
    bad = check_doc("planted.Frames", object, doc, ["frames", "interval", "peak_mm"])
    assert len(bad) == 1 and "field 'interval'" in bad[0]


def _rule(path: str, start: str) -> str:
    text = " ".join((ROOT / path).read_text().split())
    i = text.index(start) + len(start)
    return text[i: text.index("against what its docstring says.", i)]


def test_readme_library_map_and_front_page_state_the_same_rule():
    rules = {p: _rule(p, s) for p, s in [("README.md", "**Units**: "), ("book/library.md", "**Units**: "),
                                        ("book/index.md", "The library's rule: ")]}
    assert len(set(rules.values())) == 1, rules
    first = next(iter(rules.values()))
    for unit, token in UNITS.items():  # the rule names every suffix the test enforces
        assert f"`_{token}`" in first, f"the rule does not name the suffix _{token} (for {unit})"
