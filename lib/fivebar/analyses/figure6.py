r"""Reproduction of the paper's Figure 6 and how it moves with every assumption.

Figure 6 shows "the dynamic responses on the direction perpendicular to the links' axis" of the
midpoints of the couplers L2 and L3 over one steady period, computed by the
multiple-scales-Newmark method with S = 100 steps (section 5), beside a measured curve.  The
measured curve is not recoverable from the text, and the paper gives neither the crank speed
nor the other numbers listed in ``data/wang2011.toml`` under ``[assumptions]``; this module
computes the curves under those assumptions and tabulates how much each assumption moves them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from ..errors import FivebarError
from ..description.params import Params
from ..model.rigid import motor_torques
from ..description.setup import Setup, analysis, as_setup
from .branches import steady_state
from .steady import SteadyState

__all__ = ["Variant", "ASSUMPTION_VARIANTS", "assumption_effects", "speed_table"]


@dataclass(frozen=True)
class Variant:
    """One alternative to an assumption: the parameter changes and/or model switches."""

    assumption: str
    label: str
    changes: tuple[tuple[str, object], ...] = ()
    motors: bool = True

    def params(self, base: Params) -> Params:
        """The parameter set of this variant."""
        return base.replace(**dict(self.changes)) if self.changes else base

    def is_base(self, base: Params) -> bool:
        """Whether this variant is ``base`` itself (its changes are the values already chosen)."""
        return self.motors and dict(self.params(base).values) == dict(base.values)


#: The alternatives the book shows for each assumption of data/wang2011.toml that enters the
#: linkage's response (the electromagnetic ones act only on the decoupled rotor whirl).  The
#: book's own values are among them (30 mm side, 60 r/min, ...), so that a reader's parameter
#: set is compared with the book's; :func:`assumption_effects` leaves out every variant that
#: is the parameter set itself.
ASSUMPTION_VARIANTS: tuple[Variant, ...] = (
    Variant("bending_depth", "2 mm side in the plane", (("bending_depth", 0.002),)),
    Variant("bending_depth", "30 mm side in the plane", (("bending_depth", 0.030),)),
    Variant("crank_speed_rpm", "30 r/min", (("crank_speed_rpm", 30.0),)),
    Variant("crank_speed_rpm", "60 r/min", (("crank_speed_rpm", 60.0),)),
    Variant("crank_speed_rpm", "120 r/min", (("crank_speed_rpm", 120.0),)),
    Variant("speed_ratio", "crank DE at twice the speed", (("speed_ratio", 2.0),)),
    Variant("damping_ratio", "zeta = 0.01", (("damping_ratio", 0.01),)),
    Variant("damping_ratio", "zeta = 0.02", (("damping_ratio", 0.02),)),
    Variant("damping_ratio", "zeta = 0.05", (("damping_ratio", 0.05),)),
    Variant("shaft_diameter_1", "motor 1 shaft 11 mm", (("shaft_diameter_1", 0.011),)),
    Variant("shaft_diameter_1", "motor 1 shaft 14 mm", (("shaft_diameter_1", 0.014),)),
    Variant("shaft_diameter_1", "motor 1 shaft 19 mm", (("shaft_diameter_1", 0.019),)),
    Variant("shaft_diameter_2", "motor 2 shaft 14 mm", (("shaft_diameter_2", 0.014),)),
    Variant("shaft_diameter_2", "motor 2 shaft 19 mm", (("shaft_diameter_2", 0.019),)),
    Variant("shaft_diameter_2", "motor 2 shaft 24 mm", (("shaft_diameter_2", 0.024),)),
    Variant("shaft_E", "shafts rigid (crank roots clamped)", (), motors=False),
    Variant("rotary_inertia", "no rotary inertia", (("rotary_inertia", 0),)),
    Variant("gravity", "vertical plane, g = 9.81 m/s^2", (("gravity", 9.81),)),
    Variant("em_variant", "literal electromagnetic field", (("em_variant", "literal"),)),
    Variant("gap_flux_density", "gap flux density 0.9 T", (("gap_flux_density", 0.9),)),
)


def _row(res: SteadyState, couplers: tuple[str, ...]) -> dict[str, float]:
    """The couplers' transverse and bending peak-to-peak (L2, L3 of the five-bar) and the peak stress."""
    stress = res.bending_stress()
    row = {f"{k} transverse p-p (um)": 1e3 * res.peak_to_peak_mm(k) for k in couplers}
    row.update({f"{k} bending p-p (um)": 1e3 * res.peak_to_peak_mm(k, "chord") for k in couplers})
    return {**row, "peak bending stress (MPa)": max(stress.values()) / 1e6, "in link": max(stress, key=stress.get)}


def _variant(s: Setup, v: Variant) -> Setup:
    """The problem ``s`` with the variant's parameter changes (a changed crank speed included)
    and model switches."""
    p = v.params(s.run_params)
    return s.replace(params=p, crank_speed_rpm=p.crank_speed_rpm, motors=s.motors and v.motors)


