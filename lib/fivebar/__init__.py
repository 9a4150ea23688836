"""fivebar: kineto-elastodynamics of a motor-driven flexible five-bar linkage.

A library and a Jupyter Book reproducing and extending R.-G. Wang, G.-W. Cai and X.-R. Zhou,
*An evolutionary analytic method of multi-DOF nonlinear coupling dynamic model for
controllable close-chain linkage mechanism system*, Mathematical Problems in Engineering
2011, 254547.  Equation numbers in docstrings are the paper's.

The facade below is what the chapters use; the modules hold the rest.  Units at the API: SI,
or the unit in the name (``crank_speed_rpm``, ``SteadyState.midpoint_mm``, ``crank_angle_deg``).
"""

# The facade is lazy (PEP 562): ``import fivebar`` loads no heavy module (scipy submodules,
# matplotlib, pandas, control, numba); a name is imported from its module on first use.
_FACADE = {
    "clear_cache": "cache",
    "linear_model": "control_model",
    "FivebarError": "errors",
    "PAPER_SCHEME": "setup", "Setup": "setup",
    "multibody_frequencies": "multibody", "multibody_steady_state": "multibody",
    "beam_element": "elements", "motor_element": "elements",
    "GeometryError": "kinematics", "positions": "kinematics",
    "excitation_frequencies": "excitation", "load_expansion": "excitation",
    "natural_frequencies": "modal",
    "MultipleScalesResponse": "linkage_multiscale", "multiple_scales": "linkage_multiscale",
    "multiple_scales_newmark": "linkage_multiscale",
    "GeneralizedAlpha": "schemes", "HHT": "schemes", "Newmark": "schemes",
    "UnstableParametersError": "schemes",
    "NewtonConvergenceError": "newmark", "integrate": "newmark",
    "DEFAULT_PARAMS_PATH": "params", "FOURBAR_PARAMS_PATH": "params", "Motor": "params", "ParameterError": "params",
    "Params": "params", "load_params": "params",
    "campbell_diagram": "resonance", "resonance_table": "resonance",
    "Response": "response", "quasi_static": "response", "radau": "response", "transient": "response",
    "SteadyState": "steady", "SteadyStateError": "steady", "ValidityWarning": "errors", "steady_state": "steady",
    "SweepInterrupted": "sweep", "speed_sweep": "sweep",
}


# Modules a chapter reaches as ``fivebar.<module>`` without importing them first.
_SUBMODULES = ("chapter",)


def __getattr__(name: str):
    import importlib

    if name in _SUBMODULES:
        value = importlib.import_module(f".{name}", __name__)
        globals()[name] = value
        return value
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

