r"""Beam and motor elements: shape functions, mass and stiffness, eqs. (A.1)-(A.8).

**Beam element** (A.5)-(A.8).  A straight element of length :math:`L` with local coordinate
:math:`\bar x \in [0, L]`, :math:`e = \bar x / L`, and the eight DOFs

.. math::

    \mathbf q = [u_1, w_1, w_1', w_1'', u_2, w_2, w_2', w_2'']^\top ,

(:math:`u` axial, :math:`w` transverse, :math:`' = d/d\bar x`).  The axial displacement
:math:`V = \gamma_1 u_1 + \gamma_5 u_2` is linear; the transverse displacement
:math:`W = \sum_{i=2,3,4,6,7,8} \gamma_i u_i` is the quintic Hermite interpolation of value,
slope and curvature at both ends (A.6), with :math:`\gamma_4` read as
:math:`L^2 (e^2 - 3e^3 + 3e^4 - e^5)/2` (errata E1: the printed :math:`-5e^5` breaks every
interpolation condition at :math:`e = 1`).  The consistent matrices (A.8) are

.. math::

    M_{ij} ={}& \rho A \int_0^L \gamma_i \gamma_j \, d\bar x
             + \rho I \int_0^L \gamma_i' \gamma_j' \, d\bar x \ (\text{transverse only}), \\
    K_{ij} ={}& EA \int_0^L \gamma_i' \gamma_j' \, d\bar x \ (\text{axial}),\
             EI \int_0^L \gamma_i'' \gamma_j'' \, d\bar x \ (\text{transverse}),

integrated exactly by Gauss-Legendre quadrature (:func:`gauss_points`; the integrands are
polynomials of degree at most 10).

**Motor element** (A.1)-(A.4).  The motor shaft of length :math:`l = l_1 + l_2 + l_3` has
nodes 1 (bearing, :math:`x = 0`), 2 (rotor, :math:`x = l_1`), 3 (bearing,
:math:`x = l_1 + l_2`) and 4 (coupling end, :math:`x = l`).  Its four DOFs are
:math:`U_1, U_2` (rotor transverse displacement in x and y, m) and :math:`U_3, U_4` (shaft
torsion at nodes 3 and 4, rad).  :math:`\psi_{1,2}` is read as the quintic bump
:math:`10e^3 - 15e^4 + 6e^5` on both bearing spans, 1 at the rotor and 0 at both bearings
(errata E3); :math:`\psi_3, \psi_4` are the linear hat functions of nodes 3 and 4, both zero
at the rotor, so the rotor is the torsional reference and its inertia :math:`J_0` drops out of
the torsional mass.  :math:`(\bar K_{11})_{12}` is read as 0 (errata E11).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.polynomial import polynomial as P

from ..cache import memoised
from ..numerics.eigen import frozen_modes
from ..errors import InputError
from ..description.linkage import Link
from ..description.params import Motor

__all__ = [
    "AXIAL_DOFS",
    "TRANSVERSE_DOFS",
    "gauss_points",
    "shape_functions",
    "beam_element",
    "assemble_line",
    "bending_frequencies",
    "euler_loads",
    "shaft_section",
    "motor_shape_functions",
    "motor_element",
]

#: Indices of the axial DOFs u1, u2 in the beam element's DOF vector.
AXIAL_DOFS = (0, 4)
#: Indices of the transverse DOFs w1, w1', w1'', w2, w2', w2'' in the beam element's DOF vector.
TRANSVERSE_DOFS = (1, 2, 3, 5, 6, 7)

Variant = Literal["corrected", "printed"]

# (A.6): gamma_i = L**_LPOW[i] * sum_k _GAMMA[i, k] e**k, e = xbar / L.
_GAMMA = np.array(
    [
        [1.0, -1.0, 0.0, 0.0, 0.0, 0.0],  # gamma1 = 1 - e
        [1.0, 0.0, 0.0, -10.0, 15.0, -6.0],  # gamma2 = 1 - 10e^3 + 15e^4 - 6e^5
        [0.0, 1.0, 0.0, -6.0, 8.0, -3.0],  # gamma3 / L = e - 6e^3 + 8e^4 - 3e^5
        [0.0, 0.0, 0.5, -1.5, 1.5, -0.5],  # gamma4 / L^2 = (e^2 - 3e^3 + 3e^4 - e^5) / 2  (E1)
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],  # gamma5 = e
        [0.0, 0.0, 0.0, 10.0, -15.0, 6.0],  # gamma6 = 10e^3 - 15e^4 + 6e^5
        [0.0, 0.0, 0.0, -4.0, 7.0, -3.0],  # gamma7 / L = -4e^3 + 7e^4 - 3e^5
        [0.0, 0.0, 0.0, 0.5, -1.0, 0.5],  # gamma8 / L^2 = (e^3 - 2e^4 + e^5) / 2
    ]
)
_GAMMA4_PRINTED = np.array([0.0, 0.0, 0.5, -1.5, 1.5, -2.5])  # (e^2 - 3e^3 + 3e^4 - 5e^5) / 2
_LPOW = np.array([0, 0, 1, 2, 0, 0, 1, 2])

# (A.2) on the three shaft spans, as polynomials in the span's local coordinate e:
# e1 = x/l1 on [0, l1], e2 = (l1 + l2 - x)/l2 on (l1, l1 + l2], e3 = (l - x)/l3 on (l1 + l2, l].
_BUMP = np.array([0.0, 0.0, 0.0, 10.0, -15.0, 6.0])  # 10e^3 - 15e^4 + 6e^5
_ZERO = np.zeros(6)
_ONE_MINUS_E = np.array([1.0, -1.0, 0.0, 0.0, 0.0, 0.0])
_E = np.array([0.0, 1.0, 0.0, 0.0, 0.0, 0.0])
_ONE = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
_PSI = {  # [span, function, coefficient]
    "corrected": np.array(
        [
            [_BUMP, _BUMP, _ZERO, _ZERO],
            [_BUMP, _BUMP, _ONE_MINUS_E, _ZERO],
            [_ZERO, _ZERO, _E, _ONE_MINUS_E],
        ]
    ),
    "printed": np.array(
        [
            [_ONE - _BUMP, _ONE - _BUMP, _ZERO, _ZERO],
            [_ONE - _BUMP, _ONE - _BUMP, _ONE_MINUS_E, _ZERO],
            [_ZERO, _ZERO, _E, _ONE_MINUS_E],
        ]
    ),
}

_GAUSS_EXACT = 6  # Gauss-Legendre points: exact for polynomials up to degree 11


# --- input checks ----------------------------------------------------------------------------
def _positive(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{name} = {value!r} is not allowed: it must be a positive finite number")
    return v


def _order(derivative: int) -> int:
    if not _is_int(derivative) or derivative < 0:
        raise InputError(f"derivative = {derivative!r} is not allowed: it must be an integer >= 0")
    return int(derivative)


def _is_int(value: object) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def _variant(variant: str) -> str:
    if variant not in ("corrected", "printed"):
        raise InputError(
            f"variant = {variant!r} is not allowed: it must be 'corrected' or 'printed'"
        )
    return variant


def _points(x: np.typing.ArrayLike, name: str, length: float) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    tol = 1e-12 * length
    bad = ~np.isfinite(x) | (x < -tol) | (x > length + tol)
    if np.any(bad):
        raise InputError(
            f"{name} = {float(x[bad].ravel()[0])!r} is outside the element: "
            f"it must lie in [0, {length!r}] m"
        )
    return x


# --- quadrature ------------------------------------------------------------------------------
def gauss_points(n: int, L: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre points and weights on ``[0, L]``.

    ``n`` points integrate polynomials of degree ``2n - 1`` exactly; the weights sum to ``L``.

    Parameters
    ----------
    n
        Number of points (positive integer).
    L
        Length of the interval (m).

    Returns
    -------
    x, w : ndarray, shape (n,)
        Points in ``(0, L)`` (m) and weights (m).

    Examples
    --------
    >>> x, w = gauss_points(3, 2.0)
    >>> round(float(w @ x**5), 12)  # int_0^2 x^5 dx = 64/6
    10.666666666667
    """
    if not _is_int(n) or n < 1:
        raise InputError(f"n = {n!r} is not allowed: it must be a positive integer")
    L = _positive("L", L)
    t, w = _legendre(int(n))
    return 0.5 * L * (t + 1.0), 0.5 * L * w


