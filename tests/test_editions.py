"""The book's editions, its launch buttons and its version.

* **Student edition** (``make book-student`` -> ``_build/student/html``, the student archive
  ``_build/student/fivebar-student.zip`` and the student PDF ``_build/pdf/fivebar-student.pdf``):
  the text of every exercise solution in the notebooks is absent from every student artefact
  (pages, search index, the notebooks offered for download, the archive, the PDF), while the
  exercises are there; the front page offers the student PDF and "Run it yourself" the archive,
  not the repository; the
  solutions are found in the notebooks by markdown-it (the parser MyST itself uses), not by
  the regular expressions that remove them, and the same probe finds them in the instructor
  edition (``_build/html``) so that the check can fail.
* **Solution stripping** (:func:`fivebar_build.strip_solutions`) on hand-written cases.
* **Launch buttons**: a one-chapter book built with the book's own ``_config.yml``, once as
  distributed (no ``repository.url``: no launch links) and once with a repository and a
  Binder and JupyterHub service set (the links appear, pointing at the chapter's notebook).
* **Version**: ``fivebar.__version__``, ``CITATION.cff``, ``pyproject.toml`` and the
  "Version and citation" section of ``book/run.md`` agree.
"""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
import sys
import tomllib
from urllib.parse import unquote
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
STUDENT = ROOT / "_build" / "student" / "html"
INSTRUCTOR = ROOT / "_build" / "html"
sys.path.insert(0, str(ROOT / "book" / "_ext"))
import fivebar_build  # noqa: E402  (book/_ext is not a package)


def _sources() -> list[Path]:
    out = [ROOT / "_config.yml", ROOT / "_toc.yml"]
    for folder, pattern in (("book", "**/*"), ("lib/fivebar", "**/*.py"), ("data", "*")):
        out += [p for p in (ROOT / folder).glob(pattern)
                if p.is_file() and ".ipynb_checkpoints" not in p.parts
                and "__pycache__" not in p.parts]
    return out


def _fresh(stamp: Path) -> bool:
    return stamp.is_file() and all(p.stat().st_mtime <= stamp.stat().st_mtime for p in _sources())


def _make(target: str, stamp: Path) -> None:
    if _fresh(stamp):
        return
    if shutil.which("make") is None:
        pytest.skip(f"`make {target}` is needed and `make` is not available")
    run = subprocess.run(["make", target], cwd=ROOT, capture_output=True, text=True)
    if run.returncode != 0 or not stamp.is_file():
        tail = "\n".join((run.stdout + run.stderr).splitlines()[-40:])
        pytest.fail(f"`make {target}` failed (exit {run.returncode}):\n{tail}")


@pytest.fixture(scope="module")
def student() -> Path:
    _make("book-student", STUDENT / ".fivebar-build-ok")
    return STUDENT


@pytest.fixture(scope="module")
def instructor() -> Path:
    _make("book", INSTRUCTOR / ".fivebar-build-ok")
    return INSTRUCTOR


# --------------------------------------------------------------------------------------------
# What the notebooks say: exercises and solutions, found by markdown-it
# --------------------------------------------------------------------------------------------


def _blocks(kind: str) -> list[tuple[str, str]]:
    """(notebook, body) of every ``{kind}`` directive in the chapters' markdown cells."""
    from markdown_it import MarkdownIt
    from mdit_py_plugins.colon_fence import colon_fence_plugin

    md = MarkdownIt("commonmark").use(colon_fence_plugin)
    out = []
    for nb_path in sorted((ROOT / "book").glob("*.ipynb")):
        for cell in json.loads(nb_path.read_text())["cells"]:
            if cell["cell_type"] != "markdown":
                continue
            for tok in md.parse("".join(cell["source"])):
                if tok.type in {"fence", "colon_fence"} and tok.info.strip().startswith(f"{{{kind}}}"):
                    out.append((nb_path.name, tok.content))
    return out


_WORD_RUN = re.compile(r"[A-Za-z][A-Za-z ,;]{30,}[A-Za-z]")


