"""Building the book's products for the tests that read them (the browser test reads the HTML,
the PDF test the PDF), shared by both (pytest puts tests/ on sys.path)."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: under CI a missing tool fails the test instead of skipping it
IN_CI = os.environ.get("CI", "").strip().lower() in {"true", "1", "yes"}


def unavailable(reason: str) -> None:
    """Fail under CI, skip elsewhere."""
    if IN_CI:
        pytest.fail(f"{reason} (required when CI=true)")
    pytest.skip(reason)


def make(target: str, product: Path) -> None:
    """Run ``make <target>`` in the project; fail with the end of its output unless it succeeds
    and leaves ``product``."""
    if shutil.which("make") is None:
        unavailable(f"`make {target}` is needed and `make` is not available")
    run = subprocess.run(["make", target], cwd=ROOT, capture_output=True, text=True)
    if run.returncode != 0 or not product.is_file():
        tail = "\n".join((run.stdout + run.stderr).splitlines()[-40:])
        pytest.fail(f"`make {target}` failed (exit {run.returncode}):\n{tail}")


def book_extension():
    """The book's local Sphinx extension (book/_ext/fivebar_book.py), imported afresh: a module
    of its own for each call, so that a test may change it."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("fivebar_book", ROOT / "book" / "_ext" / "fivebar_book.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
