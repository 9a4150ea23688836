"""Local Sphinx extension of the fivebar book.

Loaded by ``_config.yml`` (``sphinx.local_extensions``).  It does five things:

1. **Offline MathJax.**  The book must render without a network.  MathJax 3 comes from the
   PyPI package ``django-static-mathjax`` (MathJax 3.2.2's files, no dependencies): at
   ``builder-inited`` the subset the browser needs (``es5/tex-mml-chtml.js``, the TeX
   extensions it autoloads, the CHTML fonts, the menu and accessibility components) is copied
   into ``_build/html/_static/mathjax/`` and ``mathjax_path`` points at it.  Nothing is fetched
   from a CDN.

2. **Tables generated from data.**  ``{fivebar-table} errata`` and
   ``{fivebar-table} assumptions`` render :func:`fivebar.book.reporting.errata_table` and
   :func:`fivebar.book.reporting.assumptions_table` as ordinary (searchable) tables, rebuilt
   whenever ``data/errata.toml`` or ``data/wang2011.toml`` changes.

3. **The equation index.**  ``{equation-index}`` takes one line per equation of the paper,
   ``A.6 | what it is``, and fills in which library objects cite that equation in their
   docstrings and which chapters cite it in their text, so the index cannot fall out of date.

4. **Links to the errata.**  Every row of the errata and assumptions tables carries an anchor
   (``erratum-e26``, ``assumption-crank_speed_rpm``), and the roles ``{erratum}`E26``` and
   ``{assumption}`crank_speed_rpm``` link a mention in any page to its row.  An id that is
   not in ``data/errata.toml`` or the parameter file fails the build, naming the allowed ids.

5. **The linkage figure of the front page.**  ``{linkage-figure}`` draws Figure 1 with
   :func:`fivebar.book.plotting.draw_linkage` at build time and embeds it as inline SVG, so the
   picture can never drift from the model's geometry.

6. **One unpickled tree per document for numbered references.**  Sphinx resolves every
   ``{numref}`` by unpickling the whole document it points into (``StandardDomain.
   _resolve_numref_xref`` calls ``env.get_doctree``, which keeps the pickled bytes, not the
   tree: sphinx-doc/sphinx#12883); with 220 numbered references that was 19 s of a 65 s
   build.  The tree is only read there (the target node's type and number), so during the
   writing of one build each document is unpickled once for them (:func:`_numref_trees`).
"""

from __future__ import annotations

import functools
import importlib
import inspect
import json
import pkgutil
import re
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from docutils import nodes
from docutils.parsers.rst import directives
from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

__version__ = "1.0"

# --------------------------------------------------------------------------------------------
# 1. Offline MathJax
# --------------------------------------------------------------------------------------------

#: Where the book serves MathJax from, relative to ``_static``.
MATHJAX_PATH = "mathjax/tex-mml-chtml.js"

#: The subset of MathJax's ``es5`` directory the browser needs: the combined TeX/MathML ->
#: CHTML component, the components it loads on demand (TeX extensions, fonts, the menu and
#: its accessibility options, the SVG output the menu can switch to) and the licence.
_MATHJAX_FILES = ("tex-mml-chtml.js",)
_MATHJAX_DIRS = ("input", "output", "ui", "a11y", "sre", "adaptors")


def mathjax_source() -> Path:
    """The ``es5`` directory of the installed ``django-static-mathjax`` package."""
    import mathjax  # the package django-static-mathjax

    root = Path(mathjax.__file__).resolve().parent / "static" / "mathjax"
    es5 = root / "es5"
    if not (es5 / "tex-mml-chtml.js").is_file():
        raise FileNotFoundError(
            f"MathJax 3 not found at {es5}: install the pinned 'django-static-mathjax' "
            "(requirements-lock.txt)"
        )
    return es5


def _copy_if_changed(src: Path, dst: Path) -> bool:
    if dst.is_file():
        s, d = src.stat(), dst.stat()
        if s.st_size == d.st_size and int(s.st_mtime) == int(d.st_mtime):
            return False
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src, dst)
    return True


def copy_mathjax(outdir: Path) -> int:
    """Copy the MathJax subset into ``outdir/_static/mathjax``; return the files copied."""
    es5 = mathjax_source()
    target = outdir / "_static" / Path(MATHJAX_PATH).parent
    copied = 0
    for name in _MATHJAX_FILES:
        copied += _copy_if_changed(es5 / name, target / name)
    for sub in _MATHJAX_DIRS:
        for src in sorted((es5 / sub).rglob("*")):
            if src.is_file():
                copied += _copy_if_changed(src, target / src.relative_to(es5))
    licence = es5.parent / "LICENSE"
    if licence.is_file():
        copied += _copy_if_changed(licence, target / "LICENSE")
    return copied


