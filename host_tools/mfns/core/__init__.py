"""The C core seen from Python: the ctypes binding and its header check, the flight solver wrapper,
errors, checked input reading.
"""
