"""Harmonic balance and Hill's method (fivebar.numerics.harmonic_balance) against closed forms and independent solvers.

* A damped linear oscillator under harmonic forcing, its spring split between K and the
  nonlinear-force interface (so that the AFT path of f_nl carries part of it): the exact
  amplitude and phase, and Hill's exponents equal to the roots of m s^2 + c s + k.
* A manufactured solution: a 2-DOF system with time-varying M(t), C(t), K(t) and a cubic force,
  forced by F = M u'' + C u' + K u + f_nl(u) of a chosen trigonometric u*(t): harmonic balance
  returns u* to round-off (the Galerkin residual of u* is zero).
* The forced Duffing oscillator x'' + 2 zeta x' + x + alpha x^3 = F cos(w t): with one harmonic the
  first-order closed form of the frequency response, a^2 [(1 - w^2 + 3 alpha a^2 / 4)^2 +
  (2 zeta w)^2] = F^2, to round-off; with H chosen for tol, the periodic orbit of scipy's DOP853
  (rtol 1e-12, the periodicity solved by scipy.optimize.root) at several frequencies, on all three
  coexisting orbits between the folds, and the stability (the middle orbit unstable).  The fold
  pair followed by continuation (fivebar.numerics.continuation with the HB residual problem): with one
  harmonic at the closed form's folds, with more at the folds of the DOP853 fold condition (the
  reference of tests/test_continuation.py) and near the closed form's for small nonlinearity.
* Mathieu's equation u'' + (a - 2 q cos 2t) u = 0: the boundaries of the first two instability
  tongues located by Hill's multipliers (trace of the monodromy matrix = -2, +2) against
  scipy.special.mathieu_b / mathieu_a, and the multipliers inside them.
* Hill's multipliers of a 2-DOF system with time-varying mass, damping and stiffness against the
  monodromy matrix of DOP853 (rtol 1e-12).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, fsolve, root
from scipy.special import mathieu_a, mathieu_b

from fivebar.numerics.continuation import continuation
from fivebar.errors import FivebarError
from fivebar.numerics.harmonic_balance import (HarmonicBalanceError, HarmonicBalanceFamily, SampledSystem,
                                      harmonic_balance, samples_for)
from fivebar.numerics.systems import System


# --- the damped linear oscillator ---------------------------------------------------------------
def test_damped_linear_oscillator_exact_response_and_exponents():
    m, c, k1, k2, F0, w = 2.0, 0.3, 30.0, 20.0, 1.5, 4.0
    sysm = System([[m]], [[c]], [[k1]], force=lambda t: [F0 * math.cos(w * t)],
                  nonlinear=lambda u: (k2 * u, np.array([[k2]])))  # a linear spring through the f_nl interface
    sol = harmonic_balance(SampledSystem(sysm, 2 * math.pi / w), 3)
    A = F0 / complex(k1 + k2 - m * w * w, c * w)  # x = Re(A e^{iwt}) = a1 cos + b1 sin
    c_exact = np.zeros(7)
    c_exact[1], c_exact[2] = A.real, -A.imag
    np.testing.assert_allclose(sol.coefficients.ravel(), c_exact, rtol=0, atol=1e-14 * abs(A))
    t = np.linspace(0, 2 * math.pi / w, 17)
    np.testing.assert_allclose(sol.displacement(t)[:, 0], np.real(A * np.exp(1j * w * t)), atol=1e-14 * abs(A))
    np.testing.assert_allclose(sol.velocity(t)[:, 0], np.real(1j * w * A * np.exp(1j * w * t)), atol=1e-13 * abs(A))
    hill = sol.hill()
    s = np.sort_complex(np.roots([m, c, k1 + k2]))
    np.testing.assert_allclose(np.sort_complex(hill.exponents), s, rtol=1e-12)
    np.testing.assert_allclose(np.abs(hill.multipliers), np.exp(-c / (2 * m) * 2 * math.pi / w), rtol=1e-12)
    assert hill.stable and sol.residual < 1e-14


# --- a manufactured solution with time-varying matrices and a cubic force ------------------------
def _manufactured():
    W = 1.3

    def M(t):
        return np.array([[2 + 0.5 * math.cos(W * t), 0.3 * math.sin(W * t)], [0.3 * math.sin(W * t), 1.2]])

    def K(t):
        return np.array([[30 + 6 * math.sin(2 * W * t), -8.0], [-8.0, 20 + 4 * math.cos(W * t)]])

    def C(t):
        return 0.02 * K(t) + 0.1 * M(t)

    def f(u):
        return (np.array([3.0 * u[0] ** 3 + u[0] * u[1] ** 2, 2.0 * u[1] ** 3 + u[0] ** 2 * u[1]]),
                np.array([[9.0 * u[0] ** 2 + u[1] ** 2, 2 * u[0] * u[1]], [2 * u[0] * u[1], 6.0 * u[1] ** 2 + u[0] ** 2]]))

    # u* = sum over h of (a_h cos + b_h sin), h <= 3
    coef = np.array([[0.1, -0.05], [0.3, 0.1], [-0.2, 0.25], [0.05, -0.02], [0.02, 0.04], [0.01, 0.0], [-0.005, 0.01]])
    h = np.array([0, 1, 1, 2, 2, 3, 3])

    def u(t, d=0):  # the d-th derivative of u*
        ph = h * W * t
        cs = np.where(np.arange(7) % 2 == 1, np.cos(ph + d * math.pi / 2), np.sin(ph + d * math.pi / 2))
        cs[0] = 1.0 if d == 0 else 0.0
        return ((h * W) ** d * cs) @ coef

    def F(t):
        return M(t) @ u(t, 2) + C(t) @ u(t, 1) + K(t) @ u(t) + f(u(t))[0]
    return W, coef, M, C, K, f, F, u


def test_manufactured_periodic_solution_of_a_time_varying_nonlinear_system():
    W, coef, M, C, K, f, F, _ = _manufactured()
    # M, K have harmonics up to 2, u* up to 3, f cubic: the Galerkin residual of u* is zero
    sol = harmonic_balance(SampledSystem(System(M, C, K, force=F, nonlinear=f), 2 * math.pi / W), 5)
    want = np.zeros((11, 2))
    want[:7] = coef
    np.testing.assert_allclose(sol.coefficients, want, rtol=0, atol=1e-12)


# --- the forced Duffing oscillator --------------------------------------------------------------
ZETA, ALPHA, FORCE = 0.05, 1.0, 0.1


def _duffing(w, zeta=ZETA, alpha=ALPHA, F=FORCE):
    return SampledSystem(System(np.eye(1), [[2 * zeta]], np.eye(1), force=lambda t: [F * math.cos(w * t)],
                                nonlinear=lambda u: (alpha * u ** 3, np.array([[3 * alpha * u[0] ** 2]]))),
                         2 * math.pi / w)


def test_a_hardening_orbit_far_from_the_linear_one_by_the_continuation_in_the_load():
    """At w = 1.5 and F = 2 Newton's method from the linear solution fails; the load path from
    0 to F passes a fold (the jump up of a hardening resonance) that natural stepping in the
    load stalls at (at 0.31 of the load).  The orbit against DOP853: measured 3e-10."""
    w, F = 1.5, 2.0
    sol = harmonic_balance(_duffing(w, F=F), 5, tol=1e-9)
    assert sol.accuracy["tried"][0][0] == 5 and sol.load_path[0] > 10  # the first H went by the load path
    x0, flow = _dop853_orbit(w, [sol.displacement(0.0)[0], sol.velocity(0.0)[0]], F=F)
    t = np.linspace(0, 2 * math.pi / w, 41)
    ref = flow(x0, t).y[0]
    assert np.abs(sol.displacement(t)[:, 0] - ref).max() < 1e-8 * np.ptp(ref)


def _first_order_amplitudes(w, zeta=ZETA, alpha=ALPHA, F=FORCE):
    """The real positive roots A = a^2 of A [(1 - w^2 + 3 alpha A / 4)^2 + (2 zeta w)^2] = F^2."""
    k, e = 1 - w * w, 0.75 * alpha
    roots = np.roots([e * e, 2 * k * e, k * k + (2 * zeta * w) ** 2, -F * F])
    return np.sort(np.sqrt(roots[(np.abs(roots.imag) < 1e-12) & (roots.real > 0)].real))


def _first_order_start(w, A, zeta=ZETA, alpha=ALPHA, F=FORCE, perturb=1.05):
    """The first-order solution (a1, b1) of amplitude sqrt(A) (a linear 2 x 2 system once A is
    known), times ``perturb``: a start of Newton's method near that branch."""
    k = 1 - w * w + 0.75 * alpha * A
    a1, b1 = np.linalg.solve([[k, 2 * zeta * w], [-2 * zeta * w, k]], [F, 0.0])
    return perturb * np.array([[0.0], [a1], [b1]])


