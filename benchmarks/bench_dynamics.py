"""Time the five-bar's dynamics (2.7): Newmark steps, steady periods, steady states, sweeps.

Prints one JSON object.  Sections:

  per_step         one period (the parameter file's S) of the default model (60 r/min)
                   started on its periodic orbit, in microseconds per step: linear (cached LU,
                   one solve per step) and nonlinear (full and modified Newton), for the
                   paper's rule (average acceleration) and GeneralizedAlpha(0.8).
  per_period       one steady period in ms: a plain period (march) and a period with the
                   2n x 2n (Newmark) or 3n x 3n (alpha) monodromy (one shooting iteration);
                   and one whole ``steady_state(params)`` call (model construction included).
  to_steady_state  the time from nothing (model construction included) to a periodic steady
                   state whose peak-to-peak transverse midpoint deflections of L2 and L3 are
                   within 1 % of the converged reference (shooting, S = 1600, computed here),
                   for fivebar shooting, fivebar march from rest (GeneralizedAlpha(0.8)), and
                   scipy's solve_ivp Radau from rest on the same equations (same process,
                   same model functions; the second period is compared, Radau being given the
                   knowledge that one period of transient suffices).  Radau is slow on this
                   model (its right-hand side evaluates M, C, K and the modal damping at each
                   t, and the curvature DOFs' modes reach ~1e5 rad/s), so it runs
                   --radau-runs times (default 1): the JSON says how many.
  sweep            steady states per second over --sweep-points (>= 50) crank speeds from 20 to
                   120 r/min in this process, and a 200-speed sweep on 2 worker processes
                   (concurrent.futures.ProcessPoolExecutor), measured and extrapolated
                   (nonlinear model, shooting with GeneralizedAlpha(0.8), the file's S: the paper's
                   rule fails in nonlinear shooting near 114 r/min).

Every timing is the median of >= 5 runs (time.perf_counter) unless the JSON says otherwise,
with one BLAS thread per process (threadpoolctl) for fivebar and the peers alike: the dense
matrices are small (n = 26) and threaded BLAS only adds overhead.  The machine may be shared:
the load average at the start and end is reported.

Usage: python benchmarks/bench_dynamics.py [--repeats 5] [--sweep-points 50]
       [--radau-runs 1] [--no-radau] [--no-sweep200]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import scipy
import scipy.integrate
from threadpoolctl import threadpool_limits

from fivebar import Setup, load_params
from fivebar.description.setup import scheme_name
from fivebar.model.dynamics import LinkageDynamics
from fivebar.numerics.newmark import integrate
from fivebar.numerics.schemes import GeneralizedAlpha, Newmark
from fivebar.analyses.branches import steady_state
from fivebar.analyses.steady import SteadyState, march, shooting

LINKS = ("L2", "L3")
#: the default of steady_state(params): the parameter file's scheme and S
DEFAULT = f"{scheme_name(Setup(load_params()).scheme)}, S={load_params().steps_per_period}"
SWEEP_RANGE_RPM = (20.0, 120.0)


def timed(fn, repeats: int) -> tuple[float, object]:
    """Median wall time (s) over ``repeats`` calls, and the last result."""
    times = []
    out = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def accuracy(ss: SteadyState, ref: dict[str, float]) -> dict[str, float]:
    """Relative error of the peak-to-peak transverse midpoint deflection, per link."""
    return {L: ss.peak_to_peak_mm(L) / ref[L] - 1.0 for L in LINKS}


def sweep_state(P, w: float) -> SteadyState:
    """One sweep point: the default (nonlinear) model at w r/min, shooting, the file's S, with
    GeneralizedAlpha(0.8): with the paper's rule the nonlinear shooting fails near 114 r/min
    (its discrete orbit is unstable, multiplier ~40, and a Newton step of a period diverges)."""
    return steady_state(Setup(P, crank_speed_rpm=w, scheme=GeneralizedAlpha(0.8)))


def single_blas_thread() -> None:
    """Worker initializer: one BLAS thread per process (two threaded processes on two cores
    oversubscribe them; the library's time loop limits its threads, the rest of the steady
    state computation does not)."""
    threadpool_limits(1)


def sweep_chunk(speeds: list[float]) -> list[float]:
    """Worker: sweep points at the given speeds (r/min)."""
    P = load_params()
    return [sweep_state(P, w).peak_to_peak_mm("L3") for w in speeds]


def bench_steps(P, R: int) -> dict:
    out: dict = {}
    for name, nl in (("linear", False), ("nonlinear", True)):
        d = LinkageDynamics(Setup(P, nonlinear=nl))
        for sname, sch in (("newmark", Newmark()), ("generalized_alpha_0.8", GeneralizedAlpha(0.8))):
            orbit = shooting(d.setup.replace(scheme=sch))
            u0, v0 = orbit.u[0], orbit.v[0]
            modes = ("full",) if not nl else ("full", "modified")
            for newton in modes:
                def run(newton=newton):
                    return integrate(d, u0, v0, 0.0, d.dt, d.steps_per_period, sch, step_data=d.step_data, newton=newton)

                run()  # fills the cached factorisations
                t, res = timed(run, R)
                out[f"{name}/{sname}/{newton}"] = {
                    "us_per_step": 1e6 * t / d.steps_per_period,
                    "newton_iterations_per_step": float(np.mean(res.iterations)),
                    "ms_per_period": 1e3 * t,
                }
            mode = "uv" if sch.is_newmark else "uva"

            def run_sens():
                return integrate(d, u0, v0, 0.0, d.dt, d.steps_per_period, sch, step_data=d.step_data, sensitivity=mode)

            t, _ = timed(run_sens, R)
            out[f"{name}/{sname}/period_with_monodromy"] = {"ms_per_period": 1e3 * t, "us_per_step": 1e6 * t / d.steps_per_period}
    return out


def bench_steady(P, R: int) -> dict:
    out = {}
    for name, nl in (("linear", False), ("nonlinear", True)):
        t, ss = timed(lambda: steady_state(Setup(P, nonlinear=nl)), R)
        out[f"steady_state({name}) default: shooting, {DEFAULT}"] = {
            "s": t, "periods": ss.periods, "largest_floquet_multiplier": float(abs(ss.floquet_multipliers[0]))}
    return out


def radau_from_rest(P, rtol: float, periods: int = 2, motors: bool = True) -> tuple[float, SteadyState, dict]:
    """solve_ivp Radau from rest over ``periods`` periods; the last one as a SteadyState."""
    d = LinkageDynamics(Setup(P, motors=motors))  # the same equations: M, C, K, F and f_nl at any t
    n = d.n

    def rhs(t, x):
        M, C, K, F = d._sample(np.asarray(t))
        f, _ = d.nonlinear(x[:n], t)
        return np.concatenate([x[n:], np.linalg.solve(M, F - C @ x[n:] - K @ x[:n] - f)])

    def jac(t, x):
        M, C, K, _ = d._sample(np.asarray(t))
        _, Kt = d.nonlinear(x[:n], t)
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        J[n:, :n] = -np.linalg.solve(M, K + Kt)
        J[n:, n:] = -np.linalg.solve(M, C)
        return J

    T = d.period
    t0 = time.perf_counter()
    sol = scipy.integrate.solve_ivp(rhs, (0.0, periods * T), np.zeros(2 * n), method="Radau",
                                    rtol=rtol, atol=1e-6 * rtol, jac=jac, dense_output=True)
    elapsed = time.perf_counter() - t0
    ts = np.linspace(0.0, T, d.steps_per_period + 1)
    X = sol.sol((periods - 1) * T + ts)
    ss = SteadyState(d, ts, X[:n].T, X[n:].T, "radau", periods)
    x = np.zeros(2 * n)
    t_rhs, _ = timed(lambda: rhs(0.3 * T, x), 20)
    stats = {"nfev": int(sol.nfev), "njev": int(sol.njev), "nlu": int(sol.nlu), "steps": len(sol.t) - 1,
             "success": bool(sol.success), "ms_per_rhs_evaluation": 1e3 * t_rhs}
    return elapsed, ss, stats


def bench_to_steady(P, R: int, radau_runs: int) -> dict:
    t_ref, ref_ss = timed(lambda: steady_state(Setup(P, steps_per_period=1600)), 1)
    ref = {L: ref_ss.peak_to_peak_mm(L) for L in LINKS}
    out: dict = {
        "reference": {"method": f"shooting, {scheme_name(Setup(P).scheme)}, S=1600, nonlinear",
                      "peak_to_peak_um": {L: 1e3 * v for L, v in ref.items()},
                      "largest_floquet_multiplier": float(abs(ref_ss.floquet_multipliers[0])),
                      "s_single_run": t_ref},
        "target_relative_error": 0.01,
    }
    cases = {
        f"fivebar shooting, {DEFAULT} [steady_state default]":
            lambda: steady_state(P),
        "fivebar steady_state(tol=0.01): S chosen for 1 %":
            lambda: steady_state(P, tol=0.01),
        "fivebar shooting, GeneralizedAlpha(0.8), S=50":
            lambda: steady_state(Setup(P, steps_per_period=50, scheme=GeneralizedAlpha(0.8))),
        "fivebar march from rest, GeneralizedAlpha(0.8), S=50, tol=1e-3":
            lambda: march(Setup(P, steps_per_period=50, scheme=GeneralizedAlpha(0.8)), tol=1e-3),
        f"fivebar march from rest, GeneralizedAlpha(0.8), S={P.steps_per_period}, tol=1e-3":
            lambda: march(Setup(P, scheme=GeneralizedAlpha(0.8)), tol=1e-3),
    }
    for name, fn in cases.items():
        t, ss = timed(fn, R)
        err = accuracy(ss, ref)
        out[name] = {"s": t, "periods": ss.periods, "relative_error": err,
                     "within_1_percent": bool(max(abs(e) for e in err.values()) <= 0.01)}
    if radau_runs > 0:
        rtol = 1e-3
        times = []
        for _ in range(radau_runs):
            el, ss, stats = radau_from_rest(P, rtol)
            times.append(el)
        err = accuracy(ss, ref)
        name = f"scipy solve_ivp Radau from rest, rtol={rtol:g}, atol={1e-6 * rtol:g}, 2 periods"
        out[name] = {"s": statistics.median(times), "runs": radau_runs,
                     "note": f"median of {radau_runs} run(s) only: each takes tens of seconds",
                     "relative_error": err,
                     "within_1_percent": bool(max(abs(e) for e in err.values()) <= 0.01), **stats}
        fast = [v["s"] for k, v in out.items() if k.startswith("fivebar") and v["within_1_percent"]]
        default = out[f"fivebar shooting, {DEFAULT} [steady_state default]"]["s"]
        out["ratio_radau_over_fastest_fivebar"] = out[name]["s"] / min(fast)
        out["ratio_radau_over_steady_state_default"] = out[name]["s"] / default
    return out


def bench_sweep(P, points: int, do200: bool) -> dict:
    speeds = np.linspace(*SWEEP_RANGE_RPM, points)
    t0 = time.perf_counter()
    for w in speeds:
        sweep_state(P, float(w))
    serial = time.perf_counter() - t0
    out = {
        "model": f"default (nonlinear), steady_state(): shooting, GeneralizedAlpha(0.8), S={P.steps_per_period}",
        "speeds_rpm": [SWEEP_RANGE_RPM[0], SWEEP_RANGE_RPM[1]],
        f"serial_{points}_speeds": {"s": serial, "steady_states_per_s": points / serial, "runs": 1},
        "extrapolated_200_speeds_2_processes_s": 200 * serial / points / 2,
    }
    if do200:
        sp = np.linspace(*SWEEP_RANGE_RPM, 200).tolist()
        chunks = [sp[i::2] for i in range(2)]
        t0 = time.perf_counter()
        with ProcessPoolExecutor(max_workers=2, initializer=single_blas_thread) as ex:
            res = list(ex.map(sweep_chunk, chunks))
        wall = time.perf_counter() - t0
        out["measured_200_speeds_2_processes"] = {"s": wall, "steady_states_per_s": 200 / wall, "runs": 1,
                                                   "all_finite": bool(np.all(np.isfinite(np.concatenate(res))))}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description="The per-part benchmark of the dynamics (with the targets of an "
                                 "earlier issue); bench_story.py tells the whole story of issue 10 in one run.")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--sweep-points", type=int, default=50)
    ap.add_argument("--radau-runs", type=int, default=1)
    ap.add_argument("--no-radau", action="store_true")
    ap.add_argument("--no-sweep200", action="store_true")
    args = ap.parse_args()
    R = max(args.repeats, 5)
    P = load_params()
    threadpool_limits(1)  # every timing below, peers included, with one BLAS thread
    load0 = os.getloadavg()
    t_all = time.perf_counter()
    result: dict = {
        "benchmark": "bench_dynamics",
        "model": {"crank_speed_rpm": P.crank_speed_rpm, "steps_per_period": P.steps_per_period,
                  "dofs": LinkageDynamics(Setup(P, steps_per_period=24)).n},
        "machine": {"python": sys.version.split()[0], "numpy": np.__version__, "scipy": scipy.__version__,
                    "platform": platform.platform(), "cpus": os.cpu_count()},
        "repeats": R,
        "blas_threads": 1,
    }
    result["per_step"] = bench_steps(P, R)
    result["per_period"] = bench_steady(P, R)
    result["to_steady_state"] = bench_to_steady(P, R, 0 if args.no_radau else args.radau_runs)
    result["sweep"] = bench_sweep(P, max(args.sweep_points, 50), not args.no_sweep200)
    ps = result["per_step"]
    tss = result["to_steady_state"]
    sw = result["sweep"]
    result["targets"] = {
        "us_per_step_nonlinear_le_200": {
            "measured_us": ps["nonlinear/newmark/full"]["us_per_step"],
            "met": ps["nonlinear/newmark/full"]["us_per_step"] <= 200},
        "radau_ratio_ge_10": {"measured": tss.get("ratio_radau_over_fastest_fivebar"),
                              "met": (tss.get("ratio_radau_over_fastest_fivebar") or 0) >= 10},
        "sweep_200_speeds_2_cores_le_40_s": {
            "measured_s": sw.get("measured_200_speeds_2_processes", {}).get("s"),
            "extrapolated_s": sw["extrapolated_200_speeds_2_processes_s"],
            "met": (sw.get("measured_200_speeds_2_processes", {}).get("s")
                    or sw["extrapolated_200_speeds_2_processes_s"]) <= 40},
    }
    result["load_average_start_end"] = [round(load0[0], 2), round(os.getloadavg()[0], 2)]
    result["total_s"] = time.perf_counter() - t_all
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
