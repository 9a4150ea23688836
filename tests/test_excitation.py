"""Tests of fivebar.model.excitation: the Fourier expansion (2.10), the frequencies nu_f, the modal basis."""

import math

import numpy as np
import pytest

import fivebar
from fivebar.model.dynamics import LinkageDynamics
from fivebar.model.excitation import (
    ExcitationError,
    ModalBasis,
    excitation_frequencies,
    fourier_series,
    load_expansion,
    modal_basis,
    modal_expansion,
)
from fivebar.description.setup import Setup


@pytest.fixture(scope="module")
def params():
    return fivebar.load_params()


@pytest.fixture(scope="module")
def dyn(params):
    return LinkageDynamics(Setup(params, crank_speed_rpm=120.0, steps_per_period=100, nonlinear=False))


# --- Fourier series -----------------------------------------------------------------------------
def test_pure_cosines_are_recovered_exactly():
    T, S = 0.37, 64
    nu = 2 * np.pi / T
    t = np.arange(S) * T / S
    x = np.stack([
        1.5 + 2.0 * np.cos(3 * nu * t + 0.4),
        -0.3 * np.cos(nu * t - 2.0) + 0.7 * np.cos(5 * nu * t + 1.0),
    ], axis=1)
    fs = fourier_series(x, T, 6)
    assert fs.frequency == pytest.approx(nu)
    assert fs.mean == pytest.approx([1.5, 0.0], abs=1e-13)
    assert fs.amplitude[2, 0] == pytest.approx(2.0, rel=1e-13)
    assert fs.phase[2, 0] == pytest.approx(0.4, abs=1e-13)
    assert fs.amplitude[0, 1] == pytest.approx(0.3, rel=1e-13)
    assert fs.phase[0, 1] == pytest.approx(-2.0 + np.pi, abs=1e-13)  # -0.3 cos(x) = 0.3 cos(x + pi)
    assert fs.amplitude[4, 1] == pytest.approx(0.7, rel=1e-13)
    others = np.ones_like(fs.amplitude, bool)
    others[2, 0] = others[0, 1] = others[4, 1] = False
    assert np.abs(fs.amplitude[others]).max() < 1e-13
    # and between the samples
    tt = np.linspace(0, 2 * T, 37)
    exact = np.stack([1.5 + 2.0 * np.cos(3 * nu * tt + 0.4),
                      -0.3 * np.cos(nu * tt - 2.0) + 0.7 * np.cos(5 * nu * tt + 1.0)], axis=1)
    assert np.abs(fs(tt) - exact).max() < 1e-12
    # truncation drops the fifth harmonic
    assert np.abs(fs(tt, 4)[:, 1] - (-0.3 * np.cos(nu * tt - 2.0))).max() < 1e-12


def test_truncation_error_is_the_dropped_harmonics():
    T, S = 1.0, 50
    t = np.arange(S) * T / S
    x = np.cos(2 * np.pi * t) + 0.01 * np.cos(2 * np.pi * 7 * t)
    fs = fourier_series(x, T, 10)
    assert fs.relative_error(x, 6) == pytest.approx(0.01 / 1.01, rel=1e-9)
    assert fs.relative_error(x) < 1e-13


@pytest.mark.parametrize(
    "args",
    [
        (np.ones((10, 2)), 1.0, 5),  # m = S/2 (Nyquist)
        (np.ones((10, 2)), 1.0, 0),
        (np.ones((10, 2)), -1.0, 2),
        (np.ones((10, 2)), 1.0, 2.5),
        (np.full((10, 2), np.nan), 1.0, 2),
        (np.ones((2, 2)), 1.0, 1),
    ],
)
def test_bad_series_input(args):
    with pytest.raises(ExcitationError):
        fourier_series(*args)


def test_load_series_reconstructs_the_model_force_between_steps(dyn, params):
    """(2.10) with m = params.fourier_terms against the load evaluated directly off the grid."""
    fs = load_expansion(dyn)
    assert fs.m == params.fourier_terms
    assert fs.frequency == pytest.approx(params.replace(crank_speed_rpm=120.0).crank_speed_rad_s)
    t = (np.arange(13) + 0.37) * dyn.period / 13
    F = np.array([dyn.force(x) for x in t])
    err = np.abs(fs(t) - F).max() / np.abs(F).max()
    assert err < 1e-6
    # three harmonics are not enough: the error is the dropped part, of order 1e-3
    assert 1e-4 < fs.relative_error(dyn.step_data.F, 3) < 1e-2


