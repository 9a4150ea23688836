"""Continuation of periodic orbits (fivebar.numerics.continuation) against independent references.

* Forced Duffing oscillator x'' + 2 zeta x' + x + alpha x^3 = F cos(w t), continued in w:
  the two folds of its frequency response against a reference that shares nothing with the
  library's integrator or continuation: scipy's DOP853 (rtol 1e-11) with the variational
  equations, and scipy.optimize.root on the fold condition (periodicity and
  det(Phi - I) = 0, three equations in x(0), x'(0), w).  The remaining difference is the
  trapezoidal rule's period error, w dt^2 / 12 relative (checked).  For small forcing the
  upper fold (the peak) lies on the first-order multiple-scales backbone
  w = 1 + 3 alpha a^2 / 8 (fivebar.numerics.response_curves.backbone).
* Parametrically excited damped Duffing x'' + 2 zeta x' + (a - 2 q cos 2t) x + alpha x^3 = 0,
  continued in a on its trivial orbit: the period doublings are the boundaries of the damped
  first instability tongue (reference: DOP853 monodromy of the linear equation and a root of
  det(Phi + I)); the period-2 branch after switching against brute force (a long DOP853 march
  sampled once per period, and the library's own map iterated).
* A linear oscillator with damping c through zero: a Neimark-Sacker point at c = 0 exactly
  (closed form multipliers exp(lambda T), |mu| = exp(-c T / 2)).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, root

from fivebar.numerics.continuation import ContinuationError, continuation, settle, switch_period_doubling
from fivebar.errors import FivebarError
from fivebar.numerics.newmark import NewtonConvergenceError
from fivebar.numerics.modal_equations import Harmonic, ModalSystem
from fivebar.numerics.response_curves import backbone
from fivebar.numerics.systems import System
from fivebar.numerics.periodic import PeriodicProblem, iterate_map, modal_period_map, newmark_map, shoot


def _duffing(zeta, alpha, F, S):
    def family(w):
        sysm = System(np.eye(1), [[2 * zeta]], np.eye(1), force=lambda t: [F * math.cos(w * t)],
                      nonlinear=lambda u: (alpha * u ** 3, np.array([[3 * alpha * u[0] ** 2]])))
        return PeriodicProblem(sysm, 2 * math.pi / w, S)
    return newmark_map(family)


def _duffing_compiled(zeta, alpha, F, S):
    """The map of :func:`_duffing` (the same equation, period, steps and scheme) as the modal
    equations give it: one mode, w = 1, gamma = -alpha, its force compiled, so that the compiled
    loop marches it (``_duffing``'s Python functions are marched by the Python loop); for the
    tests that apply the map tens of thousands of times."""
    duffing = ModalSystem(w=[1.0], zeta=[zeta], gamma=np.full((1, 1, 1, 1), -alpha))
    return modal_period_map(duffing, [Harmonic(1.0, [F])], steps=S)


def _duffing_fold_reference(zeta, alpha, F, guess):
    """(x0, v0, w) at a fold: DOP853 period map with its variational equations; root of
    (x(T) - x0, det(Phi - I))."""
    def flow(x0, w):
        def rhs(t, y):
            x, v = y[0], y[1]
            J = np.array([[0.0, 1.0], [-1 - 3 * alpha * x * x, -2 * zeta]])
            return np.r_[v, F * math.cos(w * t) - 2 * zeta * v - x - alpha * x ** 3,
                         (J @ y[2:].reshape(2, 2)).ravel()]
        s = solve_ivp(rhs, (0, 2 * math.pi / w), np.r_[x0, np.eye(2).ravel()], method="DOP853",
                      rtol=1e-11, atol=1e-13)
        return s.y[:2, -1], s.y[2:, -1].reshape(2, 2)

    def eqs(z):
        xT, P = flow(z[:2], z[2])
        return np.r_[xT - z[:2], np.linalg.det(P - np.eye(2))]
    sol = root(eqs, guess, tol=1e-13)
    # judged by its residual: MINPACK's step test at tol = 1e-13 sits at the round-off, and whether
    # it reports success ("not making good progress" otherwise) depends on the BLAS kernels
    assert np.abs(eqs(sol.x)).max() < 1e-10, sol.message
    return sol.x


def test_duffing_folds_against_dop853_fold_condition():
    zeta, alpha, F, S = 0.05, 1.0, 0.1, 100
    br = continuation(_duffing(zeta, alpha, F, S), np.zeros(2), 1.0, 1.4, ds=0.05, ds_max=0.3)
    folds = [b for b in br.bifurcations if b.kind == "fold"]
    assert len(folds) == 2 and br.stop.startswith("p_end")
    assert [b.kind for b in br.bifurcations] == ["fold", "fold"]
    # the branch turns back: p is not monotone, and the middle (unstable) part lies between the folds
    assert np.any(np.diff(br.p) < 0)
    unstable = br.p[~br.stable]
    assert unstable.size and folds[1].p - 1e-6 <= unstable.min() and unstable.max() <= folds[0].p + 1e-6
    period_error = (2 * math.pi / S) ** 2 / 12  # relative frequency error of the trapezoidal rule
    for b in folds:
        assert abs(b.critical - 1) < 1e-4
        ref = _duffing_fold_reference(zeta, alpha, F, np.r_[b.x, b.p])
        rel = (b.p - ref[2]) / ref[2]
        # measured: -8.4e-5 (S = 200) and -3.3e-4 (S = 100) at both folds: the period error
        assert abs(rel + period_error) < 0.1 * period_error, (b.p, ref[2], rel)
        assert abs(b.p * (1 + period_error) - ref[2]) < 2e-5
        assert abs(b.p_bracket[1] - b.p_bracket[0]) < 1e-6


def test_duffing_small_forcing_peak_on_the_multiple_scales_backbone():
    zeta, alpha, F, S = 0.005, 0.5, 0.004, 200
    br = continuation(_duffing(zeta, alpha, F, S), np.zeros(2), 0.99, 1.05, ds=0.05, ds_max=0.3,
                      p_scale=0.01)
    folds = sorted((b for b in br.bifurcations if b.kind == "fold"), key=lambda b: b.p)
    assert len(folds) == 2
    upper = folds[1]
    a = math.hypot(upper.x[0], upper.x[1] / upper.p)  # first-harmonic amplitude at the fold
    w_bb = float(backbone(ModalSystem(w=[1.0], gamma=np.full((1, 1, 1, 1), -alpha)), 0, [a])[0])
    assert abs(w_bb - (1 + 3 * alpha * a * a / 8)) < 1e-12
    shift = upper.p * (1 + (2 * math.pi / S) ** 2 / 12) - 1  # the discrete period error removed
    # first-order multiple scales: error O(shift) relative (measured 1.8 %)
    assert abs(shift / (w_bb - 1) - 1) < 0.03
    # the forced amplitude at the peak is F / (2 zeta) to first order (measured 0.385 against 0.4)
    assert abs(a / (F / (2 * zeta)) - 1) < 0.05


def _parametric(zeta, q, alpha, S):
    def family(a):
        sysm = System(np.eye(1), [[2 * zeta]], lambda t: np.array([[a - 2 * q * math.cos(2 * t)]]),
                      nonlinear=lambda u: (alpha * u ** 3, np.array([[3 * alpha * u[0] ** 2]])))
        return PeriodicProblem(sysm, math.pi, S)
    return newmark_map(family)


def _damped_mathieu_pd(zeta, q, lo, hi):
    def det_plus_i(a):
        def rhs(t, y):
            return (np.array([[0, 1], [-(a - 2 * q * math.cos(2 * t)), -2 * zeta]]) @ y.reshape(2, 2)).ravel()
        s = solve_ivp(rhs, (0, math.pi), np.eye(2).ravel(), method="DOP853", rtol=1e-12, atol=1e-14)
        return np.linalg.det(s.y[:, -1].reshape(2, 2) + np.eye(2))
    return brentq(det_plus_i, lo, hi, xtol=1e-13)


def test_period_doublings_of_the_parametric_oscillator_and_its_period_2_branch():
    zeta, q, alpha = 0.05, 0.5, 1.0
    ref = [_damped_mathieu_pd(zeta, q, 0.3, 1.0), _damped_mathieu_pd(zeta, q, 1.0, 1.8)]
    errs = {}
    for S in (100, 200):
        f = _parametric(zeta, q, alpha, S)
        br = continuation(f, np.zeros(2), 0.3, 1.8, ds=0.02, ds_max=0.05)
        pds = [b for b in br.bifurcations if b.kind == "period doubling"]
        assert [b.kind for b in br.bifurcations] == ["period doubling"] * 2
        errs[S] = np.array([b.p for b in pds]) - ref
        for b in pds:
            assert abs(b.critical + 1) < 1e-6
    # dt^2: measured 2.1e-4, 2.2e-4 at S = 100
    assert np.all(np.abs(errs[200]) < 1e-4) and np.all(np.abs(errs[100] / errs[200] - 4) < 0.3), errs

    f = _parametric(zeta, q, alpha, 100)  # the switch at S = 100
    br = continuation(f, np.zeros(2), 1.3, 1.6, ds=0.02, ds_max=0.05)
    upper = br.bifurcations[-1]
    a_end = upper.p - 0.3
    b2 = switch_period_doubling(f, upper, a_end, h=0.05, ds=0.05, ds_max=0.2)
    assert b2.periods == 2 and abs(b2.p[-1] - a_end) < 1e-12
    x2 = b2.x[-1]
    other = f(x2, a_end, False)[0]
    assert np.linalg.norm(other - x2) > 0.5  # a genuine period-2 orbit (the two iterates differ)
    assert b2.stable[-1]
    # brute force 1: the library's own map iterated from near rest converges onto the same orbit
    xs = iterate_map(f, [0.1, 0.0], a_end, periods=400)
    assert min(np.abs(xs[-1] - x2).max(), np.abs(xs[-1] - other).max()) < 1e-8
    # brute force 2: DOP853 march, sampled once per period pi
    def rhs(t, y):
        return [y[1], -2 * zeta * y[1] - (a_end - 2 * q * math.cos(2 * t)) * y[0] - alpha * y[0] ** 3]
    s = solve_ivp(rhs, (0, 400 * math.pi), [0.1, 0.0], method="DOP853", rtol=1e-11, atol=1e-13,
                  t_eval=[398 * math.pi, 399 * math.pi, 400 * math.pi])
    samples = s.y.T
    assert np.abs(samples[0] - samples[2]).max() < 1e-8  # period 2 in the samples
    d = min(np.abs(samples[2] - x2).max(), np.abs(samples[2] - other).max())
    assert d < 1e-3  # the discretisation at S = 100 (measured 2.6e-4)


def test_neimark_sacker_of_a_linear_oscillator_at_zero_damping():
    w = 0.7

    def family(c):
        return PeriodicProblem(System(np.eye(1), [[c]], np.eye(1), force=lambda t: [math.cos(w * t)]),
                               2 * math.pi / w, 200)
    br = continuation(newmark_map(family), np.zeros(2), 0.1, -0.1, ds=0.05, ds_max=0.2)
    ns = [b for b in br.bifurcations if b.kind == "Neimark-Sacker"]
    assert [b.kind for b in br.bifurcations] == ["Neimark-Sacker"]
    assert abs(ns[0].p) < 1e-7
    T = 2 * math.pi / w
    mu = ns[0].critical
    assert abs(abs(mu) - 1) < 1e-7
    # the free frequency 1: angle T; the trapezoidal rule turns by 2 atan(dt / 2) per step
    assert abs(np.angle(mu) - np.angle(np.exp(1j * T))) < 2e-3
    dt = T / 200
    assert abs(np.angle(mu) - np.angle(np.exp(1j * 200 * 2 * math.atan(dt / 2)))) < 1e-9
    assert br.stable[0] and not br.stable[-1]


def test_bad_input():
    f = _parametric(0.05, 0.5, 1.0, 50)
    with pytest.raises(FivebarError, match="ds"):
        continuation(f, np.zeros(2), 0.3, 1.0, ds=-1)
    with pytest.raises(FivebarError, match="p_end"):
        continuation(f, np.zeros(2), 0.3, 0.3)
    with pytest.raises(FivebarError, match="period doubling"):
        switch_period_doubling(f, _fake_fold(), 1.0)
    assert issubclass(ContinuationError, FivebarError)


def _fake_fold():
    from fivebar.numerics.continuation import Bifurcation
    return Bifurcation("fold", 1.0, np.zeros(2), np.zeros(2, complex), 0, (1.0, 1.0), 0.0)


def test_a_failing_map_stops_the_continuation_with_the_branch_so_far():
    def family(c):
        return PeriodicProblem(System(np.eye(1), [[c]], np.eye(1), force=lambda t: [math.cos(0.7 * t)]),
                               2 * math.pi / 0.7, 50)
    f = newmark_map(family)

    def failing(x, p, jacobian):
        if p > 0.3:
            raise ContinuationError("this map stops at 0.3")
        return f(x, p, jacobian)
    with pytest.raises(ContinuationError, match="ds_min") as info:
        continuation(failing, np.zeros(2), 0.1, 0.5, ds=0.05, ds_max=0.1, ds_min=1e-4)
    br = info.value.branch
    assert len(br.points) >= 3 and 0.29 < br.p[-1] <= 0.3 and "ds_min" in br.stop


def test_a_point_whose_jacobian_fails_is_a_rejected_step():
    """A corrected point at which the monodromy cannot be made (here: the map refuses the
    Jacobian above p = 0.3, while its plain periods go on) is not kept: the step is rejected
    and halved, and the continuation ends with the branch so far (below 0.3), its stop saying
    why, instead of the map's error escaping (as the linkage's did where a period at p + dp
    failed to integrate)."""
    def family(c):
        return PeriodicProblem(System(np.eye(1), [[c]], np.eye(1), force=lambda t: [math.cos(0.7 * t)]),
                               2 * math.pi / 0.7, 50)
    f = newmark_map(family)

    def failing(x, p, jacobian):
        if jacobian and p > 0.3:
            raise NewtonConvergenceError("no Jacobian above 0.3", 0.0, math.nan, 0)
        return f(x, p, jacobian)
    with pytest.raises(ContinuationError, match="ds_min") as info:
        continuation(failing, np.zeros(2), 0.1, 0.5, ds=0.05, ds_max=0.1, ds_min=1e-4)
    br = info.value.branch
    assert len(br.points) >= 3 and 0.29 < br.p[-1] <= 0.3
    by = br.stats["by purpose"]
    # the failed Jacobians are the rejected steps' work; every accepted point has its own
    assert by["multipliers"]["monodromies"] == len(br.points) - 1
    assert by["rejected"]["monodromies"] >= 1
    for k in ("periods", "monodromies", "newton"):
        assert sum(c[k] for c in by.values()) == br.stats[k]


def test_a_locating_trial_that_fails_is_followed_by_others_inside_the_bracket(monkeypatch):
    """Where a trial point of the locator has no Jacobian (here: the map refuses every other
    Jacobian asked while locating), the next trials go to the middle and the quarters of the
    bracket instead of ending the location: both folds of the Duffing loop are still located to
    the bracket of the plain run (chapter 13's rerun with l2_damping.toml lost one so)."""
    import fivebar.numerics.continuation as cont

    zeta, alpha, F, S = 0.05, 1.0, 0.1, 100
    f = _duffing(zeta, alpha, F, S)
    plain = continuation(f, np.zeros(2), 1.0, 1.4, ds=0.05, ds_max=0.3)
    state = {"locating": False, "asked": 0}
    locate = cont._locate

    def locating(*args, **kwargs):
        state["locating"] = True
        try:
            return locate(*args, **kwargs)
        finally:
            state["locating"] = False

    def refusing(x, p, jacobian):
        if jacobian and state["locating"]:
            state["asked"] += 1
            if state["asked"] % 2:
                raise NewtonConvergenceError("refused", 0.0, math.nan, 0)
        return f(x, p, jacobian)

    monkeypatch.setattr(cont, "_locate", locating)
    br = continuation(refusing, np.zeros(2), 1.0, 1.4, ds=0.05, ds_max=0.3)
    assert state["asked"] > 4
    assert [b.kind for b in br.bifurcations] == [b.kind for b in plain.bifurcations] == ["fold", "fold"]
    for b, ref in zip(br.bifurcations, plain.bifurcations):
        assert abs(b.critical - 1) < 1e-6 and abs(b.p - ref.p) < 1e-9
        assert abs(b.p_bracket[1] - b.p_bracket[0]) < 1e-6


def test_a_large_maximum_step_does_not_skip_the_folds():
    # ds_max the whole range: the step is set by the branch's curvature (and the corrector),
    # so the narrow hysteresis loop of the Duffing oscillator is still followed around both
    # folds, located where the fine continuation of the test above puts them (DOP853 fold
    # condition, with the trapezoidal rule's period error)
    zeta, alpha, F, S = 0.05, 1.0, 0.1, 100
    br = continuation(_duffing(zeta, alpha, F, S), np.zeros(2), 0.6, 2.5, ds=0.5, ds_max=2.0)
    assert br.stop.startswith("p_end")
    folds = [b for b in br.bifurcations if b.kind == "fold"]
    assert len(folds) == 2
    period_error = (2 * math.pi / S) ** 2 / 12
    for b in folds:
        ref = _duffing_fold_reference(zeta, alpha, F, np.r_[b.x, b.p])
        assert abs(b.p * (1 + period_error) - ref[2]) < 2e-5
    # large steps are taken where the branch is straight (measured: up to 0.40)
    assert br.steps.max() > 0.3


def test_the_stats_account_for_every_map_application_by_purpose():
    # a helix of fixed points x*(p) = (sin 4p, cos 4p) of a map whose G = -atan(K (x - x*)) / (2 K) has a
    # Newton basin of |K (x - x*)| < 1.39: the predictor's error leaves it for long steps, where the corrector
    # diverges and the step is rejected.  With K = 1e3 and the tangent predictor (error ~ h^2 / 2 on a curvature
    # ~1): 107 points, 107 rejected steps, 1926 map applications, 1192 of them in the rejected steps; the second-
    # order predictor (the tangent's turn continued, error ~ h^3) leaves the basin so rarely there (32 points,
    # 5 rejected steps, 415 map applications) that the basin is made ten times narrower: 81 points, 44 rejected
    # steps, 1088 map applications, 590 of them in the rejected steps
    K = 1e4

    def xs(p):
        return np.array([math.sin(4 * p), math.cos(4 * p)])

    def f(x, p, jacobian):
        d = x - xs(p)
        return x - 0.5 * np.arctan(K * d) / K, (np.eye(2) - np.diag(0.5 / (1 + (K * d) ** 2)) if jacobian else None)
    br = continuation(f, xs(0.0), 0.0, 1.0, ds=0.01, ds_max=0.5, scale=np.ones(2))
    assert br.stop.startswith("p_end")
    assert max(np.abs(q.x - xs(q.p)).max() for q in br.points) < 1e-8  # on the closed-form branch
    s, by = br.stats, br.stats["by purpose"]
    assert set(by) == {"start", "corrector", "rejected", "multipliers", "locate", "recovery"}
    # every map application, monodromy and corrector iteration is charged to one purpose
    for k in ("periods", "monodromies", "newton"):
        assert sum(c[k] for c in by.values()) == s[k]
    # one Jacobian (a monodromy and a period in p) at every accepted point
    assert by["multipliers"] == {"periods": 2 * (len(br.points) - 1), "monodromies": len(br.points) - 1, "newton": 0}
    # the accepted points' corrections, iteration for iteration
    assert by["corrector"]["newton"] == br.newton.sum()
    # the rejected steps' work is theirs: at least the predictor's period of each
    assert s["rejected"] > 10 and by["rejected"]["periods"] >= s["rejected"] and by["rejected"]["newton"] > 0
    assert by["start"]["periods"] >= 3 and by["locate"] == {"periods": 0, "monodromies": 0, "newton": 0}
    # a corrector whose fresh Jacobians lead out of the basin gives up (the corrector's rule: two full updates
    # of fresh Jacobians in a row that do not reduce the residual, or one that fails): measured 11.1 periods per
    # rejected step, 15.0 when it went on to its damped trials and further Jacobians (the same 107 rejections,
    # K = 1e3, tangent predictor); 13.4 with K = 1e4 and the second-order predictor, 14.8 without the rule
    assert by["rejected"]["periods"] <= 14 * s["rejected"]


def test_continuation_and_shooting_run_on_one_blas_thread():
    # the path's discrete decisions depend on rounding, which threaded BLAS changes with the
    # thread count: inside continuation (and shoot) the BLAS pools are limited to one thread
    threadpoolctl = pytest.importorskip("threadpoolctl")
    import scipy.linalg.cython_blas  # noqa: F401  (load scipy's BLAS, as the library does)

    seen = []
    base = _duffing(0.05, 1.0, 0.1, 50)

    def watched(x, p=None, jacobian=False):
        seen.append(max(i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"))
        return base(x, p, jacobian)

    with threadpoolctl.threadpool_limits(2, user_api="blas"):
        outside = max(i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas")
        continuation(watched, np.zeros(2), 0.8, 0.9, ds=0.05, ds_max=0.1)
    if outside < 2:
        pytest.skip("one core: the BLAS pools cannot have two threads here")
    assert seen and max(seen) == 1


def test_settle_names_the_period_2_orbit_inside_the_tongue_against_dop853():
    # the parametrically excited Duffing oscillator inside its first tongue (between the period
    # doublings at a = 0.61 and 1.43 for zeta = 0.05, q = 0.5): the trivial orbit is unstable with a
    # multiplier below -1, and the motion settles on a stable period-2 orbit; reference a DOP853
    # march from the same disturbed start, sampled once per period pi
    zeta, q, alpha, a, S = 0.05, 0.5, 1.0, 1.0, 200
    f = _parametric(zeta, q, alpha, S)
    orb = shoot(f, np.zeros(2), a)
    assert np.abs(orb.x).max() < 1e-12 and orb.multipliers[0].real < -1  # the trivial orbit, flipping
    out = settle(f, orb, a, periods=300)
    assert out.kind == "period-2"
    x2 = out.found.x
    other = f(x2, a, False)[0]
    assert np.abs(other - x2).max() > 0.1 and out.found.stable

    def rhs(t, y):
        return [y[1], -2 * zeta * y[1] - (a - 2 * q * math.cos(2 * t)) * y[0] - alpha * y[0] ** 3]
    s = solve_ivp(rhs, (0, 300 * math.pi), out.samples[0], method="DOP853", rtol=1e-11, atol=1e-13,
                  t_eval=[298 * math.pi, 299 * math.pi, 300 * math.pi])
    ref = s.y.T
    assert np.abs(ref[0] - ref[2]).max() < 1e-8 and np.abs(ref[0] - ref[1]).max() > 0.1  # period 2
    # the same two iterates, in the same phase (the march and DOP853 start alike); the trapezoidal
    # rule's error at S = 200, measured 5.5e-5
    assert np.abs(out.samples[-1] - ref[2]).max() < 2e-4
    assert min(np.abs(x2 - ref[2]).max(), np.abs(other - ref[2]).max()) < 2e-4


@pytest.mark.slow
def test_settle_between_the_folds_finds_the_stable_orbit_a_dop853_march_reaches():
    # the forced Duffing oscillator between its folds: the middle orbit is a saddle (a multiplier
    # above +1); the march from it, disturbed along the unstable direction, reaches one of the two
    # stable period-1 orbits, the one that a DOP853 march from the same start reaches
    zeta, alpha, F, S, w = 0.05, 1.0, 0.1, 200, 1.2
    f = _duffing(zeta, alpha, F, S)
    br = continuation(f, np.zeros(2), 1.0, 1.4, ds=0.05, ds_max=0.3)
    folds = sorted(b.p for b in br.bifurcations if b.kind == "fold")
    assert folds[0] < w < folds[1]
    middle = [q for q in br.points if not q.stable]
    saddle = shoot(f, min(middle, key=lambda q: abs(q.p - w)).x, w)
    assert not saddle.stable and abs(saddle.multipliers[0].imag) == 0 and saddle.multipliers[0].real > 1
    for sign in (1.0, -1.0):
        out = settle(f, saddle, w, periods=200, disturbance=sign * 0.01)
        assert out.kind == "other period-1" and out.found.stable

        def rhs(t, y):
            return [y[1], F * math.cos(w * t) - 2 * zeta * y[1] - y[0] - alpha * y[0] ** 3]
        T = 2 * math.pi / w
        s = solve_ivp(rhs, (0, 200 * T), out.samples[0], method="DOP853", rtol=1e-11, atol=1e-13, t_eval=[199 * T, 200 * T])
        ref = s.y.T
        assert np.abs(ref[1] - ref[0]).max() < 1e-8
        # the trapezoidal rule at S = 200 near the resonance: measured 6.4e-4 and 5.7e-4 of the size
        assert np.abs(out.found.x - ref[1]).max() < 2e-3 * np.abs(ref[1]).max()
        found = out.found.x if sign > 0 else (found, out.found.x)
    # the two directions reach the two stable orbits (the small and the large response)
    assert np.abs(found[0] - found[1]).max() > 0.1


def _swapping_map():
    """A linear map x -> A(p) x + b whose multipliers are known in closed form: a pair
    2 +- sqrt(p - 1.1) (non-real below p = 1.1, two real ones above, outside the unit circle
    up to p = 2), and 5 and (p - 0.05) / 5, whose product passes 1 at p = 1.05 (a neutral saddle;
    the products of the last with the pair stay below 1 up to p = 1.5).  No multiplier crosses
    the unit circle in 0 < p < 1.5."""
    def A(p):
        M = np.zeros((4, 4))
        M[:2, :2] = [[2.0, 1.0], [p - 1.1, 2.0]]  # eigenvalues 2 +- sqrt(p - 1.1)
        M[2, 2], M[3, 3] = 5.0, (p - 0.05) / 5.0
        return M

    b = np.array([0.1, 0.0, 0.1, 0.1])

    def f(x, p=None, jacobian=False):
        M = A(p)
        return M @ x + b, (M if jacobian else None)
    return f


def test_a_neutral_saddle_with_a_pair_turning_real_is_no_neimark_sacker():
    # between two points a complex pair outside the circle turns real (the count of non-real
    # multipliers outside changes) and two real multipliers pass through product 1 (the
    # bialternate determinant changes sign): both test conditions of a Neimark-Sacker point hold,
    # yet no multiplier is on the unit circle; the located point must be discarded
    f = _swapping_map()
    br = continuation(f, np.zeros(4), 0.0, 1.5, ds=0.5, ds_min=0.5, ds_max=0.5, scale=np.full(4, 100.0))
    assert br.stop.startswith("p_end")
    assert any(a < 1.05 and 1.1 < b for a, b in zip(br.p[:-1], br.p[1:]))  # both in one step
    assert [b.kind for b in br.bifurcations] == []
    assert [b.kind for b in br.discarded] == ["Neimark-Sacker"]
    # what it found there: the pair still non-real at the neutral saddle p = 1.05, |mu| = sqrt(4.05)
    d = br.discarded[0]
    assert abs(d.p - 1.05) < 1e-6 and abs(abs(d.critical) - math.sqrt(4.05)) < 1e-6 and d.distance() > 1


def test_the_difference_in_p_beside_the_monodromy_changes_no_number(monkeypatch):
    # a map that allows it (``concurrent``) gets its period at p + dp in a second thread while
    # the monodromy period runs; the branch (points, multipliers, located folds and the counts)
    # is that of the serial order to the bit (planted: a second thread whose period starts from
    # a perturbed state, or that is not run beside, fails the equality or the thread check)
    import threading

    import fivebar.numerics.continuation as cont

    monkeypatch.setattr(cont, "_cores", lambda: 2)  # as on a machine of two cores or more
    base = _duffing(0.05, 1.0, 0.1, 60)
    threads = []

    def make(concurrent):
        def f(x, p=None, jacobian=False):
            threads.append((threading.current_thread() is threading.main_thread(), jacobian))
            return base(x, p, jacobian)
        f.concurrent = concurrent
        return f

    runs = {}
    for concurrent in (False, True):
        threads.clear()
        runs[concurrent] = continuation(make(concurrent), np.zeros(2), 0.6, 2.5, ds=0.1, ds_max=0.5)
        seen = set(threads)
        if concurrent:  # the plain periods of the differences in a second thread, the rest here
            assert (False, False) in seen and (False, True) not in seen and (True, True) in seen
        else:
            assert seen <= {(True, False), (True, True)}
    a, b = runs[False], runs[True]
    assert len([x for x in a.bifurcations if x.kind == "fold"]) == 2
    assert len(a.points) == len(b.points) and a.stats == b.stats
    for qa, qb in zip(a.points, b.points):
        assert np.array_equal(qa.x, qb.x) and qa.p == qb.p and np.array_equal(qa.multipliers, qb.multipliers)
    assert [(x.kind, x.p) for x in a.bifurcations] == [(x.kind, x.p) for x in b.bifurcations]


def test_beside_raises_the_first_error_and_waits_for_both():
    import threading
    import time

    from fivebar.numerics.continuation import _beside

    done = []

    def slow():
        time.sleep(0.05)
        done.append(threading.current_thread().name)
        return 2

    def fail(msg):
        def f():
            raise FivebarError(msg)
        return f

    assert _beside(lambda: 1, slow, True) == (1, 2) and done  # the second ended before the return
    done.clear()
    with pytest.raises(FivebarError, match="first"):
        _beside(fail("first"), slow, True)
    assert done  # not left running
    with pytest.raises(FivebarError, match="second"):
        _beside(lambda: 1, fail("second"), True)
    with pytest.raises(FivebarError, match="first"):  # both fail: the serial order's error
        _beside(fail("first"), fail("second"), True)


@pytest.mark.slow
def test_a_branch_with_sharp_folds_is_the_same_from_either_end_and_under_perturbations():
    """The answer of a continuation is a property of the problem, not of round-off or of the
    first step: the forced Duffing oscillator whose response curve has a fold pair, with the
    state weighted lightly in the arclength (scale 300: the folds turn within a small arclength,
    as the linkage's folds do with ``follow``'s state_weight), followed from below, from the
    middle of the fold interval and from above, each with the first step scaled by 0.75, 1 and
    1.25 and the start perturbed by 1e-10: every run reaches p_end, and locates the same two
    folds, within 1e-6, at the DOP853 fold condition's frequencies (less the trapezoidal rule's
    period error).  Before the tangent's orientation followed det([J; t]) the run from 2.0
    with the unscaled first step jumped across the lower fold onto the resonant branch, turned
    back there and left the range through 3.26 (folds reported: 1.3293, 1.3293, 2.6563)."""
    zeta, alpha, F, S = 0.02, 1.0, 0.3, 100
    f = _duffing_compiled(zeta, alpha, F, S)
    found = []
    for p0, p1 in ((0.8, 3.0), (2.0, 0.8), (3.0, 0.8)):
        for factor in ((0.75, 1.0, 1.25) if p0 == 2.0 else (1.0,)):
            for pert in ((0.0, 1e-10) if p0 == 2.0 else (0.0,)):
                br = continuation(f, np.zeros(2) + pert, p0, p1, ds=0.02 * factor, ds_max=0.2, ds_min=1e-7,
                                  scale=np.full(2, 300.0), p_scale=abs(p1 - p0), max_points=400)
                assert br.stop == f"p_end = {p1:g} reached", (p0, factor, pert, br.stop)
                folds = sorted(b.p for b in br.bifurcations if b.kind == "fold")
                assert len(folds) == 2 and len(br.bifurcations) == 2, (p0, factor, pert, folds)
                found.append(folds)
                if (p0, factor, pert) == (0.8, 1.0, 0.0):
                    refs = sorted(_duffing_fold_reference(zeta, alpha, F, np.r_[b.x, b.p])[2]
                                  for b in br.bifurcations)
    found = np.array(found)
    assert np.ptp(found, axis=0).max() < 1e-6, found
    period_error = (2 * math.pi / S) ** 2 / 12
    assert np.abs(found[0] * (1 + period_error) - refs).max() < 2e-5 * max(refs)


@pytest.mark.slow
def test_a_corrector_that_cannot_converge_in_its_budget_is_recovered_by_newton():
    """With ``max_newton = 1`` the chord corrector never converges (it needs two iterations or
    more), so every step is halved down to ``ds_min``; the recovery (Newton's method with a
    fresh Jacobian at each iterate, more iterations) makes the step, each recovered point says
    so, and the branch and its folds are those of an ordinary run.  Without the recovery the
    continuation stops at its first point."""
    f = _duffing_compiled(0.05, 1.0, 0.1, 100)
    ref = continuation(f, np.zeros(2), 0.8, 1.6, ds=0.05, ds_max=0.1)
    br = continuation(f, np.zeros(2), 0.8, 1.6, ds=0.05, ds_max=0.1, ds_min=0.02, max_newton=1)
    assert br.stop == "p_end = 1.6 reached" and ref.stop == br.stop
    kinds = {q.recovery for q in br.points[1:]}
    assert kinds == {"full Newton"} and len(br.stats["recoveries"]) == len(br.points) - 1
    assert br.stats["by purpose"]["recovery"]["periods"] > 0
    a = sorted(b.p for b in ref.bifurcations)
    b = sorted(b.p for b in br.bifurcations)
    assert len(a) == len(b) == 2 and np.abs(np.subtract(a, b)).max() < 1e-5
    # every point on the branch: a period from it returns to it
    for q in br.points[::10]:
        assert np.abs(f(q.x, q.p)[0] - q.x).max() < 1e-8


def test_modal_period_map_is_the_period_map_of_the_modal_equations():
    """modal_period_map against scipy's DOP853 on ModalSystem.acceleration (the modal equations
    (3.4) as the generic core writes them), two modes with every kind of term, over one period
    at p = 1.3: the difference is the trapezoidal rule's O(dt^2) (S = 1500: below 5e-5 of the
    state); and its monodromy matrix against central differences of the map."""
    from fivebar.numerics.modal_equations import Harmonic, ModalSystem, Parametric
    from fivebar.numerics.periodic import modal_period_map, monodromy
    from fivebar.numerics.schemes import Newmark

    rng = np.random.default_rng(5)
    sysm = ModalSystem(w=[1.0, 2.3], zeta=[0.03, 0.05], alpha=0.05 * rng.standard_normal((2, 2)),
                       delta=0.1 * rng.standard_normal((2, 2, 2)), gamma=0.1 * rng.standard_normal((2, 2, 2, 2)))
    harm = [Harmonic(1.0, [0.2, 0.1], [0.3, -0.2]), Harmonic(2.0, [0.05, 0.1])]
    par = [Parametric(1.0, [[0.1, 0.02], [0.03, 0.2]], 0.4)]
    p, x0 = 1.3, np.array([0.1, -0.05, 0.02, 0.03])
    f = modal_period_map(sysm, harm, par, steps=1500, scheme=Newmark())
    xT = f(x0, p, False)[0]
    scaled_h = [Harmonic(p * h.frequency, h.amplitude, h.phase) for h in harm]
    scaled_p = [Parametric(p * q.frequency, q.stiffness, q.phase) for q in par]
    ref = solve_ivp(lambda t, y: np.r_[y[2:], sysm.acceleration(t, y[:2], y[2:], scaled_h, scaled_p)],
                    (0.0, 2 * math.pi / p), x0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    assert np.abs(xT - ref).max() < 5e-5 * np.abs(ref).max()
    coarse = modal_period_map(sysm, harm, par, steps=200, scheme=Newmark())
    _, Phi = coarse(x0, p, True)
    h = 1e-6
    fd = np.column_stack([(coarse(x0 + h * e, p, False)[0] - coarse(x0 - h * e, p, False)[0]) / (2 * h)
                          for e in np.eye(4)])
    assert np.abs(Phi - fd).max() < 1e-7
    with pytest.raises(FivebarError, match="whole multiple"):
        modal_period_map(sysm, [Harmonic(1.0, [1, 0]), Harmonic(math.sqrt(2), [1, 0])])


def test_jumps_of_a_hardening_and_a_softening_duffing_oscillator():
    """The forced Duffing oscillator swept in frequency: hardening (alpha > 0) jumps down when
    the frequency rises past its upper fold and up when it falls past its lower one; softening
    (alpha < 0) the other way round (Nayfeh & Mook 1979, 4.1.4); the jump lands on the stable
    orbit of the other leg, shot at the speed (orbits_at: three orbits between the folds)."""
    from fivebar.numerics.continuation import jumps, orbits_at

    for alpha, lo, hi in ((1.0, 1.0, 1.4), (-0.3, 0.7, 1.0)):
        f = _duffing(0.05, alpha, 0.1, 100)
        br = continuation(f, np.zeros(2), lo if alpha > 0 else hi, hi if alpha > 0 else lo, ds=0.05, ds_max=0.3)
        folds = sorted(b.p for b in br.bifurcations if b.kind == "fold")
        assert len(folds) == 2
        mid = orbits_at(br, f, 0.5 * sum(folds))
        assert len(mid) == 3 and sum(o.stable for o in mid) == 2
        js = {j.rising: j for j in jumps(br, f, lambda x, p: math.hypot(x[0], x[1] / p))}
        assert set(js) == {True, False}
        # either way a rising sweep leaves at the upper fold and a falling one at the lower
        assert js[True].p == pytest.approx(folds[1]) and js[False].p == pytest.approx(folds[0])
        assert (js[True].direction, js[False].direction) == (("down", "up") if alpha > 0 else ("up", "down"))
        assert all(len(j.after) == 1 for j in js.values())



def test_every_change_of_stability_is_located_where_a_test_functions_location_fails(monkeypatch):
    """Issue 32: a change of stability between two points that no test function locates (here the
    fold test's locator gets no Jacobian at any trial point, as where the trial points cannot be
    corrected; before, the fold was reported at the first point past it, up to a step away) is
    located on the stability itself, max |mu| - 1: both folds of the Duffing loop where the DOP853
    fold condition puts them (with the trapezoidal rule's period error), critical multiplier +1."""
    import fivebar.numerics.continuation as cont

    zeta, alpha, F, S = 0.05, 1.0, 0.1, 100
    f = _duffing(zeta, alpha, F, S)
    state = {"kind": None, "refused": 0}
    locate = cont._locate

    def locating(prob, kind, *args, **kwargs):
        state["kind"] = kind
        try:
            return locate(prob, kind, *args, **kwargs)
        finally:
            state["kind"] = None

    def refusing(x, p, jacobian):
        if jacobian and state["kind"] == "fold":
            state["refused"] += 1
            raise NewtonConvergenceError("refused", 0.0, math.nan, 0)
        return f(x, p, jacobian)

    monkeypatch.setattr(cont, "_locate", locating)
    br = continuation(refusing, np.zeros(2), 1.0, 1.4, ds=0.05, ds_max=0.3)
    assert state["refused"] > 0
    changes = np.flatnonzero(np.diff(br.stable.astype(int)))
    assert sorted(b.index for b in br.bifurcations) == list(changes) and len(changes) == 2
    period_error = (2 * math.pi / S) ** 2 / 12
    for b in br.bifurcations:
        assert b.kind == "fold" and b.distance() < 1e-6
        ref = _duffing_fold_reference(zeta, alpha, F, np.r_[b.x, b.p])
        assert abs(b.p * (1 + period_error) - ref[2]) < 2e-5


def test_the_compiled_duffing_map_is_the_python_one():
    """:func:`_duffing_compiled`, which the slow tests of this file use, is the map of
    :func:`_duffing` (Python functions, the Python loop): the same state after a period and the
    same monodromy matrix, to round-off, on and off resonance."""
    f, g = _duffing_compiled(0.02, 1.0, 0.3, 100), _duffing(0.02, 1.0, 0.3, 100)
    for x, p in ((np.array([0.4, -0.2]), 1.3), (np.array([1.5, 0.3]), 2.1)):
        (xa, Pa), (xb, Pb) = f(x, p, True), g(x, p, True)
        assert np.abs(xa - xb).max() < 1e-12 * np.abs(xb).max()
        assert np.abs(Pa - Pb).max() < 1e-11 * np.abs(Pb).max()