def _config_inited(app: Sphinx, config: Any) -> None:
    # Serve MathJax from the build, never from a CDN.
    path = str(config.mathjax_path or "")
    if not path or re.match(r"^(https?:)?//", path):
        config.mathjax_path = MATHJAX_PATH
    # The book's own stylesheet (layout of the generated tables).
    static = str(Path(__file__).resolve().parent / "static")
    if static not in config.html_static_path:
        config.html_static_path.append(static)
    # Light mode unless the reader switches: the theme otherwise logs a console error on
    # the first page a fresh browser opens (no stored mode), and figures are drawn on white.
    if isinstance(config.html_context, dict):
        config.html_context.setdefault("default_mode", "light")
    # myst-nb would add require.js and the widget manager from a CDN to any page whose
    # notebook stores ipywidgets state; the book has no widgets, so load nothing remote.
    if hasattr(config, "nb_ipywidgets_js"):
        config.nb_ipywidgets_js = {}


def _builder_inited(app: Sphinx) -> None:
    if app.builder.format != "html":
        return
    n = copy_mathjax(Path(app.outdir))
    logger.info(f"[fivebar_book] MathJax 3 served from _static/{MATHJAX_PATH} ({n} files updated)")
    # Sphinx 7.4 does not overwrite a static file that is already in the build, so an edited
    # stylesheet would not reach an incremental build: copy the book's own files every time.
    for src in (Path(__file__).resolve().parent / "static").glob("*"):
        if src.is_file():
            dst = Path(app.outdir) / "_static" / src.name
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, dst)


# --------------------------------------------------------------------------------------------
# Docutils helpers
# --------------------------------------------------------------------------------------------


def _table(header: list[str], rows: list[list[nodes.Node | str]], widths: list[int],
           classes: list[str]) -> nodes.table:
    """A docutils table with given relative column widths (also the course extension's)."""
    table = nodes.table(classes=["colwidths-given", *classes])
    table["width"] = "100%"
    group = nodes.tgroup(cols=len(header))
    table += group
    for w in widths:
        group += nodes.colspec(colwidth=w)
    head = nodes.thead()
    group += head
    row = nodes.row()
    for h in header:
        row += nodes.entry("", nodes.paragraph(text=h))
    head += row
    body = nodes.tbody()
    group += body
    for cells in rows:
        row = nodes.row()
        for cell in cells:
            entry = nodes.entry()
            if isinstance(cell, str):
                entry += nodes.paragraph(text=cell)
            elif isinstance(cell, nodes.Body):  # paragraph, container, list: as it is
                entry += cell
            else:  # inline nodes go in a paragraph
                entry += nodes.paragraph("", "", cell)
            row += entry
        body += row
    return table


def _para(*children: nodes.Node, classes: list[str] | None = None) -> nodes.paragraph:
    p = nodes.paragraph(classes=classes or [])
    for c in children:
        p += c
    return p


# --------------------------------------------------------------------------------------------
# 2. Tables generated from data
# --------------------------------------------------------------------------------------------

def _labelled(label: str, *children: nodes.Node) -> nodes.paragraph:
    return _para(nodes.strong(text=label + " "), *children)


def erratum_label(eid: str) -> str:
    """The anchor (and Sphinx label) of an erratum's row: ``E26`` -> ``erratum-e26``."""
    return f"erratum-{eid.strip().lower()}"


def assumption_label(key: str) -> str:
    """The anchor of an assumption's row: ``crank_speed_rpm`` -> ``assumption-crank_speed_rpm``."""
    return f"assumption-{key.strip().lower()}"


_MENTION = re.compile(r"\b(E\d{1,2})\b")


_MATH_OR_CODE = re.compile(r"\$[^$]*\$|`[^`]*`")


def _linked(text: str, ids: set[str], docname: str, parse: Any = None) -> list[nodes.Node]:
    """``text`` with every mention of an erratum id (``E26``) as a link to its row.

    ``parse`` (a function of a string to inline nodes) parses the text between the mentions
    as MyST, so that its formulas (``$...$``) and code are typeset; without it the text stays
    plain.  Mentions inside a formula or code are left alone."""
    def piece(t: str) -> list[nodes.Node]:
        return parse(t) if (parse is not None and t) else [nodes.Text(t)]

    skip = [m.span() for m in _MATH_OR_CODE.finditer(text)]
    out: list[nodes.Node] = []
    pos = 0
    for m in _MENTION.finditer(text):
        if m.group(1) not in ids or any(a <= m.start() < b for a, b in skip):
            continue
        out.extend(piece(text[pos:m.start()]))
        ref = addnodes.pending_xref("", refdomain="std", reftype="ref", refexplicit=True,
                                    reftarget=erratum_label(m.group(1)), refwarn=True,
                                    refdoc=docname)
        ref += nodes.inline(text=m.group(1), classes=["fivebar-erratum"])
        out.append(ref)
        pos = m.end()
    out.extend(piece(text[pos:]))
    return out


