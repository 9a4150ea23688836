"""Multiple scales (3.4)-(3.7): checked on textbook systems against closed forms (Nayfeh & Mook
1979, sections 4.1, 4.2, 5.x) and against numerical integration (periodic orbits by shooting
with scipy's DOP853, Floquet multipliers from the fundamental matrix, the project's Newmark)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipk

from fivebar.errors import FivebarError
from fivebar.numerics.modal_equations import Harmonic, ModalSystem, MultiscaleError, Parametric
from fivebar.numerics.multiscale import first_approximation, modulation_equations, particular_amplitudes
from fivebar.numerics.newmark import NewtonConvergenceError
from fivebar.numerics.newton import newton
from fivebar.numerics.response_curves import (
    backbone,
    frequency_response,
    parametric_response,
    parametric_transition_curves,
    primary_resonance,
)

IVP = dict(method="DOP853", rtol=1e-12, atol=1e-13)


# --- independent numerical references ---------------------------------------------------------
def periodic_orbit(acc, jac, T, y0, n=1, samples=1024):
    """Periodic orbit of u'' = acc(t, u, v) by shooting (Newton on the period map).

    Returns (times, u samples (n, samples), Floquet multipliers)."""

    def f(t, Y):
        u, v, P = Y[:n], Y[n : 2 * n], Y[2 * n :].reshape(2 * n, 2 * n)
        Ju, Jv = jac(t, u, v)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [Ju, Jv]])
        return np.concatenate([v, acc(t, u, v), (A @ P).ravel()])

    y = np.array(y0, float)
    Y0 = lambda y: np.concatenate([y, np.eye(2 * n).ravel()])  # noqa: E731
    for _ in range(40):
        s = solve_ivp(f, (0, T), Y0(y), **IVP)
        Phi = s.y[2 * n :, -1].reshape(2 * n, 2 * n)
        dy = np.linalg.solve(Phi - np.eye(2 * n), y - s.y[: 2 * n, -1])
        y = y + dy
        if np.max(np.abs(dy)) < 1e-12 * max(1.0, np.max(np.abs(y))):
            break
    else:
        raise AssertionError("shooting did not converge")
    s = solve_ivp(f, (0, T), Y0(y), dense_output=True, **IVP)
    t = np.linspace(0, T, samples + 1)[:-1]
    return t, s.sol(t)[:n], np.linalg.eigvals(s.y[2 * n :, -1].reshape(2 * n, 2 * n))


def harmonic(t, u, Om):
    """Complex Fourier coefficient c of u ~ Re(c e^{i Om t}) over whole periods."""
    return 2 * np.mean(u * np.exp(-1j * Om * t))


def duffing(eps, w=1.0, mu=0.25, al=1.0):
    """u'' + w^2 u + 2 eps mu u' + eps al u^3 = ... in the library's form (eps absorbed)."""
    return ModalSystem([w], [eps * mu / w], gamma=np.full((1, 1, 1, 1), -eps * al))


# --- (3.7): the particular solution -----------------------------------------------------------
def two_mode_harmonics():
    return [
        Harmonic(0.0, [0.3, -0.2], [0.0, np.pi]),  # the constant load P0
        Harmonic(0.7, [1.0, 0.5], [0.3, -1.1]),
        Harmonic(5.2, [-2.0, 0.8], 1.4),
    ]


def test_particular_solution_solves_the_linear_equation():
    w = np.array([1.3, 3.1])
    sys0 = ModalSystem(w)
    hs = two_mode_harmonics()
    t = np.linspace(0.0, 20.0, 2001)
    eta, eta_dot = first_approximation(sys0, t, hs)
    # residual of eta'' + w^2 eta = sum F cos(Omega t + tau), eta'' by central differences
    h = 1e-4
    ep, em = first_approximation(sys0, t + h, hs)[0], first_approximation(sys0, t - h, hs)[0]
    force = sum(hh.amplitude[:, None] * np.cos(hh.frequency * t + hh.phase[:, None]) for hh in hs)
    res = (ep - 2 * eta + em) / h**2 + w[:, None] ** 2 * eta - force
    assert np.max(np.abs(res)) < 1e-5 * np.max(np.abs(force))
    assert np.max(np.abs(eta_dot - (ep - em) / (2 * h))) < 1e-6
    # the static part (Omega = 0) is P0 cos(tau) / w^2
    static, _ = first_approximation(sys0, t, hs[:1])
    assert np.allclose(static, np.array([[0.3 / w[0] ** 2], [0.2 / w[1] ** 2]]), rtol=1e-14)


def test_particular_solution_approaches_the_damped_exact_one():
    w, hs = np.array([1.3, 3.1]), two_mode_harmonics()
    t = np.linspace(0.0, 30.0, 601)
    errs = []
    for z in (1e-2, 1e-3):
        eta, _ = first_approximation(ModalSystem(w, [z, z]), t, hs)
        exact = sum(
            np.real(hh.amplitude[:, None] * np.exp(1j * (hh.frequency * t + hh.phase[:, None]))
                    / (w[:, None] ** 2 - hh.frequency**2 + 2j * z * w[:, None] * hh.frequency))
            for hh in hs
        )
        errs.append(np.max(np.abs(eta - exact)))
    assert errs[0] < 0.02 * np.max(np.abs(eta))
    assert 7 < errs[0] / errs[1] < 13  # the error is O(zeta): damping is an O(eps) term


def test_printed_37_amplitude_is_half_the_response():
    """(3.7) as printed, Lambda cos(...) with |Lambda| = F / (2 (w^2 - Omega^2)), misses a 2."""
    w, Om, F, tau = 2.0, 0.9, 1.5, 0.4
    Lam = particular_amplitudes(ModalSystem([w]), [Harmonic(Om, [F], tau)])[0, 0]
    printed_gamma = F / (2 * (w**2 - Om**2))
    assert abs(Lam) == pytest.approx(printed_gamma)  # the complex amplitude is the printed Gamma
    t = np.linspace(0, 10, 500)
    printed = printed_gamma * np.cos(Om * t + tau)  # the printed real form
    residual = (w**2 - Om**2) * printed - F * np.cos(Om * t + tau)
    assert np.max(np.abs(residual)) == pytest.approx(F / 2, rel=1e-3)  # not a solution
    read = 2 * np.real(Lam * np.exp(1j * Om * t))  # the reading: Lambda e^{i Om t} + c.c.
    assert np.max(np.abs((w**2 - Om**2) * read - F * np.cos(Om * t + tau))) < 1e-12


# --- Duffing primary resonance: closed forms --------------------------------------------------
def test_duffing_frequency_response_matches_nayfeh_mook():
    eps, w, mu, al, k = 0.1, 1.0, 0.25, 1.0, 1.0
    sys1 = duffing(eps, w, mu, al)
    n_three = 0
    for sig in np.linspace(-1.0, 3.0, 41):
        branches = primary_resonance(sys1, 0, Harmonic(w + eps * sig, [eps * k]))
        # independent count: sign changes of N&M (4.1.20) on a fine grid of a
        a_grid = np.linspace(1e-4, 3.0, 30001)
        g = a_grid**2 * (mu**2 + (sig - 3 * al * a_grid**2 / (8 * w)) ** 2) - k**2 / (4 * w**2)
        assert len(branches) == np.count_nonzero(np.diff(np.sign(g)))
        n_three += len(branches) == 3
        for b in branches:
            a, gam = b.amplitude[0], -b.theta0[0]  # u = a cos(Omega t - gamma) in N&M
            assert mu * a == pytest.approx(k / (2 * w) * np.sin(gam), abs=1e-10)  # (4.1.19)
            assert (sig - 3 * al * a**2 / (8 * w)) * a == pytest.approx(-k / (2 * w) * np.cos(gam), abs=1e-10)
            # N&M (4.1.30): stable iff mu^2 + (sig - 3 al a^2/8w)(sig - 9 al a^2/8w) > 0
            crit = mu**2 + (sig - 3 * al * a**2 / (8 * w)) * (sig - 9 * al * a**2 / (8 * w))
            assert b.stable == (crit > 0)
        if len(branches) == 3:
            assert [b.stable for b in branches] == [True, False, True]
    assert n_three >= 3  # the sweep crosses the bistable range


def test_frequency_response_curve_and_backbone():
    eps, w, mu, al, k = 0.1, 1.0, 0.25, 1.0, 1.0
    sys1 = duffing(eps, w, mu, al)
    sig = eps * np.array([0.0, 1.0, 2.5])
    fr = frequency_response(sys1, 0, eps * k, sig)
    assert np.isnan(fr.amplitude[0, 1:]).all() and np.isfinite(fr.amplitude[1]).all()
    assert fr.stable[1].tolist() == [True, False, True]
    # linear limit: the peak of a damped linear oscillator, k / (2 w mu)
    lin = frequency_response(ModalSystem([w], [eps * mu / w]), 0, eps * k, [0.0])
    assert lin.amplitude[0, 0] == pytest.approx(k / (2 * w * mu), rel=1e-12)
    a = np.linspace(0.1, 2.0, 5)
    assert backbone(sys1, 0, a) == pytest.approx(w + eps * 3 * al * a**2 / (8 * w), rel=1e-14)


def test_backbone_against_exact_duffing_period():
    """Exact frequency of u'' + w^2 u + al u^3 = 0 (complete elliptic integral): the backbone
    error is O(eps^2) while the correction is O(eps)."""
    w, al, a = 1.0, 1.0, 1.0
    errs = []
    for eps in (0.1, 0.01):
        m = eps * al * a**2 / (2 * (w**2 + eps * al * a**2))
        exact = np.pi * np.sqrt(w**2 + eps * al * a**2) / (2 * ellipk(m))
        errs.append(abs(backbone(duffing(eps, w, 0.0, al), 0, a) - exact))
        assert errs[-1] < 0.1 * (exact - w)
    assert errs[0] / errs[1] > 50


def free_frequency(acc, u0, n_cycles=1):
    """Frequency and first-harmonic amplitude of a free oscillation of u'' = acc(u) from
    u(0) = u0 (a turning point): the period is twice the time to the next turning point."""
    ev = lambda t, y: y[1]  # noqa: E731
    ev.direction = 1.0
    ev.terminal = True
    s = solve_ivp(lambda t, y: [y[1], acc(y[0])], (0, 100), [u0, 0.0], events=ev, **IVP)
    T = 2 * s.t_events[0][0]
    s = solve_ivp(lambda t, y: [y[1], acc(y[0])], (0, T), [u0, 0.0], dense_output=True, **IVP)
    t = np.linspace(0, T, 2049)[:-1]
    return 2 * np.pi / T, abs(harmonic(t, s.sol(t)[0], 2 * np.pi / T))


def test_quadratic_correction_single_mode():
    """u'' + w^2 u = d u^2 + g u^3: N&M (4.2.20) w_NL = w - (9 g w^2 + 10 d^2) a^2 / (24 w^3)."""
    w, d, g = 1.0, 1.0, 0.5
    sys1 = ModalSystem([w], delta=np.full((1, 1, 1), d), gamma=np.full((1, 1, 1, 1), g))
    errs = []
    for u0 in (0.1, 0.05):
        wn, a = free_frequency(lambda u: -(w**2) * u + d * u**2 + g * u**3, u0)
        nm = w - (9 * g * w**2 + 10 * d**2) * a**2 / (24 * w**3)
        assert backbone(sys1, 0, a) == pytest.approx(nm, rel=1e-13)
        errs.append(abs(backbone(sys1, 0, a) - wn))
        assert errs[-1] < 0.05 * abs(wn - w)
        # first order alone misses the quadratic softening
        first = backbone(sys1, 0, a, quadratic_correction=False)
        assert abs(first - wn) > 5 * errs[-1]
    assert errs[0] / errs[1] > 10  # O(a^4)


def test_quadratic_correction_two_modes():
    """eta1'' + w1^2 eta1 = b eta1 eta2, eta2'' + w2^2 eta2 = c eta1^2: the passive mode 2
    softens mode 1 by b c [2/w2^2 + 1/(w2^2 - 4 w1^2)] (3/4) a^2 / (2 w1); checked against the
    numerically integrated frequency of mode 1."""
    w1, w2, b, c = 1.0, 1.7, 0.8, 0.6
    delta = np.zeros((2, 2, 2))
    delta[0, 0, 1] = delta[0, 1, 0] = b / 2
    delta[1, 0, 0] = c
    sys2 = ModalSystem([w1, w2], delta=delta)
    term = modulation_equations(sys2).coefficients(0)
    assert term.cubic.real == pytest.approx(b * c * (2 / w2**2 + 1 / (w2**2 - 4 * w1**2)) / 3, rel=1e-13)
    a = 0.1
    eta2_0 = c * a**2 / 2 * (1 / w2**2 + 1 / (w2**2 - 4 * w1**2))  # the slaved mode at t = 0

    def rhs(t, y):
        return [y[2], y[3], -(w1**2) * y[0] + b * y[0] * y[1], -(w2**2) * y[1] + c * y[0] ** 2]

    ev = lambda t, y: y[0]  # noqa: E731
    ev.direction = 1.0
    s = solve_ivp(rhs, (0, 60 * 2 * np.pi), [a, eta2_0, 0, 0], events=ev, **IVP)
    up = s.t_events[0]
    wn = 2 * np.pi * (len(up) - 1) / (up[-1] - up[0])
    predicted = backbone(sys2, 0, a)
    assert abs(predicted - wn) < 0.05 * abs(w1 - wn)
    assert abs(backbone(sys2, 0, a, quadratic_correction=False) - wn) > 0.9 * abs(w1 - wn)


# --- hard excitation: non-resonant, super- and subharmonic (N&M 4.1.4-4.1.6) ------------------
def test_hard_excitation_shifts_the_frequency():
    w, al, K, Om, eps = 1.0, 1.0, 0.5, 2.7, 0.1
    sys1 = duffing(eps, w, 0.0, al)
    Lam = K / (2 * (w**2 - Om**2))
    a = np.array([0.2, 0.7])
    # N&M (4.1.38): beta' = 3 al a^2 / (8 w) + 3 al Lam^2 / w
    expected = w + eps * (3 * al * a**2 / (8 * w) + 3 * al * Lam**2 / w)
    assert backbone(sys1, 0, a, harmonics=[Harmonic(Om, [K])]) == pytest.approx(expected, rel=1e-13)


def test_super_and_subharmonic_secular_terms():
    w, al, K, eps = 1.0, 1.0, 0.5, 0.1
    sys1 = duffing(eps, w, 0.0, al)
    # superharmonic 3 Omega ~ w: -eps al Lam^3 e^{i sigma t} (N&M 4.1.44)
    Om = (w + 0.02) / 3
    Lam = K / (2 * (w**2 - Om**2))
    terms = {t.factors: t for t in modulation_equations(sys1, [Harmonic(Om, [K])]).terms}
    assert terms["1"].coefficient == pytest.approx(-eps * al * Lam**3, rel=1e-13)
    assert terms["1"].detuning == pytest.approx(3 * Om - w, rel=1e-12)
    assert terms["A1"].coefficient == pytest.approx(-6 * eps * al * Lam**2, rel=1e-13)
    # subharmonic Omega ~ 3 w: -3 eps al Lam conj(A)^2 e^{i sigma t} (N&M 4.1.58)
    Om = 3 * w + 0.03
    Lam = K / (2 * (w**2 - Om**2))
    terms = {t.factors: t for t in modulation_equations(sys1, [Harmonic(Om, [K])]).terms}
    assert terms["conj(A1) conj(A1)"].coefficient == pytest.approx(-3 * eps * al * Lam, rel=1e-13)
    assert terms["conj(A1) conj(A1)"].detuning == pytest.approx(Om - 3 * w, rel=1e-12)


def test_superharmonic_response_against_numerical_integration():
    """Hard excitation at Omega ~ w/3: the free part locks at 3 Omega; its amplitude from the
    slow flow (found automatically among the secular terms) against the periodic orbit."""
    w, mu, al, K = 1.0, 0.25, 1.0, 1.0
    errs = []
    for eps in (0.1, 0.03):
        Om = (w + 0.3 * eps) / 3
        sys1 = duffing(eps, w, mu, al)
        flow = modulation_equations(sys1, [Harmonic(Om, [K])])
        st = flow.steady_state()
        assert st.nu[0] == pytest.approx(3 * Om - w)
        acc = lambda t, u, v: -2 * eps * mu * v - w**2 * u - eps * al * u**3 + K * np.cos(Om * t)  # noqa: E731
        jac = lambda t, u, v: (np.array([[-(w**2) - 3 * eps * al * u[0] ** 2]]), np.array([[-2 * eps * mu]]))  # noqa: E731
        y0 = [st.eta(0.0)[0], st.eta_dot(0.0)[0]]
        t, u, mult = periodic_orbit(acc, jac, 2 * np.pi / Om, y0)
        assert np.max(np.abs(mult)) < 1 and st.stable
        c3 = abs(harmonic(t, u[0], 3 * Om))
        errs.append(abs(st.amplitude[0] - c3) / c3)
        # forced part: F / (w^2 - Omega^2), the particular solution (3.7)
        assert abs(harmonic(t, u[0], Om)) == pytest.approx(K / (w**2 - Om**2), rel=3 * eps)
    assert errs[0] < 0.15 and errs[1] < errs[0] / 2.5


# --- Duffing primary resonance: numerical steady state ----------------------------------------
EPS = (0.1, 0.03, 0.01)


def duffing_orbit(eps, w, mu, al, k, sig, y0):
    Om = w + eps * sig
    acc = lambda t, u, v: -2 * eps * mu * v - w**2 * u - eps * al * u**3 + eps * k * np.cos(Om * t)  # noqa: E731
    jac = lambda t, u, v: (np.array([[-(w**2) - 3 * eps * al * u[0] ** 2]]), np.array([[-2 * eps * mu]]))  # noqa: E731
    return periodic_orbit(acc, jac, 2 * np.pi / Om, y0)


def test_primary_resonance_against_numerical_steady_state():
    """All three branches (sigma in the bistable range): amplitude error of the first
    approximation O(eps); stability as the Floquet multipliers of the numerical orbit."""
    w, mu, al, k, sig = 1.0, 0.25, 1.0, 1.0, 1.0
    err = np.zeros((len(EPS), 3))
    for i, eps in enumerate(EPS):
        branches = primary_resonance(duffing(eps, w, mu, al), 0, Harmonic(w + eps * sig, [eps * k]))
        assert len(branches) == 3
        for j, b in enumerate(branches):
            y0 = [b.eta(0.0)[0], b.eta_dot(0.0)[0]]
            t, u, mult = duffing_orbit(eps, w, mu, al, k, sig, y0)
            assert (np.max(np.abs(mult)) < 1) == b.stable
            err[i, j] = abs(abs(harmonic(t, u[0], w + eps * sig)) - b.amplitude[0]) / b.amplitude[0]
            # phase of the first harmonic: u ~ a cos(Omega t + theta0)
            assert abs(np.angle(harmonic(t, u[0], w + eps * sig)) - b.theta0[0]) < 3 * eps
    assert np.all(err < 1.0 * np.array(EPS)[:, None])
    assert np.all(err[1:] < err[:-1] / 2.5)  # shrinks with eps (ratio of eps: 3.3)


def test_primary_resonance_against_newmark():
    """The same steady state by the project's Newmark integrator (shooting with its monodromy)."""
    from fivebar.numerics.newmark import integrate
    from fivebar.numerics.systems import System

    eps, w, mu, al, k, sig, S = 0.1, 1.0, 0.25, 1.0, 1.0, 1.0, 500
    Om = w + eps * sig
    T = 2 * np.pi / Om
    system = System(
        [[1.0]], [[2 * eps * mu]], [[w**2]], force=lambda t: [eps * k * np.cos(Om * t)],
        nonlinear=lambda u: (eps * al * u**3, np.array([[3 * eps * al * u[0] ** 2]])),
    )
    for b in primary_resonance(duffing(eps, w, mu, al), 0, Harmonic(Om, [eps * k])):
        y = np.array([b.eta(0.0)[0], b.eta_dot(0.0)[0]])
        for _ in range(20):
            res = integrate(system, y[:1], y[1:], 0.0, T / S, S, sensitivity="uv", store="last")
            dy = np.linalg.solve(res.monodromy - np.eye(2), y - [res.u[-1, 0], res.v[-1, 0]])
            y = y + dy
            if np.max(np.abs(dy)) < 1e-9:
                break
        res = integrate(system, y[:1], y[1:], 0.0, T / S, S, sensitivity="uv")
        assert (np.max(np.abs(np.linalg.eigvals(res.monodromy))) < 1) == b.stable
        rel = abs(np.max(np.abs(res.u[:, 0])) - b.amplitude[0]) / b.amplitude[0]
        assert rel < eps


