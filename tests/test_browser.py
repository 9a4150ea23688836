"""The built book as a reader sees it: every page in a real browser, offline.

Two groups of tests on ``_build/html``:

* static checks of the HTML (no browser): no page loads a script, stylesheet, font or image
  from another host; MathJax is served from the build; every module of the library is in
  the API reference; every notebook in book/ is in the table of contents;
* a headless Chromium (Debian's ``/usr/bin/chromium`` driven by playwright) opens every page
  from a local HTTP server and checks that it loads, that every resource it requests answers
  200 and none is requested from another host, that no JavaScript error is logged, that
  every image decodes, that MathJax typesets every equation, that the download links of the
  chapters work, and that the search page finds a word of a chapter;
* the reader's edition (``test_page_reads_as_a_book``): every page of the table of contents
  at 1400x900 and at 390x844 has nothing cut off (no element past the text column unless it
  scrolls inside its own box; at 1400 px not even that for tables, equations and code; no
  horizontal scrolling of the page; no content clipped by ``overflow: hidden``), no visible
  ``assert`` in code cells, raster figures of at least 1.5x their displayed pixel width (or
  SVG), every mention of an erratum (``E26``) in the prose a link, and chapter titles
  numbered.  Every violation, naming page, element and measured value, goes to
  ``_build/screenshots/violations.json``.  Every page must pass.  With ``FIVEBAR_SCREENSHOTS=1``
  (``make screenshots``) a screenshot of every page at both sizes goes there too (JPEG, the
  whole page up to ``SHOT_MAX_HEIGHT``): for looking at a page as a reader would; ``make
  test`` leaves them out (they were a third of this file's time).

Each page is opened once per window size, and that one load serves all its checks (the load
checks above, the reader's checks, the screenshot); the pages outside the table of contents
are opened once, at the end, for the load checks alone.

The book is built by ``make book`` (``make test`` depends on it).  If ``_build/html`` is
missing or older than its sources, the ``book`` fixture runs ``make book`` itself.  Under CI
(``CI=true``) the browser tests are required: a missing Chromium or book fails them; on a
machine without Chromium they are skipped with the reason.  Set ``FIVEBAR_CHROMIUM`` to use
another Chromium binary.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import os
import re
import threading
import urllib.parse
from collections.abc import Iterator
from pathlib import Path

import pytest
from book_build import book_extension as _extension, make, unavailable
from book_checks import built_page_problems

ROOT = Path(__file__).resolve().parents[1]
HTML = ROOT / "_build" / "html"
STAMP = HTML / ".fivebar-build-ok"  # written by `make book` after a build without warnings
SCREENSHOTS = ROOT / "_build" / "screenshots"
#: The browser (Debian's chromium) and its headless flags: no network of its own, no updates.
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
#: A word the search page must find (it is in the introduction and in the chapters).
SEARCH_WORD = "linkage"


# --------------------------------------------------------------------------------------------
# The built book
# --------------------------------------------------------------------------------------------


def _sources() -> Iterator[Path]:
    yield ROOT / "_config.yml"
    yield ROOT / "_toc.yml"
    for folder, pattern in (("book", "**/*"), ("lib/fivebar", "**/*.py"), ("data", "*")):
        for p in (ROOT / folder).glob(pattern):
            if p.is_file() and ".ipynb_checkpoints" not in p.parts and "__pycache__" not in p.parts:
                yield p


def book_is_fresh() -> bool:
    """True if the last successful ``make book`` is newer than every source of the book."""
    if not STAMP.is_file():
        return False
    built = STAMP.stat().st_mtime
    return all(p.stat().st_mtime <= built for p in _sources())


@pytest.fixture(scope="session")
def book() -> Path:
    """``_build/html``, built (``make book``) if it is missing or stale."""
    if not book_is_fresh():
        make("book", STAMP)
    return HTML


def _pages(html: Path) -> list[Path]:
    return sorted(p for p in html.rglob("*.html")
                  if not p.relative_to(html).parts[0].startswith("_"))


def _chapter_notebooks() -> list[Path]:
    return sorted((ROOT / "book").glob("[0-9]*.ipynb"))


# --------------------------------------------------------------------------------------------
# Static checks (no browser)
# --------------------------------------------------------------------------------------------

_REMOTE = re.compile(r"^\s*(https?:)?//", re.I)
_TAG = re.compile(r"<(script|link|img|source|iframe|embed|object|audio|video)\b[^>]*>", re.I | re.S)
_ATTR = re.compile(r"\b(src|href|data|srcset)\s*=\s*(\"[^\"]*\"|'[^']*')", re.I)


def _remote_resources(page: Path) -> list[str]:
    """Remote URLs a page would load: script/img/iframe sources and <link> resources.

    Hyperlinks (<a href>) are not resources and are allowed; so are <link rel=...> that do
    not load anything (canonical, index, search, next, prev).
    """
    bad = []
    for tag in _TAG.finditer(page.read_text(encoding="utf-8")):
        text = tag.group(0)
        name = tag.group(1).lower()
        if name == "link":
            rel = re.search(r"\brel\s*=\s*[\"']([^\"']*)", text, re.I)
            rels = set((rel.group(1) if rel else "").lower().split())
            if not rels & {"stylesheet", "preload", "modulepreload", "icon", "manifest",
                           "prefetch", "preconnect", "dns-prefetch"}:
                continue
        for attr in _ATTR.finditer(text):
            for url in attr.group(2)[1:-1].split(","):
                if _REMOTE.match(url):
                    bad.append(f"<{name} {attr.group(1)}={url.strip()}>")
    return bad


def test_no_page_loads_anything_remote(book):
    pages = _pages(book)
    assert len(pages) >= 5, f"only {len(pages)} pages in {book}"
    bad = {str(p.relative_to(book)): r for p in pages if (r := _remote_resources(p))}
    assert not bad, f"pages load remote resources: {bad}"


def test_no_stylesheet_loads_remote_fonts_or_images(book):
    bad = []
    for css in (book / "_static").rglob("*.css"):
        text = re.sub(r"/\*.*?\*/", "", css.read_text(encoding="utf-8", errors="replace"),
                      flags=re.S)
        for m in re.finditer(r"(url\(\s*[\"']?|@import\s+[\"'])\s*((https?:)?//[^\"')\s]+)", text):
            bad.append(f"{css.relative_to(book)}: {m.group(2)}")
    assert not bad, f"stylesheets load remote resources: {bad}"


def test_mathjax_is_served_from_the_build(book):
    mathjax = book / "_static" / "mathjax"
    assert (mathjax / "tex-mml-chtml.js").is_file()
    fonts = list((mathjax / "output" / "chtml" / "fonts" / "woff-v2").glob("*.woff"))
    assert len(fonts) > 10, "MathJax's CHTML fonts are missing"
    with_math = [p for p in _pages(book) if 'class="math' in p.read_text(encoding="utf-8")]
    assert with_math, "no page with math: the check below would be empty"
    for page in with_math:
        text = page.read_text(encoding="utf-8")
        assert re.search(r"<script[^>]*src=\"[./]*_static/mathjax/tex-mml-chtml\.js", text), \
            f"{page.relative_to(book)} does not load the local MathJax"


def test_no_developer_output_on_the_built_pages(book):
    """The text of every built page (its article: what a reader sees, scripts and styles left out)
    shows no developer output (tests/book_checks.py: paths, reprs of display objects, warnings'
    file and line, progress bars, test files, issue numbers), as built, whatever the stored
    notebooks held and however myst-nb chose among an output's formats."""
    from bs4 import BeautifulSoup

    problems = []
    for page in _pages(book):
        doc = page.relative_to(book).with_suffix("").as_posix()
        soup = BeautifulSoup(page.read_text(encoding="utf-8"), "html.parser")
        main = soup.find("article") or soup.body or soup
        for tag in main(["script", "style"]):
            tag.decompose()
        problems += [f"{doc}.html: {p}" for p in built_page_problems(main.get_text(" "), doc)]
    assert not problems, "developer output on the built pages:\n" + "\n".join(problems[:40])


