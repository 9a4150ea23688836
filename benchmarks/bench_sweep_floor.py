"""Issue 33's sweep: what a row of ``speed_sweep(Setup(params), speeds)`` costs, and what the ways
round it measured.

The sweep of the parameter file's set-up (motors on, nonlinear, S = 800) over 200 speeds from 10
to 600 r/min solves each speed by shooting from the static start and reports each orbit's
largest Floquet multiplier.  This script measures, in one process, one BLAS thread:

  period_ms    one period at S = 800 and S = 400, without and with the monodromy matrix (the
               2 n sensitivity directions of (u, v)), from the orbit at 300 and 600 r/min
               (medians of ``--repeats``)
  cold_rows    ``sweep_point`` (the sweep's row) at every tenth of the 200 speeds and at 600
               r/min (21 speeds), at S = 800 and S = 400: milliseconds a row, the part of them
               not spent in periods (the model at the new speed, the static start, the
               quasi-static response, the amplitudes and the validity checks), the periods a
               row integrates (shooting's periods, and one with the monodromy matrix for the
               multipliers where the last period did not carry it), and the milliseconds of
               shooting and the multipliers alone (as ``warm_chain`` times its rows)
  warm_chain   the speeds of two stretches of the 200 (40 consecutive speeds each, about 247-361
               and 484-600 r/min) solved one after the other at S = 800, each from the orbit of
               the speed before (the warm start's predictor, ``steady._predict``: scaled as the
               quasi-static response scales with the speed, and the secant through the two
               before) with that orbit's monodromy matrix as the
               first Jacobian of the chord iteration (``fivebar.analyses.steady._shooting``'s
               ``monodromy``, what ``steady_state(..., tol=..., start=...)`` does at each S): the
               periods and milliseconds a row, against the rows from the static start at the
               same speeds, and the largest difference of their peak-to-peak values (times:
               shooting and the multipliers, the row's other costs left out)
  fixed_S      the rows' L2 and L3 peak-to-peak values at S = 200, 400 and 800 against S = 1600
               at the 21 speeds: the largest relative difference of each S, and where
  floor        a row started on its orbit exactly (a perfect predictor): one period with the
               monodromy matrix, which checks the periodicity and gives the multipliers, and the
               row's other costs as measured, times 200 speeds over 2 processes, at S = 800 and
               400: what no predictor can go below while each row reports its own multipliers

Private names of the library are used (the script fails loudly if one is renamed).

Usage: python benchmarks/bench_sweep_floor.py [--repeats 5] [--out benchmarks/results/sweep_floor.json]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from fivebar import load_params, steady_state  # noqa: E402
from fivebar.analyses import steady  # noqa: E402
from fivebar.analyses.sweep import sweep_point  # noqa: E402
from fivebar.description.setup import Setup  # noqa: E402
from fivebar.model.dynamics import linkage_dynamics  # noqa: E402

SPEEDS = np.linspace(10.0, 600.0, 200)  # the sweep of bench_story.sweep_default_cost
CHECKED = sorted(set(range(0, 200, 10)) | {199})  # every tenth speed, and 600 r/min
STRETCHES = (range(80, 120), range(160, 200))
LINKS = ("L2", "L3")


def _median_ms(run, repeats):
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        run()
        ts.append(time.perf_counter() - t)
    return 1e3 * statistics.median(ts)


def _worst(a, b) -> float:
    """Largest relative difference of the L2 and L3 peak-to-peak values of two results."""
    return max(abs(a.peak_to_peak_mm(L) / b.peak_to_peak_mm(L) - 1.0) for L in LINKS)


def period_ms(p, repeats):
    out = {}
    for S in (800, 400):
        for rpm in (300.0, 600.0):
            s = Setup(p, crank_speed_rpm=rpm, steps_per_period=S)
            orbit = steady_state(s)
            dyn = linkage_dynamics(s)
            n = dyn.n
            x = np.concatenate([orbit.u[0], orbit.v[0]])
            steady._period(dyn, x[:n], x[n:], s.scheme, store="last")  # (warm)
            out[f"S{S}_{rpm:g}rpm"] = {
                "plain": _median_ms(lambda: steady._period(dyn, x[:n], x[n:], s.scheme, store="last"), repeats),
                "monodromy": _median_ms(lambda: steady._monodromy_period(dyn, x, s.scheme, store="last"), repeats),
                "n": n}
    return out


def cold_rows(p):
    """The rows as the sweep makes them: their time, the part of it in periods (``steady._period``
    wrapped for the run: a period with the monodromy matrix passes through it too), and the
    periods a row integrates."""
    spent = [0.0]
    inner = steady._period

    def timed(*args, **kwargs):
        t = time.perf_counter()
        try:
            return inner(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - t

    out = {}
    for S in (800, 400):
        ms, other, periods, shooting = [], [], [], []
        for i in CHECKED:
            s = Setup(p, crank_speed_rpm=float(SPEEDS[i]), steps_per_period=S)
            steady._period, spent[0] = timed, 0.0
            try:
                t = time.perf_counter()
                sweep_point(s)  # the row as the sweep makes it, timed
                ms.append(1e3 * (time.perf_counter() - t))
            finally:
                steady._period = inner
            other.append(ms[-1] - 1e3 * spent[0])
            t = time.perf_counter()  # the same orbit and its multipliers alone, its periods counted
            st = steady._shooting(s, None, None, 1e-10, 20)
            extra = _own_monodromy(st)[1]
            shooting.append(1e3 * (time.perf_counter() - t))
            periods.append(st.periods + extra)
        out[f"S{S}"] = {"speeds": len(CHECKED), "ms_per_row_median": statistics.median(ms),
                        "ms_per_row_mean": float(np.mean(ms)), "periods_per_row_mean": float(np.mean(periods)),
                        "other_ms_per_row_median": statistics.median(other),
                        "shooting_ms_per_row_mean": float(np.mean(shooting))}
    return out


def _own_monodromy(st):
    """The monodromy matrix at a shot orbit: the one its last period carried, or one more period."""
    if "monodromy" in st._cache:
        return st._cache["monodromy"], 0
    f = st._floquet
    Phi = f()
    st._floquet = steady._Constant(Phi)
    return Phi, (0 if isinstance(f, steady._Constant) else 1)


def warm_chain(p):
    out = {}
    for stretch in STRETCHES:
        prev = before = None
        ms, periods, cold_ms, cold_periods, worst = [], [], [], [], 0.0
        for i in stretch:
            rpm = float(SPEEDS[i])
            s = Setup(p, crank_speed_rpm=rpm)
            S = s.steps_per_period
            # from the static start (the sweep as it is), for the comparison
            t = time.perf_counter()
            cold = steady._shooting(s, None, None, 1e-10, 20)
            _, extra = _own_monodromy(cold)
            cold_ms.append(1e3 * (time.perf_counter() - t))
            cold_periods.append(cold.periods + extra)
            t = time.perf_counter()
            if prev is None:
                st = steady._shooting(s, None, None, 1e-10, 20)
            else:  # the library's predictor of a warm start (steady._predict), from the last two orbits
                memo = {"x": {S: np.concatenate([prev.u[0], prev.v[0]])}, "rpm": prev_rpm, "before": before}
                x = steady._predict(memo, S, rpm)
                n = len(x) // 2
                st = steady._shooting(s, x[:n], x[n:], 1e-10, 20, monodromy=prev_Phi)
            Phi, extra = _own_monodromy(st)
            ms.append(1e3 * (time.perf_counter() - t))
            periods.append(st.periods + extra)
            worst = max(worst, _worst(st, cold))
            if prev is not None:
                before = {"x": {S: np.concatenate([prev.u[0], prev.v[0]])}, "rpm": prev_rpm}
            prev, prev_rpm, prev_Phi = st, rpm, Phi
        # the first row of a stretch has no predictor: left out of the means
        out[f"{SPEEDS[stretch[0]]:.0f}-{SPEEDS[stretch[-1]]:.0f}rpm"] = {
            "speeds": len(stretch), "step_rpm": float(SPEEDS[1] - SPEEDS[0]),
            "warm_ms_per_row_mean": float(np.mean(ms[1:])), "warm_periods_per_row_mean": float(np.mean(periods[1:])),
            "cold_ms_per_row_mean": float(np.mean(cold_ms[1:])), "cold_periods_per_row_mean": float(np.mean(cold_periods[1:])),
            "largest_difference_warm_vs_cold": worst}
    return out


def fixed_S(p):
    worst = {S: (0.0, None) for S in (200, 400, 800)}
    for i in CHECKED:
        rpm = float(SPEEDS[i])
        ref = steady_state(Setup(p, crank_speed_rpm=rpm, steps_per_period=1600))
        for S in worst:
            e = _worst(steady_state(Setup(p, crank_speed_rpm=rpm, steps_per_period=S)), ref)
            if e > worst[S][0]:
                worst[S] = (e, rpm)
    return {f"S{S}": {"largest_difference_vs_S1600": e, "at_rpm": rpm, "speeds": len(CHECKED)}
            for S, (e, rpm) in worst.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits

    warnings.simplefilter("ignore")  # (the high speeds are outside the model's validity: ValidityWarning)
    load0 = os.getloadavg()
    p = load_params()
    res = {"benchmark": "bench_sweep_floor", "command": "python benchmarks/bench_sweep_floor.py " + " ".join(sys.argv[1:]),
           "python": platform.python_version(), "numpy": np.__version__, "cpus": os.cpu_count(),
           "setup": "the parameter file's: motors on, nonlinear, S = 800 unless a row says another S"}
    with threadpool_limits(1):
        sweep_point(Setup(p, crank_speed_rpm=100.0))  # (the compiled loop loaded)
        res["period_ms"] = period_ms(p, args.repeats)
        res["cold_rows"] = cold_rows(p)
        res["warm_chain"] = warm_chain(p)
        res["fixed_S"] = fixed_S(p)
    res["floor"] = {}
    for S in (800, 400):
        mono = statistics.mean(res["period_ms"][f"S{S}_{r}rpm"]["monodromy"] for r in ("300", "600"))
        other = res["cold_rows"][f"S{S}"]["other_ms_per_row_median"]
        res["floor"][f"S{S}"] = {"monodromy_period_ms": mono, "other_ms": other,
                                 "periods_only_sweep_s_on_2_processes": 200 * mono / 2e3,
                                 "sweep_s_on_2_processes": 200 * (mono + other) / 2e3}
    res["load"] = {"start": load0, "end": os.getloadavg()}
    text = json.dumps(res, indent=1)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
