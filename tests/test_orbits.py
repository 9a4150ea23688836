"""The periodic-orbit engine (fivebar.analyses.orbits): every caller takes its method by name
from one registry, through one problem object (issue 31, point 3).

A fake method is registered beside the real ones: its steady state and its period map are the
shooting method's, recording every use.  ``steady_state``, ``follow``, ``brute_force_diagram``,
``describe_speed`` and ``explain_steady`` given ``method="fake"`` must use them (a caller that
builds the Newmark period map or calls shooting itself leaves the record empty), and a method
that cannot serve a caller must be refused with an error naming it and those that can.  The
linear model of the flexible orientation, motors off, at S = 200 keeps this fast.
"""

import numpy as np
import pytest

import fivebar
from fivebar.analyses import orbits
from fivebar.analyses.branches import brute_force_diagram, describe_speed, explain_steady, follow, steady_state
from fivebar.analyses.orbits import ORBIT_METHODS, LinkagePeriodMap, OrbitMethod, OrbitProblem, orbit_method
from fivebar.errors import FivebarError


@pytest.fixture(scope="module")
def setup():
    p = fivebar.load_params().replace(bending_depth=0.002)
    return fivebar.Setup(p, crank_speed_rpm=30, steps_per_period=200, motors=False, nonlinear=False)


class _Recording(LinkagePeriodMap):
    """The Newmark period map, recording its calls in ``log``."""

    log: list = []

    def __call__(self, x, p=None, jacobian=False):
        self.log.append(("map", float(self.setup_value() if p is None else p), bool(jacobian)))
        return super().__call__(x, p, jacobian)


@pytest.fixture
def fake(monkeypatch):
    """A method "fake" serving every caller; returns its log."""
    log: list = []
    shooting = ORBIT_METHODS["shooting"]

    def steady(s, tol, memo):
        log.append(("steady", float(s.crank_speed_rpm)))
        return shooting.steady(s, tol, memo)

    def period_map(s, parameter):
        log.append(("period_map", parameter))
        f = _Recording(s, parameter)
        f.log = log
        return f

    monkeypatch.setitem(ORBIT_METHODS, "fake", OrbitMethod("fake", steady, period_map, frozenset(orbits.CALLERS)))
    return log


def test_steady_state_takes_its_method_from_the_registry(setup, fake):
    st = steady_state(setup, method="fake")
    assert fake == [("steady", 30.0)]
    ref = steady_state(setup)
    assert np.array_equal(st.u, ref.u)


def test_follow_uses_the_registered_period_map_and_steady_state(setup, fake):
    br = follow(setup, 32, points=3, method="fake")
    assert br.method == "fake"
    assert ("period_map", "crank_speed_rpm") in fake
    assert ("steady", 30.0) in fake  # the branch's start
    assert sum(1 for e in fake if e[0] == "steady") >= 2  # and the scale (_scan_scale: the linear model)
    assert any(e[0] == "map" and e[2] for e in fake)  # the continuation iterates the method's map, with Phi
    n_before = len(fake)
    br.step_check(30.0, (200,))  # a branch's other S: the method's map again
    assert ("period_map", "crank_speed_rpm") in fake[n_before:]


def test_brute_force_marches_the_registered_period_map(setup, fake):
    d = brute_force_diagram(setup, [30.0], transient=2, samples=2, both_ways=False, method="fake")
    assert fake[0] == ("period_map", "crank_speed_rpm")
    assert [e for e in fake if e[0] == "map"] == [("map", 30.0, False)] * 4
    assert d.samples_mm.shape == (1, 2)


def test_explanations_shoot_the_registered_period_map(setup, fake):
    st = steady_state(setup)
    r = explain_steady(st, periods=2, method="fake")
    assert r.kind == "stable period-1"
    assert fake[0] == ("period_map", "crank_speed_rpm") and any(e[0] == "map" for e in fake)
    fake.clear()
    r = describe_speed(setup, 30.0, periods=2, method="fake")
    assert r.kind == "stable period-1"
    assert ("steady", 30.0) in fake and ("period_map", "crank_speed_rpm") in fake
    assert any(e[0] == "map" for e in fake)


def test_a_method_that_cannot_serve_a_caller_is_refused_by_name(setup):
    with pytest.raises(FivebarError, match=r"method = 'march' is not allowed for follow .*use one of 'shooting'"):
        follow(setup, 32, points=3, method="march")
    with pytest.raises(FivebarError, match=r"'harmonic_balance' is not allowed for follow"):
        follow(setup, 32, points=3, method="harmonic_balance")
    with pytest.raises(FivebarError, match=r"method = 'shooting' is not allowed for brute_force .*use one of 'march'"):
        brute_force_diagram(setup, [30.0], method="shooting")
    st = steady_state(setup)
    with pytest.raises(FivebarError, match=r"'march' is not allowed for explain .*use one of 'shooting'"):
        explain_steady(st, method="march")
    with pytest.raises(FivebarError, match=r"'harmonic_balance' is not allowed for explain"):
        describe_speed(setup, 30.0, method="harmonic_balance")
    with pytest.raises(FivebarError, match=r"method = 'nope' is not allowed: use one of 'shooting', 'march', "
                                           r"'harmonic_balance'"):
        steady_state(setup, method="nope")


def test_the_registry_refuses_a_malformed_entry():
    with pytest.raises(FivebarError, match="serves"):
        OrbitMethod("x", lambda s, t, m: None, None, frozenset({"follow"}))
    with pytest.raises(FivebarError, match="callers"):
        OrbitMethod("x", lambda s, t, m: None, LinkagePeriodMap, frozenset({"sweep"}))
    with pytest.raises(FivebarError, match="registered already"):
        orbits.register(OrbitMethod("shooting", lambda s, t, m: None))
    assert orbit_method("march", "brute_force") is ORBIT_METHODS["march"]


def test_the_problem_object(setup):
    prob = OrbitProblem(setup, "damping_ratio")
    assert prob.value == setup.params.damping_ratio
    assert prob.at(0.03).params.damping_ratio == 0.03 and prob.at(0.03).crank_speed_rpm == 30
    with pytest.raises(FivebarError, match="p_end"):
        prob.given("p_end", -1.0)


def test_one_shooting_loop_serves_the_generic_and_the_linkage_shooting(setup, monkeypatch):
    """``numerics.periodic.shoot`` (any period map) and ``analyses.steady.shooting`` (the linkage)
    both run ``numerics.periodic.newton_periodic``: the one loop of Newton's method on
    periodicity.  Their orbits agree (the linkage's period map, shot by the generic)."""
    from fivebar.analyses import steady
    from fivebar.numerics import periodic

    calls = []
    loop = periodic.newton_periodic

    def recorded(*args, **kwargs):
        calls.append(kwargs.get("newton", "chord"))
        return loop(*args, **kwargs)

    monkeypatch.setattr(periodic, "newton_periodic", recorded)
    monkeypatch.setattr(steady, "newton_periodic", recorded)
    st = steady.shooting(setup)
    assert calls == ["chord"]
    f = orbits.linkage_period_map(setup)
    x = f.state(st)
    orb = periodic.shoot(f, 1.01 * x, 30.0, scale=np.full(x.size, np.abs(x).max()))
    assert calls == ["chord", "full"]
    assert np.abs(orb.x - x).max() <= 1e-8 * np.abs(x).max()
