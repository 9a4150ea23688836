"""Animations of the linkage and of its modes that work offline in the HTML book.

Computing and drawing are apart: :func:`linkage_frames` and :func:`mode_frames` return the
points to draw (mm), :func:`animate_linkage` and :func:`animate_modes` render them with
matplotlib into an :class:`Animation`: PNG frames and a small self-contained player
(play/pause, step, a slider) written by :meth:`Animation.to_html`.  Nothing is loaded from
another host.  (Matplotlib's own ``FuncAnimation.to_jshtml`` page loads its button icons
from a CDN, and an HTML5 video needs ffmpeg, which the build machine does not have.)

In a notebook, :func:`show` writes the page next to the notebook and displays a fixed
``<iframe>`` snippet: the stored output does not depend on the frames' bytes, so nbval's
strict comparison passes on a re-run, and the notebook stays small.
"""

from __future__ import annotations

import base64
import html
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, checked
from ..model.kinematics import crank_laws, positions
from ..description.setup import Setup
from ..description.params import Params
from ..analyses.response import Response

__all__ = [
    "Animation",
    "LinkageFrames",
    "ModeFrames",
    "linkage_frames",
    "mode_frames",
    "animate_linkage",
    "animate_modes",
    "show",
    "Shown",
    "nice_scale",
]

_POINTS = 21


def nice_scale(x: float) -> float:
    """The largest number 1, 2 or 5 times a power of ten not above ``x`` (> 0)."""
    if not (x > 0 and math.isfinite(x)):
        raise InputError(f"x = {x!r} is not allowed: give a positive finite number")
    e = math.floor(math.log10(x))
    for m in (5, 2, 1):
        if m * 10.0**e <= x * (1 + 1e-12):
            return m * 10.0**e
    return 10.0**e  # pragma: no cover


def _coupler_length(params: Params) -> float:
    """The length (m) of the description's first coupler (L2 of the five-bar): the drawings'
    scale."""
    lk = params.linkage
    return lk.link(lk.couplers[0]).length


def _check_frames(frames: int) -> int:
    if isinstance(frames, bool) or int(frames) != frames or not 2 <= frames <= 400:
        raise InputError(f"frames = {frames!r} is not allowed: give an integer from 2 to 400")
    return int(frames)


def _shapes(model, U: NDArray, theta: tuple[NDArray, ...], points: int) -> tuple[dict, dict]:
    """Rigid and elastic points (m) of every link of the description: rigid (F, points, 2),
    elastic (F, points, 2); ``theta`` the angles of the driven cranks (F,) each."""
    P = positions(model.params, *theta)
    rigid, elastic = {}, {}
    for link, (a, b) in model.params.linkage.link_ends.items():
        d = P[b] - P[a]  # (F, 2)
        e = d / np.linalg.norm(d, axis=-1, keepdims=True)
        n = np.stack([-e[:, 1], e[:, 0]], axis=-1)
        s = np.linspace(0.0, 1.0, points)
        rigid[link] = P[a][:, None, :] + s[None, :, None] * d[:, None, :]
        el = np.empty_like(rigid[link])
        for j, sj in enumerate(s):
            ax, tr = model.link_displacement(U, *theta, link, float(sj))
            el[:, j] = ax[:, None] * e + tr[:, None] * n
        elastic[link] = el
    return rigid, elastic


@dataclass(frozen=True)
class LinkageFrames:
    """The deformed linkage over one crank turn, ready to draw.

    ``crank_angle_deg`` (frames); ``rigid_mm`` and ``deformed_mm``: link -> (frames, points, 2)
    in mm, ``deformed_mm`` = rigid + ``scale`` x elastic displacement; ``peak_mm`` the largest
    elastic displacement of any point over the turn (mm, unscaled).
    """

    crank_angle_deg: NDArray
    rigid_mm: dict[str, NDArray]
    deformed_mm: dict[str, NDArray]
    scale: float
    peak_mm: float


