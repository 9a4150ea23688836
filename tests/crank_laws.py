"""Non-uniform crank laws with analytic derivatives, shared by the tests of the kinematics, the
rigid dynamics and the control model (pytest puts tests/ on sys.path)."""

import numpy as np


def general_laws(t):
    """(theta1, omega1, alpha1, theta4, omega4, alpha4) of a non-uniform motion at times t."""
    th1 = 0.3 + 5.0 * t + 0.7 * np.sin(3.0 * t)
    w1 = 5.0 + 2.1 * np.cos(3.0 * t)
    a1 = -6.3 * np.sin(3.0 * t)
    th4 = -1.1 + 3.0 * t + 0.5 * np.cos(2.0 * t)
    w4 = 3.0 - 1.0 * np.sin(2.0 * t)
    a4 = -2.0 * np.cos(2.0 * t)
    return th1, w1, a1, th4, w4, a4
