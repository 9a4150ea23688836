"""Issue 10's figures side by side, in one run: step cost, steady state, sweep, import, scaling.

Prints one JSON object (and writes it with ``--out``).  Sections (times in ms unless named):

  step_us         one period of the default model (parameter file: S, generalised-alpha) started on
                  its orbit, microseconds per step, linear and nonlinear, motors off.
  steady_ms       at 60, 300, 600 r/min, linear and nonlinear, motors off:
                  ``tol_first``: ``steady_state(params, tol=0.01)`` (the library chooses S) with the
                  model caches emptied before each run; ``tol_new_speed``: the same call at other speeds (1 %
                  apart, each warm-started from the one before with ``start=``, the speed-independent
                  samples cached: what each further speed of a study costs; ``tol_new_speed_no_start``
                  without ``start``; ``tol_new_speed_S`` the S chosen at each of them); ``tol_S``,
                  ``tol_estimate`` and ``tol_true_error`` (against the S = 3200 orbit, the largest
                  deviation of the L2 and L3 midpoint curves relative to their peak-to-peak value);
                  ``default_first`` / ``default_repeat``: ``steady_state(params)`` at the parameter
                  file's S = 800; ``march``: marching from rest at S = 800.
  exudyn_ms       the peer (Exudyn, if installed) at its coarsest setting within 1 %, found here
                  from a ladder of meshes, steps per period and run-ups (every rung tried is
                  listed with its error against the peer's converged setting), beside
                  ``steady_state(params, tol=0.01)`` (first call and new speed, its error against
                  S = 3200) and the ratio of the times, at 300 and 600 r/min, motors off.
  radau_s         scipy's solve_ivp Radau from rest over four periods at 300 r/min (motors off,
                  nonlinear; the last one compared: the transient decays by the largest Floquet
                  multiplier, 0.13, per period), its error against the S = 3200 orbit (full run
                  only: tens of seconds).
  scaling_ms      nonlinear steady state (motors off, 300 r/min) for three meshes: at S = 100, 800,
                  1600 (first call, samples built; median of 3) and with ``tol=0.01`` (first call and
                  new speed),
                  and the exponent b of time ~ n^b from the paper's mesh to (4,8,8,4).
  sweep_s         ``speed_sweep`` over N speeds (100-3600 r/min) on a 2-process pool (the linear
                  model, motors on, S = 800), wall time including the pool start.
  sweep_default_s issue 33's sweep: the parameter file's set-up (motors on, nonlinear, S = 800)
                  over N speeds from 10 to 600 r/min on a 2-process pool, wall and CPU seconds,
                  and the rows against the S = 1600 answer at 10 of the speeds (4 with --quick).
  import_s        ``import fivebar`` in a fresh interpreter.
  load            ``os.getloadavg()`` at start and end (the machine is shared).

Usage: python benchmarks/bench_story.py [--quick] [--only SECTION] [--out benchmarks/results/story.json]
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
from fivebar.description.setup import Setup  # noqa: E402
from fivebar.model.dynamics import linkage_dynamics  # noqa: E402


def _t(fn, repeats=1):
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), out


def _clear():
    import fivebar
    fivebar.clear_cache()


def _new_speeds(setup, start, repeats):
    """Median time of ``steady_state(setup at a new speed, tol=0.01, start=...)`` over
    ``repeats`` speeds 1 % apart above ``setup``'s, each warm-started from the one before
    (``start``: the result at ``setup``'s speed), and the same calls without ``start`` (the
    samples cached, no predictor): what each further speed of a study costs; and the S chosen
    at each of those speeds.  ``start`` is the library's warm start of a new speed near a
    solved one since results depend on their inputs alone (until 2026-12-03 the library
    remembered the last orbit itself)."""
    from fivebar import steady_state

    warm, cold, steps = [], [], []
    prev = start
    for k in range(1, repeats + 1):
        s = setup.replace(crank_speed_rpm=setup.crank_speed_rpm * (1.0 + 0.01 * k))
        t = time.perf_counter()
        prev = steady_state(s, tol=0.01, start=prev)
        warm.append(time.perf_counter() - t)
        steps.append(prev.dynamics.steps_per_period)
        t = time.perf_counter()
        steady_state(s, tol=0.01)
        cold.append(time.perf_counter() - t)
    return statistics.median(warm), statistics.median(cold), steps


def _first(fn, repeats=1):
    """Like :func:`_t`, each run with the library's store emptied first (fivebar.clear_cache(): a first call)."""
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
    k = ref.dynamics.steps_per_period // res.dynamics.steps_per_period
    return max(float(np.abs(res.midpoint_mm(L) - ref.midpoint_mm(L)[::k]).max() / np.ptp(ref.midpoint_mm(L)))
               for L in ("L2", "L3"))