@pytest.mark.parametrize(
    "text, cited",
    [("eq. (A.6)", {"A.6"}),
     ("(A.9)-(A.12) and (2.7)", {"A.9", "A.10", "A.11", "A.12", "2.7"}),
     ("(3.1)–(3.3)", {"3.1", "3.2", "3.3"}),
     ("(2.10) then (4.4)", {"2.10", "4.4"}),
     ("(P2.7) and (PA.9)-(PA.12)", {"2.7", "A.9", "A.10", "A.11", "A.12"}),
     ("(A.9)-(2.3)", {"A.9", "2.3"}),  # not a range: different sections
     ("f(1.5), (5.2), x (A) . 3, version (0.1)", set())],
)
def test_equation_citations_are_read_as_written(text, cited):
    assert _extension().cited_equations(text) == cited


def test_absolute_value_bars_are_escaped_in_prose_only():
    lines = ["error |a - b| / |b|, ``|x|`` and :math:`|x|` stay", ".. math::", "",
             "    |x| = 1", "", "Example::", "", "    y = |z|", "", "then |w''|", ">>> f()  # |x|"]
    _extension()._escape_bars(None, "function", "f", None, None, lines)
    assert lines == [r"error \|a - b\| / \|b\|, ``|x|`` and :math:`|x|` stay", ".. math::", "",
                     "    |x| = 1", "", "Example::", "", "    y = |z|", "", r"then \|w''\|",
                     ">>> f()  # |x|"]


def test_generated_pages_are_complete(book):
    """The equation index has every equation of the paper, the errata every entry."""
    import tomllib

    def rows(page: str, cls: str) -> int:
        html = (book / "book" / page).read_text(encoding="utf-8")
        table = re.search(rf'<table class="{cls}[^"]*".*?</table>', html, re.S)
        assert table, f"no table {cls} in {page}"
        return len(re.findall(r"<tr", table.group(0))) - 1  # minus the header row

    paper = 10 + 7 + 4 + 12  # (2.1)-(2.10), (3.1)-(3.7), (4.1)-(4.4), (A.1)-(A.12)
    assert rows("equations.html", "fivebar-equations") == paper
    with open(ROOT / "data" / "errata.toml", "rb") as fh:
        errata = tomllib.load(fh)["erratum"]
    assert rows("errata.html", "fivebar-errata") == len(errata)
    with open(ROOT / "data" / "wang2011.toml", "rb") as fh:
        assumptions = tomllib.load(fh)["assumptions"]
    assert rows("errata.html", "fivebar-assumptions") == len(assumptions)


