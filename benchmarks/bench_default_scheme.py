"""The default scheme against the S = 1600 reference, and the time of steady_state(params).

Prints JSON: for 60, 300 and 600 r/min the default set-up's (fivebar.Setup(params)) largest
Floquet multiplier and the relative peak-to-peak error of the transverse midpoint deflection
of L2 and L3 against S = 1600 (the paper's average-acceleration rule, stable at that step: an
independent scheme), and the median wall time of ``steady_state(params)`` over ``--repeat``
runs.  ``--timing-only`` skips the accuracy table (e.g. to time another checkout's library:
``PYTHONPATH=<other>/lib python benchmarks/bench_default_scheme.py --timing-only``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

import fivebar
from fivebar.description.setup import Setup


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--timing-only", action="store_true")
    args = ap.parse_args()
    p = fivebar.load_params()
    out: dict = {"library": fivebar.__file__}
    times = []
    for _ in range(args.repeat):
        t = time.perf_counter()
        res = fivebar.steady_state(p)
        times.append(time.perf_counter() - t)
    out["steady_state(params)"] = {
        "median_s": statistics.median(times), "runs": times, "S": int(res.dynamics.steps_per_period),
        "stable": res.stable, "max_multiplier": float(np.abs(res.floquet_multipliers).max()),
    }
    if not args.timing_only:
        from fivebar import PAPER_SCHEME, Setup

        rows = {}
        for rpm in (60.0, 300.0, 600.0):
            s = Setup(p, crank_speed_rpm=rpm)
            res = fivebar.steady_state(s)
            ref = fivebar.steady_state(Setup(s, steps_per_period=1600, scheme=PAPER_SCHEME))
            rows[f"{rpm:g} r/min"] = {
                "scheme": repr(s.scheme), "S": s.steps_per_period,
                "max_multiplier": float(np.abs(res.floquet_multipliers).max()),
                **{f"{k} p2p error": res.peak_to_peak_mm(k) / ref.peak_to_peak_mm(k) - 1.0 for k in ("L2", "L3")},
            }
        out["accuracy"] = rows
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
