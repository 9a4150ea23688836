"""Issue 36, the bad-input list (tests/edge_cases.py): every case answered.

A wrong input raises a :class:`fivebar.FivebarError` that names the argument and its value
(clear); a legal input whose result is outside the model's validity gives a
:class:`fivebar.ValidityWarning` that says so; a valid input (a false refusal before, a NumPy
number or 0-d array) is accepted.  None passes silently, hangs or raises another exception.
``python tests/test_edges.py`` prints the counts and every case that is not clear.
"""

from __future__ import annotations

import json
import pytest
from pathlib import Path

from test_contract import counts, run_table

WORKER = Path(__file__).with_name("edge_cases.py")


@pytest.mark.slow
def test_every_case_of_the_list_is_answered():
    results = run_table(WORKER)
    wrong = [r for r in results if r["outcome"] not in ("clear", "accepted")]
    assert not wrong, f"{counts(results)}\n" + "\n".join(
        f"{r['outcome']:9s} {r['label']}: {r['type']}: {r['message']}" for r in wrong)


if __name__ == "__main__":
    res = run_table(WORKER)
    print(json.dumps(counts(res)))
    for r in res:
        if r["outcome"] not in ("clear", "accepted"):
            print(f"{r['outcome']:9s} {r['label']}: {r['type']}: {(r['message'] or '')[:240]} {r.get('missing', '')}")
