"""The rerun command (book/_ext/fivebar_rerun.py, `make rerun`): a chapter executed with a
reader's parameter file gets the file injected after its parameters cell and computes with it;
a cell error or a failed physics check makes the command fail and names chapter and cell.

The chapters are tested on a copy of chapter 01's head (its cells up to the one that loads the
parameters) with a last cell added; the copy lives in a temporary directory, the book's
notebooks are not touched.  Each run starts a kernel: a few seconds.  (The whole chapters are
rerun with every example file by `make rerun-examples`, in CI.)
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

pytest.importorskip("papermill")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "book" / "_ext"))
import fivebar_rerun as rerun  # noqa: E402


pytestmark = pytest.mark.slow  # subprocesses and signals: make test runs them, make check does not


def _code(source: str, tags: list[str] | None = None) -> dict:
    return {"cell_type": "code", "execution_count": None, "id": f"c{abs(hash(source)) % 10**8}",
            "metadata": {"tags": tags or []}, "outputs": [], "source": source}


def _chapter_copy(tmp_path: Path, extra: str = "") -> Path:
    """Chapter 01's head: its cells up to the one that loads its parameters (its parameters
    cell, PARAMS_FILES = [], and fivebar.book.chapter.load(PARAMS_FILES)); ``extra`` is
    appended as a last code cell."""
    nb = json.loads((ROOT / "book" / "01_mechanism.ipynb").read_text())
    tagged = [c for c in nb["cells"] if "parameters" in c["metadata"].get("tags", [])]
    assert len(tagged) == 1 and "PARAMS_FILES = []" in "".join(tagged[0]["source"])
    loads = [i for i, c in enumerate(nb["cells"]) if "fivebar.book.chapter.load(PARAMS_FILES)" in "".join(c["source"])]
    assert loads, "chapter 01 no longer loads its parameters with fivebar.book.chapter.load(PARAMS_FILES)"
    nb["cells"] = nb["cells"][: loads[0] + 1]
    nb["cells"].append(_code("print('damping ratio used:', params.damping_ratio)\n" + extra))
    path = tmp_path / "01_mechanism.ipynb"
    path.write_text(json.dumps(nb))
    return path


def _outputs_text(nb_path: Path) -> str:
    nb = json.loads(nb_path.read_text())
    return "".join(o.get("text", "") if isinstance(o.get("text", ""), str) else "".join(o["text"])
                   for c in nb["cells"] if c["cell_type"] == "code" for o in c["outputs"])


def test_rerun_injects_the_reader_file(tmp_path):
    params = tmp_path / "damping.toml"
    params.write_text("[assumptions]\ndamping_ratio = 0.0123\n")
    nb = _chapter_copy(tmp_path)
    status = rerun.main([str(params), "--chapters", str(nb), "--no-html", "--out", str(tmp_path / "out")])
    assert status == 0
    out = tmp_path / "out" / "damping" / "01_mechanism.ipynb"
    executed = json.loads(out.read_text())
    injected = [c for c in executed["cells"] if "injected-parameters" in c["metadata"].get("tags", [])]
    assert len(injected) == 1 and str(params.resolve()) in "".join(injected[0]["source"])
    assert "damping ratio used: 0.0123" in _outputs_text(out)  # not the book's


def test_rerun_fails_on_a_physics_check_and_names_it(tmp_path, capsys):
    params = tmp_path / "damping.toml"
    params.write_text("[assumptions]\ndamping_ratio = 0.0123\n")
    nb = _chapter_copy(tmp_path, "fivebar.book.chapter.physics_check(False, 'planted quantity', 1.0, '< 0', 'planted')")
    status = rerun.main([str(params), "--chapters", str(nb), "--no-html", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert status == 1
    assert "01_mechanism: failed physics check in cell" in err
    assert "planted quantity" in err


def test_rerun_refuses_bad_arguments(tmp_path, capsys):
    assert rerun.main([str(tmp_path / "absent.toml"), "--no-html"]) == 2
    assert "absent.toml' does not exist" in capsys.readouterr().err
    params = tmp_path / "p.toml"
    params.write_text("")
    assert rerun.main([str(params), "--chapters", "99", "--no-html"]) == 2
    assert "chapter '99' is not a chapter of the book" in capsys.readouterr().err
    nb = json.loads((ROOT / "book" / "01_mechanism.ipynb").read_text())  # no parameters cell
    for c in nb["cells"]:
        c["metadata"].pop("tags", None)
    (tmp_path / "01_mechanism.ipynb").write_text(json.dumps(nb))
    assert rerun.main([str(params), "--chapters", str(tmp_path / "01_mechanism.ipynb"), "--no-html"]) == 2
    assert "no cell tagged 'parameters' in 01_mechanism" in capsys.readouterr().err


def test_each_file_alone_and_the_matrix_with_what_does_not_apply(tmp_path):
    """``--each``: every chapter with every file (not layered), in one pool; the matrix names what
    each chapter said does not apply, from its note at the top (an Applicability display updated
    by a later cell: papermill keeps the update where the note was shown)."""
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text("[assumptions]\ndamping_ratio = 0.0123\n")
    b.write_text("[assumptions]\ndamping_ratio = 0.05\n")
    nb_path = _chapter_copy(tmp_path, "note = fivebar.book.chapter.Applicability()\ndisplay(note)\n")
    nb = json.loads(nb_path.read_text())
    nb["cells"].append(_code("if params.damping_ratio > 0.02:\n"
                             "    note.add('The light damping study', 'does not apply: the damping is heavy.', 'Give less.')"))
    nb_path.write_text(json.dumps(nb))
    out = tmp_path / "out"
    status = rerun.main([str(a), str(b), "--each", "--chapters", str(nb_path), "--no-html", "--out", str(out),
                         "--jobs", "2"])
    assert status == 0
    assert "damping ratio used: 0.0123" in _outputs_text(out / "a" / "01_mechanism.ipynb")
    assert "damping ratio used: 0.05" in _outputs_text(out / "b" / "01_mechanism.ipynb")
    assert rerun.applicability_notes(out / "a" / "01_mechanism.ipynb") == ()
    notes = rerun.applicability_notes(out / "b" / "01_mechanism.ipynb")
    assert notes == ("**The light damping study** does not apply: the damping is heavy.  Give less.",)
    matrix = (out / "matrix.md").read_text()
    assert "| 01_mechanism | ok (" in matrix and "ok, 1 not applicable" in matrix
    assert "01_mechanism with `b`: **The light damping study** does not apply" in matrix
    # --only-with: the chapter reruns with the files named only (CI's longest chapters), '-' for the others
    out2 = tmp_path / "out2"
    assert rerun.main([str(a), str(b), "--each", "--chapters", str(nb_path), "--no-html", "--out", str(out2),
                       "--only-with", "01=a"]) == 0
    assert (out2 / "a" / "01_mechanism.ipynb").is_file() and not (out2 / "b" / "01_mechanism.ipynb").exists()
    assert "| 01_mechanism | ok (" in (out2 / "matrix.md").read_text() and " | - | " in (out2 / "matrix.md").read_text()
    for bad in ("01=zzz", "01", "99=a"):
        assert rerun.main([str(a), str(b), "--each", "--no-html", "--out", str(out2), "--only-with", bad]) == 2
