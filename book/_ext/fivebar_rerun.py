"""Rerun chapters of the book with a reader's parameter files (``make rerun``).

Run from the repository root with the project's environment (the Makefile does)::

    .venv/bin/python book/_ext/fivebar_rerun.py mine.toml                  # every chapter
    .venv/bin/python book/_ext/fivebar_rerun.py mine.toml --chapters 09 12 # chapters 09 and 12
    .venv/bin/python book/_ext/fivebar_rerun.py a.toml b.toml --name ab    # b.toml over a.toml

    make rerun PARAMS=mine.toml [CHAPTERS="09 12"] [JOBS=2] [HTML=0]

What it does, for each chapter (``book/NN_*.ipynb``; ``--chapters`` takes the numbers ``09``
or the names ``09_figure6``):

1. executes a copy of the notebook with papermill: papermill finds the chapter's cell tagged
   ``parameters`` and injects after it a cell ``PARAMS_FILES = ["/abs/path/mine.toml", ...]``
   (the files are made absolute, so that they are found from the kernel's working directory,
   ``book/``, as in the book's own build: a copy of the repository made of symbolic links,
   ``_build/rerun/<name>/_cwd/book``, whose ``_generated/`` (animation pages, CSV files the
   chapters write) is the rerun's own, so that the book's are not replaced).  The chapter is
   not edited.
2. writes the executed notebook to ``_build/rerun/<name>/NN_x.ipynb`` (``<name>``: the
   files' stems joined by ``+``, or ``--name``), outputs and errors included.
3. renders the executed notebooks to HTML, ``_build/rerun/<name>/html/index.html``: a Jupyter
   Book build with execution off of a temporary book (``_build/rerun/<name>/_src``) made of
   the rerun chapters, the book's ``_config.yml`` and extensions (so generated MyST sentences,
   ``{numref}`` and ``{erratum}`` roles and the book's directives render as in the book), a
   front page that lists the parameter files and their entries, the errata and references
   pages (targets of the ``{erratum}``, ``{assumption}`` and ``{cite}`` roles), and for each numbered chapter *not* rerun a one-line placeholder page with its title, so that
   chapter, figure and equation numbers are the book's.  Warnings are not errors here (no
   ``-W``): a reference from a rerun chapter into a chapter that was not rerun has no target
   and is reported as a warning, rendered as plain text.

Chapters run in parallel (``--jobs``, default 2: the kernels are separate processes, and the
numba cache is shared).  The exit status is 0 when every chapter ran without a cell error,
1 otherwise: each failure is named by chapter and cell (index in the executed notebook,
execution count, first line of the cell, the error; a failed physics check is a
``fivebar.book.chapter.CheckFailed``), and 2 for bad arguments (a file that does not exist, an
unknown chapter, a chapter without a ``parameters`` cell).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
BOOK = ROOT / "book"
OUT = ROOT / "_build" / "rerun"


def chapters() -> list[Path]:
    """The book's chapters, in reading order: ``book/NN_*.ipynb``."""
    return sorted(BOOK.glob("[0-9][0-9]_*.ipynb"))


def select(names: list[str] | None) -> list[Path]:
    """The chapters named by ``names`` (``"09"``, ``"09_figure6"``, ``"09_figure6.ipynb"``, or
    the path of a notebook elsewhere, executed with the kernel in ``book/`` all the same);
    all of them when ``names`` is empty."""
    every = chapters()
    if not names:
        return every
    out = []
    for name in names:
        if name.endswith(".ipynb") and Path(name).is_file():  # a copy elsewhere (tests)
            out.append(Path(name).resolve())
            continue
        stem = Path(name).stem
        hits = [p for p in every if p.stem == stem or p.stem.split("_", 1)[0] == stem]
        if len(hits) != 1:
            raise LookupError(f"fivebar_rerun: chapter {name!r} is not a chapter of the book "
                             f"(allowed: {', '.join(p.stem for p in every)}, or their numbers)")
        if hits[0] not in out:
            out.append(hits[0])
    return out


def has_parameters_cell(nb_path: Path) -> bool:
    nb = json.loads(nb_path.read_text())
    return any("parameters" in c.get("metadata", {}).get("tags", []) for c in nb["cells"]
               if c["cell_type"] == "code")


@dataclass
class Outcome:
    chapter: str
    output: Path
    seconds: float
    error: str | None = None


def _rel(path: Path) -> str:
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def _first_line(source: str) -> str:
    for line in source.splitlines():
        if line.strip():
            return line.strip()[:100]
    return ""


