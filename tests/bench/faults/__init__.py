"""The fault campaign of `make faults` (issue 23): inject.py changes a copy of an `mfns sim nav`
folder or its beacon map; score.py compares a flight's telemetry with truth. The campaign itself
is tests/bench/fault_acceptance.py."""
