r"""Electromagnetic coupling of the motors: eqs. (2.1), (2.3), (2.7), (A.4), (A.9)-(A.10).

**Speeds** (2.1).  The paper writes one symbol :math:`\omega_{01}` for two things.  We read
the rotor angle :math:`\beta = (1 - s)\,\omega_0 t` with the *mechanical* synchronous speed
:math:`\omega_0 = 2\pi f / p` (rad/s), and the time argument of the air-gap MMF wave as the
*electrical* angular frequency :math:`\omega_e = 2\pi f = p\,\omega_0`, so that
:math:`\cos(\omega_e t - p\alpha)` is a field of :math:`p` pole pairs turning at
:math:`\omega_0`.  For motor 1 (:math:`p = 1`) the two readings coincide.

**MMF** (A.9)-(A.10), with :math:`F_{-r}` corrected to :math:`(1 - a_e)` (errata E7):

.. math::

    F_{\pm s} ={}& \tfrac12 (1 \pm a_e) F_m, \qquad
    F_{\pm r} = \tfrac12 \frac{m_2}{m_1}
        \frac{x_m}{\sqrt{(r'/s_\pm)^2 + x'^2}} (1 \pm a_e) F_m, \\
    & s_+ = s,\ s_- = 2 - s, \qquad F_m = \frac{0.9\, W K_w I}{p}, \quad a_e = U_k / U_{kn},

and the air-gap MMF of (2.3)

.. math::

    F(\alpha, t) ={}& F_{+s}\cos(\omega_e t - p\alpha) + F_{-s}\cos(\omega_e t + p\alpha)
        + F_{+r}\cos(\omega_e t - p\alpha - \varphi_{10}) \\
        &+ F_{-r}\cos(\omega_e t + p\alpha - \varphi_{20})
        = \operatorname{Re}\bigl[C(t)\, e^{-ip\alpha}\bigr],

    C(t) = P e^{i\omega_e t} + \bar N e^{-i\omega_e t}, \quad
    P = F_{+s} + F_{+r} e^{-i\varphi_{10}}, \quad N = F_{-s} + F_{-r} e^{-i\varphi_{20}}.

At every instant the wave is one sinusoid in space of amplitude :math:`|C(t)|`, which swings
between :math:`\bigl||P| - |N|\bigr|` and :math:`|P| + |N|` at :math:`2\omega_e`: the elliptic
field.  The *literal* field uses the printed numbers (a flux density
:math:`\mu_0 F_m / \sigma` of about 11 T for motor 1, errata E9); the *calibrated* field
scales :math:`F_m` so that :math:`\mu_0 (F_{+s} + F_{-s} + F_{+r} + F_{-r}) / \sigma` equals the
assumed ``gap_flux_density``: the largest flux density the four waves can reach (all in phase),
which is the peak :math:`\mu_0 (|P| + |N|)/\sigma` of the resultant when
:math:`\varphi_{10} = \varphi_{20} = 0`.

**Pull** (2.3), (A.4).  With the rotor centre displaced by :math:`(x, y)` the gap is
:math:`\sigma - x\cos\alpha - y\sin\alpha` (:math:`\sigma = k_\mu \delta_0`), its permeance per
unit area :math:`\mu_0 / (\sigma - x\cos\alpha - y\sin\alpha)`, and the magnetic co-energy

.. math::

    W'(x, y, t) = \frac{R L}{2} \int_0^{2\pi}
        \frac{\mu_0\, F(\alpha, t)^2}{\sigma - x\cos\alpha - y\sin\alpha}\, d\alpha .

The force on the rotor at constant currents is :math:`+\partial W' / \partial(x, y)`, so the
mechanical potential is :math:`V = -W'`.  To second order in :math:`(x, y)`,
:math:`V = \text{const} + \bar{\mathbf k}_{01}^\top \mathbf q
+ \tfrac12 \mathbf q^\top \bar{\mathbf K}_{12} \mathbf q` with

.. math::

    \bar K_{12} ={}& -\frac{R L \Lambda}{2\sigma^2} \int_0^{2\pi} F^2
        \begin{bmatrix} 1 + \cos 2\alpha & \sin 2\alpha \\
                        \sin 2\alpha & 1 - \cos 2\alpha \end{bmatrix} d\alpha, \\
    \bar k_{01} ={}& -\frac{R L \Lambda}{2\sigma} \int_0^{2\pi} F^2
        \begin{bmatrix} \cos\alpha \\ \sin\alpha \end{bmatrix} d\alpha, \qquad
    \Lambda = \mu_0 / \sigma .

The integrals are closed forms in :math:`C(t)`:

.. math::

    & \int F^2 d\alpha = \pi |C|^2, \quad
    \int F^2 \cos 2\alpha\, d\alpha + i \int F^2 \sin 2\alpha\, d\alpha
        = \tfrac{\pi}{2} C^2 \ (p = 1), \ 0 \ (p \ge 2), \\
    & \int F^2 \cos\alpha\, d\alpha = \int F^2 \sin\alpha\, d\alpha = 0 .

So :math:`\bar{\mathbf k}_{01} \equiv 0` for every integer :math:`p` (a centred rotor feels no
net pull; the static pull is :math:`-\bar K_{12}\bar{\mathbf e}` of (2.7)), and
:math:`\bar K_{12}(t)` holds only the frequencies 0 and :math:`2\omega_e`.  The derived
:math:`\bar K_{12}` is negative (errata E8).  The paper prints :math:`+p R L \Lambda /
(4\sigma^2)` in front of the same integrals (and :math:`+p R L \Lambda / (2\sigma)` for
:math:`\bar k_{01}`): the opposite sign, a factor :math:`p` that double counts the poles (the
integral over :math:`0 \le \alpha \le 2\pi` already covers all :math:`2p` poles) and, against
its own energy (2.3), a factor 1/2 (the coefficient of :math:`q^2` taken for that of
:math:`q^2/2`) (errata E16).  For :math:`p \ge 2` the pull is isotropic,
:math:`\bar K_{12} = -\pi R L B^2 / (2\mu_0\sigma)\, I` for a circular field of peak flux
density :math:`B`: the classical stiffness of unbalanced magnetic pull.

**Variants.**  Two switches, set together by ``variant`` and overridable one by one:

=================  ==============================  ====================================
``variant``        ``field``                       ``form``
=================  ==============================  ====================================
``"calibrated"``   ``"calibrated"`` (0.7 T)        ``"derived"`` (physical sign, no p)
``"literal"``      ``"literal"`` (printed MMF)     ``"printed"`` (as (A.4) prints it)
=================  ==============================  ====================================

``field="literal", form="derived"`` is the printed motor data under the correct physics: its
negative stiffness exceeds the shaft's and the rotor is statically unstable (errata E9).

**Eccentricity** (2.7): :math:`\bar{\mathbf e} = [e_{11} + \varepsilon_0\cos\beta,\
e_{12} + \varepsilon_0 \sin\beta,\ 0,\ 0]^\top` with :math:`(e_{11}, e_{12}) =
e_0(\cos a, \sin a)`, :math:`a` = ``static_eccentricity_angle``, both eccentricities
multiplied by the assumption ``eccentricity_scale`` (the printed ones exceed the gap, errata
E15).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FivebarError
from ..description.params import Motor, Params

__all__ = [
    "ElectromagneticsError",
    "VARIANTS",
    "synchronous_speed",
    "electrical_angular_frequency",
    "rotor_speed",
    "rotor_angle",
    "supply_frequency_for_speed",
    "effective_gap",
    "signal_coefficient",
    "magnetizing_mmf",
    "mmf_components",
    "mmf_phasors",
    "mmf_wave",
    "gap_flux_density",
    "peak_flux_density",
    "electromagnetic_stiffness",
    "electromagnetic_force",
    "stiffness_harmonics",
    "unbalanced_magnetic_pull",
    "eccentricity_vector",
    "net_rotor_stiffness",
    "field_frequencies",
]

#: variant -> (field, form); see the module docstring.
VARIANTS: dict[str, tuple[str, str]] = {
    "calibrated": ("calibrated", "derived"),
    "literal": ("literal", "printed"),
}
_FIELDS = ("calibrated", "literal")
_FORMS = ("derived", "printed")
_MMF_KEYS = ("F_+s", "F_-s", "F_+r", "F_-r")


class ElectromagneticsError(FivebarError, ValueError):
    """Bad input to the electromagnetic model (variant, time, displacement, motor data)."""


# --- input checks ----------------------------------------------------------------------------
def _choice(name: str, value: object, allowed: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in allowed:
        raise ElectromagneticsError(
            f"{name} = {value!r} is not allowed: it must be one of {list(allowed)}"
        )
    return value


def _resolve(
    params: Params, variant: str | None, field: str | None, form: str | None
) -> tuple[str, str]:
    """(field, form) from a variant name (default ``params.em_variant``) and overrides."""
    v = params.em_variant if variant is None else variant
    f0, g0 = VARIANTS[_choice("variant", v, tuple(VARIANTS))]
    f = f0 if field is None else _choice("field", field, _FIELDS)
    g = g0 if form is None else _choice("form", form, _FORMS)
    return f, g


def _times(t: ArrayLike, name: str = "t") -> NDArray[np.float64]:
    try:
        arr = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise ElectromagneticsError(
            f"{name} = {t!r} is not allowed: it must be real numbers (s)"
        ) from None
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)].ravel()[0]
        raise ElectromagneticsError(f"{name} contains {bad!r}: times must be finite (s)")
    return arr


def _real(name: str, value: ArrayLike, unit: str) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ElectromagneticsError(
            f"{name} = {value!r} is not allowed: it must be real numbers ({unit})"
        ) from None
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)].ravel()[0]
        raise ElectromagneticsError(f"{name} contains {bad!r}: it must be finite ({unit})")
    return arr


# --- speeds (2.1) ----------------------------------------------------------------------------
def electrical_angular_frequency(params: Params) -> float:
    r"""Electrical angular frequency of the supply, :math:`\omega_e = 2\pi f` (rad/s).

    The time argument of the MMF wave in (2.3) and (A.4) (the paper's :math:`\omega_{01} t`,
    read as electrical).
    """
    return 2.0 * math.pi * params.supply_frequency


def synchronous_speed(motor: Motor, params: Params) -> float:
    r"""Mechanical synchronous speed :math:`\omega_0 = 2\pi f / p` (rad/s), eq. (2.1).

    The speed at which the field of :math:`p` pole pairs turns (the paper's
    :math:`\omega_{01}` in :math:`\beta_1 = (1 - s_1)\omega_{01} t`).

    Parameters
    ----------
    motor
        The motor (uses ``p``).
    params
        Uses ``supply_frequency`` (Hz).

    Returns
    -------
    float
        :math:`\omega_0` in rad/s (motor 1 at 50 Hz: 314.16 rad/s = 3000 r/min).
    """
    return electrical_angular_frequency(params) / motor.p


def rotor_speed(motor: Motor, params: Params) -> float:
    r"""Rotor speed :math:`\Omega = (1 - s)\,\omega_0` (rad/s), eq. (2.1)."""
    return (1.0 - motor.s) * synchronous_speed(motor, params)


def rotor_angle(motor: Motor, params: Params, t: ArrayLike) -> NDArray[np.float64]:
    r"""Rotor angle :math:`\beta = (1 - s)\,\omega_0 t` (rad), eq. (2.1).

    Parameters
    ----------
    motor, params
        As in :func:`synchronous_speed`; uses the slip ``motor.s``.
    t
        Time (s), any shape.

    Returns
    -------
    ndarray, shape of ``t``
        :math:`\beta` in rad (not wrapped).
    """
    return rotor_speed(motor, params) * _times(t)


def supply_frequency_for_speed(motor: Motor, speed: float) -> float:
    r"""Supply frequency at which the rotor turns at ``speed`` (Hz).

    :math:`f = p\,\Omega / (2\pi (1 - s))`, the inverse of :func:`rotor_speed`.

    With the crank clamped to the shaft (errata E6) the rotor turns with the crank; this is
    the supply frequency consistent with a crank speed (errata E19).

    Parameters
    ----------
    motor
        Uses ``p`` and ``s``.
    speed
        Rotor speed :math:`\Omega` (rad/s), positive.

    Returns
    -------
    float
        Frequency in Hz.
    """
    v = float(_real("speed", speed, "rad/s"))
    if v <= 0:
        raise ElectromagneticsError(
            f"speed = {speed!r} is not allowed: it must be positive (rad/s)"
        )
    return motor.p * v / (2.0 * math.pi * (1.0 - motor.s))


# --- MMF (A.9)-(A.10) ------------------------------------------------------------------------
def effective_gap(motor: Motor) -> float:
    r"""Effective air gap :math:`\sigma = k_\mu \delta_0` (m), below (2.3)."""
    return motor.k_mu * motor.delta0


def signal_coefficient(motor: Motor) -> float:
    r"""Effective signal coefficient :math:`a_e = U_k / U_{kn}` (-), below (A.10).

    Raises
    ------
    ElectromagneticsError
        If :math:`a_e > 1` (the control voltage exceeds the rated voltage).
    """
    a = motor.U_k / motor.rated_voltage
    if not 0.0 <= a <= 1.0:
        raise ElectromagneticsError(
            f"a_e = U_k / U_kn = {motor.U_k!r} / {motor.rated_voltage!r} = {a:.4g} is not "
            f"allowed: the control voltage must lie between 0 and the rated voltage"
        )
    return a


def magnetizing_mmf(motor: Motor) -> float:
    r"""Printed MMF amplitude :math:`F_m = 0.9\, W K_w I / p` (A, ampere-turns), below (A.10)."""
    return 0.9 * motor.W * motor.K_w * motor.I / motor.p


def mmf_components(
    motor: Motor,
    variant: Literal["calibrated", "literal"] = "calibrated",
    gap_flux_density: float | None = None,
) -> dict[str, float]:
    r"""Amplitudes of the four MMF waves, eqs. (A.9)-(A.10) with E7 (A).

    ``F = mmf_components(params.motors["motor1"], "calibrated", params.gap_flux_density)``

    Parameters
    ----------
    motor
        The motor (uses ``W, K_w, I, p, U_k, rated_voltage, m1, m2, x_m, r_prime, x_prime, s``
        and, for the calibration, ``mu0, k_mu, delta0``).
    variant
        ``"calibrated"``: :math:`F_m` scaled so that :math:`\mu_0 (F_{+s} + F_{-s} + F_{+r}
        + F_{-r}) / \sigma` equals ``gap_flux_density`` (the largest flux density the four
        waves can reach together).  ``"literal"``: :math:`F_m = 0.9 W K_w I / p` as printed.
    gap_flux_density
        Target flux density (T), required for ``"calibrated"`` (``params.gap_flux_density``).

    Returns
    -------
    dict
        Keys ``"F_+s", "F_-s", "F_+r", "F_-r"``; amplitudes in A (ampere-turns per pole pair
        as in (A.9)).  The negative-sequence rotor term uses :math:`(1 - a_e)` (errata E7).

    Raises
    ------
    ElectromagneticsError
        For an unknown variant, a missing or non-positive ``gap_flux_density``, or
        :math:`a_e > 1`.
    """
    _choice("variant", variant, _FIELDS)
    a = signal_coefficient(motor)
    Fm = magnetizing_mmf(motor)
    ratio = motor.m2 / motor.m1 * motor.x_m
    rp = ratio / math.hypot(motor.r_prime / motor.s, motor.x_prime)
    rm = ratio / math.hypot(motor.r_prime / (2.0 - motor.s), motor.x_prime)
    F = {
        "F_+s": 0.5 * (1.0 + a) * Fm,
        "F_-s": 0.5 * (1.0 - a) * Fm,
        "F_+r": 0.5 * rp * (1.0 + a) * Fm,
        "F_-r": 0.5 * rm * (1.0 - a) * Fm,  # printed (1 + a_2): errata E7
    }
    if variant == "calibrated":
        if gap_flux_density is None:
            raise ElectromagneticsError(
                "gap_flux_density = None is not allowed for the calibrated variant: give the "
                "air-gap flux density in T (params.gap_flux_density)"
            )
        B = float(_real("gap_flux_density", gap_flux_density, "T"))
        if B <= 0:
            raise ElectromagneticsError(
                f"gap_flux_density = {gap_flux_density!r} is not allowed: it must be positive (T)"
            )
        scale = B * effective_gap(motor) / (motor.mu0 * sum(F.values()))
        F = {k: v * scale for k, v in F.items()}
    return F


def _mmf(motor: Motor, params: Params, field: str) -> dict[str, float]:
    return mmf_components(motor, field, params.gap_flux_density)


def _phasors(F: dict[str, float], params: Params) -> tuple[complex, complex]:
    P = F["F_+s"] + F["F_+r"] * np.exp(-1j * params.phase_phi10)
    N = F["F_-s"] + F["F_-r"] * np.exp(-1j * params.phase_phi20)
    return complex(P), complex(N)


def mmf_phasors(
    motor: Motor, params: Params, variant: str | None = None, *, field: str | None = None
) -> tuple[complex, complex]:
    r"""Forward and backward phasors :math:`P, N` of the resultant MMF (A).

    :math:`F(\alpha, t) = \operatorname{Re}[(P e^{i\omega_e t} + \bar N e^{-i\omega_e t})
    e^{-ip\alpha}]` with :math:`P = F_{+s} + F_{+r} e^{-i\varphi_{10}}` and
    :math:`N = F_{-s} + F_{-r} e^{-i\varphi_{20}}`.

    Parameters
    ----------
    motor, params
        The motor; ``params`` gives the phases and ``gap_flux_density``.
    variant, field
        Variant name (default ``params.em_variant``) and an optional ``field`` override.

    Returns
    -------
    P, N : complex
    """
    f, _ = _resolve(params, variant, field, None)
    return _phasors(_mmf(motor, params, f), params)


def mmf_wave(
    motor: Motor,
    params: Params,
    alpha: ArrayLike,
    t: ArrayLike,
    variant: str | None = None,
    *,
    field: str | None = None,
) -> NDArray[np.float64]:
    r"""Air-gap MMF wave :math:`F(\alpha, t)` of (2.3) (A).

    Parameters
    ----------
    motor, params
        The motor and the global parameters (supply frequency, phases, flux density).
    alpha
        Angle around the stator bore from the motor's x axis (rad).
    t
        Time (s); ``alpha`` and ``t`` broadcast against each other.
    variant, field
        As in :func:`mmf_phasors`.

    Returns
    -------
    ndarray
        :math:`F` in A, shape ``broadcast(alpha, t)``.
    """
    f, _ = _resolve(params, variant, field, None)
    F = _mmf(motor, params, f)
    a = _real("alpha", alpha, "rad")
    wt = electrical_angular_frequency(params) * _times(t)
    pa = motor.p * a
    return (
        F["F_+s"] * np.cos(wt - pa)
        + F["F_-s"] * np.cos(wt + pa)
        + F["F_+r"] * np.cos(wt - pa - params.phase_phi10)
        + F["F_-r"] * np.cos(wt + pa - params.phase_phi20)
    )


def gap_flux_density(
    motor: Motor,
    params: Params,
    alpha: ArrayLike,
    t: ArrayLike,
    variant: str | None = None,
    *,
    field: str | None = None,
) -> NDArray[np.float64]:
    r"""Air-gap flux density :math:`B = \mu_0 F(\alpha, t) / \sigma` of a centred rotor (T).

    Parameters and shapes as in :func:`mmf_wave`.
    """
    F = mmf_wave(motor, params, alpha, t, variant, field=field)
    return motor.mu0 * F / effective_gap(motor)


def peak_flux_density(
    motor: Motor, params: Params, variant: str | None = None, *, field: str | None = None
) -> float:
    r"""Largest air-gap flux density over space and time, :math:`\mu_0 (|P| + |N|) / \sigma` (T).

    For the calibrated field with :math:`\varphi_{10} = \varphi_{20} = 0` this is
    ``params.gap_flux_density``; for the literal field of motor 1 it is hundreds of tesla.
    """
    P, N = mmf_phasors(motor, params, variant, field=field)
    return motor.mu0 * (abs(P) + abs(N)) / effective_gap(motor)


# --- the pull (A.4) --------------------------------------------------------------------------
def _C(motor: Motor, params: Params, field: str, t: NDArray) -> NDArray[np.complex128]:
    P, N = _phasors(_mmf(motor, params, field), params)
    ph = np.exp(1j * electrical_angular_frequency(params) * t)
    return P * ph + np.conj(N) / ph


def _integrals(motor: Motor, C: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    r"""Closed forms of the integrals of F^2, F^2 cos 2 alpha and F^2 sin 2 alpha over a turn."""
    I0 = math.pi * np.abs(C) ** 2
    if motor.p == 1:
        C2 = 0.5 * math.pi * C**2
        return I0, C2.real, C2.imag
    zero = np.zeros_like(I0)
    return I0, zero, zero


def _prefactor(motor: Motor, form: str, power: int) -> float:
    """RL Lambda / (2 sigma^power) (derived, with minus sign) or p RL Lambda / (c sigma^power)."""
    sigma = effective_gap(motor)
    base = motor.R01 * motor.L01 * motor.mu0 / sigma / sigma**power
    if form == "derived":
        return -0.5 * base
    return motor.p * base / (4.0 if power == 2 else 2.0)


def electromagnetic_stiffness(
    motor: Motor,
    params: Params,
    t: ArrayLike,
    variant: str | None = None,
    *,
    field: str | None = None,
    form: str | None = None,
) -> NDArray[np.float64]:
    r"""Electromagnetic stiffness :math:`\bar K_{12}(t)` of the motor element, eq. (A.4) (N/m).

    ``K12 = electromagnetic_stiffness(params.motors["motor1"], params, t)``

    Parameters
    ----------
    motor, params
        The motor and the global parameters.
    t
        Time (s), any shape.
    variant
        ``"calibrated"`` or ``"literal"`` (default ``params.em_variant``); see the module
        docstring.
    field
        Override of the field: ``"calibrated"`` or ``"literal"``.
    form
        Override of the formula: ``"derived"`` (:math:`-R L \Lambda / (2\sigma^2)`, the
        physical negative stiffness) or ``"printed"`` (:math:`+p R L \Lambda/(4\sigma^2)`).

    Returns
    -------
    ndarray, shape ``t.shape + (4, 4)``
        DOFs ``[U1, U2, U3, U4]`` of the motor element; only the transverse 2 x 2 block
        (rotor x, y) is nonzero; symmetric.
    """
    f, g = _resolve(params, variant, field, form)
    tt = _times(t)
    I0, Ic, Is = _integrals(motor, _C(motor, params, f, tt))
    c = _prefactor(motor, g, 2)
    K = np.zeros(tt.shape + (4, 4))
    K[..., 0, 0] = c * (I0 + Ic)
    K[..., 1, 1] = c * (I0 - Ic)
    K[..., 0, 1] = K[..., 1, 0] = c * Is
    return K


def electromagnetic_force(
    motor: Motor,
    params: Params,
    t: ArrayLike,
    variant: str | None = None,
    *,
    field: str | None = None,
    form: str | None = None,
) -> NDArray[np.float64]:
    r"""Linear term :math:`\bar{\mathbf k}_{01}(t)` of the motor's potential, eq. (A.4) (N).

    :math:`\int_0^{2\pi} F^2 \cos\alpha\, d\alpha = \int_0^{2\pi} F^2 \sin\alpha\, d\alpha = 0`
    for a field of any integer number :math:`p` of pole pairs (:math:`F^2` holds only the
    space harmonics 0 and :math:`2p`), so :math:`\bar{\mathbf k}_{01} \equiv 0` in every
    variant: a centred rotor feels no net magnetic force.  The function returns the zero
    vector of the right shape so that (2.7) can be assembled as printed.

    Parameters
    ----------
    motor, params, t, variant, field, form
        As in :func:`electromagnetic_stiffness` (validated the same way).

    Returns
    -------
    ndarray, shape ``t.shape + (4,)``
        Zeros (N).
    """
    _resolve(params, variant, field, form)
    tt = _times(t)
    return np.zeros(tt.shape + (4,))


def stiffness_harmonics(
    motor: Motor,
    params: Params,
    variant: str | None = None,
    *,
    field: str | None = None,
    form: str | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    r"""Exact Fourier form of the electromagnetic stiffness.

    :math:`\bar K_{12}(t) = K_0 + K_c\cos 2\omega_e t + K_s \sin 2\omega_e t`.

    ``K0, Kc, Ks = stiffness_harmonics(params.motors["motor2"], params)``

    :math:`|C|^2` and :math:`C^2` hold only the frequencies 0 and :math:`2\omega_e`, so three
    samples determine the three matrices exactly.  :math:`K_0` is the mean (period-averaged)
    electromagnetic stiffness used for the modes of the mean system.

    Returns
    -------
    K0, Kc, Ks : ndarray, shape (4, 4)
        In N/m (transverse block only).
    """
    w = electrical_angular_frequency(params)
    t = np.array([0.0, 0.5 * math.pi, 0.25 * math.pi]) / w  # 2 w t = 0, pi, pi/2
    K = electromagnetic_stiffness(motor, params, t, variant, field=field, form=form)
    K0 = 0.5 * (K[0] + K[1])
    return K0, 0.5 * (K[0] - K[1]), K[2] - K0


def unbalanced_magnetic_pull(
    motor: Motor,
    params: Params,
    x: ArrayLike,
    y: ArrayLike,
    t: ArrayLike,
    variant: str | None = None,
    *,
    field: str | None = None,
    n_alpha: int = 1024,
) -> NDArray[np.float64]:
    r"""Exact magnetic force on a rotor displaced by :math:`(x, y)`, by quadrature (N).

    :math:`\mathbf f = \partial W' / \partial (x, y) = \frac{R L}{2} \int_0^{2\pi}
    \frac{\mu_0 F^2 (\cos\alpha, \sin\alpha)}{(\sigma - x\cos\alpha - y\sin\alpha)^2} d\alpha`,
    not expanded in the displacement (the trapezoidal rule, spectrally accurate for this
    periodic integrand while :math:`\sqrt{x^2+y^2}` is well below :math:`\sigma`).  For small
    displacements it tends to :math:`-\bar K_{12} \mathbf q` of the derived form.

    Parameters
    ----------
    motor, params
        The motor and the global parameters.
    x, y
        Rotor-centre displacement (m); broadcast with ``t``.
    t
        Time (s).
    variant, field
        Select the field (the formula is always the physical one).
    n_alpha
        Number of quadrature points around the gap.

    Returns
    -------
    ndarray, shape ``broadcast(x, y, t) + (2,)``
        Force components (N) in x and y.

    Raises
    ------
    ElectromagneticsError
        If the displacement reaches the effective gap :math:`\sigma` (rotor on the stator).
    """
    f, _ = _resolve(params, variant, field, None)
    if isinstance(n_alpha, bool) or not isinstance(n_alpha, (int, np.integer)) or n_alpha < 8:
        raise ElectromagneticsError(
            f"n_alpha = {n_alpha!r} is not allowed: it must be an integer >= 8"
        )
    xx, yy, tt = np.broadcast_arrays(_real("x", x, "m"), _real("y", y, "m"), _times(t))
    sigma = effective_gap(motor)
    e = np.hypot(xx, yy)
    if np.any(e >= sigma):
        raise ElectromagneticsError(
            f"displacement {float(e.max()):.4g} m is not allowed: it must be below the effective "
            f"gap sigma = k_mu delta0 = {sigma:.4g} m (the rotor would touch the stator)"
        )
    a = np.linspace(0.0, 2.0 * math.pi, n_alpha, endpoint=False)
    ca, sa = np.cos(a), np.sin(a)
    F = mmf_wave(motor, params, a, tt[..., None], variant, field=f)
    gap = sigma - xx[..., None] * ca - yy[..., None] * sa
    g = motor.mu0 * F**2 / gap**2
    w = 2.0 * math.pi / n_alpha * 0.5 * motor.R01 * motor.L01
    return np.stack([w * (g @ ca), w * (g @ sa)], axis=-1)


# --- eccentricity (2.7) ----------------------------------------------------------------------
def eccentricity_vector(motor: Motor, params: Params, t: ArrayLike) -> NDArray[np.float64]:
    r"""Eccentricity vector :math:`\bar{\mathbf e}(t)` of (2.7) for the motor element (m).

    :math:`[e_{11} + \varepsilon_0\cos\beta,\ e_{12} + \varepsilon_0\sin\beta,\ 0,\ 0]` with
    :math:`(e_{11}, e_{12}) = e_0 (\cos a, \sin a)`, :math:`a` =
    ``params.static_eccentricity_angle`` and :math:`\beta` from :func:`rotor_angle`; ``e0`` and
    ``eps0`` multiplied by ``params.eccentricity_scale`` (errata E15).

    Returns
    -------
    ndarray, shape ``t.shape + (4,)``
    """
    beta = rotor_angle(motor, params, t)
    k = params.eccentricity_scale
    a = params.static_eccentricity_angle
    out = np.zeros(beta.shape + (4,))
    out[..., 0] = k * (motor.e0 * math.cos(a) + motor.eps0 * np.cos(beta))
    out[..., 1] = k * (motor.e0 * math.sin(a) + motor.eps0 * np.sin(beta))
    return out


# --- stability and spectrum ------------------------------------------------------------------
def net_rotor_stiffness(
    motor: Motor,
    params: Params,
    t: ArrayLike,
    variant: str | None = None,
    *,
    field: str | None = None,
    form: str | None = None,
) -> NDArray[np.float64]:
    r"""Eigenvalues of the rotor's transverse stiffness :math:`\bar K_{11} + \bar K_{12}(t)` (N/m).

    :math:`\bar K_{11}` is the shaft stiffness of :func:`fivebar.model.elements.motor_element`.  A
    negative eigenvalue means the rotor is statically unstable at that instant: the magnetic
    pull outgrows the shaft's restoring force.

    Returns
    -------
    ndarray, shape ``t.shape + (2,)``
        The two eigenvalues, ascending.
    """
    from .elements import motor_element  # the shaft stiffness belongs to the elements module

    _, K11 = motor_element(motor)
    K12 = electromagnetic_stiffness(motor, params, t, variant, field=field, form=form)
    K = K11[:2, :2] + K12[..., :2, :2]
    return np.linalg.eigvalsh(K)


def field_frequencies(motor: Motor, params: Params) -> dict[str, object]:
    r"""Angular frequencies in the electromagnetic excitation of one motor (rad/s).

    Returns
    -------
    dict
        ``"electrical"``: :math:`\omega_e = 2\pi f`; ``"field"``: :math:`\omega_0 = \omega_e/p`,
        the turning speed of the field (the paper's :math:`\nu_6, \nu_7`); ``"rotor"``:
        :math:`\Omega = (1 - s)\omega_0` (:math:`\nu_1, \nu_2`); ``"stiffness"``: the
        frequencies present in :math:`\bar K_{12}(t)` (0 and, if the ripple is nonzero,
        :math:`2\omega_e`); ``"force"``: those in :math:`\bar{\mathbf k}_{01}` (none);
        ``"eccentricity"``: those in :math:`\bar{\mathbf e}(t)` (0 and :math:`\Omega`);
        ``"pull"``: those in :math:`\bar K_{12}(t)\bar{\mathbf e}(t)`, the electromagnetic
        load of (2.7): sums and differences of the two sets.  Tuples sorted ascending.
    """
    we = electrical_angular_frequency(params)
    w0 = synchronous_speed(motor, params)
    Om = rotor_speed(motor, params)
    K0, Kc, Ks = stiffness_harmonics(motor, params, field="literal", form="derived")
    ripple = np.abs(Kc).max() + np.abs(Ks).max() > 1e-12 * np.abs(K0).max()
    stiff = (0.0, 2.0 * we) if ripple else (0.0,)
    ecc: tuple[float, ...] = (0.0, Om) if motor.eps0 > 0 else (0.0,)
    if params.eccentricity_scale == 0:
        ecc = ()
    pull = sorted(
        {abs(a + b) for a in stiff for b in ecc}
        | {abs(a - b) for a in stiff for b in ecc}
    )
    return {
        "electrical": we,
        "field": w0,
        "rotor": Om,
        "stiffness": stiff,
        "force": (),
        "eccentricity": ecc,
        "pull": tuple(float(v) for v in pull),
    }
