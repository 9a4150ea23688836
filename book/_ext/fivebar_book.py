"""Local Sphinx extension of the fivebar book.

Loaded by ``_config.yml`` (``sphinx.local_extensions``).  It does three things:

1. **Offline MathJax.**  The book must render without a network.  MathJax 3 comes from the
   PyPI package ``django-static-mathjax`` (MathJax 3.2.2's files, no dependencies): at
   ``builder-inited`` the subset the browser needs (``es5/tex-mml-chtml.js``, the TeX
   extensions it autoloads, the CHTML fonts, the menu and accessibility components) is copied
   into ``_build/html/_static/mathjax/`` and ``mathjax_path`` points at it.  Nothing is fetched
   from a CDN.

2. **Tables generated from data.**  ``{fivebar-table} errata`` and
   ``{fivebar-table} assumptions`` render :func:`fivebar.reporting.errata_table` and
   :func:`fivebar.reporting.assumptions_table` as ordinary (searchable) tables, rebuilt
   whenever ``data/errata.toml`` or ``data/wang2011.toml`` changes.

3. **The equation index.**  ``{equation-index}`` takes one line per equation of the paper,
   ``A.6 | what it is | issue``, and fills in which library objects cite that equation in
   their docstrings and which chapters cite it in their text, so the index cannot fall out of
   date; an equation cited nowhere yet is shown as "planned in issue #N".
"""

from __future__ import annotations

import importlib
import inspect
import json
import pkgutil
import re
import shutil
from pathlib import Path
from typing import Any

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


# --------------------------------------------------------------------------------------------
# Docutils helpers
# --------------------------------------------------------------------------------------------


def _table(header: list[str], rows: list[list[nodes.Node | str]], widths: list[int],
           classes: list[str]) -> nodes.table:
    """A docutils table with given relative column widths."""
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
            else:
                entry += cell
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


def _errata_rows(df: Any, fmt: Any) -> tuple[list[str], list[list[nodes.Node]], list[int]]:
    """Three columns that read well in the book's text width (all fields of the frame)."""
    rows = []
    for r in df.to_dict("records"):
        where = nodes.container()
        where += _para(nodes.strong(text=fmt(r["id"])))
        where += _para(nodes.Text(fmt(r["where"])))
        text = nodes.container()
        text += _labelled("Printed:", nodes.literal(text=fmt(r["printed"])))
        text += _labelled("Read as:", nodes.literal(text=fmt(r["read as"])))
        why = nodes.container()
        why += _para(nodes.Text(fmt(r["reason"])))
        why += _labelled("Verified by:", nodes.Text(fmt(r["verified by"])))
        rows.append([where, text, why])
    return ["Where", "Printed, and read as", "Why, and what verifies it"], rows, [18, 34, 48]


def _assumption_rows(df: Any, fmt: Any) -> tuple[list[str], list[list[nodes.Node]], list[int]]:
    rows = []
    for r in df.to_dict("records"):
        unit = fmt(r["unit"])
        value = fmt(r["value"]) + ("" if unit in ("", "-") else f" {unit}")
        key = nodes.container()
        key += _para(nodes.literal(text=fmt(r["key"])))
        key += _para(nodes.Text("= " + value))
        row = [key, _para(nodes.Text(fmt(r["reason"]))), _para(nodes.Text(fmt(r["alternative"])))]
        if "effect on Figure 6" in r:
            row.append(_para(nodes.Text(fmt(r["effect on Figure 6"]))))
        rows.append(row)
    if rows and len(rows[0]) == 4:
        header = ["Assumption and value", "Reason", "Alternative shown", "Effect on Figure 6 (p-p midpoint deflection)"]
        return header, rows, [18, 38, 18, 26]
    return ["Assumption and value", "Reason", "Alternative shown"], rows, [24, 50, 26]


#: table name -> (function of fivebar.reporting, layout)
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
        import fivebar.reporting as reporting

        func, layout = _TABLES[name]
        for dep in reporting.data_files():
            self.env.note_dependency(str(dep))
        self.env.note_dependency(reporting.__file__)
        try:
            df = getattr(reporting, func)(**({"effects": True} if name == "assumptions" else {}))
        except Exception as exc:  # a malformed data file: fail the build with its message
            raise self.error(f"fivebar-table {name}: {exc}") from exc
        header, rows, widths = layout(df, reporting.format_value)
        return [_table(header, rows, widths, [f"fivebar-{name}"])]


# --------------------------------------------------------------------------------------------
# 3. Equation index
# --------------------------------------------------------------------------------------------

