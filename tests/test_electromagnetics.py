"""Electromagnetic coupling of the motors: (2.1), (2.3), (A.4), (A.9)-(A.10).

References used here, independent of the library's closed forms: the printed motor data
worked by hand, numerical quadrature over the air gap of the paper's integrands and of the
unexpanded co-energy, finite differences of that co-energy, and the classical stiffness of
unbalanced magnetic pull pi R L B^2 / (2 mu0 sigma).
"""

import math

import numpy as np
import pytest

import fivebar
from fivebar.model import electromagnetics as em

PARAMS = fivebar.load_params()
MU0 = 4e-7 * math.pi


def _motor(params, i):
    return params.motors["motor1"] if i == 1 else params.motors["motor2"]


def _F(params, motor, field, alpha, t):
    """The MMF wave of (2.3), written out here from the four amplitudes."""
    c = em.mmf_components(motor, field, params.gap_flux_density)
    w = 2 * math.pi * params.supply_frequency
    p = motor.p
    return (
        c["F_+s"] * np.cos(w * t - p * alpha)
        + c["F_-s"] * np.cos(w * t + p * alpha)
        + c["F_+r"] * np.cos(w * t - p * alpha - params.phase_phi10)
        + c["F_-r"] * np.cos(w * t + p * alpha - params.phase_phi20)
    )


def _quad(f, n=4096):
    """Trapezoidal rule over one turn (exact for trigonometric polynomials of degree < n)."""
    a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    return 2 * math.pi / n * np.sum(f(a), axis=-1)


def _coenergy(params, motor, field, x, y, t, n=4096):
    """W' = (R L / 2) int mu0 F^2 / (sigma - x cos a - y sin a) da, not expanded."""
    sigma = motor.k_mu * motor.delta0
    def integrand(a):
        gap = sigma - x * np.cos(a) - y * np.sin(a)
        return motor.mu0 * _F(params, motor, field, a, t) ** 2 / gap

    return 0.5 * motor.R01 * motor.L01 * _quad(integrand, n)


# --- speeds (2.1) ----------------------------------------------------------------------------
def test_speeds_from_supply_and_slip():
    m1, m2 = PARAMS.motors["motor1"], PARAMS.motors["motor2"]
    assert PARAMS.supply_frequency == 50.0
    # 50 Hz: 3000 r/min for one pole pair, 1500 r/min for two
    assert em.synchronous_speed(m1, PARAMS) * 30 / math.pi == pytest.approx(3000.0)
    assert em.synchronous_speed(m2, PARAMS) * 30 / math.pi == pytest.approx(1500.0)
    assert em.rotor_speed(m1, PARAMS) * 30 / math.pi == pytest.approx(3000 * (1 - 0.0713))
    assert em.rotor_speed(m2, PARAMS) * 30 / math.pi == pytest.approx(1275.0)
    t = np.array([[0.0, 0.01], [0.02, 0.5]])
    beta = em.rotor_angle(m2, PARAMS, t)
    assert beta.shape == t.shape
    assert beta[1, 1] == pytest.approx(0.5 * 1275 * math.pi / 30)
    # the printed rated speed of motor 2 (1440 r/min) would need a slip of 0.04 (errata E14)
    assert 1 - m2.rated_speed / em.synchronous_speed(m2, PARAMS) == pytest.approx(0.04)
    f = em.supply_frequency_for_speed(m1, 2 * math.pi)  # 60 r/min
    assert em.rotor_speed(m1, PARAMS.replace(supply_frequency=f)) == pytest.approx(2 * math.pi)


