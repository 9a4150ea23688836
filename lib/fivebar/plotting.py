"""Plotting helpers shared by the book's chapters.

:func:`use_book_style` sets one matplotlib style for the whole book, with the colour-blind-safe
Okabe-Ito palette; :data:`LINK_COLORS` gives each link of Figure 1 the same colour in every
chapter; :func:`draw_linkage` draws the five-bar of Figure 1 in one configuration (joints A..E,
links L1..L5, the lumped masses m01 at B and m02 at C), computed by
:func:`fivebar.kinematics.positions`.
"""

from __future__ import annotations

from typing import Any

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from .errors import InputError
from .kinematics import LINKS, positions
from .params import Params

__all__ = ["OKABE_ITO", "PALETTE", "LINK_COLORS", "campbell_plot", "use_book_style", "draw_linkage"]

#: The Okabe-Ito colour-blind-safe palette (Okabe & Ito 2008), by name.
OKABE_ITO: dict[str, str] = {
    "black": "#000000",
    "orange": "#E69F00",
    "sky blue": "#56B4E9",
    "bluish green": "#009E73",
    "yellow": "#F0E442",
    "blue": "#0072B2",
    "vermillion": "#D55E00",
    "reddish purple": "#CC79A7",
}

#: The colour cycle of the book (Okabe-Ito, most distinct colours first; yellow last but one).
PALETTE: list[str] = [
    OKABE_ITO[c]
    for c in ("blue", "vermillion", "bluish green", "orange", "reddish purple", "sky blue", "black", "yellow")
]

#: One colour per link, the same in every chapter (the couplers L2, L3 are plotted most).
LINK_COLORS: dict[str, str] = {
    "L1": OKABE_ITO["bluish green"],
    "L2": OKABE_ITO["blue"],
    "L3": OKABE_ITO["vermillion"],
    "L4": OKABE_ITO["orange"],
    "L5": "0.35",
}


def use_book_style() -> None:
    """Set the book's matplotlib style (palette, sizes, grid) for the running session.

    ``use_book_style()`` once at the top of a chapter; every later figure then uses the
    Okabe-Ito colour cycle :data:`PALETTE`, a light grid and a layout that keeps labels inside
    the figure.
    """
    mpl.rcParams.update(
        {
            "axes.prop_cycle": mpl.cycler(color=PALETTE),
            "figure.figsize": (7.0, 4.0),
            "figure.dpi": 100,
            "figure.constrained_layout.use": True,
            "savefig.dpi": 150,
            "font.size": 10,
            "axes.titlesize": 10,
            "axes.labelsize": 10,
            "legend.fontsize": 9,
            "legend.frameon": False,
            "axes.grid": True,
            "grid.color": "0.88",
            "grid.linewidth": 0.6,
            "axes.spines.top": False,
            "axes.spines.right": False,
            "lines.linewidth": 1.8,
            "image.cmap": "viridis",
        }
    )


def _scalar(name: str, value: ArrayLike) -> float:
    a = np.asarray(value, float)
    if a.ndim != 0 or not np.isfinite(a):
        raise InputError(f"{name} = {value!r} is not allowed: draw_linkage draws one configuration, give one finite angle (rad)")
    return float(a)


