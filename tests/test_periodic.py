"""Generic periodic orbits (fivebar.numerics.periodic) against closed forms.

* A damped linear oscillator under harmonic forcing: the periodic orbit is the textbook
  steady response, the Floquet multipliers are exp(lambda T) with lambda the eigenvalues of
  the free oscillator; the discrete map's multipliers converge as dt^2 (checked: the error
  falls by 4 when S doubles).
* Mathieu's equation x'' + (a - 2 q cos 2t) x = 0 (period pi): on the boundaries of the first
  instability tongue a multiplier passes through -1; the boundaries are the characteristic
  values b_1(q) and a_1(q) (scipy.special.mathieu_b / mathieu_a).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import mathieu_a, mathieu_b

from fivebar.errors import FivebarError
from fivebar.numerics.schemes import GeneralizedAlpha
from fivebar.numerics.systems import System
from fivebar.numerics.periodic import (PeriodicProblem, ShootingError, floquet_multipliers, iterate_map,
                                       monodromy, newmark_map, shoot)

W0, ZETA, F0, OMEGA = 1.3, 0.05, 0.7, 1.1  # natural frequency, damping ratio, force, forcing frequency


def _oscillator(S, scheme=None):
    sysm = System(np.eye(1), [[2 * ZETA * W0]], [[W0 ** 2]], force=lambda t: [F0 * math.cos(OMEGA * t)])
    return PeriodicProblem(sysm, 2 * math.pi / OMEGA, S, scheme=scheme)


def _oscillator_exact():
    T = 2 * math.pi / OMEGA
    lam = -ZETA * W0 + 1j * W0 * math.sqrt(1 - ZETA ** 2)
    mult = np.exp(np.array([lam, lam.conjugate()]) * T)
    H = F0 / (W0 ** 2 - OMEGA ** 2 + 2j * ZETA * W0 * OMEGA)  # x = Re(H e^{i Omega t})
    return mult, np.array([H.real, (1j * OMEGA * H).real])


@pytest.mark.parametrize("scheme", [None, GeneralizedAlpha(0.8)], ids=["newmark", "alpha"])
def test_damped_oscillator_orbit_and_multipliers_converge_as_dt2(scheme):
    mult, x_exact = _oscillator_exact()
    errs = []
    for S in (200, 400, 800):
        f = newmark_map(_oscillator(S, scheme))
        orb = shoot(f, np.zeros(2), tol=1e-12)
        assert orb.residual <= 1e-12
        mu = orb.multipliers
        mu = mu[np.argsort(-mu.imag)]
        errs.append((np.abs(mu - mult[np.argsort(-mult.imag)]).max(), np.abs(orb.x - x_exact).max()))
        assert orb.stable and abs(orb.spectral_radius - abs(mult[0])) < 1e-3
    errs = np.array(errs)
    assert errs[-1, 0] < 2e-4 and errs[-1, 1] < 1e-4
    ratios = errs[:-1] / errs[1:]
    assert np.all((ratios > 3.5) & (ratios < 4.5)), ratios  # second order: dt^2


def test_finite_difference_monodromy_when_the_map_has_no_tangent():
    f = newmark_map(_oscillator(400))

    def no_tangent(x, p, jacobian):
        return f(x, p, False)[0], None

    x = np.array([0.3, -0.2])
    _, Phi = monodromy(f, x)
    _, Phi_fd = monodromy(no_tangent, x)
    assert np.abs(Phi_fd - Phi).max() < 1e-7  # forward differences, step 1e-5 of |x|: round-off of 400 steps
    orb = shoot(no_tangent, np.zeros(2), tol=1e-11)
    assert np.abs(orb.x - shoot(f, np.zeros(2), tol=1e-11).x).max() < 1e-9


def test_a_march_converges_to_the_shot_orbit():
    f = newmark_map(_oscillator(200))
    orb = shoot(f, np.zeros(2))
    xs = iterate_map(f, np.zeros(2), periods=200)
    assert np.abs(xs[-1] - orb.x).max() < 1e-8


def _mathieu_test_function(a, q, S):
    """det(Phi + I): zero when a multiplier of the period-pi map is -1."""
    sysm = System(np.eye(1), np.zeros((1, 1)), lambda t: np.array([[a - 2 * q * math.cos(2 * t)]]))
    _, Phi = monodromy(newmark_map(PeriodicProblem(sysm, math.pi, S)), np.zeros(2))
    return float(np.linalg.det(Phi + np.eye(2)))


@pytest.mark.parametrize("q", [0.5, 1.0, 2.0])
def test_mathieu_first_tongue_boundaries(q):
    """Location error of b_1, a_1 at S = 200, 400: it falls as dt^2 (ratio 4), and at S = 400
    it is below 1e-4 (measured: 1.3e-5 / 1.4e-5 at q = 0.5, 2.0e-5 / 2.7e-5 at q = 1,
    4.2e-5 / 8.7e-5 at q = 2; at S = 100 the q = 2 upper boundary is off by 1.4e-3)."""
    b1, a1 = mathieu_b(1, q), mathieu_a(1, q)
    mid = 0.5 * (a1 + b1)
    errs = []
    for S in (200, 400):
        lo = brentq(lambda a: _mathieu_test_function(a, q, S), b1 - 0.3, mid, xtol=1e-12)
        hi = brentq(lambda a: _mathieu_test_function(a, q, S), mid, a1 + 0.3, xtol=1e-12)
        errs.append((abs(lo - b1), abs(hi - a1)))
        # inside the tongue the zero solution is unstable (a multiplier below -1)
        sysm = System(np.eye(1), np.zeros((1, 1)), lambda t: np.array([[mid - 2 * q * math.cos(2 * t)]]))
        _, Phi = monodromy(newmark_map(PeriodicProblem(sysm, math.pi, S)), np.zeros(2))
        mu = floquet_multipliers(Phi)
        assert abs(mu[0]) > 1 and mu[0].real < -1 and abs(mu[0].imag) < 1e-12
    errs = np.array(errs)
    assert np.all(errs[1] < 1e-4), errs
    assert np.all((errs[0] / errs[1] > 3.8) & (errs[0] / errs[1] < 4.2)), errs


def test_bad_input_and_no_convergence():
    with pytest.raises(FivebarError, match="period"):
        PeriodicProblem(System(np.eye(1), np.zeros((1, 1)), np.eye(1)), -1.0, 10)
    with pytest.raises(FivebarError, match="steps"):
        PeriodicProblem(System(np.eye(1), np.zeros((1, 1)), np.eye(1)), 1.0, 0)
    f = newmark_map(_oscillator(100))
    with pytest.raises(ShootingError, match="did not converge"):
        shoot(f, np.array([10.0, 3.0]), tol=1e-30, max_iter=1)


def test_the_generic_modules_import_nothing_of_the_linkage():
    import subprocess
    import sys

    code = ("import sys, fivebar.numerics.periodic, fivebar.numerics.continuation; "
            "bad = [m for m in sys.modules if m.startswith('fivebar.') and m not in "
            "('fivebar.numerics', 'fivebar.numerics.periodic', 'fivebar.numerics.continuation', "
            "'fivebar.numerics.newmark', 'fivebar.numerics.blas', 'fivebar.numerics.schemes', 'fivebar.numerics.systems', "
            "'fivebar.numerics.modal_equations', "  # the data types of (3.4) (modal_period_map): generic too
            "'fivebar.errors', 'fivebar.cache')]; "
            "print(bad); assert not bad, bad")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def _modal_and_explicit(S=120):
    """A two-mode system of the modal equations with every kind of term (linear coupling,
    quadratic and cubic terms, a parametric and two harmonic excitations), as
    ``modal_period_map`` builds it and as a :class:`System` of Python functions written out
    here from (3.4): the second is marched by the Python loop, calling them at every step."""
    from fivebar.numerics.modal_equations import Harmonic, ModalSystem, Parametric
    from fivebar.numerics.periodic import modal_period_map

    rng = np.random.default_rng(7)
    n = 2
    sysm = ModalSystem(w=[1.0, 2.3], zeta=[0.02, 0.03], alpha=0.05 * rng.standard_normal((n, n)),
                       delta=0.3 * rng.standard_normal((n, n, n)), gamma=-0.5 * np.abs(rng.standard_normal((n,) * 4)))
    harm = [Harmonic(1.0, [0.1, 0.05]), Harmonic(2.0, [0.02, -0.04], phase=0.3)]
    par = [Parametric(2.0, 0.1 * rng.standard_normal((n, n)), phase=0.5)]
    f = modal_period_map(sysm, harm, par, period=2 * math.pi, steps=S)

    def family(p):
        K = lambda t: (np.diag(sysm.w ** 2) + sysm.alpha  # noqa: E731
                       + math.cos(p * par[0].frequency * t + par[0].phase) * par[0].stiffness)
        F = lambda t: sum(h.amplitude * np.cos(p * h.frequency * t + h.phase) for h in harm)  # noqa: E731

        def nonlinear(u):
            f_ = -(np.einsum("rst,s,t->r", sysm.delta, u, u) + np.einsum("rstu,s,t,u->r", sysm.gamma, u, u, u))
            Kt = np.empty((n, n))
            for s in range(n):  # d f / d u_s term by term, with no symmetrised tensor
                e = np.eye(n)[s]
                Kt[:, s] = -(np.einsum("rst,s,t->r", sysm.delta, e, u) + np.einsum("rst,s,t->r", sysm.delta, u, e)
                             + np.einsum("rstu,s,t,u->r", sysm.gamma, e, u, u)
                             + np.einsum("rstu,s,t,u->r", sysm.gamma, u, e, u)
                             + np.einsum("rstu,s,t,u->r", sysm.gamma, u, u, e))
            return f_, Kt
        return PeriodicProblem(System(np.eye(n), np.diag(2 * sysm.zeta * sysm.w), K, force=F, nonlinear=nonlinear),
                               2 * math.pi / p, S)
    return sysm, f, newmark_map(family)


def test_the_modal_map_marches_in_the_compiled_loop_and_is_the_map_of_the_equations_written_out():
    """The period map of the modal equations runs in the compiled loop, its polynomial force
    compiled (``fivebar.numerics._polynomial_kernel``): its state after a period and its
    monodromy matrix equal, to round-off, those of the same equations written out as a
    System of Python functions and marched by the Python loop (the path the map took before,
    with a tangent written term by term here); and the compiled force is called instead of
    the numpy one (once per period at most: the initial acceleration)."""
    from fivebar.numerics import periodic

    _, f, g = _modal_and_explicit()
    x = np.array([0.3, -0.1, 0.05, 0.2])
    calls = []
    original = periodic._PolynomialForce.__call__
    periodic._PolynomialForce.__call__ = lambda self, u: calls.append(1) or original(self, u)
    try:
        xa, Pa = f(x, 1.1, True)
    finally:
        periodic._PolynomialForce.__call__ = original
    xb, Pb = g(x, 1.1, True)
    assert len(calls) <= 1
    assert np.abs(xa - xb).max() < 1e-12 * np.abs(xb).max()
    assert np.abs(Pa - Pb).max() < 1e-11 * np.abs(Pb).max()


def test_the_compiled_polynomial_force_and_its_tangent():
    """``_polynomial_kernel.polynomial_force`` against the numpy form (to round-off) and its tangent against
    central differences of the force, for three modes with every coefficient non-zero."""
    from fivebar.numerics._jitcache import import_cached
    from fivebar.numerics.periodic import _PolynomialForce

    rng = np.random.default_rng(3)
    n = 3
    delta, gamma = rng.standard_normal((n, n, n)), rng.standard_normal((n,) * 4)
    kern = import_cached("fivebar.numerics._polynomial_kernel")
    _, rdata, idata = _PolynomialForce(delta, gamma).compiled()
    u = rng.standard_normal(n)
    fc, Kc = np.empty(n), np.empty((n, n))
    kern.polynomial_force(u, 0, rdata, idata, fc, Kc, True)
    fp, Kp = _PolynomialForce(delta, gamma)(u)
    assert np.abs(fc - fp).max() < 1e-13 * np.abs(fp).max()
    assert np.abs(Kc - Kp).max() < 1e-13 * np.abs(Kp).max()
    h = 1e-6
    fd = np.column_stack([(_PolynomialForce(delta, gamma)(u + h * e)[0] - _PolynomialForce(delta, gamma)(u - h * e)[0]) / (2 * h)
                          for e in np.eye(n)])
    assert np.abs(Kc - fd).max() < 1e-8 * np.abs(Kc).max()
    f0 = np.full(n, np.nan)
    kern.polynomial_force(u, 5, rdata, idata, f0, Kc, False)  # the step point is not used
    assert np.array_equal(f0, fc)
