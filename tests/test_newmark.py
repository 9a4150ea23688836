"""Implicit Newmark integrator (4.1)-(4.4) and its dissipative variants, against independent
references: closed-form solutions, the trapezoidal rule's exact discrete frequency, energy
conservation, closed-form spectral radii, scipy's Radau integrator, finite differences."""

import math
import warnings

import numpy as np

import fivebar
import pytest
from scipy.integrate import solve_ivp

from fivebar import load_params
from fivebar.numerics.schemes import HHT, GeneralizedAlpha, Newmark, UnstableParametersError, UnstableParametersWarning, amplification_matrix
from fivebar.numerics.systems import PeriodicStepData, System, consistent_acceleration
from fivebar.errors import InputError
from fivebar.numerics.newmark import NewtonConvergenceError, integrate

SCHEMES = [Newmark(), HHT(-0.1), HHT(-1 / 3), GeneralizedAlpha(0.8), GeneralizedAlpha(0.0)]
IDS = ["newmark", "hht-0.1", "hht-1/3", "ga-0.8", "ga-0.0"]


def _spd(rng, n, scale=1.0, shift=1.0):
    A = rng.standard_normal((n, n))
    return scale * (A @ A.T / n + shift * np.eye(n))


def _order(errors):
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


# --- manufactured closed-form solution, time-varying matrices --------------------------------
def _manufactured(time_varying):
    rng = np.random.default_rng(1)
    n = 3
    M0, K0 = _spd(rng, n), _spd(rng, n, 4.0)
    C0 = 0.05 * M0 + 0.01 * K0
    M1, K1 = 0.1 * _spd(rng, n, 1.0, 0.0), 0.5 * _spd(rng, n, 1.0, 0.0)
    w = np.array([1.3, 0.7, 2.1])

    def U(t):  # the exact solution, chosen: u = sin(w t + 0.3) exp(-0.1 t)
        return np.sin(w * t + 0.3) * np.exp(-0.1 * t)

    def dU(t):
        return (w * np.cos(w * t + 0.3) - 0.1 * np.sin(w * t + 0.3)) * np.exp(-0.1 * t)

    def ddU(t):
        s, c = np.sin(w * t + 0.3), np.cos(w * t + 0.3)
        return ((0.01 - w**2) * s - 0.2 * w * c) * np.exp(-0.1 * t)

    s = 1.0 if time_varying else 0.0
    Mf = lambda t: M0 + s * np.sin(0.9 * t) * M1  # noqa: E731
    Cf = lambda t: C0 * (1 + 0.3 * s * np.cos(1.1 * t))  # noqa: E731
    Kf = lambda t: K0 + s * np.cos(0.8 * t) * K1  # noqa: E731
    F = lambda t: Mf(t) @ ddU(t) + Cf(t) @ dU(t) + Kf(t) @ U(t)  # noqa: E731
    if time_varying:
        sysm = System(Mf, Cf, Kf, force=F)
    else:
        sysm = System(M0, C0, K0, force=F)
    return sysm, U, dU


@pytest.mark.parametrize("time_varying", [False, True], ids=["lti", "time-varying"])
@pytest.mark.parametrize("scheme", SCHEMES, ids=IDS)
def test_second_order_against_closed_form(scheme, time_varying):
    sysm, U, dU = _manufactured(time_varying)
    T = 6.0
    eu, ev = [], []
    for N in (200, 400, 800, 1600):
        r = integrate(sysm, U(0.0), dU(0.0), 0.0, T / N, N, scheme)
        eu.append(np.max(np.abs(r.u - np.array([U(t) for t in r.t]))))
        ev.append(np.max(np.abs(r.v - np.array([dU(t) for t in r.t]))))
    pu, pv = _order(eu), _order(ev)
    assert np.all((pu[-2:] > 1.9) & (pu[-2:] < 2.1)), (eu, pu)
    assert np.all((pv[-2:] > 1.9) & (pv[-2:] < 2.1)), (ev, pv)
    assert eu[-1] < 1e-3


# --- average acceleration: exact discrete frequency, period error, energy ---------------------
@pytest.mark.parametrize("steps_per_period", [6, 20, 100])
def test_trapezoidal_discrete_frequency_exact(steps_per_period):
    omega = 2 * math.pi * 1.7
    dt = 2 * math.pi / omega / steps_per_period
    r = integrate(System([[2.0]], [[0.0]], [[2.0 * omega**2]]), [1.0], [0.0], 0.0, dt, 500)
    phi = 2 * math.atan(omega * dt / 2)  # the trapezoidal rule's phase per step
    assert np.max(np.abs(r.u[:, 0] - np.cos(phi * np.arange(501)))) < 1e-11


