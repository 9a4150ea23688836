"""Controller design for the free-rotor linkage: PD servo, LQR damping, gain scheduling.

A decentralised PD servo per motor (:class:`~fivebar.analyses.control.control_model.Servo`, :func:`pd_servo`), an LQR state feedback
that damps the lowest elastic modes on top of it (:func:`damping_lqr`, with python-control's
:func:`control.lqr`), and those gains designed at several crank angles and interpolated along
the cycle (:func:`damping_schedule`, :func:`schedule`).  The plant is the reduced model of
:mod:`fivebar.analyses.control.control_model`; the loops are closed along the motion by
:mod:`fivebar.analyses.control.control_simulation`.
"""

from __future__ import annotations

from collections.abc import Callable

import control
import numpy as np
import scipy.interpolate
from numpy.typing import ArrayLike, NDArray

from .control_model import _MEASURES, ControlModalModel, Servo, control_modal_model
from ...errors import InputError
from ...model.free_rotors import FlexibleLinkage, _count, _cycle_angles, _finite, _positive, rigid_inertia
from ...description.params import Params
from ...description.setup import Setup, analysis, as_setup

__all__ = [
    "damping_lqr",
    "damping_schedule",
    "pd_servo",
    "schedule",
]

@analysis
def pd_servo(
    setup: Setup | Params, bandwidth: float, zeta: float = 0.7, measure: str = "rotor", samples: int = 36
) -> Servo:
    """PD gains that place each motor's rigid closed-loop poles at ``bandwidth`` (Hz).

    ``servo = pd_servo(setup, bandwidth=5.0)`` (a Setup, of which the parameters are used, or a
    Params): kp_i = J_i w^2, kd_i = 2 zeta J_i w,
    w = 2 pi bandwidth, with J_i the cycle mean of the diagonal of the rigid mass matrix
    (:func:`rigid_inertia`) over ``samples`` configurations of the default crank laws: for
    J_i s^2 + kd_i s + kp_i this is a pair of poles of natural frequency w and damping
    ``zeta``.
    """
    params = as_setup(setup).params
    bw = _positive("bandwidth", bandwidth, "Hz")
    z = _positive("zeta", zeta)
    samples = _count("samples", samples, 1, 10**6)
    if measure not in _MEASURES:
        raise InputError(f"measure = {measure!r} is not allowed: use one of {list(_MEASURES)}")
    from ...model.rigid import mass_matrix

    th = _cycle_angles(params, np.arange(samples) * 2 * np.pi / samples)
    J = mass_matrix(params, *th, inertia=rigid_inertia(params)).diagonal(axis1=-2, axis2=-1).mean(axis=0)
    w = 2.0 * np.pi * bw
    return Servo(tuple(J * w**2), tuple(2.0 * z * J * w), measure)


def damping_lqr(
    mm: ControlModalModel, servo: Servo, damped_modes: int = 2, q: float = 1.0, r: float = 1.0
) -> NDArray:
    """LQR state feedback that adds damping to the lowest elastic modes, on top of a servo.

    ``K_x = damping_lqr(mm, servo)``; the total control is u = -F x - K_x x with F the servo
    (:meth:`ControlModalModel.feedback_matrix`); check the loop with :meth:`ControlModalModel.closed_loop`.

    Designed on the servo-closed plant (A - B F, B) with the cost
    ``J = int( q sum_{j<=damped_modes} (omega_j^2 eta_j^2 + eta_j'^2) + r u^T u ) dt``: ``q`` weighs
    twice the elastic energy (J) of the first ``damped_modes`` elastic modes, ``r`` the torques (N m)^2.
    The rigid states carry no weight: the servo keeps them.

    It regulates the elastic state to zero.  Along the nominal motion the elastic state is
    not zero: the motion needs a quasi-static deflection.  Acting on the whole state, the
    controller fights that deflection with torques that push the cranks off their laws;
    acting on the deviation from the expected elastic motion (``reference`` of
    :func:`simulate_cycle`), it only damps.

    Returns
    -------
    ndarray
        The gain K_x, shape (inputs, nx) (two inputs for the five-bar).
    """
    damped_modes = _count("damped_modes", damped_modes, 1, mm.n_modes)
    q = _positive("q", q)
    r = _positive("r", r)
    n_in = mm.linkage.inputs
    k = n_in + mm.n_modes
    Q = np.zeros((2 * k, 2 * k))
    for j in range(damped_modes):
        Q[n_in + j, n_in + j] = q * mm.omega[j] ** 2
        Q[k + n_in + j, k + n_in + j] = q
    A = mm.A - mm.B @ mm.feedback_matrix(servo)
    K, _, _ = control.lqr(A, mm.B, Q, r * np.eye(n_in))
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
    try:
        G = np.asarray(gains, float)
    except (TypeError, ValueError):
        raise InputError(f"gains = {gains!r} is not allowed: give an array (N, ...) of numbers, one gain per angle") from None
    a = np.atleast_1d(_finite("angles", angles))
    if a.ndim != 1 or G.shape[:1] != a.shape:
        raise InputError(
            f"angles (shape {a.shape}) and gains (shape {G.shape}) do not match: give one gain per angle"
        )
    if np.any(np.diff(a) <= 0) or a[-1] - a[0] >= 2 * np.pi:
        raise InputError(f"angles = {a!r} are not allowed: they must increase strictly and span less than 2 pi")
    # piecewise linear (a B-spline of degree 1) through the period closed by the first gain
    spline = scipy.interpolate.make_interp_spline(
        np.concatenate([a, [a[0] + 2 * np.pi]]), np.concatenate([G, G[:1]], axis=0), k=1, axis=0
    )

    def gain(phi: ArrayLike) -> NDArray:
        return spline(a[0] + np.mod(np.asarray(phi, float) - a[0], 2 * np.pi))

    return gain


@analysis
def damping_schedule(
    setup: Setup | Params,
    servo: Servo,
    crank_angles: ArrayLike,
    n_modes: int = 6,
    damped_modes: int = 2,
    q: float = 1.0,
    r: float = 1.0,
) -> Callable[[ArrayLike], NDArray]:
    """:func:`damping_lqr` designed at each crank angle, as scheduled physical gains.

    ``G = damping_schedule(params, servo, angles)``; ``G(phi)`` is an array (2, r, n), r the
    driven cranks: ``G[0]`` the position gain G_p and ``G[1]`` the velocity gain G_v of
    tau = -G_p p - G_v p' (coordinates of :class:`FlexibleLinkage`, in which the gains do not
    depend on the sign or order of the mode shapes, so they can be interpolated).
    ``crank_angles`` (rad) are angles of crank AB from its initial angle.  ``setup``: a Setup
    (its parameters and mesh) or a Params.
    """
    s = as_setup(setup)
    a = np.atleast_1d(_finite("crank_angles", crank_angles))
    th = _cycle_angles(s.params, a)
    fl = FlexibleLinkage(s.params, s.elements_per_link)
    out = []
    for x in zip(*th):
        mm = control_modal_model(s, *(tuple(x) + (None,) * (2 - len(x))), n_modes=n_modes, linkage=fl)
        out.append(np.stack(mm.physical_gains(damping_lqr(mm, servo, damped_modes, q, r))))
    return schedule(np.array(out), a)

