r"""The linkage's periodic steady state by harmonic balance, with Hill's stability.

The glue between a set-up (:class:`fivebar.description.setup.Setup`) and the generic
:mod:`fivebar.numerics.harmonic_balance`: the linkage subsystem of (2.7),

.. math::

    \mathbf M(t)\ddot{\mathbf u} + \mathbf C(t)\dot{\mathbf u} + \mathbf K(t)\mathbf u
    + \mathbf f_{nl}(\mathbf u, t) = -\mathbf M(t)\ddot{\mathbf u}_r(t) ,

is a :class:`~fivebar.numerics.harmonic_balance.PeriodicSystem` whose samples at :math:`t_k = kT/N` are
those of :class:`fivebar.model.dynamics.LinkageDynamics` at :math:`S = N` steps per period (the same
sampled matrices and load, from the same cache), and whose nonlinear force at the samples is
the compiled strain force (2.8) of the time loop (``fivebar.model._nonlinear_kernel``), called
sample by sample.  :func:`harmonic_balance_steady_state` is
``fivebar.steady_state(setup, method="harmonic_balance", tol=...)``: the series is solved with
H harmonics (the parameter file's ``fourier_terms`` m of (2.10) to start; with ``tol`` as many
as the error estimate of the transverse midpoint deflections of the couplers asks), and the
result is a :class:`~fivebar.analyses.steady.SteadyState` sampled at the set-up's S + 1 times of the
period, its Floquet multipliers by Hill's method.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..description.params import Params
from ..description.setup import Setup, as_setup, min_steps_per_period
from ..errors import InputError, InputTypeError
from ..model.dynamics import linkage_dynamics
from ..numerics.harmonic_balance import HarmonicBalanceSolution, PeriodicSamples, harmonic_balance, samples_for
from .response import Response
from .steady import SteadyState

__all__ = ["HILL_MAX_HARMONICS", "HarmonicBalanceState", "LinkageSystem", "harmonic_balance_steady_state"]

#: the harmonics of Hill's matrix are at most these (its size is 2 n (2 H + 1): the dense
#: eigenproblem costs its cube); the multipliers that decide the stability converge well below
HILL_MAX_HARMONICS = 12


class LinkageSystem:
    """The linkage subsystem of a set-up as a :class:`~fivebar.numerics.harmonic_balance.PeriodicSystem`.

    ``LinkageSystem(setup).samples(N)``: M, C, K, F of
    ``linkage_dynamics(setup.replace(steps_per_period=N))`` and the compiled nonlinear force at its
    N step times.  N must be at least :func:`fivebar.description.setup.min_steps_per_period`.
    """

    def __init__(self, setup: Setup | Params) -> None:
        self.setup = as_setup(setup)
        dyn = linkage_dynamics(self.setup)
        self.n, self.period = dyn.n, float(dyn.period)

    def dynamics(self, N: int):
        """The :class:`~fivebar.model.dynamics.LinkageDynamics` sampled at N steps per period."""
        return linkage_dynamics(self.setup.replace(steps_per_period=int(N)))

    def samples(self, N: int) -> PeriodicSamples:
        dyn = self.dynamics(N)
        sd = dyn.step_data
        compiled = dyn.compiled_nonlinear(sd)
        if compiled is None:
            return PeriodicSamples(sd.M, sd.C, sd.K, sd.F, None)
        force, rdata, idata = compiled
        n = dyn.n

        def nonlinear(U):
            U = np.ascontiguousarray(U, dtype=float)
            f = np.empty((N, n))
            Kt = np.empty((N, n, n))
            for k in range(N):
                force(U[k], k, rdata, idata, f[k], Kt[k], True)
            return f, Kt
        return PeriodicSamples(sd.M, sd.C, sd.K, sd.F, nonlinear)

    def quasi_static(self, H: int) -> NDArray:
        """The Fourier coefficients (2 H + 1, n) of the nonlinear quasi-static deflection
        (:meth:`fivebar.model.dynamics.LinkageDynamics.static_equilibrium` at the samples of H
        harmonics, each from the last): the start of Newton's method (with a thin section the
        stiffening of f_nl is far from the linear solution)."""
        N = samples_for(H)
        dyn = self.dynamics(N)
        U = np.empty((N, dyn.n))
        prev = None
        for k in range(N):
            U[k] = prev = dyn.static_equilibrium(k * dyn.dt, start=prev)
        tau = 2.0 * np.pi * np.arange(N) / N
        h = np.arange(1, H + 1)
        c = np.empty((2 * H + 1, dyn.n))
        c[0] = U.mean(axis=0)
        c[1::2] = 2.0 / N * np.cos(np.outer(h, tau)) @ U
        c[2::2] = 2.0 / N * np.sin(np.outer(h, tau)) @ U
        return c

    def midpoints_mm(self, t: NDArray, U: NDArray) -> NDArray:
        """The transverse midpoint deflections (mm) of the couplers (Figure 6: L2, L3) at times
        t (s) of the displacements U (N, n): the quantity whose accuracy ``tol`` asks."""
        dyn = linkage_dynamics(self.setup)
        r = Response(dyn, t, U, np.zeros_like(U))
        return np.stack([r.midpoint_mm(link) for link in dyn.params.linkage.couplers], axis=-1)


@dataclass
class HarmonicBalanceState(SteadyState):
    """A :class:`~fivebar.analyses.steady.SteadyState` computed by harmonic balance.

    ``method == "harmonic_balance"``; ``periods`` is 0 (no period is integrated);
    ``residual`` is the relative Galerkin residual; ``floquet_multipliers`` are Hill's
    (:meth:`fivebar.numerics.harmonic_balance.HarmonicBalanceSolution.hill`, with at most
    :data:`HILL_MAX_HARMONICS` harmonics), computed on first access; ``accuracy`` (with
    ``tol``) holds the estimate and the harmonics tried; ``solution`` is the
    :class:`~fivebar.numerics.harmonic_balance.HarmonicBalanceSolution` (its Fourier coefficients).
    """

    solution: Any = field(default=None, repr=False)

    @property
    def harmonics(self) -> int:
        """H, the harmonics of the series."""
        return self.solution.harmonics

    def hill(self):
        """The :class:`~fivebar.numerics.harmonic_balance.HillResult` of the orbit."""
        return self.solution.hill(min(self.solution.harmonics, HILL_MAX_HARMONICS))

    @property
    def floquet_multipliers(self) -> NDArray:
        """Floquet multipliers by Hill's method, largest modulus first."""
        return self.hill().multipliers

    @property
    def note(self) -> str:
        """The stability and how the orbit was computed."""
        sol = self.solution
        how = (f"harmonic balance with H = {sol.harmonics} harmonics on N = {sol.samples} samples, "
               f"Hill's method with {self.hill().harmonics}")
        chosen = "" if self.accuracy is None else "; " + self.accuracy["choice"]
        outside = self._outside()
        tail = chosen + ("" if not outside else "; OUTSIDE THE MODEL'S VALIDITY: " + "; ".join(outside))
        rho = float(np.abs(self.floquet_multipliers).max())
        state = "stable" if rho < 1.0 else "unstable"
        return f"{state}: largest Floquet multiplier {rho:.3g} ({how})" + tail

    @property
    def validity(self) -> dict[str, Any]:
        """The checks of :attr:`fivebar.analyses.steady.SteadyState.validity` (stress, deflection,
        speed ratio), with the harmonic-balance error estimate (``"H error estimate"``, the
        relative change of the transverse midpoint deflections of the couplers that one Newton
        step on the residual between the samples predicts) and ``"harmonics"``."""
        out = dict(self._checks())
        out["H error estimate"] = self._estimate()
        out["harmonics"] = self.solution.harmonics
        return out

    def check_accuracy(self) -> dict[str, Any]:
        """The error estimate of the harmonic-balance series (kept in :attr:`validity`)."""
        return {"H error estimate": self._estimate(), "harmonics": self.solution.harmonics}

    def _estimate(self) -> float:
        if self.accuracy is not None:
            return float(self.accuracy["estimate"])
        if "estimate" not in self._cache:
            self._cache["estimate"] = self.solution.estimate(LinkageSystem(self.setup).midpoints_mm)["estimate"]
        return float(self._cache["estimate"])

    def _outside(self) -> list[str]:
        return list(self._checks()["reasons"])


