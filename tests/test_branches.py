"""The linkage's periodic steady state followed in a parameter (fivebar.analyses.branches).

Checked against the library's two other routes to the same orbit, which share with the
continuation only the time integrator: ``steady_state`` (shooting from the quasi-static start,
one speed at a time) and brute force (long marches, one Poincaré sample per period, the speed
stepped up and down, no Newton on periodicity and no monodromy matrix).  The linear model of
the flexible orientation (2 mm in plane), motors off, keeps these tests fast; the nonlinear
model is being corrected elsewhere (issue 18, point 1).
"""

import numpy as np
import pytest

import fivebar
from fivebar.analyses.branches import brute_force_diagram, describe_speed, follow, linkage_period_map
from fivebar.errors import FivebarError
from fivebar.analyses.branches import steady_state
from fivebar.description.setup import Setup
from fivebar.model.dynamics import linkage_dynamics


@pytest.fixture(scope="module")
def setup():
    p = fivebar.load_params().replace(bending_depth=0.002)
    return fivebar.Setup(p, crank_speed_rpm=30, steps_per_period=200, motors=False, nonlinear=False)


@pytest.fixture(scope="module")
def branch(setup):
    return follow(setup, 90, points=40)


def test_branch_agrees_with_steady_state(setup, branch):
    br = branch
    assert br.branch.stop.startswith("p_end") and abs(br.p[-1] - 90) < 1e-9
    assert np.all(np.diff(br.p) > 0)  # the linear model has no folds here
    f = linkage_period_map(setup)
    for i in (0, len(br.p) // 2, len(br.p) - 1):
        st = steady_state(setup.replace(crank_speed_rpm=float(br.p[i])))
        x = f.state(st)
        assert np.abs(br.branch.points[i].x - x).max() <= 1e-6 * np.abs(x).max()
        mu = np.sort(np.abs(br.branch.points[i].multipliers))[::-1][:4]
        assert np.allclose(mu, np.sort(np.abs(st.floquet_multipliers))[::-1][:4], rtol=1e-6)
        assert br.stable[i] == st.stable
    # a point between the branch's points, shot from the branch, against steady_state there
    o = br.orbit_at(61.5)
    x = f.state(steady_state(setup.replace(crank_speed_rpm=61.5)))
    assert np.abs(o.x - x).max() <= 1e-6 * np.abs(x).max()
    # the deflection of a stored point against steady_state's
    i = len(br.p) // 2
    pp = br.steady(i).peak_to_peak_mm("L2")
    assert abs(pp - steady_state(setup.replace(crank_speed_rpm=float(br.p[i]))).peak_to_peak_mm("L2")) < 1e-6 * pp


def test_validity_of_the_points_agrees_with_steady_state(setup, branch):
    v = branch.validity()
    assert len(v) == len(branch.p) and list(v["crank_speed_rpm"]) == list(branch.p)
    for i in (0, len(branch.p) - 1):
        ref = steady_state(setup.replace(crank_speed_rpm=float(branch.p[i]))).validity
        for col, key in (("stress / yield", "stress / yield"), ("deflection / length", "deflection / length")):
            assert abs(v[col][i] - ref[key]) <= 1e-6 * ref[key]
        assert v["valid"][i] == ref["valid"]
    # the stress grows with the speed (the inertial load ~ speed^2 at low speed)
    assert v["stress / yield"].iloc[-1] > 4 * v["stress / yield"].iloc[0]


def test_brute_force_agrees_with_the_continuation_where_stable(setup, branch):
    speeds = [40.0, 60.0, 80.0]
    bf = brute_force_diagram(setup, speeds, transient=60, samples=4)
    assert list(bf.direction) == ["up"] * 3 + ["down"] * 3
    assert np.all(bf.period() == 1) and not bf.diverged.any()
    for p, x in zip(bf.p, bf.states):
        o = branch.orbit_at(p)
        assert o.stable
        assert np.abs(x - o.x).max() <= 1e-6 * np.abs(o.x).max()


def test_describe_speed_names_a_stable_orbit(setup):
    rep = describe_speed(setup, 60)
    assert rep.kind == "stable period-1" and "stable period-1 orbit" in rep.text and "60" in rep.text


def test_another_parameter_and_bad_input(setup):
    br = follow(setup.replace(crank_speed_rpm=60), 0.03, parameter="damping_ratio", p0=0.02, points=6,
                ds_max=0.3, ds=0.3)
    assert br.p[0] == 0.02 and abs(br.p[-1] - 0.03) < 1e-12
    st = steady_state(fivebar.Setup(setup.params.replace(damping_ratio=0.03), crank_speed_rpm=60,
                                    steps_per_period=200, motors=False, nonlinear=False))
    x = linkage_period_map(setup).state(st)
    assert np.abs(br.branch.points[-1].x - x).max() <= 1e-6 * np.abs(x).max()
    with pytest.raises(FivebarError, match="no_such"):
        follow(setup, 1.0, parameter="no_such_entry")
    with pytest.raises(FivebarError, match="p_end"):
        follow(setup, 30.0)


def test_a_result_is_of_its_own_scheme_whatever_was_solved_before():
    # set-ups that differ only in the scheme share one LinkageDynamics (the store's), built by the
    # first solved: a result's set-up, and what explain marches, must still be its own scheme's.
    # With the default scheme solved first, the paper's rule at S = 100 (its discrete orbit
    # unstable, errata E26) was explained with the default scheme's map: "stable period-1"
    p = fivebar.load_params()
    default = Setup(p, steps_per_period=100, nonlinear=False)
    paper = default.replace(scheme=fivebar.PAPER_SCHEME)
    first = steady_state(default)
    res = steady_state(paper, explain=True)
    assert res.dynamics is first.dynamics  # (the case: one dynamics for both)
    assert res.setup == paper and first.setup == default
    assert res.stable is False and res.explained.kind == "diverges"


def test_steady_state_explain_names_what_a_march_from_an_unstable_orbit_does():
    # the paper's rule at S = 100 makes the linear model's orbit unstable (errata E26, multiplier
    # about 65): a linear map with a multiplier outside the unit circle grows as mu^k, so the march
    # from the orbit diverges (what explain must name); without explain nothing more is computed
    p = fivebar.load_params()
    paper = Setup(p, steps_per_period=100, scheme=fivebar.PAPER_SCHEME, nonlinear=False)
    plain = steady_state(paper)
    assert plain.stable is False and plain.explained is None
    assert "explain=True" in plain.note
    res = steady_state(paper, explain=True)
    assert res.explained.kind == "diverges" and res.note.endswith(res.explained.text)
    assert "unstable" in res.explained.text and "60 r/min" in res.explained.text
    # a stable orbit: nothing to explain, the note as without
    ok = steady_state(Setup(p, nonlinear=False), explain=True)
    assert ok.stable and ok.explained is None and ok.note == steady_state(Setup(p, nonlinear=False)).note
    with pytest.raises(FivebarError, match="explain"):
        steady_state(p, method="march", explain=True)
    with pytest.raises(FivebarError, match="explain"):
        steady_state(p, explain="yes")


def test_period_map_dynamics_at_a_new_speed_equal_a_fresh_build():
    """The period map's dynamics at a new speed are made of the speed-free parts another speed
    stored (the samples, the model, the nonlinear force) and are not stored themselves: array
    for array they must equal the dynamics built afresh from the parameter set at that speed in
    a clean store, and so must one period and its monodromy matrix; a bad speed is refused by
    name."""
    from fivebar.cache import STORE

    p = fivebar.load_params().replace(bending_depth=0.002)
    s = Setup(p, crank_speed_rpm=40, steps_per_period=200, motors=False)  # nonlinear
    fivebar.clear_cache()
    f = linkage_period_map(s)
    x = f.state(steady_state(s))
    f(x, 40.0, True)
    _, d = f.dynamics(61.0)
    y, Phi = f(x, 61.0, True)
    y_plain, _ = f(x, 61.0, False)
    assert len(STORE.keys("setup.dynamics")) == 1  # the steady state's at 40 r/min, not the map's
    fivebar.clear_cache()
    s97 = Setup(p.replace(crank_speed_rpm=61.0), steps_per_period=200, motors=False)
    fresh = linkage_dynamics(s97)
    g = linkage_period_map(s97)
    assert g.dynamics(61.0)[1] is fresh  # the stored one, when there is one
    assert d.params == fresh.params and (d.period, d.dt, d.n) == (fresh.period, fresh.dt, fresh.n)
    assert np.array_equal(d.t, fresh.t) and np.array_equal(d.keep, fresh.keep)
    direct = dict(zip("MCKF", fresh._sample(fresh.t)))  # sampled at the speed, no cache
    for name in "MCKF":  # (sampled at other crank angles by round-off: C, through the modes, to 1e-10)
        X, Y = getattr(d.step_data, name), getattr(fresh.step_data, name)
        assert X.shape == Y.shape and np.abs(X - Y).max() <= 1e-9 * np.abs(Y).max(), name
        assert np.abs(X - direct[name]).max() <= 1e-9 * np.abs(Y).max(), name
    assert np.array_equal(d.step_data.kernel_arrays()[3], d.step_data.F)
    (_, r1, i1), (_, r2, i2) = d.compiled_nonlinear(d.step_data), fresh.compiled_nonlinear(fresh.step_data)
    assert np.array_equal(i1, i2) and np.allclose(r1, r2, rtol=1e-10, atol=1e-13 * np.abs(r2).max())
    y2, Phi2 = g(x, 61.0, True)
    assert np.abs(y - y2).max() <= 1e-8 * np.abs(y2).max() and np.abs(y_plain - y2).max() <= 1e-8 * np.abs(y2).max()
    assert np.abs(Phi - Phi2).max() <= 1e-8 * np.abs(Phi2).max()
    for bad in (-5.0, 0.0):
        with pytest.raises(FivebarError, match=f"crank_speed_rpm = {bad!r} is not allowed"):
            f.dynamics(bad)
    with pytest.raises(FivebarError, match="keep = 'no'"):
        linkage_dynamics(s, keep="no")


def test_the_linkage_map_at_two_speeds_in_two_threads_equals_it_in_one():
    # the continuation integrates its difference in p beside the monodromy period (the map says
    # ``concurrent``); on the nonlinear flexible orientation (the compiled strain force in the
    # compiled loop, which releases the GIL) the results of the two threads, each at its own
    # fresh speed, equal those of one call after the other to the bit, ten times over
    import threading

    p = fivebar.load_params().replace(bending_depth=0.002)
    s = fivebar.Setup(p, crank_speed_rpm=60, steps_per_period=200, motors=False, nonlinear=True)
    x0 = linkage_period_map(s).state(steady_state(s))
    f = linkage_period_map(s)
    assert f.concurrent
    for i in range(10):
        speeds = (60.0 + 0.1 * i, 60.0 + 0.1 * i + 1e-4)
        serial = [linkage_period_map(s)(x0, speeds[0], True), linkage_period_map(s)(x0, speeds[1], False)]
        out = {}
        t = threading.Thread(target=lambda: out.update(b=f(x0, speeds[1], False)))
        t.start()
        a = f(x0, speeds[0], True)
        t.join()
        assert np.array_equal(a[0], serial[0][0]) and np.array_equal(a[1], serial[0][1])
        assert np.array_equal(out["b"][0], serial[1][0]) and out["b"][1] is None
    assert len(f._dyn) == 4  # the last four speeds kept
