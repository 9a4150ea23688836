"""Rigid-body dynamics: energy, power balance, closed forms, Lagrange's equations by hand."""

import numpy as np
import pytest
from crank_laws import general_laws as _general_laws
from scipy.integrate import solve_ivp

from fivebar import load_params
from fivebar.model.kinematics import GeometryError, LINKS, crank_laws, positions, rigid_state
from fivebar.model.rigid import (
    InertiaModel,
    forward_dynamics,
    gravity_terms,
    inertia_model,
    inverse_dynamics,
    kinetic_energy,
    mass_matrix,
    motor_torques,
    potential_energy,
    velocity_terms,
)

P = load_params()
PG = P.replace(gravity=9.81)


def _energy_by_hand(params, th1, w1, th4, w4):
    """T and V summed body by body from the kinematics, written out independently of rigid.py."""
    z = np.zeros_like(np.asarray(th1, float))
    s = rigid_state(params, th1, w1, z, th4, w4, z)
    lengths = dict(zip(LINKS, params.lengths[:4]))
    T = 0.5 * (params.motors["motor1"].J0 * w1**2 + params.motors["motor2"].J0 * w4**2)
    V = 0.0
    for k, L in lengths.items():
        m = params.rho * params.width * params.thickness * L
        p, v, _ = s.point(k, 0.5)
        T = T + 0.5 * m * np.sum(v**2, -1) + 0.5 * (m * L**2 / 12) * s.omega[k] ** 2
        V = V + m * params.gravity * p[..., 1]
    for j, m in (("B", params.m01), ("C", params.m02)):
        T = T + 0.5 * m * np.sum(s.vel[j] ** 2, -1)
        V = V + m * params.gravity * s.pos[j][..., 1]
    return T, V


def _d_dt(f, t, h=1e-4):
    """Fourth-order central difference."""
    return (-f(t + 2 * h) + 8 * f(t + h) - 8 * f(t - h) + f(t - 2 * h)) / (12 * h)


GRID = np.meshgrid(np.linspace(0, 2 * np.pi, 13), np.linspace(0, 2 * np.pi, 11), indexing="ij")


def test_mass_matrix_symmetric_positive_definite():
    M = mass_matrix(P, *GRID)
    assert M.shape == GRID[0].shape + (2, 2)
    assert np.allclose(M, np.swapaxes(M, -1, -2), rtol=0, atol=1e-15)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    # without the rotors it stays positive definite: the links alone carry inertia in both q
    M0 = mass_matrix(P, *GRID, inertia=inertia_model(P).replace(rotors={}))
    assert np.all(np.linalg.eigvalsh(M0) > 0)


def test_kinetic_energy_against_positions_by_finite_differences():
    """T from velocities obtained by differencing joint positions only (no rigid_state)."""
    rng = np.random.default_rng(1)
    q = rng.uniform(0, 2 * np.pi, (20, 2))
    qd = rng.normal(0, 5, (20, 2))
    h = 1e-6
    Xp = positions(P, q[:, 0] + h * qd[:, 0], q[:, 1] + h * qd[:, 1])
    Xm = positions(P, q[:, 0] - h * qd[:, 0], q[:, 1] - h * qd[:, 1])
    rhoA = P.rho * P.width * P.thickness
    T = 0.5 * (P.motors["motor1"].J0 * qd[:, 0] ** 2 + P.motors["motor2"].J0 * qd[:, 1] ** 2)
    for k, (a, b) in LINKS.items():
        vp = (Xp[a] + Xp[b] - Xm[a] - Xm[b]) / (4 * h)  # velocity of the link midpoint
        dp, dm = Xp[b] - Xp[a], Xm[b] - Xm[a]
        w = (np.arctan2(dp[:, 1], dp[:, 0]) - np.arctan2(dm[:, 1], dm[:, 0]) + np.pi) % (2 * np.pi) - np.pi
        w /= 2 * h
        L = np.linalg.norm(dp, axis=-1)
        m = rhoA * L
        T += 0.5 * m * np.sum(vp**2, -1) + 0.5 * m * L**2 / 12 * w**2
    for j, m in (("B", P.m01), ("C", P.m02)):
        T += 0.5 * m * np.sum(((Xp[j] - Xm[j]) / (2 * h)) ** 2, -1)
    Tk = kinetic_energy(P, q[:, 0], q[:, 1], qd[:, 0], qd[:, 1])
    assert np.allclose(Tk, T, rtol=1e-8, atol=0)


