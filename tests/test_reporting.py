"""Tests of fivebar.book.reporting: the errata and assumptions tables of the book.

The reference is the data files themselves, read here independently with tomllib.
"""

import re
import tomllib

import pytest

import fivebar
from fivebar.book import reporting
from fivebar.book.reporting import ReportError, assumptions_table, errata_table, format_value

ERRATUM = """
[[erratum]]
id = "{id}"
where = "(A.6)"
printed = "p"
read_as = "r"
reason = "why"
verified_by = "tests/test_x.py"
"""


def test_errata_table_is_the_file():
    with open(reporting.ERRATA_PATH, "rb") as fh:
        entries = tomllib.load(fh)["erratum"]
    df = errata_table()
    assert list(df.columns) == ["id", "where", "printed", "read as", "reason", "verified by"]
    assert len(df) == len(entries)
    assert list(df["id"]) == [e["id"] for e in entries]
    assert list(df["read as"]) == [e["read_as"].strip() for e in entries]
    assert list(df["verified by"]) == [e["verified_by"].strip() for e in entries]


def test_errata_table_reads_another_file(tmp_path):
    f = tmp_path / "e.toml"
    f.write_text(ERRATUM.format(id="X1") + ERRATUM.format(id="X2"))
    df = errata_table(f)
    assert list(df["id"]) == ["X1", "X2"]
    assert df.loc[0, "where"] == "(A.6)"


@pytest.mark.parametrize("field", ["id", "where", "printed", "read_as", "reason", "verified_by"])
def test_errata_entry_without_a_field_is_named(tmp_path, field):
    lines = [ln for ln in ERRATUM.format(id="X1").splitlines() if not ln.startswith(field + " ")]
    f = tmp_path / "e.toml"
    f.write_text("\n".join(lines))
    with pytest.raises(ReportError, match=rf"field '{field}'"):
        errata_table(f)


def test_errata_empty_field_and_duplicate_id_are_rejected(tmp_path):
    f = tmp_path / "e.toml"
    f.write_text(ERRATUM.format(id="X1").replace('reason = "why"', 'reason = "  "'))
    with pytest.raises(ReportError, match="reason"):
        errata_table(f)
    f.write_text(ERRATUM.format(id="X1") * 2)
    with pytest.raises(ReportError, match="used twice"):
        errata_table(f)


def test_errata_missing_or_broken_file(tmp_path):
    with pytest.raises(ReportError, match="does not exist"):
        errata_table(tmp_path / "none.toml")
    f = tmp_path / "bad.toml"
    f.write_text("[[erratum]\n")
    with pytest.raises(ReportError, match="not valid TOML"):
        errata_table(f)
    f.write_text("title = 'no entries'\n")
    with pytest.raises(ReportError, match="no \\[\\[erratum\\]\\]"):
        errata_table(f)
    assert issubclass(ReportError, ValueError)


def test_assumptions_table_is_the_file():
    with open(fivebar.DEFAULT_PARAMS_PATH, "rb") as fh:
        assumptions = tomllib.load(fh)["assumptions"]
    df = assumptions_table()
    assert list(df.columns) == ["key", "value", "unit", "reason", "alternative"]
    assert sorted(df["key"]) == sorted(assumptions)
    for row in df.itertuples(index=False):
        entry = assumptions[row.key]
        assert row.value == entry["value"]
        assert row.unit == entry["unit"]
        assert row.reason == entry["reason"].strip()
        assert row.alternative == entry["alternative"].strip()


def test_assumptions_table_shows_overrides():
    params = fivebar.load_params().replace(crank_speed_rpm=123.0)
    df = assumptions_table(params).set_index("key")
    assert df.loc["crank_speed_rpm", "value"] == 123.0
    assert df.loc["crank_speed_rpm", "unit"] == "r/min"  # the provenance is kept