@pytest.mark.parametrize("Omega", [0.05, 0.1, 0.2])
def test_period_elongation_small_step(Omega):
    omega = 3.0
    dt = Omega / omega
    r = integrate(System([[1.0]], [[0.0]], [[omega**2]]), [1.0], [0.0], 0.0, dt, 50)
    u = r.u[:, 0]
    # phase per step measured from the discrete solution: u_{k+1} + u_{k-1} = 2 cos(phi) u_k
    k = np.argmax(np.abs(u[1:-1])) + 1
    phi = math.acos((u[k + 1] + u[k - 1]) / (2 * u[k]))
    elongation = Omega / phi - 1
    assert elongation == pytest.approx(Omega**2 / 12, rel=0.01)


def test_energy_conserved_undamped_average_acceleration():
    rng = np.random.default_rng(7)
    n = 6
    M, K = _spd(rng, n), _spd(rng, n, 100.0, 0.1)
    u0, v0 = rng.standard_normal(n), rng.standard_normal(n)
    wmax = math.sqrt(max(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    r = integrate(System(M, np.zeros((n, n)), K), u0, v0, 0.0, 3.0 / wmax, 2000)
    E = 0.5 * np.einsum("ki,ij,kj->k", r.v, M, r.v) + 0.5 * np.einsum("ki,ij,kj->k", r.u, K, r.u)
    assert np.max(np.abs(E / E[0] - 1)) < 1e-12
    # while the dissipative schemes lose energy of the high mode
    r2 = integrate(System(M, np.zeros((n, n)), K), u0, v0, 0.0, 3.0 / wmax, 200,
                   GeneralizedAlpha(0.5))
    E2 = 0.5 * r2.v[-1] @ M @ r2.v[-1] + 0.5 * r2.u[-1] @ K @ r2.u[-1]
    assert E2 < 0.99 * E[0]


# --- numerical dissipation ----------------------------------------------------------------
def _one_step_map(scheme, Omega):
    """The integrator's one-step map of (u, v, a) for u'' + Omega^2 u = 0, dt = 1, column by
    column (the map is linear)."""
    sysm = System([[1.0]], [[0.0]], [[Omega**2]])
    cols = []
    for e in np.eye(3):
        r = integrate(sysm, [e[0]], [e[1]], 0.0, 1.0, 1, scheme, a0=[e[2]])
        cols.append([r.u[1, 0], r.v[1, 0], r.a[1, 0]])
    return np.array(cols).T


@pytest.mark.parametrize("scheme", SCHEMES, ids=IDS)
def test_amplification_matrix_is_the_integrators_one_step_map(scheme):
    for Omega, zeta in ((0.3, 0.0), (2.0, 0.05), (50.0, 0.3)):
        sysm = System([[1.0]], [[2 * zeta * Omega]], [[Omega**2]])
        cols = []
        for e in np.eye(3):
            r = integrate(sysm, [e[0]], [e[1]], 0.0, 1.0, 1, scheme, a0=[e[2]])
            cols.append([r.u[1, 0], r.v[1, 0], r.a[1, 0]])
        A = amplification_matrix(scheme, Omega, zeta)
        assert np.allclose(A, np.array(cols).T, rtol=1e-12, atol=1e-12)


def test_zero_steps_returns_initial_state_and_identity():
    sysm, *_ = _duffing()
    r = integrate(sysm, [0.1, 0.2], [0.3, 0.4], 0.0, 0.1, 0, sensitivity=True)
    assert r.u.shape == (1, 2) and np.array_equal(r.u[0], [0.1, 0.2])
    assert np.array_equal(r.monodromy, np.eye(4))


@pytest.mark.parametrize("alpha", [-0.05, -0.1, -0.2, -1 / 3])
def test_hht_spectral_radius_at_infinity(alpha):
    A = _one_step_map(HHT(alpha), 1e8)
    rho = max(abs(np.linalg.eigvals(A)))
    assert rho == pytest.approx((1 + alpha) / (1 - alpha), rel=2e-4)
    assert HHT(alpha).rho_infinity == pytest.approx((1 + alpha) / (1 - alpha))


@pytest.mark.parametrize("rho_inf", [0.0, 0.3, 0.8, 1.0])
def test_generalized_alpha_spectral_radius_at_infinity(rho_inf):
    # Chung & Hulbert's choice makes all three roots equal to -rho_inf as omega dt -> inf:
    # the characteristic polynomial tends to (lambda + rho_inf)^3.
    A = _one_step_map(GeneralizedAlpha(rho_inf), 1e6)
    assert np.allclose(np.poly(A), np.poly([-rho_inf] * 3), atol=1e-8)
    A2 = amplification_matrix(GeneralizedAlpha(rho_inf), 1e6)
    assert np.allclose(np.poly(A2), np.poly(A), atol=1e-12)


def test_average_acceleration_does_not_dissipate():
    for Omega in (0.1, 1.0, 10.0, 1e4):
        lam = np.linalg.eigvals(_one_step_map(Newmark(), Omega))
        lam = lam[np.argsort(-abs(lam))]
        assert abs(lam[0]) == pytest.approx(1.0, abs=1e-9)
        assert abs(lam[1]) == pytest.approx(1.0, abs=1e-9)
        # phase per step is the exact trapezoidal one
        assert abs(np.angle(lam[0])) == pytest.approx(2 * math.atan(Omega / 2), rel=1e-9)
    assert Newmark().rho_infinity == 1.0


@pytest.mark.parametrize("scheme", [HHT(-0.3), GeneralizedAlpha(0.5), GeneralizedAlpha(0.0)],
                         ids=str)
def test_dissipation_kills_stiff_mode_keeps_soft_mode(scheme):
    # two uncoupled oscillators, omega = 1 and 1e4, dt = 0.05: omega dt = 0.05 and 500
    M, K = np.eye(2), np.diag([1.0, 1e8])
    dt, N = 0.05, 200
    sysm = System(M, np.zeros((2, 2)), K)
    rn = integrate(sysm, [1.0, 1e-3], [0.0, 0.0], 0.0, dt, N)
    rd = integrate(sysm, [1.0, 1e-3], [0.0, 0.0], 0.0, dt, N, scheme)
    t = dt * N
    # the average-acceleration rule keeps the stiff mode's amplitude (energy conserved) ...
    En = 0.5 * rn.v[-1, 1] ** 2 + 0.5e8 * rn.u[-1, 1] ** 2
    assert En == pytest.approx(0.5e8 * 1e-6, rel=1e-9)
    # ... the dissipative scheme removes it at rate rho_inf per step (plus a Jordan factor)
    stiff = math.hypot(rd.u[-1, 1], rd.v[-1, 1] / 1e4)
    assert stiff < 1e-3 * max(scheme.rho_infinity, 0.1) ** (N / 2)
    # and the soft mode stays accurate (second order, small error)
    assert abs(rd.u[-1, 0] - math.cos(t)) < 1e-2


def test_printed_paper_pair_amplifies_free_oscillation():
    # errata E2: (varsigma, vartheta) = (0.25, 0.5) as printed makes a free oscillation grow
    p = load_params()
    with pytest.warns(UnstableParametersWarning, match="0.25, 0.5"):
        sc = Newmark(p.newmark_sigma, p.newmark_theta, allow_unstable=True)
    omega, S = 2 * math.pi, 100  # the paper's printed S (section 5)
    N = 20 * S
    Omega = omega / S
    r = integrate(System([[1.0]], [[0.0]], [[omega**2]]), [1.0], [0.0], 0.0, 1 / S, N, sc)
    amp = np.sqrt(r.u[:, 0] ** 2 + (r.v[:, 0] / omega) ** 2)
    # Newmark's algorithmic damping ratio for small Omega is (gamma - 1/2) Omega / 2 (Hughes,
    # The Finite Element Method, sec. 9.3): negative for gamma < 1/2, so the amplitude grows
    # like exp((1/2 - gamma) Omega^2 N / 2): by a factor 2.7 over 20 periods of S = 100 steps
    assert amp[-1] == pytest.approx(math.exp((0.5 - sc.gamma) * Omega**2 * N / 2), rel=0.02)
    assert amp[-1] > 2.5
    rs = integrate(System([[1.0]], [[0.0]], [[omega**2]]), [1.0], [0.0], 0.0, 1 / S, N)
    amp_s = np.sqrt(rs.u[:, 0] ** 2 + (rs.v[:, 0] / omega) ** 2)
    assert np.max(np.abs(amp_s - 1)) < 1e-12


# --- nonlinear and time-varying against scipy's Radau ------------------------------------------
def _duffing():
    M = np.array([[1.0, 0.0], [0.0, 0.5]])
    K = np.array([[2.0, -1.0], [-1.0, 1.0]])
    C = 0.05 * K + 0.02 * M
    k3 = np.array([1.5, 0.0])

    def nonlinear(u):
        return k3 * u**3, np.diag(3 * k3 * u**2)

    F = lambda t: np.array([0.6 * np.cos(1.2 * t), 0.0])  # noqa: E731
    return System(M, C, K, force=F, nonlinear=nonlinear), M, C, K, k3, F


def _radau(rhs, y0, T):
    sol = solve_ivp(rhs, (0.0, T), y0, method="Radau", rtol=1e-10, atol=1e-12, dense_output=True)
    assert sol.success
    return sol


@pytest.mark.parametrize("scheme", SCHEMES[:2] + SCHEMES[3:4], ids=["newmark", "hht-0.1", "ga-0.8"])
def test_duffing_against_radau(scheme):
    sysm, M, C, K, k3, F = _duffing()
    u0, v0, T = np.array([0.8, -0.2]), np.array([0.0, 0.3]), 10.0
    Minv = np.linalg.inv(M)

    def rhs(t, y):
        u, v = y[:2], y[2:]
        return np.concatenate([v, Minv @ (F(t) - C @ v - K @ u - k3 * u**3)])

    ref = _radau(rhs, np.concatenate([u0, v0]), T).sol(T)
    errs = []
    for N in (250, 500, 1000, 2000):
        r = integrate(sysm, u0, v0, 0.0, T / N, N, scheme, store="last")
        errs.append(np.max(np.abs(np.concatenate([r.u[-1], r.v[-1]]) - ref)))
    p = _order(errs)
    assert np.all((p[-2:] > 1.9) & (p[-2:] < 2.1)), (errs, p)
    assert errs[-1] < 1e-4


def test_newton_converges_quadratically_on_duffing():
    sysm, *_ = _duffing()
    r = integrate(sysm, [0.8, -0.2], [0.0, 0.3], 0.0, 0.05, 200)
    assert r.iterations.max() <= 4
    rm = integrate(sysm, [0.8, -0.2], [0.0, 0.3], 0.0, 0.05, 200, newton="modified")
    assert rm.iterations.mean() > r.iterations.mean()  # linear convergence takes more
    assert np.max(np.abs(rm.u - r.u)) < 1e-9


def test_mathieu_against_radau():
    # u'' + 0.1 u' + (1 + 0.4 cos 2t) u = cos(0.9 t)
    sysm = System([[1.0]], [[0.1]], lambda t: [[1 + 0.4 * np.cos(2 * t)]],
                  force=lambda t: [np.cos(0.9 * t)])
    T = 12.0

    def rhs(t, y):
        return [y[1], np.cos(0.9 * t) - 0.1 * y[1] - (1 + 0.4 * np.cos(2 * t)) * y[0]]

    ref = _radau(rhs, [0.5, 0.0], T)
    for scheme in (Newmark(), GeneralizedAlpha(0.6)):
        errs = []
        for N in (300, 600, 1200):
            r = integrate(sysm, [0.5], [0.0], 0.0, T / N, N, scheme)
            errs.append(np.max(np.abs(r.u[:, 0] - ref.sol(r.t)[0])))
        p = _order(errs)
        assert np.all((p > 1.9) & (p < 2.1)), (errs, p)


# --- failures -------------------------------------------------------------------------------
def test_newton_failure_names_time_residual_iterations():
    k3 = 1e6
    sysm = System([[1.0]], [[0.0]], [[1.0]],
                  nonlinear=lambda u: (k3 * u**3, np.diag(3 * k3 * u**2)))
    with pytest.raises(NewtonConvergenceError) as exc:
        integrate(sysm, [1.0], [0.0], 0.0, 0.01, 10, max_iter=1)
    msg = str(exc.value)
    assert "t = 0.01 s" in msg and "residual norm" in msg and "after 1 iterations" in msg
    assert exc.value.t == pytest.approx(0.01) and exc.value.iterations == 1
    assert exc.value.residual > 0
    assert isinstance(exc.value, RuntimeError)
    # with enough iterations the same step converges
    r = integrate(sysm, [1.0], [0.0], 0.0, 0.01, 10, max_iter=50)
    assert np.all(np.isfinite(r.u))


def test_unstable_parameters_raise():
    p = load_params()
    with pytest.raises(UnstableParametersError, match=r"\(0.25, 0.5\).*\(0.5, 0.25\)"):
        Newmark(p.newmark_sigma, p.newmark_theta)  # the paper's printed values (errata E2)
    with pytest.raises(UnstableParametersError, match="gamma=0.5, beta=0.1"):
        Newmark(0.5, 0.1)
    with pytest.raises(UnstableParametersError, match="beta=0.0 must be > 0"):
        Newmark(0.5, 0.0, allow_unstable=True)
    for bad in (0.1, -0.4, math.nan):
        with pytest.raises(UnstableParametersError, match="alpha"):
            HHT(bad)
    for bad in (-0.1, 1.5):
        with pytest.raises(UnstableParametersError, match="rho_inf"):
            GeneralizedAlpha(bad)
    assert isinstance(UnstableParametersError("x"), ValueError)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Newmark(0.6, 0.3025)  # on the boundary: stable, no warning
        Newmark(0.5, 0.25)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(dt=0.0), "dt = 0.0"),
        (dict(dt=-0.1), "dt = -0.1"),
        (dict(dt=math.inf), "dt = inf"),
        (dict(nsteps=-1), "nsteps = -1"),
        (dict(nsteps=2.5), "nsteps = 2.5"),
        (dict(u0=[math.nan, 0.0]), "finite"),
        (dict(v0=[0.0]), "v0 has shape"),
        (dict(u0=[0.0, 0.0, 0.0], v0=[0.0, 0.0, 0.0]), r"M\(t0\) has shape"),
        (dict(a0=[0.0]), "a0 has shape"),
        (dict(max_iter=0), "max_iter = 0"),
        (dict(newton="quasi"), "newton = 'quasi'"),
        (dict(sensitivity="x"), "sensitivity = 'x'"),
        (dict(sensitivity="uv", a0=[0.0, 0.0]), "a0=None"),
    ],
)
def test_bad_input(kwargs, match):
    args = dict(u0=[0.0, 0.0], v0=[0.0, 0.0], t0=0.0, dt=0.1, nsteps=3)
    args.update(kwargs)
    sysm = System(np.eye(2), np.zeros((2, 2)), np.eye(2))
    with pytest.raises(fivebar.FivebarError, match=match):
        integrate(sysm, **args)


