"""The time of each analysis on the flexible slider-crank (issue 34), and on the Watt six-bar.

Prints one JSON object (and writes it with ``--out``): for each analysis the wall and CPU time of
its first call in the process (the library's store emptied first; the compiled kernels loaded
from their disk cache) and the median of ``--repeat`` further calls with the store emptied
before each, with the figure the analysis gives (so a reader sees what was computed).  One BLAS
thread.  The machine's load average is recorded: on a shared machine the wall times are upper
bounds, the CPU times the better guide.

Usage: python benchmarks/bench_slider_crank.py [--repeat 3] [--out benchmarks/results/slider_crank.json]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

import fivebar  # noqa: E402
from fivebar.analyses import multibody  # noqa: E402
from fivebar.analyses.branches import follow  # noqa: E402
from fivebar.analyses.modal import frequencies_along_cycle  # noqa: E402


def _timed(fn):
    fivebar.clear_cache()
    w0, c0 = time.perf_counter(), time.process_time()
    value = fn()
    return time.perf_counter() - w0, time.process_time() - c0, value


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out")
    args = ap.parse_args()
    warnings.simplefilter("ignore", fivebar.ValidityWarning)

    sc = fivebar.load_params([fivebar.DEFAULT_PARAMS_PATH, fivebar.SLIDER_CRANK_PARAMS_PATH])
    six = fivebar.load_params([fivebar.DEFAULT_PARAMS_PATH, fivebar.SIXBAR_PARAMS_PATH])
    rpm = sc.crank_speed_rpm  # the benchmark's 150 rad/s
    s = fivebar.Setup(sc)
    mid = lambda r: round(float(r.peak_to_peak_mm("rod")), 4)  # noqa: E731 - the rod's midpoint p-p (mm)
    cases = {
        "natural_frequencies (4 modes, crank angle 0)":
            lambda: [round(float(f), 2) for f in fivebar.natural_frequencies(sc, 0.0, n_modes=4)],
        "frequencies_along_cycle (73 angles, 4 modes)":
            lambda: round(float(frequencies_along_cycle(sc, np.linspace(0, 2 * np.pi, 73), n_modes=4)[:, 0].min()), 2),
        "steady_state, shooting at the file's S": lambda: mid(fivebar.steady_state(s)),
        "steady_state, shooting, tol=0.01": lambda: mid(fivebar.steady_state(s, tol=0.01)),
        "steady_state, march at the file's S": lambda: mid(fivebar.steady_state(s, method="march")),
        "steady_state, harmonic balance, tol=1e-3": lambda: mid(fivebar.steady_state(s, method="harmonic_balance", tol=1e-3)),
        "transient, 0.1 s from rest": lambda: round(float(np.abs(fivebar.transient(s, math.ceil(0.1 / sc.period)).midpoint_mm("rod")).max()), 4),
        "speed_sweep, 10 speeds 50-500 rad/s": lambda: len(fivebar.speed_sweep(
            s, [w * 60 / (2 * math.pi) for w in np.linspace(50, 500, 10)], links=["rod"], progress=False, cache=False)),
        "follow (continuation), 150 to 200 rad/s": lambda: len(follow(s, rpm * 200 / 150, points=60).p),
        "multiple_scales (2 modes)": lambda: mid(fivebar.multiple_scales(s)),
        "multibody_steady_state (Exudyn, 8 elements, S = 400)": lambda: round(float(np.ptp(multibody.multibody_steady_state(
            fivebar.Setup(sc.replace(damping_model="stiffness"), steps_per_period=100, elements_per_link=(0, 8)),
            integration_steps=400).midpoint_mm("rod"))), 4),
        "six-bar: steady_state at 300 r/min": lambda: round(float(max(fivebar.steady_state(
            fivebar.Setup(six, crank_speed_rpm=300.0)).peak_to_peak_mm(k) for k in ("coupler", "link5"))), 5),
    }
    load0 = os.getloadavg()
    out = {"linkage": sc.linkage.name, "crank_speed_rpm": rpm, "repeat": args.repeat, "analyses": {}}
    for name, fn in cases.items():
        try:
            w, c, value = _timed(fn)
            runs = [_timed(fn)[:2] for _ in range(args.repeat)]
            out["analyses"][name] = {"first_wall_s": round(w, 4), "first_cpu_s": round(c, 4),
                                     "median_wall_s": round(statistics.median(r[0] for r in runs), 4),
                                     "median_cpu_s": round(statistics.median(r[1] for r in runs), 4), "value": value}
        except fivebar.FivebarError as exc:
            out["analyses"][name] = {"error": f"{type(exc).__name__}: {exc}"[:300]}
        print(name, out["analyses"][name], flush=True)
    out["load"] = {"start": list(load0), "end": list(os.getloadavg())}
    out["machine"] = {"python": platform.python_version(), "cpu_count": os.cpu_count()}
    text = json.dumps(out, indent=1)
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
