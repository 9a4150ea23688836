"""The apparatus of the book as a textbook: equation numbers, list of figures, concept index,
nomenclature and title page.

Loaded by ``_config.yml`` (``sphinx.local_extensions``) beside ``fivebar_book``.

1. **One equation numbering, not confused with the paper's.**  The book's own displayed
   equations are numbered by chapter, (8.3), as MyST numbers a labelled ``$$ ... $$ (label)``
   and ``{eq}`` refers to it.  A citation of an equation *of the paper* in the text, written
   as the paper numbers it, "(2.7)", "(A.9)-(A.12)" (the numbers the library's docstrings and
   the equation index use), is shown everywhere (pages, captions, headings, generated
   sentences, the API reference, the PDF) with the prefix P: "(P2.7)", "(PA.9)-(PA.12)".  Only
   the paper's numbers are rewritten (sections 2-4 and the appendix, within the numbers it
   has), and never inside code, maths or literal text.

2. **List of figures** (``{list-of-figures}``): every numbered figure of the book in reading
   order, its number, caption and a link; in the PDF, LaTeX's own ``\\listoffigures``.

3. **Concept index** (``{concept-index}``): the index entries of the book's text (the
   ``{index}`` entries of the chapters and the terms of ``index_terms.toml``), alphabetically,
   each with links to where it is taught and used; the API reference's entries are left to
   ``genindex``.  In the PDF the index is LaTeX's ``\\printindex`` at the end; the page
   renders nothing there.

4. **Nomenclature** (``{nomenclature}``): the table of ``book/nomenclature.toml``: every
   symbol, its meaning, its unit and the chapter of its first use (a link).

5. **Title page** (``{title-page}``): title, authors, version, repository and how to cite, from
   ``CITATION.cff`` (one place for each), on the front page.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

import yaml
from docutils import nodes
from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.transforms import SphinxTransform
from sphinx.util.docutils import SphinxDirective

__version__ = "1.0"

ROOT = Path(__file__).resolve().parents[2]
NOMENCLATURE_FILE = "book/nomenclature.toml"
CITATION_FILE = ROOT / "CITATION.cff"

# --------------------------------------------------------------------------------------------
# 1. The paper's equation numbers as (P2.7)
# --------------------------------------------------------------------------------------------

#: The paper's numbered equations: section -> the largest number it has.
PAPER_EQUATIONS = {"2": 10, "3": 7, "4": 4, "A": 12}
_ONE = r"\(\s*([234A])\s*\.\s*(\d{1,2})\s*\)"
_CITATION = re.compile(_ONE + r"(\s*(?:-|–|—|to)\s*)?(?:" + _ONE + r")?")


def _is_paper(sec: str, num: str) -> bool:
    return sec in PAPER_EQUATIONS and 1 <= int(num) <= PAPER_EQUATIONS[sec]


def mark_paper_equations(text: str) -> str:
    """``text`` with every citation of a paper's equation prefixed by P.

    >>> mark_paper_equations("(2.7) and (A.9)-(A.12); version (0.1), (3.9), f(1.5)")
    '(P2.7) and (PA.9)-(PA.12); version (0.1), (3.9), f(1.5)'
    """
    def sub(m: re.Match) -> str:
        first = f"(P{m.group(1)}.{m.group(2)})" if _is_paper(m.group(1), m.group(2)) else m.group(0)
        if m.group(4) is None:
            if m.group(3):  # a dash after a lone citation: keep it
                return first + m.group(3)
            return first
        second = (f"(P{m.group(4)}.{m.group(5)})" if _is_paper(m.group(4), m.group(5))
                  else f"({m.group(4)}.{m.group(5)})")
        if not _is_paper(m.group(1), m.group(2)):
            return m.group(0)
        return first + (m.group(3) or "") + second
    return _CITATION.sub(sub, text)


_LITERAL = (nodes.literal, nodes.literal_block, nodes.math, nodes.math_block, nodes.raw,
            nodes.comment, nodes.doctest_block, addnodes.desc_signature)


def _inside_literal(node: nodes.Node) -> bool:
    parent = node.parent
    while parent is not None:
        if isinstance(parent, _LITERAL):
            return True
        if isinstance(parent, nodes.Element) and "cell_input" in parent.get("classes", []):
            return True
        parent = parent.parent
    return False


class PaperEquationNumbers(SphinxTransform):
    """Show the paper's equation numbers with the prefix P (see the module docstring)."""

    # lower numbers run first: before the index terms (870) and before the doctree-read event
    # (Sphinx's DoctreeReadEvent, 880), at which the titles are collected for the contents
    default_priority = 860

    def apply(self, **kwargs: Any) -> None:
        for text in list(self.document.findall(nodes.Text)):
            s = str(text)
            if "(" not in s or _inside_literal(text):
                continue
            new = mark_paper_equations(s)
            if new != s:
                text.parent.replace(text, nodes.Text(new))


