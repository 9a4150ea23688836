r"""The periodic excitation of (2.7): its Fourier expansion (2.10), its frequencies, its modes.

**Fourier expansion (2.10).**  Every periodic right-hand side of (2.7) is expanded as

.. math::

    (\mathbf F_f)_i = F_{f0i} + \sum_{k=1}^{m} F_{fki}\cos(k\nu_f t + \tau_{fki}),

with :math:`m` = ``params.fourier_terms`` (not printed; an assumption).  (2.10) starts at
:math:`k = 1`; the mean :math:`F_{f0i}` is kept apart here (it is part of the constant load
:math:`\mathbf P_0` of (3.2)).  The coefficients come from the discrete Fourier transform of the
:math:`S` samples :math:`\mathbf F(t_j)`, :math:`t_j = jT/S`, of one period:
:math:`X_k = \sum_j \mathbf F(t_j) e^{-2\pi i kj/S}`, :math:`F_{fki} = 2|X_k|/S`,
:math:`\tau_{fki} = \arg X_k` (:func:`fourier_series`).  This is exact for a trigonometric
polynomial of degree below :math:`S/2`; :math:`m` must stay below :math:`S/2`.

**The frequencies** :math:`\nu_1..\nu_8` (:func:`excitation_frequencies`).  (2.10) lists
:math:`\nu_1, \nu_2` the working frequencies of the two rotors, :math:`\nu_3` "the smallest common
multiple" of them, :math:`\nu_4 = \nu_1`, :math:`\nu_5 = \nu_2`, :math:`\nu_6, \nu_7` the
rotation frequencies of the stator fields, ":math:`\nu_5`" (a second time) "the smallest common
multiple" of :math:`\nu_6, \nu_7`, and :math:`\nu_8` that of all four.  Two slips (errata E27):
nine definitions for eight symbols, and the frequency whose multiples contain every harmonic of
two periodic signals is the *greatest common divisor* of their frequencies (the inverse of the
least common multiple of their periods), not a common multiple.  We read the groups as

* :math:`f = 1, 2, 3`: the rigid-body inertia :math:`-\mathbf M\ddot{\mathbf u}_r`, which
  follows crank AB (:math:`\nu_1`), crank DE (:math:`\nu_2`) and both (:math:`\nu_3 =
  \gcd(\nu_1, \nu_2)`).  The cranks are clamped to the rotors (errata E6), so the rotors' working
  frequencies are the crank speeds (errata E19);
* :math:`f = 4, 5`: the rotating eccentricity :math:`\bar{\mathbf e}(t)` of each rotor;
* :math:`f = 6, 7`: the field stiffness :math:`\bar{\mathbf K}_{12}(t)` of each motor (the
  fields turn at :math:`\omega_0 = \omega_e / p`; the stiffness itself pulsates at
  :math:`2\omega_e`, :func:`fivebar.model.electromagnetics.field_frequencies`);
* :math:`f = 8`: the products :math:`\mathbf K^e\mathbf e`, with :math:`\nu_8 = \gcd` of all.

Only :math:`f = 1, 2, 3` drive the linkage subsystem that :class:`fivebar.model.dynamics.LinkageDynamics`
integrates: the electromagnetic terms act on the rotors' transverse DOFs alone, which do not
couple to the linkage.  Under the equal-speed assumption :math:`\nu_1 = \nu_2 = \nu_3 = \Omega`,
the crank speed, and the whole linkage load is one Fourier series in :math:`k\Omega`.

**Modal coordinates** (3.1).  The modes of this linkage change strongly over a turn (chapter
"Natural frequencies along the cycle": the lowest frequency by more than 40 %, and averaging
M and K fails), so no constant :math:`\boldsymbol\phi` follows them.  :func:`modal_basis`
offers two readings of (3.1):

* ``"instantaneous"`` (the default): :math:`\mathbf u = \boldsymbol\Phi(t)\boldsymbol\eta`
  with the mass-normalised modes of the frozen structure at each instant, tracked along the
  period by continuity (the lowest at the first step, each carried on to the new mode of largest
  overlap :math:`|\boldsymbol\phi_i(t_j)^\top\mathbf M(t_j)\boldsymbol\phi_r(t_{j-1})|`,
  sign chosen so that it is positive: by frequency where the modes are apart, by shape where two
  frequencies cross).  A tracked mode may come back after one period with the opposite sign (the
  loop of the crank angles encircles a coincidence of two frequencies: it happens to a higher
  mode at a speed ratio of 2) or as another mode; the modes are then periodic over two or more
  periods, and the modal series run over those (:attr:`ModalBasis.wrap`).  Then
  :math:`\boldsymbol\Phi^\top\mathbf K\boldsymbol\Phi = \operatorname{diag}\omega_r(t)^2`
  exactly and the modal force is :math:`f_r(t) = \boldsymbol\phi_r(t)^\top\mathbf F(t)`,
  expanded by (2.10) after the projection.  The terms from
  :math:`\dot{\boldsymbol\Phi}, \ddot{\boldsymbol\Phi}`, the gyroscopic
  :math:`2\boldsymbol\Phi^\top\mathbf M\dot{\boldsymbol\Phi}\dot{\boldsymbol\eta}`
  and the kinematic stiffness
  :math:`\boldsymbol\Phi^\top\mathbf M\ddot{\boldsymbol\Phi}\boldsymbol\eta`
  (:attr:`ModalBasis.gyroscopic`, :attr:`ModalBasis.kinematic_stiffness`), are left out of
  (3.2); they are of relative size :math:`\Omega/\omega_r` and
  :math:`(\Omega/\omega_r)^2`.  The second shifts the resonances at higher speeds: for a mode
  whose shape turns with the cranks it is :math:`-\Omega^2` (spin softening), and
  :func:`fivebar.analyses.linkage_multiscale.modal_model` can keep it;
* ``"reference"``: the modes of one configuration (crank angle 0 by default), constant, with
  :math:`f_r(t) = \boldsymbol\phi_r^\top\mathbf F(t)`, whose Fourier coefficients are the
  complex sums :math:`\sum_i\phi_{ir}F_{fki}e^{i\tau_{fki}}` (errata E22).

Either way the frequencies of (3.3) are the paper's means of the instantaneous frequencies of
the linkage subsystem (the rotor whirl modes are not part of it).  The book compares the two
bases against the steady state (chapter "Multiple scales").
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from ..numerics.eigen import frozen_modes
from ..errors import FivebarError
from .dynamics import LinkageDynamics
from .electromagnetics import field_frequencies, supply_frequency_for_speed
from ..description.params import Params
from ..description.setup import fourier_harmonics

__all__ = [
    "ExcitationError",
    "FourierSeries",
    "ModalBasis",
    "excitation_frequencies",
    "fourier_series",
    "load_expansion",
    "modal_basis",
    "modal_expansion",
]

_BASES = ("instantaneous", "reference")


class ExcitationError(FivebarError, ValueError):
    r"""Bad input to the excitation functions (the message names the value)."""


# --- Fourier series (2.10) --------------------------------------------------------------------
@dataclass(frozen=True)
class FourierSeries:
    r"""A truncated Fourier series (2.10) of ``n`` periodic signals.

    :math:`x_i(t) = \text{mean}_i + \sum_{k=1}^m \text{amplitude}_{ki}
    \cos(k\nu t + \text{phase}_{ki})`.

    Attributes
    ----------
    frequency : float
        Fundamental angular frequency :math:`\nu` (rad/s).
    mean : ndarray (n,)
        The :math:`k = 0` term (units of the signal).
    amplitude : ndarray (m, n)
        :math:`F_{ki} \ge 0`, row ``k - 1`` for harmonic ``k``.
    phase : ndarray (m, n)
        :math:`\tau_{ki}` (rad), in :math:`(-\pi, \pi]`.
    """

    frequency: float
    mean: NDArray
    amplitude: NDArray
    phase: NDArray

    @property
    def m(self) -> int:
        r"""Number of harmonics m."""
        return int(self.amplitude.shape[0])

    @property
    def n(self) -> int:
        r"""Number of signals (DOFs or modes)."""
        return int(self.amplitude.shape[1])

    @property
    def period(self) -> float:
        r"""Period :math:`2\pi/\nu` (s)."""
        return 2.0 * np.pi / self.frequency

    @property
    def harmonics(self) -> NDArray:
        r"""Harmonic numbers 1..m."""
        return np.arange(1, self.m + 1)

    @property
    def frequencies(self) -> NDArray:
        r"""Angular frequencies :math:`k\nu` (rad/s) of the harmonics, (m,)."""
        return self.harmonics * self.frequency

    @property
    def complex_amplitude(self) -> NDArray:
        r""":math:`F_{ki}e^{i\tau_{ki}}`, (m, n) complex."""
        return self.amplitude * np.exp(1j * self.phase)

    def __call__(self, t: ArrayLike, m: int | None = None) -> NDArray:
        r"""Evaluate the series (first ``m`` harmonics) at times ``t`` (s): shape(t) + (n,)."""
        m = self.m if m is None else int(m)
        if not 0 <= m <= self.m:
            raise ExcitationError(f"m = {m!r} is not allowed: use 0..{self.m}")
        t = np.asarray(t, float)
        k = self.harmonics[:m]
        arg = np.multiply.outer(t, k * self.frequency)  # shape(t) + (m,)
        c = np.exp(1j * arg) @ self.complex_amplitude[:m]
        return self.mean + c.real

    def relative_error(self, samples: ArrayLike, m: int | None = None) -> float:
        r"""max |series - samples| / max |samples| over samples at t_j = j T / S, (S, n)."""
        x = np.asarray(samples, float)
        x = x[:, None] if x.ndim == 1 else x
        t = np.arange(x.shape[0]) * self.period / x.shape[0]
        return float(np.abs(self(t, m) - x).max() / max(np.abs(x).max(), 1e-300))


def fourier_series(samples: ArrayLike, period: float, m: int) -> FourierSeries:
    r"""Fourier series (2.10) with ``m`` harmonics of signals sampled over one period.

    Parameters
    ----------
    samples : array_like (S,) or (S, n)
        Values at :math:`t_j = jT/S`, :math:`j = 0..S-1` (the end point :math:`T` excluded).
    period : float
        :math:`T` (s); the fundamental is :math:`\nu = 2\pi/T`.
    m : int
        Number of harmonics, ``1 <= m < S/2`` (below the Nyquist harmonic).

    Returns
    -------
    FourierSeries
        Exact (to rounding) for a trigonometric polynomial of degree ``<= m``.
    """
    x = np.asarray(samples, float)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.shape[0] < 3:
        raise ExcitationError(f"samples must have shape (S,) or (S, n) with S >= 3, got {np.shape(samples)}")
    if not np.all(np.isfinite(x)):
        raise ExcitationError("samples contain non-finite values")
    if not (np.isfinite(period) and period > 0):
        raise ExcitationError(f"period = {period!r} is not allowed: give a positive time (s)")
    S = x.shape[0]
    if isinstance(m, bool) or int(m) != m or not 1 <= m < S / 2:
        raise ExcitationError(f"m = {m!r} is not allowed: give an integer 1 <= m < S/2 = {S / 2:g}")
    m = int(m)
    X = np.fft.rfft(x, axis=0)
    mean = X[0].real / S
    Xk = X[1 : m + 1]
    return FourierSeries(2.0 * np.pi / period, mean, 2.0 * np.abs(Xk) / S, np.angle(Xk))


def load_expansion(dyn: LinkageDynamics, m: int | None = None) -> FourierSeries:
    r"""(2.10) of the linkage load :math:`\mathbf F = \mathbf P - \mathbf M\ddot{\mathbf u}_r`
    per DOF (kept DOFs of ``dyn``; N or N m), from its S samples over the period of the motion.

    ``m`` defaults to :func:`fivebar.description.setup.fourier_harmonics`: ``params.fourier_terms``
    harmonics of each crank's frequency (``fourier_terms`` at equal crank speeds, twice as many
    harmonics of the period's fundamental at a speed ratio of 2 or 1/2).
    """
    m = fourier_harmonics(dyn.params) if m is None else m
    return fourier_series(dyn.step_data.F, dyn.period, m)


# --- frequencies nu_1..nu_8 ---------------------------------------------------------------------
def _gcd(freqs: list[float], max_denominator: int = 1000) -> float:
    r"""Greatest common divisor of positive frequencies with rational ratios (NaN if none)."""
    base = freqs[0]
    den = 1
    for f in freqs[1:]:
        r = Fraction(f / base).limit_denominator(max_denominator)
        if abs(float(r) - f / base) > 1e-9 * f / base:
            return float("nan")
        den = den * r.denominator // np.gcd(den, r.denominator)
    # every f is an integer multiple of base / den; reduce by the gcd of those integers
    ints = [round(f / base * den) for f in freqs]
    g = 0
    for i in ints:
        g = int(np.gcd(g, i))
    return base / den * g


def excitation_frequencies(
    params: Params, crank_speed_rpm: float | None = None, supply: str = "crank"
) -> pd.DataFrame:
    r"""The excitation frequencies :math:`\nu_1..\nu_8` of (2.10), each documented.

    Parameters
    ----------
    params : Params
    crank_speed_rpm : float, optional
        Speed of crank AB (r/min); default the parameters'.  Crank DE turns at
        ``speed_ratio`` times it.
    supply : {"crank", "mains"}
        "crank" (default): each motor's supply frequency is the one at which its rotor turns
        with its crank (the cranks are clamped to the rotors, errata E6, E19;
        :func:`fivebar.model.electromagnetics.supply_frequency_for_speed`).  "mains": the
        parameters' ``supply_frequency`` for both motors, the rotors at their slip speeds
        (then the rotors do not turn with the cranks).

    Returns
    -------
    pandas.DataFrame
        Indexed by symbol ("nu1".."nu8" for the paper's two motor-driven cranks; for any other
        linkage one per driven input, their common divisor when there are two, then the
        eccentricity and field of each motor), columns ``frequency (rad/s)``, ``frequency (Hz)``,
        ``source`` (the term of (2.7)), ``drives linkage`` (bool: acts on the linkage
        subsystem of :class:`fivebar.model.dynamics.LinkageDynamics`) and ``note``.  A common
        divisor that does not exist (incommensurate frequencies) is NaN.
    """
    if supply not in ("crank", "mains"):
        raise ExcitationError(f"supply = {supply!r} is not allowed: use 'crank' or 'mains'")
    if crank_speed_rpm is not None:
        params = params.replace(crank_speed_rpm=crank_speed_rpm)
    lk = params.linkage
    motors = params.crank_motors
    if len(lk.inputs) != 2 or len(motors) != 2:
        return _input_frequencies(params, supply)
    speeds = [lk.joint(joint).drive.ratio * params.crank_speed_rad_s for joint in motors]  # type: ignore[union-attr]
    W1, W2 = speeds
    fields = []
    rotors = []
    for motor, W in zip(motors.values(), speeds):
        p = params if supply == "mains" else params.replace(supply_frequency=supply_frequency_for_speed(motor, W))
        ff = field_frequencies(motor, p)
        fields.append(float(ff["field"]))
        rotors.append(float(ff["rotor"]))
    nu1, nu2 = (W1, W2) if supply == "crank" else tuple(rotors)
    rows = [
        ("nu1", nu1, "-M u_r'' (crank AB = rotor 1)", True,
         "working frequency of rotor 1; the crank AB speed when the crank is clamped to the rotor"),
        ("nu2", nu2, "-M u_r'' (crank DE = rotor 2)", True,
         "working frequency of rotor 2; equals nu1 under the equal-speed assumption"),
        ("nu3", _gcd([W1, W2]), "-M u_r'' (both cranks)", True,
         "printed 'smallest common multiple' of nu1, nu2: read as their greatest common divisor, "
         "the fundamental of the common period (errata E27)"),
        ("nu4", nu1, "-(K1e + K2e) e, rotor 1 eccentricity", False,
         "nu4 = nu1: the rotating eccentricity of rotor 1 (rotor DOFs only)"),
        ("nu5", nu2, "-(K1e + K2e) e, rotor 2 eccentricity", False,
         "nu5 = nu2 (printed twice: also as the common frequency of nu6, nu7, errata E27)"),
        ("nu6", fields[0], "K0, K12 of motor 1 (field)", False,
         "turning frequency of motor 1's stator field; K12 pulsates at 2 p nu6"),
        ("nu7", fields[1], "K0, K22 of motor 2 (field)", False,
         "turning frequency of motor 2's stator field; K22 pulsates at 2 p nu7"),
        ("nu8", _gcd([nu1, nu2, fields[0], fields[1]]), "(K1e + K2e) e, all", False,
         "printed 'smallest common multiple' of nu1, nu2, nu6, nu7: read as their greatest "
         "common divisor (NaN: incommensurate, the rotor load is quasi-periodic)"),
    ]
    df = pd.DataFrame(rows, columns=["symbol", "frequency (rad/s)", "source", "drives linkage", "note"])
    df.insert(2, "frequency (Hz)", df["frequency (rad/s)"] / (2 * np.pi))
    return df.set_index("symbol")


def _input_frequencies(params: Params, supply: str) -> pd.DataFrame:
    """The table of :func:`excitation_frequencies` for a linkage that is not the paper's pair of
    motor-driven cranks: one row per driven input (its drive's fundamental, ``ratio`` times the
    crank speed for a crank turning through whole turns, the crank speed for an oscillating
    input), their greatest common divisor for two inputs, and for each crank that names a motor
    the rotating eccentricity of its rotor and the turning frequency of its field."""
    lk = params.linkage
    W = params.crank_speed_rad_s
    rows = []
    speeds = []
    for k, j in enumerate(lk.inputs, start=1):
        d = j.drive
        f = d.ratio * W if d.ratio else W  # type: ignore[union-attr]
        speeds.append(f)
        what = f"crank {j.name}" if j.kind == "crank" else f"slider {j.name}"
        rows.append((f"nu{k}", f, f"-M u_r'' ({what})", True,
                     f"fundamental of the drive of {what}: the rigid-body inertia repeats with it"))
    if len(speeds) == 2:
        rows.append(("nu3", _gcd(speeds), "-M u_r'' (both inputs)", True,
                     "greatest common divisor of nu1, nu2: the fundamental of the common period (errata E27)"))
    k = len(rows)
    for joint, section in lk.motors:
        motor = params.motors[section]
        Wj = lk.joint(joint).drive.ratio * W  # type: ignore[union-attr]
        p = params if supply == "mains" else params.replace(supply_frequency=supply_frequency_for_speed(motor, Wj))
        ff = field_frequencies(motor, p)
        rows.append((f"nu{k + 1}", Wj if supply == "crank" else float(ff["rotor"]),
                     f"-(K1e + K2e) e, the rotor eccentricity of {section}", False,
                     f"the rotating eccentricity of the rotor that drives crank {joint} (rotor DOFs only)"))
        rows.append((f"nu{k + 2}", float(ff["field"]), f"K0, K12 of {section} (field)", False,
                     f"turning frequency of the stator field of {section}"))
        k += 2
    df = pd.DataFrame(rows, columns=["symbol", "frequency (rad/s)", "source", "drives linkage", "note"])
    df.insert(2, "frequency (Hz)", df["frequency (rad/s)"] / (2 * np.pi))
    return df.set_index("symbol")


# --- modal basis (3.1) ----------------------------------------------------------------------------
@dataclass(frozen=True)
class ModalBasis:
    r"""Modes of the linkage subsystem over one period (3.1), for the modal projection.

    Attributes
    ----------
    kind : str
        "instantaneous" or "reference".
    t : ndarray (S,)
        Times of the steps (s).
    period : float
        T (s), the period of the motion.
    omega : ndarray (S, k)
        Instantaneous natural frequencies :math:`\omega_r(t_j)` (rad/s) of the tracked modes
        (ascending at the first step; a mode keeps its shape, not its rank, where frequencies
        cross).
    shapes : ndarray (S, n, k)
        :math:`\boldsymbol\Phi(t_j)`, mass-normalised at each step (instantaneous) or the
        reference modes repeated (reference).
    mass : ndarray (S, n, n)
        :math:`\mathbf M(t_j)` (for the kinematic terms).
    wrap : ndarray (k, k) or None
        The signed permutation :math:`\mathbf Q` with which the tracked modes return after one
        period, :math:`\boldsymbol\Phi(t + T) = \boldsymbol\Phi(t)\mathbf Q` (None: the
        identity, every mode returns to itself).  A mode may return with the opposite sign (its
        shape is anti-periodic: the crank angles' loop encircles a coincidence of two
        frequencies) or as another mode (where two frequencies cross); the modes are then
        periodic over :attr:`periods` periods of the motion, over which :meth:`extended`
        gives them.
    """

    kind: str
    t: NDArray
    period: float
    omega: NDArray
    shapes: NDArray
    mass: NDArray
    wrap: NDArray | None = None

    @property
    def n_modes(self) -> int:
        r"""Number of modes k."""
        return int(self.omega.shape[1])

    @property
    def periods(self) -> int:
        r"""L, the periods of the motion after which every tracked mode returns to itself
        (:math:`\mathbf Q^L = \mathbf I`; 1 when :attr:`wrap` is None)."""
        if self.wrap is None:
            return 1
        Q, L = self.wrap, 1
        while not np.array_equal(Q, np.eye(self.n_modes)):
            Q, L = Q @ self.wrap, L + 1
        return L

    @property
    def mean_omega(self) -> NDArray:
        r"""The paper's frequency means (3.3): means of :math:`\omega_r(t)` (rad/s) over the
        :attr:`periods` periods of each tracked mode."""
        return self.extended().omega.mean(axis=0) if self.wrap is not None else self.omega.mean(axis=0)

    def _neighbours(self) -> tuple[NDArray, NDArray]:
        r""":math:`\boldsymbol\Phi(t_{j+1})` and :math:`\boldsymbol\Phi(t_{j-1})` at every step,
        across the end of the period by :attr:`wrap`."""
        ahead, behind = np.roll(self.shapes, -1, axis=0), np.roll(self.shapes, 1, axis=0)
        if self.wrap is not None:
            ahead[-1] = self.shapes[0] @ self.wrap
            behind[0] = self.shapes[-1] @ self.wrap.T
        return ahead, behind

    @property
    def shapes_dot(self) -> NDArray:
        r""":math:`\dot{\boldsymbol\Phi}(t_j)` by central differences, periodic (1/s)."""
        dt = self.period / self.t.size
        ahead, behind = self._neighbours()
        return (ahead - behind) / (2 * dt)

    @property
    def shapes_ddot(self) -> NDArray:
        r""":math:`\ddot{\boldsymbol\Phi}(t_j)` by second differences, periodic (1/s^2)."""
        dt = self.period / self.t.size
        ahead, behind = self._neighbours()
        return (ahead - 2 * self.shapes + behind) / dt**2

    @property
    def gyroscopic(self) -> NDArray:
        r""":math:`\mathbf G = \boldsymbol\Phi^\top\mathbf M\dot{\boldsymbol\Phi}` (1/s), (S, k, k).

        With :math:`\mathbf u = \boldsymbol\Phi(t)\boldsymbol\eta` the modal equations gain
        :math:`2\mathbf G\dot{\boldsymbol\eta} + \mathbf H\boldsymbol\eta`, terms that
        (3.2) leaves out.
        """
        return np.einsum("sik,sij,sjl->skl", self.shapes, self.mass, self.shapes_dot)

    @property
    def kinematic_stiffness(self) -> NDArray:
        r""":math:`\mathbf H = \boldsymbol\Phi^\top\mathbf M\ddot{\boldsymbol\Phi}` (1/s^2), (S, k, k).

        For a mode shape that turns rigidly at the rate :math:`\Omega`,
        :math:`H_{rr} = -\Omega^2`: the spin softening of a stiffness that rotates with the
        links while the mass does not (zero for the reference basis).
        """
        return np.einsum("sik,sij,sjl->skl", self.shapes, self.mass, self.shapes_ddot)

    def project(self, F: ArrayLike) -> NDArray:
        r"""Modal forces :math:`f_r(t_j) = \boldsymbol\phi_r(t_j)^\top\mathbf F(t_j)`, (S, k)."""
        return np.einsum("sik,si->sk", self.shapes, np.asarray(F, float))

    def expand(self, eta: ArrayLike) -> NDArray:
        r"""Physical displacements :math:`\boldsymbol\Phi(t_j)\boldsymbol\eta(t_j)`, (S, n)."""
        return np.einsum("sik,sk->si", self.shapes, np.asarray(eta, float))

    def tile(self, X: ArrayLike) -> NDArray:
        r"""A quantity of the motion at the S steps of one period, repeated over the
        :attr:`periods` periods of the modes (the samples of :meth:`extended`'s steps)."""
        X = np.asarray(X)
        return np.concatenate([X] * self.periods) if self.wrap is not None else X

    def extended(self) -> "ModalBasis":
        r"""The same modes over :attr:`periods` periods of the motion, :math:`L S` steps, over
        which they are periodic (``wrap`` None): block l holds
        :math:`\boldsymbol\Phi(t + lT) = \boldsymbol\Phi(t)\mathbf Q^l` and the frequencies of
        the modes so reached.  Itself when every mode returns after one period."""
        if self.wrap is None:
            return self
        L, S = self.periods, self.t.size
        shapes, omega = [self.shapes], [self.omega]
        Q = np.eye(self.n_modes)
        for _ in range(1, L):
            Q = Q @ self.wrap
            shapes.append(self.shapes @ Q)
            omega.append(self.omega @ np.abs(Q))
        dt = self.period / S
        return ModalBasis(self.kind, np.arange(L * S) * dt, L * self.period, np.concatenate(omega),
                          np.concatenate(shapes), self.tile(self.mass))


def _assign(Phi: NDArray, M: NDArray, previous: NDArray) -> tuple[NDArray, NDArray]:
    r"""The order and signs that carry the modes ``Phi`` (n, k) on from ``previous``: the
    assignment of the new modes to the old that maximises the sum of the absolute overlaps
    :math:`|\boldsymbol\phi_i^\top\mathbf M\boldsymbol\phi^{\rm old}_r|`
    (:func:`scipy.optimize.linear_sum_assignment`), each overlap made positive.  Returns
    ``order`` (new mode for old mode r) and ``signs``."""
    O = Phi.T @ M @ previous  # [new, old]
    k = O.shape[0]
    order = np.arange(k)
    if k > 1 and np.any(np.abs(np.diag(O)) < np.abs(O).max(axis=0)):  # some mode is nearer another's rank
        new, old = linear_sum_assignment(-np.abs(O))
        order[old] = new
    s = np.sign(O[order, np.arange(k)])
    s[s == 0] = 1.0
    return order, s


def _track(Phi: NDArray, M: NDArray, omega: NDArray) -> NDArray:
    r"""Follow each mode along the period by its shape (:func:`_assign` from step to step), in
    place; returns the wrap :math:`\mathbf Q` (k, k), :math:`\boldsymbol\Phi(T) =
    \boldsymbol\Phi(0)\mathbf Q`, of the modes carried on to the first step once more."""
    for j in range(1, Phi.shape[0]):
        order, s = _assign(Phi[j], M[j], Phi[j - 1])
        Phi[j] = Phi[j][:, order] * s
        omega[j] = omega[j][order]
    order, s = _assign(Phi[0], M[0], Phi[-1])
    Q = np.zeros((Phi.shape[2], Phi.shape[2]))
    Q[order, np.arange(len(order))] = s
    return Q


def modal_basis(
    dyn: LinkageDynamics, n_modes: int = 2, kind: str = "instantaneous", reference_step: int = 0
) -> ModalBasis:
    r"""The modes of the linkage subsystem at the S steps of ``dyn`` (3.1).

    Parameters
    ----------
    dyn : LinkageDynamics
    n_modes : int
        Number of lowest modes (the paper keeps 2, (3.6)).
    kind : {"instantaneous", "reference"}
        See the module docstring.
    reference_step : int
        Step whose configuration gives the reference modes (``kind="reference"``).

    The instantaneous modes are the ``n_modes`` lowest at the first step, each followed from
    step to step by its shape (the overlap in the mass metric), so that where two frequencies
    cross a mode keeps its shape, not its rank.  A mode that returns after one period with the
    opposite sign, or as another mode, is recorded in the basis's ``wrap``; the modes are then
    periodic over several periods of the motion (``ModalBasis.periods``, ``extended()``), and
    the modal series (:func:`modal_expansion`) run over those periods.

    Raises
    ------
    ExcitationError
        Bad arguments.
    """
    if kind not in _BASES:
        raise ExcitationError(f"kind = {kind!r} is not allowed: use one of {list(_BASES)}")
    if isinstance(n_modes, bool) or int(n_modes) != n_modes or not 1 <= n_modes <= dyn.n:
        raise ExcitationError(f"n_modes = {n_modes!r} is not allowed: give an integer 1..{dyn.n}")
    S = dyn.steps_per_period
    if isinstance(reference_step, bool) or int(reference_step) != reference_step or not 0 <= reference_step < S:
        raise ExcitationError(f"reference_step = {reference_step!r} is not allowed: give an integer 0..{S - 1}")
    sd = dyn.step_data
    k = int(n_modes)
    omega = np.empty((S, k))
    Phi = np.empty((S, dyn.n, k))
    # the frozen structure's modes: of the symmetric part of K (with stiffness-proportional damping K
    # holds a small circulatory term of the turning frames, linear in the speed: dynamics.py)
    w2, Phi[:] = frozen_modes(sd.M, 0.5 * (sd.K + np.swapaxes(sd.K, -1, -2)), k)
    omega[:] = np.sqrt(w2)
    wrap = None
    if kind == "instantaneous":
        Q = _track(Phi, sd.M, omega)
        wrap = None if np.array_equal(Q, np.eye(k)) else Q
    else:
        Phi = np.broadcast_to(Phi[reference_step], Phi.shape).copy()
    return ModalBasis(kind, dyn.t.copy(), dyn.period, omega, Phi, sd.M, wrap)


def modal_expansion(dyn: LinkageDynamics, basis: ModalBasis, m: int | None = None) -> FourierSeries:
    r"""(2.10) of the modal forces :math:`f_r(t) = \boldsymbol\phi_r^\top\mathbf F(t)`
    over the periods of the modes (``basis.periods`` periods of the motion: one, unless a mode
    returns with the opposite sign or as another), with ``m`` harmonics of the motion's
    fundamental (default :func:`fivebar.description.setup.fourier_harmonics`), that is ``m L``
    harmonics of the fundamental :math:`2\pi/(LT)` of the series.

    With mass-normalised modes (units kg^-1/2 on translations) the modal force is in
    kg^1/2 m / s^2 and the modal coordinate :math:`\eta_r` in kg^1/2 m."""
    m = fourier_harmonics(dyn.params) if m is None else m
    B = basis.extended()
    return fourier_series(B.project(basis.tile(dyn.step_data.F)), B.period, m * basis.periods)