def _probe(body: str) -> str:
    """A run of plain words (no math, code or markup) from a directive's body."""
    text = re.sub(r"^:\w+:.*$", "", body, flags=re.M)          # directive options
    text = re.sub(r"\$\$.*?\$\$|\$[^$]*\$|`[^`]*`", " | ", text, flags=re.S)
    runs = [re.sub(r"\s+", " ", r).strip() for r in _WORD_RUN.findall(text.replace("\n", " "))]
    runs = [r for r in runs if len(r.split()) >= 6]
    assert runs, f"no plain-text run to look for in {body[:80]!r}"
    return max(runs, key=len)


def _notebook_text(raw: str) -> str:
    """A notebook's cells (sources and text outputs) as one text: a probe that a stored
    notebook splits over two JSON strings (one per line) is found all the same."""
    nb = json.loads(raw)
    parts = []
    for cell in nb.get("cells", []):
        parts.append("".join(cell.get("source", "")))
        for out in cell.get("outputs", []):
            parts.append("".join(out.get("text", "")))
            parts.append("".join(out.get("data", {}).get("text/plain", "")))
    return "\n".join(parts)


def _page_text(path: Path, raw: str | None = None) -> str:
    """What a reader (or a search, or a text editor) finds in a built file."""
    if raw is None:
        raw = path.read_text(encoding="utf-8", errors="replace")
    if path.suffix == ".ipynb":
        raw = _notebook_text(raw)
    if path.suffix == ".html":
        raw = re.sub(r"<[^>]+>", " ", raw)
    raw = html.unescape(raw)
    for a, b in (("\u2019", "'"), ("\u2018", "'"), ("\u201c", '"'), ("\u201d", '"'),
                 ("\\n", " ")):
        raw = raw.replace(a, b)
    return re.sub(r"\s+", " ", raw)


def _built_text(root: Path) -> dict[Path, str]:
    files = [p for p in root.rglob("*")
             if p.suffix in {".html", ".js", ".ipynb", ".md", ".txt"} and p.is_file()
             and "_static" not in p.relative_to(root).parts]
    return {p: _page_text(p) for p in files}


def test_notebooks_have_solutions() -> None:
    sols = _blocks("solution")
    assert len(sols) >= 20, f"only {len(sols)} solutions found in the notebooks"
    assert len(_blocks("exercise")) >= len(sols)


def test_student_edition_has_no_solution_text(student: Path) -> None:
    built = _built_text(student)
    leaks = []
    for nb, body in _blocks("solution"):
        probe = _probe(body)
        where = [p.relative_to(student).as_posix() for p, t in built.items() if probe in t]
        if where:
            leaks.append(f"{nb}: {probe[:60]!r} in {where}")
    assert not leaks, "solution text in the student edition:\n" + "\n".join(leaks)


def test_student_edition_keeps_the_exercises(student: Path) -> None:
    built = "\n".join(_built_text(student).values())
    missing = [f"{nb}: {_probe(body)[:60]!r}" for nb, body in _blocks("exercise")
               if _probe(body) not in built]
    assert not missing, "exercises missing from the student edition:\n" + "\n".join(missing)
    assert "Solution to" not in built


def _archive_text(path: Path) -> dict[str, str]:
    import zipfile

    with zipfile.ZipFile(path) as zf:
        return {name: _page_text(Path(name), zf.read(name).decode("utf-8", "replace"))
                for name in zf.namelist() if not name.endswith("/")}


def test_student_archive_has_the_chapters_without_solutions(student: Path) -> None:
    archive = fivebar_build.STUDENT_ARCHIVE
    assert archive.is_file(), "make book-student made no student archive"
    files = _archive_text(archive)
    names = {n.split("/", 1)[1] for n in files}
    for nb in fivebar_build.chapter_notebooks():
        assert f"book/{nb.name}" in names, f"{nb.name} missing from the student archive"
    assert {"data/wang2011.toml", "lib/fivebar/__init__.py", "pyproject.toml",
            "requirements-lock.txt"} <= names
    leaks = [f"{nb}: {_probe(body)[:60]!r} in {n}" for nb, body in _blocks("solution")
             for n, t in files.items() if _probe(body) in t]
    assert not leaks, "solution text in the student archive:\n" + "\n".join(leaks)
    text = "\n".join(files.values())
    missing = [nb for nb, body in _blocks("exercise") if _probe(body) not in text]
    assert not missing, f"exercises missing from the student archive: {missing}"


