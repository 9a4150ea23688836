"""pytest configuration for the library's unit tests."""

import matplotlib

# A headless backend for the unit tests.  It is selected here, not through the MPLBACKEND
# environment variable, because the notebook kernels that nbval starts inherit the environment
# and must keep matplotlib's inline backend to reproduce the stored figure outputs.
matplotlib.use("Agg")
