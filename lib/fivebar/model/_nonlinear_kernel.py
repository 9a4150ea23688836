r"""The linkage's strain force (2.8) compiled: the element loop of :mod:`fivebar.model.nonlinear`.

:func:`force` is the model's nonlinear force in the form the compiled time loop takes it
(``fivebar.numerics._kernels.FORCE_SIG``: ``force(u, k, rdata, idata, f, Kt, tangent)``), its data in
two flat arrays made by :func:`pack` from the element geometry sampled at the S step times of
a period (:meth:`fivebar.model.nonlinear.NonlinearForce.compiled`).  :func:`element_loop` is the
element loop at one configuration; the tests hold it equal to the vectorised numpy force of
:mod:`fivebar.model.nonlinear` to round-off, for every strain measure.  Loaded (and cached on disk)
by :func:`fivebar.numerics._jitcache.import_cached`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..numerics._kernels import FORCE_SIG

__all__ = ["element_loop", "force", "pack"]


@njit(cache=True)
def element_loop(u, Ge, ae, wE, idx, measure, f, Kt, tangent):
    r"""Internal nonlinear force ``f`` (n,) and, if ``tangent``, its Jacobian ``Kt`` (n, n),
    element by element: the loop form of ``fivebar.model.nonlinear._force`` (see
    :mod:`fivebar.model.nonlinear` for the formulas), at one configuration.

    ``Ge`` (n_el, n_gauss, 8): slope rows :math:`\mathbf G_{ep}` in the element's global DOFs;
    ``ae`` (n_el, 8): stretch rows :math:`\mathbf a_e`; ``wE`` (n_el, n_gauss): EA times the
    Gauss weights; ``idx`` (n_el, 8): index of each element DOF in ``u``, or ``n`` for a DOF
    held at zero; ``measure``: the strain measure's index in
    ``fivebar.model.nonlinear.STRAIN_MEASURES`` (0 literal, 1 corotated, 2 uniform).
    """
    n = u.size
    nel, npts, _ = Ge.shape
    ue = np.empty(8)
    fl = np.empty(8)
    b = np.empty(8)
    cb = np.empty(8)
    D = np.empty(8)
    ds = np.empty(8)
    cp = np.empty(8)
    W = np.empty(npts)
    Kl = np.empty((8, 8))
    for i in range(n):
        f[i] = 0.0
    if tangent:
        for i in range(n):
            for j in range(n):
                Kt[i, j] = 0.0
    for e in range(nel):
        V = 0.0
        for i in range(8):
            d = idx[e, i]
            ue[i] = u[d] if d < n else 0.0
            V += ae[e, i] * ue[i]
            fl[i] = 0.0
            b[i] = 0.0
            cb[i] = 0.0
            ds[i] = 0.0
        if tangent:
            for i in range(8):
                for j in range(i, 8):
                    Kl[i, j] = 0.0
        EAL = 0.0
        phi = 0.0
        ebar = 0.0
        for p in range(npts):
            Wp = 0.0
            for i in range(8):
                Wp += Ge[e, p, i] * ue[i]
            W[p] = Wp
            w = wE[e, p]
            EAL += w
            phi += w * Wp
            ebar += 0.5 * w * Wp * Wp
            for i in range(8):
                b[i] += w * Ge[e, p, i]
                cb[i] += w * Wp * Ge[e, p, i]
        phi /= EAL
        ebar /= EAL
        for i in range(8):
            b[i] /= EAL
            cb[i] /= EAL
        Nsum = 0.0
        for p in range(npts):
            w = wE[e, p]
            if measure == 0:
                ep = 0.5 * W[p] * W[p]
                for i in range(8):
                    D[i] = W[p] * Ge[e, p, i]
            elif measure == 1:
                s = W[p] - phi
                ep = 0.5 * (phi * phi + s * s)
                for i in range(8):
                    D[i] = s * Ge[e, p, i] + (phi - s) * b[i]
            else:
                ep = ebar
                for i in range(8):
                    D[i] = cb[i]
            N = w * (V + ep)
            we = w * ep
            for i in range(8):
                fl[i] += we * ae[e, i] + N * D[i]
            if tangent:
                # w (D (a + D)^T + a D^T) + N h, h = g g^T (literal, uniform) or
                # g g^T + 2 b b^T - g b^T - b g^T = (g - b)(g - b)^T + b b^T (corotated): the
                # terms in a^T and b b^T summed over the points first, the rest as two
                # symmetric rank-one updates (upper triangle; mirrored when scattered)
                Nsum += N
                for i in range(8):
                    ds[i] += w * D[i]
                    cp[i] = Ge[e, p, i] - b[i] if measure == 1 else Ge[e, p, i]
                for i in range(8):
                    wd = w * D[i]
                    nc = N * cp[i]
                    for j in range(i, 8):
                        Kl[i, j] += wd * D[j] + nc * cp[j]
        if tangent:
            for i in range(8):
                for j in range(i, 8):
                    Kl[i, j] += ds[i] * ae[e, j] + ae[e, i] * ds[j]
                    if measure == 1:
                        Kl[i, j] += Nsum * b[i] * b[j]
        for i in range(8):
            d = idx[e, i]
            if d < n:
                f[d] += fl[i]
        if tangent:
            for i in range(8):
                di = idx[e, i]
                if di >= n:
                    continue
                for j in range(8):
                    dj = idx[e, j]
                    if dj < n:
                        Kt[di, dj] += Kl[i, j] if j >= i else Kl[j, i]


@njit(cache=True)
def force(u, k, rdata, idata, f, Kt, tangent):
    """The force at step point ``k`` (modulo S) from the data of :func:`pack`."""
    S, nel, npts, measure = idata[0], idata[1], idata[2], idata[3]
    idx = idata[4:4 + 8 * nel].reshape((nel, 8))
    o1 = S * nel * npts * 8
    o2 = o1 + S * nel * 8
    Ge = rdata[:o1].reshape((S, nel, npts, 8))
    ae = rdata[o1:o2].reshape((S, nel, 8))
    wE = rdata[o2:o2 + nel * npts].reshape((nel, npts))
    s = k % S
    element_loop(u, Ge[s], ae[s], wE, idx, measure, f, Kt, tangent)


def pack(Ge, ae, wE, idx, measure: int) -> tuple[np.ndarray, np.ndarray]:
    """``(rdata, idata)`` for :func:`force`: slope rows ``Ge`` (S, n_el, n_gauss, 8) and stretch
    rows ``ae`` (S, n_el, 8) at the S step points, weights ``wE`` (n_el, n_gauss), element DOF
    indices ``idx`` (n_el, 8) and the strain measure's index (as :func:`element_loop`)."""
    S, nel, npts, _ = Ge.shape
    rdata = np.concatenate([np.ravel(Ge), np.ravel(ae), np.ravel(wE)]).astype(float)
    idata = np.concatenate([[S, nel, npts, measure], np.ravel(idx)]).astype(np.int64)
    return rdata, idata


#: Compiled when loaded (:func:`fivebar.numerics._jitcache.import_cached`): the signature the time loop calls.
__jit_signatures__ = {"force": (FORCE_SIG,)}
