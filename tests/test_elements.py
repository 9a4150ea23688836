"""Beam and motor elements (A.1)-(A.8) against independent references.

References used: the interpolation conditions that define the shape functions; exact
polynomial integration (numpy.polynomial, sympy) of the functions written out here from the
paper; rigid-body motions; closed-form natural frequencies of Euler-Bernoulli and Rayleigh
beams and of axial rods; the discrete dispersion relation of linear rod elements.
"""

import dataclasses
import math

import numpy as np
import pytest
import scipy.linalg as sl
import sympy as sp
from numpy.polynomial import Polynomial
from scipy.optimize import brentq

from fivebar import load_params
from fivebar.model.elements import (
    AXIAL_DOFS,
    TRANSVERSE_DOFS,
    assemble_line,
    beam_element,
    bending_frequencies,
    gauss_points,
    motor_element,
    motor_shape_functions,
    shaft_section,
    shape_functions,
)

PARAMS = load_params()
LINK = dict(L=PARAMS.L2 / 2, E=PARAMS.E, A=PARAMS.A, I=PARAMS.I, rho=PARAMS.rho)


# --- the paper's (A.6), written out independently as polynomials in e ------------------------
def paper_gammas(L, gamma4_e5=-1.0):
    """The eight functions of (A.6) as Polynomials in xbar (gamma4's e^5 coefficient x2)."""
    e = Polynomial([0.0, 1.0 / L])
    return [
        1 - e,
        1 - 10 * e**3 + 15 * e**4 - 6 * e**5,
        L * (e - 6 * e**3 + 8 * e**4 - 3 * e**5),
        L**2 * (e**2 - 3 * e**3 + 3 * e**4 + gamma4_e5 * e**5) / 2,
        e,
        10 * e**3 - 15 * e**4 + 6 * e**5,
        L * (-4 * e**3 + 7 * e**4 - 3 * e**5),
        L**2 * (e**3 - 2 * e**4 + e**5) / 2,
    ]


def nodal_functionals(funcs, L):
    """Matrix G[k, i] = k-th DOF functional applied to function i (identity if interpolating).

    Axial DOFs read u(0), u(L) of the axial functions; transverse DOFs read w, w', w'' at 0 and
    L of the transverse functions; an axial DOF of a transverse function is 0 and vice versa.
    """
    G = np.zeros((8, 8))
    reads = {0: (0.0, 0), 4: (L, 0), 1: (0.0, 0), 2: (0.0, 1), 3: (0.0, 2),
             5: (L, 0), 6: (L, 1), 7: (L, 2)}
    for k, (x, d) in reads.items():
        for i, f in enumerate(funcs):
            if (k in AXIAL_DOFS) == (i in AXIAL_DOFS):
                G[k, i] = f.deriv(d)(x) if d else f(x)
    return G


@pytest.mark.parametrize("L", [1.0, 0.2, 3.7])
def test_every_interpolation_condition_holds(L):
    # the library's functions, read at the nodes
    funcs = [lambda x, d=0, i=i: shape_functions(x, L, d)[i] for i in range(8)]
    G = np.zeros((8, 8))
    reads = {0: (0.0, 0), 4: (L, 0), 1: (0.0, 0), 2: (0.0, 1), 3: (0.0, 2),
             5: (L, 0), 6: (L, 1), 7: (L, 2)}
    for k, (x, d) in reads.items():
        for i in range(8):
            if (k in AXIAL_DOFS) == (i in AXIAL_DOFS):
                G[k, i] = funcs[i](x, d)
    np.testing.assert_allclose(G, np.eye(8), atol=1e-12)
    # and the axial functions are linear, the transverse quintic (derivative 6 vanishes)
    x = np.linspace(0, L, 7)
    assert np.all(shape_functions(x, L, 2)[:, list(AXIAL_DOFS)] == 0)
    assert np.all(shape_functions(x, L, 6) == 0)