# --- MMF (A.9)-(A.10) ------------------------------------------------------------------------
@pytest.mark.parametrize("i", [1, 2])
def test_literal_mmf_against_the_printed_data(i):
    m = _motor(PARAMS, i)
    F = em.mmf_components(m, "literal")
    Fm = 0.9 * m.W * m.K_w * m.I / m.p
    a = m.U_k / 220.0
    assert F["F_+s"] + F["F_-s"] == pytest.approx(Fm)
    assert F["F_+s"] - F["F_-s"] == pytest.approx(a * Fm)
    zp = math.hypot(m.r_prime / m.s, m.x_prime)
    zm = math.hypot(m.r_prime / (2 - m.s), m.x_prime)
    assert F["F_+r"] / F["F_+s"] == pytest.approx(m.m2 / m.m1 * m.x_m / zp)
    assert F["F_-r"] / F["F_-s"] == pytest.approx(m.m2 / m.m1 * m.x_m / zm)  # (1 - a_e): E7


def test_literal_mmf_numbers_by_hand():
    F = em.mmf_components(PARAMS.motors["motor1"], "literal")
    # 0.9 * 924 * 0.92 * 3.58 / 1 = 2738.96 A; a_e = 26/220
    assert F["F_+s"] == pytest.approx(0.5 * (1 + 26 / 220) * 2738.95776)
    ratio = 594.35 / math.hypot(27.24 / 1.9287, 0.0196)
    assert F["F_-r"] == pytest.approx(0.5 * ratio * (1 - 26 / 220) * 2738.95776)
    # the nominal flux density mu0 F_m / (k_mu delta0): about 11 T (errata E9)
    B = MU0 * 2738.95776 / (1.2 * 0.25e-3)
    assert em.magnetizing_mmf(PARAMS.motors["motor1"]) == pytest.approx(2738.95776)
    assert 11.0 < B < 12.0


@pytest.mark.parametrize("i", [1, 2])
def test_calibrated_mmf_is_scaled_to_the_flux_density(i):
    m = _motor(PARAMS, i)
    lit = em.mmf_components(m, "literal")
    cal = em.mmf_components(m, "calibrated", 0.7)
    sigma = 1.2 * 0.25e-3
    assert MU0 * sum(cal.values()) / sigma == pytest.approx(0.7)
    ratios = {k: cal[k] / lit[k] for k in cal}
    assert max(ratios.values()) == pytest.approx(min(ratios.values()))
    # with zero phases the calibrated wave peaks at exactly 0.7 T over space and time
    a = np.linspace(0, 2 * math.pi, 721)[:, None]
    t = np.linspace(0, 1 / 50, 401)[None, :]
    B = em.gap_flux_density(m, PARAMS, a, t, "calibrated")
    assert np.abs(B).max() == pytest.approx(0.7, rel=1e-4)
    assert em.peak_flux_density(m, PARAMS, "calibrated") == pytest.approx(0.7)


def test_mmf_wave_is_one_sinusoid_of_amplitude_C():
    m = PARAMS.motors["motor2"]
    q = PARAMS.replace(phase_phi10=0.4, phase_phi20=1.1)
    P, N = em.mmf_phasors(m, q, "literal")
    t = np.array([0.0013, 0.0071, 0.0150])
    a = np.linspace(0, 2 * math.pi, 2001)
    F = em.mmf_wave(m, q, a[:, None], t[None, :], "literal")
    assert np.allclose(F, _F(q, m, "literal", a[:, None], t[None, :]))
    w = 2 * math.pi * 50
    C = P * np.exp(1j * w * t) + np.conj(N) * np.exp(-1j * w * t)
    assert np.abs(F).max(axis=0) == pytest.approx(np.abs(C), rel=1e-5)
    # phases no longer aligned: the peak stays below the sum of the amplitudes
    assert em.peak_flux_density(m, q, "calibrated") < 0.7


# --- closed forms against quadrature ---------------------------------------------------------
CASES = [
    (1, {}),
    (2, {}),
    (1, {"phase_phi10": 0.7, "phase_phi20": -1.3}),
    (2, {"phase_phi10": 0.7, "phase_phi20": 2.0}),
    (1, {"motor1.p": 3}),
    (2, {"motor2.p": 1, "phase_phi20": 0.5}),
]


