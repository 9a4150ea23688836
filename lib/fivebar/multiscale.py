r"""Multiple scales: the first approximation (3.6)-(3.7) of the modal equations (3.4).

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

**First approximation, (3.7).**  With :math:`T_0=t,\ T_1=\varepsilon t` and
:math:`\eta_r=\eta_{r0}(T_0,T_1)+\varepsilon\eta_{r1}+\dots`, the order :math:`\varepsilon^0`
gives

.. math::

    \eta_{r0} = A_r(T_1)\,e^{i\omega_r T_0} + \sum_j \Lambda_{rj}\,e^{i\Omega_j T_0} + \text{c.c.},
    \qquad \Lambda_{rj} = \frac{F_{rj}\,e^{i\tau_{rj}}}{2(\omega_r^2-\Omega_j^2)},

that is, with :math:`A_r = a_r e^{i\theta_r}`,

.. math::

    \eta_r = 2a_r\cos(\omega_r t+\theta_r)
    + \sum_j \frac{F_{rj}}{\omega_r^2-\Omega_j^2}\cos(\Omega_j t+\tau_{rj}).

The paper prints :math:`\Lambda_{rfk}\cos(ik\nu_f t+\tau_{fki})` with
:math:`|\Lambda_{rfk}| = F_{rfk}/(2(\omega_r^2-k^2\nu_f^2))`: half the particular solution
(errata E22).  A soft harmonic (:math:`\Omega_j\approx\omega_r`) has no particular part in
mode ``r``; it enters the modulation equations.

**Modulation equations.**  Removing the terms of :math:`\eta_{r1}` proportional to
:math:`e^{i\omega_r T_0}` (secular terms) gives, in the physical time,

.. math::

    2i\omega_r\big(\dot A_r + \zeta_r\omega_r A_r\big) = S_r(\mathbf A, t)
    = \sum_k c_k\, e^{i d_k t}\, z_{k_1} z_{k_2} z_{k_3},
    \qquad \mathbf z = (A_1..A_n,\ \bar A_1..\bar A_n,\ 1),

where each term :math:`k` is a product of one, two or three components of :math:`\eta_{s0}`
(:math:`A_s e^{i\omega_s t}`, :math:`\Lambda_{sj}e^{i\Omega_j t}` and conjugates) taken from
the :math:`\alpha`, :math:`P`, :math:`\delta` and :math:`\gamma` terms, or a soft harmonic,
whose frequency lies within the detuning tolerance of :math:`\omega_r`; :math:`d_k` is that
small frequency difference.  The enumeration finds every resonance of section 3 (primary,
super- and subharmonic, internal, combination) that the harmonics and coefficients create;
for exact cancellations it gives the classical terms, e.g. :math:`3\gamma_{rrrr}A_r^2\bar A_r`,
:math:`2(\gamma_{rrss}+\gamma_{rsrs}+\gamma_{rssr})A_rA_s\bar A_s`,
:math:`6\gamma_{rrrr}\Lambda\bar\Lambda A_r`.

Quadratic terms give no frequency correction at first order; with ``quadratic_correction``
the leading one, from :math:`\delta\cdot\delta` at second order (Nayfeh & Mook 1979, 4.2;
:math:`\delta=O(\varepsilon)`, :math:`\gamma=O(\varepsilon^2)`), is added by the same
enumeration: :math:`\eta_{b1}` contains
:math:`\delta_{bcd}\,c_q c_m e^{i\mu t}/(\omega_b^2-\mu^2)`, and
:math:`\sum_{a,b}(\delta_{rab}+\delta_{rba})\eta_{a0}\eta_{b1}` is searched for secular terms.
For one mode this is :math:`\gamma_\text{eff}=\gamma+10\delta^2/(9\omega^2)`.

**Steady states by Newton-Raphson.**  In a rotating frame :math:`A_r = B_r e^{i\nu_r t}`, with
:math:`\nu` solving :math:`d_k + \sum(\pm\nu_s) - \nu_r = 0` for every term, the flow is
autonomous,
:math:`\dot B_r = -(\zeta_r\omega_r + i\nu_r)B_r - \tfrac{i}{2\omega_r}S_r(\mathbf B)`;
its fixed points (Newton on :math:`(\mathrm{Re}\,\mathbf B, \mathrm{Im}\,\mathbf B)`) are the
periodic responses, with :math:`a_r=|B_r|`, :math:`\theta_r = \nu_r t + \arg B_r` in (3.7),
and the eigenvalues of the Jacobian decide their stability.  The *physical* amplitude of the
free part is :math:`2a_r` (``ModulationSteadyState.amplitude``).

For one mode with :math:`S_r = \kappa B + 3\Gamma|B|^2B + f` (primary resonance,
:math:`\nu_r=\sigma=\Omega-\omega_r`) the fixed points satisfy, with :math:`X=(2a_r)^2`,

.. math::

    X\big[(2\zeta\omega^2-\kappa_I-\tfrac34\Gamma_I X)^2
    + (2\omega\sigma+\kappa_R+\tfrac34\Gamma_R X)^2\big] = 4|f|^2,

a cubic in :math:`X` (companion roots give every branch); for the Duffing equation
:math:`\ddot u+\omega^2u+2\mu\dot u+\alpha u^3=k\cos\Omega t` (:math:`\Gamma=-\alpha`,
:math:`f=k/2`) it is Nayfeh & Mook's (4.1.20),
:math:`\big[\mu^2+(\sigma-\tfrac{3\alpha a^2}{8\omega})^2\big]a^2=\tfrac{k^2}{4\omega^2}`.
For the principal parametric resonance :math:`\Omega\approx2\omega_r` (term :math:`c\bar B`)
the trivial state loses stability between
:math:`\sigma = -\kappa_R/\omega \pm 2\sqrt{|c|^2/(4\omega^2)-(\zeta\omega-\kappa_I/(2\omega))^2}`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FivebarError
from .newmark import NewtonConvergenceError

__all__ = [
    "DEFAULT_DETUNING",
    "FrequencyResponse",
    "Harmonic",
    "ModalSystem",
    "ModeCoefficients",
    "MultiscaleError",
    "Parametric",
    "SecularTerm",
    "SlowFlow",
    "ModulationSteadyState",
    "backbone",
    "first_approximation",
    "frequency_response",
    "modulation_equations",
    "newton",
    "parametric_response",
    "parametric_transition_curves",
    "particular_amplitudes",
    "primary_amplitudes",
    "primary_resonance",
]

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]

#: Default detuning tolerance, relative to each natural frequency: a frequency combination
#: within ``DEFAULT_DETUNING * omega_r`` of ``omega_r`` counts as resonant (secular).
DEFAULT_DETUNING = 0.05


# --- errors -----------------------------------------------------------------------------------
class MultiscaleError(FivebarError, ValueError):
    """Bad input to the multiple-scales functions (the message names the value)."""


#: Former name of :class:`fivebar.newmark.NewtonConvergenceError` (one error for every Newton
#: iteration of the library); kept for old code, not exported.
NewtonError = NewtonConvergenceError


# --- input ------------------------------------------------------------------------------------
def _newton_error(message: str, residual: float, iterations: int, t: float | None = None) -> NewtonConvergenceError:
    return NewtonConvergenceError(message, t, residual, iterations)


def _real(name: str, x: ArrayLike, shape: tuple[int, ...] | None = None) -> Array:
    try:
        a = np.array(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise MultiscaleError(f"{name} = {x!r} is not a real number or array") from exc
    if shape is not None and a.shape != shape:
        raise MultiscaleError(f"{name} has shape {a.shape}, expected {shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        i = tuple(int(k) for k in np.argwhere(bad)[0])
        raise MultiscaleError(f"{name}{list(i) if i else ''} = {a[i] if i else a} is not finite")
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
            raise MultiscaleError(f"w must be a non-empty 1-D array of frequencies, got shape {w.shape}")
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
    def n(self) -> int:
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
            raise MultiscaleError(f"harmonic amplitude must be 1-D (one entry per mode), got shape {F.shape}")
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
            raise MultiscaleError(f"parametric stiffness must be square (n, n), got shape {P.shape}")
        object.__setattr__(self, "frequency", float(f))
        object.__setattr__(self, "stiffness", P)
        object.__setattr__(self, "phase", float(_real("parametric phase", self.phase, ())))


def _check_inputs(system: ModalSystem, harmonics: Sequence[Harmonic], parametric: Sequence[Parametric]) -> None:
    if not isinstance(system, ModalSystem):
        raise MultiscaleError(f"system must be a ModalSystem, got {type(system).__name__}")
    for j, h in enumerate(harmonics):
        if not isinstance(h, Harmonic):
            raise MultiscaleError(f"harmonics[{j}] must be a Harmonic, got {type(h).__name__}")
        if h.amplitude.shape != (system.n,):
            raise MultiscaleError(
                f"harmonics[{j}] has {h.amplitude.size} modal amplitudes, the system has n = {system.n} modes"
            )
    for j, p in enumerate(parametric):
        if not isinstance(p, Parametric):
            raise MultiscaleError(f"parametric[{j}] must be a Parametric, got {type(p).__name__}")
        if p.stiffness.shape != (system.n, system.n):
            raise MultiscaleError(
                f"parametric[{j}] stiffness has shape {p.stiffness.shape}, expected ({system.n}, {system.n})"
            )


def _check_mode(system: ModalSystem, mode: int) -> int:
    if not (isinstance(mode, (int, np.integer)) and 0 <= mode < system.n):
        raise MultiscaleError(f"mode = {mode!r} must be an integer in 0..{system.n - 1} (0-based: the paper's r - 1)")
    return int(mode)


# --- Newton-Raphson ---------------------------------------------------------------------------
def _fd_jacobian(fun: Callable[[Array], Array], x: Array, r: Array) -> Array:
    J = np.empty((r.size, x.size))
    for k in range(x.size):
        h = 1e-7 * max(1.0, abs(x[k]))
        xp = x.copy()
        xp[k] += h
        J[:, k] = (np.asarray(fun(xp), float) - r) / h
    return J


def newton(
    fun: Callable[[Array], ArrayLike],
    x0: ArrayLike,
    jac: Callable[[Array], ArrayLike] | None = None,
    *,
    tol: float = 1e-10,
    maxiter: int = 50,
    t: float | None = None,
) -> Array:
    """Solve ``fun(x) = 0`` by Newton-Raphson with step halving.

    Call forms::

        x = newton(fun, x0)                 # finite-difference Jacobian
        x = newton(fun, x0, jac, tol=1e-12)

    Parameters
    ----------
    fun : callable ``x -> r``
        Residual, same length as ``x``.
    x0 : array_like (m,)
        Initial guess.
    jac : callable ``x -> (m, m)``, optional
        Jacobian of ``fun``; default forward differences.
    tol : float
        Converged when ``max|fun(x)| <= tol`` (units of ``fun``).
    maxiter : int
        Maximum Newton iterations.
    t : float, optional
        Time (s) the solve belongs to; only quoted in the error message.

    Returns
    -------
    ndarray (m,)

    Raises
    ------
    NewtonConvergenceError
        No convergence in ``maxiter`` iterations, a singular Jacobian, a non-finite residual or
        a step that no halving makes decrease the residual; the message names the residual,
        the iterations and (if given) the time.
    """
    at = "" if t is None else f" at t = {t:.9g} s"
    x = np.array(x0, dtype=float).ravel()
    r = np.asarray(fun(x), dtype=float).ravel()
    norm = float(np.max(np.abs(r))) if r.size else 0.0
    if not np.isfinite(norm):
        raise _newton_error(f"Newton-Raphson{at}: residual is not finite at the initial guess", norm, 0, t)
    for it in range(maxiter):
        if norm <= tol:
            return x
        J = np.asarray(jac(x), float) if jac is not None else _fd_jacobian(fun, x, r)
        try:
            dx = np.linalg.solve(J, -r)
        except np.linalg.LinAlgError:
            dx = np.full_like(x, np.nan)
        if not np.all(np.isfinite(dx)):
            raise _newton_error(
                f"Newton-Raphson{at}: singular Jacobian after {it} iterations (residual {norm:.3e})", norm, it, t
            )
        lam = 1.0
        for _ in range(40):
            xn = x + lam * dx
            rn = np.asarray(fun(xn), dtype=float).ravel()
            nn = float(np.max(np.abs(rn)))
            if np.isfinite(nn) and (nn < norm or nn <= tol):
                break
            lam *= 0.5
        else:
            raise _newton_error(
                f"Newton-Raphson{at}: no step along the Newton direction reduces the residual "
                f"{norm:.3e} (tol {tol:.3e}) after {it + 1} iterations",
                norm, it + 1, t,
            )
        x, r, norm = xn, rn, nn
    if norm <= tol:
        return x
    raise _newton_error(
        f"Newton-Raphson{at} did not converge: residual {norm:.3e} > tol {tol:.3e} after {maxiter} iterations",
        norm, maxiter, t,
    )


# --- the first approximation ------------------------------------------------------------------
def particular_amplitudes(
    system: ModalSystem, harmonics: Sequence[Harmonic], soft: Iterable[tuple[int, int]] = ()
) -> CArray:
    """Complex amplitudes :math:`\\Lambda_{rj}` of the forced part of (3.7).

    :math:`\\Lambda_{rj} = F_{rj}e^{i\\tau_{rj}}/(2(\\omega_r^2-\\Omega_j^2))`, so the forced
    part of :math:`\\eta_r` is :math:`\\sum_j 2\\,\\mathrm{Re}(\\Lambda_{rj}e^{i\\Omega_j t})
    = \\sum_j F_{rj}\\cos(\\Omega_j t+\\tau_{rj})/(\\omega_r^2-\\Omega_j^2)`, the exact
    steady response of the undamped linear mode.

    Parameters
    ----------
    system : ModalSystem
    harmonics : sequence of Harmonic
    soft : iterable of (mode, harmonic index)
        Pairs treated as resonant (soft): their amplitude is 0 here; they enter the
        modulation equations instead.

    Returns
    -------
    ndarray (J, n) complex
    """
    _check_inputs(system, harmonics, ())
    soft = set(soft)
    Lam = np.zeros((len(harmonics), system.n), complex)
    for j, h in enumerate(harmonics):
        for r in range(system.n):
            if (r, j) in soft or h.amplitude[r] == 0.0:
                continue
            den = system.w[r] ** 2 - h.frequency**2
            if den == 0.0:
                raise MultiscaleError(
                    f"harmonics[{j}] frequency {h.frequency:g} rad/s equals omega_{r} exactly: "
                    "declare it soft (resonant) for that mode"
                )
            Lam[j, r] = h.amplitude[r] * np.exp(1j * h.phase[r]) / (2.0 * den)
    return Lam


class SecularTerm(NamedTuple):
    """One term :math:`c\\,e^{idt}z_1z_2z_3` of :math:`S_r` (mode 0-based; factors 1-based)."""

    mode: int
    factors: str
    coefficient: complex
    detuning: float
    order: int


class ModeCoefficients(NamedTuple):
    """The one-mode part of :math:`S_r = \\kappa B + 3\\Gamma|B|^2B + f + c\\bar B`."""

    kappa: complex
    cubic: complex
    forcing: complex
    parametric: complex


class SlowFlow:
    """The modulation equations of :func:`modulation_equations` (use that to build one).

    Attributes
    ----------
    system : ModalSystem
    harmonics, parametric : tuples
    Lambda : ndarray (J, n) complex
        Particular amplitudes of (3.7).
    soft : frozenset of (mode, harmonic index)
    nu : ndarray (n,) or None
        Frequencies (rad/s) of the rotating frame :math:`A_r = B_r e^{i\\nu_r t}`, None if no
        frame makes the flow autonomous (incommensurate simultaneous resonances).
    """

    def __init__(self, system, harmonics, parametric, Lambda, soft, tol, mode, coef, idx, d, order):
        self.system, self.harmonics, self.parametric = system, tuple(harmonics), tuple(parametric)
        self.Lambda, self.soft, self.tol = Lambda, frozenset(soft), tol
        self._mode, self._coef, self._idx, self._d, self._order = mode, coef, idx, d, order
        n = system.n
        # rotating frame: d_k + sum(+-nu_s over the factors) - nu_r = 0 for every term
        M = np.zeros((mode.size, n))
        for k in range(mode.size):
            for i in idx[k]:
                if i < n:
                    M[k, i] += 1.0
                elif i < 2 * n:
                    M[k, i - n] -= 1.0
            M[k, mode[k]] -= 1.0
        if mode.size:
            nu = np.linalg.lstsq(M, -d, rcond=None)[0]
            ok = np.max(np.abs(M @ nu + d)) <= 1e-9 * float(np.max(system.w))
        else:
            nu, ok = np.zeros(n), True
        self.nu = nu if ok else None

    # -- description
    @property
    def terms(self) -> list[SecularTerm]:
        """The secular terms, for tables (factors like ``A1 A1 conj(A1)``, modes 1-based)."""
        n = self.system.n
        names = [f"A{s + 1}" for s in range(n)] + [f"conj(A{s + 1})" for s in range(n)]
        out = []
        for r, c, ix, d, o in zip(self._mode, self._coef, self._idx, self._d, self._order):
            f = " ".join(names[i] for i in sorted(ix) if i < 2 * n) or "1"
            out.append(SecularTerm(int(r), f, complex(c), float(d), int(o)))
        return out

    def coefficients(self, mode: int) -> ModeCoefficients:
        """:math:`\\kappa, \\Gamma, f, c` of mode ``mode`` alone (other modes at rest).

        ``kappa`` multiplies :math:`A_r`, ``3 * cubic`` multiplies :math:`A_r^2\\bar A_r`,
        ``forcing`` is the sum of the pure-excitation terms (:math:`F/2\\,e^{i\\tau}` for a
        soft harmonic), ``parametric`` multiplies :math:`\\bar A_r`.
        """
        r = _check_mode(self.system, mode)
        n = self.system.n
        one = 2 * n
        pat = {
            "kappa": (r, one, one),
            "cubic": tuple(sorted((r, r, n + r))),
            "forcing": (one, one, one),
            "parametric": (n + r, one, one),
        }
        out = dict.fromkeys(pat, 0j)
        for rr, c, ix in zip(self._mode, self._coef, self._idx):
            if rr != r:
                continue
            key = tuple(sorted(ix))
            for name, p in pat.items():
                if key == p:
                    out[name] += c
        out["cubic"] /= 3.0
        return ModeCoefficients(**out)

    # -- evaluation
    def _z(self, A: CArray) -> CArray:
        return np.concatenate([A, np.conj(A), [1.0]])

    def secular(self, t: float, A: ArrayLike) -> CArray:
        """:math:`S_r(\\mathbf A, t)` in the original (non-rotating) frame, shape (n,)."""
        z = self._z(np.asarray(A, complex))
        val = self._coef * np.exp(1j * self._d * t) * np.prod(z[self._idx], axis=1)
        return np.bincount(self._mode, val.real, self.system.n) + 1j * np.bincount(self._mode, val.imag, self.system.n)

    def modulation(self, t: float, A: ArrayLike) -> CArray:
        """:math:`\\dot A_r = -\\zeta_r\\omega_r A_r - \\frac{i}{2\\omega_r}S_r(\\mathbf A,t)`
        (non-autonomous; integrate it for transients)."""
        s = self.system
        return -s.zeta * s.w * np.asarray(A, complex) - 0.5j / s.w * self.secular(t, A)

    def _frame(self) -> Array:
        if self.nu is None:
            raise MultiscaleError(
                "the secular terms hold resonances with incompatible (incommensurate) detunings: no "
                "rotating frame makes the slow flow autonomous, so it has no steady state; narrow the "
                "detuning tolerance (below half the spacing of the harmonics over omega_r) or integrate "
                "SlowFlow.modulation(t, A) instead"
            )
        return self.nu

    @staticmethod
    def _split(x: ArrayLike) -> CArray:
        x = np.asarray(x, float)
        m = x.size // 2
        return x[:m] + 1j * x[m:]

    def __call__(self, x: ArrayLike) -> Array:
        """Autonomous flow in the rotating frame, real form: ``x = (Re B, Im B)``."""
        s, nu = self.system, self._frame()
        B = self._split(x)
        G = -(s.zeta * s.w + 1j * nu) * B - 0.5j / s.w * self.secular(0.0, B)  # frame: e^{idt} cancels
        return np.concatenate([G.real, G.imag])

    def _scale(self, x: ArrayLike) -> float:
        """Magnitude of the largest contribution to the flow at x (for the Newton tolerance)."""
        s, nu = self.system, self._frame()
        B = self._split(x)
        z = np.abs(self._z(B))
        val = np.abs(self._coef) * np.prod(z[self._idx], axis=1)
        S = np.bincount(self._mode, val, s.n)
        return float(np.max(np.abs(s.zeta * s.w + 1j * nu) * np.abs(B) + 0.5 / s.w * S))

    def jacobian(self, x: ArrayLike) -> Array:
        """Jacobian of the flow (``__call__``) with respect to ``x = (Re B, Im B)``, (2n, 2n)."""
        s, nu = self.system, self._frame()
        n = s.n
        B = self._split(x)
        z = self._z(B)
        dS = np.zeros((n, 2 * n + 1), complex)
        zi = z[self._idx]
        for p in range(3):
            others = np.prod(np.delete(zi, p, axis=1), axis=1)
            np.add.at(dS, (self._mode, self._idx[:, p]), self._coef * others)
        g = -0.5j / s.w
        dB = np.diag(-(s.zeta * s.w + 1j * nu)) + g[:, None] * dS[:, :n]
        dBc = g[:, None] * dS[:, n : 2 * n]
        dX, dY = dB + dBc, 1j * (dB - dBc)
        return np.block([[dX.real, dY.real], [dX.imag, dY.imag]])

    def state(self, B: ArrayLike) -> ModulationSteadyState:
        """The :class:`ModulationSteadyState` at the frame amplitudes ``B`` (its stability evaluated)."""
        B = np.asarray(B, complex)
        x = np.concatenate([B.real, B.imag])
        lam = np.linalg.eigvals(self.jacobian(x))
        return ModulationSteadyState(self, B, lam)

    def steady_state(self, guess: ArrayLike | None = None, *, rtol: float = 1e-11, maxiter: int = 50) -> ModulationSteadyState:
        """A fixed point of the autonomous slow flow, by :func:`newton` from ``guess``.

        Parameters
        ----------
        guess : array_like (n,) complex, optional
            Frame amplitudes :math:`B_r` (the paper's :math:`a_r e^{i\\theta_r}` at t = 0);
            default 0.
        rtol : float
            Tolerance relative to the largest term of the flow at the guess.
        maxiter : int

        Raises
        ------
        NewtonConvergenceError
        """
        n = self.system.n
        B0 = np.zeros(n, complex) if guess is None else np.asarray(guess, complex)
        if B0.shape != (n,):
            raise MultiscaleError(f"guess has shape {B0.shape}, expected ({n},)")
        x0 = np.concatenate([B0.real, B0.imag])
        # the scale of the flow: from the guess, or from the pure-excitation terms
        tol = rtol * max(self._scale(x0), self._scale(np.zeros(2 * n)), 1e-300)
        x = newton(self, x0, self.jacobian, tol=tol, maxiter=maxiter)
        return self.state(self._split(x))


@dataclass(frozen=True, eq=False)
class ModulationSteadyState:
    """A steady state of the slow flow: the periodic first approximation (3.7).

    Attributes
    ----------
    flow : SlowFlow
    B : ndarray (n,) complex
        Frame amplitudes; the paper's :math:`a_r = |B_r|`, :math:`\\theta_r = \\nu_r t+\\arg B_r`.
    eigenvalues : ndarray (2n,) complex
        Eigenvalues (1/s) of the Jacobian of the slow flow there.
    """

    flow: SlowFlow
    B: CArray
    eigenvalues: CArray

    @property
    def a(self) -> Array:
        """The paper's :math:`a_r = |B_r|` (half the physical amplitude)."""
        return np.abs(self.B)

    @property
    def amplitude(self) -> Array:
        """Physical amplitude :math:`2a_r` of the free (or resonant) part of :math:`\\eta_r`."""
        return 2.0 * np.abs(self.B)

    @property
    def theta0(self) -> Array:
        """:math:`\\arg B_r` (rad): the phase :math:`\\theta_r` at t = 0."""
        return np.angle(self.B)

    @property
    def nu(self) -> Array:
        """Frame frequencies :math:`\\nu_r` (rad/s): :math:`\\theta_r(t) = \\nu_r t + \\theta_{r0}`."""
        return self.flow._frame()

    @property
    def stable(self) -> bool:
        """True if every eigenvalue has a negative real part (asymptotically stable)."""
        return bool(np.max(self.eigenvalues.real) < 0.0)

    def eta(self, t: ArrayLike) -> Array:
        """:math:`\\eta_r(t)` by (3.7), shape (n,) + shape(t)."""
        return self._eval(t, 0)

    def eta_dot(self, t: ArrayLike) -> Array:
        """:math:`\\dot\\eta_r(t)`, the time derivative of (3.7) at fixed :math:`a_r,\\nu_r`."""
        return self._eval(t, 1)

    def _eval(self, t: ArrayLike, deriv: int) -> Array:
        t = np.asarray(t, float)
        s, fl = self.flow.system, self.flow
        tt = t[None, ...]
        lam = (s.w + self.nu).reshape((-1,) + (1,) * t.ndim)
        B = self.B.reshape(lam.shape)
        out = 2.0 * np.real((1j * lam) ** deriv * B * np.exp(1j * lam * tt))
        for j, h in enumerate(fl.harmonics):
            L = fl.Lambda[j].reshape(lam.shape)
            out = out + 2.0 * np.real((1j * h.frequency) ** deriv * L * np.exp(1j * h.frequency * tt))
        return out


# --- building the modulation equations --------------------------------------------------------
def modulation_equations(
    system: ModalSystem,
    harmonics: Sequence[Harmonic] = (),
    parametric: Sequence[Parametric] = (),
    *,
    detuning: float = DEFAULT_DETUNING,
    soft: Iterable[tuple[int, int]] = (),
    principal: Iterable[tuple[int, int]] = (),
    quadratic_correction: bool = True,
) -> SlowFlow:
    """The first-order modulation equations of (3.4): every secular term, enumerated.

    Call forms::

        flow = modulation_equations(system, harmonics)                 # resonances by tolerance
        flow = modulation_equations(system, [h], soft=[(0, 0)])        # h resonant in mode 0
        flow = modulation_equations(system, (), [p], principal=[(0, 0)])   # Omega_p ~ 2 omega_0

    Parameters
    ----------
    system : ModalSystem
    harmonics : sequence of Harmonic
        External excitation; a harmonic within ``detuning * omega_r`` of ``omega_r`` is soft for
        mode ``r`` automatically.
    parametric : sequence of Parametric
    detuning : float
        Relative tolerance: a frequency combination within ``detuning * omega_r`` of
        ``omega_r`` is secular for mode ``r``, and a forced component within
        ``detuning * omega_b`` of ``omega_b`` is not a particular solution of mode ``b``.
    soft : iterable of (mode, harmonic index)
        Harmonics declared resonant for a mode, whatever their detuning (primary resonance).
    principal : iterable of (mode, parametric index)
        Parametric terms declared in principal resonance with a mode
        (:math:`\\Omega\\approx2\\omega_r`), whatever their detuning.
    quadratic_correction : bool
        Add the second-order :math:`\\delta\\delta` terms (the frequency correction of the
        quadratic nonlinearity, Nayfeh & Mook 4.2).

    Returns
    -------
    SlowFlow
    """
    _check_inputs(system, harmonics, parametric)
    detuning = float(_real("detuning", detuning, ()))
    _check_sign("detuning", np.array(detuning), False, "")
    n, w = system.n, system.w
    tol = detuning * w
    soft = {(_check_mode(system, r), int(j)) for r, j in soft}
    principal = {(_check_mode(system, r), int(j)) for r, j in principal}
    for r, j in soft:
        if not 0 <= j < len(harmonics):
            raise MultiscaleError(f"soft harmonic index {j} is out of range 0..{len(harmonics) - 1}")
    for r, j in principal:
        if not 0 <= j < len(parametric):
            raise MultiscaleError(f"principal parametric index {j} is out of range 0..{len(parametric) - 1}")
    for j, h in enumerate(harmonics):
        for r in range(n):
            if abs(h.frequency - w[r]) <= tol[r] and h.amplitude[r] != 0.0:
                soft.add((r, j))
    Lam = particular_amplitudes(system, harmonics, soft)

    # components of eta_s0: (frequency, constant factor, index into z, mode)
    ONE = 2 * n
    cf, cc, cv, cm = [], [], [], []
    for s in range(n):
        cf += [w[s], -w[s]]
        cc += [1.0, 1.0]
        cv += [s, n + s]
        cm += [s, s]
    for j, h in enumerate(harmonics):
        for s in range(n):
            if Lam[j, s] != 0.0:
                cf += [h.frequency, -h.frequency]
                cc += [Lam[j, s], np.conj(Lam[j, s])]
                cv += [ONE, ONE]
                cm += [s, s]
    cf, cc = np.array(cf), np.array(cc, complex)
    cv, cm = np.array(cv, int), np.array(cm, int)
    N = cf.size
    wmax = float(np.max(w))
    parts: list[tuple] = []

    def add(r: int, coef: CArray, idx: NDArray, d: Array, order: int) -> None:
        keep = coef != 0.0
        if keep.any():
            parts.append((np.full(int(keep.sum()), r), np.sort(idx[keep], axis=1), d[keep], coef[keep], order))

    def pad(*cols: NDArray) -> NDArray:
        cols = list(cols) + [np.full(cols[0].shape, ONE)] * (3 - len(cols))
        return np.stack(cols, axis=1)

    PQ = np.indices((N, N)).reshape(2, -1)
    for r in range(n):
        # soft excitation
        for j, h in enumerate(harmonics):
            if (r, j) in soft:
                c = np.array([0.5 * h.amplitude[r] * np.exp(1j * h.phase[r])])
                add(r, c, pad(np.array([ONE])), np.array([h.frequency - w[r]]), 1)
        # linear coupling -alpha_rs eta_s
        if np.any(system.alpha[r]):
            d = cf - w[r]
            m = np.abs(d) <= tol[r]
            add(r, -system.alpha[r][cm[m]] * cc[m], pad(cv[m]), d[m], 1)
        # parametric -P_rs cos(Omega t + phi) eta_s
        for j, p in enumerate(parametric):
            if not np.any(p.stiffness[r]):
                continue
            for sign in (1.0, -1.0):
                d = cf + sign * p.frequency - w[r]
                m = np.abs(d) <= tol[r]
                if sign > 0 and (r, j) in principal:
                    m |= cv == n + r
                coef = -0.5 * np.exp(1j * sign * p.phase) * p.stiffness[r][cm[m]] * cc[m]
                add(r, coef, pad(cv[m]), d[m], 1)
        # quadratic delta_rst eta_s eta_t
        if np.any(system.delta[r]):
            P, Q = PQ
            d = cf[P] + cf[Q] - w[r]
            m = np.abs(d) <= tol[r]
            P, Q = P[m], Q[m]
            add(r, system.delta[r][cm[P], cm[Q]] * cc[P] * cc[Q], pad(cv[P], cv[Q]), d[m], 1)
        # cubic gamma_rstu eta_s eta_t eta_u
        if np.any(system.gamma[r]):
            for p in range(N):
                Q, U = PQ
                d = cf[p] + cf[Q] + cf[U] - w[r]
                m = np.abs(d) <= tol[r]
                Q, U = Q[m], U[m]
                coef = system.gamma[r][cm[p], cm[Q], cm[U]] * cc[p] * cc[Q] * cc[U]
                add(r, coef, pad(np.full(Q.shape, cv[p]), cv[Q], cv[U]), d[m], 1)
        # second order: sum_ab (delta_rab + delta_rba) eta_a0 eta_b1, eta_b1 from delta_bcd
        if quadratic_correction and np.any(system.delta[r]) and np.any(system.delta):
            Q, U = PQ
            mu = cf[Q] + cf[U]
            # eta_b1 = sum delta_bcd c_q c_u e^{i mu t} / (w_b^2 - mu^2), non-resonant mu only
            valid = np.abs(np.abs(mu)[None, :] - w[:, None]) > tol[:, None]
            den = np.where(valid, w[:, None] ** 2 - mu[None, :] ** 2, 1.0)
            inner = np.where(valid, system.delta[:, cm[Q], cm[U]] / den, 0.0)  # (n, N^2)
            for p in range(N):
                d = cf[p] + mu - w[r]
                m = np.abs(d) <= tol[r]
                if not m.any():
                    continue
                a = cm[p]
                left = system.delta[r, a, :] + system.delta[r, :, a]  # (n,) over b
                coef = (left @ inner[:, m]) * cc[p] * cc[Q[m]] * cc[U[m]]
                add(r, coef, pad(np.full(int(m.sum()), cv[p]), cv[Q[m]], cv[U[m]]), d[m], 2)

    # merge equal terms: same mode, factors, detuning (to 1e-9 of the top frequency) and order
    if parts:
        mode = np.concatenate([p[0] for p in parts])
        idx = np.concatenate([p[1] for p in parts])
        d = np.concatenate([p[2] for p in parts])
        coef = np.concatenate([p[3] for p in parts])
        order = np.concatenate([np.full(p[0].size, p[4]) for p in parts])
        dkey = np.round(d / (1e-9 * wmax)).astype(np.int64)
        code = (((mode * (ONE + 1) + idx[:, 0]) * (ONE + 1) + idx[:, 1]) * (ONE + 1) + idx[:, 2]) * 2 + order - 1
        srt = np.lexsort((dkey, code))
        code, dkey = code[srt], dkey[srt]
        first = np.flatnonzero(np.r_[True, (np.diff(code) != 0) | (np.diff(dkey) != 0)])
        csum = np.add.reduceat(coef[srt], first)
        sel = srt[first[csum != 0.0]]
        mode, idx, d, order, coef = mode[sel], idx[sel], d[sel], order[sel], csum[csum != 0.0]
    else:
        mode, idx, d, order = np.zeros(0, int), np.zeros((0, 3), int), np.zeros(0), np.zeros(0, int)
        coef = np.zeros(0, complex)
    return SlowFlow(system, harmonics, parametric, Lam, soft, tol, mode, coef, idx, d, order)


# --- closed-form amplitude equations ----------------------------------------------------------
def primary_amplitudes(coeffs: ModeCoefficients, w: float, zeta: float, sigma: float) -> list[complex]:
    """Steady frame amplitudes :math:`B` of one mode at primary resonance, by companion roots.

    Solves :math:`X[(2\\zeta\\omega^2-\\kappa_I-\\tfrac34\\Gamma_IX)^2
    +(2\\omega\\sigma+\\kappa_R+\\tfrac34\\Gamma_RX)^2] = 4|f|^2` for :math:`X=(2|B|)^2`
    (``numpy.roots``: eigenvalues of the companion matrix) and returns, for each real positive
    root, :math:`B = -if/[\\,2\\zeta\\omega^2-\\kappa_I-\\tfrac34\\Gamma_IX
    + i(2\\omega\\sigma+\\kappa_R+\\tfrac34\\Gamma_RX)]`.

    Parameters
    ----------
    coeffs : ModeCoefficients
        From :meth:`SlowFlow.coefficients`.
    w, zeta : float
        :math:`\\omega_r` (rad/s) and :math:`\\zeta_r`.
    sigma : float
        Frame frequency :math:`\\nu_r = \\Omega-\\omega_r` (rad/s).

    Returns
    -------
    list of complex, ascending amplitude
    """
    k, G, f = complex(coeffs.kappa), complex(coeffs.cubic), complex(coeffs.forcing)
    p = 2 * zeta * w**2 - k.imag
    q = 2 * w * sigma + k.real
    cR, cI = 0.75 * G.real, 0.75 * G.imag
    poly = [cR**2 + cI**2, 2 * (q * cR - p * cI), p**2 + q**2, -4 * abs(f) ** 2]
    roots = np.roots(np.trim_zeros(np.array(poly), "f")) if any(poly[:3]) else np.array([])
    out = []
    big = max([abs(x) for x in roots] + [0.0])
    for X in sorted(x.real for x in roots if abs(x.imag) <= 1e-7 * big and x.real > 0):
        out.append(-1j * f / (p - cI * X + 1j * (q + cR * X)))
    return out


def _unique(states: list[ModulationSteadyState], mode: int) -> list[ModulationSteadyState]:
    out: list[ModulationSteadyState] = []
    for st in sorted(states, key=lambda s: s.amplitude[mode]):
        if not out or np.max(np.abs(st.B - out[-1].B)) > 1e-7 * max(1e-300, np.max(np.abs(st.B))):
            out.append(st)
    return out


def primary_resonance(
    system: ModalSystem,
    mode: int,
    harmonic: Harmonic,
    *,
    harmonics: Sequence[Harmonic] = (),
    parametric: Sequence[Parametric] = (),
    detuning: float = DEFAULT_DETUNING,
    quadratic_correction: bool = True,
    rtol: float = 1e-11,
) -> list[ModulationSteadyState]:
    """Every steady branch of the primary resonance :math:`\\Omega\\approx\\omega_r`.

    Call form::

        branches = primary_resonance(system, 0, Harmonic(w0 + sigma, [F]))
        [(b.amplitude[0], b.theta0[0], b.stable) for b in branches]

    The companion roots of :func:`primary_amplitudes` give one guess per branch; Newton-Raphson
    on the full slow flow (all modes, every secular term) refines it; the eigenvalues of the
    flow's Jacobian give its stability.

    Parameters
    ----------
    system : ModalSystem
    mode : int
        Resonant mode (0-based).
    harmonic : Harmonic
        The resonant (soft) harmonic, frequency :math:`\\Omega = \\omega_r + \\sigma`.
    harmonics, parametric : sequences
        Further (hard, non-resonant) excitation.
    detuning, quadratic_correction : see :func:`modulation_equations`.
    rtol : float
        Newton tolerance, relative.

    Returns
    -------
    list of ModulationSteadyState
        Sorted by the amplitude of ``mode`` (one branch, or three in the bistable range).
    """
    mode = _check_mode(system, mode)
    flow = modulation_equations(
        system, [harmonic, *harmonics], parametric, detuning=detuning, soft=[(mode, 0)],
        quadratic_correction=quadratic_correction,
    )
    nu = flow._frame()
    guesses = primary_amplitudes(flow.coefficients(mode), system.w[mode], system.zeta[mode], nu[mode])
    states = []
    for Bm in guesses:
        B0 = np.zeros(system.n, complex)
        B0[mode] = Bm
        states.append(flow.steady_state(B0, rtol=rtol))
    return _unique(states, mode)


class FrequencyResponse(NamedTuple):
    """Frequency-response curve: ``sigma`` (N,) rad/s; ``amplitude`` and ``stable`` (N, 3),
    the physical amplitudes :math:`2a_r` of the branches (ascending, NaN where absent)."""

    sigma: Array
    amplitude: Array
    stable: NDArray[np.bool_]


def frequency_response(
    system: ModalSystem,
    mode: int,
    force: float | ArrayLike,
    sigmas: ArrayLike,
    *,
    phase: float = 0.0,
    **kwargs,
) -> FrequencyResponse:
    """The primary-resonance frequency-response curve of mode ``mode`` over detunings.

    Parameters
    ----------
    system : ModalSystem
    mode : int
    force : float or array_like (n,)
        Modal force amplitude of the resonant harmonic (a float loads ``mode`` only).
    sigmas : array_like (N,)
        Detunings :math:`\\sigma=\\Omega-\\omega_r` (rad/s).
    phase : float
        Phase of the harmonic (rad).
    **kwargs
        Passed to :func:`primary_resonance`.

    Returns
    -------
    FrequencyResponse
    """
    mode = _check_mode(system, mode)
    F = np.asarray(force, float)
    if F.ndim == 0:
        F = np.zeros(system.n)
        F[mode] = float(force)
    sig = _real("sigmas", np.atleast_1d(sigmas))
    amp = np.full((sig.size, 3), np.nan)
    stab = np.zeros((sig.size, 3), bool)
    for i, s in enumerate(sig):
        Om = system.w[mode] + s
        if Om < 0:
            raise MultiscaleError(f"sigma = {s:g} rad/s gives a negative excitation frequency {Om:g} rad/s")
        br = primary_resonance(system, mode, Harmonic(Om, F, phase), **kwargs)
        for k, b in enumerate(br[:3]):
            amp[i, k], stab[i, k] = b.amplitude[mode], b.stable
    return FrequencyResponse(sig, amp, stab)


def backbone(
    system: ModalSystem,
    mode: int,
    amplitudes: ArrayLike,
    *,
    harmonics: Sequence[Harmonic] = (),
    **kwargs,
) -> Array:
    """Free-vibration frequency of mode ``mode`` against its amplitude (the backbone curve).

    :math:`\\omega_{NL} = \\omega_r - (\\kappa_R + \\tfrac34\\Gamma_R\\,(2a_r)^2)/(2\\omega_r)`,
    with :math:`\\kappa, \\Gamma` from the secular terms (including the shift that hard,
    non-resonant ``harmonics`` cause, Nayfeh & Mook 4.1.4).  For the Duffing oscillator
    :math:`\\omega_{NL} = \\omega + 3\\alpha a^2/(8\\omega)`.

    Parameters
    ----------
    system : ModalSystem
    mode : int
    amplitudes : array_like
        Physical amplitudes :math:`2a_r`.
    harmonics : sequence of Harmonic
        Hard excitation acting meanwhile.
    **kwargs
        Passed to :func:`modulation_equations`.

    Returns
    -------
    ndarray
        Frequencies (rad/s), shape of ``amplitudes``.
    """
    mode = _check_mode(system, mode)
    flow = modulation_equations(system, harmonics, **kwargs)
    c = flow.coefficients(mode)
    a = _real("amplitudes", amplitudes)
    w = system.w[mode]
    return w - (c.kappa.real + 0.75 * c.cubic.real * a**2) / (2 * w)


def parametric_transition_curves(
    system: ModalSystem,
    mode: int,
    parametric: Parametric,
    *,
    harmonics: Sequence[Harmonic] = (),
    **kwargs,
) -> tuple[float, float]:
    """Detunings bounding the principal parametric instability :math:`\\Omega\\approx2\\omega_r`.

    The trivial state is unstable for :math:`\\sigma_- < \\Omega-2\\omega_r < \\sigma_+` with
    :math:`\\sigma_\\pm = -\\kappa_R/\\omega \\pm
    2\\sqrt{|c|^2/(4\\omega^2) - (\\zeta\\omega-\\kappa_I/(2\\omega))^2}`; for the damped
    Mathieu equation :math:`\\ddot u + 2\\zeta\\omega\\dot u + \\omega^2(1+2h\\cos\\Omega t)u=0`,
    :math:`\\sigma_\\pm=\\pm\\omega\\sqrt{h^2-4\\zeta^2}`.

    Parameters
    ----------
    system : ModalSystem
    mode : int
    parametric : Parametric
        Its frequency is irrelevant here (only its stiffness and phase are used).
    harmonics : sequence of Harmonic
        Hard excitation (shifts :math:`\\kappa`).
    **kwargs
        Passed to :func:`modulation_equations`.

    Returns
    -------
    (sigma_minus, sigma_plus) : floats (rad/s), NaN if damping suppresses the instability.
    """
    mode = _check_mode(system, mode)
    w, z = system.w[mode], system.zeta[mode]
    p = Parametric(2 * w, parametric.stiffness, parametric.phase)
    flow = modulation_equations(system, harmonics, [p], principal=[(mode, 0)], **kwargs)
    c = flow.coefficients(mode)
    disc = abs(c.parametric) ** 2 / (4 * w**2) - (z * w - c.kappa.imag / (2 * w)) ** 2
    if disc < 0:
        return (np.nan, np.nan)
    return (-c.kappa.real / w - 2 * np.sqrt(disc), -c.kappa.real / w + 2 * np.sqrt(disc))


def parametric_response(
    system: ModalSystem,
    mode: int,
    parametric: Parametric,
    *,
    harmonics: Sequence[Harmonic] = (),
    rtol: float = 1e-11,
    **kwargs,
) -> list[ModulationSteadyState]:
    """Nontrivial steady states of the principal parametric resonance :math:`\\Omega\\approx2\\omega_r`.

    The response is at :math:`\\Omega/2`.  With :math:`\\sigma = \\Omega-2\\omega_r` and
    :math:`X=(2|B|)^2` the states solve
    :math:`(\\omega\\sigma+\\kappa_R+\\tfrac34\\Gamma_RX)^2
    +(2\\zeta\\omega^2-\\kappa_I-\\tfrac34\\Gamma_IX)^2 = |c|^2` (companion roots), refined by
    Newton-Raphson on the slow flow.  For the Mathieu-Duffing oscillator
    :math:`\\ddot u+2\\zeta\\omega\\dot u+\\omega^2(1+2h\\cos\\Omega t)u+\\alpha u^3=0`:
    :math:`a^2 = \\tfrac{4\\omega}{3\\alpha}(\\sigma\\pm\\omega\\sqrt{h^2-4\\zeta^2})`.

    Returns
    -------
    list of ModulationSteadyState, ascending amplitude (empty if none).
    """
    mode = _check_mode(system, mode)
    w, z = system.w[mode], system.zeta[mode]
    flow = modulation_equations(system, harmonics, [parametric], principal=[(mode, 0)], **kwargs)
    nu = flow._frame()
    c = flow.coefficients(mode)
    sigma = 2 * nu[mode]
    q = w * sigma + c.kappa.real
    p = 2 * z * w**2 - c.kappa.imag
    cR, cI = 0.75 * c.cubic.real, 0.75 * c.cubic.imag
    poly = [cR**2 + cI**2, 2 * (q * cR - p * cI), q**2 + p**2 - abs(c.parametric) ** 2]
    if not any(poly[:2]) or c.parametric == 0:
        return []
    roots = np.roots(np.trim_zeros(np.array(poly), "f"))
    states = []
    for X in roots:
        if abs(X.imag) > 1e-9 * abs(X) or X.real <= 0:
            continue
        X = X.real
        lhs = -q - cR * X + 1j * (p - cI * X)
        beta = -0.5 * np.angle(lhs / c.parametric)
        B0 = np.zeros(system.n, complex)
        B0[mode] = 0.5 * np.sqrt(X) * np.exp(1j * beta)
        states.append(flow.steady_state(B0, rtol=rtol))
    return _unique(states, mode)


def first_approximation(
    system: ModalSystem,
    t: ArrayLike,
    harmonics: Sequence[Harmonic] = (),
    parametric: Sequence[Parametric] = (),
    *,
    guess: ArrayLike | None = None,
    **kwargs,
) -> tuple[Array, Array]:
    """The first approximation (3.7) on its steady state: :math:`\\eta(t)`, :math:`\\dot\\eta(t)`.

    :math:`a_r, \\theta_r` come from Newton-Raphson on the modulation equations (from ``guess``,
    default 0; with several steady states, the guess picks one — use
    :func:`primary_resonance` to see them all).  This is the initial state of the
    multiple-scales-Newmark method (section 4).

    Parameters
    ----------
    system : ModalSystem
    t : array_like
        Times (s).
    harmonics, parametric : sequences
    guess : array_like (n,) complex, optional
        Frame amplitudes :math:`a_r e^{i\\theta_r}` to start Newton from.
    **kwargs
        Passed to :func:`modulation_equations`.

    Returns
    -------
    eta, eta_dot : ndarrays (n,) + shape(t)
    """
    flow = modulation_equations(system, harmonics, parametric, **kwargs)
    st = flow.steady_state(guess)
    return st.eta(t), st.eta_dot(t)


# The linkage's modal model and the paper's multiple-scales-Newmark method live in
# fivebar.linkage_multiscale (this module imports nothing of the linkage); their old import
# path ``from fivebar.multiscale import multiple_scales`` still works, loaded on first use.
_LINKAGE_NAMES = frozenset(('ModalModel', 'MultipleScalesResponse', 'default_detuning', 'modal_model', 'modal_nonlinear_coefficients', 'multiple_scales', 'multiple_scales_newmark', 'initial_state', 'compare_starts'))


def __getattr__(name: str):
    if name in _LINKAGE_NAMES:
        from . import linkage_multiscale

        return getattr(linkage_multiscale, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
