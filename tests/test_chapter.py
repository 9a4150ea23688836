"""The chapters' parameter loading and their two kinds of checks (fivebar.book.chapter)."""

import pytest

import fivebar
from fivebar.book import chapter


def test_load_layers_the_readers_file_over_the_books(tmp_path):
    mine = tmp_path / "mine.toml"
    mine.write_text("[assumptions]\ncrank_speed_rpm = 120\nbending_depth = 0.002\n")
    p = chapter.load([mine])
    assert p.crank_speed_rpm == 120 and p.bending_depth == 0.002
    book = chapter.load([])
    assert book.crank_speed_rpm == fivebar.load_params().crank_speed_rpm
    assert set(chapter.differences(p)) == {"assumptions.crank_speed_rpm", "assumptions.bending_depth"}
    assert chapter.differences(p)["assumptions.crank_speed_rpm"] == (book.crank_speed_rpm, 120)
    assert chapter.is_book_params(book) and not chapter.is_book_params(p)


def test_load_of_the_fourbar_compares_with_its_own_file():
    base = [fivebar.DEFAULT_PARAMS_PATH, fivebar.FOURBAR_PARAMS_PATH]
    p = chapter.load([], base=base)
    assert chapter.is_book_params(p, base)
    assert not chapter.is_book_params(p)  # against the five-bar's file


def test_physics_check_names_quantity_value_bound_and_meaning():
    chapter.physics_check(True, "energy change", 0.0, "< 1e-9", "energy is conserved")
    with pytest.raises(chapter.CheckFailed, match=r"energy change = 0.5, expected < 1e-9: energy is conserved"):
        chapter.physics_check(0.5 < 1e-9, "energy change", 0.5, "< 1e-9", "energy is conserved")
    assert issubclass(chapter.CheckFailed, fivebar.FivebarError)


def test_book_value_check_checks_with_the_books_parameters_and_skips_visibly_otherwise(capsys):
    book = fivebar.load_params()
    assert chapter.book_value_check(book, "L1", book.L1, book.L1) is True
    with pytest.raises(chapter.CheckFailed, match=r"book value check failed: L1 = 0.3, the book's parameters must give 0.31"):
        chapter.book_value_check(book, "L1", 0.3, 0.31, rtol=1e-3)
    other = book.replace(damping_ratio=0.01)
    assert chapter.book_value_check(other, "L1", 0.3, 0.31) is False
    out = capsys.readouterr().out
    assert "not checked" in out and "assumptions.damping_ratio" in out and "0.31" in out


def test_bad_arguments_are_named():
    with pytest.raises(fivebar.errors.InputError, match="rtol = -1"):
        chapter.book_value_check(fivebar.load_params(), "x", 1.0, 1.0, rtol=-1)
    with pytest.raises(fivebar.errors.InputError, match="files = 3"):
        chapter.load(3)


def test_a_list_written_as_a_string_is_refused_with_the_papermill_remedy(tmp_path):
    """papermill's -p passes '["mine.toml"]' as text; reading it as one file name would fail later
    with a missing file '["mine.toml"]'.  The error says what happened and the -y remedy, and a real
    list of the same file loads."""
    f = tmp_path / "mine.toml"
    f.write_text("[assumptions]\ncrank_speed_rpm = 120\n")
    with pytest.raises(fivebar.errors.InputError, match=r"list written as a string.*-y"):
        chapter.load(f'["{f}"]')
    assert chapter.load([str(f)]).crank_speed_rpm == 120


def test_warnings_are_shown_as_admonitions_without_paths(monkeypatch):
    """warnings_shown: each different message of the block once, as the book's admonition with
    its title and numbers, no file or line of the code that warned; other categories pass on."""
    import warnings

    import IPython.display

    from fivebar.book.chapter import warnings_shown
    from fivebar.errors import ValidityWarning

    shown = []
    monkeypatch.setattr(IPython.display, "display", lambda obj: shown.append(obj.data))
    with warnings.catch_warnings(record=True) as outer:
        warnings.simplefilter("always")
        with warnings_shown(ValidityWarning) as caught:
            for _ in range(2):
                warnings.warn("116 of 120 sweep rows are outside the model's validity", ValidityWarning)
            warnings.warn("another kind", DeprecationWarning)
    assert len(caught) == 2 and len(shown) == 1
    assert shown[0].startswith("```{warning} Outside the model's validity\n116 of 120 sweep rows")
    assert shown[0].endswith("\n```") and ".py" not in shown[0]
    assert [str(w.message) for w in outer] == ["another kind"]


