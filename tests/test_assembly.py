"""Assembly: the paper's numbering, rigid-body invariance, energies, and mesh convergence."""

import numpy as np
import pytest
import scipy.linalg

from fivebar import load_params
from fivebar.model.assembly import build_model, paper_b_matrices
from fivebar.model.elements import gauss_points, shape_functions
from fivebar.model.kinematics import rigid_state
from fivebar.analyses.modal import natural_frequencies
from fivebar.description.setup import Setup

P = load_params()
ANGLES = [(0.0, 0.0), (1.1, -2.0), (2.5, 0.7), (-0.8, 3.0)]


def test_paper_numbering_reproduces_A12_up_to_the_misprints():
    m = build_model(P)
    assert m.n == 30  # 32 numbered DOFs, two of them (u9, u31) the motor torsions U4, U8
    numbering = m.paper_numbering()
    assert len(numbering) == 32
    assert numbering[8][1] == "U4" and numbering[30][1] == "U8"
    printed = paper_b_matrices()
    for i in range(3, 9):
        derived = m.B_matrix(i - 3)
        diff = printed[i] - derived
        if i == 6:  # erratum E5: the printed (B6)_{3,21} is the only difference
            assert np.argwhere(diff).tolist() == [[2, 21 - 9]]
            assert diff[2, 21 - 9] == 1
        else:
            assert np.array_equal(printed[i], derived), i


def test_dof_kinds_match_the_paper_list_with_U25_for_the_repeated_U22():
    m = build_model(P, tie_crank_roots=False)
    kinds = {k: [n for n, _, i in m.paper_numbering() if m.dofs[i].kind == k] for k in ("x", "y", "slope", "curvature")}
    assert sorted(kinds["x"] + kinds["y"]) == [11, 12, 15, 16, 19, 20, 23, 24, 27, 28]
    assert kinds["slope"] == [9, 13, 14, 17, 21, 22, 25, 29, 30, 31]
    assert kinds["curvature"] == [10, 18, 26, 32]


@pytest.mark.parametrize("epl", [(1, 2, 2, 1), (2, 3, 3, 2)])
def test_matrices_symmetric_definite(epl):
    m = build_model(P, elements_per_link=epl)
    M, K = m.matrices(*np.array(ANGLES).T)
    for Mi, Ki in zip(M, K):
        assert np.allclose(Mi, Mi.T, atol=0) and np.allclose(Ki, Ki.T, atol=0)
        assert np.linalg.eigvalsh(Mi).min() > 0
        w2 = scipy.linalg.eigh(Ki, Mi, eigvals_only=True)
        assert w2.min() > 1.0  # tied to the motor shafts: no rigid-body mode left


def test_literal_A12_gives_singular_K_with_the_two_mechanism_modes():
    """Erratum E6: untied crank roots leave the 2-DOF mechanism free; its two rigid-body modes
    (from the kinematics, an independent computation) carry no strain energy."""
    m = build_model(P, tie_crank_roots=False)
    for th1, th4 in ANGLES:
        M, K = m.matrices(th1, th4)
        w2 = scipy.linalg.eigh(K, M, eigvals_only=True)
        assert np.sum(np.abs(w2) < 1e-6 * w2.max()) == 2
        for w1, w4 in ((1.0, 0.0), (0.0, 1.0)):
            q = m.rigid_velocity(rigid_state(P, th1, w1, 0.0, th4, w4, 0.0))
            # the motor DOFs do not move in this pattern when untied
            q[:8] = 0.0
            assert q @ K @ q < 1e-9 * (q @ q) * np.abs(K).max()


def test_tied_mechanism_mode_is_resisted_by_the_shaft_torsion_only():
    """Turning crank AB rigidly by d theta twists motor 1's shaft at the coupling end; with
    U3 free, the shaft acts as the series spring G Jp / (l2 + l3)."""
    m = build_model(P)
    mot = P.motors["motor1"]
    GJ = mot.shaft_G * np.pi * mot.shaft_diameter**4 / 32
    for th1, th4 in ANGLES:
        _, K = m.matrices(th1, th4)
        q = m.rigid_velocity(rigid_state(P, th1, 1.0, 0.0, th4, 0.0, 0.0))
        i3, i4 = m.motor_dofs[1][2], m.motor_dofs[1][3]
        assert q[i4] == 1.0
        q[m.motor_dofs[2][3]] = 0.0
        # minimise the energy over U3 (static condensation), by hand
        q[i3] = 0.0
        a = K[i3, i3]
        b = K[i3] @ q
        q[i3] = -b / a
        assert q @ K @ q == pytest.approx(GJ / (mot.l2 + mot.l3), rel=1e-9)


