"""Time the stages of a fresh ``make test`` and print them as JSON.

Run from the root of a *fresh clone* (the point is the cold cost)::

    git clone -q . /tmp/tc && cd /tmp/tc && python3 benchmarks/bench_build.py > stages.json

Stages, in the order ``make test`` runs them: the virtual environment, nbval over every
notebook (strict: it executes every cell), the execution cache seeded from the stored outputs,
the instructor PDF (Sphinx LaTeX build and XeLaTeX), the HTML book, the student edition (its
PDF and its HTML; in ``make test`` the edition tests make it), then the test session of
``tests/``; the two pytest sessions are split from pytest's JUnit report into unit tests, nbval
per notebook, the browser test and the edition/PDF tests.  ``--old-order`` times the order
before the cache was seeded (builds first, executing every notebook, then one pytest session
over ``tests`` and ``book``).  Each stage is timed by wall clock; on a shared machine the absolute
numbers are noisy, the shares are the useful part.  ``--tests-only`` skips the build stages
(they must have been run), ``--pytest-args`` passes extra arguments (e.g. ``-n 2``).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run(cmd: list[str], log: Path) -> float:
    t0 = time.perf_counter()
    with log.open("w") as fh:
        proc = subprocess.run(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT)
    dt = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed (exit {proc.returncode}); see {log}")
    return dt


def _split(junit: Path) -> dict[str, float]:
    """Seconds per group of test items (from pytest's JUnit XML)."""
    out: dict[str, float] = collections.defaultdict(float)
    for case in ET.parse(junit).iter("testcase"):
        t = float(case.get("time", 0))
        cls = case.get("classname", "")
        name = case.get("file") or cls
        if cls.startswith("book.") or ".ipynb" in name:
            key = "nbval " + cls.split(".")[1] if cls.startswith("book.") else "nbval " + name
        elif "test_browser" in cls:
            key = "browser test"
        elif "test_editions" in cls or "test_pdf" in cls:
            key = "edition and PDF tests"
        else:
            key = "unit tests"
        out[key] += t
    return dict(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tests-only", action="store_true")
    parser.add_argument("--pytest-args", default="")
    parser.add_argument("--old-order", action="store_true")
    args = parser.parse_args(argv)
    logs = ROOT / "_build" / "bench"
    logs.mkdir(parents=True, exist_ok=True)
    stages: dict[str, float] = {}
    py = str(ROOT / ".venv" / "bin" / "python")
    t_all = time.perf_counter()
    nbval = ["--nbval", "--nbval-current-env", "--nbval-sanitize-with",
             "tests/nbval_sanitize.cfg"]
    junits = []

    def pytest(name: str, paths: list[str]) -> int:
        junit = Path(tempfile.mkdtemp()) / "junit.xml"
        junits.append(junit)
        cmd = [py, "-m", "pytest", "-p", "no:cacheprovider", *paths, "-q", "--durations=30",
               f"--junitxml={junit}", *shlex.split(args.pytest_args)]
        t0 = time.perf_counter()
        with (logs / f"{name}.log").open("w") as fh:
            rc = subprocess.run(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT).returncode
        stages[f"{name} (wall)"] = time.perf_counter() - t0
        return rc

    rc = 0
    if not args.tests_only:
        stages["venv"] = _run(["make", "venv"], logs / "venv.log")
        if not args.old_order:
            rc |= pytest("pytest nbval", ["book", *nbval])
            stages["seed cache"] = _run([py, "book/_ext/fivebar_build.py", "seed-cache"],
                                        logs / "seed.log")
        stages["PDF instructor"] = _run(["make", "pdf"], logs / "pdf.log")
        stages["HTML book"] = _run(["make", "book"], logs / "book.log")
        stages["PDF student"] = _run(["make", "pdf", "EDITION=student"], logs / "pdf-student.log")
        stages["student HTML"] = _run([py, "book/_ext/fivebar_build.py", "student"],
                                      logs / "student.log")
    if args.old_order:
        rc |= pytest("pytest tests+nbval", ["tests", "book", *nbval])
    else:
        rc |= pytest("pytest tests", ["tests"])
    total = time.perf_counter() - t_all
    split: dict[str, float] = collections.defaultdict(float)
    for junit in junits:
        if junit.is_file():
            for k, v in _split(junit).items():
                split[k] += v
    print(json.dumps({"stages_s": {k: round(v, 1) for k, v in stages.items()},
                      "test_session_split_s (summed item times)":
                          {k: round(v, 1) for k, v in sorted(split.items())},
                      "total_s": round(total, 1), "pytest_exit": rc,
                      "cpus": os.cpu_count(), "logs": str(logs)}, indent=1))
    return rc


if __name__ == "__main__":
    sys.exit(main())