def test_first_approximation_on_a_branch():
    eps, w = 0.1, 1.0
    sys1 = duffing(eps, w)
    h = Harmonic(w + eps * 1.0, [eps * 1.0])
    up = primary_resonance(sys1, 0, h)[-1]
    t = np.linspace(0, 10, 7)
    eta, eta_dot = first_approximation(sys1, t, [h], soft=[(0, 0)], guess=up.B)
    Om = h.frequency
    assert np.allclose(eta[0], up.amplitude[0] * np.cos(Om * t + up.theta0[0]), atol=1e-12)
    assert np.allclose(eta_dot[0], -Om * up.amplitude[0] * np.sin(Om * t + up.theta0[0]), atol=1e-12)


# --- parametric resonance (Mathieu) -----------------------------------------------------------
def mathieu_monodromy(w, h, z, Om, periods=1):
    T = periods * 2 * np.pi / Om

    def f(t, Y):
        J = np.array([[0, 1], [-(w**2) * (1 + 2 * h * np.cos(Om * t)), -2 * z * w]])
        return (J @ Y.reshape(2, 2)).ravel()

    s = solve_ivp(f, (0, T), np.eye(2).ravel(), **IVP)
    return s.y[:, -1].reshape(2, 2)


def test_parametric_transition_curves_against_floquet():
    """u'' + 2 z w u' + w^2 (1 + 2 h cos Omega t) u = 0: sigma = +-w sqrt(h^2 - 4 z^2), with
    the numerical boundary (spectral radius of the monodromy = 1) within O(h^2)."""
    w = 1.0
    errs = []
    for h in (0.1, 0.03, 0.01):
        z = h / 4
        sm, sp = parametric_transition_curves(ModalSystem([w], [z]), 0, Parametric(2 * w, [[2 * h * w**2]]))
        assert (sm, sp) == pytest.approx((-w * np.sqrt(h**2 - 4 * z**2), w * np.sqrt(h**2 - 4 * z**2)), rel=1e-13)
        rho = lambda s: np.max(np.abs(np.linalg.eigvals(mathieu_monodromy(w, h, z, 2 * w + s)))) - 1  # noqa: E731
        for s0 in (sm, sp):
            s_num = brentq(rho, 0.5 * s0, 1.5 * s0, xtol=1e-14)
            errs.append(abs(s_num - s0) / h**2)
        # inside unstable, outside stable
        assert rho(0.0) > 0 and rho(1.5 * sp) < 0 and rho(1.5 * sm) < 0
    assert max(errs) < 0.25  # |error| <= 0.25 w h^2, against a width ~ 1.7 w h
    # damping above h/2 suppresses the instability
    assert np.isnan(parametric_transition_curves(ModalSystem([w], [0.06]), 0, Parametric(2 * w, [[0.2]]))).all()


