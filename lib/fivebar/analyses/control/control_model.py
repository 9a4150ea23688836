r"""Modal reduction of the free-rotor linkage to a state-space model (python-control).

The full-order model is :class:`fivebar.model.free_rotors.FlexibleLinkage`; this module keeps its two
rigid modes and a few elastic modes at a frozen configuration and writes the result as a
:class:`control.StateSpace` with the motor torques as inputs and the outputs of
:data:`fivebar.model.free_rotors.OUTPUTS`.

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

__all__ = [
    "ControlModalModel",
    "Servo",
    "control_modal_model",
    "linear_model",
    "models_along_cycle",
]

_INPUTS = ("tau1", "tau4")


# --- the servo -----------------------------------------------------------------------------------
_MEASURES = ("rotor", "crank")


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
            try:
                ok = len(v) == 2 and all(not isinstance(x, bool) and math.isfinite(x) and x >= 0 for x in v)
            except TypeError:
                ok = False
            if not ok:
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

    def feedback_matrix(self, servo: Servo) -> NDArray:
        """The servo as a state feedback u = -F x (2, nx) on the reduced state."""
        meas = ("theta1", "theta4") if servo.measure == "rotor" else ("crank1", "crank4")
        rate = ("omega1", "omega4") if servo.measure == "rotor" else ("crank_rate1", "crank_rate4")
        return np.asarray(servo.kp)[:, None] * self.output(meas) + np.asarray(servo.kd)[:, None] * self.output(rate)

    def closed_loop(self, servo: Servo, K_x: NDArray | None = None,
                    outputs: Sequence[str] = DEFAULT_OUTPUTS) -> control.StateSpace:
        """The loop closed by the servo (and the state feedback ``K_x``), inputs the torque
        disturbances ``tau1, tau4`` (N m) added at the motors."""
        F = self.feedback_matrix(servo) + (0.0 if K_x is None else np.asarray(K_x))
        outputs = _outputs(outputs)
        return control.ss(self.A - self.B @ F, self.B, self.output(outputs), np.zeros((len(outputs), 2)),
                          inputs=list(_INPUTS), outputs=list(outputs), states=self.state_names)

    def elastic_poles(self, servo: Servo, K_x: NDArray | None = None) -> tuple[NDArray, NDArray]:
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

    def loop(self, servo: Servo, channel: int, K_x: NDArray | None = None) -> control.StateSpace:
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
    if isinstance(zeta, bool) or not isinstance(zeta, (int, float, np.integer, np.floating)) or not 0.0 <= zeta < 1.0:
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



def models_along_cycle(
    params: Params,
    crank_angles: ArrayLike,
    n_modes: int = 6,
    outputs: Sequence[str] = DEFAULT_OUTPUTS,
    **kwargs,
) -> list[control.StateSpace]:
    """Linear models at the configurations of the default crank laws.

    ``crank_angles`` (rad) are angles of crank AB from its initial angle; crank DE follows
    with the speed ratio (as :func:`fivebar.analyses.modal.frequencies_along_cycle`).
    """
    th1, th4 = _cycle_angles(params, crank_angles)
    fl = kwargs.pop("linkage", None) or FlexibleLinkage(
        params, kwargs.pop("elements_per_link", None), kwargs.pop("rotor_inertia_scale", 1.0)
    )
    return [control_modal_model(params, a, b, n_modes, linkage=fl, **kwargs).statespace(outputs) for a, b in zip(th1, th4)]