def test_system_and_step_data_validation():
    with pytest.raises(ValueError, match="square"):
        System(np.ones((2, 3)), np.eye(2), np.eye(2))
    with pytest.raises(ValueError, match="force has shape"):
        System(np.eye(2), np.eye(2), np.eye(2), force=[1.0])
    sysm = System(np.eye(2), np.zeros((2, 2)), lambda t: np.eye(2) * (2 + np.cos(t)))
    sd = PeriodicStepData.from_system(sysm, 0.0, 2 * np.pi, 10)
    with pytest.raises(ValueError, match="differs from step_data.dt"):
        integrate(sysm, [1, 0], [0, 0], 0.0, 0.1, 5, step_data=sd)
    with pytest.raises(ValueError, match="not a time point"):
        integrate(sysm, [1, 0], [0, 0], 0.1, sd.dt, 5, step_data=sd)


def test_singular_tangent_is_reported():
    sysm = System(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)))
    with pytest.raises(NewtonConvergenceError, match="singular"):
        integrate(sysm, [0.0], [0.0], 0.0, 0.1, 2, a0=[0.0])
    with pytest.raises(ValueError, match="mass matrix"):
        integrate(sysm, [0.0], [0.0], 0.0, 0.1, 2)


# --- periodic step data: same answers, cached factorisations ----------------------------------
def _periodic_nonlinear(n=4, seed=3):
    rng = np.random.default_rng(seed)
    M0, K0 = _spd(rng, n), _spd(rng, n, 10.0)
    K1 = _spd(rng, n, 2.0, 0.0)
    C = 0.02 * M0 + 0.01 * K0
    Om = 2.0  # period pi
    k3 = 5.0 * rng.random(n)

    def nonlinear(u):
        return k3 * u**3, np.diag(3 * k3 * u**2)

    return System(M0, C, lambda t: K0 + np.cos(Om * t) * K1,
                  force=lambda t: np.sin(Om * t) * np.ones(n), nonlinear=nonlinear), np.pi


