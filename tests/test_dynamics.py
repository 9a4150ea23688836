"""The equation (2.7) of the linkage and its periodic steady state, against independent
references: scipy's Radau integrator, the quasi-static limit, scaling with speed, and the
agreement of marching and shooting."""

import numpy as np
import pytest

import fivebar
from fivebar import clear_cache, load_params
from fivebar.cache import STORE
from fivebar.errors import InputError
from fivebar.model.dynamics import LinkageDynamics, linkage_dynamics, modal_damping
from fivebar.numerics.schemes import GeneralizedAlpha, Newmark
from fivebar.analyses.branches import steady_state
from fivebar.analyses.steady import SteadyStateError, march, shooting
from fivebar.description.setup import Setup

P = load_params()


def test_modal_damping_gives_the_ratio_in_every_mode():
    d = LinkageDynamics(Setup(P, nonlinear=False, steps_per_period=24))
    M, C, K = d.step_data.M[1], d.step_data.C[1], d.step_data.K[1]
    import scipy.linalg

    w2, Phi = scipy.linalg.eigh(K, M)
    modal = Phi.T @ C @ Phi
    assert np.allclose(np.diag(modal), 2 * P.damping_ratio * np.sqrt(w2), rtol=1e-8)
    off = modal - np.diag(np.diag(modal))
    assert np.abs(off).max() < 1e-8 * np.abs(np.diag(modal)).max()
    assert np.allclose(modal_damping(M, K, 0.0), 0.0)


def test_rotor_dofs_are_decoupled_and_left_out():
    d = LinkageDynamics(Setup(P, nonlinear=False, steps_per_period=24))
    m = d.model
    M, K = m.matrices(0.3, 1.2)
    rotor = [i for i in range(m.n) if i not in d.keep]
    assert [m.dofs[i].kind for i in rotor] == ["rotor_x", "rotor_y"] * 2
    assert np.all(M[np.ix_(rotor, d.keep)] == 0) and np.all(K[np.ix_(rotor, d.keep)] == 0)


@pytest.mark.slow
def test_newmark_against_radau_on_the_full_model():
    """From a state on the steady orbit, the average-acceleration rule (S = 1600) and scipy's
    Radau (rtol 1e-7) give the same midpoint motion.  The window is 2 % of a period: the
    model's stiffest mode (about 1.2e5 rad/s) makes Radau slow, while Newmark steps over it."""
    d = LinkageDynamics(Setup(P, nonlinear=False, steps_per_period=1600))
    ss = shooting(d.setup)

    ts = ss.t[:33:8]
    radau = fivebar.radau(d.setup, ts, ss.u[0], ss.v[0], rtol=1e-7, atol=1e-13)
    assert radau.method == "radau" and radau.solver.success
    for link in ("L2", "L3"):
        err = np.abs(ss.midpoint_mm(link)[:33:8] - radau.midpoint_mm(link)).max()
        assert err < 1e-5 * ss.peak_to_peak_mm(link)


def test_quasi_static_limit_and_speed_scaling():
    """At low speed the inertial load is slow: the response is the quasi-static deflection
    K^-1 F (an independent linear solve), and it scales with the square of the speed."""
    slow = P.replace(crank_speed_rpm=3.0)
    d = LinkageDynamics(Setup(slow, nonlinear=False, steps_per_period=100))
    ss = shooting(d.setup)
    us = d.quasi_static(ss.t)
    assert np.abs(ss.u - us).max() < 1e-3 * np.abs(us).max()
    pp = [steady_state(Setup(P, crank_speed_rpm=w, nonlinear=False, scheme=GeneralizedAlpha(0.9))).peak_to_peak_mm("L3") for w in (3.0, 6.0)]
    assert pp[1] / pp[0] == pytest.approx(4.0, rel=2e-3)


def test_march_reaches_the_shooting_orbit_with_a_stable_scheme():
    d = LinkageDynamics(Setup(P, nonlinear=False, steps_per_period=100))
    sch = GeneralizedAlpha(0.8)
    sh = shooting(d.setup.replace(scheme=sch))
    assert sh.stable
    mr = march(d.setup.replace(scheme=sch), tol=1e-9)
    assert mr.periods > 1
    for link in ("L2", "L3"):
        assert np.allclose(mr.midpoint_mm(link), sh.midpoint_mm(link), atol=1e-6 * sh.peak_to_peak_mm(link))


