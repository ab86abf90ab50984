"""The imaging and pose model in numpy: camera, rotations, the reference pose solver, synthetic
observations.
"""