def _errata_rows(df: Any, fmt: Any, inline: Any) -> tuple[list[str], list[list[nodes.Node]], list[int], list[str]]:
    """Three columns that read well in the book's text width (all fields of the frame)."""
    rows, ids = [], []
    for r in df.to_dict("records"):
        where = nodes.container()
        where += _para(nodes.strong(text=fmt(r["id"])))
        where += _para(*inline.link(fmt(r["where"])))  # prose with its formulas in $...$
        text = nodes.container()
        for label, plain, tex in (("Printed:", "printed", "printed (math)"),
                                  ("Read as:", "read as", "read as (math)")):
            if r.get(tex):  # the formula typeset; the ASCII record stays in data/errata.toml
                text += _labelled(label, *inline.link(r[tex]))
            else:
                text += _labelled(label, nodes.literal(text=fmt(r[plain])))
        why = nodes.container()
        why += _para(*inline.link(fmt(r["reason"])))
        why += _labelled("Verified by:", *inline.link(fmt(r["verified by"])))
        rows.append([where, text, why])
        ids.append(erratum_label(r["id"]))
    return ["Where", "Printed, and read as", "Why, and what verifies it"], rows, [16, 38, 46], ids


def _assumption_rows(df: Any, fmt: Any, inline: Any) -> tuple[list[str], list[list[nodes.Node]], list[int], list[str]]:
    rows, ids = [], []
    for r in df.to_dict("records"):
        unit = fmt(r["unit"])
        value = fmt(r["value"]) + ("" if unit in ("", "-") else f" {unit}")
        key = nodes.container()
        key += _para(nodes.literal(text=fmt(r["key"])))
        key += _para(nodes.Text("= " + value))
        row = [key, _para(*inline.link(fmt(r["reason"]))), _para(*inline.link(fmt(r["alternative"])))]
        if "effect on Figure 6" in r:
            row.append(_para(nodes.Text(fmt(r["effect on Figure 6"]))))
        rows.append(row)
        ids.append(assumption_label(r["key"]))
    if rows and len(rows[0]) == 4:
        header = ["Assumption and value", "Reason", "Alternative shown", "Effect on Figure 6 (p-p midpoint deflection)"]
        return header, rows, [22, 38, 16, 24], ids
    return ["Assumption and value", "Reason", "Alternative shown"], rows, [24, 50, 26], ids


#: table name -> (function of fivebar.book.reporting, layout)
_TABLES = {
    "errata": ("errata_table", _errata_rows),
    "assumptions": ("assumptions_table", _assumption_rows),
}


class FivebarTable(SphinxDirective):
    """``{fivebar-table} errata`` or ``{fivebar-table} assumptions``."""

    required_arguments = 1
    has_content = False

    def run(self) -> list[nodes.Node]:
        name = self.arguments[0]
        if name not in _TABLES:
            raise self.error(f"fivebar-table: unknown table {name!r}; allowed: {sorted(_TABLES)}")
        import fivebar.book.reporting as reporting

        func, layout = _TABLES[name]
        for dep in reporting.data_files():
            self.env.note_dependency(str(dep))
        self.env.note_dependency(reporting.__file__)
        self.env.note_dependency(__file__)  # this extension lays the table out
        kwargs = {"effects": True} if name == "assumptions" else {"math": True}
        try:
            df = getattr(reporting, func)(**kwargs)
        except Exception as exc:  # a malformed data file: fail the build with its message
            raise self.error(f"fivebar-table {name}: {exc}") from exc

        def inline(text: str) -> list[nodes.Node]:
            parsed, msgs = self.state.inline_text(text, self.lineno)
            return [*parsed, *msgs]

        known = set(reporting.errata_table()["id"])
        # the errata are written in MyST (formulas in $...$); the assumptions stay plain text
        parse = inline if name == "errata" else None
        inline.link = lambda text: _linked(text, known, self.env.docname, parse)  # type: ignore[attr-defined]

        header, rows, widths, ids = layout(df, reporting.format_value, inline)
        table = _table(header, rows, widths, [f"fivebar-{name}"])
        std = self.env.get_domain("std")
        for row, label in zip(table.findall(nodes.row), [None, *ids]):  # header row first
            if label is None:
                continue
            row["ids"].append(label)
            std.note_hyperlink_target(label, self.env.docname, label)
        return [table]


# --------------------------------------------------------------------------------------------
# 3. Equation index
# --------------------------------------------------------------------------------------------

#: An equation of the paper as cited: (2.7), (A.6); a range (A.9)-(A.12) cites every number
#: in it.  Sections 2-4 and the appendix are the paper's numbered equations.
_EQ = r"\(\s*P?([234A])\s*\.\s*(\d{1,2})\s*\)"
_CITE = re.compile(_EQ + r"(?:\s*(?:-|–|—|to)\s*" + _EQ + r")?")


def cited_equations(text: str) -> set[str]:
    """Equation numbers ``'A.6'`` cited in ``text`` as ``(A.6)`` or, as the book shows the paper's
    numbers, ``(PA.6)``; ranges are expanded."""
    found: set[str] = set()
    for m in _CITE.finditer(text or ""):
        sec, first = m.group(1), int(m.group(2))
        last = first
        if m.group(4) is not None:
            if m.group(3) == sec and int(m.group(4)) >= first:
                last = int(m.group(4))
            else:  # "(A.9)-(2.3)" is two citations, not a range
                found.add(f"{m.group(3)}.{int(m.group(4))}")
        found.update(f"{sec}.{k}" for k in range(first, last + 1))
    return found