@checked
def linkage_frames(steady: Response, scale: float | None = None, frames: int = 48, points: int = _POINTS) -> LinkageFrames:
    """The linkage over one steady period with its elastic deflection times ``scale``.

    Parameters
    ----------
    steady : Response
        A steady state (:func:`fivebar.analyses.branches.steady_state`), or any
        :class:`~fivebar.analyses.response.Response` over one period.
    scale
        Magnification of the elastic displacement; ``None`` chooses the 1-2-5 number that
        draws the largest displacement at about 8 % of the length of the first coupler (L2 of
        the five-bar).
    frames
        Frames over the period (equally spaced samples of the steady state).
    points
        Points drawn along each link.
    """
    F = _check_frames(frames)
    if scale is not None and not (np.isfinite(scale) and scale > 0):
        raise InputError(f"scale = {scale!r} is not allowed: give a positive magnification or None")
    dyn = steady.dynamics
    S = len(steady.t) - 1
    idx = np.round(np.arange(F) * S / F).astype(int)
    rigid, elastic = _shapes(dyn.model, dyn.expand(steady.u[idx]), dyn.crank_angles(steady.t[idx]), points)
    peak = max(float(np.linalg.norm(v, axis=-1).max()) for v in elastic.values())
    if scale is None:
        scale = nice_scale(0.08 * _coupler_length(dyn.params) / peak) if peak > 0 else 1.0
    deformed = {k: 1e3 * (rigid[k] + scale * elastic[k]) for k in rigid}
    return LinkageFrames(steady.crank_angle_deg[idx], {k: 1e3 * v for k, v in rigid.items()}, deformed,
                         float(scale), 1e3 * peak)


@dataclass(frozen=True)
class ModeFrames:
    """The lowest modes along the cycle, ready to draw.

    ``crank_angle_deg`` (frames); ``frequencies`` (Hz, frames x n); ``rigid_mm``: link ->
    (frames, points, 2) mm; ``shapes_mm``: list over modes of link -> (frames, points, 2) mm,
    the deformed linkage with the mode normalised to a largest displacement of
    ``amplitude_mm`` mm; ``curve_angle_deg`` (deg) and ``curve`` (Hz): the frequencies on a fine grid.
    """

    crank_angle_deg: NDArray
    frequencies: NDArray
    rigid_mm: dict[str, NDArray]
    shapes_mm: list[dict[str, NDArray]]
    amplitude_mm: float
    curve_angle_deg: NDArray
    curve: NDArray


@checked
def mode_frames(params: Params, n_modes: int = 3, frames: int = 36, points: int = _POINTS,
                motors: bool = True) -> ModeFrames:
    """The ``n_modes`` lowest mode shapes at ``frames`` crank angles over one turn of the first
    crank (AB of the five-bar).

    Each shape is normalised to a largest link displacement of 6 % of the first coupler's length
    (L2 of the five-bar) and its sign chosen to follow the previous frame (mode shapes have no
    sign of their own).  The modes
    are numbered by frequency at each angle; a whirl mode of the motors' rotors, which does not
    move the linkage, is passed over.
    """
    from ..model.assembly import build_model
    from ..analyses.modal import frequencies_along_cycle, modes

    F = _check_frames(frames)
    if isinstance(n_modes, bool) or int(n_modes) != n_modes or not 1 <= n_modes <= 6:
        raise InputError(f"n_modes = {n_modes!r} is not allowed: give an integer number of modes from 1 to 6")
    n = int(n_modes)
    phi = np.arange(F) * 2 * np.pi / F
    theta = crank_laws(params, phi / params.crank_speed_rad_s)[0::3]  # the angle of each driven crank
    model = build_model(params, motors=motors)
    # the rotors' whirl (their transverse DOFs) does not couple to the links: a whirl mode among the
    # lowest does not move the linkage and is passed over (the heavy rotor on a thin shaft of
    # examples/params/motors_shafts.toml whirls at 364 Hz, below the third linkage mode)
    rotor = [d for dofs in model.motor_dofs.values() for d in dofs[:2]]
    links = np.setdiff1d(np.arange(model.n), rotor)

    def linkage_modes(angles) -> tuple[NDArray, NDArray, bool]:
        """The n lowest modes that move the linkage, and whether a whirl mode was passed over."""
        m = modes(params, *angles, n_modes=n, model=model)
        if (np.linalg.norm(m.shapes[links], axis=0) > 0).all():
            return m.frequencies, m.shapes, False
        m = modes(params, *angles, n_modes=min(n + len(rotor), model.n), model=model)
        keep = np.flatnonzero(np.linalg.norm(m.shapes[links], axis=0) > 0)[:n]
        return m.frequencies[keep], m.shapes[:, keep], True

    f = np.empty((F, n))
    V = np.empty((F, model.n, n))
    whirl = False
    for i in range(F):
        f[i], V[i], passed = linkage_modes(tuple(float(a[i]) for a in theta))
        whirl = whirl or passed
        if i:
            V[i] *= np.sign(np.einsum("jk,jk->k", V[i], V[i - 1]) + 1e-300)
    rigid = None
    shapes = []
    amplitude = 0.06 * _coupler_length(params)
    for k in range(n):
        r, el = _shapes(model, V[:, :, k], theta, points)
        rigid = r if rigid is None else rigid
        peak = np.max([np.linalg.norm(v, axis=-1).max(axis=1) for v in el.values()], axis=0)  # (F,)
        shapes.append({L: 1e3 * (r[L] + (amplitude / peak)[:, None, None] * el[L]) for L in r})
    grid = np.linspace(0.0, 2 * np.pi, 145)
    if whirl:  # the linkage's frequencies, the whirl passed over as above
        th = crank_laws(params, grid / params.crank_speed_rad_s)[0::3]
        curve = np.array([linkage_modes(tuple(float(a[i]) for a in th))[0] for i in range(grid.size)])
    else:
        curve = frequencies_along_cycle(Setup(params, motors=motors), grid, n_modes=n)
    return ModeFrames(np.degrees(phi), f, {k: 1e3 * v for k, v in rigid.items()}, shapes,
                      1e3 * amplitude, np.degrees(grid), curve)