def test_every_library_module_is_in_the_api_reference():
    api = (ROOT / "book" / "api.md").read_text(encoding="utf-8")
    documented = set(re.findall(r"automodule::\s*(fivebar\.[\w.]+)", api))
    lib = ROOT / "lib"
    modules = {".".join(p.relative_to(lib).with_suffix("").parts) for p in (lib / "fivebar").rglob("*.py")
               if not p.stem.startswith("_")}
    missing = sorted(modules - documented)
    assert not missing, f"add these modules to book/api.md (an automodule section each): {missing}"


def test_every_chapter_notebook_is_in_the_toc():
    toc = (ROOT / "_toc.yml").read_text(encoding="utf-8")
    listed = set(re.findall(r"file:\s*(\S+)", toc))
    missing = [str(nb.relative_to(ROOT)) for nb in _chapter_notebooks()
               if str(nb.relative_to(ROOT).with_suffix("")) not in listed]
    assert not missing, f"notebooks not in _toc.yml (they would not be built): {missing}"


# --------------------------------------------------------------------------------------------
# The browser
# --------------------------------------------------------------------------------------------


class _Handler(http.server.SimpleHTTPRequestHandler):
    def end_headers(self) -> None:
        # No caching: every request reaches the server and must answer 200 (not 304).
        self.send_header("Cache-Control", "no-store")
        super().end_headers()

    def log_message(self, *args) -> None:  # quiet
        pass


@contextlib.contextmanager
def _serving(directory: Path) -> Iterator[str]:
    """``directory`` served on a free local port (no caching) while the block runs; its URL."""
    handler = functools.partial(_Handler, directory=str(directory))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()
        httpd.server_close()


@pytest.fixture(scope="module")
def server(book) -> Iterator[str]:
    with _serving(book) as url:
        yield url