@pytest.mark.parametrize(
    "value, text",
    [(210.0e9, "2.1e+11"), (0.03, "0.03"), (60.0, "60"), (10, "10"), (-1.5707963, "-1.571"),
     (2.5e-7, "2.5e-07"), ("calibrated", "calibrated"), (True, "True")],
)
def test_format_value(value, text):
    assert format_value(value) == text


def test_errata_math_columns_are_the_optional_tex_fields(tmp_path):
    with open(reporting.ERRATA_PATH, "rb") as fh:
        entries = tomllib.load(fh)["erratum"]
    df = errata_table(math=True)
    assert list(df.columns)[-2:] == ["printed (math)", "read as (math)"]
    assert list(df["read as (math)"]) == [e.get("read_as_tex", "").strip() for e in entries]
    # the formulas are LaTeX between dollars, balanced (a field may be prose without a formula)
    for text in [t for t in df["printed (math)"].tolist() + df["read as (math)"].tolist() if t]:
        assert text.count("$") % 2 == 0, text
    f = tmp_path / "e.toml"
    f.write_text(ERRATUM.format(id="X1").replace('reason = "why"', 'reason = "why"\nread_as_tex = ""'))
    with pytest.raises(ReportError, match="field 'read_as_tex' = '' is not allowed"):
        errata_table(f)


def test_table_hides_the_index_and_rounds_to_significant_digits():
    import pandas as pd

    from fivebar.book.reporting import table

    df = pd.DataFrame({"speed (r/min)": [60, 1440], "L2 p-p (um)": [24.8941234, 103022.5021]})
    html = table(df).to_html()
    assert "24.89" in html and "1.03e+05" in html and "24.894" not in html
    assert 'class="row_heading' not in html  # no index column
    assert html == table(df.copy()).to_html()  # the same HTML on every run
    # a named index becomes a column
    html = table(df.set_index("speed (r/min)"), digits=2).to_html()
    assert "speed (r/min)" in html and "25" in html and 'class="row_heading' not in html
    with pytest.raises(ReportError, match="digits = 0 is not allowed"):
        table(df, digits=0)


def test_a_named_table_is_a_numbered_myst_table():
    """With name= the table is a MyST {table} directive (numbered by the book in HTML and PDF
    alike), rounded as digits says, with '|' escaped so a cell cannot split a row."""
    import numpy as np
    import pandas as pd

    from fivebar.book.reporting import table

    df = pd.DataFrame({"case": ["a|b", "c"], "p-p (um)": [24.8941234, np.nan], "n": [3, 4]})
    md = table(df, caption="Peak-to-peak at 60 r/min.", name="tab-07-pp").data
    lines = md.splitlines()
    assert lines[0] == "```{table} Peak-to-peak at 60 r/min." and lines[1] == ":name: tab-07-pp"
    assert lines[3] == "| case | p-p (um) | n |" and lines[-1] == "```"
    assert "| a\\|b | 24.89 | 3 |" in lines and "| c | – | 4 |" in lines
    assert "| a\\|b | 24.894 | 3 |" in table(df, digits={"p-p (um)": 3}, caption="c.", name="tab-07-pp").data
    with pytest.raises(ReportError, match="name = 'table1' is not allowed"):
        table(df, caption="c.", name="table1")
    with pytest.raises(ReportError, match="caption = None is not allowed"):
        table(df, name="tab-07-pp")
    with pytest.raises(ReportError, match="'q'"):
        table(df, digits={"q": 2}, caption="c.", name="tab-07-pp")
    with pytest.raises(ReportError, match="a backtick or a line break ends the table's fence"):
        table(df, caption="As {numref}`tab-07-pp`, at 120 r/min.", name="tab-07-pp2")


_ASCII_MATH = re.compile(r"[A-Za-z]_[A-Za-z0-9{]|\^\d|\bsqrt\(|\b(?:mu0|delta0|sigma|omega|varsigma|vartheta|gamma\d|"
                         r"psi\d|nu\d|phi|rho|Lambda|int)\b|<=|>=|\+-")