def _dop853_orbit(w, x0, zeta=ZETA, alpha=ALPHA, F=FORCE):
    """The periodic orbit through a state near x0: DOP853 (rtol 1e-12) over a period with its
    variational equations, Newton's method on the periodicity (x(T) - x0 below 1e-12)."""
    T = 2 * math.pi / w

    def rhs(t, y):
        x, v = y[0], y[1]
        J = np.array([[0.0, 1.0], [-1 - 3 * alpha * x * x, -2 * zeta]])
        return np.r_[v, F * math.cos(w * t) - 2 * zeta * v - x - alpha * x ** 3, (J @ y[2:].reshape(2, 2)).ravel()]

    def flow(x, t_eval=None):
        return solve_ivp(rhs, (0, T), np.r_[x, np.eye(2).ravel()], method="DOP853", rtol=1e-12, atol=1e-14,
                         t_eval=t_eval)
    x = np.array(x0, float)
    for _ in range(10):
        y = flow(x).y[:, -1]
        g = y[:2] - x
        if np.abs(g).max() <= 1e-12 * max(1.0, np.abs(x).max()):
            return x, flow
        x = x - np.linalg.solve(y[2:].reshape(2, 2) - np.eye(2), g)
    raise AssertionError(f"no periodic orbit near {x0}")