def _library_citations(exclude: set[str]) -> dict[str, list[tuple[str, str]]]:
    """Equation -> [(role, qualified name)] of the library objects whose docstrings cite it.

    Functions, classes and methods are listed; a module is listed only for the equations
    none of its objects cites (its docstring names what it implements as a whole).
    """
    import fivebar

    cites: dict[str, list[tuple[str, str]]] = {}
    for info in sorted(pkgutil.walk_packages(fivebar.__path__, "fivebar."), key=lambda i: i.name):
        if info.name.rpartition(".")[2].startswith("_"):
            continue
        modname = info.name
        try:
            module = importlib.import_module(modname)
        except Exception as exc:  # a module that does not import is a bug: say so
            logger.warning(f"equation-index: cannot import {modname}: {exc}")
            continue
        own: dict[str, list[tuple[str, str]]] = {}
        public = getattr(module, "__all__", None)
        for name, obj in vars(module).items():
            if name.startswith("_") or (public is not None and name not in public):
                continue
            if getattr(obj, "__module__", None) != modname:
                continue
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            qual = f"{modname}.{name}"
            if qual in exclude:
                continue
            role = "class" if inspect.isclass(obj) else "func"
            for eq in cited_equations(inspect.getdoc(obj) or ""):
                own.setdefault(eq, []).append((role, qual))
            if inspect.isclass(obj):
                for mname, member in vars(obj).items():
                    if mname.startswith("_"):
                        continue
                    doc = inspect.getdoc(member.fget if isinstance(member, property) else member)
                    role_m = "attr" if isinstance(member, property) else "meth"
                    if not (isinstance(member, property) or inspect.isfunction(member)
                            or isinstance(member, (classmethod, staticmethod))):
                        continue
                    if f"{qual}.{mname}" in exclude:
                        continue
                    for eq in cited_equations(doc or ""):
                        own.setdefault(eq, []).append((role_m, f"{qual}.{mname}"))
        for eq, objs in own.items():
            cites.setdefault(eq, []).extend(objs)
        if modname not in exclude:
            for eq in cited_equations(module.__doc__ or "") - set(own):
                cites.setdefault(eq, []).append(("mod", modname))
    return cites


def _source_text(path: Path) -> str:
    """The prose of a chapter: the markdown cells of a notebook, or a markdown file."""
    if path.suffix == ".ipynb":
        nb = json.loads(path.read_text(encoding="utf-8"))
        return "\n".join(
            "".join(c.get("source", "")) for c in nb.get("cells", [])
            if c.get("cell_type") == "markdown"
        )
    return path.read_text(encoding="utf-8")


class EquationIndex(SphinxDirective):
    """One row per line ``number | what it is``, or ``number | what it is | none`` for a number
    that the paper skips (its citations can only come from ranges such as (A.1)-(A.8))."""

    has_content = True
    option_spec = {"exclude": directives.unchanged, "skip-docs": directives.unchanged}

    def run(self) -> list[nodes.Node]:
        exclude = set((self.options.get("exclude") or "").split())
        skip = set((self.options.get("skip-docs") or "").split()) | {self.env.docname}
        lib = _library_citations(exclude)
        import fivebar

        for p in Path(fivebar.__file__).parent.rglob("*.py"):
            self.env.note_dependency(str(p))

        chapters: dict[str, list[str]] = {}
        for doc in sorted(self.env.found_docs):
            if doc in skip:
                continue
            path = Path(self.env.doc2path(doc))
            if not path.is_file():
                continue
            self.env.note_dependency(str(path))
            for eq in cited_equations(_source_text(path)):
                chapters.setdefault(eq, []).append(doc)

        rows = []
        for lineno, line in enumerate(self.content, start=self.content_offset + 1):
            if not line.strip():
                continue
            parts = [p.strip() for p in line.split("|")]
            if len(parts) not in (2, 3) or not re.fullmatch(r"[234A]\.\d{1,2}", parts[0]):
                raise self.error(
                    f"equation-index line {lineno}: {line!r} is not 'number | text' "
                    "(number like 2.7 or A.6), or 'number | text | none' for a skipped number"
                )
            eq, what = parts[0], parts[1]
            skipped = len(parts) == 3 and parts[2] == "none"
            if len(parts) == 3 and parts[2] not in ("", "none"):
                raise self.error(f"equation-index line {lineno}: third field {parts[2]!r} is not "
                                 "allowed: leave it out, or write 'none' for a skipped number")
            what_nodes, msgs = self.state.inline_text(what, lineno)
            if skipped:  # a number the paper skips: citations are range artefacts
                rows.append([_para(nodes.Text(f"({eq})"), classes=["fivebar-eqno"]),
                             _para(*what_nodes, *msgs), _para(nodes.Text("—")),
                             _para(nodes.Text("—"))])
                continue
            objs = lib.get(eq, [])
            lib_cell = nodes.container()
            by_module: dict[str, list[tuple[str, str]]] = {}
            for role, qual in objs:
                module = qual if role == "mod" else ".".join(qual.split(".")[:2])
                by_module.setdefault(module, []).append((role, qual))
            for module, members in by_module.items():
                line = _para()
                short = module.removeprefix("fivebar.")
                if any(role == "mod" for role, _ in members):
                    line += self._xref("py", "mod", module, short, literal=True)
                else:
                    line += nodes.Text(short + ": ")
                    for k, (role, qual) in enumerate(members):
                        if k:
                            line += nodes.Text(", ")
                        line += self._xref("py", role, qual, qual.removeprefix(module + "."),
                                           literal=True)
                lib_cell += line
            if not objs:
                lib_cell += _para(nodes.Text("—"))
            docs = chapters.get(eq, [])
            doc_cell = _para()
            for k, doc in enumerate(docs):
                if k:
                    doc_cell += nodes.Text(", ")
                doc_cell += self._xref("std", "doc", "/" + doc, None, literal=False)
            if not docs:
                doc_cell += nodes.Text("—")
            rows.append([_para(nodes.Text(f"({eq})"), classes=["fivebar-eqno"]),
                         _para(*what_nodes, *msgs),
                         lib_cell, doc_cell])
        header = ["Eq.", "What it is", "Library (docstrings citing it)",
                  "Chapters (citing it)"]
        return [_table(header, rows, [10, 34, 34, 22], ["fivebar-equations"])]

    def _xref(self, domain: str, role: str, target: str, text: str | None,
              literal: bool) -> addnodes.pending_xref:
        ref = addnodes.pending_xref(
            "", refdomain=domain, reftype=role, reftarget=target,
            refexplicit=text is not None, refwarn=True, refdoc=self.env.docname,
        )
        ref["fivebar_optional"] = True
        label = text if text is not None else target
        ref += nodes.literal(text=label) if literal else nodes.inline(text=label)
        return ref

