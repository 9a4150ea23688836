"""The PDF of the whole book (``make pdf`` -> ``_build/pdf/fivebar.pdf``), read back with pypdf.

What a reader of a printed book needs, and what a broken build would lose:

* a title page (title, version, edition) and a sane number of pages;
* the contents: every part heading of ``_toc.yml`` and every chapter, the chapters of the
  numbered parts with their numbers and the others without, each with a page number, and that
  page (found by its printed page label) opens with the chapter;
* running heads: the pages of a chapter carry its number and title at the top;
* an index of terms (``book/_ext/index_terms.toml``) with page numbers, at the end;
* one numbering: the chapter and exercise numbers of the PDF are those of the HTML book
  (``_build/html``), chapter by chapter;
* no web-only labels ("Hide code cell source"), equations typeset (no TeX source in the text),
  the figures, and the bibliography in the style of the citations ("[Wang et al., 2011]").

The PDF is built by ``make pdf`` if it is missing or older than the book's sources (it reuses
the execution cache of ``make book``).  It needs XeLaTeX: under CI (``CI=true``) a missing TeX
fails the test, elsewhere it skips it.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest
import yaml

from book_build import make, unavailable
from book_checks import built_page_problems

ROOT = Path(__file__).resolve().parents[1]
PDF = ROOT / "_build" / "pdf" / "fivebar.pdf"
HTML = ROOT / "_build" / "html"
sys.path.insert(0, str(ROOT / "book" / "_ext"))
import fivebar_build  # noqa: E402  (book/_ext is not a package)
import fivebar_index  # noqa: E402
#: The book (without the API reference) typesets on about 160 A4 pages.
PAGES = (100, 400)

pypdf = pytest.importorskip("pypdf")


def _fresh(target: Path) -> bool:
    return target.is_file() and all(p.stat().st_mtime <= target.stat().st_mtime
                                    for p in fivebar_build._sources())


@pytest.fixture(scope="module")
def pdf() -> Path:
    if not _fresh(PDF):
        missing = fivebar_build.missing_tex_tools()
        if missing:
            unavailable(f"{', '.join(missing)} not found: the PDF cannot be typeset")
        make("pdf", PDF)
    return PDF


@pytest.fixture(scope="module")
def reader(pdf: Path):
    return pypdf.PdfReader(pdf)


@pytest.fixture(scope="module")
def pages_text(reader) -> list[str]:
    return [page.extract_text() or "" for page in reader.pages]


def _squash(text: str) -> str:
    """Text compared without whitespace, ligatures, hyphenation or typographic quotes."""
    for a, b in (("\ufb01", "fi"), ("\ufb02", "fl"), ("\ufb00", "ff"), ("\ufb03", "ffi"),
                 ("\ufb04", "ffl"), ("\u2019", "'"), ("\u2018", "'"), ("\u201c", '"'),
                 ("\u201d", '"'), ("\u00ad", ""), ("\u2013", "-"), ("\u2014", "-")):
        text = text.replace(a, b)
    return re.sub(r"\s+", "", text)


def _first_heading(path: Path) -> str:
    """The first level-1 heading of a chapter (markdown page or notebook)."""
    if path.suffix == ".ipynb":
        nb = json.loads(path.read_text())
        text = "\n".join("".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "markdown")
    else:
        text = path.read_text()
    m = re.search(r"^# (.+)$", text, re.M)
    assert m, f"{path.name} has no level-1 heading"
    title = re.sub(r"`([^`]*)`", r"\1", m.group(1))
    title = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", title)
    return title.replace("*", "").strip()


def toc_parts() -> list[tuple[str, list[tuple[int | None, str, Path]]]]:
    """(caption, [(number or None, title, file)]) of every part of ``_toc.yml``: the chapters
    of the numbered parts are numbered on across parts, as in the HTML book."""
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text())
    out, n = [], 0
    for part in toc["parts"]:
        chapters = []
        for ch in part["chapters"]:
            stem = ROOT / ch["file"]
            path = next(p for p in (stem.with_suffix(".ipynb"), stem.with_suffix(".md"))
                        if p.is_file())
            if ch["file"] in {fivebar_build_api(), "book/references"}:
                continue  # not printed as pages of their own (book/_ext/fivebar_latex.py)
            number = None
            if part.get("numbered"):
                n += 1
                number = n
            chapters.append((number, _first_heading(path), path))
        out.append((part["caption"], chapters))
    return out


def fivebar_build_api() -> str:
    import fivebar_latex

    return fivebar_latex.API_DOC


def _chapters() -> list[tuple[int | None, str, Path]]:
    return [ch for _, chapters in toc_parts() for ch in chapters]


def _contents(pages_text: list[str], reader) -> str:
    """The text of the contents pages (labelled in roman numerals before page 1)."""
    labels = reader.page_labels
    return "\n".join(t for t, lab in zip(pages_text, labels)
                     if re.fullmatch(r"[ivxlc]+", lab))


def _pdf_chapters(reader, pages_text: list[str]) -> dict[str, tuple[int | None, int]]:
    """{title: (number the PDF gives it or None, index of its first page)} from the contents."""
    contents = [_squash(line) for line in _contents(pages_text, reader).splitlines()]
    labels = reader.page_labels
    body = {lab: i for i, lab in enumerate(labels) if lab.isdigit() and i > 0}
    out = {}
    for _, title, _ in _chapters():
        pattern = re.compile(r"(\d*)" + re.escape(_squash(title)) + r"\.*(\d+)")
        for line in contents:
            m = pattern.fullmatch(line)
            if m and m.group(2) in body:
                out[title] = (int(m.group(1)) if m.group(1) else None, body[m.group(2)])
                break
    return out


def _chapter_pages(reader, pages_text: list[str]) -> dict[str, int]:
    return {t: page for t, (_, page) in _pdf_chapters(reader, pages_text).items()}


def test_title_page_and_page_count(reader, pages_text: list[str], pdf: Path) -> None:
    n = len(reader.pages)
    assert PAGES[0] <= n <= PAGES[1], f"{n} pages, expected {PAGES[0]}-{PAGES[1]}"
    assert 1e6 < pdf.stat().st_size < 100e6, f"{pdf.stat().st_size} bytes"
    title = _squash(pages_text[0])
    config = yaml.safe_load((ROOT / "_config.yml").read_text())
    assert _squash(config["title"].split(":")[0]) in title
    assert _squash(f"Version {fivebar_build._version()}") in title
    assert "Instructoredition" in title


def test_contents_have_parts_numbers_and_page_numbers(reader, pages_text: list[str]) -> None:
    contents = _contents(pages_text, reader)
    lines = [_squash(line) for line in contents.splitlines()]
    assert lines and lines[0] == "Contents", "no contents page after the title page"
    for caption, _ in toc_parts():
        assert any(re.fullmatch(re.escape(_squash(caption)) + r"\d+", ln) for ln in lines), \
            f"part heading {caption!r} without a page number in the contents"
    found = _pdf_chapters(reader, pages_text)
    missing = [t for n, t, _ in _chapters() if t not in found]
    assert not missing, f"chapters not in the contents (with a page number): {missing}"
    numbers = [(t, n, found[t][0]) for n, t, _ in _chapters() if found[t][0] != n]
    assert not numbers, f"chapters numbered otherwise than _toc.yml's numbered parts (title, toc, PDF): {numbers}"
    pages = _chapter_pages(reader, pages_text)
    wrong = []
    for number, title, _ in _chapters():
        head = _squash(pages_text[pages[title]])[:400]
        if _squash(title) not in head:
            wrong.append((title, pages[title] + 1))
    assert not wrong, f"the contents' page does not open the chapter (title, PDF page): {wrong}"
    order = [pages[t] for _, t, _ in _chapters()]
    assert order == sorted(order)


def test_running_heads(reader, pages_text: list[str]) -> None:
    """Every page of a numbered chapter after its first carries "Chapter N. Title" on top."""
    found = _pdf_chapters(reader, pages_text)
    pages = _chapter_pages(reader, pages_text)
    chapters = [c for c in _chapters() if c[1] in found]
    assert len(chapters) >= 10
    bad = []
    for k, (_, title, _) in enumerate(chapters):
        number = found[title][0]
        if number is None:
            continue
        start = pages[title]
        end = pages[chapters[k + 1][1]] if k + 1 < len(chapters) else start + 1
        # the page before the next chapter may be that part's title page: stop at it
        for i in range(start + 1, end):
            first = _squash(pages_text[i].splitlines()[0] if pages_text[i] else "")
            if not _squash(pages_text[i]):
                continue
            if not first.startswith(_squash(f"Chapter {number}. {title}")[:40]):
                part_page = any(re.fullmatch(re.escape(_squash(c)) + r"\d*", _squash(pages_text[i]))
                                for c, _ in toc_parts())
                if not part_page:
                    bad.append((number, i + 1, first[:50]))
    assert not bad, f"pages without their chapter's running head (chapter, page, top line): {bad[:8]}"


def test_index_of_terms(reader, pages_text: list[str]) -> None:
    start = len(pages_text)
    while start > 1 and pages_text[start - 1].lstrip().startswith("Index"):
        start -= 1  # the index's pages: titled "Index", then headed "Index"
    assert len(pages_text) - 15 < start < len(pages_text), "no index at the end of the book"
    text = "\n".join(pages_text[start:])
    entries = re.findall(r"^(.+?),\s*([\d,\s\u2013-]+)$", text, re.M)
    terms = [e.split(";")[-1].strip() for e, _ in fivebar_index.load_terms()]
    found = {_squash(name) for name, _ in entries}
    missing = [t for t in terms if _squash(t) not in found]
    assert len(entries) >= 0.8 * len(terms), f"only {len(entries)} index entries with page numbers"
    assert len(missing) <= 0.2 * len(terms), f"terms not in the index: {missing}"
    last = len([lab for lab in reader.page_labels if lab.isdigit()])
    numbers = [int(x) for _, pages in entries for x in re.findall(r"\d+", pages)]
    # page numbers of the book (pypdf drops the en dash of a range "7-9": "79" is skipped)
    assert numbers and sum(n <= last for n in numbers) >= 0.8 * len(numbers), numbers[:40]


def _html_numbers() -> dict[str, tuple[int | None, list[str]]]:
    """{chapter title: (number, [exercise numbers])} as the HTML book shows them."""
    out = {}
    for number, title, path in _chapters():
        page = HTML / path.relative_to(ROOT).with_suffix(".html")
        text = page.read_text(encoding="utf-8")
        m = re.search(r'<h1><span class="section-number">(\d+)\. </span>', text)
        captions = {kind: re.findall(r'<span class="caption-number">%s (\d+(?:\.\d+)*) </span>'
                                     % re.escape(kind), text)
                    for kind in ("Exercise", "Fig.", "Table")}
        out[title] = (int(m.group(1)) if m else None, captions)
    return out


def _pdf_captions(text: str) -> dict[str, list[str]]:
    """Exercise, figure and table numbers of a chapter's pages as printed (captions only)."""
    return {"Exercise": re.findall(r"^\s*Exercise\s*(\d+(?:\.\d+)*)\s*$", text, re.M),
            "Fig.": re.findall(r"^\s*Fig\.\s*(\d+(?:\.\d+)*):", text, re.M),
            "Table": re.findall(r"^\s*Table\s*(\d+(?:\.\d+)*):", text, re.M)}