def test_paper_rule_at_S100_gives_an_unstable_discrete_orbit():
    """The average-acceleration rule is unconditionally stable only for constant matrices; with
    the links' turning, under-resolved modes and S = 100 the discrete periodic orbit is unstable, and a
    finer step or numerical dissipation restores stability (the book's Newmark chapter)."""
    d = LinkageDynamics(Setup(P, nonlinear=False, steps_per_period=100))
    sh = shooting(d.setup.replace(scheme=Newmark()))
    assert sh.stable is False and np.abs(sh.floquet_multipliers[0]) > 10
    with pytest.raises(SteadyStateError, match="no periodic steady state after 20 periods"):
        march(d.setup.replace(scheme=Newmark()), max_periods=20)
    ref = shooting(Setup(P, nonlinear=False, steps_per_period=1600))
    assert ref.stable
    # the unstable S = 100 orbit is nonetheless an accurate one
    assert sh.peak_to_peak_mm("L2") == pytest.approx(ref.peak_to_peak_mm("L2"), rel=3e-3)


def test_directions_and_errors():
    ss = steady_state(Setup(P, nonlinear=False, scheme=GeneralizedAlpha(0.8), steps_per_period=50))
    assert ss.midpoint_mm("L2").shape == (51,) and ss.crank_angle_deg[-1] == pytest.approx(360.0)
    # pure bending is smaller than the total transverse motion (which carries the joints)
    assert ss.peak_to_peak_mm("L2", "chord") < ss.peak_to_peak_mm("L2", "transverse")
    with pytest.raises(ValueError, match="direction = 'sideways'"):
        ss.midpoint_mm("L2", "sideways")
    with pytest.raises(ValueError, match="link = 'L5'"):
        ss.midpoint_mm("L5")
    with pytest.raises(ValueError, match="method = 'euler'"):
        steady_state(P, method="euler")
    with pytest.raises(ValueError, match="steps_per_period = 1"):
        LinkageDynamics(Setup(P, steps_per_period=1))


def test_nonlinear_force_at_step_times_equals_the_direct_evaluation():
    """f_nl(u, t) looks the configuration up at the S step times (and at their images in later
    periods) and computes it elsewhere; both agree with NonlinearForce on the full model at the
    crank angles of t."""
    from fivebar.model.nonlinear import NonlinearForce

    d = LinkageDynamics(Setup(P, steps_per_period=40))
    full = NonlinearForce(d.model)
    rng = np.random.default_rng(11)
    for t in (0.0, 7 * d.dt, 39 * d.dt, 40 * d.dt, 93 * d.dt, 2.5 * d.dt, 0.3217 * d.period):
        u = rng.normal(size=d.n) * 1e-3
        f, K = d.nonlinear(u, t)
        th1, th4 = d.crank_angles(t)
        f0, K0 = full(d.expand(u), float(th1), float(th4))
        k = d.keep
        assert np.allclose(f, f0[k], rtol=1e-12, atol=1e-12 * np.abs(f0).max())
        assert np.allclose(K, K0[np.ix_(k, k)], rtol=1e-12, atol=1e-12 * np.abs(K0).max())
    with pytest.raises(ValueError, match="linear"):
        LinkageDynamics(Setup(P, steps_per_period=24, nonlinear=False)).nonlinear_geometry(0.0)


def test_batched_modal_damping_equals_the_one_configuration_path():
    d = LinkageDynamics(Setup(P, nonlinear=False, steps_per_period=24))
    M, K = d.step_data.M, d.step_data.K
    C = modal_damping(M, K, 0.03)
    for k in range(8):
        Ck = modal_damping(M[k], K[k], 0.03)
        assert np.allclose(C[k], Ck, rtol=1e-8, atol=1e-10 * np.abs(Ck).max())


def test_march_from_rest_reaches_the_nonlinear_shooting_orbit():
    """From rest the excited stiff modes make full Newton cycle at S = 50 (steady falls back to
    modified Newton); the march still ends on the orbit that shooting finds."""
    d = LinkageDynamics(Setup(P, steps_per_period=50))
    sch = GeneralizedAlpha(0.8)
    mr = march(d.setup.replace(scheme=sch), tol=1e-7)
    sh = shooting(d.setup.replace(scheme=sch))
    for link in ("L2", "L3"):
        assert np.allclose(mr.midpoint_mm(link), sh.midpoint_mm(link), atol=1e-5 * sh.peak_to_peak_mm(link))