def test_parametric_response_against_numerical_integration():
    """Mathieu-Duffing: a^2 = 4 w / (3 al) (sigma +- w sqrt(h^2 - 4 z^2)); the response at
    Omega/2 against the periodic orbit (period 2 T), stability against Floquet multipliers."""
    w, errs = 1.0, {}
    for eps in (0.1, 0.03):
        h, z, al = eps, eps / 4, eps
        sys1 = ModalSystem([w], [z], gamma=np.full((1, 1, 1, 1), -al))
        for sig_rel, n_expected in ((0.3, 1), (1.5, 2)):
            sig = sig_rel * eps
            Om = 2 * w + sig
            branches = parametric_response(sys1, 0, Parametric(Om, [[2 * h * w**2]]))
            assert len(branches) == n_expected
            root = w * np.sqrt(h**2 - 4 * z**2)
            closed = [np.sqrt(4 * w / (3 * al) * (sig + s * root)) for s in (-1, 1) if sig + s * root > 0]
            assert [b.amplitude[0] for b in branches] == pytest.approx(closed, rel=1e-12)
            if n_expected == 2:
                assert [b.stable for b in branches] == [False, True]
            for b in branches:
                acc = lambda t, u, v: -2 * z * w * v - w**2 * (1 + 2 * h * np.cos(Om * t)) * u - al * u**3  # noqa: E731
                jac = lambda t, u, v: (  # noqa: E731
                    np.array([[-(w**2) * (1 + 2 * h * np.cos(Om * t)) - 3 * al * u[0] ** 2]]),
                    np.array([[-2 * z * w]]),
                )
                t, u, mult = periodic_orbit(acc, jac, 4 * np.pi / Om, [b.eta(0.0)[0], b.eta_dot(0.0)[0]])
                assert (np.max(np.abs(mult)) < 1) == b.stable
                a_num = abs(harmonic(t, u[0], Om / 2))
                errs[(eps, sig_rel, b.stable)] = abs(a_num - b.amplitude[0]) / a_num
                assert errs[(eps, sig_rel, b.stable)] < 0.5 * eps
        # the trivial state: unstable between the transition curves
        triv = modulation_equations(sys1, (), [Parametric(2 * w, [[2 * h * w**2]])], principal=[(0, 0)]).steady_state()
        assert triv.amplitude[0] == 0 and not triv.stable
    for key in ((0.3, True), (1.5, False), (1.5, True)):
        assert errs[(0.03, *key)] < errs[(0.1, *key)] / 2.5  # O(eps)