@pytest.mark.parametrize("linear", [True, False], ids=["linear", "nonlinear"])
@pytest.mark.parametrize("scheme", [Newmark(), GeneralizedAlpha(0.7)], ids=["newmark", "ga"])
def test_step_data_matches_direct_evaluation(linear, scheme):
    sysm, T = _periodic_nonlinear()
    if linear:
        sysm.nonlinear = None
    S = 40
    sd = PeriodicStepData.from_system(sysm, 0.0, T, S)
    u0, v0 = 0.1 * np.ones(4), np.zeros(4)
    t0 = 7 * T / S  # start inside the period
    r1 = integrate(sysm, u0, v0, t0, T / S, 3 * S + 5, scheme, sensitivity=True)
    r2 = integrate(sysm, u0, v0, t0, T / S, 3 * S + 5, scheme, step_data=sd, sensitivity=True)
    assert np.max(np.abs(r1.u - r2.u)) < 1e-12 * np.max(np.abs(r1.u))
    assert np.max(np.abs(r1.monodromy - r2.monodromy)) < 1e-10 * np.max(np.abs(r1.monodromy))
    if linear:  # the linear tangents were factorised once per step point and reused
        # (one cache for both loops)
        assert len(sd._lu_factors()) == 1
        assert all(next(iter(sd._lu_factors().values()))[2])


