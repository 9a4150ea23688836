"""Animations (fivebar.book.animation): the frames show the computed motion; the page is offline."""

from __future__ import annotations

import re

import numpy as np
import pytest

import fivebar
from fivebar.book import animation
from fivebar.model.kinematics import crank_laws


@pytest.fixture(scope="module")
def params():
    return fivebar.load_params()


@pytest.fixture(scope="module")
def steady(params):
    return fivebar.steady_state(params)


def test_nice_scale():
    assert [animation.nice_scale(x) for x in (542.0, 199.9, 200.0, 7.0, 0.013)] == [500, 100, 200, 5, 0.01]
    with pytest.raises(ValueError, match="x = -1"):
        animation.nice_scale(-1)


def test_linkage_frames_show_the_midpoint_deflection_times_the_scale(steady):
    fr = animation.linkage_frames(steady, scale=300.0, frames=8)
    S = len(steady.t) - 1
    idx = np.round(np.arange(8) * S / 8).astype(int)
    np.testing.assert_allclose(fr.crank_angle_deg, steady.crank_angle_deg[idx])
    for link in ("L2", "L3"):
        rig, dfm = fr.rigid_mm[link], fr.deformed_mm[link]
        mid = rig.shape[1] // 2
        e = rig[:, -1] - rig[:, 0]
        e /= np.linalg.norm(e, axis=1, keepdims=True)
        normal = np.stack([-e[:, 1], e[:, 0]], axis=1)
        shown = np.einsum("ij,ij->i", dfm[:, mid] - rig[:, mid], normal) / 300.0  # mm
        np.testing.assert_allclose(shown, steady.midpoint_mm(link)[idx], rtol=1e-9, atol=1e-12)


def test_default_scale_makes_the_deflection_visible_but_not_huge(steady, params):
    fr = animation.linkage_frames(steady, frames=4)
    shown = fr.scale * fr.peak_mm  # mm on the drawing
    assert 0.08 * 1e3 * params.L2 / 2.5 < shown <= 0.08 * 1e3 * params.L2 * (1 + 1e-9)
    assert fr.scale == animation.nice_scale(fr.scale)


def test_mode_frames_frequencies_and_normalisation(params):
    fr = animation.mode_frames(params, n_modes=2, frames=6)
    for i in (0, 4):
        th1, _, _, th4, _, _ = crank_laws(params, np.radians(fr.crank_angle_deg[i]) / params.crank_speed_rad_s)
        np.testing.assert_allclose(fr.frequencies[i], fivebar.natural_frequencies(params, float(th1), float(th4), n_modes=2),
                                   rtol=1e-10)
    for shape in fr.shapes_mm:
        disp = np.stack([shape[L] - fr.rigid_mm[L] for L in fr.rigid_mm], axis=1)  # (F, links, points, 2)
        peak = np.linalg.norm(disp, axis=-1).max(axis=(1, 2))
        np.testing.assert_allclose(peak, fr.amplitude_mm, rtol=1e-9)
        flat = disp.reshape(len(peak), -1)
        assert np.all(np.einsum("ij,ij->i", flat[1:], flat[:-1]) > 0)  # the sign follows the cycle


@pytest.mark.parametrize("bad", [1, 2.5, True, 1000])
def test_bad_frame_counts_are_refused(steady, bad):
    with pytest.raises(ValueError, match="frames = "):
        animation.linkage_frames(steady, frames=bad)


def test_page_is_offline_small_and_has_controls(steady, tmp_path):
    anim = animation.animate_linkage(steady, frames=4, dpi=40)
    page = anim.to_html()
    assert len(anim.frames) == 4 and all(f.startswith(b"\x89PNG") for f in anim.frames)
    assert page.count("data:image/png;base64,") == 4
    assert not re.search(r"(src|href)\s*=\s*[\"']?(https?:)?//", page), "loads from another host"
    assert "http" not in page
    for control in ('id="play"', 'id="prev"', 'id="next"', 'type="range"'):
        assert control in page
    assert anim.nbytes < 3e6


