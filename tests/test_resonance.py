"""Tests of fivebar.analyses.resonance: the six resonance conditions of section 3 and the Campbell diagram."""

import matplotlib.pyplot as plt
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.signal import find_peaks

import fivebar
from fivebar.analyses.resonance import (
    ResonanceError,
    classify,
    effective_frequencies,
    linkage_frequencies,
    resonance_speeds,
    resonance_table,
    spin_softening,
)


@pytest.fixture(scope="module")
def params():
    return fivebar.load_params()


def _types(df, mode=None):
    d = df if mode is None else df[df["mode"] == mode]
    return set(d["type"])


# --- the generic classifier against analytic oscillators -----------------------------------------
def _forced_p2p(Omega, w, zeta, c):
    """Closed-form steady peak-to-peak of u'' + 2 zeta w u' + w^2 u = sum_k c_k cos(k Omega t)."""
    t = np.linspace(0, 2 * np.pi / Omega, 400, endpoint=False)
    u = np.zeros_like(t)
    for k, ck in enumerate(c, start=1):
        H = ck / (w**2 - (k * Omega) ** 2 + 2j * zeta * w * k * Omega)
        u += np.real(H * np.exp(1j * k * Omega * t))
    return u.max() - u.min()


def test_classifier_finds_the_peaks_of_a_periodically_forced_oscillator():
    """Every response peak of a linear oscillator under a 4-harmonic periodic force is a primary
    or superharmonic resonance of the classifier, and the classifier's k-th resonance is a peak."""
    w, zeta, c = 10.0, 0.01, [1.0, 0.5, 0.3, 0.2]
    Om = np.linspace(1.5, 12.0, 3000)
    a = np.array([_forced_p2p(x, w, zeta, c) for x in Om])
    idx, _ = find_peaks(a)
    peaks = Om[idx]
    assert len(peaks) == 4
    for p in peaks:
        df = classify([w], {"nu": p}, harmonics=4, tolerance=0.01, parametric=False)
        assert _types(df) <= {"primary", "superharmonic"} and len(df) >= 1
    for k in (1, 2, 3, 4):
        df = classify([w], {"nu": w / k}, harmonics=4, tolerance=0.01)
        row = df[df["excitation"] == ("nu" if k == 1 else f"{k} nu")]
        assert row["type"].iloc[0] == ("primary" if k == 1 else "superharmonic")
        assert row["condition"].iloc[0] == (1 if k == 1 else 2)
        assert np.min(np.abs(peaks - w / k)) < 0.01 * w / k
    # between the resonances: nothing direct
    df = classify([w], {"nu": w / 2.5}, harmonics=4, tolerance=0.01, subharmonic_orders=())
    assert "primary" not in _types(df) and "superharmonic" not in _types(df)


def _mathieu_multiplier(w, zeta, h, Omega):
    """Largest Floquet multiplier of u'' + 2 zeta w u' + w^2 (1 + 2 h cos Omega t) u = 0."""
    T = 2 * np.pi / Omega

    def f(t, y):
        return [y[1], -2 * zeta * w * y[1] - w**2 * (1 + 2 * h * np.cos(Omega * t)) * y[0]]

    cols = [solve_ivp(f, (0, T), e, rtol=1e-10, atol=1e-12).y[:, -1] for e in ([1, 0], [0, 1])]
    return np.abs(np.linalg.eigvals(np.array(cols).T)).max()


def test_parametric_condition_marks_the_mathieu_instability():
    w, zeta, h = 1.0, 0.01, 0.1
    df = classify([w], {"nu": 2.0 * w}, harmonics=1, tolerance=0.02)
    assert "parametric" in _types(df) and "subharmonic" in _types(df)
    assert _mathieu_multiplier(w, zeta, h, 2.0 * w) > 1.0
    df = classify([w], {"nu": 1.6 * w}, harmonics=1, tolerance=0.02)
    assert "parametric" not in _types(df)
    assert _mathieu_multiplier(w, zeta, h, 1.6 * w) < 1.0


