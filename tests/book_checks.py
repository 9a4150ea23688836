"""What the built book must not show and must have: the checks shared by the tests of the
sources (``test_book_checks.py``), of the HTML book (``test_browser.py``) and of the PDF
(``test_pdf.py``).  Each check is a function of text or of a parsed notebook that returns the
problems it finds, one string each, so that a test can plant a fault and see it found.

* :func:`developer_output`: what a reader should never see: paths of temporary files or of a
  work tree, the file and line of the code that warned (and the source line under it), reprs
  of display objects (``<IPython.core.display.Markdown object>``, a pandas Styler), a bare
  ``True``/``False`` under a cell, progress bars, file names of the tests, issue numbers.
* :func:`cell_definitions`: functions and classes defined in a chapter's code cells (a
  ``def``, a ``class``, a lambda given a name).
* :func:`apparatus_problems`: the pages a textbook needs (nomenclature, list of figures, index
  of concepts) in the table of contents, and summaries and exercises in every numbered chapter.
"""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]

#: Patterns of developer output, each with what it is.
DEVELOPER_OUTPUT = [
    (re.compile(r"/tmp/|/var/folders/|/work/|/home/\w|[A-Za-z]:\\\\Users"), "a path of a temporary file or a work tree"),
    (re.compile(r"ipykernel_\d+"), "the name of a kernel's temporary cell file"),
    (re.compile(r"site-packages"), "a path into an installed package"),
    (re.compile(r"\b[\w/.-]+\.py:\d+: \w*(Warning|Error)\b"), "the file and line of the code that warned"),
    (re.compile(r"<IPython\.core\.display\.\w+ object>"), "the repr of a display object"),
    (re.compile(r"<pandas\.io\.formats\.style\.Styler\b|Styler object at"), "the repr of a pandas Styler"),
    (re.compile(r"<[\w.]+ (object )?at 0x[0-9a-fA-F]+>"), "the repr of an object"),
    (re.compile(r"<matplotlib\.\w+[\w.]* object at|<Figure size \d"), "the repr of a matplotlib object"),
    (re.compile(r"\d+%\|[█▏▎▍▌▋▊▉ #]*\|"), "a progress bar"),
    (re.compile(r"\btests/test_\w+\.py\b"), "the file name of a test"),
    (re.compile(r"\b[Ii]ssue \d+\b|\bissue #\d+"), "an issue number of the project's tracker"),
]


def developer_output(text: str) -> list[str]:
    """The developer output in ``text``: one "<what>: <excerpt>" per match."""
    out = []
    for pattern, what in DEVELOPER_OUTPUT:
        for m in pattern.finditer(text):
            a, b = max(0, m.start() - 40), min(len(text), m.end() + 40)
            out.append(f"{what}: ...{text[a:b]!r}...".replace("\\n", " "))
    return out


#: built pages whose text may name the tests: the maintainers' map of the library, and the
#: errata, whose "Verified by" fields name the checks of each correction
TEST_NAMES_ALLOWED = ("book/library", "book/errata")


def built_page_problems(text: str, doc: str) -> list[str]:
    """The developer output in the text a reader sees of the built page ``doc`` (its path in
    the book without suffix, "book/09_figure6"): :func:`developer_output`, less the names of the
    tests on the pages of :data:`TEST_NAMES_ALLOWED`."""
    found = developer_output(text)
    if doc in TEST_NAMES_ALLOWED:
        found = [f for f in found if not f.startswith("the file name of a test")]
    return found


def bare_values(outputs: list[str]) -> list[str]:
    """Cell outputs that are only a Python value (True, False, None, a number): the value an
    expression left at the end of a cell, not something the reader is meant to see."""
    return [f"a bare value under a cell: {o.strip()!r}" for o in outputs
            if re.fullmatch(r"\s*(True|False|None|-?\d+(\.\d+)?|np\.\w+\(.*\))\s*", o)]


def cell_definitions(nb: dict) -> list[str]:
    """Functions and classes defined in the code cells of a notebook: "cell k: def name"."""
    out = []
    for k, cell in enumerate(nb.get("cells", [])):
        if cell.get("cell_type") != "code":
            continue
        src = "".join(cell.get("source", ""))
        src = "\n".join(line for line in src.splitlines() if not line.lstrip().startswith(("%", "!")))
        try:
            tree = ast.parse(src)
        except SyntaxError as exc:
            out.append(f"cell {k}: does not parse ({exc.msg})")
            continue
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                out.append(f"cell {k}: def {node.name}")
            elif isinstance(node, ast.ClassDef):
                out.append(f"cell {k}: class {node.name}")
            elif isinstance(node, (ast.Assign, ast.AnnAssign)) and isinstance(node.value, ast.Lambda):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                out.append(f"cell {k}: {', '.join(ast.unparse(t) for t in targets)} = lambda")
    return out