# --------------------------------------------------------------------------------------------
# 2. List of figures
# --------------------------------------------------------------------------------------------

class list_of_figures(nodes.General, nodes.Element):
    """Placeholder, filled in when the page is resolved."""


class ListOfFigures(SphinxDirective):
    has_content = False

    def run(self) -> list[nodes.Node]:
        return [list_of_figures("")]


def _reading_order(env) -> list[str]:
    """The documents of the table of contents in reading order."""
    order: list[str] = []

    def walk(doc: str) -> None:
        if doc in order:
            return
        order.append(doc)
        for child in env.toctree_includes.get(doc, []):
            walk(child)
    walk(env.config.root_doc)
    return order


def _figures(app: Sphinx, fromdoc: str) -> list[tuple[str, str, str, str]]:
    """(number, caption text, docname, anchor) of every numbered figure, in reading order."""
    env = app.env
    out = []
    for doc in _reading_order(env):
        numbers = env.toc_fignumbers.get(doc, {}).get("figure", {})
        if not numbers:
            continue
        tree = env.get_doctree(doc)
        for fig in tree.findall(nodes.figure):
            ids = fig.get("ids") or []
            key = next((i for i in ids if i in numbers), None)
            if key is None:
                continue
            caption = next(iter(fig.findall(nodes.caption)), None)
            text = caption.astext() if caption is not None else ""
            out.append((".".join(map(str, numbers[key])), text, doc, key))
    return out


def _fill_list_of_figures(app: Sphinx, doctree: nodes.document, docname: str) -> None:
    for node in list(doctree.findall(list_of_figures)):
        if app.builder.format == "latex":  # LaTeX's list, without its own chapter heading
            node.replace_self(nodes.raw("", r"\makeatletter\@starttoc{lof}\makeatother", format="latex"))
            continue
        rows = []
        for number, caption, doc, anchor in _figures(app, docname):
            ref = nodes.reference("", "", internal=True,
                                  refuri=app.builder.get_relative_uri(docname, doc) + "#" + anchor)
            ref += nodes.Text(f"Fig. {number}")
            title = env_title(app, doc)
            rows.append([nodes.paragraph("", "", ref), _caption_with_errata(app, docname, caption),
                         nodes.paragraph("", title)])
        node.replace_self(_table(["Figure", "Caption", "Chapter"], rows, [12, 68, 20],
                                 "fivebar-list-of-figures"))


def _caption_with_errata(app: Sphinx, docname: str, caption: str) -> nodes.paragraph:
    """A figure's caption for the list, its erratum mentions (E3) linked to their rows as in
    the caption itself (the caption's text is taken from the figure's page, without its links)."""
    from fivebar_book import _MENTION, erratum_label  # (the mention and label the errata pages use)

    labels = app.env.get_domain("std").anonlabels  # (docname, anchor) of the errata's rows
    para = nodes.paragraph()
    last = 0
    for m in _MENTION.finditer(caption):
        target = labels.get(erratum_label(m.group(1)))
        if target is None:
            continue
        para += nodes.Text(caption[last:m.start()])
        ref = nodes.reference("", "", internal=True,
                              refuri=app.builder.get_relative_uri(docname, target[0]) + "#" + target[1])
        ref += nodes.Text(m.group(1))
        para += ref
        last = m.end()
    para += nodes.Text(caption[last:])
    return para


def env_title(app: Sphinx, doc: str) -> str:
    """A chapter's title with its number, as the HTML book numbers it."""
    env = app.env
    title = env.titles[doc].astext() if doc in env.titles else doc
    secnum = env.toc_secnumbers.get(doc, {}).get("")
    return f"{'.'.join(map(str, secnum))}. {title}" if secnum else title