@pytest.fixture(scope="module")
def browser(book, tmp_path_factory):
    """A fresh headless Chromium context; requests to any other host are refused."""
    if not os.access(CHROMIUM, os.X_OK):
        unavailable(f"Chromium not found at {CHROMIUM} (apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        unavailable("playwright for Python is not installed")
    pw = sync_playwright().start()
    context = pw.chromium.launch_persistent_context(
        str(tmp_path_factory.mktemp("chromium-profile")),
        executable_path=CHROMIUM,
        headless=True,
        args=CHROMIUM_ARGS,
        viewport={"width": 1280, "height": 900},
    )
    outside: list[str] = []

    def route(r):
        host = urllib.parse.urlsplit(r.request.url).hostname
        if host in ("127.0.0.1", "localhost"):
            r.continue_()
        else:
            outside.append(r.request.url)
            r.abort()

    context.route("**/*", route)
    context.outside_requests = outside
    try:
        yield context
    finally:
        context.close()
        pw.stop()


_WAIT_FOR_PAGE = """async () => {
    if (document.readyState !== 'complete') {  // a page navigated to: still loading
        await new Promise(resolve => window.addEventListener('load', resolve, {once: true}));
    }
    for (const img of document.images) { img.loading = 'eager'; }
    if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
        await MathJax.startup.promise;
    }
    await Promise.all(Array.from(document.images, img => img.decode().catch(() => null)));
    await document.fonts.ready;
}"""

_INSPECT_PAGE = """() => {
    const bad = (sel) => Array.from(document.querySelectorAll(sel));
    return {
        broken_images: Array.from(document.images)
            .filter(img => !(img.complete && img.naturalWidth > 0))
            .map(img => img.getAttribute('src')),
        display_math: document.querySelectorAll('div.math').length,
        display_untypeset: bad('div.math')
            .filter(el => !el.querySelector('mjx-container[display="true"]'))
            .map(el => el.textContent.trim().slice(0, 80)),
        display_typeset: document.querySelectorAll('mjx-container[display="true"]').length,
        inline_untypeset: bad('span.math')
            .filter(el => !el.querySelector('mjx-container'))
            .map(el => el.textContent.trim().slice(0, 80)),
        tex_errors: (window.MathJax && MathJax.startup && MathJax.startup.document
                     ? Array.from(MathJax.startup.document.math) : [])
            .filter(item => item.typesetRoot && item.typesetRoot.querySelector
                    && item.typesetRoot.querySelector('mjx-merror, [data-mjx-error]'))
            .map(item => item.math.slice(0, 80)),
        downloads: bad('a.btn-download-source-button, a[href$=".ipynb"]')
            .map(a => a.href),
        source_downloads: bad('a.btn-download-source-button').map(a => a.href),
    };
}"""


#: The page waited for, then inspected, in one evaluation: both see the same document (a page
#: that navigates between the two would otherwise be inspected while it typesets).
_SETTLE_AND_INSPECT = f"async () => {{ await ({_WAIT_FOR_PAGE})(); return ({_INSPECT_PAGE})(); }}"
#: A page that sends the browser on to another (the book's root index.html: a meta refresh).
_REDIRECTS = """() => !!document.querySelector('meta[http-equiv="refresh" i]')"""


def _settle(page) -> dict:
    """Wait until the page (after any redirect) has typeset its math, decoded its images and
    loaded its fonts; return what ``_INSPECT_PAGE`` finds there.

    The page is awaited for what it does, not for a quiet network: Playwright's "networkidle"
    (no request for 500 ms), waited twice, cost about a second a page, a minute of the file.  A
    redirect is followed first (its navigation awaited), so the page inspected is the one it
    leads to."""
    for attempt in range(4):
        try:
            if page.evaluate(_REDIRECTS):
                start = page.url
                page.wait_for_url(lambda url: url != start)
                page.wait_for_load_state("load")
                continue
            return page.evaluate(_SETTLE_AND_INSPECT)
        except Exception as exc:  # a redirect page navigates while we look at it
            if "context was destroyed" not in str(exc) or attempt == 3:
                raise
            page.wait_for_load_state("load")
    raise AssertionError(f"{page.url}: still redirecting after {attempt + 1} pages")


def _check_page(context, url: str, viewport: dict | None = None, *, fetch_downloads: bool = True,
                reader: dict | None = None, screenshot: Path | None = None
                ) -> tuple[list[str], dict, list[dict] | None]:
    """Open one page (at a window size); return its problems, what was inspected, and the reader's
    checks (``_READER_CHECKS`` with the options ``reader``) if asked.

    One load serves every check of a page at one size: what it requests and logs, its images and
    equations, its download links (fetched when ``fetch_downloads``), the reader's checks and the
    screenshot (``_screenshot``).
    """
    problems: list[str] = []
    found = None
    page = context.new_page()
    page.set_default_timeout(120_000)  # long pages on a busy machine
    page.on("console", lambda m: m.type == "error" and problems.append(f"console error: {m.text}"))
    page.on("pageerror", lambda e: problems.append(f"JavaScript error: {e}"))
    page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url} ({r.failure})"))
    page.on("response", lambda r: r.status != 200
            and problems.append(f"HTTP {r.status}: {r.url}"))
    try:
        if viewport is not None:
            page.set_viewport_size(viewport)
        response = page.goto(url, wait_until="load")
        if response is None or response.status != 200:
            problems.append(f"the page answered {response.status if response else 'nothing'}")
        info = _settle(page)
        for link in sorted(set(info["downloads"])) if fetch_downloads else []:
            if urllib.parse.urlsplit(link).hostname in ("127.0.0.1", "localhost"):
                r = page.request.get(link)
                if r.status != 200:
                    problems.append(f"download link {link} answered {r.status}")
        if reader is not None:
            found = page.evaluate(_READER_CHECKS, reader)
        if screenshot is not None:
            _screenshot(page, screenshot)
    finally:
        page.close()
    if info["broken_images"]:
        problems.append(f"images that do not load: {info['broken_images']}")
    if info["display_untypeset"]:
        problems.append(f"display equations not typeset by MathJax: {info['display_untypeset']}")
    if info["display_typeset"] < info["display_math"]:
        problems.append(f"{info['display_typeset']} typeset display equations for "
                        f"{info['display_math']} display-math blocks")
    if info["inline_untypeset"]:
        problems.append(f"inline math not typeset: {info['inline_untypeset'][:5]}")
    if info["tex_errors"]:
        problems.append(f"TeX errors: {info['tex_errors'][:5]}")
    return problems, info, found


#: Screenshots are JPEG (quality 80: for looking at, four times faster to write than PNG on
#: the long pages) and at most this many CSS pixels tall: every chapter whole at both sizes
#: (the longest, chapter 13, is about 48 000 px at 390 px wide), the API reference (about
#: 250 000 px) its first part only.
SHOT_MAX_HEIGHT = 50_000
#: Screenshots of every page only when asked (``make screenshots``): 70-80 s of the 3 minutes
#: of this file on 2 cores (measured 2026-12-04), for pictures no test reads.
SHOTS = os.environ.get("FIVEBAR_SCREENSHOTS", "").strip() not in ("", "0")


def _screenshot(page, path: Path) -> None:
    size = page.evaluate("() => [document.documentElement.clientWidth, "
                         "document.scrollingElement.scrollHeight]")
    path.parent.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(path), full_page=True, type="jpeg", quality=80,
                    clip={"x": 0, "y": 0, "width": size[0], "height": min(size[1], SHOT_MAX_HEIGHT)})