# --------------------------------------------------------------------------------------------
# 4. Links to the errata: {erratum}`E26`, {assumption}`crank_speed_rpm`
# --------------------------------------------------------------------------------------------


def _known_ids() -> tuple[list[str], list[str]]:
    """The errata ids and assumption keys of the data files (``reporting.data_files()``), read
    again whenever one of them changes: once per build and edit, not for each of the 130
    mentions of the book (2.3 s of a build)."""
    import fivebar.book.reporting as reporting

    return _known_ids_of(tuple((str(p), p.stat().st_mtime_ns) for p in reporting.data_files()))


@functools.lru_cache(maxsize=2)
def _known_ids_of(stamp: tuple) -> tuple[list[str], list[str]]:
    import fivebar.book.reporting as reporting

    errata = [str(i) for i in reporting.errata_table()["id"]]
    assumptions = [str(k) for k in reporting.assumptions_table()["key"]]
    return errata, assumptions


def _data_role(kind: str) -> Any:
    def role(name: str, rawtext: str, text: str, lineno: int, inliner: Any,
             options: dict | None = None, content: list | None = None) -> tuple[list, list]:
        env = inliner.document.settings.env
        key = text.strip()
        errata, assumptions = _known_ids()
        allowed = errata if kind == "erratum" else assumptions
        if key not in allowed:
            msg = inliner.reporter.error(
                f"{{{kind}}}`{key}`: {key!r} is not an {kind} id; allowed: {', '.join(allowed)}",
                line=lineno)
            return [inliner.problematic(rawtext, rawtext, msg)], [msg]
        label = erratum_label(key) if kind == "erratum" else assumption_label(key)
        ref = addnodes.pending_xref(
            rawtext, refdomain="std", reftype="ref", reftarget=label, refexplicit=True,
            refwarn=True, refdoc=env.docname,
        )
        if kind == "erratum":
            ref += nodes.inline(rawtext, key, classes=["fivebar-erratum"])
        else:
            ref += nodes.literal(rawtext, key, classes=["fivebar-assumption"])
        for dep in __import__("fivebar.book.reporting", fromlist=["data_files"]).data_files():
            env.note_dependency(str(dep))
        return [ref], []

    return role


# --------------------------------------------------------------------------------------------
# 5. The linkage figure of the front page
# --------------------------------------------------------------------------------------------


def _linkage_drawing(theta1_deg: float, theta4_deg: float, fmt: str) -> bytes:
    """Figure 1 of the paper drawn by :func:`fivebar.book.plotting.draw_linkage`, saved as ``fmt``."""
    import io

    import matplotlib as mpl
    from matplotlib.figure import Figure

    import fivebar
    from fivebar.book.plotting import draw_linkage, use_book_style

    with mpl.rc_context():
        use_book_style(inline=False)
        mpl.rcParams.update({"axes.grid": False, "svg.hashsalt": "fivebar", "svg.fonttype": "path"})
        params = fivebar.load_params()
        fig = Figure(figsize=(6.5, 3.4))
        ax = fig.add_subplot()
        draw_linkage(ax, params, float(np.radians(theta1_deg)), float(np.radians(theta4_deg)),
                     labels=True, masses=True)
        ax.set_xlabel("$x$ (mm)")
        ax.set_ylabel("$y$ (mm)")
        buf = io.BytesIO()
        fig.savefig(buf, format=fmt, metadata={"CreationDate": None} if fmt == "pdf"
                    else {"Date": None})
    return buf.getvalue()