@memoised
def _legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1], computed once per order (read-only)."""
    t, w = np.polynomial.legendre.leggauss(n)
    t.flags.writeable = w.flags.writeable = False
    return t, w


# --- beam element (A.5)-(A.8) ----------------------------------------------------------------
def shape_functions(
    xbar: np.typing.ArrayLike,
    L: float,
    derivative: int = 0,
    variant: Variant = "corrected",
) -> np.ndarray:
    r"""Beam shape functions :math:`\gamma_1 \dots \gamma_8` of (A.6) or their derivatives.

    Parameters
    ----------
    xbar
        Points along the element, :math:`0 \le \bar x \le L` (m); any shape.
    L
        Element length (m).
    derivative
        Order of the derivative with respect to :math:`\bar x` (0 = the functions; 1 = slope,
        1/m for the unit-displacement functions; 2 = curvature; higher orders are allowed).
    variant
        ``"corrected"`` (default) uses :math:`\gamma_4 = L^2(e^2-3e^3+3e^4-e^5)/2`;
        ``"printed"`` uses the paper's misprinted :math:`-5e^5` (errata E1), for comparison.

    Returns
    -------
    ndarray, shape ``xbar.shape + (8,)``
        Column ``i`` is :math:`\gamma_{i+1}^{(n)}(\bar x)` in the DOF order
        ``[u1, w1, w1', w1'', u2, w2, w2', w2'']``: columns 0 and 4 are the axial functions,
        the others the transverse ones.

    Examples
    --------
    >>> shape_functions([0.0, 0.5], 0.5)[1]  # at node 2 only gamma5 and gamma6 are 1
    array([0., 0., 0., 0., 1., 1., 0., 0.])
    """
    L = _positive("L", L)
    n = _order(derivative)
    C = _GAMMA.copy()
    if _variant(variant) == "printed":
        C[3] = _GAMMA4_PRINTED
    e = _points(xbar, "xbar", L) / L
    D = P.polyder(C.T, m=n) if n else C.T  # (6 - n, 8): coefficients in e, ascending
    vals = np.moveaxis(P.polyval(e, D, tensor=True), 0, -1)  # (..., 8)
    return vals * L ** (_LPOW - n).astype(float)


def beam_element(
    L: float, E: float, A: float, I: float, rho: float, rotary_inertia: bool = True  # noqa: E741
) -> tuple[np.ndarray, np.ndarray]:
    r"""Consistent mass and stiffness matrices of the 8-DOF beam element, eq. (A.8).

    ``M, K = beam_element(L, E, A, I, rho)``

    Parameters
    ----------
    L
        Element length (m).
    E
        Young's modulus (Pa).
    A
        Cross-section area (m^2).
    I
        Second moment of area for bending in the plane of motion (m^4).
    rho
        Density (kg/m^3).
    rotary_inertia
        Include the rotary-inertia term :math:`\rho I \int \gamma_i'\gamma_j'` of (A.8)
        (``False``: the Euler-Bernoulli mass matrix).

    Returns
    -------
    M, K : ndarray, shape (8, 8)
        Mass (kg, kg m, kg m^2 ... by DOF) and stiffness (N/m ...) in the DOF order
        ``[u1, w1, w1', w1'', u2, w2, w2', w2'']``; axial and transverse DOFs are uncoupled.

    Raises
    ------
    ValueError
        If any of ``L, E, A, I, rho`` is not a positive finite number.
    """
    L = _positive("L", L)
    E = _positive("E", E)
    A = _positive("A", A)
    I = _positive("I", I)  # noqa: E741
    rho = _positive("rho", rho)
    G0, G1, G2, Bax, Btr = _element_integrals(L)
    M = rho * A * G0 * (Bax + Btr)
    if rotary_inertia:
        M += rho * I * G1 * Btr
    K = E * A * G1 * Bax + E * I * G2 * Btr
    return M, K


@memoised
def _element_integrals(L: float) -> tuple[np.ndarray, ...]:
    """The integrals of (A.8) over an element of length L, made once per length (read-only):
    the Gram matrices of the shape functions and of their first and second derivatives, and
    the masks of the axial and the transverse DOFs."""
    x, w = gauss_points(_GAUSS_EXACT, L)
    N0, N1, N2 = (shape_functions(x, L, d) for d in range(3))
    ax = np.zeros(8)
    ax[list(AXIAL_DOFS)] = 1.0
    tr = 1.0 - ax
    Bax, Btr = np.outer(ax, ax), np.outer(tr, tr)

    def gram(N: np.ndarray) -> np.ndarray:
        G = (N * w[:, None]).T @ N
        return 0.5 * (G + G.T)

    out = (gram(N0), gram(N1), gram(N2), Bax, Btr)
    for X in out:
        X.flags.writeable = False
    return out


def assemble_line(
    n: int,
    L: float,
    E: float,
    A: float,
    I: float,  # noqa: E741
    rho: float,
    rotary_inertia: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Mass and stiffness of a straight uniform beam of ``n`` equal elements (no supports).

    Node ``k`` (``k = 0 .. n``, at ``x = k L / n``) carries the global DOFs
    ``4k + [0, 1, 2, 3] = [u, w, w', w'']``, so element ``j`` occupies DOFs ``4j .. 4j + 7``.
    Supports are imposed by the caller by deleting rows and columns.

    Parameters
    ----------
    n
        Number of elements (positive integer).
    L
        Total length (m).
    E, A, I, rho, rotary_inertia
        As in :func:`beam_element` (Pa, m^2, m^4, kg/m^3).

    Returns
    -------
    M, K : ndarray, shape (4 (n + 1), 4 (n + 1))
    """
    if not _is_int(n) or n < 1:
        raise InputError(f"n = {n!r} is not allowed: it must be a positive integer")
    L = _positive("L", L)
    Me, Ke = beam_element(L / n, E, A, I, rho, rotary_inertia)
    size = 4 * (n + 1)
    M = np.zeros((size, size))
    K = np.zeros((size, size))
    for j in range(n):
        s = slice(4 * j, 4 * j + 8)
        M[s, s] += Me
        K[s, s] += Ke
    return M, K


