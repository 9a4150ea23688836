"""The linkage description and the generic loop closure: the five-bar against its closed form,
the four-bar against Freudenstein's, finite differences, dead points, bad descriptions, and the
four-bar's frozen frequencies under mesh refinement."""

import tomllib

import numpy as np
import pytest
from crank_laws import general_laws

import fivebar
from fivebar import load_params
from fivebar.model.assembly import build_model
from fivebar.model.kinematics import DeadPointError, GeometryError, constant_speed_laws, positions, rigid_state
from fivebar.description.linkage import Drive, LinkageError
from fivebar.analyses.modal import frequencies_along_cycle
from fivebar.description.setup import Setup
from fivebar.model.dynamics import linkage_dynamics

FIVE = load_params()
FOUR = load_params([fivebar.DEFAULT_PARAMS_PATH, fivebar.FOURBAR_PARAMS_PATH])


# --- references: closed forms written here, independent of the library ------------------------
def _e(b):
    return np.stack([np.cos(b), np.sin(b)], -1)


def _n(b):
    return np.stack([-np.sin(b), np.cos(b)], -1)


def five_bar_closed_form(L, t1, w1, a1, t4, w4, a4, mode=1):
    """Joints and couplers of the five-bar by the two-circle intersection at C and the 2 x 2
    velocity and acceleration systems (the formulas of the paper's Figure 1 geometry)."""
    L1, L2, L3, L4, L5 = L
    B = L1 * _e(t1)
    D = np.array([L5, 0.0]) + L4 * _e(t4)
    d = D - B
    r = np.linalg.norm(d, axis=-1)
    a = (L2**2 - L3**2 + r**2) / (2 * r)
    h = np.sqrt(L2**2 - a**2)
    u = d / r[..., None]
    C = B + a[..., None] * u + mode * h[..., None] * np.stack([-u[..., 1], u[..., 0]], -1)
    b2, b3 = np.arctan2(*(C - B).T[::-1]), np.arctan2(*(D - C).T[::-1])
    vB, vD = L1 * w1[:, None] * _n(t1), L4 * w4[:, None] * _n(t4)
    aB = L1 * (a1[:, None] * _n(t1) - (w1**2)[:, None] * _e(t1))
    aD = L4 * (a4[:, None] * _n(t4) - (w4**2)[:, None] * _e(t4))
    A = np.stack([L2 * _n(b2), L3 * _n(b3)], -1)
    w = np.linalg.solve(A, (vD - vB)[..., None])[..., 0]
    rhs = aD - aB + L2 * (w[:, 0] ** 2)[:, None] * _e(b2) + L3 * (w[:, 1] ** 2)[:, None] * _e(b3)
    al = np.linalg.solve(A, rhs[..., None])[..., 0]
    vC = vB + L2 * w[:, :1] * _n(b2)
    aC = aB + L2 * (al[:, :1] * _n(b2) - (w[:, :1] ** 2) * _e(b2))
    return dict(B=B, C=C, D=D, vB=vB, vC=vC, vD=vD, aB=aB, aC=aC, aD=aD,
                b2=b2, b3=b3, w2=w[:, 0], w3=w[:, 1], al2=al[:, 0], al3=al[:, 1])


def freudenstein_rocker(a, b, c, d, theta):
    """Both rocker angles (of C - D) of a four-bar with crank a at A = 0, coupler b, rocker c at
    D = (d, 0), from Freudenstein's equation K1 cos(phi) - K2 cos(theta) + K3 = cos(theta - phi)
    by the tangent half-angle substitution."""
    K1, K2, K3 = d / a, d / c, (a**2 - b**2 + c**2 + d**2) / (2 * a * c)
    A = np.cos(theta) - K1 - K2 * np.cos(theta) + K3
    B = -2 * np.sin(theta)
    C = K1 - (K2 + 1) * np.cos(theta) + K3
    root = np.sqrt(B**2 - 4 * A * C)
    return 2 * np.arctan((-B - root) / (2 * A)), 2 * np.arctan((-B + root) / (2 * A))


def _wrap(x):
    return np.angle(np.exp(1j * x))


# --- the five-bar: the generic closure is the closed form --------------------------------------
@pytest.mark.parametrize("mode", [1, -1])
def test_five_bar_generic_closure_equals_the_closed_form(mode):
    t = np.linspace(0.0, 3.0, 301)
    laws = general_laws(t)
    ref = five_bar_closed_form(FIVE.lengths, *laws, mode=mode)
    s = rigid_state(FIVE, *laws, mode=mode)
    for j in "BCD":
        assert np.abs(s.pos[j] - ref[j]).max() < 1e-12
        assert np.abs(s.vel[j] - ref["v" + j]).max() < 1e-12 * 10
        assert np.abs(s.acc[j] - ref["a" + j]).max() < 1e-12 * 100
    for k, name in (("2", "L2"), ("3", "L3")):
        assert np.abs(_wrap(s.angle[name] - ref["b" + k])).max() < 1e-12
        assert np.abs(s.omega[name] - ref["w" + k]).max() < 1e-12 * 10
        assert np.abs(s.alpha[name] - ref["al" + k]).max() < 1e-12 * 100


