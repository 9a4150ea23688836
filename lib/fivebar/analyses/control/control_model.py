r"""Modal reduction of the free-rotor linkage to a state-space model (python-control).

The full-order model is :class:`fivebar.model.free_rotors.FlexibleLinkage`; this module keeps its
rigid modes (two for the five-bar, one per driven crank) and a few elastic modes at a frozen
configuration and writes the result as a :class:`control.StateSpace` with the motor torques as
inputs and the outputs of :attr:`fivebar.model.free_rotors.FlexibleLinkage.outputs` (for the
five-bar :data:`fivebar.model.free_rotors.OUTPUTS`).

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
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import InputError
from ...model.free_rotors import DEFAULT_OUTPUTS, FlexibleLinkage, _count, _cycle_angles, _finite, _outputs
from ...description.params import Params
from ...description.setup import Setup, analysis, as_setup

__all__ = [
    "ControlModalModel",
    "Servo",
    "control_modal_model",
    "linear_model",
    "models_along_cycle",
]



# --- the servo -----------------------------------------------------------------------------------
_MEASURES = ("rotor", "crank")


@dataclass(frozen=True)
class Servo:
    """Decentralised PD servo, one per motor (driven crank): tau_i = -kp_i e_i - kd_i e_i'.

    ``e_i`` is the deviation of the measured angle from the nominal crank law: the rotor angle
    (``measure="rotor"``, the motor's encoder, collocated) or the crank-root angle
    (``measure="crank"``, through the shaft; the same for a crank without a motor).  ``kp`` in
    N m/rad, ``kd`` in N m s/rad, one each per driven crank (two for the five-bar).
    """

    kp: tuple[float, ...]
    kd: tuple[float, ...]
    measure: str = "rotor"

    def __post_init__(self) -> None:
        for name in ("kp", "kd"):
            v = getattr(self, name)
            try:
                ok = len(v) >= 1 and all(not isinstance(x, bool) and math.isfinite(x) and x >= 0 for x in v)
            except TypeError:
                ok = False
            if not ok:
                raise InputError(f"Servo.{name} = {v!r} is not allowed: give one finite number >= 0 per driven crank")
        if len(self.kp) != len(self.kd):
            raise InputError(f"Servo.kp = {self.kp!r} and Servo.kd = {self.kd!r} are not allowed: give as many of each")
        if self.measure not in _MEASURES:
            raise InputError(f"Servo.measure = {self.measure!r} is not allowed: use one of {list(_MEASURES)}")

    def gains(self, linkage: FlexibleLinkage) -> tuple[NDArray, NDArray]:
        """Physical gains (G_p, G_v), each (inputs, n): tau = -G_p p - G_v p'."""
        idx = linkage.rotor if self.measure == "rotor" else linkage.crank
        if len(self.kp) != linkage.inputs:
            raise InputError(f"Servo has {len(self.kp)} gains: the linkage {linkage.params.linkage.name!r} has "
                             f"{linkage.inputs} driven crank(s), one gain each")
        Gp = np.zeros((linkage.inputs, linkage.n))
        Gv = np.zeros((linkage.inputs, linkage.n))
        for i in range(linkage.inputs):
            Gp[i, idx[i]] = self.kp[i]
            Gv[i, idx[i]] = self.kd[i]
        return Gp, Gv


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
    theta : tuple of float
        The frozen crank angles (rad), one per driven crank (:attr:`theta1`, :attr:`theta4` of
        the five-bar).
    omega : ndarray
        Elastic natural frequencies (rad/s) of the retained modes.
    zeta : float
        Modal damping ratio of the elastic modes.
    M, K : ndarray
        Full-order matrices at the configuration, shape (n, n).
    Phi_r, Phi_e : ndarray
        Rigid modes, shape (n, r) with r the driven cranks (2 for the five-bar), and retained
        elastic modes, shape (n, n_modes).
    M_rigid : ndarray
        Rigid mass matrix Phi_r^T M Phi_r (kg m^2), shape (r, r).
    A, B : ndarray
        State matrices, shapes (nx, nx) and (nx, r), nx = 2 (r + n_modes).
    """

    linkage: FlexibleLinkage
    theta: tuple[float, ...]
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
    def theta1(self) -> float:
        """The first crank's frozen angle (rad)."""
        return self.theta[0]

    @property
    def theta4(self) -> float | None:
        """The second crank's frozen angle (rad; the five-bar's theta4), None for one crank."""
        return self.theta[1] if len(self.theta) > 1 else None

    @property
    def inputs(self) -> tuple[str, ...]:
        """The torque inputs (``tau1, tau4`` for the five-bar)."""
        return self.linkage.input_names

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
        pos = [f"rigid{k}" for k in self.linkage.suffixes] + [f"eta{j + 1}" for j in range(self.n_modes)]
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
        Cp, Cv = self.linkage.output_matrix(names, *self.theta, M=self.M, Phi_r=self.Phi_r)
        # 'rigid' rows act on eta_r only (the elastic modes are mass-orthogonal to it)
        return np.hstack([Cp @ self.basis, Cv @ self.basis])

    def statespace(self, outputs: Sequence[str] | None = None, name: str | None = None) -> control.StateSpace:
        """The model as a :class:`control.StateSpace`, inputs ``tau1, tau4`` (N m; one per driven
        crank); ``outputs`` default :attr:`FlexibleLinkage.default_outputs`
        (:data:`DEFAULT_OUTPUTS` for the five-bar)."""
        outputs = _outputs(self.linkage.default_outputs if outputs is None else outputs, self.linkage.outputs)
        C = self.output(outputs)
        D = np.zeros((len(outputs), len(self.inputs)))
        angles = ", ".join(f"theta{k}={np.degrees(t):.0f} deg" for k, t in zip(self.linkage.suffixes, self.theta))
        nm = name or f"fivebar at {angles}"
        return control.ss(self.A, self.B, C, D, inputs=list(self.inputs), outputs=list(outputs),
                          states=self.state_names, name=nm)

    def zeros(self, output: str, input: str) -> NDArray:
        """Transmission zeros (rad/s) of one channel, e.g. ``mm.zeros("w2", "tau1")``.

        The rigid states do not reach the deflection outputs (their columns of C vanish), and
        their four poles at s = 0 would appear as zeros at s = 0 that cancel them; they are
        left out of such channels, so the result holds only the zeros that shape the response.
        """
        if input not in self.inputs:
            raise InputError(f"input = {input!r} is not allowed: use one of {list(self.inputs)}")
        c = self.output(_outputs((output,), self.linkage.outputs))
        r = self.linkage.inputs
        k = r + self.n_modes
        keep = np.ones(2 * k, bool)
        rigid = list(range(r)) + list(range(k, k + r))
        if np.allclose(c[0, rigid], 0.0, atol=1e-12 * np.abs(c).max()):
            keep[rigid] = False
        j = self.inputs.index(input)
        A = self.A[np.ix_(keep, keep)]
        g = control.ss(A, self.B[keep][:, [j]], c[:, keep], 0.0)
        return np.asarray(control.zeros(g))

    def feedback_matrix(self, servo: Servo) -> NDArray:
        """The servo as a state feedback u = -F x (inputs, nx) on the reduced state."""
        sx = self.linkage.suffixes
        meas = tuple(f"theta{k}" if servo.measure == "rotor" else f"crank{k}" for k in sx)
        rate = tuple(f"omega{k}" if servo.measure == "rotor" else f"crank_rate{k}" for k in sx)
        return np.asarray(servo.kp)[:, None] * self.output(meas) + np.asarray(servo.kd)[:, None] * self.output(rate)

    def closed_loop(self, servo: Servo, K_x: NDArray | None = None,
                    outputs: Sequence[str] | None = None) -> control.StateSpace:
        """The loop closed by the servo (and the state feedback ``K_x``), inputs the torque
        disturbances ``tau1, tau4`` (N m, one per driven crank) added at the motors."""
        F = self.feedback_matrix(servo) + (0.0 if K_x is None else np.asarray(K_x))
        outputs = _outputs(self.linkage.default_outputs if outputs is None else outputs, self.linkage.outputs)
        return control.ss(self.A - self.B @ F, self.B, self.output(outputs), np.zeros((len(outputs), len(self.inputs))),
                          inputs=list(self.inputs), outputs=list(outputs), states=self.state_names)

    def elastic_poles(self, servo: Servo, K_x: NDArray | None = None) -> tuple[NDArray, NDArray]:
        """Natural frequencies (Hz) and damping ratios of the closed loop's elastic poles.

        ``f, zeta = mm.elastic_poles(servo, K_x)``: the poles of :meth:`closed_loop` ordered
        by natural frequency, one per complex pair, without the four of smallest magnitude
        (the servo's, from the rigid modes: two per driven crank); ``n_modes`` values (a real
        pair counts once, at its geometric mean frequency, with its damping ratio
        ``(a + b) / (2 sqrt(a b))``).
        """
        A = self.A - self.B @ (self.feedback_matrix(servo) + (0.0 if K_x is None else np.asarray(K_x)))
        p = np.linalg.eigvals(A)
        p = p[np.argsort(np.abs(p))][2 * self.linkage.inputs:]
        cx = p[p.imag > 1e-9 * np.abs(p)]
        real = np.sort(p[np.abs(p.imag) <= 1e-9 * np.abs(p)].real)
        wn = list(np.abs(cx))
        z = list(-cx.real / np.abs(cx))
        for a, b in zip(real[::2], real[1::2]):  # real pairs, neighbours in magnitude
            wn.append(np.sqrt(a * b))
            z.append(-(a + b) / (2 * np.sqrt(a * b)))
        o = np.argsort(wn)
        return np.asarray(wn)[o] / (2 * np.pi), np.asarray(z)[o]

    def loop(self, servo: Servo, channel: int, K_x: NDArray | None = None) -> control.StateSpace:
        """Loop transfer function broken at motor ``channel`` (1 or 2: the driven cranks in
        order), the other loops closed.

        L(s) = F_i (sI - A + B_j F_j)^-1 B_i with F the servo (plus ``K_x``) as state feedback;
        use with :func:`control.margin` (negative feedback).
        """
        r = self.linkage.inputs
        if isinstance(channel, bool) or channel not in range(1, r + 1):
            raise InputError(f"channel = {channel!r} is not allowed: use "
                             + (" or ".join(f"{k} (motor {k})" for k in range(1, r + 1))))
        F = self.feedback_matrix(servo) + (0.0 if K_x is None else np.asarray(K_x))
        i = channel - 1
        j = [k for k in range(r) if k != i]
        A = self.A - self.B[:, j] @ F[j]
        return control.ss(A, self.B[:, [i]], F[[i]], 0.0, inputs=[self.inputs[i]], outputs=[f"L{channel}"])

    def physical_gains(self, K_x: NDArray) -> tuple[NDArray, NDArray]:
        """A reduced-state feedback u = -K_x x as physical gains (G_p, G_v), each (inputs, n):
        u = -G_p p - G_v p', with x = (P p, P p') and P = :attr:`projection`."""
        K_x = np.asarray(K_x, float)
        r = self.linkage.inputs
        k = r + self.n_modes
        if K_x.shape != (r, 2 * k):
            raise InputError(f"K_x has shape {K_x.shape}: it must be ({r}, {2 * k})")
        P = self.projection
        return K_x[:, :k] @ P, K_x[:, k:] @ P



@analysis
def control_modal_model(
    setup: Setup | Params,
    theta1: float,
    theta4: float | None = None,
    n_modes: int = 6,
    *,
    rotor_inertia_scale: float = 1.0,
    damping_ratio: float | None = None,
    linkage: FlexibleLinkage | None = None,
) -> ControlModalModel:
    """The reduced model (the rigid modes + ``n_modes`` elastic modes) at a frozen configuration.

    ``mm = control_modal_model(setup, theta1, theta4)``; ``mm.statespace()``;
    ``control_modal_model(params, theta, n_modes=4)`` for a linkage with one driven crank.

    Parameters
    ----------
    setup
        The problem: a :class:`fivebar.description.setup.Setup` (its parameters and its mesh
        ``elements_per_link``, default the paper's; the configuration is frozen, so the crank
        speed, S and scheme do not apply, and the rotors are free), or a Params (``Setup(params)``).
    theta1, theta4
        Crank angles (rad), one per driven crank (``theta4`` only for two).
    n_modes
        Elastic modes kept (1 .. n - r, r the driven cranks).
    rotor_inertia_scale
        Factor on J0 (large: rotors clamped).
    damping_ratio
        Modal damping ratio; ``None`` takes ``params.damping_ratio``.
    linkage
        A prebuilt :class:`FlexibleLinkage` (its mesh and rotor scale are used).
    """
    s = as_setup(setup)
    params = s.params
    fl = linkage or FlexibleLinkage(params, s.elements_per_link, rotor_inertia_scale)
    th = _theta(fl, theta1, theta4)
    r = fl.inputs
    n_modes = _count("n_modes", n_modes, 1, fl.n - r)
    zeta = params.damping_ratio if damping_ratio is None else damping_ratio
    if isinstance(zeta, bool) or not isinstance(zeta, (int, float, np.integer, np.floating)) or not 0.0 <= zeta < 1.0:
        raise InputError(f"damping_ratio = {damping_ratio!r} is not allowed: it must lie in [0, 1)")
    M, K = fl.matrices(*th)
    Phi_r = fl.rigid_modes(*th)
    omega, Phi_e = fl.modes(M, K, Phi_r)
    omega, Phi_e = omega[:n_modes], Phi_e[:, :n_modes]
    Mr = Phi_r.T @ M @ Phi_r
    k = r + n_modes
    A = np.zeros((2 * k, 2 * k))
    A[:k, k:] = np.eye(k)
    A[k + r:, r:k] = -np.diag(omega**2)
    A[k + r:, k + r:] = -np.diag(2.0 * zeta * omega)
    B = np.zeros((2 * k, r))
    B[k:k + r] = np.linalg.inv(Mr)  # Phi_r^T B = I
    B[k + r:] = Phi_e.T @ fl.B
    return ControlModalModel(fl, th, omega, float(zeta), M, K, Phi_r, Phi_e, Mr, A, B)


def _theta(fl: FlexibleLinkage, theta1: float, theta4: float | None) -> tuple[float, ...]:
    """The frozen angles, one per driven crank, checked against the linkage."""
    if fl.inputs == 1:
        if theta4 is not None:
            raise InputError(f"theta4 = {theta4!r} is not allowed: the linkage {fl.params.linkage.name!r} has one "
                             "driven crank (give its angle alone, and n_modes by keyword)")
        return (float(_finite("theta1", theta1)),)
    if theta4 is None:
        raise InputError(f"theta4 is missing: the linkage {fl.params.linkage.name!r} has two driven cranks")
    return float(_finite("theta1", theta1)), float(_finite("theta4", theta4))


@analysis
def linear_model(
    setup: Setup | Params,
    theta1: float,
    theta4: float | None = None,
    n_modes: int = 6,
    outputs: Sequence[str] | None = None,
    **kwargs,
) -> control.StateSpace:
    """Linear flexible model at a frozen configuration, as a :class:`control.StateSpace`.

    ``sys = linear_model(setup, theta1, theta4, n_modes=6)`` (a Setup, of which its parameters and
    mesh are used, or a Params)

    Inputs ``tau1, tau4``: motor torques on the rotors (N m).  Outputs (default)
    ``theta1, theta4``: rotor angles (rad); ``w2, w3``: transverse midpoint deflections of L2,
    L3 relative to the rigid motion (m); others from :data:`OUTPUTS`.  Two rigid modes (free
    integrators) and ``n_modes`` elastic modes with modal damping.  For another linkage: one
    torque, angle and rigid mode per driven crank (named by the number of its link), the
    midpoints of its couplers (:attr:`fivebar.model.free_rotors.FlexibleLinkage.default_outputs`).
    Keyword arguments go to :func:`control_modal_model`.
    """
    return control_modal_model(setup, theta1, theta4, n_modes, **kwargs).statespace(outputs)



@analysis
def models_along_cycle(
    setup: Setup | Params,
    crank_angles: ArrayLike,
    n_modes: int = 6,
    outputs: Sequence[str] | None = None,
    **kwargs,
) -> list[control.StateSpace]:
    """Linear models at the configurations of the default crank laws.

    ``crank_angles`` (rad) are angles of crank AB from its initial angle; crank DE follows
    with the speed ratio (as :func:`fivebar.analyses.modal.frequencies_along_cycle`).  ``setup``:
    a Setup (its parameters and mesh) or a Params.
    """
    s = as_setup(setup)
    params = s.params
    th = _cycle_angles(params, crank_angles)
    fl = kwargs.pop("linkage", None) or FlexibleLinkage(params, s.elements_per_link, kwargs.pop("rotor_inertia_scale", 1.0))
    return [control_modal_model(s, *(tuple(a) + (None,) * (2 - len(a))), n_modes=n_modes, linkage=fl,
                                **kwargs).statespace(outputs) for a in zip(*th)]

