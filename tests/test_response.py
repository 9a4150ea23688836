"""The one result type in time (fivebar.analyses.response), against independent references: a
displacement field whose point displacements follow from the kinematics and the shape
functions by hand, the quasi-static deflection from the matrices at each time, the periodicity
of a transient started on the orbit, and the shooting orbit against the low-speed quasi-static
limit.  (The Radau response against the shooting orbit at S = 1600 is in test_dynamics.py.)"""

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

import fivebar
from fivebar import load_params
from fivebar.model.dynamics import LinkageDynamics
from fivebar.errors import FivebarError
from fivebar.model.kinematics import positions
from fivebar.analyses.linkage_multiscale import MultipleScalesResponse
from fivebar.analyses.multibody import MultibodySteadyState
from fivebar.analyses.response import Response, quasi_static, radau, transient
from fivebar.analyses.steady import SteadyState, shooting
from fivebar.description.setup import Setup

P = load_params()


@pytest.fixture(scope="module")
def dyn():
    return LinkageDynamics(Setup(P, nonlinear=False, steps_per_period=24))


def _index(dyn, label):
    labels = [dyn.model.dofs[i].label for i in dyn.keep]
    return labels.index(label)


def _frame(dyn, t, a, b):
    """Unit axis and left normal of the link from point a to point b, from the rigid kinematics."""
    X = positions(dyn.params, *dyn.crank_angles(t))
    d = X[b] - X[a]
    e = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return e, np.stack([-e[..., 1], e[..., 0]], axis=-1)


def test_point_displacements_of_a_known_field(dyn):
    """Only the midpoint node of L2 moves, by (a, b) in global x, y (its slope and curvature,
    every other DOF zero): at the midpoint the transverse displacement is the projection on
    the link's normal and the chord deflection the same (the ends do not move); at a quarter
    of the link, inside the first element, the quintic Hermite interpolation gives half of it
    (the two translation shape functions are 1/2 each at the element's middle and sum to 1)."""
    t = np.linspace(0.0, dyn.period, 7)
    a, b = 1e-3 * np.cos(3 * t), 2e-3 * np.sin(t) + 5e-4
    u = np.zeros((t.size, dyn.n))
    u[:, _index(dyn, "L2[1].x")], u[:, _index(dyn, "L2[1].y")] = a, b
    r = Response(dyn, t, u, np.zeros_like(u), "field")
    e, nrm = _frame(dyn, t, "B", "C")
    tr = 1e3 * (nrm[:, 0] * a + nrm[:, 1] * b)
    ax = 1e3 * (e[:, 0] * a + e[:, 1] * b)
    assert r.midpoint_mm("L2") == pytest.approx(tr, rel=1e-12, abs=1e-15)
    assert r.midpoint_mm("L2", "longitudinal") == pytest.approx(ax, rel=1e-12, abs=1e-15)
    assert r.midpoint_mm("L2", "chord") == pytest.approx(tr, rel=1e-12, abs=1e-15)
    assert r.deflection_mm("L2", 0.25) == pytest.approx(0.5 * tr, rel=1e-12, abs=1e-15)
    assert r.deflection_mm("L2", 0.25, "longitudinal") == pytest.approx(0.5 * ax, rel=1e-12, abs=1e-15)
    assert r.peak_to_peak_mm("L2") == pytest.approx(np.ptp(tr), rel=1e-12)
    assert np.all(r.midpoint_mm("L3") == 0.0)
    # the curvature of a moving midpoint with zero slope bends the link: a stress; L1 is at rest
    stress = r.bending_stress()
    assert stress["L2"] > 0.0 and stress["L1"] == 0.0


def test_a_moving_pin_and_the_chord(dyn):
    """Only pin C moves, by (a, b): the midpoints of L2 and L3 stay (nodal interpolation), so
    their chord deflections are minus half the pin's transverse displacement on each link, and
    the ends of L2 (s = 1) and L3 (s = 0) move with the pin."""
    t = np.linspace(0.0, dyn.period, 5)
    a, b = 1e-3 * np.ones_like(t), -2e-3 * np.cos(2 * t)
    u = np.zeros((t.size, dyn.n))
    u[:, _index(dyn, "C.x")], u[:, _index(dyn, "C.y")] = a, b
    r = Response(dyn, t, u, u, "pin")
    for link, ends, s in (("L2", ("B", "C"), 1.0), ("L3", ("C", "D"), 0.0)):
        _, nrm = _frame(dyn, t, *ends)
        tr = 1e3 * (nrm[:, 0] * a + nrm[:, 1] * b)
        assert r.midpoint_mm(link) == pytest.approx(np.zeros_like(t), abs=1e-15)
        assert r.midpoint_mm(link, "chord") == pytest.approx(-0.5 * tr, rel=1e-12, abs=1e-15)
        assert r.deflection_mm(link, s) == pytest.approx(tr, rel=1e-12, abs=1e-15)


