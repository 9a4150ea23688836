"""The library's one reader of its TOML data files (fivebar.errors.read_toml)."""

import pytest


def test_the_one_toml_reader_names_each_fault_for_each_data_file(tmp_path):
    """Parameter files, ranges and errata are read by errors.read_toml: a missing file, a
    folder, invalid TOML and text that is not UTF-8 each raise the caller's error, naming the
    file and the fault."""
    from fivebar.analyses.sensitivity import SensitivityError, load_ranges
    from fivebar.book.reporting import ReportError, errata_table
    from fivebar.errors import ParameterError
    from fivebar import load_params

    bad_toml, not_utf8 = tmp_path / "bad.toml", tmp_path / "latin1.toml"
    bad_toml.write_text("[[input]\n")
    not_utf8.write_bytes(b"reason = '\xe9t\xe9'\n")
    cases = {"does not exist": tmp_path / "none.toml", "cannot be read": tmp_path,
             "not valid TOML": bad_toml, "not valid UTF-8": not_utf8}
    for reader, error, what in ((load_params, ParameterError, "parameter file path"),
                                (load_ranges, SensitivityError, "ranges file path"),
                                (errata_table, ReportError, "errata file path")):
        for fault, path in cases.items():
            with pytest.raises(error, match=fault) as info:
                reader(path)
            assert f"{what} = {str(path)!r}" in str(info.value)
