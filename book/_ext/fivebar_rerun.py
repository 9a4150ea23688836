"""Rerun chapters of the book with a reader's parameter files (``make rerun``).

Run from the repository root with the project's environment (the Makefile does)::

    .venv/bin/python book/_ext/fivebar_rerun.py mine.toml                  # every chapter
    .venv/bin/python book/_ext/fivebar_rerun.py mine.toml --chapters 09 12 # chapters 09 and 12
    .venv/bin/python book/_ext/fivebar_rerun.py a.toml b.toml --name ab    # b.toml over a.toml
    .venv/bin/python book/_ext/fivebar_rerun.py a.toml b.toml --each       # each alone: the matrix

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
numba cache is shared), each kernel with the machine's cores shared out as BLAS threads
(``OPENBLAS_NUM_THREADS`` and its like, unless set by the caller).  Each run's wall time and
CPU time (the kernel and the worker processes it started) are printed.  ``--each`` reruns the chapters with every file alone instead of
layered, all chapter runs of all files in one pool of ``--jobs`` processes, the chapters that
took longest in the book's own run first (their stored execution times): the rerun matrix of
``make rerun-examples``, printed and written to ``_build/rerun/matrix.md`` as a table chapter x
file: "ok", "ok, n not applicable" (the chapter's note at its top,
:class:`fivebar.book.chapter.Applicability`, said that n of its studies do not apply, listed
below the table), or "FAILED", each with its CPU seconds.  The exit status is 0 when every chapter ran without a cell error,
1 otherwise: each failure is named by chapter and cell (index in the executed notebook,
execution count, first line of the cell, the error; a failed physics check is a
``fivebar.book.chapter.CheckFailed``), and 2 for bad arguments (a file that does not exist, an
unknown chapter, a chapter without a ``parameters`` cell).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
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
    cpu: float = float("nan")  # CPU seconds of the kernel and its worker processes
    notes: tuple[str, ...] = ()  # what the chapter says does not apply (its applicability note)


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
    c0 = _children_cpu()
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
        return Outcome(nb_path.stem, output, time.perf_counter() - t0, msg, _children_cpu() - c0)
    except Exception as exc:  # the kernel died, a timeout, ...
        return Outcome(nb_path.stem, output, time.perf_counter() - t0,
                       f"{nb_path.stem}: {type(exc).__name__}: {exc}", _children_cpu() - c0)
    return Outcome(nb_path.stem, output, time.perf_counter() - t0, None, _children_cpu() - c0,
                   applicability_notes(output))


def _children_cpu() -> float:
    """CPU seconds (user + system) of this process's children that have ended (a chapter's
    kernel, with the worker processes it waited for)."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


#: the first line of a chapter's note of the studies that do not apply to the reader's linkage
#: (:class:`fivebar.book.chapter.Applicability`)
NOTE_MARK = ":::{admonition} With your parameters"


def applicability_notes(nb_path: Path) -> tuple[str, ...]:
    """The items of the chapter's applicability note in an executed notebook (empty: every study
    of the chapter applied)."""
    try:
        nb = json.loads(nb_path.read_text())
    except (OSError, ValueError):
        return ()
    for cell in nb["cells"]:
        for out in cell.get("outputs", []):
            md = out.get("data", {}).get("text/markdown", "")
            md = "".join(md) if isinstance(md, list) else md
            if md.startswith(NOTE_MARK):
                return tuple(line[2:].strip() for line in md.splitlines() if line.startswith("* "))
    return ()


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


def book_seconds(nb_path: Path) -> float:
    """The chapter's execution time as stored with the book's outputs (its cells' execution
    timestamps; 0 if it has none): the order in which a matrix starts its chapters, longest
    first, so that the last to finish are short."""
    from datetime import datetime

    try:
        cells = [c.get("metadata", {}).get("execution") for c in json.loads(nb_path.read_text())["cells"]]
        cells = [c for c in cells if c]
        a = datetime.fromisoformat(cells[0]["iopub.execute_input"].rstrip("Z"))
        b = datetime.fromisoformat(cells[-1]["shell.execute_reply"].rstrip("Z"))
        return (b - a).total_seconds()
    except (OSError, ValueError, KeyError, IndexError):
        return 0.0


