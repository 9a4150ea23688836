"""Sweeps that stop: SIGINT (Ctrl-C) and SIGTERM to a process running a 2-process speed sweep,
or the dataset writer, stop the workers at once, keep the finished points and leave no process.

Each case runs the sweep in a subprocess of its own session (its process group holds the
workers).  The script reports each finished point on stdout (by wrapping
``concurrent.futures.as_completed`` as ``fivebar.analyses.sweep`` sees it); after two the test sends the
signal and then checks: the process ends (within a generous time limit that only catches
"runs the remaining speeds to the end": the measured time is printed), the finished points are
kept (returned in ``SweepInterrupted.results``, or written to ``speed_sweep.partial.csv`` with
an intact checksum), no temporary file is left, and no process of the group survives.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

LIB = str(Path(__file__).resolve().parents[1] / "lib")

#: Every child script starts here.  Ctrl-C as in a terminal, whoever started the tests: a process
#: started in the background of a non-interactive shell inherits SIGINT ignored, and Python then
#: installs no KeyboardInterrupt handler (4 of these tests failed so, for that reason alone, on
#: 2026-12-03).
PRELUDE = textwrap.dedent("""
    import signal; signal.signal(signal.SIGINT, signal.default_int_handler)
    import json, sys, time
    sys.path.insert(0, sys.argv[1])
    import fivebar, fivebar.analyses.sweep as sw
    _real = sw.cf.as_completed
    def _reporting(fs, *a, **k):
        for f in _real(fs, *a, **k):
            print("done", flush=True)
            yield f
    sw.cf.as_completed = _reporting
    params = fivebar.load_params()
""")

SWEEP = PRELUDE + textwrap.dedent("""
    import numpy as np
    from concurrent.futures import ProcessPoolExecutor
    setup = fivebar.Setup(params, steps_per_period=800, nonlinear=False)
    speeds = np.linspace(100.0, 1000.0, 40)
    log = sys.argv[2]

    def _count_points():  # in each worker: every point computed appends a line to the log
        real = sw.sweep_point
        def counted(*a, **k):
            # a floor on the cost of a point, so that the 38 left at the signal cannot all finish
            # before it arrives on a loaded machine (a point itself can take a few ms)
            time.sleep(0.2)
            out = real(*a, **k)
            with open(log, "a") as fh:
                fh.write("point\\n")
            return out
        sw.sweep_point = counted

    with ProcessPoolExecutor(2, initializer=_count_points) as ex:
        try:
            sw.speed_sweep(setup, speeds, executor=ex, progress=False)
            print(json.dumps({"finished": True}), flush=True)
        except sw.SweepInterrupted as exc:
            print(json.dumps({"rows": len(exc.results), "signal": exc.signal,
                              "speeds": exc.results["speed (r/min)"].tolist(),
                              "cached": len(fivebar.cache.STORE.keys(sw._POINTS)), "t": time.monotonic()}), flush=True)
""")

WRITER = PRELUDE + textwrap.dedent("""
    from fivebar.book import datasets
    datasets.write_datasets(sys.argv[2], names=["speed_sweep"])