@pytest.mark.parametrize("w", [0.8, 1.0, 1.12, 1.3])
def test_duffing_one_harmonic_is_the_first_order_closed_form(w):
    amps = _first_order_amplitudes(w)
    found = []
    for a in amps:  # each branch, started 5 % off it
        sol = harmonic_balance(_duffing(w), 1, start=_first_order_start(w, a * a))
        found.append(math.hypot(*sol.coefficients[1:, 0]))
        np.testing.assert_allclose(sol.coefficients, _first_order_start(w, a * a, perturb=1.0), rtol=0, atol=1e-13)
    np.testing.assert_allclose(found, amps, rtol=1e-12)


@pytest.mark.parametrize("w", [0.9, 1.1, 1.18, 1.25])
def test_duffing_orbits_against_dop853_and_their_stability(w):
    amps = _first_order_amplitudes(w)
    period = 2 * math.pi / w
    t = np.linspace(0, period, 41)
    verdicts = []
    for a in amps:
        sol = harmonic_balance(_duffing(w), 1, tol=1e-9, start=_first_order_start(w, a * a))
        x0, flow = _dop853_orbit(w, [sol.displacement(0.0)[0], sol.velocity(0.0)[0]])
        ref = flow(x0, t).y[0]
        err = np.abs(sol.displacement(t)[:, 0] - ref).max() / np.ptp(ref)  # measured: 5e-12 to 2.4e-10
        assert err < 1e-8, (w, a, err, sol.harmonics)
        assert sol.accuracy["estimate"] <= 1e-9
        # Liouville: the product of the multipliers is exp(-2 zeta T)
        assert abs(np.prod(sol.multipliers).real - math.exp(-2 * ZETA * period)) < 1e-10
        verdicts.append(sol.stable)
    # one orbit, or three between the folds of which the middle one (a saddle) is unstable
    assert verdicts == ([True] if len(amps) == 1 else [True, False, True]), (w, verdicts)


def test_the_tolerance_estimate_tracks_the_error():
    w = 1.2
    ref = harmonic_balance(_duffing(w, alpha=5.0, F=0.3), 25)
    for tol in (1e-3, 1e-6):
        sol = harmonic_balance(_duffing(w, alpha=5.0, F=0.3), 1, tol=tol)
        t = np.linspace(0, 2 * math.pi / w, 201)
        err = np.abs(sol.displacement(t) - ref.displacement(t)).max() / np.ptp(ref.displacement(t))
        # measured: the estimate is 0.97 (tol 1e-3, H = 3) and 1.00 (tol 1e-6, H = 7) times the error
        assert err <= tol and sol.accuracy["estimate"] <= tol
        assert err >= 0.1 * sol.accuracy["estimate"], (tol, err, sol.accuracy)


