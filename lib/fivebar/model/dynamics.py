r"""The time-varying equation of motion (2.7) of the linkage over one period of the motion.

.. math::

    \mathbf M(t)\ddot{\mathbf u} + \mathbf C(t)\dot{\mathbf u} + \mathbf K(t)\mathbf u
    + \mathbf f_{nl}(\mathbf u, t) = \mathbf P - \mathbf M(t)\ddot{\mathbf u}_r(t) ,

the kineto-elastodynamic equation: the elastic deflections :math:`\mathbf u` ride on the
rigid motion prescribed by the drive laws and are driven by its inertia
:math:`-\mathbf M\ddot{\mathbf u}_r` (:meth:`fivebar.model.assembly.Model.rigid_acceleration`), and
by the inertia of the rigid motion of the DOFs a joint eliminates where that joint moves (the
pin of a rigid crank, a driven slider: :meth:`fivebar.model.assembly.Model.prescribed_load`);
:math:`\mathbf f_{nl} = -\varepsilon` is the geometric nonlinearity (2.8)
(:mod:`fivebar.model.nonlinear`).

**What is left out, and why.**  The electromagnetic terms of (2.7),
:math:`\mathbf K_0\mathbf u`, :math:`(\mathbf K^e_1 + \mathbf K^e_2)\mathbf e` and
:math:`\mathbf k_0`, act only on the rotors' transverse DOFs :math:`U_1, U_2, U_5, U_6`
(A.4).  With the shape functions of (A.2) those DOFs do not couple to any other through
M, C or K (the crank root does not translate), so the rotor whirl is a separate subsystem
(chapter on electromagnetic coupling) and the linkage's response, Figure 6 included, does not
depend on it.  This module therefore integrates the *linkage subsystem*: every DOF but the
four rotor translations (:attr:`LinkageDynamics.keep`).  The subsystem is exactly periodic
with the period of the crank motion, while the rotor subsystem is forced at the field and
rotor frequencies, which are not commensurate with it.

**Damping** (an assumption: the paper's ratios were "obtained through experiment" and are not
printed).  The parameter file's ``damping_model`` chooses between two forms.  ``"modal"``
(the default): at every instant, every mode of the frozen structure gets the damping ratio
:math:`\zeta`:

.. math::

    \mathbf C(t) = \mathbf M \boldsymbol\Phi\, \operatorname{diag}(2\zeta\omega_r)\,
    \boldsymbol\Phi^\top \mathbf M ,\qquad
    \boldsymbol\Phi^\top\mathbf M\boldsymbol\Phi = \mathbf I,\
    \boldsymbol\Phi^\top\mathbf K\boldsymbol\Phi = \operatorname{diag}(\omega_r^2)

with :math:`\mathbf M, \mathbf K, \boldsymbol\Phi, \omega_r` those of the instant.
``"stiffness"``: Rayleigh damping proportional to the stiffness of the deformation,
:math:`\mathbf C(t) = \beta\mathbf K(t)`, :math:`\beta = 2\zeta/\omega_1` with
:math:`\omega_1` the lowest frozen mode at the initial crank angles: mode :math:`r` gets
:math:`\zeta\,\omega_r/\omega_1`, as the Kelvin-Voigt material damping of the multibody model
(:mod:`fivebar.analyses.multibody`) gives it; the comparisons with that model use it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..numerics.eigen import frozen_modes
from ..errors import ComputationError, InputError, flag
from .assembly import Model, build_model
from ..cache import STORE
from .kinematics import crank_laws, rigid_state
from ..numerics.blas import blas_threads
from ..numerics.systems import PeriodicStepData
from .nonlinear import ElementGeometry, NonlinearForce
from ..description.params import Params, _unresolved_model
from ..description.setup import Setup, as_setup

__all__ = ["LinkageDynamics", "linkage_dynamics", "modal_damping"]

# Kept in the library's one store (:mod:`fivebar.cache`), under these kinds of key:
#: (params without the speed, S, mesh, motors) -> the step data at 1 rad/s: M, C, K and
#: F / Omega^2 at the S step times (a PeriodicStepData of period 2 pi s)
_SAMPLES = "dynamics.samples"
#: ("geometry" or "elements", sample key) -> the nonlinear force's configuration at the S steps
_STEP_TIMES = "dynamics.step_times"


def _model(params: Params, elements_per_link, motors: bool) -> Model:
    """:func:`fivebar.model.assembly.build_model`, built once per parameter set, mesh and motors (the
    model is not changed after it is built; the steady state to a tolerance builds one
    :class:`LinkageDynamics` per S)."""
    return STORE.get(("dynamics.model", params, elements_per_link, motors),
                     lambda: build_model(params, elements_per_link=elements_per_link, motors=motors))


def _nonlinear_force(params: Params, elements_per_link, motors: bool, keep: NDArray) -> NonlinearForce:
    """The model's :class:`~fivebar.model.nonlinear.NonlinearForce` on the DOFs ``keep`` (those of
    the linkage subsystem, which the model fixes), built once per model like it."""
    return STORE.get(("dynamics.nonlinear_force", params, elements_per_link, motors),
                     lambda: NonlinearForce(_model(params, elements_per_link, motors), keep=keep))


def _speed_free(params: Params) -> Params:
    """The parameter set at 1 r/min (the sample cache's key), made once per parameter set."""
    return STORE.get(("dynamics.speed_free", params), lambda: params.replace(crank_speed_rpm=1.0))


def modal_damping(M: NDArray, K: NDArray, zeta: float) -> NDArray:
    """C = M Phi diag(2 zeta omega) Phi^T M for one frozen configuration (N s/m).

    ``M, K`` of shape ``(n, n)``, or stacks ``(..., n, n)`` of configurations (solved
    together); the modes from :func:`fivebar.numerics.eigen.frozen_modes`, the library's one
    eigensolver.
    """
    M, K = np.asarray(M, float), np.asarray(K, float)
    w2, Phi = frozen_modes(M, K)
    MPhi = M @ Phi
    MPhi_w = MPhi * (2.0 * zeta * np.sqrt(np.clip(w2, 0.0, None)))[..., None, :]
    return MPhi_w @ np.swapaxes(MPhi, -1, -2)


class LinkageDynamics:
    """Equation (2.7) of the linkage subsystem, sampled at the S steps of one period.

    ``dyn = LinkageDynamics(setup)`` (or ``linkage_dynamics(setup)``, the same built once and kept);
    ``dyn.step_data`` feeds :func:`fivebar.numerics.newmark.integrate`, and ``dyn`` itself is a
    :class:`fivebar.numerics.systems.SecondOrderSystem` (matrices at any time, nonlinear force).

    Parameters
    ----------
    setup
        The problem, a :class:`fivebar.description.setup.Setup` (its parameters, crank speed, S, motors,
        nonlinearity and mesh), or a Params meaning ``Setup(params)``.
    P
        Optional external force on the kept DOFs, a function of time ``t -> (n,)`` (N, N m).

    Attributes
    ----------
    setup
        The problem.
    steps_per_period
        S, the steps of one period.
    """

    def __init__(self, setup: Setup | Params, P=None) -> None:
        setup = as_setup(setup)
        setup._check_memory()
        elements_per_link, motors, nonlinear = setup.elements_per_link, setup.motors, setup.nonlinear
        speed_free = _speed_free(setup.params)  # the same for every speed: found in the cache
        params = setup.run_params  # (a new speed: the speed alone checked, Params.replace)
        self.setup = setup
        self.params = params
        self.steps_per_period = S = setup.steps_per_period
        self.period = params.period
        self.dt = self.period / S
        # the model (element matrices, mesh) does not depend on the speed: one per geometry
        self.model: Model = _model(speed_free, elements_per_link, bool(motors))
        rotor = {d for i in self.model.motor_dofs for d in self.model.motor_dofs[i][:2]}
        #: indices (into the model's DOFs) of the linkage subsystem
        self.keep = np.array([i for i in range(self.model.n) if i not in rotor])
        self.n = len(self.keep)
        self._P = P
        self._nl = (_nonlinear_force(speed_free, elements_per_link, bool(motors), self.keep)
                    if nonlinear else None)
        t = np.arange(self.steps_per_period) * self.dt
        self.t = t
        self._key = None  # the sample cache's key (None: not cached)
        self._free = None  # the speed-free parameter set whose step times the cache samples
        with blas_threads(1):  # many small dense problems: threaded BLAS only adds overhead
            self.step_data = self._step_data(t, elements_per_link, motors, speed_free)
        # the nonlinear force's view of the configuration at the S step times (the element
        # rotations), so that f_nl(u, t) at a step time does no kinematics: made when first
        # needed, and like the samples the same at every speed
        self._geometry = self._elements = None

    # --- sampling ------------------------------------------------------------------------------
    def crank_angles(self, t: ArrayLike) -> tuple[NDArray, ...]:
        """Crank angles (rad) at times t (s), one array per driven crank (theta1, theta4 for
        the five-bar)."""
        return crank_laws(self.params, t)[0::3]

    def _step_data(self, t: NDArray, elements_per_link, motors, speed_free: Params) -> PeriodicStepData:
        r"""M, C, K, F at the S step times, from the speed-independent cache when it serves.

        At constant crank speed the step times k T / S meet the same crank angles at every
        speed, so M, K, the frozen modes and C do not depend on the speed, and F = -M u_r''
        scales with its square (without gravity, which is not scaled: a set-up with gravity or
        an external force is sampled afresh).  Stiffness damping adds to K the term
        :math:`\beta\mathbf Y_b` of the links' turning frames (:meth:`_bending`), linear in the
        speed (:math:`\beta = 2\zeta/\omega_1` of the frozen structure does not depend on it):
        the cache holds that term at 1 rad/s beside the rest and scales it.  The
        cache key is the parameter set with the speed taken out, S, the mesh and the motors (no
        external force P); it holds the step data at 1 rad/s (read-only arrays), and this
        object's step data is that one at the speed
        (:meth:`~fivebar.numerics.systems.PeriodicStepData.with_force`: the stored M, C, K themselves,
        checked once, and F scaled to the speed; with stiffness damping K is made afresh).
        """
        if self._P is not None or self.params.gravity != 0.0:
            # (gravity: a part of F that does not scale with the speed)
            return PeriodicStepData(*self._sample(t), t0=0.0, period=self.period)
        p = self.params
        key = (_SAMPLES, speed_free, self.steps_per_period, elements_per_link, bool(motors))
        try:
            hash(key)
        except TypeError:  # an unhashable parameter set: no cache
            return PeriodicStepData(*self._sample(t), t0=0.0, period=self.period)
        self._key = key
        self._free = speed_free
        W = p.crank_speed_rad_s
        stiffness = p.damping_model == "stiffness"

        def make():
            hit = None if stiffness else self._nested(key)  # (the halves of a stiffness-damped set: sampled afresh)
            if hit is None:
                M, C, K, F, KY = self._sample(self._free_times(), speed_free, split=True)
                for X in (M, C, K):
                    X.flags.writeable = False
                W0 = speed_free.crank_speed_rad_s
                hit = (M, C, K, F / W0 ** 2)
            unit = PeriodicStepData(*hit, t0=0.0, period=2.0 * np.pi)
            if stiffness:
                unit.speed_stiffness = KY / W0  # beta Y_b at 1 rad/s
                unit.speed_stiffness.flags.writeable = False
            return unit
        unit = STORE.get(key, make)
        if stiffness:
            return PeriodicStepData(unit.M, unit.C, np.ascontiguousarray(unit.K + W * unit.speed_stiffness),
                                    unit.F * W ** 2, t0=0.0, period=self.period)
        return unit.with_force(unit.F * W ** 2, self.period)

    def _free_times(self) -> NDArray:
        """The S step times of one period of the speed-free parameter set (the sample cache's
        key, :func:`_speed_free`): the cached samples are made there, whatever speed asks first,
        so that they, and every result built on them, do not depend on the order of the calls."""
        return np.arange(self.steps_per_period) * (self._free.period / self.steps_per_period)

    def _step_angles(self) -> tuple[NDArray, ...]:
        """The crank angles at the S step times: of the speed-free parameter set where the
        samples are cached (the same angles at every speed, made the same way whatever speed
        asks first), else of this set-up."""
        if self._key is None:
            return self.crank_angles(self.t)
        return crank_laws(self._free, self._free_times())[0::3]

    def _at_step_times(self, what: str, make):
        """``make()``, of a quantity at the S step times that does not depend on the speed,
        kept beside the samples (same key)."""
        if self._key is None:
            return make()
        return STORE.get((_STEP_TIMES, what, self._key), make)

    def _nested(self, key: tuple) -> tuple | None:
        """The samples at S from those at 2 S (every other one) or at S / 2 (computing only the
        S / 2 new ones) when the cache holds them: the step times k T / S are the even ones
        of k T / (2 S), to the last bit (halving is exact), so halving or doubling S, as
        :func:`fivebar.analyses.branches.steady_state` does to reach a tolerance, samples no time twice."""
        S = self.steps_per_period
        fine = STORE.lookup(key[:2] + (2 * S,) + key[3:], touch=False)
        if fine is not None:
            out = tuple(np.ascontiguousarray(X[::2]) for X in (fine.M, fine.C, fine.K, fine.F))
        else:
            coarse = STORE.lookup(key[:2] + (S // 2,) + key[3:], touch=False) if S % 2 == 0 else None
            if coarse is None:
                return None
            M, C, K, F = self._sample(self._free_times()[1::2], self._free)
            out = []
            for old, new in zip((coarse.M, coarse.C, coarse.K, coarse.F),
                                (M, C, K, F / self._free.crank_speed_rad_s ** 2)):
                X = np.empty((S,) + old.shape[1:])
                X[0::2], X[1::2] = old, new
                out.append(X)
        for X in out[:3]:
            X.flags.writeable = False
        return tuple(out)

    def _sample(self, t: NDArray, params: Params | None = None, split: bool = False) -> tuple[NDArray, ...]:
        r"""M, C, K, F at the times ``t`` of ``params`` (default this set-up's; the cache samples
        the speed-free set, whose matrices are the same and whose F scales with the speed).
        ``split=True`` gives (M, C, K, F, KY): K without the stiffness damping's term
        :math:`\beta\mathbf Y_b`, linear in the speed, and that term (None with modal damping)."""
        params = self.params if params is None else params
        laws = crank_laws(params, t)
        state = rigid_state(params, *laws)
        M, K = self.model.matrices(*laws[0::3])
        k = self.keep
        # contiguous (the fancy index leaves a transposed layout), as the compiled loop reads them
        M, K = (np.ascontiguousarray(X[..., k[:, None], k[None, :]]) for X in (M, K))
        ur = self.model.rigid_acceleration(state)[..., k]
        F = np.ascontiguousarray(-np.einsum("...ij,...j->...i", M, ur))
        extra = self.model.prescribed_load(state)[..., k]  # eliminated DOFs that move: a rigid crank's pin, a driven slider
        if np.any(extra):
            F = np.ascontiguousarray(F + extra)
        if self._P is not None:
            F = F + np.array([np.asarray(self._P(ti), float) for ti in np.atleast_1d(t)]).reshape(F.shape)
        KY = None
        if params.damping_model == "stiffness":
            beta = self.stiffness_damping_time
            Kb, Yb = (X[..., k[:, None], k[None, :]] for X in self._bending(laws, state))
            C = np.ascontiguousarray(beta * Kb)
            KY = beta * Yb
            if not split:
                K = np.ascontiguousarray(K + KY)
        else:
            try:
                C = modal_damping(M, K, params.damping_ratio)
            except ComputationError as exc:
                raise _unresolved_model(params, exc) from None
        return (M, C, K, F, KY) if split else (M, C, K, F)

    def _bending(self, laws, state) -> tuple[NDArray, NDArray]:
        """The stiffness of the bending (and of the motor shafts) ``Kb`` and ``Yb = sum_e R_e^T
        K_e dR_e/dt`` (..., n, n), ``K_e`` an element's bending stiffness and ``R_e`` (local <-
        global) its frame, turning at its link's angular speed: Kelvin-Voigt damping of the
        deformation rate ``R_e u' + R_e' u`` is ``beta (Kb u' + Yb u)``."""
        m = self.model
        shape = np.shape(laws[0])
        Kb = np.zeros(shape + (m.n, m.n))
        Yb = np.zeros(shape + (m.n, m.n))
        bend = np.array([1, 2, 3, 5, 6, 7])
        for el, beta in zip(m.elements, m.element_angles(state.angle)):
            beta = np.broadcast_to(beta, shape)
            R = m._rotations(beta, el.frames)
            dR = m._rotations(beta, el.frames, derivative=True)  # d/dbeta of [[c, s], [-s, c]]
            dR *= np.broadcast_to(state.omega[el.link], shape)[..., None, None]
            Ke = np.zeros((8, 8))
            Ke[np.ix_(bend, bend)] = m.Ke[el.link][np.ix_(bend, bend)]
            keep = [i for i, dof in enumerate(el.dofs) if dof >= 0]
            g = np.array([el.dofs[i] for i in keep])
            RkT = np.swapaxes(R[..., :, keep], -1, -2)
            Kb[..., g[:, None], g[None, :]] += RkT @ Ke @ R[..., :, keep]
            Yb[..., g[:, None], g[None, :]] += RkT @ Ke @ dR[..., :, keep]
        for i, idx in m.motor_dofs.items():
            g = np.array(idx)
            Kb[..., g[:, None], g[None, :]] += m.Km[i]
        return Kb, Yb

    @property
    def stiffness_damping_time(self) -> float:
        """The damping time beta (s) of the stiffness-proportional damping, 2 zeta / omega_1.

        omega_1 is the lowest frozen mode at the initial crank angles (those of the description's
        drive laws at t = 0: theta1_0 and theta4_0 of the five-bar), as in the definition of the
        multibody model's Kelvin-Voigt damping time
        (:func:`fivebar.analyses.multibody.multibody_steady_state`).
        """
        p, k = self.params, self.keep
        M, K = self.model.matrices(*(float(a[0]) for a in self.crank_angles(np.zeros(1))))
        try:
            w2 = frozen_modes(M[np.ix_(k, k)], K[np.ix_(k, k)])[0]
        except ComputationError as exc:
            raise _unresolved_model(p, exc) from None
        return 2.0 * p.damping_ratio / float(np.sqrt(np.min(w2)))

    # --- SecondOrderSystem protocol ---------------------------------------------------------------
    def matrices(self, t: float) -> tuple[NDArray, NDArray, NDArray]:
        """(M, C, K) of the linkage subsystem at time t (s)."""
        M, C, K, _ = self._sample(np.asarray(float(t)))
        return M, C, K

    def force(self, t: float) -> NDArray:
        """Right-hand side P - M u_r'' at time t (s)."""
        return self._sample(np.asarray(float(t)))[3]

    @property
    def nonlinear(self):
        """``(u, t) -> (f_nl, K_t)`` on the kept DOFs, or None when the model is linear."""
        if self._nl is None:
            return None
        return self._nonlinear

    def _nonlinear(self, u: NDArray, t: float) -> tuple[NDArray, NDArray]:
        return self._nl.evaluate(np.asarray(u, float), self.nonlinear_geometry(t))

    def compiled_nonlinear(self, step_data: PeriodicStepData):
        """The nonlinear force for the compiled time loop (the optional member of
        :class:`fivebar.numerics.systems.SecondOrderSystem`): ``(force, rdata, idata)`` of
        :meth:`fivebar.model.nonlinear.NonlinearForce.compiled`, sampled at the S step times; None when
        the model is linear or ``step_data`` does not sample this model's period at its step
        times (then the Python loop serves, with ``nonlinear``).
        """
        sd = step_data
        if (self._nl is None or sd is None or sd.steps != self.steps_per_period or sd.t0 != 0.0
                or abs(sd.period - self.period) > 1e-12 * self.period):
            return None
        if self._elements is None:
            self._elements = self._at_step_times(
                "elements", lambda: self._nl.compiled(*self._step_angles()))
        return self._elements

    def nonlinear_geometry(self, t: float) -> ElementGeometry:
        """The configuration at time t (s) as the nonlinear force sees it.

        At the step times ``k dt`` (modulo the period) it is looked up from the S instants
        sampled at construction; at any other time it is computed from the crank angles.
        """
        if self._nl is None:
            raise InputError("the model is linear (nonlinear=False): it has no nonlinear force")
        x = float(t) / self.dt
        k = round(x)
        if abs(x - k) <= 1e-9 * max(1.0, abs(x)):
            if self._geometry is None:
                self._geometry = self._at_step_times(
                    "geometry", lambda: self._nl.geometry(*self._step_angles()))
            return self._geometry.at(k % self.steps_per_period)
        return self._nl.geometry(*(float(theta) for theta in self.crank_angles(t)))

    # --- helpers ------------------------------------------------------------------------------
    def expand(self, u: ArrayLike) -> NDArray:
        """Kept-DOF vectors (..., n) -> model vectors (..., model.n), zeros on the rotors."""
        u = np.asarray(u, float)
        out = np.zeros(u.shape[:-1] + (self.model.n,))
        out[..., self.keep] = u
        return out

    def quasi_static(self, t: ArrayLike) -> NDArray:
        """Quasi-static deflection K(t)^{-1} F(t) of the linear subsystem (m, rad), (..., n)."""
        _, _, K, F = self._sample(np.asarray(t, float))
        return np.linalg.solve(K, F[..., None])[..., 0]

    def static_equilibrium(self, t: float, max_iter: int = 50, start: ArrayLike | None = None) -> NDArray:
        """Quasi-static deflection of the full subsystem at time t (s): K u + f_nl(u, t) = F.

        For the linear model this is :meth:`quasi_static`.  With the nonlinearity, Newton's
        method with load continuation (the load F raised in steps from 0, each step's Newton
        started on the path's tangent at the last equilibrium, Euler's predictor
        (K + K_t) du/dlam = F: far in the nonlinear range, the 2 mm side at 600 r/min, 3 470
        evaluations of the force against 177 948 started at the last equilibrium itself) and a
        backtracking line search on the residual: with a thin
        section the linear deflection K^-1 F can lie where f_nl is a hundred times F (2 mm
        side at 30 r/min), a start from which the first time step's Newton iteration diverges.
        ``start``: a nearby equilibrium (of a neighbouring time) from which Newton's method is
        tried first, at the full load; the continuation from zero runs if that fails.
        """
        x = float(t) / self.dt
        k = round(x)
        if abs(x - k) <= 1e-9 * max(1.0, abs(x)):  # a step time: the sampled matrices
            K, F = self.step_data.K[k % self.steps_per_period], self.step_data.F[k % self.steps_per_period]
        else:
            _, _, K, F = self._sample(np.asarray(float(t)))
        if self._nl is None:
            return np.linalg.solve(K, F)
        scale = float(np.linalg.norm(F)) + 1e-300

        def residual(u, lam):
            f, Kt = self.nonlinear(u, t)
            return K @ u + f - lam * F, Kt

        u = np.zeros(self.n)
        lam, dlam = 0.0, 0.25
        if start is not None:
            u, dlam = np.array(start, dtype=float), 1.0
            if u.shape != (self.n,) or not np.all(np.isfinite(u)):
                raise InputError(f"start has shape {u.shape}: give a finite vector of the {self.n} kept DOFs")
        slope = None  # du/dlam at the last equilibrium on the load path: the step's predictor
        while lam < 1.0:
            target = min(1.0, lam + dlam)
            v = u.copy() if slope is None else u + (target - lam) * slope
            at = residual(v, target)  # (r, K_t) at v: the accepted trial's, kept for the next iteration
            for _ in range(max_iter):
                r, Kt = at
                rn = float(np.linalg.norm(r))
                if rn <= 1e-12 * scale:
                    break
                dv = np.linalg.solve(K + Kt, r)
                step = 1.0
                while step > 1e-4:  # backtracking: accept a step that lowers the residual
                    trial = v - step * dv
                    at = residual(trial, target)
                    if float(np.linalg.norm(at[0])) < rn:
                        break
                    step *= 0.5
                v = trial
            else:
                rn = float(np.linalg.norm(at[0]))
            if rn <= 1e-9 * scale:
                u, lam = v, target
                dlam = min(2.0 * dlam, 1.0)
                if lam < 1.0:  # the path's tangent, (K + K_t) du/dlam = F: Euler's predictor
                    slope = np.linalg.solve(K + at[1], F)  # (K_t at u = v: kept from its residual)
            elif start is not None:  # the warm start failed: continuation from zero
                u, dlam, start, slope = np.zeros(self.n), 0.25, None, None
            else:
                dlam *= 0.25
                if dlam < 1e-6:
                    raise ComputationError(
                        f"no quasi-static equilibrium at t = {t:.6g} s: the load continuation stalled at "
                        f"{lam:.3g} of the load (residual {rn:.3e} of |F| = {scale:.3e})")
        return u


def linkage_dynamics(setup: Setup, keep: bool = True) -> LinkageDynamics:
    """The :class:`LinkageDynamics` of a set-up, built once and kept in the library's store
    (:mod:`fivebar.cache`): equal set-ups (the scheme aside, which the dynamics do not depend
    on) share one.  ``keep=False``: the stored one if there is one, else built and not stored,
    for a caller that keeps its own (the period map of a continuation, nearly every period of
    which is at a new speed)."""
    key = ("setup.dynamics", setup.params, setup.crank_speed_rpm, setup.steps_per_period, setup.motors,
           setup.nonlinear, setup.elements_per_link)
    if not flag("keep", keep):
        hit = STORE.lookup(key)
        return LinkageDynamics(setup) if hit is None else hit
    return STORE.get(key, lambda: LinkageDynamics(setup))
