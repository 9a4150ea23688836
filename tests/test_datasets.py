"""The CSV downloads (fivebar.book.datasets): contents against the library, provenance, cache."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import fivebar
from fivebar.book import datasets
from fivebar.model.kinematics import crank_laws
from fivebar.analyses.resonance import linkage_frequencies
from fivebar.analyses.sweep import sweep_point
from fivebar.description.setup import Setup

ROOT = Path(__file__).resolve().parents[1]
CHEAP = ["figure6_curves", "natural_frequencies", "resonance_speeds"]


@pytest.fixture(scope="module")
def params():
    return fivebar.load_params()


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("data")
    cost = datasets.write_datasets(out, names=CHEAP)
    return out, cost


def test_provenance_line_names_version_parameters_and_command(written):
    out, _ = written
    for name in CHEAP:
        head, df = datasets.read_dataset(out / f"{name}.csv")
        assert f"fivebar {fivebar.__version__}" in head
        assert "wang2011.toml sha256 " in head and datasets.DATASETS[name].how in head
        assert len(df) > 0 and not df.isna().any().any()


def test_frequencies_equal_natural_frequencies_at_two_angles(written, params):
    _, df = datasets.read_dataset(written[0] / "natural_frequencies.csv")
    for deg in (0.0, 137.0):
        row = df[df["crank angle AB (deg)"] == deg].iloc[0]
        th1, _, _, th4, _, _ = crank_laws(params, np.radians(deg) / params.crank_speed_rad_s)
        f = fivebar.natural_frequencies(params, float(th1), float(th4), n_modes=6)
        np.testing.assert_allclose(row[[f"f{k} (Hz)" for k in range(1, 7)]].to_numpy(float), f, rtol=1e-8)
        assert row["theta1 (deg)"] == pytest.approx(np.degrees(th1))


def test_figure6_curves_periodic_and_converged(written, params):
    """One steady period: the last sample repeats the first; a solution at half the steps
    (an independent discretisation) gives the same curves to within 1 % of their range."""
    _, df = datasets.read_dataset(written[0] / "figure6_curves.csv")
    assert df["crank angle (deg)"].iloc[0] == 0.0 and df["crank angle (deg)"].iloc[-1] == pytest.approx(360.0)
    coarse = fivebar.steady_state(Setup(params, steps_per_period=datasets.FIGURE6_STEPS // 2))
    for link in ("L2", "L3"):
        for direction in ("transverse", "longitudinal", "chord"):
            y = df[f"{link} {direction} (um)"].to_numpy()
            span = y.max() - y.min()
            assert abs(y[-1] - y[0]) < 1e-6 * span
            np.testing.assert_allclose(y[::2], 1e3 * coarse.midpoint_mm(link, direction), atol=0.01 * span)


def test_resonance_speeds_satisfy_their_conditions(written, params):
    _, df = datasets.read_dataset(written[0] / "resonance_speeds.csv")
    w = linkage_frequencies(params, 3).mean(axis=0) / (2 * np.pi)  # the means (3.3), Hz
    harmonic = df["speed (r/min)"] * df["k"] / 60.0
    np.testing.assert_allclose(harmonic, df["frequency (Hz)"], rtol=1e-8)
    sup = df[df["type"].isin(["primary", "superharmonic"])]
    assert len(sup) > 0
    for _, r in sup.iterrows():
        assert r["frequency (Hz)"] == pytest.approx(w[int(r["mode"]) - 1], rel=1e-8)


def test_speed_sweep_rows_equal_sweep_point(params):
    df = datasets.sweep_table(params, [700.0, 1900.0])
    for _, r in df.iterrows():
        ref = sweep_point(Setup(params, crank_speed_rpm=r["speed (r/min)"], nonlinear=False))
        for key, val in ref.items():
            assert r[key] == pytest.approx(val, rel=1e-9), key


def test_cache_skips_unchanged_and_recomputes_changed_parameters(written, tmp_path):
    out, cost = written
    assert all(c > 0 for c in cost.values())
    assert datasets.write_datasets(out, names=CHEAP) == {n: 0.0 for n in CHEAP}
    # a changed parameter file changes the hash: the files are recomputed
    p = tmp_path / "wang2011.toml"
    p.write_text(Path(fivebar.DEFAULT_PARAMS_PATH).read_text() + "\n# changed\n")
    assert datasets.source_hash(p) != datasets.source_hash()
    copy = tmp_path / "data"
    shutil.copytree(out, copy)
    again = datasets.write_datasets(copy, params_path=p, names=["resonance_speeds"])
    assert again["resonance_speeds"] > 0
    assert datasets.write_datasets(copy, params_path=p, names=["resonance_speeds"]) == {"resonance_speeds": 0.0}
    # the file written with the changed parameters is stale for the original ones
    assert datasets.write_datasets(copy, names=["resonance_speeds"])["resonance_speeds"] > 0


def test_the_source_hash_reads_every_module_of_every_subpackage():
    """The files hashed are the modules the import system finds in the package (pkgutil)."""
    import pkgutil

    modules = {m.name for m in pkgutil.walk_packages(fivebar.__path__, "fivebar.")}
    root = Path(fivebar.__file__).parent
    hashed = {".".join(("fivebar",) + p.relative_to(root).with_suffix("").parts).removesuffix(".__init__")
              for p in datasets._library_sources()}
    assert hashed == modules | {"fivebar"}
    assert {"fivebar.numerics.newmark", "fivebar.model.dynamics", "fivebar.analyses.control.control_model"} <= hashed


def test_bad_names_and_files_are_refused(tmp_path):
    with pytest.raises(ValueError, match="figure7"):
        datasets.write_datasets(tmp_path, names=["figure7"])
    bad = tmp_path / "x.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="provenance"):
        datasets.read_dataset(bad)


def test_every_dataset_belongs_to_a_chapter_of_the_book():
    toc = (ROOT / "_toc.yml").read_text()
    for ds in datasets.DATASETS.values():
        assert f"book/{ds.chapter}" in toc, ds.chapter