@pytest.mark.parametrize("L", [1.0, 0.2])
def test_library_functions_equal_the_paper_except_gamma4(L):
    x = np.linspace(0, L, 11)
    for d in range(4):
        lib = shape_functions(x, L, d)
        for i, f in enumerate(paper_gammas(L, gamma4_e5=-1.0)):
            np.testing.assert_allclose(lib[:, i], f.deriv(d)(x), atol=1e-12 * L ** (2 - d) + 1e-13)
    # the printed gamma4 differs
    printed = paper_gammas(L, gamma4_e5=-5.0)[3]
    assert not np.allclose(shape_functions(x, L)[:, 3], printed(x))


def test_printed_gamma4_fails_the_conditions_at_e_1():
    L = 0.7
    printed = paper_gammas(L, gamma4_e5=-5.0)
    G = nodal_functionals(printed, L)
    # at e = 0 the printed gamma4 is right: value 0, slope 0, curvature 1
    assert G[1, 3] == pytest.approx(0) and G[2, 3] == pytest.approx(0)
    assert G[3, 3] == pytest.approx(1.0)
    # at e = 1 it fails all three: -2 L^2, -10 L, -40 instead of 0, 0, 0
    assert G[5, 3] == pytest.approx(-2 * L**2)
    assert G[6, 3] == pytest.approx(-10 * L)
    assert G[7, 3] == pytest.approx(-40.0)
    # the corrected set interpolates exactly
    np.testing.assert_allclose(nodal_functionals(paper_gammas(L), L), np.eye(8), atol=1e-12)
    # the library's "printed" variant is the printed polynomial
    x = np.linspace(0, L, 5)
    np.testing.assert_allclose(shape_functions(x, L, variant="printed")[:, 3], printed[3](x))


def test_quintic_reproduced_exactly():
    # Hermite interpolation reproduces every quintic: sum of nodal data x shape functions = p
    rng = np.random.default_rng(1)
    L = 0.35
    p = Polynomial(rng.normal(size=6))
    q = p.deriv()
    dofs = np.array([0, p(0), q(0), q.deriv()(0), 0, p(L), q(L), q.deriv()(L)])
    x = np.linspace(0, L, 13)
    for d in range(4):
        np.testing.assert_allclose(shape_functions(x, L, d) @ dofs, p.deriv(d)(x) if d else p(x),
                                   rtol=1e-11, atol=1e-11)


def test_shape_functions_vectorised():
    L = 0.2
    x = np.linspace(0, L, 12).reshape(3, 4)
    out = shape_functions(x, L, 1)
    assert out.shape == (3, 4, 8)
    np.testing.assert_allclose(out[2, 1], shape_functions(x[2, 1], L, 1))


def test_gauss_points_exact_degree():
    x, w = gauss_points(5, 0.3)
    assert w.sum() == pytest.approx(0.3)
    for k in range(10):  # exact up to degree 2n - 1 = 9
        assert w @ x**k == pytest.approx(0.3 ** (k + 1) / (k + 1), rel=1e-13)
    assert abs(w @ x**10 - 0.3**11 / 11) > 1e-16  # and not beyond
    with pytest.raises(ValueError, match="n = 0"):
        gauss_points(0)


# --- beam matrices ---------------------------------------------------------------------------
def exact_matrices(L, E, A, I, rho, rotary_inertia=True):
    """(A.8) by exact polynomial integration of the functions written out above."""
    g = paper_gammas(L)
    M = np.zeros((8, 8))
    K = np.zeros((8, 8))
    for i in range(8):
        for j in range(8):
            axial = i in AXIAL_DOFS and j in AXIAL_DOFS
            trans = i in TRANSVERSE_DOFS and j in TRANSVERSE_DOFS
            if not (axial or trans):
                continue
            integral = lambda p: p.integ()(L) - p.integ()(0)  # noqa: E731
            M[i, j] = rho * A * integral(g[i] * g[j])
            if axial:
                K[i, j] = E * A * integral(g[i].deriv() * g[j].deriv())
            else:
                K[i, j] = E * I * integral(g[i].deriv(2) * g[j].deriv(2))
                if rotary_inertia:
                    M[i, j] += rho * I * integral(g[i].deriv() * g[j].deriv())
    return M, K


