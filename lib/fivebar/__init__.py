"""fivebar: kineto-elastodynamics of a motor-driven flexible five-bar linkage.

A library and a Jupyter Book reproducing and extending R.-G. Wang, G.-W. Cai and X.-R. Zhou,
*An evolutionary analytic method of multi-DOF nonlinear coupling dynamic model for
controllable close-chain linkage mechanism system*, Mathematical Problems in Engineering
2011, 254547.  Equation numbers in docstrings are the paper's.

The facade below is what the chapters use; the modules hold the rest.
"""

from .elements import beam_element, motor_element
from .kinematics import GeometryError, positions
from .modal import natural_frequencies
from .params import DEFAULT_PARAMS_PATH, Motor, ParameterError, Params, load_params

__all__ = [
    "DEFAULT_PARAMS_PATH",
    "GeometryError",
    "Motor",
    "ParameterError",
    "Params",
    "beam_element",
    "load_params",
    "motor_element",
    "natural_frequencies",
    "positions",
]
__version__ = "0.1.0"