@pytest.mark.parametrize("rotary", [0, 1])
def test_kinetic_energy_of_the_rigid_motion(rotary):
    """1/2 v^T M v for the rigid velocity field equals the rigid-body kinetic energy of the
    links (bars of length L and in-plane depth d) and the lumped masses."""
    p = P.replace(rotary_inertia=rotary)
    m = build_model(p, elements_per_link=(2, 3, 3, 2), tie_crank_roots=False)
    for th1, th4 in ANGLES:
        st = rigid_state(p, th1, 3.0, 0.0, th4, -2.0, 0.0)
        v = m.rigid_velocity(st)
        v[:8] = 0.0
        M, _ = m.matrices(th1, th4)
        T_fe = 0.5 * v @ M @ v
        T = 0.0
        for link, L in zip(("L1", "L2", "L3", "L4"), p.lengths):
            mass = p.rho * p.A * L
            _, vG, _ = st.point(link, 0.5)
            IG = mass * (L**2 + rotary * p.bending_depth**2) / 12
            T += 0.5 * mass * vG @ vG + 0.5 * IG * st.omega[link] ** 2
        T += 0.5 * p.m01 * st.vel["B"] @ st.vel["B"] + 0.5 * p.m02 * st.vel["C"] @ st.vel["C"]
        assert T_fe == pytest.approx(T, rel=1e-12)


def test_inertial_load_is_the_consistent_load_of_the_rigid_acceleration_field():
    """-M u_r'' equals the virtual work of the distributed rigid inertial load, computed by
    quadrature of the acceleration field along each element (an independent route)."""
    p = P.replace(rotary_inertia=0)
    m = build_model(p, tie_crank_roots=False)
    th1, th4 = 0.9, -1.7
    st = rigid_state(p, th1, 4.0, 30.0, th4, 2.5, -12.0)
    M, _ = m.matrices(th1, th4)
    F_fe = -M @ m.rigid_acceleration(st)
    F = np.zeros(m.n)
    for el in m.elements:
        beta = m.element_angles({k: st.angle[k] for k in st.angle})[m.elements.index(el)]
        c, s = np.cos(beta), np.sin(beta)
        x, w = gauss_points(8, el.length)
        N = shape_functions(x, el.length)  # (npts, 8)
        reverse = el.link == "L4"
        frac = el.s0 + x / p.lengths[int(el.link[1]) - 1]
        kin = 1.0 - frac if reverse else frac
        _, _, acc = st.point(el.link, kin)
        a_u = c * acc[:, 0] + s * acc[:, 1]
        a_w = -s * acc[:, 0] + c * acc[:, 1]
        load = np.where(np.isin(np.arange(8), [0, 4]), 1, 0)
        f_loc = -p.rho * p.A * (w[:, None] * N * np.where(load, a_u[:, None], a_w[:, None])).sum(axis=0)
        R = m._rotations(np.asarray(beta))
        f_glob = R.T @ f_loc
        for k, d in enumerate(el.dofs):
            if d >= 0:
                F[d] += f_glob[k]
    for node, mass in m.lumped.items():
        ix, iy = m.node_dofs[node]
        F[[ix, iy]] -= mass * st.acc[node]
    beam = slice(8, None)  # the motor DOFs take the paper's -M u_r'' with U3, U4 -> crank alpha
    assert np.allclose(F_fe[beam], F[beam], rtol=1e-10, atol=1e-10 * np.abs(F).max())
    Mm = m.Mm[1]
    assert np.allclose(F_fe[:4], -Mm @ [0, 0, 30.0, 30.0])


