"""What a chapter needs to be rerun with a reader's parameters: its parameter set and its checks.

Every chapter of the book starts with one *parameters cell* (tagged ``parameters``, the
convention of papermill), which names the parameter files layered over the book's own and the
few knobs the chapter turns::

    PARAMS_FILES = []          # your TOML files over the book's, e.g. ["mine.toml"]

    params = fivebar.book.chapter.load(PARAMS_FILES)

Everything below is computed from ``params``.  A chapter checks two kinds of statements:

* :func:`physics_check`: true for any sensible parameters (two methods agree, a mesh
  converges, an energy balances).  A failure raises :class:`CheckFailed` whose message names
  the quantity, its value, the bound and what the check means, so a rerun that breaks one
  says which quantity moved.
* :func:`book_value_check`: the book's parameters reproduce a stored number (the paper's
  table, a value quoted in the text).  It is checked only when the parameters are the book's;
  otherwise it prints, visibly, that it was skipped and which entries differ.

A study of a chapter that does not apply to the reader's linkage (no fold in the range, an
entry a four-bar does not have, a speed with no periodic orbit) is said at the top of the chapter,
in a note (:class:`Applicability`) that the chapter fills in where it finds out, and the rest of
the chapter runs.  A chapter of another linkage than the book's five-bar (the four-bar) takes
from the reader's files only the entries that its linkage uses (:func:`load_other_linkage`) and
names the others.

No equation of the paper is implemented here.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FivebarError, InputError, number
from ..description.params import DEFAULT_PARAMS_PATH, Params, file_entries, load_params, unused_entry

__all__ = ["Applicability", "CheckFailed", "admonition", "book_value_check", "differences", "is_book_params", "load",
           "load_other_linkage", "physics_check", "warnings_shown"]


class CheckFailed(FivebarError, RuntimeError):
    """A chapter's check failed: the message names the quantity, its value, the bound and what
    the check means."""


Files = str | Path | Iterable[str | Path]


def _paths(name: str, files: Files) -> list[Path]:
    if isinstance(files, str) and files.strip().startswith("["):
        # papermill's -p passes a list as its text: '["mine.toml"]' is not a file name
        raise InputError(f"{name} = {files!r} is not allowed: it is a list written as a string (papermill's -p "
                         "passes text); give a list, e.g. papermill ... -y 'PARAMS_FILES: [mine.toml]'")
    if isinstance(files, (str, Path)):
        files = [files]
    try:
        return [Path(f) for f in files]
    except TypeError:
        raise InputError(f"{name} = {files!r} is not allowed: give a TOML file or a list of them") from None


def load(files: Files = (), base: Files = DEFAULT_PARAMS_PATH, overrides: dict[str, Any] | None = None) -> Params:
    """The chapter's parameters: ``files`` (the reader's, entry by entry) layered over ``base``
    (the book's file or files: ``[fivebar.DEFAULT_PARAMS_PATH, fivebar.FOURBAR_PARAMS_PATH]``
    for the four-bar chapter).

    ``files`` is one path or a sequence of them (empty: the book's parameters unchanged);
    relative paths are read from the working directory of the notebook's kernel.
    """
    return load_params([*_paths("base", base), *_paths("files", files)], overrides=overrides)


def load_other_linkage(files: Files = (), base: Files = DEFAULT_PARAMS_PATH) -> tuple[Params, dict[str, str]]:
    """The parameters of a chapter whose linkage is not the book's five-bar, and the entries of
    the reader's files it leaves out: ``params, ignored = load_other_linkage(PARAMS_FILES,
    base=[fivebar.DEFAULT_PARAMS_PATH, fivebar.FOURBAR_PARAMS_PATH])``.

    A reader's file is written for the book (its five-bar): every entry is checked as the book
    reads it (over ``wang2011.toml`` alone: a misspelt name is refused there, with the nearest
    known name), and the entries that ``base``'s linkage does not use
    (:func:`fivebar.description.params.unused_entry`: the five-bar's L2 or speed ratio, a motor's
    data for a linkage without motors, a ``[linkage]`` of another number of joints) are left out
    and returned, key -> why, for the chapter to name (:meth:`Applicability.ignored`); the others
    are layered over ``base``.  With no files: ``base``'s parameters and ``{}``.
    """
    base_paths, file_paths = _paths("base", base), _paths("files", files)
    own = load_params(base_paths)
    if not file_paths:
        return own, {}
    book = load_params([DEFAULT_PARAMS_PATH, *file_paths])  # the reader's files as every other chapter reads them
    entries: dict[str, Any] = {}
    for path in file_paths:
        entries.update(file_entries(path))
    ignored: dict[str, str] = {}
    used: dict[str, Any] = {}
    for key, value in entries.items():
        if key == "linkage":
            joints = len(value.get("chain", ())) if isinstance(value, dict) else 0
            if joints != len(own.linkage.chain):
                ignored[key] = (f"it describes a linkage of {joints} joints, not this chapter's {own.linkage.name!r} "
                                f"of {len(own.linkage.chain)}")
                continue
            used[key] = value
            continue
        why = unused_entry(own, key, book)
        if why:
            ignored[key] = why
        else:
            used[key] = value
    return (own.replace(**used) if used else own), ignored


class Applicability:
    """The note, at the top of a chapter, of its studies that do not apply to the reader's linkage.

    ``applies = fivebar.book.chapter.Applicability()`` as the last line of a cell near the top
    shows the note, empty while every study applies (as with the book's parameters: nothing is
    shown); where the chapter finds that one does not, ``applies.add(study, why, change)`` adds
    it, and ``applies.ignored(entries)`` names entries of the reader's files that the chapter's
    linkage does not use.  The note is one display updated in place (IPython's
    ``update_display``; papermill and the book's build keep the update), so it stays at the top
    wherever the chapter finds out.  ``study in applies`` says whether a study was reported.
    """

    #: the first line of a note with items (fivebar_rerun.py reads it to draw the rerun matrix)
    TITLE = ":::{admonition} With your parameters, not all of this chapter applies"

    def __init__(self) -> None:
        import uuid

        self.items: list[tuple[str, str, str]] = []
        self._id = f"fivebar-applicability-{uuid.uuid4().hex}"
        self._shown = False

    def __contains__(self, study: object) -> bool:
        return any(study == s for s, _, _ in self.items)

    #: the note while every study applies: an HTML comment, which every reader of the output
    #: (Jupyter, the HTML book, the PDF) leaves out.  Not "": myst-nb passes over an empty
    #: Markdown output to its plain-text repr, which the page would show.
    EMPTY = "<!-- every study of this chapter applies with these parameters -->\n"

    def markdown(self) -> str:
        """The note as MyST Markdown (:attr:`EMPTY` when every study applies)."""
        if not self.items:
            return self.EMPTY
        lines = [self.TITLE, ":class: note", ""]
        lines += [f"* **{study}** {why}" + (f"  {change}" if change else "") for study, why, change in self.items]
        return "\n".join(lines + [":::"]) + "\n"

    def _ipython_display_(self) -> None:
        from IPython.display import Markdown, display

        display(Markdown(self.markdown()), display_id=self._id)
        self._shown = True

    def _update(self) -> None:
        if self._shown:
            from IPython.display import Markdown, update_display

            update_display(Markdown(self.markdown()), display_id=self._id)

    def add(self, study: str, why: str, change: str = "") -> None:
        """Report that ``study`` (a few words naming it, e.g. "The hysteresis loop") does not apply:
        ``why`` in the book's words, starting with a verb ("does not apply: the branch has no
        fold in the range followed."), and ``change``, what the reader can change to see it."""
        for name, value in (("study", study), ("why", why), ("change", change)):
            if not isinstance(value, str):
                raise InputError(f"{name} = {value!r} is not allowed: give a sentence (str)")
        if study not in self:
            self.items.append((study, why, change))
            self._update()

    def ignored(self, entries: dict[str, str], linkage: str = "this chapter's linkage") -> None:
        """Name the entries of the reader's files that the chapter leaves out (key -> why, as
        :func:`load_other_linkage` returns them)."""
        if entries:
            listed = "; ".join(f"`{k}` ({why})" for k, why in entries.items())
            self.add("Entries of your files", f"are not used by {linkage} and are left out here: {listed}.",
                     "The other chapters use them.")


def differences(params: Params, reference: Params | Files | None = None) -> dict[str, tuple[Any, Any]]:
    """The entries in which ``params`` differ from ``reference`` (default: the book's
    ``wang2011.toml``; a path or a list of paths loads those files in layers, as :func:`load`'s
    ``base``): dotted key -> (reference's value, params' value)."""
    if reference is None:
        reference = load_params()
    elif not isinstance(reference, Params):
        reference = load_params(_paths("reference", reference))
    a, b = dict(reference.values), dict(params.values)
    out = {}
    for key in sorted(set(a) | set(b)):
        if a.get(key, None) != b.get(key, None):
            out[key] = (a.get(key), b.get(key))
    return out


def is_book_params(params: Params, reference: Params | Files | None = None) -> bool:
    """Whether ``params`` are the book's (no entry differs from ``reference``)."""
    return not differences(params, reference)


def _fmt(x: Any) -> str:
    if isinstance(x, (float, np.floating)):
        return f"{float(x):.6g}"
    if isinstance(x, np.ndarray):
        return np.array2string(x, precision=6)
    return str(x)


def physics_check(ok: Any, quantity: str, value: Any, bound: str, meaning: str) -> None:
    """Check a statement that holds for any sensible parameters.

    ``ok`` is the outcome (a bool or a NumPy bool); ``quantity`` names what was measured,
    ``value`` its value, ``bound`` the bound in words (``"< 1e-6"``, ``"within 1 % of
    S = 3200"``) and ``meaning`` what the check establishes and what a failure means.

    >>> physics_check(abs(2.0 - 2.0) < 1e-9, "energy change", 0.0, "< 1e-9", "energy is conserved")

    Raises
    ------
    CheckFailed
        When ``ok`` is false: "physics check failed: <quantity> = <value>, expected <bound>:
        <meaning>".
    """
    if not isinstance(quantity, str) or not quantity:
        raise InputError(f"quantity = {quantity!r} is not allowed: name the quantity checked")
    if not bool(np.all(ok)):
        raise CheckFailed(f"physics check failed: {quantity} = {_fmt(value)}, expected {bound}: {meaning}")


def book_value_check(params: Params, quantity: str, value: Any, stored: Any, rtol: float = 1e-6,
                     atol: float = 0.0, reference: Params | Files | None = None) -> bool:
    """Check that the book's parameters reproduce a stored number; skip, visibly, otherwise.

    With the book's parameters (``params`` equal to ``reference``, by default ``wang2011.toml``)
    ``value`` must be within ``rtol`` (relative) or ``atol`` (absolute) of ``stored``, and the
    function returns True.  With other parameters it prints one line saying that the check of
    ``quantity`` was skipped and which entries differ, and returns False.

    Raises
    ------
    CheckFailed
        With the book's parameters and a value away from the stored one.
    """
    rtol, atol = number("rtol", rtol, low=0), number("atol", atol, low=0)
    diff = differences(params, reference)
    if diff:
        keys = ", ".join(diff) if len(diff) <= 4 else ", ".join(list(diff)[:4]) + f" and {len(diff) - 4} more"
        print(f"Book value not checked (these are not the book's parameters: {keys} differ): "
              f"{quantity} = {_fmt(value)}; the book's parameters give {_fmt(stored)}.")
        return False
    v, s = np.asarray(value, dtype=float), np.asarray(stored, dtype=float)
    if v.shape != s.shape and v.size != 1 and s.size != 1:
        raise InputError(f"value and stored have shapes {v.shape} and {s.shape}: give numbers or arrays "
                         "of one shape")
    if not np.allclose(v, s, rtol=rtol, atol=atol, equal_nan=False):
        raise CheckFailed(f"book value check failed: {quantity} = {_fmt(value)}, the book's parameters "
                          f"must give {_fmt(stored)} (rtol {rtol:g}, atol {atol:g})")
    return True


#: The admonition a warning of each category becomes on the page, and its title.
_ADMONITIONS = {"ValidityWarning": ("warning", "Outside the model's validity"),
                "UnstableParametersWarning": ("warning", "Outside the scheme's stable region")}


def admonition(text: str, kind: str = "warning", title: str | None = None) -> Any:
    """A MyST admonition of ``kind`` (``warning``, ``note``, ``important``) with ``title`` and
    ``text``, as an ``IPython.display.Markdown`` object: shown on the page as the book's own box,
    in the HTML book and in the PDF.

    >>> admonition("116 of 120 rows are above the yield stress.", title="Outside").data.splitlines()[0]
    '```{warning} Outside'
    """
    from IPython.display import Markdown

    if kind not in ("warning", "note", "important", "caution", "attention", "tip"):
        raise InputError(f"kind = {kind!r} is not allowed: use warning, note, important, caution, attention or tip")
    fence = "`" * max(3, 1 + max((len(r) for r in text.split("\n") if set(r) == {"`"}), default=0))
    head = f"{fence}{{{kind}}}" + (f" {title}" if title else "")
    return Markdown(f"{head}\n{text}\n{fence}")


@contextlib.contextmanager
def warnings_shown(*categories: type[Warning]) -> Iterator[list]:
    """Show the warnings a block of a chapter gives as the book's admonitions, not as stderr.

    ::

        with fivebar.book.chapter.warnings_shown():
            sweep = speed_sweep(setup, speeds)

    The warnings of ``categories`` (default: every warning) raised inside the block are caught;
    at its end each different message is displayed once, as an admonition whose title names
    what it means (a :class:`~fivebar.errors.ValidityWarning`: "Outside the model's validity"),
    with its numbers and without the file, line and source of the code that raised it (which
    would name the machine's temporary files).  Warnings of other categories pass through.
    Yields the list of caught warnings.
    """
    from IPython.display import display

    cats = tuple(categories) or (Warning,)
    caught: list = []
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        yield caught
    seen: list[str] = []
    for w in rec:
        if not issubclass(w.category, cats):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            continue
        caught.append(w)
        msg = str(w.message)
        if msg in seen:
            continue
        seen.append(msg)
        kind, title = _ADMONITIONS.get(w.category.__name__, ("warning", w.category.__name__))
        display(admonition(msg, kind, title))
