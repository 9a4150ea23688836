"""Build the book's other editions: the student edition and the PDF.

Run from the repository root with the project's environment (the Makefile does)::

    .venv/bin/python book/_ext/fivebar_build.py student   # -> _build/student/html
    .venv/bin/python book/_ext/fivebar_build.py pdf       # -> _build/pdf/fivebar.pdf

Both are the same Jupyter Book build as ``make book`` (``_config.yml``, ``_toc.yml``, warnings
are errors, nitpicky), called through jupyter-book's Python API so that Sphinx settings can be
overridden without a second configuration file:

* **student**: ``hide_solutions = True`` (sphinx-exercise).  The ``{solution}`` directives
  then produce no node at all, so the solutions' text is absent from the HTML, not hidden.
  The sources the pages offer for download (``_sources/**.ipynb``, ``.md``) are copies of the
  chapters *with* their solutions, so the student build removes the solution blocks from
  those copies too (:func:`strip_solutions`).
* **pdf**: Sphinx's ``singlehtml`` builder (the whole book on one page, chapters numbered) is
  printed to PDF by the headless Chromium of the browser test (Debian's ``/usr/bin/chromium``
  driven by playwright), after MathJax has typeset every equation, with print CSS (each
  chapter on a new page, no sidebars or buttons, solutions unfolded), the theme's print title
  and table of contents on the first page (with the version and edition added), page numbers
  in the footer and a PDF outline (bookmarks).  The PDF numbers its chapters whether or not
  ``_toc.yml`` does (:func:`numbered_toc`).  ``--edition student`` prints the student edition
  instead.  An up-to-date PDF (newer than every source) is not printed again.

As a Sphinx extension (``sphinx.local_extensions`` in ``_config.yml``) the module adds the role
``{fivebar-pdf}`text```: a download link to the PDF of the edition being built
(``_build/pdf/fivebar.pdf``, or ``fivebar-student.pdf`` when solutions are hidden) if that PDF
exists when the page is read, and otherwise the text followed by "(not built: run ``make
pdf``)" -- so the link is never dead.  A page with the role is re-read whenever the PDF
appears or changes.

Every build reads the notebooks' outputs from the execution cache of ``make book``
(``_build/.jupyter_cache``): nothing is re-executed if the HTML book is up to date.  Each
edition keeps its own Sphinx environment (``.doctrees``) so that alternating builds do not
force each other to re-read every page.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import json
import os
import re
import shutil
import sys
import threading
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
BUILD = ROOT / "_build"
CACHE = BUILD / ".jupyter_cache"  # shared with `make book`
CHROMIUM = os.environ.get("FIVEBAR_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-quic",
]
EDITIONS = ("instructor", "student")
PDF_NAME = "fivebar.pdf"
#: Print scale: the HTML's 16 px body text at 0.8 prints near 10 pt on A4.
SCALE = float(os.environ.get("FIVEBAR_PDF_SCALE", "0.8"))
#: A PDF outline (bookmarks) from the headings.  Chromium makes it only for a tagged
#: (accessible) PDF, which is 2.4 times larger (14.7 MB against 6.1 MB for the book of
#: 2026-11-30); FIVEBAR_PDF_OUTLINE=0 prints the small untagged PDF without bookmarks
#: (tests/test_pdf.py then fails its outline test).
OUTLINE = os.environ.get("FIVEBAR_PDF_OUTLINE", "1") == "1"
#: The single page printed.  Sphinx's singlehtml writes the whole book into the toc's root
#: document (``book/index.html``) but with links relative to the output folder (``_static/``,
#: ``_images/``), so the page is copied there under this name before printing.
PRINT_PAGE = "fivebar.html"


def _sphinx_build(builder: str, outdir: Path, doctreedir: Path, toc: Path,
                  overrides: dict) -> None:
    """One strict jupyter-book build (as ``make book``: -W -n --keep-going)."""
    from jupyter_book.sphinx import build_sphinx

    confoverrides = {
        "external_toc_path": toc.as_posix(),
        "latex_individualpages": False,
        "nitpicky": True,
        "nb_execution_cache_path": str(CACHE),
        **overrides,
    }
    result = build_sphinx(
        ROOT,
        outdir,
        use_external_toc=True,
        noconfig=True,
        path_config=str(ROOT / "_config.yml"),
        confoverrides=confoverrides,
        doctreedir=doctreedir,
        builder=builder,
        warningiserror=True,
        keep_going=True,
    )
    if result != 0:
        raise SystemExit(f"the {builder} build into {outdir} failed (exit {result}); "
                         "see the warnings above")


def _edition_overrides(edition: str) -> dict:
    if edition not in EDITIONS:
        raise SystemExit(f"unknown edition {edition!r}: choose one of {', '.join(EDITIONS)}")
    return {"hide_solutions": edition == "student"}


_FENCE_OPEN = re.compile(r"^[ \t]*(`{3,}|:{3,})[ \t]*\{(solution|solution-start|solution-end)\}")


def strip_solutions(markdown: str) -> tuple[str, int]:
    """Remove every ``{solution}`` block from MyST markdown; return the text and the count.

    A block runs from its opening fence (three or more backticks or colons, then
    ``{solution}``) to the next line that is the same fence character repeated at least as
    often and nothing else.  A gated solution, ``{solution-start}`` ... ``{solution-end}``, is
    removed from the start fence to the end of the end fence, with everything in between.
    """
    lines = markdown.splitlines(keepends=True)
    out: list[str] = []
    i = n = 0
    gated = False
    while i < len(lines):
        m = _FENCE_OPEN.match(lines[i])
        if m is None:
            if not gated:
                out.append(lines[i])
            i += 1
            continue
        fence, kind = m.group(1), m.group(2)
        close = re.compile(r"^[ \t]*" + re.escape(fence[0]) + "{" + str(len(fence)) + r",}[ \t]*$")
        j = i + 1
        while j < len(lines) and not close.match(lines[j]):
            j += 1
        if j == len(lines):
            raise ValueError(f"unclosed {{{kind}}} block (opened with {fence!r}) at line {i + 1}")
        if kind == "solution":
            n += 1
        elif kind == "solution-start":
            n += 1
            gated = True
        else:
            gated = False
        i = j + 1
    if gated:
        raise ValueError("a {solution-start} block has no {solution-end}")
    return "".join(out), n


def strip_notebook_solutions(nb: dict) -> int:
    """Remove the solutions from the markdown cells of a notebook (in place); return the count.

    A gated solution whose ``{solution-start}`` and ``{solution-end}`` lie in different cells
    (code cells between them) is not supported: the book writes each solution inside one
    markdown cell (README, "Exercises in a chapter"), and such a notebook raises ValueError.
    """
    n = 0
    for k, cell in enumerate(nb.get("cells", [])):
        src = cell.get("source", "")
        text = "".join(src) if isinstance(src, list) else src
        if cell.get("cell_type") != "markdown" or "{solution" not in text:
            continue
        try:
            stripped, m = strip_solutions(text)
        except ValueError as err:
            raise ValueError(f"cell {k}: {err}; the student edition needs every solution "
                             "inside one markdown cell") from None
        cell["source"] = stripped
        n += m
    return n


def strip_sources(html: Path) -> int:
    """Remove the solutions from the downloadable sources of a built book; return the count."""
    n = 0
    for path in sorted((html / "_sources").rglob("*")):
        if path.suffix == ".ipynb":
            nb = json.loads(path.read_text(encoding="utf-8"))
            k = strip_notebook_solutions(nb)
            if k:
                path.write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
        elif path.suffix in {".md", ".txt"}:
            text, k = strip_solutions(path.read_text(encoding="utf-8"))
            if k:
                path.write_text(text, encoding="utf-8")
        else:
            continue
        n += k
    return n


def build_student(out: Path = BUILD / "student") -> Path:
    """The student edition (no solutions) in ``_build/student/html``."""
    html = out / "html"
    stamp = html / ".fivebar-build-ok"
    stamp.unlink(missing_ok=True)
    _sphinx_build("html", html, out / ".doctrees", ROOT / "_toc.yml",
                  _edition_overrides("student"))
    n = strip_sources(html)
    print(f"[fivebar_build] removed {n} solutions from the downloadable sources")
    stamp.touch()
    return html


def numbered_toc(src: Path, dst: Path) -> Path:
    """A copy of the table of contents with every part numbered (for the PDF).

    The printed book numbers its chapters whether or not the HTML book does; the numbering
    runs on across parts (``use_multitoc_numbering`` in ``_config.yml``).
    """
    toc = yaml.safe_load(src.read_text())
    for part in toc.get("parts", []):
        part.setdefault("numbered", True)
    text = yaml.safe_dump(toc, sort_keys=False)
    dst.parent.mkdir(parents=True, exist_ok=True)
    if not dst.is_file() or dst.read_text() != text:  # keep mtime: no needless re-read
        dst.write_text(text)
    return dst


# --------------------------------------------------------------------------------------------
# Printing
# --------------------------------------------------------------------------------------------

#: What the printed page hides and how it breaks.  The theme's print styles already hide the
#: sidebars and buttons and show its own title and table of contents (``#jb-print-docs-body``);
#: Sphinx's singlehtml puts each page of the book in a ``div.toctree-wrapper > section``, and
#: each starts on a new sheet.
PRINT_CSS = """
@page { size: A4; }
html, body { background: white !important; }
.bd-header, .bd-header-announcement, .bd-sidebar-primary, .bd-sidebar-secondary,
.bd-header-article, .prev-next-area, .prev-next-footer, footer, .bd-footer,
.bd-footer-content, .bd-footer-article, #pst-back-to-top, .theme-switch-button,
.search-button, .copybtn, .skip-link, .headerlink, button.toggle-button,
label.overlay { display: none !important; }
.bd-container, .bd-container__inner, .bd-page-width, .bd-main, .bd-content,
.bd-article-container, .bd-article { max-width: none !important; width: 100% !important;
  margin: 0 !important; padding: 0 !important; display: block !important; }
