"""The book's Sphinx extension (book/_ext/fivebar_book.py) on a small Sphinx project of its own.

Numbered references: Sphinx unpickles the whole target document for every ``{numref}``
(sphinx-doc/sphinx#12883); the extension answers those lookups from one tree per document and
build.  The reference is Sphinx without the extension's change: the same pages, word for word,
and the document pointed into is unpickled once for all the references instead of once each.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
from book_build import book_extension as _extension


def _project(src: Path) -> None:
    src.mkdir()
    (src / "conf.py").write_text("numfig = True\nexclude_patterns = []\n")
    (src / "index.rst").write_text(textwrap.dedent("""\
        Index
        =====

        .. toctree::

           a
           b
        """))
    (src / "a.rst").write_text(textwrap.dedent("""\
        A
        =

        .. _tab-x:

        .. table:: The table pointed at

           = =
           1 2
           = =

        .. figure:: nothing.png
           :name: fig-x

           The figure pointed at
        """))
    (src / "b.rst").write_text(textwrap.dedent("""\
        B
        =

        See :numref:`fig-x`, :numref:`tab-x`, :numref:`Figure {number} <fig-x>` and
        :numref:`fig-x` again.
        """))


def _build(src: Path, out: Path, loads: list[str]) -> str:
    from sphinx.application import Sphinx
    from sphinx.environment import BuildEnvironment

    real = BuildEnvironment.get_doctree

    def counted(self, docname):
        loads.append(docname)
        return real(self, docname)

    BuildEnvironment.get_doctree = counted
    try:
        app = Sphinx(str(src), str(src), str(out / "html"), str(out / "doctrees"), "html",
                     status=None, warning=None, freshenv=True)
        app.build()
    finally:
        BuildEnvironment.get_doctree = real
    return (out / "html" / "b.html").read_text(encoding="utf-8")


def test_numbered_references_read_each_document_once_and_render_the_same(tmp_path, monkeypatch):
    from sphinx.domains.std import StandardDomain

    _project(tmp_path / "src")
    plain_loads: list[str] = []
    plain = _build(tmp_path / "src", tmp_path / "plain", plain_loads)
    monkeypatch.setattr(StandardDomain, "_resolve_numref_xref",
                        _extension()._numref_trees(StandardDomain._resolve_numref_xref))
    ours_loads: list[str] = []
    ours = _build(tmp_path / "src", tmp_path / "ours", ours_loads)

    assert ours == plain
    assert "Fig. 1" in ours and "Table 1" in ours and "Figure 1" in ours
    assert plain_loads.count("a") == 5  # Sphinx alone: its page, then once for each of the four references
    assert ours_loads.count("a") == plain_loads.count("a") - 3  # one load serves the four


def test_the_lookup_is_undone_after_each_reference(tmp_path):
    """``env.get_doctree`` is the class's method again after a reference is resolved, also when
    the resolver fails; the trees are dropped at the end of the reading and of the build."""
    ext = _extension()

    class Env:
        def get_doctree(self, docname):
            return {"doc": docname}

    def resolve(domain, env, docname, fail=False):
        tree = env.get_doctree(docname)
        assert env.get_doctree(docname) is tree
        if fail:
            raise ValueError("the resolver failed")
        return tree

    wrapped = ext._numref_trees(resolve)
    assert ext._numref_trees(wrapped) is wrapped  # wrapped once only
    env = Env()
    first = wrapped(None, env, "a")
    assert wrapped(None, env, "a") is first and "get_doctree" not in vars(env)
    with pytest.raises(ValueError):
        wrapped(None, env, "a", fail=True)
    assert "get_doctree" not in vars(env)
    ext._forget_numref_trees(None, None)
    assert wrapped(None, env, "a") is not first


def test_the_errata_ids_are_read_once_and_again_when_a_data_file_changes(monkeypatch, tmp_path):
    """The roles {erratum} and {assumption} check their id against the data files: read once
    for all the mentions of a build, and again when a file changes (its time stamp).  On a copy
    of the errata file (the package's own is not touched while other tests run)."""
    import os
    import shutil

    import fivebar.book.reporting as reporting

    path = tmp_path / "errata.toml"
    shutil.copy(reporting.ERRATA_PATH, path)
    monkeypatch.setattr(reporting, "ERRATA_PATH", path)
    ext = _extension()
    reads = []
    real = reporting.errata_table
    monkeypatch.setattr(reporting, "errata_table", lambda *a, **k: reads.append(1) or real(*a, **k))
    errata, assumptions = ext._known_ids()
    assert "E26" in errata and "crank_speed_rpm" in assumptions
    ext._known_ids()
    assert len(reads) == 1
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert ext._known_ids() == (errata, assumptions) and len(reads) == 2
