"""The bad-input table of the error contract, run by tests/test_contract.py in a worker process.

``python tests/contract_cases.py START`` runs the cases from index START on and prints one JSON
line per case as it finishes: ``{"i", "label", "kind", "outcome", "type", "message"}``.  The
parent kills the worker when a case exceeds its time (a hang) and restarts it after that case.

Outcomes of a case that must be refused (kind "bad"): ``clear`` (a FivebarError whose message
holds every token: the argument's name, the value, and for some a word of what is allowed),
``unclear`` (another exception, or a message without a token), ``silent`` (no error).  Of a case
that must be accepted (kind "good": NumPy scalars and size-one arrays where a number is
expected): ``accepted`` or ``refused``.
"""

from __future__ import annotations

import atexit
import json
import math
import os
import shutil
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "lib"))

import fivebar as fb  # noqa: E402
from fivebar.book import datasets  # noqa: E402
from fivebar.model.dynamics import linkage_dynamics  # noqa: E402
from fivebar.numerics.newmark import integrate  # noqa: E402
from fivebar.numerics.systems import PeriodicStepData, System  # noqa: E402
from fivebar.analyses.steady import march, shooting  # noqa: E402
from fivebar.analyses.sweep import speed_sweep, sweep_point  # noqa: E402

P = fb.load_params()
#: a cheap set-up for the solvers' bad-input cases (linear, no motors, S = 100)
L = fb.Setup(P, motors=False, nonlinear=False, steps_per_period=100)
I2, Z2 = np.eye(2), np.zeros((2, 2))
SYS = System(I2, 0.1 * I2, I2)
SD = PeriodicStepData(np.stack([I2] * 4), np.stack([Z2] * 4), np.stack([I2] * 4), np.zeros((4, 2)),
                      t0=0.0, period=1.0)
TMP = Path(tempfile.mkdtemp(prefix="fivebar-contract-"))
atexit.register(shutil.rmtree, TMP, True)
(TMP / "garbage.toml").write_text("this is = = not toml")
(TMP / "notes.csv").write_text("a,b\n1,2\n")


def _integrate(**kw):
    args = dict(system=SYS, u0=[1.0, 0.0], v0=[0.0, 0.0], t0=0.0, dt=0.1, nsteps=5)
    args.update(kw)
    return integrate(args.pop("system"), args.pop("u0"), args.pop("v0"), args.pop("t0"),
                     args.pop("dt"), args.pop("nsteps"), **args)


def bad(label, fn, *tokens):
    return ("bad", label, fn, tokens)


def good(label, fn):
    return ("good", label, fn, ())


NAN, INF = float("nan"), float("inf")

