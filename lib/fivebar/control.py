r"""Linearised control analysis of the flexible five-bar (the paper's "next step", section 6).

The prescribed-motion model (2.7) makes the motor rotors the torsional reference: their angles
*are* the crank laws, and the motor torques do not appear.  For control the rotor angles must
be free and the torques must be inputs.  This module builds that model, reduces it to a few
modes, writes it as a :class:`control.StateSpace`, and closes servo and damping loops around
it, at frozen configurations and along the nominal motion.

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
couple to the rest (chapter on the dynamics, :mod:`fivebar.dynamics`) and are left out.

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
(:meth:`fivebar.assembly.Model.rigid_velocity`, with :math:`\varphi_i = 1` and no twist), and
:math:`\boldsymbol\Phi_r^\top \mathbf M_p \boldsymbol\Phi_r` is the mass matrix of the rigid
2-DOF dynamics (:func:`fivebar.rigid.mass_matrix` with :func:`rigid_inertia`).  With
:math:`J_0 \to \infty` the rotors stand still and the nonzero frequencies tend to those of the
prescribed-motion model with motors (:func:`fivebar.modal.natural_frequencies`).

**Modal reduction.**  With the elastic modes :math:`\boldsymbol\Phi_e` (mass-normalised,
:math:`\boldsymbol\Phi_e^\top \mathbf M_p \boldsymbol\Phi_r = \mathbf 0`),
:math:`\mathbf p \approx \boldsymbol\Phi_r\boldsymbol\eta_r + \boldsymbol\Phi_e\boldsymbol\eta_e`:

.. math::

    \mathbf M_{\mathrm{rig}}\ddot{\boldsymbol\eta}_r = \boldsymbol\tau, \qquad
    \ddot\eta_j + 2\zeta\omega_j\dot\eta_j + \omega_j^2 \eta_j
      = \boldsymbol\phi_j^\top \mathbf B\boldsymbol\tau \quad (j = 1..n_{\mathrm{modes}}),

(:math:`\boldsymbol\Phi_r^\top\mathbf B = \mathbf I`), the modal damping ratio
:math:`\zeta` of the parameters on every elastic mode and none on the rigid modes (a rigid
rotation dissipates nothing).  :math:`\boldsymbol\eta_r` is the rigid part of the crank angles.

**Outputs.**  ``theta1, theta4``: rotor angles :math:`\varphi_i` (what the motor's encoder
reads; collocated with the torque); ``omega1, omega4``: their rates; ``crank1, crank4``: the
crank-root rotations :math:`s_A, s_E` (non-collocated: through the shaft); ``crank_rate1,
crank_rate4``; ``rigid1, rigid4``: :math:`\boldsymbol\eta_r`; ``w2, w3``: the transverse
displacement of the midpoint of L2, L3 relative to the rigid motion at the rotor angles,
:math:`w = \mathbf c^\top(\mathbf p - \boldsymbol\Phi_r\boldsymbol\varphi)`
(:meth:`fivebar.assembly.Model.link_displacement`), the same quantity as the prescribed-motion
model's midpoint deflection (:meth:`fivebar.steady.SteadyState.midpoint`), in m.

**Along the motion.**  Linearised about the nominal motion (crank laws
:func:`fivebar.kinematics.crank_laws`), with :math:`\mathbf p` the deviation from the nominal
rigid configuration, the kineto-elastodynamic equation of (2.7) with free rotors reads

.. math::

    \mathbf M_p(t)\ddot{\mathbf p} + \mathbf C_p(t)\dot{\mathbf p} + \mathbf K_p(t)\mathbf p
    = -\mathbf M_p(t)\,\mathbf a_r(t) + \mathbf B\big(\boldsymbol\tau_{ff}(t)
      + \boldsymbol\tau_{fb}\big),

:math:`\mathbf a_r` the nominal rigid acceleration field (rotor entries: the crank
accelerations), :math:`\boldsymbol\tau_{ff}` the inverse dynamics of the rigid model
(:func:`feedforward`, equal to :math:`\boldsymbol\Phi_r^\top\mathbf M_p\mathbf a_r`, so it
balances the rigid modes exactly), and :math:`\boldsymbol\tau_{fb} = -\mathbf G_p(t)\mathbf p
- \mathbf G_v(t)\dot{\mathbf p}` the servo and damping feedback.  :func:`simulate_cycle`
integrates it with :func:`fivebar.newmark.integrate`.  With the rotors held on the nominal
motion (an ideal servo) it is exactly the linear prescribed-motion model.

**Left out** (state it wherever results are shown): the velocity-dependent terms of the
nominal motion (Coriolis, centrifugal stiffening, :math:`\dot{\mathbf M}`), as in (2.7); the
geometric nonlinearity (2.8); the rotors' whirl and the electromagnetic terms (they do not
couple, :mod:`fivebar.dynamics`); the motors' electrical dynamics, torque limits and any
sampling or measurement noise (the motor is an ideal torque source, states are measured).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import control
import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from .errors import ComputationError, InputError, InputTypeError
from .assembly import Model, build_model
from .elements import gauss_points, motor_shape_functions, shaft_section
from .kinematics import LINKS, crank_laws, rigid_state
from .newmark import PeriodicStepData, Scheme, System, integrate
from .params import Motor, Params
from .rigid import InertiaModel, inertia_model, inverse_dynamics
from .setup import Setup, as_setup

__all__ = [
    "OUTPUTS",
    "DEFAULT_OUTPUTS",
    "FlexibleLinkage",
    "ControlModalModel",
    "Servo",
    "CycleSimulation",
    "rigid_inertia",
    "feedforward",
    "control_modal_model",
    "linear_model",
    "models_along_cycle",
    "elastic_frequencies",
    "pd_servo",
    "damping_lqr",
    "damping_schedule",
    "schedule",
    "simulate_cycle",
]

#: Output names offered by :meth:`ControlModalModel.statespace`, see the module docstring.
OUTPUTS = (
    "theta1", "theta4", "omega1", "omega4", "crank1", "crank4", "crank_rate1", "crank_rate4",
    "rigid1", "rigid4", "w2", "w3",
)
#: The default outputs, rotor (crank) angles and midpoint deflections of L2 and L3.
DEFAULT_OUTPUTS = ("theta1", "theta4", "w2", "w3")
_INPUTS = ("tau1", "tau4")
_MEASURES = ("rotor", "crank")


# --- input checks ----------------------------------------------------------------------------
def _finite(name: str, value: ArrayLike) -> NDArray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} = {value!r} is not allowed: it must be a finite number (rad)") from None
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} = {value!r} is not allowed: it must be finite (rad)")
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
    """The rigid 2-DOF inertia model consistent with the flexible model of this module.

    ``inertia = rigid_inertia(params)``; pass it to :func:`fivebar.rigid.mass_matrix` or
    :func:`fivebar.rigid.inverse_dynamics`.

    Differs from :func:`fivebar.rigid.inertia_model` in two small terms that the finite-element
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
    lengths = dict(zip(LINKS, params.lengths[:4]))
    link_inertia = {k: base.link_mass[k] * (L**2 + d2) / 12.0 for k, L in lengths.items()}
    J = [s * m.J0 + _shaft_terms(m)[0] for m in (params.motor1, params.motor2)]
    return base.replace(link_inertia=link_inertia, J1=J[0], J2=J[1])


