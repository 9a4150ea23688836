r"""The modal equations (3.4): their coefficients and excitation, the input of multiple scales.

The modal equations (3.4), with the mode index ``r`` written out (the paper carries it through
the selector :math:`\xi` of (3.5)), read

.. math::

    \ddot\eta_r + \omega_r^2\eta_r ={}& \sum_j F_{rj}\cos(\Omega_j t + \tau_{rj})
    + \varepsilon\Big(-2\zeta_r\omega_r\dot\eta_r - \sum_s \alpha_{rs}\eta_s \\
    &- \sum_{j,s} P^{(j)}_{rs}\cos(\Omega^P_j t + \varphi_j)\,\eta_s
    + \sum_{s,t}\delta_{rst}\eta_s\eta_t
    + \sum_{s,t,u}\gamma_{rstu}\eta_s\eta_t\eta_u\Big).

The harmonics ``j`` are the Fourier terms :math:`k\nu_f` of (2.10) projected on the modes
(:class:`Harmonic`; a frequency 0 is the constant load :math:`P_{0r}`).  The parametric
stiffness terms :math:`P^{(j)}` (:class:`Parametric`) are not in (3.4); they carry the
time-varying stiffness of the real linkage and the Mathieu test case.  :math:`\varepsilon` is a
bookkeeping parameter: the library takes it absorbed into the coefficients (pass
:math:`\varepsilon\alpha`, :math:`\varepsilon\delta`, ...), and the ordering is the usual one:
damping, nonlinear and parametric terms small, non-resonant harmonics of any size ("hard"),
harmonics near a natural frequency small ("soft").

This module holds the data types of (3.4) (:class:`ModalSystem`, :class:`Harmonic`,
:class:`Parametric`) and the error of bad input to the multiple-scales functions; the solver
is :mod:`fivebar.numerics.multiscale`.  It imports nothing of the linkage.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError

__all__ = ["Harmonic", "ModalSystem", "MultiscaleError", "Parametric"]

Array = NDArray[np.float64]


class MultiscaleError(InputError):
    """Bad input to the multiple-scales functions (the message names the value)."""


def _real(name: str, x: ArrayLike, shape: tuple[int, ...] | None = None) -> Array:
    try:
        a = np.array(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise MultiscaleError(f"{name} = {x!r} is not allowed: it must be a real number or an array of them") from exc
    if shape is not None and a.shape != shape:
        raise MultiscaleError(f"{name} has shape {a.shape}, expected {shape}: give one entry per mode and index")
    bad = ~np.isfinite(a)
    if bad.any():
        i = tuple(int(k) for k in np.argwhere(bad)[0])
        raise MultiscaleError(f"{name}{list(i) if i else ''} = {a[i] if i else a} is not finite: it must be a finite number")
    a.setflags(write=False)
    return a


def _check_sign(name: str, a: Array, strict: bool, unit: str) -> None:
    bad = a <= 0 if strict else a < 0
    if bad.any():
        i = tuple(int(k) for k in np.argwhere(bad)[0])
        where = list(i) if i else ""
        raise MultiscaleError(
            f"{name}{where} = {a[i] if i else float(a):g} {unit} is not allowed: "
            f"it must be {'> 0' if strict else '>= 0'}"
        )


@dataclass(frozen=True, eq=False)
class ModalSystem:
    """Coefficients of the modal equations (3.4), with epsilon absorbed.

    Parameters
    ----------
    w : array_like (n,)
        Natural frequencies :math:`\\omega_r` (rad/s), > 0.
    zeta : array_like (n,), optional
        Damping ratios :math:`\\zeta_r` (-), >= 0; default 0.
    alpha : array_like (n, n), optional
        Linear coupling :math:`\\alpha_{rs}` (1/s^2), term :math:`-\\sum_s\\alpha_{rs}\\eta_s`.
    delta : array_like (n, n, n), optional
        Quadratic coefficients :math:`\\delta_{rst}`, term :math:`+\\sum\\delta_{rst}\\eta_s\\eta_t`.
    gamma : array_like (n, n, n, n), optional
        Cubic coefficients :math:`\\gamma_{rstu}`, term
        :math:`+\\sum\\gamma_{rstu}\\eta_s\\eta_t\\eta_u` (the Duffing ``+alpha u^3`` on the
        left is ``gamma = -alpha``).
    """

    w: ArrayLike
    zeta: ArrayLike | None = None
    alpha: ArrayLike | None = None
    delta: ArrayLike | None = None
    gamma: ArrayLike | None = None

    def __post_init__(self) -> None:
        w = _real("w", self.w)
        if w.ndim != 1 or w.size == 0:
            raise MultiscaleError(f"w has shape {w.shape}: it must be a non-empty 1-D array of natural frequencies (rad/s)")
        _check_sign("w", w, True, "rad/s")
        n = w.size
        set_ = object.__setattr__
        set_(self, "w", w)
        for name, ndim in (("zeta", 1), ("alpha", 2), ("delta", 3), ("gamma", 4)):
            value = getattr(self, name)
            a = _real(name, np.zeros((n,) * ndim) if value is None else value, (n,) * ndim)
            set_(self, name, a)
        _check_sign("zeta", self.zeta, False, "")

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return int(self.w.size)

    def acceleration(
        self,
        t: float,
        eta: ArrayLike,
        eta_dot: ArrayLike,
        harmonics: Sequence[Harmonic] = (),
        parametric: Sequence[Parametric] = (),
    ) -> Array:
        """The modal acceleration :math:`\\ddot\\eta` from (3.4) (epsilon absorbed).

        Parameters
        ----------
        t : float
            Time (s).
        eta, eta_dot : array_like (n,)
            Modal coordinates and velocities.
        harmonics, parametric : sequences of Harmonic, Parametric

        Returns
        -------
        ndarray (n,)
        """
        _check_inputs(self, harmonics, parametric)
        e, v = np.asarray(eta, float), np.asarray(eta_dot, float)
        acc = -self.w**2 * e - 2 * self.zeta * self.w * v - self.alpha @ e
        acc += np.einsum("rst,s,t->r", self.delta, e, e)
        acc += np.einsum("rstu,s,t,u->r", self.gamma, e, e, e)
        for h in harmonics:
            acc += h.amplitude * np.cos(h.frequency * t + h.phase)
        for p in parametric:
            acc -= np.cos(p.frequency * t + p.phase) * (p.stiffness @ e)
        return acc


@dataclass(frozen=True, eq=False)
class Harmonic:
    """One harmonic of the excitation, :math:`F_{r}\\cos(\\Omega t+\\tau_r)` in every mode.

    Parameters
    ----------
    frequency : float
        :math:`\\Omega = k\\nu_f` (rad/s), >= 0 (0 is a constant load).
    amplitude : array_like (n,)
        Modal force amplitudes :math:`F_{r}` (modal units / s^2).
    phase : float or array_like (n,)
        Phases :math:`\\tau_r` (rad); default 0.
    """

    frequency: float
    amplitude: ArrayLike
    phase: ArrayLike = 0.0

    def __post_init__(self) -> None:
        f = _real("harmonic frequency", self.frequency, ())
        _check_sign("harmonic frequency", f, False, "rad/s")
        F = _real("harmonic amplitude", np.atleast_1d(self.amplitude))
        if F.ndim != 1:
            raise MultiscaleError(f"harmonic amplitude has shape {F.shape}: it must be 1-D, one entry per mode")
        tau = _real("harmonic phase", np.broadcast_to(self.phase, F.shape) if np.ndim(self.phase) == 0 else self.phase, F.shape)
        object.__setattr__(self, "frequency", float(f))
        object.__setattr__(self, "amplitude", F)
        object.__setattr__(self, "phase", tau)


@dataclass(frozen=True, eq=False)
class Parametric:
    """A parametric stiffness term :math:`-P_{rs}\\cos(\\Omega t+\\varphi)\\,\\eta_s`.

    Parameters
    ----------
    frequency : float
        :math:`\\Omega` (rad/s), >= 0.
    stiffness : array_like (n, n)
        :math:`P_{rs}` (1/s^2).  The Mathieu equation
        :math:`\\ddot u+\\omega^2(1+2h\\cos\\Omega t)u=0` is ``P = 2 h omega^2``.
    phase : float
        :math:`\\varphi` (rad).
    """

    frequency: float
    stiffness: ArrayLike
    phase: float = 0.0

    def __post_init__(self) -> None:
        f = _real("parametric frequency", self.frequency, ())
        _check_sign("parametric frequency", f, False, "rad/s")
        P = _real("parametric stiffness", np.atleast_2d(self.stiffness))
        if P.ndim != 2 or P.shape[0] != P.shape[1]:
            raise MultiscaleError(f"parametric stiffness has shape {P.shape}: it must be square (n, n), n the number of modes")
        object.__setattr__(self, "frequency", float(f))
        object.__setattr__(self, "stiffness", P)
        object.__setattr__(self, "phase", float(_real("parametric phase", self.phase, ())))


def _check_inputs(system: ModalSystem, harmonics: Sequence[Harmonic], parametric: Sequence[Parametric]) -> None:
    if not isinstance(system, ModalSystem):
        raise MultiscaleError(f"system is a {type(system).__name__}: it must be a fivebar.numerics.modal_equations.ModalSystem")
    for j, h in enumerate(harmonics):
        if not isinstance(h, Harmonic):
            raise MultiscaleError(f"harmonics[{j}] is a {type(h).__name__}: it must be a Harmonic")
        if h.amplitude.shape != (system.n_modes,):
            raise MultiscaleError(
                f"harmonics[{j}] has {h.amplitude.size} modal amplitudes, the system has n_modes = {system.n_modes}: "
                "give one amplitude per mode"
            )
    for j, p in enumerate(parametric):
        if not isinstance(p, Parametric):
            raise MultiscaleError(f"parametric[{j}] is a {type(p).__name__}: it must be a Parametric")
        if p.stiffness.shape != (system.n_modes, system.n_modes):
            raise MultiscaleError(
                f"parametric[{j}] stiffness has shape {p.stiffness.shape}, expected ({system.n_modes}, {system.n_modes}) "
                "(n_modes of the system)"
            )


def _check_mode(system: ModalSystem, mode: int) -> int:
    if not (isinstance(mode, (int, np.integer)) and 0 <= mode < system.n_modes):
        raise MultiscaleError(
            f"mode = {mode!r} is not allowed: it must be an integer in 0..{system.n_modes - 1} (0-based: the paper's r - 1)"
        )
    return int(mode)

