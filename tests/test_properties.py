"""Property-based tests of the entry points (Hypothesis; issue 36, point 5).

Random parameter files and random arguments of the public entry points either give a result
that passes the physics checks, or raise a :class:`fivebar.FivebarError`: never a silent NaN,
never another exception.  The physics checks are independent of the code's earlier output:

* kinematics: every link keeps its length and the loop closes (the joints computed from the
  two ground pivots meet), to round-off;
* the model: the mass matrix is symmetric positive definite and the damping and load finite;
* a steady state: finite, and periodic (the state at the end of the period equals the state at
  its start to the solver's tolerance, measured here in the energy norm of the frozen
  matrices, not by the solver's own residual);
* frequencies: finite, positive and ascending; a branch: finite points that are fixed points
  of the map.

The profile ``fivebar`` (registered below, loaded unless ``HYPOTHESIS_PROFILE`` names another)
keeps CI within budget and reproducible: 50 examples, no deadline (a first call compiles),
derandomized (the examples are a function of the test, the same on every run and machine)
and no example database written to the checkout.  The examples that found the escapes fixed
in issue 36 are pinned with ``@example``.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import ArrayLike
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

import fivebar as fb
from fivebar.model.dynamics import linkage_dynamics
from fivebar.model.assembly import build_model
from fivebar.numerics.continuation import continuation
from fivebar.errors import InputError, InputTypeError, checked
from fivebar.model.kinematics import GeometryError, positions

settings.register_profile(
    "fivebar", max_examples=50, deadline=None, derandomize=True, database=None, print_blob=False,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fivebar"))

P = fb.load_params()
#: a cheap problem for the solvers: linear, no motors, S = 100
CHEAP = fb.Setup(P, motors=False, nonlinear=False, steps_per_period=100)

# --- strategies ------------------------------------------------------------------------------
#: what is not a number, where one is expected
not_numbers = st.one_of(
    st.booleans(),
    st.none(),
    st.text(max_size=4),
    st.complex_numbers(max_magnitude=1e3),
    st.lists(st.floats(-10, 10), min_size=0, max_size=3),
)
#: NumPy numbers and 0-d arrays (numbers, to be accepted as such)
numpy_numbers = st.one_of(
    st.floats(-1e3, 1e3).map(np.float64),
    st.floats(-1e3, 1e3, width=32).map(np.float32),
    st.integers(-1000, 1000).map(np.int64),
    st.floats(-1e3, 1e3).map(np.array),  # 0-d arrays
)
#: a value where a number is expected: numbers of every kind, and what is not one
anything = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**12, 10**12), numpy_numbers,
                     not_numbers)
#: as ``anything``, its numbers bounded (a continuation over 1e12 in steps of 0.5 would not end)
bounded = st.one_of(st.floats(-1e3, 1e3), st.sampled_from([math.nan, math.inf, -math.inf]), st.integers(-1000, 1000),
                    numpy_numbers, not_numbers)
#: a positive number spanning many orders of magnitude (most of a parameter file's entries)
magnitude = st.floats(-12, 12).map(lambda e: 10.0 ** e)
#: a TOML value: mostly a plausible number, sometimes not a number at all
toml_value = st.one_of(
    magnitude, magnitude.map(lambda x: -x), st.just(0.0), st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-5, 5), st.booleans(), st.text(max_size=3))
#: a key of a parameter file: one the default file has, or a name of one's own
KNOWN = {
    "geometry": ["L1", "L2", "L3", "L4", "L5", "width", "thickness"],
    "masses": ["m01", "m02"],
    "material": ["rho", "E"],
    "assumptions": ["crank_speed_rpm", "bending_depth", "damping_ratio", "speed_ratio", "gravity",
                    "eccentricity_scale"],
    "simulation": ["theta1_0", "theta4_0", "rho_infinity"],
}
entry = st.tuples(st.sampled_from(sorted(KNOWN)), st.one_of(
    st.sampled_from(sorted({k for v in KNOWN.values() for k in v})),
    st.text(st.characters(codec="utf-8", exclude_categories=["Cs", "Cc"]), min_size=1, max_size=6)))


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    return json.dumps(value)  # a TOML basic string (\uXXXX escapes)


def _write(entries: dict[tuple[str, str], object]) -> Path:
    sections: dict[str, list[str]] = {}
    for (section, key), value in entries.items():
        sections.setdefault(section, []).append(f"{json.dumps(key)} = {_toml(value)}")
    fd, name = tempfile.mkstemp(suffix=".toml", prefix="fivebar-prop-")
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write("".join(f"[{s}]\n" + "\n".join(lines) + "\n" for s, lines in sections.items()))
    return Path(name)


# --- the physics checks ----------------------------------------------------------------------
def _check_kinematics(params, angles) -> None:
    """Every link keeps its length; the loop closes (the positions are finite and consistent)."""
    P_ = positions(params, *angles)
    for xy in P_.values():
        assert np.all(np.isfinite(xy))
    scale = max(params.lengths)
    for link in params.linkage.links:
        d = np.linalg.norm(P_[link.end] - P_[link.start])
        assert abs(d - link.length) <= 1e-9 * scale, (link.name, d, link.length)
    a, b = (np.asarray(j.at, float) for j in params.linkage.ground)
    assert np.allclose(P_[params.linkage.chain[0]], a) and np.allclose(P_[params.linkage.chain[-1]], b)


def _check_model(params) -> None:
    """The sampled mass matrix is symmetric positive definite; damping, stiffness, load finite."""
    dyn = linkage_dynamics(fb.Setup(params, motors=False, nonlinear=False, steps_per_period=max(21, 2 * params.fourier_terms + 1)))
    sd = dyn.step_data
    for X in (sd.M, sd.C, sd.K, sd.F):
        assert np.all(np.isfinite(X))
    M = sd.M[0]
    assert np.allclose(M, M.T, rtol=0, atol=1e-12 * np.abs(M).max())
    assert np.linalg.eigvalsh(0.5 * (M + M.T)).min() > 0.0


def _check_steady(res, tol: float) -> None:
    """Finite, and periodic: the end state equals the start in the energy norm of the frozen
    matrices at t = 0, relative to the largest energy of the period."""
    assert np.all(np.isfinite(res.u)) and np.all(np.isfinite(res.v))
    sd = res.dynamics.step_data
    M, K = sd.M[0], sd.K[0]

    def energy(u, v):
        return float(np.sqrt(max(u @ K @ u + v @ M @ v, 0.0)))

    big = max(energy(u, v) for u, v in zip(res.u, res.v))
    gap = energy(res.u[-1] - res.u[0], res.v[-1] - res.v[0])
    assert gap <= tol * max(big, 1e-300), (gap, big)
    for link in res.dynamics.params.linkage.couplers:
        assert math.isfinite(res.peak_to_peak_mm(link))


def _answers(fn, *args, **kwargs):
    """``fn(...)``'s result, or None if it raised a FivebarError; any other exception fails
    the test (the result's own checks catch a silent NaN)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (the results are checked for NaN themselves)
        try:
            out = fn(*args, **kwargs)
        except fb.FivebarError as exc:
            event(f"{getattr(fn, '__name__', fn)}: {type(exc).__name__}")
            return None
    event(f"{getattr(fn, '__name__', fn)}: a result")
    return out


# --- random parameter files ------------------------------------------------------------------
@given(st.dictionaries(entry, toml_value, max_size=4),
       st.tuples(st.floats(0, 2 * math.pi), st.floats(0, 2 * math.pi)))
@example({("geometry", "L22"): 0.3}, (0.0, 0.0))  # a typo of L2: kept and ignored before
@example({("geometry", "Länge"): 0.3}, (0.0, 0.0))  # a non-ASCII key
@example({("simulation", "theta1_0"): 1e20}, (0.0, 0.0))  # a legal angle the model cannot resolve
@example({("material", "rho"): 1e-10}, (0.0, 0.0))  # C full of NaN before
@example({("material", "E"): 1e300}, (0.0, 0.0))  # numpy's LinAlgError before
def test_a_random_parameter_file_gives_a_sound_model_or_a_fivebar_error(entries, angles):
    path = _write(entries)
    try:
        params = _answers(fb.load_params, [fb.DEFAULT_PARAMS_PATH, path])
    finally:
        path.unlink()
    if params is None:
        return
    for (section, key), value in entries.items():  # what the file says is what the set holds
        if f"{section}.{key}" in params.values and isinstance(value, float) and key in KNOWN.get(section, ()):
            assert params.values[f"{section}.{key}"] == value
    try:
        _check_kinematics(params, angles)
    except GeometryError:  # the loop cannot close at these angles: said, with the angles
        pass
    if _answers(_check_model, params) is None:
        return


@settings(max_examples=25)
@given(st.dictionaries(st.sampled_from([("geometry", "L2"), ("geometry", "L3"), ("masses", "m02"),
                                        ("material", "rho"), ("material", "E"), ("assumptions", "damping_ratio")]),
                       st.one_of(magnitude, st.floats(0.2, 0.6)), max_size=3),
       st.floats(5.0, 1500.0))
@pytest.mark.slow
def test_a_random_parameter_file_gives_a_periodic_steady_state_or_a_fivebar_error(entries, rpm):
    path = _write(entries)
    try:
        params = _answers(fb.load_params, [fb.DEFAULT_PARAMS_PATH, path])
    finally:
        path.unlink()
    if params is None:
        return
    res = _answers(fb.steady_state, fb.Setup(params, motors=False, steps_per_period=100, crank_speed_rpm=rpm))
    if res is not None:
        _check_steady(res, 1e-6)


# --- random arguments of the entry points ----------------------------------------------------
angles = st.one_of(st.floats(-10, 10), numpy_numbers, st.lists(st.floats(-10, 10), min_size=1, max_size=4))


@given(angles, angles, st.sampled_from([None, 1, -1]))
@example([0.1, 0.2], [0.1, 0.2, 0.3], None)  # found: numpy's ValueError (shapes that do not broadcast)
def test_positions_of_random_sound_angles_close_the_loop_or_raise_a_geometry_error(t1, t4, mode):
    _positions(t1, t4, mode)


@given(anything, anything, st.one_of(st.none(), anything))
@example(float("nan"), 0.0, None)  # NaN coordinates before
@example(float("inf"), 0.0, None)
@example("x", 0.0, None)  # numpy's ValueError before
@example(True, 0.0, None)
@example(0.1, 0.2, True)
@example(0.0, 0j, None)  # found: a complex angle reached numpy's float()
def test_positions_of_random_angles_close_the_loop_or_raise_a_fivebar_error(t1, t4, mode):
    _positions(t1, t4, mode)


def _positions(t1, t4, mode):
    P_ = _answers(positions, P, t1, t4, mode=mode)
    if P_ is None:
        return
    a1, a4 = np.broadcast_arrays(np.asarray(t1, float), np.asarray(t4, float))
    for idx in np.ndindex(a1.shape):
        _check_kinematics(P, (float(a1[idx]), float(a4[idx]))) if mode in (None, 1) else None
    for xy in P_.values():
        assert np.all(np.isfinite(xy))


@given(st.one_of(st.floats(-10, 10), numpy_numbers), st.one_of(st.floats(-10, 10), numpy_numbers),
       st.integers(1, 40), st.booleans())
def test_natural_frequencies_of_random_sound_arguments_are_positive_and_ascending(t1, t4, n, motors):
    _frequencies(fb.Setup(P, motors=motors), t1, t4, n)


@given(anything, anything, anything)
@example(float("nan"), 0.0, 6)  # numpy's ValueError before
@example(0.0, 0.0, True)
def test_natural_frequencies_of_random_arguments_are_positive_and_ascending_or_a_fivebar_error(t1, t4, n):
    _frequencies(P, t1, t4, n)


def _frequencies(setup, t1, t4, n):
    f = _answers(fb.natural_frequencies, setup, t1, t4, n_modes=n)
    if f is None:
        return
    assert f.ndim == 1 and f.size >= 1 and np.all(np.isfinite(f)) and np.all(f > 0) and np.all(np.diff(f) >= 0)


def _steady(rpm, S, method, tol, nonlinear=False):
    try:
        setup = CHEAP.replace(crank_speed_rpm=rpm, steps_per_period=S, nonlinear=nonlinear)
    except fb.FivebarError:
        return
    res = _answers(fb.steady_state, setup, method=method, tol=tol)
    if res is not None:
        _check_steady(res, 1e-5)


@settings(max_examples=30)
@given(st.floats(5.0, 1500.0), st.integers(21, 400), st.sampled_from(["shooting", "march"]),
       st.one_of(st.none(), st.floats(1e-3, 0.2)), st.booleans())
def test_steady_state_of_random_sound_arguments_is_periodic_or_a_fivebar_error(rpm, S, method, tol, nonlinear):
    _steady(rpm, S, method, tol, nonlinear)


@given(st.one_of(st.floats(-100, 1500), anything), st.one_of(st.integers(0, 500), anything),
       st.one_of(st.sampled_from(["shooting", "march"]), anything), st.one_of(st.none(), anything))
@example(-300.0, 100, "shooting", None)
@example(300.0, 0, "shooting", None)  # "an integer >= 1" though the minimum is 21, before
@example(300.0, 100, "shooting", "0.01")
def test_steady_state_of_random_arguments_is_periodic_or_a_fivebar_error(rpm, S, method, tol):
    _steady(rpm, S, method, tol)


@settings(max_examples=20)
@given(st.lists(st.one_of(st.floats(50, 400), st.floats(50, 400), st.floats(50, 400), anything), max_size=3),
       st.one_of(st.booleans(), st.booleans(), anything), st.one_of(st.booleans(), st.booleans(), anything))
@example([True], False, False)  # 1 r/min before
@example([100.0], "no", False)  # a truthy string before
def test_speed_sweep_of_random_arguments_gives_finite_rows_or_a_fivebar_error(speeds, cache, accuracy):
    df = _answers(fb.speed_sweep, CHEAP, speeds, progress=False, cache=cache, accuracy=accuracy)
    if df is None:
        return
    assert len(df) == len(speeds)
    assert np.all(np.isfinite(df.select_dtypes("number").to_numpy(float)))
    assert np.allclose(df["speed (r/min)"], [float(np.asarray(s)) for s in speeds])


@settings(max_examples=10)
@given(st.lists(st.floats(20, 600), min_size=1, max_size=3), st.booleans())
def test_speed_sweep_of_random_sound_speeds_gives_the_steady_states_peak_to_peak(speeds, nonlinear):
    setup = CHEAP.replace(nonlinear=nonlinear)
    df = _answers(fb.speed_sweep, setup, speeds, progress=False, cache=False)
    if df is None:
        return
    assert np.all(np.isfinite(df.select_dtypes("number").to_numpy(float)))
    for s_, row in zip(speeds, df.to_dict("records")):  # each row: its own steady state's
        res = fb.steady_state(setup.replace(crank_speed_rpm=s_))
        assert row["L2 p2p (mm)"] == pytest.approx(res.peak_to_peak_mm("L2"), rel=1e-6)


@given(st.dictionaries(st.one_of(st.sampled_from(sorted({k for v in KNOWN.values() for k in v})),
                                 st.text(max_size=8)), toml_value, max_size=3),
       st.one_of(st.none(), st.floats(1.0, 1000.0), anything), st.one_of(st.none(), st.integers(21, 400), anything),
       st.one_of(st.integers(1, 3), st.integers(1, 3), anything))
def test_overrides_setups_and_transients_of_random_arguments_are_finite_or_a_fivebar_error(
        overrides, rpm, S, periods):
    params = _answers(fb.load_params, overrides=overrides)
    if params is None:
        return
    setup = _answers(fb.Setup, params, crank_speed_rpm=rpm, steps_per_period=S, motors=False, nonlinear=False)
    if setup is None:
        return
    if setup.steps_per_period > 2000:
        return  # (a memory check of its own: tests/edge_cases.py)
    r = _answers(fb.transient, setup, periods)
    if r is not None:
        assert np.all(np.isfinite(r.u)) and np.all(np.isfinite(r.v)) and len(r.t) == setup.steps_per_period * int(periods) + 1
    q = _answers(fb.quasi_static, setup)
    if q is not None:
        assert np.all(np.isfinite(q.u)) and np.allclose(q.u[0], q.u[-1])


class _Toy:
    """x_T = x / 2 + p: the fixed point x = 2 p, monodromy diag(1/2) (multipliers 1/2)."""

    def __call__(self, x, p=None, jacobian=False):
        x = np.asarray(x, float)
        return 0.5 * x + p, (0.5 * np.eye(x.size) if jacobian else None)


@given(st.floats(-100.0, 100.0), st.floats(-100.0, 100.0), st.integers(2, 30),
       st.one_of(st.none(), st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)),
       st.one_of(st.none(), st.tuples(st.floats(1.0, 500.0), st.floats(1.0, 500.0))))
