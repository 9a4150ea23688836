r"""The linkage's modal equations (3.4) and its first approximation (3.6)-(3.7).

The glue between the generic multiple-scales solver :mod:`fivebar.numerics.multiscale` (with
:mod:`fivebar.numerics.modal_equations`, which know nothing of the linkage) and the model: :func:`modal_model` builds the modal system, harmonics
and parametric terms of :class:`fivebar.model.dynamics.LinkageDynamics` from
:func:`fivebar.model.excitation.modal_basis`; :func:`multiple_scales` returns the first
approximation as a :class:`fivebar.analyses.response.Response`; :func:`multiple_scales_newmark` is the
paper's method (section 4): the first approximation at t = 0 as the initial state of the
implicit scheme, marched to the steady state; :func:`compare_starts` measures its benefit.
Every function takes a :class:`fivebar.description.setup.Setup` or a Params.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..numerics.modal_equations import Harmonic, ModalSystem, MultiscaleError, Parametric
from ..numerics.multiscale import DEFAULT_DETUNING, ModulationSteadyState, SlowFlow, modulation_equations
from ..errors import ValidityWarning
from .response import Response
from ..description.setup import analysis, as_setup
from ..model.dynamics import linkage_dynamics

__all__ = [
    "ModalModel",
    "MultipleScalesResponse",
    "compare_starts",
    "default_detuning",
    "initial_state",
    "modal_model",
    "modal_nonlinear_coefficients",
    "multiple_scales",
    "multiple_scales_newmark",
]

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ModalModel:
    r"""The modal equations (3.4) of the linkage subsystem at one crank speed.

    Built by :func:`modal_model`.  With the instantaneous modes
    :math:`\boldsymbol\Phi(t)` of :func:`fivebar.model.excitation.modal_basis`,

    .. math::

        \ddot\eta_r + \bar\omega_r^2\eta_r ={}& \sum_{k=0}^m f_{rk}\cos(k\Omega t+\tau_{rk})
        - 2\zeta\bar\omega_r\dot\eta_r - \alpha_{rr}\eta_r \\
        &- \sum_{k=1}^m W_{rk}\cos(k\Omega t+\psi_{rk})\,\eta_r
        + \sum_{s,t}\bar\delta_{rst}\eta_s\eta_t
        + \sum_{s,t,u}\bar\gamma_{rstu}\eta_s\eta_t\eta_u ,

    where :math:`\bar\omega_r` is the paper's frequency mean (3.3) and
    :math:`\omega_r(t)^2 = \bar\omega_r^2 + \alpha_{rr} + \sum_k W_{rk}\cos(k\Omega t+\psi_{rk})`
    the instantaneous modal stiffness: :math:`\alpha_{rr} = \overline{\omega_r^2} -
    \bar\omega_r^2 \ge 0` (the mean of the squares minus the square of the mean) and
    :math:`W_{rk}` its harmonics, the parametric excitation of the time-varying linkage.  With
    ``kinematic`` the stiffness is :math:`\operatorname{diag}\omega_r(t)^2 + \mathbf H(t)`,
    :math:`\mathbf H = \boldsymbol\Phi^\top\mathbf M\ddot{\boldsymbol\Phi}` (a full
    matrix: :math:`\alpha` and :math:`W` are then (k, k)).  The
    paper's :math:`\alpha` is :math:`\mathbf K_{00} = \boldsymbol\phi^\top\mathbf K_0
    \boldsymbol\phi`, the electromagnetic stiffness, which acts on the rotors alone and is zero
    on the linkage subsystem; the :math:`\alpha, W` here replace it.  :math:`\bar\delta,
    \bar\gamma` are the period means of the projected nonlinear coefficients
    (:func:`modal_nonlinear_coefficients`).

    Attributes
    ----------
    dynamics : LinkageDynamics
    basis : fivebar.model.excitation.ModalBasis
        Over the periods of its modes (:meth:`~fivebar.model.excitation.ModalBasis.extended`:
        one period of the motion unless a mode returns with the opposite sign or as another).
    system : ModalSystem
        :math:`\bar\omega, \zeta, \alpha, \bar\delta, \bar\gamma` (epsilon absorbed).
    harmonics : tuple of Harmonic
        The modal load (2.10), :math:`k = 0..m` (k = 0 the mean).
    parametric : tuple of Parametric
        :math:`W_{rk}` as cosine and sine parts (empty without ``parametric``).
    load : fivebar.model.excitation.FourierSeries
        (2.10) of the modal forces.
    stiffness : fivebar.model.excitation.FourierSeries
        (2.10) of the modal stiffness, its (k, k) entries flattened (rad^2/s^2).
    delta, gamma : ndarrays (S, k, k, k), (S, k, k, k, k)
        The nonlinear coefficients at every step (zeros without ``nonlinear``).
    """

    dynamics: object
    basis: object
    system: ModalSystem
    harmonics: tuple
    parametric: tuple
    load: object
    stiffness: object
    delta: Array
    gamma: Array

    @property
    def crank_frequency(self) -> float:
        r"""The fundamental of the modal series (2.10) (rad/s): :math:`2\pi/T`, the crank
        frequency :math:`\Omega` at equal crank speeds; :math:`2\pi/(LT)` where the modes are
        periodic over L periods of the motion (``basis.periods`` of :func:`modal_model`'s
        basis before :meth:`~fivebar.model.excitation.ModalBasis.extended`)."""
        return float(self.load.frequency)


def modal_nonlinear_coefficients(dyn, basis, step_indices: Sequence[int] | None = None) -> tuple[Array, Array]:
    r"""Quadratic and cubic modal coefficients :math:`\delta_{rst}, \gamma_{rstu}` at given steps.

    The internal nonlinear force :math:`\mathbf f_{nl}(\mathbf u, t)` of
    :mod:`fivebar.model.nonlinear` (the gradient of the cubic and quartic strain energy, the negative
    of the paper's :math:`\varepsilon`) projected on the modes is
    :math:`g_r(\boldsymbol\eta) = \boldsymbol\phi_r^\top\mathbf f_{nl}(\boldsymbol\Phi
    \boldsymbol\eta) = -\sum\delta_{rst}\eta_s\eta_t - \sum\gamma_{rstu}\eta_s\eta_t\eta_u`.
    Its tangent :math:`\mathbf K_t(\mathbf u)` is linear plus quadratic in :math:`\mathbf u`,
    so its odd and even parts along a vector :math:`\mathbf v` are exactly
    :math:`\mathbf A(\mathbf v) = (\mathbf K_t(\epsilon\mathbf v)-\mathbf K_t(-\epsilon\mathbf v))
    /2\epsilon` and :math:`\mathbf B(\mathbf v,\mathbf v) = (\mathbf K_t(\epsilon\mathbf v)
    +\mathbf K_t(-\epsilon\mathbf v))/2\epsilon^2` for any :math:`\epsilon`; then

    .. math::

        \delta_{rst} = -\tfrac12\boldsymbol\phi_r^\top\mathbf A(\boldsymbol\phi_t)
        \boldsymbol\phi_s, \qquad
        \gamma_{rstu} = -\tfrac13\boldsymbol\phi_r^\top\mathbf B(\boldsymbol\phi_t,
        \boldsymbol\phi_u)\boldsymbol\phi_s ,

    with :math:`\mathbf B(\mathbf a,\mathbf b)` by polarisation.  Both are symmetric in all
    their indices (they derive from an energy).

    Parameters
    ----------
    dyn : LinkageDynamics
        Must have been built with ``nonlinear=True``.
    basis : fivebar.model.excitation.ModalBasis
    step_indices : sequence of int, optional
        Indices (0..S - 1) of the steps to evaluate (default all S).

    Returns
    -------
    delta : ndarray (len(step_indices), k, k, k)
    gamma : ndarray (len(step_indices), k, k, k, k)
        In the units of mass-normalised modal coordinates.
    """
    nl = dyn.nonlinear
    if nl is None:
        raise MultiscaleError(
            "dyn.nonlinear = None is not allowed: the dynamics has no nonlinear force; build it with nonlinear=True"
        )
    steps = range(basis.t.size) if step_indices is None else list(step_indices)
    k = basis.n_modes
    D = np.zeros((len(steps), k, k, k))
    G = np.zeros((len(steps), k, k, k, k))
    for i, j in enumerate(steps):
        t = float(basis.t[j])
        Phi = basis.shapes[j]

        def parts(v: Array) -> tuple[Array, Array]:
            e = 1e-3 / np.max(np.abs(v))
            Kp, Km = nl(e * v, t)[1], nl(-e * v, t)[1]
            return (Kp - Km) / (2 * e), (Kp + Km) / (2 * e * e)

        A = []
        B = np.zeros((k, k) + (dyn.n, dyn.n))
        for s in range(k):
            a, b = parts(Phi[:, s])
            A.append(a)
            B[s, s] = b
        for s in range(k):
            for u in range(s + 1, k):
                bp = parts(Phi[:, s] + Phi[:, u])[1]
                bm = parts(Phi[:, s] - Phi[:, u])[1]
                B[s, u] = B[u, s] = (bp - bm) / 4.0
        PA = np.array([Phi.T @ a @ Phi for a in A])  # [t, r, s]
        D[i] = -0.5 * np.transpose(PA, (1, 2, 0))
        PB = np.einsum("ir,tuij,js->rstu", Phi, B, Phi)
        G[i] = -PB / 3.0
    return D, G


def modal_model(
    dyn,
    n_modes: int = 2,
    *,
    basis: str = "instantaneous",
    frequencies: str = "mean",
    kinematic: bool = True,
    fourier_terms: int | None = None,
    nonlinear: bool = True,
    parametric: bool = True,
    nonlinear_steps: int | None = 20,
) -> ModalModel:
    r"""The modal equations (3.4) of a :class:`~fivebar.model.dynamics.LinkageDynamics` (see
    :class:`ModalModel`).

    Parameters
    ----------
    dyn : LinkageDynamics
    n_modes : int
        Modes kept (the paper: 2, (3.6)).
    basis : {"instantaneous", "reference"}
        :func:`fivebar.model.excitation.modal_basis`.  With "reference" the modal stiffness
        :math:`\boldsymbol\phi^\top\mathbf K(t)\boldsymbol\phi` is taken as the paper's
        :math:`\bar\omega^2` (no :math:`\alpha`, no parametric terms).
    frequencies : {"mean", "effective"}
        :math:`\bar\omega_r` of (3.4): "mean", the paper's means (3.3) of the instantaneous
        frequencies; "effective", :math:`\sqrt{\bar\omega_r^2 + \bar H_{rr}}` with the
        period mean of the kinematic stiffness
        :math:`\mathbf H = \boldsymbol\Phi^\top\mathbf M\ddot{\boldsymbol\Phi}`
        (:attr:`fivebar.model.excitation.ModalBasis.kinematic_stiffness`, about :math:`-\Omega^2`:
        spin softening).
    kinematic : bool
        Keep :math:`\mathbf H(t)` in the modal stiffness (its mean in :math:`\alpha`, its
        harmonics with the parametric terms).  The gyroscopic term
        :math:`2\boldsymbol\Phi^\top\mathbf M\dot{\boldsymbol\Phi}\dot{\boldsymbol\eta}`
        has no place in (3.4) and is left out.
    fourier_terms : int, optional
        m of (2.10), the harmonics of the motion's fundamental; default
        :func:`fivebar.description.setup.fourier_harmonics` (``params.fourier_terms`` at equal
        crank speeds).  Where the modes are periodic over L periods of the motion
        (``ModalBasis.periods``), the series run over those with ``m L`` harmonics.
    nonlinear : bool
        Project the geometric nonlinearity (needs ``dyn`` built with ``nonlinear=True``).
    parametric : bool
        Keep the harmonics of the modal stiffness as parametric terms.
    nonlinear_steps : int or None
        Number of equally spaced steps over which :math:`\delta, \gamma` are averaged
        (None: all S steps).

    Raises
    ------
    MultiscaleError
        Bad options, or an effective frequency that is not real (the speed is past the one at
        which spin softening cancels the mode's stiffness).
    """
    from ..description.setup import fourier_harmonics
    from ..model.excitation import fourier_series, modal_basis

    if frequencies not in ("mean", "effective"):
        raise MultiscaleError(f"frequencies = {frequencies!r} is not allowed: use 'mean' or 'effective'")
    if basis not in ("instantaneous", "reference"):
        raise MultiscaleError(f"basis = {basis!r} is not allowed: use 'instantaneous' or 'reference'")
    # over the periods of the modes (one, unless a mode returns after a period with the opposite
    # sign or as another: ModalBasis.wrap), with m harmonics of the motion's fundamental
    one = modal_basis(dyn, n_modes, basis)
    B = one.extended()
    m = (fourier_harmonics(dyn.params) if fourier_terms is None else fourier_terms) * one.periods
    load = fourier_series(B.project(one.tile(dyn.step_data.F)), B.period, m)
    k = B.n_modes
    S = B.t.size
    if basis == "instantaneous":
        Kt = np.zeros((S, k, k))
        Kt[:, np.arange(k), np.arange(k)] = B.omega**2
        if kinematic:
            Kt = Kt + B.kinematic_stiffness
    else:
        Kt = np.broadcast_to(np.diag(B.mean_omega**2), (S, k, k))
    stiff = fourier_series(Kt.reshape(S, k * k), B.period, m)
    wbar = B.mean_omega
    if frequencies == "effective":
        w2 = wbar**2 + np.diag(B.kinematic_stiffness.mean(axis=0))
        if np.any(w2 <= 0):
            r = int(np.flatnonzero(w2 <= 0)[0])
            raise MultiscaleError(
                f"frequencies = 'effective' is not allowed here: the effective frequency of mode {r + 1} is not "
                f"real (omega^2 + H = {w2[r]:.4g} rad^2/s^2), the crank speed is past the spin-softening limit "
                "of that mode; use frequencies='mean'"
            )
        wbar = np.sqrt(w2)
    harmonics = [Harmonic(0.0, load.mean)]
    harmonics += [Harmonic(f, load.amplitude[i], load.phase[i]) for i, f in enumerate(load.frequencies)]
    alpha = stiff.mean.reshape(k, k) - np.diag(wbar**2) if basis == "instantaneous" else np.zeros((k, k))
    par: list[Parametric] = []
    if parametric and basis == "instantaneous":
        for i, f in enumerate(stiff.frequencies):
            W, psi = stiff.amplitude[i].reshape(k, k), stiff.phase[i].reshape(k, k)
            par.append(Parametric(f, W * np.cos(psi), 0.0))
            par.append(Parametric(f, W * np.sin(psi), np.pi / 2))
    if nonlinear_steps is not None and (
        isinstance(nonlinear_steps, bool) or not isinstance(nonlinear_steps, (int, np.integer)) or not 1 <= nonlinear_steps <= S
    ):
        raise MultiscaleError(f"nonlinear_steps = {nonlinear_steps!r} is not allowed: give an integer in 1..{S} (S) or None")
    if nonlinear:
        steps = range(S) if nonlinear_steps is None else np.unique(np.linspace(0, S, int(nonlinear_steps), endpoint=False).astype(int))
        D, G = modal_nonlinear_coefficients(dyn, B, steps)
    else:
        D, G = np.zeros((1, k, k, k)), np.zeros((1, k, k, k, k))
    system = ModalSystem(wbar, np.full(k, dyn.params.damping_ratio), alpha, D.mean(axis=0), G.mean(axis=0))
    return ModalModel(dyn, B, system, tuple(harmonics), tuple(par), load, stiff, D, G)


def default_detuning(model: ModalModel) -> float:
    r"""Detuning tolerance for the linkage: ``min(DEFAULT_DETUNING, 0.45 Omega / max omega)``.

    Harmonics :math:`k\Omega` are :math:`\Omega` apart (:attr:`ModalModel.crank_frequency`, the
    fundamental of the series); below half that spacing (relative to
    the highest kept frequency) at most one harmonic is resonant with each mode, so a rotating
    frame exists (see :func:`modulation_equations`).
    """
    return float(min(DEFAULT_DETUNING, 0.45 * model.crank_frequency / np.max(model.system.w)))


@dataclass
class MultipleScalesResponse(Response):
    r"""The first approximation (3.6)-(3.7) over one period, as a steady state of the linkage.

    A :class:`fivebar.analyses.response.Response` (``method == "multiple scales"``) whose ``u, v`` are :math:`\boldsymbol\Phi(t)\boldsymbol\eta(t)` and
    :math:`\boldsymbol\Phi\dot{\boldsymbol\eta} + \dot{\boldsymbol\Phi}\boldsymbol\eta`
    at the S + 1 samples, so ``midpoint_mm(link, direction)``, ``peak_to_peak_mm``,
    ``bending_stress`` and ``plot`` work as for the numerical steady state.  Extra attributes: ``modal``
    (:class:`ModalModel`), ``slow`` (the slow-flow :class:`ModulationSteadyState`: ``a``, ``theta0``,
    ``stable``), ``flow`` (:class:`SlowFlow`), ``eta`` and ``eta_dot`` ((S + 1, k)), and
    ``detuning``, the relative resonance tolerance used.
    """

    modal: ModalModel | None = None
    slow: ModulationSteadyState | None = None
    flow: SlowFlow | None = None
    eta: Array | None = field(default=None, repr=False)
    eta_dot: Array | None = field(default=None, repr=False)
    detuning: float = float("nan")


@analysis
def multiple_scales(
    setup,
    *,
    n_modes: int = 2,
    basis: str = "instantaneous",
    frequencies: str = "mean",
    kinematic: bool = True,
    parametric: bool = True,
    fourier_terms: int | None = None,
    detuning: float | None = None,
    guess: ArrayLike | None = None,
):
    r"""The multiple-scales first approximation (3.6)-(3.7) of the linkage's steady response.

    Call forms::

        ms = multiple_scales(setup)                      # the set-up's speed, 2 modes
        ms.midpoint_mm("L2", "transverse")                  # mm over S + 1 samples, as fivebar.SteadyState
        ms.slow.a, ms.slow.theta0, ms.slow.stable        # a_r, theta_r by Newton-Raphson
        ms.u[0], ms.v[0]                                 # initial state of multiple-scales-Newmark

    Steps: the modal model (3.4) (:func:`modal_model`), its modulation equations with every
    secular term (:func:`modulation_equations`; harmonics within ``detuning`` of a natural
    frequency are resonant, soft), their steady state by Newton-Raphson, and
    :math:`\mathbf u = \boldsymbol\Phi(t)\boldsymbol\eta(t)` with :math:`\eta` from (3.7)
    (particular solutions of every non-resonant harmonic, the constant load, and the free or
    resonant part :math:`2a_r\cos(\omega_r t + \theta_r)`).

    Parameters
    ----------
    setup : Setup or Params
        The problem (:class:`fivebar.description.setup.Setup`: crank speed, S, motors, mesh, and
        ``nonlinear``, which also switches the modal coefficients :math:`\delta, \gamma`; a
        Params means ``Setup(params)``).
    n_modes, basis, frequencies, kinematic, parametric, fourier_terms
        See :func:`modal_model` (default: the paper's frequency means (3.3)).
    detuning : float, optional
        Relative resonance tolerance.  Default :func:`default_detuning`, halved (up to nine
        times) while weak combination terms of different modes ask for incompatible rotating
        frames; a given value is used as is.
    guess : array_like (k,) complex, optional
        Start of Newton-Raphson for the slow-flow amplitudes (default 0).

    Returns
    -------
    MultipleScalesResponse
        A :class:`fivebar.analyses.response.Response`.
    """
    dyn = linkage_dynamics(as_setup(setup))
    model = modal_model(
        dyn, n_modes, basis=basis, frequencies=frequencies, kinematic=kinematic, fourier_terms=fourier_terms,
        nonlinear=dyn.nonlinear is not None, parametric=parametric,
    )
    if detuning is not None and (
        isinstance(detuning, bool) or not isinstance(detuning, (int, float, np.floating)) or not (np.isfinite(detuning) and detuning >= 0)
    ):
        raise MultiscaleError(f"detuning = {detuning!r} is not allowed: give a finite number >= 0 (relative) or None")
    tol = default_detuning(model) if detuning is None else float(detuning)
    for _ in range(10):
        flow = modulation_equations(model.system, model.harmonics, model.parametric, detuning=tol)
        if flow.nu is not None or detuning is not None:
            break
        # weak combination terms with incompatible detunings: narrow the tolerance
        tol *= 0.5
    slow = flow.steady_state(guess)
    S = dyn.steps_per_period
    t = np.arange(S + 1) * dyn.dt
    eta = slow.eta(t).T  # (S+1, k)
    eta_dot = slow.eta_dot(t).T
    # the basis over the periods of its modes: its first S + 1 steps (one period and the next step)
    Phi = np.concatenate([model.basis.shapes, model.basis.shapes[:1]])[: S + 1]
    Phid = model.basis.shapes_dot
    Phid = np.concatenate([Phid, Phid[:1]])[: S + 1]
    u = np.einsum("sik,sk->si", Phi, eta)
    v = np.einsum("sik,sk->si", Phi, eta_dot) + np.einsum("sik,sk->si", Phid, eta)
    ms = MultipleScalesResponse(
        dynamics=dyn, t=t, u=u, v=v, method="multiple scales",
        modal=model, slow=slow, flow=flow, eta=eta, eta_dot=eta_dot, detuning=tol,
    )
    # the steady state's validity checks (stress against yield, deflection against the
    # small-deflection range), read from this response as from a SteadyState's
    from .steady import SteadyState

    outside = SteadyState._checks(ms)["reasons"]
    if outside:
        warnings.warn(f"the multiple-scales response at {dyn.setup.crank_speed_rpm:g} r/min is outside the model's "
                      "validity (whatever its slow flow says of stability): " + "; ".join(outside),
                      ValidityWarning, stacklevel=3)  # (multiple_scales, its analysis wrapper, the caller)
    return ms


def _energy_distance(dyn, u: Array, v: Array, ref) -> float:
    """Energy-norm distance of the state (u, v) at t = 0 from the orbit ``ref`` at t = 0,
    relative to the orbit's largest energy norm over the period."""
    sd = dyn.step_data
    M, K = sd.M[0], sd.K[0]
    du, dv = u - ref.u[0], v - ref.v[0]
    e = np.sqrt(du @ K @ du + dv @ M @ dv)
    scale = np.sqrt(np.einsum("si,ij,sj->s", ref.u, K, ref.u) + np.einsum("si,ij,sj->s", ref.v, M, ref.v)).max()
    return float(e / scale)


@analysis
def initial_state(setup, start: str = "multiple scales", **kwargs) -> tuple[Array, Array]:
    r"""Initial state :math:`(\mathbf u_0, \dot{\mathbf u}_0)` at t = 0 for marching to the steady state.

    Parameters
    ----------
    setup : Setup or Params
        The problem.
    start : {"multiple scales", "rest", "quasi-static"}
        "multiple scales": the first approximation (3.7) at t = 0 (the paper's section 4,
        :func:`multiple_scales`, keyword arguments passed on); "rest": zeros; "quasi-static":
        :math:`\mathbf K(0)^{-1}\mathbf F(0)` with its time derivative (central difference).
    """
    setup = as_setup(setup)
    dyn = linkage_dynamics(setup)
    if start == "multiple scales":
        ms = multiple_scales(setup, **kwargs)
        return ms.u[0].copy(), ms.v[0].copy()
    if start == "rest":
        return np.zeros(dyn.n), np.zeros(dyn.n)
    if start == "quasi-static":
        h = dyn.dt
        us = dyn.quasi_static(np.array([-h, 0.0, h]))
        return us[1], (us[2] - us[0]) / (2 * h)
    raise MultiscaleError(f"start = {start!r} is not allowed: use 'multiple scales', 'rest' or 'quasi-static'")


@analysis
def multiple_scales_newmark(
    setup,
    *,
    tol: float = 1e-4,
    max_periods: int = 500,
    start: str = "multiple scales",
    **kwargs,
):
    r"""The paper's multiple-scales-Newmark method (section 4): (3.7) at t = 0, then Newmark.

    The first approximation at :math:`t = 0` (:func:`multiple_scales`, ``**kwargs`` passed on)
    is the initial state; the implicit scheme marches period after period
    (:func:`fivebar.analyses.steady.march`) until the state repeats to ``tol`` (relative change over one
    period in the energy norm).  ``setup`` is a :class:`fivebar.description.setup.Setup` or a Params; the
    scheme and S are the set-up's (by default the parameter file's generalised-alpha: the paper's
    average-acceleration rule at S = 100 has an unstable discrete periodic orbit for this
    model, errata E26, so marching with it diverges).

    Returns
    -------
    fivebar.analyses.steady.SteadyState
        ``method == "march"``; ``periods`` is the number of periods marched.
    """
    from .steady import march

    u0, v0 = initial_state(setup, start, **kwargs)
    return march(setup, u0, v0, tol=tol, max_periods=max_periods)


@analysis
def compare_starts(
    setup,
    speeds_rpm: ArrayLike,
    *,
    starts: Sequence[str] = ("multiple scales", "rest", "quasi-static"),
    tol: float = 1e-4,
    max_periods: int = 500,
    links: Sequence[str] | None = None,
    **kwargs,
):
    r"""Periods Newmark needs to reach the steady state from several starts, and the error of
    the multiple-scales approximation, at several crank speeds.

    For every speed (replacing the problem's, a :class:`fivebar.description.setup.Setup` or a Params):
    the steady state by shooting (the reference, same scheme), the
    first approximation (:func:`multiple_scales`, ``**kwargs``), and :func:`fivebar.analyses.steady.march`
    from each start until the relative change over a period is below ``tol``.

    Returns
    -------
    pandas.DataFrame
        One row per speed: ``speed (r/min)``; ``periods from <start>`` (NaN where the march
        failed); ``start error <start>`` (energy-norm distance of the start from the steady
        orbit at t = 0, relative to the orbit's largest energy norm); for each link
        ``<link> p2p (mm)`` of the steady state and ``<link> MS error`` (relative error of the
        peak-to-peak of the first approximation), for ``links`` (default the description's
        couplers: L2 and L3 of the five-bar); ``MS waveform error`` (max over the period of the
        first link's midpoint error, relative to its largest value); ``shooting iterations``.
    """
    import pandas as pd

    from .steady import march, shooting

    base = as_setup(setup)
    links = tuple(base.params.linkage.couplers) if links is None else tuple(links)
    rows = []
    for s in np.atleast_1d(np.asarray(speeds_rpm, float)):
        at = base.replace(crank_speed_rpm=float(s))
        dyn = linkage_dynamics(at)
        ref = shooting(at)
        with warnings.catch_warnings():  # the table compares the approximation at every speed; its
            warnings.simplefilter("ignore", ValidityWarning)  # validity is the steady state's (not checked here, as before)
            ms = multiple_scales(at, **kwargs)
        row = {"speed (r/min)": float(s)}
        for st in starts:
            u0, v0 = (ms.u[0], ms.v[0]) if st == "multiple scales" else initial_state(at, st)
            row[f"start error {st}"] = _energy_distance(dyn, u0, v0, ref)
            try:
                row[f"periods from {st}"] = march(at, u0, v0, tol=tol, max_periods=max_periods).periods
            except Exception:  # noqa: BLE001 - a failed march is a result here (NaN)
                row[f"periods from {st}"] = np.nan
        for link in links:
            a = ref.peak_to_peak_mm(link)
            row[f"{link} p2p (mm)"] = a
            row[f"{link} MS error"] = ms.peak_to_peak_mm(link) / a - 1.0
        y = ref.midpoint_mm(links[0])
        row["MS waveform error"] = float(np.abs(ms.midpoint_mm(links[0]) - y).max() / np.abs(y).max())
        row["shooting iterations"] = ref.periods
        rows.append(row)
    return pd.DataFrame(rows)