_SUPPORTS = {
    # bending DOFs held at zero, as offsets from the first (0) or the last (-1) node
    "simply-supported": ((0, 1), (0, 3), (-1, 1), (-1, 3)),  # w = w'' = 0 at both ends
    "clamped-free": ((0, 1), (0, 2)),  # w = w' = 0 at x = 0 (w'' free); x = L free
    "clamped-clamped": ((0, 1), (0, 2), (-1, 1), (-1, 2)),
}


def bending_frequencies(
    n: int,
    L: float,
    E: float,
    A: float,
    I: float,  # noqa: E741
    rho: float,
    supports: str = "clamped-free",
    rotary_inertia: bool = False,
    modes: int = 3,
) -> np.ndarray:
    r"""Lowest bending circular frequencies of a uniform beam of ``n`` elements.

    The beam of :func:`assemble_line` with its axial DOFs left out and the supports imposed by
    deleting DOFs; every support offered removes the rigid motions, so the reduced stiffness
    is positive definite and the eigenproblem is solved for the largest :math:`1/\omega^2`.

    Parameters
    ----------
    n, L, E, A, I, rho, rotary_inertia
        As in :func:`assemble_line` (m, Pa, m^2, m^4, kg/m^3).
    supports
        ``"simply-supported"`` (w = w'' = 0 at both ends), ``"clamped-free"`` (w = w' = 0 at
        x = 0) or ``"clamped-clamped"`` (w = w' = 0 at both ends).
    modes
        How many frequencies to return.

    Returns
    -------
    ndarray, shape (modes,)
        Circular frequencies (rad/s), ascending.
    """
    if supports not in _SUPPORTS:
        raise InputError(
            f"supports = {supports!r} is not allowed: it must be one of {list(_SUPPORTS)}"
        )
    M, K = assemble_line(n, L, E, A, I, rho, rotary_inertia)
    last = M.shape[0] // 4 - 1
    fixed = {4 * (last if node == -1 else node) + dof for node, dof in _SUPPORTS[supports]}
    keep = [i for i in range(M.shape[0]) if i % 4 != 0 and i not in fixed]
    if not _is_int(modes) or not 1 <= modes <= len(keep):
        raise InputError(
            f"modes = {modes!r} is not allowed: it must be an integer in [1, {len(keep)}]"
        )
    # the largest eigenvalues 1/omega^2 of (M, K): accurate to rounding relative to themselves,
    # whereas the smallest of (K, M) carry the rounding error of the stiffest (curvature) modes
    w2, _ = frozen_modes(M[np.ix_(keep, keep)], K[np.ix_(keep, keep)], modes)
    return np.sqrt(w2)