def linkage_svg(theta1_deg: float = 135.0, theta4_deg: float = 60.0) -> str:
    """Figure 1 of the paper drawn by :func:`fivebar.book.plotting.draw_linkage`, as SVG text."""
    svg = _linkage_drawing(theta1_deg, theta4_deg, "svg").decode()
    svg = svg[svg.index("<svg"):]  # inline: no XML declaration or doctype
    # scale with the column: the viewBox keeps the aspect, CSS sets the width
    svg = re.sub(r'<svg([^>]*?) width="[^"]*" height="[^"]*"', r'<svg\1', svg, count=1)
    return svg.replace("<svg", '<svg class="fivebar-linkage" role="img" '
                       'aria-label="The five-bar linkage of Figure 1"', 1)


class LinkageFigure(SphinxDirective):
    """``{linkage-figure}`` with optional ``:theta1:`` and ``:theta4:`` (deg); content is the caption."""

    has_content = True
    option_spec = {"theta1": directives.unchanged, "theta4": directives.unchanged}

    def run(self) -> list[nodes.Node]:
        angles = {}
        for key, default in (("theta1", 135.0), ("theta4", 60.0)):
            raw = self.options.get(key, default)
            try:
                angles[key] = float(raw)
            except (TypeError, ValueError):
                raise self.error(f"linkage-figure: :{key}: {raw!r} is not allowed: give an angle in degrees") from None
        import fivebar.book.plotting as plotting

        self.env.note_dependency(plotting.__file__)
        try:
            svg = linkage_svg(angles["theta1"], angles["theta4"])
        except Exception as exc:
            raise self.error(f"linkage-figure: {exc}") from exc
        figure = nodes.figure(classes=["fivebar-linkage-figure"])
        figure += nodes.raw("", svg, format="html")
        if self.env.app.builder.format == "latex":
            # the PDF: the same drawing as a vector PDF image (LaTeX cannot embed SVG)
            name = f"linkage-{angles['theta1']:g}-{angles['theta4']:g}.pdf"
            path = Path(self.env.app.outdir) / "_fivebar" / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(_linkage_drawing(angles["theta1"], angles["theta4"], "pdf"))
            uri = "/" + path.relative_to(self.env.srcdir).as_posix()  # "/": from the source folder
            figure += nodes.image(uri=uri, alt="The five-bar linkage of Figure 1", width="90%")
        if self.content:
            caption, msgs = self.state.inline_text(" ".join(self.content), self.lineno)
            figure += nodes.caption("", "", *caption)
            figure += msgs
        return [figure]


#: Raw docstrings of properties and data, kept before napoleon rewrites them.
_RAW_DOCS: dict[tuple[str, str], list[str]] = {}
_PLAIN_KINDS = ("property", "data", "attribute")


def _keep_raw_doc(app: Sphinx, what: str, name: str, obj: Any, options: Any,
                  lines: list[str]) -> None:
    if what in _PLAIN_KINDS:
        _RAW_DOCS[(what, name)] = list(lines)


def _restore_raw_doc(app: Sphinx, what: str, name: str, obj: Any, options: Any,
                     lines: list[str]) -> None:
    # napoleon reads the first line of a property or data docstring Google-style, as
    # "type: text", so "Period of the motion (s): one turn of crank AB." would become a type
    # "Period of the motion (s)".  numpydoc has no such convention (the type comes from the
    # annotation), so these docstrings are kept as written.
    if what in _PLAIN_KINDS and (what, name) in _RAW_DOCS:
        lines[:] = _RAW_DOCS.pop((what, name))


#: ``|x|`` in running text: reST reads it as a substitution reference (an error), numpydoc
#: authors mean an absolute value.
_BARS = re.compile(r"(?<![\\|\w])\|(?=\S)([^|`]*?\S)\|(?![|\w])")
_QUOTED = re.compile(r"(``.*?``|:\w+:`[^`]*`|`[^`]*`_?)")


def _prose_lines(lines: list[str]):
    """Indices of the prose lines of a docstring: not in doctests, literal blocks (after a line
    ending in "::") or directive blocks (math, code, ...).  A caller may rewrite ``lines[i]``."""
    block_indent: int | None = None
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if block_indent is not None:
            if not stripped or indent > block_indent:
                continue
            block_indent = None
        if stripped.startswith((">>>", "... ")):
            continue
        if stripped.startswith(".. "):
            block_indent = indent
            continue
        yield i
        if stripped.endswith("::"):
            block_indent = indent


def _escape_bars(app: Sphinx, what: str, name: str, obj: Any, options: Any,
                 lines: list[str]) -> None:
    # Escape |x| in prose (not in inline literals or roles, not in math, code or other
    # directive blocks, not in literal blocks or doctests), so it shows as |x|.
    for i in _prose_lines(lines):
        line = lines[i]
        if "|" in line and not line.lstrip().startswith("|"):
            parts = _QUOTED.split(line)
            lines[i] = "".join(p if k % 2 else _BARS.sub(r"\\|\1\\|", p)
                               for k, p in enumerate(parts))


