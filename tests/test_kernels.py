"""The compiled time loop (fivebar.numerics._kernels) and the model's compiled force against independent
references.

References: the vectorised numpy nonlinear force (fivebar.model.nonlinear), finite differences of the
compiled force and of the compiled one-period map, numpy's LAPACK solve, the closed-form discrete
solution of the average-acceleration rule for a free oscillator, and the Python time loop (the
same algorithm written with numpy/LAPACK calls, validated against Radau and closed forms in
test_newmark and test_dynamics).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import fivebar.numerics.newmark as nm
from fivebar import load_params
from fivebar.numerics import _kernels as kern
from fivebar.model.dynamics import LinkageDynamics
from fivebar.model.nonlinear import STRAIN_MEASURES, NonlinearForce
from fivebar.analyses.steady import shooting
from fivebar.numerics.newmark import NewtonConvergenceError, integrate
from fivebar.numerics.schemes import HHT, GeneralizedAlpha, Newmark
from fivebar.description.setup import Setup
from fivebar.numerics.systems import PeriodicStepData, System


@pytest.fixture(scope="module")
def dyn():
    return LinkageDynamics(Setup(load_params(), steps_per_period=100))


def _state(dyn, rng, scale=1.0):
    """A deflected state for the force tests: the quasi-static deflection (m, rad, 1/m) times
    a random factor per DOF, amplified so that the nonlinear terms matter (|f_nl| ~ 0.6 % of
    |K u|)."""
    us = dyn.quasi_static(np.array([0.1 * dyn.period]))[0]
    return scale * 50.0 * us * (1 + rng.standard_normal(us.size))


def _start(d, scheme):
    """A state met in use: on the periodic orbit (shooting's), at t = 0."""
    orbit = shooting(d.setup.replace(scheme=scheme))
    r = integrate(d, orbit.u[0], orbit.v[0], 0.0, d.dt, 1, scheme, step_data=d.step_data)
    return orbit.u[0], orbit.v[0], r.a[0]


@pytest.mark.parametrize("measure", STRAIN_MEASURES)
def test_compiled_strain_force_matches_the_vectorised_force(dyn, measure):
    """The model's compiled force, as the compiled loop calls it (step point k, wrapping at S),
    against the vectorised numpy force, for every strain measure (the two implementations of
    one definition)."""
    rng = np.random.default_rng(1)
    nl = NonlinearForce(dyn.model, keep=dyn.keep, strain_measure=measure)
    force, rdata, idata = nl.compiled(*dyn.crank_angles(dyn.t))
    n = dyn.n
    f, K = np.empty(n), np.empty((n, n))
    for k in (0, 7, 23, dyn.steps_per_period + 7):
        u = _state(dyn, rng)
        f_ref, K_ref = nl.evaluate(u, dyn.nonlinear_geometry(k * dyn.dt))
        force(u, k, rdata, idata, f, K, True)
        assert np.linalg.norm(f_ref) > 0
        assert np.allclose(f, f_ref, rtol=0, atol=1e-12 * np.abs(f_ref).max())
        assert np.allclose(K, K_ref, rtol=0, atol=1e-12 * np.abs(K_ref).max())
        f2 = np.empty(n)
        force(u, k, rdata, idata, f2, K, False)  # force only
        assert np.array_equal(f2, f)


def test_compiled_tangent_is_the_derivative_of_the_compiled_force(dyn):
    rng = np.random.default_rng(2)
    force, rdata, idata = dyn.compiled_nonlinear(dyn.step_data)
    n = dyn.n
    u = _state(dyn, rng)
    K = np.empty((n, n))
    force(u, 3, rdata, idata, np.empty(n), K, True)
    fp, fm, dummy = np.empty(n), np.empty(n), np.empty((n, n))
    for j in range(n):
        h = 1e-4 * max(abs(u[j]), 1e-9)
        e = np.zeros(n)
        e[j] = h
        force(u + e, 3, rdata, idata, fp, dummy, False)
        force(u - e, 3, rdata, idata, fm, dummy, False)
        col = (fp - fm) / (2 * h)
        assert np.allclose(K[:, j], col, rtol=0, atol=1e-6 * np.abs(K[:, j]).max() + 1e-300)


def test_lu_matches_lapack_and_flags_a_singular_matrix():
    rng = np.random.default_rng(3)
    n = 26
    A = rng.standard_normal((n, n)) * np.logspace(0, 6, n)[None, :]  # wide column scales
    b = rng.standard_normal(n)
    B = rng.standard_normal((n, 7))
    LU, piv = A.copy(), np.empty(n, np.int64)
    dmin, dmax = kern.lu_factor(LU, piv)
    assert not kern.singular(dmin, dmax)
    x = b.copy()
    kern.lu_solve(LU, piv, x)
    X = B.copy()
    kern.lu_solve_matrix(LU, piv, X)
    cond = np.linalg.cond(A)
    assert np.linalg.norm(x - np.linalg.solve(A, b)) <= 1e-15 * cond * np.linalg.norm(x)
    assert np.linalg.norm(X - np.linalg.solve(A, B)) <= 1e-15 * cond * np.linalg.norm(X)
    S = A.copy()
    S[:, 5] = S[:, 2]  # rank deficient
    assert kern.singular(*kern.lu_factor(S, piv))
    S[0, 0] = np.nan
    assert kern.singular(*kern.lu_factor(S, piv))


@pytest.mark.parametrize("scheme", [Newmark(), HHT(-0.1), GeneralizedAlpha(0.7)],
                         ids=["newmark", "hht", "galpha"])
@pytest.mark.parametrize("newton", ["full", "modified"])
@pytest.mark.parametrize("nonlinear", [False, True], ids=["linear", "nonlinear"])
def test_compiled_linkage_period_matches_the_python_loop(scheme, newton, nonlinear, monkeypatch):
    d = LinkageDynamics(Setup(load_params(), steps_per_period=100, nonlinear=nonlinear))
    u0, v0, _ = _start(d, scheme)
    sens = "uva" if not scheme.is_newmark else "uv"
    kw = dict(step_data=d.step_data, newton=newton, sensitivity=sens)
    # 1.5 periods: exercises the wrap of the step data (a start inside the period is
    # test_newmark's test_step_data_matches_direct_evaluation)
    args = (d, u0, v0, 0.0, d.dt, 150, scheme)
    monkeypatch.setattr(nm, "_USE_KERNELS", False)
    ref = integrate(*args, **kw)
    monkeypatch.setattr(nm, "_USE_KERNELS", True)
    calls = []
    monkeypatch.setattr(nm, "_march_python", lambda *a, **k: calls.append(1))
    res = integrate(*args, **kw)
    assert not calls  # the compiled loop served
    # equal to round-off: the step tangent has condition number ~2e7 (curvature DOFs) and the
    # random start excites undamped stiff modes, so LAPACK's and the kernel's LU (same
    # algorithm, different operation order) part at ~1e-16 x 2e7 x steps
    assert np.abs(res.u - ref.u).max() <= 1e-8 * np.abs(ref.u).max()
    assert np.abs(res.v - ref.v).max() <= 1e-8 * np.abs(ref.v).max()
    assert np.abs(res.iterations - ref.iterations).sum() <= 2
    # the monodromy, block by block (its blocks differ by orders of magnitude)
    n = d.n
    for i in range(ref.monodromy.shape[0] // n):
        for j in range(ref.monodromy.shape[1] // n):
            R = ref.monodromy[i * n:(i + 1) * n, j * n:(j + 1) * n]
            C = res.monodromy[i * n:(i + 1) * n, j * n:(j + 1) * n]
            assert np.linalg.norm(C - R) <= 1e-7 * np.linalg.norm(R)
    # a stored-last run ends in the same state
    last = integrate(*args, step_data=d.step_data, newton=newton, store="last")
    assert np.array_equal(last.u[-1], res.u[-1]) and last.t[-1] == pytest.approx(res.t[-1])


@pytest.mark.parametrize("scheme", [Newmark(), GeneralizedAlpha(0.8)], ids=["newmark", "galpha"])
def test_compiled_monodromy_matches_finite_differences(dyn, scheme):
    """Columns of the one-period sensitivity of the nonlinear compiled map against central
    differences of that map."""
    n = dyn.n
    u0, v0, a_start = _start(dyn, scheme)
    sens = "uv" if scheme.is_newmark else "uva"
    kw = dict(step_data=dyn.step_data, store="last", rtol=1e-12, xtol=1e-15, max_iter=50)
    a0 = None if sens == "uv" else a_start
    res = integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps_per_period, scheme, sensitivity=sens, a0=a0, **kw)
    Phi = res.monodromy

    def final(u, v, a):
        r = integrate(dyn, u, v, 0.0, dyn.dt, dyn.steps_per_period, scheme, a0=a, **kw)
        x = [r.u[-1], r.v[-1]] + ([] if sens == "uv" else [r.a[-1]])
        return np.concatenate(x)

    for col in (0, 4, 11, n + 2, n + 9):
        x0 = [u0.copy(), v0.copy()] + ([] if a0 is None else [a0.copy()])
        blk, i = divmod(col, n)
        h = 1e-5 * max(np.abs(x0[blk]).max(), 1e-6)
        xp = [x.copy() for x in x0]
        xm = [x.copy() for x in x0]
        xp[blk][i] += h
        xm[blk][i] -= h
        fp = final(xp[0], xp[1], None if a0 is None else xp[2])
        fm = final(xm[0], xm[1], None if a0 is None else xm[2])
        fd = (fp - fm) / (2 * h)
        for b in range(Phi.shape[0] // n):  # each block row (u, v, a) in its own units
            rows = slice(b * n, (b + 1) * n)
            exact, approx = Phi[rows, col], fd[rows]
            assert np.linalg.norm(approx - exact) <= 1e-5 * np.linalg.norm(Phi[rows], 2), (col, b)


def test_compiled_free_oscillator_follows_the_closed_form(monkeypatch):
    """Average acceleration on u'' + w^2 u = 0 is the Cayley map: a rotation of (u, v/w) by
    2 atan(w dt / 2) per step, exactly (a time-invariant System: the compiled loop serves)."""
    w, dt, N = 3.0, 0.37, 400
    calls = []
    monkeypatch.setattr(nm, "_march_python", lambda *a, **k: calls.append(1))
    res = integrate(System([[1.0]], [[0.0]], [[w * w]]), [1.0], [0.0], 0.0, dt, N)
    assert not calls
    phase = 2 * math.atan(w * dt / 2) * np.arange(N + 1)
    assert np.abs(res.u[:, 0] - np.cos(phase)).max() < 1e-12
    assert np.abs(res.v[:, 0] + w * np.sin(phase)).max() < 1e-11


def test_compiled_errors_name_the_step(dyn):
    u0 = _state(dyn, np.random.default_rng(6), scale=3.0)
    with pytest.raises(NewtonConvergenceError, match=r"did not converge in step 1 .*max_iter=1"):
        integrate(dyn, u0, np.zeros(dyn.n), 0.0, dyn.dt, 5, step_data=dyn.step_data, max_iter=1,
                  rtol=1e-15, xtol=0.0)
    Z = np.zeros((2, 2))
    with pytest.raises(NewtonConvergenceError, match="singular"):
        integrate(System(Z, Z, Z), [1.0, 0.0], [0.0, 0.0], 0.0, 0.1, 3, a0=[0.0, 0.0])


@pytest.mark.parametrize("scheme", [Newmark(), GeneralizedAlpha(0.8)], ids=["newmark", "galpha"])
@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_directions_give_the_monodromy_products(dyn, scheme, compiled, monkeypatch):
    """Propagating m directions returns the full monodromy times them (both loops)."""
    monkeypatch.setattr(nm, "_USE_KERNELS", compiled)
    u0, v0, _ = _start(dyn, scheme)
    sens = "uv" if scheme.is_newmark else "uva"
    kw = dict(step_data=dyn.step_data, store="last", sensitivity=sens)
    full = integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps_per_period, scheme, **kw).monodromy
    X = np.random.default_rng(7).standard_normal((full.shape[1], 3))
    part = integrate(dyn, u0, v0, 0.0, dyn.dt, dyn.steps_per_period, scheme, directions=X, **kw).monodromy
    assert part.shape == (full.shape[0], 3)
    n = dyn.n
    ref = full @ X
    for b in range(full.shape[0] // n):
        rows = slice(b * n, (b + 1) * n)
        # round-off: the acceleration block carries 1/(beta dt^2) ~ 4e4 and the tangent's
        # condition number ~2e7
        assert np.linalg.norm(part[rows] - ref[rows]) <= 1e-8 * np.linalg.norm(ref[rows])
    with pytest.raises(ValueError, match="directions has shape"):
        integrate(dyn, u0, v0, 0.0, dyn.dt, 2, scheme, directions=X[:5], **kw)


def test_python_loop_serves_where_the_kernels_cannot(dyn, monkeypatch):
    """Step data that do not sample the model's own step times (here S = 20 instead of 100),
    and a nonlinear force given as a Python function, take the Python loop."""
    calls = []
    real = nm._march_python

    def spy(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(nm, "_march_python", spy)
    other = PeriodicStepData(dyn.step_data.M[::5], dyn.step_data.C[::5], dyn.step_data.K[::5],
                                dyn.step_data.F[::5], t0=0.0, period=dyn.period)
    assert dyn.compiled_nonlinear(other) is None
    integrate(dyn, np.zeros(dyn.n), np.zeros(dyn.n), 0.0, other.dt, 3, step_data=other)
    assert calls == [1]
    cubic = System(np.eye(2), np.zeros((2, 2)), np.eye(2), nonlinear=lambda u: (u**3, np.diag(3 * u**2)))
    integrate(cubic, [0.1, 0.0], [0.0, 0.0], 0.0, 0.1, 3)
    assert calls == [1, 1]


@pytest.mark.parametrize("scheme", [Newmark(), HHT(-0.1), GeneralizedAlpha(0.7)],
                         ids=["newmark", "hht", "galpha"])
def test_compiled_generic_system_matches_the_python_loop(scheme, monkeypatch):
    """A generic linear system (not the linkage): the compiled loop on the time-invariant
    System and the Python loop on the same matrices given as functions of time, with the
    sensitivity, agree to round-off."""
    rng = np.random.default_rng(11)
    n = 5
    A = rng.standard_normal((n, n))
    M, K = A @ A.T / n + np.eye(n), 30.0 * (A.T @ A / n + np.eye(n))
    C = 0.01 * K
    F = lambda t: np.sin(3 * t) * np.arange(1, n + 1)  # noqa: E731
    u0, v0 = np.linspace(1.0, -1.0, n), np.zeros(n)
    calls = []
    real = nm._march_python
    monkeypatch.setattr(nm, "_march_python", lambda *a, **k: (calls.append(1), real(*a, **k)))
    sens = "uv" if scheme.is_newmark else "uva"
    a = integrate(System(M, C, K, force=F), u0, v0, 0.0, 0.01, 300, scheme, sensitivity=sens)
    assert not calls  # compiled
    b = integrate(System(lambda t: M, lambda t: C, lambda t: K, force=F), u0, v0, 0.0, 0.01, 300,
                  scheme, sensitivity=sens)
    assert calls == [1]  # Python
    assert np.abs(a.u - b.u).max() <= 1e-12 * np.abs(a.u).max()
    assert np.abs(a.monodromy - b.monodromy).max() <= 1e-12 * np.abs(a.monodromy).max()


class _CubicSprings(System):
    """u'' + c u' + K(t) u + k3 u^3 = F(t) with the cubic force also given compiled, in the
    form the compiled loop takes (``compiled_nonlinear``): a user's nonlinear model, not the
    beam's."""

    def __init__(self, k3, force):
        n = k3.size
        self.k3 = k3
        super().__init__(np.eye(n), 0.05 * np.eye(n), lambda t: np.diag(2.0 + np.cos(2 * t) * np.ones(n)),
                         force=force, nonlinear=lambda u: (k3 * u**3, np.diag(3 * k3 * u**2)))

    def compiled_nonlinear(self, step_data):
        return _CUBIC, self.k3.copy(), np.zeros(1, np.int64)


def _cubic(u, k, rdata, idata, f, Kt, tangent):
    for i in range(u.size):
        f[i] = rdata[i] * u[i] ** 3
    if tangent:
        for i in range(u.size):
            for j in range(u.size):
                Kt[i, j] = 3.0 * rdata[i] * u[i] ** 2 if i == j else 0.0


_CUBIC = __import__("numba").njit(kern.FORCE_SIG)(_cubic)


@pytest.mark.parametrize("scheme", [Newmark(), GeneralizedAlpha(0.8)], ids=["newmark", "galpha"])
@pytest.mark.parametrize("newton", ["full", "modified"])
def test_a_users_compiled_force_drives_the_compiled_loop(scheme, newton, monkeypatch):
    """The compiled loop calls whatever force the system hands it: a cubic spring written by a
    user (no beam) gives the Python loop's march with the same force as a Python function, to
    round-off, with the sensitivity; a broken compiled force (twice the force) is caught."""
    sysm = _CubicSprings(np.array([4.0, 1.0, 9.0]), lambda t: np.sin(2 * t) * np.array([1.0, 0.5, -0.3]))
    S = 60
    sd = PeriodicStepData.from_system(sysm, 0.0, np.pi, S)
    u0, v0 = np.array([0.3, -0.2, 0.1]), np.zeros(3)
    sens = "uv" if scheme.is_newmark else "uva"
    kw = dict(step_data=sd, newton=newton, sensitivity=sens, max_iter=50)
    calls = []
    real = nm._march_python
    monkeypatch.setattr(nm, "_march_python", lambda *a, **k: (calls.append(1), real(*a, **k)))
    res = integrate(sysm, u0, v0, 0.0, sd.dt, 2 * S + 7, scheme, **kw)
    assert not calls
    monkeypatch.setattr(nm, "_USE_KERNELS", False)
    ref = integrate(sysm, u0, v0, 0.0, sd.dt, 2 * S + 7, scheme, **kw)
    assert calls == [1]
    assert np.abs(res.u - ref.u).max() <= 1e-12 * np.abs(ref.u).max()
    assert np.abs(res.monodromy - ref.monodromy).max() <= 1e-10 * np.abs(ref.monodromy).max()
    assert np.abs(res.u).max() > 0.1  # a real motion, the cubic term at work
    monkeypatch.setattr(nm, "_USE_KERNELS", True)
    wrong = _CubicSprings(sysm.k3, sysm._force)
    wrong.compiled_nonlinear = lambda sd: (_CUBIC, 2.0 * sysm.k3, np.zeros(1, np.int64))
    bad = integrate(wrong, u0, v0, 0.0, sd.dt, 2 * S + 7, scheme, **kw)
    assert np.abs(bad.u - ref.u).max() > 1e-3 * np.abs(ref.u).max()


@pytest.mark.slow
def test_a_fresh_process_loads_the_compiled_loop_from_the_cache(tmp_path):
    """The loop takes the force as a first-class function; its explicit signature keeps the
    cached loop valid in a new process: a second process compiles nothing (numba's own
    counters), for the loop, a piece of the step called by the Python loop and the beam's force.  (Typed by the dispatcher
    it is given, the loop would miss the cache in every process.)"""
    import glob
    import os
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    from numba.core import caching

    lib = Path(nm.__file__).parents[1]
    own = tmp_path / "numba"
    for name in ("numerics/_kernels", "model/_nonlinear_kernel"):  # a copy of the worktree's cache, if any
        folder, name = (lib / name).parent, (lib / name).name
        target = own / caching._CacheLocator.get_suitable_cache_subpath(str(folder / f"{name}.py"))
        target.mkdir(parents=True, exist_ok=True)
        for f in glob.glob(str(folder / "__pycache__" / f"{name}.*.nb[ic]")):
            shutil.copy(f, target)
    code = ("import json, numpy as np\n"
            "import fivebar.numerics.newmark as nm\n"
            "from fivebar.numerics.systems import System\n"
            "from fivebar import Setup, load_params\n"
            "from fivebar.model.dynamics import LinkageDynamics\n"
            "from fivebar.numerics._jitcache import import_cached\n"
            "for nonlinear in (False, True):\n"
            "    d = LinkageDynamics(Setup(load_params(), steps_per_period=100, nonlinear=nonlinear))\n"
            "    nm.integrate(d, np.zeros(d.n), np.zeros(d.n), 0.0, d.dt, 3, step_data=d.step_data,\n"
            "                 sensitivity=True)\n"
            "cubic = System(np.eye(2), np.eye(2), np.eye(2), nonlinear=lambda u: (u**3, np.diag(3 * u**2)))\n"
            "nm.integrate(cubic, [0.1, 0.0], [0.0, 0.0], 0.0, 0.1, 3)  # the Python loop\n"
            "k, f = nm._kernels(), import_cached('fivebar.model._nonlinear_kernel')\n"
            "out = {}\n"
            "for name, disp in [('march', k.march), ('predict', k.predict), ('force', f.force)]:\n"
            "    s = disp.stats\n"
            "    out[name] = [sum(s.cache_hits.values()), sum(s.cache_misses.values())]\n"
            "print(json.dumps(out))\n")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(own))
    env.pop("NUMBA_CACHE_LOCATOR_CLASSES", None)
    runs = []
    for _ in range(2):
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                           timeout=1500)
        assert r.returncode == 0, r.stderr
        runs.append(__import__("json").loads(r.stdout.splitlines()[-1]))
    for name, (hits, misses) in runs[1].items():
        assert hits >= 1 and misses == 0, (name, runs)


def _duffing(k3=0.5, zeta=0.05, amp=0.8, omega=1.3):
    """A forced, damped Duffing oscillator u'' + 2 zeta u' + u + k3 u^3 = amp cos(omega t): a
    generic system with a Python callback (the Python loop serves it)."""
    return System([[1.0]], [[2.0 * zeta]], [[1.0]], force=lambda t: [amp * math.cos(omega * t)],
                  nonlinear=lambda u: (k3 * u**3, np.array([[3.0 * k3 * u[0] ** 2]])))


@pytest.mark.parametrize("scheme", [Newmark(), GeneralizedAlpha(0.8)], ids=["newmark", "galpha"])
def test_newton_starts_from_the_extrapolated_acceleration(scheme, monkeypatch):
    """Newton's first iterate of a nonlinear step extrapolates the acceleration over the steps
    before (an error of order dt^3 on a smooth response, against order dt for a_{n+1} = a_n):
    about one iteration per step instead of two, and the same discrete solution to the Newton
    tolerance.  The reference: the same march from a_n (``guess_order`` 0)."""
    sysm = _duffing()
    args = (sysm, [0.3], [0.0], 0.0, 2 * math.pi / 1.3 / 200, 600, scheme)
    new = integrate(*args, rtol=1e-12)
    monkeypatch.setattr(nm._kernels(), "guess_order", lambda j: 0)
    old = integrate(*args, rtol=1e-12)
    assert np.abs(new.u - old.u).max() <= 1e-10 * np.abs(old.u).max()
    assert np.mean(old.iterations) >= 1.9
    assert np.mean(new.iterations) <= 1.3
    # the compiled loop takes the same rule: the linkage's flexible orbit at 150 r/min, S = 800
    d = LinkageDynamics(Setup(load_params().replace(bending_depth=0.002), crank_speed_rpm=150,
                              motors=False, nonlinear=True))
    orbit = shooting(d.setup)
    r = integrate(d, orbit.u[0], orbit.v[0], 0.0, d.dt, d.steps_per_period, d.setup.scheme,
                  step_data=d.step_data, store="last")
    assert np.mean(r.iterations) <= 1.3  # 1.99 from a_n


def test_a_failed_extrapolation_falls_back_to_a_n(monkeypatch):
    """Where Newton fails from the extrapolated iterate (here made to: the iterate is put out
    of the force's domain), the step is taken again from a_{n+1} = a_n, so the extrapolation
    loses no step that a_n would take: the march equals the one from a_n."""
    sysm = _duffing()
    args = (sysm, [0.3], [0.0], 0.0, 2 * math.pi / 1.3 / 200, 300)
    k = nm._kernels()
    predict = k.predict
    monkeypatch.setattr(k, "guess_order", lambda j: 0)
    ref = integrate(*args, rtol=1e-12)
    monkeypatch.setattr(k, "guess_order", lambda j: min(j - 1, 2))

    def poisoned(c, Mb, x, w, order=0):
        predict(c, Mb, x, w, order)
        if order > 0:
            w[k.U1] = np.nan

    monkeypatch.setattr(k, "predict", poisoned)
    res = integrate(*args, rtol=1e-12)
    assert np.array_equal(res.u, ref.u) and np.array_equal(res.iterations, ref.iterations)


class _StiffCubic(System):
    """u'' + k u + k3 u^3 = 0, stiff (omega dt = 10 at dt = 0.01) and hardening, its compiled
    force for the compiled loop."""

    def __init__(self, k, k3):
        self.k3 = np.array([k3])
        super().__init__(np.eye(1), np.zeros((1, 1)), np.array([[k]]), force=lambda t: np.zeros(1),
                         nonlinear=lambda u: (self.k3 * u**3, np.diag(3 * self.k3 * u**2)))

    def compiled_nonlinear(self, step_data):
        return _CUBIC, self.k3.copy(), np.zeros(1, np.int64)


@pytest.mark.parametrize("scheme", [Newmark(), GeneralizedAlpha(0.8)], ids=["newmark", "galpha"])
def test_a_start_far_from_equilibrium_in_a_stiff_hardening_spring_is_integrated(scheme, monkeypatch):
    """A state far out of equilibrium in a stiff direction (as a shooting or continuation trial
    state can be, in the axial directions of the links) has an initial acceleration of 2e8: the
    predictor of the first step then lies near u = -1e4, from where Newton's iteration on the
    cubic force crawls back by a third per iteration and does not converge in max_iter = 20.
    The step is then taken from u_n (a fallback after the extrapolated iterate and a_n):
    both loops integrate the march, agree to round-off, and equal the march whose every step
    starts from u_n (the step's equation has one root: the same discrete solution).  Without
    the u_n start both loops raise NewtonConvergenceError in step 1 (seen, planted)."""
    sysm = _StiffCubic(1e8, 1e8)
    S = 40
    sd = PeriodicStepData.from_system(sysm, 0.0, 0.4, S)
    kw = dict(step_data=sd, newton="full", rtol=1e-12)
    args = (sysm, [1.0], [0.0], 0.0, sd.dt, S, scheme)
    compiled = integrate(*args, **kw)
    monkeypatch.setattr(nm, "_USE_KERNELS", False)
    python = integrate(*args, **kw)
    assert np.abs(compiled.u - python.u).max() <= 1e-12 * np.abs(python.u).max()
    monkeypatch.setattr(nm._kernels(), "guess_order", lambda j: -1)
    from_u_n = integrate(*args, **kw)
    assert np.abs(python.u - from_u_n.u).max() <= 1e-9 * np.abs(from_u_n.u).max()
    assert np.all(np.abs(python.u) <= 1.0 + 1e-9)  # no spurious growth: the energy is bounded by the start's