def test_time_invariant_fast_path_matches_general_path():
    rng = np.random.default_rng(5)
    n = 5
    M, K = _spd(rng, n), _spd(rng, n, 30.0)
    C = 0.01 * K
    F = lambda t: np.sin(3 * t) * np.arange(1, n + 1)  # noqa: E731
    a = integrate(System(M, C, K, force=F), np.ones(n), np.zeros(n), 0.0, 0.01, 300)
    b = integrate(System(lambda t: M, lambda t: C, lambda t: K, force=F), np.ones(n), np.zeros(n),
                  0.0, 0.01, 300)
    assert np.max(np.abs(a.u - b.u)) < 1e-12 * np.max(np.abs(a.u))


def test_consistent_acceleration_satisfies_equation_every_step():
    sysm, *_ = _duffing()
    r = integrate(sysm, [0.8, -0.2], [0.0, 0.3], 0.0, 0.05, 100, rtol=1e-12)
    for k in (0, 37, 100):
        a = consistent_acceleration(sysm, r.t[k], r.u[k], r.v[k])
        assert np.max(np.abs(a - r.a[k])) < 1e-9 * max(1.0, np.max(np.abs(a)))


# --- sensitivity (monodromy) ---------------------------------------------------------------
@pytest.mark.parametrize("scheme", [Newmark(), HHT(-0.2), GeneralizedAlpha(0.6)],
                         ids=["newmark", "hht", "ga"])