def test_student_pdf_has_no_solution_text(student: Path) -> None:
    pypdf = pytest.importorskip("pypdf")
    pdf = fivebar_build.pdf_path("student")
    if not pdf.is_file():
        missing = fivebar_build.missing_tex_tools()
        from book_build import unavailable

        unavailable(f"no student PDF ({', '.join(missing) or 'TeX'} missing?)")
    raw = " ".join(p.extract_text() or "" for p in pypdf.PdfReader(pdf).pages)
    squash = lambda t: re.sub(r"[^a-z]", "", t.lower())  # noqa: E731 (PDF text loses spaces)
    text = squash(raw)
    leaks = [f"{nb}: {_probe(body)[:60]!r}" for nb, body in _blocks("solution")
             if squash(_probe(body)) in text]
    assert not leaks, "solution text in the student PDF:\n" + "\n".join(leaks)
    missing = [nb for nb, body in _blocks("exercise") if squash(_probe(body)) not in text]
    assert len(missing) <= 2, f"exercises missing from the student PDF: {missing}"
    assert "studentedition" in squash(pypdf.PdfReader(pdf).pages[0].extract_text())


def test_student_pages_offer_student_products(student: Path) -> None:
    """The front page links the student PDF (not the instructor's), "Run it yourself" the
    student archive and no repository to clone."""
    front = (student / "book" / "index.html").read_text(encoding="utf-8")
    run = (student / "book" / "run.html").read_text(encoding="utf-8")
    links = " ".join(re.findall(r'href="([^"]+)"', front + run))
    assert "fivebar.pdf" not in links, "the student edition links the instructor PDF"
    if fivebar_build.pdf_path("student").is_file():
        assert "fivebar-student.pdf" in links
    assert "fivebar-student.zip" in links, "Run it yourself does not offer the student archive"
    assert "git clone" not in _page_text(student / "book" / "run.html")
    instructor_run = INSTRUCTOR / "book" / "run.html"
    if instructor_run.is_file():
        assert "git clone" in _page_text(instructor_run)  # the control: the probe can fail


def _numbers(root: Path) -> dict[str, tuple[list[str], list[str]]]:
    """{page: (chapter and section numbers, exercise numbers)} of a built edition."""
    out = {}
    for page in sorted((root / "book").glob("*.html")):
        text = page.read_text(encoding="utf-8")
        out[page.name] = (re.findall(r'<span class="section-number">([\d.]+) </span>', text),
                          re.findall(r'<span class="caption-number">Exercise ([\d.]+) </span>', text))
    return out


def test_student_edition_numbers_as_the_instructor_edition(student: Path, instructor: Path) -> None:
    """One numbering: chapters, sections and exercises carry the same numbers in both editions
    (the PDF's are compared with the HTML's in tests/test_pdf.py)."""
    s, i = _numbers(student), _numbers(instructor)
    assert sum(len(ex) for _, ex in i.values()) >= 20
    differ = [name for name in i if s.get(name) != i[name]]
    assert not differ, f"numbers differ between the editions on {differ}"


def test_probe_finds_the_solutions_in_the_instructor_edition(instructor: Path) -> None:
    """The control: the same probes find every solution in the edition that has them."""
    pages = "\n".join(t for p, t in _built_text(instructor).items() if p.suffix == ".html")
    missing = [f"{nb}: {_probe(body)[:60]!r}" for nb, body in _blocks("solution")
               if _probe(body) not in pages]
    assert not missing, "solutions not found in the instructor edition:\n" + "\n".join(missing)


# --------------------------------------------------------------------------------------------
# Solution stripping
# --------------------------------------------------------------------------------------------