def _fold_condition_reference(guess, zeta=ZETA, alpha=ALPHA, F=FORCE):
    """(x0, v0, w) at a fold of the exact equation: DOP853 with its variational equations, root of
    (x(T) - x0, det(Phi - I)) (as tests/test_continuation.py)."""
    def flow(x0, w):
        def rhs(t, y):
            x, v = y[0], y[1]
            J = np.array([[0.0, 1.0], [-1 - 3 * alpha * x * x, -2 * zeta]])
            return np.r_[v, F * math.cos(w * t) - 2 * zeta * v - x - alpha * x ** 3, (J @ y[2:].reshape(2, 2)).ravel()]
        s = solve_ivp(rhs, (0, 2 * math.pi / w), np.r_[x0, np.eye(2).ravel()], method="DOP853", rtol=1e-12, atol=1e-14)
        return s.y[:2, -1], s.y[2:, -1].reshape(2, 2)

    def eqs(z):
        xT, P = flow(z[:2], z[2])
        return np.r_[xT - z[:2], np.linalg.det(P - np.eye(2))]
    sol = root(eqs, guess, tol=1e-13)
    # judged by its residual: MINPACK's step test at tol = 1e-13 sits at the round-off, and whether
    # it reports success ("not making good progress" otherwise) depends on the BLAS kernels
    assert np.abs(eqs(sol.x)).max() < 1e-10, sol.message
    return sol.x


def _closed_form_folds(zeta, alpha, F, guesses):
    """(w, a) at the folds of the first-order response curve: G = 0 and dG/dA = 0."""
    def eqs(z):
        A, w = z
        k = 1 - w * w + 0.75 * alpha * A
        return [A * (k * k + 4 * zeta ** 2 * w * w) - F * F, k * k + 4 * zeta ** 2 * w * w + 1.5 * alpha * A * k]
    out = []
    for g in guesses:
        A, w = fsolve(eqs, g, xtol=1e-13)
        out.append((w, math.sqrt(A)))
    return out


def test_duffing_fold_pair_by_continuation_one_harmonic_is_the_closed_form():
    fam = HarmonicBalanceFamily(lambda w: _duffing(w), 1)
    start = harmonic_balance(_duffing(1.0), 1)
    # with one harmonic Hill's method does not resolve the multipliers (the Floquet forms need a
    # few): the folds are kept whatever their multiplier, located by the tangent's p component
    br = continuation(fam, start.x, 1.0, 1.4, ds=0.05, ds_max=0.3, critical_tol=10.0)
    folds = sorted(b.p for b in br.bifurcations if b.kind == "fold")
    ref = sorted(w for w, _ in _closed_form_folds(ZETA, ALPHA, FORCE, [(0.18, 1.157), (0.65, 1.227)]))
    np.testing.assert_allclose(folds, ref, rtol=1e-9)


def test_duffing_fold_pair_by_continuation_against_dop853_and_the_closed_form():
    fam = HarmonicBalanceFamily(lambda w: _duffing(w), 7)
    br = continuation(fam, harmonic_balance(_duffing(1.0), 7).x, 1.0, 1.4, ds=0.05, ds_max=0.3)
    folds = [b for b in br.bifurcations if b.kind == "fold"]
    assert [b.kind for b in br.bifurcations] == ["fold", "fold"] and br.stop.startswith("p_end")
    unstable = br.p[~br.stable]  # Hill's verdict: the middle part, between the folds, is unstable
    assert unstable.size and folds[1].p - 1e-6 <= unstable.min() and unstable.max() <= folds[0].p + 1e-6
    for b in folds:
        assert abs(b.critical - 1) < 1e-6  # Hill's multiplier through +1
        sol = fam.solution(b.x, b.p)
        ref = _fold_condition_reference(np.r_[sol.displacement(0.0)[0], sol.velocity(0.0)[0], b.p])
        assert abs(b.p - ref[2]) < 1e-8, (b.p, ref[2])
    # measured against the first-order closed form: 1.6e-3 (upper fold, alpha a^2 = 0.65) and 2.3e-4
    cf = sorted(w for w, _ in _closed_form_folds(ZETA, ALPHA, FORCE, [(0.18, 1.157), (0.65, 1.227)]))
    assert np.abs(np.sort([b.p for b in folds]) - cf).max() < 2e-3