@pytest.mark.parametrize("state", ["uv", "uva"])
@pytest.mark.parametrize("newton", ["full", "modified"])
def test_sensitivity_matches_finite_differences(scheme, state, newton):
    sysm, T = _periodic_nonlinear(n=3, seed=11)
    n, S = 3, 30
    u0 = np.array([0.3, -0.2, 0.25])
    v0 = np.array([0.1, 0.4, -0.3])
    a0 = consistent_acceleration(sysm, 0.0, u0, v0) + (0.2 if state == "uva" else 0.0)
    kw = dict(rtol=1e-14, xtol=1e-15, newton=newton, max_iter=200, store="last")

    def final(x):
        if state == "uv":
            r = integrate(sysm, x[:n], x[n:], 0.0, T / S, S, scheme, **kw)
            return np.concatenate([r.u[-1], r.v[-1]])
        r = integrate(sysm, x[:n], x[n:2 * n], 0.0, T / S, S, scheme, a0=x[2 * n:], **kw)
        return np.concatenate([r.u[-1], r.v[-1], r.a[-1]])

    x0 = np.concatenate([u0, v0] + ([a0] if state == "uva" else []))
    if state == "uv":
        r = integrate(sysm, u0, v0, 0.0, T / S, S, scheme, sensitivity="uv", **kw)
    else:
        r = integrate(sysm, u0, v0, 0.0, T / S, S, scheme, a0=a0, sensitivity="uva", **kw)
    assert r.monodromy.shape == (x0.size, x0.size) and r.state == state
    h = 1e-5
    J = np.empty((x0.size, x0.size))
    for i in range(x0.size):
        e = np.zeros(x0.size)
        e[i] = h
        J[:, i] = (final(x0 + e) - final(x0 - e)) / (2 * h)
    assert np.max(np.abs(r.monodromy - J)) < 1e-6 * np.max(np.abs(J))