def test_continuation_of_random_sound_arguments_follows_fixed_points_or_raises_a_fivebar_error(
        p0, p_end, n, tangent, widths):
    bounds = None if widths is None else (p0 - widths[0], p0 + widths[1])
    _follow(p0, p_end, n, tangent, bounds)


@given(bounded, bounded, st.one_of(st.integers(-3, 12), st.floats(-3, 12), st.text(max_size=2), st.booleans()),
       st.one_of(st.none(), anything),
       st.one_of(st.none(), st.tuples(st.floats(-200, 200), st.floats(-200, 200)), anything))
@example(60.0, 70.0, 0, None, None)  # accepted before
@example(60.0, 70.0, 2.5, None, None)
@example(60.0, 70.0, 5, "x", None)
@example(60.0, 70.0, 5, None, (80.0, 50.0))  # stopped after one step before
def test_continuation_of_random_arguments_follows_fixed_points_or_raises_a_fivebar_error(p0, p_end, n, tangent, bounds):
    _follow(p0, p_end, n, tangent, bounds)


def _follow(p0, p_end, n, tangent, bounds):
    f = _Toy()
    x0 = np.array([1.0, 2.0])
    br = _answers(continuation, f, x0, p0, p_end, max_points=n, tangent=tangent, p_bounds=bounds)
    if br is None:
        return
    assert 1 <= len(br.points) <= int(n)
    for q in br.points:
        assert np.all(np.isfinite(q.x)) and math.isfinite(q.p)
        assert np.allclose(f(q.x, q.p)[0], q.x, rtol=1e-8, atol=1e-8 * max(1.0, abs(q.p)))
        assert np.allclose(np.abs(q.multipliers), 0.5)