_ERRATA_IDS: set[str] | None = None


def _link_errata_in_docstring(app: Sphinx, what: str, name: str, obj: Any, options: Any,
                              lines: list[str]) -> None:
    # A docstring that names an erratum ("errata E26") links it to its row on the errata
    # page, as the {erratum} role does in the chapters (prose only: not in literals, roles,
    # math, code or other directive blocks).
    global _ERRATA_IDS
    if _ERRATA_IDS is None:
        import fivebar.book.reporting as reporting

        _ERRATA_IDS = set(reporting.errata_table()["id"])
    for i in _prose_lines(lines):
        line = lines[i]
        if _MENTION.search(line):
            parts = _QUOTED.split(line)
            lines[i] = "".join(
                p if k % 2 else _MENTION.sub(
                    lambda m: (f":ref:`{m.group(1)} <{erratum_label(m.group(1))}>`"
                               if m.group(1) in _ERRATA_IDS else m.group(1)), p)
                for k, p in enumerate(parts))


_API: dict[str, set[str]] | None = None


def _public_api() -> dict[str, set[str]]:
    """Public name -> the qualified names that export it (``__all__`` of each module)."""
    global _API
    if _API is None:
        import fivebar

        api: dict[str, set[str]] = {}
        for info in pkgutil.walk_packages(fivebar.__path__, "fivebar."):
            if info.name.rpartition(".")[2].startswith("_"):
                continue
            try:
                module = importlib.import_module(info.name)
            except Exception:
                continue
            for name in getattr(module, "__all__", []):
                obj = getattr(module, name, None)
                home = getattr(obj, "__module__", None) if obj is not None else None
                qual_mod = home if (home or "").startswith("fivebar.") else module.__name__
                api.setdefault(name, set()).add(f"{qual_mod}.{name}")
        _API = api
    return _API


def _missing_reference(app: Sphinx, env: Any, node: nodes.Element,
                       contnode: nodes.Element) -> nodes.Node | None:
    # An object cited by a docstring but not (yet) in the API reference is shown unlinked
    # rather than failing the build; tests/test_browser.py checks that every module is in it.
    if node.get("fivebar_optional"):
        return contnode
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "").lstrip("~.")
    if target.startswith("fivebar."):
        return None
    head, _, rest = target.partition(".")
    owners = _public_api().get(head, set())
    # A short name of the public API used in another module ("Model" in a type hint of
    # fivebar.model.nonlinear) links to the one object of that name.
    if len(owners) == 1:
        qual = next(iter(owners)) + ("." + rest if rest else "")
        domain = env.get_domain("py")
        found = domain.resolve_xref(env, node.get("refdoc", ""), app.builder,
                                    node.get("reftype", "obj"), qual, node, contnode)
        if found is not None:
            return found
    # numpydoc types are free text ("ndarray, shape (N, n)", "tuple of float"): their words
    # are not references.  Anything that names the public API still has to resolve.
    if node.get("reftype") in ("class", "obj") and not owners:
        return contnode
    return None


def _html_page_context(app: Sphinx, pagename: str, templatename: str, context: dict,
                       doctree: Any) -> None:
    # Some extensions (sphinx-thebe, sphinx-togglebutton) register an inline script after
    # the builder is initialised, and Sphinx then emits it twice; a doubled
    # "const THEBE_JS_URL = ..." is a JavaScript error on every page.  Emit each script once.
    scripts = context.get("script_files")
    if scripts:
        seen: set = set()
        unique = []
        for js in scripts:
            attrs = getattr(js, "attributes", None) or {}
            key = (str(getattr(js, "filename", js) or ""), tuple(sorted(attrs.items())))
            if key not in seen:
                seen.add(key)
                unique.append(js)
        scripts[:] = unique


def _build_finished(app: Sphinx, exception: Exception | None) -> None:
    # Sphinx reports a warning only when it reads the document that causes it.  With
    # warnings as errors, a failed build would otherwise pass on the next run because the
    # unchanged documents are not read again.  So a build with warnings (or an error) keeps
    # no environment: the next build reads every document again and sees every warning.
    # Notebook execution stays cached (jupyter-cache), so that costs seconds.
    if exception is None and not getattr(app, "_warncount", 0):
        return
    pickle = Path(app.doctreedir) / "environment.pickle"
    if pickle.is_file():
        pickle.unlink()
        logger.info("[fivebar_book] the build had warnings: environment discarded, the next "
                    "build reads every document again")


# --------------------------------------------------------------------------------------------
# 6. One citation style: "[Wang et al., 2011]" in the text and in the bibliography
# --------------------------------------------------------------------------------------------

CITATION_STYLE = "fivebar"