def test_strip_solutions_cases() -> None:
    text = (
        "Intro\n\n```{exercise}\n:label: ex-a-1\nQuestion one.\n```\n\n"
        "````{solution} ex-a-1\n:class: dropdown\nAnswer one.\n```python\nx = 1\n```\nEnd one.\n````\n"
        "Between\n\n:::{solution} ex-a-2\nAnswer two.\n:::\n"
        "```{solution-start} ex-a-3\n```\nAnswer three.\n```{solution-end}\n```\nAfter\n"
    )
    out, n = fivebar_build.strip_solutions(text)
    assert n == 3
    for gone in ("Answer one", "x = 1", "End one", "Answer two", "Answer three", "solution"):
        assert gone not in out
    for kept in ("Intro", "Question one.", "Between", "After", "{exercise}"):
        assert kept in out
    with pytest.raises(ValueError, match="unclosed"):
        fivebar_build.strip_solutions("```{solution} ex\nno end\n")
    with pytest.raises(ValueError, match="solution-end"):
        fivebar_build.strip_solutions("```{solution-start} ex\n```\ntext\n")


def test_strip_removes_the_cells_that_compute_the_solutions() -> None:
    """A code cell tagged "solution" (it glues the numbers of the solutions) goes with the
    solutions; other code cells, tagged or not, stay."""
    nb = {"cells": [
        {"cell_type": "markdown", "metadata": {}, "source": "```{exercise}\n:label: ex-a-1\nQ.\n```\n\n"
                                                            "```{solution} ex-a-1\nThe answer is {glue:text}`a`.\n```\n"},
        {"cell_type": "code", "metadata": {"tags": ["remove-cell", "solution"]}, "source": "glue('a', '42')", "outputs": []},
        {"cell_type": "code", "metadata": {"tags": ["remove-input"]}, "source": "physics_check(...)", "outputs": []},
        {"cell_type": "code", "metadata": {}, "source": "x = 1", "outputs": []}]}
    assert fivebar_build.strip_notebook_solutions(nb) == 1
    assert [c["source"] for c in nb["cells"][1:]] == ["physics_check(...)", "x = 1"]
    assert "answer" not in nb["cells"][0]["source"] and "{exercise}" in nb["cells"][0]["source"]


def test_every_solution_cell_is_hidden_from_the_page() -> None:
    """The cells that compute the solutions' numbers are removed from every page (tag
    remove-cell): their outputs are the answers."""
    bad = [f"{nb.name} cell {k}" for nb in sorted((ROOT / "book").glob("*.ipynb"))
           for k, c in enumerate(json.loads(nb.read_text())["cells"])
           if fivebar_build.SOLUTION_TAG in c.get("metadata", {}).get("tags", [])
           and "remove-cell" not in c["metadata"]["tags"]]
    assert not bad, f"solution cells shown on the page: {bad}"


def test_strip_removes_every_solution_of_the_book() -> None:
    """Stripping the notebooks leaves none of the solutions markdown-it finds in them."""
    found = _blocks("solution")
    removed, leftover = 0, []
    for nb_path in sorted((ROOT / "book").glob("*.ipynb")):
        nb = json.loads(nb_path.read_text())
        removed += fivebar_build.strip_notebook_solutions(nb)
        text = re.sub(r"\s+", " ", " ".join("".join(c["source"]) for c in nb["cells"]))
        leftover += [_probe(body) for name, body in found
                     if name == nb_path.name and _probe(body) in text]
    assert removed == len(found)
    assert not leftover


# --------------------------------------------------------------------------------------------
# Launch buttons
# --------------------------------------------------------------------------------------------

_CHAPTER = {
    "cells": [
        {"cell_type": "markdown", "id": "a", "metadata": {}, "source": ["# A chapter\n", "\n", "Text.\n"]},
        {"cell_type": "code", "id": "b", "execution_count": 1, "metadata": {}, "outputs": [],
         "source": ["x = 1"]},
    ],
    "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python",
                                "name": "python3"}},
    "nbformat": 4, "nbformat_minor": 5,
}