def euler_loads(link: Link, effective_length_factor: float = 1.0) -> tuple[float, float]:
    r"""Euler buckling loads (N) of a link in the plane of motion and out of it.

    ``in_plane, out_of_plane = euler_loads(params.linkage.link("L2"))``.

    A straight column of length :math:`L`, Young's modulus :math:`E` and second moment
    :math:`I` buckles under the axial compression

    .. math::

        P_E = \frac{\pi^2 E I}{(K L)^2},

    :math:`K` the effective length factor (1 for a column pinned at both ends, 0.7 clamped and
    pinned, 0.5 clamped at both).  The flat bar has two: in the plane of motion it bends about
    the normal to the plane, :math:`I = b d^3/12` with :math:`d` the side in the plane (the
    section's ``bending_depth``); out of the plane about its other axis,
    :math:`I = d b^3/12`.  The default :math:`K = 1` reads every link as pinned at both ends in
    both planes: a revolute joint lets the link turn in the plane, and out of the plane its
    stiffness is not known; for the cranks, clamped to the motor shafts, it is conservative.

    Parameters
    ----------
    link
        A link of the description (``params.linkage.link(name)``): its length, section and
        material are used.
    effective_length_factor
        :math:`K` (> 0).

    Returns
    -------
    (in_plane, out_of_plane) : floats (N)
    """
    if not isinstance(link, Link):
        raise InputError(f"link = {link!r} is not allowed: give a fivebar.description.linkage.Link "
                         "(params.linkage.link(name))")
    k = _positive("effective_length_factor", effective_length_factor)
    sec, E = link.section, link.material.E
    d = sec.bending_depth
    b = sec.area / d  # the other side
    EI_in, EI_out = E * b * d**3 / 12.0, E * d * b**3 / 12.0
    scale = math.pi**2 / (k * link.length) ** 2
    return EI_in * scale, EI_out * scale


