"""The period map of the modal equations (3.4): the compiled loop against the Python loop; prints JSON.

The same forced Duffing oscillator as chapter 13 (``ModalSystem(w=[1], zeta=[0.05],
gamma=[[[[-1]]]])``, ``Harmonic(1.0, [0.1])``, S = 200 steps per period), two ways in one
process:

  compiled   ``modal_period_map``: K(t), F(t) sampled at the step times, the polynomial force
             compiled (``fivebar.numerics._polynomial_kernel``), the compiled loop
  python     the same equation as a ``System`` of Python functions (the force F cos(p t), the
             cubic force and its tangent as lambdas) through ``newmark_map``: the Python loop,
             calling them at every step and Newton iteration (how ``modal_period_map`` ran
             before the polynomial force was compiled)

and for each: one period with the monodromy matrix (``jacobian=True``) and without, and the
pseudo-arclength continuation of chapter 13 (p from 1.0 to 1.4, ds 0.05, ds_max 0.3: 38
points, two folds).  Medians over ``--repeats`` runs; the largest difference of the two maps'
states after a period (relative), and the folds of both continuations.

Usage: python benchmarks/bench_modal_map.py [--repeats 5] [--out benchmarks/results/modal_map.json]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from fivebar.numerics.continuation import continuation  # noqa: E402
from fivebar.numerics.modal_equations import Harmonic, ModalSystem  # noqa: E402
from fivebar.numerics.periodic import PeriodicProblem, modal_period_map, newmark_map  # noqa: E402
from fivebar.numerics.systems import System  # noqa: E402

ZETA, ALPHA, F, S = 0.05, 1.0, 0.1, 200


def maps():
    compiled = modal_period_map(ModalSystem(w=[1.0], zeta=[ZETA], gamma=np.full((1, 1, 1, 1), -ALPHA)),
                                [Harmonic(1.0, [F])], steps=S)

    def family(p):
        sysm = System(np.eye(1), [[2 * ZETA]], np.eye(1), force=lambda t: [F * math.cos(p * t)],
                      nonlinear=lambda u: (ALPHA * u ** 3, np.array([[3 * ALPHA * u[0] ** 2]])))
        return PeriodicProblem(sysm, 2 * math.pi / p, S)
    return {"compiled": compiled, "python": newmark_map(family)}


def median_ms(fn, repeats, warm=True):
    """Median wall time (ms) of ``repeats`` calls of ``fn`` (after one untimed call if ``warm``),
    and the last call's result."""
    if warm:
        fn()  # compiled code loaded, the problem at this p built
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return 1e3 * statistics.median(ts), out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    x, p = np.array([0.4, -0.2]), 1.2
    out = {"benchmark": "bench_modal_map", "command": " ".join([Path(sys.argv[0]).name] + sys.argv[1:]),
           "python": platform.python_version(), "numpy": np.__version__, "S": S, "repeats": args.repeats,
           "cases": {}}
    states, folds = {}, {}
    for name, f in maps().items():
        period, (xT, _) = median_ms(lambda: f(x, p, False), args.repeats)
        states[name] = xT
        with_monodromy, _ = median_ms(lambda: f(x, p, True), args.repeats)
        # (the periods above loaded the compiled code: the continuation is timed from its first run)
        branch_ms, branch = median_ms(lambda: continuation(f, np.zeros(2), 1.0, 1.4, ds=0.05, ds_max=0.3),
                                      args.repeats, warm=False)
        folds[name] = sorted(b.p for b in branch.bifurcations if b.kind == "fold")
        out["cases"][name] = {"period_ms": period, "period_with_monodromy_ms": with_monodromy,
                              "continuation_s": branch_ms / 1e3, "continuation_points": len(branch.points),
                              "folds": folds[name]}
    c, py = out["cases"]["compiled"], out["cases"]["python"]
    out["speed_up"] = {k: py[k] / c[k] for k in ("period_ms", "period_with_monodromy_ms", "continuation_s")}
    out["state_difference_relative"] = float(np.abs(states["compiled"] - states["python"]).max()
                                             / np.abs(states["python"]).max())
    out["fold_difference"] = float(np.abs(np.subtract(folds["compiled"], folds["python"])).max())
    text = json.dumps(out, indent=1)
    print(text)
    if args.out is not None:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
