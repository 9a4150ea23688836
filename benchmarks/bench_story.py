"""Issue 10's figures side by side, in one run: step cost, steady state, sweep, import, scaling.

Prints one JSON object (and writes it with ``--out``).  Sections (times in ms unless named):

  step_us         one period of the default model (parameter file: S, generalised-alpha) started on
                  its orbit, microseconds per step, linear and nonlinear, motors off.
  steady_ms       at 60, 300, 600 r/min, linear and nonlinear, motors off:
                  ``tol_first``: ``steady_state(params, tol=0.01)`` (the library chooses S) with the
                  model caches emptied before each run; ``tol_new_speed``: the same call at other speeds (1 %
                  apart: the speed-independent samples are cached, what each further speed of a
                  study costs); ``tol_S``, ``tol_estimate`` and ``tol_true_error`` (against the
                  S = 3200 orbit, the largest deviation of the L2 and L3 midpoint curves relative
                  to their peak-to-peak value); ``default_first`` / ``default_repeat``:
                  ``steady_state(params)`` at the parameter file's S = 800; ``march``: marching
                  from rest at S = 800.
  exudyn_ms       ``multibody_steady_state`` on its coarsest mesh and steps (with the p-p deflection
                  of L2 against the KED orbit at S = 1600), if exudyn is installed, and the ratio
                  of its time to fivebar's ``tol_new_speed`` / ``tol_first`` at 300 r/min.
  radau_s         scipy's solve_ivp Radau from rest over four periods at 300 r/min (motors off,
                  nonlinear; the last one compared: the transient decays by the largest Floquet
                  multiplier, 0.13, per period), its error against the S = 3200 orbit (full run
                  only: tens of seconds).
  scaling_ms      nonlinear steady state (motors off, 300 r/min) for three meshes: at S = 100, 800,
                  1600 (first call, samples built; median of 3) and with ``tol=0.01`` (first call and
                  new speed),
                  and the exponent b of time ~ n^b from the paper's mesh to (4,8,8,4).
  sweep_s         ``speed_sweep`` over N speeds (100-3600 r/min) on a 2-process pool (linear, the
                  sweep's default), wall time including the pool start.
  import_s        ``import fivebar`` in a fresh interpreter.
  load            ``os.getloadavg()`` at start and end (the machine is shared).

Usage: python benchmarks/bench_story.py [--quick] [--out benchmarks/results/story.json]
``--quick`` (< 2 min): fewer repeats, 40 sweep speeds instead of 200, no S = 1600 row, no Radau.
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
    dynamics._MODELS.clear()


def _first(fn, repeats=1):
    """Like :func:`_t`, each run with the model caches emptied first (a first call)."""
    ts = []
    for _ in range(repeats):
        _clear()
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), out


def _curve_error(res, ref):
    """Largest deviation of the L2 and L3 midpoint curves from ``ref`` (S a multiple of res's),
    relative to the reference's peak-to-peak value."""
    import numpy as np
    k = ref.dynamics.steps // res.dynamics.steps
    return max(float(np.abs(res.midpoint_mm(L) - ref.midpoint_mm(L)[::k]).max() / np.ptp(ref.midpoint_mm(L)))
               for L in ("L2", "L3"))


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
            kw = dict(motors=False, nonlinear=nl)
            ref = steady_state(p, crank_speed_rpm=rpm, steps_per_period=3200, **kw)
            first, r = _first(lambda: steady_state(p, crank_speed_rpm=rpm, tol=0.01, **kw), repeats)
            speeds = iter(rpm * (1.0 + 0.01 * k) for k in range(1, repeats + 1))
            new, _ = _t(lambda: steady_state(p, crank_speed_rpm=next(speeds), tol=0.01, **kw), repeats)
            dfirst, d = _first(lambda: steady_state(p, crank_speed_rpm=rpm, **kw), repeats)
            drep, _ = _t(lambda: steady_state(p, crank_speed_rpm=rpm, **kw), repeats)
            mar, m = _t(lambda: steady_state(p, crank_speed_rpm=rpm, method="march", **kw))
            out[f"{'nonlinear' if nl else 'linear'}_{rpm:g}rpm"] = {
                "tol_first": 1e3 * first, "tol_new_speed": 1e3 * new, "tol_S": r.dynamics.steps,
                "tol_estimate": r.accuracy["estimate"], "tol_true_error": _curve_error(r, ref),
                "default_first": 1e3 * dfirst, "default_repeat": 1e3 * drep, "default_S": d.dynamics.steps,
                "default_true_error": _curve_error(d, ref), "march": 1e3 * mar,
                "periods_default": d.periods, "periods_march": m.periods, "L2_p2p_mm": ref.peak_to_peak_mm("L2")}
    return out


def radau_cost(quick):
    if quick:
        return {"note": "not run with --quick (tens of seconds)"}
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from bench_dynamics import radau_from_rest
    from fivebar import load_params, steady_state

    p = load_params().replace(crank_speed_rpm=300)
    ref = steady_state(p, steps_per_period=3200, motors=False)
    el, ss, stats = radau_from_rest(p, 1e-3, periods=4, motors=False)  # 3 periods of transient
    ref_ss = steady_state(p, steps_per_period=ss.dynamics.steps, motors=False)
    return {"s": el, "runs": 1, "rtol": 1e-3, "periods": 4, "L2_p2p_mm": ss.peak_to_peak_mm("L2"),
            "p2p_rel_err": {L: ss.peak_to_peak_mm(L) / ref.peak_to_peak_mm(L) - 1 for L in ("L2", "L3")},
            "curve_error_vs_same_S_orbit": _curve_error(ss, ref_ss), **stats}


def exudyn_cost(quick):
    try:
        from fivebar import load_params, steady_state
        from fivebar.multibody import multibody_steady_state
        import exudyn  # noqa: F401
    except ImportError as exc:
        return {"note": f"not measured: {exc}"}
    p = load_params()
    ref = steady_state(p, crank_speed_rpm=300, motors=False, steps_per_period=1600, elements_per_link=(2, 4, 4, 2))
    a_ref = ref.peak_to_peak_mm("L2")
    out = {"ked_reference_L2_p2p_mm": a_ref, "ked_reference": "S = 1600, mesh (2,4,4,2), 300 r/min, motors off"}
    rows = []
    for steps, mesh in ((100, (1, 2, 2, 1)), (200, (1, 2, 2, 1)), (200, (2, 4, 4, 2))):
        try:
            dt, r = _t(lambda: multibody_steady_state(p, crank_speed_rpm=300, steps_per_period=steps,
                                                      samples=100, elements_per_link=mesh, tol=0.01))
            a = r.peak_to_peak_mm("L2") if hasattr(r, "peak_to_peak_mm") else float(r.midpoint_mm("L2").ptp())
            rows.append({"steps": steps, "mesh": mesh, "ms": 1e3 * dt, "L2_p2p_mm": a, "rel_err": a / a_ref - 1})
        except Exception as exc:  # noqa: BLE001 - reported
            rows.append({"steps": steps, "mesh": mesh, "error": f"{type(exc).__name__}: {str(exc)[:200]}"})
        if quick:
            break
    out["runs"] = rows
    ok = [r["ms"] for r in rows if "ms" in r and abs(r["rel_err"]) <= 0.01]
    if ok:
        first, _ = _first(lambda: steady_state(p, crank_speed_rpm=300, motors=False, tol=0.01), 5)
        speeds = iter(300.0 * (1.0 + 0.01 * k) for k in range(1, 6))
        new, _ = _t(lambda: steady_state(p, crank_speed_rpm=next(speeds), motors=False, tol=0.01), 5)
        out["fivebar_tol_ms"] = {"first": 1e3 * first, "new_speed": 1e3 * new}
        out["ratio_exudyn_coarsest_over_fivebar"] = {"first": min(ok) / (1e3 * first), "new_speed": min(ok) / (1e3 * new)}
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


def scaling(quick, repeats):
    import math
    from fivebar import load_params, steady_state

    p = load_params()
    kw = dict(crank_speed_rpm=300, motors=False)
    out = []
    for mesh in ((1, 2, 2, 1), (2, 4, 4, 2), (4, 8, 8, 4)):
        for S in ((100, 800) if quick else (100, 800, 1600)):
            try:
                dt, r = _first(lambda: steady_state(p, steps_per_period=S, elements_per_link=mesh, **kw), repeats)
                out.append({"mesh": mesh, "S": S, "n": r.dynamics.n, "ms": 1e3 * dt, "periods": r.periods})
            except Exception as exc:  # noqa: BLE001 - reported
                out.append({"mesh": mesh, "S": S, "error": f"{type(exc).__name__}: {str(exc)[:200]}"})
        dt, r = _first(lambda: steady_state(p, tol=0.01, elements_per_link=mesh, **kw), repeats)
        speeds = iter(300.0 * (1.0 + 0.01 * k) for k in range(1, 4))
        dn, _ = _t(lambda: steady_state(p, tol=0.01, elements_per_link=mesh, crank_speed_rpm=next(speeds),
                                        motors=False), 3)
        out.append({"mesh": mesh, "S": "tol=0.01", "chosen_S": r.dynamics.steps, "n": r.dynamics.n,
                    "ms": 1e3 * dt, "new_speed_ms": 1e3 * dn})
    exps = {}
    for key in ("ms", "new_speed_ms"):
        rows = {r["n"]: r[key] for r in out if r.get("S") == "tol=0.01"}
        n0, n1 = min(rows), max(rows)
        exps[f"tol_{key}"] = math.log(rows[n1] / rows[n0]) / math.log(n1 / n0)
    for S in (100, 800):
        rows = {r["n"]: r["ms"] for r in out if r.get("S") == S and "ms" in r}
        n0, n1 = min(rows), max(rows)
        exps[f"S{S}_ms"] = math.log(rows[n1] / rows[n0]) / math.log(n1 / n0)
    return {"rows": out, "exponent_b": exps}


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
        res["radau_s"] = radau_cost(args.quick)
        res["exudyn_ms"] = exudyn_cost(args.quick)
        res["scaling_ms"] = scaling(args.quick, 1 if args.quick else 3)
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