# --- the machinery ----------------------------------------------------------------------------
def test_jacobian_matches_finite_differences():
    rng = np.random.default_rng(1)
    n = 2
    sys2 = ModalSystem(
        [1.0, 2.3], [0.02, 0.03], alpha=0.05 * rng.normal(size=(n, n)),
        delta=0.1 * rng.normal(size=(n,) * 3), gamma=0.1 * rng.normal(size=(n,) * 4),
    )
    hs = [Harmonic(1.02, [0.05, 0.0]), Harmonic(0.55, [0.3, 0.2], [0.1, 0.5])]
    flow = modulation_equations(sys2, hs, [Parametric(4.65, 0.1 * np.eye(2))], soft=[(0, 0)], principal=[(1, 0)])
    assert flow.nu == pytest.approx([0.02, (4.65 - 2 * 2.3) / 2])
    assert len(flow.terms) > 10
    x = rng.normal(size=2 * n)
    J = flow.jacobian(x)
    h = 1e-6
    Jfd = np.column_stack([(flow(x + h * e) - flow(x - h * e)) / (2 * h) for e in np.eye(2 * n)])
    assert np.allclose(J, Jfd, rtol=1e-7, atol=1e-9)


def test_acceleration_is_equation_34():
    rng = np.random.default_rng(2)
    n = 2
    a, d, g = rng.normal(size=(n, n)), rng.normal(size=(n,) * 3), rng.normal(size=(n,) * 4)
    sys2 = ModalSystem([1.0, 2.0], [0.1, 0.2], a, d, g)
    h, p = Harmonic(0.5, [1.0, 2.0], [0.1, 0.2]), Parametric(3.0, [[1, 2], [3, 4]], 0.3)
    e, v, t = np.array([0.3, -0.4]), np.array([0.2, 0.1]), 0.7
    expected = [
        -(1.0 if r == 0 else 4.0) * e[r]
        + h.amplitude[r] * np.cos(0.5 * t + h.phase[r])
        - 2 * [0.1, 0.2][r] * [1.0, 2.0][r] * v[r]
        - sum(a[r, s] * e[s] for s in range(n))
        - np.cos(3.0 * t + 0.3) * sum(p.stiffness[r, s] * e[s] for s in range(n))
        + sum(d[r, s, q] * e[s] * e[q] for s in range(n) for q in range(n))
        + sum(g[r, s, q, u] * e[s] * e[q] * e[u] for s in range(n) for q in range(n) for u in range(n))
        for r in range(n)
    ]
    assert sys2.n_modes == 2
    assert sys2.acceleration(t, e, v, [h], [p]) == pytest.approx(expected, rel=1e-13)