@pytest.mark.parametrize("i, changes", CASES)
@pytest.mark.parametrize(
    "field, form", [("calibrated", "derived"), ("literal", "printed"), ("literal", "derived")]
)
def test_stiffness_and_force_equal_quadrature_of_A4(i, changes, field, form):
    q = PARAMS.replace(**changes)
    m = _motor(q, i)
    sigma = m.k_mu * m.delta0
    t = np.array([0.0, 0.0017, 0.0043, 0.0111, 0.0199])
    K = em.electromagnetic_stiffness(m, q, t, field=field, form=form)
    k = em.electromagnetic_force(m, q, t, field=field, form=form)
    assert K.shape == (5, 4, 4) and k.shape == (5, 4)
    for n, tn in enumerate(t):
        F2 = lambda a: _F(q, m, field, a, tn) ** 2  # noqa: E731
        Ixx = _quad(lambda a: (1 + np.cos(2 * a)) * F2(a))
        Ixy = _quad(lambda a: np.sin(2 * a) * F2(a))
        Iyy = _quad(lambda a: (1 - np.cos(2 * a)) * F2(a))
        Jx = _quad(lambda a: np.cos(a) * F2(a))
        Jy = _quad(lambda a: np.sin(a) * F2(a))
        RLL = m.R01 * m.L01 * m.mu0 / sigma
        if form == "derived":
            c, ck = -RLL / (2 * sigma**2), -RLL / (2 * sigma)
        else:  # as (A.4) prints them
            c, ck = m.p * RLL / (4 * sigma**2), m.p * RLL / (2 * sigma)
        ref = c * np.array([[Ixx, Ixy], [Ixy, Iyy]])
        scale = abs(c) * Ixx + abs(c) * Iyy
        assert np.allclose(K[n, :2, :2], ref, rtol=0, atol=1e-10 * scale)
        assert np.all(K[n, 2:, :] == 0) and np.all(K[n, :, 2:] == 0)
        # k01: the quadrature vanishes too, to rounding
        assert abs(ck * Jx) < 1e-10 * abs(ck) * Ixx and abs(ck * Jy) < 1e-10 * abs(ck) * Ixx
        assert np.all(k[n] == 0)


@pytest.mark.parametrize("i", [1, 2])
def test_stiffness_is_minus_the_hessian_of_the_coenergy(i):
    """Finite differences of the unexpanded co-energy: K12 = -d2W'/dq2 (the sign of E8)."""
    q = PARAMS.replace(phase_phi10=0.3, phase_phi20=0.9)
    m = _motor(q, i)
    sigma = m.k_mu * m.delta0
    h = 1e-3 * sigma
    for t in (0.0031, 0.0127):
        W = lambda x, y: _coenergy(q, m, "calibrated", x, y, t)  # noqa: E731
        H = np.empty((2, 2))
        H[0, 0] = (W(h, 0) - 2 * W(0, 0) + W(-h, 0)) / h**2
        H[1, 1] = (W(0, h) - 2 * W(0, 0) + W(0, -h)) / h**2
        H[0, 1] = H[1, 0] = (W(h, h) - W(h, -h) - W(-h, h) + W(-h, -h)) / (4 * h**2)
        K = em.electromagnetic_stiffness(m, q, t, "calibrated")[:2, :2]
        assert np.allclose(K, -H, rtol=1e-4, atol=1e-4 * np.abs(H).max())
        assert np.linalg.eigvalsh(K).max() < 0  # a negative stiffness: the rotor is pulled out
        g = np.array([(W(h, 0) - W(-h, 0)) / (2 * h), (W(0, h) - W(0, -h)) / (2 * h)])
        assert np.abs(g).max() < 1e-6 * np.abs(H).max() * sigma  # k01 = 0


