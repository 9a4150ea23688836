r"""Time-stepping schemes of the Newmark family and their one-step analysis.

The schemes that :func:`fivebar.numerics.newmark.integrate` marches with: Newmark's rule of section 4
of the paper, (4.2)-(4.3), and two dissipative members of the generalised-alpha family.  A
scheme is four numbers (``gamma, beta, alpha_m, alpha_f``) checked against the region of
unconditional stability; :func:`amplification_matrix` gives its one-step map on the free
oscillator (numerical damping, period error).  This module knows nothing of the linkage nor of
the integrator.

**The Newmark rule, (4.2)-(4.3).**  One period ``T`` is divided into ``S`` steps, (4.1)
:math:`T = S\,\Delta t`.  With the paper's parameters :math:`(\varsigma, \vartheta)`, here
``(gamma, beta)``,

.. math::

    \dot{\mathbf u}_{n+1} = \dot{\mathbf u}_n
        + \big((1-\gamma)\ddot{\mathbf u}_n + \gamma\,\ddot{\mathbf u}_{n+1}\big)\Delta t,
        \qquad (4.2)

    \mathbf u_{n+1} = \mathbf u_n + \dot{\mathbf u}_n\Delta t
        + \big((\tfrac12-\beta)\ddot{\mathbf u}_n + \beta\,\ddot{\mathbf u}_{n+1}\big)\Delta t^2
        \qquad (4.3)

(the paper prints :math:`\vartheta\,\mathbf u_{t+\Delta t}` in (4.3); the acceleration
:math:`\vartheta\,\ddot{\mathbf u}_{t+\Delta t}` is meant, errata E21).  The rule is
unconditionally stable for :math:`\gamma \ge \tfrac12`,
:math:`\beta \ge \tfrac14(\gamma+\tfrac12)^2`, the condition printed under (4.3).  The
default is the average-acceleration (trapezoidal) rule :math:`\gamma=\tfrac12,\ \beta=\tfrac14`:
second order, no numerical dissipation.  Section 5 prints
:math:`(\varsigma,\vartheta)=(0.25, 0.5)`, outside that region; it is read as
:math:`(0.5, 0.25)` (errata E2) and the printed pair raises :class:`UnstableParametersError`.

**Numerical dissipation (optional).**  The generalised-alpha family of Chung & Hulbert (1993)
evaluates the equation at intermediate points, with forces interpolated between
:math:`t_n` and :math:`t_{n+1}` (:mod:`fivebar.numerics.newmark` gives the equation and its tangent).
:class:`Newmark` is :math:`\alpha_m=\alpha_f=0`; :class:`HHT` (Hilber, Hughes & Taylor 1977)
is :math:`\alpha_m=0,\ \alpha_f=-\alpha`, :math:`\alpha\in[-\tfrac13,0]`,
:math:`\gamma=\tfrac12-\alpha`, :math:`\beta=\tfrac14(1-\alpha)^2`, spectral radius
:math:`(1+\alpha)/(1-\alpha)` at :math:`\omega\Delta t\to\infty`;
:class:`GeneralizedAlpha` takes the spectral radius :math:`\rho_\infty\in[0,1]`:
:math:`\alpha_m=(2\rho_\infty-1)/(\rho_\infty+1)`, :math:`\alpha_f=\rho_\infty/(\rho_\infty+1)`,
:math:`\gamma=\tfrac12-\alpha_m+\alpha_f`, :math:`\beta=\tfrac14(1-\alpha_m+\alpha_f)^2`.
All are second order and unconditionally stable for linear systems.

References: N. M. Newmark, J. Eng. Mech. Div. ASCE 85 (1959) 67-94; H. M. Hilber,
T. J. R. Hughes, R. L. Taylor, Earthquake Eng. Struct. Dyn. 5 (1977) 283-292; J. Chung,
G. M. Hulbert, J. Appl. Mech. 60 (1993) 371-375.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import FivebarError, InputTypeError, flag, number

__all__ = [
    "GENERIC_SCHEME",
    "GeneralizedAlpha",
    "HHT",
    "Newmark",
    "Scheme",
    "UnstableParametersError",
    "UnstableParametersWarning",
    "amplification_matrix",
]

Array = NDArray[np.float64]


# --- errors -----------------------------------------------------------------------------------
class UnstableParametersError(FivebarError, ValueError):
    """Integration parameters outside the unconditionally stable region."""


class UnstableParametersWarning(RuntimeWarning):
    """Parameters outside the unconditionally stable region were accepted on request."""


# --- schemes ----------------------------------------------------------------------------------
class Scheme:
    """Base of the time-stepping schemes: the four generalised-alpha parameters.

    Subclasses define ``gamma``, ``beta``, ``alpha_m`` and ``alpha_f`` (dimensionless).
    """

    gamma: float
    beta: float
    alpha_m: float
    alpha_f: float

    @property
    def rho_infinity(self) -> float:
        """Spectral radius of the one-step map as ``omega dt -> infinity``."""
        raise NotImplementedError

    @property
    def is_newmark(self) -> bool:
        """True if the scheme is plain Newmark (no alpha terms): the state is (u, v)."""
        return self.alpha_m == 0.0 and self.alpha_f == 0.0


@dataclass(frozen=True)
class Newmark(Scheme):
    """Newmark's rule (4.2)-(4.3) with ``(gamma, beta)`` = the paper's (varsigma, vartheta).

    Parameters
    ----------
    gamma, beta : float
        Newmark parameters (dimensionless).  Default 1/2, 1/4: average acceleration
        (trapezoidal rule), the reading of the paper's section 5 (errata E2).
    allow_unstable : bool
        Accept parameters outside the unconditionally stable region ``gamma >= 1/2``,
        ``beta >= (gamma + 1/2)^2 / 4`` with an :class:`UnstableParametersWarning` instead of
        raising :class:`UnstableParametersError`.

    Raises
    ------
    UnstableParametersError
        Parameters outside the stable region (unless ``allow_unstable``), or ``beta <= 0``
        (not an implicit scheme; never allowed), or a non-finite value.
    """

    gamma: float = 0.5
    beta: float = 0.25
    allow_unstable: bool = False
    alpha_m: float = field(default=0.0, init=False)
    alpha_f: float = field(default=0.0, init=False)

    @property
    def rho_infinity(self) -> float:
        """Spectral radius as ``omega dt -> infinity``: roots of ``l^2 - tr l + det``.

        With ``tr = (2 beta - gamma - 1/2) / beta`` and ``det = (1/2 + beta - gamma) / beta``
        (the limit of the undamped one-step map on ``(v, a)``); 1 for the default rule.
        """
        g, b = self.gamma, self.beta
        tr, det = (2 * b - g - 0.5) / b, (0.5 + b - g) / b
        disc = tr * tr - 4 * det
        if disc < 0:
            return math.sqrt(det)
        return max(abs(tr + math.sqrt(disc)), abs(tr - math.sqrt(disc))) / 2

    def __post_init__(self) -> None:
        g = number("gamma", self.gamma, error=UnstableParametersError)
        b = number("beta", self.beta, error=UnstableParametersError)
        object.__setattr__(self, "gamma", g)
        object.__setattr__(self, "beta", b)
        object.__setattr__(self, "allow_unstable", flag("allow_unstable", self.allow_unstable))
        if b <= 0.0:
            raise UnstableParametersError(
                f"Newmark beta={b!r} must be > 0 for the implicit scheme (beta = 0 is the explicit "
                "central-difference rule, not implemented here); the default is beta = 0.25"
            )
        bmin = 0.25 * (g + 0.5) ** 2
        if g < 0.5 or b < bmin * (1.0 - 1e-12):
            msg = (
                f"Newmark parameters gamma={g!r}, beta={b!r} are outside the unconditionally "
                f"stable region gamma >= 0.5 and beta >= (gamma + 0.5)^2 / 4 (= {bmin:.6g} here), "
                "the condition stated under (4.3) of the paper. Note: the paper's section 5 prints "
                "(varsigma, vartheta) = (0.25, 0.5), which is such a case; the book reads it as "
                "(0.5, 0.25), the average-acceleration rule (errata E2). "
            )
            if not self.allow_unstable:
                raise UnstableParametersError(msg + "Pass allow_unstable=True to use them anyway.")
            warnings.warn(msg + "Accepted because allow_unstable=True.", UnstableParametersWarning,
                          stacklevel=3)


#: The scheme of the generic integrator when none is given (``integrate``, the generic
#: periodic-orbit tools of :mod:`fivebar.numerics.periodic`): the average-acceleration rule.  The
#: linkage's default is the parameter file's (:func:`fivebar.description.setup.default_scheme`).
GENERIC_SCHEME: Newmark = Newmark()


@dataclass(frozen=True)
class HHT(Scheme):
    """Hilber-Hughes-Taylor alpha method: Newmark with numerical dissipation.

    Parameters
    ----------
    alpha : float
        In ``[-1/3, 0]`` (dimensionless); 0 is the average-acceleration rule.  Sets
        ``gamma = (1 - 2 alpha) / 2`` and ``beta = (1 - alpha)^2 / 4``; the spectral radius as
        ``omega dt -> infinity`` is ``(1 + alpha) / (1 - alpha)``.
    """

    alpha: float = -0.05

    def __post_init__(self) -> None:
        a = number("alpha", self.alpha, error=UnstableParametersError)
        object.__setattr__(self, "alpha", a)
        if not -1.0 / 3.0 - 1e-15 <= a <= 0.0:
            raise UnstableParametersError(
                f"HHT alpha={a!r} must lie in [-1/3, 0] (the range where the scheme is second "
                "order and unconditionally stable); alpha = 0 is the average-acceleration rule"
            )

    @property
    def rho_infinity(self) -> float:
        """Spectral radius as ``omega dt -> infinity``: ``(1 + alpha) / (1 - alpha)``."""
        return (1.0 + self.alpha) / (1.0 - self.alpha)

    @property
    def gamma(self) -> float:  # type: ignore[override]
        return 0.5 - self.alpha

    @property
    def beta(self) -> float:  # type: ignore[override]
        return 0.25 * (1.0 - self.alpha) ** 2

    @property
    def alpha_m(self) -> float:  # type: ignore[override]
        return 0.0

    @property
    def alpha_f(self) -> float:  # type: ignore[override]
        return -self.alpha


@dataclass(frozen=True)
class GeneralizedAlpha(Scheme):
    """Chung-Hulbert generalised-alpha method with prescribed high-frequency dissipation.

    Parameters
    ----------
    rho_infinity : float
        Spectral radius of the one-step map as ``omega dt -> infinity``, in ``[0, 1]``
        (dimensionless); 1 gives no dissipation (the average-acceleration rule's limit),
        0 annihilates the highest modes in one step.
    """

    rho_infinity: float = 0.8  # type: ignore[assignment]

    def __post_init__(self) -> None:
        r = number("rho_infinity", self.rho_infinity, error=UnstableParametersError)
        object.__setattr__(self, "rho_infinity", r)
        if not 0.0 <= r <= 1.0:
            raise UnstableParametersError(
                f"generalised-alpha rho_infinity={r!r} must lie in [0, 1] (the spectral radius at "
                "omega dt -> infinity; values above 1 are unstable)"
            )

    @property
    def alpha_m(self) -> float:  # type: ignore[override]
        return (2.0 * self.rho_infinity - 1.0) / (self.rho_infinity + 1.0)

    @property
    def alpha_f(self) -> float:  # type: ignore[override]
        return self.rho_infinity / (self.rho_infinity + 1.0)

    @property
    def gamma(self) -> float:  # type: ignore[override]
        return 0.5 - self.alpha_m + self.alpha_f

    @property
    def beta(self) -> float:  # type: ignore[override]
        return 0.25 * (1.0 - self.alpha_m + self.alpha_f) ** 2


def amplification_matrix(scheme: Scheme, omega_dt: float, zeta: float = 0.0) -> Array:
    r"""One-step amplification matrix of a scheme for the free oscillator.

    For :math:`\ddot u + 2\zeta\omega\dot u + \omega^2 u = 0` the scheme maps
    :math:`x_n = (u_n,\ \Delta t\,\dot u_n,\ \Delta t^2\ddot u_n)` to :math:`x_{n+1} = A x_n`.
    Its eigenvalues give the numerical damping and period error (for :class:`Newmark` one
    eigenvalue is 0: the acceleration is slaved to (u, v)).

    Parameters
    ----------
    scheme : Scheme
        The time-stepping scheme.
    omega_dt : float
        :math:`\Omega = \omega\Delta t` (rad), >= 0.
    zeta : float
        Damping ratio (dimensionless), >= 0.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    _check_scheme(scheme)
    W = number("omega_dt", omega_dt, low=0.0)
    zeta = number("zeta", zeta, low=0.0)
    g, b, am, af = scheme.gamma, scheme.beta, scheme.alpha_m, scheme.alpha_f
    c, k = 2.0 * zeta * W, W * W  # scaled damping and stiffness (dt = 1, m = 1)
    # predictors as rows acting on x = (u, v, a) with dt = 1
    P_u = np.array([1.0, 1.0, 0.5 - b])
    P_v = np.array([0.0, 1.0, 1.0 - g])
    # residual: (1-am) a1 + am a0 + (1-af)(c v1 + k u1) + af (c v0 + k u0) = 0,
    # u1 = P_u x + b a1, v1 = P_v x + g a1
    lhs = (1 - am) + (1 - af) * (c * g + k * b)
    rhs = -(am * np.array([0.0, 0.0, 1.0]) + (1 - af) * (c * P_v + k * P_u)
            + af * np.array([k, c, 0.0]))
    a1 = rhs / lhs
    return np.vstack([P_u + b * a1, P_v + g * a1, a1])


def _check_scheme(scheme: Any) -> None:
    if not isinstance(scheme, Scheme):
        raise InputTypeError(
            f"scheme = {scheme!r} ({type(scheme).__name__}) is not allowed: give a Newmark, HHT or "
            "GeneralizedAlpha instance")
