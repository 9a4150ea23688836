"""Cost of the teaching kit: the CSV downloads and the two animations (prints JSON).

    .venv/bin/python benchmarks/bench_teaching.py

Reports, per CSV of fivebar.book.datasets, the seconds to compute and write it and its size; per
animation, the seconds to compute and render it, its frame count and the size of its page.
These are the times a cold `make book` adds (the CSVs at builder-inited, the animations in the
chapters that call them); an unchanged rebuild adds nothing (hash cache, execution cache).
"""

from __future__ import annotations

import json
import os
import platform
import tempfile
import time

import matplotlib

matplotlib.use("Agg")

import fivebar  # noqa: E402
from fivebar.book import animation, datasets  # noqa: E402
from fivebar.description.setup import Setup  # noqa: E402


def main() -> dict:
    out: dict = {"python": platform.python_version(), "fivebar": fivebar.__version__,
                 "cpus": os.cpu_count(), "datasets": {}, "animations": {}}
    with tempfile.TemporaryDirectory() as d:
        cost = datasets.write_datasets(d, force=True)
        for name, sec in cost.items():
            size = os.path.getsize(os.path.join(d, f"{name}.csv"))
            out["datasets"][name] = {"seconds": round(sec, 2), "bytes": size}
        out["datasets_total_seconds"] = round(sum(cost.values()), 2)
    params = fivebar.load_params()
    t0 = time.perf_counter()
    steady = fivebar.steady_state(Setup(params, steps_per_period=400))
    t1 = time.perf_counter()
    anim = animation.animate_linkage(steady)
    t2 = time.perf_counter()
    out["animations"]["linkage"] = {"steady_state_seconds": round(t1 - t0, 2), "render_seconds": round(t2 - t1, 2),
                                    "frames": len(anim.frames), "bytes": anim.nbytes}
    t0 = time.perf_counter()
    anim = animation.animate_modes(params, n=3)
    out["animations"]["modes"] = {"render_seconds": round(time.perf_counter() - t0, 2),
                                  "frames": len(anim.frames), "bytes": anim.nbytes}
    return out


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