def _mathieu2(delta, eps, zeta, T):
    """Two coupled damped Mathieu oscillators, K(t) periodic with period T."""
    M = np.diag([1.0, 2.0])
    K0 = np.array([[delta, -0.3], [-0.3, 2.0 * delta + 1.0]])
    K1 = np.array([[eps, 0.0], [0.0, 0.5 * eps]])
    C = 2 * zeta * np.sqrt(delta) * M
    Om = 2 * np.pi / T
    return M, C, (lambda t: K0 + np.cos(Om * t) * K1)


def _floquet_reference(M, C, Kf, T):
    n = M.shape[0]
    Minv = np.linalg.inv(M)

    def rhs(t, y):
        Y = y.reshape(2 * n, 2 * n)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ Kf(t), -Minv @ C]])
        return (A @ Y).ravel()

    sol = solve_ivp(rhs, (0.0, T), np.eye(2 * n).ravel(), method="DOP853", rtol=1e-12, atol=1e-14)
    return sol.y[:, -1].reshape(2 * n, 2 * n)


def _match(lam, ref):
    lam, ref = list(lam), list(ref)
    err = 0.0
    for z in ref:
        k = int(np.argmin([abs(z - w) for w in lam]))
        err = max(err, abs(z - lam.pop(k)))
    return err


@pytest.mark.parametrize("delta, eps", [(0.8, 0.5), (1.0, 0.5)],
                         ids=["stable", "parametric-resonance"])
def test_floquet_multipliers_of_damped_mathieu(delta, eps):
    T = np.pi
    M, C, Kf = _mathieu2(delta, eps, 0.02, T)
    ref = np.linalg.eigvals(_floquet_reference(M, C, Kf, T))
    sysm = System(M, C, Kf)
    errs = []
    for S in (200, 400, 800):
        r = integrate(sysm, np.zeros(2), np.zeros(2), 0.0, T / S, S, sensitivity="uv")
        errs.append(_match(np.linalg.eigvals(r.monodromy), ref))
    assert errs[-1] < 2e-4
    assert 3.5 < errs[0] / errs[1] < 4.5 and 3.5 < errs[1] / errs[2] < 4.5
    if delta == 1.0:  # mode 1 at 0.96 rad/s, K(t) at 2 rad/s: principal parametric resonance
        assert max(abs(ref)) > 1.2
    else:
        assert max(abs(ref)) < 1.0
    # a dissipative scheme: the 2n largest multipliers of its 3n-state map are the physical ones
    r = integrate(sysm, np.zeros(2), np.zeros(2), 0.0, T / 800, 800, GeneralizedAlpha(0.8),
                  sensitivity=True)
    assert r.monodromy.shape == (6, 6)
    lam = np.linalg.eigvals(r.monodromy)
    lam = lam[np.argsort(-abs(lam))]
    assert _match(lam[:4], ref) < 1e-3 and max(abs(lam[4:])) < 1e-3


def _phase_system(Om):
    """A periodic system whose matrices are functions of the phase Omega t and whose force
    scales with Omega^2 (as the linkage's at a crank speed), with a cubic spring."""
    rng = np.random.default_rng(8)
    n = 4
    M0, K0 = _spd(rng, n), _spd(rng, n, 20.0)
    M1, K1 = 0.2 * _spd(rng, n, 1.0, 0.0), _spd(rng, n, 3.0, 0.0)
    b = np.arange(1.0, n + 1)
    return System(lambda t: M0 + np.sin(Om * t) * M1, lambda t: 0.02 * (K0 + np.cos(Om * t) * K1),
                  lambda t: K0 + np.cos(Om * t) * K1, force=lambda t: Om**2 * np.sin(Om * t) * b,
                  nonlinear=lambda u: (50.0 * u**3, np.diag(150.0 * u**2))), 2 * np.pi / Om