def test_thin_section_nonlinear_shooting_starts_from_the_nonlinear_static_state():
    """Issue 10 item 5: with the 2 mm side in plane, shooting diverged in the first step at
    30 r/min (S = 800).  Cause: the start K^-1 F of the *linear* statics, where f_nl is about
    a hundred times the load.  The orbit must now be found, and equal the one that marching
    from rest reaches (an independent route), and Exudyn's (data/multibody_sweep.json, 0.425 mm
    on the same mesh: the two models differ by 0.7 % here, so 1.5 % is asserted)."""
    import json
    from pathlib import Path

    p = load_params().replace(bending_depth=0.002)
    dyn = LinkageDynamics(Setup(p, crank_speed_rpm=30, steps_per_period=800, motors=False,
                                elements_per_link=(2, 4, 4, 2)))
    # the cause, and the static state solves K u + f_nl(u) = F
    u_lin = dyn.quasi_static(np.asarray(0.0))
    f_lin, _ = dyn.nonlinear(u_lin, 0.0)
    F = dyn.step_data.F[0]
    assert np.linalg.norm(f_lin) > 10 * np.linalg.norm(F)
    u_nl = dyn.static_equilibrium(0.0)
    f_nl, _ = dyn.nonlinear(u_nl, 0.0)
    assert np.linalg.norm(dyn.step_data.K[0] @ u_nl + f_nl - F) <= 1e-9 * np.linalg.norm(F)

    scheme = GeneralizedAlpha(0.8)
    ss = shooting(dyn.setup.replace(scheme=scheme))
    assert ss.stable
    mr = march(dyn.setup.replace(scheme=scheme), tol=1e-8)
    assert np.allclose(ss.midpoint_mm("L2"), mr.midpoint_mm("L2"), rtol=0, atol=1e-5 * np.ptp(ss.midpoint_mm("L2")) + 1e-12)
    rows = json.loads((Path(__file__).parents[1] / "data" / "multibody_sweep.json").read_text())["rows"]
    ex = next(r["exudyn"]["L2_transverse"] for r in rows if r["bending_depth_mm"] == 2.0 and r["rpm"] == 30)
    assert ss.peak_to_peak_mm("L2") == pytest.approx(ex, rel=0.015)


def test_static_equilibrium_follows_the_load_path_with_a_predictor():
    """Far in the nonlinear range (the 2 mm side in the plane at 600 r/min: the linear static
    deflection 17 against 6.8 of the nonlinear one, in the kept DOFs' units) the load continuation
    of static_equilibrium must reach the full load and solve K u + f_nl(u) = F.  With each step's
    Newton iteration started at the last equilibrium it took 177 948 evaluations of the nonlinear
    force here (8 s; 36 such solves made one failing steady state take 138 s in chapter 09); started
    on the path's tangent (Euler's predictor) 3 470.  The bound, 20 000, fails the old start."""
    p = load_params().replace(bending_depth=0.002, crank_speed_rpm=600.0)
    dyn = LinkageDynamics(Setup(p, steps_per_period=100))
    calls = [0]
    force = dyn._nonlinear

    def counted(u, t):
        calls[0] += 1
        return force(u, t)

    dyn._nonlinear = counted
    u = dyn.static_equilibrium(0.0)
    K, F = dyn.step_data.K[0], dyn.step_data.F[0]
    f, _ = force(u, 0.0)
    assert np.linalg.norm(K @ u + f - F) <= 1e-9 * np.linalg.norm(F)
    assert np.linalg.norm(f) > np.linalg.norm(F)  # the nonlinear range: f_nl is not small against the load
    assert calls[0] < 20_000, calls[0]


def test_model_sampled_once_for_all_speeds_equals_direct_sampling():
    """M, C, K are speed independent at the step times and F scales with the speed squared:
    the cached arrays of a second speed must equal sampling that speed afresh."""
    p = load_params()
    clear_cache()
    LinkageDynamics(Setup(p, crank_speed_rpm=60, steps_per_period=50, motors=False))
    assert len(STORE.keys("dynamics.samples")) == 1
    d = LinkageDynamics(Setup(p, crank_speed_rpm=437, steps_per_period=50, motors=False))
    assert len(STORE.keys("dynamics.samples")) == 1  # served from the cache
    M, C, K, F = d._sample(d.t)  # direct
    sd = d.step_data
    for X, Y in ((sd.M, M), (sd.C, C), (sd.K, K), (sd.F, F)):
        assert np.allclose(X, Y, rtol=1e-10, atol=1e-12 * np.abs(Y).max())
    assert np.abs(F).max() > 0  # the load is not trivially zero
    LinkageDynamics(Setup(p, crank_speed_rpm=60, steps_per_period=50, motors=True))
    assert len(STORE.keys("dynamics.samples")) == 2  # motors are part of the key