# --- motor element (A.1)-(A.4) ---------------------------------------------------------------
def shaft_section(diameter: float) -> tuple[float, float, float]:
    r"""Area, second moment and polar moment of a solid round shaft.

    Parameters
    ----------
    diameter
        Shaft diameter :math:`d` (m).

    Returns
    -------
    A_s, I_s, J_p : float
        :math:`\pi d^2/4` (m^2), :math:`\pi d^4/64` (m^4), :math:`\pi d^4/32` (m^4).
    """
    d = _positive("diameter", diameter)
    return math.pi * d**2 / 4.0, math.pi * d**4 / 64.0, math.pi * d**4 / 32.0


def _motor_checked(motor: Motor) -> Motor:
    for name in ("l1", "l2", "l3", "m0", "J0", "shaft_diameter", "shaft_E", "shaft_G", "shaft_rho"):
        _positive(f"motor.{name}", getattr(motor, name))
    return motor


def _spans(motor: Motor) -> tuple[tuple[float, float, float], ...]:
    """(start, length, de/dx) of the three spans, with e measured as in (A.2)."""
    l1, l2, l3 = motor.l1, motor.l2, motor.l3
    return ((0.0, l1, 1.0 / l1), (l1, l2, -1.0 / l2), (l1 + l2, l3, -1.0 / l3))


def _local_e(x: np.ndarray, span: int, motor: Motor) -> np.ndarray:
    l1, l2, l3 = motor.l1, motor.l2, motor.l3
    return (x / l1, (l1 + l2 - x) / l2, (l1 + l2 + l3 - x) / l3)[span]


def motor_shape_functions(
    x: np.typing.ArrayLike,
    motor: Motor,
    derivative: int = 0,
    variant: Variant = "corrected",
) -> np.ndarray:
    r"""Motor-shaft shape functions :math:`\psi_1 \dots \psi_4` of (A.2) or their derivatives.

    Parameters
    ----------
    x
        Points along the shaft, :math:`0 \le x \le l = l_1 + l_2 + l_3` (m); any shape.
        A point on a span boundary belongs to the span on its left, as in (A.2).
    motor
        The motor (uses ``l1, l2, l3``).
    derivative
        Order of the derivative with respect to :math:`x`.
    variant
        ``"corrected"`` (default): :math:`\psi_{1,2}` is the bump :math:`10e^3-15e^4+6e^5`,
        1 at the rotor and 0 at the bearings (errata E3).  ``"printed"``: the paper's
        :math:`1 - 10e^3 + 15e^4 - 6e^5`, 1 at the bearings and 0 at the rotor.

    Returns
    -------
    ndarray, shape ``x.shape + (4,)``
        Columns :math:`\psi_1 \dots \psi_4` for the DOFs ``[U1, U2, U3, U4]``.
    """
    _motor_checked(motor)
    n = _order(derivative)
    table = _PSI[_variant(variant)]
    x = _points(x, "x", motor.l)
    l1, l2 = motor.l1, motor.l2
    span = np.where(x <= l1, 0, np.where(x <= l1 + l2, 1, 2))
    out = np.zeros(x.shape + (4,))
    for s, (_, _, dedx) in enumerate(_spans(motor)):
        here = span == s
        if not np.any(here):
            continue
        D = P.polyder(table[s].T, m=n) if n else table[s].T
        e = _local_e(x[here], s, motor)
        out[here] = np.moveaxis(P.polyval(e, D, tensor=True), 0, -1) * dedx**n
    return out