def feedforward(
    params: Params, t: ArrayLike, crank_speed: float | None = None, rotor_inertia_scale: float = 1.0
) -> NDArray:
    """Motor torques (N m) that drive the nominal motion: the rigid inverse dynamics.

    ``tau_ff = feedforward(params, t)``: :func:`fivebar.rigid.inverse_dynamics` along
    :func:`fivebar.kinematics.crank_laws` at times ``t`` (s), with :func:`rigid_inertia`, so
    that it equals the flexible model's inertial load projected on its rigid modes.

    Returns
    -------
    ndarray, shape ``t.shape + (2,)``
        (tau1, tau4), positive anticlockwise.
    """
    t = _finite("t", t)
    return inverse_dynamics(
        params, *crank_laws(params, t, crank_speed), inertia=rigid_inertia(params, rotor_inertia_scale)
    )


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
    model : fivebar.assembly.Model
        The literal assembly (``tie_crank_roots=False``) the coordinates are built on.
    labels : list of str
        Names of the coordinates p: ``phi1, phi2`` (rotor angles), ``U3, U7`` (twists at the
        second bearings), then the beam DOFs (:class:`fivebar.assembly.Dof` labels).
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
        s = _positive("rotor_inertia_scale", rotor_inertia_scale)
        self.params = params
        self.rotor_inertia_scale = s
        m: Model = build_model(params, elements_per_link=elements_per_link, motors=True, tie_crank_roots=False)
        self.model = m
        nu = m.n
        transverse = {d for i in (1, 2) for d in m.motor_dofs[i][:2]}
        coupling = {i: m.motor_dofs[i][3] for i in (1, 2)}
        root = {1: m.dof_index("L1@A.slope"), 2: m.dof_index("L4@E.slope")}
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
        for i, motor in ((1, params.motor1), (2, params.motor2)):
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
        :meth:`fivebar.assembly.Model.rigid_acceleration` (gravity included there).
        """
        st = rigid_state(self.params, theta1, omega1, alpha1, theta4, omega4, alpha4)
        a = self.model.rigid_acceleration(st)
        return self._from_literal(a, np.stack([st.alpha["L1"], st.alpha["L4"]], -1))

    def midpoint_rows(self, theta1: ArrayLike, theta4: ArrayLike) -> NDArray:
        """Rows c^T with w = c^T p: transverse displacement (m) of the midpoints of L2, L3,
        total (rigid part not removed), shape ``(..., 2, n)``."""
        th1 = _finite("theta1", theta1)[..., None]
        th4 = _finite("theta4", theta4)[..., None]
        basis = self._Tu.T  # (n, nu): row j is the literal-model vector of unit p_j
        rows = [self.model.link_displacement(basis, th1, th4, link, 0.5)[1] for link in ("L2", "L3")]
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
            raise ComputationError(f"expected exactly two rigid modes, found omega^2 = {w2[:3]}")
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


# --- the reduced model ---------------------------------------------------------------------------
@dataclass
class ControlModalModel:
    """Modal reduction of the free-rotor linkage at one frozen configuration.

    Build it with :func:`control_modal_model`.  The state is ``x = (eta_r, eta_e, eta_r', eta_e')``,
    ``eta_r`` the rigid crank angles (rad) and ``eta_e`` the mass-normalised elastic modal
    coordinates.

    Attributes
    ----------
    linkage : FlexibleLinkage
    theta1, theta4 : float
        The frozen crank angles (rad).
    omega : ndarray
        Elastic natural frequencies (rad/s) of the retained modes.
    zeta : float
        Modal damping ratio of the elastic modes.
    M, K : ndarray
        Full-order matrices at the configuration, shape (n, n).
    Phi_r, Phi_e : ndarray
        Rigid modes, shape (n, 2), and retained elastic modes, shape (n, n_modes).
    M_rigid : ndarray
        Rigid mass matrix Phi_r^T M Phi_r (kg m^2), shape (2, 2).
    A, B : ndarray
        State matrices, shapes (nx, nx) and (nx, 2), nx = 2 (2 + n_modes).
    """

    linkage: FlexibleLinkage
    theta1: float
    theta4: float
    omega: NDArray
    zeta: float
    M: NDArray = field(repr=False)
    K: NDArray = field(repr=False)
    Phi_r: NDArray = field(repr=False)
    Phi_e: NDArray = field(repr=False)
    M_rigid: NDArray = field(repr=False)
    A: NDArray = field(repr=False)
    B: NDArray = field(repr=False)

    @property
    def n_modes(self) -> int:
        """Number of retained elastic modes."""
        return len(self.omega)

    @property
    def frequencies(self) -> NDArray:
        """Elastic natural frequencies (Hz) of the retained modes."""
        return self.omega / (2.0 * np.pi)

    @property
    def state_names(self) -> list[str]:
        """Names of the states (rigid angles, modal coordinates, their rates)."""
        pos = ["rigid1", "rigid4"] + [f"eta{j + 1}" for j in range(self.n_modes)]
        return pos + [f"d{s}" for s in pos]

    @property
    def basis(self) -> NDArray:
        """The modes as columns, p = basis @ eta, shape (n, 2 + n_modes)."""
        return np.hstack([self.Phi_r, self.Phi_e])

    @property
    def projection(self) -> NDArray:
        """The map eta = projection @ p, shape (2 + n_modes, n), exact on the basis' span."""
        top = np.linalg.solve(self.M_rigid, self.Phi_r.T @ self.M)
        return np.vstack([top, self.Phi_e.T @ self.M])

    def output(self, names: Sequence[str]) -> NDArray:
        """C with y = C x for the named outputs (:data:`OUTPUTS`), shape (len(names), nx)."""
        Cp, Cv = self.linkage.output_matrix(names, self.theta1, self.theta4, self.M, self.Phi_r)
        # 'rigid' rows act on eta_r only (the elastic modes are mass-orthogonal to it)
        return np.hstack([Cp @ self.basis, Cv @ self.basis])

    def statespace(self, outputs: Sequence[str] = DEFAULT_OUTPUTS, name: str | None = None) -> control.StateSpace:
        """The model as a :class:`control.StateSpace`, inputs ``tau1, tau4`` (N m)."""
        outputs = _outputs(outputs)
        C = self.output(outputs)
        D = np.zeros((len(outputs), 2))
        nm = name or f"fivebar at theta1={np.degrees(self.theta1):.0f} deg, theta4={np.degrees(self.theta4):.0f} deg"
        return control.ss(self.A, self.B, C, D, inputs=list(_INPUTS), outputs=list(outputs),
                          states=self.state_names, name=nm)

    def zeros(self, output: str, input: str) -> NDArray:
        """Transmission zeros (rad/s) of one channel, e.g. ``mm.zeros("w2", "tau1")``.

        The rigid states do not reach the deflection outputs (their columns of C vanish), and
        their four poles at s = 0 would appear as zeros at s = 0 that cancel them; they are
        left out of such channels, so the result holds only the zeros that shape the response.
        """
        if input not in _INPUTS:
            raise InputError(f"input = {input!r} is not allowed: use one of {list(_INPUTS)}")
        c = self.output(_outputs((output,)))
        k = 2 + self.n_modes
        keep = np.ones(2 * k, bool)
        rigid = [0, 1, k, k + 1]
        if np.allclose(c[0, rigid], 0.0, atol=1e-12 * np.abs(c).max()):
            keep[rigid] = False
        j = _INPUTS.index(input)
        A = self.A[np.ix_(keep, keep)]
        g = control.ss(A, self.B[keep][:, [j]], c[:, keep], 0.0)
        return np.asarray(control.zeros(g))

    def feedback_matrix(self, servo: "Servo") -> NDArray:
        """The servo as a state feedback u = -F x (2, nx) on the reduced state."""
        meas = ("theta1", "theta4") if servo.measure == "rotor" else ("crank1", "crank4")
        rate = ("omega1", "omega4") if servo.measure == "rotor" else ("crank_rate1", "crank_rate4")
        return np.asarray(servo.kp)[:, None] * self.output(meas) + np.asarray(servo.kd)[:, None] * self.output(rate)

    def closed_loop(self, servo: "Servo", K_x: NDArray | None = None,
                    outputs: Sequence[str] = DEFAULT_OUTPUTS) -> control.StateSpace:
        """The loop closed by the servo (and the state feedback ``K_x``), inputs the torque
        disturbances ``tau1, tau4`` (N m) added at the motors."""
        F = self.feedback_matrix(servo) + (0.0 if K_x is None else np.asarray(K_x))
        outputs = _outputs(outputs)
        return control.ss(self.A - self.B @ F, self.B, self.output(outputs), np.zeros((len(outputs), 2)),
                          inputs=list(_INPUTS), outputs=list(outputs), states=self.state_names)

    def elastic_poles(self, servo: "Servo", K_x: NDArray | None = None) -> tuple[NDArray, NDArray]:
        """Natural frequencies (Hz) and damping ratios of the closed loop's elastic poles.

        ``f, zeta = mm.elastic_poles(servo, K_x)``: the poles of :meth:`closed_loop` ordered
        by natural frequency, one per complex pair, without the four of smallest magnitude
        (the servo's, from the rigid modes); ``n_modes`` values (a real pair counts once, at
        its geometric mean frequency, with its damping ratio ``(a + b) / (2 sqrt(a b))``).
        """
        A = self.A - self.B @ (self.feedback_matrix(servo) + (0.0 if K_x is None else np.asarray(K_x)))
        p = np.linalg.eigvals(A)
        p = p[np.argsort(np.abs(p))][4:]
        cx = p[p.imag > 1e-9 * np.abs(p)]
        real = np.sort(p[np.abs(p.imag) <= 1e-9 * np.abs(p)].real)
        wn = list(np.abs(cx))
        z = list(-cx.real / np.abs(cx))
        for a, b in zip(real[::2], real[1::2]):  # real pairs, neighbours in magnitude
            wn.append(np.sqrt(a * b))
            z.append(-(a + b) / (2 * np.sqrt(a * b)))
        o = np.argsort(wn)
        return np.asarray(wn)[o] / (2 * np.pi), np.asarray(z)[o]

    def loop(self, servo: "Servo", channel: int, K_x: NDArray | None = None) -> control.StateSpace:
        """Loop transfer function broken at motor ``channel`` (1 or 2), the other loop closed.

        L(s) = F_i (sI - A + B_j F_j)^-1 B_i with F the servo (plus ``K_x``) as state feedback;
        use with :func:`control.margin` (negative feedback).
        """
        if channel not in (1, 2):
            raise InputError(f"channel = {channel!r} is not allowed: use 1 (motor 1) or 2 (motor 2)")
        F = self.feedback_matrix(servo) + (0.0 if K_x is None else np.asarray(K_x))
        i, j = channel - 1, 2 - channel
        A = self.A - self.B[:, [j]] @ F[[j]]
        return control.ss(A, self.B[:, [i]], F[[i]], 0.0, inputs=[_INPUTS[i]], outputs=[f"L{channel}"])

    def physical_gains(self, K_x: NDArray) -> tuple[NDArray, NDArray]:
        """A reduced-state feedback u = -K_x x as physical gains (G_p, G_v), each (2, n):
        u = -G_p p - G_v p', with x = (P p, P p') and P = :attr:`projection`."""
        K_x = np.asarray(K_x, float)
        k = 2 + self.n_modes
        if K_x.shape != (2, 2 * k):
            raise InputError(f"K_x has shape {K_x.shape}: it must be (2, {2 * k})")
        P = self.projection
        return K_x[:, :k] @ P, K_x[:, k:] @ P