def test_mass_matrix_is_the_hessian_of_kinetic_energy():
    """M_ij = d^2 T / d q'_i d q'_j, by exact second differences of the (quadratic) T."""
    th1, th4 = GRID
    M = mass_matrix(P, th1, th4)

    def T(w1, w4):
        return kinetic_energy(P, th1, th4, w1, w4)

    H = np.empty_like(M)
    H[..., 0, 0] = T(1.0, 0.0) * 2
    H[..., 1, 1] = T(0.0, 1.0) * 2
    H[..., 0, 1] = H[..., 1, 0] = T(1.0, 1.0) - T(1.0, 0.0) - T(0.0, 1.0)
    assert np.allclose(M, H, rtol=1e-12, atol=1e-15)
    # and T = 1/2 q'^T M q' for an arbitrary q'
    w = np.array([2.3, -4.1])
    assert np.allclose(T(*w), 0.5 * np.einsum("i,...ij,j->...", w, M, w), rtol=1e-12)


def test_velocity_terms_against_christoffel_symbols():
    """h_i = sum_jk (dM_ij/dq_k - 1/2 dM_jk/dq_i) q'_j q'_k from finite differences of M."""
    th1, th4 = GRID
    w = np.array([1.7, -2.9])
    eps = 1e-6
    dM = [
        (mass_matrix(P, th1 + eps, th4) - mass_matrix(P, th1 - eps, th4)) / (2 * eps),
        (mass_matrix(P, th1, th4 + eps) - mass_matrix(P, th1, th4 - eps)) / (2 * eps),
    ]
    dM = np.stack(dM, axis=-1)  # (..., i, j, k) = dM_ij / dq_k
    h_ref = np.einsum("...ijk,j,k->...i", dM, w, w) - 0.5 * np.einsum("...jki,j,k->...i", dM, w, w)
    h = velocity_terms(P, th1, th4, *w)
    assert np.allclose(h, h_ref, rtol=0, atol=1e-8 * np.abs(h_ref).max())
    # quadratic in the crank speeds
    assert np.allclose(velocity_terms(P, th1, th4, *(3 * w)), 9 * h, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("params", [P, PG], ids=["no gravity", "gravity"])
@pytest.mark.parametrize("laws", ["nominal", "general"])
def test_power_balance(params, laws):
    """tau . q' = d(T + V)/dt along a motion, T and V summed by hand, d/dt by differences."""
    if laws == "nominal":
        W = params.crank_speed_rad_s

        def law(t):
            return crank_laws(params, t, W)
    else:
        law = _general_laws
    t = np.linspace(0.0, 1.3, 53)
    th1, w1, a1, th4, w4, a4 = law(t)
    tau = inverse_dynamics(params, th1, w1, a1, th4, w4, a4)
    power = tau[:, 0] * w1 + tau[:, 1] * w4

    def E(tt):
        l = law(tt)
        T, V = _energy_by_hand(params, l[0], l[1], l[3], l[4])
        return T + V

    dE = _d_dt(E, t)
    scale = np.abs(power).max()
    assert scale > 0
    assert np.allclose(power, dE, rtol=0, atol=1e-7 * scale + 1e-12)


def test_energies_match_by_hand():
    th1, w1, _, th4, w4, _ = _general_laws(np.linspace(0, 2, 17))
    T, V = _energy_by_hand(PG, th1, w1, th4, w4)
    assert np.allclose(kinetic_energy(PG, th1, th4, w1, w4), T, rtol=1e-13)
    assert np.allclose(potential_energy(PG, th1, th4), V, rtol=1e-13, atol=1e-14)


def test_gravity_terms_are_the_gradient_of_the_potential():
    th1, th4 = GRID
    e = 1e-6
    dV = np.stack(
        [
            (potential_energy(PG, th1 + e, th4) - potential_energy(PG, th1 - e, th4)) / (2 * e),
            (potential_energy(PG, th1, th4 + e) - potential_energy(PG, th1, th4 - e)) / (2 * e),
        ],
        axis=-1,
    )
    assert np.allclose(gravity_terms(PG, th1, th4), dV, rtol=0, atol=1e-8)
    assert np.all(gravity_terms(P, th1, th4) == 0)  # the default: horizontal plane


def test_closed_form_massless_couplers():
    """Couplers massless, m02 = 0: each crank is a bar on a rotor, with m01 at B on crank 1.

    M = diag(J1 + m1 L1^2/3 + m01 L1^2, J2 + m4 L4^2/3), h = 0,
    g = g (cos th1 (m1 L1/2 + m01 L1), cos th4 m4 L4/2).
    """
    base = inertia_model(PG)
    model = base.replace(
        link_mass={**base.link_mass, "L2": 0.0, "L3": 0.0}, link_inertia={**base.link_inertia, "L2": 0.0, "L3": 0.0},
        masses={"B": PG.m01}
    )
    th1, th4 = GRID
    m1, m4 = base.link_mass["L1"], base.link_mass["L4"]
    M = mass_matrix(PG, th1, th4, inertia=model)
    M_ref = np.diag([base.rotors["A"] + m1 * PG.L1**2 / 3 + PG.m01 * PG.L1**2, base.rotors["E"] + m4 * PG.L4**2 / 3])
    assert np.allclose(M, M_ref, rtol=1e-13, atol=1e-16)
    assert np.allclose(velocity_terms(PG, th1, th4, 3.0, -7.0, inertia=model), 0, atol=1e-13)
    g_ref = np.stack([9.81 * np.cos(th1) * (m1 * PG.L1 / 2 + PG.m01 * PG.L1), 9.81 * np.cos(th4) * m4 * PG.L4 / 2], -1)
    assert np.allclose(gravity_terms(PG, th1, th4, inertia=model), g_ref, rtol=1e-12, atol=1e-14)


def test_closed_form_point_mass_at_C():
    """Only m02 at C: M = m02 J_C^T J_C with J_C = dC/dq from differences of positions()."""
    zero = {k: 0.0 for k in LINKS}
    model = InertiaModel(link_mass=zero, link_inertia=zero, masses={"C": 0.5})
    th1, th4 = GRID
    e = 1e-6
    J = np.stack(
        [
            (positions(P, th1 + e, th4)["C"] - positions(P, th1 - e, th4)["C"]) / (2 * e),
            (positions(P, th1, th4 + e)["C"] - positions(P, th1, th4 - e)["C"]) / (2 * e),
        ],
        axis=-1,
    )
    M_ref = 0.5 * np.einsum("...ki,...kj->...ij", J, J)
    assert np.allclose(mass_matrix(P, th1, th4, inertia=model), M_ref, rtol=0, atol=1e-9)


def test_free_motion_conserves_energy_and_inverse_forward_agree():
    """tau = 0: integrate M q'' = -h - g; T + V stays constant (tests h against M and g)."""
    def rhs(t, y):
        a = forward_dynamics(PG, y[0], y[1], y[2], y[3], 0.0, 0.0)
        return [y[2], y[3], a[0], a[1]]

    sol = solve_ivp(rhs, (0.0, 1.0), [0.4, 2.0, 3.0, -5.0], method="DOP853", rtol=1e-11, atol=1e-11, dense_output=True)
    assert sol.success
    y = sol.sol(np.linspace(0, 1, 41))
    E = kinetic_energy(PG, y[0], y[1], y[2], y[3]) + potential_energy(PG, y[0], y[1])
    assert np.ptp(E) < 1e-8 * np.abs(E).max()
    # the motion is not trivial: kinetic and potential energy exchange
    assert np.ptp(potential_energy(PG, y[0], y[1])) > 0.01 * np.abs(E).max()
    # inverse dynamics of the free motion gives zero torque
    acc = np.array([rhs(0, yy)[2:] for yy in y.T]).T
    tau = inverse_dynamics(PG, y[0], y[2], acc[0], y[1], y[3], acc[1])
    assert np.allclose(tau, 0, atol=1e-12)


def test_motor_torques_nominal():
    t = np.linspace(0, P.period, 201)
    tau = motor_torques(P, t)
    # constant speed, no gravity: the mean power over a period is zero, rotors do no work
    W = P.crank_speed_rad_s
    assert abs(np.trapezoid((tau[:, 0] + tau[:, 1] * P.speed_ratio) * W, t)) < 1e-10 * np.abs(tau).max() * W * P.period
    no_rotor = inertia_model(P).replace(rotors={})
    assert np.allclose(motor_torques(P, t, inertia=no_rotor), tau, rtol=0, atol=1e-15)
    # torques scale with the square of the crank speed
    tau3 = motor_torques(P, t / 3, 3 * W)
    assert np.allclose(tau3, 9 * tau, rtol=1e-12, atol=1e-15)


def test_shaft_inertia_option():
    m0, m1 = inertia_model(P), inertia_model(P, shaft_inertia=True)
    mot = P.motors["motor1"]
    extra = P.values["assumptions.shaft_rho"] * np.pi * mot.shaft_diameter**4 / 32 * (mot.l1 + mot.l2 + mot.l3)
    assert m1.rotors["A"] == pytest.approx(m0.rotors["A"] + extra, rel=1e-14)
    assert m1.rotors["E"] > m0.rotors["E"]


def test_bad_input():
    with pytest.raises(ValueError, match=r"InertiaModel.masses\['C'\] = -1"):
        inertia_model(P).replace(masses={"B": P.m01, "C": -1.0})
    with pytest.raises(ValueError, match=r"link_mass\['L2'\] = nan"):
        InertiaModel(link_mass={"L1": 1.0, "L2": float("nan"), "L3": 1.0, "L4": 1.0}, link_inertia={k: 0.0 for k in LINKS})
    with pytest.raises(ValueError, match="it must have exactly"):
        InertiaModel(link_mass={"L1": 1.0}, link_inertia={k: 0.0 for k in LINKS})
    with pytest.raises(GeometryError):
        mass_matrix(P.replace(L2=0.15, L3=0.15), 0.0, 0.0)
    with pytest.raises(ValueError, match="assembly mode 2"):
        mass_matrix(P, 0.0, 0.0, mode=2)


@pytest.mark.parametrize("mesh", [None, (2, 3, 3, 1)], ids=["paper mesh", "refined"])
def test_mass_matrix_against_the_finite_element_mass(mesh):
    """A second method: the consistent FE mass of the assembly (quintic Hermite beams, lumped
    masses, motor elements) projected on the rigid-body velocity fields of unit crank speeds.
    The shape functions reproduce rigid motion exactly, so with the rotary-inertia term off
    the projection equals M of the links and lumped masses, plus a constant diagonal: the
    motor elements' torsional shaft inertia (their torsion shapes vanish at the rotor, so J0
    does not enter the FE model)."""
    from fivebar.model.assembly import build_model

    q = P.replace(rotary_inertia=0)
    model = build_model(q, elements_per_link=mesh)
    th = np.random.default_rng(3).uniform(0, 2 * np.pi, (7, 2))
    M_fe, _ = model.matrices(th[:, 0], th[:, 1])
    V = np.stack(
        [model.rigid_velocity(rigid_state(q, th[:, 0], w1, 0.0, th[:, 1], w4, 0.0)) for w1, w4 in ((1, 0), (0, 1))], -1
    )
    M_proj = np.einsum("...ni,...nm,...mj->...ij", V, M_fe, V)
    links_only = inertia_model(q).replace(rotors={})
    D = M_proj - mass_matrix(q, th[:, 0], th[:, 1], inertia=links_only)
    scale = np.abs(M_proj).max()
    assert np.allclose(D[:, 0, 1], 0, atol=1e-13 * scale) and np.allclose(D[:, 1, 0], 0, atol=1e-13 * scale)
    assert np.allclose(D, D[0], rtol=0, atol=1e-13 * scale)  # the same at every configuration
    shaft = np.array([inertia_model(q, shaft_inertia=True).rotors[j] - q.crank_motors[j].J0 for j in ("A", "E")])
    assert np.all(D[0].diagonal() >= 0) and np.all(D[0].diagonal() <= shaft)


def test_four_bar_crank_torque_is_the_energy_rate():
    """A four-bar from its own description (one crank, no motor section): the crank torque of
    the rigid model equals the power balance tau = d(T + V)/dt / theta', with T and V summed
    body by body from finite differences of the loop-closure positions alone (no velocity of
    rigid.py or rigid_state), along a non-uniform crank law and with a rotor on the crank."""
    from fivebar import DEFAULT_PARAMS_PATH, FOURBAR_PARAMS_PATH
    from fivebar.model.kinematics import link_angles

    q = load_params([DEFAULT_PARAMS_PATH, FOURBAR_PARAMS_PATH]).replace(gravity=9.81)
    lk = q.linkage
    assert len(lk.cranks) == 1 and q.crank_motors == {}
    W, a, J = 2.0 * np.pi, 0.3, 2e-3  # crank law theta = W t + a sin(W t); rotor J (kg m^2)

    def theta(t):
        return W * t + a * np.sin(W * t)

    def energy(t):
        h = 1e-6
        th = [theta(t - h), theta(t + h)]
        pos = [positions(q, x) for x in th]
        ang = [link_angles(q, x) for x in th]
        mid = {k.name: [(p[k.start] + p[k.end]) / 2 for p in pos] for k in lk.links}
        T = 0.5 * J * ((th[1] - th[0]) / (2 * h)) ** 2
        V = 0.0
        for k in lk.links:
            m = k.material.rho * k.section.area * k.length
            v = (mid[k.name][1] - mid[k.name][0]) / (2 * h)
            w = np.unwrap(np.stack([ang[0][k.name], ang[1][k.name]]), axis=0)
            T += 0.5 * m * np.sum(v**2, -1) + 0.5 * m * k.length**2 / 12 * ((w[1] - w[0]) / (2 * h)) ** 2
            V += m * 9.81 * (mid[k.name][0][..., 1] + mid[k.name][1][..., 1]) / 2
        for pin, m in lk.masses.items():
            v = (pos[1][pin] - pos[0][pin]) / (2 * h)
            T += 0.5 * m * np.sum(v**2, -1)
            V += m * 9.81 * (pos[0][pin][..., 1] + pos[1][pin][..., 1]) / 2
        return T + V

    t = np.linspace(0.0, 1.0, 13)
    dt = 1e-4
    power = (energy(t + dt) - energy(t - dt)) / (2 * dt)
    omega = W * (1 + a * np.cos(W * t))
    laws = (theta(t), omega, -a * W**2 * np.sin(W * t))
    tau = inverse_dynamics(q, *laws, inertia=inertia_model(q).replace(rotors={"A": J}))
    assert tau.shape == (13, 1)
    scale = np.abs(tau).max()
    assert np.allclose(tau[:, 0], power / omega, rtol=0, atol=1e-5 * scale)
    # and its one-coordinate mass matrix against the kinetic energy: T = M theta'^2 / 2
    M = mass_matrix(q, theta(t), inertia=inertia_model(q).replace(rotors={"A": J}))
    assert M.shape == (13, 1, 1)
    T = kinetic_energy(q, theta(t), omega, inertia=inertia_model(q).replace(rotors={"A": J}))
    assert np.allclose(T, 0.5 * M[:, 0, 0] * omega**2, rtol=1e-12)


def test_inertia_model_names_only_the_description():
    four = load_params([__import__("fivebar").DEFAULT_PARAMS_PATH, __import__("fivebar").FOURBAR_PARAMS_PATH])
    with pytest.raises(ValueError, match=r"InertiaModel.rotors names \['E'\]"):
        mass_matrix(four, 0.0, inertia=inertia_model(four).replace(rotors={"E": 1.0}))
    with pytest.raises(ValueError, match="2 crank angles given: the linkage 'four-bar crank-rocker' has 1"):
        mass_matrix(four, 0.0, 0.0)
