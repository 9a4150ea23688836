r"""Resonance conditions of section 3 and the Campbell diagram of the linkage.

Section 3 lists six conditions under which the multiple-scales analysis of (3.4) finds a
resonance.  With :math:`\omega_r` the natural frequencies (the paper's means (3.3)),
:math:`\nu_p` the excitation frequencies of (2.10) and a relative tolerance :math:`\epsilon`
(``tolerance``), :func:`classify` reports every one that holds:

1. *primary*: :math:`\nu_p \approx \omega_r`;
2. *superharmonic* (the paper's "ultra-harmonic"): :math:`\omega_r \approx k\nu_p`,
   :math:`k \ne 1`;
3. *subharmonic*: :math:`\omega_r \approx \nu_p/2` or :math:`\nu_p/3` (and, because the load
   holds the harmonics :math:`k\nu_p` of (2.10), :math:`\omega_r \approx k\nu_p/2, k\nu_p/3`);
4. *internal*: :math:`\omega_s \approx \omega_t + \omega_u` (with :math:`t = u` the 2:1
   resonance :math:`\omega_s \approx 2\omega_t`), and the 3:1 resonance
   :math:`\omega_s \approx 3\omega_t` of the cubic terms;
5. *combination*: :math:`\omega_r \approx |\pm j\nu_p \pm k\nu_q|` or
   :math:`|\pm 2j\nu_p \pm k\nu_q|` for two different excitation frequencies;
6. *multiple*: two or more of the above at once (one extra row listing them).

A relative detuning :math:`|\text{excitation side}/\text{natural side} - 1| \le \epsilon`
counts.  Two remarks for this linkage.  Its load is a periodic, non-sinusoidal function of the
crank angle, so (2.10) holds the harmonics :math:`k\Omega` with their own amplitudes, and the
"superharmonic" condition 2 is a *linear* resonance of mode r with the k-th harmonic of the load
(the nonlinear superharmonic resonance of a sinusoidally forced oscillator is the same
condition).  And its stiffness varies over the turn (chapter "Natural frequencies along the
cycle"), which the paper's constant-coefficient (3.4) leaves out: a periodic stiffness adds the
*parametric* resonances :math:`k\Omega \approx 2\omega_r` (principal) and
:math:`k\Omega \approx \omega_r \pm \omega_s` (combination), listed here as an extra type
``"parametric"`` (``parametric=True``).  The principal one coincides with the subharmonic
condition 3 of order 2.

For the linkage subsystem (:func:`resonance_table`) the only excitation is the crank
frequency :math:`\Omega = \nu_1 = \nu_2 = \nu_3` (equal speeds; the motors' field and rotor
frequencies act on the decoupled rotors, :func:`fivebar.model.excitation.excitation_frequencies`), its
harmonics run to :math:`m` = ``params.fourier_terms``, and the natural frequencies are the means
of the instantaneous frequencies of the linkage subsystem (without the rotor whirl modes).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from ..cache import memoised
from ..errors import FivebarError
from ..model.dynamics import LinkageDynamics
from ..model.excitation import excitation_frequencies
from ..description.params import Params
from ..description.setup import Setup, analysis, as_setup

__all__ = [
    "ResonanceError",
    "CampbellData",
    "campbell_data",
    "classify",
    "effective_frequencies",
    "linkage_frequencies",
    "resonance_speeds",
    "resonance_table",
    "spin_softening",
]

_TYPES = ("primary", "superharmonic", "subharmonic", "internal", "combination", "parametric", "multiple")
_CONDITION = {"primary": 1, "superharmonic": 2, "subharmonic": 3, "internal": 4, "combination": 5,
              "parametric": 0, "multiple": 6}
_COLUMNS = ["condition", "type", "mode", "excitation", "excitation (Hz)", "natural (Hz)",
            "detuning (Hz)", "relative detuning", "note"]


class ResonanceError(FivebarError, ValueError):
    r"""Bad input to the resonance functions (the message names the value)."""


def _positive(name: str, x: ArrayLike) -> NDArray:
    a = np.atleast_1d(np.asarray(x, float))
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise ResonanceError(f"{name} = {x!r} is not allowed: give positive finite frequencies (rad/s)")
    return a


def classify(
    natural: ArrayLike,
    excitations: Mapping[str, float],
    *,
    harmonics: int = 1,
    tolerance: float = 0.03,
    subharmonic_orders: Sequence[int] = (2, 3),
    internal: bool = True,
    parametric: bool = True,
) -> pd.DataFrame:
    r"""Which resonance conditions of section 3 hold.

    Parameters
    ----------
    natural : array_like (n,)
        Natural frequencies :math:`\omega_r` (rad/s); mode numbers are 1-based in the table.
    excitations : mapping name -> float
        Excitation frequencies :math:`\nu_p` (rad/s), e.g. ``{"nu1": Omega}``.
    harmonics : int
        Highest harmonic k (and j) of each excitation, m of (2.10).
    tolerance : float
        Relative detuning that still counts as resonant, > 0.
    subharmonic_orders : sequence of int
        n of :math:`\omega_r \approx k\nu_p/n` (section 3: 2 and 3).
    internal, parametric : bool
        Include the internal (4) and the parametric conditions.

    Returns
    -------
    pandas.DataFrame
        One row per condition that holds, sorted by condition then |relative detuning|;
        columns ``condition`` (1-6 as in section 3, 0 for parametric), ``type``, ``mode``,
        ``excitation`` (e.g. "3 nu1"), ``excitation (Hz)``, ``natural (Hz)`` (the natural side,
        e.g. :math:`2\omega_r` for the principal parametric resonance), ``detuning (Hz)``
        (excitation side minus natural side), ``relative detuning`` and ``note``.
    """
    w = _positive("natural", natural)
    if not isinstance(excitations, Mapping) or not excitations:
        raise ResonanceError(f"excitations = {excitations!r} is not allowed: give a non-empty mapping name -> rad/s")
    names = list(excitations)
    nu = _positive("excitations", [excitations[k] for k in names])
    if isinstance(harmonics, bool) or int(harmonics) != harmonics or harmonics < 1:
        raise ResonanceError(f"harmonics = {harmonics!r} is not allowed: give an integer >= 1")
    if not (np.isfinite(tolerance) and 0 < tolerance < 1):
        raise ResonanceError(f"tolerance = {tolerance!r} is not allowed: give a relative detuning in (0, 1)")
    m = int(harmonics)
    rows: list[tuple] = []

    def add(kind, mode, exc, fe, fn, note=""):
        rel = fe / fn - 1.0
        if abs(rel) <= tolerance:
            rows.append((_CONDITION[kind], kind, mode, exc, fe / (2 * np.pi), fn / (2 * np.pi),
                         (fe - fn) / (2 * np.pi), rel, note))

    for r, wr in enumerate(w, start=1):
        for name, f in zip(names, nu):
            for k in range(1, m + 1):
                kind = "primary" if k == 1 else "superharmonic"
                note = "" if k == 1 else f"harmonic {k} of the load drives mode {r} directly"
                add(kind, str(r), f"{k} {name}" if k > 1 else name, k * f, wr, note)
                for n in subharmonic_orders:
                    if k % n:
                        note = "also principal parametric (k nu ~ 2 omega)" if n == 2 else ""
                        add("subharmonic", str(r), f"{k} {name} / {n}" if k > 1 else f"{name} / {n}",
                            k * f / n, wr, note)
        # combination of two different excitation frequencies (equal ones give harmonics)
        for (p, fp), (q, fq) in itertools.permutations(zip(names, nu), 2):
            if np.isclose(fp, fq, rtol=1e-12):
                continue
            for j in range(1, m + 1):
                for jj in (j, 2 * j):
                    for k in range(1, m + 1):
                        for sign in (1, -1):
                            fe = abs(jj * fp + sign * k * fq)
                            if fe > 0:
                                add("combination", str(r), f"|{jj} {p} {'+' if sign > 0 else '-'} {k} {q}|", fe, wr)
    if internal:
        n = w.size
        for s in range(n):
            for t in range(n):
                for u in range(t, n):
                    if s in (t, u):
                        continue
                    lab = f"{s + 1} = {t + 1} + {u + 1}" if t != u else f"{s + 1} = 2 x {t + 1}"
                    add("internal", lab, "-", w[s], w[t] + w[u], "2:1" if t == u else "")
            for t in range(n):
                if t != s:
                    add("internal", f"{s + 1} = 3 x {t + 1}", "-", w[s], 3 * w[t], "3:1")
    if parametric:
        n = w.size
        for name, f in zip(names, nu):
            for k in range(1, m + 1):
                for r in range(n):
                    add("parametric", f"2 x {r + 1}", f"{k} {name}" if k > 1 else name, k * f, 2 * w[r],
                        "principal parametric (time-varying stiffness)")
                    for s in range(r + 1, n):
                        add("parametric", f"{r + 1} + {s + 1}", f"{k} {name}" if k > 1 else name, k * f,
                            w[r] + w[s], "summed combination parametric")
                        add("parametric", f"{s + 1} - {r + 1}", f"{k} {name}" if k > 1 else name, k * f,
                            w[s] - w[r], "difference combination parametric")
    df = pd.DataFrame(rows, columns=_COLUMNS)
    # one row per physical condition: the same frequency reached by different labels counts once
    key = df["excitation (Hz)"].round(9).astype(str) + df["natural (Hz)"].round(9).astype(str)
    df = df[~pd.DataFrame({"t": df["type"], "m": df["mode"], "k": key}).duplicated()]
    if len(df) >= 2:
        listed = "; ".join(f"{a} {b} (mode {c})" for a, b, c in zip(df["type"], df["excitation"], df["mode"]))
        extra = pd.DataFrame([(6, "multiple", "-", "-", np.nan, np.nan, np.nan, np.nan, listed)], columns=_COLUMNS)
        df = pd.concat([df, extra], ignore_index=True)
    order = np.lexsort((df["relative detuning"].abs().fillna(0).to_numpy(), df["condition"].replace(0, 5.5).to_numpy()))
    return df.iloc[order].reset_index(drop=True)


# --- the linkage --------------------------------------------------------------------------------
@memoised
def _modal_data(params: Params, n_modes: int, steps: int, motors: bool, elements_per_link) -> tuple[NDArray, NDArray]:
    from ..model.excitation import modal_basis

    dyn = LinkageDynamics(Setup(params, steps_per_period=steps, motors=motors, nonlinear=False,
                                elements_per_link=elements_per_link))
    B = modal_basis(dyn, n_modes)  # (frequencies and spin softening only)
    h = np.diag(B.kinematic_stiffness.mean(axis=0)) / params.crank_speed_rad_s**2
    # the frequencies by rank at every instant (3.3); h of the modes tracked by their shapes, which
    # keep their ranks unless two frequencies cross
    return np.sort(B.omega, axis=1), h


def _data(setup: Setup | Params, n_modes: int) -> tuple[NDArray, NDArray]:
    s = as_setup(setup)
    if isinstance(n_modes, bool) or int(n_modes) != n_modes or n_modes < 1:
        raise ResonanceError(f"n_modes = {n_modes!r} is not allowed: give a positive integer")
    # the configuration, hence the frequencies, do not depend on the speed: one cache entry
    key = s.params.replace(crank_speed_rpm=60.0)
    w, h = _modal_data(key, int(n_modes), s.steps_per_period, s.motors, s.elements_per_link)
    return w.copy(), h.copy()


@analysis
def linkage_frequencies(setup: Setup | Params, n_modes: int = 4) -> NDArray:
    r"""Instantaneous natural frequencies (rad/s) of the linkage subsystem over one period.

    The eigenvalues of :math:`\mathbf K(t)\boldsymbol\phi = \omega^2\mathbf M(t)
    \boldsymbol\phi` on the DOFs of :class:`fivebar.model.dynamics.LinkageDynamics` (the rotor
    whirl modes, which do not couple, are left out) at the S equally spaced crank angles of the
    problem (a :class:`fivebar.description.setup.Setup`, or a Params: S = ``params.steps_per_period``; its
    motors and mesh); they do not depend on the crank speed.  Shape (S, n_modes), ascending in
    each row; the means over axis 0 are the paper's (3.3).  Cached in memory.
    """
    return _data(setup, n_modes)[0]


@analysis
def spin_softening(setup: Setup | Params, n_modes: int = 4) -> NDArray:
    r"""The coefficients :math:`h_r = \bar H_{rr}/\Omega^2` of the kinematic stiffness (-).

    :math:`\mathbf H = \boldsymbol\Phi^\top\mathbf M\ddot{\boldsymbol\Phi}` of the
    instantaneous modes (:attr:`fivebar.model.excitation.ModalBasis.kinematic_stiffness`), averaged
    over the period and divided by :math:`\Omega^2` (it is proportional to it at constant crank
    speed).  About -1 for a mode whose shape turns with the cranks.  ``setup`` as for
    :func:`linkage_frequencies`.
    """
    return _data(setup, n_modes)[1]


@analysis
def effective_frequencies(setup: Setup | Params, n_modes: int = 4) -> NDArray:
    r"""Effective natural frequencies :math:`\sqrt{\bar\omega_r^2 + h_r\Omega^2}` (rad/s) at
    the problem's crank speed (``effective_frequencies(setup.replace(crank_speed_rpm=600))``).

    The paper's means (3.3) corrected by the mean kinematic stiffness (:func:`spin_softening`);
    NaN past the speed at which the mode's effective stiffness vanishes.
    """
    s = as_setup(setup)
    w, h = _data(s, n_modes)
    w2 = w.mean(axis=0) ** 2 + h * s.run_params.crank_speed_rad_s**2
    return np.sqrt(np.where(w2 > 0, w2, np.nan))


def _linkage_excitations(params: Params, crank_speed_rpm: float | None, motor_fields: bool,
                         supply: str) -> dict[str, float]:
    df = excitation_frequencies(params, crank_speed_rpm, supply)
    if not motor_fields:
        df = df[df["drives linkage"]]
    df = df.dropna(subset=["frequency (rad/s)"])
    out: dict[str, float] = {}
    for sym, f in zip(df.index, df["frequency (rad/s)"]):
        same = [k for k, v in out.items() if np.isclose(v, f, rtol=1e-12)]
        if same:
            out[f"{same[0]}={sym}"] = out.pop(same[0])
        else:
            out[sym] = float(f)
    return out


@analysis
def resonance_table(
    setup: Setup | Params,
    *,
    n_modes: int = 4,
    tolerance: float = 0.03,
    harmonics: int | None = None,
    motor_fields: bool = False,
    supply: str = "crank",
    frequencies: str = "mean",
    **kwargs,
) -> pd.DataFrame:
    r"""The resonance conditions of section 3 that hold for the linkage at the problem's crank speed.

    ``resonance_table(setup.replace(crank_speed_rpm=600))``; ``setup`` a
    :class:`fivebar.description.setup.Setup` (its crank speed, S, motors, mesh) or a Params (``Setup(params)``).

    Natural frequencies: the means (3.3) of the ``n_modes`` lowest instantaneous frequencies of
    the linkage subsystem (:func:`linkage_frequencies`).  Excitations: the frequencies of
    :func:`fivebar.model.excitation.excitation_frequencies` that drive the linkage (equal ones merged,
    e.g. "nu1=nu2=nu3"); ``motor_fields`` adds the motors' field frequencies (which drive only
    the decoupled rotors).  ``harmonics`` defaults to ``params.fourier_terms``.
    ``frequencies="effective"`` uses :func:`effective_frequencies` (spin softening) instead of
    the paper's means.  Other keyword arguments go to :func:`classify`.
    """
    s = as_setup(setup)
    p = s.run_params
    if frequencies == "mean":
        w = linkage_frequencies(s, n_modes).mean(axis=0)
    elif frequencies == "effective":
        w = effective_frequencies(s, n_modes)
        if np.any(np.isnan(w)):
            raise ResonanceError(f"at {p.crank_speed_rpm:g} r/min a mode's effective stiffness is negative "
                                 "(past its spin-softening limit): no effective frequency")
    else:
        raise ResonanceError(f"frequencies = {frequencies!r} is not allowed: use 'mean' or 'effective'")
    exc = _linkage_excitations(p, None, motor_fields, supply)
    m = p.fourier_terms if harmonics is None else harmonics
    return classify(w, exc, harmonics=m, tolerance=tolerance, **kwargs)


@analysis
def resonance_speeds(
    setup: Setup | Params,
    *,
    n_modes: int = 3,
    harmonics: int | None = None,
    subharmonic_orders: Sequence[int] = (2, 3),
    parametric: bool = True,
    frequencies: str = "mean",
    speed_range: tuple[float, float] | None = None,
) -> pd.DataFrame:
    r"""Crank speeds (r/min) at which the conditions of section 3 hold exactly (equal speeds).

    With :math:`\Omega` the crank frequency and :math:`w_r` the natural frequencies:
    primary and superharmonic :math:`k\Omega = w_r`; subharmonic :math:`k\Omega = n w_r`
    (k not a multiple of n); parametric :math:`k\Omega = w_r \pm w_s` (r < s; r = s is the
    subharmonic of order 2).  ``frequencies="mean"``: :math:`w_r = \bar\omega_r`, the paper's
    means (3.3); ``"effective"``: :math:`w_r(\Omega) = \sqrt{\bar\omega_r^2 + h_r\Omega^2}`
    (:func:`effective_frequencies`), which also adds, for :math:`h_r < 0`, the speed
    :math:`\bar\omega_r/\sqrt{-h_r}` at which the mode's effective stiffness vanishes (type
    "divergence").  ``setup``: the problem (its S, motors and mesh; its speed is not used), a
    :class:`fivebar.description.setup.Setup` or a Params.

    Returns
    -------
    pandas.DataFrame
        Columns ``speed (r/min)``, ``type``, ``mode``, ``k``, ``frequency (Hz)`` (of the
        resonant harmonic :math:`k\Omega`), sorted by speed; restricted to ``speed_range`` if
        given.
    """
    if frequencies not in ("mean", "effective"):
        raise ResonanceError(f"frequencies = {frequencies!r} is not allowed: use 'mean' or 'effective'")
    s = as_setup(setup)
    w, h = _data(s, n_modes)
    w = w.mean(axis=0)
    if frequencies == "mean":
        h = np.zeros_like(h)
    m = s.params.fourier_terms if harmonics is None else int(harmonics)
    lim = np.where(h < 0, w / np.sqrt(np.where(h < 0, -h, 1.0)), np.inf)  # divergence speeds (rad/s)

    def weff(r: int, W: float) -> float:
        return float(np.sqrt(max(w[r] ** 2 + h[r] * W**2, 0.0)))

    rows = []
    for r in range(w.size):
        for k in range(1, m + 1):
            rows.append((w[r] / np.sqrt(k**2 - h[r]), "primary" if k == 1 else "superharmonic", str(r + 1), k))
            for n in subharmonic_orders:
                if k % n:
                    rows.append((n * w[r] / np.sqrt(k**2 - n**2 * h[r]), "subharmonic", f"{r + 1} (1/{n})", k))
        if np.isfinite(lim[r]):
            rows.append((lim[r], "divergence", str(r + 1), 0))
    if parametric:
        for r, s in itertools.combinations(range(w.size), 2):
            top = min(lim[r], lim[s])
            for sign, lab in ((1, f"{r + 1} + {s + 1}"), (-1, f"{s + 1} - {r + 1}")):
                for k in range(1, m + 1):
                    def g(W, k=k, sign=sign):
                        return k * W - (weff(s, W) + sign * weff(r, W))
                    hi = top if np.isfinite(top) else 10 * (w[r] + w[s])
                    if g(0.0) < 0 < g(hi):
                        rows.append((scipy.optimize.brentq(g, 0.0, hi, xtol=1e-10), "parametric", lab, k))
    df = pd.DataFrame(rows, columns=["W", "type", "mode", "k"])
    df["speed (r/min)"] = df["W"] * 60 / (2 * np.pi)
    df["frequency (Hz)"] = df["W"] * df["k"] / (2 * np.pi)
    df = df.drop(columns="W")[["speed (r/min)", "type", "mode", "k", "frequency (Hz)"]]
    if speed_range is not None:
        lo, hi = speed_range
        df = df[(df["speed (r/min)"] >= lo) & (df["speed (r/min)"] <= hi)]
    return df.sort_values("speed (r/min)").reset_index(drop=True)


@dataclass(frozen=True)
class CampbellData:
    """The numbers of a Campbell diagram (:func:`campbell_data`); draw with
    :func:`fivebar.book.plotting.campbell_plot`.

    Attributes
    ----------
    speeds_rpm
        Crank speeds spanning the diagram (r/min).
    frequencies
        Instantaneous natural frequencies (Hz) over a turn, (samples, n_modes).
    low, mean, high
        Their minimum, mean (3.3) and maximum over the turn (Hz), (n_modes,).
    spin_softening
        h_r of the effective frequencies sqrt(mean_r^2 + h_r Omega^2), (n_modes,).
    harmonics
        m: the load harmonics k Omega, k = 1..m.
    """

    speeds_rpm: NDArray
    frequencies: NDArray
    low: NDArray
    mean: NDArray
    high: NDArray
    spin_softening: NDArray
    harmonics: int

    def effective(self, speeds_rpm: ArrayLike) -> NDArray:
        """Effective frequencies (Hz) at the given speeds, (len(speeds), n_modes); NaN where
        the lowest mode has diverged (sqrt of a negative number)."""
        W = np.asarray(speeds_rpm, float)[:, None] * 2 * np.pi / 60
        w2 = (2 * np.pi * self.mean) ** 2 + self.spin_softening * W**2
        return np.where(w2 > 0, np.sqrt(np.abs(w2)), np.nan) / (2 * np.pi)

    def crossings_rpm(self, k: int, effective: bool = False) -> tuple[NDArray, NDArray]:
        """Speeds (r/min) and frequencies (Hz) where k Omega meets each mean (or effective)
        frequency, within the speed range: the primary and superharmonic resonances."""
        x = self.speeds_rpm
        if effective:
            xr = self.mean / np.sqrt(k**2 - self.spin_softening) * 60  # k W = sqrt(wbar^2 + h W^2)
            y = k * xr / 60
        else:
            xr = self.mean * 60 / k
            y = self.mean
        ok = (xr >= x.min()) & (xr <= x.max())
        return xr[ok], y[ok]


@analysis
def campbell_data(
    setup: Setup | Params,
    speeds_rpm: ArrayLike,
    *,
    n_modes: int = 3,
    harmonics: int | None = None,
) -> CampbellData:
    """Natural frequencies against crank speed, with the lines k Omega: the numbers.

    ``cd = campbell_data(setup, speeds)``; ``fivebar.book.plotting.campbell_plot(cd)`` draws them.
    The frequencies over a turn come from :func:`linkage_frequencies` (the S samples of the
    problem, a :class:`fivebar.description.setup.Setup` or a Params) and do not depend on the speed;
    ``harmonics`` is m (default ``params.fourier_terms``).
    """
    s = as_setup(setup)
    params = s.params
    x = np.asarray(speeds_rpm, float)
    if x.ndim != 1 or x.size < 2 or np.any(x <= 0):
        raise ResonanceError(f"speeds_rpm must be a 1-D array of positive speeds (r/min), got {speeds_rpm!r}")
    m = params.fourier_terms if harmonics is None else int(harmonics)
    f = linkage_frequencies(s, n_modes) / (2 * np.pi)
    return CampbellData(x, f, f.min(0), f.mean(0), f.max(0), spin_softening(s, n_modes), m)