#: An equation of the paper as cited: (2.7), (A.6); a range (A.9)-(A.12) cites every number
#: in it.  Sections 2-4 and the appendix are the paper's numbered equations.
_EQ = r"\(\s*([234A])\s*\.\s*(\d{1,2})\s*\)"
_CITE = re.compile(_EQ + r"(?:\s*(?:-|–|—|to)\s*" + _EQ + r")?")


def cited_equations(text: str) -> set[str]:
    """Equation numbers ``'A.6'`` cited in ``text`` as ``(A.6)``; ranges are expanded."""
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
    for info in sorted(pkgutil.iter_modules(fivebar.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        modname = f"fivebar.{info.name}"
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
    """One row per line ``number | what it is | issue`` (issue optional; ``none`` for a number
    that the paper skips, whose citations can only come from ranges such as (A.1)-(A.8))."""

    has_content = True
    option_spec = {"exclude": directives.unchanged, "skip-docs": directives.unchanged}

    def run(self) -> list[nodes.Node]:
        exclude = set((self.options.get("exclude") or "").split())
        skip = set((self.options.get("skip-docs") or "").split()) | {self.env.docname}
        lib = _library_citations(exclude)
        import fivebar

        for p in Path(fivebar.__file__).parent.glob("*.py"):
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
                    f"equation-index line {lineno}: {line!r} is not 'number | text | issue' "
                    "(number like 2.7 or A.6; the issue number is optional)"
                )
            eq, what = parts[0], parts[1]
            issue = parts[2].lstrip("#") if len(parts) == 3 and parts[2] else ""
            planned = f"planned in issue #{issue}" if issue else "not cited yet"
            what_nodes, msgs = self.state.inline_text(what, lineno)
            if issue == "none":  # a number the paper skips: citations are range artefacts
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
                lib_cell += _para(nodes.emphasis(text=planned))
            docs = chapters.get(eq, [])
            doc_cell = _para()
            for k, doc in enumerate(docs):
                if k:
                    doc_cell += nodes.Text(", ")
                doc_cell += self._xref("std", "doc", "/" + doc, None, literal=False)
            if not docs:
                doc_cell += nodes.emphasis(text=planned)
            rows.append([_para(nodes.Text(f"({eq})"), classes=["fivebar-eqno"]),
                         _para(*what_nodes, *msgs),
                         lib_cell, doc_cell])
        header = ["Eq.", "What it is", "Library (docstrings citing it)",
                  "Chapters (citing it)"]
        return [_table(header, rows, [8, 34, 36, 22], ["fivebar-equations"])]

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


def _escape_bars(app: Sphinx, what: str, name: str, obj: Any, options: Any,
                 lines: list[str]) -> None:
    # Escape |x| in prose (not in inline literals or roles, not in math, code or other
    # directive blocks, not in literal blocks or doctests), so it shows as |x|.
    block_indent: int | None = None
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if block_indent is not None:
            if not stripped or indent > block_indent:
                continue
            block_indent = None
        if stripped.startswith(">>>") or stripped.startswith("... "):
            continue
        if stripped.startswith(".. "):
            block_indent = indent
            continue
        if "|" in line and not stripped.startswith("|"):
            parts = _QUOTED.split(line)
            lines[i] = "".join(p if k % 2 else _BARS.sub(r"\\|\1\\|", p)
                               for k, p in enumerate(parts))
        if stripped.endswith("::"):
            block_indent = indent


_API: dict[str, set[str]] | None = None


def _public_api() -> dict[str, set[str]]:
    """Public name -> the qualified names that export it (``__all__`` of each module)."""
    global _API
    if _API is None:
        import fivebar

        api: dict[str, set[str]] = {}
        for info in pkgutil.iter_modules(fivebar.__path__):
            if info.name.startswith("_"):
                continue
            try:
                module = importlib.import_module(f"fivebar.{info.name}")
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
    # fivebar.nonlinear) links to the one object of that name.
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


def setup(app: Sphinx) -> dict[str, Any]:
    app.setup_extension("sphinx.ext.autodoc")
    app.connect("config-inited", _config_inited, priority=900)
    app.connect("builder-inited", _builder_inited)
    app.connect("missing-reference", _missing_reference)
    app.connect("build-finished", _build_finished)
    app.connect("html-page-context", _html_page_context, priority=900)
    app.connect("autodoc-process-docstring", _escape_bars, priority=300)
    app.connect("autodoc-process-docstring", _keep_raw_doc, priority=400)
    app.connect("autodoc-process-docstring", _restore_raw_doc, priority=600)
    app.add_css_file("fivebar_book.css")
    app.add_directive("fivebar-table", FivebarTable)
    app.add_directive("equation-index", EquationIndex)
    return {"version": __version__, "parallel_read_safe": True, "parallel_write_safe": True}
