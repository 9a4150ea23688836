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

    & f_{1,5} = \mp\frac{EA}{2L}\int W'^2, \quad
    f_i = EA\int \big(V' W' + \tfrac12 W'^3\big) g_i, \\
    & K_{ij} = EA\int\big(V' + \tfrac32 W'^2\big) g_i g_j, \quad
    K_{1i,5i} = \mp\frac{EA}{L}\int W' g_i ,

integrated exactly by Gauss-Legendre quadrature (10 points: the integrands are polynomials of
degree at most 16).  Element forces are rotated to the global frame and assembled like the
linear matrices; they depend on the configuration through the element rotations.

**Evaluation in the global DOFs.**  With the element rotation :math:`\mathbf R_e` and the
element's global DOFs :math:`\mathbf u_e`, the slope at Gauss point :math:`p` is
:math:`W'_p = \mathbf G_{ep}\mathbf u_e` with :math:`\mathbf G_{ep} = \mathbf g_p^\top\mathbf R_e`,
and the stretch :math:`V' = \mathbf a_e^\top\mathbf u_e` with
:math:`\mathbf a_e^\top = (\mathbf R_e[4,:] - \mathbf R_e[0,:])/L`.  Then

.. math::

    \mathbf f_e ={}& EA\Big(\sum_p w_p\big(V' + \tfrac12 W_p'^2\big)W'_p\,\mathbf G_{ep}^\top
        + \tfrac12\sum_p w_p W_p'^2\,\mathbf a_e\Big), \\
    \mathbf K_e ={}& EA\Big(\sum_p w_p\big(V' + \tfrac32 W_p'^2\big)\mathbf G_{ep}^\top\mathbf G_{ep}
        + \mathbf a_e\mathbf c_e^\top + \mathbf c_e\mathbf a_e^\top\Big),

:math:`\mathbf c_e = \sum_p w_p W'_p\mathbf G_{ep}^\top`: the rotated form of the local
force and tangent above.  :class:`NonlinearForce` evaluates all elements at once: the
configuration enters only through :class:`ElementGeometry`, the rows :math:`\mathbf G_{ep}` and
:math:`\mathbf a_e^\top` (repeated at each Gauss point of the element) scattered into the
global DOFs, so that all slopes and stretches are one product :math:`\mathbf H\mathbf u` and the
tangent one product :math:`\mathbf H^\top\mathbf Z`.  A caller stepping through known instants
computes the geometry once per instant (:class:`fivebar.dynamics.LinkageDynamics` does, for the
S step times of a period).
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .assembly import Model
from .elements import gauss_points, shape_functions
from .kinematics import link_angles

__all__ = ["ElementGeometry", "NonlinearForce", "element_energy", "element_force"]

_TRANSVERSE = np.array([1, 2, 3, 5, 6, 7])
_GAUSS = 10


@lru_cache(maxsize=64)
def _slopes_of(L: float) -> tuple[NDArray, NDArray]:
    x, w = gauss_points(_GAUSS, L)
    g = shape_functions(x, L, derivative=1)
    g[:, [0, 4]] = 0.0
    w.flags.writeable = False
    g.flags.writeable = False
    return w, g


def _slopes(L: float) -> tuple[NDArray, NDArray]:
    """Gauss weights (m) and transverse shape-function slopes g (npts, 8) of one element
    (cached per length: read-only arrays)."""
    return _slopes_of(float(L))


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


class ElementGeometry(NamedTuple):
    """The configuration as the nonlinear force sees it: slope and stretch operators.

    ``H[..., 0, :, :] @ u`` gives the slope W' of every element at its Gauss points
    (element-major, ``n_elements * n_gauss`` values) and ``H[..., 1, :, :] @ u`` the stretch
    V' of the element of each Gauss point, for a state ``u`` of the force's DOFs.  Leading
    dimensions, if any, are those of the crank angles given to
    :meth:`NonlinearForce.geometry`.
    """

    H: NDArray  #: (..., 2, n_elements * n_gauss, n): slope and stretch per unit DOF

    def at(self, k: int) -> ElementGeometry:
        """The geometry of instant ``k`` of a sampled (leading-dimension) geometry."""
        return ElementGeometry(self.H[k])


class NonlinearForce:
    """Assembled internal nonlinear force f_nl(u) and tangent of a :class:`Model`.

    ``f, Kt = NonlinearForce(model)(u, theta1, theta4)``; the element rotations come from the
    crank angles (rad).  ``u`` is one state, shape ``(n,)``.  For repeated evaluation at the
    same configuration, ``geom = nl.geometry(theta1, theta4)`` (vectorised over arrays of
    angles; pick one instant with ``geom.at(k)``) and ``nl.evaluate(u, geom)``: the
    configuration-dependent work (link angles, rotations, assembly of the slope and stretch
    operators) is then done once per configuration, and an evaluation is a few small dense
    products.

    Parameters
    ----------
    model
        The assembled structure.
    keep
        Optional indices of the model DOFs to work on: ``u``, ``f`` and ``Kt`` are then
        vectors and matrices on those DOFs only, the other DOFs held at zero.  Default: all.
    """

    def __init__(self, model: Model, keep: ArrayLike | None = None) -> None:
        self.model = model
        p = model.params
        self.EA = p.E * p.A
        keep = np.arange(model.n) if keep is None else np.asarray(keep)
        if (keep.ndim != 1 or keep.dtype.kind not in "iu" or np.any((keep < 0) | (keep >= model.n))
                or np.unique(keep).size != keep.size):
            raise ValueError(f"keep = {keep!r} is not allowed: give distinct integer DOF indices in [0, {model.n})")
        self.keep = keep.astype(int)
        #: number of DOFs of u, f and Kt
        self.n = n = int(keep.size)
        pos = np.full(model.n + 1, n)  # model DOF -> output index; held / dropped -> n (a zero)
        pos[self.keep] = np.arange(n)
        dofs = np.array([el.dofs for el in model.elements])  # -1 for held DOFs
        self._idx = pos[np.where(dofs < 0, model.n, dofs)]  # (n_el, 8) into a padded vector
        self._L = np.array([el.length for el in model.elements])
        wg = [_slopes(el.length) for el in model.elements]
        self._wE = self.EA * np.concatenate([w for w, _ in wg])  # EA x Gauss weights (N m)
        self._g = np.array([g for _, g in wg])  # (n_el, npts, 8), local slopes
        self._npts = self._g.shape[1]

    def element_geometry(self, *theta: ArrayLike) -> tuple[NDArray, NDArray]:
        """Per-element slope rows ``Ge`` (..., n_el, n_gauss, 8) and stretch rows ``ae``
        (..., n_el, 8) in the element's global DOFs, at crank angles (rad) of any common shape.

        With :attr:`element_dofs` and :attr:`element_weights` they are what the compiled
        element loop (``fivebar._kernels.nl_force``) needs.
        """
        m = self.model
        betas = np.stack(np.broadcast_arrays(*m.element_angles(link_angles(m.params, *theta))), axis=-1)
        R = m._rotations(betas)  # (..., n_el, 8, 8) local <- global
        Ge = self._g @ R  # (..., n_el, npts, 8)
        ae = (R[..., 4, :] - R[..., 0, :]) / self._L[:, None]  # (..., n_el, 8)
        return Ge, ae

    @property
    def element_dofs(self) -> NDArray:
        """(n_el, 8) index of each element DOF in ``u``, or ``n`` for a held or dropped DOF."""
        return self._idx

    @property
    def element_weights(self) -> NDArray:
        """(n_el, n_gauss) EA times the Gauss weights (N m)."""
        return self._wE.reshape(len(self.model.elements), self._npts)

    def geometry(self, *theta: ArrayLike) -> ElementGeometry:
        """Slope and stretch operators at crank angles (rad, one per driven crank) of any
        (common) shape."""
        m = self.model
        Ge, ae = self.element_geometry(*theta)
        shape = ae.shape[:-2]
        nel, npts, n = len(m.elements), self._npts, self.n
        H = np.zeros(shape + (2, nel, npts, n))
        for e in range(nel):  # scatter the element columns (a DOF appears once per element)
            j = self._idx[e] < n  # local DOFs that are free (not held, kept)
            cols = self._idx[e][j]
            H[..., 0, e, :, cols] = np.moveaxis(Ge[..., e, :, :][..., j], -1, 0)  # (nj, ..., npts)
            H[..., 1, e, :, cols] = np.moveaxis(ae[..., e, :][..., j], -1, 0)[..., None]
        return ElementGeometry(H.reshape(shape + (2, nel * npts, n)))

    def evaluate(self, u: ArrayLike, geometry: ElementGeometry) -> tuple[NDArray, NDArray]:
        """Force f_nl (n,) and tangent d f_nl / d u (n, n) at state ``u`` (n,) and one geometry."""
        H = geometry.H  # (2, P, n): slopes G and stretches A at the P Gauss points
        P, n = H.shape[1], H.shape[2]
        H2 = H.reshape(2 * P, n)
        wE = self._wE
        WV = H2 @ u
        Wp, Vp = WV[:P], WV[P:]
        W2 = Wp * Wp
        ww = wE * Wp
        # f = sum_p EA w (V' + W'^2/2) W' G_p + sum_p EA w W'^2 / 2 A_p
        c = np.empty((2, P))
        np.multiply(Vp + 0.5 * W2, ww, out=c[0])
        np.multiply(0.5 * ww, Wp, out=c[1])
        f = c.reshape(2 * P) @ H2
        # K = G^T diag(EA w (V' + 3/2 W'^2)) G + G^T diag(EA w W') A + A^T diag(EA w W') G
        Z = ww[:, None] * H[::-1]
        Z[0] += ((Vp + 1.5 * W2) * wE)[:, None] * H[0]
        K = H2.T @ Z.reshape(2 * P, n)
        return f, K

    def __call__(self, u: ArrayLike, *theta: float) -> tuple[NDArray, NDArray]:
        u = np.asarray(u, float)
        if u.shape != (self.n,):
            raise ValueError(f"u has shape {u.shape}: expected ({self.n},), one state of the force's DOFs")
        return self.evaluate(u, self.geometry(*(float(x) for x in theta)))

    def energy(self, u: ArrayLike, *theta: float) -> float:
        """Total nonlinear strain energy (J) at state ``u``."""
        H = self.geometry(*(float(x) for x in theta)).H
        Wp, Vp = H @ np.asarray(u, float)
        return float(np.sum((0.5 * Vp * Wp**2 + 0.125 * Wp**4) * self._wE))