def test_step_data_with_force_is_the_step_data_of_the_rescaled_system():
    """``with_force`` keeps M, C, K (shared) and takes the force and period of another time
    scale: it must march as the step data sampled afresh from the system at that scale, with
    LU caches of its own; a bad force or period is refused by name."""
    S = 32
    sys1, T1 = _phase_system(1.0)
    sys2, T2 = _phase_system(2.5)
    sd1 = PeriodicStepData.from_system(sys1, 0.0, T1, S)
    fresh = PeriodicStepData.from_system(sys2, 0.0, T2, S)
    u0, v0 = 0.05 * np.ones(4), np.zeros(4)
    integrate(sys1, u0, v0, 0.0, T1 / S, S, step_data=sd1, newton="modified")  # sd1's arrays and LU used first
    sd2 = sd1.with_force(sd1.F * 2.5**2, T2)
    assert np.shares_memory(sd2.M, sd1.M) and np.shares_memory(sd2.K, sd1.K)
    assert (sd2.period, sd2.dt, sd2.steps, sd2.n) == (T2, T2 / S, S, 4)
    for X, Y in ((sd2.M, fresh.M), (sd2.C, fresh.C), (sd2.K, fresh.K), (sd2.F, fresh.F)):
        assert np.allclose(X, Y, rtol=1e-12, atol=1e-12 * np.abs(Y).max())
    for newton in ("modified", "full"):
        a = integrate(sys2, u0, v0, 0.0, T2 / S, 2 * S, step_data=sd2, newton=newton, sensitivity=True)
        b = integrate(sys2, u0, v0, 0.0, T2 / S, 2 * S, step_data=fresh, newton=newton, sensitivity=True)
        assert np.max(np.abs(a.u - b.u)) < 1e-9 * np.max(np.abs(b.u))
        assert np.max(np.abs(a.monodromy - b.monodromy)) < 1e-9 * np.max(np.abs(b.monodromy))
    assert len(sd2._lu_factors()) == 1 and len(sd1._lu_factors()) == 1  # one cache each (dt differs)
    assert next(iter(sd2._lu_factors().values()))[0] is not next(iter(sd1._lu_factors().values()))[0]
    F = np.array(sd1.F)
    F[3, 1] = np.nan
    with pytest.raises(InputError, match=r"(?s)F = .* every entry must be finite"):
        sd1.with_force(F, T2)
    with pytest.raises(InputError, match=r"F has shape \(32, 3\)"):
        sd1.with_force(np.zeros((S, 3)), T2)
    with pytest.raises(InputError, match="period = -1.0"):
        sd1.with_force(sd1.F, -1.0)


def test_full_newton_on_a_nonlinear_system_makes_no_linear_tangent_cache():
    """Full Newton factorises the consistent tangent and never the linear one: the step data
    gets no (S, n, n) LU cache from it; modified Newton gets one (filled at every step point)."""
    S = 24
    sysm, T = _phase_system(1.0)
    u0, v0 = 0.05 * np.ones(4), np.zeros(4)
    sd = PeriodicStepData.from_system(sysm, 0.0, T, S)
    full = integrate(sysm, u0, v0, 0.0, T / S, S, step_data=sd, newton="full")
    assert sd._lu_factors() == {}
    modified = integrate(sysm, u0, v0, 0.0, T / S, S, step_data=sd, newton="modified")
    assert len(sd._lu_factors()) == 1 and all(next(iter(sd._lu_factors().values()))[2])
    assert np.max(np.abs(full.u - modified.u)) < 1e-8 * np.max(np.abs(full.u))


def test_the_memory_check_reads_the_system_only_for_large_requests(monkeypatch):
    """``errors.memory`` compares a request with the available memory only from CHECKED_BYTES
    up (a period of a continuation asks for kilobytes, and reading /proc/meminfo took about 0.1
    ms of each); a request above what is available is refused by name, with its size."""
    from fivebar import errors

    reads = []
    monkeypatch.setattr(errors, "available_memory", lambda: reads.append(1) or 2**30)
    errors.memory(errors.CHECKED_BYTES - 1, "a small array", "none")
    assert not reads
    r = integrate(System([[1.0]], [[0.0]], [[1.0]]), [1.0], [0.0], 0.0, 0.1, 100)  # 100 steps stored
    assert r.u.shape == (101, 1) and not reads
    with pytest.raises(errors.ResourceError, match=r"the big array need about 2 GiB.*remedy"):
        errors.memory(2 * 2**30, "the big array", "remedy")
    assert reads
