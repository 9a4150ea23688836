"""pytest configuration for nbval over the notebooks of book/ (``make test-notebooks``).

The longest notebooks first: with ``-n 2 --dist loadscope --no-loadscope-reorder`` the two
workers take the notebooks in this order, each the next one as it finishes, so that no long
notebook is left to run alone at the end (xdist's own order, by number of cells, put the
longest chapter among the last).  A notebook's length is its execution time stored in its cells
(``metadata.execution``, written by ``jupyter execute``; ``fivebar_rerun.book_seconds``, which
orders a rerun matrix the same way); a notebook without them counts as long.  The cells of a
notebook keep their order.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "_ext"))
from fivebar_rerun import book_seconds  # noqa: E402  (the one reader of a notebook's stored time)


def pytest_collection_modifyitems(session, config, items):
    seconds: dict[Path, float] = {}

    def key(item) -> float:
        path = Path(str(item.path))
        if path.suffix != ".ipynb":
            return 0.0
        if path not in seconds:
            seconds[path] = book_seconds(path) or float("inf")  # (no stored times: counts as long)
        return -seconds[path]

    items.sort(key=key)  # stable: the cells of a notebook stay in order