def test_newton_failure_raises_a_named_error():
    with pytest.raises(NewtonConvergenceError, match=r"residual .* iterations") as info:
        newton(lambda x: x**2 + 1.0, [3.0], maxiter=5, t=0.25)
    assert "t = 0.25 s" in str(info.value) and info.value.iterations <= 5 and info.value.residual >= 1.0
    with pytest.raises(NewtonConvergenceError, match="singular Jacobian"):
        newton(lambda x: x**2 + 1.0, [0.0], lambda x: np.diag(2 * x))
    with pytest.raises(FivebarError, match=r"x0 = \['a'\] is not allowed"):
        newton(lambda x: x, ["a"])
    with pytest.raises(FivebarError, match="tol = -1.0 is not allowed"):
        newton(lambda x: x, [1.0], tol=-1.0)
    with pytest.raises(FivebarError, match="maxiter = 0 is not allowed"):
        newton(lambda x: x, [1.0], maxiter=0)
    root = newton(lambda x: x**2 - 2.0, [1.0], lambda x: np.diag(2 * x), tol=1e-14)
    assert root[0] == pytest.approx(np.sqrt(2), rel=1e-14)


def test_incommensurate_resonances_have_no_steady_state():
    sys1 = duffing(0.1)
    hs = [Harmonic(1.01, [0.1]), Harmonic(1.03, [0.1])]
    flow = modulation_equations(sys1, hs)
    assert flow.nu is None
    with pytest.raises(MultiscaleError, match=r"detuning = 0.05: .*incommensurate"):
        flow.steady_state()
    assert np.all(np.isfinite(flow.modulation(1.0, [0.1 + 0.2j])))  # the transient flow still works


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: ModalSystem([1.0, -2.0]), r"w\[1\] = -2 rad/s"),
        (lambda: ModalSystem([1.0], [-0.1]), r"zeta\[0\] = -0.1"),
        (lambda: ModalSystem([1.0, 2.0], alpha=np.zeros((2, 3))), r"alpha has shape \(2, 3\), expected \(2, 2\)"),
        (lambda: ModalSystem([1.0], gamma=np.zeros((1, 1, 1))), r"gamma has shape"),
        (lambda: ModalSystem([np.nan]), r"w\[0\] = nan is not finite"),
        (lambda: ModalSystem(["a"]), r"w = \['a'\] is not allowed: it must be a real number"),
        (lambda: Harmonic(-1.0, [1.0]), r"harmonic frequency = -1 rad/s"),
        (lambda: Harmonic(1.0, [1.0, 2.0], [0.1, 0.2, 0.3]), r"harmonic phase has shape \(3,\)"),
        (lambda: Parametric(2.0, [[1.0, 2.0]]), r"square"),
        (lambda: first_approximation(ModalSystem([1.0, 2.0]), [0.0], [Harmonic(0.5, [1.0])]),
         r"harmonics\[0\] has 1 modal amplitudes, the system has n_modes = 2"),
        (lambda: primary_resonance(ModalSystem([1.0]), 1, Harmonic(1.0, [1.0])), r"mode = 1 is not allowed: it must be an integer in 0..0"),
        (lambda: particular_amplitudes(ModalSystem([2.0]), [Harmonic(2.0, [1.0])]), r"equals omega_0 exactly"),
        (lambda: modulation_equations(ModalSystem([1.0]), [Harmonic(3.0, [1.0])], soft=[(0, 4)]), r"index 4"),
        (lambda: modulation_equations(ModalSystem([1.0]), detuning=-0.1), r"detuning = -0.1"),
        (lambda: modulation_equations([1.0]), r"system is a list: it must be a fivebar.numerics.modal_equations.ModalSystem"),
        (lambda: frequency_response(ModalSystem([1.0]), 0, 0.1, [0.0, -2.0]), r"sigmas\[1\] = -2 rad/s is not allowed"),
        (lambda: first_approximation(ModalSystem([1.0]), [0.0], guess=[1, 2]), r"guess has shape \(2,\), expected \(1,\)"),
    ],
)
def test_bad_input_names_the_value(make, match):
    with pytest.raises(MultiscaleError, match=match):
        make()
    assert issubclass(MultiscaleError, ValueError) and issubclass(MultiscaleError, FivebarError)


