"""fivebar: kineto-elastodynamics of a motor-driven flexible five-bar linkage.

A library and a Jupyter Book reproducing and extending R.-G. Wang, G.-W. Cai and X.-R. Zhou,
*An evolutionary analytic method of multi-DOF nonlinear coupling dynamic model for
controllable close-chain linkage mechanism system*, Mathematical Problems in Engineering
2011, 254547.  Equation numbers in docstrings are the paper's.

The facade below is what the chapters use; the modules hold the rest, in subpackages by layer,
each importing only the layers below it: ``numerics`` (generic solvers), ``description`` (the
parameters, the linkage, a set-up), ``model`` (the linkage's equations), ``analyses`` and
``book`` (what the chapters use to show results); ``errors`` and ``cache`` at the root.  Units at
the API: SI, or the unit in the name (``crank_speed_rpm``, ``SteadyState.midpoint_mm``,
``crank_angle_deg``).
"""

# The facade is lazy (PEP 562): ``import fivebar`` loads no heavy module (scipy submodules,
# matplotlib, pandas, control, numba); a name is imported from its module on first use.
_FACADE = {
    "clear_cache": "cache",
    "linear_model": "analyses.control.control_model",
    "FivebarError": "errors",
    "PAPER_SCHEME": "description.setup", "Setup": "description.setup",
    "multibody_frequencies": "analyses.multibody", "multibody_steady_state": "analyses.multibody",
    "beam_element": "model.elements", "motor_element": "model.elements",
    "GeometryError": "model.kinematics", "positions": "model.kinematics",
    "excitation_frequencies": "model.excitation", "load_expansion": "model.excitation",
    "natural_frequencies": "analyses.modal",
    "MultipleScalesResponse": "analyses.linkage_multiscale", "multiple_scales": "analyses.linkage_multiscale",
    "multiple_scales_newmark": "analyses.linkage_multiscale",
    "GeneralizedAlpha": "numerics.schemes", "HHT": "numerics.schemes", "Newmark": "numerics.schemes",
    "UnstableParametersError": "numerics.schemes",
    "NewtonConvergenceError": "numerics.newmark", "integrate": "numerics.newmark",
    "DEFAULT_PARAMS_PATH": "description.params", "FOURBAR_PARAMS_PATH": "description.params",
    "SIXBAR_PARAMS_PATH": "description.params", "SLIDER_CRANK_PARAMS_PATH": "description.params",
    "Motor": "description.params", "ParameterError": "description.params",
    "Params": "description.params", "load_params": "description.params",
    "campbell_diagram": "book.plotting", "resonance_table": "analyses.resonance",
    "Response": "analyses.response", "quasi_static": "analyses.response", "radau": "analyses.response",
    "transient": "analyses.response",
    "SteadyState": "analyses.steady", "SteadyStateError": "analyses.steady", "ValidityWarning": "errors",
    "steady_state": "analyses.branches",
    "SweepInterrupted": "analyses.sweep", "speed_sweep": "analyses.sweep",
}


def __getattr__(name: str):
    import importlib

    module = _FACADE.get(name)
    if module is None:
        raise AttributeError(f"module 'fivebar' has no attribute {name!r}")

    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_FACADE))


__all__ = [
    "DEFAULT_PARAMS_PATH",
    "FOURBAR_PARAMS_PATH",
    "SIXBAR_PARAMS_PATH",
    "SLIDER_CRANK_PARAMS_PATH",
    "FivebarError",
    "PAPER_SCHEME",
    "Setup",
    "SweepInterrupted",
    "ValidityWarning",
    "GeneralizedAlpha",
    "GeometryError",
    "HHT",
    "Motor",
    "MultipleScalesResponse",
    "Newmark",
    "NewtonConvergenceError",
    "ParameterError",
    "Params",
    "Response",
    "SteadyState",
    "SteadyStateError",
    "UnstableParametersError",
    "beam_element",
    "campbell_diagram",
    "clear_cache",
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
    "quasi_static",
    "radau",
    "resonance_table",
    "speed_sweep",
    "steady_state",
    "transient",
]
__version__ = "0.1.0"

