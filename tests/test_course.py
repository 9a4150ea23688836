"""The course map (book/course.toml) covers the book's table of contents, and its directives and
the download helper of book/_ext/fivebar_teaching.py work."""

from __future__ import annotations

import html
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "book" / "_ext"))

import fivebar_teaching as teaching  # noqa: E402

from fivebar.book.datasets import DATASETS  # noqa: E402


def toc_files() -> list[str]:
    """Every ``file:`` of _toc.yml except the root (read as text: no yaml needed)."""
    text = (ROOT / "_toc.yml").read_text()
    return re.findall(r"^\s*-\s*file:\s*(\S+)", text, flags=re.M)


@pytest.fixture(scope="module")
def course():
    return teaching.load_course(ROOT / teaching.COURSE_FILE)


def test_every_toc_chapter_has_an_entry(course):
    missing = [f for f in toc_files() if f != "book/course" and teaching.chapter_entry(course, f) is None]
    assert not missing, f"chapters of _toc.yml without a [[chapter]] in course.toml: {missing}"


def test_every_entry_is_in_the_toc_unless_planned(course):
    toc = set(toc_files())
    stale = [ch["file"] for ch in course["chapter"]
             if not ch.get("planned") and not ({ch["file"], *ch.get("formerly", [])} & toc)]
    assert not stale, f"course.toml entries whose chapter is not in _toc.yml: {stale}"


def test_entries_are_complete(course):
    for ch in course["chapter"]:
        if ch["role"] != "reference":
            assert 3 <= len(ch["objectives"]) <= 5, ch["file"]
            assert ch["reading"] > 0 and ch["working"] > 0, ch["file"]
    roles = {ch["file"]: ch["role"] for ch in course["chapter"]}
    assert roles["book/04_electromagnetics"] == "optional"  # 0 % effect on the linkage
    assert {"core"} <= set(roles.values())


def test_paths_cover_the_core_chapters(course):
    core = {ch["file"] for ch in course["chapter"] if ch["role"] == "core"}
    for name in ("semester", "short"):
        steps = course["path"][name]["steps"]
        seen = {f for s in steps for f in s["chapters"]}
        if name == "semester":
            assert core <= seen, core - seen
            assert len(steps) >= 10
        else:
            assert core - {"book/02_elements"} <= seen, core - seen  # the short course skims 02


def test_bad_course_files_are_refused(tmp_path):
    good = (ROOT / teaching.COURSE_FILE).read_text()
    cases = {
        "objectives": re.sub(r"objectives = \[.*?\n\]", 'objectives = ["only one"]', good, count=1, flags=re.S),
        "role = 'elective'": good.replace('role = "optional"', 'role = "elective"', 1),
        "unknown chapter": good.replace('chapters = ["book/02_elements"]', 'chapters = ["book/02_element"]', 1),
        "reading": good.replace("reading = 30", 'reading = "half an hour"', 1),
    }
    for expect, text in cases.items():
        p = tmp_path / "course.toml"
        p.write_text(text)
        with pytest.raises(ValueError) as err:
            teaching.load_course(p)
        assert any(w in str(err.value) for w in expect.split()), (expect, str(err.value))


def test_download_helper_links_every_dataset_from_its_chapter():
    toc = toc_files()
    linked = []
    for f in toc:
        linked += teaching.downloads_for(f)
    assert sorted(linked) == sorted(DATASETS)
    assert teaching.downloads_for("book/09_figure6") == ["figure6_curves"]
    assert teaching.downloads_for("book/01_mechanism") == []


BUILT = ROOT / "_build" / "html"


@pytest.mark.skipif(not (BUILT / ".fivebar-build-ok").is_file(), reason="the book is not built (make book)")
def test_built_course_map_and_downloads():
    page = html.unescape((BUILT / "book" / "course.html").read_text(encoding="utf-8")).replace("\u2019", "'")
    course = teaching.load_course(ROOT / teaching.COURSE_FILE)
    for ch in course["chapter"]:
        assert ch["title"] in page
    assert "Week 13" in page and "Day 3 afternoon" in page
    # every generated CSV is there to be linked, with its provenance line
    for name in DATASETS:
        f = ROOT / teaching.GENERATED / "data" / f"{name}.csv"
        assert f.read_text(encoding="utf-8").startswith("# fivebar ")
    # chapters that already carry {data-downloads} link their files (phase two adds the rest)
    for name, ds in DATASETS.items():
        text = (BUILT / "book" / f"{ds.chapter}.html").read_text(encoding="utf-8")
        if "fivebar-downloads" in text:
            assert re.search(rf'href="[^"]*_downloads/[0-9a-f]+/{name}\.csv"', text), name