def shadow_tree(outdir: Path) -> Path:
    """``outdir/_cwd``: the repository seen through symbolic links, except ``book/_generated``
    (a directory of its own), so that what a chapter writes there (its animation pages, CSV
    files) stays with the rerun and never replaces the book's.  Returns its ``book/``."""
    cwd = outdir / "_cwd"
    shutil.rmtree(cwd, ignore_errors=True)
    (cwd / "book" / "_generated").mkdir(parents=True)
    for entry in ROOT.iterdir():
        if entry.name not in ("book", "_build", ".git"):
            os.symlink(entry, cwd / entry.name)
    for entry in BOOK.iterdir():
        if entry.name != "_generated":
            os.symlink(entry, cwd / "book" / entry.name)
    return cwd / "book"


def run_chapter(nb_path: Path, params_files: list[str], outdir: Path, cwd: Path = BOOK) -> Outcome:
    """Execute one chapter with papermill, the kernel in ``cwd`` (the book's directory or its
    :func:`shadow_tree`); the executed notebook goes to ``outdir``."""
    import papermill as pm
    from papermill.exceptions import PapermillExecutionError

    output = outdir / nb_path.name
    t0 = time.perf_counter()
    try:
        pm.execute_notebook(str(nb_path), str(output), parameters={"PARAMS_FILES": params_files},
                            cwd=str(cwd), progress_bar=False, log_output=False,
                            report_mode=False, request_save_on_cell_execute=False)
    except PapermillExecutionError as exc:
        # papermill puts an error banner first: find the cell by its execution count
        nb = json.loads(output.read_text())
        cells = [(i, c) for i, c in enumerate(nb["cells"])
                 if c["cell_type"] == "code" and c.get("execution_count") == exc.exec_count]
        where, source = (cells[0][0], "".join(cells[0][1]["source"])) if cells else (exc.cell_index, "")
        kind = "failed physics check" if exc.ename.endswith("CheckFailed") else "cell error"
        msg = (f"{nb_path.stem}: {kind} in cell In [{exc.exec_count}] (cell {where} of "
               f"{_rel(output)}: `{_first_line(source)}`): {exc.ename}: {exc.evalue}")
        return Outcome(nb_path.stem, output, time.perf_counter() - t0, msg)
    except Exception as exc:  # the kernel died, a timeout, ...
        return Outcome(nb_path.stem, output, time.perf_counter() - t0,
                       f"{nb_path.stem}: {type(exc).__name__}: {exc}")
    return Outcome(nb_path.stem, output, time.perf_counter() - t0)


def _title(nb_path: Path) -> str:
    nb = json.loads(nb_path.read_text())
    for cell in nb["cells"]:
        if cell["cell_type"] == "markdown":
            for line in "".join(cell["source"]).splitlines():
                if line.startswith("# "):
                    return line[2:].strip()
    return nb_path.stem


def _front_page(name: str, params_files: list[str], rerun: list[Path], failed: set[str]) -> str:
    lines = [f"# Rerun `{name}`: the book's chapters with your parameters", "",
             "These pages are the book's chapters executed with the parameter files below, layered "
             "entry by entry over the book's (`make rerun`, see the book's page \"Run it yourself\"). "
             "Chapters not rerun appear as one-line placeholders, so that the numbers of "
             "chapters, figures and equations are the book's; references into them are plain text.",
             ""]
    for f in params_files:
        lines += [f"## `{f}`", "", "```toml", Path(f).read_text().rstrip(), "```", ""]
    lines += ["## Chapters rerun", ""]
    for p in rerun:
        state = " (**stopped by an error**: see the page's last executed cell)" if p.stem in failed else ""
        lines.append(f"- {{doc}}`/book/{p.stem}`{state}")
    return "\n".join(lines) + "\n"