def _outputs(names: Sequence[str]) -> tuple[str, ...]:
    if isinstance(names, str):
        names = (names,)
    names = tuple(names)
    bad = [n for n in names if n not in OUTPUTS]
    if bad or not names:
        raise InputError(f"outputs = {names!r} is not allowed: choose from {list(OUTPUTS)}")
    return names


def control_modal_model(
    params: Params,
    theta1: float,
    theta4: float,
    n_modes: int = 6,
    *,
    rotor_inertia_scale: float = 1.0,
    elements_per_link: tuple[int, int, int, int] | None = None,
    damping_ratio: float | None = None,
    linkage: FlexibleLinkage | None = None,
) -> ControlModalModel:
    """The reduced model (2 rigid + ``n_modes`` elastic modes) at a frozen configuration.

    ``mm = control_modal_model(params, theta1, theta4)``; ``mm.statespace()``.

    Parameters
    ----------
    params
        Parameter set.
    theta1, theta4
        Crank angles (rad).
    n_modes
        Elastic modes kept (1 .. n - 2).
    rotor_inertia_scale
        Factor on J0 (large: rotors clamped).
    elements_per_link
        Mesh (default the paper's).
    damping_ratio
        Modal damping ratio; ``None`` takes ``params.damping_ratio``.
    linkage
        A prebuilt :class:`FlexibleLinkage` (its mesh and rotor scale are used).
    """
    th1 = float(_finite("theta1", theta1))
    th4 = float(_finite("theta4", theta4))
    fl = linkage or FlexibleLinkage(params, elements_per_link, rotor_inertia_scale)
    n_modes = _count("n_modes", n_modes, 1, fl.n - 2)
    zeta = params.damping_ratio if damping_ratio is None else damping_ratio
    if isinstance(zeta, bool) or not (0.0 <= float(zeta) < 1.0):
        raise InputError(f"damping_ratio = {damping_ratio!r} is not allowed: it must lie in [0, 1)")
    M, K = fl.matrices(th1, th4)
    Phi_r = fl.rigid_modes(th1, th4)
    omega, Phi_e = fl.modes(M, K, Phi_r)
    omega, Phi_e = omega[:n_modes], Phi_e[:, :n_modes]
    Mr = Phi_r.T @ M @ Phi_r
    k = 2 + n_modes
    A = np.zeros((2 * k, 2 * k))
    A[:k, k:] = np.eye(k)
    A[k + 2:, 2:k] = -np.diag(omega**2)
    A[k + 2:, k + 2:] = -np.diag(2.0 * zeta * omega)
    B = np.zeros((2 * k, 2))
    B[k:k + 2] = np.linalg.inv(Mr)  # Phi_r^T B = I
    B[k + 2:] = Phi_e.T @ fl.B
    return ControlModalModel(fl, th1, th4, omega, float(zeta), M, K, Phi_r, Phi_e, Mr, A, B)