def test_show_displays_a_fixed_snippet_and_writes_the_page(steady, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    a = animation.animate_linkage(steady, frames=3, dpi=40)
    b = animation.animate_linkage(steady, scale=50.0, frames=3, dpi=40)
    out_a = animation.show(a, "anim/x.html").html
    page_a = (tmp_path / "anim" / "x.html").read_text()
    out_b = animation.show(b, "anim/x.html").html
    assert (tmp_path / "anim" / "x.html").read_text() != page_a  # the file follows the animation
    assert out_a.replace("500", "50") == out_b.replace("500", "50")  # the snippet only names it
    assert 'src="anim/x.html"' in out_a
    # the page keeps the frames' aspect on a phone (the iframe's height follows its width)
    assert "aspect-ratio:" in out_a and "height:auto" in out_a


def test_the_printed_book_gets_a_strip_of_frames(steady, tmp_path, monkeypatch):
    """The PDF cannot play an iframe: the displayed object offers a PNG strip of the frames, which
    the LaTeX build takes (myst-nb's image/png before text/plain), and a text line that names the
    animation instead of '<IPython.core.display.HTML object>'."""
    import io

    import matplotlib.image as mpimg

    monkeypatch.chdir(tmp_path)
    a = animation.animate_linkage(steady, frames=8, dpi=40)
    import warnings

    import matplotlib as mpl

    # under the book's style (constrained layout on) the strip is drawn without a warning: a
    # warning would be printed under the animation on the page
    with mpl.rc_context({"figure.constrained_layout.use": True}), warnings.catch_warnings():
        warnings.simplefilter("error")
        bundle = animation.show(a, "anim/x.html")._repr_mimebundle_()
    assert set(bundle) == {"text/html", "image/png", "text/plain"}
    assert bundle["text/plain"].startswith("Animation: ") and "object>" not in bundle["text/plain"]
    strip = mpimg.imread(io.BytesIO(bundle["image/png"]), format="png")
    assert strip.shape[1] > 2.5 * strip.shape[0]  # four frames side by side
    frame = mpimg.imread(io.BytesIO(a.frames[0]), format="png")
    assert strip.shape[1] >= 2 * frame.shape[1] or strip.shape[1] >= 900
    for bad in ("/tmp/x.html", "../x.html", "anim/x.gif"):
        with pytest.raises(ValueError, match="path = "):
            animation.show(a, bad)


def test_a_four_bar_is_drawn_from_its_own_description():
    """The frames and animations take the links, crank angles, scale and ground of the linkage
    description (they read the five-bar's L1..L5 and two cranks before): for the four-bar the
    rigid frames put the joints where the loop closure does, and the elastic part of the
    coupler's midpoint is the steady state's deflection there times the scale."""
    from fivebar.model.kinematics import positions

    four = fivebar.load_params([fivebar.DEFAULT_PARAMS_PATH, fivebar.FOURBAR_PARAMS_PATH])
    st = fivebar.steady_state(fivebar.Setup(four, crank_speed_rpm=600, steps_per_period=200, motors=False))
    fr = animation.linkage_frames(st, frames=4, points=5)
    assert sorted(fr.rigid_mm) == ["coupler", "crank", "rocker"]
    (theta,) = st.dynamics.crank_angles(st.t[:-1:50])
    P = positions(four, theta)
    for link, (a, b) in four.linkage.link_ends.items():
        assert np.allclose(fr.rigid_mm[link][:, 0], 1e3 * P[a], atol=1e-9)
        assert np.allclose(fr.rigid_mm[link][:, -1], 1e3 * P[b], atol=1e-9)
    mid = fr.deformed_mm["coupler"][:, 2] - fr.rigid_mm["coupler"][:, 2]  # s = 0.5 (5 points)
    d = P["C"] - P["B"]
    normal = np.stack([-d[:, 1], d[:, 0]], axis=-1) / np.linalg.norm(d, axis=-1, keepdims=True)
    transverse = np.einsum("ij,ij->i", mid, normal) / fr.scale
    assert np.abs(transverse - st.midpoint_mm("coupler")[:-1:50]).max() < 1e-9 + 1e-9 * fr.peak_mm
    assert np.ptp(st.midpoint_mm("coupler")) > 1e-3
    assert len(animation.animate_modes(four, n_modes=2, frames=3).frames) == 3


def test_the_mode_frames_pass_over_a_rotor_whirl_that_does_not_move_the_linkage():
    """Issue 32: a heavy rotor on a thin shaft whirls (its transverse DOFs, decoupled from the links)
    below the third linkage mode; the frames show the linkage's three lowest modes, those of the
    model without the rotors' transverse DOFs (scipy's eigh on it), not the whirl, whose zero link
    displacement made the normalisation NaN (a figure 'Axis limits cannot be NaN')."""
    import scipy.linalg

    from fivebar.model.assembly import build_model

    p = fivebar.load_params().replace(**{"motor1.m0": 3.5, "motor1.J0": 0.03, "shaft_diameter_1": 0.011,
                                         "shaft_diameter_2": 0.014})
    data = animation.mode_frames(p, 3, 4)
    model = build_model(p)
    rotor = [d for dofs in model.motor_dofs.values() for d in dofs[:2]]
    keep = np.setdiff1d(np.arange(model.n), rotor)
    theta = crank_laws(p, np.zeros(1))[0::3]
    M, K = model.matrices(*(float(a[0]) for a in theta))
    w2 = scipy.linalg.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True)[:3]
    assert data.frequencies[0] == pytest.approx(np.sqrt(w2) / (2 * np.pi), rel=1e-8)
    assert fivebar.natural_frequencies(p, *(float(a[0]) for a in theta), n_modes=3)[2] < data.frequencies[0, 2]
    assert all(np.isfinite(v).all() for s in data.shapes_mm for v in s.values()) and np.isfinite(data.curve).all()


def test_a_blitted_frame_is_the_figure_drawn_whole():
    """``_render`` draws only the moving artists again for each frame; each frame must be what
    drawing the whole figure in that state gives (the reference: the canvas drawn anew, the
    artists not animated), every frame of one size."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    angles = np.linspace(0.0, 2 * np.pi, 5, endpoint=False)
    fig, ax = plt.subplots(figsize=(3.0, 2.4), layout="constrained")
    try:
        ax.set_xlim(-1.2, 1.2)
        ax.set_ylim(-1.2, 1.2)
        ax.grid(True)
        line = ax.plot([], [], lw=2)[0]
        dot = ax.plot([], [], "o")[0]
        title = ax.set_title("")

        def update(i):
            line.set_data([0.0, np.cos(angles[i])], [0.0, np.sin(angles[i])])
            dot.set_data([np.cos(angles[i])], [np.sin(angles[i])])
            title.set_text(f"angle {np.degrees(angles[i]):.0f}°")

        frames, w, h = animation._render(fig, update, len(angles), 60, [line, dot, title])
        assert len(frames) == len(angles)
        for i, png in enumerate(frames):
            got = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"), dtype=float)
            assert got.shape == (h, w, 4)
            for artist in (line, dot, title):
                artist.set_animated(False)
            update(i)
            fig.canvas.draw()
            whole = np.asarray(fig.canvas.buffer_rgba(), dtype=float)
            assert np.abs(got - whole).max() <= 2.0, f"frame {i} differs from the figure drawn whole"
            assert np.abs(got - whole).mean() < 0.01
    finally:
        plt.close(fig)
