"""The numbers of the front page's "Findings at a glance" against the chapters that show them.

Each finding on ``book/index.md`` states a number; the chapter it links to computes it.  This
test reads the number from the chapter's *stored* outputs (which nbval, in strict mode, checks
against a fresh run of the chapter) and from the errata file, rounds it as the front page does
and requires the front page to say exactly that.  So a change of the model that moves a
finding fails here until the front page is updated with it.
"""

from __future__ import annotations

import json
import re
import tomllib
from html.parser import HTMLParser
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BOOK = ROOT / "book"
INDEX = (BOOK / "index.md").read_text(encoding="utf-8")


def _findings() -> str:
    m = re.search(r"## Findings at a glance\n(.*?)\n## ", INDEX, re.S)
    assert m, "book/index.md has no section 'Findings at a glance'"
    return " ".join(m.group(1).split())  # one line: sentences wrap anywhere in the source


FINDINGS = _findings()


def _finding(erratum_or_doc: str) -> str:
    """The bullet of the findings that links to ``erratum_or_doc`` first."""
    for bullet in FINDINGS.split("* **")[1:]:
        if erratum_or_doc in bullet:
            return bullet
    raise AssertionError(f"no finding mentions {erratum_or_doc!r}: {FINDINGS[:300]}")


# --------------------------------------------------------------------------------------------
# The chapters' stored outputs
# --------------------------------------------------------------------------------------------


class _Tables(HTMLParser):
    """Every <table> of an HTML text as rows of (kind, text) cells, kind 'th' or 'td'."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[dict] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append({"head": [], "body": []})
            self._part = "head"
        elif tag == "tbody":
            self._part = "body"
        elif tag == "tr":
            self.tables[-1][self._part].append([])
        elif tag in ("th", "td"):
            self._cell = [tag, "", int(dict(attrs).get("colspan") or 1)]

    def handle_data(self, data):
        if self._cell is not None:
            self._cell[1] += data

    def handle_endtag(self, tag):
        if tag in ("th", "td") and self._cell is not None:
            kind, text, span = self._cell
            self.tables[-1][self._part][-1].extend([(kind, text.strip())] * span)
            self._cell = None


class StoredTable:
    """A pandas table as stored in a notebook's HTML output."""

    def __init__(self, table: dict) -> None:
        self.head, self.body = table["head"], table["body"]

    def column(self, name: str, sub: str | None = None) -> list[str]:
        """The cells of column ``name`` (with ``sub`` in the next header row, for a two-level
        header), aligned from the right (index cells are <th>)."""
        for level, row in enumerate(self.head):
            names = [text for _, text in row]
            for pos, n in enumerate(names):
                if n != name:
                    continue
                if sub is not None and (level + 1 >= len(self.head)
                                        or self.head[level + 1][pos][1] != sub):
                    continue
                from_right = len(names) - pos
                return [[t for k, t in r if k == "td"][-from_right] for r in self.body]
        raise KeyError(name)

    def row_labels(self) -> list[str]:
        return [" ".join(t for k, t in r if k == "th") for r in self.body]


