"""Tests of fivebar.analyses.sweep: steady-state amplitude against crank speed, serial and parallel."""

import contextlib
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest

import fivebar
from fivebar.analyses.resonance import resonance_speeds
from fivebar import clear_cache
from fivebar.cache import STORE
from fivebar.analyses.sweep import SweepError, match_peaks, speed_sweep, sweep_peaks

SPEEDS = [100.0, 700.0, 1300.0]


@pytest.fixture(scope="module")
def params():
    return fivebar.load_params()


@pytest.fixture(scope="module")
def serial(params):
    return speed_sweep(fivebar.Setup(params, nonlinear=False), SPEEDS, progress=False, cache=False)


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert list(a.columns) == list(b.columns)
    assert np.allclose(a.to_numpy(float), b.to_numpy(float), rtol=1e-10, atol=0.0)


def test_process_pool_equals_serial(params, serial):
    with ProcessPoolExecutor(max_workers=2) as ex:
        par = speed_sweep(fivebar.Setup(params, nonlinear=False), SPEEDS, executor=ex, progress=False, cache=False)
    _same(par, serial)


@pytest.mark.slow
def test_dask_local_cluster_equals_serial(params, serial):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        par = speed_sweep(fivebar.Setup(params, nonlinear=False), SPEEDS, executor=client.get_executor(), progress=False, cache=False)
    _same(par, serial)


def test_threads_and_cache(params, serial):
    clear_cache()
    with ThreadPoolExecutor(max_workers=2) as ex:
        a = speed_sweep(fivebar.Setup(params, nonlinear=False), SPEEDS[::-1], executor=ex, progress=True)
    _same(a.iloc[::-1].reset_index(drop=True), serial)
    from fivebar.analyses import sweep as module

    assert len(STORE.keys(module._POINTS)) == 3
    b = speed_sweep(fivebar.Setup(params, nonlinear=False), SPEEDS, progress=False)  # served from the cache, in the order asked
    _same(b, serial)
    clear_cache()
    assert not STORE.keys(module._POINTS)


def test_quasi_static_limit(params):
    """At a crawl the dynamic amplification tends to 1 (the response is K^-1 F)."""
    df = speed_sweep(fivebar.Setup(params, nonlinear=False), [5.0], progress=False, cache=False)
    assert df["L2 amplification"].iloc[0] == pytest.approx(1.0, abs=2e-3)
    assert df["L3 amplification"].iloc[0] == pytest.approx(1.0, abs=2e-3)
    assert df["max |multiplier|"].iloc[0] < 1.0


def test_peak_sits_at_the_predicted_superharmonic_resonance(params):
    """2 mm side in the plane: the k = 2 resonance of mode 1 lies where the effective frequency
    (spin softening) puts it, not where the paper's frequency mean (3.3) does."""
    p = params.replace(bending_depth=0.002)
    pred = {}
    for kind in ("effective", "mean"):
        sp = resonance_speeds(p, n_modes=1, frequencies=kind)
        pred[kind] = sp[(sp["type"] == "superharmonic") & (sp["k"] == 2)]["speed (r/min)"].iloc[0]
    speeds = np.linspace(0.9 * pred["effective"], 1.1 * pred["effective"], 11)
    df = speed_sweep(fivebar.Setup(p, nonlinear=False), speeds, progress=False, cache=False)
    i = int(df["L2 amplification"].idxmax())
    peak = df["speed (r/min)"].iloc[i]
    assert 0 < i < len(df) - 1  # an interior maximum
    assert df["L2 amplification"].iloc[i] > 5.0
    assert abs(peak / pred["effective"] - 1) < 0.03
    assert abs(peak / pred["mean"] - 1) > 0.08


def test_sweep_peaks():
    x = np.linspace(0, 10, 201)
    df = pd.DataFrame({"speed (r/min)": x, "a": 1 / np.hypot(1 - (x / 3) ** 2, 0.05) + 0.2 / np.hypot(1 - (x / 7) ** 2, 0.05)})
    pk = sweep_peaks(df, "a")
    assert pk["speed (r/min)"].to_numpy() == pytest.approx([3.0, 7.0], abs=0.06)
    with pytest.raises(SweepError):
        sweep_peaks(df, "b")
    m = match_peaks(df, "a", [3.1, 6.8, 5.0])
    assert m["peak (r/min)"].to_numpy()[:2] == pytest.approx([3.0, 7.0], abs=0.06)
    assert m["offset"].iloc[0] == pytest.approx(3.0 / 3.1 - 1, abs=0.02)
    assert np.isnan(m["peak (r/min)"].iloc[2])  # no interior maximum near 5


@pytest.mark.parametrize(
    "kwargs",
    [
        {"speeds_rpm": [-10.0]},
        {"speeds_rpm": []},
        {"speeds_rpm": [100.0], "links": ("L5",)},
        {"speeds_rpm": [100.0], "direction": "radial"},
        {"speeds_rpm": [100.0], "executor": "dask"},
    ],
)
def test_bad_sweep_input(params, kwargs):
    # SweepError, or the InputError of the library's validation layer (fivebar.errors.checked:
    # a speed must be > 0): both are FivebarErrors and ValueErrors
    with pytest.raises((SweepError, fivebar.errors.InputError)) as info:
        speed_sweep(params, progress=False, **kwargs)
    assert isinstance(info.value, ValueError)


@pytest.mark.slow
@pytest.mark.parametrize("pool", [False, True])
def test_a_speed_whose_steady_state_fails_is_named_and_the_finished_ones_kept(params, pool):
    """At 3600 r/min (motors off, S = 100) the nonlinear linkage has no periodic orbit that
    shooting finds (past the divergence of the lowest mode, errata E28): the sweep ends with
    the steady state's own error, its note naming the speed and what had finished, and the
    finished speed (2000 r/min) is in the store, so the same call at it does not solve again."""
    from fivebar.analyses.steady import SteadyStateError

    clear_cache()
    setup = fivebar.Setup(params, motors=False, steps_per_period=100)
    with contextlib.ExitStack() as stack:
        executor = stack.enter_context(ThreadPoolExecutor(1)) if pool else None
        with pytest.raises(SteadyStateError) as info:
            speed_sweep(setup, [2000.0, 3600.0], progress=False, executor=executor)
    notes = " ".join(getattr(info.value, "__notes__", []))
    assert "at 3600 r/min" in notes and "1 of 2 speeds had finished" in notes and "resumes" in notes
    assert len(STORE.keys("sweep.point")) == 1
