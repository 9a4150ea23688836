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

from fivebar.datasets import DATASETS  # noqa: E402


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
