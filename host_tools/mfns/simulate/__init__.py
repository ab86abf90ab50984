"""Simulators of the two experiments: `calib` (turntable calibration) and `nav` (navigation).

Each module here that defines `register(subparsers)` becomes a subcommand of `mfns sim`.
"""