CASES = [
    # --- load_params -------------------------------------------------------------------------
    bad("load_params(path=missing)", lambda: fb.load_params("/nonexistent/p.toml"), "/nonexistent/p.toml", "path"),
    bad("load_params(path=directory)", lambda: fb.load_params(TMP), str(TMP), "path"),
    bad("load_params(path=not TOML)", lambda: fb.load_params(TMP / "garbage.toml"), "garbage.toml", "toml"),
    bad("load_params(path=123)", lambda: fb.load_params(123), "path", "123"),
    bad("load_params(overrides=list)", lambda: fb.load_params(overrides=[1, 2]), "overrides", "[1, 2]"),
    bad("load_params(crank_speed_rpm='fast')", lambda: fb.load_params(overrides={"crank_speed_rpm": "fast"}),
        "crank_speed_rpm", "'fast'"),
    bad("load_params(crank_speed_rpm=nan)", lambda: fb.load_params(overrides={"crank_speed_rpm": NAN}),
        "crank_speed_rpm", "nan"),
    bad("load_params(L1=-0.2)", lambda: fb.load_params(overrides={"L1": -0.2}), "L1", "-0.2"),
    bad("load_params(bending_depth=0.5)", lambda: fb.load_params(overrides={"bending_depth": 0.5}),
        "bending_depth", "0.5"),
    bad("load_params(bending_depth=0.01)", lambda: fb.load_params(overrides={"bending_depth": 0.01}),
        "bending_depth", "0.01"),
    bad("load_params(unknown key)", lambda: fb.load_params(overrides={"colour": 1}), "colour"),
    good("load_params(speed_ratio=1.5)", lambda: fb.Setup(P.replace(speed_ratio=1.5))),
    bad("load_params(speed_ratio=sqrt 2)", lambda: fb.Setup(P.replace(speed_ratio=math.sqrt(2))),
        "speed_ratio", "1.414"),
    good("load_params(crank_speed_rpm=np.float32)", lambda: fb.load_params(overrides={"crank_speed_rpm": np.float32(300)})),
    good("load_params(steps_per_period=np.int64)", lambda: fb.load_params(overrides={"steps_per_period": np.int64(400)})),
    good("Params.replace(L1=np.float64)", lambda: P.replace(L1=np.float64(0.2))),
    # --- Setup ------------------------------------------------------------------------------
    bad("Setup(params='p')", lambda: fb.Setup("p"), "params", "str"),
    bad("Setup(crank_speed_rpm=-1)", lambda: fb.Setup(P, crank_speed_rpm=-1), "crank_speed_rpm", "-1"),
    bad("Setup(crank_speed_rpm=0)", lambda: fb.Setup(P, crank_speed_rpm=0), "crank_speed_rpm", "0"),
    bad("Setup(crank_speed_rpm=nan)", lambda: fb.Setup(P, crank_speed_rpm=NAN), "crank_speed_rpm", "nan"),
    bad("Setup(crank_speed_rpm=inf)", lambda: fb.Setup(P, crank_speed_rpm=INF), "crank_speed_rpm", "inf"),
    bad("Setup(crank_speed_rpm='300')", lambda: fb.Setup(P, crank_speed_rpm="300"), "crank_speed_rpm", "'300'"),
    bad("Setup(crank_speed_rpm=[300, 400])", lambda: fb.Setup(P, crank_speed_rpm=[300, 400]),
        "crank_speed_rpm", "[300, 400]"),
    bad("Setup(steps_per_period=10)", lambda: fb.Setup(P, steps_per_period=10), "steps_per_period", "10"),
    bad("Setup(steps_per_period=400.5)", lambda: fb.Setup(P, steps_per_period=400.5), "steps_per_period", "400.5"),
    bad("Setup(steps_per_period=nan)", lambda: fb.Setup(P, steps_per_period=NAN), "steps_per_period", "nan"),
    bad("Setup(steps_per_period=inf)", lambda: fb.Setup(P, steps_per_period=INF), "steps_per_period", "inf"),
    bad("Setup(steps_per_period='800')", lambda: fb.Setup(P, steps_per_period="800"), "steps_per_period", "'800'"),
    bad("Setup(motors='yes')", lambda: fb.Setup(P, motors="yes"), "motors", "'yes'"),
    bad("Setup(elements_per_link=(1, 2, 2))", lambda: fb.Setup(P, elements_per_link=(1, 2, 2)),
        "elements_per_link", "(1, 2, 2)"),
    bad("Setup(elements_per_link=(1, 2, 2, 0))", lambda: fb.Setup(P, elements_per_link=(1, 2, 2, 0)),
        "elements_per_link", "(1, 2, 2, 0)"),
    bad("Setup(elements_per_link=7)", lambda: fb.Setup(P, elements_per_link=7), "elements_per_link", "7"),
    bad("Setup(elements_per_link=(1, 2.5, 2, 1))", lambda: fb.Setup(P, elements_per_link=(1, 2.5, 2, 1)),
        "elements_per_link", "2.5"),
    bad("Setup(scheme='newmark')", lambda: fb.Setup(P, scheme="newmark"), "scheme", "str"),
    bad("Setup.replace(colour=1)", lambda: fb.Setup(P).replace(colour=1), "colour"),
    good("Setup(crank_speed_rpm=np.float32(300))", lambda: fb.Setup(P, crank_speed_rpm=np.float32(300))),
    good("Setup(steps_per_period=np.int64(400))", lambda: fb.Setup(P, steps_per_period=np.int64(400))),
    good("Setup(steps_per_period=array([400]))", lambda: fb.Setup(P, steps_per_period=np.array([400]))),
    good("Setup(crank_speed_rpm=array([300.0]))", lambda: fb.Setup(P, crank_speed_rpm=np.array([300.0]))),
    good("Setup(motors=np.bool_(False))", lambda: fb.Setup(P, motors=np.bool_(False))),
    good("Setup(elements_per_link=np.array([1, 2, 2, 1]))", lambda: fb.Setup(P, elements_per_link=np.array([1, 2, 2, 1]))),
    # --- steady_state -----------------------------------------------------------------------
    bad("steady_state(setup='p')", lambda: fb.steady_state("p"), "setup", "str"),
    bad("steady_state(method='newton')", lambda: fb.steady_state(L, method="newton"), "method", "'newton'"),
    bad("steady_state(tol=0)", lambda: fb.steady_state(L, tol=0), "tol", "0"),
    bad("steady_state(tol=2)", lambda: fb.steady_state(L, tol=2), "tol", "2"),
    bad("steady_state(tol=nan)", lambda: fb.steady_state(L, tol=NAN), "tol", "nan"),
    bad("steady_state(tol='0.01')", lambda: fb.steady_state(L, tol="0.01"), "tol", "'0.01'"),
    bad("steady_state(steps_per_period=nan)", lambda: fb.steady_state(L.replace(steps_per_period=NAN)),
        "steps_per_period", "nan"),
    bad("steady_state(steps_per_period=10**9)", lambda: fb.steady_state(L.replace(steps_per_period=10**9)),
        "steps_per_period", "1000000000", "memory"),
    bad("steady_state(elements_per_link=(64,)*4)", lambda: fb.steady_state(
        L.replace(elements_per_link=(400, 400, 400, 400), steps_per_period=20000)), "elements_per_link", "memory"),
    bad("steady_state(crank_speed_rpm=-300)", lambda: fb.steady_state(L.replace(crank_speed_rpm=-300)),
        "crank_speed_rpm", "-300"),
    good("steady_state(steps_per_period=np.int64(100))", lambda: fb.steady_state(L.replace(steps_per_period=np.int64(100)))),
    # a field of the problem given to an analysis as a keyword: the problem says it
    bad("steady_state(params, steps_per_period=400)", lambda: fb.steady_state(P, steps_per_period=400),
        "steps_per_period=400", "Setup(params, steps_per_period=400)", "replace(steps_per_period=400)"),
    bad("shooting(setup, scheme=...)", lambda: shooting(L, scheme=fb.PAPER_SCHEME), "scheme", "Setup(", "replace("),
    bad("speed_sweep(params, nonlinear=False)", lambda: speed_sweep(P, [100], nonlinear=False, progress=False),
        "nonlinear=False", "Setup(", "replace("),
    bad("multiple_scales(params, crank_speed_rpm=100)",
        lambda: fb.multiple_scales(P, crank_speed_rpm=100), "crank_speed_rpm=100", "Setup("),
    bad("resonance_table(params, crank_speed_rpm=100)",
        lambda: fb.resonance_table(P, crank_speed_rpm=100), "crank_speed_rpm=100", "Setup("),
    good("steady_state(tol=np.float32(0.05))", lambda: fb.steady_state(L, tol=np.float32(0.05))),
    # --- shooting / march -------------------------------------------------------------------
    bad("shooting(tol=0)", lambda: shooting(L, tol=0), "tol", "0"),
    bad("shooting(tol=nan)", lambda: shooting(L, tol=NAN), "tol", "nan"),
    bad("shooting(max_iter=0)", lambda: shooting(L, max_iter=0), "max_iter", "0"),
    bad("shooting(max_iter=-1)", lambda: shooting(L, max_iter=-1), "max_iter", "-1"),
    bad("shooting(max_iter=2.5)", lambda: shooting(L, max_iter=2.5), "max_iter", "2.5"),
    bad("shooting(max_iter=10**9)", lambda: shooting(L, max_iter=10**9), "max_iter", "1000000000"),
    bad("shooting(u0 of wrong size)", lambda: shooting(L, u0=np.zeros(3), v0=np.zeros(3)), "u0", "3"),
    bad("shooting(u0 with nan)", lambda: shooting(L, u0=np.full(linkage_dynamics(L).n, NAN)), "u0", "finite"),
    bad("shooting(dyn=5)", lambda: shooting(5), "5", "int"),
    bad("march(max_periods=0)", lambda: march(L, max_periods=0), "max_periods", "0"),
    bad("march(max_periods=-3)", lambda: march(L, max_periods=-3), "max_periods", "-3"),
    bad("march(max_periods=2.5)", lambda: march(L, max_periods=2.5), "max_periods", "2.5"),
    bad("march(max_periods=nan)", lambda: march(L, max_periods=NAN), "max_periods", "nan"),
    bad("march(max_periods=10**12)", lambda: march(L, max_periods=10**12), "max_periods", "1000000000000"),
    bad("march(tol=-1)", lambda: march(L, tol=-1), "tol", "-1"),
    bad("march(tol='1e-6')", lambda: march(L, tol="1e-6"), "tol", "'1e-6'"),
    bad("march(u0 of wrong size)", lambda: march(L, u0=np.zeros(3)), "u0", "3"),
    bad("march(v0 with inf)", lambda: march(L, v0=np.full(linkage_dynamics(L).n, INF)), "v0", "finite"),
    good("march(max_periods=np.int64(2000))", lambda: march(L, max_periods=np.int64(2000))),
    good("shooting(max_iter=np.int32(20))", lambda: shooting(L, max_iter=np.int32(20))),
    # --- the result type in time: transient / quasi_static / radau / Response --------------
    bad("transient(periods=0)", lambda: fb.transient(L, 0), "periods", "0"),
    bad("transient(periods=2.5)", lambda: fb.transient(L, 2.5), "periods", "2.5"),
    bad("transient(u0=[1.0])", lambda: fb.transient(L, 1, u0=[1.0]), "u0", "(1,)"),
    bad("quasi_static(t='x')", lambda: fb.quasi_static(L, "x"), "t", "'x'"),
    bad("radau(t=[0.0])", lambda: fb.radau(L, [0.0]), "t", "[0.0]"),
    bad("radau(rtol=0)", lambda: fb.radau(L, [0.0, 1e-5], rtol=0), "rtol", "0"),
    bad("Response.deflection_mm(s=2)", lambda: fb.quasi_static(L).deflection_mm("L2", 2), "s", "2"),
    bad("Response.period(k=3)", lambda: fb.quasi_static(L).period(3), "k", "3"),
    good("transient(periods=np.int64(1))", lambda: fb.transient(L, np.int64(1))),
    good("Response.deflection_mm(s=np.float32(0.25))", lambda: fb.quasi_static(L).deflection_mm("L2", np.float32(0.25))),
    # --- speed_sweep / sweep_point ----------------------------------------------------------
    bad("speed_sweep(speeds_rpm=[])", lambda: speed_sweep(L, [], progress=False), "speeds_rpm", "[]"),
    bad("speed_sweep(speeds_rpm=[-1])", lambda: speed_sweep(L, [-1], progress=False), "speeds_rpm", "-1"),
    bad("speed_sweep(speeds_rpm=[nan])", lambda: speed_sweep(L, [NAN], progress=False), "speeds_rpm", "nan"),
    bad("speed_sweep(speeds_rpm='fast')", lambda: speed_sweep(L, "fast", progress=False), "speeds_rpm", "'fast'"),
    bad("speed_sweep(speeds_rpm=2-D)", lambda: speed_sweep(L, [[100, 200], [300, 400]], progress=False),
        "speeds_rpm", "[[100, 200], [300, 400]]"),
    bad("speed_sweep(links=('L5',))", lambda: speed_sweep(L, [100], links=("L5",), progress=False), "links", "L5"),
    bad("speed_sweep(links='L2')", lambda: speed_sweep(L, [100], links="L2", progress=False), "links", "L2"),
    bad("speed_sweep(direction='up')", lambda: speed_sweep(L, [100], direction="up", progress=False),
        "direction", "'up'"),
    bad("speed_sweep(executor=5)", lambda: speed_sweep(L, [100], executor=5, progress=False), "executor", "5"),
    bad("speed_sweep(steps_per_period=10)", lambda: speed_sweep(L.replace(steps_per_period=10), [100], progress=False),
        "steps_per_period", "10"),
    bad("speed_sweep(params=None)", lambda: speed_sweep(None, [100], progress=False), "params", "None"),
    bad("sweep_point(crank_speed_rpm=-5)", lambda: sweep_point(L.replace(crank_speed_rpm=-5)), "crank_speed_rpm", "-5"),
    bad("sweep_point(crank_speed_rpm='x')", lambda: sweep_point(L.replace(crank_speed_rpm="x")), "crank_speed_rpm", "'x'"),
    bad("sweep_point(links=('L9',))", lambda: sweep_point(L, links=("L9",)), "links", "L9"),
    bad("sweep_point(direction='up')", lambda: sweep_point(L, direction="up"), "direction", "'up'"),
    good("speed_sweep(speeds_rpm=np.float32 array)", lambda: speed_sweep(L, np.array([100], np.float32), progress=False)),
    good("sweep_point(crank_speed_rpm=np.int64(100))", lambda: sweep_point(L.replace(crank_speed_rpm=np.int64(100)))),
    # --- integrate / System / PeriodicStepData ----------------------------------------------
    bad("integrate(dt=0)", lambda: _integrate(dt=0.0), "dt", "0"),
    bad("integrate(dt=nan)", lambda: _integrate(dt=NAN), "dt", "nan"),
    bad("integrate(dt='0.1')", lambda: _integrate(dt="0.1"), "dt", "'0.1'"),
    bad("integrate(nsteps=-1)", lambda: _integrate(nsteps=-1), "nsteps", "-1"),
    bad("integrate(nsteps=2.5)", lambda: _integrate(nsteps=2.5), "nsteps", "2.5"),
    bad("integrate(nsteps=10**12)", lambda: _integrate(nsteps=10**12), "nsteps", "1000000000000", "memory"),
    bad("integrate(t0=inf)", lambda: _integrate(t0=INF), "t0", "inf"),
    bad("integrate(u0 of wrong size)", lambda: _integrate(u0=[1.0, 0.0, 0.0]), "u0", "3"),
    bad("integrate(u0='a')", lambda: _integrate(u0="a"), "u0", "'a'"),
    bad("integrate(v0 of wrong size)", lambda: _integrate(v0=[0.0]), "v0", "1"),
    bad("integrate(u0 with nan)", lambda: _integrate(u0=[NAN, 0.0]), "u0", "nan"),
    bad("integrate(a0 of wrong size)", lambda: _integrate(a0=[0.0]), "a0", "1"),
    bad("integrate(max_iter=0)", lambda: _integrate(max_iter=0), "max_iter", "0"),
    bad("integrate(max_iter=10**9, rtol=0, xtol=0)", lambda: _integrate(
        system=System(I2, Z2, I2, nonlinear=lambda u: (u**3, np.diag(3 * u**2))), max_iter=10**9, rtol=0.0,
        xtol=0.0), "max_iter", "1000000000"),
    bad("integrate(max_iter=10**9, rtol=0, xtol=0, compiled)", lambda: integrate(
        SYS, [1.0, 0.0], [0.0, 0.0], 0.0, SD.dt, 3, step_data=SD, max_iter=10**9, rtol=0.0, xtol=0.0,
        atol=0.0), "max_iter", "1000000000"),
    bad("integrate(rtol=-1)", lambda: _integrate(rtol=-1.0), "rtol", "-1"),
    bad("integrate(rtol=nan)", lambda: _integrate(rtol=NAN), "rtol", "nan"),
    bad("integrate(xtol=-1)", lambda: _integrate(xtol=-1.0), "xtol", "-1"),
    bad("integrate(newton='half')", lambda: _integrate(newton="half"), "newton", "'half'"),
    bad("integrate(store='some')", lambda: _integrate(store="some"), "store", "'some'"),
    bad("integrate(sensitivity='x')", lambda: _integrate(sensitivity="x"), "sensitivity", "'x'"),
    bad("integrate(scheme='newmark')", lambda: _integrate(scheme="newmark"), "scheme", "str"),
    bad("integrate(system=5)", lambda: _integrate(system=5), "system", "int"),
    bad("integrate(blas_threads=0)", lambda: _integrate(blas_threads=0), "blas_threads", "0"),
    bad("integrate(step_data of other n)", lambda: integrate(
        SYS, [1.0, 0.0, 0.0], [0.0] * 3, 0.0, SD.dt, 3, step_data=SD), "step_data", "3"),
    good("integrate(nsteps=np.int64(5), dt=np.float32(0.1))", lambda: _integrate(nsteps=np.int64(5), dt=np.float32(0.1))),
    good("integrate(max_iter=np.int64(10))", lambda: _integrate(max_iter=np.int64(10))),
    bad("System(M not square)", lambda: System(np.ones((2, 3)), I2, I2), "M", "(2, 3)"),
    bad("System(C of other size)", lambda: System(I2, np.eye(3), I2), "C", "(3, 3)"),
    bad("System(K='k')", lambda: System(I2, I2, "k"), "K", "'k'"),
    bad("System(M with nan)", lambda: System(np.full((2, 2), NAN), I2, I2), "M", "finite"),
    bad("System(force of wrong size)", lambda: System(I2, I2, I2, force=np.zeros(3)), "force", "(3,)"),
    bad("System(nonlinear=5)", lambda: System(I2, I2, I2, nonlinear=5), "nonlinear", "5"),
    bad("PeriodicStepData(period=0)", lambda: PeriodicStepData(SD.M, SD.C, SD.K, SD.F, t0=0.0, period=0.0),
        "period", "0"),
    bad("PeriodicStepData(period=nan)", lambda: PeriodicStepData(SD.M, SD.C, SD.K, SD.F, t0=0.0, period=NAN),
        "period", "nan"),
    bad("PeriodicStepData(F of wrong shape)", lambda: PeriodicStepData(SD.M, SD.C, SD.K, np.zeros((3, 2)),
                                                                       t0=0.0, period=1.0), "F", "(3, 2)"),
    bad("PeriodicStepData(K of other S)", lambda: PeriodicStepData(SD.M, SD.C, SD.K[:3], SD.F, t0=0.0, period=1.0),
        "K", "(3, 2, 2)"),
    bad("PeriodicStepData(t0=nan)", lambda: PeriodicStepData(SD.M, SD.C, SD.K, SD.F, t0=NAN, period=1.0),
        "t0", "nan"),
    bad("PeriodicStepData(M='m')", lambda: PeriodicStepData("m", SD.C, SD.K, SD.F, t0=0.0, period=1.0), "M", "'m'"),
    good("PeriodicStepData(period=np.float32(1))", lambda: PeriodicStepData(SD.M, SD.C, SD.K, SD.F, t0=0.0,
                                                                           period=np.float32(1.0))),
    # --- datasets ---------------------------------------------------------------------------
    bad("write_datasets(names=['x'])", lambda: datasets.write_datasets(TMP / "o", names=["x"]), "names", "x"),
    bad("write_datasets(names='figure6_curves')", lambda: datasets.write_datasets(TMP / "o", names="figure6_curves"),
        "names", "figure6_curves"),
    bad("write_datasets(params_path=missing)", lambda: datasets.write_datasets(
        TMP / "o", params_path="/nonexistent/p.toml", names=["resonance_speeds"]), "params_path", "/nonexistent/p.toml"),
    bad("write_datasets(outdir=a file)", lambda: datasets.write_datasets(TMP / "notes.csv", names=["resonance_speeds"]),
        "outdir", "notes.csv"),
    bad("read_dataset(missing)", lambda: datasets.read_dataset(TMP / "none.csv"), "none.csv", "path"),
    bad("read_dataset(no provenance)", lambda: datasets.read_dataset(TMP / "notes.csv"), "notes.csv", "provenance"),
    bad("source_hash(missing)", lambda: datasets.source_hash("/nonexistent/p.toml"), "/nonexistent/p.toml", "params_path"),
    bad("figure6_curves(params='p')", lambda: datasets.figure6_curves("p"), "params", "str"),
    bad("frequencies_table(n_modes=0)", lambda: datasets.frequencies_table(P, n_modes=0), "n_modes", "0"),
    bad("frequencies_table(angles_deg='x')", lambda: datasets.frequencies_table(P, angles_deg="x"), "angles_deg", "'x'"),
    bad("frequencies_table(params=None)", lambda: datasets.frequencies_table(None), "params", "None"),
    bad("resonance_speeds_table(params=1)", lambda: datasets.resonance_speeds_table(1), "params", "int"),
    bad("sweep_table(speeds_rpm=[-1])", lambda: datasets.sweep_table(P, speeds_rpm=[-1]), "speeds_rpm", "-1"),
    good("frequencies_table(n_modes=np.int64(2))", lambda: datasets.frequencies_table(P, angles_deg=[0.0, 90.0], n_modes=np.int64(2))),
]


