"""Teaching kit of the fivebar book: course map, learning objectives, data downloads, animations.

Loaded by ``_config.yml`` (``sphinx.local_extensions``) next to ``fivebar_book``.

1. **Course map** from one data file, ``book/course.toml``: ``{course-map} chapters`` renders
   the table of chapters (objectives, prerequisites, time, core/optional and why),
   ``{course-map} semester`` and ``{course-map} short`` the suggested paths, and
   ``{learning-objectives}`` (no argument) the current chapter's entry, for the top of a
   chapter.

2. **Data downloads**: at ``builder-inited`` the CSV files of :mod:`fivebar.book.datasets` are
   written to ``book/_generated/data/`` (not in git; skipped when the parameter file and the
   library's sources are unchanged), and ``{data-downloads}`` lists the current chapter's
   files as download links (Sphinx copies them to ``_downloads/``).

3. **Animations**: :func:`fivebar.book.animation.show` writes a page next to the notebook
   (``book/_generated/anim/*.html``, written when the notebook runs) and displays an iframe;
   at ``build-finished`` the pages are copied next to the built chapters, and a chapter whose
   iframe names a missing page fails the build.
"""

from __future__ import annotations

import re
import shutil
import time
import tomllib
from pathlib import Path
from typing import Any

from docutils import nodes
from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.errors import ExtensionError
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

# the book's one docutils table builder (book/_ext is on sys.path beside this module)
from fivebar_book import _table

logger = logging.getLogger(__name__)

__version__ = "1.0"

#: The course data, relative to the source directory.
COURSE_FILE = "book/course.toml"
#: Generated files (CSV, animation pages), relative to the source directory; not in git.
GENERATED = "book/_generated"
_ROLES = ("core", "optional", "reference")


# --------------------------------------------------------------------------------------------
# 1. Course map
# --------------------------------------------------------------------------------------------

def load_course(path: str | Path) -> dict[str, Any]:
    """Read and check ``course.toml``; raise ValueError naming the bad entry."""
    path = Path(path)
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    chapters = data.get("chapter")
    if not isinstance(chapters, list) or not chapters:
        raise ValueError(f"{path}: no [[chapter]] entries")
    files = set()
    for i, ch in enumerate(chapters):
        where = f"{path}: chapter {i + 1} ({ch.get('file', '?')})"
        for key, kind in (("file", str), ("title", str), ("objectives", list), ("prerequisites", list),
                          ("reading", int), ("working", int), ("role", str), ("why", str)):
            if not isinstance(ch.get(key), kind) or isinstance(ch.get(key), bool):
                raise ValueError(f"{where}: {key} = {ch.get(key)!r} is not allowed: give a {kind.__name__}")
        n = len(ch["objectives"])
        if ch["role"] != "reference" and not 3 <= n <= 5:
            raise ValueError(f"{where}: {n} objectives; give 3 to 5")
        if ch["role"] not in _ROLES:
            raise ValueError(f"{where}: role = {ch['role']!r} is not allowed: use one of {list(_ROLES)}")
        if ch["reading"] < 0 or ch["working"] < 0:
            raise ValueError(f"{where}: reading and working are minutes >= 0")
        for f in [ch["file"], *ch.get("formerly", [])]:
            if f in files:
                raise ValueError(f"{where}: file {f!r} appears twice")
            files.add(f)
    for name, p in (data.get("path") or {}).items():
        for step in p.get("steps", []):
            for f in step.get("chapters", []):
                if f not in files and f != "book/index":
                    raise ValueError(f"{path}: path {name!r}, {step.get('label')}: unknown chapter {f!r}")
    project = data.get("project")
    if project is not None:
        for key in ("title", "task", "deliverables", "rubric"):
            if not project.get(key):
                raise ValueError(f"{path}: [project] needs {key!r}")
        weights = [r.get("weight") for r in project["rubric"]]
        if not all(isinstance(w, int) and w > 0 for w in weights) or sum(weights) != 100:
            raise ValueError(f"{path}: [project] rubric weights = {weights} are not allowed: give positive "
                             "integers (per cent) that sum to 100")
    return data


def chapter_entry(course: dict[str, Any], docname: str) -> dict[str, Any] | None:
    """The entry of ``docname`` (by ``file`` or a ``formerly`` name), or None."""
    for ch in course["chapter"]:
        if docname == ch["file"] or docname in ch.get("formerly", []):
            return ch
    return None


