r"""Compiled kernels of the time loop (numba): the Newmark / HHT / generalised-alpha step with
Newton iterations, dense LU of the small step matrices, the nonlinear element force and tangent
element by element, and the propagation of the step Jacobians (monodromy).

They implement exactly the algorithm of :func:`fivebar.newmark.integrate` (its docstring gives
the equations, (4.2)-(4.4) of the paper and their generalised-alpha form); this module only
removes the interpreter from the inner loop.  :mod:`fivebar.newmark` decides when they serve
(periodic step data or a time-invariant system, a linear model or a nonlinear force that supplies
its element data) and keeps the Python loop for a generic system with Python callbacks.

Compiled functions are cached on disk (``cache=True``), in ``__pycache__`` beside this file or,
where that is not writable (a read-only install), in numba's fallback user-wide cache directory;
set ``NUMBA_CACHE_DIR`` to choose another place.  The time loop's work arrays are made once
per call (the element loop's four small ones per evaluation), matrix-vector products and
norms are plain loops (no temporaries); the products with the sensitivity blocks call BLAS.

Status codes returned by :func:`march` (the caller raises the matching error):
0 converged, 1 residual not finite, 2 Newton did not converge in ``max_iter``, 3 singular tangent.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

OK, NOT_FINITE, NO_CONVERGENCE, SINGULAR = 0, 1, 2, 3


# --- small dense linear algebra -----------------------------------------------------------------
@njit(cache=True)
def lu_factor(A, piv):
    """LU with partial pivoting of the square ``A`` in place (LAPACK getrf layout, 0-based
    pivots).  Returns ``(dmin, dmax)``, the smallest and largest ``|U_kk|``."""
    n = A.shape[0]
    row = np.empty(n)
    for k in range(n):
        p = k
        m = abs(A[k, k])
        for i in range(k + 1, n):
            x = abs(A[i, k])
            if x > m:
                m = x
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                t = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = t
        akk = A[k, k]
        if akk != 0.0:
            inv = 1.0 / akk
            w = n - k - 1
            for j in range(w):  # the pivot row in a separate array: the update below then
                row[j] = A[k, k + 1 + j]  # vectorises (3 times faster at n = 94, same result)
            for i in range(k + 1, n):
                A[i, k] *= inv
            for i in range(k + 1, n):
                lik = A[i, k]
                if lik != 0.0:
                    for j in range(w):
                        A[i, k + 1 + j] -= lik * row[j]
    dmin = math.inf
    dmax = 0.0
    for k in range(n):
        d = abs(A[k, k])
        if d < dmin or d != d:
            dmin = d
        if d > dmax or d != d:
            dmax = d
    return dmin, dmax


@njit(cache=True)
def singular(dmin, dmax):
    """The test of :func:`fivebar.newmark._factor`: a pivot below 1e-14 of the largest, or
    not finite."""
    return not (dmin > 1e-14 * dmax) or not math.isfinite(dmax)


@njit(cache=True)
def lu_solve(LU, piv, b):
    """Solve ``A x = b`` in place (``b`` (n,)) with a factorisation from :func:`lu_factor`."""
    n = LU.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            t = b[k]
            b[k] = b[p]
            b[p] = t
    for i in range(1, n):
        s = b[i]
        for k in range(i):
            s -= LU[i, k] * b[k]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, n):
            s -= LU[i, k] * b[k]
        b[i] = s / LU[i, i]


@njit(cache=True)
def lu_solve_matrix(LU, piv, B):
    """Solve ``A X = B`` in place (``B`` (n, m)), row operations on contiguous rows."""
    n = LU.shape[0]
    m = B.shape[1]
    for k in range(n):
        p = piv[k]
        if p != k:
            for j in range(m):
                t = B[k, j]
                B[k, j] = B[p, j]
                B[p, j] = t
    acc = np.empty(m)  # row i accumulated apart from B: the updates then vectorise
    for i in range(1, n):
        for j in range(m):
            acc[j] = B[i, j]
        for k in range(i):
            lik = LU[i, k]
            if lik != 0.0:
                for j in range(m):
                    acc[j] -= lik * B[k, j]
        for j in range(m):
            B[i, j] = acc[j]
    for i in range(n - 1, -1, -1):
        for j in range(m):
            acc[j] = B[i, j]
        for k in range(i + 1, n):
            uik = LU[i, k]
            if uik != 0.0:
                for j in range(m):
                    acc[j] -= uik * B[k, j]
        inv = 1.0 / LU[i, i]
        for j in range(m):
            B[i, j] = acc[j] * inv


@njit(cache=True)
def matvec(A, x, out):
    """``out = A @ x`` (loops; n is small)."""
    n, m = A.shape
    for i in range(n):
        s = 0.0
        for j in range(m):
            s += A[i, j] * x[j]
        out[i] = s


@njit(cache=True)
def gemm_acc(alpha, A, B, out, tmp):
    """``out += alpha A @ B``; the product by BLAS (``tmp`` receives it): for the (n, 2n-3n)
    sensitivity blocks three times faster than loops."""
    np.dot(A, B, tmp)
    n, p = out.shape
    for i in range(n):
        for j in range(p):
            out[i, j] += alpha * tmp[i, j]


@njit(cache=True)
def nrm2(x):
    """Euclidean norm without a temporary."""
    s = 0.0
    for i in range(x.size):
        s += x[i] * x[i]
    return math.sqrt(s)


# --- nonlinear element force and tangent (fivebar.nonlinear) ------------------------------------
@njit(cache=True)
def nl_force(u, Ge, ae, wE, idx, measure, f, Kt, tangent):
    r"""Internal nonlinear force ``f`` (n,) and, if ``tangent``, its Jacobian ``Kt`` (n, n),
    element by element: the loop form of ``fivebar.nonlinear._force`` (see
    :mod:`fivebar.nonlinear` for the formulas).

    ``Ge`` (n_el, n_gauss, 8): slope rows :math:`\mathbf G_{ep}` in the element's global DOFs;
    ``ae`` (n_el, 8): stretch rows :math:`\mathbf a_e`; ``wE`` (n_el, n_gauss): EA times the
    Gauss weights; ``idx`` (n_el, 8): index of each element DOF in ``u``, or ``n`` for a DOF
    held at zero; ``measure``: the strain measure's index in
    ``fivebar.nonlinear.STRAIN_MEASURES`` (0 literal, 1 corotated, 2 uniform).
    """
    n = u.size
    nel, npts, _ = Ge.shape
    ue = np.empty(8)
    fl = np.empty(8)
    b = np.empty(8)
    cb = np.empty(8)
    D = np.empty(8)
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
        if tangent:
            for i in range(8):
                for j in range(8):
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
                for i in range(8):
                    gi = Ge[e, p, i]
                    for j in range(8):
                        gj = Ge[e, p, j]
                        h = gi * gj
                        if measure == 1:
                            h += 2.0 * b[i] * b[j] - gi * b[j] - b[i] * gj
                        Kl[i, j] += w * (D[i] * (ae[e, j] + D[j]) + ae[e, i] * D[j]) + N * h
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
                        Kt[di, dj] += Kl[i, j]


# --- the time loop ----------------------------------------------------------------------------------
@njit(cache=True)
def _tangent(Mb, C, K, Kt, cM, cC, cK, nonlin, St):
    n = St.shape[0]
    for i in range(n):
        for j in range(n):
            s = cM * Mb[i, j] + cC * C[i, j]
            St[i, j] = s + cK * (K[i, j] + Kt[i, j]) if nonlin else s + cK * K[i, j]


@njit(cache=True)
def _full_lu(u, G, Ae, wE, idx, measure, fnl, Kt, Mb, C, K, cM, cC, cK, St, piv):
    """The consistent tangent at ``u`` (f_nl and K_t evaluated) into ``St``, factorised;
    returns ``(ok, dmin, dmax)``, ok False if singular."""
    nl_force(u, G, Ae, wE, idx, measure, fnl, Kt, True)
    _tangent(Mb, C, K, Kt, cM, cC, cK, True, St)
    dmin, dmax = lu_factor(St, piv)
    return not singular(dmin, dmax), dmin, dmax


@njit(cache=True)
def _linear_lu(LUc, pivc, have, i, Mb, C, K, Kt, cM, cC, cK):
    """Fill slot ``i`` of the linear-tangent cache if empty; returns False if singular."""
    if have[i]:
        return True, 0.0, 0.0
    _tangent(Mb, C, K, Kt, cM, cC, cK, False, LUc[i])
    dmin, dmax = lu_factor(LUc[i], pivc[i])
    if singular(dmin, dmax):
        return False, dmin, dmax
    have[i] = 1
    return True, dmin, dmax


@njit(cache=True)
def march(Ms, Cs, Ks, Fs, k0, m_const, u, v, a, gn, nsteps, t0, dt, g, b, am, af,
          nonlin, Ge, ae, wE, idx, measure, Kt0,
          rtol, xtol, atol, max_iter, full,
          LUc, pivc, have,
          sens, Pu, Pv, Pa,
          store_all, T, U, V, A, iters, info):
    """March ``nsteps`` steps; see :func:`fivebar.newmark.integrate`.

    Per-step data are read at index ``(k0 + j) % len`` of ``Ms, Cs, Ks, Fs`` (and of the
    element geometry ``Ge, ae`` and the linear-tangent cache ``LUc, pivc, have``), so that a
    length-1 array is a constant.  ``u, v, a, gn`` (state and alpha history) and ``Pu, Pv, Pa``
    (sensitivity blocks, if ``sens``) are updated in place.  ``info`` receives the failing step,
    time, residual, iterations, pivots and reference norm.  Returns a status code.
    """
    n = u.size
    SM, SC, SK, SF = Ms.shape[0], Cs.shape[0], Ks.shape[0], Fs.shape[0]
    SG = Ge.shape[0]
    SL = LUc.shape[0]
    newmark = am == 0.0 and af == 0.0
    bdt2 = b * dt * dt
    cM = (1.0 - am) / bdt2
    cC = (1.0 - af) * g / (b * dt)
    cK = 1.0 - af
    c_up = dt * dt * (0.5 - b)
    c_vp = dt * (1.0 - g)
    gdt = g * dt

    ut = np.empty(n)
    vt = np.empty(n)
    u1 = np.empty(n)
    v1 = np.empty(n)
    a1 = np.empty(n)
    R = np.empty(n)
    Ma = np.empty(n)
    Cv = np.empty(n)
    Ku = np.empty(n)
    hist = np.zeros(n)
    fnl = np.zeros(n)
    Kt = np.zeros((n, n))
    Ktp = Kt0.copy()
    St = np.empty((n, n))
    piv = np.empty(n, np.int64)
    Mbw = np.empty((n, n))
    ms = Pu.shape[1]
    Dut = np.empty((n, ms))
    Dvt = np.empty((n, ms))
    Das = np.empty((n, ms))
    Wv = np.empty((n, ms))
    dR = np.empty((n, ms))
    Tmp = np.empty((n, ms))

    for j in range(1, nsteps + 1):
        t = t0 + j * dt
        kk = k0 + j
        M = Ms[kk % SM]
        C = Cs[kk % SC]
        K = Ks[kk % SK]
        F = Fs[kk % SF]
        if m_const:
            Mb = M
        else:
            Mp = Ms[(kk - 1) % SM]
            for i in range(n):
                for l in range(n):
                    Mbw[i, l] = (1.0 - af) * M[i, l] + af * Mp[i, l]
            Mb = Mbw
        for i in range(n):
            ut[i] = u[i] + dt * v[i] + c_up * a[i]
            vt[i] = v[i] + c_vp * a[i]
            u1[i] = ut[i] + bdt2 * a[i]
        if not newmark:
            matvec(Mb, a, Ma)
            for i in range(n):
                hist[i] = am * Ma[i] + af * gn[i]
        li = kk % SL
        if not nonlin:
            for i in range(n):
                v1[i] = vt[i] + gdt * a[i]
            matvec(Mb, a, Ma)
            matvec(C, v1, Cv)
            matvec(K, u1, Ku)
            if newmark:
                for i in range(n):
                    R[i] = Ma[i] + Cv[i] + Ku[i] - F[i]
            else:
                for i in range(n):
                    R[i] = (1.0 - am) * Ma[i] + (1.0 - af) * (Cv[i] + Ku[i] - F[i]) + hist[i]
            ok, dmin, dmax = _linear_lu(LUc, pivc, have, li, Mb, C, K, Kt, cM, cC, cK)
            if not ok:
                info[0], info[1], info[4], info[5] = j, t, dmin, dmax
                return SINGULAR
            lu_solve(LUc[li], pivc[li], R)
            for i in range(n):
                u1[i] -= R[i]
            LU = LUc[li]
            P = pivc[li]
        else:
            G = Ge[kk % SG]
            Ae = ae[kk % SG]
            k_it = 0
            du_norm = math.inf
            while True:
                nl_force(u1, G, Ae, wE, idx, measure, fnl, Kt, False)
                for i in range(n):
                    a1[i] = (u1[i] - ut[i]) / bdt2
                    v1[i] = vt[i] + gdt * a1[i]
                matvec(Mb, a1, Ma)
                matvec(C, v1, Cv)
                matvec(K, u1, Ku)
                for i in range(n):
                    R[i] = (1.0 - am) * Ma[i] + (1.0 - af) * (Cv[i] + Ku[i] + fnl[i] - F[i])
                ref = (1.0 - am) * nrm2(Ma) + (1.0 - af) * (
                    nrm2(Cv) + nrm2(Ku) + nrm2(fnl) + nrm2(F))
                if not newmark:
                    for i in range(n):
                        R[i] += hist[i]
                    ref += nrm2(hist)
                rn = nrm2(R)
                if not math.isfinite(rn):
                    info[0], info[1], info[2], info[3] = j, t, rn, k_it
                    return NOT_FINITE
                if rn <= rtol * ref + atol or du_norm <= xtol * nrm2(u1):
                    break
                if k_it >= max_iter:
                    info[0], info[1], info[2], info[3], info[6] = j, t, rn, k_it, ref
                    return NO_CONVERGENCE
                if full:
                    # the tangent only now, when an update follows (not at the converged point)
                    ok, dmin, dmax = _full_lu(u1, G, Ae, wE, idx, measure, fnl, Kt, Mb, C, K, cM, cC, cK, St, piv)
                    if not ok:
                        info[0], info[1], info[4], info[5] = j, t, dmin, dmax
                        return SINGULAR
                    lu_solve(St, piv, R)
                else:
                    ok, dmin, dmax = _linear_lu(LUc, pivc, have, li, Mb, C, K, Kt, cM, cC, cK)
                    if not ok:
                        info[0], info[1], info[4], info[5] = j, t, dmin, dmax
                        return SINGULAR
                    lu_solve(LUc[li], pivc[li], R)
                s = 0.0
                for i in range(n):
                    u1[i] -= R[i]
                    s += R[i] * R[i]
                du_norm = math.sqrt(s)
                k_it += 1
            iters[j - 1] = k_it
            if sens:  # the consistent tangent at the converged u_{n+1}
                ok, dmin, dmax = _full_lu(u1, G, Ae, wE, idx, measure, fnl, Kt, Mb, C, K, cM, cC, cK, St, piv)
                if not ok:
                    info[0], info[1], info[4], info[5] = j, t, dmin, dmax
                    return SINGULAR
            LU = St
            P = piv
        for i in range(n):
            a1[i] = (u1[i] - ut[i]) / bdt2
            v1[i] = vt[i] + gdt * a1[i]

        if sens:
            for i in range(n):
                for l in range(ms):
                    dut = Pu[i, l] + dt * Pv[i, l] + c_up * Pa[i, l]
                    dvt = Pv[i, l] + c_vp * Pa[i, l]
                    das = -dut / bdt2
                    Dut[i, l] = dut
                    Dvt[i, l] = dvt
                    Das[i, l] = das
                    Wv[i, l] = dvt + gdt * das
                    dR[i, l] = 0.0
            # dR = (1-am) Mb das + (1-af) C (dvt + g dt das)
            #      [+ am Mb Pa + af ((K + Kt)_n Pu + C_n Pv), the blocks at t_n]
            gemm_acc(1.0 - am, Mb, Das, dR, Tmp)
            gemm_acc(1.0 - af, C, Wv, dR, Tmp)
            if not newmark:
                gemm_acc(am, Mb, Pa, dR, Tmp)
                gemm_acc(af, Ks[(kk - 1) % SK], Pu, dR, Tmp)
                if nonlin:
                    gemm_acc(af, Ktp, Pu, dR, Tmp)
                gemm_acc(af, Cs[(kk - 1) % SC], Pv, dR, Tmp)
            lu_solve_matrix(LU, P, dR)
            for i in range(n):
                for l in range(ms):
                    du1 = -dR[i, l]
                    da1 = (du1 - Dut[i, l]) / bdt2
                    Pu[i, l] = du1
                    Pv[i, l] = Dvt[i, l] + gdt * da1
                    Pa[i, l] = da1
            if nonlin and not newmark:
                for i in range(n):
                    for l in range(n):
                        Ktp[i, l] = Kt[i, l]
        if not newmark:
            matvec(C, v1, Cv)
            matvec(K, u1, Ku)
            for i in range(n):
                gn[i] = Cv[i] + Ku[i] - F[i] + (fnl[i] if nonlin else 0.0)
        for i in range(n):
            u[i] = u1[i]
            v[i] = v1[i]
            a[i] = a1[i]
        if store_all:
            T[j] = t
            for i in range(n):
                U[j, i] = u[i]
                V[j, i] = v[i]
                A[j, i] = a[i]
    if not store_all:
        T[1] = t0 + nsteps * dt
        for i in range(n):
            U[1, i] = u[i]
            V[1, i] = v[i]
            A[1, i] = a[i]
    return OK
