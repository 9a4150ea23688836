r"""The flexible linkage with free rotors: the finite-element model of the control analysis.

The prescribed-motion model (2.7) makes the motor rotors the torsional reference: their angles
*are* the crank laws, and the motor torques do not appear.  For control the rotor angles must
be free and the torques must be inputs.  This module builds that model;
:mod:`fivebar.analyses.control.control_model` reduces it to a few modes and writes it as a
:class:`control.StateSpace`, :mod:`fivebar.analyses.control.control_design` designs servo and damping loops
around it, and :mod:`fivebar.analyses.control.control_simulation` closes them along the nominal motion (the
paper's "next step", section 6).

**Any linkage driven by cranks.**  One input angle and one torque per driven crank: for a crank
driven by the motor section its joint names (the paper's five-bar: two), the rotor angle, with
the motor's shaft between the rotor and the crank (below); for a crank without a motor, the
crank-root rotation itself, the torque applied there (a rigid drive shaft); for a rigid crank
(``rigid = true``), its rotation, which moves the joint it carries by :math:`L\,\mathbf n(\beta)`
per radian (a map that turns with the crank), with the crank's inertia about its pivot.  A
driven slider has no torque input: such a description raises an
:class:`~fivebar.errors.InputError`.  Outputs are named by the number of each crank's link and
of each link in the description (``theta1, theta4, w2, w3`` for the five-bar's L1, L4, L2, L3).

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



def _outputs(names: Sequence[str], allowed: Sequence[str] = OUTPUTS) -> tuple[str, ...]:
    if isinstance(names, str):
        names = (names,)
    names = tuple(names)
    bad = [n for n in names if n not in allowed]
    if bad or not names:
        raise InputError(f"outputs = {names!r} is not allowed: choose from {list(allowed)}")
    return names



def _crank_inputs(params: Params) -> tuple[tuple[str, Motor | None], ...]:
    """(crank joint, its motor or None) of every driven input, which must all be cranks."""
    lk = params.linkage
    sliders = [j.name for j in lk.inputs if j.kind != "crank"]
    if sliders:
        raise InputError(
            f"the free-rotor control model turns driven cranks; the linkage {lk.name!r} drives the slider(s) "
            f"{sliders}, whose force input it does not have")
    motors = params.crank_motors
    return tuple((j.name, motors.get(j.name)) for j in lk.inputs)


def _cycle_angles(params: Params, crank_angles: ArrayLike) -> tuple[NDArray, ...]:
    """The inputs' angles (one array per input) where the first crank has turned by
    ``crank_angles`` (rad) from its initial angle along the drive laws."""
    _crank_inputs(params)
    phi = np.atleast_1d(_finite("crank_angles", crank_angles))
    return crank_laws(params, phi / params.crank_speed_rad_s)[0::3]


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
    link_inertia = {k.name: base.link_mass[k.name] * (k.length**2 + params.rotary_inertia * k.section.bending_depth**2) / 12.0
                    for k in params.linkage.links}  # (each link's own in-plane depth)
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
    ndarray, shape ``t.shape + (r,)``
        One torque per driven crank, positive anticlockwise: (tau1, tau4) for the five-bar.
    """
    t = _finite("t", t, "s")
    W = None if crank_speed_rpm is None else _positive("crank_speed_rpm", crank_speed_rpm, "r/min") * math.pi / 30.0
    return inverse_dynamics(params, *crank_laws(params, t, W), inertia=rigid_inertia(params, rotor_inertia_scale))



