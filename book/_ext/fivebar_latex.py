"""The printed book: how the LaTeX build (``make pdf``) arranges the pages of ``_toc.yml``.

The PDF is made by Sphinx's LaTeX builder and XeLaTeX (``book/_ext/fivebar_build.py pdf``) with
sphinx-jupyterbook-latex and the book's class ``book/_ext/latex/fivebarbook.cls`` (Sphinx's
manual class): ``_toc.yml``'s parts become ``\\part`` pages, its chapters ``\\chapter``\\ s,
the contents list both with page numbers, running heads carry the chapter and the page
number, and the index (``\\printindex``, built by makeindex) lists the terms of
``book/_ext/index_terms.toml`` (``book/_ext/fivebar_index.py``).  This module makes the printed numbers those of the HTML book:

* **One numbering.**  LaTeX numbers every ``\\chapter`` itself; the HTML book numbers only the
  chapters of the parts marked ``numbered`` in ``_toc.yml``.  Before every chapter the module
  sets LaTeX's ``secnumdepth``: the book's depth in a numbered part, -1 (no number, the chapter
  counter stands still) elsewhere, so the course map does not become chapter 1 and the
  reference pages are not chapters 12-18.  Parts are not numbered (as in the HTML).
  Exercise numbers come from Sphinx's own numbering (sphinx-exercise), figure, table and
  equation numbers from LaTeX's counters, which restart with each numbered chapter as the
  HTML's do (``numfig_secnum_depth`` 1).
* **The root page** (``book/index``) is the printed book's first, unnumbered chapter; its
  title is the title page's, so the chapter is headed "About this book".
* **Long tables** break across pages (no page left blank before a table, none running off).
* **Long words** in table cells (code, test names) and long inline code in the text may break
  after ``_ . / :: ( , =``: TeX does not hyphenate them, so a name such as
  ``tests/test_elements.py::test_every_interpolation_condition_holds`` ran past its column.
* **Computed prose** (a cell's Markdown output: the numbers of a paragraph come from the
  chapter's computations) is set as the text around it, not as a code cell's output.
* **Web-only pages**: the API reference is replaced by a one-paragraph chapter that points to
  the HTML book's API page (the PDF stays a book: 102 of its 291 pages were API reference),
  and the "References" page, empty once its bibliography has moved to the end of the book, is
  dropped: the bibliography itself is that chapter, titled "References".
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from docutils import nodes
from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.transforms.post_transforms import SphinxPostTransform

__version__ = "1.0"

#: Pages that the PDF does not print as they are (see the module docstring).
API_DOC = "book/api"
REFERENCES_DOC = "book/references"
ROOT_HEADING = "About this book"
#: Tables with more rows than this break across pages.
LONG_TABLE_ROWS = 6


def numbered_docs(app: Sphinx) -> dict[str, bool]:
    """{docname: numbered} for every chapter of the external table of contents, in order."""
    site = app.config.external_site_map
    out: dict[str, bool] = {}
    for tree in site.root.subtrees:
        for doc in tree.items:
            name = getattr(doc, "docname", None) or str(doc)
            out[name] = bool(tree.numbered)
    return out


def _raw(tex: str) -> nodes.raw:
    return nodes.raw("", tex + "\n", format="latex")


#: words (runs without spaces) longer than this many characters get break points (see
#: below): in a table cell, any word (code, the errata's test names such as
#: ``test_every_interpolation_condition_holds``; a narrow column holds about 15 characters) ...
TABLE_WORD_CHARS = 12
#: ... and in running text, inline code (a call written out in the prose)
CODE_WORD_CHARS = 24
#: a break point is allowed after each of these (longest first: "::" before ".")
_WORD_BREAKS = re.compile(r"(::|_|\.|/|\(|,|=)")
_SKIP = (nodes.raw, nodes.math, nodes.math_block, nodes.literal_block)


def _breakable_words(node: nodes.Node, longer_than: int) -> None:
    """Words of ``node`` longer than ``longer_than`` characters may break after
    ``_ . / :: ( , =``: each such character is followed by a raw ``\\allowbreak{}`` (LaTeX
    only; the HTML and the text are unchanged).  TeX does not hyphenate such a word, so it ran
    past its column or the page's edge."""
    long_word = re.compile(r"\S{%d,}" % (longer_than + 1))
    for text in list(node.findall(nodes.Text)):
        if isinstance(text.parent, _SKIP):
            continue
        value = str(text)
        if not long_word.search(value):
            continue
        new: list[nodes.Node] = []
        at = 0
        for word in long_word.finditer(value):
            pieces = [x for x in _WORD_BREAKS.split(word.group()) if x]
            head = value[at:word.start()]
            for i, piece in enumerate(pieces):
                head += piece
                if _WORD_BREAKS.fullmatch(piece) and i < len(pieces) - 1:
                    new += [nodes.Text(head), nodes.raw("", r"\allowbreak{}", format="latex")]
                    head = ""
            if head:
                new.append(nodes.Text(head))
            at = word.end()
        if value[at:]:
            new.append(nodes.Text(value[at:]))
        parent = text.parent
        i = parent.index(text)
        parent.remove(text)
        for k, piece in enumerate(new):
            parent.insert(i + k, piece)


#: a longtable whose columns' natural widths add up to more characters than this is set in
#: wrapping columns of the page's width (a line of the book's text is about 95 characters)
WIDE_TABLE_CHARS = 90
#: the line of a longtable in characters of its 9 pt text (451 pt at 5-5.5 pt a character),
#: and the padding of a column (two 6 pt \tabcolsep) in the same characters
LINE_CHARS = 85
COLUMN_PADDING_CHARS = 3


def _fit_columns(table: nodes.table) -> None:
    """Column widths for a wide longtable, from its content.

    Sphinx sets a longtable without given widths in natural-width columns (``l``), which run
    off the right edge of the page when the headers are long (chapter 11's ten-column sweep
    tables lost their last column).  Such a table gets widths proportional to the longest
    cell of each column, the header counted by its longest word since it may wrap; Sphinx
    then sets wrapping columns that fill the line (``\\X{w}{total}``).
    """
    if "colwidths-given" in table["classes"]:
        return
    group = table.next_node(nodes.tgroup)
    if group is None:
        return
    specs = [c for c in group.children if isinstance(c, nodes.colspec)]
    head = [0] * len(specs)
    natural = [0] * len(specs)
    word = [0] * len(specs)  # the longest word of the column: what a line of it must hold
    for part in group.children:
        if not isinstance(part, (nodes.thead, nodes.tbody)):
            continue
        for row in part.findall(nodes.row):
            for k, entry in enumerate(e for e in row.children if isinstance(e, nodes.entry)):
                if k >= len(specs):
                    break
                text = entry.astext().strip()
                natural[k] = max(natural[k], len(text))
                words = max((len(w) for w in text.split()), default=0)
                head[k] = max(head[k], words if isinstance(part, nodes.thead) else len(text))
                word[k] = max(word[k], min(words, TABLE_WORD_CHARS + 1))
    if sum(natural) + 2 * len(specs) <= WIDE_TABLE_CHARS:
        return
    # every column gets at least its longest word and its padding (two \tabcolsep, about
    # COLUMN_PADDING_CHARS characters, which Sphinx takes off each column's share of the line:
    # a share proportional to the cell lengths alone left a 5-character column 14 pt for
    # "sigma"); the rest of the line is shared in proportion to what each column wants beyond
    want = [max(3, min(width, 40)) for width in head]
    least = [(w + COLUMN_PADDING_CHARS) / LINE_CHARS for w in word]
    spare = 1.0 - sum(least)
    more = [max(0, w - n) for w, n in zip(want, word)]
    if spare > 0 and sum(more) > 0:
        shares = [f + spare * m / sum(more) for f, m in zip(least, more)]
    elif spare > 0:
        shares = [f + spare / len(least) for f in least]
    else:  # the words alone are wider than the line: as near to them as the line allows
        shares = [f / sum(least) for f in least]
    for spec, share in zip(specs, shares):
        spec["colwidth"] = max(1, round(1000 * share))
    table["classes"].append("colwidths-given")


def _unwrap_prose_outputs(document: nodes.Node) -> None:
    """A cell's output that is text the chapter writes (Markdown: paragraphs, lists, an
    admonition; no code output, figure or table) is set as the body text around it, full width
    and at the body's size, as the HTML book shows it: its container is taken away, so that
    sphinx-jupyterbook-latex (later, at priority 999) does not wrap it as the output of code
    (``sphinxVerbatimOutput``, which the book's class indents and sets small).  Tables stay in
    it: their columns were fitted at that size."""
    def kept(n: nodes.Node) -> bool:
        return isinstance(n, (nodes.literal_block, nodes.image, nodes.table))
    for out in list(document.findall(nodes.container)):
        if "cell_output" not in out["classes"] or out.next_node(nodes.paragraph) is None:
            continue
        if next(iter(out.findall(kept)), None) is None:
            out.replace_self(out.children)


class PrintedBook(SphinxPostTransform):
    """Numbering, root chapter and web-only pages of the assembled LaTeX document."""

    # after sphinx-jupyterbook-latex has arranged parts and bibliography (priority 700)
    default_priority = 800
    formats = ("latex",)

    def run(self, **kwargs: Any) -> None:
        root = self.config.root_doc
        if self.app.project.path2doc(self.document["source"]) != root:
            return
        self._unlink_api()
        self._long_tables()
        _unwrap_prose_outputs(self.document)
        numbered = numbered_docs(self.app)
        for sof in list(self.document.findall(addnodes.start_of_file)):
            doc = sof.get("docname")
            self._label_rows(sof, doc)
            if doc == API_DOC:
                self._replace_api(sof)
            elif doc == REFERENCES_DOC:
                # the bibliography (at the end of the book) is this page: its label goes there
                label = _raw(r"\phantomsection\label{\detokenize{%s::doc}}" % doc)
                bibs = [n for n in self.document.children if n.tagname == "thebibliography"]
                if bibs:
                    self.document.insert(self.document.index(bibs[0]), label)
                sof.parent.remove(sof)
                continue
            if doc in numbered:
                # an unnumbered page (a reference page) numbers its figures and tables from 1
                # and without a chapter number, as the HTML does; a numbered chapter as "7.2"
                depth, bare = ((r"\fivebarsecnumdepth", r"\fivebarbarenumbersfalse")
                               if numbered[doc] else
                               ("-1", r"\fivebarbarenumberstrue\setcounter{figure}{0}"
                                      r"\setcounter{table}{0}"))
                sof.parent.insert(sof.parent.index(sof),
                                  _raw(r"\setcounter{secnumdepth}{%s}%s" % (depth, bare)))
            elif isinstance(sof.next_node(nodes.section), nodes.section) and doc not in numbered:
                # a part heading made from a caption: unnumbered as in the HTML
                sof.parent.insert(sof.parent.index(sof), _raw(r"\setcounter{secnumdepth}{-2}"))
        # the root page: an unnumbered chapter "About this book".  Its title stays: the LaTeX
        # writer takes the document's first title as the book's title (not printed there).
        for section in self.document.findall(nodes.section):
            if section.get("docname") == root:
                title = section.next_node(nodes.title)
                at = section.index(title) + 1 if title is not None and title.parent is section else 0
                section.insert(at, _raw(r"\setcounter{secnumdepth}{-1}"
                                        r"\chapter{%s}" % ROOT_HEADING))
                break

    def _long_tables(self) -> None:
        """Tables of more than a few rows break across pages (LaTeX's longtable): a table that
        cannot break is pushed whole to the next page, leaving most of a page blank, or runs
        off the bottom of the page when it is longer than one (the course map, the errata).
        Then long words in tables, and long inline code anywhere, get their break points
        (after the column widths are measured: a break point is not text)."""
        for table in list(self.document.findall(nodes.table)):
            rows = sum(1 for _ in table.findall(nodes.row))
            if rows <= LONG_TABLE_ROWS or "longtable" in table["classes"]:
                continue
            table["classes"].append("longtable")
            _fit_columns(table)
            if table.next_node(nodes.title) is None and table.parent is not None:
                # LaTeX's longtable steps the table counter and heads its continuation
                # "Table N - continued" even without a caption, which the HTML does not
                # number: no number here, and the counter stepped back after it
                at = table.parent.index(table)
                table.parent.insert(at + 1, _raw(r"\endgroup\addtocounter{table}{-1}"))
                table.parent.insert(at, _raw(r"\begingroup\renewcommand{\tablename}{}"
                                             r"\renewcommand{\thetable}{}"))
        for table in list(self.document.findall(nodes.table)):
            _breakable_words(table, TABLE_WORD_CHARS)
        for literal in list(self.document.findall(nodes.literal)):  # (pieces made above are short)
            _breakable_words(literal, CODE_WORD_CHARS)

    def _unlink_api(self) -> None:
        """Links into the API page (not printed) become their text (a name in code font)."""
        for ref in list(self.document.findall(nodes.reference)):
            uri = ref.get("refuri", "")
            if uri.startswith("%" + API_DOC + "#"):
                ref.replace_self(ref.children)

    @staticmethod
    def _label_rows(sof: addnodes.start_of_file, doc: str) -> None:
        """Table rows with anchors (the errata's ``erratum-e26``): LaTeX labels in their first
        cell, which the LaTeX writer does not make from a row's ids."""
        for row in sof.findall(nodes.row):
            entry = row.next_node(nodes.entry)
            if not row["ids"] or entry is None:
                continue
            tex = "".join(r"\phantomsection\label{\detokenize{%s:%s}}" % (doc, i) for i in row["ids"])
            entry.insert(0, _raw(tex))

    def _replace_api(self, sof: addnodes.start_of_file) -> None:
        section = sof.next_node(nodes.section)
        title = section.next_node(nodes.title).deepcopy() if section else nodes.title("", "API reference")
        new = nodes.section("", title, ids=list(section["ids"]) if section else [],
                            names=list(section["names"]) if section else [])
        new += nodes.paragraph("", (
            "The library's reference (every public function and class of fivebar, with its "
            "parameters and the equations of the paper it implements) is a page of the HTML "
            "book, api.html, generated from the docstrings; it is not printed here. "
            "Within Python, help(fivebar.<name>) shows the same text."))
        sof.children = [new]


#: The book's LaTeX class (``book/_ext/latex/fivebarbook.cls``), copied next to the .tex file.
CLASS_FILE = Path(__file__).resolve().parent / "latex" / "fivebarbook.cls"


def _preamble(app: Sphinx, config: Any) -> None:
    """LaTeX settings the printed book needs (after sphinx-jupyterbook-latex's own)."""
    config.latex_theme = CLASS_FILE.stem
    if str(CLASS_FILE) not in config.latex_additional_files:
        config.latex_additional_files = [*config.latex_additional_files, str(CLASS_FILE)]
    config.latex_domain_indices = False  # no "Python Module Index" of 25 "??" entries
    # makeindex, not xindy: Sphinx's xindy style writes a page range "39-41" as "3941"; the
    # index terms are ASCII, which makeindex sorts correctly
    config.latex_use_xindy = False
    elements = config.latex_elements
    elements.setdefault("papersize", "a4paper")
    elements.setdefault("pointsize", "10pt")
    elements.setdefault("extraclassoptions", "openany,oneside")  # no blank pages between chapters
    elements["preamble"] = elements.get("preamble", "") + r"""
% fivebar: the book's section-number depth, restored before each numbered chapter
\AtBeginDocument{\edef\fivebarsecnumdepth{\the\value{secnumdepth}}}
% the text face with TeX's ligatures, so that "--" (the index's page ranges) prints an en dash
\setmainfont{FreeSerif}[Extension=.otf, UprightFont=*, ItalicFont=*Italic, BoldFont=*Bold,
  BoldItalicFont=*BoldItalic, Ligatures=TeX]
% index entries are terms, not code: in the text face (Sphinx sets them in typewriter)
\renewcommand{\sphinxstyleindexentry}[1]{#1}
% figures and tables numbered within their chapter, "Fig. 7.2" as in the HTML book (Sphinx
% resets them per chapter but prints the bare number when the book has parts); no chapter
% number in the unnumbered front matter
% (at the beginning of the document: sphinx.sty sets them there, after the preamble)
\makeatletter
\newif\iffivebarbarenumbers
\AtBeginDocument{\counterwithin*{figure}{chapter}\counterwithin*{table}{chapter}%
  \renewcommand{\thefigure}{\iffivebarbarenumbers\else\ifnum\value{chapter}>\z@\thechapter.\fi\fi%
    \arabic{figure}}%
  \renewcommand{\thetable}{\iffivebarbarenumbers\else\ifnum\value{chapter}>\z@\thechapter.\fi\fi%
    \arabic{table}}}
\makeatother
% the bibliography is the chapter "References"
\addto\captionsenglish{\renewcommand{\bibname}{References}}
% running heads: the chapter on the left, the page number on the right (a section title
% beside a long chapter title would overprint it)
\makeatletter
\fancypagestyle{normal}{\fancyhf{}%
  \fancyhead[L]{\py@HeaderFamily\nouppercase{\leftmark}}%
  \fancyhead[R]{\py@HeaderFamily\thepage}%
  \renewcommand{\headrulewidth}{0.4pt}\renewcommand{\footrulewidth}{0pt}}
\fancypagestyle{plain}{\fancyhf{}\fancyfoot[C]{\py@HeaderFamily\thepage}%
  \renewcommand{\headrulewidth}{0pt}\renewcommand{\footrulewidth}{0pt}}
\makeatother
"""


def _keep_numfig_depth(app: Sphinx, config: Any) -> None:
    app._fivebar_numfig_secnum_depth = config.numfig_secnum_depth


def _restore_numfig_depth(app: Sphinx) -> None:
    """sphinx-jupyterbook-latex numbers figures, tables, equations and exercises per section
    (``numfig_secnum_depth`` 2: "Exercise 7.9.1") when the book has parts; the HTML book
    numbers them per chapter ("Exercise 7.1").  The PDF keeps the HTML's depth."""
    if app.builder.format == "latex":
        app.config.numfig_secnum_depth = app._fivebar_numfig_secnum_depth


def setup(app: Sphinx) -> dict[str, Any]:
    app.add_post_transform(PrintedBook)
    app.connect("config-inited", _preamble, priority=900)
    app.connect("config-inited", _keep_numfig_depth, priority=900)
    app.connect("builder-inited", _restore_numfig_depth, priority=900)
    return {"version": __version__, "env_version": 1, "parallel_read_safe": True,
            "parallel_write_safe": True}
