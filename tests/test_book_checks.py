"""The book as a teacher's text, checked in its sources (no build): no function defined in a
chapter's cells, no developer output in the stored outputs, the prose and the shipped data, the
apparatus of a textbook (nomenclature, list of figures, index of concepts, a summary and three
exercises with solutions in every numbered chapter, sixty in all), the method derived on the page
in chapters 08 and 13, and computed numbers in the solutions.  Each check is also run on a
planted fault (``book_checks.py`` holds the checks; the built HTML and PDF are checked by
``test_browser.py`` and ``test_pdf.py``).
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest
import yaml

from book_checks import (APPARATUS_PAGES, apparatus_problems, bare_values, cell_definitions, chapter_markdown,
                         developer_output, glue_problems, toc_files)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "book" / "_ext"))
TOC = yaml.safe_load((ROOT / "_toc.yml").read_text())
FILES, NUMBERED = toc_files(TOC)
NOTEBOOKS = sorted((ROOT / "book").glob("*.ipynb"))
#: myst-nb's choice of what to show of an output, for the HTML book and for the PDF
HTML_PRIORITY = ("text/html", "image/svg+xml", "image/png", "image/jpeg", "text/markdown", "text/latex", "text/plain")
LATEX_PRIORITY = ("application/pdf", "image/png", "image/jpeg", "text/latex", "text/markdown", "text/plain")
#: pages for the library's maintainers, where the names of the tests are the map
MAINTAINER_PAGES = ("book/library.md",)


def _nb(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def _shown(output: dict, priority: tuple[str, ...]) -> tuple[str, str] | None:
    """(mime, text) of what a builder shows of a display output (None: an image or nothing)."""
    data = output.get("data", {})
    for mime in priority:
        text = data.get(mime)
        text = "".join(text) if isinstance(text, list) else text
        if text:  # an empty one is passed over (myst-nb shows the next: an empty Markdown's repr)
            return mime, str(text)
    return None


def _visible_outputs(nb: dict, priority: tuple[str, ...]) -> list[tuple[int, str, str]]:
    """(cell, kind, text) of every output a builder shows as text, removed cells left out."""
    out = []
    for k, cell in enumerate(nb["cells"]):
        tags = cell.get("metadata", {}).get("tags", [])
        if cell["cell_type"] != "code" or "remove-cell" in tags or "remove-output" in tags:
            continue
        for o in cell.get("outputs", []):
            if o["output_type"] == "stream":
                out.append((k, o["name"], "".join(o["text"])))
            elif o["output_type"] in ("execute_result", "display_data"):
                if o.get("metadata", {}).get("scrapbook"):  # a glued value (display=False): not shown
                    continue
                shown = _shown(o, priority)
                if shown is not None and not shown[0].startswith("image"):
                    out.append((k, shown[0], shown[1]))
            elif o["output_type"] == "error":
                out.append((k, "error", o.get("ename", "")))
    return out


# --------------------------------------------------------------------------------------------
# No function in the cells
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_no_chapter_defines_functions_in_its_cells(path: Path) -> None:
    found = cell_definitions(_nb(path))
    assert not found, f"{path.name} defines in its cells (move it into the library, with a test): {found}"


def test_the_definition_check_finds_them() -> None:
    planted = {"cells": [
        {"cell_type": "code", "source": "def f(x):\n    return x\n"},
        {"cell_type": "code", "source": "class A:\n    pass\n"},
        {"cell_type": "code", "source": "g = lambda x: 2 * x\nsorted([3, 1], key=lambda v: -v)\n%time 1\n"},
        {"cell_type": "markdown", "source": "def in prose is fine"}]}
    assert cell_definitions(planted) == ["cell 0: def f", "cell 1: class A", "cell 2: g = lambda"]


# --------------------------------------------------------------------------------------------
# No developer output
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("priority", [HTML_PRIORITY, LATEX_PRIORITY], ids=["html", "pdf"])
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_no_developer_output_in_the_stored_outputs(path: Path, priority) -> None:
    """What the HTML book and the PDF show of every output: no stderr (a warning a reader should
    see is the book's admonition, fivebar.book.chapter.warnings_shown), no path, no repr, no
    bare value, no progress bar, no test file or issue number."""
    problems = []
    for k, kind, text in _visible_outputs(_nb(path), priority):
        if kind == "stderr":
            problems.append(f"cell {k}: stderr output {text[:120]!r}")
        problems += [f"cell {k}: {p}" for p in developer_output(text) + bare_values([text] if kind == "text/plain" else [])]
    assert not problems, f"{path.name}:\n" + "\n".join(problems)


def test_prose_and_shipped_data_have_no_developer_references() -> None:
    """The markdown of the pages and the notebooks and the shipped data files name no test file
    and no issue number (the errata's "verified by" field, which names the checks, and the
    maintainers' map of the library excepted)."""
    problems = []
    for path in sorted((ROOT / "book").glob("*.md")) + NOTEBOOKS:
        if path.relative_to(ROOT).as_posix() in MAINTAINER_PAGES:
            continue
        problems += [f"{path.name}: {p}" for p in developer_output(chapter_markdown(path))]
    for path in sorted((ROOT / "lib" / "fivebar" / "data").glob("*.toml")):
        text = "\n".join(line for line in path.read_text(encoding="utf-8").splitlines()
                         if not line.startswith("verified_by"))
        problems += [f"{path.name}: {p}" for p in developer_output(text)]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("text, what", [
    ("/tmp/ipykernel_20683/1636656708.py:4: ValidityWarning: 116 of 120 rows", "temporary file"),
    ("/work/wt/tables/lib/fivebar/figure6.py:145: ValidityWarning: the steady", "work tree"),
    ("<IPython.core.display.Markdown object>", "display object"),
    ("<pandas.io.formats.style.Styler object at 0x7f>", "Styler"),
    ("<pandas.io.formats.style.Styler at 0x7f5374684850>", "Styler"),  # as performance.ipynb stored it
    ("<fivebar.analyses.steady.SteadyState at 0x7f53a022c0d0>", "repr of an object"),
    ("evaluations:  34%|███▍      | 88/256 [00:00<00:01, 125.52eval/s]", "progress bar"),
    ("the library's tests (`tests/test_continuation.py`), its backbone", "test"),
    ("source = \"issue 17: crank AB 0.10 m\"", "issue number"),
])
def test_the_developer_output_check_finds_each_kind(text: str, what: str) -> None:
    found = developer_output(text)
    assert found and any(w in " ".join(found) for w in (what, what.split()[0])), found


def test_the_bare_value_and_stderr_checks_find_them() -> None:
    planted = {"cells": [{"cell_type": "code", "metadata": {"tags": ["remove-input"]}, "outputs": [
        {"output_type": "execute_result", "data": {"text/plain": "True"}},
        {"output_type": "stream", "name": "stderr", "text": "a warning"},
        {"output_type": "display_data", "data": {"text/html": "<iframe>", "text/plain": "<IPython.core.display.HTML object>"}},
        {"output_type": "display_data", "data": {"text/markdown": "", "text/plain": "<IPython.core.display.Markdown object>"}}]}]}
    html = _visible_outputs(planted, HTML_PRIORITY)
    pdf = _visible_outputs(planted, LATEX_PRIORITY)
    assert bare_values([html[0][2]]) and html[1][1] == "stderr" and html[2][1] == "text/html"
    assert developer_output(pdf[2][2])  # the PDF would print the HTML object's repr
    assert developer_output(html[3][2]) and developer_output(pdf[3][2])  # an empty Markdown: its repr


# --------------------------------------------------------------------------------------------
# The apparatus
# --------------------------------------------------------------------------------------------

def test_the_apparatus_is_complete() -> None:
    problems = apparatus_problems(ROOT)
    assert not problems, "\n".join(problems)


def test_the_apparatus_check_finds_what_is_missing(tmp_path: Path) -> None:
    """A table of contents without the nomenclature, a chapter without a summary and with two
    exercises (one unsolved), too few exercises in all."""
    (tmp_path / "book").mkdir()
    for page in APPARATUS_PAGES:
        (tmp_path / (page + ".md")).write_text("# x\n")
    ex = "```{exercise}\n:label: ex-a-%d\nQ.\n```\n"
    sol = "```{solution} ex-a-%d\n:class: dropdown\nA.\n```\n"
    (tmp_path / "book" / "01_a.md").write_text("# A\n\n## Exercises\n\n" + ex % 1 + sol % 1 + ex % 2)
    toc = {"root": "book/index", "parts": [
        {"caption": "Ch", "numbered": True, "chapters": [{"file": "book/01_a"}]},
        {"caption": "Ref", "chapters": [{"file": p} for p in APPARATUS_PAGES if p != "book/nomenclature"]}]}
    found = apparatus_problems(tmp_path, toc)
    expected = ["book/nomenclature: not in the table of contents", "book/01_a: no section 'Summary'",
                "book/01_a: 2 exercises, fewer than 3", "book/01_a: exercises without a solution: ['ex-a-2']",
                "2 exercises in the numbered chapters, fewer than 60"]
    assert found == expected


def test_chapters_08_and_13_derive_their_method_on_the_page() -> None:
    """At least twelve displayed, numbered equations in each (the derivation, with a check in the
    cell under each step)."""
    for name in ("08_multiple_scales", "13_nonlinear_regime"):
        text = chapter_markdown(ROOT / "book" / f"{name}.ipynb")
        numbered = re.findall(r"^\$\$ \((eq-[\w-]+)\)", text, re.M)
        assert len(numbered) >= 12 and len(set(numbered)) == len(numbered), (name, numbered)
        for label in numbered:  # every equation is referred to in the text or stands in a derivation
            assert f"{{eq}}`{label}`" in text or text.count("$$") >= 24, (name, label)


def test_the_concept_index_has_fifty_concepts() -> None:
    """``{index}`` entries in the chapters' text: at least fifty different concepts."""
    entries = set()
    for doc in FILES:
        path = ROOT / (doc + ".ipynb")
        path = path if path.is_file() else ROOT / (doc + ".md")
        if not path.is_file():
            continue
        for block in re.findall(r"```\{index\}\s*([^\n]*)\n", chapter_markdown(path)):
            for entry in block.split(","):
                entry = entry.strip().lstrip("!").strip()
                entry = re.sub(r"^(single|pair|see|seealso):\s*", "", entry)
                if entry:
                    entries.add(entry.split(";")[0].strip().lower())
    assert len(entries) >= 50, f"{len(entries)} concepts in the index entries: {sorted(entries)}"


def test_the_nomenclature_names_its_symbols_and_their_first_use() -> None:
    import fivebar_apparatus

    entries = fivebar_apparatus.load_nomenclature()
    assert len(entries) >= 50
    docs = [e["first"] for e in entries]
    assert set(docs) <= set(FILES), set(docs) - set(FILES)
    order = [d for d in FILES]
    firsts = [order.index(d) for d in docs]
    assert firsts == sorted(firsts), "the nomenclature is in reading order"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_solutions_paste_only_numbers_the_notebook_computes(path: Path) -> None:
    problems = glue_problems(_nb(path))
    assert not problems, f"{path.name}: {problems}"


def test_the_glue_check_finds_an_unglued_key() -> None:
    planted = {"cells": [{"cell_type": "code", "source": "glue('a', '1', display=False)\nfor k in (1, 2):\n    glue(f'b{k}', '2')"},
                         {"cell_type": "markdown", "source": "{glue:text}`a`, {glue:text}`b2`, {glue:text}`c`"}]}
    assert glue_problems(planted) == ["glue key 'c' is pasted but never glued"]


def test_most_solutions_carry_computed_numbers() -> None:
    """Every chapter has at least one solution whose numbers are glued from its computations,
    and at least half of the book's solutions are."""
    total = computed = 0
    for doc in NUMBERED:
        text = chapter_markdown(ROOT / (doc + ".ipynb"))
        sols = re.findall(r"```\{solution\}.*?\n```", text, re.S)
        total += len(sols)
        here = sum("{glue" in s for s in sols)
        computed += here
        assert here >= 1, f"{doc}: no solution pastes a computed number"
    assert computed >= total / 2, (computed, total)


def test_the_paper_equations_are_shown_as_P() -> None:
    import fivebar_apparatus as fa

    assert fa.mark_paper_equations("(2.7), (A.9)-(A.12) and (3.6)–(3.7); f(1.5), (0.5, 0.25), (3.9), (8.3)") == \
        "(P2.7), (PA.9)-(PA.12) and (P3.6)–(P3.7); f(1.5), (0.5, 0.25), (3.9), (8.3)"


def test_the_built_page_check_finds_developer_output() -> None:
    """The rule of the built HTML and PDF (test_browser.py, test_pdf.py): a repr or a path is
    found on any page; a test's name only outside the errata and the maintainers' map."""
    from book_checks import built_page_problems

    assert built_page_problems("phases phi10 = 0 rad <IPython.core.display.Markdown object> 4.1 Speeds",
                               "book/04_electromagnetics")
    assert built_page_problems("DEFAULT_PARAMS_PATH = PosixPath('/tmp/ci4/lib/fivebar/data/wang2011.toml')", "book/api")
    verified = "Verified by: tests/test_elements.py::test_every_interpolation_condition_holds"
    assert built_page_problems(verified, "book/09_figure6")
    assert not built_page_problems(verified, "book/errata") and not built_page_problems(verified, "book/library")
    assert built_page_problems("/work/wt/lib/fivebar/figure6.py:145: ValidityWarning", "book/errata")
