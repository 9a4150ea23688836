"""KED (library) against the fully coupled multibody model (Exudyn) over crank speed.

Writes data/multibody_sweep.json (read by book/11_multibody.ipynb) and prints it.
Run:  .venv/bin/python benchmarks/multibody_sweep.py   (about 15-25 min on one core)

For each orientation of the section (30 mm or 2 mm side in the plane of motion) and each crank
speed: peak-to-peak midpoint deflections of L2 and L3 (transverse and relative to the chord,
mm) of
  * the library's KED steady state (shooting, generalised-alpha rho_inf = 0.8, motors=False),
    linear and nonlinear, on the mesh 2-4-4-2 with S = 800 steps per period (the mesh is
    converged; the step is what matters), and the linear one with S = 1600 as its check;
    with the library's default (modal) damping, and again at matched damping (the multibody
    model's Kelvin-Voigt form, damping_model = "stiffness"): linear, nonlinear (the default
    uniform membrane strain) and nonlinear with the paper's literal strain (errata E30);
  * the Exudyn model on two settings, 2-4-4-2 elements with 400 steps per period and the
    refined 4-8-8-4 with 800 steps (the convergence check);
with the wall-clock seconds of each.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import fivebar
from fivebar.analyses import multibody
from fivebar.description.setup import Setup

OUT = Path(__file__).resolve().parents[1] / "data" / "multibody_sweep.json"
SPEEDS = {0.030: [60, 300, 600, 1000, 1440], 0.002: [15, 30, 45, 60, 90, 120]}
MESH, FINE = (2, 4, 4, 2), (4, 8, 8, 4)
S_LIB, S_LIB_FINE = 800, 1600
QUANTITIES = [(link, d) for link in ("L2", "L3") for d in ("transverse", "chord")]


def p2p(res) -> dict[str, float]:
    return {f"{link}_{d}": res.peak_to_peak_mm(link, d) for link, d in QUANTITIES}


def ked(params, rpm, nonlinear, steps=S_LIB, **replace):
    params = params.replace(**replace) if replace else params
    t = time.perf_counter()
    try:
        res = fivebar.steady_state(Setup(params, crank_speed_rpm=rpm, motors=False, nonlinear=nonlinear,
                                         steps_per_period=steps, elements_per_link=MESH,
                                         scheme=fivebar.GeneralizedAlpha(0.8)))
    except Exception as err:  # report, do not stop the sweep
        return {"error": f"{type(err).__name__}: {err}"[:300], "seconds": time.perf_counter() - t}
    return {**p2p(res), "seconds": time.perf_counter() - t, "floquet_max": float(np.abs(res.floquet_multipliers).max())}


def exudyn(params, rpm, mesh, steps):
    t = time.perf_counter()
    try:
        res = multibody.multibody_steady_state(
            fivebar.Setup(params, crank_speed_rpm=rpm, steps_per_period=math.gcd(steps, params.steps_per_period),
                          elements_per_link=mesh), integration_steps=steps, tol=1e-3)
    except Exception as err:
        return {"error": f"{type(err).__name__}: {err}"[:300], "seconds": time.perf_counter() - t}
    return {**p2p(res), "seconds": time.perf_counter() - t, "periods": res.periods,
            "periodicity_error": res.periodicity_error}


def main() -> None:
    base = fivebar.load_params()
    rows = []
    for depth, speeds in SPEEDS.items():
        params = base.replace(bending_depth=depth)
        for rpm in speeds:
            row = {"bending_depth_mm": 1e3 * depth, "rpm": rpm,
                   "ked_linear": ked(params, rpm, False), "ked_nonlinear": ked(params, rpm, True),
                   "ked_linear_fine": ked(params, rpm, False, S_LIB_FINE),
                   "ked_linear_matched": ked(params, rpm, False, damping_model="stiffness"),
                   "ked_nonlinear_matched": ked(params, rpm, True, damping_model="stiffness"),
                   "ked_nonlinear_literal_matched": ked(params, rpm, True, damping_model="stiffness",
                                                        strain_measure="literal"),
                   "exudyn": exudyn(params, rpm, MESH, 400), "exudyn_fine": exudyn(params, rpm, FINE, 800)}
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    doc = {"command": "python benchmarks/multibody_sweep.py", "exudyn_version": multibody._exudyn().__version__,
           "ked": {"mesh": MESH, "steps_per_period": S_LIB, "fine_steps_per_period": S_LIB_FINE, "scheme": "GeneralizedAlpha(0.8)", "motors": False,
                   "strain_measure": base.strain_measure, "damping_model": base.damping_model,
                   "matched": {"damping_model": "stiffness"}},
           "exudyn": {"mesh": MESH, "steps_per_period": 400, "fine_mesh": FINE, "fine_steps_per_period": 800,
                      "tol": 1e-3},
           "rows": rows}
    OUT.write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