@pytest.fixture(scope="module")
def html_numbers() -> dict[str, tuple[int | None, list[str]]]:
    if not (HTML / ".fivebar-build-ok").is_file() or not _fresh(HTML / ".fivebar-build-ok"):
        make("book", HTML / ".fivebar-build-ok")
    return _html_numbers()


def test_html_and_pdf_numbers_agree(reader, pages_text: list[str], html_numbers) -> None:
    """Chapter, exercise, figure and table numbers: the PDF's are the HTML's, chapter by
    chapter (figures and tables as their captions number them)."""
    found = _pdf_chapters(reader, pages_text)
    pages = _chapter_pages(reader, pages_text)
    chapters = _chapters()
    assert sum(len(c["Exercise"]) for _, c in html_numbers.values()) >= 20
    mismatches = [f"{t}: not in the PDF's contents" for _, t, _ in chapters if t not in found]
    chapters = [c for c in chapters if c[1] in found]
    for k, (_, title, _) in enumerate(chapters):
        number = found[title][0]
        html_number, html_captions = html_numbers[title]
        if html_number != number:
            mismatches.append(f"{title}: chapter {html_number} in the HTML, {number} in the PDF")
        end = pages[chapters[k + 1][1]] if k + 1 < len(chapters) else len(pages_text)
        text = "\n".join(pages_text[pages[title]:end])
        pdf_captions = _pdf_captions(text)
        for kind, html_list in html_captions.items():
            if pdf_captions[kind] != html_list:
                mismatches.append(f"{title}: {kind} {html_list} in the HTML, "
                                  f"{pdf_captions[kind]} in the PDF")
    assert not mismatches, "numbers differ between HTML and PDF:\n" + "\n".join(mismatches)