def _course(directive: SphinxDirective) -> dict[str, Any]:
    path = Path(directive.env.srcdir) / COURSE_FILE
    directive.env.note_dependency(str(path))
    try:
        return load_course(path)
    except (OSError, ValueError, tomllib.TOMLDecodeError) as exc:
        raise directive.error(f"course map: {exc}") from exc


def _doc_ref(env, target: str, text: str | None = None) -> nodes.Node:
    """A link to a chapter, or its title in plain text if it is not part of this build."""
    alive = [d for d in (target,) if d in env.found_docs]
    if not alive:
        return nodes.emphasis(text=(text or target) + " (planned)")
    ref = addnodes.pending_xref("", refdomain="std", reftype="doc", reftarget="/" + target,
                                refexplicit=text is not None, refwarn=True)
    ref += nodes.inline(text=text or target)
    return ref


def _resolve(env, course, f: str) -> str:
    """A chapter file as built: its new name, or a former one still in the build."""
    ch = chapter_entry(course, f)
    for name in [f, *((ch or {}).get("formerly", []))]:
        if name in env.found_docs:
            return name
    return f


_NUMBERED = re.compile(r"^book/(\d\d)_")


def chapter_number(f: str) -> int | None:
    """The number of a chapter file (``book/07_excitation`` -> 7), as the HTML, the PDF and the
    student edition number it: the numbered chapters' files carry their number (_toc.yml lists
    them in that order, no gaps; tests/test_course.py checks it).  None for the other pages."""
    m = _NUMBERED.match(f)
    return int(m.group(1)) if m else None


def _titled(course, f: str) -> str | None:
    """A chapter's title with its number ("Chapter 7: Excitation ..."), or None if not in the map."""
    ch = chapter_entry(course, f)
    if ch is None:
        return None
    n = chapter_number(f)
    return f"Chapter {n}: {ch['title']}" if n is not None else ch["title"]


def _exercise_refs(labels: list[str]) -> nodes.paragraph:
    """Links to exercises by their labels (sphinx-exercise numbers them: "Exercise 3.1")."""
    p = nodes.paragraph()
    p += nodes.emphasis(text="Exercises: ")
    for k, label in enumerate(labels):
        if k:
            p += nodes.Text(", ")
        ref = addnodes.pending_xref("", refdomain="std", reftype="ref", reftarget=label,
                                    refexplicit=False, refwarn=True)
        ref += nodes.inline(text=label)
        p += ref
    return p


def _hours(minutes: int) -> str:
    return f"{minutes} min" if minutes < 60 else f"{minutes / 60:.1f} h".replace(".0 h", " h")


def _bullets(items: list[nodes.Node]) -> nodes.bullet_list:
    ul = nodes.bullet_list()
    for it in items:
        li = nodes.list_item()
        li += it if isinstance(it, nodes.paragraph) else nodes.paragraph("", "", it)
        ul += li
    return ul


def _prereq(directive: SphinxDirective, course, ch) -> nodes.paragraph:
    """A chapter's prerequisites: chapters as links, outside knowledge as MyST (maths as $...$)."""
    env = directive.env
    p = nodes.paragraph()
    if not ch["prerequisites"]:
        p += nodes.Text("none")
    for k, item in enumerate(ch["prerequisites"]):
        if k:
            p += nodes.Text("; ")
        if item.startswith("book/"):
            other = chapter_entry(course, item)
            p += _doc_ref(env, _resolve(env, course, item), other["title"] if other else item)
        else:
            p += _inline(directive, item)
    return p


def _inline(directive: SphinxDirective, text: str) -> list[nodes.Node]:
    parsed, msgs = directive.state.inline_text(text, directive.lineno)
    return [*parsed, *msgs]