def build_html(name: str, outdir: Path, params_files: list[str], rerun: list[Path],
               failed: set[str]) -> int:
    """Render the executed notebooks in ``outdir`` as a Jupyter Book (execution off, no -W)."""
    from jupyter_book.sphinx import build_sphinx

    outdir = outdir.resolve()
    src = outdir / "_src"
    shutil.rmtree(src, ignore_errors=True)
    (src / "book").mkdir(parents=True)
    os.symlink(BOOK / "_ext", src / "book" / "_ext")
    os.symlink(outdir / "_cwd" / "book" / "_generated", src / "book" / "_generated")
    for f in ("references.bib", "references.md", "errata.md"):
        shutil.copy(BOOK / f, src / "book" / f)
    (src / "book" / "index.md").write_text(_front_page(name, params_files, rerun, failed))
    names = {p.stem for p in rerun}
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text())
    parts = []
    for part in toc["parts"]:
        if not part.get("numbered"):
            continue
        for entry in part["chapters"]:
            stem = Path(entry["file"]).name
            if stem in names:
                shutil.copy(outdir / f"{stem}.ipynb", src / "book" / f"{stem}.ipynb")
            else:
                title = _title(BOOK / f"{stem}.ipynb")
                (src / "book" / f"{stem}.md").write_text(
                    f"# {title}\n\nNot rerun: this chapter is the book's, with the book's parameters.\n")
        parts.append(part)
    parts.append({"caption": "Reference",
                  "chapters": [{"file": "book/errata"}, {"file": "book/references"}]})
    toc = {"format": "jb-book", "root": "book/index", "parts": parts}
    (src / "_toc.yml").write_text(yaml.safe_dump(toc, sort_keys=False))
    config = yaml.safe_load((ROOT / "_config.yml").read_text())
    config["title"] = f"fivebar, rerun with {name}"
    config["execute"]["execute_notebooks"] = "off"
    (src / "_config.yml").write_text(yaml.safe_dump(config, sort_keys=False))
    return build_sphinx(src, outdir / "html", use_external_toc=True, noconfig=True,
                        path_config=str(src / "_config.yml"),
                        confoverrides={"external_toc_path": str(src / "_toc.yml"),
                                       "latex_individualpages": False},
                        doctreedir=outdir / ".doctrees", builder="html",
                        warningiserror=False, keep_going=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fivebar_rerun.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("params", nargs="+", help="TOML files, layered in this order over the book's")
    ap.add_argument("--chapters", nargs="*", default=[], metavar="NN",
                    help="chapters to rerun (numbers such as 09, or names); default: all")
    ap.add_argument("--name", help="the name of the rerun, _build/rerun/<name> "
                    "(default: the files' stems joined by '+')")
    ap.add_argument("--jobs", type=int, default=2, help="chapters executed in parallel (default 2)")
    ap.add_argument("--no-html", action="store_true", help="only the executed notebooks")
    ap.add_argument("--out", type=Path, default=OUT, help="default: _build/rerun")
    args = ap.parse_args(argv)

    files = []
    for f in args.params:
        p = Path(f).expanduser().resolve()
        if not p.is_file():
            print(f"fivebar_rerun: parameter file {f!r} does not exist (looked for {p})", file=sys.stderr)
            return 2
        files.append(str(p))
    if args.jobs < 1:
        print(f"fivebar_rerun: --jobs {args.jobs} is not allowed: give 1 or more", file=sys.stderr)
        return 2
    try:
        selected = select(args.chapters)
    except LookupError as exc:
        print(exc, file=sys.stderr)
        return 2
    missing = [p.stem for p in selected if not has_parameters_cell(p)]
    if missing:
        print(f"fivebar_rerun: no cell tagged 'parameters' in {', '.join(missing)}: "
              "these chapters cannot be rerun with other parameters", file=sys.stderr)
        return 2
    name = args.name or "+".join(Path(f).stem for f in files)
    outdir = args.out.resolve() / name
    for old in outdir.glob("[0-9][0-9]_*.ipynb"):
        old.unlink()
    outdir.mkdir(parents=True, exist_ok=True)
    cwd = shadow_tree(outdir)

    t0 = time.perf_counter()
    print(f"rerunning {len(selected)} chapter(s) with {', '.join(files)} on {args.jobs} process(es) "
          f"into {outdir}", flush=True)
    outcomes = []
    if args.jobs == 1 or len(selected) == 1:
        for p in selected:
            outcomes.append(run_chapter(p, files, outdir, cwd))
            print(f"  {outcomes[-1].chapter}: {'FAILED' if outcomes[-1].error else 'ok'} "
                  f"({outcomes[-1].seconds:.0f} s)", flush=True)
    else:
        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            futures = [pool.submit(run_chapter, p, files, outdir, cwd) for p in selected]
            for fut in futures:
                outcomes.append(fut.result())
                print(f"  {outcomes[-1].chapter}: {'FAILED' if outcomes[-1].error else 'ok'} "
                      f"({outcomes[-1].seconds:.0f} s)", flush=True)
    t_exec = time.perf_counter() - t0
    failed = [o for o in outcomes if o.error]
    print(f"executed in {t_exec:.0f} s", flush=True)

    html_status = 0
    if not args.no_html:
        t1 = time.perf_counter()
        try:
            html_status = build_html(name, outdir, files, selected, {o.chapter for o in failed})
        except Exception as exc:  # a book extension that stops the build
            print(f"fivebar_rerun: the HTML build failed: {type(exc).__name__}: {exc}", file=sys.stderr)
            html_status = 1
        print(f"HTML in {time.perf_counter() - t1:.0f} s: {outdir / 'html' / 'index.html'}"
              + ("" if html_status == 0 else f" (the build failed: {html_status})"), flush=True)
    for o in failed:
        print(f"fivebar_rerun: {o.error}", file=sys.stderr)
    if failed:
        print(f"fivebar_rerun: {len(failed)} of {len(outcomes)} chapter(s) failed", file=sys.stderr)
        return 1
    return 1 if html_status else 0


if __name__ == "__main__":
    sys.exit(main())
