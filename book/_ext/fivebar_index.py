"""The index of terms, generated from a term list (``book/_ext/index_terms.toml``).

For each term of the list, the first mention in every section of every page (in running text:
not in code, maths, headings or exercise solutions) gets an index entry and an anchor, so the
printed book's index (``\\printindex``) and the HTML book's ``genindex.html`` point to where a
term is used without an ``{index}`` directive in the notebooks.  A term may have several
forms (plural, spelling variants); the entry is the term as the list writes it, and an entry
written ``"resonance; primary"`` is filed as a sub-entry (Sphinx's ``single`` entry syntax).  The list is a dependency
of every page: editing it re-reads the book.

The chapters can later add their own ``{index}`` entries; the list then shrinks.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

from docutils import nodes
from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.transforms import SphinxTransform

__version__ = "1.1"

TERMS_FILE = Path(__file__).resolve().parent / "index_terms.toml"


def load_terms(path: Path = TERMS_FILE) -> list[tuple[str, re.Pattern]]:
    """(entry, pattern) of every term; the pattern matches any of its forms as whole words."""
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    out = []
    for entry, forms in data["terms"].items():
        forms = [forms] if isinstance(forms, str) else list(forms)
        alternatives = "|".join(re.escape(f) for f in sorted(forms, key=len, reverse=True))
        out.append((entry, re.compile(r"(?<![\w-])(?:%s)(?![\w-])" % alternatives, re.I)))
    return out


_SKIP = (nodes.literal, nodes.literal_block, nodes.math, nodes.math_block, nodes.title,
         nodes.raw, nodes.reference, nodes.caption, nodes.comment, nodes.target)


def _skipped(node: nodes.Node) -> bool:
    parent = node.parent
    while parent is not None:
        if isinstance(parent, _SKIP) or "solution" in type(parent).__name__:
            return True
        if isinstance(parent, nodes.Element) and "cell_output" in parent.get("classes", []):
            return True
        parent = parent.parent
    return False


class IndexTerms(SphinxTransform):
    """Insert an index entry before the paragraph of a term's first mention per section."""

    # lower numbers run first: before Sphinx's DoctreeReadEvent (880), at which the index domain
    # collects the entries of the page for the HTML index (genindex); at 900 they reached the
    # PDF's index only
    default_priority = 870

    def apply(self, **kwargs: Any) -> None:
        self.env.note_dependency(str(TERMS_FILE))
        terms = load_terms()
        docname = self.env.docname
        serial = 0
        for section in self.document.findall(nodes.section):
            seen: set[str] = set()
            for para in list(section.findall(nodes.paragraph)):
                # the paragraph belongs to this section, not to a subsection
                owner = para.parent
                while owner is not None and not isinstance(owner, nodes.section):
                    owner = owner.parent
                if owner is not section or _skipped(para) or para.parent is None:
                    continue
                text = " ".join(t.astext() for t in para.findall(nodes.Text)
                                if not _skipped(t))
                found = [e for e, pat in terms if e not in seen and pat.search(text)]
                if not found:
                    continue
                seen.update(found)
                serial += 1
                tid = f"index-term-{docname.replace('/', '-')}-{serial}"
                entries = [("single", e, tid, "", None) for e in found]
                index = addnodes.index(entries=entries, inline=False)
                target = nodes.target("", "", ids=[tid])
                parent = para.parent
                at = parent.index(para)
                parent.insert(at, target)
                parent.insert(at, index)


def setup(app: Sphinx) -> dict[str, Any]:
    app.add_transform(IndexTerms)
    return {"version": __version__, "env_version": 1, "parallel_read_safe": True,
            "parallel_write_safe": True}