class LearningObjectives(SphinxDirective):
    """``{learning-objectives}``: the current chapter's objectives, prerequisites and time."""

    has_content = False
    optional_arguments = 1  # a chapter file, to show another chapter's entry

    def run(self) -> list[nodes.Node]:
        course = _course(self)
        doc = self.arguments[0] if self.arguments else self.env.docname
        ch = chapter_entry(course, doc)
        if ch is None:
            raise self.error(f"learning-objectives: {doc!r} has no [[chapter]] entry in {COURSE_FILE}")
        box = nodes.admonition(classes=["fivebar-objectives", "tip"])
        box += nodes.title(text="Learning objectives")
        box += nodes.paragraph(text="After this chapter you can:")
        box += _bullets([nodes.paragraph("", "", *_inline(self, o)) for o in ch["objectives"]])
        pre = _prereq(self, course, ch)
        pre.insert(0, nodes.strong(text="Prerequisites: "))
        box += pre
        box += nodes.paragraph(
            "", "", nodes.strong(text="Time: "),
            nodes.Text(f"reading {_hours(ch['reading'])}, exercises and reruns {_hours(ch['working'])}.  "),
            nodes.strong(text=f"In a course: {ch['role']}."), nodes.Text(f" {ch['why']} "),
            _doc_ref(self.env, "book/course", "Course map"), nodes.Text("."),
        )
        return [box]




class CourseMap(SphinxDirective):
    """``{course-map} chapters`` | ``semester`` | ``short``: tables from ``course.toml``."""

    required_arguments = 1
    has_content = False

    def run(self) -> list[nodes.Node]:
        course = _course(self)
        what = self.arguments[0]
        env = self.env
        if what == "chapters":
            rows = []
            total = {r: [0, 0] for r in _ROLES}
            for ch in course["chapter"]:
                name = nodes.container()
                name += nodes.paragraph("", "", _doc_ref(env, _resolve(env, course, ch["file"]), _titled(course, ch["file"])))
                name += nodes.paragraph("", "", nodes.strong(text=ch["role"]))
                name += nodes.paragraph(text=f"{_hours(ch['reading'])} reading, {_hours(ch['working'])} working")
                obj = _bullets([nodes.paragraph("", "", *_inline(self, o)) for o in ch["objectives"]])
                pre = nodes.container()
                pre += _prereq(self, course, ch)
                pre += nodes.paragraph("", "", nodes.emphasis(text=f"{ch['role'].capitalize()}: "), nodes.Text(ch["why"]))
                rows.append([name, obj, pre])
                total[ch["role"]][0] += ch["reading"]
                total[ch["role"]][1] += ch["working"]
            table = _table(["Chapter, role and time", "After it you can", "Prerequisites, and why this role"],
                           rows, [22, 48, 30], ["fivebar-course-map"])
            note = nodes.paragraph(text="Total time: " + "; ".join(
                f"{r} chapters {_hours(a)} reading + {_hours(b)} working" for r, (a, b) in total.items() if a or b) + ".")
            return [table, note]
        if what == "project":
            return self._project(course)
        paths = course.get("path") or {}
        if what not in paths:
            raise self.error(f"course-map: {what!r} is not allowed: use 'chapters', 'project' or one of {sorted(paths)}")
        p = paths[what]
        rows = []
        for step in p["steps"]:
            docs = nodes.paragraph()
            for k, f in enumerate(step["chapters"]):
                if k:
                    docs += nodes.Text(", ")
                docs += _doc_ref(env, _resolve(env, course, f), _titled(course, f))
            work = nodes.container()
            work += nodes.paragraph("", "", *_inline(self, step["work"]))
            if step.get("exercises"):
                work += _exercise_refs(step["exercises"])
            rows.append([nodes.paragraph(text=step["label"]), docs, work])
        out = [nodes.paragraph("", "", nodes.strong(text=p["title"] + ". "), nodes.Text(p.get("audience", "")))]
        out.append(_table(["When", "Chapters", "What to do"], rows, [16, 34, 50], ["fivebar-course-path"]))
        return out

    def _project(self, course: dict[str, Any]) -> list[nodes.Node]:
        """The course project of ``[project]``: the task, what to hand in and the rubric."""
        pr = course.get("project")
        if not pr:
            raise self.error(f"course-map project: {COURSE_FILE} has no [project] section")
        out = [nodes.paragraph("", "", nodes.strong(text=pr["title"] + ". "), *_inline(self, pr["task"]))]
        out.append(nodes.paragraph("", "", nodes.strong(text="Hand in: "), *_inline(self, pr["deliverables"])))
        rows = []
        for r in pr["rubric"]:
            crit = nodes.container()
            crit += nodes.paragraph("", "", nodes.strong(text=r["criterion"]))
            crit += nodes.paragraph(text=f"{r['weight']} % of the mark")
            levels = nodes.container()
            for name in ("excellent", "adequate", "insufficient"):
                levels += nodes.paragraph("", "", nodes.emphasis(text=name.capitalize() + ": "), *_inline(self, r[name]))
            rows.append([crit, levels])
        out.append(_table(["Criterion and weight", "What earns it"], rows, [26, 74], ["fivebar-course-path"]))
        return out