@pytest.mark.parametrize("rotary_inertia", [True, False])
def test_beam_matrices_equal_exact_integrals(rotary_inertia):
    M, K = beam_element(**LINK, rotary_inertia=rotary_inertia)
    Me, Ke = exact_matrices(**LINK, rotary_inertia=rotary_inertia)
    np.testing.assert_allclose(M, Me, rtol=1e-12, atol=1e-14 * np.abs(Me).max())
    np.testing.assert_allclose(K, Ke, rtol=1e-12, atol=1e-14 * np.abs(Ke).max())
    L, E, A, I, rho = LINK["L"], LINK["E"], LINK["A"], LINK["I"], LINK["rho"]
    # textbook entries: linear rod and int (gamma2'')^2 = 120/7 / L^3
    ax = np.ix_([0, 4], [0, 4])
    np.testing.assert_allclose(M[ax], rho * A * L / 6 * np.array([[2, 1], [1, 2]]))
    np.testing.assert_allclose(K[ax], E * A / L * np.array([[1, -1], [-1, 1]]))
    assert K[1, 1] == pytest.approx(120 / 7 * E * I / L**3, rel=1e-13)


def dof_scale(L):
    """q = S q_hat with q_hat = [u, w, L w', L^2 w'', ...]: S K S is dimensionally uniform."""
    return np.diag([1, 1, 1 / L, 1 / L**2, 1, 1, 1 / L, 1 / L**2])


@pytest.mark.parametrize("rotary_inertia", [True, False])
def test_beam_matrices_definiteness(rotary_inertia):
    M, K = beam_element(**LINK, rotary_inertia=rotary_inertia)
    np.testing.assert_array_equal(M, M.T)
    np.testing.assert_array_equal(K, K.T)
    L, E, A, I = LINK["L"], LINK["E"], LINK["A"], LINK["I"]
    S = dof_scale(L)
    np.linalg.cholesky(S @ M @ S)  # positive definite (raises otherwise)
    # axial and bending stiffness differ by (L/r)^2: count zero eigenvalues per block, each
    # made dimensionless (EA/L, EI/L^3, slopes x L, curvatures x L^2)
    ax, tr = list(AXIAL_DOFS), list(TRANSVERSE_DOFS)
    assert np.all(K[np.ix_(ax, tr)] == 0) and np.all(M[np.ix_(ax, tr)] == 0)
    lam_ax = np.linalg.eigvalsh(K[np.ix_(ax, ax)] / (E * A / L))
    lam_tr = np.linalg.eigvalsh((S @ K @ S)[np.ix_(tr, tr)] / (E * I / L**3))
    lam = np.concatenate([lam_ax, lam_tr])
    zero = np.abs(lam) < 1e-10
    assert zero.sum() == 3  # two translations and one rotation in the plane
    assert (np.abs(lam_ax) < 1e-10).sum() == 1
    assert np.all(lam[~zero] > 1e-2)


def test_rigid_modes_and_their_kinetic_energy():
    L, E, A, I, rho = LINK["L"], LINK["E"], LINK["A"], LINK["I"], LINK["rho"]
    M, K = beam_element(**LINK)
    M0, _ = beam_element(**LINK, rotary_inertia=False)
    axial = np.array([1, 0, 0, 0, 1, 0, 0, 0.0])  # u = 1
    transverse = np.array([0, 1, 0, 0, 0, 1, 0, 0.0])  # w = 1
    rotation = np.array([0, 0, 1, 0, 0, L, 1, 0.0])  # w = xbar, w' = 1: rotation about node 1
    for q in (axial, transverse, rotation):
        assert np.linalg.norm(K @ q) < 1e-12 * np.linalg.norm(K) * np.linalg.norm(q)
    m = rho * A * L
    # translation at unit speed: T = m v^2 / 2, so q^T M q = total mass
    assert axial @ M @ axial == pytest.approx(m, rel=1e-13)
    assert transverse @ M @ transverse == pytest.approx(m, rel=1e-13)
    assert M[np.ix_([0, 4], [0, 4])].sum() == pytest.approx(m, rel=1e-13)
    # rotation about node 1 at unit rate: moment of inertia of the bar about its end,
    # rho A L^3 / 3, plus the sections' own rho I L with rotary inertia (exact for a rigid bar)
    assert rotation @ M0 @ rotation == pytest.approx(m * L**2 / 3, rel=1e-12)
    assert rotation @ M @ rotation == pytest.approx(m * L**2 / 3 + rho * I * L, rel=1e-12)