def motor_element(motor: Motor, variant: Variant = "corrected") -> tuple[np.ndarray, np.ndarray]:
    r"""Mass :math:`\bar M_1` (A.3) and shaft stiffness :math:`\bar K_{11}` (A.4) of a motor.

    ``M, K11 = motor_element(params.motors["motor1"])``

    The shaft is solid and round (:func:`shaft_section` of ``motor.shaft_diameter``), of
    density ``shaft_rho``, moduli ``shaft_E`` and ``shaft_G``.  The transverse mass density is
    :math:`m_1(x) = \rho_s A_s + m_0 \delta(x - l_1)`, the torsional one
    :math:`J_{01}(x) = \rho_s J_p + J_0 \delta(x - l_1)`; since :math:`\psi_3(l_1) =
    \psi_4(l_1) = 0` the rotor inertia :math:`J_0` contributes nothing.

    .. math::

        (\bar M_1)_{11} = (\bar M_1)_{22} = \int_0^l m_1 \psi_1^2 dx, \quad
        (\bar M_1)_{kp} = \int_0^l J_{01} \psi_k \psi_p dx, \\
        (\bar K_{11})_{11} = (\bar K_{11})_{22} = E I_s \int_0^l \psi_1''^2 dx, \quad
        (\bar K_{11})_{kp} = G J_p \int_0^l \psi_k' \psi_p' dx \quad (k, p = 3, 4),

    all other entries zero; in particular :math:`(\bar K_{11})_{12} = 0` (errata E11).  The
    electromagnetic stiffness :math:`\bar K_{12}` is not part of this function.

    Parameters
    ----------
    motor
        The motor (uses ``l1, l2, l3, m0, J0`` and the shaft entries).
    variant
        ``"corrected"`` (default) or ``"printed"``: the paper's :math:`\psi_{1,2}` (E3), which
        vanish at the rotor so that :math:`m_0` drops out of the mass, and its
        :math:`(\bar K_{11})_{12} = E I_s \int \psi_1' \psi_2' dx` (E11; dimensionally a
        force, not a stiffness).  The printed :math:`\psi_{1,2}` jumps from 1 to 0 at the
        second bearing; its integrals are taken span by span.

    Returns
    -------
    M, K11 : ndarray, shape (4, 4)
        DOFs ``[U1, U2, U3, U4]``: U1, U2 in m (M in kg, K in N/m), U3, U4 in rad
        (M in kg m^2, K in N m/rad).
    """
    _motor_checked(motor)
    variant = _variant(variant)
    A_s, I_s, J_p = shaft_section(motor.shaft_diameter)
    rho, E, G = motor.shaft_rho, motor.shaft_E, motor.shaft_G
    M = np.zeros((4, 4))
    K = np.zeros((4, 4))
    tr, tor = [0, 1], [2, 3]
    for start, length, _ in _spans(motor):
        x, w = gauss_points(_GAUSS_EXACT, length)
        x = x + start
        psi, dpsi, ddpsi = (motor_shape_functions(x, motor, d, variant) for d in range(3))
        M[np.ix_(tr, tr)] += rho * A_s * np.diag((w @ psi[:, tr] ** 2))
        M[np.ix_(tor, tor)] += rho * J_p * (psi[:, tor] * w[:, None]).T @ psi[:, tor]
        K[np.ix_(tr, tr)] += E * I_s * np.diag(w @ ddpsi[:, tr] ** 2)
        K[np.ix_(tor, tor)] += G * J_p * (dpsi[:, tor] * w[:, None]).T @ dpsi[:, tor]
        if variant == "printed":
            K[0, 1] += E * I_s * (w @ (dpsi[:, 0] * dpsi[:, 1]))
    at_rotor = motor_shape_functions(motor.l1, motor, 0, variant)
    M[np.ix_(tr, tr)] += motor.m0 * np.diag(at_rotor[tr] ** 2)
    M[np.ix_(tor, tor)] += motor.J0 * np.outer(at_rotor[tor], at_rotor[tor])
    K[1, 0] = K[0, 1]
    return 0.5 * (M + M.T), K