def linear_model(
    params: Params,
    theta1: float,
    theta4: float,
    n_modes: int = 6,
    outputs: Sequence[str] = DEFAULT_OUTPUTS,
    **kwargs,
) -> control.StateSpace:
    """Linear flexible model at a frozen configuration, as a :class:`control.StateSpace`.

    ``sys = linear_model(params, theta1, theta4, n_modes=6)``

    Inputs ``tau1, tau4``: motor torques on the rotors (N m).  Outputs (default)
    ``theta1, theta4``: rotor angles (rad); ``w2, w3``: transverse midpoint deflections of L2,
    L3 relative to the rigid motion (m); others from :data:`OUTPUTS`.  Two rigid modes (free
    integrators) and ``n_modes`` elastic modes with modal damping.  Keyword arguments go to
    :func:`control_modal_model`.
    """
    return control_modal_model(params, theta1, theta4, n_modes, **kwargs).statespace(outputs)


def _cycle_angles(params: Params, crank_angles: ArrayLike) -> tuple[NDArray, NDArray]:
    phi = np.atleast_1d(_finite("crank_angles", crank_angles))
    th1, _, _, th4, _, _ = crank_laws(params, phi / params.crank_speed)
    return th1, th4


def models_along_cycle(
    params: Params,
    crank_angles: ArrayLike,
    n_modes: int = 6,
    outputs: Sequence[str] = DEFAULT_OUTPUTS,
    **kwargs,
) -> list[control.StateSpace]:
    """Linear models at the configurations of the default crank laws.

    ``crank_angles`` (rad) are angles of crank AB from its initial angle; crank DE follows
    with the speed ratio (as :func:`fivebar.modal.frequencies_along_cycle`).
    """
    th1, th4 = _cycle_angles(params, crank_angles)
    fl = kwargs.pop("linkage", None) or FlexibleLinkage(
        params, kwargs.pop("elements_per_link", None), kwargs.pop("rotor_inertia_scale", 1.0)
    )
    return [control_modal_model(params, a, b, n_modes, linkage=fl, **kwargs).statespace(outputs) for a, b in zip(th1, th4)]


