r"""The time step of :mod:`fivebar.numerics.newmark`, written once (numba), and the compiled time loop.

The step of the Newmark / HHT / generalised-alpha schemes ((4.2)-(4.4) of the paper and their
generalised-alpha form; :mod:`fivebar.numerics.newmark`'s docstring gives the equations) is a handful
of compiled functions: the scheme's :func:`coefficients`, the predictor with the alpha history
(:func:`predict`), the corrector's residual and its reference norm (:func:`residual`), the
Newton test and update (:func:`converged`, :func:`correct`), the step tangent and its LU
(:func:`tangent_lu`, :func:`linear_lu`), the end of the step (:func:`finish`: corrector,
history of the alpha schemes, new state) and the propagation of the step Jacobians
(:func:`sensitivity`).  Two loops call them: :func:`march` here, compiled, where the data
allow it (per-step matrices in arrays, a linear system or a nonlinear force given as a
compiled function), and the Python loop of :func:`fivebar.numerics.newmark.integrate` for a generic
system whose matrices or nonlinear force are Python callbacks.  Neither loop holds a formula of
the step of its own.

The nonlinear force of the compiled loop is the model's (the linkage's strain force,
``fivebar.model._nonlinear_kernel``, or the modal equations' polynomial force,
``fivebar.numerics._polynomial_kernel``): a compiled function of the signature
:data:`FORCE_SIG`, ``force(u, k, rdata, idata, f, Kt, tangent)``, passed to :func:`march` as a
first-class function with the model's data in two flat arrays (``rdata`` floats, ``idata``
integers: the function unpacks them), which fills ``f`` (n,) with the force at the state
``u`` and step point ``k`` and, if ``tangent``, ``Kt`` (n, n) with its Jacobian.  This module
knows nothing of the model.

The state is one array ``x`` (4, n): displacement, velocity, acceleration and the alpha
schemes' force history :math:`\mathbf g_n = \mathbf C\dot{\mathbf u} + \mathbf K\mathbf u
+ \mathbf f_{nl} - \mathbf F` at :math:`t_n`; the step's vectors are the rows of one work
array ``w`` (:data:`NWORK`, n) (rows :data:`UT` ... :data:`HIST`); the sensitivity blocks are
``P`` (3, n, m), :math:`\partial(\mathbf u, \dot{\mathbf u}, \ddot{\mathbf u})_n/\partial
\mathbf x_0` times ``m`` directions.  The functions work in place on these and allocate nothing
(matrix-vector products and norms are loops; the products with the sensitivity blocks call
BLAS).

:func:`march` releases the GIL while it runs, so that two periods can be integrated at once in
two threads (the continuation's forward difference in the parameter beside the monodromy
period, :mod:`fivebar.numerics.continuation`).

Compiled functions are cached on disk (``cache=True``) by :mod:`fivebar.numerics._jitcache`, which
compiles the signatures of :data:`__jit_signatures__` when it loads the module (the compiled
loop takes the force as a first-class function, whose type only an explicit signature keeps
the same from one process to the next: a cached loop is then found again).

Status codes returned by :func:`march` (the caller raises the matching error):
0 converged, 1 residual not finite, 2 Newton did not converge in ``max_iter``, 3 singular tangent.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

OK, NOT_FINITE, NO_CONVERGENCE, SINGULAR = 0, 1, 2, 3

#: Entries of the scheme's coefficient array (:func:`coefficients`).
DT, BDT2, GDT, C_UP, C_VP, AM, AF, CM, CC, CK = range(10)
#: Rows of the step's work array: predictors, iterate, its velocity and acceleration, residual,
#: the three products of the residual, the alpha history and the accelerations of the two
#: steps before (the nonlinear step's first iterate extrapolates them, :func:`predict`).
UT, VT, U1, V1, A1, R, MA, CV, KU, HIST, AP1, AP2 = range(12)
NWORK = 12

_f1, _f2, _f3, _i1, _i2 = (types.float64[::1], types.float64[:, ::1], types.float64[:, :, ::1],
                           types.int64[::1], types.int64[:, ::1])
#: Signature of a model's compiled nonlinear force: ``force(u, k, rdata, idata, f, Kt, tangent)``.
FORCE_SIG = types.void(_f1, types.int64, _f1, _i1, _f1, _f2, types.boolean)

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
    """A pivot below 1e-14 of the largest, or not finite: the step tangent is singular."""
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
def nrm2(x):
    """Euclidean norm without a temporary."""
    s = 0.0
    for i in range(x.size):
        s += x[i] * x[i]
    return math.sqrt(s)


# --- the step, written once ---------------------------------------------------------------------
@njit(cache=True)
def coefficients(gamma, beta, alpha_m, alpha_f, dt):
    """The scheme's constants for the step ``dt`` (entries :data:`DT` ... :data:`CK`): the
    predictor's ``dt^2 (1/2 - beta)`` and ``dt (1 - gamma)``, the corrector's ``beta dt^2`` and
    ``gamma dt``, the alpha weights and the weights of M, C, K in the step tangent."""
    c = np.empty(10)
    bdt2 = beta * dt * dt
    c[DT] = dt
    c[BDT2] = bdt2
    c[GDT] = gamma * dt
    c[C_UP] = dt * dt * (0.5 - beta)
    c[C_VP] = dt * (1.0 - gamma)
    c[AM] = alpha_m
    c[AF] = alpha_f
    c[CM] = (1.0 - alpha_m) / bdt2
    c[CC] = (1.0 - alpha_f) * gamma / (beta * dt)
    c[CK] = 1.0 - alpha_f
    return c


@njit(cache=True)
def is_alpha(c):
    """True for a scheme with alpha terms (HHT, generalised-alpha), False for Newmark."""
    return not (c[AM] == 0.0 and c[AF] == 0.0)


@njit(cache=True)
def inertia_mass(c, M, Mp, constant, Mb):
    """The mass of the inertia term: ``M`` (``M_{n+1}``) if it is ``constant`` in time or the
    scheme has no ``alpha_f``, else ``(1 - alpha_f) M + alpha_f Mp`` (into ``Mb``), the mass at
    ``t_{n+1-alpha_f}``."""
    af = c[AF]
    if constant or af == 0.0:
        return M
    n = M.shape[0]
    for i in range(n):
        for j in range(n):
            Mb[i, j] = (1.0 - af) * M[i, j] + af * Mp[i, j]
    return Mb


@njit(cache=True)
def predict(c, Mb, x, w, order=0):
    """Predictors (4.3), (4.2) without the new acceleration, into ``w[UT]``, ``w[VT]``; the
    first iterate ``u_{n+1} = u~ + beta dt^2 a*`` into ``w[U1]``, with the acceleration ``a*``
    extrapolated from ``order`` + 1 steps (0: ``a_n``; 1: ``2 a_n - a_{n-1}``; 2: ``3 a_n -
    3 a_{n-1} + a_{n-2}``, from ``w[AP1]``, ``w[AP2]``, which :func:`finish` keeps; ``order``
    -1: the first iterate is ``u_n`` itself, whatever the acceleration); the alpha
    history ``alpha_m Mb a_n + alpha_f g_n`` into ``w[HIST]`` (for Newmark it stays as it is
    made: zero).  The first iterate only starts Newton's iteration of a nonlinear step (a
    linear step solves from it exactly, and takes ``order`` 0)."""
    n = x.shape[1]
    dt, c_up, c_vp, bdt2 = c[DT], c[C_UP], c[C_VP], c[BDT2]
    u, v, a, g = x[0], x[1], x[2], x[3]
    ut, vt, u1, hist = w[UT], w[VT], w[U1], w[HIST]
    ap1, ap2 = w[AP1], w[AP2]
    for i in range(n):
        ut[i] = u[i] + dt * v[i] + c_up * a[i]
        vt[i] = v[i] + c_vp * a[i]
        if order == 2:
            ag = 3.0 * (a[i] - ap1[i]) + ap2[i]
        elif order == 1:
            ag = 2.0 * a[i] - ap1[i]
        else:
            ag = a[i]
        u1[i] = ut[i] + bdt2 * ag if order >= 0 else u[i]
    if is_alpha(c):
        Ma = w[MA]
        matvec(Mb, a, Ma)
        am, af = c[AM], c[AF]
        for i in range(n):
            hist[i] = am * Ma[i] + af * g[i]


@njit(cache=True)
def corrector(c, w):
    """(4.2)-(4.3) solved for the new acceleration and velocity of the iterate ``w[U1]``:
    ``a = (u - u~) / (beta dt^2)`` into ``w[A1]``, ``v = v~ + gamma dt a`` into ``w[V1]``."""
    bdt2, gdt = c[BDT2], c[GDT]
    ut, vt, u1, v1, a1 = w[UT], w[VT], w[U1], w[V1], w[A1]
    for i in range(u1.size):
        a1[i] = (u1[i] - ut[i]) / bdt2
        v1[i] = vt[i] + gdt * a1[i]


@njit(cache=True)
def residual(c, Mb, C, K, F, fnl, w, from_u, with_ref=True):
    """The residual of the equation at the new time, (4.4) or its alpha form, into ``w[R]``:
    ``(1-am) Mb a + (1-af)(C v + K u + f_nl - F) + hist``.  The iterate's acceleration comes
    from ``w[U1]`` (:func:`corrector`) if ``from_u``, else it is the one in ``w[A1]`` (the
    linear step's, ``a_n``).  Returns ``(|R|, ref)``, ``ref`` the sum of the norms of its terms
    (the scale of the Newton test; with ``with_ref`` False, for the linear step, both 0)."""
    if from_u:
        corrector(c, w)
    else:
        vt, v1, a1, gdt = w[VT], w[V1], w[A1], c[GDT]
        for i in range(v1.size):
            v1[i] = vt[i] + gdt * a1[i]
    Ma, Cv, Ku, Rw, hist = w[MA], w[CV], w[KU], w[R], w[HIST]
    matvec(Mb, w[A1], Ma)
    matvec(C, w[V1], Cv)
    matvec(K, w[U1], Ku)
    am, af = c[AM], c[AF]
    for i in range(Rw.size):
        Rw[i] = (1.0 - am) * Ma[i] + (1.0 - af) * (Cv[i] + Ku[i] + fnl[i] - F[i]) + hist[i]
    if not with_ref:
        return 0.0, 0.0
    ref = (1.0 - am) * nrm2(Ma) + (1.0 - af) * (nrm2(Cv) + nrm2(Ku) + nrm2(fnl) + nrm2(F))
    if is_alpha(c):
        ref += nrm2(hist)
    return nrm2(Rw), ref


@njit(cache=True)
def converged(rn, ref, du_norm, w, tol):
    """The Newton test: ``|R| <= rtol ref + atol`` or ``|du| <= xtol |u|``, ``tol`` =
    ``(rtol, xtol, atol)``."""
    return rn <= tol[0] * ref + tol[2] or du_norm <= tol[1] * nrm2(w[U1])


@njit(cache=True)
def correct(LU, piv, w):
    """The Newton update ``u -= S^-1 R`` of the iterate ``w[U1]`` (``w[R]`` receives the
    increment); returns ``|du|``."""
    Rw, u1 = w[R], w[U1]
    lu_solve(LU, piv, Rw)
    s = 0.0
    for i in range(u1.size):
        u1[i] -= Rw[i]
        s += Rw[i] * Rw[i]
    return math.sqrt(s)


@njit(cache=True)
def tangent_lu(c, Mb, C, K, Kt, with_kt, St, piv):
    """The step tangent ``cM Mb + cC C + cK (K [+ Kt])`` into ``St``, factorised in place;
    returns ``(ok, dmin, dmax)``, ``ok`` False if singular."""
    cM, cC, cK = c[CM], c[CC], c[CK]
    n = St.shape[0]
    for i in range(n):
        for j in range(n):
            s = cM * Mb[i, j] + cC * C[i, j]
            St[i, j] = s + cK * (K[i, j] + Kt[i, j]) if with_kt else s + cK * K[i, j]
    dmin, dmax = lu_factor(St, piv)
    return not singular(dmin, dmax), dmin, dmax


@njit(cache=True)
def linear_lu(c, Mb, C, K, LUc, pivc, have, i):
    """The LU of the linear tangent (without ``K_t``) in slot ``i`` of the cache ``LUc, pivc,
    have``, made if the slot is empty; returns ``(ok, dmin, dmax)``."""
    if have[i]:
        return True, 0.0, 0.0
    ok, dmin, dmax = tangent_lu(c, Mb, C, K, K, False, LUc[i], pivc[i])
    if ok:
        have[i] = 1
    return ok, dmin, dmax


@njit(cache=True)
def linear_step(c, Mb, C, K, F, fnl, x, w, LUc, pivc, have, i):
    """The step of a linear system, one solve from the predictor: ``w[U1]`` becomes
    ``u_{n+1}``; the tangent's LU is slot ``i`` of the cache.  Returns ``(ok, dmin, dmax)``."""
    a, a1 = x[2], w[A1]
    for k in range(a.size):
        a1[k] = a[k]
    residual(c, Mb, C, K, F, fnl, w, False, False)
    ok, dmin, dmax = linear_lu(c, Mb, C, K, LUc, pivc, have, i)
    if ok:
        correct(LUc[i], pivc[i], w)
    return ok, dmin, dmax


@njit(cache=True)
def finish(c, C, K, F, fnl, x, w):
    """End of the step at the converged ``w[U1]``: its velocity and acceleration
    (:func:`corrector`), the alpha history ``g_{n+1} = C v + K u + f_nl - F``, the new state
    into ``x`` (the accelerations of the two steps before into ``w[AP1]``, ``w[AP2]``)."""
    corrector(c, w)
    u1, v1, a1 = w[U1], w[V1], w[A1]
    n = u1.size
    for i in range(n):
        w[AP2, i] = w[AP1, i]
        w[AP1, i] = x[2, i]
    if is_alpha(c):
        Cv, Ku, g = w[CV], w[KU], x[3]
        matvec(C, v1, Cv)
        matvec(K, u1, Ku)
        for i in range(n):
            g[i] = Cv[i] + Ku[i] - F[i] + fnl[i]
    for i in range(n):
        x[0, i] = u1[i]
        x[1, i] = v1[i]
        x[2, i] = a1[i]


@njit(cache=True)
def sensitivity(c, LU, piv, Mb, C, Kp, Cp, Kt, Ktp, nonlin, P, PW, A):
    """The step Jacobian applied to the blocks ``P`` (3, n, m), in place (``PW`` (3, n, m)
    and ``A`` (n, 3 n) work): the linearised step with the converged tangent's LU (``LU,
    piv``), ``Kp, Cp`` and ``Ktp`` (if ``nonlin``) the matrices at ``t_n`` for the alpha terms;
    ``Ktp`` then becomes ``Kt``, the tangent at ``t_{n+1}``.

    The right-hand side ``(1-am) Mb da* + (1-af) C dv* [+ am Mb Pa + af ((K + Kt)_n Pu + C_n
    Pv)]``, with ``da* = -du~ / (beta dt^2)``, ``dv* = dv~ + gamma dt da*`` and ``du~, dv~`` the
    predictors' (linear in ``Pu, Pv, Pa``), is one product ``[A_u A_v A_a] [Pu; Pv; Pa]``: the
    three n x n blocks of ``A`` collect each block's coefficients (one product of BLAS instead
    of up to six)."""
    dt, c_up, c_vp, bdt2, gdt, am, af = c[DT], c[C_UP], c[C_VP], c[BDT2], c[GDT], c[AM], c[AF]
    Pu, Pv, Pa = P[0], P[1], P[2]
    Dut, Dvt, dR = PW[0], PW[1], PW[2]
    n, m = Pu.shape
    alpha = is_alpha(c)
    # da* = -(Pu + dt Pv + c_up Pa) / bdt2;  dv* = Pv + c_vp Pa + gdt da*
    mu, mv, ma = -(1.0 - am) / bdt2, -(1.0 - am) * dt / bdt2, -(1.0 - am) * c_up / bdt2
    cu = -(1.0 - af) * gdt / bdt2
    cv = (1.0 - af) * (1.0 - gdt * dt / bdt2)
    ca = (1.0 - af) * (c_vp - gdt * c_up / bdt2)
    for i in range(n):
        for k in range(n):
            mb, ck = Mb[i, k], C[i, k]
            A[i, k] = mu * mb + cu * ck
            A[i, n + k] = mv * mb + cv * ck
            A[i, 2 * n + k] = ma * mb + ca * ck
    if alpha:
        for i in range(n):
            for k in range(n):
                A[i, k] += af * (Kp[i, k] + Ktp[i, k]) if nonlin else af * Kp[i, k]
                A[i, n + k] += af * Cp[i, k]
                A[i, 2 * n + k] += am * Mb[i, k]
    for i in range(n):
        for l in range(m):
            Dut[i, l] = Pu[i, l] + dt * Pv[i, l] + c_up * Pa[i, l]
            Dvt[i, l] = Pv[i, l] + c_vp * Pa[i, l]
    np.dot(A, P.reshape((3 * n, m)), dR)
    lu_solve_matrix(LU, piv, dR)
    for i in range(n):
        for l in range(m):
            du1 = -dR[i, l]
            da1 = (du1 - Dut[i, l]) / bdt2
            Pu[i, l] = du1
            Pv[i, l] = Dvt[i, l] + gdt * da1
            Pa[i, l] = da1
    if nonlin and alpha:
        for i in range(n):
            for l in range(n):
                Ktp[i, l] = Kt[i, l]


@njit(cache=True)
def guess_order(j):
    """The extrapolation order of the first Newton iterate at step ``j`` (from 1) of a march:
    quadratic once two steps of this march lie behind (:func:`predict`)."""
    return min(j - 1, 2)


@njit(cache=True)
def newton(c, Mb, C, K, F, fnl, Kt, w, force, kk, rdata, idata, tol, max_iter, full, sens, LUc,
           pivc, have, li, St, piv, info, j, t):
    """Newton's iteration of a nonlinear step of the compiled loop from the iterate ``w[U1]``
    (:func:`predict`); ``full``: the consistent tangent, else the cached linear one.  The
    tangent is evaluated with the force at the first iterate (an update nearly always follows)
    and after that only when an update follows, or with the force at every iterate if
    ``sens`` (the sensitivity needs it at the converged one).  Returns ``(status, iterations,
    fresh)``, ``fresh`` True if ``Kt`` is the tangent at the converged iterate; a failure
    fills ``info`` (step ``j``, time ``t``)."""
    k_it = 0
    du_norm = math.inf
    want = full or sens
    while True:
        force(w[U1], kk, rdata, idata, fnl, Kt, want)
        rn, ref = residual(c, Mb, C, K, F, fnl, w, True)
        if not math.isfinite(rn):
            info[0], info[1], info[2], info[3] = j, t, rn, k_it
            return NOT_FINITE, k_it, want
        if converged(rn, ref, du_norm, w, tol):
            return OK, k_it, want
        if k_it >= max_iter:
            info[0], info[1], info[2], info[3], info[6] = j, t, rn, k_it, ref
            return NO_CONVERGENCE, k_it, want
        if full:
            if not want:
                force(w[U1], kk, rdata, idata, fnl, Kt, True)
            ok, dmin, dmax = tangent_lu(c, Mb, C, K, Kt, True, St, piv)
            if not ok:
                info[0], info[1], info[4], info[5] = j, t, dmin, dmax
                return SINGULAR, k_it, True
            du_norm = correct(St, piv, w)
        else:
            ok, dmin, dmax = linear_lu(c, Mb, C, K, LUc, pivc, have, li)
            if not ok:
                info[0], info[1], info[4], info[5] = j, t, dmin, dmax
                return SINGULAR, k_it, want
            du_norm = correct(LUc[li], pivc[li], w)
        k_it += 1
        want = sens


# --- the compiled loop ----------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def march(Ms, Cs, Ks, Fs, k0, c, x, nsteps, t0, force, rdata, idata, nonlin, Ktp, tol, max_iter,
          full, LUc, pivc, have, P, X, iters, info):
    """March ``nsteps`` steps of the scheme ``c`` (:func:`coefficients`) from the state ``x``
    (4, n) at ``t0``, in place; see :func:`fivebar.numerics.newmark.integrate`.

    Per-step data are read at index ``(k0 + j) % len`` of ``Ms, Cs, Ks, Fs`` and of the
    linear-tangent cache ``LUc, pivc, have`` (a length-1 array is a constant); the nonlinear
    force (if ``nonlin``) is ``force(u, k0 + j, rdata, idata, ...)`` (:data:`FORCE_SIG`),
    ``Ktp`` its tangent at ``t0`` (for the alpha terms of the sensitivity).  ``tol`` =
    ``(rtol, xtol, atol)``; ``full``: Newton with the consistent tangent, else the linear one.
    ``P`` (3, n, m): sensitivity blocks, propagated in place if ``m > 0``.  ``X`` (3, N, n)
    receives ``u, v, a`` at every step if ``N = nsteps + 1``, ``iters`` the Newton iterations,
    ``info`` the failing step, time, residual, iterations, pivots and reference norm.
    Returns a status code.
    """
    n = x.shape[1]
    SM, SC, SK, SF, SL = Ms.shape[0], Cs.shape[0], Ks.shape[0], Fs.shape[0], LUc.shape[0]
    w = np.zeros((NWORK, n))
    fnl = np.zeros(n)
    Kt = np.zeros((n, n))
    St = np.empty((n, n))
    piv = np.empty(n, np.int64)
    Mbw = np.empty((n, n))
    m = P.shape[2]
    sens = m > 0
    PW = np.empty((3, n, m))
    A = np.empty((n, 3 * n))
    store = X.shape[1] == nsteps + 1
    u1 = w[U1]
    for j in range(1, nsteps + 1):
        t = t0 + j * c[DT]
        kk = k0 + j
        C = Cs[kk % SC]
        K = Ks[kk % SK]
        F = Fs[kk % SF]
        Mb = inertia_mass(c, Ms[kk % SM], Ms[(kk - 1) % SM], SM == 1, Mbw)
        li = kk % SL
        if not nonlin:
            predict(c, Mb, x, w, 0)
            ok, dmin, dmax = linear_step(c, Mb, C, K, F, fnl, x, w, LUc, pivc, have, li)
            if not ok:
                info[0], info[1], info[4], info[5] = j, t, dmin, dmax
                return SINGULAR
            LU = LUc[li]
            LP = pivc[li]
        else:
            # Newton from the acceleration extrapolated over the steps before, from a_n if that
            # fails (a start that excites the stiff modes makes the history rough), and from
            # u_n if that fails too: a state slightly out of equilibrium in a stiff direction
            # (a corrector's trial state) has an initial acceleration that puts the predictor
            # far out, where a hardening force's Newton iteration crawls back or diverges
            order = guess_order(j)
            while True:
                predict(c, Mb, x, w, order)
                status, k_it, fresh = newton(c, Mb, C, K, F, fnl, Kt, w, force, kk, rdata, idata,
                                             tol, max_iter, full, sens, LUc, pivc, have, li, St,
                                             piv, info, j, t)
                if status == OK or status == SINGULAR or order < 0:
                    break
                order = 0 if order > 0 else -1
            if status != OK:
                return status
            iters[j - 1] = k_it
            if sens:  # the consistent tangent at the converged u_{n+1}
                if not fresh:
                    force(u1, kk, rdata, idata, fnl, Kt, True)
                ok, dmin, dmax = tangent_lu(c, Mb, C, K, Kt, True, St, piv)
                if not ok:
                    info[0], info[1], info[4], info[5] = j, t, dmin, dmax
                    return SINGULAR
            LU = St
            LP = piv
        if sens:
            sensitivity(c, LU, LP, Mb, C, Ks[(kk - 1) % SK], Cs[(kk - 1) % SC], Kt, Ktp, nonlin,
                        P, PW, A)
        finish(c, C, K, F, fnl, x, w)
        if store:
            for i in range(n):
                X[0, j, i] = x[0, i]
                X[1, j, i] = x[1, i]
                X[2, j, i] = x[2, i]
    return OK


@njit(cache=True)
def no_force(u, k, rdata, idata, f, Kt, tangent):
    """The force of a linear system (zero): the :data:`FORCE_SIG` placeholder of :func:`march`."""
    for i in range(f.size):
        f[i] = 0.0


_r2, _r3 = (types.Array(types.float64, d, "C", readonly=True) for d in (2, 3))  # step data
#: Signatures that :func:`fivebar.numerics._jitcache.import_cached` compiles when it loads the module
#: (``march`` takes the force as a first-class function of :data:`FORCE_SIG`).
__jit_signatures__ = {
    "march": (types.int64(_r3, _r3, _r3, _r2, types.int64, _f1, _f2, types.int64, types.float64,
                          types.FunctionType(FORCE_SIG), _f1, _i1, types.boolean, _f2, _f1,
                          types.int64, types.boolean, _f3, _i2, types.uint8[::1], _f3, _f3,
                          _i1, _f1),),
    "no_force": (FORCE_SIG,),
}
