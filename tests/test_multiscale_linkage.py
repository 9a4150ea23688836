"""Tests of the model-facing multiple scales (fivebar.analyses.linkage_multiscale: modal_model, multiple_scales, ...)."""

import numpy as np
import pytest

import fivebar
from fivebar.model.dynamics import LinkageDynamics
from fivebar.model.excitation import modal_basis
from fivebar.analyses.linkage_multiscale import (
    MultipleScalesResponse,
    compare_starts,
    initial_state,
    modal_model,
    modal_nonlinear_coefficients,
    multiple_scales,
    multiple_scales_newmark,
)
from fivebar.numerics.modal_equations import MultiscaleError
from fivebar.numerics.schemes import GeneralizedAlpha
from fivebar.analyses.response import Response
from fivebar.analyses.steady import shooting
from fivebar.description.setup import Setup


@pytest.fixture(scope="module")
def params():
    return fivebar.load_params()


@pytest.fixture(scope="module")
def dyn_nl(params):
    return LinkageDynamics(Setup(params, crank_speed_rpm=120.0, steps_per_period=100, nonlinear=True))


@pytest.fixture(scope="module")
def dyn_lin(params):
    return LinkageDynamics(Setup(params, crank_speed_rpm=120.0, steps_per_period=100, nonlinear=False))


def test_nonlinear_coefficients_reproduce_the_projected_force(dyn_nl):
    """g(eta) = Phi^T f_nl(Phi eta) against -(delta eta eta + gamma eta eta eta), and its Jacobian
    against central finite differences of the full model's internal force."""
    B = modal_basis(dyn_nl, 3)
    j = 37
    D, G = modal_nonlinear_coefficients(dyn_nl, B, [j])
    D, G = D[0], G[0]
    Phi, t = B.shapes[j], B.t[j]
    # symmetric in all indices (they derive from an energy)
    for perm in ((0, 2, 1), (1, 0, 2), (2, 1, 0)):
        assert np.abs(D - D.transpose(perm)).max() <= 1e-9 * np.abs(D).max()
    assert np.abs(G - G.transpose(0, 2, 1, 3)).max() <= 1e-9 * np.abs(G).max()
    assert np.abs(G - G.transpose(1, 0, 2, 3)).max() <= 1e-9 * np.abs(G).max()
    rng = np.random.default_rng(3)
    scale = 2e-3 / np.abs(Phi).max()  # midpoint displacements of order mm
    for _ in range(3):
        eta = scale * rng.standard_normal(3)
        g = Phi.T @ dyn_nl.nonlinear(Phi @ eta, t)[0]
        model = -(np.einsum("rst,s,t->r", D, eta, eta) + np.einsum("rstu,s,t,u->r", G, eta, eta, eta))
        assert np.abs(g - model).max() <= 1e-8 * np.abs(g).max()
        h = 1e-3 * scale
        J = np.array([(Phi.T @ (dyn_nl.nonlinear(Phi @ (eta + h * e), t)[0]
                                - dyn_nl.nonlinear(Phi @ (eta - h * e), t)[0])) / (2 * h) for e in np.eye(3)]).T
        Jm = -(2 * np.einsum("rst,t->rs", D, eta) + 3 * np.einsum("rstu,t,u->rs", G, eta, eta))
        assert np.abs(J - Jm).max() <= 1e-6 * np.abs(J).max()
    # both terms matter at this amplitude (the test sees each)
    eta = scale * np.ones(3)
    quad = np.abs(np.einsum("rst,s,t->r", D, eta, eta)).max()
    cub = np.abs(np.einsum("rstu,s,t,u->r", G, eta, eta, eta)).max()
    assert quad > 0 and cub > 0


def test_modal_model_structure(dyn_lin):
    mm = modal_model(dyn_lin, 2, nonlinear=False)
    B = mm.basis
    assert mm.system.w == pytest.approx(B.mean_omega)  # the paper's means (3.3)
    assert mm.system.zeta == pytest.approx([dyn_lin.params.damping_ratio] * 2)
    assert len(mm.harmonics) == dyn_lin.params.fourier_terms + 1
    assert mm.harmonics[0].frequency == 0.0
    # alpha + w^2 is the period mean of the modal stiffness diag(omega(t)^2) + Phi^T M Phi''
    Kbar = np.diag((B.omega**2).mean(0)) + B.kinematic_stiffness.mean(0)
    assert mm.system.alpha + np.diag(mm.system.w**2) == pytest.approx(Kbar)
    # the harmonics of the stiffness rebuild it: parametric cos/sin pairs at k Omega
    t = B.t[5]
    Kt = np.diag(mm.system.w**2) + mm.system.alpha
    for p in mm.parametric:
        Kt = Kt + p.stiffness * np.cos(p.frequency * t + p.phase)
    exact = np.diag(B.omega[5] ** 2) + B.kinematic_stiffness[5]
    assert np.abs(Kt - exact).max() < 2e-2 * np.abs(exact).max()
    eff = modal_model(dyn_lin, 2, nonlinear=False, frequencies="effective")
    assert eff.system.w**2 == pytest.approx(B.mean_omega**2 + np.diag(B.kinematic_stiffness.mean(0)))
    ref = modal_model(dyn_lin, 2, nonlinear=False, basis="reference")
    assert not ref.parametric and np.abs(ref.system.alpha).max() == 0.0
    with pytest.raises(MultiscaleError, match="frequencies = 'median' is not allowed"):
        modal_model(dyn_lin, 2, frequencies="median")
    with pytest.raises(MultiscaleError, match="basis = 'modal' is not allowed: use 'instantaneous' or 'reference'"):
        modal_model(dyn_lin, 2, basis="modal")
    with pytest.raises(MultiscaleError, match="dyn.nonlinear = None is not allowed"):
        modal_model(dyn_lin, 2, nonlinear=True)  # the linear dynamics has no nonlinear force
    with pytest.raises(fivebar.FivebarError, match="setup = None .* is not allowed: give a fivebar.Setup"):
        multiple_scales(None)
    with pytest.raises(MultiscaleError, match="nonlinear_steps = 0 is not allowed: give an integer in 1..100"):
        modal_model(dyn_lin, 2, nonlinear=False, nonlinear_steps=0)
    # (the library's validation layer, fivebar.errors.checked, refuses a string for a number)
    with pytest.raises(fivebar.errors.InputError, match="detuning = 'wide' is not allowed"):
        multiple_scales(dyn_lin.setup, detuning="wide")