def run_case(i: int) -> dict:
    kind, label, fn, tokens = CASES[i]
    out = {"i": i, "label": label, "kind": kind, "type": None, "message": None}
    try:
        fn()
    except Exception as exc:  # noqa: BLE001 - the table classifies every exception
        msg = str(exc)
        out["type"] = type(exc).__name__
        out["message"] = msg[:400]
        if kind == "good":
            out["outcome"] = "refused"
            out["message"] += " | " + traceback.format_exc(limit=-2)[-300:]
        elif isinstance(exc, fb.FivebarError) and all(t.lower() in msg.lower() for t in tokens):
            out["outcome"] = "clear"
        else:
            out["outcome"] = "unclear"
            out["missing"] = [t for t in tokens if t.lower() not in msg.lower()]
    else:
        out["outcome"] = "accepted" if kind == "good" else "silent"
    return out


if __name__ == "__main__":
    import warnings

    warnings.simplefilter("ignore")
    try:  # a bound on memory: a size that cannot fit fails here, not on the shared machine
        import resource

        cap = int(os.environ.get("FIVEBAR_CONTRACT_MEMORY", 6 * 2**30))
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    except (ImportError, ValueError, OSError):
        pass
    start = int(sys.argv[1]) if len(sys.argv) > 1 else 0
    if start < 0:
        print(len(CASES), flush=True)
        sys.exit(0)
    for i in range(start, len(CASES)):
        print(json.dumps(run_case(i)), flush=True)