def test_the_page_checks_find_what_is_broken(book, browser, tmp_path):
    """The load and reader checks, as ``test_page_reads_as_a_book`` runs them, find the faults
    planted in a copy of a built chapter: an image that is not there, an equation TeX cannot
    read, a JavaScript error, an assert shown in a code cell, an erratum mention that is not a
    link, an element wider than the text column.  They are found while the page is loading and
    typesetting (``_settle`` awaits MathJax, the images and the fonts, not a quiet network)."""
    site = tmp_path / "site"
    (site / "book").mkdir(parents=True)
    for entry in book.iterdir():  # the build's assets, shared; the chapter's page copied
        if entry.name != "book":
            (site / entry.name).symlink_to(entry, target_is_directory=entry.is_dir())
    page = (book / "book" / "03_assembly.html").read_text(encoding="utf-8")
    planted = ('<section id="planted-faults"><p>Erratum E26 in plain text.</p>'
               '<img src="not-there.png" alt="a figure that is not there">'
               '<div class="math notranslate nohighlight">\\[\\frac{1}{x\\]</div>'
               '<div class="cell docutils container"><div class="cell_input docutils container">'
               '<div class="highlight"><pre>assert x == 1</pre></div></div></div>'
               '<div style="width: 3000px; background: #eee">too wide</div>'
               '<script>undefined_function_of_the_test();</script></section>')
    marker = '<section id="'
    assert marker in page, "03_assembly.html has no section"
    page = page.replace(marker, planted + marker, 1)
    (site / "book" / "03_assembly.html").write_text(page, encoding="utf-8")
    (site / "redirect.html").write_text('<meta http-equiv="Refresh" content="0; url=book/03_assembly.html" />')
    with _serving(site) as url:
        problems, direct, found = _check_page(browser, f"{url}/book/03_assembly.html", VIEWPORTS["1400"],
                                         fetch_downloads=False, reader={"desktop": True, "chapter": 3})
        # through a redirect (as the book's root index.html): the page it leads to is inspected,
        # once typeset (inline math left untypeset was seen when the two were not one evaluation)
        via, info, _ = _check_page(browser, f"{url}/redirect.html", fetch_downloads=False)
    for got in (direct, info):  # every equation typeset but the planted one, by either way
        assert got["display_typeset"] == got["display_math"] - 1 > 0, got
        assert not got["inline_untypeset"] and len(got["display_untypeset"]) == 1, got
    assert any("TeX errors" in v or "not typeset" in v for v in via), via
    text = "\n".join(problems)
    assert "not-there.png" in text and "HTTP 404" in text, problems
    assert "images that do not load" in text, problems
    assert "undefined_function_of_the_test" in text, problems
    assert "TeX errors" in text or "not typeset" in text, problems
    checks = {v["check"] for v in found}
    assert "visible assert" in checks, checks
    assert "erratum mention not a link" in checks, checks
    assert any("text column" in c or "1400 px" in c or "horizontally" in c for c in checks), checks


def test_search_finds_a_word_of_the_chapters(book, server, browser):
    page = browser.new_page()
    try:
        page.goto(f"{server}/search.html?q={SEARCH_WORD}")
        page.wait_for_selector("#search-results ul.search li a", timeout=30_000)
        hits = page.eval_on_selector_all("#search-results ul.search li a",
                                         "els => els.map(a => a.getAttribute('href'))")
    finally:
        page.close()
    assert any("book/" in h for h in hits), f"search for {SEARCH_WORD!r} found no page: {hits}"


def test_screenshots(book, server, browser):
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    shots = {"front": "book/index.html"}
    figure6 = sorted(book.glob("book/*figure*6*.html")) + sorted(book.glob("book/*fig6*.html"))
    modes = sorted(book.glob("book/*modes*.html"))
    if figure6 or modes:
        shots["figure6" if figure6 else "modes"] = (figure6 or modes)[0].relative_to(book).as_posix()
    page = browser.new_page()
    try:
        for name, rel in shots.items():
            page.goto(f"{server}/{rel}")
            _settle(page)
            out = SCREENSHOTS / f"{name}.png"
            page.screenshot(path=str(out), full_page=False)
            assert out.stat().st_size > 10_000, f"{out} looks empty"
    finally:
        page.close()


# --------------------------------------------------------------------------------------------
# The reader's edition: nothing cut off, no visible asserts, sharp figures, linked errata,
# numbered chapters.  One test per page and window size.
# --------------------------------------------------------------------------------------------

#: Window sizes of the reader's-edition checks: a desktop and a phone.
VIEWPORTS = {"1400": {"width": 1400, "height": 900}, "390": {"width": 390, "height": 844}}



def _toc_pages() -> list[str]:
    """The pages of the table of contents, as paths below book/ without suffix."""
    toc = (ROOT / "_toc.yml").read_text(encoding="utf-8")
    root = re.search(r"^root:\s*(\S+)", toc, re.M)
    pages = ([root.group(1)] if root else []) + re.findall(r"^\s*-\s*file:\s*(\S+)", toc, re.M)
    return [p.removeprefix("book/") for p in pages]