def test_five_bar_description_reads_the_paper():
    lk = FIVE.linkage
    assert lk.chain == ("A", "B", "C", "D", "E") and lk.link_names == ("L1", "L2", "L3", "L4")
    assert [j.name for j in lk.cranks] == ["A", "E"] and lk.motors == (("A", "motor1"), ("E", "motor2"))
    assert lk.masses == {"B": 0.142, "C": 0.092, "D": 0.0}
    assert lk.default_mesh == (1, 2, 2, 1) and lk.couplers == ("L2", "L3")
    # an entry the description refers to moves the linkage
    q = FIVE.replace(L5=0.45)
    assert q.linkage.joint("E").at == (0.45, 0.0) and q.lengths[-1] == 0.45


# --- the four-bar: Freudenstein, finite differences, the drive laws ----------------------------
def test_four_bar_rocker_against_freudenstein():
    theta = np.linspace(0.0, 2 * np.pi, 181)
    s = constant_speed_laws(FOUR, theta / FOUR.crank_speed_rad_s)
    a, b, c, d = FOUR.lengths
    open_, crossed = freudenstein_rocker(a, b, c, d, theta)
    err = np.abs(_wrap(s.angle["rocker"] - open_))
    other = np.abs(_wrap(s.angle["rocker"] - crossed))
    assert err.max() < 1e-12 and other.min() > 0.1  # one branch, the same all the way round
    # the rocker swings between the two extreme positions of the crank-rocker
    rmin = np.pi - np.arccos((c**2 + d**2 - (b + a) ** 2) / (2 * c * d))
    assert np.isclose(s.angle["rocker"].min(), rmin, atol=1e-4)


def test_four_bar_velocities_and_accelerations_against_finite_differences():
    law = Drive(theta0=0.3, ratio=1.0, fourier=((0.2, -0.1), (0.05, 0.0)))
    lk = FOUR.linkage
    crank = lk.cranks[0]
    from dataclasses import replace

    joints = tuple(replace(j, drive=law) if j is crank else j for j in lk.joints)
    p = replace(FOUR, linkage=replace(lk, joints=joints))  # a Python drive law
    W, h = 7.0, 1e-5
    t = np.linspace(0.0, 2 * np.pi / W, 41)
    th, w, al = law.laws(t, W)
    thp, thm = law.laws(t + h, W)[0], law.laws(t - h, W)[0]
    assert np.allclose(w, (thp - thm) / (2 * h), atol=1e-7)
    assert np.allclose(al, (law.laws(t + h, W)[1] - law.laws(t - h, W)[1]) / (2 * h), atol=1e-5)
    s0 = rigid_state(p, th, w, al)
    sp = rigid_state(p, *law.laws(t + h, W))
    sm = rigid_state(p, *law.laws(t - h, W))
    assert np.allclose(s0.angle["crank"], th)
    for j in "BC":
        assert np.allclose(s0.vel[j], (sp.pos[j] - sm.pos[j]) / (2 * h), rtol=0, atol=1e-7)
        assert np.allclose(s0.acc[j], (sp.pos[j] - 2 * s0.pos[j] + sm.pos[j]) / h**2, rtol=0, atol=5e-3)
    for k in ("coupler", "rocker"):
        assert np.allclose(s0.omega[k], _wrap(sp.angle[k] - sm.angle[k]) / (2 * h), rtol=0, atol=1e-7)
        assert np.allclose(s0.alpha[k], (sp.omega[k] - sm.omega[k]) / (2 * h), rtol=0, atol=1e-4)
    # a function law gives the same state as the Fourier law it evaluates
    fn = Drive(function=lambda t, W: law.laws(t, W))
    assert np.allclose(fn.laws(t, W)[2], al)


def test_dead_point_and_no_closure_name_the_crank_angle():
    lk = _doc()
    for b, c, err, words in ((0.25, 0.25, DeadPointError, "dead point at crank angles A = 180 deg"),
                             (0.2, 0.2, GeometryError, "cannot close at crank angles A = ")):
        lk["links"]["coupler"]["length"], lk["links"]["rocker"]["length"] = b, c
        p = _with_linkage(FIVE, lk)
        with pytest.raises(err, match=words):
            constant_speed_laws(p, np.linspace(0.0, p.period, 73))


def _with_linkage(p, doc):
    return p.replace(linkage=doc)


