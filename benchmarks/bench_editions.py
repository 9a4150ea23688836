"""Time what the editions and the PDF add to a build of the book.

Prints one JSON object:

  student_cold   ``fivebar_build.py student`` with no student build yet (its own Sphinx
                 environment is read from scratch; notebooks come from the execution cache of
                 ``make book``, which must have run), seconds
  student_warm   the same again with nothing changed, seconds
  pdf_cold       ``fivebar_build.py pdf --force`` with no ``_build/pdf`` (singlehtml read from
                 scratch, printing), seconds, with the build's own split (singlehtml, load,
                 MathJax, print)
  pdf_reprint    ``pdf --force`` again (singlehtml incremental: it rewrites the one page), s
  pdf_noop       ``make pdf`` with the PDF newer than every source (nothing done), seconds
  pdf            pages and bytes of ``_build/pdf/fivebar.pdf``

Each figure is one run (a cold build cannot be repeated without deleting it again); the
machine may be shared, so the load average at the start and the end is reported.

Usage: python benchmarks/bench_editions.py   (from the repository root, after `make book`)
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable
BUILD = ROOT / "_build"


def _run(args: list[str]) -> tuple[float, str]:
    t0 = time.perf_counter()
    run = subprocess.run(args, cwd=ROOT, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if run.returncode != 0:
        sys.exit(f"{' '.join(args)} failed:\n" + "\n".join((run.stdout + run.stderr).splitlines()[-30:]))
    return dt, run.stdout


def _split(out: str) -> dict:
    m = re.search(r"singlehtml (\d+) s, printing (\d+) s \(load (\d+) s, mathjax (\d+) s, "
                  r"print (\d+) s\)", out)
    keys = ("singlehtml", "printing", "load", "mathjax", "print")
    return dict(zip(keys, map(int, m.groups()))) if m else {}


def main() -> None:
    if not (BUILD / ".jupyter_cache").is_dir():
        sys.exit("run `make book` first: the editions reuse its execution cache")
    build = [PY, "book/_ext/fivebar_build.py"]
    result: dict = {"load_average_start": os.getloadavg()}
    shutil.rmtree(BUILD / "student", ignore_errors=True)
    result["student_cold"] = round(_run(build + ["student"])[0], 1)
    result["student_warm"] = round(_run(build + ["student"])[0], 1)
    shutil.rmtree(BUILD / "pdf", ignore_errors=True)
    dt, out = _run(build + ["pdf", "--force"])
    result["pdf_cold"] = {"seconds": round(dt, 1), **_split(out)}
    dt, out = _run(build + ["pdf", "--force"])
    result["pdf_reprint"] = {"seconds": round(dt, 1), **_split(out)}
    result["pdf_noop"] = round(_run(build + ["pdf"])[0], 2)
    from pypdf import PdfReader

    pdf = BUILD / "pdf" / "fivebar.pdf"
    result["pdf"] = {"pages": len(PdfReader(pdf).pages), "bytes": pdf.stat().st_size}
    result["load_average_end"] = os.getloadavg()
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