# --------------------------------------------------------------------------------------------
# 2. Data downloads
# --------------------------------------------------------------------------------------------

def downloads_for(docname: str) -> list[str]:
    """Names of the :data:`fivebar.book.datasets.DATASETS` that chapter ``docname`` links."""
    from fivebar.book.datasets import DATASETS

    base = docname.rsplit("/", 1)[-1]
    return [n for n, d in DATASETS.items() if d.chapter == base]


class DataDownloads(SphinxDirective):
    """``{data-downloads}``: download links to the current chapter's CSV files."""

    has_content = False
    optional_arguments = 1

    def run(self) -> list[nodes.Node]:
        from fivebar.book.datasets import DATASETS

        doc = self.arguments[0] if self.arguments else self.env.docname
        names = downloads_for(doc)
        if not names:
            raise self.error(f"data-downloads: no dataset belongs to {doc!r}; "
                             f"datasets: { {n: d.chapter for n, d in DATASETS.items()} }")
        items = []
        for n in names:
            target = f"/{GENERATED}/data/{n}.csv"
            ref = addnodes.download_reference("", "", refdomain="", reftype="download", refexplicit=True,
                                              reftarget=target, refdoc=self.env.docname, refwarn=True)
            ref += nodes.literal(text=f"{n}.csv")
            items.append(nodes.paragraph("", "", ref, nodes.Text(f": {DATASETS[n].title}.")))
        box = nodes.admonition(classes=["fivebar-downloads", "note"])
        box += nodes.title(text="Data to download")
        box += _bullets(items)
        box += nodes.paragraph(text="Each file starts with one line that names the library version, the "
                                    "parameter file and the call that computed it; read it with "
                                    "pandas.read_csv(path, comment=\"#\").  Regenerated at every build "
                                    "whose parameters or library changed.")
        return [box]


def _write_datasets(app: Sphinx) -> None:
    from fivebar.book.datasets import write_datasets

    out = Path(app.srcdir) / GENERATED / "data"
    t0 = time.perf_counter()
    cost = write_datasets(out)
    logger.info(f"[fivebar_teaching] data downloads in {out}: "
                + ", ".join(f"{n} {c:.1f} s" for n, c in cost.items())
                + f" (total {time.perf_counter() - t0:.1f} s; 0 s = unchanged)")


# --------------------------------------------------------------------------------------------
# 3. Animations
# --------------------------------------------------------------------------------------------

_IFRAME = re.compile(r'<iframe class="fivebar-animation" src="([^"]+)"')


def _copy_animations(app: Sphinx, exc: Exception | None) -> None:
    if exc is not None or app.builder.format != "html":
        return
    outdir, srcdir = Path(app.outdir), Path(app.srcdir)
    src = srcdir / GENERATED / "anim"
    if src.is_dir():
        for f in sorted(src.glob("*.html")):
            dst = outdir / GENERATED / "anim" / f.name
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(f, dst)
    missing = []
    for page in sorted(outdir.rglob("*.html")):
        if GENERATED in page.as_posix():
            continue
        for ref in _IFRAME.findall(page.read_text(encoding="utf-8", errors="replace")):
            if not (page.parent / ref).is_file():
                missing.append(f"{page.relative_to(outdir)} -> {ref}")
    if missing:
        raise ExtensionError(
            "animations named in the built pages are missing (the notebook that writes them was "
            "taken from the execution cache; run `make book-clean`): " + "; ".join(missing))


def setup(app: Sphinx) -> dict[str, Any]:
    app.add_directive("learning-objectives", LearningObjectives)
    app.add_directive("course-map", CourseMap)
    app.add_directive("data-downloads", DataDownloads)
    app.connect("builder-inited", _write_datasets)
    app.connect("build-finished", _copy_animations)
    return {"version": __version__, "parallel_read_safe": True, "parallel_write_safe": True}