#: Measures one page in the browser; returns the violations as {check, element, value}.
_READER_CHECKS = r"""(opts) => {
    const out = [];
    const article = document.querySelector('article.bd-article') || document.querySelector('main');
    if (!article) { return [{check: 'layout', element: 'article', value: 'no article element'}]; }
    const cs = getComputedStyle(article);
    const box = article.getBoundingClientRect();
    const colLeft = box.left + parseFloat(cs.paddingLeft), colRight = box.right - parseFloat(cs.paddingRight);
    const describe = (el) => {
        let d = el.tagName.toLowerCase();
        if (el.id) d += '#' + el.id;
        const cls = (el.getAttribute('class') || '').trim().split(/\s+/).filter(Boolean).slice(0, 3);
        if (cls.length) d += '.' + cls.join('.');
        const sec = el.closest('section[id]');
        const txt = (el.textContent || '').replace(/\s+/g, ' ').trim().slice(0, 50);
        return d + (sec ? ` in section #${sec.id}` : '') + (txt ? ` ("${txt}")` : '');
    };
    const visible = (el) => el.checkVisibility
        ? el.checkVisibility({opacityProperty: true, visibilityProperty: true})
        : el.offsetParent !== null;
    const scrollsX = (el) => ['auto', 'scroll'].includes(getComputedStyle(el).overflowX);
    // 1. no horizontal scrolling of the page
    const doc = document.scrollingElement || document.documentElement;
    if (doc.scrollWidth > doc.clientWidth + 1) {
        out.push({check: 'page scrolls horizontally', element: 'html',
                  value: `scrollWidth ${doc.scrollWidth} px > ${doc.clientWidth} px`});
    }
    // 2. nothing past the text column unless inside its own scroll box; at the desktop width
    //    tables, equations and code must not even need to scroll
    const kinds = 'table, pre, div.math, mjx-container[display="true"], img, svg, figure, '
                + 'div.cell_output, div.output, div.highlight, p, li, dl, blockquote, iframe, video, '
                + 'code, h1, h2, h3, h4, dt';
    for (const el of article.querySelectorAll(kinds)) {
        if (!visible(el) || el.closest('mjx-container') && el.tagName.toLowerCase() !== 'mjx-container') continue;
        if (el.closest('svg') && el.tagName.toLowerCase() === 'svg' && el.parentElement.closest('svg')) continue;
        const r = el.getBoundingClientRect();
        if (r.width === 0 || r.height === 0) continue;
        const over = Math.max(r.right - colRight, colLeft - r.left);
        if (over > 1) {
            let scroller = null;
            for (let a = el.parentElement; a && a !== article; a = a.parentElement) {
                if (scrollsX(a)) { scroller = a; break; }
            }
            const sr = scroller ? scroller.getBoundingClientRect() : null;
            if (!scroller || sr.right > colRight + 1 || sr.left < colLeft - 1) {
                out.push({check: 'cut off (past the text column, no scroll box)', element: describe(el),
                          value: `${Math.round(r.width)} px wide, ${Math.round(over)} px past a ${Math.round(colRight - colLeft)} px column`});
            }
        }
        // content clipped by its own box (overflow hidden/clip)
        const ov = getComputedStyle(el).overflowX;
        if (['hidden', 'clip'].includes(ov) && el.scrollWidth > el.clientWidth + 1 && el.clientWidth > 0
            && !el.matches('figure, p, li')) {
            out.push({check: 'clipped (overflow hidden)', element: describe(el),
                      value: `content ${el.scrollWidth} px in a ${el.clientWidth} px box`});
        }
    }
    // content wider than its table cell runs into the next cell (or is clipped)
    for (const cell of article.querySelectorAll('td, th')) {
        if (!visible(cell)) continue;
        if (cell.scrollWidth > cell.clientWidth + 1) {
            out.push({check: 'overflows its table cell', element: describe(cell),
                      value: `content ${cell.scrollWidth} px in a ${cell.clientWidth} px cell`});
        }
    }
    if (opts.desktop) {
        const needScroll = article.querySelectorAll('table, div.math, mjx-container[display="true"], '
            + 'div.highlight pre, div.cell_output pre, div.output pre, .table-wrapper, '
            + '.pst-scrollable-table-container, div.output.text_html');
        for (const el of needScroll) {
            if (!visible(el)) continue;
            if (el.scrollWidth > el.clientWidth + 1 && scrollsX(el)) {
                out.push({check: 'needs horizontal scrolling at 1400 px', element: describe(el),
                          value: `content ${el.scrollWidth} px in a ${el.clientWidth} px box`});
            }
        }
    }
    // 3. no visible assert in code cells
    for (const pre of article.querySelectorAll('div.cell_input pre, div.cell div.highlight pre')) {
        if (!visible(pre)) continue;
        const lines = pre.textContent.split('\n').filter(l => /^\s*assert\b/.test(l));
        if (lines.length) {
            out.push({check: 'visible assert', element: describe(pre.closest('div.cell') || pre),
                      value: `${lines.length} line(s): ${lines[0].trim().slice(0, 60)}`});
        }
    }
    // 4. raster figures at least 1.5x their displayed width
    for (const img of article.querySelectorAll('img')) {
        if (!visible(img)) continue;
        const src = img.currentSrc || img.src || '';
        if (/\.svg(\?|#|$)/i.test(src) || src.startsWith('data:image/svg')) continue;
        const shown = img.getBoundingClientRect().width;
        if (shown > 0 && img.naturalWidth < 1.5 * shown - 0.5) {
            out.push({check: 'raster figure below 1.5x', element: describe(img) + ' ' + src.split('/').pop(),
                      value: `${img.naturalWidth} px natural for ${Math.round(shown)} px shown (${(img.naturalWidth / shown).toFixed(2)}x)`});
        }
    }
    // 5. every erratum mention in the prose is a link
    const walker = document.createTreeWalker(article, NodeFilter.SHOW_TEXT);
    const skip = 'a, code, pre, kbd, samp, .cell_input, .cell_output, .output, mjx-container, '
               + 'script, style, table.fivebar-errata tr > td:first-child, .headerlink';
    for (let n = walker.nextNode(); n; n = walker.nextNode()) {
        const m = n.textContent.match(/\bE\d{1,2}\b/g);
        if (!m) continue;
        const host = n.parentElement;
        if (!host || host.closest(skip) || !visible(host)) continue;
        out.push({check: 'erratum mention not a link', element: describe(host),
                  value: m.join(', ')});
    }
    // 6. chapter titles numbered
    if (opts.chapter !== null) {
        const h1 = Array.from(article.querySelectorAll('h1')).find(visible);
        const text = h1 ? h1.textContent.trim() : '';
        const num = (text.match(/^(\d+)\.\s/) || [])[1];
        if (String(Number(num)) !== String(opts.chapter)) {
            out.push({check: 'chapter title not numbered', element: 'h1',
                      value: `"${text.slice(0, 60)}" (expected "${opts.chapter}. ...")`});
        }
    }
    return out;
}"""