@given(st.sampled_from(sorted({k for v in KNOWN.values() for k in v}) + ["L22", "m0", "colour"]), toml_value)
@example("thickness", 0.002)  # refused as "ambiguous" before
@example("width", 0.03)
def test_params_replace_of_random_entries_gives_a_closing_linkage_or_a_fivebar_error(key, value):
    q = _answers(P.replace, **{key: value})
    if q is None:
        return
    try:
        _check_kinematics(q, (0.3, 1.1))
    except GeometryError:
        pass


# --- the validation layer itself -------------------------------------------------------------
@checked
def _probe(x: float, n: int, flag: bool, a: ArrayLike, s: str = "x", tol: float = 1e-6) -> tuple:
    return x, n, flag, a, s, tol


@given(anything, anything, anything, anything, anything, anything)
def test_the_validation_layer_passes_on_sound_values_and_names_the_argument_otherwise(x, n, flag, a, s, tol):
    try:
        out = _probe(x, n, flag, a, s, tol)
    except (InputError, InputTypeError) as exc:
        msg = str(exc)
        assert any(f"{name} = " in msg for name in ("x", "n", "flag", "a", "s", "tol")), msg
        return
    X, N, F, A, S, T = out
    assert type(X) in (int, float) and math.isfinite(X)
    assert type(N) is int and N == n
    assert type(F) is bool
    arr = np.asarray(A)
    assert arr.dtype.kind in "iufc" and np.all(np.isfinite(arr))
    assert isinstance(S, str)
    assert type(T) in (int, float) and T > 0


def test_a_bool_or_a_truthy_string_is_never_taken_for_a_number_or_a_flag():
    for bad in (dict(x=True), dict(n=False), dict(flag="no"), dict(a=[1.0, True]), dict(tol=-1.0)):
        args = dict(x=1.0, n=2, flag=False, a=[1.0], s="x", tol=1e-6) | bad
        with pytest.raises((InputError, InputTypeError), match=f"{next(iter(bad))} = "):
            _probe(**args)