def _table(header: list[str], rows: list[list[nodes.Node]], widths: list[int], cls: str) -> nodes.table:
    table = nodes.table(classes=[cls])
    group = nodes.tgroup(cols=len(header))
    table += group
    for w in widths:
        group += nodes.colspec(colwidth=w)
    head = nodes.thead()
    row = nodes.row()
    for h in header:
        row += nodes.entry("", nodes.paragraph("", h))
    head += row
    group += head
    body = nodes.tbody()
    for cells in rows:
        row = nodes.row()
        for c in cells:
            row += nodes.entry("", c)
        body += row
    group += body
    return table


# --------------------------------------------------------------------------------------------
# 3. Concept index
# --------------------------------------------------------------------------------------------

class concept_index(nodes.General, nodes.Element):
    """Placeholder, filled in when the page is resolved."""


class ConceptIndex(SphinxDirective):
    has_content = False

    def run(self) -> list[nodes.Node]:
        return [concept_index("")]


#: Pages whose index entries are the library's (the API reference), not concepts.
_API_PAGES = ("book/api",)


def concept_entries(env) -> dict[str, list[tuple[str, str, bool]]]:
    """{entry: [(docname, anchor, main)]} of the index entries of the book's text (``single``
    entries, a sub-entry written "a; b"), the API reference's left out."""
    out: dict[str, list[tuple[str, str, bool]]] = {}
    for doc, entries in env.get_domain("index").entries.items():
        if doc in _API_PAGES:
            continue
        for kind, value, anchor, main, _key in entries:
            if kind != "single":
                continue
            name = "; ".join(part.strip() for part in value.split(";"))
            out.setdefault(name, []).append((doc, anchor, main == "main"))
    return out


def _fill_concept_index(app: Sphinx, doctree: nodes.document, docname: str) -> None:
    for node in list(doctree.findall(concept_index)):
        if app.builder.format == "latex":
            node.replace_self(nodes.paragraph("", "The index of the printed book, at its end, lists these concepts "
                                                  "with the pages where they are introduced and used."))
            continue
        entries = concept_entries(app.env)
        order = _reading_order(app.env)
        items = nodes.bullet_list(classes=["fivebar-concept-index"])
        for name in sorted(entries, key=lambda n: n.lower()):
            para = nodes.paragraph()
            main = [e for e in entries[name] if e[2]]
            para += nodes.strong(text=name) if main else nodes.Text(name)
            para += nodes.Text(": ")
            seen = []
            for doc, anchor, is_main in sorted(entries[name], key=lambda e: (not e[2], order.index(e[0])
                                                                                if e[0] in order else 999)):
                if (doc, is_main) in seen:
                    continue
                seen.append((doc, is_main))
                if len(seen) > 1:
                    para += nodes.Text(", ")
                ref = nodes.reference("", "", internal=True,
                                      refuri=app.builder.get_relative_uri(docname, doc) + "#" + anchor)
                label = env_title(app, doc)
                ref += nodes.strong(text=label) if is_main else nodes.Text(label)
                para += ref
            items += nodes.list_item("", para)
        node.replace_self(items)


# --------------------------------------------------------------------------------------------
# 4. Nomenclature
# --------------------------------------------------------------------------------------------

def load_nomenclature(path: Path | None = None) -> list[dict[str, str]]:
    """The entries of ``book/nomenclature.toml``: each a ``symbol`` (LaTeX), ``meaning``, ``unit``
    (text; "-" for a number without unit) and ``first`` (the docname of the chapter of its first
    use); ValueError naming a bad entry."""
    path = path or ROOT / NOMENCLATURE_FILE
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    out = data.get("symbol", [])
    for k, e in enumerate(out):
        for key in ("symbol", "meaning", "unit", "first"):
            if not isinstance(e.get(key), str) or not e[key].strip():
                raise ValueError(f"{path}: symbol {k + 1} ({e.get('symbol', '?')}): {key} is missing")
    return out