def test_first_approximation_is_the_modal_particular_solution(dyn_lin):
    """Away from resonance, (3.7) is the undamped particular solution of every harmonic:
    u(t) = sum_r phi_r(t) sum_k F_rk cos(k Omega t + tau_rk) / (w_r^2 - k^2 Omega^2)."""
    ms = multiple_scales(dyn_lin.setup)
    assert isinstance(ms, MultipleScalesResponse) and isinstance(ms, Response)
    assert np.all(ms.slow.a == 0.0) and ms.method == "multiple scales"
    mm = ms.modal
    t = ms.t
    eta = np.zeros((t.size, 2))
    for h in mm.harmonics:
        eta += h.amplitude * np.cos(h.frequency * t[:, None] + h.phase) / (mm.system.w**2 - h.frequency**2)
    assert np.abs(ms.eta - eta).max() < 1e-12 * np.abs(eta).max()
    Phi = np.concatenate([mm.basis.shapes, mm.basis.shapes[:1]])
    assert np.abs(ms.u - np.einsum("sik,sk->si", Phi, eta)).max() < 1e-12 * np.abs(ms.u).max()
    # the midpoint accessor works as for the numerical steady state
    same = Response(dyn_lin, ms.t, ms.u, ms.v, "x")
    assert ms.midpoint_mm("L2") == pytest.approx(same.midpoint_mm("L2"))


def test_first_approximation_against_the_steady_state(params, dyn_lin):
    """At 120 r/min the first approximation is within 30 % of the steady state (it replaces the
    time-varying modal stiffness by its mean; measured -9 % for L2, -23 % for L3)."""
    ref = shooting(dyn_lin.setup.replace(scheme=GeneralizedAlpha(0.8)))
    ms = multiple_scales(dyn_lin.setup)
    for link in ("L2", "L3"):
        assert ms.peak_to_peak_mm(link) == pytest.approx(ref.peak_to_peak_mm(link), rel=0.3)
    # with every mode and the instantaneous frequencies the modal quasi-static sum is exact
    # to 1 %: the error above is the constant frequency, not the basis
    B = modal_basis(dyn_lin, 8)
    uq = B.expand(B.project(dyn_lin.step_data.F) / B.omega**2)
    qs = dyn_lin.quasi_static(dyn_lin.t)
    assert np.abs(uq - qs).max() < 1e-2 * np.abs(qs).max()


def test_multiple_scales_newmark_reaches_the_steady_state(params, dyn_nl):
    ref = shooting(dyn_nl.setup.replace(scheme=GeneralizedAlpha(0.8)))
    st = multiple_scales_newmark(dyn_nl.setup, tol=1e-6)
    assert st.periods >= 2 and st.method == "march"
    for link in ("L2", "L3"):
        assert st.peak_to_peak_mm(link) == pytest.approx(ref.peak_to_peak_mm(link), rel=1e-4)
    u0, v0 = initial_state(dyn_nl.setup, "rest")
    assert not u0.any() and not v0.any()
    with pytest.raises(MultiscaleError, match="start = 'random' is not allowed"):
        initial_state(dyn_nl.setup, "random")


def test_compare_starts_table(params):
    df = compare_starts(Setup(params, nonlinear=False), [120.0])
    row = df.iloc[0]
    for s in ("multiple scales", "rest", "quasi-static"):
        assert row[f"periods from {s}"] >= 1
    # the quasi-static start is close to the orbit at this low speed, rest is not
    assert row["start error quasi-static"] < row["start error rest"]


def test_effective_frequency_past_divergence_raises(params):
    dyn = LinkageDynamics(Setup(params.replace(bending_depth=0.002), crank_speed_rpm=400.0, steps_per_period=100, nonlinear=False))
    with pytest.raises(MultiscaleError, match="spin-softening"):
        multiple_scales(dyn.setup, frequencies="effective")
