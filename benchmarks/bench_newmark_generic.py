"""Time per step of the generic Newmark integrator (lib/fivebar/numerics/newmark.py); prints JSON.

Cases (n = 100 DOFs by default, random SPD mass and stiffness, Rayleigh damping):
  lti            time-invariant linear: one factorisation, one triangular solve per step
  tv_direct      time-varying K(t) = K0 + cos(Om t) K1, matrices evaluated and the tangent
                 factorised at every step
  tv_step_data   the same system with the S per-step matrices of one period precomputed
                 (PeriodicStepData): factorisations cached, later periods cost solves only
  nl_full        tv_step_data plus a cubic nonlinearity, full Newton (refactorised)
  nl_modified    the same, modified Newton (cached linear tangent)
  tv_monodromy   one period of tv_step_data with the 2n x 2n monodromy (sensitivity="uv")
  tv_monodromy_blas_default   the same with the BLAS thread pools left alone
                 (integrate(blas_threads=None)); the other cases run with 1 BLAS thread
Each number is the median over >= 5 runs of (wall time / steps), in microseconds.

Usage: python benchmarks/bench_newmark_generic.py [--n 100] [--repeats 5] [--blas-threads K]
(--blas-threads sets OPENBLAS_NUM_THREADS/OMP_NUM_THREADS before numpy is imported.)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--steps-per-period", type=int, default=100)
    ap.add_argument("--periods", type=int, default=10)
    ap.add_argument("--blas-threads", type=int, default=None)
    args = ap.parse_args()
    if args.blas_threads is not None:
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ[var] = str(args.blas_threads)

    import numpy as np

    from fivebar.numerics.newmark import integrate
    from fivebar.numerics.schemes import Newmark
    from fivebar.numerics.systems import PeriodicStepData, System

    n, S, P, R = args.n, args.steps_per_period, args.periods, max(args.repeats, 5)
    rng = np.random.default_rng(0)

    def spd(scale: float) -> np.ndarray:
        A = rng.standard_normal((n, n))
        return scale * (A @ A.T / n + np.eye(n))

    M, K0 = spd(1.0), spd(1e4)
    K1 = 0.1 * spd(1e4)
    C = 1e-3 * K0 + 0.1 * M
    Om = 2 * np.pi * 25.0  # 25 Hz: the period T = 0.04 s
    T = 2 * np.pi / Om
    dt = T / S
    f = rng.standard_normal(n)
    k3 = 1e6 * rng.random(n)

    def force(t: float) -> np.ndarray:
        return np.sin(Om * t) * f

    def nonlinear(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return k3 * u**3, np.diag(3 * k3 * u**2)

    lti = System(M, C, K0, force=force)
    tv = System(M, C, lambda t: K0 + np.cos(Om * t) * K1, force=force)
    tvn = System(M, C, lambda t: K0 + np.cos(Om * t) * K1, force=force, nonlinear=nonlinear)
    sd = PeriodicStepData.from_system(tv, 0.0, T, S)
    u0, v0 = np.zeros(n), np.zeros(n)

    def timed(fun, nsteps: int) -> dict:
        fun()  # warm-up (fills caches, e.g. the step data's factorisations)
        ts = []
        for _ in range(R):
            t = time.perf_counter()
            fun()
            ts.append((time.perf_counter() - t) / nsteps * 1e6)
        return {"median_us_per_step": float(np.median(ts)), "min_us_per_step": float(np.min(ts)),
                "runs": R, "steps": nsteps}

    N = S * P
    sch = Newmark()
    out = {
        "benchmark": "bench_newmark_generic",
        "n_dof": n,
        "steps_per_period": S,
        "scheme": "Newmark(gamma=0.5, beta=0.25)",
        "blas_threads_env": os.environ.get("OPENBLAS_NUM_THREADS"),
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "machine": platform.machine(),
        "load_average_1min": os.getloadavg()[0],
        "cases": {
            "lti": timed(lambda: integrate(lti, u0, v0, 0.0, dt, N, sch, store="last"), N),
            "tv_direct": timed(lambda: integrate(tv, u0, v0, 0.0, dt, N, sch, store="last"), N),
            "tv_step_data": timed(lambda: integrate(tv, u0, v0, 0.0, dt, N, sch, step_data=sd,
                                                    store="last"), N),
            "nl_full": timed(lambda: integrate(tvn, u0 + 0.03, v0, 0.0, dt, N, sch, step_data=sd,
                                               store="last"), N),
            "nl_modified": timed(lambda: integrate(tvn, u0 + 0.03, v0, 0.0, dt, N, sch,
                                                   step_data=sd, newton="modified",
                                                   store="last"), N),
            "tv_monodromy": timed(lambda: integrate(tv, u0, v0, 0.0, dt, S, sch, step_data=sd,
                                                    sensitivity="uv", store="last"), S),
            "tv_monodromy_blas_default": timed(lambda: integrate(tv, u0, v0, 0.0, dt, S, sch,
                                                                 step_data=sd, sensitivity="uv",
                                                                 store="last", blas_threads=None), S),
        },
    }
    r = integrate(tvn, u0 + 0.03, v0, 0.0, dt, N, sch, step_data=sd)
    r2 = integrate(tvn, u0 + 0.03, v0, 0.0, dt, N, sch, step_data=sd, newton="modified")
    out["newton_iterations_mean"] = {"full": float(r.iterations.mean()),
                                     "modified": float(r2.iterations.mean())}
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