_VIOLATIONS: dict[str, list[dict]] = {}


def _write_violations() -> None:
    import json

    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    (SCREENSHOTS / "violations.json").write_text(
        json.dumps(_VIOLATIONS, indent=1, ensure_ascii=False, sort_keys=True), encoding="utf-8")


@pytest.mark.parametrize("size", sorted(VIEWPORTS))
@pytest.mark.parametrize("doc", _toc_pages())
def test_page_reads_as_a_book(book, server, browser, doc, size):
    """The page loads offline and whole (``_check_page``: every request answers 200 from this
    host, no JavaScript error, every image decodes, MathJax typesets every equation; at 1400 px
    its download links answer and a chapter offers its notebook), and it reads as a book:
    nothing cut off, no visible assert, sharp figures, linked errata, numbered chapters."""
    html = book / "book" / f"{doc}.html"
    assert html.is_file(), f"book/{doc}.html was not built"
    m = re.match(r"(\d+)_", doc)
    chapter = int(m.group(1)) if m else None
    desktop = size == "1400"
    problems, info, found = _check_page(
        browser, f"{server}/book/{doc}.html", VIEWPORTS[size], fetch_downloads=desktop,
        reader={"desktop": desktop, "chapter": chapter},
        screenshot=SCREENSHOTS / f"{doc}-{size}.jpg" if SHOTS else None)
    if desktop and chapter is not None:
        offered = info["source_downloads"]
        if not any(h.endswith(f"/_sources/book/{doc}.ipynb") for h in offered):
            problems.append(f"the chapter offers no .ipynb download: {offered}")
    key = f"book/{doc}.html at {size} px"
    _VIOLATIONS[key] = found
    _write_violations()
    if not found and not problems:
        return
    lines = [f"{key}: {len(problems)} load problem(s), {len(found)} violation(s)"]
    lines += [f"  {p}" for p in problems]
    lines += [f"  [{v['check']}] {v['element']}: {v['value']}" for v in found[:60]]
    if len(found) > 60:
        lines.append(f"  ... and {len(found) - 60} more (see _build/screenshots/violations.json)")
    pytest.fail("\n".join(lines), pytrace=False)


def test_erratum_mentions_in_docstrings_become_links():
    lines = ["Corrected (errata E1, E26); not ``E3`` or :math:`E_3`.", ".. math::", "",
             "    E1 = 0", "", "E99 is not an erratum."]
    _extension()._link_errata_in_docstring(None, "function", "f", None, None, lines)
    assert lines == ["Corrected (errata :ref:`E1 <erratum-e1>`, :ref:`E26 <erratum-e26>`); "
                     "not ``E3`` or :math:`E_3`.", ".. math::", "", "    E1 = 0", "",
                     "E99 is not an erratum."]


# --------------------------------------------------------------------------------------------
# Figures: numbered, captioned, described
# --------------------------------------------------------------------------------------------

_HASHLIKE = re.compile(r"^[0-9a-f]{16,}(\.\w+)?$|\.(png|jpe?g|svg)$", re.I)


def _pointing_problems(main, page: Path, noun: str, what: str) -> list[str]:
    """Paragraphs that point at "the <noun> above/below" instead of giving the number."""
    return [f"{page.name}: paragraph {k} refers to 'the {what} above/below' instead of the {what}'s number"
            for k, p in enumerate(main.find_all("p"), 1)
            if re.search(rf"\bthe {noun} (above|below)\b", p.get_text(" ", strip=True), re.I)]


def _figure_problems(page: Path) -> list[str]:
    """Every image of a chapter's text must be a numbered figure with a caption and an alt text
    that describes it (not a file name or hash); one string per problem."""
    from bs4 import BeautifulSoup

    soup = BeautifulSoup(page.read_text(encoding="utf-8"), "html.parser")
    main = soup.find("article") or soup
    problems = []
    for k, img in enumerate(main.find_all("img"), 1):
        where = f"{page.name}, image {k}"
        alt = (img.get("alt") or "").strip()
        if not alt or _HASHLIKE.search(alt) or len(alt.split()) < 3:
            problems.append(f"{where}: alt text {alt!r} does not describe the figure")
        figure = img.find_parent("figure")
        caption = figure.find("figcaption") if figure else None
        if caption is None:
            problems.append(f"{where} ({alt[:40]!r}): not in a figure with a caption")
            continue
        if caption.find(class_="caption-number") is None:
            problems.append(f"{where} ({alt[:40]!r}): the caption has no figure number")
        text = caption.get_text(" ", strip=True)
        if len(text.split()) < 5:
            problems.append(f"{where}: caption {text!r} does not say what is plotted")
    return problems + _pointing_problems(main, page, r"(figure|plot)", "figure")


