"""Where the time of a first ``steady_state(setup, tol=0.01)`` goes, beside the multibody peer.

At 300 and 600 r/min (motors off, nonlinear: the question of ``bench_story.py``'s Exudyn
section), each run starts from an empty library store (``fivebar.clear_cache()``: a first call
in a process, the compiled kernels already loaded from numba's cache).  The run's phases are
timed by wrapping, for the duration of the measurement, these functions of the library (private
names: the script fails loudly if one is renamed):

  build              ``fivebar.model.dynamics.LinkageDynamics.__init__``: the model (first S
                     only), its M, C, K, F at the new step times of each S of the ladder and the
                     frozen modes of the modal damping there
  start              ``fivebar.analyses.steady._initial_state``: the static equilibrium the first
                     orbit starts from
  monodromy periods  ``fivebar.analyses.steady._monodromy_period``: a period carrying the
                     sensitivities along the 2 n directions of (u, v) (count and time)
  plain periods      ``fivebar.analyses.steady._period`` without sensitivities (count and time)
  Newton step        ``fivebar.analyses.steady._newton_step``: the SVD of Phi - I
  estimate           ``fivebar.analyses.steady._deflection_change``: S/2 against S
  other              the rest: validation, the store's bookkeeping, the result's checks

On the peer's footing: the peer's setting was found by a convergence study against its own
converged answer, and its run estimates no error.  ``same_footing`` does the same for the library:
``steady_state(setup)`` at the fixed S = 25, 50, 100, ... (no ``tol``), the first whose midpoint
curves of L2 and L3 are within 1 % of its S = 3200 orbit (``bench_story._curve_error``, the
measure the peer's ladder used) timed as a first call, phase by phase like the call with ``tol``,
and at new speeds 1 % apart (the model's samples in the store).

Each phase is the median over ``--repeats`` runs of its own time (so the phases need not add up
to the median total; ``other`` is the median of each run's remainder).  The peer is Exudyn at
the coarsest setting within 1 % that ``bench_story.py`` found and recorded in
``benchmarks/results/story.json`` (mesh, steps per period, run-up), timed here in the same
process (median of ``--peer-repeats``); ``budget_ms`` is a third of it (issue 33's target of
three times faster).  One BLAS thread.

Usage: python benchmarks/bench_first_call.py [--repeats 15] [--out benchmarks/results/first_call.json]
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
from collections import defaultdict  # noqa: E402
from contextlib import contextmanager  # noqa: E402
from pathlib import Path  # noqa: E402

import fivebar  # noqa: E402
from fivebar import load_params, steady_state  # noqa: E402
from fivebar.analyses import steady  # noqa: E402
from fivebar.description.setup import Setup  # noqa: E402
from fivebar.model import dynamics  # noqa: E402

# the tolerance that stops the peer at its first check, for the setting bench_story.py recorded
# with periodicity_tol None (one constant: Python puts this script's folder, benchmarks/, on the path)
from bench_story import FIRST_CHECK  # noqa: E402

STORY = Path(__file__).parent / "results" / "story.json"
PHASES = ("build", "start", "monodromy periods", "plain periods", "Newton step", "estimate")


@contextmanager
def timed_phases(acc: dict, counts: dict):
    """Wrap the library's phase functions; ``acc[phase]`` adds seconds, ``counts[phase]`` calls."""
    def wrap(owner, name, phase, counted=lambda *a, **k: True):
        original = getattr(owner, name)

        def wrapper(*args, **kwargs):
            if not counted(*args, **kwargs):
                return original(*args, **kwargs)
            t = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                acc[phase] += time.perf_counter() - t
                counts[phase] += 1
        setattr(owner, name, wrapper)
        return owner, name, original

    plain = lambda *a, **k: not (k.get("sensitivity") or (len(a) > 5 and a[5]))  # noqa: E731
    saved = [wrap(dynamics.LinkageDynamics, "__init__", "build"),
             wrap(steady, "_initial_state", "start"),
             wrap(steady, "_monodromy_period", "monodromy periods"),
             wrap(steady, "_period", "plain periods", plain),
             wrap(steady, "_newton_step", "Newton step"),
             wrap(steady, "_deflection_change", "estimate")]
    try:
        yield
    finally:
        for owner, name, original in reversed(saved):
            setattr(owner, name, original)


