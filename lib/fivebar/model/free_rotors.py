r"""The flexible linkage with free rotors: the finite-element model of the control analysis.

The prescribed-motion model (2.7) makes the motor rotors the torsional reference: their angles
*are* the crank laws, and the motor torques do not appear.  For control the rotor angles must
be free and the torques must be inputs.  This module builds that model;
:mod:`fivebar.analyses.control.control_model` reduces it to a few modes and writes it as a
:class:`control.StateSpace`, :mod:`fivebar.analyses.control.control_design` designs servo and damping loops
around it, and :mod:`fivebar.analyses.control.control_simulation` closes them along the nominal motion (the
paper's "next step", section 6).

**Five-bar only.**  The model is that of a linkage with two cranks, each driven by the motor
section its joint names (the paper's five-bar): two rotor angles, two torques, the midpoints of
its two couplers.  A description with another number of cranks or motors raises an
:class:`~fivebar.errors.InputError` that says so; the rigid inertia (:func:`rigid_inertia`) and
the feedforward (:func:`feedforward`) serve any description.

**Coordinates.**  Start from the literal assembly of (A.12) (``tie_crank_roots=False``), whose
crank-root slopes :math:`s_A, s_E` are free beam DOFs (absolute small rotations of the crank
roots), and add one absolute angle :math:`\varphi_i` per rotor.  The shaft torsion of the motor
element (A.1)-(A.2) is measured from the rotor (:math:`\psi_3 = \psi_4 = 0` there), so the
absolute angle of a cross-section of shaft :math:`i` is

.. math::

    & \Theta_i(x, t) = \varphi_i(t) + U_3(t)\,\psi_3(x) + U_4(t)\,\psi_4(x), \\
    & U_4 = s_A - \varphi_1 \quad (U_8 = s_E - \varphi_2 \text{ for motor 2}),

the coupling-end twist being the crank-root rotation relative to the rotor (the crank clamped
to the shaft, erratum E6).  The generalised coordinates are

.. math::

    \mathbf p = (\varphi_1, \varphi_2, U_3, U_7, \mathbf u_b),

:math:`\mathbf u_b` the 24 beam DOFs of the paper's mesh (more for a refined one) with
:math:`s_A, s_E` among them; the rotors' transverse DOFs :math:`U_1, U_2, U_5, U_6` do not
couple to the rest (chapter on the dynamics, :mod:`fivebar.model.dynamics`) and are left out.

**Energies.**  The shaft's kinetic energy in absolute rates, with the rotor inertia
:math:`J_0` (section 5) at the rotor, is

.. math::

    T_i ={}& \tfrac12 J_0\dot\varphi_i^2 + \tfrac12\int_0^l \rho_s J_p \dot\Theta_i^2\,dx \\
        ={}& \tfrac12 (J_0 + \rho_s J_p l)\,\dot\varphi_i^2
          + \dot\varphi_i\, \mathbf b^\top \dot{\mathbf U}
          + \tfrac12 \dot{\mathbf U}^\top \bar{\mathbf M}_{1,\mathrm{tor}} \dot{\mathbf U},
    \qquad b_k = \int_0^l \rho_s J_p \psi_k\, dx ,

with :math:`\mathbf U = (U_3, U_4)` and :math:`\bar{\mathbf M}_{1,\mathrm{tor}}` the torsion block
of (A.3); the strain energy is that of (A.4) in the relative twists, unchanged.  The links'
energies are those of the assembly (A.8), (A.11)-(A.12).  The motor torque :math:`\tau_i`
does the virtual work :math:`\tau_i\,\delta\varphi_i`.  At a frozen configuration this gives

.. math::

    \mathbf M_p \ddot{\mathbf p} + \mathbf C_p \dot{\mathbf p} + \mathbf K_p \mathbf p
    = \mathbf B \boldsymbol\tau, \qquad \mathbf B = [\mathbf e_{\varphi_1}, \mathbf e_{\varphi_2}],

with :math:`\mathbf M_p = \mathbf T^\top \mathbf M_r \mathbf T` and :math:`\mathbf K_p =
\mathbf T^\top \mathbf K_r \mathbf T`, :math:`\mathbf T` the map from :math:`\mathbf p` to the
literal model's DOFs plus the rotor angles.

**Rigid modes.**  The linkage with both rotors free is a two-degree-of-freedom mechanism:
:math:`\mathbf K_p\boldsymbol\Phi_r = \mathbf 0` for the two rigid fields of unit crank speeds
(:meth:`fivebar.model.assembly.Model.rigid_velocity`, with :math:`\varphi_i = 1` and no twist), and
:math:`\boldsymbol\Phi_r^\top \mathbf M_p \boldsymbol\Phi_r` is the mass matrix of the rigid
2-DOF dynamics (:func:`fivebar.model.rigid.mass_matrix` with :func:`rigid_inertia`).  With
:math:`J_0 \to \infty` the rotors stand still and the nonzero frequencies tend to those of the
prescribed-motion model with motors (:func:`fivebar.analyses.modal.natural_frequencies`).

**Outputs.**  ``theta1, theta4``: rotor angles :math:`\varphi_i` (what the motor's encoder
reads; collocated with the torque); ``omega1, omega4``: their rates; ``crank1, crank4``: the
crank-root rotations :math:`s_A, s_E` (non-collocated: through the shaft); ``crank_rate1,
crank_rate4``; ``rigid1, rigid4``: :math:`\boldsymbol\eta_r` (the rigid part of the crank angles in
the modal reduction of :mod:`fivebar.analyses.control.control_model`); ``w2, w3``: the transverse
displacement of the midpoint of L2, L3 relative to the rigid motion at the rotor angles,
:math:`w = \mathbf c^\top(\mathbf p - \boldsymbol\Phi_r\boldsymbol\varphi)`
(:meth:`fivebar.model.assembly.Model.link_displacement`), the same quantity as the prescribed-motion
model's midpoint deflection (:meth:`fivebar.analyses.response.Response.midpoint_mm`), in m.

**Left out** (state it wherever results are shown): the velocity-dependent terms of the
nominal motion (Coriolis, centrifugal stiffening, :math:`\dot{\mathbf M}`), as in (2.7); the
geometric nonlinearity (2.8); the rotors' whirl and the electromagnetic terms (they do not
couple, :mod:`fivebar.model.dynamics`); the motors' electrical dynamics, torque limits and any
sampling or measurement noise (the motor is an ideal torque source, states are measured).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from .assembly import Model, build_model
from .elements import gauss_points, motor_shape_functions, shaft_section
from ..errors import ComputationError, InputError
from .kinematics import crank_laws, rigid_state
from ..description.params import Motor, Params
from .rigid import InertiaModel, inertia_model, inverse_dynamics

__all__ = [
    "DEFAULT_OUTPUTS",
    "OUTPUTS",
    "FlexibleLinkage",
    "elastic_frequencies",
    "feedforward",
    "rigid_inertia",
]

#: Output names offered by :meth:`ControlModalModel.statespace`, see the module docstring.
OUTPUTS = (
    "theta1", "theta4", "omega1", "omega4", "crank1", "crank4", "crank_rate1", "crank_rate4",
    "rigid1", "rigid4", "w2", "w3",
)
#: The default outputs, rotor (crank) angles and midpoint deflections of L2 and L3.
DEFAULT_OUTPUTS = ("theta1", "theta4", "w2", "w3")


# --- input checks (shared by the control modules) ----------------------------------------------
def _finite(name: str, value: ArrayLike, unit: str = "rad") -> NDArray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} = {value!r} is not allowed: it must be a finite number ({unit})") from None
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} = {value!r} is not allowed: it must be finite ({unit})")
    return a


def _positive(name: str, value: float, unit: str = "") -> float:
    ok = not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating))
    if not ok or not math.isfinite(value) or value <= 0:
        u = f" ({unit})" if unit else ""
        raise InputError(f"{name} = {value!r} is not allowed: it must be a positive finite number{u}")
    return float(value)


def _count(name: str, value: int, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise InputError(f"{name} = {value!r} is not allowed: it must be an integer in [{lo}, {hi}]")
    return int(value)



def _outputs(names: Sequence[str]) -> tuple[str, ...]:
    if isinstance(names, str):
        names = (names,)
    names = tuple(names)
    bad = [n for n in names if n not in OUTPUTS]
    if bad or not names:
        raise InputError(f"outputs = {names!r} is not allowed: choose from {list(OUTPUTS)}")
    return names



def _two_motor_cranks(params: Params) -> tuple[tuple[str, Motor], ...]:
    """(crank joint, motor) of the two motor-driven cranks the free-rotor model needs."""
    lk = params.linkage
    motors = tuple(params.crank_motors.items())
    if len(lk.cranks) != 2 or len(motors) != 2:
        raise InputError(
            f"the free-rotor control model is of a linkage with two motor-driven cranks (the paper's five-bar); "
            f"the linkage {lk.name!r} has {len(lk.cranks)} driven crank(s), {len(motors)} of them with a motor "
            "(a crank names its motor section with motor = ...)")
    return motors


def _cycle_angles(params: Params, crank_angles: ArrayLike) -> tuple[NDArray, NDArray]:
    _two_motor_cranks(params)
    phi = np.atleast_1d(_finite("crank_angles", crank_angles))
    th1, _, _, th4, _, _ = crank_laws(params, phi / params.crank_speed_rad_s)
    return th1, th4



# --- the rigid model consistent with the flexible one ------------------------------------------
def _shaft_terms(motor: Motor) -> tuple[float, NDArray]:
    """(rho_s J_p l, b) of one motor shaft: polar inertia (kg m^2) and b_k = int rho_s J_p psi_k
    (kg m^2) for the torsion DOFs U3, U4 of (A.2)."""
    _, _, J_p = shaft_section(motor.shaft_diameter)
    b = np.zeros(2)
    for start, length in ((0.0, motor.l1), (motor.l1, motor.l2), (motor.l1 + motor.l2, motor.l3)):
        x, w = gauss_points(6, length)
        psi = motor_shape_functions(x + start, motor)
        b += motor.shaft_rho * J_p * (w @ psi[:, 2:4])
    return motor.shaft_rho * J_p * motor.l, b


def rigid_inertia(params: Params, rotor_inertia_scale: float = 1.0) -> InertiaModel:
    """The rigid inertia model consistent with the flexible model of this module (any
    description: one rotor per motor-driven crank).

    ``inertia = rigid_inertia(params)``; pass it to :func:`fivebar.model.rigid.mass_matrix` or
    :func:`fivebar.model.rigid.inverse_dynamics`.

    Differs from :func:`fivebar.model.rigid.inertia_model` in two small terms that the finite-element
    mass carries: each motor shaft's polar inertia :math:`\\rho_s J_p l` is added to its rotor
    (``shaft_inertia=True``), and each flat bar's centroidal inertia is :math:`m (L^2 + d^2)/12`
    with the in-plane depth :math:`d` when ``params.rotary_inertia`` is 1 (the rotary-inertia
    term of (A.8)).

    Parameters
    ----------
    params
        Parameter set.
    rotor_inertia_scale
        Factor on the rotor inertias J0 (1 = section 5).

    Returns
    -------
    InertiaModel
    """
    s = _positive("rotor_inertia_scale", rotor_inertia_scale)
    base = inertia_model(params, shaft_inertia=False)
    d2 = params.rotary_inertia * params.bending_depth**2
    link_inertia = {k.name: base.link_mass[k.name] * (k.length**2 + d2) / 12.0 for k in params.linkage.links}
    rotors = {joint: s * m.J0 + _shaft_terms(m)[0] for joint, m in params.crank_motors.items()}
    return base.replace(link_inertia=link_inertia, rotors=rotors)


def feedforward(
    params: Params, t: ArrayLike, crank_speed_rpm: float | None = None, rotor_inertia_scale: float = 1.0
) -> NDArray:
    """Motor torques (N m) that drive the nominal motion: the rigid inverse dynamics.

    ``tau_ff = feedforward(params, t)``: :func:`fivebar.model.rigid.inverse_dynamics` along
    :func:`fivebar.model.kinematics.crank_laws` at times ``t`` (s), with :func:`rigid_inertia`, so
    that it equals the flexible model's inertial load projected on its rigid modes.
    ``crank_speed_rpm`` (r/min) defaults to the parameters' ``crank_speed_rpm``.

    Returns
    -------
    ndarray, shape ``t.shape + (2,)``
        (tau1, tau4), positive anticlockwise.
    """
    t = _finite("t", t, "s")
    W = None if crank_speed_rpm is None else _positive("crank_speed_rpm", crank_speed_rpm, "r/min") * math.pi / 30.0
    return inverse_dynamics(params, *crank_laws(params, t, W), inertia=rigid_inertia(params, rotor_inertia_scale))



# --- the full-order model with free rotors ----------------------------------------------------
class FlexibleLinkage:
    """The linkage with free rotors: rotor angles plus every FE DOF (module docstring).

    ``fl = FlexibleLinkage(params)``; ``M, K = fl.matrices(theta1, theta4)``.

    Parameters
    ----------
    params
        Parameter set.
    elements_per_link
        Mesh (default the paper's 1-2-2-1).
    rotor_inertia_scale
        Factor on the rotor inertias J0 (large values clamp the rotors).

    Attributes
    ----------
    model : fivebar.model.assembly.Model
        The literal assembly (``tie_crank_roots=False``) the coordinates are built on.
    labels : list of str
        Names of the coordinates p: ``phi1, phi2`` (rotor angles), ``U3, U7`` (twists at the
        second bearings), then the beam DOFs (:class:`fivebar.model.assembly.Dof` labels).
    n : int
        Number of coordinates.
    rotor, crank : tuple of int
        Indices of the rotor angles and of the crank-root rotations s_A, s_E in p.
    B : ndarray
        Input matrix, shape (n, 2): the motor torques act on the rotor angles.
    """

    def __init__(
        self,
        params: Params,
        elements_per_link: tuple[int, int, int, int] | None = None,
        rotor_inertia_scale: float = 1.0,
    ) -> None:
        drives = _two_motor_cranks(params)
        s = _positive("rotor_inertia_scale", rotor_inertia_scale)
        self.params = params
        self.rotor_inertia_scale = s
        m: Model = build_model(params, elements_per_link=elements_per_link, motors=True, tie_crank_roots=False)
        self.model = m
        lk = params.linkage
        #: the crank links (chain order) and the two couplers whose midpoints are outputs
        self._crank_links = tuple(lk.crank_link(joint).name for joint, _ in drives)
        self._couplers = lk.couplers
        nu = m.n
        transverse = {d for i in (1, 2) for d in m.motor_dofs[i][:2]}
        coupling = {i: m.motor_dofs[i][3] for i in (1, 2)}
        root = {i: m.dof_index(f"{link}@{joint}.slope")
                for i, (link, (joint, _)) in enumerate(zip(self._crank_links, drives), start=1)}
        keep = [d for d in range(nu) if d not in transverse and d not in coupling.values()]
        self.labels = ["phi1", "phi2"] + [m.dofs[d].label for d in keep]
        self.n = n = len(self.labels)
        col = {d: 2 + k for k, d in enumerate(keep)}
        # T: p -> (phi1, phi2, literal model DOFs); U4 = s_A - phi1, U8 = s_E - phi2
        T = np.zeros((nu + 2, n))
        T[0, 0] = T[1, 1] = 1.0
        for d, c in col.items():
            T[2 + d, c] = 1.0
        for i in (1, 2):
            T[2 + coupling[i], col[root[i]]] = 1.0
            T[2 + coupling[i], i - 1] = -1.0
        self._T = T
        self._Tu = T[2:]  # p -> literal model DOFs (rotor transverse zero)
        # the rotors' absolute-rate terms, constant in the configuration
        extra = np.zeros((nu + 2, nu + 2))
        for i, (_, motor) in enumerate(drives, start=1):
            Js, b = _shaft_terms(motor)
            extra[i - 1, i - 1] = s * motor.J0 + Js
            tw = 2 + np.array(m.motor_dofs[i][2:4])
            extra[i - 1, tw] = b
            extra[tw, i - 1] = b
        self._M_extra = T.T @ extra @ T
        self.rotor = (0, 1)
        self.crank = (col[root[1]], col[root[2]])
        self._twist = (col[m.motor_dofs[1][2]], col[m.motor_dofs[2][2]])
        self._beam_cols = np.array([col[d] for d in keep])
        self._beam_src = np.array(keep)
        self.B = np.zeros((n, 2))
        self.B[0, 0] = self.B[1, 1] = 1.0

    # --- matrices ----------------------------------------------------------------------------
    def matrices(self, theta1: ArrayLike, theta4: ArrayLike) -> tuple[NDArray, NDArray]:
        """Mass and stiffness M_p, K_p at crank angles (rad), shape ``(..., n, n)``."""
        th1, th4 = _finite("theta1", theta1), _finite("theta4", theta4)
        Mu, Ku = self.model.matrices(th1, th4)
        Tu = self._Tu
        M = np.swapaxes(Tu, 0, 1) @ Mu @ Tu + self._M_extra
        K = np.swapaxes(Tu, 0, 1) @ Ku @ Tu
        return 0.5 * (M + np.swapaxes(M, -1, -2)), 0.5 * (K + np.swapaxes(K, -1, -2))

    def _from_literal(self, v: NDArray, rotor: NDArray) -> NDArray:
        """A rigid field of the literal model (..., nu) -> p (..., n), no relative twist."""
        out = np.zeros(v.shape[:-1] + (self.n,))
        out[..., self._beam_cols] = v[..., self._beam_src]
        out[..., list(self._twist)] = 0.0
        out[..., 0], out[..., 1] = rotor[..., 0], rotor[..., 1]
        return out

    def rigid_modes(self, theta1: ArrayLike, theta4: ArrayLike) -> NDArray:
        """The two rigid fields of unit crank rotations, shape ``(..., n, 2)``: K_p Phi_r = 0."""
        th1, th4 = np.broadcast_arrays(_finite("theta1", theta1), _finite("theta4", theta4))
        one, zero = np.ones(th1.shape), np.zeros(th1.shape)
        cols = []
        for w1, w4 in ((one, zero), (zero, one)):
            v = self.model.rigid_velocity(rigid_state(self.params, th1, w1, zero, th4, w4, zero))
            cols.append(self._from_literal(v, np.stack([w1, w4], -1)))
        return np.stack(cols, -1)

    def rigid_acceleration(self, theta1, omega1, alpha1, theta4, omega4, alpha4) -> NDArray:
        """Nominal rigid acceleration field a_r in p (as (2.7)'s u_r''), shape ``(..., n)``.

        Rotor entries: the crank accelerations; relative twists: 0; beam DOFs:
        :meth:`fivebar.model.assembly.Model.rigid_acceleration` (gravity included there).
        """
        st = rigid_state(self.params, theta1, omega1, alpha1, theta4, omega4, alpha4)
        a = self.model.rigid_acceleration(st)
        return self._from_literal(a, np.stack([st.alpha[k] for k in self._crank_links], -1))

    def midpoint_rows(self, theta1: ArrayLike, theta4: ArrayLike) -> NDArray:
        """Rows c^T with w = c^T p: transverse displacement (m) of the midpoints of L2, L3,
        total (rigid part not removed), shape ``(..., 2, n)``."""
        th1 = _finite("theta1", theta1)[..., None]
        th4 = _finite("theta4", theta4)[..., None]
        basis = self._Tu.T  # (n, nu): row j is the literal-model vector of unit p_j
        rows = [self.model.link_displacement(basis, th1, th4, link, 0.5)[1] for link in self._couplers]
        return np.stack(rows, -2)

    def elastic_midpoint_rows(self, theta1: ArrayLike, theta4: ArrayLike, Phi_r: NDArray | None = None) -> NDArray:
        """Rows of w2, w3 relative to the rigid motion at the rotor angles: c^T (I - Phi_r S),
        S picking the rotor angles; shape ``(..., 2, n)`` (m per unit p)."""
        c = self.midpoint_rows(theta1, theta4)
        Phi = self.rigid_modes(theta1, theta4) if Phi_r is None else Phi_r
        S = np.zeros((2, self.n))
        S[0, self.rotor[0]] = S[1, self.rotor[1]] = 1.0
        return c - (c @ Phi) @ S

    def output_matrix(self, names: Sequence[str], theta1: float, theta4: float,
                      M: NDArray | None = None, Phi_r: NDArray | None = None) -> tuple[NDArray, NDArray]:
        """(C_pos, C_vel) with y = C_pos p + C_vel p' for the named outputs (:data:`OUTPUTS`)
        at one configuration (``M`` and ``Phi_r`` may be passed to save their computation)."""
        names = _outputs(names)
        n = self.n
        Phi = self.rigid_modes(theta1, theta4) if Phi_r is None else Phi_r
        if M is None:
            M = self.matrices(theta1, theta4)[0]
        Cp = np.zeros((len(names), n))
        Cv = np.zeros((len(names), n))
        W: NDArray | None = None
        for k, name in enumerate(names):
            if name in ("theta1", "theta4", "omega1", "omega4"):
                i = 0 if name[-1] == "1" else 1
                (Cp if name.startswith("theta") else Cv)[k, self.rotor[i]] = 1.0
            elif name.startswith("crank"):
                i = 0 if name[-1] == "1" else 1
                (Cv if "rate" in name else Cp)[k, self.crank[i]] = 1.0
            elif name.startswith("rigid"):
                i = 0 if name[-1] == "1" else 1
                Mr = Phi.T @ M @ Phi
                Cp[k] = np.linalg.solve(Mr, Phi.T @ M)[i]
            else:  # w2, w3: relative to the rigid motion at the rotor angles
                if W is None:
                    W = self.elastic_midpoint_rows(theta1, theta4, Phi)
                Cp[k] = W[0 if name == "w2" else 1]
        return Cp, Cv

    def modes(self, M: NDArray, K: NDArray, Phi_r: NDArray) -> tuple[NDArray, NDArray]:
        """Elastic modes of one configuration: (omega (rad/s), Phi_e (n, n - 2)).

        The two rigid modes are removed; Phi_e is mass-normalised and mass-orthogonal to
        ``Phi_r``.  Raises ``RuntimeError`` if K_p does not have exactly two zero modes.
        """
        w2, V = scipy.linalg.eigh(K, M)
        if not (np.all(np.abs(w2[:2]) < 1e-8 * w2[2]) and w2[2] > 0):
            raise ComputationError(
                f"K_p has not exactly two rigid modes: its lowest omega^2 are {w2[:3]} rad^2/s^2 (two zeros and "
                "a positive third expected, the two cranks' free rotations)"
            )
        Ve = V[:, 2:]
        # remove the round-off component along the rigid modes, renormalise
        Mr = Phi_r.T @ M @ Phi_r
        Ve = Ve - Phi_r @ np.linalg.solve(Mr, Phi_r.T @ M @ Ve)
        Ve = Ve / np.sqrt(np.einsum("ij,ik,kj->j", Ve, M, Ve))
        return np.sqrt(w2[2:]), Ve

    def damping(self, M: NDArray, omega: NDArray, Phi_e: NDArray, zeta: float | None = None) -> NDArray:
        """Modal damping C = M Phi_e diag(2 zeta omega) Phi_e^T M (rigid modes undamped)."""
        z = self.params.damping_ratio if zeta is None else zeta
        MP = M @ Phi_e
        return (MP * (2.0 * z * omega)) @ MP.T



def elastic_frequencies(
    params: Params, crank_angles: ArrayLike, n_modes: int = 4, rotor_inertia_scale: float = 1.0
) -> NDArray:
    """Lowest ``n_modes`` elastic natural frequencies (Hz) of the free-rotor linkage along the
    cycle, shape ``(len(crank_angles), n_modes)`` (the two rigid modes left out)."""
    th1, th4 = _cycle_angles(params, crank_angles)
    fl = FlexibleLinkage(params, rotor_inertia_scale=rotor_inertia_scale)
    n_modes = _count("n_modes", n_modes, 1, fl.n - 2)
    M, K = fl.matrices(th1, th4)
    Phi = fl.rigid_modes(th1, th4)
    return np.array([fl.modes(Mi, Ki, Pi)[0][:n_modes] for Mi, Ki, Pi in zip(M, K, Phi)]) / (2 * np.pi)