@pytest.mark.parametrize("motors", [True, False])
def test_frozen_frequencies_converge_under_refinement(motors):
    meshes = [(1, 2, 2, 1), (2, 4, 4, 2), (4, 8, 8, 4), (8, 16, 16, 8)]
    f = np.array([natural_frequencies(Setup(P, motors=motors, elements_per_link=e), 0.4, 1.3, n_modes=6) for e in meshes])
    err = np.abs(f[:-1] - f[-1]) / f[-1]
    assert np.all(f[:-1] >= f[-1] * (1 - 1e-9))  # consistent mass: from above (to eigensolver round-off)
    assert np.all(err[1] <= err[0] + 1e-12) and np.all(err[2] <= err[1] + 1e-12)
    assert err[1].max() < 1e-3 and err[0].max() < 2e-2


def test_mean_frequencies_and_averaged_matrix_modes():
    from fivebar.model.kinematics import crank_laws
    from fivebar.analyses.modal import averaged_matrix_modes, frequencies_along_cycle, mean_frequencies

    fm = mean_frequencies(Setup(P, steps_per_period=24), n_modes=4)
    f = frequencies_along_cycle(P, np.arange(24) * np.pi / 12, n_modes=4)
    assert np.allclose(fm, f.mean(axis=0)) and np.all(f.min(0) <= fm) and np.all(fm <= f.max(0))
    md = averaged_matrix_modes(Setup(P, steps_per_period=24), n_modes=5, frame="corotating")
    m = md.model
    t = np.arange(24) * P.period / 24
    th1, _, _, th4, _, _ = crank_laws(P, t)
    M, K = m.matrices(th1, th4)
    T = m.corotating_transform(th1, th4)
    assert np.allclose(np.swapaxes(T, -1, -2) @ T, np.eye(m.n))  # orthogonal
    Mb = (np.swapaxes(T, -1, -2) @ M @ T).mean(0)
    Kb = (np.swapaxes(T, -1, -2) @ K @ T).mean(0)
    assert np.allclose(md.shapes.T @ Mb @ md.shapes, np.eye(5), atol=1e-9)
    assert np.allclose(md.shapes.T @ Kb @ md.shapes, np.diag(md.omega**2), rtol=1e-9, atol=1e-6)
    # frozen at one configuration, the co-rotating frame changes nothing: same frequencies
    M0, K0 = m.matrices(0.3, 0.9)
    T0 = m.corotating_transform(0.3, 0.9)
    import scipy.linalg

    assert np.allclose(
        scipy.linalg.eigh(T0.T @ K0 @ T0, T0.T @ M0 @ T0, eigvals_only=True),
        scipy.linalg.eigh(K0, M0, eigvals_only=True),
        rtol=1e-8,
    )


def test_bad_mesh_and_mode_count():
    with pytest.raises(ValueError, match=r"elements_per_link = \(1, 0, 2, 1\)"):
        build_model(P, elements_per_link=(1, 0, 2, 1))
    with pytest.raises(ValueError, match="n_modes = 0"):
        natural_frequencies(P, 0, 0, n_modes=0)


def test_link_displacement_of_a_known_field():
    """A global displacement field that is a small rigid rotation of each link about its start
    joint (built by hand) gives transverse displacement s L dphi and zero axial, on every mesh
    and for the reversed link L4; its slope is dphi and its curvature zero."""
    for epl in [(1, 2, 2, 1), (3, 3, 5, 2)]:
        m = build_model(P, elements_per_link=epl, tie_crank_roots=False)
        th1, th4 = 0.7, 2.2
        st = rigid_state(P, th1, 1.0, 0.0, th4, 0.0, 0.0)  # rotation of crank AB only
        u = m.rigid_velocity(st) * 1e-3  # displacement of a 1 mrad crank rotation
        for s in (0.0, 0.3, 0.5, 1.0):
            ax, tr = m.link_displacement(u, th1, th4, "L1", s)
            assert ax == pytest.approx(0.0, abs=1e-15) and tr == pytest.approx(1e-3 * s * P.L1, rel=1e-12)
            _, slope = m.link_displacement(u, th1, th4, "L1", s, derivative=1)
            _, curv = m.link_displacement(u, th1, th4, "L1", s, derivative=2)
            assert slope == pytest.approx(1e-3, rel=1e-12) and curv == pytest.approx(0.0, abs=1e-12)
        # crank ED rotating alone: L4 runs E -> D kinematically, the elements run D -> E
        st4 = rigid_state(P, th1, 0.0, 0.0, th4, 1.0, 0.0)
        u4 = m.rigid_velocity(st4) * 1e-3
        for s in (0.0, 0.25, 1.0):
            ax, tr = m.link_displacement(u4, th1, th4, "L4", s)
            assert ax == pytest.approx(0.0, abs=1e-15) and tr == pytest.approx(1e-3 * s * P.L4, rel=1e-12)
            _, slope = m.link_displacement(u4, th1, th4, "L4", s, derivative=1)
            assert slope == pytest.approx(1e-3, rel=1e-12)
    with pytest.raises(ValueError, match="s = 1.5"):
        m.link_displacement(u, th1, th4, "L2", 1.5)