# --- bad descriptions ------------------------------------------------------------------------
def _doc():
    return tomllib.loads(fivebar.FOURBAR_PARAMS_PATH.read_text())["linkage"]


@pytest.mark.parametrize(
    "change, words",
    [
        (lambda d: d["links"]["coupler"].update(length=-0.35), "linkage.links.coupler.length = -0.35"),
        (lambda d: d["links"]["rocker"].update(start="A"), "linkage.links.rocker: start = 'A'"),
        (lambda d: d["joints"]["D"].update(kind="crank"), "3 links and 2 driven cranks"),
        (lambda d: d["joints"]["B"].update(kind="ground"), "linkage.joints.B.kind = 'ground'"),
        (lambda d: d["joints"]["A"].update(motor="motor7"), "linkage.joints.A.motor = 'motor7'"),
        (lambda d: d["joints"]["A"].update(speed=3), "linkage.joints.A: unknown entries ['speed']"),
        (lambda d: d["assembly"].update(joint="B"), "linkage.assembly.joint = 'B'"),
        (lambda d: d["assembly"].update(side="up"), "linkage.assembly.side = 'up'"),
        (lambda d: d.update(chain=["A", "B", "A"]), "linkage.chain"),
        (lambda d: d["joints"]["C"].update(mass="masses.m99"), "linkage.joints.C.mass = 'masses.m99'"),
    ],
)
def test_bad_descriptions_name_the_entry(change, words):
    d = _doc()
    change(d)
    with pytest.raises(LinkageError) as info:
        _with_linkage(FIVE, d)
    assert words in str(info.value)
    assert isinstance(info.value, fivebar.ParameterError)


def test_mesh_is_validated_from_the_link_count():
    with pytest.raises(fivebar.FivebarError, match=r"give 3 integers >= 1 \(elements on crank, coupler, rocker\)"):
        build_model(FOUR, elements_per_link=(1, 2, 2, 1))
    with pytest.raises(fivebar.FivebarError, match=r"give 4 integers >= 1"):
        fivebar.Setup(FIVE, elements_per_link=(1, 2, 2))


# --- the four-bar's frozen modes ---------------------------------------------------------------
def test_four_bar_frozen_frequencies_converge_from_above_under_refinement():
    """Nested conforming meshes (each halving the last) give non-increasing eigenvalues
    (Rayleigh-Ritz); the description's mesh is within 1e-4 of one eight times finer."""
    phi = np.linspace(0.0, 2 * np.pi, 5)[:-1]
    meshes = [(1, 2, 2), (2, 4, 4), (4, 8, 8), (8, 16, 16)]
    f = [frequencies_along_cycle(Setup(FOUR, elements_per_link=e), phi, n_modes=4) for e in meshes]
    for coarse, fine in zip(f, f[1:]):
        assert np.all(coarse >= fine * (1 - 1e-12))
    err = [np.abs(x - f[-1]) / f[-1] for x in f[:-1]]
    assert np.all(err[0] >= err[1]) and np.all(err[1] >= err[2])
    assert err[0][:, :3].max() < 1e-4
    # the crank's motion changes the lowest frequency along the cycle by more than 15 %
    assert np.ptp(f[-1][:, 0]) / f[-1][:, 0].mean() > 0.15


# --- the four-bar against the independent multibody model (Exudyn) ---------------------------
def test_four_bar_frozen_frequencies_against_the_multibody_model():
    pytest.importorskip("exudyn")
    from fivebar.analyses import multibody

    same = FOUR.replace(rotary_inertia=0)  # ANCF cables carry no rotary inertia
    for theta in (0.0, 2.0, 4.5):
        f_mb = multibody.multibody_frequencies(Setup(FOUR, elements_per_link=(4, 8, 8)), theta, n_modes=3)
        f = fivebar.natural_frequencies(Setup(same, elements_per_link=(4, 8, 8)), theta, n_modes=3)
        assert np.allclose(f, f_mb, rtol=1e-4), (theta, f, f_mb)


def test_four_bar_steady_response_against_the_multibody_model():
    """At 600 r/min the KED steady state (linear, prescribed rigid motion) and the fully coupled
    multibody model give the same midpoint curves of the coupler and the rocker to 1 % of their
    peak-to-peak values (measured: 0.1 %)."""
    pytest.importorskip("exudyn")
    from fivebar.analyses import multibody

    mb = multibody.multibody_steady_state(Setup(FOUR, crank_speed_rpm=600, steps_per_period=100), integration_steps=400)
    ked = fivebar.steady_state(Setup(FOUR, crank_speed_rpm=600, steps_per_period=400, elements_per_link=(2, 4, 4)))
    for link in ("coupler", "rocker"):
        for d in ("transverse", "chord"):
            y_mb, y = mb.midpoint_mm(link, d), ked.midpoint_mm(link, d)[::4]
            assert np.ptp(y) > 0.02  # mm: a response well above round-off
            assert np.abs(y_mb - y).max() < 0.01 * np.ptp(y), (link, d)