def test_exact_pull_equals_gradient_of_coenergy_and_tends_to_linear():
    q = PARAMS
    m = q.motors["motor1"]
    sigma = m.k_mu * m.delta0
    t = 0.0042
    x, y = 0.3 * sigma, -0.2 * sigma
    h = 1e-4 * sigma
    W = lambda x, y: _coenergy(q, m, "calibrated", x, y, t, n=8192)  # noqa: E731
    grad = np.array([(W(x + h, y) - W(x - h, y)) / (2 * h), (W(x, y + h) - W(x, y - h)) / (2 * h)])
    f = em.unbalanced_magnetic_pull(m, q, x, y, t, "calibrated", n_alpha=8192)
    assert f == pytest.approx(grad, rel=1e-6)
    # small displacement: f = -K12 u, pointing outwards (towards the narrow gap)
    u = np.array([2e-3, 1e-3]) * sigma
    K = em.electromagnetic_stiffness(m, q, t, "calibrated")[:2, :2]
    f = em.unbalanced_magnetic_pull(m, q, u[0], u[1], t, "calibrated")
    assert f == pytest.approx(-K @ u, rel=5e-3)
    assert f @ u > 0
    # broadcasting over t
    fs = em.unbalanced_magnetic_pull(m, q, u[0], u[1], np.array([t, t]), "calibrated")
    assert fs.shape == (2, 2) and np.allclose(fs[0], f)


# --- single rotating wave and elliptic field: closed forms -----------------------------------
def _stator_only(params, i, U_k):
    """Motor i with a vanishing rotor MMF (x_m -> 0) and control voltage U_k."""
    return params.replace(**{f"motor{i}.x_m": 1e-12, f"motor{i}.U_k": U_k})


def test_single_wave_p2_is_the_classical_isotropic_pull():
    q = _stator_only(PARAMS, 2, 220.0)  # a_e = 1: only F_+s
    m = q.motors["motor2"]
    F = em.mmf_components(m, "calibrated", q.gap_flux_density)
    assert F["F_-s"] == 0 and F["F_+r"] < 1e-12 * F["F_+s"]
    sigma = m.k_mu * m.delta0
    t = np.linspace(0, 0.02, 37)
    K = em.electromagnetic_stiffness(m, q, t, "calibrated")
    B = 0.7
    k_ump = math.pi * m.R01 * m.L01 * B**2 / (2 * MU0 * sigma)  # classical UMP stiffness
    assert np.allclose(K[:, :2, :2], -k_ump * np.eye(2), rtol=1e-12, atol=1e-6 * k_ump)


def test_single_wave_p1_has_a_rotating_anisotropy():
    q = _stator_only(PARAMS, 1, 220.0)
    m = q.motors["motor1"]
    sigma = m.k_mu * m.delta0
    F = em.mmf_components(m, "literal")["F_+s"]
    c = m.R01 * m.L01 * MU0 * F**2 / (2 * sigma**3)
    w = 2 * math.pi * 50
    t = np.linspace(0, 0.02, 29)
    K = em.electromagnetic_stiffness(m, q, t, field="literal", form="derived")[:, :2, :2]
    cos, sin = np.cos(2 * w * t), np.sin(2 * w * t)
    turning = np.array([[cos, sin], [sin, -cos]]).transpose(2, 0, 1)
    ref = -c * (math.pi * np.eye(2) + 0.5 * math.pi * turning)
    assert np.allclose(K, ref, rtol=1e-10, atol=1e-10 * c)
    # mean isotropic, eigenvalues constant: -c pi (1 +- 1/2)
    ev = np.linalg.eigvalsh(K)
    assert np.allclose(ev, -c * math.pi * np.array([1.5, 0.5]), rtol=1e-10)