def elastic_frequencies(
    params: Params, crank_angles: ArrayLike, n: int = 4, rotor_inertia_scale: float = 1.0
) -> NDArray:
    """Lowest ``n`` elastic natural frequencies (Hz) of the free-rotor linkage along the cycle,
    shape ``(len(crank_angles), n)`` (the two rigid modes left out)."""
    th1, th4 = _cycle_angles(params, crank_angles)
    fl = FlexibleLinkage(params, rotor_inertia_scale=rotor_inertia_scale)
    n = _count("n", n, 1, fl.n - 2)
    M, K = fl.matrices(th1, th4)
    Phi = fl.rigid_modes(th1, th4)
    return np.array([fl.modes(Mi, Ki, Pi)[0][:n] for Mi, Ki, Pi in zip(M, K, Phi)]) / (2 * np.pi)


# --- controllers ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Servo:
    """Decentralised PD servo, one per motor: tau_i = -kp_i e_i - kd_i e_i'.

    ``e_i`` is the deviation of the measured angle from the nominal crank law: the rotor angle
    (``measure="rotor"``, the motor's encoder, collocated) or the crank-root angle
    (``measure="crank"``, through the shaft).  ``kp`` in N m/rad, ``kd`` in N m s/rad.
    """

    kp: tuple[float, float]
    kd: tuple[float, float]
    measure: str = "rotor"

    def __post_init__(self) -> None:
        for name in ("kp", "kd"):
            v = getattr(self, name)
            if len(v) != 2 or any(isinstance(x, bool) or not math.isfinite(x) or x < 0 for x in v):
                raise InputError(f"Servo.{name} = {v!r} is not allowed: give two finite numbers >= 0")
        if self.measure not in _MEASURES:
            raise InputError(f"Servo.measure = {self.measure!r} is not allowed: use one of {list(_MEASURES)}")

    def gains(self, linkage: FlexibleLinkage) -> tuple[NDArray, NDArray]:
        """Physical gains (G_p, G_v), each (2, n): tau = -G_p p - G_v p'."""
        idx = linkage.rotor if self.measure == "rotor" else linkage.crank
        Gp = np.zeros((2, linkage.n))
        Gv = np.zeros((2, linkage.n))
        for i in (0, 1):
            Gp[i, idx[i]] = self.kp[i]
            Gv[i, idx[i]] = self.kd[i]
        return Gp, Gv


