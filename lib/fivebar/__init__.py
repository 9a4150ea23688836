"""fivebar: kineto-elastodynamics of a motor-driven flexible five-bar linkage.

A library and a Jupyter Book reproducing and extending R.-G. Wang, G.-W. Cai and X.-R. Zhou,
*An evolutionary analytic method of multi-DOF nonlinear coupling dynamic model for
controllable close-chain linkage mechanism system*, Mathematical Problems in Engineering
2011, 254547.  Equation numbers in docstrings are the paper's.

The facade below is what the chapters use; the modules hold the rest.  Units at the API: SI,
or the unit in the name (``crank_speed_rpm``, ``midpoint(...)`` in mm as its docstring says).
"""

from .control import linear_model
from .errors import FivebarError
from .elements import beam_element, motor_element
from .kinematics import GeometryError, positions
from .excitation import excitation_frequencies, load_expansion
from .modal import natural_frequencies
from .linkage_multiscale import MultipleScalesResponse, multiple_scales, multiple_scales_newmark
from .newmark import GeneralizedAlpha, HHT, Newmark, NewtonConvergenceError, UnstableParametersError, integrate
from .params import DEFAULT_PARAMS_PATH, Motor, ParameterError, Params, load_params
from .resonance import campbell_diagram, resonance_table
from .setup import PAPER_SCHEME, Setup
from .steady import SteadyState, SteadyStateError, steady_state
from .sweep import speed_sweep

__all__ = [
    "DEFAULT_PARAMS_PATH",
    "FivebarError",
    "PAPER_SCHEME",
    "Setup",
    "GeneralizedAlpha",
    "GeometryError",
    "HHT",
    "Motor",
    "MultipleScalesResponse",
    "Newmark",
    "NewtonConvergenceError",
    "ParameterError",
    "Params",
    "SteadyState",
    "SteadyStateError",
    "UnstableParametersError",
    "beam_element",
    "campbell_diagram",
    "excitation_frequencies",
    "integrate",
    "linear_model",
    "load_expansion",
    "load_params",
    "motor_element",
    "multibody_frequencies",
    "multibody_steady_state",
    "multiple_scales",
    "multiple_scales_newmark",
    "natural_frequencies",
    "positions",
    "resonance_table",
    "speed_sweep",
    "steady_state",
]
__version__ = "0.1.0"


def multibody_steady_state(params, crank_speed_rpm=None, **kwargs):
    """Periodic steady state of the fully coupled multibody model (Exudyn).

    See :func:`fivebar.multibody.multibody_steady_state`; Exudyn is imported on first use.
    """
    from .multibody import multibody_steady_state as f

    return f(params, crank_speed_rpm, **kwargs)


def multibody_frequencies(params, theta1, theta4, n=6, **kwargs):
    """Frozen natural frequencies (Hz) of the multibody model, crank roots clamped.

    See :func:`fivebar.multibody.multibody_frequencies`; Exudyn is imported on first use.
    """
    from .multibody import multibody_frequencies as f

    return f(params, theta1, theta4, n, **kwargs)