def test_secular_terms_name_their_resonance_and_carry_the_textbook_coefficients():
    """SecularTerm.kind and the coefficients of each resonance of one or two modes against the
    hand expansion of eta^3 and of the parametric term (Nayfeh & Mook 1979, 4.1-4.2, 5.5):
    superharmonic gamma Lambda^3 (3 Omega ~ omega), subharmonic 3 gamma Lambda conj(A)^2
    (Omega ~ 3 omega), principal parametric -P e^{i phi} conj(A) / 2 (Omega ~ 2 omega),
    combination -P_rs e^{i phi} conj(A_s) / 2 (Omega ~ omega_r + omega_s), backbone 3 gamma
    A^2 conj(A) and the shift 6 gamma |Lambda|^2 A of a hard harmonic."""
    import numpy as np

    from fivebar.numerics.modal_equations import Harmonic, ModalSystem, Parametric
    from fivebar.numerics.multiscale import modulation_equations

    g = -1.0
    duff = ModalSystem(w=[1.0], zeta=[0.05], gamma=np.full((1, 1, 1, 1), g))

    def by_kind(flow):
        return {t.kind: t.coefficient for t in flow.terms}

    sup = modulation_equations(duff, [Harmonic(1.02 / 3, [0.3])])
    L = sup.Lambda[0, 0]
    k = by_kind(sup)
    assert set(k) == {"backbone", "frequency shift", "excitation"}
    assert k["backbone"] == pytest.approx(3 * g) and k["excitation"] == pytest.approx(g * L**3)
    assert k["frequency shift"] == pytest.approx(6 * g * abs(L) ** 2)
    sub = modulation_equations(duff, [Harmonic(3.03, [0.3])])
    assert by_kind(sub)["subharmonic"] == pytest.approx(3 * g * sub.Lambda[0, 0])
    par = modulation_equations(ModalSystem(w=[1.0], zeta=[0.01]), (), [Parametric(2.02, [[0.2]], 0.3)])
    assert by_kind(par) == {"parametric": pytest.approx(-0.1 * np.exp(0.3j))}
    two = ModalSystem(w=[1.0, 1.7], zeta=[0.01, 0.01])
    P = [[0.0, 0.05], [0.07, 0.0]]
    comb = modulation_equations(two, (), [Parametric(2.7, P, 0.3)])
    assert [(t.mode, t.kind) for t in comb.terms] == [(0, "combination (sum)"), (1, "combination (sum)")]
    assert [t.coefficient for t in comb.terms] == pytest.approx([-0.025 * np.exp(0.3j), -0.035 * np.exp(0.3j)])
    diff = modulation_equations(two, (), [Parametric(0.7, P, 0.3)])
    assert {t.kind for t in diff.terms} == {"combination (difference)"}