def pd_servo(
    params: Params, bandwidth: float, zeta: float = 0.7, measure: str = "rotor", samples: int = 36
) -> Servo:
    """PD gains that place each motor's rigid closed-loop poles at ``bandwidth`` (Hz).

    ``servo = pd_servo(params, bandwidth=5.0)``: kp_i = J_i w^2, kd_i = 2 zeta J_i w,
    w = 2 pi bandwidth, with J_i the cycle mean of the diagonal of the rigid mass matrix
    (:func:`rigid_inertia`) over ``samples`` configurations of the default crank laws: for
    J_i s^2 + kd_i s + kp_i this is a pair of poles of natural frequency w and damping
    ``zeta``.
    """
    bw = _positive("bandwidth", bandwidth, "Hz")
    z = _positive("zeta", zeta)
    if measure not in _MEASURES:
        raise InputError(f"measure = {measure!r} is not allowed: use one of {list(_MEASURES)}")
    from .rigid import mass_matrix

    th1, th4 = _cycle_angles(params, np.arange(samples) * 2 * np.pi / samples)
    J = mass_matrix(params, th1, th4, inertia=rigid_inertia(params)).diagonal(axis1=-2, axis2=-1).mean(axis=0)
    w = 2.0 * np.pi * bw
    return Servo(tuple(J * w**2), tuple(2.0 * z * J * w), measure)


def damping_lqr(mm: ControlModalModel, servo: Servo, modes: int = 2, q: float = 1.0, r: float = 1.0) -> NDArray:
    """LQR state feedback that adds damping to the lowest elastic modes, on top of a servo.

    ``K_x = damping_lqr(mm, servo)``; the total control is u = -F x - K_x x with F the servo
    (:meth:`ControlModalModel.feedback_matrix`); check the loop with :meth:`ControlModalModel.closed_loop`.

    Designed on the servo-closed plant (A - B F, B) with the cost
    ``J = int( q sum_{j<=modes} (omega_j^2 eta_j^2 + eta_j'^2) + r u^T u ) dt``: ``q`` weighs twice
    the elastic energy (J) of the first ``modes`` elastic modes, ``r`` the torques (N m)^2.
    The rigid states carry no weight: the servo keeps them.

    It regulates the elastic state to zero.  Along the nominal motion the elastic state is
    not zero: the motion needs a quasi-static deflection.  Acting on the whole state, the
    controller fights that deflection with torques that push the cranks off their laws;
    acting on the deviation from the expected elastic motion (``reference`` of
    :func:`simulate_cycle`), it only damps.

    Returns
    -------
    ndarray
        The gain K_x, shape (2, nx).
    """
    modes = _count("modes", modes, 1, mm.n_modes)
    q = _positive("q", q)
    r = _positive("r", r)
    k = 2 + mm.n_modes
    Q = np.zeros((2 * k, 2 * k))
    for j in range(modes):
        Q[2 + j, 2 + j] = q * mm.omega[j] ** 2
        Q[k + 2 + j, k + 2 + j] = q
    A = mm.A - mm.B @ mm.feedback_matrix(servo)
    K, _, _ = control.lqr(A, mm.B, Q, r * np.eye(2))
    return np.array(K)


def schedule(gains: ArrayLike, angles: ArrayLike) -> Callable[[ArrayLike], NDArray]:
    """Periodic linear interpolation of gains designed at crank angles.

    ``G = schedule(gains, angles)``; ``G(phi)`` is the gain at crank angle ``phi`` (rad, any
    value: angles are taken modulo 2 pi).

    Parameters
    ----------
    gains
        Array ``(N, ...)``: the gain designed at each angle.
    angles
        ``N`` crank angles (rad), strictly increasing, spanning less than 2 pi.

    Returns
    -------
    callable
        ``phi`` of any shape -> array ``phi.shape + gains.shape[1:]``.
    """
    G = np.asarray(gains, float)
    a = np.atleast_1d(_finite("angles", angles))
    if a.ndim != 1 or G.shape[:1] != a.shape:
        raise InputError(
            f"angles (shape {a.shape}) and gains (shape {G.shape}) do not match: give one gain per angle"
        )
    if np.any(np.diff(a) <= 0) or a[-1] - a[0] >= 2 * np.pi:
        raise InputError(f"angles = {a!r} are not allowed: they must increase strictly and span less than 2 pi")
    xp = np.concatenate([a, [a[0] + 2 * np.pi]])  # close the period
    Gp = np.concatenate([G, G[:1]], axis=0)

    def gain(phi: ArrayLike) -> NDArray:
        x = a[0] + np.mod(np.asarray(phi, float) - a[0], 2 * np.pi)
        j = np.clip(np.searchsorted(xp, x, side="right") - 1, 0, len(a) - 1)
        s = (x - xp[j]) / (xp[j + 1] - xp[j])
        s = s.reshape(s.shape + (1,) * (G.ndim - 1))
        return (1.0 - s) * Gp[j] + s * Gp[j + 1]

    return gain


def damping_schedule(
    params: Params,
    servo: Servo,
    crank_angles: ArrayLike,
    n_modes: int = 6,
    modes: int = 2,
    q: float = 1.0,
    r: float = 1.0,
) -> Callable[[ArrayLike], NDArray]:
    """:func:`damping_lqr` designed at each crank angle, as scheduled physical gains.

    ``G = damping_schedule(params, servo, angles)``; ``G(phi)`` is an array (2, 2, n):
    ``G[0]`` the position gain G_p and ``G[1]`` the velocity gain G_v of
    tau = -G_p p - G_v p' (coordinates of :class:`FlexibleLinkage`, in which the gains do not
    depend on the sign or order of the mode shapes, so they can be interpolated).
    ``crank_angles`` (rad) are angles of crank AB from its initial angle.
    """
    a = np.atleast_1d(_finite("crank_angles", crank_angles))
    th1, th4 = _cycle_angles(params, a)
    fl = FlexibleLinkage(params)
    out = []
    for x1, x4 in zip(th1, th4):
        mm = control_modal_model(params, x1, x4, n_modes, linkage=fl)
        out.append(np.stack(mm.physical_gains(damping_lqr(mm, servo, modes, q, r))))
    return schedule(np.array(out), a)


