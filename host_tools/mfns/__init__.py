"""MFNS host tools: simulation, CPC calibration, error analysis, calibration table, reports."""

# The one version string of the project: the Python package, and through mk/version.sh
# the C programs (mfns-nav, mfns-ground, mfns-tlm-gen) and the BOOT event.
__version__ = "0.1.0"