# --------------------------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Animation:
    """PNG frames and how to play them.

    ``frames`` (PNG bytes), ``interval_ms`` (ms between frames), ``title`` (text of the page),
    ``width``, ``height`` (px of a frame).  :meth:`to_html` gives a self-contained page,
    :meth:`save` writes it, :attr:`nbytes` is its size.
    """

    frames: tuple[bytes, ...]
    interval_ms: int
    title: str
    width: int
    height: int

    def to_html(self) -> str:
        """A self-contained HTML page: the frames as data URIs and a small player."""
        imgs = ",\n".join('"data:image/png;base64,' + base64.b64encode(b).decode("ascii") + '"' for b in self.frames)
        return _PAGE.format(title=html.escape(self.title), frames=imgs, n=len(self.frames) - 1,
                            interval=int(self.interval_ms), width=self.width, height=self.height)

    @property
    def nbytes(self) -> int:
        """Size of :meth:`to_html` in bytes."""
        return len(self.to_html().encode("utf-8"))

    def save(self, path: str | Path) -> Path:
        """Write :meth:`to_html` to ``path`` (directories created); return the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(self.to_html(), encoding="utf-8")
        return path


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ margin: 0; font: 14px sans-serif; background: #fff; }}
img {{ display: block; max-width: 100%; height: auto; }}
.bar {{ display: flex; gap: 6px; align-items: center; padding: 4px 2px; }}
button {{ min-width: 2.4em; font-size: 14px; }}
input[type=range] {{ flex: 1; }}
</style></head><body>
<img id="frame" width="{width}" height="{height}" alt="{title}">
<div class="bar">
<button id="prev" title="previous frame" aria-label="previous frame">&#9664;&#9646;</button>
<button id="play" title="play / pause" aria-label="play or pause">&#10074;&#10074;</button>
<button id="next" title="next frame" aria-label="next frame">&#9646;&#9654;</button>
<input id="slider" type="range" min="0" max="{n}" value="0" aria-label="frame">
<span id="label">1</span>
</div>
<script>
const frames = [
{frames}
];
const img = document.getElementById("frame"), slider = document.getElementById("slider");
const label = document.getElementById("label"), play = document.getElementById("play");
let k = 0, timer = null;
function show(i) {{ k = (i + frames.length) % frames.length; img.src = frames[k];
  slider.value = k; label.textContent = (k + 1) + " / " + frames.length; }}
function start() {{ if (!timer) {{ timer = setInterval(() => show(k + 1), {interval});
  play.innerHTML = "&#10074;&#10074;"; }} }}
function stop() {{ if (timer) {{ clearInterval(timer); timer = null; play.innerHTML = "&#9654;"; }} }}
play.onclick = () => (timer ? stop() : start());
document.getElementById("prev").onclick = () => {{ stop(); show(k - 1); }};
document.getElementById("next").onclick = () => {{ stop(); show(k + 1); }};
slider.oninput = () => {{ stop(); show(parseInt(slider.value, 10)); }};
show(0);
if (!window.matchMedia("(prefers-reduced-motion: reduce)").matches) start(); else stop();
</script></body></html>
"""


