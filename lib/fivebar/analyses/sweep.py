r"""Steady-state amplitude against crank speed: the response side of the Campbell diagram.

For each crank speed :math:`\Omega` the periodic steady state of (2.7) is found by shooting
(:func:`fivebar.analyses.steady.shooting`, Newton on periodicity with the Newmark monodromy matrix,
S steps per period) and the peak-to-peak transverse displacement of the midpoints of L2 and L3
over the period is recorded, with the largest Floquet multiplier (above 1: the orbit is
unstable, e.g. a parametric resonance).

The inertial load grows with :math:`\Omega^2` (at constant crank speed
:math:`\ddot{\mathbf u}_r \propto \Omega^2`), so the raw amplitude mostly shows that growth.  The
*dynamic amplification* divides it by the quasi-static amplitude at the same speed (the
peak-to-peak of :math:`\mathbf K(t)^{-1}\mathbf F(t)`, itself exactly proportional to
:math:`\Omega^2`): it is 1 at low speed and peaks at the resonances that
:mod:`fivebar.analyses.resonance` predicts.

The integrator and S are the set-up's (:class:`fivebar.description.setup.Setup`: the parameter file's
generalised-alpha scheme, errata E26: the paper's average-acceleration rule at S = 100 has an
unstable discrete periodic orbit for this model).  A sweep over many speeds may use a smaller
S to save time (``Setup(params, steps_per_period=100)``: within about 1 % up to 400 r/min),
and the linear model (``Setup(params, nonlinear=False)``): fast, and the resonance positions
do not depend on the amplitude.  The sweep solves the problem it is given: its only own
options are the speeds and what is recorded.

Parallel runs: pass any :class:`concurrent.futures.Executor` (``ProcessPoolExecutor``, or a Dask
cluster's ``client.get_executor()``); ``None`` runs serially.  Results are kept in the
library's store (:mod:`fivebar.cache`, per parameter set, speed and options; emptied by
``fivebar.clear_cache()``).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
import signal
import threading
import warnings
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from tqdm import tqdm

from ..cache import STORE
from ..errors import FivebarError, number
from ..description.params import Params
from ..description.setup import Setup, analysis, as_setup
from ..numerics.blas import one_blas_thread
from .modal import frequencies_along_cycle
from .response import quasi_static
from .orbits import OrbitProblem
from .steady import DEFLECTION_LIMIT, ValidityWarning

__all__ = ["ResonanceBand", "SweepError", "SweepInterrupted", "match_peaks", "resonance_band", "sweep_point",
           "speed_sweep", "sweep_peaks"]

#: the kind of key of a sweep point in the library's store: (kind, params, speed, options)
_POINTS = "sweep.point"


class SweepError(FivebarError, ValueError):
    r"""Bad input to the speed sweep (the message names the value)."""


class SweepInterrupted(KeyboardInterrupt):
    r"""A sweep stopped by Ctrl-C (SIGINT) or SIGTERM; ``.results`` holds the finished rows.

    It derives from :class:`KeyboardInterrupt`, not from :class:`fivebar.errors.FivebarError`: it is the
    user's signal, not an error of the library, and ``except Exception`` must not swallow it.
    The finished rows are also in the in-memory cache, so the same call resumes where it stopped.
    ``signal`` is the signal's number.
    """

    def __init__(self, message: str, results: pd.DataFrame, signal_number: int) -> None:
        super().__init__(message)
        self.results = results
        self.signal = signal_number


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread while a sweep runs."""


class _Signals:
    r"""While a sweep runs in the main thread, SIGTERM raises :class:`_Terminated` (as Ctrl-C
    raises KeyboardInterrupt), so that the workers are stopped and the finished rows kept.

    Inside :meth:`held` (the bookkeeping of a finished point: its row and its entry in the
    store) either signal waits and is raised at the end of the block, so that a point is never
    kept in the rows and not in the store, nor half counted in the store.  A handler the program
    set itself is left alone; the previous handlers are restored after the sweep."""

    def __init__(self) -> None:
        self.holding = False
        self.pending: BaseException | None = None

    @contextlib.contextmanager
    def installed(self):
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        main = os.getpid()

        def handler(signum, frame):
            if os.getpid() != main:  # a worker forked while the handler was set: as by default
                if signum == signal.SIGINT:
                    signal.default_int_handler(signum, frame)
                signal.signal(signum, signal.SIG_DFL)
                os.kill(os.getpid(), signum)
                return
            exc = _Terminated(signum) if signum == signal.SIGTERM else KeyboardInterrupt()
            if self.holding:
                self.pending = self.pending or exc
                return
            raise exc

        defaults = {signal.SIGTERM: signal.SIG_DFL, signal.SIGINT: signal.default_int_handler}
        mine = [sig for sig, default in defaults.items() if signal.getsignal(sig) is default]
        for sig in mine:
            signal.signal(sig, handler)
        try:
            yield self
        finally:
            for sig in mine:
                signal.signal(sig, defaults[sig])

    @contextlib.contextmanager
    def held(self):
        self.holding = True
        try:
            yield
        finally:
            self.holding = False
            if self.pending is not None:
                exc, self.pending = self.pending, None
                raise exc