# --------------------------------------------------------------------------------------------
# The apparatus
# --------------------------------------------------------------------------------------------

#: The pages of the apparatus, in the table of contents.
APPARATUS_PAGES = ("book/nomenclature", "book/figures", "book/concepts")
#: At least this many exercises in the book, and in every numbered chapter.
EXERCISES_IN_THE_BOOK, EXERCISES_PER_CHAPTER = 60, 3


def toc_files(toc: dict) -> tuple[list[str], list[str]]:
    """(every file, the numbered chapters) of a ``_toc.yml`` as loaded."""
    files, numbered = [toc["root"]], []
    for part in toc.get("parts", []):
        for ch in part.get("chapters", []):
            files.append(ch["file"])
            if part.get("numbered"):
                numbered.append(ch["file"])
    return files, numbered


def chapter_markdown(path: Path) -> str:
    """The markdown of a chapter (the markdown cells of a notebook, or a markdown page)."""
    if path.suffix == ".ipynb":
        nb = json.loads(path.read_text(encoding="utf-8"))
        return "\n".join("".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "markdown")
    return path.read_text(encoding="utf-8")


def _source(root: Path, doc: str) -> Path | None:
    for suffix in (".ipynb", ".md"):
        p = root / (doc + suffix)
        if p.is_file():
            return p
    return None


def apparatus_problems(root: Path = ROOT, toc: dict | None = None) -> list[str]:
    """What the textbook's apparatus lacks: a page of :data:`APPARATUS_PAGES` missing from the
    table of contents or from ``book/``, a numbered chapter without a "Summary" section or with
    fewer than :data:`EXERCISES_PER_CHAPTER` exercises (or an exercise without its solution),
    fewer than :data:`EXERCISES_IN_THE_BOOK` exercises in all."""
    toc = toc if toc is not None else yaml.safe_load((root / "_toc.yml").read_text())
    files, numbered = toc_files(toc)
    out = []
    for page in APPARATUS_PAGES:
        if page not in files:
            out.append(f"{page}: not in the table of contents")
        elif _source(root, page) is None:
            out.append(f"{page}: no such page")
    total = 0
    for doc in numbered:
        path = _source(root, doc)
        if path is None:
            out.append(f"{doc}: no such chapter")
            continue
        text = chapter_markdown(path)
        if not re.search(r"^## Summary\b", text, re.M):
            out.append(f"{doc}: no section 'Summary'")
        labels = re.findall(r"```\{exercise\}\s*\n:label:\s*(\S+)", text)
        solved = set(re.findall(r"```\{solution\}\s+(\S+)", text))
        total += len(labels)
        if len(labels) < EXERCISES_PER_CHAPTER:
            out.append(f"{doc}: {len(labels)} exercises, fewer than {EXERCISES_PER_CHAPTER}")
        missing = [lab for lab in labels if lab not in solved]
        if missing:
            out.append(f"{doc}: exercises without a solution: {missing}")
    if total < EXERCISES_IN_THE_BOOK:
        out.append(f"{total} exercises in the numbered chapters, fewer than {EXERCISES_IN_THE_BOOK}")
    return out


def glue_problems(nb: dict) -> list[str]:
    """A solution that pastes a computed number (``{glue:text}`key```) whose key no code cell of
    the notebook glues: the number would be missing from the page."""
    glued = set()
    for cell in nb.get("cells", []):
        if cell.get("cell_type") == "code":
            glued |= set(re.findall(r"glue\(\s*f?[\"']([^\"']+)[\"']", "".join(cell.get("source", ""))))
    patterns = [re.compile("^" + re.sub(r"\\\{[^}]*\\\}", r"\\w+", re.escape(g)) + "$") for g in glued]
    out = []
    for cell in nb.get("cells", []):
        if cell.get("cell_type") != "markdown":
            continue
        for key in re.findall(r"\{glue(?::\w+)?\}`([\w]+)", "".join(cell.get("source", ""))):
            if not any(p.match(key) for p in patterns):
                out.append(f"glue key {key!r} is pasted but never glued")
    return out