# --- gravity: the weight of every element, at the pins too ---------------------------------------
def _static_gravity(params, mesh, *theta, motors=True):
    """Static deflection K u = F under gravity alone (the crank speeds zero) at frozen crank angles."""
    m = build_model(params, mesh, motors=motors)
    laws = [x for th in theta for x in (th, 0.0, 0.0)]
    st = rigid_state(params, *laws)
    M, K = m.matrices(*theta)
    F = -M @ m.rigid_acceleration(st) + m.prescribed_load(st)
    return m, np.linalg.solve(K, F), F


@pytest.mark.parametrize("elements", [1, 2, 4, 16])
def test_the_slider_crank_rod_under_its_weight_sags_as_the_pinned_beam(elements):
    """At the dead centre the rod lies on the guide, pinned at B and held transversely at C: under
    its own weight its midpoint sags 5 q L^4 / (384 EI), q = rho A g.  The quartic deflection lies
    in the quintic elements' space, so every mesh gives it to round-off.  Before the weight's share
    at the eliminated translations (the rigid crank's pin, the guide) was loaded, one element gave
    no sag at all and 4 elements 8.4 % too little (the error fell as 1/n^2)."""
    import fivebar

    p = fivebar.load_params([fivebar.DEFAULT_PARAMS_PATH, fivebar.SLIDER_CRANK_PARAMS_PATH]).replace(gravity=9.81)
    rod = p.linkage.link("rod")
    m, u, _ = _static_gravity(p, (0, elements), 0.0, motors=False)
    w = float(m.link_displacement(u, 0.0, "rod", 0.5)[1])
    q = rod.material.rho * rod.section.area * p.gravity
    assert w == pytest.approx(-5 * q * rod.length**4 / (384 * rod.material.E * rod.section.I), rel=1e-9)


@pytest.mark.parametrize("motors", [True, False])
def test_the_five_bar_under_its_weight_does_not_depend_on_the_mesh(motors):
    """Each link's static deflection under a uniform weight is a quartic (bending) and a quadratic
    (stretch) whose values at the nodes the elements reproduce exactly, so the links' midpoints
    must not move from the paper's 1-2-2-1 mesh to 4 elements a link (before the fix: 1 % on L2)."""
    p = P.replace(gravity=9.81)
    th = (0.3, 1.2)
    mids = []
    for mesh in ((1, 2, 2, 1), (2, 2, 2, 2), (4, 4, 4, 4)):
        m, u, _ = _static_gravity(p, mesh, *th, motors=motors)
        mids.append([float(m.link_displacement(u, *th, link, 0.5)[1]) for link in ("L1", "L2", "L3", "L4")])
    mids = np.array(mids)
    assert np.abs(mids - mids[-1]).max() <= 1e-9 * np.abs(mids).max()


@pytest.mark.parametrize("theta", [(0.3, 1.2), (2.5, -0.7)])
def test_the_weight_does_the_work_of_the_rigid_potential(theta):
    """Over a rigid motion of the linkage (a unit rotation of one crank, the elastic DOFs following
    rigidly) the load of gravity does the work -dV/dtheta of the rigid model's potential
    (:func:`fivebar.model.rigid.gravity_terms`, from the links' and masses' heights): the elements'
    load must carry the whole weight of every link."""
    from fivebar.model.rigid import gravity_terms

    p = P.replace(gravity=9.81)
    m, _, F = _static_gravity(p, (1, 2, 2, 1), *theta)
    Phi = np.stack([m.rigid_velocity(rigid_state(p, theta[0], w1, 0.0, theta[1], 1.0 - w1, 0.0)) for w1 in (1.0, 0.0)], -1)
    np.testing.assert_allclose(Phi.T @ F, -gravity_terms(p, *theta), rtol=1e-10)