def _outside_math_and_code(text: str) -> str:
    """The prose of a field: without its $...$ formulas and `code`."""
    return re.sub(r"`[^`]*`", " ", re.sub(r"\$[^$]*\$", " ", text))


def test_the_errata_page_has_one_notation():
    """Every field the errata page shows writes its formulas in LaTeX (issue 22.6): each erratum has
    printed_tex and read_as_tex, and no ASCII maths ("mu0 F_m / (k_mu delta0)", "W'^2", "sqrt(")
    is left in the prose of where, printed_tex, read_as_tex and reason."""
    with open(reporting.ERRATA_PATH, "rb") as fh:
        entries = tomllib.load(fh)["erratum"]
    for e in entries:
        assert e.get("printed_tex") and e.get("read_as_tex"), e["id"]
        for key in ("where", "printed_tex", "read_as_tex", "reason"):
            prose = _outside_math_and_code(e[key])
            hit = _ASCII_MATH.search(prose)
            assert not hit, f"{e['id']} {key}: ASCII maths {hit.group(0)!r} in {e[key]!r}"
    assert _ASCII_MATH.search(_outside_math_and_code("mu0 F_m / (k_mu delta0) is about 11 T"))


def test_sentence_helpers_say_what_their_examples_say():
    """The helpers that put numbers into a chapter's generated sentences (they replaced functions
    defined in the chapters' cells): their docstring examples, run as doctests."""
    import doctest

    import fivebar.book.reporting as rep

    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    finder = doctest.DocTestFinder()
    tried = 0
    for f in (rep.percent, rep.change, rep.sci, rep.significant, rep.length_text, rep.ordinal, rep.how_many, rep.certain):
        for t in finder.find(f, f.__name__, globs=vars(rep)):
            runner.run(t)
            tried += len(t.examples)
    assert tried >= 7 and runner.failures == 0


def test_a_table_cell_that_rounds_to_zero_has_no_sign():
    """A quantity that is zero but for round-off (a detuning of 0 by construction: -2e-16 on one
    machine, +2e-16 or 0 on another) rounded by the caller prints as 0, not as -0: the page reads
    the same on every machine."""
    import pandas as pd

    from fivebar.book.reporting import table

    text = table(pd.DataFrame({"d (-)": [-0.0, round(-2.2e-16, 6), 0.0, -1e-5]}), digits=4,
                 caption="c", name="tab-07-zero").data
    rows = [line for line in text.splitlines() if line.startswith("| ") and "d (-)" not in line]
    assert rows == ["| 0 |", "| 0 |", "| 0 |", "| -1e-05 |"]
    text = table(pd.DataFrame({"d (-)": [-0.0004]}), digits={"d (-)": 2}, caption="c", name="tab-07-zero").data
    assert "| 0.00 |" in text


@pytest.mark.parametrize("display", [False, True])
@pytest.mark.parametrize("value", ["10.5", 3, 0.25, [1, 2]], ids=["text", "int", "float", "list"])
def test_glue_displays_what_myst_nb_glue_displays(monkeypatch, value, display) -> None:
    """The chapters' glue (fivebar.book.reporting.glue) against myst-nb's own, which the book's
    ``{glue:text}`` roles read: the same display call, bundle, metadata and options."""
    import IPython.display
    import myst_nb.ext.glue as theirs

    from fivebar.book.reporting import glue

    calls = {}

    def record(who):
        return lambda *args, **kwargs: calls.setdefault(who, []).append((args, kwargs))

    monkeypatch.setattr(theirs, "ipy_display", record("myst-nb"))
    monkeypatch.setattr(IPython.display, "display", record("fivebar"))
    theirs.glue("key", value, display=display)
    glue("key", value, display=display)
    assert calls["fivebar"] == calls["myst-nb"]
    (bundle,), options = calls["fivebar"][0]
    assert all(k.startswith("application/papermill.record/") != display for k in bundle), bundle
    assert options["metadata"]["scrapbook"]["name"] == "key"
