"""The one eigensolver of frozen modes (fivebar.numerics.eigen.frozen_modes), against scipy's direct
form on well-conditioned pairs, batched against one by one, and the modal damping it builds
against its definition C phi_r = 2 zeta omega_r M phi_r."""

import numpy as np
import pytest
import scipy.linalg

from fivebar.model.dynamics import modal_damping
from fivebar.numerics.eigen import frozen_modes
from fivebar.errors import FivebarError

rng = np.random.default_rng(7)


def _spd(n, k=()):
    A = rng.standard_normal(k + (n, n))
    return A @ np.swapaxes(A, -1, -2) + n * np.eye(n)


def test_matches_the_direct_form_and_is_mass_normalised():
    M, K = _spd(6), _spd(6)
    w2, Phi = frozen_modes(M, K, 3)
    ref = scipy.linalg.eigh(K, M, eigvals_only=True)[:3]
    assert np.allclose(w2, ref, rtol=1e-12)
    assert np.allclose(Phi.T @ M @ Phi, np.eye(3), atol=1e-12)
    assert np.allclose(K @ Phi, M @ Phi * w2, atol=1e-10)


def test_batched_equals_one_by_one():
    M, K = _spd(5, (4,)), _spd(5, (4,))
    w2, Phi = frozen_modes(M, K)
    for j in range(4):
        w2j, Pj = frozen_modes(M[j], K[j])
        assert np.allclose(w2[j], w2j, rtol=1e-12)
        assert np.allclose(np.abs(np.einsum("ik,ik->k", Phi[j], M[j] @ Pj)), 1.0, atol=1e-10)


def test_modal_damping_is_diagonal_in_the_modes():
    M, K = _spd(5, (3,)), _spd(5, (3,))
    C = modal_damping(M, K, 0.02)
    w2, Phi = frozen_modes(M, K)
    CPhi = C @ Phi
    assert np.allclose(CPhi, M @ Phi * (2 * 0.02 * np.sqrt(w2))[:, None, :], atol=1e-10)


def test_bad_mode_count_names_the_limit():
    with pytest.raises(FivebarError, match=r"n = 9 .* 1\.\.4"):
        frozen_modes(np.eye(4), np.eye(4), 9)