def _author_year(entry) -> str:
    """"Wang et al., 2011", "Chung and Hulbert, 1993", "Newmark, 1959" (plain text)."""
    import codecs

    import latexcodec  # noqa: F401  (registers the "ulatex" codec; a pybtex dependency)

    people = entry.persons.get("author") or entry.persons.get("editor") or []
    names = [codecs.decode(" ".join(p.last_names), "ulatex").replace("{", "").replace("}", "")
             for p in people]
    if not names:
        who = entry.fields.get("organization") or entry.key
    elif len(names) == 1:
        who = names[0]
    elif len(names) == 2:
        who = f"{names[0]} and {names[1]}"
    else:
        who = f"{names[0]} et al."
    return f"{who}, {entry.fields.get('year', 'n.d.')}"


def register_citation_style() -> None:
    """The pybtex style ``fivebar``: unsrt entries sorted by author and year, author-year labels
    (``bibtex_default_style`` and ``bibtex_reference_style: label`` in ``_config.yml``), so that
    a citation and its entry in the bibliography read the same, "[Wang et al., 2011]", in the
    HTML and in the PDF.  Labels that would repeat get a letter: "1984a", "1984b"."""
    from pybtex.plugin import find_plugin, register_plugin
    from pybtex.style.formatting.unsrt import Style as Unsrt
    from pybtex.style.labels import BaseLabelStyle

    try:
        find_plugin("pybtex.style.formatting", CITATION_STYLE)
        return
    except Exception:  # noqa: BLE001 - pybtex raises PluginNotFound
        pass

    class AuthorYearLabels(BaseLabelStyle):
        def format_labels(self, sorted_entries):
            entries = list(sorted_entries)
            labels = [_author_year(e) for e in entries]
            counts = {lab: labels.count(lab) for lab in labels}
            seen: dict[str, int] = {}
            for lab in labels:
                if counts[lab] > 1:
                    k = seen.get(lab, 0)
                    seen[lab] = k + 1
                    yield lab + "abcdefghijklmnopqrstuvwxyz"[k]
                else:
                    yield lab

    class FivebarStyle(Unsrt):
        default_label_style = "fivebar_author_year"
        default_sorting_style = "author_year_title"

    register_plugin("pybtex.style.labels", "fivebar_author_year", AuthorYearLabels)
    register_plugin("pybtex.style.formatting", CITATION_STYLE, FivebarStyle)


# --------------------------------------------------------------------------------------------
# 6. One unpickled tree per document for numbered references
# --------------------------------------------------------------------------------------------

#: The documents' trees as read by the numbered references of the build under way (read-only).
_NUMREF_TREES: dict[str, nodes.document] = {}


def _numref_trees(resolve):
    """``StandardDomain._resolve_numref_xref`` with ``env.get_doctree`` answered from
    ``_NUMREF_TREES``: the resolver only looks the target node up and reads its type and
    number, so one tree per document serves every reference into it.  Any other caller of
    ``get_doctree`` (which may change the tree it gets) still gets a fresh copy."""
    if getattr(resolve, "_fivebar_numref_trees", False):
        return resolve

    @functools.wraps(resolve)
    def wrapper(self, env, *args, **kwargs):
        real = env.get_doctree

        def get_doctree(docname: str) -> nodes.document:
            if docname not in _NUMREF_TREES:
                _NUMREF_TREES[docname] = real(docname)
            return _NUMREF_TREES[docname]

        env.get_doctree = get_doctree
        try:
            return resolve(self, env, *args, **kwargs)
        finally:
            del env.get_doctree  # the method of the class again

    wrapper._fivebar_numref_trees = True
    return wrapper


def _forget_numref_trees(*_args) -> None:
    """The trees are those of one build: dropped when its reading ends (a document read again
    has a new tree) and when it finishes."""
    _NUMREF_TREES.clear()


def setup(app: Sphinx) -> dict[str, Any]:
    from sphinx.domains.std import StandardDomain

    StandardDomain._resolve_numref_xref = _numref_trees(StandardDomain._resolve_numref_xref)
    app.connect("env-updated", _forget_numref_trees)
    app.connect("build-finished", _forget_numref_trees)
    register_citation_style()
    app.setup_extension("sphinx.ext.autodoc")
    app.connect("config-inited", _config_inited, priority=900)
    app.connect("builder-inited", _builder_inited)
    app.connect("missing-reference", _missing_reference)
    app.connect("build-finished", _build_finished)
    app.connect("html-page-context", _html_page_context, priority=900)
    app.connect("autodoc-process-docstring", _escape_bars, priority=300)
    app.connect("autodoc-process-docstring", _link_errata_in_docstring, priority=350)
    app.connect("autodoc-process-docstring", _keep_raw_doc, priority=400)
    app.connect("autodoc-process-docstring", _restore_raw_doc, priority=600)
    app.add_css_file("fivebar_book.css")
    app.add_directive("fivebar-table", FivebarTable)
    app.add_directive("equation-index", EquationIndex)
    app.add_directive("linkage-figure", LinkageFigure)
    app.add_role("erratum", _data_role("erratum"))
    app.add_role("assumption", _data_role("assumption"))
    # env_version: bump it when this extension changes what it writes into the documents, so
    # that an incremental build reads every page again instead of keeping the old output.
    return {"version": __version__, "env_version": 4, "parallel_read_safe": True,
            "parallel_write_safe": True}
