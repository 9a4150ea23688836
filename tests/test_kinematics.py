"""Rigid kinematics: loop closure, finite differences, bad geometry."""

import numpy as np
import pytest
from crank_laws import general_laws as _general_laws

from fivebar import load_params
from fivebar.model.kinematics import (
    GeometryError,
    LINKS,
    constant_speed_laws,
    crank_laws,
    link_angles,
    positions,
    rigid_state,
)

P = load_params()


def test_link_lengths_and_assembly_mode():
    t1 = np.linspace(0, 2 * np.pi, 73)
    t4 = 2.3 * t1 + 0.4  # independent crank angles: every pair closes
    for mode in (1, -1):
        X = positions(P, t1, t4, mode)
        for (name, (s, e)), L in zip(LINKS.items(), P.lengths[:4]):
            assert np.allclose(np.linalg.norm(X[e] - X[s], axis=-1), L, rtol=0, atol=1e-12)
        d, c = X["D"] - X["B"], X["C"] - X["B"]
        assert np.all(mode * (d[:, 0] * c[:, 1] - d[:, 1] * c[:, 0]) > 0)
    X = positions(P, 0.0, 0.0)
    assert X["C"][1] > 0  # C above AE by default
    assert np.allclose(X["D"], [P.L5 + P.L4, 0.0])


def test_every_pair_of_crank_angles_closes():
    g = np.linspace(0, 2 * np.pi, 61)
    t1, t4 = np.meshgrid(g, g)
    positions(P, t1, t4)  # raises if any pair fails


def test_geometry_that_cannot_close_names_angles_and_BD():
    q = P.replace(L2=0.15, L3=0.15)
    with pytest.raises(GeometryError, match=r"crank angles A = 0 deg, E = 0 deg: \|BD\| = 350 mm"):
        positions(q, 0.0, 0.0)
    with pytest.raises(ValueError, match="assembly mode 0"):
        positions(P, 0.0, 0.0, mode=0)


def test_velocities_and_accelerations_against_finite_differences():
    t = np.linspace(0.0, 2.0, 41)
    h = 1e-5
    s0 = rigid_state(P, *_general_laws(t))
    sp = rigid_state(P, *_general_laws(t + h))
    sm = rigid_state(P, *_general_laws(t - h))
    for j in "BCD":
        fd_v = (sp.pos[j] - sm.pos[j]) / (2 * h)
        fd_a = (sp.pos[j] - 2 * s0.pos[j] + sm.pos[j]) / h**2
        assert np.allclose(s0.vel[j], fd_v, rtol=0, atol=1e-7)
        assert np.allclose(s0.acc[j], fd_a, rtol=0, atol=2e-3)
    for k in LINKS:
        fd_w = np.angle(np.exp(1j * (sp.angle[k] - sm.angle[k]))) / (2 * h)
        fd_al = (sp.omega[k] - sm.omega[k]) / (2 * h)
        assert np.allclose(s0.omega[k], fd_w, rtol=0, atol=1e-7)
        assert np.allclose(s0.alpha[k], fd_al, rtol=0, atol=1e-5)


def test_point_on_link_matches_joints_and_finite_differences():
    t = np.linspace(0.0, 1.0, 11)
    h = 1e-5
    s0 = rigid_state(P, *_general_laws(t))
    for k, (a, b) in LINKS.items():
        for frac, joint in ((0.0, a), (1.0, b)):
            p, v, acc = s0.point(k, frac)
            assert np.allclose(p, s0.pos[joint], atol=1e-12)
            assert np.allclose(v, s0.vel[joint], atol=1e-9)
            assert np.allclose(acc, s0.acc[joint], atol=1e-7)
    pp = rigid_state(P, *_general_laws(t + h)).point("L2", 0.5)[0]
    pm = rigid_state(P, *_general_laws(t - h)).point("L2", 0.5)[0]
    _, v, acc = s0.point("L2", 0.5)
    assert np.allclose(v, (pp - pm) / (2 * h), atol=1e-7)
    assert np.allclose(acc, (pp - 2 * s0.point("L2", 0.5)[0] + pm) / h**2, atol=2e-3)


def test_constant_speed_laws_and_link_angles():
    t = np.linspace(0.0, P.period, 5)
    th1, w1, a1, th4, w4, a4 = crank_laws(P, t)
    assert np.allclose(th1[-1] - th1[0], 2 * np.pi) and np.all(a1 == 0)
    s = constant_speed_laws(P, t)
    ang = link_angles(P, th1, th4)
    for k in LINKS:
        assert np.allclose(np.angle(np.exp(1j * (ang[k] - s.angle[k]))), 0, atol=1e-12)
    # one period later the linkage is back where it started
    assert np.allclose(s.pos["C"][0], s.pos["C"][-1], atol=1e-12)
    with pytest.raises(ValueError, match="crank_speed_rad_s = -1"):
        crank_laws(P, t, crank_speed_rad_s=-1)
