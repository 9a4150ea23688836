"""Book plotting helpers: the style and the linkage drawing."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.colors as mcolors  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from fivebar import load_params  # noqa: E402
from fivebar.kinematics import GeometryError, positions  # noqa: E402
from fivebar.plotting import LINK_COLORS, OKABE_ITO, PALETTE, draw_linkage, use_book_style  # noqa: E402

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
