"""Figure 6 tables: the electromagnetic assumptions cannot move the linkage's response (the
rotor whirl is decoupled), the quasi-static speed scaling, and the drive torques."""

import numpy as np
import pytest

from fivebar import load_params
from fivebar.figure6 import ASSUMPTION_VARIANTS, Variant, assumption_effects, speed_table

P = load_params()


def test_em_assumptions_do_not_move_the_linkage_and_damping_barely_does():
    em = tuple(v for v in ASSUMPTION_VARIANTS if v.assumption in ("em_variant", "gap_flux_density"))
    damp = (Variant("damping_ratio", "zeta = 0.05", (("damping_ratio", 0.05),)),)
    df = assumption_effects(P, em + damp, steps_per_period=50)
    assert len(df) == 1 + len(em) + 1
    assert np.all(df["L2 change (%)"].iloc[1:-1] == 0.0) and np.all(df["L3 change (%)"].iloc[1:-1] == 0.0)
    # far below every natural frequency the response is quasi-static: damping hardly matters
    assert abs(df["L2 change (%)"].iloc[-1]) < 1.0


def test_speed_scaling_and_torques():
    df = speed_table(P, (30.0, 60.0), steps_per_period=50)
    # quasi-static regime: deflection and stress scale with the square of the speed
    num = df.select_dtypes("number")
    r = num.iloc[1] / num.iloc[0]
    assert r["L2 transverse p-p (um)"] == pytest.approx(4.0, rel=5e-3)
    assert r["peak bending stress (MPa)"] == pytest.approx(4.0, rel=5e-3)
    # constant crank speed: the inverse dynamics are exactly proportional to its square
    assert r["motor 1 torque (N m)"] == pytest.approx(4.0, rel=1e-9)
    assert df["motor 1 torque / stall"].iloc[1] == pytest.approx(df["motor 1 torque (N m)"].iloc[1] / 2.0)


def test_assumptions_table_reports_the_effect_of_every_assumption():
    from fivebar.reporting import assumptions_table

    df = assumptions_table(effects=True).set_index("key")
    assert df["effect on Figure 6"].str.len().min() > 0
    assert df.loc["em_variant", "effect on Figure 6"].endswith("L2 +0 %, L3 +0 %")
    assert df.loc["supply_frequency", "effect on Figure 6"].startswith("none")
    assert "120 r/min: L2 +30" in df.loc["crank_speed_rpm", "effect on Figure 6"]