def test_no_web_labels_and_equations_typeset(pages_text: list[str]) -> None:
    text = "\n".join(pages_text)
    for label in ("Hide code cell", "Show code cell", "Skip to main content", "Back to top"):
        assert label not in text, f"web-only label {label!r} in the PDF"
    raw = {tok: [i + 1 for i, p in enumerate(pages_text) if tok in p]
           for tok in ("$$", "\\begin{", "\\(", "\\[")}
    assert not any(raw.values()), f"TeX source left in the PDF text (pages): {raw}"


def test_figures_and_bibliography(reader, pages_text: list[str]) -> None:
    images = 0
    for page in reader.pages:
        xobjects = page.get("/Resources", {}).get("/XObject", {})
        for obj in xobjects.values():
            obj = obj.get_object()
            images += obj.get("/Subtype") in ("/Image", "/Form")
    pngs = 0
    for nb in (ROOT / "book").glob("[0-9][0-9]_*.ipynb"):
        for cell in json.loads(nb.read_text())["cells"]:
            for out in cell.get("outputs", []):
                pngs += "image/png" in out.get("data", {})
    assert images >= pngs > 0, f"{images} images in the PDF, {pngs} PNG outputs in the chapters"
    # one citation style: "[Wang et al., 2011]" in the text and as the bibliography's label
    text = _squash("\n".join(pages_text))
    assert text.count(_squash("[Wang et al., 2011]")) >= 2
    assert "[WCZ11]" not in text
    refs = next(i for i in range(len(pages_text) - 1, 0, -1)
                if pages_text[i].lstrip().startswith("References"))
    assert "10.1155/2011/254547" in _squash("\n".join(pages_text[refs:refs + 4]))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))