# --- the full-order model with free rotors ----------------------------------------------------
class FlexibleLinkage:
    """The linkage with free rotors: rotor angles plus every FE DOF (module docstring).

    ``fl = FlexibleLinkage(params)``; ``M, K = fl.matrices(theta1, theta4)`` (one angle per
    driven crank).

    Parameters
    ----------
    params
        Parameter set.
    elements_per_link
        Mesh (default the description's, the paper's 1-2-2-1 for the five-bar).
    rotor_inertia_scale
        Factor on the rotor inertias J0 (large values clamp the rotors).

    Attributes
    ----------
    model : fivebar.model.assembly.Model
        The literal assembly (``tie_crank_roots=False``) the coordinates are built on.
    labels : list of str
        Names of the coordinates p: ``phi1, phi2`` (the input angles: a motor's rotor angle,
        the crank-root rotation of a crank without one), ``U3, U7`` (twists at the second
        bearings of the motors), then the beam DOFs (:class:`fivebar.model.assembly.Dof` labels).
    n : int
        Number of coordinates.
    rotor, crank : tuple of int
        Indices of the input angles and of the crank-root rotations (s_A, s_E of the five-bar)
        in p (the same for a crank without a motor).
    B : ndarray
        Input matrix, shape (n, inputs): the motor torques act on the rotor angles.
    suffixes : tuple of int
        The number of each input's crank link in the description (1 and 4 for the five-bar's L1
        and L4): the outputs' names end in it (``theta1``, ``theta4``).
    """

    def __init__(
        self,
        params: Params,
        elements_per_link: tuple[int, ...] | None = None,
        rotor_inertia_scale: float = 1.0,
    ) -> None:
        drives = _crank_inputs(params)
        s = _positive("rotor_inertia_scale", rotor_inertia_scale)
        self.params = params
        self.rotor_inertia_scale = s
        m: Model = build_model(params, elements_per_link=elements_per_link, motors=True, tie_crank_roots=False)
        self.model = m
        lk = params.linkage
        N = len(drives)
        self.inputs = N
        #: the crank links (input order) and the couplers whose midpoints are outputs
        self._crank_links = tuple(lk.crank_link(joint).name for joint, _ in drives)
        self._couplers = lk.couplers
        self.suffixes = tuple(lk.link_names.index(k) + 1 for k in self._crank_links)
        motor_of = {}  # input (0-based) -> motor ordinal of the model (1-based)
        for i, (joint, motor) in enumerate(drives):
            if motor is not None:
                motor_of[i] = [j for j, _ in lk.motors].index(joint) + 1
        nu = m.n
        transverse = {d for i in motor_of.values() for d in m.motor_dofs[i][:2]}
        coupling = {i: m.motor_dofs[o][3] for i, o in motor_of.items()}
        root = {}  # input -> the literal model's crank-root slope (None for a rigid crank)
        pins = {}  # input -> the (x, y) DOFs of the joint a rigid crank carries, and its arm
        for i, ((joint, _), link) in enumerate(zip(drives, self._crank_links)):
            if lk.link(link).rigid:
                k = lk.link(link)
                far = k.end if k.start == joint else k.start
                pins[i] = (m.node_dofs[far], link, far, joint)
                root[i] = None
            else:
                root[i] = m.dof_index(f"{link}@{joint}.slope")
        tied = {d for i in pins for d in pins[i][0]}
        self_root = {root[i] for i in root if i not in motor_of and root[i] is not None}
        keep = [d for d in range(nu) if d not in transverse and d not in coupling.values() and d not in tied
                and d not in self_root]
        self.labels = [f"phi{i + 1}" for i in range(N)] + [m.dofs[d].label for d in keep]
        self.n = n = len(self.labels)
        col = {d: N + k for k, d in enumerate(keep)}
        for i in range(N):  # a crank without a motor: its root rotation is the input angle
            if i not in motor_of and root[i] is not None:
                col[root[i]] = i
        # T: p -> (phi, literal model DOFs); U4 = s_A - phi1 (U8 = s_E - phi2)
        T = np.zeros((nu + N, n))
        for i in range(N):
            T[i, i] = 1.0
        for d, c in col.items():
            T[N + d, c] = 1.0
        for i in motor_of:
            T[N + coupling[i], col[root[i]]] = 1.0
            T[N + coupling[i], i] = -1.0
        self._T = T
        self._Tu = T[N:]  # p -> literal model DOFs (rotor transverse zero; a rigid crank's pin: set per configuration)
        self._pins = pins
        # the inputs' absolute-rate terms, constant in the configuration
        extra = np.zeros((nu + N, nu + N))
        self._weights: dict[int, tuple[float, float]] = {}  # rigid crank -> its mass and centre-of-mass arm
        rig = None
        for i, (joint, motor) in enumerate(drives):
            if motor is not None:
                Js, b = _shaft_terms(motor)
                extra[i, i] = s * motor.J0 + Js
                tw = N + np.array(m.motor_dofs[motor_of[i]][2:4])
                extra[i, tw] = b
                extra[tw, i] = b
            elif i in pins:  # a rigid crank: its own inertia about the pivot (its pin's mass is the model's)
                rig = rig or rigid_inertia(params, s)
                link = self._crank_links[i]
                k = lk.link(link)
                arm = rig.link_com[link] * k.length - (0.0 if k.start == joint else k.length)  # pivot -> centre of mass
                self._weights[i] = (rig.link_mass[link], arm)  # along the link's start -> end direction
                extra[i, i] = rig.link_inertia[link] + rig.link_mass[link] * arm ** 2
        self._M_extra = T.T @ extra @ T
        self.rotor = tuple(range(N))
        self.crank = tuple(i if (i not in motor_of) else col[root[i]] for i in range(N))
        self._twist = tuple(col[m.motor_dofs[o][2]] for o in motor_of.values())
        self._beam_cols = np.array([col[d] for d in keep])
        self._beam_src = np.array(keep)
        self.B = np.zeros((n, N))
        for i in range(N):
            self.B[i, i] = 1.0

    # --- names ---------------------------------------------------------------------------------
    @property
    def input_names(self) -> tuple[str, ...]:
        """The torque inputs, ``tau<k>`` with the suffix of each crank (tau1, tau4 for the five-bar)."""
        return tuple(f"tau{k}" for k in self.suffixes)

    @property
    def outputs(self) -> tuple[str, ...]:
        """The output names of this linkage (:data:`OUTPUTS` for the five-bar, and ``w<k>`` for the
        midpoint of every flexible link k)."""
        sx = self.suffixes
        names = [f"{kind}{k}" for kind in ("theta", "omega", "crank", "crank_rate", "rigid") for k in sx]
        lk = self.params.linkage
        return tuple(names + [f"w{lk.link_names.index(k.name) + 1}" for k in lk.flexible])

    @property
    def default_outputs(self) -> tuple[str, ...]:
        """The input angles and the couplers' midpoints (:data:`DEFAULT_OUTPUTS` for the five-bar)."""
        lk = self.params.linkage
        return tuple([f"theta{k}" for k in self.suffixes] + [f"w{lk.link_names.index(c) + 1}" for c in self._couplers])

    def _angles(self, theta: tuple) -> list[NDArray]:
        if len(theta) != self.inputs:
            raise InputError(f"{len(theta)} crank angle(s) given: the linkage {self.params.linkage.name!r} has "
                             f"{self.inputs} driven crank(s), one angle (rad) each")
        names = ("theta1", "theta4") if self.inputs == 2 else tuple(f"theta{k}" for k in self.suffixes)
        return list(np.broadcast_arrays(*(_finite(nm, t) for nm, t in zip(names, theta))))

    def _tu(self, th: list[NDArray]) -> NDArray:
        """T_u of the configuration (constant unless a rigid crank's pin moves with its input)."""
        if not self._pins:
            return self._Tu
        Tu = np.broadcast_to(self._Tu, th[0].shape + self._Tu.shape).copy()
        for i, ((ix, iy), link, far, joint) in self._pins.items():
            k = self.params.linkage.link(link)
            beta = th[i] if k.start == joint else th[i] + np.pi  # the crank link's angle
            sL = (1.0 if k.start == joint else -1.0) * k.length  # far = joint + sL e(beta)
            Tu[..., ix, i] = -sL * np.sin(beta)
            Tu[..., iy, i] = sL * np.cos(beta)
        return Tu

    # --- matrices ----------------------------------------------------------------------------
    def matrices(self, *theta: ArrayLike) -> tuple[NDArray, NDArray]:
        """Mass and stiffness M_p, K_p at crank angles (rad, one per driven crank), shape ``(..., n, n)``."""
        th = self._angles(theta)
        Mu, Ku = self.model.matrices(*th)
        Tu = self._tu(th)
        M = np.swapaxes(Tu, -2, -1) @ Mu @ Tu + self._M_extra
        K = np.swapaxes(Tu, -2, -1) @ Ku @ Tu
        return 0.5 * (M + np.swapaxes(M, -1, -2)), 0.5 * (K + np.swapaxes(K, -1, -2))

    def _from_literal(self, v: NDArray, rotor: NDArray) -> NDArray:
        """A rigid field of the literal model (..., nu) -> p (..., n), no relative twist."""
        out = np.zeros(v.shape[:-1] + (self.n,))
        out[..., self._beam_cols] = v[..., self._beam_src]
        out[..., list(self._twist)] = 0.0
        for i in range(self.inputs):
            out[..., i] = rotor[..., i]
        return out

    def rigid_modes(self, *theta: ArrayLike) -> NDArray:
        """The rigid fields of unit crank rotations, shape ``(..., n, inputs)``: K_p Phi_r = 0."""
        th = self._angles(theta)
        one, zero = np.ones(th[0].shape), np.zeros(th[0].shape)
        cols = []
        for i in range(self.inputs):
            w = [one if k == i else zero for k in range(self.inputs)]
            laws = [x for k in range(self.inputs) for x in (th[k], w[k], zero)]
            v = self.model.rigid_velocity(rigid_state(self.params, *laws))
            cols.append(self._from_literal(v, np.stack(w, -1)))
        return np.stack(cols, -1)

    def rigid_acceleration(self, *laws: ArrayLike) -> NDArray:
        """Nominal rigid acceleration field a_r in p (as (2.7)'s u_r''), shape ``(..., n)``:
        ``rigid_acceleration(theta1, omega1, alpha1, theta4, omega4, alpha4)`` (per crank its
        angle, speed and acceleration).

        Input entries: the crank accelerations; relative twists: 0; beam DOFs:
        :meth:`fivebar.model.assembly.Model.rigid_acceleration` (gravity included there).
        """
        st = rigid_state(self.params, *laws)
        a = self.model.rigid_acceleration(st)
        return self._from_literal(a, np.stack([st.alpha[k] for k in self._crank_links], -1))

    def inertial_load(self, *laws: ArrayLike) -> NDArray:
        r"""The load of the nominal rigid motion on p, -M_p a_r, shape ``(..., n)`` (N, N m):
        ``inertial_load(theta1, omega1, alpha1, theta4, omega4, alpha4)``.

        The literal model's load of its eliminated DOFs
        (:meth:`~fivebar.model.assembly.Model.prescribed_load`: with gravity, the weight's share at
        the ground pins) is added through :math:`\mathbf T_u^\top`, and with gravity a rigid
        crank's own weight, which no element carries, as a torque on its input.
        A rigid crank's pin moves by :math:`L\mathbf n(\beta)` per radian of the crank, a map
        that turns with it, so the pin's centripetal acceleration is not of that form: its load,
        :math:`-\mathbf T_u^\top\mathbf M_u\,\mathbf r` with :math:`\mathbf r` the part of the
        literal model's rigid acceleration that :math:`\mathbf T_u\mathbf a_r` misses, is added.
        """
        a = self.rigid_acceleration(*laws)
        th = self._angles(laws[0::3])
        M = self.matrices(*th)[0]
        F = -np.einsum("...ij,...j->...i", M, a)
        st = rigid_state(self.params, *laws)
        Tu = self._tu(th)
        extra = self.model.prescribed_load(st)  # the eliminated DOFs' share: gravity at the ground pins
        if np.any(extra):
            F = F + np.einsum("...ji,...j->...i", Tu, extra)
        g = self.params.gravity
        for i, (mass, arm) in self._weights.items():  # a rigid crank's own weight (not in the elements)
            F[..., i] -= mass * g * arm * np.cos(st.angle[self._crank_links[i]])
        if not self._pins:
            return F
        full = self.model.rigid_acceleration(st)  # the literal model's field
        r = full - np.einsum("...ij,...j->...i", Tu, a)
        mask = np.zeros(self.model.n, bool)
        for (ix, iy), *_ in self._pins.values():
            mask[[ix, iy]] = True
        r = np.where(mask, r, 0.0)
        Mu = self.model.matrices(*th)[0]
        return F - np.einsum("...ji,...j->...i", Tu, np.einsum("...ij,...j->...i", Mu, r))

    def midpoint_rows(self, *theta: ArrayLike, links: Sequence[str] | None = None) -> NDArray:
        """Rows c^T with w = c^T p: transverse displacement (m) of the midpoints of ``links``
        (default the couplers: L2, L3 of the five-bar), total (rigid part not removed), shape
        ``(..., len(links), n)``."""
        th = [x[..., None] for x in self._angles(theta)]
        Tu = self._tu([x[..., 0] for x in th])
        basis = np.swapaxes(Tu, -2, -1)  # (..., n, nu): row j is the literal-model vector of unit p_j
        links = self._couplers if links is None else tuple(links)
        rows = [self.model.link_displacement(basis, *th, link, 0.5)[1] for link in links]
        return np.stack(rows, -2)

    def elastic_midpoint_rows(self, *theta: ArrayLike, Phi_r: NDArray | None = None,
                              links: Sequence[str] | None = None) -> NDArray:
        """Rows of the midpoint deflections relative to the rigid motion at the rotor angles:
        c^T (I - Phi_r S), S picking the input angles; shape ``(..., links, n)`` (m per unit p),
        ``links`` default the couplers (w2, w3 of the five-bar)."""
        c = self.midpoint_rows(*theta, links=links)
        Phi = self.rigid_modes(*theta) if Phi_r is None else Phi_r
        S = np.zeros((self.inputs, self.n))
        for i in range(self.inputs):
            S[i, self.rotor[i]] = 1.0
        return c - (c @ Phi) @ S

    def output_matrix(self, names: Sequence[str], *theta: float,
                      M: NDArray | None = None, Phi_r: NDArray | None = None) -> tuple[NDArray, NDArray]:
        """(C_pos, C_vel) with y = C_pos p + C_vel p' for the named outputs (:attr:`outputs`)
        at one configuration (``M`` and ``Phi_r`` may be passed to save their computation)."""
        names = _outputs(names, self.outputs)
        n = self.n
        Phi = self.rigid_modes(*theta) if Phi_r is None else Phi_r
        if M is None:
            M = self.matrices(*theta)[0]
        Cp = np.zeros((len(names), n))
        Cv = np.zeros((len(names), n))
        index = {str(k): i for i, k in enumerate(self.suffixes)}
        lk = self.params.linkage
        for k, name in enumerate(names):
            kind = name.rstrip("0123456789")
            num = name[len(kind):]
            if kind in ("theta", "omega"):
                (Cp if kind == "theta" else Cv)[k, self.rotor[index[num]]] = 1.0
            elif kind in ("crank", "crank_rate"):
                (Cv if kind == "crank_rate" else Cp)[k, self.crank[index[num]]] = 1.0
            elif kind == "rigid":
                Mr = Phi.T @ M @ Phi
                Cp[k] = np.linalg.solve(Mr, Phi.T @ M)[index[num]]
            else:  # w<k>: relative to the rigid motion at the rotor angles
                Cp[k] = self.elastic_midpoint_rows(*theta, Phi_r=Phi, links=(lk.link_names[int(num) - 1],))[0]
        return Cp, Cv

    def modes(self, M: NDArray, K: NDArray, Phi_r: NDArray) -> tuple[NDArray, NDArray]:
        """Elastic modes of one configuration: (omega (rad/s), Phi_e (n, n - inputs)).

        The rigid modes (one per input) are removed; Phi_e is mass-normalised and
        mass-orthogonal to ``Phi_r``.  Raises ``RuntimeError`` if K_p does not have exactly as
        many zero modes as inputs.
        """
        N = self.inputs
        w2, V = scipy.linalg.eigh(K, M)
        if not (np.all(np.abs(w2[:N]) < 1e-8 * w2[N]) and w2[N] > 0):
            raise ComputationError(
                f"K_p has not exactly {N} rigid modes: its lowest omega^2 are {w2[:N + 1]} rad^2/s^2 ({N} zeros and "
                f"a positive one expected, the cranks' free rotations)"
            )
        Ve = V[:, N:]
        # remove the round-off component along the rigid modes, renormalise
        Mr = Phi_r.T @ M @ Phi_r
        Ve = Ve - Phi_r @ np.linalg.solve(Mr, Phi_r.T @ M @ Ve)
        Ve = Ve / np.sqrt(np.einsum("ij,ik,kj->j", Ve, M, Ve))
        return np.sqrt(w2[N:]), Ve

    def damping(self, M: NDArray, omega: NDArray, Phi_e: NDArray, zeta: float | None = None) -> NDArray:
        """Modal damping C = M Phi_e diag(2 zeta omega) Phi_e^T M (rigid modes undamped)."""
        z = self.params.damping_ratio if zeta is None else zeta
        MP = M @ Phi_e
        return (MP * (2.0 * z * omega)) @ MP.T



def elastic_frequencies(
    params: Params, crank_angles: ArrayLike, n_modes: int = 4, rotor_inertia_scale: float = 1.0
) -> NDArray:
    """Lowest ``n_modes`` elastic natural frequencies (Hz) of the free-rotor linkage along the
    cycle, shape ``(len(crank_angles), n_modes)`` (the rigid modes, one per crank, left out)."""
    th = _cycle_angles(params, crank_angles)
    fl = FlexibleLinkage(params, rotor_inertia_scale=rotor_inertia_scale)
    n_modes = _count("n_modes", n_modes, 1, fl.n - fl.inputs)
    M, K = fl.matrices(*th)
    Phi = fl.rigid_modes(*th)
    return np.array([fl.modes(Mi, Ki, Pi)[0][:n_modes] for Mi, Ki, Pi in zip(M, K, Phi)]) / (2 * np.pi)

