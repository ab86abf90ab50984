"""Error analysis and reports: Monte Carlo, NEES, the paper comparison, the ground report,
calibration results.
"""