class Nomenclature(SphinxDirective):
    has_content = False

    def run(self) -> list[nodes.Node]:
        path = Path(self.env.srcdir) / NOMENCLATURE_FILE
        self.env.note_dependency(str(path))
        try:
            entries = load_nomenclature(path)
        except (OSError, ValueError, tomllib.TOMLDecodeError) as exc:
            raise self.error(f"nomenclature: {exc}") from exc
        rows = []
        for e in entries:
            if e["first"] not in self.env.found_docs:
                raise self.error(f"nomenclature: symbol {e['symbol']!r}: first = {e['first']!r} is not a page of "
                                 "the book")
            sym = nodes.paragraph("", "", nodes.math(e["symbol"], e["symbol"]))
            meaning, msgs = self.state.inline_text(e["meaning"], self.lineno)
            unit = nodes.paragraph("", e["unit"])
            ref = addnodes.pending_xref("", refdomain="std", reftype="doc", reftarget="/" + e["first"],
                                        refexplicit=False, refwarn=True, refdoc=self.env.docname)
            ref += nodes.inline("", e["first"])
            rows.append([sym, nodes.paragraph("", "", *meaning, *msgs), unit, nodes.paragraph("", "", ref)])
        return [_table(["Symbol", "Meaning", "Unit", "First used in"], rows, [14, 52, 12, 22],
                       "fivebar-nomenclature")]


# --------------------------------------------------------------------------------------------
# 5. Title page
# --------------------------------------------------------------------------------------------

def citation() -> dict[str, Any]:
    """``CITATION.cff`` as a dict."""
    return yaml.safe_load(CITATION_FILE.read_text(encoding="utf-8"))


def authors(cff: dict[str, Any]) -> str:
    """The authors of ``CITATION.cff`` as one line ("A. B. Name, C. Name and The X group")."""
    names = []
    for a in cff.get("authors", []):
        if "name" in a:
            names.append(str(a["name"]))
        else:
            given = " ".join(f"{p[0]}." for p in str(a.get("given-names", "")).replace("-", " ").split())
            names.append(f"{given} {a.get('family-names', '')}".strip())
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def book_citation(cff: dict[str, Any]) -> str:
    """How to cite the book, from ``CITATION.cff``."""
    year = str(cff.get("date-released", ""))[:4] or "2026"
    where = f", {cff['repository-code']}" if cff.get("repository-code") else ""
    return (f"{authors(cff)}, *{cff['title']}*, version {cff['version']} (Jupyter Book and Python library), "
            f"{year}{where}.")


class TitlePage(SphinxDirective):
    has_content = False

    def run(self) -> list[nodes.Node]:
        self.env.note_dependency(str(CITATION_FILE))
        cff = citation()
        lines = [f"**Authors:** {authors(cff)}", f"**Version:** {cff['version']}"]
        if cff.get("repository-code"):
            lines.append(f"**Repository:** <{cff['repository-code']}>")
        else:
            lines.append("**Repository:** the git repository this book is built from (its address goes into "
                         "`repository-code` of `CITATION.cff` when it is published)")
        lines.append("**License:** " + " (code) and ".join(cff.get("license", [])) + " (text and figures)")
        paper = next((r for r in cff.get("references", []) if r.get("type") == "article"), None)
        cite = [f"**How to cite:** {book_citation(cff)}"]
        if paper:
            who = ", ".join(f"{'-'.join(p[0] + '.' for p in a['given-names'].split('-'))} {a['family-names']}"
                            for a in paper["authors"])
            cite.append(f"The paper it reproduces: {who}, {paper['title'].strip()}, *{paper['journal']}* "
                        f"{paper['year']}, {paper.get('notes', '')}, doi:{paper['doi']} {{cite}}`wang2011`.")
        text = "\n\n".join(lines) + "\n\n" + " ".join(cite) + \
            "  Both entries are in `CITATION.cff` (GitHub's \"Cite this repository\" reads it)."
        container = nodes.container(classes=["fivebar-title-page"])
        self.state.nested_parse(self._lines(text), self.content_offset, container)
        return [container]

    @staticmethod
    def _lines(text: str):
        from docutils.statemachine import StringList
        return StringList(text.splitlines(), source="CITATION.cff")


def setup(app: Sphinx) -> dict[str, Any]:
    app.add_transform(PaperEquationNumbers)
    app.add_node(list_of_figures)
    app.add_node(concept_index)
    app.add_directive("list-of-figures", ListOfFigures)
    app.add_directive("concept-index", ConceptIndex)
    app.add_directive("nomenclature", Nomenclature)
    app.add_directive("title-page", TitlePage)
    app.connect("doctree-resolved", _fill_list_of_figures)
    app.connect("doctree-resolved", _fill_concept_index)
    return {"version": __version__, "env_version": 1, "parallel_read_safe": True,
            "parallel_write_safe": True}