# --- closed-loop simulation along the nominal motion ------------------------------------------
@dataclass
class CycleSimulation:
    """A closed-loop simulation along the nominal motion (:func:`simulate_cycle`).

    Attributes
    ----------
    t : ndarray
        Times (s) from crank angle 0, shape (N,).
    p, v : ndarray
        Deviations from the nominal rigid configuration and their rates (SI), shape (N, n).
    w : ndarray
        Transverse midpoint deflections of L2, L3 relative to the rigid motion at the rotor
        angles (m), shape (N, 2).
    error : ndarray
        Rotor-angle deviations from the crank laws (rad), shape (N, 2).
    torque : ndarray
        Motor torques, feedforward plus feedback (N m), shape (N, 2).
    steps_per_period, periods : int
    """

    t: NDArray
    p: NDArray
    v: NDArray
    w: NDArray
    error: NDArray
    torque: NDArray
    steps_per_period: int
    periods: int

    def last_period(self) -> slice:
        """Slice of the samples of the last period (S + 1 samples)."""
        return slice(len(self.t) - self.steps_per_period - 1, len(self.t))

    def _col(self, link: str) -> int:
        if link not in ("L2", "L3"):
            raise InputError(f"link = {link!r} is not allowed: use 'L2' or 'L3'")
        return 0 if link == "L2" else 1

    def peak_to_peak(self, link: str) -> float:
        """Peak-to-peak midpoint deflection (m) of "L2" or "L3" over the last period."""
        y = self.w[self.last_period(), self._col(link)]
        return float(y.max() - y.min())

    def periodicity(self) -> float:
        """Largest change of w over the last period, relative to its peak-to-peak."""
        S = self.steps_per_period
        if self.periods < 2:
            return math.nan
        d = np.abs(self.w[-S - 1:] - self.w[-2 * S - 1:-S]).max()
        return float(d / max(np.ptp(self.w[-S - 1:], axis=0).max(), 1e-300))

    def settling_time(self, link: str, fraction: float = 0.05) -> float:
        """Time (s) after which w stays within ``fraction`` of its steady peak-to-peak of the
        steady (last-period) motion; 0 if it always does."""
        c = self._col(link)
        f = _positive("fraction", fraction)
        S = self.steps_per_period
        ref = self.w[-S - 1:-1, c]
        dev = np.abs(self.w[:, c] - ref[np.arange(len(self.t)) % S])
        bad = np.flatnonzero(dev > f * np.ptp(ref))
        return float(self.t[bad[-1]]) if len(bad) else 0.0


def _reference(ref, fl: FlexibleLinkage, params: Params, S: int) -> tuple[NDArray, NDArray]:
    """The expected elastic motion (p, p') at the S steps of a period, from a prescribed-motion
    :class:`fivebar.steady.SteadyState` (rotors on the crank laws) or a :class:`CycleSimulation`."""
    if isinstance(ref, CycleSimulation):
        if ref.steps_per_period != S:
            raise InputError(f"reference has {ref.steps_per_period} steps per period: it must have {S}")
        sl = slice(len(ref.t) - S - 1, len(ref.t) - 1)
        return ref.p[sl], ref.v[sl]
    dyn = getattr(ref, "dynamics", None)
    if dyn is None:
        raise InputTypeError(f"reference must be a SteadyState or a CycleSimulation, got {type(ref).__name__}")
    if dyn.steps != S or not math.isclose(dyn.period, params.period, rel_tol=1e-12):
        raise InputError(
            f"reference has {dyn.steps} steps over {dyn.period:.6g} s: it must have {S} steps over "
            f"{params.period:.6g} s (the same crank speed and steps_per_period)"
        )
    labels = [dyn.model.dofs[i].label for i in dyn.keep]
    rename = {"U4": "L1@A.slope", "U8": "L4@E.slope"}  # the tied crank roots
    where = {rename.get(lab, lab): k for k, lab in enumerate(labels)}
    missing = [lab for lab in fl.labels[2:] if lab not in where]
    if missing or not dyn.model.motors:
        raise InputError(f"reference model lacks the coordinates {missing}: use motors=True and the same mesh")
    P = np.zeros((S, fl.n))
    V = np.zeros((S, fl.n))
    cols = [where[lab] for lab in fl.labels[2:]]
    P[:, 2:] = ref.u[:S, cols]
    V[:, 2:] = ref.v[:S, cols]
    return P, V