def test_load_coefficients_match_quadrature_of_a_finer_model(params):
    """The DFT coefficients of the S = 100 model against trapezoidal quadrature at S = 400."""
    coarse = load_expansion(LinkageDynamics(Setup(params, crank_speed_rpm=120.0, steps_per_period=100, nonlinear=False)), 5)
    fine = LinkageDynamics(Setup(params, crank_speed_rpm=120.0, steps_per_period=400, nonlinear=False))
    nu = 2 * np.pi / fine.period
    F = fine.step_data.F
    for k in (1, 2, 3):
        c = 2 * np.mean(F * np.exp(-1j * k * nu * fine.t)[:, None], axis=0)
        assert np.abs(coarse.complex_amplitude[k - 1] - c).max() < 1e-9 * np.abs(F).max()


# --- the frequencies nu_f ----------------------------------------------------------------------------
def test_excitation_frequencies_equal_speeds(params):
    df = excitation_frequencies(params, 90.0)
    W = 90.0 * 2 * np.pi / 60
    assert df.loc[["nu1", "nu2", "nu3", "nu4", "nu5"], "frequency (rad/s)"].to_numpy() == pytest.approx([W] * 5)
    assert df.loc["nu1", "frequency (Hz)"] == pytest.approx(1.5)
    assert list(df.index[df["drives linkage"]]) == ["nu1", "nu2", "nu3"]
    # crank-tied supply: the field turns at the rotor speed / (1 - s)
    assert df.loc["nu6", "frequency (rad/s)"] == pytest.approx(W / (1 - params.motors["motor1"].s))
    assert df.loc["nu7", "frequency (rad/s)"] == pytest.approx(W / (1 - params.motors["motor2"].s))


def test_nu3_is_the_greatest_common_divisor(params):
    df = excitation_frequencies(params.replace(speed_ratio=1.5), 60.0)
    W = 2 * np.pi
    assert df.loc["nu2", "frequency (rad/s)"] == pytest.approx(1.5 * W)
    assert df.loc["nu3", "frequency (rad/s)"] == pytest.approx(0.5 * W)  # period 2 s = lcm(1 s, 2/3 s)


def test_mains_supply_field_frequencies(params):
    df = excitation_frequencies(params, supply="mains")
    f = params.supply_frequency
    assert df.loc["nu6", "frequency (Hz)"] == pytest.approx(f / params.motors["motor1"].p)
    assert df.loc["nu7", "frequency (Hz)"] == pytest.approx(f / params.motors["motor2"].p)
    assert df.loc["nu1", "frequency (Hz)"] == pytest.approx((1 - params.motors["motor1"].s) * f / params.motors["motor1"].p)
    assert math.isnan(df.loc["nu8", "frequency (rad/s)"])
    with pytest.raises(ExcitationError):
        excitation_frequencies(params, supply="grid")


# --- modal basis ------------------------------------------------------------------------------------
def test_instantaneous_modes_diagonalise_every_step(dyn):
    B = modal_basis(dyn, 3)
    sd = dyn.step_data
    for j in (0, 17, 63):
        P = B.shapes[j]
        assert np.abs(P.T @ sd.M[j] @ P - np.eye(3)).max() < 1e-9
        assert np.abs(P.T @ sd.K[j] @ P - np.diag(B.omega[j] ** 2)).max() < 1e-7 * B.omega[j, -1] ** 2
    # tracked: consecutive shapes overlap positively, and the last returns to the first
    ov = np.einsum("sik,sij,sjk->sk", B.shapes[1:], sd.M[1:], B.shapes[:-1])
    assert ov.min() > 0.5
    assert np.all(B.omega[:, 0] < B.omega[:, 1])
    assert B.mean_omega == pytest.approx(B.omega.mean(axis=0))


def test_reference_basis_is_constant_and_projects_by_complex_sums(dyn):
    B = modal_basis(dyn, 2, "reference", reference_step=10)
    assert np.all(B.shapes == B.shapes[10])
    assert np.abs(B.gyroscopic).max() == 0.0
    ms = modal_expansion(dyn, B, 6)
    per_dof = load_expansion(dyn, 6)
    # modal phases from sum_i phi_ir F_ki e^{i tau_ki} (errata E22)
    expect = per_dof.complex_amplitude @ B.shapes[0]
    assert np.abs(ms.complex_amplitude - expect).max() < 1e-12 * np.abs(expect).max()


