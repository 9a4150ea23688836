r"""Geometric nonlinearity of the links: the small parameter :math:`\varepsilon` of (2.7), (2.8).

The printed strain energy (2.5) repeats one term three times (errata E10).  It is read as the
energy of a beam with the axial strain of a moderately large deflection,
:math:`\epsilon = V' + \tfrac12 W'^2`:

.. math::

    V_3 = \frac{EJ}{2}\int_0^L W''^2\,d\bar x + \frac{EA}{2}\int_0^L \epsilon^2\, d\bar x .

Its quadratic part is the linear stiffness :math:`\overline{\mathbf K}_3` of (A.8); the rest,
with :math:`\epsilon = V' + e` and :math:`e` the nonlinear part of the strain,

.. math::

    \Pi_{nl} = EA\int_0^L \Big(V' e + \tfrac12 e^2\Big)\,d\bar x ,

is cubic and quartic in the element DOFs.  Its gradient is the internal nonlinear force, the
negative of the paper's :math:`\varepsilon`.

**Strain measures** (:data:`STRAIN_MEASURES`, the parameter file's ``strain_measure``; errata
E30).  The element's axial field is linear, :math:`V' = (u_5 - u_1)/L`, its slope
:math:`W' = \mathbf g^\top\mathbf q` (:math:`\mathbf g = [\gamma_i']`) a polynomial; its chord
turns by :math:`\varphi = (w_2 - w_1)/L`, the mean of :math:`W'`.

* ``"literal"``: :math:`e = \tfrac12 W'^2` at each point, the paper's (2.8) (its quadratic
  terms :math:`\mathbf G_n, \mathbf K_n` and cubic terms :math:`\mathbf G_{gl},
  \mathbf K_{gl}` are the two parts of this energy, errata E29).  A continuous beam's axial
  displacement follows :math:`\tfrac12 W'^2` along the span; the linear field cannot, and a
  chord rotation :math:`\varphi` adds :math:`\varphi(W' - \varphi)` at each point, a strain
  with zero mean that no stretch causes, whose energy :math:`\tfrac{EA}2\varphi^2\int(W'-\varphi)^2`
  stiffens the bending (membrane locking).  It converges only as the mesh is refined.
* ``"corotated"``: the slopes measured from the deformed chord,
  :math:`e = \tfrac12\varphi^2 + \tfrac12 (W' - \varphi)^2` (the chord's stretch to second
  order plus the local slope): the rotation term is gone; the variation of
  :math:`(W'-\varphi)^2` along the element is left.
* ``"uniform"`` (default): the mean over the element,
  :math:`e = \frac1{2L}\int_0^L W'^2`, the same at every point: the stretch of the chord plus
  the excess of the arc length over it.  This is the exact strain of a beam of moderately large
  deflection whose axial force is uniform between nodes (the axial field condensed); a rigid
  rotation of a bent element leaves it unchanged.

All three have the same element mean of :math:`e`; they differ in its variation along the
element.  With the element's :math:`N_p = EA\,w_p (V' + e_p)` at the Gauss points and the
gradient rows :math:`\mathbf D_p = \partial e_p/\partial\mathbf q`, the force and tangent are

.. math::

    \mathbf f = \sum_p EA\,w_p\, e_p\,\mathbf a + \sum_p N_p\,\mathbf D_p ,

    \mathbf K = \sum_p EA\,w_p\big(\mathbf D_p(\mathbf a + \mathbf D_p)^\top
        + \mathbf a\mathbf D_p^\top\big) + \sum_p N_p\,\frac{\partial^2 e_p}{\partial\mathbf q^2},

:math:`\mathbf a` the stretch row (:math:`V' = \mathbf a^\top\mathbf q`), integrated exactly by
Gauss-Legendre quadrature (10 points: the integrands are polynomials of degree at most 16).
The :math:`N_p\,\partial^2 e_p/\partial\mathbf q^2` term is the geometric stiffness of the axial
force: the axial force the rigid-body inertia puts in a link (through the axial DOFs, whose
:math:`V'` carries it) stiffens its bending.  Element forces are rotated to the global frame
and assembled like the linear matrices; they depend on the configuration through the element
rotations.

**Evaluation in the global DOFs.**  With the element rotation :math:`\mathbf R_e` and the
element's global DOFs :math:`\mathbf u_e`, the slope at Gauss point :math:`p` is
:math:`W'_p = \mathbf G_{ep}\mathbf u_e` with :math:`\mathbf G_{ep} = \mathbf g_p^\top\mathbf R_e`,
and the stretch :math:`V' = \mathbf a_e^\top\mathbf u_e` with
:math:`\mathbf a_e^\top = (\mathbf R_e[4,:] - \mathbf R_e[0,:])/L`.  :class:`NonlinearForce`
evaluates all elements at once: the configuration enters only through
:class:`ElementGeometry`, the rows :math:`\mathbf G_{ep}` and :math:`\mathbf a_e^\top`
(repeated at each Gauss point of the element) scattered into the global DOFs, so that all
slopes and stretches are one product :math:`\mathbf H\mathbf u`.  A caller stepping through
known instants computes the geometry once per instant (:class:`fivebar.model.dynamics.LinkageDynamics`
does, for the S step times of a period).  The compiled element loop
(``fivebar.model._nonlinear_kernel``) evaluates the same definition; the tests hold the two equal to
round-off for every strain measure.  :meth:`NonlinearForce.compiled` hands it, with the
geometry of the step times, to the compiled time loop of :mod:`fivebar.numerics.newmark`, which calls
it as a function it is given and knows nothing of the beam.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .assembly import Model
from ..cache import memoised
from ..errors import InputError
from .elements import gauss_points, shape_functions
from .kinematics import link_angles

__all__ = ["STRAIN_MEASURES", "ElementGeometry", "NonlinearForce", "element_energy", "element_force"]

_TRANSVERSE = np.array([1, 2, 3, 5, 6, 7])
_GAUSS = 10


@memoised
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


#: The forms of the membrane strain (errata E30), in the order of their index in the compiled kernel.
STRAIN_MEASURES = ("literal", "corotated", "uniform")


def _measure_code(strain_measure: str) -> int:
    if strain_measure not in STRAIN_MEASURES:
        raise InputError(f"strain_measure = {strain_measure!r} is not allowed: use one of {list(STRAIN_MEASURES)}")
    return STRAIN_MEASURES.index(strain_measure)


def _strain(Wp: NDArray, wE: NDArray, G: NDArray, nel: int, measure: int):
    """Nonlinear part ``e`` (P,) of the membrane strain at the P Gauss points, its gradient
    rows ``D`` (P, n) and the per-point extra rows ``B`` of its Hessian (None unless
    corotated), for slopes ``Wp`` (P,) = ``G @ u``, element-major with ``nel`` elements."""
    P, n = G.shape
    npts = P // nel
    Wr, wr = Wp.reshape(nel, npts), wE.reshape(nel, npts)
    EAL = wr.sum(axis=1, keepdims=True)  # EA L per element
    if measure == 0:  # literal: W'^2 / 2 at each point
        return 0.5 * Wp * Wp, Wp[:, None] * G, None
    Gr = G.reshape(nel, npts, n)
    if measure == 1:  # slopes from the chord phi, chord stretched by phi^2 / 2
        phi = (wr * Wr).sum(axis=1, keepdims=True) / EAL
        s = Wr - phi
        b = np.einsum("ep,epn->en", wr, Gr) / EAL  # chord rotation per unit DOF
        Brep = np.repeat(b, npts, axis=0)  # (P, n)
        e = (0.5 * phi * phi + 0.5 * s * s).reshape(P)
        D = s.reshape(P)[:, None] * G + (phi - s).reshape(P)[:, None] * Brep
        return e, D, Brep
    # uniform: the element's mean of W'^2 / 2 at every point
    ebar = 0.5 * (wr * Wr * Wr).sum(axis=1, keepdims=True) / EAL
    cbar = np.einsum("ep,epn->en", wr * Wr, Gr) / EAL
    return np.repeat(ebar, npts, axis=1).reshape(P), np.repeat(cbar, npts, axis=0), None


def _force(u: NDArray, G: NDArray, A: NDArray, wE: NDArray, nel: int, measure: int,
           tangent: bool = True) -> tuple[NDArray, NDArray | None]:
    """f_nl and its tangent from slope rows ``G`` and stretch rows ``A`` (P, n) at the P Gauss
    points (element-major, ``nel`` elements) with weights ``wE`` (EA times Gauss weight)."""
    Wp, Vp = G @ u, A @ u
    e, D, B = _strain(Wp, wE, G, nel, measure)
    N = wE * (Vp + e)  # membrane force times weight at each point
    f = A.T @ (wE * e) + D.T @ N
    if not tangent:
        return f, None
    X = A.T @ (wE[:, None] * D)
    K = X + X.T + D.T @ (wE[:, None] * D) + G.T @ (N[:, None] * G)
    if B is not None:  # corotated: the Hessian of (phi^2 + s^2)/2 is b b^T + h h^T, h = G - b
        Y = G.T @ (N[:, None] * B)
        K += 2.0 * (B.T @ (N[:, None] * B)) - Y - Y.T
    return f, K


def _energy(u: NDArray, G: NDArray, A: NDArray, wE: NDArray, nel: int, measure: int) -> float:
    Wp, Vp = G @ u, A @ u
    e = _strain(Wp, wE, G, nel, measure)[0]
    return float(np.sum(wE * (Vp * e + 0.5 * e * e)))


def _local_rows(L: float) -> tuple[NDArray, NDArray, NDArray]:
    w, g = _slopes(L)
    a = np.zeros((w.size, 8))
    a[:, 0], a[:, 4] = -1.0 / L, 1.0 / L
    return w, g, a


def element_energy(q: ArrayLike, L: float, EA: float, strain_measure: str = "literal") -> NDArray:
    """Nonlinear strain energy Pi_nl (J) of elements with local DOFs ``q`` (..., 8).

    ``strain_measure``: the form of the membrane strain (:data:`STRAIN_MEASURES`); the
    paper's literal (2.8) by default here, the model takes the parameter file's
    ``strain_measure``.
    """
    code = _measure_code(strain_measure)
    q = np.asarray(q, float)
    w, g, a = _local_rows(L)
    out = np.empty(q.shape[:-1])
    for k in np.ndindex(q.shape[:-1]):
        out[k] = _energy(q[k], g, a, EA * w, 1, code)
    return out if out.ndim else out[()]


def element_force(q: ArrayLike, L: float, EA: float, strain_measure: str = "literal") -> tuple[NDArray, NDArray]:
    """Local nonlinear force (..., 8) and tangent (..., 8, 8) of elements with DOFs ``q``
    (``strain_measure`` as in :func:`element_energy`)."""
    code = _measure_code(strain_measure)
    q = np.asarray(q, float)
    w, g, a = _local_rows(L)
    f, K = np.empty(q.shape), np.empty(q.shape + (8,))
    for k in np.ndindex(q.shape[:-1]):
        f[k], K[k] = _force(q[k], g, a, EA * w, 1, code)
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
    strain_measure
        The form of the membrane strain, one of :data:`STRAIN_MEASURES`; ``None`` takes the
        parameter file's ``strain_measure``.
    """

    def __init__(self, model: Model, keep: ArrayLike | None = None, strain_measure: str | None = None) -> None:
        self.model = model
        p = model.params
        #: EA (N) of every element's link (its own section and material)
        self.EA = np.array([model.linkage.link(el.link).material.E * model.linkage.link(el.link).section.area
                            for el in model.elements])
        #: the form of the membrane strain (:data:`STRAIN_MEASURES`)
        self.strain_measure = p.strain_measure if strain_measure is None else strain_measure
        #: its index, as the compiled kernel takes it
        self.measure = _measure_code(self.strain_measure)
        self._nel = len(model.elements)
        keep = np.arange(model.n) if keep is None else np.asarray(keep)
        if (keep.ndim != 1 or keep.dtype.kind not in "iu" or np.any((keep < 0) | (keep >= model.n))
                or np.unique(keep).size != keep.size):
            raise InputError(f"keep = {keep!r} is not allowed: give distinct integer DOF indices in [0, {model.n})")
        self.keep = keep.astype(int)
        #: number of DOFs of u, f and Kt
        self.n = n = int(keep.size)
        pos = np.full(model.n + 1, n)  # model DOF -> output index; held / dropped -> n (a zero)
        pos[self.keep] = np.arange(n)
        dofs = np.array([el.dofs for el in model.elements])  # -1 for held DOFs
        self._idx = pos[np.where(dofs < 0, model.n, dofs)]  # (n_el, 8) into a padded vector
        self._L = np.array([el.length for el in model.elements])
        wg = [_slopes(el.length) for el in model.elements]
        self._wE = np.concatenate([EA * w for EA, (w, _) in zip(self.EA, wg)])  # EA x Gauss weights (N m)
        self._g = np.array([g for _, g in wg])  # (n_el, npts, 8), local slopes
        self._npts = self._g.shape[1]

    def element_geometry(self, *theta: ArrayLike) -> tuple[NDArray, NDArray]:
        """Per-element slope rows ``Ge`` (..., n_el, n_gauss, 8) and stretch rows ``ae``
        (..., n_el, 8) in the element's global DOFs, at crank angles (rad) of any common shape.

        With :attr:`element_dofs` and :attr:`element_weights` they are what the compiled
        element loop (``fivebar.model._nonlinear_kernel.element_loop``) needs.
        """
        m = self.model
        betas = np.stack(np.broadcast_arrays(*m.element_angles(link_angles(m.params, *theta))), axis=-1)
        R = m._rotations(betas, m.element_frames)  # (..., n_el, 8, 8) local <- global (a slider: its guide's frame)
        Ge = self._g @ R  # (..., n_el, npts, 8)
        ae = (R[..., 4, :] - R[..., 0, :]) / self._L[:, None]  # (..., n_el, 8)
        return Ge, ae

    def compiled(self, *theta: ArrayLike) -> tuple:
        """The force as the compiled time loop takes it, at the S configurations of the crank
        angles ``theta`` (rad, arrays of S step points, one per driven crank).

        Returns ``(force, rdata, idata)``: the compiled function
        ``force(u, k, rdata, idata, f, Kt, tangent)`` (the signature
        ``fivebar.numerics._kernels.FORCE_SIG``), which evaluates f_nl and, if ``tangent``, its Jacobian at
        the state ``u`` and step point ``k`` (modulo S), and its data.  Compiles (once, then
        cached on disk) on first use.
        """
        from ..numerics._jitcache import import_cached  # here: numba is heavy

        kern = import_cached(f"{__package__}._nonlinear_kernel")
        Ge, ae = self.element_geometry(*theta)
        if ae.ndim != 3:
            raise InputError(f"crank angles of shape {ae.shape[:-2]} are not allowed: give arrays of "
                             "the S step points, shape (S,)")
        return (kern.force,) + kern.pack(Ge, ae, self.element_weights, self.element_dofs, self.measure)

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
        return _force(np.asarray(u, float), H[0], H[1], self._wE, self._nel, self.measure)

    def __call__(self, u: ArrayLike, *theta: float) -> tuple[NDArray, NDArray]:
        u = np.asarray(u, float)
        if u.shape != (self.n,):
            raise InputError(f"u has shape {u.shape}: expected ({self.n},), one state of the force's DOFs")
        return self.evaluate(u, self.geometry(*(float(x) for x in theta)))

    def energy(self, u: ArrayLike, *theta: float) -> float:
        """Total nonlinear strain energy (J) at state ``u``."""
        H = self.geometry(*(float(x) for x in theta)).H
        return _energy(np.asarray(u, float), H[0], H[1], self._wE, self._nel, self.measure)
