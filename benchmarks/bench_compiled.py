"""Time the compiled time step (issue 10, first part) against the Python/numpy path, in one process.

Prints one JSON object (and writes it with ``--out``).  Sections:

  step_us          one period (S = 100 steps) of the default model (parameter file) started on
                   its periodic orbit, microseconds per step: linear (cached LU, one solve per
                   step) and nonlinear (full Newton), Newmark (average acceleration) and
                   GeneralizedAlpha(0.8); "compiled" is ``integrate`` as every caller gets it,
                   "python" the same call with the compiled kernels switched off
                   (``fivebar.numerics.newmark._USE_KERNELS = False``), the peer in the same process.
  steady_state_ms  one whole ``steady_state(Setup(params, crank_speed_rpm=..., nonlinear=...))`` call
                   (model construction included) at 60, 300 and 600 r/min, compiled and python.
  import_s         ``import fivebar`` in a fresh interpreter (a subprocess; warm file cache).
  numba_s          the first ``integrate`` call of a fresh interpreter with an empty numba cache
                   directory (compile), and again with that directory filled (cache hit), minus
                   the same call once warm.
  load             ``os.getloadavg()`` at the start and end: the machine may be shared.

Every timing is the median of ``--repeats`` runs (time.perf_counter), one BLAS thread.

Usage: python benchmarks/bench_compiled.py [--repeats 7] [--out benchmarks/results/compiled.json]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from fivebar.description.setup import Setup  # noqa: E402


def _median_time(fn, repeats: int) -> float:
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts)


def _set_kernels(on: bool) -> bool:
    import fivebar.numerics.newmark as nm
    if not hasattr(nm, "_USE_KERNELS"):  # a version without compiled kernels
        return on is False
    nm._USE_KERNELS = on
    return True


def step_costs(repeats: int) -> dict:
    from fivebar import load_params
    from fivebar.model.dynamics import LinkageDynamics
    from fivebar.numerics.newmark import integrate
    from fivebar.numerics.schemes import GeneralizedAlpha, Newmark
    from fivebar.analyses.steady import shooting

    p = load_params()
    out: dict = {}
    for nonlinear in (False, True):
        dyn = LinkageDynamics(Setup(p, nonlinear=nonlinear))
        for name, scheme in (("newmark", Newmark()), ("galpha0.8", GeneralizedAlpha(0.8))):
            orbit = shooting(dyn.setup.replace(scheme=scheme))
            u0, v0 = orbit.u[0], orbit.v[0]
            key = f"{'nonlinear' if nonlinear else 'linear'}_{name}"
            row = {}
            for path in ("compiled", "python"):
                if not _set_kernels(path == "compiled"):
                    continue

                def run():
                    integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps_per_period, scheme, step_data=dyn.step_data,
                              store="all")
                run()  # compile / fill the LU cache
                row[path] = 1e6 * _median_time(run, repeats) / dyn.steps_per_period
            res = integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps_per_period, scheme, step_data=dyn.step_data)
            row["newton_iterations_per_step"] = float(res.iterations.mean())
            if "python" in row and "compiled" in row:
                row["speedup"] = row["python"] / row["compiled"]
            out[key] = row
            _set_kernels(True)
    return out


def steady_costs(repeats: int) -> dict:
    from fivebar import load_params, steady_state
    from fivebar.numerics.schemes import GeneralizedAlpha

    p = load_params()
    out: dict = {}
    # "default": steady_state(Setup(params, crank_speed_rpm=rpm, nonlinear=...)) as it stands;
    # "motors_off_galpha": the setting of issue 10's table (motors off, GeneralizedAlpha(0.8))
    settings = {"default": {}, "motors_off_galpha": dict(motors=False,
                                                         scheme=GeneralizedAlpha(0.8))}
    for rpm, nonlinear, (sname, kw) in itertools.product((60.0, 300.0, 600.0), (False, True),
                                                         settings.items()):
        key = f"{'nonlinear' if nonlinear else 'linear'}_{rpm:g}rpm_{sname}"
        row = {}
        for path in ("compiled", "python"):
            if not _set_kernels(path == "compiled"):
                continue
            try:
                steady_state(Setup(p, crank_speed_rpm=rpm, nonlinear=nonlinear, **kw))
                row[path] = 1e3 * _median_time(
                    lambda: steady_state(Setup(p, crank_speed_rpm=rpm, nonlinear=nonlinear, **kw)),
                    max(3, repeats // 2))
            except Exception as exc:  # noqa: BLE001 - reported, not hidden
                row[path + "_error"] = f"{type(exc).__name__}: {str(exc)[:200]}"
        if "python" in row and "compiled" in row:
            row["speedup"] = row["python"] / row["compiled"]
        out[key] = row
        _set_kernels(True)
    return out


def import_time(repeats: int, statement: str = "import fivebar") -> dict:
    code = f"import time; t = time.perf_counter(); {statement}; print(time.perf_counter() - t)"
    ts = [float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                               check=True).stdout) for _ in range(repeats)]
    return {"statement": statement, "median": statistics.median(ts), "min": min(ts),
            "max": max(ts)}


_FIRST_CALL = r"""
import time, json
from fivebar import load_params
from fivebar.model.dynamics import LinkageDynamics
from fivebar.numerics.newmark import integrate
from fivebar.numerics.schemes import GeneralizedAlpha
import numpy as np
dyn = LinkageDynamics(load_params())
u0 = np.zeros(dyn.n)
def call(scheme, sens):
    return integrate(dyn, u0, u0, 0.0, dyn.dt, dyn.steps_per_period, scheme, step_data=dyn.step_data,
                     sensitivity=sens)
