"""Global sensitivity (fivebar.analyses.sensitivity) against indices known in closed form.

Ishigami's function Y = sin x1 + a sin^2 x2 + b x3^4 sin x1 on [-pi, pi]^3 and Sobol's G function
prod (|4 x_i - 2| + a_i) / (1 + a_i) on [0, 1]^D have first-order and total indices in closed
form (Saltelli et al., Global Sensitivity Analysis: The Primer, 2008, and Sobol' 2001); the
estimates must meet them within the tolerances stated in each test, far tighter than the
indices' differences, so a wrong estimator (a swapped matrix, a missing normalisation) fails.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import fivebar
from fivebar.analyses import sensitivity as gsa

A_ISHIGAMI, B_ISHIGAMI = 7.0, 0.1


def _ishigami_inputs():
    return [gsa.UncertainInput(f"x{i}", (-math.pi, math.pi), reason="Ishigami's test function") for i in (1, 2, 3)]


def _ishigami(inputs):
    def f(U):
        x = np.column_stack([np.vectorize(inp.value)(U[:, j]) for j, inp in enumerate(inputs)])
        return np.sin(x[:, 0]) + A_ISHIGAMI * np.sin(x[:, 1]) ** 2 + B_ISHIGAMI * x[:, 2] ** 4 * np.sin(x[:, 0])
    return f


def _ishigami_exact():
    a, b, pi = A_ISHIGAMI, B_ISHIGAMI, math.pi
    V1 = 0.5 * (1 + b * pi**4 / 5) ** 2
    V2 = a**2 / 8
    V13 = b**2 * pi**8 * (1 / 18 - 1 / 50)
    V = V1 + V2 + V13
    return np.array([V1, V2, 0.0]) / V, np.array([V1 + V13, V2, V13]) / V


def test_ishigami_first_order_and_total_indices():
    inputs = _ishigami_inputs()
    res = gsa.sobol_indices(_ishigami(inputs), inputs, width=0.05, n_start=1024, n_max=2**15, seed=3)
    S1, ST = _ishigami_exact()  # 0.314, 0.442, 0; 0.558, 0.442, 0.244
    assert res.converged and res.widest <= 0.05
    np.testing.assert_allclose(res.S1, S1, atol=0.02)
    np.testing.assert_allclose(res.ST, ST, atol=0.02)
    # the intervals cover the exact values (95 % intervals, six of them: a wide margin)
    assert np.all(np.abs(res.S1 - S1) <= 2 * res.S1_conf + 0.005)
    assert np.all(np.abs(res.ST - ST) <= 2 * res.ST_conf + 0.005)


def _g_inputs(D):
    return [gsa.UncertainInput(f"x{i}", (0.0, 1.0), reason="Sobol's G function") for i in range(D)]


def test_sobol_g_function_indices():
    a = np.array([0.0, 1.0, 4.5, 9.0, 99.0, 99.0])
    inputs = _g_inputs(len(a))

    def g(U):
        return np.prod((np.abs(4 * U - 2) + a) / (1 + a), axis=1)

    Vi = 1 / (3 * (1 + a) ** 2)
    V = np.prod(1 + Vi) - 1
    S1 = Vi / V
    ST = Vi * np.array([np.prod(np.delete(1 + Vi, i)) for i in range(len(a))]) / V
    res = gsa.sobol_indices(g, inputs, width=0.05, n_start=2048, n_max=2**15, seed=5)
    assert res.converged
    np.testing.assert_allclose(res.S1, S1, atol=0.025)
    np.testing.assert_allclose(res.ST, ST, atol=0.02)
    # the ranking of the important inputs is exact, and the unimportant ones are found
    assert list(np.argsort(-res.ST)[:4]) == [0, 1, 2, 3]
    assert np.all(res.ST[4:] < 0.01)


def test_morris_ranks_the_g_function_and_finds_the_inert_input():
    a = np.array([0.0, 1.0, 9.0, 99.0])
    inputs = _g_inputs(len(a)) + [gsa.UncertainInput("inert", (0.0, 1.0), reason="no effect")]

    def g(U):
        return np.prod((np.abs(4 * U[:, :4] - 2) + a) / (1 + a), axis=1)

    res = gsa.morris_indices(g, inputs, trajectories=40, seed=2)
    assert list(np.argsort(-res.mu_star)) == [0, 1, 2, 3, 4]
    assert res.mu_star[4] == 0.0 and res.sigma[4] == 0.0
    assert [i.key for i in res.screen(0.05)] == ["x0", "x1", "x2"]
    # a linear function: every elementary effect is its slope times the range, exactly
    lin = gsa.morris_indices(lambda U: 3.0 * U[:, 0] - 2.0 * U[:, 1], inputs[:2], trajectories=5, seed=1)
    np.testing.assert_allclose(lin.mu_star, [3.0, 2.0], rtol=1e-12)
    np.testing.assert_allclose(lin.sigma, [0.0, 0.0], atol=1e-12)


def test_results_are_pure_functions_of_the_seed():
    inputs = _ishigami_inputs()
    f = _ishigami(inputs)
    one = gsa.sobol_indices(f, inputs, width=0.2, n_start=256, n_max=1024, seed=11)
    np.random.seed(123)  # global state must not matter
    np.random.random(7)
    two = gsa.sobol_indices(f, inputs, width=0.2, n_start=256, n_max=1024, seed=11)
    for name in ("S1", "S1_conf", "ST", "ST_conf"):
        assert np.array_equal(getattr(one, name), getattr(two, name))
    other = gsa.sobol_indices(f, inputs, width=0.2, n_start=256, n_max=1024, seed=12)
    assert not np.array_equal(one.S1, other.S1)
    m1 = gsa.morris_indices(f, inputs, trajectories=6, seed=4)
    m2 = gsa.morris_indices(f, inputs, trajectories=6, seed=4)
    assert np.array_equal(m1.mu_star, m2.mu_star) and np.array_equal(m1.mu_star_conf, m2.mu_star_conf)


def test_the_sample_is_doubled_until_the_intervals_are_narrow_enough():
    inputs = _ishigami_inputs()
    calls = []
    f0 = _ishigami(inputs)

    def f(U):
        calls.append(len(U))
        return f0(U)

    res = gsa.sobol_indices(f, inputs, width=0.1, n_start=128, n_max=2**14, seed=1)
    h = res.history
    assert list(h["N"]) == [128 * 2**k for k in range(len(h))] and h["N"].iloc[-1] == res.N
    assert (h["widest interval"].iloc[:-1] > 0.1).all() and h["widest interval"].iloc[-1] <= 0.1
    assert sum(calls) == res.N * (len(inputs) + 2)  # each doubling evaluates only the new points
    capped = gsa.sobol_indices(f0, inputs, width=0.001, n_start=128, n_max=256, seed=1)
    assert not capped.converged and capped.N == 256


def test_choices_map_the_unit_interval_to_equally_likely_alternatives():
    inp = gsa.UncertainInput("assumptions.damping_model", choices=("modal", "stiffness"), reason="r")
    assert [inp.value(u) for u in (0.0, 0.49, 0.5, 1.0)] == ["modal", "modal", "stiffness", "stiffness"]
    assert inp.unit("stiffness") == 0.75
    rng = gsa.UncertainInput("material.E", (68e9, 72e9), reason="r")
    assert rng.value(0.25) == 69e9 and rng.unit(70e9) == 0.5
    with pytest.raises(gsa.SensitivityError, match="outside its range"):
        rng.unit(80e9)


def test_bad_ranges_and_inputs_are_refused(tmp_path):
    with pytest.raises(gsa.SensitivityError, match="low must be below high"):
        gsa.UncertainInput("material.E", (72e9, 68e9), reason="r")
    with pytest.raises(gsa.SensitivityError, match="has no reason"):
        gsa.UncertainInput("material.E", (68e9, 72e9))
    with pytest.raises(gsa.SensitivityError, match="either range"):
        gsa.UncertainInput("material.E", (68e9, 72e9), choices=(1, 2), reason="r")
    bad = tmp_path / "bad.toml"
    bad.write_text('[[input]]\nkey = "material.E"\nrange = [72.0e9, 68.0e9]\nreason = "r"\n')
    with pytest.raises(fivebar.FivebarError, match=r"range = \[72000000000.0, 68000000000.0\] is not allowed"):
        gsa.load_ranges(bad)
    bad.write_text('[[input]]\nkey = "material.Young"\nrange = [68.0e9, 72.0e9]\nreason = "r"\n')
    with pytest.raises(gsa.SensitivityError, match="'material.Young' names no parameter"):
        gsa.load_ranges(bad)
    bad.write_text('[[input]]\nkey = "material.E"\nrange = [68.0e9, 72.0e9]\n')
    with pytest.raises(gsa.SensitivityError, match="has no reason"):
        gsa.load_ranges(bad)
    bad.write_text('[[input]]\nkey = "material.E"\nrange = [68.0e9, 72.0e9]\nreason = "r"\nsource = "x"\n')
    with pytest.raises(gsa.SensitivityError, match="unknown field"):
        gsa.load_ranges(bad)
    with pytest.raises(gsa.SensitivityError, match="has no range"):
        gsa.check_inputs(["material.Young"], fivebar.load_params())


def test_the_shipped_ranges_hold_the_books_values():
    params = fivebar.load_params()
    inputs = gsa.load_ranges()
    assert len({i.key for i in inputs}) == len(inputs)
    for inp in inputs:
        assert 0.0 <= inp.unit(params.values[inp.key]) <= 1.0, inp.key  # raises if outside
    assert {i.key for i in inputs if i.reading} == {"assumptions.crank_speed_rpm", "assumptions.bending_depth",
                                                    "assumptions.gravity"}


def test_bending_depth_follows_the_side_it_names():
    params = fivebar.load_params()
    w = gsa.UncertainInput("geometry.width", (0.0297, 0.0303), reason="r")
    t = gsa.UncertainInput("geometry.thickness", (0.0019, 0.0021), reason="r")
    side = gsa.UncertainInput("assumptions.bending_depth", choices=(0.030, 0.002), reason="r")
    p = gsa.apply(params, [w, t], [1.0, 0.0])
    assert p.bending_depth == p.width == 0.0303 and p.thickness == 0.0019
    p = gsa.apply(params, [w, t, side], [0.0, 1.0, 0.9])
    assert p.bending_depth == p.thickness == 0.0021


def test_linkage_outputs_bad_outputs_and_nan_are_named():
    params = fivebar.load_params()
    setup = fivebar.Setup(params, steps_per_period=50, nonlinear=False)
    inp = [gsa.UncertainInput("masses.m02", (0.0828, 0.1012), reason="r")]
    with pytest.raises(gsa.SensitivityError, match="output = 'L9 p-p' is not allowed"):
        gsa.evaluate("L9 p-p", setup, inp, [[0.5]], progress=False)
    with pytest.raises(gsa.SensitivityError, match="must return one real number"):
        gsa.evaluate(_vector_output, setup, inp, [[0.5]], progress=False)
    with pytest.raises(gsa.SensitivityError, match=r"is nan at masses.m02 = 0.092"):
        gsa.evaluate(_nan_output, setup, inp, [[0.5]], progress=False)
    with pytest.raises(gsa.SensitivityError, match="the model returned nan at point 1"):
        gsa.sobol_indices(lambda U: np.where(np.arange(len(U)) == 1, np.nan, 1.0), inp, n_start=4, n_max=4)


def _vector_output(setup):
    return np.array([1.0, 2.0])


def _nan_output(setup):
    return float("nan")


def test_figure6_response_is_linear_in_the_joint_mass_and_the_executor_changes_nothing():
    """The L2 p-p against the lumped mass at C, evaluated serially and on an executor: bitwise the
    same, and (quasi-static, linear model) the elementary effect of m02 on the quasi-static
    response is the exact difference quotient of two direct steady states."""
    params = fivebar.load_params()
    setup = fivebar.Setup(params, steps_per_period=50, nonlinear=False)
    inp = [gsa.UncertainInput("masses.m02", (0.0828, 0.1012), reason="r"),
           gsa.UncertainInput("assumptions.gap_flux_density", (0.6, 0.9), reason="r")]
    U = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    serial = gsa.evaluate("L2 p-p (um)", setup, inp, U, progress=False)
    with ThreadPoolExecutor(2) as ex:
        parallel = gsa.evaluate("L2 p-p (um)", setup, inp, U, executor=ex, progress=False, chunk=1)
    assert np.array_equal(serial, parallel)
    direct = [1e3 * fivebar.steady_state(setup.replace(params=params.replace(m02=m))).peak_to_peak_mm("L2")
              for m in (0.0828, 0.1012)]
    np.testing.assert_allclose(serial[:2], direct, rtol=1e-12)
    assert serial[2] == serial[1]  # the field acts on the rotors' whirl only (decoupled): exactly no effect


def test_surrogate_reproduces_a_polynomial_and_reports_its_error():
    inputs = _g_inputs(3)
    U = gsa.unit_sample(inputs, 64, seed=1)
    f = lambda U: 1.0 + U[:, 0] ** 2 - 2 * U[:, 1] * U[:, 2] + U[:, 2] ** 3  # noqa: E731
    sur = gsa.fit_surrogate(inputs, U, f(U), log=False)
    V = gsa.unit_sample(inputs, 50, seed=2)
    np.testing.assert_allclose(sur(V), f(V), rtol=1e-10)
    assert sur.loo_error < 1e-10
    check = sur.validate(V, f(V))
    assert check["relative difference"].abs().max() < 1e-10
    with pytest.raises(gsa.SensitivityError, match="too few"):
        gsa.fit_surrogate(inputs, U[:3], f(U[:3]))


def test_spread_shrinks_to_nothing_when_every_input_is_fixed():
    inputs = _g_inputs(2)
    sp = gsa.spread(lambda U: 1.0 + U[:, 0] + 0.1 * U[:, 1], inputs, [0.5, 0.5], [0, 1], n=1024)
    assert list(sp["inputs varied"]) == [2, 1, 0]
    # x0 uniform over [0, 1] around 1.55: the central 95 % of x0 + 0.1 x1 is within about -/+ 0.5 / 1.55
    assert 25 < sp["largest (%)"].iloc[0] < 35
    assert sp["largest (%)"].iloc[1] < 4 and sp["largest (%)"].iloc[2] == 0.0