def test_small_nonlinearity_folds_approach_the_closed_form():
    zeta, alpha, F = 0.01, 0.1, 0.02  # alpha a^2 = 0.1 at the peak
    fam = HarmonicBalanceFamily(lambda w: _duffing(w, zeta, alpha, F), 5)
    br = continuation(fam, harmonic_balance(_duffing(1.0, zeta, alpha, F), 5).x, 1.0, 1.1, ds=0.02, ds_max=0.1)
    folds = sorted(b.p for b in br.bifurcations if b.kind == "fold")
    cf = sorted(w for w, _ in _closed_form_folds(zeta, alpha, F, [(0.05, 1.003), (1.0, 1.037)]))
    assert len(folds) == 2
    # the first-order form's error: measured 9.4e-6 (lower fold) and 8.0e-5 (upper), against 2.3e-4 and
    # 1.6e-3 at the ten times larger alpha a^2 of the test above
    assert np.abs(np.array(folds) - cf).max() < 1.5e-4, (folds, cf)


# --- Mathieu's equation -------------------------------------------------------------------------
def _mathieu_hill(a, q, H=10):
    sysm = System(np.eye(1), np.zeros((1, 1)), lambda t: np.array([[a - 2 * q * math.cos(2 * t)]]))
    return harmonic_balance(SampledSystem(sysm, math.pi), H).hill()


@pytest.mark.parametrize("q", [0.5, 1.0, 2.0])
def test_mathieu_transition_curves_of_the_first_two_tongues(q):
    """Period-pi map: the first tongue (b1 < a < a1) has a multiplier below -1, the second
    (b2 < a < a2) one above +1; the boundaries are where the trace of the monodromy matrix
    (mu1 + mu2, mu1 mu2 = 1) passes -2 and +2.  Measured: within 1.1e-13 at H = 10."""
    def trace(a):
        return float(np.sum(_mathieu_hill(a, q).multipliers).real)
    for b, a_, level, sign in ((mathieu_b(1, q), mathieu_a(1, q), -2.0, -1), (mathieu_b(2, q), mathieu_a(2, q), 2.0, 1)):
        mid = 0.5 * (a_ + b)
        lo = brentq(lambda a: trace(a) - level, b - 0.3, mid, xtol=1e-14)
        hi = brentq(lambda a: trace(a) - level, mid, a_ + 0.3, xtol=1e-14)
        assert abs(lo - b) < 1e-10 and abs(hi - a_) < 1e-10, (q, lo - b, hi - a_)
        mu = _mathieu_hill(mid, q).multipliers
        assert abs(mu[0].imag) < 1e-10 and sign * mu[0].real > 1 and abs(mu[0] * mu[1] - 1) < 1e-10
        assert not _mathieu_hill(mid, q).stable
        assert np.all(np.abs(np.abs(_mathieu_hill(b - 0.05, q).multipliers) - 1) < 1e-10)  # on the circle outside


# --- time-varying mass: Hill against DOP853 -----------------------------------------------------
def test_hill_multipliers_of_a_time_varying_system_against_dop853():
    W = 1.0

    def M(t):
        return np.array([[2 + 0.5 * math.cos(W * t), 0.3 * math.sin(W * t)], [0.3 * math.sin(W * t), 1.0 + 0.2 * math.cos(2 * W * t)]])

    def K(t):
        return np.array([[30 + 5 * math.sin(W * t), -10.0], [-10.0, 20 + 3 * math.cos(W * t)]])

    def C(t):
        return 0.02 * K(t) + 0.1 * M(t)

    T = 2 * math.pi / W

    def rhs(t, y):
        A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M(t), K(t)), -np.linalg.solve(M(t), C(t))]])
        return (A @ y.reshape(4, 4)).ravel()
    s = solve_ivp(rhs, (0, T), np.eye(4).ravel(), method="DOP853", rtol=1e-12, atol=1e-14)
    Phi = s.y[:, -1].reshape(4, 4)
    mu_ref = np.linalg.eigvals(Phi)
    sol = harmonic_balance(SampledSystem(System(M, C, K), T), 16)
    hill = sol.hill()
    for mu in hill.multipliers:  # measured: 3e-15 at H = 16 (1e-5 at H = 8)
        assert np.abs(mu_ref - mu).min() < 1e-10
    # the monodromy matrix from the Floquet forms: the state transition over the period itself
    np.testing.assert_allclose(hill.monodromy, Phi, atol=1e-8)


