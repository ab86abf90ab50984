"""MFNS host tools: simulation, CPC calibration, error analysis, calibration table, reports."""

__version__ = "0.1.0"