def test_kinematic_stiffness_of_a_rotating_shape():
    """A unit shape turning at Omega in the plane: H = -Omega^2, G = 0 (to O(dt^2))."""
    S, T = 400, 0.5
    W = 2 * np.pi / T
    t = np.arange(S) * T / S
    shapes = np.stack([np.cos(W * t), np.sin(W * t)], axis=1)[:, :, None]
    B = ModalBasis("instantaneous", t, T, np.ones((S, 1)), shapes, np.broadcast_to(np.eye(2), (S, 2, 2)))
    dt = T / S
    h = -(2 / dt * np.sin(W * dt / 2)) ** 2  # exact second difference of a sinusoid
    assert B.kinematic_stiffness[:, 0, 0] == pytest.approx(np.full(S, h), rel=1e-12)
    assert h == pytest.approx(-(W**2), rel=1e-3)
    assert np.abs(B.gyroscopic).max() < 1e-9 * W


def _turning_system(S, T, turn, lam):
    """A 2-DOF system with M = I whose modes turn by the angle ``turn`` over the period T:
    K(t) = lam_a(t) v_a v_a^T + lam_b(t) v_b v_b^T, v_a = R(turn t / T) e1, v_b = R(turn t / T) e2,
    (lam_a, lam_b) = lam(t); a stand-in for LinkageDynamics (what modal_basis reads of it)."""
    from types import SimpleNamespace

    t = np.arange(S) * T / S
    c, s = np.cos(turn * t / T), np.sin(turn * t / T)
    va, vb = np.stack([c, s], axis=1), np.stack([-s, c], axis=1)
    la, lb = lam(t)
    K = la[:, None, None] * va[:, :, None] * va[:, None, :] + lb[:, None, None] * vb[:, :, None] * vb[:, None, :]
    M = np.broadcast_to(np.eye(2), (S, 2, 2)).copy()
    F = np.tile([1.0, 0.0], (S, 1))
    sd = SimpleNamespace(M=M, K=K, F=F)
    return SimpleNamespace(n=2, steps_per_period=S, step_data=sd, t=t, period=T), va, vb


def test_modes_that_return_with_the_opposite_sign():
    """Modes turning by pi over a period (as a mode of the five-bar does at a speed ratio of 2):
    periodic over two periods; the basis wraps across the period's end, and the modal force of a
    constant load is a half harmonic, cos(pi t / T), exactly."""
    S, T = 200, 0.5
    dyn, va, vb = _turning_system(S, T, np.pi, lambda t: (np.full(t.shape, 4.0), np.full(t.shape, 9.0)))
    B = modal_basis(dyn, 2)
    assert B.periods == 2 and np.array_equal(B.wrap, -np.eye(2))
    # the tracked shapes are the turning vectors (one global sign each)
    for r, v in enumerate((va, vb)):
        sgn = np.sign(B.shapes[0, :, r] @ v[0])
        assert np.abs(B.shapes[:, :, r] - sgn * v).max() < 1e-12
    # the kinematic stiffness is -(pi / T)^2 at every step, across the end of the period too
    dt = T / S
    h = -(2 / dt * np.sin(np.pi / T * dt / 2)) ** 2
    assert np.diag(B.kinematic_stiffness[0]) == pytest.approx([h, h], rel=1e-9)
    assert np.abs(np.diagonal(B.kinematic_stiffness, axis1=1, axis2=2) - h).max() < 1e-9 * abs(h)
    # the modal force of mode 1, f = v_a . (1, 0) = cos(pi t / T): harmonic 1 of the series over 2 T
    ms = modal_expansion(dyn, B, 3)
    assert ms.period == pytest.approx(2 * T) and ms.m == 6
    assert ms.amplitude[0, 0] == pytest.approx(1.0, rel=1e-12)
    assert np.abs(np.delete(ms.amplitude[:, 0], 0)).max() < 1e-12
    assert ms.amplitude[0, 1] == pytest.approx(1.0, rel=1e-12)  # f_b = -sin(pi t / T)
    ext = B.extended()
    assert ext.t.size == 2 * S and ext.wrap is None
    assert np.abs(ext.shapes[S:] + B.shapes).max() == 0.0


def test_modes_that_cross_return_as_each_other():
    """Two modes whose frequencies cross twice a period while their shapes turn by pi/2: each
    tracked mode keeps its shape through the crossing (not its rank) and returns after a
    period as the other one, so the modes are periodic over four periods."""
    S, T = 201, 0.5  # (S odd: no step falls on the crossings at T/2)
    lam = lambda t: (1.5 + 0.5 * np.cos(np.pi * t / T), 1.5 - 0.5 * np.cos(np.pi * t / T))  # noqa: E731
    dyn, va, vb = _turning_system(S, T, np.pi / 2, lam)
    B = modal_basis(dyn, 2)
    assert B.periods == 4
    # mode 1 starts as v_b (the lower frequency at t = 0) and stays v_b through the crossing
    assert np.abs(np.abs(np.einsum("si,si->s", B.shapes[:, :, 0], vb)) - 1).max() < 1e-12
    la, lb = lam(dyn.t)
    assert B.omega[:, 0] == pytest.approx(np.sqrt(lb), rel=1e-12)
    assert B.omega[:, 1] == pytest.approx(np.sqrt(la), rel=1e-12)
    # over the four periods both modes spend as long on each branch: equal means
    assert B.mean_omega[0] == pytest.approx(B.mean_omega[1], rel=1e-12)
    # f_b = v_b . (1, 0) = -sin(pi t / (2 T)): harmonic 1 of the series over 4 T
    ms = modal_expansion(dyn, B, 2)
    assert ms.period == pytest.approx(4 * T)
    assert ms.amplitude[0, 0] == pytest.approx(1.0, rel=1e-9)
    assert np.abs(np.delete(ms.amplitude[:, 0], 0)).max() < 1e-9