def draw_linkage(
    ax: Axes,
    params: Params,
    theta1: float,
    theta4: float,
    *,
    mode: int = 1,
    color: str | None = None,
    lw: float = 2.5,
    alpha: float = 1.0,
    joints: bool = True,
    ground: bool = True,
    labels: bool = False,
    masses: bool = False,
    scale: float = 1e3,
    zorder: float = 2.0,
) -> dict[str, Any]:
    """Draw the five-bar of Figure 1 in one configuration.

    ``draw_linkage(ax, params, 0.0, 0.0, labels=True, masses=True)`` draws the labelled
    mechanism; ``draw_linkage(ax, params, t1, t4, color="0.8", lw=1, joints=False,
    ground=False)`` a ghosted position.

    Parameters
    ----------
    ax
        The axes to draw on (its aspect is set to equal).
    params
        The parameter set (lengths in m).
    theta1, theta4
        Crank angles (rad) of AB and ED: one configuration, scalars.
    mode
        Assembly mode of :func:`fivebar.kinematics.positions`.
    color
        One colour for all moving links; ``None`` uses :data:`LINK_COLORS`.
    lw, alpha, zorder
        Line width (points), opacity and drawing order of the links.
    joints
        Draw the pins as small open circles.
    ground
        Draw the frame AE (L5, dashed) and the ground symbols at A and E.
    labels
        Write the joint names A..E and the link names L1..L5.
    masses
        Mark the lumped masses m01 at B and m02 at C (filled circles, with their names if
        ``labels``).
    scale
        Factor from m to the plot's units (default 1e3: the axes are in mm).

    Returns
    -------
    dict
        The artists: ``"links"`` (name -> Line2D), ``"joints"``, ``"ground"``, ``"masses"``
        (lists) and ``"labels"`` (text -> Text).

    Raises
    ------
    ValueError
        If ``theta1`` or ``theta4`` is not a single finite number, or the mode is not +-1.
    fivebar.kinematics.GeometryError
        If the loop cannot close at these crank angles.
    """
    t1, t4 = _scalar("theta1", theta1), _scalar("theta4", theta4)
    P = {k: scale * np.asarray(v) for k, v in positions(params, t1, t4, mode).items()}
    out: dict[str, Any] = {"links": {}, "joints": [], "ground": [], "masses": [], "labels": {}}
    centre = np.mean([P[k] for k in "ABCDE"], axis=0)

    if ground:
        (frame,) = ax.plot(*np.transpose([P["A"], P["E"]]), ls="--", lw=1.0, color=LINK_COLORS["L5"], zorder=zorder - 0.5)
        out["links"]["L5"] = frame
        size = 0.08 * scale * params.L5
        for k in "AE":
            x, y = P[k]
            tri = np.array([[x, y], [x - size / 2, y - size], [x + size / 2, y - size]])
            out["ground"].append(ax.fill(*tri.T, facecolor="none", edgecolor="0.2", lw=1.0, hatch="///", zorder=zorder - 0.5)[0])
    for name, (s, e) in LINKS.items():
        c = LINK_COLORS[name] if color is None else color
        (line,) = ax.plot(*np.transpose([P[s], P[e]]), color=c, lw=lw, alpha=alpha, solid_capstyle="round", zorder=zorder)
        out["links"][name] = line
    if joints:
        xy = np.array([P[k] for k in "ABCDE"])
        out["joints"].append(
            ax.scatter(*xy.T, s=28, facecolor="white", edgecolor="black", linewidth=1.0, alpha=alpha, zorder=zorder + 1)
        )
    # joint labels sit outside the loop, in the direction from its centre to the joint
    away = {k: (P[k] - centre) / (np.hypot(*(P[k] - centre)) or 1.0) for k in "ABCDE"}
    if masses:
        for k, name in (("B", "$m_{01}$"), ("C", "$m_{02}$")):
            out["masses"].append(ax.scatter(*P[k], s=110, color="black", alpha=alpha, zorder=zorder + 0.5))
            if labels:  # beside the joint, square to its letter, on the right
                side = np.array([away[k][1], -away[k][0]])
                side = side if side[0] >= 0 else -side
                out["labels"][name] = ax.annotate(
                    name, P[k], xytext=tuple(12 * side + (4, 0)), textcoords="offset points",
                    ha="left", va="center", fontsize=9,
                )
    if labels:
        for k in "ABCDE":
            out["labels"][k] = ax.annotate(
                k, P[k], xytext=tuple(16 * away[k]), textcoords="offset points", ha="center", va="center", fontweight="bold"
            )
        ends = dict(LINKS, L5=("A", "E"))
        for name, (s, e) in ends.items():
            # the frame's label sits at 3/4 of AE, clear of B at theta1 = 0 when L1 = L5/2
            mid = P[s] + (0.75 if name == "L5" else 0.5) * (P[e] - P[s])
            t = (P[e] - P[s]) / np.hypot(*(P[e] - P[s]))
            n = np.array([-t[1], t[0]])
            if np.dot(n, mid - centre) < 0:
                n = -n
            sub = name[1:]
            out["labels"][name] = ax.annotate(
                f"$L_{sub}$", mid, xytext=tuple((20 if name == "L5" else 12) * n), textcoords="offset points", ha="center", va="center",
                color=LINK_COLORS[name] if color is None else color,
            )
    if labels:  # the labels lie outside the joints' bounding box, leave room for them
        ax.margins(0.1)
    ax.set_aspect("equal")
    return out


def campbell_plot(data, ax=None, *, mark: bool = True, effective: bool = True):
    r"""Draw a Campbell diagram from :func:`fivebar.resonance.campbell_data`.

    ``ax = campbell_plot(campbell_data(params, speeds))``.  Each mode is a band from the lowest
    to the highest instantaneous frequency over a turn with its mean (3.3) as a line; the load
    harmonics :math:`k\Omega` (k = 1..m) are straight lines through the origin; ``mark``
    circles their crossings with each mean (the primary and superharmonic resonance speeds of
    :func:`fivebar.resonance.resonance_speeds`).  ``effective`` adds the effective frequencies
    :math:`\sqrt{\bar\omega_r^2 + h_r\Omega^2}` as dashed curves, their crossings as filled
    dots.  Returns the matplotlib Axes.
    """
    import matplotlib.pyplot as plt

    x, lo, mean, hi, h = data.speeds_rpm, data.low, data.mean, data.high, data.spin_softening
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 5))
    xs = np.array([0.0, x.max()])
    for r in range(len(mean)):
        c = f"C{r}"
        ax.axhspan(lo[r], hi[r], color=c, alpha=0.15, lw=0)
        ax.axhline(mean[r], color=c, lw=1.5, label=f"mode {r + 1}: mean {mean[r]:.1f} Hz, range {lo[r]:.1f}-{hi[r]:.1f} Hz")
    if effective:
        xx = np.linspace(0.0, x.max(), 400)
        fe = data.effective(xx)
        for r in range(len(mean)):
            ok = np.isfinite(fe[:, r])
            ax.plot(xx[ok], fe[ok, r], color=f"C{r}", ls="--", lw=1.2, label=f"mode {r + 1}: effective, h = {h[r]:.2f}")
    for k in range(1, data.harmonics + 1):
        ax.plot(xs, k * xs / 60, color="0.4", lw=0.8, ls=":")
        xe = min(x.max(), hi.max() * 1.15 * 60 / k)
        ax.annotate(f"{k}Ω", (xe, k * xe / 60), fontsize=7, color="0.3", xytext=(2, 0), textcoords="offset points")
        if mark:
            ax.plot(*data.crossings(k), "o", mfc="none", mec="k", ms=6)
            if effective:
                ax.plot(*data.crossings(k, effective=True), "o", color="k", ms=4)
    ax.set_xlim(x.min(), x.max())
    ax.set_ylim(0, hi.max() * 1.15)
    ax.set_xlabel("crank speed (r/min)")
    ax.set_ylabel("frequency (Hz)")
    ax.legend(fontsize=8, loc="upper left")
    return ax