def step_costs(repeats):
    from fivebar import Setup, load_params
    from fivebar.numerics.newmark import integrate
    from fivebar.analyses.steady import shooting

    out = {}
    for nl in (False, True):
        s = Setup(load_params(), motors=False, nonlinear=nl)
        dyn = linkage_dynamics(s)
        orb = shooting(s)

        def run():
            integrate(dyn, orb.u[0], orb.v[0], 0.0, dyn.dt, dyn.steps_per_period, s.scheme, step_data=dyn.step_data)
        run()
        out["nonlinear" if nl else "linear"] = 1e6 * _t(run, repeats)[0] / dyn.steps_per_period
    out["S"] = dyn.steps_per_period
    return out


def steady_costs(repeats):
    from fivebar import load_params, steady_state

    p = load_params()
    out = {}
    for rpm in (60.0, 300.0, 600.0):
        for nl in (False, True):
            s = Setup(p, crank_speed_rpm=rpm, motors=False, nonlinear=nl)
            ref = steady_state(s.replace(steps_per_period=3200))
            first, r = _first(lambda: steady_state(s, tol=0.01), repeats)
            new, cold, steps = _new_speeds(s, r, repeats)
            dfirst, d = _first(lambda: steady_state(s), repeats)
            drep, _ = _t(lambda: steady_state(s), repeats)
            mar, m = _t(lambda: steady_state(s, method="march"))
            out[f"{'nonlinear' if nl else 'linear'}_{rpm:g}rpm"] = {
                "tol_first": 1e3 * first, "tol_new_speed": 1e3 * new, "tol_new_speed_no_start": 1e3 * cold,
                "tol_new_speed_S": steps, "tol_S": r.dynamics.steps_per_period,
                "tol_estimate": r.accuracy["estimate"], "tol_true_error": _curve_error(r, ref),
                "default_first": 1e3 * dfirst, "default_repeat": 1e3 * drep, "default_S": d.dynamics.steps_per_period,
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
    ref = steady_state(Setup(p, steps_per_period=3200, motors=False))
    el, ss, stats = radau_from_rest(p, 1e-3, periods=4, motors=False)  # 3 periods of transient
    ref_ss = steady_state(Setup(p, steps_per_period=ss.dynamics.steps_per_period, motors=False))
    return {"s": el, "runs": 1, "rtol": 1e-3, "periods": 4, "L2_p2p_mm": ss.peak_to_peak_mm("L2"),
            "p2p_rel_err": {L: ss.peak_to_peak_mm(L) / ref.peak_to_peak_mm(L) - 1 for L in ("L2", "L3")},
            "curve_error_vs_same_S_orbit": _curve_error(ss, ref_ss), **stats}


#: the peer's ladder, cheapest first: meshes (elements per link), steps per period, and run-ups
#: (ramp periods of the smooth start, and the periodicity tolerance that ends the run; inf: stop
#: at the first check, ramp + 2 periods)
EXUDYN_MESHES = ((1, 2, 2, 1), (2, 4, 4, 2))
EXUDYN_STEPS = (25, 50, 100, 200)
EXUDYN_RUNUPS = ((0, float("inf")), (2, float("inf")), (2, 1e-2), (2, 1e-3))
#: the tolerance passed for inf (multibody_steady_state takes a finite one since the validation
#: layer of 2026-12-03): the relative change of the curves over a period is always below it, so
#: the run stops at its first check, after the run-up and two periods
FIRST_CHECK = 1e9
#: the peer's converged reference: fine mesh, 400 steps, periodic to 1e-4
EXUDYN_REFERENCE = {"mesh": (2, 4, 4, 2), "steps": 400, "ramp_periods": 2, "tol": 1e-4}


def exudyn_cost(quick, repeats):
    """Exudyn at its coarsest setting within 1 % of its own converged answer, beside the
    library's ``steady_state(params, tol=0.01)``, at 300 and 600 r/min, motors off.

    The question both answer: the transverse midpoint deflection curves of L2 and L3 over the
    period, to 1 % of their peak-to-peak value.  The peer's error is measured against its own
    converged setting (:data:`EXUDYN_REFERENCE`), the library's against its S = 3200 orbit.
    The ladder is walked in the order of its cost (elements x steps x periods, the periods
    counted from the run-up); the first setting within 1 % is timed (median of ``repeats`` in
    this process) and the library beside it (medians of ``repeats``: first call, caches emptied;
    a new speed 1 % away, warm-started from the last with ``start=``, and without it).
    """
    try:
        import numpy as np
        from fivebar import load_params, steady_state
        from fivebar.analyses.multibody import MultibodyError, multibody_steady_state
        import exudyn  # noqa: F401
    except ImportError as exc:
        return {"note": f"not measured: {exc}"}
    p = load_params()
    samples = 25

    def curves(r):
        return {L: np.asarray(r.midpoint_mm(L)) for L in ("L2", "L3")}

    def error(c, ref):
        return max(float(np.abs(c[L] - ref[L]).max() / np.ptp(ref[L])) for L in ref)

    def run(rpm, mesh, steps, ramp, tol):
        # (tol inf: stop at the first check; the library takes a finite tolerance, and every
        # finite change meets FIRST_CHECK)
        return multibody_steady_state(Setup(p, crank_speed_rpm=rpm, steps_per_period=samples, elements_per_link=mesh),
                                      integration_steps=steps, tol=min(tol, FIRST_CHECK), ramp_periods=ramp)

    ladder = sorted(((m, s, r) for m in EXUDYN_MESHES for s in EXUDYN_STEPS for r in EXUDYN_RUNUPS),
                    key=lambda x: (sum(x[0]) * x[1] * (x[2][0] + 2), EXUDYN_RUNUPS.index(x[2])))
    run(300.0, (1, 2, 2, 1), 25, 2, float("inf"))  # the first Exudyn call loads its modules
    out = {"question": "transverse midpoint curves of L2 and L3 over the period, within 1 % of their "
                       "peak-to-peak value; motors off, nonlinear (the peer is geometrically exact)",
           "exudyn_reference": {**EXUDYN_REFERENCE, "samples": samples}}
    for rpm in (300.0, 600.0):
        rf = EXUDYN_REFERENCE
        ref = curves(run(rpm, rf["mesh"], rf["steps"], rf["ramp_periods"], rf["tol"]))
        tried, chosen = [], None
        for mesh, steps, (ramp, tol) in ladder:
            row = {"mesh": mesh, "steps_per_period": steps, "ramp_periods": ramp,
                   "periodicity_tol": None if tol == float("inf") else tol}
            try:
                r = run(rpm, mesh, steps, ramp, tol)
                row.update(periods=r.periods, error=error(curves(r), ref))
            except MultibodyError as exc:
                row["failed"] = str(exc)[:120]
            tried.append(row)
            if row.get("error", 1.0) <= 0.01:
                chosen = row
                break
        entry = {"ladder_tried": tried}
        if chosen is not None:
            ex, _ = _t(lambda: run(rpm, chosen["mesh"], chosen["steps_per_period"], chosen["ramp_periods"],
                                   chosen["periodicity_tol"] or float("inf")), repeats)
            entry["exudyn_coarsest_within_1pct"] = {**chosen, "ms": 1e3 * ex}
        fb_ref = steady_state(Setup(p, crank_speed_rpm=rpm, motors=False, steps_per_period=3200))
        first, r = _first(lambda: steady_state(Setup(p, crank_speed_rpm=rpm, motors=False), tol=0.01), repeats)
        new, cold, steps = _new_speeds(Setup(p, crank_speed_rpm=rpm, motors=False), r, repeats)
        entry["fivebar_tol_0.01"] = {"first_ms": 1e3 * first, "new_speed_ms": 1e3 * new,
                                     "new_speed_no_start_ms": 1e3 * cold, "new_speed_S": steps,
                                     "S": r.dynamics.steps_per_period,
                                     "estimate": r.accuracy["estimate"], "error_vs_S3200": _curve_error(r, fb_ref)}
        if chosen is not None:
            entry["ratio_exudyn_over_fivebar"] = {"first": ex / first, "new_speed": ex / new}
        out[f"{rpm:g}rpm"] = entry
    return out


def _pooled_sweep(setup, speeds):
    """``speed_sweep(setup, speeds)`` on a fresh 2-process pool, nothing cached: the rows, the
    wall seconds (the pool's start included) and the pool's CPU seconds."""
    from concurrent.futures import ProcessPoolExecutor
    from fivebar.analyses.sweep import speed_sweep

    c0 = os.times()
    t = time.perf_counter()
    with ProcessPoolExecutor(2) as ex:
        df = speed_sweep(setup, speeds, executor=ex, progress=False, cache=False)
    wall = time.perf_counter() - t
    c1 = os.times()
    return df, wall, (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system)


def sweep_cost(n):
    import numpy as np
    from fivebar import load_params

    # the linear model, as documented: a Params alone now means Setup(params), nonlinear, whose
    # shooting fails past the divergence of the lowest mode (errata E28) within 100-3600 r/min
    df, wall, _ = _pooled_sweep(Setup(load_params(), nonlinear=False), np.linspace(100, 3600, n))
    return {"speeds": n, "processes": 2, "seconds": wall, "rows": len(df)}


def sweep_default_cost(n, checked):
    """Issue 33's sweep: ``speed_sweep(Setup(params))`` (the parameter file's set-up: motors on,
    nonlinear, S = 800) over ``n`` speeds from 10 to 600 r/min on a 2-process pool, wall and the
    pool's CPU seconds, and its rows against the S = 1600 answer at ``checked`` of the speeds
    (the largest relative difference of the L2 and L3 midpoint peak-to-peak values)."""
    import numpy as np
    from fivebar import load_params, steady_state

    p = load_params()
    speeds = np.linspace(10.0, 600.0, n)
    df, wall, cpu = _pooled_sweep(Setup(p), speeds)
    worst = 0.0
    for i in np.linspace(0, n - 1, checked).round().astype(int):
        ref = steady_state(Setup(p, crank_speed_rpm=float(speeds[i]), steps_per_period=1600))
        for link in ("L2", "L3"):
            worst = max(worst, abs(df[f"{link} p2p (mm)"].iloc[i] / ref.peak_to_peak_mm(link) - 1.0))
    return {"speeds": n, "processes": 2, "seconds": wall, "rows": len(df), "cpu_s": cpu,
            "S": int(Setup(p).steps_per_period), "checked": checked, "largest_difference_vs_S1600": worst}


def import_time(repeats):
    code = "import time; t = time.perf_counter(); import fivebar; print(time.perf_counter() - t)"
    ts = [float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
          for _ in range(repeats)]
    return {"median": statistics.median(ts), "min": min(ts)}


def scaling(quick, repeats):
    import math
    from fivebar import load_params, steady_state

    p = load_params()
    base = Setup(p, crank_speed_rpm=300, motors=False)
    out = []
    for mesh in ((1, 2, 2, 1), (2, 4, 4, 2), (4, 8, 8, 4)):
        for S in ((100, 800) if quick else (100, 800, 1600)):
            try:
                dt, r = _first(lambda: steady_state(base.replace(steps_per_period=S, elements_per_link=mesh)), repeats)
                out.append({"mesh": mesh, "S": S, "n": r.dynamics.n, "ms": 1e3 * dt, "periods": r.periods})
            except Exception as exc:  # noqa: BLE001 - reported
                out.append({"mesh": mesh, "S": S, "error": f"{type(exc).__name__}: {str(exc)[:200]}"})
        dt, r = _first(lambda: steady_state(base.replace(elements_per_link=mesh), tol=0.01), repeats)
        dn, _, _ = _new_speeds(base.replace(elements_per_link=mesh), r, 3)
        out.append({"mesh": mesh, "S": "tol=0.01", "chosen_S": r.dynamics.steps_per_period, "n": r.dynamics.n,
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
    ap.add_argument("--only", default=None, help="one section: step_us, steady_ms, radau_s, exudyn_ms, "
                    "scaling_ms, sweep_s, sweep_default_s, import_s")
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits
    import numpy

    load0 = os.getloadavg()
    rep = 3 if args.quick else 7
    res = {"benchmark": "bench_story", "command": "python benchmarks/bench_story.py " + " ".join(sys.argv[1:]),
           "python": platform.python_version(), "numpy": numpy.__version__, "cpus": os.cpu_count()}
    t0 = time.perf_counter()
    rep_exu = 3 if args.quick else 5
    sections = {"step_us": lambda: step_costs(rep), "steady_ms": lambda: steady_costs(rep),
                "radau_s": lambda: radau_cost(args.quick), "exudyn_ms": lambda: exudyn_cost(args.quick, rep_exu),
                "scaling_ms": lambda: scaling(args.quick, 1 if args.quick else 3)}
    with threadpool_limits(1):
        for name, fn in sections.items():
            if args.only in (None, name):
                res[name] = fn()
    if args.only in (None, "sweep_s"):
        res["sweep_s"] = sweep_cost(40 if args.quick else 200)
    if args.only in (None, "sweep_default_s"):
        res["sweep_default_s"] = sweep_default_cost(40 if args.quick else 200, 4 if args.quick else 10)
    if args.only in (None, "import_s"):
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