def test_a_chapter_of_the_fourbar_names_and_leaves_out_the_five_bars_entries(tmp_path):
    """Issue 32: a reader's file is written for the book's five-bar; the four-bar's chapter takes the
    entries its linkage uses (material, damping, speed) and names the others (the five-bar's coupler
    length and mass at B, its speed ratio, a motor's data, a [linkage] of five joints), instead of
    refusing the file ('unknown entries ... which the linkage does not use') or applying them."""
    mine = tmp_path / "mine.toml"
    mine.write_text("[geometry]\nL2 = 0.45\n[masses]\nm01 = 0.3\n[material]\nE = 210e9\n"
                    "[assumptions]\nspeed_ratio = 2.0\ndamping_ratio = 0.03\nshaft_diameter_1 = 0.011\n"
                    "em_variant = \"literal\"\n[motor1]\nm0 = 3.5\n")
    base = [fivebar.DEFAULT_PARAMS_PATH, fivebar.FOURBAR_PARAMS_PATH]
    with pytest.raises(fivebar.ParameterError, match="does not use"):
        chapter.load([mine], base=base)  # the plain layering refuses the five-bar's names
    p, ignored = chapter.load_other_linkage([mine], base=base)
    own = chapter.load([], base=base)
    assert p.E == 210e9 and p.damping_ratio == 0.03
    assert [k.length for k in p.linkage.links] == [k.length for k in own.linkage.links]
    assert [j.mass for j in p.linkage.joints] == [j.mass for j in own.linkage.joints]
    assert set(ignored) == {"geometry.L2", "masses.m01", "assumptions.speed_ratio", "assumptions.shaft_diameter_1",
                            "assumptions.em_variant", "motor1.m0"}
    assert "five-bar" in ignored["assumptions.speed_ratio"] and "motor" in ignored["motor1.m0"]
    # a misspelt entry is still refused, with the nearest name, as in every other chapter
    typo = tmp_path / "typo.toml"
    typo.write_text("[geometry]\nL22 = 0.45\n")
    with pytest.raises(fivebar.ParameterError, match="did you mean 'geometry.L2'"):
        chapter.load_other_linkage([typo], base=base)
    # a [linkage] of the five-bar's five joints is not the four-bar's
    five = tmp_path / "five.toml"
    five.write_text('[linkage]\nname = "x"\nchain = ["A", "B", "C", "D", "E"]\nassembly = { joint = "C", side = "left" }\n'
                    '[linkage.links]\nL1 = { start = "A", end = "B", length = "geometry.L1" }\n'
                    'L2 = { start = "B", end = "C", length = "geometry.L2" }\n'
                    'L3 = { start = "C", end = "D", length = "geometry.L3" }\n'
                    'L4 = { start = "E", end = "D", length = "geometry.L4" }\n'
                    '[linkage.joints]\nA = { kind = "crank", at = [0.0, 0.0] }\nB = { kind = "pin" }\n'
                    'C = { kind = "pin" }\nD = { kind = "pin" }\nE = { kind = "crank", at = ["geometry.L5", 0.0] }\n')
    p, ignored = chapter.load_other_linkage([five], base=base)
    assert list(ignored) == ["linkage"] and p.linkage == own.linkage
    assert chapter.load_other_linkage([], base=base) == (own, {})


def test_the_applicability_note_is_empty_until_a_study_does_not_apply():
    note = chapter.Applicability()
    assert note.markdown() == chapter.Applicability.EMPTY and "The check" not in note
    assert note.EMPTY.startswith("<!--") and note.EMPTY.rstrip().endswith("-->")  # shown by no reader
    note.add("The check", "does not apply: no orbit at 600 r/min.", "Give a lower speed.")
    note.ignored({"geometry.L2": "not a number of the four-bar"})
    md = note.markdown()
    assert md.startswith(chapter.Applicability.TITLE) and md.rstrip().endswith(":::")
    assert "* **The check** does not apply: no orbit at 600 r/min.  Give a lower speed." in md
    assert "`geometry.L2` (not a number of the four-bar)" in md and "The check" in note
    with pytest.raises(fivebar.FivebarError, match="why"):
        note.add("x", 1)