def _render(fig, update, count: int, dpi: int, moving: list) -> tuple[tuple[bytes, ...], int, int]:
    """The ``count`` frames of ``fig`` as PNG bytes, ``update(i)`` setting frame ``i``.

    Only the ``moving`` artists (those ``update`` changes) are drawn again for each frame, over
    the rest drawn once (blitting: the axes, ticks, labels and legend are the same in every
    frame); a frame is the figure's whole canvas, so every frame has the same size.  Drawing
    every frame whole (``savefig``) took 77 ms a frame of the linkage's animation, this 15 ms
    (its 48 frames 3.7 s -> 0.7 s, an idle machine, 2026-12-04)."""
    from matplotlib.text import Text
    from PIL import Image

    fig.set_dpi(dpi)
    engine = fig.get_layout_engine()
    if engine is not None and hasattr(engine, "set"):
        engine.set(w_pad=0.1, h_pad=0.1)  # a margin of 0.1 in, as savefig's tight box gave
    texts = [a for a in moving if isinstance(a, Text)]

    def characters(i: int) -> int:
        update(i)
        return sum(len(t.get_text()) for t in texts)

    update(max(range(count), key=characters))  # laid out with the longest titles of the frames
    fig.canvas.draw()  # lay out once (constrained), then keep the positions
    fig.set_layout_engine("none")
    for artist in moving:
        artist.set_animated(True)  # left out of the figure's own drawing
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    w, h = fig.canvas.get_width_height()
    out = []
    for i in range(count):
        update(i)
        fig.canvas.restore_region(background)
        for artist in moving:
            fig.draw_artist(artist)
        buf = io.BytesIO()
        Image.frombuffer("RGBA", (w, h), fig.canvas.buffer_rgba(), "raw", "RGBA", 0, 1).save(buf, format="png")
        out.append(buf.getvalue())
    return tuple(out), int(w), int(h)


def _limits(ax, arrays, pad: float = 0.06) -> None:
    xy = np.concatenate([a.reshape(-1, 2) for a in arrays])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = hi - lo
    ax.set_xlim(lo[0] - pad * span[0], hi[0] + pad * span[0])
    ax.set_ylim(lo[1] - pad * span[1], hi[1] + pad * span[1])
    ax.set_aspect("equal", adjustable="box")


@checked
def animate_linkage(steady: Response, scale: float | None = None, frames: int = 48, dpi: int = 72,
                    interval_ms: int = 80) -> Animation:
    """The linkage over one crank turn, its elastic deflection magnified ``scale`` times.

    ``anim = animate_linkage(fivebar.steady_state(params))``; ``show(anim, "anim/x.html")``
    in a notebook.  The magnification is in the title; the rigid linkage is drawn in grey
    beneath.  See :func:`linkage_frames` for ``scale`` and ``frames``; ``interval_ms`` is the
    time between frames (ms).
    """
    import matplotlib.pyplot as plt

    from .plotting import link_colors

    data = linkage_frames(steady, scale, frames)
    fig, ax = plt.subplots(figsize=(5.0, 4.2), layout="constrained")
    try:
        _limits(ax, list(data.rigid_mm.values()) + list(data.deformed_mm.values()))
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ground = [1e3 * np.asarray(j.at) for j in steady.dynamics.params.linkage.ground]
        ax.plot(*np.transpose(ground), "--", color="0.5", lw=1)
        ghosts = {k: ax.plot([], [], color="0.75", lw=1.2)[0] for k in data.rigid_mm}
        colors = link_colors(steady.dynamics.params.linkage)
        lines = {k: ax.plot([], [], color=colors[k], lw=2.2, label=k)[0] for k in data.deformed_mm}
        joints = ax.plot([], [], "o", ms=4, mfc="white", mec="black")[0]
        ax.legend(loc="upper right", ncols=4, fontsize=8)
        title = ax.set_title("")

        def update(i: int) -> None:
            for k in data.rigid_mm:
                ghosts[k].set_data(*data.rigid_mm[k][i].T)
                lines[k].set_data(*data.deformed_mm[k][i].T)
            ends = np.array([data.deformed_mm[k][i][[0, -1]] for k in data.deformed_mm]).reshape(-1, 2)
            joints.set_data(*ends.T)
            title.set_text(f"elastic deflection × {data.scale:g} (peak {1e3 * data.peak_mm:.0f} µm);  "
                           f"crank angle {data.crank_angle_deg[i]:.0f}°")

        moving = [*ghosts.values(), *lines.values(), joints, title]
        png, w, h = _render(fig, update, len(data.crank_angle_deg), dpi, moving)
    finally:
        plt.close(fig)
    return Animation(png, interval_ms, f"Linkage over one crank turn, elastic deflection x {data.scale:g}", w, h)


