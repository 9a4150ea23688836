r"""Natural frequencies and mode shapes of the linkage, frozen or along the cycle.

At a frozen configuration the undamped linear free vibration of (2.7) gives the generalised
symmetric eigenproblem

.. math::

    \mathbf K \boldsymbol\phi = \omega^2 \mathbf M \boldsymbol\phi ,

whose roots change as the linkage moves.  The modal transformation (3.1)-(3.3) uses the paper's
"instantaneous natural frequency mean", :func:`mean_frequencies`.  Averaging the matrices
instead (:func:`averaged_matrix_modes`) is shown in the book to fail for rotating links.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..numerics.eigen import frozen_modes
from ..errors import ComputationError, InputError, memory
from ..model.assembly import Model, build_model
from ..model.kinematics import crank_laws
from ..description.params import Params, _unresolved_model
from ..description.setup import Setup, _estimated_dofs, analysis, as_setup

__all__ = [
    "Modes",
    "modes",
    "natural_frequencies",
    "frequencies_along_cycle",
    "mean_frequencies",
    "averaged_matrix_modes",
]


@dataclass(frozen=True)
class Modes:
    """Modes of a linkage model: ``frequencies`` (Hz, ascending), ``shapes`` (n x k, columns
    mass-normalised: shapes.T @ M @ shapes = I), ``omega`` (rad/s) and the ``model``."""

    frequencies: NDArray
    shapes: NDArray
    model: Model

    @property
    def omega(self) -> NDArray:
        """Circular natural frequencies (rad/s)."""
        return 2.0 * np.pi * self.frequencies


def _eig(M: NDArray, K: NDArray, n: int | None, params: Params) -> tuple[NDArray, NDArray]:
    # Solved as M phi = mu K phi for the largest mu = 1/omega^2: the curvature DOFs make M
    # ill-conditioned (eigenvalues from 1e-10 to 1), and the usual K phi = omega^2 M phi
    # then gives the lowest frequencies only to about 1e-8 relative, varying with the BLAS
    # thread count; the inverse problem gives them to round-off.
    N = M.shape[-1]
    try:
        w2, V = frozen_modes(M, K, N if n is None else min(n, N))
    except ComputationError as exc:
        raise _unresolved_model(params, exc) from None
    return np.sqrt(w2) / (2.0 * np.pi), V


def _model(s: Setup, model: Model | None, configurations: int = 1) -> Model:
    """The problem's model; refused before it is built if ``configurations`` pairs of its dense
    M and K (and the eigensolver's work arrays) would not fit in memory."""
    if model is not None:
        return model
    epl = s.params.linkage.check_mesh(s.elements_per_link)
    n = _estimated_dofs(epl, s.motors)
    memory(8.0 * n * n * (2 * configurations + 4),
           f"the mass and stiffness matrices of about {n} DOFs (elements_per_link = {epl}) at "
           f"{configurations} configuration(s)",
           "give a coarser elements_per_link, or fewer crank angles")
    return build_model(s.params, elements_per_link=s.elements_per_link, motors=s.motors)


def _angles(s: Setup, theta: tuple) -> tuple:
    """The crank angles of a frozen configuration, one per driven crank of the description."""
    cranks = s.params.linkage.cranks
    if len(theta) != len(cranks):
        raise InputError(
            f"{len(theta)} crank angle(s) {theta!r} are not allowed: the linkage has {len(cranks)} driven "
            f"crank(s) ({', '.join(j.name for j in cranks)}), give one angle (rad) for each")
    return theta


@analysis
def modes(setup: Setup | Params, *theta: float, n_modes: int | None = 6, model: Model | None = None) -> Modes:
    """Lowest ``n_modes`` modes at one frozen configuration (crank angles in rad).

    ``modes(setup, theta1, theta4)`` for the five-bar (one angle per driven crank of the
    description: ``modes(setup, theta)`` for a four-bar); the problem's ``motors`` (False: the
    crank roots clamped, the motor elements left out) and ``elements_per_link`` choose the model
    (:class:`fivebar.description.setup.Setup`; a Params is ``Setup(params)``).  ``n_modes=None`` returns all
    modes.  Pass a prebuilt ``model`` to skip the assembly set-up.
    """
    s = as_setup(setup)
    theta = _angles(s, theta)
    m = _model(s, model)
    if n_modes is not None and n_modes > m.n:
        raise InputError(
            f"n_modes = {n_modes!r} modes is more than the model has: at most {m.n} (its DOFs; refine the mesh "
            "with the set-up's elements_per_link for more)"
        )
    M, K = m.matrices(*theta)
    f, V = _eig(M, K, n_modes, s.params)
    return Modes(f, V, m)


@analysis
def natural_frequencies(setup: Setup | Params, *theta: float, n_modes: int = 6) -> NDArray:
    """The ``n_modes`` lowest natural frequencies (Hz) at the crank angles ``theta`` (rad, one
    per driven crank, as :func:`modes`), of the problem's model (its ``motors`` and
    ``elements_per_link``)."""
    if isinstance(n_modes, bool) or int(n_modes) != n_modes or n_modes < 1:
        raise InputError(f"n_modes = {n_modes!r} is not allowed: give a positive integer number of modes")
    return modes(setup, *theta, n_modes=int(n_modes)).frequencies


@analysis
def frequencies_along_cycle(setup: Setup | Params, crank_angles: ArrayLike, n_modes: int = 6) -> NDArray:
    """Lowest ``n_modes`` natural frequencies (Hz) at the configurations of the default crank laws.

    ``crank_angles`` are the phase Omega t of the drive (rad; for the five-bar the
    angle of crank AB measured from its initial angle, crank DE following with the speed
    ratio of the parameters).  Returns shape ``(len(crank_angles), n_modes)``.  The model is the
    problem's (its ``motors`` and ``elements_per_link``).
    """
    s = as_setup(setup)
    phi = np.atleast_1d(np.asarray(crank_angles, float))
    th = crank_laws(s.params, phi / s.params.crank_speed_rad_s)[0::3]
    M, K = _model(s, None, phi.size).matrices(*th)
    return _eig(M, K, n_modes, s.params)[0]


@analysis
def mean_frequencies(setup: Setup | Params, n_modes: int = 6) -> NDArray:
    """The paper's "instantaneous natural frequency mean" (3.3): the period mean (Hz) of the
    ``n_modes`` lowest instantaneous natural frequencies, mode by mode (sorted by frequency), over
    the problem's S (``steps_per_period``) equally spaced instants of one period."""
    s = as_setup(setup)
    S = s.steps_per_period
    phi = np.arange(S) * 2.0 * np.pi / S
    return frequencies_along_cycle(s, phi, n_modes).mean(axis=0)


@analysis
def averaged_matrix_modes(setup: Setup | Params, n_modes: int | None = None, frame: str = "global") -> Modes:
    """Modes of the system whose M and K are the period means of M(t) and K(t) (over the
    problem's S instants).

    This is the other possible reading of the "mean system" of (3.1)-(3.3).  The book shows
    that it is not a useful one for this linkage: averaged in the global frame
    (``frame="global"``), each link's axial stiffness is smeared over every direction the link
    takes; in co-rotating nodal coordinates (``frame="corotating"``, see
    :meth:`Model.corotating_transform`) the pins still join links whose relative angle swings
    by tens of degrees.  Either way the frequencies come out far above every instantaneous
    one.  Use :func:`mean_frequencies` for the paper's frequency means.
    """
    s = as_setup(setup)
    if frame not in ("corotating", "global"):
        raise InputError(f"frame = {frame!r} is not allowed: use 'corotating' or 'global'")
    S, params = s.steps_per_period, s.params
    t = np.arange(S) * params.period / S
    th = crank_laws(params, t)[0::3]
    m = _model(s, None, S)
    M, K = m.matrices(*th)
    if frame == "corotating":
        T = m.corotating_transform(*th)
        Tt = np.swapaxes(T, -1, -2)
        M, K = Tt @ M @ T, Tt @ K @ T
    f, V = _eig(M.mean(axis=0), K.mean(axis=0), n_modes, params)
    return Modes(f, V, m)
