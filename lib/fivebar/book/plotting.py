"""Plotting helpers shared by the book's chapters: one figure style, one unit per quantity.

:func:`use_book_style` sets one matplotlib style for the whole book: figures as wide as the
book's text column (:data:`COLUMN_WIDTH_IN`), fonts of at least 10 pt at the size shown, inline
figures as PNG at twice the displayed resolution, mathtext labels and the colour-blind-safe
Okabe-Ito palette.  :func:`figsize` sizes a figure of stacked panels for the column,
:func:`legend_outside` puts a legend beside or below the data instead of over it, and
:data:`LABELS` / :data:`UNITS` give every quantity of the book one label and one unit.
:data:`LINK_COLORS` gives each link of Figure 1 the same colour in every chapter;
:func:`draw_linkage` draws the five-bar of Figure 1 in one configuration (joints A..E, links
L1..L5, the lumped masses m01 at B and m02 at C), computed by
:func:`fivebar.model.kinematics.positions`.
"""

from __future__ import annotations

from typing import Any

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from ..errors import InputError
from ..model.kinematics import positions
from ..description.params import Params
from ..description.setup import Setup, analysis

__all__ = [
    "campbell_diagram",
    "response_plot",
    "OKABE_ITO",
    "PALETTE",
    "LINK_COLORS",
    "link_colors",
    "COLUMN_WIDTH_IN",
    "MIN_FONT_PT",
    "UNITS",
    "LABELS",
    "use_book_style",
    "figsize",
    "legend_outside",
    "draw_linkage",
    "campbell_plot",
]

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


def link_colors(linkage) -> dict[str, str]:
    """Link name -> colour for the links of a linkage description: :data:`LINK_COLORS` for the
    paper's L1..L4, the Okabe-Ito colours in turn for the links of any other linkage."""
    cycle = list(OKABE_ITO.values())
    return {k.name: LINK_COLORS.get(k.name, cycle[(i + 1) % len(cycle)]) for i, k in enumerate(linkage.links)}


#: Width (in) of a figure for the book's text column.  The text column of the built book is
#: 784 CSS px wide at a 1400 px window (measured in Chromium: the article's 848 px less its
#: padding) and 358 px on a 390 px phone.  Inline figures are 2x PNGs shown at half their
#: pixel width, 100 px per inch: a 6.5 in figure is shown at about 660 px, unscaled, so a
#: 10 pt label appears at 10 pt (13.9 px) and the figure still fits a narrower window.
COLUMN_WIDTH_IN = 6.5

#: Smallest font size (pt) of any text in a figure of the book at the size it is shown.
MIN_FONT_PT = 10.0

#: One unit per quantity across the book (the book's Units section lists the same).
#: Quantity -> unit as typeset in labels (mathtext).
UNITS: dict[str, str] = {
    "length": "mm",
    "deflection": r"$\mu$m",
    "angle": "deg",
    "crank_speed": "r/min",
    "frequency": "Hz",
    "angular_frequency": "rad/s",
    "time": "s",
    "stress": "MPa",
    "torque": "N m",
    "force": "N",
    "flux_density": "T",
}

#: Axis labels of the quantities the book plots, with their unit (mathtext).
LABELS: dict[str, str] = {
    "crank_angle": r"crank angle $\theta_1$ (deg)",
    "crank_angle_4": r"crank angle $\theta_4$ (deg)",
    "crank_speed": r"crank speed $\Omega$ (r/min)",
    "time": r"time $t$ (s)",
    "x": r"$x$ (mm)",
    "y": r"$y$ (mm)",
    "midpoint_transverse": r"transverse midpoint displacement ($\mu$m)",
    "midpoint_longitudinal": r"longitudinal midpoint displacement ($\mu$m)",
    "midpoint_bending": r"midpoint bending deflection ($\mu$m)",
    "frequency": r"frequency $f$ (Hz)",
    "natural_frequency": r"natural frequency $\omega_r/2\pi$ (Hz)",
    "angular_frequency": r"$\omega$ (rad/s)",
    "link_angle": r"link angle (deg)",
    "angular_velocity": r"angular velocity (rad/s)",
    "angular_acceleration": r"angular acceleration (rad/s$^2$)",
    "stress": r"bending stress $\sigma$ (MPa)",
    "torque": r"drive torque $\tau$ (N m)",
    "steps_per_period": r"steps per period $S$ (–)",
    "floquet": r"largest Floquet multiplier $|\mu|$ (–)",
    "amplification": r"dynamic amplification (–)",
}