# --- the directives in a small Sphinx build (in-process; the CSVs are stubbed) -----------------

def _mini_book(tmp_path: Path, monkeypatch, with_anim: bool) -> tuple[Path, Path]:
    import fivebar.book.datasets

    src = tmp_path / "src"
    (src / "book").mkdir(parents=True)
    (src / "book" / "course.toml").write_text((ROOT / teaching.COURSE_FILE).read_text())
    (src / "conf.py").write_text(
        f"import sys\nsys.path.insert(0, {str(ROOT / 'book' / '_ext')!r})\n"
        "extensions = ['myst_parser', 'fivebar_teaching']\nmyst_enable_extensions = ['colon_fence', 'dollarmath']\n"
        "exclude_patterns = ['book/_generated']\n")
    (src / "index.md").write_text("# Book\n\n```{toctree}\nbook/course\nbook/09_figure6\nbook/06_newmark\n```\n")
    (src / "book" / "course.md").write_text("# Course map\n\n```{course-map} chapters\n```\n\n```{course-map} short\n```\n")
    (src / "book" / "06_newmark.md").write_text("# Newmark\n\ntext\n")
    (src / "book" / "09_figure6.md").write_text(
        "# Figure 6\n\n```{learning-objectives}\n```\n\n```{data-downloads}\n```\n\n"
        '<iframe class="fivebar-animation" src="_generated/anim/09_linkage.html"></iframe>\n')

    def fake_write(outdir, *a, **k):
        outdir = Path(outdir)
        outdir.mkdir(parents=True, exist_ok=True)
        for name in DATASETS:
            (outdir / f"{name}.csv").write_text("# fivebar stub\na\n1\n")
        return {name: 0.0 for name in DATASETS}

    monkeypatch.setattr(fivebar.book.datasets, "write_datasets", fake_write)
    if with_anim:
        (src / "book" / "_generated" / "anim").mkdir(parents=True)
        (src / "book" / "_generated" / "anim" / "09_linkage.html").write_text("<html>stub</html>")
    return src, tmp_path / "out"


def _build(src: Path, out: Path) -> None:
    from sphinx.application import Sphinx
    from sphinx.util.docutils import docutils_namespace

    with docutils_namespace():  # each build registers its nodes afresh
        app = Sphinx(str(src), str(src), str(out), str(out / ".doctrees"), "html", status=None,
                     warning=None, warningiserror=True, freshenv=True)
        app.build()


def test_directives_render_in_a_sphinx_build(tmp_path, monkeypatch):
    src, out = _mini_book(tmp_path, monkeypatch, with_anim=True)
    _build(src, out)
    page = html.unescape((out / "book" / "09_figure6.html").read_text()).replace("\u2019", "'")
    course = teaching.load_course(src / teaching.COURSE_FILE)
    for objective in teaching.chapter_entry(course, "book/09_figure6")["objectives"]:
        assert objective in page
    assert re.search(r'href="[^"]*_downloads/[0-9a-f]+/figure6_curves\.csv"', page)
    assert (out / "book" / "_generated" / "anim" / "09_linkage.html").is_file()  # copied next to the page
    cmap = html.unescape((out / "book" / "course.html").read_text())
    assert 'href="06_newmark.html"' in cmap  # a chapter of the build is linked
    assert "Multibody validation (Exudyn against the KED model) (planned)" in cmap  # one that is not, is not
    # prerequisites and the work of a course path are MyST like the objectives: their maths typeset
    eig = r"\mathbf K \boldsymbol\phi = \omega^2 \mathbf M \boldsymbol\phi"
    assert re.search(r'<span class="math[^"]*">\\\(' + re.escape(eig) + r"\\\)</span>", cmap), "05's prerequisite"