def test_the_load_series_carries_each_cranks_harmonics(params):
    """At a speed ratio of 2 crank DE turns at twice the fundamental: the default series has 2 m
    harmonics, and between the steps it meets the load computed from the kinematics to the
    assumption's 0.1 % (m harmonics of the fundamental leave 6 % out)."""
    dyn2 = LinkageDynamics(Setup(params.replace(speed_ratio=2.0), crank_speed_rpm=120.0, steps_per_period=100,
                                 nonlinear=False))
    fs = load_expansion(dyn2)
    assert fs.m == 2 * params.fourier_terms
    t = (np.arange(11) + 0.37) * dyn2.period / 11
    F = np.array([dyn2.force(x) for x in t])
    assert np.abs(fs(t) - F).max() < 1e-3 * np.abs(F).max()
    assert np.abs(fs(t, params.fourier_terms) - F).max() > 0.03 * np.abs(F).max()


def test_a_speed_ratio_of_one_half_repeats_after_two_turns(params):
    """speed_ratio = 1/2 at 60 r/min is the five-bar whose crank AB turns at twice, and crank DE
    at once, the drive speed of 30 r/min (a description with integer ratios): the same motion,
    the same period of two turns of AB, the same steady state."""
    half = params.replace(speed_ratio=0.5)
    import copy

    table = copy.deepcopy(dict(params.values["linkage"]))
    joints = table["joints"]
    joints["A"]["ratio"], joints["E"]["ratio"] = 2.0, 1.0
    table["joints"] = joints
    whole = params.replace(linkage=table, crank_speed_rpm=30.0)
    assert half.turns == 2 and whole.turns == 1
    assert half.period == pytest.approx(2.0, rel=1e-15) and whole.period == pytest.approx(2.0, rel=1e-15)
    a = fivebar.steady_state(Setup(half, steps_per_period=200, nonlinear=False))
    b = fivebar.steady_state(Setup(whole, steps_per_period=200, nonlinear=False))
    assert np.abs(a.midpoint_mm("L2") - b.midpoint_mm("L2")).max() < 1e-9 * np.abs(b.midpoint_mm("L2")).max()
    # and the motion does not repeat after one turn of AB: the load differs half a period apart
    dyn = LinkageDynamics(Setup(half, steps_per_period=200, nonlinear=False))
    assert np.abs(dyn.step_data.F[100] - dyn.step_data.F[0]).max() > 0.1 * np.abs(dyn.step_data.F).max()


def test_bad_basis_input(dyn):
    with pytest.raises(ExcitationError):
        modal_basis(dyn, 0)
    with pytest.raises(ExcitationError):
        modal_basis(dyn, 2, "average")
    with pytest.raises(ExcitationError):
        modal_basis(dyn, 2, "reference", reference_step=100)


def test_the_frequencies_of_cranks_without_motors(params, tmp_path):
    """Cranks clamped to rigid drive shafts (a [linkage] without motors): the linkage is driven by the
    rigid-body inertia alone, at the cranks' frequencies Omega and r Omega and their common
    fundamental; the motors' nu4..nu8 do not exist (before: ExcitationError, 'two motor-driven cranks')."""
    import copy

    table = copy.deepcopy(dict(params.values["linkage"]))
    for j in table["joints"].values():
        j.pop("motor", None)
    p = params.replace(linkage=table, speed_ratio=2.0)
    df = excitation_frequencies(p, 60.0)
    assert list(df.index) == ["nu1", "nu2", "nu3"] and df["drives linkage"].all()
    assert df["frequency (Hz)"].to_numpy() == pytest.approx([1.0, 2.0, 1.0], rel=1e-12)
    assert excitation_frequencies(p, 60.0, supply="mains")["frequency (Hz)"].to_numpy() == pytest.approx([1.0, 2.0, 1.0])