def use_book_style(*, inline: bool = True) -> None:
    """Set the book's matplotlib style for the running session.

    ``use_book_style()`` once at the top of a chapter; every later figure is
    :data:`COLUMN_WIDTH_IN` wide, writes all text at :data:`MIN_FONT_PT` or more, uses the
    Okabe-Ito colour cycle :data:`PALETTE`, mathtext labels and a light grid.  In a Jupyter
    kernel inline figures are sent as PNG at twice the displayed resolution ("retina"), so
    their text stays sharp on the page.

    Parameters
    ----------
    inline
        Also set the inline figure format when running in IPython (no effect elsewhere).
    """
    mpl.rcParams.update(
        {
            "axes.prop_cycle": mpl.cycler(color=PALETTE),
            "figure.figsize": figsize(),
            "figure.dpi": 100,
            "figure.constrained_layout.use": True,
            "savefig.dpi": 200,
            "savefig.bbox": "tight",
            "font.size": MIN_FONT_PT,
            "axes.titlesize": MIN_FONT_PT + 1,
            "axes.labelsize": MIN_FONT_PT,
            "xtick.labelsize": MIN_FONT_PT,
            "ytick.labelsize": MIN_FONT_PT,
            "legend.fontsize": MIN_FONT_PT,
            "legend.title_fontsize": MIN_FONT_PT,
            "figure.titlesize": MIN_FONT_PT + 1,
            "legend.frameon": False,
            "mathtext.fontset": "dejavusans",
            "mathtext.default": "it",
            "axes.formatter.use_mathtext": True,
            "axes.grid": True,
            "grid.color": "0.88",
            "grid.linewidth": 0.6,
            "axes.spines.top": False,
            "axes.spines.right": False,
            "lines.linewidth": 1.8,
            "image.cmap": "viridis",
        }
    )
    if inline:
        _inline_retina()


def _inline_retina() -> None:
    """PNG at 2x for the inline backend, if an IPython kernel is running."""
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with the book's environment
        return
    if get_ipython() is None:
        return
    from matplotlib_inline.backend_inline import set_matplotlib_formats

    set_matplotlib_formats("retina")


def figsize(rows: int = 1, *, aspect: float = 0.55, width: float = COLUMN_WIDTH_IN) -> tuple[float, float]:
    """Size (in) of a figure of ``rows`` panels stacked in the text column.

    ``plt.subplots(2, 1, figsize=figsize(2), sharex=True)`` stacks two panels, each
    ``aspect`` times as high as wide, rather than setting them side by side.

    Parameters
    ----------
    rows
        Number of panels stacked vertically (a positive integer).
    aspect
        Height / width of one panel (positive).
    width
        Figure width (in); the default fills the text column.

    Raises
    ------
    ValueError
        If ``rows`` is not a positive integer, or ``aspect`` or ``width`` is not positive.
    """
    if isinstance(rows, bool) or not isinstance(rows, (int, np.integer)) or rows < 1:
        raise InputError(f"rows = {rows!r} is not allowed: give the number of stacked panels, an integer >= 1")
    for name, value in (("aspect", aspect), ("width", width)):
        if not (isinstance(value, (int, float, np.floating)) and np.isfinite(value) and value > 0):
            raise InputError(f"{name} = {value!r} is not allowed: give a positive number")
    return (float(width), float(width * aspect * rows))


