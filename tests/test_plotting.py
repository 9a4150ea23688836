"""Book plotting helpers: the style and the linkage drawing."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.colors as mcolors  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from fivebar import load_params  # noqa: E402
from fivebar.model.kinematics import GeometryError, positions  # noqa: E402
from fivebar.book.plotting import LINK_COLORS, OKABE_ITO, PALETTE, draw_linkage, use_book_style  # noqa: E402

P = load_params()


def test_book_style_uses_okabe_ito():
    with matplotlib.rc_context():
        use_book_style()
        cycle = [c["color"] for c in matplotlib.rcParams["axes.prop_cycle"]]
        assert cycle == PALETTE
        assert {c.upper() for c in cycle} == {c.upper() for c in OKABE_ITO.values()}
    # the published Okabe-Ito values (RGB 0-255)
    assert mcolors.to_rgb(OKABE_ITO["vermillion"]) == pytest.approx((213 / 255, 94 / 255, 0.0))
    assert mcolors.to_rgb(OKABE_ITO["blue"]) == pytest.approx((0.0, 114 / 255, 178 / 255))
    assert LINK_COLORS["L2"] != LINK_COLORS["L3"]


def test_draw_linkage_places_links_at_the_joints():
    t1, t4 = 1.1, -2.3
    fig, ax = plt.subplots()
    art = draw_linkage(ax, P, t1, t4, labels=True, masses=True)
    X = positions(P, t1, t4)
    ends = {"L1": "AB", "L2": "BC", "L3": "CD", "L4": "ED", "L5": "AE"}
    for name, (s, e) in ends.items():
        xy = np.asarray(art["links"][name].get_xydata())
        assert np.allclose(xy, 1e3 * np.array([X[s], X[e]]), atol=1e-9)
    texts = {t.get_text() for t in ax.texts}
    assert set("ABCDE") <= texts
    assert {f"$L_{i}$" for i in range(1, 6)} <= texts
    assert {"$m_{01}$", "$m_{02}$"} <= texts
    assert np.allclose(art["masses"][0].get_offsets(), [1e3 * X["B"]])
    assert np.allclose(art["masses"][1].get_offsets(), [1e3 * X["C"]])
    assert ax.get_aspect() == 1.0
    plt.close(fig)


def test_ghost_drawing_and_bad_input():
    fig, ax = plt.subplots()
    art = draw_linkage(ax, P, 0.3, 0.3, color="0.8", lw=1, joints=False, ground=False, scale=1.0)
    assert set(art["links"]) == {"L1", "L2", "L3", "L4"} and not art["joints"] and not ax.texts
    assert np.allclose(art["links"]["L4"].get_xydata()[1], positions(P, 0.3, 0.3)["D"])
    with pytest.raises(ValueError, match="theta1 = .* one configuration"):
        draw_linkage(ax, P, np.array([0.0, 1.0]), 0.0)
    with pytest.raises(GeometryError):
        draw_linkage(ax, P.replace(L2=0.15, L3=0.15), 0.0, 0.0)
    plt.close(fig)


# --------------------------------------------------------------------------------------------
# The book's figure style: column width, fonts, 2x inline PNG, legends outside, one unit
# --------------------------------------------------------------------------------------------

from fivebar.book.plotting import (  # noqa: E402
    COLUMN_WIDTH_IN,
    LABELS,
    MIN_FONT_PT,
    UNITS,
    figsize,
    legend_outside,
)


def _styled_figure(rows=2):
    fig, axes = plt.subplots(rows, 1, figsize=figsize(rows), sharex=True)
    for ax in np.atleast_1d(axes):
        x = np.linspace(0, 360, 50)
        ax.plot(x, np.sin(np.radians(x)), label="$L_2$")
        ax.plot(x, np.cos(np.radians(x)), label="$L_3$")
        ax.set_ylabel(LABELS["midpoint_transverse"])
        ax.set_title("midpoint of $L_2$")
        legend_outside(ax)
    np.atleast_1d(axes)[-1].set_xlabel(LABELS["crank_angle"])
    fig.suptitle("a figure")
    draw_linkage(np.atleast_1d(axes)[0].inset_axes([0.0, 0.0, 0.3, 0.3]), P, 0.0, 0.0, labels=True, masses=True)
    return fig


def test_figure_under_the_style_fits_the_column_with_10pt_text():
    with matplotlib.rc_context():
        use_book_style()
        fig = _styled_figure(rows=2)
        w, h = fig.get_size_inches()
        assert w == pytest.approx(COLUMN_WIDTH_IN) and h == pytest.approx(2 * 0.55 * COLUMN_WIDTH_IN)
        fig.canvas.draw()
        texts = [t for t in fig.findobj(matplotlib.text.Text) if t.get_visible() and t.get_text()]
        assert len(texts) > 20  # tick labels, axis labels, legends, titles, linkage labels
        small = [(t.get_text(), t.get_fontsize()) for t in texts if t.get_fontsize() < MIN_FONT_PT]
        assert not small, f"text below {MIN_FONT_PT} pt: {small}"
        # the figure is shown at its natural size (100 px/in) in a column of about 700 px
        assert fig.dpi * w <= 700
        plt.close(fig)


def test_legend_outside_does_not_cover_the_data():
    with matplotlib.rc_context():
        use_book_style()
        for where in ("right", "below"):
            fig, ax = plt.subplots(figsize=figsize())
            ax.plot([0, 1], [0, 1], label="a")
            ax.plot([0, 1], [1, 0], label="b")
            leg = legend_outside(ax, where)
            fig.canvas.draw()
            box, data = leg.get_window_extent(), ax.get_window_extent()
            assert not box.overlaps(data), (where, box, data)
            plt.close(fig)
        with pytest.raises(ValueError, match="where = 'top'"):
            legend_outside(ax, "top")


def test_inline_figures_are_png_at_twice_the_displayed_size():
    """In a kernel the style sends a 2x PNG whose metadata asks for the 1x display size."""
    import struct

    from IPython.core.interactiveshell import InteractiveShell

    shell = InteractiveShell.instance()
    try:
        with matplotlib.rc_context():
            use_book_style()
            fig = _styled_figure(rows=1)
            data, meta = shell.display_formatter.format(fig)
            png = data["image/png"]
            if isinstance(png, str):
                import base64

                png = base64.b64decode(png)
            width_px, height_px = struct.unpack(">II", png[16:24])  # the IHDR chunk
            shown = meta["image/png"]["width"]
            assert width_px == pytest.approx(2 * shown, abs=2)
            assert shown == pytest.approx(fig.dpi * COLUMN_WIDTH_IN, rel=0.1)  # bbox tight
            plt.close(fig)
    finally:
        InteractiveShell.clear_instance()


def test_figsize_stacks_panels_and_rejects_bad_input():
    assert figsize() == (COLUMN_WIDTH_IN, pytest.approx(0.55 * COLUMN_WIDTH_IN))
    assert figsize(3, aspect=0.4) == (COLUMN_WIDTH_IN, pytest.approx(3 * 0.4 * COLUMN_WIDTH_IN))
    for bad, match in (({"rows": 0}, "rows = 0"), ({"rows": 1.5}, "rows = 1.5"),
                       ({"aspect": -1.0}, "aspect = -1.0"), ({"width": float("nan")}, "width = nan")):
        with pytest.raises(ValueError, match=match):
            figsize(**bad)


def test_one_unit_per_quantity_in_the_labels():
    import re

    # every label names its unit in parentheses, and the unit is the book's unit of it
    for key, label in LABELS.items():
        m = re.search(r"\(([^()]*)\)\s*$", label)
        assert m, f"LABELS[{key!r}] = {label!r} has no unit in parentheses"
    assert UNITS["deflection"] == r"$\mu$m"
    for key in ("midpoint_transverse", "midpoint_longitudinal", "midpoint_bending"):
        assert LABELS[key].endswith(f"({UNITS['deflection']})")
    assert LABELS["crank_angle"] == r"crank angle $\theta_1$ (deg)"
    assert LABELS["crank_speed"].endswith(f"({UNITS['crank_speed']})")
    # the labels are valid mathtext
    from matplotlib.mathtext import MathTextParser

    parser = MathTextParser("agg")
    for label in LABELS.values():
        parser.parse(label)