def _matrix(runs: dict[str, list[Outcome]], chapters: list[Path], wall: float) -> str:
    """The matrix of a rerun of several files (``--each``) as a Markdown table: chapter x file,
    "ok" (or "ok, n not applicable" with the notes below), "FAILED", and the CPU seconds."""
    names = list(runs)
    head = "| chapter | " + " | ".join(f"`{n}`" for n in names) + " | CPU (s) |"
    lines = [head, "|" + "---|" * (len(names) + 2)]
    notes = []
    for p in chapters:
        row, cpu = [], 0.0
        for n in names:
            o = next((o for o in runs[n] if o.chapter == p.stem), None)
            if o is None:
                row.append("-")
                continue
            cpu += o.cpu
            if o.error:
                row.append(f"FAILED ({o.cpu:.0f} s)")
            elif o.notes:
                row.append(f"ok, {len(o.notes)} not applicable ({o.cpu:.0f} s)")
                notes += [f"- {p.stem} with `{n}`: {t}" for t in o.notes]
            else:
                row.append(f"ok ({o.cpu:.0f} s)")
        lines.append(f"| {p.stem} | " + " | ".join(row) + f" | {cpu:.0f} |")
    total = sum(o.cpu for out in runs.values() for o in out)
    lines += ["", f"CPU {total:.0f} s in all, {wall:.0f} s of wall time."]
    if notes:
        lines += ["", "What the chapters said does not apply:", "", *notes]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fivebar_rerun.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("params", nargs="+", help="TOML files, layered in this order over the book's")
    ap.add_argument("--chapters", nargs="*", default=[], metavar="NN",
                    help="chapters to rerun (numbers such as 09, or names); default: all")
    ap.add_argument("--name", help="the name of the rerun, _build/rerun/<name> "
                    "(default: the files' stems joined by '+')")
    ap.add_argument("--each", action="store_true",
                    help="rerun with each file alone (not layered), every chapter with every file in one pool of "
                    "--jobs processes (the matrix of make rerun-examples): _build/rerun/<stem> per file, and the "
                    "matrix of outcomes and CPU times in _build/rerun/matrix.md")
    ap.add_argument("--only-with", nargs="*", default=[], metavar="NN=STEM[,STEM]",
                    help="with --each: chapter NN reruns only with the files of these stems (the others show "
                    "'-' in the matrix); CI keeps its longest chapters to some files so")
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
    if args.each and args.name:
        print("fivebar_rerun: --name is not allowed with --each (each file's rerun is named by its stem)",
              file=sys.stderr)
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
    # the reruns: one of the files layered, or (--each) one per file
    runs = {Path(f).stem: [f] for f in files} if args.each else \
        {args.name or "+".join(Path(f).stem for f in files): files}
    if args.each and len(runs) < len(files):
        print("fivebar_rerun: --each needs files of different names (stems)", file=sys.stderr)
        return 2
    dirs, cwds = {}, {}
    for name in runs:
        outdir = args.out.resolve() / name
        for old in outdir.glob("[0-9][0-9]_*.ipynb"):
            old.unlink()
        outdir.mkdir(parents=True, exist_ok=True)
        dirs[name], cwds[name] = outdir, shadow_tree(outdir)
    only: dict[str, set[str]] = {}
    for rule in args.only_with:
        nn, _, stems = rule.partition("=")
        try:
            (chapter,) = select([nn])
        except (LookupError, ValueError):
            chapter = None
        if not args.each or chapter is None or not stems or not set(stems.split(",")) <= set(runs):
            print(f"fivebar_rerun: --only-with {rule!r} is not allowed: give NN=STEM[,STEM] with --each, a chapter "
                  f"and stems of the files given ({', '.join(runs)})", file=sys.stderr)
            return 2
        only[chapter.stem] = set(stems.split(","))
    # every chapter of every rerun, the longest (by the book's own times) first
    order = sorted(selected, key=book_seconds, reverse=True) if len(runs) > 1 else selected
    tasks = [(name, p) for p in order for name in runs if name in only.get(p.stem, {name})]

    # the machine's cores shared out among the kernels as BLAS threads (as `make test` does for nbval's
    # workers), unless the caller set them: with OpenBLAS's default, a thread per core in each of the
    # --jobs kernels, chapters 05 and 07 took 4 times as long on 2 cores (144 s against 37 s for
    # both with two files, 2026-12-04)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, str(max(1, cores // args.jobs)))

    t0 = time.perf_counter()
    what = f"each of {len(files)} files" if args.each else ", ".join(files)
    print(f"rerunning {len(selected)} chapter(s) with {what} on {args.jobs} process(es) into "
          f"{args.out.resolve() if args.each else dirs[next(iter(runs))]}", flush=True)
    outcomes: dict[str, list[Outcome]] = {name: [] for name in runs}

    def report(name: str, o: Outcome) -> None:
        outcomes[name].append(o)
        tag = f"{name}: " if args.each else ""
        state = "FAILED" if o.error else "ok" + (f", {len(o.notes)} not applicable" if o.notes else "")
        print(f"  {tag}{o.chapter}: {state} ({o.seconds:.0f} s, CPU {o.cpu:.0f} s)", flush=True)

    if args.jobs == 1 or len(tasks) == 1:
        for name, p in tasks:
            report(name, run_chapter(p, runs[name], dirs[name], cwds[name]))
    else:
        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            futures = [(name, pool.submit(run_chapter, p, runs[name], dirs[name], cwds[name])) for name, p in tasks]
            for name, fut in futures:
                report(name, fut.result())
    t_exec = time.perf_counter() - t0
    failed = [o for out in outcomes.values() for o in out if o.error]
    print(f"executed in {t_exec:.0f} s (CPU {sum(o.cpu for out in outcomes.values() for o in out):.0f} s)",
          flush=True)
    if args.each:
        table = _matrix(outcomes, selected, t_exec)
        (args.out.resolve() / "matrix.md").write_text(table)
        print(table, flush=True)

    html_status = 0
    if not args.no_html:
        for name, rerun_files in runs.items():
            t1 = time.perf_counter()
            try:
                status = build_html(name, dirs[name], rerun_files, selected,
                                    {o.chapter for o in outcomes[name] if o.error})
            except Exception as exc:  # a book extension that stops the build
                print(f"fivebar_rerun: the HTML build failed: {type(exc).__name__}: {exc}", file=sys.stderr)
                status = 1
            html_status = html_status or status
            print(f"HTML in {time.perf_counter() - t1:.0f} s: {dirs[name] / 'html' / 'index.html'}"
                  + ("" if status == 0 else f" (the build failed: {status})"), flush=True)
    for o in failed:
        print(f"fivebar_rerun: {o.error}", file=sys.stderr)
    if failed:
        print(f"fivebar_rerun: {len(failed)} of {sum(len(v) for v in outcomes.values())} chapter run(s) failed",
              file=sys.stderr)
        return 1
    return 1 if html_status else 0


if __name__ == "__main__":
    sys.exit(main())
