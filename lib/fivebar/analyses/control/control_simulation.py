r"""Closed-loop simulation of the free-rotor linkage along the nominal motion.

**Along the motion.**  Linearised about the nominal motion (crank laws
:func:`fivebar.model.kinematics.crank_laws`), with :math:`\mathbf p` the deviation from the nominal
rigid configuration, the kineto-elastodynamic equation of (2.7) with free rotors reads

.. math::

    \mathbf M_p(t)\ddot{\mathbf p} + \mathbf C_p(t)\dot{\mathbf p} + \mathbf K_p(t)\mathbf p
    = -\mathbf M_p(t)\,\mathbf a_r(t) + \mathbf B\big(\boldsymbol\tau_{ff}(t)
      + \boldsymbol\tau_{fb}\big),

:math:`\mathbf a_r` the nominal rigid acceleration field (rotor entries: the crank
accelerations), :math:`\boldsymbol\tau_{ff}` the inverse dynamics of the rigid model
(:func:`feedforward`, equal to :math:`\boldsymbol\Phi_r^\top\mathbf M_p\mathbf a_r`, so it
balances the rigid modes exactly), and :math:`\boldsymbol\tau_{fb} = -\mathbf G_p(t)\mathbf p
- \mathbf G_v(t)\dot{\mathbf p}` the servo and damping feedback.  :func:`simulate_cycle`
integrates it with :func:`fivebar.numerics.newmark.integrate`.  With the rotors held on the nominal
motion (an ideal servo) it is exactly the linear prescribed-motion model.

What the model leaves out is listed in :mod:`fivebar.model.free_rotors`.  :func:`closed_loop_multipliers`
says whether the loop is stable along the motion.  The left-out velocity terms are of the order
:math:`\Omega^2 J` on the rigid modes (on :math:`\mathbf p = \boldsymbol\Phi_r(t)\boldsymbol\eta`
the term :math:`\mathbf M_p\ddot{\mathbf p}` brings :math:`2\boldsymbol\Phi_r^\top\mathbf M_p\dot{\boldsymbol\Phi}_r
\dot{\boldsymbol\eta} + \boldsymbol\Phi_r^\top\mathbf M_p\ddot{\boldsymbol\Phi}_r\boldsymbol\eta`, which they
would balance): the model holds for a servo whose bandwidth is well above the crank frequency.
With a slower servo it can be unstable where the rigid Lagrange dynamics under the same servo are
stable (at 120 r/min with a 0.78 Hz servo, a largest multiplier of about 6 against 0.2; one of the
library's tests).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .control_model import Servo
from ...errors import InputError, InputTypeError
from ...model.free_rotors import FlexibleLinkage, _count, _positive, feedforward
from ...model.kinematics import crank_laws
from ...numerics.newmark import integrate
from ...numerics.schemes import Scheme
from ...numerics.systems import PeriodicStepData, System
from ...numerics.periodic import floquet_multipliers
from ...description.params import Params
from ...description.setup import Setup, analysis, as_setup

__all__ = ["CycleSimulation", "closed_loop_multipliers", "simulate_cycle"]


@dataclass
class CycleSimulation:
    """A closed-loop simulation along the nominal motion (:func:`simulate_cycle`).

    Attributes
    ----------
    t : ndarray
        Times (s) from crank angle 0, shape (N,).
    p, v : ndarray
        Deviations from the nominal rigid configuration and their rates (SI), shape (N, n).
    w : ndarray
        Transverse midpoint deflections of the couplers (L2, L3 of the five-bar) relative to the
        rigid motion at the rotor angles (m), shape (N, couplers).
    error : ndarray
        Rotor-angle deviations from the crank laws (rad), shape (N, driven cranks).
    torque : ndarray
        Motor torques, feedforward plus feedback (N m), shape (N, driven cranks).
    steps_per_period, periods : int
    links : tuple of str
        The couplers, in the order of the columns of ``w``.
    """

    t: NDArray
    p: NDArray
    v: NDArray
    w: NDArray
    error: NDArray
    torque: NDArray
    steps_per_period: int
    periods: int
    links: tuple[str, ...] = ()

    def last_period(self) -> slice:
        """Slice of the samples of the last period (S + 1 samples)."""
        return slice(len(self.t) - self.steps_per_period - 1, len(self.t))

    def _col(self, link: str) -> int:
        if link not in self.links:
            raise InputError(f"link = {link!r} is not allowed: use one of {list(self.links)}")
        return self.links.index(link)

    def peak_to_peak(self, link: str) -> float:
        """Peak-to-peak midpoint deflection (m) of a coupler ("L2" or "L3" of the five-bar) over
        the last period."""
        y = self.w[self.last_period(), self._col(link)]
        return float(y.max() - y.min())

    def periodicity(self) -> float:
        """Largest change of w over the last period, relative to its peak-to-peak."""
        S = self.steps_per_period
        if self.periods < 2:
            return math.nan
        d = np.abs(self.w[-S - 1:] - self.w[-2 * S - 1:-S]).max()
        return float(d / max(np.ptp(self.w[-S - 1:], axis=0).max(), 1e-300))

    def settling_time(self, link: str, fraction: float = 0.05) -> float:
        """Time (s) after which w stays within ``fraction`` of its steady peak-to-peak of the
        steady (last-period) motion; 0 if it always does."""
        c = self._col(link)
        f = _positive("fraction", fraction)
        S = self.steps_per_period
        ref = self.w[-S - 1:-1, c]
        dev = np.abs(self.w[:, c] - ref[np.arange(len(self.t)) % S])
        bad = np.flatnonzero(dev > f * np.ptp(ref))
        return float(self.t[bad[-1]]) if len(bad) else 0.0


def _reference(ref, fl: FlexibleLinkage, params: Params, S: int) -> tuple[NDArray, NDArray]:
    """The expected elastic motion (p, p') at the S steps of a period, from a prescribed-motion
    :class:`fivebar.analyses.steady.SteadyState` (rotors on the crank laws) or a :class:`CycleSimulation`."""
    if isinstance(ref, CycleSimulation):
        if ref.steps_per_period != S:
            raise InputError(f"reference has {ref.steps_per_period} steps per period: it must have {S}")
        sl = slice(len(ref.t) - S - 1, len(ref.t) - 1)
        return ref.p[sl], ref.v[sl]
    dyn = getattr(ref, "dynamics", None)
    if dyn is None:
        raise InputTypeError(f"reference must be a SteadyState or a CycleSimulation, got {type(ref).__name__}")
    if dyn.steps_per_period != S or not math.isclose(dyn.period, params.period, rel_tol=1e-12):
        raise InputError(
            f"reference has {dyn.steps_per_period} steps over {dyn.period:.6g} s: it must have {S} steps over "
            f"{params.period:.6g} s (the same crank speed and steps_per_period)"
        )
    labels = [dyn.model.dofs[i].label for i in dyn.keep]
    lk = params.linkage
    # the tied crank roots: the coupling-end torsion U4 (U8) of each motor is its crank's root slope
    rename = {f"U{4 * k}": f"{lk.crank_link(joint).name}@{joint}.slope" for k, (joint, _) in enumerate(lk.motors, start=1)}
    where = {rename.get(lab, lab): k for k, lab in enumerate(labels)}
    N = fl.inputs
    missing = [lab for lab in fl.labels[N:] if lab not in where]
    if missing or (lk.motors and not dyn.model.motors):
        raise InputError(f"reference model lacks the coordinates {missing}: use motors=True and the same mesh")
    P = np.zeros((S, fl.n))
    V = np.zeros((S, fl.n))
    cols = [where[lab] for lab in fl.labels[N:]]
    P[:, N:] = ref.u[:S, cols]
    V[:, N:] = ref.v[:S, cols]
    return P, V


@dataclass
class _ClosedLoop:
    """The closed loop along the nominal motion as per-step matrices (one period of S steps)."""

    linkage: FlexibleLinkage
    params: Params
    scheme: Scheme
    steps: int
    dt: float
    laws: tuple
    rigid_modes: NDArray
    step_data: PeriodicStepData
    Gp: NDArray
    Gv: NDArray
    u_ref: NDArray
    tau_ff: NDArray


def _closed_loop(setup, servo, damping, reference) -> _ClosedLoop:
    setup = as_setup(setup)
    params = setup.run_params
    S = _count("steps_per_period", setup.steps_per_period, 2, 10**7)
    if not isinstance(servo, Servo):
        raise InputTypeError(f"servo must be a Servo, got {type(servo).__name__}")
    fl = FlexibleLinkage(params, setup.elements_per_link)
    T = params.period
    dt = T / S
    t = np.arange(S) * dt
    laws = crank_laws(params, t)
    M, K = fl.matrices(*laws[0::3])
    Phi = fl.rigid_modes(*laws[0::3])
    C = np.empty_like(M)
    for k in range(S):
        om, Pe = fl.modes(M[k], K[k], Phi[k])
        C[k] = fl.damping(M[k], om, Pe)
    tau_ff = feedforward(params, t)
    F = fl.inertial_load(*laws)
    F = F + tau_ff @ fl.B.T
    Gs = servo.gains(fl)
    r = fl.inputs
    Gp = np.broadcast_to(Gs[0], (S, r, fl.n)).copy()
    Gv = np.broadcast_to(Gs[1], (S, r, fl.n)).copy()
    u_ref = np.zeros((S, r))
    if damping is not None:
        G = np.asarray(damping(laws[0] - params.linkage.inputs[0].drive.theta0), float)  # (the first crank's turn)
        if G.shape != (S, 2, r, fl.n):
            raise InputError(f"damping(phi) returned shape {G.shape[1:]}: it must be (2, {r}, {fl.n})")
        Gp += G[:, 0]
        Gv += G[:, 1]
        if reference is not None:
            P_ref, V_ref = _reference(reference, fl, params, S)
            u_ref = np.einsum("kij,kj->ki", G[:, 0], P_ref) + np.einsum("kij,kj->ki", G[:, 1], V_ref)
            F = F + u_ref @ fl.B.T
    Kc = K + fl.B @ Gp
    Cc = C + fl.B @ Gv
    sd = PeriodicStepData(M, Cc, Kc, F, t0=0.0, period=T)
    return _ClosedLoop(fl, params, setup.scheme, S, dt, laws, Phi, sd, Gp, Gv, u_ref, tau_ff)


@analysis
def simulate_cycle(
    setup: Setup | Params,
    servo: Servo,
    damping: Callable[[ArrayLike], NDArray] | None = None,
    *,
    reference=None,
    periods: int = 3,
    start: str = "quasi-static",
) -> CycleSimulation:
    """Closed-loop kineto-elastodynamics with free rotors along the nominal motion.

    ``sim = simulate_cycle(setup, servo)``; ``sim.peak_to_peak("L2")`` (a coupler of the linkage).

    Integrates, with the set-up's scheme (the parameter file's generalised-alpha by default,
    errata E26; :func:`fivebar.numerics.newmark.integrate`) on the full-order model of :class:`FlexibleLinkage` (no modal truncation),

    M_p p'' + C_p p' + K_p p = -M_p a_r + B (tau_ff - G_s (p, p') - G_d (p - p_ref, p' - p_ref')),

    with the matrices of the configuration at every step (a linear time-varying system),
    modal damping on the free-rotor elastic modes of the instant, the feedforward
    :func:`feedforward`, the servo G_s, and optionally the scheduled damping gains G_d
    (``damping``, from :func:`damping_schedule`) acting on the deviation from an expected
    elastic motion p_ref (``reference``; zero if not given).  See the module docstring for
    what is left out.

    Parameters
    ----------
    setup
        The problem, a :class:`fivebar.description.setup.Setup` (its crank speed, S, scheme and
        mesh; the rotors are free and the model linear, so motors and nonlinearity do not apply
        here), or a Params (``Setup(params)``).
    servo
        The PD servo (it acts on the deviation of the measured angle from the crank laws).
    damping
        ``phi -> (2, r, n)`` scheduled gains (crank angle in rad; r the driven cranks), or ``None``.
    reference
        The expected elastic motion for the damping loop: a prescribed-motion
        :class:`fivebar.analyses.steady.SteadyState` with the same speed and ``steps_per_period``
        (an ideal servo's elastic motion), or a :class:`CycleSimulation`; ``None``: zero.
    periods
        Periods of the motion to integrate (the last one is taken as the steady state).
    start
        "quasi-static" (the static deflection under the load at t = 0, at rest relative to
        it) or "rest" (p = 0, p' = 0: the linkage released undeformed at speed).
    """
    if start not in ("quasi-static", "rest"):
        raise InputError(f"start = {start!r} is not allowed: use 'quasi-static' or 'rest'")
    periods = _count("periods", periods, 1, 10**6)
    cl = _closed_loop(setup, servo, damping, reference)
    fl, S, dt, sd, Kc, F = cl.linkage, cl.steps, cl.dt, cl.step_data, cl.step_data.K, cl.step_data.F
    Cc, M, Gp, Gv, u_ref = cl.step_data.C, cl.step_data.M, cl.Gp, cl.Gv, cl.u_ref
    if start == "rest":
        u0 = np.zeros(fl.n)
        v0 = np.zeros(fl.n)
    else:
        qs = [np.linalg.solve(Kc[k], F[k]) for k in (S - 1, 0, 1)]
        u0, v0 = qs[1], (qs[2] - qs[0]) / (2 * dt)
    res = integrate(System(M[0], Cc[0], Kc[0]), u0, v0, 0.0, dt, periods * S, cl.scheme, step_data=sd)
    k = np.arange(len(res.t)) % S
    W = fl.elastic_midpoint_rows(*cl.laws[0::3], Phi_r=cl.rigid_modes)  # (S, couplers, n)
    w = np.einsum("kij,kj->ki", W[k], res.u)
    fb = -np.einsum("kij,kj->ki", Gp[k], res.u) - np.einsum("kij,kj->ki", Gv[k], res.v) + u_ref[k]
    return CycleSimulation(res.t, res.u, res.v, w, res.u[:, list(fl.rotor)], cl.tau_ff[k] + fb, S, periods,
                           tuple(fl.params.linkage.couplers))


@analysis
def closed_loop_multipliers(
    setup: Setup | Params,
    servo: Servo,
    damping: Callable[[ArrayLike], NDArray] | None = None,
) -> NDArray[np.complex128]:
    """Floquet multipliers of the closed loop of :func:`simulate_cycle` over one period.

    ``mu = closed_loop_multipliers(setup, servo, damper)``; the loop is stable along the
    motion (every start transient decays, and the simulation reaches its periodic steady
    state) if and only if ``abs(mu).max() < 1``.  The frozen-time designs say nothing about
    this: a time-varying plant can be unstable although every frozen closed loop is stable.

    The multipliers are the eigenvalues of the monodromy matrix of the discrete map that
    :func:`simulate_cycle` iterates (the product of the integrator's step Jacobians, exact
    for the linear time-varying system; the state is (p, p') for Newmark and (p, p', p'')
    for the alpha schemes, whose extra multipliers are the scheme's numerical damping).  They
    converge to those of the differential equation as the step is refined.  The forcing and
    the reference do not change them.  Arguments as for :func:`simulate_cycle`.

    Returns
    -------
    ndarray of complex
        The multipliers, largest modulus first.  The decay per period of the slowest
        transient is their largest modulus; a start transient falls by ``1e-3`` in about
        ``log(1e-3) / log(max |mu|)`` periods.
    """
    cl = _closed_loop(setup, servo, damping, None)
    sd, n = cl.step_data, cl.linkage.n
    res = integrate(System(sd.M[0], sd.C[0], sd.K[0]), np.zeros(n), np.zeros(n), 0.0, cl.dt, cl.steps, cl.scheme,
                    step_data=sd, sensitivity=True, store="last")
    return floquet_multipliers(res.monodromy)