""")


pytestmark = pytest.mark.slow  # subprocesses and signals: make test runs them, make check does not


def _run_and_signal(code: str, args: list[str], sig: int) -> tuple[subprocess.Popen, list[str], float, int, float]:
    proc = subprocess.Popen([sys.executable, "-c", code, LIB, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    done = 0
    lines = []
    while done < 2:
        line = proc.stdout.readline()
        if not line:
            pytest.fail(f"the sweep ended before the signal: {proc.stderr.read()[-2000:]}")
        lines.append(line)
        done += line.strip() == "done"
    t0 = time.monotonic()
    proc.send_signal(sig)
    try:
        out, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("the sweep did not stop within 120 s of the signal")
    elapsed = time.monotonic() - t0
    lines += out.splitlines()
    print(f"{signal.Signals(sig).name}: stopped {elapsed:.2f} s after the signal")
    return proc, lines, elapsed, done, t0


def _group_is_gone(pgid: int) -> bool:
    for _ in range(50):  # orphaned workers are reaped by init shortly after they exit
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    return False


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_stops_a_two_process_sweep_and_keeps_the_finished_points(sig, tmp_path):
    log = tmp_path / "points.log"
    proc, lines, elapsed, done, t0 = _run_and_signal(SWEEP, [str(log)], sig)
    report = json.loads([ln for ln in lines if ln.startswith("{")][-1])
    assert "finished" not in report, "the sweep ran to the end"
    assert report["signal"] == sig
    assert done <= report["rows"] < 40 and report["cached"] == report["rows"]
    print(f"  SweepInterrupted with {report['rows']} rows {report['t'] - t0:.2f} s after the signal")
    assert _group_is_gone(proc.pid), "a worker process survived"
    computed = log.read_text().count("point")
    # the workers stopped: at most the two points running at the signal finished after it
    assert computed <= report["rows"] + 2, f"{computed} points computed, {report['rows']} kept"
    assert elapsed < 60  # generous: catches only a sweep that runs the remaining speeds



UNCAUGHT = SWEEP.replace("""    try:
        sw.speed_sweep(setup, speeds, executor=ex, progress=False)
        print(json.dumps({"finished": True}), flush=True)
    except sw.SweepInterrupted as exc:""", """    sw.speed_sweep(setup, speeds, executor=ex, progress=False)
    print(json.dumps({"finished": True}), flush=True)
    if False:""").replace("initializer=_count_points", "initializer=_quiet_and_counted").replace(
    "with ProcessPoolExecutor(", textwrap.dedent("""
    def _quiet_and_counted():  # the workers ignore Ctrl-C, as fivebar.analyses.sweep.ignore_sigint makes them
        sw.ignore_sigint()
        _count_points()

    """) + "with ProcessPoolExecutor(")


def test_ctrl_c_on_a_parallel_sweep_ends_with_its_one_line(tmp_path):
    """Issue 36: Ctrl-C in a terminal (SIGINT to the whole process group) on a script whose
    2-process sweep is not caught: what the script leaves on stderr is the one report of
    SweepInterrupted (its traceback, ending in the line that says how many speeds finished), not
    the pool's InvalidStateError traceback from its manager thread, nor a worker's.  The workers
    ignore Ctrl-C (fivebar.analyses.sweep.ignore_sigint, the sweep's advice): the parent stops them.
    (Planted: the futures cancelled from outside before the workers are terminated -> 'Exception
    in thread ... InvalidStateError: CANCELLED' in 3 of 3 runs.)"""
    assert UNCAUGHT != SWEEP
    log = tmp_path / "points.log"
    proc = subprocess.Popen([sys.executable, "-c", UNCAUGHT, LIB, str(log)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    done = 0
    while done < 2:
        line = proc.stdout.readline()
        if not line:
            pytest.fail(f"the sweep ended before the signal: {proc.stderr.read()[-2000:]}")
        done += line.strip() == "done"
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: every process of the group
    try:
        out, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("the sweep did not stop within 120 s of Ctrl-C")
    assert "finished" not in out
    assert "InvalidStateError" not in err and "Exception in thread" not in err, err
    assert err.count("Traceback") == 1, err  # the SweepInterrupted's, no worker's
    last = err.strip().splitlines()[-1]
    assert last.startswith("fivebar.analyses.sweep.SweepInterrupted: speed sweep stopped by SIGINT:"), err
    assert _group_is_gone(proc.pid), "a worker process survived"


@pytest.fixture
def terminal_sigint():
    """This process's Ctrl-C as in a terminal for one test (as PRELUDE does in the children), restored after."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_while_a_point_is_kept_waits_until_it_is_in_the_rows_and_the_store(sig, monkeypatch,
                                                                                     terminal_sigint):
    """The signal that failed CI at stop 27 arrived between a point's row and its entry in the
    store (2 rows returned, 1 cached).  Here it is sent from inside ``STORE.put`` of the first
    point, before the real put runs: the sweep stops after that point, which is in the rows and
    in the store, counted once.  (Planted: without the hold the signal raises inside the put,
    and the row is kept with no entry.)"""
    import fivebar
    import fivebar.analyses.sweep as sw
    from fivebar.cache import STORE

    params = fivebar.load_params()
    setup = fivebar.Setup(params, steps_per_period=200, nonlinear=False)
    fivebar.clear_cache()
    real = STORE.put
    sent = []

    def put(key, value, owner=None):
        if key[0] == sw._POINTS and not sent:
            sent.append(sig)
            os.kill(os.getpid(), sig)  # its Python handler runs before the next line
        real(key, value, owner)

    monkeypatch.setattr(STORE, "put", put)
    with pytest.raises(sw.SweepInterrupted) as info:
        sw.speed_sweep(setup, [100.0, 150.0, 200.0], progress=False)
    assert sent and info.value.signal == sig
    assert len(info.value.results) == 1 and info.value.results["speed (r/min)"].tolist() == [100.0]
    assert len(STORE.keys(sw._POINTS)) == 1
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    fivebar.clear_cache()


def test_sigterm_stops_the_dataset_writer_and_keeps_its_rows(tmp_path):
    from fivebar.book import datasets

    proc, lines, elapsed, done, _ = _run_and_signal(WRITER, [str(tmp_path)], signal.SIGTERM)
    assert proc.returncode != 0
    assert not (tmp_path / "speed_sweep.csv").exists()
    head, df = datasets.read_dataset(tmp_path / "speed_sweep.partial.csv")  # checksum verified
    assert "PARTIAL" in head and "SIGTERM" in head and done <= len(df) < 120
    assert sorted(p.name for p in tmp_path.iterdir()) == ["speed_sweep.partial.csv"]  # no temporary file
    assert _group_is_gone(proc.pid), "a worker process survived"
    assert elapsed < 60


def test_the_dataset_cache_checks_length_and_checksum(tmp_path):
    """A written file cut short, or altered, is not fresh: it is computed again, and reading it
    says it is damaged."""
    from fivebar.book import datasets

    assert datasets.write_datasets(tmp_path, names=["resonance_speeds"])["resonance_speeds"] > 0
    path = tmp_path / "resonance_speeds.csv"
    assert datasets.write_datasets(tmp_path, names=["resonance_speeds"]) == {"resonance_speeds": 0.0}
    text = path.read_text().splitlines(keepends=True)
    for damaged in (text[:5], text[:-1] + [text[-1].replace("1", "2", 1)]):
        path.write_text("".join(damaged))
        with pytest.raises(fivebar_error(), match="damaged"):
            datasets.read_dataset(path)
        assert datasets.write_datasets(tmp_path, names=["resonance_speeds"])["resonance_speeds"] > 0
        datasets.read_dataset(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["resonance_speeds.csv"]


def fivebar_error():
    import fivebar

    return fivebar.FivebarError
