r"""Harmonic balance: the periodic response of a time-varying nonlinear system, with Hill's stability.

The :math:`T`-periodic steady state of the generic system

.. math::

    \mathbf M(t)\,\ddot{\mathbf u} + \mathbf C(t)\,\dot{\mathbf u} + \mathbf K(t)\,\mathbf u
    + \mathbf f_{nl}(\mathbf u, t) = \mathbf F(t),
    \qquad \mathbf M, \mathbf C, \mathbf K, \mathbf f_{nl}, \mathbf F \ T\text{-periodic in } t,

(``n`` degrees of freedom, dense matrices) is sought as a truncated Fourier series
(Krack & Gross, *Harmonic Balance for Nonlinear Vibration Problems*, Springer 2019, ch. 2-3):

.. math::

    \mathbf u(t) \approx \mathbf u_H(t) = \mathbf c_0 + \sum_{h=1}^{H}
        \big(\mathbf a_h\cos h\Omega t + \mathbf b_h\sin h\Omega t\big),
    \qquad \Omega = 2\pi/T ,

with the :math:`n(2H+1)` real coefficients :math:`\hat{\mathbf u} = (\mathbf c_0, \mathbf a_1,
\mathbf b_1, \dots, \mathbf a_H, \mathbf b_H)` as the unknowns.  With the basis
:math:`\mathbf q(t) = (1, \cos\Omega t, \sin\Omega t, \dots)` and the derivative matrix
:math:`\boldsymbol\nabla` (block :math:`h`: :math:`h\Omega\,[\begin{smallmatrix}0 & 1\\ -1 &
0\end{smallmatrix}]` on :math:`(\mathbf a_h, \mathbf b_h)`),
:math:`\dot{\mathbf u}_H = (\mathbf q^\top\otimes\mathbf I)(\boldsymbol\nabla\otimes\mathbf I)
\hat{\mathbf u}`.  **Galerkin projection**: the residual of the equation of motion,
:math:`\mathbf r(t) = \mathbf M\ddot{\mathbf u}_H + \mathbf C\dot{\mathbf u}_H + \mathbf K\mathbf u_H
+ \mathbf f_{nl}(\mathbf u_H, t) - \mathbf F`, is made orthogonal to the :math:`2H+1` basis
functions,

.. math::

    \mathbf R(\hat{\mathbf u}) = \frac{2}{T}\int_0^T \mathbf w(t)\otimes\mathbf r(t)\,dt = \mathbf 0,
    \qquad \mathbf w = (\tfrac12, \cos\Omega t, \sin\Omega t, \dots),

so that a series already in the span is its own projection.  **Alternating frequency-time
scheme** (AFT; Cameron & Griffin, J. Appl. Mech. 56 (1989) 149-154): the integral is the
trapezoidal rule on :math:`N` equidistant samples :math:`t_k = kT/N` of one period, the
coefficients go to the time samples by :math:`\mathbf U = \boldsymbol\Gamma\hat{\mathbf U}`
(:math:`\boldsymbol\Gamma_{kj} = q_j(t_k)`), the time-varying matrices and the nonlinear force
are evaluated sample by sample, and the projection :math:`\mathbf P = \mathbf W
\boldsymbol\Gamma^\top` (:math:`\mathbf W = \operatorname{diag}(1, 2, \dots, 2)/N`) brings the
residual back; :math:`\mathbf P\boldsymbol\Gamma = \mathbf I` exactly for :math:`N \ge 2H+1`.
The rule integrates a trigonometric polynomial of degree below :math:`N` exactly, so a cubic
:math:`\mathbf f_{nl}` (harmonics up to :math:`3H`, times a basis function of degree
:math:`H`) is projected without aliasing for :math:`N \ge 4H+1`; the default
:math:`N = 6H + 2` (at least :math:`2(3H)+1`, even) leaves room for the harmonics of the
time-varying matrices as well.  **Newton's method** with the analytic Jacobian, the
time-domain tangent projected:

.. math::

    \frac{\partial\mathbf R}{\partial\hat{\mathbf u}} =
      \mathbf P\big[\mathbf K_k + \mathbf K_{t,k}\big]\boldsymbol\Gamma
      + \mathbf P\big[\mathbf C_k\big]\boldsymbol\Gamma\,\boldsymbol\nabla
      + \mathbf P\big[\mathbf M_k\big]\boldsymbol\Gamma\,\boldsymbol\nabla^2 ,
    \qquad \mathbf K_t = \partial\mathbf f_{nl}/\partial\mathbf u ,

where :math:`\mathbf P[\mathbf A_k]\boldsymbol\Gamma` is the block matrix
:math:`\sum_k P_{jk}\Gamma_{kl}\mathbf A_k` (one :math:`n\times n` block per pair of basis
functions, assembled from the discrete Fourier sums of the samples :math:`\mathbf A_k` by the
product formulas of cos and sin), damped by Deuflhard's natural monotonicity test.  Newton's
method starts from a given series, else from the linear solution; where it fails there (a
strongly nonlinear response far from the linear one), the solution is followed from the
unloaded one by continuation in a load factor from 0 to 1 (:func:`fivebar.numerics.continuation.continuation`
with the balance as a residual problem: around the folds in the load that a hardening resonance
has) and polished by Newton's method.

**Number of harmonics** (``tol``).  The error of :math:`\mathbf u_H` is estimated by *the
residual of the time-domain equation between the samples*: the series, padded with zeros, is put
into the balance with :math:`H_e = H + \max(\lceil H/2\rceil, 2)` harmonics on
:math:`6H_e + 2` samples, where its residual has the components the Galerkin condition with
:math:`H` harmonics does not see, and one Newton step of that balance is taken,
:math:`\delta\hat{\mathbf u} = -\mathbf J_{H_e}^{-1}\mathbf R_{H_e}` (the full Jacobian: the
coupling of the neglected harmonics to the retained ones through the time-varying matrices and
the nonlinear force is kept; a period-averaged, harmonic-by-harmonic estimate underestimates the
error of the linkage three hundredfold, its modes' shapes turning with the links).  The estimate
is the largest change of a measured quantity over the samples (default the displacements; the
caller may give its quantity of interest) relative to its peak-to-peak value.  With ``tol``, H
grows from ``harmonics`` until the estimate is at most ``tol``: to the smallest H' from
:math:`\lceil 1.2H\rceil` whose part of the correction above H' is at most ``tol / 4``, else to
:math:`H_e`, each H started from the last correction.

**Stability by Hill's method** (Lazarus & Thomas, C. R. Mécanique 338 (2010) 510-517).  A
perturbation :math:`\delta\mathbf u = e^{\lambda t}\mathbf p(t)`, :math:`\mathbf p` periodic
(Floquet's form), of the linearised equation, with :math:`\mathbf p` expanded like
:math:`\mathbf u_H` (coefficients :math:`\hat{\mathbf p}`), gives the quadratic eigenvalue
problem

.. math::

    \Big(\lambda^2\hat{\mathbf M} + \lambda\big(2\hat{\mathbf M}\boldsymbol\nabla
      + \hat{\mathbf C}\big) + \frac{\partial\mathbf R}{\partial\hat{\mathbf u}}\Big)
      \hat{\mathbf p} = \mathbf 0 ,
    \qquad \hat{\mathbf M} = \mathbf P[\mathbf M_k]\boldsymbol\Gamma,\
    \hat{\mathbf C} = \mathbf P[\mathbf C_k]\boldsymbol\Gamma ,

solved as a linear one of size :math:`2n(2H+1)` (Hill's matrix; every DOF scaled by the root of
its mean mass, as the mass of a stiff model is too ill-conditioned to invert unscaled).  Its
eigenvalues are the Floquet exponents, each in :math:`2H+1` copies :math:`\lambda + ik\Omega`
(the same multiplier :math:`e^{\lambda T}`), of which those near the truncation are inaccurate,
and, where H does not resolve a Floquet form, eigenvalues that belong to no exponent.
*Selection criterion* (after Bentvelsen & Lazarus, Nonlinear Dyn. 91 (2018) 1349-1370: sort by
the eigenvectors, not by the imaginary parts, which fails for modes far above :math:`\Omega`):
each eigenvector's mass-weighted energy :math:`w_h` over the complex harmonics
:math:`h = -H..H` (normalised to sum 1) has the centroid :math:`m = \sum_h h w_h` and the
spread :math:`s = \sum_h h^2 w_h`; the copy :math:`k` of an exponent has the centroid
:math:`m - k`.  The :math:`2n` exponents are taken in increasing :math:`s` (the best-resolved,
centred Floquet form first; an unresolved eigenvector spreads over all harmonics), skipping an
eigenvalue that is a copy of one already taken (within :math:`0.05\Omega` of
:math:`\lambda + ik\Omega`, :math:`k = \operatorname{round}(m - m') \ne 0`).  The multipliers
are :math:`\mu = e^{\lambda T}`; the orbit is asymptotically stable if all lie inside the unit
circle.  A monodromy matrix follows from the selected Floquet forms,
:math:`\boldsymbol\Phi = \mathbf X_0\,\operatorname{diag}(\mu)\,\mathbf X_0^{-1}`, the columns
of :math:`\mathbf X_0` the states :math:`(\mathbf p(0), \dot{\mathbf p}(0) + \lambda\mathbf p(0))`
(for :func:`fivebar.numerics.continuation.continuation` of a :class:`HarmonicBalanceFamily`).  Hill's
method converges with the harmonics of the *Floquet forms*, which may need many more than the
response (a mode whose frequency varies strongly over the period has a broad Floquet form);
:meth:`HarmonicBalanceSolution.hill` takes its harmonics as an argument.

This module imports nothing of the linkage (like :mod:`fivebar.numerics.newmark`); the linkage's glue is
:mod:`fivebar.analyses.harmonic_balance`.  Dense linear algebra (numpy, scipy): the published harmonic-balance
codes (NLvib, MATLAB; pyHarm, MANLAB) are not Python packages this library can depend on, and
the Galerkin/AFT core is a page.  References: M. Krack, J. Gross (2019); T. M. Cameron,
J. H. Griffin (1989); A. Lazarus, O. Thomas (2010); B. Bentvelsen, A. Lazarus (2018);
L. Guillot, A. Lazarus, O. Thomas, C. Vergez, B. Cochelin, J. Comput. Phys. 416 (2020) 109477.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..errors import ComputationError, InputError, InputTypeError, memory, number
from .continuation import ContinuationError, continuation

__all__ = [
    "HarmonicBalanceError",
    "HarmonicBalanceFamily",
    "HarmonicBalanceSolution",
    "HillResult",
    "PeriodicSamples",
    "PeriodicSystem",
    "SampledSystem",
    "harmonic_balance",
    "samples_for",
]

Array = NDArray[np.float64]
#: bound of the number of harmonics (the Jacobian is dense: n (2H + 1) squared)
MAX_HARMONICS = 2000


class HarmonicBalanceError(ComputationError):
    """Newton's method of harmonic balance did not converge (or no number of harmonics reached
    the tolerance)."""


class PeriodicSamples(NamedTuple):
    """The system at the :math:`N` samples :math:`t_k = kT/N` of one period.

    ``M, C, K`` of shape (N, n, n) (or (n, n), the same at every sample), ``F`` (N, n) (or
    (n,)), and ``nonlinear``: None (a linear system) or a function of the displacements at the
    samples ``U`` (N, n) returning the force ``f`` (N, n) and its tangent ``Kt`` (N, n, n) at
    each sample."""

    M: Array
    C: Array
    K: Array
    F: Array
    nonlinear: Callable[[Array], tuple[Array, Array]] | None = None


@runtime_checkable
class PeriodicSystem(Protocol):
    """What :func:`harmonic_balance` needs from a model: ``n`` (DOFs), ``period`` (s) and
    ``samples(N) -> PeriodicSamples`` at ``t_k = k period / N``, k < N."""

    n: int
    period: float

    def samples(self, N: int) -> PeriodicSamples: ...


class SampledSystem:
    """A :class:`PeriodicSystem` from a second-order system and its period.

    ``SampledSystem(system, period)`` with ``system`` a :class:`fivebar.numerics.systems.System` (or
    anything with ``matrices(t) -> (M, C, K)``, ``force(t)`` and optionally
    ``nonlinear(u, t) -> (f, Kt)``), sampled by calling it at every sample time.
    """

    def __init__(self, system: Any, period: float) -> None:
        for name in ("matrices", "force"):
            if not callable(getattr(system, name, None)):
                raise InputTypeError(
                    f"system = {system!r} ({type(system).__name__}) is not allowed: give a second-order "
                    "system with matrices(t) and force(t) (fivebar.numerics.systems.System)")
        self.system = system
        self.period = number("period", period, low=0.0, low_open=True, unit="s")
        M = np.asarray(system.matrices(0.0)[0], float)
        self.n = int(M.shape[0])

    def samples(self, N: int) -> PeriodicSamples:
        t = self.period * np.arange(N) / N
        mats = [tuple(np.asarray(X, float) for X in self.system.matrices(float(tk))) for tk in t]
        F = np.array([np.asarray(self.system.force(float(tk)), float).reshape(self.n) for tk in t])
        M, C, K = (np.array([m[i] for m in mats]) for i in range(3))
        nl = getattr(self.system, "nonlinear", None)
        if nl is None:
            return PeriodicSamples(M, C, K, F, None)
        n = self.n

        def nonlinear(U):
            f = np.empty((N, n))
            Kt = np.empty((N, n, n))
            for k in range(N):
                fk, Kk = nl(np.array(U[k], float), float(t[k]))
                f[k], Kt[k] = np.reshape(fk, n), np.reshape(Kk, (n, n))
            return f, Kt
        return PeriodicSamples(M, C, K, F, nonlinear)


def extended(harmonics: int) -> int:
    """The harmonics of the error estimate's Newton step: ``H + max(ceil(H / 2), 2)`` (at
    least the next odd harmonics of a cubic force, H + 2)."""
    H = int(harmonics)
    return H + max(-(-H // 2), 2)


def samples_for(harmonics: int) -> int:
    """The default number of AFT samples for ``harmonics``: ``6 H + 2`` (at least 2 (3 H) + 1,
    even; see the module docstring)."""
    return 6 * int(harmonics) + 2


# --- the Fourier basis ------------------------------------------------------------------------
def _basis(H: int, N: int) -> tuple[Array, Array]:
    """Gamma (N, 2H + 1): the real basis (1, cos, sin, ...) at t_k = k T / N, and the
    projection P (2H + 1, N) with P Gamma = I."""
    tau = 2.0 * np.pi * np.arange(N) / N
    G = np.empty((N, 2 * H + 1))
    G[:, 0] = 1.0
    h = np.arange(1, H + 1)
    G[:, 1::2] = np.cos(np.outer(tau, h))
    G[:, 2::2] = np.sin(np.outer(tau, h))
    w = np.full(2 * H + 1, 2.0 / N)
    w[0] = 1.0 / N
    return G, w[:, None] * G.T


def _nabla(H: int, omega: float) -> Array:
    """The derivative matrix (2H + 1, 2H + 1) on the real coefficients (c0, a1, b1, ...)."""
    D = np.zeros((2 * H + 1, 2 * H + 1))
    for h in range(1, H + 1):
        D[2 * h - 1, 2 * h] = h * omega  # a_h' = h w b_h
        D[2 * h, 2 * h - 1] = -h * omega  # b_h' = -h w a_h
    return D


def _complex(c: ArrayLike, H: int) -> NDArray[np.complex128]:
    """Coefficients on the complex harmonics h = -H..H (2H + 1, ...) of real-basis ones."""
    c = np.asarray(c)
    out = np.empty((2 * H + 1,) + c.shape[1:], dtype=complex)
    out[H] = c[0]
    a, b = c[1::2], c[2::2]
    out[H + 1:] = 0.5 * (a - 1j * b)
    out[:H][::-1] = 0.5 * (a + 1j * b)
    return out


class _Grid:
    """The AFT grid of H harmonics on N samples: Gamma, P, and the block projector."""

    def __init__(self, H: int, N: int) -> None:
        if N < 2 * H + 1:
            raise InputError(f"samples = {N} is not allowed: harmonic balance with {H} harmonics needs at least "
                             f"2 H + 1 = {2 * H + 1} samples per period")
        self.H, self.N, self.m = H, N, 2 * H + 1
        self.G, self.P = _basis(H, N)
        j = np.arange(1, H + 1)
        self._dif = np.subtract.outer(j, j) % N  # (j - l) mod N, (H, H)
        self._sum = np.add.outer(j, j) % N  # (j + l) mod N

    def project(self, A: Array, n: int) -> Array:
        """sum_k P[j, k] A_k Gamma[k, l] as the (m n, m n) block matrix (A: (N, n, n) or (n, n)).

        By the product formulas of cos and sin, from the discrete Fourier sums
        :math:`\\sum_k A_k e^{-ip\\tau_k}` of the samples at p = j - l and j + l (modulo N: the
        trapezoidal rule's aliasing, exactly as the sum over the samples has it)."""
        m, H, N = self.m, self.H, self.N
        if A.ndim == 2 or A.strides[0] == 0:
            return np.kron(np.eye(m), A if A.ndim == 2 else A[0])
        Ah = np.fft.fft(A, axis=0)  # sum_k A_k e^{-i p tau_k}
        Cs, Ss = Ah.real / N, -Ah.imag / N  # (1/N) sum cos(p tau) A, (1/N) sum sin(p tau) A
        out = np.empty((m, m, n, n))
        h = np.arange(1, H + 1)
        out[0, 0] = Cs[0]
        out[0, 1::2], out[0, 2::2] = Cs[h], Ss[h]
        out[1::2, 0], out[2::2, 0] = 2.0 * Cs[h], 2.0 * Ss[h]
        d, s = self._dif, self._sum
        out[1::2, 1::2] = Cs[d] + Cs[s]  # cos j cos l
        out[1::2, 2::2] = Ss[s] - Ss[d]  # cos j sin l = (sin(j + l) + sin(l - j)) / 2
        out[2::2, 1::2] = Ss[s] + Ss[d]  # sin j cos l
        out[2::2, 2::2] = Cs[d] - Cs[s]  # sin j sin l
        return out.transpose(0, 2, 1, 3).reshape(m * n, m * n)


def _right(J: Array, D: Array, n: int) -> Array:
    """J (D kron I_n), J of shape (k, m n): D the derivative matrix times a number (its
    pattern: column a_h of J D is -w_h times column b_h of J, column b_h is w_h times column
    a_h), or its square (diagonal), or any matrix (the general product)."""
    m = D.shape[0]
    H = (m - 1) // 2
    Jr = J.reshape(J.shape[0], m, n)
    h = np.arange(1, H + 1)
    w = D[2 * h - 1, 2 * h]
    if np.array_equal(w, -D[2 * h, 2 * h - 1]) and np.count_nonzero(D) == np.count_nonzero(w) * 2:
        out = np.empty_like(Jr)
        out[:, 0] = 0.0
        out[:, 1::2] = -w[None, :, None] * Jr[:, 2::2]
        out[:, 2::2] = w[None, :, None] * Jr[:, 1::2]
    elif np.count_nonzero(D - np.diag(np.diag(D))) == 0:
        out = Jr * np.diag(D)[None, :, None]
    else:
        out = np.einsum("ajq,jl->alq", Jr, D, optimize=True)
    return out.reshape(J.shape[0], m * n)


class _Residual:
    """The HB residual and Jacobian of one system at H harmonics on N samples."""

    def __init__(self, system: PeriodicSystem, H: int, N: int, omega: float | None = None) -> None:
        self.system, self.n = system, int(system.n)
        size = (2 * H + 1) * self.n
        # the Jacobian, its LU factors, the projected M and C, their derivative terms and the
        # block assembly's work array: six dense (m n, m n) arrays
        memory(6 * 8.0 * size * size, f"the dense Jacobian of harmonic balance with {H} harmonics and {self.n} DOFs",
               "give fewer harmonics (harmonics, max_harmonics) or a larger tol")
        self.grid = _Grid(H, N)
        self.H, self.N = H, N
        self.omega = 2.0 * np.pi / float(system.period) if omega is None else float(omega)
        s = system.samples(N)
        n = self.n
        self.M, self.C, self.K, self.F = (np.broadcast_to(np.asarray(X, float), sh) for X, sh in
                                          zip(s[:4], ((N, n, n),) * 3 + ((N, n),)))
        self.nonlinear = s.nonlinear
        g, D = self.grid, _nabla(H, 1.0)
        self.D1 = D  # the derivative matrix at unit frequency
        self.PF = g.P @ self.F  # (m, n)
        self._proj: dict = {}
        self._lin: dict = {}

    @property
    def Mh(self) -> Array:
        """The projected mass P[M_k] Gamma (m n, m n)."""
        if "M" not in self._proj:
            self._proj["M"] = self.grid.project(self.M, self.n)
        return self._proj["M"]

    @property
    def Ch(self) -> Array:
        """The projected damping P[C_k] Gamma."""
        if "C" not in self._proj:
            self._proj["C"] = self.grid.project(self.C, self.n)
        return self._proj["C"]

    def dynamic(self, omega: float) -> Array:
        """P[C_k] Gamma nabla + P[M_k] Gamma nabla^2 at the frequency omega (the last omega kept)."""
        if omega not in self._lin:
            n, D = self.n, omega * self.D1
            self._lin = {omega: _right(self.Ch, D, n) + _right(self.Mh, D @ D, n)}
        return self._lin[omega]

    def light(self) -> _Residual:
        """This residual without its projected matrices (made again when needed): what a
        solution keeps."""
        out = copy.copy(self)
        out._proj, out._lin = {}, {}
        return out

    def linear(self, omega: float) -> Array:
        """The Jacobian of the linear terms at the frequency omega."""
        return self.dynamic(omega) + self.grid.project(self.K, self.n)

    def fields(self, c: Array, omega: float) -> tuple[Array, Array, Array]:
        """u, u', u'' at the samples (N, n) of the coefficients c (m, n)."""
        G, D = self.grid.G, omega * self.D1
        Dc = D @ c
        return G @ c, G @ Dc, G @ (D @ Dc)

    def evaluate(self, x: Array, omega: float, load: float = 1.0, jacobian: bool = True):
        """(R (m n,), J or None, time residual (N, n), Kt or None)."""
        n, g = self.n, self.grid
        c = x.reshape(g.m, n)
        U, V, A = self.fields(c, omega)
        r = (np.einsum("kij,kj->ki", self.M, A) + np.einsum("kij,kj->ki", self.C, V)
             + np.einsum("kij,kj->ki", self.K, U) - load * self.F)
        Kt = None
        if self.nonlinear is not None:
            f, Kt = self.nonlinear(U)
            r = r + f
        R = (g.P @ r).ravel()
        return R, (self.jacobian(Kt, omega) if jacobian else None), r, Kt

    def jacobian(self, Kt: Array | None, omega: float) -> Array:
        """dR/dx from the nonlinear tangent at the samples (None: linear)."""
        A = self.K if Kt is None else self.K + np.asarray(Kt, float)
        return self.dynamic(omega) + self.grid.project(A, self.n)

    def scale(self, x: Array, omega: float, load: float = 1.0) -> float:
        """The size of the terms that balance (for a relative residual)."""
        n, g = self.n, self.grid
        c = x.reshape(g.m, n)
        U, V, A = self.fields(c, omega)
        sizes = [np.abs(g.P @ np.einsum("kij,kj->ki", X, Y)).max() for X, Y in
                 ((self.M, A), (self.C, V), (self.K, U))]
        return max(max(sizes), load * float(np.abs(self.PF).max()), 1e-300)


def _newton(res: _Residual, x: Array, omega: float, load: float, rtol: float, max_iter: int):
    """Damped Newton on R = 0 from x; (x, iterations, relative residual, J, lu) or None.

    The damping is Deuflhard's natural monotonicity test (affine covariant, so the badly scaled
    residual of a stiff model does not mislead it): a step ``lam dx`` is accepted when the
    simplified Newton correction at the trial point, ``J(x)^-1 R(x + lam dx)``, is shorter than
    ``dx``; else ``lam`` is halved (P. Deuflhard, Newton Methods for Nonlinear Problems,
    Springer 2004, section 3.3).
    """
    R, J, _, _ = res.evaluate(x, omega, load)
    for it in range(1, max_iter + 1):
        if not (np.all(np.isfinite(J)) and np.all(np.isfinite(R))):
            return None
        try:
            lu = scipy.linalg.lu_factor(J, check_finite=False)
        except (ValueError, np.linalg.LinAlgError):
            return None
        dx = -scipy.linalg.lu_solve(lu, R, check_finite=False)
        size = float(np.linalg.norm(dx))
        if not np.isfinite(size):
            return None
        if size <= rtol * max(float(np.linalg.norm(x)), 1e-300):
            x = x + dx
            R, _, _, _ = res.evaluate(x, omega, load, jacobian=False)
            return x, it, float(np.linalg.norm(R)) / res.scale(x, omega, load), J, lu
        lam = 1.0
        for _ in range(14):
            xt = x + lam * dx
            Rt, _, _, Kt = res.evaluate(xt, omega, load, jacobian=False)
            if np.all(np.isfinite(Rt)):
                bar = scipy.linalg.lu_solve(lu, Rt, check_finite=False)
                if float(np.linalg.norm(bar)) < (1.0 - 0.25 * lam) * size or lam == 1.0 and float(
                        np.linalg.norm(bar)) <= rtol * max(float(np.linalg.norm(xt)), 1e-300):
                    break
            lam *= 0.5
        else:
            return None
        x, R = xt, Rt
        J = res.jacobian(Kt, omega)
    return None


def _solve(res: _Residual, x0: Array | None, omega: float, rtol: float, max_iter: int):
    """Newton from x0, else from the linear solution; where both fail, the solution is followed
    from the unloaded one (u = 0, if f_nl(0) = 0) by continuation in the load factor from 0 to 1
    (:func:`fivebar.numerics.continuation.continuation`, pseudo-arclength: around the folds in the load
    that a hardening resonance has), and polished by Newton at the full load.  Returns (x,
    iterations, relative residual, J, lu, load-path points)."""
    size = res.grid.m * res.n
    try:
        linear = np.linalg.solve(res.linear(omega), res.PF.ravel())
    except np.linalg.LinAlgError:
        linear = np.zeros(size)
    for start in ([] if x0 is None else [np.array(x0, float)]) + [linear]:
        out = _newton(res, start, omega, 1.0, rtol, max_iter)
        if out is not None:
            return out + (0,)

    path = _LoadPath(res, omega)
    big = float(np.abs(linear).max())
    try:
        br = continuation(path, np.zeros(size), 0.0, 1.0, scale=np.full(size, big if big > 0 else 1.0),
                          ds=0.05, ds_max=0.25, locate=False, max_points=_PATH_POINTS, tol=1e-9)
    except ContinuationError as exc:
        raise HarmonicBalanceError(
            f"harmonic balance with H = {res.H} harmonics did not converge: Newton's method from the linear "
            f"solution failed, and so did the continuation in the load from 0 ({exc})") from exc
    if not br.stop.startswith("p_end"):
        raise HarmonicBalanceError(
            f"harmonic balance with H = {res.H} harmonics did not converge: Newton's method from the linear "
            f"solution failed, and the continuation in the load from 0 stopped at {br.p[-1]:.3g} of it "
            f"({br.stop})")
    out = _newton(res, br.points[-1].x, omega, 1.0, rtol, max_iter)
    if out is None:
        raise HarmonicBalanceError(f"harmonic balance with H = {res.H} harmonics: Newton's method did not "
                                   "converge from the end of the continuation in the load")
    x, it, r, J, lu = out
    return x, it + br.stats["newton"], r, J, lu, len(br.points)


#: points of the continuation in the load at most
_PATH_POINTS = 400


class _LoadPath:
    """The balance with the load scaled by p, a residual problem of
    :func:`fivebar.numerics.continuation.continuation` (R / s in the units of x, s the diagonal of the
    linear Jacobian; no stability along the path: a zero monodromy matrix)."""

    def __init__(self, res: _Residual, omega: float) -> None:
        self.res, self.omega = res, omega
        d = np.abs(np.diag(res.linear(omega)))
        self.s = np.where(d > 0, d, 1.0)

    def residual(self, x, p):
        return self.res.evaluate(np.asarray(x, float), self.omega, float(p), jacobian=False)[0] / self.s

    def jacobian(self, x, p):
        J = self.res.evaluate(np.asarray(x, float), self.omega, float(p))[1]
        return J / self.s[:, None], -self.res.PF.ravel() / self.s

    def monodromy(self, x, p):
        return np.zeros((2 * self.res.n, 2 * self.res.n))


@dataclass
class HillResult:
    """Floquet exponents and multipliers of a periodic solution by Hill's method.

    Attributes
    ----------
    exponents : ndarray (2 n,) complex
        The selected Floquet exponents (1/s), in the order of :attr:`multipliers`.
    multipliers : ndarray (2 n,) complex
        :math:`e^{\\lambda T}`, largest modulus first.
    centroids : ndarray (2 n,)
        The harmonic centroid :math:`\\sum_h h w_h` of each selected eigenvector (its energy
        :math:`w_h` per complex harmonic, mass-weighted, normalised to sum 1; the copy
        :math:`\\lambda + ik\\Omega` has the centroid less k).
    spreads : ndarray (2 n,)
        Its second moment :math:`\\sum_h h^2 w_h` (the selection criterion: the smallest first).
    harmonics : int
        Harmonics of Hill's matrix.
    monodromy : ndarray (2 n, 2 n)
        The monodromy matrix of the state (u, u') at t = 0 from the selected Floquet forms.
    """

    exponents: NDArray[np.complex128]
    multipliers: NDArray[np.complex128]
    centroids: Array
    spreads: Array
    harmonics: int
    monodromy: Array

    @property
    def stable(self) -> bool:
        """True if every multiplier lies inside the unit circle."""
        return bool(np.abs(self.multipliers).max() < 1.0)


def _hill(res: _Residual, J: Array, omega: float, H: int) -> HillResult:
    """Hill's method on the Jacobian J (its leading H harmonics; module docstring)."""
    n, m_full = res.n, res.grid.m
    m = 2 * H + 1
    size = m * n
    cut = (slice(0, size), slice(0, size))  # the leading harmonics: the first m n unknowns
    Jh, Mh, Ch = (X[cut] if m < m_full else X for X in (J, res.Mh, res.Ch))
    D = omega * _nabla(H, 1.0)
    D1 = 2.0 * _right(Mh, D, n) + Ch
    # each DOF scaled by the root of its mean mass: the mass matrix of a stiff model (curvature
    # DOFs of tiny mass beside translations) is too ill-conditioned to be inverted unscaled
    dm = np.diag(res.M.mean(axis=0))
    sc = np.tile(1.0 / np.sqrt(np.where(dm > 0, dm, 1.0)), m)
    Ms, Js, Ds = (sc[:, None] * X * sc[None, :] for X in (Mh, Jh, D1))
    lu = scipy.linalg.lu_factor(Ms, check_finite=False)
    A = np.zeros((2 * size, 2 * size))
    A[:size, size:] = np.eye(size)
    A[size:, :size] = -scipy.linalg.lu_solve(lu, Js, check_finite=False)
    A[size:, size:] = -scipy.linalg.lu_solve(lu, Ds, check_finite=False)
    lam, Z = scipy.linalg.eig(A, check_finite=False)
    zs = Z[:size].reshape(m, n, -1)  # the scaled Floquet forms: mass-weighted energy per harmonic
    wgt = np.sum(np.abs(_complex(zs, H)) ** 2, axis=1)  # (2H + 1, 2 size)
    wgt = wgt / np.where(wgt.sum(axis=0) > 0, wgt.sum(axis=0), 1.0)
    hs = np.arange(-H, H + 1)
    cen, spread = hs @ wgt, (hs * hs) @ wgt
    picked: list[int] = []
    for j in np.argsort(spread, kind="stable"):
        if len(picked) == 2 * n:
            break
        if not np.isfinite(lam[j]):
            continue
        if not any((k := round(float(cen[i] - cen[j]))) != 0
                   and abs(lam[j] - (lam[i] + 1j * k * omega)) <= _COPY_TOL * omega for i in picked):
            picked.append(int(j))
    if len(picked) < 2 * n:
        raise HarmonicBalanceError(f"Hill's method found only {len(picked)} of the 2 n = {2 * n} Floquet exponents "
                                   f"(H = {H}): give more harmonics")
    idx = np.array(picked)
    lam_s = lam[idx]
    T = 2.0 * np.pi / omega
    with np.errstate(under="ignore", over="ignore"):
        mu = np.exp(lam_s * T)
    # the states (p(0), p'(0) + lambda p(0)) of the selected Floquet forms
    phi = sc.reshape(m, n)[:, :, None] * zs[:, :, idx]
    q0 = np.zeros(m)
    q0[0], q0[1::2] = 1.0, 1.0  # the basis at t = 0
    P0 = np.einsum("j,jia->ia", q0, phi)
    dP0 = np.einsum("j,jia->ia", q0, np.einsum("jl,lia->jia", D, phi))
    X0 = np.vstack([P0, dP0 + lam_s[None, :] * P0])
    try:
        Phi = np.real(X0 @ np.diag(mu) @ np.linalg.inv(X0))
    except np.linalg.LinAlgError:
        Phi = np.full((2 * n, 2 * n), np.nan)
    order = np.lexsort((-mu.imag, -np.abs(mu)))
    return HillResult(lam_s[order], mu[order], cen[idx][order], spread[idx][order], H, Phi)


#: an eigenvalue of Hill's matrix is a copy of one already selected when it lies within this
#: (times Omega) of that one shifted by the integer difference of their centroids times i Omega
_COPY_TOL = 0.05


@dataclass
class HarmonicBalanceSolution:
    """A periodic solution by harmonic balance.

    ``sol = harmonic_balance(system, 5)``; ``sol.displacement(t)``, ``sol.hill().multipliers``,
    ``sol.stable``, ``sol.accuracy``.

    Attributes
    ----------
    coefficients : ndarray (2 H + 1, n)
        Real Fourier coefficients (c0, a1, b1, ..., aH, bH) of the displacements.
    harmonics : int
        H.
    samples : int
        N, the AFT samples per period.
    period : float
        T (s).
    residual : float
        The relative Galerkin residual at the solution (of the largest balanced term).
    iterations : int
        Newton iterations of the last H (of the Newton that converged, and the corrector
        iterations of the continuation in the load where it was taken).
    accuracy : dict or None
        With ``tol``: the tolerance, the estimate, every H tried with its estimate, and the
        choice; None without ``tol`` (see :meth:`estimate`).
    load_path : list of int
        The points of the continuation in the load, for every H solved (0: Newton's method
        converged from its start).

    The solution keeps its system's samples (to compute Hill's method and the error estimate
    when asked), not the dense (2 H + 1) n square matrices of the balance: the Jacobian at the
    solution is made again by :meth:`hill` (at H = 46 with 22 DOFs each such matrix is 33 MB,
    and a sweep keeps a solution per speed).
    """

    coefficients: Array
    harmonics: int
    samples: int
    period: float
    residual: float
    iterations: int
    accuracy: dict | None = None
    load_path: list = field(default_factory=list)
    _res: Any = field(default=None, repr=False)
    _hill: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if self._res is not None:
            self._res = self._res.light()

    @property
    def omega(self) -> float:
        """The fundamental angular frequency 2 pi / T (rad/s)."""
        return 2.0 * np.pi / self.period

    @property
    def x(self) -> Array:
        """The unknowns as one vector (harmonic-major), as :class:`HarmonicBalanceFamily` uses."""
        return self.coefficients.ravel()

    def _series(self, t: ArrayLike, order: int) -> Array:
        t = np.asarray(t, float)
        H, w = self.harmonics, self.omega
        c = np.linalg.matrix_power(_nabla(H, w), order) @ self.coefficients if order else self.coefficients
        h = np.arange(1, H + 1)
        ph = np.multiply.outer(t, h) * w
        return c[0] + np.cos(ph) @ c[1::2] + np.sin(ph) @ c[2::2]

    def displacement(self, t: ArrayLike) -> Array:
        """u(t), (..., n), at times t (s)."""
        return self._series(t, 0)

    def velocity(self, t: ArrayLike) -> Array:
        """u'(t), (..., n)."""
        return self._series(t, 1)

    def acceleration(self, t: ArrayLike) -> Array:
        """u''(t), (..., n)."""
        return self._series(t, 2)

    def amplitudes(self) -> Array:
        """The amplitude sqrt(a_h^2 + b_h^2) of every harmonic h = 0..H (|c0| for h = 0), (H + 1, n)."""
        c = self.coefficients
        return np.vstack([np.abs(c[:1]), np.hypot(c[1::2], c[2::2])])

    def hill(self, harmonics: int | None = None) -> HillResult:
        """Floquet exponents and multipliers by Hill's method (module docstring), with the
        leading ``harmonics`` (default all H) of the solution's Jacobian; computed once per
        ``harmonics``."""
        H = self.harmonics if harmonics is None else int(number("harmonics", harmonics, integer=True, low=1,
                                                              high=self.harmonics))
        if H not in self._hill:
            res = self._res.light()  # its projections made here are dropped after
            J = res.evaluate(self.x, self.omega)[1]
            self._hill[H] = _hill(res, J, self.omega, H)
        return self._hill[H]

    @property
    def multipliers(self) -> NDArray[np.complex128]:
        """The Floquet multipliers by Hill's method (all harmonics), largest modulus first."""
        return self.hill().multipliers

    @property
    def stable(self) -> bool:
        """True if every Floquet multiplier (Hill) lies inside the unit circle."""
        return self.hill().stable

    def estimate(self, measure: Callable | None = None) -> dict:
        """The error estimate of the module docstring: ``{"estimate": e, "remaining": {H':
        e'}}``, e relative to the peak-to-peak value of ``measure(t, U)`` (default the
        displacements U, (N, n)), e' what would be left with H' harmonics."""
        return _estimate(self._res, self, measure)


def _measured(measure, t, U) -> Array:
    y = np.asarray(U if measure is None else measure(t, U), float)
    return y.reshape(len(t), -1)


def _relative(measure, t, U, dU) -> float:
    y0 = _measured(measure, t, U)
    y1 = _measured(measure, t, U + dU)
    p2p = float(np.max(np.ptp(y0, axis=0)))
    return float(np.abs(y1 - y0).max()) / max(p2p, 1e-300)


#: the next H is the smallest (from 1.2 H) whose remaining estimated correction is at most this
#: fraction of tol (else H_e): a margin, as the one Newton step underestimates the change
_NEXT_MARGIN = 0.25


def _estimate(res: _Residual, sol: HarmonicBalanceSolution, measure, fine: _Residual | None = None,
              tol: float | None = None) -> dict:
    """One Newton step of the balance with 2 H harmonics from the solution (module docstring):
    ``{"estimate": e, "remaining": {H': e'}, "start": the corrected coefficients (2 (2H) + 1, n),
    "fine": the residual at 2 H}``."""
    H, n = sol.harmonics, res.n
    He = min(extended(H), MAX_HARMONICS)
    if fine is None or fine.H != He:
        fine = _Residual(res.system, He, samples_for(He), sol.omega)
    x = _pad(sol.coefficients, He).ravel()
    R, J, _, _ = fine.evaluate(x, sol.omega)
    try:
        d = -np.linalg.solve(J, R).reshape(2 * He + 1, n)
    except np.linalg.LinAlgError:
        d = np.full((2 * He + 1, n), np.inf)
    Ne = fine.N
    t = sol.period * np.arange(Ne) / Ne
    G = fine.grid.G
    U = G @ x.reshape(2 * He + 1, n)
    est = _relative(measure, t, U, G @ d) if np.all(np.isfinite(d)) else math.inf
    remaining = {}
    if np.all(np.isfinite(d)):
        for Hn in range(max(H + 1, math.ceil(1.2 * H)), He):
            dn = d.copy()
            dn[:2 * Hn + 1] = 0.0
            remaining[Hn] = _relative(measure, t, U, G @ dn)
            if tol is not None and remaining[Hn] <= _NEXT_MARGIN * tol:
                break
    return {"estimate": est, "remaining": remaining, "start": x.reshape(2 * He + 1, n) + d, "fine": fine}


def harmonic_balance(
    system: PeriodicSystem,
    harmonics: int = 5,
    *,
    tol: float | None = None,
    samples: int | None = None,
    start: HarmonicBalanceSolution | ArrayLike | None = None,
    measure: Callable[[Array, Array], ArrayLike] | None = None,
    rtol: float = 1e-10,
    max_iter: int = 40,
    max_harmonics: int = 400,
) -> HarmonicBalanceSolution:
    """The periodic solution of a periodic system by harmonic balance (module docstring).

    ``sol = harmonic_balance(SampledSystem(system, T), 5)``;
    ``harmonic_balance(sys, tol=1e-4)`` chooses H.

    Parameters
    ----------
    system
        A :class:`PeriodicSystem` (``n``, ``period``, ``samples(N)``), e.g.
        :class:`SampledSystem`.
    harmonics
        H, the harmonics of the series; with ``tol`` the first H tried.
    tol
        Relative accuracy asked of ``measure`` (of its peak-to-peak value); None: solve at H.
    samples
        N, the AFT samples per period; default :func:`samples_for` (6 H + 2).  With ``tol``
        the default is used at every H.
    start
        A solution (any H: its coefficients are padded or cut) or a coefficient array
        (2 H + 1, n) to start Newton's method from; default the linear solution.
    measure
        ``(t, U) -> Y``: the quantity whose accuracy ``tol`` asks (t (N,), U (N, n) ->
        Y (N, q)); default the displacements.
    rtol
        Newton converges when the update is below ``rtol`` of the largest coefficient.
    max_iter
        Newton iterations at most (per load step).
    max_harmonics
        With ``tol``: the largest H tried.

    Raises
    ------
    HarmonicBalanceError
        Newton's method (and the continuation in the load) failed, or no H up to
        ``max_harmonics`` reaches ``tol``.
    """
    for name in ("n", "period"):
        if not hasattr(system, name) or not callable(getattr(system, "samples", None)):
            raise InputTypeError(f"system = {system!r} ({type(system).__name__}) is not allowed: give a "
                                 "fivebar.numerics.harmonic_balance.PeriodicSystem (n, period, samples(N)), e.g. "
                                 "SampledSystem(fivebar.numerics.systems.System(...), period)")
    H = number("harmonics", harmonics, integer=True, low=1, high=MAX_HARMONICS)
    max_harmonics = number("max_harmonics", max_harmonics, integer=True, low=1, high=MAX_HARMONICS)
    rtol = number("rtol", rtol, low=0.0, low_open=True)
    max_iter = number("max_iter", max_iter, integer=True, low=1, high=10_000)
    if samples is not None:
        samples = number("samples", samples, integer=True, low=2 * H + 1)
    if tol is not None:
        tol = number("tol", tol, low=0.0, high=1.0, low_open=True, high_open=True)
    if measure is not None and not callable(measure):
        raise InputTypeError(f"measure = {measure!r} is not allowed: give a function (t, U) -> Y")
    n = int(system.n)
    guess = _coefficients(start, n)
    tried: list[tuple[int, float]] = []
    path: list[int] = []
    res = None
    while True:
        N = samples if (samples is not None and tol is None) else samples_for(H)
        if res is None or res.H != H or res.N != N:
            res = _Residual(system, H, N)
        x0 = None if guess is None else _pad(guess, H).ravel()
        try:
            x, it, r, J, lu, points = _solve(res, x0, res.omega, rtol, max_iter)
            path.append(points)
        except HarmonicBalanceError:
            if tol is None or H >= max_harmonics:
                raise
            tried.append((H, math.inf))  # too few harmonics to hold the response: twice as many
            H, res = min(max_harmonics, 2 * H), None
            continue
        sol = HarmonicBalanceSolution(x.reshape(2 * H + 1, n), H, N, float(system.period), r, it,
                                      None, list(path), res)
        if tol is None:
            return sol
        est = _estimate(res, sol, measure, tol=tol)
        tried.append((H, est["estimate"]))
        if est["estimate"] <= tol:
            sol.accuracy = {"tol": tol, "estimate": est["estimate"], "harmonics": H, "tried": tried,
                            "choice": f"H = {H} harmonics chosen for tol = {tol:g}: one Newton step of the balance "
                                      f"with {extended(H)} harmonics from it changes the measured quantity by "
                                      f"{est['estimate']:.2g} of its peak-to-peak value"}
            return sol
        if H >= max_harmonics:
            raise HarmonicBalanceError(
                f"no number of harmonics up to max_harmonics = {max_harmonics} reaches tol = {tol:g} "
                f"(H, estimate: {', '.join(f'{h}: {e:.2e}' for h, e in tried)}); give a larger tol or max_harmonics")
        ok = [h for h, e in sorted(est["remaining"].items()) if e <= _NEXT_MARGIN * tol]
        H = min(max_harmonics, ok[0] if ok else est["fine"].H)
        guess = est["start"]
        if est["fine"].H == H and samples is None:
            res = est["fine"]


def _coefficients(start, n: int) -> Array | None:
    if start is None:
        return None
    if isinstance(start, HarmonicBalanceSolution):
        return start.coefficients
    c = np.asarray(start, float)
    if c.ndim != 2 or c.shape[1] != n or c.shape[0] % 2 != 1 or not np.all(np.isfinite(c)):
        raise InputError(f"start has shape {c.shape}: give finite coefficients (2 H + 1, {n}) or a solution")
    return c


def _pad(c: Array, H: int) -> Array:
    """Coefficients (2 H' + 1, n) padded with zeros or cut to H harmonics."""
    out = np.zeros((2 * H + 1, c.shape[1]))
    k = min(c.shape[0], 2 * H + 1)
    out[:k] = c[:k]
    return out


class HarmonicBalanceFamily:
    """A family of periodic systems in a parameter, as a residual problem of
    :func:`fivebar.numerics.continuation.continuation` (harmonic balance continued in p).

    ``fam = HarmonicBalanceFamily(lambda w: SampledSystem(System(...), 2 * pi / w), 5,
    parameter="frequency")``; ``continuation(fam, sol.x, p0, p1)``.

    Parameters
    ----------
    family
        ``p -> PeriodicSystem``.
    harmonics
        H.
    samples
        N (default :func:`samples_for`).
    parameter
        ``"frequency"``: p is the angular frequency :math:`\\Omega` of the family (period
        :math:`2\\pi/p`), and the samples of the system at the phases :math:`2\\pi k/N` do
        not depend on p (as for a forcing :math:`\\cos pt`): the derivative of the residual in
        p is analytic, :math:`\\mathbf P[\\mathbf C_k]\\boldsymbol\\Gamma\\boldsymbol\\nabla_1
        \\hat{\\mathbf u} + 2p\\,\\mathbf P[\\mathbf M_k]\\boldsymbol\\Gamma
        \\boldsymbol\\nabla_1^2\\hat{\\mathbf u}` (:math:`\\boldsymbol\\nabla =
        p\\boldsymbol\\nabla_1`).  ``"other"``: a central difference of the residual in p
        (relative step ``dp``).

    The residual is given in the units of the coefficients (scaled by the diagonal of the
    linear Jacobian at the first parameter asked, ``K_ii + (h w)^2 M_ii``), as the continuation's
    tolerances expect; the monodromy matrix (for the multipliers) is Hill's
    (:class:`HillResult`).
    """

    def __init__(self, family: Callable[[float], PeriodicSystem], harmonics: int, *, samples: int | None = None,
                 parameter: str = "frequency", dp: float = 1e-6, hill_harmonics: int | None = None) -> None:
        if not callable(family):
            raise InputTypeError(f"family = {family!r} is not allowed: give a function p -> PeriodicSystem")
        if parameter not in ("frequency", "other"):
            raise InputError(f"parameter = {parameter!r} is not allowed: use 'frequency' or 'other'")
        self.family = family
        self.H = number("harmonics", harmonics, integer=True, low=1, high=MAX_HARMONICS)
        self.N = samples_for(self.H) if samples is None else number("samples", samples, integer=True,
                                                                     low=2 * self.H + 1)
        self.parameter, self.dp = parameter, float(dp)
        self.hill_harmonics = hill_harmonics
        self._res: dict = {}
        self._scale: Array | None = None

    def _at(self, p: float) -> _Residual:
        key = 0.0 if self.parameter == "frequency" else float(p)
        if key not in self._res:
            if len(self._res) > 4:
                self._res.clear()
            self._res[key] = _Residual(self.family(float(p)), self.H, self.N)
        return self._res[key]

    def _omega(self, p: float, res: _Residual) -> float:
        return float(p) if self.parameter == "frequency" else res.omega

    def _s(self, res: _Residual, omega: float) -> Array:
        if self._scale is None:
            n, H = res.n, self.H
            h = np.repeat(np.r_[0, np.repeat(np.arange(1, H + 1), 2)], n)
            Md = np.tile(np.diag(res.M.mean(axis=0)), 2 * H + 1)
            Kd = np.tile(np.diag(res.K.mean(axis=0)), 2 * H + 1)
            s = np.abs(Kd) + (h * omega) ** 2 * np.abs(Md)
            self._scale = np.where(s > 0, s, 1.0)
        return self._scale

    def residual(self, x: Array, p: float) -> Array:
        """The scaled Galerkin residual R(x, p) (in the units of x)."""
        res = self._at(p)
        w = self._omega(p, res)
        return res.evaluate(np.asarray(x, float), w, jacobian=False)[0] / self._s(res, w)

    def jacobian(self, x: Array, p: float) -> tuple[Array, Array]:
        """(dR/dx, dR/dp) of the scaled residual."""
        res = self._at(p)
        w = self._omega(p, res)
        x = np.asarray(x, float)
        _, J, _, _ = res.evaluate(x, w)
        s = self._s(res, w)
        if self.parameter == "frequency":
            n, D1 = res.n, res.D1
            Rp = (_right(res.Ch, D1, n) + 2.0 * w * _right(res.Mh, D1 @ D1, n)) @ x
        else:
            h = self.dp * max(1.0, abs(p))
            Rp = (self.residual(x, p + h) - self.residual(x, p - h)) * s / (2 * h)
        return J / s[:, None], Rp / s

    def monodromy(self, x: Array, p: float) -> Array:
        """Hill's monodromy matrix of (u, u') at t = 0 (2 n, 2 n) at the solution x."""
        res = self._at(p)
        w = self._omega(p, res)
        _, J, _, _ = res.evaluate(np.asarray(x, float), w)
        H = self.H if self.hill_harmonics is None else min(self.H, int(self.hill_harmonics))
        return _hill(res, J, w, H).monodromy

    def solution(self, x: Array, p: float) -> HarmonicBalanceSolution:
        """The point x at p as a :class:`HarmonicBalanceSolution` (for its series and Hill)."""
        res = self._at(p)
        w = self._omega(p, res)
        x = np.asarray(x, float)
        R = res.evaluate(x, w, jacobian=False)[0]
        return HarmonicBalanceSolution(x.reshape(2 * self.H + 1, res.n).copy(), self.H, self.N, 2 * np.pi / w,
                                       float(np.linalg.norm(R)) / res.scale(x, w), 0, None, [], res)
