"""The bad-input list of issue 36 ("trust at the edges, round two"), run by tests/test_edges.py
in a worker process, as tests/contract_cases.py is by tests/test_contract.py (same protocol:
``python tests/edge_cases.py START`` prints one JSON line per case from index START on).

Kinds of case and their outcomes:

* ``bad`` (an input that is wrong): ``clear`` (a FivebarError whose message holds every token:
  the argument's name, its value, and for some what is allowed), ``unclear`` (a FivebarError
  without a token), ``escaped`` (another exception: Python's or NumPy's own message),
  ``silent`` (a result, no error).
* ``warn`` (an input that is legal, whose result is outside the model's validity): ``clear`` (a
  :class:`fivebar.ValidityWarning` whose message holds every token), ``unclear`` (a warning
  without them, or a FivebarError), ``escaped`` (another exception), ``silent`` (no warning).
* ``good`` (a valid input: a false refusal before the fix, or a NumPy number or 0-d array where
  a number is expected): ``accepted`` or ``refused``.
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
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "lib"))

import fivebar as fb  # noqa: E402
from fivebar.model.dynamics import linkage_dynamics  # noqa: E402
from fivebar.book.animation import animate_linkage, linkage_frames  # noqa: E402
from fivebar.analyses.branches import brute_force_diagram, describe_speed, follow, linkage_period_map  # noqa: E402
from fivebar.numerics.continuation import continuation, settle  # noqa: E402
from fivebar.model.kinematics import link_angles, positions  # noqa: E402
from fivebar.analyses.modal import frequencies_along_cycle, modes  # noqa: E402
from fivebar.numerics.periodic import shoot  # noqa: E402
from fivebar.analyses.steady import march  # noqa: E402
from fivebar.analyses.sweep import speed_sweep, sweep_peaks, sweep_point  # noqa: E402

NAN, INF = float("nan"), float("inf")
P = fb.load_params()
#: a cheap set-up (linear, no motors, S = 100)
L = fb.Setup(P, motors=False, nonlinear=False, steps_per_period=100)
TMP = Path(tempfile.mkdtemp(prefix="fivebar-edges-"))
atexit.register(shutil.rmtree, TMP, True)


def _file(name: str, text: str | bytes) -> list:
    """A parameter file ``name`` in the temporary directory, layered over the defaults."""
    path = TMP / name
    (path.write_bytes if isinstance(text, bytes) else path.write_text)(text)
    return [fb.DEFAULT_PARAMS_PATH, path]


def _junk() -> list:
    if not (TMP / "junk.toml").exists():
        (TMP / "junk.toml").write_text("[geometry]\n" + "".join(f"x{i} = 0.1\n" for i in range(200_000)))
    return [fb.DEFAULT_PARAMS_PATH, TMP / "junk.toml"]


class _Toy:
    """A cheap period map for the continuation's cases: x_T = x / 2 + p, whose fixed point is
    x = 2 p (two components), with its monodromy matrix diag(1/2)."""

    def __call__(self, x, p=None, jacobian=False):
        x = np.asarray(x, float)
        return 0.5 * x + p, (0.5 * np.eye(x.size) if jacobian else None)


TOY, X0 = _Toy(), np.array([120.0, 120.0])


def _cont(**kw):
    args = dict(period_map=TOY, x0=X0, p0=60.0, p_end=70.0, max_points=5)
    args.update(kw)
    return continuation(args.pop("period_map"), args.pop("x0"), args.pop("p0"), args.pop("p_end"), **args)


def _steady():
    return fb.steady_state(L)


def bad(label, fn, *tokens):
    return ("bad", label, fn, tokens)


def warn(label, fn, *tokens):
    return ("warn", label, fn, tokens)


def good(label, fn):
    return ("good", label, fn, ())


CASES = [
    # --- silent before: a description's unknown entries ---------------------------------------
    bad("[geometry] L22 = 0.3 (a typo of L2)", lambda: fb.load_params(_file("typo.toml", "[geometry]\nL22 = 0.3\n")),
        "geometry.L22", "did you mean", "geometry.L2", "typo.toml"),
    bad("[masses] m2 = 0.1 (a typo of m02)", lambda: fb.load_params(_file("m2.toml", "[masses]\nm2 = 0.1\n")),
        "masses.m2", "did you mean", "masses.m02"),
    bad("[geometry] non-ASCII key", lambda: fb.load_params(_file("na.toml", '[geometry]\n"Länge" = 0.3\n')),
        "Länge", "unknown"),
    bad("[geometry] 200 000 junk keys", lambda: fb.load_params(_junk()), "geometry.x0", "200000", "unknown"),
    bad("overrides {'geometry.L22': 0.3}", lambda: fb.load_params(overrides={"geometry.L22": 0.3}),
        "geometry.L22", "did you mean"),
    bad("Params.replace(**{'geometry.L22': 0.3})", lambda: P.replace(**{"geometry.L22": 0.3}),
        "geometry.L22", "did you mean"),
    bad("[assumptions] crank_sped_rpm (a typo)", lambda: fb.load_params(
        _file("sped.toml", "[assumptions]\ncrank_sped_rpm = 30\n")), "crank_sped_rpm", "did you mean",
        "assumptions.crank_speed_rpm"),
    bad("[geometri] L2 (a typo of a section)", lambda: fb.load_params(_file("sec.toml", "[geometri]\nL2 = 0.3\n")),
        "geometri.L2", "did you mean", "geometry.L2"),
    bad("four-bar: Params.replace(L1=0.3), an entry its linkage does not use",
        lambda: fb.load_params([fb.DEFAULT_PARAMS_PATH, fb.FOURBAR_PARAMS_PATH]).replace(L1=0.3),
        "L1", "four-bar"),
    good("four-bar over the paper's file (their [geometry] entries, superseded)",
         lambda: fb.load_params([fb.DEFAULT_PARAMS_PATH, fb.FOURBAR_PARAMS_PATH])),
    good("[geometry] an entry declared free", lambda: fb.load_params(
        _file("free.toml", '[geometry]\nbracket = { value = 0.05, free = true, source = "my note" }\n'))),
    # --- silent before: NaN and inf angles, huge angles ---------------------------------------
    bad("positions(p, nan, 0)", lambda: positions(P, NAN, 0), "theta", "nan"),
    bad("positions(p, inf, 0)", lambda: positions(P, INF, 0), "theta", "inf"),
    bad("link_angles(p, 0, [0, nan])", lambda: link_angles(P, 0, [0.0, NAN]), "theta", "nan"),
    warn("theta1_0 = 1e20 rad", lambda: fb.load_params(overrides={"theta1_0": 1e20}), "theta1_0", "1e+20"),
    warn("multiple_scales at 5000 r/min", lambda: fb.multiple_scales(fb.Setup(P, crank_speed_rpm=5000)),
         "5000", "validity", "deflection"),
    # --- silent before: truthy strings, booleans as speeds --------------------------------------
    bad("speed_sweep(accuracy='no')", lambda: speed_sweep(L, [100], accuracy="no", progress=False),
        "accuracy", "'no'"),
    bad("speed_sweep(cache='no')", lambda: speed_sweep(L, [100], cache="no", progress=False), "cache", "'no'"),
    bad("speed_sweep(progress='no')", lambda: speed_sweep(L, [100], progress="no"), "progress", "'no'"),
    bad("speed_sweep(setup, [True])", lambda: speed_sweep(L, [True], progress=False), "speeds_rpm", "True"),
    bad("speed_sweep(setup, [100, True])", lambda: speed_sweep(L, [100, True], progress=False),
        "speeds_rpm", "True"),
    bad("sweep_point(accuracy='yes')", lambda: sweep_point(L, accuracy="yes"), "accuracy", "'yes'"),
    bad("describe_speed(setup, -100)", lambda: describe_speed(L, -100), "value", "-100"),
    bad("describe_speed(setup, 'fast')", lambda: describe_speed(L, "fast"), "value", "'fast'"),
    bad("brute_force_diagram(values=[True])", lambda: brute_force_diagram(L, [True]), "values", "True"),
    bad("follow(p_end=True)", lambda: follow(L, True, points=3), "p_end", "True"),
    # --- silent before: the continuation's budget and bounds ----------------------------------
    bad("continuation(max_points=0)", lambda: _cont(max_points=0), "max_points", "0"),
    bad("continuation(max_points=-5)", lambda: _cont(max_points=-5), "max_points", "-5"),
    bad("continuation(max_points=2.5)", lambda: _cont(max_points=2.5), "max_points", "2.5"),
    bad("continuation(p_bounds reversed)", lambda: _cont(p_bounds=(80.0, 50.0)), "p_bounds", "(80.0, 50.0)"),
    bad("continuation(p_bounds excluding p0)", lambda: _cont(p_bounds=(100.0, 200.0)), "p_bounds", "p0"),
    bad("continuation(p_bounds=5)", lambda: _cont(p_bounds=5), "p_bounds", "5"),
    bad("continuation(locate='no')", lambda: _cont(locate="no"), "locate", "'no'"),
    # --- false refusals before ------------------------------------------------------------------
    good("Params.replace(thickness=0.002)", lambda: P.replace(thickness=0.002)),
    good("Params.replace(width=0.03)", lambda: P.replace(width=0.03)),
    good("Params.replace(thickness=np.float64(0.002))", lambda: P.replace(thickness=np.float64(0.002))),
    good("linkage_period_map(setup, 'L2')", lambda: linkage_period_map(L, "L2")),
    good("four-bar with damping_model = 'stiffness' (found while checking the four-bar)", lambda: linkage_dynamics(fb.Setup(
        fb.load_params([fb.DEFAULT_PARAMS_PATH, fb.FOURBAR_PARAMS_PATH]).replace(damping_model="stiffness"),
        steps_per_period=100, nonlinear=False)).step_data),
    good("follow(setup, 0.41, parameter='L2')", lambda: follow(L, 0.41, parameter="L2", points=2)),
    # --- unclear before: the argument the user gave, its value, what is allowed -----------------
    bad("Setup(steps_per_period=0)", lambda: fb.Setup(P, steps_per_period=0), "steps_per_period", "0", "21"),
    bad("Setup(steps_per_period=-3)", lambda: fb.Setup(P, steps_per_period=-3), "steps_per_period", "-3", "21"),
    bad("material.rho = 1e-10 (tiny)", lambda: linkage_dynamics(fb.Setup(P.replace(rho=1e-10), nonlinear=False)),
        "material.rho", "1e-10"),
    bad("material.E = 1e300 (huge)", lambda: linkage_dynamics(fb.Setup(P.replace(E=1e300), nonlinear=False)),
        "material.E", "1e+300"),
    bad("march with the paper's rule at S = 100 (diverges)", lambda: march(
        fb.Setup(P, scheme=fb.PAPER_SCHEME, steps_per_period=100, nonlinear=False, motors=False)),
        "march", "period", "diverge"),
    bad("natural_frequencies(elements_per_link=(2000,)*4)", lambda: fb.natural_frequencies(
        fb.Setup(P, elements_per_link=(2000,) * 4), 0, 0), "elements_per_link", "memory"),
    bad("frequencies_along_cycle(1000 angles, (200,)*4)", lambda: frequencies_along_cycle(
        fb.Setup(P, elements_per_link=(200,) * 4), np.linspace(0, 6, 1000)), "elements_per_link", "memory"),
    bad("a parameter file with bad UTF-8", lambda: fb.load_params(_file("utf.toml", b"[geometry]\nL2 = 0.3 # \xff\n")),
        "utf.toml", "UTF-8"),
    bad("follow(setup, p_end=-100)", lambda: follow(L, -100, points=3), "p_end", "-100"),
    bad("follow(setup, 70, p0=-5)", lambda: follow(L, 70, p0=-5, points=3), "p0", "-5"),
    bad("continuation(period_map=5)", lambda: _cont(period_map=5), "period_map", "5"),
    bad("continuation(p0='a')", lambda: _cont(p0="a"), "p0", "'a'"),
    bad("continuation(p0=None)", lambda: _cont(p0=None), "p0", "None"),
    bad("continuation(p_end=nan)", lambda: _cont(p_end=NAN), "p_end", "nan"),
    bad("continuation(tangent='x')", lambda: _cont(tangent="x"), "tangent", "'x'"),
    bad("continuation(tangent of wrong size)", lambda: _cont(tangent=[1.0, 2.0]), "tangent", "(2,)", "(3,)"),
    bad("continuation(x0 with nan)", lambda: _cont(x0=[NAN, 1.0]), "x0", "nan"),
    bad("continuation(x0='x')", lambda: _cont(x0="x"), "x0", "'x'"),
    bad("shoot(period_map='f')", lambda: shoot("f", X0, 60.0), "period_map", "'f'"),
    bad("settle(orbit=None)", lambda: settle(TOY, None, 60.0), "orbit", "None"),
    bad("animate_linkage(steady=None)", lambda: animate_linkage(None), "steady", "None"),
    bad("linkage_frames(steady=None)", lambda: linkage_frames(None), "steady", "None"),
    bad("linkage_frames(steady=params)", lambda: linkage_frames(P), "steady", "Params"),
    # --- errors that escaped FivebarError (found while writing this list) -----------------------
    bad("positions(p, 'x', 0)", lambda: positions(P, "x", 0), "theta", "'x'"),
    bad("positions(None, 0, 0)", lambda: positions(None, 0, 0), "params", "None"),
    bad("positions(p, True, 0)", lambda: positions(P, True, 0), "theta", "True"),
    bad("positions(p, 0, 0, mode=True)", lambda: positions(P, 0, 0, mode=True), "mode", "True"),
    # (found by the property-based tests, tests/test_properties.py)
    bad("positions(p, 0, 0j) (a complex angle)", lambda: positions(P, 0.0, 0j), "theta", "0j"),
    bad("positions(p, [0.1, 0.2], [0.1, 0.2, 0.3]) (shapes that do not broadcast)",
        lambda: positions(P, [0.1, 0.2], [0.1, 0.2, 0.3]), "(2,)", "(3,)", "broadcast"),
    bad("natural_frequencies(p, nan, 0)", lambda: fb.natural_frequencies(P, NAN, 0), "theta", "nan"),
    bad("modes(p, 0, 0, n_modes=True)", lambda: modes(P, 0, 0, n_modes=True), "n_modes", "True"),
    bad("frequencies_along_cycle(p, [nan])", lambda: frequencies_along_cycle(P, [NAN]), "crank_angles", "nan"),
    bad("steady_state(p, metod='march') (a misspelt keyword)", lambda: fb.steady_state(L, metod="march"),
        "metod", "method"),
    bad("steady_state() (no problem)", lambda: fb.steady_state(), "setup"),
    bad("speed_sweep(L, [100], link=('L2',)) (a misspelt keyword)",
        lambda: speed_sweep(L, [100], link=("L2",), progress=False), "link", "links"),
    bad("multiple_scales(p, n_modes=0)", lambda: fb.multiple_scales(L, n_modes=0), "n_modes", "0"),
    bad("multiple_scales(p, kinematic='no')", lambda: fb.multiple_scales(L, kinematic="no"), "kinematic", "'no'"),
    bad("transient(L, 1, newton=5)", lambda: fb.transient(L, 1, newton=5), "newton", "5"),
    bad("sweep_peaks(df, column=5)", lambda: sweep_peaks(speed_sweep(L, [100, 110, 120], progress=False), 5),
        "column", "5"),
    bad("E = 1e300 natural_frequencies", lambda: fb.natural_frequencies(P.replace(E=1e300), 0, 0),
        "material.E", "1e+300"),
    # --- NumPy numbers and 0-d arrays where a number is expected --------------------------------
    good("positions(p, np.float32(0.1), np.array(0.2))", lambda: positions(P, np.float32(0.1), np.array(0.2))),
    good("continuation(p0=np.float64(60), p_end=np.array(70.0), max_points=np.int64(3))",
         lambda: _cont(p0=np.float64(60.0), p_end=np.array(70.0), max_points=np.int64(3))),
    good("natural_frequencies(p, np.float64(0), np.array(0.0), n_modes=np.int64(2))",
         lambda: fb.natural_frequencies(P, np.float64(0.0), np.array(0.0), n_modes=np.int64(2))),
    good("describe_speed(setup, np.float64(60))", lambda: describe_speed(L, np.float64(60.0))),
    good("speed_sweep(accuracy=np.bool_(False))", lambda: speed_sweep(L, [100], accuracy=np.bool_(False),
                                                                       progress=False)),
]


def run_case(i: int) -> dict:
    kind, label, fn, tokens = CASES[i]
    out = {"i": i, "label": label, "kind": kind, "type": None, "message": None}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fn()
        except Exception as exc:  # noqa: BLE001 - the list classifies every exception
            msg = str(exc)
            out["type"] = type(exc).__name__
            out["message"] = msg[:400]
            ok = isinstance(exc, fb.FivebarError)
            if kind == "good":
                out["outcome"] = "refused"
                out["message"] += " | " + traceback.format_exc(limit=-2)[-300:]
            elif not ok:
                out["outcome"] = "escaped"
            elif kind == "bad" and all(t.lower() in msg.lower() for t in tokens):
                out["outcome"] = "clear"
            else:
                out["outcome"] = "unclear"
                out["missing"] = [t for t in tokens if t.lower() not in msg.lower()]
            return out
    if kind == "good":
        out["outcome"] = "accepted"
    elif kind == "bad":
        out["outcome"] = "silent"
    else:
        said = [str(w.message) for w in caught if issubclass(w.category, fb.ValidityWarning)]
        out["message"] = " | ".join(said)[:400] or None
        out["type"] = "ValidityWarning" if said else None
        if not said:
            out["outcome"] = "silent"
        elif any(all(t.lower() in m.lower() for t in tokens) for m in said):
            out["outcome"] = "clear"
        else:
            out["outcome"] = "unclear"
            out["missing"] = [t for t in tokens if not any(t.lower() in m.lower() for m in said)]
    return out


if __name__ == "__main__":
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
