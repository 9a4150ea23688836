"""The nonlinear KED model against the geometrically exact multibody model (issue 18, point 1).

Flexible orientation (bending_depth = 2 mm), motors off: transverse peak-to-peak midpoint
deflections of L2 and L3 (mm) over crank speed of
  * the KED steady state (shooting, generalised-alpha rho_inf = 0.8) linear, and nonlinear with
    each strain measure of fivebar.model.nonlinear.STRAIN_MEASURES ("literal" is the model before the
    fix), with the library's modal damping and with the stiffness-proportional (Kelvin-Voigt)
    damping of the multibody model (matched damping), on the mesh 2-4-4-2 at S = 800;
  * the convergence of the matched comparison: the KED model (uniform strain, stiffness damping)
    on the mesh 4-8-8-4 at S = 800 and on 2-4-4-2 at S = 1600, and the multibody model (Exudyn,
    Kelvin-Voigt damping) on 2-4-4-2 / 400 steps, 4-8-8-4 / 800 and 4-8-8-4 / 1600;
  * the default orientation (30 mm): the library's default set-up and the sweep's set-up, with
    the literal strain (before) and the default uniform strain (after), and the worst change.

Run:  .venv/bin/python benchmarks/nonlinear_vs_multibody.py [--out FILE]   (10-20 min, one core)
Prints JSON and writes it to benchmarks/results/nonlinear_vs_multibody.json (or FILE).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import fivebar
from fivebar.analyses import multibody
from fivebar.model.nonlinear import STRAIN_MEASURES
from fivebar.description.setup import Setup

OUT = Path(__file__).resolve().parent / "results" / "nonlinear_vs_multibody.json"
SPEEDS = [30, 60, 90, 120, 200, 300]
MB_SPEEDS = [30, 60, 90, 120]
MESH, FINE = (2, 4, 4, 2), (4, 8, 8, 4)
S = 800
DEFAULT_SPEEDS = [60, 150, 300, 450, 600]
LINKS = ("L2", "L3")


def _p2p(res) -> dict[str, float]:
    return {link: res.peak_to_peak_mm(link, "transverse") for link in LINKS}


def ked(params, rpm, nonlinear=True, mesh=MESH, steps=S, motors=False):
    t = time.perf_counter()
    try:
        res = fivebar.steady_state(Setup(params, crank_speed_rpm=rpm, motors=motors, nonlinear=nonlinear,
                                         steps_per_period=steps, elements_per_link=mesh,
                                         scheme=fivebar.GeneralizedAlpha(0.8)))
    except Exception as err:  # report, do not stop
        return {"error": f"{type(err).__name__}: {err}"[:300], "seconds": time.perf_counter() - t}
    return {**_p2p(res), "stable": bool(res.stable), "seconds": time.perf_counter() - t}


def exudyn(params, rpm, mesh, steps):
    t = time.perf_counter()
    try:
        res = multibody.multibody_steady_state(
            fivebar.Setup(params, crank_speed_rpm=rpm, steps_per_period=math.gcd(steps, params.steps_per_period),
                          elements_per_link=mesh), integration_steps=steps, tol=1e-3)
    except Exception as err:
        return {"error": f"{type(err).__name__}: {err}"[:300], "seconds": time.perf_counter() - t}
    return {**_p2p(res), "periods": res.periods, "seconds": time.perf_counter() - t}


def _rel(a: dict, b: dict) -> dict[str, float] | None:
    """Relative difference of a from b per link (None if either failed)."""
    if "error" in a or "error" in b:
        return None
    return {link: a[link] / b[link] - 1.0 for link in LINKS}


def flexible() -> list[dict]:
    base = fivebar.load_params().replace(bending_depth=0.002)
    rows = []
    for rpm in SPEEDS:
        row: dict = {"rpm": rpm}
        for damping in ("modal", "stiffness"):
            p = base.replace(damping_model=damping)
            row[f"linear_{damping}"] = ked(p, rpm, nonlinear=False)
            for measure in STRAIN_MEASURES:
                row[f"{measure}_{damping}"] = ked(p.replace(strain_measure=measure), rpm)
        p = base.replace(damping_model="stiffness", strain_measure="uniform")
        row["uniform_stiffness_fine_mesh"] = ked(p, rpm, mesh=FINE)
        row["uniform_stiffness_fine_step"] = ked(p, rpm, steps=2 * S)
        if rpm in MB_SPEEDS:
            row["multibody"] = exudyn(base, rpm, MESH, 400)
            row["multibody_fine"] = exudyn(base, rpm, FINE, 800)
            row["multibody_finest"] = exudyn(base, rpm, FINE, 1600)
            ref = row["multibody_finest"]
            row["error_vs_multibody"] = {k: _rel(row[k], ref) for k in (
                "linear_stiffness", "literal_stiffness", "corotated_stiffness", "uniform_stiffness",
                "uniform_stiffness_fine_mesh", "uniform_stiffness_fine_step", "linear_modal",
                "literal_modal", "uniform_modal", "multibody", "multibody_fine")}
        rows.append(row)
        print(json.dumps(row), file=sys.stderr, flush=True)
    return rows


def default_orientation() -> dict:
    base = fivebar.load_params()
    out: dict = {"rows": []}
    worst = 0.0
    for rpm in DEFAULT_SPEEDS:
        row: dict = {"rpm": rpm}
        for name, kw in (("default_setup", {}), ("sweep_setup", {"mesh": MESH, "steps": S})):
            before = _default_run(base.replace(strain_measure="literal"), rpm, **kw)
            after = _default_run(base, rpm, **kw)
            change = _rel(after, before)
            row[name] = {"literal": before, "uniform": after, "change": change}
            if change is not None:
                worst = max(worst, *(abs(c) for c in change.values()))
        out["rows"].append(row)
        print(json.dumps(row), file=sys.stderr, flush=True)
    out["worst_relative_change"] = worst
    return out


def _default_run(params, rpm, mesh=None, steps=None):
    t = time.perf_counter()
    try:
        if mesh is None:  # the library's defaults: the paper's mesh, motors, S and scheme of the file
            res = fivebar.steady_state(Setup(params, crank_speed_rpm=rpm))
        else:
            res = fivebar.steady_state(Setup(params, crank_speed_rpm=rpm, motors=False, steps_per_period=steps,
                                             elements_per_link=mesh, scheme=fivebar.GeneralizedAlpha(0.8)))
    except Exception as err:
        return {"error": f"{type(err).__name__}: {err}"[:300]}
    return {**_p2p(res), "seconds": time.perf_counter() - t}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args()
    doc = {
        "command": "python benchmarks/nonlinear_vs_multibody.py",
        "units": "transverse midpoint peak-to-peak, mm; error_vs_multibody relative to multibody_finest",
        "ked": {"mesh": MESH, "steps_per_period": S, "fine_mesh": FINE, "fine_steps_per_period": 2 * S,
                "scheme": "GeneralizedAlpha(0.8)", "motors": False, "bending_depth": 0.002},
        "multibody": {"levels": [[MESH, 400], [FINE, 800], [FINE, 1600]], "tol": 1e-3,
                      "exudyn_version": multibody._exudyn().__version__},
        "flexible": flexible(),
        "default_orientation": default_orientation(),
    }
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
