"""pytest configuration for nbval over the notebooks of book/ (``make test-notebooks``).

The longest notebooks first: with ``-n 2 --dist loadscope --no-loadscope-reorder`` the two
workers take the notebooks in this order, each the next one as it finishes, so that no long
notebook is left to run alone at the end (xdist's own order, by number of cells, put the
longest chapter among the last).  A notebook's length is the sum of its cells' execution times
stored in the notebook (``metadata.execution``, written by ``jupyter execute``); a notebook
without them counts as long.  The cells of a notebook keep their order.
"""

from __future__ import annotations

import json
from datetime import datetime
from pathlib import Path


def stored_seconds(path: Path) -> float:
    """The execution time of a notebook as stored in its cells' metadata (inf if none)."""
    try:
        nb = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return float("inf")
    total, seen = 0.0, False
    for cell in nb.get("cells", []):
        t = cell.get("metadata", {}).get("execution", {})
        try:
            start = datetime.fromisoformat(t["iopub.execute_input"].replace("Z", "+00:00"))
            end = datetime.fromisoformat(t["shell.execute_reply"].replace("Z", "+00:00"))
        except (KeyError, TypeError, ValueError):
            continue
        total += max((end - start).total_seconds(), 0.0)
        seen = True
    return total if seen else float("inf")


def pytest_collection_modifyitems(session, config, items):
    seconds: dict[Path, float] = {}

    def key(item) -> float:
        path = Path(str(item.path))
        if path.suffix != ".ipynb":
            return 0.0
        if path not in seconds:
            seconds[path] = stored_seconds(path)
        return -seconds[path]

    items.sort(key=key)  # stable: the cells of a notebook stay in order