#jb-print-docs-body { break-after: page; }
.fivebar-print-subtitle { font-size: 1.2em; margin: 0.5em 0 2em 0; color: #333; }
.fivebar-print-contents { list-style: none; padding-left: 0; line-height: 1.6; }
.toctree-wrapper > section { break-before: page; }
h1, h2, h3, h4 { break-after: avoid; }
figure, img, .cell_output img, mjx-container[display="true"] { break-inside: avoid; }
img { max-width: 100% !important; }
pre { white-space: pre-wrap !important; word-break: break-word; }
.cell_output pre { font-size: 0.8em; }
details > *, .toggle-hidden, .toggle-details__container { display: block !important; }
"""

#: Runs in the page before printing: unfold every dropdown (solutions, hidden code), put the
#: version and edition under the title.  Returns the chapter titles as printed.
PREPARE_JS = r"""
(subtitle) => {
  document.querySelectorAll('details').forEach(d => { d.open = true; });
  document.querySelectorAll('.toggle-hidden').forEach(e => e.classList.remove('toggle-hidden'));
  document.querySelectorAll('.dropdown').forEach(e => e.classList.remove('dropdown'));
  const title = document.querySelector('#jb-print-docs-body h1');
  if (title) {
    const p = document.createElement('p');
    p.className = 'fivebar-print-subtitle';
    p.textContent = subtitle;
    title.after(p);
  }
  const heads = Array.from(document.querySelectorAll('.toctree-wrapper > section > h2'));
  const titles = heads.map(h => h.textContent.replace(/#\s*$/, '').trim());
  // The contents page: the chapters as printed, each a link to its section (the theme's
  // print table of contents lists the first page's own sections, not the book's chapters).
  const toc = document.querySelector('#jb-print-toc');
  if (toc) {
    toc.innerHTML = '';
    const h = document.createElement('h2');
    h.textContent = 'Contents';
    toc.appendChild(h);
    const ul = document.createElement('ul');
    ul.className = 'fivebar-print-contents';
    heads.forEach((head, i) => {
      const li = document.createElement('li');
      const a = document.createElement('a');
      const sec = head.closest('section');
      a.href = '#' + (sec && sec.id ? sec.id : '');
      a.textContent = titles[i];
      li.appendChild(a);
      ul.appendChild(li);
    });
    toc.appendChild(ul);
  }
  return titles;
}
"""

#: Resolves when MathJax has typeset the whole page; returns what it could not typeset.
MATHJAX_JS = r"""
async () => {
  if (!(window.MathJax && MathJax.startup && MathJax.startup.promise)) return {missing: true};
  await MathJax.startup.promise;
  if (MathJax.typesetPromise) await MathJax.typesetPromise();
  const untypeset = Array.from(document.querySelectorAll('.math'))
      .filter(el => !el.querySelector('mjx-container')).length;
  const errors = document.querySelectorAll('mjx-merror, [data-mjx-error]').length;
  return {missing: false, typeset: document.querySelectorAll('mjx-container').length,
          untypeset, errors};
}
"""


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args) -> None:  # noqa: D401 - silence the access log
        pass


def _serve(folder: Path) -> tuple[http.server.ThreadingHTTPServer, str]:
    handler = functools.partial(_QuietHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/"


def _version() -> str:
    for line in (ROOT / "CITATION.cff").read_text().splitlines():
        if line.startswith("version:"):
            return line.split(":", 1)[1].strip().strip('"')
    return "unknown"


def print_pdf(html_dir: Path, pdf: Path, edition: str) -> dict:
    """Print ``html_dir/index.html`` (a singlehtml build) to ``pdf``; return a summary."""
    from playwright.sync_api import sync_playwright

    if not Path(CHROMIUM).is_file():
        raise SystemExit(f"Chromium not found at {CHROMIUM}: install Debian's 'chromium' "
                         "or set FIVEBAR_CHROMIUM to a Chromium binary")
    config = yaml.safe_load((ROOT / "_config.yml").read_text())
    subtitle = f"Version {_version()} \u00b7 {edition} edition \u00b7 {config.get('author', '')}"
    server, url = _serve(html_dir)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS,
                                        headless=True)
            try:
                page = browser.new_page()
                remote: list[str] = []
                page.on("request", lambda r: remote.append(r.url)
                        if not r.url.startswith(url) and not r.url.startswith("data:") else None)
                t0 = time.perf_counter()
                page.goto(url + PRINT_PAGE, wait_until="networkidle", timeout=300_000)
                t1 = time.perf_counter()
                math = page.evaluate(MATHJAX_JS)
                t2 = time.perf_counter()
                if math.get("missing"):
                    raise SystemExit("MathJax did not load in the single-page book")
                if math["untypeset"] or math["errors"]:
                    raise SystemExit(f"MathJax left {math['untypeset']} equations untypeset and "
                                     f"{math['errors']} with TeX errors")
                page.emulate_media(media="print")
                page.add_style_tag(content=PRINT_CSS)
                titles = page.evaluate(PREPARE_JS, subtitle)
                # Images in what was folded may be lazy: load and decode every one.
                broken = page.evaluate("""async () => {
                  const imgs = Array.from(document.images);
                  imgs.forEach(i => { i.loading = 'eager'; });
                  await Promise.all(imgs.map(i => i.decode().catch(() => null)));
                  return imgs.filter(i => !i.complete || i.naturalWidth === 0)
                             .map(i => i.getAttribute('src'));
                }""")
                if broken:
                    raise SystemExit(f"images that do not load in the single-page book: "
                                     f"{broken[:5]}")
                pdf.parent.mkdir(parents=True, exist_ok=True)
                page.pdf(
                    path=str(pdf),
                    format="A4",
                    print_background=True,
                    display_header_footer=True,
                    header_template="<span></span>",
                    footer_template=(
                        '<div style="font-size:8px;width:100%;text-align:center;color:#555">'
                        '<span class="pageNumber"></span> / <span class="totalPages"></span>'
                        "</div>"),
                    margin={"top": "15mm", "bottom": "15mm", "left": "14mm", "right": "14mm"},
                    scale=SCALE,
                    outline=OUTLINE,
                    tagged=OUTLINE,
                )
                t3 = time.perf_counter()
            finally:
                browser.close()
    finally:
        server.shutdown()
    if remote:
        raise SystemExit(f"the single-page book requested resources from other hosts: "
                         f"{sorted(set(remote))[:5]}")
    return {"pdf": str(pdf), "bytes": pdf.stat().st_size, "chapters": titles,
            "equations_typeset": math["typeset"],
            "seconds": {"load": t1 - t0, "mathjax": t2 - t1, "print": t3 - t2}}


def _sources() -> list[Path]:
    """Every file the book is built from (a PDF newer than all of them is up to date)."""
    out = [ROOT / "_config.yml", ROOT / "_toc.yml", ROOT / "CITATION.cff"]
    for folder, pattern in (("book", "**/*"), ("lib/fivebar", "**/*.py"), ("data", "*")):
        out += [p for p in (ROOT / folder).glob(pattern)
                if p.is_file() and ".ipynb_checkpoints" not in p.parts
                and "__pycache__" not in p.parts]
    return out


def build_pdf(edition: str = "instructor", force: bool = False) -> Path:
    """``_build/pdf/fivebar.pdf`` (``fivebar-student.pdf`` for the student edition).

    Nothing is done if the PDF is newer than every source of the book (``force`` rebuilds).
    """
    overrides = _edition_overrides(edition)
    pdf = pdf_path(edition)
    if not force and pdf.is_file():
        built = pdf.stat().st_mtime
        if all(p.stat().st_mtime <= built for p in _sources()):
            print(f"[fivebar_build] {pdf.relative_to(ROOT)} is up to date")
            return pdf
    out = BUILD / "pdf"
    suffix = "" if edition == "instructor" else f"-{edition}"
    html = out / f"singlehtml{suffix}"
    toc = numbered_toc(ROOT / "_toc.yml", out / f"_toc{suffix}.yml")
    t0 = time.perf_counter()
    # the copy of the last build is not a page of this one (the build checks every page's links)
    (html / PRINT_PAGE).unlink(missing_ok=True)
    _sphinx_build("singlehtml", html, out / f".doctrees{suffix}", toc, overrides)
    root = yaml.safe_load(toc.read_text())["root"]
    shutil.copyfile(html / f"{root}.html", html / PRINT_PAGE)
    t1 = time.perf_counter()
    summary = print_pdf(html, pdf, edition)
    t2 = time.perf_counter()
    print(f"[fivebar_build] {pdf.relative_to(ROOT)}: {summary['bytes'] / 1e6:.1f} MB, "
          f"{len(summary['chapters'])} chapters, {summary['equations_typeset']} equations; "
          f"singlehtml {t1 - t0:.0f} s, printing {t2 - t1:.0f} s "
          f"({', '.join(f'{k} {v:.0f} s' for k, v in summary['seconds'].items())})")
    return pdf


# --------------------------------------------------------------------------------------------
# Sphinx extension: the {fivebar-pdf} role
# --------------------------------------------------------------------------------------------


def pdf_path(edition: str) -> Path:
    """Where ``make pdf`` writes the PDF of an edition."""
    return BUILD / "pdf" / (PDF_NAME if edition == "instructor" else f"fivebar-{edition}.pdf")


def _pdf_role(name, rawtext, text, lineno, inliner, options=None, content=None):
    from docutils import nodes
    from sphinx import addnodes

    env = inliner.document.settings.env
    edition = "student" if env.config.hide_solutions else "instructor"
    pdf = pdf_path(edition)
    rel = "/" + pdf.relative_to(ROOT).as_posix()  # "/..." is relative to the source folder
    if pdf.is_file() and env.app.builder.name != "singlehtml":
        node = addnodes.download_reference(rawtext, "", refdoc=env.docname, refdomain="",
                                           reftype="download", refexplicit=True,
                                           reftarget=rel)
        node += nodes.literal(rawtext, text, classes=["xref", "download"])
        size = f" ({pdf.stat().st_size / 1e6:.0f} MB)"
        return [node, nodes.Text(size)], []
    # No PDF (or the PDF itself is being made): plain text, and a dependency on the missing
    # file so that the page is read again once the PDF exists.
    env.note_dependency(pdf.relative_to(ROOT).as_posix())
    if env.app.builder.name == "singlehtml":
        return [nodes.Text(text)], []
    return [nodes.Text(text), nodes.Text(" (not built: run "), nodes.literal("", "make pdf"),
            nodes.Text(")")], []


def _drop_stale_pdf_copies(app, env) -> None:
    """Delete the build's copies of a PDF that has changed since, before Sphinx copies it.

    Sphinx copies download files over an older copy with a message ("will overwrite data")
    that later Sphinx versions turn into a warning, which the strict build would treat as an
    error.
    """
    if app.builder.format != "html":
        return
    for edition in EDITIONS:
        src = pdf_path(edition)
        for old in Path(app.outdir, "_downloads").glob(f"*/{src.name}"):
            if not src.is_file() or old.stat().st_mtime < src.stat().st_mtime:
                old.unlink()


def setup(app):
    """Sphinx entry point: the ``{fivebar-pdf}`` role."""
    app.add_role("fivebar-pdf", _pdf_role)
    app.connect("env-updated", _drop_stale_pdf_copies)
    # myst-nb writes folded code cells (tag hide-input) for the html builder only; the
    # singlehtml build of the PDF needs the same writer (the print CSS unfolds them).
    from myst_nb.sphinx_ import HideCodeCellNode, depart_HideCellInput, visit_HideCellInput

    app.add_node(HideCodeCellNode, override=True,
                 html=(visit_HideCellInput, depart_HideCellInput),
                 singlehtml=(visit_HideCellInput, depart_HideCellInput))
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("target", choices=("student", "pdf"))
    parser.add_argument("--edition", default="instructor", choices=EDITIONS,
                        help="edition printed by `pdf` (default: instructor)")
    parser.add_argument("--force", action="store_true",
                        help="`pdf`: rebuild even if the PDF is newer than every source")
    args = parser.parse_args(argv)
    os.chdir(ROOT)
    if args.target == "student":
        print(f"[fivebar_build] student edition in {build_student().relative_to(ROOT)}")
    else:
        build_pdf(args.edition, force=args.force)
    return 0


if __name__ == "__main__":
    sys.exit(main())
