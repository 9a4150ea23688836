r"""Response curves of one mode from the modulation equations: the textbook closed forms.

The modulation equations of :mod:`fivebar.numerics.multiscale` reduce, for one resonant mode, to the
classical amplitude equations (Nayfeh & Mook 1979, 4.1 and 5.x), solved here in closed form
(companion roots) and refined by Newton-Raphson on the full slow flow.

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

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .modal_equations import Harmonic, ModalSystem, MultiscaleError, Parametric, _check_mode, _real
from .multiscale import DEFAULT_DETUNING, ModeCoefficients, ModulationSteadyState, modulation_equations

__all__ = [
    "FrequencyResponse",
    "backbone",
    "frequency_response",
    "parametric_response",
    "parametric_transition_curves",
    "primary_amplitudes",
    "primary_resonance",
]

Array = NDArray[np.float64]


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
        B0 = np.zeros(system.n_modes, complex)
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
        F = np.zeros(system.n_modes)
        F[mode] = float(force)
    sig = _real("sigmas", np.atleast_1d(sigmas))
    amp = np.full((sig.size, 3), np.nan)
    stab = np.zeros((sig.size, 3), bool)
    for i, s in enumerate(sig):
        Om = system.w[mode] + s
        if Om < 0:
            raise MultiscaleError(
                f"sigmas[{i}] = {s:g} rad/s is not allowed: it gives a negative excitation frequency {Om:g} rad/s "
                f"(sigma must be >= -omega_{mode} = {-system.w[mode]:g} rad/s)"
            )
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
        B0 = np.zeros(system.n_modes, complex)
        B0[mode] = 0.5 * np.sqrt(X) * np.exp(1j * beta)
        states.append(flow.steady_state(B0, rtol=rtol))
    return _unique(states, mode)