def test_long_words_in_table_cells_get_break_points() -> None:
    """A long word in a table cell (the errata's "Verified by" test names, code) may break after
    ``_ . / :: ( , =`` in the PDF: TeX does not hyphenate it, so it ran past its column.  Short words
    and the text itself are left as they are (the break points are raw LaTeX)."""
    from docutils import nodes

    import fivebar_latex

    name = "tests/test_elements.py::test_mass_matrix_x"
    long_code, short_code = nodes.literal(text=name), nodes.literal(text="steady_state")
    prose = nodes.Text("by test_every_interpolation_condition_holds, e.g. this")
    cell = nodes.entry("", nodes.paragraph("", "", long_code, nodes.Text(" and "), short_code),
                       nodes.paragraph("", "", prose))
    table = nodes.table("", nodes.tgroup("", nodes.tbody("", nodes.row("", cell))))
    fivebar_latex._breakable_words(table, fivebar_latex.TABLE_WORD_CHARS)
    breaks = list(long_code.findall(nodes.raw))
    assert len(breaks) == 7  # after / _ . :: _ _ _
    assert all(b.astext() == r"\allowbreak{}" and b["format"] == "latex" for b in breaks)
    assert "".join(t for t in long_code.findall(nodes.Text) if t.parent is long_code) == name
    assert not list(short_code.findall(nodes.raw)) and short_code.astext() == "steady_state"
    para = cell.children[1]
    assert len(list(para.findall(nodes.raw))) == 4  # after the four _ of the long word only
    assert "".join(t for t in para.findall(nodes.Text) if t.parent is para) == str(prose)