@analysis
def assumption_effects(
    setup: Setup | Params,
    variants: tuple[Variant, ...] = ASSUMPTION_VARIANTS,
) -> pd.DataFrame:
    """Peak-to-peak midpoint deflections and peak bending stress, the problem and each variant.

    ``df = assumption_effects(setup)``: one row for the problem ("(defaults)") and one per
    variant that differs from it (a variant whose changes are the values already chosen is
    left out), with the change of the L2 and L3 transverse peak-to-peak deflection from the
    first row (%), 0 where it is below what the steady states resolve (1e-6 %: round-off
    of a variant that cannot move the linkage).  The steady states come from :func:`fivebar.analyses.branches.steady_state` of the
    problem (a :class:`fivebar.description.setup.Setup`, or a Params: ``Setup(params)``, the geometric
    nonlinearity and the library's default step and scheme, converged for any sensible
    parameters; the paper's S = 100 and rule fail where the deflections are large, and the
    linear model is then far off: 19.6 against 12.6 mm at 120 r/min with the 2 mm side in
    the plane), each variant's with its changes.  A variant without a periodic steady state (shooting fails, for example
    past a divergence, or the variant's linkage cannot run through the cycle) gets NaN and says so in the column ``note`` (empty otherwise).
    """
    s = as_setup(setup)
    rows = []
    couplers = s.params.linkage.couplers  # the variants change no link
    base = _row(steady_state(s), couplers)
    rows.append({"assumption": "(defaults)", "alternative": "", **base})
    for v in variants:
        if v.is_base(s.run_params):
            continue
        try:
            res = steady_state(_variant(s, v))
        except FivebarError as e:  # shooting fails, or the linkage cannot run through the cycle
            rows.append({"assumption": v.assumption, "alternative": v.label, **dict.fromkeys(base, np.nan),
                         "in link": "", "note": f"no periodic steady state found ({type(e).__name__})"})
            continue
        rows.append({"assumption": v.assumption, "alternative": v.label, **_row(res, couplers), "note": ""})
    rows[0]["note"] = ""
    df = pd.DataFrame(rows)
    for link in s.params.linkage.couplers:
        col = f"{link} transverse p-p (um)"
        df[f"{link} change (%)"] = _change_percent(df[col].to_numpy(), base[col])
    return df


#: the smallest change (%) the steady states resolve: shooting converges the state to 1e-10
#: (relative), and a variant that cannot move the linkage (the electromagnetic assumptions act
#: on the rotors only) still changes the deflections by round-off, about 1e-11 %, with a sign
#: and size that depend on which speed first sampled the set-up in the process
_RESOLVED_CHANGE_PERCENT = 1e-6


def _change_percent(values: ArrayLike, base: float) -> NDArray:
    """``100 (values / base - 1)``, with the changes below :data:`_RESOLVED_CHANGE_PERCENT` set to 0.

    >>> _change_percent([1.0 - 1.7e-13, 1.01, 0.99999], 1.0).round(6).tolist()
    [0.0, 1.0, -0.001]
    """
    c = 100.0 * (np.asarray(values, float) / base - 1.0)
    return np.where(np.abs(c) < _RESOLVED_CHANGE_PERCENT, 0.0, c)


@analysis
def speed_table(setup: Setup | Params, speeds_rpm: tuple[float, ...]) -> pd.DataFrame:
    """Deflections, peak bending stress and peak drive torques at several crank speeds.

    ``speed_table(fivebar.Setup(params, steps_per_period=100, nonlinear=False,
    scheme=fivebar.PAPER_SCHEME), (30, 60, 120))``: the steady states of the problem (a
    :class:`fivebar.description.setup.Setup` or a Params) at each speed.  The torques are the rigid-body
    inverse dynamics (:func:`fivebar.model.rigid.motor_torques`) over one period; the table sets
    them against motor 1's printed stall torque and the stress against the assumed yield
    stress.
    """
    s = as_setup(setup)
    rows = []
    for rpm in speeds_rpm:
        at = s.replace(crank_speed_rpm=rpm)
        p = at.run_params
        res = steady_state(at)
        tau = np.abs(motor_torques(p, np.linspace(0.0, p.period, 181))).max(axis=0)
        row = {"crank speed (r/min)": rpm, **_row(res, s.params.linkage.couplers)}
        row["stress / yield"] = row["peak bending stress (MPa)"] * 1e6 / p.yield_stress
        for i, torque in enumerate(tau, start=1):  # the description's cranks, in chain order
            row[f"motor {i} torque (N m)"] = torque
        motors = list(p.crank_motors.values())
        stall = motors[0].stall_torque if motors else None
        row["motor 1 torque / stall"] = tau[0] / stall if stall else np.nan
        rows.append(row)
    return pd.DataFrame(rows)