@pytest.mark.parametrize(
    "name, value", [("L", 0.0), ("E", -70e9), ("A", float("nan")), ("I", float("inf")), ("rho", 0)]
)
def test_beam_element_rejects_bad_input(name, value):
    args = dict(LINK, **{name: value})
    with pytest.raises(ValueError, match=rf"^{name} = {value!r}"):
        beam_element(**args)


def test_shape_function_argument_errors():
    with pytest.raises(ValueError, match="derivative = -1"):
        shape_functions(0.1, 0.2, -1)
    with pytest.raises(ValueError, match="derivative = 1.5"):
        shape_functions(0.1, 0.2, 1.5)
    with pytest.raises(ValueError, match="variant = 'paper'"):
        shape_functions(0.1, 0.2, variant="paper")
    with pytest.raises(ValueError, match=r"xbar = 0\.3"):
        shape_functions([0.1, 0.3], 0.2)
    with pytest.raises(ValueError, match="L = 0"):
        shape_functions(0.0, 0)
    with pytest.raises(ValueError, match="n = 0"):
        assemble_line(0, **LINK)
    with pytest.raises(ValueError, match="supports = 'free'"):
        bending_frequencies(2, **LINK, supports="free")
    with pytest.raises(ValueError, match="modes = 9"):
        bending_frequencies(1, **LINK, supports="clamped-free", modes=9)


# --- beams of several elements against closed forms -------------------------------------------
BEAM = dict(L=1.0, E=70e9, A=6e-5, I=4.5e-9, rho=2700.0)


def closed_form(supports, beam=BEAM, k=3):
    if supports == "simply-supported":
        beta_L = np.pi * np.arange(1, k + 1)
    elif supports == "clamped-free":  # roots of cos(bL) cosh(bL) + 1 = 0
        beta_L = np.array([brentq(lambda b: np.cos(b) * np.cosh(b) + 1, (j - 1) * np.pi,
                                  j * np.pi) for j in range(1, k + 1)])
    else:  # clamped-clamped: nonzero roots of cos(bL) cosh(bL) - 1 = 0
        beta_L = np.array([brentq(lambda b: np.cos(b) * np.cosh(b) - 1, (j + 0.1) * np.pi,
                                  (j + 0.9) * np.pi) for j in range(1, k + 1)])
    L = beam["L"]
    return (beta_L / L) ** 2 * np.sqrt(beam["E"] * beam["I"] / (beam["rho"] * beam["A"]))


def test_cantilever_roots():
    b = closed_form("clamped-free") * BEAM["L"] ** 2 / np.sqrt(
        BEAM["E"] * BEAM["I"] / (BEAM["rho"] * BEAM["A"]))
    np.testing.assert_allclose(np.sqrt(b), [1.8751, 4.6941, 7.8548], atol=5e-5)
    b = closed_form("clamped-clamped") * BEAM["L"] ** 2 / np.sqrt(
        BEAM["E"] * BEAM["I"] / (BEAM["rho"] * BEAM["A"]))
    np.testing.assert_allclose(np.sqrt(b), [4.7300, 7.8532, 10.9956], atol=5e-5)


@pytest.mark.parametrize("supports", ["simply-supported", "clamped-free", "clamped-clamped"])
def test_four_elements_within_0p1_percent(supports):
    err = bending_frequencies(4, **BEAM, supports=supports) / closed_form(supports) - 1
    assert np.all(np.abs(err) < 1e-3), err
    assert np.all(err > -1e-9)  # a conforming Rayleigh-Ritz model is never too soft


def test_convergence_rate_is_eight():
    # frequency error of the quintic Hermite element ~ h^(2(p + 1 - m)) = h^8 (p = 5, m = 2)
    exact = closed_form("simply-supported")
    e4 = bending_frequencies(4, **BEAM, supports="simply-supported") / exact - 1
    e8 = bending_frequencies(8, **BEAM, supports="simply-supported") / exact - 1
    rate = np.log2(e4[1:] / e8[1:])  # modes 2 and 3 (mode 1 is at rounding level at n = 8)
    assert np.all((rate > 7.5) & (rate < 9.0)), rate


