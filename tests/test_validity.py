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
    assert len(v["reasons"]) == 3 and v["compression / Euler load"] > 1  # 5000 r/min: it buckles too
    msgs = [str(x.message) for x in w if issubclass(x.category, ValidityWarning)]
    assert len(msgs) == 1 and "yield stress" in msgs[0] and "small-deflection" in msgs[0] and "buckle" in msgs[0]
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


# --------------------------------------------------------------------------------------------
# Buckling: the Euler loads and the axial force of the links
# --------------------------------------------------------------------------------------------


def test_euler_loads_are_the_closed_form(params):
    """pi^2 E I / L^2 of the 30 mm x 2 mm aluminium bar typed out by hand: the coupler's 2 mm
    side buckles at about 86 N (E = 70 GPa, I = 30 * 2^3 / 12 mm^4 = 20 mm^4, L = 400 mm), its
    30 mm side at 225 times that; K = 0.5 quarters the length squared."""
    from fivebar.model.elements import euler_loads

    L2 = params.linkage.link("L2")
    assert L2.material.E == 70e9 and L2.length == 0.4 and L2.section.bending_depth == 0.030
    in_plane, out_of_plane = euler_loads(L2)
    assert out_of_plane == pytest.approx(math.pi**2 * 70e9 * 20e-12 / 0.16, rel=1e-12)
    assert out_of_plane == pytest.approx(86.36, abs=0.01)
    assert in_plane == pytest.approx(math.pi**2 * 70e9 * (2 * 30**3 / 12) * 1e-12 / 0.16, rel=1e-12)
    flex = params.replace(bending_depth=0.002).linkage.link("L2")
    assert euler_loads(flex) == pytest.approx((out_of_plane, in_plane), rel=1e-12)  # the sides swap
    assert euler_loads(L2, 0.5)[1] == pytest.approx(4 * out_of_plane, rel=1e-12)
    with pytest.raises(FivebarError, match="effective_length_factor"):
        euler_loads(L2, 0.0)


def test_euler_load_is_the_buckling_load_of_the_beam_element(params):
    """The closed form against the book's own beam element: the lowest eigenvalue P of
    (K - P K_g) v = 0 for a pinned-pinned bar of quintic elements, K_g = int g g^T (g the slope
    shape functions), the geometric stiffness of a unit compression."""
    from fivebar.model.elements import assemble_line, euler_loads, gauss_points, shape_functions
    from scipy.linalg import eigh

    link = params.replace(bending_depth=0.002).linkage.link("L2")
    E, A, L, n = link.material.E, link.section.area, link.length, 4
    I = A * 0.002**2 / 12
    _, K = assemble_line(n, L, E, A, I, link.material.rho)
    le = L / n
    x, w = gauss_points(8, le)
    g = shape_functions(x, le, derivative=1)
    g[:, [0, 4]] = 0.0
    Kg = np.zeros_like(K)
    for j in range(n):
        s = slice(4 * j, 4 * j + 8)
        Kg[s, s] += (g * w[:, None]).T @ g
    last = 4 * n
    fixed = {1, 3, last + 1, last + 3}  # w = w'' = 0 at both pins
    keep = [i for i in range(K.shape[0]) if i % 4 != 0 and i not in fixed]
    P = eigh(K[np.ix_(keep, keep)], Kg[np.ix_(keep, keep)], eigvals_only=True)
    assert P.min() == pytest.approx(euler_loads(link)[0], rel=1e-6)


@pytest.mark.parametrize("nonlinear, measure", [(False, None), (True, "uniform"), (True, "literal"), (True, "corotated")])
def test_axial_force_is_the_derivative_of_the_element_energy(params, nonlinear, measure):
    """N of every element equals the derivative of its axial strain energy,
    EA L V'^2 / 2 + Pi_nl(q) (fivebar.model.nonlinear.element_energy), with respect to the stretch
    u2 (central differences), for an elastic field of a few millimetres."""
    from fivebar.model.dynamics import linkage_dynamics
    from fivebar.model.nonlinear import element_energy

    p = params if measure is None else params.replace(strain_measure=measure)
    dyn = linkage_dynamics(fivebar.Setup(p, motors=False, nonlinear=nonlinear, steps_per_period=24))
    rng = np.random.default_rng(3)
    u = 2e-3 * rng.standard_normal((3, dyn.n))
    t = dyn.t[:3]
    res = fivebar.Response(dyn, t, u, 0 * u, "test field")
    N = {el.link: res.axial_force(el.link) for el in dyn.model.elements}
    q = dyn.model.element_displacements(dyn.expand(u), *dyn.crank_angles(t))
    for i, el in enumerate(dyn.model.elements):
        link = p.linkage.link(el.link)
        EA, L = link.material.E * link.section.area, el.length
        of_link = [j for j, e in enumerate(dyn.model.elements) if e.link == el.link]
        k = of_link.index(i)
        k = len(of_link) - 1 - k if dyn.model._reversed(el.link) else k  # axial_force: from the link's start
        for s in range(3):
            def energy(u2):
                qq = q[s, i].copy()
                qq[4] = u2
                lin = 0.5 * EA * L * ((qq[4] - qq[0]) / L) ** 2
                return lin + (element_energy(qq, L, EA, measure) if nonlinear else 0.0)
            h = 1e-7
            dE = (energy(q[s, i, 4] + h) - energy(q[s, i, 4] - h)) / (2 * h)
            assert N[el.link][s, k] == pytest.approx(dE, rel=1e-6, abs=1e-6 * EA * 1e-3)


def test_the_buckling_check_is_in_the_validity_table(params):
    """At the book's speed the couplers are in compression over part of the turn, far below the
    86 N of their 2 mm side (the quasi-static inertial load: about m02 Omega^2 L1 ~ 1 N); the
    compression grows as Omega^2, so at 8 times the speed it is 64 times larger; a bar made
    thinner in the check's formula (a K that makes the Euler load tiny) fails it."""
    st = fivebar.steady_state(_linear(params, params.crank_speed_rpm))
    v = st.validity
    assert v["buckling link"] in ("L2", "L3") and v["Euler load (N)"] == pytest.approx(86.36, abs=0.01)
    assert 0.2 < v["largest compression (N)"] < 5.0 and v["compression / Euler load"] < 0.1 and v["valid"]
    fast = fivebar.quasi_static(_linear(params, 8 * params.crank_speed_rpm))
    slow = fivebar.quasi_static(_linear(params, params.crank_speed_rpm))
    c_fast = fast.buckling()[v["buckling link"]]["largest compression (N)"]
    c_slow = slow.buckling()[v["buckling link"]]["largest compression (N)"]
    assert c_fast == pytest.approx(64 * c_slow, rel=1e-9)
    tiny = st.buckling(effective_length_factor=10.0)[v["buckling link"]]
    assert tiny["compression / Euler load"] == pytest.approx(100 * v["compression / Euler load"], rel=1e-9)
    branch_cols = {"compression / Euler load", "stress / yield", "deflection / length", "valid"}
    sweep = speed_sweep(_linear(params, 60), [60.0, 120.0], progress=False)
    assert branch_cols <= set(sweep.columns)
    assert (sweep["compression / Euler load"].iloc[1] / sweep["compression / Euler load"].iloc[0]
            == pytest.approx(4.0, rel=0.05))