def test_computed_prose_is_set_as_the_text_and_code_output_as_output() -> None:
    """A cell whose output is Markdown prose (a paragraph, a list: numbers the chapter computed)
    leaves its output container, so that it is not set as a code cell's output (indented, small:
    sphinx-jupyterbook-latex wraps every ``cell_output`` container in ``sphinxVerbatimOutput``);
    an output with printed text, a figure or a table keeps it, and so does a container that is not
    a cell's output."""
    from docutils import nodes

    import fivebar_latex

    def output(*children, classes=("cell_output",)):
        return nodes.container("", *children, classes=list(classes))
    prose = output(nodes.paragraph(text="Along the cycle ..."),
                   nodes.bullet_list("", nodes.list_item("", nodes.paragraph(text="a point"))))
    kept = [output(nodes.literal_block(text="printed")),
            output(nodes.paragraph(text="see the figure"), nodes.image(uri="fig.png")),
            output(nodes.paragraph(text="a caption"), nodes.table()),
            output(nodes.paragraph(text="not an output"), classes=("cell_input",))]
    section = nodes.section("", prose, *kept)
    fivebar_latex._unwrap_prose_outputs(section)
    assert [type(c) for c in section.children[:2]] == [nodes.paragraph, nodes.bullet_list]
    assert section.children[2:] == kept


#: LaTeX's overfull boxes wider than this (pt; 10 pt is 3.5 mm) are text past the edge of its
#: column or of the page that a reader sees
OVERFULL_PT = 10.0


def test_nothing_runs_past_its_column_or_the_page(pdf: Path) -> None:
    """The typesetting log (``_build/pdf/latex/fivebar.log``) has no overfull line box wider than
    :data:`OVERFULL_PT`: a long test name in the errata, a call written out in the prose or a
    too-wide display equation printed past the edge (38 of them before the break points of
    ``book/_ext/fivebar_latex.py``, the widest 205 pt)."""
    log = pdf.parent / "latex" / (pdf.stem + ".log")
    assert log.is_file(), f"{log} is missing: the PDF's typesetting log"
    text = log.read_text(errors="replace")
    wide = [(float(m.group(1)), m.group(2), text[m.end():m.end() + 120].strip().splitlines()[0])
            for m in re.finditer(r"Overfull \\hbox \(([\d.]+)pt too wide\) ([^\n]*)", text)
            if float(m.group(1)) > OVERFULL_PT]
    assert not wide, f"{len(wide)} line(s) past the text width: " + "; ".join(
        f"{w:.0f} pt {where}: {snippet!r}" for w, where, snippet in wide[:8])


def test_no_developer_output_in_the_pdf(reader, pages_text: list[str]) -> None:
    """No page of the PDF shows developer output (tests/book_checks.py), each page checked with
    the rules of the chapter it belongs to (the errata and the maintainers' map may name tests)."""
    starts = sorted((page, path) for (_, title, path) in _chapters()
                    for t, page in _chapter_pages(reader, pages_text).items() if t == title)
    problems = []
    for i, text in enumerate(pages_text):
        owner = [path for page, path in starts if page <= i]
        doc = owner[-1].relative_to(ROOT).with_suffix("").as_posix() if owner else "front matter"
        problems += [f"page {i + 1} ({doc}): {p}" for p in built_page_problems(text, doc)]
    assert not problems, "developer output in the PDF:\n" + "\n".join(problems[:40])