def _stop_executor(executor: cf.Executor, futures) -> None:
    r"""Cancel the queued ``futures`` and, for a process pool, terminate its worker processes
    now (a running point is not waited for); the pool is shut down without waiting.

    A process pool's futures are not cancelled here but by the pool's own shutdown
    (``cancel_futures=True``), which also drops them from the pool's pending work: a future
    cancelled from outside stays there, and when the terminated workers break the pool, its
    manager thread sets an exception on every pending future, which for a cancelled one raises
    ``InvalidStateError``, printed as a traceback of the thread (CPython 3.11)."""
    procs = list((getattr(executor, "_processes", None) or {}).values())
    queue = getattr(executor, "_call_queue", None)
    if not procs:
        for fut in futures:
            fut.cancel()
    executor.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(1.0)
        if proc.is_alive():
            proc.kill()
            proc.join(1.0)
    # the call queue's feeder thread may be blocked writing to the dead workers' pipe; joined at
    # exit it would hang the process for good (CPython's multiprocessing.Queue): let it go
    if procs and queue is not None and hasattr(queue, "cancel_join_thread"):
        queue.cancel_join_thread()


def ignore_sigint() -> None:
    r"""Initializer of a sweep's worker processes: Ctrl-C in a terminal reaches every process
    of the group; the parent stops the workers, so they ignore it (no tracebacks of theirs)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _check_links(links, direction, linkage) -> tuple[tuple[str, ...], str]:
    """The links and direction of a sweep, checked against the linkage description
    (``links=None``: its couplers, L2 and L3 of the five-bar, Figure 6)."""
    names = tuple(linkage.link_names)
    if links is None:
        links = tuple(linkage.couplers)
    ok = not isinstance(links, str)
    if ok:
        try:
            links = tuple(links)
        except TypeError:
            ok = False
    if not ok or not links or any(k not in names for k in links):
        raise SweepError(f"links = {links!r} is not allowed: give a sequence of some of {list(names)}, "
                         f"e.g. {tuple(linkage.couplers)!r}")
    if direction not in ("transverse", "longitudinal", "chord"):
        raise SweepError(f"direction = {direction!r} is not allowed: use 'transverse', 'longitudinal' or 'chord'")
    return links, direction


@analysis
@one_blas_thread
def sweep_point(
    setup: Setup | Params,
    links: tuple[str, ...] | None = None,
    direction: str = "transverse",
    accuracy: bool = False,
) -> dict[str, float]:
    r"""Steady state of a problem at its crank speed: peak-to-peak midpoint amplitudes and their
    amplification.

    ``sweep_point(setup.replace(crank_speed_rpm=300))``.  Returns a dict with ``speed (r/min)``,
    ``crank frequency (Hz)``, for every link
    ``"<link> p2p (mm)"``, ``"<link> quasi-static p2p (mm)"``, ``"<link> amplification"``,
    ``max |multiplier|`` (largest Floquet multiplier), ``periods`` (shooting cost), and the
    validity of the result (:attr:`fivebar.analyses.steady.SteadyState.validity`): ``peak stress (MPa)``
    (bending, the largest over the links), ``stress / yield`` (the file's ``yield_stress``),
    ``deflection / length`` (midpoint against chord, the largest over the links; the model's
    range is :data:`fivebar.analyses.steady.DEFLECTION_LIMIT`), ``compression / Euler load`` (the
    buckling check, the largest over the links), ``period (s)`` (the drive's period: a
    speed ratio that gives none is refused), ``valid`` (all three within range) and, with
    ``accuracy=True``, ``S error estimate`` (S against 2 S; one more steady state per speed).
    A top-level function, so that it can run in worker processes; it runs with one BLAS thread
    (:mod:`fivebar.numerics.blas`: the small dense problems of a steady state gain nothing from
    more, and the workers of a pool would contend for the cores).
    """
    setup = as_setup(setup)
    crank_speed_rpm = setup.crank_speed_rpm
    links, direction = _check_links(links, direction, setup.params.linkage)
    st = OrbitProblem(setup).steady("shooting", "steady_state")  # the engine's method by name
    quasi = quasi_static(setup)  # K(t)^-1 F(t) at the S steps
    out = {"speed (r/min)": float(crank_speed_rpm), "crank frequency (Hz)": float(crank_speed_rpm) / 60.0}
    for link in links:
        a, q = st.peak_to_peak_mm(link, direction), quasi.peak_to_peak_mm(link, direction)
        out[f"{link} p2p (mm)"] = a
        out[f"{link} quasi-static p2p (mm)"] = q
        out[f"{link} amplification"] = a / q
    out["max |multiplier|"] = float(np.abs(st.floquet_multipliers).max())
    out["periods"] = float(st.periods)
    v = st.validity if accuracy else st._checks()
    out["peak stress (MPa)"] = v["peak bending stress (MPa)"]
    out["stress / yield"] = v["stress / yield"]
    out["deflection / length"] = v["deflection / length"]
    out["compression / Euler load"] = v["compression / Euler load"]
    out["period (s)"] = v["period (s)"]
    out["valid"] = bool(v["valid"])
    if accuracy:
        out["S error estimate"] = (st.check_accuracy()["S error estimate"] if v["S error estimate"] is None
                                   else v["S error estimate"])
    return out


@analysis
def speed_sweep(
    setup: Setup | Params,
    speeds_rpm: ArrayLike,
    *,
    links: Sequence[str] | None = None,
    direction: str = "transverse",
    executor: cf.Executor | None = None,
    progress: bool = True,
    cache: bool = True,
    accuracy: bool = False,
) -> pd.DataFrame:
    r"""Steady-state midpoint amplitude of the links over a range of crank speeds.

    Call forms::

        df = speed_sweep(setup, np.linspace(100, 3600, 200))                # serial
        with ProcessPoolExecutor(2) as ex:
            df = speed_sweep(setup, speeds, executor=ex)                      # processes
        df = speed_sweep(setup, speeds, executor=client.get_executor())      # Dask
        df = speed_sweep(fivebar.Setup(params, nonlinear=False), speeds)     # the linear model

    Parameters
    ----------
    setup : Setup or Params
        The problem (its S, scheme, motors, nonlinearity, mesh; a Params means
        ``Setup(params)``: every setting the parameter file's, nonlinear); its crank speed is
        replaced by each of ``speeds_rpm``.
    speeds_rpm : array_like
        Crank speeds (r/min), positive; both cranks turn at them (``speed_ratio`` applies).
    links : sequence of str
        Links whose midpoint is recorded; ``None``: the description's couplers (the links
        between two pins: L2 and L3 of the five-bar, as Figure 6).
    direction : str
        As :meth:`fivebar.analyses.response.Response.midpoint_mm` ("transverse", "longitudinal", "chord").
    executor : concurrent.futures.Executor, optional
        Runs the speeds in parallel (``submit``); None runs them here, one after the other.
    progress : bool
        Show a tqdm progress bar (on stderr).
    cache : bool
        Reuse and store results in the library's store (:mod:`fivebar.cache`).
    accuracy : bool
        Add the column ``S error estimate`` (each speed solved again at 2 S).

    Returns
    -------
    pandas.DataFrame
        One row per speed, in the order given; columns of :func:`sweep_point`, with the
        validity of each row (``valid`` False where the stress is above yield, the deflection
        past the small-deflection range or a link's compression above its Euler load; one :class:`fivebar.errors.ValidityWarning` then says
        how many rows).

    Raises
    ------
    fivebar.errors.FivebarError
        The error of the first speed whose steady state fails (a
        :class:`fivebar.analyses.steady.SteadyStateError` past the divergence of the lowest
        mode, say), with a note naming that speed and how many had finished; the speeds not
        started are cancelled, and with ``cache`` the finished ones stay in the store, so the
        same call, or one over fewer speeds, resumes from them.
    """
    try:
        x = np.atleast_1d(np.asarray(speeds_rpm, float))
    except (TypeError, ValueError):
        x = np.array([np.nan])
    if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)) or np.any(x <= 0):
        raise SweepError(f"speeds_rpm = {speeds_rpm!r} is not allowed: give positive crank speeds (r/min)")
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise SweepError(f"executor = {executor!r} is not allowed: give a concurrent.futures.Executor or None")
    base = as_setup(setup)
    params = base.params
    links, direction = _check_links(links, direction, params.linkage)
    opts = (links, direction, base.steps_per_period, base.scheme, base.nonlinear, base.motors,
            base.elements_per_link, bool(accuracy))
    key = lambda s: (_POINTS, params, float(s), opts)  # noqa: E731
    point = (links, direction, bool(accuracy))
    results: dict[float, dict[str, float]] = {}
    todo = []
    for s in dict.fromkeys(x.tolist()):
        hit = STORE.lookup(key(s)) if cache else None
        if hit is not None:
            results[s] = hit
        else:
            todo.append(s)
    futures: dict = {}

    def keep(s, row):  # a finished point: its row, and its entry in the store
        results[s] = row
        if cache:
            STORE.put(key(s), row)

    try:
        with _Signals().installed() as signals, \
                tqdm(total=len(todo), disable=not progress, desc="crank speeds", unit="speed") as bar:
            if executor is None:
                for s in todo:
                    try:
                        row = sweep_point(base.replace(crank_speed_rpm=s), *point)
                    except FivebarError as exc:
                        _note_speed(exc, s, len(results), len(x), cache)
                        raise
                    with signals.held():
                        keep(s, row)
                    bar.update()
            else:
                futures = {executor.submit(sweep_point, base.replace(crank_speed_rpm=s), *point): s for s in todo}
                for fut in cf.as_completed(futures):
                    s = futures[fut]
                    try:
                        row = fut.result()
                    except FivebarError as exc:
                        for other in futures:  # the speeds not started: the sweep ends here
                            other.cancel()
                        _note_speed(exc, s, len(results), len(x), cache)
                        raise
                    with signals.held():
                        keep(s, row)
                    bar.update()
    except KeyboardInterrupt as exc:
        if executor is not None:
            _stop_executor(executor, futures)
            for fut, s in futures.items():  # points that finished while stopping
                if s not in results and fut.done() and not fut.cancelled() and fut.exception() is None:
                    keep(s, fut.result())
        signum = signal.SIGTERM if isinstance(exc, _Terminated) else signal.SIGINT
        done = [results[s] for s in x.tolist() if s in results]
        raise SweepInterrupted(
            f"speed sweep stopped by {signal.Signals(signum).name}: {len(done)} of {len(x)} speeds "
            "finished (in .results" + (", and cached: the same call resumes" if cache else "") + ")",
            pd.DataFrame(done), int(signum)) from None
    df = pd.DataFrame([results[s] for s in x.tolist()])
    _warn_invalid(df)
    return df


def _note_speed(exc: FivebarError, speed: float, done: int, total: int, cache: bool) -> None:
    """Add to ``exc``, the failure of one speed's steady state, a note naming the speed and what
    had finished (its type and message unchanged: ``except SteadyStateError`` still catches
    it; the note shows in the traceback)."""
    exc.add_note(f"speed_sweep: at {speed:g} r/min; {done} of {total} speeds had finished"
                 + (", kept in the library's store: the same call resumes from them" if cache else ""))


def _warn_invalid(df: pd.DataFrame) -> None:
    """One ValidityWarning for the rows of a sweep outside the model's validity."""
    if "valid" not in df or df["valid"].all():
        return
    bad = df[~df["valid"].astype(bool)]
    warnings.warn(
        f"{len(bad)} of {len(df)} sweep rows are outside the model's validity (stress above yield, "
        f"deflection past {DEFLECTION_LIMIT:g} of a link's length or compression above a link's Euler load), "
        f"from {bad['speed (r/min)'].min():g} r/min "
        f"(largest stress / yield {bad['stress / yield'].max():.3g}, deflection / length "
        f"{bad['deflection / length'].max():.3g}"
        + (f", compression / Euler load {bad['compression / Euler load'].max():.3g}" if "compression / Euler load" in bad else "")
        + "): see the columns 'valid', 'stress / yield', 'deflection / length' and 'compression / Euler load'",
        ValidityWarning, stacklevel=4)  # (speed_sweep and its analysis wrapper)


class ResonanceBand(NamedTuple):
    """Where a crank harmonic meets the lowest frozen mode (:func:`resonance_band`).

    ``frequencies_hz``: the lowest frozen frequency at the crank angles sampled; ``speeds_rpm``:
    the speeds of the linear sweep across the band; ``pp_mm``: the transverse midpoint
    peak-to-peak of ``link`` there (NaN where no steady state was found); ``peak_rpm``: the speed
    of the largest one; ``harmonic`` and ``link`` as asked."""

    frequencies_hz: NDArray
    speeds_rpm: NDArray
    pp_mm: NDArray
    peak_rpm: float
    harmonic: int
    link: str


@analysis
def resonance_band(setup: Setup | Params, harmonic: int = 2, step_rpm: float = 2.0, angles: int = 72,
                   link: str | None = None) -> ResonanceBand:
    r"""The resonance of the lowest frozen mode with the crank harmonic ``harmonic``, located by
    the linear model's steady state across the band of speeds where they meet.

    ``band = resonance_band(Setup(params, motors=False, steps_per_period=200), harmonic=2)``.

    The lowest frozen frequency :math:`f_1(\theta)` changes along the cycle
    (:func:`fivebar.analyses.modal.frequencies_along_cycle` at ``angles`` crank angles); the
    harmonic :math:`k\Omega/60` meets it between :math:`60\min f_1/k` and
    :math:`60\max f_1/k` r/min.  Across that band, every ``step_rpm``, the linear model's
    periodic steady state (shooting, the set-up's scheme and S, ``nonlinear=False``) gives the
    transverse midpoint peak-to-peak of ``link`` (default the first coupler, L2); the largest
    marks the resonance speed.  The set-up's crank speed is not used.
    """
    s = as_setup(setup)
    harmonic = int(number("harmonic", harmonic, integer=True, low=1, high=1000))
    step_rpm = number("step_rpm", step_rpm, low=1e-6)
    angles = int(number("angles", angles, integer=True, low=4, high=100_000))
    names = s.params.linkage.link_names
    link = s.params.linkage.couplers[0] if link is None else link
    if link not in names:
        raise SweepError(f"link = {link!r} is not allowed: use one of {list(names)}")
    f1 = frequencies_along_cycle(s, np.linspace(0.0, 2 * np.pi, angles + 1)[:-1], n_modes=1)[:, 0]
    speeds = np.arange(np.floor(60 * f1.min() / harmonic), np.ceil(60 * f1.max() / harmonic) + 1.0, step_rpm)
    linear = s.replace(nonlinear=False)
    pp = []
    for p in speeds:
        try:
            pp.append(OrbitProblem(linear.replace(crank_speed_rpm=float(p))).steady("shooting", "steady_state")
                      .peak_to_peak_mm(link))
        except FivebarError:
            pp.append(np.nan)
    pp = np.array(pp)
    if not np.isfinite(pp).any():
        raise SweepError(f"no steady state of the linear model was found at the {speeds.size} speeds of the band "
                         f"{speeds[0]:g}-{speeds[-1]:g} r/min (harmonic = {harmonic})")
    return ResonanceBand(f1, speeds, pp, float(speeds[np.nanargmax(pp)]), harmonic, link)


def sweep_peaks(sweep: pd.DataFrame, column: str, prominence: float = 0.05) -> pd.DataFrame:
    r"""Local maxima of a sweep column (e.g. ``"L2 amplification"``) by prominence.

    ``prominence`` is relative to the column's range.  Returns the rows of the peaks
    (``speed (r/min)`` and the column), highest first.
    """
    if column not in sweep:
        raise SweepError(f"column = {column!r} is not in the sweep: use one of {list(sweep.columns)}")
    from scipy.signal import find_peaks  # here: scipy.signal imports scipy.stats, a second at import

    y = sweep[column].to_numpy(float)
    idx, props = find_peaks(y, prominence=prominence * (np.nanmax(y) - np.nanmin(y)))
    out = sweep.iloc[idx][["speed (r/min)", column]].copy()
    out["prominence"] = props["prominences"]
    return out.sort_values(column, ascending=False).reset_index(drop=True)


def match_peaks(sweep: pd.DataFrame, column: str, speeds: ArrayLike, window: float = 0.06) -> pd.DataFrame:
    r"""The sweep's local maximum near each predicted resonance speed.

    For every predicted speed :math:`\Omega_p` (r/min), the largest value of ``column`` among
    the sweep points within :math:`\Omega_p(1 \pm \text{window})`; it counts as a peak if it is
    an interior maximum of that window (not at its edge).

    Returns
    -------
    pandas.DataFrame
        Columns ``predicted (r/min)``, ``peak (r/min)`` (NaN if no interior maximum),
        ``offset`` (peak / predicted - 1) and ``column`` at the peak.
    """
    if column not in sweep:
        raise SweepError(f"column = {column!r} is not in the sweep: use one of {list(sweep.columns)}")
    x = sweep["speed (r/min)"].to_numpy(float)
    y = sweep[column].to_numpy(float)
    rows = []
    for sp in np.atleast_1d(np.asarray(speeds, float)):
        idx = np.flatnonzero(np.abs(x / sp - 1) <= window)
        peak = val = np.nan
        if idx.size >= 3:
            i = idx[np.argmax(y[idx])]
            if idx[0] < i < idx[-1]:
                peak, val = x[i], y[i]
        rows.append((sp, peak, peak / sp - 1, val))
    return pd.DataFrame(rows, columns=["predicted (r/min)", "peak (r/min)", "offset", column])