def harmonic_balance_steady_state(setup: Setup | Params, tol: float | None = None,
                                  harmonics: int | None = None, start: Any = None) -> HarmonicBalanceState:
    """The periodic steady state of a set-up by harmonic balance.

    ``fivebar.steady_state(setup, method="harmonic_balance", tol=1e-4)`` calls this.  H starts
    at ``harmonics`` (default the parameter file's ``fourier_terms``, the m of (2.10)); with
    ``tol`` it grows until the estimated error of the transverse midpoint deflections of the
    couplers is at most ``tol`` of their peak-to-peak value
    (:func:`fivebar.numerics.harmonic_balance.harmonic_balance`).  The result is sampled at the set-up's
    S + 1 times of the period (from the Fourier series).

    ``start``: a warm start, explicit (a result depends on its inputs alone): the
    :class:`HarmonicBalanceState` of the same problem at a neighbouring speed, whose Fourier
    coefficients, scaled by the square of the speed ratio (as the inertial load), start Newton's
    method at its number of harmonics (at least ``harmonics``); without it Newton's method starts
    from the nonlinear quasi-static deflection.  With ``tol`` a warm start may end at another H
    than a cold one, both within ``tol``.
    """
    s = as_setup(setup)
    system = LinkageSystem(s)
    H0 = int(s.params.fourier_terms) if harmonics is None else int(harmonics)
    # the samples N = 6 H + 2 must resolve the load of (2.10): at least 2 m + 1
    H0 = max(H0, -(-(min_steps_per_period(s.params) - 2) // 6))
    if start is not None:
        if not isinstance(start, HarmonicBalanceState):
            raise InputTypeError(f"start = {type(start).__name__} is not allowed: give the HarmonicBalanceState of a "
                                 "neighbouring speed (fivebar.steady_state(..., method='harmonic_balance'))")
        if start.dynamics.n != system.n:
            raise InputError(f"start has {start.dynamics.n} DOFs and the set-up {system.n}: give a state of the same "
                             "model (mesh, motors) at another speed")
        H0 = max(H0, start.solution.harmonics)
        guess = start.solution.coefficients * (s.crank_speed_rpm / start.setup.crank_speed_rpm) ** 2
    else:
        guess = None if not s.nonlinear else system.quasi_static(H0)
    sol: HarmonicBalanceSolution = harmonic_balance(system, H0, tol=tol, measure=system.midpoints_mm, start=guess)
    dyn = linkage_dynamics(s)
    t = np.arange(dyn.steps_per_period + 1) * dyn.dt
    acc = None if sol.accuracy is None else dict(sol.accuracy, method="harmonic_balance")
    return HarmonicBalanceState(dyn, t, sol.displacement(t), sol.velocity(t), "harmonic_balance", 0, None,
                                residual=sol.residual, accuracy=acc, solution=sol)