def test_elliptic_field_ripple_p2():
    q = _stator_only(PARAMS, 2, 60.0)  # a_e = 60/220: F_+ and F_- of the stator only
    m = q.motors["motor2"]
    sigma = m.k_mu * m.delta0
    F = em.mmf_components(m, "literal")
    Fp, Fn = F["F_+s"], F["F_-s"]
    t = np.linspace(0, 0.01, 2000, endpoint=False)  # half a supply period = one ripple period
    Kxx = em.electromagnetic_stiffness(m, q, t, field="literal", form="derived")[:, 0, 0]
    c = m.R01 * m.L01 * MU0 / (2 * sigma**3)
    ripple = 0.5 * (Kxx.max() - Kxx.min())
    assert ripple == pytest.approx(math.pi * m.R01 * m.L01 * MU0 * Fp * Fn / sigma**3, rel=1e-6)
    assert Kxx.mean() == pytest.approx(-c * math.pi * (Fp**2 + Fn**2), rel=1e-6)
    # the printed form: opposite sign, times p / 2 (= 1 for p = 2)
    Kp = em.electromagnetic_stiffness(m, q, t, field="literal", form="printed")[:, 0, 0]
    assert np.allclose(Kp, -Kxx * m.p / 2)


@pytest.mark.parametrize("i", [1, 2])
def test_stiffness_harmonics_are_exact(i):
    q = PARAMS.replace(phase_phi10=0.2, phase_phi20=-0.8)
    m = _motor(q, i)
    K0, Kc, Ks = em.stiffness_harmonics(m, q, "calibrated")
    w = 2 * math.pi * 50
    n = 64
    t = np.arange(n) / n / 50  # one supply period
    K = em.electromagnetic_stiffness(m, q, t, "calibrated")
    rebuilt = K0 + np.cos(2 * w * t)[:, None, None] * Kc + np.sin(2 * w * t)[:, None, None] * Ks
    assert np.allclose(K, rebuilt, rtol=1e-12, atol=1e-9 * np.abs(K0).max())
    spec = np.abs(np.fft.rfft(K[:, 0, 0])) / n
    assert spec[0] == pytest.approx(abs(K0[0, 0]))
    others = np.delete(spec, [0, 2])  # only the mean and the second harmonic (2 w) of the period
    assert others.max() < 1e-9 * spec.max()


def test_default_variant_comes_from_params():
    m = PARAMS.motors["motor1"]
    K_cal = em.electromagnetic_stiffness(m, PARAMS, 0.003)
    assert np.array_equal(K_cal, em.electromagnetic_stiffness(m, PARAMS, 0.003, "calibrated"))
    lit = PARAMS.replace(em_variant="literal")
    K_lit = em.electromagnetic_stiffness(m, lit, 0.003)
    assert np.array_equal(K_lit, em.electromagnetic_stiffness(m, PARAMS, 0.003, "literal"))
    assert K_lit[0, 0] > 0 > K_cal[0, 0]  # the printed sign against the physical one (E8)


# --- eccentricity (2.7) ----------------------------------------------------------------------
def test_eccentricity_vector():
    m = PARAMS.motors["motor1"]
    t = np.array([0.0, 0.0031])
    e = em.eccentricity_vector(m, PARAMS, t)
    a = PARAMS.static_eccentricity_angle
    beta = (1 - m.s) * 2 * math.pi * 50 / m.p * t
    ref = np.stack(
        [0.75e-3 * math.cos(a) + 0.5e-3 * np.cos(beta), 0.75e-3 * math.sin(a) + 0.5e-3 * np.sin(beta)],
        -1,
    )
    assert np.allclose(e[:, :2], ref) and np.all(e[:, 2:] == 0)
    # printed eccentricity exceeds the gap (errata E15)
    assert m.e0 > m.delta0 and m.eps0 > m.delta0
    half = em.eccentricity_vector(m, PARAMS.replace(eccentricity_scale=0.1), t)
    assert np.allclose(half, 0.1 * e)
    assert np.all(em.eccentricity_vector(m, PARAMS.replace(eccentricity_scale=0.0), t) == 0)


