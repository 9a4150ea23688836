"""Issue 10's figures side by side, in one run: step cost, steady state, sweep, import, scaling.

Prints one JSON object (and writes it with ``--out``).  Sections (times in ms unless named):

  step_us         one period of the default model (parameter file: S, generalised-alpha) started on
                  its orbit, microseconds per step, linear and nonlinear, motors off.
  steady_ms       ``steady_state(params, crank_speed_rpm=rpm, motors=False, nonlinear=...)`` at 60,
                  300, 600 r/min: "first" with the model cache emptied (what a new speed costs the
                  first time), "repeat" the same call again; "march" the same by marching from rest.
  exudyn_ms       ``multibody_steady_state`` on its coarsest mesh and steps (with the p-p deflection
                  of L2 against the KED orbit at S = 1600), if exudyn is installed.
  sweep_s         ``speed_sweep`` over N speeds (100-3600 r/min) on a 2-process pool (linear, the
                  sweep's default), wall time including the pool start.
  import_s        ``import fivebar`` in a fresh interpreter.
  scaling_ms      nonlinear steady state (motors off) for three meshes x three S, first call.
  load            ``os.getloadavg()`` at start and end (the machine is shared).

Usage: python benchmarks/bench_story.py [--quick] [--out benchmarks/results/story.json]
``--quick`` (< 3 min): fewer repeats, 40 sweep speeds instead of 200, no S = 1600 row.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402


def _t(fn, repeats=1):
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), out


def _clear():
    from fivebar import dynamics
    dynamics._SAMPLE_CACHE.clear()


def step_costs(repeats):
    from fivebar import Setup, load_params
    from fivebar.newmark import integrate
    from fivebar.steady import shooting

    out = {}
    for nl in (False, True):
        s = Setup(load_params(), motors=False, nonlinear=nl)
        dyn = s.dynamics()
        orb = shooting(dyn, scheme=s.scheme)

        def run():
            integrate(dyn, orb.u[0], orb.v[0], 0.0, dyn.dt, dyn.steps, s.scheme, step_data=dyn.step_data)
        run()
        out["nonlinear" if nl else "linear"] = 1e6 * _t(run, repeats)[0] / dyn.steps
    out["S"] = dyn.steps
    return out


def steady_costs(repeats):
    from fivebar import load_params, steady_state

    p = load_params()
    out = {}
    for rpm in (60.0, 300.0, 600.0):
        for nl in (False, True):
            kw = dict(crank_speed_rpm=rpm, motors=False, nonlinear=nl)
            _clear()
            first, r = _t(lambda: steady_state(p, **kw))
            rep, _ = _t(lambda: steady_state(p, **kw), repeats)
            mar, m = _t(lambda: steady_state(p, method="march", **kw))
            out[f"{'nonlinear' if nl else 'linear'}_{rpm:g}rpm"] = {
                "first": 1e3 * first, "repeat": 1e3 * rep, "march": 1e3 * mar,
                "periods_shooting": r.periods, "periods_march": m.periods,
                "L2_p2p_mm": r.peak_to_peak("L2")}
    return out


def exudyn_cost(quick):
    try:
        from fivebar import load_params, steady_state
        from fivebar.multibody import multibody_steady_state
        import exudyn  # noqa: F401
    except ImportError as exc:
        return {"note": f"not measured: {exc}"}
    p = load_params()
    ref = steady_state(p, crank_speed_rpm=300, motors=False, steps_per_period=1600, elements_per_link=(2, 4, 4, 2))
    a_ref = ref.peak_to_peak("L2")
    out = {"ked_reference_L2_p2p_mm": a_ref, "ked_reference": "S = 1600, mesh (2,4,4,2), 300 r/min, motors off"}
    rows = []
    for steps, mesh in ((100, (1, 2, 2, 1)), (200, (1, 2, 2, 1)), (200, (2, 4, 4, 2))):
        try:
            dt, r = _t(lambda: multibody_steady_state(p, crank_speed_rpm=300, steps_per_period=steps,
                                                      samples=100, elements_per_link=mesh, tol=0.01))
            a = r.peak_to_peak("L2") if hasattr(r, "peak_to_peak") else float(r.midpoint("L2").ptp())
            rows.append({"steps": steps, "mesh": mesh, "ms": 1e3 * dt, "L2_p2p_mm": a, "rel_err": a / a_ref - 1})
        except Exception as exc:  # noqa: BLE001 - reported
            rows.append({"steps": steps, "mesh": mesh, "error": f"{type(exc).__name__}: {str(exc)[:200]}"})
        if quick:
            break
    out["runs"] = rows
    return out


def sweep_cost(n):
    import numpy as np
    from concurrent.futures import ProcessPoolExecutor
    from fivebar import load_params
    from fivebar.sweep import speed_sweep

    p = load_params()
    t = time.perf_counter()
    with ProcessPoolExecutor(2) as ex:
        df = speed_sweep(p, np.linspace(100, 3600, n), executor=ex, progress=False, cache=False)
    return {"speeds": n, "processes": 2, "seconds": time.perf_counter() - t, "rows": len(df)}


def import_time(repeats):
    code = "import time; t = time.perf_counter(); import fivebar; print(time.perf_counter() - t)"
    ts = [float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
          for _ in range(repeats)]
    return {"median": statistics.median(ts), "min": min(ts)}


def scaling(quick):
    from fivebar import load_params, steady_state

    p = load_params()
    out = []
    for mesh in ((1, 2, 2, 1), (2, 4, 4, 2), (4, 8, 8, 4)):
        for S in ((100, 400, 800) if quick else (100, 800, 1600)):
            _clear()
            try:
                dt, r = _t(lambda: steady_state(p, motors=False, steps_per_period=S, elements_per_link=mesh))
                out.append({"mesh": mesh, "S": S, "n": r.dynamics.n, "ms": 1e3 * dt, "periods": r.periods})
            except Exception as exc:  # noqa: BLE001 - reported
                out.append({"mesh": mesh, "S": S, "error": f"{type(exc).__name__}: {str(exc)[:200]}"})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits
    import numpy

    load0 = os.getloadavg()
    rep = 3 if args.quick else 7
    res = {"benchmark": "bench_story", "command": "python benchmarks/bench_story.py " + " ".join(sys.argv[1:]),
           "python": platform.python_version(), "numpy": numpy.__version__, "cpus": os.cpu_count()}
    t0 = time.perf_counter()
    with threadpool_limits(1):
        res["step_us"] = step_costs(rep)
        res["steady_ms"] = steady_costs(rep)
        res["steady_tol_call"] = {"note": "steady_state(params, tol=0.01) is not implemented yet (issue 10 item 3)"}
        res["radau"] = {"note": "not measured here: see benchmarks/bench_dynamics.py"}
        res["exudyn_ms"] = exudyn_cost(args.quick)
        res["scaling_ms"] = scaling(args.quick)
    res["sweep_s"] = sweep_cost(40 if args.quick else 200)
    res["import_s"] = import_time(rep)
    res["load"] = {"start": load0, "end": os.getloadavg()}
    res["total_s"] = time.perf_counter() - t0
    text = json.dumps(res, indent=1)
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
