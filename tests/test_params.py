"""Parameter loading: the paper's numbers, overrides, and every validation error path."""

import math
from pathlib import Path

import pytest

import fivebar
from fivebar import ParameterError, load_params


def test_paper_values_in_si():
    p = load_params()
    # section 5, converted by hand
    assert p.lengths == (0.2, 0.4, 0.4, 0.15, 0.4)
    assert p.A == pytest.approx(30e-3 * 2e-3)
    assert p.I == pytest.approx(2e-3 * 30e-3**3 / 12)  # 30 mm side in the plane (assumption)
    assert p.motors["motor1"].l == pytest.approx(0.363)  # l1 + l2 + l3 as printed in total
    assert p.motors["motor2"].l == pytest.approx(0.308)  # 100 + 33 + 175 mm (the paper prints l = 208)
    assert p.motors["motor1"].rated_speed == pytest.approx(1500 * 2 * math.pi / 60)
    assert p.crank_speed_rad_s == pytest.approx(p.crank_speed_rpm * math.pi / 30)
    assert p.period == pytest.approx(60 / p.crank_speed_rpm)
    assert p.meta["geometry.L1"]["printed"] == "200 mm"
    assert "reason" in p.meta["assumptions.damping_ratio"]


def test_every_assumption_is_documented():
    p = load_params()
    for key, meta in p.meta.items():
        if key == "linkage":  # the description: its entries refer to the documented ones
            continue
        if key.startswith("assumptions."):
            assert meta.get("reason") and meta.get("alternative") and meta.get("unit"), key
        else:
            assert meta.get("printed") and meta.get("source"), key


def test_params_are_frozen():
    p = load_params()
    with pytest.raises(AttributeError):
        p.L1 = 1.0


def test_replace_and_layered_file(tmp_path: Path):
    p = load_params()
    q = p.replace(crank_speed_rpm=120, **{"motor1.m0": 3.0})
    assert q.crank_speed_rpm == 120 and q.motors["motor1"].m0 == 3.0 and p.crank_speed_rpm != 120
    overlay = tmp_path / "mine.toml"
    overlay.write_text("[geometry]\nL1 = 0.25\n[assumptions]\nbending_depth = 0.002\n")
    r = load_params([fivebar.DEFAULT_PARAMS_PATH, overlay])
    assert r.L1 == 0.25 and r.I == pytest.approx(30e-3 * 2e-3**3 / 12)
    assert r.L2 == p.L2
    assert "mine.toml" in r.meta["geometry.L1"]["file"]
    s = load_params(overrides={"L5": 0.5})
    assert s.L5 == 0.5


@pytest.mark.parametrize(
    "key, value, words",
    [
        ("geometry.L1", -0.2, ["geometry.L1", "-0.2", "positive"]),
        ("geometry.L2", 0.0, ["geometry.L2", "0.0", "positive"]),
        ("material.E", "70 GPa", ["material.E", "'70 GPa'", "positive number (Pa)"]),
        ("motor1.p", 1.5, ["motor1.p", "1.5", "positive integer"]),
        ("motor2.s", 1.2, ["motor2.s", "1.2", "(0, 1)"]),
        ("assumptions.damping_ratio", -0.01, ["damping_ratio", "-0.01", "[0, 1)"]),
        ("assumptions.em_variant", "fancy", ["em_variant", "'fancy'", "calibrated", "literal"]),
        ("geometry.L3", float("nan"), ["geometry.L3", "nan"]),
        ("geometry.L4", True, ["geometry.L4", "True"]),
    ],
)
def test_invalid_values_name_key_value_and_rule(key, value, words):
    with pytest.raises(ParameterError) as info:
        load_params().replace(**{key: value})
    for w in words:
        assert w in str(info.value)


def test_missing_entry_in_file(tmp_path: Path):
    text = fivebar.DEFAULT_PARAMS_PATH.read_text()
    lines = [ln for ln in text.splitlines() if not ln.startswith("m02 =")]
    bad = tmp_path / "bad.toml"
    bad.write_text("\n".join(lines))
    with pytest.raises(ParameterError, match=r"linkage\.joints\.C\.mass = 'masses\.m02': masses\.m02 is missing"):
        load_params(bad)


def test_unknown_and_ambiguous_keys(tmp_path: Path):
    with pytest.raises(ParameterError, match="unknown parameter 'material.nu'"):
        load_params(overrides={"material.nu": 0.3})
    with pytest.raises(ParameterError, match="'m0' is ambiguous"):
        load_params().replace(m0=1.0)
    with pytest.raises(ParameterError, match="does not exist"):
        load_params(tmp_path / "nope.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("[geometry\nL1 = ")
    with pytest.raises(ParameterError, match="not valid TOML"):
        load_params(broken)


def _other_values(rule, value):
    """A valid value other than ``value`` and an invalid one, for an entry's rule."""
    if isinstance(rule, tuple):  # a choice
        return next(c for c in rule[1] if c != value), "no such choice"
    return {"pos": (1.5 * value, -1.0), "nonneg": (value + 1.0, -1.0), "real": (value + 0.25, math.inf),
            "posint": (value + 1, 0), "frac": ((value + 0.5) / 2, 1.0), "unit": (value / 2, 1.5),
            "flag": (1 - value, 2), "slip": (value / 2, 1.0)}[rule]


def test_replace_of_entries_kept_in_their_field_alone_equals_loading_them():
    """``replace`` of an entry the set keeps only in a field of its own (the crank speed, ...)
    checks that entry and keeps the rest: the set must equal the file loaded with the entry
    overridden (validated whole), field for field and entry for entry, and a bad value must be
    refused as loading refuses it, by name.  ``bending_depth`` is checked against the section
    even so."""
    from fivebar.description.params import _FIELD_ONLY, _SCHEMA

    assert "assumptions.crank_speed_rpm" in _FIELD_ONLY and "assumptions.bending_depth" not in _FIELD_ONLY
    p = load_params()
    for key in sorted(_FIELD_ONLY):
        good, bad = _other_values(_SCHEMA[key][0], p.values[key])
        for bare in (key, key.split(".", 1)[1]):
            q, ref = p.replace(**{bare: good}), load_params(overrides={key: good})
            assert q == ref and hash(q) == hash(ref) and q.values == ref.values, key
            assert type(q.values[key]) is type(ref.values[key]) and q.references == ref.references, key
            assert q.linkage == ref.linkage and q.motors == ref.motors, key
            assert q.meta == p.meta  # replace keeps the provenance (loading records the override)
            with pytest.raises(ParameterError) as got:
                p.replace(**{bare: bad})
            with pytest.raises(ParameterError) as want:
                load_params(overrides={key: bad})
            assert str(got.value) == str(want.value) and key in str(got.value), key
    with pytest.raises(ParameterError, match="assumptions.bending_depth = 0.003 is not allowed: it must be one side"):
        p.replace(bending_depth=0.003)
    assert p.replace(crank_speed_rpm=120, L1=0.25).L1 == 0.25  # with another entry: the whole set rebuilt