def _held_bytes(obj) -> int:
    """Bytes of the NumPy arrays reachable from ``obj`` (the library store's own count)."""
    from fivebar.cache import _parts
    return sum(nbytes for x, nbytes in _parts([obj], {}, {}).values() if isinstance(x, np.ndarray))


def test_a_solution_keeps_no_dense_matrix_of_the_balance():
    """A solution (and its Hill result) holds its coefficients and the system's samples, not
    the (2 H + 1) n square Jacobian, its LU factors or the projected M and C: a sweep keeps one
    solution per speed, 33 MB each of them at H = 46 with 22 DOFs.  Hill's method still agrees with
    DOP853 (the test above, made after this change)."""
    n, H = 6, 40
    chain = 20.0 * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))  # six masses between two walls

    def M(t):
        return np.diag(np.r_[2.0 + 0.5 * math.cos(t), np.ones(n - 1)])

    def K(t):
        return chain + np.diag(np.r_[5.0 * math.sin(t), np.zeros(n - 1)])

    def C(t):
        return 0.02 * K(t)

    dense = 8 * ((2 * H + 1) * n) ** 2  # one such matrix: 1.9 MB (the samples and the bases: 0.6 MB)
    sol = harmonic_balance(SampledSystem(System(M, C, K, lambda t: np.r_[math.cos(t), np.zeros(n - 1)]),
                                         2 * math.pi), H)
    assert _held_bytes(sol) < dense / 2
    assert sol.hill(8).stable
    assert _held_bytes(sol) < dense / 2


# --- input and failure ----------------------------------------------------------------------------
def test_bad_input_and_no_convergence():
    sysm = _duffing(1.0)
    with pytest.raises(FivebarError, match="harmonics"):
        harmonic_balance(sysm, 0)
    with pytest.raises(FivebarError, match="samples"):
        harmonic_balance(sysm, 5, samples=8)
    with pytest.raises(FivebarError, match="tol"):
        harmonic_balance(sysm, 5, tol=2.0)
    with pytest.raises(FivebarError, match="system"):
        harmonic_balance(object(), 5)
    with pytest.raises(FivebarError, match="start"):
        harmonic_balance(sysm, 5, start=np.zeros((4, 1)))
    with pytest.raises(HarmonicBalanceError, match="max_harmonics"):
        harmonic_balance(_duffing(1.2, alpha=5.0, F=0.3), 1, tol=1e-12, max_harmonics=3)
    assert samples_for(5) == 32


def test_the_generic_module_imports_nothing_of_the_linkage():
    import subprocess
    import sys

    code = ("import sys, fivebar.numerics.harmonic_balance; "
            "bad = [m for m in sys.modules if m.startswith('fivebar.') and not "
            "m.startswith(('fivebar.numerics', 'fivebar.errors', 'fivebar.cache'))]; print(bad); assert not bad, bad")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def test_continuation_takes_a_period_map_or_a_residual_problem_and_names_both_otherwise():
    """The validation layer reads the union of two protocols in continuation's annotation: a
    callable (a period map) or a ResidualProblem passes on to the solver, anything else is
    refused with both names."""
    from fivebar.errors import InputTypeError

    with pytest.raises(InputTypeError, match="PeriodMap.*ResidualProblem"):
        continuation(3.0, [0.0], 0.0, 1.0)
    family = HarmonicBalanceFamily(lambda w: _duffing(w), 3)
    branch = continuation(family, harmonic_balance(_duffing(1.0), 3).x, 1.0, 1.05, ds=0.05)
    assert branch.stop.startswith("p_end")