def test_the_control_model_and_the_excitation_table_take_the_four_bar():
    """The free-rotor control model and the excitation table were of two motor-driven cranks
    (issue 34): the four-bar gets one input, the crank's root rotation (no motor), one rigid
    mode, and one excitation frequency, its crank's; a driven slider, which has no torque input,
    is refused by name."""
    from fivebar.errors import FivebarError
    from fivebar.model.excitation import excitation_frequencies
    from fivebar.model.free_rotors import FlexibleLinkage, elastic_frequencies, rigid_inertia

    fl = FlexibleLinkage(FOUR)
    assert fl.inputs == 1 and fl.labels[0] == "phi1" and fl.default_outputs == ("theta1", "w2")
    M, K = fl.matrices(0.3)
    w2 = np.linalg.eigvalsh(np.linalg.solve(np.linalg.cholesky(M), np.linalg.solve(np.linalg.cholesky(M), K).T))
    assert abs(w2[0]) < 1e-8 * w2[1]  # one rigid mode: the crank turns freely
    assert elastic_frequencies(FOUR, [0.0], n_modes=2).shape == (1, 2)
    df = excitation_frequencies(FOUR)
    assert list(df.index) == ["nu1"] and np.isclose(df.loc["nu1", "frequency (rad/s)"], FOUR.crank_speed_rad_s)
    assert rigid_inertia(FOUR).rotors == {}  # the rigid inertia serves any description
    assert FOUR.crank_motors == {} and list(FOUR.motors) == ["motor1", "motor2"]  # the layered file's sections
    slider_drive = {"name": "slider-driven", "assembly": [{"joint": "B", "side": "left", "line": ["A", "C"]}],
                    "links": {"crank": {"start": "A", "end": "B", "length": 0.15},
                              "rod": {"start": "B", "end": "C", "length": 0.30}},
                    "joints": {"A": {"kind": "ground", "at": [0.0, 0.0]}, "B": {"kind": "pin"},
                               "C": {"kind": "slider", "guide": {"at": [0.0, 0.0], "angle": 0.0},
                                     "drive": {"s0": 0.3, "fourier": [[0.05, 0.0]]}}}}
    with pytest.raises(FivebarError, match=r"drives the slider\(s\) \['C'\], whose force input it does not have"):
        FlexibleLinkage(FOUR.replace(linkage=slider_drive))


def test_four_bar_brute_force_and_speed_report_use_its_own_links():
    """The branch tools take their default link from the description (the four-bar's coupler;
    they read L2 and two crank angles before): the brute-force Poincaré sample of a long march
    at 600 r/min is the shot orbit's coupler midpoint at crank angle 0 (a second method: no
    Newton on periodicity), and a report of the speed names a stable orbit."""
    from fivebar.analyses.branches import brute_force_diagram, describe_speed
    from fivebar.errors import InputError

    s = Setup(FOUR, crank_speed_rpm=600, steps_per_period=200, motors=False)
    bf = brute_force_diagram(s, [600.0], transient=60, samples=3, both_ways=False)
    assert bf.link == "coupler" and not bf.diverged[0]
    ref = fivebar.steady_state(s).midpoint_mm("coupler")[0]
    assert abs(ref) > 1e-4  # mm: a deflection well above round-off
    assert np.abs(bf.samples_mm[0] - ref).max() < 1e-6 * np.abs(ref) + 1e-9
    assert describe_speed(s).kind == "stable period-1"
    with pytest.raises(InputError, match="'L2' is not allowed: give one of the links"):
        brute_force_diagram(s, [600.0], transient=1, samples=1, link="L2")


def test_four_bar_nonlinear_force_between_the_step_times():
    """Off the step times the nonlinear force is computed from the crank angles (one crank for
    the four-bar; two were unpacked before): it joins the sampled values at the step times
    continuously, its change from a step time first order in the time offset."""
    dyn = linkage_dynamics(Setup(FOUR, crank_speed_rpm=600, steps_per_period=40, motors=False))
    rng = np.random.default_rng(3)
    u = 1e-3 * rng.standard_normal(dyn.n)
    f0, K0 = dyn.nonlinear(u, 5 * dyn.dt)  # a step time: the sampled configuration
    assert np.abs(f0).max() > 0
    d = [np.abs(dyn.nonlinear(u, 5 * dyn.dt + h * dyn.dt)[0] - f0).max() for h in (1e-3, 5e-4)]
    assert 0 < d[1] < d[0] < 1e-2 * np.abs(f0).max()
    assert 1.8 < d[0] / d[1] < 2.2  # first order in the offset
