"""The Exudyn multibody model against the KED library model where KED must hold.

References: the library's frozen eigenproblem (an independent discretisation: quintic
Hermite KED elements against ANCF cables), the closed form zeta_k = beta omega_k / 2 of
Kelvin-Voigt damping, and the library's steady state at a crank speed far below the lowest
natural frequency (there the rigid-elastic coupling KED drops is negligible).
"""

import numpy as np
import pytest

pytest.importorskip("exudyn", reason="the multibody model needs exudyn (pinned in requirements-lock.txt)")

import fivebar  # noqa: E402
from fivebar.analyses import multibody  # noqa: E402
from fivebar.description.setup import Setup  # noqa: E402

MESH = (2, 4, 4, 2)


@pytest.fixture(scope="module")
def params():
    return fivebar.load_params()


@pytest.mark.parametrize("depth", [0.030, 0.002])
@pytest.mark.parametrize("angles", [(0.0, 0.0), (1.1, 4.0)])
def test_frozen_frequencies_match_library(params, depth, angles):
    p = params.replace(bending_depth=depth)
    f = fivebar.multibody_frequencies(Setup(p, elements_per_link=MESH), *angles, n_modes=6)
    # same physics (no rotary inertia in an ANCF cable), same mesh
    ref = fivebar.natural_frequencies(fivebar.Setup(p.replace(rotary_inertia=0), motors=False, elements_per_link=MESH),
                                      *angles, n_modes=6)
    np.testing.assert_allclose(f, ref, rtol=5e-3)
    # the library's defaults (paper's mesh, rotary inertia): the four lowest modes
    lib = fivebar.natural_frequencies(fivebar.Setup(p, motors=False), *angles, n_modes=4)
    np.testing.assert_allclose(f[:4], lib, rtol=5e-3)


def test_damping_matches_modal_ratio_on_lowest_mode(params):
    f = fivebar.multibody_frequencies(Setup(params, elements_per_link=MESH), 0.0, 0.0, n_modes=2)
    beta = 2 * params.damping_ratio / (2 * np.pi * f[0])
    fd, zeta = multibody.damping_ratios(Setup(params, elements_per_link=MESH), 0.0, 0.0, beta, n=2)
    assert zeta[0] == pytest.approx(params.damping_ratio, rel=1e-3)
    # Kelvin-Voigt: zeta_k = beta omega_k / 2
    assert zeta[1] == pytest.approx(params.damping_ratio * f[1] / f[0], rel=1e-2)


@pytest.mark.parametrize("gravity", [0.0, 9.81])
def test_slow_steady_state_matches_ked(params, gravity):
    params = params.replace(gravity=gravity, steps_per_period=200)
    mb = fivebar.multibody_steady_state(Setup(params, crank_speed_rpm=60.0, elements_per_link=MESH), integration_steps=200)
    ked = fivebar.steady_state(Setup(params, crank_speed_rpm=60.0, motors=False, nonlinear=False,
                                     elements_per_link=MESH, scheme=fivebar.GeneralizedAlpha(0.8)))
    assert mb.periodicity_error < 1e-3
    np.testing.assert_allclose(mb.crank_angle_deg, ked.crank_angle_deg)
    for link in ("L2", "L3"):
        for direction in ("transverse", "chord", "longitudinal"):
            y, ref = mb.midpoint_mm(link, direction), ked.midpoint_mm(link, direction)
            ptp = np.ptp(ref)
            assert mb.peak_to_peak_mm(link, direction) == pytest.approx(ptp, rel=2e-2)
            assert np.abs(y - ref).max() < 2e-2 * ptp, (link, direction)


def test_bad_input_is_named(params):
    with pytest.raises(ValueError, match="elements_per_link"):
        fivebar.multibody_frequencies(Setup(params, elements_per_link=(1, 3, 2, 1)), 0.0, 0.0)
    with pytest.raises(ValueError, match="integration_steps = 250 .*S = 100"):
        fivebar.multibody_steady_state(Setup(params, steps_per_period=100), integration_steps=250)
    with pytest.raises(ValueError, match="elements_per_link=.*is a field of the problem"):
        fivebar.multibody_frequencies(params, 0.0, 0.0, elements_per_link=MESH)
    with pytest.raises(ValueError, match="steps_per_period=.*is a field of the problem"):
        fivebar.multibody_steady_state(params, steps_per_period=400)
    with pytest.raises(ValueError, match="n_modes = 0"):
        fivebar.multibody_frequencies(params, 0.0, 0.0, n_modes=0)


def test_import_does_not_load_exudyn():
    import subprocess
    import sys

    code = "import sys, fivebar; assert 'exudyn' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)
