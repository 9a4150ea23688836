"""The benchmarks behind the Performance page run on the library as it is.

``benchmarks/bench_story.py`` had stopped running without anyone noticing: from 2026-12-03
``multibody_steady_state`` refused the ``tol = inf`` its Exudyn ladder passed, and a Params alone
came to mean the nonlinear set-up, whose sweep over 100-3600 r/min fails past the divergence of
the lowest mode (errata E28); the page went on showing the figures of an older library.  Here the
sections the page reads run in their quick form, and their JSON holds what the page reads.  No
time is asserted (the machine may be shared): only that each runs and answers the question.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.slow


def _run(*args: str) -> dict:
    out = subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-4000:]
    return json.loads(out.stdout)


def test_the_exudyn_comparison_and_the_sweep_of_the_story_benchmark_run():
    pytest.importorskip("exudyn")
    ex = _run("benchmarks/bench_story.py", "--quick", "--only", "exudyn_ms")["exudyn_ms"]
    for speed in ("300rpm", "600rpm"):
        chosen = ex[speed]["exudyn_coarsest_within_1pct"]  # a setting within 1 % was found
        assert chosen["error"] <= 0.01 and chosen["ms"] > 0
        ours = ex[speed]["fivebar_tol_0.01"]
        assert ours["error_vs_S3200"] <= 0.01 and ours["estimate"] <= 0.01
        assert {"first", "new_speed"} <= set(ex[speed]["ratio_exudyn_over_fivebar"])
    sweep = _run("benchmarks/bench_story.py", "--quick", "--only", "sweep_s")["sweep_s"]
    assert sweep["rows"] == sweep["speeds"] == 40
    default = _run("benchmarks/bench_story.py", "--quick", "--only", "sweep_default_s")["sweep_default_s"]
    assert default["rows"] == default["speeds"] == 40 and default["cpu_s"] > 0
    assert default["largest_difference_vs_S1600"] <= 0.01  # S = 800 within 1 % of S = 1600


def test_the_first_call_benchmark_runs_and_its_phases_add_up():
    pytest.importorskip("exudyn")
    out = _run("benchmarks/bench_first_call.py", "--repeats", "1", "--peer-repeats", "1")
    for speed in ("300rpm", "600rpm"):
        e = out[speed]
        phases = e["phases_ms"]
        assert set(phases) == {"build", "start", "monodromy periods", "plain periods", "Newton step", "estimate",
                               "other"}
        # one run: the phases and the rest are that run's, so they add up to its time
        assert sum(phases.values()) == pytest.approx(e["total_ms"], rel=1e-9)
        assert e["calls"]["build"] >= 2 and e["calls"]["monodromy periods"] >= 1  # S/2 and S
        assert e["budget_ms"] == pytest.approx(e["exudyn"]["ms"] / 3)
        # on the peer's footing: the coarsest fixed S within 1 % of S = 3200, the one before it not
        f = e["same_footing"]
        assert f["S"] == f["ladder"][-1]["S"] and f["error"] <= 0.01
        assert all(row["error"] > 0.01 for row in f["ladder"][:-1])
        assert f["calls"]["estimate"] == 0 and f["calls"]["build"] == 1
        assert sum(f["phases_ms"].values()) == pytest.approx(f["total_ms"], rel=1e-9)
        assert 0 < f["new_speed_ms"] and f["ratio_exudyn_over_new_speed"] == pytest.approx(
            e["exudyn"]["ms"] / f["new_speed_ms"])


def test_the_modal_map_benchmark_runs_both_loops_on_one_problem():
    out = _run("benchmarks/bench_modal_map.py", "--repeats", "1")
    c, py = out["cases"]["compiled"], out["cases"]["python"]
    assert c["continuation_points"] == py["continuation_points"] and len(c["folds"]) == 2
    assert out["fold_difference"] < 1e-9 and out["state_difference_relative"] < 1e-12
    assert set(out["speed_up"]) == {"period_ms", "period_with_monodromy_ms", "continuation_s"}


def test_the_sweep_floor_benchmark_runs_and_its_rows_answer_the_same_question():
    out = _run("benchmarks/bench_sweep_floor.py", "--repeats", "1")
    # from the neighbouring speed's orbit or from the static start: the same orbit, to shooting's tolerance
    for stretch in out["warm_chain"].values():
        assert stretch["speeds"] == 40 and stretch["largest_difference_warm_vs_cold"] < 1e-6
        assert stretch["warm_periods_per_row_mean"] >= 1 and stretch["cold_periods_per_row_mean"] >= 1
    # the step's error falls as S doubles (a second-order scheme), and the file's S = 800 is within 1 %
    err = {S: out["fixed_S"][f"S{S}"]["largest_difference_vs_S1600"] for S in (200, 400, 800)}
    assert err[800] < err[400] < err[200] and err[800] <= 0.01
    for S in (800, 400):
        row, floor = out["cold_rows"][f"S{S}"], out["floor"][f"S{S}"]
        assert row["periods_per_row_mean"] >= 1 and 0 < row["other_ms_per_row_median"] < row["ms_per_row_median"]
        assert floor["sweep_s_on_2_processes"] == pytest.approx(100 * (floor["monodromy_period_ms"] + floor["other_ms"]) / 1e3)
    for case in out["period_ms"].values():  # carrying 2 n directions costs more than the period alone
        assert case["monodromy"] > case["plain"] > 0