def _myst_tables(markdown: str) -> list[dict]:
    """The pipe tables of the numbered MyST tables (``{table}`` directives, as
    ``fivebar.book.reporting.table(..., name=...)`` writes them) in a Markdown output."""
    tables = []
    for block in re.findall(r"```\{table\}.*?\n(.*?)```", markdown, re.S):
        rows = [line.strip() for line in block.splitlines() if line.strip().startswith("|")]
        if len(rows) < 2:
            continue
        cells = [[c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", r)[1:-1]] for r in rows]
        tables.append({"head": [[("th", c) for c in cells[0]]],
                       "body": [[("td", c) for c in r] for r in cells[2:]]})
    return tables


def stored_outputs(chapter: str) -> tuple[str, list[StoredTable]]:
    """All stored text outputs of a chapter, and its stored tables (HTML, or numbered MyST tables)."""
    nb = json.loads((BOOK / f"{chapter}.ipynb").read_text(encoding="utf-8"))
    texts, tables = [], []
    for cell in nb["cells"]:
        for out in cell.get("outputs", []):
            data = out.get("data", {})
            texts.append("".join(out.get("text", "")) + "".join(data.get("text/plain", "")))
            if "text/html" in data:
                parser = _Tables()
                parser.feed("".join(data["text/html"]))
                tables += [StoredTable(t) for t in parser.tables]
            if "text/markdown" in data:
                tables += [StoredTable(t) for t in _myst_tables("".join(data["text/markdown"]))]
    return "\n".join(texts), tables


def table_with(chapter: str, *columns: str) -> list[StoredTable]:
    found = []
    for t in stored_outputs(chapter)[1]:
        try:
            for c in columns:
                t.column(c)
        except KeyError:
            continue
        found.append(t)
    assert found, f"no stored table with columns {columns} in book/{chapter}.ipynb"
    return found


def pct(x: str) -> float:
    return 100 * float(x)


# --------------------------------------------------------------------------------------------
# One test per finding
# --------------------------------------------------------------------------------------------


def test_newmark_parameters_swapped_E2():
    with open(ROOT / "data" / "errata.toml", "rb") as fh:
        e2 = {e["id"]: e for e in tomllib.load(fh)["erratum"]}["E2"]
    assert e2["printed"].startswith("varsigma = 0.25, vartheta = 0.5")
    assert e2["read_as"].startswith("varsigma = 0.5, vartheta = 0.25")
    text = _finding("{erratum}`E2`")
    assert r"$\varsigma = 0.25$, $\vartheta = 0.5$" in text
    assert r"$\varsigma = 0.5$, $\vartheta = 0.25$" in text
    assert "{doc}`06_newmark`" in text


def test_unstable_discrete_orbit_E26():
    texts, _ = stored_outputs("06_newmark")
    m = re.search(r"largest multiplier ([\d.]+)", texts)
    assert m, "chapter 06 no longer prints 'largest multiplier ...'"
    multiplier = float(m.group(1))
    text = _finding("{erratum}`E26`")
    assert f"about {multiplier:.0f}" in text, (multiplier, text)
    # "S >= 800 is stable": the stored multiplier study of the chapter
    (study,) = [t for t in table_with("06_newmark", "Newmark (0.5, 0.25)")
                if "generalised-alpha 0.8" in t.head[0][-1][1]]
    by_s = dict(zip(study.column("S"), study.column("Newmark (0.5, 0.25)")))
    stable = [int(s) for s, mu in by_s.items() if float(mu) < 1]
    assert stable and min(stable) == 800 and all(float(by_s[s]) < 1 for s in by_s if int(s) >= 800)
    assert r"$S \ge 800$ is stable" in text


def test_spin_softening_shift_E28():
    (cmp,) = table_with("07_excitation", "offset, mean (3.3) (%)", "offset, effective (%)")
    mean = [abs(float(x)) for x in cmp.column("offset, mean (3.3) (%)")]
    eff = [abs(float(x)) for x in cmp.column("offset, effective (%)")]
    (soft,) = table_with("07_excitation", "h_r (–)")
    h1 = float(soft.column("h_r (–)")[0])
    text = _finding("{erratum}`E28`")
    assert f"{min(mean):.0f}-{max(mean):.0f} % above the response peaks" in text, (mean, text)
    assert f"within {max(eff):.1f} %" in text, (eff, text)
    assert f"$h_1 \\approx {h1:.2f}$" in text, (h1, text)


def test_multiple_scales_error():
    tables = table_with("08_multiple_scales", "MS p2p error L2", "MS p2p error L3")
    def speeds_of(t):  # the speeds: a column of the table (or its index, as it once was)
        try:
            return [float(s) for s in t.column("speed (r/min)")]
        except KeyError:
            return [float(s) for s in t.row_labels()]

    low = [t for t in tables if 60.0 in speeds_of(t)]
    assert len(low) == 1
    t = low[0]
    speeds = speeds_of(t)
    l2 = [abs(pct(x)) for x in t.column("MS p2p error L2")]
    l3 = [abs(pct(x)) for x in t.column("MS p2p error L3")]
    at60 = speeds.index(60.0)
    text = _finding("{doc}`08_multiple_scales`")
    assert f"off by {l2[at60]:.0f} % ($L_2$) and {l3[at60]:.0f} % ($L_3$)" in text, (l2, l3, text)
    assert max(speeds) == 400.0 and "up to 400 r/min" in text
    assert f"up to {max(l2 + l3):.0f} %" in text, (max(l2 + l3), text)
    cols = [f"{link} peak-to-peak error (–)" for link in ("L2", "L3")]
    (first,) = table_with("08_multiple_scales", "approximation", *cols)
    qs = [abs(pct(x)) for c in cols
          for label, x in zip(first.column("approximation"), first.column(c))
          if label.startswith("quasi-static")]
    assert qs and f"within {max(qs):.1f} %" in text, (qs, text)


def test_transverse_motion_from_the_motor_shafts():
    (effects,) = table_with("09_figure6", "alternative", "L2 change (%)", "L3 change (%)")
    alt = effects.column("alternative")
    row = alt.index("shafts rigid (crank roots clamped)")
    l2, l3 = (float(effects.column(c)[row]) for c in ("L2 change (%)", "L3 change (%)"))
    text = _finding("twisting motor shafts")
    assert f"drops by {-l2:.0f} % ($L_2$) and {-l3:.0f} % ($L_3$)" in text, (l2, l3, text)


def test_crank_speed_against_stall_torque():
    (speeds,) = table_with("09_figure6", "crank speed (r/min)", "motor 1 torque (N m)")
    rpm = [float(x) for x in speeds.column("crank speed (r/min)")]
    torque = [float(x) for x in speeds.column("motor 1 torque (N m)")]
    ratio = [float(x) for x in speeds.column("motor 1 torque / stall")]
    rated = [torque[rpm.index(s)] for s in (1440.0, 1500.0)]
    stall = {round(t / r, 1) for t, r in zip(torque, ratio) if r > 0.1}
    assert stall == {2.0}, stall
    text = _finding("{assumption}`crank_speed_rpm`")
    assert f"{min(rated):.0f}-{max(rated):.0f} N m against its stall torque of 2 N m" in text, (rated, text)
    assert f"60 r/min, asks {torque[rpm.index(60.0)]:.2f} N m" in text, (torque, text)


@pytest.mark.parametrize("doc", ["06_newmark", "07_excitation", "08_multiple_scales", "09_figure6"])
def test_each_linked_chapter_exists(doc):
    assert (BOOK / f"{doc}.ipynb").is_file()
    assert f"{{doc}}`{doc}`" in FINDINGS


def test_readers_guide_covers_every_chapter_and_reference_page():
    guide = INDEX[INDEX.index("## Reader's guide"):INDEX.index("## Using this book")]
    toc = (ROOT / "_toc.yml").read_text(encoding="utf-8")
    pages = [Path(f).name for f in re.findall(r"file:\s*(\S+)", toc)]
    missing = [p for p in pages if f"{{doc}}`{p}`" not in guide]
    assert not missing, f"the reader's guide does not link: {missing}"
