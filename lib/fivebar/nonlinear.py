r"""Geometric nonlinearity of the links: the small parameter :math:`\varepsilon` of (2.7), (2.8).

The printed strain energy (2.5) repeats one term three times (errata E10).  It is read as the
energy of a beam with the axial strain of a moderately large deflection,
:math:`\epsilon = V' + \tfrac12 W'^2`:

.. math::

    V_3 = \frac{EJ}{2}\int_0^L W''^2\,d\bar x + \frac{EA}{2}\int_0^L
          \Big(V' + \tfrac12 W'^2\Big)^2 d\bar x .

Its quadratic part is the linear stiffness :math:`\overline{\mathbf K}_3` of (A.8); the rest,

.. math::

    \Pi_{nl} = EA\int_0^L \Big(\tfrac12 V' W'^2 + \tfrac18 W'^4\Big)\,d\bar x ,

is cubic and quartic in the element DOFs.  Its gradient is the internal nonlinear force,
the negative of the paper's :math:`\varepsilon`: the cubic energy gives the quadratic terms
:math:`\mathbf G_n, \mathbf K_n` of (2.8), the quartic energy the cubic terms
:math:`\mathbf G_{gl}, \mathbf K_{gl}` (the book shows the term-by-term correspondence).
With :math:`V' = (u_5 - u_1)/L` and :math:`W' = \mathbf g^\top \mathbf q`,
:math:`\mathbf g = [\gamma_i']`, the force and tangent of one element are

.. math::

    f_{1,5} = \mp\frac{EA}{2L}\int W'^2, \quad
    f_i = EA\int \big(V' W' + \tfrac12 W'^3\big) g_i, \qquad
    K_{ij} = EA\int\big(V' + \tfrac32 W'^2\big) g_i g_j, \quad
    K_{1i,5i} = \mp\frac{EA}{L}\int W' g_i ,

integrated exactly by Gauss-Legendre quadrature (10 points: the integrands are polynomials of
degree at most 16).  Element forces are rotated to the global frame and assembled like the
linear matrices; they depend on the configuration through the element rotations.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .assembly import Model
from .elements import gauss_points, shape_functions
from .kinematics import link_angles

__all__ = ["NonlinearForce", "element_energy", "element_force"]

_TRANSVERSE = np.array([1, 2, 3, 5, 6, 7])
_GAUSS = 10


def _slopes(L: float) -> tuple[NDArray, NDArray]:
    """Gauss weights (m) and transverse shape-function slopes g (npts, 8) of one element."""
    x, w = gauss_points(_GAUSS, L)
    g = shape_functions(x, L, derivative=1)
    g[:, [0, 4]] = 0.0
    return w, g


def element_energy(q: ArrayLike, L: float, EA: float) -> NDArray:
    """Nonlinear strain energy Pi_nl (J) of elements with local DOFs ``q`` (..., 8)."""
    q = np.asarray(q, float)
    w, g = _slopes(L)
    Wp = q @ g.T  # (..., npts)
    Vp = (q[..., 4] - q[..., 0]) / L
    return EA * ((0.5 * Vp[..., None] * Wp**2 + 0.125 * Wp**4) @ w)


def element_force(q: ArrayLike, L: float, EA: float) -> tuple[NDArray, NDArray]:
    """Local nonlinear force (..., 8) and tangent (..., 8, 8) of elements with DOFs ``q``."""
    q = np.asarray(q, float)
    w, g = _slopes(L)
    Wp = q @ g.T  # (..., npts)
    Vp = (q[..., 4] - q[..., 0]) / L
    f = EA * (((Vp[..., None] * Wp + 0.5 * Wp**3) * w) @ g)
    I2 = (Wp**2) @ w
    f[..., 0] -= EA * I2 / (2 * L)
    f[..., 4] += EA * I2 / (2 * L)
    K = EA * np.einsum("...p,pi,pj->...ij", (Vp[..., None] + 1.5 * Wp**2) * w, g, g)
    c = EA * ((Wp * w) @ g) / L  # (..., 8)
    K[..., 0, :] -= c
    K[..., :, 0] -= c
    K[..., 4, :] += c
    K[..., :, 4] += c
    return f, K


class NonlinearForce:
    """Assembled internal nonlinear force f_nl(u) and tangent of a :class:`Model`.

    ``f, Kt = NonlinearForce(model)(u, theta1, theta4)``; the element rotations come from the
    crank angles (rad).  ``u`` is one state, shape ``(n,)``.
    """

    def __init__(self, model: Model) -> None:
        self.model = model
        p = model.params
        self.EA = p.E * p.A
        self._dofs = [np.array(el.dofs) for el in model.elements]

    def __call__(self, u: ArrayLike, theta1: float, theta4: float) -> tuple[NDArray, NDArray]:
        m = self.model
        u = np.asarray(u, float)
        n = m.n
        angles = link_angles(m.params, theta1, theta4)
        betas = m.element_angles(angles)
        up = np.append(u, 0.0)
        f = np.zeros(n + 1)
        K = np.zeros((n + 1, n + 1))
        for el, beta, idx in zip(m.elements, betas, self._dofs):
            R = m._rotations(np.asarray(beta))
            fl, Kl = element_force(R @ up[idx], el.length, self.EA)
            f[idx] += R.T @ fl
            K[np.ix_(idx, idx)] += R.T @ Kl @ R
        return f[:n], K[:n, :n]

    def energy(self, u: ArrayLike, theta1: float, theta4: float) -> float:
        """Total nonlinear strain energy (J) at state ``u``."""
        m = self.model
        up = np.append(np.asarray(u, float), 0.0)
        betas = m.element_angles(link_angles(m.params, theta1, theta4))
        return float(
            sum(
                element_energy(m._rotations(np.asarray(b)) @ up[idx], el.length, self.EA)
                for el, b, idx in zip(m.elements, betas, self._dofs)
            )
        )
