"""Build the book's other editions: the student edition and the PDF.

Run from the repository root with the project's environment (the Makefile does)::

    .venv/bin/python book/_ext/fivebar_build.py student   # -> _build/student/html
    .venv/bin/python book/_ext/fivebar_build.py pdf       # -> _build/pdf/fivebar.pdf

Both are the same Jupyter Book build as ``make book`` (``_config.yml``, ``_toc.yml``, warnings
are errors, nitpicky), called through jupyter-book's Python API so that Sphinx settings can be
overridden without a second configuration file:

* **student**: ``hide_solutions = True`` (sphinx-exercise) and the Sphinx tag ``student``
  (``{only} student`` blocks, e.g. in "Run it yourself").  The ``{solution}`` directives
  then produce no node at all, so the solutions' text is absent from the HTML, not hidden.
  The sources the pages offer for download (``_sources/**.ipynb``, ``.md``) are copies of the
  chapters *with* their solutions, so the student build removes the solution blocks from
  those copies too (:func:`strip_solutions`).  It first writes the student archive
  (:func:`build_student_archive`): the chapters without solutions, the data, the library and
  its pinned requirements, which the student pages offer instead of the repository.
* **pdf**: Sphinx's LaTeX builder (with sphinx-jupyterbook-latex and ``fivebar_latex``) and
  XeLaTeX through latexmk (Debian's TeX Live, :data:`TEX_PACKAGES`): a title page, contents
  with page numbers, running heads, numbered chapters as in the HTML, an index.
  ``--edition student`` builds the student edition's PDF.  An up-to-date PDF (newer than
  every source) is not built again.

As a Sphinx extension (``sphinx.local_extensions`` in ``_config.yml``) the module adds the role
``{fivebar-pdf}`text```: a download link to the PDF of the edition being built
(``_build/pdf/fivebar.pdf``, or ``fivebar-student.pdf`` when solutions are hidden) if that PDF
exists when the page is read, and otherwise the text followed by "(not built: run ``make
pdf``)" -- so the link is never dead; likewise ``{fivebar-archive}`text``` for the student
archive.  A page with the role is re-read whenever the file appears or changes.

Every build reads the notebooks' outputs from the execution cache of ``make book``
(``_build/.jupyter_cache``): nothing is re-executed if the HTML book is up to date.  Each
edition keeps its own Sphinx environment (``.doctrees``) so that alternating builds do not
force each other to re-read every page.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
BUILD = ROOT / "_build"
CACHE = BUILD / ".jupyter_cache"  # shared with `make book`
EDITIONS = ("instructor", "student")
PDF_NAME = "fivebar.pdf"
def _sphinx_build(builder: str, outdir: Path, doctreedir: Path, toc: Path,
                  overrides: dict, tags: list[str] | None = None) -> None:
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
        tags=tags or [],
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


#: The tag of a code cell that computes the numbers of the exercises' solutions (glued into
#: them with ``fivebar.book.reporting.glue``, in myst-nb's format; README, "Exercises in a
#: chapter"): part of the solutions.
SOLUTION_TAG = "solution"


def strip_notebook_solutions(nb: dict) -> int:
    """Remove the solutions from a notebook (in place); return the count of solution blocks.

    The ``{solution}`` blocks of its markdown cells go, and so do its code cells tagged
    :data:`SOLUTION_TAG` (the computation of the solutions' numbers), whose outputs would
    otherwise carry the answers.  A gated solution whose ``{solution-start}`` and
    ``{solution-end}`` lie in different cells (code cells between them) is not supported: the
    book writes each solution inside one markdown cell (README, "Exercises in a chapter"), and
    such a notebook raises ValueError.
    """
    n = 0
    nb["cells"] = [c for c in nb.get("cells", []) if not (
        c.get("cell_type") == "code" and SOLUTION_TAG in c.get("metadata", {}).get("tags", []))]
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


#: The student archive: what a student needs to run the chapters, without the solutions.
STUDENT_ARCHIVE = BUILD / "student" / "fivebar-student.zip"
#: Files of the repository in the archive besides the chapters (``lib/`` and ``data/`` whole).
ARCHIVE_FILES = ("pyproject.toml", "requirements-lock.txt", "LICENSE", "CITATION.cff")
ARCHIVE_README = """fivebar, student edition: the chapters as notebooks, without the exercises' solutions.

Set up once (Python 3.11; nothing outside this folder is changed):

    python3 -m venv .venv
    .venv/bin/python -m pip install -r requirements-lock.txt
    .venv/bin/python -m pip install --no-deps -e .

Then open a chapter:

    .venv/bin/jupyter lab book/05_modes.ipynb

book/   the chapters (notebooks, with their stored outputs)
data/   the parameter file (every number of the paper, every assumption) and reference data
lib/    the library fivebar that the chapters import
"""


def chapter_notebooks() -> list[Path]:
    """The numbered chapters' notebooks (``book/NN_name.ipynb``)."""
    return sorted(p for p in (ROOT / "book").glob("[0-9][0-9]_*.ipynb"))


def build_student_archive(path: Path = STUDENT_ARCHIVE) -> tuple[Path, int]:
    """A zip of the chapters (solutions removed), the data, the library and its pinned
    requirements; return its path and the number of solutions removed."""
    import zipfile

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    n = 0
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("fivebar-student/README.txt", ARCHIVE_README)
        for nb_path in chapter_notebooks():
            nb = json.loads(nb_path.read_text(encoding="utf-8"))
            n += strip_notebook_solutions(nb)
            zf.writestr(f"fivebar-student/book/{nb_path.name}",
                        json.dumps(nb, indent=1, ensure_ascii=False) + "\n")
        files = [ROOT / f for f in ARCHIVE_FILES]
        for folder in ("data", "lib"):
            files += [p for p in sorted((ROOT / folder).rglob("*"))
                      if p.is_file() and "__pycache__" not in p.parts
                      and not any(part.endswith(".egg-info") for part in p.parts)]
        for f in files:
            if f.is_file():  # data/ links into lib/fivebar/data: stored as copies
                zf.write(f.resolve(), f"fivebar-student/{f.relative_to(ROOT).as_posix()}")
    tmp.replace(path)
    return path, n


def build_student(out: Path = BUILD / "student") -> Path:
    """The student edition (no solutions) in ``_build/student/html``, and the student archive
    (made first, so that the pages can offer it)."""
    archive, k = build_student_archive()
    print(f"[fivebar_build] {archive.relative_to(ROOT)}: {k} solutions removed from "
          f"{len(chapter_notebooks())} chapters")
    html = out / "html"
    stamp = html / ".fivebar-build-ok"
    stamp.unlink(missing_ok=True)
    _sphinx_build("html", html, out / ".doctrees", ROOT / "_toc.yml",
                  _edition_overrides("student"), tags=["student"])
    n = strip_sources(html)
    print(f"[fivebar_build] removed {n} solutions from the downloadable sources")
    stamp.touch()
    return html


# --------------------------------------------------------------------------------------------
# The PDF: Sphinx's LaTeX builder and XeLaTeX
# --------------------------------------------------------------------------------------------

#: What the PDF build needs besides the project's environment (Debian's TeX Live packages).
TEX_TOOLS = ("xelatex", "latexmk", "makeindex")
TEX_PACKAGES = ("texlive-latex-recommended", "texlive-latex-extra", "texlive-fonts-recommended",
                "texlive-xetex", "latexmk", "fonts-freefont-otf", "tex-gyre")


def missing_tex_tools() -> list[str]:
    """The TeX programs the PDF needs that are not on the PATH."""
    return [tool for tool in TEX_TOOLS if shutil.which(tool) is None]


def _sources() -> list[Path]:
    """Every file the book is built from (a PDF newer than all of them is up to date)."""
    out = [ROOT / "_config.yml", ROOT / "_toc.yml", ROOT / "CITATION.cff"]
    for folder, pattern in (("book", "**/*"), ("lib/fivebar", "**/*.py"), ("data", "*")):
        out += [p for p in (ROOT / folder).glob(pattern)
                if p.is_file() and ".ipynb_checkpoints" not in p.parts
                and "__pycache__" not in p.parts]
    return out


def _version() -> str:
    for line in (ROOT / "CITATION.cff").read_text().splitlines():
        if line.startswith("version:"):
            return line.split(":", 1)[1].strip().strip('"')
    return "unknown"


def _title_page(edition: str) -> str:
    """The LaTeX title page (``latex_elements['maketitle']``): title, authors, version and
    edition, and on its back the repository, the licence and how to cite, all from
    ``CITATION.cff`` (as the HTML book's front page, ``{title-page}``)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import fivebar_apparatus as app_

    config = yaml.safe_load((ROOT / "_config.yml").read_text())
    cff = app_.citation()
    title, _, subtitle = str(config["title"]).partition(": ")

    def esc(t: str) -> str:
        t = t.replace("\\", r"\textbackslash{}")
        for a, b in (("&", r"\&"), ("%", r"\%"), ("_", r"\_"), ("#", r"\#"), ("$", r"\$"), ("{", r"\{"), ("}", r"\}")):
            t = t.replace(a, b)
        return re.sub(r"\*([^*]+)\*", r"\\emph{\1}", t)
    extra = ("Student edition: the exercises without their solutions" if edition == "student"
             else "Instructor edition: the exercises with their solutions")
    repo = (r"\url{%s}" % cff["repository-code"]) if cff.get("repository-code") else \
        "the git repository this book is built from (its address goes into CITATION.cff when it is published)"
    cite = esc(app_.book_citation(cff))
    return r"""
\begin{titlepage}
\centering
\vspace*{0.18\textheight}
{\Huge\bfseries %s\par}
\vspace{0.8em}
{\LARGE %s\par}
\vspace{3em}
{\large Reproducing, checking and extending R.-G. Wang, G.-W. Cai and X.-R. Zhou (2011),\par
\emph{Mathematical Problems in Engineering}, Article ID 254547\par}
\vfill
{\large %s\par}
\vspace{1em}
{\large Version %s\par}
\vspace{0.5em}
{\normalsize %s\par}
\end{titlepage}
\thispagestyle{empty}
\noindent\textbf{Authors:} %s\par\medskip
\noindent\textbf{Repository:} %s\par\medskip
\noindent\textbf{Licence:} code BSD-3-Clause; text and figures CC BY 4.0.\par\medskip
\noindent\textbf{How to cite:} %s\par
\noindent and the paper it reproduces: R.-G. Wang, G.-W. Cai, X.-R. Zhou, An evolutionary analytic method
of multi-DOF nonlinear coupling dynamic model for controllable close-chain linkage mechanism system,
\emph{Mathematical Problems in Engineering} 2011, Article ID 254547, doi:10.1155/2011/254547.
Both are in CITATION.cff.\par\medskip
\noindent\textbf{Equation numbers:} (P2.7) is equation (2.7) of the paper; (8.3) is the third numbered
equation of chapter 8 of this book.\par
\clearpage
""" % (esc(title), esc(subtitle or ""), esc(app_.authors(cff)), _version(), extra, esc(app_.authors(cff)), repo, cite)


def build_latex(edition: str = "instructor") -> Path:
    """The LaTeX sources of the book (``_build/pdf/latex/fivebar.tex``; the student edition's
    in ``_build/pdf/student/latex``, so that the two editions can be built at the same time:
    each Sphinx build writes the notebooks' outputs beside its output folder, in
    ``jupyter_execute``)."""
    suffix = "" if edition == "instructor" else f"-{edition}"
    out = BUILD / "pdf" / ("latex" if edition == "instructor" else f"{edition}/latex")
    overrides = {**_edition_overrides(edition),
                 "latex_elements": {"maketitle": _title_page(edition),
                                    "papersize": "a4paper", "pointsize": "10pt",
                                    "releasename": "Version", "fncychap": ""}}
    _sphinx_build("latex", out, out.parent / f".doctrees-latex{suffix}", ROOT / "_toc.yml",
                  overrides, tags=[edition] if edition == "student" else None)
    return out / "fivebar.tex"


def run_latex(tex: Path) -> Path:
    """XeLaTeX (through latexmk and the Makefile Sphinx writes) on ``tex``; return the PDF."""
    missing = missing_tex_tools()
    if missing:
        raise SystemExit(f"the PDF needs {', '.join(missing)} (Debian: apt-get install "
                         f"{' '.join(TEX_PACKAGES)}); not found on the PATH")
    log = tex.with_suffix(".log")
    # -xelatex: latexmk's XeLaTeX passes write XDV only and xdvipdfmx makes the PDF once at the
    # end (Sphinx's Makefile advises it for latexmk >= 4.52b), instead of a PDF on every pass
    # with the figures embedded each time: about 40 % less CPU for the same PDF.
    run = subprocess.run(["make", "-C", str(tex.parent), "all-pdf",
                          "LATEXMKOPTS=-xelatex -interaction=nonstopmode -halt-on-error -silent"],
                         capture_output=True, text=True)
    pdf = tex.with_suffix(".pdf")
    if run.returncode != 0 or not pdf.is_file():
        tail = "\n".join((run.stdout + run.stderr).splitlines()[-30:])
        if log.is_file():
            errors = [line for line in log.read_text(errors="replace").splitlines()
                      if line.startswith("!")][:10]
            tail += "\nLaTeX errors:\n" + "\n".join(errors)
        raise SystemExit(f"XeLaTeX failed on {tex} (exit {run.returncode}):\n{tail}")
    return pdf


def build_pdf(edition: str = "instructor", force: bool = False) -> Path:
    """``_build/pdf/fivebar.pdf`` (``fivebar-student.pdf`` for the student edition).

    Nothing is done if the PDF is newer than every source of the book (``force`` rebuilds).
    """
    _edition_overrides(edition)
    pdf = pdf_path(edition)
    if not force and pdf.is_file():
        built = pdf.stat().st_mtime
        if all(p.stat().st_mtime <= built for p in _sources()):
            print(f"[fivebar_build] {pdf.relative_to(ROOT)} is up to date")
            return pdf
    missing = missing_tex_tools()
    if missing:  # fail before the Sphinx build, not after it
        raise SystemExit(f"the PDF needs {', '.join(missing)} (Debian: apt-get install "
                         f"{' '.join(TEX_PACKAGES)}); not found on the PATH")
    t0 = time.perf_counter()
    tex = build_latex(edition)
    t1 = time.perf_counter()
    made = run_latex(tex)
    t2 = time.perf_counter()
    pdf.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(made, pdf)
    print(f"[fivebar_build] {pdf.relative_to(ROOT)}: {pdf.stat().st_size / 1e6:.1f} MB; "
          f"Sphinx LaTeX build {t1 - t0:.0f} s, XeLaTeX {t2 - t1:.0f} s")
    return pdf


# --------------------------------------------------------------------------------------------
# The execution cache seeded from the stored outputs (``make test``, after nbval)
# --------------------------------------------------------------------------------------------


def seed_cache(cache_path: Path = CACHE) -> list[str]:
    """Put every notebook of ``book/`` with its *stored* outputs into the execution cache.

    Only for ``make test``, which runs it right after nbval (strict, every cell, no
    ``nbval-skip``) has re-executed every notebook and found its stored outputs reproduced:
    the stored outputs are then the executed outputs (up to ``tests/nbval_sanitize.cfg``), so
    the book builds that follow (the PDFs, the HTML book, the student edition) read them from
    the cache instead of executing every notebook a second time.  nbval's run has also
    written the files that running a notebook writes (``book/_generated/anim``).  A
    notebook already in the cache (same code cells) with the same outputs is left as it is;
    one whose stored outputs changed (re-executed, or mended, its code the same) is cached
    again, else the builds would show the old outputs; one edited later no longer matches its
    entry and ``make book`` executes it.  Returns the notebooks added.
    """
    import nbformat
    from jupyter_cache import get_cache

    def outputs(notebook) -> list:
        return [c.get("outputs", []) for c in notebook.cells if c.cell_type == "code"]

    cache = get_cache(str(cache_path))
    added = []
    for nb_path in sorted((ROOT / "book").glob("*.ipynb")):
        nb = nbformat.read(nb_path, as_version=4)
        try:
            record = cache.match_cache_notebook(nb)
            if outputs(cache.get_cache_bundle(record.pk).nb) == outputs(nb):
                continue
        except KeyError:
            pass
        cache.cache_notebook_file(str(nb_path), check_validity=False, overwrite=True)
        added.append(nb_path.relative_to(ROOT).as_posix())
    return added


# --------------------------------------------------------------------------------------------
# Sphinx extension: the {fivebar-pdf} role
# --------------------------------------------------------------------------------------------


def pdf_path(edition: str) -> Path:
    """Where ``make pdf`` writes the PDF of an edition."""
    return BUILD / "pdf" / (PDF_NAME if edition == "instructor" else f"fivebar-{edition}.pdf")


def _download(env, rawtext: str, text: str, target: Path, how: str):
    """A download link to ``target`` if it exists when the page is read, else the text and how
    to build it; the page depends on the file (read again when it appears or changes)."""
    from docutils import nodes
    from sphinx import addnodes

    rel = "/" + target.relative_to(ROOT).as_posix()  # "/..." is relative to the source folder
    if target.is_file() and env.app.builder.format == "html":
        node = addnodes.download_reference(rawtext, "", refdoc=env.docname, refdomain="",
                                           reftype="download", refexplicit=True,
                                           reftarget=rel)
        node += nodes.literal(rawtext, text, classes=["xref", "download"])
        size = target.stat().st_size / 1e6
        return [node, nodes.Text(f" ({size:.0f} MB)" if size >= 1 else f" ({size:.1f} MB)")], []
    env.note_dependency(target.relative_to(ROOT).as_posix())
    if env.app.builder.format != "html":  # in the PDF: no link (to itself, or to a build)
        return [nodes.Text(f"{text} (this document)" if target.suffix == ".pdf" else text)], []
    return [nodes.Text(text), nodes.Text(" (not built: run "), nodes.literal("", how),
            nodes.Text(")")], []


def _pdf_role(name, rawtext, text, lineno, inliner, options=None, content=None):
    env = inliner.document.settings.env
    edition = "student" if env.config.hide_solutions else "instructor"
    how = "make pdf" if edition == "instructor" else "make pdf EDITION=student"
    return _download(env, rawtext, text, pdf_path(edition), how)


def _archive_role(name, rawtext, text, lineno, inliner, options=None, content=None):
    """``{fivebar-archive}`text```: the student archive (built by ``make book-student``)."""
    env = inliner.document.settings.env
    return _download(env, rawtext, text, STUDENT_ARCHIVE, "make book-student")


def _drop_stale_pdf_copies(app, env) -> None:
    """Delete the build's copies of a PDF that has changed since, before Sphinx copies it.

    Sphinx copies download files over an older copy with a message ("will overwrite data")
    that later Sphinx versions turn into a warning, which the strict build would treat as an
    error.
    """
    if app.builder.format != "html":
        return
    for src in [*(pdf_path(e) for e in EDITIONS), STUDENT_ARCHIVE]:
        for old in Path(app.outdir, "_downloads").glob(f"*/{src.name}"):
            if not src.is_file() or old.stat().st_mtime < src.stat().st_mtime:
                old.unlink()


def setup(app):
    """Sphinx entry point: the ``{fivebar-pdf}`` role."""
    app.add_role("fivebar-pdf", _pdf_role)
    app.add_role("fivebar-archive", _archive_role)
    app.connect("env-updated", _drop_stale_pdf_copies)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("target", choices=("student", "pdf", "seed-cache", "datasets"))
    parser.add_argument("--edition", default="instructor", choices=EDITIONS,
                        help="edition printed by `pdf` (default: instructor)")
    parser.add_argument("--force", action="store_true",
                        help="`pdf`: rebuild even if the PDF is newer than every source")
    args = parser.parse_args(argv)
    os.chdir(ROOT)
    if args.target == "datasets":
        # what the book builds do at builder-inited (book/_ext/fivebar_teaching.py), done once
        # before builds that run at the same time
        from fivebar.book.datasets import write_datasets

        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from fivebar_teaching import GENERATED

        out = ROOT / GENERATED / "data"
        t0 = time.perf_counter()
        cost = write_datasets(out)
        print(f"[fivebar_build] data downloads in {out.relative_to(ROOT)}: "
              + ", ".join(f"{n} {c:.1f} s" for n, c in cost.items())
              + f" (total {time.perf_counter() - t0:.1f} s; 0 s = unchanged)")
    elif args.target == "seed-cache":
        added = seed_cache()
        print(f"[fivebar_build] execution cache seeded from the stored outputs of "
              f"{len(added)} notebooks (nbval has just reproduced them)")
    elif args.target == "student":
        print(f"[fivebar_build] student edition in {build_student().relative_to(ROOT)}")
    else:
        build_pdf(args.edition, force=args.force)
    return 0


if __name__ == "__main__":
    sys.exit(main())