def legend_outside(ax: Axes, where: str = "right", **kwargs: Any) -> Any:
    """A legend beside (``"right"``) or below (``"below"``) the axes, never over the data.

    ``legend_outside(ax)``; ``legend_outside(ax, "below", ncols=3)``.  Keyword arguments go to
    :meth:`matplotlib.axes.Axes.legend`.

    Raises
    ------
    ValueError
        If ``where`` is not ``"right"`` or ``"below"``.
    """
    if where == "right":
        place = {"loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0}
    elif where == "below":
        place = {"loc": "upper center", "bbox_to_anchor": (0.5, -0.18), "borderaxespad": 0.0}
        kwargs.setdefault("ncols", 2)
    else:
        raise InputError(f"where = {where!r} is not allowed: use 'right' or 'below'")
    return ax.legend(**{**place, **kwargs})


def _scalar(name: str, value: ArrayLike) -> float:
    a = np.asarray(value, float)
    if a.ndim != 0 or not np.isfinite(a):
        raise InputError(f"{name} = {value!r} is not allowed: draw_linkage draws one configuration, give one finite angle (rad)")
    return float(a)


def _mass_labels(params: Params) -> dict[str, str]:
    """Pin -> label of its lumped mass: the name of the [masses] entry it refers to ($m_{01}$
    for the paper's B), else $m_B$."""
    refs = params.values.get("linkage", {}).get("joints", {})
    out = {}
    for j, m in params.linkage.masses.items():
        if m <= 0:
            continue
        ref = refs.get(j, {}).get("mass")
        name = ref.split(".", 1)[1] if isinstance(ref, str) else j
        out[j] = f"$m_{{{name[1:] if name[:1] == 'm' and len(name) > 1 else name}}}$"
    return out


def draw_linkage(
    ax: Axes,
    params: Params,
    theta1: float,
    theta4: float | None = None,
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
    """Draw the linkage of the description (the five-bar of Figure 1) in one configuration.

    Any linkage of the description: its links, pins, ground pivots (a hatched triangle each),
    and each slider as a square block on its guide (a ground guide dashed).

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
        Crank angles (rad) of AB and ED: one configuration, scalars (``theta1`` alone for a
        linkage with one driven input; a driven slider's position in m).
    mode
        Assembly mode of :func:`fivebar.model.kinematics.positions`.
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
    fivebar.model.kinematics.GeometryError
        If the loop cannot close at these crank angles.
    """
    th = [_scalar("theta1", theta1)] + ([] if theta4 is None else [_scalar("theta4", theta4)])
    lk = params.linkage
    P = {k: scale * np.asarray(v) for k, v in positions(params, *th, mode=mode).items()}
    out: dict[str, Any] = {"links": {}, "joints": [], "ground": [], "masses": [], "labels": {}}
    # the chain form: its joints in order and the frame between its ends; any other linkage:
    # its joints, a ground symbol at each ground pivot and the guides of its sliders
    chain = lk.chain if lk.chain is not None else tuple(j.name for j in lk.joints)
    pivots = (chain[0], chain[-1]) if lk.chain is not None else tuple(j.name for j in lk.ground)
    centre = np.mean([P[k] for k in chain], axis=0)
    frame_name = f"L{len(lk.links) + 1}" if all(k.name == f"L{i + 1}" for i, k in enumerate(lk.links)) else "frame"
    colors = link_colors(lk)
    colors[frame_name] = LINK_COLORS["L5"]

    if ground:
        if lk.chain is not None:
            (frame,) = ax.plot(*np.transpose([P[pivots[0]], P[pivots[1]]]), ls="--", lw=1.0, color=LINK_COLORS["L5"],
                               zorder=zorder - 0.5)
            out["links"][frame_name] = frame
        size = 0.08 * scale * lk.lengths[-1]
        for k in pivots:
            x, y = P[k]
            tri = np.array([[x, y], [x - size / 2, y - size], [x + size / 2, y - size]])
            out["ground"].append(ax.fill(*tri.T, facecolor="none", edgecolor="0.2", lw=1.0, hatch="///", zorder=zorder - 0.5)[0])
        span = 0.6 * scale * max(k.length for k in lk.links)
        for j in lk.sliders:  # a ground guide: a dashed line through the slider along the guide
            if j.guide.link is None:
                d = span * j.guide.direction
                out["ground"].append(ax.plot(*np.transpose([P[j.name] - d, P[j.name] + d]), ls="--", lw=1.0,
                                             color=LINK_COLORS["L5"], zorder=zorder - 0.5)[0])
    for name, (s, e) in lk.link_ends.items():
        c = colors[name] if color is None else color
        (line,) = ax.plot(*np.transpose([P[s], P[e]]), color=c, lw=lw, alpha=alpha, solid_capstyle="round", zorder=zorder)
        out["links"][name] = line
    if joints:
        xy = np.array([P[k] for k in chain])
        out["joints"].append(
            ax.scatter(*xy.T, s=28, facecolor="white", edgecolor="black", linewidth=1.0, alpha=alpha, zorder=zorder + 1)
        )
        for j in lk.sliders:  # the slider block
            out["joints"].append(ax.scatter(*P[j.name], s=160, marker="s", facecolor="none", edgecolor="black",
                                            linewidth=1.0, alpha=alpha, zorder=zorder + 0.8))
    # joint labels sit outside the loop, in the direction from its centre to the joint
    away = {k: (P[k] - centre) / (np.hypot(*(P[k] - centre)) or 1.0) for k in chain}
    if masses:
        for k, name in _mass_labels(params).items():
            out["masses"].append(ax.scatter(*P[k], s=110, color="black", alpha=alpha, zorder=zorder + 0.5))
            if labels:  # beside the joint, square to its letter, on the right
                side = np.array([away[k][1], -away[k][0]])
                side = side if side[0] >= 0 else -side
                out["labels"][name] = ax.annotate(
                    name, P[k], xytext=tuple(12 * side + (4, 0)), textcoords="offset points",
                    ha="left", va="center", fontsize=MIN_FONT_PT,
                )
    if labels:
        for k in chain:
            out["labels"][k] = ax.annotate(
                k, P[k], xytext=tuple(16 * away[k]), textcoords="offset points", ha="center", va="center", fontweight="bold"
            )
        ends = dict(lk.link_ends, **({frame_name: pivots} if lk.chain is not None else {}))
        for name, (s, e) in ends.items():
            # the frame's label sits at 3/4 of AE, clear of B at theta1 = 0 when L1 = L5/2
            mid = P[s] + (0.75 if name == frame_name else 0.5) * (P[e] - P[s])
            t = (P[e] - P[s]) / np.hypot(*(P[e] - P[s]))
            n = np.array([-t[1], t[0]])
            if np.dot(n, mid - centre) < 0:
                n = -n
            text = f"$L_{name[1:]}$" if name[:1] == "L" and name[1:].isdigit() else name
            out["labels"][name] = ax.annotate(
                text, mid, xytext=tuple((20 if name == frame_name else 12) * n), textcoords="offset points", ha="center", va="center",
                color=colors[name] if color is None else color,
            )
    if labels:  # the labels lie outside the joints' bounding box, leave room for them
        ax.margins(0.1)
    ax.set_aspect("equal")
    return out


def campbell_plot(data, ax=None, *, mark: bool = True, effective: bool = True, legend: str | None = "below"):
    r"""Draw a Campbell diagram from :func:`fivebar.analyses.resonance.campbell_data`.

    ``ax = campbell_plot(campbell_data(params, speeds))``.  Each mode is a band from the lowest
    to the highest instantaneous frequency over a turn with its mean (3.3) as a line; the load
    harmonics :math:`k\Omega` (k = 1..m) are straight lines through the origin; ``mark``
    circles their crossings with each mean (the primary and superharmonic resonance speeds of
    :func:`fivebar.analyses.resonance.resonance_speeds`).  ``effective`` adds the effective frequencies
    :math:`\sqrt{\bar\omega_r^2 + h_r\Omega^2}` as dashed curves, their crossings as filled
    dots.  In the book's style: axis labels from :data:`LABELS`, text at :data:`MIN_FONT_PT`,
    the legend outside the data (``legend`` = ``"below"`` or ``"right"``, see
    :func:`legend_outside`; ``None`` draws none).  Returns the matplotlib Axes.
    """
    import matplotlib.pyplot as plt

    x, lo, mean, hi, h = data.speeds_rpm, data.low, data.mean, data.high, data.spin_softening
    if ax is None:
        _, ax = plt.subplots(figsize=figsize(aspect=0.6))
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
    last_top = None  # the rays that leave through the top crowd: label one every 8 % of the width
    for k in range(1, data.harmonics + 1):
        ax.plot(xs, k * xs / 60, color="0.4", lw=0.8, ls=":")
        xe = min(x.max(), hi.max() * 1.15 * 60 / k)
        crowded = xe < x.max() and last_top is not None and last_top - xe < 0.08 * (x.max() - x.min())
        if not crowded:
            last_top = xe if xe < x.max() else last_top
            ax.annotate(f"${k}\\Omega$", (xe, k * xe / 60), fontsize=MIN_FONT_PT, color="0.3", xytext=(2, 0),
                        textcoords="offset points")
        if mark:
            ax.plot(*data.crossings_rpm(k), "o", mfc="none", mec="k", ms=6)
            if effective:
                ax.plot(*data.crossings_rpm(k, effective=True), "o", color="k", ms=4)
    ax.set_xlim(x.min(), x.max())
    ax.set_ylim(0, hi.max() * 1.15)
    ax.set_xlabel(LABELS["crank_speed"])
    ax.set_ylabel(LABELS["frequency"])
    if legend is not None:
        legend_outside(ax, legend)
    return ax


@analysis
def campbell_diagram(
    setup: Setup | Params,
    speeds_rpm: ArrayLike,
    *,
    n_modes: int = 3,
    harmonics: int | None = None,
    ax: Axes | None = None,
    mark: bool = True,
    effective: bool = True,
) -> Axes:
    """Campbell diagram in one call: :func:`fivebar.analyses.resonance.campbell_data` drawn by
    :func:`campbell_plot` (see both).  Returns the matplotlib Axes."""
    from ..analyses.resonance import campbell_data

    data = campbell_data(setup, speeds_rpm, n_modes=n_modes, harmonics=harmonics)
    return campbell_plot(data, ax=ax, mark=mark, effective=effective)


def response_plot(response, links=None, direction: str = "transverse", ax=None, **kwargs):
    r"""Draw the midpoint displacements of ``links`` of a response, in micrometres, against the
    crank angle.

    ``response`` is anything with ``params``, ``method``,
    ``crank_angle_deg`` and ``midpoint_mm`` (a :class:`fivebar.analyses.response.Response`, a
    :class:`fivebar.analyses.steady.SteadyState`, a :class:`fivebar.analyses.multibody.MultibodySteadyState`);
    ``links`` default to the description's couplers (L2 and L3 of the five-bar, as Figure 6);
    ``direction`` as :meth:`fivebar.analyses.response.Response.midpoint_mm`; ``kwargs`` go to
    ``Axes.plot``.  Returns the matplotlib Axes.
    """
    import matplotlib.pyplot as plt

    linkage = response.params.linkage
    links = tuple(linkage.couplers) if links is None else (links,) if isinstance(links, str) else tuple(links)
    if ax is None:
        _, ax = plt.subplots(figsize=figsize())
    x = response.crank_angle_deg
    for link in links:
        ax.plot(x, 1e3 * response.midpoint_mm(link, direction), label=f"{link} ({response.method})", **kwargs)
    ax.set_xlabel(LABELS["crank_angle"])
    ax.set_ylabel(f"midpoint, {direction} ($\\mu$m)")
    ax.legend()
    return ax