def test_subharmonic_internal_combination_and_multiple():
    df = classify([10.0], {"nu": 30.3}, harmonics=1, tolerance=0.02)
    row = df[df["type"] == "subharmonic"]
    assert row["excitation"].iloc[0] == "nu / 3" and row["relative detuning"].iloc[0] == pytest.approx(0.01)
    df = classify([1.0, 2.02, 3.05], {"nu": 100.0}, harmonics=1, tolerance=0.02)
    internal = df[df["type"] == "internal"]
    assert set(internal["mode"]) == {"2 = 2 x 1", "3 = 1 + 2", "3 = 3 x 1"}
    assert internal.set_index("mode").loc["3 = 1 + 2", "relative detuning"] == pytest.approx(3.05 / 3.02 - 1)
    assert (df["type"] == "multiple").sum() == 1 and df["condition"].iloc[-1] == 6
    df = classify([10.0], {"p": 3.0, "q": 7.05}, harmonics=2, tolerance=0.01, parametric=False)
    comb = df[df["type"] == "combination"]
    assert len(comb) >= 1 and comb["excitation (Hz)"].iloc[0] * 2 * np.pi == pytest.approx(10.05)
    # one condition alone is not multiple
    df = classify([10.0], {"nu": 10.1}, harmonics=1, tolerance=0.02, subharmonic_orders=(), parametric=False)
    assert list(df["type"]) == ["primary"]


@pytest.mark.parametrize(
    "args, kwargs",
    [
        (([0.0], {"nu": 1.0}), {}),
        (([1.0], {}), {}),
        (([1.0], {"nu": -1.0}), {}),
        (([1.0], {"nu": 1.0}), {"harmonics": 0}),
        (([1.0], {"nu": 1.0}), {"tolerance": 0.0}),
    ],
)
def test_bad_classifier_input(args, kwargs):
    with pytest.raises(ResonanceError):
        classify(*args, **kwargs)


# --- the linkage ---------------------------------------------------------------------------------------
def test_linkage_frequencies_exclude_the_rotor_whirl_and_ignore_speed(params):
    f = linkage_frequencies(params, 6) / (2 * np.pi)
    whirl = fivebar.natural_frequencies(params, 0.0, 0.0, n_modes=8)
    # the full model at crank angle 0 holds the rotor whirl (two pairs of equal frequencies) too
    assert not np.any(np.isclose(f[0][:, None], whirl[np.isclose(whirl, np.roll(whirl, 1))][None, :]))
    assert np.all(np.isin(np.round(f[0], 6), np.round(whirl, 6)))
    assert np.array_equal(linkage_frequencies(params.replace(crank_speed_rpm=900.0), 6) / (2 * np.pi), f)


def test_spin_softening_of_the_lowest_mode(params):
    """The lowest mode turns with the cranks: h_1 near -1 for both readings of the section."""
    for p, rpm in ((params, 600.0), (params.replace(bending_depth=0.002), 200.0)):
        h = spin_softening(p, 3)
        assert -1.4 < h[0] < -0.9
        w = effective_frequencies(p.replace(crank_speed_rpm=rpm), 3)
        W = rpm * 2 * np.pi / 60
        assert w ** 2 == pytest.approx(linkage_frequencies(p, 3).mean(0) ** 2 + h * W**2)