# --- static stability against the shaft -----------------------------------------------------
@pytest.mark.parametrize("i", [1, 2])
def test_literal_field_makes_the_rotor_unstable_calibrated_does_not(i):
    m = _motor(PARAMS, i)
    I_s = math.pi * m.shaft_diameter**4 / 64
    k_shaft = 120 / 7 * m.shaft_E * I_s * (1 / m.l1**3 + 1 / m.l2**3)  # int EI psi''^2, bump (E3)
    sigma = m.k_mu * m.delta0
    t = np.linspace(0, 1 / 50, 401)  # includes t = 0, where |C| = |P| + |N| (zero phases)
    worst = {}
    for field in ("calibrated", "literal"):
        P, N = em.mmf_phasors(m, PARAMS, field=field)
        c = m.R01 * m.L01 * MU0 / (2 * sigma**3)
        worst[field] = k_shaft - c * (1.5 if m.p == 1 else 1.0) * math.pi * (abs(P) + abs(N)) ** 2
        ev = em.net_rotor_stiffness(m, PARAMS, t, field=field, form="derived")
        assert ev.shape == (401, 2)
        assert ev.min() == pytest.approx(worst[field], rel=1e-9)
    assert worst["calibrated"] > 0.5 * k_shaft
    assert worst["literal"] < 0
    # the printed sign hides the instability: it stiffens the shaft
    assert em.net_rotor_stiffness(m, PARAMS, t, "literal").min() > k_shaft


# --- spectrum --------------------------------------------------------------------------------
def test_field_frequencies():
    w = 2 * math.pi * 50
    f1 = em.field_frequencies(PARAMS.motors["motor1"], PARAMS)
    f2 = em.field_frequencies(PARAMS.motors["motor2"], PARAMS)
    assert f1["electrical"] == f2["electrical"] == pytest.approx(w)
    assert f2["field"] == pytest.approx(w / 2)
    O = (1 - 0.15) * w / 2
    assert f2["rotor"] == pytest.approx(O)
    assert f2["stiffness"] == pytest.approx((0.0, 2 * w))
    assert f2["force"] == ()
    assert f2["pull"] == pytest.approx((0.0, O, 2 * w - O, 2 * w, 2 * w + O))
    # a single rotating wave with p = 2 has no ripple: only the rotor frequency remains
    q = _stator_only(PARAMS, 2, 220.0)
    assert em.field_frequencies(q.motors["motor2"], q)["stiffness"] == (0.0,)
    assert em.field_frequencies(q.motors["motor2"], q)["pull"] == pytest.approx((0.0, O))
    assert f1["stiffness"] == pytest.approx((0.0, 2 * w))


# --- bad input -------------------------------------------------------------------------------
def test_bad_input_is_named():
    m = PARAMS.motors["motor1"]
    with pytest.raises(em.ElectromagneticsError, match="variant = 'fancy'"):
        em.electromagnetic_stiffness(m, PARAMS, 0.0, "fancy")
    with pytest.raises(ValueError, match="form = 'positive'"):
        em.electromagnetic_stiffness(m, PARAMS, 0.0, form="positive")
    with pytest.raises(ValueError, match="field = 'x'"):
        em.electromagnetic_force(m, PARAMS, 0.0, field="x")
    with pytest.raises(ValueError, match="nan"):
        em.electromagnetic_stiffness(m, PARAMS, [0.0, float("nan")])
    with pytest.raises(ValueError, match="gap_flux_density = None"):
        em.mmf_components(m, "calibrated")
    with pytest.raises(ValueError, match="gap_flux_density = -0.7"):
        em.mmf_components(m, "calibrated", -0.7)
    with pytest.raises(ValueError, match="variant = 'printed'"):
        em.mmf_components(m, "printed")
    with pytest.raises(ValueError, match="a_e"):
        em.mmf_components(PARAMS.replace(**{"motor1.U_k": 300.0}).motors["motor1"], "literal")
    with pytest.raises(ValueError, match="touch the stator"):
        em.unbalanced_magnetic_pull(m, PARAMS, m.e0, 0.0, 0.0)
    with pytest.raises(ValueError, match="n_alpha"):
        em.unbalanced_magnetic_pull(m, PARAMS, 0.0, 0.0, 0.0, n_alpha=4)
    with pytest.raises(ValueError, match="speed"):
        em.supply_frequency_for_speed(m, -1.0)