def test_a_missing_animation_fails_the_build(tmp_path, monkeypatch):
    from sphinx.errors import ExtensionError

    src, out = _mini_book(tmp_path, monkeypatch, with_anim=False)
    with pytest.raises(ExtensionError, match="09_linkage.html"):
        _build(src, out)


# --- chapter numbers, exercises by week, the project (issue 22.6) ------------------------------

def _exercise_labels() -> dict[str, str]:
    """Every exercise label of the chapters -> its notebook (read as text)."""
    out = {}
    for nb in sorted((ROOT / "book").glob("[0-9][0-9]_*.ipynb")):
        for label in re.findall(r":label: (ex-[A-Za-z0-9_-]+)", nb.read_text(encoding="utf-8")):
            out[label] = nb.stem
    return out


def test_every_exercise_is_in_exactly_one_week(course):
    labels = _exercise_labels()
    weeks: dict[str, list[str]] = {}
    for step in course["path"]["semester"]["steps"]:
        for label in step.get("exercises", []):
            weeks.setdefault(label, []).append(step["label"])
    unmapped = sorted(set(labels) - set(weeks))
    unknown = sorted(set(weeks) - set(labels))
    twice = {k: v for k, v in weeks.items() if len(v) > 1}
    assert not unmapped, f"exercises in no week of the semester course: {unmapped}"
    assert not unknown, f"weeks list exercises that no chapter has: {unknown}"
    assert not twice, f"exercises in more than one week: {twice}"
    # a week's exercises belong to chapters of that week
    for step in course["path"]["semester"]["steps"]:
        for label in step.get("exercises", []):
            assert f"book/{labels[label]}" in step["chapters"], (step["label"], label)


def test_chapter_numbers_follow_the_toc():
    numbered = [f for f in toc_files() if teaching.chapter_number(f) is not None]
    assert [teaching.chapter_number(f) for f in numbered] == list(range(1, len(numbered) + 1))
    assert teaching.chapter_number("book/errata") is None


def test_the_project_rubric_sums_to_100(course, tmp_path):
    rubric = course["project"]["rubric"]
    assert sum(r["weight"] for r in rubric) == 100 and all(r["excellent"] and r["insufficient"] for r in rubric)
    bad = (ROOT / teaching.COURSE_FILE).read_text().replace("weight = 30", "weight = 31")
    (tmp_path / "course.toml").write_text(bad)
    with pytest.raises(ValueError, match="rubric weights"):
        teaching.load_course(tmp_path / "course.toml")


# ASCII maths in the course map's text: phi, omega, x^2, x_k, "S = 100", single-letter matrices
_ASCII_MATH = re.compile(r"[A-Za-z]_[A-Za-z0-9{]|\^\d|\bsqrt\(|\b(?:phi|omega|zeta|beta|theta\d?|Omega|sigma|mu0|rho)\b"
                         r"|\b[A-Z] = \d|\b[MK]\b|<=|>=")


_SHOWN = ("title", "objectives", "prerequisites", "why", "work", "audience", "task", "deliverables",
          "criterion", "excellent", "adequate", "insufficient")


def _shown(value, key: str | None = None) -> list[str]:
    """The texts of course.toml that the pages show (under the keys of _SHOWN, at any depth)."""
    if isinstance(value, str):
        return [value] if key in _SHOWN else []
    if isinstance(value, dict):
        return [s for k, v in value.items() for s in _shown(v, k)]
    if isinstance(value, list):
        return [s for v in value for s in _shown(v, key)]
    return []


def test_the_course_map_writes_its_maths_in_latex(course):
    """Every text of course.toml that the course map and the chapters show writes its formulas in
    LaTeX between $...$ like the rest of the book (issue 22: "K phi = omega^2 M phi" was ASCII)."""
    texts = [t for t in _shown(course) if not t.startswith("book/")]
    assert len(texts) > 100
    bad = [(hit.group(0), t) for t in texts
           if (hit := _ASCII_MATH.search(re.sub(r"`[^`]*`", " ", re.sub(r"\$[^$]*\$", " ", t))))]
    assert not bad, f"ASCII maths in course.toml (write it as $...$): {bad}"
    assert _ASCII_MATH.search("the generalised eigenproblem K phi = omega^2 M phi")
    assert not _ASCII_MATH.search(re.sub(r"\$[^$]*\$", " ", "at $S = 100$ with $\\mathbf K$"))