def first_calls(rpm: float, repeats: int, steps_per_period: int | None = None) -> dict:
    """A first call's phases: ``steady_state(setup, tol=0.01)``, or with ``steps_per_period``
    the plain call at that S (no error estimate)."""
    s = Setup(load_params(), crank_speed_rpm=rpm, motors=False)
    if steps_per_period is None:
        call = lambda: steady_state(s, tol=0.01)  # noqa: E731
    else:
        s = s.replace(steps_per_period=steps_per_period)
        call = lambda: steady_state(s)  # noqa: E731
    call()  # the compiled kernels loaded once
    runs = []
    for _ in range(repeats):
        acc, counts = defaultdict(float), defaultdict(int)
        fivebar.clear_cache()
        with timed_phases(acc, counts):
            t = time.perf_counter()
            r = call()
            total = time.perf_counter() - t
        runs.append({"total": total, "acc": dict(acc), "counts": dict(counts)})
    med = lambda xs: 1e3 * statistics.median(xs)  # noqa: E731
    phases = {p: med([run["acc"].get(p, 0.0) for run in runs]) for p in PHASES}
    phases["other"] = med([run["total"] - sum(run["acc"].values()) for run in runs])
    return {"total_ms": med([run["total"] for run in runs]), "phases_ms": phases,
            "calls": {p: runs[0]["counts"].get(p, 0) for p in PHASES},
            "S": r.dynamics.steps_per_period, "tried": r.accuracy["tried"] if r.accuracy else None, "n": r.dynamics.n,
            "periods_ms": phases["monodromy periods"] + phases["plain periods"]}


#: the fixed S tried on the peer's footing, coarsest first
FOOTING_STEPS = (25, 50, 100, 200, 400, 800)


def same_footing(rpm: float, repeats: int) -> dict:
    """The library at its coarsest fixed S within 1 % of its S = 3200 orbit (the ladder tried and
    the errors), that S's first call (:func:`first_calls`), and a new speed there: the median of
    ``repeats`` calls at speeds 1 %, 2 %, ... above ``rpm`` after the one at ``rpm`` (the model's
    samples, which do not depend on the speed, in the store; no warm start: at a fixed S the
    library takes none)."""
    from bench_story import _curve_error

    s = Setup(load_params(), crank_speed_rpm=rpm, motors=False)
    ref = steady_state(s.replace(steps_per_period=3200))
    ladder = []
    for S in FOOTING_STEPS:
        ladder.append({"S": S, "error": _curve_error(steady_state(s.replace(steps_per_period=S)), ref)})
        if ladder[-1]["error"] <= 0.01:
            out = {"ladder": ladder, "S": S, "error": ladder[-1]["error"], **first_calls(rpm, repeats, S)}
            fivebar.clear_cache()
            s = s.replace(steps_per_period=S)
            steady_state(s)
            ts = []
            for k in range(1, repeats + 1):
                t = time.perf_counter()
                steady_state(s.replace(crank_speed_rpm=rpm * (1.0 + 0.01 * k)))
                ts.append(time.perf_counter() - t)
            out["new_speed_ms"] = 1e3 * statistics.median(ts)
            return out
    return {"ladder": ladder, "S": None}


def peer(rpm: float, setting: dict, repeats: int) -> dict:
    from fivebar.analyses.multibody import multibody_steady_state
    p = load_params()

    def run():
        return multibody_steady_state(
            Setup(p, crank_speed_rpm=rpm, steps_per_period=25, elements_per_link=tuple(setting["mesh"])),
            integration_steps=setting["steps_per_period"], ramp_periods=setting["ramp_periods"],
            tol=setting["periodicity_tol"] if setting["periodicity_tol"] is not None else FIRST_CHECK)
    run()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        run()
        ts.append(time.perf_counter() - t)
    return {"setting": setting, "ms": 1e3 * statistics.median(ts)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--peer-repeats", type=int, default=5)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits

    story = json.loads(STORY.read_text()) if STORY.exists() else {}
    load0 = os.getloadavg()
    res = {"benchmark": "bench_first_call", "command": "python benchmarks/bench_first_call.py " + " ".join(sys.argv[1:]),
           "python": platform.python_version(), "cpus": os.cpu_count(), "repeats": args.repeats}
    warnings.simplefilter("ignore")  # (600 r/min is outside the model's validity: ValidityWarning)
    with threadpool_limits(1):
        for rpm in (300.0, 600.0):
            entry = first_calls(rpm, args.repeats)
            setting = story.get("exudyn_ms", {}).get(f"{rpm:g}rpm", {}).get("exudyn_coarsest_within_1pct")
            try:
                import exudyn  # noqa: F401
            except ImportError:
                setting = None
            if setting is not None:
                entry["exudyn"] = peer(rpm, {k: setting[k] for k in ("mesh", "steps_per_period", "ramp_periods",
                                                                     "periodicity_tol")}, args.peer_repeats)
                entry["budget_ms"] = entry["exudyn"]["ms"] / 3.0
                entry["ratio_exudyn_over_first_call"] = entry["exudyn"]["ms"] / entry["total_ms"]
            entry["same_footing"] = footing = same_footing(rpm, args.repeats)
            if setting is not None and footing["S"] is not None:
                footing["ratio_exudyn_over_first_call"] = entry["exudyn"]["ms"] / footing["total_ms"]
                footing["ratio_exudyn_over_new_speed"] = entry["exudyn"]["ms"] / footing["new_speed_ms"]
            res[f"{rpm:g}rpm"] = entry
    res["load"] = {"start": load0, "end": os.getloadavg()}
    text = json.dumps(res, indent=1)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
