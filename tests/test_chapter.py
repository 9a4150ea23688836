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