@checked
def animate_modes(params: Params, n_modes: int = 3, frames: int = 36, dpi: int = 64, interval_ms: int = 120,
                  motors: bool = True) -> Animation:
    """The ``n_modes`` lowest mode shapes and their frequencies along one crank turn.

    One panel per mode (the linkage deformed by the mode, normalised, over the rigid linkage
    in grey) and, below, the frequencies along the cycle with the current angle marked;
    ``interval_ms`` is the time between frames (ms).
    """
    import matplotlib.pyplot as plt

    from .plotting import PALETTE, link_colors

    data = mode_frames(params, n_modes, frames, motors=motors)
    colors = link_colors(params.linkage)
    n = int(n_modes)
    fig = plt.figure(figsize=(6.5, 4.4), layout="constrained")
    grid = fig.add_gridspec(2, n, height_ratios=[1.3, 1.0])
    axes = [fig.add_subplot(grid[0, k]) for k in range(n)] + [fig.add_subplot(grid[1, :])]
    try:
        arts = []
        for k in range(n):
            ax = axes[k]
            _limits(ax, list(data.rigid_mm.values()) + [v for s in data.shapes_mm for v in s.values()])
            ax.set_xticks([])
            ax.set_yticks([])
            ax.grid(False)
            ghosts = {L: ax.plot([], [], color="0.75", lw=1.2)[0] for L in data.rigid_mm}
            lines = {L: ax.plot([], [], color=colors[L], lw=2.0)[0] for L in data.rigid_mm}
            arts.append((ax.set_title(""), ghosts, lines))
        axc = axes[n]
        for k in range(n):
            axc.plot(data.curve_angle_deg, data.curve[:, k], color=PALETTE[k], lw=1.5, label=f"mode {k + 1}")
        marker = axc.axvline(0.0, color="0.3", lw=1)
        dots = axc.scatter(np.zeros(n), data.frequencies[0], color=PALETTE[:n], zorder=3, s=18)
        axc.set_xlim(0, 360)
        axc.set_xticks(range(0, 361, 60))
        axc.set_yscale("log")
        axc.set_xlabel("crank angle of AB (deg)")
        axc.set_ylabel("frequency (Hz)")
        axc.legend(loc="upper right", ncols=n, fontsize=8)
        sup = fig.suptitle("", fontsize=10)

        def update(i: int) -> None:
            for k, (title, ghosts, lines) in enumerate(arts):
                for L in data.rigid_mm:
                    ghosts[L].set_data(*data.rigid_mm[L][i].T)
                    lines[L].set_data(*data.shapes_mm[k][L][i].T)
                title.set_text(f"mode {k + 1}: {data.frequencies[i, k]:.1f} Hz")
            sup.set_text(f"crank angle {data.crank_angle_deg[i]:.0f}°; each shape normalised to a "
                         f"largest displacement of {data.amplitude_mm:.0f} mm")
            marker.set_xdata([data.crank_angle_deg[i]] * 2)
            dots.set_offsets(np.column_stack([np.full(n, data.crank_angle_deg[i]), data.frequencies[i]]))

        moving = [a for title, ghosts, lines in arts for a in (*ghosts.values(), *lines.values(), title)]
        moving += [sup, marker, dots]
        png, w, h = _render(fig, update, len(data.crank_angle_deg), dpi, moving)
    finally:
        plt.close(fig)
    return Animation(png, interval_ms, f"The {n} lowest modes along one crank turn", w, h)