t = time.perf_counter(); call(None, True); call(GeneralizedAlpha(0.8), True); first = time.perf_counter() - t
t = time.perf_counter(); call(None, True); call(GeneralizedAlpha(0.8), True); warm = time.perf_counter() - t
print(json.dumps({"first": first, "warm": warm}))
"""


def numba_compile() -> dict:
    try:
        import fivebar.numerics._kernels  # noqa: F401
    except ImportError:
        return {"note": "no compiled kernels in this version"}
    with tempfile.TemporaryDirectory() as d:
        env = dict(os.environ, NUMBA_CACHE_DIR=d)
        runs = []
        for _ in range(2):
            r = subprocess.run([sys.executable, "-c", _FIRST_CALL], capture_output=True, text=True,
                               env=env, check=True)
            runs.append(json.loads(r.stdout))
    return {"cold_compile": runs[0]["first"] - runs[0]["warm"],
            "cache_hit_load": runs[1]["first"] - runs[1]["warm"],
            "note": "first integrate calls (Newmark and generalised-alpha, with sensitivity) of a "
                    "fresh interpreter minus the same calls warm; empty cache dir, then filled"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--out", default=None, help="also write the JSON to this file")
    ap.add_argument("--skip-steady", action="store_true")
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits

    load0 = os.getloadavg()
    with threadpool_limits(1):
        import numpy
        import fivebar
        res = {
            "benchmark": "bench_compiled",
            "command": "python benchmarks/bench_compiled.py " + " ".join(sys.argv[1:]),
            "python": platform.python_version(), "numpy": numpy.__version__,
            "cpus": os.cpu_count(), "repeats": args.repeats,
            "fivebar_file": fivebar.__file__,
            "step_us": step_costs(args.repeats),
        }
        if not args.skip_steady:
            res["steady_state_ms"] = steady_costs(args.repeats)
    res["import_s"] = import_time(args.repeats)
    res["import_steady_state_s"] = import_time(args.repeats, "from fivebar import steady_state")
    res["numba_s"] = numba_compile()
    res["load"] = {"start": load0, "end": os.getloadavg()}
    text = json.dumps(res, indent=1)
    print(text)
    if args.out:
        os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
        with open(args.out, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