def _build_one_chapter(tmp: Path, repository: dict | None, launch: dict | None) -> str:
    """Build a one-chapter book with the book's _config.yml (overridden); return the page."""
    src = tmp / "src"
    (src / "book").mkdir(parents=True)
    (src / "book" / "intro.md").write_text("# Intro\n\nText.\n")
    (src / "book" / "chapter.ipynb").write_text(json.dumps(_CHAPTER))
    (src / "_toc.yml").write_text(
        "format: jb-book\nroot: book/intro\nchapters:\n  - file: book/chapter\n")
    config = yaml.safe_load((ROOT / "_config.yml").read_text())
    config["execute"]["execute_notebooks"] = "off"
    config["sphinx"].pop("local_extensions", None)   # not needed for the theme's buttons
    config.pop("bibtex_bibfiles", None)
    config["only_build_toc_files"] = True
    if repository:
        config["repository"].update(repository)
    if launch:
        config["launch_buttons"].update(launch)
    (src / "_config.yml").write_text(yaml.safe_dump(config, sort_keys=False))
    out = tmp / "html"
    # In a fresh interpreter: Sphinx keeps registries (source parsers, roles) per process, and
    # an earlier in-process build by another test (tests/test_course.py) breaks this one.
    script = tmp / "build.py"
    script.write_text(
        "import sys\n"
        "from pathlib import Path\n"
        "from jupyter_book.sphinx import build_sphinx\n"
        f"src, out, tmp = Path({str(src)!r}), Path({str(out)!r}), Path({str(tmp)!r})\n"
        "result = build_sphinx(src, out, use_external_toc=True, noconfig=True,\n"
        "                      path_config=str(src / '_config.yml'),\n"
        "                      confoverrides={'external_toc_path': (src / '_toc.yml').as_posix(),\n"
        "                                     'latex_individualpages': False},\n"
        "                      doctreedir=tmp / '.doctrees', builder='html', quiet=True,\n"
        "                      really_quiet=True)\n"
        "print(repr(result))\n"
        "sys.exit(0 if result == 0 else 1)\n")
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp)
    assert proc.returncode == 0, f"the one-chapter build failed: {proc.stdout[-2000:]} {proc.stderr[-2000:]}"
    return (out / "book" / "chapter.html").read_text()


def test_no_launch_buttons_as_distributed(tmp_path: Path) -> None:
    page = _build_one_chapter(tmp_path, None, None)
    assert "mybinder" not in page and "hub/user-redirect" not in page
    assert "launch-buttons" not in page


def test_launch_buttons_appear_with_repository_url(tmp_path: Path) -> None:
    page = _build_one_chapter(
        tmp_path,
        {"url": "https://github.com/example/fivebar", "branch": "main"},
        {"binderhub_url": "https://mybinder.org", "jupyterhub_url": "https://hub.example.edu"})
    links = unquote(html.unescape(" ".join(re.findall(r'href="([^"]+)"', page))))
    assert "https://mybinder.org/v2/gh/example/fivebar/main?urlpath=lab/tree/book/chapter.ipynb" in links
    assert ("https://hub.example.edu/hub/user-redirect/git-pull?repo=https://github.com/example/fivebar"
            "&urlpath=lab/tree/fivebar/book/chapter.ipynb") in links
    # Plain links: nothing from another host is loaded by the page itself.
    assert not re.search(r'<script[^>]+src="https?://', page)


# --------------------------------------------------------------------------------------------
# Version
# --------------------------------------------------------------------------------------------


def test_version_is_the_same_everywhere() -> None:
    import fivebar

    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())["version"]
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    run = (ROOT / "book" / "run.md").read_text()
    stated = re.search(r"This is version \*\*([^*]+)\*\*", run)
    assert stated, "book/run.md does not state the version"
    cited = re.search(r"version ([0-9][^ ]*) \(Jupyter Book", run)
    assert {fivebar.__version__, str(cff), pyproject, stated.group(1), cited.group(1)} == {str(cff)}