def test_rotary_inertia_matches_rayleigh_beam():
    # a short, deep beam: sigma_n = k_n^2 I/A is not small.  Simply supported Rayleigh beam:
    # omega^2 = EI k^4 / (rho A (1 + k^2 I / A)), k = n pi / L
    beam = dict(L=0.2, E=70e9, A=6e-5, I=4.5e-9, rho=2700.0)
    kn = np.pi * np.arange(1, 4) / beam["L"]
    exact = np.sqrt(beam["E"] * beam["I"] * kn**4
                    / (beam["rho"] * beam["A"] * (1 + kn**2 * beam["I"] / beam["A"])))
    fe = bending_frequencies(8, **beam, supports="simply-supported", rotary_inertia=True)
    np.testing.assert_allclose(fe, exact, rtol=1e-6)
    eb = bending_frequencies(8, **beam, supports="simply-supported", rotary_inertia=False)
    assert np.all(eb / fe - 1 > 0.005)  # the effect is real: 0.9 % to 8 % here


def test_axial_rod_modes():
    # clamped-free rod of n linear elements: the discrete eigenvectors are sin(k x_j) and the
    # eigenvalues obey omega^2 = 6 c^2 (1 - cos kh) / (h^2 (2 + cos kh)), k = (2j - 1) pi / 2L
    n = 20
    L, E, rho = BEAM["L"], BEAM["E"], BEAM["rho"]
    M, K = assemble_line(n, **BEAM, rotary_inertia=False)
    keep = list(range(4, M.shape[0], 4))  # u at nodes 1..n (u = 0 at node 0)
    lam = sl.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True)
    k = (2 * np.arange(1, 4) - 1) * np.pi / (2 * L)
    h = L / n
    c2 = E / rho
    discrete = np.sqrt(6 * c2 * (1 - np.cos(k * h)) / (h**2 * (2 + np.cos(k * h))))
    np.testing.assert_allclose(np.sqrt(lam[:3]), discrete, rtol=1e-10)
    continuum = k * np.sqrt(c2)
    err = np.sqrt(lam[:3]) / continuum - 1
    np.testing.assert_allclose(err, (k * h) ** 2 / 24, rtol=0.05)  # leading O(h^2) error term


# --- motor element ---------------------------------------------------------------------------
MOTORS = [PARAMS.motors["motor1"], PARAMS.motors["motor2"]]


def bump_integrals():
    e = sp.symbols("e")
    b = 10 * e**3 - 15 * e**4 + 6 * e**5
    return sp.integrate(b**2, (e, 0, 1)), sp.integrate(sp.diff(b, e, 2) ** 2, (e, 0, 1))


def test_bump_integrals_symbolic():
    assert bump_integrals() == (sp.Rational(181, 462), sp.Rational(120, 7))