def test_every_figure_is_numbered_captioned_and_described(book):
    """A chapter image without a figure number, a caption or an alt text that describes it
    (a file hash is not one), or a reference to "the figure above", fails."""
    pages = [book / p.relative_to(ROOT).with_suffix(".html") for p in _chapter_notebooks()]
    problems = [msg for page in pages if page.is_file() for msg in _figure_problems(page)]
    assert not problems, f"{len(problems)} figure problems:\n" + "\n".join(problems)


# --------------------------------------------------------------------------------------------
# Tables: numbered and captioned
# --------------------------------------------------------------------------------------------


def _table_problems(page: Path, chapter: int) -> list[str]:
    """Every table of a chapter's text must carry a caption numbered "Table <chapter>.k" (a MyST
    ``{table}``, as ``fivebar.book.reporting.table(..., name=)`` writes it; a pandas Styler or a bare
    DataFrame has none) that says what is tabulated; the text must not point at "the table
    above/below"; one string per problem."""
    from bs4 import BeautifulSoup

    soup = BeautifulSoup(page.read_text(encoding="utf-8"), "html.parser")
    main = soup.find("article") or soup
    problems = []
    for k, tab in enumerate(main.find_all("table"), 1):
        head = " | ".join(c.get_text(" ", strip=True) for c in tab.find_all(["th", "td"])[:3])
        where = f"{page.name}, table {k} ({head[:50]!r})"
        caption = tab.find("caption")
        number = caption.find(class_="caption-number") if caption else None
        if number is None:
            problems.append(f"{where}: no numbered caption (use fivebar.book.reporting.table(..., name=))")
            continue
        m = re.fullmatch(r"Table (\d+)\.(\d+)", number.get_text(" ", strip=True))
        if not m or int(m.group(1)) != chapter:
            problems.append(f"{where}: numbered {number.get_text(strip=True)!r}, not 'Table {chapter}.k'")
        text = caption.get_text(" ", strip=True)
        if len(text.split()) < 6:
            problems.append(f"{where}: caption {text!r} does not say what is tabulated")
    return problems + _pointing_problems(main, page, r"tables?", "table")


def test_every_table_is_numbered_and_captioned(book):
    """A chapter table (01-13) without a caption numbered "Table N.k" (N the chapter), with a
    caption that says nothing, or a reference to "the table above", fails."""
    problems = []
    for nb in _chapter_notebooks():
        page = book / nb.relative_to(ROOT).with_suffix(".html")
        if page.is_file():
            problems += _table_problems(page, int(nb.name[:2]))
    assert not problems, f"{len(problems)} table problems:\n" + "\n".join(problems)


def test_the_table_check_finds_unnumbered_tables(tmp_path):
    """The check itself (no build): a numbered caption of the chapter passes; a Styler's table
    (caption without number), a bare DataFrame, another chapter's number, an empty caption and
    'the table below' are found."""
    numbered = ('<table class="table" id="tab-07-pp"><caption><span class="caption-number">Table 7.{k} '
                '</span><span class="caption-text">{text}</span></caption><tr><td>1</td></tr></table>')
    page = tmp_path / "07_x.html"
    page.write_text("<article>" + numbered.format(k=1, text="Peak-to-peak deflections at the chapter's speeds")
                    + "<p>As Table 7.1 shows.</p></article>", encoding="utf-8")
    assert _table_problems(page, 7) == []
    page.write_text(
        "<article>" + '<table id="T_fivebar0123"><caption>Peak-to-peak at the speeds</caption></table>'
        + '<table class="dataframe"><tr><td>2</td></tr></table>'
        + numbered.format(k=1, text="Peak-to-peak deflections at the chapter's speeds").replace("7.1", "8.1")
        + numbered.format(k=2, text="Deflections") + "<p>The table below compares them.</p></article>",
        encoding="utf-8")
    found = _table_problems(page, 7)
    expected = ["no numbered caption", "no numbered caption", "numbered 'Table 8.1', not 'Table 7.k'",
                "caption 'Table 7.2 Deflections", "refers to 'the table above/below'"]
    assert len(found) == len(expected) and all(e in m for e, m in zip(expected, found)), found


def test_the_pages_outside_the_contents_render_offline(book, server, browser):
    """The pages ``test_page_reads_as_a_book`` does not open (the index, the search page, the
    module index, the animations' pages) pass its load checks too; and no page opened by the
    tests of this module asked for anything from another host (run last: the browser's record)."""
    contents = {f"book/{doc}.html" for doc in _toc_pages()}
    pages = [p for p in _pages(book) if p.relative_to(book).as_posix() not in contents]
    report: dict[str, list[str]] = {}
    for path in pages:
        rel = path.relative_to(book).as_posix()
        problems, _, _ = _check_page(browser, f"{server}/{rel}")
        if problems:
            report[rel] = problems
    if browser.outside_requests:
        report["(any page)"] = [f"request to another host: {u}"
                                for u in sorted(set(browser.outside_requests))]
    assert not report, "\n".join(f"{page}:\n  " + "\n  ".join(p) for page, p in report.items())
