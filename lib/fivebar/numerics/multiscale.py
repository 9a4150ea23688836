r"""Multiple scales: the first approximation (3.6)-(3.7) of the modal equations (3.4).

The modal equations (3.4) and their data types are in :mod:`fivebar.numerics.modal_equations`; the
closed forms of one mode (frequency response, backbone, parametric transition curves) in
:mod:`fivebar.numerics.response_curves`.  This module, like them, imports nothing of the linkage
(:mod:`fivebar.analyses.linkage_multiscale` builds the linkage's modal equations).

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
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .modal_equations import (
    Harmonic,
    ModalSystem,
    MultiscaleError,
    Parametric,
    _check_inputs,
    _check_mode,
    _check_sign,
    _real,
)
from .newton import newton

__all__ = [
    "DEFAULT_DETUNING",
    "ModeCoefficients",
    "ModulationSteadyState",
    "SecularTerm",
    "SlowFlow",
    "first_approximation",
    "modulation_equations",
    "particular_amplitudes",
]

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]

#: Default detuning tolerance, relative to each natural frequency: a frequency combination
#: within ``DEFAULT_DETUNING * omega_r`` of ``omega_r`` counts as resonant (secular).
DEFAULT_DETUNING = 0.05


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
    Lam = np.zeros((len(harmonics), system.n_modes), complex)
    for j, h in enumerate(harmonics):
        for r in range(system.n_modes):
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

    @property
    def kind(self) -> str:
        r"""What resonance the term expresses, read from its factors (mode :math:`r`, 1-based in
        the factors):

        * ``"excitation"`` (no factor: ``"1"``): a soft harmonic (the primary resonance
          :math:`\Omega_j\approx\omega_r`) or a product of forced parts through the nonlinear
          terms (the superharmonic :math:`\gamma\Lambda^3`, :math:`3\Omega_j\approx\omega_r`);
        * ``"frequency shift"`` (:math:`A_r`): the linear and forced shift of the frequency;
        * ``"parametric"`` (:math:`\bar A_r`): the principal parametric resonance
          :math:`\Omega_P\approx2\omega_r`;
        * ``"combination (sum)"`` (:math:`\bar A_s`, :math:`s\ne r`): :math:`\Omega_P\approx
          \omega_r+\omega_s`; ``"combination (difference)"`` (:math:`A_s`): :math:`\Omega_P
          \approx\omega_r-\omega_s`;
        * ``"backbone"`` (:math:`A_r^2\bar A_r`): the cubic term's own frequency shift;
          ``"cross-mode"`` (:math:`A_rA_s\bar A_s`): the shift by another mode's amplitude;
        * ``"subharmonic"`` (:math:`\bar A_r^2`, with a forced part):
          :math:`\Omega_j\approx3\omega_r`;
        * ``"internal"``: any other product of amplitudes (an internal resonance).
        """
        r = f"A{self.mode + 1}"
        c = f"conj({r})"
        f = [] if self.factors == "1" else self.factors.split()
        if not f:
            return "excitation"
        if len(f) == 1:
            if f[0] == r:
                return "frequency shift"
            if f[0] == c:
                return "parametric"
            return "combination (sum)" if f[0].startswith("conj") else "combination (difference)"
        if sorted(f) == sorted([r, r, c]):
            return "backbone"
        if len(f) == 2 and f == [c, c]:
            return "subharmonic"
        if len(f) == 3 and f.count(r) == 1 and c not in f:
            rest = [x for x in f if x != r]
            if len(rest) == 2 and rest[1] == f"conj({rest[0]})":
                return "cross-mode"
        return "internal"


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
        n = system.n_modes
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
        n = self.system.n_modes
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
        n = self.system.n_modes
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
        return np.bincount(self._mode, val.real, self.system.n_modes) + 1j * np.bincount(self._mode, val.imag, self.system.n_modes)

    def modulation(self, t: float, A: ArrayLike) -> CArray:
        """:math:`\\dot A_r = -\\zeta_r\\omega_r A_r - \\frac{i}{2\\omega_r}S_r(\\mathbf A,t)`
        (non-autonomous; integrate it for transients)."""
        s = self.system
        return -s.zeta * s.w * np.asarray(A, complex) - 0.5j / s.w * self.secular(t, A)

    def _frame(self) -> Array:
        if self.nu is None:
            detuning = float(self.tol[0] / self.system.w[0])
            raise MultiscaleError(
                f"detuning = {detuning:g}: the secular terms hold resonances with incompatible (incommensurate) detunings: no "
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
        S = np.bincount(self._mode, val, s.n_modes)
        return float(np.max(np.abs(s.zeta * s.w + 1j * nu) * np.abs(B) + 0.5 / s.w * S))

    def jacobian(self, x: ArrayLike) -> Array:
        """Jacobian of the flow (``__call__``) with respect to ``x = (Re B, Im B)``, (2n, 2n)."""
        s, nu = self.system, self._frame()
        n = s.n_modes
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
        n = self.system.n_modes
        B0 = np.zeros(n, complex) if guess is None else np.asarray(guess, complex)
        if B0.shape != (n,):
            raise MultiscaleError(f"guess has shape {B0.shape}, expected ({n},): one complex amplitude per mode")
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
    n, w = system.n_modes, system.w
    tol = detuning * w
    soft = {(_check_mode(system, r), int(j)) for r, j in soft}
    principal = {(_check_mode(system, r), int(j)) for r, j in principal}
    for r, j in soft:
        if not 0 <= j < len(harmonics):
            raise MultiscaleError(f"soft = {sorted(soft)!r}: harmonic index {j} is not allowed, it must lie in 0..{len(harmonics) - 1}")
    for r, j in principal:
        if not 0 <= j < len(parametric):
            raise MultiscaleError(
                f"principal = {sorted(principal)!r}: parametric index {j} is not allowed, it must lie in 0..{len(parametric) - 1}"
            )
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


# --- the steady first approximation -----------------------------------------------------------
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


