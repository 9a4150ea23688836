"""Tables of the book generated from data: the paper's misprints and the model's assumptions.

The errata chapter renders two tables from the project's data files, so the book can never
disagree with what the code uses:

* :func:`errata_table` reads ``data/errata.toml``: one ``[[erratum]]`` per misprint or
  inconsistency of the paper, with where it is, what is printed, how the book reads it, why,
  and what verifies the reading.
* :func:`assumptions_table` reads the ``[assumptions]`` of a parameter set (by default
  ``data/wang2011.toml``): every number the paper does not give, with its value, unit, the
  reason for it and the alternative the book shows beside it.

Beside them, how every chapter shows its numbers: :func:`table` (a numbered table), the
wording of a value (:func:`certain`, :func:`percent`, :func:`significant`, ...) and :func:`glue`
(a computed number stored for the text of an exercise's solution).

No equation of the paper is implemented here.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path
from typing import Any

import pandas as pd

from ..errors import FivebarError, InputError, read_toml
from ..description.params import DEFAULT_PARAMS_PATH, Params, load_params

__all__ = [
    "ERRATA_PATH",
    "certain",
    "change",
    "how_many",
    "length_text",
    "ordinal",
    "percent",
    "sci",
    "significant",
    "ERRATA_FIELDS",
    "ERRATA_MATH_FIELDS",
    "ReportError",
    "errata_table",
    "assumptions_table",
    "format_value",
    "data_files",
    "GLUE_PREFIX",
    "glue",
    "table",
]

#: The errata file shipped with the project.
#:
#: :meta hide-value:
ERRATA_PATH = Path(str(resources.files("fivebar") / "data" / "errata.toml"))

#: Field of an ``[[erratum]]`` entry -> column of :func:`errata_table`.
ERRATA_FIELDS = {
    "id": "id",
    "where": "where",
    "printed": "printed",
    "read_as": "read as",
    "reason": "reason",
    "verified_by": "verified by",
}

#: Optional fields of an ``[[erratum]]``: the printed text and the reading with their formulas
#: in LaTeX between ``$...$`` (what the book typesets) -> column of ``errata_table(math=True)``.
ERRATA_MATH_FIELDS = {
    "printed_tex": "printed (math)",
    "read_as_tex": "read as (math)",
}

_ASSUMPTION_FIELDS = ("unit", "reason", "alternative")


class ReportError(FivebarError, ValueError):
    """A data file for a table is missing, malformed or has an incomplete entry."""


def data_files() -> tuple[Path, Path]:
    """The data files the tables are generated from: (errata, parameters)."""
    return ERRATA_PATH, DEFAULT_PARAMS_PATH


def errata_table(path: str | Path | None = None, math: bool = False) -> pd.DataFrame:
    """The paper's misprints, one row per ``[[erratum]]`` of the errata file.

    ``df = errata_table()``; ``df = errata_table("my_errata.toml")``

    Parameters
    ----------
    path
        The errata file; ``None`` reads ``data/errata.toml``.
    math
        Add the columns ``printed (math)`` and ``read as (math)``: the optional fields
        ``printed_tex`` and ``read_as_tex`` (formulas in LaTeX between ``$...$``), empty where
        an entry has none.

    Returns
    -------
    pandas.DataFrame
        Columns ``id``, ``where``, ``printed``, ``read as``, ``reason``, ``verified by``
        (all text), in the order of the file.

    Raises
    ------
    ReportError
        If the file does not exist or is not valid TOML, if an entry lacks a field or has
        an empty or non-text one (the message names the entry and the field), or if two
        entries share an id.
    """
    path = Path(ERRATA_PATH if path is None else path)
    doc = read_toml(path, "errata file path", ReportError)
    entries = doc.get("erratum")
    if not isinstance(entries, list) or not entries:
        raise ReportError(f"errata file {str(path)!r} has no [[erratum]] entries")
    rows = []
    seen: set[str] = set()
    for k, entry in enumerate(entries, start=1):
        label = f"[[erratum]] number {k} (id {entry.get('id', '?')!r}) of {str(path)!r}"
        row = {}
        for key, column in ERRATA_FIELDS.items():
            value = entry.get(key)
            if not isinstance(value, str) or not value.strip():
                raise ReportError(
                    f"{label}: field {key!r} = {value!r} is not allowed: it must be "
                    "non-empty text"
                )
            row[column] = value.strip()
        for key, column in ERRATA_MATH_FIELDS.items():
            value = entry.get(key, "")
            if not isinstance(value, str) or (key in entry and not value.strip()):
                raise ReportError(
                    f"{label}: field {key!r} = {value!r} is not allowed: it must be "
                    "non-empty text (LaTeX between $...$) or absent"
                )
            if math:
                row[column] = value.strip()
        if row["id"] in seen:
            raise ReportError(f"{label}: id {row['id']!r} is used twice")
        seen.add(row["id"])
        rows.append(row)
    columns = list(ERRATA_FIELDS.values()) + (list(ERRATA_MATH_FIELDS.values()) if math else [])
    return pd.DataFrame(rows, columns=columns)


def assumptions_table(params: Params | None = None, effects: bool = False) -> pd.DataFrame:
    """The model's assumptions: the numbers the paper does not give.

    ``df = assumptions_table()``; ``df = assumptions_table(load_params().replace(...))``

    Parameters
    ----------
    params
        The parameter set whose ``[assumptions]`` are listed (values as used, including
        overrides); ``None`` loads ``data/wang2011.toml``.
    effects
        Add a column ``effect on Figure 6``: how much the peak-to-peak transverse midpoint
        deflections of L2 and L3 move when the assumption takes each alternative of
        :data:`fivebar.analyses.figure6.ASSUMPTION_VARIANTS` (a few seconds of computation).

    Returns
    -------
    pandas.DataFrame
        Columns ``key`` (the name in ``[assumptions]``), ``value`` (a number in the unit of
        the ``unit`` column, or text), ``unit``, ``reason``, ``alternative``; in the order of
        the parameter schema (:mod:`fivebar.description.params`).  An entry overridden without a reason shows an empty reason.
    """
    params = load_params() if params is None else params
    rows = []
    for dotted, value in params.values.items():
        section, _, key = dotted.partition(".")
        if section != "assumptions":
            continue
        meta = params.meta.get(dotted, {})
        row: dict[str, Any] = {"key": key, "value": value}
        for field in _ASSUMPTION_FIELDS:
            row[field] = str(meta.get(field, "")).strip()
        rows.append(row)
    df = pd.DataFrame(rows, columns=["key", "value", *_ASSUMPTION_FIELDS])
    if effects:
        df["effect on Figure 6"] = df["key"].map({**_NO_EFFECT, **_figure6_effects(params)}).fillna(
            "not varied in the Figure 6 table"
        )
    return df


_ROTOR_ONLY = "none: it acts only on the rotors' whirl, which is decoupled from the links"
#: assumptions that cannot move the linkage's response, and why
_NO_EFFECT = {
    "supply_frequency": _ROTOR_ONLY,
    "phase_phi10": _ROTOR_ONLY,
    "phase_phi20": _ROTOR_ONLY,
    "static_eccentricity_angle": _ROTOR_ONLY,
    "eccentricity_scale": _ROTOR_ONLY,
    "fourier_terms": "none: it is used by the multiple-scales approximation only",
    "yield_stress": "none: it is the limit the computed stress is compared with",
    "buckling_length_factor": "none: it sets the Euler load the computed compression is compared with",
}


def _figure6_effects(params: Params) -> dict[str, str]:
    """Assumption key -> the change of the L2 / L3 peak-to-peak deflections, in words."""
    from ..analyses.figure6 import assumption_effects

    eff = assumption_effects(params).iloc[1:]
    out: dict[str, list[str]] = {}
    for r in eff.to_dict("records"):
        out.setdefault(r["assumption"], []).append(
            f"{r['alternative']}: L2 {r['L2 change (%)']:+.3g} %, L3 {r['L3 change (%)']:+.3g} %"
        )
    return {k: "; ".join(v) for k, v in out.items()}


def format_value(value: Any) -> str:
    """A table cell as text: numbers to 4 significant digits, text unchanged.

    >>> format_value(210.0e9), format_value(0.03), format_value(100), format_value("literal")
    ('2.1e+11', '0.03', '100', 'literal')
    """
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isfinite(value) and value == int(value) and abs(value) < 1e6:
            return str(int(value))
        return f"{value:.4g}"
    return str(value)


def certain(value: float, uncertainty: float, decimals: int = 2) -> str:
    """``value`` to the decimals that ``uncertainty`` cannot change: the fewest, from
    ``decimals`` up, at which ``value - uncertainty`` and ``value + uncertainty`` print the same
    (a value within its uncertainty of a rounding boundary takes more decimals instead of
    printing whichever side round-off lands it on); if even ``decimals`` is too many, fewer.

    A number computed to a tolerance (a fold located to 1e-5 r/min, an orbit to 1e-10) differs
    in its last digits from one machine to another (BLAS kernel, threads, fused multiply-add);
    printed with this, the page reads the same on every machine.

    >>> certain(195.16791, 1e-4), certain(204.03500, 1e-4), certain(204.03503, 1e-4)
    ('195.17', '204.035', '204.035')
    >>> certain(0.123456, 0.01, decimals=3)
    '0.1'
    """
    value, uncertainty = float(value), abs(float(uncertainty))
    if not (math.isfinite(value) and math.isfinite(uncertainty)):
        raise InputError(f"value = {value!r}, uncertainty = {uncertainty!r} are not allowed: give finite numbers")

    def same(d):
        lo, hi = f"{value - uncertainty:.{d}f}", f"{value + uncertainty:.{d}f}"
        return lo == hi and lo == f"{value:.{d}f}"
    for d in range(int(decimals), int(decimals) + 4):
        if same(d):
            return f"{value:.{d}f}"
    for d in range(int(decimals) - 1, -1, -1):
        if same(d):
            return f"{value:.{d}f}"
    return f"{value:.0f}"


# --- words and numbers for the sentences a chapter generates --------------------------------------
def percent(fraction: float, digits: int = 2) -> str:
    """A fraction as a magnitude in per cent, ``digits`` significant digits.

    >>> percent(0.0905), percent(-0.229), percent(0.00442, 3)
    ('9 %', '23 %', '0.442 %')
    """
    return f"{100 * abs(float(fraction)):.{int(digits)}g} %"


def change(pct: float) -> str:
    """A signed change given in per cent: "+12.5 %", or "a factor 3.2" once it exceeds 100 %.

    >>> change(12.54), change(-3.0), change(220.0)
    ('+12.5 %', '-3 %', 'a factor 3.2')
    """
    pct = float(pct)
    return f"{pct:+.3g} %" if abs(pct) < 100 else f"a factor {1 + pct / 100:.3g}"


def significant(x: float, digits: int = 2) -> str:
    """``x`` to ``digits`` significant digits, without an exponent.

    >>> significant(0.0123456), significant(12345.6), significant(1.5, 3)
    ('0.012', '12000', '1.5')
    """
    return f"{float(f'{float(x):.{int(digits)}g}'):g}" if abs(float(x)) < 1e16 else f"{float(x):.{int(digits)}g}"


def sci(x: float, digits: int = 1) -> str:
    r"""``x`` for a sentence: plain between 0.01 and 10^4, else LaTeX scientific notation.

    >>> sci(0.5), sci(1.2e-5, 2), sci(3e6)
    ('0.5', '$1.2\\times10^{-5}$', '$3\\times10^{6}$')
    """
    x = float(x)
    if 1e-2 <= abs(x) < 1e4:
        return f"{x:.{int(digits)}g}"
    mantissa, exponent = f"{x:.{int(digits) - 1}e}".split("e")
    return f"${mantissa}\\times10^{{{int(exponent)}}}$"


def length_text(value_um: float) -> str:
    """A length as words with its unit: micrometres below a millimetre, else millimetres.

    >>> length_text(36.25), length_text(2450.0)
    ('36.2 µm', '2.45 mm')

    Parameters
    ----------
    value_um : float
        The length (µm).
    """
    um = float(value_um)
    return f"{um:.3g} µm" if abs(um) < 1e3 else f"{um / 1e3:.3g} mm"


def ordinal(k: int) -> str:
    """'first', 'second', 'third', then '4th', '5th', ...

    >>> ordinal(2), ordinal(5)
    ('second', '5th')
    """
    k = int(k)
    return {1: "first", 2: "second", 3: "third"}.get(k, f"{k}th")


def how_many(ok: Any, noun: str = "angle") -> str:
    """Where a condition holds among cases: "at every angle", "at no angle" or "at 3 of 24 angles".

    >>> how_many([True, True]), how_many([False]), how_many([True, False, False], "speed")
    ('at every angle', 'at no angle', 'at 1 of 3 speeds')
    """
    import numpy as np

    ok = np.asarray(ok, bool)
    if ok.all():
        return f"at every {noun}"
    if not ok.any():
        return f"at no {noun}"
    return f"at {int(ok.sum())} of {ok.size} {noun}s"


#: The MIME-type prefix of a glued value that is not displayed, under which myst-nb's
#: ``{glue:text}`` roles find it in the stored outputs (its papermill-compatible format).
GLUE_PREFIX = "application/papermill.record/"


def glue(name: str, value: Any, display: bool = True) -> None:
    """Store ``value``'s display in the cell's outputs under ``name``, for ``{glue:text}`name```
    in the text (the solutions of the exercises paste their computed numbers so).

    The output is myst-nb's glue: the formats IPython would display, with the metadata
    ``{"scrapbook": {"name": name, "mime_prefix": ...}}``, each format under
    :data:`GLUE_PREFIX` when ``display`` is False (stored, not shown).
    """
    # Not myst_nb.glue itself: importing it into a chapter's kernel imports nbformat, whose
    # jsonschema imports rfc3987_syntax, which builds a grammar at import (python-jsonschema
    # issue #1428): 1.1 s of every run of a chapter, 2 x 16 runs in make test and 133
    # more in CI's reruns.  tests/test_reporting.py checks the messages against myst-nb's.
    from IPython.core.formatters import format_display_data
    from IPython.display import display as show

    formats, metadata = format_display_data(value)
    prefix = "" if display else GLUE_PREFIX
    metadata["scrapbook"] = {"name": name, "mime_prefix": prefix}
    show({prefix + mime: data for mime, data in formats.items()}, raw=True, metadata=metadata)


def table(df: pd.DataFrame, digits: int | dict[str, int] = 4, caption: str | None = None,
          name: str | None = None) -> Any:
    """A table for the book: no index column, numbers rounded as ``digits`` says.

    ``table(df, caption=..., name="tab-07-offsets")`` as the last line of a cell is a numbered
    table ("Table 7.1" in the HTML and the PDF alike) that ``{numref}`` can point to: a MyST
    ``{table}`` directive the book renders as Markdown (``nb_render_markdown_format: myst``).
    Without ``name`` it is a pandas ``Styler`` (for pages that are not chapters).  Name the rows
    in a column, with the unit in every numeric header, e.g. ``"L2 p-p (um)"``.  The output is
    the same on every run, so a strictly compared notebook reproduces it.

    Parameters
    ----------
    df
        The table.  A non-default index is kept as the first column(s).
    digits
        Significant digits of floating-point numbers (1 to 15; integers are shown whole), or a
        mapping from column name to decimal places (columns not named: 4 significant digits).
        A mapping needs ``name``.
    caption
        The caption: what is tabulated, for which parameters.  Required with ``name``.
    name
        The table's label for ``{numref}``: ``tab-`` then the chapter's two digits, a dash and
        a word (``tab-07-offsets``).

    Returns
    -------
    IPython.display.Markdown (with ``name``) or pandas.io.formats.style.Styler

    Raises
    ------
    ReportError
        If ``digits`` is not an integer from 1 to 15 (or a mapping of column names to
        integers from 0 to 15), if ``name`` is not of the form ``tab-NN-word``, if
        ``name`` is given without a caption, or if such a caption holds a backtick or a line
        break (they would end the directive's fence: put roles in the text instead).
    """
    import hashlib
    import re

    def _places(v, lo):
        return not isinstance(v, bool) and isinstance(v, int) and lo <= v <= 15

    if isinstance(digits, dict):
        bad = {k: v for k, v in digits.items() if k not in df.columns or not _places(v, 0)}
        if bad or name is None:
            raise ReportError(f"digits = {digits!r} is not allowed: a mapping needs name= and maps "
                              f"the table's columns {list(map(str, df.columns))} to integers from 0 to 15"
                              + (f" ({bad!r} do not)" if bad else ""))
    elif not _places(digits, 1):
        raise ReportError(f"digits = {digits!r} is not allowed: give an integer from 1 to 15")
    default_index = df.index.equals(pd.RangeIndex(len(df))) and all(n is None for n in df.index.names)
    if not default_index:
        df = df.reset_index()
    if name is not None:
        if not isinstance(name, str) or not re.fullmatch(r"tab-\d\d-[a-z0-9][a-z0-9-]*", name):
            raise ReportError(f"name = {name!r} is not allowed: give tab-NN-word, NN the chapter's "
                              "two digits (e.g. 'tab-07-offsets')")
        if not caption or not str(caption).strip():
            raise ReportError(f"caption = {caption!r} is not allowed: a numbered table needs a caption "
                              "that says what is tabulated")
        if "`" in str(caption) or "\n" in str(caption):
            raise ReportError(f"caption = {caption!r} is not allowed: a backtick or a line break ends the "
                              "table's fence; write roles such as {numref} in the text around the table")
        return _myst_table(df, digits, str(caption), name)
    floats = [c for c in df.columns if pd.api.types.is_float_dtype(df[c])]
    styler = df.style.hide(axis="index").format({c: f"{{:.{digits}g}}" for c in floats}, na_rep="–")
    if caption:
        styler = styler.set_caption(caption)
    digest = hashlib.sha1(pd.util.hash_pandas_object(df, index=False).values.tobytes()
                          + repr(list(df.columns)).encode()).hexdigest()[:10]
    return styler.set_uuid(f"fivebar{digest}")


def _myst_table(df: pd.DataFrame, digits: int | dict[str, int], caption: str, name: str) -> Any:
    """The numbered MyST table of :func:`table` (a ``{table}`` directive around a pipe table)."""
    import re

    from IPython.display import Markdown

    def cell(col, v) -> str:
        if hasattr(v, "item") and not isinstance(v, str):
            v = v.item()  # a numpy scalar as the Python number
        if v is None or (isinstance(v, float) and not math.isfinite(v)):
            return "–"
        if isinstance(v, float):
            if isinstance(digits, dict):
                text = f"{v:.{digits[col]}f}" if col in digits else f"{v:.4g}"
            else:
                text = f"{v:.{digits}g}"
            # a value that rounds to zero prints as 0, whatever the sign its round-off took
            return text[1:] if re.fullmatch(r"-0(\.0*)?", text) else text
        return str(v).replace("|", "\\|").replace("\n", " ")

    head = [str(c).replace("|", "\\|") for c in df.columns]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(cell(c, v) for c, v in zip(df.columns, row)) + " |"
              for row in df.itertuples(index=False)]
    return Markdown(f"```{{table}} {caption}\n:name: {name}\n\n" + "\n".join(lines) + "\n```")
