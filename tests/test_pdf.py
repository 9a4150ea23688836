"""The PDF of the whole book (``make pdf`` -> ``_build/pdf/fivebar.pdf``), read back with pypdf.

What a reader of the PDF needs and what a broken print would lose:

* a sane number of pages (a print that stopped after the first page, or one that repeats the
  book, is far outside the range);
* every page of the table of contents, under its title as the page's first heading says it
  (notebook or markdown), numbered in the order of ``_toc.yml`` and starting a new sheet;
* equations typeset: no TeX source left in the text (``$$``, ``\\begin{``, ``\\(``);
* the figures (at least as many images as the notebooks store PNG outputs) and the
  bibliography (the paper's DOI under "References");
* a PDF outline (bookmarks) with every chapter, each at the top of a new page.

The PDF is built by ``make pdf`` if it is missing or older than the book's sources (the
build reuses the execution cache of ``make book``).  Printing needs Chromium: under CI
(``CI=true``) a missing Chromium fails the test, elsewhere it skips it.
"""

from __future__ import annotations

import json
import os
import re
import sys
from pathlib import Path

import pytest
import yaml

from book_build import make, unavailable

ROOT = Path(__file__).resolve().parents[1]
PDF = ROOT / "_build" / "pdf" / "fivebar.pdf"
sys.path.insert(0, str(ROOT / "book" / "_ext"))
import fivebar_build  # noqa: E402  (book/_ext is not a package)
CHROMIUM = os.environ.get("FIVEBAR_CHROMIUM", "/usr/bin/chromium")
#: Today's book prints on about 210 A4 pages; a truncated or duplicated print falls outside.
PAGES = (100, 600)

pypdf = pytest.importorskip("pypdf")


def _fresh(target: Path) -> bool:
    return target.is_file() and all(p.stat().st_mtime <= target.stat().st_mtime
                                    for p in fivebar_build._sources())


@pytest.fixture(scope="module")
def pdf() -> Path:
    if not _fresh(PDF):
        if not Path(CHROMIUM).is_file():
            unavailable(f"Chromium not found at {CHROMIUM}: the PDF cannot be printed")
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
    # Markdown inline markup to the text a reader sees.
    title = re.sub(r"`([^`]*)`", r"\1", m.group(1))
    title = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", title)
    return title.replace("*", "").strip()


def toc_chapters() -> list[tuple[int, str, Path]]:
    """(number, title, file) of every chapter of ``_toc.yml``, numbered across parts."""
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text())
    out = []
    for part in toc["parts"]:
        for ch in part["chapters"]:
            stem = ROOT / ch["file"]
            path = next(p for p in (stem.with_suffix(".ipynb"), stem.with_suffix(".md"))
                        if p.is_file())
            out.append((len(out) + 1, _first_heading(path), path))
    return out


def test_page_count_and_size(reader, pdf: Path) -> None:
    n = len(reader.pages)
    assert PAGES[0] <= n <= PAGES[1], f"{n} pages, expected {PAGES[0]}-{PAGES[1]}"
    assert 1e6 < pdf.stat().st_size < 100e6, f"{pdf.stat().st_size} bytes"


def test_every_chapter_titled_and_numbered(pages_text: list[str]) -> None:
    text = _squash("\n".join(pages_text))
    chapters = toc_chapters()
    assert len(chapters) >= 10
    missing = [f"{n}. {title}" for n, title, _ in chapters
               if _squash(f"{n}. {title}") not in text]
    assert not missing, f"chapter titles (numbered) not in the PDF text: {missing}"


def test_table_of_contents_first(pages_text: list[str]) -> None:
    front = _squash("\n".join(pages_text[:3]))
    assert _squash("Contents") in front
    for n, title, _ in toc_chapters():
        assert _squash(f"{n}. {title}") in front, f"{title!r} not in the table of contents"


def test_equations_typeset(pages_text: list[str]) -> None:
    raw = {"$$": [], "\\begin{": [], "\\(": [], "\\[": []}
    for i, page in enumerate(pages_text):
        for token in raw:
            if token in page:
                raw[token].append(i + 1)
    assert not any(raw.values()), f"TeX source left in the PDF text (pages): {raw}"


def test_figures_and_bibliography(reader, pages_text: list[str]) -> None:
    # Images: count image XObjects without decoding them.
    images = 0
    for page in reader.pages:
        xobjects = page.get("/Resources", {}).get("/XObject", {})
        for obj in xobjects.values():
            obj = obj.get_object()
            images += obj.get("/Subtype") == "/Image"
    pngs = 0
    for nb in (ROOT / "book").glob("*.ipynb"):
        for cell in json.loads(nb.read_text())["cells"]:
            for out in cell.get("outputs", []):
                pngs += "image/png" in out.get("data", {})
    assert images >= pngs > 0, f"{images} images in the PDF, {pngs} PNG outputs in the notebooks"
    last = _squash("\n".join(pages_text[-15:]))
    assert "10.1155/2011/254547" in last, "the bibliography (the paper's DOI) is not at the end"


def test_outline_has_every_chapter_each_on_a_new_page(reader) -> None:
    """The PDF outline lists every chapter, in order, each at the top of its own page."""
    def entries(items):
        for it in items:
            if isinstance(it, list):
                yield from entries(it)
            else:
                yield it
    found = {}
    for it in entries(reader.outline):
        for n, title, _ in toc_chapters():
            if n not in found and _squash(it.title).startswith(_squash(f"{n}. {title}")):
                found[n] = it
    missing = [t for n, t, _ in toc_chapters() if n not in found]
    assert not missing, f"chapters missing from the PDF outline: {missing}"
    pages, low = [], []
    for n, it in sorted(found.items()):
        page = reader.get_destination_page_number(it)
        pages.append(page)
        height = float(reader.pages[page].mediabox.height)
        if it.top is None or float(it.top) < 0.85 * height:
            low.append((n, page + 1, it.top))
    assert pages == sorted(pages) and len(set(pages)) == len(pages), f"chapter pages {pages}"
    assert not low, f"chapters that do not start at the top of a page (n, page, y): {low}"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))
