"""One error contract over the public API: a table of bad inputs (tests/contract_cases.py).

Every bad input must raise a :class:`fivebar.FivebarError` whose message names the argument and
the value (clear); none may pass silently, hang (a per-case time limit, enforced by killing the
worker process) or raise anything else.  NumPy scalars and size-one arrays must be accepted
where a Python number is.  ``python tests/test_contract.py`` prints the counts and every case
that is not clear.
"""

from __future__ import annotations

import collections
import pytest
import json
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

WORKER = Path(__file__).with_name("contract_cases.py")
#: seconds a case may take (the slowest good cases solve one small steady state; the worker's
#: first case also pays the import and, in a fresh checkout, the compilation)
CASE_SECONDS, FIRST_SECONDS = 60.0, 600.0


def run_table(worker: Path = WORKER) -> list[dict]:
    """Every case of ``worker`` (a table of the protocol of tests/contract_cases.py), each a
    JSON record with its ``outcome``."""
    n = int(subprocess.run([sys.executable, str(worker), "-1"], capture_output=True, text=True,
                           check=True).stdout.split()[-1])
    results: list[dict] = []
    start = 0
    while start < n:
        proc = subprocess.Popen([sys.executable, str(worker), str(start)], stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True, start_new_session=True)
        limit = FIRST_SECONDS
        deadline = time.monotonic() + limit
        hung = False
        while start < n:
            ready, _, _ = select.select([proc.stdout], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                hung = True
                break
            line = proc.stdout.readline()
            if not line:
                break
            rec = json.loads(line)
            results.append(rec)
            start = rec["i"] + 1
            deadline = time.monotonic() + CASE_SECONDS
        if not hung:
            try:
                proc.wait(timeout=60)  # let it exit (and remove its temporary directory)
            except subprocess.TimeoutExpired:
                hung = True
        if hung:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        if start < n and (hung or not results or results[-1]["i"] < start):
            results.append({"i": start, "label": f"case {start}", "kind": "?", "outcome": "hang" if hung else "crash",
                            "type": None, "message": None})
            start += 1
    return results


def counts(results: list[dict]) -> dict[str, int]:
    c = collections.Counter(r["outcome"] for r in results)
    return {"tried": len(results), **{k: c.get(k, 0) for k in
            ("clear", "unclear", "escaped", "silent", "hang", "crash", "accepted", "refused")}}


@pytest.mark.slow
def test_every_bad_input_gets_a_clear_error_and_numpy_numbers_are_accepted():
    results = run_table()
    wrong = [r for r in results if r["outcome"] not in ("clear", "accepted")]
    assert not wrong, f"{counts(results)}\n" + "\n".join(
        f"{r['outcome']:9s} {r['label']}: {r['type']}: {r['message']}" for r in wrong)


if __name__ == "__main__":
    res = run_table()
    print(json.dumps(counts(res)))
    for r in res:
        if r["outcome"] not in ("clear", "accepted"):
            print(f"{r['outcome']:9s} {r['label']}: {r['type']}: {(r['message'] or '')[:200]} {r.get('missing', '')}")