@pytest.mark.parametrize("S", [40, 80])
def test_samples_from_half_or_double_S_equal_direct_sampling(S):
    """Doubling or halving S reuses the cached samples (the step times of S are the even ones
    of 2 S): the arrays must equal sampling afresh, and the cache must have been used."""
    p = load_params()
    clear_cache()
    LinkageDynamics(Setup(p, crank_speed_rpm=200, steps_per_period=S // 2 if S == 80 else 2 * S, motors=False))
    calls = []
    real = LinkageDynamics._sample
    try:
        LinkageDynamics._sample = lambda self, t, params=None: calls.append(len(np.atleast_1d(t))) or real(self, t, params)
        d = LinkageDynamics(Setup(p, crank_speed_rpm=333, steps_per_period=S, motors=False))
    finally:
        LinkageDynamics._sample = real
    assert calls == ([S // 2] if S == 80 else [])  # only the new step times were sampled
    M, C, K, F = d._sample(d.t)
    sd = d.step_data
    for X, Y in ((sd.M, M), (sd.C, C), (sd.K, K), (sd.F, F)):
        assert np.allclose(X, Y, rtol=1e-10, atol=1e-12 * np.abs(Y).max())
    # and to the last bit what the same set-up samples in an empty cache (results do not depend
    # on what was computed before)
    clear_cache()
    fresh = LinkageDynamics(Setup(p, crank_speed_rpm=333, steps_per_period=S, motors=False)).step_data
    for X, Y in ((sd.M, fresh.M), (sd.C, fresh.C), (sd.K, fresh.K), (sd.F, fresh.F)):
        assert np.array_equal(X, Y)


def test_the_samples_at_a_speed_do_not_depend_on_the_speed_sampled_first():
    """The cache keeps the samples of the speed-free parameter set; the step data at 300 r/min
    built first, or after 333 and 450 r/min filled the cache, are equal to the last bit (before:
    the cached force was scaled from the speed that sampled first, and differed in the last
    digits), and so is the nonlinear force's configuration at the step times."""
    p = load_params()

    def build(speeds):
        clear_cache()
        for rpm in speeds:
            d = LinkageDynamics(Setup(p, crank_speed_rpm=rpm, steps_per_period=64, motors=False))
        u = np.linspace(-1e-4, 1e-4, d.n)
        return d.step_data, d.nonlinear(u, 5 * d.dt)
    (a, fa), (b, fb) = build([300.0]), build([333.0, 450.0, 300.0])
    for X, Y in ((a.M, b.M), (a.C, b.C), (a.K, b.K), (a.F, b.F), (fa[0], fb[0]), (fa[1], fb[1])):
        assert np.array_equal(X, Y)


@pytest.mark.parametrize("nonlinear", [False, True])
def test_floquet_multipliers_equal_those_of_the_finite_difference_monodromy(nonlinear):
    """The shooting orbit's multipliers (chord Newton; the monodromy matrix propagated along the
    2 n consistent directions; for the nonlinear model computed at the orbit on request) against
    the eigenvalues of the period map's Jacobian by central differences."""
    from fivebar.analyses.steady import _energy_norm, _period

    d = LinkageDynamics(Setup(P, crank_speed_rpm=300, steps_per_period=100, motors=False, nonlinear=nonlinear))
    scheme = GeneralizedAlpha(0.8)
    st = shooting(d.setup.replace(scheme=scheme))
    n = d.n
    x = np.concatenate([st.u[0], st.v[0]])
    scale = np.concatenate([np.full(n, np.abs(st.u).max()), np.full(n, np.abs(st.v).max())])
    J = np.empty((2 * n, 2 * n))
    for i in range(2 * n):
        e = np.zeros(2 * n)
        e[i] = 1e-5 * scale[i]
        xp, xm = (_period(d, y[:n], y[n:], scheme, store="last", rtol=1e-14) for y in (x + e, x - e))
        J[:, i] = (np.concatenate([xp.u[-1], xp.v[-1]]) - np.concatenate([xm.u[-1], xm.v[-1]])) / (2 * e[i])
    fd = np.linalg.eigvals(J)
    fd = fd[np.argsort(-np.abs(fd))]
    mult = st.floquet_multipliers
    # central differences with a step of 1e-5 of the state's scale: O(1e-10) error in the Jacobian,
    # which moves its small eigenvalues by up to ~1e-9 depending on the orbit's start (the orbit
    # itself depends on the starting guess to its 1e-9 tolerance, e.g. on the predictor's memory).
    # The differenced periods solve each step's Newton to 1e-14, not the default 1e-10: a step that
    # converges in one update from the extrapolated iterate meets 1e-10 with little to spare, and
    # that error over the difference step (1e-10 / 1e-5) would be 1e-5 of the Jacobian; the
    # monodromy is the derivative of the step at its converged state, which that error hardly moves
    assert np.allclose(np.abs(mult[:6]), np.abs(fd[:6]), rtol=1e-5, atol=1e-8)
    assert abs(mult[0]) > 0.05  # the comparison is not among vanishing multipliers
    g = st.u[-1] - st.u[0], st.v[-1] - st.v[0]
    assert _energy_norm(d, *g) <= 1e-9 * _energy_norm(d, st.u, st.v).max()


def test_the_energy_norm_of_shooting_is_the_quadratic_form_of_every_state():
    """Shooting measures its residual and the orbit's size in sqrt(u K0 u + v M0 v) (K0, M0 at
    t = 0), for one state and for every row of a period's (steps, n) arrays: against the sums
    written out (K and M swapped, or u paired with v, fail it)."""
    from fivebar.analyses.steady import _energy_norm

    d = LinkageDynamics(Setup(P, crank_speed_rpm=300, steps_per_period=50, motors=True, nonlinear=True))
    K, M = d.step_data.K[0], d.step_data.M[0]
    rng = np.random.default_rng(7)
    u, v = rng.standard_normal((2, 9, d.n))

    def written_out(a, b):
        return np.sqrt(sum(a[i] * K[i, j] * a[j] + b[i] * M[i, j] * b[j] for i in range(d.n) for j in range(d.n)))

    want = np.array([written_out(a, b) for a, b in zip(u, v)])
    assert np.allclose(_energy_norm(d, u, v), want, rtol=1e-13)
    assert np.isclose(_energy_norm(d, u[3], v[3]), want[3], rtol=1e-13)
    assert np.ndim(_energy_norm(d, u[3], v[3])) == 0


@pytest.mark.parametrize("rpm,nonlinear", [(300, True), (600, False)])
def test_steady_state_to_a_tolerance_meets_it_against_a_fine_reference(rpm, nonlinear):
    """``steady_state(..., tol=)`` chooses S; its midpoint curves of L2 and L3 must lie within
    tol (of their peak-to-peak value) of the S = 3200 solution, and its stated estimate must not
    be below the true error."""
    s = Setup(P, crank_speed_rpm=rpm, motors=False, nonlinear=nonlinear)
    ref = steady_state(s.replace(steps_per_period=3200))
    steps = []
    for tol in (1e-2, 1e-4):
        res = steady_state(s, tol=tol)
        steps.append(res.dynamics.steps_per_period)
        S = res.dynamics.steps_per_period
        err = max(np.abs(res.midpoint_mm(k) - ref.midpoint_mm(k)[:: 3200 // S]).max() / np.ptp(ref.midpoint_mm(k))
                  for k in ("L2", "L3"))
        assert err <= tol and err <= res.accuracy["estimate"]
        assert res.accuracy["compared_with"] == S // 2 and f"S = {S} chosen" in res.note
    assert steps[1] > steps[0]  # a finer tolerance takes a finer step


@pytest.mark.parametrize("rpm", [300.0, 600.0])
def test_a_new_speed_warm_started_from_the_last_meets_the_tolerance_and_the_cold_start(rpm, monkeypatch):
    """A sequence of speeds with ``tol``, each after the first warm-started from the last
    (``start=``: its orbits and monodromy matrices).  Each result must lie within tol of its own
    S = 3200 solution, choose the S of a cold start, agree with the cold start's curves to well
    below tol (the inner tolerance), be periodic, and (the point of the warm start; at 300
    r/min) cost less than the cold start: fewer periods with a monodromy matrix (which cost
    about two without), and fewer in all counting those as two.  At 600 r/min, where the last
    speed's matrices fall short, it may cost at most one period more than the cold start (the
    first new speed tried them at S = 50, 100 and 200 and cost 15 against 10)."""
    import fivebar.analyses.steady as st

    s = Setup(P, motors=False, nonlinear=True)
    clear_cache()
    count = {"mono": 0, "all": 0}
    period = st._period

    def counted(*a, **k):
        count["all"] += 1
        count["mono"] += bool(k.get("sensitivity"))
        return period(*a, **k)
    monkeypatch.setattr(st, "_period", counted)

    def cost(start=None, **kw):
        count.update(mono=0, all=0)
        res = steady_state(s.replace(**kw), tol=0.01, start=start)
        return res, count["mono"], count["all"] + count["mono"]
    last = steady_state(s.replace(crank_speed_rpm=rpm), tol=0.01)
    for k in (1, 2):
        speed = rpm * (1.0 + 0.01 * k)
        warm, warm_mono, warm_cost = cost(last, crank_speed_rpm=speed)
        cold, cold_mono, cold_cost = cost(crank_speed_rpm=speed)
        ref = steady_state(s.replace(crank_speed_rpm=speed, steps_per_period=3200))
        S = warm.dynamics.steps_per_period
        assert S == cold.dynamics.steps_per_period and warm.accuracy["tried"][:-1] == cold.accuracy["tried"][:-1]
        for link in ("L2", "L3"):
            span = np.ptp(ref.midpoint_mm(link))
            assert np.abs(warm.midpoint_mm(link) - ref.midpoint_mm(link)[:: 3200 // S]).max() <= 0.01 * span
            assert np.abs(warm.midpoint_mm(link) - cold.midpoint_mm(link)).max() <= 1e-4 * span
        assert warm.residual <= 1e-6
        if rpm == 300.0:  # near 600 r/min the last speed's matrices fall short (see _to_tolerance)
            assert warm_mono < cold_mono and warm_cost < cold_cost, (warm_mono, cold_mono, warm_cost, cold_cost)
        else:  # where they fall short, only the first S of the call pays for trying them
            assert warm_cost <= cold_cost + 1, (warm_mono, cold_mono, warm_cost, cold_cost)
        last = warm


def test_a_warm_start_must_come_from_the_same_problem_nearby():
    """``start=`` takes only a tol-result of the same set-up at a speed within 25 %, with the same
    tol and shooting; anything else is refused by name."""
    s = Setup(P, motors=False, nonlinear=False)
    base = steady_state(s.replace(crank_speed_rpm=300.0), tol=0.01)
    for bad, kw in ((base, dict(tol=0.02)), (base, dict(tol=None)), (base, dict(method="march", tol=0.01)),
                    ("x", dict(tol=0.01)), (steady_state(s.replace(crank_speed_rpm=300.0)), dict(tol=0.01))):
        with pytest.raises(fivebar.FivebarError, match="start"):
            steady_state(s.replace(crank_speed_rpm=310.0), start=bad, **kw)
    with pytest.raises(InputError, match="more than 25 %"):
        steady_state(s.replace(crank_speed_rpm=400.0), tol=0.01, start=base)
    with pytest.raises(InputError, match="another set-up"):
        steady_state(s.replace(crank_speed_rpm=310.0, nonlinear=True), tol=0.01, start=base)


@pytest.mark.parametrize("nonlinear", [True, False])
def test_a_stale_monodromy_matrix_still_reaches_the_orbit(nonlinear):
    """Shooting started with a wrong Jacobian (the monodromy matrix of a speed 10 % away, or
    none at all: zeros, Picard's iteration) must still reach the orbit of Newton's method
    (it takes the orbit's own matrix when the stale one falls short), and report the orbit's
    own Floquet multipliers, not the given matrix's."""
    import fivebar.analyses.steady as st

    s = Setup(P, motors=False, nonlinear=nonlinear, steps_per_period=100, scheme=GeneralizedAlpha(0.8))
    newton = shooting(s.replace(crank_speed_rpm=600))
    far = shooting(s.replace(crank_speed_rpm=660))
    d = linkage_dynamics(s.replace(crank_speed_rpm=600))
    for Phi in (far._cache["monodromy"], np.zeros((2 * d.n, 2 * d.n))):
        res = st._shooting(d.setup, far.u[0], far.v[0], 1e-10, 20, monodromy=Phi)
        for link in ("L2", "L3"):
            assert np.abs(res.midpoint_mm(link) - newton.midpoint_mm(link)).max() <= 1e-7 * np.ptp(newton.midpoint_mm(link))
        assert np.allclose(res.floquet_multipliers[:4], newton.floquet_multipliers[:4], rtol=1e-6)


@pytest.mark.parametrize("kw", [dict(tol=0), dict(tol=1.5), dict(tol=True), dict(tol="1%")])
def test_steady_state_tolerance_errors_name_the_value(kw):
    from fivebar.errors import InputError

    with pytest.raises(InputError, match="tol = "):
        steady_state(Setup(P, motors=False), **kw)


@pytest.mark.parametrize("nonlinear", [False, True])
def test_newton_picard_shooting_reaches_the_newton_orbit(nonlinear, monkeypatch):
    """Above 32 DOFs shooting takes Newton's step on the lowest frozen modes only (Picard's
    iteration on the rest) and modified Newton within the steps: on the (2,4,4,2) mesh its
    orbit must equal the one of Newton's method with the whole monodromy matrix."""
    import fivebar.analyses.steady as st

    s = Setup(P, crank_speed_rpm=600, steps_per_period=100, motors=False, nonlinear=nonlinear,
              elements_per_link=(2, 4, 4, 2), scheme=GeneralizedAlpha(0.8))
    d = LinkageDynamics(s)
    assert d.n > st._DENSE_MAX_DOFS and st._picard_basis(d, GeneralizedAlpha(0.8), np.ones(2 * d.n)) is not None
    widths = []
    step = st._newton_step
    monkeypatch.setattr(st, "_newton_step", lambda W, V, D: widths.append(W.shape[1]) or step(W, V, D))
    picard = shooting(s)
    assert set(widths) == {2 * st._PICARD_MODES}  # converged without falling back to Newton
    monkeypatch.setattr(st, "_DENSE_MAX_DOFS", 10**6)
    newton = shooting(s.replace())
    for link in ("L2", "L3"):
        a, b = picard.midpoint_mm(link), newton.midpoint_mm(link)
        assert np.abs(a - b).max() <= 1e-7 * np.ptp(b)
    assert np.allclose(picard.floquet_multipliers[:4], newton.floquet_multipliers[:4], rtol=1e-6)


def test_gravity_is_not_scaled_with_the_speed():
    """With gravity (an assumption, 0 in the book's file) the load F = -M (u_r'' + g) has a part
    that does not scale with the speed's square: the step data at 300 r/min, built after 150
    r/min, must equal sampling at 300 r/min (before, the cached F / Omega^2 of the first speed
    was scaled, so the weight of the links grew fourfold)."""
    p = load_params().replace(gravity=9.81)
    clear_cache()
    LinkageDynamics(Setup(p, crank_speed_rpm=150, steps_per_period=32, motors=False))
    d = LinkageDynamics(Setup(p, crank_speed_rpm=300, steps_per_period=32, motors=False))
    F = d._sample(d.t)[3]
    assert np.abs(d.step_data.F - F).max() <= 1e-12 * np.abs(F).max()


def test_stiffness_damping_from_the_cache_is_the_speed_s_own():
    """Stiffness (Kelvin-Voigt) damping adds beta Y_b to K, a term of the links' turning frames
    linear in the speed, with beta = 2 zeta / omega_1 independent of it: the cache holds it at
    1 rad/s and scales it.  The step data at 300 r/min, built after 150 r/min filled the cache,
    must equal sampling at 300 r/min (a cache that kept the first speed's K, or scaled the term
    with the speed's square, is off by the size of the term, 5e-6 of K's largest entry here, far above
    round-off)."""
    p = load_params().replace(damping_model="stiffness", bending_depth=0.002)
    clear_cache()
    LinkageDynamics(Setup(p, crank_speed_rpm=150, steps_per_period=32, motors=False))
    d = LinkageDynamics(Setup(p, crank_speed_rpm=300, steps_per_period=32, motors=False))
    assert d._key is not None  # served by the cache
    fresh = d._sample(d.t)
    for name, X, ref in zip("MCKF", (d.step_data.M, d.step_data.C, d.step_data.K, d.step_data.F), fresh):
        assert np.abs(X - ref).max() <= 1e-13 * np.abs(ref).max(), name


def test_shooting_converging_as_it_leaves_the_newton_picard_basis():
    """Above 32 DOFs shooting starts with Newton on the lowest modes and Picard's iteration on
    the rest, and goes over to Newton on every direction when an iteration reduces the residual
    by less than 10.  If that same iteration reached the tolerance, the reduced monodromy
    (2 n x 24) was kept as the orbit's own and scaled by the full scaling: ValueError, shapes
    (92,24) and (1,92).  The tolerance is put just above the residual of the first slow
    iteration, found from this run's own history, so the case is met on any machine; the orbit
    must then come with its 2 n Floquet multipliers (stable: the damped linear model)."""
    import re

    s = Setup(P, crank_speed_rpm=300.0, motors=False, nonlinear=False, elements_per_link=(2, 4, 4, 2),
              steps_per_period=100)
    history = []
    for it in range(1, 9):
        with pytest.raises(fivebar.FivebarError) as exc:
            shooting(s, tol=1e-16, max_iter=it)
        history.append(float(re.search(r"residual ([0-9.e+-]+)", str(exc.value)).group(1)))
    slow = next(k for k in range(1, len(history)) if history[k] > 0.1 * history[k - 1])
    res = shooting(s, tol=1.01 * history[slow], max_iter=slow + 1)
    assert res.residual <= 1.01 * history[slow]
    mu = res.floquet_multipliers
    assert mu.shape == (2 * res.dynamics.n,) and np.abs(mu).max() < 1


def test_shooting_settles_first_where_newtons_step_fails():
    """Issue 32: steel links, heavier masses, crank DE at twice the speed, the 2 mm side in the plane,
    70 r/min (S = 200): from the quasi-static state no step along Newton's direction reduces the
    periodicity residual, yet the damped linkage settles on a stable orbit within a few periods.
    Shooting now marches from its start until the change over a period is small and shoots from
    there: its orbit is the one a long march from the same start reaches (an independent route, no
    Newton on periodicity; from rest the transient's first steps fail), to the march's tolerance."""
    from fivebar.analyses.steady import _initial_state, _newton_orbit

    p = load_params().replace(**{"material.E": 210e9, "material.rho": 7850.0, "masses.m01": 0.3,
                                 "masses.m02": 0.2, "speed_ratio": 2.0, "bending_depth": 0.002,
                                 "damping_model": "stiffness"})
    s = Setup(p, crank_speed_rpm=70, steps_per_period=200, motors=False)
    with pytest.raises(SteadyStateError, match="no step along the Newton direction"):
        _newton_orbit(s, None, None, 1e-10, 20)  # the case: Newton from the quasi-static state fails
    sh = shooting(s)
    assert sh.stable and sh.residual < 1e-10
    mr = march(s, *_initial_state(linkage_dynamics(s)), tol=1e-9, max_periods=400)
    for link in ("L2", "L3"):
        assert np.abs(mr.midpoint_mm(link) - sh.midpoint_mm(link)).max() < 1e-6 * sh.peak_to_peak_mm(link)


def test_a_cold_start_that_cannot_leave_the_quasi_static_state_starts_from_the_coarser_orbit():
    """Issue 32: the flexible orientation at 30 r/min with 3 % damping, nonlinear, S = 100
    (examples/params/flexible_slow_damped.toml): from the quasi-static state the first step's
    Newton iteration stalls (Newton on periodicity and the march fail alike), while from the
    orbit at S = 50 every step converges.  Shooting then starts from that orbit; its orbit is the
    one a march at S = 100 from the same state settles on (no Newton on periodicity), to the
    march's tolerance."""
    from fivebar.analyses.steady import _newton_orbit
    from fivebar.numerics.newmark import NewtonConvergenceError

    p = load_params().replace(**{"bending_depth": 0.002, "crank_speed_rpm": 30.0, "damping_ratio": 0.03})
    s = Setup(p, steps_per_period=100)
    with pytest.raises(NewtonConvergenceError, match="could not integrate the first period"):
        _newton_orbit(s, None, None, 1e-10, 20)  # the case: the cold start fails
    sh = shooting(s)
    assert sh.dynamics.steps_per_period == 100 and sh.residual < 1e-8
    coarse = shooting(s.replace(steps_per_period=50))
    mr = march(s, coarse.u[0], coarse.v[0], tol=1e-10, max_periods=400)
    for link in ("L2", "L3"):
        assert np.abs(mr.midpoint_mm(link) - sh.midpoint_mm(link)).max() < 1e-6 * sh.peak_to_peak_mm(link)


def test_shooting_stops_at_the_round_off_floor_within_ten_times_the_tolerance():
    """Issue 32: a residual that no Newton step reduces is the round-off floor of the period map;
    within ten times ``tol`` the orbit is returned (its residual kept), farther it is an error.  The
    floor is measured here (a tolerance far below it fails and names the residual reached); a
    tolerance a third of it must then converge with that residual, and its orbit is the one shot
    to a loose tolerance that Newton reaches outright (independent of the rule)."""
    import re

    s = Setup(load_params(), steps_per_period=100, nonlinear=False)
    with pytest.raises(SteadyStateError, match="no step along the Newton direction") as exc:
        shooting(s, tol=1e-30)
    floor = float(re.search(r"residual ([0-9.e+-]+)", str(exc.value)).group(1))
    res = shooting(s, tol=floor / 3)
    assert floor / 3 < res.residual <= 10 * floor / 3
    with pytest.raises(SteadyStateError, match="no step along the Newton direction"):
        shooting(s, tol=floor / 30)  # beyond ten times the tolerance: not taken as converged
    ref = shooting(s, tol=1e-9)
    assert ref.residual <= 1e-9
    for link in ("L2", "L3"):
        assert np.abs(res.midpoint_mm(link) - ref.midpoint_mm(link)).max() < 1e-6 * ref.peak_to_peak_mm(link)