@pytest.mark.parametrize("motor", MOTORS, ids=["motor1", "motor2"])
def test_motor_shape_functions_nodal_values(motor):
    l1, l2, l = motor.l1, motor.l2, motor.l
    nodes = np.array([0.0, l1, l1 + l2, l])
    psi = motor_shape_functions(nodes, motor)
    expected = np.array([[0, 0, 0, 0], [1, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    np.testing.assert_allclose(psi, expected, atol=1e-14)
    # psi1,2 are C2 at the rotor and at the bearings (zero slope at the rotor, smooth into
    # the overhang); psi3 and psi4 are continuous
    eps = 1e-12 * l
    for x in (l1, l1 + l2):
        for d in range(3):
            left, right = motor_shape_functions(np.array([x, x + eps]), motor, d)
            np.testing.assert_allclose(left[:2], right[:2], atol=1e-6 / min(l1, l2) ** d)
        left, right = motor_shape_functions(np.array([x - eps, x + eps]), motor)
        np.testing.assert_allclose(left, right, atol=1e-6)
    # printed psi1,2: 1 at the bearings, 0 at the rotor
    printed = motor_shape_functions(nodes[:3], motor, variant="printed")
    np.testing.assert_allclose(printed[:, 0], [1, 0, 1], atol=1e-14)


@pytest.mark.parametrize("motor", MOTORS, ids=["motor1", "motor2"])
def test_motor_mass_closed_form(motor):
    A_s, I_s, J_p = shaft_section(motor.shaft_diameter)
    d = motor.shaft_diameter
    assert (A_s, I_s, J_p) == pytest.approx((math.pi * d**2 / 4, math.pi * d**4 / 64,
                                             math.pi * d**4 / 32))
    b2, _ = bump_integrals()
    rho, l1, l2, l3 = motor.shaft_rho, motor.l1, motor.l2, motor.l3
    M, _ = motor_element(motor)
    shaft = rho * A_s * float(b2) * (l1 + l2)
    expected = np.zeros((4, 4))
    expected[0, 0] = expected[1, 1] = motor.m0 + shaft  # the rotor m0 is in (E3)
    expected[2:, 2:] = rho * J_p * np.array([[(l2 + l3) / 3, l3 / 6], [l3 / 6, l3 / 3]])  # no J0
    np.testing.assert_allclose(M, expected, rtol=1e-13, atol=1e-20)
    np.testing.assert_array_equal(M, M.T)
    np.linalg.cholesky(M)
    # the printed psi vanishes at the rotor: m0 drops out, the shaft part is unchanged
    Mp, _ = motor_element(motor, variant="printed")
    assert Mp[0, 0] == pytest.approx(shaft, rel=1e-13)
    assert M[0, 0] - Mp[0, 0] == pytest.approx(motor.m0, rel=1e-12)
    # J0 drops out of the torsional mass (psi3 = psi4 = 0 at the rotor)
    M2, _ = motor_element(dataclasses.replace(motor, J0=10 * motor.J0))
    np.testing.assert_array_equal(M2, M)


@pytest.mark.parametrize("motor", MOTORS, ids=["motor1", "motor2"])
def test_motor_stiffness_closed_form(motor):
    _, I_s, J_p = shaft_section(motor.shaft_diameter)
    _, b2 = bump_integrals()
    E, G, l1, l2, l3 = motor.shaft_E, motor.shaft_G, motor.l1, motor.l2, motor.l3
    _, K = motor_element(motor)
    bend = E * I_s * float(b2) * (1 / l1**3 + 1 / l2**3)
    GJ = G * J_p
    expected = np.zeros((4, 4))
    expected[0, 0] = expected[1, 1] = bend
    # the spans l2 and l3 are torsion springs in series
    expected[2:, 2:] = [[GJ / l2 + GJ / l3, -GJ / l3], [-GJ / l3, GJ / l3]]
    np.testing.assert_allclose(K, expected, rtol=1e-12, atol=1e-12 * bend)
    assert K[0, 1] == 0 and K[1, 0] == 0  # (E11): no x-y coupling
    np.testing.assert_array_equal(K, K.T)
    np.linalg.cholesky(K)  # the bearings fix the transverse and the rotor the torsional DOFs
    # static check: a torque T at node 4 with node 3 free twists the two spans in series
    T = 1.0
    U = np.linalg.solve(K[2:, 2:], [0.0, T])
    assert U[1] == pytest.approx(T * (l2 + l3) / GJ, rel=1e-12)
    # the printed (K11)_12 = EI int psi1' psi2' is nonzero: EI (10/7)(1/l1 + 1/l2)
    _, Kp = motor_element(motor, variant="printed")
    assert Kp[0, 1] == pytest.approx(E * I_s * 10 / 7 * (1 / l1 + 1 / l2), rel=1e-12)


def test_motor_input_errors():
    motor = PARAMS.motors["motor1"]
    with pytest.raises(ValueError, match=r"motor\.l2 = 0"):
        motor_element(dataclasses.replace(motor, l2=0.0))
    with pytest.raises(ValueError, match=r"motor\.shaft_G = -1"):
        motor_element(dataclasses.replace(motor, shaft_G=-1.0))
    with pytest.raises(ValueError, match="variant = 'literal'"):
        motor_element(motor, variant="literal")
    with pytest.raises(ValueError, match=r"x = 1\.0"):
        motor_shape_functions(1.0, motor)  # beyond l = 0.363 m