def simulate_cycle(
    params: Params | Setup,
    servo: Servo,
    damping: Callable[[ArrayLike], NDArray] | None = None,
    *,
    reference=None,
    periods: int = 3,
    steps_per_period: int | None = None,
    crank_speed_rpm: float | None = None,
    start: str = "quasi-static",
    scheme: Scheme | None = None,
) -> CycleSimulation:
    """Closed-loop kineto-elastodynamics with free rotors along the nominal motion.

    ``sim = simulate_cycle(params, servo)``; ``sim.peak_to_peak("L2")``.

    Integrates, with the set-up's scheme (the parameter file's generalised-alpha by default,
    errata E26; :func:`fivebar.newmark.integrate`) on the full-order model of :class:`FlexibleLinkage` (no modal truncation),

    M_p p'' + C_p p' + K_p p = -M_p a_r + B (tau_ff - G_s (p, p') - G_d (p - p_ref, p' - p_ref')),

    with the matrices of the configuration at every step (a linear time-varying system),
    modal damping on the free-rotor elastic modes of the instant, the feedforward
    :func:`feedforward`, the servo G_s, and optionally the scheduled damping gains G_d
    (``damping``, from :func:`damping_schedule`) acting on the deviation from an expected
    elastic motion p_ref (``reference``; zero if not given).  See the module docstring for
    what is left out.

    Parameters
    ----------
    params
        Parameter set, or a :class:`fivebar.setup.Setup` (its crank speed, S and scheme are the
        defaults of the keywords below; motors, nonlinearity and mesh do not apply here).
    servo
        The PD servo (it acts on the deviation of the measured angle from the crank laws).
    damping
        ``phi -> (2, 2, n)`` scheduled gains (crank angle in rad), or ``None``.
    reference
        The expected elastic motion for the damping loop: a prescribed-motion
        :class:`fivebar.steady.SteadyState` with the same speed and ``steps_per_period``
        (an ideal servo's elastic motion), or a :class:`CycleSimulation`; ``None``: zero.
    periods
        Periods of the motion to integrate (the last one is taken as the steady state).
    steps_per_period
        Steps per period; ``None`` takes the set-up's (the parameter file's).
    crank_speed_rpm
        Crank speed (r/min); ``None`` takes the set-up's (the parameters').
    start
        "quasi-static" (the static deflection under the load at t = 0, at rest relative to
        it) or "rest" (p = 0, p' = 0: the linkage released undeformed at speed).
    scheme
        Time integrator; ``None`` takes the set-up's.
    """
    setup = as_setup(params, crank_speed_rpm=crank_speed_rpm, steps_per_period=steps_per_period, scheme=scheme)
    params = setup.run_params
    periods = _count("periods", periods, 1, 10**6)
    S = _count("steps_per_period", setup.steps_per_period, 2, 10**7)
    if start not in ("quasi-static", "rest"):
        raise InputError(f"start = {start!r} is not allowed: use 'quasi-static' or 'rest'")
    if not isinstance(servo, Servo):
        raise InputTypeError(f"servo must be a Servo, got {type(servo).__name__}")
    fl = FlexibleLinkage(params)
    T = params.period
    dt = T / S
    t = np.arange(S) * dt
    laws = crank_laws(params, t)
    M, K = fl.matrices(laws[0], laws[3])
    Phi = fl.rigid_modes(laws[0], laws[3])
    C = np.empty_like(M)
    for k in range(S):
        om, Pe = fl.modes(M[k], K[k], Phi[k])
        C[k] = fl.damping(M[k], om, Pe)
    tau_ff = feedforward(params, t)
    F = -np.einsum("kij,kj->ki", M, fl.rigid_acceleration(*laws)) + tau_ff @ fl.B.T
    Gs = servo.gains(fl)
    Gp = np.broadcast_to(Gs[0], (S, 2, fl.n)).copy()
    Gv = np.broadcast_to(Gs[1], (S, 2, fl.n)).copy()
    u_ref = np.zeros((S, 2))
    if damping is not None:
        G = np.asarray(damping(laws[0] - params.theta1_0), float)
        if G.shape != (S, 2, 2, fl.n):
            raise InputError(f"damping(phi) returned shape {G.shape[1:]}: it must be (2, 2, {fl.n})")
        Gp += G[:, 0]
        Gv += G[:, 1]
        if reference is not None:
            P_ref, V_ref = _reference(reference, fl, params, S)
            u_ref = np.einsum("kij,kj->ki", G[:, 0], P_ref) + np.einsum("kij,kj->ki", G[:, 1], V_ref)
            F = F + u_ref @ fl.B.T
    Kc = K + fl.B @ Gp
    Cc = C + fl.B @ Gv
    sd = PeriodicStepData(M, Cc, Kc, F, t0=0.0, period=T)
    if start == "rest":
        u0 = np.zeros(fl.n)
        v0 = np.zeros(fl.n)
    else:
        qs = [np.linalg.solve(Kc[k], F[k]) for k in (S - 1, 0, 1)]
        u0, v0 = qs[1], (qs[2] - qs[0]) / (2 * dt)
    res = integrate(System(M[0], Cc[0], Kc[0]), u0, v0, 0.0, dt, periods * S, setup.scheme, step_data=sd)
    k = np.arange(len(res.t)) % S
    W = fl.elastic_midpoint_rows(laws[0], laws[3], Phi)  # (S, 2, n)
    w = np.einsum("kij,kj->ki", W[k], res.u)
    fb = -np.einsum("kij,kj->ki", Gp[k], res.u) - np.einsum("kij,kj->ki", Gv[k], res.v) + u_ref[k]
    return CycleSimulation(res.t, res.u, res.v, w, res.u[:, list(fl.rotor)], tau_ff[k] + fb, S, periods)
