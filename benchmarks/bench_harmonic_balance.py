"""Harmonic balance against shooting on the linkage (issue 31, point 4): accuracy, stability, time.

Prints one JSON object (and writes it with ``--out``).  For each case (speed, orientation; motors
off, nonlinear):

  hb              ``steady_state(setup, method="harmonic_balance", tol=1e-4)`` with the library's
                  store emptied first (a first call): the transverse midpoint p-p of L2 and L3 (mm),
                  the harmonics H and the N samples chosen, every H tried with its estimate,
                  the wall and CPU time of the solve (s), and Hill's stability (its verdict, largest
                  multiplier, harmonics, time).
  shooting        ``steady_state(setup, tol=1e-4)`` with the store emptied first: p-p, the S chosen,
                  wall and CPU time, the verdict and largest Floquet multiplier (of the scheme's
                  discrete map at that S).
  reference       shooting at 2 S (S the one chosen for 1e-4) and the Richardson extrapolation of
                  the p-p from S and 2 S (the schemes are second order): the continuous-time orbit's
                  p-p to about the square of the step error; also its largest multiplier at 2 S.
  difference_pct  HB against the shooting of ``shooting`` (converged S) and against the reference
                  (extrapolated), L2 and L3, percent.

The orientations: "default" (the parameter file), "flexible" (``params.replace(bending_depth=0.002,
damping_model="stiffness")``, as chapter 13 sets it up).  Single-threaded BLAS; the load average
is recorded (the machine may be shared: the times are then upper bounds, the CPU times the better
guide).

Usage: python benchmarks/bench_harmonic_balance.py [--quick] [--out benchmarks/results/harmonic_balance.json]
``--quick``: 300 r/min default and 60 r/min flexible only.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

import fivebar  # noqa: E402

CASES = [("default", 60.0), ("default", 300.0), ("default", 600.0),
         ("flexible", 30.0), ("flexible", 60.0), ("flexible", 90.0), ("flexible", 120.0)]
QUICK = [("default", 300.0), ("flexible", 60.0)]
TOL = 1e-4


def _params(orientation: str) -> fivebar.Params:
    p = fivebar.load_params()
    return p if orientation == "default" else p.replace(bending_depth=0.002, damping_model="stiffness")


def _timed(fn):
    fivebar.clear_cache()
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w, time.process_time() - c


def _pp(res) -> list[float]:
    return [res.peak_to_peak_mm("L2"), res.peak_to_peak_mm("L3")]


def case(orientation: str, rpm: float) -> dict:
    setup = fivebar.Setup(_params(orientation), crank_speed_rpm=rpm, motors=False, nonlinear=True)
    hb, hb_wall, hb_cpu = _timed(lambda: fivebar.steady_state(setup, method="harmonic_balance", tol=TOL))
    w, c = time.perf_counter(), time.process_time()
    hill = hb.hill()
    hill_wall, hill_cpu = time.perf_counter() - w, time.process_time() - c
    sh, sh_wall, sh_cpu = _timed(lambda: fivebar.steady_state(setup, tol=TOL))
    S = sh.accuracy["steps"]
    fine = fivebar.steady_state(setup.replace(steps_per_period=2 * S))
    pp_hb, pp_sh, pp_fine = np.array(_pp(hb)), np.array(_pp(sh)), np.array(_pp(fine))
    pp_ref = pp_fine + (pp_fine - pp_sh) / 3.0
    return {
        "orientation": orientation, "crank_speed_rpm": rpm,
        "hb": {"pp_mm": pp_hb.tolist(), "harmonics": hb.harmonics, "samples": hb.solution.samples,
               "tried": [[h, e] for h, e in hb.accuracy["tried"]], "estimate": hb.accuracy["estimate"],
               "newton_iterations": hb.solution.iterations, "wall_s": hb_wall, "cpu_s": hb_cpu,
               "stable": bool(hill.stable), "largest_multiplier": float(np.abs(hill.multipliers).max()),
               "hill_harmonics": hill.harmonics, "hill_wall_s": hill_wall, "hill_cpu_s": hill_cpu},
        "shooting": {"pp_mm": pp_sh.tolist(), "S": S, "estimate": sh.accuracy["estimate"], "wall_s": sh_wall,
                     "cpu_s": sh_cpu, "stable": bool(sh.stable),
                     "largest_multiplier": float(np.abs(sh.floquet_multipliers).max())},
        "reference": {"S": 2 * S, "pp_mm_2S": pp_fine.tolist(), "pp_mm_extrapolated": pp_ref.tolist(),
                      "largest_multiplier_2S": float(np.abs(fine.floquet_multipliers).max())},
        "difference_pct": {"vs_shooting": (100 * (pp_hb / pp_sh - 1)).tolist(),
                           "vs_reference": (100 * (pp_hb / pp_ref - 1)).tolist()},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out")
    args = ap.parse_args()
    warnings.simplefilter("ignore", fivebar.ValidityWarning)
    load0 = os.getloadavg()
    fivebar.steady_state(fivebar.Setup(fivebar.load_params(), motors=False), method="harmonic_balance")  # compile, import
    rows = [case(o, r) for o, r in (QUICK if args.quick else CASES)]
    out = {"tol": TOL, "cases": rows, "load": {"start": load0, "end": os.getloadavg()},
           "machine": {"python": platform.python_version(), "cpu_count": os.cpu_count()}}
    text = json.dumps(out, indent=1)
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
