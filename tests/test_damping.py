"""Stiffness-proportional (Kelvin-Voigt) damping of the deformation, the multibody model's
damping: its modal ratios against the closed form zeta_r = beta omega_r / 2, and its turning
term against finite differences of the element frames."""

import numpy as np
import pytest
import scipy.linalg as sl

from fivebar import load_params
from fivebar.model.dynamics import LinkageDynamics
from fivebar.model.kinematics import link_angles
from fivebar.description.setup import Setup


@pytest.mark.parametrize("depth", [0.002, 0.030])
def test_stiffness_damping_gives_zeta_on_the_first_mode_and_beta_omega_over_two_above(depth):
    p = load_params().replace(bending_depth=depth, damping_model="stiffness")
    d = LinkageDynamics(Setup(p, crank_speed_rpm=60, steps_per_period=100, motors=False, nonlinear=False))
    M, C, K = d.step_data.M[0], d.step_data.C[0], d.step_data.K[0]
    n = d.n
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    ev = np.linalg.eigvals(A)
    ev = ev[ev.imag > 0]
    ev = ev[np.argsort(np.abs(ev))][:4]
    zeta = -ev.real / np.abs(ev)
    M0, K0 = load_matrices(d)
    w = np.sqrt(sl.eigh(K0, M0, eigvals_only=True)[:4])
    beta = d.stiffness_damping_time
    assert beta == pytest.approx(2 * p.damping_ratio / w[0], rel=1e-9)
    assert zeta[0] == pytest.approx(p.damping_ratio, rel=2e-2)
    assert np.allclose(zeta, beta * w / 2, rtol=3e-2)  # bending modes: the axial share is small
    modal = LinkageDynamics(Setup(p.replace(damping_model="modal"), crank_speed_rpm=60, steps_per_period=100,
                                  motors=False, nonlinear=False))
    assert not np.allclose(modal.step_data.C[0], C)  # the choice takes effect


def load_matrices(d):
    """M, K of the kept DOFs at the initial crank angles, from the model (no damping terms)."""
    p, k = d.params, d.keep
    M, K = d.model.matrices(p.theta1_0, p.theta4_0)
    return M[np.ix_(k, k)], K[np.ix_(k, k)]


def test_damping_acts_on_the_deformation_rate_of_the_turning_elements():
    """C u' + (K_ode - K) u = beta sum_e R_e^T K_e,bend d/dt(R_e u) for any u, u': the turning
    term against a central difference of the element frames in time."""
    p = load_params().replace(bending_depth=0.002, damping_model="stiffness")
    d = LinkageDynamics(Setup(p, crank_speed_rpm=90, steps_per_period=100, motors=False, nonlinear=False))
    m, k = d.model, d.keep
    rng = np.random.default_rng(3)
    beta = d.stiffness_damping_time
    bend = [1, 2, 3, 5, 6, 7]
    for j in (0, 17, 61):
        t = d.t[j]
        u, v = np.zeros(m.n), np.zeros(m.n)
        u[k], v[k] = rng.normal(size=(2, d.n)) * 1e-3
        h = 1e-6 * d.period
        frames = []
        for tt in (t - h, t, t + h):
            th1, th4 = d.crank_angles(tt)
            frames.append([m._rotations(np.asarray(b)) for b in m.element_angles(link_angles(p, th1, th4))])
        ref = np.zeros(m.n + 1)
        for e, el in enumerate(m.elements):
            idx = np.array(el.dofs)
            Kl = np.zeros((8, 8))
            Kl[np.ix_(bend, bend)] = m.Ke[el.link][np.ix_(bend, bend)]
            up, vp = np.append(u, 0.0)[idx], np.append(v, 0.0)[idx]
            R0, Rm, Rp = frames[1][e], frames[0][e], frames[2][e]
            rate = R0 @ vp + (Rp - Rm) @ up / (2 * h)  # d/dt (R u) with u' = v
            ref[idx] += beta * R0.T @ Kl @ rate
        M0, Kpure = m.matrices(*d.crank_angles(t))
        got = d.step_data.C[j] @ v[k] + (d.step_data.K[j] - Kpure[np.ix_(k, k)]) @ u[k]
        assert np.abs(got).max() > 0
        assert np.allclose(got, ref[:m.n][k], rtol=0, atol=1e-6 * np.abs(ref).max())