def test_quasi_static_is_k_inverse_f_at_each_time(dyn):
    """At times off the step grid, u = K(t)^-1 F(t) from the matrices and the load at each time,
    and v its time derivative (against a fourth-order difference over a step of 1e-4 T); at
    the step times the sampled matrices give the same deflection, and the periodic central
    difference of a fine grid the same velocity within its (omega dt)^2 error."""
    t = np.linspace(0.013, 0.7 * dyn.period, 9)
    r = quasi_static(dyn.setup, t)
    assert r.method == "quasi-static" and isinstance(r, Response)
    for k in (0, 4, 8):
        K, F = dyn.matrices(t[k])[2], dyn.force(t[k])
        assert r.u[k] == pytest.approx(np.linalg.solve(K, F), rel=1e-10, abs=1e-14 * np.abs(r.u).max())
    h = 1e-4 * dyn.period
    w = quasi_static(dyn.setup, t[4] + h * np.array([-2.0, -1.0, 1.0, 2.0])).u
    v_ref = (w[0] - 8 * w[1] + 8 * w[2] - w[3]) / (12 * h)
    assert np.abs(r.v[4] - v_ref).max() < 1e-6 * np.abs(v_ref).max()
    grid = quasi_static(dyn.setup)
    assert grid.t.size == dyn.steps_per_period + 1 and np.array_equal(grid.u[0], grid.u[-1])
    K, F = dyn.matrices(grid.t[5])[2], dyn.force(grid.t[5])
    assert grid.u[5] == pytest.approx(np.linalg.solve(K, F), rel=1e-10, abs=1e-14 * np.abs(grid.u).max())
    fine = LinkageDynamics(Setup(P, nonlinear=False, steps_per_period=400))
    g, exact = quasi_static(fine.setup), quasi_static(fine.setup, fine.t[::50])
    assert np.abs(g.v[:-1:50] - exact.v).max() < 1e-2 * np.abs(exact.v).max()


def test_the_slow_steady_state_is_the_quasi_static_response():
    """At 3 r/min the inertial load is slow: the shooting orbit's midpoint curves are the
    quasi-static response's, read through the same accessors."""
    d = LinkageDynamics(Setup(P.replace(crank_speed_rpm=3.0), nonlinear=False, steps_per_period=100))
    orbit = shooting(d.setup)
    qs = quasi_static(d.setup)
    for link in ("L2", "L3"):
        assert np.abs(orbit.midpoint_mm(link) - qs.midpoint_mm(link)).max() < 2e-3 * qs.peak_to_peak_mm(link)


def test_a_transient_from_the_orbit_stays_on_it(dyn):
    """Started on the periodic orbit, two periods of the transient repeat the orbit in each
    period (a wrong start, step or slicing of the periods would not): the first to rounding,
    the second within the scheme's error at this coarse S = 24 (shooting closes the orbit in
    (u, v) with the start's acceleration from the equation of motion, while the march carries
    the generalised-alpha acceleration on through T)."""
    orbit = shooting(dyn.setup)
    r = transient(orbit.setup, 2, orbit.u[0], orbit.v[0])
    assert r.method == "transient" and r.t.size == 2 * dyn.steps_per_period + 1 and r.solver.iterations.size == 2 * dyn.steps_per_period
    scale = np.abs(orbit.u).max()
    for k, tol in ((0, 1e-9), (1, 1e-3)):
        p = r.period(k)
        assert p.t[0] == pytest.approx(k * dyn.period) and p.t.size == dyn.steps_per_period + 1
        assert np.abs(p.u - orbit.u).max() < tol * scale
        assert np.abs(p.midpoint_mm("L2") - orbit.midpoint_mm("L2")).max() < tol * orbit.peak_to_peak_mm("L2")
    rest = transient(dyn.setup, 1)
    assert np.all(rest.u[0] == 0.0) and np.abs(rest.u[-1]).max() > 0.0


def test_every_result_in_time_is_read_alike():
    """Steady states and the multiple-scales approximation are Responses; the multibody result
    has the same accessor names."""
    assert issubclass(SteadyState, Response) and issubclass(MultipleScalesResponse, Response)
    for name in ("t", "params", "crank_angle_deg", "deflection_mm", "midpoint_mm", "peak_to_peak_mm", "method"):
        assert hasattr(Response, name) or name in Response.__dataclass_fields__, name
        assert hasattr(MultibodySteadyState, name) or name in MultibodySteadyState.__dataclass_fields__, name
    assert fivebar.Response is Response and fivebar.transient is transient


def test_plot_draws_the_midpoint_curves(dyn):
    from fivebar.book.plotting import response_plot

    r = quasi_static(dyn.setup)
    ax = response_plot(r)
    lines = ax.get_lines()
    assert [ln.get_label() for ln in lines] == ["L2 (quasi-static)", "L3 (quasi-static)"]
    assert np.array_equal(lines[0].get_ydata(), 1e3 * r.midpoint_mm("L2"))
    assert np.array_equal(lines[1].get_xdata(), r.crank_angle_deg)


def test_bad_input_names_the_argument(dyn):
    t = np.linspace(0.0, dyn.period, 3)
    u = np.zeros((3, dyn.n))
    with pytest.raises(FivebarError, match=r"u has shape \(3, 2\)"):
        Response(dyn, t, u[:, :2], u)
    with pytest.raises(FivebarError, match="dynamics = Params is not allowed"):
        Response(P, t, u, u)
    r = Response(dyn, t, u, u)
    with pytest.raises(FivebarError, match="s = 1.5"):
        r.deflection_mm("L2", 1.5)
    with pytest.raises(FivebarError, match="link = 'L9'"):
        r.midpoint_mm("L9")
    with pytest.raises(FivebarError, match="direction = 'up'"):
        r.midpoint_mm("L2", "up")
    with pytest.raises(FivebarError, match="k = 0 is not allowed"):
        r.period(0)
    with pytest.raises(FivebarError, match="periods = 0"):
        transient(dyn.setup, 0)
    with pytest.raises(FivebarError, match="t = .* is not allowed"):
        quasi_static(dyn.setup, [])
    with pytest.raises(FivebarError, match="t = .* is not allowed"):
        radau(dyn.setup, [0.0])