def test_resonance_table_of_the_linkage(params):
    assert resonance_table(params.replace(crank_speed_rpm=60.0)).empty
    wbar = linkage_frequencies(params, 2).mean(axis=0)
    rpm = wbar[0] / 2 * 60 / (2 * np.pi)  # 2 Omega = omega_1
    df = resonance_table(params.replace(crank_speed_rpm=rpm))
    row = df[(df["type"] == "superharmonic") & (df["mode"] == "1")]
    assert row["excitation"].iloc[0] == "2 nu1=nu2=nu3"
    assert abs(row["relative detuning"].iloc[0]) < 1e-9
    # the effective frequency puts that resonance lower
    sp = resonance_speeds(params, n_modes=2, frequencies="effective")
    eff = sp[(sp["type"] == "superharmonic") & (sp["mode"] == "1") & (sp["k"] == 2)]["speed (r/min)"].iloc[0]
    assert eff < 0.95 * rpm
    df = resonance_table(params.replace(crank_speed_rpm=eff), frequencies="effective")
    assert ((df["type"] == "superharmonic") & (df["mode"] == "1")).any()
    with pytest.raises(ResonanceError):
        resonance_table(params.replace(crank_speed_rpm=rpm), frequencies="instantaneous")


def test_resonance_speeds_solve_their_conditions(params):
    sp = resonance_speeds(params, n_modes=2, frequencies="effective", speed_range=(100, 4000))
    for row in sp.itertuples():
        W = row[1] * 2 * np.pi / 60
        w = effective_frequencies(params.replace(crank_speed_rpm=row[1]), 2)
        if row.type in ("primary", "superharmonic"):
            assert row.k * W == pytest.approx(w[int(row.mode) - 1], rel=1e-9)
        elif row.type == "parametric":
            r, s = (int(x) - 1 for x in row.mode.replace("+", " ").replace("-", " ").split())
            target = w[r] + w[s] if "+" in row.mode else abs(w[r] - w[s])
            assert row.k * W == pytest.approx(target, rel=1e-7)
        elif row.type == "divergence":
            assert np.isnan(effective_frequencies(params.replace(crank_speed_rpm=row[1] * 1.001), 2)[int(row.mode) - 1])
    mean = resonance_speeds(params, n_modes=2)
    assert set(mean["type"]) == {"primary", "superharmonic", "subharmonic", "parametric"}


def test_campbell_diagram(params):
    from fivebar.book.plotting import LABELS, MIN_FONT_PT, campbell_diagram

    ax = campbell_diagram(params, np.linspace(100, 3000, 50), n_modes=2)
    assert ax.get_xlabel() == LABELS["crank_speed"] and ax.get_ylabel() == LABELS["frequency"]
    assert len(ax.get_legend().get_texts()) == 4
    # the book's style: no text below MIN_FONT_PT, the legend outside the data (below the axes)
    fig = ax.figure
    fig.canvas.draw()
    texts = [*ax.texts, *ax.get_legend().get_texts(), ax.xaxis.label, ax.yaxis.label]
    assert min(t.get_fontsize() for t in texts) >= MIN_FONT_PT
    box, leg = ax.get_window_extent(), ax.get_legend().get_window_extent()
    assert leg.y1 <= box.y0 + 1, (leg, box)
    plt.close(fig)
    with pytest.raises(ResonanceError):
        campbell_diagram(params, [100.0])


def test_campbell_data_is_numbers_and_its_crossings_solve_k_omega_equals_frequency(params):
    from fivebar.book.plotting import campbell_plot
    from fivebar.analyses.resonance import CampbellData, campbell_data

    cd = campbell_data(params, np.linspace(100, 3000, 50), n_modes=2)
    assert isinstance(cd, CampbellData) and cd.frequencies.shape[1] == 2
    assert np.all(cd.low <= cd.mean) and np.all(cd.mean <= cd.high)
    for k in (1, 2, 3):
        for eff in (False, True):
            x, y = cd.crossings_rpm(k, effective=eff)
            assert np.allclose(k * x / 60, y, rtol=1e-12)  # on the line k Omega
            f = cd.effective(x) if eff else np.broadcast_to(cd.mean, (len(x), 2))
            assert np.all(np.isclose(f, y[:, None], rtol=1e-10).any(axis=1))  # and on a mode's curve
    ax = campbell_plot(cd)
    assert len(ax.get_legend().get_texts()) == 4
    plt.close(ax.figure)
