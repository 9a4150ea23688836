"""Validity stated with every result (SteadyState.validity, the sweep's columns, the warning).

References: the exact elastica of a cantilever (the small-deflection threshold), the Omega^2
scaling of the quasi-static inertial load (the stress check), a converged solution at 16 S (the
accuracy estimate), the crank laws (the period a speed ratio implies).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_bvp

import fivebar
from fivebar.errors import FivebarError
from fivebar.analyses.steady import DEFLECTION_LIMIT, ValidityWarning
from fivebar.analyses.sweep import speed_sweep


@pytest.fixture(scope="module")
def params():
    return fivebar.load_params()


def _linear(params, rpm, S=100):
    return fivebar.Setup(params, crank_speed_rpm=rpm, motors=False, nonlinear=False, steps_per_period=S)


def _elastica_tip(alpha: float) -> float:
    """Tip deflection / L of a cantilever under a tip load P normal to its axis, alpha = P L^2 / EI:
    theta'' = -alpha cos(theta), theta(0) = 0, theta'(1) = 0 (s: arc length / L)."""
    sol = solve_bvp(lambda s, y: np.vstack([y[1], -alpha * np.cos(y[0])]),
                    lambda a, b: np.array([a[0], b[1]]), np.linspace(0, 1, 101),
                    np.vstack([alpha * (np.linspace(0, 1, 101) - np.linspace(0, 1, 101) ** 2 / 2),
                               alpha * (1 - np.linspace(0, 1, 101))]), tol=1e-10)
    s = np.linspace(0.0, 1.0, 4001)
    return float(np.trapezoid(np.sin(sol.sol(s)[0]), s))


def test_the_deflection_limit_is_where_small_deflection_theory_is_off_by_one_percent():
    """The linear tip deflection alpha / 3 against the elastica: 1 % high at DEFLECTION_LIMIT,
    growing as the square of the deflection."""
    err = {d: d / _elastica_tip(3 * d) - 1 for d in (DEFLECTION_LIMIT / 2, DEFLECTION_LIMIT, 2 * DEFLECTION_LIMIT)}
    assert 0.008 < err[DEFLECTION_LIMIT] < 0.012
    assert err[DEFLECTION_LIMIT] / err[DEFLECTION_LIMIT / 2] == pytest.approx(4.0, rel=0.05)


def test_default_result_is_valid_and_its_note_unchanged(params):
    with warnings.catch_warnings():
        warnings.simplefilter("error", ValidityWarning)
        res = fivebar.steady_state(_linear(params, params.crank_speed_rpm))
    v = res.validity
    assert v["valid"] and v["reasons"] == [] and v["yield stress (MPa)"] == params.yield_stress / 1e6
    assert v["speed ratio"] == "1" and v["period (s)"] == pytest.approx(60.0 / params.crank_speed_rpm)
    assert "OUTSIDE" not in res.note and res.note.startswith("stable: largest Floquet multiplier")


def test_stress_follows_the_quasi_static_load(params):
    """Far below the first resonance the response is quasi-static and the inertial load goes as
    Omega^2: so does the peak bending stress (and the deflection)."""
    a = fivebar.steady_state(_linear(params, 30)).validity
    b = fivebar.steady_state(_linear(params, 60)).validity
    assert b["peak bending stress (MPa)"] / a["peak bending stress (MPa)"] == pytest.approx(4.0, rel=0.02)
    assert b["deflection / length"] / a["deflection / length"] == pytest.approx(4.0, rel=0.02)


def test_a_result_past_yield_and_small_deflection_says_so(params):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = fivebar.steady_state(_linear(params, 5000))
    v = res.validity
    assert not v["valid"] and v["stress / yield"] > 1 and v["deflection / length"] > DEFLECTION_LIMIT
    assert len(v["reasons"]) == 2
    msgs = [str(x.message) for x in w if issubclass(x.category, ValidityWarning)]
    assert len(msgs) == 1 and "yield stress" in msgs[0] and "small-deflection" in msgs[0]
    assert "OUTSIDE THE MODEL'S VALIDITY" in res.note and "yield" in res.note


def test_accuracy_estimate_against_a_converged_solution(params):
    """The validity's estimate (S against 2 S) against the true error of S (against 16 S): for a
    second-order scheme the estimate is about 3/4 of the true error."""
    coarse = fivebar.steady_state(_linear(params, 600, 100))
    ref = fivebar.steady_state(_linear(params, 600, 1600))
    est = coarse.validity["S error estimate"]
    assert coarse.validity["S compared"] == (100, 200)
    true = max(float(np.abs(coarse.midpoint_mm(k) - ref.midpoint_mm(k)[::16]).max() / np.ptp(ref.midpoint_mm(k)))
               for k in ("L2", "L3"))
    assert 0.5 < est / true < 1.2
    if est > 0.01:
        assert "% off S = 200" in coarse.note


def test_the_drive_must_be_periodic(params):
    two = fivebar.steady_state(_linear(params.replace(speed_ratio=2.0), 60)).validity
    assert two["speed ratio"] == "2" and two["period (s)"] == pytest.approx(1.0)
    # 3/2: the motion repeats after two turns of crank AB, the period of every computation in time
    three_halves = params.replace(speed_ratio=1.5)
    assert three_halves.turns == 2 and fivebar.Setup(three_halves).params.period == pytest.approx(2.0)
    with pytest.raises(FivebarError, match="never repeats"):
        fivebar.steady_state(params.replace(speed_ratio=math.sqrt(2)))


def test_bending_depth_is_a_side_of_the_section(params):
    for d in (params.width, params.thickness):
        assert params.replace(bending_depth=d).bending_depth == d
    for d in (0.5, 0.01):
        with pytest.raises(fivebar.ParameterError, match=r"bending_depth = .* one side of the links' section"):
            params.replace(bending_depth=d)


def test_the_sweep_table_carries_the_checks(params):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        df = speed_sweep(_linear(params, 60), [60.0, 5000.0], progress=False, cache=False, accuracy=True)
    for col in ("peak stress (MPa)", "stress / yield", "deflection / length", "period (s)", "valid",
                "S error estimate"):
        assert col in df
    assert df["valid"].tolist() == [True, False]
    assert df["period (s)"].tolist() == pytest.approx([1.0, 0.012])
    msgs = [str(x.message) for x in w if issubclass(x.category, ValidityWarning)]
    assert len(msgs) == 1 and msgs[0].startswith("1 of 2 sweep rows")