class Shown:
    """What :func:`show` displays: the player in an ``<iframe>`` on a web page, a strip of its
    frames in a printed book (the PDF), one line of text elsewhere.

    Its mime bundle (``_repr_mimebundle_``) holds ``text/html`` (the iframe, whose size keeps
    the frames' aspect on any screen), ``image/png`` (:meth:`strip`: a few frames side by side,
    which the book's LaTeX build prints where the animation is) and ``text/plain`` (a line that
    names the animation, not the object's repr).  The HTML names only the file and the frame
    size, so it is the same on every run; the strip is an image, which the notebooks' strict
    comparison leaves out.
    """

    def __init__(self, anim: Animation, src: str, width: int, frames_in_strip: int = 4) -> None:
        self.anim, self.src, self.width, self.count = anim, src, int(width), int(frames_in_strip)

    @property
    def html(self) -> str:
        """The iframe and a link to the animation's own page."""
        a = self.anim
        h = int(round(a.height * self.width / a.width)) + 44  # the player's button bar
        return (f'<iframe class="fivebar-animation" src="{html.escape(self.src)}" width="{self.width}" height="{h}" '
                f'style="border:0; max-width:100%; height:auto; aspect-ratio:{self.width} / {h}" loading="lazy" '
                f'title="{html.escape(a.title)}"></iframe>\n'
                f'<p class="fivebar-animation-link"><a href="{html.escape(self.src)}">Open the animation on its own '
                'page</a></p>')

    def strip(self) -> bytes:
        """PNG: ``frames_in_strip`` frames of the animation, evenly spaced over it, side by side."""
        import matplotlib
        import matplotlib.image as mpimg
        from matplotlib.figure import Figure

        n = max(1, min(self.count, len(self.anim.frames)))
        picks = [round(k * len(self.anim.frames) / n) for k in range(n)]
        fig = Figure(figsize=(6.5, 6.5 / n * self.anim.height / self.anim.width + 0.35), dpi=150,
                     layout="none")  # the book's style turns constrained layout on; placed by hand here
        for k, i in enumerate(picks):
            ax = fig.add_subplot(1, n, k + 1)
            ax.imshow(mpimg.imread(io.BytesIO(self.anim.frames[i]), format="png"))
            ax.set_axis_off()
            ax.set_title(f"frame {i + 1} of {len(self.anim.frames)}", fontsize=8)
        fig.subplots_adjust(left=0.01, right=0.99, bottom=0.01, top=0.9, wspace=0.04)
        buf = io.BytesIO()
        with matplotlib.rc_context({"savefig.bbox": "tight"}):
            fig.savefig(buf, format="png")
        return buf.getvalue()

    def _repr_mimebundle_(self, include=None, exclude=None):
        return {"text/html": self.html, "image/png": self.strip(),
                "text/plain": f"Animation: {self.anim.title} ({len(self.anim.frames)} frames)"}


def show(anim: Animation, path: str | Path, width: int | None = None) -> Shown:
    """Write ``anim`` to ``path`` (relative to the notebook) and display it.

    On the web page an iframe plays it (its size keeps the frames' aspect on a phone too); in
    the PDF a strip of its frames stands in for it (:class:`Shown`).  The displayed HTML names
    only the file and the frame size, so it is the same on every run (nbval compares it
    strictly).  The book's build copies the file next to the page
    (``book/_ext/fivebar_teaching.py``).
    """
    path = Path(path)
    if path.is_absolute() or ".." in path.parts or path.suffix != ".html":
        raise InputError(f"path = {str(path)!r} is not allowed: give a relative path ending in .html "
                         "below the notebook's folder (e.g. 'anim/linkage.html')")
    anim.save(path)
    w = anim.width if width is None else int(width)
    return Shown(anim, path.as_posix(), w)
