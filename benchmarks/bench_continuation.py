"""Continuation of the linkage's periodic steady state over crank speed (issue 18, point 5).

The flexible orientation (``bending_depth = 0.002``: the 2 mm side in the plane of motion),
motors off, the parameter file's S and scheme otherwise; ``fivebar.analyses.branches.follow`` from 10 to
300 r/min with a budget of 200 points, for the linear and the nonlinear model.  Prints one
JSON object (and writes it with ``--out``):

  <model>.points, .p_reached     points computed and the last speed (r/min)
  <model>.stop                   why it stopped ("p_end = 300 reached", or the failure)
  <model>.steps                  arclength steps (scaled: the range 10-300 is 1) and the speed
                                 steps (r/min): min, median, max
  <model>.newton                 corrector iterations: total, mean per point, histogram
  <model>.stats                  map applications (periods), monodromy matrices, rejected steps,
                                 and "by purpose": the periods, monodromies and corrector
                                 iterations of the start, the accepted steps' corrector, the
                                 rejected steps, the multipliers at the points and the locating
  <model>.time_s, .ms_per_point  wall time (the state scaling's linear scan included) and per point
  <model>.bifurcations           kind, speed, bracket, critical multiplier, four largest multipliers
  <model>.after                  at a speed just past the first period doubling (if any):
                                 ``describe_speed``'s sentence
  load                           os.getloadavg() at start and end (the machine is shared)
  cores                          the cores this process may run on

With ``--threads 2,1`` each model runs twice, with the forward difference's period in p
beside the monodromy period on a second core (the library's default where there are two) and
one after the other, as "<model>, 2 thread(s)" and "<model>, 1 thread(s)": the same branch to
the bit (the counts say so), so the ratio of the times is the second core's gain.

``--case chapter13`` times chapter 13's continuation instead (issue 33: at most 10 s): the
flexible orientation with stiffness damping, S = 200, the nonlinear model from 150 to 240 r/min with
a budget of 240 points, as the chapter runs it; ``--repeat N`` runs it N times, the library's
cache cleared before each (each run samples its step data afresh, as a chapter's one run does),
and prints every time, their median and the folds of each run.

Usage: python benchmarks/bench_continuation.py [--out benchmarks/results/continuation.json]
       [--steps S] [--points 200] [--models linear,nonlinear] [--threads 2,1]
       python benchmarks/bench_continuation.py --case chapter13 [--repeat 3] [--out FILE]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402


def _c(z):
    return [round(float(z.real), 6), round(float(z.imag), 6)]


def run(model: str, steps: int | None, points: int) -> dict:
    import numpy as np

    import fivebar
    from fivebar.analyses.branches import describe_speed, follow

    p = fivebar.load_params().replace(bending_depth=0.002)
    s = fivebar.Setup(p, crank_speed_rpm=10, motors=False, nonlinear=(model == "nonlinear"),
                      steps_per_period=steps)
    t = time.perf_counter()
    br = follow(s, 300, points=points)
    wall = time.perf_counter() - t
    b = br.branch
    dp = np.abs(np.diff(b.p))
    out = {
        "S": s.steps_per_period,
        "scheme": fivebar.description.setup.scheme_name(s.scheme),
        "points": len(b.points),
        "p_reached": round(float(b.p[-1]), 4),
        "stop": b.stop,
        "steps": {"arclength": [float(np.min(b.steps)), float(np.median(b.steps)), float(np.max(b.steps))],
                  "rpm": [float(dp.min()), float(np.median(dp)), float(dp.max())]},
        "newton": {"total": int(b.newton.sum()), "mean": round(float(b.newton.mean()), 2),
                   "histogram": np.bincount(b.newton).tolist()},
        "stats": dict(b.stats),
        "time_s": round(wall, 2),
        "ms_per_point": round(1e3 * wall / len(b.points), 1),
        "stable_fraction": round(float(np.mean(b.stable)), 3),
        "largest_multiplier": round(float(br.spectral_radius.max()), 5),
        "bifurcations": [
            {"kind": x.kind, "rpm": round(x.p, 6), "bracket": [round(v, 6) for v in x.p_bracket],
             "critical": _c(x.critical), "abs_critical": round(abs(x.critical), 6),
             "multipliers": [_c(m) for m in x.multipliers[:4]]}
            for x in br.bifurcations],
    }
    pd = [x for x in br.bifurcations if x.kind == "period doubling"]
    if pd:
        try:
            rep = describe_speed(s, pd[0].p + 0.2, branch=br, periods=300)
            out["after"] = {"rpm": round(pd[0].p + 0.2, 4), "kind": rep.kind, "text": rep.text}
        except Exception as exc:  # noqa: BLE001 - report, do not fail the benchmark
            out["after"] = {"rpm": round(pd[0].p + 0.2, 4), "error": f"{type(exc).__name__}: {exc}"}
    return out


def chapter13(repeat: int) -> dict:
    """Chapter 13's continuation, ``repeat`` times from a cleared cache: times, median, folds."""
    import statistics

    import fivebar
    from fivebar.analyses.branches import follow
    from fivebar.cache import clear_cache

    p = fivebar.load_params().replace(bending_depth=0.002, damping_model="stiffness")
    s = fivebar.Setup(p, crank_speed_rpm=150, motors=False, nonlinear=True, steps_per_period=200)
    runs = []
    for _ in range(repeat):
        clear_cache()
        t = time.perf_counter()
        br = follow(s, 240, points=240)
        wall = time.perf_counter() - t
        b = br.branch
        runs.append({"time_s": round(wall, 2), "points": len(b.points), "stop": b.stop,
                     "newton_per_point": round(float(b.newton.mean()), 2), "rejected": b.stats["rejected"],
                     "periods": b.stats["periods"], "monodromies": b.stats["monodromies"],
                     "folds_rpm": sorted(round(x.p, 5) for x in br.bifurcations if x.kind == "fold")})
    times = [r["time_s"] for r in runs]
    return {"case": "chapter 13: flexible orientation, stiffness damping, S = 200, nonlinear, 150-240 r/min, "
                    "240 points", "budget_s": 10.0, "median_s": round(statistics.median(times), 2), "runs": runs}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out")
    ap.add_argument("--steps", type=int, default=None, help="S (default: the parameter file's)")
    ap.add_argument("--points", type=int, default=200)
    ap.add_argument("--models", default="linear,nonlinear")
    ap.add_argument("--case", default="benchmark", choices=("benchmark", "chapter13"))
    ap.add_argument("--repeat", type=int, default=3, help="runs of the chapter13 case")
    ap.add_argument("--threads", default="2", help="comma-separated: 2 (the forward difference's period "
                    "beside the monodromy's where there are two cores, the library's default), 1 (one "
                    "after the other); each model is run with each, in this process")
    a = ap.parse_args()
    res = {"python": platform.python_version(), "cores": len(os.sched_getaffinity(0)),
           "load": {"start": list(os.getloadavg())}}
    import fivebar  # noqa: F401  (the import and the numba cache load are not timed)
    from fivebar import steady_state
    from fivebar.analyses.branches import LinkagePeriodMap
    steady_state(fivebar.Setup(fivebar.load_params(), motors=False))  # warm the compiled kernels
    threads = [int(t) for t in a.threads.split(",")]
    if a.case == "chapter13":
        res["chapter13"] = chapter13(a.repeat)
    for model in (a.models.split(",") if a.case == "benchmark" else ()):
        for t in threads:
            LinkagePeriodMap.concurrent = t > 1  # the map's permission (the library's default: True)
            res[model if t == 2 and len(threads) == 1 else f"{model}, {t} thread(s)"] = run(model, a.steps, a.points)
    LinkagePeriodMap.concurrent = True
    res["load"]["end"] = list(os.getloadavg())
    text = json.dumps(res, indent=1)
    print(text)
    if a.out:
        with open(a.out, "w") as fh:
            fh.write(text + "\n")


if __name__ == "__main__":
    main()
